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


def test_memo_returns_the_same_interval_and_follows_the_content():
    rng = np.random.default_rng(21)
    x = rng.gamma(2.0, 1.0, 80)
    y = x + rng.normal(0.0, 0.3, 80)
    stats._MEMO.clear()
    first = stats.paired_diff_ci(x, y)
    assert len(stats._MEMO) == 1, "the interval was not remembered"
    assert stats.paired_diff_ci(x.copy(), list(y)) is first, "same content, new bootstrap"
    assert stats.paired_diff_ci(x, y, seed=1) != first, "another seed must give its own interval"
    x[0] += 1.0
    assert stats.paired_diff_ci(x, y).value != first.value, "a changed array got a stale interval"
    stats._MEMO.clear()
    assert stats.paired_diff_ci(x, y) == stats.paired_diff_ci.__wrapped__(x, y), \
        "the remembered interval differs from a fresh computation"


def test_memo_skips_what_it_cannot_key_and_does_not_remember_errors():
    stats._MEMO.clear()
    with pytest.raises(ValueError):
        stats.mean_ci(np.full(50, 2.0))
    assert not stats._MEMO, "an error was remembered"
    with pytest.raises((TypeError, ValueError)):
        stats.mean_ci(np.array([1.0, None] * 30, dtype=object))
    assert not stats._MEMO, "an object array was keyed"
