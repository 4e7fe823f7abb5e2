"""SMC-PHD step API (trackcore.trackers.smc_phd_step) cross-checked against Stone Soup's
SMCPHDPredictor ('expansion' births) and SMCPHDUpdater on shared inputs.

Stone Soup 1.9.1's SMCPHDUpdater.update without a resampler returns the predicted weights
(it writes the updated ones only in its resampling branch): the deterministic checks take
its updated weights from ``get_log_weights_per_hypothesis`` (the same logsumexp ``update``
does), the multi-scan check runs it with its ``SystematicResampler``.  Its likelihood
calls ``measurement_model.logpdf(..., noise=True)``, which
adds a fresh measurement-noise draw to every particle's predicted measurement
(``test_stonesoup_as_shipped_likelihood_is_random`` shows it).  The cross-checks therefore
give Stone Soup a ``CartesianToBearingRange`` whose ``logpdf`` drops that keyword, i.e. the
textbook likelihood ``N(z; h(x), R)`` that trackcore evaluates.
"""
from __future__ import annotations

import datetime
import math

import numpy as np
import pytest

from trackcore.filters import loglik_range_bearing
from trackcore.models import cv_process_noise, cv_transition, range_bearing
from trackcore.trackers import (SmcPhdModel, smc_phd_filter, smc_phd_model, smc_phd_step,
                                smc_phd_update)

pytest.importorskip("stonesoup")
from scipy.special import logsumexp  # noqa: E402
from stonesoup.hypothesiser.simple import SimpleHypothesiser  # noqa: E402
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.particle import SMCPHDPredictor  # noqa: E402
from stonesoup.resampler.particle import SystematicResampler  # noqa: E402
from stonesoup.sampler.particle import ParticleSampler  # noqa: E402
from stonesoup.types.array import StateVectors  # noqa: E402
from stonesoup.types.detection import Detection, MissedDetection  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.multihypothesis import MultipleHypothesis  # noqa: E402
from stonesoup.types.prediction import ParticleStatePrediction  # noqa: E402
from stonesoup.types.state import ParticleState  # noqa: E402
from stonesoup.updater.particle import SMCPHDUpdater  # noqa: E402

PERM = [0, 2, 1, 3]  # trackcore [x, y, vx, vy] -> Stone Soup [x, vx, y, vy]
SR, SB = 10.0, 0.01
R = np.diag([SR**2, SB**2])
PD = 0.9
KAPPA = 10.0 / (4500.0 * 0.5 * math.pi)  # 10 clutter over [500, 5000] m x [0, pi/2] rad
T0 = datetime.datetime(2026, 1, 1)


class NoiselessLikelihood(CartesianToBearingRange):
    """Stone Soup's range-bearing model with ``logpdf`` evaluating ``N(z; h(x), R)``."""

    def logpdf(self, state1, state2, **kwargs):
        kwargs.pop("noise", None)
        return super().logpdf(state1, state2, **kwargs)


def _mm(cls=NoiselessLikelihood):
    return cls(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([SB**2, SR**2]))


def _ss_update(X, w, Z, pd=PD, kappa=KAPPA, mm=None):
    """Stone Soup's SMCPHDUpdater (no resampler) on predicted particles X (trackcore order)."""
    mm = _mm() if mm is None else mm
    pred = ParticleStatePrediction(StateVectors(X[:, PERM].T), log_weight=np.log(w),
                                   timestamp=T0)
    hyps = [SingleHypothesis(pred, MissedDetection(timestamp=T0))]
    hyps += [SingleHypothesis(pred, Detection(np.array([[b], [r]]), timestamp=T0,
                                              measurement_model=mm)) for r, b in Z]
    hyps = MultipleHypothesis(hyps)
    up = SMCPHDUpdater(measurement_model=mm, prob_detect=pd, clutter_intensity=kappa)
    # SMCPHDUpdater.update's own weights: logsumexp over the hypotheses of
    # get_log_weights_per_hypothesis (update() without a resampler returns the
    # *predicted* weights in Stone Soup 1.9.1: it only writes them in its resampling branch)
    per_hyp = up.get_log_weights_per_hypothesis(hyps)
    post = np.exp(logsumexp(per_hyp, axis=1))
    zmass = np.exp(logsumexp(per_hyp[:, 1:], axis=0)) if len(Z) else np.zeros(0)
    return post, zmass


