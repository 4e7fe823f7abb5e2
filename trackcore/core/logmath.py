"""Log-space maths: log-sum-exp and Gaussian log-densities via Cholesky.

Probabilities that can underflow travel as logarithms.  The ``*_kernel``
functions are numba kernels for use inside other kernels; they assume valid,
contiguous float64 input and are not public (the package imports them from
this module).

``-inf`` is a weight of zero and is allowed wherever log-weights travel; NaN
and ``+inf`` are not (a weight of infinity has no normalisation), and both
:func:`logsumexp` and :func:`normalize_log_weights` reject them with a
``ValueError``.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from .validation import as_array, as_covariance, as_vector

__all__ = [
    "logsumexp",
    "normalize_log_weights",
    "gaussian_logpdf",
    "LOG_2PI",
]

LOG_2PI = math.log(2.0 * math.pi)


@nb.njit(cache=True, fastmath=False)
def logsumexp_kernel(a):
    """log(sum(exp(a))) of a 1-D array; -inf for an empty or all -inf array."""
    n = a.shape[0]
    if n == 0:
        return -np.inf
    amax = -np.inf
    for i in range(n):
        if a[i] > amax:
            amax = a[i]
    if amax == -np.inf:
        return -np.inf
    if amax == np.inf:
        return np.inf
    s = 0.0
    for i in range(n):
        s += math.exp(a[i] - amax)
    return amax + math.log(s)


@nb.njit(cache=True)
def normalize_log_weights_kernel(logw):
    """Normalise log-weights in place; returns the log of the total mass."""
    total = logsumexp_kernel(logw)
    if total == -np.inf:
        return total
    for i in range(logw.shape[0]):
        logw[i] -= total
    return total


def logsumexp(a, axis=None):
    """Stable ``log(sum(exp(a)))``; ``-inf`` entries are allowed (zero mass).

    With ``axis=None`` the whole array is reduced to a float; otherwise the
    reduction runs along ``axis`` like :func:`scipy.special.logsumexp`.  An
    empty reduction, or one over ``-inf`` entries only, is ``-inf`` (the log
    of a zero sum).  NaN and ``+inf`` entries raise ``ValueError``, as in
    :func:`normalize_log_weights`: a term of infinite mass leaves nothing to
    compare the others with.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import logsumexp
    >>> round(logsumexp(np.array([1000.0, 1000.0])), 4)       # no overflow: 1000 + log 2
    1000.6931
    >>> logsumexp(np.array([-np.inf, -np.inf]))              # zero total mass
    -inf
    >>> print(np.round(logsumexp(np.log([[1.0, 3.0], [2.0, 2.0]]), axis=1), 4))
    [1.3863 1.3863]
    """
    arr = as_array(a, "a", finite=False)
    if np.any(np.isnan(arr)) or np.any(arr == np.inf):
        raise ValueError("a must not contain NaN or +inf")
    if axis is None:
        return float(logsumexp_kernel(arr.ravel()))
    if isinstance(axis, (bool, np.bool_)) or not isinstance(axis, (int, np.integer)):
        raise TypeError(f"axis must be an integer or None, got {type(axis).__name__}")
    if not -arr.ndim <= axis < arr.ndim:
        raise ValueError(f"axis={axis} is out of range for an array with {arr.ndim} "
                         "dimension(s)")
    moved = np.moveaxis(arr, axis, -1)
    flat = np.ascontiguousarray(moved.reshape(math.prod(moved.shape[:-1]), moved.shape[-1]))
    out = np.empty(flat.shape[0])
    for i in range(flat.shape[0]):
        out[i] = logsumexp_kernel(flat[i])
    return out.reshape(moved.shape[:-1])


def normalize_log_weights(logw):
    """Return ``(normalised log-weights, log total)`` of a 1-D array.

    Raises ``ValueError`` when every weight is zero (all ``-inf``): there is
    no distribution to normalise, and silently returning NaN would hide it.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import normalize_log_weights
    >>> logw, log_total = normalize_log_weights(np.log([1.0, 3.0]))
    >>> print(np.round(np.exp(logw), 4), round(log_total, 4))
    [0.25 0.75] 1.3863
    """
    w = as_array(logw, "logw", ndim=1, finite=False).copy()
    if np.any(np.isnan(w)) or np.any(w == np.inf):
        raise ValueError("logw must not contain NaN or +inf")
    total = normalize_log_weights_kernel(w)
    if total == -np.inf:
        raise ValueError("logw has zero total weight (all entries are -inf)")
    return w, float(total)


@nb.njit(cache=True)
def cholesky_logpdf_kernel(r, L):
    """log N(r; 0, L L^T) for a residual ``r`` and lower Cholesky factor ``L``."""
    n = r.shape[0]
    # forward substitution L y = r
    y = np.empty(n)
    logdet_half = 0.0
    for i in range(n):
        s = r[i]
        for j in range(i):
            s -= L[i, j] * y[j]
        y[i] = s / L[i, i]
        logdet_half += math.log(L[i, i])
    maha = 0.0
    for i in range(n):
        maha += y[i] * y[i]
    return -0.5 * (n * 1.8378770664093453 + maha) - logdet_half


def gaussian_logpdf(x, mean, cov):
    """log N(x; mean, cov) using a Cholesky factorisation.

    ``x`` may be one point ``(n,)`` or a batch ``(k, n)`` (returns ``(k,)``).
    ``cov`` must be symmetric positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import LOG_2PI, gaussian_logpdf
    >>> round(gaussian_logpdf([0.0, 0.0], [0.0, 0.0], np.eye(2)), 4)
    -1.8379
    >>> round(-LOG_2PI, 4)                                    # the same: log(1 / (2 pi))
    -1.8379
    >>> round(gaussian_logpdf([1.0], [0.0], [[4.0]]), 4)
    -1.7371
    """
    mean = as_vector(mean, "mean")
    n = mean.shape[0]
    cov = as_covariance(cov, "cov", n)
    xa = as_array(x, "x", ndim=(1, 2))
    single = xa.ndim == 1
    if xa.shape[-1] != n:
        raise ValueError(f"x must have last dimension {n}, got shape {xa.shape}")
    xa = xa.reshape(-1, n)
    try:
        L = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        raise ValueError("cov must be positive definite") from None
    out = np.empty(xa.shape[0])
    for i in range(xa.shape[0]):
        out[i] = cholesky_logpdf_kernel(xa[i] - mean, L)
    return float(out[0]) if single else out
