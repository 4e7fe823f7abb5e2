"""The feature-JPDA readings varied one at a time (issue 29, session 12): the matched clutter
density, the config, one run against the readings trial, the registered experiments and
their stores."""
import random

import numpy as np
import pytest
from _stores import corrupted_store

from trackcore.core.rng import generator_for_run
from trackcore.detection.image import detect_blobs
from trackcore.experiments import (
    VerificationError,
    get,
    load,
    names,
    status,
    verify_sample,
)
from trackcore.experiments.fjpda_oat import (
    CONFIRM_S3_RUNS,
    FJPDA_CALIBRATION_SEED,
    FJPDA_OAT_SEED,
    IMAGE_AREA,
    MATCHED_LAM,
    OAT_SCENES,
    VARIED,
    FjpdaConfirmS3Config,
    FjpdaOatConfig,
    clutter_per_frame,
    matched_density,
    oat_trial,
    scene_of_run,
)
from trackcore.experiments.fjpda_readings import READINGS_SCENES, readings_trial
from trackcore.scenarios.feature_scenes import N_WARMUP, render_scene

NAME = "fjpda-oat"
RUN = 7  # scene 1: side by side


def test_clutter_per_frame_counts_blobs_off_the_vehicles():
    scene = render_scene("glare", np.random.default_rng(0), jitter=0.0)
    veh = np.nonzero(scene.is_vehicle)[0] + 1
    dets = []
    for k in range(3):
        mask = np.isin(scene.labels[N_WARMUP + k], veh)
        mask[2:10, 2:10] = k > 0  # a blob in the corner, away from every vehicle
        dets.append(detect_blobs(mask, np.zeros(mask.shape), clean=False))
    counts = clutter_per_frame(scene, dets)
    n_veh = [len(d.z) - (k > 0) for k, d in enumerate(dets)]
    assert counts.tolist() == [0, 1, 1], (counts, n_veh)


def test_matched_lam_is_the_declared_measurement():
    # one scene's 50 calibration renders (about 12 s), a fresh one of the six each time, as
    # the notebooks verify a fresh sample of stored runs
    key = random.SystemRandom().choice(OAT_SCENES)
    assert matched_density(key) == pytest.approx(MATCHED_LAM[key], rel=1e-12), key


def test_matched_density_floor_and_fresh_seed():
    assert MATCHED_LAM["side-by-side"] == pytest.approx(
        1.0 / (50 * 60 * IMAGE_AREA), rel=1e-12), "one detection over 50 x 60 frames"
    seeds = {get(n).seed for n in names()}
    assert FJPDA_CALIBRATION_SEED not in seeds and FJPDA_CALIBRATION_SEED + 5 not in seeds


def test_config_validation_and_variants():
    c = FjpdaOatConfig()
    assert c.lam == tuple(MATCHED_LAM[s] for s in OAT_SCENES), c.lam
    for i, key in enumerate(OAT_SCENES):
        v = c.variants(i)
        assert list(v) == list(VARIED), list(v)
        jit = READINGS_SCENES[key][1]
        assert v["default"][1]["FJPDA"].r_std == pytest.approx(np.hypot(1.0, jit)), key
        assert v["gate20"][1]["JPDA"].gate_max == 20.0, "unscaled for both trackers"
        assert v["lam"][1]["JPDA"].lam == v["lam"][1]["FJPDA"].lam == c.lam[i], key
        assert v["seg_ra"][0] == "running_average" and v["rw"][1]["JPDA"].model == "rw"
    with pytest.raises(ValueError, match="must start with 'default'"):
        FjpdaOatConfig(values=("mem1", "default"))
    with pytest.raises(ValueError, match="one density > 0 per scene"):
        FjpdaOatConfig(lam=(1e-5,))
    with pytest.raises(ValueError, match="unknown scene"):
        FjpdaOatConfig(scenes=("S9",))
    with pytest.raises(ValueError, match="no extras"):
        FjpdaConfirmS3Config(extras=("s3",))
    assert FjpdaOatConfig().with_overrides({"values": "default,mem1"}).values == (
        "default", "mem1")


def test_registry_seeds_counts_and_scene_cycle():
    e, c = get(NAME), get("fjpda-confirm-s3")
    assert (e.seed, e.runs) == (FJPDA_OAT_SEED, 200 * len(OAT_SCENES))
    assert (c.seed, c.runs) == (FJPDA_OAT_SEED + 1, CONFIRM_S3_RUNS) and c.runs >= 600
    # fjpda-accuracy reruns fjpda-oat's runs on purpose (the same renders and detections)
    others = {get(n).seed for n in names()
              if n not in (NAME, "fjpda-confirm-s3", "fjpda-accuracy")}
    assert e.seed not in others and c.seed not in others, "fresh master seeds"
    s3 = get("fjpda-readings-s3-jitter5")
    assert c.trial is s3.trial and c.extract is s3.extract
    want = {k: v for k, v in s3.config.variants().items() if k in c.config.variants()}
    assert c.config.variants() == want and len(want) == 5, list(want)
    got = [scene_of_run(generator_for_run(e.seed, i, e.runs), 6) for i in range(13)]
    assert got == [i % 6 for i in range(13)], got


def test_one_run_default_pair_is_the_readings_trial():
    config = FjpdaOatConfig(values=("default", "rho", "mem1"))
    i, out = oat_trial(generator_for_run(3, 0, 6), config)  # run 0: glare
    name, jitter, _ = READINGS_SCENES[OAT_SCENES[i]]
    ref = readings_trial(generator_for_run(3, 0, 6), name,
                         {t: config.variants(i)["default"][1][t] for t in ("JPDA", "FJPDA")},
                         jitter)
    def same(m):  # the association time per frame is a wall-clock measure
        return m._replace(assoc_ms=0.0)

    for t in ("JPDA", "FJPDA"):
        assert same(out[f"{t} default"]) == same(ref[t][0]), t
    assert same(out["JPDA rho"]) == same(out["JPDA default"]), "JPDA ignores rho weights"
    row = get(NAME).extract((i, out), config)
    assert row["scene"] == 0 and row["FJPDA mem1.false_tracks"] >= 0, sorted(row)[:5]


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
        got = stored.row(RUN)[k]
        assert got == v or (np.isnan(got) and np.isnan(v)), (k, got, v)
    assert np.array_equal(stored["scene"], np.arange(stored.runs) % 6), "scene cycle"


def test_verification_catches_a_corrupted_stored_row(stored, tmp_path):
    column = "FJPDA mem1.false_tracks"
    bad = corrupted_store(NAME, tmp_path, column, RUN)
    with pytest.raises(VerificationError, match=f"run {RUN}, column '{column}'"):
        verify_sample(bad, indices=[RUN])
