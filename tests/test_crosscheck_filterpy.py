"""Cross-checks of trackcore's KF and IMM against filterpy 2.0.

filterpy's ``KalmanFilter.update`` uses the Joseph form and ``K = P H^T S^{-1}``
with an explicit inverse; trackcore uses Cholesky solves, so agreement is to
rounding (checked at 1e-9).  ``IMMEstimator`` runs ``predict()`` (mixing +
mode-matched prediction) then ``update(z)`` (mode-matched updates, mode
probabilities, combination); one ``trackcore.filters.imm_step`` is exactly
that pair, and ``imm_filter_run`` is the loop over it.
"""
import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, KalmanFilter
from hypothesis import given, settings, strategies as st

from trackcore.filters import imm_filter_run, imm_step, kalman_filter_run, kf_predict, kf_update


def random_linear_problem(rng, n, m, K):
    A = rng.normal(size=(n, n))
    P0 = A @ A.T + np.eye(n)
    F = np.eye(n) + 0.2 * rng.normal(size=(n, n))
    F /= max(1.0, np.max(np.abs(np.linalg.eigvals(F))))  # keep runs bounded
    C = rng.normal(size=(n, n))
    Q = 0.1 * C @ C.T
    H = rng.normal(size=(m, n))
    B = rng.normal(size=(m, m))
    R = B @ B.T + 0.5 * np.eye(m)
    x0 = rng.normal(size=n)
    zs = rng.normal(size=(K, m)) * 3
    return x0, P0, F, Q, H, R, zs


def filterpy_kf(x0, P0, F, Q, H, R):
    n, m = len(x0), H.shape[0]
    kf = KalmanFilter(dim_x=n, dim_z=m)
    kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = x0.copy(), P0.copy(), F, Q, H, R
    return kf


def max_abs_diff_kf(x0, P0, F, Q, H, R, zs):
    """The appendix call pattern: same measurements through both libraries."""
    run = kalman_filter_run(zs, x0, P0, F, Q, H, R)
    kf = filterpy_kf(x0, P0, F, Q, H, R)
    worst = 0.0
    for k, z in enumerate(zs):
        kf.predict()
        kf.update(z)
        worst = max(worst, np.max(np.abs(run.xs[k] - kf.x)), np.max(np.abs(run.Ps[k] - kf.P)),
                    abs(run.loglik[k] - kf.log_likelihood),
                    abs(run.nis[k] - kf.mahalanobis**2))
    return worst


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("n,m", [(2, 1), (4, 2), (6, 3)])
def test_kf_run_equals_filterpy(seed, n, m):
    rng = np.random.default_rng(seed)
    assert max_abs_diff_kf(*random_linear_problem(rng, n, m, 60)) < 1e-9


@given(st.integers(0, 2**32 - 1), st.integers(1, 5), st.integers(1, 3))
@settings(max_examples=25, deadline=None)
def test_kf_step_equals_filterpy(seed, n, m):
    rng = np.random.default_rng(seed)
    x0, P0, F, Q, H, R, zs = random_linear_problem(rng, n, m, 5)
    kf = filterpy_kf(x0, P0, F, Q, H, R)
    x, P = x0, P0
    for z in zs:
        kf.predict()
        x, P = kf_predict(x, P, F, Q)
        np.testing.assert_allclose(x, kf.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(P, kf.P, rtol=0, atol=1e-9)
        kf.update(z)
        u = kf_update(x, P, z, H, R)
        x, P = u.x, u.P
        np.testing.assert_allclose(u.x, kf.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(u.P, kf.P, rtol=0, atol=1e-9)
        np.testing.assert_allclose(u.K, kf.K, rtol=0, atol=1e-9)
        np.testing.assert_allclose(u.S, kf.S, rtol=0, atol=1e-9)
        np.testing.assert_allclose(u.innovation, kf.y, rtol=0, atol=1e-9)
        assert abs(u.loglik - kf.log_likelihood) < 1e-9


def random_imm_problem(rng, r, K):
    n, m = 4, 2
    T = 1.0
    from trackcore.models import coordinated_turn_transition, cv_process_noise, position_matrix
    Fs = np.stack([coordinated_turn_transition(w, T) for w in rng.uniform(-0.3, 0.3, r)])
    Qs = np.stack([cv_process_noise(T, q) for q in rng.uniform(0.05, 3.0, r)])
    H = position_matrix()
    B = rng.normal(size=(m, m))
    R = B @ B.T + 2.0 * np.eye(m)
    PI = rng.dirichlet(np.ones(r), size=r) * 0.3 + 0.7 * np.eye(r)
    mu0 = rng.dirichlet(np.ones(r))
    xs0 = rng.normal(size=(r, n)) + [0.0, 0.0, 10.0, 0.0]
    A = rng.normal(size=(r, n, n))
    Ps0 = A @ A.transpose(0, 2, 1) + 5.0 * np.eye(n)
    zs = np.cumsum(rng.normal(size=(K, m)) * 3.0 + [10.0, 0.0], axis=0)
    return zs, xs0, Ps0, mu0, PI, Fs, Qs, H, R


def filterpy_imm(xs0, Ps0, mu0, PI, Fs, Qs, H, R):
    filters = []
    for j in range(len(mu0)):
        kf = KalmanFilter(dim_x=xs0.shape[1], dim_z=H.shape[0])
        kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = xs0[j].copy(), Ps0[j].copy(), Fs[j], Qs[j], H, R
        filters.append(kf)
    return IMMEstimator(filters, mu0.copy(), PI)


def max_abs_diff_imm(zs, xs0, Ps0, mu0, PI, Fs, Qs, H, R):
    """The appendix call pattern: one filterpy predict()+update(z) per trackcore scan."""
    run = imm_filter_run(zs, xs0, Ps0, mu0, PI, Fs, Qs, H, R)
    imm = filterpy_imm(xs0, Ps0, mu0, PI, Fs, Qs, H, R)
    worst = 0.0
    for k, z in enumerate(zs):
        imm.predict()
        imm.update(z)
        worst = max(worst, np.max(np.abs(run.x[k] - imm.x)), np.max(np.abs(run.P[k] - imm.P)),
                    np.max(np.abs(run.mu[k] - imm.mu)))
    return worst


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("r", [2, 3])
def test_imm_run_equals_filterpy(seed, r):
    rng = np.random.default_rng(100 + seed)
    assert max_abs_diff_imm(*random_imm_problem(rng, r, 80)) < 1e-9


@pytest.mark.parametrize("seed", range(4))
def test_imm_step_mode_matched_equals_filterpy(seed):
    rng = np.random.default_rng(200 + seed)
    zs, xs0, Ps0, mu0, PI, Fs, Qs, H, R = random_imm_problem(rng, 3, 20)
    imm = filterpy_imm(xs0, Ps0, mu0, PI, Fs, Qs, H, R)
    xs, Ps, mu = xs0, Ps0, mu0
    for z in zs:
        imm.predict()
        imm.update(z)
        s = imm_step(xs, Ps, mu, PI, Fs, Qs, z, H, R)
        xs, Ps, mu = s.xs, s.Ps, s.mu
        for j, f in enumerate(imm.filters):
            np.testing.assert_allclose(s.xs[j], f.x, rtol=0, atol=1e-9)
            np.testing.assert_allclose(s.Ps[j], f.P, rtol=0, atol=1e-9)
            assert abs(s.logliks[j] - f.log_likelihood) < 1e-9
        np.testing.assert_allclose(s.mu, imm.mu, rtol=0, atol=1e-12)
        np.testing.assert_allclose(s.x, imm.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(s.P, imm.P, rtol=0, atol=1e-9)
