"""Tests for the rendered feature-JPDA scenes: geometry (closest approaches, merges,
gaps), camera jitter, the ambiguity the scenes are built to create, Monte Carlo
trials and the measurement-level crossing."""
import math

import numpy as np
import pytest
from scipy import ndimage

from trackcore.detection.image import ncc, render_frame, vehicle_sprite
from trackcore.scenarios.feature_metrics import scene_run, scene_trial, scene_trials
from trackcore.scenarios.feature_scenes import (AMBIGUITY_SCENES, DEFAULT_JITTER, MIN_VEHICLE_GAP,
                                                N_WARMUP, PAPER_SCENES, SCENES, closest_approach,
                                                crossing_detections, pair_gaps, render_scene,
                                                scene_layout, segment_scene,
                                                separate_blob_distance)
from trackcore.trackers.jpda_tracker import (JPDATrackerConfig, matched_config,
                                             steady_state_gate)


@pytest.fixture(scope="module")
def scenes():
    return {name: render_scene(name, np.random.default_rng(i)) for i, name in enumerate(SCENES)}


def test_scene_names_and_bad_input():
    assert SCENES == PAPER_SCENES + AMBIGUITY_SCENES and "S4" not in SCENES
    with pytest.raises(ValueError, match="name"):
        scene_layout("S9")
    with pytest.raises(ValueError, match="jitter"):
        render_scene("S1", np.random.default_rng(0), jitter=-1.0)
    with pytest.raises(ValueError, match="jitter"):
        render_scene("S1", np.random.default_rng(0), jitter=np.nan)
    with pytest.raises(TypeError, match="rng"):
        render_scene("S1", 3)
    sc = render_scene("S2a", np.random.default_rng(1))
    with pytest.raises(ValueError, match="method"):
        segment_scene(sc, "median")


def test_shapes_warmup_and_truth(scenes):
    for name, sc in scenes.items():
        K = scene_layout(name)[1]
        assert sc.frames.shape == (N_WARMUP + K, 240, 320) and sc.frames.dtype == np.uint8
        assert np.all(sc.labels[:N_WARMUP] == 0)
        assert sc.jitter == DEFAULT_JITTER[name] and sc.offsets.shape == (N_WARMUP + K, 2)
        assert np.all(np.isnan(sc.xy[~sc.present])) and np.all(np.isfinite(sc.xy[sc.present]))
        assert np.all(sc.visible <= sc.present)


@pytest.mark.parametrize("name", ["S2a", "S2b", "occlusion"])
def test_closest_approach_at_the_scored_frame(scenes, name):
    sc = scenes[name]
    k, d = closest_approach(sc)
    assert abs(k - sc.conflict_frame) <= 2
    assert sc.score_window[0] <= k <= sc.score_window[1]
    if name != "occlusion":
        assert not sc.merged.any()


def test_s2a_silhouettes_correlate_above_threshold(scenes):
    sc = scenes["S2a"]
    lab = sc.labels[N_WARMUP + 10]
    masks = [ndimage.find_objects((lab == i + 1).astype(int))[0] for i in range(2)]
    crops = [(lab == i + 1)[m] for i, m in enumerate(masks)]
    assert ncc(crops[0], crops[1]) >= 0.6


def test_occlusion_blobs_merge_for_several_frames(scenes):
    sc = scenes["occlusion"]
    merged = np.nonzero(sc.merged)[0]
    assert 4 <= len(merged) <= 8
    assert np.all(np.diff(merged) == 1)
    assert merged[0] <= sc.conflict_frame <= merged[-1]


def test_every_other_object_keeps_its_gap(scenes):
    for name, sc in scenes.items():
        if name == "occlusion":
            continue
        veh = np.nonzero(sc.is_vehicle)[0]
        for k in range(0, sc.xy.shape[0], 3):
            lab = sc.labels[N_WARMUP + k]
            for a in veh:
                for b in range(len(sc.names)):
                    if b != a and sc.present[k, a] and sc.present[k, b]:
                        assert pair_gaps(lab, a + 1, b + 1) >= MIN_VEHICLE_GAP


