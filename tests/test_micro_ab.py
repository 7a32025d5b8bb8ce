#!/usr/bin/env python3
"""scripts/micro_ab.sh: one micro_nns as both A and B on two cheap benchmarks gives one row each, with both
times and their ratio, and the header names the binaries and the load; with --noise each row also has A's second
run and A2/A; bad arguments exit 2 with one line. The first A/B runs under a locale whose decimal point is a comma
(German, compiled into a scratch folder: no root needed), as a user's may be.

Usage: test_micro_ab.py MICRO_AB_SH MICRO_NNS. Never a timing: the ratio is only checked to be a number."""
import os
import re
import subprocess
import sys
import tempfile

FILTER = "^(Build/fig3/ours_kdtree|Ranged1NN/fig3/ours_kdtree/0.10)$"


def comma_locale(folder):
    """The environment of a German locale compiled into FOLDER, after checking that its decimal point is a comma
    there (Debian's awk, mawk, then reads "2.5" as 2; gawk reads it as 2.5 in any locale)."""
    subprocess.run(["localedef", "-i", "de_DE", "-f", "UTF-8", os.path.join(folder, "de_DE.UTF-8")], check=True,
                   capture_output=True)
    env = dict(os.environ, LOCPATH=folder, LC_ALL="de_DE.UTF-8")
    # glibc's setlocale keeps its copy of LOCPATH for good, which LeakSanitizer reports in a sanitizer build.
    suppressions = os.path.join(folder, "lsan_suppressions.txt")
    with open(suppressions, "w") as f:
        f.write("leak:__argz_add_sep\n")
    env["LSAN_OPTIONS"] = ":".join(filter(None, [os.environ.get("LSAN_OPTIONS"), f"suppressions={suppressions}"]))
    point = subprocess.run([sys.executable, "-c", 'import locale; locale.setlocale(locale.LC_ALL, "");'
                            'print(locale.localeconv()["decimal_point"])'], capture_output=True, text=True, env=env)
    if point.stdout.strip() != ",":
        raise RuntimeError(f"the comma locale is not in force: decimal point {point.stdout.strip()!r} {point.stderr}")
    return env


def main(script, micro_nns):
    failures = []
    with tempfile.TemporaryDirectory() as folder:
        proc = subprocess.run([script, micro_nns, micro_nns, "1", FILTER], capture_output=True, text=True,
                              timeout=280, env=comma_locale(folder))
    out = proc.stdout
    if proc.returncode != 0:
        failures.append(f"exit {proc.returncode}: {proc.stderr[-500:]}")
    for line in ("# A: ", "# B: ", "# load before: ", "# load after: "):
        if not re.search(rf"^{re.escape(line)}\S", out, re.M):
            failures.append(f"no header line '{line}...'")
    rows = re.findall(r"^(\S+) +([0-9.]+) +([0-9.]+) +([0-9.]+)$", out, re.M)
    names = sorted(r[0] for r in rows)
    if names != ["Build/fig3/ours_kdtree", "Ranged1NN/fig3/ours_kdtree/0.10"]:
        failures.append(f"rows {names}, expected one per benchmark run:\n{out}")
    for name, a, b, ratio in rows:
        if not (float(a) > 0 and float(b) > 0 and abs(float(ratio) - float(b) / float(a)) < 0.002):
            failures.append(f"{name}: A {a}, B {b}, B/A {ratio} do not add up")
    proc = subprocess.run([script, "--noise", micro_nns, micro_nns, "1", FILTER], capture_output=True, text=True,
                          timeout=280)
    if proc.returncode != 0 or "command: " + script + " --noise " not in proc.stdout:
        failures.append(f"--noise: exit {proc.returncode}, or the command line lacks it:\n{proc.stdout}{proc.stderr[-500:]}")
    rows = re.findall(r"^(\S+) +([0-9.]+) +([0-9.]+) +([0-9.]+) +([0-9.]+) +([0-9.]+)$", proc.stdout, re.M)
    if sorted(r[0] for r in rows) != ["Build/fig3/ours_kdtree", "Ranged1NN/fig3/ours_kdtree/0.10"]:
        failures.append(f"--noise: rows {rows}, expected one of six columns per benchmark:\n{proc.stdout}")
    for name, a, b, ratio, a2, noise in rows:
        if not (float(a2) > 0 and abs(float(noise) - float(a2) / float(a)) < 0.002):
            failures.append(f"--noise {name}: A {a}, A2 {a2}, A2/A {noise} do not add up")
    for bad in ([micro_nns], ["--noise", micro_nns], [micro_nns, micro_nns, "0", FILTER], [micro_nns, "/no/such/binary", "1", FILTER],
                [micro_nns, micro_nns, "two", FILTER]):
        p = subprocess.run([script] + bad, capture_output=True, text=True, timeout=60)
        if p.returncode != 2 or len(p.stderr.strip().splitlines()) != 1 or "micro_ab: error:" not in p.stderr:
            failures.append(f"{bad[1:]}: exit {p.returncode}, stderr {p.stderr!r} (want exit 2 and one line)")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
