"""Bootstrap particle filter: trackcore's fused numba step vs Stone Soup's ParticlePredictor
and ParticleUpdater (systematic resampling every step), same truth, same measurements, same
initial particles, in the same process.

Three trackcore paths are timed: ``trackcore_kernel`` (an njit loop over the scans calling
``bootstrap_step_kernel``, as a tracker kernel would), ``trackcore`` (the public, validating
``bootstrap_step`` called from Python once per scan) and, for N >= 2e4, ``trackcore_threads``
(``bootstrap_step(..., parallel=True)``: the move-and-weigh pass on numba threads).  They give
the same estimates (same seed, same draws); all paths run interleaved so they see the same
load.  Times are process CPU time (see ``_common.Stopwatch``), wall times stored beside.

4-state CV target, range-bearing sensor at the origin.  Agreement is checked on the position
RMSE of the posterior mean against the truth: the two filters use independent random draws,
so they must agree to Monte Carlo tolerance, not bit for bit.
"""
from __future__ import annotations

import datetime
import math
import time
from statistics import median

import numba as nb
import numpy as np

from trackcore.filters import bootstrap_step
from trackcore.filters.particle import MODEL_RANGE_BEARING, bootstrap_step_kernel, noise_factor
from trackcore.models import cv_process_noise, cv_transition, range_bearing

from ._common import Stopwatch, median_time, record

T = 1.0
Q_PSD = 0.5          # CWNA power spectral density (Stone Soup's ConstantVelocity noise_diff_coeff)
SIGMA_R, SIGMA_B = 10.0, 0.01
N_STEPS = 20


def _scenario(seed: int):
    rng = np.random.default_rng(seed)
    F = cv_transition(T)
    Q = cv_process_noise(T, Q_PSD, kind="cwna")
    L = np.linalg.cholesky(Q)
    x = np.array([1000.0, 2000.0, 10.0, -5.0])
    truth, zs = [], []
    for _ in range(N_STEPS):
        x = F @ x + L @ rng.standard_normal(4)
        truth.append(x.copy())
        r, b = range_bearing(x)
        zs.append(np.array([r + SIGMA_R * rng.standard_normal(), b + SIGMA_B * rng.standard_normal()]))
    x0 = np.array([1000.0, 2000.0, 10.0, -5.0])
    return F, Q, np.array(truth), np.array(zs), x0


def _initial_particles(N, x0, seed):
    rng = np.random.default_rng(seed)
    return x0 + rng.standard_normal((N, 4)) * np.array([20.0, 20.0, 2.0, 2.0])


@nb.njit(cache=True)
def _kernel_filter(particles, logw, F, L, zs, Rinv, logdetR, rng, scratch, est):
    """The bootstrap filter as a tracker kernel runs it: one njit loop over the scans
    calling :func:`bootstrap_step_kernel`, the position estimate (particle mean after
    resampling, i.e. the weighted mean) computed in the same kernel."""
    N = particles.shape[0]
    for k in range(zs.shape[0]):
        bootstrap_step_kernel(particles, logw, F, L, zs[k], Rinv, logdetR, MODEL_RANGE_BEARING,
                              0.0, 0.0, rng, 1.0, scratch)
        e0 = 0.0
        e1 = 0.0
        for i in range(N):
            e0 += particles[i, 0]
            e1 += particles[i, 1]
        est[k, 0] = e0 / N
        est[k, 1] = e1 / N


def _setup(N, seed):
    F, Q, truth, zs, x0 = _scenario(seed)
    R = np.diag([SIGMA_R**2, SIGMA_B**2])
    return F, noise_factor(Q), R, truth, zs, _initial_particles(N, x0, seed + 1)


def run_trackcore_kernel(N: int, seed: int = 0):
    """(CPU s per step, wall s per step, position estimates) of the kernel-level filter."""
    F, L, R, truth, zs, X0 = _setup(N, seed)
    Rinv = np.linalg.inv(R)
    logdetR = float(np.linalg.slogdet(R)[1])
    particles = X0.copy()
    logw = np.full(N, -np.log(N))
    scratch = np.empty_like(particles)
    est = np.empty((N_STEPS, 2))
    rng = np.random.default_rng(seed + 2)
    with Stopwatch() as sw:
        _kernel_filter(particles, logw, F, L, zs, Rinv, logdetR, rng, scratch, est)
    return sw.cpu / N_STEPS, sw.wall / N_STEPS, est


def run_trackcore(N: int, seed: int = 0, parallel: bool = False):
    """(CPU s per step, wall s per step, position estimates) calling the public, validating
    :func:`bootstrap_step` once per scan from Python (``parallel=True``: numba threads)."""
    F, L, R, truth, zs, X0 = _setup(N, seed)
    particles = X0.copy()
    logw = np.full(N, -np.log(N))
    scratch = np.empty_like(particles)
    rng = np.random.default_rng(seed + 2)
    est = np.empty((N_STEPS, 2))
    with Stopwatch() as sw:
        for k in range(N_STEPS):
            out = bootstrap_step(particles, logw, F, L, zs[k], R, rng, scratch=scratch,
                                 parallel=parallel)
            particles, logw = out.particles, out.logw
            est[k] = particles[:, :2].mean(axis=0)
    return sw.cpu / N_STEPS, sw.wall / N_STEPS, est


