"""Presentation helpers of the HPDA chapter (book/000-hpda): tables, figures and the
formatting of intervals, so that the notebooks show the experiments and not the
bookkeeping.

This module is private (its name starts with an underscore): it is not re-exported by
``trackcore.scenarios`` and is not part of the public API. Nothing here computes a
result of the book; every function formats or draws what the notebooks computed with
the public functions of ``trackcore``.
"""
from __future__ import annotations

import math
import textwrap

import numpy as np

from ..stats import Estimate, bootstrap_ci, mean_ci, rate_ci

__all__: list[str] = []  # private: nothing is re-exported


# --------------------------------------------------------------------------- 04-scenario

def table2_rows(p1, p2, configs) -> list[tuple[str, str, str]]:
    """Rows ``(parameter, source, value)`` of the reconstructed Table 2.

    ``p1``, ``p2``: :func:`~trackcore.scenarios.hpda_parameters` of cases 1 and 2;
    ``configs``: :func:`~trackcore.scenarios.hpda_tracker_configs` of case 1.
    """
    c1 = configs
    hp, phd, cl = c1["hpda"], c1["phd"], c1["clustering"]
    return [
        ("T [s]", "paper", f"{p1.T:g}"),
        ("P_D", "paper", f"{p1.pd:g} | {p2.pd:g}"),
        ("SNR rho (linear, flag: dB possible)", "paper", f"{p1.snr:g} | {p2.snr:g}"),
        ("lambda V (clutter per scan)", "paper",
         f"{p1.clutter_mean:g} | {p2.clutter_mean:g}"),
        ("amplitude threshold tau = -(1+rho) ln P_D (E18)", "derived",
         f"{p1.tau:.3f} | {p2.tau:.3f}"),
        ("V [m^2] (disc of radius 10 km)", "paper", f"{p1.area:.4g}"),
        ("sigma_xy [m/s^2]", "paper", f"{p1.sigma_a:g}"),
        ("[sigma_r m, sigma_theta deg]", "paper",
         f"[{p1.sigma_r:g}, {np.degrees(p1.sigma_theta):g}]"),
        ("a_m [m/s^2]", "paper (PHD, HPDA)", f"{p1.a_m:g}"),
        ("N, HPDA particles per confirmed track", "paper", f"{hp.n_particles}"),
        ("N, SMC-PHD particles per expected target", "paper / choice",
         f"{phd.n_per_target}"),
        ("N, clustering particles per track", "choice (guess)", f"{cl.n_particles}"),
        ("eps_w (printed eps_z, E17)", "paper", f"{cl.eps_w:g}"),
        ("eta = tau_b = tau_d, ROI window (printed tau = 2, E18)", "paper, flag",
         f"{cl.eta}"),
        ("B_k birth particles / P_birth", "paper, flag",
         f"{phd.n_birth} / {phd.birth_mass:g}"),
        ("P_c / P_t", "paper", f"{hp.p_confirm:g} / {hp.p_terminate:g}"),
        ("gate g^2 (P_G = 0.99)", "choice", f"{hp.gate_threshold:.4f}"),
        ("existence chain Pi11, Pi12", "choice", f"{hp.pi11:g}, {hp.pi12:g}"),
        ("candidate initial existence p_0", "choice", f"{hp.p_initial:g}"),
        ("tentative deletion below", "choice", f"{hp.p_delete:g}"),
        ("tentative filter", "choice",
         f"EKF (CV, sigma_a = {hp.tentative_sigma_a:g} m/s^2)"),
        ("mode transition matrix", "choice", str(hp.mode_tpm)),
        ("velocity prior of new tracks [m/s]", "choice",
         f"N(0, {hp.velocity_std:g}^2 I)"),
        ("PHD survival P_S", "choice", f"{phd.p_survival:g}"),
        ("JPDA hypotheses", "choice", "exact enumeration (limit of m-best)"),
        ("resampling", "choice", "systematic, every scan"),
    ]


# --------------------------------------------------------------------------- 05-single-runs

