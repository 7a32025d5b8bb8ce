"""round_spread.py on fixtures: spread within and between rounds, the first round's offset, bad input."""
import json
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures
import round_spread  # noqa: E402 (fixtures puts plots/ on the path)

SCRIPT = fixtures.PLOTS_DIR / "round_spread.py"


def cell(adapter, times_ms, dist=0.1):
    """A cell's call records in the order timed, as run_sweep writes them, and its median aggregate."""
    name = f"sweep/hollow_cube/filled_sphere/{adapter}/ranged/max_dist:{dist:.2f}"
    base = {"name": name, "run_name": name, "type": "sweep", "adapter": adapter, "model": "hollow_cube",
            "query": "filled_sphere", "search": "ranged", "strategy": "native", "max_dist": dist, "time_unit": "ms"}
    recs = [dict(base, run_type="iteration", repetition_index=i, real_time=t) for i, t in enumerate(times_ms)]
    recs.append(dict(base, name=name + "_median", run_type="aggregate", aggregate_name="median",
                     real_time=sorted(times_ms)[len(times_ms) // 2], rounds=3))
    return recs


def document(records, rounds=3, repetitions=2):
    return {"context": {"config": {"rounds": rounds, "repetitions": repetitions}}, "benchmarks": records}


class RoundSpreadTest(unittest.TestCase):
    def test_a_slow_round_shows_between_rounds_not_within(self):
        steady = cell("ann_kdtree", [10, 11, 10, 11, 10, 11])
        spell = cell("ours_kdtree", [15, 16, 10, 11, 10, 11])  # the first round fell in a slow spell
        cells = round_spread.cell_rounds(document(steady + spell))
        self.assertEqual(cells[("ours_kdtree", spell[0]["name"])], [[0.015, 0.016], [0.010, 0.011], [0.010, 0.011]])
        rows = {r[0]: r for r in round_spread.summary(cells)}
        _, n, within, between, more, off, worst, slowest = rows["ours_kdtree"]
        self.assertEqual(n, 1)
        self.assertAlmostEqual(within, 1.1)  # the median round's 11 / 10
        self.assertAlmostEqual(between, 15.5 / 10.5)
        self.assertEqual((more, off), (1, 1))
        self.assertAlmostEqual(worst, 15.5 / 11.0)  # first round's median over all six calls' median
        self.assertEqual(slowest, [1, 0, 0])
        self.assertEqual(rows["ann_kdtree"][3:6], (1.0, 0, 0))
        self.assertEqual(rows["all"][1], 2)
        self.assertEqual(rows["all"][7], [2, 0, 0])  # ann_kdtree's rounds tie: the first of the slowest

    def test_first_round_outliers_farthest_first_either_way(self):
        records = (cell("ann_kdtree", [10, 10, 10, 10, 10, 10]) + cell("ours_kdtree", [30, 30, 10, 10, 10, 10], 0.2)
                   + cell("ours_octree", [5, 5, 10, 10, 10, 10]) + cell("vtk_kdtree", [12, 12, 10, 10, 10, 10]))
        cells = round_spread.cell_rounds(document(records))
        rows = round_spread.first_round_outliers(cells, 3)
        self.assertEqual([r[1] for r in rows], ["ours_kdtree", "ours_octree", "vtk_kdtree"])
        self.assertAlmostEqual(rows[0][0], 3.0)
        self.assertAlmostEqual(rows[1][0], 0.5)  # a first round faster than the rest counts too
        self.assertEqual(rows[0][3], [0.030, 0.010, 0.010])
        self.assertTrue(rows[0][2].endswith("ours_kdtree/ranged/max_dist:0.20"))
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "run.json"
            path.write_text(json.dumps(document(records)))
            proc = subprocess.run([sys.executable, str(SCRIPT), str(path), "--first-round", "1"],
                                  capture_output=True, text=True, timeout=60)
            self.assertEqual(proc.returncode, 0, proc.stderr)
            listed = [line for line in proc.stdout.splitlines() if "/max_dist:" in line]
            self.assertEqual(listed, ["| 3.000 | ours_kdtree | sweep/hollow_cube/filled_sphere/ours_kdtree/ranged/"
                                      "max_dist:0.20 | 30 / 10 / 10 |"])
            proc = subprocess.run([sys.executable, str(SCRIPT), str(path), "--first-round", "-1"],
                                  capture_output=True, text=True, timeout=60)
            self.assertEqual((proc.returncode, len(proc.stderr.strip().splitlines()), proc.stdout), (2, 1, ""))

    def test_budget_cuts_lists_the_series_ended_on_a_cell_whose_median_lies_within_the_budget(self):
        def ended(adapter, at, later):
            name = f"sweep/hollow_cube/filled_sphere/{adapter}/ranged/max_dist:{later:.2f}"
            return [{"name": name, "run_name": name, "type": "sweep", "adapter": adapter, "run_type": "iteration",
                     "skipped": f"over budget: 1.7 s at max_dist {at:.2f} > 1 s", "error_occurred": True}]
        # ours_kdtree: its first round over the budget, the others within: an outlier ended the series.
        # ann_kdtree: over the budget in every round. vtk_kdtree: ended by an error, not the budget.
        records = (cell("ours_kdtree", [1700, 1700, 600, 600, 600, 600], 0.2) + ended("ours_kdtree", 0.2, 0.3)
                   + cell("ann_kdtree", [1500, 1500, 1400, 1400, 1600, 1600], 0.2) + ended("ann_kdtree", 0.2, 0.3)
                   + cell("vtk_kdtree", [10, 10, 10, 10, 10, 10], 0.2))
        doc = document(records)
        doc["context"]["config"]["budget_seconds"] = 1.0
        series, within = round_spread.budget_cuts(doc)
        self.assertEqual(series, 2)
        self.assertEqual(within, [("sweep/hollow_cube/filled_sphere/ours_kdtree/ranged/max_dist:0.20", 0.6, 6)])
        del doc["context"]["config"]["budget_seconds"]
        with self.assertRaises(ValueError):
            round_spread.budget_cuts(doc)

    def test_cells_cut_short_and_skipped_cells_are_left_out(self):
        short = cell("ours_kdtree", [10, 11, 10, 11, 10])
        skipped = [{"name": "sweep/x/y/ann_kdtree/ranged/max_dist:0.30", "type": "sweep", "adapter": "ann_kdtree",
                    "run_type": "iteration", "skipped": "over budget", "error_occurred": True}]
        self.assertEqual(round_spread.cell_rounds(document(short + skipped)), {})

    def test_one_round_is_refused_with_one_line_and_exit_2(self):
        with tempfile.TemporaryDirectory() as tmp:
            for label, doc in (("one", document(cell("ours_kdtree", [10, 11]), rounds=1)),
                               ("none", document(cell("ours_kdtree", [10, 11, 12]), repetitions=2))):
                path = Path(tmp) / f"{label}.json"
                path.write_text(json.dumps(doc))
                proc = subprocess.run([sys.executable, str(SCRIPT), str(path)], capture_output=True, text=True,
                                      timeout=60)
                self.assertEqual(proc.returncode, 2, label)
                self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)
                self.assertEqual(proc.stdout, "")


if __name__ == "__main__":
    unittest.main()
