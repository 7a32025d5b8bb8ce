#!/usr/bin/env python3
"""Tests of run_sweep, run on tiny synthetic data: test_run_sweep.py RUN_SWEEP CASE WORKDIR.

Cases: fields, resume, rounds, budget, bad_input, hostile_values, files, isolation, quick_tiny,
scale_memory, scale_budget, shards. Each exits non-zero with a message on failure.
"""
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

RUN_SWEEP, CASE, WORK = sys.argv[1], sys.argv[2], Path(sys.argv[3]) / sys.argv[2]
TINY = ["--points", "300", "--dists", "0:0.3:0.1", "--repetitions", "2"]

# Every cell's record (its median aggregate, or the one record of a skipped cell) has these; sweep and build
# records add their own, and timed cells their times (see results/README.md).
COMMON = {"name": str, "run_name": str, "run_type": str, "repetitions": int, "iterations": int, "threads": int,
          "type": str, "model": str, "adapter": str, "exact": bool}
TIMES = {"real_time": (int, float), "cpu_time": (int, float), "time_unit": str, "median_s": (int, float),
         "mean_s": (int, float), "min_s": (int, float), "stddev_s": (int, float), "cpu_median_s": (int, float)}
BUILD_TIMES = {"build_seconds": (int, float)}
SWEEP = {"query": str, "search": str, "strategy": str, "found": int, "neighbours": int, "dist_sum": (int, float)}
BUILD = {"index_bytes": int, "n_points": int}
CONTEXT = ["date", "host_name", "num_cpus", "mhz_per_cpu", "caches", "library_build_type", "compiler", "flags",
           "build_type", "git_commit", "git_dirty", "command_line", "wall_seconds", "load_avg", "load_avg_after",
           "experiment", "config", "adapters", "datasets"]


def fail(message):
    print(f"FAIL [{CASE}]: {message}")
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)


def run(args, env=None, expect=0):
    full_env = dict(os.environ, **(env or {}))
    proc = subprocess.run([RUN_SWEEP] + args, capture_output=True, text=True, env=full_env, timeout=900)
    if "At Most 1 required but received" in proc.stderr:  # refused for the repeat, not for what it tests
        fail(f"a flag given twice: {' '.join(args)}")
    if expect is not None and proc.returncode != expect:
        fail(f"{' '.join(args)} exited {proc.returncode}, expected {expect}\nstderr:\n{proc.stderr[-3000:]}")
    return proc


def load_raw(path):
    return json.loads(Path(path).read_text())


def cell_groups(records):
    groups = {}
    for rec in records:
        groups.setdefault(rec.get("run_name") or rec["name"], []).append(rec)
    return groups


def cells_of(records):
    """One record per cell, named by its cell: the median aggregate, or the one record of a skipped cell."""
    cells = []
    for name, recs in cell_groups(records).items():
        median = next((r for r in recs if r.get("aggregate_name") == "median"), None)
        if median is None:
            check(len(recs) == 1 and recs[0].get("error_occurred"), f"{name}: timed, but no median aggregate")
            cells.append(recs[0])
        else:
            cells.append(dict(median, name=name))
    return cells


def load(path):
    """The file with 'benchmarks' as one record per cell and 'records' as written."""
    doc = load_raw(path)
    doc["records"] = doc["benchmarks"]
    doc["benchmarks"] = cells_of(doc["records"])
    return doc


def check_repetition_records(records):
    """Google Benchmark's layout: a record per timed repetition, then mean, median (and with two or more,
    stddev and cv) aggregates of them; a skipped cell is one error record without times."""
    for name, recs in cell_groups(records).items():
        runs = [r for r in recs if r["run_type"] == "iteration"]
        aggregates = {r["aggregate_name"]: r for r in recs if r["run_type"] == "aggregate"}
        if recs[0].get("error_occurred"):
            check(len(recs) == 1 and "real_time" not in recs[0], f"{name}: a skipped cell has times or aggregates")
            continue
        n = len(runs)
        check(n >= 1 and all(r["repetitions"] == n for r in recs), f"{name}: {n} repetition records")
        check([r["repetition_index"] for r in runs] == list(range(n)), f"{name}: repetition indices")
        check(all(r["name"] == name and r["iterations"] == 1 and r["time_unit"] == "us" for r in runs),
              f"{name}: repetition record fields")
        wanted = {"mean", "median"} | ({"stddev", "cv"} if n >= 2 else set())
        check(set(aggregates) == wanted, f"{name}: aggregates {sorted(aggregates)}, expected {sorted(wanted)}")
        check(all(a["name"] == f"{name}_{k}" for k, a in aggregates.items()), f"{name}: aggregate names")
        times = [r["real_time"] for r in runs]
        check(math.isclose(aggregates["median"]["real_time"], statistics.median(times), rel_tol=1e-9),
              f"{name}: the median aggregate is not the repetitions' median")
        check(math.isclose(aggregates["mean"]["real_time"], statistics.fmean(times), rel_tol=1e-9),
              f"{name}: the mean aggregate is not the repetitions' mean")
        if n >= 2:
            check(math.isclose(aggregates["stddev"]["real_time"], statistics.stdev(times), rel_tol=1e-6, abs_tol=1e-12),
                  f"{name}: stddev")
            check(aggregates["cv"]["aggregate_unit"] == "percentage", f"{name}: cv unit")


def check_record_fields(rec):
    name = rec.get("name", "?")
    expected = dict(COMMON, **(SWEEP if rec.get("type") == "sweep" else BUILD), **({} if "skipped" in rec else TIMES),
                    **({} if "skipped" in rec or rec.get("type") == "sweep" else BUILD_TIMES))
    for field, kind in expected.items():
        check(field in rec, f"{name}: field '{field}' missing")
        check(isinstance(rec[field], kind) and not (kind is int and isinstance(rec[field], bool)),
              f"{name}: field '{field}' = {rec[field]!r} has the wrong type")
    if "skipped" in rec:
        check(rec.get("error_occurred") is True and rec["skipped"], f"{name}: skipped without a reason")
        check(rec["run_type"] == "iteration" and "real_time" not in rec, f"{name}: a skipped cell has a time")
    else:
        check(rec["time_unit"] == "us" and rec["run_type"] == "aggregate", f"{name}: time_unit/run_type")
        check(math.isclose(rec["real_time"], 1e6 * rec["median_s"], rel_tol=1e-12, abs_tol=1e-15),
              f"{name}: real_time is not the median in us")
        check(rec["repetitions"] >= 1, f"{name}: ran with 0 repetitions")
        check(rec["min_s"] <= rec["median_s"] <= max(rec["mean_s"], rec["median_s"]) or rec["repetitions"] > 2,
              f"{name}: odd statistics")
    if rec["type"] == "build":
        check(name == f"build/{rec['model']}/{rec['adapter']}", f"{name}: build name")
        return
    check(rec["search"] in ("ranged", "knn", "radius"), f"{name}: search {rec['search']}")
    check(rec["strategy"] in ("native", "native_unpruned", "via_knn", "via_radius", "via_box"), f"{name}: strategy")
    if rec["search"] == "knn":
        check("max_dist" not in rec and isinstance(rec.get("k"), int), f"{name}: knn has max_dist or no k")
    else:
        check(isinstance(rec.get("max_dist"), (int, float)), f"{name}: no max_dist")
        check(name.endswith(f"max_dist:{rec['max_dist']:.2f}"), f"{name}: name does not end with its max_dist")
    if rec["search"] == "radius":
        check("k" not in rec, f"{name}: radius has k")
    if rec["search"] == "ranged":
        check(isinstance(rec.get("k"), int), f"{name}: ranged has no k")
    if rec["exact"] and "skipped" not in rec:
        check(isinstance(rec.get("agrees"), bool) and rec.get("checked_against"), f"{name}: no agreement check")


