"""Presentation helpers of the TOM-IMM chapter (book/001-tom-imm), so that the
notebooks show the checks and experiments and not the bookkeeping.

This module is private (its name starts with an underscore): it is not re-exported by
``trackcore.scenarios`` and is not part of the public API. Nothing here computes a
result of the book; the notebooks use these helpers to check the public functions of
``trackcore`` against independent routes.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from trackcore.models import (
    tom_process_noise,
    tom_rotation,
    tom_transition,
    van_loan_discretize,
)

__all__: list[str] = []  # private: nothing is re-exported

_G = np.vstack([np.zeros((2, 2)), np.eye(2)])


def _f_cont(phi: float) -> np.ndarray:
    """Continuous-time drift of the TOM state (position, velocity in (f, s) axes)."""
    F = np.zeros((4, 4))
    F[:2, 2:] = tom_rotation(phi)
    return F


def _rel_err(A: np.ndarray, B: np.ndarray) -> float:
    return float(np.max(np.abs(A - B)) / np.max(np.abs(B)))


def tom_discretization_errors(
    phi: float, T: float, sf: float, ss: float
) -> tuple[float, float, float]:
    """Errors of the TOM discretization against independent matrix-exponential routes.

    Returns ``(e_phi, e_dwna, e_cwna)``: the largest absolute difference of
    ``tom_transition`` from ``expm(F T)``; the relative difference of the DWNA
    ``tom_process_noise`` from ``Gamma S Gamma^T`` with ``Gamma`` taken from the
    exponential of the augmented matrix ``[[F, G], [0, 0]]``; the relative difference
    of the CWNA noise from Van Loan's discretization of ``G S G^T``.
    """
    if not T > 0:
        raise ValueError(f"T must be positive, got {T}")
    if not (sf >= 0 and ss >= 0):
        raise ValueError(f"sf and ss must be non-negative, got {sf}, {ss}")
    S = np.diag([sf**2, ss**2])
    F = _f_cont(phi)
    e_phi = float(np.max(np.abs(tom_transition(phi, T) - scipy.linalg.expm(F * T))))
    M = np.zeros((6, 6))
    M[:4, :4] = F
    M[:4, 4:] = _G
    Gamma = scipy.linalg.expm(M * T)[:4, 4:]
    e_d = _rel_err(tom_process_noise(phi, T, sf, ss), Gamma @ S @ Gamma.T)
    _, Q_vl = van_loan_discretize(F, _G @ S @ _G.T, T)
    e_c = _rel_err(tom_process_noise(phi, T, sf, ss, kind="cwna"), Q_vl)
    return e_phi, e_d, e_c


def below_or_sci(e: float, floor: str) -> str:
    """``"< floor"`` when ``e`` is below ``float(floor)``, else ``e`` as ``"1.2e-08"``."""
    return f"< {floor}" if e < float(floor) else f"{e:.1e}"


def filterpy_imm_run(models, zs, x0, P0, R):
    """Run filterpy's ``IMMEstimator`` (an independent IMM) over the scans ``zs``.

    ``models`` is a trackcore IMM model set (``embed``, ``init_var``, ``F``, ``Q``,
    ``H``, ``mu0``, ``transition``); the state ``x0``, ``P0`` is embedded in each
    model's state as ``imm_pdaf_track`` does. Each scan is one measurement (``P_D = 1``,
    no clutter). Returns the combined states, covariances and model probabilities,
    one row per scan.
    """
    from filterpy.kalman import IMMEstimator, KalmanFilter

    zs = np.asarray(zs, dtype=float)
    if zs.ndim != 2 or zs.shape[1] != 2:
        raise ValueError(f"zs must have shape (K, 2), got {zs.shape}")
    xm = models.embed @ x0
    Pm = models.embed @ P0 @ models.embed.T + np.diag(models.init_var)
    filters = []
    for j in range(models.F.shape[0]):
        kf = KalmanFilter(dim_x=xm.size, dim_z=2)
        kf.x, kf.P = xm.copy(), Pm.copy()
        kf.F, kf.Q = models.F[j].copy(), models.Q[j].copy()
        kf.H, kf.R = models.H.copy(), np.array(R, dtype=float)
        filters.append(kf)
    imm = IMMEstimator(filters, models.mu0.copy(), models.transition.copy())
    xs, Ps, mus = [], [], []
    for z in zs:
        imm.predict()
        imm.update(z)
        xs.append(imm.x.copy())
        Ps.append(imm.P.copy())
        mus.append(imm.mu.copy())
    return np.array(xs), np.array(Ps), np.array(mus)


def max_rel_diff(a, b) -> float:
    """Largest ``|a - b| / max(|b|, 1)`` entry: relative where ``|b| > 1``, else
    absolute."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"a and b must have the same shape, got {a.shape}, {b.shape}")
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1.0)))


