"""The strong reading of the clustering hybrid: a motion term in the ROI links, chains
seeded from every scan of the window, and a track's own gated return as support."""
import math

import numpy as np
import pytest

from trackcore.scenarios import (hpda_parameters, hpda_tracker_configs, hpda_truth,
                                 simulate_hpda_scans)
from trackcore.trackers import ClusteringConfig, clustering_link_rates, clustering_run
from trackcore.trackers.clustering_hybrid import CHI2_2_99


def _scans(pattern, z0=(5000.0, 0.3), jitter=None, seed=0):
    """One fixed point seen at the scans where ``pattern`` is True (no clutter)."""
    K = len(pattern)
    off = np.zeros(K + 1, dtype=np.int64)
    np.cumsum(np.asarray(pattern, dtype=np.int64), out=off[1:])
    z = np.tile(z0, (int(off[-1]), 1))
    if jitter is not None:
        z += np.random.default_rng(seed).normal(size=z.shape) * jitter
    return z, off


def test_tracker_configs_hold_the_two_readings():
    cfgs = hpda_tracker_configs(hpda_parameters(1))
    strong, literal = cfgs["clustering"], cfgs["clustering_literal"]
    assert strong.link_gate == pytest.approx(9.2103, abs=1e-4) == CHI2_2_99
    assert strong.link_motion_std == strong.velocity_std == 1.5
    assert strong.seed_every_scan and strong.gated_support
    assert literal.link_gate == 1.0 and literal.link_motion_std == 0.0
    assert not literal.seed_every_scan and not literal.gated_support


def test_seeds_from_every_scan_form_an_roi_after_a_miss_at_k_minus_eta():
    # seen at two of every three scans, missed at k = 0, 3, 6, ...: with seeds only at
    # k - eta, the windows that start with a miss form no ROI, and with tau_d = 1 the
    # track dies there; seeded from every scan, every window from k = 2 on forms one
    pattern = [k % 3 != 0 for k in range(30)]
    z, off = _scans(pattern)
    base = dict(pd=0.9, clutter_density_xy=3e-8, n_particles=300, tau_d=1)
    a = clustering_run(z, off, ClusteringConfig(**base), np.random.default_rng(0))
    b = clustering_run(z, off, ClusteringConfig(**base, seed_every_scan=True),
                       np.random.default_rng(0))
    born = int(np.argmax(b.count > 0))
    assert born <= 4
    assert b.count[born:].mean() > 0.9 > 0.5 > a.count[born:].mean()


def test_gated_support_keeps_a_track_whose_rois_break():
    # identical returns link at any gate and give birth; then the returns jitter by
    # 30 m, beyond a tiny link gate, so ROIs stop forming: only the track's own gated
    # returns can keep it alive
    K = 40
    z, off = _scans([True] * K)
    z[10:] += np.random.default_rng(1).normal(size=(K - 10, 2)) * [30.0, 0.0]
    base = dict(pd=0.9, clutter_density_xy=3e-8, n_particles=300, link_d2=1e-6)
    without = clustering_run(z, off, ClusteringConfig(**base), np.random.default_rng(2))
    with_ = clustering_run(z, off, ClusteringConfig(**base, gated_support=True),
                           np.random.default_rng(2))
    assert without.count[:10].max() == 1 and with_.count[:10].max() == 1
    assert without.count[-1] == 0
    assert with_.count[10:].min() == 1


def test_motion_term_links_a_moving_target():
    # a target crossing the line of sight at 15 m per scan, 5 km out, no noise:
    # the literal link (d^2 <= 1 under 2R) rejects the step, the motion term accepts it
    K = 10
    y = 15.0 * np.arange(K)
    z = np.column_stack([np.hypot(5000.0, y), np.arctan2(y, 5000.0)])
    off = np.arange(K + 1, dtype=np.int64)
    origin = np.zeros(K, dtype=np.int64)
    rng_t = np.hypot(5000.0, y)[:, None]
    edges = [0.0, 1e4]
    lit = ClusteringConfig(pd=0.9, clutter_density_xy=3e-8)
    mot = ClusteringConfig(pd=0.9, clutter_density_xy=3e-8, link_motion_std=1.5)
    r_lit = clustering_link_rates(z, off, origin, rng_t, lit, edges)
    r_mot = clustering_link_rates(z, off, origin, rng_t, mot, edges)
    assert r_lit["pairs"][0] == r_mot["pairs"][0] == K - 1
    assert r_lit["links"][0] == 0 and r_mot["links"][0] == K - 1
    assert r_lit["windows"][0] == r_mot["windows"][0] == K - 2
    assert r_lit["rois"][0] == 0 and r_mot["rois"][0] == K - 2


