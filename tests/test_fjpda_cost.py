"""The measured-cluster and duplicate-rule CLEAR-MOT helpers of the feature-JPDA
chapter (trackcore.experiments.fjpda_cost)."""
import numpy as np
import pytest

from trackcore.experiments import fjpda_cost as fc


def _notebook_instance(rng, T):
    # notebook 06's original model at the assumed rates (0.7, 0.5, Poisson 2)
    m = T + rng.poisson(2.0)
    valid = rng.random((m, T)) < 0.7
    wrong = np.ones((m, T), bool)
    idx = np.arange(T)
    wrong[idx, idx] = False
    gated = valid & ~(wrong & (rng.random((m, T)) < 0.5))
    return valid, gated


def test_cluster_instance_is_the_notebook_model():
    a, b = np.random.default_rng(3), np.random.default_rng(3)
    for T in range(1, 6):
        v1, g1 = fc.cluster_instance(a, T, 0.7, 0.5, 2.0)
        v2, g2 = _notebook_instance(b, T)
        assert np.array_equal(v1, v2) and np.array_equal(g1, g2)


def test_simulated_events_gate_never_adds_and_no_rejection_changes_nothing():
    plain, feat = fc.simulated_events(np.random.default_rng(1), 4, 20, 0.7, 0.5, 2.0)
    assert np.all(feat <= plain) and np.all(plain >= 1)
    plain, feat = fc.simulated_events(np.random.default_rng(1), 4, 20, 0.7, 0.0, 2.0)
    assert np.array_equal(plain, feat)


def test_pooled_rates_sums_over_stores_and_handles_no_multi_cluster():
    zero = {c: np.zeros(3, np.int64) for c in fc.CLUSTER_COLUMNS}
    one = dict(zero, clusters_3=np.array([1, 0, 0]), multi_tracks=np.array([3, 0, 0]),
               multi_meas=np.array([2, 0, 0]), multi_cells=np.array([6, 0, 0]),
               multi_pairs=np.array([3, 0, 0]), pairs_kin=np.array([5, 1, 0]),
               pairs_removed=np.array([1, 0, 0]))
    rates = fc.pooled_rates([zero, one])
    assert rates["p"] == 0.5 and rates["r"] == pytest.approx(1 / 6)
    assert rates["clutter"] == 0.0 and rates["n_multi"] == 1
    none = fc.pooled_rates([zero])
    assert np.isnan(none["p"]) and np.isnan(none["clutter"]) and none["n_multi"] == 0


def test_kinematic_validation_matches_the_tracker_every_frame():
    from trackcore.scenarios.feature_scenes import crossing_detections
    from trackcore.trackers.jpda_tracker import JPDATracker, JPDATrackerConfig

    detections, _ = crossing_detections(np.random.default_rng(0))
    tracker = JPDATracker(JPDATrackerConfig(variant="FJPDA"))
    for d in detections:
        v = fc.kinematic_validation(tracker, d.z)
        assert int(v.sum()) == tracker.step(d).n_valid_kin


def test_cluster_trial_columns_are_consistent():
    out = fc.cluster_trial(np.random.default_rng(0), "side_by_side", 5.0)
    assert set(out) == set(fc.CLUSTER_COLUMNS)
    n_multi = out["clusters_2"] + out["clusters_3"] + out["clusters_4plus"]
    assert out["multi_tracks"] >= 2 * n_multi
    assert out["multi_pairs"] <= out["multi_cells"] and out["multi_pairs"] <= out["pairs_kin"]
    assert 0 <= out["pairs_removed"] <= out["pairs_kin"]
    assert out["events"] <= out["events_kin"]


def test_configs_reject_unknown_scenes_and_list_the_dup_variants():
    with pytest.raises(ValueError, match="scene must be one of"):
        fc.FjpdaClusterConfig("S9", 5.0)
    cfg = fc.FjpdaDupMotConfig().variants()
    assert list(cfg) == list(fc.DUP_VARIANTS)
    assert cfg["JPDA"].duplicate_deletion and not cfg["JPDA, no duplicate deletion"].duplicate_deletion


def test_events_ratio_interval_or_marked_point():
    rng = np.random.default_rng(2)
    y = rng.integers(2, 6, 60).astype(float)
    x = y + rng.integers(0, 3, 60)
    e = fc.events_ratio(x, y)
    assert e.lo <= x.mean() / y.mean() <= e.hi
    assert format(fc.events_ratio([4, 4, 4], [2, 2, 2]), ".1f") == "2.0 (no interval)"
    assert np.isnan(fc.events_ratio([], []))
