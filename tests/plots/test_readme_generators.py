"""readme_tables.py's generated tables on fixture results: the reference runs' provenance, the real pairs'
scans and the ICP accuracy run."""
import json
import tempfile
import unittest
from pathlib import Path

import fixtures

import readme_tables  # noqa: E402
import results_io  # noqa: E402

IDENTITY = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
MOVED = [[1.0, 0.0, 0.0, 0.5], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]


def scan(pair, role, points, n_non_finite=0, n_zero=0, **extra):
    return {"spec": pair, "role": role, "kind": "real_pair", "file": f"{pair}-{role}.pcd", "points": points,
            "n_read": points + n_non_finite + n_zero, "n_dropped": n_non_finite + n_zero,
            "n_non_finite": n_non_finite, "n_zero": n_zero, "units": "m", **extra}


def accuracy_record(pair, initial, error_m, error_deg, converged=True, **settings):
    return {"name": f"icp/{pair}/nanoflann_kdtree/bucket:10", "pair": pair, "adapter": "nanoflann_kdtree",
            "bucket_size": 10, "icp_seconds": 1.0, "real_time": 1.0, "time_unit": "s", "iterations": 12,
            "converged": converged, "max_dist_start_m": 1.0, "max_dist_factor": 0.8, "max_dist_floor_m": 0.2,
            "max_iterations": 50, "query_stride": 1, "initial_pose": initial, "final_pose": IDENTITY,
            "ref_translation_error_m": error_m, "ref_rotation_error_deg": error_deg, **settings}


class ReadmeTablesTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, name, context, records=()):
        path = self.dir / name
        path.write_text(json.dumps({"context": context, "benchmarks": list(records)}))
        return path

    def test_reference_runs_say_what_each_file_records_and_not_recorded_otherwise(self):
        new = fixtures.context("quick", date="2024-01-02T00:00:00", wall_seconds=300.0,
                               commit=fixtures.CLEAN_COMMIT + "+dirty")
        old = {"date": "2024-01-01T00:00:00", "nnb_experiment": "icp_real", "load_avg": [1.5, 1.0, 1.0]}
        results = results_io.load([self.write("new.json", new), self.write("old.json", old)])
        lines = readme_tables.reference_runs_lines(results)
        self.assertEqual(len(lines), 4)
        self.assertEqual(lines[2], f"| `{self.dir / 'old.json'}` | icp_real | not recorded | not recorded | "
                                   "1.50 -> not recorded | 2024-01-01T00:00:00 | not recorded |")
        self.assertEqual(lines[3], f"| `{self.dir / 'new.json'}` | quick | `run_sweep --experiment quick` | "
                                   "0123456 (dirty) | 0.10 -> 0.20 | 2024-01-02T00:00:00 | 5 min |")

    def test_micro_builds_judge_each_tree_against_the_faster_nanoflann(self):
        def build(model, adapter, ms, run_type="iteration"):
            return {"name": f"Build/{model}/{adapter}", "run_name": f"Build/{model}/{adapter}", "run_type": run_type,
                    "cpu_time": ms, "real_time": ms, "time_unit": "ms"}
        records = [build("sick", "ours_kdtree", 5.0), build("sick", "ours_kdtree", 4.0), build("sick", "ours_octree", 2.0),
                   build("sick", "nanoflann_kdtree", 9.0), build("sick", "nanoflann_latest", 7.0),
                   build("sick", "ours_kdtree", 1.0, run_type="aggregate"),  # a mean: never the fastest repetition
                   build("sick", "ours_kdtree[bucket_size=8]", 0.5), build("sick", "ours_kdtree/threads:2/real_time", 0.5)]
        results = results_io.load([self.write("micro_nns.json", {"date": "2024-01-01T00:00:00"}, records)])
        lines = readme_tables.micro_build_lines(results)
        self.assertEqual(lines[2], "| office-sick-3dtk | 4 ms | 2 ms | 7 ms | 1.75x* | 3.50x |")

    def test_micro_icp_judges_the_faster_of_ours_against_the_faster_nanoflann(self):
        def run(pair, adapter, ms, run_type="iteration"):
            return {"name": f"Icp/{pair}/{adapter}", "run_name": f"Icp/{pair}/{adapter}", "run_type": run_type,
                    "cpu_time": ms, "real_time": ms, "time_unit": "ms", "icp_iterations": 50}
        records = [run("sick", "ours_kdtree", 400.0), run("sick", "ours_kdtree", 380.0), run("sick", "ours_octree", 450.0),
                   run("sick", "nanoflann_kdtree", 1000.0), run("sick", "nanoflann_latest", 950.0),
                   run("sick", "ours_kdtree", 1.0, run_type="aggregate"),  # a mean: never the fastest repetition
                   run("kinect", "ours_kdtree", 100.0), run("kinect", "nanoflann_latest", 300.0),
                   run("bunny", "ours_kdtree", 10.0)]
        results = results_io.load([self.write("micro_nns.json", {"date": "2024-01-01T00:00:00"}, records)])
        self.assertEqual(results.sweep, [], "ICP runs are not sweep cells")
        self.assertEqual(readme_tables.micro_icp_lines(results)[2:], [
            "| bunny | 10 ms | - | - | - |",
            "| kinect | 100 ms | - | 300 ms | 3.00x |",
            "| sick | 380 ms | 450 ms | 950 ms | 2.50x |"])
        records[4] = run("sick", "nanoflann_latest", 949.0)
        results = results_io.load([self.write("micro_nns.json", {"date": "2024-01-01T00:00:00"}, records)])
        self.assertEqual(readme_tables.micro_icp_lines(results)[4], "| sick | 380 ms | 450 ms | 949 ms | 2.50x* |")

    def test_real_sweep_ranks_exact_timed_ranged_cells_at_the_distance(self):
        records = [dict(r, n_queries=5000) for r in fixtures.sweep_records(shapes=("kinect",))]
        for r in records:
            if r["adapter"] == "ours_octree" and r.get("max_dist") == 0.1 and r["search"] == "ranged":
                r["agrees"] = False
            if r["adapter"] == "ann_kdtree" and r["search"] == "ranged":
                r.update(skipped="over the budget", real_time=0, cpu_time=0)
        records += fixtures.sweep_records(shapes=("city-60k",))
        context = dict(fixtures.context("real"), datasets=[scan("kinect", "model", 5000), scan("kinect", "query", 5000),
                                                           {"spec": "city-60k", "role": "model", "kind": "simulated_pair"}])
        results = results_io.load([self.write("real.json", context, records)])
        lines = readme_tables.real_sweep_lines(results, max_dist_m=0.1)
        self.assertEqual(len(lines), 3, "one row per real pair, none for simulated scans")
        self.assertEqual(lines[2], "| kinect | 5,000 | ours_octree 27 ms (DISAGREES) | ours_kdtree 30.3 ms | "
                                   "nanoflann_kdtree 33.7 ms | nanoflann_kdtree 33.7 ms | 1.25x | 6 of 8 |")

    def test_real_pairs_row_per_pair_from_the_datasets_context(self):
        context = {"date": "2024-01-01T00:00:00", "datasets": [
            scan("kinect", "model", 1000, n_non_finite=20), scan("kinect", "query", 990, n_non_finite=30,
                                                                  placed_by="identity"),
            scan("velodyne", "model", 5000, n_zero=7), scan("velodyne", "query", 5100, n_zero=9,
                                                            placed_by="relative.txt"),
            {"spec": "hollow_cube", "role": "model", "kind": "synthetic", "points": 60000}]}
        lines = readme_tables.real_pairs_lines(results_io.load([self.write("pairs.json", context)]))
        self.assertEqual(lines[2:], [
            "| `kinect` (kinect-model.pcd <- kinect-query.pcd) | 1,000 / 990 | 1,020 / 1,020 | 20 / 30 | 0 / 0 | m | "
            "identity |",
            "| `velodyne` (velodyne-model.pcd <- velodyne-query.pcd) | 5,000 / 5,100 | 5,007 / 5,109 | 0 / 0 | 7 / 9 | "
            "m | `relative.txt` |"])

    def test_real_pairs_fields_an_older_file_lacks_are_not_recorded(self):
        entries = [{"spec": "sick", "role": role, "kind": "real_pair", "points": 81360, "n_read": 81360}
                   for role in ("model", "query")]
        lines = readme_tables.real_pairs_lines(results_io.load([self.write("sweep.json", {"datasets": entries})]))
        self.assertEqual(lines[2:], ["| `sick` | 81,360 / 81,360 | 81,360 / 81,360 | not recorded | not recorded | "
                                     "not recorded | not recorded |"])

    def test_real_pairs_a_later_file_recording_less_keeps_the_earlier_fields_of_the_same_scans(self):
        full = {"date": "2024-01-01T00:00:00", "datasets": [scan("sick", "model", 100, sha256="a"),
                                                            scan("sick", "query", 90, sha256="b", placed_by="f")]}
        short = {"date": "2024-01-02T00:00:00", "datasets": [
            {"spec": "sick", "role": role, "kind": "real_pair", "points": n, "n_read": n + 1, "sha256": sha}
            for role, n, sha in (("model", 100, "a"), ("query", 90, "c"))]}
        paths = [self.write("pairs.json", full), self.write("sweep.json", short)]
        lines = readme_tables.real_pairs_lines(results_io.load(paths, prefer="newest"))
        # the model's scan is the same data: its units and file stay; the query's is other data: only what it says
        self.assertEqual(lines[2:], ["| `sick` | 100 / 90 | 101 / 91 | not recorded | not recorded | m | not recorded |"])

    def test_icp_accuracy_reads_the_accuracy_experiment_only(self):
        records = [accuracy_record("velodyne", IDENTITY, 0.011, 0.35),
                   accuracy_record("sick", MOVED, 0.00009, 0.0015, max_dist_factor=1.0, query_stride=8),
                   accuracy_record("kitti", IDENTITY, 0.24, 0.11, converged=False)]
        timing = [accuracy_record("velodyne", IDENTITY, 0.5, 5.0)]
        results = results_io.load([self.write("acc.json", {"experiment": "icp_accuracy"}, records),
                                   self.write("real.json", {"experiment": "icp_real"}, timing)])
        self.assertEqual(readme_tables.icp_accuracy_lines(results)[2:], [
            "| velodyne | nanoflann_kdtree | 1 -> 0.2 m, x0.8, at most 50 iterations | identity | 12 | 1.1 cm / 0.35 deg |",
            "| sick | nanoflann_kdtree | 1 m fixed, at most 50 iterations, query stride 8 | the pair's initial "
            "pose | 12 | 0.09 mm / 0.0015 deg |",
            "| kitti | nanoflann_kdtree | 1 -> 0.2 m, x0.8, at most 50 iterations | identity | 12 (not converged) | "
            "24 cm / 0.11 deg |"])

    def test_accuracy_runs_stay_out_of_the_icp_timing(self):
        import fig_icp
        records = [accuracy_record("velodyne", IDENTITY, 0.011, 0.35)]
        results = results_io.load([self.write("acc.json", {"experiment": "icp_accuracy"}, records)])
        self.assertEqual(fig_icp.real_times(results), {})


    def test_registry_table1_has_a_row_per_declared_adapter(self):
        declared = {"b_tree": {"library": "B", "version": "2", "structure": "k-d tree", "scalar": "float",
                               "exact": True, "knn": "native", "radius": "native", "ranged": "via_knn",
                               "ranged_strategies": ["via_knn", "via_radius"], "params": {"leaf": "8"}},
                    "a_scan": {"library": "A", "version": "1", "structure": "linear scan", "scalar": "double",
                               "exact": False, "knn": "native", "radius": "unsupported", "ranged": "native"}}
        path = self.dir / "adapters.json"
        path.write_text(json.dumps(declared))
        lines = readme_tables.registry_table1_lines(None, path)
        self.assertEqual(len(lines), 2 + 2)
        self.assertTrue(lines[2].startswith("| a_scan | A | 1 | linear scan | double | native | no |"), lines[2])
        self.assertIn("**no (approximate)**", lines[2])
        self.assertIn("leaf=8", lines[3])
        self.assertEqual(readme_tables.registry_table1_lines(None, self.dir / "missing.json"), lines[:2])

if __name__ == "__main__":
    unittest.main()
