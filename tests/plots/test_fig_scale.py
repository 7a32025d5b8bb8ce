"""The scale figure and exponent table on fixture results: exponents recovered, skipped sizes left out."""
import re
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures  # first: puts plots/ on the path
import fig_scale  # noqa: E402
import results_io  # noqa: E402

SCRIPT = fixtures.PLOTS_DIR / "make_figures.py"


def run(args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, timeout=300)


def exponent_rows(text):
    """{adapter: (sizes run, query exponent, build exponent, stopped)} from scale_exponents.md."""
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 9 and re.fullmatch(r"\d+", cells[1]):
            rows[cells[0]] = (int(cells[1]), float(cells[4]), float(cells[5]), cells[8])
    return rows


class FigScaleTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def test_figure_and_exponents(self):
        path = fixtures.write(self.dir / "scale.json", "scale", fixtures.scale_records())
        out = self.dir / "figures"
        proc = run([path, "--out", out])
        self.assertEqual(proc.returncode, 0, proc.stderr)
        for ext in ("png", "svg"):
            self.assertGreater((out / f"fig8_scale.{ext}").stat().st_size, 5000)
        rows = exponent_rows((out / "scale_exponents.md").read_text())
        self.assertEqual(set(rows), set(fixtures.SCALE_LAWS))
        for adapter, (q_exp, b_exp, sizes_run) in fixtures.SCALE_LAWS.items():
            run_count, query_exp, build_exp, stopped = rows[adapter]
            self.assertEqual(run_count, sizes_run, adapter)
            self.assertAlmostEqual(query_exp, q_exp, places=2, msg=adapter)
            self.assertAlmostEqual(build_exp, b_exp, places=2, msg=adapter)
            self.assertEqual(stopped == "-", sizes_run == len(fixtures.SCALE_SIZES), f"{adapter}: {stopped}")
        self.assertIn(f"at {fixtures.SCALE_SIZES[3]}: skipped on models of", rows["brute_force"][3])

    def test_series_read_sizes_from_context_when_records_lack_them(self):
        records = [{k: v for k, v in r.items() if k not in ("n_points", "n_queries")} for r in fixtures.scale_records()]
        path = fixtures.write(self.dir / "scale.json", "scale", records)
        doc = path.read_text().replace('"context": {', '"context": {"datasets": ' + str(
            [{"spec": f"city-{n}", "role": "model", "points": n} for n in fixtures.SCALE_SIZES]
            + [{"spec": "city-q", "role": "query", "points": fixtures.SCALE_QUERIES}]).replace("'", '"') + ", ", 1)
        path.write_text(doc)
        key, cells = fig_scale.scale_cells(results_io.load([path]))
        self.assertEqual(key, ("city-q", "ranged", 0.1, 1))
        self.assertEqual(len({c.n_points for c in cells}), len(fixtures.SCALE_SIZES))

    def test_no_scale_records_skips_with_a_message(self):
        files = fixtures.write_all(self.dir)  # the paper's sweeps: every model has the same size
        out = self.dir / "figures"
        proc = run([*files, "--out", out])
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("fig8: no scale records", proc.stderr)
        self.assertFalse((out / "fig8_scale.png").exists())
        self.assertFalse((out / "scale_exponents.md").exists())


if __name__ == "__main__":
    unittest.main()
