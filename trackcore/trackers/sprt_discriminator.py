"""Target-versus-decoy discrimination with hypothesis-matched EKFs and an SPRT.

Jeong & Hong (1996).  After the decoy (ACM) is released two tracks ``a`` and
``b`` exist.  H0: ``a`` is the target and ``b`` the ACM; H1: the reverse.  Each
hypothesis has a pair of matched filters:

=======  ==========  =====  ==================================================
filter   hypothesis  track  model
=======  ==========  =====  ==================================================
``a0``   H0          a      target EKF: relative Cartesian CV, (r, theta, rdot)
``b0``   H0          b      ACM EKF: modified polar [theta, 1/r], bearing only
``a1``   H1          a      ACM EKF
``b1``   H1          b      target EKF
=======  ==========  =====  ==================================================

Each filter accumulates its Gaussian innovation log-likelihood without the
``2 pi`` constant (eqs 22-25), ``Lambda_xj(k) = Lambda_xj(k-1) - (ln det V +
nu^T V^-1 nu)/2``, and ``Lambda = -Lambda_a0 - Lambda_b0 + Lambda_a1 +
Lambda_b1`` (eq 21) is the log-likelihood ratio ``ln p(Z|H1)/p(Z|H0)``.  Both
hypotheses use four scalar measurements per scan (three at the first scan),
so the ``2 pi`` terms cancel.

Scan convention: post-release scan ``k = 1`` is the first scan of the ACM
(paper eq 28).  The target filters both start from the prediction of the
single pre-release target track to that scan and contribute from ``k = 1``;
the ACM filters are initialised at ``k = 1`` from range and bearing (eq 28)
and contribute from ``k = 2``.

The target filters are the paper's constant-velocity EKF (``target_model="cv"``)
or one of two manoeuvre-tolerant alternatives that the paper does not use:

* ``"imm"``: a two-mode IMM after the release, the paper's CV mode and a CV mode
  whose white acceleration covers a turn at ``manoeuvre_accel``; its
  log-likelihood increment is the log of its predictive mixture density
  ``sum_j c_j N(nu_j; 0, S_j)``, so Lambda stays a ratio of predictive densities;
* ``"boost"``: the CV EKF whose process noise is raised to that of the
  manoeuvre mode for the predictions that start within ``boost_time`` seconds
  after the release (the moment a target that drops a decoy is likely to turn).

The ACM filters' inverse range ``beta = 1/r`` is free in the paper and may turn
negative (a point behind the pursuer).  ``beta_min`` (not in the paper) keeps it
at least ``beta_min`` by truncation: after the initialisation and after every
update, an estimate ``beta < beta_min`` is set to ``beta_min`` (the projection of
the mean onto the constraint in the inverse-range coordinate; the bearing and the
covariance are left as the update made them).

The EKFs are built from the foundation's Kalman and IMM kernels
(``trackcore.filters.kalman``, ``trackcore.filters.imm``) and the measurement
and transition models; a whole Monte Carlo batch runs in one numba kernel.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from ..core.logmath import LOG_2PI
from ..core.validation import as_array, as_positive
from ..filters.imm import imm_mix_kernel, imm_mode_update_kernel
from ..filters.kalman import kf_predict_kernel, kf_update_kernel
from ..models.measurement import (range_bearing_doppler_jacobian_kernel,
                                  range_bearing_doppler_kernel, wrap_angle_kernel)
from ..models.modified_polar import modified_polar_F_kernel, modified_polar_f_kernel
from ..models.motion import cv_process_noise, cv_transition

__all__ = [
    "SPRT_ACM_FILTERS",
    "SPRT_ACM_TARGET_MODELS",
    "SprtAcmFilterConfig",
    "SprtAcmDiscrimination",
    "sprt_acm_discriminate",
    "sprt_acm_llr",
]

SPRT_ACM_FILTERS = ("a0", "b0", "a1", "b1")
_Z_CAP = 1e9  # largest |measurement| or |own-ship state| accepted (m, rad, m/s)
SPRT_ACM_TARGET_MODELS = ("cv", "imm", "boost")


@dataclass(frozen=True)
class SprtAcmFilterConfig:
    """Parameters of the four matched filters (paper sec. IV.1 unless noted).

    Every field is checked when the record is built (``ValueError`` or
    ``TypeError`` naming the field); :meth:`replace` returns a checked copy.

    Attributes
    ----------
    sigma_r, sigma_theta, sigma_rdot : float
        Measurement noise std: range (m), bearing (rad), range rate (m/s).
    sigma_v : float
        Target filter: white-acceleration PSD ``sigma_v**2`` (m^2/s^3, eq 12).
    sigma_p : float
        ACM filter: drift-velocity PSD ``sigma_p**2`` (m^2/s, eqs 13-14).
    beta_std_factor : float
        ACM prior std of ``1/r`` is ``beta_std_factor / z_r(1)`` (eq 28 prints 2).
    beta_std_factor_a1 : float or None
        Diagnostic only (breaks the symmetry of the two hypotheses): the prior
        factor of the decoy filter ``a1`` alone, the one run on track ``a``;
        ``None`` (default) uses ``beta_std_factor`` for both decoy filters.
    init_pos_std, init_vel_std : float
        Target filter prior at the first pre-release scan (m, m/s; our choice).
    target_model : {"cv", "imm", "boost"}
        ``"cv"``: the paper's constant-velocity target EKF.  ``"imm"``: a two-mode
        IMM after the release (not in the paper): mode 1 is the CV model above,
        mode 2 a CV model with PSD ``manoeuvre_accel**2 * T``.  ``"boost"``: the
        CV EKF with that PSD for the predictions starting within ``boost_time``
        of the release (not in the paper).
    manoeuvre_accel : float
        IMM and boost: acceleration (m/s^2) that the manoeuvre model's white
        acceleration covers within one scan (PSD ``manoeuvre_accel**2 * T``, i.e.
        a velocity-change std of ``manoeuvre_accel * T`` per scan).
    boost_time : float
        Boost only: the predictions that start less than ``boost_time`` seconds
        after the release use the manoeuvre PSD (s, >= 0).
    p_stay_cv, p_stay_manoeuvre : float
        IMM only: probabilities of staying in each mode from one scan to the
        next.
    beta_min : float or None
        Sign constraint of the ACM filters (not in the paper): their inverse-range
        estimate is truncated at ``beta_min`` (1/m, > 0) after the initialisation
        and after every update (the bearing and the covariance unchanged);
        ``None`` (default, the paper) leaves it free.
    mu_release : float or None
        IMM only: probability of the manoeuvre mode at the release, in [0, 1];
        ``None`` (default) starts from the chain's stationary mode probabilities.
        A value near 1 tells the IMM that a target which drops a decoy is likely
        to turn then (the cue the boost uses).

    Examples
    --------
    >>> cfg = SprtAcmFilterConfig()
    >>> cfg.sigma_v, cfg.target_model
    (2.0, 'cv')
    >>> cfg.replace(target_model="imm").target_model
    'imm'
    >>> SprtAcmFilterConfig(target_model="ukf")
    Traceback (most recent call last):
        ...
    ValueError: target_model must be one of ('cv', 'imm', 'boost'), got 'ukf'
    """
    sigma_r: float = 5.0
    sigma_theta: float = 0.035
    sigma_rdot: float = 1.0
    sigma_v: float = 2.0
    sigma_p: float = 1.0
    beta_std_factor: float = 2.0
    init_pos_std: float = 100.0
    init_vel_std: float = 30.0
    target_model: str = "cv"
    manoeuvre_accel: float = 10.0
    p_stay_cv: float = 0.95
    p_stay_manoeuvre: float = 0.5
    boost_time: float = 2.0
    beta_std_factor_a1: float | None = None
    mu_release: float | None = None
    beta_min: float | None = None

    def __post_init__(self):
        for name in ("sigma_r", "sigma_theta", "sigma_rdot", "beta_std_factor",
                     "init_pos_std", "init_vel_std", "manoeuvre_accel"):
            _check_real(self, name, positive=True)
        for name in ("sigma_v", "sigma_p", "boost_time"):
            _check_real(self, name, positive=False)
        for name in ("p_stay_cv", "p_stay_manoeuvre"):
            v = _check_real(self, name, positive=True)
            if not v < 1.0:
                raise ValueError(f"{name} must lie in (0, 1), got {v}")
        if self.beta_std_factor_a1 is not None:
            _check_real(self, "beta_std_factor_a1", positive=True)
        if self.beta_min is not None:
            _check_real(self, "beta_min", positive=True)
        if self.mu_release is not None:
            v = _check_real(self, "mu_release", positive=False)
            if not v <= 1.0:
                raise ValueError(f"mu_release must lie in [0, 1], got {v}")
        if not isinstance(self.target_model, str):
            raise TypeError(f"target_model must be a string, got {type(self.target_model).__name__}")
        if self.target_model not in SPRT_ACM_TARGET_MODELS:
            raise ValueError(f"target_model must be one of {SPRT_ACM_TARGET_MODELS}, "
                             f"got {self.target_model!r}")

    def replace(self, **changes) -> "SprtAcmFilterConfig":
        """A copy with ``changes`` applied (checked like a new record)."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise TypeError(f"unknown SprtAcmFilterConfig field(s): {sorted(unknown)}")
        return dataclasses.replace(self, **changes)

    @property
    def manoeuvre_probability_at_release(self) -> float:
        """The IMM's manoeuvre-mode probability at the release: ``mu_release`` if set,
        else the stationary probability of the mode chain."""
        if self.mu_release is not None:
            return float(self.mu_release)
        a, b = 1.0 - self.p_stay_cv, 1.0 - self.p_stay_manoeuvre
        return a / (a + b)


