#!/usr/bin/env python3
"""scripts/reference_run.sh with stand-in programs: test_reference_run.py REFERENCE_RUN_SH WORKDIR.

The stand-ins (run_sweep, run_icp, nns_query, micro_nns) record their arguments and write their --out file,
so the script's order, resumption, refusals and installation are checked in seconds, without a build.
"""
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

SCRIPT, WORK = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
STEPS = ["micro_nns", "registry", "checks", "quick", "scale", "icp_accuracy", "real_pairs", "icp_hints", "icp_no_hints",
         "icp_track", "icp_bucket", "icp_real", "paper_grid", "paper_grid_spatialindex", "real"]

STAND_IN = r'''#!/usr/bin/env python3
import json, os, sys, time
name = os.path.basename(sys.argv[0])
args = sys.argv[1:]
if args[:1] == ["--version"]:  # not recorded: the script asks before any step
    print(name + " 0.1 (git " + os.environ.get("STAMP", "") + ", Release)")
    sys.exit(0)
with open(os.environ["CALLS"], "a") as f:
    f.write(name + " " + " ".join(args) + "\n")
if name == "micro_nns":  # the noise probe and the micro_nns step: NOISE's spread, 1.05 unless set
    out = [a.split("=", 1)[1] for a in args if a.startswith("--benchmark_out=")][0]
    spread = float(os.environ.get("NOISE", "1.05"))
    runs = [{"run_name": b, "run_type": "iteration", "cpu_time": 2.0 * (spread if r == 3 else 1.0)}
            for b in ("probe/a", "probe/b") for r in range(7)]
    open(out, "w").write(json.dumps({"benchmarks": runs}))
    sys.exit(0)
if args[:1] == ["--list"]:
    print("brute_force\tx\nours_kdtree\tx\nspatialindex_rstar\tx\nspatialindex_quadratic\tx\nnanoflann_kdtree\tx")
    sys.exit(0)
out = [a.split("=", 1)[1] for a in args if a.startswith("--benchmark_out=")]
out += [args[i + 1] for i, a in enumerate(args[:-1]) if a in ("--out", "--describe-real-pairs", "--stats") and args[i + 1] != "-"]
if os.environ.get("SLOW") and "--experiment" in args and args[args.index("--experiment") + 1] == os.environ["SLOW"]:
    open(out[0], "w").write("{}")  # a partial file, as a killed run leaves one
    time.sleep(60)
for path in out:
    open(path, "w").write('{"benchmarks": []}')
'''


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)


def git(tree, *args):
    subprocess.run(["git", "-C", str(tree), *args], check=True, capture_output=True)


def make_tree(path):
    shutil.rmtree(path, ignore_errors=True)
    path.mkdir(parents=True)
    (path / "README.md").write_text("a tree\n")
    git(path, "init", "-q")
    git(path, "add", "README.md")
    git(path, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "two")
    return path


def make_bench(path):
    path.mkdir(parents=True, exist_ok=True)
    for name in ("run_sweep", "run_icp", "nns_query", "micro_nns"):
        (path / name).write_text(STAND_IN)
        (path / name).chmod(0o755)
    return path


def head(tree):
    return subprocess.run(["git", "-C", str(tree), "rev-parse", "HEAD"], check=True, capture_output=True,
                          text=True).stdout.strip()


def run(tree, out, *args, expect=0, env_extra=None, timeout=60):
    env = dict(os.environ, NNB_BENCH_DIR=str(BENCH), CALLS=str(CALLS), STAMP=head(tree))
    env.update(env_extra or {})
    proc = subprocess.run([str(SCRIPT), "--source", str(tree), "--out", str(out), "--no-build", *args],
                          capture_output=True, text=True, env=env, timeout=timeout)
    if expect == 0:
        check(proc.returncode == 0, f"{args}: exit {proc.returncode}: {proc.stderr}")
    else:
        check(proc.returncode == expect, f"{args}: exit {proc.returncode}, expected {expect}: {proc.stderr}")
        lines = proc.stderr.splitlines()
        check(len(lines) == 1 and lines[0].startswith("reference_run: error: "), f"not one error line: {lines}")
    return proc


def calls():
    return CALLS.read_text().splitlines() if CALLS.exists() else []


