#!/usr/bin/env python3
"""The README's data tables, made from the results files: python3 plots/readme_tables.py --check | --write.

Each table sits between `<!-- generated: NAME -->` and `<!-- end -->` in README.md; --write replaces the
blocks, --check exits 1 (and prints what differs) when the README's copy is not what the results give."""
import argparse
import json
import difflib
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import fig_icp  # noqa: E402
from files import write_atomically  # noqa: E402
import fig_scale  # noqa: E402
import findings  # noqa: E402
import provenance  # noqa: E402
import results_io  # noqa: E402
import style  # noqa: E402
from table1 import HEADER, adapter_lines, table1_lines  # noqa: E402

README = results_io.REPO_ROOT / "README.md"
BLOCK = re.compile(r"(<!-- generated: (?P<name>[a-z0-9_]+) -->\n)(?P<body>.*?)(<!-- end -->)", re.S)
MICRO_OURS = ("ours_kdtree", "ours_octree")
MICRO_ANCHORS = ("nanoflann_kdtree", "nanoflann_latest")
MICRO_SUBJECTS = MICRO_OURS + MICRO_ANCHORS
MICRO_PAIRS = {"fig3": "Figure 3 (hollow cube -> hollow sphere)", "sick": "office-sick-3dtk"}
MICRO_FAST_PAIRS = ("fig3", "sick", "office-sick-3dtk")
ICP_TARGET = 2.5  # micro_nns's kIcpTarget: whole ICP runs, ours against the faster nanoflann


def icp_lines(results, shown=3):
    """Per real pair: the fastest exact adapters' ICP times and the winner's speed-up over the faster nanoflann."""
    lines = ["| pair | fastest | second | third | faster nanoflann | fastest vs it |", "|---|---|---|---|---|---|"]
    for pair, times in sorted(fig_icp.real_times(results).items()):
        ranked, _ = fig_icp.ranked_pair(results, times)
        cells = [f"{k} {times[k][0]:.2f} s" + fig_icp.bucket_text(times[k][2])
                 + ("" if times[k][1] is not False else " (not converged)")
                 for k in ranked[:shown]]
        cells += ["-"] * (shown - len(cells))
        name = fig_icp.faster_nanoflann(times)
        ref = f"{name} {times[name][0]:.2f} s" if name else "-"
        ratio = f"{times[name][0] / times[ranked[0]][0]:.2f}x" if name and ranked else "-"
        lines.append(f"| {pair} | " + " | ".join(cells) + f" | {ref} | {ratio} |")
    return lines


def real_sweep_lines(results, shown=3, max_dist_m=0.1):
    """Per real pair swept: the fastest exact adapters' ranged 1-NN time over all the pair's queries at one
    distance (each adapter's default strategy, as Figure 9 draws it) and the fastest's speed-up over the faster
    nanoflann. A cell over the budget is not ranked; one disagreeing with brute force is marked."""
    lines = [f"| pair | queries | fastest at {max_dist_m:g} m | second | third | faster nanoflann | "
             "fastest vs it | ranked (of run) |", "|---|---|---|---|---|---|---|---|"]
    pairs = sorted({c.model for c in results.sweep if c.model == c.query
                    and results.datasets.get((c.model, "model"), {}).get("kind") == "real_pair"})
    for pair in pairs:
        cells = {c.adapter: c for c in results.sweep
                 if c.model == pair and c.query == pair and c.search == "ranged" and c.max_dist_m is not None
                 and abs(c.max_dist_m - max_dist_m) < 1e-9 and results_io.is_default_strategy(results, c)}
        timed = {a: c for a, c in cells.items()
                 if c.seconds and results.adapter_info(a).get("exact", True) and a != "brute_force"}
        ranked = sorted(timed, key=lambda a: timed[a].seconds)
        texts = [f"{a} {timed[a].seconds * 1e3:.3g} ms" + (" (DISAGREES)" if timed[a].agrees is False else "")
                 for a in ranked[:shown]]
        texts += ["-"] * (shown - len(texts))
        name = fig_icp.faster_nanoflann({a: (c.seconds,) for a, c in timed.items()})
        ref = f"{name} {timed[name].seconds * 1e3:.3g} ms" if name else "-"
        ratio = f"{timed[name].seconds / timed[ranked[0]].seconds:.2f}x" if name else "-"
        queries = next((c.n_queries for c in cells.values() if c.n_queries), None)
        lines.append(f"| {pair} | {f'{queries:,.0f}' if queries else '?'} | " + " | ".join(texts)
                     + f" | {ref} | {ratio} | {len(ranked)} of {len(cells)} |")
    return lines