def _predicted_particles(seed=0):
    """Three tight clouds (one straddling the bearing cut at +-pi), a broad birth-like set,
    weights of mass about 3."""
    rng = np.random.default_rng(seed)
    centres = np.array([[1500.0, 1000.0], [-2000.0, 1.0], [1200.0, 2600.0]])
    clouds = [np.column_stack([c + rng.normal(0, 25.0, (300, 2)), rng.normal(0, 3, (300, 2))])
              for c in centres]
    broad = np.column_stack([rng.uniform(-3000, 3000, (100, 2)), rng.normal(0, 5, (100, 2))])
    X = np.vstack(clouds + [broad])
    w = np.concatenate([rng.uniform(0.5, 1.5, 900) / 900 * 3, np.full(100, 0.05 / 100)])
    return X, w


def _scan(X_true, seed=1, n_clutter=10):
    rng = np.random.default_rng(seed)
    h = range_bearing(X_true) + rng.normal(0, 1, (len(X_true), 2)) * [SR, SB]
    h[:, 1] = (h[:, 1] + np.pi) % (2 * np.pi) - np.pi
    c = np.column_stack([rng.uniform(500, 5000, n_clutter), rng.uniform(-np.pi, np.pi, n_clutter)])
    return np.vstack([h, c])


# --------------------------------------------------------------------------
# (a) deterministic: same predicted particles and weights into both updaters
# --------------------------------------------------------------------------
def test_update_matches_stonesoup_ungated():
    X, w = _predicted_particles()
    Z = _scan(np.array([[1510.0, 990.0, 0, 0], [-1990.0, -1.0, 0, 0], [1200, 2610, 0, 0]]))
    ours = smc_phd_update(X, w, Z, R, PD, KAPPA, gate=np.inf)
    ref, ref_mass = _ss_update(X, w, Z)
    np.testing.assert_allclose(ours.w, ref, rtol=1e-9, atol=0)
    assert abs(ours.cardinality - ref.sum()) < 1e-9
    np.testing.assert_allclose(ours.measurement_mass, ref_mass, rtol=1e-9, atol=1e-300)
    # N_hat = (1 - P_D) sum w + sum_z C(z) / (kappa(z) + C(z)); the targets' measurements
    # (the first three) are explained by the clouds
    assert ours.cardinality == pytest.approx((1 - PD) * w.sum() + ours.measurement_mass.sum(),
                                             rel=1e-12)
    assert np.all(ours.measurement_mass[:3] > 0.9)


def test_update_matches_stonesoup_default_gate():
    # the gate (d^2 > 60) drops likelihood terms below exp(-30) ~ 1e-13 of the peak: each
    # weight keeps at least its missed-detection part w (1 - P_D), so the relative error of a
    # weight is at most P_D g_max exp(-30) / (kappa (1 - P_D)) per measurement (~1e-9 here)
    X, w = _predicted_particles(3)
    Z = _scan(np.array([[1510.0, 990.0, 0, 0], [-1990.0, -1.0, 0, 0]]), seed=4)
    ours = smc_phd_update(X, w, Z, R, PD, KAPPA)
    ref, _ = _ss_update(X, w, Z)
    gmax = 1.0 / (2 * np.pi * SR * SB)
    bound = len(Z) * PD * gmax * math.exp(-30.0) / (KAPPA * (1 - PD))
    assert np.max(np.abs(ours.w / ref - 1)) <= bound
    assert abs(ours.cardinality - ref.sum()) < 1e-9


def test_update_per_measurement_clutter_and_sensor_offset():
    # kappa given per measurement; sensor away from the origin (Stone Soup translation_offset)
    X, w = _predicted_particles(5)
    sensor = np.array([100.0, -200.0])
    Xs = X.copy()
    Xs[:, :2] -= sensor
    Z = _scan(np.array([[1410.0, 1190.0, 0, 0]]), seed=6, n_clutter=4)
    kap = KAPPA * np.linspace(0.5, 2.0, len(Z))
    ours = smc_phd_update(X, w, Z, R, PD, kap, sensor=sensor, gate=np.inf)
    shifted = smc_phd_update(Xs, w, Z, R, PD, kap, gate=np.inf)
    np.testing.assert_allclose(ours.w, shifted.w, rtol=1e-9)
    ref = w * (1 - PD)
    for j, z in enumerate(Z):  # the closed form, one measurement at a time
        g = np.exp(loglik_range_bearing(X, z, R, sensor))
        ref = ref + PD * g * w / (kap[j] + np.sum(PD * g * w))
    np.testing.assert_allclose(ours.w, ref, rtol=1e-9)


