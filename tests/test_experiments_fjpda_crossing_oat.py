"""Experiments fjpda-crossing-oat and fjpda-crossing-oat-vel: the Fig 7 crossing under every
reading (004-09, issue 29): the config, one run against the crossing of 07, the registered
experiments (the pv store's runs are the same crossings) and their stores."""
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
from trackcore.experiments.fjpda_crossing_oat import (
    CELLS,
    CROSSING_OAT_RUNS,
    FJPDA_CROSSING_OAT_SEED,
    OAT_CELLS,
    FjpdaCrossingOatConfig,
    cell_label,
)
from trackcore.experiments.fjpda_extensions import (
    CROSSING_OUTCOMES,
    FjpdaCrossingConfig,
)
from trackcore.scenarios.feature_metrics import crossing_trial
from trackcore.scenarios.feature_scenes import crossing_detections
from trackcore.trackers.jpda_tracker import JPDATrackerConfig

NAME = "fjpda-crossing-oat"
VEL = "fjpda-crossing-oat-vel"
RUN = 11


def test_config_validation_and_variants():
    c = FjpdaCrossingOatConfig()
    v = c.variants()
    assert len(v) == 19 and all(cfg.duplicate_deletion for cfg in v.values()), list(v)
    grid = [k for k, (r, *_) in CELLS.items() if not r]
    assert len(grid) == 8 and "JPDA cn" not in v, "the grid cells are FJPDA only"
    assert all(cfg.lam == 1e-5 for k, cfg in v.items() if not k.endswith(" lam"))
    assert v["JPDA lam"].lam == v["FJPDA lam"].lam == pytest.approx(1 / 120**2)
    assert v["FJPDA sv"].correlation == "sliding" and not v["FJPDA sv"].template_update
    assert v["FJPDA sv"].template_from == "fully_visible"
    assert v["JPDA mem1"].memory_frames == v["FJPDA mem1"].memory_frames == 1
    assert v["JPDA rw"].model == "rw" and v["FJPDA tsi"].tsi_from == "unvalidated"
    assert v["FJPDA rho"].rho_weight == "normalised" and not v["FJPDA cn"].template_guard
    assert c.scene() == FjpdaCrossingConfig(3.0).scene(), "the crossing of 07 at 3 px"
    with pytest.raises(ValueError, match="must start with 'cu'"):
        FjpdaCrossingOatConfig(cells=("mem1", "cu"))
    with pytest.raises(ValueError, match="unknown cell"):
        FjpdaCrossingOatConfig(cells=("cu", "pw"))
    with pytest.raises(ValueError, match="must start with 'cu'"):
        FjpdaCrossingOatConfig(cells=("pv", "sf"))
    assert c.cells == OAT_CELLS and "pv" not in OAT_CELLS and len(CELLS) == 14
    pv = FjpdaCrossingOatConfig(cells=("pv",)).variants()
    assert list(pv) == ["JPDA pv", "FJPDA pv"], list(pv)
    for t, cfg in pv.items():
        ref = v[t.replace("pv", "cu")]
        assert cfg == JPDATrackerConfig(**{**ref.__dict__, "model": "pv"}), t
    with pytest.raises(ValueError, match="lam_matched must be > 0"):
        FjpdaCrossingOatConfig(lam_matched=0.0)
    with pytest.raises(ValueError, match="conflict must be in"):
        FjpdaCrossingOatConfig(conflict=36)
    with pytest.raises(ValueError, match="unknown config field"):
        c.with_overrides({"trackers": "JPDA"})
    assert c.with_overrides({"cells": "cu,mem1"}).cells == ("cu", "mem1")


def test_cell_labels_are_the_registry_grid():
    import sys
    from pathlib import Path

    book = Path(__file__).resolve().parent.parent / "book"
    sys.path.insert(0, str(book / "_ext"))
    import scorecard

    path = book / "004-feature-jpda" / "claims.yml"
    data = scorecard.load(path)
    claim = next(c for c in data["claims"] if c["id"] == "fjpda-fig7-crossing")
    grid = scorecard.reading_grid(data, claim)
    from trackcore.experiments.fjpda_crossing_oat import READINGS2_CELLS

    labels = {cell_label(k): k for k in CELLS}
    labels |= {f"{cell_label('cu')}; {r}: {v}": k for k, (r, v, *_) in READINGS2_CELLS.items()}
    pending = [g for g in grid if g not in labels]
    assert pending == [], pending
    for label, key in labels.items():
        assert claim["ours"][label] == f"09-crossing-readings::fjpda_xo_{key}", label


def test_one_run_equals_the_crossing_trial():
    config = FjpdaCrossingOatConfig(cells=("cu", "sf", "rho", "lam"))
    rng = generator_for_run(5, 2, 10)
    out = crossing_trial(rng, *get(NAME).call(config)[0], **config.scene())
    ref = crossing_trial(generator_for_run(5, 2, 10),
                         {"JPDA": JPDATrackerConfig(variant="JPDA", lam=1 / 120**2)},
                         **config.scene())
    assert out["JPDA lam"]._replace(assoc_ms=0.0) == ref["JPDA"]._replace(assoc_ms=0.0)
    assert out["JPDA rho"].crossing == out["JPDA cu"].crossing, "JPDA ignores rho weights"
    row = get(NAME).extract(out, config)
    assert sorted(row) == sorted(f"{t}.crossing" for t in out), sorted(row)
    assert all(CROSSING_OUTCOMES[row[k]] == out[k[:-9]].crossing for k in row), row


