"""KF and IMM: trackcore's whole-run numba kernels vs filterpy, same inputs, same process.

KF: 4-state CV, position measurements, 1000 runs x 100 steps.
IMM: 3 models (CV and +/- coordinated turn), 200 runs x 100 steps.
Both implementations must agree to 1e-9 (max abs difference of the posterior means) before
any time is reported.  The peer's runs are timed in blocks interleaved with repetitions of
the trackcore paths, so both see the same (shared, noisy) machine load; times are medians of
process CPU time (wall times stored beside them).
"""
from __future__ import annotations

from statistics import median

import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter

from trackcore.filters import imm_filter_run, kalman_filter_batch, kalman_filter_run
from trackcore.models import (coordinated_turn_transition, cv_process_noise, cv_transition,
                              position_matrix)

from ._common import Stopwatch, record

T = 1.0
F = cv_transition(T)
Q = cv_process_noise(T, 1.0)
H = position_matrix()
R = np.diag([100.0, 100.0])
x0 = np.array([0.0, 0.0, 10.0, 5.0])
P0 = np.diag([100.0, 100.0, 25.0, 25.0])


def _measurements(n_runs: int, n_steps: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    zs = np.empty((n_runs, n_steps, 2))
    Lq = np.linalg.cholesky(Q + 1e-12 * np.eye(4))
    for i in range(n_runs):
        x = x0.copy()
        for k in range(n_steps):
            x = F @ x + Lq @ rng.standard_normal(4)
            zs[i, k] = x[:2] + 10.0 * rng.standard_normal(2)
    return zs


def _filterpy_kf(zs, out):
    for i in range(zs.shape[0]):
        kf = KalmanFilter(dim_x=4, dim_z=2)
        kf.F, kf.Q, kf.H, kf.R = F, Q, H, R
        kf.x, kf.P = x0.copy(), P0.copy()
        for k in range(zs.shape[1]):
            kf.predict()
            kf.update(zs[i, k])
            out[i, k] = kf.x


def _stonesoup_kf(zs, out):
    """Stone Soup KalmanPredictor / KalmanUpdater, one Track per run (state order
    [x, vx, y, vy], converted back)."""
    import datetime

    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import KalmanUpdater

    perm = [0, 2, 1, 3]
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(1.0), ConstantVelocity(1.0)])
    mm = LinearGaussian(4, (0, 2), R)
    predictor, updater = KalmanPredictor(tm), KalmanUpdater(mm)
    t0 = datetime.datetime(2026, 1, 1)
    for i in range(zs.shape[0]):
        state = GaussianState(x0[perm].reshape(-1, 1), P0[np.ix_(perm, perm)], timestamp=t0)
        for k in range(zs.shape[1]):
            ts = t0 + datetime.timedelta(seconds=T * (k + 1))
            pred = predictor.predict(state, timestamp=ts)
            det = Detection(zs[i, k].reshape(-1, 1), timestamp=ts, measurement_model=mm)
            state = updater.update(SingleHypothesis(pred, det))
            out[i, k] = np.asarray(state.state_vector, dtype=float).ravel()[perm]


def bench_kf(n_runs: int = 1000, n_steps: int = 100, blocks: int = 5) -> list[dict]:
    """Three trackcore paths against filterpy on the same measurements:

    * ``trackcore_batch``: :func:`kalman_filter_batch`, the whole Monte Carlo in one call
      (covariance recursion shared by the runs);
    * ``trackcore``: :func:`kalman_filter_run` called once per run (validation + kernel);
    * ``filterpy``: ``KalmanFilter.predict(); update(z)`` per step.

    filterpy processes the runs in ``blocks`` blocks, each block timed between two
    repetitions of the trackcore paths (same load); the time per step is the median.
    """
    zs = _measurements(n_runs, n_steps, 1)
    kalman_filter_run(zs[0], x0, P0, F, Q, H, R)      # compile / load the caches
    kalman_filter_batch(zs[:2], x0, P0, F, Q, H, R)
    peer = np.empty((n_runs, n_steps, 4))
    per = n_runs // blocks
    t_batch, t_run, t_peer, w_batch, w_run, w_peer = [], [], [], [], [], []
    for b in range(blocks + 1):
        with Stopwatch() as sw:
            batch = kalman_filter_batch(zs, x0, P0, F, Q, H, R)
        t_batch.append(sw.cpu / (n_runs * n_steps))
        w_batch.append(sw.wall / (n_runs * n_steps))
        with Stopwatch() as sw:
            ours = [kalman_filter_run(zs[i], x0, P0, F, Q, H, R).xs for i in range(n_runs)]
        t_run.append(sw.cpu / (n_runs * n_steps))
        w_run.append(sw.wall / (n_runs * n_steps))
        if b < blocks:
            sl = slice(b * per, (b + 1) * per if b < blocks - 1 else n_runs)
            with Stopwatch() as sw:
                _filterpy_kf(zs[sl], peer[sl])
            t_peer.append(sw.cpu / ((sl.stop - sl.start) * n_steps))
            w_peer.append(sw.wall / ((sl.stop - sl.start) * n_steps))
    if not np.array_equal(np.asarray(ours), batch.xs):
        raise AssertionError("KF: kalman_filter_batch differs from kalman_filter_run")
    # Stone Soup (about 20x slower than filterpy): the first ss_runs runs only.  Its
    # ConstantVelocity model is CWNA, so the batch is re-run with the same Q for the check.
    ss_runs = 20
    Q_ss = cv_process_noise(T, 1.0, kind="cwna")
    ref = kalman_filter_batch(zs[:ss_runs], x0, P0, F, Q_ss, H, R).xs
    ss = np.empty((ss_runs, n_steps, 4))
    t_ss, w_ss = [], []
    for _ in range(3):
        with Stopwatch() as sw:
            _stonesoup_kf(zs[:ss_runs], ss)
        t_ss.append(sw.cpu / (ss_runs * n_steps))
        w_ss.append(sw.wall / (ss_runs * n_steps))
    diff_ss = float(np.max(np.abs(ref - ss)))
    if not diff_ss < 1e-9:
        raise AssertionError(f"KF: trackcore and Stone Soup differ by {diff_ss:g}")
    diff = float(np.max(np.abs(batch.xs - peer)))
    if not diff < 1e-9:
        raise AssertionError(f"KF: trackcore and filterpy differ by {diff:g}")
    common = {"max_abs_diff_vs_filterpy": diff, "runs": n_runs, "steps": n_steps}
    return [record("kf_cv4", "trackcore_batch", 4, median(t_batch), trials=t_batch, wall=w_batch,
                   api="kalman_filter_batch(zs (1000, 100, 2), ...) once", **common),
            record("kf_cv4", "trackcore", 4, median(t_run), trials=t_run, wall=w_run,
                   api="kalman_filter_run(zs[i], ...) per run", **common),
            record("kf_cv4", "filterpy", 4, median(t_peer), trials=t_peer, wall=w_peer,
                   api="KalmanFilter predict(); update(z) per step", **common),
            record("kf_cv4", "stonesoup", 4, median(t_ss), trials=t_ss, wall=w_ss,
                   api="KalmanPredictor.predict; KalmanUpdater.update per step (CWNA Q)",
                   max_abs_diff_vs_trackcore=diff_ss, runs=ss_runs, steps=n_steps)]


