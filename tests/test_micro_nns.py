#!/usr/bin/env python3
"""micro_nns on part of its benchmarks: every target it ran is judged PASS or MISS, the rest "not run"; its
results file is written whole or not at all.

Usage: test_micro_nns.py MICRO_NNS. Never a timing: the verdicts themselves may go either way."""
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

import real_data

FILTER = ("^(IcpStep/fig3|Build/fig3/(ours_kdtree|ours_octree|nanoflann_kdtree)"
          "|Ranged1NN/fig3/(ours_kdtree|ours_octree|nanoflann_kdtree)/0.10(/threads:2/real_time)?"
          "|Icp/office-sick-3dtk/(ours_kdtree|nanoflann_kdtree))$")
VERDICT = r"(PASS|MISS)"


def check_results_file(micro_nns, out_json, failures):
    """--benchmark_out is written whole or not at all: an interrupted run leaves the earlier file as it was,
    the next run clears its temporary; a path that cannot be written is refused before any work."""
    folder = os.path.dirname(out_json)
    before = open(out_json, "rb").read()
    run = subprocess.Popen([micro_nns, "--benchmark_filter=^Ranged1NN/fig3/", f"--benchmark_out={out_json}"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    temporary = os.path.join(folder, f".micro.json.tmp.{run.pid}")
    deadline = time.monotonic() + 120
    while not os.path.exists(temporary) and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    if not os.path.exists(temporary):
        failures.append(f"no temporary {temporary} while the run wrote (exit {run.poll()})")
    run.send_signal(signal.SIGINT)
    run.wait(timeout=60)
    if open(out_json, "rb").read() != before:
        failures.append("an interrupted run changed the earlier results file")
    again = subprocess.run([micro_nns, "--benchmark_filter=^Build/fig3/ours_kdtree$", "--benchmark_min_time=0.01",
                            f"--benchmark_out={out_json}"], capture_output=True, text=True, timeout=120)
    names = [b["name"] for b in json.load(open(out_json))["benchmarks"]] if again.returncode == 0 else []
    if names != ["Build/fig3/ours_kdtree"]:
        failures.append(f"the run after it: exit {again.returncode}, benchmarks {names}")
    if sorted(os.listdir(folder)) != ["micro.json"]:
        failures.append(f"left beside the results file: {sorted(os.listdir(folder))}")
    bad = subprocess.run([micro_nns, f"--benchmark_out={folder}"], capture_output=True, text=True, timeout=60)
    if bad.returncode != 2 or len(bad.stderr.strip().splitlines()) != 1:
        failures.append(f"--benchmark_out=FOLDER: exit {bad.returncode}, stderr {bad.stderr!r}")


def main(micro_nns):
    out_json = os.path.join(tempfile.mkdtemp(), "micro.json")
    proc = subprocess.run([micro_nns, "--benchmark_min_time=0.01", f"--benchmark_filter={FILTER}",
                           f"--benchmark_out={out_json}", "--benchmark_out_format=json"],
                          capture_output=True, text=True, timeout=280)
    out = proc.stdout
    failures = []
    context = json.load(open(out_json))["context"] if os.path.exists(out_json) else {}
    if "git_commit" not in context or "micro_nns" not in context.get("command_line", ""):
        failures.append(f"the results file's context lacks the commit or the command line: {context}")
    if proc.returncode != 0:
        failures.append(f"exit {proc.returncode}: {proc.stderr[-500:]}")
    # The ranged row: both targets judged (2x the faster nanoflann; under 100 ns at 0.1 m on fig3).
    if not re.search(rf"^fig3 +0\.10 \|.*x >= 2 {VERDICT} +\| [0-9.]+ ns < 100 {VERDICT}$", out, re.M):
        failures.append("the fig3 0.10 m row does not judge both ranged targets")
    if not re.search(rf"^fig3 +0\.02 \|.*\| not run +\| not run$", out, re.M):
        failures.append("a distance that did not run is not marked 'not run'")
    # The threads row: ours' speed-up from 1 to 2 threads judged, the anchor's shown.
    if not re.search(rf"^fig3 +0\.10 +2 \| +[0-9.]+ +[0-9.]+ +[0-9.]+ .*x >= 1.8 {VERDICT}$", out, re.M):
        failures.append("the fig3 0.10 m row on 2 threads does not judge the threads target")
    if not re.search(r"^fig3 +0\.02 +2 \| +- +- +- +- \| not run$", out, re.M):
        failures.append("a thread count that did not run is not marked 'not run'")
    if not re.search(rf"^fig3 +[0-9.]+ ns < 10 {VERDICT}$", out, re.M):
        failures.append("the ICP step on fig3 is not judged")
    if not re.search(rf"^fig3 +\|.*\| [0-9.]+x >= 2 {VERDICT} +\| [0-9.]+x >= 2 {VERDICT}$", out, re.M):
        failures.append("the fig3 builds of the k-d tree and the octree are not judged each")
    # The ICP target on a real pair: judged when the scans are there, "not run" (the benchmark skipped) without.
    icp_judged = re.search(rf"^office-sick-3dtk +\| +[0-9.]+ +- +\| +[0-9.]+ +- +\| [0-9.]+x >= 2.5 {VERDICT}$", out, re.M)
    if real_data.present() or real_data.required():
        if not icp_judged:
            failures.append("ICP on the SICK pair is not judged against the 2.5x target")
    elif not re.search(r"^office-sick-3dtk +\| +- +- +\| +- +- +\| not run$", out, re.M):
        failures.append("ICP on the SICK pair without its scans is not marked 'not run'")
    if not re.search(r"^office-kinect-pcl +\| +- +- +\| +- +- +\| not run$", out, re.M):
        failures.append("ICP on a pair that did not run is not marked 'not run'")
    summary = re.search(r"^Targets: (\d+) PASS, (\d+) MISS, (\d+) not run$", out, re.M)
    expected = 7 if icp_judged else 6
    if not summary:
        failures.append("no summary line")
    elif int(summary[1]) + int(summary[2]) != expected:
        failures.append(f"expected {expected} targets judged, got {summary[0]}")
    # a --data-dir that is not a folder would leave every real pair "not run" with exit 0: refused at once
    for args in (["--threads", "0"], ["--data-dir", "/nonexistent/nnb-real-scans"]):
        bad = subprocess.run([micro_nns, *args], capture_output=True, text=True, timeout=60)
        if bad.returncode != 2 or len(bad.stderr.strip().splitlines()) != 1:
            failures.append(f"{' '.join(args)}: exit {bad.returncode}, stderr {bad.stderr!r}")
    check_results_file(micro_nns, out_json, failures)
    for f in failures:
        print("FAIL:", f)
    if failures:
        print(out[-3000:])
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
