"""Inputs the plots must not trust silently: dirty trees, overlapping runs, duplicated records; partial verdicts."""
import json
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixtures
import findings
import provenance
import results_io

FINDINGS = fixtures.PLOTS_DIR / "findings.py"
QUICK_SHAPES = ("hollow_sphere", "hollow_cube")


def run_findings(*args):
    return subprocess.run([sys.executable, str(FINDINGS), *map(str, args)], capture_output=True, text=True,
                          timeout=120)


def sized(records, n):
    """The records as swept at n points and n queries."""
    return [dict(r, n_points=n, n_queries=n) for r in records]


class ProvenanceTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)
        self.out = self.dir / "F.md"

    def tearDown(self):
        self.tmp.cleanup()

    def test_dirty_input_is_refused_unless_allowed_then_marked(self):
        f = fixtures.write(self.dir / "s.json", "paper", fixtures.build_records(), commit="abc+dirty")
        proc = run_findings(f, "--out", self.out)
        self.assertEqual(proc.returncode, 2)
        self.assertEqual(len(proc.stderr.strip().splitlines()), 1, proc.stderr)
        self.assertIn("dirty", proc.stderr)
        self.assertFalse(self.out.exists())
        proc = run_findings(f, "--out", self.out, "--allow-dirty")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        text = self.out.read_text()
        self.assertIn("NOT A CLEAN RUN", text)
        self.assertIn("commit abc+dirty (DIRTY TREE); command `run_sweep --experiment paper`", text)

    def test_overlapping_runs_are_refused_unless_allowed(self):
        a = fixtures.write(self.dir / "a.json", "paper", fixtures.build_records(shapes=("filled_cube",)),
                           date="2024-01-01T10:00:00+00:00", wall_seconds=3600)
        b = fixtures.write(self.dir / "b.json", "paper", fixtures.build_records(shapes=("hollow_cube",)),
                           date="2024-01-01T10:30:00+00:00", wall_seconds=60)
        c = fixtures.write(self.dir / "c.json", "paper", fixtures.build_records(shapes=("filled_sphere",)),
                           date="2024-01-01T11:00:01+00:00", wall_seconds=60)
        proc = run_findings(a, b, "--out", self.out)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("overlapped", proc.stderr)
        self.assertEqual(run_findings(a, c, "--out", self.out).returncode, 0)
        proc = run_findings(a, b, "--out", self.out, "--allow-overlap")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("runs overlapped in time", self.out.read_text())
        self.assertIn("wall time 3600 s", self.out.read_text())

    def test_a_resumed_run_is_checked_by_its_last_sitting(self):
        """The wall time of a resumed run is its last sitting's: the interval starts at that sitting, and the
        provenance line says the earlier sittings went unchecked."""
        a = fixtures.write(self.dir / "a.json", "paper", fixtures.build_records(shapes=("filled_cube",)),
                           date="2024-01-01T09:00:00+00:00", wall_seconds=600)
        doc = json.loads(a.read_text())
        doc["context"]["resumed"] = ["2024-01-01T12:00:00+00:00"]
        a.write_text(json.dumps(doc))
        between = fixtures.write(self.dir / "b.json", "paper", fixtures.build_records(shapes=("hollow_cube",)),
                                 date="2024-01-01T09:05:00+00:00", wall_seconds=60)
        during = fixtures.write(self.dir / "c.json", "paper", fixtures.build_records(shapes=("filled_sphere",)),
                                date="2024-01-01T12:05:00+00:00", wall_seconds=60)
        proc = run_findings(a, between, "--out", self.out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("its last of 2 sittings", self.out.read_text())
        proc = run_findings(a, during, "--out", self.out)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("overlapped", proc.stderr)

    def test_duplicates_need_prefer_newest_and_the_newest_wins(self):
        old = fixtures.write(self.dir / "z_old.json", "paper", fixtures.sweep_records(shapes=QUICK_SHAPES),
                             date="2024-01-01T00:00:00")
        new = fixtures.write(self.dir / "a_new.json", "quick",
                             fixtures.sweep_records(shapes=QUICK_SHAPES, speed={"ours_kdtree": 2.0}),
                             date="2024-02-01T00:00:00")
        proc = run_findings(old, new, "--out", self.out)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("--prefer newest", proc.stderr)
        self.assertEqual(run_findings(old, new, "--out", self.out, "--prefer", "newest").returncode, 0)
        results = results_io.load([new, old], prefer="newest")
        got = {c.seconds for c in results.sweep if c.adapter == "ours_kdtree" and c.search == "knn"}
        self.assertEqual(got, {2.0 * 0.15})

    def test_a_combination_at_other_set_sizes_is_left_out(self):
        small = sized(fixtures.sweep_records(shapes=("hollow_sphere",), speed={"ours_kdtree": 0.1}), 15000)
        small.append(dict(small[-1], name=small[-1]["name"] + "/only_here", max_dist=0.77))
        old = fixtures.write(self.dir / "quick.json", "quick", small, date="2024-01-01T00:00:00")
        new = fixtures.write(self.dir / "grid.json", "paper", sized(fixtures.sweep_records(shapes=("hollow_sphere",)),
                             60000), date="2024-02-01T00:00:00")
        for prefer in ("newest", None):
            results = results_io.load([new, old], prefer=prefer)
            self.assertEqual({c.n_points for c in results.sweep}, {60000}, "the newest file's sizes, read in any order")
        self.assertNotIn(0.77, {c.max_dist_m for c in results.sweep})
        self.assertEqual(results.duplicates, {}, "the same names at other set sizes are other cells")
        self.assertEqual(run_findings(old, new, "--out", self.out).returncode, 0)
        self.assertNotIn("NOT A CLEAN RUN", self.out.read_text())

    def test_a_later_smaller_sweep_leaves_the_larger_series_drawn(self):
        def records(n, **speed):
            shapes = ("hollow_sphere",)
            return sized(fixtures.sweep_records(shapes=shapes, **speed) + fixtures.build_records(shapes=shapes), n)
        grid = fixtures.write(self.dir / "grid.json", "paper", records(60000), date="2024-01-01T00:00:00")
        quick = fixtures.write(self.dir / "quick.json", "quick", records(15000, speed={"ours_kdtree": 0.1}),
                               date="2024-02-01T00:00:00")
        for files in ([grid, quick], [quick, grid]):
            results = results_io.load(files)
            self.assertEqual({c.n_points for c in results.sweep}, {60000}, "quick's later 15,000 points are not drawn")
            self.assertEqual({b.n_points for b in results_io.latest_builds(results).values()} - {None}, {60000})

    def test_every_sitting_in_the_run_log_is_checked_for_overlap(self):
        """A resumed run's earlier sittings have no end in its file; the reference run's log has them all."""
        def run(name, date, wall, resumed=()):
            f = fixtures.write(self.dir / name, "paper", fixtures.build_records(shapes=(name[:-5],)), date=date,
                               wall_seconds=wall)
            doc = json.loads(f.read_text())
            doc["context"].update(command_line=f"run_sweep --out /run/{name}", resumed=list(resumed))
            f.write_text(json.dumps(doc))
            return f
        a = run("hollow_cube.json", "2024-01-01T09:00:00+00:00", 600, ["2024-01-01T12:00:00+00:00"])
        b = run("filled_cube.json", "2024-01-01T10:00:00+00:00", 60)
        log = self.dir / "reference_run_log.txt"
        log.write_text("2024-01-01T09:00:00+00:00 start a at 0123456, tree clean: run_sweep --out /run/hollow_cube.json"
                       " | load 1.0 1.0 1.0\n2024-01-01T10:30:00+00:00 end a rc=124 | load 1.0 1.0 1.0\n"
                       "2024-01-01T12:00:00+00:00 start a at 0123456, tree clean: run_sweep --out /run/hollow_cube.json"
                       " | load 1.0 1.0 1.0\n2024-01-01T12:10:00+00:00 end a rc=0 | load 1.0 1.0 1.0\n")
        proc = run_findings(a, b, "--out", self.out)
        self.assertEqual(proc.returncode, 2, "b ran during a's first sitting (09:00-10:30), which only the log knows")
        self.assertIn("overlapped", proc.stderr)
        log.write_text(log.read_text().replace("10:30:00", "09:50:00"))
        proc = run_findings(a, b, "--out", self.out)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        self.assertIn("2 sittings, each checked for overlap from the run's log", self.out.read_text())

    def test_an_output_path_with_spaces_is_read_whole(self):
        self.assertEqual(provenance.output_path("'run_sweep' '--out' '/my runs/a.json'"), "/my runs/a.json")
        self.assertEqual(provenance.output_path("'micro_nns' '--benchmark_out=/my runs/m.json'"), "/my runs/m.json")
        self.assertEqual(provenance.output_path("run_sweep --out /run/a.json"), "/run/a.json")
        self.assertIsNone(provenance.output_path("'nns_query' '--out' '-'"))
        log = ("2024-01-01T09:00:00+00:00 start a at 0123456, tree clean: 'run_sweep' '--out' '/my runs/a.json'"
               " | load 1.0 1.0 1.0\n2024-01-01T09:10:00+00:00 end a rc=0 | load 1.0 1.0 1.0\n"
               "2024-01-01T09:10:00+00:00 start b at 0123456, tree clean: 'run_sweep' '--out' '/my runs/b.json'"
               " | load 1.0 1.0 1.0\n2024-01-01T09:20:00+00:00 end b rc=0 | load 1.0 1.0 1.0\n")
        self.assertEqual(sorted(provenance.run_log_sittings(log)), ["/my runs/a.json", "/my runs/b.json"])

    def test_icp_experiment_name_is_read(self):
        f = fixtures.write(self.dir / "icp.json", "x", fixtures.icp_real_records())
        doc = f.read_text().replace('"experiment": "x"', '"nnb_experiment": "icp_real"')
        f.write_text(doc)
        self.assertEqual(run_findings(f, "--out", self.out).returncode, 0)
        self.assertIn("experiment icp_real", self.out.read_text())


class LikeForLikeTest(unittest.TestCase):
    def verdicts(self, records):
        with tempfile.TemporaryDirectory() as tmp:
            results = results_io.load([fixtures.write(Path(tmp) / "r.json", "quick", records)])
        return {v.number: v for v in findings.evaluate(results, 0.1)}

    def test_one_combination_gives_partial_verdicts(self):
        got = self.verdicts(fixtures.sweep_records(shapes=QUICK_SHAPES))
        self.assertEqual(got[1].verdict, "HOLDS on 4 of 16 combinations only")
        self.assertEqual(got[5].verdict, "HOLDS on 2 of 12 combinations only")
        self.assertEqual(got[6].verdict, "NOT TESTED")  # no ICP file
        for v in got.values():
            self.assertTrue(v.basis.startswith("rests on"), v)

    def test_budget_stopped_ranged_is_not_measured_not_replaced_by_knn(self):
        records = fixtures.sweep_records(kind_factor={("ours_kdtree", "ranged"): 40.0})
        got = self.verdicts(records)
        self.assertIn("not measured", got[5].basis)
        self.assertNotIn("rests on 0 comparisons", got[5].basis)
        # ours' ranged is 36x slower than the rivals wherever measured: no k-NN time may rescue it
        self.assertEqual(got[5].verdict, "DOES NOT HOLD")
        missing = int(got[5].basis.split("; ")[1].split()[0])
        self.assertGreater(missing, 0)

    def test_approximate_adapter_never_counts_as_fastest(self):
        with tempfile.TemporaryDirectory() as tmp:
            files = fixtures.write_all(tmp) + [fixtures.approx_file(Path(tmp) / "approx.json")]
            results = results_io.load(files)
        got = {v.number: v for v in findings.evaluate(results, 0.1)}
        self.assertEqual(got[7].verdict, "HOLDS")
        self.assertIn("rank 1", got[7].numbers[0])


if __name__ == "__main__":
    unittest.main()
