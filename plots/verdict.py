"""A claim's verdict with the rule that decided it and the numbers it was decided on."""
from collections import namedtuple

HOLDS, FAILS, UNTESTED = "HOLDS", "DOES NOT HOLD", "NOT TESTED"
Verdict = namedtuple("Verdict", "number claim verdict rule numbers")


def fmt_s(seconds):
    return "skipped" if seconds is None else f"{seconds:.4g} s"


def where(combo, d):
    model, query = combo
    at = "" if d is None else f" at {d:.2f} m"
    return f"model {model} / query {query}{at}"
