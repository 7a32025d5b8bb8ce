#!/usr/bin/env python3
"""Opens plots/report.py's page in headless Chromium: every plot rendered, no script error, a screenshot kept.

Usage: test_report_chromium.py OUT_DIR [RESULTS...] (default: fixture results). Exit 77 without chromium."""
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "plots"))
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def chromium(args, profile):
    cmd = [shutil.which("chromium"), *FLAGS, f"--user-data-dir={profile}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def main():
    if not shutil.which("chromium"):
        print("chromium not installed (scripts/install_deps.sh installs it): skipped")
        return 77
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    results = [Path(p) for p in sys.argv[2:]]
    if not results:
        import fixtures
        results = fixtures.write_all(out) + [fixtures.approx_file(out / "approx.json"),
                                             fixtures.write(out / "scale.json", "scale", fixtures.scale_records())]
    made = subprocess.run([sys.executable, str(ROOT / "plots" / "report.py"), *map(str, results), "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    if made.returncode != 0:
        print(made.stderr)
        return 1
    page = out / "report.html"
    plots = page.read_text().count("<div class=plot ")
    with tempfile.TemporaryDirectory() as profile:
        dom = chromium(["--virtual-time-budget=60000", "--dump-dom", page.as_uri()], profile).stdout
    with tempfile.TemporaryDirectory() as profile:
        chromium(["--window-size=1400,2400", "--virtual-time-budget=60000", f"--screenshot={out / 'report.png'}",
                  page.as_uri()], profile)
    done = re.search(r'data-plots-done="(\d+)"', dom)
    errors = re.search(r'<pre id="errors">(.*?)</pre>', dom, re.S)
    failures = []
    if plots == 0:
        failures.append("the page has no plots")
    if not done or int(done.group(1)) != plots:
        failures.append(f"plots rendered: {done.group(1) if done else 'none'} of {plots}")
    svgs = dom.count('class="main-svg"')
    if svgs < plots:
        failures.append(f"only {svgs} plot SVGs in the DOM for {plots} plots")
    if errors is None or errors.group(1).strip():
        failures.append("script errors: " + (errors.group(1).strip() if errors else "no #errors element in the DOM"))
    if not (out / "report.png").is_file():
        failures.append("no screenshot")
    for f in failures:
        print("FAIL:", f)
    print(f"{plots} plots, screenshot {out / 'report.png'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
