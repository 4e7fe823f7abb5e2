"""The Houles & Bar-Shalom (1989) manoeuvring-target scenario used by Yoon & Ko (sec. 4.3).

Truth: start at (21689, 10840) m with velocity (-8.3, -399.9) m/s (speed 399.986,
"400 m/s"), constant speed; a right (clockwise) turn at 60 m/s^2 on [20, 35) s
(turn rate -60/speed = -0.150005 rad/s) and a left turn at 40 m/s^2 on [55, 70) s
(+40/speed = +0.100003 rad/s), straight flight otherwise.  (Rounding the rates to
-0.15/+0.10 rad/s moves the t = 90 s position by about 1.5 m.)  The final leg passes
within 0.70 m of the sensor at the origin at t = 90.003 s, so the scenario lasts 90 s
(scans t = 0, 1, ..., 90).
The truth is propagated in closed form with the exact coordinated-turn
transition, segment by segment.

Sensor: linear Cartesian position measurements, ``R = 400 I`` m^2 (sigma = 20 m
per axis), period 1 s, detection probability ``pd``; Poisson clutter of spatial
density ``clutter_density`` (2e-6 m^-2 in the paper) uniform in a square window
of side ``window`` (2 km, our choice) centred on the true position, i.e. on
average ``clutter_density * window^2`` = 8 false returns per scan.
"""
from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np

from ..core.validation import (as_array, as_int, as_nonnegative, as_positive, as_probability,
                               as_rng)
from ..models.motion import coordinated_turn_transition
from ..stats import Estimate, bootstrap_ci, mcnemar_exact, paired_diff_ci, rate_ci, ratio_ci

__all__ = [
    "HOULES_INITIAL_STATE",
    "HOULES_TURNS",
    "HOULES_DURATION",
    "houles_truth",
    "HoulesScans",
    "houles_measurements",
    "HoulesRun",
    "houles_imm_trial",
    "HOULES_TIMES",
    "houles_windows",
    "window_mse",
    "position_failures",
    "gate_miss_failures",
    "FailureAnatomy",
    "failure_anatomy",
    "FailureComparison",
    "failure_comparison",
    "FAILURE_DEFINITIONS",
    "failure_grid",
    "rmse_estimate",
    "rmse_ratio",
    "rmse_estimate_mse",
    "rmse_ratio_mse",
    "HoulesTable",
    "houles_table",
]

#: Initial state [x, y, vx, vy] (m, m/s) at t = 0.
HOULES_INITIAL_STATE = (21689.0, 10840.0, -8.3, -399.9)
_SPEED = float(np.hypot(HOULES_INITIAL_STATE[2], HOULES_INITIAL_STATE[3]))
#: Turns as (start s, end s, turn rate rad/s); positive = counter-clockwise (left).
#: The rates are the paper's lateral accelerations (60 and 40 m/s^2) over the speed.
HOULES_TURNS = ((20.0, 35.0, -60.0 / _SPEED), (55.0, 70.0, 40.0 / _SPEED))
#: Duration (s): the final leg reaches the sensor at the origin at t = 90.003 s.
HOULES_DURATION = 90.0


def _segments():
    """Piecewise-constant turn rate as (start time, rate) breakpoints, with the
    state at each breakpoint."""
    starts, rates = [0.0], [0.0]
    for a, b, w in HOULES_TURNS:
        starts += [a, b]
        rates += [w, 0.0]
    states = [np.array(HOULES_INITIAL_STATE, dtype=float)]
    for i in range(1, len(starts)):
        F = coordinated_turn_transition(rates[i - 1], starts[i] - starts[i - 1])
        states.append(F @ states[-1])
    return np.array(starts), np.array(rates), states


def houles_truth(t):
    """True state ``[x, y, vx, vy]`` at times ``t`` (s, >= 0); returns ``(len(t), 4)``.

    A scalar ``t`` gives shape ``(1, 4)``.  Times after 90 s extrapolate the
    final straight leg (the target has reached the sensor by then).

    Examples
    --------
    The start state, and the target next to the sensor at t = 90 s:

    >>> [round(float(v), 1) for v in houles_truth(0.0)[0]]
    [21689.0, 10840.0, -8.3, -399.9]
    >>> x = houles_truth([90.0])[0]
    >>> round(float(np.hypot(x[0], x[1])), 1), round(float(np.hypot(x[2], x[3])), 1)
    (1.5, 400.0)
    """
    t = as_array(t, "t", ndim=(0, 1)).reshape(-1)
    if t.size and t.min() < 0:
        raise ValueError("t must be >= 0 (the scenario starts at t = 0)")
    starts, rates, states = _segments()
    out = np.empty((t.size, 4))
    seg = np.searchsorted(starts, t, side="right") - 1
    for k in range(t.size):
        i = seg[k]
        out[k] = coordinated_turn_transition(rates[i], t[k] - starts[i]) @ states[i]
    return out