def _check_real(record, name, positive):
    v = getattr(record, name)
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(v).__name__}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if v > 1e60:  # its square or fourth power enters covariances
        raise ValueError(f"{name} is out of range (at most 1e60), got {v}")
    if positive and not v > 0.0:
        raise ValueError(f"{name} must be > 0, got {v}")
    if not positive and not v >= 0.0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    return v


class SprtAcmDiscrimination(NamedTuple):
    """Matched-filter outputs over ``K`` post-release scans (batch axis first if batched).

    Attributes
    ----------
    lam : (..., K, 4)
        ``Lambda_a0, Lambda_b0, Lambda_a1, Lambda_b1`` (eqs 22-25).
    llr : (..., K)
        ``Lambda`` (eq 21).
    nis : (..., K, 4)
        NIS per filter (NaN where the filter has no innovation); for the IMM the
        predicted-mode-probability-weighted NIS of its modes.
    beta : (..., K, 2)
        Inverse-range estimates of the ACM filters ``b0``, ``a1`` (1/m).
    mu : (..., K, 2)
        Manoeuvre-mode probability of the target filters ``a0``, ``b1`` (IMM
        only; NaN for the CV filter).
    ok : (...,)
        False if an innovation covariance lost positive definiteness.

    Examples
    --------
    What :func:`sprt_acm_discriminate` returns, for one run of 16 post-release scans:

    >>> from trackcore.scenarios.sprt_acm import sprt_acm_scenario, sprt_acm_trial
    >>> out = sprt_acm_trial(np.random.default_rng(0), sprt_acm_scenario(1))
    >>> out.lam.shape, out.llr.shape, out.nis.shape, out.beta.shape, bool(out.ok)
    ((16, 4), (16,), (16, 4), (16, 2), True)
    """
    lam: np.ndarray
    llr: np.ndarray
    nis: np.ndarray
    beta: np.ndarray
    mu: np.ndarray
    ok: np.ndarray


