"""Tests for the feature-JPDA tracker, its track management, the synthetic
scenes and the scene metrics."""
import numpy as np
import pytest

from trackcore.detection.image import ImageDetections, vehicle_sprite
from trackcore.scenarios.feature_metrics import (SceneMetrics, match_tracks, scene_metrics,
                                                 wilson_interval)
from trackcore.scenarios.feature_scenes import N_WARMUP, render_scene, scene_layout, segment_scene
from trackcore.trackers.jpda_tracker import (FrameReport, JPDATracker, JPDATrackerConfig,
                                             TrackSnapshot, run_jpda_tracker)

VAN = vehicle_sprite("van")[1]
SEDAN = vehicle_sprite("sedan")[1]
BAR = np.ones((22, 6), bool)


def dets(points, masks=None):
    z = np.array(points, float).reshape(-1, 2)
    if masks is None:
        masks = [VAN] * len(z)
    return ImageDetections(z, np.zeros((len(z), 4), np.int64), np.zeros(len(z), np.int64),
                           list(masks), list(masks))


def line(k, x0=50.0, y0=100.0, vx=2.0, vy=0.5):
    return [x0 + vx * k, y0 + vy * k]


def statuses(rep):
    return {s.tid: s.status for s in rep.tracks}


# ---------------------------------------------------------------- state machine
def test_tsi_and_confirmation_timeline():
    trk = JPDATracker(JPDATrackerConfig(variant="JPDA"))
    seen = [statuses(trk.step(dets([line(k)]))) for k in range(6)]
    assert seen[0] == {}                         # stored as "previous"
    assert seen[1] == {1: "tentative"}           # TSI pair
    assert seen[2] == {1: "reserved"}
    assert seen[3] == {1: "reserved"}            # 1st consecutive hit in reserved
    assert seen[4] == {1: "confirmed"}           # 2nd consecutive hit
    assert seen[5] == {1: "confirmed"}
    tr = trk.tracks[0]
    assert np.allclose(tr.x[2:], [2.0, 0.5], atol=0.3)    # CV state [x, y, vx, vy]


def test_tsi_feature_ablation_pairs_only_similar_shapes():
    """tsi_feature=True (spec section 9 ablation): a TSI pair needs
    rho(z_p, z_c) >= c_I; the default pairs on distance alone."""
    for tsi_feature, expect in ((False, ["tentative"]), (True, [])):
        trk = JPDATracker(JPDATrackerConfig(variant="FJPDA", tsi_feature=tsi_feature))
        trk.step(dets([[50, 100]], [VAN]))
        rep = trk.step(dets([[52, 100]], [BAR]))      # within r, different shape
        assert [s.status for s in rep.tracks] == expect
    # the unpaired bar replaces the previous set and pairs with a second bar
    rep = trk.step(dets([[54, 100]], [BAR]))
    assert [s.status for s in rep.tracks] == ["tentative"]
    trk = JPDATracker(JPDATrackerConfig(variant="FJPDA", tsi_feature=True))
    trk.step(dets([[50, 100]], [VAN]))
    rep = trk.step(dets([[52, 100]], [VAN]))          # same shape: paired
    assert [s.status for s in rep.tracks] == ["tentative"]


def test_tsi_respects_max_speed_radius():
    trk = JPDATracker(JPDATrackerConfig(variant="JPDA"))
    trk.step(dets([[50, 100]]))
    rep = trk.step(dets([[59, 100]]))            # 9 px > v_max T + 3 = 8 px
    assert rep.tracks == ()
    rep = trk.step(dets([[66, 100]]))            # 7 px from the stored 59
    assert [s.status for s in rep.tracks] == ["tentative"]


def test_tentative_deleted_on_miss_and_reserved_on_second_miss():
    trk = JPDATracker(JPDATrackerConfig(variant="JPDA"))
    trk.step(dets([line(0)]))
    trk.step(dets([line(1)]))
    rep = trk.step(dets([]))
    assert rep.tracks == () and rep.deleted == ((1, "miss"),)
    trk = JPDATracker(JPDATrackerConfig(variant="JPDA"))
    for k in range(3):
        trk.step(dets([line(k)]))
    assert statuses(trk.step(dets([]))) == {1: "reserved"}   # 1st miss survives
    rep = trk.step(dets([]))
    assert rep.deleted == ((1, "miss"),)


def test_confirmed_memory_cycle_and_memory_deletion():
    trk = JPDATracker(JPDATrackerConfig(variant="JPDA"))
    for k in range(5):
        trk.step(dets([line(k)]))
    assert statuses(trk.step(dets([]))) == {1: "memory"}
    assert statuses(trk.step(dets([line(7)]))) == {1: "confirmed"}
    assert statuses(trk.step(dets([]))) == {1: "memory"}
    rep = trk.step(dets([]))
    assert rep.deleted == ((1, "miss"),) and rep.tracks == ()


