"""Table 1: what each adapter's library offers, and how each search kind is answered."""
import json

from results_io import warn

STRATEGY_CELL = {"native": "native", "via_knn": "via k-NN", "via_radius": "via radius", "via_box": "via box"}
HEADER = ("| adapter | library | version | data structure | k-NN | fixed radius | ranged | exact | parameters |\n"
          "|---|---|---|---|---|---|---|---|---|\n")


def _cell(value):
    if value is None or value == "":
        return "?"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, dict):
        return ", ".join(f"{k}={v}" for k, v in sorted(value.items())) or "-"
    text = STRATEGY_CELL.get(value, str(value)) if isinstance(value, str) else json.dumps(value)
    return text.replace("|", "\\|")


def write_table1(results, out_dir):
    """Writes table1.md from the adapters' metadata (context 'adapters', else record fields)."""
    if not results.adapters:
        warn("table1: no adapter metadata in the results: table skipped")
        return None
    rows = []
    for name in sorted(results.adapters):
        info = results.adapters[name]
        if not info.get("library"):
            warn(f"table1: adapter {name} has no library metadata; shown with '?'")
        rows.append("| " + " | ".join([name] + [_cell(info.get(k)) for k in
                                                 ("library", "version", "structure", "knn", "radius", "ranged",
                                                  "exact", "params")]) + " |")
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "table1.md"
    path.write_text("# Table 1: libraries and how each search kind is answered\n\n"
                    "native: the library's own search; via k-NN / via radius / via box: emulated on top of that "
                    "search and filtered by distance; ?: not recorded.\n\n" + HEADER + "\n".join(rows) + "\n")
    print(f"wrote {path}")
    return path
