"""The tables of the appendix "Performance" (benchmarks._perf_page), on synthetic rows
and on the stored benchmark results."""
import sys
from pathlib import Path

import pytest

# benchmarks/ is a folder of the repository, not an installed package (as in the appendix)
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks import _perf_page as pp  # noqa: E402
from benchmarks.report import load, row, seconds  # noqa: E402


def _r(workload, impl, size, s, **kw):
    return dict(workload=workload, implementation=impl, size=size,
                seconds_per_step=s, **kw)


def test_close_rows_synthetic():
    res = []
    for T in (3,):
        res += [_r("jpda_close", "trackcore", T, 1e-3, measurements=6,
                   feasible_events=1234, method="net"),
                _r("jpda_close", "trackcore_kernels", T, 5e-4),
                _r("jpda_close", "stonesoup_JPDAwithEHM2", T, 2e-2),
                _r("jpda_close", "stonesoup_JPDA", T, 0.5),
                _r("jpda_close_marginals", "trackcore", T, 2e-5),
                _r("jpda_close_marginals", "stonesoup_EHM2_core", T, 4e-4)]
    (got,) = pp.close_rows({"results": res}, sizes=(3,))
    assert got == (3, 6, "1,234", "net", "1.00", "0.50", "20.0", "500", "20", "0.40",
                   "20x [20-20]")
    assert len(got) == len(pp.CLOSE_HEADERS)
    with pytest.raises(KeyError):
        pp.close_rows({"results": res}, sizes=(5,))


def test_series_rows_mark_sizes_the_peer_did_not_run():
    res = [_r("jpda_chain", "trackcore", T, 0.001 * T, measurements=2 * T,
              feasible_events=10.0 ** T, method="net") for T in (4, 2)]
    res.append(_r("jpda_chain", "stonesoup_JPDAwithEHM2", 2, 0.02))
    from benchmarks.report import series_ratios
    data = {"results": res}
    rows = pp.series_rows(data, {"chain": series_ratios(data, "jpda_chain",
                                                        "stonesoup_JPDAwithEHM2")})
    assert [r[1] for r in rows] == [2, 4], "sorted by size"
    assert rows[0][6:] == ("0.02", "10x [10-10]")
    assert rows[1][6:] == ("not run", "")
    assert all(len(r) == len(pp.SERIES_HEADERS) for r in rows)


def test_accuracy_rows():
    r = {"targets": 6, "measurements": 8, "lam": 1e-60, "feasible_events": 93289,
         "net_scaled_certified": False, "net_max_rel_error": 1.5e-15,
         "enumeration_max_rel_error": 2e-13}
    assert pp.accuracy_rows([r]) == [("6 x 8", "1e-60", "93,289", "log space",
                                      "1.5e-15", "2.0e-13")]


def test_label_size():
    assert pp.label_size("JPDA chain of targets (T = 40)") == "40"
    assert pp.label_size("Marcum Q1 vs ncx2.sf, per element (12 dB)") == "12"
    assert pp.label_size("a (b) (c)") == "c"
    with pytest.raises(ValueError, match="label"):
        pp.label_size("no size")


def test_tables_of_the_stored_results():
    data = load()
    close = pp.close_rows(data)
    assert [r[0] for r in close] == [3, 5, 8]
    ours = row(data, "jpda_close", "trackcore", 3)
    assert close[0][4] == f"{seconds(ours) * 1e3:.2f}"
    marcum = pp.marcum_scalar_rows(data)
    assert marcum and all(len(r) == len(pp.MARCUM_SCALAR_HEADERS) for r in marcum)
    assert [float(r[0]) for r in marcum] == sorted(float(r[0]) for r in marcum)
