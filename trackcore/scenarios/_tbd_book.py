"""Bookkeeping helpers of chapter 003's verdict grid (book/003-tbd-pf/06-verdict-grid).

Kept out of the notebook so that its cells stay short and the logic is tested
(tests/test_tbd_book.py).
"""
from __future__ import annotations

import math

from ..stats import MIN_RUNS, compare

__all__ = ["direction_verdict", "variant_effect"]


def variant_effect(columns, tag, variant, letter, mk, measure, w, a, b, book_val, short,
                   trackers=("A", "B", "C")):
    """Glue key, effect and verdict of ``a - b`` in one cell under a stronger baseline.

    ``columns``: the cell's per-run columns with tracker ``letter`` replaced by the
    stronger baseline ``variant`` (``"bg"``, ``"as"``, ``"imm"``); ``tag``: the cell's
    key part (``"base_25"``); ``mk``: the measure's key (``"pm"``, ``"cap"``, ``"held"``,
    ``"heldd"``) and ``measure`` its ``(metric, loss)``; ``w``: ``"100"`` or ``"all"``.
    A pair without ``letter`` under a measure that keeps every run is the book's value
    ``book_val[key]`` (an ``(effect, verdict)`` pair).  A selected measure with fewer than
    ``MIN_RUNS`` runs gives no interval: the key goes into ``short`` (key -> runs) and the
    effect is ``None``, the verdict ``"n/a"``.  Returns ``(key, effect text, verdict)``.
    """
    from ..experiments.tbd_grid import tbd_grid_values

    if letter not in trackers:
        raise ValueError(f"letter must be one of {tuple(trackers)}, got {letter!r}")
    book = f"tbd_g_{tag}_{mk}_{w}_{a}{b}".lower()
    key = f"tbd_{variant}_{book[4:]}"
    if letter not in (a, b) and not mk.startswith("held"):
        return (key, *book_val[book])
    x = tbd_grid_values(columns, trackers, w, *measure)
    n = len(x[trackers[0]])
    if n < MIN_RUNS:
        short[key] = n
    if key in short:
        return key, None, "n/a"
    r = compare(x[a], x[b], (a, b))
    return key, f"{r.effect:.0f}", r.verdict


def direction_verdict(estimates, expect):
    """``"met"`` when every interval of ``estimates`` lies wholly ``expect`` (``"below"``
    or ``"above"``) zero, ``"missed"`` when any lies wholly on the other side, otherwise
    ``"undecided"`` (an interval that contains zero is a tie)."""
    if expect not in ("below", "above"):
        raise ValueError(f"expect must be 'below' or 'above', got {expect!r}")
    ests = list(estimates)
    if not ests:
        raise ValueError("estimates must hold at least one interval")
    for e in ests:
        if not (math.isfinite(e.lo) and math.isfinite(e.hi)):
            raise ValueError(f"every interval must be finite, got [{e.lo}, {e.hi}]")
    below = [e.hi < 0 for e in ests]
    above = [e.lo > 0 for e in ests]
    holds, fails = (below, above) if expect == "below" else (above, below)
    if any(fails):
        return "missed"
    return "met" if all(holds) else "undecided"
