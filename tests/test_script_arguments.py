#!/usr/bin/env python3
"""The README's two commands and the scripts they call refuse what they do not take with one line and exit 2,
before any work. Each runs from a copy in a scratch folder, so that one that stopped refusing fails there at
once (its next steps are not beside it) instead of starting a build or a test run.

Usage: test_script_arguments.py SCRIPTS_DIR WORK_DIR"""
import shutil
import subprocess
import sys
from pathlib import Path

CASES = [("run_main.sh", ["--bogus"], "no arguments taken"), ("run_tests.sh", ["all"], "no arguments taken"),
         ("fuzz.sh", ["--bogus"], "SECONDS must be"), ("fuzz.sh", ["0"], "SECONDS must be"),
         ("fuzz.sh", ["10", "no_such_target"], "unknown target"), ("fuzz.sh", ["--replay", "pcdx"], "unknown target"),
         ("install_deps.sh", ["--yes"], "not a package name"), ("test_aarch64.sh", ["--clean"], "not a build folder"),
         ("test_aarch64.sh", ["a", "b"], "one build folder at most")]


def main(scripts, work):
    shutil.rmtree(work, ignore_errors=True)
    (work / "scripts").mkdir(parents=True)
    failures = []
    for script, args, message in CASES:
        copy = work / "scripts" / script
        shutil.copy2(scripts / script, copy)
        proc = subprocess.run([str(copy), *args], capture_output=True, text=True, timeout=60, cwd=work)
        lines = proc.stderr.strip().splitlines()
        if proc.returncode != 2 or len(lines) != 1 or message not in lines[0] or proc.stdout:
            failures.append(f"{script} {' '.join(args)}: exit {proc.returncode}, stderr {proc.stderr[-500:]!r}")
    for failure in failures:
        print("FAIL:", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