def test_update_empty_scan_matches_stonesoup():
    X, w = _predicted_particles(7)
    ours = smc_phd_update(X, w, np.zeros((0, 2)), R, PD, KAPPA)
    ref, _ = _ss_update(X, w, np.zeros((0, 2)))
    np.testing.assert_allclose(ours.w, ref, rtol=1e-12)
    np.testing.assert_allclose(ours.w, w * (1 - PD), rtol=1e-15)
    assert ours.measurement_mass.shape == (0,)
    assert ours.cardinality == pytest.approx((1 - PD) * w.sum(), rel=1e-12)


def test_stonesoup_as_shipped_likelihood_is_random():
    """Why the cross-checks use NoiselessLikelihood: SMCPHDUpdater passes noise=True."""
    X, w = _predicted_particles(8)
    Z = _scan(np.array([[1510.0, 990.0, 0, 0]]), seed=9, n_clutter=2)
    np.random.seed(0)
    a, _ = _ss_update(X, w, Z, mm=_mm(CartesianToBearingRange))
    b, _ = _ss_update(X, w, Z, mm=_mm(CartesianToBearingRange))
    assert np.max(np.abs(a / b - 1)) > 1e-3


# --------------------------------------------------------------------------
# (b) statistical: multi-scan runs on the same scans, independent draws
# --------------------------------------------------------------------------
Q_PSD = 0.5
DEATH = 0.01
BIRTH_MEAN = np.array([1800.0, 1800.0, 0.0, 0.0])
BIRTH_COV = np.diag([1000.0**2, 1000.0**2, 10.0**2, 10.0**2])
X0 = np.array([[1500.0, 1000.0, 5.0, 8.0], [1000.0, 2500.0, 8.0, -3.0],
               [3000.0, 2000.0, -6.0, 4.0]])


def _run_scans(K=8, seed=11):
    rng = np.random.default_rng(seed)
    F = cv_transition(1.0)
    Lq = np.linalg.cholesky(cv_process_noise(1.0, Q_PSD, kind="cwna"))
    x = X0.copy()
    zs, off = [], [0]
    for _ in range(K):
        x = x @ F.T + rng.standard_normal(x.shape) @ Lq.T
        det = rng.random(3) < PD
        h = range_bearing(x[det]) + rng.standard_normal((det.sum(), 2)) * [SR, SB]
        nc = rng.poisson(10)
        c = np.column_stack([rng.uniform(500, 5000, nc), rng.uniform(0, np.pi / 2, nc)])
        zs.append(np.vstack([h, c]))
        off.append(off[-1] + len(zs[-1]))
    return np.vstack(zs), np.array(off)


def _model(n_birth):
    return smc_phd_model(cv_transition(1.0), cv_process_noise(1.0, Q_PSD, kind="cwna"), R,
                         pd=PD, ps=math.exp(-DEATH), clutter_intensity=KAPPA,
                         birth_mean=BIRTH_MEAN, birth_cov=BIRTH_COV, n_birth=n_birth,
                         birth_rate=0.05)


def _init(n_per):
    rng = np.random.default_rng(12)
    X = np.vstack([x + rng.standard_normal((n_per, 4)) * [20, 20, 2, 2] for x in X0])
    return X, np.full(len(X), 1.0 / n_per)