def fresh_workdir():
    shutil.rmtree(WORK, ignore_errors=True)
    WORK.mkdir(parents=True)
    return WORK


def case_fields():
    out = fresh_workdir() / "fields.json"
    run(TINY + ["--adapters", "brute_force", "--strategies", "default", "--out", str(out)])
    doc = load(out)
    for key in CONTEXT:
        check(key in doc["context"], f"context field '{key}' missing")
    check(doc["context"]["experiment"] == "quick", "context experiment")
    check(doc["context"]["datasets"][0]["seed"] == 1, "data set seed missing")
    check("brute_force" in doc["context"]["adapters"], "adapter info missing from context")
    names = [r["name"] for r in doc["benchmarks"]]
    check(len(names) == len(set(names)), "duplicate cell names")
    # brute force offers all three kinds: 1 build + 4 ranged + 1 knn + 4 radius
    check(len(names) == 10, f"expected 10 records, got {len(names)}: {names}")
    for rec in doc["benchmarks"]:
        check_record_fields(rec)
    check_repetition_records(doc["records"])
    check("sweep/hollow_sphere/hollow_cube/brute_force/ranged/max_dist:0.20" in names, "ranged cell name")
    check("sweep/hollow_sphere/hollow_cube/brute_force/knn/k:1" in names, "knn cell name")
    by_name = {r["name"]: r for r in doc["benchmarks"]}
    # at max_dist 0 the hollow cube and the hollow sphere share no point; found grows with the distance
    found = [by_name[f"sweep/hollow_sphere/hollow_cube/brute_force/ranged/max_dist:{d}"]["found"]
             for d in ("0.00", "0.10", "0.20", "0.30")]
    check(found[0] == 0 and found == sorted(found) and found[-1] > 0, f"ranged found not growing: {found}")
    check(by_name["sweep/hollow_sphere/hollow_cube/brute_force/knn/k:1"]["found"] == 300, "knn found != 300")


def case_min_time():
    """--min-time repeats a cell until its calls took that long, up to --repetitions: each repetition a record."""
    work = fresh_workdir()
    base = ["--points", "300", "--dists", "0:0.3:0.1", "--adapters", "brute_force", "--strategies", "default"]
    for min_time, reps, expected in (("1000", "6", 6), ("1e-9", "6", 1), ("0", "4", 4)):
        out = work / f"min_time_{min_time}.json"
        run(base + ["--repetitions", reps, "--min-time", min_time, "--out", str(out)])
        doc = load(out)
        check(doc["context"]["config"]["min_time_seconds"] == float(min_time), "config.min_time_seconds")
        check_repetition_records(doc["records"])
        counts = {r["repetitions"] for r in doc["benchmarks"] if r["type"] == "sweep"}
        check(counts == {expected}, f"--min-time {min_time} --repetitions {reps}: repetitions {counts}")
    proc = run(base + ["--min-time", "-1", "--out", str(work / "bad.json")], expect=2)
    check("min_time_seconds" in proc.stderr, f"--min-time -1: {proc.stderr}")


def case_threads():
    """--threads: the config says how many were asked, each record how many its calls ran on; same answers."""
    work = fresh_workdir()
    base = ["--points", "1500", "--dists", "0:0.3:0.1", "--strategies", "default", "--repetitions", "1"]
    listed = subprocess.run([str(Path(RUN_SWEEP).parent / "nns_query"), "--list"], capture_output=True, text=True,
                            timeout=300).stdout
    adapters = "brute_force,ann_kdtree" if "ann_kdtree" in listed else "brute_force"  # ANN: single-threaded
    docs = {}
    for threads in ("1", "3"):
        out = work / f"threads_{threads}.json"
        run(base + ["--adapters", adapters, "--threads", threads, "--out", str(out)])
        docs[threads] = load(out)
        check(docs[threads]["context"]["config"]["threads"] == int(threads), "config.threads")
    for rec in docs["3"]["benchmarks"]:
        ran = 1 if rec["type"] == "build" or rec["adapter"] == "ann_kdtree" else 3
        check(rec["threads"] == ran, f"{rec['name']}: threads {rec['threads']}, expected {ran}")
    one = {r["name"]: (r["found"], r["neighbours"], r["dist_sum"]) for r in docs["1"]["benchmarks"] if r["type"] == "sweep"}
    three = {r["name"]: (r["found"], r["neighbours"], r["dist_sum"]) for r in docs["3"]["benchmarks"] if r["type"] == "sweep"}
    check(one == three, "answers differ between 1 and 3 threads")
    run(base + ["--threads", "0", "--out", str(work / "bad.json")], expect=2)
    check(not (work / "bad.json").exists(), "--threads 0 wrote a results file")


COMPARE_PY = Path("/usr/share/benchmark/compare.py")  # Debian's libbenchmark-tools


def case_compare_py():
    """Google Benchmark's compare.py reads two run_sweep files: readable ratios, and its U-test runs."""
    check(COMPARE_PY.exists(), f"{COMPARE_PY} missing: scripts/install_deps.sh installs libbenchmark-tools")
    work = fresh_workdir()
    args = ["--points", "2000", "--dists", "0.1:0.2:0.1", "--adapters", "brute_force", "--strategies", "default",
            "--repetitions", "9", "--min-time", "0"]
    a, b = work / "a.json", work / "b.json"
    run(args + ["--out", str(a)])
    run(args + ["--out", str(b)])
    proc = subprocess.run(["/usr/bin/python3", str(COMPARE_PY), "--no-color", "benchmarks", str(a), str(b)],
                          capture_output=True, text=True, timeout=300)
    check(proc.returncode == 0, f"compare.py exited {proc.returncode}: {proc.stderr[-2000:]}")
    cell = "sweep/hollow_sphere/hollow_cube/brute_force/ranged/max_dist:0.10"
    rows = [line.split() for line in proc.stdout.splitlines() if line.startswith(cell)]
    check(rows, f"compare.py printed no row for {cell}:\n{proc.stdout[:3000]}")
    old_times = [float(row[3]) for row in rows if len(row) >= 7 and row[0] == cell]
    check(old_times and all(t > 0 for t in old_times), f"compare.py rows for {cell}: {rows}")
    pvalue = [row for row in rows if row[0] == f"{cell}_pvalue"]
    check(pvalue and "U" in " ".join(pvalue[0]) and "9 vs 9" in " ".join(pvalue[0]),
          f"no U-test over 9 repetitions for {cell}: {rows}")
    check(any(row[0] == f"{cell}_median" for row in rows), f"no median aggregate row: {rows}")


