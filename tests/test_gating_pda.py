"""Tests for trackcore.association.gating and trackcore.association.pda."""
import math

import numba as nb
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra import numpy as hnp
from scipy import stats

from trackcore.association.gating import (gate_probability, gate_threshold, gate_volume,
                                          mahalanobis_gate, unit_ball_volume)
from trackcore.association.pda import (pda_betas, pda_log_likelihood, pda_update,
                                       pda_update_kernel)
from trackcore.filters.kalman import ekf_update, kf_update


def random_spd(rng, d, scale=1.0):
    A = rng.normal(size=(d, d))
    return scale * (A @ A.T + d * np.eye(d))


# ---------------------------------------------------------------- gating
@pytest.mark.parametrize("d", [1, 2, 3, 4, 6])
@pytest.mark.parametrize("pg", [0.5, 0.9, 0.95, 0.99, 0.9997])
def test_gate_threshold_matches_scipy(pg, d):
    g = gate_threshold(pg, d)
    assert g == pytest.approx(stats.chi2.ppf(pg, d), rel=1e-12)
    assert gate_probability(g, d) == pytest.approx(pg, rel=1e-10)


def test_gate_threshold_known_values_and_bad_input():
    assert gate_threshold(0.99, 2) == pytest.approx(9.2103, abs=1e-4)
    assert gate_threshold(1.0, 2) == math.inf
    assert gate_probability(math.inf, 3) == 1.0
    for bad in (0.0, -0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="pg"):
            gate_threshold(bad, 2)
    with pytest.raises(ValueError, match="d"):
        gate_threshold(0.9, 0)
    with pytest.raises(TypeError, match="d"):
        gate_threshold(0.9, 2.5)


def test_unit_ball_and_gate_volume():
    assert unit_ball_volume(1) == pytest.approx(2.0)
    assert unit_ball_volume(2) == pytest.approx(math.pi)
    assert unit_ball_volume(3) == pytest.approx(4 * math.pi / 3)
    S = np.array([[4.0, 1.0], [1.0, 2.0]])
    assert gate_volume(9.0, S) == pytest.approx(math.pi * 9.0 * math.sqrt(7.0), rel=1e-12)
    S3 = random_spd(np.random.default_rng(0), 3)
    assert gate_volume(2.0, S3) == pytest.approx(
        4 * math.pi / 3 * 2.0 ** 1.5 * math.sqrt(np.linalg.det(S3)), rel=1e-12)
    with pytest.raises(ValueError, match="no finite gate volume"):  # pg = 1: no gate (F2)
        gate_volume(math.inf, S)
    with pytest.raises(ValueError, match="S"):
        gate_volume(1.0, np.diag([1.0, -1.0]))
    with pytest.raises(ValueError, match="gamma"):
        gate_volume(-1.0, S)


def test_gate_volume_monte_carlo():
    """Fraction of a bounding box inside the gate ellipse times the box area."""
    S = np.array([[4.0, 1.5], [1.5, 2.0]])
    gamma = 5.0
    half = np.sqrt(gamma * np.diag(S)) * 1.01
    u = np.random.default_rng(1).uniform(-1, 1, size=(200_000, 2)) * half
    mask, _ = mahalanobis_gate(u, [0.0, 0.0], S, gamma)
    est = mask.mean() * np.prod(2 * half)
    assert est == pytest.approx(gate_volume(gamma, S), rel=0.01)


def test_mahalanobis_gate_matches_numpy():
    rng = np.random.default_rng(2)
    S = random_spd(rng, 3)
    zp = rng.normal(size=3)
    z = zp + rng.normal(size=(50, 3)) * 3
    mask, d2 = mahalanobis_gate(z, zp, S, 11.3)
    nu = z - zp
    ref = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(S), nu)
    np.testing.assert_allclose(d2, ref, rtol=1e-12)
    np.testing.assert_array_equal(mask, ref <= 11.3)
    assert mask.dtype == np.bool_
    # gate probability: target-originated innovations fall in with probability pg
    L = np.linalg.cholesky(S)
    nu = rng.normal(size=(100_000, 3)) @ L.T
    mask, _ = mahalanobis_gate(nu, np.zeros(3), S, gate_threshold(0.95, 3))
    assert mask.mean() == pytest.approx(0.95, abs=0.004)


