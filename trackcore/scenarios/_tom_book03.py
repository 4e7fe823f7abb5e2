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


def _pooled(p, oks):
    """Pooled RMSE over the last axis: sqrt(sum(p) / oks), ``oks`` the summed survival
    flags, as the book's statistic computes it (NaN for a resample without a survivor)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.sum(p, axis=-1) / oks)


def _columns(mse, failed, query, oks):
    """Per filter of ``query`` = (num, den or None, window): (m * ok per run, the key of
    its ok column in ``oks``, filled here: one column per failure array and filter)."""
    num, den, window = query
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
        key = (id(failed), f)
        oks.setdefault(key, okf)
        cols.append((np.where(ok, mse[:, f, w], 0.0) * okf, key))
    return cols


def _stat(cols, idx, sums):
    """The statistic of one query on the resamples ``idx`` (b, n) of the runs, ``sums``
    the ok columns summed over the same resamples."""
    r = [_pooled(p[idx], sums[key]) for p, key in cols]
    return r[0] if len(r) == 1 else r[0] / r[1]


def _pooled_cis(mse, failed, queries, *, seed=0):
    """Intervals of several pooled RMSEs and RMSE ratios on the same runs.

    ``mse`` (runs, filters, 3) per-run window mean squares, ``failed`` (runs, filters)
    bool; ``queries`` a list of ``(num, den, window)`` or ``(num, den, window, failed)``
    (a failure array of its own for that query): ``den`` None for filter ``num``'s
    pooled RMSE (m) over the runs it did not fail (:func:`rmse_estimate_mse`), else the
    ratio of ``num``'s to ``den``'s, each over its own unfailed runs (:func:`rmse_ratio_mse`).
    Returns one :class:`~trackcore.stats.Estimate` per query, equal to those functions'.
    """
    if not isinstance(queries, (list, tuple)) or not queries:
        raise TypeError(f"queries must be a non-empty list of (num, den, window), got {queries!r}")
    cols, oks, checked = [], {}, []
    for s in queries:
        if not isinstance(s, tuple) or len(s) not in (3, 4):
            raise TypeError(f"each query must be (num, den, window[, failed]), got {s!r}")
        m, fl = _mse_failed(mse, s[3] if len(s) == 4 else failed)
        checked.append(fl)  # keeps every failure array alive: its id keys its ok columns
        cols.append(_columns(m, fl, s[:3], oks))
    n = m.shape[0]

    def stats_on(idx):
        sums = {key: np.sum(ok[idx], axis=-1) for key, ok in oks.items()}
        return [_stat(c, idx, sums) for c in cols]

    theta = [float(v[0]) for v in stats_on(np.arange(n)[None])]
    rng = np.random.default_rng(seed)
    boot = np.empty((len(queries), stats.N_BOOT))
    done = 0
    while done < stats.N_BOOT:
        b = min(stats._CHUNK // 4, stats.N_BOOT - done)
        boot[:, done:done + b] = stats_on(rng.integers(0, n, size=(b, n)))
        done += b
    j = np.arange(n - 1)
    jack = stats_on(j[None, :] + (j[None, :] >= np.arange(n)[:, None]))  # row i: run i out
    return [stats._bca(theta[k], boot[k], jack[k], stats.LEVEL, n, "BCa bootstrap")
            for k in range(len(queries))]


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
        row = [f"RMSE {win} (m)"]
        for f, n in enumerate(names):
            row += [f"{paper[n][w]:.2f}" if n in paper else "(lost)", f"{table.rmse[f][w]:.2f}"]
        rows.append(row)
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


#: Singer's and CAR's Table 1 cells: (key, num, den, window); Singer's total and
#: manoeuvring RMSE are read as a fraction of the paper's column.
BASELINE = (("singer_total", 0, None, "total"), ("singer_man", 0, None, "manoeuvring"),
            ("singer_non", 0, None, "non-manoeuvring"), ("car_total", 1, None, "total"),
            ("car_man", 1, None, "manoeuvring"), ("car_ratio_total", 1, 0, "total"),
            ("car_ratio_man", 1, 0, "manoeuvring"))


def _baseline_cells(mse, cells, paper_singer):
    """Singer's and CAR's Table 1 cells at one gate under every failure definition, every
    interval on one set of resamples.  ``cells`` maps each definition to its
    :class:`FailureCell` (``.failed`` (runs, filters), Singer 0 and CAR 1); returns
    ``{(definition, key): Estimate}`` for the :data:`BASELINE` keys: RMSE in m, ratios
    as fractions, ``singer_total`` and ``singer_man`` as a fraction of ``paper_singer``
    (the paper's total and manoeuvring Singer RMSE)."""
    if not cells:
        raise ValueError("cells must hold at least one failure definition")
    keys, queries = [], []
    for d, c in cells.items():
        for key, num, den, w in BASELINE:
            keys.append((d, key))
            queries.append((num, den, w, c.failed))
    out = dict(zip(keys, _pooled_cis(mse, None, queries)))
    for d in cells:
        for key, c in (("singer_total", paper_singer[0]), ("singer_man", paper_singer[1])):
            e = out[d, key]
            out[d, key] = stats.Estimate(e.value / c, e.lo / c, e.hi / c, e.level, e.n,
                                         e.method)
    return out
