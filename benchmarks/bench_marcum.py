"""Marcum Q1: trackcore against scipy's non-central chi-square distribution.

``Q1(a, b) = P(X > b^2)`` for ``X`` non-central chi-square with 2 degrees of freedom and
non-centrality ``a^2``, so ``scipy.stats.ncx2.sf(b**2, 2, a**2)`` (Boost's algorithm) is
``Q1`` and ``ncx2.cdf`` is ``1 - Q1``.  The distribution object checks and broadcasts its
arguments in Python before it calls a ufunc; the bare ufuncs are
``scipy.special.chndtr`` (the cdf, public) and ``scipy.special._ufuncs._ncx2_sf`` (the sf
that ``ncx2.sf`` calls; private, so looked up defensively).  Workload of the book's
detection chapters: ``a = sqrt(2 SNR)`` at SNR 0, 2, ..., 40 dB, ``b = sqrt(2 ln 10^6)``
(``P_fa = 1e-6``).

* Per element: arrays of 10^4 values (SNR spread by 1 % so that no two are equal);
  trackcore ``marcum_q1(a, b)`` against ``ncx2.sf`` and the bare sf ufunc, and
  ``marcum_q1_complement(a, b)`` against ``ncx2.cdf`` and ``chndtr``.
* Per scalar call: one Python float at a time, the same four comparisons.

Before timing, the values are compared: relative difference to ``ncx2.sf`` where scipy's
value is above 1e-290, to ``ncx2.cdf`` where it is above 1e-12 (below that scipy's cdf
loses relative accuracy; trackcore's accuracy against a 60-digit reference is tested in
``tests/test_marcum_regimes.py``).  Repetitions interleave trackcore and scipy; each
repetition's ratio is stored.
"""
from __future__ import annotations

import math
from statistics import median

import numpy as np

from trackcore.detection import marcum_q1, marcum_q1_complement

from ._common import Stopwatch, record


def _bare_sf():
    """SciPy's bare non-central chi-square sf ufunc, or None if this SciPy has none."""
    try:
        from scipy.special._ufuncs import _ncx2_sf
    except ImportError:
        return None
    return _ncx2_sf

SNR_DB = tuple(float(x) for x in np.arange(0.0, 40.01, 2.0))
SCALAR_SNR_DB = (0.0, 10.0, 20.0, 30.0, 40.0)
PFA = 1e-6
N_ELEMENTS = 10_000
REPS = 7


def _time(fn, min_seconds=0.02, max_calls=100_000):
    """CPU seconds per call of ``fn``, repeated until ``min_seconds`` of CPU time."""
    fn()
    n = 1
    while True:
        with Stopwatch() as sw:
            for _ in range(n):
                fn()
        if sw.cpu >= min_seconds or n >= max_calls:
            return sw.cpu / n
        n = min(max_calls, max(2 * n, int(n * 1.5 * min_seconds / max(sw.cpu, 1e-6))))


def _ratios(ours, peer):
    r = [p / o for o, p in zip(ours, peer)]
    return {"median": median(r), "min": min(r), "max": max(r), "per_repetition": r}