def _rmse(est, seed=0):
    truth = _scenario(seed)[2]
    return float(np.sqrt(np.mean(np.sum((est - truth[:, :2]) ** 2, axis=1))))


def run_stonesoup(N: int, seed: int = 0):
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.resampler.particle import SystematicResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.updater.particle import ParticleUpdater

    F, Q, truth, zs, x0 = _scenario(seed)
    perm = [0, 2, 1, 3]  # trackcore [x, y, vx, vy] -> Stone Soup [x, vx, y, vy]
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(Q_PSD), ConstantVelocity(Q_PSD)])
    assert np.allclose(tm.covar(time_interval=datetime.timedelta(seconds=T)), Q[np.ix_(perm, perm)])
    mm = CartesianToBearingRange(ndim_state=4, mapping=(0, 2),
                                 noise_covar=np.diag([SIGMA_B**2, SIGMA_R**2]))
    predictor = ParticlePredictor(tm)
    updater = ParticleUpdater(mm, resampler=SystematicResampler())
    start = datetime.datetime(2026, 1, 1)
    particles = _initial_particles(N, x0, seed + 1)[:, perm]
    np.random.seed(seed + 3)  # Stone Soup draws from numpy's global stream
    state = ParticleState(StateVectors(particles.T), log_weight=np.full(N, -np.log(N)),
                          timestamp=start)
    est = np.empty((N_STEPS, 2))
    with Stopwatch() as sw:
        for k in range(N_STEPS):
            ts = start + datetime.timedelta(seconds=T * (k + 1))
            pred = predictor.predict(state, timestamp=ts)
            det = Detection(np.array([[zs[k, 1]], [zs[k, 0]]]), timestamp=ts,
                            measurement_model=mm)
            state = updater.update(SingleHypothesis(pred, det))
            sv = np.asarray(state.mean, dtype=float).ravel()  # weighted mean of the particles
            est[k] = sv[[0, 2]]
    return sw.cpu / N_STEPS, sw.wall / N_STEPS, est


@nb.njit(cache=True)
def _floor_op(op, x, y, out):
    """One elementary operation of the bootstrap step over arrays (see :func:`roofline_floor`)."""
    n = x.shape[0]
    if op == 0:
        for i in range(n):
            out[i] = math.atan2(y[i], x[i])
    elif op == 1:
        for i in range(n):
            out[i] = math.sqrt(x[i] * x[i] + y[i] * y[i])
    else:
        for i in range(n):
            out[i] = math.exp(-y[i])


@nb.njit(cache=True)
def _floor_draws(rng, out):
    for i in range(out.shape[0]):
        out[i] = rng.standard_normal()


def roofline_floor(k: int = 4, m: int = 1 << 18) -> dict:
    """The elementary-operation floor of one bootstrap step, per particle, on this core now.

    Each step needs per particle ``k`` standard-normal draws (process noise; ``k = 4`` for the
    full-rank CWNA noise), one square root and one arctangent (predicted range and bearing)
    and one exponential (normalising the weights; systematic resampling every step needs no
    logarithm).  Each is timed alone in a numba loop over ``m`` values (median of 7, process
    CPU time), the arctangent and square root on positions like the benchmark's (around
    (1000, 2000) m), the exponential on log-weight differences in [0, 30].  Arithmetic and
    memory traffic come on top, so no kernel reaches this floor; the ``trackcore_kernel`` rows
    store it with ``fraction_of_floor`` = floor / measured time per particle.
    """
    rng = np.random.default_rng(7)
    x = 1000.0 + 20.0 * rng.standard_normal(m)
    y = 2000.0 + 20.0 * rng.standard_normal(m)
    d = 30.0 * rng.random(m)
    out = np.empty(m)
    ns = {}
    for name, op, b in (("atan2", 0, y), ("sqrt", 1, y), ("exp", 2, d)):
        _floor_op(op, x, b, out)
        ns[name] = median_time(lambda: _floor_op(op, x, b, out), repeat=7) / m * 1e9
    _floor_draws(rng, out)
    ns["normal_draw"] = median_time(lambda: _floor_draws(rng, out), repeat=7) / m * 1e9
    counts = {"normal_draw": k, "atan2": 1, "sqrt": 1, "exp": 1}
    return {"ns_per_op": ns, "ops_per_particle": counts,
            "ns_per_particle": sum(counts[o] * ns[o] for o in counts)}


