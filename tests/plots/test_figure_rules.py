"""What makes the figures readable: page width, approximate adapters never ranked, clouds in size order."""
import subprocess
import sys
import tempfile
import unittest
from unittest import mock
from pathlib import Path

import fixtures  # first: puts plots/ on the path
import fig_build  # noqa: E402
import fig_icp  # noqa: E402
import fig_speedup  # noqa: E402
import fig_sweep  # noqa: E402
import readme_tables  # noqa: E402
import report  # noqa: E402
import results_io  # noqa: E402
import style  # noqa: E402
from PIL import Image  # noqa: E402

SCRIPT = fixtures.PLOTS_DIR / "make_figures.py"


class FigureRulesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = Path(cls.tmp.name)
        cls.files = fixtures.write_all(cls.dir) + [fixtures.approx_file(cls.dir / "approx.json"),
                                                   fixtures.write(cls.dir / "scale.json", "scale",
                                                                  fixtures.scale_records())]
        cls.results = results_io.load(cls.files)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_every_png_fits_a_page(self):
        out = self.dir / "figures"
        proc = subprocess.run([sys.executable, str(SCRIPT), *map(str, self.files), "--out", str(out)],
                              capture_output=True, text=True, timeout=600)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        pngs = sorted(out.glob("*.png"))
        self.assertGreaterEqual(len(pngs), 8)
        for png in pngs:
            self.assertLessEqual(Image.open(png).size[0], style.MAX_WIDTH_PX, png.name)

    def test_approximate_adapter_is_never_among_the_fastest(self):
        r = self.results
        self.assertTrue(style.is_approximate(fixtures.APPROX, r))
        series = results_io.sweep_series(r, *fig_sweep.FIG3)
        self.assertIn((fixtures.APPROX, "ranged"), series)  # it is the fastest series drawn
        self.assertNotIn(fixtures.APPROX, [k[0] for k in fig_sweep.fastest_exact(r, series, 3)])
        self.assertNotIn(fixtures.APPROX, [k[0] for k in fig_sweep.best_keys(r)])
        for pair, times in fig_icp.real_times(r).items():
            ranked, approximate = fig_icp.ranked_pair(r, times)
            self.assertNotIn(fixtures.APPROX, ranked, pair)
            self.assertIn(fixtures.APPROX, approximate, pair)
        self.assertNotIn(fixtures.APPROX, "\n".join(readme_tables.icp_lines(r)))

    def test_bucket_curves_share_a_log_time_axis(self):
        drawn = []
        with mock.patch.object(style, "save", lambda fig, out_dir, stem: drawn.append(fig)):
            fig_icp.fig2(self.results, self.dir / "unused")
        self.assertEqual(len(drawn), 1)
        self.assertEqual([ax.get_yscale() for ax in drawn[0].axes], ["log"])
        self.assertEqual(report.bucket_figure(self.results)["layout"]["yaxis"]["type"], "log")

    def test_approximate_adapter_is_drawn_grey_and_hollow(self):
        kw = style.marker_kw(fixtures.APPROX, self.results)
        self.assertEqual(kw["color"], style.APPROX_COLOUR)
        self.assertEqual(kw["markerfacecolor"], "white")
        self.assertIn("approx", style.library_label(fixtures.APPROX, self.results))

    def test_strategies_have_four_distinct_line_styles(self):
        kinds = [("ranged", "native"), ("ranged", "via_knn"), ("radius", "native"), ("knn", "native")]
        styles = [repr(style.line_kw("ours_kdtree", k, s)["linestyle"]) for k, s in kinds]
        self.assertEqual(len(set(styles)), 4)

    def test_libraries_get_distinct_colours(self):
        colours = {style.adapter_colour(a, self.results) for a in fixtures.ADAPTERS if a != fixtures.APPROX}
        families = {style.family(a) for a in fixtures.ADAPTERS if a != fixtures.APPROX}
        self.assertEqual(len(colours), len(families))

    def test_strategies_drawn_from_the_set_size_they_ran_at(self):
        def sized(records, n):
            return [{**r, "n_points": n, "n_queries": n} for r in records]
        model, query = fig_sweep.FIG3
        grid = fixtures.write(self.dir / "grid.json", "paper", sized(fixtures.sweep_records(), 60000))
        quick = fixtures.write(self.dir / "quick.json", "quick",
                               sized(fixtures.sweep_records(shapes=(model, query)) + fixtures.strategy_records(), 15000),
                               date="2025-01-01T00:00:00")
        results = results_io.load([grid, quick])
        self.assertEqual({c.n_points for c in results.sweep if (c.model, c.query) == (model, query)}, {60000})
        shown = fig_sweep.ranged_strategies(results, model, query)
        self.assertEqual(sorted(shown), ["flann_kdtree"])
        self.assertEqual(sorted(shown["flann_kdtree"]), ["via_knn", "via_radius"])
        self.assertEqual({c.n_points for cells in shown["flann_kdtree"].values() for c in cells}, {15000})
        self.assertEqual(fig_sweep.ranged_strategies(results_io.load([grid]), model, query), {})

    def test_a_long_adapter_legend_is_saved_whole(self):
        style.setup()
        fig = style.plt.figure(figsize=(10, 4))
        grid_spec = fig.add_gridspec(2, 1, height_ratios=[3, 0.6])
        fig.add_subplot(grid_spec[0])
        legend_ax = fig.add_subplot(grid_spec[1])
        style.legends_in(legend_ax, [f"adapter_{i}" for i in range(40)], {"native"}, self.results)
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        [adapters] = [a for a in legend_ax.artists if a is not legend_ax.get_legend()]
        saved = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans)  # what bbox_inches="tight" keeps
        shown = adapters.get_window_extent(renderer)
        self.assertLess(shown.y0, legend_ax.get_window_extent(renderer).y0)  # the list overflows its axis ...
        self.assertLessEqual(saved.y0, shown.y0 + 1e-6)  # ... and is saved all the same
        style.plt.close(fig)

    def test_a_wide_adapter_legend_puts_the_line_styles_below_it(self):
        style.setup()
        for names, beside in (([f"adapter_{i}" for i in range(12)], True),
                              ([f"an_adapter_with_a_long_name_{i} (approx.)" for i in range(36)], False)):
            fig = style.plt.figure(figsize=(13, 6))
            grid_spec = fig.add_gridspec(2, 1, height_ratios=[3, 1.2])
            fig.add_subplot(grid_spec[0])
            legend_ax = fig.add_subplot(grid_spec[1])
            style.legends_in(legend_ax, names, {"native", "via_knn"}, self.results)
            fig.canvas.draw()
            renderer = fig.canvas.get_renderer()
            [adapters] = [a for a in legend_ax.artists if a is not legend_ax.get_legend()]
            a, s = adapters.get_window_extent(renderer), legend_ax.get_legend().get_window_extent(renderer)
            self.assertFalse(a.overlaps(s), f"{len(names)} adapters: the legends overlap")
            self.assertEqual(s.x0 > a.x1, beside, f"{len(names)} adapters: line styles beside {s.x0 > a.x1}")
            saved = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans)
            self.assertLessEqual(saved.y0, min(a.y0, s.y0) + 1e-6)  # both saved whole
            style.plt.close(fig)

    def test_clouds_in_size_order(self):
        names = ["city-15k", "city-16m", "city-1m", "city-250k", "city-4m", "city-60k", "hollow_cube"]
        sizes = {"city-15k": 15e3, "city-60k": 6e4, "city-250k": 2.5e5, "city-1m": 1e6, "city-4m": 4e6, "city-16m": 1.6e7,
                 "hollow_cube": 6e4}
        r = results_io.Results()
        r.builds = [results_io.Build(m, "ours_kdtree", 1.0, None, sizes[m], 0) for m in names]
        self.assertEqual(fig_build.model_order(r, names),
                         ["hollow_cube", "city-15k", "city-60k", "city-250k", "city-1m", "city-4m", "city-16m"])

    def test_builds_come_from_the_newest_run(self):
        r = results_io.Results()
        r.files = [("old.json", {"date": "2024-01-01"}), ("new.json", {"date": "2025-01-01"})]
        r.builds = [results_io.Build("m", "a", 5.0, None, 10, 1), results_io.Build("m", "a", 1.0, None, 10, 0)]
        self.assertEqual(fig_build.build_table(r), {("m", "a"): 5.0})
        r.builds = [results_io.Build("m", "a", 5.0, None, 60000, 1), results_io.Build("m", "a", 1.0, None, 15000, 0)]
        self.assertEqual(fig_build.model_title(r, "m"), "m (60,000 points)", "the size of the build drawn")
        r.builds.append(results_io.Build("m", "only_in_old", 0.5, None, 15000, 0))
        self.assertEqual(fig_build.build_table(r), {("m", "a"): 5.0}, "one set size per model: the newest run's")

    def test_speed_ups_are_over_the_faster_nanoflann_at_each_distance(self):
        adapters = {**fixtures.ADAPTERS, "nanoflann_latest": ("nanoflann", "k-d tree", {"ranged": "native"})}
        records = fixtures.sweep_records(shapes=("hollow_sphere",), adapters=adapters,
                                         speed={"nanoflann_latest": 1.0},
                                         kind_factor={("nanoflann_latest", "ranged"): 0.5})
        records = [r for r in records if not (r["adapter"] == "nanoflann_latest" and r.get("max_dist") == 0.5)]
        with tempfile.TemporaryDirectory() as tmp:
            results = results_io.load([fixtures.write(Path(tmp) / "s.json", "paper", records)])
        ratios = dict(fig_speedup.sweep_ratios(results, "hollow_sphere", "hollow_sphere")["ours_kdtree"])
        self.assertAlmostEqual(ratios[0.4], 0.5 / 0.9, msg="the newest nanoflann, twice as fast, is the baseline")
        self.assertAlmostEqual(ratios[0.5], 1.0 / 0.9, msg="where it did not run, Debian's is")
        self.assertEqual(fig_icp.faster_nanoflann({"nanoflann_kdtree": (2.0,), "nanoflann_latest": (1.5,)}),
                         "nanoflann_latest")


if __name__ == "__main__":
    unittest.main()