def ks_distance(a) -> float:
    """Kolmogorov-Smirnov distance of the sample ``a`` from the normal law with its
    own mean and standard deviation."""
    from scipy import stats

    a = np.asarray(a, dtype=float)
    if a.ndim != 1 or a.size < 2:
        raise ValueError(f"a must be a 1-D sample of at least 2 values, got {a.shape}")
    return float(stats.kstest(a, "norm", args=(a.mean(), a.std())).statistic)


def acceleration_seed_stats(rng, rng_n) -> dict[str, float]:
    """One seed's acceleration statistics of the random-manoeuvre scenarios.

    From ``rng``: scenario 1 (``a1``), scenario 2 (``a2``) and a white-noise pair of
    ``a2``'s length, in that order; from ``rng_n``: scenario 2 without the speed clip
    (the ablation). Returns the variances of ``a_f, a_s, a_x, a_y`` of ``a2``, the
    largest ``|ρ|`` of the cross-correlation of each pair, ``|mean a_s|``, the KS
    distances from normal (``ks_*``, ablation ``n_ks_*``) and the ablation's top speed.
    Checks the trace identity (the mean square acceleration does not depend on the
    axes) and raises ``AssertionError`` if it fails.
    """
    from trackcore.scenarios import (
        cross_correlation_coefficient,
        random_manoeuvre_turn,
        random_manoeuvre_xy,
    )

    def max_rho(A):
        return float(np.abs(cross_correlation_coefficient(A[:, 0], A[:, 1])[1]).max())

    a3 = random_manoeuvre_turn(rng_n, speed_limits=(1.0, 5000.0))
    a1 = random_manoeuvre_xy(rng)
    a2 = random_manoeuvre_turn(rng)
    xy, fs = a2.accel_xy, a2.accel_fs
    m2xy, m2fs = (xy**2).mean(axis=0).sum(), (fs**2).mean(axis=0).sum()
    assert abs(m2xy - m2fs) < 1e-9 * m2xy, f"trace identity: {m2xy} vs {m2fs}"
    wn = rng.normal(size=(xy.shape[0], 2))
    return {
        "var_f": float(fs[:, 0].var()),
        "var_s": float(fs[:, 1].var()),
        "var_x": float(xy[:, 0].var()),
        "var_y": float(xy[:, 1].var()),
        "rho_xy": max_rho(xy),
        "rho_fs": max_rho(fs),
        "rho_white": max_rho(wn),
        "mean_s": float(abs(fs[:, 1].mean())),
        "ks_x1": ks_distance(a1.accel_xy[:, 0]),
        "ks_f1": ks_distance(a1.accel_fs[:, 0]),
        "ks_x2": ks_distance(xy[:, 0]),
        "ks_y2": ks_distance(xy[:, 1]),
        "ks_f2": ks_distance(fs[:, 0]),
        "ks_s2": ks_distance(fs[:, 1]),
        "n_ks_x": ks_distance(a3.accel_xy[:, 0]),
        "n_ks_f": ks_distance(a3.accel_fs[:, 0]),
        "n_ks_y": ks_distance(a3.accel_xy[:, 1]),
        "n_ks_s": ks_distance(a3.accel_fs[:, 1]),
        "n_vmax": float(np.hypot(*a3.velocity.T).max()),
    }