def case_table1():
    """plots/table1.py --from-registry (the adapters nns_query --list --json declares) writes one row per
    adapter built in, and for the adapters of a results file the same rows as from that file's metadata."""
    plots = Path(__file__).resolve().parents[1] / "plots"
    sys.path.insert(0, str(plots))
    import results_io  # noqa: E402
    from table1 import table1_lines  # noqa: E402
    out = fresh_workdir() / "table1.json"
    adapters = ["brute_force", "flann_kdtree", "nanoflann_kdtree", "ours_octree", "pcl_octree_approx"]
    run(["--points", "300", "--dists", "0:0.1:0.1", "--repetitions", "1", "--adapters", ",".join(adapters),
         "--out", str(out)])
    from_results = table1_lines(results_io.load([out]))
    check(len(from_results) == 2 + len(adapters), f"table1.py rows from the results file: {from_results}")
    nns_query = Path(RUN_SWEEP).parent / "nns_query"
    listed = subprocess.run([str(nns_query), "--list"], capture_output=True, text=True, timeout=300)
    check(listed.returncode == 0, f"nns_query --list: {listed.stderr}")
    registered = sorted(line.split("\t")[0] for line in listed.stdout.splitlines())
    proc = subprocess.run([sys.executable, str(plots / "table1.py"), "--from-registry", str(nns_query)],
                          capture_output=True, text=True, timeout=300)
    check(proc.returncode == 0, f"table1.py --from-registry: {proc.stderr}")
    from_registry = proc.stdout.splitlines()
    check(from_registry[:2] == from_results[:2], f"headers differ:\n{from_registry[:2]}\n{from_results[:2]}")
    rows = {line.split(" | ")[0][2:]: line for line in from_registry[2:]}
    check(sorted(rows) == registered and len(rows) == len(from_registry) - 2,
          f"rows from the registry {sorted(rows)}, adapters registered {registered}")
    for line in from_results[2:]:
        name = line.split(" | ")[0][2:]
        check(rows.get(name) == line, f"{name}:\n  from the registry: {rows.get(name)}\n  from the results: {line}")


def case_strategies():
    """--strategies all runs ranged search with every strategy an adapter offers, each its own named series,
    every one cross-checked; the default keeps the plain name."""
    out = fresh_workdir() / "strategies.json"
    run(TINY + ["--adapters", "brute_force,nanoflann_kdtree", "--strategies", "all", "--out", str(out)])
    doc = load(out)
    offered = doc["context"]["adapters"]["nanoflann_kdtree"]["ranged_strategies"]
    check(offered[0] == doc["context"]["adapters"]["nanoflann_kdtree"]["ranged"] and "via_knn" in offered
          and "via_radius" in offered, f"ranged strategies offered: {offered}")
    ranged = [r for r in doc["benchmarks"] if r.get("search") == "ranged" and r["adapter"] == "nanoflann_kdtree"]
    by_strategy = {}
    for r in ranged:
        by_strategy.setdefault(r["strategy"], []).append(r)
        default = r["strategy"] == offered[0]
        check(("/strategy:" not in r["name"]) == default, f"{r['name']}: strategy component for {r['strategy']}")
        check(r.get("agrees") is True, f"{r['name']}: does not agree with brute force")
    check(sorted(by_strategy) == sorted(offered) and all(len(v) == 4 for v in by_strategy.values()),
          f"ranged cells by strategy: { {k: len(v) for k, v in by_strategy.items()} }")
    for s in offered:
        found = [r["found"] for r in sorted(by_strategy[s], key=lambda r: r["max_dist"])]
        check(found == [r["found"] for r in sorted(by_strategy[offered[0]], key=lambda r: r["max_dist"])],
              f"{s}: found {found} differs from the default strategy")
    check(doc["context"]["config"]["strategies"] == "all", "config.strategies")
    default_only = fresh_workdir() / "default.json"
    run(TINY + ["--adapters", "nanoflann_kdtree", "--strategies", "default", "--out", str(default_only)])
    check(not any("/strategy:" in r["name"] for r in load(default_only)["benchmarks"]),
          "the default run recorded other strategies")
    proc = run(TINY + ["--adapters", "brute_force", "--strategies", "some", "--out", str(out) + ".x"], expect=2)
    lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
    check(len(lines) == 1 and "strategies must be" in lines[0], f"--strategies some: {lines}")


def case_resume():
    work = fresh_workdir()
    data = ["--adapters", "brute_force", "--datasets", "hollow_sphere:hollow_cube,filled_cube"]
    args = TINY + data
    whole = work / "whole.json"
    run(args + ["--out", str(whole)])
    killed = work / "killed.json"
    proc = run(args + ["--out", str(killed)], env={"NNB_SWEEP_ABORT_AFTER_CELLS": "7"}, expect=None)
    check(proc.returncode == -9, f"the fault-injected run was not killed (exit {proc.returncode})")
    partial = load(killed)
    killed_copy = work / "killed_copy.json"
    shutil.copy(killed, killed_copy)
    n_partial = len(partial["benchmarks"])
    n_whole = len(load(whole)["benchmarks"])
    check(7 <= n_partial < n_whole, f"killed run recorded {n_partial} of {n_whole} cells")
    # a resume with another configuration is refused and leaves the file alone
    before = killed.read_bytes()
    other = ["--points", "300", "--dists", "0:0.3:0.1", "--repetitions", "3"]
    refused = run(other + data + ["--out", str(killed), "--resume"], expect=2)
    check("configuration" in refused.stderr, f"unclear refusal: {refused.stderr}")
    check(killed.read_bytes() == before, "a refused resume changed the file")
    run(args + ["--out", str(killed), "--resume"])
    resumed = load(killed)
    names_whole = sorted(r["name"] for r in load(whole)["benchmarks"])
    names_resumed = sorted(r["name"] for r in resumed["benchmarks"])
    check(names_whole == names_resumed, f"cells differ:\n{names_whole}\n{names_resumed}")
    # the cells recorded before the kill were kept, not redone
    kept = {r["name"]: r for r in resumed["benchmarks"]}
    for rec in partial["benchmarks"]:
        check(kept[rec["name"]] == rec, f"{rec['name']} was redone or changed on resume")
    check(len(resumed["context"]["resumed"]) == 1, "resumption not noted in the context")
    check(not list(work.glob("*.tmp")) and not list(work.glob(".*.tmp.*")), "temporary files left behind")
    # results agree between the two runs: same data, same exact answers
    whole_by_name = {r["name"]: r for r in load(whole)["benchmarks"]}
    for name, rec in kept.items():
        if rec["type"] == "sweep":
            check(rec["found"] == whole_by_name[name]["found"], f"{name}: found differs between runs")
    check_hostile_resume(args, load_raw(killed_copy), work)


def check_hostile_resume(args, partial, work):
    """A results file edited into something its reader cannot hold is refused with one line, left alone."""
    def nested(depth):
        return [nested(depth - 1)] if depth else []
    count = json.loads(json.dumps(partial))
    next(r for r in count["benchmarks"] if "neighbours" in r)["neighbours"] = 4.9e23
    deep = json.loads(json.dumps(partial))
    deep["context"]["note"] = nested(200)
    resumed = json.loads(json.dumps(partial))
    resumed["context"]["resumed"] = "yesterday"
    for label, doc in (("count beyond size_t", count), ("200 levels deep", deep), ("resumed not a list", resumed)):
        path = work / "hostile.json"
        path.write_text(json.dumps(doc))
        before = path.read_bytes()
        proc = run(args + ["--out", str(path), "--resume"], expect=2)
        lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
        check(len(lines) == 1 and lines[0].startswith("run_sweep: error: "), f"{label}: not one error line: {lines}")
        check(path.read_bytes() == before, f"{label}: the refused resume changed the file")


