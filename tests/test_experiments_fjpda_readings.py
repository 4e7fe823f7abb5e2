"""The feature-JPDA readings runs (issue 29): the sliding correlation, the first fully
visible template, the false-track attribution, the py-motmetrics measures against our
ID-switch counter, the registered experiments and their stores."""

import numpy as np
import pytest
from _stores import corrupted_store
from test_ncc_sliding import _sliding_reference  # the direct loop, shared

from trackcore.core.rng import generator_for_run
from trackcore.detection import ncc, ncc_sliding, vehicle_sprite
from trackcore.experiments import VerificationError, get, load, status, verify_sample
from trackcore.experiments.fjpda_readings import (
    FALSE_SOURCES,
    FJPDA_READINGS_SEED,
    MOT_VARIANTS,
    READINGS_SCENES,
    FjpdaReadingsConfig,
    readings_trial,
)
from trackcore.scenarios.feature_metrics import clear_mot_metrics, scene_metrics
from trackcore.scenarios.feature_scenes import render_scene
from trackcore.trackers.jpda_tracker import (
    FrameReport,
    JPDATracker,
    TrackSnapshot,
    _touches_edge,
    matched_config,
)

NAME = "fjpda-readings-glare"
RUN = 3


def test_ncc_sliding_equals_a_direct_loop():
    rng = np.random.default_rng(0)
    for _ in range(5):
        A = rng.random((rng.integers(3, 9), rng.integers(3, 9))) < 0.5
        B = rng.random((rng.integers(3, 12), rng.integers(3, 12))) < 0.5
        ref = _sliding_reference(A, B, 2, "mask")
        assert ncc_sliding(A, B, 2) == pytest.approx(ref, abs=1e-12)
    van = vehicle_sprite("van")[1]
    assert ncc_sliding(van, van) == pytest.approx(1.0), "a template matches itself"


def test_sliding_finds_a_template_inside_a_merged_blob():
    van, sedan = vehicle_sprite("van")[1], vehicle_sprite("sedan")[1]
    merged = np.zeros((van.shape[0] + sedan.shape[0], van.shape[1] + 6), bool)
    merged[:van.shape[0], :van.shape[1]] = van
    merged[van.shape[0]:, 6:6 + sedan.shape[1]] = sedan
    slid, canvas = ncc_sliding(van, merged), ncc(van, merged)
    assert slid == pytest.approx(1.0), f"the van lies whole inside the blob: {slid}"
    assert canvas < 0.65, f"the canvas NCC is lowered by the partner's pixels: {canvas}"
    pv, pm = np.pad(van, 4), np.pad(merged, 4)  # patches with the detector's margin
    assert ncc_sliding(pv, pm) > ncc(pv, pm) + 0.1, "the margin lowers both, less so"


def test_touches_edge_detects_a_patch_cut_at_the_border():
    m = np.zeros((12, 16), bool)
    m[4:8, 4:12] = True  # 4 px margin on every side
    assert not _touches_edge(m), "equal margins: not at the border"
    assert _touches_edge(m[:, 2:]), "left margin 2 of 4: cut at the border"
    assert _touches_edge(np.zeros((3, 3), bool)), "an empty patch is not a template"


class _Dets:
    def __init__(self, z, masks):
        self.z, self.masks = np.array(z, float).reshape(-1, 2), masks


def test_first_fully_visible_template_replaces_a_truncated_one():
    full = np.zeros((12, 20), bool)
    full[4:8, 4:16] = True
    cut = full[:, 8:]  # the front of the vehicle, cut at the left border
    cfg = matched_config("FJPDA", 0.0, template_update=False, template_from="fully_visible")
    trk = JPDATracker(cfg)
    frames = [_Dets([[2.0 + 3 * k, 50.0]], [cut if k < 3 else full]) for k in range(6)]
    for d in frames:
        trk.step(d)
    (tr,) = trk.tracks
    assert tr.whole and tr.template is frames[3].masks[0], "the first whole silhouette"
    assert tr.template0 is tr.template, "the drift guard anchors to it"
    fixed = JPDATracker(matched_config("FJPDA", 0.0, template_update=False))
    for d in frames:
        fixed.step(d)
    assert fixed.tracks[0].template is frames[0].masks[0] or \
        fixed.tracks[0].template is frames[1].masks[0], "fixed first keeps the cut one"


