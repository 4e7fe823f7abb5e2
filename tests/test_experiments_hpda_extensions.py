"""trackcore.experiments.hpda_extensions: the HPDA chapter's extensions (07) as experiments."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from trackcore import montecarlo
from trackcore.experiments import (
    HpdaMonteCarloConfig,
    VerificationError,
    get,
    load,
    run_experiment,
    verify_sample,
)
from trackcore.experiments._core import META_KEY
from trackcore.experiments.hpda_extensions import (
    LADDER_READINGS,
    HpdaLadderConfig,
    HpdaPriorSweepConfig,
)
from trackcore.scenarios import run_hpda_trial

SEED = 20070828  # the notebook's SEED; case c runs with SEED + c


def _direct(n, case, algorithms, **kwargs):
    """The notebook's own call: montecarlo.run of run_hpda_trial."""
    return montecarlo.run(run_hpda_trial, n, SEED + case, args=(case, algorithms),
                          kwargs=kwargs)


def test_the_experiments_are_registered_with_the_notebook_seeds_and_runs():
    want = {"hpda-ext-prior-case1": SEED + 1, "hpda-ext-prior-case2": SEED + 2,
            "hpda-ext-ladder-case1": SEED + 1, "hpda-ext-ladder-case2": SEED + 2,
            "hpda-ext-factor-pd": SEED + 1, "hpda-ext-factor-clutter": SEED + 1,
            "hpda-ext-snr-linear": SEED + 2, "hpda-ext-snr-db": SEED + 2}
    for name, seed in want.items():  # 100 runs each, at least MIN_RUNS for an interval
        e = get(name)
        assert (e.runs, e.seed, e.version) == (100, seed, "2"), (name, e.runs, e.seed)
        assert e.notebook == "book/000-hpda/07-extensions.ipynb", e.notebook
    assert get("hpda-ext-factor-pd").config == HpdaMonteCarloConfig(
        1, ("hpda", "phd", "clustering"), pd=0.6)
    assert get("hpda-ext-snr-db").config == HpdaMonteCarloConfig(2, ("hpda",),
                                                                 snr=10**0.5)
    assert get("hpda-ext-prior-case2").config.priors == (0.98, 0.99, 0.995)
    assert get("hpda-ext-ladder-case1").config.readings == tuple(LADDER_READINGS)


def test_prior_sweep_rows_equal_the_notebook_runs():
    """Each prior's counts are the notebook's montecarlo.run at that prior."""
    res = run_experiment("hpda-ext-prior-case2", runs=1, overrides={"priors": "0.98"},
                         write=False, progress=False)
    d = _direct(1, 2, ("hpda", "phd"),
                overrides={"hpda": {"pi11": 0.98}, "phd": {"p_survival": 0.98}})
    for a in ("hpda", "phd"):
        col = res[f"{a}.count"]
        assert col.dtype == np.int16 and col.shape == (1, 1, 451), (a, col.shape)
        direct = np.array([r[a]["count"] for r in d], dtype=float)
        assert np.array_equal(col[:, 0].astype(float), direct), f"{a} counts differ"
    sum_w = res["phd.sum_w"]  # SMC-PHD's sum of weights, the sum reading of its count
    assert sum_w.dtype == np.float32 and sum_w.shape == (1, 1, 451), sum_w.shape
    direct = np.array([r["phd"]["aux"] for r in d], dtype=np.float32)
    assert np.array_equal(sum_w[:, 0], direct), "sums of weights differ"


def test_ladder_rows_equal_the_notebook_runs():
    keys = ("literal", "gated_support")  # the two ends of the ladder
    res = run_experiment("hpda-ext-ladder-case2", runs=2, write=False, progress=False,
                         overrides={"readings": ",".join(keys)})
    col = res["clustering_literal.count"]
    assert col.shape == (2, 2, 451), col.shape
    for j, ov in enumerate(LADDER_READINGS[k] for k in keys):
        d = _direct(2, 2, ("clustering_literal",), overrides={"clustering_literal": ov})
        direct = np.array([r["clustering_literal"]["count"] for r in d], dtype=float)
        assert np.array_equal(col[:, j].astype(float), direct), f"reading {j} differs"


