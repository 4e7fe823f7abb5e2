"""Pursuer / target / acoustic-decoy (ACM) scenarios of Jeong & Hong (1996).

The paper gives speeds, turns, the range at release and the scan interval but
no geometry.  **The geometry is our choice** (chapter "Telling a target from an
acoustic decoy", *Choices we made*): at the release time the pursuer is at the origin and the target at ``(0, R0)``, so the line of
sight (LOS) points due north; ``alpha`` is the target course and ``lead`` the
pursuer course, both measured clockwise from the LOS (degrees).  Before the
release both move in straight lines (positions at ``t = 0`` follow by
back-propagation); turns start at the release, are to the right (clockwise)
at the lateral acceleration ``turn_accel`` and last ``angle / (accel / speed)``
seconds (61.2 s and 60.9 s in the paper).

The ACM stays at the target's release position and answers each ping with a
growing delay and a Doppler shift so that it looks like a point receding
along the LOS at ``decoy_speed``:
``z_r = r_acm + v_d (t - t_rel) + w_r``, ``z_theta = theta_acm + w_theta``,
``z_rdot = rdot_acm + v_d + w_rdot``.

Scans are at ``t = 0, T, ..., t_end``; post-release scan ``k = 1`` is at the
release time.  Randomness only through an explicit ``numpy.random.Generator``;
run ``i`` of a Monte Carlo batch uses ``default_rng(SeedSequence(seed).spawn(n)[i])``
(same as :func:`trackcore.montecarlo.run`).
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..core.rng import spawn_generators
from ..core.validation import as_array, as_count, as_rng
from ..models.measurement import range_bearing_doppler
from ..models.motion import coordinated_turn_transition, cv_process_noise, cv_transition
from ..trackers.sprt_discriminator import (SprtAcmDiscrimination, SprtAcmFilterConfig,
                                           sprt_acm_discriminate)

__all__ = [
    "SprtAcmScenario",
    "SprtAcmTruth",
    "SprtAcmMeasurements",
    "sprt_acm_scenario",
    "sprt_acm_states",
    "sprt_acm_truth",
    "sprt_acm_measurements",
    "sprt_acm_trial",
    "sprt_acm_monte_carlo",
    "sprt_acm_filter_config",
]


_CAPS = {"T": 1e4, "R0": 1e8, "alpha_deg": 1e6, "lead_deg": 1e6, "gamma": 1e4,
         "target_turn_deg": 1e6, "pursuer_turn_deg": 1e6, "turn_accel": 1e4,
         "target_speed": 1e4, "pursuer_speed": 1e4, "decoy_speed": 1e4, "t_release": 1e6,
         "t_end": 1e6, "sigma_r": 1e6, "sigma_theta": 10.0, "sigma_rdot": 1e4,
         "target_accel_psd": 1e8}


@dataclass(frozen=True)
class SprtAcmScenario:
    """Parameters of one scenario (angles in degrees, SI units otherwise).

    Every field is checked when the record is built: ``TypeError`` for a
    non-number, ``ValueError`` naming the field for a non-finite or
    out-of-range value (each field also has a generous upper bound, far beyond
    any sonar scenario, so that the simulation stays finite), or scan times that
    are not whole multiples of ``T``.

    Attributes
    ----------
    name : str
        Label, e.g. ``"S1"``.
    T : float
        Scan interval (s).
    R0 : float
        Pursuer-target range at release (m).
    alpha_deg, lead_deg : float
        Target and pursuer courses, clockwise from the LOS at release (our choice).
    gamma : float
        The paper's threshold ``gamma1 = -gamma0``.
    target_turn_deg, pursuer_turn_deg : float
        Right turns starting at the release (degrees; negative turns left).
    turn_accel : float
        Lateral acceleration in the turns (m/s^2).
    target_speed, pursuer_speed : float
        Speeds (m/s).
    decoy_speed : float
        Apparent LOS speed of the ACM (m/s, > 0 receding).
    t_release, t_end : float
        Release time and end of the run (s); both whole multiples of ``T``.
    sigma_r, sigma_theta, sigma_rdot : float
        Sensor noise std: range (m), bearing (rad), range rate (m/s).
    target_accel_psd : float
        ``> 0``: random CWNA acceleration of this PSD added to the target truth
        after the release (used to check filter consistency).

    Examples
    --------
    >>> s = SprtAcmScenario("mine", T=2.0, R0=1000.0, alpha_deg=45.0, lead_deg=0.0, gamma=3.0)
    >>> s.target_speed, s.t_release, s.t_end
    (15.4, 60.0, 90.0)
    >>> SprtAcmScenario("bad", T=2.0, R0=1000.0, alpha_deg=45.0, lead_deg=0.0, gamma=3.0,
    ...                 t_end=91.0)
    Traceback (most recent call last):
        ...
    ValueError: t_release and t_end - t_release must be whole multiples of T, got T=2.0, t_release=60.0, t_end=91.0
    """
    name: str
    T: float
    R0: float
    alpha_deg: float
    lead_deg: float
    gamma: float
    target_turn_deg: float = 0.0
    pursuer_turn_deg: float = 0.0
    turn_accel: float = 10.0
    target_speed: float = 15.4
    pursuer_speed: float = 23.1
    decoy_speed: float = 12.8
    t_release: float = 60.0
    t_end: float = 90.0
    sigma_r: float = 5.0
    sigma_theta: float = 0.035
    sigma_rdot: float = 1.0
    target_accel_psd: float = 0.0

    def __post_init__(self):
        if not isinstance(self.name, str):
            raise TypeError(f"name must be a string, got {type(self.name).__name__}")
        for f in dataclasses.fields(self):
            if f.name == "name":
                continue
            v = getattr(self, f.name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
                raise TypeError(f"{f.name} must be a real number, got {type(v).__name__}")
            if not math.isfinite(float(v)):
                raise ValueError(f"{f.name} must be finite, got {v!r}")
        for f in ("T", "R0", "target_speed", "pursuer_speed", "t_release", "sigma_r",
                  "sigma_theta", "sigma_rdot", "gamma", "turn_accel", "t_end"):
            v = getattr(self, f)
            if not v > 0:
                raise ValueError(f"{f} must be > 0, got {v!r}")
        for f, cap in _CAPS.items():  # far beyond any sonar scenario; keeps the maths finite
            v = getattr(self, f)
            if abs(v) > cap:
                raise ValueError(f"{f} is out of range (|{f}| at most {cap:g}), got {v!r}")
        if not self.target_accel_psd >= 0:
            raise ValueError(f"target_accel_psd must be >= 0, got {self.target_accel_psd!r}")
        if not self.t_release >= self.T:
            raise ValueError(f"t_release must be at least T (one scan before the release), "
                             f"got t_release={self.t_release}, T={self.T}")
        if not self.R0 >= 1.0:
            raise ValueError(f"R0 must be at least 1 m, got {self.R0!r}")
        if not self.t_end >= self.t_release:
            raise ValueError(f"t_end must be >= t_release, got t_end={self.t_end}, "
                             f"t_release={self.t_release}")
        n_pre = self.t_release / self.T
        n_post = (self.t_end - self.t_release) / self.T
        if abs(n_pre - round(n_pre)) > 1e-9 or abs(n_post - round(n_post)) > 1e-9:
            raise ValueError("t_release and t_end - t_release must be whole multiples "
                             f"of T, got T={self.T}, t_release={self.t_release}, "
                             f"t_end={self.t_end}")
        if n_pre + n_post > 1e6:
            raise ValueError(f"T={self.T} gives {n_pre + n_post:.3g} scans; at most 1e6")

    @property
    def n_pre(self) -> int:
        """Number of pre-release scans (t = 0 .. t_release - T)."""
        return int(round(self.t_release / self.T))

    @property
    def n_post(self) -> int:
        """Number of post-release scans k = 1..K (t = t_release .. t_end)."""
        return int(round((self.t_end - self.t_release) / self.T)) + 1


_PAPER = {
    1: dict(name="S1", T=2.0, R0=1000.0, alpha_deg=45.0, lead_deg=0.0,
            gamma=math.log(19.0)),
    2: dict(name="S2", T=2.0, R0=1000.0, alpha_deg=7.5, lead_deg=-15.0, gamma=5.3,
            target_turn_deg=45.0, pursuer_turn_deg=22.5),
    3: dict(name="S3", T=1.0, R0=400.0, alpha_deg=7.5, lead_deg=-15.0, gamma=5.3,
            target_turn_deg=45.0, pursuer_turn_deg=22.5),
}


def sprt_acm_scenario(number, **changes):
    """Scenario 1, 2 or 3 of the paper with our geometry.

    S1: constant velocity, G-A geometry (alpha = 45 deg, lead = 0), T = 2 s,
    gamma = ln 19.  S2: target turns 45 deg right, pursuer 22.5 deg right at
    release, G-B geometry (alpha = 7.5 deg, lead = -15 deg), T = 2 s,
    gamma = 5.3.  S3: S2 at R0 = 400 m with T = 1 s.  Keyword ``changes``
    override any field (e.g. ``alpha_deg=30``).

    Examples
    --------
    Scenario 1: threshold ``ln 19`` (5 % errors); any field can be changed:

    >>> s = sprt_acm_scenario(1)
    >>> s.name, s.T, s.R0, s.alpha_deg, round(s.gamma, 4)
    ('S1', 2.0, 1000.0, 45.0, 2.9444)
    >>> sprt_acm_scenario(3, alpha_deg=30.0).alpha_deg
    30.0
    """
    if isinstance(number, bool) or number not in _PAPER:
        raise ValueError(f"number must be 1, 2 or 3, got {number!r}")
    params = dict(_PAPER[number])
    unknown = set(changes) - {f.name for f in dataclasses.fields(SprtAcmScenario)}
    if unknown:
        raise TypeError(f"unknown scenario field(s): {sorted(unknown)}")
    params.update(changes)
    return SprtAcmScenario(**params)


def _course_vector(speed, course_deg):
    c = math.radians(course_deg)    # clockwise from north (+y)
    return np.array([speed * math.sin(c), speed * math.cos(c)])


def _vehicle(p_rel, v_rel, turn_deg, speed, accel, t_rel, t):
    """States [x, y, vx, vy] at times t: straight before t_rel, right turn, straight."""
    omega = -accel / speed                          # right turn: clockwise
    dur = math.radians(abs(turn_deg)) / (accel / speed)
    if turn_deg < 0:
        omega = -omega
    s0 = np.concatenate([p_rel, v_rel])
    s_end = coordinated_turn_transition(omega, dur) @ s0
    out = np.empty((t.size, 4))
    for i, ti in enumerate(t):
        dt = ti - t_rel
        if dt <= 0.0:
            out[i] = [p_rel[0] + v_rel[0] * dt, p_rel[1] + v_rel[1] * dt, v_rel[0], v_rel[1]]
        elif dt <= dur:
            out[i] = coordinated_turn_transition(omega, dt) @ s0
        else:
            d2 = dt - dur
            out[i] = [s_end[0] + s_end[2] * d2, s_end[1] + s_end[3] * d2, s_end[2], s_end[3]]
    return out


def sprt_acm_states(scenario, t):
    """True pursuer and target states ``[x, y, vx, vy]`` at times ``t``.

    Returns ``(own (n, 4), target (n, 4), acm (2,))``; the ACM is the target's
    release position.

    Examples
    --------
    Pursuer, target and decoy positions (m) at t = 0 and at the release (t = 60 s), where
    the decoy is left at the target's position, 1000 m ahead of the pursuer:

    >>> s = sprt_acm_scenario(1)
    >>> own, target, acm = sprt_acm_states(s, np.array([0.0, 60.0]))
    >>> np.round(own[:, :2], 1) + 0.0, np.round(target[:, :2], 1) + 0.0, np.round(acm, 1) + 0.0
    (array([[    0., -1386.],
           [    0.,     0.]]), array([[-653.4,  346.6],
           [   0. , 1000. ]]), array([   0., 1000.]))
    """
    if not isinstance(scenario, SprtAcmScenario):
        raise TypeError(f"scenario must be an SprtAcmScenario, got {type(scenario).__name__}")
    t = as_array(t, "t", ndim=1)
    sc = scenario
    own = _vehicle(np.zeros(2), _course_vector(sc.pursuer_speed, sc.lead_deg),
                   sc.pursuer_turn_deg, sc.pursuer_speed, sc.turn_accel, sc.t_release, t)
    tgt = _vehicle(np.array([0.0, sc.R0]), _course_vector(sc.target_speed, sc.alpha_deg),
                   sc.target_turn_deg, sc.target_speed, sc.turn_accel, sc.t_release, t)
    if not (np.all(np.isfinite(own)) and np.all(np.isfinite(tgt))):
        raise ValueError("the scenario's speeds, turns and times give non-finite trajectories "
                         "(parameters far outside a physical range)")
    return own, tgt, np.array([0.0, sc.R0])


class SprtAcmTruth(NamedTuple):
    """True states at the scan times.

    Examples
    --------
    What :func:`sprt_acm_truth` returns:

    >>> SprtAcmTruth._fields
    ('times', 'own', 'target', 'acm', 'n_pre')
    """
    times: np.ndarray    # (n_pre + K,) scan times (s)
    own: np.ndarray      # (n_pre + K, 4) pursuer
    target: np.ndarray   # (n_pre + K, 4) target
    acm: np.ndarray      # (2,) ACM position
    n_pre: int           # scans before release


def sprt_acm_truth(scenario):
    """Truth at the scan times ``0, T, ..., t_end``.

    Examples
    --------
    Scans every 2 s from 0 to 90 s; 30 before the release:

    >>> truth = sprt_acm_truth(sprt_acm_scenario(1))
    >>> truth.times.shape, truth.n_pre, truth.own.shape, float(truth.times[truth.n_pre])
    ((46,), 30, (46, 4), 60.0)
    """
    if not isinstance(scenario, SprtAcmScenario):
        raise TypeError(f"scenario must be an SprtAcmScenario, got {type(scenario).__name__}")
    n = scenario.n_pre + scenario.n_post
    times = scenario.T * np.arange(n)
    own, tgt, acm = sprt_acm_states(scenario, times)
    return SprtAcmTruth(times, own, tgt, acm, scenario.n_pre)


class SprtAcmMeasurements(NamedTuple):
    """One run's measurements ``(r, theta, rdot)``.

    Examples
    --------
    What :func:`sprt_acm_measurements` returns (``(r, theta, rdot)`` rows):

    >>> m = sprt_acm_measurements(sprt_acm_scenario(1), np.random.default_rng(0))
    >>> m.z_pre.shape, m.z_a.shape, m.z_b.shape
    ((30, 3), (16, 3), (16, 3))
    """
    z_pre: np.ndarray    # (n_pre, 3) target before release
    z_a: np.ndarray      # (K, 3) track a (target under H0)
    z_b: np.ndarray      # (K, 3) track b (ACM under H0)


def _acm_noiseless(scenario, truth, acm):
    post = slice(truth.n_pre, None)
    own = truth.own[post]
    d = acm[None, :] - own[:, :2]
    r = np.hypot(d[:, 0], d[:, 1])
    rdot = -(own[:, 2] * d[:, 0] + own[:, 3] * d[:, 1]) / r
    tau = truth.times[post] - scenario.t_release
    return np.stack([r + scenario.decoy_speed * tau, np.arctan2(d[:, 1], d[:, 0]),
                     rdot + scenario.decoy_speed], axis=1)


_MIN_RANGE_SIGMAS = 8.0
"""Smallest true range (target) or apparent range (decoy) accepted, in range-noise standard
deviations: below it a Gaussian range error could make a measured range non-positive
(probability below 1e-15 per measurement at 8 sigma)."""


def _check_ranges(scenario, truth, rel, z_acm):
    """Refuse a scenario that brings a track so close to the pursuer that the range noise
    could make a measured range <= 0 (the filters' measurement model no longer holds)."""
    limit = _MIN_RANGE_SIGMAS * scenario.sigma_r
    r_t = np.hypot(rel[:, 0], rel[:, 1])
    for name, r, times in (("the target", r_t, truth.times),
                           ("the decoy (apparent range)", z_acm[:, 0],
                            truth.times[truth.n_pre:])):
        i = int(np.argmin(r))
        if not r[i] >= limit:
            raise ValueError(
                f"scenario {scenario.name}: {name} comes within {r[i]:.1f} m of the pursuer "
                f"at t = {times[i]:g} s, less than {_MIN_RANGE_SIGMAS:g} sigma_r = {limit:g} m, "
                "where the range noise can make a measured range <= 0; change the geometry "
                "or end the run earlier (t_end)")


def sprt_acm_measurements(scenario, rng, truth=None, h1_true=False):
    """Simulate one run's measurements.

    Draw order (fixed): [target process noise if ``target_accel_psd > 0``],
    pre-release target noise, post-release target noise, ACM noise.
    ``h1_true`` swaps the tracks (a = ACM, b = target).  With
    ``target_accel_psd > 0`` the target truth is the nominal trajectory plus a
    random deviation that follows the filter's own CWNA model (eq 12) after the
    release (used to check filter consistency).  A scenario that brings the target,
    or the decoy's apparent range, within eight ``sigma_r`` of the
    pursuer raises ``ValueError`` naming the scenario.

    Examples
    --------
    Track ``a`` is the target, ``b`` the decoy (swapped with ``h1_true``); their first
    post-release ``(r, theta, rdot)``, both about 1000 m ahead:

    >>> m = sprt_acm_measurements(sprt_acm_scenario(1), np.random.default_rng(0))
    >>> np.round(m.z_a[0], 2), np.round(m.z_b[0], 2)
    (array([998.56,   1.63, -12.64]), array([988.17,   1.61,  -9.96]))
    """
    if not isinstance(scenario, SprtAcmScenario):
        raise TypeError(f"scenario must be an SprtAcmScenario, got {type(scenario).__name__}")
    rng = as_rng(rng)
    if not isinstance(h1_true, (bool, np.bool_)):
        raise TypeError(f"h1_true must be a bool, got {type(h1_true).__name__}")
    truth = sprt_acm_truth(scenario) if truth is None else truth
    if not isinstance(truth, SprtAcmTruth):
        raise TypeError(f"truth must be an SprtAcmTruth, got {type(truth).__name__}")
    sig = np.array([scenario.sigma_r, scenario.sigma_theta, scenario.sigma_rdot])
    target, acm = truth.target, truth.acm
    if scenario.target_accel_psd > 0:
        n, n0 = target.shape[0], truth.n_pre
        L = np.linalg.cholesky(cv_process_noise(scenario.T, scenario.target_accel_psd, 2,
                                                kind="cwna"))
        F = cv_transition(scenario.T, 2)
        w = rng.standard_normal((n - n0 - 1, 4)) @ L.T
        dev = np.zeros((n, 4))
        for i in range(n0 + 1, n):
            dev[i] = F @ dev[i - 1] + w[i - n0 - 1]
        target = target + dev
    rel = target - truth.own
    z_t = range_bearing_doppler(rel) if np.all(np.hypot(rel[:, 0], rel[:, 1]) > 0) else None
    z_acm = _acm_noiseless(scenario, truth, acm)
    _check_ranges(scenario, truth, rel, z_acm)
    n_pre = truth.n_pre
    z_pre = z_t[:n_pre] + rng.standard_normal((n_pre, 3)) * sig
    z_tgt = z_t[n_pre:] + rng.standard_normal((z_t.shape[0] - n_pre, 3)) * sig
    z_acm = z_acm + rng.standard_normal(z_acm.shape) * sig
    if h1_true:
        return SprtAcmMeasurements(z_pre, z_acm, z_tgt)
    return SprtAcmMeasurements(z_pre, z_tgt, z_acm)


def sprt_acm_filter_config(scenario, **changes):
    """Filter parameters matched to the scenario's sensor noise (paper values otherwise).

    Examples
    --------
    >>> cfg = sprt_acm_filter_config(sprt_acm_scenario(1), sigma_v=3.0)
    >>> cfg.sigma_r, cfg.sigma_theta, cfg.sigma_rdot, cfg.sigma_v
    (5.0, 0.035, 1.0, 3.0)
    """
    if not isinstance(scenario, SprtAcmScenario):
        raise TypeError(f"scenario must be an SprtAcmScenario, got {type(scenario).__name__}")
    params = dict(sigma_r=scenario.sigma_r, sigma_theta=scenario.sigma_theta,
                  sigma_rdot=scenario.sigma_rdot)
    unknown = set(changes) - {f.name for f in dataclasses.fields(SprtAcmFilterConfig)}
    if unknown:
        raise TypeError(f"unknown SprtAcmFilterConfig field(s): {sorted(unknown)}")
    params.update(changes)
    return SprtAcmFilterConfig(**params)


def sprt_acm_trial(rng, scenario, config=None, h1_true=False):
    """One Monte Carlo run (for :func:`trackcore.montecarlo.run`): the matched-filter outputs.

    Examples
    --------
    One run of scenario 1 (target on track ``a``): ``Lambda`` falls, and the SPRT decides
    H0 (track ``a`` is the target) at the first post-release scan:

    >>> from trackcore.detection.sprt import sprt_test
    >>> s = sprt_acm_scenario(1)
    >>> out = sprt_acm_trial(np.random.default_rng(0), s)
    >>> np.round(out.llr[:5], 2), bool(out.ok)
    (array([-3.1 , -3.35, -4.56, -3.97, -8.18]), True)
    >>> sprt_test(out.llr, -s.gamma, s.gamma)[:2]  # (decision, scan)
    (0, 1)
    """
    truth = sprt_acm_truth(scenario)
    z = sprt_acm_measurements(scenario, rng, truth, h1_true=h1_true)
    cfg = sprt_acm_filter_config(scenario) if config is None else config
    return sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, scenario.T, cfg)


