"""Target-oriented velocity model (TOM) of Yoon & Ko.

State ``[x, y, v_f, v_s]``: Cartesian position plus the forward (along-track)
velocity ``v_f`` and the lateral (cross-track) velocity ``v_s`` in a frame
attached to the heading ``phi`` (counter-clockwise from +x).  Position moves as
``[x', y'] = R(phi) [v_f, v_s]`` with the reflection

    R(phi) = [[cos phi,  sin phi],
              [sin phi, -cos phi]],      R^2 = I,  det R = -1,

so the forward unit vector is ``(cos phi, sin phi)`` and ``+v_s`` points to the
*right* of the heading.  With ``phi`` held constant over an interval ``T``
(eq. 4 of the paper) ``F^2 = 0`` and the transition is exactly
``Phi = [[I, T R], [0, I]]`` (eq. 5).

Process noise: independent accelerations ``w_f, w_s`` drive ``v_f, v_s``.

* ``kind="dwna"`` (piecewise-constant acceleration, the paper's eq. 7 with the
  ``q12`` misprint corrected): ``Q = Gamma S Gamma^T`` with
  ``Gamma = [T^2/2 R; T I]`` and ``S = diag(sigma_f^2, sigma_s^2)``
  (accelerations, (m/s^2)^2).
* ``kind="cwna"`` (continuous white acceleration, what eq. 6 literally
  describes): ``Q = [[T^3/3 R S R, T^2/2 R S], [T^2/2 S R, T S]]`` with
  ``S`` the power spectral densities (m^2/s^3).

:func:`tom_printed_process_noise` returns eq. (7) exactly as printed (with the
wrong ``q12``) so the chapter can show that it is not a covariance.

The numba kernels (``*_kernel``) are not public: the TOM-IMM tracker
(:mod:`trackcore.trackers.imm_pdaf`) imports them from this module.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import as_covariance, as_nonnegative, as_scalar, as_vector

__all__ = [
    "tom_rotation",
    "tom_transition",
    "tom_process_noise",
    "tom_printed_process_noise",
    "tom_from_cartesian",
    "tom_to_cartesian",
    "chord_heading",
]

_KINDS = ("dwna", "cwna")


# ---------------------------------------------------------------------- kernels
@nb.njit(cache=True)
def tom_transition_kernel(phi, T, out):
    """Write ``[[I, T R(phi)], [0, I]]`` into the (4, 4) array ``out``."""
    c = math.cos(phi)
    s = math.sin(phi)
    for i in range(4):
        for j in range(4):
            out[i, j] = 1.0 if i == j else 0.0
    out[0, 2] = T * c
    out[0, 3] = T * s
    out[1, 2] = T * s
    out[1, 3] = -T * c


@nb.njit(cache=True)
def tom_process_noise_kernel(phi, T, var_f, var_s, cwna, out):
    """Write the TOM process noise into the (4, 4) array ``out``.

    ``var_f``/``var_s`` are sigma_f^2/sigma_s^2; ``cwna`` selects the
    continuous-white-noise factors (T^3/3, T^2/2, T) instead of the DWNA ones
    (T^4/4, T^3/2, T^2).
    """
    c = math.cos(phi)
    s = math.sin(phi)
    if cwna:
        a = T * T * T / 3.0
        b = T * T / 2.0
        d = T
    else:
        a = T * T * T * T / 4.0
        b = T * T * T / 2.0
        d = T * T
    out[0, 0] = (var_f * c * c + var_s * s * s) * a
    out[1, 1] = (var_f * s * s + var_s * c * c) * a
    out[0, 1] = (var_f - var_s) * s * c * a
    out[1, 0] = out[0, 1]
    out[0, 2] = var_f * c * b
    out[0, 3] = var_s * s * b
    out[1, 2] = var_f * s * b
    out[1, 3] = -var_s * c * b
    out[2, 0] = out[0, 2]
    out[3, 0] = out[0, 3]
    out[2, 1] = out[1, 2]
    out[3, 1] = out[1, 3]
    out[2, 2] = var_f * d
    out[3, 3] = var_s * d
    out[2, 3] = 0.0
    out[3, 2] = 0.0


@nb.njit(cache=True)
def chord_heading_kernel(x_prev, y_prev, x_curr, y_curr, phi_fallback, min_distance):
    """``atan2(dy, dx)`` of the chord, or ``phi_fallback`` if it is shorter than ``min_distance``."""
    dx = x_curr - x_prev
    dy = y_curr - y_prev
    if math.hypot(dx, dy) < min_distance:
        return phi_fallback
    return math.atan2(dy, dx)


# ---------------------------------------------------------------------- public
def _check_kind(kind):
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {_KINDS}, got {kind!r}")


def tom_rotation(phi):
    """The reflection ``R(phi) = [[cos, sin], [sin, -cos]]`` (its own inverse).

    Examples
    --------
    >>> tom_rotation(0.0)
    array([[ 1.,  0.],
           [ 0., -1.]])
    >>> R = tom_rotation(0.3)
    >>> np.allclose(R @ R, np.eye(2))  # its own inverse
    True
    """
    phi = as_scalar(phi, "phi")
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, s], [s, -c]])


def tom_transition(phi, T):
    """TOM transition ``Phi = expm(F T) = [[I, T R(phi)], [0, I]]`` (paper eq. 5).

    ``phi`` is the heading (rad, counter-clockwise from +x) held over the
    interval, ``T >= 0`` the interval (s).

    Examples
    --------
    Heading along +x, forward speed 10 m/s: one second moves the target 10 m along x:

    >>> Phi = tom_transition(0.0, 1.0)
    >>> Phi @ np.array([0.0, 0.0, 10.0, 0.0])  # [x, y, v_f, v_s]
    array([10.,  0., 10.,  0.])
    >>> tom_transition(np.pi / 2, 1.0) @ np.array([0.0, 0.0, 10.0, 0.0]) + 0.0  # heading +y
    array([ 0., 10., 10.,  0.])
    """
    phi = as_scalar(phi, "phi")
    T = as_nonnegative(T, "T")
    out = np.empty((4, 4))
    tom_transition_kernel(phi, T, out)
    return out


def _finite_noise_inputs(T, sigma_f, sigma_s):
    """``(T, var_f, var_s)`` after checking that the entries of ``Q`` are finite.

    ``sigma**2`` or ``T**4`` of a huge finite input overflows; that is a bad argument,
    reported as a ``ValueError`` naming it, never an ``OverflowError`` or an ``inf``.
    """
    with np.errstate(over="ignore"):
        var_f = np.float64(sigma_f) * np.float64(sigma_f)
        var_s = np.float64(sigma_s) * np.float64(sigma_s)
        T4 = np.float64(T) ** 4
        big = max(var_f, var_s) * max(T4, 1.0)
    for name, v in (("sigma_f", var_f), ("sigma_s", var_s), ("T", T4)):
        if not np.isfinite(v):
            raise ValueError(f"{name} is too large: the process noise overflows")
    if not np.isfinite(big):
        raise ValueError("sigma_f, sigma_s and T are too large together: the process noise "
                         "overflows")
    return T, float(var_f), float(var_s)


def tom_process_noise(phi, T, sigma_f, sigma_s, kind="dwna"):
    """TOM process-noise covariance (paper eq. 7 corrected, or its CWNA form).

    ``sigma_f``/``sigma_s`` are the standard deviations of the forward and
    lateral accelerations: for ``kind="dwna"`` per-interval constant
    accelerations (m/s^2), ``Q = Gamma diag(sigma_f^2, sigma_s^2) Gamma^T`` with
    ``Gamma = [T^2/2 R(phi); T I]``; for ``kind="cwna"`` square roots of the
    power spectral densities, ``Q = int_0^T Phi(s) G S G^T Phi(s)^T ds``.

    Examples
    --------
    Forward and lateral accelerations of sd 1 and 0.5 m/s^2 over T = 1 s, heading +x:

    >>> tom_process_noise(0.0, 1.0, sigma_f=1.0, sigma_s=0.5)
    array([[ 0.25  ,  0.    ,  0.5   ,  0.    ],
           [ 0.    ,  0.0625,  0.    , -0.125 ],
           [ 0.5   ,  0.    ,  1.    ,  0.    ],
           [ 0.    , -0.125 ,  0.    ,  0.25  ]])
    >>> np.round(tom_process_noise(0.0, 1.0, 1.0, 0.5, kind="cwna")[:2, :2], 4)
    array([[0.3333, 0.    ],
           [0.    , 0.0833]])
    """
    phi = as_scalar(phi, "phi")
    T = as_nonnegative(T, "T")
    sigma_f = as_nonnegative(sigma_f, "sigma_f")
    sigma_s = as_nonnegative(sigma_s, "sigma_s")
    _check_kind(kind)
    T, var_f, var_s = _finite_noise_inputs(T, sigma_f, sigma_s)
    out = np.empty((4, 4))
    tom_process_noise_kernel(phi, T, var_f, var_s, kind == "cwna", out)
    return out


def tom_printed_process_noise(phi, T, sigma_f, sigma_s):
    """Eq. (7) exactly as printed, including the wrong ``q12``.

    Printed: ``q12 = (sigma_f^2 + sigma_s^2) sin(phi) T^4/4``; the correct
    entry is ``(sigma_f^2 - sigma_s^2) sin(phi) cos(phi) T^4/4``.  This is kept
    only to demonstrate the erratum (the printed matrix is indefinite); never
    use it in a filter.

    Examples
    --------
    The printed matrix has a negative eigenvalue; the corrected one does not:

    >>> printed = tom_printed_process_noise(np.pi / 2, 1.0, sigma_f=1.0, sigma_s=0.5)
    >>> np.round(np.linalg.eigvalsh(printed), 4)
    array([-0.2699,  0.1906,  0.3744,  1.2673])
    >>> bool(np.linalg.eigvalsh(tom_process_noise(np.pi / 2, 1.0, 1.0, 0.5)).min() > -1e-12)
    True
    """
    Q = tom_process_noise(phi, T, sigma_f, sigma_s, kind="dwna")
    T, var_f, var_s = _finite_noise_inputs(as_nonnegative(T, "T"),
                                           as_nonnegative(sigma_f, "sigma_f"),
                                           as_nonnegative(sigma_s, "sigma_s"))
    q12 = (var_f + var_s) * math.sin(as_scalar(phi, "phi")) * T**4 / 4.0
    Q[0, 1] = Q[1, 0] = q12
    return Q


def _block(phi):
    B = np.eye(4)
    B[2:, 2:] = tom_rotation(phi)
    return B


def tom_from_cartesian(x, P, phi):
    """Map a Cartesian estimate ``[x, y, vx, vy]``, ``P`` to TOM coordinates.

    ``[v_f, v_s] = R(phi) [vx, vy]`` (``R`` is its own inverse), so the map is
    ``B = blkdiag(I, R(phi))`` and ``P -> B P B^T``.  Returns ``(x_tom, P_tom)``.

    Examples
    --------
    A target moving up at 10 m/s, seen with heading pi/2, moves forward at 10 m/s; the
    velocity variances follow their axes:

    >>> x_cart, P_cart = np.array([0.0, 0.0, 0.0, 10.0]), np.diag([1.0, 1.0, 4.0, 1.0])
    >>> x, P = tom_from_cartesian(x_cart, P_cart, np.pi / 2)
    >>> np.round(x, 4) + 0.0, np.round(np.diag(P), 4)
    (array([ 0.,  0., 10.,  0.]), array([1., 1., 1., 4.]))
    """
    x = as_vector(x, "x", 4)
    P = as_covariance(P, "P", 4)
    B = _block(phi)
    return B @ x, B @ P @ B.T


def tom_to_cartesian(x, P, phi):
    """Inverse of :func:`tom_from_cartesian` (the same map: ``B^{-1} = B``).

    Examples
    --------
    >>> x, P = tom_from_cartesian(np.array([5.0, 1.0, 3.0, 4.0]), np.eye(4), 0.7)
    >>> xc, Pc = tom_to_cartesian(x, P, 0.7)
    >>> np.round(xc, 4), bool(np.allclose(Pc, np.eye(4)))
    (array([5., 1., 3., 4.]), True)
    """
    x = as_vector(x, "x", 4)
    P = as_covariance(P, "P", 4)
    B = _block(phi)
    return B @ x, B @ P @ B.T


def chord_heading(p_prev, p_curr, phi_fallback=0.0, min_distance=1e-6):
    """Heading of the chord between two position estimates (paper eq. 8, with atan2).

    ``atan2(y_curr - y_prev, x_curr - x_prev)``; if the two points are closer
    than ``min_distance`` (m) the heading is undefined and ``phi_fallback``
    (e.g. the previous heading) is returned.

    Examples
    --------
    >>> round(chord_heading([0.0, 0.0], [1.0, 1.0]), 4)  # pi/4
    0.7854
    >>> chord_heading([0.0, 0.0], [0.0, 0.0], phi_fallback=0.5)  # no chord: the fallback
    0.5
    """
    p_prev = as_vector(p_prev, "p_prev", 2)
    p_curr = as_vector(p_curr, "p_curr", 2)
    phi_fallback = as_scalar(phi_fallback, "phi_fallback")
    min_distance = as_nonnegative(min_distance, "min_distance")
    return float(chord_heading_kernel(p_prev[0], p_prev[1], p_curr[0], p_curr[1],
                                      phi_fallback, min_distance))
