"""Tests for trackcore.models (motion and measurement models)."""
import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings, strategies as st

from trackcore.models import (converted_measurement_covariance, coordinated_turn_process_noise,
                              coordinated_turn_transition, cv_process_noise, cv_transition,
                              kron_axes, polar_to_cartesian, position_matrix, range_bearing,
                              range_bearing_doppler, range_bearing_doppler_jacobian,
                              range_bearing_jacobian, singer_process_noise, singer_transition,
                              van_loan_discretize, wrap_angle)
from trackcore.models.measurement import wrap_angle_kernel


# ---------------------------------------------------------------- motion
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_cv_transition_layout(dim):
    F = cv_transition(0.5, dim)
    assert F.shape == (2 * dim, 2 * dim)
    x = np.arange(2 * dim, dtype=float)
    pos, vel = x[:dim], x[dim:]
    np.testing.assert_allclose(F @ x, np.concatenate([pos + 0.5 * vel, vel]))


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("T", [0.1, 1.0, 3.7])
def test_cwna_equals_van_loan(dim, T):
    q = 2.3
    A = np.kron(np.array([[0.0, 1.0], [0.0, 0.0]]), np.eye(dim))
    W = np.kron(np.diag([0.0, q]), np.eye(dim))
    F, Q = van_loan_discretize(A, W, T)
    np.testing.assert_allclose(F, cv_transition(T, dim), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(Q, cv_process_noise(T, q, dim, kind="cwna"), rtol=1e-9, atol=0)


def test_dwna_is_q_g_gt():
    T, q = 0.7, 1.9
    G = np.array([[T**2 / 2], [T]])
    np.testing.assert_allclose(cv_process_noise(T, q, 1, kind="dwna"), q * G @ G.T, rtol=1e-15)
    np.testing.assert_allclose(cv_process_noise(T, q, 2), kron_axes(q * G @ G.T, 2), rtol=1e-15)


def test_cv_bad_inputs():
    with pytest.raises(ValueError, match="T"):
        cv_transition(-1.0)
    with pytest.raises(ValueError, match="dim"):
        cv_transition(1.0, dim=4)
    with pytest.raises(TypeError, match="dim"):
        cv_transition(1.0, dim=2.5)
    with pytest.raises(ValueError, match="q"):
        cv_process_noise(1.0, -1.0)
    with pytest.raises(ValueError, match="q"):
        cv_process_noise(1.0, np.nan)
    with pytest.raises(ValueError, match="kind"):
        cv_process_noise(1.0, 1.0, kind="white")
    with pytest.raises(TypeError, match="T"):
        cv_process_noise("1", 1.0)
    with pytest.raises(ValueError, match="M"):
        kron_axes(np.ones((2, 3)))


def test_coordinated_turn_matches_expm_and_limit():
    for omega in [0.3, -0.05, 1e-5, -1e-9, 2.0]:
        T = 1.3
        A = np.zeros((4, 4))
        A[0, 2] = A[1, 3] = 1.0
        A[2, 3], A[3, 2] = -omega, omega
        np.testing.assert_allclose(coordinated_turn_transition(omega, T),
                                   scipy.linalg.expm(A * T), rtol=1e-12, atol=1e-14)
    F0 = coordinated_turn_transition(0.0, 2.0)
    np.testing.assert_array_equal(F0, cv_transition(2.0, 2))
    # speed is preserved and heading rotates by omega T
    x = np.array([0.0, 0.0, 3.0, 4.0])
    y = coordinated_turn_transition(0.2, 1.5) @ x
    assert math.isclose(np.hypot(y[2], y[3]), 5.0, rel_tol=1e-14)
    assert math.isclose(math.atan2(y[3], y[2]) - math.atan2(4, 3), 0.3, rel_tol=1e-12)
    np.testing.assert_array_equal(coordinated_turn_process_noise(1.0, 2.0),
                                  cv_process_noise(1.0, 2.0, 2))


def test_coordinated_turn_bad_inputs():
    with pytest.raises(ValueError, match="omega"):
        coordinated_turn_transition(np.inf, 1.0)
    with pytest.raises(ValueError, match="T"):
        coordinated_turn_transition(0.1, -1.0)
    with pytest.raises(ValueError, match="kind"):
        coordinated_turn_process_noise(1.0, 1.0, kind="x")


@pytest.mark.parametrize("T,tau", [(1.0, 20.0), (0.1, 1000.0), (2.0, 1.5), (1.0, 0.999),
                                   (1.0, 1.001), (1.0, 1e6), (3.0, 1.0), (0.01, 60.0)])
def test_singer_equals_van_loan(T, tau):
    sigma_m = 1.7
    a = 1.0 / tau
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -a]])
    W = np.zeros((3, 3))
    W[2, 2] = 2.0 * sigma_m**2 / tau
    F, Q = van_loan_discretize(A, W, T)
    # F from expm(A T) directly: Van Loan's block exponential loses digits in F
    # when T/tau is large (its -A block grows like e^{T/tau}); its Q is accurate.
    np.testing.assert_allclose(singer_transition(T, tau), scipy.linalg.expm(A * T),
                               rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(singer_process_noise(T, tau, sigma_m), Q, rtol=1e-9, atol=0)


@pytest.mark.parametrize("T,tau", [(5.0, 0.5), (1.0, 20.0), (20.0, 0.5)])
def test_singer_q_equals_quadrature(T, tau):
    # Van Loan's Q loses ~e^{T/tau} eps for T >> tau; check there by quadrature of
    # int_0^T F(s) [0,0,1]^T (2 s^2/tau) [0,0,1] F(s)^T ds.
    import scipy.integrate
    sm = 1.7

    def integrand(s, i, j):
        col = singer_transition(s, tau)[:, 2]
        return col[i] * col[j] * 2.0 * sm**2 / tau

    Qq = np.array([[scipy.integrate.quad(integrand, 0.0, T, args=(i, j), epsabs=0.0,
                                         epsrel=1e-13, limit=200)[0] for j in range(3)]
                   for i in range(3)])
    np.testing.assert_allclose(singer_process_noise(T, tau, sm), Qq, rtol=1e-11, atol=0)


def test_singer_limits():
    # tau -> infinity: Q -> white-jerk-free limit 0 (PSD 2 s^2/tau -> 0), F -> CA
    F = singer_transition(2.0, 1e12)
    np.testing.assert_allclose(F, [[1, 2, 2], [0, 1, 2], [0, 0, 1]], rtol=1e-9)
    # T = 0: identity and zero noise
    np.testing.assert_array_equal(singer_transition(0.0, 3.0), np.eye(3))
    np.testing.assert_array_equal(singer_process_noise(0.0, 3.0, 1.0), np.zeros((3, 3)))
    # steady state: acceleration variance tends to sigma_m^2 as T >> tau
    Q = singer_process_noise(1e3, 1.0, 2.0)
    assert math.isclose(Q[2, 2], 4.0, rel_tol=1e-12)
    Q = singer_process_noise(1.0, 5.0, 1.0)
    assert np.all(np.linalg.eigvalsh(Q) > 0)


def test_singer_bad_inputs():
    with pytest.raises(ValueError, match="tau"):
        singer_transition(1.0, 0.0)
    with pytest.raises(ValueError, match="tau"):
        singer_process_noise(1.0, -2.0, 1.0)
    with pytest.raises(ValueError, match="sigma_m"):
        singer_process_noise(1.0, 2.0, -1.0)
    with pytest.raises(ValueError, match="T"):
        singer_process_noise(np.nan, 2.0, 1.0)


def test_van_loan_bad_inputs():
    with pytest.raises(ValueError, match="A"):
        van_loan_discretize(np.ones((2, 3)), np.eye(2), 1.0)
    with pytest.raises(ValueError, match="L_Qc_Lt"):
        van_loan_discretize(np.eye(2), -np.eye(2), 1.0)
    with pytest.raises(ValueError, match="L_Qc_Lt"):
        van_loan_discretize(np.eye(2), np.eye(3), 1.0)
    with pytest.raises(ValueError, match="T"):
        van_loan_discretize(np.eye(2), np.eye(2), -1.0)


# ---------------------------------------------------------------- measurement
def test_position_matrix():
    np.testing.assert_array_equal(position_matrix(2, 4), [[1, 0, 0, 0], [0, 1, 0, 0]])
    assert position_matrix(3, 6).shape == (3, 6)
    with pytest.raises(ValueError, match="n"):
        position_matrix(3, 2)
    with pytest.raises(ValueError, match="dim"):
        position_matrix(0, 2)


def test_wrap_angle():
    assert wrap_angle(math.pi) == math.pi
    assert wrap_angle(-math.pi) == math.pi
    assert math.isclose(wrap_angle(3 * math.pi), math.pi)
    assert wrap_angle(0.0) == 0.0
    a = np.linspace(-20, 20, 1001)
    w = wrap_angle(a)
    assert w.shape == a.shape
    assert np.all(w > -math.pi) and np.all(w <= math.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    assert wrap_angle(np.zeros((0,))).shape == (0,)
    assert wrap_angle_kernel(7.0) == wrap_angle(7.0)
    with pytest.raises(ValueError, match="a"):
        wrap_angle(np.array([np.nan]))
    with pytest.raises(TypeError, match="a"):
        wrap_angle("x")


@given(st.floats(-1e4, 1e4))
@settings(max_examples=200, deadline=None)
def test_wrap_angle_property(a):
    w = wrap_angle(a)
    assert -math.pi < w <= math.pi
    assert abs(math.remainder(w - a, 2 * math.pi)) < 1e-9


def _fd_jacobian(f, x, h=1e-6):
    x = np.asarray(x, float)
    f0 = f(x)
    J = np.empty((f0.size, x.size))
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h * max(1.0, abs(x[j]))
        J[:, j] = (f(x + e) - f(x - e)) / (2 * e[j])
    return J


def test_range_bearing_values_and_batch():
    x = np.array([3.0, 4.0, 1.0, 2.0])
    np.testing.assert_allclose(range_bearing(x), [5.0, math.atan2(4, 3)])
    np.testing.assert_allclose(range_bearing(x, sensor=[3.0, 0.0]), [4.0, math.pi / 2])
    rng = np.random.default_rng(1)
    X = rng.normal(size=(50, 4)) * 10
    Z = range_bearing(X, sensor=[1.0, -2.0])
    assert Z.shape == (50, 2)
    for i in range(50):
        np.testing.assert_allclose(Z[i], range_bearing(X[i], sensor=[1.0, -2.0]))
    assert range_bearing(np.zeros((0, 4))).shape == (0, 2)
    assert range_bearing(np.zeros(4))[0] == 0.0


@pytest.mark.parametrize("seed", range(5))
def test_range_bearing_jacobians_finite_difference(seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=4) * 50
    s = rng.normal(size=2)
    np.testing.assert_allclose(range_bearing_jacobian(x, s),
                               _fd_jacobian(lambda v: range_bearing(v, s), x),
                               rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(range_bearing_doppler_jacobian(x),
                               _fd_jacobian(range_bearing_doppler, x), rtol=1e-6, atol=1e-9)
    X = rng.normal(size=(7, 6)) * 20
    JB = range_bearing_doppler_jacobian(X)
    assert JB.shape == (7, 3, 6)
    for i in range(7):
        np.testing.assert_allclose(JB[i], _fd_jacobian(range_bearing_doppler, X[i]),
                                   rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(range_bearing_jacobian(X)[i],
                                   _fd_jacobian(range_bearing, X[i]), rtol=1e-6, atol=1e-9)


def test_range_bearing_doppler_values():
    z = range_bearing_doppler([3.0, 4.0, 1.0, 2.0])
    np.testing.assert_allclose(z, [5.0, math.atan2(4, 3), (3 + 8) / 5])
    assert range_bearing_doppler(np.zeros((0, 4))).shape == (0, 3)


def test_measurement_bad_inputs():
    with pytest.raises(ValueError, match="zero range"):
        range_bearing_jacobian([0.0, 0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="zero range"):
        range_bearing_jacobian([1.0, 2.0], sensor=[1.0, 2.0])
    with pytest.raises(ValueError, match="zero range"):
        range_bearing_doppler_jacobian(np.array([[1.0, 1, 0, 0], [0, 0, 1, 1]]))
    with pytest.raises(ValueError, match="zero range"):
        range_bearing_doppler([0.0, 0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="x"):
        range_bearing([1.0])
    with pytest.raises(ValueError, match="x_rel"):
        range_bearing_doppler([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="x"):
        range_bearing([np.nan, 1.0])
    with pytest.raises(ValueError, match="sensor"):
        range_bearing([1.0, 1.0], sensor=[1.0])
    with pytest.raises(ValueError, match="x"):
        range_bearing(np.ones((2, 2, 2)))


def test_polar_conversion():
    z = np.array([[5.0, math.atan2(4, 3)], [2.0, -math.pi / 2]])
    np.testing.assert_allclose(polar_to_cartesian(z), [[3.0, 4.0], [0.0, -2.0]], atol=1e-12)
    np.testing.assert_allclose(range_bearing(polar_to_cartesian(z[0], sensor=[1, 1]),
                                             sensor=[1, 1]), z[0])
    assert polar_to_cartesian(np.zeros((0, 2))).shape == (0, 2)
    with pytest.raises(ValueError, match="z"):
        polar_to_cartesian([[-1.0, 0.0]])
    with pytest.raises(ValueError, match="z"):
        polar_to_cartesian([[1.0, 0.0, 0.0]])
    # linearised covariance equals J R J^T with the polar_to_cartesian Jacobian
    r, b, sr, sb = 1000.0, 0.7, 5.0, 0.01
    J = _fd_jacobian(lambda v: polar_to_cartesian(v), np.array([r, b]))
    np.testing.assert_allclose(converted_measurement_covariance(r, b, sr, sb),
                               J @ np.diag([sr**2, sb**2]) @ J.T, rtol=1e-6)
    with pytest.raises(ValueError, match="sigma_r"):
        converted_measurement_covariance(1.0, 0.0, -1.0, 0.1)


# ---------------------------------------------------------------- extreme scales (issue 17)
def test_range_bearing_far_and_near_states_are_finite():
    X = np.array([[1e300, 2e300, 0.0, 0.0], [3e-300, -4e-300, 0.0, 0.0], [30.0, 40.0, 1.0, 2.0]])
    z = range_bearing(X)
    np.testing.assert_allclose(z[:, 0], [math.hypot(1, 2) * 1e300, 5e-300, 50.0], rtol=1e-15)
    np.testing.assert_allclose(z[:, 1], np.arctan2(X[:, 1], X[:, 0]), rtol=1e-15)
    # the usual rows keep the kernel's bits
    assert np.array_equal(z[2], range_bearing(X[2]))
    J = range_bearing_jacobian(X)
    for i in range(3):
        r = math.hypot(X[i, 0], X[i, 1])
        np.testing.assert_allclose(J[i, 0, :2], X[i, :2] / r, rtol=1e-14)
        np.testing.assert_allclose(J[i, 1, :2] * r, [-X[i, 1] / r, X[i, 0] / r], rtol=1e-14)
    d = range_bearing_doppler(X)
    np.testing.assert_allclose(d[:, 0], z[:, 0], rtol=1e-15)
    np.testing.assert_allclose(d[2, 2], (30 * 1 + 40 * 2) / 50.0, rtol=1e-15)
    Jd = range_bearing_doppler_jacobian(X[[0, 2]])
    assert np.all(np.isfinite(Jd))
    np.testing.assert_allclose(Jd[1], range_bearing_doppler_jacobian(X[2]), rtol=1e-15)
    with pytest.raises(ValueError, match="zero range"):
        range_bearing_jacobian(np.zeros(4))


def test_overflowing_models_raise():
    with pytest.raises(ValueError, match="T and q"):
        cv_process_noise(1e300, 1.0)
    with pytest.raises(ValueError, match="T, tau and sigma_m"):
        singer_process_noise(1.0, 20.0, 1e300)
    with pytest.raises(ValueError, match="A and T"):
        van_loan_discretize(np.array([[0.0, 1.0], [0.0, 1e300]]), np.eye(2), 1.0)
    with pytest.raises(ValueError, match="omega \\* T"):
        coordinated_turn_transition(1e300, 1e300)
    with pytest.raises(ValueError, match="r, sigma_r and sigma_bearing"):
        converted_measurement_covariance(1e300, 0.3, 1.0, 1.0)
