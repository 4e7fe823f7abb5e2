"""SMC-PHD filter: trackcore (``trackcore.trackers.smc_phd_step``) vs Stone Soup's
``SMCPHDPredictor`` ('expansion' birth scheme) and ``SMCPHDUpdater`` with
``SystematicResampler``, same truth, same scans, same initial particles, in the same process.

Shared configuration (both implementations compute the same thing up to random draws):
3 targets, 4-state CV motion with CWNA noise (Stone Soup ``ConstantVelocity``), range-bearing
sensor at the origin with diagonal ``R``, ``P_D = 0.9``, survival ``P_S = exp(-0.01 T)``
(Stone Soup ``death_probability = 0.01``), Poisson clutter, 10 per scan, uniform over the
range-bearing box ``[500, 5000] m x [0, pi/2] rad`` (clutter intensity ``10 / area`` per m rad),
Gaussian birth density with ``300`` particles per scan (Stone Soup ``birth_probability = 0.1``
of 3000) of total weight ``birth_rate = 0.05``, and ``3000`` particles (1000 per target) after
systematic resampling every scan.  The filter starts from 1000 particles around each true
initial state, weight 1/1000 each (mass 3).

Stone Soup 1.9.1's ``SMCPHDUpdater`` evaluates ``measurement_model.logpdf(..., noise=True)``,
which adds a random measurement-noise draw to every particle's predicted measurement (the
likelihood is then that of ``h(x) + v``, on average ``N(z; h(x), 2R)``, not ``g(z | x)``).
The peer therefore runs with ``_NoiselessLikelihood`` (``CartesianToBearingRange`` whose
``logpdf`` drops the ``noise`` keyword), which makes it the textbook update that trackcore
computes; this also makes it faster (no noise draws), so the ratio is conservative.  The
as-shipped updater is timed too (row ``stonesoup_as_shipped``) and its cardinality reported.

Paths timed: ``trackcore_kernel`` (:func:`smc_phd_filter`, the whole run in one kernel),
``trackcore`` (the public :func:`smc_phd_step` called from Python once per scan; identical
draws and results), ``stonesoup`` and ``stonesoup_as_shipped``.  Interleaved repetitions,
median process CPU time per scan (see ``_common.Stopwatch``), wall times stored beside.

Agreement, checked before the times are recorded: the two trackcore paths give identical
cardinalities in every repetition; trackcore's and Stone Soup's mean cardinality (over the
``repeats`` runs x 20 scans; repetition ``r`` uses filter draws ``r`` on the same scans) agree
within 0.1 (the target of issue #8).  Both filters see the same scans, so the difference is
only their independent particle draws.  The update itself (same predicted particles into both
updaters) agrees to 1e-9 in ``tests/test_smc_phd_stonesoup.py``.
"""
from __future__ import annotations

import datetime
import math
from statistics import median

import numpy as np

from trackcore.models import cv_process_noise, cv_transition, range_bearing
from trackcore.trackers import smc_phd_filter, smc_phd_model, smc_phd_step

from ._common import Stopwatch, record

T = 1.0
Q_PSD = 0.5                      # CWNA power spectral density (ConstantVelocity noise_diff_coeff)
SIGMA_R, SIGMA_B = 10.0, 0.01
PD = 0.9
DEATH = 0.01                     # Stone Soup death_probability: P_S = exp(-DEATH T)
PS = math.exp(-DEATH * T)
CLUTTER_MEAN = 10.0
R_LO, R_HI, B_LO, B_HI = 500.0, 5000.0, 0.0, 0.5 * math.pi
CLUTTER_INTENSITY = CLUTTER_MEAN / ((R_HI - R_LO) * (B_HI - B_LO))
N_PER_TARGET = 1000
N_BIRTH_FRACTION = 0.1           # Stone Soup birth_probability ('expansion': round(0.1 N) births)
BIRTH_RATE = 0.05
BIRTH_MEAN = np.array([1800.0, 1800.0, 0.0, 0.0])
BIRTH_COV = np.diag([1000.0**2, 1000.0**2, 10.0**2, 10.0**2])
X0 = np.array([[1500.0, 1000.0, 5.0, 8.0],
               [1000.0, 2500.0, 8.0, -3.0],
               [3000.0, 2000.0, -6.0, 4.0]])
INIT_SPREAD = np.array([20.0, 20.0, 2.0, 2.0])
N_SCANS = 20
PERM = [0, 2, 1, 3]              # trackcore [x, y, vx, vy] -> Stone Soup [x, vx, y, vy]