def _fake(tracks_per_frame):
    return [FrameReport(k, tuple(TrackSnapshot(t, st, x, y, 1.0, 1.0, 0)
                                 for t, st, x, y in tr), 1, 0, 0, (), 0.0)
            for k, tr in enumerate(tracks_per_frame)]


def _two_cars(K=40):
    xy = np.zeros((K, 2, 2))
    xy[:, 0, 0], xy[:, 1, 0] = np.arange(K), np.arange(K) + 50.0
    present = np.ones((K, 2), bool)
    sc = render_scene("S2a", np.random.default_rng(2))._replace(
        xy=xy, present=present, visible=present, conflict_frame=-1, pair=())
    return sc, xy


def test_our_counter_against_clear_mot():
    """A duplicate track that is momentarily closer to a vehicle: our per-frame
    re-matching counts two switches, CLEAR-MOT (py-motmetrics) none; a real swap of
    two tracks is two switches for both."""
    sc, xy = _two_cars()
    K = xy.shape[0]
    dup = _fake([[(1, "confirmed", xy[k, 0, 0], 2.0), (2, "confirmed", xy[k, 1, 0], 0.0)]
                 + ([(3, "confirmed", xy[k, 0, 0], 0.5)] if k == 20 else [])
                 for k in range(K)])
    ours, mot = scene_metrics(sc, dup), clear_mot_metrics(sc, dup)
    assert ours.id_switches == 2, f"our counter follows the closer track: {ours}"
    assert mot["num_switches"] == 0, f"CLEAR-MOT keeps the still-valid match: {mot}"
    swap = _fake([[(1 if k < 20 else 2, "confirmed", xy[k, 0, 0], 0.0),
                   (2 if k < 20 else 1, "confirmed", xy[k, 1, 0], 0.0)] for k in range(K)])
    ours, mot = scene_metrics(sc, swap), clear_mot_metrics(sc, swap)
    assert ours.id_switches == 2 and mot["num_switches"] == 2, (ours, mot)
    assert mot["mostly_tracked"] == 2 and mot["idf1"] == pytest.approx(0.5), mot


def test_a_false_track_beside_a_vehicle_is_attributed_to_it():
    sc, xy = _two_cars()
    reps = _fake([[(1, "confirmed", xy[k, 0, 0], 0.0), (2, "confirmed", xy[k, 1, 0], 0.0),
                   (3, "confirmed", xy[k, 0, 0], 6.0)] for k in range(xy.shape[0])])
    m = scene_metrics(sc, reps)
    assert m.false_sources == (("vehicle", 1),), m.false_sources


#: the scenes whose 200-run stores are committed (the others are registered, not run)
STORED = tuple(READINGS_SCENES)  # all six scenes are stored


def test_registry_holds_the_six_scenes():
    for i, (key, (scene, jitter, extras)) in enumerate(READINGS_SCENES.items()):
        e = get(f"fjpda-readings-{key}")
        assert (e.seed, e.runs, e.version) == (FJPDA_READINGS_SEED + i, 200, "1"), key
        assert e.config == FjpdaReadingsConfig(scene, jitter, extras), key
        want = "current" if key in STORED else "missing"
        assert status(e.name) == want, f"{e.name}: {status(e.name)}"
    assert len(get("fjpda-readings-s3-jitter5").config.variants()) == 10, "S3 ablations"


@pytest.mark.parametrize("kwargs, match", [
    ({"scene": "S9", "jitter": 0.0}, "scene must be one of"),
    ({"scene": "glare", "jitter": -1.0}, "jitter must be a finite number >= 0"),
    ({"scene": "glare", "jitter": 5.0, "extras": ("s4",)}, "unknown extra"),
])
def test_bad_config_raises_a_clear_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FjpdaReadingsConfig(**kwargs)


@pytest.fixture(scope="module")
def direct():
    e = get(NAME)
    rng = generator_for_run(e.seed, RUN, e.runs)
    return readings_trial(rng, "glare", e.config.variants(), 5.0)


