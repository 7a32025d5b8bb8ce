#!/usr/bin/env python3
"""Table 1: what each adapter's library offers, and how each search kind is answered. The one formatter of
the table: table1.md beside the figures, the README's copy and the report use it, and
`python3 plots/table1.py --from-registry build/release/bench/nns_query` prints it for the adapters built in
(from `nns_query --list --json`); `python3 plots/table1.py [RESULTS...]` for those of results files."""
import argparse
import json
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import results_io  # noqa: E402
from files import write_atomically  # noqa: E402
from results_io import warn  # noqa: E402
from style import LIBRARY_STRATEGIES, STRATEGY_TEXT  # noqa: E402

HEADER = ["| adapter | library | version | data structure | precision | k-NN | fixed radius | ranged | exact | parameters |",
          "|---|---|---|---|---|---|---|---|---|---|"]


def _strategy(value):
    if value == "unsupported":
        return "no"
    return STRATEGY_TEXT.get(value, "?" if value in (None, "") else str(value))


def _ranged(info):
    """Every ranged strategy the adapter offers, the default first; the library's own call in bold."""
    offered = info.get("ranged_strategies") or [info.get("ranged")]
    return "; ".join(f"**{_strategy(s)}**" if s in LIBRARY_STRATEGIES else _strategy(s) for s in offered)


def _params(params):
    return ", ".join(f"{k}={v}" for k, v in sorted((params or {}).items())) or "-"


def table1_lines(results):
    """The table's Markdown lines, one row per adapter in the results' metadata."""
    return adapter_lines(results.adapters)


def adapter_lines(adapters):
    """The table's Markdown lines, one row per adapter of {name: metadata} (a results file's context
    'adapters'). The ranged column lists every strategy offered, the default first, in bold where it is the
    library's own ranged call."""
    lines = list(HEADER)
    for name in sorted(adapters):
        info = adapters[name]
        if not info.get("library"):
            warn(f"table1: adapter {name} has no library metadata; shown with '?'")
        exact = "yes" if info.get("exact") is not False else "**no (approximate)**"
        cells = [name, info.get("library") or "?", str(info.get("version") or "?"), info.get("structure") or "?",
                 info.get("scalar") or "?", _strategy(info.get("knn")), _strategy(info.get("radius")), _ranged(info),
                 exact, _params(info.get("params"))]
        lines.append("| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |")
    return lines


def write_table1(results, out_dir):
    """Writes table1.md from the adapters' metadata (context 'adapters', else record fields)."""
    if not results.adapters:
        warn("table1: no adapter metadata in the results: table skipped")
        return None
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "table1.md"
    write_atomically(path, "# Table 1: libraries and how each search kind is answered\n\n"
                    "native: the library's own search; via k-NN / via radius / via box: emulated on top of that "
                    "search and filtered by distance; no: not offered; ?: not recorded.\n\n"
                    + "\n".join(table1_lines(results)) + "\n")
    print(f"wrote {path}")
    return path


def registry_adapters(nns_query):
    """The metadata every adapter built into nns_query declares, by name (nns_query --list --json)."""
    try:
        proc = subprocess.run([str(nns_query), "--list", "--json"], capture_output=True, text=True, timeout=300)
    except OSError as e:
        raise SystemExit(f"table1: cannot run {nns_query}: {e}")
    if proc.returncode != 0:
        raise SystemExit(f"table1: {nns_query} --list --json exited {proc.returncode}: {proc.stderr.strip()}")
    return json.loads(proc.stdout)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Prints Table 1 as Markdown, from the adapters built into "
                                                 "nns_query or from results files' metadata.")
    parser.add_argument("--from-registry", metavar="NNS_QUERY", type=Path,
                        help="the nns_query binary whose adapters to list (e.g. build/release/bench/nns_query)")
    parser.add_argument("results", nargs="*", type=Path, help="results files (default: as make_figures.py)")
    args = parser.parse_args(argv)
    if args.from_registry and args.results:
        parser.error("give either --from-registry or results files, not both")
    if args.from_registry:
        adapters = registry_adapters(args.from_registry)
    else:
        adapters = results_io.load(args.results or results_io.default_inputs()).adapters
    print("\n".join(adapter_lines(adapters)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
