#!/usr/bin/env python3
"""Instructions, simulated cache misses and mispredicted branches a query, per library: each adapter answers a
ranged 1-NN batch in nns_query under Valgrind's callgrind, which counts only inside the search call (not loading,
building or writing rows) and simulates one cache geometry and one branch predictor for every library and machine.
The batch counted is the second of two, as micro_nns times a batch (the index, its scratch and the caches as the
first left them; the second run's counts less the first's); --cold counts the first batch in a fresh process. The
counts are the same on every run, so they stand where this machine kind's timings are too noisy, and they put
numbers on the paper's cache argument where the machine exposes no hardware counters. A simulation, not the CPU:
no prefetchers, one cache level below L1, and a 2-bit counter a branch, which a CPU's history-based predictor beats
(at a loop's exit above all), so mispredicts compare libraries on one model rather than give cycles.

  scripts/cache_counts.py [--adapters A,B[NAME=VALUE,...]] [--pairs MODEL:QUERY|PAIR,...] [--max-dist M]
                          [--points N] [--cold] [--nns-query PATH] [--resume] --out FILE

An adapter may carry parameters as micro_nns labels them, ours_kdtree[order=caller,bucket_size=8]: each is
passed to nns_query as --param, and the label names the row, so variants of one library sit side by side.

The file is rewritten atomically after every row, so a killed run loses at most the row in flight; --resume
keeps the rows of a file made by the same binary with the same settings and counts only the others.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from typing import NamedTuple
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
# Ours, the nanoflanns, FLANN and 3DTK's pointer-based tree. Not ANN by default: its ranged search gathers every
# point within the distance before keeping the nearest, hours under callgrind on the dense Kinect pair at 0.1 m.
DEFAULT_ADAPTERS = ["ours_kdtree", "ours_octree", "nanoflann_kdtree", "nanoflann_latest", "flann_kdtree",
                    "simple_kdtree"]
DEFAULT_PAIRS = ["hollow_cube:hollow_sphere", "office-sick-3dtk", "office-kinect-pcl"]
# L1: 32 KiB, 8-way; the last level: 2 MiB, 16-way (a core's L2 on this machine kind's CPUs); 64-byte lines.
CACHES = {"I1": "32768,8,64", "D1": "32768,8,64", "LL": "2097152,16,64"}
COLUMNS = ["pair", "adapter", "max_dist_m", "queries", "found", "instructions", "data_reads", "data_writes",
           "d1_misses", "ll_misses", "branches", "mispredicts"]


def die(message):
    print(f"cache_counts: error: {message}", file=sys.stderr)
    sys.exit(2)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--adapters", default=",".join(DEFAULT_ADAPTERS),
                   help="comma-separated adapters, each NAME or NAME[PARAM=VALUE,...]")
    p.add_argument("--pairs", default=",".join(DEFAULT_PAIRS),
                   help="comma-separated MODEL:QUERY (shapes or files) or real pair names")
    p.add_argument("--max-dist", type=float, default=0.1, help="maximal distance, metres")
    p.add_argument("--points", type=int, help="points per synthetic set (nns_query's default otherwise)")
    p.add_argument("--cold", action="store_true", help="count the first batch in a fresh process, not the second")
    p.add_argument("--nns-query", default=str(HERE / "build/release/bench/nns_query"), help="the binary to count")
    p.add_argument("--out", required=True, help="results file (TSV with a commented header), written atomically")
    p.add_argument("--resume", action="store_true", help="keep the rows --out already holds; count the others")
    args = p.parse_args()
    if not args.max_dist > 0:
        die(f"--max-dist must be above 0 (got {args.max_dist})")
    if args.points is not None and args.points < 1:
        die(f"--points must be at least 1 (got {args.points})")
    if not (os.path.isfile(args.nns_query) and os.access(args.nns_query, os.X_OK)):
        die(f"no executable nns_query at {args.nns_query} (build the release preset, or give --nns-query)")
    if shutil.which("valgrind") is None:
        die("valgrind is not installed (scripts/install_deps.sh installs it)")
    return args


def known_adapters(nns_query):
    listing = subprocess.run([nns_query, "--list"], capture_output=True, text=True, check=True).stdout
    return [line.split("\t")[0] for line in listing.splitlines() if line.strip()]


def split_labels(text):
    """The comma-separated adapter labels of text; commas inside a label's brackets separate its parameters."""
    labels, depth, start = [], 0, 0
    for i, c in enumerate(text + ","):
        depth += {"[": 1, "]": -1}.get(c, 0)
        if c == "," and depth == 0:
            labels.append(text[start:i].strip())
            start = i + 1
    if depth != 0:
        die(f"unbalanced brackets in --adapters '{text}'")
    return [label for label in labels if label]


