"""Reading results: units honoured, median preferred, skipped cells kept as skipped, bad records ignored."""
import json
import tempfile
import unittest
from pathlib import Path

import fixtures
import fig_icp
import results_io


def cell(name, **fields):
    parts = name.split("/")
    rec = {"name": name, "model": parts[1], "query": parts[2], "adapter": parts[3], "search": parts[4],
           "strategy": "native"}
    rec.update(fields)
    return rec


class ResultsIoTest(unittest.TestCase):
    def load(self, records):
        with tempfile.TemporaryDirectory() as tmp:
            return results_io.load([fixtures.write(Path(tmp) / "r.json", "paper", records)])

    def test_time_unit_and_median(self):
        r = self.load([cell("sweep/a/b/x/ranged/max_dist:0.10", max_dist=0.1, real_time=250.0, time_unit="ms"),
                       cell("sweep/a/b/x/ranged/max_dist:0.20", max_dist=0.2, real_time=9.0, time_unit="s",
                            median_seconds=0.5),
                       cell("sweep/a/b/x/knn", real_time=3.0, time_unit="s")])
        got = {c.max_dist_m: c.seconds for c in r.sweep}
        self.assertEqual(got, {0.1: 0.25, 0.2: 0.5, None: 3.0})

    def test_fastest_statistic_reads_the_fastest_call(self):
        records = [cell("sweep/a/b/x/ranged/max_dist:0.10", max_dist=0.1, real_time=250.0, time_unit="ms",
                        median_s=0.25, min_s=0.2),
                   cell("sweep/a/b/x/ranged/max_dist:0.20", max_dist=0.2, real_time=300.0, time_unit="ms"),
                   {"name": "build/a/x", "model": "a", "adapter": "x", "build_seconds": 0.5, "min_s": 0.4,
                    "index_bytes": 8}]
        with tempfile.TemporaryDirectory() as tmp:
            path = fixtures.write(Path(tmp) / "r.json", "paper", records)
            median, fastest = (results_io.load([path], statistic=s) for s in ("median", "fastest"))
        self.assertEqual({c.max_dist_m: c.seconds for c in median.sweep}, {0.1: 0.25, 0.2: 0.3})
        self.assertEqual({c.max_dist_m: c.seconds for c in fastest.sweep}, {0.1: 0.2})  # no fastest kept: left out
        self.assertEqual([(b.build_seconds, fastest.statistic) for b in fastest.builds], [(0.4, "fastest")])
        self.assertEqual([b.build_seconds for b in median.builds], [0.5])

    def test_icp_bucket_source(self):
        """An ICP file run at the best buckets of another file says, per adapter, best or default."""
        records = [{"name": f"icp/sick/{a}/bucket:{b}", "pair": "sick", "adapter": a, "bucket_size": b,
                    "icp_seconds": 1.0} for a, b in (("tuned", 64), ("untuned", 100))]
        with tempfile.TemporaryDirectory() as tmp:
            path = fixtures.write(Path(tmp) / "icp.json", "icp_real", records)
            doc = json.loads(path.read_text())
            doc["context"]["config"] = {"buckets_from": "icp_bucket.json", "best_buckets": {"tuned": 64}}
            path.write_text(json.dumps(doc))
            tuned_file = results_io.load([path])
            plain_file = results_io.load([fixtures.write(Path(tmp) / "plain.json", "icp_real", records)])
        self.assertEqual({r.adapter: r.bucket_source for r in tuned_file.icp}, {"tuned": "best", "untuned": "default"})
        self.assertEqual({r.bucket_source for r in plain_file.icp}, {None})
        times = fig_icp.real_times(tuned_file)["sick"]
        self.assertEqual(fig_icp.bucket_text(times["tuned"][2]), " (best bucket 64)")
        self.assertEqual(fig_icp.bucket_text(times["untuned"][2]), " (default bucket 100)")
        self.assertEqual(fig_icp.bucket_text(fig_icp.real_times(plain_file)["sick"]["tuned"][2]), " (bucket 64)")

    def test_skipped_and_incomplete_records(self):
        r = self.load([cell("sweep/a/b/x/radius/max_dist:0.90", max_dist=0.9, skipped="over budget",
                            real_time=0, time_unit="s"),
                       cell("sweep/a/b/x/radius/max_dist:0.10", real_time=1.0, time_unit="s"),  # no max_dist
                       cell("sweep/a/b/x/radius/max_dist:0.20", max_dist=0.2, real_time=1.0, time_unit="parsec"),
                       {"name": "something/else"}])
        self.assertEqual(len(r.sweep), 1)
        self.assertIsNone(r.sweep[0].seconds)
        self.assertEqual(r.sweep[0].skipped, "over budget")

    def test_adapter_metadata_from_context(self):
        r = self.load(fixtures.build_records())
        self.assertEqual(r.adapter_info("ann_kdtree")["library"], "ANN")
        self.assertEqual(len(r.builds), 4 * len(fixtures.ADAPTERS))


if __name__ == "__main__":
    unittest.main()
