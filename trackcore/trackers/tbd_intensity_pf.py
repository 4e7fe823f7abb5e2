"""Raw-intensity track-before-detect particle filter (Salmond & Birch 2001; Rutten,
Gordon & Maskell 2005) -- a baseline for chapter 003, **not** part of Kwon et al. (2016).

Sensor model (Rutten et al.'s, in our cell geometry).  Each scan is a map of
*unthresholded* noise-normalised cell powers over a range–azimuth–elevation grid with
cell sizes ``Δr`` (m) and ``Δθ`` (rad, azimuth and elevation).  Cell ``c = (i, j, l)`` has
its centre at ``(i Δr, j Δθ, l Δθ)``.  A target at ``(r, az, el)`` with per-scan SNR ``S``
(linear, peak-cell) gives::

    z_c = |sqrt(S) e^{iφ} h_c(x) + n_c|^2,   n_c ~ CN(0, 1)  (noise power 1),

with the amplitude point-spread function (PSF)::

    h_c(x) = exp(-d_c^2 / (4 β^2)),   d_c^2 = (i - r/Δr)^2 + (j - az/Δθ)^2 + (l - el/Δθ)^2,

so the *power* PSF ``h^2`` is a Gaussian of standard deviation ``β`` cells.  The PSF is
truncated to the 3 × 3 × 3 footprint around the cell nearest to the target (beyond it
``h^2 < 0.011`` for ``β = 0.5``); outside the footprint ``z_c ~ Exp(1)``.

Likelihood ratio (Salmond–Birch / Rutten).  The cells are independent given the state,
so the likelihood of the whole map divided by its noise-only likelihood reduces to the
footprint of the particle::

    log ℓ(z | x) = Σ_{c ∈ footprint(x)} [ log I0(2 sqrt(S) h_c(x) sqrt(z_c)) - S h_c(x)^2 ],

the Rician-over-exponential density ratio (non-fluctuating amplitude, unknown phase) with
a *design* SNR ``S`` known to the filter.  The per-particle cost is the 27 cells of the
footprint, so a scan costs ``O(27 N)`` regardless of the map size.  Footprint cells that
fall outside the stored map block are skipped (unobserved cells carry no information);
their number is reported so that a run that leaves the simulated block can be flagged.

The filter is a bootstrap (SIR) particle filter over the 6-D CV state with the chapter's
DWNA process noise, SIS weights, the weighted-mean estimate and systematic resampling
when ``N_eff < N/2`` -- the same structure as methods B, C and P of
:mod:`trackcore.trackers.tbd_pf` -- built from the foundation's particle kernels.  It has
no target-existence variable: like the chapter's other trackers it assumes that one
target is present from scan 0 and starts from the same ``N(x0, P0)`` (see the chapter's
notebook 05 for why).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..core.validation import as_array, as_covariance, as_int, as_nonnegative, as_positive, \
    as_probability, as_rng, as_vector
from ..filters.particle import (effective_sample_size_kernel, noise_factor,
                                propagate_linear_kernel, systematic_resample_kernel,
                                weighted_mean_cov_kernel)
from ..models.motion import cv_process_noise, cv_transition

__all__ = [
    "IntensityGrid",
    "IntensityMaps",
    "INTENSITY_FOOTPRINT",
    "intensity_psf",
    "intensity_log_likelihood_ratio",
    "IntensityTbdConfig",
    "IntensityTrackResult",
    "run_intensity_tbd",
]

#: cells in the PSF footprint (3 x 3 x 3 around the nearest cell)
INTENSITY_FOOTPRINT = 27


@dataclass(frozen=True)
class IntensityGrid:
    """Cell geometry and PSF of the intensity map (the book's choices, notebook 05).

    ``range_cell`` (m) and ``angle_cell`` (rad) are chosen so that the single-scan
    Cramér–Rao accuracy of the PSF centroid at 6 dB, about ``0.32`` cells per axis for
    ``psf_width = 0.5``, matches the detection model's ``σ_r = 25 m`` and
    ``σ_az = σ_el = 0.15°``.  ``half_range`` / ``half_angle``: the simulated block extends
    this many cells either side of the target's cell in range / in each angle.
    """
    range_cell: float = 75.0
    angle_cell: float = math.radians(0.5)
    psf_width: float = 0.5
    half_range: int = 40
    half_angle: int = 8

    def __post_init__(self):
        for name in ("range_cell", "angle_cell", "psf_width"):
            as_positive(getattr(self, name), name)
        as_int(self.half_range, "half_range", minimum=1)
        as_int(self.half_angle, "half_angle", minimum=1)

    @property
    def shape(self):
        """Cells of one scan's block: ``(range, azimuth, elevation)``."""
        return (2 * self.half_range + 1, 2 * self.half_angle + 1, 2 * self.half_angle + 1)


@dataclass(frozen=True)
class IntensityMaps:
    """All intensity maps of one run.

    ``power[k, a, b, c]`` is the noise-normalised power of the cell with integer index
    ``origin[k] + (a, b, c)``; its centre is at range ``(origin[k, 0] + a) Δr``, azimuth
    ``(origin[k, 1] + b) Δθ`` and elevation ``(origin[k, 2] + c) Δθ``.
    """
    power: np.ndarray    # (K, nr, na, ne) float64
    origin: np.ndarray   # (K, 3) int64
    grid: IntensityGrid

    @property
    def n_scans(self) -> int:
        return self.power.shape[0]


# =============================================================================== PSF and log I0
@nb.njit(cache=True)
def log_i0_kernel(x):
    """``log I0(x)`` for ``x >= 0`` to ~1e-15 relative: power series below 20, the
    Hankel asymptotic series above (its smallest term there is below 1e-17)."""
    if x < 20.0:
        q = 0.25 * x * x
        term = 1.0
        s = 1.0
        k = 0
        while True:
            k += 1
            term *= q / (k * k)
            s += term
            if term < 1e-17 * s:
                break
        return math.log(s)
    inv = 1.0 / x
    term = 1.0
    s = 1.0
    k = 0
    while k < 60:
        k += 1
        nxt = term * (2.0 * k - 1.0) ** 2 / (8.0 * k) * inv
        if nxt >= term or nxt < 1e-18 * s:
            break
        term = nxt
        s += term
    return x - 0.5 * math.log(2.0 * math.pi * x) + math.log(s)


@nb.njit(cache=True)
def psf_footprint_kernel(r, az, el, dr, dth, beta, cells, h):
    """The 27 footprint cells (integer indices into ``cells (27, 3)``) of a point at
    ``(r, az, el)`` and their amplitude PSF values ``h (27,)``."""
    u = r / dr
    v = az / dth
    w = el / dth
    i0 = math.floor(u + 0.5)
    j0 = math.floor(v + 0.5)
    l0 = math.floor(w + 0.5)
    c4 = 1.0 / (4.0 * beta * beta)
    t = 0
    for di in range(-1, 2):
        for dj in range(-1, 2):
            for dl in range(-1, 2):
                i = i0 + di
                j = j0 + dj
                l = l0 + dl
                cells[t, 0] = i
                cells[t, 1] = j
                cells[t, 2] = l
                d2 = (i - u) ** 2 + (j - v) ** 2 + (l - w) ** 2
                h[t] = math.exp(-d2 * c4)
                t += 1


@nb.njit(cache=True, inline="always")
def _rae(x0, x1, x2):
    r = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    return r, math.atan2(x1, x0), math.asin(x2 / r) if r > 0.0 else 0.0


@nb.njit(cache=True)
def intensity_loglr_kernel(particles, power, origin, dr, dth, beta, snr, cells, h, out):
    """``out[i] = Σ_c log I0(2 sqrt(S) h_c sqrt(z_c)) - S h_c²`` over the footprint of
    particle ``i`` inside the block ``power (nr, na, ne)`` at ``origin (3,)``.  Returns the
    number of particles whose footprint is not wholly inside the block."""
    N = particles.shape[0]
    nr, na, ne = power.shape
    a = math.sqrt(snr)
    outside = 0
    for i in range(N):
        r, az, el = _rae(particles[i, 0], particles[i, 1], particles[i, 2])
        psf_footprint_kernel(r, az, el, dr, dth, beta, cells, h)
        s = 0.0
        miss = False
        for t in range(cells.shape[0]):
            ia = cells[t, 0] - origin[0]
            ib = cells[t, 1] - origin[1]
            ic = cells[t, 2] - origin[2]
            if ia < 0 or ia >= nr or ib < 0 or ib >= na or ic < 0 or ic >= ne:
                miss = True
                continue
            z = power[ia, ib, ic]
            s += log_i0_kernel(2.0 * a * h[t] * math.sqrt(z)) - snr * h[t] * h[t]
        if miss:
            outside += 1
        out[i] = s
    return outside


def _as_grid(grid):
    if not isinstance(grid, IntensityGrid):
        raise TypeError(f"grid must be an IntensityGrid, got {type(grid).__name__}")
    return grid


def intensity_psf(position, grid=IntensityGrid()):
    """Footprint of a target at Cartesian ``position`` (3,) (radar at the origin):
    ``(cells (27, 3) int64, h (27,))`` -- the integer cell indices and the amplitude PSF."""
    grid = _as_grid(grid)
    p = as_vector(position, "position", 3)
    r = float(np.linalg.norm(p))
    if r == 0.0:
        raise ValueError("position must not be at the radar (range 0)")
    cells = np.empty((INTENSITY_FOOTPRINT, 3), dtype=np.int64)
    h = np.empty(INTENSITY_FOOTPRINT)
    psf_footprint_kernel(r, math.atan2(p[1], p[0]), math.asin(p[2] / r), grid.range_cell,
                         grid.angle_cell, grid.psf_width, cells, h)
    return cells, h


def _as_block(power, name="power"):
    P = as_array(power, name, ndim=3)
    if P.size == 0:
        raise ValueError(f"{name} must not be empty (a map needs at least one cell)")
    if np.any(P < 0):
        raise ValueError(f"{name} must hold non-negative cell powers")
    return P


def _as_origin(origin, name="origin", shape=(3,)):
    o = np.asarray(origin)
    if o.shape != shape or not np.issubdtype(o.dtype, np.integer):
        raise ValueError(f"{name} must be an integer array of shape {shape}, got "
                         f"{o.dtype} {o.shape}")
    return np.ascontiguousarray(o, dtype=np.int64)


def _as_snr(snr, name="snr"):
    s = as_nonnegative(snr, name)
    return s


def _as_particles6(particles):
    X = as_array(particles, "particles", ndim=2)
    if X.shape[1] < 3:
        raise ValueError(f"particles must have shape (N, >=3), got {X.shape}")
    if X.shape[0] and np.any(np.linalg.norm(X[:, :3], axis=1) == 0):
        raise ValueError("particles must not sit at the radar (range 0)")
    return X


def intensity_log_likelihood_ratio(particles, power, origin, snr, grid=IntensityGrid()):
    """Log likelihood ratio (target present at the particle vs noise only) of one scan's
    map, for particles ``(N, >=3)`` (positions first): ``(N,)``.

    ``power (nr, na, ne)``: the scan's block of cell powers; ``origin (3,)``: the integer
    index of its first cell; ``snr``: the filter's design SNR (linear).
    """
    grid = _as_grid(grid)
    X = _as_particles6(particles)
    P = _as_block(power)
    o = _as_origin(origin)
    S = _as_snr(snr)
    out = np.empty(X.shape[0])
    cells = np.empty((INTENSITY_FOOTPRINT, 3), dtype=np.int64)
    h = np.empty(INTENSITY_FOOTPRINT)
    intensity_loglr_kernel(X, P, o, grid.range_cell, grid.angle_cell, grid.psf_width, S, cells,
                           h, out)
    return out


# =============================================================================== the filter
@dataclass(frozen=True)
class IntensityTbdConfig:
    """Parameters of the raw-intensity TBD particle filter (the book's choices).

    ``design_snr``: the linear SNR of the likelihood ratio (default 6 dB, as method P);
    ``sigma_a``: DWNA acceleration std (m/s²); ``resample_threshold``: resample when
    ``N_eff < resample_threshold · N``.
    """
    n_particles: int = 600
    design_snr: float = 10.0 ** 0.6
    sigma_a: float = 15.0
    resample_threshold: float = 0.5
    scan_period: float = 1.0

    def __post_init__(self):
        as_int(self.n_particles, "n_particles", minimum=1)
        as_positive(self.design_snr, "design_snr")
        as_nonnegative(self.sigma_a, "sigma_a")
        as_probability(self.resample_threshold, "resample_threshold")
        as_positive(self.scan_period, "scan_period")


@dataclass(frozen=True)
class IntensityTrackResult:
    """Output of :func:`run_intensity_tbd` over ``K`` scans."""
    estimates: np.ndarray    # (K, 6) weighted-mean posterior estimates
    ess: np.ndarray          # (K,) N_eff after the update
    resampled: np.ndarray    # (K,) bool
    n_outside: np.ndarray    # (K,) particles whose footprint left the stored block


@nb.njit(cache=True)
def _intensity_run_kernel(particles, logw, F, L, power, origin, dr, dth, beta, snr,
                          resample_below, rng, est, ess, resampled, n_outside):
    N, n = particles.shape
    K = power.shape[0]
    ll = np.empty(N)
    w = np.empty(N)
    cov = np.empty((n, n))
    mean = np.empty(n)
    ridx = np.empty(N, dtype=np.int64)
    work = np.empty_like(particles)
    cells = np.empty((27, 3), dtype=np.int64)
    h = np.empty(27)
    for k in range(K):
        if k > 0:
            propagate_linear_kernel(particles, F, L, rng, particles)
        n_outside[k] = intensity_loglr_kernel(particles, power[k], origin[k], dr, dth, beta, snr,
                                              cells, h, ll)
        mx = -np.inf
        for i in range(N):
            v = logw[i] + ll[i]
            if v > mx:
                mx = v
        for i in range(N):
            logw[i] = logw[i] + ll[i] - mx
        weighted_mean_cov_kernel(particles, logw, mean, cov)
        for a in range(n):
            est[k, a] = mean[a]
        n_eff = effective_sample_size_kernel(logw)
        ess[k] = n_eff
        if n_eff < resample_below:
            for i in range(N):
                w[i] = math.exp(logw[i])
            systematic_resample_kernel(w, rng, ridx)
            for i in range(N):
                src = ridx[i]
                for a in range(n):
                    work[i, a] = particles[src, a]
            for i in range(N):
                for a in range(n):
                    particles[i, a] = work[i, a]
                logw[i] = 0.0
            resampled[k] = True


def _as_maps(maps):
    if not isinstance(maps, IntensityMaps):
        raise TypeError(f"maps must be IntensityMaps, got {type(maps).__name__}")
    P = as_array(maps.power, "maps.power", ndim=4)
    if P.size == 0:
        raise ValueError("maps.power must not be empty (at least one scan of one cell)")
    if np.any(P < 0):
        raise ValueError("maps.power must hold non-negative cell powers")
    o = _as_origin(maps.origin, "maps.origin", (P.shape[0], 3))
    return P, o, _as_grid(maps.grid)


def run_intensity_tbd(maps, x0, P0, rng, config=IntensityTbdConfig()):
    """Run the raw-intensity TBD particle filter over a whole run of intensity maps.

    ``maps``: :class:`IntensityMaps` (``K`` scans); ``x0`` (6,), ``P0`` (6, 6): the initial
    estimate and covariance at scan 0 (particles drawn from ``N(x0, P0)`` with ``rng``);
    scan 0 is processed without a prediction.  Returns :class:`IntensityTrackResult`.
    """
    if not isinstance(config, IntensityTbdConfig):
        raise TypeError(f"config must be an IntensityTbdConfig, got {type(config).__name__}")
    rng = as_rng(rng)
    power, origin, grid = _as_maps(maps)
    x0 = as_vector(x0, "x0", 6)
    P0 = as_covariance(P0, "P0", 6, strict=True)
    K = power.shape[0]
    N = int(config.n_particles)
    T = config.scan_period
    F = cv_transition(T, dim=3)
    L = noise_factor(cv_process_noise(T, config.sigma_a ** 2, dim=3, kind="dwna"))
    particles = np.ascontiguousarray(x0 + rng.standard_normal((N, 6)) @ np.linalg.cholesky(P0).T)
    if np.any(np.linalg.norm(particles[:, :3], axis=1) == 0):
        raise ValueError("x0/P0 put a particle at the radar (range 0)")
    logw = np.zeros(N)
    est = np.empty((K, 6))
    ess = np.empty(K)
    resampled = np.zeros(K, dtype=bool)
    n_outside = np.zeros(K, dtype=np.int64)
    _intensity_run_kernel(particles, logw, F, L, power, origin, grid.range_cell, grid.angle_cell,
                          grid.psf_width, float(config.design_snr),
                          float(config.resample_threshold * N), rng, est, ess, resampled,
                          n_outside)
    return IntensityTrackResult(est, ess, resampled, n_outside)
