"""Marcum Q1: trackcore against scipy's non-central chi-square distribution.

``Q1(a, b) = P(X > b^2)`` for ``X`` non-central chi-square with 2 degrees of freedom and
non-centrality ``a^2``, so ``scipy.stats.ncx2.sf(b**2, 2, a**2)`` (Boost's algorithm) is
``Q1`` and ``ncx2.cdf`` is ``1 - Q1``; ``scipy.special.chndtr`` is the same cdf as a bare
ufunc (no distribution-object overhead).  Workload of the book's detection chapters: ``a =
sqrt(2 SNR)`` at SNR 0, 2, ..., 40 dB, ``b = sqrt(2 ln 10^6)`` (``P_fa = 1e-6``).

* Per element: arrays of 10^4 values (SNR spread by 1 % so that no two are equal);
  trackcore ``marcum_q1(a, b)`` and ``marcum_q1_complement(a, b)`` against ``ncx2.sf`` and
  ``ncx2.cdf`` / ``chndtr``.
* Per scalar call: one Python float at a time, ``marcum_q1`` against ``ncx2.sf``.

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
    b = math.sqrt(-2.0 * math.log(PFA))
    rows = []
    marcum_q1(np.ones(4), b)            # load the compiled kernels
    marcum_q1_complement(np.ones(4), b)
    marcum_q1(1.0, b)
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
        paths = {
            "trackcore_q1": lambda: marcum_q1(a, bb),
            "scipy_ncx2_sf": lambda: ncx2.sf(b2, 2, a2),
            "trackcore_q1_complement": lambda: marcum_q1_complement(a, bb),
            "scipy_ncx2_cdf": lambda: ncx2.cdf(b2, 2, a2),
            "scipy_chndtr": lambda: special.chndtr(b2, 2.0, a2),
        }
        times = {k: [] for k in paths}
        for _ in range(REPS):                       # interleaved
            for k, fn in paths.items():
                times[k].append(_time(fn) / N_ELEMENTS)
        common = {"snr_db": db, "noncentrality_a2": float(2.0 * 10.0 ** (db / 10.0)),
                  "b": b, "pfa": PFA, "elements": N_ELEMENTS, **agree}
        for k in paths:
            extra = {}
            if k == "scipy_ncx2_sf":
                extra["ratio_to_trackcore"] = _ratios(times["trackcore_q1"], times[k])
            elif k in ("scipy_ncx2_cdf", "scipy_chndtr"):
                extra["ratio_to_trackcore"] = _ratios(times["trackcore_q1_complement"], times[k])
            rows.append(record("marcum_array", k, db, median(times[k]), unit="element",
                               trials=times[k], **extra, **common))
    for db in SCALAR_SNR_DB:
        a = math.sqrt(2.0 * 10.0 ** (db / 10.0))
        if not math.isclose(marcum_q1(a, b), float(ncx2.sf(b * b, 2, a * a)), rel_tol=1e-9):
            raise AssertionError(f"Marcum Q scalar at {db} dB differs from scipy")
        paths = {"trackcore_q1": lambda: marcum_q1(a, b),
                 "scipy_ncx2_sf": lambda: ncx2.sf(b * b, 2, a * a)}
        times = {k: [] for k in paths}
        for _ in range(REPS):
            for k, fn in paths.items():
                times[k].append(_time(fn, min_seconds=0.01))
        for k in paths:
            extra = {}
            if k == "scipy_ncx2_sf":
                extra["ratio_to_trackcore"] = _ratios(times["trackcore_q1"], times[k])
            rows.append(record("marcum_scalar", k, db, median(times[k]), unit="call",
                               trials=times[k], snr_db=db, b=b, pfa=PFA, **extra))
    return rows


WORKLOADS = {"marcum": bench_marcum}
