#!/usr/bin/env python3
"""run_icp end to end on tiny data: test_run_icp.py RUN_ICP WORKDIR [CASE].

cli (the default): the results file has Google Benchmark's layout, the same machine and build context as
run_sweep's (one writer for both), records with the fields plots/ reads; bad input exits 2 and writes nothing.
shards: an experiment run whole and as 3 shards, merged by plots/merge_results.py, gives the single run's
records; --plan prints the split and runs nothing; a shard resumes its own file only; bad --shard exits 2.
buckets: --buckets-from runs each adapter at its fastest bucket of a bucket sweep.
"""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

RUN_ICP, WORK = os.path.abspath(sys.argv[1]), Path(sys.argv[2])
CASE = sys.argv[3] if len(sys.argv) > 3 else "cli"
SOURCE = Path(__file__).resolve().parents[1]
# run_sweep's machine and build fields (tests/test_run_sweep.py checks the same ones there).
CONTEXT = ["date", "host_name", "executable", "num_cpus", "mhz_per_cpu", "cpu_scaling_enabled", "caches", "load_avg",
           "library_build_type", "compiler", "flags", "build_type", "ndebug", "sanitizers", "git_commit",
           "nnb_build_type", "experiment", "data_dir", "git_dirty", "command_line", "wall_seconds", "load_avg_after"]
RECORD = ["name", "pair", "adapter", "icp_seconds", "build_seconds", "nns_seconds", "estimate_seconds",
          "iterations", "converged", "rms_m", "final_pose"]


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def run(args, cwd=None):
    proc = subprocess.run([RUN_ICP] + args, capture_output=True, text=True, timeout=300, cwd=cwd)
    if "At Most 1 required but received" in proc.stderr:  # refused for the repeat, not for what it tests
        fail(f"a flag given twice: {' '.join(args)}")
    return proc


def case_cli():
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

    # Threads: the same pose, the record says how many threads the searches ran on.
    poses = {}
    for threads in ("1", "2"):
        proc = run(["--adapter", "ours_kdtree", "--threads", threads, "--out", str(out)] + tiny)
        if proc.returncode != 0:
            fail(f"--threads {threads}: exited {proc.returncode}: {proc.stderr[-2000:]}")
        record = json.loads(out.read_text())["benchmarks"][0]
        if record["threads"] != int(threads):
            fail(f"--threads {threads}: the record says {record['threads']}")
        poses[threads] = record["final_pose"]
    if poses["1"] != poses["2"]:
        fail(f"the pose differs on 2 threads: {poses}")

    # Bad input: one clear line, exit 2, no file.
    for bad in (["--adapter", "no_such_adapter"], ["--adapter", "ours_kdtree", "--threads", "0"], ["--adapter", "ours_kdtree", "--max-dist", "-1"],
                ["--adapter", "ours_kdtree", "--param", "bucket_size=0"]):
        bad_out = WORK / "bad.json"
        bad_out.unlink(missing_ok=True)
        proc = run(bad + ["--out", str(bad_out)] + tiny)
        if proc.returncode != 2:
            fail(f"{bad}: exited {proc.returncode}, expected 2")
        if "error" not in proc.stderr or bad_out.exists():
            fail(f"{bad}: no error line, or a file was written: {proc.stderr!r}")
    # Command-line errors are CLI11's but exit 2 with one line, like every other error.
    for bad in (["--iterations", "abc"], ["--no-such-option"], ["--max-dist"], ["--data-dir", str(WORK / "absent")]):
        proc = run(bad)
        lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
        if proc.returncode != 2 or len(lines) != 1 or not lines[0].startswith("run_icp: error: "):
            fail(f"{bad}: exit {proc.returncode}, stderr {proc.stderr!r}")

    # Experiment files with values that would run nothing, plan more runs than memory holds, or name what is
    # not there (a misspelt field, settings of a pair not run) are refused before any run.
    for label, icp, more in (("zero_dist", {"max_dist_m": 0}, {}), ("negative_iterations", {"iterations": -1}, {}),
                             ("negative_stride", {"query_stride": -1}, {}),
                             ("fractional_iterations", {"iterations": 2.5}, {}), ("zero_threads", {"threads": 0}, {}),
                             ("huge_repetitions", {}, {"repetitions": 2000000000}),
                             ("misspelt_field", {}, {"repetitons": 3}),
                             ("settings_of_no_pair", {}, {"icp_by_pair": {"office-sick": {"iterations": 3}}})):
        experiment = WORK / f"{label}.json"
        experiment.write_text(json.dumps({"name": label, "pairs": ["office-sick-3dtk"], "adapters": ["brute_force"],
                                          "icp": icp, **more}))
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


