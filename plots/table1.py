"""Table 1: what each adapter's library offers, and how each search kind is answered. The one generator of
the table from results files: table1.md beside the figures, the README's copy and the report use it."""
from results_io import warn
from style import LIBRARY_STRATEGIES, STRATEGY_TEXT

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
    """The table's Markdown lines, one row per adapter in the results' metadata. The ranged column lists every
    strategy offered, the default first, in bold where it is the library's own ranged call."""
    lines = list(HEADER)
    for name in sorted(results.adapters):
        info = results.adapters[name]
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
    path.write_text("# Table 1: libraries and how each search kind is answered\n\n"
                    "native: the library's own search; via k-NN / via radius / via box: emulated on top of that "
                    "search and filtered by distance; no: not offered; ?: not recorded.\n\n"
                    + "\n".join(table1_lines(results)) + "\n")
    print(f"wrote {path}")
    return path
