"""trackcore.experiments: registry, Parquet store, staleness, sampled verification, CLI."""
import json
import shutil
import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from trackcore import montecarlo
from trackcore.experiments import (
    FLOAT_RTOL,
    HoulesConfig,
    HoulesSweepConfig,
    HpdaMonteCarloConfig,
    MissingResultsError,
    StaleResultsError,
    VerificationError,
    compare_rows,
    config_hash,
    get,
    load,
    names,
    obtain,
    run_experiment,
    sample_size,
    verify_sample,
)
from trackcore.experiments._core import META_KEY
from trackcore.scenarios import houles_imm_trial

NAME = "tom-imm-houles"  # the cheapest registered experiment (~10 ms per run)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("store") / "t.parquet"
    res = run_experiment(NAME, runs=6, out=path, progress=False)
    return path, res


def test_registry_lists_the_book_experiments():
    assert {"hpda-mc-case1", "hpda-mc-case2", "hpda-mc-case3", NAME} <= set(names())
    e = get("hpda-mc-case3")
    assert e.runs == 100 and e.seed == 20070831, e
    with pytest.raises(ValueError, match="unknown experiment 'nope'"):
        get("nope")


def test_config_records_validate_and_parse_overrides():
    c = get("hpda-mc-case1").config
    assert c.with_overrides({"snr": "3.5"}).snr == 3.5
    assert c.with_overrides({"algorithms": "hpda,phd"}).algorithms == ("hpda", "phd")
    with pytest.raises(ValueError, match="unknown config field"):
        c.with_overrides({"bogus": 1})
    with pytest.raises(ValueError, match="case must be 1, 2 or 3"):
        HpdaMonteCarloConfig(4, ("hpda",))
    with pytest.raises(ValueError, match="unknown algorithm"):
        HpdaMonteCarloConfig(1, ("kalman",))
    with pytest.raises(ValueError, match="pd"):
        c.with_overrides({"pd": "1.5"})
    with pytest.raises(ValueError, match="pg must be in"):
        HoulesConfig(pg=1.0)
    assert config_hash(HoulesConfig()) == config_hash(HoulesConfig())
    assert config_hash(HoulesConfig()) != config_hash(HoulesConfig(pg=0.999))


def test_rows_equal_the_notebook_computation(store):
    """The stored rows are what montecarlo.run of the trial gives (the notebooks' call)."""
    _, res = store
    from trackcore.experiments.registry import _houles_model_sets

    direct = montecarlo.stack_results(montecarlo.run(
        houles_imm_trial, 6, get(NAME).seed, args=(list(_houles_model_sets(5.0)),)))
    assert np.array_equal(res["pos_err2"], direct.pos_err2), "pos_err2 differs"
    assert np.array_equal(res["target_gated"], direct.target_gated), "gating differs"
    assert res["target_gated"].dtype == np.int8


def test_houles_sweep_rows_equal_separate_runs():
    """A sweep row holds, per gate, what separate montecarlo.run calls at that gate give."""
    from trackcore.experiments.registry import _houles_model_set
    from trackcore.scenarios.houles import window_mse

    name = "tom-imm-houles-gates"
    e = get(name)
    res = run_experiment(name, runs=3, write=False, progress=False)
    sets = [_houles_model_set(s) for s in e.config.filters]
    for g, pg in enumerate(e.config.gates):
        d = montecarlo.stack_results(montecarlo.run(houles_imm_trial, 3, e.seed, args=(sets,),
                                                    kwargs={"pg": pg}))
        assert res["window_mse"][:, g].tobytes() == window_mse(d.pos_err2).tobytes(), pg
        assert np.array_equal(res["max_err2"][:, g], d.pos_err2.max(axis=-1)), pg
        assert np.array_equal(res["last_err2"][:, g], d.pos_err2[..., -1]), pg
        assert np.array_equal(res["target_gated"][:, g], d.target_gated), pg
    c = HoulesSweepConfig(("tom",))
    assert c.with_overrides({"gates": "0.9,0.99"}).gates == (0.9, 0.99)
    with pytest.raises(ValueError, match="unknown filter key"):
        HoulesSweepConfig(("kalman",))
    with pytest.raises(ValueError, match="parameters must be numbers"):
        HoulesSweepConfig(("car:x",))
    with pytest.raises(ValueError, match="gate probability"):
        HoulesSweepConfig(("tom",), gates=(1.0,))
    with pytest.raises(ValueError, match="must not repeat"):
        HoulesSweepConfig(("tom",), gates=(0.9, 0.9))