def case_budget():
    work = fresh_workdir()
    out = work / "budget.json"
    run(TINY + ["--adapters", "brute_force", "--budget", "1e-9", "--out", str(out)])
    recs = {r["name"]: r for r in load(out)["benchmarks"]}
    for kind in ("ranged", "radius"):
        first = recs[f"sweep/hollow_sphere/hollow_cube/brute_force/{kind}/max_dist:0.00"]
        check("skipped" not in first and first["repetitions"] == 1,
              f"{kind} at 0: should run once, then stop repeating: {first}")
        for d in ("0.10", "0.20", "0.30"):
            rec = recs[f"sweep/hollow_sphere/hollow_cube/brute_force/{kind}/max_dist:{d}"]
            check(rec.get("skipped", "").startswith("over budget:") and "at max_dist 0.00" in rec["skipped"],
                  f"{rec['name']}: not skipped for the budget: {rec.get('skipped')}")
            check(rec["repetitions"] == 0, f"{rec['name']}: a skipped cell has repetitions")
    check("skipped" not in recs["sweep/hollow_sphere/hollow_cube/brute_force/knn/k:1"], "knn skipped")
    # a generous budget skips nothing
    run(TINY + ["--adapters", "brute_force", "--budget", "100", "--out", str(work / "none.json")])
    check(not any("skipped" in r for r in load(work / "none.json")["benchmarks"]), "skipped under a large budget")
    # the neighbour budget, from an experiment file: radius stops after the first cell over 400 neighbours
    experiment = work / "neighbours.json"
    experiment.write_text(json.dumps({"name": "nb", "pairs": [{"model": "filled_cube", "query": "filled_cube"}],
                                      "adapters": ["brute_force"], "searches": ["radius"], "dists": "0:0.5:0.1",
                                      "repetitions": 1, "neighbour_budget": 400, "synthetic_points": 200}))
    run(["--experiment", str(experiment), "--out", str(work / "nb.json")])
    recs = [r for r in load(work / "nb.json")["benchmarks"] if r["type"] == "sweep"]
    ran = [r for r in recs if "skipped" not in r]
    check(len(recs) == 6 and 1 <= len(ran) < 6, f"neighbour budget: {len(ran)} of {len(recs)} cells ran")
    check(ran[-1]["neighbours"] > 400 and all(r["neighbours"] <= 400 for r in ran[:-1]),
          "neighbour budget stopped at the wrong cell")
    check(all(r["skipped"].startswith("over neighbour budget") for r in recs[len(ran):]), "neighbour skip reason")
    # ranged search via_radius holds the radius answer before it keeps k: its group stops, unrun, at the first
    # distance whose radius answer passes the budget (where the radius group, which holds it as its answer, runs
    # its last cell), though one row a query is kept
    experiment.write_text(json.dumps({"name": "nb", "pairs": [{"model": "filled_cube", "query": "filled_cube"}],
                                      "adapters": ["brute_force"], "searches": ["ranged", "radius"],
                                      "strategies": "all", "dists": "0:0.5:0.1", "repetitions": 1,
                                      "neighbour_budget": 400, "synthetic_points": 200}))
    run(["--experiment", str(experiment), "--out", str(work / "nb_via_radius.json")])
    cells = [r for r in load(work / "nb_via_radius.json")["benchmarks"] if r["type"] == "sweep"]
    via_radius = [r for r in cells if r["strategy"] == "via_radius"]
    ran = [r for r in via_radius if "skipped" not in r]
    check(len(via_radius) == 6 and 1 <= len(ran) < 6, f"via_radius: {len(ran)} of {len(via_radius)} cells ran")
    check(all(r["neighbours"] <= 200 for r in ran), "via_radius kept more than one neighbour a query")
    check(all("radius search behind via_radius" in r["skipped"] for r in via_radius[len(ran):]),
          "via_radius skip reason: " + "; ".join(r["skipped"] for r in via_radius[len(ran):]))
    radius = [r for r in cells if r["search"] == "radius" and "skipped" not in r]
    check(len(radius) == len(ran) + 1 and radius[-1]["neighbours"] > 400 >= radius[-2]["neighbours"],
          "via_radius stopped where the radius answer did not pass the budget: " +
          ", ".join(str(r["neighbours"]) for r in radius))
    others = [r for r in cells if r["search"] == "ranged" and r["strategy"] != "via_radius"]
    check(others and not any("skipped" in r for r in others), "the budget stopped another ranged strategy")

def with_flags(base, extra):
    """base's flags and values with those extra gives replaced (a flag given twice is itself refused)."""
    given = {extra[i] for i in range(0, len(extra), 2)}
    kept = [word for i in range(0, len(base), 2) if base[i] not in given for word in base[i:i + 2]]
    return kept + extra


def case_bad_input():
    work = fresh_workdir()
    bad_json = work / "bad.json"
    bad_json.write_text("{ not json")
    cases = [["--adapters", "no_such_adapter"], ["--datasets", "no_such_data_set"], ["--dists", "0:1:0"],
             ["--dists", "0:1:-0.02"], ["--dists", "-0.1:1:0.02"], ["--dists", "0:1"], ["--dists", "a:b:c"],
             ["--experiment", str(work / "missing.json")], ["--experiment", str(bad_json)],
             ["--repetitions", "0"], ["--rounds", "0"], ["--rounds", "1001"], ["--budget", "0"], ["--no-such-flag"],
             ["--data-dir", str(work / "absent")]]
    for i, extra in enumerate(cases):
        out = work / f"out{i}.json"
        proc = run(with_flags(TINY, extra) + ["--out", str(out)], expect=2)
        lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
        check(lines, f"{extra}: no message")
        check("At Most 1 required" not in proc.stderr, f"{extra}: refused for a flag given twice")
        check(not out.exists(), f"{extra}: wrote a results file")
    check(sorted(p.name for p in work.iterdir()) == ["bad.json"], "bad input left files behind")


def check_rounds(path, rounds, repetitions, build_repetitions, budget_s=None):
    """Every cell that ran holds its repetitions of every round, agreeing, unless a call over budget_s ended
    its rounds there (as it ends repetitions); skipped cells stay one record."""
    doc = load(path)
    check_repetition_records(doc["records"])
    calls_s = {name: [r["real_time"] / 1e6 for r in recs if r["run_type"] == "iteration" and "real_time" in r]
               for name, recs in cell_groups(doc["records"]).items()}
    ran = [r for r in doc["benchmarks"] if "skipped" not in r]
    check(ran, f"{path}: no cell ran")
    for rec in doc["benchmarks"]:
        check_record_fields(rec)
        if "skipped" in rec:
            check("rounds" not in rec, f"{rec['name']}: a skipped cell has rounds")
            continue
        per_round = build_repetitions if rec["type"] == "build" else repetitions
        if budget_s is not None and rec["type"] == "sweep" and rec.get("rounds", 1) < rounds:
            check(calls_s[rec["name"]][-1] > budget_s and rec["repetitions"] == rec.get("rounds", 1) * per_round,
                  f"{rec['name']}: {rec.get('rounds', 1)} rounds, its last call within the budget")
            continue
        check(rec.get("rounds") == rounds and rec["repetitions"] == rounds * per_round,
              f"{rec['name']}: {rec.get('rounds')} rounds, {rec['repetitions']} repetitions")
        check(rec["type"] == "build" or not rec["exact"] or rec.get("agrees") is True,
              f"{rec['name']}: disagrees: {rec.get('disagreement')}")
    check(doc["context"]["config"].get("rounds") == rounds, "config.rounds")
    return doc


