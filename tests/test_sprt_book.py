"""The SPRT chapter's private helpers (trackcore.scenarios._sprt_book)."""

import numpy as np
import pytest

from trackcore.models import modified_polar_F, modified_polar_f
from trackcore.scenarios import _sprt_book as sb


def test_private_module_exports_nothing():
    import trackcore.scenarios as sc

    assert sb.__all__ == [], "the private module re-exports something"
    assert not hasattr(sc, "central_jacobian"), "helper leaked into scenarios"


def test_central_jacobian_of_a_linear_map_is_its_matrix():
    A = np.array([[1.0, 2.0, -1.0], [0.5, 0.0, 3.0]])
    J = sb.central_jacobian(lambda v: A @ v, [0.3, -2.0, 1.0], [1e-3, 1.0, 0.1])
    assert J.shape == (2, 3), f"shape {J.shape}"
    assert np.allclose(J, A, atol=1e-12), f"{J} != {A}"


def test_central_jacobian_is_the_central_difference_bit_for_bit():
    f = lambda v: np.array([np.sin(v[0]) * v[1], v[0] ** 3])
    x, h = np.array([0.7, 1.3]), 1e-4
    J = sb.central_jacobian(f, x, [h, h])
    e = np.array([h, 0.0])
    assert np.array_equal(J[:, 0], (f(x + e) - f(x - e)) / (2 * h)), "column 0"
    exact = np.array([[np.cos(0.7) * 1.3, np.sin(0.7)], [3 * 0.7**2, 0.0]])
    assert np.allclose(J, exact, rtol=1e-7), f"{J} far from {exact}"


def test_central_jacobian_matches_modified_polar_F():
    xb, ub = np.array([0.4, 1.0 / 1500.0]), np.array([10.0, -20.0])
    Jn = sb.central_jacobian(
        lambda v: modified_polar_f(v, ub), xb, [1e-6, 1e-6 * xb[1]]
    )
    F = modified_polar_F(xb, ub)
    assert np.allclose(Jn, F, rtol=1e-5, atol=1e-9), f"{Jn} != {F}"


@pytest.mark.parametrize(
    "x, steps", [([[1.0]], [1.0]), ([1.0, 2.0], [1.0]), ([1.0], [0.0]), ([1.0], [-1.0])]
)
def test_central_jacobian_rejects_bad_input(x, steps):
    with pytest.raises(ValueError, match="x must|steps must"):
        sb.central_jacobian(lambda v: v, x, steps)


def test_in_mrad_lowers_each_filter_by_its_bearing_count():
    lam = np.zeros((2, 3, 4))
    out = sb.in_mrad(lam)
    h = 0.5 * np.log(1e6)
    assert np.allclose(out[0, :, 0], -h * np.array([1, 2, 3])), "target filter a0"
    assert np.allclose(out[1, :, 1], -h * np.array([0, 1, 2])), "decoy filter b0"
    assert np.array_equal(out[..., 0], out[..., 3]), "a0 and b1 alike"
    assert np.array_equal(out[..., 1], out[..., 2]), "b0 and a1 alike"


def test_in_mrad_leaves_lambda_unchanged():
    lam = np.random.default_rng(0).normal(size=(5, 16, 4))
    m = sb.in_mrad(lam)
    llr = lambda x: -x[..., 0] - x[..., 1] + x[..., 2] + x[..., 3]
    assert np.allclose(llr(m), llr(lam)), "the bearing unit changes Lambda"


def test_in_mrad_rejects_a_bad_shape():
    with pytest.raises(ValueError, match="lam"):
        sb.in_mrad(np.zeros((3, 5)))


def test_annotated_heatmap_prints_every_cell():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    val = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    im = sb.annotated_heatmap(ax, val, [0.0, 5.0, 10.0], [-1.0, 1.0], cmap="viridis",
                              vrange=(0, 6), fmt="{:.0f}", dark=lambda v: v > 3)
    texts = [(t.get_text(), t.get_color()) for t in ax.texts]
    assert len(texts) == 6, f"{len(texts)} labels"
    assert texts[0] == ("1", "k") and texts[-1] == ("6", "w"), texts
    assert list(im.get_extent()) == [-2.5, 12.5, -3.5, 3.5], im.get_extent()
    plt.close(fig)