def test_gate_size_deletion():
    """First update of a TSI track: P_pos = R + 2R + 2R + sigma_a^2/4 per axis, so
    S = 6.0225 px^2 and the gate semi-axis is sqrt(9.21 * 6.0225) = 7.448 px."""
    semi = np.sqrt(9.21 * (5.0 + 0.09 / 4 + 1.0))
    for gmax, deleted in ((semi - 0.01, True), (semi + 0.01, False)):
        trk = JPDATracker(JPDATrackerConfig(variant="JPDA", gate_max=gmax))
        trk.step(dets([line(0)]))
        trk.step(dets([line(1)]))
        rep = trk.step(dets([line(2)]))
        assert (rep.deleted == ((1, "gate"),)) is deleted
        if not deleted:
            assert rep.tracks[0].gate_x == pytest.approx(semi, rel=1e-9)


def _two_identical_tracks(dup):
    trk = JPDATracker(JPDATrackerConfig(variant="JPDA", duplicate_deletion=dup))
    for k in range(5):
        trk.step(dets([line(k)]))
    # a clone of track 1, born later: a duplicate
    import copy
    clone = copy.deepcopy(trk.tracks[0])
    clone.tid, clone.born, clone.dup = 99, trk.k - 1, {}
    trk.tracks.append(clone)
    reps = [trk.step(dets([line(k)])) for k in range(5, 9)]
    return reps


def test_duplicate_deletion_after_three_frames_keeps_longer_history():
    reps = _two_identical_tracks(True)
    assert {s.tid for s in reps[0].tracks} == {1, 99}
    assert {s.tid for s in reps[1].tracks} == {1, 99}
    assert reps[2].deleted == ((99, "duplicate"),)
    assert {s.tid for s in reps[3].tracks} == {1}
    reps = _two_identical_tracks(False)
    assert {s.tid for s in reps[-1].tracks} == {1, 99}


def test_empty_scans_and_no_tracks():
    trk = JPDATracker()
    for _ in range(3):
        rep = trk.step(dets([]))
    assert rep.tracks == () and rep.n_events == 0


# ---------------------------------------------------------------- features
def test_feature_gate_rejects_wrong_shape_and_reduces_events():
    """A bar next to a van track: JPDA validates it, FJPDA does not."""
    out = {}
    for variant in ("JPDA", "FJPDA-gate", "FJPDA"):
        trk = JPDATracker(JPDATrackerConfig(variant=variant))
        for k in range(5):
            trk.step(dets([line(k, vy=0.0)]))
        z = line(5, vy=0.0)
        rep = trk.step(dets([z, [z[0] + 1.5, z[1] + 1.0]], [VAN, BAR]))
        out[variant] = rep
    assert out["JPDA"].n_valid == 2 and out["JPDA"].n_events == 3
    for v in ("FJPDA-gate", "FJPDA"):
        assert out[v].n_valid_kin == 2 and out[v].n_valid == 1 and out[v].n_events == 2


def test_rho_weighting_prefers_matching_shape():
    """Two measurements equidistant from a van track: FJPDA (eq 6) moves the
    estimate towards the van-shaped one, plain JPDA stays in the middle."""
    xs = {}
    for variant in ("JPDA", "FJPDA"):
        trk = JPDATracker(JPDATrackerConfig(variant=variant, c_I=0.3))
        for k in range(5):
            trk.step(dets([line(k, vy=0.0)]))
        z = line(5, vy=0.0)
        trk.step(dets([[z[0], z[1] + 1.2], [z[0], z[1] - 1.2]], [VAN, SEDAN]))
        xs[variant] = trk.tracks[0].x[1] - z[1]
    assert abs(xs["JPDA"]) < 0.05
    assert xs["FJPDA"] > 0.1


def test_gnn_variant_and_position_only_ablation():
    for cfg in (JPDATrackerConfig(variant="GNN"), JPDATrackerConfig(variant="JPDA", model="rw")):
        reps = run_jpda_tracker([dets([line(k)]) for k in range(8)], cfg)
        assert [s.status for s in reps[-1].tracks] == ["confirmed"]


@pytest.mark.parametrize("kwargs", [dict(variant="PDA"), dict(pd=1.5), dict(gamma=-1.0),
                                    dict(model="ca"), dict(c_I=2.0), dict(dup_frames=0),
                                    dict(lam=0.0)])
def test_bad_config(kwargs):
    with pytest.raises(ValueError, match=list(kwargs)[0]):
        JPDATrackerConfig(**kwargs)


