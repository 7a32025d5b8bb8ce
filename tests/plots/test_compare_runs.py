"""compare_runs.py on fixtures: ratios per cell from either record shape, noise-aware flags, per-adapter summary."""
import json
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures
import compare_runs  # noqa: E402 (fixtures puts plots/ on the path)

SCRIPT = fixtures.PLOTS_DIR / "compare_runs.py"


def cell(adapter, median, stddev=0.0, skipped=None):
    rec = {"name": f"sweep/hollow_sphere/hollow_cube/{adapter}/ranged/max_dist:0.10", "model": "hollow_sphere",
           "query": "hollow_cube", "adapter": adapter, "search": "ranged", "strategy": "native", "max_dist": 0.1,
           "run_type": "iteration", "repetition_index": 0, "time_unit": "s", "real_time": median,
           "median_s": median, "min_s": median - stddev, "stddev_s": stddev}
    if skipped:
        rec.update(skipped=skipped, real_time=0, median_s=0)
    return rec


def repetitions(adapter, times_ms):
    """Google Benchmark's shape: one record per repetition plus median/mean/stddev/cv aggregates."""
    base = cell(adapter, 0.0)
    for field in ("median_s", "min_s", "stddev_s"):
        base.pop(field)
    name = base["name"]
    recs = [{**base, "run_name": name, "repetition_index": i, "real_time": t, "time_unit": "ms"}
            for i, t in enumerate(times_ms)]
    mean = sum(times_ms) / len(times_ms)
    sd = (sum((t - mean) ** 2 for t in times_ms) / (len(times_ms) - 1)) ** 0.5
    median = sorted(times_ms)[len(times_ms) // 2]
    for agg, value, unit in (("mean", mean, "time"), ("median", median, "time"), ("stddev", sd, "time"),
                             ("cv", sd / mean, "percentage")):
        recs.append({**base, "name": f"{name}_{agg}", "run_name": name, "run_type": "aggregate",
                     "aggregate_name": agg, "aggregate_unit": unit, "real_time": value, "time_unit": "ms"})
    return recs


def icp_run(adapter, pose_offset=0.0, iterations=17, seconds=0.5):
    """One ICP run's record as run_icp writes it, its final pose the identity's translation moved by pose_offset."""
    pose = [[1.0, 0.0, 0.0, 0.25 + pose_offset], [0.0, 1.0, 0.0, -0.5], [0.0, 0.0, 1.0, 1.5], [0.0, 0.0, 0.0, 1.0]]
    return {"name": f"icp/office-sick-3dtk/{adapter}/bucket:10", "pair": "office-sick-3dtk", "adapter": adapter,
            "run_type": "iteration", "repetition_index": 0, "time_unit": "s", "real_time": seconds,
            "icp_seconds": seconds, "iterations": iterations, "final_pose": pose}


class CompareRunsTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, name, records):
        return fixtures.write(self.dir / name, "quick", records)

    def run_cli(self, *args):
        return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                              timeout=120)

    def test_ratio_flags_only_changes_beyond_the_noise(self):
        a = self.write("a.json", [cell("ours_kdtree", 1.0, 0.01), cell("flann_kdtree", 1.0, 0.2),
                                  cell("ann_kdtree", 1.0, 0.0), cell("cgal_kdtree", 1.0, 0.0)])
        b = self.write("b.json", [cell("ours_kdtree", 0.5, 0.01), cell("flann_kdtree", 1.5, 0.2),
                                  cell("ann_kdtree", 1.03, 0.0), cell("cgal_kdtree", 0.0, skipped="over budget: 3 s")])
        rows = {r[0][0]: r for r in compare_runs.compare(compare_runs.read_cells(a)[1], compare_runs.read_cells(b)[1],
                                                          0.05)}
        self.assertAlmostEqual(rows["ours_kdtree"][3], 0.5)
        self.assertEqual(rows["ours_kdtree"][5], "faster")
        self.assertEqual(rows["flann_kdtree"][5], "")      # 50% slower but within 3 x 28% spread
        self.assertEqual(rows["ann_kdtree"][5], "")        # no spread, but under the 5% threshold
        self.assertEqual(rows["cgal_kdtree"][5], "not measured")
        proc = self.run_cli(a, b)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("| ours_kdtree | ranged | native | hollow_sphere <- hollow_cube | max_dist:0.10 | 1 s | 500 ms | "
                      "0.500 | ±2.2% | FASTER |", proc.stdout)
        self.assertIn("| ours_kdtree | 1 | 0.500 | 1 | 0 | 0 |", proc.stdout)
        self.assertIn("| cgal_kdtree | 0 | - | 0 | 0 | 1 |", proc.stdout)

    def test_per_model_geometric_means_of_search_cells(self):
        def on(model, rec):
            return {**rec, "name": rec["name"].replace("hollow_sphere", model, 1), "model": model}
        build = {"name": "build/filled_cube/ours_kdtree", "model": "filled_cube", "adapter": "ours_kdtree",
                 "type": "build", "run_type": "iteration", "repetition_index": 0, "time_unit": "s", "real_time": 1.0,
                 "median_s": 1.0}
        a = self.write("a.json", [cell("ours_kdtree", 1.0), cell("ann_kdtree", 1.0),
                                  on("filled_cube", cell("ours_kdtree", 1.0)), build])
        b = self.write("b.json", [cell("ours_kdtree", 0.5), cell("ann_kdtree", 2.0),
                                  on("filled_cube", cell("ours_kdtree", 3.0)), {**build, "real_time": 9.0,
                                                                                  "median_s": 9.0}])
        proc = self.run_cli(a, b)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("| hollow_sphere | all | 2 | 1.000 |", proc.stdout)   # 0.5 and 2.0
        self.assertIn("| hollow_sphere | ann_kdtree | 1 | 2.000 |", proc.stdout)
        self.assertIn("| filled_cube | all | 1 | 3.000 |", proc.stdout)     # the build's 9x left out
        self.assertIn("| filled_cube | ours_kdtree | 1 | 3.000 |", proc.stdout)

    def test_threshold_option(self):
        a = self.write("a.json", [cell("ann_kdtree", 1.0)])
        b = self.write("b.json", [cell("ann_kdtree", 1.03)])
        self.assertNotIn("SLOWER", self.run_cli(a, b).stdout)
        self.assertIn("SLOWER", self.run_cli(a, b, "--threshold", "0.01").stdout)

    def test_repetitions_and_aggregates_shape(self):
        a = self.write("a.json", repetitions("ours_kdtree", [10.0, 10.2, 9.8]))
        b = self.write("b.json", repetitions("ours_kdtree", [20.0, 20.4, 19.6]) + [cell("nanoflann_kdtree", 1.0)])
        a_cells, b_cells = compare_runs.read_cells(a)[1], compare_runs.read_cells(b)[1]
        key = ("ours_kdtree", "ranged", "native", "hollow_sphere <- hollow_cube", "max_dist:0.10")
        self.assertAlmostEqual(a_cells[key][0], 0.010)
        self.assertAlmostEqual(a_cells[key][1], 0.02)
        (row,) = compare_runs.compare(a_cells, b_cells, 0.05)
        self.assertAlmostEqual(row[3], 2.0)
        self.assertEqual(row[5], "slower")

    def test_repetitions_without_aggregates(self):
        recs = [r for r in repetitions("ours_kdtree", [10.0, 12.0, 11.0]) if r["run_type"] == "iteration"]
        stats = next(iter(compare_runs.read_cells(self.write("a.json", recs))[1].values()))
        self.assertAlmostEqual(stats[0], 0.011)
        self.assertAlmostEqual(stats[1], 0.001 / 0.011)

    def test_icp_final_poses_compared_bit_for_bit(self):
        a = self.write("a.json", [icp_run("ours_kdtree"), icp_run("nanoflann_kdtree"), icp_run("flann_kdtree"),
                                  icp_run("ann_kdtree")])
        b = self.write("b.json", [icp_run("ours_kdtree", seconds=0.3), icp_run("nanoflann_kdtree", 2.0 ** -40),
                                  icp_run("flann_kdtree", iterations=18), icp_run("cgal_kdtree")])
        proc = self.run_cli(a, b)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("ICP's final poses: 1 of 3 runs in both files end at the same pose, bit for bit, after as many "
                      "iterations; the others:", proc.stdout)
        self.assertIn("| nanoflann_kdtree | office-sick-3dtk | bucket:10 | 9.09e-13 | 17 | 17 |", proc.stdout)
        self.assertIn("| flann_kdtree | office-sick-3dtk | bucket:10 | 0 | 17 | 18 |", proc.stdout)
        self.assertNotIn("| ours_kdtree | office-sick-3dtk | bucket:10 |", proc.stdout.split("ICP's final poses")[1])

    def test_no_pose_section_without_icp_runs(self):
        a = self.write("a.json", [cell("ours_kdtree", 1.0)])
        self.assertNotIn("ICP's final poses", self.run_cli(a, a).stdout)

    def test_unreadable_input_exits_2(self):
        bad = self.dir / "bad.json"
        bad.write_text("{}")
        self.assertEqual(self.run_cli(bad, bad).returncode, 2)


if __name__ == "__main__":
    unittest.main()
