"""The bootstrap kernels behind trackcore.stats give bit-identical results to the NumPy
expressions they replaced, so every interval the book prints is unchanged by them."""
import numpy as np
import pytest

from trackcore import _stats_kernels as K
from trackcore import stats

SIZES = [2, 3, 7, 8, 9, 16, 17, 40, 127, 128, 129, 257, 500, 1001, 5000, 8193, 20000]


@pytest.mark.parametrize("n", SIZES)
def test_kernels_match_numpy_bitwise(n):
    rng = np.random.default_rng(n)
    x = rng.lognormal(0.0, 1.0, n)
    y = rng.gamma(2.0, 1.0, n) + 0.01
    idx = rng.integers(0, n, size=(16, n), dtype=np.int32)
    xb, yb = x[idx], y[idx]
    assert np.array_equal(K.boot_means(x, idx), xb.mean(axis=1)), "means differ from NumPy"
    m, v = K.boot_mean_var(x, idx)
    assert np.array_equal(m, xb.mean(axis=1)), "means differ from NumPy"
    assert np.array_equal(np.sqrt(v), xb.std(axis=1, ddof=1)), "spreads differ from NumPy"
    mx, my, ss = K.boot_paired_ratio(x, y, idx)
    r = xb.mean(axis=1) / yb.mean(axis=1)
    res = xb - r[:, None] * yb
    assert np.array_equal(mx, xb.mean(axis=1)) and np.array_equal(my, yb.mean(axis=1)), \
        "ratio means differ from NumPy"
    assert np.array_equal(ss, np.sum(res * res, axis=-1)), "ratio residuals differ from NumPy"


@pytest.mark.parametrize("n", [40, 1000, 5000, 123457])
def test_32_bit_draws_equal_64_bit_draws(n):
    a = np.random.default_rng(7).integers(0, n, size=(8, n))
    b = stats._draw(np.random.default_rng(7), n, 8)
    assert b.dtype == np.int32, "indices below 2**31 are drawn as int32"
    assert np.array_equal(a, b), "NumPy's 32-bit draws no longer equal its 64-bit ones"


def _reference_student_mean(v, n_boot=10_000, seed=0):
    """The studentized replicates as stats computed them before the kernels."""
    rng = np.random.default_rng(seed)
    n = v.size
    m = v.mean()
    t = []
    for _ in range(n_boot // stats._CHUNK):
        r = v[rng.integers(0, n, size=(stats._CHUNK, n))]
        t.append((r.mean(axis=1) - m) / (r.std(axis=1, ddof=1) / np.sqrt(n)))
    return np.concatenate(t)


def test_intervals_unchanged_by_kernels():
    rng = np.random.default_rng(11)
    v = rng.gamma(2.0, 1.0, 300)
    t = _reference_student_mean(v)
    m, se = v.mean(), v.std(ddof=1) / np.sqrt(v.size)
    ref = stats._studentized(m, se, t, 0.95, v.size, "studentized bootstrap",
                             (float(v.min()), float(v.max())))
    assert stats.mean_ci(v) == ref, "mean_ci's interval changed"
