"""Tests for trackcore.scenarios.random_manoeuvre (Yoon & Ko sec. 4.1)."""
import math

import numpy as np
import pytest

from trackcore.models import tom_rotation
from trackcore.scenarios import (cross_correlation_coefficient, forward_lateral,
                                 random_manoeuvre_turn, random_manoeuvre_xy)


def test_xy_kinematics_consistent():
    r = random_manoeuvre_xy(np.random.default_rng(0), n=500)
    assert r.position.shape == r.velocity.shape == r.accel_xy.shape == r.accel_fs.shape == (500, 2)
    np.testing.assert_allclose(np.diff(r.velocity, axis=0), r.accel_xy[:-1], atol=1e-9)
    np.testing.assert_allclose(np.diff(r.position, axis=0),
                               r.velocity[:-1] + 0.5 * r.accel_xy[:-1], atol=1e-8)
    np.testing.assert_allclose(r.velocity[0], [200.0, 0.0])
    assert np.all(r.accel_xy[0] == 0.0)  # every walk starts a segment at 0


def test_turn_speed_limits_and_turn_rate():
    r = random_manoeuvre_turn(np.random.default_rng(1), n=3000, sigma_wf=3.0)
    V = np.hypot(r.velocity[:, 0], r.velocity[:, 1])
    assert V.min() >= 50.0 - 1e-9 and V.max() <= 400.0 + 1e-9
    # the forward component is the actual change of speed
    np.testing.assert_allclose(np.diff(V), r.accel_fs[:-1, 0], atol=1e-9)
    # the lateral component is -V omega (right-positive) and |omega| <= 0.3
    psi = np.unwrap(np.arctan2(r.velocity[:, 1], r.velocity[:, 0]))
    omega = np.diff(psi)
    assert np.abs(omega).max() <= 0.3 + 1e-12
    np.testing.assert_allclose(r.accel_fs[:-1, 1], -V[:-1] * omega, atol=1e-8)


def test_forward_lateral_matches_tom_rotation():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(50, 2))
    v = rng.normal(size=(50, 2))
    fs = forward_lateral(a, v)
    for k in range(50):
        phi = math.atan2(v[k, 1], v[k, 0])
        np.testing.assert_allclose(fs[k], tom_rotation(phi) @ a[k], atol=1e-14)
    # a right turn of a target heading +x: acceleration along -y is +lateral
    np.testing.assert_allclose(forward_lateral([[0.0, -3.0]], [[10.0, 0.0]]), [[0.0, 3.0]])


def test_section_41_statistics_scenario_2():
    """The chapter's target on sec. 4.1, scenario 2, on one seed: var_s >> var_f, var_x ~ var_y, rho_fs small."""
    r = random_manoeuvre_turn(np.random.default_rng(3))
    vf, vs = r.accel_fs.var(axis=0)
    vx, vy = r.accel_xy.var(axis=0)
    assert vs / vf >= 20
    assert 0.67 <= vx / vy <= 1.5
    _, rxy = cross_correlation_coefficient(r.accel_xy[:, 0], r.accel_xy[:, 1])
    _, rfs = cross_correlation_coefficient(r.accel_fs[:, 0], r.accel_fs[:, 1])
    assert np.abs(rfs).max() <= 0.15 < np.abs(rxy).max()


def test_cross_correlation_definition():
    rng = np.random.default_rng(4)
    u = rng.normal(size=400)
    v = np.roll(u, 3) + 0.1 * rng.normal(size=400)  # v_k ~ u_{k-3}
    lags, rho = cross_correlation_coefficient(u, v, max_lag=5)
    np.testing.assert_array_equal(lags, np.arange(-5, 6))
    assert lags[np.argmax(rho)] == 3 and rho.max() > 0.9
    du, dv = u - u.mean(), v - v.mean()
    ref = np.dot(du[:-2], dv[2:]) / (398 * u.std() * v.std())
    assert rho[lags == 2][0] == pytest.approx(ref, rel=1e-12)
    _, r0 = cross_correlation_coefficient(u, u, max_lag=0)
    assert r0[0] == pytest.approx(1.0)


def test_reproducible():
    a = random_manoeuvre_turn(np.random.default_rng(9), n=200)
    b = random_manoeuvre_turn(np.random.default_rng(9), n=200)
    np.testing.assert_array_equal(a.accel_xy, b.accel_xy)


def test_bad_inputs():
    rng = np.random.default_rng(0)
    with pytest.raises(TypeError, match="rng"):
        random_manoeuvre_xy(0)
    with pytest.raises(ValueError, match="n"):
        random_manoeuvre_xy(rng, n=1)
    with pytest.raises(ValueError, match="sigma_w"):
        random_manoeuvre_xy(rng, sigma_w=-1.0)
    with pytest.raises(ValueError, match="dt"):
        random_manoeuvre_turn(rng, dt=0.0)
    with pytest.raises(ValueError, match="speed_limits"):
        random_manoeuvre_turn(rng, speed_limits=(400.0, 50.0))
    with pytest.raises(ValueError, match="omega_max"):
        random_manoeuvre_turn(rng, omega_max=0.0)
    with pytest.raises(ValueError, match="max_lag"):
        cross_correlation_coefficient(np.arange(5.0), np.arange(5.0), max_lag=5)
    with pytest.raises(ValueError, match="v"):
        cross_correlation_coefficient(np.arange(5.0), np.arange(4.0))
    with pytest.raises(ValueError, match="constant"):
        cross_correlation_coefficient(np.ones(5), np.arange(5.0), max_lag=1)
    with pytest.raises(ValueError, match="velocity"):
        forward_lateral(np.zeros((3, 2)), np.zeros((2, 2)))
