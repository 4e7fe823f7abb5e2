"""Particle-filter kernels: propagation, weighting, ESS, resampling.

Particles are ``(N, n)`` C-contiguous float64 arrays and weights travel as
``(N,)`` log-weights.  Every public function validates its input once and
then calls a ``@numba.njit(cache=True)`` kernel; the ``*_kernel`` functions
take plain arrays of the right shapes (and a ``numpy.random.Generator`` where
randomness is needed), check nothing, and are called from other numba kernels
(the trackers import them from this module; they are not public).

Log-weights are never NaN.  A particle whose log-likelihood is not finite (its
state so far away that the squared innovation overflows, or a state that is
itself not finite) gets the log-weight ``-inf``: weight zero, never selected by
resampling.  When every particle of a step gets weight zero there is no
posterior, and :func:`bootstrap_step` raises ``ValueError``.  On finite input
these rules change no bit of any result.

Random draws are always made serially in a fixed order, so every result is
a deterministic function of the generator's state.  On request
(``parallel=True``) the element-wise move-and-weigh / likelihood passes run
on numba threads (identical results); all reductions are serial.  Serial is
the default: on a shared machine, or under a Monte Carlo that already uses
every core, threads slow these loops down.

Resampling schemes (all O(N), one pass over the cumulative weights):

* systematic -- one uniform ``u0``; positions ``(u0 + i) / N``;
* stratified -- one uniform per stratum; positions ``(u_i + i) / N``;
* multinomial -- ``N`` i.i.d. uniforms, generated already sorted via
  normalised cumulative exponential spacings (no sort, no binary search);
* residual -- ``floor(N w_i)`` deterministic copies, the remaining
  ``R = N - sum floor(N w_i)`` drawn *systematically* from the residual
  weights (so every count lies in ``[floor(N w_i), ceil(N w_i)]``).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.logmath import logsumexp_kernel
from ..core.validation import (as_array, as_covariance, as_int, as_matrix, as_rng,
                               as_scalar, as_square_matrix, as_vector, finite_result)
from ..models.measurement import wrap_angle_kernel
from ._fastcheck import checked

__all__ = [
    "noise_factor",
    "propagate_linear",
    "effective_sample_size",
    "systematic_resample",
    "stratified_resample",
    "residual_resample",
    "multinomial_resample",
    "RESAMPLING_SCHEMES",
    "resample_particles",
    "loglik_gaussian_position",
    "loglik_range_bearing",
    "BootstrapStep",
    "bootstrap_step",
    "MODEL_POSITION",
    "MODEL_RANGE_BEARING",
    "weighted_mean_cov",
]

_LOG_2PI = math.log(2.0 * math.pi)

#: measurement-model codes for :func:`bootstrap_step_kernel`
MODEL_POSITION = 0
MODEL_RANGE_BEARING = 1
_MODELS = {"position": MODEL_POSITION, "range_bearing": MODEL_RANGE_BEARING}

#: names accepted by ``scheme=``
RESAMPLING_SCHEMES = ("systematic", "stratified", "residual", "multinomial")

# Particle loops run serially unless a public function is called with
# ``parallel=True``: on a shared machine, or inside a Monte Carlo that already
# runs one process per core, nested threading is a slowdown (measured 2-6x
# slower at N = 1e5 with a load average of 5).  The ``*_kernel`` functions
# never reach a ``parallel=True`` function: a cached parallel kernel linked
# into a caller's kernel aborts LLVM in a fresh process ("Symbol not found:
# allocate_sched") unless numba's thread pool was started, and a process that
# has started GNU OpenMP threads must not fork (see trackcore.montecarlo).
_PARALLEL_MIN = 20000  # threads only for N >= this, and only on request


# --------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------
def noise_factor(Q, name: str = "Q", rtol: float = 1e-12):
    """A factor ``L`` (``(n, k)``, ``k = rank Q``) with ``Q = L L^T``.

    Works for positive semi-definite, singular ``Q`` (e.g. the rank-2 DWNA
    process noise of a 4-state CV model) via a symmetric eigendecomposition;
    eigenvalues below ``rtol * max eigenvalue`` are dropped, so only ``k``
    normal draws per particle are needed.  ``Q = 0`` gives an ``(n, 0)``
    factor (noise-free propagation).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import noise_factor
    >>> Q = np.array([[1.0, 1.0], [1.0, 1.0]])     # rank 1
    >>> L = noise_factor(Q)
    >>> L.shape
    (2, 1)
    >>> bool(np.allclose(L @ L.T, Q))
    True
    """
    Q = as_covariance(Q, name)
    n = Q.shape[0]
    if n == 0:
        return np.zeros((0, 0))
    lam, V = np.linalg.eigh(Q)
    top = max(float(lam[-1]), 0.0)
    keep = lam > rtol * top if top > 0 else np.zeros(n, dtype=bool)
    L = V[:, keep] * np.sqrt(lam[keep])
    return np.ascontiguousarray(L[:, ::-1])  # largest variance first


_noise_factor = noise_factor  # propagate_linear's keyword shadows the name


def _as_particles(particles, name="particles", n=None):
    arr = as_array(particles, name, ndim=2)
    if n is not None and arr.shape[1] != n:
        raise ValueError(f"{name} must have shape (N, {n}), got {arr.shape}")
    return arr


def _as_logw(logw, N=None, name="logw"):
    w = as_array(logw, name, ndim=1, finite=False)
    if N is not None and w.shape[0] != N:
        raise ValueError(f"{name} must have shape ({N},), got {w.shape}")
    if np.any(np.isnan(w)) or np.any(w == np.inf):
        raise ValueError(f"{name} must not contain NaN or +inf")
    if w.size and not np.any(np.isfinite(w)):
        raise ValueError(f"{name} has zero total weight (all entries are -inf)")
    return w


def _as_weights(w, name="w"):
    arr = as_array(w, name, ndim=1, finite=False)
    if arr.size == 0:
        raise ValueError(f"{name} must not be empty")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (found NaN or inf)")
    if np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative")
    with np.errstate(over="ignore"):
        total = float(arr.sum())
    if not total > 0:
        raise ValueError(f"{name} must have a positive sum (all weights are zero)")
    if total < 1e-280 or total == math.inf:
        # keep the kernels' cumulative sums out of the subnormal range and below overflow
        arr = arr / arr.max()
        if not _finite_sum(arr):  # more than ~1e308 particles: not reachable
            raise ValueError(f"{name} has too many entries to sum")
    return arr


def _n_out(n_out, N):
    if n_out is None:
        return N
    return as_int(n_out, "n_out", minimum=0)


# --------------------------------------------------------------------------
# propagation
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def propagate_linear_kernel(particles, F, L, rng, out):
    """``out[i] = F particles[i] + L w_i``, ``w_i ~ N(0, I_k)``.

    ``L`` is ``(n, k)``; the ``k`` draws of particle ``i`` are taken in
    order from ``rng`` (``rng.standard_normal()``), particle by particle
    (all draws first, then one arithmetic pass).  ``out`` may be the same
    array as ``particles``.
    """
    N = particles.shape[0]
    k = L.shape[1]
    noise = np.empty((N, k))
    for i in range(N):
        for c2 in range(k):
            noise[i, c2] = rng.standard_normal()
    _move_range(particles, 0, N, F, L, noise, out)


def propagate_linear(particles, F, Q, rng, *, noise_factor=None, out=None):
    """Propagate particles through ``x' = F x + w``, ``w ~ N(0, Q)``.

    ``Q`` may be singular (PSD); it is factored as ``Q = L L^T`` by
    :func:`noise_factor`.  Pass ``noise_factor=L`` (``(n, k)`` with
    ``Q = L L^T``, e.g. ``Gamma * sigma``) to skip the factorisation, in which
    case ``Q`` may be ``None``.  Returns a new ``(N, n)`` array unless ``out``
    is given (which may be ``particles`` itself for in-place propagation).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import propagate_linear
    >>> from trackcore.models import cv_transition
    >>> particles = np.tile([0.0, 1.0], (1000, 1))
    >>> moved = propagate_linear(particles, cv_transition(1.0, dim=1), 0.01 * np.eye(2),
    ...                          np.random.default_rng(1))
    >>> moved.shape
    (1000, 2)
    >>> print(np.round(moved.mean(axis=0), 1))
    [1. 1.]
    """
    rng = as_rng(rng)
    X = _as_particles(particles)
    n = X.shape[1]
    F = as_square_matrix(F, "F", n)
    if noise_factor is None:
        if Q is None:
            raise ValueError("Q must be given when noise_factor is None")
        L = _noise_factor(Q, "Q")
        if L.shape[0] != n:
            raise ValueError(f"Q must be ({n}, {n}), got {np.shape(Q)}")
    else:
        L = as_matrix(noise_factor, "noise_factor", (n, None))
    if out is None:
        out = np.empty_like(X)
    else:
        if not (isinstance(out, np.ndarray) and out.dtype == np.float64
                and out.flags.c_contiguous and out.shape == X.shape):
            raise ValueError(f"out must be a C-contiguous float64 array of shape {X.shape}")
        if out is particles and X is not particles:
            raise ValueError("in-place propagation needs particles as a C-contiguous float64 array")
        if out is not particles and np.may_share_memory(out, X):
            raise ValueError("out must be particles itself or not overlap it")
    propagate_linear_kernel(X, F, L, rng, out)
    if not _finite_sum(out):
        finite_result(out, "the propagated particles", "particles, F and Q")
    return out


def _finite_sum(a) -> bool:
    """One pass: True when the sum is finite (then so is every entry); a sum of finite
    entries that overflows (numpy warns) sends the caller to the entry-wise check."""
    return math.isfinite(float(a.sum()))


# --------------------------------------------------------------------------
# effective sample size and moments
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def effective_sample_size_kernel(logw):
    """``1 / sum w_i^2`` of the normalised weights ``w ∝ exp(logw)``."""
    N = logw.shape[0]
    m = -np.inf
    for i in range(N):
        if logw[i] > m:
            m = logw[i]
    if m == -np.inf:
        return 0.0
    s1 = 0.0
    s2 = 0.0
    for i in range(N):
        e = math.exp(logw[i] - m)
        s1 += e
        s2 += e * e
    return s1 * s1 / s2


def effective_sample_size(logw):
    """Effective sample size ``1 / sum w^2`` from (unnormalised) log-weights.

    Lies in ``[1, N]``.  Raises ``ValueError`` for NaN/+inf entries or when all
    weights are zero.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import effective_sample_size
    >>> round(effective_sample_size(np.zeros(100)), 3)            # equal weights
    100.0
    >>> round(effective_sample_size(np.log([0.7, 0.1, 0.1, 0.1])), 3)
    1.923
    """
    w = _as_logw(logw)
    if w.size == 0:
        raise ValueError("logw must not be empty")
    return float(effective_sample_size_kernel(w))


@nb.njit(cache=True)
def weighted_mean_cov_kernel(particles, logw, mean, cov):
    """Weighted mean and covariance (``sum w (x-m)(x-m)^T``) into ``mean``, ``cov``."""
    N, n = particles.shape
    m = -np.inf
    for i in range(N):
        if logw[i] > m:
            m = logw[i]
    tot = 0.0
    for a in range(n):
        mean[a] = 0.0
        for b in range(n):
            cov[a, b] = 0.0
    for i in range(N):
        wi = math.exp(logw[i] - m)
        tot += wi
        if wi == 0.0:
            continue
        for a in range(n):
            mean[a] += wi * particles[i, a]
    for a in range(n):
        mean[a] /= tot
    for i in range(N):
        wi = math.exp(logw[i] - m) / tot
        if wi == 0.0:  # a zero weight adds nothing (and no NaN from a far particle)
            continue
        for a in range(n):
            da = particles[i, a] - mean[a]
            for b in range(a, n):
                cov[a, b] += wi * da * (particles[i, b] - mean[b])
    for a in range(n):
        for b in range(a + 1, n):
            cov[b, a] = cov[a, b]


def weighted_mean_cov(particles, logw):
    """``(mean (n,), cov (n, n))`` of the particle approximation.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import weighted_mean_cov
    >>> particles = np.array([[0.0], [2.0]])
    >>> mean, cov = weighted_mean_cov(particles, np.log([0.5, 0.5]))
    >>> print(mean, cov)
    [1.] [[1.]]
    """
    X = _as_particles(particles)
    if X.shape[0] == 0:
        raise ValueError("particles must not be empty")
    w = _as_logw(logw, X.shape[0])
    n = X.shape[1]
    mean = np.empty(n)
    cov = np.empty((n, n))
    weighted_mean_cov_kernel(X, w, mean, cov)
    finite_result(mean, "the weighted mean", "particles")
    finite_result(cov, "the weighted covariance", "particles")
    return mean, cov


# --------------------------------------------------------------------------
# resampling kernels (w non-negative, sum > 0; normalised internally)
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def _systematic_marks(w, total, u0, out):
    """Systematic resampling without a data-dependent inner loop.

    Position ``i`` is ``(u0 + i) / M * total``; the number of positions below
    the cumulative weight ``C_j`` is ``ceil(C_j M / total - u0)`` (clamped to
    [0, M]).  Each positive-weight particle marks the first output slot of its
    run, and a running maximum fills the runs: two branch-light passes instead
    of the classic while-loop whose branch is unpredictable.  Zero-weight
    particles are never selected.
    """
    M = out.shape[0]
    if M == 0:
        return
    cur = _systematic_run_marks(w, total, u0, out)
    for i in range(M):
        v = out[i]
        cur = v if v > cur else cur
        out[i] = cur


@nb.njit(cache=True)
def _systematic_run_marks(w, total, u0, out):
    """First pass of :func:`_systematic_marks`: ``out`` (length ``M >= 1``) gets
    the index of each run's particle at the run's first slot and 0 elsewhere;
    returns the first positive-weight index.  The output slot ``i`` then holds
    the running maximum of ``out[:i + 1]`` and that returned index.

    The run end ``min(ceil(C_j M / total - u0), M)`` is non-decreasing in
    ``j``; it is kept with a select, not a branch (a data-dependent branch
    here is mispredicted about every other particle once N outgrows the
    branch history, which cost ~4 ns per particle at N = 1e5)."""
    N = w.shape[0]
    M = out.shape[0]
    for i in range(M):
        out[i] = 0
    inv = M / total
    tiny = not math.isfinite(inv)
    if tiny:  # subnormal total: normalise each weight by division instead
        inv = float(M)
    cum = 0.0
    prev = 0
    first = -1
    for j in range(N):
        wj = w[j] / total if tiny else w[j]
        if wj > 0.0:
            if first < 0:
                first = j
            if prev < M:
                out[prev] = j
            cum += wj
            c = min(math.ceil(cum * inv - u0), M)
            prev = c if c > prev else prev
    return first


@nb.njit(cache=True)
def systematic_indices_kernel(w, u0, out):
    """Systematic resampling with offset ``u0`` in [0, 1): positions
    ``(u0 + i) / M`` (``M = len(out)``) against the cumulative weights."""
    total = 0.0
    for j in range(w.shape[0]):
        total += w[j]
    _systematic_marks(w, total, u0, out)


@nb.njit(cache=True)
def stratified_indices_kernel(w, u, out):
    """Stratified resampling: positions ``(u[i] + i) / M`` with ``u`` in [0, 1)."""
    N = w.shape[0]
    M = out.shape[0]
    total = 0.0
    for j in range(N):
        total += w[j]
    j = 0
    c = w[0]
    for i in range(M):
        pos = (u[i] + i) / M * total
        while pos >= c and j < N - 1:
            j += 1
            c += w[j]
        out[i] = j


@nb.njit(cache=True)
def systematic_resample_kernel(w, rng, out):
    """Systematic resampling; draws one ``rng.random()``."""
    systematic_indices_kernel(w, rng.random(), out)


@nb.njit(cache=True)
def stratified_resample_kernel(w, rng, out):
    """Stratified resampling; draws ``len(out)`` values of ``rng.random()``."""
    M = out.shape[0]
    u = np.empty(M)
    for i in range(M):
        u[i] = rng.random()
    stratified_indices_kernel(w, u, out)


@nb.njit(cache=True)
def multinomial_resample_kernel(w, rng, out):
    """Multinomial resampling in O(N): ``M`` sorted i.i.d. uniforms are made
    from normalised cumulative sums of ``M + 1`` standard exponentials."""
    N = w.shape[0]
    M = out.shape[0]
    if M == 0:
        return
    e = np.empty(M)
    s = 0.0
    for i in range(M):
        s += rng.standard_exponential()
        e[i] = s
    s += rng.standard_exponential()
    total = 0.0
    for j in range(N):
        total += w[j]
    j = 0
    c = w[0]
    scale = total / s
    for i in range(M):
        pos = e[i] * scale
        while pos >= c and j < N - 1:
            j += 1
            c += w[j]
        out[i] = j


@nb.njit(cache=True)
def residual_resample_kernel(w, rng, out):
    """Residual resampling: ``floor(M w_i)`` copies, the rest systematic on the
    residuals ``M w_i - floor(M w_i)``; draws one ``rng.random()`` if any
    residual copies are needed."""
    N = w.shape[0]
    M = out.shape[0]
    total = 0.0
    for j in range(N):
        total += w[j]
    res = np.empty(N)
    k = 0
    rtot = 0.0
    for j in range(N):
        x = M * (w[j] / total)
        c = int(math.floor(x))
        if k + c > M:  # round-off guard
            c = M - k
        for _ in range(c):
            out[k] = j
            k += 1
        r = x - c
        if r < 0.0:
            r = 0.0
        res[j] = r
        rtot += r
    R = M - k
    if R > 0:
        if rtot <= 0.0:  # only possible through round-off
            for j in range(N):
                res[j] = w[j]
        systematic_indices_kernel(res, rng.random(), out[k:])


def _resample(kernel, w, rng, n_out):
    rng = as_rng(rng)
    arr = _as_weights(w)
    M = _n_out(n_out, arr.shape[0])
    out = np.empty(M, dtype=np.int64)
    if M:
        kernel(arr, rng, out)
    return out


def systematic_resample(w, rng, n_out=None):
    """Indices (int64, ``(n_out,)``, default ``N``) by systematic resampling.

    ``w``: non-negative finite weights with positive sum (normalised
    internally).  Uses one ``rng.random()`` draw.  Each index ``i`` appears
    ``floor(M w_i)`` or ``ceil(M w_i)`` times; output is sorted.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import systematic_resample
    >>> idx = systematic_resample([0.5, 0.25, 0.25, 0.0], np.random.default_rng(0))
    >>> idx.tolist()      # each particle kept about N w_i times
    [0, 0, 1, 2]
    """
    return _resample(systematic_resample_kernel, w, rng, n_out)


def stratified_resample(w, rng, n_out=None):
    """Indices by stratified resampling (one uniform per stratum); sorted.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import stratified_resample
    >>> idx = stratified_resample([0.5, 0.25, 0.25, 0.0], np.random.default_rng(0), n_out=8)
    >>> np.bincount(idx, minlength=4).tolist()
    [4, 2, 2, 0]
    """
    return _resample(stratified_resample_kernel, w, rng, n_out)


def residual_resample(w, rng, n_out=None):
    """Indices by residual resampling (systematic on the residuals).

    The deterministic copies come first (in index order), then the residual
    draws (in index order).

    Each count lies in ``[floor(M w_i), ceil(M w_i)]``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import residual_resample
    >>> idx = residual_resample([0.5, 0.25, 0.25, 0.0], np.random.default_rng(0))
    >>> idx.tolist()        # the integer parts N w_i are copied deterministically
    [0, 0, 1, 2]
    """
    return _resample(residual_resample_kernel, w, rng, n_out)


def multinomial_resample(w, rng, n_out=None):
    """Indices by multinomial resampling (i.i.d. draws from ``w``), sorted, O(N).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import multinomial_resample
    >>> idx = multinomial_resample([0.5, 0.5, 0.0], np.random.default_rng(0), n_out=6)
    >>> bool(np.all(np.diff(idx) >= 0)), bool(np.all(idx < 2))  # sorted; never index 2
    (True, True)
    """
    return _resample(multinomial_resample_kernel, w, rng, n_out)


_RESAMPLERS = {
    "systematic": systematic_resample,
    "stratified": stratified_resample,
    "residual": residual_resample,
    "multinomial": multinomial_resample,
}


def resample_particles(particles, logw, rng, scheme="systematic", n_out=None):
    """Resample ``(particles, logw)``; returns ``(new particles, uniform log-weights)``.

    The log-weights may be unnormalised.  ``scheme`` is one of
    :data:`RESAMPLING_SCHEMES`.  The returned log-weights are ``-log(n_out)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import resample_particles
    >>> particles = np.array([[0.0], [1.0], [2.0], [3.0]])
    >>> logw = np.log([0.1, 0.1, 0.1, 0.7])
    >>> new, new_logw = resample_particles(particles, logw, np.random.default_rng(0))
    >>> new.shape
    (4, 1)
    >>> print(np.round(np.exp(new_logw), 3))         # uniform weights after resampling
    [0.25 0.25 0.25 0.25]
    >>> int((new[:, 0] == 3.0).sum()) >= 2
    True
    """
    if scheme not in _RESAMPLERS:
        raise ValueError(f"scheme must be one of {RESAMPLING_SCHEMES}, got {scheme!r}")
    X = _as_particles(particles)
    if X.shape[0] == 0:
        raise ValueError("particles must not be empty")
    lw = _as_logw(logw, X.shape[0])
    w = np.exp(lw - lw.max())
    idx = _RESAMPLERS[scheme](w, rng, n_out)
    M = idx.shape[0]
    return np.ascontiguousarray(X[idx]), np.full(M, -math.log(M) if M else 0.0)


# --------------------------------------------------------------------------
# measurement log-likelihoods on particle batches
# --------------------------------------------------------------------------
def _plain(x, ndim):
    return (type(x) is np.ndarray and x.dtype == np.float64 and x.ndim == ndim
            and x.flags.c_contiguous)


_RINV_CACHE: dict = {}


def _inv_logdet_cached(R, d):
    """:func:`_inv_logdet` of ``R`` (``(d, d)``), memoised on the bytes of a plain
    float64 ``R`` (filters call it every step with the same matrix).  Only
    successes are cached; the cached ``R^-1`` is private to the step functions."""
    if not _plain(R, 2) or R.shape != (d, d):
        return _inv_logdet(as_square_matrix(R, "R", d))
    key = R.tobytes()
    hit = _RINV_CACHE.get(key)
    if hit is None:
        Rinv, logdet = _inv_logdet(as_square_matrix(R, "R", d))
        if len(_RINV_CACHE) >= 256:
            _RINV_CACHE.clear()
        hit = _RINV_CACHE[key] = (Rinv, logdet)
    return hit


def _inv_logdet(R, name="R"):
    """``(R^-1, log|R|)`` of a symmetric positive definite ``R`` (validated).

    The Cholesky factorisation doubles as the definiteness check (cheaper
    than an eigendecomposition; this runs once per filter step).
    """
    R = as_square_matrix(R, name)
    scale = max(float(np.max(np.abs(R))), 1e-300) if R.size else 1.0
    if R.size and np.max(np.abs(R - R.T)) > 1e-8 * scale:
        raise ValueError(f"{name} must be symmetric")
    R = 0.5 * (R + R.T)
    try:
        L = np.linalg.cholesky(R)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name} must be positive definite") from None
    Linv = np.linalg.inv(L)
    Rinv = Linv.T @ Linv
    Rinv = 0.5 * (Rinv + Rinv.T)
    return np.ascontiguousarray(Rinv), float(2.0 * np.sum(np.log(np.diag(L))))


@nb.njit(cache=True, inline="always")
def _ll_position_one(particles, i, z, Rinv, c):
    d = z.shape[0]
    q = 0.0
    for a in range(d):
        ra = z[a] - particles[i, a]
        s = 0.0
        for b in range(d):
            s += Rinv[a, b] * (z[b] - particles[i, b])
        q += ra * s
    return c - 0.5 * q


@nb.njit(cache=True, inline="always")
def _ll_range_bearing_one(particles, i, z, Rinv, c, sx, sy):
    dx = particles[i, 0] - sx
    dy = particles[i, 1] - sy
    r0 = z[0] - math.sqrt(dx * dx + dy * dy)
    r1 = z[1] - math.atan2(dy, dx)
    if not (-math.pi < r1 <= math.pi):
        r1 = wrap_angle_kernel(r1)
    return c - 0.5 * (Rinv[0, 0] * r0 * r0 + 2.0 * Rinv[0, 1] * r0 * r1
                      + Rinv[1, 1] * r1 * r1)


@nb.njit(cache=True)
def _ll_serial(particles, z, Rinv, c, model, sx, sy, out):
    N = particles.shape[0]
    if model == 1:
        for i in range(N):
            out[i] += _ll_range_bearing_one(particles, i, z, Rinv, c, sx, sy)
    else:
        for i in range(N):
            out[i] += _ll_position_one(particles, i, z, Rinv, c)


@nb.njit(cache=True, parallel=True)
def _ll_parallel(particles, z, Rinv, c, model, sx, sy, out):
    N = particles.shape[0]
    if model == 1:
        for i in nb.prange(N):
            out[i] += _ll_range_bearing_one(particles, i, z, Rinv, c, sx, sy)
    else:
        for i in nb.prange(N):
            out[i] += _ll_position_one(particles, i, z, Rinv, c)


@nb.njit(cache=True)
def _add_loglik(particles, z, Rinv, logdetR, model, sx, sy, out):
    c = -0.5 * (z.shape[0] * 1.8378770664093453 + logdetR)
    _ll_serial(particles, z, Rinv, c, model, sx, sy, out)


@nb.njit(cache=True)
def loglik_gaussian_position_kernel(particles, z, Rinv, logdetR, out):
    """``out[i] += log N(z; particles[i, :d], R)`` (``d = len(z)``), given
    ``Rinv = R^-1`` and ``logdetR = log|R|``."""
    _add_loglik(particles, z, Rinv, logdetR, 0, 0.0, 0.0, out)


@nb.njit(cache=True)
def loglik_range_bearing_kernel(particles, z, Rinv, logdetR, sx, sy, out):
    """``out[i] += log N(z - h(x_i); 0, R)``, ``h = (range, bearing)`` from the
    sensor at ``(sx, sy)``, bearing innovation wrapped to (-pi, pi]."""
    _add_loglik(particles, z, Rinv, logdetR, 1, sx, sy, out)


def _loglik_dispatch(X, z, Rinv, logdet, model, sx, sy, out, parallel):
    if parallel and X.shape[0] >= _PARALLEL_MIN:
        c = -0.5 * (z.shape[0] * _LOG_2PI + logdet)
        _ll_parallel(X, z, Rinv, c, model, sx, sy, out)
    else:
        _add_loglik(X, z, Rinv, logdet, model, sx, sy, out)
    # an overflowing innovation can make inf - inf: that particle's likelihood is zero
    nan = np.isnan(out)
    if nan.any():
        out[nan] = -np.inf


def loglik_gaussian_position(particles, z, R, *, parallel=False):
    """Log-likelihoods ``log N(z; x_i[:d], R)`` of each particle, ``(N,)``.

    The first ``d = len(z)`` state components are the measured position.  A
    particle so far from ``z`` that its squared Mahalanobis distance overflows
    gets ``-inf`` (likelihood zero), never NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import loglik_gaussian_position
    >>> particles = np.array([[0.0, 0.0, 1.0, 1.0], [3.0, 4.0, 0.0, 0.0]])   # [x, y, vx, vy]
    >>> print(np.round(loglik_gaussian_position(particles, [0.0, 0.0], np.eye(2)), 3))
    [ -1.838 -14.338]
    """
    X = _as_particles(particles)
    z = as_vector(z, "z")
    d = z.shape[0]
    if d == 0 or d > X.shape[1]:
        raise ValueError(f"z must have 1..{X.shape[1]} components, got {d}")
    Rinv, logdet = _inv_logdet(as_square_matrix(R, "R", d))
    out = np.zeros(X.shape[0])
    _loglik_dispatch(X, z, Rinv, logdet, 0, 0.0, 0.0, out, parallel)
    return out


def _sensor(sensor):
    s = as_vector(sensor, "sensor", 2)
    return float(s[0]), float(s[1])


def loglik_range_bearing(particles, z, R, sensor=(0.0, 0.0), *, parallel=False):
    """Log-likelihoods of a range-bearing measurement ``z = (r, theta)``.

    ``particles`` have ``[x, y, ...]`` first; bearing ``atan2(y - sy, x - sx)``;
    the bearing innovation is wrapped to (-pi, pi].  Returns ``(N,)``; a
    particle whose range innovation overflows gets ``-inf``, never NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import loglik_range_bearing
    >>> particles = np.array([[100.0, 0.0, 0.0, 0.0], [0.0, 100.0, 0.0, 0.0]])
    >>> ll = loglik_range_bearing(particles, [100.0, 0.0], np.diag([1.0, 0.01]))
    >>> print(np.round(ll, 2))        # the particle on the x axis explains (r, theta) = (100, 0)
    [   0.46 -122.91]
    """
    X = _as_particles(particles)
    if X.shape[1] < 2:
        raise ValueError(f"particles must have at least 2 columns, got {X.shape}")
    z = as_vector(z, "z", 2)
    Rinv, logdet = _inv_logdet(as_square_matrix(R, "R", 2))
    sx, sy = _sensor(sensor)
    out = np.zeros(X.shape[0])
    _loglik_dispatch(X, z, Rinv, logdet, 1, sx, sy, out, parallel)
    return out


# --------------------------------------------------------------------------
# fused bootstrap step
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def _move_range(particles, lo, hi, F, L, noise, out):
    """``out[i] = F particles[i] + L noise[i, :k]`` for ``i`` in ``lo..hi-1``
    (``out`` may be ``particles``).

    Every path evaluates ``((F x)_a + L[a, 0] w_0) + L[a, 1] w_1 + ...`` with
    ``(F x)_a = ((F[a, 0] x_0 + F[a, 1] x_1) + F[a, 2] x_2) + ...``, in this
    order, so they all give the same bits.  For ``n = 4`` and ``k = 4`` or
    ``2`` on C-contiguous arrays a flat loop lets LLVM vectorise across
    particles (each SIMD lane does one particle's scalar arithmetic; no
    reassociation, no FMA contraction); it falls back to the scalar loop at
    run time when ``out`` overlaps an input.
    """
    n = particles.shape[1]
    k = L.shape[1]
    if (n == 4 and (k == 4 or k == 2) and particles.flags.c_contiguous
            and noise.flags.c_contiguous and out.flags.c_contiguous):
        _move_flat4(particles, lo, hi, F, L, noise, out)
    elif n == 4:
        f00, f01, f02, f03 = F[0, 0], F[0, 1], F[0, 2], F[0, 3]
        f10, f11, f12, f13 = F[1, 0], F[1, 1], F[1, 2], F[1, 3]
        f20, f21, f22, f23 = F[2, 0], F[2, 1], F[2, 2], F[2, 3]
        f30, f31, f32, f33 = F[3, 0], F[3, 1], F[3, 2], F[3, 3]
        for i in range(lo, hi):
            x0 = particles[i, 0]
            x1 = particles[i, 1]
            x2 = particles[i, 2]
            x3 = particles[i, 3]
            y0 = f00 * x0 + f01 * x1 + f02 * x2 + f03 * x3
            y1 = f10 * x0 + f11 * x1 + f12 * x2 + f13 * x3
            y2 = f20 * x0 + f21 * x1 + f22 * x2 + f23 * x3
            y3 = f30 * x0 + f31 * x1 + f32 * x2 + f33 * x3
            for c2 in range(k):
                w = noise[i, c2]
                y0 += L[0, c2] * w
                y1 += L[1, c2] * w
                y2 += L[2, c2] * w
                y3 += L[3, c2] * w
            out[i, 0] = y0
            out[i, 1] = y1
            out[i, 2] = y2
            out[i, 3] = y3
    else:
        tmp = np.empty(n)
        for i in range(lo, hi):
            for a in range(n):
                s = 0.0
                for b in range(n):
                    s += F[a, b] * particles[i, b]
                for c2 in range(k):
                    s += L[a, c2] * noise[i, c2]
                tmp[a] = s
            for a in range(n):
                out[i, a] = tmp[a]


@nb.njit(cache=True)
def _move_flat4(particles, lo, hi, F, L, noise, out):
    """:func:`_move_range` for ``n = 4``, ``k`` in {4, 2}, C-contiguous arrays:
    flat indexing and the coefficients in registers, which LLVM vectorises
    across particles (2.3 instead of 5.4 ns per particle)."""
    k = L.shape[1]
    f00, f01, f02, f03 = F[0, 0], F[0, 1], F[0, 2], F[0, 3]
    f10, f11, f12, f13 = F[1, 0], F[1, 1], F[1, 2], F[1, 3]
    f20, f21, f22, f23 = F[2, 0], F[2, 1], F[2, 2], F[2, 3]
    f30, f31, f32, f33 = F[3, 0], F[3, 1], F[3, 2], F[3, 3]
    P = particles.reshape(particles.size)
    W = noise.reshape(noise.size)
    O = out.reshape(out.size)
    if k == 4:
        l00, l01, l02, l03 = L[0, 0], L[0, 1], L[0, 2], L[0, 3]
        l10, l11, l12, l13 = L[1, 0], L[1, 1], L[1, 2], L[1, 3]
        l20, l21, l22, l23 = L[2, 0], L[2, 1], L[2, 2], L[2, 3]
        l30, l31, l32, l33 = L[3, 0], L[3, 1], L[3, 2], L[3, 3]
        for i in range(lo, hi):
            b = 4 * i
            x0 = P[b]
            x1 = P[b + 1]
            x2 = P[b + 2]
            x3 = P[b + 3]
            w0 = W[b]
            w1 = W[b + 1]
            w2 = W[b + 2]
            w3 = W[b + 3]
            O[b] = (f00 * x0 + f01 * x1 + f02 * x2 + f03 * x3
                    + l00 * w0 + l01 * w1 + l02 * w2 + l03 * w3)
            O[b + 1] = (f10 * x0 + f11 * x1 + f12 * x2 + f13 * x3
                        + l10 * w0 + l11 * w1 + l12 * w2 + l13 * w3)
            O[b + 2] = (f20 * x0 + f21 * x1 + f22 * x2 + f23 * x3
                        + l20 * w0 + l21 * w1 + l22 * w2 + l23 * w3)
            O[b + 3] = (f30 * x0 + f31 * x1 + f32 * x2 + f33 * x3
                        + l30 * w0 + l31 * w1 + l32 * w2 + l33 * w3)
    else:
        l00, l01 = L[0, 0], L[0, 1]
        l10, l11 = L[1, 0], L[1, 1]
        l20, l21 = L[2, 0], L[2, 1]
        l30, l31 = L[3, 0], L[3, 1]
        for i in range(lo, hi):
            b = 4 * i
            q = 2 * i
            x0 = P[b]
            x1 = P[b + 1]
            x2 = P[b + 2]
            x3 = P[b + 3]
            w0 = W[q]
            w1 = W[q + 1]
            O[b] = f00 * x0 + f01 * x1 + f02 * x2 + f03 * x3 + l00 * w0 + l01 * w1
            O[b + 1] = f10 * x0 + f11 * x1 + f12 * x2 + f13 * x3 + l10 * w0 + l11 * w1
            O[b + 2] = f20 * x0 + f21 * x1 + f22 * x2 + f23 * x3 + l20 * w0 + l21 * w1
            O[b + 3] = f30 * x0 + f31 * x1 + f32 * x2 + f33 * x3 + l30 * w0 + l31 * w1


@nb.njit(cache=True)
def _weigh_range(X, lo, hi, z, Rinv, c, model, sx, sy, logw):
    """Add the log-likelihoods of particles ``X[lo:hi]`` to ``logw`` (skipped
    when ``z`` is empty); returns the largest resulting log-weight in the range
    (a separate pass in the same order as the additions, so the same value).
    A NaN log-weight (``inf - inf`` from a non-finite or overflowing state)
    becomes ``-inf`` in that pass."""
    if z.shape[0] > 0:
        if model == 1:
            _add_range_bearing_loglik(X, lo, hi, z, Rinv, c, sx, sy, logw)
        else:
            for i in range(lo, hi):
                logw[i] = logw[i] + _ll_position_one(X, i, z, Rinv, c)
    top = -np.inf
    for i in range(lo, hi):
        v = logw[i]
        if v != v:  # NaN from an overflowing innovation: this particle has weight zero
            v = -np.inf
            logw[i] = v
        top = v if v > top else top
    return top


@nb.njit(cache=True)
def _add_range_bearing_loglik(X, lo, hi, z, Rinv, c, sx, sy, logw):
    """``logw[i] += log N(z - h(x_i); 0, R)`` for ``i`` in ``lo..hi-1``: the
    arithmetic of :func:`_ll_range_bearing_one`, operation for operation, in
    two passes.  The first only calls ``atan2`` (and wraps the bearing
    innovation); the second, free of calls, computes the range innovation and
    the quadratic form and is vectorised by LLVM for ``n = 4`` (one particle
    per SIMD lane, IEEE-exact ``sqrt``, no reassociation).  In one loop the
    quadratic form's latency after each ``atan2`` call and the scalar ``sqrt``
    cost ~3 ns per particle."""
    m = hi - lo
    r1s = np.empty(m)
    z0 = z[0]
    z1 = z[1]
    for i in range(lo, hi):
        r1 = z1 - math.atan2(X[i, 1] - sy, X[i, 0] - sx)
        if not (-math.pi < r1 <= math.pi):
            r1 = wrap_angle_kernel(r1)
        r1s[i - lo] = r1
    a = Rinv[0, 0]
    b2 = 2.0 * Rinv[0, 1]
    d = Rinv[1, 1]
    if X.shape[1] == 4 and X.flags.c_contiguous:
        P = X.reshape(X.size)
        for i in range(lo, hi):
            dx = P[4 * i] - sx
            dy = P[4 * i + 1] - sy
            r0 = z0 - math.sqrt(dx * dx + dy * dy)
            r1 = r1s[i - lo]
            logw[i] = logw[i] + (c - 0.5 * (a * r0 * r0 + b2 * r0 * r1 + d * r1 * r1))
    else:
        for i in range(lo, hi):
            dx = X[i, 0] - sx
            dy = X[i, 1] - sy
            r0 = z0 - math.sqrt(dx * dx + dy * dy)
            r1 = r1s[i - lo]
            logw[i] = logw[i] + (c - 0.5 * (a * r0 * r0 + b2 * r0 * r1 + d * r1 * r1))


@nb.njit(cache=True, parallel=True)
def _move_weigh_parallel(particles, F, L, noise, z, Rinv, c, model, sx, sy, logw, out):
    """``out = F particles + L noise`` and the weighting, on numba threads in
    chunks; returns the largest log-weight (the same as the serial passes)."""
    N = particles.shape[0]
    chunk = 4096
    nchunks = (N + chunk - 1) // chunk
    tops = np.empty(nchunks)
    for q in nb.prange(nchunks):
        lo = q * chunk
        hi = min(N, lo + chunk)
        _move_range(particles, lo, hi, F, L, noise, out)
        tops[q] = _weigh_range(out, lo, hi, z, Rinv, c, model, sx, sy, logw)
    top = -np.inf
    for q in range(nchunks):
        top = tops[q] if tops[q] > top else top
    return top


@nb.njit(cache=True)
def _bootstrap_prepare(logw, L, rng):
    """Phase 1: log of the prior total weight, and the ``(N, k)`` process noise
    drawn serially (particle by particle)."""
    N = logw.shape[0]
    k = L.shape[1]
    uniform = True  # cheap path for uniform weights, the usual case
    for i in range(1, N):
        if logw[i] != logw[0]:
            uniform = False
            break
    if uniform:
        lse0 = logw[0] + math.log(N)
    else:
        lse0 = logsumexp_kernel(logw)
    noise = np.empty((N, k))
    for i in range(N):
        for c2 in range(k):
            noise[i, c2] = rng.standard_normal()
    return lse0, noise


@nb.njit(cache=True)
def _bootstrap_finish(particles, logw, moved, top, lse0, has_z, rng, ess_threshold):
    """Phase 3: normalise (one exp per particle), ESS, evidence, then resample
    from ``moved`` into ``particles`` (or copy ``moved`` over when not
    resampling)."""
    N, n = particles.shape
    dead = top == -np.inf
    if dead:
        # every particle has zero likelihood: evidence 0, fall back to uniform weights
        for i in range(N):
            logw[i] = 0.0
        top = 0.0
    s1 = 0.0
    s2 = 0.0
    for i in range(N):  # logw temporarily holds w_i / w_max
        e = math.exp(logw[i] - top)
        logw[i] = e
        s1 += e
        s2 += e * e
    ess = s1 * s1 / s2
    if dead:
        log_ev = -np.inf
    elif has_z:
        log_ev = top + math.log(s1) - lse0
    else:
        log_ev = 0.0
    resampled = False
    if ess_threshold >= 1.0 or ess < ess_threshold * N:
        resampled = True
        # systematic resampling (as _systematic_marks), the running maximum
        # that fills the runs fused with the gather
        idx = np.empty(N, dtype=np.int64)
        cur = _systematic_run_marks(logw, s1, rng.random(), idx)
        lu = -math.log(N)
        if n == 4:
            for i in range(N):
                v = idx[i]
                cur = v if v > cur else cur
                logw[i] = lu
                particles[i, 0] = moved[cur, 0]
                particles[i, 1] = moved[cur, 1]
                particles[i, 2] = moved[cur, 2]
                particles[i, 3] = moved[cur, 3]
        else:
            for i in range(N):
                v = idx[i]
                cur = v if v > cur else cur
                logw[i] = lu
                for a in range(n):
                    particles[i, a] = moved[cur, a]
    else:
        ls1 = math.log(s1)
        for i in range(N):
            logw[i] = math.log(logw[i]) - ls1
            for a in range(n):
                particles[i, a] = moved[i, a]
    return log_ev, ess, resampled


@nb.njit(cache=True)
def bootstrap_step_kernel(particles, logw, F, L, z, Rinv, logdetR, model, sx, sy,
                          rng, ess_threshold, scratch):
    """One bootstrap-PF step in place: propagate, weight, normalise, resample.

    ``particles`` ``(N, n)`` and ``logw`` ``(N,)`` are overwritten; ``scratch``
    is an ``(N, n)`` work array (it receives the propagated particles; it must
    not overlap ``particles``) and ``L`` is ``(n, k)`` with ``k <= n``.
    ``z`` of length 0 means an empty scan (no weighting).  ``model``:
    :data:`MODEL_POSITION` or :data:`MODEL_RANGE_BEARING`.  Systematic
    resampling happens when ``ess_threshold >= 1`` or
    ``ESS < ess_threshold * N``.

    Passes: draw the noise; propagate into ``scratch``; weigh (tracking the
    maximum log-weight); one exp per particle for the normalisation and the
    ESS; systematic resampling gathers from ``scratch`` straight back into
    ``particles`` (no copy-back).

    Random draws: ``N * k`` standard normals (particle by particle, the same
    stream as :func:`propagate_linear_kernel`), then one ``rng.random()`` if
    resampling.  This kernel is serial and safe to call from other kernels;
    :func:`bootstrap_step` with ``parallel=True`` runs the same phases with
    a threaded move-and-weigh pass (identical results).

    Returns ``(log_evidence, ess_before_resampling, resampled)`` where
    ``log_evidence = log sum_i w_i p(z | x_i)`` with the input weights
    normalised (0 for an empty scan).
    """
    N = particles.shape[0]
    lse0, noise = _bootstrap_prepare(logw, L, rng)
    c = -0.5 * (z.shape[0] * 1.8378770664093453 + logdetR)
    _move_range(particles, 0, N, F, L, noise, scratch)
    top = _weigh_range(scratch, 0, N, z, Rinv, c, model, sx, sy, logw)
    return _bootstrap_finish(particles, logw, scratch, top, lse0, z.shape[0] > 0, rng,
                             ess_threshold)


class BootstrapStep(NamedTuple):
    """Result of :func:`bootstrap_step` (particles/logw are updated in place).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import bootstrap_step, noise_factor
    >>> from trackcore.models import cv_transition, cv_process_noise
    >>> rng = np.random.default_rng(0)
    >>> particles = rng.normal([0.0, 0.0, 1.0, 1.0], 1.0, size=(500, 4))
    >>> step = bootstrap_step(particles, np.zeros(500), cv_transition(1.0),
    ...                       noise_factor(cv_process_noise(1.0, 0.1)), [1.0, 1.0], np.eye(2), rng,
    ...                       model="position")
    >>> step._fields
    ('particles', 'logw', 'log_evidence', 'ess', 'resampled')
    >>> step.resampled
    True
    """

    particles: np.ndarray
    logw: np.ndarray
    log_evidence: float
    ess: float
    resampled: bool


def bootstrap_step(particles, logw, F, L, z, R, rng, model="range_bearing", *,
                   sensor=(0.0, 0.0), ess_threshold=1.0, scratch=None, parallel=False):
    """Fused predict-weight-resample bootstrap particle-filter step.

    ``particles`` ``(N, n)`` (C-contiguous float64, updated in place when it
    already is one) and log-weights ``logw`` ``(N,)``; ``F`` ``(n, n)``;
    ``L`` the ``(n, k)`` process-noise factor (``Q = L L^T``, see
    :func:`noise_factor`); ``z`` the measurement (``(2,)`` range-bearing for
    ``model="range_bearing"``; ``(d,)`` position for ``model="position"``;
    empty for an empty scan); ``R`` its covariance.  Resamples
    systematically when ``ESS < ess_threshold * N`` (always for the default
    ``ess_threshold=1``).  ``parallel=True`` runs the move-and-weigh pass on
    numba threads for ``N >= 20000`` (same results; only worth it on idle
    cores).  ``scratch``: optional ``(N, n)`` C-contiguous float64 work
    array, not overlapping ``particles`` (reuse one across steps to save an
    allocation).  Returns a :class:`BootstrapStep`.

    A particle whose log-likelihood is not finite gets the log-weight
    ``-inf`` (it is never resampled); when every particle does, there is no
    posterior and a ``ValueError`` is raised, as it is when the propagation
    overflows.  Log-weights, ESS and log-evidence are never NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import bootstrap_step, noise_factor, weighted_mean_cov
    >>> from trackcore.models import cv_transition, cv_process_noise
    >>> rng = np.random.default_rng(0)
    >>> particles = rng.normal([0.0, 0.0, 1.0, 1.0], 1.0, size=(2000, 4))
    >>> logw = np.zeros(2000)
    >>> F, L = cv_transition(1.0), noise_factor(cv_process_noise(1.0, 0.1))
    >>> step = bootstrap_step(particles, logw, F, L, [1.0, 1.0], 0.1 * np.eye(2), rng,
    ...                       model="position", ess_threshold=0.5)
    >>> step.resampled       # the measurement concentrates the weights: ESS below N / 2
    True
    >>> mean, cov = weighted_mean_cov(step.particles, step.logw)
    >>> print(np.round(mean[:2], 1))
    [1. 1.]
    """
    # Each argument takes a cheap path when it is already what the kernel needs
    # (C-contiguous float64 of the right shape, finite sum); anything else goes
    # through the full checks, which convert or raise the usual errors.
    rng = rng if type(rng) is np.random.Generator else as_rng(rng)
    if model not in _MODELS:
        raise ValueError(f"model must be one of {tuple(_MODELS)}, got {model!r}")
    code = _MODELS[model]
    if _plain(particles, 2) and math.isfinite(particles.sum()):
        X = particles
    else:
        X = _as_particles(particles)
    N, n = X.shape
    if N == 0:
        raise ValueError("particles must not be empty")
    if _plain(logw, 1) and logw.shape[0] == N and math.isfinite(logw.sum()):
        lw = logw
    else:
        lw = _as_logw(logw, N)  # the caller's array itself when already float64 C-contiguous
    F = checked(F, "F", (n, n)) if _plain(F, 2) else as_square_matrix(F, "F", n)
    L = checked(L, "L", L.shape) if (_plain(L, 2) and L.shape[0] == n) else as_matrix(
        L, "L", (n, None))
    if L.shape[1] > n:
        raise ValueError(f"L must have at most {n} columns (Q = L L^T), got {L.shape}")
    if _plain(z, 1) and math.isfinite(z.sum()):
        pass
    elif isinstance(z, (list, tuple)) and len(z) == 0:
        z = np.zeros(0)
    else:
        z = as_vector(z, "z")
    if type(ess_threshold) is not float:
        ess_threshold = as_scalar(ess_threshold, "ess_threshold")
    if not 0.0 <= ess_threshold <= 1.0:
        raise ValueError(f"ess_threshold must be in [0, 1], got {ess_threshold}")
    if z.shape[0] == 0:
        Rinv, logdet = np.zeros((0, 0)), 0.0
    else:
        if code == MODEL_RANGE_BEARING:
            if z.shape[0] != 2:
                raise ValueError(f"z must have shape (2,) for model='range_bearing', got {z.shape}")
            if n < 2:
                raise ValueError("particles must have at least 2 columns")
        elif z.shape[0] > n:
            raise ValueError(f"z must have at most {n} components, got {z.shape[0]}")
        Rinv, logdet = _inv_logdet_cached(R, z.shape[0])
    sx, sy = (0.0, 0.0) if type(sensor) is tuple and sensor == (0.0, 0.0) else _sensor(sensor)
    if scratch is None:
        scratch = np.empty_like(X)
    elif not (isinstance(scratch, np.ndarray) and scratch.dtype == np.float64
              and scratch.flags.c_contiguous and scratch.shape == X.shape):
        raise ValueError(f"scratch must be a C-contiguous float64 array of shape {X.shape}")
    elif np.may_share_memory(scratch, X):
        raise ValueError("scratch must not overlap particles")
    if parallel and N >= _PARALLEL_MIN:
        # same phases as bootstrap_step_kernel, threaded move-and-weigh pass
        lse0, noise = _bootstrap_prepare(lw, L, rng)
        c = -0.5 * (z.shape[0] * _LOG_2PI + logdet)
        top = _move_weigh_parallel(X, F, L, noise, z, Rinv, c, code, sx, sy, lw, scratch)
        log_ev, ess, res = _bootstrap_finish(X, lw, scratch, top, lse0, z.shape[0] > 0, rng,
                                             ess_threshold)
    else:
        log_ev, ess, res = bootstrap_step_kernel(X, lw, F, L, z, Rinv, logdet, code, sx, sy,
                                                 rng, ess_threshold, scratch)
    if not _finite_sum(X):
        finite_result(X, "the propagated particles", "particles, F and L")
    if log_ev == -math.inf:
        raise ValueError("every particle has likelihood zero (each log-likelihood is -inf or "
                         "NaN, e.g. z is too far from every particle for its density to be "
                         "represented); particles now hold the propagated particles with "
                         "uniform weights")
    return BootstrapStep(X, lw, float(log_ev), float(ess), bool(res))
