"""Throughput against threads: micro_nns's threaded records and sweeps run at several thread counts, read apart
from the single-threaded cells the other figures draw."""
import json
import tempfile
import unittest
from unittest import mock
from pathlib import Path

import fixtures  # first: puts plots/ on the path
import fig_icp  # noqa: E402
import fig_threads  # noqa: E402
import report  # noqa: E402
import results_io  # noqa: E402
import style  # noqa: E402

QUERIES = 60000


def micro_record(adapter, max_dist, ms, threads=1, repetition=0):
    """A micro_nns repetition: CPU time on one thread, wall time (real_time) on several."""
    name = f"Ranged1NN/fig3/{adapter}/{max_dist:.2f}" + (f"/threads:{threads}/real_time" if threads > 1 else "")
    return {"name": name, "run_name": name, "run_type": "iteration", "repetition_index": repetition,
            "real_time": ms, "cpu_time": ms * threads, "time_unit": "ms", "items_per_call": float(QUERIES)}


def micro_file(path):
    records = [micro_record("ours_kdtree", 0.1, 6.0), micro_record("ours_kdtree", 0.1, 5.0, repetition=1),
               micro_record("ours_kdtree", 0.1, 3.0, threads=2), micro_record("ours_kdtree", 0.1, 2.0, threads=3),
               micro_record("nanoflann_kdtree", 0.1, 12.0), micro_record("nanoflann_kdtree", 0.1, 6.5, threads=2),
               micro_record("flann_kdtree", 0.1, 9.0)]  # one thread only: nothing to draw
    path.write_text(json.dumps({"context": {"date": "2024-01-01T00:00:00"}, "benchmarks": records}))
    return path


def sweep_file(directory, threads, factor):
    """The fixture sweep and builds on the Figure 3 pair, run given `threads` threads, each search time multiplied
    by factor; ours_kdtree builds on them (1.0 s on one, 0.6 s on more), the others on one."""
    records = fixtures.sweep_records(shapes=("hollow_sphere",))
    for rec in records:
        rec.update(threads=threads, n_queries=QUERIES)
        for field in ("real_time", "cpu_time", "median_seconds", "mean_seconds", "min_seconds"):
            if rec.get(field):
                rec[field] *= factor
    for rec in fixtures.build_records(shapes=("hollow_sphere",)):
        on_threads = threads if rec["adapter"] == "ours_kdtree" else 1
        if rec["adapter"] == "ours_kdtree":
            rec.update(build_seconds=1.0 if on_threads == 1 else 0.6)
        records.append({**rec, "threads": on_threads})
    path = fixtures.write(directory / f"sweep_threads{threads}.json", "quick", records)
    doc = json.loads(path.read_text())
    doc["context"]["config"] = {"threads": threads}
    path.write_text(json.dumps(doc))
    return path


def icp_file(directory, threads, factor):
    """The fixture's ICP runs on the real pairs, run_icp given `threads` threads on each pair, each time multiplied
    by factor; ours_kdtree's searches run on them, the others' on one (as adapters that cannot share an index)."""
    records = fixtures.icp_real_records()
    for rec in records:
        rec.update(icp_seconds=rec["icp_seconds"] * factor, threads=threads if rec["adapter"] == "ours_kdtree" else 1)
    path = fixtures.write(directory / f"icp_threads{threads}.json", "icp_real", records)
    doc = json.loads(path.read_text())
    pairs = sorted({rec["pair"] for rec in records})
    doc["context"]["config"] = {"pairs": [{"pair": p, "icp": {"threads": threads}} for p in pairs]}
    path.write_text(json.dumps(doc))
    return path


class FigThreadsTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def assertRates(self, got, expected):
        self.assertEqual(sorted(got), sorted(expected))
        for threads, rate in expected.items():
            self.assertAlmostEqual(got[threads] / rate, 1.0, places=12)

    def test_micro_throughput_is_queries_over_the_fastest_wall_time(self):
        results = results_io.load([micro_file(self.dir / "micro.json")])
        rates = fig_threads.micro_throughputs(results)
        self.assertEqual(list(rates), [("fig3", 0.1)])
        self.assertRates(rates[("fig3", 0.1)]["ours_kdtree"], {1: QUERIES / 5e-3, 2: QUERIES / 3e-3, 3: QUERIES / 2e-3})
        self.assertRates(rates[("fig3", 0.1)]["nanoflann_kdtree"], {1: QUERIES / 12e-3, 2: QUERIES / 6.5e-3})
        self.assertNotIn("flann_kdtree", rates[("fig3", 0.1)])
        # The single-threaded targets still read CPU time, and the threaded names stay out of them.
        self.assertAlmostEqual(results_io.micro_cells(results)[("fig3", "ours_kdtree", 0.1)], 5e-3)

    def test_sweeps_at_two_thread_counts_are_no_duplicates_and_draw_one_thread(self):
        one, two = sweep_file(self.dir, 1, 1.0), sweep_file(self.dir, 2, 0.5)
        results = results_io.load([one, two])  # the run on threads read last: the newer
        self.assertEqual(results.duplicates, {})
        self.assertEqual({c.threads for c in results.sweep}, {1})
        builds = results_io.latest_builds(results)
        self.assertEqual(builds[("hollow_sphere", "ours_kdtree")].build_seconds, 1.0)  # its build on one thread
        self.assertEqual({c.threads for c in results.sweep_threads}, {1, 2})
        rates = fig_threads.sweep_throughputs(results)
        self.assertEqual(sorted(rates), [("hollow_sphere -> hollow_sphere", 0.1), ("hollow_sphere -> hollow_sphere", 1.0)])
        kd = rates[("hollow_sphere -> hollow_sphere", 0.1)]["ours_kdtree"]
        self.assertAlmostEqual(kd[2] / kd[1], 2.0)

    def test_a_sweep_on_threads_alone_is_drawn_and_said(self):
        results_io._WARNED.clear()
        with mock.patch.object(results_io, "warn", wraps=results_io.warn) as warned:
            results = results_io.load([sweep_file(self.dir, 2, 0.5)])
        self.assertTrue(results.sweep)
        self.assertEqual({c.threads for c in results.sweep}, {2})
        self.assertTrue(any("on 2 threads only" in str(call) for call in warned.call_args_list))
        self.assertEqual(fig_threads.sweep_throughputs(results), {})

    def test_icp_runs_at_two_thread_counts_are_no_duplicates_and_draw_one_thread(self):
        results = results_io.load([icp_file(self.dir, 1, 1.0), icp_file(self.dir, 2, 0.5)])  # threads read last
        self.assertEqual(results.duplicates, {})
        times = fig_icp.real_times(results)["sick_office"]
        self.assertAlmostEqual(times["ours_kdtree"][0], fixtures.SPEED["ours_kdtree"])  # its one-thread run
        self.assertEqual(fig_icp.bucket_text(times["ours_kdtree"][2]), "")

    def test_icp_on_threads_alone_is_drawn_and_said(self):
        results_io._WARNED.clear()
        with mock.patch.object(results_io, "warn", wraps=results_io.warn) as warned:
            results = results_io.load([icp_file(self.dir, 2, 0.5)])
        self.assertTrue(any("ICP runs ran on 2 threads only" in str(call) for call in warned.call_args_list))
        times = fig_icp.real_times(results)["sick_office"]
        self.assertEqual(fig_icp.bucket_text(times["ours_kdtree"][2]), " (2 threads)")
        self.assertEqual(fig_icp.bucket_text(times["nanoflann_kdtree"][2]), "")

    def test_figure_written_or_skipped(self):
        style.setup()
        out = self.dir / "figures"
        png = fig_threads.fig10(results_io.load([micro_file(self.dir / "micro.json")]), out)
        self.assertTrue(png.is_file())
        self.assertTrue((out / "fig10_threads.svg").is_file())
        self.assertIsNone(fig_threads.fig10(results_io.load([sweep_file(self.dir, 1, 1.0)]), self.dir / "none"))
        sections = dict(report.all_figures(results_io.load([micro_file(self.dir / "micro.json")])))
        [panel] = sections["Figure 10: throughput against threads"]
        self.assertEqual([t["x"] for t in panel["data"]], [[1, 2], [1, 2, 3]])  # nanoflann, then ours
        self.assertFalse((self.dir / "none" / "fig10_threads.png").exists())


if __name__ == "__main__":
    unittest.main()
