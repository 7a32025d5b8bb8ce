"""Figures 3, 6 and 7: search time for a whole query set against the maximal distance."""
import math

import numpy as np

import style
from results_io import SHAPES, sweep_series, warn

plt = style.plt
BEST_COUNT = 6


def _panel_distances(series):
    dists = sorted({c.max_dist_m for cells in series.values() for c in cells if c.max_dist_m is not None})
    return dists or [0.0, 1.0]


def draw_series(ax, results, key, cells, dists):
    """Draws one adapter+kind; the last point before a skipped cell gets an 'x'. Returns the line or None."""
    adapter, kind = key
    kw = style.line_kw(adapter, kind)
    label = style.series_label(adapter, kind, cells[0].strategy, results)
    if all(c.max_dist_m is None for c in cells):  # k-NN recorded once: flat over the swept distances
        run = [c for c in cells if c.seconds is not None]
        if not run:
            warn(f"{cells[0].model}/{cells[0].query}/{adapter}/{kind}: skipped ({cells[0].skipped}), not drawn")
            return None
        xs = np.array(dists)
        (line,) = ax.plot(xs, np.full(len(xs), run[-1].seconds), label=label,
                          markevery=max(1, len(xs) // 6), **kw)
        return line
    cells = [c for c in cells if c.max_dist_m is not None]
    xs = np.array([c.max_dist_m for c in cells])
    ys = np.array([math.nan if c.seconds is None else c.seconds for c in cells])
    if np.all(np.isnan(ys)):
        warn(f"{cells[0].model}/{cells[0].query}/{adapter}/{kind}: every cell skipped, not drawn")
        return None
    (line,) = ax.plot(xs, ys, label=label, markevery=max(1, len(xs) // 8), **kw)
    ends = [i - 1 for i in range(1, len(cells)) if cells[i].seconds is None and cells[i - 1].seconds is not None]
    if ends:
        ax.plot(xs[ends], ys[ends], color=kw["color"], **style.SKIP_MARKER)
    return line


def draw_panel(ax, results, model, query, keys=None):
    """Draws the chosen (adapter, kind) series of one combination; returns {label: line}."""
    series = sweep_series(results, model, query)
    dists = _panel_distances(series)
    lines = {}
    for key in sorted(series):
        if keys is None or key in keys:
            line = draw_series(ax, results, key, series[key], dists)
            if line is not None:
                lines[line.get_label()] = line
    ax.set_xlim(min(dists), max(dists))
    return lines


def _legend(fig, lines, ncol):
    handles = [lines[k] for k in sorted(lines)]
    handles.append(plt.Line2D([], [], color="black", **style.SKIP_MARKER))
    fig.legend(handles, [h.get_label() for h in handles[:-1]] + ["last cell before skipped ones (over budget)"],
               loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=ncol, frameon=False)


def _values(series, keys):
    return [c.seconds for k in keys for c in series.get(k, []) if c.seconds is not None]


def fig3(results, out_dir):
    """Hollow cube queries against the hollow sphere model: log overview and linear zoom."""
    model, query = "hollow_sphere", "hollow_cube"
    series = sweep_series(results, model, query)
    if not series:
        warn("fig3: no sweep cells for model hollow_sphere / query hollow_cube: figure skipped")
        return None
    fig, (ax_log, ax_lin) = plt.subplots(1, 2, figsize=(13, 5))
    lines = draw_panel(ax_log, results, model, query)
    draw_panel(ax_lin, results, model, query)
    style.log_y(ax_log)
    ax_log.set_title("all adapters, log scale")
    fastest = sorted((k for k in series if _values(series, [k])),
                     key=lambda k: np.mean(_values(series, [k])))[:3]
    top = 1.2 * max(_values(series, fastest))
    ax_lin.set_ylim(0, top)
    ax_lin.set_title(f"linear zoom: 0 to {top:.3g} s (about the 3 fastest)")
    for ax in (ax_log, ax_lin):
        ax.set_xlabel("max distance (m)")
        ax.set_ylabel("time for all queries (s)")
    fig.suptitle("Query: hollow cube, model: hollow sphere")
    _legend(fig, lines, 3)
    return style.save(fig, out_dir, "fig3_hollow_cube_vs_hollow_sphere")


def best_keys(results, count=BEST_COUNT):
    """The `count` adapter+kind series of lowest mean rank over every swept cell of the 4x4 grid.

    A skipped or missing cell ranks last; k-NN (recorded once) counts at every distance; brute force is a
    reference and approximate adapters answer another question: neither is ever among the best."""
    approximate = {name for name, info in results.adapters.items() if info.get("exact") is False}
    ranks = {}
    for model in SHAPES:
        for query in SHAPES:
            series = {k: v for k, v in sweep_series(results, model, query).items() if k[0] != "brute_force" and k[0] not in approximate}
            for d in {c.max_dist_m for cells in series.values() for c in cells if c.max_dist_m is not None}:
                times = {}
                for key, cells in series.items():
                    match = [c for c in cells if c.max_dist_m in (d, None)]
                    times[key] = match[0].seconds if match and match[0].seconds is not None else math.inf
                for rank, key in enumerate(sorted(times, key=times.get)):
                    ranks.setdefault(key, []).append(rank)
    worst = max((len(r) for r in ranks.values()), default=0)
    score = {k: (sum(r) + (worst - len(r)) * len(ranks)) / max(worst, 1) for k, r in ranks.items()}
    return sorted(score, key=lambda k: (score[k], k))[:count]


def grid(results, out_dir, best):
    """Figure 6 (every series, log) or 7 (best series, linear) as a 4x4 grid: model x query."""
    stem = "fig7_grid_best" if best else "fig6_grid_all"
    if not any(c.model in SHAPES and c.query in SHAPES for c in results.sweep):
        warn(f"{stem}: no synthetic sweep cells: figure skipped")
        return None
    keys = set(best_keys(results)) if best else None
    if best and not keys:
        warn(f"{stem}: no synthetic sweep series besides the brute-force reference: figure skipped")
        return None
    fig, axes = plt.subplots(4, 4, figsize=(16, 13), sharex=True, sharey=True)
    lines, values = {}, []
    for col, model in enumerate(SHAPES):
        for row, query in enumerate(SHAPES):
            ax = axes[row][col]
            lines.update(draw_panel(ax, results, model, query, keys))
            values += _values(sweep_series(results, model, query), keys or sweep_series(results, model, query))
            if not sweep_series(results, model, query):
                ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center", color="grey")
            if row == 0:
                ax.set_title(f"model: {model.replace('_', ' ')}", fontsize=11)
            if col == 0:
                ax.set_ylabel(f"query: {query.replace('_', ' ')}\ntime (s)", fontsize=11)
            if row == 3:
                ax.set_xlabel("max distance (m)")
    if best:
        p90 = float(np.percentile(values, 90)) if values else 1.0
        top = 1.0 if 0.2 <= p90 <= 1.0 else float(f"{1.1 * p90:.1g}")
        axes[0][0].set_ylim(0, top)
        fig.suptitle(f"Best {len(keys)} adapter+kinds (lowest mean rank over all cells), linear 0 to {top:g} s",
                     fontsize=12)
    else:
        style.log_y(axes[0][0])
        fig.suptitle("All adapters, log scale (construction excluded)", fontsize=12)
    fig.tight_layout()
    _legend(fig, lines, 3)
    return style.save(fig, out_dir, stem)
