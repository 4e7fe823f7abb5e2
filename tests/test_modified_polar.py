"""Tests for trackcore.models.modified_polar (Jeong & Hong 1996, eqs 10, 11, 14)."""
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

from trackcore.models import (modified_polar_F, modified_polar_f, modified_polar_from_cartesian,
                              modified_polar_Q, wrap_angle)


def cartesian_route(xb, ub):
    """Independent route: polar -> Cartesian point, move the observer, back to polar."""
    theta, beta = xb
    r = 1.0 / beta
    p = np.array([r * math.cos(theta), r * math.sin(theta)]) - np.asarray(ub)
    return np.array([math.atan2(p[1], p[0]), 1.0 / math.hypot(*p)])


CASES = [
    ([0.3, 1 / 1000.0], [10.0, 40.0]),
    ([-2.9, 1 / 400.0], [-30.0, 5.0]),
    ([math.pi / 2, 1 / 1000.0], [0.0, 46.2]),     # S1 geometry: heading at the point
    ([1.0, 1 / 50.0], [30.0, 60.0]),              # observer passes the point (S2 < 0)
    ([3.1, 1 / 200.0], [-150.0, 20.0]),           # crosses the +-pi bearing cut
]


@pytest.mark.parametrize("xb,ub", CASES)
def test_f_matches_cartesian_route(xb, ub):
    f = modified_polar_f(xb, ub)
    ref = cartesian_route(xb, ub)
    assert abs(wrap_angle(f[0] - ref[0])) < 1e-9
    assert f[1] == pytest.approx(ref[1], rel=1e-9)


def test_f_uses_atan2_when_observer_passes_point():
    xb, ub = [1.0, 1 / 50.0], [30.0, 60.0]
    th, beta = xb
    c, s = math.cos(th), math.sin(th)
    S2 = 1 + beta * (-ub[1] * s - ub[0] * c)
    assert S2 < 0                                   # printed tan^-1(S1/S2) would be wrong by pi
    f = modified_polar_f(xb, ub)
    S1 = beta * (-ub[1] * c + ub[0] * s)
    assert abs(wrap_angle(f[0] - (th + math.atan(S1 / S2)))) == pytest.approx(math.pi, abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.floats(-math.pi, math.pi), st.floats(50.0, 5000.0),
       st.floats(-80.0, 80.0), st.floats(-80.0, 80.0))
def test_f_property_cartesian(theta, r, u1, u2):
    xb = [theta, 1.0 / r]
    assume(math.hypot(r * math.cos(theta) - u1, r * math.sin(theta) - u2) > 1.0)
    f = modified_polar_f(xb, [u1, u2])
    ref = cartesian_route(xb, [u1, u2])
    assert abs(wrap_angle(f[0] - ref[0])) < 1e-9
    assert f[1] == pytest.approx(ref[1], rel=1e-9)


def numerical_jacobian(xb, ub, h=(1e-7, 1e-10)):
    J = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = h[j]
        J[:, j] = (modified_polar_f(np.add(xb, e), ub) - modified_polar_f(np.subtract(xb, e), ub)) \
            / (2 * h[j])
    return J


@pytest.mark.parametrize("xb,ub", CASES)
def test_jacobian_finite_differences(xb, ub):
    F = modified_polar_F(xb, ub)
    Fn = numerical_jacobian(xb, ub, h=(1e-6, 1e-6 * xb[1]))
    np.testing.assert_allclose(F, Fn, rtol=1e-5, atol=1e-9 * np.abs(F).max())


def test_jacobian_zero_displacement_is_identity():
    np.testing.assert_allclose(modified_polar_F([0.7, 1e-3], [0.0, 0.0]), np.eye(2), atol=1e-15)
    np.testing.assert_allclose(modified_polar_f([0.7, 1e-3], [0.0, 0.0]), [0.7, 1e-3])


def test_Q_first_order_mapping_of_cartesian_drift():
    xb, T, sp = np.array([0.4, 1 / 800.0]), 2.0, 1.0
    Q = modified_polar_Q(xb, T, sp)
    np.testing.assert_allclose(Q, sp**2 * T * np.diag([xb[1] ** 2, xb[1] ** 4]))
    # J Qbar J^T with J = d(theta, 1/r)/d(x, y) (numerical)
    r = 1 / xb[1]
    p = r * np.array([math.cos(xb[0]), math.sin(xb[0])])
    J = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = 1e-4
        J[:, j] = (modified_polar_from_cartesian(p + e) - modified_polar_from_cartesian(p - e)) / 2e-4
    Qn = J @ (sp**2 * T * np.eye(2)) @ J.T
    np.testing.assert_allclose(Q, Qn, rtol=1e-5, atol=1e-12 * Q.max())


def test_bad_input():
    with pytest.raises(ValueError, match="xb"):
        modified_polar_f([0.1, 0.2, 0.3], [0, 0])
    with pytest.raises(ValueError, match="ub"):
        modified_polar_F([0.1, 0.01], [0, np.nan])
    with pytest.raises(TypeError, match="xb"):
        modified_polar_f("ab", [0, 0])
    with pytest.raises(ValueError, match="T"):
        modified_polar_Q([0.1, 0.01], -1.0, 1.0)
    with pytest.raises(ValueError, match="sigma_p"):
        modified_polar_Q([0.1, 0.01], 1.0, -1.0)
    with pytest.raises(ValueError, match="S1 = S2 = 0"):
        modified_polar_f([0.0, 0.01], [100.0, 0.0])   # observer lands on the point
    with pytest.raises(ValueError, match="p_rel"):
        modified_polar_from_cartesian([0.0, 0.0])
