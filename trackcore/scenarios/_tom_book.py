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
