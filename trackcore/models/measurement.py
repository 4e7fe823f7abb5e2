"""Measurement models: linear position, range-bearing, range-bearing-Doppler.

The sensor sits at the origin unless a ``sensor`` position ``[sx, sy]`` is
given.  Bearing is ``atan2(y, x)`` (counter-clockwise from +x), in
``(-pi, pi]``.  Functions of a state accept one state ``(n,)`` or a batch
``(N, n)``; batches go through numba kernels (particle filters call them on
10^5 particles).  Jacobians are analytic and raise ``ValueError`` at zero
range, where they are undefined.

The ``*_kernel`` functions are numba kernels for other kernels (particle
filters, trackers); they assume valid input and are not public.  The public
functions give the same bits as the kernels, except for states so far from (or
so close to) the sensor that ``x**2 + y**2`` overflows (or underflows): those
rows are recomputed in a scaled form (``hypot``), so a finite state always has a
finite range, and a result that cannot be represented raises ``ValueError``.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_int, as_nonnegative, as_scalar, as_vector,
                               finite_result)

__all__ = [
    "position_matrix",
    "wrap_angle",
    "range_bearing",
    "range_bearing_jacobian",
    "range_bearing_doppler",
    "range_bearing_doppler_jacobian",
    "polar_to_cartesian",
    "converted_measurement_covariance",
]

_TWO_PI = 2.0 * math.pi


def position_matrix(dim=2, n=4):
    """``H = [I_dim, 0]`` of shape ``(dim, n)``: observe the positions of a state.

    Examples
    --------
    >>> from trackcore.models import position_matrix
    >>> print(position_matrix(dim=2, n=4))
    [[1. 0. 0. 0.]
     [0. 1. 0. 0.]]
    """
    dim = as_int(dim, "dim", minimum=1)
    n = as_int(n, "n", minimum=1)
    if n < dim:
        raise ValueError(f"n must be >= dim ({dim}), got {n}")
    H = np.zeros((dim, n))
    H[:, :dim] = np.eye(dim)
    return H


@nb.njit(cache=True)
def wrap_angle_kernel(a):
    """Wrap one angle (radians) to (-pi, pi]."""
    return a - _TWO_PI * math.ceil((a - math.pi) / _TWO_PI)


@nb.njit(cache=True)
def _wrap_array_kernel(a, out):
    flat_in = a.ravel()
    flat_out = out.ravel()
    for i in range(flat_in.shape[0]):
        flat_out[i] = wrap_angle_kernel(flat_in[i])


def wrap_angle(a):
    """Wrap angles (radians, scalar or array) to ``(-pi, pi]``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import wrap_angle
    >>> round(wrap_angle(3 * np.pi / 2), 4)
    -1.5708
    >>> print(np.round(wrap_angle(np.array([-np.pi, np.pi, 7.0])), 4))
    [3.1416 3.1416 0.7168]
    """
    if np.ndim(a) == 0 and not isinstance(a, np.ndarray):
        return float(wrap_angle_kernel(as_scalar(a, "a")))
    arr = as_array(a, "a")
    out = np.empty_like(arr)
    _wrap_array_kernel(arr, out)
    return out


def _states(x, name, min_n):
    arr = as_array(x, name, ndim=(1, 2))
    if arr.shape[-1] < min_n:
        raise ValueError(f"{name} must have at least {min_n} components in its last "
                         f"dimension, got shape {arr.shape}")
    return arr


def _sensor(sensor):
    if sensor is None:
        return np.zeros(2)
    return as_vector(sensor, "sensor", 2)


def _kernel_on_rows(kernel, X, out, rows, *extra):
    """``kernel(X, *extra, out)`` restricted to the rows where ``rows`` is True (all of
    them in the usual case, without a copy); returns the kernel's zero-range index in
    ``X``'s numbering, or -1."""
    if rows.all():
        args = (X,) + extra + (out,)
        return kernel(*args)
    keep = np.flatnonzero(rows)
    sub = np.zeros((keep.size,) + out.shape[1:])
    args = (np.ascontiguousarray(X[keep]),) + extra + (sub,)
    bad = kernel(*args)
    out[keep] = sub
    return -1 if bad < 0 else int(keep[bad])


