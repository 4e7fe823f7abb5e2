"""The feature-JPDA duplicate rule under every reading (issue 29, session 14): the config
(every cell built by the existing builders, with and without the rule), the comparison
moved from notebook 05, the registered experiment and its store; since session 15 the
premise columns (the follower's full entry, each with-rule arm's first duplicate
deletion), the premise subset and the share of false tracks removed."""
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
    NOT_APPLICABLE,
    FjpdaDupReadingsConfig,
    cell_label,
    dup_rule_effect,
    dup_trial,
    first_deletion,
    follower_entry,
    premise_effect,
    premise_seeds,
    removed_share,
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
    assert e.trial is dup_trial and e.version == "2"


def test_claims_cells_map_to_the_declared_glue_keys():
    sys.path.insert(0, str(ROOT / "book" / "_ext"))
    import scorecard

    data = scorecard.load(ROOT / "book" / "004-feature-jpda" / "claims.yml")
    claims = {c["id"]: c for c in data["claims"]}
    by_label = {cell_label(v): ("cu" if v == "default" else v) for v in DUP_VALUES}
    for cid, kind in (("fjpda-fig8-duplicates", "prem"),
                      ("fjpda-conclusion-duplicates", "false")):
        grid = scorecard.reading_grid(data, claims[cid])
        assert sorted(grid) == sorted(by_label), cid
        jpda, fjpda = (p["ours"] for p in claims[cid]["rule"]["all"])
        shown = claims[cid]["ours"]
        for label in grid:
            k = by_label[label]
            assert shown[label] == fjpda[label], (cid, label)
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


def test_fig8_is_decided_on_the_premise_measure():
    sys.path.insert(0, str(ROOT / "book" / "_ext"))
    import scorecard

    data = scorecard.load(ROOT / "book" / "004-feature-jpda" / "claims.yml")
    claim = {c["id"]: c for c in data["claims"]}["fjpda-fig8-duplicates"]
    assert claim["measure"] == "dup-follow-premise" and "dup-follow" in data["measures"]
    assert "dup-follow-premise" in data["premises"], sorted(data["premises"])
    assert NOT_APPLICABLE.startswith("not applicable"), NOT_APPLICABLE


def test_dup_trial_is_oat_trials_run_plus_the_premise_frames():
    config = FjpdaDupReadingsConfig(values=("default", "dd2"))
    i, metrics = oat_trial(generator_for_run(FJPDA_DUP_READINGS_SEED, RUN, 600), config)
    j, metrics2, entry, first = dup_trial(
        generator_for_run(FJPDA_DUP_READINGS_SEED, RUN, 600), config)
    def timeless(m):  # assoc_ms is a wall time (not stored)
        return {k: v._replace(assoc_ms=0.0) for k, v in m.items()}

    assert i == j and timeless(metrics) == timeless(metrics2), "oat_trial's draws"
    assert sorted(first) == ["FJPDA dd2", "FJPDA default", "JPDA dd2", "JPDA default"]
    assert entry > 0 and all(k >= -1 for k in first.values()), (entry, first)


def test_follower_entry_is_the_first_fully_visible_frame():
    from trackcore.scenarios.feature_scenes import render_scene

    scene = render_scene("S3", np.random.default_rng(4), jitter=5.0)
    full = np.nonzero(scene.visible[:, scene.pair[1]])[0]
    assert follower_entry(scene) == full[0] > 0
    present = np.nonzero(scene.present[:, scene.pair[1]])[0]
    assert present[0] <= full[0], "present (partly) before fully visible"
    assert follower_entry(scene._replace(name="S1")) == -1
    gone = scene._replace(visible=scene.visible & ~np.isin(
        np.arange(scene.visible.shape[1]), [scene.pair[1]])[None, :])
    assert follower_entry(gone) == -1


def test_first_deletion_reads_the_reason_of_the_first_deleting_frame():
    from trackcore.trackers.jpda_tracker import FrameReport

    reps = [FrameReport(k, (), 0, 0, 0, d, 0.0) for k, d in enumerate(
        [(), ((1, "gate"),), ((2, "miss"), (4, "duplicate")), ((6, "duplicate"),)])]
    assert first_deletion(reps) == 2 and first_deletion(reps, "gate") == 1
    assert first_deletion(reps[3:]) == 3 and first_deletion(reps[:2]) == -1
    assert first_deletion([]) == -1


