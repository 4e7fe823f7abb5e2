"""Tests of fjpda-occlusion-map-confirm (004-12): the occlusion map's four tying cells
(the sliding correlation with a fixed template) on fresh seeds."""
from __future__ import annotations

import numpy as np
import pytest
from _stores import corrupted_store

from trackcore.core.rng import generator_for_run
from trackcore.experiments import VerificationError, get, load, status, verify_sample
from trackcore.experiments.fjpda_map_readings import (
    FJPDA_MAP_CONFIRM_SEED,
    MAP_CONFIRM_CELLS,
    MAP_CONFIRM_RUNS,
    MAP_NEW_CELLS,
    MAP_READINGS_FIELDS,
    MAP_READINGS_MEMORY,
    FjpdaMapConfirmConfig,
    map_readings_trial,
)
from trackcore.experiments.fjpda_templates import MAP_CELLS, MAP_OFFSETS
from trackcore.trackers.jpda_tracker import matched_config

NAME = "fjpda-occlusion-map-confirm"
RUN = 5
REVIEW_SEEDS = (1500000000, 1510000010)


def test_registry_is_the_declared_design():
    e = get(NAME)
    assert (e.seed, e.runs) == (FJPDA_MAP_CONFIRM_SEED, MAP_CONFIRM_RUNS) == (20161645, 1000)
    assert e.config.offsets == MAP_OFFSETS and e.config.jitter == 3.0
    assert e.config.memory == MAP_READINGS_MEMORY == (1.0, 2.0)
    others = {x.seed for n in (
        "fjpda-occlusion-map", "fjpda-occlusion-map-readings", "fjpda-oat", "fjpda-confirm-s3")
        for x in [get(n)]}
    assert e.seed not in others
    assert not REVIEW_SEEDS[0] <= e.seed <= REVIEW_SEEDS[1]


def test_config_cells_are_the_maps():
    assert MAP_CONFIRM_CELLS["sf"] == MAP_CELLS["sf"]
    assert MAP_CONFIRM_CELLS["sv"] == MAP_NEW_CELLS["sv"]
    v = FjpdaMapConfirmConfig().variants()
    assert list(v) == ["JPDA m1", "sf m1", "sv m1", "JPDA m2", "sf m2", "sv m2"]
    for m in (1, 2):
        assert v[f"JPDA m{m}"] == ("vibe", matched_config("JPDA", 3.0, memory_frames=m))
        for cell, kw in MAP_CONFIRM_CELLS.items():
            assert v[f"{cell} m{m}"] == ("vibe", matched_config(
                "FJPDA", 3.0, memory_frames=m, **kw))
    with pytest.raises(ValueError, match="offsets must lie"):
        FjpdaMapConfirmConfig(offsets=(40.0,))


def test_first_fully_visible_is_fixed_first_on_one_run():
    """The vehicles enter fully visible: no first template touches the border, so
    "first fully visible" keeps the first silhouette and the runs are the same."""
    v = FjpdaMapConfirmConfig(memory=(1.0,)).variants()
    out = map_readings_trial(np.random.default_rng(11), (6.0, 2.0), v, 3.0)
    for c, (_, metrics) in out.items():
        for f in MAP_READINGS_FIELDS:
            assert getattr(metrics["sf m1"], f) == getattr(metrics["sv m1"], f), (c, f)


@pytest.fixture(scope="module")
def stored():
    if status(NAME) != "current":
        pytest.skip("store not current")
    return load(NAME)


def test_sv_rows_equal_sf_rows_run_for_run(stored):
    assert stored.runs == MAP_CONFIRM_RUNS
    for c in MAP_OFFSETS:
        for m in MAP_READINGS_MEMORY:
            for f in MAP_READINGS_FIELDS:
                a, b = (f"c{c:g}.{cell} m{m:g}.{f}" for cell in ("sf", "sv"))
                assert np.array_equal(stored[a], stored[b]), (a, b)


def test_stored_row_equals_the_direct_run(stored):
    e = get(NAME)
    row = e.row(generator_for_run(e.seed, RUN, e.runs), e.config)
    assert row == stored.row(RUN)


def test_verification_catches_a_corrupted_stored_row(stored, tmp_path):
    column = "c2.sf m1.tmr_num"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])
