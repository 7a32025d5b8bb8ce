"""findings.py verdicts on fixtures built to make each claim hold, fail, or lack data."""
import json
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures
import findings
import results_io

HOLDS, FAILS, UNTESTED = "HOLDS", "DOES NOT HOLD", "NOT TESTED"


def verdicts(**fixture_args):
    with tempfile.TemporaryDirectory() as tmp:
        results = results_io.load(fixtures.write_all(tmp, **fixture_args))
    return {v.number: v for v in findings.evaluate(results, 0.1)}


def verdicts_of(experiment, records):
    with tempfile.TemporaryDirectory() as tmp:
        results = results_io.load([fixtures.write(Path(tmp) / "r.json", experiment, records)])
    return {v.number: v.verdict for v in findings.evaluate(results, 0.1)}


class FindingsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.paper_like = verdicts()

    def assertVerdict(self, got, number, expected):
        self.assertEqual(got[number].verdict, expected, f"claim {number}: {got[number].numbers}")

    def test_paper_like_fixture_supports_every_claim(self):
        for number in range(1, 9):
            self.assertVerdict(self.paper_like, number, HOLDS)
        self.assertIn("160 comparisons in 16 of 16 combinations", self.paper_like[1].numbers[0])
        self.assertIn("8.00x", self.paper_like[8].numbers[0])

    def test_claim1_fails_when_a_native_ranged_is_slower_than_its_knn(self):
        self.assertVerdict(verdicts(kind_factor={("nanoflann_kdtree", "ranged"): 10.0}), 1, FAILS)

    def test_claim2_fails_when_ranged_keeps_growing(self):
        original = fixtures.kind_seconds
        fixtures.kind_seconds = lambda kind, d: original("radius", d) if kind == "ranged" else original(kind, d)
        try:
            self.assertVerdict(verdicts(), 2, FAILS)
        finally:
            fixtures.kind_seconds = original

    def test_claim2_names_a_stopped_series_last_distance_as_swept(self):
        # A sweep's distances are i * step: 3 * 0.1 is 0.30000000000000004, and the verdict says 0.3.
        records = fixtures.sweep_records(kind_factor={("ann_kdtree", "radius"): 6.0})
        for rec in records:
            if "max_dist" in rec:
                rec["max_dist"] = round(rec["max_dist"] * 10) * 0.1
        with tempfile.TemporaryDirectory() as tmp:
            results = results_io.load([fixtures.write(Path(tmp) / "r.json", "paper", records)])
        claim2 = {v.number: v for v in findings.evaluate(results, 0.1)}[2]
        self.assertIn("ann_kdtree radius: did not run at 0.80 m and 0.15 m beyond (last run 0.3 m), not counted",
                      claim2.numbers)
        self.assertFalse([n for n in claim2.numbers if "00000" in n], claim2.numbers)

    def test_claim3_fails_when_cgal_is_fast(self):
        self.assertVerdict(verdicts(speed={"cgal_kdtree": 0.5}), 3, FAILS)

    def test_claim4_fails_when_spatialindex_builds_fast(self):
        self.assertVerdict(verdicts(build_s={"spatialindex_rstar": 0.015}), 4, FAILS)

    def test_claim5_fails_when_ours_kdtree_is_slow(self):
        got = verdicts(speed={"ours_kdtree": 3.0})
        self.assertVerdict(got, 5, FAILS)
        self.assertIn("failed", got[5].numbers[0])

    def test_claim6_fails_when_the_optimum_bucket_is_50(self):
        self.assertVerdict(verdicts(best_bucket=50), 6, FAILS)

    def test_claim7_fails_when_the_octree_is_slow(self):
        self.assertVerdict(verdicts(speed={"ours_octree": 10.0}), 7, FAILS)

    def test_claim8_fails_when_ann_is_only_3x_larger(self):
        self.assertVerdict(verdicts(index_bytes={"ann_kdtree": 300_000}), 8, FAILS)

    def test_absent_data_is_not_tested(self):
        icp_only = verdicts_of("icp_real", fixtures.icp_real_records())
        for number in range(1, 9):
            self.assertEqual(icp_only[number], UNTESTED, number)
        sweep_only = verdicts_of("paper", fixtures.sweep_records())
        self.assertEqual([sweep_only[n] for n in (4, 6, 8)], [UNTESTED] * 3)
        self.assertEqual([sweep_only[n] for n in (1, 2, 3, 5, 7)], [HOLDS] * 5)

    def test_cli_writes_markdown(self):
        with tempfile.TemporaryDirectory() as tmp:
            files = fixtures.write_all(tmp, speed={"cgal_kdtree": 0.5})
            out = Path(tmp) / "FINDINGS.md"
            proc = subprocess.run([sys.executable, str(fixtures.PLOTS_DIR / "findings.py"), *map(str, files),
                                   "--out", str(out)], capture_output=True, text=True, timeout=120)
            self.assertEqual(proc.returncode, 0, proc.stderr)
            text = out.read_text()
        self.assertIn("| 3 | The k-NN-only libraries (CGAL, libspatialindex) are the slowest | **DOES NOT HOLD** |", text)
        self.assertIn("claim 3: DOES NOT HOLD", proc.stdout)

    def test_statistic_fastest_judges_each_cells_fastest_call(self):
        """ours_kdtree slow in its cells' medians (a slow spell) but not in their fastest calls: claim 5 follows
        --statistic, and the output says which time it took."""
        with tempfile.TemporaryDirectory() as tmp:
            files = fixtures.write_all(tmp, speed={"ours_kdtree": 2.5})
            doc = json.loads(files[0].read_text())
            for rec in doc["benchmarks"]:
                if rec.get("search") and not rec.get("skipped"):
                    median = results_io.record_seconds(rec)
                    rec["min_seconds"] = median * (0.2 if rec["adapter"] == "ours_kdtree" else 1.0)
            files[0].write_text(json.dumps(doc))
            runs = {}
            for statistic in ("median", "fastest"):
                out = Path(tmp) / f"{statistic}.md"
                proc = subprocess.run([sys.executable, str(fixtures.PLOTS_DIR / "findings.py"), *map(str, files),
                                       "--statistic", statistic, "--out", str(out)], capture_output=True, text=True,
                                      timeout=120)
                self.assertEqual(proc.returncode, 0, proc.stderr)
                runs[statistic] = (proc.stdout, out.read_text())
        self.assertIn("claim 5: DOES NOT HOLD", runs["median"][0])
        self.assertIn("claim 5: HOLDS", runs["fastest"][0])
        self.assertIn("A cell's time here is the fastest of its calls", runs["fastest"][1])
        self.assertNotIn("A cell's time here", runs["median"][1])


if __name__ == "__main__":
    unittest.main()
