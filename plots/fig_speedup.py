"""Figure 9: speed-up over the faster nanoflann (Debian's or the newest) against the maximal distance (ranged 1-NN).

Ratios of two adapters timed in the same run survive a noisy machine better than absolute times."""

import style
from fig_icp import NANOFLANNS
from results_io import SHAPES, micro_cells, sweep_series, warn

plt = style.plt
MICRO_TITLES = {"fig3": "Figure 3 pair, micro-benchmark", "sick": "SICK office scan, queries in scan order",
                "sick_shuffled": "SICK office scan, queries shuffled"}


def faster_nanoflann_by_dist(times):
    """{max_dist: the faster nanoflann's seconds} from {adapter: {max_dist: seconds}} (fig_icp.faster_nanoflann
    per distance)."""
    out = {}
    for name in NANOFLANNS:
        for d, seconds in times.get(name, {}).items():
            if seconds and (d not in out or seconds < out[d]):
                out[d] = seconds
    return out


def sweep_ratios(results, model, query):
    """{adapter: [(max_dist, the faster nanoflann's time / adapter time)]} over the ranged series of one
    combination; both nanoflanns are drawn too (the faster at 1 at each distance)."""
    series = {a: cells for (a, kind), cells in sweep_series(results, model, query).items() if kind == "ranged"}
    ref = faster_nanoflann_by_dist({a: {c.max_dist_m: c.seconds for c in cells} for a, cells in series.items()})
    if not ref:
        return {}
    both = all(n in series for n in NANOFLANNS)
    out = {}
    for adapter, cells in series.items():
        points = [(c.max_dist_m, ref[c.max_dist_m] / c.seconds) for c in cells
                  if c.seconds and c.max_dist_m in ref and c.max_dist_m > 0]
        if points and adapter != "brute_force" and (both or adapter not in NANOFLANNS):
            out[adapter] = points
    return out


def micro_ratios(results):
    """{pair: {adapter: [(max_dist, ratio)]}} from the micro-benchmarks (fastest repetition, CPU time)."""
    cells = micro_cells(results)
    out = {}
    for (pair, adapter, d), seconds in sorted(cells.items()):
        ref = min(filter(None, (cells.get((pair, n, d)) for n in NANOFLANNS)), default=None)
        if ref and seconds:
            out.setdefault(pair, {}).setdefault(adapter, []).append((d, ref / seconds))
    return out


def speedup_panels(results):
    """[(title, {adapter: points})]: the Figure 3 pair's sweep, real-pair sweeps, then the micro-benchmarks."""
    panels = []
    combos = sorted({(c.model, c.query) for c in results.sweep if c.search == "ranged"})
    wanted = [("hollow_sphere", "hollow_cube")] + [c for c in combos if c[0] not in SHAPES and c[0] == c[1]]
    for model, query in wanted:
        ratios = sweep_ratios(results, model, query)
        if ratios and len({d for pts in ratios.values() for d, _ in pts}) >= 3:
            title = ("Figure 3 pair, sweep" if model in SHAPES else f"{model}, sweep")
            panels.append((title, ratios))
    for pair, ratios in micro_ratios(results).items():
        panels.append((MICRO_TITLES.get(pair, f"{pair}, micro-benchmark"), ratios))
    return panels


def draw_ratios(ax, results, title, ratios):
    for adapter in sorted(ratios, key=lambda a: (style.family(a), a)):
        xs, ys = zip(*sorted(ratios[adapter]))
        strategy = results.adapter_info(adapter).get("ranged")
        ax.plot(xs, ys, label=style.short_label(adapter, results), markevery=max(1, len(xs) // 8),
                **style.line_kw(adapter, "ranged", strategy, results))
    ax.axhline(1.0, color=style.LIBRARY_COLOUR["nanoflann"], linewidth=2, alpha=0.6)
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(plt.FuncFormatter(lambda y, _: f"{y:g}x"))
    ax.yaxis.set_minor_formatter(plt.FuncFormatter(lambda y, _: f"{y:g}x" if round(y, 1) in (0.2, 0.5, 2, 5, 20, 50)
                                                   else ""))
    ax.set_title(title)
    ax.set_xlabel("maximal distance (m)")
    ax.set_ylabel("speed-up over the faster nanoflann (x)")


def fig9(results, out_dir):
    panels = speedup_panels(results)
    if not panels:
        warn("fig9: no ranged times of nanoflann beside other adapters: figure skipped")
        return None
    fig = style.ranged_panels_figure(results, panels, draw_ratios, 2, 3.6, "Figure 9: speed-up of ranged 1-NN over "
                                     "the faster nanoflann (its time / the adapter's; above 1 = faster)", 0.95)
    return style.save(fig, out_dir, "fig9_speedup")

