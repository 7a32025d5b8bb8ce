"""Figure 8 (the scale experiment): time per query and build time against the model size, log-log,
and each adapter's growth exponent (least-squares slope of log time against log n) in scale_exponents.md."""
import numpy as np

import style
from files import write_atomically
from results_io import is_default_strategy, latest_builds, warn

plt = style.plt
MIN_SIZES = 3  # a query searched against at least this many model sizes makes a scale series


def scale_cells(results):
    """The sweep cells of the scale series: one (query, search, max_dist, k) searched against the most model
    sizes (at least MIN_SIZES). Returns (key, cells) or (None, [])."""
    groups = {}
    for c in results.sweep:
        if c.n_points is not None and c.n_queries and is_default_strategy(results, c):
            groups.setdefault((c.query, c.search, c.max_dist_m, c.k), []).append(c)
    sized = {key: cells for key, cells in groups.items() if len({c.n_points for c in cells}) >= MIN_SIZES}
    if not sized:
        return None, []
    key = max(sized, key=lambda k: (len({c.n_points for c in sized[k]}), len(sized[k])))
    return key, sized[key]


def growth_exponent(ns, ts):
    """Least-squares slope of log(t) against log(n); None with fewer than two distinct sizes."""
    if len(set(ns)) < 2:
        return None
    slope, _ = np.polyfit(np.log(np.asarray(ns, float)), np.log(np.asarray(ts, float)), 1)
    return float(slope)


def scale_table(results):
    """{adapter: {"query": [(n, s/query)], "build": [(n, s)], "stopped": (n, reason) or None}} and the key."""
    key, cells = scale_cells(results)
    table = {}
    models = {c.model: int(c.n_points) for c in cells}
    for c in sorted(cells, key=lambda c: c.n_points):
        row = table.setdefault(c.adapter, {"query": [], "build": [], "stopped": None})
        if c.seconds is not None:
            row["query"].append((int(c.n_points), c.seconds / c.n_queries))
        elif row["stopped"] is None:
            row["stopped"] = (int(c.n_points), c.skipped)
    for (model, adapter), b in sorted(latest_builds(results).items(), key=lambda kv: models.get(kv[0][0], 0)):
        if model in models and adapter in table and b.build_seconds > 0:
            table[adapter]["build"].append((models[model], b.build_seconds))
            if b.index_bytes:
                table[adapter].setdefault("memory", []).append((models[model], b.index_bytes / models[model]))
    return key, table


def _fmt(x, digits=2):
    return "-" if x is None else f"{x:.{digits}f}"


def _sig(x):
    return "-" if x is None else f"{x:.3g}"


def write_exponents(key, table, out_dir):
    """Writes scale_exponents.md: per adapter, the growth exponents and the times at the largest size run."""
    query, search, max_dist, k = key
    lines = ["# Growth with the model size (scale experiment)", "",
             f"Query set `{query}`, {search} search" + (f" at max_dist {max_dist:g} m" if max_dist is not None else "")
             + (f", k = {k:g}" if k is not None else "") + ". Exponent: least-squares slope of log(time) "
             "against log(n) over the sizes that ran (1 = linear in the model size, 0 = independent of it).", "",
             "| adapter | sizes run | n from | n to | query time exponent | build time exponent | "
             "µs per query at n to | build s at n to | stopped |",
             "|---|---|---|---|---|---|---|---|---|"]
    for adapter in sorted(table):
        row = table[adapter]
        ran = row["query"]
        query_exp = growth_exponent(*zip(*ran)) if len(ran) >= 2 else None
        build_exp = growth_exponent(*zip(*row["build"])) if len(row["build"]) >= 2 else None
        last_build = dict(row["build"]).get(ran[-1][0]) if ran else None
        stopped = "-" if row["stopped"] is None else f"at {row['stopped'][0]}: {row['stopped'][1]}"
        lines.append(f"| {adapter} | {len(ran)} | {ran[0][0] if ran else '-'} | {ran[-1][0] if ran else '-'} | "
                     f"{_fmt(query_exp)} | {_fmt(build_exp)} | {_sig(ran[-1][1] * 1e6 if ran else None)} | "
                     f"{_sig(last_build)} | {stopped.replace('|', '/')} |")
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "scale_exponents.md"
    write_atomically(path, "\n".join(lines) + "\n")
    print(f"wrote {path}")
    return path


def fig8(results, out_dir):
    """Writes fig8_scale.png/.svg and scale_exponents.md; None (with a message) without scale records."""
    key, table = scale_table(results)
    if key is None:
        warn(f"fig8: no scale records (one query set searched against {MIN_SIZES} or more model sizes): "
             "figure skipped")
        return None
    write_exponents(key, table, out_dir)
    fig = plt.figure(figsize=(style.PAGE_WIDTH_IN, 6.4))
    grid_spec = fig.add_gridspec(2, 3, height_ratios=[3, 1.1], hspace=0.35, wspace=0.3)
    panels = [(fig.add_subplot(grid_spec[0, i]), part) for i, part in enumerate(("query", "build", "memory"))]
    for adapter in sorted(table):
        for ax, part in panels:
            points = table[adapter].get(part, [])
            if points:
                ns, ts = zip(*points)
                ax.plot(ns, [t * (1e6 if part == "query" else 1.0) for t in ts], linewidth=1.4,
                        label=style.short_label(adapter, results), **style.marker_kw(adapter, results))
    query, search, max_dist, _ = key
    (ax_query, _), (ax_build, _), (ax_memory, _) = panels
    ax_query.set_ylabel("time per query (µs)")
    ax_query.set_title(f"{search} 1-NN" + (f" at {max_dist:g} m" if max_dist is not None else ""))
    ax_build.set_ylabel("build time (s)")
    ax_build.set_title("construction")
    ax_memory.set_ylabel("index bytes per model point (B)")
    ax_memory.set_title("memory beyond the points")
    for ax, _ in panels:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("model points n")
    key_ax = fig.add_subplot(grid_spec[1, :])
    key_ax.axis("off")
    key_ax.legend(handles=style.adapter_handles(sorted(table, key=lambda a: (style.family(a), a)), results),
                  loc="upper center", ncol=5, frameon=False, title="adapter (colour: library, marker: structure)")
    fig.suptitle(f"Figure 8: growth with the model size, log-log, queries: {query}; a line ends where the "
                 "adapter went over a budget")
    return style.save(fig, out_dir, "fig8_scale")
