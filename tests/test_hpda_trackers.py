"""Tests for the HPDA-PF, SMC-PHD and clustering trackers (paper 000)."""
import math

import numpy as np
import pytest

from trackcore.scenarios import hpda_parameters, hpda_true_count, hpda_truth, simulate_hpda_scans
from trackcore.trackers import HpdaPfConfig, hpda_pf_run
from trackcore.trackers.hpda_pf import jump_markov_propagate_kernel


def _short(case=1, K=60, seed=0, clutter=None):
    from dataclasses import replace
    p = hpda_parameters(case)
    if clutter is not None:
        p = replace(p, clutter_mean=clutter)
    truth = hpda_truth(n_scans=K)
    s = simulate_hpda_scans(truth, p, np.random.default_rng(seed))
    return p, truth, s


def _cfg(p, **kw):
    return HpdaPfConfig(pd=p.pd, snr=p.snr, clutter_density_xy=max(p.clutter_density_xy, 1e-9),
                        **kw)


def test_hpda_single_target_confirmed_and_accurate():
    p, truth, s = _short()
    out = hpda_pf_run(s.z, s.amplitude, s.offsets, _cfg(p, n_particles=300), np.random.default_rng(1))
    n = hpda_true_count(truth)
    assert out.count.shape == (60,)
    # confirmed within a few scans, then exactly one track most of the time
    first = int(np.argmax(out.count >= 1))
    assert first <= 6
    assert np.mean(out.count[first:] == n[first:]) > 0.9
    k = 59
    err = np.hypot(*(out.estimates[k, 0, :2] - truth.states[k, 0, :2]))
    assert err < 150.0
    assert out.n_estimates[k] == out.count[k]


def test_hpda_empty_scans_and_clutter_only():
    off = np.zeros(21, dtype=np.int64)
    cfg = HpdaPfConfig(pd=0.9, snr=10, clutter_density_xy=3e-8, n_particles=50)
    out = hpda_pf_run(np.zeros((0, 2)), np.zeros(0), off, cfg, np.random.default_rng(0))
    assert np.all(out.count == 0) and np.all(out.aux == 0)
    # clutter only: few false confirmations in case 1
    rng = np.random.default_rng(3)
    K, M = 50, 10
    r = 1e4 * np.sqrt(rng.random(K * M))
    z = np.column_stack([r, rng.uniform(-np.pi, np.pi, K * M)])
    a = 1.159 + rng.exponential(1.0, K * M)
    off = np.arange(0, K * M + 1, M, dtype=np.int64)
    out = hpda_pf_run(z, a, off, HpdaPfConfig(pd=0.9, snr=10, clutter_density_xy=10 / (math.pi * 1e8),
                                              n_particles=50), np.random.default_rng(4))
    assert out.count.mean() < 0.3


def test_hpda_deterministic_and_rules():
    p, truth, s = _short(case=2, K=40)
    a = hpda_pf_run(s.z, s.amplitude, s.offsets, _cfg(p, n_particles=100), np.random.default_rng(9))
    b = hpda_pf_run(s.z, s.amplitude, s.offsets, _cfg(p, n_particles=100), np.random.default_rng(9))
    np.testing.assert_array_equal(a.count, b.count)
    np.testing.assert_array_equal(a.estimates, b.estimates)
    for rule in ("strongest", "nearest"):
        out = hpda_pf_run(s.z, s.amplitude, s.offsets, _cfg(p, n_particles=100, selection=rule),
                          np.random.default_rng(9))
        assert out.count.shape == (40,)


def test_jump_markov_kernel_modes():
    rng = np.random.default_rng(0)
    X = np.tile([0.0, 0.0, 1.5, 0.0], (4000, 1))
    modes = np.zeros(4000, dtype=np.int64)
    cum = np.cumsum(np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]]), axis=1)
    jump_markov_propagate_kernel(X, modes, cum, 10.0, 0.0, 0.01, rng)
    assert np.all(modes == 1)
    # left turn: speed preserved, heading rotated by a_m T / v
    np.testing.assert_allclose(np.hypot(X[:, 2], X[:, 3]), 1.5, rtol=1e-12)
    np.testing.assert_allclose(np.arctan2(X[:, 3], X[:, 2]), 0.01 * 10 / 1.5, rtol=1e-12)
    # mode frequencies follow the TPM row
    X = np.tile([0.0, 0.0, 1.5, 0.0], (20000, 1))
    modes = np.zeros(20000, dtype=np.int64)
    cum = np.cumsum(np.array([[0.9, 0.05, 0.05]] * 3), axis=1)
    jump_markov_propagate_kernel(X, modes, cum, 10.0, 0.0015, 0.01, rng)
    frac = np.bincount(modes, minlength=3) / 20000
    assert abs(frac[0] - 0.9) < 4 * math.sqrt(0.09 / 20000)


