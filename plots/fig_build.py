"""Figure 4: construction time per data structure and model cloud, y axis split linear (low) + log (high)."""
import math
from statistics import mean

import numpy as np

import style
from results_io import SHAPES, warn

plt = style.plt


def _nice_ceil(x):
    """Smallest of 1, 2, 5 x 10^n that is >= x."""
    exp = math.floor(math.log10(x))
    for m in (1, 2, 5, 10):
        if m * 10 ** exp >= x:
            return m * 10 ** exp
    return 10 ** (exp + 1)


def build_table(results):
    """{(model, adapter): mean build seconds} over every build record."""
    times = {}
    for b in results.builds:
        times.setdefault((b.model, b.adapter), []).append(b.build_seconds)
    return {k: mean(v) for k, v in times.items()}


def fig4(results, out_dir):
    table = build_table(results)
    if not table:
        warn("fig4: no build records: figure skipped")
        return None
    models = sorted({m for m, _ in table}, key=lambda m: (SHAPES.index(m) if m in SHAPES else 99, m))
    adapters = sorted({a for _, a in table})
    values = np.array(list(table.values()))
    split = _nice_ceil(float(np.percentile(values, 75)) * 1.2)
    top_max = max(float(values.max()) * 2, split * 10)
    fig, (ax_log, ax_lin) = plt.subplots(2, 1, sharex=True, figsize=(max(8, 1.2 * len(models) * len(adapters) / 3), 7),
                                         gridspec_kw={"height_ratios": [1, 2], "hspace": 0.06})
    width = 0.8 / len(adapters)
    for i, adapter in enumerate(adapters):
        xs = [j + (i - (len(adapters) - 1) / 2) * width for j, m in enumerate(models) if (m, adapter) in table]
        ys = [table[(m, adapter)] for m in models if (m, adapter) in table]
        colour, _ = style.adapter_style(adapter)
        ax_lin.bar(xs, ys, width, color=colour, label=style.library_label(adapter, results))
        high = [(x, y) for x, y in zip(xs, ys) if y > split]
        if high:
            ax_log.bar([x for x, _ in high], [y - split for _, y in high], width, bottom=split, color=colour)
    ax_lin.set_ylim(0, split)
    ax_log.set_yscale("log")
    ax_log.set_ylim(split, top_max)
    ax_log.spines["bottom"].set_visible(False)
    ax_lin.spines["top"].set_visible(False)
    ax_log.tick_params(axis="x", bottom=False)
    for ax, y in ((ax_log, 0), (ax_lin, 1)):  # the usual diagonal marks of a broken axis
        ax.plot([0, 1], [y, y], transform=ax.transAxes, color="k", linestyle=(0, (4, 3)), clip_on=False, lw=0.8)
    ax_lin.set_xticks(range(len(models)), [m.replace("_", " ") for m in models], rotation=20, ha="right")
    ax_lin.set_ylabel(f"build time (s), linear to {split:g}")
    ax_log.set_ylabel("build time (s), log")
    ax_log.set_title("Construction time per data structure and model cloud (mean over records)")
    ax_lin.set_xlabel("model cloud")
    ax_lin.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), ncol=3, frameon=False)
    return style.save(fig, out_dir, "fig4_construction")