def case_rounds():
    """--rounds N: N passes over each model's units, each cell's calls of every pass in its one record;
    resumable."""
    work = fresh_workdir()
    common = ["--points", "300", "--dists", "0:0.3:0.1", "--repetitions", "1", "--adapters",
              "brute_force,nanoflann_kdtree", "--datasets", "hollow_sphere:hollow_cube", "--strategies", "default"]
    args = common + ["--rounds", "3"]
    whole = work / "whole.json"
    run(args + ["--out", str(whole)])
    n_cells = len(check_rounds(whole, 3, 1, 3)["benchmarks"])
    # one round writes the file as before: no rounds anywhere
    one = work / "one.json"
    run(common + ["--out", str(one)])
    check(all("rounds" not in r for r in load_raw(one)["benchmarks"]) and
          "rounds" not in load_raw(one)["context"]["config"], "a run of one round records rounds")
    # cells over the budget are skipped in the first round and not run again; a call over it ends its
    # cell's rounds, as it ends repetitions (the builds, which the budget does not judge, take all three)
    tight = work / "tight.json"
    run(args + ["--budget", "1e-9", "--out", str(tight)])
    doc = check_rounds(tight, 3, 1, 3, budget_s=1e-9)
    check(any("skipped" in r for r in doc["benchmarks"]), "a 1 ns budget skipped nothing")
    timed = [r for r in doc["benchmarks"] if "skipped" not in r and r["type"] == "sweep"]
    check(timed and all(r.get("rounds", 1) == 1 for r in timed),
          f"calls over a 1 ns budget were timed again: rounds {sorted({r.get('rounds', 1) for r in timed})}")
    check(all(r["rounds"] == 3 for r in doc["benchmarks"] if r["type"] == "build"), "a build lost rounds")
    # killed in the second round, resumed: every cell ends with its three rounds
    killed = work / "killed.json"
    proc = run(args + ["--out", str(killed)], env={"NNB_SWEEP_ABORT_AFTER_CELLS": str(n_cells + 5)}, expect=None)
    check(proc.returncode == -9, f"the fault-injected run was not killed (exit {proc.returncode})")
    partial = load(killed)["benchmarks"]
    check(len(partial) == n_cells and {r.get("rounds") for r in partial} == {None, 2},
          f"killed run: {len(partial)} cells, rounds {sorted({str(r.get('rounds')) for r in partial})}")
    refused = run(common + ["--rounds", "2", "--out", str(killed), "--resume"], expect=2)
    check("configuration" in refused.stderr, f"a resume with other rounds: {refused.stderr}")
    run(args + ["--out", str(killed), "--resume"])
    resumed = check_rounds(killed, 3, 1, 3)
    check(sorted(r["name"] for r in resumed["benchmarks"]) == sorted(r["name"] for r in load(whole)["benchmarks"]),
          "the resumed run's cells differ from the whole run's")
    # a model's rounds all run before the next model's: killed just after the first model's third round,
    # the first model's cells have all three and the second's none beyond its first
    two_models = common[:common.index("--datasets")] + [
        "--datasets", "hollow_sphere:hollow_cube,hollow_cube:hollow_sphere", "--strategies", "default", "--rounds", "3"]
    model_of = lambda name: name.split("/")[1]
    first_model = [r for r in load(whole)["benchmarks"] if model_of(r["name"]) == "hollow_sphere"]
    cut = work / "cut.json"
    proc = run(two_models + ["--out", str(cut)], env={"NNB_SWEEP_ABORT_AFTER_CELLS": str(3 * len(first_model) + 1)},
               expect=None)
    check(proc.returncode == -9, f"the fault-injected run was not killed (exit {proc.returncode})")
    cells = load(cut)["benchmarks"]
    rounds_of = lambda model: sorted({str(r.get("rounds")) for r in cells if model_of(r["name"]) == model})
    check(rounds_of("hollow_sphere") == ["3"], f"the first model's cells ended with rounds {rounds_of('hollow_sphere')}")
    check(rounds_of("hollow_cube") in ([], ["None"]), f"the second model's cells have rounds {rounds_of('hollow_cube')}")


def case_quick_tiny():
    """The quick experiment on tiny data: every adapter's cells, and every exact adapter finds what brute
    force finds in every cell."""
    work = fresh_workdir()
    out = work / "quick.json"
    run(["--experiment", "quick", "--points", "500", "--out", str(out)])
    doc = load(out)
    adapters = doc["context"]["adapters"]
    recs = doc["benchmarks"]
    for rec in recs:
        check_record_fields(rec)
    check(len(doc["context"]["config"]["adapters"]) == len(adapters), "not every adapter")
    for name, info in adapters.items():
        kinds = [r["search"] for r in recs if r["adapter"] == name and r["type"] == "sweep"]
        dists = 21  # 0:1:0.05
        ranged = dists * len(info["ranged_strategies"])  # quick runs every ranged strategy
        check(kinds.count("ranged") == ranged, f"{name}: {kinds.count('ranged')} ranged cells, expected {ranged}")
        for kind in ("knn", "radius"):
            offered = info[kind] in ("native", "via_box")
            expected = (1 if kind == "knn" else dists) if offered else 0
            check(kinds.count(kind) == expected, f"{name}: {kinds.count(kind)} {kind} cells, expected {expected}")
        check(any(r["type"] == "build" and r["adapter"] == name for r in recs), f"{name}: no build record")
    disagreements = [f"{r['name']}: {r['disagreement']}" for r in recs if r.get("agrees") is False]
    check(not disagreements, f"{len(disagreements)} cells where exact adapters disagree:\n" + "\n".join(disagreements))
    errors = [f"{r['name']}: {r['skipped']}" for r in recs if r.get("skipped", "").startswith("error")]
    check(not errors, "adapters failed:\n" + "\n".join(errors))


# The scale experiment on its two smallest model sizes, queries = the smallest query scan (fast).
SCALE_SMALL = ["--experiment", "scale", "--datasets", "city-tls-15k:city-tls-15k,city-tls-60k:city-tls-15k",
               "--repetitions", "1"]
SMALL, LARGER = "city-tls-15k", "city-tls-60k"
GIB = 1024.0 ** 3


def by_model_adapter(recs):
    """{(model, adapter): (build record, [sweep records])}."""
    table = {}
    for rec in recs:
        entry = table.setdefault((rec["model"], rec["adapter"]), [None, []])
        if rec["type"] == "build":
            entry[0] = rec
        else:
            entry[1].append(rec)
    return table


def check_scale_fields(doc):
    for rec in doc["benchmarks"]:
        check_record_fields(rec)
        check(isinstance(rec.get("n_points"), int) and rec["n_points"] > 0, f"{rec['name']}: no n_points")
        if rec["type"] == "build":
            check(isinstance(rec.get("index_bytes_per_point"), (int, float)), f"{rec['name']}: no bytes per point")
            check(isinstance(rec.get("build_peak_rss_bytes"), int), f"{rec['name']}: no build_peak_rss_bytes")
            if rec["n_points"]:
                check(abs(rec["index_bytes_per_point"] - rec["index_bytes"] / rec["n_points"]) < 1e-9,
                      f"{rec['name']}: index_bytes_per_point != index_bytes / n_points")
        else:
            check(isinstance(rec.get("n_queries"), int) and rec["n_queries"] > 0, f"{rec['name']}: no n_queries")
            if "skipped" in rec:
                check("seconds_per_query" not in rec, f"{rec['name']}: a skipped cell has seconds_per_query")
            else:
                check(abs(rec["seconds_per_query"] * rec["n_queries"] - rec["median_s"]) <= 1e-12 + 1e-9 * rec["median_s"],
                      f"{rec['name']}: seconds_per_query != median_s / n_queries")
    n = {d["spec"]: d["points"] for d in doc["context"]["datasets"] if d["role"] == "model"}
    check(n[SMALL] < n[LARGER], f"model sizes not increasing: {n}")
    for rec in doc["benchmarks"]:
        check(rec["n_points"] == n[rec["model"]], f"{rec['name']}: n_points {rec['n_points']} != {n[rec['model']]}")


