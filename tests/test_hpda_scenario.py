"""Tests for trackcore.scenarios.hpda_scenario (Kim & Song 2007, Table 1)."""
import math

import numpy as np
import pytest
from scipy import stats

from trackcore.scenarios import (HPDA_TABLE1, hpda_parameters, hpda_true_count, hpda_truth,
                                 simulate_hpda_scans)

# death states of the two truth readings: straight flight (A) and the one-turn reading (B)
DEATH_A = [(0, -3000), (2500, 2500), (-3750, 2500), (500, -1000), (1750, 1750), (4000, -3000)]
DEATH_B = [(-1712.7, -2179.0, -0.228, 1.788), (213.7, 2275.7, -0.832, -1.144),
           (-3236.1, 4619.0, 0.868, 0.704), (-1279.3, -769.9, -1.021, -0.720),
           (3114.9, 1274.4, 0.333, -2.095), (2515.8, -1886.3, -1.458, -0.353)]
TURNS = [(63.6, 91, 110), (81.0, 216, 235), (102.5, 266, 285), (91.7, 341, 360),
         (54.0, 366, 385), (76.4, 241, 260)]


def test_truth_variant_a_and_b_death_states():
    a, b = hpda_truth("A"), hpda_truth("B")
    for t in range(6):
        d = a.deaths[t]
        np.testing.assert_allclose(a.states[d, t, :2], DEATH_A[t], atol=1e-6)
        np.testing.assert_allclose(b.states[d, t], DEATH_B[t], atol=0.06)
        # birth state is Table 1's
        np.testing.assert_array_equal(b.states[b.births[t], t], HPDA_TABLE1[t][3])


def test_turns_and_speed_preserved():
    b = hpda_truth("B")
    for t, (deg, k0, k1) in enumerate(TURNS):
        turn = np.nonzero(b.modes[:, t] > 1)[0]
        assert (turn[0], turn[-1]) == (k0, k1)
        v0 = b.states[b.births[t], t, 2:]
        v1 = b.states[b.deaths[t], t, 2:]
        ang = math.degrees(math.atan2(v1[1], v1[0]) - math.atan2(v0[1], v0[0]))
        ang = (ang + 180) % 360 - 180
        assert abs(abs(ang) - deg) < 0.1
        assert (ang > 0) == (t % 2 == 0)  # odd TID (index even) turns left
        assert np.linalg.norm(v1) == pytest.approx(np.linalg.norm(v0), rel=1e-12)
        # acceleration magnitude a_m during the turn (E2)
        dv = np.linalg.norm(b.states[k0, t, 2:] - b.states[k0 - 1, t, 2:]) / 10.0
        assert dv == pytest.approx(0.01, rel=1e-3)


def test_true_count_change_points():
    n = hpda_true_count(hpda_truth())
    assert n.shape == (451,)
    changes = {int(k): int(n[k]) for k in np.nonzero(np.diff(n))[0] + 1}
    assert changes == {100: 2, 150: 4, 201: 3, 250: 4, 300: 5, 351: 3, 401: 2}
    assert n[0] == 1 and n.mean() == pytest.approx(2.785, abs=5e-4)
    assert np.isnan(hpda_truth().states[~hpda_truth().alive]).all()


def test_parameters():
    p1, p2 = hpda_parameters(1), hpda_parameters(2)
    assert (p1.pd, p1.snr, p1.clutter_mean) == (0.9, 10.0, 10.0)
    assert (p2.pd, p2.snr, p2.clutter_mean) == (0.6, 5.0, 50.0)
    assert p1.tau == pytest.approx(1.159, abs=5e-4) and p2.tau == pytest.approx(3.065, abs=5e-4)
    assert p1.clutter_density_xy == pytest.approx(3.18e-8, rel=2e-3)
    with pytest.raises(ValueError, match="case"):
        hpda_parameters(4)


