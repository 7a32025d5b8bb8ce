# The medians of results/ab/hnswlib/real_0.1m_results.json as a table (python3 summary.py FILE): build and search
# times per pair, and hnswlib's against each exact adapter's.
import json, sys
d = json.load(open(sys.argv[1]))
med = [b for b in d["benchmarks"] if b.get("aggregate_name") == "median"]
pairs = ["office-sick-3dtk", "office-kinect-pcl", "velodyne-hdl32-fastgicp", "kitti00-hdl64-gtsampoints", "bunny-stanford"]
adapters = ["hnswlib_hnsw", "nanoflann_kdtree", "nanoflann_latest", "ours_kdtree"]
build = {(b["model"], b["adapter"]): b["median_s"] for b in med if b["type"] == "build"}
search = {(b["model"], b["adapter"], b["search"]): b["median_s"] for b in med if b["type"] == "sweep"}
for title, cell in (("build", lambda p, a: build.get((p, a))),
                    ("1-NN", lambda p, a: search.get((p, a, "knn"))),
                    ("ranged 1-NN at 0.1 m", lambda p, a: search.get((p, a, "ranged")))):
    print(f"{title}, ms (median of 3)")
    labels = {"nanoflann_kdtree": "nanoflann 1.4.3", "nanoflann_latest": "nanoflann 1.12.1", "ours_kdtree": "ours_kdtree"}
    print(f"{'pair':26}" + "".join(f"{a:>18}" for a in adapters) + "".join(f"{'hnsw / ' + labels[a]:>25}" for a in adapters[1:]))
    for p in pairs:
        ms = {a: cell(p, a) for a in adapters}
        text = "".join(f"{(f'{1e3 * ms[a]:.1f}' if ms[a] is not None else '-'):>18}" for a in adapters)
        ratios = "".join(f"{(f'{ms[adapters[0]] / ms[a]:.1f}x' if ms[a] and ms[adapters[0]] else '-'):>25}"
                         for a in adapters[1:])
        print(f"{p:26}{text}{ratios}")
    print()