def test_camera_jitter_shifts_the_whole_image():
    """Two renderings with the same seed differ only by the camera offsets: the
    labels of a jittered frame are the unjittered labels shifted by the offset."""
    sc = render_scene("glare", np.random.default_rng(9), jitter=4.0)
    off = sc.offsets
    assert np.abs(off).max() <= 16 and 2.5 < off[:, 0].std() < 5.5
    van = sc.names.index("van")
    for k in range(0, sc.xy.shape[0], 7):
        rr, cc = np.nonzero(sc.labels[N_WARMUP + k] == van + 1)
        if len(rr) and sc.visible[k, van]:
            centre = np.array([cc.mean(), rr.mean()]) - off[N_WARMUP + k]
            assert np.allclose(centre, sc.xy[k, van], atol=1e-9)
    still = render_scene("glare", np.random.default_rng(9), jitter=0.0)
    assert np.all(still.offsets == 0)


def test_ambiguity_is_built_in(scenes):
    """The glare and the side-by-side partner lie inside the first vehicle's
    steady-state gate in most frames (jitter moves them together), and the
    paper-geometry scenes keep every second object outside it."""
    for name, low, high in (("glare", 0.5, 1.0), ("side_by_side", 0.5, 1.0),
                            ("S1", 0.0, 0.0), ("S2a", 0.0, 0.0), ("S2b", 0.0, 0.0)):
        sc = scenes[name]
        gate = steady_state_gate(matched_config("JPDA", sc.jitter))
        a = np.nonzero(sc.is_vehicle)[0][0]
        o = sc.offsets[N_WARMUP:]
        inside = []
        for b in range(len(sc.names)):
            if b == a:
                continue
            both = sc.present[:, a] & sc.present[:, b]
            d = np.hypot(*(sc.xy[both, b] - sc.xy[both, a] + o[both]).T)
            inside.append(d <= gate)
        frac = np.concatenate(inside).mean()
        assert low <= frac <= high, (name, frac)


def test_segmentation_recovers_vehicles_with_jitter():
    """Under camera jitter the detections follow the shifted image: the measured
    centroid minus the frame's offset is the scene truth to within a pixel."""
    g = np.random.default_rng(4)
    sc = render_scene("side_by_side", g)
    dets, _ = segment_scene(sc, "vibe", g)
    err = []
    for k, d in enumerate(dets):
        if len(d.z) == 0:
            continue
        z = d.z - sc.offsets[N_WARMUP + k]
        for i in (0, 1):
            if sc.visible[k, i]:
                err.append(np.hypot(*(z - sc.xy[k, i]).T).min())
    assert len(err) > 80 and np.median(err) < 1.0


def test_scene_trial_reproducible_and_shared_rendering():
    cfgs = {"JPDA": JPDATrackerConfig(variant="JPDA"), "FJPDA": JPDATrackerConfig(variant="FJPDA")}
    t = scene_trial(np.random.default_rng(5), "S2a", cfgs, method="running_average")
    assert set(t.metrics) == set(cfgs) and t.truth_xy.shape == (80, 2, 2)
    assert len(t.positions["JPDA"]) == 80
    t2 = scene_trial(np.random.default_rng(5), "S2a", cfgs, method="running_average")
    assert {k: m._replace(assoc_ms=0.0) for k, m in t2.metrics.items()} == \
        {k: m._replace(assoc_ms=0.0) for k, m in t.metrics.items()}
    both = scene_trials(np.random.default_rng(7), "S1", {"vibe": cfgs, "running_average": cfgs})
    one = scene_trial(np.random.default_rng(7), "S1", cfgs, method="running_average")
    assert one.metrics["JPDA"]._replace(assoc_ms=0.0) == \
        both["running_average"].metrics["JPDA"]._replace(assoc_ms=0.0)
    scene, dets, reps = scene_run(np.random.default_rng(5), "S2a", cfgs, "running_average")
    assert len(dets) == len(reps["FJPDA"]) == 80
    with pytest.raises(ValueError, match="variants_by_method"):
        scene_trials(np.random.default_rng(7), "S1", {})
    with pytest.raises(TypeError, match="variants"):
        scene_trial(np.random.default_rng(7), "S1", {"JPDA": "JPDA"})


def test_s2a_tracked_through_the_crossing():
    cfgs = {"FJPDA": JPDATrackerConfig(variant="FJPDA")}
    t = scene_trial(np.random.default_rng(0), "S2a", cfgs, method="running_average")
    m = t.metrics["FJPDA"]
    assert m.tmr > 0.9 and m.crossing == "kept" and m.false_tracks == 0


