"""Tests of the 004 follow-up experiments (issue 29, ninth review): the S3 threshold sweep
below 0.4 and the occlusion map at memories as long as its merges."""
from __future__ import annotations

import numpy as np
import pytest

from trackcore.experiments import get, load, status
from trackcore.experiments import names
from trackcore.experiments.fjpda_followups import (
    CONFIRM_RUNS,
    CONFIRM_SCENES,
    FJPDA_CONFIRM_SEED,
    MAP_LONG_MEMORY,
    S3_LOW_THRESHOLDS,
    FjpdaS3ThresholdConfig,
)
from trackcore.experiments.fjpda_templates import MAP_CELLS, MAP_OFFSETS


def test_registry_pairs_with_the_stores_it_extends():
    t, r = get("fjpda-s3-threshold"), get("fjpda-readings-s3-jitter5")
    assert (t.seed, t.runs) == (r.seed, r.runs), "the threshold runs must be the S3 runs"
    assert t.config.jitter == r.config.jitter == 5.0
    m, om = get("fjpda-occlusion-map-long"), get("fjpda-occlusion-map")
    assert (m.seed, m.runs) == (om.seed, om.runs), "the long map must be the map's renders"
    assert m.config.offsets == om.config.offsets and m.config.jitter == om.config.jitter
    assert m.config.memory == MAP_LONG_MEMORY
    merges = (5, 10, 14)  # frames at offsets 6, 4, 2 px (measured before the map ran)
    assert all(any(mem >= k for mem in MAP_LONG_MEMORY) for k in merges)
    labels = list(m.config.variants())
    assert len(labels) == len(MAP_LONG_MEMORY) * (1 + len(MAP_CELLS)), labels


def test_confirmation_runs_are_the_readings_runs_on_fresh_seeds():
    seeds = {get(n).seed for n in names() if n.startswith("fjpda-")
             and not n.startswith("fjpda-confirm-")}
    for i, key in enumerate(CONFIRM_SCENES):
        c, r = get(f"fjpda-confirm-{key}"), get(f"fjpda-readings-{key}")
        assert c.config == r.config and c.trial is r.trial and c.extract is r.extract
        assert (c.seed, c.runs) == (FJPDA_CONFIRM_SEED + i, CONFIRM_RUNS)
        assert c.seed not in seeds, "the confirmation seeds must be fresh"
    assert CONFIRM_RUNS >= 4 * 150  # the replication's intervals halved


def test_threshold_config():
    v = FjpdaS3ThresholdConfig().variants()
    assert [v[f"FJPDA, c_I {c:.1f}"].c_I for c in S3_LOW_THRESHOLDS] == [0.3, 0.2]
    assert v["FJPDA"].c_I == 0.6 and v["JPDA"].c_I == 0.6
    with pytest.raises(ValueError, match="thresholds must lie"):
        FjpdaS3ThresholdConfig(thresholds=(0.0,))


@pytest.mark.skipif(status("fjpda-s3-threshold") != "current"
                    or status("fjpda-readings-s3-jitter5") != "current",
                    reason="stores not current")
def test_threshold_rows_are_the_readings_runs():
    t, r = load("fjpda-s3-threshold"), load("fjpda-readings-s3-jitter5")
    for label in ("JPDA", "FJPDA"):
        for f in ("tmr_num", "tmr_den", "false_tracks", "mean_events", "false_bar"):
            assert np.array_equal(t[f"{label}.{f}"], r[f"{label}.{f}"]), (label, f)


@pytest.mark.skipif(status("fjpda-occlusion-map-long") != "current"
                    or status("fjpda-occlusion-map") != "current",
                    reason="stores not current")
def test_long_map_renders_the_map_scenes():
    m, om = load("fjpda-occlusion-map-long"), load("fjpda-occlusion-map")
    for c in MAP_OFFSETS:
        assert np.array_equal(m[f"c{c:g}.merged"], om[f"c{c:g}.merged"]), c
        assert len(m[f"c{c:g}.JPDA m15.tmr_num"]) == m.runs == 40, c
