"""IMM-PDAF for one target in clutter, with the model sets of Yoon & Ko (sec. 4.3).

Three model sets share one numba whole-run kernel:

* **Singer-IMM** (as Houles & Bar-Shalom 1989): constant velocity embedded in
  the 6-state ``[x, y, vx, vy, ax, ay]`` (acceleration forced to 0) plus two
  Singer models (``tau`` = 20 s / 5 s, ``sigma_m`` = 15 / 60 m/s^2).
* **CAR-IMM** (constant angle-rate, Dufour & Mariton): state ``[x, y, vx, vy]``,
  CV plus exact coordinated-turn models at ``omega = +-0.14`` rad/s.
* **TOM-IMM** (the paper): three target-oriented models ``[x, y, v_f, v_s]``
  with lateral-velocity inputs ``u = 0, +70, -70`` m/s and the cycle of the
  chapter spec (sec. 6): heading from the chord of the last two combined
  position estimates (eq. 8, ``atan2``), mixing, ``v_s <- u_j``, prediction,
  PDA update, combination, then ``v_s <- 0`` in every model.

One scan of the IMM-PDAF (Blom & Bar-Shalom 1988; Houles & Bar-Shalom 1989):
mixing with the Markov matrix; per-model prediction; chi-square gates per model
and the validated set = their union; per-model parametric PDA on the validated
set (``beta0 ∝ lambda (1 - P_D P_G)``, ``beta_j ∝ P_D N(nu_j; 0, S)``) with the
covariance-spread update; model likelihood ``log(lambda (1 - P_D P_G) +
P_D sum_j N(nu_j; 0, S))`` (common factors dropped); model probabilities in
log space; moment-matched combination.  Gating, PDA and Kalman prediction are
the kernels of :mod:`trackcore.association` and :mod:`trackcore.filters`.

Outputs are reported in Cartesian ``[x, y, vx, vy]`` whatever the model state.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..association.gating import gate_threshold, mahalanobis_gate_kernel
from ..association.pda import pda_betas_kernel, pda_update_kernel
from ..core.validation import (as_offsets, as_array, as_covariance, as_measurements, as_nonnegative,
                               as_positive, as_probabilities, as_probability, as_scalar,
                               as_square_matrix, as_vector)
from ..filters.imm import imm_combine_kernel, imm_mix_kernel, imm_mode_update_kernel
from ..filters.kalman import cholesky_lower_kernel, kf_predict_kernel
from ..models.motion import (coordinated_turn_transition, cv_process_noise, kron_axes,
                             singer_process_noise, singer_transition)
from ..models.tom import chord_heading_kernel, tom_process_noise_kernel, tom_transition_kernel

__all__ = [
    "IMMModelSet",
    "IMMPDAFResult",
    "markov_matrix",
    "singer_imm_model_set",
    "car_imm_model_set",
    "tom_imm_model_set",
    "two_point_init",
    "pack_scans",
    "imm_pdaf_track",
    "imm_pdaf_track_packed",
    "imm_pdaf_run_kernel",
]

_LOG_2PI = math.log(2.0 * math.pi)


class IMMModelSet(NamedTuple):
    """A set of ``r`` linear models for the IMM-PDAF (build with the ``*_model_set`` functions).

    ``F``, ``Q`` (r, n, n) are used as given for ``tom=False``; for ``tom=True``
    they are recomputed every scan from the chord heading with ``T``,
    ``var_f``, ``var_s`` (r,) and the lateral inputs ``u`` (r,).  ``H`` (2, n)
    picks the position.  ``embed`` (n, 4) maps a Cartesian ``[x, y, vx, vy]``
    initial estimate into the model state (TOM: then rotated by the initial
    heading) and ``init_var`` (n,) is added to the diagonal of the embedded
    initial covariance.  ``out_index`` (4,) gives the state entries of
    ``[x, y, vx, vy]`` (TOM: ``[x, y, v_f, v_s]``, rotated back).
    """
    name: str
    labels: tuple
    F: np.ndarray
    Q: np.ndarray
    H: np.ndarray
    transition: np.ndarray   # Markov matrix Pi[i, j] = P(model j at k | model i at k-1)
    mu0: np.ndarray
    embed: np.ndarray
    init_var: np.ndarray
    out_index: np.ndarray
    tom: bool
    T: float
    u: np.ndarray
    var_f: np.ndarray
    var_s: np.ndarray
    cwna: bool


class IMMPDAFResult(NamedTuple):
    """Output of :func:`imm_pdaf_track` over ``K`` scans (Cartesian ``[x, y, vx, vy]``)."""
    x: np.ndarray        # (K, 4) combined estimate
    P: np.ndarray        # (K, 4, 4) combined covariance
    mu: np.ndarray       # (K, r) posterior model probabilities
    z_pred: np.ndarray   # (K, 2) mixture predicted measurement (before the update)
    S: np.ndarray        # (K, 2, 2) mixture innovation covariance (before the update)
    gated: np.ndarray    # (N,) bool: measurement in the union of the model gates (packed rows)
    heading: np.ndarray  # (K,) heading used for the prediction (TOM; NaN otherwise)


# ---------------------------------------------------------------------- model sets
def markov_matrix(r, p_stay):
    """``r x r`` Markov matrix with ``p_stay`` on the diagonal and the rest spread evenly."""
    r = int(r)
    if r < 1:
        raise ValueError(f"r must be >= 1, got {r}")
    p = as_probability(p_stay, "p_stay")
    if r == 1:
        return np.ones((1, 1))
    M = np.full((r, r), (1.0 - p) / (r - 1))
    np.fill_diagonal(M, p)
    return M


def _check_transition(transition, r):
    Pi = as_square_matrix(transition, "transition", r)
    if Pi.min() < 0 or Pi.max() > 1:
        raise ValueError("transition must contain probabilities in [0, 1]")
    if not np.allclose(Pi.sum(axis=1), 1.0, atol=1e-12):
        raise ValueError("transition rows must sum to 1")
    return Pi


def _check_mu0(mu0, r):
    mu = as_probabilities(mu0, "mu0", shape=(r,))
    if abs(mu.sum() - 1.0) > 1e-12:
        raise ValueError(f"mu0 must sum to 1, got {mu.sum()!r}")
    return mu


def _finish(name, labels, F, Q, H, transition, mu0, embed, init_var, out_index, tom=False, T=1.0,
            u=None, var_f=None, var_s=None, cwna=False):
    r = F.shape[0]
    transition = markov_matrix(r, 0.9) if transition is None else _check_transition(transition, r)
    mu0 = _check_mu0(mu0, r)
    z = np.zeros(r)
    return IMMModelSet(name, tuple(labels), np.ascontiguousarray(F), np.ascontiguousarray(Q),
                       np.ascontiguousarray(H), transition, mu0, np.ascontiguousarray(embed),
                       np.ascontiguousarray(init_var), np.asarray(out_index, dtype=np.int64), tom,
                       float(T), z if u is None else u, z if var_f is None else var_f,
                       z if var_s is None else var_s, bool(cwna))


def singer_imm_model_set(T=1.0, tau=(20.0, 5.0), sigma_m=(15.0, 60.0), sigma_cv=1.0,
                         init_sigma_a=15.0, transition=None, mu0=(0.8, 0.1, 0.1)):
    """CV + Singer models on ``[x, y, vx, vy, ax, ay]`` (Houles & Bar-Shalom's set).

    The CV model has ``Phi_aa = 0``, DWNA velocity noise ``sigma_cv`` (m/s^2) and
    ``Q_aa = 1e-6``; each Singer model uses the exact transition and process
    noise for ``tau[i]`` (s) and ``sigma_m[i]`` (m/s^2).  The initial
    acceleration is 0 with standard deviation ``init_sigma_a``.
    ``transition`` defaults to ``markov_matrix(r, 0.9)``.
    """
    T = as_positive(T, "T")
    tau = as_array(tau, "tau", ndim=1)
    sigma_m = as_array(sigma_m, "sigma_m", shape=(tau.size,))
    if tau.size == 0 or tau.min() <= 0:
        raise ValueError("tau must hold positive time constants")
    if sigma_m.min() < 0:
        raise ValueError("sigma_m must be >= 0")
    sigma_cv = as_nonnegative(sigma_cv, "sigma_cv")
    init_sigma_a = as_nonnegative(init_sigma_a, "init_sigma_a")
    r = tau.size + 1
    F = np.zeros((r, 6, 6))
    Q = np.zeros((r, 6, 6))
    cv = np.array([[1.0, T, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    F[0] = kron_axes(cv, 2)
    Q[0, :4, :4] = cv_process_noise(T, sigma_cv**2, dim=2, kind="dwna")
    Q[0, 4, 4] = Q[0, 5, 5] = 1e-6
    labels = ["CV"]
    for i in range(tau.size):
        F[i + 1] = kron_axes(singer_transition(T, tau[i]), 2)
        Q[i + 1] = kron_axes(singer_process_noise(T, tau[i], sigma_m[i]), 2)
        labels.append(f"Singer tau={tau[i]:g} s")
    H = np.zeros((2, 6))
    H[0, 0] = H[1, 1] = 1.0
    embed = np.zeros((6, 4))
    embed[:4, :4] = np.eye(4)
    init_var = np.r_[np.zeros(4), init_sigma_a**2, init_sigma_a**2]
    return _finish("Singer-IMM", labels, F, Q, H, transition, mu0, embed, init_var, [0, 1, 2, 3])


def car_imm_model_set(T=1.0, omega=0.14, sigma_cv=1.0, sigma_ct=8.0, transition=None,
                      mu0=(0.8, 0.1, 0.1)):
    """CV + coordinated-turn models at ``+-omega`` (rad/s) on ``[x, y, vx, vy]``.

    DWNA process noise: ``sigma_cv`` for CV and ``sigma_ct`` for the turn
    models (m/s^2).  Model order: CV, turn ``+omega`` (left), turn ``-omega``
    (right).
    """
    T = as_positive(T, "T")
    omega = as_scalar(omega, "omega")
    sigma_cv = as_nonnegative(sigma_cv, "sigma_cv")
    sigma_ct = as_nonnegative(sigma_ct, "sigma_ct")
    F = np.stack([coordinated_turn_transition(0.0, T), coordinated_turn_transition(omega, T),
                  coordinated_turn_transition(-omega, T)])
    Q = np.stack([cv_process_noise(T, sigma_cv**2), cv_process_noise(T, sigma_ct**2),
                  cv_process_noise(T, sigma_ct**2)])
    H = np.zeros((2, 4))
    H[0, 0] = H[1, 1] = 1.0
    labels = ["CV", f"CT {omega:+g} rad/s", f"CT {-omega:+g} rad/s"]
    return _finish("CAR-IMM", labels, F, Q, H, transition, mu0, np.eye(4), np.zeros(4),
                   [0, 1, 2, 3])


def tom_imm_model_set(T=1.0, u=70.0, sigma_f=1.0, sigma_s_centre=3.0, sigma_s_turn=20.0,
                      transition=None, mu0=(0.8, 0.1, 0.1), kind="dwna"):
    """Three target-oriented models with lateral inputs ``0, +u, -u`` (m/s).

    ``+u`` is a right turn (``+v_s`` points right of the heading).  Process
    noise :func:`trackcore.models.tom_process_noise` of ``kind`` with
    ``sigma_f`` for all models and ``sigma_s_centre`` / ``sigma_s_turn`` for the
    lateral axis.
    """
    T = as_positive(T, "T")
    u = as_nonnegative(u, "u")
    sigma_f = as_nonnegative(sigma_f, "sigma_f")
    sc = as_nonnegative(sigma_s_centre, "sigma_s_centre")
    st = as_nonnegative(sigma_s_turn, "sigma_s_turn")
    if kind not in ("dwna", "cwna"):
        raise ValueError(f"kind must be 'dwna' or 'cwna', got {kind!r}")
    H = np.zeros((2, 4))
    H[0, 0] = H[1, 1] = 1.0
    labels = ["TOM u=0", f"TOM u=+{u:g} (right)", f"TOM u=-{u:g} (left)"]
    zeros = np.zeros((3, 4, 4))
    return _finish("TOM-IMM", labels, zeros, zeros.copy(), H, transition, mu0, np.eye(4),
                   np.zeros(4), [0, 1, 2, 3], tom=True, T=T, u=np.array([0.0, u, -u]),
                   var_f=np.full(3, sigma_f**2), var_s=np.array([sc**2, st**2, st**2]),
                   cwna=(kind == "cwna"))


def two_point_init(z0, z1, R, T=1.0):
    """Two-point differencing: ``x = [z1, (z1 - z0)/T]`` with covariance
    ``[[R, R/T], [R/T, 2R/T^2]]`` (Bar-Shalom, Li & Kirubarajan 2001)."""
    z0 = as_vector(z0, "z0", 2)
    z1 = as_vector(z1, "z1", 2)
    R = as_covariance(R, "R", 2)
    T = as_positive(T, "T")
    x = np.r_[z1, (z1 - z0) / T]
    P = np.block([[R, R / T], [R / T, 2.0 * R / T**2]])
    return x, P


def pack_scans(scans, d=2):
    """Pack a sequence of ``(m_k, d)`` scans into ``(z (N, d), offsets (K + 1,))``."""
    arrs = [as_measurements(s, f"scans[{k}]", d) for k, s in enumerate(scans)]
    offsets = np.zeros(len(arrs) + 1, dtype=np.int64)
    np.cumsum([a.shape[0] for a in arrs], out=offsets[1:])
    z = np.ascontiguousarray(np.concatenate(arrs, axis=0)) if arrs else np.zeros((0, d))
    return z, offsets


# ---------------------------------------------------------------------- kernels
@nb.njit(cache=True)
def imm_pdaf_run_kernel(z, offsets, x0, P0, F, Q, H, R, Pi, mu0, tom, T, u, var_f, var_s, cwna,
                        prev2, prev1, phi0, out_index, pd, pg, gamma, log_lam,
                        xs, Ps, mus, zps, Ss, gated, headings):
    """Whole-run IMM-PDAF over the scans ``z[offsets[k]:offsets[k+1]]``.

    ``x0`` (n,), ``P0`` (n, n): the initial estimate in model coordinates
    (every model starts from it); ``prev2``/``prev1`` (2,): the combined
    positions at the two previous scans (TOM heading chord); ``phi0`` the
    initial heading.  ``log_lam = log(lambda)`` (``-inf`` without clutter),
    ``gamma`` the gate threshold.  Outputs (preallocated): ``xs`` (K, 4),
    ``Ps`` (K, 4, 4), ``mus`` (K, r), ``zps`` (K, 2), ``Ss`` (K, 2, 2),
    ``gated`` (N,), ``headings`` (K,).  Returns -1, or the scan index at which
    an innovation covariance was not positive definite.
    """
    r, n = F.shape[0], F.shape[1]
    d = H.shape[0]
    K = offsets.shape[0] - 1
    X = np.empty((r, n))
    P = np.empty((r, n, n))
    for j in range(r):
        for a in range(n):
            X[j, a] = x0[a]
            for b in range(n):
                P[j, a, b] = P0[a, b]
    mu = mu0.copy()
    c = np.empty(r)
    X0 = np.empty((r, n))
    P0m = np.empty((r, n, n))
    Xp = np.empty((r, n))
    Pp = np.empty((r, n, n))
    Fk = F.copy()
    Qk = Q.copy()
    Zp = np.empty((r, d))
    Sm = np.empty((r, d, d))
    L = np.empty((r, d, d))
    halflogdet = np.empty(r)
    xc = np.empty(n)
    Pcm = np.empty((n, n))
    nu = np.empty(d)
    Sout = np.empty((d, d))
    Kg = np.empty((n, d))
    log_like = np.empty(r)
    logmu = np.empty(r)
    M = np.zeros((4, n))
    log_pd = math.log(pd) if pd > 0 else -np.inf
    miss = 1.0 - pd * pg
    log_miss = math.log(miss) if miss > 0 else -np.inf
    p2x, p2y, p1x, p1y = prev2[0], prev2[1], prev1[0], prev1[1]
    phi = phi0
    for k in range(K):
        lo, hi = offsets[k], offsets[k + 1]
        m = hi - lo
        zk = z[lo:hi]
        # 1. heading and the models of this scan (TOM)
        if tom:
            phi = chord_heading_kernel(p2x, p2y, p1x, p1y, phi, 1e-6)
            for j in range(r):
                tom_transition_kernel(phi, T, Fk[j])
                tom_process_noise_kernel(phi, T, var_f[j], var_s[j], cwna, Qk[j])
            headings[k] = phi
        else:
            headings[k] = np.nan
        # 2. mixing
        imm_mix_kernel(mu, Pi, X, P, X0, P0m, c)
        # 3. lateral input and prediction
        for j in range(r):
            if tom:
                X0[j, 3] = u[j]
            kf_predict_kernel(X0[j], P0m[j], Fk[j], Qk[j], Xp[j], Pp[j])
            for a in range(d):
                s = 0.0
                for b in range(n):
                    s += H[a, b] * Xp[j, b]
                Zp[j, a] = s
            for a in range(d):
                for b in range(d):
                    s = R[a, b]
                    for e in range(n):
                        for f in range(n):
                            s += H[a, e] * Pp[j, e, f] * H[b, f]
                    Sm[j, a, b] = s
            if not cholesky_lower_kernel(Sm[j], L[j]):
                return k
            hl = 0.0
            for a in range(d):
                hl += math.log(L[j, a, a])
            halflogdet[j] = hl
        # mixture predicted measurement (for NIS)
        for a in range(d):
            s = 0.0
            for j in range(r):
                s += c[j] * Zp[j, a]
            zps[k, a] = s
        for a in range(d):
            for b in range(d):
                s = 0.0
                for j in range(r):
                    s += c[j] * (Sm[j, a, b] + (Zp[j, a] - zps[k, a]) * (Zp[j, b] - zps[k, b]))
                Ss[k, a, b] = s
        # 4. gates: union over models
        mask = np.zeros(m, dtype=np.bool_)
        mj = np.empty(m, dtype=np.bool_)
        d2 = np.empty((r, m))
        for j in range(r):
            mahalanobis_gate_kernel(zk, Zp[j], L[j], gamma, -1, mj, d2[j])
            for i in range(m):
                if mj[i]:
                    mask[i] = True
        mv = 0
        for i in range(m):
            gated[lo + i] = mask[i]
            if mask[i]:
                mv += 1
        zv = np.empty((mv, d))
        idx = np.empty(mv, dtype=np.int64)
        t = 0
        for i in range(m):
            if mask[i]:
                idx[t] = i
                for a in range(d):
                    zv[t, a] = zk[i, a]
                t += 1
        # 5. PDA per model
        ll = np.empty(mv)
        betas = np.empty(mv)
        for j in range(r):
            for t in range(mv):
                ll[t] = -0.5 * (d * _LOG_2PI + d2[j, idx[t]]) - halflogdet[j]
            beta0, log_norm = pda_betas_kernel(ll, log_pd, log_miss, log_lam, betas)
            if math.isnan(beta0):  # all hypotheses impossible: keep the prediction
                beta0 = 1.0
                for t in range(mv):
                    betas[t] = 0.0
                log_norm = -np.inf
            log_like[j] = log_norm
            ok = pda_update_kernel(Xp[j], Pp[j], zv, Zp[j], H, R, betas, beta0, -1,
                                   X[j], P[j], nu, Sout, Kg)
            if not ok:
                return k
        # 6. model probabilities (log space)
        if imm_mode_update_kernel(c, log_like, logmu) == -np.inf:
            for j in range(r):  # no model explains the scan: keep the predicted ones
                mu[j] = c[j]
        else:
            for j in range(r):
                mu[j] = logmu[j]
        # 7. combination and Cartesian output
        imm_combine_kernel(mu, X, P, xc, Pcm)
        for a in range(4):
            for b in range(n):
                M[a, b] = 0.0
            M[a, out_index[a]] = 1.0
        if tom:
            cph = math.cos(phi)
            sph = math.sin(phi)
            M[2, 2] = cph
            M[2, 3] = sph
            M[3, 2] = sph
            M[3, 3] = -cph
        for a in range(4):
            s = 0.0
            for b in range(n):
                s += M[a, b] * xc[b]
            xs[k, a] = s
        for a in range(4):
            for b in range(4):
                s = 0.0
                for e in range(n):
                    if M[a, e] == 0.0:
                        continue
                    for f in range(n):
                        s += M[a, e] * Pcm[e, f] * M[b, f]
                Ps[k, a, b] = s
        for j in range(r):
            mus[k, j] = mu[j]
        # 8. TOM: remember the combined position, reset v_s
        if tom:
            p2x, p2y = p1x, p1y
            p1x, p1y = xc[0], xc[1]
            for j in range(r):
                X[j, 3] = 0.0
    return -1


# ---------------------------------------------------------------------- public
def imm_pdaf_track_packed(models, z, offsets, x0, P0, R, *, pd=1.0, pg=0.99,
                          clutter_density=2e-6, prev_position=None):
    """IMM-PDAF over packed scans (see :func:`pack_scans`); returns :class:`IMMPDAFResult`.

    ``x0``, ``P0``: Cartesian initial estimate ``[x, y, vx, vy]`` at the time
    before the first scan (e.g. :func:`two_point_init`).  ``R`` (2, 2):
    measurement covariance.  ``pd`` = P_D, ``pg`` = P_G (the gate is the
    ``pg`` chi-square quantile, ``pg = 1`` disables gating);
    ``clutter_density`` = lambda (m^-2, 0 for no clutter).  For the TOM the
    heading chord starts from ``prev_position`` (default ``x0[:2] - T v0``,
    which for a two-point initialisation is the first measurement) and
    ``x0[:2]``.
    """
    if not isinstance(models, IMMModelSet):
        raise TypeError(f"models must be an IMMModelSet, got {type(models).__name__}")
    z = as_measurements(z, "z", 2)
    offsets = as_offsets(offsets, z.shape[0])
    x0 = as_vector(x0, "x0", 4)
    P0 = as_covariance(P0, "P0", 4)
    R = as_covariance(R, "R", 2, strict=True)
    pd = as_probability(pd, "pd")
    pg = as_probability(pg, "pg", open_low=True)
    lam = as_nonnegative(clutter_density, "clutter_density")
    gamma = gate_threshold(pg, 2)
    n = models.F.shape[1]
    r = models.F.shape[0]
    xm = models.embed @ x0
    Pm = models.embed @ P0 @ models.embed.T + np.diag(models.init_var)
    phi0 = 0.0
    if models.tom:
        phi0 = math.atan2(x0[3], x0[2])
        c, s = math.cos(phi0), math.sin(phi0)
        B = np.eye(4)
        B[2:, 2:] = [[c, s], [s, -c]]
        xm, Pm = B @ xm, B @ Pm @ B.T
    if prev_position is None:
        prev2 = x0[:2] - models.T * x0[2:]
    else:
        prev2 = as_vector(prev_position, "prev_position", 2)
    K = offsets.size - 1
    xs = np.empty((K, 4))
    Ps = np.empty((K, 4, 4))
    mus = np.empty((K, r))
    zps = np.empty((K, 2))
    Ss = np.empty((K, 2, 2))
    gated = np.zeros(z.shape[0], dtype=np.bool_)
    heads = np.empty(K)
    bad = imm_pdaf_run_kernel(z, offsets, np.ascontiguousarray(xm), np.ascontiguousarray(Pm),
                              models.F, models.Q, models.H, R, models.transition, models.mu0,
                              models.tom, models.T, models.u, models.var_f, models.var_s,
                              models.cwna, np.ascontiguousarray(prev2), x0[:2].copy(), phi0,
                              models.out_index, pd, pg, float(gamma),
                              math.log(lam) if lam > 0 else -math.inf,
                              xs, Ps, mus, zps, Ss, gated, heads)
    if bad >= 0:
        raise ValueError(f"innovation covariance not positive definite at scan {bad}")
    return IMMPDAFResult(xs, Ps, mus, zps, Ss, gated, heads)


def imm_pdaf_track(models, scans, x0, P0, R, *, pd=1.0, pg=0.99, clutter_density=2e-6,
                   prev_position=None):
    """IMM-PDAF over a sequence of ``(m_k, 2)`` position scans (``m_k = 0`` allowed).

    See :func:`imm_pdaf_track_packed` for the arguments; ``gated`` in the
    result refers to the rows of the scans concatenated in order.
    """
    z, offsets = pack_scans(scans, 2)
    return imm_pdaf_track_packed(models, z, offsets, x0, P0, R, pd=pd, pg=pg,
                                 clutter_density=clutter_density, prev_position=prev_position)
