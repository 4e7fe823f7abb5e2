"""Ellipsoidal (chi-square) validation gates.

A measurement ``z_j`` falls in the gate of a track with predicted measurement
``z_pred`` and innovation covariance ``S`` when its squared Mahalanobis
distance ``d2_j = nu_j^T S^-1 nu_j`` (``nu_j = z_j - z_pred``) is at most
``gamma``.  With ``gamma`` the ``pg``-quantile of the chi-square distribution
with ``d`` degrees of freedom, a target-originated measurement lies in the
gate with probability ``P_G = pg`` (Bar-Shalom & Li).  The gate volume is
``V = c_d gamma^{d/2} |S|^{1/2}`` with ``c_d = pi^{d/2} / Gamma(d/2 + 1)``
the volume of the unit ball in ``d`` dimensions.

``pg = 1`` is "no gate": ``gamma = inf`` (:func:`gate_threshold`), every
measurement is validated (:func:`mahalanobis_gate`), ``P_G = 1``
(:func:`gate_probability`), and there is no finite gate volume:
:func:`gate_volume` raises ``ValueError`` for ``gamma = inf`` rather than return
``inf``.  Without a gate the clutter density must come from the parametric
model (a given ``lambda``, as in :func:`trackcore.association.pda_betas` with
``mode="parametric"`` and the IMM-PDAF tracker), not from ``m / V``.

``mahalanobis_gate_kernel`` is the numba kernel behind :func:`mahalanobis_gate`
for the trackers' kernels; it assumes valid input and is not public.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np
from scipy import special, stats

from ..core.validation import (as_covariance, as_int, as_measurements, as_nonnegative,
                               as_probability, as_scalar, as_vector, finite_result)
from ..filters.kalman import cholesky_lower_kernel
from ..models.measurement import wrap_angle_kernel

__all__ = [
    "gate_threshold",
    "gate_probability",
    "unit_ball_volume",
    "gate_volume",
    "mahalanobis_gate",
]


def gate_threshold(pg, d):
    """Gate threshold ``gamma`` with ``P(chi2_d <= gamma) = pg``.

    ``pg`` in (0, 1]; ``pg = 1`` gives ``gamma = inf``: no gate, every
    measurement is validated, and the clutter density must be parametric (the
    gate has no finite volume; see the module docstring).

    Examples
    --------
    >>> from trackcore.association import gate_threshold
    >>> round(gate_threshold(0.99, 2), 4)      # 99 % gate in two dimensions
    9.2103
    """
    pg = as_probability(pg, "pg", open_low=True)
    d = as_int(d, "d", minimum=1)
    if pg == 1.0:
        return math.inf
    return float(stats.chi2.ppf(pg, d))


def gate_probability(gamma, d):
    """``P_G = P(chi2_d <= gamma)``, the inverse of :func:`gate_threshold`.

    Examples
    --------
    >>> from trackcore.association import gate_probability, gate_threshold
    >>> round(gate_probability(9.2103, 2), 4)
    0.99
    >>> round(gate_probability(gate_threshold(0.95, 3), 3), 6)
    0.95
    """
    gamma = as_nonnegative(gamma, "gamma") if not (isinstance(gamma, float) and gamma == math.inf) else gamma
    d = as_int(d, "d", minimum=1)
    if gamma == math.inf:
        return 1.0
    return float(special.gammainc(d / 2.0, gamma / 2.0))


def unit_ball_volume(d):
    """``c_d = pi^{d/2} / Gamma(d/2 + 1)`` (2 for d=1, pi for d=2, 4pi/3 for d=3).

    Examples
    --------
    >>> import math
    >>> from trackcore.association import unit_ball_volume
    >>> [round(unit_ball_volume(d), 4) for d in (1, 2, 3)]
    [2.0, 3.1416, 4.1888]
    >>> round(4 * math.pi / 3, 4)
    4.1888
    """
    d = as_int(d, "d", minimum=1)
    return float(math.exp(0.5 * d * math.log(math.pi) - math.lgamma(0.5 * d + 1.0)))


_NO_GATE_VOLUME = ("gamma = inf (pg = 1: no gate) has no finite gate volume; without a gate "
                   "the clutter density must be the parametric lambda "
                   "(pda_betas(..., mode='parametric', clutter_density=lambda)), not m / V")


def gate_volume(gamma, S):
    """Volume ``c_d gamma^{d/2} |S|^{1/2}`` of ``{nu : nu^T S^-1 nu <= gamma}``.

    ``gamma = inf`` (``pg = 1``, no gate) raises ``ValueError``: that gate has no
    finite volume, and the nonparametric clutter density ``m / V`` that would use
    it is undefined (use the parametric density).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import gate_volume
    >>> round(gate_volume(9.0, np.diag([4.0, 1.0])), 3)    # pi * 9 * 2
    56.549
    """
    if as_scalar(gamma, "gamma", finite=False) == math.inf:
        raise ValueError(_NO_GATE_VOLUME)
    gamma = as_nonnegative(gamma, "gamma")
    S = as_covariance(S, "S", strict=True)
    d = S.shape[0]
    if d == 0:
        raise ValueError("S must not be empty")
    sign, logdet = np.linalg.slogdet(S)
    try:
        v = float(unit_ball_volume(d) * gamma ** (0.5 * d) * math.exp(0.5 * logdet))
    except OverflowError:
        v = math.inf
    return finite_result(v, "the gate volume", "gamma and S")


@nb.njit(cache=True)
def mahalanobis_gate_kernel(z, z_pred, L, gamma, angle_index, mask, d2):
    """Squared Mahalanobis distances of the rows of ``z`` (m, d) and the gate
    mask ``d2 <= gamma``; ``L`` is the lower Cholesky factor of ``S``;
    ``angle_index`` < 0 means no angular component (else that component of
    the innovation is wrapped to (-pi, pi]).  Returns the number gated."""
    m, d = z.shape
    y = np.empty(d)
    count = 0
    for j in range(m):
        q = 0.0
        for a in range(d):
            r = z[j, a] - z_pred[a]
            if a == angle_index:
                r = wrap_angle_kernel(r)
            for b in range(a):
                r -= L[a, b] * y[b]
            y[a] = r / L[a, a]
            q += y[a] * y[a]
        d2[j] = q
        ok = q <= gamma
        mask[j] = ok
        if ok:
            count += 1
    return count


def mahalanobis_gate(z, z_pred, S, gamma, angle_index=None):
    """Gate a scan: returns ``(mask (m,) bool, d2 (m,))``.

    ``z``: ``(m, d)`` measurements (``m = 0`` allowed); ``z_pred`` ``(d,)``;
    ``S`` ``(d, d)`` positive definite innovation covariance; ``gamma`` the
    threshold (``>= 0``, ``inf`` accepts all); ``angle_index``: index of an
    angular measurement component whose innovation is wrapped to (-pi, pi].

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import mahalanobis_gate
    >>> z = np.array([[1.0, 0.0], [0.0, 5.0], [2.0, 2.0]])
    >>> mask, d2 = mahalanobis_gate(z, [0.0, 0.0], np.eye(2), gamma=9.21)
    >>> print(mask, d2)
    [ True False  True] [ 1. 25.  8.]
    """
    z_pred = as_vector(z_pred, "z_pred")
    d = z_pred.shape[0]
    if d == 0:
        raise ValueError("z_pred must not be empty")
    z = as_measurements(z, "z", d)
    S = as_covariance(S, "S", d, strict=True)
    if not (isinstance(gamma, float) and gamma == math.inf):
        gamma = as_nonnegative(gamma, "gamma")
    if angle_index is None:
        ai = -1
    else:
        ai = as_int(angle_index, "angle_index")
        if not -d <= ai < d:
            raise ValueError(f"angle_index must index one of the {d} components, got {ai}")
        ai %= d
    L = np.zeros((d, d))
    if not cholesky_lower_kernel(S, L):
        raise ValueError("S must be positive definite")
    m = z.shape[0]
    mask = np.zeros(m, dtype=np.bool_)
    d2 = np.empty(m)
    mahalanobis_gate_kernel(z, z_pred, L, float(gamma), ai, mask, d2)
    finite_result(d2, "the squared Mahalanobis distance", "z, z_pred and S")
    return mask, d2
