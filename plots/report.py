#!/usr/bin/env python3
"""One self-contained interactive HTML page of the results: python3 plots/report.py [FILES] --out DIR.

Plotly's JavaScript is inlined (no network at view time). The page sets data-plots-done on <body> once every
plot has rendered and collects script errors in #errors, so a headless browser can check it."""
import argparse
import html
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import fig_build  # noqa: E402
from files import write_atomically  # noqa: E402
import fig_icp  # noqa: E402
import fig_scale  # noqa: E402
import fig_speedup  # noqa: E402
import fig_sweep  # noqa: E402
import fig_threads  # noqa: E402
import findings  # noqa: E402
import provenance  # noqa: E402
from table1 import table1_lines  # noqa: E402
import results_io  # noqa: E402
import style  # noqa: E402

DASH = {"native": "solid", "emulated": "dash", "radius": "dot", "knn": "dashdot"}
LOG_LINEAR = [dict(type="buttons", direction="right", x=1.0, xanchor="right", y=1.13, showactive=True,
                   buttons=[dict(label="log", method="relayout", args=[{"yaxis.type": "log"}]),
                            dict(label="linear", method="relayout", args=[{"yaxis.type": "linear"}])])]


def trace(x, y, name, adapter, results, kind="ranged", strategy=None, group=None):
    """One line in the figures' look: colour by library, dash by strategy, hollow markers when approximate."""
    colour = style.adapter_colour(adapter, results)
    symbol = {"o": "circle", "s": "square", "D": "diamond", "^": "triangle-up", "X": "x"}.get(
        style.adapter_marker(adapter), "circle")
    if style.is_approximate(adapter, results):
        symbol += "-open"
    return dict(type="scatter", mode="lines+markers", x=list(x), y=list(y), name=name, legendgroup=group or adapter,
                line=dict(color=colour, dash=DASH[style.strategy_class(kind, strategy)], width=1.6),
                marker=dict(symbol=symbol, size=5, color=colour))


def figure(traces, title, xtitle, ytitle, log_y=True, log_x=False, buttons=True, height=520):
    layout = dict(title=dict(text=title, font=dict(size=14)), height=height, hovermode="closest",
                  xaxis=dict(title=xtitle, type="log" if log_x else "linear"),
                  yaxis=dict(title=ytitle, type="log" if log_y else "linear"),
                  legend=dict(font=dict(size=11)), margin=dict(t=70))
    if buttons:
        layout["updatemenus"] = LOG_LINEAR
    return dict(data=traces, layout=layout)


def sweep_figure(results, model, query, title):
    series = results_io.sweep_series(results, model, query)
    dists = fig_sweep._panel_distances(series)
    traces = []
    for (adapter, kind), cells in sorted(series.items()):
        xs, ys = fig_sweep.series_xy(cells, dists)
        ys = [None if y != y else y for y in ys]
        if any(y is not None for y in ys):
            traces.append(trace(xs, ys, style.series_label(adapter, kind, cells[0].strategy, results), adapter,
                                results, kind, cells[0].strategy))
    return figure(traces, title, "maximal distance (m)", "time for all queries (s)")


def strategies_figure(results, model, query):
    """Every ranged strategy of every adapter run with more than one: a trace per (adapter, strategy)."""
    shown = fig_sweep.ranged_strategies(results, model, query)
    dists = fig_sweep._panel_distances({k: v for a in shown for k, v in shown[a].items()})
    traces = []
    for adapter in sorted(shown, key=lambda a: (style.family(a), a)):
        for strategy, cells in sorted(shown[adapter].items()):
            xs, ys = fig_sweep.series_xy(cells, dists)
            ys = [None if y != y else y for y in ys]
            if any(y is not None for y in ys):
                traces.append(trace(xs, ys, style.series_label(adapter, "ranged", strategy, results), adapter,
                                    results, "ranged", strategy, group=adapter))
    return figure(traces, "every ranged strategy, by adapter (click a legend entry to hide it)",
                  "maximal distance (m)", "time for all queries (s)")


