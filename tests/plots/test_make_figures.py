"""make_figures.py on fixture results: every figure is written and non-empty; absent data skips its figure."""
import json
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures

SCRIPT = fixtures.PLOTS_DIR / "make_figures.py"
FIGURES = ("fig2_icp_bucket", "fig3_hollow_cube_vs_hollow_sphere", "fig3_strategies", "fig4_construction", "fig5_icp_real",
           "fig6_grid_all", "fig7_grid_best")


def run(args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, timeout=300)


class MakeFiguresTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def test_all_figures_and_table_from_full_fixture(self):
        files = fixtures.write_all(self.dir)
        out = self.dir / "figures"
        proc = run([*files, "--out", out])
        self.assertEqual(proc.returncode, 0, proc.stderr)
        for stem in FIGURES:
            for ext in ("png", "svg"):
                path = out / f"{stem}.{ext}"
                self.assertTrue(path.is_file(), f"{path} missing; stderr: {proc.stderr}")
                self.assertGreater(path.stat().st_size, 5000, path)
        table = (out / "table1.md").read_text()
        for expected in ("| flann_kdtree | FLANN | 1.0 | k-d tree | ? | native | native | via k-NN |",
                         "| ours_octree | ours | 1.0 | octree | ? | via box | via box | **native** |"):
            self.assertIn(expected, table)

    def test_absent_data_skips_figures_with_a_message(self):
        sweep_only = fixtures.write(self.dir / "sweep.json", "paper",
                                    fixtures.sweep_records(shapes=("filled_cube", "filled_sphere")))
        out = self.dir / "figures"
        proc = run([sweep_only, "--out", out])
        self.assertEqual(proc.returncode, 0, proc.stderr)
        for stem in ("fig2_icp_bucket", "fig3_hollow_cube_vs_hollow_sphere", "fig4_construction", "fig5_icp_real"):
            self.assertFalse((out / f"{stem}.png").exists(), stem)
            self.assertIn(f"{stem.split('_')[0]}: no ", proc.stderr)
        self.assertTrue((out / "fig6_grid_all.png").is_file())  # partial grid: drawn, empty panels say so
        self.assertTrue((out / "fig7_grid_best.png").is_file())

    def test_figures_these_inputs_cannot_draw_are_removed(self):
        out = self.dir / "figures"
        self.assertEqual(run([*fixtures.write_all(self.dir), "--out", out]).returncode, 0)
        (out / "notes.md").write_text("mine")
        sweep_only = fixtures.write(self.dir / "sweep.json", "paper",
                                    fixtures.sweep_records(shapes=("filled_cube", "filled_sphere")))
        proc = run([sweep_only, "--out", out])
        self.assertEqual(proc.returncode, 0, proc.stderr)
        for stem in ("fig2_icp_bucket", "fig3_hollow_cube_vs_hollow_sphere", "fig4_construction", "fig5_icp_real"):
            self.assertFalse((out / f"{stem}.png").exists(), stem)
            self.assertFalse((out / f"{stem}.svg").exists(), stem)
            self.assertIn(f"removed {out / stem}.png", proc.stdout)
        self.assertTrue((out / "fig6_grid_all.png").is_file())
        self.assertEqual((out / "notes.md").read_text(), "mine")

    def test_no_results_file_is_a_message_not_a_crash(self):
        bad = self.dir / "bad.json"
        bad.write_text(json.dumps({"context": {}}))
        proc = run([bad, "--out", self.dir / "figures"])
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("not a results file", proc.stderr)
        self.assertFalse((self.dir / "figures").exists())


if __name__ == "__main__":
    unittest.main()