def scenario(seed: int, n_scans: int = N_SCANS, x0=X0):
    """Truth ``(K, n_t, 4)``, scans ``z`` ``(M, 2)`` (range, bearing) and ``offsets``."""
    rng = np.random.default_rng(seed)
    F = cv_transition(T)
    Lq = np.linalg.cholesky(cv_process_noise(T, Q_PSD, kind="cwna"))
    x = np.array(x0, dtype=float)
    truth, zs, off = [], [], [0]
    for _ in range(n_scans):
        x = x @ F.T + rng.standard_normal(x.shape) @ Lq.T
        truth.append(x.copy())
        det = rng.random(len(x)) < PD
        h = range_bearing(x[det])
        h = h + rng.standard_normal(h.shape) * np.array([SIGMA_R, SIGMA_B])
        nc = rng.poisson(CLUTTER_MEAN)
        c = np.column_stack([rng.uniform(R_LO, R_HI, nc), rng.uniform(B_LO, B_HI, nc)])
        z = np.vstack([h, c])
        zs.append(z[rng.permutation(len(z))])
        off.append(off[-1] + len(z))
    return np.array(truth), np.vstack(zs), np.array(off, dtype=np.int64)


def initial_particles(seed: int, x0=X0, n_per_target: int = N_PER_TARGET):
    rng = np.random.default_rng(seed)
    X = np.vstack([x + rng.standard_normal((n_per_target, 4)) * INIT_SPREAD for x in x0])
    return X, np.full(len(X), 1.0 / n_per_target)


def model(n_total: int):
    return smc_phd_model(cv_transition(T), cv_process_noise(T, Q_PSD, kind="cwna"),
                         np.diag([SIGMA_R**2, SIGMA_B**2]), pd=PD, ps=PS,
                         clutter_intensity=CLUTTER_INTENSITY, birth_mean=BIRTH_MEAN,
                         birth_cov=BIRTH_COV, n_birth=round(N_BIRTH_FRACTION * n_total),
                         birth_rate=BIRTH_RATE)


def run_trackcore_kernel(seed: int = 0, rep: int = 0):
    """(CPU s per scan, wall s per scan, cardinality per scan): :func:`smc_phd_filter`.
    ``seed`` fixes the scans and initial particles, ``rep`` the filter's draws."""
    _, z, off = scenario(seed)
    X, w = initial_particles(seed + 1)
    mdl = model(len(X))
    rng = np.random.default_rng([seed + 2, rep])
    with Stopwatch() as sw:
        out = smc_phd_filter(X, w, z, off, mdl, rng, n_out=len(X))
    K = len(off) - 1
    return sw.cpu / K, sw.wall / K, out.cardinality


def run_trackcore(seed: int = 0, rep: int = 0):
    """(CPU s per scan, wall s per scan, cardinality per scan): :func:`smc_phd_step` called
    once per scan from Python (same draws as :func:`run_trackcore_kernel`)."""
    _, z, off = scenario(seed)
    X, w = initial_particles(seed + 1)
    n = len(X)
    mdl = model(n)
    rng = np.random.default_rng([seed + 2, rep])
    K = len(off) - 1
    card = np.empty(K)
    with Stopwatch() as sw:
        for k in range(K):
            X, w, card[k], _ = smc_phd_step(X, w, z[off[k]:off[k + 1]], mdl, rng, n_out=n)
    return sw.cpu / K, sw.wall / K, card


def stonesoup_filter(as_shipped: bool = False, n_total: int = 3 * N_PER_TARGET):
    """Stone Soup (predictor, hypothesiser, updater, measurement model) for the shared
    configuration; ``as_shipped=False`` uses :class:`_NoiselessLikelihood`."""
    from stonesoup.hypothesiser.simple import SimpleHypothesiser
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.particle import SMCPHDPredictor
    from stonesoup.resampler.particle import SystematicResampler
    from stonesoup.sampler.particle import ParticleSampler
    from stonesoup.updater.particle import SMCPHDUpdater

    class _NoiselessLikelihood(CartesianToBearingRange):
        """``CartesianToBearingRange`` whose ``logpdf`` ignores ``noise=True`` (which
        ``SMCPHDUpdater`` passes), i.e. evaluates ``N(z; h(x), R)``."""

        def logpdf(self, state1, state2, **kwargs):
            kwargs.pop("noise", None)
            return super().logpdf(state1, state2, **kwargs)

    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(Q_PSD), ConstantVelocity(Q_PSD)])
    Q = cv_process_noise(T, Q_PSD, kind="cwna")
    assert np.allclose(tm.covar(time_interval=datetime.timedelta(seconds=T)), Q[np.ix_(PERM, PERM)])
    cls = CartesianToBearingRange if as_shipped else _NoiselessLikelihood
    mm = cls(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([SIGMA_B**2, SIGMA_R**2]))
    sampler = ParticleSampler(distribution_func=np.random.multivariate_normal,
                              params={"mean": BIRTH_MEAN[PERM],
                                      "cov": BIRTH_COV[np.ix_(PERM, PERM)]},
                              ndim_state=4)
    predictor = SMCPHDPredictor(transition_model=tm, death_probability=DEATH,
                                birth_probability=N_BIRTH_FRACTION, birth_rate=BIRTH_RATE,
                                birth_sampler=sampler, birth_func_num_samples_field="size",
                                birth_scheme="expansion")
    updater = SMCPHDUpdater(measurement_model=mm, resampler=SystematicResampler(),
                            prob_detect=PD, clutter_intensity=CLUTTER_INTENSITY,
                            num_samples=n_total)
    return SimpleHypothesiser(predictor, check_timestamp=False), updater, mm