# A small ICP experiment: a simulated scan pair that ICP really moves (every 8th query point, so that brute force
# stays quick) and a synthetic shape; three adapters, two of them at two bucket sizes; two repetitions.
SHARD_EXPERIMENT = {
    "name": "icp_shards", "pairs": ["city-tls-15k", "hollow_sphere"],
    "adapters": ["brute_force", "nanoflann_kdtree", "ours_kdtree"], "bucket_sizes": [4, 16],
    "icp": {"max_dist_m": 0.5, "iterations": 10}, "icp_by_pair": {"city-tls-15k": {"query_stride": 8}},
    "repetitions": 2, "out": "results/icp_shards.json"}
MERGE = SOURCE / "plots" / "merge_results.py"
# What must not differ between a single run and its shards merged: the run's identity and its outcome.
SAME = ["name", "pair", "adapter", "bucket_param", "bucket_size", "params", "repetition_index", "model_points",
        "query_points", "iterations", "converged", "failure", "rms_m", "correspondences", "initial_pose", "final_pose"]


def ran(args, expect=0, cwd=None):
    proc = run(args, cwd)
    if proc.returncode != expect:
        fail(f"run_icp {' '.join(args)}: exit {proc.returncode}, expected {expect}:\n{proc.stderr[-2000:]}")
    return proc


