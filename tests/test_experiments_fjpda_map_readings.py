"""Tests of fjpda-occlusion-map-readings (004-12): the occlusion map's pending template
cells and its readings one at a time, on the renders of fjpda-occlusion-map."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from _stores import corrupted_store

from trackcore.core.rng import generator_for_run
from trackcore.experiments import VerificationError, get, load, status, verify_sample
from trackcore.experiments.fjpda_map_readings import (
    MAP_NEW_CELLS,
    MAP_READINGS_MEMORY,
    MAP_VARIED,
    FjpdaMapReadingsConfig,
    map_results,
)
from trackcore.experiments.fjpda_oat import MATCHED_LAM
from trackcore.experiments.fjpda_readings import NO_TRACK
from trackcore.experiments.fjpda_templates import MAP_OFFSETS
from trackcore.trackers.jpda_tracker import matched_config

NAME = "fjpda-occlusion-map-readings"
MAP = "fjpda-occlusion-map"
RUN = 3


def test_registry_pairs_with_the_map():
    e, om = get(NAME), get(MAP)
    assert (e.seed, e.runs) == (om.seed, om.runs) == (om.seed, 40), "the map's renders"
    assert e.config.offsets == om.config.offsets == MAP_OFFSETS
    assert e.config.jitter == om.config.jitter == 3.0
    assert set(MAP_READINGS_MEMORY) <= set(om.config.memory)
    assert e.config.lam == MATCHED_LAM["occlusion"]


def test_config_cells_and_readings():
    v = FjpdaMapReadingsConfig().variants()
    default = matched_config("FJPDA", 3.0)
    assert v["cu m2"] == ("vibe", default), "the default cell at memory 2"
    for m in MAP_READINGS_MEMORY:
        assert v[f"JPDA m{m:g}"][1] == matched_config("JPDA", 3.0, memory_frames=int(m))
        for cell, kw in MAP_NEW_CELLS.items():
            method, cfg = v[f"{cell} m{m:g}"]
            assert method == "vibe" and cfg == matched_config("FJPDA", 3.0,
                                                             memory_frames=int(m), **kw)
    assert sorted(MAP_NEW_CELLS) == ["cn", "cv", "sn", "sv"]
    assert MAP_NEW_CELLS["sv"] == {"correlation": "sliding", "template_update": False,
                                   "template_from": "fully_visible"}
    changed = {}
    for value in MAP_VARIED:
        for t in ("JPDA", "FJPDA"):
            method, cfg = v[f"{t} {value}"]
            base = matched_config(t, 3.0)
            diff = {f.name for f in dataclasses.fields(cfg)
                    if getattr(cfg, f.name) != getattr(base, f.name)}
            changed[value, t] = (method, diff)
    assert changed["seg_ra", "FJPDA"] == ("running_average", set())
    assert changed["lam", "JPDA"] == ("vibe", {"lam"})
    assert v["FJPDA lam"][1].lam == MATCHED_LAM["occlusion"]
    for value, field in (("tsi", "tsi_from"), ("rho", "rho_weight"), ("rw", "model"),
                         ("pv", "model"), ("dd2", "d_dup"), ("gate20", "gate_max")):
        assert changed[value, "FJPDA"] == ("vibe", {field}), value
    assert v["JPDA gate20"][1].gate_max == 20.0 and v["FJPDA dd2"][1].d_dup == 2.0


def test_config_rejects_bad_fields():
    with pytest.raises(ValueError, match="unknown value 'mem1' in values"):
        FjpdaMapReadingsConfig(values=("mem1",))
    with pytest.raises(ValueError, match="lam must be > 0"):
        FjpdaMapReadingsConfig(lam=0.0)
    with pytest.raises(ValueError, match="memory must hold whole numbers"):
        FjpdaMapReadingsConfig(memory=(1.5,))
    with pytest.raises(ValueError, match="offsets must lie"):
        FjpdaMapReadingsConfig(offsets=(40.0,))
    assert "cu m2" not in FjpdaMapReadingsConfig(memory=(1.0,)).variants()


@pytest.fixture(scope="module")
def stored():
    if status(NAME) != "current" or status(MAP) != "current":
        pytest.skip("stores not current")
    return load(NAME)


def test_jpda_rows_are_the_maps_run_for_run(stored):
    """The store's JPDA (and default FJPDA) rows equal the map's: the same renders and
    ViBe segmentations."""
    om = load(MAP)
    assert stored.runs == om.runs == 40
    for c in MAP_OFFSETS:
        assert np.array_equal(stored[f"c{c:g}.merged"], om[f"c{c:g}.merged"]), c
        for label in (*(f"JPDA m{m:g}" for m in MAP_READINGS_MEMORY), "cu m2"):
            for f in ("tmr_num", "tmr_den", "false_tracks"):
                col = f"c{c:g}.{label}.{f}"
                assert np.array_equal(stored[col], om[col]), col


def test_stored_row_equals_the_direct_run(stored):
    e = get(NAME)
    row = e.row(generator_for_run(e.seed, RUN, e.runs), e.config)
    assert row == stored.row(RUN)


def test_verification_catches_a_corrupted_stored_row(stored, tmp_path):
    column = "c4.FJPDA seg_ra.tmr_num"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])


def test_map_results_of_the_store(stored):
    cells, rows = map_results(stored)
    n = 2 * len(MAP_NEW_CELLS) + 1 + len(MAP_VARIED)  # the default cell beside
    assert len(cells) == len(MAP_OFFSETS) * n and len(rows) == n
    texts = [t for t, _ in cells.values()]
    assert all(isinstance(t, str) and t for t in texts)
    # every not-applicable cell is one where neither tracker confirms a track
    for (c, key), (text, _) in cells.items():
        if text == NO_TRACK:
            assert key in MAP_VARIED, key
            for t in ("JPDA", "FJPDA"):
                assert not np.any(stored[f"c{c:g}.{t} {key}.coverage_num"]), (c, key)
