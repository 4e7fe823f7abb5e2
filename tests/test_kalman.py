"""Tests for trackcore.filters.kalman."""
import math

import numpy as np
import pytest
import scipy.stats
from hypothesis import given, settings, strategies as st

from trackcore.core.logmath import cholesky_logpdf_kernel
from trackcore.filters.kalman import (GaussianEstimate, KalmanUpdate, ekf_update,
                                      kalman_filter_run, kf_predict, kf_predict_kernel,
                                      kf_update, kf_update_kernel)
from trackcore.models import (cv_process_noise, cv_transition, position_matrix, range_bearing,
                              range_bearing_jacobian)


def random_problem(rng, n, m):
    A = rng.normal(size=(n, n))
    P = A @ A.T + 0.1 * np.eye(n)
    B = rng.normal(size=(m, m))
    R = B @ B.T + 0.1 * np.eye(m)
    C = rng.normal(size=(n, n))
    Q = C @ C.T * 0.1
    F = np.eye(n) + 0.3 * rng.normal(size=(n, n))
    H = rng.normal(size=(m, n))
    x = rng.normal(size=n)
    z = rng.normal(size=m)
    return x, P, F, Q, H, R, z


def reference_update(x, P, z, H, R):
    """Textbook formulas with explicit inverses (independent of the kernels)."""
    nu = z - H @ x
    S = H @ P @ H.T + R
    Si = np.linalg.inv(S)
    K = P @ H.T @ Si
    IKH = np.eye(len(x)) - K @ H
    Pp = IKH @ P @ IKH.T + K @ R @ K.T
    return x + K @ nu, Pp, nu, S, K, nu @ Si @ nu, scipy.stats.multivariate_normal(
        np.zeros(len(z)), S).logpdf(nu)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("n,m", [(1, 1), (2, 1), (4, 2), (6, 3), (3, 5)])
