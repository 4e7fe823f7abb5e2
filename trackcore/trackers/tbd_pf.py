"""Radar track-before-detect with SNR/Marcum-Q weights (Kwon, Kang & Kwak 2016).

Three trackers over thresholded radar detections that carry a 3-D position, a radial
velocity (Doppler) and a measured SNR ``ζ`` (linear).  Each detection's score is
``P_D(ζ) = Q1(sqrt(2 ζ), sqrt(-2 ln P_fa))`` (eq 9), computed once per detection with
:func:`trackcore.detection.log_marcum_detection_probability`.

* ``"A"`` -- the detections inside the processing sphere are collapsed into one
  weighted-mean position ``p̄`` (eqs 10-11, normalised weights, erratum 4), converted to
  (range, azimuth, elevation) and fed to an EKF with a chi-square validation gate
  (``gate = inf`` gives the paper's literal, ungated EKF).  The covariance the EKF
  assigns to ``p̄`` is a choice the paper leaves open (``pseudo_covariance``): by
  default an isotropic covariance calibrated on ``p̄``'s own error (see
  :func:`pseudo_measurement_errors`), as options the detections' weighted spread plus
  the sensor noise, or the noise of one detection.
* ``"B"`` -- the same ``p̄`` feeds a particle filter:
  ``w^i ∝ w^i_{k-1} exp(-||p^i - p̄|| / σ_r)``.
* ``"C"`` -- the proposed method, eqs 12-15 with the errata: every particle is weighted by
  the sum over all detections in the window,
  ``log w̄^i = logsumexp_j(log P_D,j - ||p^i - p_j||/σ_r - |ṙ(s^i) - ṙ_j|/σ_v)``, times
  its previous weight (SIS, erratum 6); a scan without detections leaves the weights
  unchanged.

All particle trackers propagate with the DWNA CV model (erratum 2), estimate with the
weighted mean (erratum 3), and resample systematically when ``N_eff = 1/Σw²`` (erratum 7)
falls below ``resample_threshold · N``.  The processing window is the sphere of radius
``processing_radius`` around the predicted position.  A whole run is one numba kernel;
the per-scan cost is ``O(N m)`` for method C (``m`` detections in the window) plus
``O(M)`` to select the window among all ``M`` detections of the scan.

The ``"P"`` method is the book's extension (not in the paper): a PDA-style particle
likelihood ``1 - P_D P_G + (P_D/λ) Σ_j ℓ_a(ζ_j) N(z_j; h(s^i), R)`` with the Rician
amplitude likelihood ratio ``ℓ_a``; see :func:`run_tbd_tracker`.

Detections without a Doppler measurement are handled by ``sigma_v = math.inf`` (the
Doppler factor of eqs 10 and 13 is then 1) and, for method P,
``sigma_range_rate = math.inf``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_count, as_covariance, as_int, as_nonnegative,
                               as_offsets, as_positive, as_probability, as_rng, as_scalar,
                               as_vector)
from ..detection.marcum import (log_marcum_detection_probability,
                                log_marcum_detection_probability_scalar_kernel,
                                marcum_detection_probability, rician_log_likelihood_ratio)
from ..filters.kalman import kf_predict_kernel, kf_update_kernel
from ..filters.particle import noise_factor, propagate_linear_kernel, systematic_resample_kernel
from ..models.measurement import wrap_angle_kernel
from ..models.motion import cv_process_noise, cv_transition

__all__ = [
    "TBD_METHODS",
    "TBD_KERNELS",
    "TBD_PSEUDO_COVARIANCES",
    "TBD_PSEUDO_SIGMA",
    "TBD_WEIGHT_REFERENCES",
    "TbdTrackerConfig",
    "TbdTrackResult",
    "run_tbd_tracker",
    "range_azimuth_elevation",
    "range_azimuth_elevation_jacobian",
    "spherical_to_cartesian",
    "radial_velocity",
    "detection_snr_cap",
    "weighted_mean_detection",
    "direct_particle_log_weights",
    "pseudo_measurement_errors",
    "tbd_position_errors",
    "tbd_measurement_errors",
    "tbd_nees",
    "tbd_track_lost",
    "tbd_loss_onset",
    "tbd_run_outcomes",
    "TbdRunOutcomes",
    "TbdErrorSummary",
    "tbd_error_summary",
]

#: method codes accepted by :class:`TbdTrackerConfig`
TBD_METHODS = ("A", "B", "C", "P")
_CODE = {"A": 0, "B": 1, "C": 2, "P": 3}
_LOG_2PI = math.log(2.0 * math.pi)

#: how method A's EKF sees the weighted-mean pseudo-measurement ``p̄``
#: (:class:`TbdTrackerConfig` ``pseudo_covariance``)
TBD_PSEUDO_COVARIANCES = ("calibrated", "spread", "sensor")
_PSEUDO_CODE = {"calibrated": 0, "spread": 1, "sensor": 2}

#: the state from which eq (10) measures ``r_m`` and ``v_m`` for methods A and B
#: (:class:`TbdTrackerConfig` ``weight_reference``): the prediction ``ŝ_{k|k-1}`` (default)
#: or the previous estimate ``ŝ_{k-1|k-1}`` (the paper's words, "이전 추정 좌표")
TBD_WEIGHT_REFERENCES = ("prediction", "previous")

#: Per-axis standard deviations (position in m, Doppler in m/s) of the pseudo-measurement
#: ``p̄`` of eqs (10)-(11) on the chapter's scenario, by processing radius (m): the root
#: mean square of ``p̄`` minus the true position over the approach (scans 0-99, 200 runs)
#: with the window centred on the truth, from :func:`pseudo_measurement_errors`.  They
#: are the default covariance of method A (``pseudo_covariance="calibrated"``); the
#: chapter's tracking notebook recomputes them and asserts these values.
TBD_PSEUDO_SIGMA = {2500.0: (387.0, 64.0), 1000.0: (194.0, 94.0)}


# =============================================================================== geometry
@nb.njit(cache=True, inline="always")
def _rae(x0, x1, x2):
    r = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    az = math.atan2(x1, x0)
    el = math.asin(x2 / r) if r > 0.0 else 0.0
    return r, az, el


@nb.njit(cache=True, inline="always")
def _radial_velocity(s0, s1, s2, s3, s4, s5):
    r = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    if r == 0.0:
        return 0.0
    return (s0 * s3 + s1 * s4 + s2 * s5) / r


@nb.njit(cache=True)
def _rae_jacobian_kernel(x, H, with_doppler):
    """Jacobian of (r, az, el[, ṙ]) w.r.t. [x, y, z, vx, vy, vz] into ``H`` (3 or 4, 6)."""
    px, py, pz = x[0], x[1], x[2]
    rho2 = px * px + py * py
    rho = math.sqrt(rho2)
    r2 = rho2 + pz * pz
    r = math.sqrt(r2)
    for i in range(H.shape[0]):
        for j in range(6):
            H[i, j] = 0.0
    H[0, 0] = px / r
    H[0, 1] = py / r
    H[0, 2] = pz / r
    H[1, 0] = -py / rho2
    H[1, 1] = px / rho2
    H[2, 0] = -px * pz / (r2 * rho)
    H[2, 1] = -py * pz / (r2 * rho)
    H[2, 2] = rho / r2
    if with_doppler:
        vx, vy, vz = x[3], x[4], x[5]
        rdot = (px * vx + py * vy + pz * vz) / r
        H[3, 0] = (vx - rdot * px / r) / r
        H[3, 1] = (vy - rdot * py / r) / r
        H[3, 2] = (vz - rdot * pz / r) / r
        H[3, 3] = px / r
        H[3, 4] = py / r
        H[3, 5] = pz / r


#: the largest position (m), velocity (m/s) or range rate a public function accepts, and
#: the largest covariance entry: far beyond any radar, small enough that no square or
#: product of them overflows
_LIMIT = 1e12
_COV_LIMIT = 1e24


def _bounded(arr, name, limit=_LIMIT):
    """``arr`` itself, after checking that every entry lies within ``±limit``."""
    if arr.size and np.max(np.abs(arr)) > limit:
        raise ValueError(f"{name} must lie within +-{limit:.0e} (metres, m/s), "
                         f"got {np.max(np.abs(arr)):.3g}")
    return arr


def _states(x, name, n):
    arr = _bounded(as_array(x, name, ndim=(1, 2)), name)
    single = arr.ndim == 1
    arr2 = arr.reshape(1, -1) if single else arr
    if arr2.shape[1] < n:
        raise ValueError(f"{name} must have at least {n} components per state, "
                         f"got {arr2.shape[1]}")
    return arr2, single


def range_azimuth_elevation(x):
    """``(r, azimuth, elevation)`` of positions ``x[..., :3]`` seen from the origin.

    Azimuth ``atan2(y, x)`` (counter-clockwise from +x), elevation ``asin(z / r)``.
    ``x`` is ``(n,)`` or ``(N, n)`` with ``n >= 3``; returns ``(3,)`` or ``(N, 3)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import range_azimuth_elevation
    >>> r, az, el = range_azimuth_elevation(np.array([3000.0, 4000.0, 0.0]))
    >>> print(round(float(r), 1), round(float(np.degrees(az)), 2), float(el))
    5000.0 53.13 0.0
    """
    X, single = _states(x, "x", 3)
    r = np.linalg.norm(X[:, :3], axis=1)
    if np.any(r == 0):
        raise ValueError("x must not be at the radar (range 0)")
    out = np.column_stack([r, np.arctan2(X[:, 1], X[:, 0]), np.arcsin(X[:, 2] / r)])
    return out[0] if single else out


def range_azimuth_elevation_jacobian(x, with_doppler=False):
    """Jacobian ``(3, 6)`` (``(4, 6)`` with the range rate) at one state ``x`` (6,).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import range_azimuth_elevation_jacobian
    >>> H = range_azimuth_elevation_jacobian(np.array([3000.0, 4000.0, 0.0, -200.0, 0.0, 0.0]))
    >>> H.shape, H[0, :3].round(2)
    ((3, 6), array([0.6, 0.8, 0. ]))
    >>> range_azimuth_elevation_jacobian(np.ones(6), with_doppler=True).shape
    (4, 6)
    """
    x = _bounded(as_vector(x, "x", 6), "x")
    if not np.hypot(x[0], x[1]) >= 1e-100:
        raise ValueError("x must not lie on (or within 1e-100 m of) the z axis (azimuth "
                         "undefined)")
    H = np.empty((4 if with_doppler else 3, 6))
    _rae_jacobian_kernel(x, H, bool(with_doppler))
    return H


def spherical_to_cartesian(z):
    """Positions ``(N, 3)`` (or ``(3,)``) from ``(r, azimuth, elevation)`` rows.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import spherical_to_cartesian
    >>> spherical_to_cartesian(np.array([5000.0, np.arctan2(4.0, 3.0), 0.0])).round(1)
    array([3000., 4000.,    0.])
    """
    Z, single = _states(z, "z", 3)
    r, az, el = Z[:, 0], Z[:, 1], Z[:, 2]
    ce = np.cos(el)
    out = np.column_stack([r * ce * np.cos(az), r * ce * np.sin(az), r * np.sin(el)])
    return out[0] if single else out


def radial_velocity(x):
    """Radial velocity ``p·v / ||p||`` of states ``[x, y, z, vx, vy, vz]`` (radar at the
    origin).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import radial_velocity
    >>> print(round(float(radial_velocity(np.array([3000.0, 4000.0, 0.0, -200.0, 0.0, 0.0]))), 1))
    -120.0
    """
    X, single = _states(x, "x", 6)
    r = np.linalg.norm(X[:, :3], axis=1)
    safe = np.where(r > 0, r, 1.0)
    out = np.where(r > 0, np.einsum("ij,ij->i", X[:, :3], X[:, 3:6]) / safe, 0.0)
    return float(out[0]) if single else out


# =============================================================================== SNR score
def detection_snr_cap(pfa):
    """The measured SNR above which ``P_D`` of eq (9) is 1 to double precision.

    ``ζ_cap = (sqrt(-2 ln P_fa) + 10)² / 2``: there ``1 - P_D < 1e-22`` (the Rician tail
    ten standard deviations beyond the threshold), so ``log P_D`` lies within ``1e-22``
    of 0 for every ``ζ >= ζ_cap``.  The trackers evaluate eq (9) at ``min(ζ, ζ_cap)``,
    which changes no weight by more than that and keeps the cost of the Marcum
    function bounded for any finite ``ζ``.

    Examples
    --------
    >>> from trackcore.trackers import detection_snr_cap
    >>> print(round(float(detection_snr_cap(1e-6)), 1))
    116.4
    """
    pfa = as_probability(pfa, "pfa", open_low=True, open_high=True)
    return 0.5 * (math.sqrt(-2.0 * math.log(pfa)) + 10.0) ** 2


def _as_snr(snr, name, shape):
    s = as_array(snr, name, shape=shape)
    if s.size and np.any(s < 0):
        raise ValueError(f"{name} must be a non-negative linear power ratio (not dB)")
    return s


def _log_pd(snr, pfa):
    """``log P_D`` of eq (9) at the measured SNRs, capped at :func:`detection_snr_cap`."""
    cap = detection_snr_cap(pfa)
    return np.ascontiguousarray(log_marcum_detection_probability(np.minimum(snr, cap), pfa))


# =============================================================================== weights
#: kernel shapes of eqs (10)/(13): the paper's exp(-x) and the Gaussian exp(-x^2/2), x = d/σ
TBD_KERNELS = ("laplace", "gaussian")


@nb.njit(cache=True, inline="always")
def _neg_log_kernel(x, gauss):
    return 0.5 * x * x if gauss else x


@nb.njit(cache=True)
def _weighted_mean_kernel(idx, m, pos, rr, lpd, p_ref, rr_ref, inv_r, inv_v, gauss, lw,
                          out_p):
    """Eqs (10)-(11) with normalised weights: p̄ into ``out_p``; returns the weighted ṙ̄.

    ``lpd[t]`` is ``log P_D`` of detection ``idx[t]``; ``lw`` (>= m,) receives the
    *normalised* weights ``w̄_t``.  ``inv_v = 0`` drops the Doppler factor.  Returns NaN
    if every weight underflows.
    """
    mx = -np.inf
    for t in range(m):
        j = idx[t]
        d = math.sqrt((pos[j, 0] - p_ref[0]) ** 2 + (pos[j, 1] - p_ref[1]) ** 2
                      + (pos[j, 2] - p_ref[2]) ** 2)
        lw[t] = (lpd[t] - _neg_log_kernel(d * inv_r, gauss)
                 - _neg_log_kernel(abs(rr[j] - rr_ref) * inv_v, gauss))
        if lw[t] > mx:
            mx = lw[t]
    if mx == -np.inf:
        return np.nan
    tot = 0.0
    for t in range(m):
        lw[t] = math.exp(lw[t] - mx)
        tot += lw[t]
    out_p[0] = 0.0
    out_p[1] = 0.0
    out_p[2] = 0.0
    rbar = 0.0
    for t in range(m):
        j = idx[t]
        w = lw[t] / tot
        lw[t] = w
        out_p[0] += w * pos[j, 0]
        out_p[1] += w * pos[j, 1]
        out_p[2] += w * pos[j, 2]
        rbar += w * rr[j]
    return rbar


@nb.njit(cache=True)
def _direct_loglik_kernel(particles, idx, m, pos, rr, lpd, inv_r, inv_v, gauss, tmp, out):
    """Eqs (13)-(14) in log space: ``out[i] = logsumexp_j(log P_D,j - d_ij/σ_r - δ_ij/σ_v)``
    (``inv_v = 0``: no Doppler factor)."""
    N = particles.shape[0]
    for i in range(N):
        x0 = particles[i, 0]
        x1 = particles[i, 1]
        x2 = particles[i, 2]
        rdot = _radial_velocity(x0, x1, x2, particles[i, 3], particles[i, 4], particles[i, 5])
        mx = -np.inf
        for t in range(m):
            j = idx[t]
            d = math.sqrt((x0 - pos[j, 0]) ** 2 + (x1 - pos[j, 1]) ** 2 + (x2 - pos[j, 2]) ** 2)
            v = (lpd[t] - _neg_log_kernel(d * inv_r, gauss)
                 - _neg_log_kernel(abs(rdot - rr[j]) * inv_v, gauss))
            tmp[t] = v
            if v > mx:
                mx = v
        if mx == -np.inf:
            out[i] = -np.inf
            continue
        s = 0.0
        for t in range(m):
            s += math.exp(tmp[t] - mx)
        out[i] = mx + math.log(s)


@nb.njit(cache=True)
def _pda_loglik_kernel(particles, idx, m, pos, rr, logla, log_pd, log_miss, log_rho,
                       rae_density, sig_range, sig_angle, sig_rr, tmp, out):
    """Extension "P": ``log(1 - P_D + (P_D / λ_i) Σ_j ℓ_j N(z_j; h(s^i), R))``.

    The measurement model is (r, az, el[, ṙ]) with independent Gaussian errors; the
    Cartesian detection is converted back to spherical coordinates (exactly, since the
    simulator drew its noise there).  ``sig_rr = inf`` drops the range rate.
    ``logla[j]`` is the log likelihood ratio of the *thresholded* amplitude densities.
    The false-alarm density in (r, az, el[, ṙ]) space at the particle is
    ``λ_i = ρ r_i² cos(el_i)`` with ``ρ`` (``log_rho``) the Cartesian density per m³ [per
    (m/s) of Doppler]; with ``rae_density`` it is the constant ``exp(log_rho)`` itself
    (a sensor whose cells are fixed in range and angle).
    """
    N = particles.shape[0]
    dop = not math.isinf(sig_rr)
    c = -1.5 * _LOG_2PI - math.log(sig_range) - 2.0 * math.log(sig_angle)
    if dop:
        c -= 0.5 * _LOG_2PI + math.log(sig_rr)
    for i in range(N):
        r_i, az_i, el_i = _rae(particles[i, 0], particles[i, 1], particles[i, 2])
        rdot = _radial_velocity(particles[i, 0], particles[i, 1], particles[i, 2],
                                particles[i, 3], particles[i, 4], particles[i, 5])
        if rae_density:
            log_lam = log_rho
        else:
            log_lam = log_rho + 2.0 * math.log(r_i) + math.log(math.cos(el_i))
        mx = log_miss
        for t in range(m):
            j = idx[t]
            r_j, az_j, el_j = _rae(pos[j, 0], pos[j, 1], pos[j, 2])
            e0 = (r_j - r_i) / sig_range
            e1 = wrap_angle_kernel(az_j - az_i) / sig_angle
            e2 = (el_j - el_i) / sig_angle
            q = e0 * e0 + e1 * e1 + e2 * e2
            if dop:
                e3 = (rr[j] - rdot) / sig_rr
                q += e3 * e3
            v = log_pd - log_lam + logla[j] + c - 0.5 * q
            tmp[t] = v
            if v > mx:
                mx = v
        s = math.exp(log_miss - mx)
        for t in range(m):
            s += math.exp(tmp[t] - mx)
        out[i] = mx + math.log(s)


# =============================================================================== run kernels
@nb.njit(cache=True)
def _window(pos, snr, log_pfa, snr_cap, lo, hi, p, R, idx, lpd, processed, cache):
    """Detections of rows ``lo:hi`` within ``R`` of ``p``: indices into ``idx`` and their
    ``log P_D`` (eq 9 at ``min(ζ, snr_cap)``, evaluated only for the detections that are
    processed) into ``lpd``.  ``cache`` (M,) holds the values already evaluated (NaN:
    not yet) and receives the new ones."""
    m = 0
    R2 = R * R
    for j in range(lo, hi):
        d2 = (pos[j, 0] - p[0]) ** 2 + (pos[j, 1] - p[1]) ** 2 + (pos[j, 2] - p[2]) ** 2
        if d2 <= R2:
            idx[m] = j
            if math.isnan(cache[j]):
                cache[j] = log_marcum_detection_probability_scalar_kernel(
                    min(snr[j], snr_cap), log_pfa)
            lpd[m] = cache[j]
            processed[j] = True
            m += 1
    return m


@nb.njit(cache=True)
def _scan_window(k, x, pos, snr, log_pfa, snr_cap, offsets, R, idx, lpd, processed, cache,
                 centers, nproc):
    """Scan ``k``'s processing window around ``x[:3]``: records the centre in
    ``centers[k]``, selects the detections inside (:func:`_window`), records their count
    in ``nproc[k]`` and returns it."""
    for a in range(3):
        centers[k, a] = x[a]
    m = _window(pos, snr, log_pfa, snr_cap, offsets[k], offsets[k + 1], x, R, idx, lpd,
                processed, cache)
    nproc[k] = m
    return m


@nb.njit(cache=True)
def _pf_predict(k, particles, F, L, rng, logw, w, mean):
    """A particle filter's prediction to scan ``k`` (none at ``k = 0``) and the weighted
    mean state ``mean`` of the predicted cloud."""
    if k > 0:
        propagate_linear_kernel(particles, F, L, rng, particles)
    _weighted_state(particles, logw, w, mean)


@nb.njit(cache=True)
def _weighted_state(particles, logw, w, mean):
    """Normalised weights into ``w`` (from ``logw``) and the weighted mean state."""
    N, n = particles.shape
    mx = -np.inf
    for i in range(N):
        if logw[i] > mx:
            mx = logw[i]
    tot = 0.0
    for i in range(N):
        w[i] = math.exp(logw[i] - mx)
        tot += w[i]
    for a in range(n):
        mean[a] = 0.0
    s2 = 0.0
    for i in range(N):
        w[i] /= tot
        s2 += w[i] * w[i]
        for a in range(n):
            mean[a] += w[i] * particles[i, a]
    return 1.0 / s2


@nb.njit(cache=True)
def _roughen(particles, K, rng):
    """Roughening (Gordon, Salmond & Smith 1993): add ``N(0, (K E_a N^{-1/n})^2)`` to
    component ``a`` of every particle, ``E_a`` the spread (max - min) of that component."""
    N, n = particles.shape
    scale = K * N ** (-1.0 / n)
    for a in range(n):
        lo = particles[0, a]
        hi = particles[0, a]
        for i in range(1, N):
            v = particles[i, a]
            if v < lo:
                lo = v
            if v > hi:
                hi = v
        sd = scale * (hi - lo)
        for i in range(N):
            particles[i, a] += sd * rng.standard_normal()


@nb.njit(cache=True)
def _pf_scan_loglik(method, particles, idx, m, pos, rr, lpd, ref, inv_r, inv_v, gauss,
                    use_doppler, logla, log_pd, log_miss, log_rho, rae_density, sig_range,
                    sig_angle, sig_rr, tmp, pbar, ll):
    """One scan's log-likelihood of every particle into ``ll`` for methods B, C and P from
    the ``m`` detections ``idx[:m]`` of ``pos``/``rr`` (``lpd``: their ``log P_D``); ``ref``
    is the state that eq (10) measures ``r_m`` and ``v_m`` from (method B).
    Returns False when the scan carries no information (no update)."""
    N = particles.shape[0]
    if m == 0:
        return False
    if method == 2:
        _direct_loglik_kernel(particles, idx, m, pos, rr, lpd, inv_r, inv_v, gauss, tmp, ll)
        return True
    if method == 3:
        _pda_loglik_kernel(particles, idx, m, pos, rr, logla, log_pd, log_miss, log_rho,
                           rae_density, sig_range, sig_angle, sig_rr, tmp, ll)
        return True
    rr_ref = _radial_velocity(ref[0], ref[1], ref[2], ref[3], ref[4], ref[5])
    rbar = _weighted_mean_kernel(idx, m, pos, rr, lpd, ref, rr_ref, inv_r, inv_v, gauss,
                                 tmp, pbar)
    if math.isnan(rbar):
        return False
    for i in range(N):
        d = math.sqrt((particles[i, 0] - pbar[0]) ** 2 + (particles[i, 1] - pbar[1]) ** 2
                      + (particles[i, 2] - pbar[2]) ** 2)
        v = -_neg_log_kernel(d * inv_r, gauss)
        if use_doppler:
            rd = _radial_velocity(particles[i, 0], particles[i, 1], particles[i, 2],
                                  particles[i, 3], particles[i, 4], particles[i, 5])
            v -= _neg_log_kernel(abs(rd - rbar) * inv_v, gauss)
        ll[i] = v
    return True


@nb.njit(cache=True)
def _pf_scan_finish(k, particles, logw, ll, updated, resample_below, roughening, rng, w,
                    mean, ridx, work, est, cov, want_cov, ess, resampled):
    """SIS update with ``ll`` (if ``updated``), the weighted estimate (and, if
    ``want_cov``, covariance) of scan ``k``, and systematic resampling below
    ``resample_below``."""
    N, n = particles.shape
    if updated:
        # SIS: multiply by the previous weights; all-zero (underflow) -> keep the old ones
        mx = -np.inf
        for i in range(N):
            v = logw[i] + ll[i]
            if v > mx:
                mx = v
        if mx > -np.inf:
            for i in range(N):
                logw[i] = logw[i] + ll[i] - mx
    n_eff = _weighted_state(particles, logw, w, mean)
    for a in range(n):
        est[k, a] = mean[a]
    if want_cov:
        for a in range(n):
            for b in range(n):
                cov[k, a, b] = 0.0
        for i in range(N):
            wi = w[i]
            for a in range(n):
                da = particles[i, a] - mean[a]
                for b in range(a, n):
                    cov[k, a, b] += wi * da * (particles[i, b] - mean[b])
        for a in range(n):
            for b in range(a + 1, n):
                cov[k, b, a] = cov[k, a, b]
    ess[k] = n_eff
    if n_eff < resample_below:
        systematic_resample_kernel(w, rng, ridx)
        for i in range(N):
            src = ridx[i]
            for a in range(n):
                work[i, a] = particles[src, a]
        for i in range(N):
            for a in range(n):
                particles[i, a] = work[i, a]
            logw[i] = 0.0
        if roughening > 0.0:
            _roughen(particles, roughening, rng)
        resampled[k] = True


@nb.njit(cache=True)
def _pf_run_kernel(method, particles, logw, F, L, pos, rr, snr, log_pfa, snr_cap, cache, logla,
                   offsets, R, inv_r, inv_v, gauss, use_doppler, from_previous, resample_below,
                   log_pd, log_miss, log_rho, rae_density, sig_range, sig_angle, sig_rr,
                   roughening, rng, est, cov, want_cov, centers, nproc, processed, ess,
                   resampled):
    N = particles.shape[0]
    K = offsets.shape[0] - 1
    max_m = 0
    for k in range(K):
        if offsets[k + 1] - offsets[k] > max_m:
            max_m = offsets[k + 1] - offsets[k]
    idx = np.empty(max(max_m, 1), dtype=np.int64)
    tmp = np.empty(max(max_m, 1))
    lpd = np.empty(max(max_m, 1))
    ll = np.empty(N)
    w = np.empty(N)
    mean = np.empty(6)
    pbar = np.empty(3)
    ridx = np.empty(N, dtype=np.int64)
    work = np.empty_like(particles)
    for k in range(K):
        _pf_predict(k, particles, F, L, rng, logw, w, mean)
        m = _scan_window(k, mean, pos, snr, log_pfa, snr_cap, offsets, R, idx, lpd,
                         processed, cache, centers, nproc)
        ref = est[k - 1] if (from_previous and k > 0) else mean
        updated = _pf_scan_loglik(method, particles, idx, m, pos, rr, lpd, ref, inv_r,
                                  inv_v, gauss, use_doppler, logla, log_pd, log_miss,
                                  log_rho, rae_density, sig_range, sig_angle, sig_rr, tmp,
                                  pbar, ll)
        _pf_scan_finish(k, particles, logw, ll, updated, resample_below, roughening, rng, w,
                        mean, ridx, work, est, cov, want_cov, ess, resampled)


@nb.njit(cache=True)
def _pseudo_covariance_kernel(mode, idx, m, pos, rr, wbar, pbar, rbar, sig_p, sig_prr,
                              Rsens, nz, J, Rm):
    """Method A's measurement covariance ``Rm`` (nz, nz) of ``p̄`` in (r, az, el[, ṙ]).

    ``mode`` 0: isotropic ``sig_p`` per Cartesian axis (``sig_prr`` for ṙ̄); 1: the
    sensor noise ``Rsens`` plus the weighted spread ``Σ w̄_j d_j d_jᵀ`` of the detections
    about ``p̄`` (``d_j`` mapped to (r, az, el[, ṙ]) by the Jacobian ``J`` at ``p̄``);
    2: ``Rsens`` alone (one detection's noise, the paper's sensor figures).
    """
    for a in range(nz):
        for b in range(nz):
            Rm[a, b] = 0.0
    if mode == 0:
        r, az, el = _rae(pbar[0], pbar[1], pbar[2])
        s2 = sig_p * sig_p
        Rm[0, 0] = s2
        ce = math.cos(el)
        Rm[1, 1] = s2 / (r * r * ce * ce)
        Rm[2, 2] = s2 / (r * r)
        if nz == 4:
            Rm[3, 3] = sig_prr * sig_prr
        return
    for a in range(nz):
        for b in range(nz):
            Rm[a, b] = Rsens[a, b]
    if mode == 2:
        return
    d = np.empty(4)
    for t in range(m):
        j = idx[t]
        for a in range(3):
            d[a] = 0.0
            for c in range(3):
                d[a] += J[a, c] * (pos[j, c] - pbar[c])
        d[3] = rr[j] - rbar
        wt = wbar[t]
        for a in range(nz):
            for b in range(nz):
                Rm[a, b] += wt * d[a] * d[b]


@nb.njit(cache=True)
def _ekf_run_kernel(x, P, F, Q, Rsens, mode, sig_p, sig_prr, pos, rr, snr, log_pfa, snr_cap,
                    cache, offsets, R, inv_r, inv_v, gauss, gate, use_doppler, from_previous, est, cov,
                    centers, nproc, processed, accepted, nis_out):
    K = offsets.shape[0] - 1
    nz = 4 if use_doppler else 3
    max_m = 0
    for k in range(K):
        if offsets[k + 1] - offsets[k] > max_m:
            max_m = offsets[k + 1] - offsets[k]
    idx = np.empty(max(max_m, 1), dtype=np.int64)
    wbar = np.empty(max(max_m, 1))
    lpd = np.empty(max(max_m, 1))
    pbar = np.empty(3)
    xp = np.empty(6)
    Pp = np.empty((6, 6))
    xu = np.empty(6)
    Pu = np.empty((6, 6))
    H = np.empty((nz, 6))
    Jp = np.empty((3, 6))
    Rm = np.empty((nz, nz))
    z = np.empty(nz)
    innov = np.empty(nz)
    S = np.empty((nz, nz))
    Kg = np.empty((6, nz))
    xs = np.zeros(6)
    for k in range(K):
        if k > 0:
            kf_predict_kernel(x, P, F, Q, xp, Pp)
            x[:] = xp
            P[:, :] = Pp
        rr_pred = _radial_velocity(x[0], x[1], x[2], x[3], x[4], x[5])
        m = _scan_window(k, x, pos, snr, log_pfa, snr_cap, offsets, R, idx, lpd, processed,
                         cache, centers, nproc)
        nis_out[k] = np.nan
        if m > 0:
            ref = est[k - 1] if (from_previous and k > 0) else x
            rr_ref = _radial_velocity(ref[0], ref[1], ref[2], ref[3], ref[4], ref[5])
            rbar = _weighted_mean_kernel(idx, m, pos, rr, lpd, ref, rr_ref, inv_r, inv_v,
                                         gauss, wbar, pbar)
            if not math.isnan(rbar):
                r_m, az_m, el_m = _rae(pbar[0], pbar[1], pbar[2])
                r_p, az_p, el_p = _rae(x[0], x[1], x[2])
                _rae_jacobian_kernel(x, H, use_doppler)
                if mode == 1:
                    for a in range(3):
                        xs[a] = pbar[a]
                    _rae_jacobian_kernel(xs, Jp, False)
                _pseudo_covariance_kernel(mode, idx, m, pos, rr, wbar, pbar, rbar, sig_p,
                                          sig_prr, Rsens, nz, Jp, Rm)
                # z' = (z - h(x), azimuth wrapped) + H x, so that z' - H x is the EKF innovation
                innov[0] = r_m - r_p
                innov[1] = wrap_angle_kernel(az_m - az_p)
                innov[2] = el_m - el_p
                if use_doppler:
                    innov[3] = rbar - rr_pred
                for i in range(nz):
                    s = innov[i]
                    for a in range(6):
                        s += H[i, a] * x[a]
                    z[i] = s
                nis, _, ok = kf_update_kernel(x, P, z, H, Rm, xu, Pu, innov, S, Kg)
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


# =============================================================================== public API
def _finite_or_inf(value, name):
    v = as_scalar(value, name, finite=False)
    if math.isnan(v) or v <= 0:
        raise ValueError(f"{name} must be > 0 (math.inf for none), got {value}")
    return v


@dataclass(frozen=True)
class TbdTrackerConfig:
    """Parameters of one TBD tracker (defaults: the chapter's choices, listed on its index
    page under "Choices we made").

    ``method``: ``"A"`` (weighted mean + EKF), ``"B"`` (weighted mean + PF), ``"C"``
    (direct particle weights, the paper's proposal) or ``"P"`` (extension: PDA particle
    likelihood with the amplitude likelihood ratio).  ``gate``: NIS threshold of the EKF
    (99 % of chi-square with 3 dof; ``math.inf`` = the paper's ungated EKF).

    ``pseudo_covariance`` (method A): the covariance the EKF gives the weighted mean
    ``p̄`` -- ``"calibrated"`` (default): isotropic, ``pseudo_sigma`` metres per Cartesian
    axis (and ``pseudo_sigma_rr`` m/s for the weighted-mean Doppler), by default the
    value of :data:`TBD_PSEUDO_SIGMA` for ``processing_radius``; ``"spread"``: the sensor
    noise plus the weighted spread of the detections about ``p̄``; ``"sensor"``: one
    detection's noise ``(sigma_range, sigma_angle, sigma_angle[, sigma_range_rate])``,
    the literal reading (ablation).

    ``weight_reference`` (methods A and B): the state from which eq (10) measures each
    detection's distance ``r_m`` and Doppler difference ``v_m``, ``"prediction"`` (default)
    or ``"previous"`` (the previous estimate, the paper's words; ablation).  The
    processing window is always centred on the prediction.

    ``use_doppler``: give (A)/(B) the weighted-mean Doppler too (ablation).  ``kernel``:
    ``"laplace"`` (the paper's ``exp(-d/σ)``) or ``"gaussian"`` (``exp(-d²/(2σ²))``,
    ablation).  ``sigma_v = math.inf``: the detections carry no Doppler (the Doppler
    factor of eqs 10 and 13 is 1).  ``roughening``: the constant ``K`` of roughening
    after each resampling (0 = off; Gordon et al. suggest about 0.2); PF methods only.
    ``pfa``: the ``P_fa`` inside eq (9).  ``resample_threshold``: resample when
    ``N_eff < resample_threshold * N``.  ``sigma_range``, ``sigma_angle``,
    ``sigma_range_rate``: one detection's measurement noise (method A's "spread" and
    "sensor" readings, method P's likelihood; ``sigma_range_rate = math.inf`` drops the
    range rate from P).  ``target_snr``, ``threshold_db``, ``clutter_density``: method P
    only (the design SNR of the amplitude likelihood ratio and of
    ``P_D = Q1(sqrt(2 S), sqrt(2 τ))``, the detection threshold ``τ`` in dB, and the
    Cartesian false-alarm density per m³ [per (m/s) of Doppler]; the default is the
    scenario's ``2.820 km⁻³ e^{-τ} / 600 m/s``).  ``clutter_density_rae`` (method P): if
    > 0, a false-alarm density that is constant in (range, azimuth, elevation) space,
    per m rad² (for a sensor with fixed range and angle cells); it replaces
    ``clutter_density``.

    Examples
    --------
    >>> from trackcore.trackers import TbdTrackerConfig
    >>> cfg = TbdTrackerConfig(method="A", processing_radius=1000.0)
    >>> cfg.method, cfg.n_particles, cfg.sigma_r, cfg.gate
    ('A', 600, 150.0, 11.345)
    >>> cfg.pseudo_sigmas
    (194.0, 94.0)
    """
    method: str = "C"
    n_particles: int = 600
    weight_reference: str = "prediction"
    processing_radius: float = 2500.0
    sigma_r: float = 150.0
    sigma_v: float = 40.0
    sigma_a: float = 15.0
    pfa: float = 1e-6
    resample_threshold: float = 0.5
    gate: float = 11.345
    use_doppler: bool = False
    kernel: str = "laplace"
    roughening: float = 0.0
    scan_period: float = 1.0
    pseudo_covariance: str = "calibrated"
    pseudo_sigma: float | None = None
    pseudo_sigma_rr: float | None = None
    sigma_range: float = 25.0
    sigma_angle: float = math.radians(0.15)
    sigma_range_rate: float = 2.0
    target_snr: float = 10.0 ** 0.6
    threshold_db: float = 5.0
    clutter_density: float = 2.820e-9 * math.exp(-10.0 ** 0.5) / 600.0
    clutter_density_rae: float = 0.0

    def __post_init__(self):
        if self.method not in TBD_METHODS:
            raise ValueError(f"method must be one of {TBD_METHODS}, got {self.method!r}")
        if self.kernel not in TBD_KERNELS:
            raise ValueError(f"kernel must be one of {TBD_KERNELS}, got {self.kernel!r}")
        if self.weight_reference not in TBD_WEIGHT_REFERENCES:
            raise ValueError(f"weight_reference must be one of {TBD_WEIGHT_REFERENCES}, "
                             f"got {self.weight_reference!r}")
        if self.pseudo_covariance not in TBD_PSEUDO_COVARIANCES:
            raise ValueError(f"pseudo_covariance must be one of {TBD_PSEUDO_COVARIANCES}, "
                             f"got {self.pseudo_covariance!r}")
        as_int(self.n_particles, "n_particles", minimum=1)
        for name in ("processing_radius", "sigma_r", "scan_period", "sigma_range",
                     "sigma_angle", "clutter_density"):
            as_positive(getattr(self, name), name)
        as_nonnegative(self.sigma_a, "sigma_a")
        _finite_or_inf(self.sigma_v, "sigma_v")
        _finite_or_inf(self.sigma_range_rate, "sigma_range_rate")
        _finite_or_inf(self.gate, "gate")
        as_nonnegative(self.roughening, "roughening")
        as_nonnegative(self.target_snr, "target_snr")
        as_nonnegative(self.clutter_density_rae, "clutter_density_rae")
        as_probability(self.pfa, "pfa", open_low=True, open_high=True)
        as_probability(self.resample_threshold, "resample_threshold")
        as_scalar(self.threshold_db, "threshold_db")
        if not isinstance(self.use_doppler, (bool, np.bool_)):
            raise TypeError(f"use_doppler must be a bool, got {type(self.use_doppler).__name__}")
        if self.use_doppler and math.isinf(self.sigma_v):
            raise ValueError("use_doppler needs Doppler measurements (a finite sigma_v)")
        for name in ("pseudo_sigma", "pseudo_sigma_rr"):
            if getattr(self, name) is not None:
                as_positive(getattr(self, name), name)
        if (self.method == "A" and self.pseudo_covariance == "calibrated"
                and (self.pseudo_sigma is None
                     or (self.use_doppler and self.pseudo_sigma_rr is None))
                and float(self.processing_radius) not in TBD_PSEUDO_SIGMA):
            raise ValueError(
                f"pseudo_sigma (and pseudo_sigma_rr with use_doppler) must be given for "
                f"processing_radius {self.processing_radius}: TBD_PSEUDO_SIGMA has values "
                f"only for {sorted(TBD_PSEUDO_SIGMA)}")

    @property
    def pseudo_sigmas(self):
        """``(σ_p, σ_ṙ)`` of the calibrated reading for this configuration."""
        table = TBD_PSEUDO_SIGMA.get(float(self.processing_radius), (math.nan, math.nan))
        sp = table[0] if self.pseudo_sigma is None else float(self.pseudo_sigma)
        sr = table[1] if self.pseudo_sigma_rr is None else float(self.pseudo_sigma_rr)
        return sp, sr


@dataclass(frozen=True)
class TbdTrackResult:
    """Output of :func:`run_tbd_tracker` over ``K`` scans with ``M`` detections in total.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> from trackcore.scenarios.tbd_radar import TBD_INITIAL_COVARIANCE as P0
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> from trackcore.trackers import TbdTrackerConfig, run_tbd_tracker
    >>> cfg = TbdTrackerConfig(method="A", processing_radius=1000.0)
    >>> res = run_tbd_tracker(scans, truth.states[0], P0, np.random.default_rng(2), cfg)
    >>> type(res).__name__, res.covariances.shape
    ('TbdTrackResult', (20, 6, 6))
    >>> bool(np.isnan(res.ess).all()), res.processed.shape == scans.snr.shape
    (True, True)
    """
    estimates: np.ndarray   # (K, 6) posterior estimates [x, y, z, vx, vy, vz]
    covariances: np.ndarray  # (K, 6, 6) EKF covariance (A) or weighted particle covariance
    #                          (None for a particle filter run with covariances=False)
    window_centers: np.ndarray  # (K, 3) predicted position: centre of the processing sphere
    n_processed: np.ndarray  # (K,) detections inside the processing sphere
    processed: np.ndarray   # (M,) bool: detection was inside the sphere of its scan
    ess: np.ndarray         # (K,) N_eff after the update (NaN for the EKF)
    resampled: np.ndarray   # (K,) bool: the PF resampled at this scan
    accepted: np.ndarray    # (K,) bool: the EKF accepted the pseudo-measurement (A only)
    nis: np.ndarray         # (K,) NIS of A's pseudo-measurement (NaN: none, or not A)


def _scan_arrays(scans):
    try:
        positions, range_rate, snr, offsets = (scans.positions, scans.range_rate, scans.snr,
                                               scans.offsets)
    except AttributeError:
        raise TypeError("scans must have attributes positions, range_rate, snr and offsets "
                        "(e.g. a trackcore.scenarios.TbdRadarScans)") from None
    pos = _bounded(as_array(positions, "scans.positions", ndim=2), "scans.positions")
    if pos.shape[1] != 3:
        raise ValueError(f"scans.positions must have shape (M, 3), got {pos.shape}")
    M = pos.shape[0]
    rr = _bounded(as_array(range_rate, "scans.range_rate", shape=(M,)), "scans.range_rate")
    snr = _as_snr(snr, "scans.snr", (M,))
    off = as_offsets(offsets, M, "scans.offsets", min_scans=1)
    return pos, rr, snr, off


def _inv(sigma):
    return 0.0 if math.isinf(sigma) else 1.0 / float(sigma)


def _pda_terms(config, snr):
    """``(log P_D, log(1 - P_D), log ℓ_a (M,))`` of method P's amplitude model."""
    tau = 10.0 ** (config.threshold_db / 10.0)
    pd = marcum_detection_probability(config.target_snr, math.exp(-tau))
    logla = np.zeros(snr.size)
    if snr.size:
        # thresholded densities: (p1 / P_D) / (p0 / P_fa)
        logla = np.ascontiguousarray(rician_log_likelihood_ratio(snr, config.target_snr)
                                     - math.log(pd) - tau)
    return math.log(pd), math.log1p(-pd), logla


def _pf_setup(x0, P0, rng, config):
    """Particles drawn from ``N(x0, P0)``, zero log-weights, and the DWNA CV model of
    ``config`` (anything with ``n_particles``, ``scan_period`` and ``sigma_a``)."""
    N = int(config.n_particles)
    chol = np.linalg.cholesky(P0)
    particles = np.ascontiguousarray(x0 + rng.standard_normal((N, 6)) @ chol.T)
    T = config.scan_period
    F = cv_transition(T, dim=3)
    L = noise_factor(cv_process_noise(T, config.sigma_a ** 2, dim=3, kind="dwna"))
    return particles, np.zeros(N), F, L


def _log_clutter(config):
    """``log ρ`` of method P: the (r, az, el) density if given, else the Cartesian one."""
    return math.log(config.clutter_density_rae if config.clutter_density_rae > 0
                    else config.clutter_density)


def run_tbd_tracker(scans, x0, P0, rng, config=TbdTrackerConfig(), *, covariances=True,
                    log_pd_cache=None):
    """Run one TBD tracker over a whole scenario run.

    ``scans``: an object with ``positions (M, 3)``, ``range_rate (M,)``, ``snr (M,)``
    (measured, linear, finite and >= 0) and ``offsets (K+1,)`` (scan ``k`` owns detections
    ``offsets[k]:offsets[k+1]``), e.g. :class:`trackcore.scenarios.TbdRadarScans`.
    ``x0``, ``P0``: the initial estimate and covariance at scan 0 (the EKF starts there;
    the particles are drawn from ``N(x0, P0)`` with ``rng``).  Scan 0 is processed without
    a prediction; every later scan is predicted over ``config.scan_period``.
    ``covariances=False`` skips the particle filters' weighted covariance (about a sixth
    of their cost; ``TbdTrackResult.covariances`` is then None); method A's EKF
    covariance is always returned.  ``log_pd_cache``: an optional float array (M,) shared
    by trackers that run on the same ``scans`` with the same ``config.pfa``; NaN entries
    are evaluated when a detection is first processed and stored, so eq (9) is evaluated
    once per detection however many trackers see it (the results do not change).
    Returns :class:`TbdTrackResult`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> from trackcore.scenarios.tbd_radar import TBD_INITIAL_COVARIANCE as P0
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> from trackcore.trackers import TbdTrackerConfig, run_tbd_tracker, tbd_position_errors
    >>> cfg = TbdTrackerConfig(method="C", n_particles=200, processing_radius=1000.0)
    >>> res = run_tbd_tracker(scans, truth.states[0], P0, np.random.default_rng(2), cfg)
    >>> res.estimates.shape, res.n_processed.shape
    ((20, 6), (20,))
    >>> bool(tbd_position_errors(res.estimates, truth.states).max() < 1000.0)
    True
    """
    if not isinstance(config, TbdTrackerConfig):
        raise TypeError(f"config must be a TbdTrackerConfig, got {type(config).__name__}")
    if not isinstance(covariances, (bool, np.bool_)):
        raise TypeError(f"covariances must be a bool, got {type(covariances).__name__}")
    if not isinstance(config, TbdTrackerConfig):
        raise TypeError(f"config must be a TbdTrackerConfig, got {type(config).__name__}")
    rng = as_rng(rng)
    pos, rr, snr, off = _scan_arrays(scans)
    x0 = _bounded(as_vector(x0, "x0", 6), "x0")
    P0 = _bounded(as_covariance(P0, "P0", 6, strict=True), "P0", _COV_LIMIT)
    K = off.size - 1
    M = pos.shape[0]
    log_pfa = math.log(config.pfa)
    cap = detection_snr_cap(config.pfa)
    if log_pd_cache is None:
        cache = np.full(max(M, 1), np.nan)
    else:
        cache = log_pd_cache
        if not (isinstance(cache, np.ndarray) and cache.dtype == np.float64
                and cache.shape == (M,) and cache.flags.c_contiguous):
            raise ValueError(f"log_pd_cache must be a contiguous float64 array of shape "
                             f"({M},) (one entry per detection)")
        if M == 0:
            cache = np.full(1, np.nan)
    est = np.empty((K, 6))
    cov = np.empty((K, 6, 6))
    centers = np.empty((K, 3))
    nproc = np.zeros(K, dtype=np.int64)
    processed = np.zeros(M, dtype=bool)
    resampled = np.zeros(K, dtype=bool)
    accepted = np.zeros(K, dtype=bool)
    nis = np.full(K, np.nan)
    inv_r, inv_v = _inv(config.sigma_r), _inv(config.sigma_v)
    gauss = config.kernel == "gaussian"
    if config.method == "A":
        T = config.scan_period
        F = cv_transition(T, dim=3)
        Q = cv_process_noise(T, config.sigma_a ** 2, dim=3, kind="dwna")
        Rsens = np.diag([config.sigma_range ** 2, config.sigma_angle ** 2,
                         config.sigma_angle ** 2, config.sigma_range_rate ** 2])
        sp, sr = config.pseudo_sigmas
        x = x0.copy()
        P = P0.copy()
        _ekf_run_kernel(x, P, F, Q, Rsens, _PSEUDO_CODE[config.pseudo_covariance], sp, sr,
                        pos, rr, snr, log_pfa, cap, cache, off,
                        float(config.processing_radius),
                        inv_r, inv_v, gauss, float(config.gate), bool(config.use_doppler),
                        config.weight_reference == "previous", est, cov, centers, nproc,
                        processed, accepted, nis)
        ess = np.full(K, np.nan)
    else:
        particles, logw, F, L = _pf_setup(x0, P0, rng, config)
        log_rho = _log_clutter(config)
        N = particles.shape[0]
        log_pd = log_miss = 0.0
        logla = np.zeros(M)
        if config.method == "P":
            log_pd, log_miss, logla = _pda_terms(config, snr)
        ess = np.empty(K)
        _pf_run_kernel(_CODE[config.method], particles, logw, F, L, pos, rr, snr, log_pfa,
                       cap, cache, logla, off, float(config.processing_radius), inv_r, inv_v,
                       gauss, bool(config.use_doppler), config.weight_reference == "previous",
                       float(config.resample_threshold * N), log_pd, log_miss, log_rho,
                       config.clutter_density_rae > 0, float(config.sigma_range),
                       float(config.sigma_angle), float(config.sigma_range_rate),
                       float(config.roughening), rng, est, cov, bool(covariances), centers,
                       nproc, processed, ess, resampled)
        if not covariances:
            cov = None
    return TbdTrackResult(est, cov, centers, nproc, processed, ess, resampled, accepted, nis)


# =============================================================================== pieces, for tests and notebooks
def _kernel_flag(kernel):
    if kernel not in TBD_KERNELS:
        raise ValueError(f"kernel must be one of {TBD_KERNELS}, got {kernel!r}")
    return kernel == "gaussian"


def _detections(positions, range_rate, snr):
    pos = _bounded(as_array(positions, "positions", ndim=2), "positions")
    m = pos.shape[0]
    if m and pos.shape[1] != 3:
        raise ValueError(f"positions must have shape (m, 3), got {pos.shape}")
    rr = _bounded(as_array(range_rate, "range_rate", shape=(m,)), "range_rate")
    snr = _as_snr(snr, "snr", (m,))
    return np.ascontiguousarray(pos.reshape(m, 3)), rr, snr


def weighted_mean_detection(positions, range_rate, snr, p_ref, rr_ref, sigma_r, sigma_v, pfa,
                            kernel="laplace"):
    """Eqs (10)-(11) with normalised weights (erratum 4): ``(p̄ (3,), ṙ̄)``.

    ``positions (m, 3)``, ``range_rate (m,)``, ``snr (m,)`` linear (finite, >= 0);
    ``p_ref`` (3,) and ``rr_ref`` the predicted position and radial velocity;
    ``sigma_v = math.inf`` drops the Doppler factor.  ``m = 0`` (or all weights zero)
    returns ``(None, None)``: there is no pseudo-measurement.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import weighted_mean_detection
    >>> pos = np.array([[1000.0, 0.0, 0.0], [1100.0, 0.0, 0.0]])
    >>> pbar, rbar = weighted_mean_detection(pos, [-100.0, -100.0], [10.0, 10.0],
    ...     [1050.0, 0.0, 0.0], -100.0, 150.0, 40.0, 1e-6)
    >>> pbar.round(1), round(float(rbar), 1)
    (array([1050.,    0.,    0.]), -100.0)
    """
    pos, rr, snr = _detections(positions, range_rate, snr)
    m = pos.shape[0]
    p_ref = _bounded(as_vector(p_ref, "p_ref", 3), "p_ref")
    rr_ref = float(_bounded(np.array([as_scalar(rr_ref, "rr_ref")]), "rr_ref")[0])
    sigma_r = as_positive(sigma_r, "sigma_r")
    sigma_v = _finite_or_inf(sigma_v, "sigma_v")
    pfa = as_probability(pfa, "pfa", open_low=True, open_high=True)
    gauss = _kernel_flag(kernel)
    if m == 0:
        return None, None
    out = np.empty(3)
    rbar = _weighted_mean_kernel(np.arange(m), m, pos, rr, _log_pd(snr, pfa), p_ref, rr_ref,
                                 1.0 / sigma_r, _inv(sigma_v), gauss, np.empty(m), out)
    if math.isnan(rbar):
        return None, None
    return out, float(rbar)


def direct_particle_log_weights(particles, positions, range_rate, snr, sigma_r, sigma_v, pfa,
                                kernel="laplace"):
    """Eqs (12)-(14) in log space: ``log w̄_s^i`` (N,) for particles ``(N, 6)``.

    ``snr`` (m,) linear, finite and >= 0; ``sigma_v = math.inf`` drops the Doppler factor.
    ``m = 0`` returns zeros (no information: the weights stay as they were).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import direct_particle_log_weights
    >>> particles = np.array([[1000.0, 0, 0, 0, 0, 0], [1600.0, 0, 0, 0, 0, 0]])
    >>> lw = direct_particle_log_weights(particles, [[1000.0, 0.0, 0.0]], [0.0], [10.0],
    ...     150.0, 40.0, 1e-6)
    >>> print(round(float(lw[0] - lw[1]), 3))  # 600 m / sigma_r = 4
    4.0
    """
    X = _bounded(as_array(particles, "particles", ndim=2), "particles")
    if X.shape[1] != 6:
        raise ValueError(f"particles must have shape (N, 6), got {X.shape}")
    pos, rr, snr = _detections(positions, range_rate, snr)
    m = pos.shape[0]
    sigma_r = as_positive(sigma_r, "sigma_r")
    sigma_v = _finite_or_inf(sigma_v, "sigma_v")
    pfa = as_probability(pfa, "pfa", open_low=True, open_high=True)
    gauss = _kernel_flag(kernel)
    if m == 0:
        return np.zeros(X.shape[0])
    out = np.empty(X.shape[0])
    _direct_loglik_kernel(X, np.arange(m), m, pos, rr, _log_pd(snr, pfa), 1.0 / sigma_r,
                          _inv(sigma_v), gauss, np.empty(m), out)
    return out


def pseudo_measurement_errors(scans, truth, config=TbdTrackerConfig(method="A")):
    """Errors of the pseudo-measurement of eqs (10)-(11) with the window on the truth.

    For every scan ``k`` the detections of ``scans`` within ``config.processing_radius``
    of the true position ``truth[k, :3]`` are collapsed into ``p̄`` exactly as method A
    does (weights of eq 10 about the true position and radial velocity), which is what
    a tracker that predicts perfectly would be fed.  Returns ``(dp (K, 3), dv (K,))``:
    ``p̄ - p_k`` and ``ṙ̄ - ṙ_k``, NaN where the window holds no detection.  Their root
    mean square calibrates :data:`TBD_PSEUDO_SIGMA` without running any tracker.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> from trackcore.scenarios.tbd_radar import TBD_INITIAL_COVARIANCE as P0
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> from trackcore.trackers import pseudo_measurement_errors
    >>> dp, dv = pseudo_measurement_errors(scans, truth.states)
    >>> dp.shape, dv.shape
    ((20, 3), (20,))
    >>> bool(np.nanmax(np.linalg.norm(dp, axis=1)) <= 2500.0)
    True
    """
    if not isinstance(config, TbdTrackerConfig):
        raise TypeError(f"config must be a TbdTrackerConfig, got {type(config).__name__}")
    pos, rr, snr, off = _scan_arrays(scans)
    K = off.size - 1
    Tr = _bounded(as_array(truth, "truth", ndim=2), "truth")
    if Tr.shape != (K, 6):
        raise ValueError(f"truth must have shape ({K}, 6) (one state per scan), got {Tr.shape}")
    dp = np.full((K, 3), np.nan)
    dv = np.full(K, np.nan)
    _pseudo_errors_kernel(pos, rr, snr, math.log(config.pfa), detection_snr_cap(config.pfa),
                          off, Tr, float(config.processing_radius), _inv(config.sigma_r),
                          _inv(config.sigma_v), config.kernel == "gaussian", dp, dv)
    return dp, dv


@nb.njit(cache=True)
def _pseudo_errors_kernel(pos, rr, snr, log_pfa, snr_cap, offsets, truth, R, inv_r, inv_v,
                          gauss, dp, dv):
    cache = np.full(max(pos.shape[0], 1), np.nan)
    K = offsets.shape[0] - 1
    M = pos.shape[0]
    n = max(M, 1)
    idx = np.empty(n, dtype=np.int64)
    lpd = np.empty(n)
    wbar = np.empty(n)
    processed = np.zeros(n, dtype=np.bool_)
    pbar = np.empty(3)
    for k in range(K):
        p = truth[k, :3]
        m = _window(pos, snr, log_pfa, snr_cap, offsets[k], offsets[k + 1], p, R, idx, lpd,
                    processed, cache)
        if m == 0:
            continue
        rr_true = _radial_velocity(truth[k, 0], truth[k, 1], truth[k, 2], truth[k, 3],
                                   truth[k, 4], truth[k, 5])
        rbar = _weighted_mean_kernel(idx, m, pos, rr, lpd, p, rr_true, inv_r, inv_v, gauss,
                                     wbar, pbar)
        if math.isnan(rbar):
            continue
        for a in range(3):
            dp[k, a] = pbar[a] - p[a]
        dv[k] = rbar - rr_true


def tbd_position_errors(estimates, truth):
    """Eq (20), corrected (erratum 9): ``E_err(k) = ||E_pos(k) - R_pos(k)||`` (K,).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_position_errors
    >>> est = np.zeros((2, 6))
    >>> truth = np.array([[3.0, 4.0, 0, 0, 0, 0], [0.0, 0.0, 12.0, 5.0, 0, 0]])
    >>> tbd_position_errors(est, truth)
    array([ 5., 12.])
    """
    E = _bounded(as_array(estimates, "estimates", ndim=2), "estimates")
    Tr = _bounded(as_array(truth, "truth", ndim=2), "truth")
    if E.shape[0] != Tr.shape[0] or E.shape[1] < 3 or Tr.shape[1] < 3:
        raise ValueError(f"estimates and truth must be (K, >=3) with the same K, got "
                         f"{E.shape} and {Tr.shape}")
    return np.linalg.norm(E[:, :3] - Tr[:, :3], axis=1)


def tbd_nees(estimates, covariances, truth):
    """Normalised estimation error squared ``e_kᵀ P_k⁻¹ e_k`` of every scan (K,), with
    ``e_k`` the full 6-D state error; NaN where ``P_k`` is not positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_nees
    >>> est = np.ones((1, 6))
    >>> tbd_nees(est, np.eye(6)[None] * 2.0, np.zeros((1, 6)))
    array([3.])
    """
    E = _bounded(as_array(estimates, "estimates", ndim=2), "estimates")
    C = _bounded(as_array(covariances, "covariances", ndim=3), "covariances", _COV_LIMIT)
    Tr = _bounded(as_array(truth, "truth", ndim=2), "truth")
    K, n = E.shape
    if C.shape != (K, n, n) or Tr.shape[0] != K or Tr.shape[1] < n:
        raise ValueError(f"estimates (K, n), covariances (K, n, n) and truth (K, >= n) must "
                         f"agree, got {E.shape}, {C.shape} and {Tr.shape}")
    e = E - Tr[:, :n]
    out = np.full(K, np.nan)
    try:
        L = np.linalg.cholesky(C)
        good = np.ones(K, dtype=bool)
    except np.linalg.LinAlgError:
        L = np.zeros_like(C)
        good = np.zeros(K, dtype=bool)
        for k in range(K):
            try:
                L[k] = np.linalg.cholesky(C[k])
                good[k] = True
            except np.linalg.LinAlgError:
                pass
    if good.any():
        y = np.linalg.solve(L[good], e[good][..., None])[..., 0]
        out[good] = np.einsum("ij,ij->i", y, y)
    return out


def tbd_measurement_errors(positions, offsets, truth, mask=None):
    """Eq (19): mean distance of the (masked) detections of scan ``k`` from the truth.

    ``positions (M, 3)``, ``offsets (K+1,)`` as in :func:`run_tbd_tracker`, ``truth
    (K, >=3)``, ``mask (M,)`` booleans (default all).  NaN for a scan with no (masked)
    detection (the metric is undefined there).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_measurement_errors
    >>> pos = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 2.0], [6.0, 8.0, 0.0]])
    >>> offsets = np.array([0, 2, 3])  # scan 0: rows 0-1, scan 1: row 2
    >>> tbd_measurement_errors(pos, offsets, np.zeros((2, 6)))
    array([ 3.5, 10. ])
    """
    pos = _bounded(as_array(positions, "positions", ndim=2), "positions")
    if pos.shape[1] != 3:
        raise ValueError(f"positions must have shape (M, 3), got {pos.shape}")
    M = pos.shape[0]
    off = as_offsets(offsets, M, "offsets")
    Tr = _bounded(as_array(truth, "truth", ndim=2), "truth")
    K = off.size - 1
    if Tr.shape[0] != K or Tr.shape[1] < 3:
        raise ValueError(f"truth must have shape ({K}, >=3) (one row per scan), got {Tr.shape}")
    if mask is None:
        keep = np.ones(M, dtype=bool)
    else:
        keep = np.asarray(mask)
        if keep.dtype != bool or keep.shape != (M,):
            raise ValueError(f"mask must be a boolean array of shape ({M},), got "
                             f"{keep.dtype} {keep.shape}")
    scan = np.repeat(np.arange(K), np.diff(off))
    d = np.linalg.norm(pos - Tr[scan, :3], axis=1)
    total = np.bincount(scan[keep], weights=d[keep], minlength=K)
    count = np.bincount(scan[keep], minlength=K)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def tbd_loss_onset(errors, threshold=1000.0, consecutive=10):
    """First scan of the first stretch of at least ``consecutive`` scans with
    ``errors > threshold`` (the chapter's rule: 1 km for 10 scans), or -1 if none.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_loss_onset
    >>> E = np.r_[np.full(5, 200.0), np.full(12, 1500.0), np.full(3, 200.0)]
    >>> tbd_loss_onset(E), tbd_loss_onset(np.full(20, 200.0))
    (5, -1)
    """
    e = as_array(errors, "errors", ndim=1)
    threshold = as_positive(threshold, "threshold")
    consecutive = as_count(consecutive, "consecutive")
    if consecutive == 0:
        return 0
    above = e > threshold
    if not above.any():
        return -1
    d = np.diff(np.concatenate([[False], above, [False]]).astype(np.int8))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    long_enough = np.flatnonzero(ends - starts >= consecutive)
    return int(starts[long_enough[0]]) if long_enough.size else -1


def tbd_track_lost(errors, threshold=1000.0, consecutive=10):
    """True if ``errors`` exceed ``threshold`` for at least ``consecutive`` scans in a row
    (the chapter's rule: 1 km for 10 scans).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_track_lost
    >>> E = np.r_[np.full(5, 200.0), np.full(10, 1500.0), np.full(5, 200.0)]
    >>> tbd_track_lost(E), tbd_track_lost(E[:14])
    (True, False)
    """
    return tbd_loss_onset(errors, threshold, consecutive) >= 0


class TbdRunOutcomes(NamedTuple):
    """Per-run outcomes of :func:`tbd_run_outcomes` (boolean arrays, one entry per run).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_run_outcomes
    >>> out = tbd_run_outcomes(np.full((2, 20), 200.0))
    >>> type(out).__name__, out._fields
    ('TbdRunOutcomes', ('lost', 'transient', 'diverged', 'other'))
    """
    lost: np.ndarray       # E_err > 1 km for >= 10 consecutive scans
    transient: np.ndarray  # lost, and back within 1 km for the last 10 scans
    diverged: np.ndarray   # lost, and the final error exceeds 5 km
    other: np.ndarray      # lost, neither back on track nor 5 km off at the end


def tbd_run_outcomes(errors, threshold=1000.0, consecutive=10, diverged_at=5000.0):
    """Classify runs ``errors (runs, K)`` into a :class:`TbdRunOutcomes`.

    *lost*: ``E_err > threshold`` for at least ``consecutive`` scans in a row
    (:func:`tbd_track_lost`); a lost run is *transient* if its last ``consecutive`` errors
    are all within ``threshold`` (the track came back), *diverged* if its final error
    exceeds ``diverged_at`` (default 5 km), and *other* otherwise (still lost at the end,
    but closer than ``diverged_at``).  The three classes partition the lost runs.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_run_outcomes
    >>> E = np.full((3, 30), 200.0)
    >>> E[1, 5:18] = 1500.0  # lost, then back
    >>> E[2, 5:] = 8000.0   # diverged
    >>> out = tbd_run_outcomes(E)
    >>> out.lost, out.transient, out.diverged
    (array([False,  True,  True]), array([False,  True, False]), array([False, False,  True]))
    """
    E = as_array(errors, "errors", ndim=2)
    if E.shape[0] == 0 or E.shape[1] == 0:
        raise ValueError("errors must hold at least one run of at least one scan")
    threshold = as_positive(threshold, "threshold")
    consecutive = as_int(consecutive, "consecutive", minimum=1)
    diverged_at = as_positive(diverged_at, "diverged_at")
    if diverged_at < threshold:
        raise ValueError(f"diverged_at ({diverged_at}) must be >= threshold ({threshold})")
    lost = np.array([tbd_track_lost(e, threshold, consecutive) for e in E])
    back = np.all(E[:, -consecutive:] <= threshold, axis=1)
    transient = lost & back
    diverged = lost & ~back & (E[:, -1] > diverged_at)
    return TbdRunOutcomes(lost, transient, diverged, lost & ~transient & ~diverged)


@dataclass(frozen=True)
class TbdErrorSummary:
    """Table 3 style summary of ``E_err`` over runs (errors averaged over a scan window).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_error_summary
    >>> s = tbd_error_summary(np.full((2, 20), 150.0))
    >>> type(s).__name__, s.mean, s.lost, s.beyond_sim
    ('TbdErrorSummary', 150.0, 0, 0)
    """
    mean: float            # mean over all runs of the per-run window mean (the paper's metric)
    median_run: float      # median over runs of the per-run window mean
    lost: int              # runs lost (E_err > 1 km for >= 10 consecutive scans, whole run)
    mean_not_lost: float   # mean over the runs that were not lost (NaN if all were)
    beyond_sim: int        # runs whose error ever exceeded the 5-km simulation margin
    per_run: np.ndarray    # (runs,) per-run window means
    diverged: int = 0      # lost runs whose final error exceeds 5 km
    transient: int = 0     # lost runs back within 1 km for the last 10 scans
    other: int = 0         # lost runs neither back nor 5 km off at the end
    lost_mask: np.ndarray | None = None  # (runs,) bool


def tbd_error_summary(errors, window=None, sim_margin=5000.0):
    """Summarise ``errors (runs, K)`` over ``window`` (a slice of scans, default all).

    Lost runs stay in ``mean`` (as in the paper's metric) and are counted in ``lost``,
    split into ``transient``, ``diverged`` and ``other`` (:func:`tbd_run_outcomes`, over
    the whole run); ``mean_not_lost`` excludes them.  ``beyond_sim`` counts runs that left the
    sphere in which the clutter was simulated (their later errors are not representative).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import tbd_error_summary
    >>> E = np.full((3, 30), 100.0)
    >>> E[2, 5:] = 8000.0
    >>> s = tbd_error_summary(E, window=slice(0, 10))
    >>> print(round(s.mean, 1), s.median_run, s.lost, s.diverged, s.mean_not_lost)
    1416.7 100.0 1 1 100.0
    """
    E = as_array(errors, "errors", ndim=2)
    if E.shape[0] == 0 or E.shape[1] == 0:
        raise ValueError("errors must hold at least one run of at least one scan")
    if window is not None and not isinstance(window, slice):
        raise TypeError(f"window must be a slice of scans or None, got {type(window).__name__}")
    sim_margin = as_positive(sim_margin, "sim_margin")
    sl = slice(None) if window is None else window
    if E[:, sl].shape[1] == 0:
        raise ValueError("window selects no scan")
    per_run = E[:, sl].mean(axis=1)
    out = tbd_run_outcomes(E)
    keep = ~out.lost
    return TbdErrorSummary(float(per_run.mean()), float(np.median(per_run)),
                           int(out.lost.sum()),
                           float(per_run[keep].mean()) if keep.any() else float("nan"),
                           int(np.sum(np.max(E, axis=1) > sim_margin)), per_run,
                           int(out.diverged.sum()), int(out.transient.sum()),
                           int(out.other.sum()), out.lost)
