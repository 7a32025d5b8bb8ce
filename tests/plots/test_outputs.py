"""to_csv.py and report.py on fixture results; readme_tables.py on a README of marked blocks."""
import csv
import json
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures

PLOTS = fixtures.PLOTS_DIR


def run(script, *args):
    return subprocess.run([sys.executable, str(PLOTS / script), *map(str, args)], capture_output=True, text=True,
                          timeout=600)


class OutputsTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def test_csv_has_one_row_per_record(self):
        path = fixtures.write_all(self.dir)[0]
        records = json.loads(path.read_text())["benchmarks"]
        proc = run("to_csv.py", path, "--out", self.dir / "out.csv")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        with open(self.dir / "out.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        self.assertEqual(len(rows), len(records))
        self.assertEqual(rows[0]["name"], records[0]["name"])
        self.assertEqual(rows[0]["context_experiment"], "paper")
        self.assertIn("skipped", rows[0])  # union of every record's fields

    def test_csv_refuses_a_non_results_file(self):
        bad = self.dir / "bad.json"
        bad.write_text("{}")
        self.assertEqual(run("to_csv.py", bad).returncode, 2)

    def test_report_is_one_self_contained_page(self):
        files = fixtures.write_all(self.dir) + [fixtures.approx_file(self.dir / "approx.json")]
        proc = run("report.py", *files, "--out", self.dir / "report")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        page = (self.dir / "report" / "report.html").read_text()
        import report
        self.assertIn(report.plotly_js(), page)
        own = page.replace(report.plotly_js(), "")
        self.assertFalse("<script src" in own or "<link" in own or "http" in own, "the page loads from elsewhere")
        for section in ('id="table1"', 'id="findings"', 'id="machine"', "id='adapter-ours_kdtree'", "Plotly.newPlot"):
            self.assertTrue(section in page, section)
        self.assertGreater(page.count("class=plot"), 5)

    def test_readme_blocks_checked_and_written(self):
        files = fixtures.write_all(self.dir)
        readme = self.dir / "README.md"
        readme.write_text("# x\n<!-- generated: findings -->\nstale\n<!-- end -->\ntext\n")
        self.assertEqual(run("readme_tables.py", "--check", "--readme", readme, *files).returncode, 1)
        self.assertEqual(run("readme_tables.py", "--write", "--readme", readme, *files).returncode, 0)
        text = readme.read_text()
        self.assertIn("| 7 | The octree is among the fastest |", text)
        self.assertTrue(text.endswith("<!-- end -->\ntext\n"))
        proc = run("readme_tables.py", "--check", "--readme", readme, *files)
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)


if __name__ == "__main__":
    unittest.main()
