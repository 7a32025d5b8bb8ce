"""Builds synthetic results files (made-up numbers, paper-like shapes) for the plotting and findings tests."""
import json
import math
import sys
from pathlib import Path

PLOTS_DIR = Path(__file__).resolve().parents[2] / "plots"
sys.path.insert(0, str(PLOTS_DIR))

SHAPES = ("hollow_cube", "filled_cube", "hollow_sphere", "filled_sphere")
# adapter: (library, structure, {kind: strategy})
ADAPTERS = {
    "ours_kdtree": ("ours", "k-d tree", {"knn": "native", "ranged": "native"}),
    "ours_octree": ("ours", "octree", {"ranged": "native"}),
    "nanoflann_kdtree": ("nanoflann", "k-d tree", {"knn": "native", "radius": "native", "ranged": "native"}),
    "flann_kdtree": ("FLANN", "k-d tree", {"knn": "native", "radius": "native", "ranged": "via_knn"}),
    "ann_kdtree": ("ANN", "k-d tree", {"knn": "native", "radius": "native", "ranged": "via_knn"}),
    "cgal_kdtree": ("CGAL", "k-d tree", {"knn": "native", "ranged": "via_knn"}),
    "spatialindex_rstar": ("libspatialindex", "R*-tree", {"knn": "native", "ranged": "via_knn"}),
    "brute_force": ("none", "brute force", {"knn": "native", "radius": "native", "ranged": "native"}),
}
SPEED = {"pcl_octree_approx": 0.1, "ours_octree": 0.8, "ours_kdtree": 0.9, "nanoflann_kdtree": 1.0, "flann_kdtree": 1.5, "ann_kdtree": 1.6,
         "cgal_kdtree": 3.0, "spatialindex_rstar": 4.0, "brute_force": 50.0}
BUILD_S = {"spatialindex_rstar": 0.5, "brute_force": 0.0001}
INDEX_BYTES = {"ours_kdtree": 100_000, "ann_kdtree": 800_000}
DISTS = [round(0.1 * i, 2) for i in range(11)]
BUDGET_S = 2.5


def kind_seconds(kind, d):
    """Paper-like shapes: ranged levels off at sqrt(3) - 1, radius keeps growing, k-NN flat."""
    if kind == "ranged":
        return 0.02 + 0.1 * min(d, 0.73) / 0.73
    if kind == "radius":
        return 0.03 + 2.0 * d * d
    return 0.15


def cell_seconds(adapter, kind, strategy, d, speed, kind_factor):
    base = kind_seconds("knn", d) * 1.1 if strategy == "via_knn" else kind_seconds(kind, d)
    return speed[adapter] * kind_factor.get((adapter, kind), 1.0) * base


def sweep_records(speed=None, shapes=SHAPES, adapters=ADAPTERS, kind_factor=None):
    """Sweep cells; speed scales an adapter, kind_factor {(adapter, kind): x} one of its kinds."""
    speed, kind_factor = {**SPEED, **(speed or {})}, kind_factor or {}
    records = []
    for model in shapes:
        for query in shapes:
            for adapter, (_, _, kinds) in adapters.items():
                for kind, strategy in kinds.items():
                    over = False
                    for d in ([None] if kind == "knn" else DISTS):
                        seconds = cell_seconds(adapter, kind, strategy, d or 0.0, speed, kind_factor)
                        over = over or seconds > BUDGET_S
                        name = f"sweep/{model}/{query}/{adapter}/{kind}" + ("" if d is None else f"/max_dist:{d:.2f}")
                        rec = {"name": name, "model": model, "query": query, "adapter": adapter, "search": kind,
                               "strategy": strategy, "k": 1, "repetitions": 3, "run_type": "iteration",
                               "iterations": 1, "real_time": seconds * 1000.0, "cpu_time": seconds * 1000.0,
                               "time_unit": "ms", "found": 100, "dist_sum": 1.0}
                        if d is not None:
                            rec["max_dist"] = d
                        if over:
                            rec = {k: v for k, v in rec.items() if k not in ("real_time", "cpu_time", "found")}
                            rec.update(skipped="over the 2.5 s budget", real_time=0, cpu_time=0)
                        elif adapter != "ann_kdtree":  # ann's cells keep only real_time in ms: exercises units
                            rec.update(median_seconds=seconds, mean_seconds=seconds, min_seconds=seconds,
                                       stddev_seconds=0.0)
                        records.append(rec)
    return records


