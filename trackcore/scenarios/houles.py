"""The Houles & Bar-Shalom (1989) manoeuvring-target scenario used by Yoon & Ko (sec. 4.3).

Truth: start at (21689, 10840) m with velocity (-8.3, -399.9) m/s (speed 399.986,
"400 m/s"), constant speed; a right (clockwise) turn at 60 m/s^2 on [20, 35) s
(turn rate -60/speed = -0.150005 rad/s) and a left turn at 40 m/s^2 on [55, 70) s
(+40/speed = +0.100003 rad/s), straight flight otherwise.  (Rounding the rates to
-0.15/+0.10 rad/s moves the t = 90 s position by about 1.5 m.)  The final leg passes within 0.71 m of the sensor at
the origin at t = 90.003 s, so the scenario lasts 90 s (scans t = 0, 1, ..., 90).
The truth is propagated in closed form with the exact coordinated-turn
transition, segment by segment.

Sensor: linear Cartesian position measurements, ``R = 400 I`` m^2 (sigma = 20 m
per axis), period 1 s, detection probability ``pd``; Poisson clutter of spatial
density ``clutter_density`` (2e-6 m^-2 in the paper) uniform in a square window
of side ``window`` (2 km, our choice) centred on the true position, i.e. on
average ``clutter_density * window^2`` = 8 false returns per scan.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..core.validation import as_array, as_nonnegative, as_positive, as_probability, as_rng
from ..models.motion import coordinated_turn_transition

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
    "position_failures",
    "gate_miss_failures",
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


def houles_measurements(truth, rng, *, sigma=20.0, pd=1.0, clutter_density=2e-6, window=2000.0,
                        times=None):
    """Simulate the sensor for the true states ``truth`` (K, >= 2) (positions first).

    Each scan holds the target measurement ``truth[k, :2] + N(0, sigma^2 I)``
    with probability ``pd`` and ``Poisson(clutter_density * window^2)`` false
    returns uniform in the ``window`` x ``window`` square centred on the true
    position.  ``rng`` is a ``numpy.random.Generator``.  Returns
    :class:`HoulesScans`.
    """
    truth = as_array(truth, "truth", ndim=2)
    if truth.shape[1] < 2:
        raise ValueError(f"truth must have shape (K, >= 2), got {truth.shape}")
    rng = as_rng(rng)
    sigma = as_nonnegative(sigma, "sigma")
    pd = as_probability(pd, "pd")
    lam = as_nonnegative(clutter_density, "clutter_density")
    window = as_positive(window, "window")
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
    return HoulesScans(times, z, offsets, target_index)


# ---------------------------------------------------------------------- the experiment
class HoulesRun(NamedTuple):
    """One Monte Carlo run of the sec. 4.3 experiment for ``F`` filters.

    Times: ``t = 1 .. 90`` for the error arrays (``t = 1`` is the two-point
    initialisation, common to all filters), ``t = 2 .. 90`` for the rest.
    """
    pos_err2: np.ndarray      # (F, 90) squared position error (m^2), t = 1..90
    vel_err2: np.ndarray      # (F, 90) squared velocity error ((m/s)^2), t = 1..90
    nees: np.ndarray          # (F, 89) NEES of [x, y, vx, vy], t = 2..90
    nis: np.ndarray           # (F, 89) NIS of the target measurement (NaN if missed)
    mu: np.ndarray            # (F, 89, r) model probabilities
    target_gated: np.ndarray  # (F, 89) int8: 1 gated, 0 outside every gate, -1 missed


def houles_imm_trial(rng, model_sets, *, pd=1.0, pg=0.99, clutter_density=2e-6, window=2000.0,
                     sigma=20.0, detect_init=True):
    """One run of the sec. 4.3 experiment: simulate, then run every IMM-PDAF on the same data.

    ``model_sets`` is a sequence of :class:`trackcore.trackers.IMMModelSet`
    (common random numbers: all filters see the same measurements).  Each
    filter starts from the two-point initialisation on the target measurements
    at t = 0 and 1 (``detect_init``: they are always detected), then runs on
    the scans t = 2 .. 90 with the PDA parameters ``pd``, ``pg`` and
    ``clutter_density``.  Returns :class:`HoulesRun`.
    """
    from ..metrics import nees, nis
    from ..trackers.imm_pdaf import imm_pdaf_track_packed, two_point_init

    rng = as_rng(rng)
    times = np.arange(0.0, HOULES_DURATION + 1.0)
    truth = houles_truth(times)
    scans = houles_measurements(truth, rng, sigma=sigma, pd=pd, clutter_density=clutter_density,
                                window=window, times=times)
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
    ni = np.full((nF, K), np.nan)
    mu = np.full((nF, K, r), np.nan)
    gated = np.full((nF, K), -1, dtype=np.int8)
    for f, ms in enumerate(model_sets):
        res = imm_pdaf_track_packed(ms, z, offsets, x0, P0, R, pd=pd, pg=pg,
                                    clutter_density=clutter_density)
        err = res.x - truth[2:]
        pos[f, 0] = np.sum((x0[:2] - truth[1, :2]) ** 2)
        vel[f, 0] = np.sum((x0[2:] - truth[1, 2:]) ** 2)
        pos[f, 1:] = np.sum(err[:, :2] ** 2, axis=1)
        vel[f, 1:] = np.sum(err[:, 2:] ** 2, axis=1)
        ne[f] = nees(err, res.P)
        if detected.any():
            ni[f, detected] = nis(z[tidx[detected]] - res.z_pred[detected], res.S[detected])
            gated[f, detected] = res.gated[tidx[detected]]
        mu[f, :, :ms.F.shape[0]] = res.mu
    return HoulesRun(pos, vel, ne, ni, mu, gated)


# ---------------------------------------------------------------------- Table 1 statistics
#: Scan times of the error statistics (t = 1 .. 90).
HOULES_TIMES = np.arange(1.0, HOULES_DURATION + 1.0)


def houles_windows():
    """Boolean masks over ``t = 1 .. 90``: ``(manoeuvring, non_manoeuvring)``.

    Manoeuvring = {21..40} u {56..75}: the first scan after each turn onset
    through 5 s after its end (40 samples); non-manoeuvring = the other 50.
    With these, total^2 = (40/90) man^2 + (50/90) non^2, the identity that the
    paper's Singer and CAR columns satisfy.
    """
    t = HOULES_TIMES
    man = ((t >= 21) & (t <= 40)) | ((t >= 56) & (t <= 75))
    return man, ~man


def position_failures(pos_err2, threshold=200.0):
    """Runs whose position error exceeds ``threshold`` (m) at any time.

    ``pos_err2`` (..., T) squared errors; returns a bool array of shape (...).
    """
    e = as_array(pos_err2, "pos_err2", ndim=(1, 2, 3), finite=False)
    if np.any(np.isnan(e)) or np.any(e < 0):
        raise ValueError("pos_err2 must hold non-negative squared errors (no NaN)")
    threshold = as_positive(threshold, "threshold")
    return np.any(e > threshold**2, axis=-1)


def gate_miss_failures(target_gated, n_consecutive=3):
    """Runs in which the target measurement was outside every gate on at least
    ``n_consecutive`` consecutive scans (``target_gated`` from :class:`HoulesRun`;
    missed detections, -1, neither count nor break a streak)."""
    g = np.asarray(target_gated)
    if g.ndim < 1 or not np.issubdtype(g.dtype, np.integer):
        raise TypeError("target_gated must be an integer array (1 gated, 0 not, -1 missed)")
    n = int(n_consecutive)
    if n < 1:
        raise ValueError(f"n_consecutive must be >= 1, got {n_consecutive}")
    out = np.zeros(g.shape[:-1], dtype=bool)
    streak = np.zeros(g.shape[:-1], dtype=np.int64)
    for k in range(g.shape[-1]):
        col = g[..., k]
        streak = np.where(col == 0, streak + 1, np.where(col == 1, 0, streak))
        out |= streak >= n
    return out


class HoulesTable(NamedTuple):
    """Table 1 statistics for ``F`` filters, columns (total, manoeuvring, non-manoeuvring).

    ``*_ci`` are bootstrap percentile intervals with shape (..., 2).
    """
    rmse: np.ndarray           # (F, 3) RMSE over non-failed runs (m)
    rmse_ci: np.ndarray        # (F, 3, 2)
    ratio: np.ndarray          # (F, 3) RMSE / RMSE of the reference filter
    ratio_ci: np.ndarray       # (F, 3, 2)
    fail_rate: np.ndarray      # (F,)
    fail_rate_ci: np.ndarray   # (F, 2)
    rmse_all: np.ndarray       # (F, 3) RMSE over all runs (failures included)


def houles_table(pos_err2, failed, rng, *, n_boot=2000, reference=0, level=0.95):
    """Table 1 (RMSE total/manoeuvring/non-manoeuvring, ratios, failure rates) with
    bootstrap confidence intervals.

    ``pos_err2`` (runs, F, 90) squared position errors at t = 1..90;
    ``failed`` (runs, F) bool; the RMSEs pool squared errors over the
    non-failed runs and the window's samples, ``sqrt(mean)``.  The bootstrap
    resamples runs (the same resample for every filter, so ratios are paired).
    """
    e = as_array(pos_err2, "pos_err2", ndim=3)
    runs, nF, T = e.shape
    if T != HOULES_TIMES.size:
        raise ValueError(f"pos_err2 must have {HOULES_TIMES.size} times, got {T}")
    failed = np.asarray(failed)
    if failed.shape != (runs, nF) or failed.dtype != np.bool_:
        raise ValueError(f"failed must be a bool array of shape {(runs, nF)}")
    rng = as_rng(rng)
    n_boot = int(n_boot)
    if n_boot < 1:
        raise ValueError("n_boot must be >= 1")
    if not 0 <= int(reference) < nF:
        raise ValueError(f"reference must index one of the {nF} filters")
    level = as_probability(level, "level", open_low=True, open_high=True)
    man, non = houles_windows()
    masks = [np.ones(T, bool), man, non]
    sums = np.stack([e[:, :, w].sum(axis=2) for w in masks], axis=2)   # (runs, F, 3)
    lens = np.array([w.sum() for w in masks], dtype=float)
    ok = (~failed).astype(float)                                        # (runs, F)

    def stats(weights):
        # weights (B, runs): multiplicity of each run
        num = np.einsum("br,rfw->bfw", weights, sums * ok[:, :, None])
        den = np.einsum("br,rf->bf", weights, ok)[:, :, None] * lens
        with np.errstate(invalid="ignore", divide="ignore"):
            rm = np.sqrt(num / den)
        fr = np.einsum("br,rf->bf", weights, 1.0 - ok) / weights.sum(axis=1)[:, None]
        return rm, rm / rm[:, reference:reference + 1, :], fr

    rm, ra, fr = stats(np.ones((1, runs)))
    W = rng.multinomial(runs, np.full(runs, 1.0 / runs), size=n_boot).astype(float)
    brm, bra, bfr = stats(W)
    q = [(1 - level) / 2 * 100, (1 + level) / 2 * 100]
    all_rm = np.sqrt(sums.sum(axis=0) / (runs * lens))
    return HoulesTable(rm[0], np.moveaxis(np.nanpercentile(brm, q, axis=0), 0, -1), ra[0],
                       np.moveaxis(np.nanpercentile(bra, q, axis=0), 0, -1), fr[0],
                       np.moveaxis(np.percentile(bfr, q, axis=0), 0, -1), all_rm)