def case_scale_memory():
    """A memory limit skips an adapter on the larger models, with the reason; the run ends normally."""
    work = fresh_workdir()
    adapters = ["--adapters", "brute_force,nanoflann_kdtree,ann_kdtree"]
    # A tiny limit: every adapter whose build takes memory is over it at the first size already.
    out = work / "tiny_limit.json"
    proc = run(SCALE_SMALL + adapters + ["--memory-limit-gib", "0.000001", "--out", str(out)])
    doc = load(out)
    check(doc["context"]["config"]["memory_limit_gib"] == 0.000001, "memory limit not in the config")
    check_scale_fields(doc)
    table = by_model_adapter(doc["benchmarks"])
    check(len(table) == 6 and all(b and len(cells) == 1 for b, cells in table.values()), "missing records")
    for adapter in ("nanoflann_kdtree", "ann_kdtree"):
        build, cells = table[(SMALL, adapter)]
        check("skipped" not in build and "skipped" not in cells[0], f"{adapter}: did not run at the first size")
        check(build["index_bytes"] > 0.000001 * GIB, f"{adapter}: index of {build['index_bytes']} B under 1 kB?")
        check(build.get("skips_larger_models", "").startswith("over memory limit:"),
              f"{adapter}: first build over the limit does not close larger models: {build.get('skips_larger_models')}")
        build, cells = table[(LARGER, adapter)]
        for rec in [build] + cells:
            check("points and more: over memory limit" in rec.get("skipped", ""),
                  f"{rec['name']}: not skipped for memory: {rec.get('skipped')}")
            check(rec["repetitions"] == 0, f"{rec['name']}: skipped but timed")
    # brute force holds no index: it runs unless the RSS it grew while building was over the limit
    for model in (SMALL, LARGER):
        build, _ = table[(model, "brute_force")]
        check("skipped" not in build or "over memory limit" in build["skipped"], f"brute force: {build}")
    check("larger models will be skipped: over memory limit" in proc.stderr, "no message about the memory skip")

    # A limit between the first index and the second one's extrapolation: skipped before building, by estimate.
    first = table[(SMALL, "nanoflann_kdtree")][0]
    per_point = max(first["index_bytes"], first["build_peak_rss_bytes"]) / first["n_points"]
    n_larger = table[(LARGER, "nanoflann_kdtree")][0]["n_points"]
    limit_gib = per_point * (first["n_points"] + n_larger) / 2 / GIB
    out = work / "estimate.json"
    run(SCALE_SMALL + ["--adapters", "nanoflann_kdtree", "--memory-limit-gib", repr(limit_gib), "--out", str(out)])
    table = by_model_adapter(load(out)["benchmarks"])
    build, cells = table[(SMALL, "nanoflann_kdtree")]
    check("skipped" not in build and "skipped" not in cells[0], "under the limit at the first size, yet skipped")
    if "skips_larger_models" not in build:  # its RSS growth may differ from the first run's; then it closes instead
        build, cells = table[(LARGER, "nanoflann_kdtree")]
        for rec in [build] + cells:
            check(rec.get("skipped", "").startswith("over memory limit: estimated"),
                  f"{rec['name']}: not skipped by the estimate: {rec.get('skipped')}")
    # no limit worth the name: nothing skipped
    out = work / "no_limit.json"
    run(SCALE_SMALL + adapters + ["--memory-limit-gib", "8", "--out", str(out)])
    # (a loaded machine may still stop brute force by the time budget: only memory skips are wrong here)
    memory_skips = [r["name"] for r in load(out)["benchmarks"] if "memory" in r.get("skipped", "")]
    check(not memory_skips, f"skipped for memory under an 8 GiB limit: {memory_skips}")
    for bad in ("0", "-1", "nan", "x"):
        run(SCALE_SMALL + adapters + ["--memory-limit-gib", bad, "--out", str(work / "bad.json")], expect=2)
    check(not (work / "bad.json").exists(), "a bad memory limit wrote a file")


def case_scale_budget():
    """Over the time budget at one model size: the adapter is skipped at every larger size, also on resume."""
    work = fresh_workdir()
    args = SCALE_SMALL + ["--adapters", "brute_force,nanoflann_kdtree"]
    out = work / "budget.json"
    run(args + ["--budget", "1e-9", "--out", str(out)])
    doc = load(out)
    check(doc["context"]["config"]["skip_larger_models"] is True, "scale experiment without skip_larger_models")
    check_scale_fields(doc)
    table = by_model_adapter(doc["benchmarks"])
    for adapter in ("brute_force", "nanoflann_kdtree"):
        build, cells = table[(SMALL, adapter)]
        check("skipped" not in build and "skipped" not in cells[0], f"{adapter}: skipped at the first size")
        check(build.get("skips_larger_models", "").startswith("over budget: build"),
              f"{adapter}: build over a 1 ns budget does not close larger models: {build}")
        build, cells = table[(LARGER, adapter)]
        for rec in [build] + cells:
            check(f"skipped on models of {table[(SMALL, adapter)][0]['n_points']} points and more: over budget"
                  in rec.get("skipped", ""), f"{rec['name']}: not skipped for the budget: {rec.get('skipped')}")
    # killed after the first size, resumed: the closure is read back from the file
    killed = work / "killed.json"
    proc = run(args + ["--budget", "1e-9", "--out", str(killed)], env={"NNB_SWEEP_ABORT_AFTER_CELLS": "4"},
               expect=None)
    check(proc.returncode == -9, f"the fault-injected run was not killed (exit {proc.returncode})")
    check(len(load(killed)["benchmarks"]) == 4, "the killed run did not stop after the first size")
    run(args + ["--budget", "1e-9", "--out", str(killed), "--resume"])
    # the reasons quote measured times: compare them with the times blanked out
    skips = lambda path: {r["name"]: re.sub(r"[0-9.e+-]+ s\b", "T s", r.get("skipped", ""))
                          for r in load(path)["benchmarks"]}
    check(skips(killed) == skips(out), f"resumed run skips differently:\n{skips(killed)}\n{skips(out)}")
    # a generous budget closes nothing
    out = work / "generous.json"
    run(args + ["--budget", "100", "--out", str(out)])
    recs = load(out)["benchmarks"]
    check(not any("skipped" in r or "skips_larger_models" in r for r in recs), "skipped under a 100 s budget")
    by_name = {r["name"]: r for r in recs}
    for model in (SMALL, LARGER):
        cell = by_name[f"sweep/{model}/city-tls-15k/nanoflann_kdtree/ranged/max_dist:0.10"]
        check(cell.get("agrees") is True and cell["found"] > 0, f"{cell['name']}: {cell}")