@nb.njit(cache=True)
def _target_update(x, P, z, R, x_out, P_out):
    """EKF update of a relative Cartesian state with (r, theta, rdot); (loglik, nis, ok)."""
    X = x.reshape((1, 4))
    zp = np.empty((1, 3))
    H = np.zeros((1, 3, 4))
    if range_bearing_doppler_kernel(X, zp) >= 0:
        return 0.0, np.nan, False
    range_bearing_doppler_jacobian_kernel(X, H)
    Hk = H[0]
    # The foundation's linear update recomputes nu = z_eff - H x; passing
    # z_eff = nu + H x applies the EKF innovation nu = z - h(x) (bearing wrapped).
    zeff = np.empty(3)
    for i in range(3):
        nu = z[i] - zp[0, i]
        if i == 1:
            nu = wrap_angle_kernel(nu)
        s = nu
        for j in range(4):
            s += Hk[i, j] * x[j]
        zeff[i] = s
    innov = np.empty(3)
    S = np.empty((3, 3))
    K = np.empty((4, 3))
    nis, ll, ok = kf_update_kernel(x, P, zeff, Hk, R, x_out, P_out, innov, S, K)
    return ll, nis, ok


@nb.njit(cache=True)
def _acm_update(x, P, z_theta, R, x_out, P_out):
    """Bearing-only update of the modified-polar state (eq 16); (loglik, nis, ok)."""
    H = np.zeros((1, 2))
    H[0, 0] = 1.0
    zeff = np.empty(1)
    zeff[0] = x[0] + wrap_angle_kernel(z_theta - x[0])
    innov = np.empty(1)
    S = np.empty((1, 1))
    K = np.empty((2, 1))
    nis, ll, ok = kf_update_kernel(x, P, zeff, H, R, x_out, P_out, innov, S, K)
    return ll, nis, ok


