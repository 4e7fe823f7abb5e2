"""Association benchmarks.

JPDA: T = 3, 5, 8 close targets (on a line, 12 m apart, gates overlapping) and 10 clutter
detections per scan.  trackcore (KF prediction, chi-square gating, Gaussian likelihoods and
:func:`trackcore.association.jpda_marginals`, exact enumeration in numba) against Stone
Soup's ``JPDA`` (brute-force product of the per-track hypotheses) and ``JPDAwithEHM2``
(efficient hypothesis management), with the same ``PDAHypothesiser`` model
(``prob_detect``, ``prob_gate``, ``clutter_spatial_density``).  All three must give the
same association probabilities (max abs difference < 1e-9).

Stone Soup weighs a missed detection by ``1 - P_D P_G`` and a detection by
``P_D N(z; z_hat, S) / lambda``: exactly trackcore's parametric JPDA with detection
probability ``P_D P_G`` and the gate-truncated likelihood ``N / P_G``.

HPDA: :func:`trackcore.association.hpda_log_rank_probabilities` for m = 1..500 (all
``l = 1..m``); time per ``(l, m)`` pair; checked against the closed form
``sum_l P(M_T^l, m) = P_D P_G mu_F(m - 1)`` in log space for every m.
"""
from __future__ import annotations

import datetime
import math
from statistics import median

import numpy as np

from trackcore.association import (gate_threshold, hpda_log_rank_probabilities,
                                   jpda_marginals, mahalanobis_gate)
from trackcore.core.logmath import logsumexp
from trackcore.filters import kf_predict
from trackcore.models import cv_process_noise, cv_transition, position_matrix

from ._common import Stopwatch, record

PD, PG, SPACING = 0.9, 0.99, 12.0
N_CLUTTER = 10
Q_PSD = 0.5
R_VAR = 9.0
P_POS, P_VEL = 25.0, 1.0


def jpda_scene(T: int, seed: int = 0):
    """Priors (T, 4) in trackcore order, P0, the scan (m, 2) and the clutter density."""
    rng = np.random.default_rng(seed + 100 * T)
    x0 = np.zeros((T, 4))
    x0[:, 0] = SPACING * np.arange(T)
    x0[:, 2] = 1.0
    P0 = np.diag([P_POS, P_POS, P_VEL, P_VEL])
    F = cv_transition(1.0)
    truth = x0 @ F.T
    det = truth[:, :2] + math.sqrt(R_VAR) * rng.standard_normal((T, 2))
    det = det[rng.random(T) < PD]
    lo = np.array([-30.0, -30.0])
    hi = np.array([SPACING * (T - 1) + 30.0, 30.0])
    clutter = lo + (hi - lo) * rng.random((N_CLUTTER, 2))
    Z = np.ascontiguousarray(np.vstack([det, clutter]))
    lam = N_CLUTTER / float(np.prod(hi - lo))
    return x0, P0, Z, lam


def trackcore_jpda(x0, P0, Z, lam):
    """The whole association step: predictions, gates, likelihoods, marginals."""
    F = cv_transition(1.0)
    Q = cv_process_noise(1.0, Q_PSD, kind="cwna")
    H = position_matrix()
    R = np.eye(2) * R_VAR
    gamma = gate_threshold(PG, 2)
    T = x0.shape[0]
    m = Z.shape[0]
    valid = np.zeros((m, T), dtype=bool)
    lik = np.zeros((m, T))
    for t in range(T):
        xp, Pp = kf_predict(x0[t], P0, F, Q)
        S = H @ Pp @ H.T + R
        mask, d2 = mahalanobis_gate(Z, H @ xp, S, gamma)
        valid[:, t] = mask
        lik[:, t] = np.exp(-0.5 * d2) / (2.0 * math.pi * math.sqrt(np.linalg.det(S)))
    # Stone Soup's PDAHypothesiser model: P_D P_G for detection, N / P_G in the gate
    return jpda_marginals(lik / PG, valid, PD * PG, lam)


def _stonesoup_setup(x0, P0, Z, lam):
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    t0 = datetime.datetime(2026, 1, 1)
    t1 = t0 + datetime.timedelta(seconds=1)
    perm = [0, 2, 1, 3]  # trackcore [x, y, vx, vy] -> Stone Soup [x, vx, y, vy]
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(Q_PSD), ConstantVelocity(Q_PSD)])
    mm = LinearGaussian(4, (0, 2), np.eye(2) * R_VAR)
    hyp = PDAHypothesiser(KalmanPredictor(tm), KalmanUpdater(mm), clutter_spatial_density=lam,
                          prob_detect=PD, prob_gate=PG)
    tracks = [Track([GaussianState(x[perm].reshape(-1, 1), P0[np.ix_(perm, perm)], timestamp=t0)])
              for x in x0]
    dets = [Detection(z.reshape(-1, 1), timestamp=t1, measurement_model=mm) for z in Z]
    return hyp, tracks, dets, t1


