"""Step-level SMC-PHD filter (Vo, Singh & Doucet 2005) for a linear-Gaussian
motion model, a Gaussian birth density and a range-bearing sensor.

This is the configuration Stone Soup's ``SMCPHDPredictor`` (``'expansion'``
birth scheme) and ``SMCPHDUpdater`` implement, so the two can be run on the
same inputs (``benchmarks/bench_phd.py``, ``tests/test_smc_phd_stonesoup.py``).
One scan:

* predict: survivors ``x' = F x + w``, ``w ~ N(0, Q)``, weights times
  ``P_S``; then ``n_birth`` particles drawn from ``N(birth_mean,
  birth_cov)`` with weight ``birth_rate / n_birth`` each, appended (the
  birth intensity's total mass is ``birth_rate``, the expected number of new
  targets per scan);
* update (``phd_range_bearing_update_kernel``, shared with
  :func:`trackcore.trackers.smc_phd_run`)

      w_i <- [1 - P_D + sum_z P_D g(z|x_i) / (kappa(z) + C(z))] w_i,
      C(z) = sum_j P_D g(z|x_j) w_j,

  ``g = N(z; h(x), R)``, ``h = (range, bearing)`` from the sensor, bearing
  innovation wrapped to (-pi, pi], ``R`` diagonal; the cardinality estimate
  is ``N_hat = sum_i w_i``;
* resample ``n_out`` particles systematically in proportion to the weights,
  each with weight ``N_hat / n_out`` (mass preserving).

Weights are linear (PHD weights are ``O(N_hat / n)`` after every
resampling, far from underflow).  Likelihood terms with a normalised squared
innovation above ``gate`` (default 60, i.e. below ``exp(-30)`` of the peak)
are skipped; ``gate=inf`` evaluates every pair.

Random draws per scan, in order: the survivors' process noise (``k``
standard normals per particle, particle by particle, as
``trackcore.filters.propagate_linear_kernel``), the births' ``k_b``
standard normals per particle, then one uniform for the resampling offset
(none when ``N_hat = 0``).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.validation import (as_offsets, as_array, as_int, as_measurements, as_nonnegative,
                               as_probability, as_rng, as_scalar, as_square_matrix, as_vector)
from ..filters.particle import noise_factor, propagate_linear_kernel, systematic_indices_kernel
from ..models.measurement import range_bearing_kernel, wrap_angle_kernel

__all__ = [
    "SmcPhdModel",
    "SmcPhdUpdate",
    "SmcPhdStep",
    "SmcPhdFilterRun",
    "smc_phd_model",
    "smc_phd_update",
    "smc_phd_step",
    "smc_phd_filter",
]

#: default gate on the normalised squared innovation (terms below exp(-30) of the peak skipped)
DEFAULT_GATE = 60.0


# --------------------------------------------------------------------------
# kernels
# --------------------------------------------------------------------------
def _grid_work_size(L):
    """Length of the int64 work array ``iwork`` of ``phd_range_bearing_update_kernel``."""
    return 2 * L + 2 * (max(64, 4 * L) + 1)


@nb.njit(cache=True)
def _n_bins(span, width, cap):
    """``int(span / width) + 1``, or ``cap + 1`` (too many) when that would exceed ``cap``
    (so that a huge ratio never overflows the integer conversion)."""
    x = span / width
    if not (x < cap):
        return cap + 1
    return int(x) + 1


@nb.njit(cache=True)
def _grid_cells(H, wr, wb, iwork):
    """Bucket the particles by (range, bearing) cells at least ``wr`` by ``wb`` wide.

    ``iwork`` holds, in order: each particle's cell (L), the particles of every cell in
    index order (L), the start of each cell's run (cells + 1) and a fill pointer
    (cells).  Returns ``(rmin, cwr, nbr, cwb, nbb)``; ``nbr = 0`` when a grid would not
    help (an infinite gate, or a bearing window wider than a third of the circle)."""
    L = H.shape[0]
    if L == 0 or not (wr < np.inf) or not (wb < 2.0 * math.pi / 3.0):
        return 0.0, 0.0, 0, 0.0, 0
    rmin = H[0, 0]
    rmax = H[0, 0]
    for i in range(L):
        if not (abs(H[i, 0]) < np.inf and abs(H[i, 1]) < np.inf):
            # a particle at infinity or NaN: no grid, every pair is tested
            return 0.0, 0.0, 0, 0.0, 0
        rmin = min(rmin, H[i, 0])
        rmax = max(rmax, H[i, 0])
    if not (rmax - rmin < np.inf):
        return 0.0, 0.0, 0, 0.0, 0
    cap = max(64, 4 * L)
    cwr = wr * (1.0 + 1e-9) + 1e-9
    nbb = int(2.0 * math.pi / (wb * (1.0 + 1e-9) + 1e-12))
    nbr = _n_bins(rmax - rmin, cwr, cap)
    while nbr * nbb > cap:
        if nbb > 3:
            nbb = max(3, nbb // 2)
        else:
            cwr *= 2.0
            nbr = _n_bins(rmax - rmin, cwr, cap)
    cwb = 2.0 * math.pi / nbb
    nc = nbr * nbb
    cell = iwork[:L]
    members = iwork[L:2 * L]
    start = iwork[2 * L:2 * L + nc + 1]
    fill = iwork[2 * L + cap + 1:2 * L + cap + 1 + nc]
    for c in range(nc + 1):
        start[c] = 0
    for i in range(L):
        rb = min(int((H[i, 0] - rmin) / cwr), nbr - 1)
        bb = min(max(int((H[i, 1] + math.pi) / cwb), 0), nbb - 1)
        cell[i] = rb * nbb + bb
        start[cell[i] + 1] += 1
    for c in range(nc):
        start[c + 1] += start[c]
        fill[c] = start[c]
    for i in range(L):
        members[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return rmin, cwr, nbr, cwb, nbb


@nb.njit(cache=True)
def phd_range_bearing_update_kernel(H, w, Z, kappa, pd, i00, i11, gnorm, gate2, fac, zmass,
                                    gidx, gval, iwork):
    """PHD weight update in place for a range-bearing sensor with diagonal
    ``R = diag(1 / i00, 1 / i11)``.

    ``H`` ``(L, 2)``: predicted (range, bearing) of each particle; ``w``
    ``(L,)`` weights (overwritten by the updated ones); ``Z`` ``(m, 2)``
    measurements; ``kappa`` ``(m,)`` clutter intensity at each measurement
    (per unit of range x bearing); ``gnorm = 1 / (2 pi sqrt(|R|))``; pairs with
    ``d^2 > gate2`` are skipped (range part tested first).  With a finite gate the
    particles are first bucketed in (range, bearing) cells at least as wide as the
    gate, and each measurement visits only the particles of its own and the eight
    neighbouring cells (the others cannot pass the gate), so the cost grows with
    the gated pairs rather than with ``L m``.  ``zmass`` ``(m,)`` receives
    ``C(z) / (kappa(z) + C(z))``, the posterior probability that ``z`` came from a
    target (0 when ``C(z)`` underflows).  Work arrays ``fac`` ``(L,)`` float64,
    ``gidx`` ``(L,)`` int64 and ``gval`` ``(L,)`` float64 (the gated particles of one
    measurement and their ``exp(-d^2 / 2)``, so the second pass visits only those),
    ``iwork`` int64 of length ``2 L + 2 (max(64, 4 L) + 1)`` (the cells).  Returns
    ``N_hat``, the updated total mass."""
    L = H.shape[0]
    m = Z.shape[0]
    for i in range(L):
        fac[i] = 1.0 - pd
    nbr = 0
    rmin, cwr, cwb, nbb = 0.0, 1.0, 1.0, 1
    bz = 0
    if m > 0 and gate2 < np.inf:
        rmin, cwr, nbr, cwb, nbb = _grid_cells(H, math.sqrt(gate2 / i00),
                                               math.sqrt(gate2 / i11), iwork)
    members = iwork[L:2 * L]
    start = iwork[2 * L:]
    for jj in range(m):
        zr, zb = Z[jj, 0], Z[jj, 1]
        zmass[jj] = 0.0
        Cz = 0.0
        cnt = 0
        if nbr == 0:
            r0, r1, nbw = 0, 1, 1
        else:
            # clamped to [-2, nbr + 1] before the integer conversion (a far or non-finite
            # measurement visits no cell, as it would unclamped)
            fz = math.floor((zr - rmin) / cwr)
            rz = int(fz) if -2.0 <= fz <= nbr + 1.0 else (nbr + 1 if fz > 0.0 else -2)
            r0, r1 = max(rz - 1, 0), min(rz + 2, nbr)
            fb = math.floor((zb + math.pi) / cwb)
            if not (abs(fb) < 1e15):
                fb = np.fmod(fb, float(nbb)) if abs(fb) < np.inf else 0.0
            bz = int(fb)
            nbw = 3
        for rb in range(r0, r1):
            for u in range(nbw):
                if nbr == 0:
                    q0, q1 = 0, L
                else:
                    c = rb * nbb + (bz - 1 + u) % nbb
                    q0, q1 = start[c], start[c + 1]
                for q in range(q0, q1):
                    i = q if nbr == 0 else members[q]
                    dr = zr - H[i, 0]
                    d2 = dr * dr * i00
                    if d2 > gate2:
                        continue
                    db = zb - H[i, 1]
                    if not (-math.pi < db <= math.pi):
                        db = wrap_angle_kernel(db)
                    d2 += db * db * i11
                    if d2 > gate2:
                        continue
                    e = math.exp(-0.5 * d2)
                    Cz += pd * gnorm * e * w[i]
                    gidx[cnt] = i
                    gval[cnt] = e
                    cnt += 1
        den = kappa[jj] + Cz
        if Cz <= 0.0:
            continue
        zmass[jj] = Cz / den
        for q in range(cnt):
            fac[gidx[q]] += pd * gnorm * gval[q] / den
    Nhat = 0.0
    for i in range(L):
        w[i] *= fac[i]
        Nhat += w[i]
    return Nhat


@nb.njit(cache=True)
def smc_phd_step_kernel(X, w, n, Z, kappa, F, L, ps, birth_mean, birth_L, n_birth, birth_rate,
                        pd, i00, i11, gnorm, gate2, sx, sy, rng, Xout, wout, H, fac, zmass, ridx,
                        gidx, gval, iwork):
    """One SMC-PHD scan (predict, Gaussian birth, update, resample).

    ``X`` ``(cap, n_x)`` holds the ``n`` prior particles in its first rows and
    ``w`` ``(cap,)`` their weights, ``cap >= n + n_birth``; both are used as
    work space.  ``F`` ``(n_x, n_x)``, ``L`` ``(n_x, k)`` the process-noise
    factor (``Q = L L^T``), ``birth_L`` ``(n_x, k_b)`` the birth-covariance
    factor.  The ``n_out = len(wout)`` resampled particles go to ``Xout``
    (``(n_out, n_x)``) with weights ``N_hat / n_out`` (all 0 and the
    predicted particles in order, cycling, when ``N_hat = 0``).  Work arrays:
    ``H`` ``(cap, 2)``, ``fac`` ``(cap,)``, ``zmass`` ``(m,)``, ``ridx``
    ``(n_out,)`` int64, ``gidx`` ``(cap,)`` int64, ``gval`` ``(cap,)``, ``iwork``
    (int64, see ``phd_range_bearing_update_kernel``, for ``cap`` particles).
    Returns ``N_hat``."""
    nx = X.shape[1]
    if n > 0:
        propagate_linear_kernel(X[:n], F, L, rng, X[:n])
        for i in range(n):
            w[i] *= ps
    if n_birth > 0:
        for i in range(n, n + n_birth):
            for a in range(nx):
                X[i, a] = birth_mean[a]
        eye = np.eye(nx)
        propagate_linear_kernel(X[n:n + n_birth], eye, birth_L, rng, X[n:n + n_birth])
        wb = birth_rate / n_birth
        for i in range(n, n + n_birth):
            w[i] = wb
    Lt = n + n_birth
    range_bearing_kernel(X[:Lt], sx, sy, H[:Lt])
    Nhat = phd_range_bearing_update_kernel(H[:Lt], w[:Lt], Z, kappa, pd, i00, i11, gnorm,
                                           gate2, fac[:Lt], zmass, gidx, gval, iwork)
    n_out = wout.shape[0]
    if Nhat > 0.0:
        systematic_indices_kernel(w[:Lt], rng.random(), ridx)
        wo = Nhat / n_out
        for i in range(n_out):
            j = ridx[i]
            for a in range(nx):
                Xout[i, a] = X[j, a]
            wout[i] = wo
    else:
        for i in range(n_out):
            j = i % Lt if Lt > 0 else 0
            for a in range(nx):
                Xout[i, a] = X[j, a] if Lt > 0 else birth_mean[a]
            wout[i] = 0.0
    return Nhat


@nb.njit(cache=True)
def _filter_kernel(X0, w0, Z, off, kappa_const, F, L, ps, birth_mean, birth_L, n_birth,
                   birth_rate, pd, i00, i11, gnorm, gate2, sx, sy, rng, n_out, card):
    nx = X0.shape[1]
    n = X0.shape[0]
    cap = max(n, n_out) + n_birth
    X = np.zeros((cap, nx))
    w = np.zeros(cap)
    for i in range(n):
        w[i] = w0[i]
        for a in range(nx):
            X[i, a] = X0[i, a]
    Xo = np.zeros((cap, nx))   # the two buffers swap roles every scan (no copy back)
    wo = np.zeros(cap)
    H = np.zeros((cap, 2))
    fac = np.zeros(cap)
    ridx = np.zeros(n_out, dtype=np.int64)
    gidx = np.zeros(cap, dtype=np.int64)
    gval = np.zeros(cap)
    iwork = np.zeros(2 * cap + 2 * (max(64, 4 * cap) + 1), dtype=np.int64)
    K = off.shape[0] - 1
    mmax = 0
    for k in range(K):
        mmax = max(mmax, off[k + 1] - off[k])
    zmass = np.zeros(mmax)
    kappa = np.full(mmax, kappa_const)
    for k in range(K):
        a0, a1 = off[k], off[k + 1]
        m = a1 - a0
        card[k] = smc_phd_step_kernel(X, w, n, Z[a0:a1], kappa[:m], F, L, ps, birth_mean,
                                      birth_L, n_birth, birth_rate, pd, i00, i11, gnorm, gate2,
                                      sx, sy, rng, Xo[:n_out], wo[:n_out], H, fac, zmass[:m],
                                      ridx, gidx, gval, iwork)
        X, Xo = Xo, X
        w, wo = wo, w
        n = n_out
    return X[:n_out].copy(), w[:n_out].copy()


# --------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------
class SmcPhdModel(NamedTuple):
    """Validated SMC-PHD model (build with :func:`smc_phd_model`).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_model
    >>> F = np.eye(4)
    >>> F[0, 2] = F[1, 3] = 1.0
    >>> model = smc_phd_model(F, 0.01 * np.eye(4), np.diag([25.0, 1e-4]), pd=0.9, ps=0.99,
    ...                       clutter_intensity=1e-3, birth_mean=[1000.0, 0.0, 0.0, 0.0],
    ...                       birth_cov=np.diag([100.0, 100.0, 1.0, 1.0]), n_birth=200,
    ...                       birth_rate=0.1)
    >>> type(model).__name__, model.F.shape, model.L.shape
    ('SmcPhdModel', (4, 4), (4, 4))
    """

    F: np.ndarray
    L: np.ndarray
    R: np.ndarray
    pd: float
    ps: float
    clutter_intensity: float
    birth_mean: np.ndarray
    birth_L: np.ndarray
    n_birth: int
    birth_rate: float
    sensor: tuple
    gate: float


class SmcPhdUpdate(NamedTuple):
    """Result of :func:`smc_phd_update`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_update
    >>> up = smc_phd_update(np.array([[1000.0, 0.0]]), [1.0], np.zeros((0, 2)),
    ...                     np.diag([25.0, 1e-4]), 0.9, 1e-3)
    >>> type(up).__name__, up.w.round(2).tolist(), round(up.cardinality, 2)
    ('SmcPhdUpdate', [0.1], 0.1)
    """

    w: np.ndarray
    cardinality: float
    measurement_mass: np.ndarray


class SmcPhdStep(NamedTuple):
    """Result of :func:`smc_phd_step`: the resampled particles and weights,
    ``cardinality = N_hat`` (sum of the updated weights) and per measurement
    ``C(z) / (kappa(z) + C(z))``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_model
    >>> F = np.eye(4)
    >>> F[0, 2] = F[1, 3] = 1.0
    >>> model = smc_phd_model(F, 0.01 * np.eye(4), np.diag([25.0, 1e-4]), pd=0.9, ps=0.99,
    ...                       clutter_intensity=1e-3, birth_mean=[1000.0, 0.0, 0.0, 0.0],
    ...                       birth_cov=np.diag([100.0, 100.0, 1.0, 1.0]), n_birth=200,
    ...                       birth_rate=0.1)
    >>> from trackcore.trackers.smc_phd_step import smc_phd_step
    >>> st = smc_phd_step(np.zeros((0, 4)), np.zeros(0), np.zeros((0, 2)), model,
    ...                   np.random.default_rng(0), n_out=100)
    >>> type(st).__name__, round(st.cardinality, 3)
    ('SmcPhdStep', 0.01)
    """

    particles: np.ndarray
    w: np.ndarray
    cardinality: float
    measurement_mass: np.ndarray


class SmcPhdFilterRun(NamedTuple):
    """Result of :func:`smc_phd_filter`: ``cardinality`` ``(K,)`` per scan and
    the final particles and weights.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_model
    >>> F = np.eye(4)
    >>> F[0, 2] = F[1, 3] = 1.0
    >>> model = smc_phd_model(F, 0.01 * np.eye(4), np.diag([25.0, 1e-4]), pd=0.9, ps=0.99,
    ...                       clutter_intensity=1e-3, birth_mean=[1000.0, 0.0, 0.0, 0.0],
    ...                       birth_cov=np.diag([100.0, 100.0, 1.0, 1.0]), n_birth=200,
    ...                       birth_rate=0.1)
    >>> from trackcore.trackers.smc_phd_step import smc_phd_filter
    >>> no_z = np.zeros((0, 2))
    >>> out = smc_phd_filter(np.zeros((0, 4)), np.zeros(0), no_z, np.zeros(3, int), model,
    ...                      np.random.default_rng(0), n_out=200)
    >>> type(out).__name__, out.cardinality.shape, out.particles.shape
    ('SmcPhdFilterRun', (2,), (200, 4))
    """

    cardinality: np.ndarray
    particles: np.ndarray
    w: np.ndarray


def _diag_R(R):
    R = as_square_matrix(R, "R", 2)
    if R[0, 1] != 0.0 or R[1, 0] != 0.0:
        raise ValueError("R must be diagonal (range and bearing noise independent)")
    if not (R[0, 0] > 0.0 and R[1, 1] > 0.0):
        raise ValueError(f"R must have positive diagonal entries, got {np.diag(R)}")
    return R


def _rb_constants(R):
    i00 = 1.0 / R[0, 0]
    i11 = 1.0 / R[1, 1]
    d = math.sqrt(R[0, 0] * R[1, 1])
    if not (d > 0.0 and math.isfinite(i00) and math.isfinite(i11)):
        raise ValueError("R is too small: its inverse or determinant leaves double range")
    gnorm = 1.0 / (2.0 * math.pi * d)
    return i00, i11, gnorm


def _gate(gate):
    g = as_scalar(gate, "gate", finite=False)
    if not g > 0.0:
        raise ValueError(f"gate must be > 0 (may be inf), got {g}")
    return g


def _sensor_xy(sensor):
    s = as_vector(sensor, "sensor", 2)
    return float(s[0]), float(s[1])


def smc_phd_model(F, Q, R, *, pd, ps, clutter_intensity, birth_mean, birth_cov, n_birth,
                  birth_rate, sensor=(0.0, 0.0), gate=DEFAULT_GATE) -> SmcPhdModel:
    """Validate an SMC-PHD model once: motion ``x' = F x + w``, ``w ~ N(0, Q)``
    (``Q`` PSD, factored by :func:`trackcore.filters.noise_factor`);
    range-bearing measurement noise ``R`` (2x2, diagonal: ``[sigma_r^2,
    sigma_theta^2]``); detection and survival probabilities ``pd`` (in
    (0, 1]) and ``ps``; constant clutter intensity ``clutter_intensity``
    (> 0, expected clutter count per unit of range x bearing: ``lambda / V``);
    Gaussian birth density ``N(birth_mean, birth_cov)`` sampled with
    ``n_birth`` particles per scan of total weight ``birth_rate``; sensor
    position; likelihood gate (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_model
    >>> F = np.eye(4)
    >>> F[0, 2] = F[1, 3] = 1.0
    >>> model = smc_phd_model(F, 0.01 * np.eye(4), np.diag([25.0, 1e-4]), pd=0.9, ps=0.99,
    ...                       clutter_intensity=1e-3, birth_mean=[1000.0, 0.0, 0.0, 0.0],
    ...                       birth_cov=np.diag([100.0, 100.0, 1.0, 1.0]), n_birth=200,
    ...                       birth_rate=0.1)
    >>> model.n_birth, model.birth_rate, model.pd
    (200, 0.1, 0.9)
    """
    F = as_square_matrix(F, "F")
    nx = F.shape[0]
    if nx < 2:
        raise ValueError(f"F must be at least 2x2 (state [x, y, ...]), got {F.shape}")
    L = noise_factor(Q, "Q")
    if L.shape[0] != nx:
        raise ValueError(f"Q must be ({nx}, {nx}), got {np.shape(Q)}")
    R = _diag_R(R)
    pd = as_probability(pd, "pd", open_low=True)
    ps = as_probability(ps, "ps")
    kap = as_scalar(clutter_intensity, "clutter_intensity")
    if not kap > 0.0:
        raise ValueError(f"clutter_intensity must be > 0, got {kap}")
    bm = as_vector(birth_mean, "birth_mean", nx)
    bL = noise_factor(birth_cov, "birth_cov")
    if bL.shape[0] != nx:
        raise ValueError(f"birth_cov must be ({nx}, {nx}), got {np.shape(birth_cov)}")
    nb_ = as_int(n_birth, "n_birth", minimum=0)
    br = as_nonnegative(birth_rate, "birth_rate")
    if nb_ == 0 and br > 0:
        raise ValueError("n_birth must be >= 1 when birth_rate > 0")
    return SmcPhdModel(F, np.ascontiguousarray(L), R, pd, ps, kap, bm, np.ascontiguousarray(bL),
                       nb_, br, _sensor_xy(sensor), _gate(gate))


def _plain(x, ndim):
    """Already what the kernels take (C-contiguous float64, finite): skip the full checks."""
    return (type(x) is np.ndarray and x.dtype == np.float64 and x.ndim == ndim
            and x.flags.c_contiguous and math.isfinite(x.sum()))


def _particles_weights(particles, w, nx=None):
    # each argument takes a cheap path when it is already a plain finite float64 array;
    # anything else goes through the full checks (which convert or raise the usual errors)
    X = particles if _plain(particles, 2) else as_array(particles, "particles", ndim=2)
    if nx is not None and X.shape[1] != nx:
        raise ValueError(f"particles must have shape (N, {nx}), got {X.shape}")
    if X.shape[1] < 2:
        raise ValueError(f"particles must have at least 2 columns, got {X.shape}")
    W = w if _plain(w, 1) else as_array(w, "w", ndim=1)
    if W.shape[0] != X.shape[0]:
        raise ValueError(f"w must have shape ({X.shape[0]},), got {W.shape}")
    if W.size and W.min() < 0:
        raise ValueError("w must be non-negative")
    return X, W


def smc_phd_update(particles, w, z, R, pd, clutter_intensity, *, sensor=(0.0, 0.0),
                   gate=DEFAULT_GATE) -> SmcPhdUpdate:
    """PHD update of predicted particles ``(N, n)`` (``[x, y, ...]``) with
    linear weights ``w`` ``(N,)`` by the range-bearing scan ``z`` ``(m, 2)``
    (``m = 0`` allowed: every weight times ``1 - pd``).  ``R`` diagonal 2x2;
    ``clutter_intensity`` a scalar or ``(m,)`` array of ``kappa(z)`` (> 0).
    Returns :class:`SmcPhdUpdate` (new weight array, ``N_hat = sum w``, per
    measurement ``C(z) / (kappa(z) + C(z))``).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_update
    >>> particles = np.column_stack([np.full(100, 1000.0), np.zeros(100)])
    >>> R = np.diag([25.0, 1e-4])
    >>> up = smc_phd_update(particles, np.full(100, 0.01), [[1000.0, 0.0]], R, 0.9, 1e-3)
    >>> round(up.cardinality, 3), up.measurement_mass.round(3).tolist()
    (1.1, [1.0])
    """
    X, W = _particles_weights(particles, w)
    Z = as_measurements(z, "z", 2)
    R = _diag_R(R)
    pd = as_probability(pd, "pd", open_low=True)
    m = Z.shape[0]
    kap = np.asarray(clutter_intensity)
    if kap.ndim == 0:
        kap = np.full(m, as_scalar(clutter_intensity, "clutter_intensity"))
    else:
        kap = as_array(clutter_intensity, "clutter_intensity", shape=(m,))
    if np.any(~(kap > 0.0)):
        raise ValueError("clutter_intensity must be > 0")
    sx, sy = _sensor_xy(sensor)
    gate2 = _gate(gate)
    N = X.shape[0]
    H = np.empty((N, 2))
    range_bearing_kernel(X, sx, sy, H)
    W = W.copy()
    zmass = np.zeros(m)
    nhat = phd_range_bearing_update_kernel(H, W, Z, kap, pd, *_rb_constants(R), gate2,
                                           np.empty(N), zmass, np.empty(N, dtype=np.int64),
                                           np.empty(N),
                                           np.empty(_grid_work_size(N), dtype=np.int64))
    return SmcPhdUpdate(W, float(nhat), zmass)


def _model_array(value, name, shape):
    if (type(value) is not np.ndarray or value.dtype != np.float64 or value.shape != shape
            or not value.flags.c_contiguous):
        raise TypeError(f"model.{name} must be a C-contiguous float64 array of shape {shape} "
                        f"(build the model with smc_phd_model)")
    if not np.all(np.isfinite(value)):
        raise ValueError(f"model.{name} must be finite")


def _model_scalar(value, name, *, low, high=None, low_open=False):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer,
                                                                     np.floating)):
        raise TypeError(f"model.{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    ok = (v > low if low_open else v >= low) and (high is None or v <= high)
    if math.isnan(v) or not ok:
        rng_ = f"{'(' if low_open else '['}{low}, {high if high is not None else 'inf'}]"
        raise ValueError(f"model.{name} must lie in {rng_}, got {value}")
    return v


def _check_model(model):
    """Check every field of ``model`` before a kernel sees it, so that a record changed
    with ``model._replace(...)`` cannot bypass :func:`smc_phd_model`'s checks."""
    if not isinstance(model, SmcPhdModel):
        raise TypeError(f"model must be an SmcPhdModel (see smc_phd_model), got "
                        f"{type(model).__name__}")
    F = model.F
    if type(F) is not np.ndarray or F.ndim != 2:
        raise TypeError("model.F must be a square 2-D array (build the model with "
                        "smc_phd_model)")
    nx = F.shape[0]
    _model_array(F, "F", (nx, nx))
    if nx < 2:
        raise ValueError(f"model.F must be at least 2x2, got {F.shape}")
    for name in ("L", "birth_L"):
        v = getattr(model, name)
        if type(v) is not np.ndarray or v.ndim != 2:
            raise TypeError(f"model.{name} must be a 2-D array")
        _model_array(v, name, (nx, v.shape[1]))
    _model_array(model.R, "R", (2, 2))
    if model.R[0, 1] != 0.0 or model.R[1, 0] != 0.0 or not (model.R[0, 0] > 0.0
                                                            and model.R[1, 1] > 0.0):
        raise ValueError("model.R must be diagonal with positive entries")
    _model_array(model.birth_mean, "birth_mean", (nx,))
    _model_scalar(model.pd, "pd", low=0.0, high=1.0, low_open=True)
    _model_scalar(model.ps, "ps", low=0.0, high=1.0)
    kap = _model_scalar(model.clutter_intensity, "clutter_intensity", low=0.0, low_open=True)
    if not math.isfinite(kap):
        raise ValueError(f"model.clutter_intensity must be finite, got {kap}")
    nb_ = model.n_birth
    if isinstance(nb_, (bool, np.bool_)) or not isinstance(nb_, (int, np.integer)):
        raise TypeError(f"model.n_birth must be an integer, got {nb_!r}")
    if nb_ < 0:
        raise ValueError(f"model.n_birth must be >= 0, got {nb_}")
    br = _model_scalar(model.birth_rate, "birth_rate", low=0.0)
    if not math.isfinite(br):
        raise ValueError(f"model.birth_rate must be finite, got {br}")
    if nb_ == 0 and br > 0:
        raise ValueError("model.n_birth must be >= 1 when model.birth_rate > 0")
    sensor = model.sensor
    if (not isinstance(sensor, tuple) or len(sensor) != 2
            or not all(isinstance(v, float) and math.isfinite(v) for v in sensor)):
        raise TypeError("model.sensor must be a tuple of two finite floats")
    _model_scalar(model.gate, "gate", low=0.0, low_open=True)
    return model


def _output_size(n_out, N: int, mdl: SmcPhdModel) -> int:
    """The number of particles kept after resampling (default: the prior's ``N``)."""
    n_out = N if n_out is None else as_int(n_out, "n_out", minimum=1)
    if n_out < 1:
        raise ValueError("n_out must be >= 1 (particles is empty: pass n_out)")
    if N + mdl.n_birth == 0:
        raise ValueError("particles is empty and model.n_birth is 0: nothing to propagate")
    return n_out


def smc_phd_step(particles, w, z, model: SmcPhdModel, rng, *, n_out=None) -> SmcPhdStep:
    """One SMC-PHD scan: predict the prior particles ``(N, n)`` with linear
    weights ``w`` ``(N,)`` (``N = 0`` allowed: births only), add the Gaussian
    births, update with the range-bearing scan ``z`` ``(m, 2)`` (``m = 0``
    allowed) and resample ``n_out`` particles (default ``N``).  ``model`` from
    :func:`smc_phd_model`; ``rng`` a ``numpy.random.Generator`` (draw order in
    the module docstring).  Returns :class:`SmcPhdStep` (new arrays).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_model
    >>> F = np.eye(4)
    >>> F[0, 2] = F[1, 3] = 1.0
    >>> model = smc_phd_model(F, 0.01 * np.eye(4), np.diag([25.0, 1e-4]), pd=0.9, ps=0.99,
    ...                       clutter_intensity=1e-3, birth_mean=[1000.0, 0.0, 0.0, 0.0],
    ...                       birth_cov=np.diag([100.0, 100.0, 1.0, 1.0]), n_birth=200,
    ...                       birth_rate=0.1)
    >>> from trackcore.trackers.smc_phd_step import smc_phd_step
    >>> st = smc_phd_step(np.zeros((0, 4)), np.zeros(0), [[1000.0, 0.0]], model,
    ...                   np.random.default_rng(0), n_out=200)
    >>> st.particles.shape, round(st.cardinality, 2)
    ((200, 4), 1.0)
    """
    mdl = _check_model(model)
    rng = as_rng(rng)
    nx = mdl.F.shape[0]
    X, W = _particles_weights(particles, w, nx)
    Z = z if (_plain(z, 2) and z.shape[1] == 2) else as_measurements(z, "z", 2)
    N = X.shape[0]
    n_out = _output_size(n_out, N, mdl)
    cap = N + mdl.n_birth
    Xw = np.empty((cap, nx))
    Xw[:N] = X
    ww = np.empty(cap)
    ww[:N] = W
    m = Z.shape[0]
    Xo = np.empty((n_out, nx))
    wo = np.empty(n_out)
    zmass = np.zeros(m)
    i00, i11, gnorm = _rb_constants(mdl.R)
    nhat = smc_phd_step_kernel(Xw, ww, N, Z, np.full(m, mdl.clutter_intensity), mdl.F, mdl.L,
                               mdl.ps, mdl.birth_mean, mdl.birth_L, mdl.n_birth, mdl.birth_rate,
                               mdl.pd, i00, i11, gnorm, mdl.gate, mdl.sensor[0], mdl.sensor[1],
                               rng, Xo, wo, np.empty((cap, 2)), np.empty(cap), zmass,
                               np.empty(n_out, dtype=np.int64), np.empty(cap, dtype=np.int64),
                               np.empty(cap), np.empty(_grid_work_size(cap), dtype=np.int64))
    return SmcPhdStep(Xo, wo, float(nhat), zmass)


def smc_phd_filter(particles, w, z, offsets, model: SmcPhdModel, rng, *,
                   n_out=None) -> SmcPhdFilterRun:
    """Run :func:`smc_phd_step` over a whole run of scans in one kernel
    (identical results and draws): ``z`` ``(M, 2)`` all scans concatenated,
    ``offsets`` ``(K + 1,)`` (scan ``k`` is ``z[offsets[k]:offsets[k+1]]``).
    Returns :class:`SmcPhdFilterRun` (``N_hat`` per scan, final particles).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.smc_phd_step import smc_phd_model
    >>> F = np.eye(4)
    >>> F[0, 2] = F[1, 3] = 1.0
    >>> model = smc_phd_model(F, 0.01 * np.eye(4), np.diag([25.0, 1e-4]), pd=0.9, ps=0.99,
    ...                       clutter_intensity=1e-3, birth_mean=[1000.0, 0.0, 0.0, 0.0],
    ...                       birth_cov=np.diag([100.0, 100.0, 1.0, 1.0]), n_birth=200,
    ...                       birth_rate=0.1)
    >>> from trackcore.trackers.smc_phd_step import smc_phd_filter
    >>> z = np.array([[1000.0, 0.0]] * 5)
    >>> offsets = np.arange(6)
    >>> out = smc_phd_filter(np.zeros((0, 4)), np.zeros(0), z, offsets, model,
    ...                      np.random.default_rng(0), n_out=200)
    >>> out.cardinality.round(2).tolist()
    [1.0, 1.11, 1.12, 1.12, 1.12]
    """
    mdl = _check_model(model)
    rng = as_rng(rng)
    nx = mdl.F.shape[0]
    X, W = _particles_weights(particles, w, nx)
    Z = as_measurements(z, "z", 2)
    off = as_offsets(offsets, Z.shape[0])
    N = X.shape[0]
    n_out = _output_size(n_out, N, mdl)
    card = np.zeros(off.shape[0] - 1)
    i00, i11, gnorm = _rb_constants(mdl.R)
    if off.shape[0] == 1:
        return SmcPhdFilterRun(card, X.copy(), W.copy())  # no scans: the prior, unchanged
    Xo, wo = _filter_kernel(X, W, Z, off, mdl.clutter_intensity, mdl.F, mdl.L, mdl.ps,
                            mdl.birth_mean, mdl.birth_L, mdl.n_birth, mdl.birth_rate, mdl.pd,
                            i00, i11, gnorm, mdl.gate, mdl.sensor[0], mdl.sensor[1], rng, n_out,
                            card)
    return SmcPhdFilterRun(card, Xo, wo)