def build_figure(results):
    table = fig_build.build_table(results)
    models = fig_build.model_order(results, {m for m, _ in table})
    traces = []
    for adapter in sorted({a for _, a in table}, key=lambda a: (style.family(a), a)):
        ms = [m for m in models if (m, adapter) in table]
        traces.append(dict(type="bar", x=ms, y=[table[(m, adapter)] for m in ms], name=adapter,
                           marker=dict(color=style.adapter_colour(adapter, results))))
    fig = figure(traces, "Construction time per model cloud (newest run of each)", "model cloud", "build time (s)")
    fig["layout"]["barmode"] = "group"
    return fig


def icp_figure(results):
    times = fig_icp.real_times(results)
    traces = []
    adapters = sorted({a for by in times.values() for a in by}, key=lambda a: (style.family(a), a))
    pairs = sorted(times)
    for adapter in adapters:
        keys = [(p, adapter) for p in pairs if adapter in times[p]]
        traces.append(dict(type="bar", x=[p for p, _ in keys], y=[times[p][k][0] for p, k in keys],
                           name=style.short_label(adapter, results),
                           marker=dict(color=style.adapter_colour(adapter, results)),
                           hovertext=[("not converged" if times[p][k][1] is False else "converged")
                                      + fig_icp.bucket_text(times[p][k][2]) for p, k in keys]))
    fig = figure(traces, "ICP time on the real pairs (search + estimation)", "pair", "ICP time (s)")
    fig["layout"]["barmode"] = "group"
    return fig


def bucket_figure(results):
    traces = []
    for pair, curves in sorted(fig_icp.bucket_curves(results).items()):
        for adapter, points in sorted(curves.items()):
            xs = sorted(points)
            traces.append(trace(xs, [points[x] for x in xs], f"{pair}: {adapter}", adapter, results,
                                "ranged", results.adapter_info(adapter).get("ranged")))
    return figure(traces, "ICP time against bucket size", "bucket size (points per leaf)", "ICP time (s)",
                  log_x=True)


def scale_figures(results):
    key, table = fig_scale.scale_table(results)
    if key is None:
        return []
    out = []
    for part, ytitle, factor in (("query", "time per query (µs)", 1e6), ("build", "build time (s)", 1.0),
                                 ("memory", "index bytes per model point (B)", 1.0)):
        traces = [trace([n for n, _ in row[part]], [t * factor for _, t in row[part]], a, a, results)
                  for a, row in sorted(table.items()) if row.get(part)]
        out.append(figure(traces, f"Scale: {ytitle} against the model size", "model points n", ytitle, log_x=True))
    return out


def speedup_figures(results):
    out = []
    for title, ratios in fig_speedup.speedup_panels(results):
        traces = [trace(*zip(*sorted(points)), a, a, results, "ranged", results.adapter_info(a).get("ranged"))
                  for a, points in sorted(ratios.items())]
        out.append(figure(traces, f"Speed-up over the faster nanoflann: {title}", "maximal distance (m)",
                          "faster nanoflann time / adapter time (x)"))
    return out


def threads_figures(results):
    out = []
    for title, rates in fig_threads.panels(results):
        traces = [trace(*zip(*sorted((t, r / 1e6) for t, r in by_threads.items())), a, a, results, "ranged",
                        results.adapter_info(a).get("ranged")) for a, by_threads in sorted(rates.items())]
        out.append(figure(traces, f"Throughput against threads: {title}", "threads", "million queries per second",
                          log_y=False, buttons=False))
    return out


