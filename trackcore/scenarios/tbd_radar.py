"""The radar scenario of chapter 003 (Kwon, Kang & Kwak 2016) -- **the book's choice**.

The paper gives no scenario numbers (positions, speeds, scan period, P_fa, noise,
clutter density).  This module implements the scenario the book fixed before running
any tracker (the chapter's scenario notebook lists it), so that the three trackers can be
compared:

* **Truth** (Fig 2): a low-observable aircraft, radar at the origin, z up, integrated at
  0.01 s from a piecewise acceleration profile and sampled every ``T = 1 s`` for 250
  scans: level approach along -x at 200 m/s from (50, 20, 7) km (k = 0-99); a descent
  with v_z ramping 0 -> -100 m/s over 3 s, holding, and ramping back over s 122-125
  (k = 100-124); a level 90° clockwise coordinated turn at ω = -π/20 rad/s (3.2 g,
  k = 125-134); exit along +y (k = 135-249).
* **SNR** (Fig 3): the radar equation with coherent integration over 100 pulses,
  L band (1.3 GHz), 35 dBi antennas, 10 dB noise figure, aspect-dependent RCS (Table 2:
  ref, ref + 5 dB from the top during the dive, ref + 3 dB from the side; ref = -20 dBsm,
  steps smoothed by a 3-scan moving average in dB), and ``P_t τ`` calibrated so that the
  mean SNR at k = 0 is 3.0 dB.  Per scan the target power fluctuates log-normally
  (σ = 3 dB, independent from scan to scan, constant within the dwell; ``"swerling1"``
  is the exponential ablation) and the detection statistic is ``ζ = |sqrt(S) + n|^2``,
  ``n ~ CN(0, 1)``.  The target is detected if ``ζ >= τ = 10^(thr/10)``.
* **Target measurement**: range, azimuth, elevation with σ = 25 m, 0.15°, 0.15°, range
  rate with σ = 2 m/s, converted to Cartesian.
* **Clutter** (Figs 4-5): per scan a homogeneous Poisson field of noise/clutter cells,
  ``ρ_0 = 2.820`` raw cells per km³, each with ``ζ ~ Exp(1)``, so the false alarms above
  ``τ`` have density ``ρ_0 e^{-τ}``, ``ζ = τ + Exp(1)`` and a Doppler ``U(-300, 300)`` m/s.
  The field is generated only inside a sphere of radius ``R + 5 km`` around the *true*
  target (statistically identical to the whole space for a tracker that never looks
  outside it; runs whose error exceeds 5 km must be flagged).

Detections are stored flat, scan after scan (``offsets`` as in CSR), so a run is a few
contiguous arrays that every tracker reads without a Python loop over detections.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_count, as_covariance, as_int, as_nonnegative,
                               as_positive, as_rng, as_scalar)
from ..trackers.tbd_pf import (_COV_LIMIT, _LIMIT, TBD_METHODS, TbdTrackerConfig, _bounded,
                               run_tbd_tracker, spherical_to_cartesian, tbd_nees,
                               tbd_position_errors)

__all__ = [
    "SPEED_OF_LIGHT",
    "BOLTZMANN",
    "TBD_THRESHOLDS_DB",
    "TbdRadarParameters",
    "TbdRadarTruth",
    "TbdRadarScans",
    "tbd_radar_truth",
    "simulate_tbd_radar",
    "select_threshold",
    "sample_clutter",
    "radar_equation_snr",
    "TBD_INITIAL_COVARIANCE",
    "TbdTrialResult",
    "tbd_paired_trial",
]

#: the initial covariance P_0 of every tracker: 300 m per position axis, 20 m/s per
#: velocity axis (the book's choice)
TBD_INITIAL_COVARIANCE = np.diag([300.0 ** 2] * 3 + [20.0 ** 2] * 3)

SPEED_OF_LIGHT = 299_792_458.0
BOLTZMANN = 1.380649e-23
#: the SNR thresholds of the paper's Fig 5 (dB)
TBD_THRESHOLDS_DB = (12.0, 9.0, 7.0, 5.0, 3.0)
_FLUCTUATIONS = ("lognormal", "swerling1", "none")


@dataclass(frozen=True)
class TbdRadarParameters:
    """Scenario parameters (all are the book's choices except the Table 2 entries: L band,
    N = 100 pulses, 35 dBi, 10 dB, RCS offsets).  Every field is checked when the record
    is built.

    Examples
    --------
    >>> from trackcore.scenarios import TbdRadarParameters
    >>> prm = TbdRadarParameters(processing_radius=1000.0)
    >>> prm.n_scans, prm.threshold_db, round(prm.threshold, 3)
    (250, 5.0, 3.162)
    >>> print(round(prm.wavelength, 4))
    0.2306
    """
    scan_period: float = 1.0
    n_scans: int = 250
    integration_step: float = 0.01
    frequency: float = 1.3e9
    n_pulses: int = 100
    gain_tx_db: float = 35.0
    gain_rx_db: float = 35.0
    noise_figure_db: float = 10.0
    loss_db: float = 0.0
    noise_temperature: float = 290.0
    rcs_ref_dbsm: float = -20.0
    rcs_offsets_db: tuple = (0.0, 5.0, 3.0, 3.0)   # by phase: front, top, side, side
    snr0_db: float = 3.0                            # calibrates P_t τ (mean SNR at k = 0)
    fluctuation: str = "lognormal"
    rcs_sigma_db: float = 3.0
    sigma_range: float = 25.0
    sigma_azimuth: float = math.radians(0.15)
    sigma_elevation: float = math.radians(0.15)
    sigma_range_rate: float = 2.0
    clutter_density: float = 2.820                  # raw cells per km^3 per scan
    clutter_doppler_max: float = 300.0
    threshold_db: float = 5.0
    processing_radius: float = 2500.0
    simulation_margin: float = 5000.0

    def __post_init__(self):
        if self.fluctuation not in _FLUCTUATIONS:
            raise ValueError(f"fluctuation must be one of {_FLUCTUATIONS}, "
                             f"got {self.fluctuation!r}")
        for name in ("scan_period", "integration_step", "frequency", "noise_temperature",
                     "sigma_range", "sigma_azimuth", "sigma_elevation", "sigma_range_rate",
                     "clutter_doppler_max", "processing_radius"):
            as_positive(getattr(self, name), name)
        for name in ("clutter_density", "rcs_sigma_db", "simulation_margin"):
            as_nonnegative(getattr(self, name), name)
        for name in ("gain_tx_db", "gain_rx_db", "noise_figure_db", "loss_db", "rcs_ref_dbsm",
                     "snr0_db", "threshold_db"):
            as_scalar(getattr(self, name), name)
        as_int(self.n_scans, "n_scans", minimum=1)
        as_int(self.n_pulses, "n_pulses", minimum=1)
        offs = self.rcs_offsets_db
        if not isinstance(offs, (tuple, list)) or len(offs) != 4:
            raise ValueError("rcs_offsets_db must hold 4 values (one per flight phase)")
        for v in offs:
            as_scalar(v, "rcs_offsets_db")
        ratio = self.scan_period / self.integration_step
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError("scan_period must be a whole multiple of integration_step")

    @property
    def wavelength(self) -> float:
        return SPEED_OF_LIGHT / self.frequency

    @property
    def threshold(self) -> float:
        """The detection threshold ``τ`` as a linear noise-normalised power."""
        return 10.0 ** (self.threshold_db / 10.0)


@dataclass(frozen=True)
class TbdRadarTruth:
    """The target's truth and mean SNR per scan.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> type(truth).__name__, truth.times[:3]
    ('TbdRadarTruth', array([0., 1., 2.]))
    """
    times: np.ndarray      # (K,) s
    states: np.ndarray     # (K, 6) [x, y, z, vx, vy, vz]
    phase: np.ndarray      # (K,) 1 approach, 2 descent, 3 turn, 4 exit
    rcs_dbsm: np.ndarray   # (K,) aspect-dependent mean RCS (smoothed)
    mean_snr: np.ndarray   # (K,) linear mean SNR
    pt_tau: float          # calibrated P_t τ (J)


@dataclass(frozen=True)
class TbdRadarScans:
    """All detections of one run, stored scan after scan.

    Scan ``k`` owns rows ``offsets[k]:offsets[k+1]``.  ``target_snr``/``target_zeta`` hold
    the realised target SNR and detection statistic of every scan (detected or not).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> pos, rr, snr, is_target = scans.scan(0)
    >>> pos.shape[1], bool(np.all(snr >= prm.threshold)), scans.scan_index.size == scans.snr.size
    (3, True, True)
    """
    positions: np.ndarray    # (M, 3) Cartesian, m
    range_rate: np.ndarray   # (M,) m/s
    snr: np.ndarray          # (M,) measured ζ, linear
    is_target: np.ndarray    # (M,) bool
    offsets: np.ndarray      # (K+1,) int64
    target_snr: np.ndarray   # (K,) realised S_k, linear
    target_zeta: np.ndarray  # (K,) ζ_k of the target cell
    threshold_db: float
    sim_radius: float

    @property
    def n_scans(self) -> int:
        return self.offsets.size - 1

    @property
    def scan_index(self) -> np.ndarray:
        return np.repeat(np.arange(self.n_scans), np.diff(self.offsets))

    def scan(self, k):
        """``(positions, range_rate, snr, is_target)`` of scan ``k``."""
        lo, hi = self.offsets[k], self.offsets[k + 1]
        return self.positions[lo:hi], self.range_rate[lo:hi], self.snr[lo:hi], self.is_target[lo:hi]


# ----------------------------------------------------------------------------- truth
@nb.njit(cache=True)
def _integrate_profile_kernel(p0, v0, dt, steps_per_scan, n_scans, out):
    """Integrate the scenario's acceleration profile; write the state at every scan."""
    p = p0.copy()
    v = v0.copy()
    om = -math.pi / 20.0
    a_dive = 100.0 / 3.0
    c = math.cos(om * dt)
    s = math.sin(om * dt)
    n_steps = steps_per_scan * (n_scans - 1)
    spt = steps_per_scan  # integration steps per second (scan_period = 1 s)
    for i in range(n_steps + 1):
        if i % steps_per_scan == 0:
            k = i // steps_per_scan
            for a in range(3):
                out[k, a] = p[a]
                out[k, 3 + a] = v[a]
        if i == n_steps:
            break
        # phase boundaries on the integration grid (integer step indices, no round-off)
        if 125.0 * spt <= i < 135.0 * spt:
            vx = v[0]
            vy = v[1]
            p[0] += (s * vx - (1.0 - c) * vy) / om
            p[1] += (s * vy + (1.0 - c) * vx) / om
            v[0] = c * vx - s * vy
            v[1] = s * vx + c * vy
            p[2] += v[2] * dt
        else:
            az = 0.0
            if 100.0 * spt <= i < 103.0 * spt:
                az = -a_dive
            elif 122.0 * spt <= i < 125.0 * spt:
                az = a_dive
            p[0] += v[0] * dt
            p[1] += v[1] * dt
            p[2] += v[2] * dt + 0.5 * az * dt * dt
            v[2] += az * dt


