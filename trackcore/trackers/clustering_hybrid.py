"""Clustering hybrid multi-target tracker (Ng, Li, Godsill & Vermaak 2005) as
described by Kim & Song (2007), section 2.2 (the chapter's Fig 1).

Per scan ``k``:

1. **Set ROIs** over the window of scans ``k - eta .. k`` (``eta + 1`` scans; the
   text chains "a measurement of time k - eta" through the following scans "up to
   time k"): from a measurement of a seed scan build a chain by repeatedly taking the
   nearest unused measurement of the next scan under the normalised distance

       d^2 = dr^2 / (2 R_rr + s_m^2) + db^2 / (2 R_bb + s_m^2 / r^2),
       s_m = link_motion_std * T * (scans between the two measurements),

   (bearing wrapped, ``r`` the range of the chain's last measurement), appended iff
   ``d^2`` does not exceed the link gate; otherwise that scan is skipped and the chain
   continues from its last element.  A chain is an ROI iff its length exceeds
   ``P_D eta``; measurements are not reused across ROIs.  The printed reading
   (``link_motion_std = 0``, gate ``d <= eps_w = 1``, seeds only at ``k - eta``)
   has no allowance for target motion; the strong reading adds one scan of motion
   from the tracker's own velocity prior, takes the 99 % chi-square point for 2
   degrees of freedom as the gate and seeds chains from every scan of the window
   (``seed_every_scan``), so that a target missed at ``k - eta`` still forms an
   ROI.
2. An ROI **supports** a track if its latest measurement is in the gate of a track
   that existed before this scan's ROI pass; with ``gated_support`` a track's own
   gated measurement of this scan supports it too.
3. **Birth move**: an ROI that supports no track for ``tau_b`` consecutive scans
   (ROIs linked through any shared earlier measurement) spawns a track: position
   from its latest measurement, velocity (last - first)/elapsed, ``N`` particles
   drawn with the converted measurement covariance and the velocity prior.
4. **Death move**: a track without support for ``tau_d`` consecutive scans is
   removed.
5. **JPDA particle filter**: one particle set per track; predictive likelihoods
   ``l_tj = mean_i N(z_j; h(x_t^i), R)``; joint association events weighted
   ``prod (P_D l_tj / lambda_z) prod (1 - P_D P_G)`` and enumerated exactly (the
   limit of Murty's m-best list; conflicts are rare here); particle weights
   ``beta_t0 + sum_j beta_tj N(z_j; h(x^i), R) / l_tj``; systematic resampling.
   Amplitudes are not used.

:func:`clustering_link_rates` measures, on simulated scans, how often two
consecutive returns of one target link and how often a target's own returns form
an ROI, under either reading.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..association.jpda import _enumerate_kernel
from ..core.validation import as_array, as_rng
from ..filters.particle import systematic_indices_kernel
from ..models.measurement import wrap_angle_kernel
from .hpda_pf import (TrackerRun, _finite, _flag, _gate_probability, _integer,
                      _motion_and_sensor, _particle_moments, check_scans,
                      jump_markov_propagate_kernel)

__all__ = ["ClusteringConfig", "clustering_run", "clustering_link_rates"]

#: the 99 % point of the chi-square distribution with 2 degrees of freedom
CHI2_2_99 = -2.0 * math.log(0.01)


@dataclass(frozen=True)
class ClusteringConfig:
    """Parameters of the clustering hybrid; every field is checked when the record is
    built (``ValueError``/``TypeError`` naming the field).

    From the paper (Table 2, errata E17/E18): ``eps_w = 1`` (normalised-distance gate
    for ROI links), ``eta = 2`` (the printed "tau = 2"; ROIs span the ``eta + 1`` scans
    ``k - eta .. k``), ``tau_b = tau_d = eta``; ROI minimum size ``P_D eta``.

    Readings of the text (defaults: the printed one): ``link_d2 = None`` (link gate
    ``d^2 <= eps_w^2``; a number sets the gate on ``d^2`` directly, e.g. 9.21),
    ``link_motion_std = 0`` (m/s; the strong reading uses the velocity prior,
    1.5 m/s, so one scan of motion adds ``(1.5 T)^2`` to the link covariance),
    ``seed_every_scan = False`` and ``gated_support = False`` (see the module
    docstring).

    Choices: ``n_particles = 1000`` per track, ``gate_probability = 0.99``,
    ``velocity_std = 1.5`` m/s, ``mode_tpm``, ``max_tracks``.

    Examples
    --------
    >>> cfg = ClusteringConfig(pd=0.9, clutter_density_xy=1e-9)
    >>> cfg.eps_w, cfg.eta, cfg.tau_b, cfg.link_d2, cfg.link_motion_std
    (1.0, 2, 2, None, 0.0)
    >>> ClusteringConfig(pd=1.5, clutter_density_xy=1e-9)
    Traceback (most recent call last):
        ...
    ValueError: pd must be < 1.0, got 1.5
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
    link_motion_std: float = 0.0
    seed_every_scan: bool = False
    gated_support: bool = False
    max_tracks: int = 32

    def __post_init__(self):
        _motion_and_sensor(self)
        _integer(self, "n_particles", 1)
        _finite(self, "eps_w", low=0.0, low_open=True)
        _integer(self, "eta", 1)
        _integer(self, "tau_b", 1)
        _integer(self, "tau_d", 1)
        _gate_probability(self, "the gate also decides which measurements each track's JPDA "
                                "and support use: with no gate that would be every measurement")
        if self.link_d2 is not None:
            _finite(self, "link_d2", low=0.0, low_open=True)
        _finite(self, "link_motion_std", low=0.0)
        _flag(self, "seed_every_scan")
        _flag(self, "gated_support")
        _integer(self, "max_tracks", 1)

    @property
    def link_gate(self) -> float:
        """The gate on the link distance ``d^2``."""
        return self.eps_w ** 2 if self.link_d2 is None else self.link_d2