def _fastest(got, adapters):
    """The least of got's times among adapters (None where none ran): the faster of ours or of the anchors."""
    return min(filter(None, (got.get(a) for a in adapters)), default=None)


def micro_lines(results):
    """Per pair and query order: ours (the faster of our two trees) against the faster nanoflann at each
    distance (target >= 2x), and ours' ns per query at <= 0.1 m (target under 100 ns on Figure 3 and SICK),
    as micro_nns judges them; a missed target is marked."""
    cells, queries = results_io.micro_cells(results), results_io.micro_queries(results)
    dists = sorted({k[2] for k in cells})
    lines = ["| pair | queries | ours vs the faster nanoflann at " + " / ".join(f"{d:g}" for d in dists) +
             " m (target >= 2x) | ours, ns per query at " + " / ".join(f"{d:g}" for d in dists if d <= 0.1) +
             " m (target < 100 on Figure 3 and SICK) |", "|---|---|---|---|"]
    pairs = sorted({k[0] for k in cells}, key=lambda p: (p != "fig3", p.replace("_shuffled", ""), p))
    for pair in pairs:
        base = pair.replace("_shuffled", "")
        n, judged = queries.get(pair), base in MICRO_FAST_PAIRS
        ratios, fast = [], []
        for d in dists:
            got = {a: cells.get((pair, a, d)) for a in MICRO_SUBJECTS}
            ours = _fastest(got, MICRO_OURS)
            anchor = _fastest(got, MICRO_ANCHORS)
            ratios.append(f"{anchor / ours:.2f}" + ("" if anchor / ours >= 2 else "*") if ours and anchor else "-")
            if d <= 0.1:
                ns = ours * 1e9 / n if ours and n else None
                fast.append("-" if ns is None else f"{ns:.0f}" + ("*" if judged and ns >= 100 else ""))
        order = "shuffled" if pair.endswith("_shuffled") else ("generated" if base == "fig3" else "scan")
        lines.append(f"| {MICRO_PAIRS.get(base, base)} | {order} | " + " / ".join(ratios) + " | " + " / ".join(fast) + " |")
    return lines


def _ms_text(seconds):
    ms = seconds * 1e3
    return f"{ms:,.0f} ms" if ms >= 100 else f"{ms:.3g} ms"


def micro_build_lines(results):
    """Per model: each of our trees' single-threaded build against the faster nanoflann's (target >= 2x for
    each tree), as micro_nns judges them; a missed target is marked."""
    cells = results_io.micro_build_cells(results)
    lines = ["| model | ours_kdtree | ours_octree | faster nanoflann | k-d tree vs it (target >= 2x) | octree vs it (target >= 2x) |",
             "|---|---|---|---|---|---|"]
    for model in sorted({m for m, a in cells if a in MICRO_SUBJECTS}, key=lambda m: (m != "fig3", m)):
        got = {a: cells.get((model, a)) for a in MICRO_SUBJECTS}
        anchor = _fastest(got, MICRO_ANCHORS)

        def ms(adapter):
            return _ms_text(got[adapter]) if got[adapter] else "-"

        def judged(adapter):
            if not (got[adapter] and anchor):
                return "-"
            return f"{anchor / got[adapter]:.2f}x" + ("" if anchor / got[adapter] >= 2 else "*")
        lines.append(f"| {MICRO_PAIRS.get(model, model)} | {ms('ours_kdtree')} | {ms('ours_octree')} | "
                     f"{_ms_text(anchor) if anchor else '-'} | {judged('ours_kdtree')} | {judged('ours_octree')} |")
    return lines