def test_crossing_detections_geometry_and_merge_distance():
    dets_, sc = crossing_detections(np.random.default_rng(4), heading_b=math.radians(20),
                                    min_sep=3.0, pd=1.0, clutter_rate=0.0)
    d = np.hypot(*(sc.xy[:, 0] - sc.xy[:, 1]).T)
    assert np.argmin(d) == sc.conflict_frame and d.min() == pytest.approx(3.0)
    assert all(len(x.z) == 2 and len(x.masks) == 2 for x in dets_)
    assert sc.score_window == (sc.conflict_frame - 10, sc.conflict_frame + 10)
    cfg = JPDATrackerConfig(variant="FJPDA", feature_lr=(20.0, 1.5, 5.0, 4.0))
    from trackcore.trackers.jpda_tracker import run_jpda_tracker
    reps = run_jpda_tracker(dets_[:12], cfg)
    assert sum(s.status == "confirmed" for s in reps[-1].tracks) >= 1
    # below this distance a renderer draws one merged blob; above it two blobs
    sep = separate_blob_distance(math.radians(20))
    assert 16.0 < sep < 40.0
    assert separate_blob_distance(math.radians(90)) > 16.0
    with pytest.raises(ValueError, match="conflict"):
        crossing_detections(np.random.default_rng(0), n_frames=10, conflict=20)
    with pytest.raises(ValueError, match="pd"):
        crossing_detections(np.random.default_rng(0), pd=1.5)


def test_extreme_arguments_are_refused_quickly():
    """Sizes and rates that would hang or exhaust memory are refused up front."""
    g = np.random.default_rng(0)
    with pytest.raises(ValueError, match="n_frames"):
        crossing_detections(g, n_frames=1e9, conflict=2)
    with pytest.raises(ValueError, match="clutter_rate"):
        crossing_detections(g, clutter_rate=1e300, n_frames=5, conflict=2)
    with pytest.raises(ValueError, match="max_sep"):
        separate_blob_distance(max_sep=1e300)
    with pytest.raises(ValueError, match="heading_b"):
        separate_blob_distance(heading_b=np.nan)
    with pytest.raises(ValueError, match="jitter"):
        render_scene("glare", g, jitter=1e300)
    with pytest.raises(ValueError, match="jitter"):
        matched_config("JPDA", 1e300)
    from trackcore.scenarios.feature_scenes import feature_correlation_samples, fig3_patches
    with pytest.raises(ValueError, match="n_draws"):
        feature_correlation_samples(g, n_draws=1e9)
    with pytest.raises(ValueError, match="shift"):
        fig3_patches(g, shift=(1e300, 0.0))


def test_scene_functions_reject_a_non_scene():
    from trackcore.scenarios.feature_metrics import scene_metrics, vehicle_mask_iou
    from trackcore.scenarios.feature_scenes import closest_approach
    for f, args in ((segment_scene, ("running_average",)), (closest_approach, ()),
                    (scene_metrics, ([],)), (vehicle_mask_iou, (np.zeros((1, 2, 2), bool),))):
        with pytest.raises(TypeError, match="scene must be a FeatureScene"):
            f(None, *args)


def test_pair_gaps_checks_its_arguments():
    from trackcore.scenarios.feature_scenes import pair_gaps
    lab = np.zeros((20, 20), np.int8)
    lab[2:5, 2:5], lab[2:5, 9:12] = 1, 2
    assert pair_gaps(lab, 1, 2) == 4.0 and pair_gaps(lab, 1, 3) == math.inf
    with pytest.raises(ValueError, match="labels"):
        pair_gaps(lab.astype(float), 1, 2)
    with pytest.raises(ValueError, match="labels"):
        pair_gaps(lab[0], 1, 2)
    with pytest.raises(TypeError, match="b must be an integer"):
        pair_gaps(lab, 1, 2.5)


def test_crossing_trial_window_past_the_scene_is_a_clear_error():
    from trackcore.scenarios.feature_metrics import crossing_trial
    with pytest.raises(ValueError, match="score window"):
        crossing_trial(np.random.default_rng(1), {"JPDA": JPDATrackerConfig(variant="JPDA")},
                       n_frames=20, conflict=10)
