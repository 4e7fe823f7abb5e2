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
* ``check_result_cov(P, what, arguments)``: the same PSD rule applied to a
  covariance (or a stack of them) that a call returns; raises ``ValueError``
  naming the argument whose negative eigenvalue (rounding at its own scale)
  is not rounding at the result's, and projects a result that fails through
  the computation's own rounding onto the PSD cone.  The common case costs one Cholesky
  factorisation per matrix: a matrix that factorises is positive definite to
  rounding and passes the rule; only the others are eigen-decomposed.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_covariance, covariance_result_violation,
                               psd_projection)

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


@nb.njit(cache=True, inline="always")
def _factorises(P, j, L, D):
    """True when ``P[j] = L D L^T`` (unit lower ``L``) has every pivot ``D > 0``: the
    Cholesky test without square roots (``L``, ``D`` scratch)."""
    n = P.shape[1]
    for a in range(n):
        for b in range(a):
            s = P[j, a, b]
            for k in range(b):
                s -= L[a, k] * L[b, k] * D[k]
            L[a, b] = s / D[b]
        s = P[j, a, a]
        for k in range(a):
            s -= L[a, k] * L[a, k] * D[k]
        if not s > 0.0:
            return False
        D[a] = s
    return True


@nb.njit(cache=True)
def _all_factorise(P):
    """True when every matrix of the C-contiguous (r, n, n) stack ``P`` factorises."""
    L = np.empty((P.shape[1], P.shape[1]))
    D = np.empty(P.shape[1])
    for j in range(P.shape[0]):
        if not _factorises(P, j, L, D):
            return False
    return True


def check_result_cov(P, what: str, arguments) -> bool:
    """Apply the PSD rule of :func:`trackcore.core.validation.as_covariance` to the
    result ``P`` ((n, n) or (r, n, n), float64, C-contiguous, finite) computed from the
    ``(name, covariance)`` pairs ``arguments``.  A matrix that fails it raises
    ``ValueError`` naming the arguments with a negative eigenvalue; when no argument
    has one, the failure is rounding of the computation and the failing matrices are
    replaced in place by their PSD projection.  Returns True when ``P`` was changed
    (never for a result that passes the rule)."""
    if P.shape[-1] == 0 or _all_factorise(P.reshape((-1,) + P.shape[-2:])):
        return False
    found = covariance_result_violation(P, what, arguments)
    if found is None:
        return False
    msg, blamed, bad = found
    if blamed:
        raise ValueError(msg)
    stack = P.reshape((-1,) + P.shape[-2:])
    for j in bad:
        stack[j] = psd_projection(stack[j])
    return True
