"""Valid distance-only existence updates: the nearest-neighbour likelihood and IPDA.

Both are likelihood ratios ``L = P(data | target exists) / P(data | no target)`` of the
data the filter actually uses, so that on clutter alone ``E[L] = 1`` and the existence
update ``p = L p^- / (1 - p^- + L p^-)`` is Bayes' rule.  Written as
``delta = 1 - L`` they plug into the same update as HPDA's eq (19),
``p = (1 - delta) p^- / (1 - delta p^-)``.

Model: in a gate of volume ``V_G`` and probability ``P_G`` around ``z_hat`` (innovation
covariance ``S``), clutter is Poisson with density ``lambda`` (in the units of the
measurement space of ``N``), the target is detected with probability ``P_D`` at
density ``N(z; z_hat, S)``.

* **Nearest neighbour (NN likelihood).**  The filter keeps only the nearest gated return
  (squared normalised distance ``d^2``).  The nearest return lies at ``z`` when a return
  lies there and none lies closer.  With the region closer than ``d`` of volume
  ``V(d)``, no clutter closer has probability ``exp(-lambda V(d))`` under both
  hypotheses, and with a target the target must also not lie closer, probability
  ``1 - P_D (1 - exp(-d^2 / 2))`` (the mass of a 2-D Gaussian within ``d`` is
  ``1 - exp(-d^2/2)``).  Hence

      L_NN = 1 - P_D (1 - exp(-d^2/2)) + P_D N(z; z_hat, S) / lambda,   m >= 1
      L_NN = 1 - P_D P_G,                                             m = 0

  and the probability that the nearest return is the target, given that it exists, is
  ``beta = P_D N / (lambda L_NN)``.  HPDA's eq (19) evaluated at the nearest return's
  amplitude rank is the ratio for a rank fixed before the data, not for a return chosen
  by its distance, and its mean on clutter exceeds 1.
* **IPDA** (integrated PDA, Musicki, Evans and Stankovic): every gated return is used,

      L_IPDA = 1 - P_D P_G + P_D sum_j N(z_j; z_hat, S) / lambda,

  with the PDA weights ``beta_j = P_D N_j / (lambda L_IPDA)`` and
  ``beta_0 = (1 - P_D P_G) / L_IPDA``.  For one return this is HPDA's own update.

The ``*_kernel`` functions are numba-callable (the HPDA-PF tracker's ``"nn-likelihood"``
and ``"ipda"`` selection rules use them); the public functions validate their inputs.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import as_array, as_count, as_nonnegative, as_positive, as_probability

__all__ = ["ipda_existence_delta", "nn_existence_delta"]


@nb.njit(cache=True)
def nn_existence_kernel(d2, normal_density, pd, clutter_density):
    """``(delta, beta)`` of the nearest-neighbour likelihood for a nearest return at
    squared normalised distance ``d2`` with ``normal_density = N(z; z_hat, S)``."""
    miss = 1.0 - pd * (1.0 - math.exp(-0.5 * d2))
    target = pd * normal_density / clutter_density
    lr = miss + target
    return 1.0 - lr, target / lr


@nb.njit(cache=True)
def ipda_existence_kernel(sum_normal, pd, pg, clutter_density):
    """``delta`` of IPDA: ``P_D P_G - P_D sum_j N_j / lambda``."""
    return pd * pg - pd * sum_normal / clutter_density


def nn_existence_delta(m, d2, normal_density, pd, pg, clutter_density):
    """``delta = 1 - L_NN`` for ``m`` gated returns whose nearest lies at squared
    normalised distance ``d2`` with ``normal_density = N(z; z_hat, S)`` (not divided by
    ``P_G``); ``m = 0`` gives ``P_D P_G`` (``d2`` and ``normal_density`` ignored).
    ``clutter_density`` lambda in the units of ``N``'s measurement space.

    Examples
    --------
    With no gated return, ``delta = P_D P_G``; a return close to the prediction
    (density well above the clutter density) gives a large negative ``delta``
    (existence goes up), a far one a ``delta`` near 0:

    >>> nn_existence_delta(0, 0.0, 0.0, pd=0.9, pg=0.99, clutter_density=1e-3)
    0.891
    >>> round(nn_existence_delta(1, 1.0, 0.1, pd=0.9, pg=0.99, clutter_density=1e-3), 3)
    -89.646
    >>> round(nn_existence_delta(1, 9.0, 0.001, pd=0.9, pg=0.99, clutter_density=1e-3), 4)
    -0.01
    """
    m = as_count(m, "m")
    pd = as_probability(pd, "pd")
    pg = as_probability(pg, "pg")
    lam = as_positive(clutter_density, "clutter_density")
    if m == 0:
        return pd * pg
    d2 = as_nonnegative(d2, "d2")
    nd = as_nonnegative(normal_density, "normal_density")
    return float(nn_existence_kernel(d2, nd, pd, lam)[0])


def ipda_existence_delta(normal_densities, pd, pg, clutter_density):
    """``delta = 1 - L_IPDA = P_D P_G - P_D sum_j N_j / lambda`` for the gated returns'
    ``normal_densities`` ``N(z_j; z_hat, S)`` (1-D, possibly empty).

    Examples
    --------
    Every gated return counts; an empty gate gives ``P_D P_G``:

    >>> ipda_existence_delta([], pd=0.9, pg=0.99, clutter_density=1e-3)
    0.891
    >>> round(ipda_existence_delta([0.1, 0.001], pd=0.9, pg=0.99, clutter_density=1e-3), 3)
    -90.009
    >>> ipda_existence_delta([-0.1], pd=0.9, pg=0.99, clutter_density=1e-3)
    Traceback (most recent call last):
        ...
    ValueError: normal_densities must be non-negative
    """
    nd = as_array(normal_densities, "normal_densities", ndim=1)
    if nd.size and nd.min() < 0:
        raise ValueError("normal_densities must be non-negative")
    pd = as_probability(pd, "pd")
    pg = as_probability(pg, "pg")
    lam = as_positive(clutter_density, "clutter_density")
    return float(ipda_existence_kernel(float(np.sum(nd)), pd, pg, lam))
