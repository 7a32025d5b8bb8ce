"""Figures 2 and 5: ICP time (search + estimation, construction excluded)."""
from statistics import median

import numpy as np

import style
from results_io import warn

plt = style.plt
BEST_COUNT = 5
# The speed-up baseline: the faster of Debian's nanoflann and the newest, the tree people use (per pair).
NANOFLANNS = ("nanoflann_kdtree", "nanoflann_latest")


def is_bucket_run(run):
    if run.experiment:  # run_icp names its experiment: icp_bucket (or a variant such as icp_bucket_coarse), icp_real
        return run.experiment.startswith("icp_bucket")
    return run.bucket_size is not None


def is_accuracy_run(run):
    """run_icp's accuracy experiments (icp_accuracy) measure the final pose; no figure of time draws them."""
    return bool(run.experiment) and run.experiment.startswith("icp_accuracy")


def icp_label(adapter, results):
    """ICP searches ranged 1-NN: the label says how the adapter answers it when not natively."""
    strategy = results.adapter_info(adapter).get("ranged")
    kind = f" — {style.STRATEGY_TEXT.get(strategy, strategy)}" if strategy and strategy != "native" else ""
    return style.library_label(adapter, results) + kind


def bucket_curves(results):
    """{pair: {adapter: {bucket_size: median icp seconds}}}."""
    curves = {}
    for run in results.icp:
        if is_bucket_run(run) and run.bucket_size is not None:
            curves.setdefault(run.pair, {}).setdefault(run.adapter, {}) \
                  .setdefault(run.bucket_size, []).append(run.icp_seconds)
    return {p: {k: {b: median(v) for b, v in c.items()} for k, c in s.items()} for p, s in curves.items()}


def curve_threads(results, pair, adapter):
    """The most threads an adapter's bucket curve ran on (1 for the paper's single-threaded comparison)."""
    return max((r.threads for r in results.icp if is_bucket_run(r) and r.pair == pair and r.adapter == adapter),
               default=1)


def fig2(results, out_dir):
    curves = bucket_curves(results)
    if not curves:
        warn("fig2: no ICP runs with a bucket_size: figure skipped")
        return None
    fig, axes = plt.subplots(1, len(curves), figsize=(min(style.PAGE_WIDTH_IN, 9 * len(curves)), 5), squeeze=False)
    for ax, pair in zip(axes[0], sorted(curves)):
        for adapter, points in sorted(curves[pair].items()):
            xs = sorted(points)
            kw = style.line_kw(adapter, "ranged", results.adapter_info(adapter).get("ranged"), results)
            threads = curve_threads(results, pair, adapter)
            label = icp_label(adapter, results) + (f", {threads} threads" if threads > 1 else "")
            ax.plot(xs, [points[x] for x in xs], label=label, **kw)
        ax.axvspan(5, 20, color="grey", alpha=0.12, label="bucket 5 to 20 (paper's optimum)")
        ax.set_xscale("log")
        style.log_y(ax)  # the libraries' curves lie orders of magnitude apart: linear flattens all but the slowest
        sizes = sorted({b for points in curves[pair].values() for b in points})
        ax.set_xticks(sizes, [f"{b:g}" for b in sizes])
        ax.minorticks_off()
        ax.set_xlabel("bucket size (points per leaf)")
        ax.set_ylabel("ICP time (s)")
        ax.set_title(f"ICP time against bucket size: {pair}")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2, frameon=False)
    return style.save(fig, out_dir, "fig2_icp_bucket")


def real_times(results):
    """{pair: {adapter: (median icp seconds, all converged or None, (bucket size, its source, threads) or None)}}."""
    runs = {}
    for run in results.icp:
        if not is_bucket_run(run) and not is_accuracy_run(run):
            runs.setdefault(run.pair, {}).setdefault(run.adapter, []).append(run)
    out = {}
    for pair, by_key in runs.items():
        out[pair] = {}
        for key, rs in by_key.items():
            flags = [r.converged for r in rs if r.converged is not None]
            buckets = {(r.bucket_size, r.bucket_source, r.threads) for r in rs}
            out[pair][key] = (median(r.icp_seconds for r in rs), all(flags) if flags else None,
                              buckets.pop() if len(buckets) == 1 else None)
    return out