def case_hostile_values():
    """Values that could run nothing, wrap or allocate gigabytes: each is one line and exit 2."""
    work = fresh_workdir()
    experiments = {"fractional_repetitions": {"repetitions": 1.5}, "negative_points": {"synthetic_points": -1},
                   "huge_k": {"k": [2147483648]}, "zero_step": {"dists": "0:1:0"},
                   "huge_build_repetitions": {"build_repetitions": 2000000000}}
    cases = [["--points", "-1"], ["--dists", "0:1:1e-300"], ["--dists", "0:100:0.000001"],
             ["--dists", "0:0.000000001:0.0000000001"], ["--repetitions", "2000000000"], ["--budget", "inf"],
             ["--min-time", "inf"], ["--cell-timeout", "inf"]]
    for label, fields in experiments.items():
        path = work / f"{label}.json"
        path.write_text(json.dumps(dict({"name": label, "pairs": [{"model": "hollow_sphere", "query": "hollow_cube"}],
                                         "adapters": ["brute_force"]}, **fields)))
        cases.append(["--experiment", str(path)])
    for i, extra in enumerate(cases):
        out = work / f"out{i}.json"
        args = with_flags(TINY, extra) if "--experiment" not in extra else ["--points", "300"] + extra
        proc = run(args + ["--adapters", "brute_force", "--out", str(out)], expect=2)
        lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
        check(len(lines) == 1 and lines[0].startswith("run_sweep: error: "), f"{extra}: not one error line: {lines}")
        check("(see --help)" not in lines[0], f"{extra}: refused as a command line, not as a value: {lines[0]}")
        check(len(lines[0]) < 200, f"{extra}: an error line of {len(lines[0])} characters")
        check(not out.exists(), f"{extra}: wrote a results file")
    # numbers in a message as typed, not as %f would print them
    proc = run(with_flags(TINY, ["--dists", "0:1e300:1"]) + ["--out", str(work / "big.json")], expect=2)
    check("0:1e+300 by 1 m" in proc.stderr, f"--dists 0:1e300:1: {proc.stderr.strip()}")