def radar_equation_snr(rcs_m2, range_m, pt_tau, params=TbdRadarParameters()):
    """Mean linear SNR ``P_t τ N G_t G_r λ² σ / ((4π)³ R⁴ k T_0 F L)``.

    ``rcs_m2`` (m², >= 0) and ``range_m`` (m, > 0) broadcast together; ``pt_tau`` (J, > 0)
    is the transmitted energy per pulse.

    Examples
    --------
    >>> from trackcore.scenarios import radar_equation_snr
    >>> s1 = radar_equation_snr(0.01, 50000.0, 1e-3)
    >>> s2 = radar_equation_snr(0.01, 25000.0, 1e-3)
    >>> import numpy as np
    >>> np.round(s2 / s1, 1)  # R^-4: half the range, 16 times the SNR
    array([16.])
    """
    if not isinstance(params, TbdRadarParameters):
        raise TypeError(f"params must be TbdRadarParameters, got {type(params).__name__}")
    rcs = _bounded(as_array(rcs_m2, "rcs_m2"), "rcs_m2")
    rng_m = _bounded(as_array(range_m, "range_m"), "range_m")
    if np.any(rcs < 0):
        raise ValueError("rcs_m2 must be >= 0 (a radar cross-section in m², not dBsm)")
    if np.any(rng_m <= 0):
        raise ValueError("range_m must be > 0")
    pt_tau = as_positive(pt_tau, "pt_tau")
    if pt_tau > _LIMIT:
        raise ValueError(f"pt_tau must be at most {_LIMIT:.0e} J, got {pt_tau:.3g}")
    try:
        np.broadcast_shapes(rcs.shape, rng_m.shape)
    except ValueError:
        raise ValueError(f"rcs_m2 {rcs.shape} and range_m {rng_m.shape} must broadcast "
                         f"together") from None
    g = 10.0 ** ((params.gain_tx_db + params.gain_rx_db) / 10.0)
    fl = 10.0 ** ((params.noise_figure_db + params.loss_db) / 10.0)
    num = pt_tau * params.n_pulses * g * params.wavelength ** 2 * rcs
    den = (4.0 * math.pi) ** 3 * rng_m ** 4 * BOLTZMANN * params.noise_temperature * fl
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        out = num / den
    if not np.all(np.isfinite(out)):
        raise ValueError("range_m is too small for the SNR to stay within double range")
    return out