def test_stored_row_equals_the_direct_run(direct):
    res = load(NAME)
    assert res.runs == 200 and res.is_book, res
    row = get(NAME).extract(direct, res.config)
    assert row.keys() == res.row(RUN).keys(), sorted(row)
    for k, v in row.items():
        got = res.row(RUN)[k]
        assert got == v or (np.isnan(got) and np.isnan(v)), (k, got, v)
    for label, (m, mot) in direct.items():
        assert sum(row[f"{label}.false_{s}"] for s in FALSE_SOURCES) == m.false_tracks, label
        assert (mot is not None) == (label in MOT_VARIANTS), label


def test_verification_catches_a_corrupted_stored_row(direct, tmp_path):
    column = "FJPDA.false_tracks"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])


def test_compare_reports_no_interval_below_the_minimum():
    from trackcore.experiments.fjpda_readings import NoInterval, compare

    few = compare(np.arange(10.0), np.zeros(10), ("F", "J"))
    assert few.verdict == "no interval" and isinstance(few.diff, NoInterval), few
    assert format(few.diff, ".2g") == "4.5 (no interval)", format(few.diff, ".2g")
    rng = np.random.default_rng(1)
    x = rng.normal(1.0, 1.0, 60)
    ok = compare(x, x - 1.0 + rng.normal(0, 0.1, 60), ("F", "J"))
    assert ok.verdict in ("F better", "J better", "tie") and ok.diff.n == 60, ok


def test_per_run_measures():
    from trackcore.experiments.fjpda_readings import per_run

    res = {"F.tmr_num": [3, 4], "F.tmr_den": [4, 4], "F.coverage_num": [4, 4],
           "F.mean_events": [2.0, 3.0], "F.mean_events_kin": [3.0, 3.0],
           "F.false_glare": [1, 0]}
    assert per_run(res, "F", "tmr").tolist() == [0.75, 1.0]
    assert per_run(res, "F", "events_same").tolist() == [-1.0, 0.0]
    assert per_run(res, "F", "false_glare").tolist() == [1.0, 0.0]
    with pytest.raises(ValueError, match="eligible"):
        per_run({**res, "F.tmr_den": [0, 4]}, "F", "tmr")


def test_estimate_falls_back_to_a_point_value():
    from trackcore.experiments.fjpda_readings import NoInterval, estimate
    from trackcore.stats import mean_ci, paired_diff_ci

    e = estimate(mean_ci, np.arange(10.0))
    assert isinstance(e, NoInterval) and e.value == 4.5 and not e.lo >= 0.1, e
    d = estimate(paired_diff_ci, np.arange(5.0), np.zeros(5))
    assert isinstance(d, NoInterval) and float(d) == 2.0, d
    ok = estimate(mean_ci, np.random.default_rng(0).normal(size=60))
    assert not isinstance(ok, NoInterval) and ok.lo < ok.hi, ok


def test_confirms_nothing_reads_the_unscaled_gate_cell_of_the_stored_runs():
    # the premise of the chapter's tracker comparisons, on the stored one-at-a-time runs:
    # with G_th = 20 px neither tracker confirms a track in any run of any scene; at the
    # default readings both do in every scene
    from trackcore.experiments.fjpda_readings import NO_TRACK, confirms_nothing

    oat = load("fjpda-oat").columns
    scene = np.asarray(oat["scene"])
    for i in range(len(get("fjpda-oat").config.scenes)):
        sel = scene == i
        assert confirms_nothing(oat, ["JPDA gate20", "FJPDA gate20"], select=sel)
        assert not confirms_nothing(oat, ["JPDA default", "FJPDA default"], select=sel)
    assert NO_TRACK.startswith("not applicable")


@pytest.mark.parametrize("trackers, select, match", [
    ("JPDA", None, "non-empty list"),
    ([], None, "non-empty list"),
    (["JPDA"], np.array([1, 0]), "boolean mask"),
    (["JPDA"], np.array([True]), "boolean mask"),
])
def test_confirms_nothing_refuses_bad_input(trackers, select, match):
    from trackcore.experiments.fjpda_readings import confirms_nothing

    res = {"JPDA.coverage_num": np.zeros(2), "JPDA.false_tracks": np.zeros(2)}
    with pytest.raises(ValueError, match=match):
        confirms_nothing(res, trackers, select=select)
