"""Exact joint probabilistic data association (JPDA), with the image-feature form of
Kim, Jung, Kang & Yoon (2016).

A *feasible joint event* assigns every measurement either to clutter or to one
target that validates it, with at most one measurement per target.  Its
posterior probability is (parametric form, Poisson clutter of density lam)

    P(theta | Z) = 1/c  prod_j [rho_{j,t_j} N_{j,t_j} / lam]^{tau_j}
                        prod_t pd_t^{delta_t} (1 - pd_t)^{1 - delta_t}

(rho = 1 for plain JPDA), or with phi! / V**phi instead of lam^{-tau}
(nonparametric form, phi = number of false measurements).  The marginals
beta_{j,t} = sum_theta P(theta|Z) omega_{j,t}(theta) and beta_{0,t} (target t
missed) are computed exactly, by one of the two methods below.

With ``rho`` given, the validation matrix is ``valid & (rho >= c_I)`` (eq 5)
and each target-originated assignment carries the factor rho (eq 6).

The number of feasible events equals the permanent of the T x (m + T) 0/1
matrix ``[valid.T | I_T]``; :func:`permanent` gives an independent count.

Two exact methods compute the same marginals.  The enumeration visits every feasible
event (its cost is their number, which grows exponentially with the number of targets
whose gates overlap); the hypothesis net (``trackcore/association/_jpda_net.py``) merges
the partial assignments that leave the rest of the problem in the same state, processes
the connected components of the validation graph one after the other and costs about
``sum_k 2^{w_k} (1 + degree_k)`` for frontier widths ``w_k`` (small for separated or
chained targets, ``2^T`` per measurement when every gate holds every measurement); it
works in scaled arithmetic where a certificate shows that nothing underflows and in log
space otherwise.  :func:`jpda_marginals` enumerates small problems (at most
``ENUMERATE_MAX_PRODUCT`` combinations of per-target choices over the whole matrix; kept
there so that their results stay bit for bit those of earlier versions, although the net
is faster there too) and uses the net otherwise.  Both check the size of the work before
they start and raise ``ValueError`` naming the limit and the size of the problem when it
is too large.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..core.validation import (
    as_array,
    as_bool_matrix,
    as_positive,
    as_probabilities,
    as_probability,
)
from ._jpda_net import (
    MAX_CELLS,
    MAX_COST,
    MAX_LOG_COST,
    MAX_SLOTS,
    net_count,
    net_marginals,
    net_marginals_log,
)

__all__ = [
    "FEATURE_THRESHOLD",
    "feasible_event_count",
    "feasible_events",
    "feature_validation",
    "jpda_clusters",
    "jpda_marginals",
    "permanent",
]

#: c_I of the paper (eq 5): a measurement validates a track only if rho >= c_I.
FEATURE_THRESHOLD = 0.6
#: ``method="auto"`` enumerates when ``prod_t (1 + gated measurements of t)`` (an upper
#: bound on the number of feasible events) is at most this, and uses the net otherwise.
ENUMERATE_MAX_PRODUCT = 100
#: largest number of feasible events the enumeration visits (``method="enumerate"``;
#: about 0.15 us each)
MAX_ENUMERATED_EVENTS = 2 * 10**7
#: largest number of events :func:`feasible_events` lists
MAX_LISTED_EVENTS = 10**7
#: largest number of entries (events x targets, 8 bytes each) :func:`feasible_events` lists
MAX_LISTED_ENTRIES = 2 * 10**7
#: column sums of the net's marginals must lie within this of 1 (output check)
COLUMN_SUM_TOLERANCE = 1e-9


@nb.njit(cache=True)
def _logaddexp_kernel(a, b):
    """log(exp(a) + exp(b)) for scalars, -inf safe."""
    if a == -np.inf:
        return b
    if b == -np.inf:
        return a
    if a > b:
        return a + math.log1p(math.exp(b - a))
    return b + math.log1p(math.exp(a - b))


@nb.njit(cache=True)
def _enumerate_kernel(logf, valid, log_pd, log_1mpd, nonparametric, logV):
    """Depth-first enumeration of all feasible joint events.

    ``logf[j, t]`` is the log weight of assigning measurement j to target t,
    *excluding* the detection probability (i.e. log(rho N / lam) in the
    parametric form, log(rho N) in the nonparametric form).  Returns
    ``(log_acc, log_miss, log_total, n_events)`` with ``log_acc[j, t]`` the
    unnormalised log marginal of (j, t) and ``log_miss[t]`` that of a miss.
    """
    m, T = valid.shape
    log_acc = np.full((m, T), -np.inf)
    log_miss = np.full(T, -np.inf)
    log_total = -np.inf
    n_events = 0
    choice = np.full(max(m, 1), -1, np.int64)   # 0 = clutter, c >= 1 = target c-1
    used = np.zeros(T, np.bool_)
    # log(phi!) table for the nonparametric form
    lfact = np.zeros(m + 1)
    for i in range(1, m + 1):
        lfact[i] = lfact[i - 1] + math.log(i)
    j = 0
    while j >= 0:
        if j == m:
            n_events += 1
            lw = 0.0
            ndet = 0
            for jj in range(m):
                c = choice[jj]
                if c >= 1:
                    lw += logf[jj, c - 1]
                    ndet += 1
            for t in range(T):
                if used[t]:
                    lw += log_pd[t]
                else:
                    lw += log_1mpd[t]
            if nonparametric:
                phi = m - ndet
                lw += lfact[phi] - phi * logV
            if lw > -np.inf:
                log_total = _logaddexp_kernel(log_total, lw)
                for jj in range(m):
                    c = choice[jj]
                    if c >= 1:
                        log_acc[jj, c - 1] = _logaddexp_kernel(log_acc[jj, c - 1], lw)
                for t in range(T):
                    if not used[t]:
                        log_miss[t] = _logaddexp_kernel(log_miss[t], lw)
            j -= 1
            continue
        c = choice[j]
        if c >= 1:
            used[c - 1] = False
        c += 1
        while c >= 1 and c <= T and ((not valid[j, c - 1]) or used[c - 1]):
            c += 1
        if c > T:
            choice[j] = -1
            j -= 1
            continue
        choice[j] = c
        if c >= 1:
            used[c - 1] = True
        j += 1
        if j < m:
            choice[j] = -1
    return log_acc, log_miss, log_total, n_events


@nb.njit(cache=True)
def _walk_events(valid, out):
    """Depth-first walk over the feasible events of ``valid``; returns their count.

    When ``out`` has rows, row e receives event e: column t holds the 0-based index
    of the measurement assigned to target t, or -1 for a miss (``out`` must be
    pre-filled with -1).  With a zero-row ``out`` it only counts."""
    m, T = valid.shape
    store = out.shape[0] > 0
    choice = np.full(max(m, 1), -1, np.int64)
    used = np.zeros(T, np.bool_)
    e = 0
    j = 0
    while j >= 0:
        if j == m:
            if store:
                for jj in range(m):
                    if choice[jj] >= 1:
                        out[e, choice[jj] - 1] = jj
            e += 1
            j -= 1
            continue
        c = choice[j]
        if c >= 1:
            used[c - 1] = False
        c += 1
        while c >= 1 and c <= T and ((not valid[j, c - 1]) or used[c - 1]):
            c += 1
        if c > T:
            choice[j] = -1
            j -= 1
            continue
        choice[j] = c
        if c >= 1:
            used[c - 1] = True
        j += 1
        if j < m:
            choice[j] = -1
    return e


@nb.njit(cache=True)
def _list_events_kernel(valid, n_events):
    """All feasible events as an (n_events, T) array (see :func:`_walk_events`)."""
    out = np.full((n_events, valid.shape[1]), -1, np.int64)
    _walk_events(valid, out)
    return out


@nb.njit(cache=True)
def _count_kernel(valid):
    return _walk_events(valid, np.empty((0, valid.shape[1]), np.int64))


@nb.njit(cache=True)
def _net_inputs(lik, valid, rho, use_rho, pd, log_scale):
    """``(logw, log(1 - pd))`` for the net: ``logw[j, t] = log(pd_t lik_jt rho_jt) +
    log_scale`` on valid pairs (``rho`` clipped at 0), ``-inf`` elsewhere.  Formed in log
    space: a pair whose product ``pd lik rho`` would underflow keeps its weight."""
    m, T = valid.shape
    logw = np.empty((m, T))
    log_miss = np.empty(T)
    for t in range(T):
        log_miss[t] = math.log1p(-pd[t]) if pd[t] < 1.0 else -np.inf
    for j in range(m):
        for t in range(T):
            if (valid[j, t] and lik[j, t] > 0.0 and pd[t] > 0.0
                    and (not use_rho or rho[j, t] > 0.0)):
                logw[j, t] = math.log(lik[j, t]) + math.log(pd[t]) + log_scale
                if use_rho:
                    logw[j, t] += math.log(rho[j, t])
            else:
                logw[j, t] = -np.inf
    return logw, log_miss


@nb.njit(cache=True)
def _marginals_ok(beta, tol):
    """Output check of the net: every value finite and in [0, 1 + tol], every column
    summing to 1 within ``tol``."""
    m1, T = beta.shape
    for t in range(T):
        s = 0.0
        for j in range(m1):
            v = beta[j, t]
            if not (0.0 <= v <= 1.0 + tol):
                return False
            s += v
        if not abs(s - 1.0) <= tol:
            return False
    return True


def _check_valid(valid, name="valid"):
    arr = np.asarray(valid)
    if arr.ndim != 2:
        raise ValueError(f"{name} must have shape (m, T), got {arr.shape}")
    return as_bool_matrix(arr, name, shape=(None, None))


def feature_validation(valid, rho, c_I=FEATURE_THRESHOLD):
    """The feature validation matrix of eq (5): ``valid & (rho >= c_I)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import feature_validation
    >>> valid = np.array([[True, True], [True, False]])
    >>> rho = np.array([[0.9, 0.3], [0.7, 0.95]])
    >>> feature_validation(valid, rho).tolist()    # a feature correlation below 0.6 removes a pair
    [[True, False], [True, False]]
    """
    valid = _check_valid(valid)
    rho = as_array(rho, "rho", shape=valid.shape)
    if rho.size and (rho.min() < -1 - 1e-12 or rho.max() > 1 + 1e-12):
        raise ValueError("rho must contain correlations in [-1, 1]")
    c_I = float(c_I)
    if not -1.0 <= c_I <= 1.0:
        raise ValueError(f"c_I must lie in [-1, 1], got {c_I}")
    return np.ascontiguousarray(valid & (rho >= c_I))


def _size(valid):
    m, T = valid.shape
    return f"{m} measurements x {T} targets, {int(valid.sum())} gated pairs"


def _net_limit_error(name, valid, info, marginals, log_space=False):
    """The ``ValueError`` of a net over its limits, naming each limit it exceeds."""
    slots, cells, cost = (float(x) for x in info)
    max_cost, cost_name = (MAX_LOG_COST, "MAX_LOG_COST") if log_space else (MAX_COST,
                                                                          "MAX_COST")
    parts = []
    if slots > MAX_SLOTS:
        parts.append(f"its frontier reaches {slots:.0f}{'+' if slots >= 64 else ''} "
                     f"elements, more than MAX_SLOTS = {MAX_SLOTS}")
    if marginals and cells > MAX_CELLS:
        parts.append(f"it would store {cells:.3g} node values ({8 * cells / 2**30:.3g} "
                     f"GiB), more than MAX_CELLS = 2**{MAX_CELLS.bit_length() - 1}")
    if cost > max_cost:
        parts.append(f"its cost is about {cost:.3g} node visits, more than {cost_name} = "
                     f"{max_cost:.1e}")
    what = ("the weights span too wide a range for the scaled net (a product could fall "
            "below 1e-290) and the log-space hypothesis net" if log_space else
            "the hypothesis net of this validation matrix")
    return ValueError(
        f"{name} ({_size(valid)}): {what} exceeds its limits: {'; '.join(parts)}. Split "
        "the problem into smaller clusters or tighten the gates")


def _events_number(count, exp2):
    """The number of feasible events ``count * 2**exp2``: an ``int`` below ``2**53``
    (exact), otherwise a ``float`` to double precision (``math.inf`` above the largest
    double)."""
    if exp2 == 0 and count < 2.0**53:
        return int(count)
    try:
        return math.ldexp(float(count), int(exp2))
    except OverflowError:
        return math.inf


def _count(valid, name="valid"):
    """Number of feasible events counted by the net (``ValueError`` if it is too large)."""
    n, exp2, status, info = net_count(valid)
    if status == 1:
        raise _net_limit_error(name, valid, info, marginals=False)
    return _events_number(n, exp2)


def feasible_event_count(valid):
    """Number of feasible joint events of a validation matrix (m, T).

    Counted by the hypothesis net, without enumerating them (the all-valid 12 x 12
    matrix's 53,334,454,417 events in about a millisecond).  Returns an ``int``, exact,
    below ``2**53``; above, a ``float`` to double precision, ``math.inf`` beyond the
    largest double (about 1.8e308).  Raises ``ValueError`` naming the limit when the net
    exceeds its limits.

    Examples
    --------
    >>> from trackcore.association import feasible_event_count
    >>> valid = [[True, True],      # measurement 0 in both gates
    ...          [False, True]]     # measurement 1 in target 1's gate only
    >>> feasible_event_count(valid)
    5
    """
    valid = _check_valid(valid)
    if valid.shape[0] == 0:
        return 1
    return _count(valid)


def feasible_events(valid):
    """All feasible joint events of the (m, T) validation matrix ``valid``.

    Returns an int array (n_events, T): entry [e, t] is the 0-based index of
    the measurement target t receives in event e, or -1 if t is missed.
    Rows are sorted lexicographically with misses first.  Raises ``ValueError`` when
    there are more than ``MAX_LISTED_EVENTS`` (10**7) events or the listing would have
    more than ``MAX_LISTED_ENTRIES`` (2 * 10**7, events x targets) entries.

    Examples
    --------
    >>> from trackcore.association import feasible_events
    >>> valid = [[True, True], [False, True]]
    >>> feasible_events(valid).tolist()   # per event, each target's measurement (-1: missed)
    [[-1, -1], [-1, 0], [-1, 1], [0, -1], [0, 1]]
    """
    valid = _check_valid(valid)
    m, T = valid.shape
    n = _count(valid) if m else 1
    if n > MAX_LISTED_EVENTS or n * T > MAX_LISTED_ENTRIES:
        raise ValueError(
            f"valid ({_size(valid)}) has {n:.6g} feasible events, a listing of {n * T:.6g} "
            f"entries; feasible_events lists at most MAX_LISTED_EVENTS = "
            f"{MAX_LISTED_EVENTS:.0e} events and MAX_LISTED_ENTRIES = "
            f"{MAX_LISTED_ENTRIES:.0e} entries (events x targets)")
    n = _count_kernel(valid)
    ev = _list_events_kernel(valid, n)
    if ev.shape[0] > 1:
        order = np.lexsort(ev.T[::-1])
        ev = ev[order]
    return ev


def _gate_sizes(valid):
    return valid.sum(axis=0).tolist()


def _product_at_most(valid, limit):
    """Whether ``prod_t (1 + number of measurements in t's gate)`` (an upper bound on the
    number of feasible events) is at most ``limit``, in exact integer arithmetic."""
    p = 1
    for c in _gate_sizes(valid):
        p *= 1 + c
        if p > limit:
            return False
    return True


def _product_bound(valid):
    """``prod_t (1 + number of measurements in t's gate)`` as a float (``inf`` when it
    exceeds the largest double; no overflow warning)."""
    return float(math.prod(1.0 + c for c in _gate_sizes(valid)))


def jpda_marginals(lik, valid, pd, lam, rho=None, mode="parametric", V=None,
                   c_I=FEATURE_THRESHOLD, method="auto"):
    """Exact JPDA association probabilities (enumeration in log space, or the net).

    Parameters
    ----------
    lik : (m, T) array of Gaussian likelihoods N(nu_{j,t}; 0, S_t) (>= 0).
    valid : (m, T) boolean validation matrix (measurement j in track t's gate).
    pd : (T,) detection probabilities in [0, 1] (or a scalar for all).
    lam : clutter spatial density (> 0); used by the parametric form.
    rho : optional (m, T) feature correlations in [-1, 1]; enables the feature
        form of eqs (5)-(6): validation ``valid & (rho >= c_I)``, factor rho.
    mode : "parametric" (Poisson clutter, lam) or "nonparametric" (phi!/V^phi).
    V : gate (surveillance) volume > 0, required for ``mode="nonparametric"``.
    c_I : feature threshold (0.6 in the paper).
    method : "auto" (default: enumeration when ``prod_t (1 + gated measurements)`` over
        the whole matrix is at most ``ENUMERATE_MAX_PRODUCT``, the hypothesis net
        otherwise), "enumerate" or "net".  Both are exact in exact arithmetic; their
        rounding differs (see the notes).

    Returns
    -------
    beta : (m + 1, T) array; row 0 is beta_{0,t} (no measurement from t), row
        j + 1 is beta_{j,t}.  Every column sums to 1.
    n_events : number of feasible joint events: an ``int`` (enumerated, or counted by
        the net and exact) below ``2**53``; above, a ``float`` to double precision
        (``math.inf`` beyond the largest double).

    Notes
    -----
    Rounding.  The enumeration adds every event's weight in log space, so its error
    grows with the number of events and with the size of the log weights: a few 1e-14
    relative on the problems ``method="auto"`` enumerates (at most 100 combinations),
    but measured against exact rational arithmetic on the all-valid 8 x 10 problem (13
    million events) about 5e-12 at ``lam = 1e-3`` and 1e-10 at ``lam = 1e-60`` (the
    Performance appendix).  The net works in scaled linear arithmetic while a
    layer-by-layer certificate shows that no product can fall below 1e-290 (then every
    marginal keeps full relative precision: about 2e-15 on that problem), and otherwise
    repeats the computation in log space (weights spanning hundreds of decades; about
    2e-13 there, at several times the cost).  Its output is checked (finite, every
    column summing to 1 within ``COLUMN_SUM_TOLERANCE``); a failed check falls back to
    the enumeration when it has at most ``MAX_ENUMERATED_EVENTS`` events and raises
    ``ValueError`` otherwise.

    Limits.  The enumeration refuses more than ``MAX_ENUMERATED_EVENTS`` events, the
    net a problem over ``MAX_SLOTS``, ``MAX_CELLS`` or ``MAX_COST``
    (``trackcore/association/_jpda_net.py``), with a ``ValueError`` naming the limit
    and the size of the problem, before any work.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import jpda_marginals
    >>> lik = np.array([[0.10, 0.02],
    ...                 [0.00, 0.08]])              # (m = 2 measurements, T = 2 targets)
    >>> valid = lik > 0
    >>> beta, n_events = jpda_marginals(lik, valid, pd=0.9, lam=0.01)
    >>> n_events
    5
    >>> print(np.round(beta, 3))                  # rows: missed, measurement 0, measurement 1
    [[0.014 0.014]
     [0.986 0.003]
     [0.    0.984]]
    >>> print(beta.sum(axis=0))
    [1. 1.]
    """
    if method not in ("auto", "enumerate", "net"):
        raise ValueError(f"method must be 'auto', 'enumerate' or 'net', got {method!r}")
    valid = _check_valid(valid)
    m, T = valid.shape
    lik = as_array(lik, "lik", ndim=2)
    if lik.shape != (m, T):
        raise ValueError(f"lik must have shape {(m, T)} like valid, got {lik.shape}")
    if lik.size and lik.min() < 0:
        raise ValueError("lik must contain non-negative likelihoods")
    if np.ndim(pd) == 0 and not isinstance(pd, (str, bytes)):
        pd = np.full(T, as_probability(pd, "pd"))
    pd_arr = as_probabilities(pd, "pd", shape=(T,))
    if mode not in ("parametric", "nonparametric"):
        raise ValueError(f"mode must be 'parametric' or 'nonparametric', got {mode!r}")
    lam = as_positive(lam, "lam") if mode == "parametric" else (
        1.0 if lam is None else as_positive(lam, "lam"))
    if mode == "nonparametric":
        if V is None:
            raise ValueError("V (gate volume) is required for mode='nonparametric'")
        V = as_positive(V, "V")
        logV = math.log(V)
    else:
        logV = 0.0
    rho_arr = None
    if rho is not None:
        valid = feature_validation(valid, rho, c_I)
        rho_arr = as_array(rho, "rho", shape=(m, T))
    return _jpda_marginals_checked(lik, valid, pd_arr, lam, rho_arr,
                                   mode == "nonparametric", logV, method)


def _jpda_marginals_checked(lik, valid, pd_arr, lam, rho_arr, nonparametric, logV, method):
    """:func:`jpda_marginals` after its checks: ``lik`` (m, T) float, ``valid`` (m, T)
    bool (already feature-validated when ``rho_arr`` is given), ``pd_arr`` (T,) float,
    ``lam`` > 0 (1.0 when nonparametric without one), ``rho_arr`` (m, T) float or None,
    ``logV`` (0.0 when parametric), ``method`` one of "auto", "enumerate", "net".  For
    callers whose inputs are valid by construction (a tracker's inner loop)."""
    m, T = valid.shape
    rho = rho_arr
    mode = "nonparametric" if nonparametric else "parametric"
    if m == 0:
        beta = np.zeros((m + 1, T))
        beta[0, :] = 1.0
        return beta, 1
    if method == "auto":
        method = "enumerate" if _product_at_most(valid, ENUMERATE_MAX_PRODUCT) else "net"
    if method == "net":
        logw, log_1mpd = _net_inputs(lik, valid, rho_arr if rho is not None else lik,
                                     rho is not None, pd_arr,
                                     logV if nonparametric else -math.log(lam))
        if nonparametric:
            # phi!/V^phi with phi = m - d: V^-m (m - d)! V^d, the V^d carried by the pairs
            lg_count = np.array([math.lgamma(m - k + 1.0) for k in range(min(m, T) + 1)])
        else:
            lg_count = np.zeros(1)
        beta, n, exp2, status, info = net_marginals(logw, valid, log_1mpd, lg_count)
        if status == 0 and not _marginals_ok(beta, COLUMN_SUM_TOLERANCE):
            status = 3
        log_space = status == 3
        if log_space:
            # not certified in scaled linear arithmetic: the same net in log space
            beta, status, info = net_marginals_log(logw, valid, log_1mpd, lg_count)
            n, exp2, _, _ = net_count(valid)
            if status == 0 and not _marginals_ok(beta, COLUMN_SUM_TOLERANCE):
                status = 4
            if status == 1 and _events_number(n, exp2) <= MAX_ENUMERATED_EVENTS:
                status = 4          # the enumeration is affordable: use it
        if status == 1:
            raise _net_limit_error("valid", valid, info, marginals=True, log_space=log_space)
        if status == 2:
            raise ValueError("every feasible joint event has zero probability "
                             "(check pd = 1 with empty gates, or zero likelihoods)")
        n_events = _events_number(n, exp2)
        if status == 0:
            return beta, n_events
        if n_events > MAX_ENUMERATED_EVENTS:
            raise ValueError(
                f"valid ({_size(valid)}): the hypothesis net's marginals failed their "
                "check (non-finite, or a column not summing to 1 within "
                f"{COLUMN_SUM_TOLERANCE:g}) and the {n_events:.3g} events are more than "
                f"MAX_ENUMERATED_EVENTS = {MAX_ENUMERATED_EVENTS:.0e} to enumerate")
    with np.errstate(divide="ignore"):
        logf = np.log(lik)
        if rho is not None:
            logf = logf + np.log(np.where(valid, np.clip(rho_arr, 0.0, None), 1.0))
        log_pd = np.log(pd_arr)
        log_1mpd = np.log1p(-pd_arr)
    if mode == "parametric":
        logf = logf - math.log(lam)
    logf = np.ascontiguousarray(np.where(valid, logf, -np.inf))
    beta = np.zeros((m + 1, T))
    if not _product_at_most(valid, MAX_ENUMERATED_EVENTS):
        n_ev, exp2, status, _ = net_count(valid)
        n_ev = math.inf if status == 1 else _events_number(n_ev, exp2)
        if n_ev > MAX_ENUMERATED_EVENTS:
            what = ("more feasible events than the hypothesis net can count within its "
                    "limits" if status == 1 else f"{n_ev:.4g} feasible events")
            raise ValueError(
                f"valid ({_size(valid)}) has {what}, more than MAX_ENUMERATED_EVENTS = "
                f"{MAX_ENUMERATED_EVENTS:.0e} to enumerate; use method='net' or 'auto'")
    log_acc, log_miss, log_total, n_events = _enumerate_kernel(
        logf, valid, np.ascontiguousarray(log_pd), np.ascontiguousarray(log_1mpd),
        nonparametric, logV)
    if log_total == -np.inf:
        raise ValueError("every feasible joint event has zero probability "
                         "(check pd = 1 with empty gates, or zero likelihoods)")
    beta[1:, :] = np.exp(log_acc - log_total)
    beta[0, :] = np.exp(log_miss - log_total)
    return beta, int(n_events)


@nb.njit(cache=True)
def _permanent_kernel(A):
    """Permanent of a T x n matrix (T <= n) by Ryser's rectangular formula:
    per(A) = sum_{k=0}^{T-1} (-1)^k C(n-T+k, k) sum_{|S| = T-k} prod_i r_i(S),
    with r_i(S) the sum of row i over the column subset S (inclusion-exclusion
    over the image of the row-to-column map)."""
    T, n = A.shape
    if T == 0:
        return 1.0
    total = 0.0
    for mask in range(1, 1 << n):
        size = 0
        mm = mask
        while mm:
            size += mm & 1
            mm >>= 1
        if size > T:
            continue
        k = T - size
        prod = 1.0
        for i in range(T):
            s = 0.0
            for j in range(n):
                if (mask >> j) & 1:
                    s += A[i, j]
            prod *= s
            if prod == 0.0:
                break
        # C(n - T + k, k)
        c = 1.0
        for q in range(1, k + 1):
            c = c * (n - T + q) / q
        if k % 2 == 0:
            total += c * prod
        else:
            total -= c * prod
    return total


@nb.njit(cache=True)
def _permanent_rows_kernel(A):
    """Permanent of a T x n matrix (T <= n) by a recursion over the columns on subsets
    of rows: ``f_j(S)`` sums the products of the injective maps of the rows in ``S`` into
    the first ``j`` columns; ``f_{j+1}(S) = f_j(S) + sum_{i in S} A[i, j] f_j(S - i)``.
    ``O(n 2^T T)`` operations, no cancellation for non-negative matrices."""
    T, n = A.shape
    f = np.zeros(1 << T)
    f[0] = 1.0
    for j in range(n):
        for S in range((1 << T) - 1, 0, -1):
            v = f[S]
            for i in range(T):
                if (S >> i) & 1:
                    v += f[S ^ (1 << i)] * A[i, j]
            f[S] = v
    return f[(1 << T) - 1]


#: largest operation count :func:`permanent` accepts (a few seconds of CPU time)
MAX_PERMANENT_OPERATIONS = 2**30


def permanent(A):
    """Permanent of a T x n matrix with T <= n: the sum over injective row-to-column maps
    of the products.

    Ryser's rectangular formula (``O(2^n T n)``) when ``n <= 16`` or ``n = T`` (where it
    is the cheaper), otherwise the recursion over subsets of rows (``O(n 2^T T)``); a
    ``ValueError`` names the limit ``MAX_PERMANENT_OPERATIONS`` and the shape when the
    chosen method needs more operations (counted in exact integers: no overflow).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import permanent
    >>> round(permanent(np.array([[1.0, 2.0], [3.0, 4.0]])), 6)    # 1*4 + 2*3
    10.0
    >>> round(permanent(np.ones((2, 3))), 6)                       # 3 * 2 injective maps
    6.0
    """
    A = as_array(A, "A", ndim=2)
    T, n = A.shape
    if T > n:
        raise ValueError(f"A must have no more rows than columns, got shape {A.shape}")
    if T == 0:
        return 1.0
    if n <= 16 or n == T:
        ops, how = 2**n * T * n, "Ryser's formula"
    else:
        ops, how = n * 2**T * T, "the recursion over subsets of rows"
    if ops > MAX_PERMANENT_OPERATIONS:
        raise ValueError(f"A of shape {A.shape}: the permanent needs about {float(ops):.1e} "
                         f"operations ({how}), more than MAX_PERMANENT_OPERATIONS = "
                         f"2**{MAX_PERMANENT_OPERATIONS.bit_length() - 1}")
    if n <= 16 or n == T:
        return float(_permanent_kernel(A))
    return float(_permanent_rows_kernel(np.ascontiguousarray(A)))


def jpda_clusters(valid):
    """Connected components of the track-measurement validation graph.

    Returns a list of ``(track_indices, measurement_indices)`` int arrays, one
    per cluster that contains at least one track (tracks with empty gates
    form singleton clusters with no measurements).  Measurements validated by
    no track belong to no cluster.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.association import jpda_clusters
    >>> valid = np.array([[True, False, False],
    ...                   [True, True, False],
    ...                   [False, False, True]])    # (m = 3 measurements, T = 3 tracks)
    >>> for tracks, meas in jpda_clusters(valid):
    ...     print(tracks.tolist(), meas.tolist())
    ...
    [0, 1] [0, 1]
    [2] [2]
    """
    return _clusters(_check_valid(valid))


def _clusters(valid):
    """:func:`jpda_clusters` of a checked (m, T) boolean ``valid``."""
    m, T = valid.shape
    parent = np.arange(m + T)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    js, ts = np.nonzero(valid)
    for j, t in zip(js, ts):
        ra, rb = find(j), find(m + t)
        if ra != rb:
            parent[ra] = rb
    roots = {}
    for t in range(T):
        roots.setdefault(find(m + t), ([], []))[0].append(t)
    for j in range(m):
        r = find(j)
        if r in roots:
            roots[r][1].append(j)
    return [(np.array(tr, dtype=np.int64), np.array(ms, dtype=np.int64))
            for tr, ms in roots.values()]