@nb.njit(cache=True)
def _acm_predict(x, P, u1, u2, qT, x_out, P_out):
    """EKF prediction with f of eq (10), its Jacobian and Q of eq (14) at x; False if undefined."""
    F = np.empty((2, 2))
    if not modified_polar_F_kernel(x[0], x[1], u1, u2, F):
        return False
    b2 = x[1] * x[1]
    Q = np.zeros((2, 2))
    Q[0, 0] = qT * b2
    Q[1, 1] = qT * b2 * b2
    kf_predict_kernel(x, P, F, Q, x_out, P_out)   # covariance F P F^T + Q (mean replaced below)
    return modified_polar_f_kernel(x[0], x[1], u1, u2, x_out)


@nb.njit(cache=True)
def _target_predict(x, P, Phi, Qa, own_prev, own_cur, T, x_out, P_out):
    """Relative CV prediction x = Phi x - u_a (eqs 6, 8, 9) with u_a from the own-ship states."""
    kf_predict_kernel(x, P, Phi, Qa, x_out, P_out)
    for i in range(2):
        x_out[i] -= own_cur[i] - own_prev[i] - T * own_prev[2 + i]
        x_out[2 + i] -= own_cur[2 + i] - own_prev[2 + i]


@nb.njit(cache=True)
def _run_one(z_pre, z_a, z_b, own, T, Phi, Qa, Qs, PI, mu0, Qb, n_boost, Ra, Rb, P0, qT,
             beta_factors, sigma_theta, beta_min, lam, nis, beta, mu_out):
    """One Monte Carlo run; fills lam (K,4), nis (K,4), beta (K,2), mu_out (K,2); returns ok.

    ``Qs`` (r, 4, 4), ``PI`` (r, r) and ``mu0`` (r,) describe the target filters
    after the release: ``r = 1`` is the CV EKF, whose first ``n_boost``
    post-release predictions use ``Qb`` instead of ``Qs[0]``; ``r = 2`` the IMM.
    ``beta_factors`` (2,) are the prior factors of eq (28) for ``b0`` and ``a1``;
    ``beta_min`` truncates their inverse range from below (``-inf``: free).
    """
    n_pre = z_pre.shape[0]
    K = z_a.shape[0]
    r = Qs.shape[0]
    half_log2pi = 0.5 * LOG_2PI
    for k in range(K):
        for j in range(4):
            lam[k, j] = np.nan
            nis[k, j] = np.nan
        for j in range(2):
            beta[k, j] = np.nan
            mu_out[k, j] = np.nan
    # ---- pre-release target track: first measurement -> position, zero velocity
    x = np.zeros(4)
    P = P0.copy()
    x[0] = z_pre[0, 0] * math.cos(z_pre[0, 1])
    x[1] = z_pre[0, 0] * math.sin(z_pre[0, 1])
    xp = np.empty(4)
    Pp = np.empty((4, 4))
    for i in range(1, n_pre):
        _target_predict(x, P, Phi, Qa, own[i - 1], own[i], T, xp, Pp)
        ll, v, ok = _target_update(xp, Pp, z_pre[i], Ra, x, P)
        if not ok:
            return False
    # ---- release: both target filters start from the prediction to scan k = 1
    xt = np.empty((2, r, 4))   # a0, b1; one state per mode
    Pt = np.empty((2, r, 4, 4))
    mu = np.empty((2, r))
    x0s = np.empty((r, 4))
    P0s = np.empty((r, 4, 4))
    c_bar = np.empty(r)
    logliks = np.empty(r)
    nises = np.empty(r)
    mu_new = np.empty(r)
    xm = np.empty((2, 2))      # b0, a1
    Pm = np.empty((2, 2, 2))
    xmp = np.empty(2)
    Pmp = np.empty((2, 2))
    x1 = np.empty(4)           # the common prediction to k = 1
    P1 = np.empty((4, 4))
    _target_predict(x, P, Phi, Qa, own[n_pre - 1], own[n_pre], T, x1, P1)
    acc = np.zeros(4)          # Lambda_a0, Lambda_b0, Lambda_a1, Lambda_b1
    for k in range(K):
        j = n_pre + k
        # target filters: a0 on track a, b1 on track b (slot 0 -> a0, slot 1 -> b1)
        for s in range(2):
            z = z_a[k] if s == 0 else z_b[k]
            col = 0 if s == 0 else 3
            if k == 0:
                # every mode starts from the one pre-release prediction
                for m in range(r):
                    ll, v, ok = _target_update(x1, P1, z, Ra, xt[s, m], Pt[s, m])
                    if not ok:
                        return False
                    mu[s, m] = mu0[m]
                total = ll
            elif r == 1:
                Q = Qb if k <= n_boost else Qs[0]
                _target_predict(xt[s, 0], Pt[s, 0], Phi, Q, own[j - 1], own[j], T, xp, Pp)
                ll, v, ok = _target_update(xp, Pp, z, Ra, xt[s, 0], Pt[s, 0])
                if not ok:
                    return False
                total = ll
            else:
                imm_mix_kernel(mu[s], PI, xt[s], Pt[s], x0s, P0s, c_bar)
                for m in range(r):
                    _target_predict(x0s[m], P0s[m], Phi, Qs[m], own[j - 1], own[j], T,
                                    xp, Pp)
                    ll, nises[m], ok = _target_update(xp, Pp, z, Ra, xt[s, m], Pt[s, m])
                    if not ok:
                        return False
                    logliks[m] = ll
                total = imm_mode_update_kernel(c_bar, logliks, mu_new)
                if total == -np.inf:
                    return False
                v = 0.0
                for m in range(r):
                    mu[s, m] = mu_new[m]
                    v += c_bar[m] * nises[m]
            acc[col] += total + 3.0 * half_log2pi
            nis[k, col] = v
            if r > 1:
                mu_out[k, s] = mu[s, r - 1]
        # ACM filters: b0 on track b (slot 0), a1 on track a (slot 1)
        for s in range(2):
            z = z_b[k] if s == 0 else z_a[k]
            col = 1 if s == 0 else 2
            if k == 0:     # eq (28)
                xm[s, 0] = z[1]
                xm[s, 1] = 1.0 / z[0]
                Pm[s, 0, 0] = sigma_theta * sigma_theta
                Pm[s, 0, 1] = 0.0
                Pm[s, 1, 0] = 0.0
                sb = beta_factors[s] / z[0]
                Pm[s, 1, 1] = sb * sb
            else:
                u1 = own[j, 0] - own[j - 1, 0]
                u2 = own[j, 1] - own[j - 1, 1]
                if not _acm_predict(xm[s], Pm[s], u1, u2, qT, xmp, Pmp):
                    return False
                ll, v, ok = _acm_update(xmp, Pmp, z[1], Rb, xm[s], Pm[s])
                if not ok:
                    return False
                acc[col] += ll + half_log2pi
                nis[k, col] = v
            if xm[s, 1] < beta_min:     # the sign constraint (truncation of 1/r)
                xm[s, 1] = beta_min
            beta[k, s] = xm[s, 1]
        for c in range(4):
            lam[k, c] = acc[c]
    return True