def ranked_pair(results, times):
    """(exact adapters fastest first, approximate adapters): approximate adapters are shown but never ranked."""
    exact = [a for a in times if not style.is_approximate(a, results)]
    return sorted(exact, key=lambda k: times[k][0]), [k for k in times if k not in exact]


def faster_nanoflann(times):
    """The faster nanoflann's name among {adapter: (seconds, ...)}, or None."""
    present = [n for n in NANOFLANNS if n in times and times[n][0]]
    return min(present, key=lambda n: times[n][0], default=None)


def nanoflann_seconds(times):
    name = faster_nanoflann(times)
    return times[name][0] if name else None


def bar_text(seconds, converged, reference):
    text = f" {seconds:.3g} s"
    if reference and seconds:
        text += f", {reference / seconds:.2f}x"
    return text + (" (not converged)" if converged is False else "")


def bucket_text(bucket):
    """The bucket size a bar ran at, and its threads when more than one: the reader sees whether each library ran at
    its best (see run_icp --buckets-from) or its default, and which searches ran on several threads."""
    size, source, threads = bucket or (None, None, 1)
    if source == "best":
        parts = [f"best bucket {size:g}"]
    elif source == "default":
        parts = ["default" if size is None else f"default bucket {size:g}"]
    else:
        parts = [f"bucket {size:g}"] if size is not None else []
    parts += [f"{threads} threads"] if threads > 1 else []
    return f" ({', '.join(parts)})" if parts else ""


def draw_pair(ax, results, pair, times):
    best, approximate = ranked_pair(results, times[pair])
    shown = best[:BEST_COUNT] + approximate
    ys = np.arange(len(shown))[::-1]
    reference = nanoflann_seconds(times[pair])
    for y, key in zip(ys, shown):
        seconds, converged, _ = times[pair][key]
        colour = style.adapter_colour(key, results)
        hollow = style.is_approximate(key, results)
        ax.barh(y, seconds, color="white" if hollow else colour, edgecolor=colour if hollow else "white",
                hatch="//" if converged is False else None)
        ax.text(seconds, y, bar_text(seconds, converged, reference), va="center", fontsize=9)
    ax.set_yticks(ys, [style.short_label(key, results) + bucket_text(times[pair][key][2])
                       + ("" if key in best else ", not ranked") for key in shown])
    ax.set_xlim(0, 2.35 * max(times[pair][k][0] for k in shown))
    ax.set_xlabel("ICP time (s), construction excluded")
    ax.set_title(f"{pair}: the {min(BEST_COUNT, len(best))} fastest exact adapters")
    ax.grid(axis="y", visible=False)


def fig5(results, out_dir):
    times = real_times(results)
    if not times:
        warn("fig5: no ICP runs on real pairs: figure skipped")
        return None
    pairs = sorted(times)
    cols = min(2, len(pairs))
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(style.PAGE_WIDTH_IN, 2.4 * rows + 1.2), squeeze=False)
    for ax, pair in zip(axes.flat, pairs):
        draw_pair(ax, results, pair, times)
    for ax in list(axes.flat)[len(pairs):]:
        ax.axis("off")
    hatch = plt.Rectangle((0, 0), 1, 1, facecolor="#cccccc", edgecolor="white", hatch="//",
                          label="did not converge within the iteration limit")
    hollow = plt.Rectangle((0, 0), 1, 1, facecolor="white", edgecolor=style.APPROX_COLOUR,
                           label="approximate adapter (shown, not ranked)")
    fig.legend(handles=[hatch, hollow], loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=2, frameon=False)
    fig.suptitle("Figure 5: ICP on the real pairs (search + estimation); ratios are the faster nanoflann's time / "
                 "the adapter's")
    fig.tight_layout()
    return style.save(fig, out_dir, "fig5_icp_real")
