"""Claims 1, 2, 3, 5 and 7: decided on the synthetic 4x4 sweep. Brute force is a reference, never a contender."""
import math

from results_io import SHAPES, is_default_strategy
from verdict import FAILS, GRID_COMBINATIONS, HOLDS, UNTESTED, Verdict, basis, fmt_s, scoped, where

KNN_ONLY = ("cgal_kdtree", "spatialindex_")  # names, or name prefixes ending in '_'
REFERENCE = "brute_force"
WINDOW_M = (0.30, 0.55)  # "near 1/3 to 1/2", one step of margin


def grid(results):
    """{(model, query): {(adapter, kind): {max_dist or None: cell}}} over the synthetic combinations.

    Approximate adapters answer another question, so they never compete; each adapter competes with its
    default strategy (its own ranged search where it has one)."""
    out = {}
    approximate = {a for a, info in results.adapters.items() if info.get("exact") is False}
    for c in results.sweep:
        if (c.model in SHAPES and c.query in SHAPES and c.adapter != REFERENCE and c.adapter not in approximate
                and is_default_strategy(results, c)):
            out.setdefault((c.model, c.query), {}).setdefault((c.adapter, c.search), {})[c.max_dist_m] = c
    return out


def seconds(cells, d):
    """Time of a series at distance d (k-NN recorded once counts at every d); None if skipped or absent."""
    cell = cells.get(d) or cells.get(None)
    return cell.seconds if cell else None


def not_measured(cells, d):
    """True when the series has a record at d that did not run (over budget or another limit)."""
    cell = cells.get(d) or cells.get(None)
    return cell is not None and cell.seconds is None


def ranged_times(series, d, names):
    """({adapter: ranged seconds at d} of those measured, count of those recorded but not measured)."""
    times, missing = {}, 0
    for adapter in names:
        cells = series.get((adapter, "ranged"), {})
        if not_measured(cells, d):
            missing += 1
        elif seconds(cells, d) is not None:
            times[adapter] = seconds(cells, d)
    return times, missing


def distances(series):
    return sorted({d for cells in series.values() for d in cells if d is not None})


def strategy(cells):
    return next(iter(cells.values())).strategy


def adapters(series):
    return sorted({a for a, _ in series})


def is_knn_only(adapter):
    return any(adapter == n or (n.endswith("_") and adapter.startswith(n)) for n in KNN_ONLY)


def claim1(results, small_m):
    series_by_combo = grid(results)
    checked, failures, combos, missing = 0, [], set(), 0
    for combo, series in sorted(series_by_combo.items()):
        for d in (d for d in distances(series) if d <= small_m + 1e-9):
            def compare(what, ranged_t, other_t):
                nonlocal checked, missing
                if ranged_t is None or other_t is None:
                    missing += 1
                    return
                checked += 1
                combos.add(combo)
                if not ranged_t < other_t:
                    failures.append(f"{what}: ranged {fmt_s(ranged_t)} >= {fmt_s(other_t)}, {where(combo, d)}")
            for (adapter, kind), cells in series.items():  # (a) same library
                if kind == "ranged" and strategy(cells) == "native":
                    for other in ("knn", "radius"):
                        if (adapter, other) in series and strategy(series[(adapter, other)]) == "native":
                            compare(f"{adapter} ranged vs its {other}", seconds(cells, d),
                                    seconds(series[(adapter, other)], d))
            best = {}
            for (adapter, kind), cells in series.items():  # (b) best against best
                t = seconds(cells, d)
                if t is not None and (kind != "ranged" or strategy(cells) == "native"):
                    best[kind] = min(best.get(kind, math.inf), t)
            for other in ("knn", "radius"):
                if "ranged" in best and other in best:
                    compare(f"best native ranged vs best {other}", best["ranged"], best[other])
    rule = (f"small = max distance <= {small_m} m. (a) every adapter with a native ranged search against its own "
            "native k-NN and radius; (b) the fastest native ranged against the fastest k-NN and the fastest radius "
            "of any adapter. HOLDS if ranged is strictly faster in every comparison (a comparison with a side not "
            "measured is left out); on fewer than 16 combinations the verdict says on how many.")
    numbers = [f"{checked} comparisons in {len(combos)} of {GRID_COMBINATIONS} combinations; {len(failures)} where "
               "ranged was not faster"]
    numbers += failures[:8] + ([f"... and {len(failures) - 8} more"] if len(failures) > 8 else [])
    verdict = UNTESTED if checked == 0 else (FAILS if failures else HOLDS)
    return Verdict(1, "Ranged search beats k-NN and fixed-radius search at small distances in all 16 combinations",
                   scoped(verdict, len(combos), GRID_COMBINATIONS), rule, numbers,
                   basis(checked, missing, "comparisons"))