def test_link_rates_on_the_scenario():
    p = hpda_parameters(1)
    truth = hpda_truth()
    s = simulate_hpda_scans(truth, p, np.random.default_rng(0))
    rng_t = np.hypot(truth.states[..., 0], truth.states[..., 1])
    cfgs = hpda_tracker_configs(p)
    edges = [0.0, 3000.0, 6000.0, 1e4]
    lit = clustering_link_rates(s.z, s.offsets, s.origin, rng_t, cfgs["clustering_literal"],
                                edges)
    strong = clustering_link_rates(s.z, s.offsets, s.origin, rng_t, cfgs["clustering"], edges)
    for r in (lit, strong):
        assert np.all(r["links"] <= r["pairs"]) and np.all(r["rois"] <= r["windows"])
        assert r["pairs"].sum() > 1000
    p_lit = lit["links"].sum() / lit["pairs"].sum()
    p_strong = strong["links"].sum() / strong["pairs"].sum()
    # noise alone links with probability 1 - exp(-1/2) = 0.39 under the literal gate
    assert p_lit < 1 - math.exp(-0.5) < 0.95 < p_strong
    assert strong["rois"].sum() > 2 * lit["rois"].sum()


def test_link_rates_bad_input():
    cfg = ClusteringConfig(pd=0.9, clutter_density_xy=3e-8)
    z, off = np.array([[5000.0, 0.0]]), np.array([0, 1])
    with pytest.raises(ValueError, match="origin"):
        clustering_link_rates(z, off, np.zeros(2, dtype=np.int64), np.ones((1, 1)), cfg, [0, 1])
    with pytest.raises(ValueError, match="target_range"):
        clustering_link_rates(z, off, np.zeros(1, dtype=np.int64), np.ones((2, 1)), cfg, [0, 1])
    with pytest.raises(ValueError, match="range_edges"):
        clustering_link_rates(z, off, np.zeros(1, dtype=np.int64), np.ones((1, 1)), cfg, [1, 0])
    with pytest.raises(TypeError, match="config"):
        clustering_link_rates(z, off, np.zeros(1, dtype=np.int64), np.ones((1, 1)), {}, [0, 1])


def test_jpda_by_component_equals_joint_enumeration():
    from trackcore.association.jpda import _enumerate_kernel
    from trackcore.trackers.clustering_hybrid import _jpda_by_component
    rng = np.random.default_rng(0)
    for _ in range(200):
        m, T = int(rng.integers(0, 7)), int(rng.integers(1, 6))
        valid = rng.random((m, T)) < 0.35
        logf = np.where(valid, rng.normal(0.0, 2.0, (m, T)), -np.inf)
        lpd, l1 = math.log(0.8), math.log(1 - 0.8 * 0.99)
        beta, beta0 = _jpda_by_component(logf, valid, lpd, l1)
        la, lm, lt, _ = _enumerate_kernel(logf, valid, np.full(T, lpd), np.full(T, l1),
                                          False, 0.0)
        np.testing.assert_allclose(beta, np.exp(la - lt), rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(beta0, np.exp(lm - lt), rtol=1e-10, atol=1e-14)


def test_dense_clutter_does_not_explode():
    # many clutter tracks: the groups stay small, so a dense scene runs in bounded time
    import time
    p = hpda_parameters(3)
    s = simulate_hpda_scans(hpda_truth(n_scans=40), p, np.random.default_rng(0))
    cfg = hpda_tracker_configs(p, clustering={"n_particles": 100})["clustering"]
    t = time.process_time()
    out = clustering_run(s.z, s.offsets, cfg, np.random.default_rng(1))
    assert time.process_time() - t < 20 and out.count.shape == (40,)
