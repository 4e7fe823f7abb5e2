"""First-order Marcum Q function and the detection probability of a square-law detector.

Definition (Marcum 1960)::

    Q1(a, b) = int_b^inf x exp(-(x^2 + a^2)/2) I0(a x) dx,     a, b >= 0.

For a non-fluctuating (Swerling 0) target with linear signal-to-noise ratio ``snr``
behind a square-law detector whose threshold gives the false-alarm probability
``pfa`` (noise-normalised power threshold ``-ln pfa``)::

    P_D = Q1(sqrt(2 snr), sqrt(-2 ln pfa)).

Numerics
--------
With ``x = a^2/2`` and ``y = b^2/2``, ``X = |a + n|^2`` (``n`` complex normal, per real
component variance 1) is non-central chi-square with 2 degrees of freedom; ``X/2 ~
Gamma(J + 1, 1)`` with ``J ~ Poisson(x)``, so that, with ``M ~ Poisson(y)`` independent
of ``J``, ``Q1 = P(M <= J)`` and ``1 - Q1 = P(J < M)``.  Whichever of the two is the
smaller ("the small side", at most about 0.6) is computed directly, to full relative
precision, and the other one as one minus it; the kernels work in log space, so
``log Q1`` and ``log(1 - Q1)`` stay finite where the values underflow (``1 - P_D =
1.9e-19`` at 20 dB and ``P_fa = 1e-6``; ``Q1(2, 40) = 1.29e-315``).  Two regimes, by
``xi = a b``:

* ``xi < 40``: the Poisson double sums, rearranged into single sums of positive terms,
  ``Q1 = e^{-x-y} sum_{n>=0} (xy)^n / n!^2 g_n`` with ``g_n = 1 + (n/y) g_{n-1}``,
  ``g_0 = 1`` (used when ``y > x + 1``) and ``1 - Q1 = y e^{-x-y} sum_{k>=1}
  (xy)^{k-1} / (k! (k-1)!) f_{k-1}`` with ``f_j = 1 + (j/x) f_{j-1}`` (otherwise).  The
  ratio of successive terms is bounded by a decreasing sequence ``r_n``, so the remainder
  after a term ``t_n`` is at most ``t_n r_n / (1 - r_n)``; summation stops when that is
  below ``1e-17`` of the sum: ``xi/2 + O(sqrt(xi))`` terms, at most 70.
* ``xi >= 40``: the asymptotic expansion for large ``xi`` of Gil, Segura & Temme
  (2014, section 4.1), ``small side = (sqrt(rho)/2) erfc(|b - a|/sqrt 2) +- e^{-z}
  rho/sqrt(8 pi) sum_{n>=1} c_n xi^{1/2-n} H_n(z)`` with ``rho = b/a``, ``z = (b -
  a)^2/2``, ``c_n = A_n + B_n/rho > 0`` from the Bessel-function asymptotic
  coefficients and ``H_n(z) = e^z z^{n-1/2} Gamma(1/2 - n, z)`` (``+`` for ``Q1`` when
  ``b >= a``, ``-`` for ``1 - Q1`` when ``b < a``).  ``H_n`` is computed by its forward
  recurrence ``H_n = (1 - z H_{n-1})/(n - 1/2)`` when ``z <= 30`` and by the backward one
  (stable there) otherwise; the series is truncated once its terms fall below ``1e-17``
  of the sum (at most 20 terms at ``xi = 40``, 8 at ``xi = 743``, the book's 40 dB at
  ``P_fa = 1e-6``).

Every loop has a fixed maximum number of iterations, so the cost is bounded for all
finite inputs (``Q1(3e4, 1)`` and ``Q1(1e300, 1)`` cost no more than any other value),
and infinite ``x``, ``y`` or ``xi`` (arguments above ``1e154``) take the exact limits.
The accuracy is limited by the conditioning of the function itself: a relative change
``e`` of ``a`` or ``b`` changes ``Q1`` (or ``1 - Q1``) by about ``e max(a, b) |b - a|``
relatively.  Over the book's range (``a, b <= 150``), wherever the value is a normal double
(so ``|b - a| < 38``), that is below ``1e-12`` for inputs rounded to double precision, and
the computed values agree with a 60-digit reference to the same bound.

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
    "detection_probability",
    "log_marcum_detection_probability",
    "log_marcum_miss_probability",
    "log_marcum_q1",
    "log_marcum_q1_complement",
    "marcum_detection_probability",
    "marcum_miss_probability",
    "marcum_q1",
    "marcum_q1_complement",
    "rician_log_likelihood_ratio",
    "square_law_threshold",
    "swerling1_detection_probability",
    "swerling1_miss_probability",
]

_NEG_INF = -np.inf
# relative truncation error of every series (below double rounding)
_EPS = 1e-17
# xi = a b at and above which the large-xi asymptotic expansion is used
XI_ASYMPTOTIC = 40.0
# z = (b - a)^2 / 2 up to which H_n is computed by forward recurrence
Z_FORWARD = 30.0
# hard caps on the number of iterations (never reached for finite input: see the tests)
_MAX_SERIES_TERMS = 400
_MAX_ASYMPTOTIC_TERMS = 60
_SQRT_PI = math.sqrt(math.pi)
_INV_SQRT2 = 1.0 / math.sqrt(2.0)
_SQRT_2PI = math.sqrt(2.0 * math.pi)


def _tables(n_asym, n_series):
    """Coefficients ``A_n = (-1)^n a_n(0)``, ``B_n = -(-1)^n a_n(1)`` of the Bessel
    asymptotic series ``I_nu(w) ~ e^w / sqrt(2 pi w) sum (-1)^n a_n(nu) / w^n``
    (``a_n(nu) = prod_{j<=n} (4 nu^2 - (2j - 1)^2) / (n! 8^n)``; both positive for
    ``n >= 1``), ``1/(n - 1/2)`` and the reciprocals ``1/n``."""
    A = np.zeros(n_asym + 1)
    B = np.zeros(n_asym + 1)
    half = np.zeros(n_asym + 1)
    A[0] = B[0] = 1.0
    for k in range(1, n_asym + 1):
        A[k] = A[k - 1] * (2 * k - 1) ** 2 / (8.0 * k)
        B[k] = B[k - 1] * abs(4.0 - (2 * k - 1) ** 2) / (8.0 * k)
        half[k] = 1.0 / (k - 0.5)
    inv = np.zeros(n_series + 3)
    inv[1:] = 1.0 / np.arange(1, n_series + 3)
    return A, B, half, inv


_A, _B, _INV_HALF, _INV = _tables(_MAX_ASYMPTOTIC_TERMS + 1, _MAX_SERIES_TERMS)


@nb.njit(cache=True)
def _erfcx_large(t):
    """``exp(t^2) erfc(t)`` for ``t >= 25`` by its asymptotic series (8 terms: error
    below ``3e-17`` relative)."""
    u = 1.0 / (2.0 * t * t)
    s = 1.0
    term = 1.0
    for k in range(1, 9):
        term *= -(2 * k - 1) * u
        s += term
    return s / (t * _SQRT_PI)


@nb.njit(cache=True)
def _log_q_series(x, y):
    """``log Q1`` for ``y > x`` and ``xi < 40`` (see the module notes)."""
    w = x * y
    iy = 1.0 / y
    s = 1.0
    v = 1.0
    g = 1.0
    for n in range(1, _MAX_SERIES_TERMS):
        v *= w * _INV[n] * _INV[n]
        g = 1.0 + n * iy * g
        t = v * g
        s += t
        # t_{n+1}/t_n <= r_n = w / ((n+1)^2 g_n) + x/(n+1), decreasing in n; rg = r_n g_n
        rg = w * _INV[n + 1] * _INV[n + 1] + x * g * _INV[n + 1]
        if rg < g and t * rg <= _EPS * s * (g - rg):
            break
    return math.log(s) - x - y


@nb.njit(cache=True)
def _log_p_series(x, y, log_y):
    """``log(1 - Q1)`` for ``y <= x + 1`` and ``xi < 40`` (see the module notes)."""
    s = 1.0
    if x < 1.0:
        # 1 - Q1 = y e^{-x-y} sum_{k>=1} y^{k-1}/k! e_{k-1}, e_j = sum_{n<=j} x^n/n!
        v = 1.0        # y^{k-1}/k!
        e = 1.0        # e_{k-1}
        p = 1.0        # x^{k-1}/(k-1)!
        for k in range(1, _MAX_SERIES_TERMS):
            v *= y * _INV[k + 1]
            p *= x * _INV[k]
            e += p
            t = v * e
            s += t
            # t_{k+2}/t_{k+1} <= y (1 + x/(k+1)) / (k+2), decreasing in k
            r = y * (1.0 + x * _INV[k + 1]) * _INV[k + 2]
            if r < 1.0 and t * r <= _EPS * s * (1.0 - r):
                break
        return log_y + math.log(s) - x - y
    # 1 - Q1 = y e^{-x-y} sum_{k>=1} (xy)^{k-1}/(k!(k-1)!) f_{k-1}, f_j = 1 + (j/x) f_{j-1}
    w = x * y
    ix = 1.0 / x
    u = 1.0
    f = 1.0
    for k in range(1, _MAX_SERIES_TERMS):
        f = 1.0 + k * ix * f
        u *= w * _INV[k] * _INV[k + 1]
        t = u * f
        s += t
        # t_{k+2}/t_{k+1} <= w / ((k+1)(k+2) f_k) + y/(k+2), decreasing; rf = ratio f_k
        rf = w * _INV[k + 1] * _INV[k + 2] + y * f * _INV[k + 2]
        if rf < f and t * rf <= _EPS * s * (f - rf):
            break
    return log_y + math.log(s) - x - y


@nb.njit(cache=True)
def _log_asymptotic(a, b):
    """``(log of the small side, it is Q1)`` for ``xi = a b >= 40``, ``a, b`` finite.

    The small side is ``e^{-z} lead (1 +- ratio)`` with ``lead = sqrt(rho)/2 erfcx(t)``,
    ``t = sqrt(z)``, and ``ratio = rho sqrt(1/xi) S / (sqrt(8 pi) lead)``; with the
    coefficients scaled by ``min(1, 1/rho)`` (``c_n`` when ``rho >= 1``, ``rho c_n``
    otherwise) the ratio is ``S / (sqrt(2 pi) min(a, b) erfcx(t))``, free of overflow.
    """
    q_side = b >= a
    t = abs(b - a) * _INV_SQRT2          # sqrt(z)
    z = t * t
    if z == np.inf:
        return _NEG_INF, q_side
    s = 1.0 / (a * b)                   # 1 / xi (0 when xi overflows)
    if q_side:
        fa, fb, small = 1.0, a / b, a   # c_n = A_n + B_n / rho
    else:
        fa, fb, small = b / a, 1.0, b   # rho c_n = A_n rho + B_n
    if z <= Z_FORWARD:
        E = math.exp(z) * math.erfc(t)
        # H_1 = 2 (1 - sqrt(pi z) erfcx(sqrt z)), then H_n = (1 - z H_{n-1}) / (n - 1/2)
        H = 2.0 * (1.0 - _SQRT_PI * t * E)
        S = (_A[1] * fa + _B[1] * fb) * H
        p = 1.0
        for n in range(2, _MAX_ASYMPTOTIC_TERMS):
            H = (1.0 - z * H) * _INV_HALF[n]
            p *= s
            term = (_A[n] * fa + _B[n] * fb) * p * H
            S += term
            if term <= _EPS * S:
                break
    else:
        E = math.exp(z) * math.erfc(t) if t < 25.0 else _erfcx_large(t)
        # truncation index N: c_N xi^{1-N} below 1e-18 c_1 (H_n decreases in n)
        c1 = _A[1] * fa + _B[1] * fb
        p = 1.0
        N = _MAX_ASYMPTOTIC_TERMS - 1
        for n in range(2, _MAX_ASYMPTOTIC_TERMS):
            p *= s
            if (_A[n] * fa + _B[n] * fb) * p <= 0.1 * _EPS * c1:
                N = n
                break
        # backward recurrence H_{n-1} = (1 - (n - 1/2) H_n) / z from n = N + 6, started
        # from two levels of the continued fraction of Gamma(1/2 - n, z) (its error
        # shrinks by (n - 1/2)/z < 1 per step), then Horner's scheme in 1/xi downwards
        top = N + 6
        iz = 1.0 / z
        H = 1.0 / (z + top + 0.5 - (top + 0.5) / (z + top + 2.5))
        for n in range(top, N, -1):
            H = (1.0 - (n - 0.5) * H) * iz
        S = (_A[N] * fa + _B[N] * fb) * H
        for n in range(N, 1, -1):
            H = (1.0 - (n - 0.5) * H) * iz
            S = (_A[n - 1] * fa + _B[n - 1] * fb) * H + s * S
    ratio = S / (_SQRT_2PI * small * E)
    f = 1.0 + ratio if q_side else 1.0 - ratio
    lead = 0.5 * math.sqrt(b / a) * E
    if lead > 1e-290:
        return math.log(lead * f) - z, q_side
    return math.log(0.5 * E * f) + 0.5 * (math.log(b) - math.log(a)) - z, q_side


@nb.njit(cache=True)
def _log_small_side(a, b, x, y):
    """``(log s, is_q)``: ``s`` is ``Q1(a, b)`` if ``is_q`` else ``1 - Q1(a, b)``, the
    smaller of the two (up to about 0.6); ``x = a^2/2``, ``y = b^2/2`` (possibly
    ``inf``).  ``a, b >= 0``, not NaN."""
    if b == 0.0:
        return _NEG_INF, False                       # 1 - Q1 = 0
    if b == np.inf:
        return _NEG_INF, True                        # Q1 = 0
    if x < 1e-300:
        # Q1(0, b) = e^{-y}; for 0 < x < 1e-300 the correction, relatively O(x y) to Q1
        # and O(x) to log Q1, is below rounding wherever Q1 (or 1 - Q1) is a double
        if y > 1.0:
            return -y, True
        if y < 1e-300:                               # y underflows: 1 - e^{-y} = y
            return 2.0 * math.log(b) - math.log(2.0), False
        return math.log(-math.expm1(-y)), False
    if a == np.inf:
        return _NEG_INF, False
    if a * b >= XI_ASYMPTOTIC:
        return _log_asymptotic(a, b)
    if y > x + 1.0:
        if y == np.inf:
            return _NEG_INF, True
        return _log_q_series(x, y), True
    if x == np.inf:
        return _NEG_INF, False                       # 1 - Q1 < e^{-x}: below 1e-308
    return _log_p_series(x, y, 2.0 * math.log(b) - math.log(2.0)), False


@nb.njit(cache=True)
def _log_side(a, b, x, y, complement):
    """``log Q1`` or, with ``complement``, ``log(1 - Q1)``."""
    ls, is_q = _log_small_side(a, b, x, y)
    if is_q != complement:
        return ls
    return math.log1p(-math.exp(ls))


@nb.njit(cache=True)
def _side(a, b, x, y, complement):
    """``Q1`` or, with ``complement``, ``1 - Q1`` (the large side as one minus the small)."""
    ls, is_q = _log_small_side(a, b, x, y)
    if is_q != complement:
        return math.exp(ls)
    return -math.expm1(ls)


@nb.njit(cache=True)
def log_marcum_q1_pair_kernel(a, b):
    """``(log Q1(a, b), log(1 - Q1(a, b)))`` for ``a, b >= 0`` (not NaN)."""
    ls, is_q = _log_small_side(a, b, 0.5 * a * a, 0.5 * b * b)
    other = math.log1p(-math.exp(ls))
    if is_q:
        return ls, other
    return other, ls


@nb.njit(cache=True)
def _q1_array(a, b, complement, log, out):
    for i in range(a.shape[0]):
        ai = a[i]
        bi = b[i]
        if log:
            out[i] = _log_side(ai, bi, 0.5 * ai * ai, 0.5 * bi * bi, complement)
        else:
            out[i] = _side(ai, bi, 0.5 * ai * ai, 0.5 * bi * bi, complement)


@nb.njit(cache=True)
def _pd_array(snr, log_pfa, complement, log, out):
    """``P_D`` (or ``1 - P_D``, or their logs) of ``snr[i]`` at ``log_pfa[i]``
    (``log_pfa`` of length 1 is broadcast)."""
    one = log_pfa.shape[0] == 1
    for i in range(snr.shape[0]):
        mu = -log_pfa[0] if one else -log_pfa[i]
        x = snr[i]
        a = math.sqrt(2.0 * x)
        b = math.sqrt(2.0 * mu)
        if log:
            out[i] = _log_side(a, b, x, mu, complement)
        else:
            out[i] = _side(a, b, x, mu, complement)


@nb.njit(cache=True)
def log_marcum_detection_probability_kernel(snr, log_pfa, complement, out):
    """``log P_D`` (or ``log(1 - P_D)`` if ``complement``) of a non-fluctuating target.

    ``snr`` (m,) linear, ``>= 0``; ``log_pfa`` = ``ln P_fa`` (< 0).  Writes into ``out``.
    """
    mu = -log_pfa
    b = math.sqrt(2.0 * mu)
    for i in range(snr.shape[0]):
        out[i] = _log_side(math.sqrt(2.0 * snr[i]), b, snr[i], mu, complement)


@nb.njit(cache=True)
def log_marcum_detection_probability_scalar_kernel(snr, log_pfa):
    """``log P_D`` of one detection (numba-callable): ``snr >= 0`` linear, ``log_pfa < 0``."""
    mu = -log_pfa
    return _log_side(math.sqrt(2.0 * snr), math.sqrt(2.0 * mu), snr, mu, False)


@nb.njit(cache=True)
def _scalar_q1(a, b, complement, log):
    if log:
        return _log_side(a, b, 0.5 * a * a, 0.5 * b * b, complement)
    return _side(a, b, 0.5 * a * a, 0.5 * b * b, complement)


@nb.njit(cache=True)
def _scalar_pd(snr, log_pfa, complement, log):
    mu = -log_pfa
    a = math.sqrt(2.0 * snr)
    b = math.sqrt(2.0 * mu)
    if log:
        return _log_side(a, b, snr, mu, complement)
    return _side(a, b, snr, mu, complement)


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


_PLAIN = (float, int)


def _plain_scalar(v, name):
    """A Python float/int checked like :func:`_nonneg` would (fast path), else None."""
    if type(v) not in _PLAIN:
        return None
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must contain only finite values (found NaN or inf)")
    if v < 0:
        raise ValueError(f"{name} must be non-negative")
    return v


def _q1(a, b, complement, log):
    sa = _plain_scalar(a, "a")
    sb = _plain_scalar(b, "b") if sa is not None else None
    if sb is not None:
        return float(_scalar_q1(sa, sb, complement, log))
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
    _q1_array(A, B, complement, log, out)
    return _finish(out, shape)


def marcum_q1(a, b):
    """First-order Marcum Q function ``Q1(a, b)`` (vectorised over broadcast ``a, b``).

    ``a, b >= 0`` finite.  Accurate to about 1e-13 relative in both tails (see the
    module notes for the limit set by the conditioning of ``Q1``); use
    :func:`marcum_q1_complement` for ``1 - Q1`` when ``Q1`` is close to 1 and
    :func:`log_marcum_q1` when ``Q1`` underflows.  Returns a float for scalar input.

    Examples
    --------
    >>> import math
    >>> from trackcore.detection import marcum_q1
    >>> round(float(marcum_q1(0.0, 2.0)), 6), round(math.exp(-2.0), 6)  # exp(-b^2 / 2)
    (0.135335, 0.135335)
    >>> round(float(marcum_q1(3.0, 1.0)), 4)
    0.9892
    """
    return _q1(a, b, False, False)


def marcum_q1_complement(a, b):
    """``1 - Q1(a, b)`` computed directly (no cancellation when ``Q1 -> 1``).

    Examples
    --------
    >>> from trackcore.detection import marcum_q1_complement
    >>> f"{float(marcum_q1_complement(10.0, 1.0)):.3e}"  # below machine epsilon
    '3.414e-20'
    """
    return _q1(a, b, True, False)


def log_marcum_q1(a, b):
    """``ln Q1(a, b)``, finite even where ``Q1`` underflows (``-inf`` only if ``Q1 = 0``).

    Examples
    --------
    >>> from trackcore.detection import log_marcum_q1
    >>> round(float(log_marcum_q1(1.0, 50.0)), 2)         # Q1 itself underflows to 0
    -1203.35
    """
    return _q1(a, b, False, True)


def log_marcum_q1_complement(a, b):
    """``ln(1 - Q1(a, b))`` computed directly (``-inf`` at ``b = 0``).

    Examples
    --------
    >>> import math
    >>> from trackcore.detection import log_marcum_q1_complement, marcum_q1
    >>> round(float(log_marcum_q1_complement(2.0, 1.0)), 4)
    -2.5024
    >>> round(math.log(1 - float(marcum_q1(2.0, 1.0))), 4)
    -2.5024
    """
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
    if type(snr) in _PLAIN and type(pfa) in _PLAIN:
        s = float(snr)
        p = float(pfa)
        if math.isfinite(s) and s >= 0 and 0.0 < p < 1.0:
            return float(_scalar_pd(s, math.log(p), complement, log))
    S, P = _snr_pfa(snr, pfa)
    shape = S.shape
    S = np.ascontiguousarray(S, dtype=np.float64).reshape(-1)
    logP = np.log(np.ascontiguousarray(P, dtype=np.float64).reshape(-1))
    if logP.size and np.all(logP == logP[0]):
        logP = logP[:1]
    out = np.empty(S.shape[0])
    _pd_array(S, logP, complement, log, out)
    return _finish(out, shape)


def marcum_detection_probability(snr, pfa):
    """``P_D = Q1(sqrt(2 snr), sqrt(-2 ln pfa))`` of a non-fluctuating target (eq 9).

    ``snr``: *linear* signal-to-noise power ratio (``>= 0``; convert dB with
    ``10**(dB/10)``); ``pfa`` in the open interval (0, 1).  Broadcasts.  At
    ``snr = 0`` the result is ``pfa``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.detection import marcum_detection_probability
    >>> print(np.round(marcum_detection_probability(np.array([1.0, 10.0, 30.0]), 1e-4), 4))
    [0.0037 0.6161 0.9998]
    """
    return _pd(snr, pfa, False, False)


detection_probability = marcum_detection_probability


def marcum_miss_probability(snr, pfa):
    """``1 - P_D`` computed directly (accurate when ``P_D`` is close to 1).

    Examples
    --------
    >>> from trackcore.detection import marcum_miss_probability, marcum_detection_probability
    >>> f"{float(marcum_miss_probability(100.0, 1e-6)):.3e}"
    '1.921e-19'
    >>> float(1 - marcum_detection_probability(100.0, 1e-6))      # the subtraction loses it
    0.0
    """
    return _pd(snr, pfa, True, False)


def log_marcum_detection_probability(snr, pfa):
    """``ln P_D`` (finite where ``P_D`` underflows).

    Examples
    --------
    >>> import math
    >>> from trackcore.detection import log_marcum_detection_probability
    >>> ln_pd = log_marcum_detection_probability(0.0, 1e-300)   # P_D = 1e-300 itself at zero SNR
    >>> round(float(ln_pd), 3), round(math.log(1e-300), 3)
    (-690.776, -690.776)
    """
    return _pd(snr, pfa, False, True)


def log_marcum_miss_probability(snr, pfa):
    """``ln(1 - P_D)`` (finite where ``1 - P_D`` underflows).

    Examples
    --------
    >>> from trackcore.detection import log_marcum_miss_probability
    >>> round(float(log_marcum_miss_probability(1000.0, 1e-6)), 1)   # 1 - P_D underflows to 0
    -784.4
    """
    return _pd(snr, pfa, True, True)


def swerling1_detection_probability(snr, pfa):
    """Swerling I average ``P_D = pfa^(1/(1 + snr))`` (``snr`` = mean linear SNR).

    Exponentially distributed target power, constant within the dwell, single
    square-law detection.  Broadcasts; returns a float for scalar input.

    Examples
    --------
    >>> from trackcore.detection import swerling1_detection_probability
    >>> round(float(swerling1_detection_probability(20.0, 1e-6)), 4)    # 1e-6 ** (1 / 21)
    0.5179
    """
    S, P = _snr_pfa(snr, pfa)
    out = np.exp(np.log(P) / (1.0 + S))
    return float(out) if out.shape == () else out


def swerling1_miss_probability(snr, pfa):
    """``1 - pfa^(1/(1 + snr))`` computed with ``expm1`` (no cancellation).

    Examples
    --------
    >>> from trackcore.detection import swerling1_miss_probability
    >>> f"{float(swerling1_miss_probability(1e12, 1e-6)):.4e}"  # no cancellation
    '1.3816e-11'
    """
    S, P = _snr_pfa(snr, pfa)
    out = -np.expm1(np.log(P) / (1.0 + S))
    return float(out) if out.shape == () else out


def square_law_threshold(pfa):
    """Noise-normalised power threshold ``tau = -ln pfa`` of a square-law detector
    (``ζ = |s + n|^2`` with ``n ~ CN(0, 1)``), and conversely ``pfa = exp(-tau)``.

    Examples
    --------
    >>> from trackcore.detection import square_law_threshold
    >>> round(float(square_law_threshold(1e-6)), 4)        # -ln 1e-6
    13.8155
    """
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

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.detection import rician_log_likelihood_ratio
    >>> print(np.round(rician_log_likelihood_ratio(np.array([0.0, 10.0, 1e4]), snr=10.0), 3))
    [-10.      7.59  618.312]
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
