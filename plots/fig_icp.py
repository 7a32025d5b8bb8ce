"""Figures 2 and 5: ICP time (search + estimation, construction excluded)."""
from statistics import median

import numpy as np

import style
from results_io import warn

plt = style.plt
BEST_COUNT = 5


def is_bucket_run(run):
    if run.experiment:  # run_icp names its experiment: icp_bucket (or a variant such as icp_bucket_coarse), icp_real
        return run.experiment.startswith("icp_bucket")
    return run.bucket_size is not None


def icp_label(adapter, search, results):
    info = results.adapter_info(adapter)
    kind = f" — {search}" if search else ""
    strategy = info.get(search) if search else None
    if strategy and strategy != "native":
        kind += " " + style.STRATEGY_TEXT.get(strategy, strategy)
    return style.library_label(adapter, results) + kind


def bucket_curves(results):
    """{pair: {(adapter, search): {bucket_size: median icp seconds}}}."""
    curves = {}
    for run in results.icp:
        if is_bucket_run(run) and run.bucket_size is not None:
            curves.setdefault(run.pair, {}).setdefault((run.adapter, run.search), {}) \
                  .setdefault(run.bucket_size, []).append(run.icp_seconds)
    return {p: {k: {b: median(v) for b, v in c.items()} for k, c in s.items()} for p, s in curves.items()}


def fig2(results, out_dir):
    curves = bucket_curves(results)
    if not curves:
        warn("fig2: no ICP runs with a bucket_size: figure skipped")
        return None
    fig, axes = plt.subplots(1, len(curves), figsize=(6.5 * len(curves), 4.5), squeeze=False)
    for ax, pair in zip(axes[0], sorted(curves)):
        for (adapter, search), points in sorted(curves[pair].items(), key=lambda kv: (kv[0][0], kv[0][1] or "")):
            xs = sorted(points)
            kw = style.line_kw(adapter, search or "ranged")
            ax.plot(xs, [points[x] for x in xs], label=icp_label(adapter, search, results), **kw)
        ax.axvspan(5, 20, color="grey", alpha=0.12, label="bucket 5 to 20 (paper's optimum)")
        ax.set_xscale("log")
        sizes = sorted({b for points in curves[pair].values() for b in points})
        ax.set_xticks(sizes, [f"{b:g}" for b in sizes])
        ax.minorticks_off()
        ax.set_xlabel("bucket size (points per leaf)")
        ax.set_ylabel("ICP time (s)")
        ax.set_title(f"ICP time against bucket size: {pair}")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2, frameon=False)
    return style.save(fig, out_dir, "fig2_icp_bucket")


def real_times(results):
    """{pair: {(adapter, search): (median icp seconds, all converged or None)}}."""
    runs = {}
    for run in results.icp:
        if not is_bucket_run(run):
            runs.setdefault(run.pair, {}).setdefault((run.adapter, run.search), []).append(run)
    out = {}
    for pair, by_key in runs.items():
        out[pair] = {}
        for key, rs in by_key.items():
            flags = [r.converged for r in rs if r.converged is not None]
            out[pair][key] = (median(r.icp_seconds for r in rs), all(flags) if flags else None)
    return out


def fig5(results, out_dir):
    times = real_times(results)
    if not times:
        warn("fig5: no ICP runs on real pairs: figure skipped")
        return None
    fig, axes = plt.subplots(1, len(times), figsize=(5.5 * len(times), 4.5), squeeze=False)
    for ax, pair in zip(axes[0], sorted(times)):
        best = sorted(times[pair], key=lambda k: times[pair][k][0])[:BEST_COUNT]
        ys = np.arange(len(best))[::-1]
        for y, key in zip(ys, best):
            seconds, converged = times[pair][key]
            colour, _ = style.adapter_style(key[0])
            ax.barh(y, seconds, color=colour, hatch="//" if converged is False else None, edgecolor="white")
            ax.text(seconds, y, f" {seconds:.3g} s" + (" (not converged)" if converged is False else ""),
                    va="center", fontsize=8)
        ax.set_yticks(ys, [icp_label(a, s, results) for a, s in best])
        ax.set_xlim(0, 1.35 * max(times[pair][k][0] for k in best))
        ax.set_xlabel("ICP time (s), construction excluded")
        ax.set_title(f"{pair}: {len(best)} fastest")
    fig.tight_layout()
    return style.save(fig, out_dir, "fig5_icp_real")
