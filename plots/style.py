"""One look for every figure: colour by library, marker by data structure, line style by strategy.

Approximate adapters are drawn grey with hollow markers and labelled so; figures are at most MAX_WIDTH_PX wide.
"""
import math
import zlib

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)
from PIL import Image  # noqa: E402  (matplotlib depends on Pillow)

from files import written_atomically  # noqa: E402

MAX_WIDTH_PX = 1600
DPI = 110
PAGE_WIDTH_IN = 14.0  # 1540 px at DPI: room for the tight bounding box

# One colour per library (the prefix of the adapter's name), well apart in hue and lightness.
LIBRARY_COLOUR = {
    "ours": "#0b5cad",
    "nanoflann": "#2ca02c",
    "open3d": "#e69f00",
    "flann": "#d62728",
    "pcl": "#8c564b",
    "ann": "#9467bd",
    "cgal": "#e377c2",
    "spatialindex": "#17a2b8",
    "brute": "#222222",
}
LIBRARY_NAME = {"ours": "ours", "nanoflann": "nanoflann", "open3d": "Open3D", "flann": "FLANN", "pcl": "PCL",
                "ann": "ANN", "cgal": "CGAL", "spatialindex": "libspatialindex", "brute": "brute force"}
APPROX_COLOUR = "#8a8a8a"
FALLBACK_COLOURS = ("#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd", "#e6550d", "#31a354", "#756bb1")
# Marker by data structure (the rest of the name), so two structures of one library stay apart.
STRUCTURE_MARKER = {"kdtree": "o", "octree": "s", "octree_approx": "s", "rstar": "D", "quadratic": "^",
                    "force": "X"}
FALLBACK_MARKERS = ("P", "v", "<", ">", "h", "*", "p", "d")

# Line style by how a series is answered: ranged native, ranged emulated, fixed radius, k-NN.
STRATEGY_LINESTYLE = {"native": "-", "emulated": (0, (5, 2)), "radius": (0, (1.2, 1.6)), "knn": (0, (6, 2, 1.2, 2))}
STRATEGY_LEGEND = {"native": "ranged, the library's own call", "emulated": "ranged, emulated (via k-NN / radius / box)",
                   "radius": "fixed radius", "knn": "k-NN (flat: no distance limit)"}
KIND_TEXT = {"ranged": "ranged", "radius": "radius", "knn": "k-NN"}
STRATEGY_TEXT = {"native": "native", "native_unpruned": "native, unpruned", "via_knn": "via k-NN",
                 "via_radius": "via radius", "via_box": "via box"}
LIBRARY_STRATEGIES = ("native", "native_unpruned")  # the library's own ranged call
SKIP_MARKER = dict(marker="x", markersize=9, markeredgewidth=2.2, linestyle="none", zorder=5)


def setup():
    """Fonts of at least 9 pt at the saved size."""
    plt.rcParams.update({"font.size": 10, "axes.titlesize": 11, "axes.labelsize": 10, "legend.fontsize": 9,
                         "xtick.labelsize": 9, "ytick.labelsize": 9, "axes.grid": True, "grid.alpha": 0.3,
                         "svg.hashsalt": "nnb", "savefig.dpi": DPI, "figure.titlesize": 12})


def log_y(ax):
    """Log y axis whose minor ticks are labelled too when it spans under two decades."""
    ax.set_yscale("log")
    ax.yaxis.set_minor_formatter(matplotlib.ticker.LogFormatterSciNotation(labelOnlyBase=False,
                                                                           minor_thresholds=(2, 0.5)))


def family(adapter):
    """The library part of an adapter's name: 'pcl' for pcl_octree_approx."""
    return adapter.split("_", 1)[0]


def structure(adapter):
    return adapter.split("_", 1)[1] if "_" in adapter else adapter


def is_approximate(adapter, results=None):
    """Declared approximate (exact: false), or named so when the results carry no metadata."""
    info = results.adapter_info(adapter) if results is not None else {}
    if isinstance(info.get("exact"), bool):
        return not info["exact"]
    return "approx" in adapter


def adapter_colour(adapter, results=None):
    if is_approximate(adapter, results):
        return APPROX_COLOUR
    if family(adapter) in LIBRARY_COLOUR:
        return LIBRARY_COLOUR[family(adapter)]
    return FALLBACK_COLOURS[zlib.crc32(family(adapter).encode()) % len(FALLBACK_COLOURS)]


def adapter_marker(adapter):
    if structure(adapter) in STRUCTURE_MARKER:
        return STRUCTURE_MARKER[structure(adapter)]
    return FALLBACK_MARKERS[zlib.crc32(adapter.encode()) % len(FALLBACK_MARKERS)]


def adapter_style(adapter, results=None):
    """(colour, marker) for an adapter; unknown names get a fixed choice derived from the name."""
    return adapter_colour(adapter, results), adapter_marker(adapter)


def marker_kw(adapter, results=None, size=5):
    """Marker colour and fill: hollow for approximate adapters."""
    colour, marker = adapter_style(adapter, results)
    face = "white" if is_approximate(adapter, results) else colour
    return dict(color=colour, marker=marker, markersize=size, markerfacecolor=face, markeredgecolor=colour)


def strategy_class(kind, strategy):
    """native / emulated / radius / knn: the four line styles."""
    if kind in ("radius", "knn"):
        return kind
    return "native" if strategy in (None, "?") + LIBRARY_STRATEGIES else "emulated"


def line_kw(adapter, kind, strategy=None, results=None):
    kw = marker_kw(adapter, results, size=4)
    kw.update(linestyle=STRATEGY_LINESTYLE[strategy_class(kind, strategy)], linewidth=1.5)
    return kw


