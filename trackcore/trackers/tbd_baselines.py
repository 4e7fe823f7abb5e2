"""Stronger baselines for the TBD chapter's comparison (book/003-tbd-pf, 06-verdict-grid).

Three variants of the weighted-mean baselines A and B of :mod:`trackcore.trackers.tbd_pf`,
each the chapter's tracker with one thing made stronger, run on the same scans:

* :func:`run_tbd_gated_b` -- method B with method A's validation gate: the weighted mean
  ``p̄`` updates the particles only if its squared Mahalanobis distance from the particle
  cloud's predicted position, with covariance ``P_pos + σ_p² I`` (the cloud's weighted
  covariance plus A's isotropic pseudo-measurement covariance), is at most ``gate``.  To
  first order this is A's NIS (A maps the same isotropic covariance to range, azimuth
  and elevation).  ``gate = math.inf`` is method B exactly.
* :func:`run_tbd_snr_ekf` -- method A whose pseudo-measurement covariance follows the
  SNR: ``σ_p,k = max(σ_floor, σ_p sqrt(τ / ζ̄_k))``, ``ζ̄_k = Σ_j w̄_j ζ_j`` the measured
  SNR of the window's detections averaged with the weights of ``p̄`` (eq 10), ``τ`` the
  detection threshold.  The variance of a position estimate falls as 1/SNR (its
  Cramér-Rao bound); the calibrated ``σ_p`` is taken to hold at the threshold, where the
  approach's detections lie, and the floor is one detection's range noise.
* :func:`run_tbd_imm` -- method A as an interacting multiple model filter (Blom and
  Bar-Shalom): CV models with different ``σ_a`` (DWNA), Markov switching ``PI``, one
  pseudo-measurement ``p̄`` per scan (window and eq 10 from the combined prediction),
  accepted when the smallest NIS over the models is at most ``gate``.

Every function returns a :class:`~trackcore.trackers.TbdTrackResult`.  These functions
are reached through this module (they are not exported by :mod:`trackcore.trackers`).
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_covariance, as_positive, as_probability,
                               as_rng, as_vector)
from ..filters.kalman import kf_predict_kernel, kf_update_kernel
from ..models.measurement import wrap_angle_kernel
from ..models.motion import cv_process_noise, cv_transition
from .tbd_pf import (_COV_LIMIT, TbdTrackerConfig, TbdTrackResult, _bounded, _inv,
                     _neg_log_kernel, _pf_scan_finish, _pf_setup, _pseudo_covariance_kernel,
                     _rae, _rae_jacobian_kernel, _radial_velocity, _scan_arrays,
                     _pf_predict, _scan_window, _weighted_mean_kernel, detection_snr_cap)

__all__ = ["run_tbd_gated_b", "run_tbd_snr_ekf", "run_tbd_imm"]


def _check(config, method):
    if not isinstance(config, TbdTrackerConfig):
        raise TypeError(f"config must be a TbdTrackerConfig, got {type(config).__name__}")
    if config.method != method:
        raise ValueError(f"config.method must be {method!r}, got {config.method!r}")
    if (config.use_doppler or config.kernel != "laplace" or config.roughening
            or config.weight_reference != "prediction"
            or (method == "A" and config.pseudo_covariance != "calibrated")):
        raise ValueError("these baselines take the chapter's default config options "
                         "(no Doppler, Laplace kernel, no roughening, prediction reference"
                         ", calibrated covariance)")


def _inputs(scans, x0, P0, config):
    pos, rr, snr, off = _scan_arrays(scans)
    x0 = _bounded(as_vector(x0, "x0", 6), "x0")
    P0 = _bounded(as_covariance(P0, "P0", 6, strict=True), "P0", _COV_LIMIT)
    K, M = off.size - 1, pos.shape[0]
    out = dict(est=np.empty((K, 6)), cov=np.empty((K, 6, 6)), centers=np.empty((K, 3)),
               nproc=np.zeros(K, dtype=np.int64), processed=np.zeros(M, dtype=bool),
               accepted=np.zeros(K, dtype=bool))
    common = (pos, rr, snr, math.log(config.pfa), detection_snr_cap(config.pfa),
              np.full(max(M, 1), np.nan), off, float(config.processing_radius),
              _inv(config.sigma_r), _inv(config.sigma_v), False)
    return x0, P0, common, out


def _result(out, ess=None, resampled=None, nis=None):
    K = out["est"].shape[0]
    return TbdTrackResult(out["est"], out["cov"], out["centers"], out["nproc"],
                          out["processed"], np.full(K, np.nan) if ess is None else ess,
                          np.zeros(K, dtype=bool) if resampled is None else resampled,
                          out["accepted"], np.full(K, np.nan) if nis is None else nis)


# ================================================================ B with A's gate
@nb.njit(cache=True)
def _sym3_nis(S, d):
    """``dᵀ S⁻¹ d`` for a 3x3 symmetric ``S`` (Cholesky); inf if not positive definite."""
    l00 = S[0, 0]
    if not l00 > 0.0:
        return np.inf
    l00 = math.sqrt(l00)
    l10 = S[1, 0] / l00
    l20 = S[2, 0] / l00
    t = S[1, 1] - l10 * l10
    if not t > 0.0:
        return np.inf
    l11 = math.sqrt(t)
    l21 = (S[2, 1] - l20 * l10) / l11
    t = S[2, 2] - l20 * l20 - l21 * l21
    if not t > 0.0:
        return np.inf
    l22 = math.sqrt(t)
    y0 = d[0] / l00
    y1 = (d[1] - l10 * y0) / l11
    y2 = (d[2] - l20 * y0 - l21 * y1) / l22
    return y0 * y0 + y1 * y1 + y2 * y2


@nb.njit(cache=True)
def _gated_b_kernel(particles, logw, F, L, pos, rr, snr, log_pfa, snr_cap, cache, offsets,
                    R, inv_r, inv_v, gauss, resample_below, rng, gate, sig_p, est, cov,
                    centers, nproc, processed, accepted, nis_out, ess, resampled):
    N = particles.shape[0]
    K = offsets.shape[0] - 1
    max_m = 1
    for k in range(K):
        max_m = max(max_m, offsets[k + 1] - offsets[k])
    idx = np.empty(max_m, dtype=np.int64)
    tmp = np.empty(max_m)
    lpd = np.empty(max_m)
    ll, w = np.empty(N), np.empty(N)
    mean, pbar, d = np.empty(6), np.empty(3), np.empty(3)
    S = np.empty((3, 3))
    ridx = np.empty(N, dtype=np.int64)
    work = np.empty_like(particles)
    for k in range(K):
        _pf_predict(k, particles, F, L, rng, logw, w, mean)
        m = _scan_window(k, mean, pos, snr, log_pfa, snr_cap, offsets, R, idx, lpd,
                         processed, cache, centers, nproc)
        nis_out[k] = np.nan
        updated = False
        if m > 0:
            rr_ref = _radial_velocity(mean[0], mean[1], mean[2], mean[3], mean[4], mean[5])
            rbar = _weighted_mean_kernel(idx, m, pos, rr, lpd, mean, rr_ref, inv_r, inv_v,
                                         gauss, tmp, pbar)
            if not math.isnan(rbar):
                nis = 0.0
                if gate < np.inf:
                    for a in range(3):
                        d[a] = pbar[a] - mean[a]
                        for b in range(3):
                            S[a, b] = sig_p * sig_p if a == b else 0.0
                    for i in range(N):
                        for a in range(3):
                            da = particles[i, a] - mean[a]
                            for b in range(3):
                                S[a, b] += w[i] * da * (particles[i, b] - mean[b])
                    nis = _sym3_nis(S, d)
                    nis_out[k] = nis
                if nis <= gate:
                    for i in range(N):
                        dist = math.sqrt((particles[i, 0] - pbar[0]) ** 2
                                         + (particles[i, 1] - pbar[1]) ** 2
                                         + (particles[i, 2] - pbar[2]) ** 2)
                        ll[i] = -_neg_log_kernel(dist * inv_r, gauss)
                    updated = True
                    accepted[k] = True
        _pf_scan_finish(k, particles, logw, ll, updated, resample_below, 0.0, rng, w, mean,
                        ridx, work, est, cov, True, ess, resampled)


def run_tbd_gated_b(scans, x0, P0, rng, config=TbdTrackerConfig(method="B")):
    """Method B with method A's gate (``config.gate`` on the NIS of ``p̄``, covariance
    ``P_pos + σ_p² I`` with A's ``σ_p`` = ``config.pseudo_sigmas[0]``); ``config`` is a
    method-``"B"`` :class:`~trackcore.trackers.TbdTrackerConfig` with the chapter's
    default options.  ``gate = math.inf`` gives :func:`run_tbd_tracker`'s method B.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> from trackcore.scenarios.tbd_radar import TBD_INITIAL_COVARIANCE as P0
    >>> from trackcore.trackers import TbdTrackerConfig, tbd_position_errors
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> from trackcore.trackers.tbd_baselines import run_tbd_gated_b
    >>> cfg = TbdTrackerConfig(method="B", n_particles=200, processing_radius=1000.0)
    >>> res = run_tbd_gated_b(scans, truth.states[0], P0, np.random.default_rng(2), cfg)
    >>> res.estimates.shape, int(res.accepted.sum()) <= 20
    ((20, 6), True)
    """
    _check(config, "B")
    rng = as_rng(rng)
    sig_p = config.pseudo_sigmas[0]
    if not math.isfinite(sig_p) and math.isfinite(config.gate):
        raise ValueError("config.pseudo_sigma must be given for this processing_radius")
    x0, P0, common, out = _inputs(scans, x0, P0, config)
    particles, logw, F, L = _pf_setup(x0, P0, rng, config)
    K = out["est"].shape[0]
    ess, resampled, nis = np.empty(K), np.zeros(K, dtype=bool), np.full(K, np.nan)
    _gated_b_kernel(particles, logw, F, L, *common,
                    float(config.resample_threshold * particles.shape[0]), rng,
                    float(config.gate), float(sig_p), out["est"], out["cov"],
                    out["centers"], out["nproc"], out["processed"], out["accepted"], nis,
                    ess, resampled)
    return _result(out, ess, resampled, nis)


# ================================================================ A with an SNR covariance
@nb.njit(cache=True)
def _ekf_scan_update(x, P, pbar, sig_p, Rsens, idx, m, pos, rr, wbar, rbar, H, Jp, Rm, z,
                     innov, xu, Pu, S, Kg):
    """One EKF update of ``(x, P)`` with ``p̄`` (isotropic ``sig_p``) into ``xu``, ``Pu``;
    returns ``(nis, loglik, ok)`` (method A's update, without Doppler)."""
    r_m, az_m, el_m = _rae(pbar[0], pbar[1], pbar[2])
    r_p, az_p, el_p = _rae(x[0], x[1], x[2])
    _rae_jacobian_kernel(x, H, False)
    _pseudo_covariance_kernel(0, idx, m, pos, rr, wbar, pbar, rbar, sig_p, 1.0, Rsens, 3,
                              Jp, Rm)
    innov[0] = r_m - r_p
    innov[1] = wrap_angle_kernel(az_m - az_p)
    innov[2] = el_m - el_p
    for i in range(3):
        s = innov[i]
        for a in range(6):
            s += H[i, a] * x[a]
        z[i] = s
    return kf_update_kernel(x, P, z, H, Rm, xu, Pu, innov, S, Kg)


@nb.njit(cache=True)
def _snr_ekf_kernel(x, P, F, Q, sig_p, tau, floor, pos, rr, snr, log_pfa, snr_cap, cache,
                    offsets, R, inv_r, inv_v, gauss, gate, est, cov, centers, nproc,
                    processed, accepted, nis_out, sig_out):
    K = offsets.shape[0] - 1
    max_m = 1
    for k in range(K):
        max_m = max(max_m, offsets[k + 1] - offsets[k])
    idx = np.empty(max_m, dtype=np.int64)
    wbar, lpd = np.empty(max_m), np.empty(max_m)
    pbar, z, innov = np.empty(3), np.empty(3), np.empty(3)
    xp, xu = np.empty(6), np.empty(6)
    Pp, Pu = np.empty((6, 6)), np.empty((6, 6))
    H, Jp, Rm, S = np.empty((3, 6)), np.empty((3, 6)), np.empty((3, 3)), np.empty((3, 3))
    Kg, Rsens = np.empty((6, 3)), np.zeros((4, 4))
    for k in range(K):
        if k > 0:
            kf_predict_kernel(x, P, F, Q, xp, Pp)
            x[:] = xp
            P[:, :] = Pp
        m = _scan_window(k, x, pos, snr, log_pfa, snr_cap, offsets, R, idx, lpd,
                         processed, cache, centers, nproc)
        nis_out[k] = np.nan
        sig_out[k] = np.nan
        if m > 0:
            rr_ref = _radial_velocity(x[0], x[1], x[2], x[3], x[4], x[5])
            rbar = _weighted_mean_kernel(idx, m, pos, rr, lpd, x, rr_ref, inv_r, inv_v,
                                         gauss, wbar, pbar)
            if not math.isnan(rbar):
                zeta = 0.0
                for t in range(m):
                    zeta += wbar[t] * snr[idx[t]]
                sk = max(floor, sig_p * math.sqrt(tau / zeta)) if zeta > 0 else sig_p
                sig_out[k] = sk
                nis, _, ok = _ekf_scan_update(x, P, pbar, sk, Rsens, idx, m, pos, rr, wbar,
                                              rbar, H, Jp, Rm, z, innov, xu, Pu, S, Kg)
                if ok:
                    nis_out[k] = nis
                if ok and nis <= gate:
                    x[:] = xu
                    P[:, :] = Pu
                    accepted[k] = True
        for a in range(6):
            est[k, a] = x[a]
            for b in range(6):
                cov[k, a, b] = P[a, b]


def run_tbd_snr_ekf(scans, x0, P0, config=TbdTrackerConfig(method="A"), *,
                    threshold=10.0 ** 0.5, floor=25.0):
    """Method A with the SNR-dependent covariance ``σ_p,k = max(floor, σ_p sqrt(threshold
    / ζ̄_k))`` (module docstring); ``threshold``: the detection threshold ``τ`` (linear,
    the scenario's 5 dB by default), ``floor`` (m).  Returns the track and, as its
    ``ess`` field, ``σ_p,k`` per scan (NaN: no update).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> from trackcore.scenarios.tbd_radar import TBD_INITIAL_COVARIANCE as P0
    >>> from trackcore.trackers import TbdTrackerConfig, tbd_position_errors
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> from trackcore.trackers.tbd_baselines import run_tbd_snr_ekf
    >>> cfg = TbdTrackerConfig(method="A", processing_radius=1000.0)
    >>> res = run_tbd_snr_ekf(scans, truth.states[0], P0, cfg)
    >>> sig = res.ess[np.isfinite(res.ess)]  # sigma_p,k of the scans with an update
    >>> bool(np.all(sig >= 25.0)), res.estimates.shape
    (True, (20, 6))
    """
    _check(config, "A")
    tau = as_positive(threshold, "threshold")
    floor = as_positive(floor, "floor")
    x0, P0, common, out = _inputs(scans, x0, P0, config)
    T = config.scan_period
    F = cv_transition(T, dim=3)
    Q = cv_process_noise(T, config.sigma_a ** 2, dim=3, kind="dwna")
    K = out["est"].shape[0]
    nis, sig = np.full(K, np.nan), np.full(K, np.nan)
    _snr_ekf_kernel(x0.copy(), P0.copy(), F, Q, float(config.pseudo_sigmas[0]), tau, floor,
                    *common, float(config.gate), out["est"], out["cov"], out["centers"],
                    out["nproc"], out["processed"], out["accepted"], nis, sig)
    return _result(out, ess=sig, nis=nis)


# ================================================================ A as an IMM
@nb.njit(cache=True)
def _imm_kernel(x0, P0, F, Qs, PI, mu0, sig_p, pos, rr, snr, log_pfa, snr_cap, cache,
                offsets, R, inv_r, inv_v, gauss, gate, est, cov, centers, nproc, processed,
                accepted, nis_out, mu_out):
    K = offsets.shape[0] - 1
    M = Qs.shape[0]
    max_m = 1
    for k in range(K):
        max_m = max(max_m, offsets[k + 1] - offsets[k])
    idx = np.empty(max_m, dtype=np.int64)
    wbar, lpd = np.empty(max_m), np.empty(max_m)
    pbar, z, innov = np.empty(3), np.empty(3), np.empty(3)
    xs, Ps = np.empty((M, 6)), np.empty((M, 6, 6))
    xu, Pu = np.empty((M, 6)), np.empty((M, 6, 6))
    xm, Pm, xc = np.empty((M, 6)), np.empty((M, 6, 6)), np.empty(6)
    H, Jp, Rm, S = np.empty((3, 6)), np.empty((3, 6)), np.empty((3, 3)), np.empty((3, 3))
    Kg, Rsens = np.empty((6, 3)), np.zeros((4, 4))
    mu, c, lik, ok = mu0.copy(), mu0.copy(), np.empty(M), np.zeros(M, dtype=np.bool_)
    nis = np.empty(M)
    for j in range(M):
        xs[j] = x0
        Ps[j] = P0
    for k in range(K):
        if k > 0:
            for j in range(M):  # mixing
                c[j] = 0.0
                for i in range(M):
                    c[j] += PI[i, j] * mu[i]
            for j in range(M):
                if not c[j] > 0.0:  # a model no other can reach: it keeps its state
                    xm[j] = xs[j]
                    Pm[j] = Ps[j]
                    continue
                xm[j] = 0.0
                for i in range(M):
                    xm[j] += (PI[i, j] * mu[i] / c[j]) * xs[i]
                Pm[j] = 0.0
                for i in range(M):
                    wij = PI[i, j] * mu[i] / c[j]
                    for a in range(6):
                        da = xs[i, a] - xm[j, a]
                        for b in range(6):
                            Pm[j, a, b] += wij * (Ps[i, a, b] + da * (xs[i, b] - xm[j, b]))
            for j in range(M):
                kf_predict_kernel(xm[j], Pm[j], F, Qs[j], xs[j], Ps[j])
                mu[j] = c[j]
        xc[:] = 0.0
        for j in range(M):
            xc += mu[j] * xs[j]
        m = _scan_window(k, xc, pos, snr, log_pfa, snr_cap, offsets, R, idx, lpd,
                         processed, cache, centers, nproc)
        nis_out[k] = np.nan
        if m > 0:
            rr_ref = _radial_velocity(xc[0], xc[1], xc[2], xc[3], xc[4], xc[5])
            rbar = _weighted_mean_kernel(idx, m, pos, rr, lpd, xc, rr_ref, inv_r, inv_v,
                                         gauss, wbar, pbar)
            if not math.isnan(rbar):
                best, top = np.inf, -np.inf
                for j in range(M):
                    nj, lj, oj = _ekf_scan_update(
                        xs[j], Ps[j], pbar, sig_p, Rsens, idx, m, pos, rr, wbar, rbar, H,
                        Jp, Rm, z, innov, xu[j], Pu[j], S, Kg)
                    nis[j], lik[j], ok[j] = nj, lj, oj
                    if ok[j]:
                        best = min(best, nis[j])
                        top = max(top, lik[j])
                if best < np.inf:
                    nis_out[k] = best
                if best <= gate:
                    accepted[k] = True
                    tot = 0.0
                    for j in range(M):
                        if ok[j]:
                            xs[j] = xu[j]
                            Ps[j] = Pu[j]
                            mu[j] *= math.exp(lik[j] - top)
                        else:
                            mu[j] = 0.0
                        tot += mu[j]
                    for j in range(M):
                        mu[j] = mu[j] / tot if tot > 0.0 else c[j]
        xc[:] = 0.0
        for j in range(M):
            xc += mu[j] * xs[j]
            mu_out[k, j] = mu[j]
        for a in range(6):
            est[k, a] = xc[a]
            for b in range(6):
                cov[k, a, b] = 0.0
        for j in range(M):
            for a in range(6):
                da = xs[j, a] - xc[a]
                for b in range(6):
                    cov[k, a, b] += mu[j] * (Ps[j, a, b] + da * (xs[j, b] - xc[b]))


def run_tbd_imm(scans, x0, P0, config=TbdTrackerConfig(method="A"), *,
                sigma_a=(3.0, 30.0), transition=((0.99, 0.01), (0.1, 0.9)), mu0=None):
    """Method A as an IMM of CV models with accelerations ``sigma_a`` (m/s², DWNA) and
    Markov ``transition`` matrix (rows sum to 1); ``mu0``: the initial model
    probabilities (default: the chain's stationary distribution).  ``config``: a
    method-``"A"`` config (its ``pseudo_sigma``, ``gate``, window and weights; its own
    ``sigma_a`` is not used).  Returns the track (combined estimate and covariance) and,
    as its ``ess`` field, the first model's probability per scan.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> from trackcore.scenarios.tbd_radar import TBD_INITIAL_COVARIANCE as P0
    >>> from trackcore.trackers import TbdTrackerConfig, tbd_position_errors
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> from trackcore.trackers.tbd_baselines import run_tbd_imm
    >>> cfg = TbdTrackerConfig(method="A", processing_radius=1000.0)
    >>> res = run_tbd_imm(scans, truth.states[0], P0, cfg, sigma_a=(3.0, 30.0),
    ...     transition=((0.99, 0.01), (0.1, 0.9)))
    >>> res.estimates.shape, res.covariances.shape
    ((20, 6), (20, 6, 6))
    """
    _check(config, "A")
    sig = as_array(sigma_a, "sigma_a", ndim=1)
    M = sig.size
    if M < 1 or not np.all(np.isfinite(sig)) or np.any(sig < 0):
        raise ValueError(f"sigma_a must be one or more finite values >= 0, got {sigma_a}")
    PI = as_array(transition, "transition", shape=(M, M))
    for v in PI.ravel():
        as_probability(float(v), "transition")
    if not np.allclose(PI.sum(axis=1), 1.0, atol=1e-9):
        raise ValueError("the rows of transition must sum to 1")
    if mu0 is None:
        vals, vecs = np.linalg.eig(PI.T)
        p = np.abs(np.real(vecs[:, np.argmin(np.abs(vals - 1.0))]))
        mu = p / p.sum()
    else:
        mu = as_array(mu0, "mu0", shape=(M,))
        if np.any(mu < 0) or not math.isclose(mu.sum(), 1.0, abs_tol=1e-9):
            raise ValueError("mu0 must be probabilities summing to 1")
    x0, P0, common, out = _inputs(scans, x0, P0, config)
    T = config.scan_period
    F = cv_transition(T, dim=3)
    Qs = np.array([cv_process_noise(T, s ** 2, dim=3, kind="dwna") for s in sig])
    K = out["est"].shape[0]
    nis, mus = np.full(K, np.nan), np.empty((K, M))
    _imm_kernel(x0, P0, F, Qs, np.ascontiguousarray(PI), mu.astype(np.float64),
                float(config.pseudo_sigmas[0]), *common, float(config.gate), out["est"],
                out["cov"], out["centers"], out["nproc"], out["processed"], out["accepted"],
                nis, mus)
    return _result(out, ess=mus[:, 0].copy(), nis=nis)