def _growth(cells, d_from, d_to):
    a, b = seconds(cells, d_from), seconds(cells, d_to)
    return None if a is None or b is None or a <= 0 else b / a


def claim2(results):
    series = grid(results).get(("hollow_sphere", "hollow_cube"), {})
    rule = ("query hollow cube, model hollow sphere (the farthest query point is sqrt(3) - 1 = 0.732 m from the "
            "sphere). d0 = first swept distance >= 0.74 m, d1 = the series' last distance that ran, d1 >= d0 + 0.15 m. "
            "Radius: each series never drops by more than 10% from one distance to the next, and "
            "T(d1)/T(d0) >= 1.25. Native ranged: T(d1)/T(d0) <= 1.25. k-NN: max/min over distances <= 1.25 "
            "when recorded per distance. HOLDS if all radius and ranged series that ran at d0 and d1 pass.")
    dists = distances(series)
    d0 = next((d for d in dists if d >= 0.74), None)
    if not series or d0 is None or dists[-1] < d0 + 0.15 - 1e-9:
        return Verdict(2, "Radius time keeps growing with the distance; ranged levels off near 0.73 m; k-NN flat",
                       UNTESTED, rule, ["no hollow cube / hollow sphere cells reaching past 0.89 m"])
    numbers, ok, tested, missing = [], True, 0, 0
    for (adapter, kind), cells in sorted(series.items()):
        run = [(d, cells[d].seconds) for d in sorted(d for d in cells if d is not None) if cells[d].seconds is not None]
        d1 = run[-1][0] if run and run[-1][0] >= d0 + 0.15 - 1e-9 else None
        if kind == "radius":
            drops = [d for (_, a), (d, b) in zip(run, run[1:]) if b < 0.9 * a]
            g = None if d1 is None else _growth(cells, d0, d1)
            if g is None:
                numbers.append(f"{adapter} radius: did not run at {d0:.2f} m and 0.15 m beyond (last run "
                               f"{f'{run[-1][0]:.6g}' if run else '-'} m), not counted")
                missing += 1
                continue
            tested += 1
            passed = g >= 1.25 and not drops
            ok &= passed
            numbers.append(f"{adapter} radius: T({d1:.2f})/T({d0:.2f}) = {g:.2f}, drops > 10% at {drops or 'none'}"
                           f" -> {'grows' if passed else 'does not keep growing'}")
        elif kind == "ranged" and strategy(cells) == "native":
            g = None if d1 is None else _growth(cells, d0, d1)
            if g is None:
                missing += 1
                continue
            tested += 1
            ok &= g <= 1.25
            numbers.append(f"{adapter} ranged: T({d1:.2f})/T({d0:.2f}) = {g:.2f} -> "
                           f"{'levels off' if g <= 1.25 else 'still grows'}")
        elif kind == "knn":
            ts = [t for _, t in run]
            if len(ts) >= 2:
                tested += 1
                ok &= max(ts) / min(ts) <= 1.25
                numbers.append(f"{adapter} k-NN: max/min over distances = {max(ts) / min(ts):.2f}")
            elif None in cells:
                numbers.append(f"{adapter} k-NN: recorded once ({fmt_s(cells[None].seconds)}); flat by design, "
                               "not measured per distance")
    verdict = UNTESTED if tested == 0 else (HOLDS if ok else FAILS)
    return Verdict(2, "Radius time keeps growing with the distance; ranged levels off near 0.73 m; k-NN flat",
                   verdict, rule, numbers, basis(tested, missing, "series") + " (a series not measured at both "
                   "distances counts as one)")


def _cells(series_by_combo, pick=lambda d: True, combos=lambda c: True):
    for combo, series in sorted(series_by_combo.items()):
        if combos(combo):
            for d in distances(series):
                if pick(d):
                    yield combo, series, d


def claim3(results):
    rule = ("like for like: each adapter's ranged search (native or emulated, as the library offers it) at a "
            "(combination, distance). A cell passes if every k-NN-only adapter (cgal_kdtree, spatialindex_*) is "
            "slower than every other adapter measured there. HOLDS if >= 90% of the cells with both groups pass "
            "(the paper: 'in almost all cases'); on fewer than 16 combinations the verdict says on how many.")
    passed, total, worst, missing, combos = 0, 0, None, 0, set()
    for combo, series, d in _cells(grid(results)):
        times, skipped = ranged_times(series, d, adapters(series))
        missing += skipped
        knn_only = [(t, a) for a, t in times.items() if is_knn_only(a)]
        others = [(t, a) for a, t in times.items() if not is_knn_only(a)]
        if not knn_only or not others:
            continue
        total += 1
        combos.add(combo)
        fastest_k, slowest_o = min(knn_only), max(others)
        passed += fastest_k[0] > slowest_o[0]
        margin = fastest_k[0] / slowest_o[0]
        if worst is None or margin < worst[0]:
            worst = (margin, f"{fastest_k[1]} {fmt_s(fastest_k[0])} vs {slowest_o[1]} {fmt_s(slowest_o[0])}, "
                             f"{where(combo, d)}")
    title = "The k-NN-only libraries (CGAL, libspatialindex) are the slowest"
    if total == 0:
        return Verdict(3, title, UNTESTED, rule, ["no cell with ranged times of both k-NN-only and other adapters"],
                       basis(0, missing))
    numbers = [f"{passed} of {total} cells pass ({100 * passed / total:.1f}%)",
               f"closest call (fastest k-NN-only / slowest other = {worst[0]:.2f}): {worst[1]}"]
    verdict = HOLDS if passed >= 0.9 * total else FAILS
    return Verdict(3, title, scoped(verdict, len(combos), GRID_COMBINATIONS), rule, numbers,
                   basis(total, missing) + " (a ranged series of one adapter at one distance)")


