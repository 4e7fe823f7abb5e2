"""Highest Probability Data Association (HPDA): amplitude-rank probabilities,
association probabilities and track existence (Kim & Song 2007, eqs 6-19).

Model.  Validated clutter amplitudes are ``tau + Exp(1)`` and detected target
amplitudes ``tau + Exp(1 + rho)``; ``P_D = exp(-tau c)`` with
``c = 1 / (1 + rho)``.  The number of validated false measurements in the gate
is Poisson with mean ``clutter_mean = lambda V_G``; the target falls in the
gate with probability ``P_G``.  With ``m`` validated measurements ranked by
amplitude (``l = 1`` strongest) the probability that the target is the
``l``-th strongest, given that it was detected and there are ``m - 1`` clutter
returns, is (the chapter's order-statistics page derives it)

    q(l, m) = c C(m-1, l-1) B(l-1+c, m-l+1)
            = c Gamma(m) Gamma(l-1+c) / (Gamma(l) Gamma(m+c)),

so ``q(1, m) = Pbar_A(m)`` and ``q(l, m) = gamma(l) Pbar_A(m)`` for every
``1 <= l <= m`` (errata E10/E11: no special ``l = m`` branch).  The joint
probabilities are

    P(M_T^l, m) = P_D P_G mu_F(m-1) q(l, m)                       (12)
    P(m)        = (1 - P_D P_G) mu_F(m) + P_D P_G mu_F(m-1)       (11)
    P(M_F^l, m) = P(m) - P(M_T^l, m)                              (10)

Everything is evaluated with log-gamma (E12: the printed alternating sum for
``Pbar_A`` cancels catastrophically; :func:`pa_bar_alternating` keeps the
printed form so the book can show it failing).

Densities (made explicit here; the paper leaves them implicit): at the *track* level (14), (19)
the target density is ``f_T(z) = N(z; z_hat, S) / P_G`` (gate-truncated) and
clutter is ``1 / V_G``; at the *particle* level (13) the target density is
``N(z; h(x_i), R)``.  ``clutter_density`` (lambda) is in the units of the
measurement space of ``N`` (per m rad for range-bearing).
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..models.measurement import wrap_angle_kernel
from ..core.validation import (as_array, as_count, as_rng, as_nonnegative, as_positive,
                               as_probability, as_scalar)


@nb.njit(cache=True)
def _wrap_near(a):
    """:func:`~trackcore.models.measurement.wrap_angle_kernel` bit for bit, without its
    division for ``|a| <= 3``: there ``ceil((a - pi) / 2 pi)`` is 0 and the kernel returns
    ``a - 0.0``, which is ``a`` (signed zeros included).  For the HPDA kernels' inner
    loops, whose bearing differences are almost always small."""
    if -3.0 <= a <= 3.0:
        return a
    return wrap_angle_kernel(a)

__all__ = [
    "hpda_rank_probabilities",
    "hpda_false_rank_probabilities",
    "hpda_log_rank_probabilities",
    "hpda_measurement_count_probability",
    "hpda_conditional_rank_probabilities",
    "hpda_rank_probabilities_printed",
    "rank_probability_q",
    "pa_bar",
    "pa_bar_alternating",
    "rank_gamma",
    "hpda_betas",
    "hpda_select",
    "hpda_mixture_loglik",
    "existence_predict",
    "hpda_existence_delta",
    "existence_update",
    "simulate_hpda_ranks",
    "simulate_existence_posterior",
]


# --------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------
def _common(m, snr, tau, pg, clutter_mean):
    m = as_count(m, "m")
    snr = as_nonnegative(snr, "snr")
    tau = as_nonnegative(tau, "tau")
    pg = as_probability(pg, "pg")
    lam = as_nonnegative(clutter_mean, "clutter_mean")
    c = 1.0 / (1.0 + snr)
    pd = math.exp(-tau * c)
    return m, c, pd, pg, lam


# --------------------------------------------------------------------------
# kernels (numba; assume valid input)
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def _log_poisson(k, mean):
    """log Poisson(k; mean); -inf for k < 0; mean = 0 handled exactly."""
    if k < 0:
        return -np.inf
    if mean == 0.0:
        return 0.0 if k == 0 else -np.inf
    return k * math.log(mean) - mean - math.lgamma(k + 1.0)


@nb.njit(cache=True)
def _log_q(l, m, c):
    """log q(l, m) = log c + lgamma(m) + lgamma(l-1+c) - lgamma(l) - lgamma(m+c)."""
    return (math.log(c) + math.lgamma(m) + math.lgamma(l - 1.0 + c)
            - math.lgamma(l) - math.lgamma(m + c))


rank_log_q_kernel = _log_q
"""Numba kernel ``log q(l, m)`` for float ``l``, ``m`` and ``c = 1/(1+snr)``."""


@nb.njit(cache=True)
def hpda_rank_probabilities_kernel(m, c, pd, pg, clutter_mean, log_pt, log_pf):
    """Log joint probabilities ``log P(M_T^l, m)`` and ``log P(M_F^l, m)``,
    ``l = 1..m``, into ``log_pt``, ``log_pf`` (length >= m); returns ``log P(m)``.

    ``c = 1/(1+snr)``; ``pd = exp(-tau c)``.
    """
    pdpg = pd * pg
    lmu_m = _log_poisson(m, clutter_mean)
    lmu_m1 = _log_poisson(m - 1, clutter_mean)
    # log P(m) = log[(1 - pdpg) mu(m) + pdpg mu(m-1)]
    a = math.log(1.0 - pdpg) + lmu_m if pdpg < 1.0 else -np.inf
    b = math.log(pdpg) + lmu_m1 if pdpg > 0.0 else -np.inf
    hi = max(a, b)
    if hi == -np.inf:
        log_pm = -np.inf
    else:
        log_pm = hi + math.log(math.exp(a - hi) + math.exp(b - hi))
    for l in range(1, m + 1):
        lq = _log_q(l, m, c)
        log_pt[l - 1] = b + lq
        # P_F = (1-pdpg) mu(m) + pdpg mu(m-1) (1 - q); 1 - q >= 0 exactly at q = 1
        one_m_q = -math.expm1(lq)
        bf = b + math.log(one_m_q) if one_m_q > 0.0 else -np.inf
        hi2 = max(a, bf)
        if hi2 == -np.inf:
            log_pf[l - 1] = -np.inf
        else:
            log_pf[l - 1] = hi2 + math.log(math.exp(a - hi2) + math.exp(bf - hi2))
    return log_pm


@nb.njit(cache=True)
def hpda_conditional_rank_kernel(m, c, pdpg, clutter_mean, pt, pf):
    """Conditional probabilities ``P(M_T^l | m)`` and ``P(M_F^l | m)`` into
    ``pt``, ``pf`` (length >= m), in the form that never under- or overflows:
    with ``r = m / clutter_mean = mu_F(m-1)/mu_F(m)``,

        P(M_T^l | m) = pdpg m q_l / [(1 - pdpg) clutter_mean + pdpg m].

    ``q_1`` comes from log-gamma functions and ``q_{l+1} = q_l (l - 1 + c) / l``
    (the ratio of the Beta forms), so a call costs three log-gamma evaluations.
    Returns False when ``P(m) = 0`` (impossible scan: ``m >= 1`` with no
    clutter and no detection possible, or ``m >= 2`` without clutter).
    """
    if m == 0:
        return True
    return _conditional_rank_from_q1(m, math.exp(_log_q(1.0, float(m), c)), c, pdpg,
                                     clutter_mean, pt, pf)


@nb.njit(cache=True)
def _conditional_rank_from_q1(m, q, c, pdpg, clutter_mean, pt, pf):
    """:func:`hpda_conditional_rank_kernel` for ``m >= 1`` given ``q = q_1 =
    exp(log q(1, m))`` (a caller that sees the same ``m`` and ``c`` often keeps it)."""
    if clutter_mean == 0.0 and m >= 2:
        return False
    den = (1.0 - pdpg) * clutter_mean + pdpg * m
    if den <= 0.0:
        return False
    for l in range(1, m + 1):
        pt[l - 1] = pdpg * m * q / den
        pf[l - 1] = ((1.0 - pdpg) * clutter_mean + pdpg * m * (1.0 - q)) / den
        q *= (l - 1.0 + c) / l
    return True


@nb.njit(cache=True)
def hpda_existence_delta_kernel(m, q_s, pd, pg, clutter_density, gate_volume, normal_density):
    """delta_k of eq (19): ``pd pg - m/(lambda V_G) pd pg (1 - q_s)
    - m/lambda pd N(z^s; z_hat, S) q_s``; ``pd pg`` when ``m = 0``."""
    pdpg = pd * pg
    if m == 0:
        return pdpg
    return (pdpg - m / (clutter_density * gate_volume) * pdpg * (1.0 - q_s)
            - m / clutter_density * pd * normal_density * q_s)


@nb.njit(cache=True)
def _mixture_kernel(loglik, log_a, log_b, out):
    """out[i] = log(exp(loglik[i] + log_a) + exp(log_b))."""
    for i in range(loglik.shape[0]):
        u = loglik[i] + log_a
        hi = max(u, log_b)
        if hi == -np.inf:
            out[i] = -np.inf
        else:
            out[i] = hi + math.log(math.exp(u - hi) + math.exp(log_b - hi))


@nb.njit(cache=True)
def hpda_mixture_loglik_kernel(particles, z, Rinv, logdetR, sx, sy, log_pt, log_pf_vg, out):
    """Eq (13) per particle, up to the constant ``-log P(m)``:
    ``out[i] = log[N(z; h(x_i), R) P_T + P_F / V_G]`` with ``log_pt = log P_T``
    and ``log_pf_vg = log(P_F / V_G)`` (conditional or joint, as long as both
    use the same normaliser).  ``out`` is overwritten.  Range-bearing ``h``
    from the sensor at ``(sx, sy)``, bearing innovation wrapped."""
    c = -1.8378770664093453 - 0.5 * logdetR
    for i in range(particles.shape[0]):
        dx = particles[i, 0] - sx
        dy = particles[i, 1] - sy
        out[i] = _mixture_loglik_polar(math.sqrt(dx * dx + dy * dy), math.atan2(dy, dx), z,
                                       Rinv, c, log_pt, log_pf_vg)


@nb.njit(cache=True)
def _mixture_loglik_polar(rng_i, brg_i, z, Rinv, c, log_pt, log_pf_vg):
    """One particle's term of :func:`hpda_mixture_loglik_kernel` from its range
    ``rng_i`` and bearing ``brg_i`` (``c = -log(2 pi) - log|R| / 2``)."""
    r0 = z[0] - rng_i
    r1 = _wrap_near(z[1] - brg_i)
    ll = c - 0.5 * (Rinv[0, 0] * r0 * r0 + 2.0 * Rinv[0, 1] * r0 * r1
                    + Rinv[1, 1] * r1 * r1)
    if math.isnan(ll):
        # an infinite innovation (a particle or sensor beyond double range; inputs are
        # finite) times a zero cross term: the Gaussian term is 0
        ll = -np.inf
    u = ll + log_pt
    hi = max(u, log_pf_vg)
    if hi == -np.inf:
        return -np.inf
    # log(exp(u - hi) + exp(log_pf_vg - hi)): the larger term is exp(0) = 1 exactly
    lo = u if hi == log_pf_vg else log_pf_vg
    return hi + math.log(1.0 + math.exp(lo - hi))


# --------------------------------------------------------------------------
# public API: rank probabilities
# --------------------------------------------------------------------------
def hpda_log_rank_probabilities(m, snr, tau, pg, clutter_mean):
    """``(log P(M_T^l, m), log P(M_F^l, m), log P(m))`` for ``l = 1..m``.

    Stable for any ``m`` (log-gamma throughout); use this when ``mu_F``
    underflows (e.g. ``m = 500`` with ``clutter_mean = 1``).

    Examples
    --------
    The logarithms stay finite where the probabilities themselves underflow:

    >>> lt, lf, lm = hpda_log_rank_probabilities(3, snr=10.0, tau=2.0, pg=0.99, clutter_mean=1.0)
    >>> np.round(np.exp(lt), 4), round(float(np.exp(lm)), 4)
    (array([0.1331, 0.0121, 0.0066]), 0.1625)
    >>> lt, lf, lm = hpda_log_rank_probabilities(500, snr=10.0, tau=2.0, pg=0.99, clutter_mean=1.0)
    >>> np.round(lt[:2], 1), round(float(lm), 1)
    (array([-2606.9, -2609.3]), -2606.3)
    """
    m, c, pd, pg, lam = _common(m, snr, tau, pg, clutter_mean)
    lpt = np.empty(m)
    lpf = np.empty(m)
    lpm = hpda_rank_probabilities_kernel(m, c, pd, pg, lam, lpt, lpf)
    return lpt, lpf, float(lpm)


def hpda_rank_probabilities(m, snr, tau, pg, clutter_mean):
    """Joint probabilities ``P(M_T^l, m)``, ``l = 1..m`` (eq 12, corrected by E10/E11).

    ``snr`` is the linear mean SNR rho, ``tau`` the amplitude threshold
    (``P_D = exp(-tau/(1+snr))``), ``pg`` the gate probability and
    ``clutter_mean = lambda V_G`` the Poisson mean of validated false
    measurements in the gate.  Returns an array of length ``m`` (empty for
    ``m = 0``).  Values below ~1e-308 underflow to 0; see
    :func:`hpda_log_rank_probabilities` for the logarithms.

    Examples
    --------
    Three validated returns at a mean SNR of 10 (linear): the target is most likely
    the strongest of them:

    >>> np.round(hpda_rank_probabilities(3, snr=10.0, tau=2.0, pg=0.99, clutter_mean=1.0), 4)
    array([0.1331, 0.0121, 0.0066])
    >>> hpda_rank_probabilities(0, snr=10.0, tau=2.0, pg=0.99, clutter_mean=1.0)
    array([], dtype=float64)
    """
    lpt, _, _ = hpda_log_rank_probabilities(m, snr, tau, pg, clutter_mean)
    return np.exp(lpt)


def hpda_false_rank_probabilities(m, snr, tau, pg, clutter_mean):
    """Joint probabilities ``P(M_F^l, m)``, ``l = 1..m`` (eq 10).

    Examples
    --------
    For every rank, true plus false is the probability of ``m`` (eq 10):

    >>> pf = hpda_false_rank_probabilities(3, snr=10.0, tau=2.0, pg=0.99, clutter_mean=1.0)
    >>> pt = hpda_rank_probabilities(3, snr=10.0, tau=2.0, pg=0.99, clutter_mean=1.0)
    >>> np.round(pf, 4), np.round(pt + pf, 4)
    (array([0.0294, 0.1504, 0.1559]), array([0.1625, 0.1625, 0.1625]))
    """
    _, lpf, _ = hpda_log_rank_probabilities(m, snr, tau, pg, clutter_mean)
    return np.exp(lpf)


def hpda_measurement_count_probability(m, snr, tau, pg, clutter_mean):
    """``P(m) = (1 - P_D P_G) mu_F(m) + P_D P_G mu_F(m-1)`` (eq 11).

    Examples
    --------
    >>> round(hpda_measurement_count_probability(3, snr=10.0, tau=2.0, pg=0.99,
    ...                                          clutter_mean=1.0), 4)
    0.1625
    >>> sum(hpda_measurement_count_probability(m, 10.0, 2.0, 0.99, 1.0) for m in range(40))
    1.0...
    """
    m, c, pd, pg, lam = _common(m, snr, tau, pg, clutter_mean)
    lpm = hpda_rank_probabilities_kernel(m, c, pd, pg, lam, np.empty(m), np.empty(m))
    return float(math.exp(lpm))


def hpda_conditional_rank_probabilities(m, snr, tau, pg, clutter_mean):
    """``(P(M_T^l | m), P(M_F^l | m))``, ``l = 1..m``: the joint probabilities
    divided by ``P(m)``, computed without forming ``mu_F`` (never underflows).

    Raises ``ValueError`` when ``P(m) = 0`` (e.g. ``m >= 2`` with
    ``clutter_mean = 0``).

    Examples
    --------
    Given three returns, the strongest is the target's with probability 0.82:

    >>> pt, pf = hpda_conditional_rank_probabilities(3, snr=10.0, tau=2.0, pg=0.99,
    ...                                              clutter_mean=1.0)
    >>> np.round(pt, 4), np.round(pt + pf, 4)
    (array([0.8191, 0.0745, 0.0406]), array([1., 1., 1.]))
    >>> hpda_conditional_rank_probabilities(2, snr=10.0, tau=2.0, pg=0.99, clutter_mean=0.0)
    Traceback (most recent call last):
        ...
    ValueError: m = 2 measurements has probability 0 under clutter_mean = 0.0 and P_D P_G = 0.82...
    """
    m, c, pd, pg, lam = _common(m, snr, tau, pg, clutter_mean)
    pt = np.empty(m)
    pf = np.empty(m)
    if not hpda_conditional_rank_kernel(m, c, pd * pg, lam, pt, pf):
        raise ValueError(f"m = {m} measurements has probability 0 under clutter_mean = {lam} "
                         f"and P_D P_G = {pd * pg}")
    return pt, pf


def rank_probability_q(l, m, snr):
    """``q(l, m) = gamma(l) Pbar_A(m)``: probability that a detected target is the
    ``l``-th strongest among itself and ``m - 1`` clutter returns (Beta form).

    ``l`` may be an integer array; all entries must satisfy ``1 <= l <= m``.

    Examples
    --------
    The ranks of a detected target among three returns (they sum to 1):

    >>> q = rank_probability_q(np.arange(1, 4), 3, snr=10.0)
    >>> np.round(q, 4), round(float(q.sum()), 6)
    (array([0.8768, 0.0797, 0.0435]), 1.0)
    >>> rank_probability_q(4, 3, snr=10.0)
    Traceback (most recent call last):
        ...
    ValueError: l must lie in [1, m] = [1, 3]
    """
    m = as_count(m, "m")
    snr = as_nonnegative(snr, "snr")
    larr = np.asarray(l)
    if larr.dtype.kind not in "iu" and not (larr.dtype.kind == "f"
                                            and np.all(np.floor(larr) == larr)):
        raise TypeError(f"l must hold integers, got dtype {larr.dtype}")
    larr = larr.astype(np.float64)
    if larr.size and (larr.min() < 1 or larr.max() > m):
        raise ValueError(f"l must lie in [1, m] = [1, {m}]")
    c = 1.0 / (1.0 + snr)
    from scipy.special import gammaln
    lq = (math.log(c) + gammaln(m) + gammaln(larr - 1.0 + c) - gammaln(larr) - gammaln(m + c))
    out = np.exp(lq)
    return float(out) if out.ndim == 0 else out


def pa_bar(m, snr):
    """``Pbar_A(m) = Gamma(m) Gamma(1+c) / Gamma(m+c)`` (stable form of eq 10's sum).

    Examples
    --------
    The probability that a detected target is the strongest of ``m`` returns:

    >>> round(float(pa_bar(2, snr=10.0)), 4)  # 1 / (1 + c) with c = 1/11
    0.9167
    >>> round(float(pa_bar(70, snr=5.0)), 3)
    0.457
    """
    m = _as_int_ge1(m)
    return rank_probability_q(1, m, snr)


def _as_int_ge1(m):
    m = as_count(m, "m")
    if m < 1:
        raise ValueError(f"m must be >= 1, got {m}")
    return m


def pa_bar_alternating(m, snr):
    """``Pbar_A(m)`` by the **printed** alternating sum
    ``sum_{i=0}^{m-1} (-1)^i C(m-1, i) / ((i+1) + i rho)`` in float64.

    Kept to demonstrate catastrophic cancellation (erratum E12): at
    ``rho = 5`` it returns about 10.7 for ``m = 70`` although the true value is
    0.457.  Do not use it for computation.

    Examples
    --------
    Right for small ``m``, wrong by cancellation for large ``m`` (the true value is 0.457):

    >>> round(float(pa_bar_alternating(5, snr=5.0)), 4), round(float(pa_bar(5, snr=5.0)), 4)
    (0.7196, 0.7196)
    >>> round(float(pa_bar_alternating(70, snr=5.0)), 1)
    10.7
    """
    m = _as_int_ge1(m)
    rho = as_nonnegative(snr, "snr")
    s = 0.0
    for i in range(m):
        s += (-1.0) ** i * math.comb(m - 1, i) / ((i + 1.0) + i * rho)
    return s


def rank_gamma(l, snr):
    """``gamma(l) = prod_{j=1}^{l-1} [(j-1)(1+rho)+1] / ((l-1)! (1+rho)^{l-1})
    = Gamma(l-1+c) / (Gamma(c) Gamma(l))`` (eq 10), via log-gamma.

    Examples
    --------
    ``gamma(1) = 1``, and ``q(l, m) = gamma(l) Pbar_A(m)``:

    >>> [round(float(rank_gamma(l, snr=10.0)), 4) for l in (1, 2, 3)]
    [1.0, 0.0909, 0.0496]
    >>> g2, q2 = rank_gamma(2, 10.0) * pa_bar(3, 10.0), rank_probability_q(2, 3, 10.0)
    >>> round(float(g2), 4), round(float(q2), 4)
    (0.0797, 0.0797)
    """
    snr = as_nonnegative(snr, "snr")
    l = _as_int_ge1(l)
    c = 1.0 / (1.0 + snr)
    return math.exp(math.lgamma(l - 1.0 + c) - math.lgamma(c) - math.lgamma(l))


def hpda_rank_probabilities_printed(m, snr, tau, pg, clutter_mean):
    """Eq (12) **exactly as printed**: ``P_D P_G gamma(l) Pbar_A(m) mu_F(m-1)``
    for ``l < m`` with the alternating-sum ``Pbar_A`` and the product form of
    ``gamma``, and the printed ``l = m`` branch
    ``mu_F(m-1) / (P_D P_G m + (m-1) rho)`` (erratum E10: wrong).

    For demonstration only (notebook 02).

    Examples
    --------
    The printed ``l = m`` branch differs from eq (12) (erratum E10):

    >>> np.round(hpda_rank_probabilities_printed(3, snr=10.0, tau=2.0, pg=0.99,
    ...                                          clutter_mean=1.0), 4)
    array([0.1331, 0.0121, 0.0082])
    >>> np.round(hpda_rank_probabilities(3, snr=10.0, tau=2.0, pg=0.99, clutter_mean=1.0), 4)
    array([0.1331, 0.0121, 0.0066])
    """
    m, c, pd, pg, lam = _common(m, snr, tau, pg, clutter_mean)
    rho = 1.0 / c - 1.0
    if m == 0:
        return np.zeros(0)
    mu1 = math.exp(_log_poisson(m - 1, lam))
    pa = pa_bar_alternating(m, rho)
    out = np.empty(m)
    for l in range(1, m):
        g = 1.0
        for j in range(1, l):
            g *= ((j - 1) * (1 + rho) + 1) / (j * (1 + rho))
        out[l - 1] = pd * pg * g * pa * mu1
    out[m - 1] = mu1 / (pd * pg * m + (m - 1) * rho)
    return out


# --------------------------------------------------------------------------
# association (14), (15) and the particle likelihood (13)
# --------------------------------------------------------------------------
def hpda_betas(target_density, p_target, p_false, gate_volume):
    """Association probabilities beta^l of eq (14), ``l = 1..m`` in rank order.

    ``target_density[l]`` is ``f_T(z^l) = N(z^l; z_hat, S) / P_G`` (track
    level), ``p_target``/``p_false`` the rank probabilities ``P(M_T^l, m)``,
    ``P(M_F^l, m)`` (joint or conditional on ``m``, the ratio is the same), and
    ``gate_volume`` V_G.  Each beta^l is the posterior probability that the
    ``l``-th strongest measurement is the target's, given its rank and
    position only.

    Examples
    --------
    Two returns in a gate of volume 20: the strongest lies at a lower target density
    but its rank makes it the likelier origin:

    >>> pt, pf = hpda_conditional_rank_probabilities(2, snr=10.0, tau=2.0, pg=0.99,
    ...                                              clutter_mean=1.0)
    >>> betas = hpda_betas([0.05, 0.2], pt, pf, gate_volume=20.0)
    >>> np.round(betas, 4)
    array([0.829 , 0.2459])
    >>> hpda_select(betas)
    0
    """
    f = as_array(target_density, "target_density", ndim=1)
    m = f.shape[0]
    pt = as_array(p_target, "p_target", shape=(m,))
    pf = as_array(p_false, "p_false", shape=(m,))
    vg = as_positive(gate_volume, "gate_volume")
    if m and (f.min() < 0):
        raise ValueError("target_density must be >= 0")
    for arr, name in ((pt, "p_target"), (pf, "p_false")):
        if m and (arr.min() < 0 or arr.max() > 1):
            raise ValueError(f"{name} must hold probabilities in [0, 1]")
    num = f * pt
    den = num + pf / vg
    with np.errstate(invalid="ignore", divide="ignore"):
        beta = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return beta


def hpda_select(betas):
    """Index ``s`` (0-based rank) of the highest beta (eq 15); -1 for ``m = 0``.

    Ties go to the stronger measurement (smaller rank).

    Examples
    --------
    >>> hpda_select([0.2, 0.7, 0.7])  # a tie goes to the stronger return
    1
    >>> hpda_select([])  # no validated measurement
    -1
    """
    b = as_array(betas, "betas", ndim=1)
    if b.size == 0:
        return -1
    return int(np.argmax(b))


def hpda_mixture_loglik(particles, z, R, p_target, p_false, gate_volume, sensor=(0.0, 0.0)):
    """Particle log-likelihoods of eq (13) for the selected measurement ``z = z^s``:

        log p(z | x_i, m) = log[N(z; h(x_i), R) P(M_T^s|m) + P(M_F^s|m) / V_G]

    with range-bearing ``h`` (bearing innovation wrapped).  ``p_target`` and
    ``p_false`` are the probabilities *conditional on m* (e.g. from
    :func:`hpda_conditional_rank_probabilities`), so the result is the
    normalised likelihood of (13).  Returns ``(N,)``.

    Examples
    --------
    Range-bearing ``z = (1000 m, 0 rad)`` seen from the origin; particles are
    ``[x, y, ...]`` rows.  A particle far from ``z`` keeps the clutter floor
    ``log(P_F / V_G) = log(0.2 / 20)``:

    >>> X = np.array([[1000.0, 0.0, 0.0, 0.0], [1010.0, 0.0, 0.0, 0.0], [1100.0, 0.0, 0.0, 0.0]])
    >>> R = np.diag([10.0**2, 0.01**2])
    >>> ll = hpda_mixture_loglik(X, [1000.0, 0.0], R, p_target=0.8, p_false=0.2, gate_volume=20.0)
    >>> np.round(ll, 3)
    array([ 0.249, -0.246, -4.605])
    >>> round(float(np.log(0.2 / 20.0)), 3)
    -4.605
    """
    X = as_array(particles, "particles", ndim=2)
    if X.shape[1] < 2:
        raise ValueError(f"particles must have at least 2 columns, got {X.shape}")
    z = as_array(z, "z", shape=(2,))
    R = as_array(R, "R", shape=(2, 2))
    if R[0, 1] != R[1, 0]:
        raise ValueError(f"R must be symmetric, got R[0, 1] = {R[0, 1]} and "
                         f"R[1, 0] = {R[1, 0]}")
    pt = as_probability(p_target, "p_target")
    pf = as_probability(p_false, "p_false")
    vg = as_positive(gate_volume, "gate_volume")
    try:
        L = np.linalg.cholesky(R)
    except np.linalg.LinAlgError:
        raise ValueError("R must be positive definite") from None
    Rinv = np.ascontiguousarray(np.linalg.inv(R))
    logdet = float(2.0 * np.sum(np.log(np.diag(L))))
    s = as_array(sensor, "sensor", shape=(2,))
    lpt = math.log(pt) if pt > 0 else -np.inf
    lpf = math.log(pf / vg) if pf > 0 else -np.inf
    out = np.empty(X.shape[0])
    hpda_mixture_loglik_kernel(X, z, Rinv, logdet, float(s[0]), float(s[1]), lpt, lpf, out)
    return out


# --------------------------------------------------------------------------
# existence (16)-(19)
# --------------------------------------------------------------------------
def existence_predict(p, pi11, pi12=0.0):
    """Eq (17) corrected (E13): ``P(H_k|Z^{k-1}) = Pi11 p + Pi12 (1 - p)``.

    Examples
    --------
    >>> existence_predict(0.5, pi11=0.98)
    0.49
    >>> existence_predict(0.5, pi11=0.98, pi12=0.01)  # births from the no-target state
    0.495
    """
    p = as_probability(p, "p")
    pi11 = as_probability(pi11, "pi11")
    pi12 = as_probability(pi12, "pi12")
    return pi11 * p + pi12 * (1.0 - p)


def hpda_existence_delta(m, s, normal_density, snr, tau, pg, clutter_density, gate_volume):
    """delta_k of eq (19) for ``m`` validated measurements, selected rank ``s``
    (1-based, ``1 <= s <= m``; ignored when ``m = 0``), ``normal_density =
    N(z^s; z_hat, S)`` (*not* divided by P_G), lambda = ``clutter_density``
    in measurement-space units and ``gate_volume`` V_G.  ``m = 0`` gives
    ``P_D P_G`` (the IPDA miss update).

    Examples
    --------
    An empty gate gives ``P_D P_G``; one return near the prediction, whose density exceeds
    the clutter density, gives ``delta < 0`` (existence goes up):

    >>> round(hpda_existence_delta(0, 0, 0.0, snr=10.0, tau=2.0, pg=0.99,
    ...                            clutter_density=0.05, gate_volume=20.0), 4)
    0.8254
    >>> round(hpda_existence_delta(2, 1, 0.05, snr=10.0, tau=2.0, pg=0.99,
    ...                            clutter_density=0.05, gate_volume=20.0), 4)
    -0.8407
    """
    m = as_count(m, "m")
    snr = as_nonnegative(snr, "snr")
    tau = as_nonnegative(tau, "tau")
    pg = as_probability(pg, "pg")
    pd = math.exp(-tau / (1.0 + snr))
    if m == 0:
        return pd * pg
    s = as_count(s, "s")
    if not 1 <= s <= m:
        raise ValueError(f"s must lie in [1, m] = [1, {m}], got {s}")
    nd = as_nonnegative(normal_density, "normal_density")
    lam = as_positive(clutter_density, "clutter_density")
    vg = as_positive(gate_volume, "gate_volume")
    q = math.exp(_log_q(float(s), float(m), 1.0 / (1.0 + snr)))
    return float(hpda_existence_delta_kernel(m, q, pd, pg, lam, vg, nd))


def existence_update(p_pred, delta):
    """Eq (19): ``(1 - delta) p / (1 - delta p)`` with ``p = P(H_k|Z^{k-1})``.

    Examples
    --------
    ``delta < 0`` raises the existence probability, ``delta > 0`` lowers it:

    >>> round(existence_update(0.5, -0.8407), 4)
    0.648
    >>> round(existence_update(0.5, 0.8254), 4)
    0.1486
    >>> existence_update(0.5, 1.5)
    Traceback (most recent call last):
        ...
    ValueError: delta must be <= 1, got 1.5
    """
    p = as_probability(p_pred, "p_pred")
    d = as_scalar(delta, "delta")
    if d > 1.0:
        raise ValueError(f"delta must be <= 1, got {d}")
    den = 1.0 - d * p
    if den <= 0.0:
        return 1.0
    return min(1.0, max(0.0, (1.0 - d) * p / den))


# --------------------------------------------------------------------------
# first-principles Monte Carlo of the amplitude ranks (for verification)
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def _simulate_ranks_kernel(rng, n_draws, snr, tau, pg, clutter_mean, counts):
    m_max = counts.shape[0] - 1
    for _ in range(n_draws):
        present = rng.random() < pg
        at = -1.0
        if present:
            a = rng.exponential(1.0 + snr)
            if a > tau:
                at = a
        nf = rng.poisson(clutter_mean)
        m = nf + (1 if at >= 0.0 else 0)
        rank = 0
        if at >= 0.0:
            rank = 1
        for _j in range(nf):
            ac = tau + rng.exponential(1.0)
            if at >= 0.0 and ac > at:
                rank += 1
        if m <= m_max:
            counts[m, rank] += 1


#: the largest clutter mean per gate the simulators accept
_MAX_SIM_CLUTTER = 1e6


def simulate_hpda_ranks(rng, n_draws, snr, tau, pg, clutter_mean, m_max):
    """Monte Carlo of the amplitude ranks from first principles.

    Each draw: the target is in the gate with probability ``pg``; its raw
    amplitude is Exp(mean ``1 + snr``) and it is detected iff that exceeds
    ``tau``; ``Poisson(clutter_mean)`` validated clutter returns have
    amplitudes ``tau + Exp(1)``.  Returns integer counts ``(m_max + 1,
    m_max + 1)``: ``counts[m, l]`` for ``m`` validated measurements with the
    target ranked ``l`` (1 = strongest), ``counts[m, 0]`` with no target
    measurement.  Draws with ``m > m_max`` are dropped (they still count in
    ``n_draws``).

    Examples
    --------
    20,000 draws: the fraction with ``m`` returns and the target strongest, against
    eq (12):

    >>> counts = simulate_hpda_ranks(np.random.default_rng(0), 20_000, snr=10.0, tau=2.0, pg=0.99,
    ...                              clutter_mean=1.0, m_max=3)
    >>> counts.shape
    (4, 4)
    >>> np.round(counts[1:, 1] / 20_000, 3)
    array([0.308, 0.279, 0.131])
    >>> np.round([hpda_rank_probabilities(m, 10.0, 2.0, 0.99, 1.0)[0] for m in (1, 2, 3)], 3)
    array([0.304, 0.278, 0.133])
    """
    rng = as_rng(rng)
    n = as_count(n_draws, "n_draws")
    snr = as_nonnegative(snr, "snr")
    tau = as_nonnegative(tau, "tau")
    pg = as_probability(pg, "pg")
    lam = as_nonnegative(clutter_mean, "clutter_mean")
    if lam > _MAX_SIM_CLUTTER:
        # every draw loops over its clutter returns (and a Poisson draw of a huge mean
        # overflows the integer count)
        raise ValueError(f"clutter_mean must be <= {_MAX_SIM_CLUTTER:g}, got {lam}")
    m_max = as_count(m_max, "m_max")
    counts = np.zeros((m_max + 1, m_max + 1), dtype=np.int64)
    _simulate_ranks_kernel(rng, n, snr, tau, pg, lam, counts)
    return counts


@nb.njit(cache=True)
def _simulate_existence_kernel(rng, n_draws, m_req, s_req, cx, cy, rad2, snr, tau, g2,
                               clutter_mean, p_prior):
    g = math.sqrt(g2)
    n_ev = 0
    n_h = 0
    amps = np.empty(1024)
    xs = np.empty(1024)
    ys = np.empty(1024)
    for _ in range(n_draws):
        exists = rng.random() < p_prior
        n = 0
        if exists:
            a = rng.exponential(1.0 + snr)
            if a > tau:
                x = rng.standard_normal()
                y = rng.standard_normal()
                if x * x + y * y <= g2:
                    amps[0] = a
                    xs[0] = x
                    ys[0] = y
                    n = 1
        nf = rng.poisson(clutter_mean)
        if n + nf != m_req or m_req > 1024:
            # still consume the clutter draws for a fixed stream layout
            for _j in range(nf):
                rng.random()
                rng.random()
                rng.exponential(1.0)
            continue
        for _j in range(nf):
            r = g * math.sqrt(rng.random())
            th = 2.0 * math.pi * rng.random()
            amps[n] = tau + rng.exponential(1.0)
            xs[n] = r * math.cos(th)
            ys[n] = r * math.sin(th)
            n += 1
        # the s-th strongest
        order = np.argsort(-amps[:n])
        j = order[s_req - 1]
        dx = xs[j] - cx
        dy = ys[j] - cy
        if dx * dx + dy * dy <= rad2:
            n_ev += 1
            if exists:
                n_h += 1
    return n_ev, n_h


def simulate_existence_posterior(rng, n_draws, m, s, centre, radius, snr, tau, gate_threshold,
                                 clutter_mean, p_prior):
    """Monte Carlo of the exact existence posterior in normalised measurement
    space (``z_hat = 0``, ``S = I``, circular gate ``|z|^2 <= gate_threshold``).

    Each draw: the track exists with probability ``p_prior``; if it does, the
    target return (``N(0, I)``) is reported iff its amplitude
    ``Exp(1 + snr)`` exceeds ``tau`` and it falls in the gate;
    ``Poisson(clutter_mean)`` clutter returns are uniform in the gate with
    amplitudes ``tau + Exp(1)``.  Events: exactly ``m`` returns and the
    ``s``-th strongest within ``radius`` of ``centre``.  Returns
    ``(n_events, n_events_with_existence)``; their ratio estimates
    ``P(H | m, z^s near centre)``, to compare with eq (19).

    Examples
    --------
    One return near the prediction in a 99 % gate (``|z|^2 <= 9.21``) holding on average one
    clutter return; the posterior from 20,000 draws, against eq (19):

    >>> import math
    >>> n, n_exist = simulate_existence_posterior(np.random.default_rng(0), 20_000, m=1, s=1,
    ...     centre=(0.0, 0.0), radius=0.5, snr=10.0, tau=2.0, gate_threshold=9.21,
    ...     clutter_mean=1.0, p_prior=0.5)
    >>> n, round(n_exist / n, 3)
    (491, 0.79)
    >>> vg = math.pi * 9.21
    >>> d = hpda_existence_delta(1, 1, 1 / (2 * math.pi), snr=10.0, tau=2.0,
    ...     pg=1 - math.exp(-9.21 / 2), clutter_density=1 / vg, gate_volume=vg)
    >>> round(existence_update(0.5, d), 3)
    0.801
    """
    rng = as_rng(rng)
    n = as_count(n_draws, "n_draws")
    m = as_count(m, "m")
    s = as_count(s, "s")
    if not 1 <= s <= m:
        raise ValueError(f"s must lie in [1, m] = [1, {m}], got {s}")
    c = as_array(centre, "centre", shape=(2,))
    radius = as_positive(radius, "radius")
    snr = as_nonnegative(snr, "snr")
    tau = as_nonnegative(tau, "tau")
    g2 = as_positive(gate_threshold, "gate_threshold")
    lam = as_nonnegative(clutter_mean, "clutter_mean")
    p = as_probability(p_prior, "p_prior")
    ne, nh = _simulate_existence_kernel(rng, n, m, s, float(c[0]), float(c[1]), radius * radius,
                                        snr, tau, g2, lam, p)
    return int(ne), int(nh)
