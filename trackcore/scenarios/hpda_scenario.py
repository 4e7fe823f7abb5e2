"""The six-target scenario of Kim & Song (2007), Table 1, with its sensor.

Truth (spec section 5.1, conventions are choices): the state in Table 1 is the
state *at the birth scan*; a target is alive for ``b <= k <= d``; scans run
``k = 0..450`` at ``T = 10 s``.  Motion follows the three-mode jump-Markov
model of eqs (1)-(2): mode 1 CV, mode 2 a left (counter-clockwise)
coordinated turn, mode 3 a right turn, with turn rate ``Omega = +-a_m/speed``
(erratum E2: speed, not range).

* ``variant="A"``: pure CV, noise-free.
* ``variant="B"`` (default, the book's truth): noise-free; each target flies
  CV, then one 20-scan turn centred on mid-life (left for odd TID, right for
  even TID), then CV again.  Identical in every Monte Carlo run.

Sensor: range-bearing at the origin, ``sigma_r = 50 m``,
``sigma_theta = 0.1 deg``.  Amplitudes are exponential (mean ``1 + rho`` for
targets, 1 for clutter) with threshold ``tau = -(1 + rho) ln P_D`` (E18).
Clutter: ``Poisson(lambda V)`` returns per scan, uniform over the disc of
radius 10 km, amplitude ``tau + Exp(1)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..core.validation import as_count, as_int, as_nonnegative, as_positive, as_probability, as_rng
from ..detection.amplitude import exponential_amplitude_threshold
from ..models.motion import coordinated_turn_transition, cv_transition
from ..trackers.clustering_hybrid import ClusteringConfig, clustering_run
from ..trackers.hpda_pf import HpdaPfConfig, hpda_pf_run
from ..trackers.smc_phd import SmcPhdConfig, smc_phd_run

__all__ = [
    "HPDA_TABLE1",
    "HpdaParameters",
    "HpdaTruth",
    "HpdaScans",
    "hpda_parameters",
    "hpda_truth",
    "hpda_true_count",
    "simulate_hpda_scans",
    "hpda_tracker_configs",
    "run_hpda_trial",
    "HPDA_ALGORITHMS",
    "track_delays",
]

#: Table 1: (TID, birth scan, death scan, [x, y, vx, vy] at birth)
HPDA_TABLE1 = (
    (1, 0, 200, (-3000.0, -5000.0, 1.5, 1.0)),
    (2, 100, 350, (0.0, 5000.0, 1.0, -1.0)),
    (3, 150, 400, (-5000.0, 5000.0, 0.5, -1.0)),
    (4, 250, 450, (-1000.0, 1000.0, 0.75, -1.0)),
    (5, 300, 450, (4000.0, 4000.0, -1.5, -1.5)),
    (6, 150, 350, (4000.0, 0.0, 0.0, -1.5)),
)


@dataclass(frozen=True)
class HpdaParameters:
    """Scenario and sensor parameters of one environment (Table 2, reconstructed)."""
    pd: float                 # detection probability
    snr: float                # linear mean SNR rho
    clutter_mean: float       # lambda V: expected clutter returns per scan in the disc
    T: float = 10.0           # scan period [s]
    n_scans: int = 451        # scans k = 0..450
    radius: float = 1.0e4     # surveillance disc radius [m]
    sigma_r: float = 50.0     # range noise std [m]
    sigma_theta: float = math.radians(0.1)  # bearing noise std [rad]
    sigma_a: float = 0.0015   # process-noise acceleration std [m/s^2]
    a_m: float = 0.01         # manoeuvre acceleration [m/s^2]

    @property
    def tau(self) -> float:
        """Amplitude threshold ``-(1 + rho) ln P_D`` (E18)."""
        return exponential_amplitude_threshold(self.pd, self.snr)

    @property
    def pfa(self) -> float:
        return math.exp(-self.tau)

    @property
    def area(self) -> float:
        """Surveillance area ``V = pi r^2`` [m^2]."""
        return math.pi * self.radius ** 2

    @property
    def clutter_density_xy(self) -> float:
        """Clutter per unit Cartesian area, ``lambda V / V`` [1/m^2]."""
        return self.clutter_mean / self.area

    @property
    def R(self) -> np.ndarray:
        return np.diag([self.sigma_r ** 2, self.sigma_theta ** 2])


def hpda_parameters(case: int) -> HpdaParameters:
    """Case 1: ``(P_D, rho, lambda V) = (0.9, 10, 10)``; case 2: ``(0.6, 5, 50)``."""
    case = as_int(case, "case")
    if case == 1:
        return HpdaParameters(pd=0.9, snr=10.0, clutter_mean=10.0)
    if case == 2:
        return HpdaParameters(pd=0.6, snr=5.0, clutter_mean=50.0)
    raise ValueError(f"case must be 1 or 2, got {case}")


class HpdaTruth(NamedTuple):
    states: np.ndarray   # (K, 6, 4), NaN where the target is not alive
    alive: np.ndarray    # (K, 6) bool
    modes: np.ndarray    # (K, 6) int: 1 CV, 2 left turn, 3 right turn, 0 not alive
    births: np.ndarray   # (6,) birth scans
    deaths: np.ndarray   # (6,) death scans (last alive scan)


class HpdaScans(NamedTuple):
    """All scans of one run, concatenated: scan ``k`` is rows
    ``offsets[k]:offsets[k+1]``."""
    z: np.ndarray          # (M, 2) range [m], bearing [rad]
    amplitude: np.ndarray  # (M,) reported amplitude (>= tau)
    offsets: np.ndarray    # (K + 1,) int64
    origin: np.ndarray     # (M,) int64: target index 0..5, or -1 for clutter

    def scan(self, k):
        a, b = self.offsets[k], self.offsets[k + 1]
        return self.z[a:b], self.amplitude[a:b]

    @property
    def n_scans(self) -> int:
        return self.offsets.shape[0] - 1


def hpda_truth(variant="B", T=10.0, a_m=0.01, n_scans=451, turn_length=20):
    """Noise-free truth of Table 1 (see module docstring for the variants)."""
    if variant not in ("A", "B"):
        raise ValueError(f"variant must be 'A' or 'B', got {variant!r}")
    T = as_positive(T, "T")
    a_m = as_nonnegative(a_m, "a_m")
    K = as_count(n_scans, "n_scans")
    L = as_count(turn_length, "turn_length")
    F_cv = cv_transition(T)
    n_t = len(HPDA_TABLE1)
    states = np.full((K, n_t, 4), np.nan)
    alive = np.zeros((K, n_t), dtype=bool)
    modes = np.zeros((K, n_t), dtype=np.int64)
    births = np.array([b for _, b, _, _ in HPDA_TABLE1])
    deaths = np.array([d for _, _, d, _ in HPDA_TABLE1])
    for t, (tid, b, d, x0) in enumerate(HPDA_TABLE1):
        if b >= K:
            continue
        x = np.array(x0, dtype=float)
        ks = b + (d - b) // 2 - L // 2
        states[b, t] = x
        alive[b, t] = True
        modes[b, t] = 1
        for k in range(b + 1, min(d, K - 1) + 1):
            mode = 1
            if variant == "B" and ks + 1 <= k <= ks + L:
                mode = 2 if tid % 2 == 1 else 3
            if mode == 1:
                x = F_cv @ x
            else:
                omega = (-1) ** mode * a_m / math.hypot(x[2], x[3])
                x = coordinated_turn_transition(omega, T) @ x
            states[k, t] = x
            alive[k, t] = True
            modes[k, t] = mode
    return HpdaTruth(states, alive, modes, births, deaths)


def hpda_true_count(truth: HpdaTruth) -> np.ndarray:
    """True number of targets per scan (Fig 5)."""
    return truth.alive.sum(axis=1)


def simulate_hpda_scans(truth: HpdaTruth, params: HpdaParameters, rng) -> HpdaScans:
    """Measurements of every scan: detections of live targets (P_D via the
    amplitude threshold) plus Poisson clutter, shuffled within each scan.

    Vectorised over all scans; randomness only from ``rng``.
    """
    rng = as_rng(rng)
    if not isinstance(params, HpdaParameters):
        raise TypeError(f"params must be HpdaParameters, got {type(params).__name__}")
    if not isinstance(truth, HpdaTruth):
        raise TypeError(f"truth must be HpdaTruth, got {type(truth).__name__}")
    as_probability(params.pd, "params.pd", open_low=True)
    K, n_t = truth.alive.shape
    tau = params.tau
    # targets: raw amplitude Exp(1 + rho), reported iff > tau
    kk, tt = np.nonzero(truth.alive)
    raw = rng.exponential(1.0 + params.snr, kk.size)
    det = raw > tau
    kk, tt, amp_t = kk[det], tt[det], raw[det]
    X = truth.states[kk, tt]
    r = np.hypot(X[:, 0], X[:, 1]) + params.sigma_r * rng.standard_normal(kk.size)
    th = np.arctan2(X[:, 1], X[:, 0]) + params.sigma_theta * rng.standard_normal(kk.size)
    th = np.mod(th + np.pi, 2 * np.pi) - np.pi
    # clutter: Poisson(lambda V) per scan, uniform in the disc
    nc = rng.poisson(params.clutter_mean, K)
    kc = np.repeat(np.arange(K), nc)
    rc = params.radius * np.sqrt(rng.random(kc.size))
    thc = rng.uniform(-np.pi, np.pi, kc.size)
    amp_c = tau + rng.exponential(1.0, kc.size)
    scan = np.concatenate([kk, kc])
    z = np.column_stack([np.concatenate([r, rc]), np.concatenate([th, thc])])
    amp = np.concatenate([amp_t, amp_c])
    origin = np.concatenate([tt, np.full(kc.size, -1)]).astype(np.int64)
    key = rng.random(scan.size)
    order = np.lexsort((key, scan))
    counts = np.bincount(scan, minlength=K)
    offsets = np.zeros(K + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return HpdaScans(np.ascontiguousarray(z[order]), np.ascontiguousarray(amp[order]),
                     offsets, origin[order])


#: algorithm keys of :func:`run_hpda_trial`
HPDA_ALGORITHMS = ("hpda", "phd", "clustering", "clustering_wide", "hpda_sn", "hpda_nn")


def hpda_tracker_configs(params: HpdaParameters, **overrides):
    """Tracker configurations for one environment: a dict with keys of
    :data:`HPDA_ALGORITHMS` (``clustering_wide`` is the sensitivity variant
    with ROI links on ``d^2 <= 9.21``; ``hpda_sn``/``hpda_nn`` use the
    strongest/nearest-neighbour rule instead of eq 15).  ``overrides`` maps
    an algorithm key to a dict of field overrides."""
    if not isinstance(params, HpdaParameters):
        raise TypeError(f"params must be HpdaParameters, got {type(params).__name__}")
    common = dict(T=params.T, sigma_r=params.sigma_r, sigma_theta=params.sigma_theta,
                  sigma_a=params.sigma_a, a_m=params.a_m)
    lam = params.clutter_density_xy
    cfgs = {
        "hpda": HpdaPfConfig(pd=params.pd, snr=params.snr, clutter_density_xy=lam, **common),
        "phd": SmcPhdConfig(pd=params.pd, clutter_density_xy=lam, **common),
        "clustering": ClusteringConfig(pd=params.pd, clutter_density_xy=lam, **common),
        "clustering_wide": ClusteringConfig(pd=params.pd, clutter_density_xy=lam, link_d2=9.21,
                                            **common),
        "hpda_sn": HpdaPfConfig(pd=params.pd, snr=params.snr, clutter_density_xy=lam,
                                selection="strongest", **common),
        "hpda_nn": HpdaPfConfig(pd=params.pd, snr=params.snr, clutter_density_xy=lam,
                                selection="nearest", **common),
    }
    from dataclasses import replace
    for key, ov in overrides.items():
        if key not in cfgs:
            raise ValueError(f"unknown algorithm {key!r}; expected one of {HPDA_ALGORITHMS}")
        cfgs[key] = replace(cfgs[key], **ov)
    return cfgs


def _run_algorithm(key, cfg, scans, rng):
    if key.startswith("hpda"):
        return hpda_pf_run(scans.z, scans.amplitude, scans.offsets, cfg, rng)
    if key == "phd":
        return smc_phd_run(scans.z, scans.offsets, cfg, rng)
    return clustering_run(scans.z, scans.offsets, cfg, rng)


def track_delays(run, truth: HpdaTruth, radius=500.0):
    """Confirmation delay (scans from birth until an estimate lies within
    ``radius`` of the target; NaN if never) and termination delay (scans
    after death until no estimate lies within ``radius`` of the target's
    CV-extrapolated position; capped at the end of the run) per target."""
    K, n_t = truth.alive.shape
    conf = np.full(n_t, np.nan)
    term = np.full(n_t, np.nan)
    for t in range(n_t):
        b, d = int(truth.births[t]), int(truth.deaths[t])
        for k in range(b, min(d, K - 1) + 1):
            n = run.n_estimates[k]
            if n and np.min(np.hypot(*(run.estimates[k, :n, :2] - truth.states[k, t, :2]).T)) < radius:
                conf[t] = k - b
                break
        if d >= K - 1:
            continue
        xd = truth.states[d, t]
        for k in range(d + 1, K):
            pos = xd[:2] + (k - d) * 10.0 * xd[2:]
            n = run.n_estimates[k]
            if not n or np.min(np.hypot(*(run.estimates[k, :n, :2] - pos).T)) >= radius:
                term[t] = k - d
                break
        else:
            term[t] = K - 1 - d
    return conf, term


def run_hpda_trial(rng, case, algorithms=("hpda", "phd", "clustering"), keep_estimates=False,
                   overrides=None, scenario_overrides=None):
    """One Monte Carlo run of the paper's experiment: simulate the scans of
    environment ``case`` (variant-B truth) and run every tracker in
    ``algorithms`` on them.  ``overrides`` maps algorithm keys to config
    field overrides; ``scenario_overrides`` replaces fields of the
    environment's :class:`HpdaParameters` (e.g. ``{"snr": 3.16}``) for both
    the simulation and the trackers.  Random streams:
    ``rng.spawn(1 + len(algorithms))`` (data first).  Returns a dict
    ``{key: {"count", "aux", "conf_delay", "term_delay", ["run"]}}`` plus
    ``"n_measurements"``."""
    rng = as_rng(rng)
    params = hpda_parameters(case)
    if scenario_overrides:
        from dataclasses import replace
        params = replace(params, **scenario_overrides)
    truth = _TRUTH_CACHE.get("B")
    if truth is None:
        truth = _TRUTH_CACHE.setdefault("B", hpda_truth("B"))
    cfgs = hpda_tracker_configs(params, **(overrides or {}))
    streams = rng.spawn(1 + len(algorithms))
    scans = simulate_hpda_scans(truth, params, streams[0])
    out = {"n_measurements": int(scans.offsets[-1])}
    for key, r in zip(algorithms, streams[1:]):
        if key not in cfgs:
            raise ValueError(f"unknown algorithm {key!r}; expected one of {HPDA_ALGORITHMS}")
        res = _run_algorithm(key, cfgs[key], scans, r)
        conf, term = track_delays(res, truth)
        rec = {"count": res.count, "aux": res.aux, "conf_delay": conf, "term_delay": term}
        if keep_estimates:
            rec["run"] = res
        out[key] = rec
    return out


_TRUTH_CACHE: dict = {}
