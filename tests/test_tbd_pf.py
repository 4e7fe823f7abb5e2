"""Tests for trackcore.trackers.tbd_pf (chapter 003: TBD trackers A, B, C and extension P)."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from trackcore.core.logmath import logsumexp
from trackcore.detection import log_marcum_detection_probability
from trackcore.filters import effective_sample_size, noise_factor, propagate_linear
from trackcore.models import cv_process_noise, cv_transition
from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
from trackcore.trackers import (TBD_PSEUDO_SIGMA, TbdTrackerConfig, detection_snr_cap,
                                direct_particle_log_weights, pseudo_measurement_errors,
                                radial_velocity, range_azimuth_elevation,
                                range_azimuth_elevation_jacobian, run_tbd_tracker,
                                spherical_to_cartesian, tbd_measurement_errors, tbd_nees,
                                tbd_position_errors, tbd_run_outcomes, tbd_track_lost,
                                weighted_mean_detection)
from trackcore.detection import marcum_miss_probability
import _truth  # tests/_truth.py (shared truth helper)

P0 = np.diag([300.0 ** 2] * 3 + [20.0 ** 2] * 3)


def scans_from_list(scan_list):
    """Flat scan arrays from a list of (positions, range_rate, snr) per scan."""
    pos = [np.asarray(s[0], float).reshape(-1, 3) for s in scan_list]
    off = np.zeros(len(pos) + 1, dtype=np.int64)
    np.cumsum([p.shape[0] for p in pos], out=off[1:])
    return SimpleNamespace(positions=np.vstack(pos) if pos else np.zeros((0, 3)),
                           range_rate=np.concatenate([np.asarray(s[1], float) for s in scan_list]),
                           snr=np.concatenate([np.asarray(s[2], float) for s in scan_list]),
                           offsets=off)


def straight_track(K=30, x0=(30e3, 10e3, 5e3, -150.0, 50.0, 0.0)):
    return _truth.straight_track(K, x0)


# ----------------------------------------------------------------------------- errata
def test_erratum2_dwna_q_matches_sampled_gamma_a():
    # eq (3) corrected: w = Gamma a, a ~ N(0, sigma^2 I) has covariance Q of the DWNA model
    T, sa = 1.0, 15.0
    Gamma = np.vstack([0.5 * T ** 2 * np.eye(3), T * np.eye(3)])
    rng = np.random.default_rng(1)
    w = rng.standard_normal((100_000, 3)) * sa @ Gamma.T
    Q = cv_process_noise(T, sa ** 2, dim=3, kind="dwna")
    emp = np.cov(w.T)
    d = np.sqrt(np.diag(Q))
    assert np.max(np.abs(emp - Q) / np.outer(d, d)) < 0.02
    # the particle propagation (foundation kernel with the rank-3 factor) has the same covariance
    X = propagate_linear(np.zeros((100_000, 6)), cv_transition(T, 3), Q, rng)
    assert np.max(np.abs(np.cov(X.T) - Q) / np.outer(d, d)) < 0.02
    assert noise_factor(Q).shape == (6, 3)
    # the printed "W" vector is not diag(Q) (nor dimensionally a noise sample)
    printed = np.array([0.5 * sa ** 2 * T ** 2] * 3 + [sa ** 2 * T] * 3)
    assert not np.allclose(printed, np.diag(Q))


def test_erratum4_weighted_mean_of_equal_points_returns_the_point():
    p = np.array([[31e3, 20e3, 7e3]] * 4)
    pbar, rbar = weighted_mean_detection(p, [-180.0, -170.0, 10.0, 100.0], [3.0, 10.0, 20.0, 4.0],
                                         [31.1e3, 20e3, 7e3], -180.0, 150.0, 40.0, 1e-6)
    np.testing.assert_allclose(pbar, p[0], rtol=1e-14)
    # the printed (1/m) sum w_j x_j would shrink it towards the radar by 1/m
    assert np.linalg.norm(p[0] / 4) < np.linalg.norm(pbar) / 3


def test_weighted_mean_formula():
    rng = np.random.default_rng(3)
    p = rng.normal(0, 500, (6, 3)) + [30e3, 20e3, 7e3]
    rr = rng.normal(-150, 50, 6)
    snr = rng.uniform(2, 30, 6)
    ref = np.array([30e3, 20e3, 7e3])
    w = np.exp(log_marcum_detection_probability(snr, 1e-6)
               - np.linalg.norm(p - ref, axis=1) / 150.0 - np.abs(rr + 160.0) / 40.0)
    w /= w.sum()
    pbar, rbar = weighted_mean_detection(p, rr, snr, ref, -160.0, 150.0, 40.0, 1e-6)
    np.testing.assert_allclose(pbar, w @ p, rtol=1e-12)
    assert rbar == pytest.approx(w @ rr, rel=1e-12)
    # m = 0: no pseudo-measurement; all weights underflowing: none either
    assert weighted_mean_detection(np.zeros((0, 3)), [], [], ref, 0.0, 150.0, 40.0, 1e-6) == (None, None)
    far = np.array([[1e11, 0.0, 0.0]])
    assert weighted_mean_detection(far, [0.0], [5.0], ref, 0.0, 1e-300, 40.0, 1e-6) == (None, None)
    with pytest.raises(ValueError, match="positions"):
        weighted_mean_detection(far * 1e290, [0.0], [5.0], ref, 0.0, 1.0, 40.0, 1e-6)


def test_direct_weights_match_brute_force():
    rng = np.random.default_rng(4)
    X = np.column_stack([rng.normal(30e3, 300, (50, 3)), rng.normal(-150, 20, (50, 3))])
    p = rng.normal(30e3, 800, (7, 3))
    rr = rng.normal(-150, 80, 7)
    snr = rng.uniform(3, 40, 7)
    got = direct_particle_log_weights(X, p, rr, snr, 150.0, 40.0, 1e-6)
    lpd = log_marcum_detection_probability(snr, 1e-6)
    d = np.linalg.norm(X[:, None, :3] - p[None], axis=2)
    rd = radial_velocity(X)
    want = logsumexp(lpd[None] - d / 150.0 - np.abs(rd[:, None] - rr[None]) / 40.0, axis=1)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    gauss = direct_particle_log_weights(X, p, rr, snr, 150.0, 40.0, 1e-6, kernel="gaussian")
    want_g = logsumexp(lpd[None] - 0.5 * (d / 150.0) ** 2
                       - 0.5 * (np.abs(rd[:, None] - rr[None]) / 40.0) ** 2, axis=1)
    np.testing.assert_allclose(gauss, want_g, rtol=1e-12)
    with pytest.raises(ValueError, match="kernel"):
        direct_particle_log_weights(X, p, rr, snr, 150.0, 40.0, 1e-6, kernel="cauchy")
    # m = 0 leaves the weights unchanged (zero log-likelihood)
    np.testing.assert_array_equal(direct_particle_log_weights(X, np.zeros((0, 3)), [], [], 150.0,
                                                              40.0, 1e-6), np.zeros(50))
    # far-away particles: weights underflow in linear space but stay finite in log space
    far = direct_particle_log_weights(X + 1e7, p, rr, snr, 1.0, 40.0, 1e-6)
    assert np.all(np.isfinite(far)) and np.all(np.exp(far) == 0.0)


def test_erratum7_ess():
    assert effective_sample_size(np.zeros(600)) == pytest.approx(600.0)
    w = np.array([0.5, 0.25, 0.25])
    assert effective_sample_size(np.log(w)) == pytest.approx(1.0 / np.sum(w ** 2))
    # as printed, 1 / sum(w) is always 1
    assert 1.0 / w.sum() == 1.0


# ----------------------------------------------------------------------------- geometry
def test_geometry_roundtrip_and_jacobian():
    rng = np.random.default_rng(5)
    X = np.column_stack([rng.uniform(-5e4, 5e4, (20, 2)), rng.uniform(1e3, 8e3, 20),
                         rng.normal(0, 200, (20, 3))])
    z = range_azimuth_elevation(X)
    np.testing.assert_allclose(spherical_to_cartesian(z), X[:, :3], rtol=1e-12, atol=1e-8)
    x = X[0]
    H = range_azimuth_elevation_jacobian(x, with_doppler=True)

    def h(s):
        return np.r_[range_azimuth_elevation(s), radial_velocity(s)]
    num = np.empty((4, 6))
    for j in range(6):
        e = np.zeros(6)
        step = 1e-3 if j < 3 else 1e-4
        e[j] = step
        num[:, j] = (h(x + e) - h(x - e)) / (2 * step)
    np.testing.assert_allclose(H, num, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(range_azimuth_elevation_jacobian(x), H[:3])
    with pytest.raises(ValueError, match="range 0"):
        range_azimuth_elevation(np.zeros(6))
    with pytest.raises(ValueError, match="x must"):
        range_azimuth_elevation_jacobian(np.zeros(5))


# ----------------------------------------------------------------------------- trackers
def clean_scans(truth, rng, sigma=25.0):
    """Target-only scans (one detection per scan) with Cartesian noise, SNR 20."""
    K = truth.shape[0]
    p = truth[:, :3] + rng.normal(0, sigma, (K, 3))
    return scans_from_list([(p[k], [radial_velocity(truth[k])], [20.0]) for k in range(K)])


@pytest.mark.parametrize("method,kernel", [("A", "laplace"), ("B", "laplace"), ("C", "laplace"),
                                           ("P", "laplace"), ("B", "gaussian"), ("C", "gaussian")])
def test_trackers_follow_a_clean_target(method, kernel):
    truth = straight_track(40)
    rng = np.random.default_rng(6)
    scans = clean_scans(truth, rng)
    cfg = TbdTrackerConfig(method=method, n_particles=400, processing_radius=2000.0, kernel=kernel,
                           pseudo_sigma=30.0)
    res = run_tbd_tracker(scans, truth[0] + [200, -100, 50, 10, -5, 0], P0, rng, cfg)
    e = tbd_position_errors(res.estimates, truth)
    assert np.mean(e[10:]) < 120.0
    assert not tbd_track_lost(e)
    assert np.all(res.n_processed == 1)
    assert res.processed.all()
    if method == "A":
        assert res.accepted[1:].all() and np.all(np.isnan(res.ess))
        assert np.all(np.isfinite(res.nis[1:]))
    else:
        assert np.all((res.ess >= 1.0) & (res.ess <= 400.0 + 1e-9))
        assert np.all(np.isnan(res.nis))
    # the covariance is a covariance, and (except for P, whose 2 m/s range-rate likelihood
    # collapses the velocity spread of 400 particles) the NEES is of the order of the
    # state dimension
    assert np.all(np.linalg.eigvalsh(res.covariances) > 0)
    if method != "P":
        assert np.median(tbd_nees(res.estimates, res.covariances, truth)[10:]) < 30.0


def test_empty_scans_are_prediction_only():
    truth = straight_track(15)
    empty = scans_from_list([(np.zeros((0, 3)), [], [])] * 15)
    x0 = truth[0]
    for method in "ABCP":
        res = run_tbd_tracker(empty, x0, P0, np.random.default_rng(7),
                              TbdTrackerConfig(method=method, n_particles=2000))
        assert np.all(res.n_processed == 0) and res.processed.shape == (0,)
        if method == "A":
            np.testing.assert_allclose(res.estimates, truth, rtol=1e-12)
        else:
            # uniform weights all along (no update, no resampling): N_eff = N
            np.testing.assert_allclose(res.ess, 2000.0)
            assert not res.resampled.any()
            # mean of the propagated cloud follows the CV prediction (Monte Carlo error)
            e = tbd_position_errors(res.estimates, truth)
            assert np.max(e) < 150.0


def test_sis_weights_are_kept_without_resampling():
    # two scans, no resampling: the final weights are the product of both scans' terms
    truth = straight_track(2, x0=(30e3, 10e3, 5e3, 0.0, 0.0, 0.0))
    rng = np.random.default_rng(8)
    scans = clean_scans(truth, rng)
    cfg = TbdTrackerConfig(method="C", n_particles=300, sigma_a=0.0, resample_threshold=0.0)
    P_small = np.diag([100.0 ** 2] * 3 + [1e-6] * 3)
    res = run_tbd_tracker(scans, truth[0], P_small, np.random.default_rng(9), cfg)
    # reproduce: draw the same particles, weight with both scans (sigma_a = 0: static)
    g = np.random.default_rng(9)
    X = truth[0] + g.standard_normal((300, 6)) @ np.linalg.cholesky(P_small).T
    lw = np.zeros(300)
    for k in range(2):
        if k:
            X = X @ cv_transition(1.0, dim=3).T  # sigma_a = 0: deterministic prediction
        pos, rr, snr = (scans.positions[k:k + 1], scans.range_rate[k:k + 1], scans.snr[k:k + 1])
        lw += direct_particle_log_weights(X, pos, rr, snr, 150.0, 40.0, 1e-6)
    w = np.exp(lw - lw.max())
    w /= w.sum()
    np.testing.assert_allclose(res.estimates[1], w @ X, rtol=1e-10)
    assert res.ess[1] == pytest.approx(1.0 / np.sum(w ** 2), rel=1e-10)
    # erratum 3: the weighted estimate differs from the plain particle mean
    assert np.linalg.norm(res.estimates[1, :3] - X[:, :3].mean(axis=0)) > 1.0


def test_gate_rejects_far_pseudo_measurement():
    truth = straight_track(3)
    far = truth[:, :3] + [2000.0, 0.0, 0.0]
    scans = scans_from_list([(far[k], [radial_velocity(truth[k])], [50.0]) for k in range(3)])
    gated = run_tbd_tracker(scans, truth[0], np.diag([30.0 ** 2] * 3 + [5.0 ** 2] * 3),
                            np.random.default_rng(0), TbdTrackerConfig(method="A"))
    assert not gated.accepted.any()
    np.testing.assert_allclose(gated.estimates, truth, rtol=1e-12)
    literal = run_tbd_tracker(scans, truth[0], np.diag([30.0 ** 2] * 3 + [5.0 ** 2] * 3),
                              np.random.default_rng(0), TbdTrackerConfig(method="A", gate=math.inf))
    assert literal.accepted.all()


def test_scenario_run_is_deterministic_and_c_beats_a():
    truth = tbd_radar_truth()
    sc = simulate_tbd_radar(truth, TbdRadarParameters(), np.random.default_rng(12))
    cfg = TbdTrackerConfig(method="C", n_particles=300)
    r1 = run_tbd_tracker(sc, truth.states[0], P0, np.random.default_rng(1), cfg)
    r2 = run_tbd_tracker(sc, truth.states[0], P0, np.random.default_rng(1), cfg)
    np.testing.assert_array_equal(r1.estimates, r2.estimates)
    e = tbd_position_errors(r1.estimates, truth.states)
    assert not tbd_track_lost(e)
    assert np.mean(e) < 300.0
    # only detections within R of the prediction are processed
    assert np.all(r1.n_processed == np.bincount(sc.scan_index[r1.processed], minlength=250))
    assert r1.n_processed.mean() < 15.0
    d = np.linalg.norm(sc.positions - r1.window_centers[sc.scan_index], axis=1)
    np.testing.assert_array_equal(r1.processed, d <= 2500.0)
    m_err = tbd_measurement_errors(sc.positions, sc.offsets, truth.states, r1.processed)
    assert np.nanmean(m_err) > np.mean(e)  # the filter beats the raw detections


def test_metrics():
    e = np.r_[np.zeros(5), np.full(9, 2000.0), np.zeros(3), np.full(10, 1500.0)]
    assert tbd_track_lost(e)
    assert not tbd_track_lost(e[:17])
    assert not tbd_track_lost(np.zeros(20))
    from trackcore.trackers import tbd_loss_onset
    assert tbd_loss_onset(e) == 17 and tbd_loss_onset(e[:17]) == -1
    assert tbd_loss_onset(e, consecutive=5) == 5
    est = np.zeros((3, 6))
    tru = np.zeros((3, 6))
    tru[:, 0] = [3.0, 4.0, 0.0]
    np.testing.assert_allclose(tbd_position_errors(est, tru), [3.0, 4.0, 0.0])
    pos = np.array([[1.0, 0, 0], [3.0, 0, 0], [0.0, 0, 0]])
    out = tbd_measurement_errors(pos, np.array([0, 2, 2, 3]), np.zeros((3, 6)))
    np.testing.assert_allclose(out, [2.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="truth"):
        tbd_measurement_errors(pos, np.array([0, 2, 3]), np.zeros((3, 6)))


# ----------------------------------------------------------------------------- bad input
def test_config_bad_input():
    with pytest.raises(ValueError, match="method"):
        TbdTrackerConfig(method="D")
    with pytest.raises(ValueError, match="n_particles"):
        TbdTrackerConfig(n_particles=0)
    for bad in (0.0, 1.0, 1.5):
        with pytest.raises(ValueError, match="pfa"):
            TbdTrackerConfig(pfa=bad)
    with pytest.raises(ValueError, match="sigma_r"):
        TbdTrackerConfig(sigma_r=-1.0)
    with pytest.raises(ValueError, match="gate"):
        TbdTrackerConfig(gate=0.0)
    with pytest.raises(ValueError, match="kernel"):
        TbdTrackerConfig(kernel="cauchy")
    with pytest.raises(ValueError, match="processing_radius"):
        TbdTrackerConfig(processing_radius=float("nan"))


def test_run_bad_input():
    truth = straight_track(3)
    good = clean_scans(truth, np.random.default_rng(0))
    rng = np.random.default_rng(0)
    with pytest.raises(TypeError, match="scans"):
        run_tbd_tracker(object(), truth[0], P0, rng)
    with pytest.raises(TypeError, match="rng"):
        run_tbd_tracker(good, truth[0], P0, 42)
    with pytest.raises(TypeError, match="config"):
        run_tbd_tracker(good, truth[0], P0, rng, {"method": "C"})
    with pytest.raises(ValueError, match="x0"):
        run_tbd_tracker(good, truth[0, :4], P0, rng)
    with pytest.raises(ValueError, match="P0"):
        run_tbd_tracker(good, truth[0], -P0, rng)
    bad = SimpleNamespace(**vars(good))
    bad.snr = good.snr.copy()
    bad.snr[0] = -1.0
    with pytest.raises(ValueError, match="snr"):
        run_tbd_tracker(bad, truth[0], P0, rng)
    bad = SimpleNamespace(**vars(good))
    bad.snr = good.snr.copy()
    bad.snr[1] = np.nan
    with pytest.raises(ValueError, match="snr"):
        run_tbd_tracker(bad, truth[0], P0, rng)
    bad = SimpleNamespace(**vars(good))
    bad.offsets = np.array([0, 2, 1, 3])
    with pytest.raises(ValueError, match="offsets"):
        run_tbd_tracker(bad, truth[0], P0, rng)
    bad = SimpleNamespace(**vars(good))
    bad.positions = good.positions[:, :2]
    with pytest.raises(ValueError, match="positions"):
        run_tbd_tracker(bad, truth[0], P0, rng)
    with pytest.raises(ValueError, match="pfa"):
        direct_particle_log_weights(np.zeros((2, 6)), [[1.0, 2.0, 3.0]], [0.0], [3.0], 1.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="snr"):
        direct_particle_log_weights(np.zeros((2, 6)), [[1.0, 2.0, 3.0]], [0.0], [-3.0], 1.0, 1.0, 1e-6)
    with pytest.raises(ValueError, match="errors"):
        tbd_track_lost(np.array([np.nan, 1.0]))


def test_error_summary():
    from trackcore.trackers import tbd_error_summary
    E = np.full((4, 30), 100.0)
    E[1, 5:20] = 2000.0   # lost
    E[2, 0] = 6000.0       # beyond the simulation sphere once, not lost
    s = tbd_error_summary(E)
    assert s.lost == 1 and s.beyond_sim == 1  # the lost run stays within 2 km
    np.testing.assert_allclose(s.per_run, E.mean(axis=1))
    assert s.mean == pytest.approx(E.mean())
    assert s.mean_not_lost == pytest.approx(E[[0, 2, 3]].mean())
    assert s.median_run == pytest.approx(np.median(E.mean(axis=1)))
    w = tbd_error_summary(E, slice(0, 5))
    assert w.mean == pytest.approx(E[:, :5].mean()) and w.lost == 1
    with pytest.raises(ValueError, match="errors"):
        tbd_error_summary(np.zeros((0, 5)))


def test_roughening():
    from trackcore.trackers.tbd_pf import _roughen
    N = 200_000
    X = np.zeros((N, 6))
    X[0] = -np.arange(1, 7)      # spread E_a = 2 a per component
    X[1] = np.arange(1, 7)
    before = X.copy()
    _roughen(X, 0.2, np.random.default_rng(3))
    sd = (X - before)[2:].std(axis=0)
    np.testing.assert_allclose(sd, 0.2 * N ** (-1 / 6) * 2 * np.arange(1, 7), rtol=0.01)
    # a whole run with roughening still tracks a clean target
    truth = straight_track(12)
    scans = clean_scans(truth, np.random.default_rng(21))
    cfg = TbdTrackerConfig(method="C", n_particles=500, resample_threshold=1.0, roughening=0.2)
    r = run_tbd_tracker(scans, truth[0], P0, np.random.default_rng(2), cfg)
    assert r.resampled.all()
    assert np.mean(tbd_position_errors(r.estimates, truth)[4:]) < 150.0
    with pytest.raises(ValueError, match="roughening"):
        TbdTrackerConfig(roughening=-0.1)


# ----------------------------------------------------------------------------- reliability and the fair A
def test_snr_cap_makes_pd_exactly_one_and_huge_snr_is_safe():
    for pfa in (1e-2, 1e-6, 1e-12, 1e-300):
        cap = detection_snr_cap(pfa)
        assert marcum_miss_probability(cap, pfa) < 1e-22
    X = np.column_stack([np.full((3, 3), 1e4), np.zeros((3, 3))])
    p = np.array([[1e4, 1e4, 1e4], [1.1e4, 1e4, 1e4]])
    base = direct_particle_log_weights(X, p, [0.0, 0.0], [1e3, 2e3], 150.0, 40.0, 1e-6)
    huge = direct_particle_log_weights(X, p, [0.0, 0.0], [1e300, 1e3], 150.0, 40.0, 1e-6)
    np.testing.assert_allclose(huge, base, rtol=0, atol=1e-15)
    pbar, _ = weighted_mean_detection(p, [0.0, 0.0], [1e300, 1e300], p.mean(axis=0), 0.0,
                                      150.0, 40.0, 1e-6)
    np.testing.assert_allclose(pbar, p.mean(axis=0))
    for bad in (np.inf, np.nan, -1.0):
        with pytest.raises(ValueError, match="snr"):
            direct_particle_log_weights(X, p, [0.0, 0.0], [bad, 1.0], 150.0, 40.0, 1e-6)
        with pytest.raises(ValueError, match="snr"):
            weighted_mean_detection(p, [0.0, 0.0], [1.0, bad], p[0], 0.0, 150.0, 40.0, 1e-6)
    with pytest.raises(ValueError, match="pfa"):
        weighted_mean_detection(p, [0.0, 0.0], [1.0, 1.0], p[0], 0.0, 150.0, 40.0, 1.5)
    with pytest.raises(ValueError, match="rr_ref"):
        weighted_mean_detection(p, [0.0, 0.0], [1.0, 1.0], p[0], np.nan, 150.0, 40.0, 1e-6)


def test_no_doppler_drops_the_doppler_factor():
    rng = np.random.default_rng(14)
    X = np.column_stack([rng.normal(30e3, 300, (40, 3)), rng.normal(-150, 20, (40, 3))])
    p = rng.normal(30e3, 800, (5, 3))
    snr = rng.uniform(3, 40, 5)
    a = direct_particle_log_weights(X, p, rng.normal(0, 100, 5), snr, 150.0, math.inf, 1e-6)
    b = direct_particle_log_weights(X, p, rng.normal(0, 100, 5), snr, 150.0, math.inf, 1e-6)
    np.testing.assert_array_equal(a, b)   # the Doppler values do not matter any more
    lpd = log_marcum_detection_probability(snr, 1e-6)
    d = np.linalg.norm(X[:, None, :3] - p[None], axis=2)
    np.testing.assert_allclose(a, logsumexp(lpd[None] - d / 150.0, axis=1), rtol=1e-12)
    with pytest.raises(ValueError, match="use_doppler"):
        TbdTrackerConfig(method="B", sigma_v=math.inf, use_doppler=True)
    with pytest.raises(ValueError, match="sigma_v"):
        TbdTrackerConfig(sigma_v=float("nan"))


def test_pseudo_covariance_readings():
    truth = straight_track(30)
    rng = np.random.default_rng(15)
    scans = clean_scans(truth, rng)
    x0 = truth[0] + [200, -100, 50, 10, -5, 0]
    runs = {}
    for mode in ("calibrated", "spread", "sensor"):
        cfg = TbdTrackerConfig(method="A", pseudo_covariance=mode, pseudo_sigma=100.0)
        runs[mode] = run_tbd_tracker(scans, x0, P0, np.random.default_rng(0), cfg)
    # one detection per scan: its weighted spread is zero, so "spread" is the sensor noise
    np.testing.assert_allclose(runs["spread"].estimates, runs["sensor"].estimates, rtol=1e-12)
    # a larger measurement covariance makes the EKF trust its prediction more (slower pull)
    e_cal = runs["calibrated"].estimates[1:, :3] - runs["calibrated"].estimates[:-1, :3]
    assert not np.allclose(runs["calibrated"].estimates, runs["sensor"].estimates)
    assert np.all(np.isfinite(e_cal))
    # the calibrated covariance of the EKF covers a 100 m per axis error: the final
    # position variance lies between the sensor's and the calibrated value's
    P_end = runs["calibrated"].covariances[-1, :3, :3]
    assert np.all(np.diag(P_end) < 100.0 ** 2)
    assert np.trace(P_end) > np.trace(runs["sensor"].covariances[-1, :3, :3])
    # defaults: the calibrated value of the processing radius, and a clear error elsewhere
    assert TbdTrackerConfig(method="A").pseudo_sigmas == TBD_PSEUDO_SIGMA[2500.0]
    assert TbdTrackerConfig(method="A", processing_radius=1000.0).pseudo_sigmas == \
        TBD_PSEUDO_SIGMA[1000.0]
    with pytest.raises(ValueError, match="pseudo_sigma"):
        TbdTrackerConfig(method="A", processing_radius=1234.0)
    TbdTrackerConfig(method="A", processing_radius=1234.0, pseudo_sigma=300.0)
    TbdTrackerConfig(method="C", processing_radius=1234.0)     # only A needs it
    with pytest.raises(ValueError, match="pseudo_covariance"):
        TbdTrackerConfig(method="A", pseudo_covariance="adaptive")
    with pytest.raises(ValueError, match="pseudo_sigma"):
        TbdTrackerConfig(method="A", pseudo_sigma=-1.0)


def test_spread_covariance_matches_its_definition():
    # two detections: R = sensor + J (sum w (p - pbar)(p - pbar)^T) J^T, checked through NIS
    truth = straight_track(2, x0=(30e3, 10e3, 5e3, 0.0, 0.0, 0.0))
    p = np.array([truth[1, :3] + [300.0, 0, 0], truth[1, :3] - [0, 200.0, 0]])
    rr = [0.0, 0.0]
    snr = [10.0, 20.0]
    scans = scans_from_list([(np.zeros((0, 3)), [], []), (p, rr, snr)])
    Pi = np.diag([50.0 ** 2] * 3 + [1.0] * 3)
    cfg = TbdTrackerConfig(method="A", pseudo_covariance="spread", sigma_a=0.0, gate=math.inf)
    res = run_tbd_tracker(scans, truth[0], Pi, np.random.default_rng(0), cfg)
    pbar, _ = weighted_mean_detection(p, rr, snr, truth[1, :3], 0.0, 150.0, 40.0, 1e-6)
    lpd = log_marcum_detection_probability(np.array(snr), 1e-6)
    w = np.exp(lpd - np.linalg.norm(p - truth[1, :3], axis=1) / 150.0)
    w /= w.sum()
    J = range_azimuth_elevation_jacobian(np.r_[pbar, 0, 0, 0])[:, :3]
    d = (p - pbar) @ J.T
    R = np.diag([25.0 ** 2, math.radians(0.15) ** 2, math.radians(0.15) ** 2]) + (w[:, None] * d).T @ d
    H = range_azimuth_elevation_jacobian(truth[1])
    z = range_azimuth_elevation(pbar) - range_azimuth_elevation(truth[1])
    F = cv_transition(1.0, dim=3)
    S = H @ F @ Pi @ F.T @ H.T + R
    assert res.nis[1] == pytest.approx(z @ np.linalg.solve(S, z), rel=1e-9)


def test_pseudo_measurement_errors_on_the_truth():
    truth = straight_track(10)
    scans = scans_from_list([(truth[k, :3] + [30.0, -20.0, 10.0], [radial_velocity(truth[k]) + 1.0],
                              [20.0]) for k in range(5)] + [(np.zeros((0, 3)), [], [])] * 5)
    dp, dv = pseudo_measurement_errors(scans, truth, TbdTrackerConfig(method="A"))
    np.testing.assert_allclose(dp[:5], np.tile([30.0, -20.0, 10.0], (5, 1)), atol=1e-6)
    np.testing.assert_allclose(dv[:5], 1.0, atol=1e-9)
    assert np.all(np.isnan(dp[5:])) and np.all(np.isnan(dv[5:]))
    with pytest.raises(ValueError, match="truth"):
        pseudo_measurement_errors(scans, truth[:5], TbdTrackerConfig(method="A"))
    with pytest.raises(TypeError, match="config"):
        pseudo_measurement_errors(scans, truth, None)


def test_nees_definition_and_bad_input():
    rng = np.random.default_rng(16)
    E = rng.normal(size=(5, 6))
    C = np.array([np.diag(rng.uniform(1, 4, 6)) for _ in range(5)])
    Tr = np.zeros((5, 6))
    want = np.einsum("ki,kij,kj->k", E, np.linalg.inv(C), E)
    np.testing.assert_allclose(tbd_nees(E, C, Tr), want, rtol=1e-12)
    C[2] = 0.0
    out = tbd_nees(E, C, Tr)
    assert np.isnan(out[2]) and np.all(np.isfinite(out[[0, 1, 3, 4]]))
    with pytest.raises(ValueError, match="covariances"):
        tbd_nees(E, C[:3], Tr)


def test_run_outcomes():
    E = np.full((5, 40), 100.0)
    E[1, 5:20] = 2000.0                 # lost, back on track: transient
    E[2, 10:] = np.linspace(2000, 9000, 30)   # lost and ends 9 km off: diverged
    E[3, 39] = 6000.0                   # one bad last scan: not lost, so nothing else
    E[4, 10:] = 3000.0                  # lost, still 3 km off at the end: other
    out = tbd_run_outcomes(E)
    np.testing.assert_array_equal(out.lost, [False, True, True, False, True])
    np.testing.assert_array_equal(out.transient, [False, True, False, False, False])
    np.testing.assert_array_equal(out.diverged, [False, False, True, False, False])
    np.testing.assert_array_equal(out.other, [False, False, False, False, True])
    assert np.array_equal(out.transient | out.diverged | out.other, out.lost)
    from trackcore.trackers import tbd_error_summary
    s = tbd_error_summary(E)
    assert (s.lost, s.transient, s.diverged, s.other) == (3, 1, 1, 1)
    with pytest.raises(ValueError, match="errors"):
        tbd_run_outcomes(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="diverged_at"):
        tbd_run_outcomes(E, diverged_at=500.0)
    with pytest.raises(TypeError, match="window"):
        tbd_error_summary(E, window=5)


def test_measurement_errors_bad_shapes():
    pos = np.zeros((3, 3))
    with pytest.raises(ValueError, match="positions"):
        tbd_measurement_errors(np.zeros((3, 2)), np.array([0, 3]), np.zeros((1, 6)))
    with pytest.raises(ValueError, match="offsets"):
        tbd_measurement_errors(pos, np.array([0, 5]), np.zeros((1, 6)))
    with pytest.raises(ValueError, match="offsets"):
        tbd_measurement_errors(pos, np.array([[0, 3]]), np.zeros((1, 6)))
    with pytest.raises(ValueError, match="truth"):
        tbd_measurement_errors(pos, np.array([0, 3]), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="mask"):
        tbd_measurement_errors(pos, np.array([0, 3]), np.zeros((1, 6)), mask=[1, 0, 1])
    with pytest.raises(ValueError, match="mask"):
        tbd_measurement_errors(pos, np.array([0, 3]), np.zeros((1, 6)),
                               mask=np.ones(2, dtype=bool))


def test_config_validates_every_field():
    for name in ("n_particles", "processing_radius", "sigma_r", "sigma_a", "pfa",
                 "resample_threshold", "gate", "roughening", "scan_period", "sigma_range",
                 "sigma_angle", "sigma_range_rate", "target_snr", "threshold_db",
                 "clutter_density", "clutter_density_rae"):
        with pytest.raises((ValueError, TypeError), match=name):
            TbdTrackerConfig(**{name: float("nan")})
    with pytest.raises(TypeError, match="use_doppler"):
        TbdTrackerConfig(use_doppler="yes")


def test_weight_reference_previous_estimate():
    # scan 0 empty (the estimate stays x0), scan 1 two detections: "previous" measures r_m
    # and v_m from x0, "prediction" from F x0; the pseudo-measurement (hence NIS) differs
    truth = straight_track(2, x0=(30e3, 10e3, 5e3, -200.0, 0.0, 0.0))
    p = np.array([truth[1, :3] + [100.0, 0, 0], truth[1, :3] + [300.0, 50.0, 0]])
    rr = [radial_velocity(truth[1])] * 2
    snr = [10.0, 10.0]
    scans = scans_from_list([(np.zeros((0, 3)), [], []), (p, rr, snr)])
    Pi = np.diag([50.0 ** 2] * 3 + [1.0] * 3)
    F = cv_transition(1.0, dim=3)
    nis = {}
    for ref, state in (("prediction", truth[1]), ("previous", truth[0])):
        cfg = TbdTrackerConfig(method="A", sigma_a=0.0, gate=math.inf, weight_reference=ref)
        res = run_tbd_tracker(scans, truth[0], Pi, np.random.default_rng(0), cfg)
        pbar, _ = weighted_mean_detection(p, rr, snr, state[:3], radial_velocity(state), 150.0,
                                          40.0, 1e-6)
        z = range_azimuth_elevation(pbar) - range_azimuth_elevation(truth[1])
        z[1] = (z[1] + math.pi) % (2 * math.pi) - math.pi
        sp = TBD_PSEUDO_SIGMA[2500.0][0]
        r, _, el = range_azimuth_elevation(pbar)
        R = np.diag([sp ** 2, sp ** 2 / (r * math.cos(el)) ** 2, sp ** 2 / r ** 2])
        H = range_azimuth_elevation_jacobian(truth[1])
        S = H @ F @ Pi @ F.T @ H.T + R
        assert res.nis[1] == pytest.approx(z @ np.linalg.solve(S, z), rel=1e-9)
        nis[ref] = res.nis[1]
        # method B runs with either reading
        b = run_tbd_tracker(scans, truth[0], Pi, np.random.default_rng(0),
                            TbdTrackerConfig(method="B", weight_reference=ref, n_particles=50))
        assert np.all(np.isfinite(b.estimates))
    assert nis["prediction"] != nis["previous"]
    with pytest.raises(ValueError, match="weight_reference"):
        TbdTrackerConfig(weight_reference="estimate")


def test_covariances_are_optional_and_change_nothing_else():
    truth = straight_track(20)
    scans = clean_scans(truth, np.random.default_rng(17))
    for method in "BCP":
        cfg = TbdTrackerConfig(method=method, n_particles=200)
        a = run_tbd_tracker(scans, truth[0], P0, np.random.default_rng(3), cfg)
        b = run_tbd_tracker(scans, truth[0], P0, np.random.default_rng(3), cfg,
                            covariances=False)
        np.testing.assert_array_equal(a.estimates, b.estimates)
        assert b.covariances is None and a.covariances.shape == (20, 6, 6)
    with pytest.raises(TypeError, match="covariances"):
        run_tbd_tracker(scans, truth[0], P0, np.random.default_rng(3), cfg, covariances="no")


def test_log_pd_cache_is_shared_and_changes_nothing():
    truth = tbd_radar_truth(TbdRadarParameters(n_scans=30))
    sc = simulate_tbd_radar(truth, TbdRadarParameters(n_scans=30), np.random.default_rng(18))
    M = sc.positions.shape[0]
    cache = np.full(M, np.nan)
    for method in "ABC":
        cfg = TbdTrackerConfig(method=method, n_particles=200)
        a = run_tbd_tracker(sc, truth.states[0], P0, np.random.default_rng(4), cfg)
        b = run_tbd_tracker(sc, truth.states[0], P0, np.random.default_rng(4), cfg,
                            log_pd_cache=cache)
        np.testing.assert_array_equal(a.estimates, b.estimates)
    # every processed detection was evaluated once, with eq (9) itself
    done = np.isfinite(cache)
    assert done.any() and not done.all()
    np.testing.assert_array_equal(
        cache[done], log_marcum_detection_probability(sc.snr[done], 1e-6))
    with pytest.raises(ValueError, match="log_pd_cache"):
        run_tbd_tracker(sc, truth.states[0], P0, np.random.default_rng(4),
                        TbdTrackerConfig(), log_pd_cache=np.zeros(3))


def test_huge_finite_inputs_are_rejected_not_overflowed():
    big = np.array([1e300, 0, 0, 0, 0, 0.0])
    for f, args in ((range_azimuth_elevation, (big,)), (radial_velocity, (big,)),
                    (range_azimuth_elevation_jacobian, (big,)),
                    (tbd_position_errors, (big[None], np.zeros((1, 6))))):
        with pytest.raises(ValueError):
            f(*args)
    truth = straight_track(3)
    scans = clean_scans(truth, np.random.default_rng(0))
    with pytest.raises(ValueError, match="x0"):
        run_tbd_tracker(scans, big, P0, np.random.default_rng(0))
    with pytest.raises(ValueError, match="P0"):
        run_tbd_tracker(scans, truth[0], P0 * 1e290, np.random.default_rng(0))
    with pytest.raises(ValueError, match="particles"):
        direct_particle_log_weights(big[None], [[1.0, 2.0, 3.0]], [0.0], [3.0], 1.0, 1.0, 1e-6)