def test_first_deletion_of_a_real_run_is_a_duplicate_and_none_without_the_rule():
    from trackcore.scenarios.feature_scenes import render_scene, segment_scene
    from trackcore.trackers.jpda_tracker import run_jpda_tracker

    rng = np.random.default_rng(11)
    scene = render_scene("S3", rng, jitter=5.0)
    dets = segment_scene(scene, "vibe", rng)[0]
    cfg = matched_config("JPDA", 5.0)
    reps = run_jpda_tracker(dets, cfg)
    k = first_deletion(reps)
    dups = [r.k for r in reps if any(w == "duplicate" for _, w in r.deleted)]
    assert k == (dups[0] if dups else -1), (k, dups)
    off = run_jpda_tracker(dets, type(cfg)(**{**cfg.__dict__, "duplicate_deletion": False}))
    assert first_deletion(off) == -1


def test_premise_seeds_need_a_deletion_strictly_before_entry():
    d = np.array([-1, 0, 5, 6, 7, 3, -1])
    e = np.array([6, 6, 6, 6, 6, -1, -1])
    assert premise_seeds(d, e).tolist() == [False, True, True, False, False, False, False]
    with pytest.raises(ValueError, match="paired runs"):
        premise_seeds(d, e[:3])


def test_premise_effect_is_dup_rule_effect_on_the_subset():
    rng = np.random.default_rng(8)
    n = 300
    dw = np.where(rng.random(n) < 0.6, rng.integers(0, 20, n), -1)
    dwo = np.where(rng.random(n) < 0.2, dw, -1)
    fw, fwo = rng.poisson(1.0, n), rng.poisson(1.3, n)
    prem = rng.random(n) < 0.4
    e, k = premise_effect(dw, dwo, fw, fwo, prem)
    ref = dup_rule_effect(dw[prem], dwo[prem], fw[prem], fwo[prem])
    assert k == prem.sum() and format(e.follow_diff, ".4f") == format(ref.follow_diff, ".4f")
    assert (e.only_with, e.only_without) == (ref.only_with, ref.only_without)
    assert premise_effect(dw, dwo, fw, fwo, np.zeros(n, bool)) == (None, 0)
    with pytest.raises(ValueError, match="premise has shape"):
        premise_effect(dw, dwo, fw, fwo, prem[:10])


def test_removed_share_is_one_minus_the_ratio_of_means():
    from trackcore.stats import ratio_ci

    rng = np.random.default_rng(2)
    wo = rng.poisson(1.5, 400)
    w = np.maximum(wo - rng.poisson(0.6, 400), 0)
    s = removed_share(w, wo)
    r = ratio_ci(w.astype(float), wo.astype(float), paired=True)
    assert abs(s.value - (wo.mean() - w.mean()) / wo.mean()) < 1e-12
    assert (s.lo, s.hi) == pytest.approx((1 - r.hi, 1 - r.lo)), (s, r)
    assert s.lo < s.value < s.hi
    assert removed_share(np.zeros(50), np.zeros(50)) is None
    with pytest.raises(ValueError, match="paired runs"):
        removed_share(w, wo[:5])


def test_new_columns_are_stored(stored):
    entry = np.asarray(stored["follower_entry"])
    assert entry.dtype.kind == "i" and np.all(entry >= -1)
    for v in DUP_VALUES:
        for t in ("JPDA", "FJPDA"):
            if t == "JPDA" and v in GRID:
                continue
            k = np.asarray(stored[f"{t} {v}.first_dup_deletion"])
            assert k.dtype.kind == "i" and np.all(k >= -1), (t, v)
            assert f"{t} nodup {v}.first_dup_deletion" not in stored.columns


@pytest.mark.parametrize("column", ["follower_entry", "FJPDA sf.first_dup_deletion"])
def test_verification_catches_a_corrupted_premise_column(stored, tmp_path, column):
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])
