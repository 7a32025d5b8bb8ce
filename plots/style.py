"""One look for every figure: colour and marker per adapter, line style per search kind, legend labels."""
import zlib

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

# Fixed table so an adapter looks the same in every figure and every run.
ADAPTER_STYLE = {
    "ours_kdtree": ("#1f77b4", "o"),
    "ours_octree": ("#ff7f0e", "s"),
    "nanoflann_kdtree": ("#2ca02c", "^"),
    "flann_kdtree": ("#d62728", "v"),
    "ann_kdtree": ("#9467bd", "D"),
    "cgal_kdtree": ("#8c564b", "P"),
    "spatialindex_rtree": ("#e377c2", "X"),
    "spatialindex_rstar": ("#e377c2", "X"),
    "spatialindex_linear": ("#f7b6d2", "*"),
    "spatialindex_quadratic": ("#c51b7d", "p"),
    "pcl_kdtree": ("#bcbd22", "<"),
    "pcl_octree": ("#17becf", ">"),
    "pcl_octree_approx": ("#9edae5", ">"),
    "open3d_kdtree": ("#393b79", "h"),
    "brute_force": ("#7f7f7f", "."),
}
FALLBACK_COLOURS = ("#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd", "#e6550d", "#31a354", "#756bb1",
                    "#636363", "#6baed6", "#fd8d3c", "#74c476", "#9e9ac8", "#969696")
FALLBACK_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "<", ">", "h", "*", "p")
KIND_LINESTYLE = {"ranged": "-", "radius": "--", "knn": ":"}
KIND_TEXT = {"ranged": "ranged", "radius": "radius", "knn": "k-NN"}
STRATEGY_TEXT = {"native": "native", "via_knn": "via k-NN", "via_radius": "via radius", "via_box": "via box"}
SKIP_MARKER = dict(marker="x", markersize=9, markeredgewidth=2.2, linestyle="none", zorder=5)


def setup():
    """Readable defaults for every figure."""
    plt.rcParams.update({"font.size": 10, "axes.titlesize": 10, "axes.labelsize": 10, "legend.fontsize": 8,
                         "xtick.labelsize": 9, "ytick.labelsize": 9, "axes.grid": True, "grid.alpha": 0.3,
                         "svg.hashsalt": "nnb", "savefig.dpi": 110})


def log_y(ax):
    """Log y axis whose minor ticks are labelled too when it spans under two decades."""
    ax.set_yscale("log")
    ax.yaxis.set_minor_formatter(matplotlib.ticker.LogFormatterSciNotation(labelOnlyBase=False,
                                                                           minor_thresholds=(2, 0.5)))


def adapter_style(name):
    """(colour, marker) for an adapter; unknown names get a fixed choice derived from the name."""
    if name in ADAPTER_STYLE:
        return ADAPTER_STYLE[name]
    if name.startswith("spatialindex_"):
        return ADAPTER_STYLE["spatialindex_rtree"]
    h = zlib.crc32(name.encode())
    return FALLBACK_COLOURS[h % len(FALLBACK_COLOURS)], FALLBACK_MARKERS[(h // 7) % len(FALLBACK_MARKERS)]


def line_kw(adapter, kind):
    colour, marker = adapter_style(adapter)
    return dict(color=colour, marker=marker, linestyle=KIND_LINESTYLE.get(kind, "-."), markersize=4,
                linewidth=1.4)


def library_label(adapter, results):
    """"FLANN k-d tree", from the adapters' metadata; the registry name is added when it is ambiguous."""
    info = results.adapter_info(adapter)
    if not info.get("library"):
        return adapter
    text = info["library"] + (" " + info["structure"] if info.get("structure") else "")
    twins = [a for a, i in results.adapters.items()
             if a != adapter and i.get("library") == info.get("library") and i.get("structure") == info.get("structure")]
    return f"{text} ({adapter})" if twins else text


def series_label(adapter, kind, strategy, results):
    """E.g. "nanoflann k-d tree — ranged native", "FLANN k-d tree — radius"."""
    text = KIND_TEXT.get(kind, kind)
    if kind == "ranged" or strategy not in (None, "native", "?"):
        text += " " + STRATEGY_TEXT.get(strategy, strategy or "")
    return f"{library_label(adapter, results)} — {text.strip()}"


def save(fig, out_dir, stem):
    """Writes stem.png and stem.svg; returns the png path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    png = out_dir / f"{stem}.png"
    fig.savefig(png, bbox_inches="tight")
    fig.savefig(out_dir / f"{stem}.svg", bbox_inches="tight", metadata={"Date": None})
    plt.close(fig)
    print(f"wrote {png} (+ .svg)")
    return png
