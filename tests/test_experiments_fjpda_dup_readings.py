"""The feature-JPDA duplicate rule under every reading (issue 29, session 14): the config
(every cell built by the existing builders, with and without the rule), the comparison
moved from notebook 05, the registered experiment and its store."""
import sys
from pathlib import Path

import numpy as np
import pytest
from _stores import corrupted_store

from trackcore.core.rng import generator_for_run
from trackcore.experiments import (
    VerificationError,
    get,
    load,
    names,
    status,
    verify_sample,
)
from trackcore.experiments.fjpda_dup_readings import (
    DUP_READINGS_RUNS,
    DUP_VALUES,
    FJPDA_DUP_READINGS_SEED,
    GRID,
    FjpdaDupReadingsConfig,
    cell_label,
    dup_rule_effect,
)
from trackcore.experiments.fjpda_oat import FJPDA_CALIBRATION_SEED, MATCHED_LAM, oat_trial
from trackcore.experiments.fjpda_readings import READING_VARIANTS
from trackcore.experiments.fjpda_templates import TEMPLATE_VARIANTS
from trackcore.trackers.jpda_tracker import matched_config

NAME = "fjpda-dup-readings"
RUN = 5
ROOT = Path(__file__).resolve().parent.parent


def test_config_builds_every_cell_with_and_without_the_rule():
    c = FjpdaDupReadingsConfig()
    assert c.scenes == ("s3-jitter5",) and c.lam == (MATCHED_LAM["s3-jitter5"],), c
    v = c.variants(0)
    assert list(v) == list(DUP_VALUES) and len(v) == 17, list(v)
    labels = {**READING_VARIANTS, **TEMPLATE_VARIANTS}
    kws = [kw for _, kw in labels.values()]
    for key, (_, _, kw) in GRID.items():
        assert kw in kws, key
        arms = v["default" if key == "cu" else key][1]
        assert arms["FJPDA"] == matched_config("FJPDA", 5.0, **kw), key
        assert arms["FJPDA nodup"] == matched_config(
            "FJPDA", 5.0, duplicate_deletion=False, **kw), key
        assert ("JPDA" in arms) == (key == "cu"), (key, sorted(arms))
    for key, (method, arms) in v.items():
        assert method == ("running_average" if key == "seg_ra" else "vibe"), key
        for t in ("JPDA", "FJPDA"):
            if t in arms and key != "dd2":
                assert arms[f"{t} nodup"] == type(arms[t])(
                    **{**arms[t].__dict__, "duplicate_deletion": False}), (key, t)
    assert sorted(v["dd2"][1]) == ["FJPDA", "JPDA"], "the 'without' arm is the default's"
    assert v["dd2"][1]["JPDA"].d_dup == 2.0 and v["default"][1]["JPDA"].d_dup == 5.0
    assert v["lam"][1]["JPDA"].lam == MATCHED_LAM["s3-jitter5"]
    with pytest.raises(ValueError, match="must start with 'default'"):
        FjpdaDupReadingsConfig(values=("dd2", "default"))


def test_registry_seed_and_count():
    e = get(NAME)
    assert (e.seed, e.runs) == (FJPDA_DUP_READINGS_SEED, DUP_READINGS_RUNS) == (20160955, 600)
    others = {get(n).seed for n in names() if n != NAME}
    calibration = set(range(FJPDA_CALIBRATION_SEED, FJPDA_CALIBRATION_SEED + 6))
    assert e.seed not in others | calibration, "a fresh master seed"
    assert not 1300000001 <= e.seed <= 1300000010, "not the review's seeds"
    assert e.trial is oat_trial


def test_claims_cells_map_to_the_declared_glue_keys():
    sys.path.insert(0, str(ROOT / "book" / "_ext"))
    import scorecard

    data = scorecard.load(ROOT / "book" / "004-feature-jpda" / "claims.yml")
    claims = {c["id"]: c for c in data["claims"]}
    by_label = {cell_label(v): ("cu" if v == "default" else v) for v in DUP_VALUES}
    for cid, kind in (("fjpda-fig8-duplicates", "follow"),
                      ("fjpda-conclusion-duplicates", "false")):
        grid = scorecard.reading_grid(data, claims[cid])
        assert sorted(grid) == sorted(by_label), cid
        jpda, fjpda = (p["ours"] for p in claims[cid]["rule"]["all"])
        for label in grid:
            k = by_label[label]
            assert fjpda[label].endswith(f"::fjpda_dupr_{kind}_fjpda_{k}"), (cid, label)
            kj = "cu" if k in GRID else k
            assert jpda[label].endswith(f"::fjpda_dupr_{kind}_jpda_{kj}"), (cid, label)


def test_dup_rule_effect_is_05s_computation():
    if status("fjpda-scenes-s3-jitter5") != "current":
        pytest.skip("store not current")
    sys.path.insert(0, str(ROOT / "book" / "_ext"))
    import scorecard

    glued = scorecard.glued(ROOT / "book" / "004-feature-jpda" / "05-scene-results.ipynb")
    res = load("fjpda-scenes-s3-jitter5")
    for v in ("JPDA", "FJPDA"):
        nd = f"{v}, no duplicate deletion"
        e = dup_rule_effect(res[f"{v}.follower_delay"], res[f"{nd}.follower_delay"],
                            res[f"{v}.false_tracks"], res[f"{nd}.false_tracks"])
        key = f"fjpda_dup_follow_{v.lower()}"
        assert format(e.follow_with, ".2f") == glued[key], (v, e.follow_with)
        assert format(e.follow_diff, ".2f") == glued[f"{key}_diff"], (v, e.follow_diff)
        assert format(e.false.diff, ".2f") == glued[f"fjpda_dup_false_{v.lower()}"], v


@pytest.fixture(scope="module")
def stored():
    if status(NAME) != "current":
        pytest.skip("store not current")
    return load(NAME)


def test_stored_row_equals_a_direct_run(stored):
    # the ViBe cells of a subset of values: ViBe segments first, so the detections and
    # these columns are those of the full run
    e = get(NAME)
    config = FjpdaDupReadingsConfig(values=("default", "dd2"))
    row = e.row(generator_for_run(e.seed, RUN, e.runs), config)
    full = stored.row(RUN)
    assert len(row) > 40 and set(row) <= set(full), sorted(set(row) - set(full))[:5]
    for k, x in row.items():
        assert full[k] == x, (k, full[k], x)
    assert np.array_equal(stored["scene"], np.zeros(stored.runs)), "S3 only"


def test_verification_catches_a_corrupted_stored_row(stored, tmp_path):
    column = "FJPDA nodup sf.follower_delay"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])
