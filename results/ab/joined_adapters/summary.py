# The medians of results/ab/joined_adapters/real_0.1m_results.json as a table (python3 summary.py FILE).
import json, sys
d = json.load(open(sys.argv[1]))
med = {b["name"][:-len("_median")]: b for b in d["benchmarks"] if b.get("aggregate_name") == "median"}
pairs = ["office-sick-3dtk", "office-kinect-pcl", "velodyne-hdl32-fastgicp", "kitti00-hdl64-gtsampoints", "bunny-stanford"]
adapters = ["geographiclib_vptree", "opencv_flann", "cneartree", "nanoflann_kdtree", "ours_kdtree"]
print(f"{'pair':26}" + "".join(f"{a:>22}" for a in adapters) + f"{'vptree/nanoflann':>18}")
for p in pairs:
    ms = {}
    for a in adapters:
        b = med.get(f"sweep/{p}/{p}/{a}/ranged/max_dist:0.10")
        ms[a] = b["real_time"] / 1000 if b else None
    cells = "".join(f"{(f'{ms[a]:.1f} ms' if ms[a] is not None else 'killed'):>22}" for a in adapters)
    print(f"{p:26}{cells}{ms['geographiclib_vptree'] / ms['nanoflann_kdtree']:>17.1f}x")
