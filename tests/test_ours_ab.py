#!/usr/bin/env python3
"""scripts/ours_ab.sh: a folder and a git revision of ours/ as the two sides give a row per cell and a summary;
a side whose answers differ (a copy of ours/include whose k-d tree stops a search early) exits 1 naming the
cell and the query; --cxx-b compiles side B, and only B, with the compiler given (a wrapper that leaves a mark);
bad input (no such revision, a folder without ours/include, a side that does not compile, an unknown pair or tree,
no rounds, no such compiler) exits 2 with one line.

Usage: test_ours_ab.py OURS_AB_SH OURS_AB SOURCE_DIR WORK_DIR. Never a timing: the ratios are only checked to add
up. The sides are compiled at -O0 (the quickest compile; the script's default is the Release flags)."""
import pathlib
import re
import shutil
import subprocess
import sys

FAST = ["--cxxflags", "-O0"]
CELL = ["--pairs", "fig3", "--dists", "0.1", "--rounds", "1"]
# Sabotage: a query in the previous query's leaf stops after that leaf even when its ball crosses the cell's wall.
EARLY_STOP = ("if (wall * wall * shrink_ > collect.bound()) return true;", "return true;")


def run(script, binary, *args):
    return subprocess.run([script, "--bin", binary, *FAST, *args], capture_output=True, text=True, timeout=280)


def check_rows(out, failures, what):
    rows = re.findall(r"^fig3 +generated +(kdtree|octree) +0\.10 \| +([0-9.]+) +([0-9.]+) \| ([0-9.]+)$", out, re.M)
    if sorted(r[0] for r in rows) != ["kdtree", "octree"]:
        failures.append(f"{what}: rows {rows}, expected one a tree:\n{out}")
    for tree, a, b, ratio in rows:
        if not (float(a) > 0 and float(b) > 0 and abs(float(ratio) - float(b) / float(a)) < 0.002):
            failures.append(f"{what} {tree}: A {a}, B {b}, B/A {ratio} do not add up")
    if not re.search(r"^B/A over 2 cells: .*every answer equal\)$", out, re.M):
        failures.append(f"{what}: no summary line:\n{out}")
    for line in ("# A: ", "# B: ", "# load before: ", "# load after: "):
        if not re.search(rf"^{re.escape(line)}\S", out, re.M):
            failures.append(f"{what}: no header line '{line}...'")


def one_line_refusal(proc, failures, what, expected):
    lines = proc.stderr.strip().splitlines()
    if proc.returncode != 2 or len(lines) != 1 or expected not in lines[0]:
        failures.append(f"{what}: exit {proc.returncode}, stderr {proc.stderr!r}, expected one line with {expected!r}")


def copy_of_ours(source, folder, edit=None):
    include = folder / "ours" / "include"
    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(source / "ours" / "include", include)
    if edit:
        path = include / "ours" / "kdtree.hpp"
        text = path.read_text()
        if edit[0] not in text:
            raise SystemExit(f"kdtree.hpp no longer has {edit[0]!r}: update the sabotage of this test")
        path.write_text(text.replace(edit[0], edit[1]))
    return folder


def main(script, binary, source, work):
    source, work = pathlib.Path(source), pathlib.Path(work)
    work.mkdir(parents=True, exist_ok=True)
    failures = []
    proc = run(script, binary, str(source), "HEAD", *CELL)
    if proc.returncode != 0:
        failures.append(f"folder against HEAD: exit {proc.returncode}: {proc.stderr[-800:]}")
    check_rows(proc.stdout, failures, "folder against HEAD")
    if not re.search(r"^# B: [0-9a-f]{7,} \(HEAD\); compiler: \S", proc.stdout, re.M):
        failures.append(f"the revision side is not named by its commit and compiler:\n{proc.stdout}")

    marks = work / "compiled_by_wrapper"
    marks.unlink(missing_ok=True)
    wrapper = work / "cxx_wrapper"
    wrapper.write_text(f'#!/bin/sh\n[ "$1" = --version ] && {{ echo "wrapper of c++"; exit 0; }}\n'
                       f'echo side >> "{marks}"\nexec c++ "$@"\n')
    wrapper.chmod(0o755)
    proc = run(script, binary, "--cxx-b", str(wrapper), str(source), "HEAD", *CELL)
    check_rows(proc.stdout, failures, "--cxx-b")
    if not re.search(r"^# B: .*; compiler: wrapper of c\+\+$", proc.stdout, re.M):
        failures.append(f"--cxx-b: side B's compiler not named:\n{proc.stdout}")
    if not marks.exists() or marks.read_text().split() != ["side"]:
        failures.append(f"--cxx-b: the wrapper compiled {marks.read_text().split() if marks.exists() else []}, "
                        "expected side B alone")

    bad = copy_of_ours(source, work / "early_stop", EARLY_STOP)
    proc = run(script, binary, str(source), str(bad), *CELL, "--trees", "kdtree")
    if proc.returncode != 1 or not re.search(r"fig3 generated kdtree 0\.10 m: B's answers are not A's, query \d+",
                                             proc.stderr):
        failures.append(f"a side stopping early: exit {proc.returncode}, stderr {proc.stderr[-800:]!r}")

    broken = copy_of_ours(source, work / "broken")
    with open(broken / "ours" / "include" / "ours" / "kdtree.hpp", "a") as f:
        f.write("\nthis is not C++;\n")
    empty = work / "empty"
    empty.mkdir(exist_ok=True)
    one_line_refusal(run(script, binary, str(source), "no-such-revision-here", *CELL), failures, "no such revision",
                     "neither a folder nor a revision")
    one_line_refusal(run(script, binary, str(source), str(empty), *CELL), failures, "a folder without ours/",
                     "holds no ours/include")
    one_line_refusal(run(script, binary, str(source), str(broken), *CELL), failures, "a side that does not compile",
                     "does not compile")
    for args, expected in ((["--pairs", "nope"], "unknown pair 'nope'"), (["--trees", "quad"], "unknown tree"),
                           (["--rounds", "0"], "--rounds")):
        one_line_refusal(run(script, binary, str(source), str(source), *args), failures, " ".join(args), expected)
    one_line_refusal(run(script, binary, "--cxx-a", "/no/such/c++", str(source), str(source), *CELL), failures,
                     "no such compiler", "no compiler '/no/such/c++'")
    one_line_refusal(subprocess.run([script, "--bin", "/no/such/ours_ab", str(source), str(source)],
                                    capture_output=True, text=True), failures, "no driver", "no executable")
    for f in failures:
        print("FAIL:", f)
    print(f"{'FAILED' if failures else 'ok'}: ours_ab.sh")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:5]))
