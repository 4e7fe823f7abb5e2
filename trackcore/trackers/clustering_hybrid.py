"""Clustering hybrid multi-target tracker (Ng, Li, Godsill & Vermaak 2005) as
read by Kim & Song (2007) section 2.2 and spec section 6.1.

Per scan ``k``:

1. **Set ROIs** over the window of scans ``k - eta .. k`` (``eta + 1``
   scans): from every measurement of scan ``k - eta`` build a chain by
   repeatedly taking the nearest measurement of the next scan under the
   normalised distance
   ``d^2 = (z' - z)^T (2 R)^{-1} (z' - z)`` (bearing wrapped), appended iff
   ``d <= eps_w``; otherwise that scan is skipped and the chain continues
   from its last element (choice).  A chain is an ROI iff its length
   exceeds ``P_D eta``; measurements are not reused across ROIs.
   The window follows the text (sec 2.2: "from a measurement of time
   k - eta to the measurements of time k - eta + 1 ... continued up to time
   k", "over the time interval eta"); an earlier version used only the
   ``eta`` scans ``k - eta + 1 .. k``, which with ``eta = 2`` turned the
   ``> P_D eta`` size rule into "2 of 2" for any ``P_D > 0.5`` (a defect,
   fixed; case-1 e 2.48 -> 2.42 literal, 0.75 -> 0.46 wide links, 100 runs).
   The comparison ``d <= eps_w`` is the same as ``d^2 <= eps_w`` at the
   paper's ``eps_w = 1``; ``Sigma_w = R`` is the polar noise of eq (3) as
   the text says; consecutive scans are linked without motion compensation
   (the text assumes slowly moving targets and warns that ROIs fail for
   long sampling times).  Measured on case 1 (T = 10 s), consecutive
   detections of one target link with probability 0.26 at ``d^2 <= 1``
   (0.39 for noise alone; 0.91 at ``d^2 <= 9.21``), so a target's ROI
   forms in 28 % of scans (81 % wide) and ``tau_d = 2`` scans without one
   end the track: the undercount with
   ``eps_w = 1`` is the method with the paper's parameters.
2. An ROI **supports** a track if its latest measurement is in the gate of
   a track that existed before this scan's ROI pass.
3. **Birth move**: an ROI that supports no track for ``tau_b`` consecutive
   scans (ROIs linked through any shared earlier measurement) spawns a track:
   position from its latest measurement, velocity (last - first)/elapsed,
   ``N`` particles drawn with the converted measurement covariance and the
   velocity prior.
4. **Death move**: a track without a supporting ROI for ``tau_d``
   consecutive scans is removed.
5. **JPDA particle filter**: one particle set per track; predictive
   likelihoods ``l_tj = mean_i N(z_j; h(x_t^i), R)``; joint association
   events weighted ``prod (P_D l_tj / lambda_z) prod (1 - P_D P_G)`` and
   enumerated exactly (the limit of Murty's m-best list; conflicts are rare
   here -- a documented choice); particle weights
   ``beta_t0 + sum_j beta_tj N(z_j; h(x^i), R) / l_tj``; systematic
   resampling.  Amplitudes are not used.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..association.jpda import _enumerate_kernel
from ..core.validation import as_array, as_int, as_rng
from ..filters.particle import systematic_indices_kernel
from ..models.measurement import wrap_angle_kernel
from .hpda_pf import (TrackerRun, _particle_moments, check_scans,
                      jump_markov_propagate_kernel)

__all__ = ["ClusteringConfig", "clustering_run"]


@dataclass(frozen=True)
class ClusteringConfig:
    """Parameters of the clustering hybrid.  From the paper (Table 2, E17/E18):
    ``eps_w = 1`` (normalised-distance gate for ROI linking), ``eta = 2``
    (the printed "tau = 2"; ROIs span the ``eta + 1`` scans ``k - eta .. k``),
    ``tau_b = tau_d = eta``; ROI
    minimum size ``P_D eta``.  Choices: ``n_particles = 1000`` per track,
    ``gate_probability = 0.99``, ``velocity_std = 1.5`` m/s, ``mode_tpm``,
    ``link_d2 = None`` (use ``eps_w^2``; set 9.21 for the sensitivity run).
    """
    pd: float
    clutter_density_xy: float
    T: float = 10.0
    sigma_r: float = 50.0
    sigma_theta: float = math.radians(0.1)
    sigma_a: float = 0.0015
    a_m: float = 0.01
    n_particles: int = 1000
    eps_w: float = 1.0
    eta: int = 2
    tau_b: int = 2
    tau_d: int = 2
    gate_probability: float = 0.99
    velocity_std: float = 1.5
    mode_tpm: tuple = ((0.90, 0.05, 0.05), (0.10, 0.90, 0.0), (0.10, 0.0, 0.90))
    link_d2: float | None = None
    max_tracks: int = 32


@nb.njit(cache=True)
def _cluster_run_kernel(Z, off, prm, cum_tpm, R, rng, out_count, out_est, out_id, out_n):
    (pd, lam_xy, T, sigma_a, a_m, pg, g2, link_d2, vstd) = (
        prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6], prm[7], prm[8])
    N = int(prm[9])
    eta = int(prm[10])
    tau_b = int(prm[11])
    tau_d = int(prm[12])
    K = off.shape[0] - 1
    NC = out_est.shape[1]
    X = np.zeros((NC, N, 4))
    Mo = np.zeros((NC, N), dtype=np.int64)
    act = np.zeros(NC, dtype=np.bool_)
    tid = np.full(NC, -1, dtype=np.int64)
    nosup = np.zeros(NC, dtype=np.int64)
    next_id = 0
    zh = np.zeros((NC, 2))
    Sg = np.zeros((NC, 2, 2))
    S = np.zeros((2, 2))
    zhat = np.zeros(2)
    i2r0 = 1.0 / (2.0 * R[0, 0])
    i2r1 = 1.0 / (2.0 * R[1, 1])
    i00 = 1.0 / R[0, 0]
    i11 = 1.0 / R[1, 1]
    gnorm = 1.0 / (2.0 * math.pi * math.sqrt(R[0, 0] * R[1, 1]))
    min_len = pd * eta
    Mtot = Z.shape[0]
    roi_age = np.zeros(Mtot, dtype=np.int64)   # unsupported-ROI age ending at a measurement
    scratch = np.zeros((N, 4))
    ms = np.zeros(N, dtype=np.int64)
    wts = np.zeros(N)
    ridx = np.zeros(N, dtype=np.int64)
    hr = np.zeros(N)
    hb = np.zeros(N)
    chain = np.zeros(eta + 1, dtype=np.int64)
    for k in range(K):
        a0, a1 = off[k], off[k + 1]
        m = a1 - a0
        # ---- predict and gate every track
        for t in range(NC):
            if not act[t]:
                continue
            jump_markov_propagate_kernel(X[t], Mo[t], cum_tpm, T, sigma_a, a_m, rng)
            _particle_moments(X[t], zhat, S, R)
            zh[t, 0] = zhat[0]
            zh[t, 1] = zhat[1]
            for a in range(2):
                for b in range(2):
                    Sg[t, a, b] = S[a, b]
        valid_all = np.zeros((m, NC), dtype=np.bool_)
        for t in range(NC):
            if not act[t]:
                continue
            det = Sg[t, 0, 0] * Sg[t, 1, 1] - Sg[t, 0, 1] * Sg[t, 1, 0]
            j00 = Sg[t, 1, 1] / det
            j01 = -Sg[t, 0, 1] / det
            j11 = Sg[t, 0, 0] / det
            for jj in range(m):
                n0 = Z[a0 + jj, 0] - zh[t, 0]
                n1 = wrap_angle_kernel(Z[a0 + jj, 1] - zh[t, 1])
                if j00 * n0 * n0 + 2.0 * j01 * n0 * n1 + j11 * n1 * n1 <= g2:
                    valid_all[jj, t] = True
        # ---- JPDA over the gated measurements and live tracks
        tl = np.zeros(NC, dtype=np.int64)
        nt = 0
        for t in range(NC):
            if act[t]:
                tl[nt] = t
                nt += 1
        ml = np.zeros(m, dtype=np.int64)
        ng = 0
        for jj in range(m):
            for q in range(nt):
                if valid_all[jj, tl[q]]:
                    ml[ng] = jj
                    ng += 1
                    break
        if nt > 0:
            valid = np.zeros((ng, nt), dtype=np.bool_)
            logf = np.full((ng, nt), -np.inf)
            lik = np.zeros((ng, nt))
            for q in range(nt):
                t = tl[q]
                for i in range(N):
                    hr[i] = math.sqrt(X[t, i, 0] ** 2 + X[t, i, 1] ** 2)
                    hb[i] = math.atan2(X[t, i, 1], X[t, i, 0])
                for g in range(ng):
                    jj = ml[g]
                    if not valid_all[jj, t]:
                        continue
                    s = 0.0
                    for i in range(N):
                        dr = Z[a0 + jj, 0] - hr[i]
                        db = wrap_angle_kernel(Z[a0 + jj, 1] - hb[i])
                        s += math.exp(-0.5 * (dr * dr * i00 + db * db * i11))
                    l_tj = gnorm * s / N
                    lik[g, q] = l_tj
                    if l_tj > 0.0:
                        valid[g, q] = True
                        logf[g, q] = math.log(l_tj / (lam_xy * Z[a0 + jj, 0]))
            log_pd = np.full(nt, math.log(pd))
            log_1mpd = np.full(nt, math.log(1.0 - pd * pg))
            log_acc, log_miss, log_total, nev = _enumerate_kernel(logf, valid, log_pd, log_1mpd,
                                                                  False, 0.0)
            for q in range(nt):
                t = tl[q]
                b0 = math.exp(log_miss[q] - log_total)
                any_meas = False
                for g in range(ng):
                    if valid[g, q] and math.exp(log_acc[g, q] - log_total) > 1e-12:
                        any_meas = True
                if not any_meas:
                    continue
                for i in range(N):
                    hr[i] = math.sqrt(X[t, i, 0] ** 2 + X[t, i, 1] ** 2)
                    hb[i] = math.atan2(X[t, i, 1], X[t, i, 0])
                tot = 0.0
                for i in range(N):
                    v = b0
                    for g in range(ng):
                        if not valid[g, q]:
                            continue
                        bj = math.exp(log_acc[g, q] - log_total)
                        if bj <= 1e-12:
                            continue
                        jj = ml[g]
                        dr = Z[a0 + jj, 0] - hr[i]
                        db = wrap_angle_kernel(Z[a0 + jj, 1] - hb[i])
                        v += bj * gnorm * math.exp(-0.5 * (dr * dr * i00 + db * db * i11)) / lik[g, q]
                    wts[i] = v
                    tot += v
                systematic_indices_kernel(wts, rng.random(), ridx)
                for i in range(N):
                    j = ridx[i]
                    for a in range(4):
                        scratch[i, a] = X[t, j, a]
                    ms[i] = Mo[t, j]
                for i in range(N):
                    for a in range(4):
                        X[t, i, a] = scratch[i, a]
                    Mo[t, i] = ms[i]
        # ---- set ROIs over scans k-eta .. k (eta + 1 scans, the text's "k - eta ... k")
        supported = np.zeros(NC, dtype=np.bool_)
        k0 = k - eta
        act0 = act.copy()   # tracks gated this scan (not those born in this ROI pass)
        if k0 >= 0:
            used = np.zeros(off[k + 1] - off[k0], dtype=np.bool_)
            base = off[k0]
            for j0 in range(off[k0], off[k0 + 1]):
                if used[j0 - base]:
                    continue
                chain[0] = j0
                n_ch = 1
                last = j0
                for kk in range(k0 + 1, k + 1):
                    best = 1e300
                    bj = -1
                    for j in range(off[kk], off[kk + 1]):
                        if used[j - base]:
                            continue
                        dr = Z[j, 0] - Z[last, 0]
                        db = wrap_angle_kernel(Z[j, 1] - Z[last, 1])
                        d2 = dr * dr * i2r0 + db * db * i2r1
                        if d2 < best:
                            best = d2
                            bj = j
                    if bj >= 0 and best <= link_d2:
                        chain[n_ch] = bj
                        n_ch += 1
                        last = bj
                if n_ch <= min_len:
                    continue
                for c in range(n_ch):
                    used[chain[c] - base] = True
                # support: latest measurement in a live track's gate (latest scan only)
                sup_any = False
                if last >= a0:
                    for t in range(NC):
                        if act0[t] and valid_all[last - a0, t]:
                            supported[t] = True
                            sup_any = True
                else:
                    for t in range(NC):
                        if not act0[t]:
                            continue
                        det = Sg[t, 0, 0] * Sg[t, 1, 1] - Sg[t, 0, 1] * Sg[t, 1, 0]
                        n0 = Z[last, 0] - zh[t, 0]
                        n1 = wrap_angle_kernel(Z[last, 1] - zh[t, 1])
                        d2 = (Sg[t, 1, 1] * n0 * n0 - 2.0 * Sg[t, 0, 1] * n0 * n1
                              + Sg[t, 0, 0] * n1 * n1) / det
                        if d2 <= g2:
                            supported[t] = True
                            sup_any = True
                if sup_any:
                    roi_age[last] = 0
                    continue
                # linked to an earlier ROI through any shared (non-latest) measurement
                age = 1
                for c in range(n_ch - 1):
                    if roi_age[chain[c]] + 1 > age:
                        age = roi_age[chain[c]] + 1
                roi_age[last] = age
                if age >= tau_b:
                    slot = -1
                    for t in range(NC):
                        if not act[t]:
                            slot = t
                            break
                    if slot < 0:
                        continue
                    # birth: latest measurement and finite-difference velocity
                    first = chain[0]
                    kf = 0
                    for kk in range(k0, k + 1):
                        if off[kk] <= first < off[kk + 1]:
                            kf = kk
                    kl = kf
                    for kk in range(k0, k + 1):
                        if off[kk] <= last < off[kk + 1]:
                            kl = kk
                    r, b = Z[last, 0], Z[last, 1]
                    x0 = r * math.cos(b)
                    y0 = r * math.sin(b)
                    vx = 0.0
                    vy = 0.0
                    if kl > kf:
                        rf, bf = Z[first, 0], Z[first, 1]
                        vx = (x0 - rf * math.cos(bf)) / ((kl - kf) * T)
                        vy = (y0 - rf * math.sin(bf)) / ((kl - kf) * T)
                    cb, sb_ = math.cos(b), math.sin(b)
                    sr = math.sqrt(R[0, 0])
                    sth = math.sqrt(R[1, 1])
                    for i in range(N):
                        dr = sr * rng.standard_normal()
                        dth = sth * rng.standard_normal()
                        X[slot, i, 0] = x0 + cb * dr - r * sb_ * dth
                        X[slot, i, 1] = y0 + sb_ * dr + r * cb * dth
                        X[slot, i, 2] = vx + vstd * rng.standard_normal()
                        X[slot, i, 3] = vy + vstd * rng.standard_normal()
                        Mo[slot, i] = 0
                    act[slot] = True
                    tid[slot] = next_id
                    next_id += 1
                    nosup[slot] = 0
                    supported[slot] = True
                    roi_age[last] = 0
        # ---- death move
        for t in range(NC):
            if not act[t]:
                continue
            if supported[t]:
                nosup[t] = 0
            else:
                nosup[t] += 1
                if nosup[t] >= tau_d:
                    act[t] = False
        n = 0
        for t in range(NC):
            if act[t]:
                for a in range(4):
                    s = 0.0
                    for i in range(N):
                        s += X[t, i, a]
                    out_est[k, n, a] = s / N
                out_id[k, n] = tid[t]
                n += 1
        out_n[k] = n
        out_count[k] = n


def clustering_run(z, offsets, config: ClusteringConfig, rng) -> TrackerRun:
    """Run the clustering hybrid over a whole run of scans (sensor at the origin).

    Returns a :class:`TrackerRun`; ``count`` is the number of live tracks."""
    if not isinstance(config, ClusteringConfig):
        raise TypeError(f"config must be ClusteringConfig, got {type(config).__name__}")
    rng = as_rng(rng)
    Z = as_array(z, "z", ndim=2)
    Z, _, off = check_scans(Z, np.zeros(Z.shape[0]), offsets)
    cfg = config
    if not 0.0 < cfg.pd < 1.0:
        raise ValueError(f"config.pd must lie in (0, 1), got {cfg.pd}")
    if cfg.clutter_density_xy <= 0:
        raise ValueError("config.clutter_density_xy must be > 0")
    if not 0.0 < cfg.gate_probability < 1.0:
        raise ValueError("config.gate_probability must lie in (0, 1)")
    if cfg.eps_w <= 0:
        raise ValueError("config.eps_w must be > 0")
    N = as_int(cfg.n_particles, "config.n_particles", minimum=1)
    eta = as_int(cfg.eta, "config.eta", minimum=1)
    tau_b = as_int(cfg.tau_b, "config.tau_b", minimum=1)
    tau_d = as_int(cfg.tau_d, "config.tau_d", minimum=1)
    tpm = as_array(cfg.mode_tpm, "config.mode_tpm", shape=(3, 3))
    if np.any(tpm < 0) or np.any(np.abs(tpm.sum(axis=1) - 1) > 1e-9):
        raise ValueError("config.mode_tpm must be a row-stochastic 3x3 matrix")
    cum = np.ascontiguousarray(np.cumsum(tpm, axis=1))
    R = np.diag([cfg.sigma_r ** 2, cfg.sigma_theta ** 2])
    g2 = -2.0 * math.log(1.0 - cfg.gate_probability)
    link = cfg.eps_w ** 2 if cfg.link_d2 is None else float(cfg.link_d2)
    prm = np.array([cfg.pd, cfg.clutter_density_xy, cfg.T, cfg.sigma_a, cfg.a_m,
                    cfg.gate_probability, g2, link, cfg.velocity_std, float(N), float(eta),
                    float(tau_b), float(tau_d)])
    K = off.shape[0] - 1
    C = as_int(cfg.max_tracks, "config.max_tracks", minimum=1)
    count = np.zeros(K, dtype=np.int64)
    est = np.full((K, C, 4), np.nan)
    ids = np.full((K, C), -1, dtype=np.int64)
    n_est = np.zeros(K, dtype=np.int64)
    _cluster_run_kernel(Z, off, prm, cum, R, rng, count, est, ids, n_est)
    return TrackerRun(count, est, ids, n_est, count.astype(np.float64))