def test_mismatched_masks_raise():
    with pytest.raises(ValueError, match="masks"):
        JPDATracker().step(ImageDetections(np.zeros((2, 2)), None, None, [VAN], [VAN]))


# ---------------------------------------------------------------- scenes and metrics
def test_scene_s2a_render_segment_track():
    rng = np.random.default_rng(0)
    sc = render_scene("S2a", rng)
    objs, K, conflict, pair = scene_layout("S2a")
    assert sc.frames.shape == (N_WARMUP + K, 240, 320) and sc.frames.dtype == np.uint8
    assert sc.xy.shape == (K, 2, 2) and conflict == 43
    assert np.all(sc.labels[:N_WARMUP] == 0)                 # vehicle-free warm-up
    d = np.hypot(*(sc.xy[:, 0] - sc.xy[:, 1]).T)
    assert np.nanmin(d) >= 22.0
    dets_, masks = segment_scene(sc, "running_average")
    assert len(dets_) == K and masks.shape == (K, 240, 320)
    assert np.mean([len(x.z) == sc.present[k].sum() for k, x in enumerate(dets_)]) > 0.9
    reps = run_jpda_tracker(dets_, JPDATrackerConfig(variant="FJPDA"))
    m = scene_metrics(sc, reps)
    assert isinstance(m, SceneMetrics)
    assert m.tmr > 0.9 and m.crossing == "kept" and m.false_tracks == 0


@pytest.mark.parametrize("name", ["S1", "S3"])
def test_clutter_stays_a_separate_blob(name):
    """Clutter beside a lane never touches a vehicle (>= 3 px between masks),
    so segmentation gives the vehicle its own blob while the clutter is on."""
    from scipy import ndimage
    sc = render_scene(name, np.random.default_rng(7))
    veh = np.nonzero(sc.is_vehicle)[0]
    clutter = np.nonzero(~sc.is_vehicle)[0]
    gaps = []
    for k in range(sc.xy.shape[0]):
        lab = sc.labels[N_WARMUP + k]
        for i in veh:
            if not sc.present[k, i]:
                continue
            dist = ndimage.distance_transform_cdt(lab != i + 1, metric="taxicab")
            for c in clutter:
                if sc.present[k, c]:
                    gaps.append(dist[lab == c + 1].min() - 1)
    assert len(gaps) > 10 and min(gaps) >= 3
    dets_, _ = segment_scene(sc, "running_average")
    both = [k for k in range(len(dets_)) if sc.visible[k, veh[0]] and sc.present[k, clutter].any()]
    err = [np.hypot(*(dets_[k].z - sc.xy[k, veh[0]]).T).min() for k in both]
    assert len(both) > 5 and np.median(err) < 1.0 and max(err) < 3.0


def test_scene_names_and_bad_input():
    with pytest.raises(ValueError, match="name"):
        scene_layout("S9")
    sc = render_scene("S2a", np.random.default_rng(1))
    with pytest.raises(ValueError, match="method"):
        segment_scene(sc, "median")


def _fake_reports(tracks_per_frame):
    return [FrameReport(k, tuple(TrackSnapshot(tid, st, x, y, 1.0, 1.0, 0)
                                 for tid, st, x, y in tr), 1, 0, 0, (), 0.0)
            for k, tr in enumerate(tracks_per_frame)]


def test_metrics_perfect_swap_and_false_track():
    K = 60
    xy = np.zeros((K, 2, 2))
    xy[:, 0, 0] = np.arange(K)
    xy[:, 1, 0] = np.arange(K) + 50.0
    present = np.ones((K, 2), bool)
    sc = render_scene("S2a", np.random.default_rng(2))._replace(
        xy=xy, present=present, visible=present, conflict_frame=30, pair=(0, 1))
    perfect = _fake_reports([[(1, "confirmed", xy[k, 0, 0], 0.0), (2, "confirmed", xy[k, 1, 0], 0.0)]
                             for k in range(K)])
    m = scene_metrics(sc, perfect)
    assert m.tmr == 1.0 and m.crossing == "kept" and m.id_switches == 0 and m.false_tracks == 0
    assert m.mota == pytest.approx(1.0)
    swapped = _fake_reports([[(1 if k < 30 else 2, "confirmed", xy[k, 0, 0], 0.0),
                              (2 if k < 30 else 1, "confirmed", xy[k, 1, 0], 0.0),
                              (7, "confirmed", 200.0, 200.0)] for k in range(K)])
    m = scene_metrics(sc, swapped)
    assert m.crossing == "swap" and m.id_switches == 2 and m.false_tracks == 1
    assert m.false_sources == (("other", 1),)
    assert m.tmr == pytest.approx((27 * 2) / (57 * 2))
    ids, _ = match_tracks(xy, present, swapped)
    assert ids[0, 0] == 1 and ids[40, 0] == 2