def test_annotated_heatmap_rejects_a_mismatched_grid():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    with pytest.raises(ValueError, match="val"):
        sb.annotated_heatmap(ax, np.zeros((2, 2)), [0.0, 1.0, 2.0], [0.0, 1.0],
                             cmap="viridis", vrange=(0, 1), fmt="{}", dark=bool)
    plt.close(fig)


def test_paired_rate_diff_ci_matches_the_stats_helper():
    """The multinomial draw of the three per-run differences gives the same paired BCa
    interval as trackcore.stats.paired_diff_ci (up to bootstrap noise), and the helper
    itself below BCA_RUNS runs."""
    import numpy as np
    import pytest

    from trackcore.scenarios._sprt_book import paired_rate_diff_ci
    from trackcore.stats import paired_diff_ci

    rng = np.random.default_rng(5)
    base = rng.random(3000)
    x = (base < 0.9).astype(float)
    y = (base + rng.normal(0, 0.05, base.size) < 0.88).astype(float)
    a, b = paired_diff_ci(x, y), paired_rate_diff_ci(x, y)
    assert a.value == b.value, "the same estimate"
    assert abs(a.lo - b.lo) < 0.002 and abs(a.hi - b.hi) < 0.002, f"{a} against {b}"
    assert "multinomial" in b.method, b.method
    small = paired_rate_diff_ci(x[:100], y[:100])
    assert small == paired_diff_ci(x[:100], y[:100]), "below BCA_RUNS: the helper itself"
    with pytest.raises(ValueError, match="0/1"):
        paired_rate_diff_ci(x + 0.5, y)


def test_fss_n_star_is_the_first_reach_on_a_non_monotone_curve():
    from trackcore.stats import Estimate

    e = lambda v, lo, hi: Estimate(v, lo, hi, 0.95, 1000, "t")
    # short, tie, ahead, short again, ahead: N* is the first reach (2 [2, 3])
    diffs = [e(-.05, -.06, -.04), e(-.001, -.004, .002), e(.02, .01, .03),
             e(-.02, -.03, -.01), e(.05, .04, .06)]
    assert sb.fss_n_star(diffs, [1, 2, 3, 4, 5]) == (2, 3, 3)
    assert sb.fss_n_star(diffs[:1], [1]) == (None, None, None)
    with pytest.raises(ValueError):
        sb.fss_n_star(diffs, [1, 2, 3, 5, 4])
    ek = Estimate(5.0, 4.0, 6.0, 0.95, 1000, "t")
    s = sb.fss_saving((2, 3, 3), ek)
    assert (s.value, s.lo, s.hi) == (0.6, 2 / 6, 3 / 4), s
    assert sb.fss_saving((2, 3, None), ek) is None


def test_fss_curve_on_constructed_runs():
    rng = np.random.default_rng(5)
    n = 4000
    d = np.where(rng.random(n) < 0.9, 0, 1).astype(np.int8)   # SPRT right in 90 %
    k = rng.integers(3, 8, n).astype(np.int16)
    ps = [0.6, 0.9, 0.99, 0.7, 0.999]          # FSS right: short, tie, ahead, short, ahead
    fss = np.stack([(rng.random(n) < p) for p in ps], axis=1).astype(np.int8)
    out = sb.fss_curve(d, k, fss, [1, 2, 3, 4, 5])
    assert out["n_star"][0] in (2, 3) and out["n_star"][2] == 3, out["n_star"]
    assert out["short_after"] == [4], out["short_after"]
    assert abs(out["ek"].value - k.mean()) < 1e-12
    assert out["saving"].lo <= out["saving"].value <= out["saving"].hi
    with pytest.raises(ValueError):
        sb.fss_curve(d, k, fss[:, :4], [1, 2, 3, 4, 5])
