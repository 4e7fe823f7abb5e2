"""The feature-JPDA position error on the same frames (issue 29, session 14): the measure on
hand-made tracks, the config, the registered experiment, its store and its agreement with
fjpda-oat's stored own-frames MOTP."""
import numpy as np
import pytest
from _stores import corrupted_store

from trackcore.core.rng import generator_for_run
from trackcore.experiments import VerificationError, get, load, status, verify_sample
from trackcore.experiments.fjpda_accuracy import (
    ACCURACY_RUNS,
    GRID_CELLS,
    VARIED_ACC,
    FjpdaAccuracyConfig,
    cell_pair,
)
from trackcore.experiments.fjpda_oat import FJPDA_OAT_SEED, OAT_SCENES, FjpdaOatConfig
from trackcore.experiments.fjpda_oat_vel import FjpdaOatDupConfig, FjpdaOatVelConfig
from trackcore.experiments.fjpda_readings import READING_VARIANTS, READINGS_SCENES
from trackcore.experiments.fjpda_templates import TEMPLATE_VARIANTS
from trackcore.scenarios.feature_metrics import match_tracks, same_frames_error
from trackcore.trackers.jpda_tracker import FrameReport, TrackSnapshot, matched_config

NAME = "fjpda-accuracy"
RUN = 8  # scene 2: occlusion


def _reports(positions, status="confirmed"):
    """One FrameReport per frame holding a track (tid 1) at each (x, y), none at None."""
    return [FrameReport(k, () if p is None else (TrackSnapshot(1, status, *p, 1.0, 1.0, 5),),
                        0, 0, 0, (), 0.0) for k, p in enumerate(positions)]


def test_same_frames_error_on_hand_made_tracks_differs_in_sign_from_own_frames():
    # one vehicle at (50, 50) over 10 frames; A matched in all (0.5 px off, then 3 px),
    # B only in frames 5-9 (2.5 px off): A is better over its own frames, worse over
    # the frames both keep
    truth = np.full((10, 1, 2), 50.0)
    present = np.ones((10, 1), bool)
    a = _reports([(50.5, 50.0)] * 5 + [(53.0, 50.0)] * 5)
    b = _reports([None] * 5 + [(50.0, 52.5)] * 5)
    da, db = (match_tracks(truth, present, r)[1] for r in (a, b))
    r = same_frames_error(da, db)
    assert (r.pairs, r.matched_a, r.matched_b) == (5, 10, 5), r
    assert r.diff == pytest.approx(0.5) and r.diff_sum == pytest.approx(2.5), r
    assert r.own_a - r.own_b == pytest.approx(-0.75), "own frames: A better"
    assert np.sign(r.diff) != np.sign(r.own_a - r.own_b), "the two measures differ in sign"


def test_same_frames_error_uses_the_motp_match_and_counts_no_common_pair():
    truth = np.full((4, 1, 2), 50.0)
    present = np.array([[True], [True], [True], [False]])
    # A: a tentative track (not reported), one beyond the 10 px gate, two matched (one
    # in a frame where the vehicle is absent: not matched); B matched in the first two
    a = [*_reports([(51.0, 50.0)], "tentative"), *_reports([(61.0, 50.0), (52.0, 50.0),
                                                          (50.0, 50.0)])]
    b = _reports([(50.0, 51.0), (50.0, 51.0), None, None])
    da, db = (match_tracks(truth, present, r)[1] for r in (a, b))
    r = same_frames_error(da, db)
    assert (r.pairs, r.matched_a, r.matched_b) == (0, 1, 2), r
    assert np.isnan(r.diff) and r.diff_sum == 0.0, "no common pair: contributes nothing"
    assert r.own_a == 2.0 and r.own_b == 1.0, r
    none = same_frames_error(np.full((3, 2), np.nan), np.full((3, 2), np.nan))
    assert none.pairs == 0 and np.isnan(none.own_a) and np.isnan(none.own_b), none
    with pytest.raises(ValueError, match="of one shape"):
        same_frames_error(np.zeros((3, 2)), np.zeros((3, 1)))
    with pytest.raises(ValueError, match=">= 0 or NaN"):
        same_frames_error(np.full((3, 1), -1.0), np.zeros((3, 1)))


