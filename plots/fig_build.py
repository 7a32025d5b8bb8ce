"""Figure 4: construction time, one panel per model cloud, adapters sorted fastest first, missing ones marked."""
import math

import numpy as np

import style
from results_io import SHAPES, build_rank, file_ranks, latest_builds, size_order, warn

plt = style.plt
COLUMNS = 4


def drawn_builds(results):
    """{(model, adapter): Build}, each as latest_builds picks it, at one set size per model: the largest (quick's
    15,000-point builds are not drawn beside the grid's 60,000, whichever ran last)."""
    latest, ranks = latest_builds(results), file_ranks(results)
    chosen = {}
    for (model, _), b in latest.items():
        order = (size_order(b.n_points), build_rank(results, b, ranks))
        if model not in chosen or order >= chosen[model][0]:
            chosen[model] = (order, b.n_points)
    return {k: b for k, b in latest.items() if None in (b.n_points, chosen[k[0]][1]) or b.n_points == chosen[k[0]][1]}


def build_table(results):
    """{(model, adapter): build seconds} of the builds drawn (drawn_builds: runs are never mixed)."""
    return {k: b.build_seconds for k, b in drawn_builds(results).items()}


def model_order(results, models):
    """The paper's shapes first, then the other clouds by their number of points (numeric, not string order)."""
    sizes = {b.model: b.n_points for b in results.builds if b.n_points}
    return sorted(models, key=lambda m: (SHAPES.index(m) if m in SHAPES else len(SHAPES), sizes.get(m) or math.inf, m))


def model_title(results, model):
    """The model's name and size, the size of the builds drawn (the newest run's, as build_table takes them)."""
    sizes = sorted({b.n_points for (m, _), b in drawn_builds(results).items() if m == model and b.n_points})
    return model.replace("_", " ") + (f" ({' / '.join(f'{n:,.0f}' for n in sizes)} points)" if sizes else "")


def draw_model(ax, results, model, table, adapters):
    """Sorted horizontal bars with their values; adapters not built on this model get a labelled gap."""
    built = sorted((table[(model, a)], a) for a in adapters if (model, a) in table)
    missing = [a for a in adapters if (model, a) not in table]
    names = [a for _, a in built] + missing
    ys = np.arange(len(names))[::-1]
    low = min(t for t, _ in built) if built else 1e-3
    for y, (seconds, adapter) in zip(ys, built):
        colour = style.adapter_colour(adapter, results)
        hollow = style.is_approximate(adapter, results)
        ax.barh(y, seconds, color="white" if hollow else colour, edgecolor=colour, hatch="///" if hollow else None,
                left=0)
        ax.text(seconds, y, f" {seconds:.3g}", va="center", fontsize=9)
    for y, adapter in zip(ys[len(built):], missing):
        reason = results.build_skips.get((model, adapter))
        ax.text(low / 1.8, y, "not built" + (": over a budget" if reason and "budget" in reason else
                                        ": skipped" if reason else ": no record"),
                va="center", fontsize=9, color="#b00020", style="italic")
    ax.set_yticks(ys, [style.short_label(a, results) for a in names])
    ax.set_xscale("log")
    if built:
        ax.set_xlim(low / 2, max(t for t, _ in built) * 12)
    ax.set_title(model_title(results, model), fontsize=10)
    ax.set_xlabel("build time (s), log")
    ax.grid(axis="y", visible=False)


def fig4(results, out_dir):
    table = build_table(results)
    if not table:
        warn("fig4: no build records: figure skipped")
        return None
    models = model_order(results, {m for m, _ in table})
    adapters = sorted({a for _, a in table})
    rows = math.ceil(len(models) / COLUMNS)
    height = 0.19 * len(adapters) + 1.1
    fig, axes = plt.subplots(rows, min(COLUMNS, len(models)), figsize=(style.PAGE_WIDTH_IN, rows * height + 0.8),
                             squeeze=False)
    for ax, model in zip(axes.flat, models):
        draw_model(ax, results, model, table, adapters)
    for ax in list(axes.flat)[len(models):]:
        ax.axis("off")
    fig.suptitle("Figure 4: construction time per model cloud, fastest first (newest run of each; "
                 "hollow grey: approximate)", y=1.0)
    fig.tight_layout()
    return style.save(fig, out_dir, "fig4_construction")