def tbd_radar_truth(params=TbdRadarParameters()):
    """Truth trajectory, phases, aspect-dependent RCS and mean SNR of the chapter's
    scenario (its Figs 2 and 3).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> truth.states.shape, truth.phase[:3]
    ((20, 6), array([1, 1, 1]))
    >>> print(round(10 * np.log10(truth.mean_snr[0]), 2))  # snr0_db
    3.0
    """
    if not isinstance(params, TbdRadarParameters):
        raise TypeError(f"params must be TbdRadarParameters, got {type(params).__name__}")
    K = int(params.n_scans)
    T = params.scan_period
    if abs(T - 1.0) > 1e-12:
        raise ValueError("the scenario's profile is defined for scan_period = 1 s")
    steps = int(round(T / params.integration_step))
    states = np.empty((K, 6))
    _integrate_profile_kernel(np.array([50e3, 20e3, 7e3]), np.array([-200.0, 0.0, 0.0]),
                              params.integration_step, steps, K, states)
    k = np.arange(K)
    phase = np.select([k < 100, k < 125, k < 135], [1, 2, 3], default=4)
    offsets = np.asarray(params.rcs_offsets_db, dtype=float)[phase - 1]
    smooth = np.convolve(np.pad(offsets, 1, mode="edge"), np.ones(3) / 3.0, mode="valid")
    rcs_dbsm = params.rcs_ref_dbsm + smooth
    rng_m = np.linalg.norm(states[:, :3], axis=1)
    unit = radar_equation_snr(10.0 ** (rcs_dbsm / 10.0), rng_m, 1.0, params)
    pt_tau = 10.0 ** (params.snr0_db / 10.0) / unit[0]
    return TbdRadarTruth(k * T, states, phase, rcs_dbsm, pt_tau * unit, float(pt_tau))


