"""HPDA-PF: automatic multi-target detection and tracking with Highest
Probability Data Association and particle filters (Kim & Song 2007, Fig 3;
flow reconstructed in spec section 6.3).

Every scan, for every track (tentative or confirmed):

1. predict (confirmed: jump-Markov particles; tentative: EKF) and
   ``P^- = Pi11 p + Pi12 (1 - p)`` (eq 17);
2. gate the scan around ``z_hat``, ``S`` (``g^2`` from ``P_G``), rank the
   validated measurements by amplitude, compute the rank probabilities (12),
   (10), the betas (14) with ``f_T = N(z; z_hat, S) / P_G`` and select the
   highest, ``s`` (15);
3. update the existence probability by (19) (``delta = P_D P_G`` if m = 0);
4. if ``m >= 1`` update the state with ``z^s`` -- confirmed tracks weight
   their particles with the target/clutter mixture likelihood (13) and
   resample systematically; tentative tracks do the single-measurement PDA
   update of their EKF with ``beta^s``.

Status changes: tentative -> confirmed at ``p >= P_c`` (its EKF posterior is
sampled into ``N`` particles); confirmed tracks below ``P_t`` are terminated;
tentative tracks below ``p_delete`` are deleted.  Every measurement that is
in no confirmed track's gate and was not selected by any tentative track
spawns a new tentative track (``p_0``), first updated at the next scan.

Choices (not in the paper) are fields of :class:`HpdaPfConfig` and are
documented there.  The whole run is one numba kernel over fixed-capacity
arrays; particles are ``(N, 4)`` per confirmed track.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from ..association.gating import gate_threshold
from ..association.hpda import (hpda_conditional_rank_kernel, hpda_existence_delta_kernel,
                                hpda_mixture_loglik_kernel, rank_log_q_kernel)
from ..association.pda import pda_update_kernel
from ..filters.kalman import kf_predict_kernel
from ..filters.particle import systematic_indices_kernel
from ..core.validation import as_array, as_int, as_offsets, as_rng
from ..models.measurement import (range_bearing_jacobian_kernel, range_bearing_kernel,
                                  wrap_angle_kernel)

__all__ = [
    "HpdaPfConfig",
    "TrackerRun",
    "hpda_pf_run",
    "SELECT_HPDA",
    "SELECT_STRONGEST",
    "SELECT_NEAREST",
    "jump_markov_propagate_kernel",
    "check_scans",
]

#: selection rules: eq (15) (HPDA), strongest neighbour (s = 1), nearest neighbour
SELECT_HPDA = 0
SELECT_STRONGEST = 1
SELECT_NEAREST = 2
_RULES = {"hpda": SELECT_HPDA, "strongest": SELECT_STRONGEST, "nearest": SELECT_NEAREST}


@dataclass(frozen=True)
class HpdaPfConfig:
    """Parameters of the HPDA-PF tracker.

    Environment (from the paper): ``pd``, ``snr`` (linear rho),
    ``clutter_density_xy`` (lambda V / V per m^2), ``T``, ``sigma_r``,
    ``sigma_theta``, ``sigma_a`` (model acceleration std), ``a_m``
    (manoeuvre acceleration), ``n_particles = 1000`` per confirmed track,
    ``p_confirm = 0.9`` (P_c), ``p_terminate = 0.6`` (P_t).

    Choices (spec section 5.2, labelled as such in the book):
    ``gate_probability = 0.99`` (g^2 = 9.21), ``pi11 = 0.98``, ``pi12 = 0``,
    ``p_initial = 0.01``, ``p_delete = 5e-4``, ``velocity_std = 1.5`` m/s
    (prior of new tracks), mode transition matrix ``mode_tpm`` (rows: from
    CV, left, right), ``tentative_sigma_a = 0.01`` m/s^2 (the tentative EKF
    is a CV filter whose process noise covers the manoeuvre acceleration),
    ``max_confirmed``/``max_tentative`` capacities, ``selection`` rule
    (``"hpda"``; ``"strongest"``/``"nearest"`` for the book's ablation),
    ``duplicate_scans = 3`` (two confirmed tracks selecting the same
    measurement that many scans in a row: the less likely one is dropped),
    and ``tentative_yield = True`` (a tentative track that selects the
    same measurement as a confirmed track is deleted: the confirmed track
    owns it).
    """
    pd: float
    snr: float
    clutter_density_xy: float
    T: float = 10.0
    sigma_r: float = 50.0
    sigma_theta: float = math.radians(0.1)
    sigma_a: float = 0.0015
    a_m: float = 0.01
    n_particles: int = 1000
    p_confirm: float = 0.9
    p_terminate: float = 0.6
    gate_probability: float = 0.99
    pi11: float = 0.98
    pi12: float = 0.0
    p_initial: float = 0.01
    p_delete: float = 5e-4
    velocity_std: float = 1.5
    mode_tpm: tuple = ((0.90, 0.05, 0.05), (0.10, 0.90, 0.0), (0.10, 0.0, 0.90))
    tentative_sigma_a: float = 0.01
    max_confirmed: int = 32
    max_tentative: int = 4096
    selection: str = "hpda"
    duplicate_scans: int = 3
    tentative_yield: bool = True

    @property
    def tau(self) -> float:
        return -(1.0 + self.snr) * math.log(self.pd)

    @property
    def gate_threshold(self) -> float:
        """``g^2`` of a 2-D gate with probability ``gate_probability``."""
        return gate_threshold(self.gate_probability, 2)


class TrackerRun(NamedTuple):
    """Output of a multi-target tracker run over K scans."""
    count: np.ndarray       # (K,) estimated number of targets
    estimates: np.ndarray   # (K, C, 4) estimated states, rows 0..n_estimates[k]-1 valid
    ids: np.ndarray         # (K, C) track ids (-1 unused)
    n_estimates: np.ndarray  # (K,)
    aux: np.ndarray         # (K,) algorithm-specific (HPDA: tentative tracks; PHD: sum of weights)


def check_scans(z, amplitude, offsets):
    """Validate a concatenated run of scans; returns contiguous arrays."""
    Z = as_array(z, "z", ndim=2)
    if Z.shape[1] != 2:
        raise ValueError(f"z must have shape (M, 2), got {Z.shape}")
    A = as_array(amplitude, "amplitude", finite=False)
    if A.shape != (Z.shape[0],):
        raise ValueError(f"amplitude must have shape ({Z.shape[0]},), got {A.shape}")
    if np.isnan(A).any():
        raise ValueError("amplitude must not contain NaN")
    off = as_offsets(offsets, Z.shape[0])
    return Z, np.ascontiguousarray(A, dtype=np.float64), off


# --------------------------------------------------------------------------
# kernels
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def jump_markov_propagate_kernel(X, modes, cum_tpm, T, sigma_a, a_m, rng):
    """Propagate particles ``X`` (N, 4) in place through the three-mode
    jump-Markov model (eqs 1-2): draw the new mode from row ``modes[i]`` of
    the cumulative transition matrix, apply CV (mode 0) or a coordinated turn
    with ``Omega = +a_m/speed`` (mode 1, left) or ``-a_m/speed`` (mode 2,
    right), then add ``Gamma v``, ``v ~ N(0, sigma_a^2 I_2)``."""
    N = X.shape[0]
    hT2 = 0.5 * T * T
    for i in range(N):
        u = rng.random()
        r = modes[i]
        j = 0
        while j < 2 and u >= cum_tpm[r, j]:
            j += 1
        modes[i] = j
        x, y, vx, vy = X[i, 0], X[i, 1], X[i, 2], X[i, 3]
        sp = math.sqrt(vx * vx + vy * vy)
        if j == 0 or sp < 1e-9:
            x += T * vx
            y += T * vy
        else:
            om = a_m / sp if j == 1 else -a_m / sp
            wt = om * T
            s, c = math.sin(wt), math.cos(wt)
            a = s / om
            b = (1.0 - c) / om
            x += a * vx - b * vy
            y += b * vx + a * vy
            nvx = c * vx - s * vy
            vy = s * vx + c * vy
            vx = nvx
        w1 = sigma_a * rng.standard_normal()
        w2 = sigma_a * rng.standard_normal()
        X[i, 0] = x + hT2 * w1
        X[i, 1] = y + hT2 * w2
        X[i, 2] = vx + T * w1
        X[i, 3] = vy + T * w2


@nb.njit(cache=True)
def _particle_moments(X, zhat, S, R):
    """Predicted measurement mean and covariance of equally weighted
    particles (bearing averaged about the first particle's bearing)."""
    N = X.shape[0]
    ref = math.atan2(X[0, 1], X[0, 0])
    sr = 0.0
    sb = 0.0
    for i in range(N):
        sr += math.sqrt(X[i, 0] * X[i, 0] + X[i, 1] * X[i, 1])
        sb += wrap_angle_kernel(math.atan2(X[i, 1], X[i, 0]) - ref)
    mr = sr / N
    mb = sb / N
    zhat[0] = mr
    zhat[1] = wrap_angle_kernel(ref + mb)
    c00 = 0.0
    c01 = 0.0
    c11 = 0.0
    for i in range(N):
        dr = math.sqrt(X[i, 0] * X[i, 0] + X[i, 1] * X[i, 1]) - mr
        db = wrap_angle_kernel(math.atan2(X[i, 1], X[i, 0]) - ref) - mb
        c00 += dr * dr
        c01 += dr * db
        c11 += db * db
    S[0, 0] = c00 / N + R[0, 0]
    S[0, 1] = c01 / N + R[0, 1]
    S[1, 0] = S[0, 1]
    S[1, 1] = c11 / N + R[1, 1]


@nb.njit(cache=True)
def _gate_and_select(Zs, As_order, zhat, S, g2, pd, pg, c, lam_xy, rule,
                     vidx, d2buf, ndens, pt, pf):
    """Gate the (amplitude-ordered) scan, rank-select a measurement.

    Returns ``(m, s_idx, beta_s, delta, pt_s, pf_s, V_G, normal_s)`` where
    ``s_idx`` is the scan index of ``z^s`` (-1 if m = 0)."""
    det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    i00 = S[1, 1] / det
    i01 = -S[0, 1] / det
    i11 = S[0, 0] / det
    sq = math.sqrt(det)
    VG = math.pi * g2 * sq
    m = 0
    for jj in range(As_order.shape[0]):
        j = As_order[jj]
        n0 = Zs[j, 0] - zhat[0]
        n1 = wrap_angle_kernel(Zs[j, 1] - zhat[1])
        d2 = i00 * n0 * n0 + 2.0 * i01 * n0 * n1 + i11 * n1 * n1
        if d2 <= g2:
            vidx[m] = j
            d2buf[m] = d2
            ndens[m] = math.exp(-0.5 * d2) / (2.0 * math.pi * sq)
            m += 1
    pdpg = pd * pg
    lam_z = lam_xy * zhat[0]
    if m == 0:
        return 0, -1, 0.0, pdpg, 0.0, 0.0, VG, 0.0
    clutter_mean = lam_z * VG
    hpda_conditional_rank_kernel(m, c, pdpg, clutter_mean, pt, pf)
    best = -1.0
    s = 0
    if rule == 0:
        for l in range(m):
            fT = ndens[l] / pg
            num = fT * pt[l]
            b = num / (num + pf[l] / VG)
            if b > best:
                best = b
                s = l
    elif rule == 1:
        s = 0
    else:
        dmin = 1e300
        for l in range(m):
            if d2buf[l] < dmin:
                dmin = d2buf[l]
                s = l
    fT = ndens[s] / pg
    num = fT * pt[s]
    beta = num / (num + pf[s] / VG)
    q_s = math.exp(rank_log_q_kernel(s + 1.0, float(m), c))
    delta = hpda_existence_delta_kernel(m, q_s, pd, pg, lam_z, VG, ndens[s])
    return m, vidx[s], beta, delta, pt[s], pf[s], VG, ndens[s]


@nb.njit(cache=True)
def _weight_resample(X, modes, z, Rinv, logdetR, log_pt, log_pf_vg, logw, scratch, mscratch,
                     idx, rng):
    """Eq (13) weights for ``z^s`` (:func:`hpda_mixture_loglik_kernel`),
    then systematic resampling in place (one ``rng.random()``)."""
    N = X.shape[0]
    hpda_mixture_loglik_kernel(X, z, Rinv, logdetR, 0.0, 0.0, log_pt, log_pf_vg, logw)
    mx = -np.inf
    for i in range(N):
        if logw[i] > mx:
            mx = logw[i]
    for i in range(N):
        logw[i] = math.exp(logw[i] - mx)
    systematic_indices_kernel(logw, rng.random(), idx)
    for i in range(N):
        j = idx[i]
        for a in range(4):
            scratch[i, a] = X[j, a]
        mscratch[i] = modes[j]
    for i in range(N):
        for a in range(4):
            X[i, a] = scratch[i, a]
        modes[i] = mscratch[i]


@nb.njit(cache=True)
def _polar_init(r, b, R, vstd, x, P):
    """Cartesian state and covariance from one range-bearing measurement."""
    cb, sb = math.cos(b), math.sin(b)
    x[0] = r * cb
    x[1] = r * sb
    x[2] = 0.0
    x[3] = 0.0
    # J = d(x, y)/d(r, b)
    j00, j01, j10, j11 = cb, -r * sb, sb, r * cb
    for a in range(4):
        for c in range(4):
            P[a, c] = 0.0
    P[0, 0] = j00 * j00 * R[0, 0] + j01 * j01 * R[1, 1]
    P[0, 1] = j00 * j10 * R[0, 0] + j01 * j11 * R[1, 1]
    P[1, 0] = P[0, 1]
    P[1, 1] = j10 * j10 * R[0, 0] + j11 * j11 * R[1, 1]
    P[2, 2] = vstd * vstd
    P[3, 3] = vstd * vstd


@nb.njit(cache=True)
def _ekf_moments(X1, P, R, zhat, S, H3):
    """Predicted range-bearing measurement, Jacobian (``H3[0]``) and
    innovation covariance ``S = H P H^T + R`` of the EKF state ``X1`` (1, 4)."""
    range_bearing_kernel(X1, 0.0, 0.0, zhat.reshape((1, 2)))
    range_bearing_jacobian_kernel(X1, 0.0, 0.0, H3)
    H = H3[0]
    for a in range(2):
        for b in range(2):
            s = R[a, b]
            for c in range(2):
                for d in range(2):
                    s += H[a, c] * P[c, d] * H[b, d]
            S[a, b] = s


@nb.njit(cache=True)
def _hpda_run_kernel(Z, A, off, prm, cum_tpm, F_t, Q_t, R, rng,
                     out_count, out_est, out_id, out_n, out_aux):
    (pd, pg, g2, c, lam_xy, T, sigma_a, a_m, p_conf, p_term, pi11, pi12, p0, p_del,
     vstd, rule_f, dup_f, yield_f) = (prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6],
                                      prm[7], prm[8], prm[9], prm[10], prm[11], prm[12],
                                      prm[13], prm[14], prm[15], prm[16], prm[17])
    rule = int(rule_f)
    dup_max = int(dup_f)
    K = off.shape[0] - 1
    NC, N = out_est.shape[1], int(prm[18])
    NT = int(prm[19])
    cX = np.zeros((NC, N, 4))
    cM = np.zeros((NC, N), dtype=np.int64)
    cp = np.zeros(NC)
    cact = np.zeros(NC, dtype=np.bool_)
    cid = np.full(NC, -1, dtype=np.int64)
    csel = np.full(NC, -1, dtype=np.int64)
    cdup = np.zeros(NC, dtype=np.int64)
    tx = np.zeros((NT, 4))
    tP = np.zeros((NT, 4, 4))
    tp = np.zeros(NT)
    tact = np.zeros(NT, dtype=np.bool_)
    next_id = 0
    Rinv = np.linalg.inv(R)
    logdetR = math.log(R[0, 0] * R[1, 1] - R[0, 1] * R[1, 0])
    scratch = np.zeros((N, 4))
    mscratch = np.zeros(N, dtype=np.int64)
    logw = np.zeros(N)
    ridx = np.zeros(N, dtype=np.int64)
    xb = np.zeros(4)
    Pb = np.zeros((4, 4))
    zsel = np.zeros((1, 2))
    bsel = np.zeros(1)
    nu_b = np.zeros(2)
    S_b = np.zeros((2, 2))
    K_b = np.zeros((4, 2))
    zhat = np.zeros(2)
    S = np.zeros((2, 2))
    H3 = np.zeros((1, 2, 4))
    Lc = np.zeros((4, 4))
    mmax = 1
    for k in range(K):
        mmax = max(mmax, off[k + 1] - off[k])
    vidx = np.zeros(mmax, dtype=np.int64)
    d2buf = np.zeros(mmax)
    ndens = np.zeros(mmax)
    pt = np.zeros(mmax)
    pf = np.zeros(mmax)
    for k in range(K):
        Zs = Z[off[k]:off[k + 1]]
        As = A[off[k]:off[k + 1]]
        m_k = Zs.shape[0]
        order = np.argsort(-As)
        in_conf = np.zeros(m_k, dtype=np.bool_)
        selected = np.zeros(m_k, dtype=np.bool_)
        # ---- confirmed tracks
        for t in range(NC):
            if not cact[t]:
                continue
            X = cX[t]
            jump_markov_propagate_kernel(X, cM[t], cum_tpm, T, sigma_a, a_m, rng)
            ppred = pi11 * cp[t] + pi12 * (1.0 - cp[t])
            _particle_moments(X, zhat, S, R)
            m, js, beta, delta, pts, pfs, VG, nds = _gate_and_select(
                Zs, order, zhat, S, g2, pd, pg, c, lam_xy, rule, vidx, d2buf, ndens, pt, pf)
            for l in range(m):
                in_conf[vidx[l]] = True
            den = 1.0 - delta * ppred
            cp[t] = 1.0 if den <= 0.0 else min(1.0, max(0.0, (1.0 - delta) * ppred / den))
            csel[t] = js
            if m > 0:
                lpt = math.log(pts) if pts > 0.0 else -np.inf
                lpf = math.log(pfs / VG) if pfs > 0.0 else -np.inf
                _weight_resample(X, cM[t], Zs[js], Rinv, logdetR, lpt, lpf, logw,
                                 scratch, mscratch, ridx, rng)
        # duplicates and termination
        for t in range(NC):
            if not cact[t]:
                continue
            shared = False
            if csel[t] >= 0:
                for u in range(NC):
                    if u != t and cact[u] and csel[u] == csel[t]:
                        shared = True
            cdup[t] = cdup[t] + 1 if shared else 0
        for t in range(NC):
            if not cact[t]:
                continue
            if cp[t] < p_term:
                cact[t] = False
                continue
            if dup_max > 0 and cdup[t] >= dup_max:
                for u in range(NC):
                    if u != t and cact[u] and csel[u] == csel[t] and (
                            cp[u] > cp[t] or (cp[u] == cp[t] and cid[u] < cid[t])):
                        cact[t] = False
                        break
        # ---- tentative tracks
        for t in range(NT):
            if not tact[t]:
                continue
            kf_predict_kernel(tx[t], tP[t], F_t, Q_t, xb, Pb)
            tx[t, :] = xb
            tP[t, :, :] = Pb
            ppred = pi11 * tp[t] + pi12 * (1.0 - tp[t])
            _ekf_moments(tx[t:t + 1], tP[t], R, zhat, S, H3)
            H = H3[0]
            m, js, beta, delta, pts, pfs, VG, nds = _gate_and_select(
                Zs, order, zhat, S, g2, pd, pg, c, lam_xy, rule, vidx, d2buf, ndens, pt, pf)
            den = 1.0 - delta * ppred
            tp[t] = 1.0 if den <= 0.0 else min(1.0, max(0.0, (1.0 - delta) * ppred / den))
            if m > 0:
                owned = False
                if yield_f > 0.5:
                    for u in range(NC):
                        if cact[u] and csel[u] == js:
                            owned = True
                if owned:
                    tact[t] = False
                    continue
                selected[js] = True
                # single-measurement PDA update of the EKF with beta^s
                zsel[0, 0] = Zs[js, 0]
                zsel[0, 1] = Zs[js, 1]
                bsel[0] = beta
                pda_update_kernel(tx[t], tP[t], zsel, zhat, H, R, bsel, 1.0 - beta, 1,
                                  xb, Pb, nu_b, S_b, K_b)
                tx[t, :] = xb
                tP[t, :, :] = Pb
            if tp[t] >= p_conf:
                slot = -1
                for u in range(NC):
                    if not cact[u]:
                        slot = u
                        break
                tact[t] = False
                if slot >= 0:
                    # sample the EKF posterior into N particles, all in CV mode
                    Pm = tP[t]
                    for a in range(4):
                        for b in range(4):
                            Lc[a, b] = 0.0
                    ok = True
                    for a in range(4):
                        for b in range(a + 1):
                            s = Pm[a, b]
                            for e in range(b):
                                s -= Lc[a, e] * Lc[b, e]
                            if a == b:
                                if s <= 0.0:
                                    ok = False
                                    s = 1e-12
                                Lc[a, a] = math.sqrt(s)
                            else:
                                Lc[a, b] = s / Lc[b, b]
                    for i in range(N):
                        w0 = rng.standard_normal()
                        w1 = rng.standard_normal()
                        w2 = rng.standard_normal()
                        w3 = rng.standard_normal()
                        for a in range(4):
                            cX[slot, i, a] = (tx[t, a] + Lc[a, 0] * w0 + Lc[a, 1] * w1
                                              + Lc[a, 2] * w2 + Lc[a, 3] * w3)
                        cM[slot, i] = 0
                    cact[slot] = True
                    cp[slot] = tp[t]
                    cid[slot] = next_id
                    csel[slot] = js if m > 0 else -1
                    cdup[slot] = 0
                    next_id += 1
            elif tp[t] < p_del:
                tact[t] = False
        # ---- new candidates
        for j in range(m_k):
            if in_conf[j] or selected[j]:
                continue
            slot = -1
            for u in range(NT):
                if not tact[u]:
                    slot = u
                    break
            if slot < 0:
                break
            _polar_init(Zs[j, 0], Zs[j, 1], R, vstd, tx[slot], tP[slot])
            tp[slot] = p0
            tact[slot] = True
        # ---- output
        n = 0
        for t in range(NC):
            if cact[t]:
                X = cX[t]
                for a in range(4):
                    s = 0.0
                    for i in range(N):
                        s += X[i, a]
                    out_est[k, n, a] = s / N
                out_id[k, n] = cid[t]
                n += 1
        out_n[k] = n
        out_count[k] = n
        nt = 0
        for t in range(NT):
            if tact[t]:
                nt += 1
        out_aux[k] = nt


def hpda_pf_run(z, amplitude, offsets, config: HpdaPfConfig, rng) -> TrackerRun:
    """Run the HPDA-PF tracker over a whole run of scans.

    ``z`` ``(M, 2)`` range-bearing measurements of all scans concatenated,
    ``amplitude`` ``(M,)``, ``offsets`` ``(K + 1,)`` (scan ``k`` is rows
    ``offsets[k]:offsets[k+1]``; empty scans are valid).  Sensor at the
    origin.  Returns a :class:`TrackerRun` with the number of confirmed
    tracks per scan and their estimates (``aux``: number of tentative tracks).
    """
    if not isinstance(config, HpdaPfConfig):
        raise TypeError(f"config must be HpdaPfConfig, got {type(config).__name__}")
    rng = as_rng(rng)
    Z, A, off = check_scans(z, amplitude, offsets)
    cfg = config
    if not 0.0 < cfg.pd < 1.0:
        raise ValueError(f"config.pd must lie in (0, 1), got {cfg.pd}")
    if not 0.0 < cfg.gate_probability < 1.0:
        raise ValueError(f"config.gate_probability must lie in (0, 1), got {cfg.gate_probability}")
    if cfg.clutter_density_xy <= 0:
        raise ValueError("config.clutter_density_xy must be > 0")
    if cfg.selection not in _RULES:
        raise ValueError(f"config.selection must be one of {tuple(_RULES)}, got {cfg.selection!r}")
    N = as_int(cfg.n_particles, "config.n_particles", minimum=1)
    tpm = as_array(cfg.mode_tpm, "config.mode_tpm", shape=(3, 3))
    if np.any(tpm < 0) or np.any(np.abs(tpm.sum(axis=1) - 1) > 1e-9):
        raise ValueError("config.mode_tpm must be a row-stochastic 3x3 matrix")
    cum = np.ascontiguousarray(np.cumsum(tpm, axis=1))
    T = cfg.T
    F_t = np.array([[1, 0, T, 0], [0, 1, 0, T], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
    G = np.array([[T * T / 2, 0], [0, T * T / 2], [T, 0], [0, T]])
    Q_t = np.ascontiguousarray(cfg.tentative_sigma_a ** 2 * G @ G.T)
    R = np.diag([cfg.sigma_r ** 2, cfg.sigma_theta ** 2])
    prm = np.array([cfg.pd, cfg.gate_probability, cfg.gate_threshold, 1.0 / (1.0 + cfg.snr),
                    cfg.clutter_density_xy, T, cfg.sigma_a, cfg.a_m, cfg.p_confirm,
                    cfg.p_terminate, cfg.pi11, cfg.pi12, cfg.p_initial, cfg.p_delete,
                    cfg.velocity_std, float(_RULES[cfg.selection]), float(cfg.duplicate_scans),
                    1.0 if cfg.tentative_yield else 0.0, float(N), float(cfg.max_tentative)])
    K = off.shape[0] - 1
    C = as_int(cfg.max_confirmed, "config.max_confirmed", minimum=1)
    count = np.zeros(K, dtype=np.int64)
    est = np.full((K, C, 4), np.nan)
    ids = np.full((K, C), -1, dtype=np.int64)
    n_est = np.zeros(K, dtype=np.int64)
    aux = np.zeros(K)
    _hpda_run_kernel(Z, A, off, prm, cum, F_t, Q_t, R, rng, count, est, ids, n_est, aux)
    return TrackerRun(count, est, ids, n_est, aux)
