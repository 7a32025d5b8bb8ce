# The medians of results/ab/itk_kdtree/real_0.1m_results.json as a table (python3 summary.py FILE): ms a call
# for every adapter and strategy, and ITK's default (via k-NN) against the others' defaults.
import json, sys
d = json.load(open(sys.argv[1]))
med = [b for b in d["benchmarks"] if b.get("aggregate_name") == "median" and b.get("type") == "sweep"]
pairs = ["office-sick-3dtk", "office-kinect-pcl", "velodyne-hdl32-fastgicp", "kitti00-hdl64-gtsampoints", "bunny-stanford"]
cols = sorted({(b["adapter"], b["strategy"]) for b in med}, key=lambda c: (c[0] != "itk_kdtree", c))
ms = {(b["model"], b["adapter"], b["strategy"]): b["median_s"] * 1e3 for b in med}
agree = all(b["agrees"] for b in med)
print(f"{'pair':26}" + "".join(f"{a + ' ' + s:>34}" for a, s in cols))
for p in pairs:
    print(f"{p:26}" + "".join(f"{(f'{ms[(p, a, s)]:.1f} ms' if (p, a, s) in ms else '-'):>34}" for a, s in cols))
defaults = {"itk_kdtree": "via_knn", "cgal_kdtree": "via_knn", "pcl_kdtree": "native", "nanoflann_kdtree": "native",
            "nanoflann_latest": "native", "ours_kdtree": "native"}
print("\nitk_kdtree (via_knn) / each adapter's default, per pair:")
for a, s in defaults.items():
    if a == "itk_kdtree":
        continue
    ratios = [ms[(p, "itk_kdtree", "via_knn")] / ms[(p, a, s)] for p in pairs if (p, a, s) in ms]
    print(f"  / {a} ({s}): " + ", ".join(f"{r:.1f}x" for r in ratios))
print(f"\nevery cell's answers agree with its check: {agree}")