# --------------------------------------------------------------------------- 001-05
def over(max_err2, threshold):
    """Failures from the largest squared error per run: error > ``threshold`` (m) at
    some time, as ``position_failures`` gives from the error series."""
    if not threshold > 0:
        raise ValueError(f"threshold must be positive, got {threshold}")
    return np.asarray(max_err2) > threshold**2


#: The failure definitions of the chapter's ``failure`` reading, in its order: key,
#: registry value.
FAILURE_DEFS = (
    ("f200", "error > 200 m at some time"),
    ("f300", "error > 300 m at some time"),
    ("f500", "error > 500 m at some time"),
    ("f1000", "error > 1000 m at some time"),
    ("lost", "still > 200 m at t = 90 s"),
    ("miss", "3 gate misses in a row"),
)


def failure_masks(max_err2, last_err2, streak):
    """Every failure definition of :data:`FAILURE_DEFS` as a bool array of the shape
    of ``max_err2``: thresholds on the largest squared error, a lost track from the
    last one, and 3 gate misses in a row from the longest streak (of scans outside
    every gate, or without a gate of NIS above the 0.99 gate's threshold)."""
    max_err2, last_err2 = np.asarray(max_err2), np.asarray(last_err2)
    streak = np.asarray(streak)
    if not max_err2.shape == last_err2.shape == streak.shape:
        raise ValueError(
            f"max_err2, last_err2 and streak must have one shape, got {max_err2.shape}, "
            f"{last_err2.shape}, {streak.shape}"
        )
    out = {k: over(max_err2, float(k[1:])) for k, _ in FAILURE_DEFS[:4]}
    out["lost"] = last_err2 > 200.0**2
    out["miss"] = streak >= 3
    return out


def step_word(est, ref=1.0):
    """``"better"`` (lower) when the interval lies below ``ref``, ``"worse"`` when
    above, otherwise ``"tie"``: the ladder's reading of one step's change."""
    if est.hi < ref:
        return "better"
    if est.lo > ref:
        return "worse"
    return "tie"


def ladder_steps(mse, failed, steps, singer=0):
    """Each step of a ladder against the step before on the same runs.

    ``mse`` (runs, filters, 3) window mean squares, ``failed`` (runs, filters) bool,
    ``steps`` the filter indices in ladder order. Returns one dict per step: the
    paired RMSE ratios to the step before (``"total"``, ``"man"``) and to Singer
    (``"vs_singer"``, ``"vs_singer_man"``), the failure rate (``"fail"``) and the
    paired failure difference with the step before (``"fail_diff"``, a
    ``FailureComparison``); the first step has no ``"total"``, ``"man"`` or
    ``"fail_diff"``."""
    from trackcore.scenarios import failure_comparison, rmse_ratio_mse
    from trackcore.stats import rate_ci

    mse, failed = np.asarray(mse), np.asarray(failed)
    if mse.ndim != 3 or failed.shape != mse.shape[:2]:
        raise ValueError(
            f"mse must be (runs, filters, 3) and failed (runs, filters), got "
            f"{mse.shape}, {failed.shape}"
        )
    if len(steps) < 2:
        raise ValueError("a ladder needs at least 2 steps")
    out = []
    for i, f in enumerate(steps):
        d = {
            "vs_singer": rmse_ratio_mse(mse, failed, f, singer),
            "vs_singer_man": rmse_ratio_mse(mse, failed, f, singer, window="manoeuvring"),
            "fail": rate_ci(failed[:, f], failed.shape[0]),
        }
        if i:
            g = steps[i - 1]
            d["total"] = rmse_ratio_mse(mse, failed, f, g)
            d["man"] = rmse_ratio_mse(mse, failed, f, g, window="manoeuvring")
            d["fail_diff"] = failure_comparison(failed, f, g)
        out.append(d)
    return out