def flow_chart(steps, loop_from=1, loop_label="next scan"):
    """A top-down flow chart: each step is a box text or a tuple of texts drawn side by
    side; an arrow returns from the last box to box ``loop_from``. Returns the figure."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyBboxPatch

    from ..plotting import BOOK_WIDTH

    rows = [s if isinstance(s, tuple) else (s,) for s in steps]
    if not rows or not all(rows) or not all(isinstance(t, str) for r in rows for t in r):
        raise ValueError("steps must be a non-empty list of texts or tuples of texts")
    fig, ax = plt.subplots(figsize=(BOOK_WIDTH, 0.8 * len(rows) + 0.1))
    ax.set_xlim(0, 10)
    ax.set_ylim(-len(rows) + 0.6, 0.4)
    ax.axis("off")
    left, right = 0.2, 8.9
    centres = []
    for i, row in enumerate(rows):
        n = len(row)
        gap = 0.25
        w = (right - left - gap * (n - 1)) / n
        xs = [left + w / 2 + j * (w + gap) for j in range(n)]
        for x, text in zip(xs, row):
            box = FancyBboxPatch((x - w / 2, -i - 0.35), w, 0.7, boxstyle="round,pad=0.02",
                                 fc="#e8eff8", ec="#2b4c6f", lw=0.9)
            ax.add_patch(box)
            ax.text(x, -i, "\n".join(textwrap.wrap(text, int(w * 9.2))), ha="center",
                    va="center", fontsize=9, linespacing=1.15)
        centres.append(xs)
    arrow = {"arrowstyle": "-|>", "color": "#2b4c6f", "lw": 0.9, "shrinkA": 0, "shrinkB": 0}
    for i in range(len(rows) - 1):
        pairs = ([(x, centres[i + 1][0]) for x in centres[i]]
                 if len(centres[i + 1]) == 1
                 else [(centres[i][0], x) for x in centres[i + 1]])
        for x0, x1 in pairs:
            ax.annotate("", xy=(x1, -i - 1 + 0.37), xytext=(x0, -i - 0.37),
                        arrowprops=arrow)
    back = {"arrowstyle": "-|>", "color": "#9b2d2d", "lw": 0.9, "shrinkA": 0, "shrinkB": 0}
    y0, y1 = -len(rows) + 1, -loop_from
    ax.plot([right + 0.05, 9.35, 9.35], [y0, y0, y1], color="#9b2d2d", lw=0.9)
    ax.annotate("", xy=(right + 0.05, y1), xytext=(9.35, y1), arrowprops=back)
    ax.text(9.6, (y0 + y1) / 2, loop_label, rotation=90, ha="center", va="center",
            fontsize=9, color="#9b2d2d")
    return fig


def truth_lines(ax, truth):
    """Draw the true tracks of ``truth`` (an :class:`~trackcore.scenarios.HpdaTruth`)
    as wide grey lines with the sensor, and frame the axes around them."""
    for t in range(truth.alive.shape[1]):
        xy = truth.states[truth.alive[:, t], t, :2]
        ax.plot(xy[:, 0], xy[:, 1], color="0.75", lw=5, solid_capstyle="round", zorder=1)
    ax.plot([], [], color="0.75", lw=5, label="truth")
    ax.plot(0, 0, "k^", ms=6, label="sensor")
    xy = truth.states[truth.alive][:, :2]
    lo, hi = xy.min(axis=0) - 700, xy.max(axis=0) + 700
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def track_segments(run):
    """``(id, scans, xy)`` of every track of a tracker run (``ids`` ``(K, n)``, -1 for
    none; ``estimates`` ``(K, n, >=2)``), longest-lived first."""
    ids = np.asarray(run.ids)
    segs = []
    for tid in np.unique(ids[ids >= 0]):
        ks, cs = np.nonzero(ids == tid)
        segs.append((tid, ks, run.estimates[ks, cs, :2]))
    return sorted(segs, key=lambda s: -len(s[1]))


def _rate(k, n) -> str:
    return f"{rate_ci(int(k), int(n)):.2f}"


LINK_READINGS = (("clustering_literal", "literal"), ("clustering", "strong"))


def link_rate_table(rates, bins):
    """The link and ROI rates of the clustering hybrid by target range, with their 95 %
    Wilson intervals.

    ``rates[case, reading]`` (cases 1, 2; readings ``clustering_literal`` and
    ``clustering``) are the summed counts of
    :func:`~trackcore.trackers.clustering_link_rates` (``pairs``, ``links``,
    ``windows``, ``rois`` per range bin); ``bins`` names the range bins.
    Returns ``(rows, glued)``: the table rows and the chapter's glued values by key.
    """
    lit, strong = rates[1, "clustering_literal"], rates[1, "clustering"]
    rows = []
    for b, name in enumerate(bins):
        rows.append((name, int(lit["pairs"][b]), _rate(lit["links"][b], lit["pairs"][b]),
                     _rate(strong["links"][b], strong["pairs"][b]))
                    + tuple(_rate(rates[c, rd]["rois"][b], rates[c, rd]["windows"][b])
                            for c in (1, 2) for rd, _ in LINK_READINGS))
    glued = {}
    for case in (1, 2):
        for rd, tag in LINK_READINGS:
            t = rates[case, rd]
            glued[f"hpda_roi_rate_{tag}_{case}"] = _rate(t["rois"].sum(), t["windows"].sum())
    for rd, tag in LINK_READINGS:
        t = rates[1, rd]
        glued[f"hpda_link_rate_{tag}"] = _rate(t["links"].sum(), t["pairs"].sum())
        glued[f"hpda_link_rate_{tag}_near"] = _rate(t["links"][0], t["pairs"][0])
        glued[f"hpda_link_rate_{tag}_far"] = _rate(t["links"][-1], t["pairs"][-1])
    return rows, glued


LINK_HEADERS = ("target range", "pairs", "link, literal", "link, strong",
                "ROI case 1, literal", "ROI case 1, strong", "ROI case 2, literal",
                "ROI case 2, strong")


# --------------------------------------------------------------------------- 06-monte-carlo

MC_KEYS = ("e", "s", "abs", "rmse", "ospa", "false", "conf", "term")
"""Glue-key parts of the entries of :func:`mc_row`, in order."""

MC_HEADERS = ("e", "s", "mean abs(N_hat − N)", "count RMSE", "OSPA [m]",
              "false tracks / scan", "confirmation delay [scans]",
              "termination delay [scans]")
"""Column headers of the entries of :func:`mc_row`, in order."""


def per_run_delay(x):
    """Per-run mean of the delays ``x`` ``(n_runs, n_targets)`` over the targets they are
    defined for (NaN elsewhere); runs without any defined delay are left out."""
    x = np.asarray(x, dtype=float)
    if x.ndim != 2:
        raise ValueError(f"x must be 2-D (runs, targets), got shape {x.shape}")
    keep = ~np.all(np.isnan(x), axis=1)
    return np.nanmean(x[keep], axis=1)


def mc_row(e: Estimate, s: Estimate, metrics, conf, term) -> tuple[str, ...]:
    """One tracker's entries of the Monte Carlo tables, formatted with their 95 %
    intervals: ``e`` and ``s`` (from :func:`~trackcore.scenarios.count_error_ci`), the
    per-run absolute count error, count RMSE, OSPA and false tracks of ``metrics``
    (arrays by name, as in :data:`~trackcore.scenarios.HPDA_METRICS`) and the per-run
    confirmation and termination delays ``conf``, ``term`` ("—" for fewer than two
    runs)."""
    m = metrics
    rmse = bootstrap_ci(lambda x: np.sqrt(x.mean(axis=1)), m["sq_count_error"])
    return (
        f"{e:.3f}",
        f"{s:+.3f}",
        f"{mean_ci(m['abs_count_error']):.3f}",
        f"{rmse:.2f}",
        f"{mean_ci(m['ospa']):.0f}",
        f"{mean_ci(m['false_tracks']):.3f}",
        f"{mean_ci(conf):.1f}" if len(conf) > 1 else "—",
        f"{mean_ci(term):.1f}" if len(term) > 1 else "—",
    )


def ranking_verdict(*diffs: Estimate) -> str:
    """'met' when every paired interval lies below 0, 'missed' when one lies above,
    'tie' otherwise."""
    if not diffs or not all(isinstance(d, Estimate) for d in diffs):
        raise TypeError("ranking_verdict needs one Estimate or more")
    if all(d.hi < 0 for d in diffs):
        return "met"
    return "missed" if any(d.lo > 0 for d in diffs) else "tie"


def labelled(values, names, labels, fmt="+.3f") -> str:
    """``"label value; label value"`` for values (e.g. intervals) of the named trackers."""
    return "; ".join(f"{labels[n]} {format(v, fmt)}" for v, n in zip(values, names))


def gospa_parts(metrics, names):
    """Mean GOSPA² components (localisation, missed, false) per scan, in 10³ m², of
    ``metrics[name]`` for each of ``names``: an array ``(len(names), 3)``."""
    return np.array([[metrics[n][f"gospa_{p}"].mean()
                      for p in ("localisation", "missed", "false")] for n in names]) / 1e3




# ------------------------------------------------------------------- 07, 08: intervals

NO_INTERVAL = "(no interval)"


def interval_text(fn, fmt: str = "+.3f") -> str:
    """``fn()``'s interval formatted with ``fmt``, or :data:`NO_INTERVAL` when it has none.

    ``fn`` computes an :class:`~trackcore.stats.Estimate`. It has none when ``fn`` raises
    ``ValueError`` (too few runs, a degenerate sample) or when the helper fell back to a
    basic interval because the estimate lies outside its own bootstrap distribution: the
    book never widens an interval to contain its estimate.
    """
    try:
        est = fn()
    except ValueError:
        return NO_INTERVAL
    return NO_INTERVAL if "basic" in est.method else format(est, fmt)


# ------------------------------------------------- 06, 07: the count measures of a pair
def per_run_error(counts, n_true):
    """Per run, the mean over scans of ``|N_hat_k - N_k|``: ``counts`` is
    ``(runs, scans)``, ``n_true`` ``(scans,)``; returns ``(runs,)``."""
    counts = np.asarray(counts, dtype=float)
    n_true = np.asarray(n_true, dtype=float)
    if counts.ndim != 2 or counts.shape[1] != n_true.shape[0]:
        raise ValueError(f"counts must be (runs, {n_true.shape[0]}), got {counts.shape}")
    return np.abs(counts - n_true).mean(axis=1)


def own_measures(x, n_true):
    """One tracker's count error, as zero-argument callables (for :func:`interval_text`):
    ``{"e": e, "ebc": the bias-corrected e}`` of ``count_error_ci``."""
    from .hpda_scenario import count_error_ci

    return {"e": lambda: count_error_ci(x, n_true),
            "ebc": lambda: count_error_ci(x, n_true, kind="e-bc")}


def paired_measures(h, x, n_true):
    """``h`` minus ``x`` on the same runs, as zero-argument callables (for
    :func:`interval_text`): ``{"de": paired e, "debc": paired bias-corrected e,
    "dabs": paired per-run count error}``."""
    from ..stats import paired_diff_ci
    from .hpda_scenario import count_error_ci

    return {"de": lambda: count_error_ci(h, n_true, versus=x),
            "debc": lambda: count_error_ci(h, n_true, kind="e-bc", versus=x),
            "dabs": lambda: paired_diff_ci(per_run_error(h, n_true),
                                           per_run_error(x, n_true))}


def paired_typical(h, x):
    """Beside a mean paired difference, what a typical run shows: for per-run values
    ``h`` and ``x`` on the same runs, ``(median, wins)`` -- the BCa interval of the median
    of ``h - x`` and the Wilson interval of the share of runs with ``h < x`` (a tie is no
    win), both :class:`~trackcore.stats.Estimate`.

    Examples
    --------
    >>> import numpy as np
    >>> h, x = np.array([0.0, 1.0, 1.0, 1.0]), np.array([3.0, 0.5, 0.5, 0.5])
    >>> med, wins = paired_typical(np.tile(h, 10), np.tile(x, 10))
    >>> med.value, wins.value
    (0.5, 0.25)
    """
    h = np.asarray(h, dtype=float)
    x = np.asarray(x, dtype=float)
    if h.shape != x.shape or h.ndim != 1:
        raise ValueError(f"h and x must be paired 1-D samples, got {h.shape} and {x.shape}")
    d = h - x
    med = bootstrap_ci(lambda b: np.median(b, axis=1), d)
    return med, rate_ci(d < 0, d.size)


# ---------------------------------------------------- 05: a stored run, re-simulated
def rerun_stored(results, i, **extra):
    """Run ``i`` of a stored experiment re-simulated by the experiment's own trial, from
    the store's master seed and the run index (the generator ``montecarlo.run`` hands
    run ``i``), with ``extra`` keyword arguments for the trial (e.g.
    ``keep_estimates=True``); raises ``VerificationError`` unless the run's row equals
    the stored one (:func:`~trackcore.experiments._core.compare_rows`). Returns the
    trial's output."""
    from ..core.rng import spawn_seed_sequences
    from ..experiments._core import compare_rows

    n = int(results.runs)
    if not 0 <= int(i) < n:
        raise ValueError(f"run index must lie in [0, {n}), got {i!r}")
    e, config = results.experiment, results.config
    args, kwargs = e.call(config)
    rng = np.random.default_rng(spawn_seed_sequences(results.meta["seed"], n)[int(i)])
    out = e.trial(rng, *args, **kwargs, **extra)
    compare_rows(results.row(int(i)), e.extract(out, config), int(i))
    return out


# --------------------------------------------------------- 04: the truth's printed table
#: Table 1's death positions of the constant-velocity truth (m) and of variant B
#: (x, y in m, vx, vy in m/s; printed to 0.1 m and 0.001 m/s), per target.
DEATHS_CV = ((0, -3000), (2500, 2500), (-3750, 2500), (500, -1000), (1750, 1750),
             (4000, -3000))
DEATHS_B = ((-1712.7, -2179.0, -0.228, 1.788), (213.7, 2275.7, -0.832, -1.144),
            (-3236.1, 4619.0, 0.868, 0.704), (-1279.3, -769.9, -1.021, -0.720),
            (3114.9, 1274.4, 0.333, -2.095), (2515.8, -1886.3, -1.458, -0.353))


def min_separation(truth):
    """The smallest distance (m) between two live targets of ``truth`` over all scans
    (``inf`` when no two targets live at once)."""
    xy, alive = truth.states[..., :2], truth.alive
    best = math.inf
    n = alive.shape[1]
    for i in range(n):
        for j in range(i + 1, n):
            both = alive[:, i] & alive[:, j]
            if both.any():
                d = np.hypot(*(xy[both, i] - xy[both, j]).T)
                best = min(best, float(np.min(d)))
    return best
