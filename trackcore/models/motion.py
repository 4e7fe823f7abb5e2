"""Linear motion models: constant velocity, coordinated turn, Singer.

State conventions (see the design appendix of the book): a ``dim``-dimensional kinematic state
is ``[positions..., velocities...]`` (e.g. ``[x, y, vx, vy]``), and a Singer
state is ``[positions..., velocities..., accelerations...]``.  Per-axis
matrices (``[p, v]`` or ``[p, v, a]``) are lifted to that layout with
:func:`kron_axes` (``kron(M, I_dim)``).

Every function returns new C-contiguous float64 arrays.  Continuous-time
models are discretised exactly; :func:`van_loan_discretize` gives the same
discretisation numerically (Van Loan, 1978) and is what the tests and the
chapters use to check the closed forms.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.linalg

from ..core.validation import (as_covariance, as_int, as_nonnegative, as_positive,
                               as_scalar, as_square_matrix, finite_result)

__all__ = [
    "kron_axes",
    "cv_transition",
    "cv_process_noise",
    "coordinated_turn_transition",
    "coordinated_turn_process_noise",
    "singer_transition",
    "singer_process_noise",
    "van_loan_discretize",
]

_KINDS = ("dwna", "cwna")


def _as_dim(dim) -> int:
    d = as_int(dim, "dim")
    if d not in (1, 2, 3):
        raise ValueError(f"dim must be 1, 2 or 3, got {d}")
    return d


def kron_axes(M, dim=2):
    """Lift a per-axis matrix ``M`` (e.g. over ``[p, v]``) to ``dim`` axes.

    Returns ``kron(M, I_dim)``, i.e. the layout ``[p_x, p_y, v_x, v_y]`` for a
    2x2 ``M`` and ``dim=2``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import kron_axes
    >>> print(kron_axes(np.array([[1.0, 2.0], [0.0, 1.0]]), dim=2))
    [[1. 0. 2. 0.]
     [0. 1. 0. 2.]
     [0. 0. 1. 0.]
     [0. 0. 0. 1.]]
    """
    M = as_square_matrix(M, "M")
    d = _as_dim(dim)
    return np.ascontiguousarray(np.kron(M, np.eye(d)))


def cv_transition(T, dim=2):
    """Constant-velocity transition matrix ``[[I, T I], [0, I]]`` of size 2*dim.

    ``T`` is the sampling interval (>= 0).

    Examples
    --------
    >>> from trackcore.models import cv_transition
    >>> print(cv_transition(0.5, dim=1))
    [[1.  0.5]
     [0.  1. ]]
    >>> cv_transition(1.0).shape            # [x, y, vx, vy]
    (4, 4)
    """
    T = as_nonnegative(T, "T")
    d = _as_dim(dim)
    return np.ascontiguousarray(np.kron(np.array([[1.0, T], [0.0, 1.0]]), np.eye(d)))


def cv_process_noise(T, q, dim=2, kind="dwna"):
    """Process-noise covariance of the constant-velocity model.

    ``kind="dwna"`` (discrete white-noise acceleration, Bar-Shalom et al. 2001
    sec. 6.3.3): ``q`` is the acceleration variance sigma_a^2 and per axis
    ``Q = q G G^T`` with ``G = [T^2/2, T]``.
    ``kind="cwna"`` (continuous white-noise acceleration, sec. 6.2.2): ``q`` is
    the power spectral density and per axis
    ``Q = q [[T^3/3, T^2/2], [T^2/2, T]]``.

    Examples
    --------
    >>> from trackcore.models import cv_process_noise
    >>> print(cv_process_noise(1.0, 1.0, dim=1))                  # q G G^T, G = [T^2/2, T]
    [[0.25 0.5 ]
     [0.5  1.  ]]
    >>> print(cv_process_noise(1.0, 3.0, dim=1, kind="cwna"))     # q [[T^3/3, T^2/2], [T^2/2, T]]
    [[1.  1.5]
     [1.5 3. ]]
    """
    T = as_nonnegative(T, "T")
    q = as_nonnegative(q, "q")
    d = _as_dim(dim)
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {_KINDS}, got {kind!r}")
    try:
        if kind == "dwna":
            per_axis = q * np.array([[T**4 / 4.0, T**3 / 2.0], [T**3 / 2.0, T**2]])
        else:
            per_axis = q * np.array([[T**3 / 3.0, T**2 / 2.0], [T**2 / 2.0, T]])
    except OverflowError:
        per_axis = np.full((2, 2), np.inf)
    finite_result(per_axis, "the process-noise covariance", "T and q")
    return np.ascontiguousarray(np.kron(per_axis, np.eye(d)))


def _sinc(u: float) -> float:
    """sin(u)/u, exact at and near 0 (Taylor series for |u| < 1e-3)."""
    if abs(u) < 1e-3:
        u2 = u * u
        return 1.0 - u2 / 6.0 * (1.0 - u2 / 20.0 * (1.0 - u2 / 42.0))
    return math.sin(u) / u


def coordinated_turn_transition(omega, T):
    """Exact coordinated-turn transition for ``[x, y, vx, vy]`` at known rate.

    ``omega`` is the turn rate in rad/s (positive = counter-clockwise), ``T``
    the sampling interval.  Uses ``sin(wT)/w = T sinc(wT)`` and
    ``(1 - cos wT)/w = T sin(wT/2) sinc(wT/2)``, so ``omega = 0`` gives the
    constant-velocity matrix without any division by zero.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import coordinated_turn_transition
    >>> F = coordinated_turn_transition(np.pi / 2, 1.0)   # a quarter turn in one second
    >>> print(np.round(F @ [0.0, 0.0, 1.0, 0.0], 4))     # [x, y, vx, vy]: heading east -> north
    [0.6366 0.6366 0.     1.    ]
    """
    w = as_scalar(omega, "omega")
    T = as_nonnegative(T, "T")
    u = w * T
    if not math.isfinite(u):
        raise ValueError(f"omega * T must be finite, got omega={w!r}, T={T!r}")
    s, c = math.sin(u), math.cos(u)
    a = T * _sinc(u)                         # sin(wT)/w
    b = T * math.sin(0.5 * u) * _sinc(0.5 * u)  # (1 - cos wT)/w
    return np.array([[1.0, 0.0, a, -b],
                     [0.0, 1.0, b, a],
                     [0.0, 0.0, c, -s],
                     [0.0, 0.0, s, c]])


def coordinated_turn_process_noise(T, q, kind="dwna"):
    """Process noise for :func:`coordinated_turn_transition` (state ``[x, y, vx, vy]``).

    With a known turn rate the usual choice (Bar-Shalom et al. 2001, sec. 11.7)
    is the constant-velocity noise of the same ``kind`` applied to both axes,
    so this returns ``cv_process_noise(T, q, dim=2, kind=kind)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import coordinated_turn_process_noise, cv_process_noise
    >>> Q = coordinated_turn_process_noise(1.0, 0.5)
    >>> Q.shape, bool(np.allclose(Q, cv_process_noise(1.0, 0.5)))
    ((4, 4), True)
    """
    return cv_process_noise(T, q, dim=2, kind=kind)


# --- Singer model --------------------------------------------------------------
#
# Per axis, state [p, v, a], da/dt = -alpha a + w with alpha = 1/tau and
# E[w(t) w(s)] = 2 alpha sigma_m^2 delta(t - s) (Singer 1970).  The exact Q has
# entries  Q_ij = 2 alpha sigma_m^2 * B_ij(alpha T) / (2 alpha^k_ij)  where the
# brackets B_ij suffer catastrophic cancellation for small alpha T; they are
# evaluated by power series for x = alpha T < 1 and in closed form otherwise.

_NSER = 40


def _series(terms, x):
    """Sum of ``coef * x**p * exp(-c x)`` terms as a power series in ``x``."""
    coefs = np.zeros(_NSER)
    for coef, p, c in terms:
        for k in range(p, _NSER):
            coefs[k] += coef * (-c) ** (k - p) / math.factorial(k - p)
    total = 0.0
    for k in range(_NSER - 1, -1, -1):  # Horner
        total = total * x + coefs[k]
    return total


def _closed(terms, x):
    return sum(coef * x**p * math.exp(-c * x) for coef, p, c in terms)


# brackets B_ij(x) as lists of (coef, power of x, decay c in exp(-c x))
_SINGER_BRACKETS = {
    (0, 0): [(1, 0, 0), (-1, 0, 2), (2, 1, 0), (2.0 / 3.0, 3, 0), (-2, 2, 0), (-4, 1, 1)],
    (0, 1): [(1, 0, 2), (1, 0, 0), (-2, 0, 1), (2, 1, 1), (-2, 1, 0), (1, 2, 0)],
    (0, 2): [(1, 0, 0), (-1, 0, 2), (-2, 1, 1)],
    (1, 1): [(4, 0, 1), (-3, 0, 0), (-1, 0, 2), (2, 1, 0)],
    (1, 2): [(1, 0, 2), (1, 0, 0), (-2, 0, 1)],
    (2, 2): [(1, 0, 0), (-1, 0, 2)],
}
# power of alpha in the denominator 2 alpha^k
_SINGER_POWERS = {(0, 0): 5, (0, 1): 4, (0, 2): 3, (1, 1): 3, (1, 2): 2, (2, 2): 1}


def _bracket(key, x):
    terms = _SINGER_BRACKETS[key]
    return _series(terms, x) if x < 1.0 else _closed(terms, x)


def singer_transition(T, tau):
    """Singer (1970) transition for one axis ``[p, v, a]``.

    ``tau`` is the manoeuvre time constant (alpha = 1/tau):
    ``[[1, T, (aT - 1 + e^{-aT})/a^2], [0, 1, (1 - e^{-aT})/a], [0, 0, e^{-aT}]]``.
    Use :func:`kron_axes` for several axes.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import singer_transition
    >>> print(np.round(singer_transition(1.0, tau=10.0), 4))       # state [p, v, a]
    [[1.     1.     0.4837]
     [0.     1.     0.9516]
     [0.     0.     0.9048]]
    """
    T = as_nonnegative(T, "T")
    tau = as_positive(tau, "tau")
    a = 1.0 / tau
    x = a * T
    # (x - 1 + e^{-x}) / a^2 = T^2 * (x - 1 + e^{-x}) / x^2, series when small
    if x < 1e-6:
        f13 = T * T * (0.5 - x / 6.0)
    elif x < 1.0:
        f13 = T * T * _series([(1, 1, 0), (-1, 0, 0), (1, 0, 1)], x) / (x * x)
    else:
        f13 = (x - 1.0 + math.exp(-x)) / (a * a)
    f23 = -math.expm1(-x) / a if x > 0 else T
    return finite_result(np.array([[1.0, T, f13],
                                   [0.0, 1.0, f23],
                                   [0.0, 0.0, math.exp(-x)]]),
                         "the Singer transition matrix", "T and tau")


def singer_process_noise(T, tau, sigma_m):
    """Exact Singer (1970) process noise for one axis ``[p, v, a]``.

    The acceleration is a first-order Gauss-Markov process with standard
    deviation ``sigma_m`` and time constant ``tau``, i.e. driving white noise of
    power spectral density ``2 sigma_m^2 / tau``.  The closed form is Singer's
    eq. (21), evaluated without cancellation for small ``T/tau``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import singer_process_noise
    >>> Q = singer_process_noise(1.0, tau=10.0, sigma_m=2.0)
    >>> print(np.round(Q, 4))
    [[0.0379 0.0936 0.1207]
     [0.0936 0.2476 0.3622]
     [0.1207 0.3622 0.7251]]
    """
    T = as_nonnegative(T, "T")
    tau = as_positive(tau, "tau")
    sigma_m = as_nonnegative(sigma_m, "sigma_m")
    a = 1.0 / tau
    x = a * T
    Q = np.empty((3, 3))
    try:
        for (i, j), k in _SINGER_POWERS.items():
            # 2 a s^2 * B / (2 a^k) = s^2 * B / a^(k-1)
            v = sigma_m**2 * _bracket((i, j), x) * tau ** (k - 1)
            Q[i, j] = Q[j, i] = v
    except OverflowError:
        Q[:] = np.inf
    return finite_result(Q, "the Singer process-noise covariance", "T, tau and sigma_m")


def van_loan_discretize(A, L_Qc_Lt, T):
    """Exact discretisation of ``dx = A x dt + L dw`` over an interval ``T``.

    ``L_Qc_Lt`` is the continuous noise intensity ``L Qc L^T`` (n x n, PSD).
    Returns ``(F, Q)`` with ``F = expm(A T)`` and
    ``Q = int_0^T expm(A s) L Qc L^T expm(A s)^T ds``, computed with Van Loan's
    (1978) block matrix exponential.  Accuracy: the block exponential contains
    ``expm(-A T)``, so for strongly stable modes (eigenvalue ``-lambda`` with
    ``lambda T`` large) roughly ``e^{lambda T} * eps`` relative accuracy is lost;
    prefer closed forms there (e.g. :func:`singer_process_noise`).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import van_loan_discretize, cv_process_noise
    >>> A = np.array([[0.0, 1.0], [0.0, 0.0]])            # dp = v dt, dv = dw
    >>> F, Q = van_loan_discretize(A, np.diag([0.0, 3.0]), 1.0)
    >>> print(F)
    [[1. 1.]
     [0. 1.]]
    >>> bool(np.allclose(Q, cv_process_noise(1.0, 3.0, dim=1, kind="cwna")))
    True
    """
    A = as_square_matrix(A, "A")
    n = A.shape[0]
    W = as_covariance(L_Qc_Lt, "L_Qc_Lt", n)
    T = as_nonnegative(T, "T")
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = -A
    M[:n, n:] = W
    M[n:, n:] = A.T
    with np.errstate(all="ignore"):
        E = scipy.linalg.expm(M * T)
        F = E[n:, n:].T
        Q = F @ E[:n, n:]
        Q = 0.5 * (Q + Q.T)
    finite_result(F, "the discretised transition expm(A T)", "A and T")
    finite_result(Q, "the discretised process noise", "A, L_Qc_Lt and T")
    return np.ascontiguousarray(F), np.ascontiguousarray(Q)