def _stonesoup_run(z, off, X, w, seed):
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(Q_PSD), ConstantVelocity(Q_PSD)])
    mm = _mm()
    sampler = ParticleSampler(distribution_func=np.random.multivariate_normal,
                              params={"mean": BIRTH_MEAN[PERM],
                                      "cov": BIRTH_COV[np.ix_(PERM, PERM)]}, ndim_state=4)
    pred = SMCPHDPredictor(transition_model=tm, death_probability=DEATH, birth_probability=0.1,
                           birth_rate=0.05, birth_sampler=sampler,
                           birth_func_num_samples_field="size", birth_scheme="expansion")
    up = SMCPHDUpdater(measurement_model=mm, resampler=SystematicResampler(), prob_detect=PD,
                       clutter_intensity=KAPPA, num_samples=len(X))
    hyp = SimpleHypothesiser(pred, check_timestamp=False)
    np.random.seed(seed)
    state = ParticleState(StateVectors(X[:, PERM].T), log_weight=np.log(w), timestamp=T0)
    card = []
    for k in range(len(off) - 1):
        ts = T0 + datetime.timedelta(seconds=k + 1)
        dets = [Detection(np.array([[b], [r]]), timestamp=ts, measurement_model=mm)
                for r, b in z[off[k]:off[k + 1]]]
        state = up.update(hyp.hypothesise(state, dets, ts))
        card.append(math.exp(logsumexp(state.log_weight)))
    return np.array(card)


def test_mean_cardinality_matches_stonesoup():
    """Same scans, same initial PHD, 300 particles per target, 90 births per scan, 8 scans.

    Each filter's run-mean cardinality varies between runs only through its particle draws;
    the tolerance is 4 standard errors of the difference of the two averages, estimated from
    the run-to-run spread (a systematic difference -- e.g. a wrong survival or birth weight,
    a missed-detection term, resampling that loses mass -- shifts every run the same way)."""
    z, off = _run_scans()
    X, w = _init(300)
    mdl = _model(90)
    n_ours, n_ss = 200, 16
    ours = np.array([smc_phd_filter(X, w, z, off, mdl, np.random.default_rng([21, i]),
                                    n_out=len(X)).cardinality for i in range(n_ours)])
    ss = np.array([_stonesoup_run(z, off, X, w, [22, i]) for i in range(n_ss)])
    a, b = ours.mean(axis=1), ss.mean(axis=1)
    se = math.sqrt(a.var(ddof=1) / n_ours + b.var(ddof=1) / n_ss)
    diff = a.mean() - b.mean()
    assert abs(diff) < 4 * se, (a.mean(), b.mean(), se)
    assert abs(diff) < 0.1  # issue #8's agreement target
    assert 2.5 < a.mean() < 3.5
    # per scan too (Bonferroni over the scans: 4.5 standard errors)
    se_k = np.sqrt(ours.var(axis=0, ddof=1) / n_ours + ss.var(axis=0, ddof=1) / n_ss)
    assert np.all(np.abs(ours.mean(axis=0) - ss.mean(axis=0)) < 4.5 * se_k + 1e-12)


# --------------------------------------------------------------------------
# trackcore API: step vs run, mass, m = 0, bad input
# --------------------------------------------------------------------------
def test_step_and_filter_identical_and_mass_preserving():
    z, off = _run_scans(K=5, seed=13)
    X, w = _init(200)
    mdl = _model(60)
    run = smc_phd_filter(X, w, z, off, mdl, np.random.default_rng(3), n_out=600)
    rng = np.random.default_rng(3)
    P, W = X, w
    for k in range(5):
        st = smc_phd_step(P, W, z[off[k]:off[k + 1]], mdl, rng, n_out=600)
        P, W = st.particles, st.w
        assert st.cardinality == run.cardinality[k]
        assert W.sum() == pytest.approx(st.cardinality, rel=1e-12)
        assert P.shape == (600, 4) and np.all(W == W[0])
    np.testing.assert_array_equal(P, run.particles)
    np.testing.assert_array_equal(W, run.w)