def _two_process_worker(N, repeats):
    """Runs in a worker process: the kernel-level filter ``repeats`` times; returns
    (wall start, wall stop, CPU seconds) of the timed part."""
    run_trackcore_kernel(1000)  # load the compiled kernels
    t0 = time.time()
    with Stopwatch() as sw:
        for _ in range(repeats):
            run_trackcore_kernel(N)
    return t0, time.time(), sw.cpu


def two_core_throughput(N: int = 100000, repeats: int = 3) -> dict:
    """Particle-updates per second with one serial filter per core (two processes),
    the way a Monte Carlo uses both cores (``trackcore.montecarlo.process_pool``).

    ``particle_updates_per_second`` divides the updates of both processes by their mean
    CPU time (what two unshared cores deliver); ``wall_particle_updates_per_second`` by
    the wall time of the whole (shared) run."""
    from trackcore.montecarlo import process_pool
    with process_pool(2) as ex:
        list(ex.map(_two_process_worker, [1000, 1000], [1, 1]))  # start and warm the workers
        spans = list(ex.map(_two_process_worker, [N, N], [repeats, repeats]))
    wall = max(b for _, b, _ in spans) - min(a for a, _, _ in spans)
    cpu = sum(c for _, _, c in spans) / 2
    updates = 2 * repeats * N * N_STEPS
    return {"particles": N, "processes": 2, "steps": N_STEPS * repeats, "cpu_seconds": cpu,
            "wall_seconds": wall, "particle_updates_per_second": updates / cpu,
            "wall_particle_updates_per_second": updates / wall}


def bench_pf(sizes=(1000, 10000, 100000), repeats=5) -> list[dict]:
    """Rows per size and path (median CPU time per step over interleaved repetitions: 3x
    ``repeats`` below N = 1e5, where a repetition is cheap), the ``trackcore_kernel`` rows with
    the :func:`roofline_floor` measured in the same loop, and the two-process throughput."""
    out = []
    k = noise_factor(_scenario(0)[1]).shape[1]
    for N in sizes:
        reps = repeats if N >= 100000 else 3 * repeats
        names = ["trackcore_kernel", "trackcore", "stonesoup"]
        if N >= 20000:
            names.append("trackcore_threads")
        cpu = {k: [] for k in names}
        wall = {k: [] for k in names}
        run_trackcore_kernel(min(N, 1000))      # compile / load the caches
        run_trackcore(min(N, 1000))
        run_trackcore(min(N, 1000), parallel=True)
        ests = {}
        floors = []
        for _ in range(reps):                  # interleaved: all paths see the same load
            floors.append(roofline_floor(k, m=1 << 16))
            for name in names:
                if name == "stonesoup":
                    c, w, e = run_stonesoup(N)
                elif name == "trackcore":
                    c, w, e = run_trackcore(N)
                elif name == "trackcore_threads":
                    c, w, e = run_trackcore(N, parallel=True)
                else:
                    c, w, e = run_trackcore_kernel(N)
                cpu[name].append(c)
                wall[name].append(w)
                ests[name] = e
        # same seed, same arithmetic: every trackcore path gives the same estimates
        for name in names:
            if name.startswith("trackcore") and not np.allclose(ests[name], ests["trackcore"],
                                                                rtol=0, atol=1e-9):
                raise AssertionError(f"PF N={N}: {name} differs from bootstrap_step")
        rmse_ours, rmse_peer = _rmse(ests["trackcore"]), _rmse(ests["stonesoup"])
        # independent random draws: the two RMSEs must agree to Monte Carlo tolerance
        tol = max(0.25 * rmse_peer, 3.0)
        if abs(rmse_ours - rmse_peer) > tol:
            raise AssertionError(f"PF N={N}: RMSE trackcore {rmse_ours:.2f} vs Stone Soup {rmse_peer:.2f}")
        common = {"rmse_trackcore": rmse_ours, "rmse_stonesoup": rmse_peer, "steps": N_STEPS}
        fl = {"ops_per_particle": floors[0]["ops_per_particle"],
              "ns_per_op": {o: median(f["ns_per_op"][o] for f in floors)
                            for o in floors[0]["ns_per_op"]},
              "ns_per_particle": median(f["ns_per_particle"] for f in floors)}
        for name in names:
            t = median(cpu[name])
            extra = {}
            if name == "trackcore_kernel":
                extra = {"floor": fl, "floor_ns_per_particle": fl["ns_per_particle"],
                         "fraction_of_floor": fl["ns_per_particle"] / (t / N * 1e9)}
            out.append(record("bootstrap_pf", name, N, t, ns_per_particle=t / N * 1e9,
                              trials=list(cpu[name]), wall=wall[name], **common, **extra))
    tp = two_core_throughput()
    out.append(record("bootstrap_pf_two_processes", "trackcore_kernel", tp["particles"],
                      tp["cpu_seconds"] / tp["steps"], **tp))
    return out
