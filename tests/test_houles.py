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


# ---------------------------------------------------------------- the experiment and Table 1
from trackcore.scenarios import (HOULES_TIMES, failure_anatomy, gate_miss_failures,  # noqa: E402
                                 houles_imm_trial, houles_table, houles_windows,
                                 position_failures, rmse_estimate, rmse_estimate_mse,
                                 rmse_ratio, rmse_ratio_mse, window_mse)
from trackcore.stats import Estimate, ratio_ci  # noqa: E402
from trackcore.trackers import (car_imm_model_set, cv_model_set,  # noqa: E402
                                tom_imm_model_set)


def _values(est_rows):
    return np.array([[e.value for e in row] for row in est_rows])


def test_windows_and_aggregation_identity():
    man, non = houles_windows()
    assert man.sum() == 40 and non.sum() == 50 and HOULES_TIMES[0] == 1 and HOULES_TIMES[-1] == 90
    assert man[HOULES_TIMES == 21][0] and man[HOULES_TIMES == 40][0]
    assert not man[HOULES_TIMES == 20][0] and not man[HOULES_TIMES == 41][0]
    e = np.random.default_rng(0).exponential(300.0, size=(50, 2, 90))
    tab = houles_table(e, np.zeros((50, 2), bool))
    rm = _values(tab.rmse)
    np.testing.assert_allclose(rm[:, 0] ** 2, 4 / 9 * rm[:, 1] ** 2 + 5 / 9 * rm[:, 2] ** 2,
                               rtol=1e-12)
    np.testing.assert_allclose(rm[:, 0], np.sqrt(e.mean(axis=(0, 2))), rtol=1e-12)
    np.testing.assert_allclose(_values(tab.ratio)[0], 1.0)
    assert all(isinstance(x, Estimate) and x.lo <= x.value <= x.hi
               for row in tab.rmse + tab.ratio + tab.ratio_common for x in row)
    np.testing.assert_allclose(tab.rmse_all, rm)
    np.testing.assert_allclose(window_mse(e).mean(axis=0), rm**2, rtol=1e-12)
    # with no failure the two survivor definitions agree
    np.testing.assert_allclose(_values(tab.ratio), _values(tab.ratio_common), rtol=1e-12)
    assert tab.n_common == 50 and list(tab.n_ok) == [50, 50]


def test_table_excludes_failed_runs():
    e = np.full((4, 1, 90), 100.0)
    e[0, 0, 10] = 1e6
    failed = position_failures(e, 200.0)
    np.testing.assert_array_equal(failed, [[True], [False], [False], [False]])
    tab = houles_table(e, failed)
    np.testing.assert_allclose(_values(tab.rmse), 10.0)
    assert tab.fail_rate[0].value == pytest.approx(0.25)
    assert tab.fail_rate[0].method == "Wilson"
    assert tab.rmse_all[0, 0] > 10.0


def test_ratio_survivor_definitions():
    rng = np.random.default_rng(5)
    e = rng.exponential(400.0, size=(200, 3, 90))
    e[:, 1] *= 0.64                       # filter 1 has 80 % of filter 0's RMSE
    e[:20, 2, 30] = 1e6                   # filter 2 fails on 20 runs
    e[10:40, 0, 50] = 1e6                 # filter 0 fails on 30 runs (10 shared)
    failed = position_failures(e)
    own = rmse_ratio(e, failed, 1, 0)
    ok0, ok1 = ~failed[:, 0], ~failed[:, 1]
    m = window_mse(e)[:, :, 0]
    assert own.value == pytest.approx(np.sqrt(m[ok1, 1].mean() / m[ok0, 0].mean()), rel=1e-12)
    assert own.lo < own.value < own.hi
    com = rmse_ratio(e, failed, 1, 0, survivors="common")
    keep = ~failed.any(axis=1)
    assert keep.sum() == 200 - 40
    ref = ratio_ci(m[keep, 1], m[keep, 0])
    assert com.value == pytest.approx(np.sqrt(ref.value), rel=1e-12)
    assert (com.lo, com.hi) == pytest.approx((np.sqrt(ref.lo), np.sqrt(ref.hi)), rel=1e-12)
    assert com.contains(0.8)
    man = rmse_ratio(e, failed, 1, 0, window="manoeuvring")
    assert man.value == pytest.approx(0.8, rel=0.05)
    r0 = rmse_estimate(e, failed, 0, window="non-manoeuvring")
    _, non = houles_windows()
    assert r0.value == pytest.approx(np.sqrt(e[ok0, 0][:, non].mean()), rel=1e-12)
    with pytest.raises(ValueError, match="survivors"):
        rmse_ratio(e, failed, 1, 0, survivors="all")
    with pytest.raises(ValueError, match="window"):
        rmse_ratio(e, failed, 1, 0, window="turns")
    with pytest.raises(ValueError, match="num"):
        rmse_ratio(e, failed, 3, 0)


