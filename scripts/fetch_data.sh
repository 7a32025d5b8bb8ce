#!/usr/bin/env bash
# Fetches the real scan pairs listed in datasets/manifest.json into the data folder, one folder per pair,
# and checks every file against its sha256. Safe to rerun: files already there and intact are kept.
#
#   NNB_DATA_DIR=DIR     where to put them (default: data/real in this clone, where the programs look)
#   NNB_DATA_MIRROR=DIR  copy from a local folder of the same layout instead of downloading
#   NNB_MANIFEST=FILE    another manifest (default: datasets/manifest.json)
#
# Needs bash, python3 (to read the JSON), sha256sum, and curl or wget unless a mirror is given.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
manifest="${NNB_MANIFEST:-${root}/datasets/manifest.json}"
dest="${NNB_DATA_DIR:-${root}/data/real}"
mirror="${NNB_DATA_MIRROR:-}"

if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then
  sed -n '2,8s/^# \{0,1\}//p' "$0"
  exit 0
elif [[ $# -gt 0 ]]; then
  echo "fetch_data: error: no arguments taken ('$1'); settings are environment variables, see --help" >&2
  exit 2
fi

tmp=""
# A temp file is only ever renamed into place after its checksum passed; every other exit removes it.
trap 'if [[ -n "${tmp}" ]]; then rm -f "${tmp}"; fi' EXIT
trap 'exit 130' INT TERM

die() {
  echo "fetch_data: error: $*" >&2
  exit 1
}

[[ -f "${manifest}" ]] || die "no manifest at ${manifest}"
if [[ -n "${mirror}" ]]; then
  [[ -d "${mirror}" ]] || die "NNB_DATA_MIRROR=${mirror} is not a folder"
  mirror="$(cd "${mirror}" && pwd)"
  downloader=""
elif command -v curl >/dev/null 2>&1; then
  downloader=curl
elif command -v wget >/dev/null 2>&1; then
  downloader=wget
else
  die "neither curl nor wget is installed (or set NNB_DATA_MIRROR to a local copy)"
fi

# One line per file: folder, file, sha256, url ("-" when the manifest carries the bytes as text).
listing="$(python3 - "${manifest}" <<'EOF'
import json, sys
try:
    doc = json.load(open(sys.argv[1]))
    for pair in doc["pairs"]:
        entries = [pair["model"], pair["query"]]
        entries += [pair[k] for k in ("reference_pose", "initial_pose", "estimate_pose") if pair.get(k)]
        entries += pair.get("other_files", [])
        for e in entries:
            url = e.get("url")
            if not url and "text" not in e:
                raise KeyError(f"{pair['folder']}/{e['file']} has neither url nor text")
            print("\t".join([pair["folder"], e["file"], e["sha256"], url or "-"]))
except (OSError, ValueError, KeyError, TypeError) as err:
    print(f"fetch_data: error: cannot read the manifest {sys.argv[1]}: {err}", file=sys.stderr)
    sys.exit(1)
EOF
)" || exit 1

file_mode="$(printf '%o' $((0666 & ~$(umask))))"
verified=0
fetched=0
while IFS=$'\t' read -r folder file sha url; do
  target="${dest}/${folder}/${file}"
  if [[ -f "${target}" ]]; then
    if [[ "$(sha256sum "${target}" | cut -d' ' -f1)" == "${sha}" ]]; then
      verified=$((verified + 1))
      continue
    fi
    echo "fetch_data: ${folder}/${file} is there but its sha256 differs; fetching it again" >&2
  fi
  mkdir -p "${dest}/${folder}" || die "cannot create ${dest}/${folder}"
  # Named before it is made, so that a signal at any point leaves the trap its name.
  tmp="${dest}/${folder}/.${file}.$$.${RANDOM}"
  (set -o noclobber; : > "${tmp}") 2>/dev/null || die "cannot write in ${dest}/${folder}"
  if [[ "${url}" == "-" ]]; then
    from="the manifest"
    python3 -c 'import json, sys
pair = next(p for p in json.load(open(sys.argv[1]))["pairs"] if p["folder"] == sys.argv[2])
entries = [pair[k] for k in ("model", "query", "reference_pose", "initial_pose", "estimate_pose") if pair.get(k)]
entry = next(e for e in entries + pair.get("other_files", []) if e["file"] == sys.argv[3])
sys.stdout.buffer.write(entry["text"].encode("utf-8"))' "${manifest}" "${folder}" "${file}" >"${tmp}" ||
      die "cannot write ${folder}/${file} from the manifest"
  elif [[ -n "${mirror}" ]]; then
    from="${mirror}/${folder}/${file}"
    [[ -f "${from}" ]] || die "missing mirror file ${from}"
    cp "${from}" "${tmp}" || die "cannot copy ${from}"
  else
    from="${url}"
    if [[ "${downloader}" == curl ]]; then
      err="$(curl -fsSL --retry 2 --connect-timeout 30 -o "${tmp}" "${url}" 2>&1)" || die "download failed: ${url}: ${err##*$'\n'}"
    else
      err="$(wget -q -O "${tmp}" "${url}" 2>&1)" || die "download failed: ${url}${err:+: ${err##*$'\n'}}"
    fi
  fi
  actual="$(sha256sum "${tmp}" | cut -d' ' -f1)"
  [[ "${actual}" == "${sha}" ]] ||
    die "checksum mismatch for ${folder}/${file} from ${from}: expected sha256 ${sha}, got ${actual}"
  chmod "${file_mode}" "${tmp}"
  mv -f "${tmp}" "${target}" || die "cannot move ${folder}/${file} into place"
  tmp=""
  fetched=$((fetched + 1))
  echo "fetch_data: fetched ${folder}/${file}"
done <<<"${listing}"

echo "fetch_data: ${verified} verified, ${fetched} fetched, in ${dest}"
