"""Tests for the feature-JPDA tracker, its track management, the synthetic
scenes and the scene metrics."""
import numpy as np
import pytest

from trackcore.detection.image import ImageDetections, vehicle_sprite
from trackcore.scenarios.feature_metrics import (SceneMetrics, match_tracks, paired_comparison,
                                                 scene_metrics)
from trackcore.scenarios.feature_scenes import N_WARMUP, render_scene, scene_layout, segment_scene
from trackcore.trackers.jpda_tracker import (FrameReport, JPDATracker, JPDATrackerConfig,
                                             TrackSnapshot, matched_config, run_jpda_tracker,
                                             steady_state_gate, initial_gate)

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
    """tsi_feature=True (an ablation): a TSI pair needs
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


@pytest.mark.parametrize("memory", [1, 2, 4])
def test_confirmed_memory_cycle_and_memory_deletion(memory):
    """A confirmed track coasts ``memory_frames`` missed frames in memory and is
    deleted at the next consecutive miss (default 2; 1 = the second miss)."""
    trk = JPDATracker(JPDATrackerConfig(variant="JPDA", memory_frames=memory))
    for k in range(5):
        trk.step(dets([line(k)]))
    assert statuses(trk.step(dets([]))) == {1: "memory"}
    assert statuses(trk.step(dets([line(6)]))) == {1: "confirmed"}
    for _ in range(memory):
        assert statuses(trk.step(dets([]))) == {1: "memory"}
    rep = trk.step(dets([]))
    assert rep.deleted == ((1, "miss"),) and rep.tracks == ()
    assert JPDATrackerConfig().memory_frames == 2


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
    assert out["JPDA"].n_valid == 2 and out["JPDA"].n_events == out["JPDA"].n_events_kin == 3
    for v in ("FJPDA-gate", "FJPDA"):
        assert out[v].n_valid_kin == 2 and out[v].n_valid == 1 and out[v].n_events == 2
        assert out[v].n_events_kin == 3         # the same tracks without the feature gate


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
                                    dict(lam=0.0), dict(q_rw=np.nan), dict(pair_margin=-1.0),
                                    dict(dup_frames=np.nan), dict(dup_frames=2.5),
                                    dict(memory_frames=0), dict(sigma_a=np.inf),
                                    dict(pd=np.nan), dict(c_I=np.nan), dict(tsi_from="all"),
                                    dict(rho_weight="softmax"),
                                    dict(feature_lr=(1.0, np.nan, 1.0, 1.0))])
def test_bad_config(kwargs):
    with pytest.raises(ValueError, match=list(kwargs)[0]):
        JPDATrackerConfig(**kwargs)


@pytest.mark.parametrize("kwargs", [dict(r_std="1"), dict(duplicate_deletion=1),
                                    dict(template_guard=None), dict(memory_frames=True)])
def test_bad_config_types(kwargs):
    with pytest.raises(TypeError, match=list(kwargs)[0]):
        JPDATrackerConfig(**kwargs)


def test_q_rw_and_pair_margin_reproducers():
    with pytest.raises(ValueError, match="q_rw"):
        JPDATrackerConfig(q_rw=np.nan, pair_margin=-1)
    with pytest.raises(ValueError, match="dup_frames"):
        JPDATrackerConfig(dup_frames=np.nan)


def test_nan_detection_is_rejected_not_dropped():
    frames = [dets([line(k)]) for k in range(4)]
    frames[2] = dets([line(2), [np.nan, 5.0]])
    with pytest.raises(ValueError, match=r"detections\[2\]\.z"):
        run_jpda_tracker(frames, JPDATrackerConfig(variant="JPDA"))
    bad_mask = dets([line(0)], [np.full((3, 3), 2)])
    with pytest.raises(ValueError, match="masks"):
        run_jpda_tracker([bad_mask])
    with pytest.raises(TypeError, match="config"):
        run_jpda_tracker(frames[:1], config={"variant": "JPDA"})
    with pytest.raises(TypeError, match="detections"):
        run_jpda_tracker([np.zeros((1, 2))])


def test_matched_config_and_steady_state_gate():
    c0 = matched_config("JPDA", 0.0)
    assert c0 == JPDATrackerConfig(variant="JPDA")
    c5 = matched_config("FJPDA", 5.0, memory_frames=1)
    s = np.sqrt(26.0)
    assert c5.r_std == pytest.approx(s) and c5.pair_margin == pytest.approx(3 * s)
    assert c5.gate_max == pytest.approx(20 * s) and c5.memory_frames == 1
    # the steady-state gate against the closed form of the DARE solved by scipy
    from scipy.linalg import solve_discrete_are
    trk = JPDATracker(c5)
    P = solve_discrete_are(trk.F.T, trk.H.T, trk.Q, trk.R)
    S = trk.H @ P @ trk.H.T + trk.R
    assert steady_state_gate(c5) == pytest.approx(np.sqrt(9.21 * np.linalg.eigvalsh(S)[-1]),
                                                  rel=1e-8)
    assert steady_state_gate(c0) < steady_state_gate(matched_config("JPDA", 3.0)) \
        < steady_state_gate(c5)
    with pytest.raises(ValueError, match="jitter"):
        matched_config("JPDA", -1.0)


def test_mismatched_masks_raise():
    with pytest.raises(ValueError, match="masks"):
        JPDATracker().step(ImageDetections(np.zeros((2, 2)), None, None, [VAN], [VAN]))
    with pytest.raises(ValueError, match=r"z must have shape"):
        JPDATracker().step(ImageDetections(np.zeros((2, 3)), None, None, [VAN] * 2, [VAN] * 2))


# ---------------------------------------------------------------- open readings
def _van_track(variant, **cfg):
    trk = JPDATracker(JPDATrackerConfig(variant=variant, **cfg))
    for k in range(5):
        trk.step(dets([line(k, vy=0.0)]))
    return trk


def test_tsi_reading_outside_gates_vs_unvalidated():
    """A bar inside the van's kinematic gate but rejected by the feature gate starts
    no track under the default reading; under tsi_from="unvalidated" it can."""
    for tsi_from, expect_new in (("outside_gates", 0), ("unvalidated", 1)):
        trk = _van_track("FJPDA", tsi_from=tsi_from)
        for k in (5, 6):
            z = line(k, vy=0.0)
            rep = trk.step(dets([z, [z[0] + 1.5, z[1] + 1.5]], [VAN, BAR]))
        new = [s for s in rep.tracks if s.tid != 1]
        assert len(new) == expect_new
    # plain JPDA: both readings are the same (the bar is validated by the van)
    for tsi_from in ("outside_gates", "unvalidated"):
        trk = _van_track("JPDA", tsi_from=tsi_from)
        for k in (5, 6):
            z = line(k, vy=0.0)
            rep = trk.step(dets([z, [z[0] + 1.5, z[1] + 1.5]], [VAN, BAR]))
        assert [s.tid for s in rep.tracks] == [1]


def test_normalised_rho_weighting_matches_enumeration():
    """rho_weight="normalised": eq (6) with rho / sum over the track's validated
    measurements, checked against jpda_marginals on transformed likelihoods."""
    from trackcore.association import jpda_marginals
    trk_raw = _van_track("FJPDA", c_I=0.3)
    trk_nrm = _van_track("FJPDA", c_I=0.3, rho_weight="normalised")
    z = line(5, vy=0.0)
    frame = dets([[z[0], z[1] + 1.2], [z[0], z[1] - 1.2]], [VAN, SEDAN])
    x_raw = (trk_raw.step(frame), trk_raw.tracks[0].x.copy())[1]
    x_nrm = (trk_nrm.step(frame), trk_nrm.tracks[0].x.copy())[1]
    # both pull towards the van-shaped measurement (+1.2 px), by different amounts
    assert x_raw[1] - z[1] > 0.05 and x_nrm[1] - z[1] > 0.05
    assert abs(x_raw[1] - x_nrm[1]) > 1e-6
    rho = np.array([1.0, float(__import__("trackcore.detection.image", fromlist=["ncc"])
                               .ncc(VAN, SEDAN))])
    lik = np.array([[0.02], [0.02]])
    b_n, _ = jpda_marginals(lik * (rho / rho.sum())[:, None], np.ones((2, 1), bool), 0.9, 1e-5)
    b_r, _ = jpda_marginals(lik, np.ones((2, 1), bool), 0.9, 1e-5, rho=rho[:, None], c_I=0.3)
    # the normalisation changes detected-vs-missed odds, not the ratio between measurements
    assert b_n[1, 0] / b_n[2, 0] == pytest.approx(b_r[1, 0] / b_r[2, 0], rel=1e-12)
    assert b_n[0, 0] != pytest.approx(b_r[0, 0])


def test_template_drift_guard():
    """The template follows the measurement it was updated with (beta >= 0.5 and
    rho >= c_I); with the drift guard the new mask must also correlate >= c_I with
    the track's first template.  Van -> sedan -> compact: rho(van, sedan) = 0.72 and
    rho(sedan, compact) = 0.69 pass, rho(van, compact) = 0.52 does not, so the
    unguarded template drifts to the compact and the guarded one stops at the sedan."""
    from trackcore.detection.image import ncc
    compact = vehicle_sprite("compact")[1]
    assert ncc(VAN, SEDAN) >= 0.6 and ncc(SEDAN, compact) >= 0.6 > ncc(VAN, compact)
    out = {}
    for guard in (True, False):
        trk = _van_track("FJPDA", template_guard=guard)
        t0 = trk.tracks[0].template0
        for k, M in zip((5, 6, 7, 8), (SEDAN, SEDAN, compact, compact)):
            trk.step(dets([line(k, vy=0.0)], [M]))
        assert trk.tracks[0].template0 is t0
        out[guard] = trk.tracks[0].template
    assert out[False] is compact
    assert out[True] is SEDAN


def test_template_update_off_keeps_first_template():
    trk = _van_track("FJPDA", template_update=False)
    t0 = trk.tracks[0].template
    trk.step(dets([line(5, vy=0.0)], [SEDAN]))
    assert trk.tracks[0].template is t0


# ---------------------------------------------------------------- metrics
def _fake_reports(tracks_per_frame):
    return [FrameReport(k, tuple(TrackSnapshot(tid, st, x, y, 1.0, 1.0, 0)
                                 for tid, st, x, y in tr), 1, 0, 0, (), 0.0)
            for k, tr in enumerate(tracks_per_frame)]


def _pair_scene(K=60):
    xy = np.zeros((K, 2, 2))
    xy[:, 0, 0] = np.arange(K)
    xy[:, 1, 0] = np.arange(K) + 50.0
    present = np.ones((K, 2), bool)
    sc = render_scene("S2a", np.random.default_rng(2))._replace(
        xy=xy, present=present, visible=present, conflict_frame=30, pair=(0, 1),
        score_window=(20, 40))
    return sc, xy, present


def test_metrics_perfect_swap_and_false_track():
    K = 60
    sc, xy, present = _pair_scene(K)
    perfect = _fake_reports([[(1, "confirmed", xy[k, 0, 0], 0.0), (2, "confirmed", xy[k, 1, 0], 0.0)]
                             for k in range(K)])
    m = scene_metrics(sc, perfect)
    assert m.tmr == 1.0 and m.crossing == "kept" and m.id_switches == 0 and m.false_tracks == 0
    assert m.kept and not m.swapped and m.events_per_frame == m.mean_events == 1.0
    assert m.mota == pytest.approx(1.0)
    swapped = _fake_reports([[(1 if k < 30 else 2, "confirmed", xy[k, 0, 0], 0.0),
                              (2 if k < 30 else 1, "confirmed", xy[k, 1, 0], 0.0),
                              (7, "confirmed", 200.0, 200.0)] for k in range(K)])
    m = scene_metrics(sc, swapped)
    assert m.crossing == "swap" and m.swapped and m.id_switches == 2 and m.false_tracks == 1
    assert m.false_sources == (("other", 1),)
    assert m.tmr == pytest.approx((27 * 2) / (57 * 2))
    ids, _ = match_tracks(xy, present, swapped)
    assert ids[0, 0] == 1 and ids[40, 0] == 2
    # the score window decides: a swap after it is not scored
    late = _fake_reports([[(1 if k < 45 else 2, "confirmed", xy[k, 0, 0], 0.0),
                           (2 if k < 45 else 1, "confirmed", xy[k, 1, 0], 0.0)] for k in range(K)])
    assert scene_metrics(sc, late).crossing == "kept"


def test_match_tracks_bad_shapes_raise_value_error():
    sc, xy, present = _pair_scene(10)
    reps = _fake_reports([[(1, "confirmed", 0.0, 0.0)]] * 10)
    with pytest.raises(ValueError, match="truth_xy"):
        match_tracks(xy[:, :, :1], present, reps)
    with pytest.raises(ValueError, match="truth_present"):
        match_tracks(xy, present.astype(float), reps)
    with pytest.raises(ValueError, match="reports"):
        match_tracks(xy, present, reps[:5])
    with pytest.raises(ValueError, match="match_gate"):
        match_tracks(xy, present, reps, match_gate=-1.0)


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


def test_vehicle_mask_iou_perfect_empty_and_bad_shapes():
    from trackcore.scenarios.feature_metrics import vehicle_mask_iou
    sc = render_scene("S2a", np.random.default_rng(3))
    truth = sc.labels[N_WARMUP:] > 0
    v = vehicle_mask_iou(sc, truth)
    assert len(v) == sc.visible.sum() and np.allclose(v, 1.0)
    assert np.all(vehicle_mask_iou(sc, np.zeros_like(truth)) == 0.0)
    with pytest.raises(ValueError, match="masks"):
        vehicle_mask_iou(sc, truth[:5])
    with pytest.raises(ValueError, match="masks"):
        vehicle_mask_iou(sc, truth[:, :10])
    with pytest.raises(ValueError, match="masks"):
        vehicle_mask_iou(sc, truth.astype(float))


def test_paired_comparison():
    x = np.array([0, 0, 1, 0, 0, 0, 0, 0, 0, 0] * 5, float)      # A: fewer events
    y = np.array([1, 1, 1, 0, 1, 1, 0, 1, 1, 0] * 5, float)
    c = paired_comparison(x, y, ("FJPDA", "JPDA"))
    assert c.verdict == "FJPDA better" and c.a_better == 30 and c.b_better == 0
    assert c.diff.hi < 0 and c.p_sign < 1e-8 and c.mean_a == pytest.approx(0.1)
    c = paired_comparison(x, y, ("FJPDA", "JPDA"), lower_is_better=False)
    assert c.verdict == "JPDA better"
    c = paired_comparison(x, x, ("A", "B"))
    assert c.verdict == "tie" and c.p_sign == 1.0
    with pytest.raises(ValueError, match="paired"):
        paired_comparison(x, y[:-1])
    with pytest.raises(ValueError, match="x"):
        paired_comparison(np.full(5, np.nan), np.zeros(5))


@pytest.mark.parametrize("jitter, model", [(0.0, "cv"), (3.0, "cv"), (5.0, "rw"), (5.0, "pv")])
def test_initial_gate_is_the_gate_a_new_track_reports(jitter, model):
    # two frames start a track by the two-step initialisation; on the third the tracker
    # reports the gate of that first prediction (R and Q isotropic: the half-width along
    # x is the semi-major axis)
    cfg = matched_config("JPDA", jitter, model=model, gate_max=1e4)
    trk = JPDATracker(cfg)
    trk.step(dets([[100.0, 100.0]]))
    trk.step(dets([[102.0, 101.0]]))
    rep = trk.step(dets([[104.0, 102.0]]))  # where it predicts: validated, a hit
    (t,) = rep.tracks
    assert t.gate_x == pytest.approx(initial_gate(cfg), rel=1e-9)
    # at 3 px of jitter or more the CV track's first gate exceeds an unscaled 20 px
    assert (initial_gate(matched_config("JPDA", jitter, model=model)) > 20.0) == \
        (jitter >= 3.0 and model != "rw" or jitter >= 5.0)
