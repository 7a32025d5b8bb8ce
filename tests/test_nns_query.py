"""nns_query end to end: the CSV and stats it writes, and one clear line with exit code 2 on bad input.

Run as: python3 test_nns_query.py NNS_QUERY_BINARY [unittest args]
"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import real_data

BINARY = None


def run(*args, env=None):
    proc = subprocess.run([BINARY, *args], capture_output=True, text=True, timeout=300, env=env)
    if "At Most 1 required but received" in proc.stderr:  # refused for the repeat, not for what it tests
        raise AssertionError(f"a flag given twice: {' '.join(args)}")
    return proc


class Answers(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="nns_query_test_")

    def tearDown(self):
        shutil.rmtree(self.dir)

    def test_list_names_brute_force(self):
        result = run("--list")
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertIn("brute_force", result.stdout)

    def test_list_json_declares_every_adapter(self):
        names = [line.split("\t")[0] for line in run("--list").stdout.splitlines()]
        result = run("--list", "--json")
        self.assertEqual(result.returncode, 0, result.stderr)
        adapters = json.loads(result.stdout)
        self.assertEqual(sorted(adapters), sorted(names))
        for name, info in adapters.items():
            for field in ("library", "version", "structure", "scalar", "exact", "knn", "radius", "ranged",
                          "ranged_strategies", "concurrency", "params"):
                self.assertIn(field, info, name)
            self.assertEqual(info["ranged_strategies"][0], info["ranged"], name)
            self.assertIn(info["concurrency"], ("single", "queries", "library"), name)

    def test_threads_give_the_same_csv_and_the_stats_say_how_many_ran(self):
        outputs = {}
        for adapter, threads, used in (("ours_kdtree", "1", 1), ("ours_kdtree", "3", 3), ("ann_kdtree", "3", 1)):
            if adapter not in run("--list").stdout:
                continue
            out, stats = os.path.join(self.dir, adapter + threads + ".csv"), os.path.join(self.dir, "s.json")
            result = run("--adapter", adapter, "--model", "hollow_sphere", "--query", "hollow_cube", "--points", "3000",
                         "--max-dist", "0.2", "--threads", threads, "--out", out, "--stats", stats)
            self.assertEqual(result.returncode, 0, result.stderr)
            with open(stats) as f:
                self.assertEqual(json.load(f)["threads"], used, adapter + " asked for " + threads)
            with open(out) as f:
                outputs[(adapter, threads)] = f.read()
        if ("ours_kdtree", "3") in outputs:
            self.assertEqual(outputs[("ours_kdtree", "1")], outputs[("ours_kdtree", "3")])

    def test_json_without_list_is_refused(self):
        result = run("--json")
        self.assertEqual(result.returncode, 2)

    def test_csv_is_sorted_and_within_the_limit_and_stats_agree(self):
        out, stats = os.path.join(self.dir, "n.csv"), os.path.join(self.dir, "s.json")
        result = run("--adapter", "brute_force", "--model", "hollow_sphere", "--query", "hollow_cube",
                     "--points", "500", "--search", "ranged", "--k", "3", "--max-dist", "0.4",
                     "--repeat", "3", "--out", out, "--stats", stats)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(out) as f:
            rows = list(csv.reader(f))
        self.assertEqual(rows[0], ["query", "neighbor", "distance"])
        keys = [(int(q), float(d)) for q, _, d in rows[1:]]
        self.assertEqual(keys, sorted(keys))
        self.assertTrue(all(0.0 <= d <= 0.4 for _, d in keys))
        per_query = {}
        for q, _ in keys:
            per_query[q] = per_query.get(q, 0) + 1
        self.assertTrue(all(1 <= n <= 3 for n in per_query.values()))
        with open(stats) as f:
            s = json.load(f)
        for field in ("adapter", "library_version", "build_seconds", "query_seconds", "found", "index_bytes"):
            self.assertIn(field, s)
        self.assertEqual(s["found"], len(per_query))
        self.assertEqual(s["adapter"], "brute_force")

    def test_check_counts_the_queries_with_brute_forces_distances(self):
        listed = run("--list").stdout.splitlines()
        exact = [line.split("\t")[0] for line in listed if "APPROXIMATE" not in line]
        approximate = [line.split("\t")[0] for line in listed if "APPROXIMATE" in line]
        cases = [(name, ["--search", "ranged", "--k", "3", "--max-dist", "0.3"], True) for name in exact[:2]]
        cases += [(name, ["--search", "knn", "--k", "1"], False) for name in approximate]
        for name, search, all_agree in cases:
            stats = os.path.join(self.dir, name + ".json")
            result = run("--adapter", name, "--model", "hollow_sphere", "--query", "hollow_cube", "--points", "500",
                         *search, "--check", "--out", os.path.join(self.dir, "n.csv"), "--stats", stats)
            self.assertEqual(result.returncode, 0, name + ": " + result.stderr)
            with open(stats) as f:
                agreeing = json.load(f)["agreeing_with_brute_force"]
            self.assertIn(f"check: {agreeing} of 500 queries", result.stderr)
            self.assertTrue(agreeing == 500 if all_agree else 0 <= agreeing <= 500, f"{name}: {agreeing}")

    def test_every_adapter_gives_the_same_csv_distances(self):
        names = [line.split("\t")[0] for line in run("--list").stdout.splitlines()
                 if "APPROXIMATE" not in line]
        answers = {}
        for name in names:
            out = os.path.join(self.dir, name + ".csv")
            result = run("--adapter", name, "--model", "filled_cube", "--query", "hollow_sphere", "--points",
                         "400", "--search", "ranged", "--max-dist", "0.15", "--out", out)
            self.assertEqual(result.returncode, 0, name + ": " + result.stderr)
            with open(out) as f:
                answers[name] = [(r[0], round(float(r[2]), 9)) for r in list(csv.reader(f))[1:]]
        for name, answer in answers.items():
            self.assertEqual(answer, answers["brute_force"], name)


    def test_every_ranged_strategy_gives_the_same_csv(self):
        common = ["--model", "filled_cube", "--query", "hollow_sphere", "--points", "400", "--search", "ranged",
                  "--k", "2", "--max-dist", "0.15"]
        answers = {}
        for adapter, strategy in (("flann_kdtree", ""), ("flann_kdtree", "via_knn"), ("flann_kdtree", "via_radius"),
                                  ("ann_kdtree", "native_unpruned"), ("brute_force", "native")):
            out, stats = os.path.join(self.dir, "s.csv"), os.path.join(self.dir, "s.json")
            extra = ["--strategy", strategy] if strategy else []
            result = run("--adapter", adapter, *common, *extra, "--out", out, "--stats", stats)
            if result.returncode != 0 and "unknown adapter" in result.stderr:
                continue  # built without that library
            self.assertEqual(result.returncode, 0, result.stderr)
            with open(stats) as f:
                self.assertEqual(json.load(f)["strategy"], strategy or "native", f"{adapter} {strategy}")
            with open(out) as f:
                answers[(adapter, strategy)] = f.read()
        reference = answers[("brute_force", "native")]
        for key, answer in answers.items():
            self.assertEqual(answer, reference, key)

    def test_describe_real_pairs_counts_every_scan_as_the_manifest_does(self):
        real_data.skip_unless_present(self)
        out = os.path.join(self.dir, "pairs.json")
        result = run("--describe-real-pairs", out)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(out) as f:
            doc = json.load(f)
        with open(os.path.join(real_data.SOURCE, "datasets", "manifest.json")) as f:
            manifest = {p["name"]: p for p in json.load(f)["pairs"]}
        scans = doc["context"]["datasets"]
        self.assertEqual(len(scans), 2 * len(manifest))
        for s in scans:
            listed = manifest[s["spec"]][s["role"]]
            self.assertEqual((s["file"], s["n_read"]), (listed["file"], listed["points"]))
            self.assertEqual(s["points"] + s["n_non_finite"] + s["n_zero"], s["n_read"])
            self.assertEqual(s["n_dropped"], s["n_non_finite"] + s["n_zero"])
        self.assertIn("--describe-real-pairs", doc["context"]["command_line"])
        self.assertEqual(doc["benchmarks"], [])

    def test_a_strategy_the_adapter_lacks_is_refused_with_one_line(self):
        for adapter, args, words in (("vtk_kdtree", ["--strategy", "native"], "offers"),
                                     ("brute_force", ["--strategy", "sideways"], "unknown strategy"),
                                     ("brute_force", ["--search", "knn", "--strategy", "via_knn"], "ranged")):
            result = run("--adapter", adapter, "--model", "hollow_sphere", "--query", "hollow_cube", "--points", "100",
                         *args)
            if "unknown adapter" in result.stderr:
                continue  # built without that library
            lines = [l for l in result.stderr.splitlines() if l.strip() and "WARNING" not in l]
            self.assertEqual(result.returncode, 2, result.stderr)
            self.assertEqual(len(lines), 1, lines)
            self.assertIn(words, lines[0])


class BadInput(unittest.TestCase):
    """Each: exit code 2, one line on stderr naming the problem, no output file left behind."""

    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="nns_query_bad_")
        self.out = os.path.join(self.dir, "out.csv")

    def tearDown(self):
        shutil.rmtree(self.dir)

    def expect_refused(self, args, words, env=None):
        result = run(*args, "--out", self.out, env=env)
        self.assertEqual(result.returncode, 2, result.stderr)
        lines = [l for l in result.stderr.splitlines() if l.strip()]
        errors = [l for l in lines if "error" in l.lower()]
        self.assertEqual(len(errors), 1, result.stderr)
        for word in words:
            self.assertIn(word, errors[0])
        self.assertFalse(os.path.exists(self.out))
        self.assertEqual([f for f in os.listdir(self.dir) if f != "bad.xyz" and f != "bad.bin"], [])

    def test_huge_k_is_answered_within_the_model_size(self):
        out = os.path.join(self.dir, "k.csv")
        result = run("--adapter", "brute_force", "--model", "hollow_sphere", "--query", "hollow_cube", "--points", "50",
                     "--search", "knn", "--k", "2147483647", "--out", out)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(out) as f:
            self.assertEqual(len(f.readlines()), 1 + 50 * 50)

    def test_answers_beyond_the_neighbour_budget_are_refused_before_any_output(self):
        out = os.path.join(self.dir, "n.csv")
        for search in (["--search", "radius", "--max-dist", "10"], ["--search", "knn", "--k", "1000"],
                       ["--search", "ranged", "--strategy", "via_radius", "--max-dist", "10"]):
            result = run("--adapter", "brute_force", "--model", "filled_cube", "--query", "filled_cube",
                         "--points", "3000", "--max-neighbours", "100000", *search, "--out", out)
            self.assertEqual(result.returncode, 2, result.stderr)
            self.assertIn("--max-neighbours", result.stderr)
            self.assertFalse(os.path.exists(out))

    def test_output_is_never_an_input(self):
        cloud = os.path.join(self.dir, "cloud.xyz")
        with open(cloud, "w") as f:
            f.writelines(f"{i * 0.01} {i * 0.02} 0\n" for i in range(20))
        with open(cloud) as f:
            before = f.read()
        for option in ("--out", "--stats"):
            result = run("--model", cloud, "--query", "hollow_cube", "--points", "20", option, cloud)
            self.assertEqual(result.returncode, 2, result.stderr)
            with open(cloud) as f:
                self.assertEqual(f.read(), before)

    def test_outputs_are_never_one_file(self):
        out = os.path.join(self.dir, "answer.csv")
        result = run("--model", "hollow_cube", "--query", "hollow_cube", "--points", "20", "--out", out,
                     "--stats", os.path.join(self.dir, ".", "answer.csv"))
        self.assertEqual(result.returncode, 2, result.stderr)
        self.assertIn("same file", result.stderr)
        self.assertFalse(os.path.exists(out))

    def test_command_line_errors_are_one_line_and_exit_2(self):
        for bad in (["--k", "abc"], ["--no-such-option"], ["--threads", "0"], ["--threads", "100000"],
                    ["--data-dir", os.path.join(self.dir, "absent"), "--model", "hollow_cube", "--query", "hollow_cube"],
                    ["--describe-real-pairs", os.path.join(self.dir, "pairs.json"), "--model", "hollow_cube"],
                    ["--model", "hollow_cube", "--query", "hollow_cube", "--points", "10", "--repeat", "2000000000"]):
            result = run(*bad)
            self.assertEqual(result.returncode, 2)
            self.assertEqual(len(result.stderr.strip().splitlines()), 1, result.stderr)

    def test_version(self):
        result = run("--version")
        self.assertEqual(result.returncode, 0)
        self.assertRegex(result.stdout, r"^nns_query \d+\.\d+ \(git ")

    def test_missing_file(self):
        self.expect_refused(["--model", "/nonexistent/cloud.pcd", "--query", "hollow_cube"], ["cloud.pcd"])

    def test_unknown_adapter(self):
        self.expect_refused(["--adapter", "no_such", "--model", "hollow_cube", "--query", "hollow_cube"],
                            ["no_such"])

    def test_unknown_data_set(self):
        self.expect_refused(["--model", "hollow_torus", "--query", "hollow_cube"], ["hollow_torus"])

    def test_negative_distance(self):
        self.expect_refused(["--model", "hollow_cube", "--query", "hollow_cube", "--points", "100",
                             "--max-dist", "-0.5"], ["max_dist"])

    def test_k_zero(self):
        self.expect_refused(["--model", "hollow_cube", "--query", "hollow_cube", "--points", "100", "--k", "0"],
                            ["k"])

    def test_unknown_search_kind(self):
        self.expect_refused(["--model", "hollow_cube", "--query", "hollow_cube", "--search", "nearest"],
                            ["nearest"])

    def test_bad_adapter_parameter(self):
        self.expect_refused(["--model", "hollow_cube", "--query", "hollow_cube", "--param", "nonsense=3"],
                            ["nonsense"])

    def test_malformed_and_truncated_files(self):
        bad_xyz = os.path.join(self.dir, "bad.xyz")
        with open(bad_xyz, "w") as f:
            f.write("0 0 1\n1 2 x\n")
        self.expect_refused(["--model", bad_xyz, "--query", "hollow_cube"], ["bad.xyz"])
        bad_bin = os.path.join(self.dir, "bad.bin")
        with open(bad_bin, "wb") as f:
            f.write(b"\0" * 13)
        self.expect_refused(["--model", bad_bin, "--query", "hollow_cube"], ["bad.bin"])

    def test_empty_cloud_after_dropping_invalid_points(self):
        nan_xyz = os.path.join(self.dir, "bad.xyz")
        with open(nan_xyz, "w") as f:
            f.write("nan 0 0\n0 inf 0\n0 0 0\n")
        self.expect_refused(["--model", nan_xyz, "--query", "hollow_cube"], ["bad.xyz"])

    def test_checksum_mismatch(self):
        real_data.skip_unless_present(self)
        real = str(real_data.data_dir())
        copy = os.path.join(self.dir, "data")
        pair = os.path.join(copy, "bunny-stanford")
        shutil.copytree(os.path.join(real, "bunny-stanford"), pair)
        os.chmod(pair, 0o755)  # the data may be read-only, and only root could then empty the copy
        target = os.path.join(pair, "bun000.ply")
        os.chmod(target, 0o644)
        with open(target, "r+b") as f:
            f.seek(-3, os.SEEK_END)
            f.write(b"9")
        env = dict(os.environ, NNB_DATA_DIR=copy)
        result = run("--model", "bunny-stanford", "--query", "hollow_cube", "--out", self.out, env=env)
        self.assertEqual(result.returncode, 2, result.stderr)
        self.assertIn("sha256", result.stderr.lower())
        self.assertFalse(os.path.exists(self.out))


if __name__ == "__main__":
    BINARY = os.path.abspath(sys.argv.pop(1))
    sys.exit(real_data.exit_code(unittest.main(exit=False).result))