def probes():
    return [c for c in calls() if "--benchmark_filter=" in c]


def steps_called():
    return [c for c in calls() if "--benchmark_filter=" not in c]


shutil.rmtree(WORK, ignore_errors=True)
WORK.mkdir(parents=True)
BENCH = make_bench(WORK / "bench")
CALLS = WORK / "calls.txt"
tree = make_tree(WORK / "tree")

# Refusals: an output folder inside the tree, a dirty tree, an unknown step.
run(tree, tree / "out", expect=2)
(tree / "README.md").write_text("changed\n")
run(tree, WORK / "out", expect=2)
git(tree, "checkout", "-q", "README.md")
run(tree, WORK / "out", "--steps", "nonsense", expect=2)
check(not calls(), f"a refused run called programs: {calls()}")
# Binaries built from another commit (or from a modified tree) would mislabel every file.
run(tree, WORK / "stale", expect=2, env_extra={"STAMP": "0" * 40})
run(tree, WORK / "stale", expect=2, env_extra={"STAMP": head(tree) + "+dirty"})
check(not calls(), f"a run on stale binaries called programs: {calls()}")

# A whole run: every step once, in order, each output written, the grid without brute force and
# libspatialindex and libspatialindex on its own, ICP on the real pairs at the bucket run's best buckets.
out = WORK / "out"
run(tree, out)
ran = [c for c in steps_called() if "--list" not in c and "--version" not in c]
checks = [c for c in ran if "--check" in c]
check(len(checks) == 3 and len(ran) == len(STEPS) - 1 + 2, f"{len(ran)} programs ran for {len(STEPS)} steps: {ran}")
check("nns_query --list --json" in calls(), f"the registry not written: {calls()}")
check((out / "registry" / "adapters.json").read_text().startswith("brute_force"), "the registry's file")
check(len(list((out / "checks").glob("pcl_octree_approx_*.json"))) == 3, "not three checks of the approximate octree")
check(any("--experiment icp_no_hints --out " + str(out / "hints" / "icp_no_hints.json") in c for c in ran),
      f"no ICP run without hints: {ran}")
check(any("--experiment icp_track --out " + str(out / "hints" / "icp_track.json") in c for c in ran),
      f"no ICP run with tracked neighbours: {ran}")
for step in STEPS:
    check((out / ".done" / step).exists(), f"{step} not marked done")
grid = next(c for c in ran if "--datasets" in c and "ours_kdtree" in c)
check("brute_force" not in grid and "spatialindex" not in grid, f"the grid's adapters: {grid}")
check("hollow_sphere:filled_cube" in grid and grid.count(":") == 16, f"the grid's 16 combinations: {grid}")
check(any("--adapters spatialindex_quadratic,spatialindex_rstar" in c for c in ran), "no libspatialindex grid")
check(any(f"--buckets-from {out}/icp_bucket.json" in c for c in ran), "ICP on the real pairs not at tuned buckets")
icp_real = f"--experiment {SCRIPT.parent.parent}/bench/experiments/icp_real.json"
check(any(icp_real in c for c in ran), f"ICP on the real pairs not from the script's clone: {ran}")
check((out / "micro_nns" / "micro_nns.txt").read_text().count("# before: ") == 1, "micro_nns.txt lacks its load")
log = (out / "log.txt").read_text()
check(log.count(" start ") == len(STEPS) and "all steps done" in log and "load " in log, f"log: {log}")
# The machine's noise probed before the sitting's first step and after its last, each in the log.
check(len(probes()) == 2 and "noise before: spread 1.050" in log and "noise after: spread 1.050" in log
      and log.index("noise before") < log.index(" start ") and log.index("noise after") > log.rindex(" end "),
      f"the noise probes: {probes()} {log}")
check("noise in micro_nns: spread median 1.050, largest 1.050 (probe/a) over 2 benchmarks" in log,
      f"micro_nns's own spread not logged: {log}")
