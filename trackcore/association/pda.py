"""Probabilistic data association (PDAF), Bar-Shalom & Li.

Association probabilities (parametric form, Poisson clutter of spatial
density ``lambda``), for ``m`` gated measurements with Gaussian likelihoods
``L_j = N(nu_j; 0, S)``:

    beta_j ∝ P_D L_j            (j = 1..m)
    beta_0 ∝ lambda (1 - P_D P_G)

normalised to sum to one.  The nonparametric (diffuse prior) form replaces
``lambda`` by ``m / V`` with ``V`` the gate volume.  ``P_G = pg = 1`` is "no
gate" (every measurement validated, ``1 - P_D P_G = 1 - P_D``); the gate then has
no finite volume, so ``lambda`` must come from the parametric model: the
nonparametric form with ``volume = inf`` raises ``ValueError`` (a finite
``volume`` with ``pg = 1`` is the volume of the region the ``m`` measurements
were drawn from).  All of it is computed in
log space (``log_lik=``), so likelihoods that underflow do not break it.

State update with the combined innovation ``nu = sum_j beta_j nu_j``:

    x = x_pred + K nu
    P = beta_0 P_pred + (1 - beta_0) P_c + K (sum_j beta_j nu_j nu_j^T - nu nu^T) K^T

with ``K`` and ``P_c`` the Kalman gain and (Joseph-form) updated covariance of
the Kalman update kernel (``trackcore.filters.kalman.kf_update_kernel``), which
this module calls.  The numba kernels here (``pda_betas_kernel``,
``pda_update_kernel``) serve the trackers' kernels; they assume valid input and
are not public.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_covariance, as_int, as_matrix, as_measurements,
                               as_nonnegative, as_positive, as_probability, as_scalar, as_vector,
                               finite_result)
from ..filters._fastcheck import check_result_cov
from ..filters.kalman import _kf_update_work, _update_scratch
from ..models.measurement import wrap_angle_kernel

__all__ = [
    "PDAUpdate",
    "pda_betas",
    "pda_log_likelihood",
    "pda_update",
]

_BETA_SUM_TOL = 1e-9


class PDAUpdate(NamedTuple):
    """Result of :func:`pda_update`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import pda_update
    >>> upd = pda_update(np.zeros(2), np.eye(2), [[1.0]], [0.0], [[1.0, 0.0]], [[1.0]],
    ...                  betas=[0.6], beta0=0.4)
    >>> upd._fields
    ('x', 'P', 'innovation_combined', 'S', 'K')
    >>> print(np.round(upd.x, 3), np.round(upd.innovation_combined, 3))
    [0.3 0. ] [0.6]
    """
    x: np.ndarray                    # updated mean (n,)
    P: np.ndarray                    # updated covariance with spread term (n, n)
    innovation_combined: np.ndarray  # nu = sum_j beta_j nu_j (d,)
    S: np.ndarray                    # innovation covariance (d, d)
    K: np.ndarray                    # gain (n, d)


# ------------------------------------------------------------------ betas
@nb.njit(cache=True)
def pda_betas_kernel(log_lik, log_pd, log_miss, log_clutter, betas):
    """Association probabilities in log space.

    ``log_lik`` (m,): log N(nu_j; 0, S); ``log_pd = log P_D``; ``log_miss =
    log(1 - P_D P_G)``; ``log_clutter = log lambda`` (``log(m / V)`` for the
    nonparametric form).  Writes ``betas`` (m,) and returns
    ``(beta0, log_norm)`` with ``log_norm = log(lambda (1 - P_D P_G) +
    P_D sum_j L_j)``.  For ``m = 0``: ``beta0 = 1``, ``log_norm = log_clutter
    + log_miss``.  If every term is zero, returns ``beta0 = NaN``,
    ``log_norm = -inf`` (the caller decides: the hypotheses are inconsistent).
    """
    m = log_lik.shape[0]
    a0 = log_clutter + log_miss
    if m == 0:
        return 1.0, a0
    top = a0
    for j in range(m):
        v = log_pd + log_lik[j]
        if v > top:
            top = v
    if top == -np.inf:
        for j in range(m):
            betas[j] = np.nan
        return np.nan, -np.inf
    s = math.exp(a0 - top)
    for j in range(m):
        s += math.exp(log_pd + log_lik[j] - top)
    log_norm = top + math.log(s)
    for j in range(m):
        betas[j] = math.exp(log_pd + log_lik[j] - log_norm)
    beta0 = math.exp(a0 - log_norm)
    return beta0, log_norm


def _log_terms(lik, pd, pg, clutter_density, log_lik, mode, volume, log_clutter_density=None):
    if (lik is None) == (log_lik is None):
        raise ValueError("give exactly one of lik and log_lik")
    if log_lik is None:
        arr = as_array(lik, "lik", ndim=1)
        if arr.size and arr.min() < 0:
            raise ValueError("lik must contain non-negative likelihoods")
        with np.errstate(divide="ignore"):
            ll = np.log(arr)
    else:
        ll = as_array(log_lik, "log_lik", ndim=1, finite=False)
        if np.any(np.isnan(ll)) or np.any(ll == np.inf):
            raise ValueError("log_lik must not contain NaN or +inf")
    pd = as_probability(pd, "pd")
    pg = as_probability(pg, "pg", open_low=True)
    m = ll.shape[0]
    log_lam = None
    if mode == "parametric":
        if log_clutter_density is not None:
            if clutter_density is not None:
                raise ValueError("give only one of clutter_density and log_clutter_density")
            log_lam = as_scalar(log_clutter_density, "log_clutter_density", finite=False)
            if math.isnan(log_lam) or log_lam == math.inf:
                raise ValueError("log_clutter_density must be < +inf and not NaN")
            lam = 0.0
        elif clutter_density is None:
            raise ValueError("clutter_density is required for mode='parametric'")
        else:
            lam = as_nonnegative(clutter_density, "clutter_density")
    elif mode == "nonparametric":
        if volume is None:
            raise ValueError("volume (gate volume V) is required for mode='nonparametric'")
        if as_scalar(volume, "volume", finite=False) == math.inf:
            raise ValueError("volume must be finite for mode='nonparametric' (lambda = m / V); "
                             "pg = 1 (no gate) has no finite gate volume: use "
                             "mode='parametric' with clutter_density")
        V = as_positive(volume, "volume")
        lam = m / V
    else:
        raise ValueError(f"mode must be 'parametric' or 'nonparametric', got {mode!r}")
    with np.errstate(divide="ignore"):
        log_pd = math.log(pd) if pd > 0 else -math.inf
        miss = 1.0 - pd * pg
        log_miss = math.log(miss) if miss > 0 else -math.inf
        if log_lam is None:
            log_lam = math.log(lam) if lam > 0 else -math.inf
    return np.ascontiguousarray(ll), log_pd, log_miss, log_lam


def pda_betas(lik=None, pd=1.0, pg=1.0, clutter_density=None, *, log_lik=None,
              mode="parametric", volume=None, log_clutter_density=None):
    """PDA association probabilities ``(beta0, betas (m,))``.

    ``lik[j] = N(nu_j; 0, S)`` for the ``m`` gated measurements (or pass
    ``log_lik=`` to stay in log space); ``pd`` = P_D, ``pg`` = P_G;
    ``clutter_density`` = lambda (per unit measurement volume) for the
    parametric form (or ``log_clutter_density=log lambda``); ``mode="nonparametric"`` uses ``lambda = m / volume``.
    ``beta0 + sum(betas) = 1``.  ``m = 0`` gives ``beta0 = 1``.  Raises
    ``ValueError`` when every hypothesis has zero probability (e.g. no
    clutter, ``P_D P_G = 1`` and all likelihoods zero).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import pda_betas
    >>> lik = np.array([0.05, 0.01])            # N(nu_j; 0, S) of two gated measurements
    >>> beta0, betas = pda_betas(lik, pd=0.9, pg=0.99, clutter_density=0.001)
    >>> round(beta0, 4), np.round(betas, 4)
    (0.002, array([0.8317, 0.1663]))
    >>> beta0, betas = pda_betas([], pd=0.9, pg=0.99, clutter_density=0.001)   # empty scan
    >>> beta0, betas.shape
    (1.0, (0,))
    """
    ll, log_pd, log_miss, log_lam = _log_terms(lik, pd, pg, clutter_density, log_lik, mode,
                                               volume, log_clutter_density)
    betas = np.empty(ll.shape[0])
    beta0, log_norm = pda_betas_kernel(ll, log_pd, log_miss, log_lam, betas)
    if math.isnan(beta0):
        raise ValueError("every association hypothesis has zero probability "
                         "(no clutter, P_D P_G = 1 and all likelihoods are zero?)")
    return float(beta0), betas


def pda_log_likelihood(lik=None, pd=1.0, pg=1.0, clutter_density=None, *, log_lik=None,
                       mode="parametric", volume=None, log_clutter_density=None):
    """``log(lambda (1 - P_D P_G) + P_D sum_j L_j)``: the PDA measurement
    likelihood of a scan up to a factor common to all models at that scan
    (the IMM-PDAF mode likelihood).  ``-inf`` when it is zero.

    In the nonparametric form ``lambda = m / V``; the scan's likelihood with
    the diffuse clutter prior is ``V^-m (1 - P_D P_G) + V^(1-m) (P_D / m)
    sum_j L_j``, which is the expression above times the common factor
    ``V^-m (V / m)`` for ``m > 0``.  For an empty scan it is ``1 - P_D P_G``,
    the probability of a missed detection, and that is what is returned (not
    ``log 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import pda_log_likelihood
    >>> ll = pda_log_likelihood([0.05, 0.01], pd=0.9, pg=0.99, clutter_density=0.001)
    >>> round(ll, 4), round(float(np.log(0.001 * (1 - 0.9 * 0.99) + 0.9 * 0.06)), 4)
    (-2.9168, -2.9168)
    >>> round(pda_log_likelihood([], pd=0.9, pg=0.99, mode="nonparametric", volume=10.0), 4)
    -2.2164
    """
    ll, log_pd, log_miss, log_lam = _log_terms(lik, pd, pg, clutter_density, log_lik, mode,
                                               volume, log_clutter_density)
    if mode == "nonparametric" and ll.shape[0] == 0:
        return float(log_miss)
    betas = np.empty(ll.shape[0])
    _, log_norm = pda_betas_kernel(ll, log_pd, log_miss, log_lam, betas)
    return float(log_norm)


# ------------------------------------------------------------------ update
@nb.njit(cache=True)
def pda_update_kernel(x_pred, P_pred, z, z_pred, H, R, betas, beta0, angle_index,
                      x_out, P_out, nu_out, S_out, K_out):
    """PDA state update into preallocated outputs (plain arrays, numba-callable).

    ``z`` (m, d) gated measurements, ``z_pred`` (d,), ``H`` (d, n), ``R``
    (d, d), ``betas`` (m,), ``beta0``; ``angle_index`` < 0 for none.
    Outputs: ``x_out`` (n,), ``P_out`` (n, n), ``nu_out`` (d,) combined
    innovation, ``S_out`` (d, d), ``K_out`` (n, d).  Returns False if ``S`` is
    not positive definite.  ``m = 0`` gives ``x_pred, P_pred`` (S, K still
    computed).
    """
    n = x_pred.shape[0]
    m, d = z.shape
    return _pda_update_work(x_pred, P_pred, z, z_pred, H, R, betas, beta0, angle_index, x_out,
                            P_out, nu_out, S_out, K_out, _pda_scratch(n, d, m))


@nb.njit(cache=True)
def _pda_scratch(n, d, m_max):
    """Work arrays of :func:`_pda_update_work` for state size ``n``, measurement size
    ``d`` and up to ``m_max`` measurements."""
    return ((np.empty((m_max, d)), np.empty(d), np.empty((n, n)), np.empty(d),
             np.empty((d, d)), np.empty((n, d))) + _update_scratch(n, d))


@nb.njit(cache=True)
def _pda_update_work(x_pred, P_pred, z, z_pred, H, R, betas, beta0, angle_index, x_out,
                     P_out, nu_out, S_out, K_out, work):
    """:func:`pda_update_kernel` with its work arrays ``work`` (from
    :func:`_pda_scratch`), for callers in a loop."""
    nus, zc, Pc, innov, D, KD, PHt, W, RKt, L, A, y = work
    n = x_pred.shape[0]
    m, d = z.shape
    for a in range(d):
        nu_out[a] = 0.0
    for j in range(m):
        for a in range(d):
            r = z[j, a] - z_pred[a]
            if a == angle_index:
                r = wrap_angle_kernel(r)
            nus[j, a] = r
            nu_out[a] += betas[j] * r
    # K, S and the Joseph-form P_c from the Kalman kernel: feed it a
    # measurement whose innovation is the combined one
    for a in range(d):
        s = nu_out[a]
        for b in range(n):
            s += H[a, b] * x_pred[b]
        zc[a] = s
    _, _, ok = _kf_update_work(x_pred, P_pred, zc, H, R, x_out, Pc, innov, S_out, K_out,
                               PHt, W, RKt, L, A, y)
    if not ok:
        return False
    if m == 0:
        for i in range(n):
            x_out[i] = x_pred[i]
            for k in range(n):
                P_out[i, k] = P_pred[i, k]
        return True
    # spread D = sum_j beta_j nu_j nu_j^T - nu nu^T
    for a in range(d):
        for b in range(d):
            s = -nu_out[a] * nu_out[b]
            for j in range(m):
                s += betas[j] * nus[j, a] * nus[j, b]
            D[a, b] = s
    for i in range(n):
        for b in range(d):
            s = 0.0
            for a in range(d):
                s += K_out[i, a] * D[a, b]
            KD[i, b] = s
    w1 = 1.0 - beta0
    for i in range(n):
        for k in range(i + 1):
            s = 0.0
            for b in range(d):
                s += KD[i, b] * K_out[k, b]
            v = beta0 * P_pred[i, k] + w1 * Pc[i, k] + s
            P_out[i, k] = v
            P_out[k, i] = v
    return True


def pda_update(x_pred, P_pred, z, z_pred, H, R, betas, beta0, angle_index=None):
    """PDAF update with the covariance-spread term; returns :class:`PDAUpdate`.

    ``z`` is the ``(m, d)`` array of gated measurements (``m = 0`` returns the
    prediction), ``z_pred`` the predicted measurement (``H x_pred`` for a
    linear model, ``h(x_pred)`` with ``H`` its Jacobian for an EKF-PDAF),
    ``betas`` ``(m,)`` and ``beta0`` from :func:`pda_betas` (they must be
    non-negative and sum to one), ``angle_index`` an angular measurement
    component whose innovations are wrapped to (-pi, pi].

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import pda_update
    >>> x, P = np.zeros(2), np.eye(2)              # [position, velocity]
    >>> H, R = np.array([[1.0, 0.0]]), np.array([[1.0]])
    >>> z = np.array([[1.0], [-1.0]])              # two gated measurements
    >>> upd = pda_update(x, P, z, [0.0], H, R, betas=[0.45, 0.45], beta0=0.1)
    >>> print(np.round(upd.x, 3))                 # the innovations cancel ...
    [0. 0.]
    >>> print(np.round(upd.P, 3))                 # ... but their spread inflates P
    [[0.775 0.   ]
     [0.    1.   ]]
    """
    x_pred = as_vector(x_pred, "x_pred")
    n = x_pred.shape[0]
    if n == 0:
        raise ValueError("x_pred must not be empty")
    P_pred = as_covariance(P_pred, "P_pred", n)
    z_pred = as_vector(z_pred, "z_pred")
    d = z_pred.shape[0]
    if d == 0:
        raise ValueError("z_pred must not be empty")
    z = as_measurements(z, "z", d)
    m = z.shape[0]
    H = as_matrix(H, "H", (d, n))
    R = as_covariance(R, "R", d)
    betas = as_array(betas, "betas", shape=(m,))
    beta0 = as_probability(beta0, "beta0")
    if m and betas.min() < 0:
        raise ValueError("betas must be non-negative")
    if abs(beta0 + float(betas.sum()) - 1.0) > _BETA_SUM_TOL:
        raise ValueError(f"beta0 + sum(betas) must be 1, got {beta0 + float(betas.sum())!r}")
    if angle_index is None:
        ai = -1
    else:
        ai = as_int(angle_index, "angle_index")
        if not -d <= ai < d:
            raise ValueError(f"angle_index must index one of the {d} components, got {ai}")
        ai %= d
    x = np.empty(n)
    P = np.empty((n, n))
    nu = np.empty(d)
    S = np.empty((d, d))
    K = np.empty((n, d))
    ok = pda_update_kernel(x_pred, P_pred, z, z_pred, H, R, betas, beta0, ai, x, P, nu, S, K)
    if not ok:
        raise ValueError("innovation covariance S = H P_pred H^T + R is not positive definite "
                         "(check P_pred and R)")
    for a in (x, P, nu, S, K):
        finite_result(a, "the PDA update", "x_pred, P_pred, z, z_pred, H and R")
    check_result_cov(P, "the PDA posterior covariance", (("R", R), ("P_pred", P_pred)))
    return PDAUpdate(x, P, nu, S, K)