def sprt_acm_monte_carlo(scenario, n_runs, seed, config=None, h1_true=False):
    """``n_runs`` runs in one batch kernel; run ``i`` identical to ``sprt_acm_trial`` with
    ``default_rng(SeedSequence(seed).spawn(n_runs)[i])``.  Returns a batched
    :class:`trackcore.trackers.SprtAcmDiscrimination`.

    Examples
    --------
    200 runs of scenario 1 under H0 and under H1 (designed for 5 % errors):

    >>> from trackcore.detection.sprt import sprt_decide
    >>> s = sprt_acm_scenario(1)
    >>> d0, k0 = sprt_decide(sprt_acm_monte_carlo(s, 200, seed=1).llr, -s.gamma, s.gamma)
    >>> d1, k1 = sprt_decide(sprt_acm_monte_carlo(s, 200, seed=1, h1_true=True).llr,
    ...                      -s.gamma, s.gamma)
    >>> float((d0 == 0).mean()), float((d1 == 1).mean())  # correct decisions
    (0.94, 0.94)
    """
    if not isinstance(scenario, SprtAcmScenario):
        raise TypeError(f"scenario must be an SprtAcmScenario, got {type(scenario).__name__}")
    n_runs = as_count(n_runs, "n_runs")
    if config is not None and not isinstance(config, SprtAcmFilterConfig):
        raise TypeError(f"config must be an SprtAcmFilterConfig, got {type(config).__name__}")
    if not isinstance(h1_true, (bool, np.bool_)):
        raise TypeError(f"h1_true must be a bool, got {type(h1_true).__name__}")
    truth = sprt_acm_truth(scenario)
    K, n_pre = scenario.n_post, scenario.n_pre
    zp = np.empty((n_runs, n_pre, 3))
    za = np.empty((n_runs, K, 3))
    zb = np.empty((n_runs, K, 3))
    for i, g in enumerate(spawn_generators(seed, n_runs)):
        zp[i], za[i], zb[i] = sprt_acm_measurements(scenario, g, truth, h1_true=h1_true)
    cfg = sprt_acm_filter_config(scenario) if config is None else config
    if n_runs == 0:
        return SprtAcmDiscrimination(np.zeros((0, K, 4)), np.zeros((0, K)), np.zeros((0, K, 4)),
                                     np.zeros((0, K, 2)), np.zeros((0, K, 2)),
                                     np.zeros(0, dtype=bool))
    return sprt_acm_discriminate(zp, za, zb, truth.own, scenario.T, cfg)