# Each line's time to the microsecond makes it its event's alone: --install drops lines a clone already has.
check(all(re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{6}[+-]\d\d:\d\d ", line) for line in log.splitlines()),
      f"a log line without its time to the microsecond: {log}")
sys.path.insert(0, str(SCRIPT.parent.parent / "plots"))
import provenance  # noqa: E402  the reader of the installed log
sittings = provenance.run_log_sittings(log)  # every step but the registry and the checks writes one --out file
check(len(sittings) == len(STEPS) - 2 and all(len(s) == 1 for s in sittings.values()),
      f"provenance did not read one sitting a step from the log: {sittings}")
listed = run(tree, out, "--list").stdout.splitlines()
rel = subprocess.run([str(SCRIPT), "--source", str(tree), "--out", str(out), "--list"], capture_output=True, text=True,
                     cwd="/", env=dict(os.environ, NNB_BENCH_DIR=os.path.relpath(BENCH, tree), CALLS=str(CALLS)))
check(rel.returncode == 0 and "ours_kdtree" in rel.stdout and not rel.stderr, f"--list from another folder: {rel.stderr}")
check([line.split("\t")[:2] for line in listed] == [[s, "done"] for s in STEPS], f"--list: {listed}")

# Run again: nothing reruns. A new commit: the folder's run is refused.
before = len(calls())
run(tree, out)
check(len(calls()) == before, "a finished step ran again")
(tree / "README.md").write_text("three\n")
git(tree, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qam", "three")
run(tree, out, expect=2)

# --until stops the step in flight, which then resumes its file; a later step waits for it. Only the slow step
# and the one after it are asked for, so that a loaded machine cannot reach the deadline before the slow one.
out2 = WORK / "out2"
CALLS.unlink()
start = time.monotonic()
run(tree, out2, "--steps", "icp_bucket,icp_real", "--until", "now + 10 seconds", env_extra={"SLOW": "icp_bucket_coarse"})
check(time.monotonic() - start < 50, "--until did not stop the step in flight")
check(not (out2 / ".done" / "icp_bucket").exists() and (out2 / "icp_bucket.json").exists(), "no partial file kept")
check(not (out2 / ".done" / "icp_real").exists(), "a step after the stopped one ran")
run(tree, out2)
resumed = [c for c in calls() if "icp_bucket_coarse" in c]
check(len(resumed) == 2 and "--resume" in resumed[1] and "--resume" not in resumed[0], f"not resumed: {resumed}")

# --end-early keeps a stopped step's file as finished, with its reason in the log; it needs a reason and a file.
out_early = WORK / "out_early"
run(tree, out_early, "--steps", "icp_bucket", "--until", "now + 5 seconds", env_extra={"SLOW": "icp_bucket_coarse"})
run(tree, out_early, "--end-early", "icp_bucket", expect=2)
run(tree, out_early, "--end-early", "scale", "--reason", "no file", expect=2)
run(tree, out_early, "--end-early", "icp_bucket", "--reason", "the last settings take days")
check((out_early / ".done" / "icp_bucket").exists(), "--end-early did not mark the step done")
check("ended icp_bucket early, its file as it stands: the last settings take days" in (out_early / "log.txt").read_text(),
      "--end-early's reason not in the log")
run(tree, out_early, "--end-early", "icp_bucket", "--reason", "again", expect=2)

# A failed step stops the run (exit 1), leaving the later steps to do.
out3 = WORK / "out3"
(BENCH / "run_icp").write_text("#!/bin/sh\nexit 3\n")
proc = subprocess.run([str(SCRIPT), "--source", str(tree), "--out", str(out3), "--no-build"],
                      capture_output=True, text=True,
                      env=dict(os.environ, NNB_BENCH_DIR=str(BENCH), CALLS=str(CALLS), STAMP=head(tree)))
check(proc.returncode == 1 and "icp_accuracy failed" in proc.stderr, f"failed step: {proc.returncode} {proc.stderr}")
check(not (out3 / ".done" / "real_pairs").exists(), "steps after a failure ran")

# --install into a clone: finished files in place, unfinished ones to pending/.
clone = WORK / "clone"
shutil.copytree(SCRIPT.parent.parent / "scripts", clone / "scripts")
(out3 / "icp_accuracy.json").write_text("{}")
proc = subprocess.run([str(clone / "scripts" / SCRIPT.name), "--out", str(out3), "--install"],
                      capture_output=True, text=True)
check(proc.returncode == 0, f"--install: {proc.stderr}")
reference = clone / "results" / "reference"
check(len(list((reference / "checks").glob("*.json"))) == 3 and (reference / "registry" / "adapters.json").exists(),
      f"the registry and the checks not installed: {proc.stdout}")
check((reference / "sweep_scale.json").exists() and (reference / "micro_nns" / "micro_nns.txt").exists(),
      f"finished files not installed: {proc.stdout}")
check((reference / "pending" / "icp_accuracy.partial.json.gz").exists(), f"unfinished file not pending: {proc.stdout}")
check(not (reference / "icp_accuracy.json").exists(), "an unfinished file installed as finished")
check((reference / "reference_run_log.txt").read_text() == (out3 / "log.txt").read_text(), "the log not installed")
proc = subprocess.run([str(clone / "scripts" / SCRIPT.name), "--out", str(out3), "--install"],
                      capture_output=True, text=True)
check((reference / "reference_run_log.txt").read_text() == (out3 / "log.txt").read_text(),
      "installing the same run twice repeated its log lines")
# A later run of one step: its file replaces the old one, its log lines follow the first run's.
out5 = WORK / "out5"
run(tree, out5, "--steps", "micro_nns")
proc = subprocess.run([str(clone / "scripts" / SCRIPT.name), "--out", str(out5), "--install"],
                      capture_output=True, text=True)
check(proc.returncode == 0 and "installed micro_nns/micro_nns.json" in proc.stdout, f"--install of one step: {proc}")
check((reference / "reference_run_log.txt").read_text() == (out3 / "log.txt").read_text() + (out5 / "log.txt").read_text(),
      "a later run's log lines did not follow the first run's")

# --from-pending on another machine: the pending file is copied into the new folder and resumed.
out4 = WORK / "out4"
(BENCH / "run_icp").write_text(STAND_IN)
CALLS.unlink()
env = dict(os.environ, NNB_BENCH_DIR=str(BENCH), CALLS=str(CALLS), STAMP=head(tree))
proc = subprocess.run([str(clone / "scripts" / SCRIPT.name), "--source", str(tree), "--out", str(out4), "--no-build",
                       "--steps", "icp_accuracy", "--from-pending"], capture_output=True, text=True, env=env)
check(proc.returncode == 0 and (out4 / ".done" / "icp_accuracy").exists(), f"--from-pending: {proc.stderr}")
check(steps_called() == [f"run_icp --experiment icp_accuracy --out {out4}/icp_accuracy.json --resume"], f"{calls()}")

# A noisy machine: the run refuses to start (one line, exit 2), the spread in the log; --noise-limit none or a
# higher limit runs; a limit that is not a number is refused.
out6 = WORK / "out6"
CALLS.unlink()
noisy = {"NOISE": "1.5"}
run(tree, out6, "--steps", "registry", expect=2, env_extra=noisy)
check(steps_called() == [] and len(probes()) == 1 and not (out6 / ".done" / "registry").exists(),
      f"a noisy machine ran steps: {calls()}")
check("noise before: spread 1.500" in (out6 / "log.txt").read_text(), "the refused sitting's spread not logged")
run(tree, out6, "--steps", "registry", "--noise-limit", "1.6", env_extra=noisy)
check((out6 / ".done" / "registry").exists(), "a spread within --noise-limit refused")
run(tree, out6, "--steps", "checks", "--noise-limit", "none", env_extra=noisy)
check((out6 / ".done" / "checks").exists(), "--noise-limit none refused")
run(tree, out6, "--steps", "quick", "--noise-limit", "loud", expect=2)

# machine_noise.py on its own: a probe that fails, and a file that is no micro_nns run, get one line and exit 2.
noise_py = SCRIPT.parent / "machine_noise.py"
(WORK / "not_json.txt").write_text("not a run\n")
(WORK / "no_repetitions.json").write_text('{"benchmarks": []}')
for args in (["--micro-nns", "/bin/false"], ["--micro-nns", str(WORK / "missing")],
             ["--results", str(WORK / "not_json.txt")], ["--results", str(WORK / "no_repetitions.json")]):
    proc = subprocess.run([sys.executable, str(noise_py), *args], capture_output=True, text=True)
    check(proc.returncode == 2 and len(proc.stderr.splitlines()) == 1 and proc.stderr.startswith("machine_noise: error: "),
          f"machine_noise.py {args}: exit {proc.returncode}: {proc.stderr}")
print("reference_run: all checks passed")
