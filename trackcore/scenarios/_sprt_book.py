"""Presentation helpers of the SPRT chapter (book/002-sprt-acm), so that the
notebooks show the checks and experiments and not the bookkeeping.

This module is private (its name starts with an underscore): it is not re-exported by
``trackcore.scenarios`` and is not part of the public API. Nothing here computes a
result of the book; the notebooks use these helpers to check the public functions of
``trackcore`` against independent routes.
"""

from __future__ import annotations

import math

import numpy as np

from ..stats import paired_rate_diff_ci  # (also imported by notebook 04 from here)

__all__: list[str] = []  # private: nothing is re-exported


def central_jacobian(f, x, steps) -> np.ndarray:
    """Jacobian of ``f`` at ``x`` by central differences, column ``j`` with step
    ``steps[j]``: ``(f(x + h e_j) - f(x - h e_j)) / (2 h)``.

    ``f`` maps a 1-D array to a 1-D array; ``steps`` has one positive step per entry
    of ``x``.
    """
    x = np.asarray(x, dtype=float)
    steps = np.asarray(steps, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"x must be a 1-D array, got shape {x.shape}")
    if steps.shape != x.shape or not np.all(steps > 0):
        raise ValueError(f"steps must be {x.size} positive numbers, got {steps}")
    cols = []
    for j, h in enumerate(steps):
        e = np.zeros(x.size)
        e[j] = h
        cols.append((np.asarray(f(x + e)) - np.asarray(f(x - e))) / (2 * h))
    return np.stack(cols, axis=-1)


def cause_column(geometry, model, prior, sign, geometries, models, priors, signs):
    """Column of the cell (``geometry``, ``model``, ``prior``, ``sign``) in a cause
    factorial whose cells run geometry slowest, then target filter, prior and sign (the
    order of :func:`trackcore.experiments.sprt.cause_cells`)."""
    levels = (geometries, models, priors, signs)
    j = 0
    for value, axis in zip((geometry, model, prior, sign), levels):
        axis = list(axis)
        if value not in axis:
            raise ValueError(f"{value!r} is not a level of the factorial: {axis}")
        j = j * len(axis) + axis.index(value)
    return j


def paired_effect(d, k, base, changed, min_runs=None):
    """Paired effects of changing cell ``base`` to cell ``changed`` on the same runs:
    ``{"dsucc": Estimate of the success-rate difference (fractions, changed minus base),
    "dscan": Estimate of the decision-scan difference over the runs that succeed in both
    cells, or None with fewer than min_runs such runs (default trackcore.stats.MIN_RUNS)
    or too few differing runs for an interval, "both": their number, "why": the reason
    for a missing interval}``. ``d`` and ``k`` are (runs, cells) arrays of decisions (0:
    right) and decision scans."""
    from ..stats import MIN_RUNS, paired_diff_ci

    d, k = np.asarray(d), np.asarray(k)
    if d.ndim != 2 or d.shape != k.shape:
        raise ValueError(f"d and k must be 2-D arrays of one shape, got {d.shape}, {k.shape}")
    ok = d == 0
    dsucc = paired_diff_ci(ok[:, changed].astype(float), ok[:, base].astype(float))
    both = ok[:, changed] & ok[:, base]
    min_runs = MIN_RUNS if min_runs is None else min_runs
    dscan, why = None, f"{int(both.sum())} runs succeed in both"
    if both.sum() >= min_runs:
        try:
            dscan = paired_diff_ci(k[both, changed].astype(float),
                                   k[both, base].astype(float))
        except ValueError:   # too few runs whose scans differ for a studentized interval
            why = f"{int((k[both, changed] != k[both, base]).sum())} runs differ"
    return {"dsucc": dsucc, "dscan": dscan, "both": int(both.sum()), "why": why}


