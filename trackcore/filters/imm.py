"""Interacting Multiple Model (IMM) estimator for linear-Gaussian modes.

One cycle (Bar-Shalom, Li & Kirubarajan 2001, sec. 11.6.6), with ``r`` modes,
Markov transition matrix ``PI[i, j] = P(mode j at k | mode i at k-1)``:

1. mixing (:func:`imm_mix`): predicted mode probabilities
   ``c_bar_j = sum_i PI_ij mu_i``, mixing weights ``mu_{i|j} = PI_ij mu_i / c_bar_j``,
   mixed initial conditions ``x0_j = sum_i mu_{i|j} x_i`` and
   ``P0_j = sum_i mu_{i|j} (P_i + (x_i - x0_j)(x_i - x0_j)^T)``;
2. mode-matched Kalman prediction and Joseph-form update (``trackcore.filters.kalman``);
3. mode probabilities (:func:`imm_mode_update`), in log space:
   ``log mu_j = log c_bar_j + log Lambda_j - logsumexp(...)``, so they stay
   finite when every likelihood underflows;
4. combination (:func:`imm_combine`) into one Gaussian for output.

:func:`imm_step` is one cycle (the same as filterpy's ``IMMEstimator.predict()``
followed by ``update(z)``); :func:`imm_filter_run` runs all scans in one numba
kernel.  All modes share the state dimension and the measurement model.
The ``*_kernel`` functions are numba kernels for other kernels (the IMM-PDAF
tracker); they assume valid input and are not public.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.validation import as_array, as_vector
from ._fastcheck import check_result_cov, checked, checked_cov, checked_cov_stack
from .kalman import (GaussianEstimate, _finite_outputs, _predict_into, _update_into,
                     _update_scratch)

__all__ = [
    "IMMStep",
    "IMMRun",
    "imm_mix",
    "imm_mode_update",
    "imm_combine",
    "imm_step",
    "imm_filter_run",
]


class IMMStep(NamedTuple):
    """Result of one IMM cycle.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import imm_step
    >>> r = imm_step(np.zeros((2, 1)), np.ones((2, 1, 1)), [0.5, 0.5], [[0.9, 0.1], [0.1, 0.9]],
    ...              np.ones((2, 1, 1)), [[[0.1]], [[10.0]]], [3.0], [[1.0]], [[1.0]])
    >>> r._fields
    ('xs', 'Ps', 'mu', 'x', 'P', 'logliks')
    >>> print(np.round(r.mu, 3), np.round(r.x, 3))
    [0.29 0.71] [2.408]
    """
    xs: np.ndarray       # (r, n) mode-matched posterior means
    Ps: np.ndarray       # (r, n, n) mode-matched posterior covariances
    mu: np.ndarray       # (r,) posterior mode probabilities
    x: np.ndarray        # (n,) combined mean
    P: np.ndarray        # (n, n) combined covariance
    logliks: np.ndarray  # (r,) log N(nu_j; 0, S_j) of each mode


class IMMRun(NamedTuple):
    """Result of :func:`imm_filter_run` over K scans.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import imm_filter_run
    >>> run = imm_filter_run(np.zeros((4, 1)), np.zeros((2, 1)), np.ones((2, 1, 1)), [0.5, 0.5],
    ...                      [[0.9, 0.1], [0.1, 0.9]], np.ones((2, 1, 1)), [[[0.1]], [[10.0]]],
    ...                      [[1.0]], [[1.0]])
    >>> run._fields
    ('x', 'P', 'mu', 'loglik')
    >>> run.x.shape, run.P.shape, run.mu.shape, run.loglik.shape
    ((4, 1), (4, 1, 1), (4, 2), (4,))
    """
    x: np.ndarray       # (K, n) combined posterior means
    P: np.ndarray       # (K, n, n) combined posterior covariances
    mu: np.ndarray      # (K, r) mode probabilities
    loglik: np.ndarray  # (K,) log p(z_k | z_1..z_{k-1}) (0 for a missed scan)


# ---------------------------------------------------------------------- kernels
@nb.njit(cache=True)
def imm_mix_kernel(mu, PI, xs, Ps, x0s, P0s, c_bar):
    """Mixing step into preallocated ``x0s`` (r, n), ``P0s`` (r, n, n), ``c_bar`` (r,).

    A mode with ``c_bar_j = 0`` (unreachable) keeps its own estimate.
    """
    r = mu.shape[0]
    n = xs.shape[1]
    for j in range(r):
        c = 0.0
        for i in range(r):
            c += PI[i, j] * mu[i]
        c_bar[j] = c
    for j in range(r):
        c = c_bar[j]
        if c <= 0.0:
            for a in range(n):
                x0s[j, a] = xs[j, a]
                for b in range(n):
                    P0s[j, a, b] = Ps[j, a, b]
            continue
        for a in range(n):
            x0s[j, a] = 0.0
            for b in range(n):
                P0s[j, a, b] = 0.0
        for i in range(r):
            w = PI[i, j] * mu[i] / c
            for a in range(n):
                x0s[j, a] += w * xs[i, a]
        for i in range(r):
            w = PI[i, j] * mu[i] / c
            if w == 0.0:
                continue
            for a in range(n):
                da = xs[i, a] - x0s[j, a]
                for b in range(a + 1):
                    P0s[j, a, b] += w * (Ps[i, a, b] + da * (xs[i, b] - x0s[j, b]))
        for a in range(n):
            for b in range(a):
                P0s[j, b, a] = P0s[j, a, b]


@nb.njit(cache=True)
def imm_mode_update_kernel(c_bar, logliks, mu_out):
    """Posterior mode probabilities into ``mu_out``; returns log sum_j c_bar_j Lambda_j.

    Returns ``-inf`` (and leaves ``mu_out`` undefined) if no mode has mass.
    """
    r = c_bar.shape[0]
    amax = -np.inf
    for j in range(r):
        if c_bar[j] > 0.0:
            mu_out[j] = math.log(c_bar[j]) + logliks[j]
        else:
            mu_out[j] = -np.inf
        if mu_out[j] > amax:
            amax = mu_out[j]
    if amax == -np.inf or math.isnan(amax):
        return -np.inf
    # normalise exp(l_j - max) by its sum (not exp(l_j - logsumexp)): the sum is
    # then 1 to rounding even when the log-likelihoods are huge in magnitude
    s = 0.0
    for j in range(r):
        mu_out[j] = math.exp(mu_out[j] - amax)
        s += mu_out[j]
    for j in range(r):
        mu_out[j] /= s
    return amax + math.log(s)


@nb.njit(cache=True)
def imm_combine_kernel(mu, xs, Ps, x, P):
    """Moment-matched combination into preallocated ``x`` (n,), ``P`` (n, n)."""
    r = mu.shape[0]
    n = xs.shape[1]
    for a in range(n):
        s = 0.0
        for j in range(r):
            s += mu[j] * xs[j, a]
        x[a] = s
    for a in range(n):
        for b in range(a + 1):
            s = 0.0
            for j in range(r):
                s += mu[j] * (Ps[j, a, b] + (xs[j, a] - x[a]) * (xs[j, b] - x[b]))
            P[a, b] = s
            P[b, a] = s


@nb.njit(cache=True)
def _imm_cycle(xs, Ps, mu, PI, Fs, Qs, z, missed, H, R, x0s, P0s, c_bar, xp, Pp, FP,
               innov, S, K, PHt, W, RKt, L, A, y, logliks, mu_out):
    """One IMM cycle in place on ``xs``, ``Ps``; returns (total loglik, failed mode or -1)."""
    r = mu.shape[0]
    n = xs.shape[1]
    m = z.shape[0]
    imm_mix_kernel(mu, PI, xs, Ps, x0s, P0s, c_bar)
    for j in range(r):
        _predict_into(x0s[j], P0s[j], Fs[j], Qs[j], xp, Pp, FP)
        if missed or m == 0:
            for a in range(n):
                xs[j, a] = xp[a]
                for b in range(n):
                    Ps[j, a, b] = Pp[a, b]
            logliks[j] = 0.0
        else:
            for i in range(m):
                s = z[i]
                for a in range(n):
                    s -= H[i, a] * xp[a]
                innov[i] = s
            nis, ll, ok = _update_into(xp, Pp, innov, H, R, xs[j], Ps[j], S, K, PHt, W, RKt,
                                       L, A, y)
            if not ok:
                return -np.inf, j
            logliks[j] = ll
    total = imm_mode_update_kernel(c_bar, logliks, mu_out)
    if total == -np.inf:
        return total, r
    return total, -1


@nb.njit(cache=True)
def imm_filter_run_kernel(zs, xs0, Ps0, mu0, PI, Fs, Qs, H, R, x_out, P_out, mu_out,
                          loglik_out):
    """IMM over the rows of ``zs`` (K, m) into preallocated outputs.

    A row whose first entry is NaN is a missed scan.  Returns ``(k, j)``: the
    scan and mode where ``S`` was not positive definite (``j = r`` when every
    mode lost its mass), or ``(-1, -1)``.
    """
    r, n = xs0.shape
    m = zs.shape[1]
    xs = xs0.copy()
    Ps = Ps0.copy()
    mu = mu0.copy()
    x0s = np.empty((r, n))
    P0s = np.empty((r, n, n))
    c_bar = np.empty(r)
    xp = np.empty(n)
    Pp = np.empty((n, n))
    FP = np.empty((n, n))
    innov = np.empty(m)
    S = np.empty((m, m))
    K = np.empty((n, m))
    PHt, W, RKt, L, A, y = _update_scratch(n, m)
    logliks = np.empty(r)
    mu_new = np.empty(r)
    for k in range(zs.shape[0]):
        missed = m > 0 and math.isnan(zs[k, 0])
        total, bad = _imm_cycle(xs, Ps, mu, PI, Fs, Qs, zs[k], missed, H, R, x0s, P0s, c_bar,
                                xp, Pp, FP, innov, S, K, PHt, W, RKt, L, A, y, logliks,
                                mu_new)
        if bad >= 0:
            return k, bad
        for j in range(r):
            mu[j] = mu_new[j]
            mu_out[k, j] = mu_new[j]
        loglik_out[k] = 0.0 if missed else total
        imm_combine_kernel(mu, xs, Ps, x_out[k], P_out[k])
    return -1, -1


# ---------------------------------------------------------------------- wrappers
def _check_mu(mu, name="mu", r=None):
    mu = checked(mu, name, (r,)) if r is not None else as_vector(mu, name)
    if mu.size == 0:
        raise ValueError(f"{name} must not be empty")
    if np.any(mu < 0) or abs(mu.sum() - 1.0) > 1e-9:
        raise ValueError(f"{name} must be a probability vector (entries >= 0 summing to 1), "
                         f"got sum {mu.sum():.12g}")
    return mu


def _check_PI(PI, r):
    PI = checked(PI, "PI", (r, r))
    if PI.min() < 0 or PI.max() > 1:
        raise ValueError("PI must contain probabilities in [0, 1]")
    if np.any(np.abs(PI.sum(axis=1) - 1.0) > 1e-9):
        raise ValueError(f"PI rows must sum to 1 (row sums {PI.sum(axis=1).tolist()})")
    return PI


def _check_modes(xs, Ps, r=None, names=("xs", "Ps")):
    xn, pn = names
    if not (type(xs) is np.ndarray and xs.ndim == 2):
        xs = as_array(xs, xn, ndim=2)
    xs = checked(xs, xn, xs.shape)
    r_, n = xs.shape
    if r is not None and r_ != r:
        raise ValueError(f"{xn} must have {r} rows (one per mode), got shape {xs.shape}")
    if n == 0 or r_ == 0:
        raise ValueError(f"{xn} must be a non-empty (r, n) array, got shape {xs.shape}")
    Ps = checked_cov_stack(Ps, pn, r_, n)
    return xs, Ps, r_, n


def _check_stack(M, name, r, n, covariance):
    if covariance:
        return checked_cov_stack(M, name, r, n)
    return checked(M, name, (r, n, n))


def imm_mix(mu, PI, xs, Ps):
    """IMM mixing step.  Returns ``(x0s (r, n), P0s (r, n, n), c_bar (r,))``.

    ``c_bar`` are the predicted mode probabilities ``mu @ PI``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import imm_mix
    >>> xs = np.array([[0.0], [2.0]])          # two modes, one state
    >>> Ps = np.array([[[1.0]], [[1.0]]])
    >>> x0s, P0s, c_bar = imm_mix([0.5, 0.5], [[0.9, 0.1], [0.1, 0.9]], xs, Ps)
    >>> print(np.round(x0s.ravel(), 3), np.round(P0s.ravel(), 3), c_bar)
    [0.2 1.8] [1.36 1.36] [0.5 0.5]
    """
    xs, Ps, r, n = _check_modes(xs, Ps)
    mu = _check_mu(mu, "mu", r)
    PI = _check_PI(PI, r)
    x0s, P0s, c_bar = np.empty((r, n)), np.empty((r, n, n)), np.empty(r)
    imm_mix_kernel(mu, PI, xs, Ps, x0s, P0s, c_bar)
    _finite_outputs("the mixed estimate", "xs and Ps", x0s, P0s)
    check_result_cov(P0s, "the mixed covariance P0s", (("Ps", Ps),))
    return x0s, P0s, c_bar


def imm_mode_update(c_bar, logliks):
    """Posterior mode probabilities from predicted ones and log-likelihoods.

    Computed in log space: stable when every likelihood underflows (e.g.
    ``logliks = [-2000, -2001]``).  ``logliks`` entries may be ``-inf``
    (impossible mode) but not all modes may have zero mass.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import imm_mode_update
    >>> mu = imm_mode_update(np.array([0.5, 0.5]), np.log([0.1, 0.3]))
    >>> print(np.round(mu, 3))
    [0.25 0.75]
    """
    c_bar = _check_mu(c_bar, "c_bar")
    r = c_bar.shape[0]
    ll = as_vector(logliks, "logliks", r, finite=False)
    if np.any(np.isnan(ll)) or np.any(ll == np.inf):
        raise ValueError("logliks must not contain NaN or +inf")
    mu = np.empty(r)
    total = imm_mode_update_kernel(c_bar, ll, mu)
    if total == -np.inf:
        raise ValueError("no mode has positive probability: c_bar * exp(logliks) is zero "
                         "for every mode")
    return mu


def imm_combine(mu, xs, Ps):
    """Moment-matched combination of the mode-matched estimates -> ``GaussianEstimate``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import imm_combine
    >>> est = imm_combine(np.array([0.5, 0.5]), np.array([[0.0], [2.0]]), np.ones((2, 1, 1)))
    >>> print(est.x, est.P)     # the spread of the means adds to the covariance
    [1.] [[2.]]
    """
    xs, Ps, r, n = _check_modes(xs, Ps)
    mu = _check_mu(mu, "mu", r)
    x, P = np.empty(n), np.empty((n, n))
    imm_combine_kernel(mu, xs, Ps, x, P)
    _finite_outputs("the combined estimate", "xs and Ps", x, P)
    check_result_cov(P, "the combined covariance", (("Ps", Ps),))
    return GaussianEstimate(x, P)


def _check_imm_inputs(xs, Ps, mu, PI, Fs, Qs, H, R, m, names=("xs", "Ps", "mu")):
    xs, Ps, r, n = _check_modes(xs, Ps, names=names[:2])
    mu = _check_mu(mu, names[2], r)
    PI = _check_PI(PI, r)
    Fs = _check_stack(Fs, "Fs", r, n, covariance=False)
    Qs = _check_stack(Qs, "Qs", r, n, covariance=True)
    if m == 0:
        H, R = np.zeros((0, n)), np.zeros((0, 0))
    else:
        H = checked(H, "H", (m, n))
        R = checked_cov(R, "R", m)
    return xs, Ps, mu, PI, Fs, Qs, H, R, r, n


def imm_step(xs, Ps, mu, PI, Fs, Qs, z, H, R):
    """One IMM cycle (mix, predict, update, mode probabilities, combine).

    ``xs`` (r, n), ``Ps`` (r, n, n), ``mu`` (r,) are the previous posteriors;
    ``Fs``, ``Qs`` (r, n, n) the mode models; ``z`` (m,) with common ``H``
    (m, n), ``R`` (m, m).  An empty ``z`` (m = 0) predicts only.  Returns
    :class:`IMMStep`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import imm_step
    >>> from trackcore.models import cv_transition, cv_process_noise, position_matrix
    >>> F = cv_transition(1.0, dim=1)
    >>> Fs = np.stack([F, F])
    >>> Qs = np.stack([cv_process_noise(1.0, 0.01, dim=1), cv_process_noise(1.0, 10.0, dim=1)])
    >>> H, R = position_matrix(dim=1, n=2), np.array([[1.0]])
    >>> xs, Ps = np.zeros((2, 2)), np.stack([np.eye(2), np.eye(2)])
    >>> step = imm_step(xs, Ps, [0.5, 0.5], [[0.95, 0.05], [0.05, 0.95]], Fs, Qs, [8.0], H, R)
    >>> print(np.round(step.mu, 3))     # a jump of 8 sigma favours the high-noise mode
    [0.011 0.989]
    >>> print(np.round(step.x, 3))
    [6.533 8.663]
    """
    z = as_vector(z, "z")
    m = z.shape[0]
    xs, Ps, mu, PI, Fs, Qs, H, R, r, n = _check_imm_inputs(xs, Ps, mu, PI, Fs, Qs, H, R, m)
    xs = xs.copy()
    Ps_in, Ps = Ps, Ps.copy()
    mu_new = np.empty(r)
    logliks = np.empty(r)
    total, bad = _imm_cycle(xs, Ps, mu, PI, Fs, Qs, z, False, H, R, np.empty((r, n)),
                            np.empty((r, n, n)), np.empty(r), np.empty(n), np.empty((n, n)),
                            np.empty((n, n)), np.empty(m), np.empty((m, m)), np.empty((n, m)),
                            *_update_scratch(n, m), logliks, mu_new)
    if bad >= 0:
        if bad == r:
            raise ValueError("no mode has positive probability after the update")
        raise ValueError(f"innovation covariance of mode {bad} is not positive definite")
    x, P = np.empty(n), np.empty((n, n))
    imm_combine_kernel(mu_new, xs, Ps, x, P)
    _finite_outputs("the IMM cycle", "xs, Ps, Fs, Qs, z, H and R", xs, Ps, x, P, logliks)
    args = (("R", R), ("Ps", Ps_in), ("Qs", Qs))
    if check_result_cov(Ps, "the mode-matched posterior covariance Ps", args):
        imm_combine_kernel(mu_new, xs, Ps, x, P)  # combine the projected covariances
    check_result_cov(P, "the combined posterior covariance", args)
    return IMMStep(xs, Ps, mu_new, x, P, logliks)


def imm_filter_run(zs, xs0, Ps0, mu0, PI, Fs, Qs, H, R):
    """Run the IMM over all scans ``zs`` (K, m) in one numba kernel.

    Starts from mode-matched priors ``xs0`` (r, n), ``Ps0`` (r, n, n) and mode
    probabilities ``mu0``; each scan is one :func:`imm_step`.  A row of NaN is a
    missed scan.  Returns :class:`IMMRun` ``(x (K, n), P (K, n, n), mu (K, r),
    loglik (K,))``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import imm_filter_run
    >>> from trackcore.models import cv_transition, cv_process_noise, position_matrix
    >>> F = cv_transition(1.0, dim=1)
    >>> Fs = np.stack([F, F])
    >>> Qs = np.stack([cv_process_noise(1.0, 0.01, dim=1), cv_process_noise(1.0, 10.0, dim=1)])
    >>> H, R = position_matrix(dim=1, n=2), np.array([[1.0]])
    >>> zs = np.array([[0.0], [1.0], [2.0], [9.0], [16.0]])   # a manoeuvre at scan 3
    >>> run = imm_filter_run(zs, np.zeros((2, 2)), np.stack([np.eye(2), np.eye(2)]), [0.5, 0.5],
    ...                      [[0.95, 0.05], [0.05, 0.95]], Fs, Qs, H, R)
    >>> print(np.round(run.mu, 3))
    [[0.575 0.425]
     [0.681 0.319]
     [0.76  0.24 ]
     [0.007 0.993]
     [0.05  0.95 ]]
    >>> print(np.round(run.x[-1], 3))
    [15.931  7.567]
    """
    if not (type(zs) is np.ndarray and zs.dtype == np.float64 and zs.ndim == 2
            and zs.flags.c_contiguous):
        zs = as_array(zs, "zs", ndim=2, finite=False)
    Kn, m = zs.shape
    if not math.isfinite(zs.sum()):
        nan_rows = np.isnan(zs)
        if np.any(nan_rows.any(axis=1) != nan_rows.all(axis=1)) or np.any(np.isinf(zs)):
            raise ValueError("zs must be finite; a missed scan is a row that is entirely NaN")
    xs0, Ps0, mu0, PI, Fs, Qs, H, R, r, n = _check_imm_inputs(
        xs0, Ps0, mu0, PI, Fs, Qs, H, R, m, names=("xs0", "Ps0", "mu0"))
    x_out, P_out = np.empty((Kn, n)), np.empty((Kn, n, n))
    mu_out, ll_out = np.empty((Kn, r)), np.empty(Kn)
    k, bad = imm_filter_run_kernel(zs, xs0, Ps0, mu0, PI, Fs, Qs, H, R, x_out, P_out, mu_out,
                                   ll_out)
    if k >= 0:
        if bad == r:
            raise ValueError(f"no mode has positive probability at scan {k}")
        raise ValueError(f"innovation covariance of mode {bad} is not positive definite "
                         f"at scan {k}")
    if Kn:  # a non-finite estimate stays non-finite (see kalman._finite_run)
        _finite_outputs("the IMM estimate", "zs, xs0, Ps0, Fs, Qs, H and R", x_out[-1],
                        P_out[-1], ll_out)
        check_result_cov(P_out, "the combined covariance P",
                         (("R", R), ("Ps0", Ps0), ("Qs", Qs)))
    return IMMRun(x_out, P_out, mu_out, ll_out)