def test_mahalanobis_gate_angle_wrap_and_empty():
    S = np.diag([1.0, 0.01])
    zp = np.array([100.0, math.pi - 0.01])
    z = np.array([[100.0, -math.pi + 0.01]])  # 0.02 rad away across the cut
    mask, d2 = mahalanobis_gate(z, zp, S, 9.21, angle_index=1)
    assert d2[0] == pytest.approx(0.02 ** 2 / 0.01, rel=1e-9) and mask[0]
    mask, d2 = mahalanobis_gate(z, zp, S, 9.21)
    assert not mask[0]
    mask, d2 = mahalanobis_gate(np.zeros((0, 2)), zp, S, 9.21)
    assert mask.shape == (0,) and d2.shape == (0,)
    mask, d2 = mahalanobis_gate([], zp, S, 9.21)
    assert mask.shape == (0,)


def test_mahalanobis_gate_bad_input():
    S = np.eye(2)
    with pytest.raises(ValueError, match="S"):
        mahalanobis_gate([[0.0, 0.0]], [0.0, 0.0], np.zeros((2, 2)), 1.0)
    with pytest.raises(ValueError, match="z"):
        mahalanobis_gate([[0.0, 0.0, 0.0]], [0.0, 0.0], S, 1.0)
    with pytest.raises(ValueError, match="z"):
        mahalanobis_gate([[np.nan, 0.0]], [0.0, 0.0], S, 1.0)
    with pytest.raises(ValueError, match="gamma"):
        mahalanobis_gate([[0.0, 0.0]], [0.0, 0.0], S, -1.0)
    with pytest.raises(ValueError, match="angle_index"):
        mahalanobis_gate([[0.0, 0.0]], [0.0, 0.0], S, 1.0, angle_index=2)


# ---------------------------------------------------------------- betas
def _betas_reference(lik, pd, pg, lam):
    num = np.concatenate([[lam * (1 - pd * pg)], pd * np.asarray(lik)])
    return num / num.sum()


@settings(max_examples=80, deadline=None, derandomize=True)
@given(hnp.arrays(np.float64, st.integers(0, 12), elements=st.floats(1e-8, 10.0)),
       st.floats(0.0, 1.0), st.floats(0.5, 1.0), st.floats(1e-6, 10.0))
def test_betas_sum_to_one_and_match_formula(lik, pd, pg, lam):
    beta0, betas = pda_betas(lik, pd, pg, lam)
    assert betas.shape == lik.shape
    assert beta0 + betas.sum() == pytest.approx(1.0, abs=1e-12)
    assert beta0 >= 0 and np.all(betas >= 0)
    ref = _betas_reference(lik, pd, pg, lam)
    np.testing.assert_allclose(np.concatenate([[beta0], betas]), ref, rtol=1e-10, atol=1e-300)
    b0l, bl = pda_betas(pd=pd, pg=pg, clutter_density=lam, log_lik=np.log(lik))
    assert b0l == pytest.approx(beta0, rel=1e-10, abs=1e-300)
    np.testing.assert_allclose(bl, betas, rtol=1e-10, atol=1e-300)


def test_betas_empty_scan_nonparametric_and_special_cases():
    b0, b = pda_betas(np.zeros(0), 0.9, 0.99, 1e-4)
    assert b0 == 1.0 and b.shape == (0,)
    b0, b = pda_betas(np.zeros(0), 0.9, 0.99, mode="nonparametric", volume=3.0)
    assert b0 == 1.0
    lik = np.array([0.02, 0.05, 0.001])
    V = 40.0
    b0n, bn = pda_betas(lik, 0.8, 0.99, mode="nonparametric", volume=V)
    b0p, bp = pda_betas(lik, 0.8, 0.99, 3 / V)
    assert b0n == pytest.approx(b0p, rel=1e-12)
    np.testing.assert_allclose(bn, bp, rtol=1e-12)
    # no clutter, P_D = P_G = 1: beta0 = 0 and betas are the normalised likelihoods
    b0, b = pda_betas(lik, 1.0, 1.0, 0.0)
    assert b0 == 0.0
    np.testing.assert_allclose(b, lik / lik.sum(), rtol=1e-12)
    # P_D = 0: every measurement is clutter
    b0, b = pda_betas(lik, 0.0, 0.99, 1e-3)
    assert b0 == 1.0 and np.all(b == 0)