def test_measurement_statistics():
    truth = hpda_truth()
    p = hpda_parameters(2)
    rng = np.random.default_rng(11)
    s = simulate_hpda_scans(truth, p, rng)
    K = 451
    assert s.offsets.shape == (K + 1,) and s.offsets[-1] == s.z.shape[0] == s.amplitude.shape[0]
    n_alive = truth.alive.sum()
    n_det = (s.origin >= 0).sum()
    assert abs(n_det / n_alive - 0.6) < 4 * math.sqrt(0.24 / n_alive)
    n_cl = (s.origin < 0).sum()
    assert abs(n_cl - 50 * K) < 4 * math.sqrt(50 * K)
    assert s.amplitude.min() >= p.tau
    assert np.all(s.z[:, 0] <= p.radius + 300) and np.all(np.abs(s.z[:, 1]) <= math.pi)
    # clutter ranges ~ r^2 / R^2 uniform, amplitudes tau + Exp(1)
    cl = s.origin < 0
    assert stats.kstest((s.z[cl, 0] / p.radius) ** 2, "uniform").pvalue > 1e-3
    assert stats.kstest(s.amplitude[cl] - p.tau, "expon").pvalue > 1e-3
    assert stats.kstest(s.amplitude[~cl] - p.tau, "expon", args=(0, 6.0)).pvalue > 1e-3
    # target measurement noise
    k, t = np.nonzero(truth.alive)
    idx = np.nonzero(s.origin >= 0)[0]
    scans = np.searchsorted(s.offsets, idx, side="right") - 1
    X = truth.states[scans, s.origin[idx]]
    er = s.z[idx, 0] - np.hypot(X[:, 0], X[:, 1])
    eb = (s.z[idx, 1] - np.arctan2(X[:, 1], X[:, 0]) + np.pi) % (2 * np.pi) - np.pi
    assert abs(er.std() / 50 - 1) < 0.1 and abs(eb.std() / math.radians(0.1) - 1) < 0.1
    z0, a0 = s.scan(0)
    assert z0.shape[0] == a0.shape[0] == s.offsets[1]


def test_deterministic_and_empty_scans():
    truth = hpda_truth()
    p = hpda_parameters(1)
    s1 = simulate_hpda_scans(truth, p, np.random.default_rng(5))
    s2 = simulate_hpda_scans(truth, p, np.random.default_rng(5))
    np.testing.assert_array_equal(s1.z, s2.z)
    # no clutter and P_D tiny: many empty scans are valid
    from dataclasses import replace
    q = replace(p, clutter_mean=0.0, pd=1e-6)
    s = simulate_hpda_scans(truth, q, np.random.default_rng(1))
    assert s.z.shape == (s.offsets[-1], 2) and np.sum(np.diff(s.offsets) == 0) > 400


def test_bad_input():
    with pytest.raises(ValueError, match="variant"):
        hpda_truth("C")
    with pytest.raises(TypeError, match="rng"):
        simulate_hpda_scans(hpda_truth(), hpda_parameters(1), 3)
    with pytest.raises(TypeError, match="params"):
        simulate_hpda_scans(hpda_truth(), {"pd": 0.9}, np.random.default_rng())
    with pytest.raises(ValueError, match="T"):
        hpda_truth(T=-1)


def test_trial_runs_every_algorithm_and_delays():
    from trackcore.scenarios import HPDA_ALGORITHMS, hpda_tracker_configs, run_hpda_trial
    cfgs = hpda_tracker_configs(hpda_parameters(1), hpda={"n_particles": 50})
    assert set(cfgs) == set(HPDA_ALGORITHMS) and cfgs["hpda"].n_particles == 50
    out = run_hpda_trial(np.random.default_rng(0), 1, ("hpda",),
                         overrides={"hpda": {"n_particles": 100}})
    rec = out["hpda"]
    assert rec["count"].shape == (451,)
    assert np.all(rec["conf_delay"][~np.isnan(rec["conf_delay"])] >= 0)
    # targets 4 and 5 live to the last scan: no termination delay
    assert np.isnan(rec["term_delay"][3]) and np.isnan(rec["term_delay"][4])
    with pytest.raises(ValueError, match="unknown algorithm"):
        run_hpda_trial(np.random.default_rng(0), 1, ("kalman",))
    with pytest.raises(ValueError, match="unknown algorithm"):
        hpda_tracker_configs(hpda_parameters(1), foo={})


def test_trial_scenario_overrides_change_only_amplitudes():
    from trackcore.scenarios import run_hpda_trial
    a = run_hpda_trial(np.random.default_rng(3), 2, ("phd",),
                       overrides={"phd": {"n_per_target": 100, "n_birth": 50}})
    b = run_hpda_trial(np.random.default_rng(3), 2, ("phd",),
                       overrides={"phd": {"n_per_target": 100, "n_birth": 50}},
                       scenario_overrides={"snr": 3.16})
    # the detection pattern depends on P_D only, so the PHD (no amplitudes) is unchanged
    np.testing.assert_array_equal(a["phd"]["aux"], b["phd"]["aux"])
    assert a["n_measurements"] == b["n_measurements"]


