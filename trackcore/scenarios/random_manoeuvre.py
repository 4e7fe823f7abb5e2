"""Random-manoeuvre trajectories of Yoon & Ko sec. 4.1 (Figs 3-4).

The paper drives a target for 10 000 s with accelerations that follow the
random walk of its eq. (9), ``delta(k+1) = delta(k) + w(k)``, over segments of
Poisson-distributed duration, and compares the statistics of the Cartesian
acceleration components ``(a_x, a_y)`` with those of the target-oriented ones
``(a_f, a_s)`` (forward, lateral).  It gives neither the noise levels, the
mean segment length, the speed nor what happens between segments; the
generators below are the chapter's documented choices (book chapter
"Target-oriented velocity model", *Choices we made*):

* dt = 1 s, start at the origin at 200 m/s along +x; segment durations
  ``max(1, Poisson(mean_duration))``, back to back.
* **Scenario 1** (:func:`random_manoeuvre_xy`): ``a_x`` and ``a_y`` are
  independent eq.-(9) walks (``sigma_w`` per step), each reset to 0 at the start
  of its own segments.
* **Scenario 2** (:func:`random_manoeuvre_turn`): the forward acceleration
  ``a_f`` is an eq.-(9) walk reset at every segment; the turn rate ``omega`` is
  an eq.-(9) walk that is not reset and is reflected at ``|omega| <= omega_max``;
  the speed is clipped to ``speed_limits`` (the forward acceleration reported is
  the one actually applied, 0 while the speed sits at a limit); the centripetal
  acceleration is ``V omega``.

The lateral component follows the TOM convention of :mod:`trackcore.models.tom`
(``+`` = right of the heading): ``[a_f, a_s] = R(psi) [a_x, a_y]`` with the
heading ``psi`` of the velocity, so a left (counter-clockwise) turn has
``a_s = -V omega < 0``.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.validation import as_array, as_int, as_nonnegative, as_positive, as_rng

__all__ = [
    "RandomManoeuvre",
    "random_manoeuvre_xy",
    "random_manoeuvre_turn",
    "forward_lateral",
    "cross_correlation_coefficient",
]


class RandomManoeuvre(NamedTuple):
    """A sampled random-manoeuvre trajectory (``n`` samples, period ``dt``).

    Examples
    --------
    What :func:`random_manoeuvre_xy` and :func:`random_manoeuvre_turn` return:

    >>> tr = random_manoeuvre_xy(np.random.default_rng(0), n=100)
    >>> tr.t.shape, tr.position.shape, tr.velocity.shape, tr.accel_xy.shape, tr.accel_fs.shape
    ((100,), (100, 2), (100, 2), (100, 2), (100, 2))
    """
    t: np.ndarray          # (n,) s
    position: np.ndarray   # (n, 2) m
    velocity: np.ndarray   # (n, 2) m/s
    accel_xy: np.ndarray   # (n, 2) [a_x, a_y] m/s^2
    accel_fs: np.ndarray   # (n, 2) [a_f, a_s] m/s^2 (a_s > 0: to the right)


def _segment_starts(rng, n, mean_duration):
    """Boolean (n,) array: True where a new segment starts (always at 0)."""
    starts = np.zeros(n, dtype=np.bool_)
    k = 0
    while k < n:
        starts[k] = True
        k += max(1, int(rng.poisson(mean_duration)))
    return starts


@nb.njit(cache=True)
def _walk_with_resets(w, starts, out):
    d = 0.0
    for k in range(w.shape[0]):
        if starts[k]:
            d = 0.0
        out[k] = d
        d += w[k]


@nb.njit(cache=True)
def _integrate_xy(a, dt, v0, pos, vel):
    vx, vy, x, y = v0[0], v0[1], 0.0, 0.0
    for k in range(a.shape[0]):
        pos[k, 0] = x
        pos[k, 1] = y
        vel[k, 0] = vx
        vel[k, 1] = vy
        x += vx * dt + 0.5 * a[k, 0] * dt * dt
        y += vy * dt + 0.5 * a[k, 1] * dt * dt
        vx += a[k, 0] * dt
        vy += a[k, 1] * dt


@nb.njit(cache=True)
def _turn_kernel(af, w_omega, dt, speed0, omega_max, vmin, vmax, pos, vel, acc):
    x, y, psi, V, omega = 0.0, 0.0, 0.0, speed0, 0.0
    for k in range(af.shape[0]):
        c, s = math.cos(psi), math.sin(psi)
        pos[k, 0] = x
        pos[k, 1] = y
        vel[k, 0] = V * c
        vel[k, 1] = V * s
        V_next = min(max(V + af[k] * dt, vmin), vmax)
        a_f = (V_next - V) / dt  # the forward acceleration actually applied (0 at a speed limit)
        a_c = V * omega  # centripetal, to the left for omega > 0
        acc[k, 0] = a_f * c - a_c * s
        acc[k, 1] = a_f * s + a_c * c
        x += V * c * dt
        y += V * s * dt
        psi += omega * dt
        V = V_next
        omega += w_omega[k]
        if omega > omega_max:
            omega = 2.0 * omega_max - omega
        elif omega < -omega_max:
            omega = -2.0 * omega_max - omega


def forward_lateral(accel_xy, velocity):
    """Project accelerations ``(n, 2)`` on the velocity heading: ``[a_f, a_s]``
    with ``a_s`` positive to the right (``R(psi) [a_x, a_y]``, TOM convention).

    Examples
    --------
    Moving along +x, an acceleration along +x is forward and one along -y is lateral to
    the right:

    >>> accel, velocity = np.array([[1.0, 0.0], [0.0, -2.0]]), np.array([[10.0, 0.0], [10.0, 0.0]])
    >>> forward_lateral(accel, velocity) + 0.0
    array([[1., 0.],
           [0., 2.]])
    """
    a = as_array(accel_xy, "accel_xy", ndim=2)
    v = as_array(velocity, "velocity", shape=a.shape)
    if a.shape[1] != 2:
        raise ValueError(f"accel_xy must have shape (n, 2), got {a.shape}")
    psi = np.arctan2(v[:, 1], v[:, 0])
    c, s = np.cos(psi), np.sin(psi)
    return np.column_stack([c * a[:, 0] + s * a[:, 1], s * a[:, 0] - c * a[:, 1]])


def _common(rng, n, dt, mean_duration):
    rng = as_rng(rng)
    n = as_int(n, "n", minimum=2)
    dt = as_positive(dt, "dt")
    if not dt <= 1e100:
        # positions grow as dt**2 n**2: beyond this they leave double range
        raise ValueError(f"dt must be at most 1e100 s, got {dt}")
    mean_duration = as_positive(mean_duration, "mean_duration")
    return rng, n, dt, mean_duration


def random_manoeuvre_xy(rng, n=10_000, dt=1.0, sigma_w=2.0, mean_duration=20.0, speed0=200.0):
    """Scenario 1: independent eq.-(9) walks on ``a_x`` and ``a_y``.

    Each axis has its own segments (durations ``max(1, Poisson(mean_duration))``
    samples) and its walk restarts from 0 at each segment start; increments are
    ``N(0, sigma_w^2)`` (m/s^2 per step).  Returns :class:`RandomManoeuvre`.

    Examples
    --------
    1000 s of scenario 1 from 200 m/s along +x; the accelerations are walks of
    ``N(0, 2^2)`` steps restarted every ~20 samples:

    >>> tr = random_manoeuvre_xy(np.random.default_rng(0), n=1000)
    >>> np.round(tr.velocity[0], 1), np.round(np.abs(tr.accel_xy).mean(axis=0), 2)
    (array([200.,   0.]), array([5.01, 4.5 ]))
    """
    rng, n, dt, mean_duration = _common(rng, n, dt, mean_duration)
    sigma_w = as_nonnegative(sigma_w, "sigma_w")
    speed0 = as_nonnegative(speed0, "speed0")
    a = np.empty((n, 2))
    for axis in range(2):
        starts = _segment_starts(rng, n, mean_duration)
        _walk_with_resets(rng.normal(0.0, sigma_w, n), starts, a[:, axis])
    pos = np.empty((n, 2))
    vel = np.empty((n, 2))
    _integrate_xy(a, dt, np.array([speed0, 0.0]), pos, vel)
    return RandomManoeuvre(np.arange(n) * dt, pos, vel, a, forward_lateral(a, vel))


def random_manoeuvre_turn(rng, n=10_000, dt=1.0, sigma_wf=1.3, sigma_womega=0.006, omega_max=0.3,
                          speed_limits=(50.0, 400.0), mean_duration=20.0, speed0=200.0):
    """Scenario 2: eq.-(9) walks on the forward acceleration and the turn rate.

    ``a_f`` restarts from 0 at each segment start (increments ``sigma_wf``);
    ``omega`` (rad/s) is never reset (increments ``sigma_womega``) and is
    reflected into ``[-omega_max, omega_max]``; the speed is clipped to
    ``speed_limits``.  Returns :class:`RandomManoeuvre`.

    Examples
    --------
    Scenario 2 keeps the speed within its limits:

    >>> tr = random_manoeuvre_turn(np.random.default_rng(0), n=1000)
    >>> speed = np.hypot(*tr.velocity.T)
    >>> round(float(speed.min()), 1) >= 50.0, round(float(speed.max()), 1) <= 400.0
    (True, True)
    >>> np.round(np.abs(tr.accel_fs).mean(axis=0), 2)  # mean |a_f|, |a_s| (m/s^2)
    array([2.1 , 7.31])
    """
    rng, n, dt, mean_duration = _common(rng, n, dt, mean_duration)
    sigma_wf = as_nonnegative(sigma_wf, "sigma_wf")
    sigma_womega = as_nonnegative(sigma_womega, "sigma_womega")
    omega_max = as_positive(omega_max, "omega_max")
    lim = as_array(speed_limits, "speed_limits", shape=(2,))
    if not 0 <= lim[0] <= lim[1]:
        raise ValueError(f"speed_limits must satisfy 0 <= min <= max, got {tuple(lim)}")
    speed0 = as_nonnegative(speed0, "speed0")
    starts = _segment_starts(rng, n, mean_duration)
    af = np.empty(n)
    _walk_with_resets(rng.normal(0.0, sigma_wf, n), starts, af)
    w_omega = rng.normal(0.0, sigma_womega, n)
    pos, vel, acc = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
    _turn_kernel(af, w_omega, dt, min(max(speed0, lim[0]), lim[1]), omega_max, lim[0], lim[1],
                 pos, vel, acc)
    return RandomManoeuvre(np.arange(n) * dt, pos, vel, acc, forward_lateral(acc, vel))


def cross_correlation_coefficient(u, v, max_lag=60):
    """``rho_uv(tau) = 1/(N - |tau|) sum_k (u_k - ubar)(v_{k+tau} - vbar) / (s_u s_v)``
    for ``tau = -max_lag .. max_lag``; returns ``(lags, rho)``.

    Examples
    --------
    A series against itself delayed by 3 samples peaks at lag 3:

    >>> u = np.random.default_rng(0).standard_normal(500)
    >>> lags, rho = cross_correlation_coefficient(u[3:], u[:-3], max_lag=5)
    >>> lags
    array([-5, -4, -3, -2, -1,  0,  1,  2,  3,  4,  5])
    >>> int(lags[np.argmax(rho)]), round(float(rho.max()), 2)
    (3, 1.0)
    """
    u = as_array(u, "u", ndim=1)
    v = as_array(v, "v", shape=u.shape)
    N = u.size
    L = as_int(max_lag, "max_lag", minimum=0)
    if L >= N:
        raise ValueError(f"max_lag must be < len(u) = {N}, got {L}")
    su, sv = u.std(), v.std()
    if su == 0 or sv == 0:
        raise ValueError("u and v must not be constant")
    du, dv = u - u.mean(), v - v.mean()
    lags = np.arange(-L, L + 1)
    rho = np.empty(lags.size)
    for i, tau in enumerate(lags):
        if tau >= 0:
            s = np.dot(du[:N - tau], dv[tau:])
        else:
            s = np.dot(du[-tau:], dv[:N + tau])
        rho[i] = s / ((N - abs(tau)) * su * sv)
    return lags, rho
