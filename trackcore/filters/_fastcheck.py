"""Cheap repeat validation for the filters' public wrappers (private module).

The whole-run kernels are called once per Monte Carlo run with the same model
matrices; re-running the full checks of :mod:`trackcore.core.validation`
(eigenvalues, dtype inspection) each time costs more than a 100-step run.
These helpers give the same results as the core checks:

* ``checked(x, name, shape)``: a C-contiguous float64 ndarray of exactly
  ``shape`` whose entries are finite is returned as is (what ``as_array``
  returns for it); anything else goes through ``as_array`` (which converts
  or raises the usual error).
* ``checked_cov(x, name, n)``: ``as_covariance``, memoised on the matrix
  bytes, so a covariance already accepted is not eigen-decomposed again.
  Only successes are cached (errors are always re-raised by the core check).
"""
from __future__ import annotations

import math

import numpy as np

from ..core.validation import as_array, as_covariance

_COV_CACHE: dict = {}
_COV_CACHE_MAX = 512


def _plain(x, shape) -> bool:
    return (type(x) is np.ndarray and x.dtype == np.float64 and x.shape == shape
            and x.flags.c_contiguous)


def checked(x, name: str, shape: tuple) -> np.ndarray:
    if _plain(x, shape) and math.isfinite(x.sum()):
        return x
    return as_array(x, name, shape=shape)


def checked_cov(x, name: str, n: int) -> np.ndarray:
    if _plain(x, (n, n)):
        key = (n, x.tobytes())
        hit = _COV_CACHE.get(key)
        if hit is not None:
            return hit
        out = as_covariance(x, name, n)
        if len(_COV_CACHE) >= _COV_CACHE_MAX:
            _COV_CACHE.clear()
        _COV_CACHE[key] = out
        return out
    return as_covariance(x, name, n)


def checked_cov_stack(x, name: str, r: int, n: int) -> np.ndarray:
    """An (r, n, n) stack of covariances, each checked as ``name[j]``."""
    if _plain(x, (r, n, n)):
        key = (r, n, x.tobytes())
        hit = _COV_CACHE.get(key)
        if hit is not None:
            return hit
    arr = as_array(x, name, shape=(r, n, n))
    out = np.ascontiguousarray(np.stack([as_covariance(arr[j], f"{name}[{j}]", n)
                                         for j in range(r)]))
    if _plain(x, (r, n, n)):
        if len(_COV_CACHE) >= _COV_CACHE_MAX:
            _COV_CACHE.clear()
        _COV_CACHE[(r, n, x.tobytes())] = out
    return out
