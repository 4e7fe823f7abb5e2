"""Tests for trackcore.models.tom (target-oriented velocity model, Yoon & Ko eqs 2-8)."""
import math

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from hypothesis import given, settings, strategies as st

from trackcore.models.tom import chord_heading_kernel
from trackcore.models import (chord_heading, tom_from_cartesian,
                              tom_printed_process_noise, tom_process_noise, tom_rotation,
                              tom_to_cartesian, tom_transition, van_loan_discretize)

# (phi, T, sigma_f, sigma_s): the reference settings of the chapter
SETTINGS = [(0.3, 1.0, 1.0, 3.0), (-1.5917, 1.0, 1.0, 20.0), (2.2, 0.5, 4.0, 30.0),
            (math.pi / 2, 2.0, 1.0, 1.0), (-2.9, 3.0, 10.0, 0.5)]


def _F(phi):
    F = np.zeros((4, 4))
    F[:2, 2:] = tom_rotation(phi)
    return F


def _G():
    return np.vstack([np.zeros((2, 2)), np.eye(2)])


def _dwna_expm(phi, T, sf, ss):
    """Q = Gamma S Gamma^T with Gamma = int_0^T expm(F s) G ds from an augmented expm."""
    M = np.zeros((6, 6))
    M[:4, :4] = _F(phi)
    M[:4, 4:] = _G()
    E = scipy.linalg.expm(M * T)
    Gamma = E[:4, 4:]
    return Gamma @ np.diag([sf**2, ss**2]) @ Gamma.T


def _cwna_van_loan(phi, T, sf, ss):
    G = _G()
    return van_loan_discretize(_F(phi), G @ np.diag([sf**2, ss**2]) @ G.T, T)


def _assert_rel(A, B, rtol):
    scale = np.max(np.abs(B))
    err = np.max(np.abs(A - B)) / scale
    assert err <= rtol, err
    nz = np.abs(B) > 1e-6 * scale
    assert np.all(np.abs(A[nz] - B[nz]) <= rtol * np.abs(B[nz]))


@pytest.mark.parametrize("phi,T,sf,ss", SETTINGS)
def test_transition_is_expm(phi, T, sf, ss):
    Phi = tom_transition(phi, T)
    np.testing.assert_allclose(Phi, scipy.linalg.expm(_F(phi) * T), rtol=0, atol=1e-12)
    F, _ = _cwna_van_loan(phi, T, sf, ss)
    np.testing.assert_allclose(Phi, F, rtol=0, atol=1e-12)


@pytest.mark.parametrize("phi,T,sf,ss", SETTINGS)
def test_dwna_matches_augmented_expm(phi, T, sf, ss):
    _assert_rel(tom_process_noise(phi, T, sf, ss), _dwna_expm(phi, T, sf, ss), 1e-9)


@pytest.mark.parametrize("phi,T,sf,ss", SETTINGS)
def test_cwna_matches_van_loan(phi, T, sf, ss):
    _, Qvl = _cwna_van_loan(phi, T, sf, ss)
    _assert_rel(tom_process_noise(phi, T, sf, ss, kind="cwna"), Qvl, 1e-9)


def test_cwna_matches_quadrature():
    phi, T, sf, ss = 0.7, 1.3, 2.0, 5.0
    G, S = _G(), np.diag([sf**2, ss**2])
    ts = np.linspace(0.0, T, 2001)
    vals = np.array([tom_transition(phi, T - t) @ G @ S @ G.T @ tom_transition(phi, T - t).T
                     for t in ts])
    Qq = scipy.integrate.simpson(vals, x=ts, axis=0)
    _assert_rel(tom_process_noise(phi, T, sf, ss, kind="cwna"), Qq, 1e-9)


def test_elementwise_eq7_except_q12():
    phi, T, sf, ss = 0.4, 1.0, 2.0, 7.0
    c, s = math.cos(phi), math.sin(phi)
    Q = tom_process_noise(phi, T, sf, ss)
    Qp = tom_printed_process_noise(phi, T, sf, ss)
    assert Q[0, 0] == pytest.approx((sf**2 * c**2 + ss**2 * s**2) * T**4 / 4, rel=1e-14)
    assert Q[0, 2] == pytest.approx(sf**2 * c * T**3 / 2, rel=1e-14)
    assert Q[1, 3] == pytest.approx(-ss**2 * c * T**3 / 2, rel=1e-14)
    assert Q[2, 3] == 0.0
    assert Q[0, 1] == pytest.approx((sf**2 - ss**2) * s * c * T**4 / 4, rel=1e-14)
    mask = np.ones((4, 4), bool)
    mask[0, 1] = mask[1, 0] = False
    np.testing.assert_array_equal(Q[mask], Qp[mask])
    assert Qp[0, 1] == pytest.approx((sf**2 + ss**2) * s * T**4 / 4, rel=1e-14)


@pytest.mark.parametrize("phi,T,sf,ss", SETTINGS)
def test_printed_q_is_indefinite(phi, T, sf, ss):
    assert np.linalg.eigvalsh(tom_printed_process_noise(phi, T, sf, ss))[0] < 0
    ev = np.linalg.eigvalsh(tom_process_noise(phi, T, sf, ss))
    assert ev[0] >= -1e-12 * ev[-1]


def test_printed_determinant_at_half_pi():
    T, sf, ss = 1.7, 2.0, 3.0
    Qp = tom_printed_process_noise(math.pi / 2, T, sf, ss)
    det = Qp[0, 0] * Qp[1, 1] - Qp[0, 1] ** 2
    assert det == pytest.approx(-T**8 / 16 * (sf**4 + sf**2 * ss**2 + ss**4), rel=1e-12)


