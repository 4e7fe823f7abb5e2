"""The feature-JPDA measurement reading "position and velocity" (issue 29, session 13): the
config, one run against the one-at-a-time trial, the registered experiment and its store."""
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
from trackcore.experiments.fjpda_oat import (
    FJPDA_CALIBRATION_SEED,
    OAT_SCENES,
    FjpdaOatConfig,
    oat_trial,
)
from trackcore.experiments.fjpda_oat_vel import (
    FJPDA_OAT_VEL_SEED,
    OAT_VEL_RUNS,
    VARIED_VEL,
    FjpdaOatVelConfig,
)
from trackcore.experiments.fjpda_readings import READINGS_SCENES

NAME = "fjpda-oat-vel"
RUN = 9  # scene 3: S3 under 5 px


def test_config_validation_and_variants():
    c = FjpdaOatVelConfig()
    assert c.values == ("default", "pv") and c.scenes == OAT_SCENES, c
    assert c.lam == FjpdaOatConfig().lam, "the matched densities, unused by these values"
    for i, key in enumerate(OAT_SCENES):
        v = c.variants(i)
        assert list(v) == list(VARIED_VEL), list(v)
        jit = READINGS_SCENES[key][1]
        for t in ("JPDA", "FJPDA"):
            pv, d = v["pv"][1][t], v["default"][1][t]
            assert pv.model == "pv" and d.model == "cv", (pv, d)
            assert pv.r_std == d.r_std == pytest.approx(np.hypot(1.0, jit)), key
            assert pv.lam == d.lam == 1e-5 and pv.c_I == 0.6, pv
        assert v["pv"][0] == v["default"][0] == "vibe", key
    assert FjpdaOatConfig().variants(0)["default"] == c.variants(0)["default"], "same cell"
    with pytest.raises(ValueError, match="unknown value 'rw'"):
        FjpdaOatVelConfig(values=("default", "rw"))
    with pytest.raises(ValueError, match="must start with 'default'"):
        FjpdaOatVelConfig(values=("pv", "default"))
    with pytest.raises(ValueError, match="unknown value 'pv'"):
        FjpdaOatConfig(values=("default", "pv"))


def test_registry_seed_and_count():
    e = get(NAME)
    assert (e.seed, e.runs) == (FJPDA_OAT_VEL_SEED, OAT_VEL_RUNS) == (20160935, 1200)
    others = {get(n).seed for n in names() if n != NAME}
    calibration = set(range(FJPDA_CALIBRATION_SEED, FJPDA_CALIBRATION_SEED + 6))
    assert e.seed not in others | calibration, "a fresh master seed"
    assert e.trial is get("fjpda-oat").trial and e.extract is get("fjpda-oat").extract


def test_tiny_run_default_pair_matches_the_one_at_a_time_trial():
    rng = lambda: generator_for_run(3, 2, 6)  # run 2: occlusion
    i, out = oat_trial(rng(), FjpdaOatVelConfig())
    j, ref = oat_trial(rng(), FjpdaOatConfig(values=("default",)))
    assert i == j == 2 and sorted(out) == ["FJPDA default", "FJPDA pv", "JPDA default",
                                           "JPDA pv"], sorted(out)
    for t in ("JPDA", "FJPDA"):
        assert out[f"{t} default"]._replace(assoc_ms=0.0) == ref[f"{t} default"]._replace(
            assoc_ms=0.0), t
    row = get(NAME).extract((i, out), FjpdaOatVelConfig())
    assert row["scene"] == 2 and row["FJPDA pv.false_tracks"] >= 0, sorted(row)[:5]


@pytest.fixture(scope="module")
def stored():
    if status(NAME) != "current":
        pytest.skip("store not current")
    return load(NAME)


def test_verification_catches_a_corrupted_stored_row(stored, tmp_path):
    assert np.array_equal(stored["scene"], np.arange(stored.runs) % 6), "scene cycle"
    column = "FJPDA pv.false_tracks"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])


DUP = "fjpda-oat-dup"


def test_dup_config_and_registry():
    from trackcore.experiments.fjpda_oat_vel import (
        FJPDA_OAT_DUP_SEED,
        VARIED_DUP,
        FjpdaOatDupConfig,
    )

    c = FjpdaOatDupConfig()
    assert c.values == ("default", "dd2") and list(VARIED_DUP) == list(c.values), c
    for i, key in enumerate(OAT_SCENES):
        v = c.variants(i)
        assert v["default"] == FjpdaOatConfig().variants(i)["default"], key
        for t in ("JPDA", "FJPDA"):
            dd, d = v["dd2"][1][t], v["default"][1][t]
            assert dd.d_dup == 2.0 and d.d_dup == 5.0 and dd.duplicate_deletion, key
            assert dd == type(d)(**{**d.__dict__, "d_dup": 2.0}), (key, t)
    e = get(DUP)
    assert (e.seed, e.runs) == (FJPDA_OAT_DUP_SEED, OAT_VEL_RUNS) == (20160945, 1200)
    others = {get(n).seed for n in names() if n != DUP}
    calibration = set(range(FJPDA_CALIBRATION_SEED, FJPDA_CALIBRATION_SEED + 6))
    assert e.seed not in others | calibration, "a fresh master seed"
    assert not 1300000001 <= e.seed <= 1300000010, "not the review's seeds"


