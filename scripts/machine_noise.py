#!/usr/bin/env python3
"""How steadily this machine times: python3 scripts/machine_noise.py --micro-nns PATH [--limit X]
                                   python3 scripts/machine_noise.py --results MICRO_NNS.json

A benchmark's spread is its slowest repetition's CPU time over its fastest's. --micro-nns runs a few of
micro_nns's benchmarks now (the two nanoflanns on Figure 3 at 0.1 m, repetitions interleaved) and prints the
largest of their spreads; with --limit it exits 1 when that is above the limit. The load average does not show a
busy host under a virtual machine; this does, for the seconds it runs. --results reads a finished micro_nns run
and prints the median and largest spread over its benchmarks: how noisy the run itself was. Exit 2, one line:
micro_nns failed, or no repetitions to read."""
import argparse
import collections
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

PROBE = "^Ranged1NN/fig3/nanoflann_(kdtree|latest)/0.10$"
REPETITIONS = 7


def fail(message):
    print(f"machine_noise: error: {message}", file=sys.stderr)
    sys.exit(2)


def run_probe(micro_nns, out):
    """micro_nns's probe benchmarks, their repetitions written to out (JSON)."""
    cmd = [micro_nns, f"--benchmark_filter={PROBE}", f"--benchmark_repetitions={REPETITIONS}",
           "--benchmark_min_time=0.1", "--benchmark_enable_random_interleaving=true",
           f"--benchmark_out={out}", "--benchmark_out_format=json"]
    try:
        proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    except OSError as e:
        fail(f"cannot run {micro_nns}: {e.strerror}")
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        fail(f"{micro_nns} exited {proc.returncode}: {last}")


def spreads(doc):
    """{benchmark: slowest repetition's CPU time / fastest's} of every benchmark with two repetitions or more."""
    times = collections.defaultdict(list)
    for record in doc.get("benchmarks", []):
        if record.get("run_type") == "iteration" and isinstance(record.get("cpu_time"), (int, float)):
            times[record["run_name"]].append(float(record["cpu_time"]))
    return {name: max(t) / min(t) for name, t in times.items() if len(t) >= 2 and min(t) > 0}


def read_json(path):
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError) as e:
        fail(f"cannot read {path} as JSON ({e})")


def summarise_run(path):
    """The median and largest spread of a finished micro_nns run's benchmarks."""
    found = spreads(read_json(path))
    if not found:
        fail(f"{path} holds no benchmark with two repetitions or more")
    ordered = sorted(found.values())
    worst = max(found, key=found.get)
    print(f"spread median {statistics.median(ordered):.3f}, largest {ordered[-1]:.3f} ({worst}) over "
          f"{len(found)} benchmarks")
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--micro-nns", help="the micro_nns binary to probe the machine with")
    source.add_argument("--results", help="a finished micro_nns run's JSON (--benchmark_out) to read")
    parser.add_argument("--limit", type=float, help="with --micro-nns: exit 1 when the spread is above this")
    args = parser.parse_args()
    if args.results:
        return summarise_run(args.results)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "probe.json"
        run_probe(args.micro_nns, out)
        doc = read_json(out)
    found = spreads(doc)
    if not found:
        fail(f"micro_nns ran no repetitions of {PROBE} (a build without the nanoflanns?)")
    worst = max(found.values())
    detail = "; ".join(f"{name} {value:.3f}" for name, value in sorted(found.items()))
    print(f"spread {worst:.3f} over {REPETITIONS} repetitions ({detail})")
    return 1 if args.limit is not None and worst > args.limit else 0


if __name__ == "__main__":
    sys.exit(main())