@nb.njit(cache=True)
def sprt_acm_discriminate_kernel(z_pre, z_a, z_b, own, T, Phi, Qa, Qs, PI, mu0, Qb, n_boost,
                                 Ra, Rb, P0, qT, beta_factors, sigma_theta, beta_min, lam,
                                 nis, beta, mu, ok):
    """Batch kernel: ``z_pre`` (N, n_pre, 3), ``z_a``/``z_b`` (N, K, 3), ``own`` (n_pre+K, 4).

    Outputs ``lam``/``nis`` (N, K, 4), ``beta``/``mu`` (N, K, 2), ``ok`` (N,) bool.
    Filter parameters: CV ``Phi``/``Qa`` (4, 4) before the release, the target
    filters' modes after it ``Qs`` (r, 4, 4) with ``PI`` (r, r) and ``mu0`` (r,),
    the boosted ``Qb`` (4, 4) of the first ``n_boost`` post-release predictions,
    ``Ra`` (3, 3), ``Rb`` (1, 1), target prior ``P0`` (4, 4), ``qT = sigma_p^2 T``,
    ACM prior factors ``beta_factors`` (2,) of ``b0`` and ``a1``, ``sigma_theta`` and the
    lower bound ``beta_min`` of their inverse range (``-inf``: free).
    Assumes valid input
    (checked by :func:`sprt_acm_discriminate`).
    """
    for n in range(z_a.shape[0]):
        ok[n] = _run_one(z_pre[n], z_a[n], z_b[n], own, T, Phi, Qa, Qs, PI, mu0, Qb, n_boost,
                         Ra, Rb, P0, qT, beta_factors, sigma_theta, beta_min, lam[n], nis[n],
                         beta[n], mu[n])