def test_empty_scans_and_empty_prior():
    mdl = _model(50)
    X, w = _init(100)
    # empty scan: weights (ps w + births) (1 - pd)
    st = smc_phd_step(X, w, np.zeros((0, 2)), mdl, np.random.default_rng(0))
    assert st.cardinality == pytest.approx((math.exp(-DEATH) * 3 + 0.05) * (1 - PD), rel=1e-12)
    assert st.particles.shape == (300, 4) and st.measurement_mass.shape == (0,)
    # a filter that starts empty: births only
    st0 = smc_phd_step(np.zeros((0, 4)), np.zeros(0), np.zeros((0, 2)), mdl,
                       np.random.default_rng(0), n_out=100)
    assert st0.cardinality == pytest.approx(0.05 * (1 - PD), rel=1e-12)
    # whole run of empty scans, and K = 0
    run = smc_phd_filter(X, w, np.zeros((0, 2)), np.zeros(4, dtype=np.int64), mdl,
                         np.random.default_rng(0))
    assert run.cardinality.shape == (3,) and np.all(np.diff(run.cardinality) < 0)
    run0 = smc_phd_filter(X, w, np.zeros((0, 2)), np.zeros(1, dtype=np.int64), mdl,
                          np.random.default_rng(0))
    assert run0.cardinality.shape == (0,)
    # pd = 1, no measurement near anything, no births: every weight 0, no NaN
    m1 = smc_phd_model(cv_transition(1.0), cv_process_noise(1.0, Q_PSD, kind="cwna"), R, pd=1.0,
                       ps=1.0, clutter_intensity=KAPPA, birth_mean=BIRTH_MEAN,
                       birth_cov=BIRTH_COV, n_birth=0, birth_rate=0.0)
    st1 = smc_phd_step(X, w, np.zeros((0, 2)), m1, np.random.default_rng(0))
    assert st1.cardinality == 0.0 and np.all(st1.w == 0) and np.all(np.isfinite(st1.particles))


def test_seed_determinism():
    z, off = _run_scans(K=3, seed=14)
    X, w = _init(100)
    mdl = _model(30)
    a = smc_phd_filter(X, w, z, off, mdl, np.random.default_rng(9))
    b = smc_phd_filter(X, w, z, off, mdl, np.random.default_rng(9))
    np.testing.assert_array_equal(a.cardinality, b.cardinality)
    np.testing.assert_array_equal(a.particles, b.particles)


def _kw(**over):
    kw = dict(F=cv_transition(1.0), Q=cv_process_noise(1.0, Q_PSD, kind="cwna"), R=R, pd=PD,
              ps=0.99, clutter_intensity=KAPPA, birth_mean=BIRTH_MEAN, birth_cov=BIRTH_COV,
              n_birth=10, birth_rate=0.05)
    kw.update(over)
    return kw


@pytest.mark.parametrize("over, exc, name", [
    (dict(F=np.eye(3)), ValueError, "Q"),
    (dict(Q=-np.eye(4)), ValueError, "Q"),
    (dict(R=np.array([[100.0, 1.0], [1.0, 1e-4]])), ValueError, "R"),
    (dict(R=np.diag([100.0, 0.0])), ValueError, "R"),
    (dict(R=np.eye(3)), ValueError, "R"),
    (dict(pd=0.0), ValueError, "pd"),
    (dict(pd=1.2), ValueError, "pd"),
    (dict(ps=-0.1), ValueError, "ps"),
    (dict(ps=np.nan), ValueError, "ps"),
    (dict(clutter_intensity=0.0), ValueError, "clutter_intensity"),
    (dict(clutter_intensity="a"), TypeError, "clutter_intensity"),
    (dict(birth_mean=np.zeros(3)), ValueError, "birth_mean"),
    (dict(birth_cov=np.eye(3)), ValueError, "birth_cov"),
    (dict(birth_cov=np.diag([1.0, 1, 1, -1])), ValueError, "birth_cov"),
    (dict(n_birth=-1), ValueError, "n_birth"),
    (dict(n_birth=2.5), TypeError, "n_birth"),
    (dict(n_birth=0), ValueError, "n_birth"),
    (dict(birth_rate=-1.0), ValueError, "birth_rate"),
    (dict(sensor=(0.0,)), ValueError, "sensor"),
    (dict(gate=0.0), ValueError, "gate"),
])
def test_model_bad_input(over, exc, name):
    kw = _kw(**over)
    F, Q, R_ = kw.pop("F"), kw.pop("Q"), kw.pop("R")
    with pytest.raises(exc, match=name):
        smc_phd_model(F, Q, R_, **kw)