def test_rmse_from_window_mse_is_bit_identical():
    """The stored-metric path (per-run window mean squares computed run by run) gives the
    same estimates, bit for bit, as the error-series path."""
    rng = np.random.default_rng(11)
    e = rng.exponential(400.0, size=(120, 3, 90))
    e[:15, 2, 30] = 1e6
    e[10:30, 0, 50] = 1e6
    failed = position_failures(e)
    m = np.stack([window_mse(e[i]) for i in range(len(e))])  # as the store holds them
    assert m.tobytes() == window_mse(e).tobytes()
    np.testing.assert_array_equal(failed, e.max(axis=-1) > 200.0**2)
    for w in ("total", "manoeuvring", "non-manoeuvring"):
        assert rmse_estimate_mse(m, failed, 2, window=w) == rmse_estimate(e, failed, 2, window=w)
        for surv in ("own", "common"):
            assert rmse_ratio_mse(m, failed, 2, 0, window=w, survivors=surv) == \
                rmse_ratio(e, failed, 2, 0, window=w, survivors=surv)
    with pytest.raises(ValueError, match="mse must have shape"):
        rmse_estimate_mse(e, failed, 0)
    with pytest.raises(ValueError, match="non-negative"):
        rmse_ratio_mse(-m, failed, 1, 0)
    with pytest.raises(ValueError, match="failed must be a bool array"):
        rmse_estimate_mse(m, failed[:, :2], 0)


def test_failure_anatomy():
    e = np.full((3, 90), 100.0)
    e[0, 20:] = 1e6          # lost at t = 21 s and never recovered
    e[1, 40:45] = 1e6        # lost at t = 41 s for 5 scans, recovered
    a = failure_anatomy(e)
    np.testing.assert_array_equal(a.failed, [True, True, False])
    np.testing.assert_array_equal(a.onset[:2], [21.0, 41.0])
    assert np.isnan(a.onset[2])
    np.testing.assert_array_equal(a.permanent, [True, False, False])
    np.testing.assert_array_equal(a.time_lost, [70, 5, 0])
    np.testing.assert_array_equal(a.failed, position_failures(e))


def test_gate_miss_failures():
    g = np.array([[1, 0, 0, -1, 0, 1],    # 3 misses with a missed detection inside
                  [0, 0, 1, 0, 0, 1],     # never 3 in a row
                  [-1, -1, -1, -1, 1, 1]], dtype=np.int8)
    np.testing.assert_array_equal(gate_miss_failures(g, 3), [True, False, False])
    np.testing.assert_array_equal(gate_miss_failures(g, 2), [True, True, False])
    with pytest.raises(TypeError, match="target_gated"):
        gate_miss_failures(np.zeros(3))
    with pytest.raises(ValueError, match="n_consecutive"):
        gate_miss_failures(g, 0)
    with pytest.raises(ValueError, match="target_gated"):   # codes other than 1, 0, -1
        gate_miss_failures(np.array([[1, 2, 0]], dtype=np.int8))


def test_failure_comparison():
    from trackcore.scenarios import failure_comparison
    from trackcore.stats import mcnemar_exact
    rng = np.random.default_rng(7)
    fa = rng.random(400) < 0.10
    fb = fa & (rng.random(400) < 0.3)            # B fails only where A does, less often
    failed = np.column_stack([fa, fb])
    c = failure_comparison(failed, 0, 1)
    assert c.only_a == int(np.sum(fa & ~fb)) and c.only_b == 0
    assert c.p_value == mcnemar_exact(c.only_a, 0) and c.p_value < 1e-6
    assert c.difference.value == pytest.approx(fa.mean() - fb.mean())
    assert c.difference.lo > 0
    same = failure_comparison(np.column_stack([fa, fa]), 0, 1)
    assert same.difference.value == 0 and same.p_value == 1.0
    # no discordant run is a tie with an interval of its own, not a zero-width one
    assert same.difference.lo < 0 < same.difference.hi
    with pytest.raises(ValueError, match="failed"):
        failure_comparison(failed.astype(int), 0, 1)
    with pytest.raises(ValueError, match="b"):
        failure_comparison(failed, 0, 2)