def test_betas_log_space_underflow():
    # likelihoods far below the double range: linear space would give 0/0
    ll = np.array([-2000.0, -2001.0, -2003.0])
    b0, b = pda_betas(pd=1.0, pg=1.0, clutter_density=0.0, log_lik=ll)
    w = np.exp(ll - ll.max())
    np.testing.assert_allclose(b, w / w.sum(), rtol=1e-12)
    assert b0 == 0.0
    b0, b = pda_betas(pd=0.9, pg=0.99, clutter_density=1e-6, log_lik=ll)
    assert b0 == 1.0 and np.all(np.isfinite(b)) and np.all(b >= 0) and b.max() < 1e-300
    # clutter density comparable with the likelihoods in log space
    b0, b = pda_betas(pd=0.5, pg=1.0, log_clutter_density=-2000.0, log_lik=ll)
    num = np.exp(np.array([-2000.0 + math.log(0.5)] + list(ll + math.log(0.5))) + 2000)
    np.testing.assert_allclose(np.concatenate([[b0], b]), num / num.sum(), rtol=1e-12)
    assert pda_log_likelihood(pd=0.5, pg=1.0, log_clutter_density=-2000.0,
                              log_lik=ll) == pytest.approx(-2000 + math.log(num.sum()), rel=1e-14)
    # all hypotheses impossible
    with pytest.raises(ValueError, match="zero probability"):
        pda_betas(pd=1.0, pg=1.0, clutter_density=0.0, log_lik=[-np.inf, -np.inf])


def test_betas_bad_input():
    with pytest.raises(ValueError, match="pd"):
        pda_betas([0.1], 1.2, 0.99, 1.0)
    with pytest.raises(ValueError, match="pg"):
        pda_betas([0.1], 0.9, 0.0, 1.0)
    with pytest.raises(ValueError, match="clutter_density"):
        pda_betas([0.1], 0.9, 0.99, -1.0)
    with pytest.raises(ValueError, match="clutter_density"):
        pda_betas([0.1], 0.9, 0.99)
    with pytest.raises(ValueError, match="lik"):
        pda_betas([-0.1], 0.9, 0.99, 1.0)
    with pytest.raises(ValueError, match="lik"):
        pda_betas([np.nan], 0.9, 0.99, 1.0)
    with pytest.raises(ValueError, match="log_lik"):
        pda_betas(pd=0.9, pg=0.99, clutter_density=1.0, log_lik=[np.nan])
    with pytest.raises(ValueError, match="lik"):
        pda_betas([0.1], 0.9, 0.99, 1.0, log_lik=[0.0])
    with pytest.raises(ValueError, match="volume"):
        pda_betas([0.1], 0.9, 0.99, mode="nonparametric")
    with pytest.raises(ValueError, match="mode"):
        pda_betas([0.1], 0.9, 0.99, 1.0, mode="bogus")


def test_pda_log_likelihood():
    lik = np.array([0.02, 0.05])
    assert pda_log_likelihood(lik, 0.8, 0.99, 0.01) == pytest.approx(
        math.log(0.01 * (1 - 0.8 * 0.99) + 0.8 * 0.07), rel=1e-14)
    assert pda_log_likelihood(np.zeros(0), 0.8, 0.99, 0.01) == pytest.approx(
        math.log(0.01 * (1 - 0.8 * 0.99)), rel=1e-14)


# ---------------------------------------------------------------- update
def _problem(rng, n=4, d=2, m=3):
    x = rng.normal(size=n)
    P = random_spd(rng, n)
    H = rng.normal(size=(d, n))
    R = random_spd(rng, d, 0.5)
    zp = H @ x
    S = H @ P @ H.T + R
    z = zp + rng.normal(size=(m, d)) @ np.linalg.cholesky(S).T
    return x, P, H, R, zp, z


def test_single_measurement_pd1_no_clutter_equals_kf_update():
    rng = np.random.default_rng(3)
    x, P, H, R, zp, z = _problem(rng, m=1)
    lik = stats.multivariate_normal(zp, H @ P @ H.T + R).pdf(z[0])
    b0, b = pda_betas([lik], 1.0, 1.0, 0.0)
    assert b0 == 0.0 and b[0] == 1.0
    r = pda_update(x, P, z, zp, H, R, b, b0)
    k = kf_update(x, P, z[0], H, R)
    np.testing.assert_allclose(r.x, k.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.P, k.P, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.S, k.S, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.K, k.K, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.innovation_combined, k.innovation, rtol=0, atol=1e-12)


def test_single_angular_measurement_equals_ekf_update():
    x = np.array([-100.0, 1.0, 1.0, 0.0])
    P = np.diag([4.0, 4.0, 1.0, 1.0])
    r = math.hypot(x[0], x[1])
    zp = np.array([r, math.atan2(x[1], x[0])])
    H = np.array([[x[0] / r, x[1] / r, 0, 0], [-x[1] / r ** 2, x[0] / r ** 2, 0, 0]])
    R = np.diag([1.0, 1e-4])
    z = np.array([[100.5, -math.pi + 0.005]])
    res = pda_update(x, P, z, zp, H, R, [1.0], 0.0, angle_index=1)
    k = ekf_update(x, P, z[0], zp, H, R, angle_index=1)
    np.testing.assert_allclose(res.x, k.x, atol=1e-12)
    np.testing.assert_allclose(res.P, k.P, atol=1e-12)
    assert abs(res.innovation_combined[1]) < 0.1