def case_files():
    """The results file: never over an input, checked before work, one writer, clean interrupts, markers."""
    work = fresh_workdir()
    args = TINY + ["--adapters", "brute_force"]
    # an input file as --out, a directory, an unwritable place: refused at once, the input untouched
    cloud = work / "cloud.xyz"
    cloud.write_text("".join(f"{i * 0.01} {i * 0.02} {i * 0.03}\n" for i in range(50)))
    before = cloud.read_bytes()
    run(["--datasets", str(cloud), "--dists", "0:0.1:0.05", "--adapters", "brute_force", "--out", str(cloud)],
        expect=2)
    check(cloud.read_bytes() == before, "an input file was overwritten")
    for bad_out in (str(work), str(cloud / "results.json")):  # a folder, and a path under a file
        proc = run(args + ["--out", bad_out], expect=2)
        lines = [l for l in proc.stderr.splitlines() if l.strip() and "WARNING" not in l]
        check(len(lines) == 1, f"{bad_out}: not one line: {proc.stderr!r}")
    # a second writer of the same file is refused while the first holds it
    import fcntl
    out = work / "locked.json"
    with open(str(out) + ".lock", "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        proc = run(args + ["--out", str(out)], expect=2)
        check("another process" in proc.stderr, f"lock: {proc.stderr!r}")
    Path(str(out) + ".lock").unlink()
    check(not out.exists(), "the refused writer wrote the file")
    # stale temporaries of a killed writer are removed; the lock file goes when the run ends
    out = work / "sweep.json"
    stale = work / ".sweep.json.tmp.999999999"
    stale.write_text("half")
    run(args + ["--out", str(out)])
    check(not stale.exists(), "a stale temporary was left")
    check(not Path(str(out) + ".lock").exists(), "the lock file was left")
    # a non-finite number is written as a marker that --resume reads back
    doc = load_raw(out)
    last_cell = [r for r in doc["benchmarks"] if r["type"] == "sweep"][-1]["run_name"]
    doc["benchmarks"] = [r for r in doc["benchmarks"] if r["run_name"] != last_cell]
    marked = [r for r in doc["benchmarks"] if "dist_sum" in r][-1]
    marked["dist_sum"] = "inf"
    out.write_text(json.dumps(doc))
    run(args + ["--out", str(out), "--resume"])
    cells = {r["name"]: r for r in load(out)["benchmarks"]}
    check(cells[marked["run_name"]]["dist_sum"] == "inf", "marker not kept on resume")
    check(last_cell in cells, "the removed cell was not run again")
    # SIGTERM: the checkpoint is finished, one line names the resume command, --resume completes the cells
    import signal
    import time
    slow = ["--points", "3000", "--dists", "0:0.5:0.02", "--repetitions", "3", "--adapters", "brute_force",
            "--datasets", "filled_cube"]
    whole, stopped = work / "whole.json", work / "stopped.json"
    run(slow + ["--out", str(whole)])
    proc = subprocess.Popen([RUN_SWEEP] + slow + ["--out", str(stopped)], stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while not stopped.exists() and time.time() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    check(proc.returncode == 128 + signal.SIGTERM, f"SIGTERM: exit {proc.returncode}: {err[-2000:]}")
    check("--resume" in err.splitlines()[-1], f"no resume command: {err[-500:]}")
    n_stopped = len(load(stopped)["benchmarks"])
    n_whole = len(load(whole)["benchmarks"])
    check(0 < n_stopped < n_whole, f"stopped run recorded {n_stopped} of {n_whole}")
    check(not list(work.glob(".*.tmp.*")) and not list(work.glob("*.lock")), "files left after SIGTERM")
    run(slow + ["--out", str(stopped), "--resume"])
    check(sorted(r["name"] for r in load(stopped)["benchmarks"]) ==
          sorted(r["name"] for r in load(whole)["benchmarks"]), "resume after SIGTERM gave other cells")


def case_isolation():
    """A library that crashes or hangs costs its own cells, recorded failed with the reason; the rest run."""
    work = fresh_workdir()
    args = TINY + ["--adapters", "brute_force,nanoflann_kdtree,ours_kdtree", "--datasets", "hollow_sphere:hollow_cube"]
    # A crash is SIGSEGV, or SIGABRT where AddressSanitizer catches the fault first.
    for fault, extra, reason in (("NNB_SWEEP_CRASH_ADAPTER", [], "crashed: killed by signal "),
                                 ("NNB_SWEEP_HANG_ADAPTER", ["--cell-timeout", "2"], "timed out: ")):
        out = work / f"{fault}.json"
        run(args + extra + ["--out", str(out)], env={fault: "nanoflann_kdtree"})
        recs = load(out)["benchmarks"]
        faulty = [r for r in recs if r["adapter"] == "nanoflann_kdtree"]
        healthy = [r for r in recs if r["adapter"] != "nanoflann_kdtree" and r["type"] == "sweep"]
        check(faulty and all(r["type"] == "build" or r.get("skipped", "").startswith(reason) for r in faulty),
              f"{fault}: faulty cells not recorded failed: {[r.get('skipped') for r in faulty]}")
        check(healthy and all("skipped" not in r and r["agrees"] for r in healthy), f"{fault}: others did not run")
        # --resume does not run the failed cells again; --retry-failed does
        before = out.read_bytes()
        run(args + extra + ["--out", str(out), "--resume"])
        check([r.get("skipped") for r in load(out)["benchmarks"]] == [r.get("skipped") for r in recs],
              f"{fault}: --resume retried failed cells")
        run(args + extra + ["--out", str(out), "--resume", "--retry-failed"])
        retried = [r for r in load(out)["benchmarks"] if r["adapter"] == "nanoflann_kdtree"]
        check(len(retried) == len(faulty) and all("skipped" not in r for r in retried),
              f"{fault}: --retry-failed left {[r.get('skipped') for r in retried]}")
        check(out.read_bytes() != before, "nothing changed on retry")


MERGE = Path(__file__).resolve().parents[1] / "plots" / "merge_results.py"
SHARD_RUN = ["--points", "300", "--dists", "0:0.3:0.1", "--repetitions", "1",
             "--adapters", "brute_force,nanoflann_kdtree,ours_kdtree",
             "--datasets", "hollow_sphere:hollow_cube,filled_cube"]


def merge(paths, out, expect):
    proc = subprocess.run([sys.executable, str(MERGE)] + [str(p) for p in paths] + ["--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    check(proc.returncode == expect, f"merge of {[Path(p).name for p in paths]} exited {proc.returncode}, expected "
                                     f"{expect}:\n{proc.stderr[-2000:]}")
    return proc


def check_plan_balanced():
    plan = json.loads(run(SHARD_RUN + ["--plan", "--json", "--shard", "1/3"]).stdout)
    check(plan["shards"] == 3 and len(plan["shard_cost"]) == 3, f"plan shards: {plan['shards']}")
    check(sum(plan["shard_cells"]) == plan["total_cells"] == sum(u["cells"] for u in plan["units"]),
          "plan: cells of the shards do not add up to the total")
    check(len(plan["units"]) == 6 and all(0 <= u["shard"] < 3 for u in plan["units"]), "plan: units or shards")
    check(len(plan["cells"]) == plan["shard_cells"][1], "plan: the shard's cell names")
    # longest-first assignment is within 4/3 of the best makespan, itself at least the mean and the largest unit
    bound = max(sum(plan["shard_cost"]) / 3, max(u["cost"] for u in plan["units"]))
    check(max(plan["shard_cost"]) <= 4 / 3 * bound + 1e-12, f"unbalanced plan: {plan['shard_cost']}")
    # brute force, the slow one, is weighted above the trees on the same data
    cost = {(u["model"], u["adapter"]): u["cost"] for u in plan["units"]}
    check(cost[("hollow_sphere", "brute_force")] > cost[("hollow_sphere", "ours_kdtree")], "adapter factor")
    # the slow libraries' measured factors, where the build has them
    listed = subprocess.run([str(Path(RUN_SWEEP).parent / "nns_query"), "--list"], capture_output=True, text=True,
                            timeout=300).stdout
    measured = {"itk_kdtree": 8, "hnswlib_hnsw": 8, "alglib_kdtree": 5, "openvdb_pointindex": 4}
    slow = [a for a in measured if a in listed]
    if slow:
        args = SHARD_RUN[:SHARD_RUN.index("--adapters")] + ["--adapters", ",".join(slow + ["ours_kdtree"]),
                                                              "--datasets", "filled_cube"]
        weighed = json.loads(run(args + ["--plan", "--json", "--shard", "0/2"]).stdout)
        per_cell = {u["adapter"]: u["cost"] / u["cells"] for u in weighed["units"]}
        for a in slow:
            factor = per_cell[a] / per_cell["ours_kdtree"]
            check(abs(factor - measured[a]) < 1e-9, f"{a}'s factor: {factor}")
    text = run(SHARD_RUN + ["--plan", "--shard", "1/3"]).stdout
    check("3 shards" in text and "<- this shard" in text and "units of shard 1/3" in text, f"plan text:\n{text}")
    return plan


def case_shards():
    work = fresh_workdir()
    plan = check_plan_balanced()
    check(not list(work.iterdir()), "--plan wrote files")
    whole = work / "whole.json"
    run(SHARD_RUN + ["--out", str(whole)])
    shards = [work / f"s{i}.json" for i in range(3)]
    for i, path in enumerate(shards):
        run(SHARD_RUN + ["--shard", f"{i}/3", "--out", str(path)])
    merged = work / "merged.json"
    merge(shards, merged, 0)
    whole_recs, merged_doc = load(whole)["benchmarks"], load(merged)
    check([r["name"] for r in merged_doc["benchmarks"]] == [r["name"] for r in whole_recs],
          "merged cells differ from the single run's (or their order)")
    for a, b in zip(merged_doc["benchmarks"], whole_recs):
        for field in ("found", "neighbours", "agrees", "checked_against", "skipped"):
            check(a.get(field) == b.get(field), f"{a['name']}: {field} {a.get(field)!r} != {b.get(field)!r}")
    check(all(load(p)["context"]["shard"]["units"] == [dict(u) for u in plan["units"]] for p in shards),
          "every shard carries the whole plan")
    context = merged_doc["context"]
    check("shard" not in context and "shard" not in context["config"], "the merged context still names a shard")
    check(context["config"] == load(whole)["context"]["config"], "merged config differs from the single run's")
    check([m["shard"] for m in context["merged_from"]] == ["0/3", "1/3", "2/3"], "merged_from")
    # a shard file refuses a resume as another shard
    refused = run(SHARD_RUN + ["--shard", "2/3", "--out", str(shards[0]), "--resume"], expect=2)
    check("configuration" in refused.stderr, f"unclear refusal: {refused.stderr}")
    # a missing shard is reported by its units, and nothing is written
    proc = merge(shards[:2], work / "partial.json", 1)
    check("shard 2/3 missing" in proc.stderr and not (work / "partial.json").exists(), proc.stderr)
    # a missing cell is reported by name
    cut = load_raw(shards[1])
    lost = cut["benchmarks"][-1]["run_name"]
    cut["benchmarks"] = [r for r in cut["benchmarks"] if r["run_name"] != lost]
    (work / "cut.json").write_text(json.dumps(cut))
    proc = merge([shards[0], work / "cut.json", shards[2]], work / "partial.json", 1)
    check(lost in proc.stderr, f"the missing cell is not named: {proc.stderr}")
    # shards of another configuration are refused
    other = work / "other.json"
    other_run = [("2" if arg == "1" else arg) for arg in SHARD_RUN]  # two repetitions instead of one
    run(other_run + ["--shard", "2/3", "--out", str(other)])
    proc = merge([shards[0], shards[1], other], work / "mixed.json", 2)
    check("configuration" in proc.stderr and not (work / "mixed.json").exists(), proc.stderr)
    merge([shards[0], shards[0], shards[1]], work / "twice.json", 2)
    # bad --shard values exit 2 and write nothing
    for bad in ("3/3", "1", "-1/3", "0/0", "a/3", "1/3/4"):
        run(SHARD_RUN + ["--shard", bad, "--out", str(work / "bad.json")], expect=2)
    check(not (work / "bad.json").exists(), "a bad --shard wrote a file")
    # the default results file names its shard
    (work / "results").mkdir()
    proc = subprocess.run([os.path.abspath(RUN_SWEEP)] + SHARD_RUN + ["--shard", "0/3"], cwd=work,
                          capture_output=True, text=True, timeout=300)
    check(proc.returncode == 0 and (work / "results" / "sweep_quick.shard-0-of-3.json").exists(),
          f"default shard file: {proc.stderr[-1000:]}")


CASES = {"isolation": case_isolation, "hostile_values": case_hostile_values, "files": case_files, "fields": case_fields, "min_time": case_min_time, "threads": case_threads,
         "compare_py": case_compare_py, "table1": case_table1, "strategies": case_strategies, "resume": case_resume, "budget": case_budget, "bad_input": case_bad_input,
         "quick_tiny": case_quick_tiny, "scale_memory": case_scale_memory,
         "scale_budget": case_scale_budget, "shards": case_shards, "rounds": case_rounds}

if __name__ == "__main__":
    CASES[CASE]()
    print(f"ok [{CASE}]")
