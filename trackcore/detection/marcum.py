"""First-order Marcum Q function and the detection probability of a square-law detector.

Definition (Marcum 1960)::

    Q1(a, b) = int_b^inf x exp(-(x^2 + a^2)/2) I0(a x) dx,     a, b >= 0.

For a non-fluctuating (Swerling 0) target with linear signal-to-noise ratio ``snr``
behind a square-law detector whose threshold gives the false-alarm probability
``pfa`` (noise-normalised power threshold ``-ln pfa``)::

    P_D = Q1(sqrt(2 snr), sqrt(-2 ln pfa)).

Numerics
--------
With ``lam = a^2/2`` and ``mu = b^2/2``, ``X = |a + n|^2`` (``n`` complex unit
normal, per real component variance 1) is non-central chi-square with 2 degrees of
freedom; ``X/2 ~ Gamma(J + 1, 1)`` with ``J ~ Poisson(lam)``, and
``P(Gamma(J+1) >= mu) = P(M <= J)`` with ``M ~ Poisson(mu)``.  Hence, with ``J`` and
``M`` independent Poisson variables of means ``lam`` and ``mu``::

    Q1(a, b)     = P(M <= J) = sum_{n>=0} p_lam(n) P(M <= n),
    1 - Q1(a, b) = P(J <  M) = sum_{n>=1} p_mu(n)  P(J <= n - 1).

Both are sums of *positive* terms, so each is computed to full relative precision
directly: there is no cancellation in either tail, and ``1 - P_D`` near 0 (e.g.
``1.9e-19`` at 20 dB, ``P_fa = 1e-6``) is as accurate as ``P_D`` near 0.  The kernel
accumulates in log space (running log-sum-exp), so ``log Q1`` is available even
where ``Q1`` underflows.  Whichever side exceeds 1/2 is returned as one minus the
other side (itself summed directly), so it is exact to rounding and never exceeds 1.  The series is truncated with a rigorous bound: once past
the Poisson mode the ratio of successive terms is bounded by
``r_n = alpha/(n+1) (1 + beta/(n+1-s)) < 1`` and decreasing, so the remainder is at
most ``t_n r_n / (1 - r_n)``; summation stops when that is below ``1e-17`` of the sum.
The cost is ``O(lam + mu + sqrt(lam))`` terms: about 400 at 25 dB SNR, so the
function is meant for the radar range of arguments (``a, b`` up to a few hundred),
not for ``a`` in the thousands.

Swerling I (exponentially distributed power, mean ``snr``, constant within the
dwell) averages ``P_D`` in closed form: ``P_D = pfa^(1/(1 + snr))``.

Naming: :func:`detection_probability` ``(snr, pfa)`` is the book's public name for the
square-law Marcum form; :func:`marcum_detection_probability` is the same function under a
name that says which model it is (the HPDA chapter's exponential-amplitude model is
``exponential_detection_probability(tau, snr)`` in ``trackcore/detection/amplitude.py``).
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import as_array

__all__ = [
    "marcum_q1",
    "marcum_q1_complement",
    "log_marcum_q1",
    "log_marcum_q1_complement",
    "log_marcum_q1_pair_kernel",
    "detection_probability",
    "marcum_detection_probability",
    "marcum_miss_probability",
    "log_marcum_detection_probability",
    "log_marcum_miss_probability",
    "log_marcum_detection_probability_kernel",
    "log_marcum_detection_probability_scalar_kernel",
    "swerling1_detection_probability",
    "swerling1_miss_probability",
    "square_law_threshold",
    "rician_log_likelihood_ratio",
]

_NEG_INF = -np.inf
# relative truncation error of the series (below double rounding)
_LOG_EPS = math.log(1e-17)


@nb.njit(cache=True, inline="always")
def _logaddexp(x, y):
    if x == _NEG_INF:
        return y
    if y == _NEG_INF:
        return x
    if x > y:
        return x + math.log1p(math.exp(y - x))
    return y + math.log1p(math.exp(x - y))


@nb.njit(cache=True)
def _log_poisson_mixture(alpha, beta, s):
    """``log sum_{n >= s} p_alpha(n) P(Poisson(beta) <= n - s)`` for ``s`` in {0, 1}.

    ``p_alpha(n) = exp(-alpha) alpha^n / n!``.  ``alpha, beta >= 0``.
    """
    if beta == 0.0:
        # P(Poisson(0) <= k) = 1 for k >= 0: sum_{n >= s} p_alpha(n)
        if s == 0:
            return 0.0
        return math.log(-math.expm1(-alpha)) if alpha > 0.0 else _NEG_INF
    if alpha == 0.0:
        # only n = 0 has mass: P(Poisson(beta) <= -s)
        if s == 0:
            return -beta
        return _NEG_INF
    log_alpha = math.log(alpha)
    log_beta = math.log(beta)
    log_c = _NEG_INF      # log P(Poisson(beta) <= k), built up term by term
    log_pb = -beta        # log p_beta(k), k = 0
    k = 0                 # next k whose p_beta(k) enters log_c
    total = _NEG_INF
    n = s
    while True:
        # bring log_c up to k = n - s
        while k <= n - s:
            log_c = _logaddexp(log_c, log_pb)
            k += 1
            log_pb += log_beta - math.log(k)
        log_t = n * log_alpha - alpha - math.lgamma(n + 1.0) + log_c
        total = _logaddexp(total, log_t)
        if n + 1.0 > alpha:
            r = alpha / (n + 1.0) * (1.0 + beta / (n + 1.0 - s))
            if r < 1.0:
                # remainder <= t_n r / (1 - r)
                log_rem = log_t + math.log(r) - math.log1p(-r)
                if log_rem < total + _LOG_EPS:
                    return total
        n += 1


_LOG_HALF = math.log(0.5)


@nb.njit(cache=True)
def _log_q1_side(lam, mu, complement):
    """``log Q1`` (or ``log(1 - Q1)``) at ``lam = a^2/2``, ``mu = b^2/2``.

    The requested side is summed directly.  If it exceeds 1/2, the other side
    (then < 1/2) is summed too and the result is ``log1p(-other)``: this keeps the
    large side exact to rounding and never above 1.
    """
    if complement:
        x = _log_poisson_mixture(mu, lam, 1)
    else:
        x = _log_poisson_mixture(lam, mu, 0)
    if x > _LOG_HALF:
        if complement:
            y = _log_poisson_mixture(lam, mu, 0)
        else:
            y = _log_poisson_mixture(mu, lam, 1)
        return math.log1p(-math.exp(y))
    return x


@nb.njit(cache=True)
def log_marcum_q1_pair_kernel(a, b):
    """``(log Q1(a, b), log(1 - Q1(a, b)))`` for finite ``a, b >= 0``."""
    lam = 0.5 * a * a
    mu = 0.5 * b * b
    x = _log_poisson_mixture(lam, mu, 0)
    y = _log_poisson_mixture(mu, lam, 1)
    if x > _LOG_HALF:
        x = math.log1p(-math.exp(y))
    else:
        y = math.log1p(-math.exp(x))
    return x, y


@nb.njit(cache=True)
def _log_q1_array(a, b, complement, out):
    for i in range(a.shape[0]):
        out[i] = _log_q1_side(0.5 * a[i] * a[i], 0.5 * b[i] * b[i], complement)


@nb.njit(cache=True)
def log_marcum_detection_probability_kernel(snr, log_pfa, complement, out):
    """``log P_D`` (or ``log(1 - P_D)`` if ``complement``) of a non-fluctuating target.

    ``snr`` (m,) linear, ``>= 0``; ``log_pfa`` = ``ln P_fa`` (< 0).  Writes into ``out``.
    Direct form: ``lam = snr``, ``mu = -ln P_fa``.
    """
    mu = -log_pfa
    for i in range(snr.shape[0]):
        out[i] = _log_q1_side(snr[i], mu, complement)


@nb.njit(cache=True)
def log_marcum_detection_probability_scalar_kernel(snr, log_pfa):
    """``log P_D`` of one detection (numba-callable): ``snr >= 0`` linear, ``log_pfa < 0``."""
    return _log_q1_side(snr, -log_pfa, False)


# ---------------------------------------------------------------------- wrappers
def _array(x, name):
    """``as_array`` that keeps a scalar's shape ``()`` (so scalars come back as floats)."""
    arr = as_array(x, name)
    return arr.reshape(np.shape(x))