def bench_marcum() -> list[dict]:
    from scipy import special
    from scipy.stats import ncx2

    rng = np.random.default_rng(20261124)
    sf_ufunc = _bare_sf()
    b = math.sqrt(-2.0 * math.log(PFA))
    rows = []
    marcum_q1(np.ones(4), b)            # load the compiled kernels
    marcum_q1_complement(np.ones(4), b)
    marcum_q1(1.0, b)
    marcum_q1_complement(1.0, b)
    for db in SNR_DB:
        snr = 10.0 ** (db / 10.0) * (1.0 + 0.01 * rng.random(N_ELEMENTS))
        a = np.sqrt(2.0 * snr)
        bb = np.full(N_ELEMENTS, b)
        a2, b2 = a * a, bb * bb
        q, qc = marcum_q1(a, bb), marcum_q1_complement(a, bb)
        sf, cdf = ncx2.sf(b2, 2, a2), ncx2.cdf(b2, 2, a2)
        ok_sf, ok_cdf = sf > 1e-290, cdf > 1e-12
        agree = {
            "sf_max_rel_diff": float(np.max(np.abs(q[ok_sf] / sf[ok_sf] - 1.0), initial=0.0)),
            "sf_compared": int(ok_sf.sum()),
            "cdf_max_rel_diff": float(np.max(np.abs(qc[ok_cdf] / cdf[ok_cdf] - 1.0),
                                             initial=0.0)),
            "cdf_compared": int(ok_cdf.sum()),
            "scipy_sf_zero_where_trackcore_positive": int(np.sum((sf == 0) & (q > 0))),
        }
        if agree["sf_max_rel_diff"] > 1e-9 or agree["cdf_max_rel_diff"] > 1e-9:
            raise AssertionError(f"Marcum Q at {db} dB: trackcore and scipy differ: {agree}")
        if sf_ufunc is not None and not np.array_equal(sf_ufunc(b2, 2.0, a2), sf):
            raise AssertionError("the bare sf ufunc is not what ncx2.sf computes")
        paths = {
            "trackcore_q1": lambda: marcum_q1(a, bb),
            "scipy_ncx2_sf": lambda: ncx2.sf(b2, 2, a2),
            "trackcore_q1_complement": lambda: marcum_q1_complement(a, bb),
            "scipy_ncx2_cdf": lambda: ncx2.cdf(b2, 2, a2),
            "scipy_chndtr": lambda: special.chndtr(b2, 2.0, a2),
        }
        if sf_ufunc is not None:
            paths["scipy_ncx2_sf_ufunc"] = lambda: sf_ufunc(b2, 2.0, a2)
        times = {k: [] for k in paths}
        for _ in range(REPS):                       # interleaved
            for k, fn in paths.items():
                times[k].append(_time(fn) / N_ELEMENTS)
        common = {"snr_db": db, "noncentrality_a2": float(2.0 * 10.0 ** (db / 10.0)),
                  "b": b, "pfa": PFA, "elements": N_ELEMENTS, **agree}
        for k in paths:
            extra = {}
            if k in PEER_OF:
                extra["ratio_to_trackcore"] = _ratios(times[PEER_OF[k]], times[k])
            rows.append(record("marcum_array", k, db, median(times[k]), unit="element",
                               trials=times[k], **extra, **common))
    for db in SCALAR_SNR_DB:
        a = math.sqrt(2.0 * 10.0 ** (db / 10.0))
        a2, b2 = a * a, b * b
        if not math.isclose(marcum_q1(a, b), float(ncx2.sf(b2, 2, a2)), rel_tol=1e-9):
            raise AssertionError(f"Marcum Q scalar at {db} dB differs from scipy")
        qc = marcum_q1_complement(a, b)
        if qc > 1e-12 and not math.isclose(qc, float(special.chndtr(b2, 2.0, a2)),
                                           rel_tol=1e-9):
            raise AssertionError(f"Marcum 1 - Q scalar at {db} dB differs from scipy")
        paths = {"trackcore_q1": lambda: marcum_q1(a, b),
                 "scipy_ncx2_sf": lambda: ncx2.sf(b2, 2, a2),
                 "trackcore_q1_complement": lambda: marcum_q1_complement(a, b),
                 "scipy_chndtr": lambda: special.chndtr(b2, 2.0, a2)}
        if sf_ufunc is not None:
            paths["scipy_ncx2_sf_ufunc"] = lambda: sf_ufunc(b2, 2.0, a2)
        times = {k: [] for k in paths}
        for _ in range(REPS):
            for k, fn in paths.items():
                times[k].append(_time(fn, min_seconds=0.01))
        for k in paths:
            extra = {}
            if k in PEER_OF:
                extra["ratio_to_trackcore"] = _ratios(times[PEER_OF[k]], times[k])
            rows.append(record("marcum_scalar", k, db, median(times[k]), unit="call",
                               trials=times[k], snr_db=db, b=b, pfa=PFA, **extra))
    return rows


#: the trackcore path each SciPy path is compared with
PEER_OF = {"scipy_ncx2_sf": "trackcore_q1", "scipy_ncx2_sf_ufunc": "trackcore_q1",
           "scipy_ncx2_cdf": "trackcore_q1_complement",
           "scipy_chndtr": "trackcore_q1_complement"}


WORKLOADS = {"marcum": bench_marcum}