def build_records(build_s=None, index_bytes=None, shapes=SHAPES):
    build_s, index_bytes = {**BUILD_S, **(build_s or {})}, {**INDEX_BYTES, **(index_bytes or {})}
    records = []
    for model in shapes:
        for adapter in ADAPTERS:
            seconds = build_s.get(adapter, 0.01 * SPEED[adapter] ** 0.5)
            records.append({"name": f"build/{model}/{adapter}", "model": model, "adapter": adapter,
                            "real_time": seconds, "cpu_time": seconds, "time_unit": "s", "build_seconds": seconds,
                            "index_bytes": index_bytes.get(adapter, 400_000), "n_points": 60000})
    return records


def icp_bucket_records(best_bucket=10):
    records = []
    for adapter in ("ours_kdtree", "ours_octree", "flann_kdtree"):
        for bucket in (1, 2, 5, 10, 20, 50, 100):
            seconds = SPEED[adapter] * (1.0 + math.log(bucket / best_bucket) ** 2 / 4)
            records.append({"name": f"icp/sick_office/{adapter}/bucket:{bucket}", "pair": "sick_office",
                            "adapter": adapter, "bucket_size": bucket, "icp_seconds": seconds,
                            "real_time": seconds, "time_unit": "s", "build_seconds": 0.01, "nns_seconds": seconds * 0.9,
                            "iterations": 30, "converged": True})
    return records


def icp_real_records():
    records = []
    for pair, scale in (("sick_office", 1.0), ("kinect_office", 3.0), ("riegl_city", 40.0)):
        for adapter in ADAPTERS:
            seconds = scale * SPEED[adapter]
            records.append({"name": f"icp/{pair}/{adapter}", "pair": pair, "adapter": adapter,
                            "icp_seconds": seconds, "real_time": seconds, "time_unit": "s", "iterations": 25,
                            "converged": adapter != "cgal_kdtree"})
    return records


CLEAN_COMMIT = "0123456789abcdef0123456789abcdef01234567"


def context(experiment, date="2024-01-01T00:00:00", wall_seconds=None, commit=CLEAN_COMMIT):
    """A clean run's context (commit without +dirty); wall_seconds recorded only when given."""
    extra = {} if wall_seconds is None else {"wall_seconds": wall_seconds, "load_avg_after": [0.2, 0.2, 0.2]}
    return {"date": date, "host_name": "fixture", "experiment": experiment, **extra,
            "git_commit": commit, "command_line": f"run_sweep --experiment {experiment}", "load_avg": [0.1, 0.1, 0.1],
            "library_build_type": "release",
            "adapters": {name: {"library": lib, "version": "1.0", "structure": structure,
                                "knn": kinds.get("knn", "via_box"), "radius": kinds.get("radius", "via_box"),
                                "ranged": kinds["ranged"], "exact": True, "params": {"bucket_size": 10}}
                         for name, (lib, structure, kinds) in ADAPTERS.items()}}


def write(path, experiment, records, **context_args):
    """Writes one results file; returns its path. context_args: see context()."""
    path = Path(path)
    path.write_text(json.dumps({"context": context(experiment, **context_args), "benchmarks": records}))
    return path


def strategy_records(adapter="flann_kdtree", model="hollow_sphere", query="hollow_cube"):
    """An adapter's ranged search on one pair with its other strategies (k-NN then a cut, radius search),
    named as run_sweep --strategies all names them."""
    records = []
    for strategy, factor in (("via_knn", 1.4), ("via_radius", 2.5)):
        for d in DISTS:
            seconds = factor * cell_seconds(adapter, "ranged", "native", d, SPEED, {})
            records.append({"name": f"sweep/{model}/{query}/{adapter}/ranged/strategy:{strategy}/max_dist:{d:.2f}",
                            "model": model, "query": query, "adapter": adapter, "search": "ranged",
                            "strategy": strategy, "k": 1, "max_dist": d, "repetitions": 3, "run_type": "iteration",
                            "iterations": 1, "real_time": seconds, "cpu_time": seconds, "time_unit": "s",
                            "median_seconds": seconds, "found": 100, "dist_sum": 1.0})
    return records