def _extreme_rows(dx, dy):
    """Rows whose ``dx**2 + dy**2`` overflows or underflows (kernels' arithmetic
    loses the range there); recomputed with ``hypot`` by the public functions."""
    with np.errstate(all="ignore"):
        r2 = dx * dx + dy * dy
    return ~np.isfinite(r2) | ((r2 < 1e-290) & ((dx != 0) | (dy != 0)))


@nb.njit(cache=True)
def range_bearing_kernel(X, sx, sy, out):
    """Range and bearing of each row of ``X`` (N, n>=2) into ``out`` (N, 2)."""
    for i in range(X.shape[0]):
        dx = X[i, 0] - sx
        dy = X[i, 1] - sy
        out[i, 0] = math.sqrt(dx * dx + dy * dy)
        out[i, 1] = math.atan2(dy, dx)


def range_bearing(x, sensor=None):
    """``h(x) = [r, atan2(y - sy, x - sx)]`` for a state ``[x, y, ...]`` or a batch.

    Returns ``(2,)`` for one state, ``(N, 2)`` for ``(N, n)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import range_bearing
    >>> print(np.round(range_bearing([3.0, 4.0, 1.0, 0.0]), 4))             # [r, bearing]
    [5.     0.9273]
    >>> print(np.round(range_bearing([3.0, 4.0, 0.0, 0.0], sensor=[3.0, 0.0]), 4))
    [4.     1.5708]
    >>> range_bearing(np.zeros((5, 4)) + [1.0, 1.0, 0.0, 0.0]).shape        # a batch of states
    (5, 2)
    """
    X = _states(x, "x", 2)
    s = _sensor(sensor)
    single = X.ndim == 1
    X2 = X.reshape(1, -1) if single else X
    out = np.empty((X2.shape[0], 2))
    range_bearing_kernel(X2, s[0], s[1], out)
    dx, dy = X2[:, 0] - s[0], X2[:, 1] - s[1]
    bad = _extreme_rows(dx, dy)
    if bad.any():
        out[bad, 0] = np.hypot(dx[bad], dy[bad])
        out[bad, 1] = np.arctan2(dy[bad], dx[bad])
        finite_result(out, "the range", "x and sensor")
    return out[0] if single else out


@nb.njit(cache=True)
def range_bearing_jacobian_kernel(X, sx, sy, out):
    """Returns the index of the first zero-range state, or -1."""
    for i in range(X.shape[0]):
        dx = X[i, 0] - sx
        dy = X[i, 1] - sy
        r2 = dx * dx + dy * dy
        if r2 == 0.0:
            return i
        r = math.sqrt(r2)
        out[i, 0, 0] = dx / r
        out[i, 0, 1] = dy / r
        out[i, 1, 0] = -dy / r2
        out[i, 1, 1] = dx / r2
    return -1


def range_bearing_jacobian(x, sensor=None):
    """Jacobian of :func:`range_bearing`: ``(2, n)`` or ``(N, 2, n)``.

    Rows: ``[x/r, y/r, 0...]`` and ``[-y/r^2, x/r^2, 0...]`` (relative to the
    sensor).  Raises ``ValueError`` at zero range.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import range_bearing_jacobian
    >>> print(np.round(range_bearing_jacobian([3.0, 4.0, 0.0, 0.0]), 4))
    [[ 0.6   0.8   0.    0.  ]
     [-0.16  0.12  0.    0.  ]]
    """
    X = _states(x, "x", 2)
    s = _sensor(sensor)
    single = X.ndim == 1
    X2 = X.reshape(1, -1) if single else X
    out = np.zeros((X2.shape[0], 2, X2.shape[1]))
    dx, dy = X2[:, 0] - s[0], X2[:, 1] - s[1]
    ext = _extreme_rows(dx, dy)
    bad = _kernel_on_rows(range_bearing_jacobian_kernel, X2, out, ~ext, s[0], s[1])
    if ext.any():  # the scaled form on the rows the kernel's arithmetic cannot take
        r = np.hypot(dx[ext], dy[ext])
        u, v = dx[ext] / r, dy[ext] / r
        out[ext, 0, 0] = u
        out[ext, 0, 1] = v
        out[ext, 1, 0] = -v / r
        out[ext, 1, 1] = u / r
        finite_result(out, "the range-bearing Jacobian", "x and sensor")
    if bad >= 0:
        raise ValueError("x is at zero range from the sensor: the range-bearing Jacobian "
                         f"is undefined (state index {bad})")
    return out[0] if single else out


