"""The SPRT chapter's calibration decomposition: its statistics, stored rows and verdicts."""
import numpy as np
import pytest

from trackcore.detection import sprt_decide
from trackcore.experiments import sprt as S
from trackcore.experiments._core import _columns, compute_rows, get
from trackcore.scenarios import sprt_acm_monte_carlo, sprt_acm_scenario
from trackcore.scenarios._sprt_book import bound_verdict, geometry_tag
from trackcore.stats import rate_ci
from trackcore.trackers import sprt_acm_llr


def test_statistics_split_lambda():
    lam = np.random.default_rng(1).normal(size=(5, 7, 4))
    st = S.calib_statistics(lam)
    assert st.shape == (5, 7, 3), "three statistics per scan"
    np.testing.assert_allclose(st[..., 0], sprt_acm_llr(lam), err_msg="eq (21)")
    np.testing.assert_allclose(st[..., 1] + st[..., 2], st[..., 0], err_msg="the two pairs sum")
    np.testing.assert_allclose(st[..., 1], lam[..., 2] - lam[..., 1], err_msg="decoy pair")
    with pytest.raises(ValueError, match="last dimension 4"):
        S.calib_statistics(np.zeros((3, 3)))


def test_rows_are_the_book_runs():
    """G-A's column of the stored experiment holds the runs of sprt_acm_monte_carlo."""
    e = get("sprt-calib-s1-family")
    rows, _ = compute_rows(e, e.config, e.seed, 6)
    c = _columns(rows)
    sc = sprt_acm_scenario(1)
    res = sprt_acm_monte_carlo(sc, 6, e.seed)
    d, k = sprt_decide(res.llr, -sc.gamma, sc.gamma)
    assert np.array_equal(c["d_full"][:, 0], d) and np.array_equal(c["k_full"][:, 0], k), (
        "G-A's decisions are those of the chapter's S1 runs")
    dec = res.lam[..., 2] - res.lam[..., 1]
    assert np.array_equal(c["ever_dec"][:, 0] == 1, (dec >= sc.gamma).any(axis=1)), (
        "the decoy pair's crossings")
    dd, _ = sprt_decide(dec, -sc.gamma, sc.gamma)
    assert np.array_equal(c["d_dec"][:, 0], dd), "the decoy-only SPRT's decisions"


def test_bound_verdict_and_tag():
    assert bound_verdict(rate_ci(10, 1000), 1 / 19) == "respects", "1 % < 5.26 %"
    assert bound_verdict(rate_ci(200, 1000), 1 / 19) == "violates", "20 % > 5.26 %"
    assert bound_verdict(rate_ci(53, 1000), 1 / 19) == "undecided", "5.3 % ~ 5.26 %"
    with pytest.raises(ValueError, match="bound"):
        bound_verdict(rate_ci(1, 10), 1.5)
    assert geometry_tag(33.8, -15.0) == "a338_lm15" and geometry_tag(45.0, 0.0) == "a45_l0"
    assert geometry_tag(33.8, 15.0) == "a338_lp15", "positive lead"
    with pytest.raises(TypeError, match="alpha"):
        geometry_tag("45", 0.0)


def test_filters_rows_are_the_notebook_runs():
    """sprt-filters-s2's rows equal 06-sensitivity's direct batch computation."""
    from trackcore.scenarios import sprt_acm_filter_config

    e = get("sprt-filters-s2")
    keys = [k for k, _ in S.filters_cells()]
    assert keys[0] == ("prior", 2.0), "the paper's filters come first"
    rows, _ = compute_rows(e, e.config, e.seed, 3)
    c = _columns(rows)
    sc = sprt_acm_scenario(2)
    for key, ch in ((("prior", 2.0), {}), (("model", "boost", 0.2),
                    dict(beta_std_factor=0.2, target_model="boost"))):
        j = keys.index(key)
        res = sprt_acm_monte_carlo(sc, 3, e.seed, config=sprt_acm_filter_config(sc, **ch))
        d, k = sprt_decide(res.llr, -sc.gamma, sc.gamma)
        assert np.array_equal(c["d"][:, j], d) and np.array_equal(c["k"][:, j], k), key
        np.testing.assert_array_equal(c["tp8"][:, j], res.lam[:, 7, 3] - res.lam[:, 7, 0],
                                      err_msg=f"{key}: target pair at k = 8")
    acm = res.lam[..., 2] - res.lam[..., 1]
    assert acm.shape == (3, sc.n_post), "one decoy-only statistic per run"


def test_filters_cells_bad_change():
    with pytest.raises(TypeError):
        S.filters_cells({"beta_std_factor": 1.0})  # set twice in the prior cells


@pytest.mark.parametrize("name, column", [("sprt-calib-s1-family", "ever_dec"),
                                          ("sprt-filters-s3", "k_acm")])
def test_a_corrupted_stored_row_is_caught(tmp_path, name, column):
    import json
    import shutil

    import pyarrow as pa
    import pyarrow.parquet as pq

    from trackcore.experiments import VerificationError, load, verify_sample
    from trackcore.experiments._core import META_KEY

    path = get(name).default_path()
    bad = tmp_path / "bad.parquet"
    shutil.copy(path, bad)
    table = pq.read_table(path)
    size = int(np.prod(json.loads(table.schema.metadata[META_KEY])["columns"][column][0]))
    values = table.column(column).combine_chunks().flatten().to_numpy(
        zero_copy_only=False).copy()
    values[5 * size + 1] += 1
    i = table.schema.get_field_index(column)
    new = pa.FixedSizeListArray.from_arrays(pa.array(values), size)
    pq.write_table(table.set_column(i, table.schema.field(i), new), bad)
    good = verify_sample(load(name), indices=[5])  # the book's stored row is right
    assert good.checked == 1, good
    with pytest.raises(VerificationError, match=rf"run 5, column '{column}'\[1\]"):
        verify_sample(load(name, path=bad), indices=[4, 5])
