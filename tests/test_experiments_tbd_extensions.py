"""The TBD chapter's extensions experiments (tbd-ext-*): rows, configs, stores."""
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
    read_metadata,
    status,
    verify_sample,
)
from trackcore.experiments.tbd_extensions import (
    CALIBRATED_SIGMA,
    TbdExtensionsConfig,
    tbd_extension_trackers,
)
from trackcore.scenarios import TbdRadarParameters, tbd_paired_trial, tbd_radar_truth
from trackcore.trackers import TbdTrackerConfig, tbd_run_outcomes

NAME = "tbd-ext-pda-r10"  # the cheapest (about 0.3 s per run, 2 trackers at R = 1 km)
BOOK = {"tbd-ext-pda-r25": 100, "tbd-ext-pda-r10": 100, "tbd-ext-ablations": 100,
        "tbd-ext-scen-swerling1": 100, "tbd-ext-scen-lambda1-1": 100,
        "tbd-ext-scen-lambda1-2": 100, "tbd-ext-rough-r25": 100,
        "tbd-ext-rough-r10": 100, "tbd-ext-maps": 60}


def test_registered_with_the_notebook_seed_and_runs():
    assert set(BOOK) <= set(names()), sorted(set(BOOK) - set(names()))
    for name, runs in BOOK.items():
        e = get(name)
        assert (e.runs, e.seed, e.version) == (runs, 20160307, "1"), e
        assert e.notebook == "book/003-tbd-pf/05-extensions.ipynb", e.notebook
    assert len(tbd_extension_trackers(get("tbd-ext-ablations").config)) == 22
    assert list(tbd_extension_trackers(get("tbd-ext-maps").config)) == [
        "I (raw intensity)", "C, 5 dB", "P, 5 dB", "C, 8.3 dB", "P, 8.3 dB"]


def test_book_stores_are_current():
    for name, runs in BOOK.items():
        assert status(name) == "current", f"{name}: {status(name)}"
        m = read_metadata(get(name).default_path())
        assert m["runs"] == runs and m["seed"] == 20160307, (name, m)


def test_rows_equal_the_notebook_computation():
    """The first stored rows are the notebook's own montecarlo.run of the trial, reduced
    as its tables did (window means, outcomes) and its figure (the series)."""
    R = 1000.0
    cfg = {m: TbdTrackerConfig(method=m, processing_radius=R) for m in "CP"}
    res = montecarlo.run(tbd_paired_trial, 2, 20160307,
                         args=(cfg, TbdRadarParameters(processing_radius=R),
                               tbd_radar_truth()))
    stored = load(NAME, runs=2)
    for j, m in enumerate("CP"):
        E = np.array([r.errors[m] for r in res])
        assert np.array_equal(stored["mean100"][:, j], E[:, :100].mean(axis=1)), m
        assert np.array_equal(stored["mean_all"][:, j], E.mean(axis=1)), m
        assert np.array_equal(stored["errors"][:, j], E.astype(np.float32)), m
        out = tbd_run_outcomes(E)
        code = stored["outcome"][:, j]
        assert np.array_equal(code > 0, out.lost), m
        assert np.array_equal(code == 1, out.transient), m
        assert np.array_equal(code == 2, out.diverged), m
        assert np.array_equal(code == 3, out.other), m


def test_bad_configs_raise_clear_errors():
    e = get("tbd-ext-ablations")
    with pytest.raises(ValueError, match="block must be one of"):
        TbdExtensionsConfig("nope")
    with pytest.raises(ValueError, match="fluctuation must be one of"):
        e.configure({"fluctuation": "swerling9"})
    with pytest.raises(ValueError, match="processing_radius must be a number"):
        e.configure({"processing_radius": "wide"})
    with pytest.raises(ValueError, match="processing_radius must be > 0"):
        e.configure({"processing_radius": "-1"})
    with pytest.raises(ValueError, match="pseudo_sigma must be > 0 for block 'scenario'"):
        e.configure({"pseudo_sigma": 300.0})
    with pytest.raises(ValueError, match="unknown config field"):
        e.configure({"n_particles": 10})
    with pytest.raises(TypeError, match="config must be a TbdExtensionsConfig"):
        tbd_extension_trackers("pda")
    s = get("tbd-ext-scen-swerling1")
    assert s.configure({"pseudo_sigma": CALIBRATED_SIGMA["swerling1"]}) == s.config
    assert s.configure({"fluctuation": "swerling1"}) == s.config


def test_verification_catches_a_corrupted_row(tmp_path):
    path = get(NAME).default_path()
    table = pq.read_table(path)
    col = table.column("mean_all").combine_chunks()
    values = col.flatten().to_numpy(zero_copy_only=False).copy()
    values[3 * 2 + 1] *= 1 + 1e-3  # run 3, tracker P (above the relative 1e-6)
    i = table.schema.get_field_index("mean_all")
    new = pa.FixedSizeListArray.from_arrays(pa.array(values), 2)
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    pq.write_table(table.set_column(i, table.schema.field(i), new), bad)
    res = load(NAME, path=bad)
    with pytest.raises(VerificationError, match=r"run 3, column 'mean_all'\[1\]"):
        verify_sample(res, indices=[3])