@nb.njit(cache=True)
def _link_weights(r_last, gap, two_r00, two_r11, sig_m):
    """Inverse variances ``(1 / (2 R_rr + s^2), 1 / (2 R_bb + s^2 / r^2))`` of a link
    spanning ``gap`` scans, with ``s = gap * sig_m`` (``sig_m``: motion per scan)."""
    s2 = (gap * sig_m) ** 2
    return 1.0 / (two_r00 + s2), 1.0 / (two_r11 + s2 / (r_last * r_last))


@nb.njit(cache=True)
def _jpda_by_component(logf, valid, log_pd, log_1mpd):
    """JPDA marginals ``(beta (m, T), beta0 (T,))`` by exact enumeration, done separately
    for each group of tracks linked through shared gated measurements (the groups are
    independent, so the marginals are those of the joint problem, and the work grows
    with the largest group instead of with all tracks at once)."""
    m, T = valid.shape
    parent = np.arange(T)
    for j in range(m):
        first = -1
        for t in range(T):
            if not valid[j, t]:
                continue
            if first < 0:
                first = t
                continue
            a, b = first, t
            while parent[a] != a:
                a = parent[a]
            while parent[b] != b:
                b = parent[b]
            if a != b:
                parent[max(a, b)] = min(a, b)
    root = np.empty(T, dtype=np.int64)
    for t in range(T):
        a = t
        while parent[a] != a:
            a = parent[a]
        root[t] = a
    beta = np.zeros((m, T))
    beta0 = np.ones(T)
    for r in range(T):
        if root[r] != r:
            continue
        tracks = np.nonzero(root == r)[0]
        rows = np.zeros(m, dtype=np.bool_)
        for j in range(m):
            for t in tracks:
                if valid[j, t]:
                    rows[j] = True
        meas = np.nonzero(rows)[0]
        if meas.shape[0] == 0:
            continue
        sub_f = np.empty((meas.shape[0], tracks.shape[0]))
        sub_v = np.zeros((meas.shape[0], tracks.shape[0]), dtype=np.bool_)
        for a in range(meas.shape[0]):
            for b in range(tracks.shape[0]):
                sub_f[a, b] = logf[meas[a], tracks[b]]
                sub_v[a, b] = valid[meas[a], tracks[b]]
        nt_ = tracks.shape[0]
        la, lm, lt, _ = _enumerate_kernel(sub_f, sub_v, np.full(nt_, log_pd),
                                          np.full(nt_, log_1mpd), False, 0.0)
        for b in range(nt_):
            beta0[tracks[b]] = math.exp(lm[b] - lt)
            for a in range(meas.shape[0]):
                beta[meas[a], tracks[b]] = math.exp(la[a, b] - lt)
    return beta, beta0