def test_config_validation_and_cells():
    c = FjpdaAccuracyConfig()
    assert c.values == tuple(VARIED_ACC) and c.values[0] == "default", c.values
    assert len(c.values) == 10 and len(c.cells) == 7 and c.scenes == OAT_SCENES, c
    assert len(c.compared()) == 17, "8 grid cells and 9 changed readings"
    for i, key in enumerate(OAT_SCENES):
        v, oat = c.variants(i), FjpdaOatConfig().variants(i)
        assert all(v[k] == oat[k] for k in oat), "the values of fjpda-oat, built by it"
        assert v["pv"] == FjpdaOatVelConfig().variants(i)["pv"], key
        assert v["dd2"] == FjpdaOatDupConfig().variants(i)["dd2"], key
        jitter = READINGS_SCENES[key][1]
        labels = {"cf": "FJPDA, canvas, fixed", "su": "FJPDA, sliding, updated",
                  "sf": "FJPDA, sliding, fixed", "cn": "FJPDA, canvas, no guard",
                  "cv": "FJPDA, canvas, first fully visible",
                  "sn": "FJPDA, sliding, no guard",
                  "sv": "FJPDA, sliding, first fully visible"}
        table = {**READING_VARIANTS, **TEMPLATE_VARIANTS}
        for cell, cfg in c.grid(i).items():
            variant, kw = table[labels[cell]]
            assert cfg == matched_config(variant, jitter, **kw), (key, cell)
    assert set(GRID_CELLS) == set(c.cells)
    assert cell_pair("cv") == ("FJPDA cv", "JPDA default"), "the grid's one JPDA"
    assert cell_pair("lam") == ("FJPDA lam", "JPDA lam"), "both trackers changed"
    with pytest.raises(ValueError, match="unknown cell"):
        cell_pair("xx")
    with pytest.raises(ValueError, match="unknown cell 'cu'"):
        FjpdaAccuracyConfig(cells=("cu",))
    with pytest.raises(ValueError, match="must start with 'default'"):
        FjpdaAccuracyConfig(values=("pv", "default"))
    assert FjpdaAccuracyConfig().with_overrides({"cells": "sf,sv"}).cells == ("sf", "sv")


def test_registry_takes_the_runs_of_fjpda_oat():
    e, oat = get(NAME), get("fjpda-oat")
    assert (e.seed, e.runs) == (oat.seed, oat.runs) == (FJPDA_OAT_SEED, ACCURACY_RUNS)
    assert e.runs == 200 * len(OAT_SCENES) and e.config.scenes == oat.config.scenes


@pytest.fixture(scope="module")
def stored():
    if status(NAME) != "current":
        pytest.skip("store not current")
    return load(NAME)


def test_stored_row_equals_the_direct_run(stored):
    e = get(NAME)
    row = e.row(generator_for_run(e.seed, RUN, e.runs), e.config)
    ref = stored.row(RUN)
    assert row.keys() == ref.keys(), sorted(row)[:5]
    for k, v in row.items():
        assert ref[k] == v or (np.isnan(ref[k]) and np.isnan(v)), (k, ref[k], v)
    assert np.array_equal(stored["scene"], np.arange(stored.runs) % 6), "scene cycle"


def test_verification_catches_a_corrupted_stored_row(stored, tmp_path):
    column = "sf sv.pairs"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])


def test_stored_own_frames_motp_equals_fjpda_oat(stored):
    # the same renders and detections: every tracker both stores hold has the same
    # own-frames MOTP in every run (exactly; NaN where it matched nothing)
    if status("fjpda-oat") != "current":
        pytest.skip("fjpda-oat's store not current")
    oat = load("fjpda-oat")
    shared = [k for k in oat.columns if k.endswith(".motp")]
    assert len(shared) == 16 and all(k in stored.columns for k in shared), shared
    for k in shared:
        x, y = np.asarray(stored[k]), np.asarray(oat[k])
        assert np.array_equal(x, y, equal_nan=True), k
    assert np.array_equal(stored["scene"], oat["scene"]), "the same scenes"
    for c in FjpdaAccuracyConfig().values + tuple(GRID_CELLS):
        a, b = cell_pair(c)
        n = np.asarray(stored[f"sf {c}.pairs"])
        bound = np.minimum(stored[f"{a}.matched"], stored[f"{b}.matched"])
        assert np.all(n <= bound), c
        assert np.all(np.asarray(stored[f"sf {c}.diff_sum"])[n == 0] == 0.0), c
