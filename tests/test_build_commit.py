#!/usr/bin/env python3
"""cmake/write_build_commit.cmake, the stamp of the commit a binary is built from: in a scratch git repository
it writes the HEAD's hash, adds "+dirty" when a tracked file differs, follows a new commit, leaves the header
untouched when nothing changed (so a build without changes rebuilds nothing) and writes "" outside a checkout.
Then the binary given reports, as its --version, the stamp its build wrote.

Usage: test_build_commit.py WRITE_BUILD_COMMIT_CMAKE BINARY STAMP_HEADER"""
import os
import re
import subprocess
import sys
import tempfile


def stamp(script, source, out):
    subprocess.run(["cmake", f"-DSOURCE_DIR={source}", f"-DOUT={out}", "-P", script], check=True,
                   capture_output=True, text=True)
    with open(out) as f:
        found = re.search(r'#define NNB_BUILD_GIT_COMMIT "([^"]*)"', f.read())
    return found.group(1) if found else None


def git(repo, *args):
    return subprocess.run(["git", "-C", repo, "-c", "user.name=t", "-c", "user.email=t@t", *args], check=True,
                          capture_output=True, text=True).stdout.strip()


def main(script, binary, header):
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        repo, out = os.path.join(tmp, "repo"), os.path.join(tmp, "stamp.hpp")
        os.mkdir(repo)
        git(repo, "init", "-q")
        with open(os.path.join(repo, "a.txt"), "w") as f:
            f.write("one\n")
        git(repo, "add", "a.txt")
        git(repo, "commit", "-qm", "one")
        first = git(repo, "rev-parse", "HEAD")
        if stamp(script, repo, out) != first:
            failures.append(f"clean tree: {stamp(script, repo, out)!r}, expected {first!r}")
        before = os.stat(out).st_mtime_ns
        os.utime(out, ns=(before - 10**9, before - 10**9))
        stamp(script, repo, out)
        if os.stat(out).st_mtime_ns != before - 10**9:
            failures.append("the header was rewritten although the commit had not changed")
        with open(os.path.join(repo, "a.txt"), "w") as f:
            f.write("two\n")
        if stamp(script, repo, out) != first + "+dirty":
            failures.append(f"modified tree: {stamp(script, repo, out)!r}, expected {first + '+dirty'!r}")
        git(repo, "commit", "-qam", "two")
        second = git(repo, "rev-parse", "HEAD")
        if second == first or stamp(script, repo, out) != second:
            failures.append(f"new commit: {stamp(script, repo, out)!r}, expected {second!r}")
        outside = os.path.join(tmp, "not_a_repo")
        os.mkdir(outside)
        if stamp(script, outside, out) != "":
            failures.append(f"outside a checkout: {stamp(script, outside, out)!r}, expected ''")
    with open(header) as f:
        built = re.search(r'#define NNB_BUILD_GIT_COMMIT "([^"]*)"', f.read()).group(1)
    version = subprocess.run([binary, "--version"], capture_output=True, text=True).stdout
    if f"(git {built}," not in version and not (built == "" and "(git unknown," in version):
        failures.append(f"{binary} --version says {version.strip()!r}; its build stamped {built!r}")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:4]))