def heading_ratios(mse, masks, alternatives, chord=0):
    """Total RMSE of each alternative heading over the chord TOM's, on the same runs,
    under each failure definition: ``{(alt, def): Estimate or None}`` (None when a
    filter survives fewer than 2 runs, so that no ratio exists). ``mse`` (runs,
    filters, 3); ``masks`` from :func:`failure_masks`; ``alternatives`` filter
    indices."""
    from trackcore.scenarios import rmse_ratio_mse

    out = {}
    for key, fl in masks.items():
        for a in alternatives:
            try:
                out[a, key] = rmse_ratio_mse(mse, fl, a, chord)
            except ValueError:
                out[a, key] = None
    return out


def scaled(est, c):
    """An interval divided by a constant (e.g. ours / the paper's number)."""
    from trackcore.stats import Estimate

    if not c > 0:
        raise ValueError(f"c must be positive, got {c}")
    return Estimate(est.value / c, est.lo / c, est.hi / c, est.level, est.n, est.method)


def verdict_word(est, claim, lo=None, hi=None):
    """The scorecard's verdict on a ratio claim: the claim's value inside the interval,
    the tolerance band met, or the claim's value excluded."""
    from trackcore.stats import band_verdict

    if est.contains(claim):
        return "reproduced"
    if band_verdict(est, lo, hi) == "met":
        return "reproduced within tolerance"
    return "not reproduced"


def grid_scores(E_points, E_singer):
    """A grid's scores against Singer on the same runs: ``(points, 3)`` RMSE ratios
    (total, manoeuvring, non-manoeuvring) over the runs neither the point nor Singer
    failed, and ``(points,)`` failure rates (error above 200 m). ``E_points`` (runs,
    points, 90) and ``E_singer`` (runs, 90) squared errors."""
    from trackcore.scenarios import position_failures, window_mse

    return grid_scores_mse(
        window_mse(E_points),
        position_failures(E_points, 200.0),
        window_mse(E_singer),
        position_failures(E_singer, 200.0),
    )


def grid_scores_mse(M_points, fl_points, M_singer, fl_singer):
    """:func:`grid_scores` from stored rows: the window mean squares ``M_points``
    (runs, points, 3) and ``M_singer`` (runs, 3), and the failures ``fl_points`` (runs,
    points) and ``fl_singer`` (runs,) (the same numbers, bit for bit)."""
    M_points, M_singer = np.asarray(M_points), np.asarray(M_singer)
    fl, fl_singer = np.asarray(fl_points, dtype=bool), np.asarray(fl_singer, dtype=bool)
    if M_points.ndim != 3 or M_points.shape[-1] != 3 or fl.shape != M_points.shape[:2]:
        raise ValueError(
            f"M_points must be (runs, points, 3) and fl_points (runs, points), got "
            f"{M_points.shape} and {fl.shape}"
        )
    if M_singer.shape != (M_points.shape[0], 3) or fl_singer.shape != fl.shape[:1]:
        raise ValueError(
            f"M_singer must be (runs, 3) and fl_singer (runs,), got {M_singer.shape} "
            f"and {fl_singer.shape}"
        )
    ok = ~fl & ~fl_singer[:, None]
    num = (M_points * ok[..., None]).sum(axis=0)
    den = (M_singer[:, None, :] * ok[..., None]).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.sqrt(num / den)
    return np.where(np.isfinite(score), score, np.inf), fl.mean(axis=0)