def _nonneg(x, name):
    arr = _array(x, name)
    if arr.size and np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative")
    return arr


def _finish(values, shape):
    if shape == ():
        return float(values[0])
    return values.reshape(shape)


def _q1(a, b, complement, log):
    a = _nonneg(a, "a")
    b = _nonneg(b, "b")
    try:
        A, B = np.broadcast_arrays(a, b)
    except ValueError:
        raise ValueError(f"a and b must broadcast together, got shapes {a.shape} and {b.shape}") from None
    shape = A.shape
    A = np.ascontiguousarray(A, dtype=np.float64).reshape(-1)
    B = np.ascontiguousarray(B, dtype=np.float64).reshape(-1)
    out = np.empty(A.shape[0])
    _log_q1_array(A, B, complement, out)
    if not log:
        out = np.exp(out)
    return _finish(out, shape)


def marcum_q1(a, b):
    """First-order Marcum Q function ``Q1(a, b)`` (vectorised over broadcast ``a, b``).

    ``a, b >= 0`` finite.  Accurate to about 1e-13 relative in both tails; use
    :func:`marcum_q1_complement` for ``1 - Q1`` when ``Q1`` is close to 1 and
    :func:`log_marcum_q1` when ``Q1`` underflows.  Returns a float for scalar input.
    """
    return _q1(a, b, False, False)


def marcum_q1_complement(a, b):
    """``1 - Q1(a, b)`` computed directly (no cancellation when ``Q1 -> 1``)."""
    return _q1(a, b, True, False)


