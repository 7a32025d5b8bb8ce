"""Figures 3, 6 and 7: search time for a whole query set against the maximal distance."""
import math

import numpy as np

import style
from results_io import SHAPES, size_order, sweep_series, warn

plt = style.plt
BEST_COUNT = 6
FIG3 = ("hollow_sphere", "hollow_cube")  # (model, query)
ZOOM_COUNT = 3


def _panel_distances(series):
    dists = sorted({c.max_dist_m for cells in series.values() for c in cells if c.max_dist_m is not None})
    return dists or [0.0, 1.0]


def series_xy(cells, dists):
    """(xs, ys) of one series; k-NN, recorded once, is flat over the swept distances; skipped cells are NaN."""
    if all(c.max_dist_m is None for c in cells):
        run = [c for c in cells if c.seconds is not None]
        ys = run[-1].seconds if run else math.nan
        return np.array(dists), np.full(len(dists), ys)
    cells = [c for c in cells if c.max_dist_m is not None]
    return (np.array([c.max_dist_m for c in cells]),
            np.array([math.nan if c.seconds is None else c.seconds for c in cells]))


def draw_series(ax, results, key, cells, dists):
    """Draws one adapter+kind; the last point before a skipped cell gets an 'x'. Returns the line or None."""
    adapter, kind = key
    kw = style.line_kw(adapter, kind, cells[0].strategy, results)
    label = style.series_label(adapter, kind, cells[0].strategy, results)
    xs, ys = series_xy(cells, dists)
    if np.all(np.isnan(ys)):
        warn(f"{cells[0].model}/{cells[0].query}/{adapter}/{kind}: every cell skipped, not drawn")
        return None
    (line,) = ax.plot(xs, ys, label=label, markevery=max(1, len(xs) // 8), **kw)
    ends = [i - 1 for i in range(1, len(ys)) if np.isnan(ys[i]) and not np.isnan(ys[i - 1])]
    if ends:
        ax.plot(xs[ends], ys[ends], color=kw["color"], **style.SKIP_MARKER)
    return line


def draw_panel(ax, results, model, query, keys=None):
    """Draws the chosen (adapter, kind) series of one combination; returns the keys drawn."""
    series = sweep_series(results, model, query)
    dists = _panel_distances(series)
    drawn = []
    for key in sorted(series):
        if keys is None or key in keys:
            if draw_series(ax, results, key, series[key], dists) is not None:
                drawn.append(key)
    ax.set_xlim(min(dists), max(dists))
    return drawn


def _values(series, keys):
    return [c.seconds for k in keys for c in series.get(k, []) if c.seconds is not None]


def _classes(results, series, keys):
    return {style.strategy_class(k[1], series[k][0].strategy) for k in keys if k in series}


def fastest_exact(results, series, count):
    """Each adapter's best series, the `count` of lowest mean log time (a skipped cell costs twice the
    slowest time), approximate adapters and brute force never among them."""
    contenders = {k: v for k, v in series.items() if _values(series, [k]) and k[0] != "brute_force"
                  and not style.is_approximate(k[0], results)}
    if not contenders:
        return []
    dists = _panel_distances(series)
    penalty = 2 * max(v for k in contenders for v in _values(contenders, [k]))
    scores = {k: _score(contenders, k, dists, penalty) for k in contenders}
    best = {}
    for key in sorted(scores, key=scores.get):
        best.setdefault(key[0], key)
    return sorted(best.values(), key=scores.get)[:count]


def adapter_order(keys):
    """Adapters of the keys, grouped by library."""
    return sorted({k[0] for k in keys}, key=lambda a: (style.family(a), a))


def fig3(results, out_dir):
    """Hollow cube queries against the hollow sphere model: log overview and linear zoom on the fastest."""
    model, query = FIG3
    series = sweep_series(results, model, query)
    if not series:
        warn("fig3: no sweep cells for model hollow_sphere / query hollow_cube: figure skipped")
        return None
    fig = plt.figure(figsize=(style.PAGE_WIDTH_IN, 8.0))
    grid_spec = fig.add_gridspec(2, 2, height_ratios=[3, 1.0], hspace=0.28, wspace=0.18)
    ax_log, ax_lin, ax_key = (fig.add_subplot(grid_spec[0, 0]), fig.add_subplot(grid_spec[0, 1]),
                              fig.add_subplot(grid_spec[1, :]))
    drawn = draw_panel(ax_log, results, model, query)
    style.log_y(ax_log)
    ax_log.set_title("every adapter and kind, log scale")
    fastest = fastest_exact(results, series, ZOOM_COUNT)
    draw_panel(ax_lin, results, model, query, set(fastest))
    top = 1.15 * max(_values(series, fastest)) if fastest else 1.0
    ax_lin.set_ylim(0, top)
    ax_lin.set_title(f"linear zoom on the {len(fastest)} fastest exact adapters (approximate ones not ranked)")
    for ax in (ax_log, ax_lin):
        ax.set_xlabel("maximal distance (m)")
        ax.set_ylabel("time for all queries (s)")
    n_queries = next((c.n_queries for cells in series.values() for c in cells if c.n_queries), None)
    fig.suptitle(f"Figure 3: {query.replace('_', ' ')} queries" + (f" ({n_queries:,.0f})" if n_queries else "")
                 + f" against a {model.replace('_', ' ')} model, 1-NN, construction excluded", y=0.95)
    style.legends_in(ax_key, adapter_order(drawn), _classes(results, series, drawn), results)
    return style.save(fig, out_dir, "fig3_hollow_cube_vs_hollow_sphere")


STRATEGY_ORDER = ("native", "native_unpruned", "via_knn", "via_radius", "via_box")
STRATEGY_COLOUR = {"native": "#1b6ca8", "native_unpruned": "#6a3d9a", "via_knn": "#d95f02", "via_radius": "#1b9e77",
                   "via_box": "#7f7f7f"}
STRATEGY_DASH = {"native": "-", "native_unpruned": "-", "via_knn": (0, (5, 2)), "via_radius": (0, (1.2, 1.6)),
                 "via_box": (0, (6, 2, 1.2, 2))}


def ranged_strategies(results, model, query):
    """{adapter: {strategy: cells}} of the ranged series of one combination, for adapters run with more than
    one strategy: at the set size the other figures draw, else at the largest size swept with several strategies
    (a grid run with each adapter's default strategy beside quick's run of every strategy at fewer points)."""
    sizes = sorted({(c.n_points, c.n_queries) for c in results.sweep_every_size if (c.model, c.query) == (model, query)},
                   key=lambda size: size_order(*size), reverse=True)
    for cells in [None] + [[c for c in results.sweep_every_size if (c.model, c.query, c.n_points, c.n_queries) ==
                            (model, query, *size)] for size in sizes]:
        by_adapter = {}
        for (adapter, kind, strategy), series in sweep_series(results, model, query, True, cells).items():
            if kind == "ranged":
                by_adapter.setdefault(adapter, {})[strategy] = series
        shown = {a: s for a, s in by_adapter.items() if len(s) > 1}
        if shown:
            return shown
    return {}


def fig3_strategies(results, out_dir):
    """Figure 3's pair with every ranged strategy each adapter offers: one small panel per adapter, a line per
    strategy (the library's own call, k-NN then a cut, radius search then the k nearest)."""
    model, query = FIG3
    shown = ranged_strategies(results, model, query)
    if not shown:
        warn("fig3_strategies: no adapter ran ranged search with more than one strategy: figure skipped")
        return None
    adapters = sorted(shown, key=lambda a: (style.family(a), a))
    cols = 4
    rows = math.ceil(len(adapters) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(style.PAGE_WIDTH_IN, 1.75 * rows + 1.2), sharex=True, sharey=True,
                             squeeze=False)
    dists = _panel_distances({k: v for a in shown for k, v in shown[a].items()})
    used = set()
    for ax, adapter in zip(axes.flat, adapters):
        for strategy in sorted(shown[adapter], key=lambda s: STRATEGY_ORDER.index(s) if s in STRATEGY_ORDER else 99):
            xs, ys = series_xy(shown[adapter][strategy], dists)
            ax.plot(xs, ys, color=STRATEGY_COLOUR.get(strategy, "black"), linestyle=STRATEGY_DASH.get(strategy, "-"),
                    linewidth=1.5)
            used.add(strategy)
        ax.set_title(style.short_label(adapter, results), fontsize=9)
        style.log_y(ax)
    for ax in list(axes.flat)[len(adapters):]:
        ax.axis("off")
    handles = [plt.Line2D([], [], color=STRATEGY_COLOUR.get(s, "black"), linestyle=STRATEGY_DASH.get(s, "-"),
                          linewidth=1.5, label="ranged " + style.STRATEGY_TEXT.get(s, s))
               for s in STRATEGY_ORDER if s in used]
    fig.legend(handles=handles, loc="upper center", ncol=len(handles), bbox_to_anchor=(0.5, 0.985 - 0.25 / rows))
    fig.supxlabel("maximal distance (m)")
    fig.supylabel("time for all queries (s)")
    cell = next(c for strategies in shown.values() for cells in strategies.values() for c in cells)
    sizes = f" ({cell.n_queries:,.0f} queries, {cell.n_points:,.0f} points)" if cell.n_queries and cell.n_points else ""
    fig.suptitle(f"Figure 3, every ranged strategy: {query.replace('_', ' ')} queries against a "
                 f"{model.replace('_', ' ')} model{sizes}, 1-NN (\"native\": the library's own ranged call)", y=0.995)
    fig.tight_layout(rect=(0, 0, 1, 0.985 - 0.6 / rows))
    return style.save(fig, out_dir, "fig3_strategies")


def _score(series, key, dists, penalty):
    """Mean log time over the panel's distances; a skipped cell costs `penalty` seconds."""
    xs, ys = series_xy(series[key], dists)
    ys = np.where(np.isnan(ys), penalty, ys)
    return float(np.mean(np.log(np.maximum(ys, 1e-12))))


def best_per_family(results, series):
    """Per library, its fastest series in this panel (by mean log time); approximate adapters apart."""
    dists = _panel_distances(series)
    values = [v for k in series for v in _values(series, [k])]
    penalty = 2 * max(values) if values else 1.0
    best = {}
    for key in series:
        if not _values(series, [key]):
            continue
        group = "approx" if style.is_approximate(key[0], results) else style.family(key[0])
        score = _score(series, key, dists, penalty)
        if group not in best or score < best[group][0]:
            best[group] = (score, key)
    return {key for _, key in best.values()}


def best_keys(results, count=BEST_COUNT):
    """The `count` adapter+kind series of lowest mean rank over every swept cell of the 4x4 grid.

    A skipped or missing cell ranks last; k-NN (recorded once) counts at every distance; brute force is a
    reference and approximate adapters answer another question: neither is ever among the best."""
    ranks = {}
    for model in SHAPES:
        for query in SHAPES:
            series = {k: v for k, v in sweep_series(results, model, query).items()
                      if k[0] != "brute_force" and not style.is_approximate(k[0], results)}
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


def _label_grid(ax, row, col, model, query, ylabel):
    if row == 0:
        ax.set_title(f"model: {model.replace('_', ' ')}")
    if col == 0:
        ax.set_ylabel(f"query: {query.replace('_', ' ')}\n{ylabel}")
    if row == 3:
        ax.set_xlabel("maximal distance (m)")


def _row_top(values):
    """A linear axis top that shows the row's lines rather than its one outlier: 1.15 x the 95th percentile."""
    if not values:
        return 1.0
    return float(f"{1.15 * float(np.percentile(values, 95)):.2g}")


def grid(results, out_dir, best):
    """Figure 6 (each library's fastest series per panel, log) or 7 (best series, linear, one scale per row)."""
    stem = "fig7_grid_best" if best else "fig6_grid_all"
    if not any(c.model in SHAPES and c.query in SHAPES for c in results.sweep):
        warn(f"{stem}: no synthetic sweep cells: figure skipped")
        return None
    keys = set(best_keys(results)) if best else None
    if best and not keys:
        warn(f"{stem}: no synthetic sweep series besides the brute-force reference: figure skipped")
        return None
    fig = plt.figure(figsize=(style.PAGE_WIDTH_IN, 15.5))
    grid_spec = fig.add_gridspec(5, 4, height_ratios=[1, 1, 1, 1, 0.62], hspace=0.3, wspace=0.22)
    drawn, classes = set(), set()
    for row, query in enumerate(SHAPES):
        row_axes, row_values = [], []
        for col, model in enumerate(SHAPES):
            ax = fig.add_subplot(grid_spec[row, col], sharex=row_axes[0] if row_axes else None,
                                 sharey=row_axes[0] if row_axes else None)
            row_axes.append(ax)
            series = sweep_series(results, model, query)
            chosen = keys if best else best_per_family(results, series)
            shown = draw_panel(ax, results, model, query, chosen)
            drawn.update(shown)
            classes |= _classes(results, series, shown)
            row_values += _values(series, shown)
            if not series:
                ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center", color="grey")
            _label_grid(ax, row, col, model, query, "time (s)")
            if col:
                ax.tick_params(labelleft=False)
        if best:
            row_axes[0].set_ylim(0, _row_top(row_values))
        else:
            style.log_y(row_axes[0])
    if best:
        fig.suptitle(f"Figure 7: the {len(keys)} best adapter+kinds over the grid (lowest mean rank), linear; "
                     "each row has its own time scale", y=0.92)
    else:
        fig.suptitle("Figure 6: each library's fastest series per panel, log scale; every series is in the "
                     "interactive report", y=0.92)
    style.legends_in(fig.add_subplot(grid_spec[4, :]), adapter_order(drawn), classes, results)
    return style.save(fig, out_dir, stem)
