#!/usr/bin/env python3
"""scripts/cache_counts.py: brute force and ours_kdtree on a 2,000-point pair give a row each of counts a query
(the second batch's); brute force executes far more instructions a query than the tree, and its scan streams 48 KB
of points through the simulated 32 KiB L1, so it misses at least (48,000 - 32,768) / 64 lines a query; branches and
mispredicts are counted; the counts are the same in a second run; --cold counts the first batch, which sets up ours'
scratch, so more instructions; an adapter's parameters (ours_kdtree[bucket_size=1,order=caller]) reach nns_query and
label the row; --resume counts only the rows missing; bad arguments exit 2 with one line and write no file.

Usage: test_cache_counts.py CACHE_COUNTS_PY NNS_QUERY WORK_DIR. Counts from Valgrind's simulation, never a
timing, so nothing here depends on the machine."""
import shutil
import subprocess
import sys
from pathlib import Path


def run(script, args, expect):
    proc = subprocess.run(["/usr/bin/python3", script] + args, capture_output=True, text=True, timeout=280)
    if proc.returncode != expect:
        raise AssertionError(f"{' '.join(args)}: exit {proc.returncode}, expected {expect}\n{proc.stderr[-800:]}")
    return proc


def rows_of(path):
    lines = [line for line in Path(path).read_text().splitlines() if not line.startswith("#")]
    columns = lines[0].split("\t")
    return [dict(zip(columns, line.split("\t"))) for line in lines[1:]]


def main(script, nns_query, work):
    work = Path(work)
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    common = ["--pairs", "hollow_cube:hollow_sphere", "--points", "2000", "--nns-query", nns_query]
    out = work / "counts.tsv"
    run(script, common + ["--adapters", "brute_force,ours_kdtree", "--out", str(out)], 0)
    text = out.read_text()
    for needle in ("# cache_counts: ", "# binary: ", "# simulated caches: I1 32768,8,64", "LL 2097152,16,64"):
        assert needle in text, f"no '{needle}' in the header:\n{text}"
    rows = {r["adapter"]: r for r in rows_of(out)}
    assert sorted(rows) == ["brute_force", "ours_kdtree"], f"rows {sorted(rows)}"
    brute, tree = rows["brute_force"], rows["ours_kdtree"]
    assert brute["queries"] == tree["queries"] == "2000" and brute["found"] == tree["found"], f"{brute} {tree}"
    assert float(brute["instructions"]) > 10 * float(tree["instructions"]) > 0, f"{brute} {tree}"
    assert float(brute["d1_misses"]) >= (48000 - 32768) / 64, f"brute force's scan missed too little: {brute}"
    for row in (brute, tree):
        assert 0 <= float(row["mispredicts"]) <= float(row["branches"]) > 0, f"branch counts: {row}"
    cold = work / "cold.tsv"
    run(script, common + ["--adapters", "ours_kdtree", "--cold", "--out", str(cold)], 0)
    first = rows_of(cold)[0]
    assert "batch first (cold" in cold.read_text() and "batch second (warm" in text, "the header names no batch"
    assert float(first["instructions"]) > float(tree["instructions"]), f"cold {first} against warm {tree}"
    assert first["found"] == tree["found"], f"cold {first} against warm {tree}"
    # parameters in a label reach the search: one-point buckets in the caller's order count otherwise, same answers;
    # the plain adapter beside it is the second run of the first's row, which must count the same
    labelled = work / "labelled.tsv"
    variant = "ours_kdtree[bucket_size=1,order=caller]"
    run(script, common + ["--adapters", f"ours_kdtree,{variant}", "--out", str(labelled)], 0)
    both = {r["adapter"]: r for r in rows_of(labelled)}
    assert sorted(both) == ["ours_kdtree", variant], f"rows {sorted(both)}"
    # the same instructions and branches exactly; simulated cache misses depend on where the heap lies too, which
    # threads a library starts as it is loaded (log4cplus, under OpenVDB) may move by a little between processes
    again = both["ours_kdtree"]
    layout = ("d1_misses", "ll_misses")
    assert {k: v for k, v in again.items() if k not in layout} == {k: v for k, v in tree.items() if k not in layout}, \
        f"a second run counted otherwise: {again} against {tree}"
    for k in layout:
        assert abs(float(again[k]) - float(tree[k])) <= max(0.1, 0.02 * float(tree[k])) + 1e-9, \
            f"a second run missed otherwise: {again} against {tree}"
    assert both[variant]["found"] == tree["found"], f"{both[variant]} against {tree}"
    assert both[variant]["instructions"] != tree["instructions"], f"the parameters changed nothing: {both}"
    # --resume keeps the rows there and counts only the others; other settings are refused
    resumed = work / "resumed.tsv"
    resumed.write_text(text)
    proc = run(script, common + ["--adapters", "brute_force,ours_kdtree,ours_octree", "--resume", "--out",
                                 str(resumed)], 0)
    counted = [line for line in proc.stderr.splitlines() if line.startswith("cache_counts: hollow_cube")]
    assert len(counted) == 1 and " ours_octree: " in counted[0], f"--resume counted {counted}"
    assert [r["adapter"] for r in rows_of(resumed)] == ["brute_force", "ours_kdtree", "ours_octree"]
    assert rows_of(resumed)[:2] == rows_of(out), "--resume changed the rows it kept"
    before = resumed.read_text()
    proc = run(script, common + ["--adapters", "ours_kdtree", "--max-dist", "0.2", "--resume", "--out",
                                 str(resumed)], 2)
    assert "other settings" in proc.stderr and resumed.read_text() == before, proc.stderr
    bad = work / "bad.tsv"
    for args in (["--adapters", "no_such_adapter"], ["--pairs", "no_such_shape"], ["--max-dist", "0"],
                 ["--nns-query", "/no/such/binary"], ["--points", "0"], ["--adapters", "ours_kdtree[no_such=1]"],
                 ["--adapters", "ours_kdtree[bucket_size]"], ["--adapters", "ours_kdtree[]"],
                 ["--adapters", "ours_kdtree[bucket_size=1"]):
        proc = run(script, common + ["--adapters", "ours_kdtree"] + args + ["--out", str(bad)], 2)
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("cache_counts: error: "), f"{args}: {proc.stderr}"
        assert not bad.exists(), f"{args} left {bad}"
    print("ok")


if __name__ == "__main__":
    main(*sys.argv[1:])