@nb.njit(cache=True)
def range_bearing_doppler_kernel(X, out):
    """``[r, bearing, range rate]`` of each relative state row ``[x, y, vx, vy, ...]``.

    Returns the index of the first zero-range row (range rate undefined), or -1.
    """
    for i in range(X.shape[0]):
        x = X[i, 0]
        y = X[i, 1]
        r = math.sqrt(x * x + y * y)
        if r == 0.0:
            return i
        out[i, 0] = r
        out[i, 1] = math.atan2(y, x)
        out[i, 2] = (x * X[i, 2] + y * X[i, 3]) / r
    return -1


def range_bearing_doppler(x_rel):
    """``[r, atan2(y, x), (x vx + y vy)/r]`` of a relative state ``[x, y, vx, vy, ...]``.

    ``x_rel`` is target minus sensor (position and velocity), one state
    ``(n,)`` or a batch ``(N, n)``.  Raises ``ValueError`` at zero range, where
    the range rate is undefined.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import range_bearing_doppler
    >>> print(np.round(range_bearing_doppler([3.0, 4.0, 3.0, 4.0]), 4))   # moving straight away
    [5.     0.9273 5.    ]
    """
    X = _states(x_rel, "x_rel", 4)
    single = X.ndim == 1
    X2 = X.reshape(1, -1) if single else X
    out = np.empty((X2.shape[0], 3))
    ext = _extreme_rows(X2[:, 0], X2[:, 1])
    bad = _kernel_on_rows(range_bearing_doppler_kernel, X2, out, ~ext)
    if ext.any():
        x, y, vx, vy = (X2[ext, j] for j in range(4))
        r = np.hypot(x, y)
        with np.errstate(all="ignore"):
            out[ext, 0] = r
            out[ext, 1] = np.arctan2(y, x)
            out[ext, 2] = (x / r) * vx + (y / r) * vy
    if bad >= 0:
        raise ValueError("x_rel has zero range: the range rate is undefined "
                         f"(state index {bad})")
    finite_result(out, "the range rate", "x_rel")
    return out[0] if single else out


@nb.njit(cache=True)
def range_bearing_doppler_jacobian_kernel(X, out):
    for i in range(X.shape[0]):
        x = X[i, 0]
        y = X[i, 1]
        vx = X[i, 2]
        vy = X[i, 3]
        r2 = x * x + y * y
        if r2 == 0.0:
            return i
        r = math.sqrt(r2)
        r3 = r2 * r
        cross = vx * y - vy * x
        out[i, 0, 0] = x / r
        out[i, 0, 1] = y / r
        out[i, 1, 0] = -y / r2
        out[i, 1, 1] = x / r2
        out[i, 2, 0] = y * cross / r3
        out[i, 2, 1] = -x * cross / r3
        out[i, 2, 2] = x / r
        out[i, 2, 3] = y / r
    return -1


