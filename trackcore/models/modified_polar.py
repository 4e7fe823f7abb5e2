"""Reduced modified-polar model of a stationary (drifting) point seen from a moving observer.

State ``xb = [theta, beta]`` with bearing ``theta = atan2(y, x)`` and inverse
range ``beta = 1/r`` of the point relative to the observer (Aidala & Hammel
1983, reduced to the two observable-by-bearings components of a stationary
point; Jeong & Hong 1996, eqs 5, 7, 10, 11, 13, 14).  Between two scans the
observer moves by ``ub = [dx_o, dy_o]``; the point does not move, so

    S1 = beta (-u2 cos theta + u1 sin theta)     (cross-LOS, divided by r)
    S2 = 1 + beta (-u2 sin theta - u1 cos theta) (along-LOS, divided by r)
    f(xb, ub) = [theta + atan2(S1, S2), beta / sqrt(S1^2 + S2^2)]

``atan2`` replaces the paper's ``tan^-1(S1/S2)`` (identical while S2 > 0,
i.e. while the observer's displacement along the LOS is less than the range).
``f`` is exact for any ``beta`` with ``S1^2 + S2^2 > 0`` (negative ``beta``,
which an EKF can produce, is evaluated by the same formula).

Process noise: a Cartesian drift velocity with white noise of PSD
``sigma_p^2`` gives ``Qbar = sigma_p^2 T I_2`` (eq 13), mapped to the state by
the Jacobian of ``(theta, 1/r)`` w.r.t. ``(x, y)`` (first order, eq 14):
``Q = sigma_p^2 T diag(beta^2, beta^4)``.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import as_nonnegative, as_vector

__all__ = [
    "modified_polar_f",
    "modified_polar_F",
    "modified_polar_Q",
    "modified_polar_from_cartesian",
]


@nb.njit(cache=True)
def modified_polar_f_kernel(theta, beta, u1, u2, out):
    """Write ``f([theta, beta], [u1, u2])`` into ``out`` (2,); returns False if S1 = S2 = 0.

    Kernel (not public): assumes ``out`` has 2 elements; see :func:`modified_polar_f`.
    """
    c = math.cos(theta)
    s = math.sin(theta)
    a = -u2 * c + u1 * s
    b = -u2 * s - u1 * c
    S1 = beta * a
    S2 = 1.0 + beta * b
    D = S1 * S1 + S2 * S2
    if D == 0.0:
        return False
    out[0] = theta + math.atan2(S1, S2)
    out[1] = beta / math.sqrt(D)
    return True


@nb.njit(cache=True)
def modified_polar_F_kernel(theta, beta, u1, u2, out):
    """Write the Jacobian ``d f / d [theta, beta]`` into ``out`` (2, 2); False if S1 = S2 = 0.

    With ``a = -u2 cos + u1 sin``, ``b = -u2 sin - u1 cos`` (so ``da/dtheta = -b``,
    ``db/dtheta = a``), ``S1 = beta a``, ``S2 = 1 + beta b``, ``D = S1^2 + S2^2``:
    ``df1/dtheta = 1 - beta (S1 a + S2 b)/D``, ``df1/dbeta = a/D``,
    ``df2/dtheta = -beta^2 a / D^{3/2}``,
    ``df2/dbeta = 1/sqrt(D) - beta (S1 a + S2 b)/D^{3/2}``.
    """
    c = math.cos(theta)
    s = math.sin(theta)
    a = -u2 * c + u1 * s
    b = -u2 * s - u1 * c
    S1 = beta * a
    S2 = 1.0 + beta * b
    D = S1 * S1 + S2 * S2
    if D == 0.0:
        return False
    g = S1 * a + S2 * b
    sd = math.sqrt(D)
    d32 = D * sd
    out[0, 0] = 1.0 - beta * g / D
    out[0, 1] = a / D
    out[1, 0] = -beta * beta * a / d32
    out[1, 1] = 1.0 / sd - beta * g / d32
    return True


def _check(xb, ub):
    xb = as_vector(xb, "xb", 2)
    ub = as_vector(ub, "ub", 2)
    return xb, ub


def _finite(out):
    if not np.all(np.isfinite(out)):
        raise ValueError("xb and ub out of range: the transition overflows (|beta * ub| "
                         "too large for double precision)")
    return out


def _degenerate():
    return ValueError("the observer displacement ub lands exactly on the point "
                      "(S1 = S2 = 0): the modified-polar transition is undefined")


def modified_polar_f(xb, ub):
    """Transition ``f(xb, ub)`` of eqs (10)-(11) with ``atan2``.

    ``xb = [theta, 1/r]`` (rad, 1/m) at scan ``k-1``; ``ub = [dx_o, dy_o]`` the
    observer's displacement over ``[t_{k-1}, t_k]`` (m).  Returns the state at
    ``k`` (the bearing is not wrapped: ``theta + atan2(S1, S2)``).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import modified_polar_f
    >>> xb = np.array([0.0, 0.01])          # [bearing, 1 / range]: a point 100 m due east
    >>> theta, beta = modified_polar_f(xb, [0.0, 10.0])  # the observer moves 10 m north
    >>> round(float(theta), 6), round(float(1 / beta), 3)   # now at (100, -10) from it
    (-0.099669, 100.499)
    """
    xb, ub = _check(xb, ub)
    out = np.empty(2)
    with np.errstate(over="ignore", invalid="ignore"):
        if not modified_polar_f_kernel(xb[0], xb[1], ub[0], ub[1], out):
            raise _degenerate()
    return _finite(out)


def modified_polar_F(xb, ub):
    """Analytic Jacobian ``d f / d xb`` (2, 2) of :func:`modified_polar_f`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import modified_polar_F
    >>> print(np.round(modified_polar_F([0.0, 0.01], [0.0, 10.0]), 4))
    [[ 0.9901 -9.901 ]
     [ 0.001   0.9852]]
    """
    xb, ub = _check(xb, ub)
    out = np.empty((2, 2))
    with np.errstate(over="ignore", invalid="ignore"):
        if not modified_polar_F_kernel(xb[0], xb[1], ub[0], ub[1], out):
            raise _degenerate()
    return _finite(out)


def modified_polar_Q(xb, T, sigma_p):
    """Process noise ``sigma_p^2 T diag(beta^2, beta^4)`` of eq (14) at ``xb = [theta, beta]``.

    ``sigma_p`` (m/s) is the standard deviation scale of the drift: the
    Cartesian drift-velocity white noise has PSD ``sigma_p^2`` (m^2/s), so that
    the Cartesian displacement covariance over ``T`` is ``sigma_p^2 T I`` (eq 13).

    Examples
    --------
    >>> from trackcore.models import modified_polar_Q
    >>> print(modified_polar_Q([0.0, 0.1], T=1.0, sigma_p=2.0))     # 4 * diag(0.01, 0.0001)
    [[0.04   0.    ]
     [0.     0.0004]]
    """
    xb = as_vector(xb, "xb", 2)
    T = as_nonnegative(T, "T")
    sp = as_nonnegative(sigma_p, "sigma_p")
    with np.errstate(over="ignore", invalid="ignore"):
        b2 = xb[1] * xb[1]
        q = sp * sp * T
        out = np.array([[q * b2, 0.0], [0.0, q * b2 * b2]])
    if not np.all(np.isfinite(out)):
        raise ValueError("xb, T and sigma_p out of range: sigma_p^2 T beta^4 overflows")
    return out


def modified_polar_from_cartesian(p_rel):
    """``[atan2(y, x), 1/r]`` of a relative position ``p_rel = [x, y]`` (r > 0).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import modified_polar_from_cartesian
    >>> print(np.round(modified_polar_from_cartesian([0.0, 50.0]), 4))   # [pi / 2, 1 / 50]
    [1.5708 0.02  ]
    """
    p = as_vector(p_rel, "p_rel", 2)
    r = math.hypot(p[0], p[1])
    if r == 0.0:
        raise ValueError("p_rel must be non-zero (inverse range undefined at r = 0)")
    return np.array([math.atan2(p[1], p[0]), 1.0 / r])
