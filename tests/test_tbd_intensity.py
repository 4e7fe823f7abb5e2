"""Tests for the raw-intensity TBD baseline of chapter 003 and the one-sensor comparison: the
intensity-map simulator (trackcore.scenarios.tbd_intensity), the Salmond–Birch / Rutten
particle filter and the detection-level trackers on the same maps
(trackcore.trackers.tbd_intensity_pf)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.special import i0e

from trackcore.scenarios import (TbdRadarParameters, simulate_intensity_maps, tbd_intensity_trial,
                                 tbd_paired_trial, tbd_radar_truth)
from trackcore.trackers import (IntensityGrid, IntensityMaps, IntensityTbdConfig,
                                TbdTrackerConfig, intensity_detections,
                                intensity_false_alarm_probability, intensity_log_likelihood_ratio,
                                intensity_psf, intensity_tracker_config, run_intensity_tbd,
                                run_tbd_tracker_on_map)
from trackcore.trackers.tbd_intensity_pf import log_i0_kernel
import _truth  # tests/_truth.py (shared truth helper)

GRID = IntensityGrid()
P0 = np.diag([300.0 ** 2] * 3 + [20.0 ** 2] * 3)
OFF = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"),
               axis=-1).reshape(27, 3)


def cell_centre(i, j, l, grid=GRID):
    """Cartesian position of the centre of cell (i, j, l)."""
    r, az, el = i * grid.range_cell, j * grid.angle_cell, l * grid.angle_cell
    return np.array([r * math.cos(el) * math.cos(az), r * math.cos(el) * math.sin(az),
                     r * math.sin(el)])


def straight_track(K, x0=(30e3, 15e3, 5e3, -150.0, 60.0, 0.0)):
    return _truth.straight_track(K, x0)


# ----------------------------------------------------------------------------- log I0
def test_log_i0_matches_scipy():
    x = np.concatenate([[0.0], np.logspace(-6, 3, 400), [19.999, 20.0, 20.001]])
    ours = np.array([log_i0_kernel(v) for v in x])
    ref = np.log(i0e(x)) + x
    assert np.allclose(ours, ref, rtol=1e-14, atol=1e-15)


# ----------------------------------------------------------------------------- the noise field
def test_noise_cells_are_independent_unit_exponentials_everywhere():
    maps = simulate_intensity_maps(straight_track(40)[:, :3], np.zeros(40), GRID,
                                   np.random.default_rng(1))
    # a block around the target and one 200 km away: the same statistics
    z = np.concatenate([maps.block(k)[0].ravel() for k in range(0, 40, 4)])
    far = np.array([[3000 + i, -200 + j, 50] for i in range(300) for j in range(300)])
    z_far = maps.cell_power(7, far)
    for sample in (z, z_far):
        se = 1.0 / math.sqrt(sample.size)
        assert abs(sample.mean() - 1.0) < 4 * se
        assert abs(sample.var() - 1.0) < 4 * math.sqrt(8.0) * se
        assert stats.kstest(sample[:100_000], "expon").pvalue > 1e-3
    # a wrong mean is rejected by the same test (the test can fail)
    assert stats.kstest(1.1 * z[:100_000], "expon").pvalue < 1e-6
    # neighbouring cells, neighbouring scans and other keys are uncorrelated
    block0, _ = maps.block(0)
    block1, _ = maps.block(1)
    n = block0.size
    for a, b in ((block0[1:], block0[:-1]), (block0[:, 1:], block0[:, :-1]),
                 (block0[:, :, 1:], block0[:, :, :-1])):
        assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 4 / math.sqrt(a.size)
    other = simulate_intensity_maps(straight_track(40)[:, :3], np.zeros(40), GRID,
                                    np.random.default_rng(2))
    cells = np.array([[400 + i, 30, 10] for i in range(20_000)])
    assert abs(np.corrcoef(maps.cell_power(3, cells), other.cell_power(3, cells))[0, 1]) \
        < 4 / math.sqrt(20_000)
    assert not np.array_equal(block0, block1) and n == np.prod(GRID.shape)


def test_the_map_is_one_map():
    """Every reader of a cell sees the same power, in any order and at any distance."""
    maps = simulate_intensity_maps(straight_track(5)[:, :3], np.full(5, 10.0), GRID,
                                   np.random.default_rng(3))
    cells = np.array([[10_000, -5000, 300], [400, 30, 10], [-5, 7, 1]])
    a = maps.cell_power(2, cells)
    b = maps.cell_power(2, cells[::-1])[::-1]
    np.testing.assert_array_equal(a, b)
    blk, origin = maps.block(2, 3, 2)
    sub = np.array([origin + [1, 2, 3]])
    assert maps.cell_power(2, sub)[0] == blk[1, 2, 3]
    # the footprint cells hold the stored target powers
    c0 = maps.footprint_centre[2]
    np.testing.assert_array_equal(maps.cell_power(2, c0 + OFF), maps.footprint_power[2])


def test_target_cell_mean_power_is_noise_plus_snr():
    K, S = 6000, 4.0
    p = cell_centre(520, 50, 12)
    maps = simulate_intensity_maps(np.tile(p, (K, 1)), np.full(K, S), GRID,
                                   np.random.default_rng(2))
    np.testing.assert_array_equal(maps.footprint_centre, np.tile([520, 50, 12], (K, 1)))
    centre = maps.footprint_power[:, 13]
    # |sqrt(S) + n|^2, n ~ CN(0, 1): mean 1 + S, variance 1 + 2 S
    assert abs(centre.mean() - (1.0 + S)) < 4 * math.sqrt(1 + 2 * S) / math.sqrt(K)
    # a neighbour in range gets S h^2 with h = exp(-1 / (4 beta^2))
    h = math.exp(-1.0 / (4 * GRID.psf_width ** 2))
    nb_ = maps.footprint_power[:, 22]   # offset (+1, 0, 0)
    assert abs(nb_.mean() - (1.0 + S * h * h)) < 4 * math.sqrt(1 + 2 * S * h * h) / math.sqrt(K)
    # a cell outside the footprint is noise only
    far = np.array([maps.cell_power(k, np.array([[523, 50, 12]]))[0] for k in range(0, K, 6)])
    assert abs(far.mean() - 1.0) < 4 / math.sqrt(far.size)
    # and the target cell is Rician: compare with scipy's noncentral chi-square (2 dof)
    assert stats.kstest(2 * centre, stats.ncx2(2, 2 * S).cdf).pvalue > 1e-3


def test_psf_footprint():
    p = cell_centre(500, 60, 10)
    cells, h = intensity_psf(p)
    assert cells.shape == (27, 3) and h.shape == (27,)
    assert h.max() == pytest.approx(1.0, abs=1e-9)
    assert tuple(cells[np.argmax(h)]) == (500, 60, 10)
    np.testing.assert_array_equal(cells, np.array([500, 60, 10]) + OFF)
    # the summed footprint energy of a target at a cell centre: (1 + 2 e^-2)^3
    assert np.sum(h ** 2) == pytest.approx((1 + 2 * math.exp(-2.0)) ** 3, rel=1e-12)


# ----------------------------------------------------------------------------- likelihood ratio
def numpy_loglr(particles, maps, k, S, grid=GRID):
    """Direct NumPy evaluation of Σ_c log I0(2 sqrt(S) h_c sqrt(z_c)) - S h_c^2."""
    p = particles[:, :3]
    r = np.linalg.norm(p, axis=1)
    u = np.stack([r / grid.range_cell, np.arctan2(p[:, 1], p[:, 0]) / grid.angle_cell,
                  np.arcsin(p[:, 2] / r) / grid.angle_cell], axis=1)        # (N, 3)
    near = np.floor(u + 0.5).astype(np.int64)
    cells = near[:, None, :] + OFF[None]                                    # (N, 27, 3)
    h = np.exp(-np.sum((cells - u[:, None, :]) ** 2, axis=2) / (4 * grid.psf_width ** 2))
    z = maps.cell_power(k, cells.reshape(-1, 3)).reshape(cells.shape[:2])
    x = 2 * np.sqrt(S) * h * np.sqrt(z)
    return (np.log(i0e(x)) + x - S * h * h).sum(axis=1)


def test_likelihood_ratio_kernel_matches_numpy():
    rng = np.random.default_rng(3)
    truth = cell_centre(600, 45, 9)
    maps = simulate_intensity_maps(truth[None], np.array([10.0]), GRID, rng)
    # particles around the target and far from it
    X = np.column_stack([truth + rng.normal(0, 3000, (500, 3)), rng.normal(0, 50, (500, 3))])
    for S in (0.5, 4.0, 40.0):
        ours = intensity_log_likelihood_ratio(X, maps, 0, S)
        ref = numpy_loglr(X, maps, 0, S)
        assert np.allclose(ours, ref, rtol=1e-12, atol=1e-12)
    # the target's own position is favoured over a particle 1 km off
    far = np.array([truth, truth + np.array([1000.0, 0, 0])])
    ll = intensity_log_likelihood_ratio(far, maps, 0, 10.0)
    assert ll[0] > ll[1]
    assert np.array_equal(intensity_log_likelihood_ratio(X, maps, 0, 0.0), np.zeros(500))


def test_far_from_the_target_the_log_lr_is_that_of_noise():
    """Off the target the footprint is noise: E[log LR] = Σ_c E[log I0(2 a h sqrt(z))] - S h²
    with z ~ Exp(1), negative (the noise never looks like a target on average)."""
    K = 400
    xs = straight_track(K)
    maps = simulate_intensity_maps(xs[:, :3], np.zeros(K), GRID, np.random.default_rng(4))
    X = xs[:, None, :] + np.array([5000.0, 0, 0, 0, 0, 0])
    ll = np.array([intensity_log_likelihood_ratio(X[k], maps, k, 4.0)[0] for k in range(K)])
    z = np.random.default_rng(5).standard_exponential((200_000, 27))
    _, h = intensity_psf(X[0, 0, :3])
    x = 2 * 2.0 * h * np.sqrt(z)
    want = (np.log(i0e(x)) + x - 4.0 * h * h).sum(axis=1)
    assert abs(ll.mean() - want.mean()) < 4 * want.std() / math.sqrt(K)
    assert want.mean() < 0


# ----------------------------------------------------------------------------- detections
def test_false_alarm_probability_of_the_extractor():
    for thr in (3.0, 5.0, 8.0):
        tau = 10 ** (thr / 10)
        p = intensity_false_alarm_probability(thr)
        assert p == pytest.approx((1 - (1 - math.exp(-tau)) ** 27) / 27, rel=1e-12)
        assert p < math.exp(-tau)
    # by simulation: detections per km^3 far from the target
    maps = simulate_intensity_maps(straight_track(60)[:, :3], np.zeros(60), GRID,
                                   np.random.default_rng(6))
    count, expect = 0, 0.0
    for k in range(60):
        c = np.array([40e3, 10e3, 4e3]) + 3000.0 * (k % 3)
        pos, snr = intensity_detections(maps, k, c, 1500.0, 5.0)
        assert np.all(snr >= 10 ** 0.5)
        assert np.all(np.linalg.norm(pos - c, axis=1) <= 1500.0 + 1e-6)
        count += pos.shape[0]
        r = np.linalg.norm(c)
        cos_el = math.cos(math.asin(c[2] / r))
        cells = 4 / 3 * math.pi * 1500.0 ** 3 / (GRID.range_cell * (r * GRID.angle_cell) ** 2
                                                  * cos_el)
        expect += cells * intensity_false_alarm_probability(5.0)
    assert abs(count - expect) < 4 * math.sqrt(expect)
    # a large window at a low threshold (thousands of detections in one extraction)
    c = np.array([40e3, 10e3, 4e3])
    pos, _ = intensity_detections(maps, 0, c, 8000.0, 0.0)
    r = np.linalg.norm(pos, axis=1)
    cells = np.sum(4 / 3 * math.pi * 8000.0 ** 3 / (GRID.range_cell * GRID.angle_cell ** 2))
    mean_inv = np.mean(1.0 / (r ** 2 * np.cos(np.arcsin(pos[:, 2] / r))))
    expect = cells * mean_inv * intensity_false_alarm_probability(0.0)
    assert pos.shape[0] > 4096 and abs(pos.shape[0] - expect) < 0.05 * expect


def test_detections_are_local_maxima_at_cell_centres():
    K = 40
    xs = straight_track(K)
    maps = simulate_intensity_maps(xs[:, :3], np.full(K, 100.0), GRID, np.random.default_rng(7))
    for k in range(0, K, 5):
        pos, snr = intensity_detections(maps, k, xs[k, :3], 800.0, 5.0)
        best = np.argmax(snr)
        # the brightest detection is one of the target's footprint cells, at its centre
        c0 = maps.footprint_centre[k]
        cells = c0 + OFF
        t = np.argmin([np.linalg.norm(pos[best] - cell_centre(*c)) for c in cells])
        assert np.allclose(pos[best], cell_centre(*cells[t]), atol=1e-6)
        assert snr[best] == maps.footprint_power[k, t]
        # every detection is at least as bright as its 26 neighbours
        for p_, s_ in zip(pos, snr):
            r = np.linalg.norm(p_)
            cell = np.rint([r / GRID.range_cell, math.atan2(p_[1], p_[0]) / GRID.angle_cell,
                            math.asin(p_[2] / r) / GRID.angle_cell]).astype(np.int64)
            assert maps.cell_power(k, cell + OFF).max() == s_


# ----------------------------------------------------------------------------- bad input
def test_bad_input():
    pos = straight_track(5)[:, :3]
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="snr"):
        simulate_intensity_maps(pos, np.array([1.0, 1.0, -1.0, 1.0, 1.0]), GRID, rng)
    with pytest.raises(ValueError, match="snr"):
        simulate_intensity_maps(pos, np.full(5, np.nan), GRID, rng)
    with pytest.raises(ValueError, match="positions"):
        simulate_intensity_maps(np.zeros((0, 3)), np.zeros(0), GRID, rng)
    bad = pos.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="positions"):
        simulate_intensity_maps(bad, np.ones(5), GRID, rng)
    with pytest.raises(ValueError, match="snr"):
        simulate_intensity_maps(pos, np.ones(4), GRID, rng)
    with pytest.raises(TypeError, match="rng"):
        simulate_intensity_maps(pos, np.ones(5), GRID, 42)
    with pytest.raises(TypeError, match="grid"):
        simulate_intensity_maps(pos, np.ones(5), "grid", rng)
    for name in ("range_cell", "angle_cell", "psf_width"):
        with pytest.raises(ValueError, match=name):
            IntensityGrid(**{name: -1.0})
        with pytest.raises(ValueError, match=name):
            IntensityGrid(**{name: float("nan")})
    with pytest.raises(ValueError, match="half_range"):
        IntensityGrid(half_range=0)
    maps = simulate_intensity_maps(pos, np.ones(5), GRID, rng)
    X = np.column_stack([pos, np.zeros((5, 3))])
    with pytest.raises(ValueError, match="snr"):
        intensity_log_likelihood_ratio(X, maps, 0, -1.0)
    with pytest.raises(ValueError, match="snr"):
        intensity_log_likelihood_ratio(X, maps, 0, np.nan)
    with pytest.raises(ValueError, match="k"):
        intensity_log_likelihood_ratio(X, maps, 5, 1.0)
    with pytest.raises(ValueError, match="particles"):
        intensity_log_likelihood_ratio(np.full((2, 6), np.nan), maps, 0, 1.0)
    with pytest.raises(TypeError, match="maps"):
        intensity_log_likelihood_ratio(X, "maps", 0, 1.0)
    with pytest.raises(ValueError, match="footprint_power"):
        IntensityMaps(maps.footprint_centre, -maps.footprint_power, 1, GRID)
    with pytest.raises(ValueError, match="footprint_power"):
        IntensityMaps(maps.footprint_centre, np.full((5, 27), np.nan), 1, GRID)
    with pytest.raises(ValueError, match="footprint_centre"):
        IntensityMaps(maps.footprint_centre.astype(float), maps.footprint_power, 1, GRID)
    with pytest.raises(ValueError, match="footprint_centre"):
        IntensityMaps(np.zeros((0, 3), np.int64), np.zeros((0, 27)), 1, GRID)
    with pytest.raises(ValueError, match="noise_key"):
        IntensityMaps(maps.footprint_centre, maps.footprint_power, -1, GRID)
    with pytest.raises(ValueError, match="cells"):
        maps.cell_power(0, np.zeros((3, 2), np.int64))
    with pytest.raises(ValueError, match="radius"):
        intensity_detections(maps, 0, pos[0], -1.0, 5.0)
    with pytest.raises(ValueError, match="threshold_db"):
        intensity_detections(maps, 0, pos[0], 100.0, np.inf)
    with pytest.raises(ValueError, match="centre"):
        intensity_detections(maps, 0, np.zeros(3), 100.0, 5.0)
    for name in ("design_snr", "n_particles", "sigma_a", "resample_threshold", "scan_period"):
        with pytest.raises((ValueError, TypeError), match=name):
            IntensityTbdConfig(**{name: float("nan")})
    with pytest.raises(ValueError, match="design_snr"):
        IntensityTbdConfig(design_snr=-1.0)
    with pytest.raises(ValueError, match="x0"):
        run_intensity_tbd(maps, np.full(6, np.nan), P0, rng)
    with pytest.raises(ValueError, match="P0"):
        run_intensity_tbd(maps, X[0], -P0, rng)
    with pytest.raises(TypeError, match="config"):
        run_intensity_tbd(maps, X[0], P0, rng, config=TbdTrackerConfig())
    with pytest.raises(TypeError, match="maps"):
        run_intensity_tbd("maps", X[0], P0, rng)
    # the detection-level trackers on a map: no Doppler, and B/C/P only
    with pytest.raises(ValueError, match="Doppler"):
        run_tbd_tracker_on_map(maps, X[0], P0, rng, TbdTrackerConfig(method="C"))
    with pytest.raises(ValueError, match="method"):
        run_tbd_tracker_on_map(maps, X[0], P0, rng, intensity_tracker_config("A"))
    with pytest.raises(TypeError, match="config"):
        run_tbd_tracker_on_map(maps, X[0], P0, rng, IntensityTbdConfig())


# ----------------------------------------------------------------------------- determinism and tracking
def test_determinism_given_a_seed():
    xs = straight_track(30)
    a = simulate_intensity_maps(xs[:, :3], np.full(30, 4.0), GRID, np.random.default_rng(7))
    b = simulate_intensity_maps(xs[:, :3], np.full(30, 4.0), GRID, np.random.default_rng(7))
    c = simulate_intensity_maps(xs[:, :3], np.full(30, 4.0), GRID, np.random.default_rng(8))
    assert np.array_equal(a.footprint_power, b.footprint_power) and a.noise_key == b.noise_key
    assert np.array_equal(a.block(3)[0], b.block(3)[0])
    assert not np.array_equal(a.block(3)[0], c.block(3)[0])
    cfg = IntensityTbdConfig(n_particles=300)
    t1 = run_intensity_tbd(a, xs[0], P0, np.random.default_rng(1), cfg)
    t2 = run_intensity_tbd(a, xs[0], P0, np.random.default_rng(1), cfg)
    t3 = run_intensity_tbd(a, xs[0], P0, np.random.default_rng(2), cfg)
    assert np.array_equal(t1.estimates, t2.estimates) and np.array_equal(t1.ess, t2.ess)
    assert not np.array_equal(t1.estimates, t3.estimates)


def test_filter_tracks_a_bright_target_and_beats_its_prior():
    K = 60
    xs = straight_track(K)
    maps = simulate_intensity_maps(xs[:, :3], np.full(K, 20.0), GRID, np.random.default_rng(11))
    x0 = xs[0] + np.array([250.0, -200.0, 150.0, 10.0, -10.0, 5.0])
    res = run_intensity_tbd(maps, x0, P0, np.random.default_rng(12),
                            IntensityTbdConfig(n_particles=1000, design_snr=20.0))
    err = np.linalg.norm(res.estimates[:, :3] - xs[:, :3], axis=1)
    assert err[0] < np.linalg.norm(x0[:3] - xs[0, :3])   # the first map already helps
    assert np.median(err[20:]) < 60.0                      # ~ cell-fraction accuracy
    assert np.all((res.ess >= 1.0) & (res.ess <= 1000.0 + 1e-9))
    assert res.resampled.any()
    assert np.all(np.linalg.eigvalsh(res.covariances) > 0)


def test_detection_trackers_on_the_map_track_a_bright_target():
    K = 60
    xs = straight_track(K)
    maps = simulate_intensity_maps(xs[:, :3], np.full(K, 30.0), GRID, np.random.default_rng(13))
    x0 = xs[0] + np.array([150.0, -100.0, 80.0, 5.0, -5.0, 0.0])
    for method in "BCP":
        cfg = intensity_tracker_config(method, processing_radius=1000.0, n_particles=500)
        res = run_tbd_tracker_on_map(maps, x0, P0, np.random.default_rng(14), cfg)
        err = np.linalg.norm(res.estimates[:, :3] - xs[:, :3], axis=1)
        assert np.median(err[20:]) < 150.0, method
        assert np.all(res.n_processed >= 1)
        # the detections a tracker saw are those of intensity_detections in its window
        k = 30
        pos, _ = intensity_detections(maps, k, res.window_centers[k], 1000.0, 5.0)
        assert pos.shape[0] == res.n_processed[k]


def test_noise_only_maps_do_not_pull_the_filter_towards_a_target():
    """With S = 0 in the data the log-LR has no systematic pull: the estimate follows the
    prior (its error grows like the DWNA spread rather than collapsing onto the truth)."""
    K = 20
    xs = straight_track(K)
    maps = simulate_intensity_maps(xs[:, :3], np.zeros(K), GRID, np.random.default_rng(5))
    res = run_intensity_tbd(maps, xs[0] + np.array([600.0, 0, 0, 0, 0, 0]), P0,
                            np.random.default_rng(6), IntensityTbdConfig(n_particles=500))
    err = np.linalg.norm(res.estimates[:, :3] - xs[:, :3], axis=1)
    assert np.median(err) > 200.0


def test_trial_is_paired_with_the_detection_level_trial():
    prm = TbdRadarParameters(n_scans=40)
    truth = tbd_radar_truth(prm)
    det = tbd_paired_trial(np.random.default_rng(9), {"C": TbdTrackerConfig(n_particles=50)},
                           prm, truth, keep=True)
    cfgs = {"I": IntensityTbdConfig(n_particles=100),
            "C": intensity_tracker_config("C", processing_radius=1000.0, n_particles=100)}
    inten = tbd_intensity_trial(np.random.default_rng(9), cfgs, prm, truth, keep=True, nees=True)
    assert np.array_equal(det.x0, inten.x0)
    assert np.array_equal(det.scans.target_snr, inten.target_snr)
    for name in cfgs:
        assert inten.errors[name].shape == (40,) and np.all(np.isfinite(inten.errors[name]))
        assert inten.nees[name].shape == (40,)
    assert np.all(np.isnan(inten.n_processed["I"])) and np.all(inten.n_processed["C"] >= 0)
    again = tbd_intensity_trial(np.random.default_rng(9), {"I": cfgs["I"]}, prm, truth)
    assert np.array_equal(again.errors["I"], inten.errors["I"])   # common random numbers
    with pytest.raises(ValueError, match="method"):
        tbd_intensity_trial(np.random.default_rng(9), {"A": TbdTrackerConfig(method="A")}, prm,
                            truth)
    with pytest.raises(TypeError, match="configs"):
        tbd_intensity_trial(np.random.default_rng(9), {}, prm, truth)


def test_huge_inputs_are_rejected():
    maps = simulate_intensity_maps(straight_track(3)[:, :3], np.ones(3), GRID,
                                   np.random.default_rng(0))
    with pytest.raises(ValueError, match="radius"):
        intensity_detections(maps, 0, straight_track(3)[0, :3], 1e7, 5.0)
    with pytest.raises(ValueError, match="block"):
        maps.block(0, 10_000, 1000)
    with pytest.raises(ValueError, match="positions"):
        simulate_intensity_maps(np.full((2, 3), 1e300), np.ones(2), GRID,
                                np.random.default_rng(0))
    with pytest.raises(ValueError, match="particles"):
        intensity_log_likelihood_ratio(np.full((2, 3), 1e300), maps, 0, 1.0)
