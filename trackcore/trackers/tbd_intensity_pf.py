"""Raw-intensity track-before-detect particle filter (Salmond & Birch 2001; Rutten,
Gordon & Maskell 2005) -- a baseline for chapter 003, **not** part of Kwon et al. (2016) --
and the detection-level trackers of :mod:`trackcore.trackers.tbd_pf` run on the *same*
intensity maps, thresholded.

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
``h^2 < 0.011`` for ``β = 0.5``); every other cell holds noise, ``z_c ~ Exp(1)``.

The map is defined **everywhere**.  :class:`IntensityMaps` stores the 27 footprint cells
of the target per scan; the power of any other cell is drawn on demand from a
counter-based generator keyed by ``(noise_key, k, i, j, l)`` (a SplitMix64 hash turned
into ``Exp(1)``), so the same cell always has the same power, whichever filter reads it
and however far from the target it lies.  No filter can leave the simulated map.

Likelihood ratio (Salmond–Birch / Rutten).  The cells are independent given the state,
so the likelihood of the whole map divided by its noise-only likelihood reduces to the
footprint of the particle::

    log ℓ(z | x) = Σ_{c ∈ footprint(x)} [ log I0(2 sqrt(S) h_c(x) sqrt(z_c)) - S h_c(x)^2 ],

the Rician-over-exponential density ratio (non-fluctuating amplitude, unknown phase) with
a *design* SNR ``S`` known to the filter.  The per-particle cost is the 27 cells of the
footprint, so a scan costs ``O(27 N)`` regardless of the map size.

Detections from the same map (:func:`intensity_detections`): a cell is a detection when
its power reaches the threshold ``τ`` and is the largest of its 3 × 3 × 3 neighbourhood
(plot extraction by local maxima); the detection sits at the cell's centre and its
measured SNR is the cell power.  A noise cell is a detection with probability
``(1 - (1 - e^{-τ})^27) / 27`` (:func:`intensity_false_alarm_probability`).
:func:`run_tbd_tracker_on_map` runs methods B, C and P of
:mod:`~trackcore.trackers.tbd_pf` on these detections, extracted scan by scan inside each
tracker's own processing window, so the raw-intensity filter and the detection-level
trackers see one sensor.

The filters are bootstrap (SIR) particle filters over the 6-D CV state with the chapter's
DWNA process noise, SIS weights, the weighted-mean estimate and systematic resampling
when ``N_eff < N/2``, built from the same scan kernels as methods B, C and P.  The
intensity filter has no target-existence variable: like the chapter's other trackers it
assumes that one target is present from scan 0 and starts from ``N(x0, P0)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..core.validation import (as_array, as_covariance, as_int, as_nonnegative, as_positive,
                               as_probability, as_rng, as_scalar, as_vector)
from ..detection.marcum import log_marcum_detection_probability_scalar_kernel
from ..filters.particle import propagate_linear_kernel
from .tbd_pf import (_COV_LIMIT, _CODE, TbdTrackerConfig, _bounded, _inv, _log_clutter,
                     _pda_terms, _pf_scan_finish, _pf_scan_loglik, _pf_setup, _rae,
                     _weighted_state, detection_snr_cap)

#: the most cells one scan's detection extraction may examine (a window of radius R
#: around a point at range r spans about (2R/Δr)(2R/(rΔθ))² cells, and at most
#: (2R/Δr + 3)(2π/Δθ + 3)(π/Δθ + 3) when the window reaches the radar)
_MAX_WINDOW_CELLS = 100_000_000
#: the most cells :meth:`IntensityMaps.block` materialises
_MAX_BLOCK_CELLS = 10_000_000

__all__ = [
    "IntensityGrid",
    "IntensityMaps",
    "INTENSITY_FOOTPRINT",
    "intensity_psf",
    "intensity_log_likelihood_ratio",
    "intensity_false_alarm_probability",
    "intensity_detections",
    "intensity_tracker_config",
    "IntensityTbdConfig",
    "IntensityTrackResult",
    "run_intensity_tbd",
    "MapTrackResult",
    "run_tbd_tracker_on_map",
]

#: cells in the PSF footprint (3 x 3 x 3 around the nearest cell)
INTENSITY_FOOTPRINT = 27


@dataclass(frozen=True)
class IntensityGrid:
    """Cell geometry and PSF of the intensity map (the book's choices).

    ``range_cell`` (m) and ``angle_cell`` (rad) are chosen so that the single-scan
    Cramér–Rao accuracy of the PSF centroid at 6 dB, about ``0.26`` cells per axis for
    ``psf_width = 0.5``, is close to the detection model's ``σ_r = 25 m`` and
    ``σ_az = σ_el = 0.15°``.  ``half_range`` / ``half_angle``: the default half-size, in
    cells either side of the target's cell, of a block materialised with
    :meth:`IntensityMaps.block` (for figures; the map itself is unbounded).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import IntensityGrid
    >>> g = IntensityGrid()
    >>> print(g.range_cell, round(float(np.degrees(g.angle_cell)), 2), g.psf_width)
    75.0 0.5 0.5
    """
    range_cell: float = 75.0
    angle_cell: float = math.radians(0.5)
    psf_width: float = 0.5
    half_range: int = 40
    half_angle: int = 8

    def __post_init__(self):
        for name in ("range_cell", "angle_cell", "psf_width"):
            as_positive(getattr(self, name), name)
        if self.angle_cell >= 0.5 * math.pi:
            raise ValueError(f"angle_cell must be < pi/2 rad, got {self.angle_cell}")
        as_int(self.half_range, "half_range", minimum=1)
        as_int(self.half_angle, "half_angle", minimum=1)

    @property
    def shape(self):
        """Cells of a default block: ``(range, azimuth, elevation)``."""
        return (2 * self.half_range + 1, 2 * self.half_angle + 1, 2 * self.half_angle + 1)


# =============================================================================== the noise field
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLD = np.uint64(0x9E3779B97F4A7C15)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_MASK21 = 0x1FFFFF


@nb.njit(cache=True, inline="always")
def _mix64(x):
    x = x ^ (x >> _S30)
    x = x * _M1
    x = x ^ (x >> _S27)
    x = x * _M2
    return x ^ (x >> _S31)


@nb.njit(cache=True)
def _noise_power_kernel(key, k, i, j, l):
    """``Exp(1)`` power of the noise cell ``(i, j, l)`` of scan ``k`` (a pure function of
    its arguments: SplitMix64 of the key, the scan and the packed cell index)."""
    packed = ((i & _MASK21) << 42) | ((j & _MASK21) << 21) | (l & _MASK21)
    h = _mix64(np.uint64(key) + _GOLD * np.uint64(k + 1))
    h = _mix64(h ^ np.uint64(packed))
    u = float(h >> _S11) * (1.0 / 9007199254740992.0)
    return -math.log1p(-u)


@nb.njit(cache=True, inline="always")
def _cell_power(key, k, c0, fp, i, j, l):
    """Power of cell ``(i, j, l)`` at scan ``k``: the stored footprint value if the cell is
    one of the target's 27 (``c0``: their centre cell, ``fp``: their powers), else noise."""
    di = i - c0[0]
    dj = j - c0[1]
    dl = l - c0[2]
    if -1 <= di <= 1 and -1 <= dj <= 1 and -1 <= dl <= 1:
        return fp[(di + 1) * 9 + (dj + 1) * 3 + (dl + 1)]
    return _noise_power_kernel(key, k, i, j, l)


@nb.njit(cache=True)
def _block_kernel(key, k, c0, fp, origin, out):
    nr, na, ne = out.shape
    for a in range(nr):
        for b in range(na):
            for c in range(ne):
                out[a, b, c] = _cell_power(key, k, c0, fp, origin[0] + a, origin[1] + b,
                                           origin[2] + c)


@nb.njit(cache=True)
def _cells_kernel(key, k, c0, fp, cells, out):
    for t in range(cells.shape[0]):
        out[t] = _cell_power(key, k, c0, fp, cells[t, 0], cells[t, 1], cells[t, 2])


@dataclass(frozen=True)
class IntensityMaps:
    """All intensity maps of one run, defined over the whole range–angle space.

    ``footprint_centre[k]`` is the integer index of the cell nearest to the target at scan
    ``k`` and ``footprint_power[k]`` the powers of the 27 cells around it (ordered by
    range, azimuth, elevation offsets -1, 0, 1, elevation fastest); every other cell's
    power is the noise of ``noise_key`` (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))  # a target at rest, 5 scans
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> type(maps).__name__, maps.footprint_centre.shape, maps.footprint_power.shape
    ('IntensityMaps', (5, 3), (5, 27))
    """
    footprint_centre: np.ndarray  # (K, 3) int64
    footprint_power: np.ndarray   # (K, 27) float64
    noise_key: int
    grid: IntensityGrid

    def __post_init__(self):
        if not isinstance(self.grid, IntensityGrid):
            raise TypeError(f"grid must be an IntensityGrid, got {type(self.grid).__name__}")
        c = np.asarray(self.footprint_centre)
        if c.ndim != 2 or c.shape[1] != 3 or c.shape[0] == 0 or \
                not np.issubdtype(c.dtype, np.integer):
            raise ValueError(f"footprint_centre must be an integer array of shape (K, 3), "
                             f"K >= 1, got {c.dtype} {c.shape}")
        p = as_array(self.footprint_power, "footprint_power",
                     shape=(c.shape[0], INTENSITY_FOOTPRINT))
        if np.any(p < 0):
            raise ValueError("footprint_power must hold non-negative cell powers")
        if isinstance(self.noise_key, (bool, np.bool_)) or \
                not isinstance(self.noise_key, (int, np.integer)) or \
                not 0 <= int(self.noise_key) < 2 ** 63:
            raise ValueError(f"noise_key must be an integer in [0, 2**63), "
                             f"got {self.noise_key!r}")
        object.__setattr__(self, "footprint_centre", np.ascontiguousarray(c, dtype=np.int64))
        object.__setattr__(self, "footprint_power", p)
        object.__setattr__(self, "noise_key", int(self.noise_key))

    @property
    def n_scans(self) -> int:
        return self.footprint_centre.shape[0]

    def _scan(self, k):
        k = as_int(k, "k", minimum=0)
        if k >= self.n_scans:
            raise ValueError(f"k must be < {self.n_scans} (the number of scans), got {k}")
        return k

    def cell_power(self, k, cells):
        """Powers ``(n,)`` of the integer cells ``cells (n, 3)`` at scan ``k``."""
        k = self._scan(k)
        c = np.asarray(cells)
        if c.ndim != 2 or c.shape[1] != 3 or not np.issubdtype(c.dtype, np.integer):
            raise ValueError(f"cells must be an integer array of shape (n, 3), "
                             f"got {c.dtype} {c.shape}")
        out = np.empty(c.shape[0])
        _cells_kernel(self.noise_key, k, self.footprint_centre[k], self.footprint_power[k],
                      np.ascontiguousarray(c, dtype=np.int64), out)
        return out

    def block(self, k, half_range=None, half_angle=None):
        """The block of cells around the target's cell at scan ``k``:
        ``(power (nr, na, ne), origin (3,))``, ``origin`` the index of cell ``[0, 0, 0]``.
        Half-sizes default to the grid's ``half_range`` and ``half_angle``."""
        k = self._scan(k)
        hr = self.grid.half_range if half_range is None else as_int(half_range, "half_range",
                                                                     minimum=0)
        ha = self.grid.half_angle if half_angle is None else as_int(half_angle, "half_angle",
                                                                     minimum=0)
        if (2 * hr + 1) * (2 * ha + 1) ** 2 > _MAX_BLOCK_CELLS:
            raise ValueError(f"a block of half-sizes {hr} (range) and {ha} (angle) exceeds "
                             f"{_MAX_BLOCK_CELLS} cells")
        origin = self.footprint_centre[k] - np.array([hr, ha, ha], dtype=np.int64)
        out = np.empty((2 * hr + 1, 2 * ha + 1, 2 * ha + 1))
        _block_kernel(self.noise_key, k, self.footprint_centre[k], self.footprint_power[k],
                      np.ascontiguousarray(origin), out)
        return out, origin


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
        while k < 200:
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


@nb.njit(cache=True)
def intensity_loglr_kernel(particles, key, k, c0, fp, dr, dth, beta, snr, cells, h, out):
    """``out[i] = Σ_c log I0(2 sqrt(S) h_c sqrt(z_c)) - S h_c²`` over the footprint of
    particle ``i`` on the map of scan ``k`` (``key``, ``c0``, ``fp`` as in
    :class:`IntensityMaps`)."""
    N = particles.shape[0]
    a = math.sqrt(snr)
    for i in range(N):
        r, az, el = _rae(particles[i, 0], particles[i, 1], particles[i, 2])
        psf_footprint_kernel(r, az, el, dr, dth, beta, cells, h)
        s = 0.0
        for t in range(cells.shape[0]):
            z = _cell_power(key, k, c0, fp, cells[t, 0], cells[t, 1], cells[t, 2])
            s += log_i0_kernel(2.0 * a * h[t] * math.sqrt(z)) - snr * h[t] * h[t]
        out[i] = s


def _as_grid(grid):
    if not isinstance(grid, IntensityGrid):
        raise TypeError(f"grid must be an IntensityGrid, got {type(grid).__name__}")
    return grid


def _as_maps(maps):
    if not isinstance(maps, IntensityMaps):
        raise TypeError(f"maps must be IntensityMaps, got {type(maps).__name__}")
    return maps


def intensity_psf(position, grid=IntensityGrid()):
    """Footprint of a target at Cartesian ``position`` (3,) (radar at the origin):
    ``(cells (27, 3) int64, h (27,))`` -- the integer cell indices and the amplitude PSF.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import intensity_psf
    >>> cells, h = intensity_psf(np.array([30000.0, 0.0, 1000.0]))
    >>> cells.shape, round(float(h.max()), 3)
    ((27, 3), 0.921)
    """
    grid = _as_grid(grid)
    p = _bounded(as_vector(position, "position", 3), "position")
    r = float(np.linalg.norm(p))
    if r == 0.0:
        raise ValueError("position must not be at the radar (range 0)")
    cells = np.empty((INTENSITY_FOOTPRINT, 3), dtype=np.int64)
    h = np.empty(INTENSITY_FOOTPRINT)
    psf_footprint_kernel(r, math.atan2(p[1], p[0]), math.asin(p[2] / r), grid.range_cell,
                         grid.angle_cell, grid.psf_width, cells, h)
    return cells, h


def _as_particles(particles):
    X = _bounded(as_array(particles, "particles", ndim=2), "particles")
    if X.shape[1] < 3:
        raise ValueError(f"particles must have shape (N, >=3), got {X.shape}")
    if X.shape[0] and np.any(np.linalg.norm(X[:, :3], axis=1) == 0):
        raise ValueError("particles must not sit at the radar (range 0)")
    return X


def intensity_log_likelihood_ratio(particles, maps, k, snr):
    """Log likelihood ratio (target present at the particle vs noise only) of the map of
    scan ``k``, for particles ``(N, >=3)`` (positions first): ``(N,)``.  ``snr``: the
    filter's design SNR (linear, >= 0).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))  # a target at rest, 5 scans
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> from trackcore.trackers import intensity_log_likelihood_ratio
    >>> particles = np.zeros((3, 6))
    >>> particles[:, :3] = pos[0]
    >>> particles[1, 0] += 500.0
    >>> particles[2, 0] += 2000.0
    >>> llr = intensity_log_likelihood_ratio(particles, maps, 0, 4.0)
    >>> bool(llr[0] > llr[1]), bool(llr[0] > llr[2])  # the particle on the target wins
    (True, True)
    """
    maps = _as_maps(maps)
    X = _as_particles(particles)
    k = maps._scan(k)
    S = as_nonnegative(snr, "snr")
    g = maps.grid
    out = np.empty(X.shape[0])
    cells = np.empty((INTENSITY_FOOTPRINT, 3), dtype=np.int64)
    h = np.empty(INTENSITY_FOOTPRINT)
    intensity_loglr_kernel(X, maps.noise_key, k, maps.footprint_centre[k],
                           maps.footprint_power[k], g.range_cell, g.angle_cell, g.psf_width, S,
                           cells, h, out)
    return out


# =============================================================================== detections
def _db_power(value, name):
    """``10^(value/10)`` of a finite dB value at most 3000 dB (beyond, the power overflows)."""
    v = as_scalar(value, name)
    if not v <= 3000.0:
        raise ValueError(f"{name} must be at most 3000 dB, got {v}")
    return 10.0 ** (v / 10.0)


def intensity_false_alarm_probability(threshold_db):
    """Probability that a noise cell becomes a detection: its power reaches
    ``τ = 10^(threshold_db/10)`` and is the largest of its 27-cell neighbourhood,
    ``(1 - (1 - e^{-τ})^27) / 27``.

    Examples
    --------
    >>> from trackcore.trackers import intensity_false_alarm_probability
    >>> print(round(float(intensity_false_alarm_probability(5.0)), 4))
    0.0255
    """
    tau = _db_power(threshold_db, "threshold_db")
    return float(-np.expm1(27.0 * np.log1p(-math.exp(-tau))) / 27.0)


@nb.njit(cache=True)
def _extract_kernel(key, k, c0, fp, centre, R, tau, dr, dth, max_cells):
    """Detections of scan ``k`` whose cell centre lies within ``R`` of ``centre``: cells
    with power >= ``tau`` that are the largest of their 27-cell neighbourhood.  Returns
    ``(positions (n, 3), powers (n,), m)``; the first ``m`` rows are the detections;
    ``m = -1`` (and nothing examined) if the window spans more than ``max_cells``."""
    r_c, az_c, el_c = _rae(centre[0], centre[1], centre[2])
    if R >= r_c:
        half = 0.5 * math.pi
    else:
        half = math.asin(R / r_c)
    i_lo = int(math.floor((r_c - R) / dr))
    i_hi = int(math.ceil((r_c + R) / dr))
    if i_lo < 0:
        i_lo = 0
    el_lo = el_c - half
    el_hi = el_c + half
    l_lo = int(math.floor(el_lo / dth)) - 1
    l_hi = int(math.ceil(el_hi / dth)) + 1
    # azimuth half-width of a cap of angular radius `half` whose points have |el| <= el_max
    c_max = math.cos(min(max(abs(el_lo), abs(el_hi)), 0.5 * math.pi))
    if half >= 0.5 * math.pi or math.sin(half) >= c_max:
        ahalf = math.pi
    else:
        ahalf = math.asin(math.sin(half) / c_max)
    j_lo = int(math.floor((az_c - ahalf) / dth)) - 1
    j_hi = int(math.ceil((az_c + ahalf) / dth)) + 1
    n = (i_hi - i_lo + 1) * (j_hi - j_lo + 1) * (l_hi - l_lo + 1)
    if n > max_cells:
        return np.empty((1, 3)), np.empty(1), -1
    cap = min(max(n, 1), 4096)
    pos = np.empty((cap, 3))
    powr = np.empty(cap)
    R2 = R * R
    m = 0
    for i in range(i_lo, i_hi + 1):
        r = i * dr
        for l in range(l_lo, l_hi + 1):
            el = l * dth
            ce = math.cos(el)
            z = r * math.sin(el)
            for j in range(j_lo, j_hi + 1):
                az = j * dth
                x = r * ce * math.cos(az)
                y = r * ce * math.sin(az)
                d2 = (x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2
                if d2 > R2:
                    continue
                v = _cell_power(key, k, c0, fp, i, j, l)
                if v < tau:
                    continue
                peak = True
                for di in range(-1, 2):
                    for dj in range(-1, 2):
                        for dl in range(-1, 2):
                            if di == 0 and dj == 0 and dl == 0:
                                continue
                            if _cell_power(key, k, c0, fp, i + di, j + dj, l + dl) > v:
                                peak = False
                                break
                        if not peak:
                            break
                    if not peak:
                        break
                if peak:
                    if m == cap:  # grow the buffers (about 2.5 % of the cells at 5 dB)
                        cap *= 2
                        pos2 = np.empty((cap, 3))
                        pow2 = np.empty(cap)
                        pos2[:m] = pos[:m]
                        pow2[:m] = powr[:m]
                        pos = pos2
                        powr = pow2
                    pos[m, 0] = x
                    pos[m, 1] = y
                    pos[m, 2] = z
                    powr[m] = v
                    m += 1
    return pos, powr, m


def intensity_detections(maps, k, centre, radius, threshold_db):
    """The detections of scan ``k`` within ``radius`` (m) of ``centre`` (3,):
    ``(positions (m, 3), snr (m,))`` -- local maxima of the map at or above
    ``threshold_db``, placed at their cell centres, with the cell power as measured SNR.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))  # a target at rest, 5 scans
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> from trackcore.trackers import intensity_detections
    >>> p, snr = intensity_detections(maps, 0, pos[0], 1000.0, 5.0)
    >>> p.shape[1], bool(np.all(snr >= 10 ** 0.5))
    (3, True)
    """
    maps = _as_maps(maps)
    k = maps._scan(k)
    c = _bounded(as_vector(centre, "centre", 3), "centre")
    if not np.linalg.norm(c) > 0:
        raise ValueError("centre must not be at the radar (range 0)")
    R = as_positive(radius, "radius")
    tau = _db_power(threshold_db, "threshold_db")
    g = maps.grid
    pos, powr, m = _extract_kernel(maps.noise_key, k, maps.footprint_centre[k],
                                   maps.footprint_power[k], c, R, tau, g.range_cell,
                                   g.angle_cell, _MAX_WINDOW_CELLS)
    if m < 0:
        raise ValueError(f"radius {R:.3g} m spans more than {_MAX_WINDOW_CELLS} cells at "
                         f"this range: use a smaller radius")
    return pos[:m].copy(), powr[:m].copy()


def intensity_tracker_config(method="C", grid=IntensityGrid(), threshold_db=5.0, **kwargs):
    """A :class:`~trackcore.trackers.TbdTrackerConfig` for the detections of an intensity
    map: no Doppler (``sigma_v = sigma_range_rate = inf``), method P's measurement noise
    that of a detection placed at its cell's centre (``Δr/√12``, ``Δθ/√12``) and its
    false-alarm density ``p_fa / (Δr Δθ²)`` per unit of (range, azimuth, elevation),
    with ``p_fa`` from :func:`intensity_false_alarm_probability`.  ``kwargs`` override.

    Examples
    --------
    >>> from trackcore.trackers import intensity_tracker_config
    >>> cfg = intensity_tracker_config("C", n_particles=100)
    >>> cfg.method, cfg.n_particles, cfg.sigma_v, cfg.use_doppler
    ('C', 100, inf, False)
    """
    grid = _as_grid(grid)
    thr = as_scalar(threshold_db, "threshold_db")
    base = dict(method=method, sigma_v=math.inf, sigma_range_rate=math.inf,
                sigma_range=grid.range_cell / math.sqrt(12.0),
                sigma_angle=grid.angle_cell / math.sqrt(12.0), threshold_db=thr,
                clutter_density_rae=intensity_false_alarm_probability(thr)
                / (grid.range_cell * grid.angle_cell ** 2))
    base.update(kwargs)
    return TbdTrackerConfig(**base)


# =============================================================================== the filters
@dataclass(frozen=True)
class IntensityTbdConfig:
    """Parameters of the raw-intensity TBD particle filter (the book's choices).

    ``design_snr``: the linear SNR of the likelihood ratio (default 6 dB, as method P);
    ``sigma_a``: DWNA acceleration std (m/s²); ``resample_threshold``: resample when
    ``N_eff < resample_threshold · N``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers import IntensityTbdConfig
    >>> cfg = IntensityTbdConfig(n_particles=100)
    >>> print(cfg.n_particles, round(float(10 * np.log10(cfg.design_snr)), 1), cfg.sigma_a)
    100 6.0 15.0
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
    """Output of :func:`run_intensity_tbd` over ``K`` scans.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))  # a target at rest, 5 scans
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> P0 = np.diag([300.0**2] * 3 + [20.0**2] * 3)
    >>> x0 = np.r_[pos[0], 0.0, 0.0, 0.0]
    >>> from trackcore.trackers import IntensityTbdConfig, run_intensity_tbd
    >>> res = run_intensity_tbd(maps, x0, P0, np.random.default_rng(1),
    ...     IntensityTbdConfig(n_particles=100), covariances=False)
    >>> type(res).__name__, res.covariances is None, res.ess.shape
    ('IntensityTrackResult', True, (5,))
    """
    estimates: np.ndarray    # (K, 6) weighted-mean posterior estimates
    covariances: np.ndarray  # (K, 6, 6) weighted particle covariance
    ess: np.ndarray          # (K,) N_eff after the update
    resampled: np.ndarray    # (K,) bool


@nb.njit(cache=True)
def _intensity_run_kernel(particles, logw, F, L, key, c0, fp, dr, dth, beta, snr,
                          resample_below, rng, est, cov, want_cov, ess, resampled):
    N, n = particles.shape
    K = c0.shape[0]
    ll = np.empty(N)
    w = np.empty(N)
    mean = np.empty(n)
    ridx = np.empty(N, dtype=np.int64)
    work = np.empty_like(particles)
    cells = np.empty((27, 3), dtype=np.int64)
    h = np.empty(27)
    for k in range(K):
        if k > 0:
            propagate_linear_kernel(particles, F, L, rng, particles)
        intensity_loglr_kernel(particles, key, k, c0[k], fp[k], dr, dth, beta, snr, cells, h,
                               ll)
        _pf_scan_finish(k, particles, logw, ll, True, resample_below, 0.0, rng, w, mean,
                        ridx, work, est, cov, want_cov, ess, resampled)


def _start(x0, P0):
    x0 = _bounded(as_vector(x0, "x0", 6), "x0")
    P0 = _bounded(as_covariance(P0, "P0", 6, strict=True), "P0", _COV_LIMIT)
    return x0, P0


def run_intensity_tbd(maps, x0, P0, rng, config=IntensityTbdConfig(), *, covariances=True):
    """Run the raw-intensity TBD particle filter over a whole run of intensity maps.

    ``maps``: :class:`IntensityMaps` (``K`` scans); ``x0`` (6,), ``P0`` (6, 6): the initial
    estimate and covariance at scan 0 (particles drawn from ``N(x0, P0)`` with ``rng``);
    scan 0 is processed without a prediction.  ``covariances=False`` skips the weighted
    covariance (``covariances`` is then None).  Returns :class:`IntensityTrackResult`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))  # a target at rest, 5 scans
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> P0 = np.diag([300.0**2] * 3 + [20.0**2] * 3)
    >>> x0 = np.r_[pos[0], 0.0, 0.0, 0.0]
    >>> from trackcore.trackers import IntensityTbdConfig, run_intensity_tbd
    >>> res = run_intensity_tbd(maps, x0, P0, np.random.default_rng(1),
    ...     IntensityTbdConfig(n_particles=100))
    >>> res.estimates.shape, res.covariances.shape
    ((5, 6), (5, 6, 6))
    """
    if not isinstance(config, IntensityTbdConfig):
        raise TypeError(f"config must be an IntensityTbdConfig, got {type(config).__name__}")
    if not isinstance(covariances, (bool, np.bool_)):
        raise TypeError(f"covariances must be a bool, got {type(covariances).__name__}")
    rng = as_rng(rng)
    maps = _as_maps(maps)
    x0, P0 = _start(x0, P0)
    K = maps.n_scans
    particles, logw, F, L = _pf_setup(x0, P0, rng, config)
    if np.any(np.linalg.norm(particles[:, :3], axis=1) == 0):
        raise ValueError("x0/P0 put a particle at the radar (range 0)")
    N = particles.shape[0]
    est = np.empty((K, 6))
    cov = np.empty((K, 6, 6))
    ess = np.empty(K)
    resampled = np.zeros(K, dtype=bool)
    g = maps.grid
    _intensity_run_kernel(particles, logw, F, L, maps.noise_key, maps.footprint_centre,
                          maps.footprint_power, g.range_cell, g.angle_cell, g.psf_width,
                          float(config.design_snr), float(config.resample_threshold * N), rng,
                          est, cov, bool(covariances), ess, resampled)
    return IntensityTrackResult(est, cov if covariances else None, ess, resampled)


@dataclass(frozen=True)
class MapTrackResult:
    """Output of :func:`run_tbd_tracker_on_map` over ``K`` scans.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))  # a target at rest, 5 scans
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> P0 = np.diag([300.0**2] * 3 + [20.0**2] * 3)
    >>> x0 = np.r_[pos[0], 0.0, 0.0, 0.0]
    >>> from trackcore.trackers import intensity_tracker_config, run_tbd_tracker_on_map
    >>> cfg = intensity_tracker_config("C", n_particles=100)
    >>> res = run_tbd_tracker_on_map(maps, x0, P0, np.random.default_rng(1), cfg,
    ...     covariances=False)
    >>> type(res).__name__, res.covariances is None
    ('MapTrackResult', True)
    """
    estimates: np.ndarray       # (K, 6)
    covariances: np.ndarray     # (K, 6, 6) weighted particle covariance
    window_centers: np.ndarray  # (K, 3) predicted position: centre of the processing sphere
    n_processed: np.ndarray     # (K,) detections extracted inside the sphere
    ess: np.ndarray             # (K,)
    resampled: np.ndarray       # (K,) bool


@nb.njit(cache=True)
def _map_run_kernel(method, particles, logw, F, L, key, c0, fp, dr, dth, tau, log_pfa,
                    snr_cap, R, inv_r, inv_v, gauss, use_doppler, from_previous, resample_below,
                    design_snr,
                    log_pd, log_miss, log_rho, rae_density, sig_range, sig_angle, sig_rr,
                    roughening, rng, est, cov, want_cov, centers, nproc, ess, resampled,
                    max_cells):
    N = particles.shape[0]
    K = c0.shape[0]
    ll = np.empty(N)
    w = np.empty(N)
    mean = np.empty(6)
    pbar = np.empty(3)
    ridx = np.empty(N, dtype=np.int64)
    work = np.empty_like(particles)
    sq = math.sqrt(design_snr)
    for k in range(K):
        if k > 0:
            propagate_linear_kernel(particles, F, L, rng, particles)
        _weighted_state(particles, logw, w, mean)
        for a in range(3):
            centers[k, a] = mean[a]
        pos, powr, m = _extract_kernel(key, k, c0[k], fp[k], mean, R, tau, dr, dth,
                                       max_cells)
        nproc[k] = m
        n1 = max(m, 1)
        idx = np.arange(n1)
        rr = np.zeros(n1)
        lpd = np.empty(n1)
        logla = np.empty(n1)
        tmp = np.empty(n1)
        for t in range(m):
            lpd[t] = log_marcum_detection_probability_scalar_kernel(min(powr[t], snr_cap),
                                                                    log_pfa)
            # Rician amplitude ratio of the thresholded densities (method P)
            logla[t] = (log_i0_kernel(2.0 * sq * math.sqrt(powr[t])) - design_snr - log_pd
                        - tau)
        ref = est[k - 1] if (from_previous and k > 0) else mean
        updated = _pf_scan_loglik(method, particles, idx, m, pos, rr, lpd, ref, inv_r,
                                  inv_v, gauss, use_doppler, logla, log_pd, log_miss, log_rho,
                                  rae_density, sig_range, sig_angle, sig_rr, tmp, pbar, ll)
        _pf_scan_finish(k, particles, logw, ll, updated, resample_below, roughening, rng, w,
                        mean, ridx, work, est, cov, want_cov, ess, resampled)


def run_tbd_tracker_on_map(maps, x0, P0, rng, config, *, covariances=True):
    """Run method B, C or P of :func:`~trackcore.trackers.run_tbd_tracker` on detections
    extracted from intensity maps (:func:`intensity_detections` at
    ``config.threshold_db``), scan by scan inside the tracker's own processing window.

    The maps carry no Doppler, so ``config`` must have ``sigma_v = sigma_range_rate =
    math.inf`` and ``use_doppler = False`` (build it with :func:`intensity_tracker_config`).
    ``covariances=False`` skips the weighted covariance (``covariances`` is then None).
    Returns :class:`MapTrackResult`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.scenarios import simulate_intensity_maps
    >>> pos = np.tile([30000.0, 0.0, 1000.0], (5, 1))  # a target at rest, 5 scans
    >>> maps = simulate_intensity_maps(pos, np.full(5, 4.0), rng=np.random.default_rng(0))
    >>> P0 = np.diag([300.0**2] * 3 + [20.0**2] * 3)
    >>> x0 = np.r_[pos[0], 0.0, 0.0, 0.0]
    >>> from trackcore.trackers import intensity_tracker_config, run_tbd_tracker_on_map
    >>> cfg = intensity_tracker_config("C", n_particles=100)
    >>> res = run_tbd_tracker_on_map(maps, x0, P0, np.random.default_rng(1), cfg)
    >>> res.estimates.shape, res.n_processed.shape
    ((5, 6), (5,))
    """
    if not isinstance(covariances, (bool, np.bool_)):
        raise TypeError(f"covariances must be a bool, got {type(covariances).__name__}")
    if not isinstance(config, TbdTrackerConfig):
        raise TypeError(f"config must be a TbdTrackerConfig, got {type(config).__name__}")
    if config.method not in ("B", "C", "P"):
        raise ValueError(f"config.method must be 'B', 'C' or 'P' on a map, got "
                         f"{config.method!r}")
    if not (math.isinf(config.sigma_v) and math.isinf(config.sigma_range_rate)) \
            or config.use_doppler:
        raise ValueError("intensity maps carry no Doppler: config needs sigma_v = "
                         "sigma_range_rate = math.inf and use_doppler = False "
                         "(see intensity_tracker_config)")
    rng = as_rng(rng)
    maps = _as_maps(maps)
    x0, P0 = _start(x0, P0)
    g = maps.grid
    R = float(config.processing_radius)
    worst = ((2 * R / g.range_cell + 3) * (2 * math.pi / g.angle_cell + 3)
             * (math.pi / g.angle_cell + 3))
    if worst > _MAX_WINDOW_CELLS:
        raise ValueError(f"config.processing_radius {R:.3g} m could make a window span "
                         f"{worst:.3g} map cells (more than {_MAX_WINDOW_CELLS}): use a "
                         f"smaller radius or coarser cells")
    K = maps.n_scans
    particles, logw, F, L = _pf_setup(x0, P0, rng, config)
    log_rho = _log_clutter(config)
    N = particles.shape[0]
    log_pd = log_miss = 0.0
    if config.method == "P":
        log_pd, log_miss, _ = _pda_terms(config, np.zeros(0))
    est = np.empty((K, 6))
    cov = np.empty((K, 6, 6))
    centers = np.empty((K, 3))
    nproc = np.zeros(K, dtype=np.int64)
    ess = np.empty(K)
    resampled = np.zeros(K, dtype=bool)
    g = maps.grid
    _map_run_kernel(_CODE[config.method], particles, logw, F, L, maps.noise_key,
                    maps.footprint_centre, maps.footprint_power, g.range_cell, g.angle_cell,
                    10.0 ** (config.threshold_db / 10.0), math.log(config.pfa),
                    detection_snr_cap(config.pfa), float(config.processing_radius),
                    _inv(config.sigma_r), _inv(config.sigma_v), config.kernel == "gaussian",
                    False, config.weight_reference == "previous",
                    float(config.resample_threshold * N), float(config.target_snr),
                    log_pd, log_miss, log_rho, config.clutter_density_rae > 0,
                    float(config.sigma_range), float(config.sigma_angle),
                    float(config.sigma_range_rate), float(config.roughening), rng, est, cov,
                    bool(covariances), centers, nproc, ess, resampled, _MAX_WINDOW_CELLS)
    return MapTrackResult(est, cov if covariances else None, centers, nproc, ess, resampled)
