"""001-05's grids, fresh seeds, T9 sample and no-clutter anatomy: the stores' runs are
the runs the page computed live on its seed streams; configs; a corrupted row."""
import json
import shutil

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
from trackcore.experiments._core import META_KEY
from trackcore.experiments.tom_tuning import (
    GRID_SEED,
    T9_RUNS,
    StreamConfig,
    _on_stream,
    ref_key,
    tom_key,
)
from trackcore.montecarlo import run, stack_results
from trackcore.scenarios import (
    HOULES_TURNS,
    failure_anatomy,
    houles_imm_trial,
    window_mse,
)
from trackcore.scenarios._tom_book import anatomy_columns, grid_scores, grid_scores_mse
from trackcore.trackers import (
    ct_imm_model_set,
    markov_matrix,
    singer_imm_model_set,
    tom_imm_model_set,
)


def test_registered_at_the_book_sizes():
    for name, seed, runs in (("tom-tuning-grid", GRID_SEED, 200),
                             ("tom-tuning-fresh", GRID_SEED, 1000),
                             ("tom-tuning-t9", GRID_SEED, T9_RUNS),
                             ("tom-cause-no-clutter", 20261123, 1000)):
        e = get(name)
        assert (e.seed, e.runs, e.version) == (seed, runs, "1"), e
    assert T9_RUNS == 5000, "the declared T9 run count"
    cfg = get("tom-tuning-grid").config
    assert len(set(cfg.filters)) == len(cfg.filters), "every grid point once"
    assert (cfg.stream, cfg.pg) == (0, 0.9999), cfg


def test_stream_rows_equal_the_pages_live_runs():
    """Run i on stream s = run i of ``run(..., SeedSequence(GRID_SEED).spawn(3)[s])``."""
    grid_seq, fresh_seq, _ = np.random.SeedSequence(GRID_SEED).spawn(3)
    sets = [singer_imm_model_set(),
            tom_imm_model_set(u=50.0, sigma_s_turn=20.0, sigma_s_centre=0.0,
                              transition=markov_matrix(3, 0.9)),
            ct_imm_model_set([0.0, HOULES_TURNS[0][2], HOULES_TURNS[1][2]], [0.5, 2.0, 2.0],
                             transition=markov_matrix(3, 0.95))]
    keys = ("singer", tom_key(50, 20, 0, 0.9), ref_key(0.5, 2, 0.95))
    for stream, seq in ((0, grid_seq), (1, fresh_seq)):
        direct = stack_results(run(houles_imm_trial, 2, seq, args=(sets,),
                                   kwargs={"pg": 0.9999})).pos_err2
        res = run_experiment("tom-tuning-fresh", runs=2, write=False, progress=False,
                             overrides={"filters": keys, "stream": stream})
        assert np.array_equal(res["window_mse"], window_mse(direct)), stream
        assert np.array_equal(res["max_err2"], direct.max(axis=-1)), stream


def test_no_clutter_anatomy_equals_the_pages_computation():
    sets = [singer_imm_model_set(), tom_imm_model_set()]
    d = stack_results(run(houles_imm_trial, 2, 20261123, args=(sets,),
                          kwargs={"clutter_density": 0.0}))
    res = run_experiment("tom-cause-no-clutter", runs=2, write=False, progress=False,
                         overrides={"filters": ("singer", "tom")})
    an = failure_anatomy(d.pos_err2)
    assert np.array_equal(res["onset"], an.onset, equal_nan=True), "onset"
    assert np.array_equal(res["last_err2"] > 200.0**2, an.permanent), "permanent"
    assert np.array_equal(res["max_err2"], d.pos_err2.max(axis=-1)), "largest error"


def test_anatomy_columns_and_grid_scores_from_rows():
    e = np.full((3, 2, 90), 100.0)
    e[0, 1, 30:] = 250.0**2  # fails at t = 31 s and stays lost
    e[1, 0, 10] = 300.0**2  # fails at t = 11 s and recovers
    g = np.ones((3, 2, 89), dtype=np.int8)
    g[0, 1, 27:] = 0  # outside every gate from t = 29 s
    cols = anatomy_columns(e, g)
    assert cols["onset"][0, 1] == 31.0 and np.isnan(cols["onset"][2, 0]), cols["onset"]
    assert cols["first_miss"][0, 1] == 29.0 and np.isinf(cols["first_miss"][1, 0]), "miss"
    assert cols["last_err2"][0, 1] == 250.0**2, "the last squared error"
    assert cols["max_err2"][1, 0] == 300.0**2, "the largest squared error"
    rng = np.random.default_rng(1)
    E = rng.gamma(2.0, 400.0, size=(50, 4, 90))
    E[3, 2, 40] = 500.0**2
    sc, fl = grid_scores(E[:, 1:], E[:, 0])
    sc2, fl2 = grid_scores_mse(window_mse(E[:, 1:]), E[:, 1:].max(axis=-1) > 200.0**2,
                               window_mse(E[:, 0]), E[:, 0].max(axis=-1) > 200.0**2)
    assert np.array_equal(sc, sc2) and np.array_equal(fl, fl2), "bit for bit"
    with pytest.raises(ValueError, match="must match"):
        anatomy_columns(e, g[..., :-1])
    with pytest.raises(ValueError, match="M_points must be"):
        grid_scores_mse(window_mse(E[:, 1:]), np.zeros((50, 2), bool), window_mse(E[:, 0]),
                        np.zeros(50, bool))


@pytest.mark.parametrize("kwargs, match", [
    ({"stream": -2}, "stream must be an int >= -1"),
    ({"stream": True}, "stream must be an int >= -1"),
    ({"filters": ("tom:bogus=1",)}, "unknown filter key"),
    ({"pg": 0.0}, "pg must be in"),
])
def test_bad_stream_configs_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        StreamConfig(**kwargs)


def test_a_stream_run_needs_the_stores_generator():
    with pytest.raises(ValueError, match="needs the store's generator"):
        _on_stream(np.random.default_rng(np.random.SeedSequence(1, spawn_key=(0, 3))), 0,
                   [singer_imm_model_set()])


def test_a_corrupted_stored_row_is_caught(tmp_path):
    name = "tom-tuning-fresh"
    path = get(name).default_path()
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    table = pq.read_table(path)
    size = int(np.prod(json.loads(table.schema.metadata[META_KEY])["columns"]["max_err2"][0]))
    values = table.column("max_err2").combine_chunks().flatten().to_numpy(
        zero_copy_only=False).copy()
    values[5 * size + 2] *= 1 + 1e-3
    i = table.schema.get_field_index("max_err2")
    new = pa.FixedSizeListArray.from_arrays(pa.array(values), size)
    pq.write_table(table.set_column(i, table.schema.field(i), new), bad)
    with pytest.raises(VerificationError, match=r"run 5, column 'max_err2'\[2\]"):
        verify_sample(load(name, path=bad), indices=[4, 5])