def sprt_acm_llr(lam):
    """Lambda of eq (21) from ``lam[..., :] = [Lambda_a0, Lambda_b0, Lambda_a1, Lambda_b1]``.

    Examples
    --------
    ``Lambda = -Lambda_a0 - Lambda_b0 + Lambda_a1 + Lambda_b1``:

    >>> sprt_acm_llr([[1.0, 2.0, 0.5, 0.5], [0.0, 0.0, 1.0, 2.0]])
    array([-2.,  3.])
    >>> sprt_acm_llr([1.0, 2.0, 3.0])
    Traceback (most recent call last):
        ...
    ValueError: lam must have last dimension 4 (a0, b0, a1, b1), got shape (3,)
    """
    L = as_array(lam, "lam", finite=False)
    if L.ndim < 1 or L.shape[-1] != 4:
        raise ValueError(f"lam must have last dimension 4 (a0, b0, a1, b1), got shape {L.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        out = -L[..., 0] - L[..., 1] + L[..., 2] + L[..., 3]
    if np.any(np.isfinite(L).all(axis=-1) & ~np.isfinite(out)):
        raise ValueError("lam out of range: the sum of eq (21) overflows")
    if np.any(np.isnan(out) & ~np.isnan(L).any(axis=-1)):
        # (a row with NaN, a failed run, stays NaN)
        raise ValueError("lam out of range: infinite terms of opposite sign in eq (21)")
    return out


def _config(config):
    if config is None:
        return SprtAcmFilterConfig()
    if not isinstance(config, SprtAcmFilterConfig):
        raise TypeError(f"config must be an SprtAcmFilterConfig, got {type(config).__name__}")
    return config


def _target_modes(cfg, T):
    """``(Qs, PI, mu0, Qb, n_boost)`` of the target filters after the release."""
    Qa = cv_process_noise(T, cfg.sigma_v ** 2, 2, kind="cwna")
    Qm = cv_process_noise(T, cfg.manoeuvre_accel ** 2 * T, 2, kind="cwna")
    if cfg.target_model == "cv":
        return Qa[None], np.ones((1, 1)), np.ones(1), Qa, 0
    if cfg.target_model == "boost":
        n_boost = int(math.ceil(cfg.boost_time / T - 1e-9))
        return Qa[None], np.ones((1, 1)), np.ones(1), Qm, n_boost
    p1, p2 = cfg.p_stay_cv, cfg.p_stay_manoeuvre
    PI = np.array([[p1, 1.0 - p1], [1.0 - p2, p2]])
    m = cfg.manoeuvre_probability_at_release
    return np.stack([Qa, Qm]), PI, np.array([1.0 - m, m]), Qa, 0


def sprt_acm_discriminate(z_pre, z_a, z_b, own_states, T, config=None):
    """Run the four hypothesis-matched filters and the LLR of eqs (19)-(25).

    Parameters
    ----------
    z_pre : (n_pre, 3) or (N, n_pre, 3)
        Pre-release target measurements ``(r, theta, rdot)`` at scans
        ``0 .. n_pre-1`` (n_pre >= 1); the target EKF starts from the first.
    z_a, z_b : (K, 3) or (N, K, 3)
        Measurements of tracks ``a`` and ``b`` at the post-release scans
        ``k = 1..K`` (K >= 0).
    own_states : (n_pre + K, 4)
        Own-ship (pursuer) ``[x, y, vx, vy]`` at every scan, known to the
        pursuer; gives ``u_a`` (eq 9) and ``u_b``.
    T : float
        Scan interval (s).
    config : SprtAcmFilterConfig, optional

    Returns
    -------
    SprtAcmDiscrimination
        Batched if the measurements were.  Decide with
        :func:`trackcore.detection.sprt_decide` on ``llr``.

    Examples
    --------
    Scenario 1's measurements and own-ship track through the four matched filters; the
    LLR is eq (21) of their log-likelihoods:

    >>> from trackcore.scenarios.sprt_acm import (sprt_acm_scenario, sprt_acm_truth,
    ...                                          sprt_acm_measurements)
    >>> s = sprt_acm_scenario(1)
    >>> truth = sprt_acm_truth(s)
    >>> m = sprt_acm_measurements(s, np.random.default_rng(0), truth)
    >>> out = sprt_acm_discriminate(m.z_pre, m.z_a, m.z_b, truth.own, s.T)
    >>> np.round(out.llr[:4], 2)
    array([-3.1 , -3.35, -4.56, -3.97])
    >>> bool(np.allclose(out.llr, sprt_acm_llr(out.lam)))
    True
    """
    cfg = _config(config)
    T = as_positive(T, "T")
    zp = as_array(z_pre, "z_pre", ndim=(2, 3))
    single = zp.ndim == 2
    za = as_array(z_a, "z_a", ndim=zp.ndim)
    zb = as_array(z_b, "z_b", ndim=zp.ndim)
    if single:
        zp, za, zb = zp[None], za[None], zb[None]
    N, n_pre = zp.shape[0], zp.shape[1]
    K = za.shape[1]
    if zp.shape[2] != 3 or n_pre < 1:
        raise ValueError(f"z_pre must have shape (n_pre >= 1, 3) per run, got {zp.shape[1:]}")
    if za.shape != (N, K, 3):
        raise ValueError(f"z_a must have shape ({'N, ' if not single else ''}K, 3) matching "
                         f"z_pre's runs, got {za.shape[1:] if single else za.shape}")
    if zb.shape != za.shape:
        raise ValueError(f"z_b must have the shape of z_a {za.shape[1:]}, got {zb.shape[1:]}")
    if np.any(zp[:, :, 0] < 1e-6) or np.any(za[:, :, 0] < 1e-6) or np.any(zb[:, :, 0] < 1e-6):
        # (a range below a micrometre makes the polar-to-Cartesian covariances degenerate)
        raise ValueError("measured ranges (column 0 of z_pre, z_a, z_b) must be >= 1e-6 m")
    for name, z in (("z_pre", zp), ("z_a", za), ("z_b", zb)):
        if np.any(np.abs(z) > _Z_CAP):  # far beyond any sonar; keeps the filters finite
            raise ValueError(f"{name} is out of range: |r|, |theta| and |rdot| at most "
                             f"{_Z_CAP:g}")
    own = as_array(own_states, "own_states", shape=(n_pre + K, 4))
    if np.any(np.abs(own) > _Z_CAP):
        raise ValueError(f"own_states is out of range: at most {_Z_CAP:g} in magnitude")
    Phi = cv_transition(T, 2)
    with np.errstate(over="ignore", invalid="ignore"):
        Qa = cv_process_noise(T, cfg.sigma_v ** 2, 2, kind="cwna")
        Qs, PI, mu0, Qb, n_boost = _target_modes(cfg, T)
    Ra = np.diag([cfg.sigma_r ** 2, cfg.sigma_theta ** 2, cfg.sigma_rdot ** 2])
    Rb = np.array([[cfg.sigma_theta ** 2]])
    P0 = np.diag([cfg.init_pos_std ** 2] * 2 + [cfg.init_vel_std ** 2] * 2)
    if not all(np.all(np.isfinite(a)) for a in (Qa, Qs, Ra, Rb, P0, Qb)):
        raise ValueError("config and T out of range: a filter covariance overflows")
    lam = np.empty((N, K, 4))
    nis = np.empty((N, K, 4))
    beta = np.empty((N, K, 2))
    mu = np.empty((N, K, 2))
    ok = np.empty(N, dtype=np.bool_)
    f_a1 = cfg.beta_std_factor if cfg.beta_std_factor_a1 is None else cfg.beta_std_factor_a1
    beta_factors = np.array([cfg.beta_std_factor, f_a1], dtype=float)
    beta_min = -math.inf if cfg.beta_min is None else float(cfg.beta_min)
    sprt_acm_discriminate_kernel(zp, za, zb, own, T, Phi, Qa, Qs, PI, mu0, Qb, n_boost, Ra, Rb,
                                 P0, cfg.sigma_p ** 2 * T, beta_factors,
                                 float(cfg.sigma_theta), beta_min, lam, nis, beta, mu, ok)
    bad = ok & ~np.all(np.isfinite(lam), axis=(1, 2))
    if np.any(bad):
        raise ValueError(f"run {int(np.argmax(bad))}: the filters overflowed; the "
                         "measurements, own_states or config are far outside a physical range")
    llr = sprt_acm_llr(lam)
    if single:
        return SprtAcmDiscrimination(lam[0], llr[0], nis[0], beta[0], mu[0], bool(ok[0]))
    return SprtAcmDiscrimination(lam, llr, nis, beta, mu, ok)