class Label(NamedTuple):
    """An adapter label as given (it names the row), the adapter it names and its parameters (NAME=VALUE each)."""
    text: str
    adapter: str
    params: list


def adapter_and_params(label):
    """The adapter a label names and its parameters (NAME=VALUE each), for nns_query's --param."""
    m = re.fullmatch(r"([A-Za-z0-9_]+)(?:\[([^\[\]]*)\])?", label)
    if m is None:
        die(f"adapter '{label}' is not NAME or NAME[PARAM=VALUE,...]")
    params = [p.strip() for p in (m.group(2) or "").split(",") if p.strip()]
    for param in params:
        if not re.fullmatch(r"[A-Za-z0-9_]+=\S+", param):
            die(f"parameter '{param}' of '{label}' is not NAME=VALUE")
    if m.group(2) is not None and not params:
        die(f"adapter '{label}' has empty brackets")
    return m.group(1), params


def model_and_query(pair):
    model, _, query = pair.partition(":")
    return model, query or model


def totals(callgrind_out):
    """The events callgrind counted, by name."""
    events = values = None
    for line in Path(callgrind_out).read_text().splitlines():
        if line.startswith("events:"):
            events = line.split()[1:]
        elif line.startswith("totals:"):
            values = [int(v) for v in line.split()[1:]]
    if events is None or values is None:
        raise RuntimeError(f"no totals in {callgrind_out}")
    return dict(zip(events, values + [0] * (len(events) - len(values))))


