#!/usr/bin/env python3
"""scripts/jobs.sh, how many compilers the README's commands run at once: one a core, but no more than the
available memory holds, at least one, and NNB_JOBS when set (a bad value refused in one line, exit 2). The
cores come from nproc (which OMP_NUM_THREADS sets) and the memory from a stand-in for /proc/meminfo.

Usage: test_parallel_jobs.py JOBS_SH"""
import os
import subprocess
import sys
import tempfile
import unittest

JOBS_SH = None


def meminfo(available_kib):
    lines = ["MemTotal:       25000000 kB"]
    if available_kib is not None:
        lines.append(f"MemAvailable:   {available_kib} kB")
    return "\n".join(lines + ["SwapTotal:             0 kB"]) + "\n"


class ParallelJobs(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.meminfo = os.path.join(self.tmp.name, "meminfo")

    def tearDown(self):
        self.tmp.cleanup()

    def jobs(self, cores, available_kib, call="build_jobs", **env):
        with open(self.meminfo, "w") as f:
            f.write(meminfo(available_kib))
        environment = {k: v for k, v in os.environ.items() if k != "NNB_JOBS"}
        environment.update(OMP_NUM_THREADS=str(cores), NNB_MEMINFO=self.meminfo, **env)
        return subprocess.run(["bash", "-c", f'set -euo pipefail; . "$0"; {call}', JOBS_SH],
                              capture_output=True, text=True, env=environment)

    def answer(self, *args, **env):
        result = self.jobs(*args, **env)
        self.assertEqual(result.returncode, 0, result.stderr)
        return int(result.stdout)

    def test_one_job_a_core_where_memory_is_plenty(self):
        self.assertEqual(self.answer(2, 24 << 20), 2)
        self.assertEqual(self.answer(8, 24 << 20), 8)

    def test_many_cores_and_little_memory_run_what_memory_holds(self):
        self.assertEqual(self.answer(64, 16 << 20), 10)  # 16 GiB at 1.5 GiB a compiler
        self.assertEqual(self.answer(64, 16 << 20, call="parallel_jobs 1024"), 16)

    def test_at_least_one_job_however_little_memory(self):
        self.assertEqual(self.answer(8, 200 << 10), 1)

    def test_without_a_memory_figure_one_job_a_core(self):
        self.assertEqual(self.answer(6, None), 6)
        result = subprocess.run(["bash", "-c", '. "$0"; build_jobs', JOBS_SH], capture_output=True, text=True,
                                env=dict(os.environ, OMP_NUM_THREADS="3", NNB_MEMINFO="/nonexistent/meminfo"))
        self.assertEqual((result.returncode, result.stdout.strip()), (0, "3"), result.stderr)

    def test_nnb_jobs_decides(self):
        self.assertEqual(self.answer(64, 200 << 10, NNB_JOBS="12"), 12)

    def test_a_bad_nnb_jobs_is_refused_in_one_line(self):
        for bad in ["0", "-3", "two", "2.5", " 4"]:
            with self.subTest(bad=bad):
                result = self.jobs(2, 24 << 20, call='jobs=$(build_jobs); echo "ran with ${jobs}"', NNB_JOBS=bad)
                self.assertEqual(result.returncode, 2)
                self.assertEqual(result.stdout, "")
                self.assertEqual(len(result.stderr.strip().splitlines()), 1, result.stderr)
                self.assertIn("NNB_JOBS", result.stderr)


if __name__ == "__main__":
    JOBS_SH = os.path.abspath(sys.argv.pop(1))
    unittest.main()