def test_scenario_rows_equal_the_notebook_runs():
    res = run_experiment("hpda-ext-snr-db", runs=2, write=False, progress=False)
    d = _direct(2, 2, ("hpda",), scenario_overrides={"snr": 10**0.5})
    direct = np.array([r["hpda"]["count"] for r in d], dtype=float)
    assert np.array_equal(res["hpda.count"].astype(float), direct), "counts differ"
    assert set(res.columns) == {"run", "hpda.count"}, sorted(res.columns)


def test_bad_configs_raise_clear_errors():
    with pytest.raises(ValueError, match="every prior must be a number in"):
        HpdaPriorSweepConfig(1, priors=(0.99, 1.0))
    with pytest.raises(ValueError, match="priors must not repeat"):
        HpdaPriorSweepConfig(1, priors=(0.99, 0.99))
    with pytest.raises(ValueError, match="algorithms of HpdaPriorSweepConfig"):
        HpdaPriorSweepConfig(1, algorithms=("clustering",))
    with pytest.raises(ValueError, match="unknown reading 'bogus'"):
        get("hpda-ext-ladder-case1").configure({"readings": "literal,bogus"})
    with pytest.raises(ValueError, match="case must be 1, 2 or 3"):
        HpdaLadderConfig(5)
    with pytest.raises(ValueError, match="unknown config field"):
        get("hpda-ext-prior-case1").configure({"prior": "0.9"})
    c = get("hpda-ext-prior-case1").configure({"priors": "0.9,0.95", "pd": "0.8"})
    assert c.priors == (0.9, 0.95) and c.pd == 0.8, c


def test_verification_catches_a_corrupted_count(tmp_path):
    path = tmp_path / "ladder.parquet"
    run_experiment("hpda-ext-ladder-case2", runs=2, overrides={"readings": "literal"},
                   out=path, progress=False)
    ov = {"readings": "literal"}
    v = verify_sample(load("hpda-ext-ladder-case2", runs=2, overrides=ov, path=path),
                      fraction=1.0)
    assert v.checked == 2, v
    table = pq.read_table(path)
    name = "clustering_literal.count"
    shape = json.loads(table.schema.metadata[META_KEY])["columns"][name][0]
    values = table.column(name).combine_chunks().flatten().to_numpy().copy()
    size = int(np.prod(shape))
    values[size + 200] += 1  # run 1, scan 200
    i = table.schema.get_field_index(name)
    col = pa.FixedSizeListArray.from_arrays(pa.array(values), size)
    pq.write_table(table.set_column(i, table.schema.field(i), col), path)
    res = load("hpda-ext-ladder-case2", runs=2, overrides=ov, path=path)
    with pytest.raises(VerificationError, match=r"run 1, column 'clustering_literal.count'"
                                                r"\[0, 200\].*must be equal"):
        verify_sample(res, fraction=1.0)


def test_t4_confirmation_set_is_registered_and_pairs_its_trackers():
    """hpda-t4-confirm: its own seed; HPDA-PF at each prior and the strong hybrid are the
    runs of run_hpda_trial on the same scans and particle streams."""
    from trackcore.experiments.hpda_extensions import (
        CONFIRM_RUNS,
        CONFIRM_SEED,
        HpdaConfirmConfig,
    )

    e = get("hpda-t4-confirm")
    assert (e.runs, e.seed) == (CONFIRM_RUNS, CONFIRM_SEED)
    assert CONFIRM_SEED not in {SEED + c for c in (1, 2, 3)}
    assert e.config == HpdaConfirmConfig(1)
    assert e.config.priors == (0.98, 0.99, 0.995)
    with pytest.raises(ValueError, match="must be"):
        HpdaConfirmConfig(1, algorithms=("hpda",))
    res = run_experiment("hpda-t4-confirm", runs=1, seed=5,
                         overrides={"priors": "0.98,0.995"}, write=False, progress=False)
    for j, v in enumerate((0.98, 0.995)):
        d = montecarlo.run(run_hpda_trial, 1, 5, args=(1, ("hpda", "clustering")),
                           kwargs={"overrides": {"hpda": {"pi11": v}}})[0]
        assert np.array_equal(res["hpda.count"][0, j], d["hpda"]["count"])
        assert np.array_equal(res["clustering.count"][0], d["clustering"]["count"])
    assert res["hpda.count"].dtype == np.int16 and res["hpda.count"].shape == (1, 2, 451)
