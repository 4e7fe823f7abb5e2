"""The SPRT chapter's stored experiments (002-06): rows, configs, verification."""
import json
import shutil

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from trackcore.detection import sprt_decide
from trackcore.experiments import VerificationError, get, load, run_experiment, verify_sample
from trackcore.experiments._core import META_KEY
from trackcore.experiments.sprt import (
    FAMILY_S1,
    FAMILY_S23,
    GEO_ALPHAS,
    GEO_LEADS,
    SprtCellsConfig,
    _cells_trial,
    cell_of,
    decision_summary,
    family_cell,
    t10_cell,
)
from trackcore.scenarios import (
    sprt_acm_filter_config,
    sprt_acm_monte_carlo,
    sprt_acm_scenario,
)
from trackcore.stats import mean_ci, rate_ci

SEED = 20261123


def test_registered_at_the_book_sizes():
    for name, seed, cells in (("sprt-s1-geometry", SEED + 1, 49),
                              ("sprt-t10-s2", SEED + 1002, 4), ("sprt-t10-s3", SEED + 1003, 4),
                              ("sprt-t10-boost-rep-s2", SEED + 2002, 1),
                              ("sprt-t10-boost-rep-s3", SEED + 2003, 1)):
        e = get(name)
        assert (e.seed, e.runs, e.version, len(e.config.cells)) == (seed, 5000, "1", cells), e
    geo = get("sprt-s1-geometry").config.cells
    assert geo[0] == "alpha_deg=30.0;lead_deg=-20.0", geo[0]
    assert geo.index(cell_of(alpha_deg=45.0, lead_deg=0.0)) == 4 * 7 + 3
    assert len(GEO_ALPHAS) == len(GEO_LEADS) == 7
    assert t10_cell("imm_cue") == "beta_std_factor=0.2;target_model=imm;mu_release=1.0"


def test_the_declared_family_is_registered_on_the_verdict_runs():
    for name, seed, runs, cells in (("sprt-s1-family", SEED + 500, 5000, 5),
                                    ("sprt-s2-family", SEED + 2, 1000, 6),
                                    ("sprt-s3-family", SEED + 3, 1000, 6)):
        e = get(name)
        assert (e.seed, e.runs, len(e.config.cells)) == (seed, runs, cells), e
    assert FAMILY_S23[1:] == FAMILY_S1 and FAMILY_S23[0] == (45.0, 0.0), FAMILY_S23
    assert family_cell(3, 45.0, 15.0) == "alpha_deg=45.0;lead_deg=15.0;t_end=80.0"
    assert family_cell(2, 45.0, 15.0) == "alpha_deg=45.0;lead_deg=15.0"
    assert family_cell(3, 33.8, -15.0) == "alpha_deg=33.8;lead_deg=-15.0"


def _direct(scenario, cell, runs, seed, h1_true=False):
    """The notebook's computation: one batch of the cell's settings, then the decisions."""
    sc_kw, f_kw = {}, {}
    for part in filter(None, cell.split(";")):
        k, v = part.split("=")
        target = f_kw if k in ("target_model", "beta_std_factor", "mu_release",
                               "sigma_v") else sc_kw
        target[k] = v if k == "target_model" else float(v)
    sc = sprt_acm_scenario(scenario, **sc_kw)
    res = sprt_acm_monte_carlo(sc, runs, seed, config=sprt_acm_filter_config(sc, **f_kw),
                               h1_true=h1_true)
    return sprt_decide(res.llr, -sc.gamma, sc.gamma)


def test_rows_equal_the_notebooks_batches():
    cells = ("alpha_deg=45.0;lead_deg=-15.0", "", t10_cell("boost"),
             "decoy_speed=6.4;sigma_v=1.0")
    for n, seed in ((1, SEED + 1), (2, SEED + 1002)):
        res = run_experiment("sprt-t10-s2" if n == 2 else "sprt-s1-geometry", runs=3,
                             seed=seed, overrides={"cells": cells}, write=False,
                             progress=False)
        assert res["d"].dtype == np.int8 and res["k"].dtype == np.int16, res["d"].dtype
        for j, cell in enumerate(cells):
            d, k = _direct(n, cell, 3, seed)
            assert np.array_equal(res["d"][:, j], d), (n, cell)
            assert np.array_equal(res["k"][:, j], k), (n, cell)


def test_h1_true_rows_equal_the_batch():
    cfg = SprtCellsConfig(3, ("",), h1_true=True)
    rng = np.random.default_rng(np.random.SeedSequence(SEED + 53).spawn(4)[2])
    d, k = _cells_trial(rng, cfg.scenario, cfg.cells, True)
    dd, kk = _direct(3, "", 4, SEED + 53, h1_true=True)
    assert (d[0], k[0]) == (dd[2], kk[2]), (d, k, dd, kk)


def test_decision_summary_is_the_notebooks_decide():
    d = np.array([0, 0, 1, -1, 0] * 20, dtype=np.int8)
    k = np.array([5, 6, 2, 0, 7] * 20, dtype=np.int16)
    s = decision_summary(d, k)
    assert s["d"].dtype == np.int64 and s["k"].dtype == np.int64, s["d"].dtype
    assert str(s["success"]) == str(rate_ci(60, 100)), s["success"]
    assert str(s["ksucc"]) == str(mean_ci(np.array([5, 6, 7] * 20))), s["ksucc"]
    assert decision_summary(d[:10], k[:10])["ksucc"] is None  # fewer than MIN_RUNS
    with pytest.raises(ValueError, match="d and k must be"):
        decision_summary(d, k[:3])