class HoulesScans(NamedTuple):
    """Measurements of one Monte Carlo run, packed scan by scan.

    Scan ``k`` (time ``times[k]``) is ``z[offsets[k]:offsets[k + 1]]``, an
    ``(m_k, 2)`` array (``m_k = 0`` is possible); ``target_index[k]`` is the
    row of ``z`` holding the target-originated measurement, or -1 if the target
    was not detected.  Rows within a scan are in random order.

    Examples
    --------
    >>> scans = houles_measurements(houles_truth([0.0, 1.0]), np.random.default_rng(1))
    >>> scans.scan(0).shape, len(scans.scans()), scans.target_index.tolist()
    ((8, 2), 2, [6, 15])
    """
    times: np.ndarray         # (K,)
    z: np.ndarray             # (N, 2)
    offsets: np.ndarray       # (K + 1,) int64
    target_index: np.ndarray  # (K,) int64

    def scan(self, k):
        """The ``(m_k, 2)`` measurements of scan ``k``."""
        return self.z[self.offsets[k]:self.offsets[k + 1]]

    def scans(self):
        """All scans as a list of ``(m_k, 2)`` arrays."""
        return [self.scan(k) for k in range(len(self.times))]


#: the most false returns per scan :func:`houles_measurements` will draw (on average)
_MAX_CLUTTER_PER_SCAN = 1e5


