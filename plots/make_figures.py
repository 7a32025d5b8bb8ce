#!/usr/bin/env python3
"""Regenerates the paper's table and figures from results JSON: python3 plots/make_figures.py [FILES] [--out DIR]."""
import argparse
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
import provenance  # noqa: E402
import results_io  # noqa: E402
import style  # noqa: E402
from table1 import write_table1  # noqa: E402


def write_provenance(check, out_dir):
    """PROVENANCE.md beside the figures: the inputs they were drawn from, and the warning if any."""
    out_dir.mkdir(parents=True, exist_ok=True)
    lines = ["# Inputs of these figures", ""] + ([f"**{check.banner()}**", ""] if check.marks else [])
    write_atomically(out_dir / "PROVENANCE.md", "\n".join(lines + [f"- {line}" for line in check.lines]) + "\n")


# Every figure make_figures draws: one left in the folder from earlier inputs that these no longer allow would be
# read as drawn from them.
FIGURE_STEMS = ("fig2_icp_bucket", "fig3_hollow_cube_vs_hollow_sphere", "fig3_strategies", "fig4_construction",
                "fig5_icp_real", "fig6_grid_all", "fig7_grid_best", "fig8_scale", "fig9_speedup", "fig10_threads")


def remove_stale(out_dir, drawn):
    """Removes the figures of FIGURE_STEMS these inputs did not draw."""
    for stem in FIGURE_STEMS:
        for path in (out_dir / f"{stem}.png", out_dir / f"{stem}.svg"):
            if stem not in drawn and path.is_file():
                path.unlink()
                print(f"removed {path}: not drawn from these inputs")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("results", nargs="*", type=Path,
                        help="results files, micro_nns.json included (default: results/reference/*.json and its "
                             "micro_nns/micro_nns.json, else results/*.json)")
    parser.add_argument("--out", type=Path, default=results_io.REPO_ROOT / "results" / "figures",
                        help="output directory (default: results/figures)")
    provenance.add_arguments(parser)
    args = parser.parse_args(argv)
    paths = args.results or results_io.default_inputs()
    if not paths:
        print("make_figures: no results files (results/reference/*.json or results/*.json): nothing to plot")
        return 0
    results = results_io.load(paths, prefer=args.prefer)
    if not results.files:
        print("make_figures: none of the given files could be read", file=sys.stderr)
        return 2
    check = provenance.check_or_exit(results, args, "make_figures")
    write_provenance(check, args.out)
    style.WARNING = check.banner()
    style.setup()
    write_table1(results, args.out)
    written = [fig_icp.fig2(results, args.out), fig_sweep.fig3(results, args.out),
               fig_sweep.fig3_strategies(results, args.out), fig_build.fig4(results, args.out),
               fig_icp.fig5(results, args.out), fig_sweep.grid(results, args.out, best=False),
               fig_sweep.grid(results, args.out, best=True), fig_scale.fig8(results, args.out),
               fig_speedup.fig9(results, args.out), fig_threads.fig10(results, args.out)]
    remove_stale(args.out, {png.stem for png in written if png})
    return 0


if __name__ == "__main__":
    sys.exit(main())
