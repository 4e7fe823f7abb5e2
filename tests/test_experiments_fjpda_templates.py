"""Tests of the 004 template cells, HOTA and occlusion-map experiments (issue 29)."""
from __future__ import annotations

import numpy as np
import pytest

from trackcore.core.rng import generator_for_run
from trackcore.experiments import get, load, status
from trackcore.experiments.fjpda_readings import FJPDA_READINGS_SEED, READINGS_SCENES
from trackcore.experiments.fjpda_templates import (
    MAP_OFFSETS,
    NEW_CELLS,
    FjpdaOcclusionMapConfig,
    FjpdaTemplatesConfig,
)
from trackcore.scenarios.feature_metrics import _trackeval_hota, hota_metrics
from trackcore.scenarios.feature_scenes import render_scene, scene_layout
from trackcore.trackers.jpda_tracker import FrameReport, TrackSnapshot


def _fake(tracks_per_frame):
    return [FrameReport(k, tuple(TrackSnapshot(t, st, x, y, 1.0, 1.0, 0)
                                 for t, st, x, y in tr), 1, 0, 0, (), 0.0)
            for k, tr in enumerate(tracks_per_frame)]


def _one_car(K=20):
    xy = np.zeros((K, 1, 2))
    xy[:, 0, 0] = np.arange(K)
    present = np.ones((K, 1), bool)
    sc = render_scene("S2a", np.random.default_rng(2))
    sc = sc._replace(xy=xy, present=present, visible=present, conflict_frame=-1, pair=(),
                     is_vehicle=np.array([True]), names=("car",))
    return sc, xy


def test_trackeval_hota_on_hand_cases():
    """HOTA = sqrt(DetA AssA), each the mean over 19 thresholds: worked by hand."""
    on = ([0], [1], [[1.0]])
    switch = [on, on, ([0], [2], [[1.0]]), ([0], [2], [[1.0]])]
    # every frame detected (DetA 1); each match's track covers half the vehicle (AssA 1/2)
    assert _trackeval_hota(switch) == pytest.approx(
        {"HOTA": 0.5 ** 0.5, "DetA": 1.0, "AssA": 0.5}), "an ID switch halves AssA"
    # similarity 0.5: matched at the 10 thresholds alpha <= 0.5, missed at the other 9
    half = _trackeval_hota([([0], [1], [[0.5]])] * 4)
    assert half == pytest.approx({"HOTA": 10 / 19, "DetA": 10 / 19, "AssA": 10 / 19}), half
    # a missed frame, then a match: TP 1, FN 1 (DetA 1/2); A = 1 / (2 + 1 - 1) = 1/2
    miss = _trackeval_hota([([0], [], np.zeros((1, 0))), on])
    assert miss == pytest.approx({"HOTA": 0.5, "DetA": 0.5, "AssA": 0.5}), miss


