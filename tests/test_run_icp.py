#!/usr/bin/env python3
"""run_icp end to end on a tiny synthetic pair: test_run_icp.py RUN_ICP WORKDIR.

The results file has Google Benchmark's layout, the same machine and build context as run_sweep's (one writer
for both), records with the fields plots/ reads; bad input exits 2 and writes nothing.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

RUN_ICP, WORK = sys.argv[1], Path(sys.argv[2])
# run_sweep's machine and build fields (tests/test_run_sweep.py checks the same ones there).
CONTEXT = ["date", "host_name", "executable", "num_cpus", "mhz_per_cpu", "cpu_scaling_enabled", "caches", "load_avg",
           "library_build_type", "compiler", "flags", "build_type", "ndebug", "sanitizers", "git_commit",
           "nnb_build_type", "experiment", "data_dir", "git_dirty", "command_line", "wall_seconds", "load_avg_after"]
RECORD = ["name", "pair", "adapter", "icp_seconds", "build_seconds", "nns_seconds", "estimate_seconds",
          "iterations", "converged", "rms_m", "final_pose"]


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def run(args):
    return subprocess.run([RUN_ICP] + args, capture_output=True, text=True, timeout=300)


WORK.mkdir(parents=True, exist_ok=True)
out = WORK / "icp.json"
out.unlink(missing_ok=True)
tiny = ["--model", "hollow_sphere", "--query", "hollow_sphere", "--points", "500", "--iterations", "5"]
proc = run(["--adapter", "ours_kdtree", "--out", str(out)] + tiny)
if proc.returncode != 0:
    fail(f"run_icp exited {proc.returncode}: {proc.stderr[-2000:]}")
doc = json.loads(out.read_text())
context = doc.get("context", {})
for field in CONTEXT:
    if field not in context:
        fail(f"context field '{field}' missing")
# Provenance of the run itself: how it was started, how long it ran, whether the tree was modified.
if not (isinstance(context["git_dirty"], bool) and "--adapter" in context["command_line"]
        and isinstance(context["wall_seconds"], (int, float)) and context["wall_seconds"] >= 0
        and isinstance(context["load_avg_after"], list)):
    fail(f"run provenance: {context['git_dirty']!r} {context['command_line']!r} {context['wall_seconds']!r}")
# What the machine exposes, which may be nothing (virtual machines without /sys cache entries).
if not isinstance(context["caches"], list):
    fail(f"context.caches is not a list: {context['caches']!r}")
if not all({"type", "level", "size", "num_sharing"} <= set(c) for c in context["caches"]):
    fail(f"a cache entry lacks a field: {context['caches']}")
records = doc.get("benchmarks", [])
if len(records) != 1:
    fail(f"{len(records)} records, expected 1")
for field in RECORD:
    if field not in records[0]:
        fail(f"record field '{field}' missing")
if records[0]["adapter"] != "ours_kdtree" or len(records[0]["final_pose"]) != 4:
    fail(f"record: {records[0]}")

# Bad input: one clear line, exit 2, no file.
for bad in (["--adapter", "no_such_adapter"], ["--adapter", "ours_kdtree", "--max-dist", "-1"],
            ["--adapter", "ours_kdtree", "--param", "bucket_size=0"]):
    bad_out = WORK / "bad.json"
    bad_out.unlink(missing_ok=True)
    proc = run(bad + ["--out", str(bad_out)] + tiny)
    if proc.returncode != 2:
        fail(f"{bad}: exited {proc.returncode}, expected 2")
    if "error" not in proc.stderr or bad_out.exists():
        fail(f"{bad}: no error line, or a file was written: {proc.stderr!r}")
# Command-line errors are CLI11's but exit 2 with one line, like every other error.
for bad in (["--iterations", "abc"], ["--no-such-option"], ["--max-dist"]):
    proc = run(bad)
    lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
    if proc.returncode != 2 or len(lines) != 1 or not lines[0].startswith("run_icp: error: "):
        fail(f"{bad}: exit {proc.returncode}, stderr {proc.stderr!r}")

# Experiment files with values that would run nothing are refused before any run, not skipped run by run.
for label, icp in (("zero_dist", {"max_dist_m": 0}), ("negative_iterations", {"iterations": -1}),
                   ("negative_stride", {"query_stride": -1}), ("fractional_iterations", {"iterations": 2.5})):
    experiment = WORK / f"{label}.json"
    experiment.write_text(json.dumps({"name": label, "pairs": ["office-sick-3dtk"], "adapters": ["brute_force"],
                                      "icp": icp}))
    bad_out = WORK / f"{label}_out.json"
    proc = run(["--experiment", str(experiment), "--out", str(bad_out)])
    if proc.returncode != 2 or "error" not in proc.stderr or bad_out.exists():
        fail(f"experiment {icp}: exit {proc.returncode}, stderr {proc.stderr!r}")

# The output is never one of the inputs.
cloud = WORK / "cloud.xyz"
cloud.write_text("".join(f"{i * 0.01} {i * 0.013} {(i % 7) * 0.02}\n" for i in range(100)))
before = cloud.read_bytes()
proc = run(["--adapter", "brute_force", "--model", str(cloud), "--query", str(cloud), "--out", str(cloud)])
if proc.returncode != 2 or cloud.read_bytes() != before:
    fail(f"--out = --model: exit {proc.returncode}, file changed: {cloud.read_bytes() != before}")

# A machine that exposes no /sys or /proc facts (as some virtual machines): the run still succeeds and the
# context says what it could not read, with the fields present and of their types.
bare = WORK / "bare_machine"
bare.mkdir(exist_ok=True)
out.unlink(missing_ok=True)
proc = subprocess.run([RUN_ICP, "--adapter", "ours_kdtree", "--out", str(out)] + tiny, capture_output=True,
                      text=True, timeout=300, env=dict(os.environ, NNB_MACHINE_ROOT=str(bare)))
if proc.returncode != 0:
    fail(f"run_icp on a bare machine exited {proc.returncode}: {proc.stderr[-2000:]}")
context = json.loads(out.read_text())["context"]
if context["caches"] != [] or not isinstance(context["mhz_per_cpu"], (int, float)):
    fail(f"bare machine context: caches {context['caches']!r}, mhz_per_cpu {context['mhz_per_cpu']!r}")
print("run_icp: ok")