def test_hpda_bad_input():
    cfg = HpdaPfConfig(pd=0.9, snr=10, clutter_density_xy=3e-8, n_particles=10)
    off = np.array([0, 1])
    with pytest.raises(ValueError, match="amplitude must not contain NaN"):
        hpda_pf_run(np.array([[5000.0, 0.1]]), np.array([np.nan]), off, cfg, np.random.default_rng())
    with pytest.raises(ValueError, match="offsets"):
        hpda_pf_run(np.array([[5000.0, 0.1]]), np.array([2.0]), np.array([0, 2]), cfg,
                    np.random.default_rng())
    with pytest.raises(ValueError, match="z must have shape"):
        hpda_pf_run(np.ones((1, 3)), np.array([2.0]), off, cfg, np.random.default_rng())
    with pytest.raises(TypeError, match="rng"):
        hpda_pf_run(np.array([[5000.0, 0.1]]), np.array([2.0]), off, cfg, 1)
    with pytest.raises(TypeError, match="config"):
        hpda_pf_run(np.array([[5000.0, 0.1]]), np.array([2.0]), off, {}, np.random.default_rng())
    from dataclasses import replace
    with pytest.raises(ValueError, match="pd"):
        replace(cfg, pd=1.0)
    with pytest.raises(ValueError, match="selection"):
        replace(cfg, selection="x")
    with pytest.raises(ValueError, match="mode_tpm"):
        replace(cfg, mode_tpm=((1, 1, 0), (0, 1, 0), (0, 0, 1)))
    with pytest.raises(ValueError, match="range"):
        hpda_pf_run(np.array([[-5.0, 0.1]]), np.array([2.0]), off, cfg, np.random.default_rng())


# ---------------------------------------------------------------- SMC-PHD
from trackcore.trackers import (ClusteringConfig, SmcPhdConfig, clustering_run,  # noqa: E402
                                smc_phd_run)
from trackcore.trackers.smc_phd import kmeans_extract_kernel  # noqa: E402


def test_phd_mass_tracks_single_target():
    p, truth, s = _short(K=60)
    cfg = SmcPhdConfig(pd=p.pd, clutter_density_xy=p.clutter_density_xy, n_per_target=300,
                       n_birth=200)
    out = smc_phd_run(s.z, s.offsets, cfg, np.random.default_rng(2))
    # after the first few scans the mass is close to one target
    assert abs(out.aux[20:].mean() - 1.0) < 0.35
    ones = 20 + np.nonzero(out.count[20:] == 1)[0]
    assert ones.size > 0.7 * 40
    # every scan that reports one target reports it near the truth (never vacuous:
    # at least 28 such scans are checked)
    err = np.hypot(*(out.estimates[ones, 0, :2] - truth.states[ones, 0, :2]).T)
    assert out.n_estimates[ones].min() == 1
    assert np.all(err < 200), err.max()


def test_phd_empty_and_deterministic():
    cfg = SmcPhdConfig(pd=0.9, clutter_density_xy=3e-8, n_per_target=100, n_birth=50)
    out = smc_phd_run(np.zeros((0, 2)), np.zeros(11, dtype=np.int64), cfg, np.random.default_rng(0))
    assert np.all(out.count == 0) and np.all(out.aux == 0)
    p, truth, s = _short(case=2, K=30)
    cfg = SmcPhdConfig(pd=p.pd, clutter_density_xy=p.clutter_density_xy, n_per_target=100,
                       n_birth=50)
    a = smc_phd_run(s.z, s.offsets, cfg, np.random.default_rng(5))
    b = smc_phd_run(s.z, s.offsets, cfg, np.random.default_rng(5))
    np.testing.assert_array_equal(a.aux, b.aux)


def test_phd_far_measurement_removes_birth_mass():
    # births from scan 0 meet the update at scan 1: with P_D = 1 - 1e-9 and a
    # measurement far from every birth particle, the missed-detection factor
    # 1 - P_D removes (almost) all of the birth mass
    cfg = SmcPhdConfig(pd=1 - 1e-9, clutter_density_xy=3e-8, n_per_target=100, n_birth=100)
    z = np.array([[5000.0, 0.0], [5000.0, 2.0]])
    out = smc_phd_run(z, np.array([0, 1, 2]), cfg, np.random.default_rng(0))
    assert out.aux[1] < 1e-6