def test_hota_metrics_reads_the_scene_and_the_tracks():
    sc, xy = _one_car()
    K = xy.shape[0]
    exact = _fake([[(1, "confirmed", xy[k, 0, 0], 0.0)] for k in range(K)])
    assert hota_metrics(sc, exact) == pytest.approx(
        {"HOTA": 1.0, "DetA": 1.0, "AssA": 1.0}), "a perfect track"
    off5 = _fake([[(1, "memory", xy[k, 0, 0], 5.0)] for k in range(K)])
    assert hota_metrics(sc, off5)["DetA"] == pytest.approx(10 / 19), "5 px of 10 px"
    tentative = _fake([[(1, "tentative", xy[k, 0, 0], 0.0)] for k in range(K)])
    assert hota_metrics(sc, tentative)["HOTA"] == 0.0, "tentative tracks are not reported"
    swap = _fake([[(1 if k < K // 2 else 2, "confirmed", xy[k, 0, 0], 0.0)]
                  for k in range(K)])
    assert hota_metrics(sc, swap)["AssA"] == pytest.approx(0.5), "a switch halfway"
    with pytest.raises(ValueError, match="match_gate"):
        hota_metrics(sc, exact, match_gate=0.0)


def test_crossing_offset_sets_the_occlusion_crossing():
    same = scene_layout("occlusion")[0], scene_layout("occlusion", 6.0)[0]
    assert [o["pos"](30) for o in same[0]] == [o["pos"](30) for o in same[1]], \
        "the default offset is the scene's 6 px"
    near = scene_layout("occlusion", 2.0)[0]
    assert near[0]["pos"](35) != same[0][0]["pos"](35), "another offset moves the pair"
    with pytest.raises(ValueError, match="occlusion scene only"):
        scene_layout("glare", 4.0)
    with pytest.raises(ValueError, match="crossing_offset"):
        scene_layout("occlusion", 31.0)
    with pytest.raises(ValueError, match="crossing_offset"):
        render_scene("occlusion", np.random.default_rng(0), crossing_offset=-1.0)


def test_registry_and_configs():
    for i, (key, (scene, jitter, _)) in enumerate(READINGS_SCENES.items()):
        e, r = get(f"fjpda-templates-{key}"), get(f"fjpda-readings-{key}")
        assert (e.seed, r.seed, e.runs) == (FJPDA_READINGS_SEED + i,) * 2 + (100,), key
        assert set(NEW_CELLS.values()) <= set(e.config.variants()), key
    m = get("fjpda-occlusion-map")
    assert m.config.offsets == MAP_OFFSETS and m.runs == 40, m
    assert len(m.config.variants()) == 15, "JPDA and four FJPDA cells at 3 memories"
    with pytest.raises(ValueError, match="scene must be one of"):
        FjpdaTemplatesConfig("S9", 0.0)
    with pytest.raises(ValueError, match="offsets must lie"):
        FjpdaOcclusionMapConfig(offsets=(40.0,))
    with pytest.raises(ValueError, match="memory must hold"):
        FjpdaOcclusionMapConfig(memory=(1.5,))


@pytest.mark.skipif(status("fjpda-templates-occlusion") != "current",
                    reason="store not generated")
def test_template_rows_are_the_readings_runs():
    """Run i of a templates store is run i of the readings store: the trackers both
    ran agree field by field, and a direct run reproduces the stored row."""
    name = "fjpda-templates-occlusion"
    t, r = load(name), load("fjpda-readings-occlusion")
    for col in ("JPDA.tmr_num", "FJPDA.false_tracks", "FJPDA, sliding, fixed.tmr_num"):
        assert np.array_equal(t[col], r[col][: t.runs]), col
    e = get(name)
    assert status(name) == "current" and t.runs == 100, t
    for key in READINGS_SCENES:  # every scene's template store is committed
        assert status(f"fjpda-templates-{key}") == "current", key
    row = e.row(generator_for_run(e.seed, 7, e.runs), e.config)
    assert row == pytest.approx(t.row(7)), "run 7 re-simulated"


def test_dup_crossings_are_the_3px_crossings():
    """fjpda-ext-3px-dup runs FJPDA with the duplicate rule on the first 400 crossings of
    fjpda-ext-3px (same seed); a direct run of one crossing reproduces its stored row."""
    from trackcore.experiments.fjpda_extensions import FjpdaCrossingConfig

    e, s = get("fjpda-ext-3px-dup"), get("fjpda-ext-3px")
    assert (e.seed, e.runs, s.runs) == (s.seed, 400, 800), (e.seed, e.runs)
    assert e.config.trackers == ("FJPDA, duplicate rule",), e.config
    assert e.config.variants()["FJPDA, duplicate rule"].duplicate_deletion, "rule on"
    with pytest.raises(ValueError, match="unknown tracker"):
        FjpdaCrossingConfig(3.0, ("FJPDA, no such rule",))
    if status(e.name) == "current":
        row = e.row(generator_for_run(e.seed, 5, e.runs), e.config)
        assert row == load(e.name).row(5), "run 5 re-simulated"


def test_occlusion_map_store():
    """The committed map: 40 runs, every offset x tracker column, and blobs that merge
    longer as the crossing offset falls (0 frames at 10 px)."""
    name = "fjpda-occlusion-map"
    assert status(name) == "current", status(name)
    m, e = load(name), get(name)
    assert m.runs == 40, m
    for c in MAP_OFFSETS:
        for label in e.config.variants():
            for f in ("tmr_num", "tmr_den", "false_tracks"):
                assert f"c{c:g}.{label}.{f}" in m.columns, (c, label, f)
    merged = [np.mean(m[f"c{c:g}.merged"]) for c in MAP_OFFSETS]
    assert merged[0] == 0 and np.all(np.diff(merged) > 0), merged