def _imm_models():
    omega = 0.05
    Fs = np.stack([F, coordinated_turn_transition(omega, T), coordinated_turn_transition(-omega, T)])
    Qs = np.stack([Q, 4.0 * Q, 4.0 * Q])
    PI = np.array([[0.90, 0.05, 0.05], [0.10, 0.85, 0.05], [0.10, 0.05, 0.85]])
    mu0 = np.array([0.8, 0.1, 0.1])
    return Fs, Qs, PI, mu0


def _filterpy_imm(zs, Fs, Qs, PI, mu0, out):
    for i in range(zs.shape[0]):
        filters = []
        for j in range(3):
            kf = KalmanFilter(dim_x=4, dim_z=2)
            kf.F, kf.Q, kf.H, kf.R = Fs[j], Qs[j], H, R
            kf.x, kf.P = x0.copy(), P0.copy()
            filters.append(kf)
        imm = IMMEstimator(filters, mu0.copy(), PI)
        for k in range(zs.shape[1]):
            imm.predict()
            imm.update(zs[i, k])
            out[i, k] = imm.x


def bench_imm(n_runs: int = 200, n_steps: int = 100, blocks: int = 5) -> list[dict]:
    """trackcore :func:`imm_filter_run` per run vs filterpy ``IMMEstimator``; filterpy in
    ``blocks`` blocks interleaved with repetitions of the trackcore loop."""
    zs = _measurements(n_runs, n_steps, 2)
    Fs, Qs, PI, mu0 = _imm_models()
    xs0 = np.tile(x0, (3, 1))
    Ps0 = np.tile(P0, (3, 1, 1))
    imm_filter_run(zs[0], xs0, Ps0, mu0, PI, Fs, Qs, H, R)
    peer = np.empty((n_runs, n_steps, 4))
    per = n_runs // blocks
    t_ours, t_peer, w_ours, w_peer = [], [], [], []
    for b in range(blocks + 1):
        with Stopwatch() as sw:
            ours = [imm_filter_run(zs[i], xs0, Ps0, mu0, PI, Fs, Qs, H, R).x
                    for i in range(n_runs)]
        t_ours.append(sw.cpu / (n_runs * n_steps))
        w_ours.append(sw.wall / (n_runs * n_steps))
        if b < blocks:
            sl = slice(b * per, (b + 1) * per if b < blocks - 1 else n_runs)
            with Stopwatch() as sw:
                _filterpy_imm(zs[sl], Fs, Qs, PI, mu0, peer[sl])
            t_peer.append(sw.cpu / ((sl.stop - sl.start) * n_steps))
            w_peer.append(sw.wall / ((sl.stop - sl.start) * n_steps))
    diff = float(np.max(np.abs(np.asarray(ours) - peer)))
    if not diff < 1e-9:
        raise AssertionError(f"IMM: trackcore and filterpy differ by {diff:g}")
    common = {"max_abs_diff_vs_filterpy": diff, "runs": n_runs, "steps": n_steps}
    return [record("imm_3models", "trackcore", 3, median(t_ours), trials=t_ours, wall=w_ours,
                   api="imm_filter_run(zs[i], ...) per run", **common),
            record("imm_3models", "filterpy", 3, median(t_peer), trials=t_peer, wall=w_peer,
                   api="IMMEstimator predict(); update(z) per step", **common)]