def test_store_metadata_and_prefix_property(store):
    path, res = store
    m = res.meta
    assert m["runs"] == 6 and m["seed"] == get(NAME).seed and m["version"] == "1", m
    assert m["config_hash"] == config_hash(HoulesConfig()), m
    assert "trackcore" in m["code_version"] and m["wall_seconds"] >= 0 and "cpu_seconds" in m
    first = load(NAME, runs=3, path=path)  # the first 3 of 6 stored runs
    fresh = run_experiment(NAME, runs=3, write=False, progress=False)
    assert np.array_equal(first["pos_err2"], fresh["pos_err2"]), "prefix rows differ"


def test_bit_identical_serial_processes_localcluster(store):
    _, serial = store
    with montecarlo.process_pool(2) as pool:
        procs = run_experiment(NAME, runs=6, executor=pool, write=False, progress=False)
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        dask = run_experiment(NAME, runs=6, executor=client.get_executor(), write=False,
                              progress=False)
    for other, what in ((procs, "process pool"), (dask, "LocalCluster")):
        for col in ("pos_err2", "target_gated"):
            assert np.array_equal(serial[col], other[col]), f"{what}: {col} differs"
            assert serial[col].tobytes() == other[col].tobytes(), f"{what}: {col} bits differ"


def test_missing_and_stale_stores_name_the_command(store, tmp_path):
    path, _ = store
    with pytest.raises(MissingResultsError) as exc:
        load(NAME, path=tmp_path / "none.parquet")
    assert "python -m trackcore.experiments run tom-imm-houles" in str(exc.value)
    with pytest.raises(StaleResultsError) as exc:  # another config than the stored one
        load(NAME, runs=6, path=path, overrides={"pg": 0.999})
    msg = str(exc.value)
    assert "is not the requested" in msg, msg
    assert f"python -m trackcore.experiments run {NAME} --runs 6 --set pg=0.999 --out {path}" \
        in msg, msg
    with pytest.raises(StaleResultsError, match="holds 6 runs, 7 are requested"):
        load(NAME, runs=7, path=path)
    with pytest.raises(StaleResultsError, match="its seed is"):
        load(NAME, runs=6, seed=1, path=path)
    # a store whose experiment version is not the code's
    table = pq.read_table(path)
    meta = json.loads(table.schema.metadata[META_KEY])
    meta["version"] = "0"
    old = tmp_path / "old.parquet"
    pq.write_table(table.replace_schema_metadata({META_KEY: json.dumps(meta).encode()}), old)
    with pytest.raises(StaleResultsError, match="version '0' of the experiment") as exc:
        load(NAME, runs=6, path=old)
    assert f"--out {old}" in str(exc.value)


def _corrupt(path, out, run, column, element, factor):
    table = pq.read_table(path)
    col = table.column(column).combine_chunks()
    shape = json.loads(table.schema.metadata[META_KEY])["columns"][column][0]
    values = col.flatten().to_numpy(zero_copy_only=False).copy()
    size = int(np.prod(shape))
    values[run * size + element] = values[run * size + element] * factor
    new = pa.FixedSizeListArray.from_arrays(pa.array(values), size)
    i = table.schema.get_field_index(column)
    pq.write_table(table.set_column(i, table.schema.field(i), new), out)


def test_verification_catches_a_corrupted_row(store, tmp_path):
    path, _ = store
    v = verify_sample(load(NAME, runs=6, path=path), fraction=1.0)
    assert str(v) == f"{NAME}: re-simulated 6 of 6 stored runs (a fresh random sample): " \
                     "all match", str(v)
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    _corrupt(path, bad, run=4, column="pos_err2", element=2 * 90 + 17, factor=1 + 1e-4)
    res = load(NAME, runs=6, path=bad)
    with pytest.raises(VerificationError) as exc:
        verify_sample(res, fraction=1.0)  # every row: deterministic
    msg = str(exc.value)
    assert msg.startswith("run 4, column 'pos_err2'[2, 17]: stored "), msg
    assert "recomputed" in msg and "relative tolerance 1e-06" in msg, msg
    # a difference inside the tolerance passes; an integer must match exactly
    row = res.row(0)
    close = dict(row, pos_err2=row["pos_err2"] * (1 + FLOAT_RTOL / 10))
    compare_rows(row, close, 0)
    flipped = dict(row, target_gated=row["target_gated"].copy())
    flipped["target_gated"][0, 0] = 1 - flipped["target_gated"][0, 0]
    with pytest.raises(VerificationError, match="must be equal"):
        compare_rows(row, flipped, 0)


def test_sample_size_and_fresh_samples(store):
    assert sample_size(100) == 20 and sample_size(5000) == 50 and sample_size(10) == 10
    assert sample_size(1500) == 20 and sample_size(2500) == 25
    assert sample_size(1500, minimum=10) == 15 and sample_size(100, minimum=10) == 10
    assert sample_size(1000, fraction=1.0) == 1000
    with pytest.raises(ValueError, match="fraction"):
        sample_size(10, fraction=0.0)
    path, _ = store
    res = load(NAME, runs=6, path=path)
    draws = {verify_sample(res, minimum=3).indices for _ in range(8)}
    assert len(draws) > 1, "the sample must change between calls"