def stonesoup_detections(zk, ts, mm):
    from stonesoup.types.detection import Detection
    return [Detection(np.array([[b], [r]]), timestamp=ts, measurement_model=mm) for r, b in zk]


def run_stonesoup(seed: int = 0, rep: int = 0, as_shipped: bool = False):
    """(CPU s per scan, wall s per scan, cardinality per scan) of Stone Soup."""
    from scipy.special import logsumexp
    from stonesoup.types.array import StateVectors
    from stonesoup.types.state import ParticleState

    _, z, off = scenario(seed)
    X, w = initial_particles(seed + 1)
    hyp, updater, mm = stonesoup_filter(as_shipped, len(X))
    start = datetime.datetime(2026, 1, 1)
    np.random.seed([seed + 3, rep])  # Stone Soup draws from numpy's global stream
    state = ParticleState(StateVectors(X[:, PERM].T), log_weight=np.log(w), timestamp=start)
    K = len(off) - 1
    card = np.empty(K)
    with Stopwatch() as sw:
        for k in range(K):
            ts = start + datetime.timedelta(seconds=T * (k + 1))
            dets = stonesoup_detections(z[off[k]:off[k + 1]], ts, mm)
            state = updater.update(hyp.hypothesise(state, dets, ts))
            card[k] = math.exp(logsumexp(state.log_weight))
    return sw.cpu / K, sw.wall / K, card


def bench_phd(repeats: int = 5, seed: int = 0) -> list[dict]:
    """Rows for ``benchmarks.run`` (key ``phd``).  Repetition ``r`` runs every path on the
    same scans with filter draws ``r``; cardinalities are averaged over the repetitions."""
    names = ["trackcore_kernel", "trackcore", "stonesoup", "stonesoup_as_shipped"]
    run = {"trackcore_kernel": run_trackcore_kernel, "trackcore": run_trackcore,
           "stonesoup": run_stonesoup,
           "stonesoup_as_shipped": lambda seed, rep: run_stonesoup(seed, rep, as_shipped=True)}
    run_trackcore_kernel(seed)      # compile / load the caches
    run_trackcore(seed)
    cpu = {k: [] for k in names}
    wall = {k: [] for k in names}
    card = {k: [] for k in names}
    for rep in range(repeats):     # interleaved: all paths see the same load
        for name in names:
            c, w, e = run[name](seed, rep)
            cpu[name].append(c)
            wall[name].append(w)
            card[name].append(e)
        if not np.array_equal(card["trackcore_kernel"][-1], card["trackcore"][-1]):
            raise AssertionError("PHD: smc_phd_filter and smc_phd_step differ")
    per_scan = {k: np.mean(v, axis=0) for k, v in card.items()}
    mean = {k: float(np.mean(v)) for k, v in card.items()}
    diff = mean["trackcore"] - mean["stonesoup"]
    # Independent particle draws on the same scans.  The mean over one run of 20 scans has a
    # standard deviation of about 0.025 between runs (measured over 200 trackcore and 20 Stone
    # Soup runs: 0.025 and 0.022, means 3.089 and 3.085); averaged over ``repeats`` runs the
    # difference's standard deviation is about 0.035 / sqrt(repeats): issue #8's 0.1 is > 6 of them.
    if abs(diff) > 0.1:
        raise AssertionError(f"PHD: mean cardinality trackcore {mean['trackcore']:.3f} vs "
                             f"Stone Soup {mean['stonesoup']:.3f}")
    K = len(per_scan["trackcore"])
    n = 3 * N_PER_TARGET
    common = {"scans": K, "particles": n, "birth_particles": round(N_BIRTH_FRACTION * n),
              "targets": 3, "clutter_per_scan": CLUTTER_MEAN, "runs_averaged": repeats,
              "mean_cardinality_trackcore": mean["trackcore"],
              "mean_cardinality_stonesoup": mean["stonesoup"],
              "mean_cardinality_stonesoup_as_shipped": mean["stonesoup_as_shipped"],
              "mean_cardinality_difference": diff,
              "max_abs_cardinality_difference_per_scan":
                  float(np.max(np.abs(per_scan["trackcore"] - per_scan["stonesoup"])))}
    out = []
    for name in names:
        t = median(cpu[name])
        out.append(record("smc_phd", name, n, t, unit="step", trials=list(cpu[name]),
                          wall=wall[name], speedup_vs_stonesoup=median(cpu["stonesoup"]) / t,
                          speedup_vs_stonesoup_as_shipped=median(cpu["stonesoup_as_shipped"]) / t,
                          mean_cardinality_per_scan=[float(c) for c in per_scan[name]],
                          **common))
    return out