def test_update_bad_input():
    X, w = _predicted_particles()
    Z = np.array([[1000.0, 0.5]])
    with pytest.raises(ValueError, match="particles"):
        smc_phd_update(X[:, :1], w, Z, R, PD, KAPPA)
    with pytest.raises(ValueError, match="w"):
        smc_phd_update(X, w[:-1], Z, R, PD, KAPPA)
    with pytest.raises(ValueError, match="w"):
        smc_phd_update(X, -w, Z, R, PD, KAPPA)
    w_nan = w.copy()
    w_nan[0] = np.nan
    with pytest.raises(ValueError, match="w"):
        smc_phd_update(X, w_nan, Z, R, PD, KAPPA)
    with pytest.raises(ValueError, match="z"):
        smc_phd_update(X, w, np.array([[1.0, np.nan]]), R, PD, KAPPA)
    with pytest.raises(ValueError, match="z"):
        smc_phd_update(X, w, np.zeros((2, 3)), R, PD, KAPPA)
    with pytest.raises(ValueError, match="clutter_intensity"):
        smc_phd_update(X, w, Z, R, PD, np.array([KAPPA, KAPPA]))
    with pytest.raises(ValueError, match="clutter_intensity"):
        smc_phd_update(X, w, Z, R, PD, -1.0)
    with pytest.raises(ValueError, match="pd"):
        smc_phd_update(X, w, Z, R, 1.5, KAPPA)
    with pytest.raises(ValueError, match="R"):
        smc_phd_update(X, w, Z, np.eye(3), PD, KAPPA)
    with pytest.raises(TypeError, match="particles"):
        smc_phd_update("x", w, Z, R, PD, KAPPA)


def test_step_and_filter_bad_input():
    mdl = _model(10)
    X, w = _init(10)
    Z = np.array([[1000.0, 0.5]])
    with pytest.raises(TypeError, match="model"):
        smc_phd_step(X, w, Z, {"pd": 0.9}, np.random.default_rng())
    with pytest.raises(TypeError, match="rng"):
        smc_phd_step(X, w, Z, mdl, 5)
    with pytest.raises(ValueError, match="particles"):
        smc_phd_step(X[:, :3], w, Z, mdl, np.random.default_rng())
    with pytest.raises(ValueError, match="n_out"):
        smc_phd_step(X, w, Z, mdl, np.random.default_rng(), n_out=0)
    with pytest.raises(ValueError, match="n_out"):
        smc_phd_step(np.zeros((0, 4)), np.zeros(0), Z, mdl, np.random.default_rng())
    m0 = mdl._replace(n_birth=0, birth_rate=0.0)
    assert isinstance(m0, SmcPhdModel)
    with pytest.raises(ValueError, match="n_birth"):
        smc_phd_step(np.zeros((0, 4)), np.zeros(0), Z, m0, np.random.default_rng(), n_out=5)
    with pytest.raises(ValueError, match="offsets"):
        smc_phd_filter(X, w, Z, np.array([0, 2]), mdl, np.random.default_rng())
    with pytest.raises(ValueError, match="offsets"):
        smc_phd_filter(X, w, Z, np.array([0.0, 1.0]), mdl, np.random.default_rng())
    with pytest.raises(ValueError, match="offsets"):
        smc_phd_filter(X, w, np.zeros((2, 2)), np.array([0, 2, 1, 2]), mdl,
                       np.random.default_rng())


# --------------------------------------------------------------------------
# property: N_hat = (1 - P_D) sum w + sum_z C(z) / (kappa(z) + C(z)), each mass in [0, 1]
# --------------------------------------------------------------------------
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(0, 12), pd=st.floats(0.05, 1.0),
       log_kappa=st.floats(-12.0, 2.0), gate=st.sampled_from([60.0, np.inf]))
def test_update_mass_identity(seed, m, pd, log_kappa, gate):
    rng = np.random.default_rng(seed)
    N = int(rng.integers(1, 400))
    X = np.column_stack([rng.uniform(-3000, 3000, (N, 2)), rng.normal(0, 5, (N, 2))])
    w = rng.uniform(0, 2, N) / N
    Z = np.column_stack([rng.uniform(10, 4500, m), rng.uniform(-np.pi, np.pi, m)])
    out = smc_phd_update(X, w, Z, R, pd, math.exp(log_kappa), gate=gate)
    assert np.all(np.isfinite(out.w)) and np.all(out.w >= (1 - pd) * w * (1 - 1e-15))
    assert np.all((out.measurement_mass >= 0) & (out.measurement_mass <= 1))
    assert out.cardinality == pytest.approx((1 - pd) * w.sum() + out.measurement_mass.sum(),
                                            rel=1e-10, abs=1e-300)
    assert out.cardinality == pytest.approx(out.w.sum(), rel=1e-12)