def test_false_tracks_attributed_to_nearest_clutter_object():
    sc = render_scene("S1", np.random.default_rng(6))
    bar = sc.names.index("bar")
    van = sc.names.index("van")
    K = sc.xy.shape[0]
    on_bar = [k for k in range(K) if sc.present[k, bar]]
    reps = _fake_reports([[(1, "confirmed", *sc.xy[k, van])]
                          + ([(2, "confirmed", sc.xy[k, bar, 0] + 2.0, sc.xy[k, bar, 1])]
                             if k in on_bar else [])
                          + ([(3, "memory", 5.0, 5.0)] if 10 <= k < 14 else [])
                          for k in range(K)])
    m = scene_metrics(sc, reps)
    assert m.false_tracks == 2 and m.false_sources == (("bar", 1), ("other", 1))
    assert m.tmr == 1.0


def test_wilson_interval():
    lo, hi = wilson_interval(5, 10)
    assert lo == pytest.approx(0.2366, abs=1e-4) and hi == pytest.approx(0.7634, abs=1e-4)
    lo, hi = wilson_interval(50, 50)
    assert hi == pytest.approx(1.0) and lo == pytest.approx(0.9287, abs=1e-4)
    with pytest.raises(ValueError):
        wilson_interval(3, 2)


def test_vehicle_mask_iou_perfect_and_empty():
    from trackcore.scenarios.feature_metrics import vehicle_mask_iou
    sc = render_scene("S2a", np.random.default_rng(3))
    truth = sc.labels[N_WARMUP:] > 0
    v = vehicle_mask_iou(sc, truth)
    assert len(v) == sc.visible.sum() and np.allclose(v, 1.0)
    assert np.all(vehicle_mask_iou(sc, np.zeros_like(truth)) == 0.0)


def test_crossing_detections_geometry_and_lr_variant():
    import math
    from trackcore.scenarios.feature_scenes import crossing_detections
    dets_, sc = crossing_detections(np.random.default_rng(4), heading_b=math.radians(20),
                                    min_sep=3.0, pd=1.0, clutter_rate=0.0)
    d = np.hypot(*(sc.xy[:, 0] - sc.xy[:, 1]).T)
    assert np.argmin(d) == sc.conflict_frame and d.min() == pytest.approx(3.0)
    assert all(len(x.z) == 2 and len(x.masks) == 2 for x in dets_)
    cfg = JPDATrackerConfig(variant="FJPDA", feature_lr=(20.0, 1.5, 5.0, 4.0))
    reps = run_jpda_tracker(dets_[:12], cfg)
    assert sum(s.status == "confirmed" for s in reps[-1].tracks) >= 1
    with pytest.raises(ValueError, match="feature_lr"):
        JPDATrackerConfig(feature_lr=(1.0, 2.0))


def test_scene_trial_runs_variants_on_shared_detections():
    from trackcore.scenarios.feature_metrics import scene_trial
    cfgs = {"JPDA": JPDATrackerConfig(variant="JPDA"), "FJPDA": JPDATrackerConfig(variant="FJPDA")}
    t = scene_trial(np.random.default_rng(5), "S2a", cfgs, method="running_average")
    assert set(t.metrics) == set(cfgs) and t.truth_xy.shape == (80, 2, 2)
    assert len(t.positions["JPDA"]) == 80
    assert all(p.shape[1] == 2 for p in t.positions["FJPDA"])
    t2 = scene_trial(np.random.default_rng(5), "S2a", cfgs, method="running_average")
    # reproducible from the generator (all but the wall-clock association time)
    assert {k: m._replace(assoc_ms=0.0) for k, m in t2.metrics.items()} == \
        {k: m._replace(assoc_ms=0.0) for k, m in t.metrics.items()}


def test_scene_trials_share_one_rendering_across_segmentations():
    from trackcore.scenarios.feature_metrics import scene_trial, scene_trials
    cfgs = {"JPDA": JPDATrackerConfig(variant="JPDA")}
    both = scene_trials(np.random.default_rng(7), "S1",
                        {"vibe": cfgs, "running_average": cfgs})
    for method in ("vibe", "running_average"):
        one = scene_trial(np.random.default_rng(7), "S1", cfgs, method=method)
        assert one.metrics["JPDA"]._replace(assoc_ms=0.0) == \
            both[method].metrics["JPDA"]._replace(assoc_ms=0.0)
        assert np.array_equal(one.truth_xy, both[method].truth_xy, equal_nan=True)
    with pytest.raises(ValueError, match="variants_by_method"):
        scene_trials(np.random.default_rng(7), "S1", {})