@nb.njit(cache=True)
def _cluster_run_kernel(Z, off, prm, cum_tpm, R, rng, out_count, out_est, out_id, out_n):
    (pd, lam_xy, T, sigma_a, a_m, pg, g2, link_d2, vstd) = (
        prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6], prm[7], prm[8])
    N = int(prm[9])
    eta = int(prm[10])
    tau_b = int(prm[11])
    tau_d = int(prm[12])
    sig_m = prm[13]
    seed_all = prm[14] > 0.5
    gated_support = prm[15] > 0.5
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
    two_r00 = 2.0 * R[0, 0]
    two_r11 = 2.0 * R[1, 1]
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
            beta, beta0 = _jpda_by_component(logf, valid, math.log(pd), math.log(1.0 - pd * pg))
            for q in range(nt):
                t = tl[q]
                b0 = beta0[q]
                any_meas = False
                for g in range(ng):
                    if valid[g, q] and beta[g, q] > 1e-12:
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
                        bj = beta[g, q]
                        if bj <= 1e-12:
                            continue
                        jj = ml[g]
                        dr = Z[a0 + jj, 0] - hr[i]
                        db = wrap_angle_kernel(Z[a0 + jj, 1] - hb[i])
                        v += (bj * gnorm * math.exp(-0.5 * (dr * dr * i00 + db * db * i11))
                              / lik[g, q])
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
            last_seed = k - 1 if seed_all else k0
            for ks in range(k0, last_seed + 1):
                for j0 in range(off[ks], off[ks + 1]):
                    if used[j0 - base]:
                        continue
                    chain[0] = j0
                    n_ch = 1
                    last = j0
                    klast = ks
                    for kk in range(ks + 1, k + 1):
                        c0, c1 = _link_weights(Z[last, 0], kk - klast, two_r00, two_r11,
                                               sig_m)
                        best = 1e300
                        bj = -1
                        for j in range(off[kk], off[kk + 1]):
                            if used[j - base]:
                                continue
                            dr = Z[j, 0] - Z[last, 0]
                            db = wrap_angle_kernel(Z[j, 1] - Z[last, 1])
                            d2 = dr * dr * c0 + db * db * c1
                            if d2 < best:
                                best = d2
                                bj = j
                        if bj >= 0 and best <= link_d2:
                            chain[n_ch] = bj
                            n_ch += 1
                            last = bj
                            klast = kk
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
                        kf = ks
                        kl = klast
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
        # ---- a track's own gated measurement of this scan also supports it
        if gated_support:
            for t in range(NC):
                if not act0[t]:
                    continue
                for jj in range(m):
                    if valid_all[jj, t]:
                        supported[t] = True
                        break
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

    Returns a :class:`~trackcore.trackers.hpda_pf.TrackerRun`; ``count`` is the number
    of live tracks.

    Examples
    --------
    One target 5 km north moving east at 1 m/s, seen every 10 s without clutter.  The
    printed reading (no motion allowance, gate ``d <= 1``) never forms an ROI, so no
    track is born; the strong reading holds one from scan 3 on (0-based):

    >>> from trackcore.trackers.imm_pdaf import pack_scans
    >>> xy = np.array([[10.0 * k, 5000.0] for k in range(8)])
    >>> rb = np.column_stack([np.hypot(*xy.T), np.arctan2(xy[:, 1], xy[:, 0])])
    >>> rb += np.random.default_rng(0).normal(size=rb.shape) * [50.0, np.radians(0.1)]
    >>> z, offsets = pack_scans([rb[k:k + 1] for k in range(8)])
    >>> printed = ClusteringConfig(pd=0.9, clutter_density_xy=1e-9, n_particles=200)
    >>> clustering_run(z, offsets, printed, np.random.default_rng(1)).count
    array([0, 0, 0, 0, 0, 0, 0, 0])
    >>> strong = ClusteringConfig(pd=0.9, clutter_density_xy=1e-9, n_particles=200, link_d2=9.21,
    ...                           link_motion_std=1.5, seed_every_scan=True)
    >>> clustering_run(z, offsets, strong, np.random.default_rng(1)).count
    array([0, 0, 0, 1, 1, 1, 1, 1])
    """
    if not isinstance(config, ClusteringConfig):
        raise TypeError(f"config must be ClusteringConfig, got {type(config).__name__}")
    rng = as_rng(rng)
    Z = as_array(z, "z", ndim=2)
    Z, _, off = check_scans(Z, np.zeros(Z.shape[0]), offsets)
    cfg = config
    cum = np.ascontiguousarray(np.cumsum(np.array(cfg.mode_tpm), axis=1))
    R = np.diag([cfg.sigma_r ** 2, cfg.sigma_theta ** 2])
    g2 = -2.0 * math.log(1.0 - cfg.gate_probability)
    prm = np.array([cfg.pd, cfg.clutter_density_xy, cfg.T, cfg.sigma_a, cfg.a_m,
                    cfg.gate_probability, g2, cfg.link_gate, cfg.velocity_std,
                    float(cfg.n_particles), float(cfg.eta), float(cfg.tau_b), float(cfg.tau_d),
                    cfg.link_motion_std * cfg.T, 1.0 if cfg.seed_every_scan else 0.0,
                    1.0 if cfg.gated_support else 0.0])
    K = off.shape[0] - 1
    C = cfg.max_tracks
    count = np.zeros(K, dtype=np.int64)
    est = np.full((K, C, 4), np.nan)
    ids = np.full((K, C), -1, dtype=np.int64)
    n_est = np.zeros(K, dtype=np.int64)
    _cluster_run_kernel(Z, off, prm, cum, R, rng, count, est, ids, n_est)
    return TrackerRun(count, est, ids, n_est, count.astype(np.float64))


def _chains(scans, eta, seed_every_scan, d2_fn, gate, min_len):
    """ROI chains over one window of one target's returns (clutter ignored).

    ``scans`` is a list of ``eta + 1`` lists of returns ``(r, b)``; returns whether
    some chain is longer than ``min_len``."""
    used = [[False] * len(s) for s in scans]
    seeds = range(eta) if seed_every_scan else range(1)
    for ks in seeds:
        for j0 in range(len(scans[ks])):
            if used[ks][j0]:
                continue
            chain = [(ks, j0)]
            last, klast = scans[ks][j0], ks
            for kk in range(ks + 1, eta + 1):
                best, bj = np.inf, -1
                for j, zj in enumerate(scans[kk]):
                    if used[kk][j]:
                        continue
                    d2 = d2_fn(last, zj, kk - klast)
                    if d2 < best:
                        best, bj = d2, j
                if bj >= 0 and best <= gate:
                    chain.append((kk, bj))
                    last, klast = scans[kk][bj], kk
            if len(chain) > min_len:
                return True
    return False


def clustering_link_rates(z, offsets, origin, target_range, config: ClusteringConfig,
                          range_edges):
    """How often the ROI step links a target's own returns, binned by range.

    ``z``, ``offsets`` a run of scans and ``origin`` ``(M,)`` the index of the target
    behind each return (-1 for clutter); ``target_range`` ``(K, n_targets)`` the true
    range of each target (NaN when it is not alive); ``range_edges`` increasing bin
    edges in m.  Two measures, under the link metric and gate of ``config``:

    * *pairs*: consecutive-scan return pairs of one target, binned by the range of the
      first, and how many of them link (``d^2`` within the gate);
    * *windows*: scans ``k >= eta`` with the target alive over ``k - eta .. k``,
      binned by its range at ``k``, and in how many of them its own returns of the
      window (clutter ignored) form an ROI.

    Returns a dict of integer arrays ``pairs``, ``links``, ``windows``, ``rois`` (one
    entry per bin).

    Examples
    --------
    The target of :func:`clustering_run`'s example: under the printed reading 2 of its 7
    consecutive-scan pairs link and 2 of 6 windows form an ROI; under the strong reading
    all do:

    >>> from trackcore.trackers.imm_pdaf import pack_scans
    >>> xy = np.array([[10.0 * k, 5000.0] for k in range(8)])
    >>> rb = np.column_stack([np.hypot(*xy.T), np.arctan2(xy[:, 1], xy[:, 0])])
    >>> rb += np.random.default_rng(0).normal(size=rb.shape) * [50.0, np.radians(0.1)]
    >>> z, offsets = pack_scans([rb[k:k + 1] for k in range(8)])
    >>> origin, true_range = np.zeros(8, dtype=int), np.hypot(*xy.T)[:, None]
    >>> printed = ClusteringConfig(pd=0.9, clutter_density_xy=1e-9)
    >>> clustering_link_rates(z, offsets, origin, true_range, printed, [0.0, 6000.0])
    {'pairs': array([7]), 'links': array([2]), 'windows': array([6]), 'rois': array([2])}
    >>> strong = ClusteringConfig(pd=0.9, clutter_density_xy=1e-9, link_d2=9.21,
    ...                           link_motion_std=1.5, seed_every_scan=True)
    >>> clustering_link_rates(z, offsets, origin, true_range, strong, [0.0, 6000.0])
    {'pairs': array([7]), 'links': array([7]), 'windows': array([6]), 'rois': array([6])}
    """
    if not isinstance(config, ClusteringConfig):
        raise TypeError(f"config must be ClusteringConfig, got {type(config).__name__}")
    Z = as_array(z, "z", ndim=2)
    Z, _, off = check_scans(Z, np.zeros(Z.shape[0]), offsets)
    org = np.asarray(origin)
    if org.shape != (Z.shape[0],) or org.dtype.kind not in "iu":
        raise ValueError(f"origin must be an integer array of shape ({Z.shape[0]},)")
    K = off.shape[0] - 1
    rng_t = as_array(target_range, "target_range", ndim=2, finite=False)
    if rng_t.shape[0] != K:
        raise ValueError(f"target_range must have {K} rows (one per scan), got "
                         f"{rng_t.shape[0]}")
    edges = as_array(range_edges, "range_edges", ndim=1)
    if edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError("range_edges must hold at least two increasing edges")
    n_t = rng_t.shape[1]
    two_r00, two_r11 = 2.0 * config.sigma_r ** 2, 2.0 * config.sigma_theta ** 2
    sig_m = config.link_motion_std * config.T
    gate = config.link_gate

    def d2_fn(a, b, gap):
        c0, c1 = _link_weights(a[0], gap, two_r00, two_r11, sig_m)
        db = (b[1] - a[1] + np.pi) % (2 * np.pi) - np.pi
        return (b[0] - a[0]) ** 2 * c0 + db * db * c1

    nb_ = edges.size - 1
    out = {k: np.zeros(nb_, dtype=np.int64) for k in ("pairs", "links", "windows", "rois")}
    scan_of = np.repeat(np.arange(K), np.diff(off))
    own = [[[] for _ in range(K)] for _ in range(n_t)]
    for j in np.nonzero(org >= 0)[0]:
        if org[j] >= n_t:
            raise ValueError(f"origin holds target index {org[j]} >= {n_t}")
        own[org[j]][scan_of[j]].append((Z[j, 0], Z[j, 1]))

    def bin_of(r):
        i = int(np.searchsorted(edges, r, side="right")) - 1
        return i if 0 <= i < nb_ else -1

    min_len = config.pd * config.eta
    for t in range(n_t):
        for k in range(K):
            if own[t][k] and k + 1 < K and own[t][k + 1]:
                b = bin_of(own[t][k][0][0])
                if b >= 0:
                    out["pairs"][b] += 1
                    out["links"][b] += d2_fn(own[t][k][0], own[t][k + 1][0], 1) <= gate
            k0 = k - config.eta
            if k0 < 0 or not np.all(np.isfinite(rng_t[k0:k + 1, t])):
                continue
            b = bin_of(rng_t[k, t])
            if b < 0:
                continue
            out["windows"][b] += 1
            out["rois"][b] += _chains([own[t][kk] for kk in range(k0, k + 1)], config.eta,
                                      config.seed_every_scan, d2_fn, gate, min_len)
    return out