def run_batches(args, pair, label, batches, work):
    """The events callgrind counted over the first `batches` batches of one adapter on one pair, and nns_query's
    statistics."""
    model, query = model_and_query(pair)
    cg_out, stats, rows = work / "callgrind.out", work / "stats.json", work / "rows.csv"
    # Every counted process starts alike: whether its output files already exist changes a batch's counts
    # (results/ab/cache_counts_output_files_probe.txt).
    for path in (cg_out, stats, rows):
        path.unlink(missing_ok=True)
    cmd = ["valgrind", "--tool=callgrind", "--cache-sim=yes", "--branch-sim=yes", f"--callgrind-out-file={cg_out}",
           "--toggle-collect=nnb::SearchIndex::ranged*"]
    cmd += [f"--{level}={geometry}" for level, geometry in CACHES.items()]
    cmd += [args.nns_query, "--model", model, "--query", query, "--adapter", label.adapter, "--search", "ranged",
            "--k", "1", "--max-dist", repr(args.max_dist), "--repeat", str(batches), "--out", str(rows),
            "--stats", str(stats)]
    cmd += [arg for param in label.params for arg in ("--param", param)]
    if args.points is not None:
        cmd += ["--points", str(args.points)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        last = [line for line in proc.stderr.splitlines() if not line.startswith("==")][-1:] or ["no message"]
        raise RuntimeError(f"{label.text} on {pair} exited {proc.returncode}: {last[0]}")
    return totals(cg_out), json.loads(stats.read_text())


def count(args, pair, label, work):
    """One adapter's counted batch on one pair: the row of COLUMNS (counts a query)."""
    text = label.text
    t, s = run_batches(args, pair, label, 1, work)
    if not args.cold:
        two, _ = run_batches(args, pair, label, 2, work)
        t = {event: two[event] - t[event] for event in t}
        if min(t.values()) < 0:
            raise RuntimeError(f"{text} on {pair}: two batches counted less than one (counts not repeatable)")
    n = s["query_points"]
    if t.get("Ir", 0) == 0:
        raise RuntimeError(f"{text} on {pair}: nothing counted inside the search call")
    per_query = lambda v: f"{v / n:.1f}"
    return [pair, text, repr(args.max_dist), str(n), str(s["found"]), per_query(t["Ir"]), per_query(t["Dr"]),
            per_query(t["Dw"]), per_query(t["D1mr"] + t["D1mw"]), per_query(t["DLmr"] + t["DLmw"]),
            per_query(t["Bc"] + t["Bi"]), per_query(t["Bcm"] + t["Bim"])]


def header(args):
    version = subprocess.run([args.nns_query, "--version"], capture_output=True, text=True).stdout.strip()
    valgrind = subprocess.run(["valgrind", "--version"], capture_output=True, text=True).stdout.strip()
    return [f"# cache_counts: {datetime.now(timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')}; command: "
            + " ".join([sys.argv[0]] + sys.argv[1:]),
            f"# binary: {args.nns_query}: {version}; {valgrind} (callgrind, --cache-sim=yes --branch-sim=yes)",
            f"# settings: max_dist_m {args.max_dist!r}; points {args.points}; batch {batch_counted(args)}; {version}",
            "# simulated caches: " + ", ".join(f"{k} {v} (bytes,ways,line)" for k, v in CACHES.items()),
            "# counted inside SearchIndex::ranged only (the batch, not loading or building); one thread; ranged 1-NN,"
            " each adapter's default strategy; every count is a query's (instructions executed, data reads and"
            " writes, D1 and LL misses, reads and writes, conditional and indirect branches and their"
            " mispredictions)"]


def batch_counted(args):
    return "first (cold: a fresh process)" if args.cold else "second (warm: as micro_nns repeats a batch)"


def kept_rows(args, out, settings_line):
    """With --resume, the rows out already holds (made with the same binary and settings), by (pair, adapter)."""
    if not args.resume or not out.exists():
        return {}
    lines = out.read_text().splitlines()
    if settings_line not in lines:
        die(f"--resume: {out} was made with another binary or other settings ('{settings_line[2:]}' not in it)")
    rows = [line.split("\t") for line in lines if not line.startswith("#")][1:]
    return {(r[0], r[1]): r for r in rows if len(r) == len(COLUMNS)}


def write_atomically(out, lines, rows):
    partial = out.with_name(out.name + ".partial")
    partial.write_text("\n".join(lines + ["\t".join(COLUMNS)] + ["\t".join(r) for r in rows]) + "\n")
    os.replace(partial, out)


def main():
    args = parse_args()
    adapters = [Label(text, *adapter_and_params(text)) for text in split_labels(args.adapters)]
    pairs = [p for p in args.pairs.split(",") if p]
    if not adapters or not pairs:
        die("give at least one adapter and one pair")
    known = known_adapters(args.nns_query)
    for label in adapters:
        if label.adapter not in known:
            die(f"unknown adapter '{label.text}' (nns_query --list shows those built in)")
    out = Path(args.out)
    if not out.parent.is_dir():
        die(f"no folder {out.parent} for --out")
    lines = header(args)
    kept = kept_rows(args, out, lines[2])
    rows = []
    with tempfile.TemporaryDirectory(prefix="cache_counts_") as tmp:
        for pair in pairs:
            for label in adapters:
                if (pair, label.text) in kept:
                    rows.append(kept[(pair, label.text)])
                    continue
                try:
                    rows.append(count(args, pair, label, Path(tmp)))
                except RuntimeError as e:
                    die(str(e))
                row = dict(zip(COLUMNS, rows[-1]))
                print(f"cache_counts: {pair} {label.text}: {row['instructions']} instructions, {row['d1_misses']} D1"
                      f" misses, {row['ll_misses']} LL misses, {row['mispredicts']} mispredicts a query",
                      file=sys.stderr)
                write_atomically(out, lines, rows)
    write_atomically(out, lines, rows)


if __name__ == "__main__":
    main()
