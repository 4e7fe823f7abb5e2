"""The Houles & Bar-Shalom (1989) manoeuvring-target scenario used by Yoon & Ko (sec. 4.3).

Truth: start at (21689, 10840) m with velocity (-8.3, -399.9) m/s (|v| = 399.986,
"400 m/s"), constant speed; a right (clockwise) turn at 60 m/s^2 on [20, 35) s
(turn rate -60/|v| = -0.150005 rad/s) and a left turn at 40 m/s^2 on [55, 70) s
(+40/|v| = +0.100003 rad/s), straight flight otherwise.  (Rounding the rates to
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
