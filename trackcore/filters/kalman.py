"""Kalman filter and extended Kalman filter (Joseph-form update).

Public functions (:func:`kf_predict`, :func:`kf_update`, :func:`ekf_update`,
:func:`kalman_filter_run`) validate their inputs once and call numba kernels.
The kernels (``*_kernel``) assume valid, C-contiguous float64 arrays and write
into preallocated outputs of the right shapes; they are meant to be called from
other kernels (IMM, PDA, trackers), are not public, and are imported from this
module.  Finite inputs whose result overflows (a state or a measurement near
``1e300``) raise ``ValueError`` rather than return ``inf`` or NaN.

Update (Bar-Shalom, Li & Kirubarajan 2001, sec. 5.2):
``S = H P H^T + R``, ``K = P H^T S^{-1}``, ``x+ = x + K nu``,
``P+ = (I - K H) P (I - K H)^T + K R K^T`` (Joseph form, then symmetrised).
``S^{-1}`` is applied through its Cholesky factor; the log-likelihood
``log N(nu; 0, S)`` and the NIS ``nu^T S^{-1} nu`` come from the same factor.
An empty measurement (``m = 0``) is a valid update that changes nothing
(``nis = 0``, ``loglik = 0``).

Covariances follow one PSD rule (:func:`trackcore.core.validation.as_covariance`):
every covariance argument and every covariance a public function returns (each
scan's for the whole-run functions) has no eigenvalue below ``-1e-9`` times its
largest.  An argument whose negative eigenvalue is rounding at its own scale but
breaks the rule in the result (an ``R`` with eigenvalue ``-1e-9`` against a
posterior of scale ``1e-8``) raises ``ValueError`` naming it; a result broken by
the arithmetic's own rounding is projected onto the PSD matrices.  A result that
follows the rule is returned exactly as the kernels computed it.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.logmath import LOG_2PI
from ..core.validation import as_array, as_vector, finite_result
from ..models.measurement import wrap_angle_kernel
from ._fastcheck import check_result_cov, checked, checked_cov

__all__ = [
    "GaussianEstimate",
    "KalmanUpdate",
    "KalmanRun",
    "kf_predict",
    "kf_update",
    "ekf_update",
    "kalman_filter_run",
    "kalman_filter_batch",
]


class GaussianEstimate(NamedTuple):
    """A Gaussian state estimate: mean ``x`` (n,) and covariance ``P`` (n, n).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import GaussianEstimate
    >>> est = GaussianEstimate(x=np.array([1.0, 0.5]), P=np.eye(2))
    >>> est.x, est.P.shape
    (array([1. , 0.5]), (2, 2))
    """
    x: np.ndarray
    P: np.ndarray


class KalmanUpdate(NamedTuple):
    """Result of a (E)KF measurement update.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import kf_update
    >>> upd = kf_update(np.zeros(2), np.eye(2), [1.0], [[1.0, 0.0]], [[1.0]])
    >>> upd._fields
    ('x', 'P', 'innovation', 'S', 'K', 'nis', 'loglik')
    >>> print(upd.x, round(upd.nis, 3))
    [0.5 0. ] 0.5
    """
    x: np.ndarray           # posterior mean (n,)
    P: np.ndarray           # posterior covariance (n, n)
    innovation: np.ndarray  # nu = z - z_pred (m,), angles wrapped for the EKF
    S: np.ndarray           # innovation covariance (m, m)
    K: np.ndarray           # gain (n, m)
    nis: float              # nu^T S^{-1} nu
    loglik: float           # log N(nu; 0, S)


class KalmanRun(NamedTuple):
    """Result of :func:`kalman_filter_run` over K scans.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import kalman_filter_run
    >>> I = np.eye(1)
    >>> run = kalman_filter_run(np.ones((3, 1)), np.zeros(1), I, I, 0.1 * I, I, I)
    >>> run._fields
    ('xs', 'Ps', 'nis', 'loglik')
    >>> run.xs.shape, run.Ps.shape, run.nis.shape
    ((3, 1), (3, 1, 1), (3,))
    """
    xs: np.ndarray      # (K, n) posterior means
    Ps: np.ndarray      # (K, n, n) posterior covariances
    nis: np.ndarray     # (K,) NIS (NaN for a missed scan)
    loglik: np.ndarray  # (K,) log N(nu_k; 0, S_k) (0 for a missed scan)


# ---------------------------------------------------------------------- kernels
@nb.njit(cache=True)
def cholesky_lower_kernel(A, L):
    """Lower Cholesky factor of symmetric ``A`` into ``L``; False if not PD."""
    m = A.shape[0]
    for i in range(m):
        for j in range(i + 1):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if not s > 0.0:
                    return False
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
        for j in range(i + 1, m):
            L[i, j] = 0.0
    return True


@nb.njit(cache=True, inline="always")
def _predict_into(x, P, F, Q, x_out, P_out, FP):
    n = x.shape[0]
    for i in range(n):
        s = 0.0
        for k in range(n):
            s += F[i, k] * x[k]
        x_out[i] = s
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += F[i, k] * P[k, j]
            FP[i, j] = s
    for i in range(n):
        for j in range(i + 1):
            s = 0.0
            for k in range(n):
                s += FP[i, k] * F[j, k]
            v = s + 0.5 * (Q[i, j] + Q[j, i])
            P_out[i, j] = v
            P_out[j, i] = v


@nb.njit(cache=True)
def kf_predict_kernel(x, P, F, Q, x_out, P_out):
    """``x_out = F x``, ``P_out = F P F^T + Q`` (outputs may not alias inputs)."""
    FP = np.empty_like(P)
    _predict_into(x, P, F, Q, x_out, P_out, FP)


@nb.njit(cache=True, inline="always")
def _update_into(x, P, innov, H, R, x_out, P_out, S, K, PHt, W, RKt, L, A, y):
    """Joseph update given the innovation; returns (nis, loglik, ok).

    Scratch: PHt, W (n, m); RKt (m, n); L (m, m); A (n, n); y (m,).
    """
    n = x.shape[0]
    m = innov.shape[0]
    if m == 0:
        for i in range(n):
            x_out[i] = x[i]
            for j in range(n):
                P_out[i, j] = P[i, j]
        return 0.0, 0.0, True
    # PHt = P H^T
    for i in range(n):
        for j in range(m):
            s = 0.0
            for k in range(n):
                s += P[i, k] * H[j, k]
            PHt[i, j] = s
    # S = H P H^T + R (symmetrised)
    for i in range(m):
        for j in range(i + 1):
            s = 0.0
            for k in range(n):
                s += H[i, k] * PHt[k, j]
            v = s + 0.5 * (R[i, j] + R[j, i])
            S[i, j] = v
            S[j, i] = v
    if not cholesky_lower_kernel(S, L):
        return np.nan, -np.inf, False
    # K = PHt S^{-1}: solve L Y^T = PHt^T, then L^T K^T = Y^T (one reciprocal
    # per pivot, all rows at once)
    for j in range(m):
        inv = 1.0 / L[j, j]
        for i in range(n):
            s = PHt[i, j]
            for k in range(j):
                s -= L[j, k] * K[i, k]
            K[i, j] = s * inv
    for j in range(m - 1, -1, -1):
        inv = 1.0 / L[j, j]
        for i in range(n):
            s = K[i, j]
            for k in range(j + 1, m):
                s -= L[k, j] * K[i, k]
            K[i, j] = s * inv
    # NIS and log N(nu; 0, S) from the same factor: the arithmetic of
    # core.logmath.cholesky_logpdf_kernel, inlined so whole-run kernels do not
    # allocate per step (tests check the two agree).
    nis = 0.0
    det_half = 1.0
    for j in range(m):
        s = innov[j]
        for k in range(j):
            s -= L[j, k] * y[k]
        y[j] = s / L[j, j]
        nis += y[j] * y[j]
        det_half *= L[j, j]
    if det_half > 1e-280 and det_half < 1e280:
        half_logdet = math.log(det_half)
    else:  # guard against over/underflow of the product
        half_logdet = 0.0
        for j in range(m):
            half_logdet += math.log(L[j, j])
    loglik = -0.5 * (m * LOG_2PI + nis) - half_logdet
    # x+ = x + K nu
    for i in range(n):
        s = x[i]
        for j in range(m):
            s += K[i, j] * innov[j]
        x_out[i] = s
    # Joseph form P+ = (I - K H) P (I - K H)^T + K R K^T, grouped as
    #   A = (I - K H) P = P - K (P H^T)^T,   W = A H^T,
    #   P+ = A - W K^T + K (R K^T)          (lower triangle, mirrored).
    for i in range(n):
        for j in range(n):
            s = P[i, j]
            for k in range(m):
                s -= K[i, k] * PHt[j, k]
            A[i, j] = s
    for i in range(n):
        for j in range(m):
            s = 0.0
            for k in range(n):
                s += A[i, k] * H[j, k]
            W[i, j] = s
    for a in range(m):
        for j in range(n):
            t = 0.0
            for b in range(m):
                t += R[a, b] * K[j, b]
            RKt[a, j] = t
    for i in range(n):
        for j in range(i + 1):
            s = A[i, j]
            for a in range(m):
                s += K[i, a] * RKt[a, j] - W[i, a] * K[j, a]
            P_out[i, j] = s
            P_out[j, i] = s
    return nis, loglik, True


@nb.njit(cache=True)
def _update_scratch(n, m):
    return (np.empty((n, m)), np.empty((n, m)), np.empty((m, n)), np.empty((m, m)),
            np.empty((n, n)), np.empty(m))


@nb.njit(cache=True)
def kf_update_kernel(x, P, z, H, R, x_out, P_out, innov, S, K):
    """Joseph-form KF update into preallocated outputs.

    ``innov`` (m,), ``S`` (m, m), ``K`` (n, m) are outputs too.  Returns
    ``(nis, loglik, ok)``; ``ok`` is False when ``S`` is not positive definite.
    """
    PHt, W, RKt, L, A, y = _update_scratch(x.shape[0], z.shape[0])
    return _kf_update_work(x, P, z, H, R, x_out, P_out, innov, S, K, PHt, W, RKt, L, A, y)


@nb.njit(cache=True)
def _kf_update_work(x, P, z, H, R, x_out, P_out, innov, S, K, PHt, W, RKt, L, A, y):
    """:func:`kf_update_kernel` with its work arrays given (those of
    ``_update_scratch(n, m)``), for callers in a loop."""
    n = x.shape[0]
    m = z.shape[0]
    for i in range(m):
        s = z[i]
        for k in range(n):
            s -= H[i, k] * x[k]
        innov[i] = s
    return _update_into(x, P, innov, H, R, x_out, P_out, S, K, PHt, W, RKt, L, A, y)


@nb.njit(cache=True)
def kalman_filter_run_kernel(zs, x0, P0, F, Q, H, R, xs, Ps, nis, loglik):
    """Predict-then-update over the rows of ``zs`` (K, m) into preallocated outputs.

    A row whose first entry is NaN is a missed scan (prediction only; NIS NaN,
    loglik 0).  Returns the index of the first scan whose ``S`` was not
    positive definite, or -1.
    """
    n = x0.shape[0]
    m = zs.shape[1]
    xp = np.empty(n)
    Pp = np.empty((n, n))
    FP = np.empty((n, n))
    innov = np.empty(m)
    S = np.empty((m, m))
    K = np.empty((n, m))
    PHt, W, RKt, L, A, y = _update_scratch(n, m)
    xc = x0.copy()
    Pc = P0.copy()
    for k in range(zs.shape[0]):
        _predict_into(xc, Pc, F, Q, xp, Pp, FP)
        if m > 0 and math.isnan(zs[k, 0]):
            for i in range(n):
                xc[i] = xp[i]
                for j in range(n):
                    Pc[i, j] = Pp[i, j]
            nis[k] = np.nan
            loglik[k] = 0.0
        else:
            for i in range(m):
                s = zs[k, i]
                for j in range(n):
                    s -= H[i, j] * xp[j]
                innov[i] = s
            v, ll, ok = _update_into(xp, Pp, innov, H, R, xc, Pc, S, K, PHt, W, RKt, L, A, y)
            if not ok:
                return k
            nis[k] = v
            loglik[k] = ll
        for i in range(n):
            xs[k, i] = xc[i]
            for j in range(n):
                Ps[k, i, j] = Pc[i, j]
    return -1


@nb.njit(cache=True)
def _has_missed_scan(zs_run):
    for k in range(zs_run.shape[0]):
        if math.isnan(zs_run[k, 0]):
            return True
    return False


@nb.njit(cache=True)
def kalman_filter_batch_kernel(zs, x0, P0, F, Q, H, R, xs, Ps, nis, loglik):
    """:func:`kalman_filter_run_kernel` for ``n_runs`` runs ``zs`` (n_runs, K, m)
    sharing the model and the prior, into outputs with a leading run axis.

    The covariance recursion of a linear KF does not depend on the measurements,
    so for every run without a missed scan (no NaN row) it is computed once and
    only the means, innovations, NIS and log-likelihoods are run per run, with
    the same arithmetic as the single-run kernel (bit-identical results).  A run
    with missed scans goes through :func:`kalman_filter_run_kernel` itself.
    Returns ``(run, scan)`` of the first failure (``S`` not positive definite)
    in run order, or ``(-1, -1)``.
    """
    n_runs = zs.shape[0]
    K = zs.shape[1]
    m = zs.shape[2]
    n = x0.shape[0]
    # shared recursion for the all-detected pattern
    Pc_all = np.empty((K, n, n))
    K_all = np.empty((K, n, m))
    L_all = np.empty((K, m, m))
    hld_all = np.empty(K)
    Pp = np.empty((n, n))
    FP = np.empty((n, n))
    xp = np.empty(n)
    xdummy = np.empty(n)
    innov = np.zeros(m)
    S = np.empty((m, m))
    Kg = np.empty((n, m))
    PHt, W, RKt, L, A, y = _update_scratch(n, m)
    Pc = P0.copy()
    bad_shared = -1
    for k in range(K):
        _predict_into(x0, Pc, F, Q, xp, Pp, FP)
        if m == 0:
            for i in range(n):
                for j in range(n):
                    Pc[i, j] = Pp[i, j]
            hld_all[k] = 0.0
        else:
            _, _, ok = _update_into(xp, Pp, innov, H, R, xdummy, Pc, S, Kg, PHt, W, RKt, L,
                                    A, y)
            if not ok:
                bad_shared = k
                break
            det_half = 1.0
            for j in range(m):
                det_half *= L[j, j]
            if det_half > 1e-280 and det_half < 1e280:
                hld = math.log(det_half)
            else:
                hld = 0.0
                for j in range(m):
                    hld += math.log(L[j, j])
            hld_all[k] = hld
            for i in range(n):
                for j in range(m):
                    K_all[k, i, j] = Kg[i, j]
            for i in range(m):
                for j in range(m):
                    L_all[k, i, j] = L[i, j]
        for i in range(n):
            for j in range(n):
                Pc_all[k, i, j] = Pc[i, j]
    xc = np.empty(n)
    for r in range(n_runs):
        if m > 0 and _has_missed_scan(zs[r]):
            bad = kalman_filter_run_kernel(zs[r], x0, P0, F, Q, H, R, xs[r], Ps[r], nis[r],
                                           loglik[r])
            if bad >= 0:
                return r, bad
            continue
        if bad_shared >= 0:
            return r, bad_shared
        for i in range(n):
            xc[i] = x0[i]
        for k in range(K):
            for i in range(n):
                s = 0.0
                for j in range(n):
                    s += F[i, j] * xc[j]
                xp[i] = s
            if m == 0:
                for i in range(n):
                    xc[i] = xp[i]
                nis[r, k] = 0.0
                loglik[r, k] = 0.0
            else:
                for i in range(m):
                    s = zs[r, k, i]
                    for j in range(n):
                        s -= H[i, j] * xp[j]
                    innov[i] = s
                v = 0.0
                for j in range(m):
                    s = innov[j]
                    for q in range(j):
                        s -= L_all[k, j, q] * y[q]
                    y[j] = s / L_all[k, j, j]
                    v += y[j] * y[j]
                nis[r, k] = v
                loglik[r, k] = -0.5 * (m * LOG_2PI + v) - hld_all[k]
                for i in range(n):
                    s = xp[i]
                    for j in range(m):
                        s += K_all[k, i, j] * innov[j]
                    xc[i] = s
            for i in range(n):
                xs[r, k, i] = xc[i]
                for j in range(n):
                    Ps[r, k, i, j] = Pc_all[k, i, j]
    return -1, -1


# ---------------------------------------------------------------------- wrappers
def _check_state(x, P, x_name="x", P_name="P"):
    if not (type(x) is np.ndarray and x.ndim == 1):
        x = as_vector(x, x_name)
    n = x.shape[0]
    x = checked(x, x_name, (n,))
    if n == 0:
        raise ValueError(f"{x_name} must not be empty")
    P = checked_cov(P, P_name, n)
    return x, P, n


def kf_predict(x, P, F, Q):
    """Kalman prediction: returns ``(F x, F P F^T + Q)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import kf_predict
    >>> from trackcore.models import cv_transition, cv_process_noise
    >>> F, Q = cv_transition(1.0, dim=1), cv_process_noise(1.0, 0.1, dim=1)
    >>> x, P = kf_predict(np.array([0.0, 2.0]), np.eye(2), F, Q)
    >>> print(x)
    [2. 2.]
    >>> print(np.round(P, 3))
    [[2.025 1.05 ]
     [1.05  1.1  ]]
    """
    x, P, n = _check_state(x, P)
    F = checked(F, "F", (n, n))
    Q = checked_cov(Q, "Q", n)
    x_out = np.empty(n)
    P_out = np.empty((n, n))
    kf_predict_kernel(x, P, F, Q, x_out, P_out)
    _finite_outputs("the prediction", "x, P, F and Q", x_out, P_out)
    check_result_cov(P_out, "the predicted covariance", (("Q", Q), ("P", P)))
    return GaussianEstimate(x_out, P_out)


def _finite_outputs(what, cause, *arrays):
    for a in arrays:
        if not math.isfinite(float(np.sum(a))):
            finite_result(a, what, cause)


def _check_measurement(z, H, R, n, z_name="z"):
    if not (type(z) is np.ndarray and z.ndim == 1):
        z = as_vector(z, z_name)
    m = z.shape[0]
    z = checked(z, z_name, (m,))
    H = as_array(H, "H", ndim=2) if m == 0 else checked(H, "H", (m, n))
    if m == 0:
        H = np.zeros((0, n))
        R = np.zeros((0, 0))
    else:
        R = checked_cov(R, "R", m)
    return z, H, R, m


_NOT_PD = "innovation covariance S = H P H^T + R is not positive definite (check P and R)"


def _finish_update(x, P, innov, H, R, n, m):
    x_out = np.empty(n)
    P_out = np.empty((n, n))
    S = np.empty((m, m))
    K = np.empty((n, m))
    nis, loglik, ok = _update_into(x, P, innov, H, R, x_out, P_out, S, K,
                                   *_update_scratch(n, m))
    if not ok:
        raise ValueError(_NOT_PD)
    _finite_outputs("the update", "x, P, z, z_pred, H and R", x_out, P_out, innov, S, K,
                    nis, loglik)
    check_result_cov(P_out, "the posterior covariance", (("R", R), ("P", P)))
    return KalmanUpdate(x_out, P_out, innov, S, K, float(nis), float(loglik))


def kf_update(x, P, z, H, R):
    """Joseph-form Kalman update with measurement ``z = H x + w``, ``w ~ N(0, R)``.

    Returns :class:`KalmanUpdate`.  ``z`` of length 0 (empty scan) returns the
    prior unchanged with ``nis = loglik = 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import kf_update
    >>> x, P = np.array([0.0, 1.0]), np.diag([4.0, 1.0])
    >>> H, R = np.array([[1.0, 0.0]]), np.array([[1.0]])
    >>> upd = kf_update(x, P, [2.0], H, R)
    >>> print(upd.x)
    [1.6 1. ]
    >>> print(np.round(upd.P, 3))
    [[0.8 0. ]
     [0.  1. ]]
    >>> print(upd.innovation, upd.S, round(upd.nis, 3), round(upd.loglik, 3))
    [2.] [[5.]] 0.8 -2.124
    >>> kf_update(x, P, [], H, R).nis    # an empty scan leaves the prior unchanged
    0.0
    """
    x, P, n = _check_state(x, P)
    z, H, R, m = _check_measurement(z, H, R, n)
    x_out, P_out = np.empty(n), np.empty((n, n))
    innov, S, K = np.empty(m), np.empty((m, m)), np.empty((n, m))
    nis, loglik, ok = kf_update_kernel(x, P, z, H, R, x_out, P_out, innov, S, K)
    if not ok:
        raise ValueError(_NOT_PD)
    _finite_outputs("the update", "x, P, z, H and R", x_out, P_out, innov, S, K, nis,
                    loglik)
    check_result_cov(P_out, "the posterior covariance", (("R", R), ("P", P)))
    return KalmanUpdate(x_out, P_out, innov, S, K, float(nis), float(loglik))


def ekf_update(x, P, z, z_pred, H, R, angle_index=None):
    """Extended Kalman update with a linearised measurement model.

    ``z_pred = h(x)`` and ``H`` its Jacobian at ``x`` (computed by the caller,
    e.g. :func:`trackcore.models.range_bearing`).  ``angle_index`` lists the
    measurement components that are angles: their innovations are wrapped to
    ``(-pi, pi]``.  Returns :class:`KalmanUpdate`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import ekf_update
    >>> from trackcore.models import range_bearing, range_bearing_jacobian
    >>> x, P = np.array([-100.0, 0.1, 0.0, 0.0]), np.diag([25.0, 25.0, 1.0, 1.0])
    >>> z_pred, H = range_bearing(x), range_bearing_jacobian(x)
    >>> print(np.round(z_pred, 3))               # bearing just below +pi
    [100.      3.141]
    >>> z = np.array([101.0, -np.pi + 0.01])     # bearing just above -pi
    >>> upd = ekf_update(x, P, z, z_pred, H, np.diag([1.0, 1e-4]), angle_index=[1])
    >>> print(np.round(upd.innovation, 3))       # wrapped: 0.011 rad, not -6.272
    [1.    0.011]
    """
    x, P, n = _check_state(x, P)
    z, H, R, m = _check_measurement(z, H, R, n)
    z_pred = as_vector(z_pred, "z_pred", m)
    innov = z - z_pred
    if angle_index is not None:
        if isinstance(angle_index, (bool, np.bool_, str, bytes)):
            raise TypeError(f"angle_index must be an integer or a sequence of integers, "
                            f"got {type(angle_index).__name__}")
        idx = np.atleast_1d(np.asarray(angle_index))
        if idx.ndim != 1 or (idx.size and not np.issubdtype(idx.dtype, np.integer)):
            raise TypeError(f"angle_index must hold integers, got {idx.dtype} of shape "
                            f"{idx.shape}")
        if idx.size and (idx.min() < -m or idx.max() >= m):
            raise ValueError(f"angle_index entries must index the {m} measurement components, "
                             f"got {idx.tolist()}")
        for i in idx:
            innov[i] = wrap_angle_kernel(innov[i])
    return _finish_update(x, P, np.ascontiguousarray(innov), H, R, n, m)


def kalman_filter_run(zs, x0, P0, F, Q, H, R):
    """Run a linear Kalman filter over all scans in one numba kernel.

    For each scan ``k``: predict with ``(F, Q)`` then update with ``zs[k]``
    (same order as ``filterpy``'s ``predict(); update(z)``), starting from the
    prior ``(x0, P0)`` at the time before the first scan.  ``zs`` is ``(K, m)``;
    a row of NaN is a missed scan (prediction only).  Returns
    :class:`KalmanRun` ``(xs (K, n), Ps (K, n, n), nis (K,), loglik (K,))``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import kalman_filter_run
    >>> from trackcore.models import cv_transition, cv_process_noise, position_matrix
    >>> F, Q = cv_transition(1.0, dim=1), cv_process_noise(1.0, 0.01, dim=1)
    >>> H, R = position_matrix(dim=1, n=2), np.array([[1.0]])
    >>> zs = np.array([[1.0], [2.1], [np.nan], [3.9]])     # scan 2 is missed
    >>> run = kalman_filter_run(zs, np.zeros(2), 10.0 * np.eye(2), F, Q, H, R)
    >>> print(np.round(run.xs, 3))
    [[0.952 0.476]
     [2.018 0.948]
     [2.965 0.948]
     [3.901 0.943]]
    >>> print(np.round(run.nis, 3))
    [0.048 0.055   nan 0.   ]
    """
    x0, P0, n = _check_state(x0, P0, "x0", "P0")
    if not (type(zs) is np.ndarray and zs.dtype == np.float64 and zs.ndim == 2
            and zs.flags.c_contiguous):
        zs = as_array(zs, "zs", ndim=2, finite=False)
    K, m = zs.shape
    if not math.isfinite(zs.sum()):
        nan_rows = np.isnan(zs)
        if np.any(nan_rows.any(axis=1) != nan_rows.all(axis=1)) or np.any(np.isinf(zs)):
            raise ValueError("zs must be finite; a missed scan is a row that is entirely NaN")
    F = checked(F, "F", (n, n))
    Q = checked_cov(Q, "Q", n)
    H = checked(H, "H", (m, n))
    R = checked_cov(R, "R", m) if m else np.zeros((0, 0))
    xs = np.empty((K, n))
    Ps = np.empty((K, n, n))
    nis = np.empty(K)
    loglik = np.empty(K)
    bad = kalman_filter_run_kernel(zs, x0, P0, F, Q, H, R, xs, Ps, nis, loglik)
    if bad >= 0:
        raise ValueError(f"innovation covariance S is not positive definite at scan {bad}")
    _finite_run(zs, xs, Ps, nis, loglik)
    check_result_cov(Ps, "the filtered covariance Ps", (("R", R), ("Q", Q), ("P0", P0)))
    return KalmanRun(xs, Ps, nis, loglik)


def _check_batch_covariances(nis, Ps, R, Q, P0):
    """The PSD rule on a batch's covariances: the runs without a missed scan share one
    recursion (checked once, and projected together), the others are checked each.
    ``nis`` (n_runs, K) is NaN exactly at the missed scans (checked by _finite_run)."""
    args = (("R", R), ("Q", Q), ("P0", P0))
    if math.isfinite(float(nis.sum())):
        missed = np.zeros(nis.shape[0], dtype=bool)
    else:
        missed = np.isnan(nis).any(axis=1)
    clean = np.flatnonzero(~missed)
    if clean.size and check_result_cov(Ps[clean[0]], f"the filtered covariance Ps[{clean[0]}]",
                                       args):
        Ps[clean] = Ps[clean[0]]
    for r in np.flatnonzero(missed):
        check_result_cov(Ps[r], f"the filtered covariance Ps[{r}]", args)


def _finite_run(zs, xs, Ps, nis, loglik):
    """A run's outputs are finite except the NIS of a missed scan (NaN by definition).

    A non-finite mean or covariance stays non-finite through every later prediction and
    update (``inf`` times a zero is NaN), so the last scan's estimate stands for the
    run's; the NIS and log-likelihoods are checked at every scan."""
    cause = "zs, x0, P0, F, Q, H and R"
    if xs.shape[-2]:
        _finite_outputs("the filtered state", cause, xs[..., -1, :], Ps[..., -1, :, :])
    _finite_outputs("the log-likelihood", cause, loglik)
    if not math.isfinite(float(np.nansum(nis))) or (
            np.isnan(nis).any() and zs.shape[-1] and np.any(
                np.isnan(nis) != np.isnan(zs[..., 0]))):
        raise ValueError("the NIS is not finite in floating point (it overflows); check "
                         f"the magnitude of {cause}")


def _check_zs(zs, ndim):
    if not (type(zs) is np.ndarray and zs.dtype == np.float64 and zs.ndim == ndim
            and zs.flags.c_contiguous):
        zs = as_array(zs, "zs", ndim=ndim, finite=False)
    if not math.isfinite(zs.sum()):
        nan = np.isnan(zs)
        if np.any(nan.any(axis=-1) != nan.all(axis=-1)) or np.any(np.isinf(zs)):
            raise ValueError("zs must be finite; a missed scan is a row that is entirely NaN")
    return zs


def kalman_filter_batch(zs, x0, P0, F, Q, H, R):
    """:func:`kalman_filter_run` for a whole Monte Carlo batch in one kernel call.

    ``zs`` is ``(n_runs, K, m)``: run ``r``'s scans, all runs sharing the prior
    ``(x0, P0)`` and the model ``(F, Q, H, R)``; a row of NaN is a missed scan.
    Returns :class:`KalmanRun` with a leading run axis: ``xs (n_runs, K, n)``,
    ``Ps (n_runs, K, n, n)``, ``nis`` and ``loglik`` ``(n_runs, K)``; run ``r``
    equals ``kalman_filter_run(zs[r], x0, P0, F, Q, H, R)`` bit for bit.  The
    inputs are validated once, and the measurement-independent covariance
    recursion is computed once for all runs without missed scans.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.filters import kalman_filter_batch, kalman_filter_run
    >>> from trackcore.models import cv_transition, cv_process_noise, position_matrix
    >>> F, Q = cv_transition(1.0, dim=1), cv_process_noise(1.0, 0.01, dim=1)
    >>> H, R = position_matrix(dim=1, n=2), np.array([[1.0]])
    >>> zs = np.random.default_rng(0).normal(size=(5, 10, 1))   # 5 runs of 10 scans
    >>> batch = kalman_filter_batch(zs, np.zeros(2), 10.0 * np.eye(2), F, Q, H, R)
    >>> batch.xs.shape, batch.nis.shape
    ((5, 10, 2), (5, 10))
    >>> one = kalman_filter_run(zs[3], np.zeros(2), 10.0 * np.eye(2), F, Q, H, R)
    >>> bool(np.array_equal(batch.xs[3], one.xs))
    True
    """
    x0, P0, n = _check_state(x0, P0, "x0", "P0")
    zs = _check_zs(zs, 3)
    n_runs, K, m = zs.shape
    F = checked(F, "F", (n, n))
    Q = checked_cov(Q, "Q", n)
    H = checked(H, "H", (m, n))
    R = checked_cov(R, "R", m) if m else np.zeros((0, 0))
    xs = np.empty((n_runs, K, n))
    Ps = np.empty((n_runs, K, n, n))
    nis = np.empty((n_runs, K))
    loglik = np.empty((n_runs, K))
    if n_runs and K:
        run, scan = kalman_filter_batch_kernel(zs, x0, P0, F, Q, H, R, xs, Ps, nis, loglik)
        if run >= 0:
            raise ValueError(f"innovation covariance S is not positive definite at scan {scan} "
                             f"of run {run}")
        _finite_run(zs, xs, Ps, nis, loglik)
        _check_batch_covariances(nis, Ps, R, Q, P0)
    return KalmanRun(xs, Ps, nis, loglik)