def _stonesoup_betas(assoc, tracks, dets):
    """(m + 1, T) marginals in trackcore's layout from a Stone Soup association."""
    out = np.zeros((len(dets) + 1, len(tracks)))
    index = {id(d): j for j, d in enumerate(dets)}
    for t, track in enumerate(tracks):
        for h in assoc[track]:
            if h:
                out[index[id(h.measurement)] + 1, t] = float(h.probability)
            else:
                out[0, t] = float(h.probability)
    return out


def bench_jpda(targets=(3, 5, 8)) -> list[dict]:
    from stonesoup.dataassociator.probability import JPDA, JPDAwithEHM2
    rows = []
    trackcore_jpda(*jpda_scene(3))  # load the compiled kernels
    for T in targets:
        x0, P0, Z, lam = jpda_scene(T)
        hyp, tracks, dets, t1 = _stonesoup_setup(x0, P0, Z, lam)
        impls = {"stonesoup_JPDA": JPDA(hyp), "stonesoup_JPDAwithEHM2": JPDAwithEHM2(hyp)}
        reps = 3 if T >= 8 else 5
        times = {"trackcore": [], **{k: [] for k in impls}}
        walls = {k: [] for k in times}
        betas = {}
        for rep in range(reps):   # interleaved: every implementation sees the same load
            n_inner = 20
            with Stopwatch() as sw:
                for _ in range(n_inner):
                    beta, n_events = trackcore_jpda(x0, P0, Z, lam)
            times["trackcore"].append(sw.cpu / n_inner)
            walls["trackcore"].append(sw.wall / n_inner)
            betas["trackcore"] = beta
            for name, assoc in impls.items():
                if name == "stonesoup_JPDA" and T >= 8 and rep > 0:
                    continue  # brute force takes tens of seconds per scan: timed once
                with Stopwatch() as sw:
                    res = assoc.associate(set(tracks), set(dets), t1)
                times[name].append(sw.cpu)
                walls[name].append(sw.wall)
                betas[name] = _stonesoup_betas(res, tracks, dets)
        diffs = {k: float(np.max(np.abs(betas[k] - betas["trackcore"]))) for k in impls}
        for k, d in diffs.items():
            if not d < 1e-9:
                raise AssertionError(f"JPDA T={T}: trackcore and {k} marginals differ by {d:g}")
        # size of Stone Soup's brute-force product: prod_t (1 + gated measurements of t)
        gated = [int(np.count_nonzero(betas["trackcore"][1:, t] > 0)) for t in range(T)]
        product = int(np.prod([1 + g for g in gated]))
        # the enumeration alone (same validation matrix, unit likelihoods), 5 x 10 calls
        t_marg = []
        valid = betas["trackcore"][1:] > 0
        lik = np.where(valid, 1.0, 0.0)
        for _ in range(5):
            with Stopwatch() as sw:
                for _ in range(10):
                    jpda_marginals(lik, valid, PD * PG, lam)
            t_marg.append(sw.cpu / 10)
        common = {"targets": T, "measurements": int(Z.shape[0]), "feasible_events": int(n_events),
                  "brute_force_product": product, "max_abs_diff": diffs}
        rows.append(record("jpda_scan", "trackcore", T, median(times["trackcore"]), unit="scan",
                           trials=sorted(times["trackcore"]), wall=walls["trackcore"],
                           marginals_only_seconds=median(t_marg), **common))
        for name in impls:
            rows.append(record("jpda_scan", name, T, median(times[name]), unit="scan",
                               trials=sorted(times[name]), wall=walls[name], **common))
    return rows


def bench_hpda(m_max: int = 500, snr: float = 10.0, tau: float = 2.0, pg: float = 0.99,
               clutter_mean: float = 2.0) -> list[dict]:
    pd = math.exp(-tau / (1.0 + snr))
    ms = range(1, m_max + 1)
    # closed-form check of every m, in log space (mu_F(m - 1) underflows for large m)
    worst = 0.0
    for m in ms:
        lpt, _, _ = hpda_log_rank_probabilities(m, snr, tau, pg, clutter_mean)
        if not np.all(np.isfinite(lpt)):
            raise AssertionError(f"HPDA: non-finite log rank probability at m = {m}")
        ref = math.log(pd * pg) + (m - 1) * math.log(clutter_mean) - clutter_mean - math.lgamma(m)
        worst = max(worst, abs(float(logsumexp(lpt)) - ref))
    if not worst < 1e-9:
        raise AssertionError(f"HPDA: sum over ranks misses the closed form by {worst:g} (log)")
    pairs = m_max * (m_max + 1) // 2
    times, walls = [], []
    for _ in range(7):
        with Stopwatch() as sw:
            for m in ms:
                hpda_log_rank_probabilities(m, snr, tau, pg, clutter_mean)
        times.append(sw.cpu / pairs)
        walls.append(sw.wall / pairs)
    return [record("hpda_rank_probabilities", "trackcore", m_max, median(times), unit="pair",
                   trials=sorted(times), wall=walls, pairs=pairs, max_abs_log_error_closed_form=worst,
                   api="hpda_log_rank_probabilities(m, ...) for m = 1..500",
                   snr=snr, tau=tau, pg=pg, clutter_mean=clutter_mean)]


WORKLOADS = {"jpda": bench_jpda, "hpda": bench_hpda}