def test_isotropic_noise_is_cv_noise():
    from trackcore.models import cv_process_noise
    for kind in ("dwna", "cwna"):
        Q = tom_process_noise(1.1, 0.8, 3.0, 3.0, kind=kind)
        B = np.eye(4)
        B[2:, 2:] = tom_rotation(1.1)
        # Cartesian covariance of the same noise equals the CV noise
        np.testing.assert_allclose(B @ Q @ B.T, cv_process_noise(0.8, 9.0, kind=kind),
                                   rtol=1e-12, atol=1e-14)


@settings(max_examples=60, deadline=None)
@given(phi=st.floats(-10, 10), T=st.floats(0.01, 5), sf=st.floats(0, 50), ss=st.floats(0, 50),
       kind=st.sampled_from(["dwna", "cwna"]))
def test_q_symmetric_psd(phi, T, sf, ss, kind):
    Q = tom_process_noise(phi, T, sf, ss, kind=kind)
    np.testing.assert_array_equal(Q, Q.T)
    ev = np.linalg.eigvalsh(Q)
    assert ev[0] >= -1e-10 * max(ev[-1], 1e-300)


def test_rotation_is_reflection_and_right_lateral():
    R = tom_rotation(0.9)
    np.testing.assert_allclose(R @ R, np.eye(2), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(-1.0)
    # heading +y (phi = pi/2): +v_s must point to the right, i.e. +x
    np.testing.assert_allclose(tom_rotation(math.pi / 2) @ [0.0, 1.0], [1.0, 0.0], atol=1e-15)


def test_cartesian_roundtrip():
    rng = np.random.default_rng(1)
    x = rng.normal(size=4)
    A = rng.normal(size=(4, 4))
    P = A @ A.T + np.eye(4)
    phi = math.atan2(x[3], x[2])
    xt, Pt = tom_from_cartesian(x, P, phi)
    assert xt[2] == pytest.approx(math.hypot(x[2], x[3]))
    assert xt[3] == pytest.approx(0.0, abs=1e-14)
    xb, Pb = tom_to_cartesian(xt, Pt, phi)
    np.testing.assert_allclose(xb, x, atol=1e-14)
    np.testing.assert_allclose(Pb, P, atol=1e-13)
    # one TOM step equals one CV step in the Cartesian frame
    Phi = tom_transition(phi, 2.0)
    xn, _ = tom_to_cartesian(Phi @ xt, Pt, phi)
    np.testing.assert_allclose(xn, [x[0] + 2 * x[2], x[1] + 2 * x[3], x[2], x[3]], atol=1e-12)


def test_chord_heading_uses_atan2():
    # Houles start: heading -91.19 deg; atan of the ratio would give +88.8 deg
    phi = chord_heading([21689.0, 10840.0], [21689.0 - 8.3, 10840.0 - 399.9])
    assert math.degrees(phi) == pytest.approx(-91.189, abs=1e-3)
    assert math.degrees(math.atan(-399.9 / -8.3)) == pytest.approx(88.81, abs=1e-2)
    assert chord_heading([0, 0], [-1, 0]) == pytest.approx(math.pi)
    assert chord_heading([5, 5], [5, 5 + 1e-9], phi_fallback=0.25) == 0.25
    assert chord_heading_kernel(0.0, 0.0, 0.0, 1.0, 0.0, 1e-6) == pytest.approx(math.pi / 2)


def test_zero_interval():
    np.testing.assert_array_equal(tom_transition(0.3, 0.0), np.eye(4))
    np.testing.assert_array_equal(tom_process_noise(0.3, 0.0, 1.0, 2.0), np.zeros((4, 4)))


def test_bad_inputs():
    with pytest.raises(ValueError, match="T"):
        tom_transition(0.1, -1.0)
    with pytest.raises(ValueError, match="phi"):
        tom_transition(np.nan, 1.0)
    with pytest.raises(TypeError, match="phi"):
        tom_transition("north", 1.0)
    with pytest.raises(ValueError, match="sigma_f"):
        tom_process_noise(0.1, 1.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="sigma_s"):
        tom_process_noise(0.1, 1.0, 1.0, np.inf)
    with pytest.raises(ValueError, match="kind"):
        tom_process_noise(0.1, 1.0, 1.0, 1.0, kind="white")
    # finite but huge: the square overflows; a ValueError naming the argument, never an
    # OverflowError or an inf in Q
    for f in (tom_process_noise, tom_printed_process_noise):
        with pytest.raises(ValueError, match="sigma_f"):
            f(0.1, 1.0, 1e200, 1.0)
        with pytest.raises(ValueError, match="sigma_s"):
            f(0.1, 1.0, 1.0, 1e200)
        with pytest.raises(ValueError, match="T"):
            f(0.1, 1e100, 1.0, 1.0)
        with pytest.raises(ValueError, match="too large together"):
            f(0.1, 1e60, 1e100, 1.0)
    with pytest.raises(ValueError, match="x"):
        tom_from_cartesian(np.zeros(3), np.eye(4), 0.0)
    with pytest.raises(ValueError, match="P"):
        tom_from_cartesian(np.zeros(4), -np.eye(4), 0.0)
    with pytest.raises(ValueError, match="p_curr"):
        chord_heading([0.0, 0.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="min_distance"):
        chord_heading([0.0, 0.0], [1.0, 2.0], min_distance=-1)