# ----------------------------------------------------------------------------- clutter
def sample_clutter(centers, radius, threshold, density_per_km3, doppler_max, rng):
    """False alarms above ``threshold`` (linear) in spheres around ``centers (K, 3)``.

    Per sphere a Poisson number with mean ``density · e^{-threshold} · V``, positions
    uniform in the ball, ``ζ = threshold + Exp(1)``, Doppler ``U(-doppler_max, doppler_max)``.
    Returns ``(positions (M, 3), range_rate (M,), zeta (M,), counts (K,))`` in sphere order.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import sample_clutter
    >>> pos, rr, zeta, counts = sample_clutter(np.zeros((2, 3)), 1000.0, 3.16, 2.82, 300.0,
    ...     np.random.default_rng(0))
    >>> counts.shape, int(counts.sum()) == len(zeta), bool(np.all(zeta >= 3.16))
    ((2,), True, True)
    >>> bool(np.all(np.linalg.norm(pos, axis=1) <= 1000.0))
    True
    """
    rng = as_rng(rng)
    C = _bounded(as_array(centers, "centers", ndim=2), "centers")
    if C.shape[1] != 3:
        raise ValueError(f"centers must have shape (K, 3), got {C.shape}")
    radius = as_positive(radius, "radius")
    if not radius <= 1e100:
        raise ValueError(f"radius must be at most 1e100 m, got {radius}")
    threshold = float(threshold)
    if not np.isfinite(threshold) or threshold < 0:
        raise ValueError(f"threshold must be a finite linear power >= 0, got {threshold}")
    if not (np.isfinite(density_per_km3) and density_per_km3 >= 0):
        raise ValueError(f"density_per_km3 must be finite and >= 0, got {density_per_km3}")
    doppler_max = as_positive(doppler_max, "doppler_max")
    volume_km3 = 4.0 / 3.0 * math.pi * (radius / 1000.0) ** 3
    mean = density_per_km3 * math.exp(-threshold) * volume_km3
    if not mean * C.shape[0] <= 1e8:
        raise ValueError(f"about {mean * C.shape[0]:.3g} false alarms to draw: reduce "
                         f"radius, density_per_km3 or the number of centers (at most 1e8)")
    counts = rng.poisson(mean, size=C.shape[0])
    M = int(counts.sum())
    u = rng.standard_normal((M, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    rad = radius * rng.random(M) ** (1.0 / 3.0)
    pos = np.repeat(C, counts, axis=0) + u * rad[:, None]
    zeta = threshold + rng.standard_exponential(M)
    rdot = rng.uniform(-doppler_max, doppler_max, M)
    return pos, rdot, zeta, counts


# ----------------------------------------------------------------------------- one run
def simulate_tbd_radar(truth, params=TbdRadarParameters(), rng=None):
    """One run of detections (target + false alarms) at ``params.threshold_db``.

    Random draws, in order: the target's power fluctuation and receiver noise for every
    scan, its measurement noise, then the clutter.  The same ``rng`` state therefore gives
    the same target realisation for any clutter setting.  Detections of a scan are
    stored target first (if detected), then false alarms.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> scans.n_scans, scans.positions.shape[1], bool(scans.is_target.sum() <= 20)
    (20, 3, True)
    """
    if not isinstance(truth, TbdRadarTruth):
        raise TypeError(f"truth must be TbdRadarTruth, got {type(truth).__name__}")
    if not isinstance(params, TbdRadarParameters):
        raise TypeError(f"params must be TbdRadarParameters, got {type(params).__name__}")
    rng = as_rng(rng)
    K = truth.states.shape[0]
    S_bar = truth.mean_snr
    if params.fluctuation == "lognormal":
        S = S_bar * 10.0 ** (0.1 * params.rcs_sigma_db * rng.standard_normal(K))
    elif params.fluctuation == "swerling1":
        S = S_bar * rng.standard_exponential(K)
    else:
        S = S_bar.copy()
    noise = (rng.standard_normal(K) + 1j * rng.standard_normal(K)) / math.sqrt(2.0)
    zeta_t = np.abs(np.sqrt(S) + noise) ** 2
    # target measurement noise (drawn for every scan, used where detected)
    p = truth.states[:, :3]
    r = np.linalg.norm(p, axis=1)
    az = np.arctan2(p[:, 1], p[:, 0])
    el = np.arcsin(p[:, 2] / r)
    rdot = np.einsum("ij,ij->i", p, truth.states[:, 3:]) / r
    e = rng.standard_normal((K, 4))
    z_sph = np.column_stack([r + params.sigma_range * e[:, 0], az + params.sigma_azimuth * e[:, 1],
                             el + params.sigma_elevation * e[:, 2]])
    t_pos = spherical_to_cartesian(z_sph)
    t_rdot = rdot + params.sigma_range_rate * e[:, 3]
    tau = params.threshold
    det = zeta_t >= tau
    sim_radius = params.processing_radius + params.simulation_margin
    c_pos, c_rdot, c_zeta, counts = sample_clutter(p, sim_radius, tau, params.clutter_density,
                                                   params.clutter_doppler_max, rng)
    per_scan = counts + det.astype(np.int64)
    offsets = np.zeros(K + 1, dtype=np.int64)
    np.cumsum(per_scan, out=offsets[1:])
    M = int(offsets[-1])
    # target first in its scan: its row is offsets[k]; clutter fills the rest in order
    is_target = np.zeros(M, dtype=bool)
    is_target[offsets[:-1][det]] = True
    positions = np.empty((M, 3))
    range_rate = np.empty(M)
    snr = np.empty(M)
    positions[is_target] = t_pos[det]
    range_rate[is_target] = t_rdot[det]
    snr[is_target] = zeta_t[det]
    positions[~is_target] = c_pos
    range_rate[~is_target] = c_rdot
    snr[~is_target] = c_zeta
    return TbdRadarScans(positions, range_rate, snr, is_target, offsets, S, zeta_t,
                         float(params.threshold_db), float(sim_radius))


def select_threshold(scans, threshold_db):
    """The detections of ``scans`` with ``ζ >= 10^(threshold_db/10)`` (a higher threshold
    than the one simulated gives exactly the detections that threshold would have).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> truth = tbd_radar_truth(prm)
    >>> from trackcore.scenarios import select_threshold
    >>> scans = simulate_tbd_radar(truth, prm, np.random.default_rng(1))
    >>> high = select_threshold(scans, 7.0)
    >>> bool(np.all(high.snr >= 10 ** 0.7)), high.snr.size < scans.snr.size
    (True, True)
    """
    if not isinstance(scans, TbdRadarScans):
        raise TypeError(f"scans must be TbdRadarScans, got {type(scans).__name__}")
    thr = float(threshold_db)
    if not (np.isfinite(thr) and thr <= 3000.0):
        raise ValueError(f"threshold_db must be finite and at most 3000 dB, got {threshold_db}")
    if not (isinstance(scans.sim_radius, (int, float)) and scans.sim_radius > 0
            and math.isfinite(scans.sim_radius)):
        raise ValueError(f"scans.sim_radius must be a finite positive radius, got "
                         f"{scans.sim_radius!r}")
    if thr < scans.threshold_db - 1e-12:
        raise ValueError(f"threshold_db must be >= the simulated threshold "
                         f"{scans.threshold_db} dB, got {thr}")
    keep = scans.snr >= 10.0 ** (thr / 10.0)
    counts = np.bincount(scans.scan_index[keep], minlength=scans.n_scans)
    offsets = np.zeros(scans.n_scans + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return TbdRadarScans(scans.positions[keep], scans.range_rate[keep], scans.snr[keep],
                         scans.is_target[keep], offsets, scans.target_snr, scans.target_zeta,
                         thr, scans.sim_radius)


# ----------------------------------------------------------------------------- paired Monte Carlo run
@dataclass(frozen=True)
class TbdTrialResult:
    """One paired Monte Carlo run: every tracker on the same detections and start.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, tbd_paired_trial
    >>> from trackcore.trackers import TbdTrackerConfig
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> cfgs = {"C": TbdTrackerConfig(n_particles=100, processing_radius=1000.0)}
    >>> res = tbd_paired_trial(np.random.default_rng(3), cfgs, prm, keep=True)
    >>> type(res).__name__, res.scans.n_scans, sorted(res.tracks)
    ('TbdTrialResult', 20, ['C'])
    """
    errors: dict        # name -> (K,) E_err(k) (eq 20)
    n_processed: dict   # name -> (K,) detections inside the processing sphere
    nees: dict          # name -> (K,) NEES of the 6-D state (trackcore.trackers.tbd_nees),
    #                     for the configurations whose method is in nees_methods
    x0: np.ndarray      # (6,) the shared initial estimate
    scans: object       # TbdRadarScans (None unless keep=True)
    tracks: dict        # name -> TbdTrackResult (empty unless keep=True)


def tbd_paired_trial(rng, configs, params=TbdRadarParameters(), truth=None,
                     P0=TBD_INITIAL_COVARIANCE, keep=False, nees_methods=("A",)):
    """One run of the chapter's experiment, for :func:`trackcore.montecarlo.run`.

    ``rng`` is split into a scenario stream (detections, then ``x0 ~ N(s_0, P0)``) and a
    filter stream per tracker *method* (``TBD_METHODS`` order), so every configuration of a
    method sees the same random numbers (common random numbers across ablations) and
    every method sees the same detections and start.  ``configs``: dict name ->
    :class:`~trackcore.trackers.TbdTrackerConfig`.  ``truth`` defaults to
    ``tbd_radar_truth(params)``.  ``keep=True`` also returns the scans and full tracks.
    ``nees_methods``: the method letters whose NEES is computed (the particle filters'
    weighted covariance costs about a sixth of their run time; the EKF's is free).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, tbd_paired_trial
    >>> from trackcore.trackers import TbdTrackerConfig
    >>> prm = TbdRadarParameters(n_scans=20, processing_radius=1000.0)
    >>> cfgs = {m: TbdTrackerConfig(method=m, n_particles=100, processing_radius=1000.0)
    ...     for m in "BC"}
    >>> res = tbd_paired_trial(np.random.default_rng(3), cfgs, prm)
    >>> sorted(res.errors), res.errors['C'].shape, res.x0.shape
    (['B', 'C'], (20,), (6,))
    """
    if not isinstance(keep, (bool, np.bool_)):
        raise TypeError(f"keep must be True or False, got {keep!r}")
    rng = as_rng(rng)
    if not isinstance(configs, dict) or not configs:
        raise TypeError("configs must be a non-empty dict of name -> TbdTrackerConfig")
    for name, cfg in configs.items():
        if not isinstance(cfg, TbdTrackerConfig):
            raise TypeError(f"configs[{name!r}] must be a TbdTrackerConfig")
    if not isinstance(params, TbdRadarParameters):
        raise TypeError(f"params must be TbdRadarParameters, got {type(params).__name__}")
    if truth is None:
        truth = tbd_radar_truth(params)
    if not isinstance(truth, TbdRadarTruth):
        raise TypeError(f"truth must be TbdRadarTruth, got {type(truth).__name__}")
    P0 = _bounded(as_covariance(P0, "P0", 6, strict=True), "P0", _COV_LIMIT)
    if isinstance(nees_methods, str) or not all(m in TBD_METHODS for m in nees_methods):
        raise ValueError(f"nees_methods must be a sequence of letters from {TBD_METHODS}, "
                         f"got {nees_methods!r}")
    r_scene, r_filter = rng.spawn(2)
    scans = simulate_tbd_radar(truth, params, r_scene)
    x0 = truth.states[0] + np.linalg.cholesky(P0) @ r_scene.standard_normal(6)
    seeds = r_filter.bit_generator.seed_seq.spawn(len(TBD_METHODS))
    errors, nproc, nees, tracks = {}, {}, {}, {}
    caches = {}  # log P_D of eq (9) per detection, shared by trackers with the same P_fa
    for name, cfg in configs.items():
        g = np.random.default_rng(seeds[TBD_METHODS.index(cfg.method)])
        want = cfg.method in nees_methods
        cache = caches.setdefault(cfg.pfa, np.full(scans.positions.shape[0], np.nan))
        res = run_tbd_tracker(scans, x0, P0, g, cfg, covariances=want, log_pd_cache=cache)
        errors[name] = tbd_position_errors(res.estimates, truth.states)
        nproc[name] = res.n_processed
        if want:
            nees[name] = tbd_nees(res.estimates, res.covariances, truth.states)
        if keep:
            tracks[name] = res
    return TbdTrialResult(errors, nproc, nees, x0, scans if keep else None, tracks)


# ----------------------------------------------------------------------------- clutter everywhere
#: Offset added to a cube's lattice index so that it is a non-negative spawn key.
_CUBE_OFFSET = 1 << 30


def _cube_clutter(field, k, index, cube, rate_per_km3, threshold, doppler_max, centre,
                  sim_radius):
    """False alarms of scan ``k`` in the lattice cube ``index`` (side ``cube`` m) outside
    the sphere ``sim_radius`` around ``centre`` (that sphere is the base field's).

    The draws come from their own stream (``field``'s entropy and spawn key extended by
    ``k`` and the cube's index), so a cube holds the same points whenever it is drawn:
    the cubes are pieces of one Poisson field over all of space."""
    key = tuple(field.spawn_key) + (int(k),) + tuple(int(i) + _CUBE_OFFSET for i in index)
    g = np.random.default_rng(np.random.SeedSequence(field.entropy, spawn_key=key))
    n = g.poisson(rate_per_km3 * (cube / 1000.0) ** 3)
    pos = (np.asarray(index, dtype=np.float64) + g.random((n, 3))) * cube
    zeta = threshold + g.standard_exponential(n)
    rdot = g.uniform(-doppler_max, doppler_max, n)
    out = np.linalg.norm(pos - centre, axis=1) > sim_radius
    return pos[out], rdot[out], zeta[out]


def _with_cubes(base, cubes):
    """``base`` (TbdRadarScans) with the false alarms of ``cubes`` ({(k, i, j, l): (pos,
    rdot, zeta)}) appended to their scans, in the order of the keys."""
    if not cubes:
        return base
    keys = sorted(cubes)
    ks = np.concatenate([np.full(cubes[q][0].shape[0], q[0], dtype=np.int64) for q in keys])
    order = np.argsort(np.concatenate([base.scan_index, ks]), kind="stable")
    cat = [np.concatenate([a, *(cubes[q][j] for q in keys)])[order]
           for j, a in enumerate((base.positions, base.range_rate, base.snr))]
    is_target = np.concatenate([base.is_target, np.zeros(ks.size, dtype=bool)])[order]
    offsets = np.zeros(base.n_scans + 1, dtype=np.int64)
    np.cumsum(np.bincount(ks, minlength=base.n_scans) + np.diff(base.offsets),
              out=offsets[1:])
    return TbdRadarScans(cat[0], cat[1], cat[2], is_target, offsets, base.target_snr,
                         base.target_zeta, base.threshold_db, base.sim_radius)


def _cubes_needed(centres, truth_pos, radius, sim_radius, cube, pad):
    """Keys ``(k, i, j, l)`` of the lattice cubes that meet the box of half-side
    ``radius + pad`` around ``centres[k]``, for every scan whose processing sphere
    (``radius`` around ``centres[k]``) is not inside the base sphere."""
    d = np.linalg.norm(centres - truth_pos, axis=1)
    out = set()
    for k in np.flatnonzero(~(d + radius <= sim_radius)):
        lo = np.floor((centres[k] - radius - pad) / cube).astype(np.int64)
        hi = np.floor((centres[k] + radius + pad) / cube).astype(np.int64)
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                for m in range(lo[2], hi[2] + 1):
                    out.add((int(k), int(i), int(j), int(m)))
    return out


def _everywhere_trial(rng, configs, params=TbdRadarParameters(), truth=None,
                      P0=TBD_INITIAL_COVARIANCE, cube=5000.0, max_rounds=2000):
    """One paired run of :func:`tbd_paired_trial` with **clutter everywhere**: the base
    field (the sphere ``R + simulation_margin`` around the truth, drawn exactly as there)
    plus, wherever a tracker's processing sphere leaves it, the false alarms of lattice
    cubes of side ``cube`` drawn lazily from the run's third stream (same density and
    marks; points inside the base sphere dropped, since the base field covers it).

    A tracker whose processing spheres are not all inside the simulated region is run
    again with the missing cubes (and their neighbours within half a cube) added, until
    every sphere of its run is covered; a cube's points never depend on when it was
    drawn, so the result is the run on one Poisson field over all of space.  A run in
    which no sphere leaves the base sphere is the same as :func:`tbd_paired_trial`'s.
    Returns ``SimpleNamespace(errors, x0, reach, rounds)``: ``reach`` per tracker the
    largest distance of its window centre from the truth (m), ``rounds`` the runs of the
    trackers needed.
    """
    from types import SimpleNamespace

    rng = as_rng(rng)
    if truth is None:
        truth = tbd_radar_truth(params)
    cube = as_positive(cube, "cube")
    r_scene, r_filter = rng.spawn(2)
    field = rng.spawn(1)[0].bit_generator.seed_seq
    base = simulate_tbd_radar(truth, params, r_scene)
    x0 = truth.states[0] + np.linalg.cholesky(P0) @ r_scene.standard_normal(6)
    seeds = r_filter.bit_generator.seed_seq.spawn(len(TBD_METHODS))
    p = truth.states[:, :3]
    tau = params.threshold
    rate = params.clutter_density * math.exp(-tau)
    cubes, errors, reach, todo = {}, {}, {}, list(configs)
    for rounds in range(1, max_rounds + 1):
        scans = _with_cubes(base, cubes)
        caches, missing = {}, set()
        for name in todo:
            cfg = configs[name]
            g = np.random.default_rng(seeds[TBD_METHODS.index(cfg.method)])
            cache = caches.setdefault(cfg.pfa, np.full(scans.positions.shape[0], np.nan))
            res = run_tbd_tracker(scans, x0, P0, g, cfg, covariances=cfg.method == "A",
                                  log_pd_cache=cache)
            need = _cubes_needed(res.window_centers, p, cfg.processing_radius,
                                 base.sim_radius, cube, 0.0)
            if need <= cubes.keys():
                errors[name] = tbd_position_errors(res.estimates, truth.states)
                reach[name] = float(np.linalg.norm(res.window_centers - p, axis=1).max())
            else:
                missing |= _cubes_needed(res.window_centers, p, cfg.processing_radius,
                                         base.sim_radius, cube, cube / 2)
        todo = [n for n in todo if n not in errors]
        if not todo:
            break
        for q in sorted(missing - cubes.keys()):
            cubes[q] = _cube_clutter(field, q[0], q[1:], cube, rate, tau,
                                     params.clutter_doppler_max, p[q[0]], base.sim_radius)
    else:
        raise RuntimeError(f"the trackers {todo} still leave the simulated clutter after "
                           f"{max_rounds} rounds")
    errors = {n: errors[n] for n in configs}
    return SimpleNamespace(errors=errors, x0=x0, reach={n: reach[n] for n in configs},
                           rounds=rounds)
