#!/usr/bin/env python3
"""Whether a compiler flag changes the code: compiles each translation unit of a build (its
compile_commands.json) under the given source folders as configured and again with FLAG added, and
compares the two objects' instructions (objdump -d without raw bytes, after the file header).

Usage: scripts/same_code.py BUILD_DIR FLAG FOLDER [FOLDER ...]
  e.g. scripts/same_code.py build/release -ffp-contract=off adapters/ bench/
Prints 'same' or 'DIFF' a translation unit, then the count; exits 1 if any differs."""
import hashlib
import json
import os
import shlex
import subprocess
import sys
import tempfile


def instructions(command, directory, out_path, extra_flags=()):
    args = shlex.split(command)
    at = args.index("-o")
    subprocess.run(args[:at] + list(extra_flags) + ["-o", out_path] + args[at + 2:], cwd=directory, check=True)
    listing = subprocess.run(["objdump", "-d", "--no-show-raw-insn", out_path],
                             capture_output=True, text=True, check=True).stdout
    return hashlib.sha256(listing.split("\n", 3)[3].encode()).hexdigest()


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    build, flag, folders = sys.argv[1], sys.argv[2], sys.argv[3:]
    commands = json.load(open(os.path.join(build, "compile_commands.json")))
    with open(os.path.join(build, "CMakeCache.txt")) as cache:
        source_root = next(line.split("=", 1)[1].strip() for line in cache if line.startswith("CMAKE_HOME_DIRECTORY:"))
    seen, differing = set(), 0
    with tempfile.TemporaryDirectory() as scratch:
        out_path = os.path.join(scratch, "unit.o")
        for entry in commands:
            unit = os.path.relpath(entry["file"], source_root)
            if unit in seen or not any(unit.startswith(folder) for folder in folders):
                continue
            seen.add(unit)
            plain = instructions(entry["command"], entry["directory"], out_path)
            flagged = instructions(entry["command"], entry["directory"], out_path, [flag])
            differing += plain != flagged
            print("same" if plain == flagged else "DIFF", unit, flush=True)
    print(f"translation units: {len(seen)} differing: {differing}")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
