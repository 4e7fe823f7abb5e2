"""Bookkeeping helpers of chapter 003 (book/003-tbd-pf): its verdict grid
(06-verdict-grid) and the particle-count sweep's figure (04-tracking).

Kept out of the notebook so that its cells stay short and the logic is tested
(tests/test_tbd_book.py).
"""
from __future__ import annotations

import math

from ..stats import MIN_RUNS, compare

__all__ = ["direction_verdict", "sweep_figure", "variant_effect", "why_summary"]


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

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios._tbd_book import variant_effect
    >>> g = np.random.default_rng(0)
    >>> m = g.lognormal(5.0, 0.3, (60, 3)) + [60.0, 30.0, 0.0]  # A, B, C
    >>> cols = {k: m for k in ("m100", "mall", "c100", "call", "sd", "sdc")}
    >>> cols["outcome"] = np.zeros((60, 3), dtype=np.int8)
    >>> key, effect, verdict = variant_effect(cols, "base_25", "bg", "B", "pm",
    ...     ("paper mean", "lost"), "all", "B", "A", {}, {})
    >>> key, effect
    ('tbd_bg_g_base_25_pm_all_ba', '-22 [-37, -7]')
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
    ``"undecided"`` (an interval that contains zero is a tie).

    Examples
    --------
    >>> from trackcore.scenarios._tbd_book import direction_verdict
    >>> from trackcore.stats import Estimate
    >>> lower = Estimate(-0.05, -0.09, -0.01)
    >>> tie = Estimate(-0.03, -0.07, 0.01)
    >>> direction_verdict([lower], "below"), direction_verdict([lower, tie], "below")
    ('met', 'undecided')
    >>> direction_verdict([lower], "above")
    'missed'
    """
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


def sweep_figure(stats, counts, radii):
    """The particle-count sweep of 04-tracking (Figs 11-12): per radius (columns) the mean
    error of all runs and of the runs not lost with their intervals and the median run
    (top, log-log), and the lost fraction split into diverged, still lost and transient
    runs with the lost fraction's interval (bottom).

    ``stats[R][N]``: a dict with ``mean`` and ``not_lost`` (:class:`~trackcore.stats.Estimate`,
    ``not_lost`` may be ``None``: too few runs), ``median``, ``div``, ``oth``, ``tr``
    (fractions) and ``lost`` (an Estimate of the lost fraction) for every ``N`` of
    ``counts`` and ``R`` of ``radii`` (m).  Returns the matplotlib figure.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from trackcore.scenarios._tbd_book import sweep_figure
    >>> from trackcore.stats import Estimate
    >>> e = Estimate(150.0, 140.0, 160.0)
    >>> one = dict(mean=e, not_lost=e, median=145.0, div=0.02, oth=0.0, tr=0.01,
    ...     lost=Estimate(0.03, 0.01, 0.06))
    >>> fig = sweep_figure({2500.0: {50: one, 600: one}}, [50, 600], [2500.0])
    >>> [ax.get_title() for ax in fig.axes]
    ['R = 2.5 km', '']
    >>> import matplotlib.pyplot as plt
    >>> plt.close(fig)
    """
    import matplotlib.pyplot as plt
    import numpy as np

    counts, radii = list(counts), list(radii)
    if not counts or not radii:
        raise ValueError("counts and radii must each hold at least one value")
    missing = [(R, N) for R in radii for N in counts if N not in stats.get(R, {})]
    if missing:
        raise ValueError(f"stats lacks (R, N) = {missing[:3]}")
    fig, axes = plt.subplots(2, len(radii), figsize=(7.5, 6.5), sharex=True,
                             sharey="row", squeeze=False)
    Ns = np.array(counts, dtype=float)
    for col, R in enumerate(radii):
        ax, bx, st = axes[0, col], axes[1, col], stats[R]
        for key, fmt, lab, off in (("mean", "o-", "mean of all runs", 0.97),
                                   ("not_lost", "^-", "mean of runs not lost", 1.03)):
            ok = [N for N in counts if st[N][key] is not None]
            v = np.array([st[N][key].value for N in ok])
            lo = np.array([st[N][key].lo for N in ok])
            hi = np.array([st[N][key].hi for N in ok])
            ax.errorbar(np.array(ok) * off, v, yerr=[v - lo, hi - v], fmt=fmt, ms=4,
                        capsize=2, label=lab)
        ax.plot(Ns, [st[N]["median"] for N in counts], "s--", ms=4, label="median run")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"R = {R / 1000:.1f} km")
        div, oth, tr = (np.array([st[N][k] for N in counts]) for k in ("div", "oth", "tr"))
        tot = div + oth + tr
        bx.bar(Ns, div, width=0.25 * Ns, color="C3", label="diverged")
        bx.bar(Ns, oth, width=0.25 * Ns, bottom=div, color="C5", label="still lost")
        bx.bar(Ns, tr, width=0.25 * Ns, bottom=div + oth, color="C4", label="transient")
        lo = np.array([st[N]["lost"].lo for N in counts])
        hi = np.array([st[N]["lost"].hi for N in counts])
        bx.errorbar(Ns, tot, yerr=[tot - lo, hi - tot], fmt="none", ecolor="k", capsize=2)
        bx.set_xlabel("number of particles N")
        for a in (ax, bx):
            a.axvline(600, color="0.6", ls=":", lw=1)
    axes[0, 0].set_ylabel("$E_{err,avg}$, whole run (m)")
    axes[1, 0].set_ylabel("fraction of runs lost")
    axes[0, 0].legend(fontsize=9, loc="upper right")
    axes[1, 0].legend(fontsize=9, loc="upper right")
    fig.tight_layout()
    return fig


def why_summary(columns, n_scans=250):
    """What C's window held in one cell of ``tbd-grid-why-*`` (06-verdict-grid, T14).

    ``columns``: the stored per-run columns ``onset``, ``n_t``, ``n_f``, ``n_e``,
    ``pre_f``, ``post_t`` and ``n_proc``; ``n_scans``: the scans of a run.  Returns a dict:
    ``target``, ``false``, ``empty`` (per run, the shares of the scans before the loss
    onset whose window held the target's detection, only false alarms, or nothing,
    :class:`~trackcore.stats.Estimate` over the runs with at least one such scan, ``None``
    when the share is the same in every run;
    ``shares`` the per-run arrays behind them, NaN for a run lost from its first scan),
    ``lost`` (runs lost), ``pre`` (false-alarm-only scans among the up to 10 before the
    onsets of the lost runs, and how many scans that is), ``post`` (scans from the onsets
    on whose window held the target's detection, and how many scans that is) and
    ``onset`` (the median onset scan of the lost runs, NaN if none).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios._tbd_book import why_summary
    >>> g = np.random.default_rng(0)
    >>> n_f, n_e = g.integers(0, 60, 50), g.integers(0, 20, 50)
    >>> cols = dict(onset=np.full(50, -1), n_t=250 - n_f - n_e, n_f=n_f, n_e=n_e,
    ...     pre_f=np.zeros(50), post_t=np.full(50, np.nan))
    >>> cols['onset'][0], cols['n_t'][0], cols['n_f'][0], cols['n_e'][0] = 20, 10, 8, 2
    >>> cols['pre_f'][0], cols['post_t'][0] = 6, 0.0
    >>> s = why_summary(cols)
    >>> print(f"{s['false']:.3f}", s["lost"], s["pre"], s["post"], s["onset"])
    0.112 [0.089, 0.137] 1 (6, 10) (0, 230) 20.0
    """
    import numpy as np

    from ..stats import mean_ci

    c = {k: np.asarray(columns[k]) for k in
         ("onset", "n_t", "n_f", "n_e", "pre_f", "post_t")}
    onset = c["onset"].astype(np.int64).reshape(-1)
    tot = (c["n_t"] + c["n_f"] + c["n_e"]).reshape(-1).astype(float)
    if not np.all(tot == np.where(onset >= 0, onset, n_scans)):
        raise ValueError("the scan classes must count every scan before the onset")
    with np.errstate(invalid="ignore", divide="ignore"):
        shares = {k: np.where(tot > 0, c[f"n_{k[0]}"].reshape(-1) / tot, np.nan)
                  for k in ("target", "false", "empty")}
    ok = tot > 0
    out = {k: mean_ci(v[ok]) if np.ptp(v[ok]) > 0 else None for k, v in shares.items()}
    lost = onset >= 0
    n_post = n_scans - onset[lost]
    out.update(
        shares=shares, lost=int(lost.sum()),
        pre=(int(c["pre_f"].reshape(-1)[lost].sum()), int(np.minimum(onset[lost], 10).sum())),
        post=(int(np.rint((c["post_t"].reshape(-1)[lost] * n_post).sum())),
              int(n_post.sum())),
        onset=float(np.median(onset[lost])) if lost.any() else float("nan"))
    return out