def micro_icp_lines(results):
    """Per real pair: a whole ICP run with each of our trees and the faster nanoflann, and the faster of ours
    against it (target >= 2.5x), as micro_nns judges them; a missed target is marked."""
    cells = results_io.micro_icp_cells(results)
    lines = ["| pair | ours_kdtree | ours_octree | faster nanoflann | ours vs it (target >= 2.5x) |",
             "|---|---|---|---|---|"]
    for pair in sorted({p for p, a in cells if a in MICRO_SUBJECTS}):
        got = {a: cells.get((pair, a)) for a in MICRO_SUBJECTS}
        ours = _fastest(got, MICRO_OURS)
        anchor = _fastest(got, MICRO_ANCHORS)
        judged = f"{anchor / ours:.2f}x" + ("" if anchor / ours >= ICP_TARGET else "*") if ours and anchor else "-"
        ms = [_ms_text(got[a]) if got[a] else "-" for a in ("ours_kdtree", "ours_octree")]
        lines.append(f"| {pair} | {ms[0]} | {ms[1]} | {_ms_text(anchor) if anchor else '-'} | {judged} |")
    return lines


def micro_times_lines(results):
    cells = results_io.micro_cells(results)
    dists = sorted({k[2] for k in cells})
    lines = ["| pair | adapter | " + " | ".join(f"{d:g} m" for d in dists) + " |", "|---|---|" + "---|" * len(dists)]
    for pair in sorted({k[0] for k in cells}, key=lambda p: (p != "fig3", p)):
        for adapter in sorted({k[1] for k in cells if k[0] == pair}, key=lambda a: cells.get((pair, a, dists[0]), 1)):
            lines.append(f"| {pair} | {adapter} | " + " | ".join(
                f"{cells[(pair, adapter, d)] * 1e3:.3g} ms" if (pair, adapter, d) in cells else "-" for d in dists) + " |")
    return lines


def scale_lines(results):
    key, table = fig_scale.scale_table(results)
    lines = ["| adapter | sizes run | largest n | query time exponent | build time exponent | µs per query | "
             "build s | index B per point | stopped at |", "|---|---|---|---|---|---|---|---|---|"]
    if key is None:
        return lines
    rows = []
    for adapter, row in table.items():
        ran = row["query"]
        if not ran:
            continue
        q = fig_scale.growth_exponent(*zip(*ran)) if len(ran) >= 2 else None
        b = fig_scale.growth_exponent(*zip(*row["build"])) if len(row["build"]) >= 2 else None
        n = ran[-1][0]
        build = dict(row["build"]).get(n)
        memory = dict(row.get("memory", [])).get(n)
        stopped = f"{row['stopped'][0]:,} points" if row["stopped"] else "-"
        rows.append((ran[-1][1] if len(ran) == len(fig_scale_sizes(table)) else 1e9, adapter,
                     f"| {style.short_label(adapter, results)} | {len(ran)} | {n:,} | {fig_scale._fmt(q)} | "
                     f"{fig_scale._fmt(b)} | {ran[-1][1] * 1e6:.3g} | {fig_scale._sig(build)} | "
                     f"{fig_scale._sig(memory)} | {stopped} |"))
    return lines + [r for _, _, r in sorted(rows)]


def fig_scale_sizes(table):
    return {n for row in table.values() for n, _ in row["query"]}


def findings_lines(results):
    lines = ["| # | the paper's claim | on these results |", "|---|---|---|"]
    return lines + [f"| {v.number} | {v.claim} | **{v.verdict}** |" for v in findings.evaluate(results, 0.1)]


NOT_RECORDED = "not recorded"  # a field an older results file lacks: said, never guessed


def _cell(text):
    return str(text).replace("|", "\\|")


def _load_1min(load):
    """The 1-minute load average of a context's load list, or None."""
    return f"{load[0]:.2f}" if isinstance(load, list) and load and isinstance(load[0], (int, float)) else None


