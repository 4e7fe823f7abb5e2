"""Bookkeeping of the TOM-IMM chapter's Houles notebook (001-03), kept out of its cells.

:func:`_pooled_cis` gives many pooled-RMSE intervals on the same runs at once, bit for bit
the intervals of :func:`~trackcore.scenarios.houles.rmse_estimate_mse` and
:func:`~trackcore.scenarios.houles.rmse_ratio_mse` (``survivors="own"``): every call of
:func:`trackcore.stats.bootstrap_ci` with its default seed draws the same resample indices
for the same number of runs, so one draw serves every interval, and the leave-one-out
samples of the jackknife are gathered by one index array instead of a Python loop.  The
other helpers format and collect the notebook's tables and glue cells.
"""
from __future__ import annotations

import numpy as np

from .. import stats
from .houles import _filter_index, _mse_failed, _window_index


def _pooled(p, ok):
    """Pooled RMSE over the last axis: sqrt(sum(p) / sum(ok)) as the book's statistic
    computes it (NaN for a resample without a surviving run)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.sum(p, axis=-1) / np.sum(ok, axis=-1))


def _columns(mse, failed, spec):
    """Per run (m * ok, ok) of each filter of ``spec`` = (num, den or None, window)."""
    num, den, window = spec
    w = _window_index(window)
    cols = []
    for name, f in (("num", num), ("den", den)):
        if f is None:
            continue
        f = _filter_index(f, name, mse.shape[1])
        ok = ~failed[:, f]
        if ok.sum() < 2:
            raise ValueError(f"filter {f} survives fewer than 2 runs; no RMSE interval")
        okf = ok.astype(float)
        cols.append((np.where(ok, mse[:, f, w], 0.0) * okf, okf))
    return cols


def _stat(cols, idx):
    """The statistic of one spec on the resamples ``idx`` (b, n) of the runs."""
    r = [_pooled(p[idx], ok[idx]) for p, ok in cols]
    return r[0] if len(r) == 1 else r[0] / r[1]


def _pooled_cis(mse, failed, specs, *, seed=0):
    """Intervals of several pooled RMSEs and RMSE ratios on the same runs.

    ``mse`` (runs, filters, 3) per-run window mean squares, ``failed`` (runs, filters)
    bool; ``specs`` a list of ``(num, den, window)`` or ``(num, den, window, failed)``
    (a failure array of its own for that spec): ``den`` None for filter ``num``'s
    pooled RMSE (m) over the runs it did not fail (:func:`rmse_estimate_mse`), else the
    ratio of ``num``'s to ``den``'s, each over its own unfailed runs (:func:`rmse_ratio_mse`).
    Returns one :class:`~trackcore.stats.Estimate` per spec, equal to those functions'.
    """
    if not isinstance(specs, (list, tuple)) or not specs:
        raise TypeError(f"specs must be a non-empty list of (num, den, window), got {specs!r}")
    cols = []
    for s in specs:
        if not isinstance(s, tuple) or len(s) not in (3, 4):
            raise TypeError(f"each spec must be (num, den, window[, failed]), got {s!r}")
        m, fl = _mse_failed(mse, s[3] if len(s) == 4 else failed)
        cols.append(_columns(m, fl, s[:3]))
    n = m.shape[0]
    theta = [float(_stat(c, np.arange(n)[None])[0]) for c in cols]
    rng = np.random.default_rng(seed)
    boot = np.empty((len(specs), stats.N_BOOT))
    done = 0
    while done < stats.N_BOOT:
        b = min(stats._CHUNK // 4, stats.N_BOOT - done)
        idx = rng.integers(0, n, size=(b, n))
        for k, c in enumerate(cols):
            boot[k, done:done + b] = _stat(c, idx)
        done += b
    j = np.arange(n - 1)
    loo = j[None, :] + (j[None, :] >= np.arange(n)[:, None])  # run i left out of row i
    return [stats._bca(theta[k], boot[k], _stat(c, loo), stats.LEVEL, n, "BCa bootstrap")
            for k, c in enumerate(cols)]


def _errorbar(ax, x, ests, scale=1.0, **kw):
    """Draw the Estimates ``ests`` at ``x`` as points with their intervals (times ``scale``)."""
    v = scale * np.array([[e.value, e.lo, e.hi] for e in ests])
    return ax.errorbar(x, v[:, 0], yerr=[v[:, 0] - v[:, 1], v[:, 2] - v[:, 0]],
                       capsize=3, **kw)


def _rmse_rows(table, paper, names, paper_ratio_tom, windows):
    """Table 1's RMSE and ratio rows: paper and book side by side per filter
    (``table`` a :class:`~trackcore.scenarios.houles.HoulesTable`)."""
    rows = []
    for w, win in enumerate(windows):
        rows.append([f"RMSE {win} (m)"] + sum(
            ([f"{paper[n][w]:.2f}" if n in paper else "(lost)", f"{table.rmse[f][w]:.2f}"]
             for f, n in enumerate(names)), []))
    for w, win in enumerate(windows):
        rows.append([f"ratio {win}", "100 %", "100 %",
                     f"{100 * paper['CAR'][w] / paper['Singer'][w]:.2f} %",
                     f"{table.ratio[1][w]:.1%}", paper_ratio_tom[w] + " %",
                     f"{table.ratio[2][w]:.1%}"])
    for w, win in enumerate(windows):
        rows.append([f"ratio {win}, common survivors", "—", "100 %", "—",
                     f"{table.ratio_common[1][w]:.1%}", "—",
                     f"{table.ratio_common[2][w]:.1%}"])
    return rows


#: Singer's and CAR's Table 1 cells: (key, num, den, window), their failure runs the
#: default definition's; Singer's total and manoeuvring cells under every definition.
BASELINE_200 = (("singer_non", 0, None, "non-manoeuvring"), ("car_total", 1, None, "total"),
                ("car_man", 1, None, "manoeuvring"), ("car_ratio_total", 1, 0, "total"),
                ("car_ratio_man", 1, 0, "manoeuvring"))


def _baseline_cells(mse, cells, paper_singer, d200):
    """Singer's and CAR's Table 1 cells at one gate, every interval on one set of
    resamples.  ``cells`` maps each failure definition to its :class:`FailureCell`
    (``.failed`` (runs, filters), Singer 0 and CAR 1) and ``d200`` names the default one;
    returns ``{(definition, key): Estimate}``: ``singer_total`` and ``singer_man`` as a
    fraction of ``paper_singer`` (total, manoeuvring) under every definition, the
    :data:`BASELINE_200` keys under ``d200`` (RMSE in m, ratios as fractions)."""
    if d200 not in cells:
        raise ValueError(f"d200 must be one of the definitions, got {d200!r}")
    keys, specs = [], []
    for d, c in cells.items():
        for key, w in (("singer_total", "total"), ("singer_man", "manoeuvring")):
            keys.append((d, key))
            specs.append((0, None, w, c.failed))
    for key, num, den, w in BASELINE_200:
        keys.append((d200, key))
        specs.append((num, den, w, cells[d200].failed))
    out = dict(zip(keys, _pooled_cis(mse, None, specs)))
    for d in cells:
        for key, c in (("singer_total", paper_singer[0]), ("singer_man", paper_singer[1])):
            e = out[d, key]
            out[d, key] = stats.Estimate(e.value / c, e.lo / c, e.hi / c, e.level, e.n,
                                         e.method)
    return out