def anatomy_columns(pos_err2, target_gated, threshold=200.0):
    """Per run and filter, what the failure anatomy needs: the largest and the last
    squared position error, the onset (first time, s, the error exceeds
    ``threshold`` m; NaN if never, as :func:`~trackcore.scenarios.failure_anatomy`)
    and the first time the target measurement fell outside every gate (inf if
    never). ``pos_err2`` (..., 90) for t = 1..90, ``target_gated`` (..., 89) for
    t = 2..90 (1 gated, 0 outside every gate, -1 missed)."""
    from trackcore.scenarios import failure_anatomy

    e, g = np.asarray(pos_err2, dtype=np.float64), np.asarray(target_gated)
    if e.shape[:-1] != g.shape[:-1] or e.shape[-1] != g.shape[-1] + 1:
        raise ValueError(
            f"pos_err2 (..., T) and target_gated (..., T - 1) must match, got "
            f"{e.shape} and {g.shape}"
        )
    an = failure_anatomy(e, threshold)
    miss = g == 0
    first = np.where(miss.any(axis=-1), 2.0 + np.argmax(miss, axis=-1), np.inf)
    return {
        "max_err2": e.max(axis=-1),
        "last_err2": e[..., -1],
        "onset": an.onset,
        "first_miss": first,
    }


def local_search(memo, start, ladders, score, key, max_rounds=8):
    """From ``start``, score the points one ladder step away along each axis (new
    ones in one batch by ``score``) and move to the best neighbour while it lowers
    ``key``. ``memo`` maps each scored point to its scores. Returns the final point."""
    point = start
    for _ in range(max_rounds):
        nbrs = []
        for a, lad in enumerate(ladders):
            i = lad.index(point[a])
            for j in (i - 1, i + 1):
                if 0 <= j < len(lad):
                    nbrs.append(point[:a] + (lad[j],) + point[a + 1 :])
        score([q for q in nbrs if q not in memo])
        best = min(nbrs, key=lambda q: key(memo[q]))
        if key(memo[best]) >= key(memo[point]):
            return point
        point = best
    return point


def velocity_on_table1(stored):
    """The velocity-heading variant's best point over Singer, total, on Table 1's
    runs at P_G = 0.9999 (03's stores: Singer, CAR, TOM; tuned TOM, velocity)."""
    from trackcore.scenarios import rmse_ratio_mse

    gs, tg = stored["tom-imm-houles-gates"], stored["tom-imm-houles-tuned-gates"]
    M = np.concatenate([gs["window_mse"][:, 1], tg["window_mse"][:, 2]], axis=1)
    mx = np.concatenate([gs["max_err2"][:, 1], tg["max_err2"][:, 2]], axis=1)
    return rmse_ratio_mse(M, over(mx, 200.0), 4, 0)


def plot_one_at_a_time(sweep, params, windows, singer_fail, width):
    """Figure of 05's one-at-a-time sweep: per parameter, the TOM/Singer ratios of each
    window (left) and the TOM's failure rate (right), with their intervals.

    ``sweep``: ``(label, value, [ratio per window], failure rate)`` rows, estimates with
    ``value``, ``lo``, ``hi``; ``params``: the ``(label, key, values)`` rows of the sweep;
    ``windows``: the window names (3); ``singer_fail``: Singer's failure-rate estimate on
    the same runs; ``width``: the figure width (in). Returns the figure.
    """
    import matplotlib.pyplot as plt

    if len(windows) != 3:
        raise ValueError(f"windows must name 3 windows, got {windows!r}")
    labels = {s[0] for s in sweep}
    if not params or not all(label in labels for label, _, _ in params):
        raise ValueError("every row of params needs rows of sweep with its label")
    fig, axes = plt.subplots(len(params), 2, figsize=(width, 10.0), squeeze=False)
    f_max = 100 * max(s[3].hi for s in sweep) * 1.05
    for (ax_r, ax_f), (label, _, _) in zip(axes, params):
        rs = [s for s in sweep if s[0] == label]
        x = np.array([s[1] for s in rs])
        dx = 0.012 * (x.max() - x.min())
        for w, (win, mk) in enumerate(zip(windows, ("o", "s", "^"))):
            v = np.array([[s[2][w].value, s[2][w].lo, s[2][w].hi] for s in rs]) * 100
            ax_r.errorbar(x + dx * (w - 1), v[:, 0], yerr=[v[:, 0] - v[:, 1],
                          v[:, 2] - v[:, 0]], fmt=mk + "-", capsize=2, label=win)
        ax_r.axhline(80, color="C3", ls="--", lw=1, label="claim: total ≤ 80 %")
        ax_r.set_ylabel("% of Singer")
        f_ = np.array([[s[3].value, s[3].lo, s[3].hi] for s in rs]) * 100
        ax_f.errorbar(x, f_[:, 0], yerr=[f_[:, 0] - f_[:, 1], f_[:, 2] - f_[:, 0]],
                      fmt="x-", color="0.3", capsize=2, label="TOM failures")
        ax_f.axhline(100 * singer_fail.value, color="C0", ls=":", lw=1.2,
                     label="Singer failures")
        ax_f.set_ylabel("failures (%)")
        ax_f.set_ylim(0, f_max)
        for ax in (ax_r, ax_f):
            ax.set_xticks(x, [f"{v:g}" for v in x])
            ax.set_xlabel(label)
    handles, labs = axes[0, 0].get_legend_handles_labels()
    h2, l2 = axes[0, 1].get_legend_handles_labels()
    fig.legend(handles + h2, labs + l2, loc="upper center", ncols=3, fontsize=9)
    plt.tight_layout(rect=(0, 0, 1, 0.95))
    return fig