def test_stress_environment():
    p3 = hpda_parameters(3)
    assert (p3.pd, p3.snr) == (0.9, 10.0)
    assert p3.sigma_r == 150.0 and p3.sigma_theta == pytest.approx(math.radians(3.0))
    # one expected false return in a gate S = R, P_G = 0.99, at 5 km
    vg = math.pi * (-2 * math.log(0.01)) * p3.sigma_r * p3.sigma_theta
    assert p3.clutter_density_xy * 5000.0 * vg == pytest.approx(1.0, rel=1e-12)
    assert 250 < p3.clutter_mean < 300


def test_negative_noisy_range_is_reflected():
    from dataclasses import replace
    # a huge range noise makes negative draws common; they come out as positive ranges
    p = replace(hpda_parameters(1), clutter_mean=0.0, sigma_r=3000.0)
    s = simulate_hpda_scans(hpda_truth(n_scans=50), p, np.random.default_rng(0))
    assert s.z[:, 0].min() > 0 and np.all(np.abs(s.z[:, 1]) <= np.pi)


def test_run_metrics_and_perfect_tracker():
    from trackcore.scenarios import HPDA_METRICS, hpda_run_metrics
    from trackcore.trackers import TrackerRun
    truth = hpda_truth()
    K = truth.alive.shape[0]
    n = truth.alive.sum(axis=1)
    est = np.full((K, 8, 4), np.nan)
    for k in range(K):
        est[k, :n[k]] = truth.states[k, truth.alive[k]]
    perfect = TrackerRun(n.copy(), est, np.zeros((K, 8), dtype=np.int64), n.copy(),
                         np.zeros(K))
    m = hpda_run_metrics(perfect, truth)
    assert set(m) == set(HPDA_METRICS)
    assert m["coverage_straight"] == m["coverage_turn"] == 1.0
    assert all(m[k] == 0.0 for k in HPDA_METRICS[:7])
    # one extra estimate 10 km away at every scan: a false track, OSPA and GOSPA false
    est2 = est.copy()
    for k in range(K):
        est2[k, n[k], :2] = (1e4, 1e4)
    extra = perfect._replace(count=n + 1, estimates=est2, n_estimates=n + 1)
    m2 = hpda_run_metrics(extra, truth)
    assert m2["abs_count_error"] == 1.0 and m2["sq_count_error"] == 1.0
    assert m2["false_tracks"] == 1.0 and m2["gospa_missed"] == 0.0
    assert m2["coverage_turn"] == 1.0
    # no estimate at all: nothing covered, every target missed
    none = perfect._replace(count=0 * n, estimates=np.full_like(est, np.nan),
                            n_estimates=0 * n)
    m3 = hpda_run_metrics(none, truth)
    assert m3["coverage_straight"] == m3["coverage_turn"] == 0.0
    assert m3["gospa_missed"] == pytest.approx(np.mean(n) * 500.0 ** 2 / 2)
    assert m2["gospa_false"] == pytest.approx(500.0 ** 2 / 2)
    ospa = np.mean([500.0 / math.sqrt(nk + 1) for nk in n])
    assert m2["ospa"] == pytest.approx(ospa, rel=1e-12)
    with pytest.raises(ValueError, match="p"):
        hpda_run_metrics(perfect, truth, p=0.5)


def test_count_error_intervals():
    from trackcore.scenarios import count_error_ci
    rng = np.random.default_rng(0)
    n_true = np.repeat([1, 3, 2], 20)
    a = n_true + rng.choice([-1, 0, 0, 0, 1], size=(50, 60))
    b = n_true - (rng.random((50, 60)) < 0.4)
    ea = count_error_ci(a, n_true)
    d = a.mean(axis=0) - n_true
    assert ea.value == pytest.approx(np.abs(d).mean()) and ea.lo <= ea.value <= ea.hi
    sb = count_error_ci(b, n_true, kind="s")
    assert sb.value == pytest.approx((b.mean(axis=0) - n_true).mean()) and sb.hi < 0
    diff = count_error_ci(a, n_true, versus=b)
    eb = count_error_ci(b, n_true)
    assert diff.value == pytest.approx(ea.value - eb.value) and diff.hi < 0
    assert count_error_ci(a, n_true, seed=0) == ea
    un = count_error_ci(a, n_true, versus=b[:40], paired=False)
    assert un.value == pytest.approx(ea.value - count_error_ci(b[:40], n_true).value)
    early = count_error_ci(b, n_true, kind="s", early=20)
    assert early.value == pytest.approx((b.mean(axis=0) - n_true)[:20].mean())
    with pytest.raises(ValueError, match="kind"):
        count_error_ci(a, n_true, kind="rmse")
    with pytest.raises(ValueError, match="versus"):
        count_error_ci(a, n_true, versus=b[:10])


