#!/usr/bin/env python3
"""scripts/fetch_data.sh on fake files: test_fetch_data.py FETCH_DATA_SH WORKDIR.

A temporary manifest (NNB_MANIFEST) lists small files kept in a local mirror (NNB_DATA_MIRROR), one file given
inline as text, so no real scan and no network is needed. Fetches into an empty folder, reruns without fetching,
repairs a damaged file, and fails with one line and no file left behind on a bad checksum, a missing mirror
file, a failed download and a bad manifest; an interrupted run leaves no temp file either. Then the project's
manifest: sizes and URLs of every file, and a fetch of all of them when the real scans are at hand.
"""
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

SCRIPT, WORK = sys.argv[1], Path(sys.argv[2])


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)


def sha(data):
    return hashlib.sha256(data).hexdigest()


def run(target, mirror=None, manifest=None, expect=0):
    env = {k: v for k, v in os.environ.items() if k not in ("NNB_DATA_MIRROR", "NNB_DATA_DIR", "NNB_MANIFEST")}
    env.update(NNB_DATA_DIR=str(target), NNB_MANIFEST=str(manifest or WORK / "manifest.json"))
    if mirror is not None:
        env["NNB_DATA_MIRROR"] = str(mirror)
    proc = subprocess.run([SCRIPT], capture_output=True, text=True, timeout=60, env=env)
    if expect == 0:
        check(proc.returncode == 0, f"exit {proc.returncode}: {proc.stderr}")
    else:
        check(proc.returncode != 0, f"exit 0, expected a failure: {proc.stdout}")
        lines = proc.stderr.splitlines()
        check(len(lines) == 1 and lines[0].startswith("fetch_data: error: "), f"not one error line: {proc.stderr!r}")
        for word in expect:
            check(word in lines[0], f"'{word}' not in the error line: {lines[0]}")
    return proc


def files_under(folder):
    return sorted(str(p.relative_to(folder)) for p in Path(folder).rglob("*") if p.is_file())


def no_temp_files(folder, label):
    leftovers = [f for f in files_under(folder) if Path(f).name.startswith(".")]
    check(not leftovers, f"{label}: temp files left: {leftovers}")


if WORK.exists():
    shutil.rmtree(WORK)
mirror = WORK / "mirror"
contents = {("pair-a", "model.bin"): bytes(range(256)) * 40, ("pair-a", "query.xyz"): b"1 2 3\n4 5 6\n",
            ("pair-a", "extra.txt"): b"an extra file\n", ("pair-b", "model.pcd"): os.urandom(5000),
            ("pair-b", "query.pcd"): os.urandom(3000)}
for (folder, name), data in contents.items():
    (mirror / folder).mkdir(parents=True, exist_ok=True)
    (mirror / folder / name).write_bytes(data)
pose_text = "1 0 0 0.5\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
contents[("pair-b", "pose.txt")] = pose_text.encode()


def entry(folder, name, **extra):
    data = contents[(folder, name)]
    out = {"file": name, "format": "x", "sha256": sha(data), "bytes": len(data),
           "url": f"https://example.invalid/{folder}/{name}"}
    out.update(extra)
    return out


def write_manifest(path, doc):
    path.write_text(json.dumps(doc, indent=1))
    return path


doc = {"pairs": [
    {"name": "a", "folder": "pair-a", "model": entry("pair-a", "model.bin", points=1),
     "query": entry("pair-a", "query.xyz", points=2), "scale_to_m": 1.0, "reference_pose": None,
     "other_files": [entry("pair-a", "extra.txt")]},
    {"name": "b", "folder": "pair-b", "model": entry("pair-b", "model.pcd", points=1),
     "query": entry("pair-b", "query.pcd", points=1), "scale_to_m": 1.0,
     "reference_pose": entry("pair-b", "pose.txt", url=None, text=pose_text)}]}
write_manifest(WORK / "manifest.json", doc)
n = len(contents)

# Into an empty folder: every file, byte for byte; then again: nothing fetched.
target = WORK / "data"
proc = run(target, mirror)
check(f"0 verified, {n} fetched" in proc.stdout, f"first run: {proc.stdout}")
for (folder, name), data in contents.items():
    check((target / folder / name).read_bytes() == data, f"{folder}/{name} differs")
check(len(files_under(target)) == n, f"unexpected files: {files_under(target)}")
proc = run(target, mirror)
check(f"{n} verified, 0 fetched" in proc.stdout, f"second run: {proc.stdout}")
# A damaged local file is fetched again, the rest kept.
(target / "pair-a" / "query.xyz").write_bytes(b"damaged\n")
proc = run(target, mirror)
check(f"{n - 1} verified, 1 fetched" in proc.stdout, f"repair run: {proc.stdout}")
check((target / "pair-a" / "query.xyz").read_bytes() == contents[("pair-a", "query.xyz")], "not repaired")

