"""Figure 10: throughput of ranged 1-NN against the threads a batch runs on (wall time).

Drawn from micro_nns's threaded benchmarks (`--threads N`: 1 to N threads on the Figure 3 pair and SICK) and from
sweep cells run at more than one thread count (`run_sweep --threads N`, one results file per count)."""

import style
from results_io import is_default_strategy, warn

plt = style.plt
COLUMNS = 4
SWEEP_DISTS_M = (0.1, 1.0)  # a sweep's panels: these distances where it ran them, else its largest


def micro_throughputs(results):
    """{(pair, max_dist): {adapter: {threads: queries per second}}} from micro_nns (fastest repetition's wall time),
    for the (pair, adapter, distance) cells timed on more than one thread; default variants only."""
    fastest = {}
    for w in results.micro_walls:
        if w.variant is None and w.n_queries:
            key = (w.pair, w.max_dist_m, w.adapter, w.threads)
            fastest[key] = max(fastest.get(key, 0.0), w.n_queries / w.wall_seconds)
    return _threaded_only(fastest)


def sweep_throughputs(results):
    """The same from sweep cells (ranged, each adapter's default strategy, median wall time), keyed
    ("<model> -> <query>", max_dist), at SWEEP_DISTS_M where run, else at the largest distance run."""
    rates = {}
    for c in results.sweep_threads:
        if c.search == "ranged" and c.seconds and c.n_queries and c.max_dist_m is not None and \
                is_default_strategy(results, c):
            rates[(f"{c.model} -> {c.query}", c.max_dist_m, c.adapter, c.threads)] = c.n_queries / c.seconds
    threaded = _threaded_only(rates)
    out = {}
    for pair in sorted({p for p, _ in threaded}):
        dists = sorted(d for p, d in threaded if p == pair)
        for d in [d for d in dists if d in SWEEP_DISTS_M] or dists[-1:]:
            out[(pair, d)] = threaded[(pair, d)]
    return out


def _threaded_only(rates):
    """{(pair, d): {adapter: {threads: rate}}} of the adapters with rates at two thread counts or more."""
    by_cell = {}
    for (pair, d, adapter, threads), rate in rates.items():
        by_cell.setdefault((pair, d), {}).setdefault(adapter, {})[threads] = rate
    out = {}
    for key, adapters in sorted(by_cell.items()):
        kept = {a: t for a, t in adapters.items() if len(t) >= 2}
        if kept:
            out[key] = kept
    return out


def micro_title(pair, max_dist_m):
    return f"{'Figure 3 pair' if pair == 'fig3' else pair}, {max_dist_m:g} m"


def draw_panel(ax, results, title, adapters):
    top = 1
    for adapter in sorted(adapters, key=lambda a: (style.family(a), a)):
        xs, ys = zip(*sorted(adapters[adapter].items()))
        ax.plot(xs, [y / 1e6 for y in ys], label=style.short_label(adapter, results),
                **style.line_kw(adapter, "ranged", results.adapter_info(adapter).get("ranged"), results))
        top = max(top, max(xs))
    best_one = max((t[1] for t in adapters.values() if 1 in t), default=None)
    if best_one:  # what perfect scaling of the fastest single thread would give
        ax.plot([1, top], [best_one / 1e6, best_one * top / 1e6], color="#999999", linestyle=":", linewidth=1)
    ax.xaxis.set_major_locator(style.matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("threads")
    ax.set_ylabel("million queries / s")


def panels(results):
    """[(title, {adapter: {threads: queries per second}})]: the micro-benchmarks', then the sweeps'."""
    return [(micro_title(p, d), a) for (p, d), a in micro_throughputs(results).items()] + \
           [(f"{p}, sweep, {d:g} m", a) for (p, d), a in sweep_throughputs(results).items()]


def fig10(results, out_dir):
    panels_drawn = panels(results)
    if not panels_drawn:
        warn("fig10: no ranged search timed on more than one thread count: figure skipped")
        return None
    fig = style.ranged_panels_figure(results, panels_drawn, draw_panel, COLUMNS, 3.0, "Figure 10: ranged 1-NN "
                                     "throughput against threads (wall time of a batch; dotted: the fastest "
                                     "single-thread rate times the threads)", 0.97)
    return style.save(fig, out_dir, "fig10_threads")