def plot_tuning_grid(scores, grids, marked, singer_fail, width):
    """Figure of 05's joint tuning: each scored setting's total score against its
    failure rate on the grid seeds, the grid's points filled, the points past its
    edges open.

    ``scores``: ``{heading label: {setting: (total, manoeuvring, non, failure)}}``
    (fractions); ``grids``: ``{heading label: the grid's settings}``; ``marked``:
    ``(default setting of the first heading, [(heading label, best setting), ...])``;
    ``singer_fail``: Singer's failure rate (fraction); ``width``: figure width (in).
    Returns the figure.
    """
    import matplotlib.pyplot as plt

    if set(scores) != set(grids):
        raise ValueError(f"scores and grids must name the same headings, got "
                         f"{sorted(scores)} and {sorted(grids)}")
    default, best = marked
    first = next(iter(scores))
    if default not in scores[first] or any(q not in scores[h] for h, q in best):
        raise ValueError("every marked setting must be scored")
    fig, ax = plt.subplots(figsize=(width, 4.2))
    for (lab, m), mk in zip(scores.items(), ("o", "^", "s", "v")):
        g = np.array([m[q] for q in grids[lab]])
        ax.scatter(100 * g[:, 3], 100 * g[:, 0], s=18, marker=mk,
                   label=f"TOM grid ({lab})")
        ext = [q for q in m if q not in grids[lab]]
        if ext:
            e_ = np.array([m[q] for q in ext])
            ax.scatter(100 * e_[:, 3], 100 * e_[:, 0], s=22, marker=mk,
                       facecolors="none", edgecolors="0.3",
                       label=f"past the grid's edges ({lab})")
    d = scores[first][default]
    ax.scatter(100 * d[3], 100 * d[0], s=90, facecolors="none", edgecolors="k",
               label="chapter default")
    ax.scatter([100 * scores[h][q][3] for h, q in best],
               [100 * scores[h][q][0] for h, q in best], s=140, marker="*",
               color="C3", label="best total (its grid-seed score; fresh seeds: "
               "table below)")
    ax.axhline(80, color="C3", ls="--", lw=1, label="claim: total ≤ 80 %")
    ax.axvline(100 * singer_fail, color="0.5", ls=":", lw=1,
               label="Singer's failure rate")
    ax.set_xlabel("TOM failure rate on the 200 grid seeds (%)")
    ax.set_ylabel("TOM total RMSE, % of Singer\n(runs neither failed)")
    ax.set_ylim(76, None)
    # below the axes: at a readable size the legend is wider than the data's empty corner
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize=9, ncols=2)
    return fig