def merge(paths, out, expect):
    proc = subprocess.run([sys.executable, str(MERGE)] + [str(p) for p in paths] + ["--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    if proc.returncode != expect:
        fail(f"merge of {[Path(p).name for p in paths]}: exit {proc.returncode}, expected {expect}:\n{proc.stderr}")
    return proc


def load(path):
    return json.loads(Path(path).read_text())


def cells(doc):
    return [f"{r['name']}#{r['repetition_index']}" for r in doc["benchmarks"]]


def check_plan(experiment, work):
    plan = json.loads(ran(experiment + ["--plan", "--json", "--shard", "1/3"]).stdout)
    if plan["shards"] != 3 or len(plan["units"]) != 10 or plan["total_cells"] != 20:
        fail(f"plan: {plan['shards']} shards, {len(plan['units'])} units, {plan['total_cells']} cells")
    if not sum(plan["shard_cells"]) == plan["total_cells"] == sum(u["cells"] for u in plan["units"]):
        fail("plan: the cells of the shards do not add up to the total")
    if len(plan["cells"]) != plan["shard_cells"][1]:
        fail("plan: the shard's cell names")
    # longest-first is within 4/3 of the best makespan, itself at least the mean and the largest unit
    bound = max(sum(plan["shard_cost"]) / 3, max(u["cost"] for u in plan["units"]))
    if max(plan["shard_cost"]) > 4 / 3 * bound + 1e-12:
        fail(f"unbalanced plan: {plan['shard_cost']}")
    cost = {(u["pair"], u["adapter"], u["bucket_size"]): u["cost"] for u in plan["units"]}
    if not cost[("city-tls-15k", "brute_force", None)] > cost[("city-tls-15k", "ours_kdtree", 16)]:
        fail("plan: brute force is not weighted above a tree")
    text = ran(experiment + ["--plan", "--shard", "1/3"]).stdout
    if not ("3 shards" in text and "<- this shard" in text and "units of shard 1/3" in text):
        fail(f"plan text:\n{text}")
    if list(work.iterdir()) != [work / "icp_shards.json"]:
        fail(f"--plan wrote files: {list(work.iterdir())}")
    return plan


def check_merged_equals_whole(whole, merged):
    if cells(merged) != cells(whole):
        fail(f"merged cells differ from the single run's (or their order):\n{cells(merged)}\n{cells(whole)}")
    for a, b in zip(merged["benchmarks"], whole["benchmarks"]):
        for field in SAME:
            if a.get(field) != b.get(field):
                fail(f"{a['name']}#{a['repetition_index']}: {field} {a.get(field)!r} != {b.get(field)!r}")
    if not any(r["iterations"] > 1 and r["final_pose"] != r["initial_pose"] for r in whole["benchmarks"]):
        fail("no run moved the query: the comparison of poses says nothing")
    context = merged["context"]
    if "shard" in context or "shard" in context["config"] or context["config"] != whole["context"]["config"]:
        fail("the merged context still names a shard, or its configuration differs from the single run's")
    if [m["shard"] for m in context["merged_from"]] != ["0/3", "1/3", "2/3"]:
        fail(f"merged_from: {context['merged_from']}")
    # plots/ reads the merged file as it reads the single run's
    sys.path.insert(0, str(SOURCE / "plots"))
    import results_io
    outcome = lambda path: sorted((r.experiment, r.pair, r.adapter, r.bucket_size, r.iterations, r.converged)
                                  for r in results_io.load([path]).icp)
    if outcome(WORK / "shards" / "merged.json") != outcome(WORK / "shards" / "whole.json"):
        fail("plots/results_io reads the merged file otherwise than the single run's")


def check_resume(experiment, shard_file, index, work):
    """A shard cut short resumes its own file: the records it has stay, the rest run, nothing twice."""
    full = load(shard_file)
    if len(full["benchmarks"]) < 2:
        fail(f"shard {index} has too few records to cut")
    cut = dict(full, benchmarks=full["benchmarks"][:len(full["benchmarks"]) // 2])
    partial = work / "partial.json"
    partial.write_text(json.dumps(cut))
    ran(experiment + ["--shard", f"{index}/3", "--out", str(partial), "--resume"])
    resumed = load(partial)
    if cells(resumed) != cells(full) or resumed["benchmarks"][:len(cut["benchmarks"])] != cut["benchmarks"]:
        fail(f"resumed shard: {cells(resumed)} != {cells(full)}, or the kept records changed")
    if len(resumed["context"]["resumed"]) != 1:
        fail(f"context.resumed: {resumed['context']['resumed']}")
    refused = ran(experiment + ["--shard", f"{(index + 1) % 3}/3", "--out", str(partial), "--resume"], expect=2)
    if "configuration" not in refused.stderr:
        fail(f"a resume as another shard: unclear refusal {refused.stderr!r}")


def check_merge_refusals(experiment, shards, work):
    proc = merge(shards[:2], work / "partial_merge.json", 1)
    if "shard 2/3 missing" not in proc.stderr or (work / "partial_merge.json").exists():
        fail(f"a missing shard: {proc.stderr}")
    cut = load(shards[1])
    lost = cells(cut)[-1]
    cut["benchmarks"].pop()
    (work / "cut.json").write_text(json.dumps(cut))
    proc = merge([shards[0], work / "cut.json", shards[2]], work / "partial_merge.json", 1)
    if lost not in proc.stderr:
        fail(f"the missing cell {lost} is not named: {proc.stderr}")
    doubled = load(shards[1])
    doubled["benchmarks"].append(doubled["benchmarks"][0])
    twice = work / "twice.json"
    twice.write_text(json.dumps(doubled))
    proc = merge([shards[0], twice, shards[2]], work / "partial_merge.json", 1)
    if "recorded twice" not in proc.stderr:
        fail(f"a cell recorded twice is not reported: {proc.stderr}")
    other = work / "other.json"
    ran([("300" if arg == "500" else arg) for arg in experiment] + ["--shard", "2/3", "--out", str(other)])
    proc = merge([shards[0], shards[1], other], work / "mixed.json", 2)
    if "configuration" not in proc.stderr or (work / "mixed.json").exists():
        fail(f"shards of another configuration: {proc.stderr}")
    merge([shards[0], shards[0], shards[1]], work / "mixed.json", 2)


def check_bad_shards(experiment, work):
    for bad in ("3/3", "1", "-1/3", "0/0", "a/3", "1/3/4"):
        proc = ran(experiment + ["--shard", bad, "--out", str(work / "bad.json")], expect=2)
        lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
        if len(lines) != 1 or not lines[0].startswith("run_icp: error: ") or (work / "bad.json").exists():
            fail(f"--shard {bad}: stderr {proc.stderr!r}")
    ran(["--shard", "0/3", "--adapter", "ours_kdtree", "--model", "hollow_sphere", "--query", "hollow_sphere",
         "--out", str(work / "bad.json")], expect=2)


def case_shards():
    work = WORK / "shards"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    (work / "icp_shards.json").write_text(json.dumps(SHARD_EXPERIMENT))
    experiment = ["--experiment", str(work / "icp_shards.json"), "--points", "500"]
    plan = check_plan(experiment, work)
    ran(experiment + ["--out", str(work / "whole.json")])
    shards = [work / f"s{i}.json" for i in range(3)]
    for i, path in enumerate(shards):
        ran(experiment + ["--shard", f"{i}/3", "--out", str(path)])
        if load(path)["context"]["shard"]["index"] != i:
            fail(f"shard {i}: context.shard {load(path)['context']['shard']}")
    merge(shards, work / "merged.json", 0)
    check_merged_equals_whole(load(work / "whole.json"), load(work / "merged.json"))
    busiest = max(range(3), key=lambda i: plan["shard_cells"][i])
    check_resume(experiment, shards[busiest], busiest, work)
    check_merge_refusals(experiment, shards, work)
    check_bad_shards(experiment, work)
    # without --out, the experiment's file named for its shard, from the current folder
    lightest = min(range(3), key=lambda i: plan["shard_cost"][i])
    ran(experiment + ["--shard", f"{lightest}/3"], cwd=work)
    if not (work / "results" / f"icp_shards.shard-{lightest}-of-3.json").exists():
        fail("the default shard file is missing")


def case_buckets():
    """--buckets-from runs each adapter at its fastest bucket in a bucket sweep, failed runs left out; 'none',
    its default; a missing file exits 2 with one line, and so does an --out over it."""
    work = WORK / "buckets"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    sweep = {"name": "tiny_bucket", "pairs": ["hollow_sphere"], "adapters": ["nanoflann_kdtree", "ours_kdtree"],
             "bucket_sizes": [4, 16], "icp": {"max_dist_m": 0.5, "iterations": 5}, "repetitions": 1}
    (work / "tiny_bucket.json").write_text(json.dumps(sweep))
    ran(["--experiment", str(work / "tiny_bucket.json"), "--points", "500", "--out", str(work / "bucket.json")])
    doc = load(work / "bucket.json")
    # Times set so that the answer is known: nanoflann fastest at 16; ours at 16 faster still but failed.
    wanted_seconds = {("nanoflann_kdtree", 4): 2.0, ("nanoflann_kdtree", 16): 1.0, ("ours_kdtree", 4): 1.5,
                      ("ours_kdtree", 16): 0.1}
    for rec in doc["benchmarks"]:
        rec["icp_seconds"] = wanted_seconds[(rec["adapter"], rec["bucket_size"])]
        if (rec["adapter"], rec["bucket_size"]) == ("ours_kdtree", 16):
            rec["failure"] = "diverged"
    (work / "bucket.json").write_text(json.dumps(doc))
    real = dict(sweep, name="tiny_real", adapters=["brute_force", "nanoflann_kdtree", "ours_kdtree"], bucket_sizes=None)
    (work / "tiny_real.json").write_text(json.dumps(real))
    experiment = ["--experiment", str(work / "tiny_real.json"), "--points", "500"]
    proc = ran(experiment + ["--buckets-from", str(work / "bucket.json"), "--out", str(work / "best.json")])
    best = load(work / "best.json")
    used = {r["adapter"]: r.get("bucket_size") for r in best["benchmarks"]}
    if used != {"brute_force": None, "nanoflann_kdtree": 16, "ours_kdtree": 4}:
        fail(f"--buckets-from: buckets used {used}")
    if best["context"]["config"].get("best_buckets") != {"nanoflann_kdtree": 16, "ours_kdtree": 4}:
        fail(f"config.best_buckets: {best['context']['config'].get('best_buckets')}")
    if "nanoflann_kdtree=16" not in proc.stdout:
        fail(f"the chosen buckets are not said: {proc.stdout}")
    ran(experiment + ["--buckets-from", "none", "--out", str(work / "default.json")])
    defaults = {r["adapter"]: r.get("bucket_size") for r in load(work / "default.json")["benchmarks"]}
    if defaults["ours_kdtree"] == 4 or "best_buckets" in load(work / "default.json")["context"]["config"]:
        fail(f"--buckets-from none: {defaults}")
    proc = ran(experiment + ["--buckets-from", str(work / "absent.json"), "--out", str(work / "x.json")], expect=2)
    lines = [line for line in proc.stderr.splitlines() if line.strip() and "WARNING" not in line and "warning" not in line]
    if len(lines) != 1 or "absent.json" not in lines[0] or (work / "x.json").exists():
        fail(f"--buckets-from a missing file: {proc.stderr}")
    before = (work / "bucket.json").read_bytes()
    proc = ran(experiment + ["--buckets-from", str(work / "bucket.json"), "--out", str(work / "bucket.json")],
               expect=2)
    if "input file" not in proc.stderr or (work / "bucket.json").read_bytes() != before:
        fail(f"--out over the --buckets-from file: {proc.stderr}")


if __name__ == "__main__":
    WORK.mkdir(parents=True, exist_ok=True)
    {"cli": case_cli, "shards": case_shards, "buckets": case_buckets}[CASE]()
    print(f"run_icp: ok [{CASE}]")