def all_figures(results):
    """[(section, [figure])] for every figure the results allow."""
    sections = []
    model, query = fig_sweep.FIG3
    if results_io.sweep_series(results, model, query):
        figs = [sweep_figure(results, model, query, "hollow cube queries, hollow sphere model")]
        if fig_sweep.ranged_strategies(results, model, query):
            figs.append(strategies_figure(results, model, query))
        sections.append(("Figure 3: the paper's pair", figs))
    grid = [sweep_figure(results, m, q, f"model {m}, query {q}") for m in results_io.SHAPES
            for q in results_io.SHAPES if results_io.sweep_series(results, m, q) and (m, q) != fig_sweep.FIG3]
    if grid:
        sections.append(("Figures 6 and 7: the 4 x 4 grid, every series", grid))
    if results.builds:
        sections.append(("Figure 4: construction", [build_figure(results)]))
    if fig_icp.real_times(results):
        sections.append(("Figure 5: ICP on real pairs", [icp_figure(results)]))
    if fig_icp.bucket_curves(results):
        sections.append(("Figure 2: ICP against bucket size", [bucket_figure(results)]))
    for title, figs in (("Figure 8: scale", scale_figures(results)),
                        ("Figure 9: speed-up over the faster nanoflann", speedup_figures(results)),
                        ("Figure 10: throughput against threads", threads_figures(results))):
        if figs:
            sections.append((title, figs))
    return sections


def md_table_html(lines):
    """A markdown table (list of '| a | b |' lines) as HTML."""
    rows = [[c.strip() for c in line.strip().strip("|").split("|")] for line in lines if line.startswith("|")]
    if not rows:
        return ""
    head, body = rows[0], rows[2:]
    cell = lambda c: html.escape(c).replace("\\|", "|")  # noqa: E731
    return ("<table><tr>" + "".join(f"<th>{cell(c)}</th>" for c in head) + "</tr>"
            + "".join("<tr>" + "".join(f"<td>{cell(c)}</td>" for c in r) + "</tr>" for r in body) + "</table>")


def provenance_html(results, check=None):
    check = check or provenance.Check(results, True, True, "newest")
    lines = "".join(f"<li>{html.escape(line)}</li>" for line in check.lines)
    rows = ["| file | experiment | date | host | CPUs | load at start | build | git commit |", "|---|---|---|---|---|---|---|---|"]
    for path, ctx in results.files:
        load = ctx.get("load_avg")
        rows.append(f"| {results_io.display_path(path)} | {ctx.get('experiment', '?')} | {ctx.get('date', '?')} | "
                    f"{ctx.get('host_name', '?')} | {ctx.get('num_cpus', '?')} x {ctx.get('mhz_per_cpu', '?')} MHz | "
                    f"{', '.join(f'{x:.2f}' for x in load) if isinstance(load, list) else '?'} | "
                    f"{ctx.get('build_type', ctx.get('library_build_type', '?'))} | {ctx.get('git_commit') or '?'} |")
    return md_table_html(rows) + f"<ul>{lines}</ul>"


def findings_html(results):
    parts = []
    for v in findings.evaluate(results, 0.1):
        items = "".join(f"<li>{html.escape(n)}</li>" for n in v.numbers[:12])
        more = f"<li>... and {len(v.numbers) - 12} more</li>" if len(v.numbers) > 12 else ""
        parts.append(f"<h3>{v.number}. {html.escape(v.claim)}: <b>{html.escape(v.verdict)}</b></h3>"
                     f"<p class=rule>Rule: {html.escape(v.rule)}</p><ul>{items}{more}</ul>")
    return "".join(parts)


def adapter_html(results, name):
    info = results.adapter_info(name)
    fields = "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(str(v))}</td></tr>" for k, v in sorted(info.items()))
    builds = sorted((b.model, b.build_seconds) for b in results_io.latest_builds(results).values() if b.adapter == name)
    icp = {pair: by[name][0] for pair, by in fig_icp.real_times(results).items() if name in by}
    text = "".join(f"<li>build on {html.escape(m)}: {s:.4g} s</li>" for m, s in builds)
    text += "".join(f"<li>ICP on {html.escape(p)}: {t:.3g} s</li>" for p, t in sorted(icp.items()))
    return (f"<section id='adapter-{html.escape(name)}'><h3>{html.escape(name)}"
            f"{' (approximate)' if style.is_approximate(name, results) else ''}</h3>"
            f"<table class=kv>{fields}</table><ul>{text}</ul></section>")


