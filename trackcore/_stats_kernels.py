"""Private numba kernels behind :mod:`trackcore.stats`' bootstrap (not public API).

Each kernel takes the runs and a block of resample indices (one row per resample, drawn by
``stats`` exactly as before) and returns per-resample means, spreads or ratios without
building the ``(resamples, runs)`` array of resampled values and its temporaries, which is
what made a bootstrap over thousands of runs slow (page faults on hundreds of MB per
interval).

The sums follow NumPy's own pairwise summation (``pairwise_sum`` in NumPy's
``loops_utils.h.src``: plain loop below 8 terms, eight interleaved partial sums up to 128,
halving above), in the same order, and every step is the same IEEE operation NumPy does
(``sum / n``, ``(v - mean) ** 2``, ``x - r * y``), so the results are bit-identical to the
NumPy expressions they replace; ``tests/test_stats_kernels.py`` checks that for every
resample on run counts from 2 to 20 000.
"""
from __future__ import annotations

import numba as nb
import numpy as np

_PW_BLOCK = 128  # NumPy's PW_BLOCKSIZE
_MAX_DEPTH = 64  # the halving tree of any int64 count is far shallower


@nb.njit(cache=True)
def _term(x, y, j, m, mode):
    """One summand: ``x[j]`` (mode 0), ``(x[j] - m) ** 2`` (mode 1) or
    ``(x[j] - m * y[j]) ** 2`` (mode 2), each with NumPy's operations and roundings."""
    if mode == 0:
        return x[j]
    if mode == 1:
        d = x[j] - m
    else:
        d = x[j] - m * y[j]
    return d * d


@nb.njit(cache=True)
def _leaf(x, y, row, lo, n, m, mode):
    """NumPy's pairwise sum of ``n <= 128`` terms ``row[lo:lo + n]``."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += _term(x, y, row[lo + i], m, mode)
        return res
    r = np.empty(8)
    for k in range(8):
        r[k] = _term(x, y, row[lo + k], m, mode)
    i = 8
    stop = n - (n % 8)
    while i < stop:
        for k in range(8):
            r[k] += _term(x, y, row[lo + i + k], m, mode)
        i += 8
    res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        res += _term(x, y, row[lo + i], m, mode)
        i += 1
    return res


@nb.njit(cache=True)
def _pw(x, y, row, m, mode):
    """NumPy's pairwise sum of the terms of every run in ``row``: above 128 terms the range
    is halved (the first half a multiple of 8) and the halves' sums added, left + right.
    Walked with an explicit stack (numba's cache cannot hold recursive functions)."""
    n = row.shape[0]
    if n <= _PW_BLOCK:
        return _leaf(x, y, row, 0, n, m, mode)
    los = np.empty(_MAX_DEPTH, np.int64)
    ns = np.empty(_MAX_DEPTH, np.int64)
    state = np.zeros(_MAX_DEPTH, np.int64)
    vals = np.empty(_MAX_DEPTH + 1)
    top, nv = 0, 0
    los[0], ns[0], state[0] = 0, n, 0
    while top >= 0:
        lo, cnt = los[top], ns[top]
        if cnt <= _PW_BLOCK:
            vals[nv] = _leaf(x, y, row, lo, cnt, m, mode)
            nv += 1
            top -= 1
            continue
        n2 = cnt // 2
        n2 -= n2 % 8
        if state[top] == 0:
            state[top] = 1
            top += 1
            los[top], ns[top], state[top] = lo, n2, 0
        elif state[top] == 1:
            state[top] = 2
            top += 1
            los[top], ns[top], state[top] = lo + n2, cnt - n2, 0
        else:
            nv -= 1
            vals[nv - 1] = vals[nv - 1] + vals[nv]
            top -= 1
    return vals[0]


@nb.njit(cache=True)
def boot_means(v, idx):
    """``v[idx].mean(axis=1)``."""
    b, n = idx.shape
    out = np.empty(b)
    for k in range(b):
        out[k] = _pw(v, v, idx[k], 0.0, 0) / n
    return out


@nb.njit(cache=True)
def boot_mean_var(v, idx):
    """``(v[idx].mean(axis=1), v[idx].var(axis=1, ddof=1))``."""
    b, n = idx.shape
    means = np.empty(b)
    var = np.empty(b)
    for k in range(b):
        row = idx[k]
        m = _pw(v, v, row, 0.0, 0) / n
        means[k] = m
        var[k] = _pw(v, v, row, m, 1) / (n - 1)
    return means, var


@nb.njit(cache=True, error_model="numpy")
def boot_paired_ratio(x, y, idx):
    """Per resample of paired runs: ``mean(x*)``, ``mean(y*)`` and the sum of squared
    residuals ``sum((x* - (mean(x*) / mean(y*)) y*) ** 2)`` (the delta-method numerator)."""
    b, n = idx.shape
    mx = np.empty(b)
    my = np.empty(b)
    ss = np.empty(b)
    for k in range(b):
        row = idx[k]
        a = _pw(x, y, row, 0.0, 0) / n
        c = _pw(y, x, row, 0.0, 0) / n
        mx[k] = a
        my[k] = c
        ss[k] = _pw(x, y, row, a / c, 2)
    return mx, my, ss