def range_bearing_doppler_jacobian(x_rel):
    """Jacobian of :func:`range_bearing_doppler`: ``(3, n)`` or ``(N, 3, n)``.

    Raises ``ValueError`` at zero range.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import range_bearing_doppler_jacobian
    >>> J = range_bearing_doppler_jacobian([3.0, 4.0, 0.0, 1.0])
    >>> J.shape
    (3, 4)
    >>> print(np.round(J[2], 4))           # d(range rate) / d[x, y, vx, vy]
    [-0.096  0.072  0.6    0.8  ]
    """
    X = _states(x_rel, "x_rel", 4)
    single = X.ndim == 1
    X2 = X.reshape(1, -1) if single else X
    out = np.zeros((X2.shape[0], 3, X2.shape[1]))
    ext = _extreme_rows(X2[:, 0], X2[:, 1])
    bad = _kernel_on_rows(range_bearing_doppler_jacobian_kernel, X2, out, ~ext)
    if ext.any():
        x, y, vx, vy = (X2[ext, j] for j in range(4))
        with np.errstate(all="ignore"):
            r = np.hypot(x, y)
            u, v = x / r, y / r
            cross = vx * v - vy * u
            out[ext] = 0.0
            out[ext, 0, 0] = u
            out[ext, 0, 1] = v
            out[ext, 1, 0] = -v / r
            out[ext, 1, 1] = u / r
            out[ext, 2, 0] = v * cross / r
            out[ext, 2, 1] = -u * cross / r
            out[ext, 2, 2] = u
            out[ext, 2, 3] = v
    if bad < 0:
        finite_result(out, "the range-bearing-Doppler Jacobian", "x_rel")
    if bad >= 0:
        raise ValueError("x_rel has zero range: the range-bearing-Doppler Jacobian is "
                         f"undefined (state index {bad})")
    return out[0] if single else out


def polar_to_cartesian(z, sensor=None):
    """Convert ``[r, bearing]`` (``(2,)`` or ``(m, 2)``) to Cartesian ``[x, y]``.

    ``m = 0`` scans are returned as ``(0, 2)``.  Ranges must be >= 0.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import polar_to_cartesian
    >>> print(np.round(polar_to_cartesian([2.0, np.pi / 2]), 4))
    [0. 2.]
    >>> print(np.round(polar_to_cartesian([[1.0, 0.0], [1.0, np.pi]], sensor=[10.0, 0.0]), 4))
    [[11.  0.]
     [ 9.  0.]]
    """
    Z = as_array(z, "z", ndim=(1, 2))
    if Z.shape[-1] != 2 and Z.size:
        raise ValueError(f"z must have shape (2,) or (m, 2), got {Z.shape}")
    if Z.ndim == 2 and Z.shape[0] == 0:
        return np.zeros((0, 2))
    if np.any(Z[..., 0] < 0):
        raise ValueError("z ranges (column 0) must be >= 0")
    s = _sensor(sensor)
    r, b = Z[..., 0], Z[..., 1]
    return np.ascontiguousarray(np.stack([s[0] + r * np.cos(b), s[1] + r * np.sin(b)],
                                         axis=-1))


def converted_measurement_covariance(r, bearing, sigma_r, sigma_bearing):
    """Linearised covariance of a polar measurement converted to Cartesian.

    ``R_xy = J diag(sigma_r^2, sigma_bearing^2) J^T`` with
    ``J = [[cos b, -r sin b], [sin b, r cos b]]`` (Bar-Shalom et al. 2001,
    sec. 10.4.3, first-order conversion).  Returns a 2x2 matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.models import converted_measurement_covariance
    >>> R = converted_measurement_covariance(1000.0, 0.0, sigma_r=10.0, sigma_bearing=0.01)
    >>> print(np.round(R, 3))              # along the x axis: range error in x, bearing error in y
    [[100.   0.]
     [  0. 100.]]
    """
    r = as_nonnegative(r, "r")
    b = as_scalar(bearing, "bearing")
    sr = as_nonnegative(sigma_r, "sigma_r")
    sb = as_nonnegative(sigma_bearing, "sigma_bearing")
    c, s = math.cos(b), math.sin(b)
    J = np.array([[c, -r * s], [s, r * c]])
    with np.errstate(all="ignore"):
        R = J @ np.diag([sr * sr, sb * sb]) @ J.T
        R = 0.5 * (R + R.T)
    return finite_result(R, "the converted covariance", "r, sigma_r and sigma_bearing")