SCRIPT = """
window.__errors = [];
function noteError(msg) { document.getElementById('errors').textContent += msg + '\\n'; }
window.onerror = function (msg, src, line) { noteError('error: ' + msg + ' at ' + src + ':' + line); };
window.addEventListener('unhandledrejection', function (e) { noteError('rejection: ' + e.reason); });
var origError = console.error;
console.error = function () { noteError('console.error: ' + Array.from(arguments).join(' ')); origError.apply(console, arguments); };
document.addEventListener('DOMContentLoaded', function () {
  var figs = JSON.parse(document.getElementById('figures').textContent);
  var done = figs.map(function (f, i) {
    return Plotly.newPlot('plot-' + i, f.data, f.layout, {responsive: true});
  });
  Promise.all(done).then(function () {
    document.body.setAttribute('data-plots-done', String(done.length));
  }, function (e) { noteError('plot failed: ' + e); });
});
"""

CSS = """#provenance-warning{color:#b00020}body{font-family:sans-serif;max-width:1400px;margin:auto;padding:0 1em;color:#222}
table{border-collapse:collapse;font-size:13px;margin:0.5em 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}
.plot{width:100%;min-height:520px}.rule{color:#555;font-size:13px}#errors{color:#b00020}
nav a{margin-right:1em}details{margin:0.5em 0}"""


def warning_html(check):
    return f"<p id=provenance-warning><b>{html.escape(check.banner())}</b></p>" if check and check.marks else ""


def render(results, plotly_js, check=None):
    sections = all_figures(results)
    figs, body = [], []
    for title, section_figs in sections:
        body.append(f"<h2>{html.escape(title)}</h2>")
        for fig in section_figs:
            body.append(f"<div class=plot id='plot-{len(figs)}'></div>")
            figs.append(fig)
    table1 = md_table_html(table1_lines(results)) if results.adapters else "<p>no adapter metadata</p>"
    adapters = "".join(adapter_html(results, a) for a in sorted(results.adapters))
    nav = "".join(f"<a href='#{s}'>{s}</a>" for s in ("figures", "table1", "findings", "machine", "adapters"))
    return f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>nns-bench report</title>
<style>{CSS}</style><script>{plotly_js}</script><script>{SCRIPT}</script></head><body>
<h1>nns-bench: nearest-neighbour search for 3D registration</h1>
<p>Every plot: click a legend entry to hide a series, double-click to isolate it, hover for values;
the log / linear buttons switch the time axis.</p>{warning_html(check)}<nav>{nav}</nav><pre id="errors"></pre>
<div id="plots">{''.join(body)}</div>
<h2 id="table1">Table 1: libraries and how each search kind is answered</h2>{table1}
<h2 id="findings">The paper's claims against these results</h2>{findings_html(results)}
<h2 id="machine">Machine and provenance of each input file</h2>{provenance_html(results, check)}
<h2 id="adapters">Adapters</h2>{adapters}
<script type="application/json" id="figures">{figures_json(figs)}</script>
</body></html>"""


def figures_json(figs):
    """The figures as JSON safe inside a <script> element."""
    return json.dumps(figs).replace("</", "<\\/")


def plotly_js():
    """Plotly's JavaScript from the installed python package (Debian's python3-plotly ships it unminified)."""
    from plotly.offline import get_plotlyjs
    return get_plotlyjs()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("results", nargs="*", type=Path, help="results files (default: as make_figures.py)")
    parser.add_argument("--out", type=Path, default=results_io.REPO_ROOT / "results" / "figures",
                        help="output directory; the page is DIR/report.html")
    provenance.add_arguments(parser)
    args = parser.parse_args(argv)
    paths = args.results or results_io.default_inputs()
    results = results_io.load(paths, prefer=args.prefer)
    if not results.files:
        print("report: no results file could be read", file=sys.stderr)
        return 2
    check = provenance.check_or_exit(results, args, "report")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "report.html"
    write_atomically(path, render(results, plotly_js(), check))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
