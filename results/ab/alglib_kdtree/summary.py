# The medians of results/ab/alglib_kdtree/real_0.1m_results.json as tables (python3 summary.py FILE): ms a call
# per pair for the builds, 1-NN and every ranged strategy, and ALGLIB's against each adapter's default.
import json, sys
d = json.load(open(sys.argv[1]))
med = [b for b in d["benchmarks"] if b.get("aggregate_name") == "median"]
pairs = ["office-sick-3dtk", "office-kinect-pcl", "velodyne-hdl32-fastgicp", "kitti00-hdl64-gtsampoints", "bunny-stanford"]
defaults = {"alglib_kdtree": "via_knn", "cgal_kdtree": "via_knn", "nanoflann_kdtree": "native",
            "nanoflann_latest": "native", "ours_kdtree": "native"}
ms = {}
for b in med:
    key = ("build",) if b["type"] == "build" else (b["search"], b["strategy"])
    ms[key + (b["model"], b["adapter"])] = b["median_s"] * 1e3
cols = sorted({k[:-2] + (k[-1],) for k in ms}, key=lambda c: (c[0] != "build", c[0] != "knn", c[-1] != "alglib_kdtree", c))
print(f"{'pair':26}" + "".join(f"{' '.join(c[::-1]):>34}" for c in cols))
for p in pairs:
    cell = lambda c: ms.get(c[:-1] + (p, c[-1]))
    print(f"{p:26}" + "".join(f"{(f'{cell(c):.1f} ms' if cell(c) is not None else '-'):>34}" for c in cols))
for title, key in (("build", lambda a: ("build",)), ("1-NN", lambda a: ("knn", "native")),
                   ("ranged 1-NN at 0.1 m, each default", lambda a: ("ranged", defaults[a]))):
    print(f"\nalglib_kdtree / each adapter, {title}, per pair:")
    for a in defaults:
        if a != "alglib_kdtree":
            ratios = [ms[key("alglib_kdtree") + (p, "alglib_kdtree")] / ms[key(a) + (p, a)] for p in pairs
                      if key(a) + (p, a) in ms and key("alglib_kdtree") + (p, "alglib_kdtree") in ms]
            print(f"  / {a}: " + ", ".join(f"{r:.2f}x" for r in ratios))
print(f"\nevery cell's answers agree with its check: {all(b.get('agrees', True) for b in med)}")
