"""Wald's sequential probability ratio test (SPRT) for two simple hypotheses.

The test statistic is the log-likelihood ratio ``Lambda(k) = ln p(Z^k|H1) /
p(Z^k|H0)`` accumulated scan by scan (Jeong & Hong 1996, eqs 2-3).  The test
stops at the first scan ``k`` (1-based) with ``Lambda(k) >= gamma1`` (decide
H1) or ``Lambda(k) <= gamma0`` (decide H0); Wald's thresholds (eq 4) are

    gamma1 = ln((1 - P_M) / P_F),   gamma0 = ln(P_M / (1 - P_F)),

with ``P_F = P(decide H1 | H0)`` and ``P_M = P(decide H0 | H1)``.

Decisions are coded ``0`` (H0), ``1`` (H1) and ``-1`` (undecided: no crossing
within the data); the decision scan of an undecided test is ``0``.

Wald's approximations (neglecting the overshoot of the thresholds) give the
error probabilities actually achieved by given thresholds, the operating
characteristic (OC) and the average sample number (ASN).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_count, as_positive, as_probability, as_rng,
                               as_scalar)

__all__ = [
    "SPRT_H0",
    "SPRT_H1",
    "SPRT_UNDECIDED",
    "SprtResult",
    "SprtState",
    "sprt_thresholds",
    "sprt_symmetric_error",
    "sprt_step",
    "sprt_test",
    "sprt_decide",
    "SprtSummary",
    "sprt_summary",
    "first_crossing_scan",
    "gaussian_llr_walks",
    "wald_error_probabilities",
    "wald_expected_stopping_llr",
    "wald_oc",
    "wald_asn",
    "wald_gaussian_oc_asn",
]

SPRT_H0 = 0
SPRT_H1 = 1
SPRT_UNDECIDED = -1


class SprtResult(NamedTuple):
    """Outcome of a sequential test over a sequence of scans.

    Examples
    --------
    What :func:`sprt_test` returns:

    >>> r = sprt_test([1.5, 2.0, 1.5], *sprt_thresholds(0.01, 0.01))
    >>> r.decision, r.scan, r.llr
    (1, 3, array([1.5, 3.5, 5. ]))
    """
    decision: int       # 0 = H0, 1 = H1, -1 = undecided
    scan: int           # 1-based scan of the decision (0 if undecided)
    llr: np.ndarray     # cumulative log-likelihood ratio Lambda(k), k = 1..K


@dataclass(frozen=True)
class SprtState:
    """State of an online SPRT after ``k`` scans (immutable; see :func:`sprt_step`).

    Attributes
    ----------
    llr : float
        ``Lambda(k)``; ``Lambda(0) = 0`` (equal priors).
    k : int
        Scans taken so far (>= 0).
    decision : int
        ``SPRT_H0``, ``SPRT_H1`` or ``SPRT_UNDECIDED``.
    scan : int
        Scan of the decision, ``1 <= scan <= k`` (0 while undecided).

    The fields are checked when the record is built (``ValueError`` or
    ``TypeError`` naming the field).

    Examples
    --------
    >>> SprtState()
    SprtState(llr=0.0, k=0, decision=-1, scan=0)
    >>> SprtState(k=-1)
    Traceback (most recent call last):
        ...
    ValueError: k must be >= 0, got -1
    """
    llr: float = 0.0
    k: int = 0
    decision: int = SPRT_UNDECIDED
    scan: int = 0

    def __post_init__(self):
        as_scalar(self.llr, "llr")
        for name in ("k", "decision", "scan"):
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
                raise TypeError(f"{name} must be an integer, got {type(v).__name__}")
        if self.k < 0:
            raise ValueError(f"k must be >= 0, got {self.k}")
        if self.decision not in (SPRT_H0, SPRT_H1, SPRT_UNDECIDED):
            raise ValueError(f"decision must be 0 (H0), 1 (H1) or -1 (undecided), "
                             f"got {self.decision}")
        if self.decision == SPRT_UNDECIDED and self.scan != 0:
            raise ValueError(f"scan must be 0 while undecided, got {self.scan}")
        if self.decision != SPRT_UNDECIDED and not 1 <= self.scan <= self.k:
            raise ValueError(f"scan must lie in [1, k={self.k}] once decided, got {self.scan}")


def _check_thresholds(gamma0, gamma1):
    g0 = as_scalar(gamma0, "gamma0")
    g1 = as_scalar(gamma1, "gamma1")
    if not g0 < 0.0:
        raise ValueError(f"gamma0 must be < 0, got {g0}")
    if not g1 > 0.0:
        raise ValueError(f"gamma1 must be > 0, got {g1}")
    return g0, g1


def sprt_thresholds(p_miss, p_false):
    """Wald's thresholds ``(gamma0, gamma1)`` of eq (4).

    ``p_miss = P_M = P(decide H0 | H1)``, ``p_false = P_F = P(decide H1 | H0)``,
    both in (0, 1) with ``P_M + P_F < 1`` (otherwise ``gamma0 >= gamma1`` and
    the test is meaningless).  Returns ``(ln(P_M/(1-P_F)), ln((1-P_M)/P_F))``.

    Examples
    --------
    Equal error probabilities of 1 % give symmetric thresholds ``-+ln 99``:

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> round(g0, 4), round(g1, 4)
    (-4.5951, 4.5951)
    >>> sprt_thresholds(0.6, 0.5)
    Traceback (most recent call last):
        ...
    ValueError: p_miss + p_false must be < 1, got 0.6 + 0.5
    """
    pm = as_probability(p_miss, "p_miss", open_low=True, open_high=True)
    pf = as_probability(p_false, "p_false", open_low=True, open_high=True)
    if not pm + pf < 1.0:
        raise ValueError(f"p_miss + p_false must be < 1, got {pm} + {pf}")
    gamma0 = math.log(pm) - math.log1p(-pf)
    gamma1 = math.log1p(-pm) - math.log(pf)
    return gamma0, gamma1


def sprt_symmetric_error(gamma):
    """Error probability ``P_e`` with ``P_M = P_F = P_e`` whose thresholds are ``-+gamma``.

    Inverts ``gamma = ln((1 - P_e)/P_e)``: ``P_e = 1 / (1 + e^gamma)``.

    Examples
    --------
    The inverse of :func:`sprt_thresholds` with ``P_M = P_F``:

    >>> round(sprt_symmetric_error(4.5951), 4)
    0.01
    """
    g = as_scalar(gamma, "gamma")
    if not g > 0.0:
        raise ValueError(f"gamma must be > 0, got {g}")
    e = math.exp(-g)  # 1 / (1 + e^g) without overflow
    return e / (1.0 + e)


def sprt_step(state, increment, gamma0, gamma1):
    """Add one scan's LLR increment to an online test; returns the new :class:`SprtState`.

    Once decided, the decision and its scan stay fixed while ``llr`` and ``k``
    keep accumulating (the book keeps computing Lambda after the decision).

    Examples
    --------
    An online test fed one increment per scan decides H1 at scan 3 (``Lambda = 5 > 4.6``):

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> state = SprtState()
    >>> for increment in (2.0, 2.0, 1.0):
    ...     state = sprt_step(state, increment, g0, g1)
    >>> state
    SprtState(llr=5.0, k=3, decision=1, scan=3)
    >>> sprt_step(state, -20.0, g0, g1)  # the decision stays
    SprtState(llr=-15.0, k=4, decision=1, scan=3)
    """
    if not isinstance(state, SprtState):
        raise TypeError(f"state must be an SprtState, got {type(state).__name__}")
    inc = as_scalar(increment, "increment")
    g0, g1 = _check_thresholds(gamma0, gamma1)
    llr = state.llr + inc
    if not math.isfinite(llr):
        raise ValueError(f"increment {inc:g} makes Lambda overflow (state.llr = {state.llr:g})")
    k = state.k + 1
    decision, scan = state.decision, state.scan
    if decision == SPRT_UNDECIDED:
        if llr >= g1:
            decision, scan = SPRT_H1, k
        elif llr <= g0:
            decision, scan = SPRT_H0, k
    return SprtState(llr, k, decision, scan)


@nb.njit(cache=True)
def sprt_decide_kernel(llr, gamma0, gamma1, decision, scan):
    """First crossing of each cumulative LLR path ``llr`` (N, K).

    Writes ``decision[i]`` (0 H0, 1 H1, -1 undecided) and ``scan[i]`` (1-based,
    0 when undecided).
    """
    N, K = llr.shape
    for i in range(N):
        decision[i] = -1
        scan[i] = 0
        for k in range(K):
            v = llr[i, k]
            if v >= gamma1:
                decision[i] = 1
                scan[i] = k + 1
                break
            if v <= gamma0:
                decision[i] = 0
                scan[i] = k + 1
                break


def sprt_decide(llr, gamma0, gamma1):
    """Decisions and decision scans of cumulative LLR paths.

    ``llr`` is ``Lambda(k)`` for ``k = 1..K``: shape ``(K,)`` for one test or
    ``(N, K)`` for ``N`` tests (K = 0 is allowed: undecided).  Returns
    ``(decision, scan)`` as ints for a 1-D input, int arrays ``(N,)`` otherwise.

    Examples
    --------
    Two paths: the first crosses ``gamma1`` at scan 3 (H1), the second ``gamma0`` at scan 2 (H0):

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> sprt_decide(np.array([[1.0, 3.0, 5.0], [-2.0, -5.0, -1.0]]), g0, g1)
    (array([1, 0]), array([3, 2]))
    >>> sprt_decide(np.array([1.0, 3.0]), g0, g1)  # one path, still undecided
    (-1, 0)
    """
    L = as_array(llr, "llr", ndim=(1, 2))
    g0, g1 = _check_thresholds(gamma0, gamma1)
    single = L.ndim == 1
    L2 = L.reshape(1, -1) if single else L
    decision = np.empty(L2.shape[0], dtype=np.int64)
    scan = np.empty(L2.shape[0], dtype=np.int64)
    sprt_decide_kernel(L2, g0, g1, decision, scan)
    if single:
        return int(decision[0]), int(scan[0])
    return decision, scan


def sprt_test(increments, gamma0, gamma1):
    """Run the SPRT on a sequence of per-scan LLR increments (eq 3).

    ``increments[k-1] = ln p(z(k)|Z^{k-1},H1) - ln p(z(k)|Z^{k-1},H0)``; an
    empty sequence is valid (undecided).  Returns :class:`SprtResult` with the
    whole cumulative path (computed past the decision).

    Examples
    --------
    The cumulative path is kept past the decision:

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> sprt_test([1.5, 2.0, 1.5, -1.0], g0, g1)
    SprtResult(decision=1, scan=3, llr=array([1.5, 3.5, 5. , 4. ]))
    """
    inc = as_array(increments, "increments", ndim=1)
    g0, g1 = _check_thresholds(gamma0, gamma1)
    llr = np.cumsum(inc)
    d, k = sprt_decide(llr, g0, g1) if llr.size else (SPRT_UNDECIDED, 0)
    return SprtResult(int(d), int(k), llr)


def wald_error_probabilities(gamma0, gamma1):
    """Error probabilities ``(P_F, P_M)`` implied by thresholds (Wald, no overshoot).

    With ``A = e^gamma1``, ``B = e^gamma0``: ``P_F = (1 - B)/(A - B)`` and
    ``P_M = B (A - 1)/(A - B)``; the exact inverse of :func:`sprt_thresholds`.

    Examples
    --------
    >>> np.round(wald_error_probabilities(*sprt_thresholds(0.05, 0.01)), 4)  # (P_F, P_M)
    array([0.01, 0.05])
    """
    g0, g1 = _check_thresholds(gamma0, gamma1)
    # divide numerator and denominator by A = e^gamma1 (no overflow for large gamma1)
    ia = math.exp(-g1)
    b = math.exp(g0)
    den = 1.0 - b * ia
    pf = ia * (1.0 - b) / den
    pm = b * (1.0 - ia) / den
    return pf, pm


def wald_expected_stopping_llr(gamma0, gamma1, p_decide_h0):
    """Wald's ``E[Lambda_N] = L gamma0 + (1 - L) gamma1`` at the stopping scan ``N``.

    ``L = p_decide_h0``.  Neglecting the overshoot, the test stops exactly on a
    threshold, so the mean of ``Lambda`` at the stop is the average of the two
    thresholds weighted by the probabilities of reaching them.  Under H0 with
    Wald's ``P_F`` (:func:`wald_error_probabilities`) it is
    ``(1 - P_F) gamma0 + P_F gamma1``.

    Examples
    --------
    Under H0 with 1 % errors the test stops, on average, just above ``gamma0 = -4.5951``:

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> round(wald_expected_stopping_llr(g0, g1, p_decide_h0=0.99), 4)
    -4.5032
    """
    g0, g1 = _check_thresholds(gamma0, gamma1)
    L = as_probability(p_decide_h0, "p_decide_h0")
    return L * g0 + (1.0 - L) * g1


def wald_oc(h, gamma0, gamma1):
    """Wald's operating characteristic: probability of deciding H0.

    ``h != 0`` solves ``E[exp(h lambda)] = 1`` for the LLR increment ``lambda``
    under the true distribution (``h = 1`` under H0, ``h = -1`` under H1).
    ``L(h) = (e^{h gamma1} - 1)/(e^{h gamma1} - e^{h gamma0})``, and
    ``L(0) = gamma1/(gamma1 - gamma0)``.  ``h`` may be an array.

    Examples
    --------
    Under H0 (``h = 1``) the test decides H0 with probability ``1 - P_F``, under H1
    (``h = -1``) with ``P_M``; halfway (``h = 0``) it is a coin toss:

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> np.round(wald_oc(np.array([1.0, 0.0, -1.0]), g0, g1), 4)
    array([0.99, 0.5 , 0.01])
    """
    g0, g1 = _check_thresholds(gamma0, gamma1)
    scalar = np.ndim(h) == 0
    H = as_array(h, "h")
    out = np.empty_like(H)
    flat, res = H.ravel(), out.ravel()
    for i, hv in enumerate(flat):
        if abs(hv) < 1e-10:
            res[i] = g1 / (g1 - g0)
            continue
        a, b = hv * g1, hv * g0
        # (e^a - 1)/(e^a - e^b), stable for large |a|, |b|
        m = max(a, b)
        res[i] = (math.exp(a - m) - math.exp(-m)) / (math.exp(a - m) - math.exp(b - m))
    return float(out.reshape(-1)[0]) if scalar else out


def wald_asn(mean_increment, gamma0, gamma1, p_decide_h0):
    """Wald's average sample number ``E[k] = (L gamma0 + (1 - L) gamma1) / E[lambda]``.

    ``L = p_decide_h0``; under H0 with ``P_F`` this is
    ``((1 - P_F) gamma0 + P_F gamma1) / E[lambda | H0]``, the ratio of
    :func:`wald_expected_stopping_llr` to the mean increment (Wald's identity).  ``mean_increment``
    must be non-zero (use :func:`wald_gaussian_oc_asn` for the zero-drift limit).

    Examples
    --------
    Increments of mean -0.5 under H0: about nine scans to a decision:

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> round(wald_asn(-0.5, g0, g1, p_decide_h0=0.99), 3)
    9.006
    """
    mu = as_scalar(mean_increment, "mean_increment")
    if mu == 0.0:
        raise ValueError("mean_increment must be non-zero")
    g0, g1 = _check_thresholds(gamma0, gamma1)
    L = as_probability(p_decide_h0, "p_decide_h0")
    asn = (L * g0 + (1.0 - L) * g1) / mu
    if asn < 0.0:
        raise ValueError("mean_increment has the wrong sign for p_decide_h0: the ASN "
                         f"approximation came out negative ({asn:.3g})")
    return asn


def wald_gaussian_oc_asn(mean, var, gamma0, gamma1):
    """OC and ASN for i.i.d. Gaussian increments ``N(mean, var)`` (Wald).

    ``h = -2 mean / var``; returns ``(P(decide H0), ASN)``.  At ``mean = 0`` the
    ASN is ``-gamma0 gamma1 / var``.

    Examples
    --------
    ``N(-1/2, 1)`` increments are the exact LLR of a unit shift under H0; zero drift
    takes longer:

    >>> g0, g1 = sprt_thresholds(0.01, 0.01)
    >>> np.round(wald_gaussian_oc_asn(-0.5, 1.0, g0, g1), 3)
    array([0.99 , 9.006])
    >>> np.round(wald_gaussian_oc_asn(0.0, 1.0, g0, g1), 3)
    array([ 0.5  , 21.115])
    """
    mu = as_scalar(mean, "mean")
    v = as_scalar(var, "var")
    if not v > 0.0:
        raise ValueError(f"var must be > 0, got {v}")
    g0, g1 = _check_thresholds(gamma0, gamma1)
    h = -2.0 * mu / v
    if not math.isfinite(h):
        raise ValueError(f"mean / var out of range: h = -2 mean / var overflows "
                         f"(mean={mu:g}, var={v:g})")
    L = wald_oc(h, g0, g1)
    if abs(h) < 1e-10:
        return L, -g0 * g1 / v
    return L, (L * g0 + (1.0 - L) * g1) / mu


def first_crossing_scan(path, level):
    """Fractional scan at which a path ``path[k-1] = Lambda(k)``, ``k = 1..K``, first
    reaches ``level``, by linear interpolation between scans (``Lambda(0) = 0``).

    A negative ``level`` is reached from above (``Lambda <= level``), a positive
    one from below.  Returns ``nan`` if the path never reaches it.  The paper
    reads such a crossing off the run-averaged Lambda (eq 29) and quotes it with
    one decimal (scan 5.4 in its Fig. 5).

    Examples
    --------
    ``Lambda`` goes 1, 3, 5: it reaches 4 halfway between scans 2 and 3:

    >>> first_crossing_scan([1.0, 3.0, 5.0], 4.0)
    2.5
    >>> first_crossing_scan([-1.0, -3.0], -2.0)  # a negative level from above
    1.5
    >>> first_crossing_scan([1.0, 2.0], 5.0)
    nan
    """
    p = as_array(path, "path", ndim=1)
    lev = as_scalar(level, "level")
    if lev == 0.0:
        raise ValueError("level must be non-zero (the path starts at Lambda(0) = 0)")
    sgn = 1.0 if lev > 0 else -1.0
    prev = 0.0
    for i, v in enumerate(p):
        if sgn * v >= sgn * lev:
            if v == prev:
                return float(i + 1)
            sc = max(abs(v), abs(prev), abs(lev))  # scaled: no overflow for any finite path
            frac = (lev / sc - prev / sc) / (v / sc - prev / sc)
            return float(i + min(max(frac, 0.0), 1.0))
        prev = v
    return float("nan")


def gaussian_llr_walks(var, n_runs, n_scans, rng, h1_true=False):
    """Cumulative log-likelihood ratios of a test that *is* a true likelihood ratio.

    The increment of scan ``k`` is ``N(-v_k/2, v_k)`` under H0 (``N(+v_k/2, v_k)`` with
    ``h1_true``): the exact LLR of one Gaussian datum whose mean shifts by ``sqrt(v_k)``
    standard deviations between the hypotheses.  ``var`` is one variance for every scan
    (i.i.d. increments) or an array of ``n_scans`` per-scan variances (a non-stationary
    walk, e.g. one whose mean increments follow another statistic's).  For such a walk
    ``E[exp(Lambda(k)) | H0] = 1`` at every scan; it is the reference against which the
    book measures the calibration of an approximate statistic.  Returns an
    ``(n_runs, n_scans)`` array.

    Examples
    --------
    Under H0 scan ``k``'s ``Lambda`` has mean ``-k v / 2`` and variance ``k v``:

    >>> walks = gaussian_llr_walks(1.0, n_runs=2000, n_scans=30, rng=np.random.default_rng(0))
    >>> walks.shape, np.round(walks[:, 9].mean(), 2), np.round(walks[:, 9].var(), 2)
    ((2000, 30), np.float64(-4.99), np.float64(9.65))
    """
    n = as_count(n_runs, "n_runs")
    K = as_count(n_scans, "n_scans")
    if np.ndim(var) == 0:
        v = np.full(K, as_positive(var, "var"))
    else:
        v = as_array(var, "var", ndim=1)
        if v.size != K:
            raise ValueError(f"var must be a number or hold n_scans = {K} variances, "
                             f"got {v.size}")
        if not np.all(v > 0):
            raise ValueError("var must be > 0 at every scan")
    g = as_rng(rng)
    if not isinstance(h1_true, (bool, np.bool_)):
        raise TypeError(f"h1_true must be a bool, got {type(h1_true).__name__}")
    mean = 0.5 * v if h1_true else -0.5 * v
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.cumsum(mean + np.sqrt(v) * g.standard_normal((n, K)), axis=1)
    if not np.all(np.isfinite(out)):
        raise ValueError(f"var (up to {v.max() if v.size else 0:g}) is too large: the "
                         "cumulative sums overflow")
    return out


class SprtSummary(NamedTuple):
    """Monte Carlo summary of SPRT runs whose true hypothesis is ``truth``.

    Examples
    --------
    What :func:`sprt_summary` returns (a few of its fields):

    >>> walks = gaussian_llr_walks(1.0, 2000, 30, np.random.default_rng(0))
    >>> s = sprt_summary(walks, *sprt_thresholds(0.01, 0.01), truth=SPRT_H0)
    >>> s.n_runs, s.counts_correct.shape
    (2000, (30,))
    """
    n_runs: int
    p_correct: float          # fraction deciding the true hypothesis
    p_wrong: float            # fraction deciding the other one
    p_undecided: float        # fraction with no crossing within the data
    mean_scan_correct: float  # mean decision scan of the correct decisions (NaN if none)
    mean_scan_wrong: float    # mean decision scan of the wrong decisions (NaN if none)
    mean_scan: float          # mean decision scan over all decided runs (NaN if none)
    mean_llr_crossing: int    # first scan at which the run-averaged Lambda crosses a threshold (0: none)
    counts_correct: np.ndarray  # (K,) number of correct decisions at scan k = 1..K
    counts_wrong: np.ndarray    # (K,) number of wrong decisions at scan k
    mean_llr_crossing_scan: float  # the same crossing interpolated between scans (nan: none)


def sprt_summary(llr, gamma0, gamma1, truth=SPRT_H0):
    """Success rates, mean decision scans and the mean-Lambda crossing of ``llr`` (N, K).

    ``truth`` is the hypothesis that generated the data (0 or 1).  The
    mean-Lambda crossing is the first scan at which the average of ``llr`` over
    the runs (paper eq 29) reaches ``gamma0`` or ``gamma1``; it is given both as
    a whole scan and interpolated (:func:`first_crossing_scan`).

    Examples
    --------
    2000 exact-LLR walks under H0 with 1 % thresholds: about 98 % decide H0, 0.3 %
    decide H1 (under the 1 % design), the rest are undecided after 30 scans; the
    mean decision scan exceeds Wald's 9.0, which neglects the overshoot:

    >>> walks = gaussian_llr_walks(1.0, 2000, 30, np.random.default_rng(0))
    >>> s = sprt_summary(walks, *sprt_thresholds(0.01, 0.01), truth=SPRT_H0)
    >>> round(s.p_correct, 4), round(s.p_wrong, 4), round(s.p_undecided, 4)
    (0.9785, 0.003, 0.0185)
    >>> round(s.mean_scan, 2), s.mean_llr_crossing, round(s.mean_llr_crossing_scan, 2)
    (10.07, 10, 9.23)
    """
    L = as_array(llr, "llr", ndim=2)
    if truth not in (SPRT_H0, SPRT_H1) or isinstance(truth, bool):
        raise ValueError(f"truth must be 0 (H0) or 1 (H1), got {truth!r}")
    if L.shape[0] == 0:
        raise ValueError("llr must hold at least one run")
    d, k = sprt_decide(L, gamma0, gamma1)
    K = L.shape[1]
    good = d == truth
    bad = d == 1 - truth

    def _mean(mask):
        return float(k[mask].mean()) if np.any(mask) else float("nan")

    mean_path = L.mean(axis=0)
    md, mk = sprt_decide(mean_path, gamma0, gamma1)
    g0, g1 = _check_thresholds(gamma0, gamma1)
    if md == SPRT_UNDECIDED:
        crossing = float("nan")
    else:
        crossing = first_crossing_scan(mean_path, g1 if md == SPRT_H1 else g0)
    return SprtSummary(L.shape[0], float(good.mean()), float(bad.mean()),
                       float(np.mean(d == SPRT_UNDECIDED)), _mean(good), _mean(bad),
                       _mean(d != SPRT_UNDECIDED), int(mk),
                       np.bincount(k[good], minlength=K + 1)[1:],
                       np.bincount(k[bad], minlength=K + 1)[1:], crossing)
