# The medians of a joined library's run_sweep results as tables (python3 results/ab/joined_summary.py FILE
# ADAPTER): ms a call per pair for the builds, each search and strategy, and ADAPTER's time over each other
# adapter's, each with its default strategies (as the file's context declares them).
import json, sys
d = json.load(open(sys.argv[1]))
subject = sys.argv[2]
info = d["context"]["adapters"]
med = [b for b in d["benchmarks"] if b.get("aggregate_name") == "median"]
pairs = list(dict.fromkeys(b["model"] for b in med))
ms = {}
for b in med:
    key = ("build",) if b["type"] == "build" else (b["search"], b["strategy"])
    ms[key + (b["model"], b["adapter"])] = b["median_s"] * 1e3
cols = sorted({k[:-2] + (k[-1],) for k in ms}, key=lambda c: (c[0] != "build", c[0] != "knn", c[-1] != subject, c))
print(f"{'pair':26}" + "".join(f"{' '.join(c[::-1]):>36}" for c in cols))
for p in pairs:
    cell = lambda c: ms.get(c[:-1] + (p, c[-1]))
    print(f"{p:26}" + "".join(f"{(f'{cell(c):.1f} ms' if cell(c) is not None else '-'):>36}" for c in cols))
for title, key in (("build", lambda a: ("build",)), ("1-NN, each default", lambda a: ("knn", info[a]["knn"])),
                   ("ranged 1-NN at 0.1 m, each default", lambda a: ("ranged", info[a]["ranged"]))):
    print(f"\n{subject} / each adapter, {title}, per pair:")
    for a in info:
        ratios = [ms[key(subject) + (p, subject)] / ms[key(a) + (p, a)] for p in pairs
                  if key(a) + (p, a) in ms and key(subject) + (p, subject) in ms]
        if a != subject and ratios:
            label = f" ({key(a)[1]})" if len(key(a)) > 1 else ""
            print(f"  / {a}{label}: " + ", ".join(f"{r:.2f}x" for r in ratios))
print(f"\nevery cell's answers agree with its check: {all(b.get('agrees', True) for b in med)}")
