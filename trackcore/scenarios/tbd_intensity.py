"""Raw-intensity (pre-detection) sensor for chapter 003's radar scenario -- **the book's
choice**, built for the Salmond–Birch / Rutten baseline of notebook 05.

Per scan a block of noise-normalised cell powers on the range–azimuth–elevation grid of
:class:`~trackcore.trackers.IntensityGrid` (75 m × 0.5° × 0.5° by default), centred on
the cell of the *true* target and ``half_range`` / ``half_angle`` cells wide either side
(the map is simulated only where a tracker that follows the target looks, as the clutter
of :mod:`trackcore.scenarios.tbd_radar` is; a filter that leaves the block is flagged).

* Noise-only cells: ``z ~ Exp(1)`` (the power of ``n ~ CN(0, 1)``).
* The 27 cells of the target's PSF footprint: ``z_c = |sqrt(S_k) e^{iφ_k} h_c + n_c|^2``
  (Rutten, Gordon & Maskell 2005), ``h_c`` the amplitude PSF of
  :func:`~trackcore.trackers.intensity_psf`, ``φ_k ~ U(0, 2π)`` a per-scan phase and
  ``S_k`` the realised per-scan SNR of the chapter's radar equation (its mean SNR along
  the truth times the log-normal or Swerling fluctuation), so a cell whose centre is the
  target has mean power ``1 + S_k``.

Its per-scan SNR is taken as an input, so a trial can feed the very same realised SNR
sequence to the detection-level trackers and to the intensity filter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..core.validation import as_array, as_covariance, as_rng
from ..trackers.tbd_intensity_pf import (INTENSITY_FOOTPRINT, IntensityGrid, IntensityMaps,
                                         IntensityTbdConfig, psf_footprint_kernel,
                                         run_intensity_tbd)
from ..trackers.tbd_pf import tbd_position_errors
from .tbd_radar import (TBD_INITIAL_COVARIANCE, TbdRadarParameters, TbdRadarTruth,
                        simulate_tbd_radar, tbd_radar_truth)

__all__ = [
    "simulate_intensity_maps",
    "IntensityTrialResult",
    "tbd_intensity_trial",
]


@nb.njit(cache=True)
def _add_target_kernel(pos, snr, phase, noise_re, noise_im, dr, dth, beta, power, origin):
    """Overwrite the footprint cells of scan ``k`` with ``|sqrt(S) e^{iφ} h + n|^2``."""
    K = pos.shape[0]
    nr, na, ne = power.shape[1], power.shape[2], power.shape[3]
    cells = np.empty((27, 3), dtype=np.int64)
    h = np.empty(27)
    for k in range(K):
        x, y, z = pos[k, 0], pos[k, 1], pos[k, 2]
        r = math.sqrt(x * x + y * y + z * z)
        psf_footprint_kernel(r, math.atan2(y, x), math.asin(z / r), dr, dth, beta, cells, h)
        a = math.sqrt(snr[k])
        cr = a * math.cos(phase[k])
        ci = a * math.sin(phase[k])
        for t in range(27):
            ia = cells[t, 0] - origin[k, 0]
            ib = cells[t, 1] - origin[k, 1]
            ic = cells[t, 2] - origin[k, 2]
            if ia < 0 or ia >= nr or ib < 0 or ib >= na or ic < 0 or ic >= ne:
                continue
            re = cr * h[t] + noise_re[k, t]
            im = ci * h[t] + noise_im[k, t]
            power[k, ia, ib, ic] = re * re + im * im


def simulate_intensity_maps(positions, snr, grid=IntensityGrid(), rng=None):
    """Intensity maps of one run for a target at ``positions (K, >=3)`` (Cartesian, radar
    at the origin) with realised per-scan SNR ``snr (K,)`` (linear, >= 0).

    Random draws, in order: every cell's ``Exp(1)`` noise power, then per scan the target
    phase and the 27 complex noise samples of its footprint.  Returns
    :class:`~trackcore.trackers.IntensityMaps`.
    """
    if not isinstance(grid, IntensityGrid):
        raise TypeError(f"grid must be an IntensityGrid, got {type(grid).__name__}")
    rng = as_rng(rng)
    P = as_array(positions, "positions", ndim=2)
    if P.shape[1] < 3:
        raise ValueError(f"positions must have shape (K, >=3), got {P.shape}")
    K = P.shape[0]
    if K == 0:
        raise ValueError("positions must hold at least one scan (the maps would be empty)")
    S = as_array(snr, "snr", shape=(K,))
    if np.any(S < 0):
        raise ValueError("snr must be a non-negative linear power ratio (not dB)")
    pos = np.ascontiguousarray(P[:, :3])
    r = np.linalg.norm(pos, axis=1)
    if np.any(r == 0):
        raise ValueError("positions must not be at the radar (range 0)")
    centre = np.column_stack([np.floor(r / grid.range_cell + 0.5),
                              np.floor(np.arctan2(pos[:, 1], pos[:, 0]) / grid.angle_cell + 0.5),
                              np.floor(np.arcsin(pos[:, 2] / r) / grid.angle_cell + 0.5)])
    half = np.array([grid.half_range, grid.half_angle, grid.half_angle])
    origin = np.ascontiguousarray(centre.astype(np.int64) - half)
    power = rng.standard_exponential((K,) + grid.shape)
    phase = rng.uniform(0.0, 2.0 * math.pi, K)
    nz = rng.standard_normal((K, 2, INTENSITY_FOOTPRINT)) / math.sqrt(2.0)
    _add_target_kernel(pos, S, phase, np.ascontiguousarray(nz[:, 0]),
                       np.ascontiguousarray(nz[:, 1]), grid.range_cell, grid.angle_cell,
                       grid.psf_width, power, origin)
    return IntensityMaps(power, origin, grid)


@dataclass(frozen=True)
class IntensityTrialResult:
    """One Monte Carlo run of the raw-intensity TBD on the chapter's scenario."""
    errors: np.ndarray     # (K,) E_err(k) (eq 20)
    n_outside: np.ndarray  # (K,) particles whose footprint left the simulated block
    x0: np.ndarray         # (6,) the shared initial estimate
    target_snr: np.ndarray  # (K,) realised S_k (identical to the detection-level run's)
    maps: object           # IntensityMaps (None unless keep=True)
    track: object          # IntensityTrackResult (None unless keep=True)


def tbd_intensity_trial(rng, config=IntensityTbdConfig(), params=TbdRadarParameters(),
                        truth=None, grid=IntensityGrid(), P0=TBD_INITIAL_COVARIANCE,
                        keep=False):
    """One run of the raw-intensity baseline, paired with :func:`tbd_paired_trial`.

    ``rng`` is split exactly as :func:`~trackcore.scenarios.tbd_paired_trial` splits it, and
    the detection-level run is replayed from the scenario stream, so this run has the same
    realised target SNR ``S_k`` and the same initial estimate ``x0`` as the detection-level
    trackers of the same Monte Carlo index.  The maps and the filter then draw from two
    further children of ``rng``, independent of every detection-level stream.
    """
    rng = as_rng(rng)
    if not isinstance(config, IntensityTbdConfig):
        raise TypeError(f"config must be an IntensityTbdConfig, got {type(config).__name__}")
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
    res = run_intensity_tbd(maps, x0, P0, r_pf, config)
    return IntensityTrialResult(tbd_position_errors(res.estimates, truth.states), res.n_outside,
                                x0, scans.target_snr, maps if keep else None,
                                res if keep else None)