def test_kmeans_kernel_two_blobs():
    rng = np.random.default_rng(0)
    X = np.vstack([rng.normal([0, 0, 1, 0], 10, (500, 4)), rng.normal([5000, 0, -1, 0], 10, (500, 4))])
    X = np.vstack([X, [[-9000.0, 9000.0, 0, 0]]])      # a stray particle is ignored
    cen = np.zeros((2, 4))
    lab = np.zeros(1001, dtype=np.int64)
    # candidates: a stale centre (no particles near it) and two measurements
    cand = np.array([[0.0, 8000, 0, 0], [300.0, 100, 0, 0], [4700.0, -100, 0, 0]])
    n = kmeans_extract_kernel(X, 2, cand, 3, 10, 1000.0 ** 2, cen, lab)
    assert n == 2
    xs = sorted(cen[:, 0])
    assert abs(xs[0]) < 5 and abs(xs[1] - 5000) < 5
    assert lab[-1] == -1


def test_phd_bad_input():
    cfg = SmcPhdConfig(pd=0.9, clutter_density_xy=3e-8)
    with pytest.raises(TypeError, match="config"):
        smc_phd_run(np.zeros((0, 2)), np.zeros(2, dtype=np.int64), {}, np.random.default_rng())
    with pytest.raises(ValueError, match="offsets"):
        smc_phd_run(np.zeros((1, 2)), np.array([0, 0]), cfg, np.random.default_rng())
    with pytest.raises(ValueError, match="z must"):
        smc_phd_run(np.full((1, 2), np.nan), np.array([0, 1]), cfg, np.random.default_rng())


# ---------------------------------------------------------------- clustering
def test_clustering_tracks_with_wide_links_and_literal_rule_is_strict():
    p, truth, s = _short(K=80)
    wide = ClusteringConfig(pd=p.pd, clutter_density_xy=p.clutter_density_xy, n_particles=200,
                            link_d2=9.21)
    out = clustering_run(s.z, s.offsets, wide, np.random.default_rng(1))
    assert out.count.mean() > 0.4
    k = np.nonzero(out.count == 1)[0][-1]
    assert np.hypot(*(out.estimates[k, 0, :2] - truth.states[k, 0, :2])) < 300
    lit = ClusteringConfig(pd=p.pd, clutter_density_xy=p.clutter_density_xy, n_particles=200)
    out2 = clustering_run(s.z, s.offsets, lit, np.random.default_rng(1))
    assert out2.count.mean() <= out.count.mean()


def test_clustering_empty_and_bad_input():
    cfg = ClusteringConfig(pd=0.9, clutter_density_xy=3e-8, n_particles=20)
    out = clustering_run(np.zeros((0, 2)), np.zeros(6, dtype=np.int64), cfg, np.random.default_rng(0))
    assert np.all(out.count == 0)
    with pytest.raises(TypeError, match="config"):
        clustering_run(np.zeros((0, 2)), np.zeros(2, dtype=np.int64), {}, np.random.default_rng())
    from dataclasses import replace
    with pytest.raises(ValueError, match="eps_w"):
        replace(cfg, eps_w=0.0)
    with pytest.raises(ValueError, match="eta"):
        replace(cfg, eta=0)


def test_clustering_roi_window_spans_eta_plus_one_scans():
    # Text (sec 2.2): chains run from scan k - eta to scan k (eta + 1 scans) and an ROI needs more
    # than P_D * eta measurements.  A fixed point seen in two of every three scans (no clutter) then
    # forms an ROI at every scan and is confirmed and kept; with a window of only eta = 2 scans
    # (needing 2 of 2) consecutive ROIs never share a measurement and no track is ever born.
    K = 40
    keep = np.array([k % 3 != 2 for k in range(K)])
    counts = keep.astype(np.int64)
    off = np.zeros(K + 1, dtype=np.int64)
    np.cumsum(counts, out=off[1:])
    z = np.tile([5000.0, 0.3], (int(off[-1]), 1))
    cfg = ClusteringConfig(pd=0.9, clutter_density_xy=3e-8, n_particles=200)
    out = clustering_run(z, off, cfg, np.random.default_rng(3))
    born = np.nonzero(out.count > 0)[0]
    assert born.size and born[0] <= 4
    assert np.all(out.count[born[0]:] == 1)
    assert len(np.unique(out.ids[out.ids >= 0])) == 1
    k = K - 1
    assert abs(np.hypot(*out.estimates[k, 0, :2]) - 5000.0) < 100.0