# A corrupted mirror file: one line naming it, no file and no temp file left for it.
bad_mirror = WORK / "bad_mirror"
shutil.copytree(mirror, bad_mirror)
(bad_mirror / "pair-b" / "model.pcd").write_bytes(b"corrupt")
bad_target = WORK / "bad_data"
run(bad_target, bad_mirror, expect=["checksum mismatch", "pair-b/model.pcd", sha(b"corrupt")])
check(not (bad_target / "pair-b" / "model.pcd").exists(), "the corrupted file was left in the target")
no_temp_files(bad_target, "corrupted mirror")

# A missing mirror file.
missing_mirror = WORK / "missing_mirror"
shutil.copytree(mirror, missing_mirror)
(missing_mirror / "pair-a" / "extra.txt").unlink()
missing_target = WORK / "missing_data"
run(missing_target, missing_mirror, expect=["missing mirror file", "pair-a/extra.txt"])
check(not (missing_target / "pair-a" / "extra.txt").exists(), "a file appeared for a missing mirror file")
no_temp_files(missing_target, "missing mirror file")
run(WORK / "no_mirror_data", WORK / "no_such_mirror", expect=["no_such_mirror"])

# Downloads, through file:// URLs (curl reads them; no network here): one that works, one that fails.
if shutil.which("curl"):
    local = json.loads(json.dumps(doc))
    local["pairs"] = local["pairs"][:1]
    for e in (local["pairs"][0]["model"], local["pairs"][0]["query"], local["pairs"][0]["other_files"][0]):
        e["url"] = (mirror / "pair-a" / e["file"]).as_uri()
    download_target = WORK / "download_data"
    proc = run(download_target, manifest=write_manifest(WORK / "local.json", local))
    check("0 verified, 3 fetched" in proc.stdout, f"download run: {proc.stdout}")
    local["pairs"][0]["query"]["url"] = (WORK / "nowhere" / "query.xyz").as_uri()
    shutil.rmtree(download_target)
    run(download_target, manifest=write_manifest(WORK / "broken.json", local), expect=["download failed", "nowhere"])
    check(not (download_target / "pair-a" / "query.xyz").exists(), "a failed download left a file")
    no_temp_files(download_target, "failed download")

# A manifest that is not JSON.
(WORK / "bad.json").write_text("{ not json")
run(WORK / "x", mirror, manifest=WORK / "bad.json", expect=["cannot read the manifest", "bad.json"])

# Interrupted while copying (a cp that copies, then hangs): the trap removes the temp file.
shim = WORK / "slow_bin"
shim.mkdir()
(shim / "cp").write_text(f"#!/bin/sh\n{shutil.which('cp')} \"$@\"\nexec sleep 60\n")
(shim / "cp").chmod(0o755)
slow_target = WORK / "slow_data"
env = dict(os.environ, NNB_DATA_DIR=str(slow_target), NNB_MANIFEST=str(WORK / "manifest.json"),
           NNB_DATA_MIRROR=str(mirror), PATH=f"{shim}:{os.environ.get('PATH', '/usr/bin:/bin')}")
proc = subprocess.Popen([SCRIPT], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
deadline = time.time() + 30
while time.time() < deadline and not any(Path(f).name.startswith(".") for f in files_under(slow_target)):
    time.sleep(0.05)
check(time.time() < deadline, "the interrupted run never started copying")
os.killpg(proc.pid, signal.SIGTERM)
# bash runs its trap once the foreground command ends; the shim's sleep normally dies with the group's
# signal at once, and ends by itself within 60 s on a machine too loaded to deliver it promptly.
check(proc.wait(timeout=90) != 0, "an interrupted run exited 0")
check(files_under(slow_target) == [], f"an interrupted run left files: {files_under(slow_target)}")

# The project's manifest: every file has its size and either a pinned raw GitHub URL or its bytes inline.
sys.path.insert(0, str(Path(__file__).resolve().parent))
import real_data  # noqa: E402

project_manifest = real_data.SOURCE / "datasets" / "manifest.json"
for pair in json.loads(project_manifest.read_text())["pairs"]:
    entries = [pair["model"], pair["query"]] + [pair[k] for k in ("reference_pose", "initial_pose", "estimate_pose")
                                                if pair.get(k)] + pair.get("other_files", [])
    for e in entries:
        label = f"{pair['folder']}/{e['file']}"
        check(isinstance(e.get("bytes"), int) and e["bytes"] > 0, f"{label}: no size")
        if e.get("url") is None:
            text = e.get("text", "").encode()
            check(len(text) == e["bytes"] and sha(text) == e["sha256"], f"{label}: inline text does not match")
        else:
            parts = e["url"].split("/")
            check(e["url"].startswith("https://raw.githubusercontent.com/") and len(parts[5]) == 40,
                  f"{label}: not a raw GitHub URL pinned to a commit: {e['url']}")
# With the real scans at hand, the script fetches all of them from there (CI: always).
if real_data.present():
    real_target = WORK / "real_data"
    proc = run(real_target, real_data.data_dir(), manifest=project_manifest)
    check(" 0 verified, " in proc.stdout, f"real scans: {proc.stdout}")
    proc = run(real_target, real_data.data_dir(), manifest=project_manifest)
    check(" 0 fetched" in proc.stdout, f"real scans, second run: {proc.stdout}")
    shutil.rmtree(real_target)

print("fetch_data: ok")