def log_marcum_q1(a, b):
    """``ln Q1(a, b)``, finite even where ``Q1`` underflows (``-inf`` only if ``Q1 = 0``)."""
    return _q1(a, b, False, True)


def log_marcum_q1_complement(a, b):
    """``ln(1 - Q1(a, b))`` computed directly (``-inf`` at ``b = 0``)."""
    return _q1(a, b, True, True)


def _snr_pfa(snr, pfa):
    snr = _array(snr, "snr")
    if snr.size and np.any(snr < 0):
        raise ValueError("snr must be a non-negative linear power ratio (not dB)")
    pfa = _array(pfa, "pfa")
    if pfa.size and np.any((pfa <= 0) | (pfa >= 1)):
        raise ValueError("pfa must lie in the open interval (0, 1)")
    try:
        S, P = np.broadcast_arrays(snr, pfa)
    except ValueError:
        raise ValueError(
            f"snr and pfa must broadcast together, got shapes {snr.shape} and {pfa.shape}") from None
    return S, P


def _pd(snr, pfa, complement, log):
    S, P = _snr_pfa(snr, pfa)
    shape = S.shape
    S = np.ascontiguousarray(S, dtype=np.float64).reshape(-1)
    logP = np.log(np.ascontiguousarray(P, dtype=np.float64).reshape(-1))
    out = np.empty(S.shape[0])
    if S.size == 0:
        pass
    elif np.all(logP == logP[0]):
        log_marcum_detection_probability_kernel(S, logP[0], complement, out)
    else:
        _log_q1_array(np.sqrt(2.0 * S), np.sqrt(-2.0 * logP), complement, out)
    if not log:
        out = np.exp(out)
    return _finish(out, shape)


def marcum_detection_probability(snr, pfa):
    """``P_D = Q1(sqrt(2 snr), sqrt(-2 ln pfa))`` of a non-fluctuating target (eq 9).

    ``snr``: *linear* signal-to-noise power ratio (``>= 0``; convert dB with
    ``10**(dB/10)``); ``pfa`` in the open interval (0, 1).  Broadcasts.  At
    ``snr = 0`` the result is ``pfa``.
    """
    return _pd(snr, pfa, False, False)


detection_probability = marcum_detection_probability


def marcum_miss_probability(snr, pfa):
    """``1 - P_D`` computed directly (accurate when ``P_D`` is close to 1)."""
    return _pd(snr, pfa, True, False)


def log_marcum_detection_probability(snr, pfa):
    """``ln P_D`` (finite where ``P_D`` underflows)."""
    return _pd(snr, pfa, False, True)


def log_marcum_miss_probability(snr, pfa):
    """``ln(1 - P_D)`` (finite where ``1 - P_D`` underflows)."""
    return _pd(snr, pfa, True, True)


def swerling1_detection_probability(snr, pfa):
    """Swerling I average ``P_D = pfa^(1/(1 + snr))`` (``snr`` = mean linear SNR).

    Exponentially distributed target power, constant within the dwell, single
    square-law detection.  Broadcasts; returns a float for scalar input.
    """
    S, P = _snr_pfa(snr, pfa)
    out = np.exp(np.log(P) / (1.0 + S))
    return float(out) if out.shape == () else out


def swerling1_miss_probability(snr, pfa):
    """``1 - pfa^(1/(1 + snr))`` computed with ``expm1`` (no cancellation)."""
    S, P = _snr_pfa(snr, pfa)
    out = -np.expm1(np.log(P) / (1.0 + S))
    return float(out) if out.shape == () else out


def square_law_threshold(pfa):
    """Noise-normalised power threshold ``tau = -ln pfa`` of a square-law detector
    (``ζ = |s + n|^2`` with ``n ~ CN(0, 1)``), and conversely ``pfa = exp(-tau)``."""
    P = _array(pfa, "pfa")
    if P.size and np.any((P <= 0) | (P >= 1)):
        raise ValueError("pfa must lie in the open interval (0, 1)")
    out = -np.log(P)
    return float(out) if out.shape == () else out


def rician_log_likelihood_ratio(zeta, snr):
    """``ln(p_1(ζ | S) / p_0(ζ)) = ln I0(2 sqrt(S ζ)) - S`` of the square-law statistic.

    ``p_0(ζ) = e^{-ζ}`` (noise, ``CN(0, 1)``) and ``p_1(ζ | S) = e^{-(ζ + S)} I0(2 sqrt(S ζ))``
    (non-fluctuating target of linear SNR ``S``).  Computed with the scaled Bessel function,
    so it does not overflow.  Divide by ``P_D / P_fa`` for the densities truncated at a
    threshold.
    """
    from scipy.special import i0e
    z = _array(zeta, "zeta")
    if z.size and np.any(z < 0):
        raise ValueError("zeta must be non-negative")
    S = _array(snr, "snr")
    if S.size and np.any(S < 0):
        raise ValueError("snr must be a non-negative linear power ratio (not dB)")
    x = 2.0 * np.sqrt(S * z)
    out = np.log(i0e(x)) + x - S
    return float(out) if np.shape(out) == () else out