def test_update_matches_reference(seed, n, m):
    rng = np.random.default_rng(seed)
    x, P, F, Q, H, R, z = random_problem(rng, n, m)
    u = kf_update(x, P, z, H, R)
    assert isinstance(u, KalmanUpdate)
    ref = reference_update(x, P, z, H, R)
    for got, want in zip(u, ref):
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-10)
    np.testing.assert_array_equal(u.P, u.P.T)
    assert np.all(np.linalg.eigvalsh(u.P) > 0)
    # the inlined log-likelihood equals the core kernel's
    L = np.linalg.cholesky(u.S)
    assert math.isclose(u.loglik, cholesky_logpdf_kernel(u.innovation, L), rel_tol=1e-12,
                        abs_tol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_predict(seed):
    rng = np.random.default_rng(seed)
    x, P, F, Q, H, R, z = random_problem(rng, 4, 2)
    e = kf_predict(x, P, F, Q)
    assert isinstance(e, GaussianEstimate)
    np.testing.assert_allclose(e.x, F @ x, rtol=1e-12)
    np.testing.assert_allclose(e.P, F @ P @ F.T + Q, rtol=1e-12, atol=1e-12)
    xo, Po = np.empty(4), np.empty((4, 4))
    kf_predict_kernel(x, P, F, Q, xo, Po)
    np.testing.assert_array_equal(xo, e.x)
    np.testing.assert_array_equal(Po, e.P)


def test_update_kernel_matches_wrapper():
    rng = np.random.default_rng(7)
    x, P, F, Q, H, R, z = random_problem(rng, 4, 2)
    u = kf_update(x, P, z, H, R)
    xo, Po, nu, S, K = np.empty(4), np.empty((4, 4)), np.empty(2), np.empty((2, 2)), np.empty((4, 2))
    nis, ll, ok = kf_update_kernel(x, P, z, H, R, xo, Po, nu, S, K)
    assert ok
    np.testing.assert_array_equal(xo, u.x)
    np.testing.assert_array_equal(Po, u.P)
    assert nis == u.nis and ll == u.loglik
    # singular S reported, not raised, by the kernel
    nis, ll, ok = kf_update_kernel(x, np.zeros((4, 4)), z, H, np.zeros((2, 2)), xo, Po, nu, S, K)
    assert not ok


def test_empty_scan_is_noop():
    x, P = np.ones(4), np.eye(4)
    u = kf_update(x, P, np.zeros(0), np.zeros((0, 4)), np.zeros((0, 0)))
    np.testing.assert_array_equal(u.x, x)
    np.testing.assert_array_equal(u.P, P)
    assert u.nis == 0.0 and u.loglik == 0.0 and u.K.shape == (4, 0)
    u = ekf_update(x, P, [], [], np.zeros((0, 4)), np.zeros((0, 0)))
    np.testing.assert_array_equal(u.x, x)


def test_nis_is_chi2_distributed():
    # consistency: NIS of a correctly modelled filter has mean m
    rng = np.random.default_rng(3)
    F, Q, H = cv_transition(1.0), cv_process_noise(1.0, 0.3), position_matrix()
    R = np.diag([4.0, 1.0])
    K = 4000
    xt = np.zeros(4)
    zs = np.empty((K, 2))
    LQ = np.linalg.cholesky(Q + 1e-15 * np.eye(4))
    for k in range(K):
        xt = F @ xt + LQ @ rng.normal(size=4)
        zs[k] = H @ xt + np.sqrt(np.diag(R)) * rng.normal(size=2)
    run = kalman_filter_run(zs, np.zeros(4), np.eye(4) * 1e-9, F, Q, H, R)
    assert abs(run.nis[100:].mean() - 2.0) < 0.15  # 4-sigma band for 3900 chi2_2 samples
    # the run kernel equals stepping the wrappers
    x, P = np.zeros(4), np.eye(4) * 1e-9
    for k in range(50):
        x, P = kf_predict(x, P, F, Q)
        u = kf_update(x, P, zs[k], H, R)
        x, P = u.x, u.P
        np.testing.assert_allclose(run.xs[k], x, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(run.Ps[k], P, rtol=1e-12, atol=1e-14)
        assert math.isclose(run.loglik[k], u.loglik, rel_tol=1e-12)
        assert math.isclose(run.nis[k], u.nis, rel_tol=1e-10, abs_tol=1e-12)


def test_run_missed_scans():
    F, Q, H, R = cv_transition(1.0), cv_process_noise(1.0, 0.3), position_matrix(), np.eye(2)
    zs = np.array([[1.0, 2.0], [np.nan, np.nan], [3.0, 4.0]])
    run = kalman_filter_run(zs, np.zeros(4), np.eye(4), F, Q, H, R)
    assert np.isnan(run.nis[1]) and run.loglik[1] == 0.0
    x1, P1 = kf_predict(run.xs[0], run.Ps[0], F, Q)
    np.testing.assert_allclose(run.xs[1], x1, rtol=1e-14)
    np.testing.assert_allclose(run.Ps[1], P1, rtol=1e-14)
    assert kalman_filter_run(np.zeros((0, 2)), np.zeros(4), np.eye(4), F, Q, H, R).xs.shape == (0, 4)
    with pytest.raises(ValueError, match="zs"):
        kalman_filter_run(np.array([[1.0, np.nan]]), np.zeros(4), np.eye(4), F, Q, H, R)
    with pytest.raises(ValueError, match="zs"):
        kalman_filter_run(np.array([[1.0, np.inf]]), np.zeros(4), np.eye(4), F, Q, H, R)
    with pytest.raises(ValueError, match="H"):
        kalman_filter_run(np.zeros((3, 3)), np.zeros(4), np.eye(4), F, Q, H, R)
    with pytest.raises(ValueError, match="not positive definite"):
        kalman_filter_run(np.zeros((3, 2)), np.zeros(4), np.zeros((4, 4)), np.eye(4),
                          np.zeros((4, 4)), H, np.zeros((2, 2)))


def test_ekf_update_wraps_angles():
    x = np.array([-100.0, 1e-3, 0.0, 0.0])  # bearing ~ +pi
    P = np.diag([10.0, 10.0, 1.0, 1.0])
    R = np.diag([1.0, 1e-4])
    zp = range_bearing(x)
    H = range_bearing_jacobian(x)
    z = np.array([100.0, -math.pi + 1e-4])   # just across the branch cut
    u = ekf_update(x, P, z, zp, H, R, angle_index=[1])
    assert abs(u.innovation[1]) < 1e-3
    ref = kf_update(x, P, H @ x + u.innovation, H, R)
    np.testing.assert_allclose(u.x, ref.x, rtol=1e-12)
    # without wrapping the innovation is ~ -2 pi
    u2 = ekf_update(x, P, z, zp, H, R)
    assert u2.innovation[1] < -6.0
    ekf_update(x, P, z, zp, H, R, angle_index=1)


def test_bad_inputs():
    x, P, F, Q, H, R = np.zeros(4), np.eye(4), np.eye(4), np.eye(4), position_matrix(), np.eye(2)
    z = np.zeros(2)
    with pytest.raises(ValueError, match="P"):
        kf_predict(x, -np.eye(4), F, Q)
    with pytest.raises(ValueError, match="P"):
        kf_predict(x, np.eye(3), F, Q)
    with pytest.raises(ValueError, match="P"):
        kf_predict(x, np.triu(np.ones((4, 4))), F, Q)
    with pytest.raises(ValueError, match="F"):
        kf_predict(x, P, np.eye(3), Q)
    with pytest.raises(ValueError, match="Q"):
        kf_predict(x, P, F, np.full((4, 4), np.nan))
    with pytest.raises(ValueError, match="x"):
        kf_predict([np.nan, 0, 0, 0], P, F, Q)
    with pytest.raises(ValueError, match="x"):
        kf_predict(np.zeros((4, 1)), P, F, Q)
    with pytest.raises(TypeError, match="x"):
        kf_predict("abcd", P, F, Q)
    with pytest.raises(ValueError, match="H"):
        kf_update(x, P, z, np.eye(4), R)
    with pytest.raises(ValueError, match="R"):
        kf_update(x, P, z, H, np.eye(3))
    with pytest.raises(ValueError, match="R"):
        kf_update(x, P, z, H, -np.eye(2))
    with pytest.raises(ValueError, match="z"):
        kf_update(x, P, [np.nan, 0.0], H, R)
    with pytest.raises(ValueError, match="not positive definite"):
        kf_update(x, np.zeros((4, 4)), z, H, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="z_pred"):
        ekf_update(x, P, z, np.zeros(3), H, R)
    with pytest.raises(ValueError, match="angle_index"):
        ekf_update(x, P, z, z, H, R, angle_index=[2])
    with pytest.raises(TypeError, match="angle_index"):
        ekf_update(x, P, z, z, H, R, angle_index=[0.5])


@given(st.integers(0, 2**32 - 1), st.integers(1, 5), st.integers(1, 4))
@settings(max_examples=40, deadline=None)
def test_update_property(seed, n, m):
    rng = np.random.default_rng(seed)
    x, P, F, Q, H, R, z = random_problem(rng, n, m)
    u = kf_update(x, P, z, H, R)
    # posterior covariance never exceeds the prior (in the PSD order) and stays PD
    assert np.all(np.linalg.eigvalsh(P - u.P) > -1e-9 * np.abs(P).max())
    assert np.all(np.linalg.eigvalsh(u.P) > 0)
    ref = reference_update(x, P, z, H, R)
    np.testing.assert_allclose(u.x, ref[0], rtol=1e-8, atol=1e-8)


def test_fast_validation_matches_core_checks():
    from trackcore.core.validation import as_covariance
    from trackcore.filters._fastcheck import checked, checked_cov, checked_cov_stack
    rng = np.random.default_rng(5)
    A = rng.normal(size=(4, 4))
    P = A @ A.T
    P_near = P.copy()
    P_near[0, 1] += 1e-14  # symmetric to tolerance: accepted and symmetrised
    for _ in range(2):  # second pass hits the cache
        np.testing.assert_array_equal(checked_cov(P_near, "P", 4), as_covariance(P_near, "P", 4))
    bad = -P
    for _ in range(2):
        with pytest.raises(ValueError, match="Pbad"):
            checked_cov(bad, "Pbad", 4)
    with pytest.raises(ValueError, match="P"):
        checked_cov(np.triu(P), "P", 4)
    with pytest.raises(ValueError, match="Qs\\[1\\]"):
        checked_cov_stack(np.stack([P, -P]), "Qs", 2, 4)
    with pytest.raises(ValueError, match="F"):
        checked(np.full((2, 2), np.inf), "F", (2, 2))
    np.testing.assert_array_equal(checked([[1, 2], [3, 4]], "F", (2, 2)), [[1.0, 2.0], [3.0, 4.0]])
    # a previously accepted P does not let a different, invalid one through
    x, H, R = np.zeros(4), position_matrix(), np.eye(2)
    kf_update(x, P, np.zeros(2), H, R)
    P2 = P.copy()
    P2[3, 3] = -100.0
    with pytest.raises(ValueError, match="P"):
        kf_update(x, P2, np.zeros(2), H, R)


def _batch_problem(seed, n_runs=6, K=12):
    rng = np.random.default_rng(seed)
    F, Q, H = cv_transition(1.0), cv_process_noise(1.0, 0.5), position_matrix()
    R = np.array([[4.0, 0.5], [0.5, 2.0]])
    zs = rng.normal(size=(n_runs, K, 2)) * 3.0
    return zs, np.array([0.0, 0.0, 1.0, -1.0]), np.diag([10.0, 10.0, 2.0, 2.0]), F, Q, H, R


@pytest.mark.parametrize("seed", [0, 1])
def test_batch_equals_single_runs_bit_for_bit(seed):
    from trackcore.filters.kalman import kalman_filter_batch
    zs, x0, P0, F, Q, H, R = _batch_problem(seed)
    zs[1, 3] = np.nan          # runs with missed scans take the per-run path
    zs[4, 0] = np.nan
    zs[4, -1] = np.nan
    batch = kalman_filter_batch(zs, x0, P0, F, Q, H, R)
    assert batch.xs.shape == (6, 12, 4) and batch.Ps.shape == (6, 12, 4, 4)
    for r in range(zs.shape[0]):
        single = kalman_filter_run(zs[r], x0, P0, F, Q, H, R)
        for a, b in zip(single, batch):
            assert np.array_equal(a, b[r], equal_nan=True)


def test_batch_edge_cases_and_bad_input():
    from trackcore.filters.kalman import kalman_filter_batch
    zs, x0, P0, F, Q, H, R = _batch_problem(2)
    empty = kalman_filter_batch(zs[:0], x0, P0, F, Q, H, R)
    assert empty.xs.shape == (0, 12, 4) and empty.nis.shape == (0, 12)
    assert kalman_filter_batch(zs[:, :0], x0, P0, F, Q, H, R).Ps.shape == (6, 0, 4, 4)
    # m = 0: every scan empty -> prediction only, nis = loglik = 0
    none = kalman_filter_batch(np.zeros((2, 3, 0)), x0, P0, F, Q, np.zeros((0, 4)), None)
    single = kalman_filter_run(np.zeros((3, 0)), x0, P0, F, Q, np.zeros((0, 4)), None)
    assert np.array_equal(none.xs[1], single.xs) and np.array_equal(none.Ps[0], single.Ps)
    assert np.all(none.nis == 0.0) and np.all(none.loglik == 0.0)
    with pytest.raises(ValueError, match="zs"):
        kalman_filter_batch(zs[0], x0, P0, F, Q, H, R)          # 2-D
    bad = zs.copy()
    bad[2, 1, 0] = np.nan                                        # half a row NaN
    with pytest.raises(ValueError, match="zs"):
        kalman_filter_batch(bad, x0, P0, F, Q, H, R)
    bad[2, 1, 0] = np.inf
    with pytest.raises(ValueError, match="zs"):
        kalman_filter_batch(bad, x0, P0, F, Q, H, R)
    with pytest.raises(ValueError, match="H"):
        kalman_filter_batch(np.zeros((2, 3, 3)), x0, P0, F, Q, H, R)
    with pytest.raises(ValueError, match="P0"):
        kalman_filter_batch(zs, x0, -P0, F, Q, H, R)
    with pytest.raises(ValueError, match="not positive definite at scan 0 of run 0"):
        kalman_filter_batch(np.zeros((2, 3, 2)), np.zeros(4), np.zeros((4, 4)), np.eye(4),
                            np.zeros((4, 4)), H, np.zeros((2, 2)))


# ---------------------------------------------------------------- overflow (issue 17)
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_overflowing_results_raise_instead_of_inf():
    x, P = np.array([1.0, 2.0, 0.5, 0.1]), np.eye(4)
    F, Q, H, R = cv_transition(1.0), cv_process_noise(1.0, 0.5), position_matrix(), np.eye(2)
    with pytest.raises(ValueError, match="overflows"):
        kf_predict(x, P, F * 1e300, Q)
    with pytest.raises(ValueError, match="overflows"):
        kf_update(x, P, [1e300, 0.0], H, R)
    with pytest.raises(ValueError, match="overflows"):
        ekf_update(x, P, [1e300, 0.0], H @ x, H, R)
    zs = np.ones((5, 2))
    with pytest.raises(ValueError, match="overflows"):
        kalman_filter_run(zs * 1e300, x, P, F, Q, H, R)
    zs[2] = np.nan  # a missed scan: the NIS there is NaN, everything else finite
    run = kalman_filter_run(zs, x, P, F, Q, H, R)
    assert np.isnan(run.nis[2]) and np.all(np.isfinite(np.delete(run.nis, 2)))
    assert np.all(np.isfinite(run.xs)) and np.all(np.isfinite(run.loglik))


def test_angle_index_must_be_integers():
    x, P = np.array([100.0, 50.0, 1.0, 1.0]), np.eye(4)
    z_pred, Hj = range_bearing(x), range_bearing_jacobian(x)
    for bad in (True, "1", 1.0, [[1]]):
        with pytest.raises(TypeError, match="angle_index"):
            ekf_update(x, P, z_pred, z_pred, Hj, np.eye(2), angle_index=bad)