def library_label(adapter, results):
    """"FLANN k-d tree", from the adapters' metadata; the registry name when it is ambiguous; approximate said."""
    info = results.adapter_info(adapter)
    if not info.get("library"):
        text = adapter
    else:
        text = info["library"] + (" " + info["structure"] if info.get("structure") else "")
        twins = [a for a, i in results.adapters.items() if a != adapter and i.get("library") == info.get("library")
                 and i.get("structure") == info.get("structure")]
        text = f"{text} ({adapter})" if twins else text
    if is_approximate(adapter, results) and "approx" not in text:
        text += " (approximate)"
    return text


def short_label(adapter, results=None):
    """The registry name, marked when approximate: for crowded axes."""
    return adapter + (" (approx.)" if is_approximate(adapter, results) and "approx" not in adapter else "")


def series_label(adapter, kind, strategy, results):
    """E.g. "nanoflann k-d tree — ranged native", "FLANN k-d tree — radius"."""
    text = KIND_TEXT.get(kind, kind)
    if kind == "ranged" or strategy not in (None, "native", "?"):
        text += " " + STRATEGY_TEXT.get(strategy, strategy or "")
    return f"{library_label(adapter, results)} — {text.strip()}"


def adapter_handles(adapters, results):
    """Legend entries, one per adapter: colour and marker, no line."""
    return [plt.Line2D([], [], linestyle="none", label=short_label(a, results), **marker_kw(a, results, size=7))
            for a in adapters]


def strategy_handles(classes):
    """Legend entries, one per line style used."""
    return [plt.Line2D([], [], color="black", linewidth=1.5, linestyle=STRATEGY_LINESTYLE[c],
                       label=STRATEGY_LEGEND[c]) for c in STRATEGY_LINESTYLE if c in classes]


def skip_handle():
    return plt.Line2D([], [], color="black", label="last cell before the skipped ones (over budget)",
                      **SKIP_MARKER)


def legends_in(ax, adapters, classes, results, ncol=4, skip=True):
    """Adapters (colour, marker) and line styles (strategy) as two legends filling an axis of their own: side by
    side, or the line styles in a row below the adapters when the adapters' columns reach across to them."""
    ax.axis("off")
    first = ax.legend(handles=adapter_handles(adapters, results), loc="upper left", ncol=ncol, frameon=False,
                      title="adapter (colour: library, marker: structure)", alignment="left")
    ax.add_artist(first)
    first.set_clip_on(False)  # an added artist is clipped to the axis: a long list would lose its last rows
    extra = strategy_handles(classes) + ([skip_handle()] if skip else [])
    if not extra:
        return
    title = "line style: how the search is answered"
    styles = ax.legend(handles=extra, loc="upper right", ncol=1, frameon=False, alignment="left", title=title)
    renderer = ax.figure.canvas.get_renderer()
    adapters_box = first.get_window_extent(renderer)
    if adapters_box.x1 > styles.get_window_extent(renderer).x0:
        below_y = adapters_box.transformed(ax.transAxes.inverted()).y0
        styles = ax.legend(handles=extra, loc="upper left", bbox_to_anchor=(0, below_y), ncol=min(len(extra), 3),
                           frameon=False, alignment="left", title=title)
        styles.set_clip_on(False)


def ranged_panels_figure(results, panels, draw, cols, panel_height, title, title_y):
    """A figure of panels [(panel title, {adapter: data})], each drawn by draw(ax, results, panel title, data), in
    rows of cols, with one legend row of every adapter and ranged strategy drawn below them."""
    cols = min(cols, len(panels))
    rows = math.ceil(len(panels) / cols)
    fig = plt.figure(figsize=(PAGE_WIDTH_IN, panel_height * rows + 1.5))
    grid_spec = fig.add_gridspec(rows + 1, cols, height_ratios=[panel_height] * rows + [1.2], hspace=0.5, wspace=0.22)
    adapters, classes = set(), set()
    for i, (panel_title, data) in enumerate(panels):
        draw(fig.add_subplot(grid_spec[i // cols, i % cols]), results, panel_title, data)
        adapters |= set(data)
        classes |= {strategy_class("ranged", results.adapter_info(a).get("ranged")) for a in data}
    fig.suptitle(title, y=title_y)
    legends_in(fig.add_subplot(grid_spec[rows, :]), sorted(adapters, key=lambda a: (family(a), a)), classes, results,
               skip=False)
    return fig


# Set by make_figures.py when its inputs are not a clean run: written across the top of every figure.
WARNING = ""


def save_png(fig, path):
    fig.savefig(path, bbox_inches="tight", dpi=DPI)
    width = Image.open(path).size[0]
    if width > MAX_WIDTH_PX:  # a long label widened the tight box: shrink rather than overflow a page
        fig.savefig(path, bbox_inches="tight", dpi=DPI * MAX_WIDTH_PX / width * 0.99)


def save(fig, out_dir, stem):
    """Writes stem.png (at most MAX_WIDTH_PX wide) and stem.svg; returns the png path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    if WARNING:
        fig.text(0.5, 1.0, WARNING, ha="center", va="bottom", color="#b00020", fontsize=9, fontweight="bold",
                 wrap=True)
    png = out_dir / f"{stem}.png"
    written_atomically(png, lambda tmp: save_png(fig, tmp))
    written_atomically(out_dir / f"{stem}.svg", lambda tmp: fig.savefig(tmp, bbox_inches="tight",
                                                                        metadata={"Date": None}))
    plt.close(fig)
    print(f"wrote {png} (+ .svg)")
    return png
