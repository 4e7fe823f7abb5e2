"""HPDA-PF: automatic multi-target detection and tracking with Highest
Probability Data Association and particle filters (Kim & Song 2007, Fig 3;
the flow is reconstructed from the paper's text, see the chapter's
"Single runs" page).

Every scan, for every track (tentative or confirmed):

1. predict (confirmed: jump-Markov particles; tentative: EKF) and
   ``P^- = Pi11 p + Pi12 (1 - p)`` (eq 17);
2. gate the scan around ``z_hat``, ``S`` (``g^2`` from ``P_G``), rank the
   validated measurements by amplitude, compute the rank probabilities (12),
   (10), the betas (14) with ``f_T = N(z; z_hat, S) / P_G`` and select the
   highest, ``s`` (15);
3. update the existence probability by (19) (``delta = P_D P_G`` if m = 0);
4. if ``m >= 1`` update the state with ``z^s`` -- confirmed tracks weight
   their particles with the target/clutter mixture likelihood (13) and
   resample systematically; tentative tracks do the single-measurement PDA
   update of their EKF with ``beta^s``.

Status changes: tentative -> confirmed at ``p >= P_c`` (its EKF posterior is
sampled into ``N`` particles); confirmed tracks below ``P_t`` are terminated;
tentative tracks below ``p_delete`` are deleted.  Every measurement that is
in no confirmed track's gate and was not selected by any tentative track
spawns a new tentative track (``p_0``), first updated at the next scan.

Choices (not in the paper) are fields of :class:`HpdaPfConfig` and are
documented there.  The whole run is one numba kernel over fixed-capacity
arrays; particles are ``(N, 4)`` per confirmed track.  Gating visits only
the measurements whose bearing lies within the gate's bearing extent
(a binary search in the scan sorted by bearing), so dense scans cost
``O(log m)`` per track and scan plus the validated returns.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from ..association.existence import ipda_existence_kernel, nn_existence_kernel
from ..association.gating import gate_threshold
from ..association.hpda import (_conditional_rank_from_q1, _log_q, _mixture_loglik_polar,
                                _wrap_near, hpda_existence_delta_kernel)
from ..association.pda import _pda_scratch, _pda_update_work
from ..filters.particle import systematic_indices_kernel
from ..core.validation import as_array, as_offsets, as_rng, as_scalar
from ..models.measurement import range_bearing_jacobian_kernel, wrap_angle_kernel

__all__ = [
    "HpdaPfConfig",
    "TrackerRun",
    "hpda_pf_run",
    "SELECT_HPDA",
    "SELECT_STRONGEST",
    "SELECT_NEAREST",
    "SELECTION_DIAGNOSTICS",
    "check_scans",
    "clutter_likelihood_ratios",
]

#: selection rules: eq (15) (HPDA), strongest neighbour (s = 1), nearest neighbour (all
#: three with eq (19)); the two valid distance-only filters of
#: :mod:`trackcore.association.existence` (codes 3, 4): the nearest neighbour with its own
#: likelihood, and IPDA over every gated return
SELECT_HPDA = 0
SELECT_STRONGEST = 1
SELECT_NEAREST = 2
_SELECT_NN_LIKELIHOOD = 3
_SELECT_IPDA = 4
_RULES = {"hpda": SELECT_HPDA, "strongest": SELECT_STRONGEST, "nearest": SELECT_NEAREST,
          "nn-likelihood": _SELECT_NN_LIKELIHOOD, "ipda": _SELECT_IPDA}

#: columns of :attr:`TrackerRun.diagnostics` (rows: confirmed, tentative tracks)
SELECTION_DIAGNOSTICS = (
    "track_scans",       # track-scans processed
    "m_ge_1",            # ... with at least one validated measurement
    "m_ge_2",            # ... with two or more (the only ones where the rules can differ)
    "hpda_ne_nearest",   # ... where eq (15) picks another measurement than the nearest
    "hpda_ne_strongest",  # ... where eq (15) picks another measurement than the strongest
    "sum_lambda_vg",     # sum of lambda V_G (expected clutter in the gate) over track-scans
    "dropped",           # candidates not opened for lack of capacity (tentative row only)
)


# --------------------------------------------------------------------------
# validation of the configuration records (shared with the other trackers)
# --------------------------------------------------------------------------
def _finite(obj, name, *, low=None, high=None, low_open=False, high_open=False):
    """Check ``obj.name`` is a finite real in the given range; store it as float."""
    v = getattr(obj, name)
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer,
                                                             np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(v).__name__}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if low is not None and (v <= low if low_open else v < low):
        raise ValueError(f"{name} must be {'>' if low_open else '>='} {low}, got {v}")
    if high is not None and (v >= high if high_open else v > high):
        raise ValueError(f"{name} must be {'<' if high_open else '<='} {high}, got {v}")
    object.__setattr__(obj, name, v)
    return v


def _gate_probability(obj, why):
    """``gate_probability`` in (0, 1); ``pg = 1`` (no gate) is rejected with ``why``."""
    v = obj.gate_probability
    if (isinstance(v, (int, float, np.integer, np.floating))
            and not isinstance(v, (bool, np.bool_)) and v == 1):
        raise ValueError(f"gate_probability must be < 1, got {float(v)}: pg = 1 means no gate "
                         f"(g^2 = inf), and {why}")
    return _finite(obj, "gate_probability", low=0.0, high=1.0, low_open=True, high_open=True)


def _integer(obj, name, minimum):
    v = getattr(obj, name)
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        if isinstance(v, (float, np.floating)) and math.isfinite(v) and float(v).is_integer():
            v = int(v)
        else:
            raise TypeError(f"{name} must be an integer, got {v!r}")
    v = int(v)
    if v < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {v}")
    object.__setattr__(obj, name, v)
    return v


def _flag(obj, name):
    v = getattr(obj, name)
    if not isinstance(v, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(v).__name__}")
    object.__setattr__(obj, name, bool(v))


def _tpm(obj, name="mode_tpm"):
    try:
        tpm = np.array(getattr(obj, name), dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a 3x3 matrix of numbers") from None
    if tpm.shape != (3, 3):
        raise ValueError(f"{name} must be 3x3, got shape {tpm.shape}")
    if (not np.all(np.isfinite(tpm)) or np.any(tpm < 0)
            or np.any(np.abs(tpm.sum(axis=1) - 1) > 1e-9)):
        raise ValueError(f"{name} must be a row-stochastic 3x3 matrix (entries >= 0, "
                         f"rows summing to 1), got {tpm.tolist()}")
    object.__setattr__(obj, name, tuple(tuple(float(v) for v in row) for row in tpm))


def _motion_and_sensor(obj):
    """The fields every tracker of the chapter shares, checked the same way."""
    _finite(obj, "pd", low=0.0, high=1.0, low_open=True, high_open=True)
    _finite(obj, "clutter_density_xy", low=0.0, low_open=True)
    _finite(obj, "T", low=0.0, low_open=True)
    _finite(obj, "sigma_r", low=0.0, low_open=True)
    _finite(obj, "sigma_theta", low=0.0, high=math.pi, low_open=True)
    _finite(obj, "sigma_a", low=0.0)
    _finite(obj, "a_m", low=0.0)
    _finite(obj, "velocity_std", low=0.0)
    _tpm(obj)


@dataclass(frozen=True)
class HpdaPfConfig:
    """Parameters of the HPDA-PF tracker; every field is checked when the record is
    built (``ValueError``/``TypeError`` naming the field).

    Environment (from the paper): ``pd`` (in (0, 1)), ``snr`` (linear rho >= 0),
    ``clutter_density_xy`` (lambda V / V per m^2, > 0), ``T`` (s), ``sigma_r`` (m),
    ``sigma_theta`` (rad), ``sigma_a`` (model acceleration std, m/s^2), ``a_m``
    (manoeuvre acceleration), ``n_particles = 1000`` per confirmed track,
    ``p_confirm = 0.9`` (P_c), ``p_terminate = 0.6`` (P_t).

    Choices (the book's, stated in the chapter's "Choices we made"):
    ``gate_probability = 0.99`` (g^2 = 9.21); ``pi11 = 0.99`` (the same death prior
    as the SMC-PHD filter's survival probability ``P_S = 0.99``), ``pi12 = 0``;
    ``p_initial = 0.01``, ``p_delete = 5e-4``, ``velocity_std = 1.5`` m/s
    (prior of new tracks), mode transition matrix ``mode_tpm`` (rows: from
    CV, left, right), ``tentative_sigma_a = 0.01`` m/s^2 (the tentative EKF
    is a CV filter whose process noise covers the manoeuvre acceleration),
    ``max_confirmed``/``max_tentative`` capacities, ``selection`` rule
    (``"hpda"``; ``"strongest"``/``"nearest"`` for the book's ablation, both with
    eq (19); ``"nn-likelihood"``: the nearest return with the nearest-neighbour
    likelihood ratio as existence update and as the weight of ``z^s``; ``"ipda"``:
    IPDA, every gated return in the existence update, the PDA update of the tentative
    EKF and the particles' weights, ``z^s`` the return of the largest weight),
    ``duplicate_scans = 3`` (two confirmed tracks selecting the same
    measurement that many scans in a row: the less likely one is dropped; 0
    disables), and ``tentative_yield = True`` (a tentative track that selects
    the same measurement as a confirmed track is deleted: the confirmed track
    owns it).

    Examples
    --------
    >>> import math
    >>> from trackcore.trackers.hpda_pf import HpdaPfConfig
    >>> cfg = HpdaPfConfig(pd=0.9, snr=10.0, clutter_density_xy=10 / (math.pi * 1e8))
    >>> cfg.n_particles, cfg.p_confirm, cfg.p_terminate, round(cfg.gate_threshold, 2)
    (1000, 0.9, 0.6, 9.21)
    >>> HpdaPfConfig(pd=1.5, snr=10.0, clutter_density_xy=1e-7)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: pd must be < 1.0, got 1.5
    """
    pd: float
    snr: float
    clutter_density_xy: float
    T: float = 10.0
    sigma_r: float = 50.0
    sigma_theta: float = math.radians(0.1)
    sigma_a: float = 0.0015
    a_m: float = 0.01
    n_particles: int = 1000
    p_confirm: float = 0.9
    p_terminate: float = 0.6
    gate_probability: float = 0.99
    pi11: float = 0.99
    pi12: float = 0.0
    p_initial: float = 0.01
    p_delete: float = 5e-4
    velocity_std: float = 1.5
    mode_tpm: tuple = ((0.90, 0.05, 0.05), (0.10, 0.90, 0.0), (0.10, 0.0, 0.90))
    tentative_sigma_a: float = 0.01
    max_confirmed: int = 32
    max_tentative: int = 4096
    selection: str = "hpda"
    duplicate_scans: int = 3
    tentative_yield: bool = True

    def __post_init__(self):
        _motion_and_sensor(self)
        _finite(self, "snr", low=0.0)
        _integer(self, "n_particles", 1)
        _finite(self, "p_confirm", low=0.0, high=1.0, low_open=True)
        _finite(self, "p_terminate", low=0.0, high=1.0, high_open=True)
        _gate_probability(self, "the HPDA's clutter model needs a finite gate volume V_G "
                                "(clutter mean lambda V_G, false-return density 1 / V_G)")
        _finite(self, "pi11", low=0.0, high=1.0)
        _finite(self, "pi12", low=0.0, high=1.0)
        _finite(self, "p_initial", low=0.0, high=1.0, low_open=True, high_open=True)
        _finite(self, "p_delete", low=0.0, high=1.0, high_open=True)
        _finite(self, "tentative_sigma_a", low=0.0)
        _integer(self, "max_confirmed", 1)
        _integer(self, "max_tentative", 1)
        _integer(self, "duplicate_scans", 0)
        _flag(self, "tentative_yield")
        if self.p_terminate > self.p_confirm:
            raise ValueError(f"p_terminate must be <= p_confirm, got {self.p_terminate} > "
                             f"{self.p_confirm}")
        if self.p_delete >= self.p_confirm:
            raise ValueError(f"p_delete must be < p_confirm, got {self.p_delete}")
        if not isinstance(self.selection, str) or self.selection not in _RULES:
            raise ValueError(f"selection must be one of {tuple(_RULES)}, got "
                             f"{self.selection!r}")

    @property
    def tau(self) -> float:
        return -(1.0 + self.snr) * math.log(self.pd)

    @property
    def gate_threshold(self) -> float:
        """``g^2`` of a 2-D gate with probability ``gate_probability``."""
        return gate_threshold(self.gate_probability, 2)


class TrackerRun(NamedTuple):
    """Output of a multi-target tracker run over K scans.

    ``count`` (K,) estimated number of targets; ``estimates`` (K, C, 4) estimated
    states, rows ``0 .. n_estimates[k] - 1`` valid; ``ids`` (K, C) track ids (-1
    unused); ``n_estimates`` (K,); ``aux`` (K,) algorithm-specific (HPDA: number of
    tentative tracks; SMC-PHD: sum of weights; clustering: number of tracks);
    ``diagnostics`` (HPDA only, else ``None``): a (2, 7) array, rows confirmed and
    tentative tracks, columns :data:`SELECTION_DIAGNOSTICS`.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.hpda_pf import TrackerRun
    >>> run = TrackerRun(np.array([0, 1]), np.full((2, 4, 4), np.nan), np.full((2, 4), -1),
    ...                  np.array([0, 1]), np.zeros(2))
    >>> run.count.tolist(), run.estimates.shape, run.diagnostics is None
    ([0, 1], (2, 4, 4), True)
    """
    count: np.ndarray
    estimates: np.ndarray
    ids: np.ndarray
    n_estimates: np.ndarray
    aux: np.ndarray
    diagnostics: np.ndarray | None = None


#: the largest range :func:`check_scans` accepts (m)
_MAX_RANGE = 1e15
#: the smallest range :func:`check_scans` accepts (m; the bearing's spread in m is
#: range x sigma_theta, and the link weights divide by its square)
_MIN_RANGE = 1e-6


def check_scans(z, amplitude, offsets):
    """Validate a concatenated run of scans (ranges ``> 0``, finite bearings, no NaN
    amplitude, valid offsets); returns contiguous arrays ``(z, amplitude, offsets)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.hpda_pf import check_scans
    >>> z, amp, off = check_scans([[1000.0, 0.1], [2000.0, -0.2]], [3.0, 4.0], [0, 1, 2])
    >>> z.shape, amp.tolist(), off.tolist()
    ((2, 2), [3.0, 4.0], [0, 1, 2])
    >>> check_scans([[-5.0, 0.1]], [3.0], [0, 1])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: z[:, 0] (range) must be >= 1e-06 m
    """
    Z = as_array(z, "z", ndim=2)
    if Z.shape[1] != 2:
        raise ValueError(f"z must have shape (M, 2), got {Z.shape}")
    A = as_array(amplitude, "amplitude", finite=False)
    if A.shape != (Z.shape[0],):
        raise ValueError(f"amplitude must have shape ({Z.shape[0]},), got {A.shape}")
    if np.isnan(A).any():
        raise ValueError("amplitude must not contain NaN")
    if np.isinf(A).any():
        raise ValueError("amplitude must be finite (not inf)")
    off = as_offsets(offsets, Z.shape[0])
    if Z.shape[0] and not Z[:, 0].min() >= _MIN_RANGE:
        raise ValueError(f"z[:, 0] (range) must be >= {_MIN_RANGE:g} m")
    if Z.shape[0] and not Z[:, 0].max() < _MAX_RANGE:
        # a gate volume grows with the range squared: beyond this it overflows to inf
        raise ValueError(f"z[:, 0] (range) must be below {_MAX_RANGE:g} m")
    return Z, np.ascontiguousarray(A, dtype=np.float64), off


# --------------------------------------------------------------------------
# kernels
# --------------------------------------------------------------------------
@nb.njit(cache=True)
def jump_markov_propagate_kernel(X, modes, cum_tpm, T, sigma_a, a_m, rng):
    """Propagate particles ``X`` (N, 4) in place through the three-mode
    jump-Markov model (eqs 1-2): draw the new mode from row ``modes[i]`` of
    the cumulative transition matrix, apply CV (mode 0) or a coordinated turn
    with ``Omega = +a_m/speed`` (mode 1, left) or ``-a_m/speed`` (mode 2,
    right), then add ``Gamma v``, ``v ~ N(0, sigma_a^2 I_2)``."""
    N = X.shape[0]
    hT2 = 0.5 * T * T
    for i in range(N):
        u = rng.random()
        r = modes[i]
        j = 0
        while j < 2 and u >= cum_tpm[r, j]:
            j += 1
        modes[i] = j
        x, y, vx, vy = X[i, 0], X[i, 1], X[i, 2], X[i, 3]
        sp = math.sqrt(vx * vx + vy * vy)
        if j == 0 or sp < 1e-9:
            x += T * vx
            y += T * vy
        else:
            om = a_m / sp if j == 1 else -a_m / sp
            wt = om * T
            s, c = math.sin(wt), math.cos(wt)
            a = s / om
            b = (1.0 - c) / om
            x += a * vx - b * vy
            y += b * vx + a * vy
            nvx = c * vx - s * vy
            vy = s * vx + c * vy
            vx = nvx
        w1 = sigma_a * rng.standard_normal()
        w2 = sigma_a * rng.standard_normal()
        X[i, 0] = x + hT2 * w1
        X[i, 1] = y + hT2 * w2
        X[i, 2] = vx + T * w1
        X[i, 3] = vy + T * w2


@nb.njit(cache=True)
def _particle_moments(X, zhat, S, R):
    """Predicted measurement mean and covariance of equally weighted
    particles (bearing averaged about the first particle's bearing)."""
    N = X.shape[0]
    _particle_moments_polar(X, zhat, S, R, np.empty(N), np.empty(N), np.empty(N))


@nb.njit(cache=True)
def _particle_moments_polar(X, zhat, S, R, rng_, brg, rel):
    """:func:`_particle_moments` that also leaves each particle's range in ``rng_``, its
    bearing in ``brg`` (for the weights of the same particles) and the bearing relative
    to the first particle's in ``rel`` (work arrays of length ``N``)."""
    N = X.shape[0]
    ref = math.atan2(X[0, 1], X[0, 0])
    sr = 0.0
    sb = 0.0
    for i in range(N):
        rng_[i] = math.sqrt(X[i, 0] * X[i, 0] + X[i, 1] * X[i, 1])
        brg[i] = math.atan2(X[i, 1], X[i, 0])
        rel[i] = _wrap_near(brg[i] - ref)
        sr += rng_[i]
        sb += rel[i]
    mr = sr / N
    mb = sb / N
    zhat[0] = mr
    zhat[1] = wrap_angle_kernel(ref + mb)
    c00 = 0.0
    c01 = 0.0
    c11 = 0.0
    for i in range(N):
        dr = rng_[i] - mr
        db = rel[i] - mb
        c00 += dr * dr
        c01 += dr * db
        c11 += db * db
    S[0, 0] = c00 / N + R[0, 0]
    S[0, 1] = c01 / N + R[0, 1]
    S[1, 0] = S[0, 1]
    S[1, 1] = c11 / N + R[1, 1]


@nb.njit(cache=True)
def _bearing_window(bsorted, lo, hi):
    """Index range ``[i0, i1)`` of the sorted bearings within ``[lo, hi]``."""
    i0 = np.searchsorted(bsorted, lo, side="left")
    i1 = np.searchsorted(bsorted, hi, side="right")
    return i0, i1


@nb.njit(cache=True, inline="always")
def _gate_and_select(Zs, As, border, bsorted, zhat, S, g2, pd, pg, c, lam_xy, rule,
                     vidx, d2buf, ndens, pt, pf, q1cache):
    """Gate the scan, rank the validated returns by amplitude and select one.

    ``border`` is the scan's order by bearing and ``bsorted`` the sorted bearings: only
    returns within the gate's bearing extent ``sqrt(g^2 S_11)`` (wrapped) are tested,
    and of these only those within its range extent ``sqrt(g^2 S_00)`` (widened by a
    relative 1e-6) get their distance computed.  ``q1cache[m]`` holds ``q_1`` of the
    rank probabilities for ``m`` returns once computed (-1 before; ``c`` must be the same
    in every call with the same cache).
    Returns ``(m, s_idx, beta_s, delta, pt_s, pf_s, V_G, s_used, s_hpda, s_nn)``:
    ``s_idx`` is the scan index of ``z^s`` (-1 if m = 0), the last three are ranks
    (0 = strongest) chosen by the rule in use, by eq (15) and by the nearest
    neighbour."""
    det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    i00 = S[1, 1] / det
    i01 = -S[0, 1] / det
    i11 = S[0, 0] / det
    sq = math.sqrt(det)
    VG = math.pi * g2 * sq
    hw = math.sqrt(g2 * S[1, 1]) * (1.0 + 1e-9) + 1e-12
    # d^2 >= n0^2 / S_00 for every bearing innovation: the range extent of the gate
    rw2 = g2 * S[0, 0] * (1.0 + 1e-6)
    m = 0
    n_win = 1
    lo0, hi0, lo1, hi1 = zhat[1] - hw, zhat[1] + hw, 1.0, 0.0
    if hw >= math.pi:
        lo0, hi0 = -np.inf, np.inf
    elif lo0 < -math.pi:
        lo1, hi1 = lo0 + 2.0 * math.pi, np.inf
        n_win = 2
    elif hi0 > math.pi:
        lo1, hi1 = -np.inf, hi0 - 2.0 * math.pi
        n_win = 2
    for w in range(n_win):
        if w == 0:
            i0, i1 = _bearing_window(bsorted, lo0, hi0)
        else:
            i0, i1 = _bearing_window(bsorted, lo1, hi1)
        for q in range(i0, i1):
            j = border[q]
            n0 = Zs[j, 0] - zhat[0]
            if n0 * n0 > rw2:
                continue
            n1 = _wrap_near(Zs[j, 1] - zhat[1])
            d2 = i00 * n0 * n0 + 2.0 * i01 * n0 * n1 + i11 * n1 * n1
            if d2 <= g2:
                # insert, keeping the validated returns in decreasing amplitude
                pos = m
                while pos > 0 and As[vidx[pos - 1]] < As[j]:
                    vidx[pos] = vidx[pos - 1]
                    d2buf[pos] = d2buf[pos - 1]
                    ndens[pos] = ndens[pos - 1]
                    pos -= 1
                vidx[pos] = j
                d2buf[pos] = d2
                ndens[pos] = math.exp(-0.5 * d2) / (2.0 * math.pi * sq)
                m += 1
    pdpg = pd * pg
    lam_z = lam_xy * zhat[0]
    if m == 0:
        return 0, -1, 0.0, pdpg, 0.0, 0.0, VG, -1, -1, -1
    clutter_mean = lam_z * VG
    q1 = q1cache[m]
    if q1 < 0.0:
        q1 = math.exp(_log_q(1.0, float(m), c))
        q1cache[m] = q1
    _conditional_rank_from_q1(m, q1, c, pdpg, clutter_mean, pt, pf)
    best = -1.0
    s_h = 0
    for l in range(m):
        fT = ndens[l] / pg
        num = fT * pt[l]
        b = num / (num + pf[l] / VG)
        if b > best:
            best = b
            s_h = l
    s_nn = 0
    dmin = 1e300
    for l in range(m):
        if d2buf[l] < dmin:
            dmin = d2buf[l]
            s_nn = l
    if rule == 3:
        # the nearest neighbour with its own likelihood: pt, pf / V_G of the mixture
        # weight P_D N(z; h(x), R) + lambda (1 - P_D (1 - exp(-d^2 / 2)))
        delta, beta = nn_existence_kernel(d2buf[s_nn], ndens[s_nn], pd, lam_z)
        miss = lam_z * (1.0 - pd * (1.0 - math.exp(-0.5 * d2buf[s_nn])))
        return m, vidx[s_nn], beta, delta, pd, miss * VG, VG, s_nn, s_h, s_nn
    if rule == 4:
        # IPDA: every gated return; z^s is the one of the largest beta (the nearest)
        sum_n = 0.0
        for l in range(m):
            sum_n += ndens[l]
        delta = ipda_existence_kernel(sum_n, pd, pg, lam_z)
        beta = pd * ndens[s_nn] / lam_z / (1.0 - delta)
        return (m, vidx[s_nn], beta, delta, pd, lam_z * (1.0 - pdpg) * VG, VG, s_nn, s_h,
                s_nn)
    if rule == 0:
        s = s_h
    elif rule == 1:
        s = 0
    else:
        s = s_nn
    fT = ndens[s] / pg
    num = fT * pt[s]
    beta = num / (num + pf[s] / VG)
    # q(s, m) from P(M_T^s | m) = pdpg m q / ((1 - pdpg) lambda V_G + pdpg m)
    q_s = pt[s] * ((1.0 - pdpg) * clutter_mean + pdpg * m) / (pdpg * m)
    delta = hpda_existence_delta_kernel(m, q_s, pd, pg, lam_z, VG, ndens[s])
    return m, vidx[s], beta, delta, pt[s], pf[s], VG, s, s_h, s_nn


@nb.njit(cache=True)
def _count_selection(diag, row, m, s_h, s_nn, lam_vg):
    diag[row, 0] += 1.0
    diag[row, 5] += lam_vg
    if m >= 1:
        diag[row, 1] += 1.0
    if m >= 2:
        diag[row, 2] += 1.0
        if s_h != s_nn:
            diag[row, 3] += 1.0
        if s_h != 0:
            diag[row, 4] += 1.0


@nb.njit(cache=True)
def _gather_in_place(X, modes, idx, n, scratch, mscratch):
    """Rows ``idx[:n]`` of the particles ``X`` (4 columns) and their ``modes`` become
    rows ``0..n-1``, through the work arrays ``scratch`` and ``mscratch``."""
    for i in range(n):
        j = idx[i]
        for a in range(4):
            scratch[i, a] = X[j, a]
        mscratch[i] = modes[j]
    for i in range(n):
        for a in range(4):
            X[i, a] = scratch[i, a]
        modes[i] = mscratch[i]


@nb.njit(cache=True)
def _resample_log_weights(X, modes, logw, scratch, mscratch, idx, rng):
    """Systematic resampling in place of the ``N = len(X)`` particles with log weights
    ``logw`` (overwritten by the weights scaled to a largest of 1; one ``rng.random()``)."""
    N = X.shape[0]
    mx = -np.inf
    for i in range(N):
        if logw[i] > mx:
            mx = logw[i]
    for i in range(N):
        logw[i] = math.exp(logw[i] - mx)
    systematic_indices_kernel(logw, rng.random(), idx)
    _gather_in_place(X, modes, idx, N, scratch, mscratch)


@nb.njit(cache=True)
def _weight_resample(X, modes, rng_, brg, z, Rinv, logdetR, log_pt, log_pf_vg, logw, scratch,
                     mscratch, idx, rng):
    """Eq (13) weights for ``z^s`` (``hpda_mixture_loglik_kernel``'s, from the particles'
    ranges ``rng_`` and bearings ``brg`` seen from the origin), then systematic
    resampling in place (one ``rng.random()``)."""
    c0 = -1.8378770664093453 - 0.5 * logdetR
    for i in range(X.shape[0]):
        logw[i] = _mixture_loglik_polar(rng_[i], brg[i], z, Rinv, c0, log_pt, log_pf_vg)
    _resample_log_weights(X, modes, logw, scratch, mscratch, idx, rng)


@nb.njit(cache=True)
def _ipda_log_term(Zs, j, rr, bb, Rinv, shift):
    """``shift - d^2 / 2`` for return ``Zs[j]`` against range ``rr`` and bearing ``bb``
    (``d^2`` its squared Mahalanobis distance under ``Rinv``, bearing wrapped)."""
    r0 = Zs[j, 0] - rr
    r1 = _wrap_near(Zs[j, 1] - bb)
    return shift - 0.5 * (Rinv[0, 0] * r0 * r0 + 2.0 * Rinv[0, 1] * r0 * r1
                          + Rinv[1, 1] * r1 * r1)


@nb.njit(cache=True)
def _ipda_weight_resample(X, modes, rng_, brg, Zs, vidx, m, Rinv, logdetR, log_pd,
                          log_clutter, logw, terms, scratch, mscratch, idx, rng):
    """IPDA's particle weights ``lambda (1 - P_D P_G) + P_D sum_j N(z_j; h(x_i), R)``
    over the ``m`` gated returns ``Zs[vidx[:m]]`` (``log_clutter`` the log of the first
    term; ``rng_``, ``brg`` the particles' ranges and bearings, ``terms`` a work array
    of length >= m), then systematic resampling in place (one ``rng.random()``)."""
    N = X.shape[0]
    c0 = -1.8378770664093453 - 0.5 * logdetR
    for i in range(N):
        rr = rng_[i]
        bb = brg[i]
        hi = log_clutter
        for q in range(m):
            terms[q] = _ipda_log_term(Zs, vidx[q], rr, bb, Rinv, log_pd + c0)
            hi = max(hi, terms[q])
        acc = math.exp(log_clutter - hi)
        for q in range(m):
            acc += math.exp(terms[q] - hi)
        logw[i] = hi + math.log(acc)
    _resample_log_weights(X, modes, logw, scratch, mscratch, idx, rng)


@nb.njit(cache=True)
def _ipda_ekf_update(x, P, Zs, vidx, m, zhat, H, R, pd, pdpg, lam_z, ndens, zg, bet,
                     x_out, P_out, nu, S, K, work):
    """PDA update of a tentative track's EKF with every gated return (IPDA's weights
    ``beta_j = P_D N_j / (lambda L)``, ``beta_0 = (1 - P_D P_G) / L``; ``nu`` (2,),
    ``S`` (2, 2), ``K`` (4, 2) and ``work`` (``_pda_scratch(4, 2, m)``) work arrays)."""
    tot = 1.0 - pdpg
    for q in range(m):
        bet[q] = pd * ndens[q] / lam_z
        tot += bet[q]
        j = vidx[q]
        zg[q, 0] = Zs[j, 0]
        zg[q, 1] = Zs[j, 1]
    for q in range(m):
        bet[q] /= tot
    _pda_update_work(x, P, zg[:m], zhat, H, R, bet[:m], (1.0 - pdpg) / tot, 1, x_out,
                     P_out, nu, S, K, work)


@nb.njit(cache=True)
def _polar_init(r, b, R, vstd, x, P):
    """Cartesian state and covariance from one range-bearing measurement."""
    cb, sb = math.cos(b), math.sin(b)
    x[0] = r * cb
    x[1] = r * sb
    x[2] = 0.0
    x[3] = 0.0
    # J = d(x, y)/d(r, b)
    j00, j01, j10, j11 = cb, -r * sb, sb, r * cb
    for a in range(4):
        for c in range(4):
            P[a, c] = 0.0
    P[0, 0] = j00 * j00 * R[0, 0] + j01 * j01 * R[1, 1]
    P[0, 1] = j00 * j10 * R[0, 0] + j01 * j11 * R[1, 1]
    P[1, 0] = P[0, 1]
    P[1, 1] = j10 * j10 * R[0, 0] + j11 * j11 * R[1, 1]
    P[2, 2] = vstd * vstd
    P[3, 3] = vstd * vstd


@nb.njit(cache=True, inline="always")
def _ekf_moments(X1, P, R, zhat, S, H3):
    """Predicted range-bearing measurement, Jacobian (``H3[0]``) and
    innovation covariance ``S = H P H^T + R`` of the EKF state ``X1`` (1, 4)."""
    # range_bearing_kernel(X1, 0.0, 0.0, zhat.reshape((1, 2))) written out (no reshape)
    dx = X1[0, 0] - 0.0
    dy = X1[0, 1] - 0.0
    zhat[0] = math.sqrt(dx * dx + dy * dy)
    zhat[1] = math.atan2(dy, dx)
    range_bearing_jacobian_kernel(X1, 0.0, 0.0, H3)
    H = H3[0]
    for a in range(2):
        for b in range(2):
            s = R[a, b]
            for c in range(2):
                for d in range(2):
                    s += H[a, c] * P[c, d] * H[b, d]
            S[a, b] = s


@nb.njit(cache=True, inline="always")
def _cv_predict(x, P, T, Q, x_out, P_out):
    """Constant-velocity Kalman prediction ``x' = F x``, ``P' = F P F^T + Q`` for
    ``F = [[I, T I], [0, I]]``, written out (no temporaries) for the tentative
    tracks' inner loop."""
    x_out[0] = x[0] + T * x[2]
    x_out[1] = x[1] + T * x[3]
    x_out[2] = x[2]
    x_out[3] = x[3]
    for i in range(4):
        for j in range(i + 1):
            # (F P F^T)_ij with F = I + T E, E[0, 2] = E[1, 3] = 1
            v = P[i, j]
            if i < 2:
                v += T * P[i + 2, j]
            if j < 2:
                v += T * P[i, j + 2]
            if i < 2 and j < 2:
                v += T * T * P[i + 2, j + 2]
            v += 0.5 * (Q[i, j] + Q[j, i])
            P_out[i, j] = v
            P_out[j, i] = v


@nb.njit(cache=True, inline="always")
def _pda1_update(x, P, z, zhat, H, R, beta, x_out, P_out, K, A, W):
    """PDA update of an EKF (state (4,), measurement (2,)) with one validated
    measurement ``z`` of association probability ``beta`` (``beta_0 = 1 - beta``):
    ``x + K beta nu`` and ``beta_0 P + beta P_c + K beta (1 - beta) nu nu^T K^T``,
    ``P_c`` the Joseph-form updated covariance; bearing innovation wrapped.  The
    single-measurement case of :func:`trackcore.association.pda_update`, written out
    with the work arrays ``K`` (4, 2), ``A`` and ``W`` (4, 4) for the tentative tracks'
    inner loop (a unit test checks the two agree)."""
    # S = H P H^T + R and its inverse
    s00 = R[0, 0]
    s01 = R[0, 1]
    s11 = R[1, 1]
    for c in range(4):
        for d in range(4):
            pcd = P[c, d]
            s00 += H[0, c] * pcd * H[0, d]
            s01 += H[0, c] * pcd * H[1, d]
            s11 += H[1, c] * pcd * H[1, d]
    det = s00 * s11 - s01 * s01
    i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    # K = P H^T S^-1
    for i in range(4):
        p0 = 0.0
        p1 = 0.0
        for c in range(4):
            p0 += P[i, c] * H[0, c]
            p1 += P[i, c] * H[1, c]
        K[i, 0] = p0 * i00 + p1 * i01
        K[i, 1] = p0 * i01 + p1 * i11
    nu0 = z[0] - zhat[0]
    nu1 = wrap_angle_kernel(z[1] - zhat[1])
    for i in range(4):
        x_out[i] = x[i] + beta * (K[i, 0] * nu0 + K[i, 1] * nu1)
    # A = I - K H
    for i in range(4):
        for j in range(4):
            A[i, j] = (1.0 if i == j else 0.0) - K[i, 0] * H[0, j] - K[i, 1] * H[1, j]
    spread = beta * (1.0 - beta)
    # W[j, c] = (P A^T)_cj, the inner sums of the Joseph form
    for j in range(4):
        for c in range(4):
            apc = 0.0
            for d in range(4):
                apc += P[c, d] * A[j, d]
            W[j, c] = apc
    for i in range(4):
        kn_i = K[i, 0] * nu0 + K[i, 1] * nu1
        for j in range(i + 1):
            # Joseph form (A P A^T + K R K^T)_ij
            v = 0.0
            for c in range(4):
                v += A[i, c] * W[j, c]
            v += (K[i, 0] * (R[0, 0] * K[j, 0] + R[0, 1] * K[j, 1])
                  + K[i, 1] * (R[1, 0] * K[j, 0] + R[1, 1] * K[j, 1]))
            kn_j = K[j, 0] * nu0 + K[j, 1] * nu1
            val = (1.0 - beta) * P[i, j] + beta * v + spread * kn_i * kn_j
            P_out[i, j] = val
            P_out[j, i] = val


@nb.njit(cache=True)
def _hpda_run_kernel(Z, A, off, prm, cum_tpm, Q_t, R, rng,
                     out_count, out_est, out_id, out_n, out_aux, diag):
    (pd, pg, g2, c, lam_xy, T, sigma_a, a_m, p_conf, p_term, pi11, pi12, p0, p_del,
     vstd, rule_f, dup_f, yield_f) = (prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6],
                                      prm[7], prm[8], prm[9], prm[10], prm[11], prm[12],
                                      prm[13], prm[14], prm[15], prm[16], prm[17])
    rule = int(rule_f)
    dup_max = int(dup_f)
    K = off.shape[0] - 1
    NC, N = out_est.shape[1], int(prm[18])
    NT = int(prm[19])
    cX = np.zeros((NC, N, 4))
    cM = np.zeros((NC, N), dtype=np.int64)
    cp = np.zeros(NC)
    cact = np.zeros(NC, dtype=np.bool_)
    cid = np.full(NC, -1, dtype=np.int64)
    csel = np.full(NC, -1, dtype=np.int64)
    cdup = np.zeros(NC, dtype=np.int64)
    tx = np.zeros((NT, 4))
    tP = np.zeros((NT, 4, 4))
    tp = np.zeros(NT)
    tact = np.zeros(NT, dtype=np.bool_)
    next_id = 0
    Rinv = np.linalg.inv(R)
    logdetR = math.log(R[0, 0] * R[1, 1] - R[0, 1] * R[1, 0])
    scratch = np.zeros((N, 4))
    mscratch = np.zeros(N, dtype=np.int64)
    logw = np.zeros(N)
    ridx = np.zeros(N, dtype=np.int64)
    xb = np.zeros(4)
    Pb = np.zeros((4, 4))
    K_b = np.zeros((4, 2))
    A_b = np.zeros((4, 4))
    W_b = np.zeros((4, 4))
    zhat = np.zeros(2)
    S = np.zeros((2, 2))
    H3 = np.zeros((1, 2, 4))
    H = np.zeros((2, 4))
    xc = np.zeros(4)
    Pc = np.zeros((4, 4))
    xp = np.zeros(4)
    Pp = np.zeros((4, 4))
    x1 = np.zeros((1, 4))
    zsel = np.zeros(2)
    Lc = np.zeros((4, 4))
    mmax = 1
    for k in range(K):
        mmax = max(mmax, off[k + 1] - off[k])
    vidx = np.zeros(mmax, dtype=np.int64)
    d2buf = np.zeros(mmax)
    ndens = np.zeros(mmax)
    pt = np.zeros(mmax)
    pf = np.zeros(mmax)
    zgbuf = np.zeros((mmax, 2))
    betbuf = np.zeros(mmax)
    termbuf = np.zeros(mmax)
    # q_1 of the rank probabilities per number of gated returns (c is fixed for the run)
    q1cache = np.full(mmax + 1, -1.0)
    prng = np.zeros(N)
    pbrg = np.zeros(N)
    prel = np.zeros(N)
    nu_b = np.zeros(2)
    S_b = np.zeros((2, 2))
    pda_work = _pda_scratch(4, 2, mmax)
    thint = 0   # lowest tentative slot that may be free
    for k in range(K):
        Zs = Z[off[k]:off[k + 1]]
        As = A[off[k]:off[k + 1]]
        m_k = Zs.shape[0]
        border = np.argsort(Zs[:, 1])
        bsorted = np.empty(m_k)
        for q in range(m_k):
            bsorted[q] = Zs[border[q], 1]
        in_conf = np.zeros(m_k, dtype=np.bool_)
        selected = np.zeros(m_k, dtype=np.bool_)
        # ---- confirmed tracks
        for t in range(NC):
            if not cact[t]:
                continue
            X = cX[t]
            jump_markov_propagate_kernel(X, cM[t], cum_tpm, T, sigma_a, a_m, rng)
            ppred = pi11 * cp[t] + pi12 * (1.0 - cp[t])
            _particle_moments_polar(X, zhat, S, R, prng, pbrg, prel)
            m, js, beta, delta, pts, pfs, VG, s_u, s_h, s_nn = _gate_and_select(
                Zs, As, border, bsorted, zhat, S, g2, pd, pg, c, lam_xy, rule, vidx, d2buf,
                ndens, pt, pf, q1cache)
            _count_selection(diag, 0, m, s_h, s_nn, lam_xy * zhat[0] * VG)
            for l in range(m):
                in_conf[vidx[l]] = True
            den = 1.0 - delta * ppred
            cp[t] = 1.0 if den <= 0.0 else min(1.0, max(0.0, (1.0 - delta) * ppred / den))
            csel[t] = js
            if m > 0:
                lpt = math.log(pts) if pts > 0.0 else -np.inf
                lpf = math.log(pfs / VG) if pfs > 0.0 else -np.inf
                if rule == 4:
                    _ipda_weight_resample(X, cM[t], prng, pbrg, Zs, vidx, m, Rinv, logdetR,
                                          lpt, lpf, logw, termbuf, scratch, mscratch, ridx,
                                          rng)
                else:
                    _weight_resample(X, cM[t], prng, pbrg, Zs[js], Rinv, logdetR, lpt, lpf,
                                     logw, scratch, mscratch, ridx, rng)
        # duplicates and termination
        for t in range(NC):
            if not cact[t]:
                continue
            shared = False
            if csel[t] >= 0:
                for u in range(NC):
                    if u != t and cact[u] and csel[u] == csel[t]:
                        shared = True
            cdup[t] = cdup[t] + 1 if shared else 0
        for t in range(NC):
            if not cact[t]:
                continue
            if cp[t] < p_term:
                cact[t] = False
                continue
            if dup_max > 0 and cdup[t] >= dup_max:
                for u in range(NC):
                    if u != t and cact[u] and csel[u] == csel[t] and (
                            cp[u] > cp[t] or (cp[u] == cp[t] and cid[u] < cid[t])):
                        cact[t] = False
                        break
        # ---- tentative tracks
        for t in range(NT):
            if not tact[t]:
                continue
            # the track's state goes through work arrays (scalar copies): no array views
            # (each costs reference counting) in this loop over every tentative track
            for a in range(4):
                xc[a] = tx[t, a]
                for b in range(4):
                    Pc[a, b] = tP[t, a, b]
            _cv_predict(xc, Pc, T, Q_t, xp, Pp)
            for a in range(4):
                tx[t, a] = xp[a]
                x1[0, a] = xp[a]
                for b in range(4):
                    tP[t, a, b] = Pp[a, b]
            ppred = pi11 * tp[t] + pi12 * (1.0 - tp[t])
            _ekf_moments(x1, Pp, R, zhat, S, H3)
            for a in range(2):
                for b in range(4):
                    H[a, b] = H3[0, a, b]
            m, js, beta, delta, pts, pfs, VG, s_u, s_h, s_nn = _gate_and_select(
                Zs, As, border, bsorted, zhat, S, g2, pd, pg, c, lam_xy, rule, vidx, d2buf,
                ndens, pt, pf, q1cache)
            _count_selection(diag, 1, m, s_h, s_nn, lam_xy * zhat[0] * VG)
            den = 1.0 - delta * ppred
            tp[t] = 1.0 if den <= 0.0 else min(1.0, max(0.0, (1.0 - delta) * ppred / den))
            if m > 0:
                owned = False
                if yield_f > 0.5:
                    for u in range(NC):
                        if cact[u] and csel[u] == js:
                            owned = True
                if owned:
                    tact[t] = False
                    thint = min(thint, t)
                    continue
                selected[js] = True
                if rule == 4:
                    _ipda_ekf_update(xp, Pp, Zs, vidx, m, zhat, H, R, pd, pd * pg,
                                     lam_xy * zhat[0], ndens, zgbuf, betbuf, xb, Pb, nu_b,
                                     S_b, K_b, pda_work)
                else:
                    # single-measurement PDA update of the EKF with beta^s
                    zsel[0] = Zs[js, 0]
                    zsel[1] = Zs[js, 1]
                    _pda1_update(xp, Pp, zsel, zhat, H, R, beta, xb, Pb, K_b, A_b, W_b)
                for a in range(4):
                    tx[t, a] = xb[a]
                    for b in range(4):
                        tP[t, a, b] = Pb[a, b]
            if tp[t] >= p_conf:
                slot = -1
                for u in range(NC):
                    if not cact[u]:
                        slot = u
                        break
                tact[t] = False
                thint = min(thint, t)
                if slot >= 0:
                    # sample the EKF posterior into N particles, all in CV mode
                    Pm = tP[t]
                    for a in range(4):
                        for b in range(4):
                            Lc[a, b] = 0.0
                    for a in range(4):
                        for b in range(a + 1):
                            s = Pm[a, b]
                            for e in range(b):
                                s -= Lc[a, e] * Lc[b, e]
                            if a == b:
                                if s <= 0.0:
                                    s = 1e-12
                                Lc[a, a] = math.sqrt(s)
                            else:
                                Lc[a, b] = s / Lc[b, b]
                    for i in range(N):
                        w0 = rng.standard_normal()
                        w1 = rng.standard_normal()
                        w2 = rng.standard_normal()
                        w3 = rng.standard_normal()
                        for a in range(4):
                            cX[slot, i, a] = (tx[t, a] + Lc[a, 0] * w0 + Lc[a, 1] * w1
                                              + Lc[a, 2] * w2 + Lc[a, 3] * w3)
                        cM[slot, i] = 0
                    cact[slot] = True
                    cp[slot] = tp[t]
                    cid[slot] = next_id
                    csel[slot] = js if m > 0 else -1
                    cdup[slot] = 0
                    next_id += 1
            elif tp[t] < p_del:
                tact[t] = False
                thint = min(thint, t)
        # ---- new candidates
        for j in range(m_k):
            if in_conf[j] or selected[j]:
                continue
            while thint < NT and tact[thint]:
                thint += 1
            if thint >= NT:
                diag[1, 6] += 1.0
                continue
            slot = thint
            thint += 1
            _polar_init(Zs[j, 0], Zs[j, 1], R, vstd, tx[slot], tP[slot])
            tp[slot] = p0
            tact[slot] = True
        # ---- output
        n = 0
        for t in range(NC):
            if cact[t]:
                X = cX[t]
                for a in range(4):
                    s = 0.0
                    for i in range(N):
                        s += X[i, a]
                    out_est[k, n, a] = s / N
                out_id[k, n] = cid[t]
                n += 1
        out_n[k] = n
        out_count[k] = n
        nt = 0
        for t in range(NT):
            if tact[t]:
                nt += 1
        out_aux[k] = nt


@nb.njit(cache=True)
def _clutter_lr_kernel(rule, clutter_mean, pd, pg, g2, c, tau, n, rng, out):
    r0, sr, sb = 1000.0, 1.0, 1e-3
    S = np.array([[sr * sr, 0.0], [0.0, sb * sb]])
    zhat = np.array([r0, 0.0])
    VG = math.pi * g2 * sr * sb
    lam_xy = clutter_mean / (VG * r0)
    mcap = 16
    while mcap < 8 * clutter_mean + 64:
        mcap *= 2
    Zs = np.zeros((mcap, 2))
    As = np.zeros(mcap)
    vidx = np.zeros(mcap, dtype=np.int64)
    d2buf = np.zeros(mcap)
    ndens = np.zeros(mcap)
    pt = np.zeros(mcap)
    pf = np.zeros(mcap)
    q1cache = np.full(mcap + 1, -1.0)
    for i in range(n):
        m = min(rng.poisson(clutter_mean), mcap)
        for j in range(m):
            rad = math.sqrt(g2 * rng.random() * (1.0 - 1e-9))
            phi = 2.0 * math.pi * rng.random()
            Zs[j, 0] = r0 + sr * rad * math.cos(phi)
            Zs[j, 1] = sb * rad * math.sin(phi)
            As[j] = tau + rng.exponential(1.0)
        border = np.argsort(Zs[:m, 1])
        bsorted = np.empty(m)
        for q in range(m):
            bsorted[q] = Zs[border[q], 1]
        res = _gate_and_select(Zs[:m], As[:m], border, bsorted, zhat, S, g2, pd, pg, c,
                               lam_xy, rule, vidx, d2buf, ndens, pt, pf, q1cache)
        out[i] = 1.0 - res[3]


def clutter_likelihood_ratios(selection, clutter_mean, snr, pd, gate_probability, n_draws,
                              rng):
    """The existence likelihood ratio ``1 - delta`` that HPDA-PF's rule ``selection``
    (a key of the selection rules: ``"hpda"``, ``"strongest"``, ``"nearest"`` with
    eq (19), ``"nn-likelihood"``, ``"ipda"``) computes in ``n_draws`` gates that hold
    clutter only: Poisson(``clutter_mean`` = lambda V_G) returns, uniform in the gate of
    probability ``gate_probability``, amplitudes ``tau + Exp(1)`` with
    ``tau = -(1 + snr) ln pd``.  It calls the tracker's own gating and selection code.
    A valid existence update has mean 1 here (its ratio is a likelihood ratio of the
    data it uses); returns the ``(n_draws,)`` ratios.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.trackers.hpda_pf import clutter_likelihood_ratios
    >>> rng = np.random.default_rng(0)
    >>> lr = clutter_likelihood_ratios("ipda", 1.0, 3.0, 0.9, 0.99, 20000, rng)
    >>> lr.shape, round(float(lr.mean()), 1)
    ((20000,), 1.0)
    """
    if not isinstance(selection, str) or selection not in _RULES:
        raise ValueError(f"selection must be one of {tuple(_RULES)}, got {selection!r}")
    lv = as_scalar(clutter_mean, "clutter_mean")
    if not 0.0 < lv <= 1e3:
        raise ValueError(f"clutter_mean must lie in (0, 1000], got {lv}")
    rho = as_scalar(snr, "snr")
    if rho < 0.0:
        raise ValueError(f"snr must be >= 0, got {rho}")
    pdv = as_scalar(pd, "pd")
    if not 0.0 < pdv < 1.0:
        raise ValueError(f"pd must lie in (0, 1), got {pdv}")
    pg = as_scalar(gate_probability, "gate_probability")
    if not 0.0 < pg < 1.0:
        raise ValueError(f"gate_probability must lie in (0, 1), got {pg}")
    if isinstance(n_draws, bool) or not isinstance(n_draws, (int, np.integer)):
        raise TypeError(f"n_draws must be an integer, got {n_draws!r}")
    if not 1 <= n_draws <= 10**8:
        raise ValueError(f"n_draws must lie in [1, 1e8], got {n_draws}")
    rng = as_rng(rng)
    out = np.empty(int(n_draws))
    _clutter_lr_kernel(_RULES[selection], lv, pdv, pg, gate_threshold(pg, 2),
                       1.0 / (1.0 + rho), -(1.0 + rho) * math.log(pdv), int(n_draws), rng,
                       out)
    return out


def hpda_pf_run(z, amplitude, offsets, config: HpdaPfConfig, rng) -> TrackerRun:
    """Run the HPDA-PF tracker over a whole run of scans.

    ``z`` ``(M, 2)`` range-bearing measurements of all scans concatenated,
    ``amplitude`` ``(M,)``, ``offsets`` ``(K + 1,)`` (scan ``k`` is rows
    ``offsets[k]:offsets[k+1]``; empty scans are valid).  Sensor at the
    origin.  Returns a :class:`TrackerRun` with the number of confirmed
    tracks per scan and their estimates (``aux``: number of tentative tracks;
    ``diagnostics``: how often the selection rules could and did differ).

    Examples
    --------
    >>> import numpy as np
    >>> from dataclasses import replace
    >>> from trackcore.scenarios import (hpda_parameters, hpda_tracker_configs, hpda_truth,
    ...                                  simulate_hpda_scans)
    >>> from trackcore.trackers.hpda_pf import hpda_pf_run
    >>> p = replace(hpda_parameters(1), n_scans=40)
    >>> scans = simulate_hpda_scans(hpda_truth(n_scans=40), p, np.random.default_rng(1))
    >>> cfg = hpda_tracker_configs(p)["hpda"]
    >>> run = hpda_pf_run(scans.z, scans.amplitude, scans.offsets, cfg, np.random.default_rng(2))
    >>> run.count.shape, int(run.count[-1]), int(hpda_truth(n_scans=40).alive[-1].sum())
    ((40,), 1, 1)
    """
    if not isinstance(config, HpdaPfConfig):
        raise TypeError(f"config must be HpdaPfConfig, got {type(config).__name__}")
    rng = as_rng(rng)
    Z, A, off = check_scans(z, amplitude, offsets)
    cfg = config
    cum = np.ascontiguousarray(np.cumsum(np.array(cfg.mode_tpm), axis=1))
    N = cfg.n_particles
    T = cfg.T
    G = np.array([[T * T / 2, 0], [0, T * T / 2], [T, 0], [0, T]])
    Q_t = np.ascontiguousarray(cfg.tentative_sigma_a ** 2 * G @ G.T)
    R = np.diag([cfg.sigma_r ** 2, cfg.sigma_theta ** 2])
    prm = np.array([cfg.pd, cfg.gate_probability, cfg.gate_threshold, 1.0 / (1.0 + cfg.snr),
                    cfg.clutter_density_xy, T, cfg.sigma_a, cfg.a_m, cfg.p_confirm,
                    cfg.p_terminate, cfg.pi11, cfg.pi12, cfg.p_initial, cfg.p_delete,
                    cfg.velocity_std, float(_RULES[cfg.selection]), float(cfg.duplicate_scans),
                    1.0 if cfg.tentative_yield else 0.0, float(N), float(cfg.max_tentative)])
    K = off.shape[0] - 1
    C = cfg.max_confirmed
    count = np.zeros(K, dtype=np.int64)
    est = np.full((K, C, 4), np.nan)
    ids = np.full((K, C), -1, dtype=np.int64)
    n_est = np.zeros(K, dtype=np.int64)
    aux = np.zeros(K)
    diag = np.zeros((2, len(SELECTION_DIAGNOSTICS)))
    _hpda_run_kernel(Z, A, off, prm, cum, Q_t, R, rng, count, est, ids, n_est, aux, diag)
    return TrackerRun(count, est, ids, n_est, aux, diag)