@pytest.fixture(scope="module")
def stored_dup():
    if status(DUP) != "current":
        pytest.skip("store not current")
    return load(DUP)


def test_stored_dup_row_equals_the_direct_run(stored_dup):
    e = get(DUP)
    row = e.row(generator_for_run(e.seed, RUN, e.runs), e.config)
    assert row.keys() == stored_dup.row(RUN).keys(), sorted(row)[:5]
    for k, x in row.items():
        if not k.endswith("assoc_ms"):
            assert stored_dup.row(RUN)[k] == x, (k, stored_dup.row(RUN)[k], x)


def test_verification_catches_a_corrupted_stored_dup_row(stored_dup, tmp_path):
    column = "FJPDA dd2.false_tracks"
    bad = corrupted_store(DUP, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])


CPV = "fjpda-confirm-pv"


def test_confirm_pv_config_and_registry():
    from trackcore.experiments.fjpda_oat_vel import (
        CONFIRM_PV_RUNS,
        CONFIRM_PV_SCENES,
        FJPDA_CONFIRM_PV_SEED,
        FjpdaConfirmPvConfig,
    )

    c = FjpdaConfirmPvConfig()
    assert c.values == ("pv",) and c.scenes == CONFIRM_PV_SCENES == ("glare", "side-by-side")
    vel = FjpdaOatVelConfig()
    for i, key in enumerate(c.scenes):
        assert c.variants(i)["pv"] == vel.variants(OAT_SCENES.index(key))["pv"], key
    with pytest.raises(ValueError, match="unknown value 'default'"):
        FjpdaConfirmPvConfig(values=("default", "pv"))
    with pytest.raises(ValueError, match="unknown scene"):
        FjpdaConfirmPvConfig(scenes=("glare", "nowhere"))
    e = get(CPV)
    assert (e.seed, e.runs) == (FJPDA_CONFIRM_PV_SEED, CONFIRM_PV_RUNS) == (20160965, 4000)
    others = {get(n).seed for n in names() if n != CPV}
    calibration = set(range(FJPDA_CALIBRATION_SEED, FJPDA_CALIBRATION_SEED + 6))
    assert e.seed not in others | calibration, "a fresh master seed"
    assert not 1500000000 <= e.seed <= 1510000010, "not the review's seeds"
    assert e.trial is get("fjpda-oat-vel").trial and e.extract is get("fjpda-oat-vel").extract


def test_confirm_pv_run_is_the_vel_trial_on_its_scene():
    """Run 3 renders side by side (3 mod 2); its pv pair equals the vel store's config
    run on the same generator restricted to that scene."""
    from trackcore.experiments.fjpda_oat_vel import FjpdaConfirmPvConfig

    rng = lambda: generator_for_run(11, 3, 4)
    i, out = oat_trial(rng(), FjpdaConfirmPvConfig())
    j, ref = oat_trial(rng(), FjpdaOatVelConfig(scenes=("glare", "side-by-side"),
                                                values=("default", "pv")))
    assert i == j == 1 and sorted(out) == ["FJPDA pv", "JPDA pv"], sorted(out)
    for t in ("JPDA", "FJPDA"):
        assert out[f"{t} pv"]._replace(assoc_ms=0.0) == ref[f"{t} pv"]._replace(
            assoc_ms=0.0), t


@pytest.fixture(scope="module")
def stored_cpv():
    if status(CPV) != "current":
        pytest.skip("store not current")
    return load(CPV)


def test_stored_cpv_row_equals_the_direct_run(stored_cpv):
    assert np.array_equal(stored_cpv["scene"], np.arange(stored_cpv.runs) % 2), "scenes"
    e = get(CPV)
    row = e.row(generator_for_run(e.seed, RUN, e.runs), e.config)
    assert row.keys() == stored_cpv.row(RUN).keys(), sorted(row)[:5]
    for k, x in row.items():
        if not k.endswith("assoc_ms"):
            assert stored_cpv.row(RUN)[k] == x, (k, stored_cpv.row(RUN)[k], x)


def test_verification_catches_a_corrupted_stored_cpv_row(stored_cpv, tmp_path):
    column = "FJPDA pv.false_tracks"
    bad = corrupted_store(CPV, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])
