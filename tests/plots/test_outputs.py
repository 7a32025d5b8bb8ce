"""to_csv.py and report.py on fixture results; readme_tables.py on a README of marked blocks."""
import csv
import json
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures
import files  # noqa: E402  (fixtures puts plots/ on the path)

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

    def test_csv_to_a_path_that_cannot_be_written_is_one_line_and_exit_2(self):
        path = fixtures.write_all(self.dir)[0]
        proc = run("to_csv.py", path, "--out", self.dir / "absent" / "out.csv")
        self.assertEqual(proc.returncode, 2, proc.stderr)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)

    def test_unreadable_results_are_bad_input_not_a_crash(self):
        nested = self.dir / "nested.json"  # deeper than Python's JSON reader recurses
        nested.write_text("[" * 100000 + "]" * 100000)
        garbage = self.dir / "garbage.json"
        garbage.write_text("{ not json")
        out = self.dir / "out"
        for bad in (nested, garbage):
            for script, *args in (("findings.py", bad, "--out", out / "F.md"),
                                  ("to_csv.py", bad, "--out", out / "x.csv"),
                                  ("make_figures.py", bad, "--out", out), ("report.py", bad, "--out", out),
                                  ("compare_runs.py", bad, bad), ("merge_results.py", bad, "--out", out / "m.json"),
                                  ("round_spread.py", bad)):
                proc = run(script, *args)
                self.assertEqual(proc.returncode, 2, f"{script} {bad.name}: {proc.stderr[-500:]}")
                self.assertNotIn("Traceback", proc.stderr, f"{script} {bad.name}")

    def test_an_output_over_an_input_is_refused(self):
        path = fixtures.write_all(self.dir)[0]
        before = path.read_bytes()
        for script in ("to_csv.py", "findings.py"):
            proc = run(script, path, "--out", path.parent / "." / path.name)
            self.assertEqual(proc.returncode, 2, f"{script}: {proc.stderr}")
            self.assertIn("refused", proc.stderr)
            self.assertEqual(path.read_bytes(), before, script)

    def test_outputs_are_written_whole_or_not_at_all(self):
        target = self.dir / "README.md"
        target.write_text("the last whole file\n")

        def half_then_fail(tmp):
            Path(tmp).write_text("half of a")
            raise KeyboardInterrupt

        with self.assertRaises(KeyboardInterrupt):
            files.written_atomically(target, half_then_fail)
        self.assertEqual(target.read_text(), "the last whole file\n")
        self.assertEqual(sorted(p.name for p in self.dir.iterdir()), ["README.md"])
        files.write_atomically(target, "new\n")
        self.assertEqual(target.read_text(), "new\n")
        mask = os.umask(0)
        os.umask(mask)
        self.assertEqual(target.stat().st_mode & 0o777, 0o666 & ~mask)  # not mkstemp's 0600
        self.assertEqual(sorted(p.name for p in self.dir.iterdir()), ["README.md"])

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
