"""The experiments of 001-05 (why the claim fails): rows, configs, verification."""
import json
import shutil

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from trackcore.experiments import VerificationError, get, load, run_experiment, verify_sample
from trackcore.experiments._core import META_KEY
from trackcore.experiments.tom_cause import StraightLegConfig, TomVariantsConfig
from trackcore.montecarlo import run, stack_results
from trackcore.scenarios import HOULES_TIMES, houles_imm_trial, window_mse
from trackcore.trackers import (
    cv_model_set,
    markov_matrix,
    tom_imm_model_set,
    tom_model_set,
)

SEED = 20261123


def test_registered_at_the_book_sizes():
    for name, runs in (("tom-cause-straight-leg", 1000), ("tom-cause-readings", 1000),
                       ("tom-cause-one-at-a-time", 300)):
        e = get(name)
        assert (e.seed, e.runs, e.version) == (SEED, runs, "1"), e


def test_variant_rows_equal_the_notebooks_runs():
    """Readings and one-at-a-time rows = the notebook's direct computation."""
    sets = [tom_imm_model_set(heading="chord_literal"), tom_imm_model_set(heading="velocity"),
            tom_imm_model_set(reset_vs_variance=True), tom_imm_model_set(rotate_covariance=True),
            tom_imm_model_set(u=50.0), tom_imm_model_set(transition=markov_matrix(3, 0.8))]
    direct = stack_results(run(houles_imm_trial, 2, SEED, args=(sets,))).pos_err2
    over = {"filters": ("tom:heading=chord_literal", "tom:heading=velocity",
                        "tom:reset_vs_variance=1", "tom:rotate_covariance=1", "tom:u=50.0",
                        "tom:p_stay=0.8")}
    res = run_experiment("tom-cause-readings", runs=2, overrides=over, write=False,
                         progress=False)
    assert np.array_equal(res["window_mse"], window_mse(direct)), "window mean squares"
    assert np.array_equal(res["max_err2"], direct.max(axis=-1)), "largest squared error"
    keys = get("tom-cause-one-at-a-time").config.filters
    assert len(keys) == 19 and keys[0] == "tom:u=50.0" and keys[-1] == "tom:p_stay=0.98", keys


def test_straight_leg_rows_equal_the_notebooks_runs():
    one = [cv_model_set(sigma=1.0), tom_model_set([0.0], [1.0], sigma_f=1.0),
           tom_model_set([0.0], [3.0], sigma_f=1.0)]
    d = stack_results(run(houles_imm_trial, 2, SEED, args=(one,),
                          kwargs={"clutter_density": 0.0, "pg": 1.0}))
    res = run_experiment("tom-cause-straight-leg", runs=2, write=False, progress=False)
    leg = (HOULES_TIMES >= 5) & (HOULES_TIMES <= 19)
    leg2 = leg[1:]
    assert np.array_equal(res["leg_mse"], d.pos_err2[:, :, leg].mean(axis=2)), "leg MSE"
    assert np.array_equal(res["leg_lat2"], (d.pred_err[:, :, leg2, 1] ** 2).mean(axis=2))
    assert np.array_equal(res["leg_along2"], (d.pred_err[:, :, leg2, 0] ** 2).mean(axis=2))
    assert np.array_equal(res["leg_nees_vel"], d.nees_vel[:, :, leg2].mean(axis=2))
    assert np.array_equal(res["pred_err"], d.pred_err[:, :, HOULES_TIMES[1:] <= 19]), "fig"


@pytest.mark.parametrize("kwargs, match", [
    ({"filters": ("tom:bogus=1",)}, "unknown filter key"),
    ({"filters": ("singer",)}, "unknown filter key"),
    ({"filters": ("tom:u=fast",)}, "u must be a number"),
    ({"filters": ("tom:rotate_covariance=yes",)}, "must be 0 or 1"),
    ({"filters": ("tom",), "pg": 1.5}, "pg must be in"),
    ({"filters": ("tom",), "pd": 0.0}, "pd must be in"),
    ({"filters": ("tom",), "clutter_density": -1.0}, "clutter_density must be >= 0"),
])
def test_bad_variant_configs_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        TomVariantsConfig(**kwargs)


def test_bad_straight_leg_configs_and_overrides_raise():
    with pytest.raises(TypeError, match="filters must be a non-empty tuple"):
        TomVariantsConfig(())
    with pytest.raises(ValueError, match="t0 <= t1"):
        StraightLegConfig(t0=30.0, t1=10.0)
    with pytest.raises(ValueError, match="every noise must be finite and >= 0"):
        StraightLegConfig(tom_sigma_s=(-1.0,))
    with pytest.raises(ValueError, match="pg must be a number"):
        get("tom-cause-readings").configure({"pg": "wide"})
    with pytest.raises(ValueError, match="unknown config field"):
        get("tom-cause-straight-leg").configure({"clutter_density": 0.0})


def test_a_corrupted_stored_row_is_caught(tmp_path):
    name = "tom-cause-readings"
    path = get(name).default_path()
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    table = pq.read_table(path)
    col = table.column("max_err2").combine_chunks()
    size = int(np.prod(json.loads(table.schema.metadata[META_KEY])["columns"]["max_err2"][0]))
    values = col.flatten().to_numpy(zero_copy_only=False).copy()
    values[7 * size + 1] *= 1 + 1e-3  # above the store's relative tolerance (1e-6)
    i = table.schema.get_field_index("max_err2")
    new = pa.FixedSizeListArray.from_arrays(pa.array(values), size)
    pq.write_table(table.set_column(i, table.schema.field(i), new), bad)
    good = verify_sample(load(name), indices=[7])  # the book's stored row is right
    assert good.checked == 1, good
    with pytest.raises(VerificationError, match=r"run 7, column 'max_err2'\[1\]"):
        verify_sample(load(name, path=bad), indices=[6, 7])
