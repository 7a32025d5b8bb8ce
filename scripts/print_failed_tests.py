#!/usr/bin/env python3
"""Prints the end of each failed test's output from a ctest run, so that it lands at the end of a long log."""
import re
import sys
from pathlib import Path

LINES = 40


def main(build_dir):
    temporary = Path(build_dir) / "Testing" / "Temporary"
    failed = temporary / "LastTestsFailed.log"
    if not failed.exists():
        return
    numbers = {line.split(":", 1)[0] for line in failed.read_text(errors="replace").splitlines() if ":" in line}
    log = (temporary / "LastTest.log").read_text(errors="replace")
    for section in re.split(r"\n(?=\d+/\d+ Testing: )", log):
        head = re.match(r"(\d+)/\d+ Testing: (.*)", section)
        if not head or head.group(1) not in numbers:
            continue
        output = section.split("Output:\n", 1)[-1].split("<end of output>", 1)[0].splitlines()
        print(f"=== output of failed test {head.group(1)}: {head.group(2)[:120]} (last {LINES} lines)")
        print("\n".join(output[-LINES:]))


if __name__ == "__main__":
    main(sys.argv[1])