def claim5(results, ours="ours_kdtree", rivals=("flann_kdtree", "ann_kdtree")):
    lo, hi = WINDOW_M
    scope = GRID_COMBINATIONS - len(SHAPES)
    rule = (f"like for like: ranged search against ranged search (a cell the time budget stopped is not measured, "
            f"never replaced by another search kind), on the non-trivial combinations (model != query). Outside "
            f"{lo}-{hi} m {ours} must be strictly faster than each of {', '.join(rivals)}; inside, at most 10% "
            f"slower (the paper's 'equal in runtime'). HOLDS if every compared cell passes; on fewer than {scope} "
            "combinations the verdict says on how many.")
    title = "The compact k-d tree is faster than FLANN and ANN in every non-trivial combination"
    checked, failures, worst, missing, combos = 0, [], {}, 0, set()
    for combo, series, d in _cells(grid(results), combos=lambda c: c[0] != c[1]):
        times, _ = ranged_times(series, d, (ours, *rivals))
        for rival in rivals:
            if not_measured(series.get((ours, "ranged"), {}), d) or not_measured(series.get((rival, "ranged"), {}), d):
                missing += 1
                continue
            if ours not in times or rival not in times:
                continue
            checked += 1
            combos.add(combo)
            ratio = times[ours] / times[rival]
            inside = lo <= d <= hi
            worst[inside] = max(worst.get(inside, 0.0), ratio)
            if (ratio > 1.10) if inside else (ratio >= 1.0):
                failures.append(f"{ours} {fmt_s(times[ours])} vs {rival} {fmt_s(times[rival])} ({ratio:.2f}x), "
                                f"{where(combo, d)}")
    if checked == 0:
        return Verdict(5, title, UNTESTED, rule, [f"no non-trivial cell with ranged times of {ours} and a rival"],
                       basis(0, missing, "comparisons"))
    numbers = [f"{checked} comparisons in {len(combos)} of {scope} non-trivial combinations, {len(failures)} failed; "
               f"worst {ours}/rival time ratio outside the window {worst.get(False, float('nan')):.2f}, "
               f"inside {worst.get(True, float('nan')):.2f}"]
    numbers += failures[:8] + ([f"... and {len(failures) - 8} more"] if len(failures) > 8 else [])
    return Verdict(5, title, scoped(FAILS if failures else HOLDS, len(combos), scope), rule, numbers,
                   basis(checked, missing, "comparisons"))


def claim7(results, small_m, octree="ours_octree"):
    rule = (f"like for like: at every (combination, distance <= {small_m} m) rank the exact adapters by their "
            f"ranged search time; HOLDS if {octree} is in the top 3 in >= 75% of those cells. A cell where "
            f"{octree} was not measured is left out; on fewer than 16 combinations the verdict says on how many.")
    title = "The octree is among the fastest"
    ranks, missing, combos = [], 0, set()
    for combo, series, d in _cells(grid(results), pick=lambda d: d <= small_m + 1e-9):
        times, _ = ranged_times(series, d, adapters(series))
        if not_measured(series.get((octree, "ranged"), {}), d):
            missing += 1
        elif octree in times:
            ranks.append(1 + sum(t < times[octree] for t in times.values()))
            combos.add(combo)
    if not ranks:
        return Verdict(7, title, UNTESTED, rule, [f"no small-distance cell where {octree}'s ranged search ran"],
                       basis(0, missing))
    top3 = sum(r <= 3 for r in ranks)
    dist = ", ".join(f"rank {r}: {ranks.count(r)}" for r in sorted(set(ranks)))
    numbers = [f"top 3 in {top3} of {len(ranks)} cells ({100 * top3 / len(ranks):.1f}%); {dist}"]
    return Verdict(7, title, scoped(HOLDS if top3 >= 0.75 * len(ranks) else FAILS, len(combos), GRID_COMBINATIONS),
                   rule, numbers, basis(len(ranks), missing))
