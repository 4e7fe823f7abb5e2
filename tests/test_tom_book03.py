"""Unit tests of the private helpers of the TOM-IMM chapter's Houles notebook (001-03)."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest

from trackcore.scenarios import (
    FAILURE_DEFINITIONS,
    failure_grid,
    houles_table,
    rmse_estimate_mse,
    rmse_ratio_mse,
)
from trackcore.scenarios._tom_book03 import (
    BASELINE,
    _baseline_cells,
    _errorbar,
    _pooled_cis,
    _rmse_rows,
)
from trackcore.stats import Estimate


def _data(n=60, nf=3, seed=1):
    rng = np.random.default_rng(seed)
    mse = rng.gamma(2.0, 300.0, size=(n, nf, 3))
    failed = rng.random((n, nf)) < 0.1
    return mse, failed


def _same(a, b):
    return (a.value, a.lo, a.hi, a.n, a.method) == (b.value, b.lo, b.hi, b.n, b.method)


def test_pooled_cis_equals_the_book_functions_bit_for_bit():
    mse, failed = _data()
    other = np.roll(failed, 3, axis=0)
    queries = [(0, None, "total"), (2, None, "manoeuvring"), (2, 0, "total"),
             (1, 0, "non-manoeuvring"), (0, None, "total", other)]
    got = _pooled_cis(mse, failed, queries)
    want = [rmse_estimate_mse(mse, failed, 0), rmse_estimate_mse(mse, failed, 2,
                                                                 window="manoeuvring"),
            rmse_ratio_mse(mse, failed, 2, 0),
            rmse_ratio_mse(mse, failed, 1, 0, window="non-manoeuvring"),
            rmse_estimate_mse(mse, other, 0)]
    for g, w, s in zip(got, want, queries):
        assert _same(g, w), f"query {s[:3]}: {g!r} != {w!r}"


def test_pooled_cis_bad_input():
    mse, failed = _data()
    with pytest.raises(TypeError, match="queries"):
        _pooled_cis(mse, failed, [])
    with pytest.raises(TypeError, match="query"):
        _pooled_cis(mse, failed, [(0, None)])
    with pytest.raises(ValueError, match="window"):
        _pooled_cis(mse, failed, [(0, None, "turns")])
    with pytest.raises(ValueError, match="num"):
        _pooled_cis(mse, failed, [(5, None, "total")])
    all_failed = np.ones_like(failed)
    with pytest.raises(ValueError, match="fewer than 2"):
        _pooled_cis(mse, all_failed, [(0, None, "total")])


def test_baseline_cells():
    mse, _ = _data(n=50)
    rng = np.random.default_rng(2)
    mx = rng.gamma(2.0, 2e4, size=(50, 3))
    last = mx * rng.random((50, 3))
    cells = failure_grid(mx, last, rng.random((50, 3)) < 0.05)
    out = _baseline_cells(mse, cells, (20.0, 25.0))
    assert len(out) == len(cells) * len(BASELINE), f"{len(out)} cells"
    for d in (FAILURE_DEFINITIONS[0], FAILURE_DEFINITIONS[4]):
        f = cells[d].failed
        e = rmse_estimate_mse(mse, f, 0, window="manoeuvring")
        got = out[d, "singer_man"]
        assert np.isclose(got.value * 25.0, e.value, rtol=1e-14, atol=0), "scaled by 25"
        want = rmse_ratio_mse(mse, f, 1, 0, window="manoeuvring")
        assert _same(out[d, "car_ratio_man"], want), f"CAR / Singer in the turns, {d}"
        assert _same(out[d, "car_total"], rmse_estimate_mse(mse, f, 1)), f"CAR, {d}"
    with pytest.raises(ValueError, match="cells"):
        _baseline_cells(mse, {}, (20.0, 25.0))


def test_errorbar_and_rows():
    fig, ax = plt.subplots()
    ests = [Estimate(1.0, 0.5, 2.0), Estimate(2.0, 1.5, 3.0)]
    art = _errorbar(ax, [0, 1], ests, scale=100.0, fmt="o")
    _, y = art.lines[0].get_data()
    assert list(y) == [100.0, 200.0], f"points at {list(y)}"
    plt.close(fig)
    rng = np.random.default_rng(3)
    e = rng.gamma(2.0, 100.0, size=(40, 3, 90))
    table = houles_table(e, np.zeros((40, 3), bool))
    paper = {"Singer": (1.0, 2.0, 3.0), "CAR": (1.0, 1.0, 1.0)}
    rows = _rmse_rows(table, paper, ["Singer", "CAR", "TOM"], ("a", "b", "c"),
                      ["total", "manoeuvring", "non-manoeuvring"])
    assert len(rows) == 9 and all(len(r) == 7 for r in rows), "9 rows of 7 columns"
    assert rows[0][5] == "(lost)" and rows[3][5] == "a %", "TOM's paper cells"
