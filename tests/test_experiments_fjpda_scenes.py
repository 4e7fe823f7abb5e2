"""The feature-JPDA scene experiments (book/004-feature-jpda/05-scene-results.ipynb):
registry entries, config validation, stored rows against the notebook's computation,
a corrupted stored row caught by the sampled verification."""

import numpy as np
import pytest
from _stores import corrupted_store

from trackcore.core.rng import generator_for_run
from trackcore.experiments import VerificationError, get, load, status, verify_sample
from trackcore.experiments.fjpda_scenes import (
    CROSSING_CODES,
    EXPERIMENTS,
    FJPDA_SCENE_FIELDS,
    FjpdaSceneConfig,
)
from trackcore.scenarios.feature_metrics import scene_trial
from trackcore.trackers.jpda_tracker import matched_config

NAME = "fjpda-scenes-s1-jitter0"  # the cheapest scene: JPDA and FJPDA only
RUN = 3


@pytest.fixture(scope="module")
def direct():
    """Run RUN of the S1, 0 px scene as the notebook computed it before the port:
    ``montecarlo.run(scene_trial, 50, 20160325 + 100 + 0, args=(scene, variants))``."""
    variants = {v: matched_config(v, 0.0) for v in ("JPDA", "FJPDA")}
    rng = generator_for_run(20160325 + 100, RUN, 50)
    return scene_trial(rng, "jitter", variants, jitter=0.0)


def test_registry_holds_the_notebooks_seven_scenes():
    for i, (label, (key, scene, jitter, abl)) in enumerate(EXPERIMENTS.items()):
        e = get(f"fjpda-scenes-{key}")
        assert (e.seed, e.runs, e.version) == (20160325 + 100 + i, 50, "1"), label
        assert e.config == FjpdaSceneConfig(scene, jitter, abl), label
        assert status(e.name) == "current", f"{e.name}: {status(e.name)}"
    glare = get("fjpda-scenes-glare").config.variants()
    assert list(glare) == ["JPDA", "FJPDA", "FJPDA-gate", "FJPDA, TSI from unvalidated",
                           "FJPDA, normalised ρ"], list(glare)


def test_stored_rows_equal_the_notebooks_computation(direct):
    res = load(NAME)
    assert res.runs == 50 and res.is_book, res
    assert set(direct.metrics) == {"JPDA", "FJPDA"}, direct.metrics.keys()
    for v, m in direct.metrics.items():
        for field in FJPDA_SCENE_FIELDS:
            want = getattr(m, field)
            want = CROSSING_CODES[want] if field == "crossing" else want
            got = res[f"{v}.{field}"][RUN]
            assert got == want or (np.isnan(got) and np.isnan(want)), (v, field, got, want)
    row = get(NAME).extract(direct, res.config)  # the extractor on the same run
    assert row.keys() == res.row(RUN).keys(), sorted(row)
    assert all(row[k] == res.row(RUN)[k] or np.isnan(row[k]) for k in row), row


@pytest.mark.parametrize("kwargs, match", [
    ({"scene": "S9", "jitter": 0.0}, "scene must be one of"),
    ({"scene": "glare", "jitter": -1.0}, "jitter must be a finite number >= 0"),
    ({"scene": "glare", "jitter": float("nan")}, "jitter must be a finite number >= 0"),
    ({"scene": "glare", "jitter": 5.0, "ablations": ("gate", "nope")}, "unknown ablation"),
    ({"scene": "glare", "jitter": 5.0, "ablations": ("gate", "gate")}, "must not repeat"),
])
def test_bad_config_raises_a_clear_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FjpdaSceneConfig(**kwargs)


def test_overrides_are_parsed_and_validated():
    e = get("fjpda-scenes-glare")
    c = e.configure({"jitter": "3", "ablations": "gate,rho"})
    assert (c.scene, c.jitter, c.ablations) == ("glare", 3.0, ("gate", "rho")), c
    assert e.configure({"scene": "S3"}).scene == "S3"
    with pytest.raises(ValueError, match="scene must be one of"):
        e.configure({"scene": "nowhere"})
    with pytest.raises(ValueError, match="unknown config field"):
        e.configure({"runs": 3})
    with pytest.raises(TypeError, match="ablations must be a tuple"):
        FjpdaSceneConfig("glare", 5.0, ["gate"])


def test_verification_catches_a_corrupted_stored_row(direct, tmp_path):
    column = "FJPDA.id_switches"
    res = corrupted_store(NAME, tmp_path, column, RUN)
    assert res[column][RUN] == direct.metrics["FJPDA"].id_switches + 1
    with pytest.raises(VerificationError) as exc:
        verify_sample(res, indices=[RUN])
    msg = str(exc.value)
    assert msg.startswith(f"run {RUN}, column '{column}': stored "), msg
    assert "(must be equal)" in msg, msg