def test_empty_scan_returns_prediction():
    rng = np.random.default_rng(4)
    x, P, H, R, zp, _ = _problem(rng)
    r = pda_update(x, P, np.zeros((0, 2)), zp, H, R, np.zeros(0), 1.0)
    np.testing.assert_array_equal(r.x, x)
    np.testing.assert_array_equal(r.P, P)
    np.testing.assert_array_equal(r.innovation_combined, np.zeros(2))
    np.testing.assert_allclose(r.S, H @ P @ H.T + R, atol=1e-12)
    r = pda_update(x, P, [], zp, H, R, [], 1.0)
    np.testing.assert_array_equal(r.x, x)


@pytest.mark.parametrize("seed", range(6))
def test_pda_update_equals_moment_matched_mixture(seed):
    """PDA posterior = mean and covariance of beta0 N(x_pred, P_pred) + sum_j beta_j N(x_j, P_c)."""
    rng = np.random.default_rng(seed)
    m = 1 + seed % 4
    x, P, H, R, zp, z = _problem(rng, m=m)
    S = H @ P @ H.T + R
    lik = stats.multivariate_normal(zp, S).pdf(z).reshape(-1)
    b0, b = pda_betas(lik, 0.9, 0.99, 0.05)
    r = pda_update(x, P, z, zp, H, R, b, b0)
    K = P @ H.T @ np.linalg.inv(S)
    Pc = P - K @ S @ K.T
    means = [x] + [x + K @ (zj - zp) for zj in z]
    covs = [P] + [Pc] * m
    w = np.concatenate([[b0], b])
    mean = sum(wi * mi for wi, mi in zip(w, means))
    cov = sum(wi * (Ci + np.outer(mi - mean, mi - mean)) for wi, mi, Ci in zip(w, means, covs))
    np.testing.assert_allclose(r.x, mean, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(r.P, cov, rtol=1e-9, atol=1e-10)
    np.testing.assert_array_equal(r.P, r.P.T)
    assert np.linalg.eigvalsh(r.P).min() > 0


def test_pda_update_bad_input():
    rng = np.random.default_rng(5)
    x, P, H, R, zp, z = _problem(rng, m=2)
    b = np.array([0.3, 0.3])
    with pytest.raises(ValueError, match="beta0"):
        pda_update(x, P, z, zp, H, R, b, 0.3)
    with pytest.raises(ValueError, match="betas"):
        pda_update(x, P, z, zp, H, R, np.array([0.3]), 0.4)
    with pytest.raises(ValueError, match="betas"):
        pda_update(x, P, z, zp, H, R, np.array([-0.1, 0.7]), 0.4)
    with pytest.raises(ValueError, match="beta0"):
        pda_update(x, P, z, zp, H, R, np.array([0.0, 0.0]), 1.5)
    with pytest.raises(ValueError, match="H"):
        pda_update(x, P, z, zp, H[:, :3], R, b, 0.4)
    with pytest.raises(ValueError, match="P_pred"):
        pda_update(x, -P, z, zp, H, R, b, 0.4)
    with pytest.raises(ValueError, match="z"):
        pda_update(x, P, z[:, :1], zp, H, R, b, 0.4)
    with pytest.raises(ValueError, match="angle_index"):
        pda_update(x, P, z, zp, H, R, b, 0.4, angle_index=5)
    with pytest.raises(ValueError, match="positive definite"):
        pda_update(x, np.zeros((4, 4)), z, zp, H, np.zeros((2, 2)), b, 0.4)


@nb.njit(cache=False)
def _run_many(x, P, z, zp, H, R, b, b0, reps):
    n = x.shape[0]
    d = zp.shape[0]
    xo = np.empty(n)
    Po = np.empty((n, n))
    nu = np.empty(d)
    S = np.empty((d, d))
    K = np.empty((n, d))
    acc = 0.0
    for _ in range(reps):
        pda_update_kernel(x, P, z, zp, H, R, b, b0, -1, xo, Po, nu, S, K)
        acc += Po[0, 0]
    return xo, Po, acc


def test_pda_update_kernel_callable_from_numba():
    rng = np.random.default_rng(6)
    x, P, H, R, zp, z = _problem(rng, m=3)
    b0, b = pda_betas(np.array([0.1, 0.2, 0.05]), 0.9, 0.99, 0.1)
    xo, Po, acc = _run_many(x, P, z, zp, H, R, b, b0, 10)
    r = pda_update(x, P, z, zp, H, R, b, b0)
    # same kernel; only the compiler's floating-point contraction may differ
    np.testing.assert_allclose(xo, r.x, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(Po, r.P, rtol=1e-14, atol=1e-14)
    assert acc == pytest.approx(10 * r.P[0, 0])


def test_pda_matches_stonesoup():
    """Betas and the reduced posterior agree with Stone Soup's PDAHypothesiser + PDA
    association + Gaussian-mixture reduction (same model, clutter density, P_D, P_G)."""
    import datetime
    from stonesoup.dataassociator.probability import PDA
    from stonesoup.functions import gm_reduce_single
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    t0 = datetime.datetime(2026, 1, 1)
    t1 = t0 + datetime.timedelta(seconds=1)
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.5), ConstantVelocity(0.5)])
    R = np.diag([4.0, 2.0])
    mm = LinearGaussian(4, (0, 2), R)
    predictor, updater = KalmanPredictor(tm), KalmanUpdater(mm)
    track = Track([GaussianState(np.array([[0.0], [1.0], [0.0], [-1.0]]),
                                 np.diag([10.0, 1.0, 10.0, 1.0]), timestamp=t0)])
    zs = np.array([[1.5, -0.5], [3.0, -2.0], [-1.0, 0.5]])
    dets = {Detection(z.reshape(-1, 1), timestamp=t1, measurement_model=mm) for z in zs}
    hyp = PDAHypothesiser(predictor, updater, clutter_spatial_density=0.01, prob_detect=0.9,
                          prob_gate=0.99, include_all=True)
    hyps = PDA(hyp).associate({track}, dets, t1)[track]
    means, covs, ws, ss_beta = [], [], [], {}
    for h in hyps:
        if h:
            u = updater.update(h)
            means.append(u.state_vector)
            covs.append(u.covar)
            ss_beta[tuple(np.asarray(h.measurement.state_vector, float).ravel())] = float(h.probability)
        else:
            means.append(h.prediction.state_vector)
            covs.append(h.prediction.covar)
            ss_beta0 = float(h.probability)
        ws.append(float(h.probability))
    m, C = gm_reduce_single(StateVectors(means), np.stack(covs, axis=2), np.array(ws))
    perm = [0, 2, 1, 3]  # Stone Soup [x, vx, y, vy] -> trackcore [x, y, vx, vy]
    pred = predictor.predict(track.state, timestamp=t1)
    xp = np.asarray(pred.state_vector, float).ravel()[perm]
    Pp = np.asarray(pred.covar, float)[np.ix_(perm, perm)]
    H = np.eye(2, 4)
    S = H @ Pp @ H.T + R
    lik = stats.multivariate_normal(H @ xp, S).pdf(zs)
    b0, b = pda_betas(lik, 0.9, 0.99, 0.01)
    assert b0 == pytest.approx(ss_beta0, rel=1e-12)
    for zj, bj in zip(zs, b):
        assert bj == pytest.approx(ss_beta[tuple(zj)], rel=1e-12)
    r = pda_update(xp, Pp, zs, H @ xp, H, R, b, b0)
    np.testing.assert_allclose(r.x, np.asarray(m, float).ravel()[perm], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.P, np.asarray(C, float)[np.ix_(perm, perm)], rtol=0, atol=1e-12)


# ---------------------------------------------------------------- issue 17
def test_overflow_raises_and_empty_scan_likelihood():
    S = np.array([[2.0, 0.3], [0.3, 1.0]])
    with pytest.raises(ValueError, match="overflows"):
        gate_volume(1e300, np.eye(3))
    with pytest.raises(ValueError, match="gamma = inf"):  # no gate: no volume (F2)
        gate_volume(math.inf, S)
    with pytest.raises(ValueError, match="overflows"):
        mahalanobis_gate(np.array([[1e300, 0.0]]), np.zeros(2), S, 9.21)
    # nonparametric PDA: an empty scan has the likelihood of a miss, 1 - PD PG
    assert pda_log_likelihood(np.zeros(0), 0.9, 0.99, mode="nonparametric",
                              volume=5.0) == pytest.approx(math.log(1 - 0.9 * 0.99))
    x, P = np.zeros(4), np.eye(4)
    H = np.eye(2, 4)
    with pytest.raises(ValueError, match="overflows"):
        pda_update(x, P, np.array([[1e300, 0.0]]), np.zeros(2), H, np.eye(2), [0.5], 0.5)
