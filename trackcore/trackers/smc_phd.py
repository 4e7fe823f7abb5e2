"""Sequential Monte Carlo PHD filter (Vo, Singh & Doucet 2005) for the
range-bearing scenario of Kim & Song (2007) (the chapter's Fig 2).

Per scan: predict the particles through the jump-Markov model with survival
``P_S``; add ``B_k`` birth particles of total mass ``P_birth``; PHD weight
update

    w_i <- [1 - P_D + sum_z P_D g(z|x_i) / (kappa(z) + C(z))] w_i,
    C(z) = sum_j P_D g(z|x_j) w_j,

with ``g = N(z; h(x), R)`` in polar coordinates and ``kappa(z) = lambda_xy
r_z`` the clutter intensity per (m rad) (the update is
``trackcore.trackers.smc_phd_step.phd_range_bearing_update_kernel``, shared
with the step-level API); resample ``L = max(N round(N_hat), N)`` particles
systematically with weights ``N_hat / L`` (mass preserving); extract up to
``round(N_hat)`` point estimates by gated k-means over particle positions,
initialised from the previous centres and then from the current
measurements in decreasing order of their PHD update mass.

Choices (documented in the chapter's "Choices we made"): births are
measurement-driven -- ``B_k`` particles split equally over the measurements
of the previous scan, position from ``z + N(0, R)`` converted to Cartesian,
velocity ``N(0, velocity_std^2 I)``, then propagated one step; the filter
starts empty; k-means is deterministic (``kmeans_extract_kernel``).
The whole run is one numba kernel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..core.validation import as_array, as_rng
from ..filters.particle import systematic_indices_kernel
from ..models.measurement import range_bearing_kernel
from .hpda_pf import (TrackerRun, _finite, _gather_in_place, _integer, _motion_and_sensor,
                      check_scans, jump_markov_propagate_kernel)
from .smc_phd_step import phd_range_bearing_update_kernel

__all__ = ["SmcPhdConfig", "smc_phd_run"]

#: The birth models of :class:`SmcPhdConfig`: ``birth_mass`` per scan or per return.
BIRTH_MODELS = ("per_scan", "per_return")


@dataclass(frozen=True)
class SmcPhdConfig:
    """Parameters of the SMC-PHD filter; every field is checked when the record is
    built (``ValueError``/``TypeError`` naming the field).  From the paper: ``pd``,
    ``T``, ``sigma_r``, ``sigma_theta``, ``sigma_a``, ``a_m``, ``n_per_target =
    1000`` (N), ``n_birth = 500`` (B_k), ``birth_mass = 0.2`` (P_birth, read as the
    expected number of births per scan).  Choices: ``birth_model = "per_scan"``
    (``birth_mass`` is the total mass of one scan's births, split equally over the
    previous scan's returns; with ``"per_return"`` every return of the previous scan
    carries ``birth_mass``, so a scan's births total ``birth_mass`` times its number of
    returns, still on ``n_birth`` particles), ``p_survival = 0.99``,
    ``velocity_std = 1.5`` m/s, ``mode_tpm``, ``kmeans_iterations = 10``,
    ``extraction_radius = 1000`` m (particles farther than this from every
    k-means centre are ignored in the means), ``max_estimates``,
    ``max_particles``.

    Examples
    --------
    >>> from trackcore.trackers.smc_phd import SmcPhdConfig
    >>> cfg = SmcPhdConfig(pd=0.9, clutter_density_xy=3e-7)
    >>> cfg.n_per_target, cfg.n_birth, cfg.birth_mass, cfg.birth_model
    (1000, 500, 0.2, 'per_scan')
    >>> SmcPhdConfig(pd=0.9, clutter_density_xy=3e-7, birth_model="x")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: birth_model must be one of ('per_scan', 'per_return'), got 'x'
    """
    pd: float
    clutter_density_xy: float
    T: float = 10.0
    sigma_r: float = 50.0
    sigma_theta: float = math.radians(0.1)
    sigma_a: float = 0.0015
    a_m: float = 0.01
    n_per_target: int = 1000
    n_birth: int = 500
    birth_mass: float = 0.2
    birth_model: str = "per_scan"
    p_survival: float = 0.99
    velocity_std: float = 1.5
    mode_tpm: tuple = ((0.90, 0.05, 0.05), (0.10, 0.90, 0.0), (0.10, 0.0, 0.90))
    kmeans_iterations: int = 10
    extraction_radius: float = 1000.0
    max_estimates: int = 32
    max_particles: int = 40000

    def __post_init__(self):
        _motion_and_sensor(self)
        _integer(self, "n_per_target", 1)
        _integer(self, "n_birth", 0)
        _finite(self, "birth_mass", low=0.0)
        if self.n_birth == 0 and self.birth_mass > 0:
            raise ValueError("n_birth must be >= 1 when birth_mass > 0")
        if not isinstance(self.birth_model, str) or self.birth_model not in BIRTH_MODELS:
            raise ValueError(
                f"birth_model must be one of {BIRTH_MODELS}, got {self.birth_model!r}")
        _finite(self, "p_survival", low=0.0, high=1.0)
        _integer(self, "kmeans_iterations", 0)
        _finite(self, "extraction_radius", low=0.0, low_open=True)
        _integer(self, "max_estimates", 1)
        _integer(self, "max_particles", self.n_per_target)


@nb.njit(cache=True)
def kmeans_extract_kernel(X, n_clusters, cand, n_cand, iters, gate2, centres, labels):
    """Deterministic gated k-means of particle rows ``X`` (L, 4) on positions.

    Initial centres are taken in order from the candidate rows ``cand[:n_cand]``
    (the caller passes the previous centres first, then the current
    measurements by decreasing PHD update mass), skipping candidates within
    ``sqrt(gate2) / 3`` of a chosen one.  Lloyd iterations assign each particle
    to its nearest centre if within ``sqrt(gate2)`` (others are ignored, so
    stray birth particles do not drag the means); a centre left without
    particles is replaced by the next unused candidate.  Writes ``centres``
    (n_clusters, 4: cluster means of all four components) and ``labels``
    (-1 for ignored particles); returns the number of centres found."""
    L = X.shape[0]
    if n_clusters == 0 or L == 0:
        return 0
    sep2 = gate2 / 9.0
    nc = 0
    nxt = 0
    while nc < n_clusters and nxt < n_cand:
        ok = True
        for c in range(nc):
            dx = cand[nxt, 0] - centres[c, 0]
            dy = cand[nxt, 1] - centres[c, 1]
            if dx * dx + dy * dy < sep2:
                ok = False
                break
        if ok:
            for a in range(4):
                centres[nc, a] = cand[nxt, a]
            nc += 1
        nxt += 1
    if nc == 0:
        return 0
    sums = np.zeros((nc, 4))
    cnt = np.zeros(nc)
    for _ in range(iters):
        for c in range(nc):
            cnt[c] = 0.0
            for a in range(4):
                sums[c, a] = 0.0
        for i in range(L):
            dmin = 1e300
            bc = -1
            for c in range(nc):
                dx = X[i, 0] - centres[c, 0]
                dy = X[i, 1] - centres[c, 1]
                d = dx * dx + dy * dy
                if d < dmin:
                    dmin = d
                    bc = c
            if dmin > gate2:
                bc = -1
            labels[i] = bc
            if bc >= 0:
                cnt[bc] += 1.0
                for a in range(4):
                    sums[bc, a] += X[i, a]
        for c in range(nc):
            if cnt[c] > 0:
                for a in range(4):
                    centres[c, a] = sums[c, a] / cnt[c]
            elif nxt < n_cand:
                for a in range(4):
                    centres[c, a] = cand[nxt, a]
                nxt += 1
    return nc


@nb.njit(cache=True)
def _phd_run_kernel(Z, off, prm, cum_tpm, R, rng, out_count, out_est, out_n, out_aux):
    (pd, lam_xy, T, sigma_a, a_m, ps, mass_b, vstd) = (prm[0], prm[1], prm[2], prm[3],
                                                       prm[4], prm[5], prm[6], prm[7])
    Nt = int(prm[8])
    B = int(prm[9])
    iters = int(prm[10])
    Lmax = int(prm[11])
    gate2 = prm[12] * prm[12]
    per_return = prm[13] > 0.0
    C = out_est.shape[1]
    K = off.shape[0] - 1
    cap = Lmax + B
    X = np.zeros((cap, 4))
    M = np.zeros(cap, dtype=np.int64)
    w = np.zeros(cap)
    Xn = np.zeros((cap, 4))
    Mn = np.zeros(cap, dtype=np.int64)
    H = np.zeros((cap, 2))
    fac = np.zeros(cap)
    gidx = np.zeros(cap, dtype=np.int64)   # work arrays of the update (allocated once)
    gval = np.zeros(cap)
    iwork = np.zeros(2 * cap + 2 * (max(64, 4 * cap) + 1), dtype=np.int64)
    L = 0
    i00 = 1.0 / R[0, 0]
    i11 = 1.0 / R[1, 1]
    gnorm = 1.0 / (2.0 * math.pi * math.sqrt(R[0, 0] * R[1, 1]))
    sr = math.sqrt(R[0, 0])
    sb = math.sqrt(R[1, 1])
    prev = np.zeros((C, 4))
    n_prev = 0
    labels = np.zeros(cap, dtype=np.int64)
    ridx = np.zeros(cap, dtype=np.int64)
    for k in range(K):
        # predict survivors
        if L > 0:
            jump_markov_propagate_kernel(X[:L], M[:L], cum_tpm, T, sigma_a, a_m, rng)
            for i in range(L):
                w[i] *= ps
        # births from the previous scan's measurements
        if k > 0:
            a0, a1 = off[k - 1], off[k]
            mp = a1 - a0
            if mp > 0:
                nb_ = B
                mass_k = mass_b * mp if per_return else mass_b
                for i in range(nb_):
                    j = a0 + (i % mp)
                    r = Z[j, 0] + sr * rng.standard_normal()
                    b = Z[j, 1] + sb * rng.standard_normal()
                    X[L + i, 0] = r * math.cos(b)
                    X[L + i, 1] = r * math.sin(b)
                    X[L + i, 2] = vstd * rng.standard_normal()
                    X[L + i, 3] = vstd * rng.standard_normal()
                    M[L + i] = 0
                    w[L + i] = mass_k / nb_
                jump_markov_propagate_kernel(X[L:L + nb_], M[L:L + nb_], cum_tpm, T, sigma_a,
                                             a_m, rng)
                L += nb_
        # update
        a0, a1 = off[k], off[k + 1]
        m = a1 - a0
        range_bearing_kernel(X[:L], 0.0, 0.0, H[:L])
        zmass = np.zeros(m)
        kap = np.empty(m)
        for jj in range(m):
            kap[jj] = lam_xy * Z[a0 + jj, 0]
        Nhat = phd_range_bearing_update_kernel(H[:L], w[:L], Z[a0:a1], kap, pd, i00, i11, gnorm,
                                               60.0, fac[:L], zmass, gidx, gval, iwork)
        out_aux[k] = Nhat
        # resample: L' = max(N round(Nhat), N), mass preserving
        if L > 0 and Nhat > 0.0:
            nr = int(math.floor(Nhat + 0.5))
            Lp = max(Nt * nr, Nt)
            if Lp > Lmax:
                Lp = Lmax
            systematic_indices_kernel(w[:L], rng.random(), ridx[:Lp])
            _gather_in_place(X, M, ridx, Lp, Xn, Mn)
            for i in range(Lp):
                w[i] = Nhat / Lp
            L = Lp
        else:
            L = 0
        # extraction
        nr = int(math.floor(Nhat + 0.5))
        if nr > C:
            nr = C
        out_count[k] = nr
        nfound = 0
        if nr > 0 and L > 0:
            cand = np.zeros((n_prev + m, 4))
            for c in range(n_prev):
                for a in range(4):
                    cand[c, a] = prev[c, a]
            order = np.argsort(-zmass)
            for q in range(m):
                j = a0 + order[q]
                cand[n_prev + q, 0] = Z[j, 0] * math.cos(Z[j, 1])
                cand[n_prev + q, 1] = Z[j, 0] * math.sin(Z[j, 1])
            cen = np.zeros((nr, 4))
            nfound = kmeans_extract_kernel(X[:L], nr, cand, n_prev + m, iters, gate2, cen, labels)
            for c in range(nfound):
                for a in range(4):
                    out_est[k, c, a] = cen[c, a]
                    prev[c, a] = cen[c, a]
        n_prev = nfound
        out_n[k] = nfound


def smc_phd_run(z, offsets, config: SmcPhdConfig, rng) -> TrackerRun:
    """Run the SMC-PHD filter over a whole run of scans (sensor at the origin).

    ``z`` ``(M, 2)`` range-bearing measurements of all scans concatenated,
    ``offsets`` ``(K + 1,)``.  Returns a :class:`~trackcore.trackers.hpda_pf.TrackerRun`
    whose ``count`` is ``round(N_hat)``, ``estimates`` the k-means centres
    (``n_estimates`` of them, at most ``count``; ``ids`` are -1: the PHD has no track
    identities) and ``aux`` the total mass ``N_hat``.

    Examples
    --------
    >>> import numpy as np
    >>> from dataclasses import replace
    >>> from trackcore.scenarios import (hpda_parameters, hpda_tracker_configs, hpda_truth,
    ...                                  simulate_hpda_scans)
    >>> from trackcore.trackers.smc_phd import smc_phd_run
    >>> p = replace(hpda_parameters(1), n_scans=40)
    >>> scans = simulate_hpda_scans(hpda_truth(n_scans=40), p, np.random.default_rng(1))
    >>> run = smc_phd_run(scans.z, scans.offsets, hpda_tracker_configs(p)["phd"],
    ...                   np.random.default_rng(2))
    >>> run.count.shape, round(float(run.aux[-1]), 1), bool((run.ids == -1).all())
    ((40,), 1.1, True)
    """
    if not isinstance(config, SmcPhdConfig):
        raise TypeError(f"config must be SmcPhdConfig, got {type(config).__name__}")
    rng = as_rng(rng)
    Z = as_array(z, "z", ndim=2)
    Z, _, off = check_scans(Z, np.zeros(Z.shape[0]), offsets)
    cfg = config
    cum = np.ascontiguousarray(np.cumsum(np.array(cfg.mode_tpm), axis=1))
    R = np.diag([cfg.sigma_r ** 2, cfg.sigma_theta ** 2])
    prm = np.array([cfg.pd, cfg.clutter_density_xy, cfg.T, cfg.sigma_a, cfg.a_m, cfg.p_survival,
                    cfg.birth_mass, cfg.velocity_std, float(cfg.n_per_target),
                    float(cfg.n_birth), float(cfg.kmeans_iterations), float(cfg.max_particles),
                    cfg.extraction_radius, float(cfg.birth_model == "per_return")])
    K = off.shape[0] - 1
    C = cfg.max_estimates
    count = np.zeros(K, dtype=np.int64)
    est = np.full((K, C, 4), np.nan)
    n_est = np.zeros(K, dtype=np.int64)
    aux = np.zeros(K)
    _phd_run_kernel(Z, off, prm, cum, R, rng, count, est, n_est, aux)
    ids = np.full((K, C), -1, dtype=np.int64)
    return TrackerRun(count, est, ids, n_est, aux)