@pytest.mark.parametrize("kwargs, error, match", [
    ({"scenario": 4}, ValueError, "scenario must be 1, 2 or 3"),
    ({"scenario": True}, ValueError, "scenario must be 1, 2 or 3"),
    ({"scenario": 1, "cells": ()}, TypeError, "cells must be a non-empty tuple"),
    ({"scenario": 1, "cells": ("", "")}, ValueError, "cells must not repeat"),
    ({"scenario": 1, "cells": ("bogus=1",)}, ValueError, "unknown setting 'bogus'"),
    ({"scenario": 1, "cells": ("alpha_deg=wide",)}, ValueError, "alpha_deg must be a number"),
    ({"scenario": 1, "cells": ("alpha_deg",)}, ValueError, "expected name=value"),
    ({"scenario": 1, "cells": ("alpha_deg=1;alpha_deg=2",)}, ValueError, "set twice"),
    ({"scenario": 1, "cells": ("target_model=kalman",)}, ValueError, "target_model"),
    ({"scenario": 1, "cells": ("R0=-5",)}, ValueError, "R0"),
    ({"scenario": 1, "h1_true": 1}, TypeError, "h1_true must be a bool"),
])
def test_bad_configs_raise(kwargs, error, match):
    with pytest.raises(error, match=match):
        SprtCellsConfig(**kwargs)


def test_bad_overrides_raise():
    with pytest.raises(ValueError, match="unknown config field"):
        get("sprt-t10-s2").configure({"gamma": 3.0})
    with pytest.raises(TypeError, match="must be a number or a str"):
        cell_of(alpha_deg=None)


def test_a_corrupted_stored_row_is_caught(tmp_path):
    name = "sprt-t10-s2"
    path = get(name).default_path()
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    table = pq.read_table(path)
    size = int(np.prod(json.loads(table.schema.metadata[META_KEY])["columns"]["k"][0]))
    values = table.column("k").combine_chunks().flatten().to_numpy(
        zero_copy_only=False).copy()
    values[7 * size + 1] += 1
    i = table.schema.get_field_index("k")
    new = pa.FixedSizeListArray.from_arrays(pa.array(values), size)
    pq.write_table(table.set_column(i, table.schema.field(i), new), bad)
    good = verify_sample(load(name), indices=[7])  # the book's stored row is right
    assert good.checked == 1, good
    with pytest.raises(VerificationError, match=r"run 7, column 'k'\[1\]"):
        verify_sample(load(name, path=bad), indices=[6, 7])


def test_fss_curve_and_calib_ga_are_registered_as_declared():
    from trackcore.experiments.sprt import CALIB_GEOMETRIES, FSS_CURVE_NS

    e = get("sprt-fss-curve-s1")
    assert (e.seed, e.runs, len(e.config.cells)) == (SEED + 7000, 20000, 6), e
    assert e.config.cells == tuple(family_cell(1, *g) for g in CALIB_GEOMETRIES)
    assert FSS_CURVE_NS == tuple(range(1, 17))
    e = get("sprt-calib-ga")
    assert (e.seed, e.runs, e.config.cells) == (SEED + 8000, 60000,
                                                 ("alpha_deg=45.0;lead_deg=0.0",)), e


def test_fss_curve_rows_are_the_batch():
    from trackcore.experiments.sprt import FSS_CURVE_NS

    cells = ("alpha_deg=45.0;lead_deg=0.0", "alpha_deg=45.0;lead_deg=15.0")
    res = run_experiment("sprt-fss-curve-s1", runs=3, seed=SEED + 77,
                         overrides={"cells": cells}, write=False, progress=False)
    for j, cell in enumerate(cells):
        sc = sprt_acm_scenario(1, alpha_deg=45.0, lead_deg=float(cell.split("=")[-1]))
        b = sprt_acm_monte_carlo(sc, 3, SEED + 77)
        d, k = sprt_decide(b.llr, -sc.gamma, sc.gamma)
        assert np.array_equal(res["d"][:, j], d) and np.array_equal(res["k"][:, j], k)
        for n in FSS_CURVE_NS:
            assert np.array_equal(res[f"fss{n}_h0"][:, j], b.llr[:, n - 1] < 0), (cell, n)


def test_ek_undecided_at_end_counts_undecided_runs_at_the_end():
    from trackcore.experiments.sprt import ek_undecided_at_end
    from trackcore.stats import mean_ci

    d = np.tile([0, 1, -1, 0, -1], 20)
    k = np.tile([2, 4, 0, 6, 0], 20)
    e = ek_undecided_at_end(d, k)
    assert e.value == pytest.approx((2 + 4 + 16 + 6 + 16) / 5)
    assert e.value == mean_ci(np.tile([2.0, 4, 16, 6, 16], 20)).value
    assert ek_undecided_at_end(d[d >= 0], k[d >= 0]).value == mean_ci(k[d >= 0].astype(float)).value
    assert ek_undecided_at_end(d, k, n_scans=10).value == pytest.approx(32 / 5)
