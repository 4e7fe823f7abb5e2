"""Performance metrics: RMSE, NEES/NIS with chi-square bounds, OSPA, GOSPA, cardinality error.

Conventions
-----------
* States follow the package convention ``[positions..., velocities...]``; the
  position/velocity RMSE helpers take the spatial dimension ``dim``.
* Monte Carlo arrays put the run axis first: estimates ``(n_runs, n_steps, n)``
  and truth ``(n_steps, n)`` (or the same shape as the estimates), so ``axis=0``
  averages over runs and leaves one value per time step.
* Set metrics take the estimated set ``X`` first and the true set ``Y`` second,
  each an ``(m, d)`` array of points (``[]`` or a ``(0, d)`` array for the empty
  set), like Stone Soup's ``compute_gospa_metric(measured_states, truth_states)``.
* OSPA :cite:p:`schuhmacher2008ospa` minimises
  :math:`\\sum \\min(d, c)^p` exactly with a numba Hungarian algorithm
  (``min_cost_assignment_kernel``, checked against
  ``scipy.optimize.linear_sum_assignment`` in the tests).  The numba kernels
  (``ospa_kernel``, ``gospa_kernel``, ``min_cost_assignment_kernel``) serve other
  kernels and are not public.
  GOSPA :cite:p:`rahmathullah2017gospa` uses the same assignment; its components
  (localisation, missed, false) are reported, as in Stone Soup, in units of
  distance to the power ``p`` so that ``distance**p = localisation + missed + false``.
* Scale: for the usual orders (``p <= 20``) and cut-offs ``c`` in ``[1e-100, 1e100]``
  whose ``c**p`` lies well inside the floating-point range, the powers are taken as
  written.  Otherwise both metrics are computed in a scaled form (coordinate
  differences divided by ``c`` before they are squared, capped distances divided by
  the bottleneck of the assignment before the power, sums in log space), so that no
  square or power overflows or underflows and every call returns (a power that
  overflows would turn the assignment costs into ``inf`` and stall the assignment).
  GOSPA's components are themselves powers of distances; when ``c**p / alpha`` is not
  representable they raise ``ValueError``.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np
from scipy.stats import chi2

from .core.validation import as_array, as_int, as_positive, as_scalar, finite_result

__all__ = [
    "rmse",
    "position_rmse",
    "velocity_rmse",
    "nees",
    "nis",
    "chi2_bounds",
    "OSPAResult",
    "GOSPAResult",
    "CardinalityError",
    "ospa",
    "gospa",
    "cardinality_error",
]


# --------------------------------------------------------------------------- RMSE

def _errors(est, truth):
    est = as_array(est, "est")
    truth = as_array(truth, "truth")
    try:
        return est - truth
    except ValueError:
        raise ValueError(
            f"est and truth must have broadcastable shapes, got {est.shape} and {truth.shape}"
        ) from None


def _check_axis(axis, ndim, name="axis"):
    if axis is None:
        return None
    axes = (axis,) if not isinstance(axis, tuple) else axis
    for a in axes:
        a = as_int(a, name)
        if not -ndim <= a < ndim:
            raise ValueError(f"{name}={a} is out of range for an array with {ndim} dimension(s)")
    return axis


def rmse(est, truth, axis=0):
    """Root-mean-square error ``sqrt(mean((est - truth)**2, axis))``, per component.

    ``truth`` broadcasts against ``est`` (e.g. ``(n_runs, n_steps, n)`` against
    ``(n_steps, n)``).  ``axis=None`` averages over everything.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import rmse
    >>> est = np.array([[1.0, 0.0], [-1.0, 2.0]])     # 2 runs, 2 components
    >>> truth = np.zeros(2)
    >>> print(rmse(est, truth))                      # per component, over the runs
    [1.     1.4142]
    """
    err = _errors(est, truth)
    if err.size == 0:
        raise ValueError("est must not be empty")
    axis = _check_axis(axis, err.ndim)
    with np.errstate(over="ignore"):
        out = np.sqrt(np.mean(err * err, axis=axis))
    return _rescaled_if_overflow(out, err, lambda e: np.sqrt(np.mean(e * e, axis=axis)))


def _rescaled_if_overflow(out, err, f):
    """``f(err)`` is positively homogeneous of degree 1: when squaring overflowed, compute
    it on ``err / s`` and multiply by ``s`` (``s`` the largest error)."""
    if np.all(np.isfinite(out)):
        return out
    s = float(np.max(np.abs(err)))
    out = f(err / s) * s
    return finite_result(out, "the RMSE", "est and truth")


def _norm_rmse(est, truth, start, dim, axis, what):
    dim = as_int(dim, "dim", minimum=1)
    err = _errors(est, truth)
    if err.ndim == 0 or err.shape[-1] < start + dim:
        raise ValueError(
            f"est must have at least {start + dim} state components in its last axis for "
            f"{what} with dim={dim}, got shape {err.shape}")
    if err.size == 0:
        raise ValueError("est must not be empty")
    part = err[..., start:start + dim]

    def f(e):
        sq = np.sum(e ** 2, axis=-1)
        return float(np.sqrt(sq)) if sq.ndim == 0 else np.sqrt(np.mean(sq, axis=axis))

    if part.ndim > 1:
        axis = _check_axis(axis, part.ndim - 1)
    with np.errstate(over="ignore"):
        out = f(part)
    return _rescaled_if_overflow(out, part, f)


def position_rmse(est, truth, dim=2, axis=0):
    """Position RMSE ``sqrt(mean(||p_est - p_true||^2, axis))``.

    The position is the first ``dim`` state components (``[x, y, vx, vy]``
    convention).  With estimates ``(n_runs, n_steps, n)`` and ``axis=0`` this is
    the RMSE over Monte Carlo runs at each time step, shape ``(n_steps,)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import position_rmse
    >>> truth = np.zeros((3, 4))                         # 3 scans of [x, y, vx, vy]
    >>> est = np.zeros((2, 3, 4))                        # 2 runs
    >>> est[0, :, :2] = [3.0, 4.0]                       # run 0 is 5 m off at every scan
    >>> print(position_rmse(est, truth))                 # per scan: sqrt((25 + 0) / 2)
    [3.5355 3.5355 3.5355]
    """
    return _norm_rmse(est, truth, 0, dim, axis, "position_rmse")


def velocity_rmse(est, truth, dim=2, axis=0):
    """Velocity RMSE: like :func:`position_rmse` on components ``dim:2*dim``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import velocity_rmse
    >>> truth = np.array([0.0, 0.0, 1.0, 1.0])          # [x, y, vx, vy]
    >>> est = np.array([[0.0, 0.0, 1.0, 2.0], [0.0, 0.0, 1.0, 0.0]])
    >>> round(float(velocity_rmse(est, truth)), 4)
    1.0
    """
    return _norm_rmse(est, truth, as_int(dim, "dim", minimum=1), dim, axis, "velocity_rmse")


# --------------------------------------------------------------------------- NEES / NIS

def _quadratic_form(e, M, e_name, M_name):
    e = as_array(e, e_name)
    M = as_array(M, M_name)
    if e.ndim == 0:
        raise ValueError(f"{e_name} must have at least 1 dimension, got a scalar")
    n = e.shape[-1]
    if M.ndim < 2 or M.shape[-1] != n or M.shape[-2] != n:
        raise ValueError(
            f"{M_name} must have shape (..., {n}, {n}) to match {e_name} of shape {e.shape}, "
            f"got {M.shape}")
    try:
        batch = np.broadcast_shapes(e.shape[:-1], M.shape[:-2])
    except ValueError:
        raise ValueError(
            f"{e_name} batch shape {e.shape[:-1]} and {M_name} batch shape {M.shape[:-2]} "
            "do not broadcast") from None
    if n == 0:
        return np.zeros(batch) if batch else 0.0
    if not np.allclose(M, np.swapaxes(M, -1, -2), rtol=1e-9, atol=0.0):
        raise ValueError(f"{M_name} must be symmetric")
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise ValueError(f"{M_name} must be positive definite") from None
    eb = np.broadcast_to(e, batch + (n,))
    Lb = np.broadcast_to(L, batch + (n, n))
    # Solve L y = e; the quadratic form is ||y||^2.
    with np.errstate(all="ignore"):
        y = np.linalg.solve(Lb, eb[..., None])[..., 0]
        out = np.sum(y * y, axis=-1)
    finite_result(out, f"the quadratic form of {e_name}", f"{e_name} and {M_name}")
    return float(out) if out.ndim == 0 else out


def nees(x_err, P):
    """Normalised estimation error squared ``x_err^T P^{-1} x_err`` (batched).

    ``x_err`` is ``(..., n)`` (estimate minus truth) and ``P`` is ``(..., n, n)``;
    batch shapes broadcast.  Returns a float for a single pair, else an array of
    the broadcast batch shape.  ``P`` must be symmetric positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import nees
    >>> round(nees([1.0, 2.0], np.diag([1.0, 4.0])), 4)
    2.0
    >>> print(nees(np.array([[1.0, 0.0], [0.0, 3.0]]), np.eye(2)))     # a batch of two errors
    [1. 9.]
    """
    return _quadratic_form(x_err, P, "x_err", "P")


def nis(nu, S):
    """Normalised innovation squared ``nu^T S^{-1} nu`` (batched like :func:`nees`).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import nis
    >>> round(nis([2.0], [[4.0]]), 4)
    1.0
    """
    return _quadratic_form(nu, S, "nu", "S")


def chi2_bounds(dof, n_runs, alpha=0.05):
    """Two-sided ``1 - alpha`` acceptance interval of the run-averaged NEES/NIS.

    If each of ``n_runs`` independent runs gives a chi-square variable with
    ``dof`` degrees of freedom, ``n_runs`` times their average is chi-square with
    ``n_runs * dof`` degrees of freedom :cite:p:`barshalom2001estimation`; the
    bounds are ``chi2.ppf([alpha/2, 1 - alpha/2], n_runs * dof) / n_runs``.
    Returns ``(lower, upper)``.

    Examples
    --------
    >>> from trackcore.metrics import chi2_bounds
    >>> lo, hi = chi2_bounds(dof=4, n_runs=50)
    >>> round(lo, 3), round(hi, 3)  # 95 % acceptance band of the average NEES
    (3.255, 4.821)
    """
    dof = as_int(dof, "dof", minimum=1)
    n_runs = as_int(n_runs, "n_runs", minimum=1)
    alpha = as_scalar(alpha, "alpha")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    k = n_runs * dof
    lo = float(chi2.ppf(alpha / 2.0, k)) / n_runs
    if 1.0 - alpha / 2.0 < 1.0:
        hi = float(chi2.ppf(1.0 - alpha / 2.0, k)) / n_runs
    else:  # alpha / 2 below the rounding of 1: the upper tail directly
        hi = float(chi2.isf(alpha / 2.0, k)) / n_runs
    return finite_result((lo, hi), "the chi-square bounds", "dof, n_runs and alpha")


# --------------------------------------------------------------------------- set metrics

class OSPAResult(NamedTuple):
    """OSPA distance and its components (all in distance units).

    ``distance**p == localisation**p + cardinality**p`` for finite ``p``.

    Examples
    --------
    >>> from trackcore.metrics import ospa
    >>> res = ospa([[0.0, 0.0]], [[3.0, 4.0], [10.0, 0.0]], c=10.0)
    >>> res._fields
    ('distance', 'localisation', 'cardinality')
    >>> print(round(res.distance, 3), round(res.localisation, 3), round(res.cardinality, 3))
    7.5 2.5 5.0
    """
    distance: float
    localisation: float
    cardinality: float


class GOSPAResult(NamedTuple):
    """GOSPA distance (distance units) and its components (distance**p units).

    ``distance**p == localisation + missed + false``.  ``n_missed``/``n_false``
    count the true points left unassigned and the estimated points left
    unassigned (a pair farther apart than ``c`` counts as one of each).

    Examples
    --------
    >>> from trackcore.metrics import gospa
    >>> res = gospa([[0.0, 0.0]], [[3.0, 4.0], [10.0, 0.0]], c=10.0)
    >>> res._fields
    ('distance', 'localisation', 'missed', 'false', 'n_missed', 'n_false')
    >>> res.n_missed, res.n_false
    (1, 0)
    >>> round(res.distance ** 2, 3) == round(res.localisation + res.missed + res.false, 3)
    True
    """
    distance: float
    localisation: float
    missed: float
    false: float
    n_missed: int
    n_false: int


def _point_sets(X, Y):
    out = []
    for arr, name in ((X, "X"), (Y, "Y")):
        if isinstance(arr, (list, tuple)) and len(arr) == 0:
            out.append(None)
            continue
        a = as_array(arr, name, ndim=(1, 2))
        if a.ndim == 1:
            if a.size == 0:
                out.append(None)
                continue
            raise ValueError(f"{name} must be an (m, d) array of points, got shape {a.shape}")
        out.append(a)
    X, Y = out
    if X is not None and Y is not None and X.shape[1] != Y.shape[1]:
        raise ValueError(
            f"X and Y must have the same point dimension, got {X.shape[1]} and {Y.shape[1]}")
    d = X.shape[1] if X is not None else (Y.shape[1] if Y is not None else 0)
    X = np.zeros((0, d)) if X is None else X
    Y = np.zeros((0, d)) if Y is None else Y
    return X, Y


def _order(p, name="p"):
    if isinstance(p, (bool, np.bool_)):
        raise TypeError(f"{name} must be a real number >= 1, got bool")
    p = as_scalar(p, name, finite=False)
    if np.isnan(p) or p < 1.0:
        raise ValueError(f"{name} must be >= 1, got {p}")
    return p


#: the powers are taken as written while p <= _P_PLAIN and c**p lies in this range
_P_PLAIN = 20.0
_POW_LO, _POW_HI = 1e-250, 1e250


def _c_pow(c, p):
    """``c**p`` as a float (``inf`` on overflow)."""
    try:
        return c ** p
    except OverflowError:
        return math.inf


def _plain_powers(c, p) -> bool:
    """The powers and squared distances are taken as written: moderate ``p``, and ``c``
    (so the capped distances) far from both ends of the floating-point range."""
    return p <= _P_PLAIN and 1e-100 <= c <= 1e100 and _POW_LO <= _c_pow(c, p) <= _POW_HI


@nb.njit(cache=True)
def min_cost_assignment_kernel(cost, row_to_col):
    """Exact minimum-cost assignment of every row of ``cost`` (r, k), ``r <= k``.

    Shortest-augmenting-path Hungarian algorithm with dual potentials,
    O(r^2 k); writes the column of each row into ``row_to_col`` (r,) and
    returns the minimum total cost.  ``cost`` must be finite.  Same optimum as
    ``scipy.optimize.linear_sum_assignment`` (ties may be broken differently).
    """
    r, k = cost.shape
    u = np.zeros(r + 1)
    v = np.zeros(k + 1)
    owner = np.zeros(k + 1, dtype=np.int64)     # 1-based row assigned to column j (0: none)
    way = np.zeros(k + 1, dtype=np.int64)
    minv = np.empty(k + 1)
    used = np.empty(k + 1, dtype=np.bool_)
    for i in range(1, r + 1):
        owner[0] = i
        j0 = 0
        for j in range(k + 1):
            minv[j] = np.inf
            used[j] = False
        while True:
            used[j0] = True
            i0 = owner[j0]
            delta = np.inf
            j1 = 0
            for j in range(1, k + 1):
                if not used[j]:
                    cur = cost[i0 - 1, j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j] = cur
                        way[j] = j0
                    if minv[j] < delta:
                        delta = minv[j]
                        j1 = j
            for j in range(k + 1):
                if used[j]:
                    u[owner[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if owner[j0] == 0:
                break
        while True:
            j1 = way[j0]
            owner[j0] = owner[j1]
            j0 = j1
            if j0 == 0:
                break
    total = 0.0
    for j in range(1, k + 1):
        if owner[j] != 0:
            row_to_col[owner[j] - 1] = j - 1
    for i in range(r):
        total += cost[i, row_to_col[i]]
    return total


@nb.njit(cache=True)
def _capped_distances_kernel(A, B, c):
    """min(c, ||a_i - b_j||) for the rows of A (r, d) and B (k, d)."""
    r, d = A.shape
    k = B.shape[0]
    D = np.empty((r, k))
    for i in range(r):
        for j in range(k):
            s = 0.0
            for t in range(d):
                e = A[i, t] - B[j, t]
                s += e * e
            D[i, j] = min(math.sqrt(s), c)
    return D


@nb.njit(cache=True)
def _assigned_capped(A, B, c, p):
    """Capped distances of the optimal assignment of all rows of A (r <= k rows of B)."""
    D = _capped_distances_kernel(A, B, c)
    r, k = D.shape
    cost = D.copy()
    if p != 1.0:
        for i in range(r):
            for j in range(k):
                cost[i, j] = D[i, j] ** p
    cols = np.empty(r, dtype=np.int64)
    min_cost_assignment_kernel(cost, cols)
    out = np.empty(r)
    for i in range(r):
        out[i] = D[i, cols[i]]
    return out


@nb.njit(cache=True)
def _bottleneck_rect_kernel(T):
    """Smallest achievable largest entry when every row of ``T`` (r, k), ``r <= k``,
    is assigned a distinct column (for a square ``T``: of a perfect matching)."""
    r, k = T.shape
    values = np.unique(T.ravel())
    lo, hi = 0, values.shape[0] - 1
    over = np.empty((r, k))
    cols = np.empty(r, dtype=np.int64)
    while lo < hi:
        mid = (lo + hi) // 2
        for i in range(r):
            for j in range(k):
                over[i, j] = 1.0 if T[i, j] > values[mid] else 0.0
        if min_cost_assignment_kernel(over, cols) == 0.0:
            hi = mid
        else:
            lo = mid + 1
    return values[lo]


@nb.njit(cache=True)
def _scaled_distances_kernel(A, B, c):
    """``t = min(||a_i - b_j||, c) / c`` for the rows of A (r, d) and B (k, d), with the
    differences divided by ``c`` before they are squared (no overflow for coordinates
    near 1e300, no underflow for coordinates and ``c`` near 1e-300)."""
    r, d = A.shape
    k = B.shape[0]
    T = np.empty((r, k))
    for i in range(r):
        for j in range(k):
            s = 0.0
            capped = False
            for q in range(d):
                e = (A[i, q] - B[j, q]) / c
                if not abs(e) < 1.0:
                    capped = True
                    break
                s += e * e
            T[i, j] = 1.0 if capped or s >= 1.0 else math.sqrt(s)
    return T


@nb.njit(cache=True)
def _scaled_assignment(X, Y, c, p, cols):
    """The optimal assignment of the rows of ``X`` to those of ``Y`` (``1 <= m <= n``)
    in the scaled form; writes it to ``cols`` (m,) and returns ``(b, S, T)``: the capped
    distances over ``c``, ``T = min(d, c) / c``, their bottleneck ``b`` and
    ``S = min_pi sum (t / b)^p``, so that ``min_pi sum min(d, c)^p = (c b)^p S``.
    Every optimal assignment has its largest ``t / b >= 1``, so ``1 <= S <= m``: costs
    above ``m + 1`` cannot be optimal and are capped there; no power overflows, and the
    ones that underflow are below ``1e-308`` of the optimum."""
    T = _scaled_distances_kernel(X, Y, c)
    m, n = T.shape
    b = _bottleneck_rect_kernel(T)
    cost = np.empty((m, n))
    if b == 0.0:
        for i in range(m):
            for j in range(n):
                cost[i, j] = 0.0 if T[i, j] == 0.0 else 1.0
        min_cost_assignment_kernel(cost, cols)
        return 0.0, 0.0, T
    cap = m + 1.0
    lcap = math.log(cap)
    for i in range(m):
        for j in range(n):
            u = T[i, j] / b
            if u == 0.0:
                cost[i, j] = 0.0
            else:
                e = p * math.log(u)
                cost[i, j] = cap if e >= lcap else math.exp(e)
    S = min_cost_assignment_kernel(cost, cols)
    return b, S, T


def _log_add(terms):
    top = max(terms)
    return top + math.log(sum(math.exp(t - top) for t in terms))


@nb.njit(cache=True)
def _ospa_scaled_kernel(X, Y, c, p):
    """:func:`ospa_kernel` for finite ``p`` in the scaled form (any ``c``, any ``p``)."""
    m = X.shape[0]
    n = Y.shape[0]
    if m > n:
        X, Y = Y, X
        m, n = n, m
    if n == 0:
        return 0.0, 0.0, 0.0
    card = c * math.exp(math.log((n - m) / n) / p) if n > m else 0.0
    if m == 0:
        return c, 0.0, c
    cols = np.empty(m, dtype=np.int64)
    b, S, _ = _scaled_assignment(X, Y, c, p, cols)
    if b == 0.0:
        return card, 0.0, card
    # log of the p-th powers divided by c^p: localisation and cardinality
    a_loc = p * math.log(b) + math.log(S) - math.log(n)
    loc = c * math.exp(a_loc / p)
    if n > m:
        a_card = math.log((n - m) / n)
        top = max(a_loc, a_card)
        a_tot = top + math.log(math.exp(a_loc - top) + math.exp(a_card - top))
    else:
        a_tot = a_loc
    return c * math.exp(a_tot / p), loc, card


@nb.njit(cache=True)
def ospa_kernel(X, Y, c, p):
    """OSPA ``(distance, localisation, cardinality)`` for valid float64 ``(m, d)``/``(n, d)``
    point arrays, ``c > 0`` and ``p >= 1`` (``inf`` allowed).  Callable from other kernels."""
    m = X.shape[0]
    n = Y.shape[0]
    if m > n:
        X, Y = Y, X
        m, n = n, m
    if n == 0:
        return 0.0, 0.0, 0.0
    if p == np.inf:
        if m != n:
            return c, 0.0, c
        v = _bottleneck_rect_kernel(_capped_distances_kernel(X, Y, c))
        return v, v, 0.0
    if m == 0:
        return c, 0.0, c
    d = _assigned_capped(X, Y, c, p)
    loc_p = 0.0
    for i in range(m):
        loc_p += d[i] ** p
    loc_p /= n
    card_p = c ** p * (n - m) / n
    return (loc_p + card_p) ** (1.0 / p), loc_p ** (1.0 / p), card_p ** (1.0 / p)


@nb.njit(cache=True)
def gospa_kernel(X, Y, c, p, alpha):
    """GOSPA ``(distance, localisation, missed, false, n_missed, n_false)`` for valid
    float64 estimates ``X`` (nx, d) and truth ``Y`` (ny, d), ``c > 0``, finite
    ``p >= 1``, ``0 < alpha <= 2``.  Callable from other kernels."""
    nx = X.shape[0]
    ny = Y.shape[0]
    unit = c ** p / alpha
    loc = 0.0
    n_cut = 0
    if nx > 0 and ny > 0:
        if nx <= ny:
            d = _assigned_capped(X, Y, c, p)
        else:
            d = _assigned_capped(Y, X, c, p)
        for i in range(d.shape[0]):
            if alpha == 2.0:
                if d[i] < c:
                    loc += d[i] ** p
                else:
                    n_cut += 1
            else:
                loc += d[i] ** p
    n_assigned = min(nx, ny) - n_cut
    if alpha == 2.0:
        n_missed = ny - n_assigned
        n_false = nx - n_assigned
    else:
        n_missed = max(ny - nx, 0)
        n_false = max(nx - ny, 0)
    missed = unit * n_missed
    false = unit * n_false
    return (loc + missed + false) ** (1.0 / p), loc, missed, false, n_missed, n_false


def ospa(X, Y, c, p=1):
    """OSPA metric of order ``p`` with cut-off ``c`` between point sets ``X`` and ``Y``.

    .. math:: \\bar d_p^{(c)}(X, Y) = \\Big(\\frac{1}{n}\\big(\\min_\\pi \\sum_{i=1}^{m}
              \\min(c, \\|x_i - y_{\\pi(i)}\\|)^p + c^p (n - m)\\big)\\Big)^{1/p},
              \\quad m \\le n,

    :cite:p:`schuhmacher2008ospa`, with the exact optimal assignment (minimum
    of the sum of ``p``-th powers; :func:`min_cost_assignment_kernel`).
    Returns :class:`OSPAResult` ``(distance, localisation, cardinality)`` where
    ``localisation = (min_pi sum min(c, d)^p / n)^(1/p)`` and
    ``cardinality = (c^p (n - m) / n)^(1/p)``.  Both sets empty gives zeros.
    ``p = inf`` is allowed (distance ``c`` if the cardinalities differ, else the
    smallest achievable largest cut-off distance).  Inside numba code call
    :func:`ospa_kernel` directly.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import ospa
    >>> X = np.array([[0.0, 0.0], [10.0, 10.0]])
    >>> Y = np.array([[1.0, 0.0]])
    >>> res = ospa(X, Y, c=5.0, p=1)       # one distance of 1, one unmatched point at c
    >>> print(round(res.distance, 3), round(res.localisation, 3), round(res.cardinality, 3))
    3.0 0.5 2.5
    >>> ospa(np.zeros((0, 2)), np.zeros((0, 2)), c=5.0).distance       # two empty sets
    0.0
    """
    c = as_positive(c, "c")
    p = _order(p)
    X, Y = _point_sets(X, Y)
    if p == math.inf or _plain_powers(c, p):
        dist, loc, card = ospa_kernel(X, Y, c, p)
    else:
        dist, loc, card = _ospa_scaled_kernel(X, Y, c, p)
    return OSPAResult(*_finite_set_metric((float(dist), float(loc), float(card)), c))


def _finite_set_metric(values, c):
    """Set-metric values scale with ``c``; distances between points ``1e300`` apart
    can still overflow the point differences themselves."""
    return finite_result(values, "the set metric", "X, Y and c")


def gospa(X, Y, c, p=2, alpha=2):
    """GOSPA metric :cite:p:`rahmathullah2017gospa` between estimates ``X`` and truth ``Y``.

    .. math:: d_p^{(c,\\alpha)}(X, Y) = \\Big(\\min_\\pi \\sum_{i=1}^{m}
              \\min(c, \\|x_i - y_{\\pi(i)}\\|)^p + \\frac{c^p}{\\alpha}(n - m)\\Big)^{1/p},
              \\quad m = \\min(|X|, |Y|), \\; n = \\max(|X|, |Y|).

    No normalisation by ``n`` (unlike OSPA).  Returns :class:`GOSPAResult`.  For
    ``alpha = 2`` (the recommended value, and Stone Soup's only one) a pair
    farther apart than ``c`` is one missed plus one false target, each costing
    ``c^p / 2``, so ``localisation`` is the sum of ``d^p`` over pairs closer than
    ``c``, ``missed = c^p/2 * n_missed`` and ``false = c^p/2 * n_false``.  For
    another ``alpha`` the decomposition into missed/false is not defined by the
    paper; pairs capped at ``c`` then stay in ``localisation`` (each costing
    ``c^p``) and ``missed``/``false`` hold only the cardinality surplus
    ``c^p/alpha * ||X| - |Y||``.  Inside numba code call :func:`gospa_kernel`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import gospa
    >>> est = np.array([[0.0, 0.0], [50.0, 50.0]])      # one good track, one false track
    >>> truth = np.array([[1.0, 0.0], [20.0, 0.0]])     # one found target, one missed target
    >>> res = gospa(est, truth, c=10.0, p=2, alpha=2)
    >>> print(round(res.distance, 3), res.n_missed, res.n_false)
    10.05 1 1
    >>> print(round(res.localisation, 3), round(res.missed, 3), round(res.false, 3))
    1.0 50.0 50.0
    """
    c = as_positive(c, "c")
    p = _order(p)
    if np.isinf(p):
        raise ValueError("p must be finite for GOSPA, got inf")
    alpha = as_scalar(alpha, "alpha")
    if not 0.0 < alpha <= 2.0:
        raise ValueError(f"alpha must be in (0, 2], got {alpha}")
    unit = _c_pow(c, p) / alpha
    if not 1e-300 <= unit <= 1e300:
        raise ValueError(f"GOSPA's components are in units of distance**p, and c**p / alpha "
                         f"= {unit:.3g} for c={c!r}, p={p!r}, alpha={alpha!r} is not "
                         "representable; rescale the coordinates (and c) or lower p")
    X, Y = _point_sets(X, Y)
    if _plain_powers(c, p):
        dist, loc, missed, false, n_missed, n_false = gospa_kernel(X, Y, c, p, alpha)
    else:
        dist, loc, missed, false, n_missed, n_false = _gospa_scaled(X, Y, c, p, alpha)
    vals = finite_result((float(dist), float(loc), float(missed), float(false)),
                         "the GOSPA metric", "X, Y, c and p")
    return GOSPAResult(*vals, int(n_missed), int(n_false))


def _gospa_scaled(X, Y, c, p, alpha):
    """:func:`gospa_kernel` in the scaled form: the assignment of
    :func:`_scaled_assignment`, the distance ``c (S_t + (n - m) / alpha)^(1/p)`` from
    logarithms (``S_t`` the optimal sum of ``(min(d, c) / c)^p``), the components as
    powers (each representable, since ``c**p / alpha`` is)."""
    nx, ny = X.shape[0], Y.shape[0]
    A, B = (X, Y) if nx <= ny else (Y, X)
    m, n = A.shape[0], B.shape[0]
    unit = _c_pow(c, p) / alpha
    loc = 0.0
    n_cut = 0
    terms = []
    if m:
        cols = np.empty(m, dtype=np.int64)
        b, S, T = _scaled_assignment(A, B, c, p, cols)
        for i in range(m):
            t = float(T[i, cols[i]])
            if alpha == 2.0 and t >= 1.0:
                n_cut += 1
            elif t > 0.0:
                loc += math.exp(p * (math.log(t) + math.log(c)))
        if b > 0.0:
            terms.append(p * math.log(b) + math.log(S))
    if n > m:
        terms.append(math.log((n - m) / alpha))
    dist = c * math.exp(_log_add(terms) / p) if terms else 0.0
    n_assigned = m - n_cut
    if alpha == 2.0:
        n_missed, n_false = ny - n_assigned, nx - n_assigned
    else:
        n_missed, n_false = max(ny - nx, 0), max(nx - ny, 0)
    return dist, loc, unit * n_missed, unit * n_false, n_missed, n_false


# --------------------------------------------------------------------------- cardinality

class CardinalityError(NamedTuple):
    """Mean signed error (bias ``s``) and mean absolute error (``e``) of target counts.

    Examples
    --------
    >>> from trackcore.metrics import cardinality_error
    >>> err = cardinality_error([2, 3, 1], [2, 2, 2], axis=None)
    >>> err._fields
    ('bias', 'mae')
    >>> print(round(err.bias, 4), round(err.mae, 4))
    0.0 0.6667
    """
    bias: np.ndarray | float
    mae: np.ndarray | float


def cardinality_error(est_counts, true_counts, axis=0):
    """Bias ``s = mean(N_est - N_true)`` and ``e = mean(|N_est - N_true|)`` over ``axis``.

    ``est_counts`` is e.g. ``(n_runs, n_scans)`` and ``true_counts`` ``(n_scans,)``
    (broadcast); ``axis=0`` gives per-scan values, ``axis=None`` one number each.
    Counts must be finite and non-negative (they may be expected, non-integer
    counts such as a PHD filter's total mass).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.metrics import cardinality_error
    >>> est = np.array([[2, 3, 3], [2, 1, 3]])            # 2 runs, 3 scans
    >>> err = cardinality_error(est, [2, 2, 3])           # per scan
    >>> print(err.bias, err.mae)
    [0. 0. 0.] [0. 1. 0.]
    """
    est = as_array(est_counts, "est_counts")
    tru = as_array(true_counts, "true_counts")
    for a, name in ((est, "est_counts"), (tru, "true_counts")):
        if a.size and a.min() < 0:
            raise ValueError(f"{name} must be non-negative")
    if est.size == 0:
        raise ValueError("est_counts must not be empty")
    try:
        err = est - tru
    except ValueError:
        raise ValueError(
            f"est_counts and true_counts must have broadcastable shapes, got {est.shape} "
            f"and {tru.shape}") from None
    axis = _check_axis(axis, err.ndim)
    s = np.mean(err, axis=axis)
    e = np.mean(np.abs(err), axis=axis)
    if np.ndim(s) == 0:
        return CardinalityError(float(s), float(e))
    return CardinalityError(s, e)