def effect_verdict(est, margin, helpful):
    """The verdict of a paired effect ``est`` (an Estimate or None) as the registry's
    cause factorial's declared rule decides it (index, "Choices we made"): ``"none"``
    when the whole interval lies inside ``[-margin, margin]`` (a demonstrated
    equivalence: no cause, however the interval lies about 0), else ``"helps"`` when it
    lies wholly on the ``helpful`` side of 0 (``"above"`` or ``"below"``), ``"hurts"``
    when it lies wholly on the other side, else ``"undecided"`` (also without an
    interval).  Equivalence is checked first: a small effect decided on many runs is
    "none", not "helps".

    Examples
    --------
    >>> from trackcore.stats import Estimate
    >>> from trackcore.scenarios._sprt_book import effect_verdict
    >>> effect_verdict(Estimate(0.005, 0.002, 0.008, 0.95, 5000, "t"), 0.02, "above")
    'none'
    >>> effect_verdict(Estimate(0.03, 0.01, 0.05, 0.95, 5000, "t"), 0.02, "above")
    'helps'
    """
    if helpful not in ("above", "below"):
        raise ValueError(f"helpful must be 'above' or 'below', got {helpful!r}")
    if not margin > 0:
        raise ValueError(f"margin must be > 0, got {margin!r}")
    if est is None:
        return "undecided"
    lo, hi = (est.lo, est.hi) if helpful == "above" else (-est.hi, -est.lo)
    if -margin <= lo and hi <= margin:
        return "none"
    if lo > 0:
        return "helps"
    if hi < 0:
        return "hurts"
    return "undecided"


def fss_n_star(diffs, ns):
    """The FSS test's N* on one set of runs, by the chapter's declared rule (claims.yml,
    ``sprt-fss-saving``): ``diffs[i]`` is the paired interval of FSS(``ns[i]``) success
    minus the SPRT's (an Estimate, ``ns`` increasing). Returns ``(lo, value, hi)``: ``lo``
    the smallest N whose interval does not lie wholly below 0 (the FSS test is not shown
    short of the SPRT), ``value`` the smallest N whose estimate is >= 0, ``hi`` the
    smallest N whose interval lies wholly above 0 (shown ahead); None where no N of
    ``ns`` qualifies. N* is the first N that reaches the SPRT: on a non-monotone curve a
    larger N can fall short of it again, which N* does not undo (the text reports it).

    Examples
    --------
    >>> from trackcore.stats import Estimate
    >>> from trackcore.scenarios._sprt_book import fss_n_star
    >>> e = lambda v, lo, hi: Estimate(v, lo, hi, 0.95, 20000, "t")
    >>> fss_n_star([e(-.05, -.06, -.04), e(-.001, -.004, .002), e(.004, .001, .007),
    ...             e(-.02, -.03, -.01)], [1, 2, 3, 4])
    (2, 3, 3)
    """
    ns = list(ns)
    if len(ns) != len(diffs) or ns != sorted(set(ns)):
        raise ValueError(f"ns must be increasing and match diffs, got {ns!r}")
    lo = next((n for n, d in zip(ns, diffs) if not d.hi < 0), None)
    value = next((n for n, d in zip(ns, diffs) if d.value >= 0), None)
    hi = next((n for n, d in zip(ns, diffs) if d.lo > 0), None)
    return lo, value, hi


def fss_saving(n_star, ek):
    """The saving N* / E[k] (an Estimate) from ``n_star = (lo, value, hi)`` of
    :func:`fss_n_star` and the SPRT's mean decision scan ``ek`` (an Estimate): value
    ``value / ek.value``, interval ``[lo / ek.hi, hi / ek.lo]`` (the ends of N* against
    the ends of E[k]; the ends of N* come from per-N 95 % intervals, without a
    multiplicity correction). None when an end of N* is missing (no N of the curve
    reaches, or is shown ahead of, the SPRT).

    Examples
    --------
    >>> from trackcore.stats import Estimate
    >>> from trackcore.scenarios._sprt_book import fss_saving
    >>> f"{fss_saving((7, 7, 8), Estimate(5.0, 4.9, 5.1, 0.95, 100, 't')):.3f}"
    '1.400 [1.373, 1.633]'
    """
    from ..stats import Estimate

    lo, value, hi = n_star
    if lo is None or value is None or hi is None:
        return None
    return Estimate(value / ek.value, lo / ek.hi, hi / ek.lo, ek.level, ek.n,
                    "N* / E[k], ends of N* (per-N paired intervals) over ends of E[k]")


