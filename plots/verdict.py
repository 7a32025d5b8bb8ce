"""A claim's verdict with the rule that decided it, the numbers it was decided on and the cells behind it."""
from collections import namedtuple

HOLDS, FAILS, UNTESTED = "HOLDS", "DOES NOT HOLD", "NOT TESTED"
# basis: how many cells (or comparisons, series, runs) the verdict rests on and how many were not measured.
Verdict = namedtuple("Verdict", "number claim verdict rule numbers basis", defaults=("",))
GRID_COMBINATIONS = 16


def fmt_s(seconds):
    return "skipped" if seconds is None else f"{seconds:.4g} s"


def where(combo, d):
    model, query = combo
    at = "" if d is None else f" at {d:.2f} m"
    return f"model {model} / query {query}{at}"


def firm(verdict):
    """True for a verdict on all the data the claim is about (HOLDS or DOES NOT HOLD, unqualified)."""
    return verdict in (HOLDS, FAILS)


def scoped(verdict, covered, scope, what="combinations"):
    """A verdict from part of the claim's scope says on how much: 'HOLDS on 1 of 16 combinations only'."""
    if verdict == UNTESTED or covered >= scope:
        return verdict
    return f"{verdict} on {covered} of {scope} {what} only"


def basis(used, not_measured, unit="cells"):
    return (f"rests on {used} {unit}; {not_measured} needed cell(s) not measured (skipped: over the time budget "
            "or another limit), left out rather than replaced by another search kind")
