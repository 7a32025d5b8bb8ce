"""readme_tables.py's generated tables on fixture results."""
import json
import tempfile
import unittest
from pathlib import Path

import fixtures

import readme_tables  # noqa: E402
import results_io  # noqa: E402

class ReadmeTablesTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, name, context, records=()):
        path = self.dir / name
        path.write_text(json.dumps({"context": context, "benchmarks": list(records)}))
        return path

    def test_reference_runs_say_what_each_file_records_and_not_recorded_otherwise(self):
        new = fixtures.context("quick", date="2024-01-02T00:00:00", wall_seconds=300.0,
                               commit=fixtures.CLEAN_COMMIT + "+dirty")
        old = {"date": "2024-01-01T00:00:00", "nnb_experiment": "icp_real", "load_avg": [1.5, 1.0, 1.0]}
        results = results_io.load([self.write("new.json", new), self.write("old.json", old)])
        lines = readme_tables.reference_runs_lines(results)
        self.assertEqual(len(lines), 4)
        self.assertEqual(lines[2], f"| `{self.dir / 'old.json'}` | icp_real | not recorded | not recorded | "
                                   "1.50 -> not recorded | 2024-01-01T00:00:00 | not recorded |")
        self.assertEqual(lines[3], f"| `{self.dir / 'new.json'}` | quick | `run_sweep --experiment quick` | "
                                   "0123456 (dirty) | 0.10 -> 0.20 | 2024-01-02T00:00:00 | 5 min |")


if __name__ == "__main__":
    unittest.main()
