"""Tests for trackcore.scenarios.houles (Houles & Bar-Shalom scenario, Yoon & Ko sec. 4.3)."""
import math

import numpy as np
import pytest

from trackcore.scenarios import (HOULES_DURATION, HOULES_INITIAL_STATE, HOULES_TURNS,
                                 houles_measurements, houles_truth)


def _rate(t):
    for a, b, w in HOULES_TURNS:
        if a <= t < b:
            return w
    return 0.0


def _rk4_truth(t_end, h=1e-3):
    """Independent reference: RK4 on p' = v, v' = omega(t) J v (J = 90 deg rotation)."""
    s = np.array(HOULES_INITIAL_STATE, dtype=float)

    def f(w, s):
        return np.array([s[2], s[3], -w * s[3], w * s[2]])

    out = {}
    t = 0.0
    n = int(round(t_end / h))
    checkpoints = {int(round(c / h)) for c in (20, 35, 55, 70, 90)}
    for k in range(n):
        # the turn rate jumps exactly at grid points, so each RK4 step sees one rate
        w = _rate(t + h / 2)
        k1 = f(w, s)
        k2 = f(w, s + h / 2 * k1)
        k3 = f(w, s + h / 2 * k2)
        k4 = f(w, s + h * k3)
        s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t = (k + 1) * h
        if k + 1 in checkpoints:
            out[round(t)] = s.copy()
    return out


def test_truth_matches_rk4():
    ref = _rk4_truth(90.0)
    X = houles_truth(np.array(sorted(ref)))
    for row, t in zip(X, sorted(ref)):
        assert np.linalg.norm(row[:2] - ref[t][:2]) < 1e-3, t
        assert np.linalg.norm(row[2:] - ref[t][2:]) < 1e-5, t


def test_truth_initial_state_and_speed():
    X = houles_truth(np.arange(0.0, 90.5, 0.5))
    np.testing.assert_allclose(X[0], HOULES_INITIAL_STATE)
    speed = np.hypot(X[:, 2], X[:, 3])
    np.testing.assert_allclose(speed, math.hypot(8.3, 399.9), rtol=1e-12)
    assert HOULES_DURATION == 90.0


def test_heading_changes_and_accelerations():
    X = houles_truth(np.array([20.0, 35.0, 55.0, 70.0]))
    h = np.degrees(np.arctan2(X[:, 3], X[:, 2]))
    d1 = (h[1] - h[0] + 180) % 360 - 180
    d2 = (h[3] - h[2] + 180) % 360 - 180
    assert d1 == pytest.approx(-128.9, abs=0.05)
    assert d2 == pytest.approx(85.9, abs=0.05)
    v = math.hypot(8.3, 399.9)
    assert abs(HOULES_TURNS[0][2]) * v == pytest.approx(60.0)
    assert HOULES_TURNS[1][2] * v == pytest.approx(40.0)


def test_closest_approach_to_sensor():
    t = np.linspace(89.9, 90.1, 20001)
    X = houles_truth(t)
    r = np.hypot(X[:, 0], X[:, 1])
    i = int(np.argmin(r))
    assert r[i] == pytest.approx(0.70, abs=0.02)
    assert t[i] == pytest.approx(90.003, abs=0.001)


def test_truth_shapes_and_bad_input():
    assert houles_truth(3.0).shape == (1, 4)
    assert houles_truth(np.array([])).shape == (0, 4)
    with pytest.raises(ValueError, match="t"):
        houles_truth(np.array([-1.0, 2.0]))
    with pytest.raises(ValueError, match="t"):
        houles_truth(np.array([np.nan]))
    with pytest.raises(ValueError, match="t"):
        houles_truth(np.zeros((2, 2)))
    with pytest.raises(TypeError, match="t"):
        houles_truth("now")


def test_measurements_statistics():
    truth = houles_truth(np.arange(91.0))
    rng = np.random.default_rng(5)
    counts, errs = [], []
    for _ in range(200):
        s = houles_measurements(truth, rng)
        assert s.offsets[0] == 0 and s.offsets[-1] == s.z.shape[0]
        assert np.all(s.target_index >= s.offsets[:-1]) and np.all(s.target_index < s.offsets[1:])
        counts.append(np.diff(s.offsets) - 1)
        errs.append(s.z[s.target_index] - truth[:, :2])
        # clutter inside the 2 km window centred on the truth
        k = np.repeat(np.arange(91), np.diff(s.offsets))
        assert np.all(np.abs(s.z - truth[k, :2]) <= 1000.0 + 5 * 20.0)
    counts = np.concatenate(counts)
    errs = np.concatenate(errs)
    assert counts.mean() == pytest.approx(8.0, abs=0.15)      # lambda * A = 2e-6 * 4e6
    assert counts.var() == pytest.approx(8.0, rel=0.1)        # Poisson
    assert errs.std(axis=0) == pytest.approx([20.0, 20.0], rel=0.05)
    assert np.abs(errs.mean(axis=0)).max() < 0.5


def test_measurements_pd_and_empty_scans():
    truth = houles_truth(np.arange(91.0))
    rng = np.random.default_rng(6)
    s = houles_measurements(truth, rng, pd=0.0, clutter_density=0.0)
    assert s.z.shape == (0, 2) and np.all(s.target_index == -1)
    assert all(sc.shape == (0, 2) for sc in s.scans())
    s = houles_measurements(truth, rng, pd=0.7, clutter_density=0.0)
    det = s.target_index >= 0
    assert 0.5 < det.mean() < 0.9
    np.testing.assert_array_equal(np.diff(s.offsets), det.astype(int))


def test_measurements_reproducible():
    truth = houles_truth(np.arange(91.0))
    a = houles_measurements(truth, np.random.default_rng(7))
    b = houles_measurements(truth, np.random.default_rng(7))
    for u, v in zip(a, b):
        np.testing.assert_array_equal(u, v)


def test_measurements_bad_input():
    truth = houles_truth(np.arange(5.0))
    rng = np.random.default_rng(0)
    with pytest.raises(TypeError, match="rng"):
        houles_measurements(truth, 42)
    with pytest.raises(ValueError, match="pd"):
        houles_measurements(truth, rng, pd=1.5)
    with pytest.raises(ValueError, match="clutter_density"):
        houles_measurements(truth, rng, clutter_density=-1e-6)
    with pytest.raises(ValueError, match="window"):
        houles_measurements(truth, rng, window=0.0)
    with pytest.raises(ValueError, match="truth"):
        houles_measurements(np.zeros((5, 1)), rng)
    with pytest.raises(ValueError, match="truth"):
        houles_measurements(np.full((5, 4), np.nan), rng)
    with pytest.raises(ValueError, match="times"):
        houles_measurements(truth, rng, times=np.arange(3.0))