def test_registry_seed_and_runs():
    e = get(NAME)
    assert (e.seed, e.runs) == (FJPDA_CROSSING_OAT_SEED, CROSSING_OAT_RUNS) and e.runs >= 400
    others = {get(n).seed for n in names() if n not in (NAME, VEL)}
    assert e.seed not in others, "a fresh master seed"


def test_the_pv_store_runs_the_same_crossings():
    e, v = get(NAME), get(VEL)
    assert (v.seed, v.runs) == (e.seed, e.runs), "the same master seed and run count"
    assert v.trial is e.trial and v.call is e.call and v.extract is e.extract
    assert v.config == FjpdaCrossingOatConfig(cells=("pv",)), v.config
    assert v.config.scene() == e.config.scene(), "the same crossing scene"
    for i in (0, RUN, e.runs - 1):
        a, _ = crossing_detections(generator_for_run(e.seed, i, e.runs), **e.config.scene())
        b, _ = crossing_detections(generator_for_run(v.seed, i, v.runs), **v.config.scene())
        assert len(a) == len(b), i
        for k, (fa, fb) in enumerate(zip(a, b)):
            for f in ("z", "boxes", "areas"):
                assert np.array_equal(getattr(fa, f), getattr(fb, f)), (i, k, f)
            for f in ("masks", "greys"):
                x, y = getattr(fa, f), getattr(fb, f)
                assert len(x) == len(y), (i, k, f)
                assert all(np.array_equal(p, q) for p, q in zip(x, y)), (i, k, f)


@pytest.fixture(scope="module")
def stored():
    if status(NAME) != "current":
        pytest.skip("store not current")
    return load(NAME)


def test_stored_row_equals_the_direct_run(stored):
    e = get(NAME)
    row = e.row(generator_for_run(e.seed, RUN, e.runs), e.config)
    assert row.keys() == stored.row(RUN).keys(), sorted(row)[:5]
    for k, v in row.items():
        assert stored.row(RUN)[k] == v, (k, stored.row(RUN)[k], v)
    assert np.array_equal(stored["JPDA rho.crossing"], stored["JPDA cu.crossing"])


def test_verification_catches_a_corrupted_stored_row(stored, tmp_path):
    column = "FJPDA sf.crossing"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])


@pytest.fixture(scope="module")
def stored_vel():
    if status(VEL) != "current":
        pytest.skip("store not current")
    return load(VEL)


def test_stored_pv_row_equals_the_direct_run(stored_vel):
    v = get(VEL)
    row = v.row(generator_for_run(v.seed, RUN, v.runs), v.config)
    assert sorted(row) == ["FJPDA pv.crossing", "JPDA pv.crossing"], sorted(row)
    for k, x in row.items():
        assert stored_vel.row(RUN)[k] == x, (k, stored_vel.row(RUN)[k], x)
    assert stored_vel.runs == CROSSING_OAT_RUNS, stored_vel.runs


def test_verification_catches_a_corrupted_stored_pv_row(stored_vel, tmp_path):
    column = "FJPDA pv.crossing"
    bad = corrupted_store(VEL, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])


R2 = "fjpda-crossing-readings2"


def test_readings2_config_and_labels():
    from trackcore.experiments.fjpda_crossing_oat import (
        FJPDA_CROSSING_READINGS2_SEED,
        READINGS2_CELLS,
        FjpdaCrossingReadings2Config,
    )

    e = get(R2)
    assert (e.seed, e.runs) == (FJPDA_CROSSING_READINGS2_SEED, CROSSING_OAT_RUNS)
    others = {get(n).seed for n in names() if n != R2}
    assert e.seed not in others, "a fresh master seed"
    assert not 1300000001 <= e.seed <= 1300000010, "not the review's seeds"
    groups = {k: (v, s) for k, v, s in e.config.groups()}
    assert list(groups) == list(READINGS2_CELLS), list(groups)
    default = FjpdaCrossingOatConfig()
    for key, (variants, scene) in groups.items():
        _, _, sep, d_dup = READINGS2_CELLS[key]
        assert scene == {**default.scene(), "min_sep": sep}, key
        assert list(variants) == ["JPDA", "FJPDA"], key
        for t, cfg in variants.items():
            ref = default.variants()[f"{t} cu"]
            assert cfg == JPDATrackerConfig(**{**ref.__dict__, "d_dup": d_dup}), (key, t)
    assert groups["dd2"][1]["min_sep"] == 3.0 and groups["dd2"][0]["FJPDA"].d_dup == 2.0
    with pytest.raises(ValueError, match="unknown cell"):
        FjpdaCrossingReadings2Config(cells=("dd3",))


@pytest.fixture(scope="module")
def stored_r2():
    if status(R2) != "current":
        pytest.skip("store not current")
    return load(R2)


def test_stored_readings2_row_equals_the_direct_run(stored_r2):
    e = get(R2)
    row = e.row(generator_for_run(e.seed, RUN, e.runs), e.config)
    assert len(row) == 8 and row.keys() == stored_r2.row(RUN).keys(), sorted(row)
    for k, x in row.items():
        assert stored_r2.row(RUN)[k] == x, (k, stored_r2.row(RUN)[k], x)


def test_verification_catches_a_corrupted_stored_readings2_row(stored_r2, tmp_path):
    column = "FJPDA dd2.crossing"
    bad = corrupted_store(R2, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])
