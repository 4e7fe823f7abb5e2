"""Raw-intensity (pre-detection) sensor for chapter 003's radar scenario -- **the book's
choice**, built for the comparison of the raw-intensity track-before-detect of
Salmond–Birch / Rutten with the detection-level trackers on one sensor.

Per scan a map of noise-normalised cell powers on the range–azimuth–elevation grid of
:class:`~trackcore.trackers.IntensityGrid` (75 m × 0.5° × 0.5° by default), defined over
all of space (:class:`~trackcore.trackers.IntensityMaps`):

* noise-only cells: ``z ~ Exp(1)`` (the power of ``n ~ CN(0, 1)``), drawn on demand
  from a counter-based generator, so every cell any filter reads exists;
* the 27 cells of the target's PSF footprint: ``z_c = |sqrt(S_k) e^{iφ_k} h_c + n_c|^2``
  (Rutten, Gordon & Maskell 2005), ``h_c`` the amplitude PSF of
  :func:`~trackcore.trackers.intensity_psf`, ``φ_k ~ U(0, 2π)`` a per-scan phase and
  ``S_k`` the realised per-scan SNR of the chapter's radar equation (its mean SNR along
  the truth times the log-normal or Swerling fluctuation), so a cell whose centre is the
  target has mean power ``1 + S_k``.

The map has no Doppler dimension.  The raw-intensity filter reads it cell by cell; the
detection-level trackers threshold it (local maxima at or above the threshold, see
:func:`~trackcore.trackers.intensity_detections`) inside their own processing windows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..core.validation import as_array, as_covariance, as_rng
from ..trackers.tbd_intensity_pf import (INTENSITY_FOOTPRINT, IntensityGrid, IntensityMaps,
                                         IntensityTbdConfig, psf_footprint_kernel,
                                         run_intensity_tbd, run_tbd_tracker_on_map)
from ..trackers.tbd_pf import _bounded, TbdTrackerConfig, tbd_nees, tbd_position_errors
from .tbd_radar import (TBD_INITIAL_COVARIANCE, TbdRadarParameters, TbdRadarTruth,
                        simulate_tbd_radar, tbd_radar_truth)

__all__ = [
    "simulate_intensity_maps",
    "IntensityTrialResult",
    "tbd_intensity_trial",
]


@nb.njit(cache=True)
def _footprint_kernel(pos, snr, phase, noise_re, noise_im, dr, dth, beta, centre, power):
    """Footprint centre cell and the 27 powers ``|sqrt(S) e^{iφ} h + n|^2`` of every scan."""
    K = pos.shape[0]
    cells = np.empty((27, 3), dtype=np.int64)
    h = np.empty(27)
    for k in range(K):
        x, y, z = pos[k, 0], pos[k, 1], pos[k, 2]
        r = math.sqrt(x * x + y * y + z * z)
        psf_footprint_kernel(r, math.atan2(y, x), math.asin(z / r), dr, dth, beta, cells, h)
        for a in range(3):
            centre[k, a] = cells[13, a]
        a_ = math.sqrt(snr[k])
        cr = a_ * math.cos(phase[k])
        ci = a_ * math.sin(phase[k])
        for t in range(27):
            re = cr * h[t] + noise_re[k, t]
            im = ci * h[t] + noise_im[k, t]
            power[k, t] = re * re + im * im


def simulate_intensity_maps(positions, snr, grid=IntensityGrid(), rng=None):
    """Intensity maps of one run for a target at ``positions (K, >=3)`` (Cartesian, radar
    at the origin) with realised per-scan SNR ``snr (K,)`` (linear, >= 0).

    Random draws, in order: the noise key of the map's noise cells, then per scan the
    target phase, then the 27 complex noise samples of every scan's footprint.  Returns
    :class:`~trackcore.trackers.IntensityMaps`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> maps.footprint_power.shape, bool(np.all(maps.footprint_power >= 0))
    ((5, 27), True)
    """
    if not isinstance(grid, IntensityGrid):
        raise TypeError(f"grid must be an IntensityGrid, got {type(grid).__name__}")
    rng = as_rng(rng)
    P = _bounded(as_array(positions, "positions", ndim=2), "positions")
    if P.shape[1] < 3:
        raise ValueError(f"positions must have shape (K, >=3), got {P.shape}")
    K = P.shape[0]
    if K == 0:
        raise ValueError("positions must hold at least one scan (the maps would be empty)")
    S = as_array(snr, "snr", shape=(K,))
    if np.any(S < 0):
        raise ValueError("snr must be a non-negative linear power ratio (not dB)")
    pos = np.ascontiguousarray(P[:, :3])
    if np.any(np.linalg.norm(pos, axis=1) == 0):
        raise ValueError("positions must not be at the radar (range 0)")
    key = int(rng.integers(0, 2 ** 63 - 1))
    phase = rng.uniform(0.0, 2.0 * math.pi, K)
    nz = rng.standard_normal((K, 2, INTENSITY_FOOTPRINT)) / math.sqrt(2.0)
    centre = np.empty((K, 3), dtype=np.int64)
    power = np.empty((K, INTENSITY_FOOTPRINT))
    _footprint_kernel(pos, S, phase, np.ascontiguousarray(nz[:, 0]),
                      np.ascontiguousarray(nz[:, 1]), grid.range_cell, grid.angle_cell,
                      grid.psf_width, centre, power)
    return IntensityMaps(centre, power, key, grid)


@dataclass(frozen=True)
class IntensityTrialResult:
    """One Monte Carlo run of the one-sensor comparison on the chapter's scenario.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, tbd_intensity_trial
    >>> from trackcore.trackers import IntensityTbdConfig, intensity_tracker_config
    >>> prm = TbdRadarParameters(n_scans=10)
    >>> cfgs = {"I": IntensityTbdConfig(n_particles=100),
    ...     "C": intensity_tracker_config("C", n_particles=100)}
    >>> res = tbd_intensity_trial(np.random.default_rng(4), cfgs, prm)
    >>> type(res).__name__, res.maps is None, res.x0.shape
    ('IntensityTrialResult', True, (6,))
    """
    errors: dict           # name -> (K,) E_err(k) (eq 20)
    nees: dict             # name -> (K,) NEES of the 6-D state (with nees=True)
    n_processed: dict      # name -> (K,) detections in the window (NaN for the intensity PF)
    x0: np.ndarray         # (6,) the shared initial estimate
    target_snr: np.ndarray  # (K,) realised S_k (identical to the detection-level run's)
    maps: object           # IntensityMaps (None unless keep=True)
    tracks: dict           # name -> track result (empty unless keep=True)


def tbd_intensity_trial(rng, configs, params=TbdRadarParameters(), truth=None,
                        grid=IntensityGrid(), P0=TBD_INITIAL_COVARIANCE, keep=False,
                        nees=False):
    """One run of the one-sensor comparison, paired with
    :func:`~trackcore.scenarios.tbd_paired_trial`.

    ``configs``: dict name -> :class:`~trackcore.trackers.IntensityTbdConfig` (the
    raw-intensity filter) or :class:`~trackcore.trackers.TbdTrackerConfig` (method B, C or
    P on the map's detections, see :func:`~trackcore.trackers.intensity_tracker_config`).
    ``rng`` is split exactly as :func:`~trackcore.scenarios.tbd_paired_trial` splits it,
    and the detection-level run is replayed from the scenario stream, so this run has the
    same realised target SNR ``S_k`` and the same initial estimate ``x0`` as the chapter's
    detection-level run of the same Monte Carlo index.  The map and the filters then draw
    from further children of ``rng``: one for the map, one per configuration *kind*
    (intensity filter, or the method letter), shared by configurations of the same kind.
    ``nees=True`` also computes every filter's NEES (their weighted covariances cost about
    a sixth of the run time).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import TbdRadarParameters, tbd_intensity_trial
    >>> from trackcore.trackers import IntensityTbdConfig, intensity_tracker_config
    >>> prm = TbdRadarParameters(n_scans=10)
    >>> cfgs = {"I": IntensityTbdConfig(n_particles=100),
    ...     "C": intensity_tracker_config("C", n_particles=100)}
    >>> res = tbd_intensity_trial(np.random.default_rng(4), cfgs, prm)
    >>> sorted(res.errors), res.errors['I'].shape, res.target_snr.shape
    (['C', 'I'], (10,), (10,))
    """
    rng = as_rng(rng)
    if not isinstance(configs, dict) or not configs:
        raise TypeError("configs must be a non-empty dict of name -> IntensityTbdConfig "
                        "or TbdTrackerConfig")
    for name, cfg in configs.items():
        if not isinstance(cfg, (IntensityTbdConfig, TbdTrackerConfig)):
            raise TypeError(f"configs[{name!r}] must be an IntensityTbdConfig or a "
                            f"TbdTrackerConfig")
        if isinstance(cfg, TbdTrackerConfig) and cfg.method not in ("B", "C", "P"):
            raise ValueError(f"configs[{name!r}].method must be 'B', 'C' or 'P' on a map, "
                             f"got {cfg.method!r}")
    if not isinstance(params, TbdRadarParameters):
        raise TypeError(f"params must be TbdRadarParameters, got {type(params).__name__}")
    if truth is None:
        truth = tbd_radar_truth(params)
    if not isinstance(truth, TbdRadarTruth):
        raise TypeError(f"truth must be TbdRadarTruth, got {type(truth).__name__}")
    P0 = as_covariance(P0, "P0", 6, strict=True)
    r_scene, _ = rng.spawn(2)
    scans = simulate_tbd_radar(truth, params, r_scene)
    x0 = truth.states[0] + np.linalg.cholesky(P0) @ r_scene.standard_normal(6)
    r_map, r_pf = rng.spawn(2)
    maps = simulate_intensity_maps(truth.states, scans.target_snr, grid, r_map)
    kinds = ("I", "B", "C", "P")
    seeds = r_pf.bit_generator.seed_seq.spawn(len(kinds))
    errors, nees_out, nproc, tracks = {}, {}, {}, {}
    for name, cfg in configs.items():
        if isinstance(cfg, IntensityTbdConfig):
            g = np.random.default_rng(seeds[0])
            res = run_intensity_tbd(maps, x0, P0, g, cfg, covariances=bool(nees))
            nproc[name] = np.full(truth.states.shape[0], np.nan)
        else:
            g = np.random.default_rng(seeds[kinds.index(cfg.method)])
            res = run_tbd_tracker_on_map(maps, x0, P0, g, cfg, covariances=bool(nees))
            nproc[name] = res.n_processed.astype(float)
        errors[name] = tbd_position_errors(res.estimates, truth.states)
        if nees:
            nees_out[name] = tbd_nees(res.estimates, res.covariances, truth.states)
        if keep:
            tracks[name] = res
    return IntensityTrialResult(errors, nees_out, nproc, x0, scans.target_snr,
                                maps if keep else None, tracks)