def _commit_text(context):
    commit = context.get("git_commit")
    if not commit:
        return NOT_RECORDED
    return str(commit).removesuffix("+dirty")[:7] + (" (dirty)" if provenance.is_dirty(context) else "")


def _wall_text(context):
    seconds = provenance.wall_seconds(context)
    if seconds is None:
        return NOT_RECORDED
    text = f"{seconds:.2g} s" if seconds < 10 else f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} min"
    resumed = context.get("resumed")
    return text + (f" (the last of {len(resumed) + 1} runs: resumed)" if isinstance(resumed, list) and resumed else "")


def provenance_cells(path, context):
    """One results file's row: file, experiment, command, commit, load before -> after, start, wall time."""
    command = context.get("command_line")
    before, after = _load_1min(context.get("load_avg")), _load_1min(context.get("load_avg_after"))
    return [f"`{results_io.display_path(path)}`", results_io.experiment_of(context) or "-",
            f"`{_cell(command)}`" if command else NOT_RECORDED, _commit_text(context),
            f"{before or NOT_RECORDED} -> {after or NOT_RECORDED}", context.get("date") or NOT_RECORDED,
            _wall_text(context)]


def reference_runs_lines(results):
    """Every results file read, oldest first, with the provenance its context records."""
    lines = ["| file | experiment | command as run | commit | load (1 min) before -> after | started | wall time |",
             "|---|---|---|---|---|---|---|"]
    files = sorted(results.files, key=lambda f: (results_io.file_date(f[1]), results_io.display_path(f[0])))
    return lines + ["| " + " | ".join(provenance_cells(path, ctx)) + " |" for path, ctx in files]


def _both(model, query, field, fmt="{:,}"):
    values = [scan.get(field) for scan in (model, query)]
    if any(v is None for v in values):
        return NOT_RECORDED
    return " / ".join(fmt.format(v) for v in values)


def real_pair_scans(results):
    """{pair: (model entry, query entry)} of the real pairs' scans in the results' context.datasets, by name."""
    scans = {}
    for (spec, role), entry in results.datasets.items():
        if entry.get("kind") == "real_pair" and role in ("model", "query"):
            scans.setdefault(spec, {})[role] = entry
    return {spec: (s["model"], s["query"]) for spec, s in sorted(scans.items()) if len(s) == 2}


def real_pairs_lines(results):
    """Per real pair, its scans as loaded: points kept and read, dropped by kind, units, the query's pose."""
    lines = ["| pair (model <- query) | points kept (model / query) | read | dropped non-finite | dropped (0,0,0) | "
             "units in the files | query placed by |", "|---|---|---|---|---|---|---|"]
    for pair, (model, query) in real_pair_scans(results).items():
        files = f" ({model['file']} <- {query['file']})" if model.get("file") and query.get("file") else ""
        lines.append(f"| `{pair}`{files} | {_both(model, query, 'points')} | {_both(model, query, 'n_read')} | "
                     f"{_both(model, query, 'n_non_finite')} | {_both(model, query, 'n_zero')} | "
                     f"{_cell(model.get('units') or NOT_RECORDED)} | {_placed_text(query)} |")
    return lines


def _placed_text(query):
    placed = query.get("placed_by")
    if placed is None:
        return NOT_RECORDED
    return placed if placed == "identity" else f"`{placed}`"


def _length_text(metres):
    if metres < 0.01:
        return f"{metres * 1e3:.2g} mm"
    return f"{metres * 1e2:.2g} cm" if metres < 1 else f"{metres:.3g} m"


def _schedule_text(settings):
    start, factor = settings.get("max_dist_start_m"), settings.get("max_dist_factor")
    if start is None or factor is None:
        return NOT_RECORDED
    text = f"{start:g} m fixed" if factor == 1 else f"{start:g} -> {settings.get('max_dist_floor_m', 0):g} m, x{factor:g}"
    if settings.get("max_iterations") is not None:
        text += f", at most {settings['max_iterations']} iterations"
    stride = settings.get("query_stride") or 1
    return text + (f", query stride {stride}" if stride > 1 else "")