def fss_curve(d, k, fss_ok, ns):
    """The FSS curve of one cell beside the SPRT on the same runs (04-fixed-sample-size):
    ``d``, ``k`` the SPRT's decisions (0: right, 1: wrong, -1: undecided) and scans, and
    ``fss_ok`` a (runs, len(ns)) array, 1 where the FSS test with ``ns[i]`` scans decides
    right. Returns ``{"success": the SPRT's success (rate_ci), "ek": its mean decision
    scan over the decided runs (mean_ci), "diffs": FSS(N) minus SPRT success per N
    (paired_rate_diff_ci), "n_star": fss_n_star, "saving": fss_saving, "short_after": the
    N beyond N*'s upper end whose FSS test is shown short of the SPRT again}``."""
    from ..stats import mean_ci, rate_ci

    d, k, fss_ok = np.asarray(d), np.asarray(k), np.asarray(fss_ok)
    if d.ndim != 1 or k.shape != d.shape or fss_ok.shape != (d.size, len(ns)):
        raise ValueError(f"shapes d {d.shape}, k {k.shape}, fss_ok {fss_ok.shape} do "
                         f"not match {len(ns)} N")
    ok = (d == 0).astype(float)
    diffs = [paired_rate_diff_ci(fss_ok[:, i].astype(float), ok) for i in range(len(ns))]
    ek = mean_ci(k[d >= 0].astype(float))
    n_star = fss_n_star(diffs, ns)
    after = [n for n, e in zip(ns, diffs)
             if n_star[2] is not None and n > n_star[2] and e.hi < 0]
    return {"success": rate_ci(int(ok.sum()), d.size), "ek": ek, "diffs": diffs,
            "n_star": n_star, "saving": fss_saving(n_star, ek), "short_after": after}


def geometry_tag(alpha, lead):
    """The glue-key tag of a geometry (target course ``alpha``, pursuer lead ``lead``,
    degrees), as 06-sensitivity names the family's cells: ``(33.8, -15)`` is
    ``"a338_lm15"``, ``(45, 0)`` is ``"a45_l0"``."""
    for name, v in (("alpha", alpha), ("lead", lead)):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise TypeError(f"{name} must be a number, got {v!r}")
    sign = "m" if lead < 0 else "p" if lead > 0 else ""
    return f"a{alpha:g}".replace(".", "") + f"_l{sign}{abs(lead):g}"


def bound_verdict(est, bound):
    """How a rate ``est`` (an Estimate, fractions) stands against an upper ``bound`` as
    the registry's direction rule (expect below) decides it: ``"respects"`` when the
    whole interval lies below the bound, ``"violates"`` when it lies wholly above,
    ``"undecided"`` when it contains the bound."""
    if not 0 < bound < 1:
        raise ValueError(f"bound must lie in (0, 1), got {bound!r}")
    if est.hi < bound:
        return "respects"
    if est.lo > bound:
        return "violates"
    return "undecided"


#: 1/2 ln 10^6: the change of -1/2 ln det V per bearing datum when the bearing is in mrad
#: instead of rad (its variance 10^6 times larger)
HALF_LN_1E6 = 0.5 * math.log(1e6)


def in_mrad(lam):
    """``lam[..., k, :] = [Lambda_a0, Lambda_b0, Lambda_a1, Lambda_b1]`` at scans
    ``k = 1, 2, ...`` (second-to-last axis) with the bearing in mrad instead of rad: each
    bearing datum lowers its filter's -1/2 ln det V by 1/2 ln 10^6 (the target filters
    hold one from scan 1, the decoy filters one from scan 2)."""
    lam = np.asarray(lam, dtype=float)
    if lam.ndim < 2 or lam.shape[-1] != 4:
        raise ValueError(f"lam must have shape (..., scans, 4), got {lam.shape}")
    k = np.arange(1, lam.shape[-2] + 1)
    return lam - HALF_LN_1E6 * np.stack([k, k - 1, k - 1, k], axis=-1)


def annotated_heatmap(ax, val, xs, ys, *, cmap, vrange, fmt, dark, half=(2.5, 2.5)):
    """Draw ``val[i, j]`` (row ``i`` at ``ys[i]``, column ``j`` at ``xs[j]``) on ``ax`` as
    an image with each cell's value printed in it (``fmt.format(v)``; white where
    ``dark(v)``), cells ``2 * half`` wide (x, y); returns the image for a colour bar."""
    val = np.asarray(val, dtype=float)
    xs, ys = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
    if val.shape != (ys.size, xs.size):
        raise ValueError(f"val must have shape ({ys.size}, {xs.size}), got {val.shape}")
    ext = [xs[0] - half[0], xs[-1] + half[0], ys[0] - half[1], ys[-1] + half[1]]
    im = ax.imshow(val, origin="lower", cmap=cmap, vmin=vrange[0], vmax=vrange[1],
                   aspect="auto", extent=ext)
    for i, y in enumerate(ys):
        for j, x in enumerate(xs):
            v = val[i, j]
            ax.text(x, y, fmt.format(v), ha="center", va="center", fontsize=8.5,
                    color="w" if dark(v) else "k")
    ax.grid(False)
    return im