def write_all(directory, speed=None, build_s=None, index_bytes=None, best_bucket=10, kind_factor=None):
    """A full set of results files (sweep+build, icp_bucket, icp_real) in directory; returns their paths."""
    directory = Path(directory)
    return [write(directory / "sweep.json", "paper", sweep_records(speed, kind_factor=kind_factor) + strategy_records()
                  + build_records(build_s, index_bytes)),
            write(directory / "icp_bucket.json", "icp_bucket", icp_bucket_records(best_bucket)),
            write(directory / "icp_real.json", "icp_real", icp_real_records())]


# The scale experiment: one query set against model sizes x4 apart; exact power laws with these exponents.
SCALE_SIZES = [15712 * 4 ** i for i in range(6)]
SCALE_QUERIES = 62721
SCALE_LAWS = {  # adapter: (query exponent, build exponent, sizes run)
    "nanoflann_kdtree": (0.2, 1.1, 6),
    "flann_kdtree": (0.3, 1.0, 6),
    "brute_force": (1.0, 0.5, 3),  # over budget at the third size: the larger ones are skipped
}


def scale_records():
    """Sweep and build records of a scale run (models city-N, query city-q), times following SCALE_LAWS."""
    records = []
    for i, n in enumerate(SCALE_SIZES):
        model = f"city-{n}"
        for adapter, (q_exp, b_exp, sizes_run) in SCALE_LAWS.items():
            per_query = 1e-7 * (n / SCALE_SIZES[0]) ** q_exp
            build_s = 1e-3 * (n / SCALE_SIZES[0]) ** b_exp
            cell = {"name": f"sweep/{model}/city-q/{adapter}/ranged/max_dist:0.10", "model": model, "query": "city-q",
                    "adapter": adapter, "search": "ranged", "strategy": ADAPTERS[adapter][2]["ranged"], "k": 1, "max_dist": 0.1,
                    "n_points": n, "n_queries": SCALE_QUERIES, "run_type": "iteration", "time_unit": "s",
                    "real_time": per_query * SCALE_QUERIES, "median_s": per_query * SCALE_QUERIES}
            build = {"name": f"build/{model}/{adapter}", "model": model, "adapter": adapter, "n_points": n,
                     "real_time": build_s, "time_unit": "s", "build_seconds": build_s, "index_bytes": 20 * n}
            if i >= sizes_run:
                reason = f"skipped on models of {SCALE_SIZES[sizes_run - 1]} points and more: over budget"
                for rec in (cell, build):
                    rec.update(skipped=reason, real_time=0, median_s=0, build_seconds=0)
            records += [cell, build]
    return records


APPROX = "pcl_octree_approx"


def approx_file(path):
    """Results of an approximate adapter faster than every exact one, on the grid and the real pairs."""
    records = sweep_records(speed={APPROX: 0.1}, adapters={APPROX: ("PCL", "octree", {"knn": "native", "ranged": "via_knn"})})
    records += [{"name": f"icp/{pair}/{APPROX}", "pair": pair, "adapter": APPROX, "icp_seconds": 0.01,
                 "real_time": 0.01, "time_unit": "s", "iterations": 25, "converged": True}
                for pair in ("sick_office", "kinect_office", "riegl_city")]
    ctx = context("paper")
    ctx["adapters"] = {APPROX: {"library": "PCL", "version": "1.0", "structure": "octree", "knn": "native",
                                "radius": "unsupported", "ranged": "via_knn", "exact": False, "params": {}}}
    path = Path(path)
    path.write_text(json.dumps({"context": ctx, "benchmarks": records}))
    return path
