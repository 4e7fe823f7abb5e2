"""Experiments fjpda-ext-*: the feature-JPDA extensions' crossing outcomes (004-07)."""
import json
import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from trackcore import montecarlo
from trackcore.experiments import (
    VerificationError,
    get,
    load,
    read_metadata,
    run_experiment,
    status,
    verify_sample,
)
from trackcore.experiments._core import META_KEY
from trackcore.experiments.fjpda_extensions import (
    CROSSING_OUTCOMES,
    CROSSING_TRACKERS,
    FJPDA_EXT_LR,
    FjpdaCrossingConfig,
)
from trackcore.scenarios.feature_metrics import crossing_trial
from trackcore.trackers.jpda_tracker import JPDATrackerConfig

BOOK = {"fjpda-ext-3px": (800, 20160328), "fjpda-ext-8px": (400, 20160333),
        "fjpda-ext-16px": (400, 20160341)}


def _notebook_runs(sep, n):
    """The notebook's direct computation before the port (its cell, verbatim)."""
    lam = 1.0 / 120**2
    trackers = {
        "JPDA": JPDATrackerConfig(variant="JPDA", lam=lam, duplicate_deletion=False),
        "FJPDA": JPDATrackerConfig(variant="FJPDA", lam=lam, duplicate_deletion=False),
    }
    at_3px = {
        "FJPDA-LR": JPDATrackerConfig(variant="FJPDA", lam=lam, feature_lr=FJPDA_EXT_LR,
                                      duplicate_deletion=False),
        "JPDA, duplicate rule": JPDATrackerConfig(variant="JPDA", lam=lam),
    }
    crossing = dict(heading_b=math.radians(20.0), pd=0.98, n_frames=36, conflict=18)
    return montecarlo.run(crossing_trial, n, 20160325 + int(sep),
                          args=(trackers | at_3px if sep == 3.0 else trackers,),
                          kwargs=crossing | dict(min_sep=sep))


@pytest.mark.parametrize("sep", [3.0, 8.0])
def test_stored_rows_equal_the_notebook_computation(sep):
    name = f"fjpda-ext-{sep:.0f}px"
    stored = load(name, runs=4)
    direct = _notebook_runs(sep, 4)
    assert list(direct[0]) == list(stored.config.trackers), stored.config.trackers
    for t in stored.config.trackers:
        got = np.asarray(CROSSING_OUTCOMES)[stored[f"{t}.crossing"]]
        want = [r[t].crossing for r in direct]
        assert got.tolist() == want, f"{name}, {t}: stored {got}, direct {want}"
        assert stored[f"{t}.crossing"].dtype == np.int8, t


def test_book_stores_are_current():
    for name, (runs, seed) in BOOK.items():
        assert status(name) == "current", f"{name}: {status(name)}"
        m = read_metadata(get(name).default_path())
        assert m["runs"] == runs and m["seed"] == seed, m
    assert get("fjpda-ext-3px").config.trackers == CROSSING_TRACKERS


def test_bad_configs_raise_clear_errors():
    c = get("fjpda-ext-8px").config
    assert c.with_overrides({"pd": "0.9"}).pd == 0.9
    assert c.with_overrides({"trackers": "JPDA"}).trackers == ("JPDA",)
    with pytest.raises(ValueError, match="unknown config field"):
        c.with_overrides({"separation": 3})
    with pytest.raises(ValueError, match="pd must be in"):
        c.with_overrides({"pd": "1.5"})
    with pytest.raises(ValueError, match="unknown tracker 'KF'"):
        FjpdaCrossingConfig(3.0, ("JPDA", "KF"))
    with pytest.raises(ValueError, match="feature_lr must hold four"):
        FjpdaCrossingConfig(3.0, ("FJPDA-LR",))
    with pytest.raises(ValueError, match="min_sep must be >= 0"):
        FjpdaCrossingConfig(-1.0)
    with pytest.raises(ValueError, match="conflict must be in"):
        FjpdaCrossingConfig(3.0, conflict=40)
    with pytest.raises(TypeError, match="n_frames must be an integer"):
        FjpdaCrossingConfig(3.0, n_frames=36.0)
    with pytest.raises(ValueError, match="must not repeat"):
        FjpdaCrossingConfig(3.0, ("JPDA", "JPDA"))


def test_verification_catches_a_corrupted_row(tmp_path):
    name, path = "fjpda-ext-16px", tmp_path / "x.parquet"
    run_experiment(name, runs=3, out=path, progress=False)
    assert "all match" in str(verify_sample(load(name, runs=3, path=path), fraction=1.0))
    table = pq.read_table(path)
    col = "FJPDA.crossing"
    values = table.column(col).to_numpy().copy()
    values[1] = (values[1] + 1) % 3
    i = table.schema.get_field_index(col)
    bad = tmp_path / "bad.parquet"
    pq.write_table(table.set_column(i, table.schema.field(i), pa.array(values)), bad)
    assert json.loads(pq.read_schema(bad).metadata[META_KEY])["runs"] == 3
    with pytest.raises(VerificationError, match=r"run 1, column 'FJPDA.crossing'.*equal"):
        verify_sample(load(name, runs=3, path=bad), fraction=1.0)