def houles_measurements(truth, rng, *, sigma=20.0, pd=1.0, clutter_density=2e-6, window=2000.0,
                        times=None, outer_window=None):
    """Simulate the sensor for the true states ``truth`` (K, >= 2) (positions first).

    Each scan holds the target measurement ``truth[k, :2] + N(0, sigma^2 I)``
    with probability ``pd`` and ``Poisson(clutter_density * window^2)`` false
    returns uniform in the ``window`` x ``window`` square centred on the true
    position.  ``rng`` is a ``numpy.random.Generator``.  With ``outer_window``
    (m, larger than ``window``) the clutter fills the ``outer_window`` square at
    the same density: the draws above come first, unchanged, and the returns of
    the ring between the two squares are drawn after them and appended to each
    scan, so the target measurements and the inner clutter are those of the same
    generator without the ring.  Returns :class:`HoulesScans`.

    Examples
    --------
    Four scans of the paper's clutter (8 false returns per scan on average), then the
    same draws with the ring out to a 6 km square appended:

    >>> truth = houles_truth(np.arange(0.0, 4.0))
    >>> scans = houles_measurements(truth, np.random.default_rng(1))
    >>> np.diff(scans.offsets).tolist(), scans.target_index.tolist()
    ([8, 8, 12, 8], [4, 14, 24, 30])
    >>> ring = houles_measurements(truth, np.random.default_rng(1), outer_window=6000.0)
    >>> np.diff(ring.offsets).tolist(), bool(np.array_equal(ring.scan(0)[:8], scans.scan(0)))
    ([74, 56, 73, 67], True)
    """
    truth = as_array(truth, "truth", ndim=2)
    if truth.shape[1] < 2:
        raise ValueError(f"truth must have shape (K, >= 2), got {truth.shape}")
    rng = as_rng(rng)
    sigma = as_nonnegative(sigma, "sigma")
    if not sigma <= 1e100:
        raise ValueError(f"sigma must be at most 1e100 m, got {sigma}")
    pd = as_probability(pd, "pd")
    lam = as_nonnegative(clutter_density, "clutter_density")
    window = as_positive(window, "window")
    if not lam * window * window <= _MAX_CLUTTER_PER_SCAN:
        raise ValueError(f"clutter_density * window**2 (false returns expected per scan) must "
                         f"be at most {_MAX_CLUTTER_PER_SCAN:g}, got {lam * window * window:g}")
    K = truth.shape[0]
    if times is None:
        times = np.arange(K, dtype=float)
    else:
        times = as_array(times, "times", shape=(K,))
    detected = rng.random(K) < pd
    n_clutter = rng.poisson(lam * window * window, size=K)
    counts = n_clutter + detected
    offsets = np.zeros(K + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    N = int(offsets[-1])
    z = np.empty((N, 2))
    centres = np.repeat(truth[:, :2], counts, axis=0)
    z[:] = centres + (rng.random((N, 2)) - 0.5) * window
    # the target measurement goes to a random row of its scan
    target_index = np.full(K, -1, dtype=np.int64)
    noise = rng.normal(0.0, sigma, size=(K, 2)) if sigma > 0 else np.zeros((K, 2))
    slot = (rng.random(K) * np.maximum(counts, 1)).astype(np.int64)
    rows = offsets[:-1] + slot
    target_index[detected] = rows[detected]
    z[rows[detected]] = truth[detected, :2] + noise[detected]
    if outer_window is not None:
        return _add_ring(truth, rng, lam, window, outer_window,
                         HoulesScans(times, z, offsets, target_index))
    return HoulesScans(times, z, offsets, target_index)


def _add_ring(truth, rng, lam, window, outer_window, scans):
    """``scans`` with the clutter of the ring between the ``window`` and
    ``outer_window`` squares (centred on the truth) appended to each scan: uniform
    points of the outer square at density ``lam``, those inside the inner square
    dropped (a thinned Poisson process is Poisson)."""
    outer = as_positive(outer_window, "outer_window")
    if not outer > window:
        raise ValueError(f"outer_window must exceed window = {window:g} m, got {outer:g}")
    if not lam * outer * outer <= _MAX_CLUTTER_PER_SCAN:
        raise ValueError(f"clutter_density * outer_window**2 must be at most "
                         f"{_MAX_CLUTTER_PER_SCAN:g}, got {lam * outer * outer:g}")
    K = truth.shape[0]
    n = rng.poisson(lam * outer * outer, size=K)
    u = (rng.random((int(n.sum()), 2)) - 0.5) * outer
    keep = np.any(np.abs(u) > window / 2, axis=1)
    scan = np.repeat(np.arange(K), n)[keep]
    ring = u[keep] + truth[scan, :2]
    extra = np.bincount(scan, minlength=K)
    old = np.diff(scans.offsets)
    offsets = np.zeros(K + 1, dtype=np.int64)
    np.cumsum(old + extra, out=offsets[1:])
    z = np.empty((int(offsets[-1]), 2))
    for k in range(K):
        lo, m = offsets[k], old[k]
        z[lo:lo + m] = scans.z[scans.offsets[k]:scans.offsets[k + 1]]
        z[lo + m:offsets[k + 1]] = ring[scan == k]
    shift = offsets[:-1] - scans.offsets[:-1]
    tidx = np.where(scans.target_index >= 0, scans.target_index + shift, -1)
    return HoulesScans(scans.times, z, offsets, tidx)


# ---------------------------------------------------------------------- the experiment
@lru_cache(maxsize=1)
def _scan_truth():
    """The true states at the scan times t = 0, 1, ..., 90 (computed once, read-only)."""
    truth = houles_truth(np.arange(0.0, HOULES_DURATION + 1.0))
    truth.setflags(write=False)
    return truth


class HoulesRun(NamedTuple):
    """One Monte Carlo run of the sec. 4.3 experiment for ``F`` filters.

    Times: ``t = 1 .. 90`` for the error arrays (``t = 1`` is the two-point
    initialisation, common to all filters), ``t = 2 .. 90`` for the rest.
    ``pred_err`` is the error of the predicted position (the mixture's predicted
    measurement before the update) in the target's own frame: along-track and
    lateral (positive to the right of the true heading, the TOM convention).

    Examples
    --------
    >>> from trackcore.trackers import singer_imm_model_set
    >>> run = houles_imm_trial(np.random.default_rng(5), [singer_imm_model_set()])
    >>> run.pos_err2.shape, run.nis.shape, run.mu.shape, run.pred_err.shape
    ((1, 90), (1, 89), (1, 89, 3), (1, 89, 2))
    """
    pos_err2: np.ndarray      # (F, 90) squared position error (m^2), t = 1..90
    vel_err2: np.ndarray      # (F, 90) squared velocity error ((m/s)^2), t = 1..90
    nees: np.ndarray          # (F, 89) NEES of [x, y, vx, vy] (4 dof), t = 2..90
    nees_pos: np.ndarray      # (F, 89) NEES of the position [x, y] (2 dof)
    nees_vel: np.ndarray      # (F, 89) NEES of the velocity [vx, vy] (2 dof)
    nis: np.ndarray           # (F, 89) NIS of the target measurement (NaN if missed)
    mu: np.ndarray            # (F, 89, r) model probabilities
    target_gated: np.ndarray  # (F, 89) int8: 1 gated, 0 outside every gate, -1 missed
    pred_err: np.ndarray      # (F, 89, 2) predicted-position error (along, lateral) (m)


def houles_imm_trial(rng, model_sets, *, pd=1.0, pg=0.99, clutter_density=2e-6, window=2000.0,
                     sigma=20.0, detect_init=True, outer_window=None):
    """One run of the sec. 4.3 experiment: simulate, then run every IMM-PDAF on the same data.

    ``model_sets`` is a sequence of :class:`trackcore.trackers.IMMModelSet`
    (common random numbers: all filters see the same measurements, and the
    measurements do not depend on the filters, so runs with the same generator
    seed see the same data whatever the model sets).  Each filter starts from
    the two-point initialisation on the target measurements at t = 0 and 1
    (``detect_init``: they are always detected), then runs on the scans
    t = 2 .. 90 with the PDA parameters ``pd``, ``pg`` and ``clutter_density``;
    ``window`` and ``outer_window`` as in :func:`houles_measurements`.
    Returns :class:`HoulesRun`.

    Examples
    --------
    Singer and CAR on the same measurements; their RMSE (m) per window:

    >>> from trackcore.trackers import car_imm_model_set, singer_imm_model_set
    >>> sets = [singer_imm_model_set(), car_imm_model_set(sigma_cv=5.0)]
    >>> run = houles_imm_trial(np.random.default_rng(5), sets)
    >>> np.sqrt(window_mse(run.pos_err2)).round(1).tolist()
    [[27.0, 31.3, 22.9], [26.1, 28.9, 23.6]]
    >>> position_failures(run.pos_err2).tolist()
    [False, False]
    """
    from ..metrics import nees, nis
    from ..trackers.imm_pdaf import IMMModelSet, imm_pdaf_track_packed, two_point_init

    rng = as_rng(rng)
    if isinstance(model_sets, IMMModelSet) or not hasattr(model_sets, "__len__") \
            or len(model_sets) == 0:
        raise TypeError("model_sets must be a non-empty sequence of IMMModelSet")
    for i, ms in enumerate(model_sets):
        if not isinstance(ms, IMMModelSet):
            raise TypeError(f"model_sets[{i}] must be an IMMModelSet, got {type(ms).__name__}")
    truth = _scan_truth()
    times = np.arange(0.0, HOULES_DURATION + 1.0)
    scans = houles_measurements(truth, rng, sigma=sigma, pd=pd, clutter_density=clutter_density,
                                window=window, times=times, outer_window=outer_window)
    init = []
    for k in (0, 1):
        i = scans.target_index[k]
        if i >= 0:
            init.append(scans.z[i])
        elif detect_init:
            init.append(truth[k, :2] + rng.normal(0.0, sigma, 2))
        else:
            raise ValueError("the target was not detected at t = 0 or 1 (detect_init=False)")
    R = sigma**2 * np.eye(2)
    x0, P0 = two_point_init(init[0], init[1], R)
    lo = scans.offsets[2]
    z = scans.z[lo:]
    offsets = scans.offsets[2:] - lo
    tidx = scans.target_index[2:] - lo
    detected = tidx >= 0
    nF = len(model_sets)
    K = offsets.size - 1
    r = max(ms.F.shape[0] for ms in model_sets)
    pos = np.empty((nF, K + 1))
    vel = np.empty((nF, K + 1))
    ne = np.empty((nF, K))
    ne_p = np.empty((nF, K))
    ne_v = np.empty((nF, K))
    ni = np.full((nF, K), np.nan)
    mu = np.full((nF, K, r), np.nan)
    gated = np.full((nF, K), -1, dtype=np.int8)
    perr = np.empty((nF, K, 2))
    tr = truth[2:]
    speed = np.hypot(tr[:, 2], tr[:, 3])
    fwd = tr[:, 2:] / speed[:, None]
    right = np.column_stack([fwd[:, 1], -fwd[:, 0]])
    for f, ms in enumerate(model_sets):
        res = imm_pdaf_track_packed(ms, z, offsets, x0, P0, R, pd=pd, pg=pg,
                                    clutter_density=clutter_density)
        err = res.x - tr
        pos[f, 0] = np.sum((x0[:2] - truth[1, :2]) ** 2)
        vel[f, 0] = np.sum((x0[2:] - truth[1, 2:]) ** 2)
        pos[f, 1:] = np.sum(err[:, :2] ** 2, axis=1)
        vel[f, 1:] = np.sum(err[:, 2:] ** 2, axis=1)
        ne[f] = nees(err, res.P)
        ne_p[f] = nees(err[:, :2], res.P[:, :2, :2])
        ne_v[f] = nees(err[:, 2:], res.P[:, 2:, 2:])
        if detected.any():
            ni[f, detected] = nis(z[tidx[detected]] - res.z_pred[detected], res.S[detected])
            gated[f, detected] = res.gated[tidx[detected]]
        mu[f, :, :ms.F.shape[0]] = res.mu
        pe = res.z_pred - tr[:, :2]
        perr[f, :, 0] = np.sum(pe * fwd, axis=1)
        perr[f, :, 1] = np.sum(pe * right, axis=1)
    return HoulesRun(pos, vel, ne, ne_p, ne_v, ni, mu, gated, perr)


# ---------------------------------------------------------------------- Table 1 statistics
#: Scan times of the error statistics (t = 1 .. 90).
HOULES_TIMES = np.arange(1.0, HOULES_DURATION + 1.0)
_WINDOWS = ("total", "manoeuvring", "non-manoeuvring")


def houles_windows():
    """Boolean masks over ``t = 1 .. 90``: ``(manoeuvring, non_manoeuvring)``.

    Manoeuvring = {21..40} u {56..75}: the first scan after each turn onset
    through 5 s after its end (40 samples); non-manoeuvring = the other 50.
    With these, total^2 = (40/90) man^2 + (50/90) non^2, the identity that the
    paper's Singer and CAR columns satisfy.

    Examples
    --------
    >>> man, non = houles_windows()
    >>> int(man.sum()), int(non.sum()), HOULES_TIMES[man][:3].tolist()
    (40, 50, [21.0, 22.0, 23.0])
    """
    t = HOULES_TIMES
    man = ((t >= 21) & (t <= 40)) | ((t >= 56) & (t <= 75))
    return man, ~man


def _squared(threshold):
    """``threshold**2`` for a positive float, ``inf`` where the square overflows."""
    return threshold**2 if threshold < 1e150 else float("inf")


def _errors(pos_err2, name="pos_err2"):
    e = as_array(pos_err2, name, ndim=(1, 2, 3), finite=False)
    if np.any(np.isnan(e)) or np.any(e < 0):
        raise ValueError(f"{name} must hold non-negative squared errors (no NaN)")
    if e.shape[-1] != HOULES_TIMES.size:
        raise ValueError(f"{name} must have {HOULES_TIMES.size} times (t = 1..90) on its last "
                         f"axis, got shape {e.shape}")
    return e


def _squared_errors(a, name):
    """A (runs, filters) array of squared errors: non-negative, no NaN."""
    e = as_array(a, name, ndim=2, finite=False)
    if np.any(np.isnan(e)) or np.any(e < 0):
        raise ValueError(f"{name} must hold non-negative squared errors (no NaN)")
    if e.shape[0] < 2:
        raise ValueError(f"{name} must hold at least 2 runs, got {e.shape[0]}")
    return e


def window_mse(pos_err2):
    """Per-run mean squared position error over the three windows of Table 1.

    ``pos_err2`` (..., 90) squared errors at t = 1..90; returns (..., 3) for
    (total, manoeuvring, non-manoeuvring).  The pooled RMSE of a set of runs is
    the square root of the mean of these over the runs.

    Examples
    --------
    A run with a 10 m error throughout, and one with a 250 m excursion at t = 31 s:

    >>> e = np.full((2, 90), 100.0)
    >>> e[1, 30] = 250.0**2
    >>> window_mse(e).round(1).tolist()
    [[100.0, 100.0, 100.0], [793.3, 1660.0, 100.0]]
    """
    e = _errors(pos_err2)
    if not np.all(np.isfinite(e)):
        raise ValueError("pos_err2 must be finite (a mean squared error over an infinite "
                         "error is not a number to report)")
    return _window_mse(e)


def _window_mse(e):
    """:func:`window_mse` of checked errors (the tables call it on every run, failed
    runs included, and drop the failed ones afterwards)."""
    man, non = houles_windows()
    return np.stack([e.mean(axis=-1), e[..., man].mean(axis=-1), e[..., non].mean(axis=-1)],
                    axis=-1)


def position_failures(pos_err2, threshold=200.0):
    """Runs whose position error exceeds ``threshold`` (m) at any time.

    ``pos_err2`` (..., T) squared errors; returns a bool array of shape (...).

    Examples
    --------
    >>> e = np.full((2, 90), 100.0)
    >>> e[1, 30] = 250.0**2
    >>> position_failures(e).tolist(), position_failures(e, threshold=300.0).tolist()
    ([False, True], [False, False])
    """
    e = as_array(pos_err2, "pos_err2", ndim=(1, 2, 3), finite=False)
    if np.any(np.isnan(e)) or np.any(e < 0):
        raise ValueError("pos_err2 must hold non-negative squared errors (no NaN)")
    threshold = as_positive(threshold, "threshold")
    return np.any(e > _squared(threshold), axis=-1)


def gate_miss_failures(target_gated, n_consecutive=3):
    """Runs in which the target measurement was outside every gate on at least
    ``n_consecutive`` consecutive scans (``target_gated`` from :class:`HoulesRun`;
    missed detections, -1, neither count nor break a streak).

    Examples
    --------
    A miss (-1) inside a streak of scans outside the gate does not break it:

    >>> g = np.array([[1, 0, 0, -1, 0, 1], [1, 0, 1, 0, 0, 1]], dtype=np.int8)
    >>> gate_miss_failures(g).tolist(), gate_miss_failures(g, n_consecutive=2).tolist()
    ([True, False], [True, True])
    """
    g = np.asarray(target_gated)
    if g.ndim < 1 or not np.issubdtype(g.dtype, np.integer):
        raise TypeError("target_gated must be an integer array (1 gated, 0 not, -1 missed)")
    if g.size and not np.all((g == 1) | (g == 0) | (g == -1)):
        bad = sorted(set(np.unique(g).tolist()) - {-1, 0, 1})
        raise ValueError(f"target_gated must hold only 1 (gated), 0 (outside every gate) and "
                         f"-1 (missed), got {bad[:5]}")
    n = as_int(n_consecutive, "n_consecutive", minimum=1)
    out = np.zeros(g.shape[:-1], dtype=bool)
    streak = np.zeros(g.shape[:-1], dtype=np.int64)
    for k in range(g.shape[-1]):
        col = g[..., k]
        streak = np.where(col == 0, streak + 1, np.where(col == 1, 0, streak))
        out |= streak >= n
    return out


class FailureAnatomy(NamedTuple):
    """When and how runs fail (see :func:`failure_anatomy`).


    Examples
    --------
    >>> e = np.full((1, 90), 100.0)
    >>> e[0, 30:33] = 250.0**2
    >>> failure_anatomy(e).time_lost.tolist()
    [3]
    """
    failed: np.ndarray     # (...) bool: error above the threshold at some time
    onset: np.ndarray      # (...) first time (s) above the threshold, NaN if never
    permanent: np.ndarray  # (...) bool: still above the threshold at t = 90 s
    time_lost: np.ndarray  # (...) number of scans above the threshold


def failure_anatomy(pos_err2, threshold=200.0):
    """Onset time, permanence and duration of every failure (``pos_err2`` (..., 90)).

    A run fails when its position error exceeds ``threshold`` (m) at some time
    t = 1..90 (as :func:`position_failures`); ``onset`` is the first such time
    and ``permanent`` says whether the error is still above the threshold at the
    last scan.

    Examples
    --------
    The second run exceeds 200 m at t = 31 s only, and recovers:

    >>> e = np.full((2, 90), 100.0)
    >>> e[1, 30] = 250.0**2
    >>> a = failure_anatomy(e)
    >>> a.failed.tolist(), a.onset.tolist(), a.permanent.tolist(), a.time_lost.tolist()
    ([False, True], [nan, 31.0], [False, False], [0, 1])
    """
    e = _errors(pos_err2)
    threshold = as_positive(threshold, "threshold")
    above = e > _squared(threshold)
    failed = above.any(axis=-1)
    first = np.argmax(above, axis=-1)
    onset = np.where(failed, HOULES_TIMES[first], np.nan)
    return FailureAnatomy(failed, onset, above[..., -1], above.sum(axis=-1))


class FailureComparison(NamedTuple):
    """Paired failure outcomes of two filters on the same runs (see :func:`failure_comparison`).


    Examples
    --------
    >>> c = failure_comparison(np.array([[True, False]] * 3 + [[False, True]] * 37), 0, 1)
    >>> c.only_a, c.only_b
    (3, 37)
    """
    difference: Estimate  # rate of A minus rate of B, paired (Newcombe) interval
    only_a: int           # runs that A failed and B did not
    only_b: int           # runs that B failed and A did not
    p_value: float        # exact two-sided McNemar test on the discordant runs


def failure_comparison(failed, a, b):
    """Failure rate of filter ``a`` minus that of filter ``b`` on the same runs.

    ``failed`` (runs, filters) bool.  Returns :class:`FailureComparison`: the paired
    difference of the rates with its interval (:func:`trackcore.stats.paired_diff_ci` on
    the 0/1 outcomes) and the exact McNemar p-value (:func:`trackcore.stats.mcnemar_exact`)
    on the runs where exactly one of the two failed.

    Examples
    --------
    Filter 0 fails in 6 of 20 runs, filter 1 in none:

    >>> failed = np.array([[True, False]] * 6 + [[False, False]] * 14)
    >>> c = failure_comparison(failed, 0, 1)
    >>> f"{c.difference.value:.2f}", c.only_a, c.only_b, round(c.p_value, 4)
    ('0.30', 6, 0, 0.0312)
    """
    failed = np.asarray(failed)
    if failed.ndim != 2 or failed.dtype != np.bool_:
        raise ValueError(f"failed must be a bool array of shape (runs, filters), got "
                         f"{failed.dtype} {failed.shape}")
    if failed.shape[0] < 2:
        raise ValueError("failed must hold at least 2 runs")
    nF = failed.shape[1]
    a = _filter_index(a, "a", nF)
    b = _filter_index(b, "b", nF)
    fa, fb = failed[:, a], failed[:, b]
    only_a, only_b = int(np.sum(fa & ~fb)), int(np.sum(~fa & fb))
    # 0/1 runs: Newcombe's paired interval, which keeps a width with no discordant run
    diff = paired_diff_ci(fa.astype(float), fb.astype(float))
    return FailureComparison(diff, only_a, only_b, mcnemar_exact(only_a, only_b))


#: The chapter's failure definitions (the registry's ``failure`` reading), in order.
FAILURE_DEFINITIONS = (
    "error > 200 m at some time",
    "error > 300 m at some time",
    "error > 500 m at some time",
    "error > 1000 m at some time",
    "still > 200 m at t = 90 s",
    "3 gate misses in a row",
)


class FailureCell(NamedTuple):
    """One failure definition on the runs of one gate (see :func:`failure_grid`; a
    result record, not exported)."""
    rate: tuple                      # per filter: failure rate with its interval
    singer_minus_tom: FailureComparison
    tom_minus_car: FailureComparison
    singer_minus_car: FailureComparison
    failed: np.ndarray               # (runs, filters) bool: the runs that failed


def failure_grid(max_err2, last_err2, gate_missed, *, singer=0, car=1, tom=2):
    """Every failure definition of :data:`FAILURE_DEFINITIONS` on one gate's runs.

    ``max_err2`` and ``last_err2`` (runs, filters): the largest and the last (t = 90 s)
    squared position error of each run; ``gate_missed`` (runs, filters) bool: the run
    met the gate-miss definition.  ``singer``, ``car`` and ``tom`` index the filters
    compared.  Returns ``{definition: FailureCell}``: each filter's rate (exact
    interval) and the paired differences Singer − TOM, TOM − CAR, Singer − CAR
    (:func:`failure_comparison`), and the failed runs.

    Examples
    --------
    Singer (filter 0) exceeds 200 m, but not 300 m, in 3 of 40 runs:

    >>> mx = np.array([[250.0, 150.0, 120.0]] * 3 + [[100.0] * 3] * 37) ** 2
    >>> last, miss = np.full((40, 3), 100.0), np.zeros((40, 3), dtype=bool)
    >>> grid = failure_grid(mx, last, miss)
    >>> cell = grid["error > 200 m at some time"]
    >>> f"{cell.rate[0]:.1%}", cell.singer_minus_tom.only_a
    ('7.5 [2.6, 19.9] %', 3)
    >>> f"{grid['error > 300 m at some time'].rate[0]:.1%}"
    '0.0 [0.0, 8.8] %'
    """
    mx = _squared_errors(max_err2, "max_err2")
    last = _squared_errors(last_err2, "last_err2")
    if last.shape != mx.shape:
        raise ValueError(f"max_err2 and last_err2 must have one shape (runs, filters), "
                         f"got {mx.shape} and {last.shape}")
    miss = np.asarray(gate_missed)
    if miss.dtype != np.bool_ or miss.shape != mx.shape:
        raise ValueError(f"gate_missed must be a bool array of shape {mx.shape}, got "
                         f"{miss.dtype} {miss.shape}")
    failed = {d: mx > _squared(h) for d, h in zip(FAILURE_DEFINITIONS[:4],
                                                   (200.0, 300.0, 500.0, 1000.0))}
    failed[FAILURE_DEFINITIONS[4]] = last > _squared(200.0)
    failed[FAILURE_DEFINITIONS[5]] = miss
    out = {}
    for d, fl in failed.items():
        rates = tuple(rate_ci(fl[:, f], fl.shape[0]) for f in range(fl.shape[1]))
        out[d] = FailureCell(rates, failure_comparison(fl, singer, tom),
                             failure_comparison(fl, tom, car),
                             failure_comparison(fl, singer, car), fl)
    return out


def _window_index(window):
    if window not in _WINDOWS:
        raise ValueError(f"window must be one of {_WINDOWS}, got {window!r}")
    return _WINDOWS.index(window)


def _runs_filters(pos_err2, failed):
    e = _errors(pos_err2)
    if e.ndim != 3:
        raise ValueError(f"pos_err2 must have shape (runs, filters, 90), got {e.shape}")
    failed = np.asarray(failed)
    if failed.shape != e.shape[:2] or failed.dtype != np.bool_:
        raise ValueError(f"failed must be a bool array of shape {e.shape[:2]}")
    return e, failed


def _filter_index(i, name, nF):
    i = as_int(i, name, minimum=0)
    if i >= nF:
        raise ValueError(f"{name} must index one of the {nF} filters, got {i}")
    return i


def _pooled_rmse(cols):
    """statistic for bootstrap_ci: cols (b, n, 2) = [mse, ok] -> pooled RMSE over ok runs
    (NaN for a resample without a surviving run; the bootstrap drops it)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.sum(cols[..., 0] * cols[..., 1], axis=-1)
                       / np.sum(cols[..., 1], axis=-1))


def _pooled_ratio(cols):
    """cols (b, n, 4) = [mse_a, ok_a, mse_b, ok_b] -> RMSE_a / RMSE_b, each over its own ok runs."""
    return _pooled_rmse(cols[..., :2]) / _pooled_rmse(cols[..., 2:])


def _mse_failed(mse, failed):
    """Checked per-run window mean squares (runs, filters, 3) and failures (runs, filters)."""
    m = as_array(mse, "mse", ndim=3, finite=False)
    if m.shape[-1] != len(_WINDOWS):
        raise ValueError(f"mse must have shape (runs, filters, {len(_WINDOWS)}) (windows "
                         f"{_WINDOWS}), got {m.shape}")
    if np.any(np.isnan(m)) or np.any(m < 0):
        raise ValueError("mse must hold non-negative mean squared errors (no NaN)")
    failed = np.asarray(failed)
    if failed.shape != m.shape[:2] or failed.dtype != np.bool_:
        raise ValueError(f"failed must be a bool array of shape {m.shape[:2]}")
    return m, failed


def rmse_estimate(pos_err2, failed, f=0, *, window="total"):
    """Pooled RMSE (m) of filter ``f`` over the runs it did not fail, with its BCa
    bootstrap interval over runs (:func:`trackcore.stats.bootstrap_ci`).

    ``pos_err2`` (runs, filters, 90), ``failed`` (runs, filters) bool; ``window``
    is ``"total"``, ``"manoeuvring"`` or ``"non-manoeuvring"``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> e = rng.chisquare(2, size=(50, 1, 90)) * 200.0
    >>> f"{rmse_estimate(e, np.zeros((50, 1), dtype=bool)):.1f}"
    '20.2 [19.9, 20.4]'
    """
    e, failed = _runs_filters(pos_err2, failed)
    return _rmse_estimate(_window_mse(e), failed, f, window)


def rmse_estimate_mse(mse, failed, f=0, *, window="total"):
    """:func:`rmse_estimate` from the per-run window mean squares ``mse`` (runs,
    filters, 3) = :func:`window_mse` of ``pos_err2``: the same numbers, bit for bit,
    from stored per-run metrics instead of the error series.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> e = rng.chisquare(2, size=(50, 1, 90)) * 200.0
    >>> failed = np.zeros((50, 1), dtype=bool)
    >>> rmse_estimate_mse(window_mse(e), failed) == rmse_estimate(e, failed)
    True
    """
    m, failed = _mse_failed(mse, failed)
    return _rmse_estimate(m, failed, f, window)


def _rmse_estimate(mse, failed, f, window):
    f = _filter_index(f, "f", mse.shape[1])
    w = _window_index(window)
    ok = ~failed[:, f]
    if ok.sum() < 2:
        raise ValueError(f"filter {f} survives fewer than 2 runs; no RMSE interval")
    m = np.where(ok, mse[:, f, w], 0.0)
    return bootstrap_ci(_pooled_rmse, np.column_stack([m, ok.astype(float)]))


def rmse_ratio(pos_err2, failed, num, den=0, *, window="total", survivors="own"):
    """RMSE of filter ``num`` as a fraction of filter ``den``'s, with a paired interval.

    ``survivors="own"`` (Table 1's definition): each filter's RMSE pools the runs
    *it* did not fail; the interval is a paired BCa bootstrap over runs (a
    resample draws whole runs, with every filter's errors and failures).
    ``survivors="common"``: only the runs where **no** filter in ``failed``
    failed; the interval is :func:`trackcore.stats.ratio_ci` of the per-run
    mean squared errors, whose square root is the RMSE ratio.

    Examples
    --------
    Filter 1 has half the mean squared error of filter 0, so about 71 % of its RMSE:

    >>> rng = np.random.default_rng(0)
    >>> e = rng.chisquare(2, size=(50, 2, 90)) * np.array([200.0, 100.0])[:, None]
    >>> failed = np.zeros((50, 2), dtype=bool)
    >>> f"{rmse_ratio(e, failed, 1, 0):.1%}"
    '70.5 [69.2, 72.0] %'
    """
    e, failed = _runs_filters(pos_err2, failed)
    return _rmse_ratio(_window_mse(e), failed, num, den, window, survivors)


def rmse_ratio_mse(mse, failed, num, den=0, *, window="total", survivors="own"):
    """:func:`rmse_ratio` from the per-run window mean squares ``mse`` (runs, filters,
    3) = :func:`window_mse` of ``pos_err2`` (the same numbers, bit for bit).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> e = rng.chisquare(2, size=(50, 2, 90)) * np.array([200.0, 100.0])[:, None]
    >>> failed = np.zeros((50, 2), dtype=bool)
    >>> rmse_ratio_mse(window_mse(e), failed, 1, 0) == rmse_ratio(e, failed, 1, 0)
    True
    """
    m, failed = _mse_failed(mse, failed)
    return _rmse_ratio(m, failed, num, den, window, survivors)


def _rmse_ratio(mse, failed, num, den, window, survivors):
    nF = mse.shape[1]
    a = _filter_index(num, "num", nF)
    b = _filter_index(den, "den", nF)
    w = _window_index(window)
    if survivors not in ("own", "common"):
        raise ValueError(f"survivors must be 'own' or 'common', got {survivors!r}")
    mse = mse[:, :, w]
    if survivors == "own":
        oka, okb = ~failed[:, a], ~failed[:, b]
        if oka.sum() < 2 or okb.sum() < 2:
            raise ValueError("each filter must survive at least 2 runs")
        cols = np.column_stack([np.where(oka, mse[:, a], 0.0), oka, np.where(okb, mse[:, b], 0.0),
                                okb]).astype(float)
        return bootstrap_ci(_pooled_ratio, cols)
    common = ~failed.any(axis=1)
    if common.sum() < 2:
        raise ValueError("fewer than 2 runs where no filter failed")
    est = ratio_ci(mse[common, a], mse[common, b])
    return Estimate(float(np.sqrt(est.value)), float(np.sqrt(est.lo)), float(np.sqrt(est.hi)),
                    est.level, est.n, est.method + " (common survivors, ratio of mean squares)")


class HoulesTable(NamedTuple):
    """Table 1 for ``F`` filters; windows (total, manoeuvring, non-manoeuvring).

    Every entry is a :class:`trackcore.stats.Estimate` (value and 95 % interval):
    ``rmse[f][w]`` over the runs filter ``f`` did not fail; ``ratio[f][w]``
    and ``ratio_common[f][w]`` as :func:`rmse_ratio` with ``survivors="own"`` and
    ``"common"`` (the reference filter's ratio is exactly 1); ``fail_rate[f]``
    with its Wilson interval.

    Examples
    --------
    >>> e = np.random.default_rng(0).chisquare(2, size=(50, 1, 90)) * 200.0
    >>> failed = np.zeros((50, 1), dtype=bool)
    >>> failed[0] = True
    >>> table = houles_table(e, failed)
    >>> table.n_ok.tolist(), table.n_common, f"{table.ratio[0][0]:.0%}"
    ([49], 49, '100 [100, 100] %')
    """
    rmse: tuple
    ratio: tuple
    ratio_common: tuple
    fail_rate: tuple
    n_ok: np.ndarray      # (F,) runs each filter survived
    n_common: int         # runs that no filter failed
    rmse_all: np.ndarray  # (F, 3) RMSE over all runs, failures included (m)


def houles_table(pos_err2, failed, *, reference=0):
    """Table 1 (RMSE total/manoeuvring/non-manoeuvring, ratios to ``reference``,
    failure rates) with the book's 95 % intervals (see :class:`HoulesTable`).

    ``pos_err2`` (runs, F, 90) squared position errors at t = 1..90;
    ``failed`` (runs, F) bool.

    Examples
    --------
    One filter over 50 runs, one of them failed:

    >>> e = np.random.default_rng(0).chisquare(2, size=(50, 1, 90)) * 200.0
    >>> failed = np.zeros((50, 1), dtype=bool)
    >>> failed[0] = True
    >>> table = houles_table(e, failed)
    >>> f"{table.rmse[0][0]:.1f}", f"{table.fail_rate[0]:.1%}"
    ('20.2 [19.9, 20.4]', '2.0 [0.4, 10.5] %')
    """
    e, failed = _runs_filters(pos_err2, failed)
    runs, nF, _ = e.shape
    ref = _filter_index(reference, "reference", nF)
    one = Estimate(1.0, 1.0, 1.0, n=runs, method="reference")
    rmse, ratio, common = [], [], []
    for f in range(nF):
        rmse.append(tuple(rmse_estimate(e, failed, f, window=w) for w in _WINDOWS))
        ratio.append(tuple(one if f == ref else rmse_ratio(e, failed, f, ref, window=w)
                           for w in _WINDOWS))
        common.append(tuple(one if f == ref else
                            rmse_ratio(e, failed, f, ref, window=w, survivors="common")
                            for w in _WINDOWS))
    fail = tuple(rate_ci(int(failed[:, f].sum()), runs) for f in range(nF))
    all_rm = np.sqrt(_window_mse(e).mean(axis=0))
    return HoulesTable(tuple(rmse), tuple(ratio), tuple(common), fail,
                       (~failed).sum(axis=0), int((~failed.any(axis=1)).sum()), all_rm)
