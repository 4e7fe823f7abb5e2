"""Tests for trackcore.scenarios.sprt_acm (the chapter's geometry, ACM measurements)."""
import math

import numpy as np
import pytest

from trackcore.detection import sprt_decide
from trackcore.montecarlo import run, stack_results
from trackcore.scenarios import (sprt_acm_measurements, sprt_acm_monte_carlo, sprt_acm_scenario,
                                 sprt_acm_states, sprt_acm_trial, sprt_acm_truth)

# the chapter's geometry: target / pursuer at t = 0, ranges at t = 0 and 90 s
TABLE = {
    1: ((-653.37, 346.63), (0.0, -1386.0), 1851.7, 712.9),
    2: ((-120.61, 83.90), (358.72, -1338.77), 1501.3, 658.5),
    3: ((-120.61, -516.10), (358.72, -1338.77), 952.1, 274.5),
}


@pytest.mark.parametrize("num", [1, 2, 3])
def test_geometry_matches_table(num):
    sc = sprt_acm_scenario(num)
    own, tgt, acm = sprt_acm_states(sc, np.array([0.0, 60.0, 90.0]))
    t0, o0, r0, r90 = TABLE[num]
    np.testing.assert_allclose(tgt[0, :2], t0, atol=0.01)
    np.testing.assert_allclose(own[0, :2], o0, atol=0.01)
    np.testing.assert_allclose(own[1, :2], [0, 0], atol=1e-9)
    np.testing.assert_allclose(tgt[1, :2], [0, sc.R0], atol=1e-9)
    np.testing.assert_allclose(acm, [0, sc.R0])
    assert math.hypot(*(tgt[0, :2] - own[0, :2])) == pytest.approx(r0, abs=0.1)
    assert math.hypot(*(tgt[2, :2] - own[2, :2])) == pytest.approx(r90, abs=0.1)


def test_turns_timing_and_speed():
    sc = sprt_acm_scenario(2)
    t = np.array([59.0, 60.0, 60.5, 60.9071, 61.2095, 75.0])
    own, tgt, _ = sprt_acm_states(sc, t)
    np.testing.assert_allclose(np.hypot(tgt[:, 2], tgt[:, 3]), 15.4, rtol=1e-12)
    np.testing.assert_allclose(np.hypot(own[:, 2], own[:, 3]), 23.1, rtol=1e-12)
    course = lambda v: np.degrees(np.arctan2(v[..., 0], v[..., 1]))   # clockwise from north
    assert course(tgt[0, 2:]) == pytest.approx(7.5)
    assert course(tgt[4, 2:]) == pytest.approx(52.5, abs=0.01)       # 45 deg right by 61.21 s
    assert course(tgt[5, 2:]) == pytest.approx(52.5, abs=0.01)
    assert course(own[3, 2:]) == pytest.approx(7.5, abs=0.01)         # 22.5 deg right by 60.91 s
    # turn path continuity (lateral acceleration 10 m/s^2): position is continuous at the ends
    eps = 1e-6
    a, b, _ = sprt_acm_states(sc, np.array([61.2095 - eps, 61.2095 + eps]))
    assert np.max(np.abs(np.diff(b[:, :2], axis=0))) < 1e-3


def test_acm_measurements_noiseless_structure():
    sc = sprt_acm_scenario(1, sigma_r=1e-9, sigma_theta=1e-12, sigma_rdot=1e-9)
    truth = sprt_acm_truth(sc)
    z = sprt_acm_measurements(sc, np.random.default_rng(0), truth)
    own = truth.own[truth.n_pre:]
    d = truth.acm - own[:, :2]
    r = np.hypot(d[:, 0], d[:, 1])
    tau = truth.times[truth.n_pre:] - 60.0
    np.testing.assert_allclose(z.z_b[:, 0], r + 12.8 * tau, atol=1e-6)
    np.testing.assert_allclose(z.z_b[:, 2], -(own[:, 2] * d[:, 0] + own[:, 3] * d[:, 1]) / r + 12.8,
                               atol=1e-6)
    # S1: pursuer heads straight at the ACM, constant bearing 90 deg, closing at 23.1 m/s
    np.testing.assert_allclose(z.z_b[:, 1], math.pi / 2, atol=1e-9)
    np.testing.assert_allclose(z.z_b[:, 2], -23.1 + 12.8, atol=1e-6)
    # the target's Doppler at release: 10.889 - 23.1 along the LOS
    assert z.z_a[0, 2] == pytest.approx(15.4 * math.cos(math.radians(45)) - 23.1, abs=1e-6)
    assert sc.n_pre == 30 and sc.n_post == 16 and sprt_acm_scenario(3).n_post == 31
    sw = sprt_acm_measurements(sc, np.random.default_rng(0), truth, h1_true=True)
    np.testing.assert_array_equal(sw.z_a, z.z_b)


def test_monte_carlo_equals_montecarlo_run():
    sc = sprt_acm_scenario(3)
    batch = sprt_acm_monte_carlo(sc, 4, 99)
    per_run = stack_results(run(sprt_acm_trial, 4, 99, args=(sc,)))
    np.testing.assert_allclose(batch.llr, per_run.llr, rtol=1e-12, atol=1e-12)
    assert sprt_acm_monte_carlo(sc, 0, 1).llr.shape == (0, sc.n_post)


def test_s1_discriminates_mostly_correctly():
    # coarse sanity check (200 runs); the notebook asserts the paper's targets at 100/1000 runs
    sc = sprt_acm_scenario(1)
    res = sprt_acm_monte_carlo(sc, 200, 11)
    d, k = sprt_decide(res.llr, -sc.gamma, sc.gamma)
    assert res.ok.all()
    assert 0.85 < np.mean(d == 0) < 0.99
    assert 4.0 < k[d == 0].mean() < 7.0
    # H1 true: mirror image
    res1 = sprt_acm_monte_carlo(sc, 200, 11, h1_true=True)
    d1, _ = sprt_decide(res1.llr, -sc.gamma, sc.gamma)
    assert 0.85 < np.mean(d1 == 1) < 0.99


def test_target_process_noise_option_changes_truth_only_after_release():
    sc = sprt_acm_scenario(1, target_accel_psd=4.0)
    truth = sprt_acm_truth(sc)
    z0 = sprt_acm_measurements(sprt_acm_scenario(1), np.random.default_rng(3), truth)
    z1 = sprt_acm_measurements(sc, np.random.default_rng(3), truth)
    assert z1.z_pre.shape == z0.z_pre.shape and not np.allclose(z1.z_a[3:], z0.z_a[3:])


def test_bad_input():
    with pytest.raises(ValueError, match="number"):
        sprt_acm_scenario(4)
    with pytest.raises(TypeError, match="unknown"):
        sprt_acm_scenario(1, speed=3)
    with pytest.raises(ValueError, match="T"):
        sprt_acm_scenario(1, T=0.0)
    with pytest.raises(ValueError, match="multiples"):
        sprt_acm_scenario(1, T=7.0)
    with pytest.raises(ValueError, match="target_accel_psd"):
        sprt_acm_scenario(1, target_accel_psd=-1.0)
    with pytest.raises(TypeError, match="rng"):
        sprt_acm_measurements(sprt_acm_scenario(1), 42)
    with pytest.raises(TypeError, match="scenario"):
        sprt_acm_truth("S1")
    with pytest.raises(ValueError, match="n_runs"):
        sprt_acm_monte_carlo(sprt_acm_scenario(1), -1, 0)
    with pytest.raises(ValueError, match="t"):
        sprt_acm_states(sprt_acm_scenario(1), np.zeros((2, 2)))