def test_obtain_non_book_config_computes_live_with_a_note(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("TRACKCORE_RESULTS", str(tmp_path))
    res = obtain(NAME, runs=3, overrides={"pg": 0.999})
    out = capsys.readouterr().out
    assert "the book's stored results were not used" in out, out
    assert not res.from_store and res.runs == 3
    with pytest.raises(MissingResultsError, match="run tom-imm-houles"):
        obtain(NAME, runs=3)  # the book's config must come from its store


def test_obtain_more_runs_than_stored_verifies_only_the_stored_ones(capsys):
    stored = get(NAME).runs
    res = obtain(NAME, runs=stored + 2)
    out = capsys.readouterr().out
    assert f"runs {stored} to {stored + 1} are computed now" in out, out
    assert res.runs == stored + 2 and res.meta["stored_runs"] == stored, res.meta
    v = verify_sample(res, minimum=3, fraction=0.001)
    assert max(v.indices) < stored, v.indices
    assert str(v) == (f"{NAME}: re-simulated 3 of {stored} stored runs (a fresh random "
                      "sample): all match; 2 more runs were computed now, not read from "
                      "the store"), str(v)


def test_cli_list_run_verify(tmp_path):
    env_out = tmp_path / "cli.parquet"
    cmd = [sys.executable, "-m", "trackcore.experiments"]
    r = subprocess.run(cmd + ["list"], capture_output=True, text=True, check=True)
    assert "hpda-mc-case1" in r.stdout and "store" in r.stdout, r.stdout
    r = subprocess.run(cmd + ["run", NAME, "--runs", "3", "--set", "pg=0.999", "--out",
                              str(env_out), "--no-progress"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run(cmd + ["verify", NAME, "--path", str(env_out), "--set", "pg=0.999",
                              "--fraction", "1.0", "--no-progress"],
                       capture_output=True, text=True)
    assert r.returncode == 0 and "re-simulated 3 of 3" in r.stdout, r.stdout + r.stderr
    r = subprocess.run(cmd + ["run", NAME, "--set", "nope=1", "--runs", "2", "--out",
                              str(tmp_path / "x.parquet")], capture_output=True, text=True)
    assert r.returncode == 2 and "unknown config field" in r.stderr, r.stderr


def test_book_store_is_current_and_its_metadata_complete():
    """The committed store of the ported notebook: current, 100 runs per case."""
    from trackcore.experiments import read_metadata, status

    for c in (1, 2, 3):
        name = f"hpda-mc-case{c}"
        assert status(name) == "current", f"{name}: {status(name)}"
        m = read_metadata(get(name).default_path())
        assert m["runs"] == 100 and m["seed"] == 20070828 + c, m
        assert {"code_version", "wall_seconds", "cpu_seconds", "executor", "config"} <= set(m)


def test_exec_stats_page_reads_verified_runs_from_outputs():
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    spec = importlib.util.spec_from_file_location("exec_stats",
                                                  root / "book" / "_ext" / "exec_stats.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.runs_verified(root / "book" / "000-hpda" / "06-monte-carlo.ipynb") == (80, 1300)
    assert mod.runs_verified(root / "book" / "000-hpda" / "01-model.ipynb") is None


def test_progress_bar_is_plain_text_and_sanitised_to_one_line(monkeypatch):
    """The bar of compute_rows/verify_sample(progress=True) is tqdm's plain bar on stderr
    (no ipywidgets needed in a notebook); the test suite's nbval sanitizer maps its times
    to one text, so a notebook cell may show it and stay strictly checked."""
    import configparser
    import io
    import re
    import time as _time
    from pathlib import Path

    from trackcore.experiments._core import _progress_bar

    cfg = configparser.ConfigParser()
    cfg.read(Path(__file__).parent / "nbval_sanitize.cfg")
    rx = cfg["progress bar times"]["regex"]
    finals = set()
    for pause in (0.0, 0.06):
        buf = io.StringIO()
        monkeypatch.setattr(sys, "stderr", buf)
        bar = _progress_bar(20, "toy", True)
        for _ in range(20):
            bar.update(1)
            _time.sleep(pause)
        bar.close()
        finals.add(re.sub(rx, "[time]", buf.getvalue().split("\r")[-1]))
    assert finals == {"toy: 100%|" + "█" * 20 + "| 20/20 [time]\n"} or \
        finals == {"toy: 100%|" + "#" * 20 + "| 20/20 [time]\n"}, finals
