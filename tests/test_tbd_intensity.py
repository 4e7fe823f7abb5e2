"""Tests for the raw-intensity TBD baseline of chapter 003: the intensity-map simulator
(trackcore.scenarios.tbd_intensity) and the Salmond–Birch / Rutten particle filter
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
                                TbdTrackerConfig, intensity_log_likelihood_ratio, intensity_psf,
                                run_intensity_tbd)
from trackcore.trackers.tbd_intensity_pf import log_i0_kernel
import _truth  # tests/_truth.py (shared truth helper)

GRID = IntensityGrid()
P0 = np.diag([300.0 ** 2] * 3 + [20.0 ** 2] * 3)


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


# ----------------------------------------------------------------------------- simulator statistics
def test_noise_only_cells_are_exponential_with_unit_mean():
    maps = simulate_intensity_maps(straight_track(40)[:, :3], np.zeros(40), GRID,
                                   np.random.default_rng(1))
    z = maps.power.ravel()
    assert z.size == 40 * np.prod(GRID.shape)
    se = 1.0 / math.sqrt(z.size)
    assert abs(z.mean() - 1.0) < 4 * se
    assert abs(z.var() - 1.0) < 4 * math.sqrt(8.0) * se  # Var(sample var) = (mu4 - 1)/n = 8/n
    assert stats.kstest(z[:200_000], "expon").pvalue > 1e-3
    # a wrong mean is rejected by the same test (the test can fail)
    assert stats.kstest(1.1 * z[:200_000], "expon").pvalue < 1e-6


def test_target_cell_mean_power_is_noise_plus_snr():
    K, S = 6000, 4.0
    p = cell_centre(520, 50, 12)
    maps = simulate_intensity_maps(np.tile(p, (K, 1)), np.full(K, S), GRID,
                                   np.random.default_rng(2))
    a, b, c = GRID.half_range, GRID.half_angle, GRID.half_angle
    centre = maps.power[:, a, b, c]
    # |sqrt(S) + n|^2, n ~ CN(0, 1): mean 1 + S, variance 1 + 2 S
    assert abs(centre.mean() - (1.0 + S)) < 4 * math.sqrt(1 + 2 * S) / math.sqrt(K)
    # a neighbour in range gets S h^2 with h = exp(-1 / (4 beta^2))
    h = math.exp(-1.0 / (4 * GRID.psf_width ** 2))
    nb_ = maps.power[:, a + 1, b, c]
    assert abs(nb_.mean() - (1.0 + S * h * h)) < 4 * math.sqrt(1 + 2 * S * h * h) / math.sqrt(K)
    # a cell outside the footprint is noise only
    far = maps.power[:, a + 3, b, c]
    assert abs(far.mean() - 1.0) < 4 / math.sqrt(K)
    # and the target cell is Rician: compare with scipy's noncentral chi-square (2 dof)
    assert stats.kstest(2 * centre, stats.ncx2(2, 2 * S).cdf).pvalue > 1e-3


def test_psf_footprint_and_origin():
    p = cell_centre(500, 60, 10)
    cells, h = intensity_psf(p)
    assert cells.shape == (27, 3) and h.shape == (27,)
    assert h.max() == pytest.approx(1.0, abs=1e-9)
    assert tuple(cells[np.argmax(h)]) == (500, 60, 10)
    maps = simulate_intensity_maps(p[None], np.array([1.0]), GRID, np.random.default_rng(0))
    assert tuple(maps.origin[0]) == (500 - GRID.half_range, 60 - GRID.half_angle,
                                     10 - GRID.half_angle)


# ----------------------------------------------------------------------------- likelihood ratio
def numpy_loglr(particles, power, origin, S, grid=GRID):
    """Direct NumPy evaluation of Σ_c log I0(2 sqrt(S) h_c sqrt(z_c)) - S h_c^2."""
    p = particles[:, :3]
    r = np.linalg.norm(p, axis=1)
    u = np.stack([r / grid.range_cell, np.arctan2(p[:, 1], p[:, 0]) / grid.angle_cell,
                  np.arcsin(p[:, 2] / r) / grid.angle_cell], axis=1)        # (N, 3)
    near = np.floor(u + 0.5).astype(np.int64)
    off = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"),
                   axis=-1).reshape(27, 3)
    cells = near[:, None, :] + off[None]                                    # (N, 27, 3)
    h = np.exp(-np.sum((cells - u[:, None, :]) ** 2, axis=2) / (4 * grid.psf_width ** 2))
    idx = cells - origin
    inside = np.all((idx >= 0) & (idx < np.array(power.shape)), axis=2)
    idx = np.where(inside[..., None], idx, 0)
    z = power[idx[..., 0], idx[..., 1], idx[..., 2]]
    x = 2 * np.sqrt(S) * h * np.sqrt(z)
    terms = np.log(i0e(x)) + x - S * h * h
    return np.where(inside, terms, 0.0).sum(axis=1)


def test_likelihood_ratio_kernel_matches_numpy():
    rng = np.random.default_rng(3)
    truth = cell_centre(600, 45, 9)
    maps = simulate_intensity_maps(truth[None], np.array([10.0]), GRID, rng)
    # particles around the target, some far enough to leave the block
    X = np.column_stack([truth + rng.normal(0, 1500, (500, 3)), rng.normal(0, 50, (500, 3))])
    for S in (0.5, 4.0, 40.0):
        ours = intensity_log_likelihood_ratio(X, maps.power[0], maps.origin[0], S)
        ref = numpy_loglr(X, maps.power[0], maps.origin[0], S)
        assert np.allclose(ours, ref, rtol=1e-12, atol=1e-12)
    # the target's own position is favoured over a particle 1 km off
    far = np.array([truth, truth + np.array([1000.0, 0, 0])])
    ll = intensity_log_likelihood_ratio(far, maps.power[0], maps.origin[0], 10.0)
    assert ll[0] > ll[1]


def test_likelihood_ratio_is_zero_off_the_map_and_at_zero_snr():
    power = np.ones((3, 3, 3))
    X = np.array([cell_centre(100, 10, 5), cell_centre(700, 40, 8)])
    assert np.array_equal(intensity_log_likelihood_ratio(X, power, np.array([0, 0, 0]), 4.0),
                          np.zeros(2))
    ll = intensity_log_likelihood_ratio(X, power, np.array([99, 9, 4]), 0.0)
    assert np.array_equal(ll, np.zeros(2))


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
    with pytest.raises(ValueError, match="range_cell"):
        IntensityGrid(range_cell=-1.0)
    X = np.column_stack([pos, np.zeros((5, 3))])
    block = np.ones((3, 3, 3))
    o = np.array([0, 0, 0])
    with pytest.raises(ValueError, match="snr"):
        intensity_log_likelihood_ratio(X, block, o, -1.0)
    with pytest.raises(ValueError, match="snr"):
        intensity_log_likelihood_ratio(X, block, o, np.nan)
    with pytest.raises(ValueError, match="power"):
        intensity_log_likelihood_ratio(X, np.ones((0, 3, 3)), o, 1.0)
    with pytest.raises(ValueError, match="power"):
        intensity_log_likelihood_ratio(X, np.full((3, 3, 3), np.nan), o, 1.0)
    with pytest.raises(ValueError, match="power"):
        intensity_log_likelihood_ratio(X, -block, o, 1.0)
    with pytest.raises(ValueError, match="origin"):
        intensity_log_likelihood_ratio(X, block, np.array([0.5, 0, 0]), 1.0)
    with pytest.raises(ValueError, match="particles"):
        intensity_log_likelihood_ratio(np.full((2, 6), np.nan), block, o, 1.0)
    with pytest.raises(ValueError, match="design_snr"):
        IntensityTbdConfig(design_snr=-1.0)
    with pytest.raises(ValueError, match="n_particles"):
        IntensityTbdConfig(n_particles=0)
    maps = simulate_intensity_maps(pos, np.ones(5), GRID, rng)
    with pytest.raises(ValueError, match="maps.power"):
        run_intensity_tbd(IntensityMaps(np.zeros((0,) + GRID.shape), np.zeros((0, 3), np.int64),
                                        GRID), X[0], P0, rng)
    nanmaps = IntensityMaps(np.where(maps.power > 2, np.nan, maps.power), maps.origin, GRID)
    with pytest.raises(ValueError, match="maps.power"):
        run_intensity_tbd(nanmaps, X[0], P0, rng)
    with pytest.raises(ValueError, match="maps.origin"):
        run_intensity_tbd(IntensityMaps(maps.power, maps.origin[:3], GRID), X[0], P0, rng)
    with pytest.raises(TypeError, match="maps"):
        run_intensity_tbd("maps", X[0], P0, rng)
    with pytest.raises(ValueError, match="x0"):
        run_intensity_tbd(maps, np.full(6, np.nan), P0, rng)
    with pytest.raises(ValueError, match="P0"):
        run_intensity_tbd(maps, X[0], -P0, rng)
    with pytest.raises(TypeError, match="config"):
        run_intensity_tbd(maps, X[0], P0, rng, config=TbdTrackerConfig())


# ----------------------------------------------------------------------------- determinism and tracking
def test_determinism_given_a_seed():
    xs = straight_track(30)
    a = simulate_intensity_maps(xs[:, :3], np.full(30, 4.0), GRID, np.random.default_rng(7))
    b = simulate_intensity_maps(xs[:, :3], np.full(30, 4.0), GRID, np.random.default_rng(7))
    c = simulate_intensity_maps(xs[:, :3], np.full(30, 4.0), GRID, np.random.default_rng(8))
    assert np.array_equal(a.power, b.power) and np.array_equal(a.origin, b.origin)
    assert not np.array_equal(a.power, c.power)
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
    assert res.n_outside[20:].max() == 0
    assert np.all((res.ess >= 1.0) & (res.ess <= 1000.0 + 1e-9))
    assert res.resampled.any()


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
    truth = tbd_radar_truth(TbdRadarParameters(n_scans=40))
    prm = TbdRadarParameters(n_scans=40)
    det = tbd_paired_trial(np.random.default_rng(9), {"C": TbdTrackerConfig(n_particles=50)},
                           prm, truth, keep=True)
    inten = tbd_intensity_trial(np.random.default_rng(9), IntensityTbdConfig(n_particles=100),
                                prm, truth, keep=True)
    assert np.array_equal(det.x0, inten.x0)
    assert np.array_equal(det.scans.target_snr, inten.target_snr)
    assert inten.errors.shape == (40,) and np.all(np.isfinite(inten.errors))
    again = tbd_intensity_trial(np.random.default_rng(9), IntensityTbdConfig(n_particles=100),
                                prm, truth)
    assert np.array_equal(again.errors, inten.errors)
