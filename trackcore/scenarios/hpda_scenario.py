"""The six-target scenario of Kim & Song (2007), Table 1, with its sensor, the
chapter's trackers and the per-run metrics of its Monte Carlo study.

Truth (conventions are the book's choices): the state in Table 1 is the state *at
the birth scan*; a target is alive for ``b <= k <= d``; scans run ``k = 0..450`` at
``T = 10 s``.  Motion follows the three-mode jump-Markov model of eqs (1)-(2): mode 1
CV, mode 2 a left (counter-clockwise) coordinated turn, mode 3 a right turn, with
turn rate ``Omega = +-a_m/speed`` (erratum E2: speed, not range).

* ``variant="A"``: pure CV, noise-free.
* ``variant="B"`` (default, the book's truth): noise-free; each target flies
  CV, then one 20-scan turn centred on mid-life (left for odd TID, right for
  even TID), then CV again.  Identical in every Monte Carlo run.

Sensor: range-bearing at the origin, ``sigma_r = 50 m``,
``sigma_theta = 0.1 deg``.  Amplitudes are exponential (mean ``1 + rho`` for
targets, 1 for clutter) with threshold ``tau = -(1 + rho) ln P_D`` (E18).
Clutter: ``Poisson(lambda V)`` returns per scan, uniform over the disc of
radius 10 km, amplitude ``tau + Exp(1)``.

Environments: the paper's two, ``hpda_parameters(1)`` ``(P_D, rho, lambda V) =
(0.9, 10, 10)`` and ``hpda_parameters(2)`` ``(0.6, 5, 50)``, and the book's stress
environment ``hpda_parameters(3)`` (see :func:`hpda_stress_clutter_mean`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_count, as_int, as_nonnegative, as_positive,
                               as_probability, as_rng)
from ..detection.amplitude import exponential_amplitude_threshold
from ..metrics import gospa_kernel
from ..models.motion import coordinated_turn_transition, cv_transition
from ..stats import MIN_RUNS, Estimate, bootstrap_ci
from ..trackers.clustering_hybrid import CHI2_2_99, ClusteringConfig, clustering_run
from ..trackers.hpda_pf import HpdaPfConfig, TrackerRun, _finite, _integer, hpda_pf_run
from ..trackers.smc_phd import SmcPhdConfig, smc_phd_run

__all__ = [
    "HPDA_TABLE1",
    "HpdaParameters",
    "HpdaTruth",
    "HpdaScans",
    "hpda_parameters",
    "hpda_stress_clutter_mean",
    "hpda_truth",
    "hpda_true_count",
    "simulate_hpda_scans",
    "hpda_tracker_configs",
    "run_hpda_trial",
    "HPDA_ALGORITHMS",
    "HPDA_METRICS",
    "track_delays",
    "hpda_run_metrics",
    "count_error_ci",
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
    """Scenario and sensor parameters of one environment (Table 2, reconstructed).

    ``pd`` detection probability (in (0, 1)), ``snr`` linear mean SNR rho (>= 0),
    ``clutter_mean`` lambda V, the expected clutter returns per scan in the disc
    (>= 0), ``T`` scan period [s], ``n_scans`` (scans ``k = 0 .. n_scans - 1``),
    ``radius`` of the surveillance disc [m], ``sigma_r`` range noise std [m],
    ``sigma_theta`` bearing noise std [rad], ``sigma_a`` process-noise acceleration
    std [m/s^2], ``a_m`` manoeuvre acceleration [m/s^2].  Every field is checked
    when the record is built.

    Examples
    --------
    >>> from trackcore.scenarios.hpda_scenario import HpdaParameters
    >>> p = HpdaParameters(pd=0.9, snr=10.0, clutter_mean=10.0)
    >>> round(p.tau, 3), p.n_scans, round(p.clutter_density_xy * 1e9, 3)
    (1.159, 451, 31.831)
    """
    pd: float
    snr: float
    clutter_mean: float
    T: float = 10.0
    n_scans: int = 451
    radius: float = 1.0e4
    sigma_r: float = 50.0
    sigma_theta: float = math.radians(0.1)
    sigma_a: float = 0.0015
    a_m: float = 0.01

    def __post_init__(self):
        _finite(self, "pd", low=0.0, high=1.0, low_open=True, high_open=True)
        _finite(self, "snr", low=0.0)
        _finite(self, "clutter_mean", low=0.0)
        _finite(self, "T", low=0.0, low_open=True)
        _integer(self, "n_scans", 1)
        _finite(self, "radius", low=0.0, low_open=True)
        _finite(self, "sigma_r", low=0.0, low_open=True)
        _finite(self, "sigma_theta", low=0.0, high=math.pi, low_open=True)
        _finite(self, "sigma_a", low=0.0)
        _finite(self, "a_m", low=0.0)

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


#: the stress environment's sensor: three times the paper's range noise, thirty times
#: its bearing noise
STRESS_SIGMA_R = 150.0
STRESS_SIGMA_THETA = math.radians(3.0)


def hpda_stress_clutter_mean(lambda_vg=1.0, *, reference_range=5000.0, sigma_r=STRESS_SIGMA_R,
                             sigma_theta=STRESS_SIGMA_THETA, radius=1.0e4,
                             gate_probability=0.99):
    """Clutter per scan ``lambda V`` that puts ``lambda_vg`` expected false returns in a
    gate at ``reference_range``.

    The gate is taken at its floor, ``S = R`` (a track's predicted spread only widens
    it): ``V_G = pi g^2 sigma_r sigma_theta`` in (m rad), ``g^2`` the 2-dof chi-square
    point of ``gate_probability``.  Clutter uniform over the disc of radius ``radius``
    has polar density ``lambda_z = lambda V r / (pi radius^2)``, so
    ``lambda V = lambda_vg radius^2 / (r g^2 sigma_r sigma_theta)``.

    Examples
    --------
    >>> from trackcore.scenarios.hpda_scenario import hpda_stress_clutter_mean
    >>> round(hpda_stress_clutter_mean(), 1), round(hpda_stress_clutter_mean(2.0), 1)
    (276.5, 553.0)
    """
    lv = as_positive(lambda_vg, "lambda_vg")
    r = as_positive(reference_range, "reference_range")
    sr = as_positive(sigma_r, "sigma_r")
    st = as_positive(sigma_theta, "sigma_theta")
    rad = as_positive(radius, "radius")
    pg = as_probability(gate_probability, "gate_probability", open_low=True, open_high=True)
    g2 = -2.0 * math.log(1.0 - pg)
    if not g2 > 0.0:
        raise ValueError(f"gate_probability must be large enough for a gate of non-zero size, "
                         f"got {pg}")
    out = lv * rad * rad / (r * g2 * sr * st)
    if not math.isfinite(out):
        raise ValueError("lambda_vg, radius, reference_range, sigma_r and sigma_theta give a "
                         "clutter mean that is not finite")
    return out


def hpda_parameters(case: int) -> HpdaParameters:
    """Case 1: ``(P_D, rho, lambda V) = (0.9, 10, 10)``; case 2: ``(0.6, 5, 50)``
    (the paper's two environments).  Case 3 (the book's stress environment, not in the
    paper): case 1's detection ``(P_D, rho) = (0.9, 10)`` with a coarse sensor
    (``sigma_r = 150`` m, ``sigma_theta = 3`` deg) and the clutter of
    :func:`hpda_stress_clutter_mean` (one false return expected in a gate at 5 km,
    about 276 per scan).

    Examples
    --------
    >>> from trackcore.scenarios.hpda_scenario import hpda_parameters
    >>> [(p.pd, p.snr, p.clutter_mean) for p in map(hpda_parameters, (1, 2))]
    [(0.9, 10.0, 10.0), (0.6, 5.0, 50.0)]
    >>> round(hpda_parameters(3).clutter_mean, 1)
    276.5
    """
    case = as_int(case, "case")
    if case == 1:
        return HpdaParameters(pd=0.9, snr=10.0, clutter_mean=10.0)
    if case == 2:
        return HpdaParameters(pd=0.6, snr=5.0, clutter_mean=50.0)
    if case == 3:
        return HpdaParameters(pd=0.9, snr=10.0, clutter_mean=hpda_stress_clutter_mean(),
                              sigma_r=STRESS_SIGMA_R, sigma_theta=STRESS_SIGMA_THETA)
    raise ValueError(f"case must be 1, 2 or 3, got {case}")


class HpdaTruth(NamedTuple):
    """Noise-free truth of the six targets of Table 1 (:func:`hpda_truth`).

    Examples
    --------
    >>> from trackcore.scenarios.hpda_scenario import hpda_truth
    >>> truth = hpda_truth()
    >>> type(truth).__name__, truth.states.shape, truth.births.tolist()
    ('HpdaTruth', (451, 6, 4), [0, 100, 150, 250, 300, 150])
    """
    states: np.ndarray   # (K, 6, 4), NaN where the target is not alive
    alive: np.ndarray    # (K, 6) bool
    modes: np.ndarray    # (K, 6) int: 1 CV, 2 left turn, 3 right turn, 0 not alive
    births: np.ndarray   # (6,) birth scans
    deaths: np.ndarray   # (6,) death scans (last alive scan)


class HpdaScans(NamedTuple):
    """All scans of one run, concatenated: scan ``k`` is rows
    ``offsets[k]:offsets[k+1]``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import hpda_parameters, hpda_truth, simulate_hpda_scans
    >>> scans = simulate_hpda_scans(hpda_truth(), hpda_parameters(1), np.random.default_rng(0))
    >>> type(scans).__name__, scans.n_scans, scans.scan(0)[0].shape[1]
    ('HpdaScans', 451, 2)
    """
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
    """Noise-free truth of Table 1 (see module docstring for the variants).

    Examples
    --------
    >>> from trackcore.scenarios.hpda_scenario import hpda_truth
    >>> truth = hpda_truth()
    >>> truth.states.shape, truth.deaths.tolist(), int((truth.modes >= 2).sum())
    ((451, 6, 4), [200, 350, 400, 450, 450, 350], 120)
    """
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
    """True number of targets per scan (Fig 5).

    Examples
    --------
    >>> from trackcore.scenarios.hpda_scenario import hpda_true_count, hpda_truth
    >>> n = hpda_true_count(hpda_truth())
    >>> int(n.max()), round(float(n.mean()), 3)
    (5, 2.785)
    """
    if not isinstance(truth, HpdaTruth):
        raise TypeError(f"truth must be HpdaTruth, got {type(truth).__name__}")
    return truth.alive.sum(axis=1)


def _scan_order(scan, key, offsets):
    """``np.lexsort((key, scan))``, the same permutation (by scan, then key, then index)
    in a third of the time for a run's returns: a stable sort by scan, then a stable sort
    by key within each scan's ``offsets[k]:offsets[k + 1]`` (the scans' row ranges).

    Examples
    --------
    >>> import numpy as np
    >>> scan, key = np.array([1, 0, 1, 0, 1]), np.array([0.5, 0.7, 0.2, 0.7, 0.5])
    >>> _scan_order(scan, key, np.array([0, 2, 5])), np.lexsort((key, scan))
    (array([1, 3, 2, 0, 4]), array([1, 3, 2, 0, 4]))
    """
    by_scan = np.argsort(scan, kind="stable")
    key_by_scan = key[by_scan]
    order = np.empty_like(by_scan)
    for a, b in zip(offsets[:-1].tolist(), offsets[1:].tolist()):
        order[a:b] = by_scan[a:b][np.argsort(key_by_scan[a:b], kind="stable")]
    return order


def simulate_hpda_scans(truth: HpdaTruth, params: HpdaParameters, rng) -> HpdaScans:
    """Measurements of every scan: detections of live targets (P_D via the
    amplitude threshold) plus Poisson clutter, shuffled within each scan.

    Vectorised over all scans; randomness only from ``rng``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import hpda_parameters, hpda_truth, simulate_hpda_scans
    >>> scans = simulate_hpda_scans(hpda_truth(), hpda_parameters(1), np.random.default_rng(0))
    >>> scans.n_scans, int((scans.origin >= 0).sum()), int((scans.origin < 0).sum())
    (451, 1140, 4514)
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
    if not np.all(np.isfinite(truth.states[kk, tt])):
        raise ValueError("truth.states must be finite wherever truth.alive is True")
    raw = rng.exponential(1.0 + params.snr, kk.size)
    det = raw > tau
    kk, tt, amp_t = kk[det], tt[det], raw[det]
    X = truth.states[kk, tt]
    r = np.hypot(X[:, 0], X[:, 1]) + params.sigma_r * rng.standard_normal(kk.size)
    th = np.arctan2(X[:, 1], X[:, 0]) + params.sigma_theta * rng.standard_normal(kk.size)
    # a noisy range below zero (a target passing close to the sensor) is the point
    # at range |r| on the opposite bearing
    neg = r < 0
    r[neg] = -r[neg]
    th[neg] += np.pi
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
    counts = np.bincount(scan, minlength=K)
    offsets = np.zeros(K + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    order = _scan_order(scan, key, offsets)
    return HpdaScans(np.ascontiguousarray(z[order]), np.ascontiguousarray(amp[order]),
                     offsets, origin[order])


#: algorithm keys of :func:`run_hpda_trial`
HPDA_ALGORITHMS = ("hpda", "phd", "clustering", "clustering_literal", "hpda_sn", "hpda_nn")

#: per-run metrics of :func:`hpda_run_metrics` (each a mean over the scans of one run)
HPDA_METRICS = ("abs_count_error", "sq_count_error", "ospa", "gospa_localisation",
                "gospa_missed", "gospa_false", "false_tracks", "coverage_straight",
                "coverage_turn")


def hpda_tracker_configs(params: HpdaParameters, **overrides):
    """Tracker configurations for one environment: a dict with keys of
    :data:`HPDA_ALGORITHMS`.

    * ``hpda``: HPDA-PF with eq (15); ``hpda_sn``/``hpda_nn``: the same tracker with
      the strongest- or nearest-neighbour rule in place of eq (15);
    * ``phd``: the SMC-PHD filter;
    * ``clustering``: the clustering hybrid as its authors would tune it -- ROI links
      with one scan of motion from the tracker's own velocity prior, the 99 % chi-square
      gate (``d^2 <= 9.21``), chains seeded from every scan of the window, a track's
      own gated measurement counted as support;
    * ``clustering_literal``: the printed reading (``d <= eps_w = 1``, no motion term,
      chains seeded at ``k - eta`` only, support from ROIs only).

    ``overrides`` maps an algorithm key to a dict of field overrides.

    Examples
    --------
    >>> from trackcore.scenarios.hpda_scenario import hpda_parameters, hpda_tracker_configs
    >>> cfgs = hpda_tracker_configs(hpda_parameters(1), phd={"birth_model": "per_return"})
    >>> sorted(cfgs), cfgs["phd"].birth_model, cfgs["hpda"].pi11
    (['clustering', 'clustering_literal', 'hpda', 'hpda_nn', 'hpda_sn', 'phd'], 'per_return', 0.99)
    """
    if not isinstance(params, HpdaParameters):
        raise TypeError(f"params must be HpdaParameters, got {type(params).__name__}")
    common = dict(T=params.T, sigma_r=params.sigma_r, sigma_theta=params.sigma_theta,
                  sigma_a=params.sigma_a, a_m=params.a_m)
    lam = params.clutter_density_xy
    hpda = HpdaPfConfig(pd=params.pd, snr=params.snr, clutter_density_xy=lam, **common)
    literal = ClusteringConfig(pd=params.pd, clutter_density_xy=lam, **common)
    cfgs = {
        "hpda": hpda,
        "phd": SmcPhdConfig(pd=params.pd, clutter_density_xy=lam, **common),
        "clustering": replace(literal, link_d2=CHI2_2_99,
                              link_motion_std=literal.velocity_std, seed_every_scan=True,
                              gated_support=True),
        "clustering_literal": literal,
        "hpda_sn": replace(hpda, selection="strongest"),
        "hpda_nn": replace(hpda, selection="nearest"),
    }
    for key, ov in overrides.items():
        if key not in cfgs:
            raise ValueError(f"unknown algorithm {key!r}; expected one of {HPDA_ALGORITHMS}")
        if not isinstance(ov, dict):
            raise TypeError(f"overrides[{key!r}] must be a dict of field values")
        cfgs[key] = replace(cfgs[key], **ov)
    return cfgs


def _run_algorithm(key, cfg, scans, rng):
    if key.startswith("hpda"):
        return hpda_pf_run(scans.z, scans.amplitude, scans.offsets, cfg, rng)
    if key == "phd":
        return smc_phd_run(scans.z, scans.offsets, cfg, rng)
    return clustering_run(scans.z, scans.offsets, cfg, rng)


def _check_run_truth(run, truth):
    if not isinstance(run, TrackerRun):
        raise TypeError(f"run must be a TrackerRun, got {type(run).__name__}")
    if not isinstance(truth, HpdaTruth):
        raise TypeError(f"truth must be HpdaTruth, got {type(truth).__name__}")
    K = truth.alive.shape[0]
    if np.shape(run.count) != (K,) or np.ndim(run.estimates) != 3 or \
            np.shape(run.estimates)[0] != K or np.shape(run.n_estimates) != (K,):
        raise ValueError(f"run must cover the truth's {K} scans")


def track_delays(run, truth: HpdaTruth, radius=500.0, T=10.0):
    """Confirmation delay (scans from birth until an estimate lies within
    ``radius`` of the target; NaN if never) and termination delay (scans
    after death until no estimate lies within ``radius`` of the target's
    CV-extrapolated position, ``T`` the scan period; capped at the end of the run)
    per target.

    Examples
    --------
    >>> import numpy as np
    >>> from dataclasses import replace
    >>> from trackcore.scenarios.hpda_scenario import (hpda_parameters, hpda_tracker_configs,
    ...                                                hpda_truth, simulate_hpda_scans)
    >>> from trackcore.trackers import smc_phd_run
    >>> p = replace(hpda_parameters(1), n_scans=60)
    >>> truth = hpda_truth(n_scans=60)
    >>> scans = simulate_hpda_scans(truth, p, np.random.default_rng(1))
    >>> run = smc_phd_run(scans.z, scans.offsets, hpda_tracker_configs(p)["phd"],
    ...                   np.random.default_rng(2))
    >>> from trackcore.scenarios.hpda_scenario import track_delays
    >>> conf, term = track_delays(run, truth)
    >>> conf.tolist(), term.tolist()
    ([1.0, nan, nan, nan, nan, nan], [nan, nan, nan, nan, nan, nan])
    """
    _check_run_truth(run, truth)
    radius = as_positive(radius, "radius")
    T = as_positive(T, "T")
    K, n_t = truth.alive.shape
    conf = np.full(n_t, np.nan)
    term = np.full(n_t, np.nan)
    for t in range(n_t):
        b, d = int(truth.births[t]), int(truth.deaths[t])
        for k in range(b, min(d, K - 1) + 1):
            n = run.n_estimates[k]
            if n and np.min(np.hypot(*(run.estimates[k, :n, :2]
                                       - truth.states[k, t, :2]).T)) < radius:
                conf[t] = k - b
                break
        if d >= K - 1:
            continue
        xd = truth.states[d, t]
        for k in range(d + 1, K):
            pos = xd[:2] + (k - d) * T * xd[2:]
            n = run.n_estimates[k]
            if not n or np.min(np.hypot(*(run.estimates[k, :n, :2] - pos).T)) >= radius:
                term[t] = k - d
                break
        else:
            term[t] = K - 1 - d
    return conf, term


@nb.njit(cache=True)
def _metrics_kernel(est, n_est, truth_xy, alive, turning, c, p, out, cover):
    """Per-scan OSPA, GOSPA parts and false tracks into ``out`` (K, 5); covered and
    live target-scans in straight flight and in turns into ``cover`` (4,)."""
    K = est.shape[0]
    cp = c ** p
    for k in range(K):
        nx = n_est[k]
        X = np.empty((nx, 2))
        for i in range(nx):
            X[i, 0] = est[k, i, 0]
            X[i, 1] = est[k, i, 1]
        ny = 0
        for t in range(alive.shape[1]):
            if alive[k, t]:
                ny += 1
        Y = np.empty((ny, 2))
        q = 0
        for t in range(alive.shape[1]):
            if alive[k, t]:
                Y[q, 0] = truth_xy[k, t, 0]
                Y[q, 1] = truth_xy[k, t, 1]
                q += 1
                near = False
                for i in range(nx):
                    dx = X[i, 0] - truth_xy[k, t, 0]
                    dy = X[i, 1] - truth_xy[k, t, 1]
                    if dx * dx + dy * dy <= c * c:
                        near = True
                        break
                j = 2 if turning[k, t] else 0
                cover[j + 1] += 1.0
                if near:
                    cover[j] += 1.0
        dist, loc, missed, false, n_missed, n_false = gospa_kernel(X, Y, c, p, 2.0)
        mn = min(nx, ny)
        n = max(nx, ny)
        n_cut = mn - (ny - n_missed)
        if n > 0:
            out[k, 0] = ((loc + n_cut * cp + cp * (n - mn)) / n) ** (1.0 / p)
        else:
            out[k, 0] = 0.0
        out[k, 1] = loc
        out[k, 2] = missed
        out[k, 3] = false
        nf = 0
        for i in range(nx):
            far = True
            for j in range(ny):
                dx = X[i, 0] - Y[j, 0]
                dy = X[i, 1] - Y[j, 1]
                if dx * dx + dy * dy <= c * c:
                    far = False
                    break
            if far:
                nf += 1
        out[k, 4] = nf


def hpda_run_metrics(run, truth: HpdaTruth, c=500.0, p=2.0):
    """Per-run metrics of one tracker run against the truth (keys :data:`HPDA_METRICS`).

    Means over the scans of the run: ``abs_count_error`` ``|N_hat - N|``,
    ``sq_count_error`` ``(N_hat - N)^2``, ``ospa`` (cut-off ``c`` [m], order ``p``, on
    positions), the three GOSPA parts (``alpha = 2``; localisation, missed, false, in
    m^p), ``false_tracks``, the number of estimates farther than ``c`` from every live
    target.  Fractions of live target-scans with an estimate within ``c`` of the
    target: ``coverage_straight`` (target flying straight) and ``coverage_turn``
    (target in its turn; NaN if the truth has no turn).

    Examples
    --------
    >>> import numpy as np
    >>> from dataclasses import replace
    >>> from trackcore.scenarios.hpda_scenario import (hpda_parameters, hpda_tracker_configs,
    ...                                                hpda_truth, simulate_hpda_scans)
    >>> from trackcore.trackers import smc_phd_run
    >>> p = replace(hpda_parameters(1), n_scans=60)
    >>> truth = hpda_truth(n_scans=60)
    >>> scans = simulate_hpda_scans(truth, p, np.random.default_rng(1))
    >>> run = smc_phd_run(scans.z, scans.offsets, hpda_tracker_configs(p)["phd"],
    ...                   np.random.default_rng(2))
    >>> from trackcore.scenarios.hpda_scenario import hpda_run_metrics
    >>> m = hpda_run_metrics(run, truth)
    >>> round(m["abs_count_error"], 3), round(m["ospa"], 1)
    (0.117, 77.0)
    """
    _check_run_truth(run, truth)
    c = as_positive(c, "c")
    p = as_positive(p, "p")
    if not (math.isfinite(p) and p >= 1.0):
        raise ValueError(f"p must be a finite number >= 1, got {p}")
    if not -300.0 < p * math.log10(c) < 300.0:
        # the metrics sum distances to the power p, capped at c**p
        raise ValueError(f"c**p must stay within double range, got c = {c}, p = {p}")
    n_true = truth.alive.sum(axis=1)
    K = n_true.shape[0]
    d = run.count - n_true
    per = np.zeros((K, 5))
    cover = np.zeros(4)
    est = np.ascontiguousarray(run.estimates, dtype=np.float64)
    _metrics_kernel(est, np.ascontiguousarray(run.n_estimates, dtype=np.int64),
                    np.ascontiguousarray(np.nan_to_num(truth.states[:, :, :2])), truth.alive,
                    truth.modes > 1, c, p, per, cover)
    with np.errstate(invalid="ignore", divide="ignore"):
        cov = (cover[0] / cover[1], cover[2] / cover[3] if cover[3] else np.nan)
    vals = (np.mean(np.abs(d)), np.mean(d * d), *per.mean(axis=0), *cov)
    return dict(zip(HPDA_METRICS, (float(v) for v in vals)))


def run_hpda_trial(rng, case, algorithms=("hpda", "phd", "clustering"), keep_estimates=False,
                   overrides=None, scenario_overrides=None, metrics=False):
    """One Monte Carlo run of the paper's experiment: simulate the scans of
    environment ``case`` (variant-B truth) and run every tracker in
    ``algorithms`` on them.  ``overrides`` maps algorithm keys to config
    field overrides; ``scenario_overrides`` replaces fields of the
    environment's :class:`HpdaParameters` (e.g. ``{"snr": 3.16}``) for both
    the simulation and the trackers.  Random streams:
    ``rng.spawn(1 + len(algorithms))`` (data first), so a tracker sees the same
    scans and the same particle stream whatever runs beside it.  Returns a dict
    ``{key: {"count", "aux", "conf_delay", "term_delay", ["metrics"],
    ["diagnostics"], ["run"]}}`` plus ``"n_measurements"``; ``metrics=True`` adds
    :func:`hpda_run_metrics`, HPDA runs add their selection diagnostics.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios.hpda_scenario import run_hpda_trial
    >>> out = run_hpda_trial(np.random.default_rng(0), 1, ("phd",),
    ...                      scenario_overrides={"n_scans": 40})
    >>> sorted(out), out["phd"]["count"].shape, out["n_measurements"]
    (['n_measurements', 'phd'], (40,), 468)
    """
    for flag, name in ((keep_estimates, "keep_estimates"), (metrics, "metrics")):
        if not isinstance(flag, (bool, np.bool_)):
            raise TypeError(f"{name} must be True or False, got {flag!r}")
    rng = as_rng(rng)
    params = hpda_parameters(case)
    if scenario_overrides:
        params = replace(params, **scenario_overrides)
    truth = _TRUTH_CACHE.get(params.n_scans)
    if truth is None:
        truth = _TRUTH_CACHE.setdefault(params.n_scans,
                                        hpda_truth("B", n_scans=params.n_scans))
    cfgs = hpda_tracker_configs(params, **(overrides or {}))
    for key in algorithms:
        if key not in cfgs:
            raise ValueError(f"unknown algorithm {key!r}; expected one of {HPDA_ALGORITHMS}")
    streams = rng.spawn(1 + len(algorithms))
    scans = simulate_hpda_scans(truth, params, streams[0])
    out = {"n_measurements": int(scans.offsets[-1])}
    for key, r in zip(algorithms, streams[1:]):
        res = _run_algorithm(key, cfgs[key], scans, r)
        conf, term = track_delays(res, truth, T=params.T)
        rec = {"count": res.count, "aux": res.aux, "conf_delay": conf, "term_delay": term}
        if metrics:
            rec["metrics"] = hpda_run_metrics(res, truth)
        if res.diagnostics is not None:
            rec["diagnostics"] = res.diagnostics
        if keep_estimates:
            rec["run"] = res
        out[key] = rec
    return out


_TRUTH_CACHE: dict = {}


def count_error_ci(counts, n_true, *, versus=None, paired=True, kind="e", early=None,
                   seed=0) -> Estimate:
    """The chapter's count errors over Monte Carlo runs, with a BCa bootstrap interval.

    ``counts`` ``(n_runs, K)``: estimated counts per run and scan; ``n_true`` ``(K,)``.
    With ``kind="e"`` the statistic is ``e = mean_k |Nbar_k - N_k|`` and with
    ``kind="s"`` it is ``s = mean_k (Nbar_k - N_k)``, ``Nbar_k`` the mean over runs;
    ``early=n`` restricts the mean over scans to the first ``n`` scans.  ``versus``
    (another algorithm's counts) gives the interval of the difference
    ``stat(counts) - stat(versus)``: paired (same runs, resampled together, equal
    shapes) or, with ``paired=False``, independent samples (e.g. two environments).
    The runs are resampled and ``Nbar`` recomputed for every resample.

    ``kind="e-bc"`` is ``e`` corrected for its run-to-run noise bias by the jackknife over
    runs, ``R e - (R - 1)`` times the mean of the ``R`` leave-one-run-out values of ``e``;
    the correction is recomputed in every resample, so the interval is that of the
    corrected statistic itself.  A ValueError is raised rather than an interval widened
    to contain the estimate (when the estimate falls outside the central 95 % of its own
    bootstrap distribution).

    Like the other interval functions of :mod:`trackcore.stats`, it needs at least
    :data:`~trackcore.stats.MIN_RUNS` runs in ``counts`` and in ``versus`` (ValueError
    below), for every ``kind``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios.hpda_scenario import count_error_ci
    >>> n_true = np.array([1, 1, 2, 2])
    >>> counts = n_true + np.random.default_rng(0).integers(-1, 2, size=(40, 4))
    >>> f"{count_error_ci(counts, n_true, kind='s'):+.3f}"
    '+0.081 [-0.044, +0.200]'
    """
    if kind not in ("e", "s", "e-bc"):
        raise ValueError(f"kind must be 'e', 's' or 'e-bc', got {kind!r}")
    C = as_array(counts, "counts", ndim=2)
    K = C.shape[1]
    N = as_array(n_true, "n_true", shape=(K,))
    k1 = K if early is None else as_int(early, "early", minimum=1)
    if k1 > K:
        raise ValueError(f"early must be <= {K}, got {k1}")
    D = [(C - N)[:, :k1]]
    if versus is not None:
        V = as_array(versus, "versus", ndim=2)
        if (paired and V.shape != C.shape) or V.shape[1] != K:
            raise ValueError(f"versus must have shape {C.shape if paired else ('n', K)}, "
                             f"got {V.shape}")
        D.append((V - N)[:, :k1])
    for Dm, name in zip(D, ("counts", "versus")):
        if Dm.shape[0] < MIN_RUNS:
            raise ValueError(
                f"{name} has {Dm.shape[0]} runs; count_error_ci needs at least {MIN_RUNS} "
                "(trackcore.stats.MIN_RUNS: with fewer, bootstrap intervals of means of "
                "non-0/1 values fall short of 93 % coverage); use more runs")

    def one(idx, Dm):
        ii = idx.astype(np.int64)
        b, m = ii.shape
        n = Dm.shape[0]
        flat = (ii + n * np.arange(b)[:, None]).ravel()
        W = np.bincount(flat, minlength=b * n).reshape(b, n)
        if kind == "e-bc":
            return _e_bc(W, Dm)
        M = (W / m) @ Dm
        return np.abs(M).mean(axis=1) if kind == "e" else M.mean(axis=1)

    if versus is None:
        est = bootstrap_ci(lambda i: one(i, D[0]), np.arange(D[0].shape[0], dtype=float),
                           seed=seed)
    elif paired:
        est = bootstrap_ci(lambda i: one(i, D[0]) - one(i, D[1]),
                           np.arange(D[0].shape[0], dtype=float), seed=seed)
    else:
        est = bootstrap_ci(lambda i, j: one(i, D[0]) - one(j, D[1]),
                           np.arange(D[0].shape[0], dtype=float),
                           np.arange(D[1].shape[0], dtype=float), paired=False, seed=seed)
    if kind == "e-bc" and "basic" in est.method:
        raise ValueError("the bias-corrected e lies outside the central interval of its own "
                         "bootstrap distribution; no interval is given for it")
    return est


def _e_bc(W, D):
    """Jackknife bias-corrected ``e`` of each resample.

    ``W`` ``(b, n)``: how often each of the ``n`` runs (rows of ``D``, count minus truth
    per scan) occurs in each resample of ``m = W.sum(1)`` runs.  Returns ``m e - (m - 1)``
    times the mean of the ``m`` leave-one-out values of ``e``; leaving out any copy of run
    ``j`` gives the same value, so run ``j`` enters that mean with weight ``W[:, j]``.
    """
    W = np.ascontiguousarray(W, dtype=float)
    D = np.ascontiguousarray(D, dtype=float)
    m = W.sum(axis=1)
    S = W @ D
    e = np.abs(S / m[:, None]).mean(axis=1)
    if _exact_in_integers(D, W):
        # counts minus truth: every sum below is an integer the floats hold exactly, so
        # integer arithmetic gives the same bits, about 6x faster
        loo = _loo_e_mean_int(W.astype(np.int64), S.astype(np.int64), D.astype(np.int64))
    else:
        loo = _loo_e_mean(W, S, D)
    return m * e - (m - 1.0) * loo


def _exact_in_integers(D, W):
    """Whether ``D`` holds integers small enough that every sum of :func:`_loo_e_mean`
    (at most ``sum(W) * K`` terms of size ``2 max|D| sum(W)``) is exact in float64."""
    if D.size == 0 or not np.all(np.isfinite(D)) or not np.array_equal(D, np.rint(D)):
        return False
    top = float(np.abs(D).max()) + 1.0
    terms = float(W.sum(axis=1).max()) + 1.0
    return 2.0 * top * terms * terms * D.shape[1] < 2.0**52


@nb.njit(cache=True)
def _loo_e_mean(W, S, D):
    """Mean over the copies in each resample of ``e`` with that copy left out."""
    b, n = W.shape
    K = S.shape[1]
    out = np.zeros(b)
    for i in range(b):
        m = 0.0
        for j in range(n):
            m += W[i, j]
        tot = 0.0
        for j in range(n):
            w = W[i, j]
            if w > 0:
                acc = 0.0
                for k in range(K):
                    acc += abs(S[i, k] - D[j, k])
                tot += w * acc
        out[i] = tot / (K * (m - 1.0) * m)
    return out


@nb.njit(cache=True)
def _loo_e_mean_int(W, S, D):
    """:func:`_loo_e_mean` for int64 ``W``, ``S``, ``D`` (exact integer sums; the same
    values as the float kernel whenever its sums are exact, see ``_exact_in_integers``)."""
    b, n = W.shape
    K = S.shape[1]
    out = np.zeros(b)
    for i in range(b):
        m = 0
        for j in range(n):
            m += W[i, j]
        tot = 0
        Si = S[i]
        for j in range(n):
            w = W[i, j]
            if w > 0:
                Dj = D[j]
                acc = 0
                for k in range(K):
                    acc += abs(Si[k] - Dj[k])
                tot += w * acc
        mf = float(m)
        out[i] = float(tot) / (K * (mf - 1.0) * mf)
    return out