def test_count_error_ci_needs_min_runs():
    """Like every interval of trackcore.stats: MIN_RUNS runs per sample at least."""
    from trackcore.scenarios import count_error_ci
    from trackcore.stats import MIN_RUNS
    n_true = np.ones(5)
    c = np.random.default_rng(1).integers(0, 3, (MIN_RUNS, 5)).astype(float)
    assert count_error_ci(c, n_true).n == MIN_RUNS
    with pytest.raises(ValueError, match=f"counts has {MIN_RUNS - 1} runs.*at least {MIN_RUNS}"):
        count_error_ci(c[:-1], n_true)
    with pytest.raises(ValueError, match=f"versus has {MIN_RUNS - 1} runs"):
        count_error_ci(c, n_true, versus=c[:-1], paired=False)
    with pytest.raises(ValueError, match=f"counts has {MIN_RUNS - 1} runs"):
        count_error_ci(c[:-1], n_true, versus=c[:-1])


def test_trial_metrics_and_diagnostics():
    from trackcore.scenarios import HPDA_METRICS, run_hpda_trial
    out = run_hpda_trial(np.random.default_rng(1), 1, ("hpda", "clustering_literal"),
                         overrides={"hpda": {"n_particles": 100}}, metrics=True)
    assert set(out["hpda"]["metrics"]) == set(HPDA_METRICS)
    assert out["hpda"]["diagnostics"].shape == (2, 7)
    assert "diagnostics" not in out["clustering_literal"]


def test_metrics_and_delays_check_their_inputs():
    from trackcore.scenarios import hpda_run_metrics, track_delays
    from trackcore.trackers import TrackerRun
    truth = hpda_truth(n_scans=20)
    K = 20
    run = TrackerRun(np.zeros(K, dtype=np.int64), np.full((K, 4, 4), np.nan),
                     np.full((K, 4), -1), np.zeros(K, dtype=np.int64), np.zeros(K))
    with pytest.raises(TypeError, match="run"):
        hpda_run_metrics({"count": 1}, truth)
    with pytest.raises(TypeError, match="truth"):
        track_delays(run, "truth")
    with pytest.raises(ValueError, match="scans"):
        hpda_run_metrics(run, hpda_truth(n_scans=30))
    with pytest.raises(ValueError, match="radius"):
        track_delays(run, truth, radius=float("nan"))
    conf, term = track_delays(run, truth)
    assert np.isnan(conf[0]) and conf.shape == (6,)


def test_scan_order_is_lexsort():
    """The scans' shuffle (_scan_order) is np.lexsort((key, scan)) exactly, ties in the
    key (broken by index) and empty scans included."""
    from trackcore.scenarios.hpda_scenario import _scan_order

    rng = np.random.default_rng(7)
    for n, K in ((0, 3), (1, 1), (9, 4), (500, 7), (5000, 451)):
        # two runs each sorted by scan, as simulate_hpda_scans concatenates them
        cut = n // 3
        scan = np.concatenate([np.sort(rng.integers(0, K, cut)),
                               np.sort(rng.integers(0, K, n - cut))]).astype(np.int64)
        key = rng.random(n)
        if n >= 9:
            key[: n // 3] = key[n // 3: 2 * (n // 3)]  # exact ties in the key
        offsets = np.zeros(K + 1, dtype=np.int64)
        np.cumsum(np.bincount(scan, minlength=K), out=offsets[1:])
        np.testing.assert_array_equal(_scan_order(scan, key, offsets),
                                      np.lexsort((key, scan)),
                                      err_msg=f"n = {n}, K = {K}: not lexsort's permutation")
