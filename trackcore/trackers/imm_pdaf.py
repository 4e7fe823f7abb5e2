"""IMM-PDAF for one target in clutter, with the model sets of Yoon & Ko (sec. 4.3).

The model sets share one numba whole-run kernel:

* **Singer-IMM** (as Houles & Bar-Shalom 1989): constant velocity embedded in
  the 6-state ``[x, y, vx, vy, ax, ay]`` (acceleration forced to 0) plus two
  Singer models (``tau`` = 20 s / 5 s, ``sigma_m`` = 15 / 60 m/s^2).
* **CAR-IMM** (constant angle-rate, Dufour & Mariton): state ``[x, y, vx, vy]``,
  CV plus exact coordinated-turn models at ``omega = +-0.14`` rad/s
  (:func:`car_imm_model_set`); any set of known turn rates with
  :func:`ct_imm_model_set` (e.g. the scenario's true rates, a plausibility bound).
* **TOM-IMM** (the paper): target-oriented models ``[x, y, v_f, v_s]`` with
  lateral-velocity inputs ``u_j`` (``0, +70, -70`` m/s in the paper,
  :func:`tom_imm_model_set`; any inputs with :func:`tom_model_set`).  One TOM
  cycle at scan ``k`` (the chapter "TOM-IMM" of the book): heading ``phi`` from
  eq. (8) (``atan2`` of the chord of the combined position estimates at
  ``k - 2`` and ``k - 1``), mixing, ``v_s <- u_j`` in model ``j``'s mixed mean,
  prediction with ``Phi(phi)`` and ``Q_j(phi)``, PDA update, combination, then
  ``v_s <- 0`` in every model.  Two other headings are kept for ablations:
  ``heading="chord_literal"`` indexes eq. (8) literally (``Phi(k) =
  Phi(t_{k+1}, t_k)`` with the chord of ``k - 1`` and ``k - 2``, i.e. the
  chord one scan older than the default), and ``heading="velocity"`` takes the
  direction of the combined velocity estimate at ``k - 1``.  Two readings of
  what happens to the covariance, which the paper does not say, are kept as
  ablations too: ``reset_vs_variance`` zeroes the ``v_s`` row and column of
  every model's covariance along with the mean (``v_s = 0`` taken as exact),
  and ``rotate_covariance`` turns each model's velocity covariance into the
  frame of the new heading before mixing (the mean is re-pointed along the
  new heading, as the reset implies, in every reading).
* A single constant-velocity Kalman filter (:func:`cv_model_set`, one model).

One scan of the IMM-PDAF (Blom & Bar-Shalom 1988; Houles & Bar-Shalom 1989):
mixing with the Markov matrix; per-model prediction; chi-square gates per model
and the validated set = their union; per-model parametric PDA on the validated
set (``beta0 ∝ lambda (1 - P_D P_G)``, ``beta_j ∝ P_D N(nu_j; 0, S)``) with the
covariance-spread update; model likelihood ``log(lambda (1 - P_D P_G) +
P_D sum_j N(nu_j; 0, S))`` (common factors dropped); model probabilities in
log space; moment-matched combination.  Gating, PDA and Kalman prediction are
the kernels of :mod:`trackcore.association` and :mod:`trackcore.filters`.

Outputs are reported in Cartesian ``[x, y, vx, vy]`` whatever the model state.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from ..association.gating import gate_threshold, mahalanobis_gate_kernel
from ..association.pda import pda_betas_kernel, pda_update_kernel
from ..core.validation import (as_array, as_covariance, as_int, as_measurements,
                               as_nonnegative, as_offsets, as_positive, as_probabilities,
                               as_probability, as_scalar, as_square_matrix, as_vector)
from ..filters.imm import imm_combine_kernel, imm_mix_kernel, imm_mode_update_kernel
from ..filters.kalman import cholesky_lower_kernel, kf_predict_kernel
from ..models.motion import (coordinated_turn_transition, cv_process_noise, kron_axes,
                             singer_process_noise, singer_transition)
from ..models.tom import chord_heading_kernel, tom_process_noise_kernel, tom_transition_kernel

__all__ = [
    "TOM_HEADINGS",
    "IMMModelSet",
    "IMMPDAFResult",
    "markov_matrix",
    "singer_imm_model_set",
    "ct_imm_model_set",
    "car_imm_model_set",
    "cv_model_set",
    "tom_model_set",
    "tom_imm_model_set",
    "two_point_init",
    "pack_scans",
    "imm_pdaf_track",
    "imm_pdaf_track_packed",
]

_LOG_2PI = math.log(2.0 * math.pi)

#: Heading rules of the TOM cycle: ``"chord"`` (eq. 8 with the most recent
#: chord, the chapter's reading), ``"chord_literal"`` (eq. 8 indexed as printed
#: with ``Phi(k) = Phi(t_{k+1}, t_k)``: the chord one scan older) and
#: ``"velocity"`` (direction of the combined velocity estimate); the alternatives
#: the paper's sec. 3.1 names and rejects: ``"chord_mean2"`` and ``"chord_mean3"``
#: (circular mean of the last 2 or 3 chords), ``"smoothed"`` (exponential smoothing
#: of the chord headings, weight :data:`SMOOTH_ALPHA` on the newest) and
#: ``"heading_rate_kf"`` (a separate Kalman filter of heading and turn rate fed with
#: the chord headings, its heading extrapolated by one scan; see
#: :data:`HEADING_KF_SIGMAS`).
TOM_HEADINGS = ("chord", "chord_literal", "velocity", "chord_mean2", "chord_mean3",
                "smoothed", "heading_rate_kf")
#: Weight of the newest chord in the ``"smoothed"`` heading (mean age of the smoothed
#: chords: ``(1 - a) / a`` = 1 scan older than the newest chord).
SMOOTH_ALPHA = 0.5
#: ``"heading_rate_kf"``: standard deviation of a chord heading (rad; two estimates
#: about 400 m apart with about 14 m of lateral error each) and of the turn-rate
#: noise (rad/s^2, DWNA on the rate), and the prior standard deviation of the rate
#: (rad/s).
HEADING_KF_SIGMAS = (0.05, 0.05, 0.1)


def _stack3(x, name, r, n):
    a = as_array(x, name, ndim=3)
    if a.shape != (r, n, n):
        raise ValueError(f"{name} must have shape {(r, n, n)}, got {a.shape}")
    return a


def _vec(x, name, r, *, nonnegative=False):
    a = as_array(x, name, ndim=1)
    if a.shape != (r,):
        raise ValueError(f"{name} must have shape ({r},), got {a.shape}")
    if nonnegative and a.size and a.min() < 0:
        raise ValueError(f"{name} must be >= 0")
    return a


def _flag(x, name):
    if not isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(x).__name__}")
    return bool(x)


@dataclass(frozen=True, eq=False)
class IMMModelSet:
    """A set of ``r`` linear models for the IMM-PDAF (build it with the ``*_model_set``
    functions; every field is checked when the record is built, also by
    :func:`dataclasses.replace`).

    Attributes
    ----------
    name : str
        Display name, e.g. ``"TOM-IMM"``.
    labels : tuple of str
        One label per model.
    F, Q : ndarray, shape (r, n, n)
        Transition and process-noise covariance of each model (used as given when
        ``tom`` is false; recomputed every scan from the heading when it is true).
    H : ndarray, shape (2, n)
        Picks the position.
    transition : ndarray, shape (r, r)
        Markov matrix, ``transition[i, j] = P(model j at k | model i at k-1)``.
    mu0 : ndarray, shape (r,)
        Initial model probabilities.
    embed : ndarray, shape (n, 4)
        Maps a Cartesian ``[x, y, vx, vy]`` initial estimate into the model state
        (TOM: then rotated by the initial heading).
    init_var : ndarray, shape (n,)
        Added to the diagonal of the embedded initial covariance.
    out_index : ndarray of int, shape (4,)
        State entries of ``[x, y, vx, vy]`` (TOM: ``[x, y, v_f, v_s]``, rotated back).
    tom : bool
        Target-oriented models (``n = 4``) with the TOM cycle.
    T : float
        Sampling interval (s), ``> 0``.
    u, var_f, var_s : ndarray, shape (r,)
        TOM lateral inputs (m/s) and forward/lateral acceleration variances.
    cwna : bool
        TOM process noise of the continuous-white-noise form instead of DWNA.
    heading : str
        TOM heading rule, one of :data:`TOM_HEADINGS`.
    reset_vs_variance : bool
        TOM: also zero the ``v_s`` row and column of each model's covariance at the reset.
    rotate_covariance : bool
        TOM: rotate each model's velocity covariance into the new heading's frame.
    reproject_velocity : bool
        TOM (needs ``rotate_covariance``): turn each model's velocity mean into the new
        heading's frame as well and keep ``v_s`` instead of resetting it (the
        re-projection reading of the frame change).
    vs_prior_var : float
        TOM: if positive, reset the ``v_s`` variance of each model to this prior
        ((m/s)^2, cross terms zeroed) at the reset; 0 keeps the covariance.

    The TOM-only fields (``u``, ``var_f``, ``var_s``, ``cwna``, ``heading``,
    ``reset_vs_variance``, ``rotate_covariance``, ``reproject_velocity``,
    ``vs_prior_var``) must keep their defaults (or zeros)
    when ``tom`` is false: a non-TOM model set would silently ignore them.

    Examples
    --------
    What the ``*_model_set`` functions build:

    >>> ms = car_imm_model_set()
    >>> ms.name, ms.labels
    ('CAR-IMM', ('CV', 'CT +0.14 rad/s', 'CT -0.14 rad/s'))
    >>> ms.F.shape, ms.transition.shape, ms.mu0
    ((3, 4, 4), (3, 3), array([0.8, 0.1, 0.1]))
    """

    name: str
    labels: tuple
    F: np.ndarray
    Q: np.ndarray
    H: np.ndarray
    transition: np.ndarray
    mu0: np.ndarray
    embed: np.ndarray
    init_var: np.ndarray
    out_index: np.ndarray
    tom: bool = False
    T: float = 1.0
    u: np.ndarray = None
    var_f: np.ndarray = None
    var_s: np.ndarray = None
    cwna: bool = False
    heading: str = "chord"
    reset_vs_variance: bool = False
    rotate_covariance: bool = False
    reproject_velocity: bool = False
    vs_prior_var: float = 0.0

    def __post_init__(self):
        def put(field, value):
            object.__setattr__(self, field, value)

        if not isinstance(self.name, str):
            raise TypeError(f"name must be a str, got {type(self.name).__name__}")
        F = as_array(self.F, "F", ndim=3)
        r, n = F.shape[0], F.shape[1]
        if r < 1 or F.shape[2] != n or n < 4:
            raise ValueError(f"F must have shape (r >= 1, n >= 4, n), got {F.shape}")
        labels = self.labels
        if isinstance(labels, str) or not hasattr(labels, "__len__") or len(labels) != r \
                or not all(isinstance(s, str) for s in labels):
            raise ValueError(f"labels must be {r} strings, one per model")
        put("labels", tuple(labels))
        put("F", F)
        Q = _stack3(self.Q, "Q", r, n)
        for j in range(r):
            as_covariance(Q[j], f"Q[{j}]", n)
        put("Q", Q)
        H = as_array(self.H, "H", ndim=2)
        if H.shape != (2, n):
            raise ValueError(f"H must have shape {(2, n)}, got {H.shape}")
        put("H", H)
        put("transition", _check_transition(self.transition, r))
        put("mu0", _check_mu0(self.mu0, r))
        embed = as_array(self.embed, "embed", ndim=2)
        if embed.shape != (n, 4):
            raise ValueError(f"embed must have shape {(n, 4)}, got {embed.shape}")
        put("embed", embed)
        put("init_var", _vec(self.init_var, "init_var", n, nonnegative=True))
        oi = np.asarray(self.out_index)
        if oi.shape != (4,) or not np.issubdtype(oi.dtype, np.integer):
            raise TypeError("out_index must be 4 integers")
        if oi.min() < 0 or oi.max() >= n:
            raise ValueError(f"out_index must index the {n} state entries")
        put("out_index", np.ascontiguousarray(oi, dtype=np.int64))
        tom = _flag(self.tom, "tom")
        if tom and n != 4:
            raise ValueError(f"tom=True needs the 4-state [x, y, v_f, v_s], got n = {n}")
        put("T", as_positive(self.T, "T"))
        zeros = np.zeros(r)
        put("u", zeros if self.u is None else _vec(self.u, "u", r))
        put("var_f", zeros if self.var_f is None else
            _vec(self.var_f, "var_f", r, nonnegative=True))
        put("var_s", zeros if self.var_s is None else
            _vec(self.var_s, "var_s", r, nonnegative=True))
        put("cwna", _flag(self.cwna, "cwna"))
        if self.heading not in TOM_HEADINGS:
            raise ValueError(f"heading must be one of {TOM_HEADINGS}, got {self.heading!r}")
        put("reset_vs_variance", _flag(self.reset_vs_variance, "reset_vs_variance"))
        put("rotate_covariance", _flag(self.rotate_covariance, "rotate_covariance"))
        put("reproject_velocity", _flag(self.reproject_velocity, "reproject_velocity"))
        if self.reproject_velocity and not self.rotate_covariance:
            raise ValueError("reproject_velocity needs rotate_covariance=True (the mean "
                             "and the covariance turn together)")
        put("vs_prior_var", float(as_nonnegative(self.vs_prior_var, "vs_prior_var")))
        if self.vs_prior_var > 0 and self.reset_vs_variance:
            raise ValueError("give reset_vs_variance or vs_prior_var, not both")
        if not tom:
            for field in ("u", "var_f", "var_s"):
                if np.any(getattr(self, field) != 0):
                    raise ValueError(f"{field} is a TOM parameter; it needs tom=True "
                                     f"(a non-TOM model set would ignore it)")
            for field, default in (("cwna", False), ("heading", "chord"),
                                   ("reset_vs_variance", False),
                                   ("rotate_covariance", False),
                                   ("reproject_velocity", False), ("vs_prior_var", 0.0)):
                if getattr(self, field) != default:
                    raise ValueError(f"{field} is a TOM option; it needs tom=True "
                                     f"(a non-TOM model set would ignore it)")

    @property
    def r(self) -> int:
        """Number of models."""
        return self.F.shape[0]


class IMMPDAFResult(NamedTuple):
    """Output of :func:`imm_pdaf_track` over ``K`` scans (Cartesian ``[x, y, vx, vy]``).

    Examples
    --------
    What :func:`imm_pdaf_track` returns over ``K`` scans (here 3):

    >>> scans = [np.array([[10.0, 0.0]]), np.array([[20.0, 0.0]]), np.array([[30.0, 0.0]])]
    >>> x0, P0 = two_point_init([-10.0, 0.0], [0.0, 0.0], np.eye(2))
    >>> res = imm_pdaf_track(car_imm_model_set(), scans, x0, P0, np.eye(2))
    >>> res.x.shape, res.P.shape, res.mu.shape, res.z_pred.shape, res.S.shape, res.gated.shape
    ((3, 4), (3, 4, 4), (3, 3), (3, 2), (3, 2, 2), (3,))
    """
    x: np.ndarray        # (K, 4) combined estimate
    P: np.ndarray        # (K, 4, 4) combined covariance
    mu: np.ndarray       # (K, r) posterior model probabilities
    z_pred: np.ndarray   # (K, 2) mixture predicted measurement (before the update)
    S: np.ndarray        # (K, 2, 2) mixture innovation covariance (before the update)
    gated: np.ndarray    # (N,) bool: measurement in the union of the model gates (packed rows)
    heading: np.ndarray  # (K,) heading used for the prediction (TOM; NaN otherwise)


# ---------------------------------------------------------------------- model sets
def markov_matrix(r, p_stay):
    """``r x r`` Markov matrix with ``p_stay`` on the diagonal and the rest spread evenly.

    ``r`` is a whole number of models (``>= 1``); ``p_stay`` a probability.

    Examples
    --------
    >>> markov_matrix(3, 0.9)
    array([[0.9 , 0.05, 0.05],
           [0.05, 0.9 , 0.05],
           [0.05, 0.05, 0.9 ]])
    >>> markov_matrix(1, 0.9)
    array([[1.]])
    """
    if isinstance(r, float) and not r.is_integer():
        raise ValueError(f"r must be a whole number of models, got {r}")
    r = as_int(r, "r", minimum=1)
    p = as_probability(p_stay, "p_stay")
    if r == 1:
        return np.ones((1, 1))
    M = np.full((r, r), (1.0 - p) / (r - 1))
    np.fill_diagonal(M, p)
    return M


def _check_transition(transition, r):
    Pi = as_square_matrix(transition, "transition", r)
    if Pi.min() < 0 or Pi.max() > 1:
        raise ValueError("transition must contain probabilities in [0, 1]")
    if not np.allclose(Pi.sum(axis=1), 1.0, atol=1e-12):
        raise ValueError("transition rows must sum to 1")
    return Pi


def _check_mu0(mu0, r):
    mu = as_probabilities(mu0, "mu0", shape=(r,))
    if abs(mu.sum() - 1.0) > 1e-12:
        raise ValueError(f"mu0 must sum to 1, got {mu.sum()!r}")
    return mu


def _default_mu0(r):
    """0.8 on the first (non-manoeuvring) model, the rest spread evenly."""
    if r == 1:
        return np.ones(1)
    return np.r_[0.8, np.full(r - 1, 0.2 / (r - 1))]


def _finish(name, labels, F, Q, H, transition, mu0, embed, init_var, out_index, **tom):
    r = F.shape[0]
    transition = markov_matrix(r, 0.9) if transition is None else transition
    mu0 = _default_mu0(r) if mu0 is None else mu0
    return IMMModelSet(name, tuple(labels), F, Q, H, transition, mu0, embed, init_var,
                       np.asarray(out_index, dtype=np.int64), **tom)


def _std(value, name):
    """A standard deviation: finite, >= 0 and at most 1e100 (its square stays a double)."""
    v = as_nonnegative(value, name)
    if not v <= 1e100:
        raise ValueError(f"{name} must be at most 1e100, got {v}")
    return v


def _position_H(n):
    H = np.zeros((2, n))
    H[0, 0] = H[1, 1] = 1.0
    return H


def singer_imm_model_set(T=1.0, tau=(20.0, 5.0), sigma_m=(15.0, 60.0), sigma_cv=1.0,
                         init_sigma_a=15.0, transition=None, mu0=(0.8, 0.1, 0.1)):
    """CV + Singer models on ``[x, y, vx, vy, ax, ay]`` (Houles & Bar-Shalom's set).

    The CV model has ``Phi_aa = 0``, DWNA velocity noise ``sigma_cv`` (m/s^2) and
    ``Q_aa = 1e-6``; each Singer model uses the exact transition and process
    noise for ``tau[i]`` (s) and ``sigma_m[i]`` (m/s^2).  The initial
    acceleration is 0 with standard deviation ``init_sigma_a``.
    ``transition`` defaults to ``markov_matrix(r, 0.9)``.

    Examples
    --------
    >>> ms = singer_imm_model_set()
    >>> ms.labels, ms.F.shape
    (('CV', 'Singer τ = 20 s', 'Singer τ = 5 s'), (3, 6, 6))
    """
    T = as_positive(T, "T")
    tau = as_array(tau, "tau", ndim=1)
    sigma_m = as_array(sigma_m, "sigma_m", shape=(tau.size,))
    if tau.size == 0 or tau.min() <= 0:
        raise ValueError("tau must hold positive time constants")
    if sigma_m.min() < 0:
        raise ValueError("sigma_m must be >= 0")
    sigma_cv = _std(sigma_cv, "sigma_cv")
    init_sigma_a = _std(init_sigma_a, "init_sigma_a")
    r = tau.size + 1
    F = np.zeros((r, 6, 6))
    Q = np.zeros((r, 6, 6))
    cv = np.array([[1.0, T, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    F[0] = kron_axes(cv, 2)
    Q[0, :4, :4] = cv_process_noise(T, sigma_cv**2, dim=2, kind="dwna")
    Q[0, 4, 4] = Q[0, 5, 5] = 1e-6
    labels = ["CV"]
    for i in range(tau.size):
        F[i + 1] = kron_axes(singer_transition(T, tau[i]), 2)
        Q[i + 1] = kron_axes(singer_process_noise(T, tau[i], sigma_m[i]), 2)
        labels.append(f"Singer τ = {tau[i]:g} s")
    embed = np.zeros((6, 4))
    embed[:4, :4] = np.eye(4)
    init_var = np.r_[np.zeros(4), init_sigma_a**2, init_sigma_a**2]
    return _finish("Singer-IMM", labels, F, Q, _position_H(6), transition, mu0, embed,
                   init_var, [0, 1, 2, 3], T=T)


def ct_imm_model_set(omegas, sigmas, T=1.0, transition=None, mu0=None, name="CT-IMM"):
    """Coordinated-turn models at known rates ``omegas`` (rad/s, ``0`` = constant
    velocity, positive = counter-clockwise) on ``[x, y, vx, vy]``.

    ``sigmas`` (m/s^2, one per model) are the DWNA process-noise standard
    deviations.  ``transition`` defaults to ``markov_matrix(r, 0.9)`` and
    ``mu0`` to 0.8 on the first model with the rest spread evenly.

    Examples
    --------
    A constant-velocity model and turns at +-0.1 rad/s:

    >>> ms = ct_imm_model_set([0.0, 0.1, -0.1], [1.0, 5.0, 5.0])
    >>> ms.name, ms.mu0, ms.F.shape
    ('CT-IMM', array([0.8, 0.1, 0.1]), (3, 4, 4))
    >>> np.round(ms.F[1] @ [0.0, 0.0, 10.0, 0.0], 3)  # 1 s of left turn from 10 m/s along +x
    array([9.983, 0.5  , 9.95 , 0.998])
    """
    T = as_positive(T, "T")
    omegas = as_array(omegas, "omegas", ndim=1)
    if omegas.size == 0:
        raise ValueError("omegas must hold at least one turn rate")
    sigmas = as_array(sigmas, "sigmas", shape=(omegas.size,))
    if sigmas.min() < 0:
        raise ValueError("sigmas must be >= 0")
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__}")
    F = np.stack([coordinated_turn_transition(w, T) for w in omegas])
    Q = np.stack([cv_process_noise(T, s**2) for s in sigmas])
    labels = ["CV" if w == 0 else f"CT {w:+.4g} rad/s" for w in omegas]
    return _finish(name, labels, F, Q, _position_H(4), transition, mu0, np.eye(4),
                   np.zeros(4), [0, 1, 2, 3], T=T)


def car_imm_model_set(T=1.0, omega=0.14, sigma_cv=1.0, sigma_ct=8.0, transition=None,
                      mu0=(0.8, 0.1, 0.1)):
    """CV + coordinated-turn models at ``+-omega`` (rad/s) on ``[x, y, vx, vy]``.

    DWNA process noise: ``sigma_cv`` for CV and ``sigma_ct`` for the turn
    models (m/s^2).  Model order: CV, turn ``+omega`` (left), turn ``-omega``
    (right).

    Examples
    --------
    >>> ms = car_imm_model_set(omega=0.14)
    >>> ms.labels, np.round(ms.transition, 2)
    (('CV', 'CT +0.14 rad/s', 'CT -0.14 rad/s'), array([[0.9 , 0.05, 0.05],
           [0.05, 0.9 , 0.05],
           [0.05, 0.05, 0.9 ]]))
    """
    omega = as_scalar(omega, "omega")
    sigma_cv = _std(sigma_cv, "sigma_cv")
    sigma_ct = _std(sigma_ct, "sigma_ct")
    return ct_imm_model_set([0.0, omega, -omega], [sigma_cv, sigma_ct, sigma_ct], T=T,
                            transition=transition, mu0=mu0, name="CAR-IMM")


def cv_model_set(T=1.0, sigma=1.0):
    """One constant-velocity model (DWNA, ``sigma`` in m/s^2): run with ``pd = 1``,
    ``pg = 1`` and no clutter, the IMM-PDAF is then a plain Kalman filter.

    Examples
    --------
    With one model, no clutter and ``pd = 1`` the IMM-PDAF is a Kalman filter; a target
    moving at 10 m/s along +x is followed exactly:

    >>> scans = [np.array([[10.0 * k, 0.0]]) for k in range(1, 6)]
    >>> x0, P0 = two_point_init([-10.0, 0.0], [0.0, 0.0], np.eye(2))
    >>> res = imm_pdaf_track(cv_model_set(), scans, x0, P0, np.eye(2), pg=1.0, clutter_density=0.0)
    >>> np.round(res.x[-1], 3) + 0.0
    array([50.,  0., 10.,  0.])
    """
    sigma = as_nonnegative(sigma, "sigma")
    return ct_imm_model_set([0.0], [sigma], T=T, name="CV-KF")


def tom_model_set(u, sigma_s, sigma_f=1.0, T=1.0, transition=None, mu0=None, kind="dwna",
                  heading="chord", name="TOM-IMM", labels=None, reset_vs_variance=False,
                  rotate_covariance=False, reproject_velocity=False, vs_prior_var=0.0):
    """Target-oriented models with lateral inputs ``u`` (m/s, one per model; ``+`` is
    to the right of the heading) and lateral noises ``sigma_s`` (m/s^2, one per
    model).

    ``sigma_f`` (m/s^2, a scalar or one per model) is the forward noise; the
    process noise is :func:`trackcore.models.tom_process_noise` of ``kind``
    (``"dwna"`` or ``"cwna"``).  ``heading`` is one of :data:`TOM_HEADINGS`.
    ``transition`` defaults to ``markov_matrix(r, 0.9)`` and ``mu0`` to 0.8 on the
    first model with the rest spread evenly.  ``labels`` (one string per model)
    default to the inputs.  ``reset_vs_variance`` and ``rotate_covariance`` select
    the covariance readings of the cycle (see the module docstring; both off is
    the book's reading); ``reproject_velocity`` and ``vs_prior_var`` two more
    readings of the frame change (:class:`IMMModelSet`).

    Examples
    --------
    Two target-oriented models: straight and a 30 m/s lateral input to the right:

    >>> ms = tom_model_set([0.0, 30.0], [2.0, 10.0])
    >>> ms.tom, ms.labels, ms.u, ms.mu0
    (True, ('TOM u=0', 'TOM u=+30 (right)'), array([ 0., 30.]), array([0.8, 0.2]))
    """
    T = as_positive(T, "T")
    u = as_array(u, "u", ndim=1)
    if u.size == 0:
        raise ValueError("u must hold at least one lateral input")
    r = u.size
    sigma_s = as_array(sigma_s, "sigma_s", shape=(r,))
    sigma_f = as_array(sigma_f, "sigma_f", ndim=(0, 1))
    sigma_f = np.broadcast_to(sigma_f, (r,)).copy() if sigma_f.size in (1, r) else None
    if sigma_f is None:
        raise ValueError(f"sigma_f must be a scalar or hold {r} values")
    if sigma_s.min() < 0:
        raise ValueError("sigma_s must be >= 0")
    if sigma_f.min() < 0:
        raise ValueError("sigma_f must be >= 0")
    with np.errstate(over="ignore"):
        var_f, var_s = sigma_f * sigma_f, sigma_s * sigma_s
    for nm, v in (("sigma_f", var_f), ("sigma_s", var_s)):
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{nm} is too large: its square overflows")
    if kind not in ("dwna", "cwna"):
        raise ValueError(f"kind must be 'dwna' or 'cwna', got {kind!r}")
    if heading not in TOM_HEADINGS:
        raise ValueError(f"heading must be one of {TOM_HEADINGS}, got {heading!r}")
    if labels is None:
        labels = ["TOM u=0" if v == 0 else
                  f"TOM u={v:+g} ({'right' if v > 0 else 'left'})" for v in u]
    zeros = np.zeros((r, 4, 4))
    return _finish(name, labels, zeros, zeros.copy(), _position_H(4), transition, mu0,
                   np.eye(4), np.zeros(4), [0, 1, 2, 3], tom=True, T=T, u=u,
                   var_f=var_f, var_s=var_s, cwna=(kind == "cwna"),
                   heading=heading, reset_vs_variance=reset_vs_variance,
                   rotate_covariance=rotate_covariance,
                   reproject_velocity=reproject_velocity, vs_prior_var=vs_prior_var)


def tom_imm_model_set(T=1.0, u=70.0, sigma_f=1.0, sigma_s_centre=3.0, sigma_s_turn=20.0,
                      transition=None, mu0=(0.8, 0.1, 0.1), kind="dwna", heading="chord",
                      reset_vs_variance=False, rotate_covariance=False,
                      reproject_velocity=False, vs_prior_var=0.0):
    """The paper's three target-oriented models with lateral inputs ``0, +u, -u`` (m/s).

    ``+u`` is a right turn (``+v_s`` points right of the heading).  Process
    noise :func:`trackcore.models.tom_process_noise` of ``kind`` with
    ``sigma_f`` for all models and ``sigma_s_centre`` / ``sigma_s_turn`` for the
    lateral axis; ``heading`` is one of :data:`TOM_HEADINGS`;
    ``reset_vs_variance``, ``rotate_covariance``, ``reproject_velocity`` and
    ``vs_prior_var`` as in :func:`tom_model_set`.

    Examples
    --------
    The paper's set: lateral inputs 0, +70, -70 m/s:

    >>> ms = tom_imm_model_set()
    >>> ms.name, ms.tom, ms.u, ms.heading
    ('TOM-IMM', True, array([  0.,  70., -70.]), 'chord')
    """
    u = as_nonnegative(u, "u")
    sigma_f = _std(sigma_f, "sigma_f")
    sc = _std(sigma_s_centre, "sigma_s_centre")
    st = _std(sigma_s_turn, "sigma_s_turn")
    labels = ("TOM u=0", f"TOM u=+{u:g} (right)", f"TOM u=-{u:g} (left)")
    return tom_model_set([0.0, u, -u], [sc, st, st], sigma_f=sigma_f, T=T,
                         transition=transition, mu0=mu0, kind=kind, heading=heading,
                         labels=labels, reset_vs_variance=reset_vs_variance,
                         rotate_covariance=rotate_covariance,
                         reproject_velocity=reproject_velocity, vs_prior_var=vs_prior_var)


def two_point_init(z0, z1, R, T=1.0):
    """Two-point differencing: ``x = [z1, (z1 - z0)/T]`` with covariance
    ``[[R, R/T], [R/T, 2R/T^2]]`` (Bar-Shalom, Li & Kirubarajan 2001).

    Examples
    --------
    >>> x0, P0 = two_point_init([0.0, 0.0], [10.0, 5.0], np.eye(2) * 4.0, T=1.0)
    >>> x0
    array([10.,  5., 10.,  5.])
    >>> np.diag(P0)
    array([4., 4., 8., 8.])
    """
    z0 = as_vector(z0, "z0", 2)
    z1 = as_vector(z1, "z1", 2)
    R = as_covariance(R, "R", 2)
    T = as_positive(T, "T")
    if not 1e-100 <= T <= 1e100:
        raise ValueError(f"T must lie in [1e-100, 1e100] s (2 R / T**2 stays a double), got {T}")
    x = np.r_[z1, (z1 - z0) / T]
    P = np.block([[R, R / T], [R / T, 2.0 * R / T**2]])
    return x, P


def pack_scans(scans, d=2):
    """Pack a sequence of ``(m_k, d)`` scans into ``(z (N, d), offsets (K + 1,))``.

    Examples
    --------
    >>> scans = [np.array([[1.0, 2.0], [3.0, 4.0]]), np.zeros((0, 2)), np.array([[5.0, 6.0]])]
    >>> z, offsets = pack_scans(scans)
    >>> z
    array([[1., 2.],
           [3., 4.],
           [5., 6.]])
    >>> offsets  # scan k is z[offsets[k]:offsets[k + 1]]
    array([0, 2, 2, 3])
    """
    arrs = [as_measurements(s, f"scans[{k}]", d) for k, s in enumerate(scans)]
    offsets = np.zeros(len(arrs) + 1, dtype=np.int64)
    np.cumsum([a.shape[0] for a in arrs], out=offsets[1:])
    z = np.ascontiguousarray(np.concatenate(arrs, axis=0)) if arrs else np.zeros((0, d))
    return z, offsets


# ---------------------------------------------------------------------- kernels
@nb.njit(cache=True)
def imm_pdaf_run_kernel(z, offsets, x0, P0, F, Q, H, R, Pi, mu0, tom, T, u, var_f, var_s, cwna,
                        heading_mode, reset_var, rotate_cov, prev2, prev1, v0, phi0, out_index,
                        pd, pg, gamma, log_lam, xs, Ps, mus, zps, Ss, gated, headings):
    """Whole-run IMM-PDAF over the scans ``z[offsets[k]:offsets[k+1]]``.

    ``x0`` (n,), ``P0`` (n, n): the initial estimate in model coordinates
    (every model starts from it); ``prev2``/``prev1`` (2,): the combined
    positions at the two previous scans (TOM heading chord); ``v0`` (2,) the
    initial Cartesian velocity and ``phi0`` the initial heading.
    ``heading_mode``: 0 chord of the last two combined positions, 1 the chord
    one scan older (eq. 8 indexed literally; the first scan extrapolates the
    initial chord back, so it uses ``phi0``), 2 direction of the last combined
    velocity, 3 and 4 the circular mean of the last 2 and 3 chords, 5 the
    exponentially smoothed chord heading, 6 the heading-and-rate Kalman filter
    (:data:`TOM_HEADINGS`).  ``reset_var``: below 0 the reset keeps the covariance; 0 zeroes the ``v_s``
    row and column of each model's covariance; above 0 also sets the ``v_s`` variance to
    it.  ``rotate_cov``: 1 or 2, each model's covariance is turned
    into the frame of the new heading (``blkdiag(I, Rot(phi - phi_prev))``)
    before mixing (2: the velocity mean too, and ``v_s`` is not reset).  ``log_lam = log(lambda)`` (``-inf`` without clutter),
    ``gamma`` the gate threshold.  Outputs (preallocated): ``xs`` (K, 4),
    ``Ps`` (K, 4, 4), ``mus`` (K, r), ``zps`` (K, 2), ``Ss`` (K, 2, 2),
    ``gated`` (N,), ``headings`` (K,).  Returns -1, or the scan index at which
    an innovation covariance was not positive definite.
    """
    r, n = F.shape[0], F.shape[1]
    d = H.shape[0]
    K = offsets.shape[0] - 1
    X = np.empty((r, n))
    P = np.empty((r, n, n))
    for j in range(r):
        for a in range(n):
            X[j, a] = x0[a]
            for b in range(n):
                P[j, a, b] = P0[a, b]
    mu = mu0.copy()
    c = np.empty(r)
    X0 = np.empty((r, n))
    P0m = np.empty((r, n, n))
    Xp = np.empty((r, n))
    Pp = np.empty((r, n, n))
    Fk = F.copy()
    Qk = Q.copy()
    Zp = np.empty((r, d))
    Sm = np.empty((r, d, d))
    L = np.empty((r, d, d))
    halflogdet = np.empty(r)
    xc = np.empty(n)
    Pcm = np.empty((n, n))
    nu = np.empty(d)
    Sout = np.empty((d, d))
    Kg = np.empty((n, d))
    log_like = np.empty(r)
    logmu = np.empty(r)
    M = np.zeros((4, n))
    log_pd = math.log(pd) if pd > 0 else -np.inf
    miss = 1.0 - pd * pg
    log_miss = math.log(miss) if miss > 0 else -np.inf
    p2x, p2y, p1x, p1y = prev2[0], prev2[1], prev1[0], prev1[1]
    p3x, p3y = 2.0 * p2x - p1x, 2.0 * p2y - p1y
    p4x, p4y = 3.0 * p2x - 2.0 * p1x, 3.0 * p2y - 2.0 * p1y
    # heading filters (modes 5, 6): smoothed heading; heading, rate and covariance
    sm = phi0
    hf, hw = phi0, 0.0
    h00, h01, h11 = HEADING_KF_SIGMAS[0] ** 2, 0.0, HEADING_KF_SIGMAS[2] ** 2
    hq = HEADING_KF_SIGMAS[1] ** 2
    hr = HEADING_KF_SIGMAS[0] ** 2
    vcx, vcy = v0[0], v0[1]
    phi = phi0
    phi_frame = phi0  # the heading whose frame the model covariances are in
    B2 = np.empty((2, 2))
    tmp = np.empty((n, n))
    for k in range(K):
        lo, hi = offsets[k], offsets[k + 1]
        m = hi - lo
        zk = z[lo:hi]
        # 1. heading and the models of this scan (TOM)
        if tom:
            if heading_mode == 0:
                phi = chord_heading_kernel(p2x, p2y, p1x, p1y, phi, 1e-6)
            elif heading_mode == 1:
                phi = chord_heading_kernel(p3x, p3y, p2x, p2y, phi, 1e-6)
            elif heading_mode == 2:
                phi = chord_heading_kernel(0.0, 0.0, vcx, vcy, phi, 1e-6)
            else:
                c1 = chord_heading_kernel(p2x, p2y, p1x, p1y, phi, 1e-6)
                if heading_mode == 3 or heading_mode == 4:
                    c2 = chord_heading_kernel(p3x, p3y, p2x, p2y, phi, 1e-6)
                    cs = math.cos(c1) + math.cos(c2)
                    sn = math.sin(c1) + math.sin(c2)
                    if heading_mode == 4:
                        c3 = chord_heading_kernel(p4x, p4y, p3x, p3y, phi, 1e-6)
                        cs += math.cos(c3)
                        sn += math.sin(c3)
                    phi = math.atan2(sn, cs)
                elif heading_mode == 5:
                    dd = c1 - sm
                    sm += SMOOTH_ALPHA * math.atan2(math.sin(dd), math.cos(dd))
                    phi = sm
                else:
                    # predict heading and rate by one scan, update with the chord
                    hf += T * hw
                    t4 = hq * T * T
                    h00 += 2.0 * T * h01 + T * T * h11 + t4 * T * T / 4.0
                    h01 += T * h11 + t4 * T / 2.0
                    h11 += t4
                    dd = c1 - hf
                    dd = math.atan2(math.sin(dd), math.cos(dd))
                    sv = h00 + hr
                    g0, g1 = h00 / sv, h01 / sv
                    hf += g0 * dd
                    hw += g1 * dd
                    h11 -= g1 * h01
                    h01 -= g0 * h01
                    h00 -= g0 * h00
                    phi = hf + T * hw  # the chord describes k - 3/2; predict k - 1/2
            for j in range(r):
                tom_transition_kernel(phi, T, Fk[j])
                tom_process_noise_kernel(phi, T, var_f[j], var_s[j], cwna, Qk[j])
            headings[k] = phi
            if rotate_cov:
                dphi = phi - phi_frame
                cd = math.cos(dphi)
                sd = math.sin(dphi)
                B2[0, 0] = cd
                B2[0, 1] = -sd
                B2[1, 0] = sd
                B2[1, 1] = cd
                for j in range(r):
                    # P <- B P B^T with B = blkdiag(I, B2): rows 2..3, then columns 2..3
                    for a in range(n):
                        for b in range(n):
                            tmp[a, b] = P[j, a, b]
                    for b in range(n):
                        P[j, 2, b] = B2[0, 0] * tmp[2, b] + B2[0, 1] * tmp[3, b]
                        P[j, 3, b] = B2[1, 0] * tmp[2, b] + B2[1, 1] * tmp[3, b]
                    for a in range(n):
                        t2 = P[j, a, 2]
                        t3 = P[j, a, 3]
                        P[j, a, 2] = t2 * B2[0, 0] + t3 * B2[0, 1]
                        P[j, a, 3] = t2 * B2[1, 0] + t3 * B2[1, 1]
                    if rotate_cov == 2:  # re-project the velocity mean too
                        t2 = X[j, 2]
                        t3 = X[j, 3]
                        X[j, 2] = B2[0, 0] * t2 + B2[0, 1] * t3
                        X[j, 3] = B2[1, 0] * t2 + B2[1, 1] * t3
            phi_frame = phi
        else:
            headings[k] = np.nan
        # 2. mixing
        imm_mix_kernel(mu, Pi, X, P, X0, P0m, c)
        # 3. lateral input and prediction
        for j in range(r):
            if tom:
                X0[j, 3] = u[j]
            kf_predict_kernel(X0[j], P0m[j], Fk[j], Qk[j], Xp[j], Pp[j])
            for a in range(d):
                s = 0.0
                for b in range(n):
                    s += H[a, b] * Xp[j, b]
                Zp[j, a] = s
            for a in range(d):
                for b in range(d):
                    s = R[a, b]
                    for e in range(n):
                        for f in range(n):
                            s += H[a, e] * Pp[j, e, f] * H[b, f]
                    Sm[j, a, b] = s
            if not cholesky_lower_kernel(Sm[j], L[j]):
                return k
            hl = 0.0
            for a in range(d):
                hl += math.log(L[j, a, a])
            halflogdet[j] = hl
        # mixture predicted measurement (for NIS)
        for a in range(d):
            s = 0.0
            for j in range(r):
                s += c[j] * Zp[j, a]
            zps[k, a] = s
        for a in range(d):
            for b in range(d):
                s = 0.0
                for j in range(r):
                    s += c[j] * (Sm[j, a, b] + (Zp[j, a] - zps[k, a]) * (Zp[j, b] - zps[k, b]))
                Ss[k, a, b] = s
        # 4. gates: union over models
        mask = np.zeros(m, dtype=np.bool_)
        mj = np.empty(m, dtype=np.bool_)
        d2 = np.empty((r, m))
        for j in range(r):
            mahalanobis_gate_kernel(zk, Zp[j], L[j], gamma, -1, mj, d2[j])
            for i in range(m):
                if mj[i]:
                    mask[i] = True
        mv = 0
        for i in range(m):
            gated[lo + i] = mask[i]
            if mask[i]:
                mv += 1
        zv = np.empty((mv, d))
        idx = np.empty(mv, dtype=np.int64)
        t = 0
        for i in range(m):
            if mask[i]:
                idx[t] = i
                for a in range(d):
                    zv[t, a] = zk[i, a]
                t += 1
        # 5. PDA per model
        ll = np.empty(mv)
        betas = np.empty(mv)
        for j in range(r):
            for t in range(mv):
                ll[t] = -0.5 * (d * _LOG_2PI + d2[j, idx[t]]) - halflogdet[j]
            beta0, log_norm = pda_betas_kernel(ll, log_pd, log_miss, log_lam, betas)
            if math.isnan(beta0):  # all hypotheses impossible: keep the prediction
                beta0 = 1.0
                for t in range(mv):
                    betas[t] = 0.0
                log_norm = -np.inf
            log_like[j] = log_norm
            ok = pda_update_kernel(Xp[j], Pp[j], zv, Zp[j], H, R, betas, beta0, -1,
                                   X[j], P[j], nu, Sout, Kg)
            if not ok:
                return k
        # 6. model probabilities (log space)
        if imm_mode_update_kernel(c, log_like, logmu) == -np.inf:
            for j in range(r):  # no model explains the scan: keep the predicted ones
                mu[j] = c[j]
        else:
            for j in range(r):
                mu[j] = logmu[j]
        # 7. combination and Cartesian output
        imm_combine_kernel(mu, X, P, xc, Pcm)
        for a in range(4):
            for b in range(n):
                M[a, b] = 0.0
            M[a, out_index[a]] = 1.0
        if tom:
            cph = math.cos(phi)
            sph = math.sin(phi)
            M[2, 2] = cph
            M[2, 3] = sph
            M[3, 2] = sph
            M[3, 3] = -cph
        for a in range(4):
            s = 0.0
            for b in range(n):
                s += M[a, b] * xc[b]
            xs[k, a] = s
        for a in range(4):
            for b in range(a, 4):  # exactly symmetric output
                s = 0.0
                for e in range(n):
                    if M[a, e] == 0.0:
                        continue
                    for f in range(n):
                        s += M[a, e] * Pcm[e, f] * M[b, f]
                Ps[k, a, b] = s
                Ps[k, b, a] = s
        for j in range(r):
            mus[k, j] = mu[j]
        # 8. TOM: remember the combined position, reset v_s
        if tom:
            p4x, p4y = p3x, p3y
            p3x, p3y = p2x, p2y
            p2x, p2y = p1x, p1y
            p1x, p1y = xc[0], xc[1]
            vcx, vcy = xs[k, 2], xs[k, 3]
            for j in range(r):
                if rotate_cov != 2:
                    X[j, 3] = 0.0
                if reset_var >= 0.0:
                    for a in range(n):
                        P[j, 3, a] = 0.0
                        P[j, a, 3] = 0.0
                    P[j, 3, 3] = reset_var
    return -1


def _reset_code(models):
    """The kernel's ``reset_var``: -1 keeps the covariance at the reset, 0 zeroes the
    ``v_s`` row and column, a positive value resets the ``v_s`` variance to it."""
    if models.reset_vs_variance:
        return 0.0
    return models.vs_prior_var if models.vs_prior_var > 0 else -1.0


def _rotate_code(models):
    """The kernel's ``rotate_cov``: 0 none, 1 the covariance, 2 covariance and mean."""
    return 2 if models.reproject_velocity else int(models.rotate_covariance)


# ---------------------------------------------------------------------- public
def imm_pdaf_track_packed(models, z, offsets, x0, P0, R, *, pd=1.0, pg=0.99,
                          clutter_density=2e-6, prev_position=None):
    """IMM-PDAF over packed scans (see :func:`pack_scans`); returns :class:`IMMPDAFResult`.

    ``x0``, ``P0``: Cartesian initial estimate ``[x, y, vx, vy]`` at the time
    before the first scan (e.g. :func:`two_point_init`).  ``R`` (2, 2):
    measurement covariance.  ``pd`` = P_D, ``pg`` = P_G (the gate is the
    ``pg`` chi-square quantile, ``pg = 1`` disables gating: every measurement is
    validated and ``P_G = 1``); ``clutter_density`` = lambda (m^-2, 0 for no
    clutter), the parametric clutter density (so ``pg = 1`` needs no gate volume).  For the TOM the
    heading chord starts from ``prev_position`` (default ``x0[:2] - T v0``,
    which for a two-point initialisation is the first measurement) and
    ``x0[:2]``; the initial velocity ``x0[2:]`` must not be zero, because its
    direction is the initial heading of the target-oriented frame.

    Examples
    --------
    The same track as :func:`imm_pdaf_track` on packed scans:

    >>> z, offsets = pack_scans([np.array([[10.0 * k, 0.0]]) for k in range(1, 6)])
    >>> x0, P0 = two_point_init([-10.0, 0.0], [0.0, 0.0], np.eye(2))
    >>> res = imm_pdaf_track_packed(cv_model_set(), z, offsets, x0, P0, np.eye(2), pg=1.0,
    ...                             clutter_density=0.0)
    >>> np.round(res.x[-1], 3) + 0.0
    array([50.,  0., 10.,  0.])
    """
    if not isinstance(models, IMMModelSet):
        raise TypeError(f"models must be an IMMModelSet, got {type(models).__name__}")
    z = as_measurements(z, "z", 2)
    offsets = as_offsets(offsets, z.shape[0])
    x0 = as_vector(x0, "x0", 4)
    P0 = as_covariance(P0, "P0", 4)
    R = as_covariance(R, "R", 2, strict=True)
    pd = as_probability(pd, "pd")
    pg = as_probability(pg, "pg", open_low=True)
    lam = as_nonnegative(clutter_density, "clutter_density")
    gamma = gate_threshold(pg, 2)
    r = models.F.shape[0]
    xm = models.embed @ x0
    Pm = models.embed @ P0 @ models.embed.T + np.diag(models.init_var)
    phi0 = 0.0
    if models.tom:
        if x0[2] == 0.0 and x0[3] == 0.0:
            raise ValueError("x0 must have a non-zero velocity x0[2:] for a TOM model set: "
                             "it defines the initial heading of the target-oriented frame")
        phi0 = math.atan2(x0[3], x0[2])
        c, s = math.cos(phi0), math.sin(phi0)
        B = np.eye(4)
        B[2:, 2:] = [[c, s], [s, -c]]
        xm, Pm = B @ xm, B @ Pm @ B.T
    if prev_position is None:
        prev2 = x0[:2] - models.T * x0[2:]
    else:
        prev2 = as_vector(prev_position, "prev_position", 2)
    K = offsets.size - 1
    xs = np.empty((K, 4))
    Ps = np.empty((K, 4, 4))
    mus = np.empty((K, r))
    zps = np.empty((K, 2))
    Ss = np.empty((K, 2, 2))
    gated = np.zeros(z.shape[0], dtype=np.bool_)
    heads = np.empty(K)
    bad = imm_pdaf_run_kernel(z, offsets, np.ascontiguousarray(xm), np.ascontiguousarray(Pm),
                              models.F, models.Q, models.H, R, models.transition, models.mu0,
                              models.tom, models.T, models.u, models.var_f, models.var_s,
                              models.cwna, TOM_HEADINGS.index(models.heading),
                              _reset_code(models), _rotate_code(models),
                              np.ascontiguousarray(prev2), x0[:2].copy(), x0[2:].copy(), phi0,
                              models.out_index, pd, pg, float(gamma),
                              math.log(lam) if lam > 0 else -math.inf,
                              xs, Ps, mus, zps, Ss, gated, heads)
    if bad >= 0:
        raise ValueError(f"innovation covariance not positive definite at scan {bad}")
    return IMMPDAFResult(xs, Ps, mus, zps, Ss, gated, heads)


def imm_pdaf_track(models, scans, x0, P0, R, *, pd=1.0, pg=0.99, clutter_density=2e-6,
                   prev_position=None):
    """IMM-PDAF over a sequence of ``(m_k, 2)`` position scans (``m_k = 0`` allowed).

    See :func:`imm_pdaf_track_packed` for the arguments; ``gated`` in the
    result refers to the rows of the scans concatenated in order.

    Examples
    --------
    A target at 10 m/s along +x, with a clutter return in scan 3 and a missed scan 4; the
    CV/turn IMM keeps its probability on the CV model:

    >>> scans = [np.array([[10.0, 0.3]]), np.array([[20.0, -0.2]]),
    ...          np.array([[30.0, 0.1], [34.0, 6.0]]), np.zeros((0, 2)), np.array([[50.0, 0.2]])]
    >>> x0, P0 = two_point_init([-10.0, 0.0], [0.0, 0.0], np.eye(2))
    >>> res = imm_pdaf_track(car_imm_model_set(), scans, x0, P0, np.eye(2), pd=0.9,
    ...                      clutter_density=1e-3)
    >>> np.round(res.x[-1, :2], 1), np.round(res.mu[-1], 2)
    (array([50. ,  0.2]), array([0.97, 0.01, 0.01]))
    >>> res.gated  # every return validated, the clutter one too (the turn models' gates are wide)
    array([ True,  True,  True,  True,  True])
    """
    z, offsets = pack_scans(scans, 2)
    return imm_pdaf_track_packed(models, z, offsets, x0, P0, R, pd=pd, pg=pg,
                                 clutter_density=clutter_density, prev_position=prev_position)
