"""trackcore.experiments.tbd_tracking: the TBD chapter's tracking experiments (04-tracking)."""
import json
import shutil

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from trackcore import montecarlo
from trackcore.experiments import (
    VerificationError,
    get,
    load,
    names,
    run_experiment,
    status,
    verify_sample,
)
from trackcore.experiments._core import META_KEY
from trackcore.experiments.tbd_tracking import TbdCalibrationConfig, TbdTrackingConfig
from trackcore.scenarios import (
    TbdRadarParameters,
    simulate_tbd_radar,
    tbd_paired_trial,
    tbd_radar_truth,
)
from trackcore.trackers import TbdTrackerConfig, pseudo_measurement_errors

SEED = 20160307  # the notebook's
KINDS = ("calibration", "main", "literal", "sweep")


def test_the_chapter_experiments_are_registered():
    want = {f"tbd-tracking-{k}-{r}" for k in KINDS for r in ("25", "10")}
    assert want <= set(names()), sorted(want - set(names()))
    assert get("tbd-tracking-main-25").runs == 1000 and get("tbd-tracking-main-10").runs == 500
    for r in ("25", "10"):
        assert get(f"tbd-tracking-calibration-{r}").seed == SEED + 10
        for k in ("main", "literal", "sweep"):
            assert get(f"tbd-tracking-{k}-{r}").seed == SEED
            assert get(f"tbd-tracking-{k}-{r}").version == "1"


def test_literal_rows_equal_the_notebook_computation():
    """Runs 0..2 of the literal A: what montecarlo.run of tbd_paired_trial gives."""
    prm, truth = TbdRadarParameters(processing_radius=1000.0), tbd_radar_truth()
    lit = {"A1": TbdTrackerConfig(method="A", processing_radius=1000.0,
                                  pseudo_covariance="sensor")}
    direct = montecarlo.run(tbd_paired_trial, 3, SEED, args=(lit, prm, truth))
    res = run_experiment("tbd-tracking-literal-10", runs=3, write=False, progress=False)
    assert np.array_equal(res["err.A1"], np.array([r.errors["A1"] for r in direct]))
    assert np.array_equal(res["nees.A1"], np.array([r.nees["A1"][:100] for r in direct]))
    assert np.array_equal(res["x0"], np.array([r.x0 for r in direct])), "x0 differs"
    assert sorted(res.columns) == ["err.A1", "nees.A1", "run", "x0"], sorted(res.columns)


def test_calibration_rows_equal_the_notebook_computation():
    """The per-run sums the notebook pooled, bit for bit (its own array expressions)."""
    truth = tbd_radar_truth()

    def calibration_trial(rng, R):  # the notebook's trial before the port
        scans = simulate_tbd_radar(truth, TbdRadarParameters(processing_radius=R), rng)
        cfg = TbdTrackerConfig(method="A", processing_radius=R)
        return pseudo_measurement_errors(scans, truth.states, cfg)

    runs = montecarlo.run(calibration_trial, 4, SEED + 10, args=(2500.0,))
    dp = np.array([r[0][:100] for r in runs])
    dv = np.array([r[1][:100] for r in runs])
    res = run_experiment("tbd-tracking-calibration-25", runs=4, write=False, progress=False)
    assert np.array_equal(res["ms_p"], np.nanmean(dp**2, axis=(1, 2))), "ms_p differs"
    assert np.array_equal(res["ms_v"], np.nanmean(dv**2, axis=1)), "ms_v differs"
    assert np.array_equal(res["n_valid"], np.sum(np.isfinite(dv), axis=1))
    far = np.linalg.norm(dp, axis=2) > 500.0
    assert res["n_far"].sum() / dp[..., 0].size == np.nanmean(far), "far fraction differs"


def test_bad_configs_raise_clear_errors():
    c = get("tbd-tracking-main-25").config
    assert c.with_overrides({"trackers": "A,C200"}).trackers == ("A", "C200")
    assert c.with_overrides({"snr0_db": "4"}).snr0_db == 4.0
    with pytest.raises(ValueError, match="unknown tracker key 'Z'"):
        TbdTrackingConfig(("A", "Z"))
    with pytest.raises(ValueError, match="must not repeat"):
        TbdTrackingConfig(("A", "A"))
    with pytest.raises(TypeError, match="trackers must be a non-empty tuple"):
        TbdTrackingConfig(())
    with pytest.raises(ValueError, match="pseudo_sigma"):  # A is calibrated at 1, 2.5 km
        c.with_overrides({"processing_radius": "1500"})
    with pytest.raises(ValueError, match="nees_scans"):
        TbdTrackingConfig(("A",), nees_scans=300)
    with pytest.raises(ValueError, match="clutter_density must be >= 0"):
        TbdCalibrationConfig(clutter_density=-1.0)
    with pytest.raises(ValueError, match="window"):
        TbdCalibrationConfig(window=0)
    with pytest.raises(ValueError, match="unknown config field"):
        c.with_overrides({"pd": 0.9})
    with pytest.raises(ValueError, match="must be a number"):
        c.with_overrides({"snr0_db": "loud"})


def test_book_stores_are_current():
    for k in KINDS:
        for r in ("25", "10"):
            name = f"tbd-tracking-{k}-{r}"
            assert status(name) == "current", f"{name}: {status(name)}"


def _corrupt(path, out, run, column, element, factor):
    table = pq.read_table(path)
    col = table.column(column).combine_chunks()
    shape = json.loads(table.schema.metadata[META_KEY])["columns"][column][0]
    values = col.flatten().to_numpy(zero_copy_only=False).copy()
    size = int(np.prod(shape))
    values[run * size + element] *= factor
    new = pa.FixedSizeListArray.from_arrays(pa.array(values), size)
    i = table.schema.get_field_index(column)
    pq.write_table(table.set_column(i, table.schema.field(i), new), out)


def test_a_corrupted_stored_row_is_caught(tmp_path):
    name = "tbd-tracking-literal-25"
    path = get(name).default_path()
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    _corrupt(path, bad, run=7, column="err.A1", element=120, factor=1 + 1e-3)
    good = load(name)
    verify_sample(good, indices=[7])  # the stored row itself matches
    res = load(name, path=bad)
    with pytest.raises(VerificationError) as exc:
        verify_sample(res, indices=[3, 7])
    msg = str(exc.value)
    assert msg.startswith("run 7, column 'err.A1'[120]: stored "), msg
