"""001-03's post-turn stores: the rows equal the direct runs and the stores they repeat."""
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from trackcore.experiments import (
    VerificationError,
    get,
    load,
    run_experiment,
    verify_sample,
)
from trackcore.experiments.tom_cause import _tom_variant
from trackcore.experiments.tom_pg1 import TUNED, TomGatesConfig, _post_mask
from trackcore.montecarlo import run, stack_results
from trackcore.scenarios import HOULES_TIMES, houles_imm_trial
from trackcore.trackers import (
    car_imm_model_set,
    singer_imm_model_set,
    tom_imm_model_set,
)

SEED = 20261123


def _sets():
    return [singer_imm_model_set(), car_imm_model_set(sigma_cv=5.0), tom_imm_model_set(),
            _tom_variant(TUNED)]


def test_the_post_turn_window():
    t = HOULES_TIMES[_post_mask()]
    assert t.tolist() == [36, 37, 38, 39, 40, 71, 72, 73, 74, 75], f"window {t}"


def test_gated_rows_equal_the_direct_runs():
    res = run_experiment("tom-imm-houles-postturn", runs=2, write=False, progress=False)
    for g, pg in enumerate((0.99, 0.999, 0.9999)):
        d = stack_results(run(houles_imm_trial, 2, SEED, args=(_sets(),),
                              kwargs={"pg": pg}))
        e = d.pos_err2
        assert np.array_equal(res["post_mse"][:, g], e[..., _post_mask()].mean(axis=-1)), pg
        assert np.array_equal(res["max_err2"][:, g], e.max(axis=-1)), pg


def test_rows_without_a_gate_equal_the_direct_runs():
    res = run_experiment("tom-imm-houles-pg1-postturn", runs=2, write=False,
                         progress=False)
    d = stack_results(run(houles_imm_trial, 2, SEED, args=(_sets(),),
                          kwargs={"pg": 1.0, "outer_window": 6000.0}))
    assert np.array_equal(res["post_mse"], d.pos_err2[..., _post_mask()].mean(axis=-1))
    assert np.array_equal(res["max_err2"], d.pos_err2.max(axis=-1)), "largest error"


def test_the_stores_repeat_the_runs_of_the_other_stores():
    pt, g = load("tom-imm-houles-postturn"), load("tom-imm-houles-gates")
    assert np.array_equal(pt["max_err2"][:, 1:, :3], g["max_err2"]), "P_G 0.999, 0.9999"
    p1, p0 = load("tom-imm-houles-pg1-postturn"), load("tom-imm-houles-pg1")
    assert np.array_equal(p1["max_err2"], p0["max_err2"]), "without a gate"


def test_the_stores_verify_and_a_bad_config_raises():
    for name, runs in (("tom-imm-houles-postturn", 1000),
                       ("tom-imm-houles-pg1-postturn", 3000)):
        e = get(name)
        assert (e.seed, e.runs, e.version) == (SEED, runs, "1"), e
        assert verify_sample(load(name), indices=[0, runs - 1]).checked == 2, name
    with pytest.raises(ValueError, match="every gate probability"):
        TomGatesConfig(filters=("singer", "tom"), gates=(0.0,))


def test_a_corrupted_row_is_caught(tmp_path):
    name, path = "tom-imm-houles-pg1-postturn", tmp_path / "x.parquet"
    run_experiment(name, runs=3, out=path, progress=False)
    table = pq.read_table(path)
    i = table.schema.get_field_index("post_mse")
    values = np.stack(table.column("post_mse").to_pylist())
    values[1, 2] *= 1 + 1e-3  # above the store's relative tolerance (1e-6)
    col = pa.FixedSizeListArray.from_arrays(pa.array(values.ravel()), values.shape[1])
    bad = tmp_path / "bad.parquet"
    pq.write_table(table.set_column(i, table.schema.field(i), col), bad)
    with pytest.raises(VerificationError, match=r"run 1, column 'post_mse'"):
        verify_sample(load(name, runs=3, path=bad), fraction=1.0)
