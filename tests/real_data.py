"""The real scans for the Python tests, found as default_data_dir() finds them (datasets/catalog.hpp).

Missing data skips a test (ctest: exit code 77, SKIP_RETURN_CODE); NNB_REQUIRE_REAL_DATA=1, as in CI, fails it.
"""
import json
import os
from pathlib import Path

SOURCE = Path(__file__).resolve().parent.parent
SKIP_RETURN_CODE = 77
MISSING = "real scans not found: run scripts/fetch_data.sh"


def data_dir():
    env = os.environ.get("NNB_DATA_DIR")
    if env:
        return Path(env)
    fetched = SOURCE / "data" / "real"
    for candidate in (fetched, SOURCE.parent / "shared" / "datasets" / "real"):
        if candidate.is_dir():
            return candidate
    return fetched


def present():
    """Every pair's model and query scan is in data_dir()."""
    manifest = os.environ.get("NNB_MANIFEST") or SOURCE / "datasets" / "manifest.json"
    with open(manifest) as f:
        pairs = json.load(f)["pairs"]
    return all((data_dir() / p["folder"] / p[role]["file"]).is_file() for p in pairs for role in ("model", "query"))


def required():
    return os.environ.get("NNB_REQUIRE_REAL_DATA", "") not in ("", "0")


def skip_unless_present(test_case):
    """In a unittest test: skip (or fail, when required) without the real scans."""
    if present():
        return
    if required():
        test_case.fail(f"{MISSING} (looked in {data_dir()}; NNB_REQUIRE_REAL_DATA is set)")
    test_case.skipTest(MISSING)


def exit_code(result):
    """unittest result -> process exit code: 1 on a failure, 77 if a test was skipped for want of real scans."""
    if not result.wasSuccessful():
        return 1
    return SKIP_RETURN_CODE if any(reason == MISSING for _, reason in result.skipped) else 0
