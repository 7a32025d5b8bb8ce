"""Claims 4, 6 and 8: decided on construction records and ICP runs."""
from fig_build import build_table
from fig_icp import bucket_curves
from results_io import latest_builds
from verdict import FAILS, HOLDS, UNTESTED, Verdict, basis

REFERENCE = "brute_force"


def claim4(results, prefix="spatialindex_"):
    rule = (f"per model cloud: the fastest-building {prefix}* adapter takes >= 2x the build time of the slowest "
            "other adapter (brute force excluded). HOLDS if so for every model cloud that has both.")
    title = "libspatialindex is by far the slowest to build"
    table = build_table(results)
    numbers, ok = [], True
    for model in sorted({m for m, _ in table}):
        spatial = [(t, a) for (m, a), t in table.items() if m == model and a.startswith(prefix)]
        others = [(t, a) for (m, a), t in table.items() if m == model and not a.startswith(prefix) and a != REFERENCE]
        if spatial and others:
            ratio = min(spatial)[0] / max(others)[0]
            ok &= ratio >= 2.0
            numbers.append(f"{model}: {min(spatial)[1]} {min(spatial)[0]:.4g} s vs slowest other "
                           f"{max(others)[1]} {max(others)[0]:.4g} s: {ratio:.2f}x")
    skipped = sum(1 for (_, a) in results.build_skips if a != REFERENCE)
    if not numbers:
        return Verdict(4, title, UNTESTED, rule, [f"no model cloud with builds of both {prefix}* and others"],
                       basis(0, skipped, "model clouds"))
    return Verdict(4, title, HOLDS if ok else FAILS, rule, numbers, basis(len(numbers), skipped, "model clouds"))


def claim6(results, lo=5, hi=20):
    rule = (f"per ICP bucket curve (pair, adapter) with sizes both inside and outside {lo}-{hi}: the bucket size "
            f"of least ICP time lies in {lo}-{hi}. HOLDS if so for >= 75% of the curves (the paper: 'usually').")
    title = f"A bucket size between {lo} and {hi} is optimal for ICP"
    numbers, good, tested = [], 0, 0
    for pair, curves in sorted(bucket_curves(results).items()):
        for adapter, points in sorted(curves.items()):
            sizes = sorted(points)
            if not any(lo <= b <= hi for b in sizes) or all(lo <= b <= hi for b in sizes):
                numbers.append(f"{pair} {adapter}: sizes {sizes} do not straddle {lo}-{hi}, not counted")
                continue
            best = min(sizes, key=points.get)
            tested += 1
            good += lo <= best <= hi
            numbers.append(f"{pair} {adapter}: best bucket {best:g} "
                           f"({points[best]:.4g} s; range {min(points.values()):.4g}-{max(points.values()):.4g} s)")
    if tested == 0:
        return Verdict(6, title, UNTESTED, rule, numbers or ["no ICP bucket-size runs (needs an ICP bucket results file)"],
                       "rests on 0 curves")
    numbers.insert(0, f"{good} of {tested} curves have their optimum in {lo}-{hi}")
    return Verdict(6, title, HOLDS if good >= 0.75 * tested else FAILS, rule, numbers,
                   f"rests on {tested} curves; {len(numbers) - 1 - tested} curves do not straddle {lo}-{hi}, not counted")


def claim8(results, ours="ours_kdtree", ann="ann_kdtree"):
    rule = f"per model cloud: index_bytes({ann}) / index_bytes({ours}) >= 5. HOLDS if so for every model cloud."
    title = "The compact k-d tree uses at least 5x less memory than ANN"
    size = {key: b.index_bytes for key, b in latest_builds(results).items() if b.index_bytes}
    numbers, ok = [], True
    for model in sorted({m for m, _ in size}):
        if (model, ours) in size and (model, ann) in size:
            ratio = size[(model, ann)] / size[(model, ours)]
            ok &= ratio >= 5.0
            numbers.append(f"{model}: {ann} {size[(model, ann)]:.0f} B, {ours} {size[(model, ours)]:.0f} B: {ratio:.2f}x")
    skipped = sum(1 for (_, a) in results.build_skips if a in (ours, ann))
    if not numbers:
        return Verdict(8, title, UNTESTED, rule, [f"no model cloud with index_bytes of both {ours} and {ann}"],
                       basis(0, skipped, "model clouds"))
    return Verdict(8, title, HOLDS if ok else FAILS, rule, numbers, basis(len(numbers), skipped, "model clouds"))