def _start_text(settings):
    pose = settings.get("initial_pose")
    if not isinstance(pose, list):
        return NOT_RECORDED
    identity = all(pose[r][c] == (1.0 if r == c else 0.0) for r in range(4) for c in range(4))
    return "identity" if identity else "the pair's initial pose"


def icp_accuracy_lines(results):
    """Per pair of the accuracy experiment: the settings, the start, the iterations and the final pose's error."""
    lines = ["| pair | adapter | settings | start | iterations | error vs reference (translation / rotation) |",
             "|---|---|---|---|---|---|"]
    for run in [r for r in results.icp if fig_icp.is_accuracy_run(r)]:
        settings = run.settings or {}
        iterations = "-" if run.iterations is None else f"{run.iterations:g}" + (
            " (not converged)" if run.converged is False else "")
        error = ("no reference" if run.ref_translation_error_m is None or run.ref_rotation_error_deg is None else
                 f"{_length_text(run.ref_translation_error_m)} / {run.ref_rotation_error_deg:.2g} deg")
        lines.append(f"| {run.pair} | {run.adapter} | {_schedule_text(settings)} | {_start_text(settings)} | "
                     f"{iterations} | {error} |")
    return lines


def registry_table1_lines(_results, path=None):
    """Table 1 for every adapter the build declares: results/reference/registry/adapters.json is what
    `nns_query --list --json` printed (a committed file, so that the check needs no build)."""
    path = Path(path or results_io.REPO_ROOT / "results" / "reference" / "registry" / "adapters.json")
    if not path.is_file():
        return list(HEADER)
    return adapter_lines(json.loads(path.read_text()))


TABLES = {"table1": table1_lines, "table1_registry": registry_table1_lines, "icp_ranking": icp_lines,
          "real_sweep": real_sweep_lines, "micro_nns": micro_lines, "micro_nns_builds": micro_build_lines,
          "micro_nns_icp": micro_icp_lines,
          "micro_nns_times": micro_times_lines, "scale": scale_lines, "findings": findings_lines,
          "reference_runs": reference_runs_lines, "real_pairs": real_pairs_lines, "icp_accuracy": icp_accuracy_lines}


def generate(results, name):
    return "\n".join(TABLES[name](results)) + "\n"


def refresh(text, results):
    """The README text with every generated block remade; unknown block names are an error."""
    def replace(match):
        if match.group("name") not in TABLES:
            raise SystemExit(f"readme_tables: unknown block {match.group('name')!r}")
        return match.group(1) + generate(results, match.group("name")) + match.group(4)
    return BLOCK.sub(replace, text)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true", help="exit 1 when README.md differs from the results")
    mode.add_argument("--write", action="store_true", help="rewrite the generated blocks of README.md")
    mode.add_argument("--print", metavar="NAME", choices=sorted(TABLES), help="print one table")
    parser.add_argument("--readme", type=Path, default=README)
    parser.add_argument("results", nargs="*", type=Path, help="results files (default: as make_figures.py)")
    args = parser.parse_args(argv)
    results = results_io.load(args.results or results_io.default_inputs(), prefer="newest")
    if args.print:
        print(generate(results, args.print), end="")
        return 0
    text = args.readme.read_text()
    new = refresh(text, results)
    if args.write:
        write_atomically(args.readme, new)
        print(f"readme_tables: {len(BLOCK.findall(new))} blocks written in {args.readme}")
        return 0
    if new != text:
        sys.stdout.writelines(difflib.unified_diff(text.splitlines(True), new.splitlines(True),
                                                   str(args.readme), "from the results"))
        print(f"readme_tables: {args.readme} differs from the results: run plots/readme_tables.py --write",
              file=sys.stderr)
        return 1
    print(f"readme_tables: {len(BLOCK.findall(text))} blocks match the results")
    return 0


if __name__ == "__main__":
    sys.exit(main())