def test_trial_shapes_and_common_random_numbers():
    sets = [car_imm_model_set(), tom_imm_model_set()]
    r = houles_imm_trial(np.random.default_rng(3), sets)
    assert r.pos_err2.shape == (2, 90) and r.nees.shape == (2, 89) and r.mu.shape == (2, 89, 3)
    assert r.nees_pos.shape == r.nees_vel.shape == (2, 89) and r.pred_err.shape == (2, 89, 2)
    assert r.pos_err2[0, 0] == r.pos_err2[1, 0]  # same initialisation
    assert set(np.unique(r.target_gated)) <= {0, 1}
    # the same run with one filter gives the same numbers for that filter
    r1 = houles_imm_trial(np.random.default_rng(3), sets[:1])
    np.testing.assert_array_equal(r1.pos_err2[0], r.pos_err2[0])
    assert np.all(np.isfinite(r.nees)) and np.all(r.nis[np.isfinite(r.nis)] >= 0)
    assert np.all(r.nees_pos >= 0) and np.all(r.nees_vel >= 0)
    rm = houles_imm_trial(np.random.default_rng(4), sets[:1], pd=0.5)
    assert np.any(rm.target_gated == -1) and np.any(np.isnan(rm.nis))
    with pytest.raises(TypeError, match="model_sets"):
        houles_imm_trial(np.random.default_rng(3), sets[0])
    with pytest.raises(TypeError, match=r"model_sets\[1\]"):
        houles_imm_trial(np.random.default_rng(3), [sets[0], "TOM"])


def test_prediction_error_frame():
    """A CV Kalman filter without clutter: the predicted-position error equals the
    combined estimate of the previous scan moved by its velocity, in the target frame."""
    from trackcore.trackers import imm_pdaf_track, two_point_init
    from trackcore.scenarios import houles_measurements, houles_truth

    r = houles_imm_trial(np.random.default_rng(8), [cv_model_set()], clutter_density=0.0,
                         pg=1.0)
    s = houles_measurements(houles_truth(np.arange(91.0)), np.random.default_rng(8),
                            clutter_density=0.0)
    R = 400.0 * np.eye(2)
    x0, P0 = two_point_init(s.z[0], s.z[1], R)
    res = imm_pdaf_track(cv_model_set(), list(s.z[2:, None, :]), x0, P0, R, pg=1.0,
                         clutter_density=0.0)
    truth = houles_truth(np.arange(2.0, 91.0))
    pred = np.vstack([x0[:2] + x0[2:], res.x[:-1, :2] + res.x[:-1, 2:]])
    err = pred - truth[:, :2]
    fwd = truth[:, 2:] / np.linalg.norm(truth[:, 2:], axis=1)[:, None]
    np.testing.assert_allclose(r.pred_err[0, :, 0], np.sum(err * fwd, axis=1), atol=1e-8)
    np.testing.assert_allclose(r.pred_err[0, :, 1], fwd[:, 1] * err[:, 0] - fwd[:, 0] * err[:, 1],
                               atol=1e-8)


def test_table_bad_inputs():
    e = np.ones((5, 2, 90))
    ok = np.zeros((5, 2), bool)
    with pytest.raises(ValueError, match="pos_err2"):
        houles_table(np.ones((5, 2, 80)), ok)
    with pytest.raises(ValueError, match="failed"):
        houles_table(e, np.zeros((5, 3), bool))
    with pytest.raises(ValueError, match="reference"):
        houles_table(e, ok, reference=2)
    with pytest.raises(ValueError, match="pos_err2"):
        position_failures(-np.ones((2, 90)))
    with pytest.raises(ValueError, match="threshold"):
        position_failures(np.ones((2, 90)), threshold=0.0)
    with pytest.raises(ValueError, match="pos_err2"):
        failure_anatomy(np.ones((2, 80)))
