"""Multi-target tracker of Kim, Jung, Kang & Yoon (2016): JPDA aided by image
features, with two-step initialisation and a track-management state machine.

Variants (``JPDATrackerConfig.variant``):

* ``"GNN"``        global nearest neighbour (Hungarian on d^2, same gate);
* ``"JPDA"``       kinematic JPDA (eq 4);
* ``"FJPDA-gate"`` JPDA over the feature validation matrix (eq 5) only;
* ``"FJPDA"``      the paper's: feature validation (eq 5) and rho-weighted
  joint events (eq 6).

Each frame: predict (CV, DWNA), gate (chi-square), feature correlation of each
gated pair (NCC of the track's silhouette template and the measurement's mask),
per-cluster exact JPDA marginals (:func:`trackcore.association.jpda_marginals`),
PDA update with the covariance-spread term
(:func:`trackcore.association.pda_update`), then the state machine

    tentative --hit--> reserved --2 consecutive hits--> confirmed <--> memory

with deletion on misses (tentative: the 1st; reserved: the 2nd consecutive;
memory: once the consecutive misses exceed ``memory_frames``), on an oversized
gate (semi-major axis sqrt(gamma lambda_max(S)) > G_th) and on a duplicate
counter reaching 3 (close positions and equal, non-empty validated measurement
sets on 3 consecutive frames; the track with the shorter history goes, on a tie
the larger ID).  Measurements outside every track's kinematic gate seed new
tentative tracks by two-step initialisation (TSI).  The readings of the paper
that these rules fix are listed in :class:`JPDATrackerConfig`.
"""
from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import beta as beta_dist
from scipy.stats import chi2

from ..association.gating import mahalanobis_gate_kernel
from ..core.validation import as_array, as_bool_matrix
from ..association.jpda import _clusters, _jpda_marginals_checked, feasible_event_count
from ..association.pda import pda_update_kernel
from ..filters.kalman import cholesky_lower_kernel, kf_predict_kernel
from ..detection.image import _mask_ncc as ncc
from ..detection.image import _mask_ncc_sliding
from ..models.measurement import position_matrix
from ..models.motion import cv_process_noise, cv_transition

__all__ = [
    "JPDATrackerConfig",
    "TrackStatus",
    "TrackSnapshot",
    "FrameReport",
    "JPDATracker",
    "run_jpda_tracker",
    "matched_config",
    "steady_state_gate",
    "initial_gate",
    "VARIANTS",
]

VARIANTS = ("GNN", "JPDA", "FJPDA-gate", "FJPDA")
MODELS = ("cv", "rw", "pv")
TSI_SOURCES = ("outside_gates", "unvalidated")
RHO_WEIGHTS = ("raw", "normalised")
CORRELATIONS = ("canvas", "sliding")
TEMPLATE_SOURCES = ("first", "fully_visible")


class TrackStatus:
    """The states of a track (strings, as in :class:`TrackSnapshot`'s ``status``):
    tentative, reserved, confirmed, memory (see the module docstring).

    Examples
    --------
    >>> TrackStatus.CONFIRMED, TrackStatus.MEMORY
    ('confirmed', 'memory')
    """
    TENTATIVE = "tentative"
    RESERVED = "reserved"
    CONFIRMED = "confirmed"
    MEMORY = "memory"


def _check_real(obj, name, *, positive=False, nonnegative=False, lo=None, hi=None):
    v = getattr(obj, name)
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(v).__name__}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if positive and not v > 0:
        raise ValueError(f"{name} must be > 0, got {v}")
    if nonnegative and not v >= 0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got {v}")


def _check_count(obj, name, minimum=1):
    v = getattr(obj, name)
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise TypeError(f"{name} must be an integer, got {type(v).__name__}")
    if not math.isfinite(float(v)) or float(v) != int(v) or int(v) < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {v}")


@dataclass(frozen=True)
class JPDATrackerConfig:
    """Tracker parameters (pixels, frames).  The paper gives none of the numbers; the
    defaults are the chapter's choices (its index page, *Choices we made*).

    Readings the paper leaves open, with the default first:

    * ``memory_frames`` (2): a confirmed track that misses enters memory and is
      deleted when its consecutive misses exceed ``memory_frames`` (1 = deleted on
      the second consecutive miss, counting the one that sent it to memory);
    * ``tsi_from`` (``"outside_gates"``): two-step initialisation uses the
      measurements outside every track's kinematic gate; ``"unvalidated"`` uses
      those validated by no track under the variant's own validation (feature
      gated for the F variants), so that a measurement the feature gate rejected
      can start a track;
    * ``rho_weight`` (``"raw"``): eq (6) multiplies an assignment by the NCC
      rho; ``"normalised"`` by rho divided by the sum of rho over the
      measurements validated by the same track;
    * ``template_guard`` (True): a template update must also correlate at
      least c_I with the track's first template (a drift guard);
      ``template_update=False`` keeps the first template;
    * ``correlation`` (``"canvas"``): rho is :func:`~trackcore.detection.ncc`, both
      patches centred on a common canvas and normalised over it; ``"sliding"`` is
      :func:`~trackcore.detection.ncc_sliding`, the template slid over the
      measurement's patch with local normalisation (the drift guard uses the same);
    * ``template_from`` (``"first"``): a track's first template is the silhouette
      that started it; ``"fully_visible"``: while the track's template touches the
      image border (:func:`_touches_edge`), it is replaced every frame
      by the silhouette of the nearest kinematically validated measurement (outside
      memory), until one away from the border is taken; the drift guard is
      anchored to that one;
    * ``model`` (``"cv"``): what a detection reports and the state it updates.
      ``"cv"``: its position, the state [x, y, vx, vy] (constant velocity, DWNA);
      ``"rw"``: its position, the state [x, y] (random walk, ``q_rw``);
      ``"pv"``: position *and* velocity (the paper's detector "reports the velocity as
      well"), the CV state and H = I4.  Detection j of frame k reports (z_j, v_j) with
      v_j = z_j - z_p, z_p the nearest detection (any, not only the unused ones) of
      frame k-1 within the TSI radius r = v_max T + pair_margin; its noise is that of
      the difference of two noisy positions, R_pv = [[R, R], [R, 2R]] (the correlation
      of v_j with the previous frame's measurement, already used by the filter, is
      ignored).  The gate is chi-square on 4 dof at the gate probability of ``gamma``
      on 2 dof (:attr:`gate_gamma`, 13.28 for 9.21), the clutter density is ``lam``
      times a uniform density of clutter velocities over ``|v_x|, |v_y| <= r``
      (:attr:`clutter_density`, ``lam / (2 r)^2``).  A detection with no detection of
      frame k-1 within r reports no velocity: no track validates it (our simplification:
      JPDA could weigh it by its 2-D likelihood over the 2-D clutter density, since each
      ratio of a likelihood to its clutter density has no unit, but the tracker keeps one
      clutter density per association), and, being outside every gate, it may start a
      track by TSI (as the previous detection of the next frame's pair).  TSI, the
      gate-size rule and the gate half-widths are the CV model's (the position block of
      S with ``gamma``).

    Examples
    --------
    >>> cfg = JPDATrackerConfig()
    >>> cfg.variant, cfg.r_std, cfg.gamma, cfg.memory_frames
    ('FJPDA', 1.0, 9.21, 2)
    >>> JPDATrackerConfig(variant="X")
    Traceback (most recent call last):
        ...
    ValueError: variant must be one of ('GNN', 'JPDA', 'FJPDA-gate', 'FJPDA'), got 'X'

    The position-and-velocity measurement: a 4-dof gate at the same gate probability, the
    clutter density spread over the velocities within the TSI radius (here 8 px/frame):

    >>> pv = JPDATrackerConfig(model="pv")
    >>> round(pv.gate_gamma, 2), pv.clutter_density == 1e-5 / 16.0 ** 2
    (13.28, True)
    """
    variant: str = "FJPDA"
    sigma_a: float = 0.3            # DWNA acceleration std, px/frame^2
    r_std: float = 1.0              # measurement noise std per axis, px
    pd: float = 0.9
    gamma: float = 9.21             # chi-square gate, P_G = 0.99, 2 dof
    lam: float = 1e-5               # clutter density, px^-2
    c_I: float = 0.6                # feature threshold (eq 5)
    v_max: float = 5.0              # TSI max speed, px/frame
    pair_margin: float = 3.0        # TSI radius r = v_max T + pair_margin
    gate_max: float = 20.0          # G_th, px (gate semi-major axis)
    d_dup: float = 5.0              # duplicate distance, px
    dup_frames: int = 3
    duplicate_deletion: bool = True
    model: str = "cv"               # "cv", "rw" (position-only random walk, ablation) or
                                    # "pv" (position and velocity measured, CV state)
    q_rw: float = 4.0               # random-walk position variance per frame, px^2
    template_update: bool = True
    template_guard: bool = True
    tsi_feature: bool = False       # ablation: TSI pairs need rho(z_p, z_c) >= c_I
    tsi_from: str = "outside_gates"
    memory_frames: int = 2
    rho_weight: str = "raw"
    correlation: str = "canvas"
    template_from: str = "first"
    feature_lr: tuple | None = None  # (a1, b1, a0, b0): FJPDA weights by the Beta likelihood
                                     # ratio g1(rho)/g0(rho) instead of rho (extension)

    def __post_init__(self):
        for name, allowed in (("variant", VARIANTS), ("model", MODELS),
                              ("tsi_from", TSI_SOURCES), ("rho_weight", RHO_WEIGHTS),
                              ("correlation", CORRELATIONS),
                              ("template_from", TEMPLATE_SOURCES)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, "
                                 f"got {getattr(self, name)!r}")
        for name in ("sigma_a", "r_std", "gamma", "lam", "v_max", "gate_max", "d_dup",
                     "q_rw"):
            _check_real(self, name, positive=True)
        _check_real(self, "pair_margin", nonnegative=True)
        _check_real(self, "pd", lo=0.0, hi=1.0)
        _check_real(self, "c_I", lo=-1.0, hi=1.0)
        _check_count(self, "dup_frames")
        _check_count(self, "memory_frames")
        for name in ("duplicate_deletion", "template_update", "template_guard",
                     "tsi_feature"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TypeError(f"{name} must be True or False, "
                                f"got {getattr(self, name)!r}")
        if self.feature_lr is not None:
            lr = self.feature_lr
            ok = (isinstance(lr, (tuple, list)) and len(lr) == 4
                  and all(isinstance(v, numbers.Real) and not isinstance(v, bool)
                          and math.isfinite(v) and v > 0 for v in lr))
            if not ok:
                raise ValueError("feature_lr must be four positive Beta parameters "
                                 f"(a1, b1, a0, b0), got {lr!r}")

    @property
    def uses_features(self):
        return self.variant in ("FJPDA-gate", "FJPDA")

    @property
    def gate_gamma(self):
        """The gate threshold on d^2 of one measurement: ``gamma`` (2 dof) for the
        position models; for ``model="pv"`` the 4-dof threshold of the same gate
        probability."""
        if self.model != "pv":
            return self.gamma
        return float(chi2.ppf(chi2.cdf(self.gamma, 2), 4))

    @property
    def clutter_density(self):
        """The clutter density of the association: ``lam`` (px^-2) for the position
        models; for ``model="pv"`` ``lam / (2 r)^2`` (clutter velocities uniform over
        ``|v_x|, |v_y| <= r``, ``r = v_max T + pair_margin`` the TSI radius)."""
        if self.model != "pv":
            return self.lam
        return self.lam / (2.0 * (self.v_max * 1.0 + self.pair_margin)) ** 2


def matched_config(variant="FJPDA", jitter=0.0, **overrides):
    """The tracker matched to a camera jitter of ``jitter`` px (per axis): every
    length tied to the measurement noise scales with s = sqrt(1 + jitter^2), the
    measurement standard deviation in px: R = s^2 I, the TSI pairing margin 3 s and
    the gate-size threshold G_th = 20 s (at ``jitter=0`` the defaults).  Other
    fields are the defaults unless given in ``overrides``.

    Examples
    --------
    A camera jitter of 3 px per axis: the measurement sd becomes ``sqrt(1 + 3^2)`` px and
    the lengths tied to it scale with it:

    >>> cfg = matched_config("FJPDA", jitter=3.0)
    >>> round(cfg.r_std, 3), round(cfg.pair_margin, 3), round(cfg.gate_max, 2)
    (3.162, 9.487, 63.25)
    """
    if isinstance(jitter, bool) or not isinstance(jitter, numbers.Real) \
            or not math.isfinite(jitter) or not 0 <= jitter <= 1e3:
        raise ValueError(f"jitter must be a number in [0, 1000] px, got {jitter!r}")
    s = math.sqrt(1.0 + float(jitter) ** 2)
    kw = dict(variant=variant, r_std=s, pair_margin=3.0 * s, gate_max=20.0 * s)
    kw.update(overrides)
    return JPDATrackerConfig(**kw)


def steady_state_gate(config):
    """Semi-major axis (px) of the steady-state gate sqrt(gamma lambda_max(S)) of a
    track updated by one measurement per frame (the Kalman filter's Riccati
    recursion iterated to convergence).

    Examples
    --------
    >>> round(steady_state_gate(JPDATrackerConfig()), 3)
    4.46
    >>> round(steady_state_gate(matched_config(jitter=3.0)), 3)  # a wider gate under jitter
    11.927
    """
    if not isinstance(config, JPDATrackerConfig):
        raise TypeError("config must be a JPDATrackerConfig")
    trk = JPDATracker(config)
    F, Q, H, R = trk.F, trk.Q, trk.H, trk.R
    P = np.eye(F.shape[0]) * 100.0
    for _ in range(2000):
        Pp = F @ P @ F.T + Q
        S = H @ Pp @ H.T + R
        W = Pp @ H.T @ np.linalg.inv(S)
        P_new = Pp - W @ S @ W.T
        if np.max(np.abs(P_new - P)) < 1e-12:
            break
        P = P_new
    return _predicted_gate(trk, P)


def initial_gate(config):
    """Semi-major axis (px) of the gate sqrt(gamma lambda_max(S)) of a track started by the
    two-step initialisation, at its first prediction (the frame after it was started,
    before any update): beside :func:`steady_state_gate`, it says whether the gate-size
    threshold G_th lets a new track live, since a track whose gate exceeds G_th is
    deleted, tentative tracks included.

    Examples
    --------
    >>> round(initial_gate(JPDATrackerConfig()), 2)
    7.45
    >>> round(initial_gate(matched_config(jitter=5.0)), 1)  # above an unscaled G_th of 20 px
    37.9
    """
    if not isinstance(config, JPDATrackerConfig):
        raise TypeError("config must be a JPDATrackerConfig")
    trk = JPDATracker(config)
    return _predicted_gate(trk, trk._initial_covariance())


def _predicted_gate(trk, P):
    """The gate semi-axis at the prediction from covariance P (the position block of S)."""
    S = (trk.H @ (trk.F @ P @ trk.F.T + trk.Q) @ trk.H.T + trk.R)[:2, :2]
    return float(math.sqrt(trk.cfg.gamma * np.linalg.eigvalsh(S)[-1]))


class TrackSnapshot(NamedTuple):
    """One track after a frame: ID, status, position [x, y], gate half-widths
    (sqrt(gamma S_xx), sqrt(gamma S_yy)) of the frame's gate, age (frames).

    Examples
    --------
    The tracks of a :class:`FrameReport`:

    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> reports = run_jpda_tracker(detections[:11])
    >>> t = reports[-1].tracks[0]
    >>> t.tid, t.status, round(t.x, 1), round(t.y, 1), t.age
    (2, 'confirmed', 116.1, 136.8, 9)
    """
    tid: int
    status: str
    x: float
    y: float
    gate_x: float
    gate_y: float
    age: int


class FrameReport(NamedTuple):
    """What happened at one frame.

    Examples
    --------
    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> r = run_jpda_tracker(detections[:31])[30]  # the pair's closest approach
    >>> r.k, len(r.tracks), r.n_events, r.n_valid_kin, r.n_valid
    (30, 1, 3, 2, 2)
    """
    k: int
    tracks: tuple            # TrackSnapshot of every live track after the frame
    n_events: int            # feasible joint events, summed over clusters
    n_valid_kin: int         # kinematically validated (j, t) pairs
    n_valid: int             # pairs validated by the variant (feature-gated for F*)
    deleted: tuple           # (tid, reason) deleted at this frame
    assoc_ms: float          # wall time of gating + association + update (ms)
    n_events_kin: int = 0    # feasible events of the kinematic validation of the same
                             # tracks (= n_events for GNN and JPDA)


@dataclass
class _Track:
    tid: int
    x: np.ndarray
    P: np.ndarray
    template: np.ndarray
    born: int
    template0: np.ndarray | None = None
    whole: bool = True            # the template does not touch its patch's edge
    status: str = TrackStatus.TENTATIVE
    hits: int = 0                 # consecutive hits in the current state
    misses: int = 0               # consecutive misses
    dup: dict = field(default_factory=dict)
    validated: frozenset = frozenset()
    gate: tuple = (0.0, 0.0)


class JPDATracker:
    """The tracker; call :meth:`step` once per frame with that frame's
    :class:`trackcore.detection.ImageDetections` (or any object with ``z``
    (m, 2) and a list ``masks`` of m binary patches).

    Examples
    --------
    Frame by frame on the measurement-level crossing of a van and a sedan; by frame 10
    both vehicles have confirmed tracks:

    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> tracker = JPDATracker(JPDATrackerConfig(variant="FJPDA"))
    >>> for d in detections[:11]:
    ...     report = tracker.step(d)
    >>> sorted((t.tid, t.status) for t in report.tracks)
    [(2, 'confirmed'), (3, 'confirmed')]
    """

    def __init__(self, config: JPDATrackerConfig | None = None):
        self.cfg = config if config is not None else JPDATrackerConfig()
        c = self.cfg
        self.R2 = c.r_std ** 2 * np.eye(2)   # the noise of one position
        if c.model == "rw":
            self.F = np.eye(2)
            self.Q = c.q_rw * np.eye(2)
            self.H = np.eye(2)
        else:
            self.F = cv_transition(1.0)
            self.Q = cv_process_noise(1.0, c.sigma_a ** 2)
            self.H = position_matrix(2, 4) if c.model == "cv" else np.eye(4)
        R = self.R2
        self.R = R if c.model != "pv" else np.block([[R, R], [R, 2 * R]])
        self.tracks: list[_Track] = []
        self.prev_all = np.zeros((0, 2))    # every detection of the previous frame
        self.prev_z = np.zeros((0, 2))
        self.prev_masks: list = []
        self.next_id = 1
        self.k = 0
        self._rho = _mask_ncc_sliding if self.cfg.correlation == "sliding" else ncc

    # ------------------------------------------------------------ helpers
    def _initial_covariance(self):
        """P of a track started by the two-step initialisation (T = 1 frame)."""
        R = self.R2
        if self.cfg.model != "rw":
            return np.block([[R, R], [R, 2 * R]])
        return R.copy()

    def _new_track(self, zc, zp, mask):
        if self.cfg.model != "rw":
            x = np.array([zc[0], zc[1], zc[0] - zp[0], zc[1] - zp[1]])
        else:
            x = np.array(zc, float)
        P = self._initial_covariance()
        t = _Track(self.next_id, x, P, mask, self.k, template0=mask,
                   whole=self.cfg.template_from == "first" or not _touches_edge(mask))
        self.next_id += 1
        return t

    # ------------------------------------------------------------ one frame
    def step(self, detections, name="detections"):
        """Process one frame; ``name`` is used in error messages."""
        c = self.cfg
        z, masks = _check_detections(detections, name)
        m = z.shape[0]
        t0 = time.perf_counter()
        T = len(self.tracks)
        xp, Pp, S_all, zp_all = [], [], [], []
        valid_kin = np.zeros((m, T), bool)
        lik = np.zeros((m, T))
        nx, nz = self.H.shape[1], self.H.shape[0]
        zz, has_v = self._measurements(z)
        gamma = c.gate_gamma
        L = np.zeros((nz, nz))
        gmask = np.zeros(m, np.bool_)
        d2 = np.empty(m)
        nearest = np.full(T, -1)
        for i, tr in enumerate(self.tracks):
            # the tracker validated its inputs; it calls the foundation kernels directly
            x = np.empty(nx)
            P = np.empty((nx, nx))
            kf_predict_kernel(tr.x, tr.P, self.F, self.Q, x, P)
            S = self.H @ P @ self.H.T + self.R
            zpred = self.H @ x
            xp.append(x)
            Pp.append(P)
            S_all.append(S)
            zp_all.append(zpred)
            if m:
                if not cholesky_lower_kernel(S, L):
                    raise ValueError("innovation covariance lost positive definiteness")
                mahalanobis_gate_kernel(zz, zpred, L, gamma, -1, gmask, d2)
                if has_v is not None:
                    gmask &= has_v       # a detection without velocity is validated by none
                valid_kin[:, i] = gmask
                if not tr.whole and gmask.any():
                    nearest[i] = int(np.argmin(np.where(gmask, d2, np.inf)))
                if gmask.any() and nz == 2:
                    lik[gmask, i] = np.exp(-0.5 * d2[gmask]) / (
                        2 * np.pi * L[0, 0] * L[1, 1])
                elif gmask.any():
                    lik[gmask, i] = np.exp(-0.5 * d2[gmask]) / (
                        (2 * np.pi) ** (nz / 2) * np.prod(np.diag(L)))
        rho = np.zeros((m, T))
        if c.uses_features:
            for j, i in zip(*np.nonzero(valid_kin)):
                rho[j, i] = self._rho(self.tracks[i].template, masks[j])
            valid = valid_kin & (rho >= c.c_I)
        else:
            valid = valid_kin
        beta = np.zeros((m + 1, T))
        beta[0, :] = 1.0
        n_events = 0
        if c.variant == "GNN":
            if m and T:
                d2 = np.full((m, T), 1e12)
                for i in range(T):
                    nu = zz - zp_all[i]
                    d2[:, i] = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(S_all[i]), nu)
                cost = np.where(valid, d2, 1e12)
                rows, cols = linear_sum_assignment(cost)
                for j, i in zip(rows, cols):
                    if valid[j, i]:
                        beta[0, i] = 0.0
                        beta[j + 1, i] = 1.0
            n_events = 0
        else:
            # the inputs are valid by construction: jpda_marginals and jpda_clusters
            # without their checks (valid is valid_kin & (rho >= c_I) for the F variants,
            # the feature validation jpda_marginals would compute from rho)
            for trk, mea in _clusters(valid):
                if len(mea) == 0:
                    n_events += 1
                    continue
                ix = (mea[:, None], trk)   # np.ix_(mea, trk), without its checks
                sub_valid = valid[ix]
                sub_lik = lik[ix]
                pd_arr = np.full(len(trk), float(c.pd))
                sub_rho = None
                if c.variant == "FJPDA" and c.feature_lr is not None:
                    r = np.clip(rho[ix], 1e-6, 1 - 1e-6)
                    a1, b1, a0, b0 = c.feature_lr
                    lr = np.exp(beta_dist.logpdf(r, a1, b1) - beta_dist.logpdf(r, a0, b0))
                    sub_lik = sub_lik * lr
                elif c.variant == "FJPDA" and c.rho_weight == "normalised":
                    w = np.where(sub_valid, rho[ix], 0.0)
                    tot = w.sum(axis=0)
                    w = np.divide(w, tot, out=np.zeros_like(w), where=tot > 0)
                    sub_lik = sub_lik * w
                elif c.variant == "FJPDA":
                    sub_rho = rho[ix]
                b, n = _jpda_marginals_checked(sub_lik, sub_valid, pd_arr,
                                               float(c.clutter_density),
                                               sub_rho, False, 0.0, "auto")
                n_events += n
                beta[0, trk] = b[0]
                beta[(mea + 1)[:, None], trk] = b[1:]
        n_events_kin = n_events
        if c.uses_features and not np.array_equal(valid, valid_kin):
            n_events_kin = 0
            for trk, mea in _clusters(valid_kin):
                n_events_kin += (feasible_event_count(valid_kin[np.ix_(mea, trk)])
                                 if len(mea) else 1)
        # state update
        hit = valid.any(axis=0) if m else np.zeros(T, bool)
        for i, tr in enumerate(self.tracks):
            sel = np.nonzero(valid[:, i])[0]
            xo, Po = np.empty(nx), np.empty((nx, nx))
            ok = pda_update_kernel(xp[i], Pp[i], np.ascontiguousarray(zz[sel]), zp_all[i],
                                   self.H, self.R, np.ascontiguousarray(beta[sel + 1, i]),
                                   float(max(0.0, 1.0 - beta[sel + 1, i].sum())), -1, xo, Po,
                                   np.empty(nz), np.empty((nz, nz)), np.empty((nx, nz)))
            if not ok:
                raise ValueError("innovation covariance lost positive definiteness")
            was_memory = tr.status == TrackStatus.MEMORY
            tr.x, tr.P = xo, Po
            tr.validated = frozenset(sel.tolist())
            gx, gy = math.sqrt(c.gamma * S_all[i][0, 0]), math.sqrt(c.gamma * S_all[i][1, 1])
            tr.gate = (gx, gy)
            if nearest[i] >= 0 and not was_memory:
                tr.template = tr.template0 = masks[nearest[i]]
                tr.whole = not _touches_edge(tr.template)
            elif c.uses_features and c.template_update and len(sel) and not was_memory:
                jb = sel[np.argmax(beta[sel + 1, i])]
                if beta[jb + 1, i] >= 0.5 and rho[jb, i] >= c.c_I and (
                        not c.template_guard or masks[jb] is tr.template0
                        or self._rho(tr.template0, masks[jb]) >= c.c_I):
                    tr.template = masks[jb]
        assoc_ms = 1e3 * (time.perf_counter() - t0)
        # track management
        deleted = []
        keep = []
        for i, tr in enumerate(self.tracks):
            h = bool(hit[i])
            Si = S_all[i]   # its position block: largest eigenvalue in closed form
            half = 0.5 * (Si[0, 0] - Si[1, 1])
            lmax = 0.5 * (Si[0, 0] + Si[1, 1]) + math.sqrt(half * half + Si[0, 1] * Si[1, 0])
            semi = math.sqrt(c.gamma * lmax)
            reason = None
            if semi > c.gate_max:
                reason = "gate"
            elif tr.status == TrackStatus.TENTATIVE:
                if h:
                    tr.status, tr.hits, tr.misses = TrackStatus.RESERVED, 0, 0
                else:
                    reason = "miss"
            elif tr.status == TrackStatus.RESERVED:
                if h:
                    tr.hits += 1
                    tr.misses = 0
                    if tr.hits >= 2:
                        tr.status, tr.hits = TrackStatus.CONFIRMED, 0
                else:
                    tr.hits = 0
                    tr.misses += 1
                    if tr.misses >= 2:
                        reason = "miss"
            elif tr.status == TrackStatus.CONFIRMED:
                if h:
                    tr.misses = 0
                else:
                    tr.status, tr.misses = TrackStatus.MEMORY, 1
            elif tr.status == TrackStatus.MEMORY:
                if h:
                    tr.status, tr.misses = TrackStatus.CONFIRMED, 0
                else:
                    tr.misses += 1
                    if tr.misses > c.memory_frames:
                        reason = "miss"
            if reason is None:
                keep.append(tr)
            else:
                deleted.append((tr.tid, reason))
        self.tracks = keep
        if c.duplicate_deletion:
            deleted += self._duplicates()
        # two-step initialisation from measurements outside every kinematic gate (or, for
        # tsi_from="unvalidated", validated by no track under the variant's validation)
        if not T:
            used = np.zeros(m, bool)
        elif c.tsi_from == "outside_gates":
            used = valid_kin.any(axis=1)
        else:
            used = valid.any(axis=1)
        cand = np.nonzero(~used)[0]
        new_prev = []
        if len(cand):
            r = c.v_max * 1.0 + c.pair_margin
            P = self.prev_z
            pairs = []
            for j in cand:
                if len(P):
                    d = np.hypot(*(P - z[j]).T)
                    for p in np.nonzero(d <= r)[0]:
                        pairs.append((d[p], j, p))
            pairs.sort()
            cj, cp = set(), set()
            for d, j, p in pairs:
                if j in cj or p in cp:
                    continue
                if c.tsi_feature and ncc(self.prev_masks[p], masks[j]) < c.c_I:
                    continue
                cj.add(j)
                cp.add(p)
                self.tracks.append(self._new_track(z[j], P[p], masks[j]))
            new_prev = [j for j in cand if j not in cj]
        self.prev_z = z[new_prev].reshape(-1, 2)
        self.prev_all = z
        self.prev_masks = [masks[j] for j in new_prev]
        snaps = tuple(TrackSnapshot(tr.tid, tr.status, float(tr.x[0]), float(tr.x[1]),
                                    tr.gate[0], tr.gate[1], self.k - tr.born)
                      for tr in self.tracks)
        rep = FrameReport(self.k, snaps, int(n_events), int(valid_kin.sum()),
                          int(valid.sum()), tuple(deleted), assoc_ms, int(n_events_kin))
        self.k += 1
        return rep

    def _measurements(self, z):
        """``(zz, has_v)``: the measurement rows of the frame's positions ``z`` and, for
        ``model="pv"``, which detections report a velocity (``None`` otherwise).  For
        ``"pv"`` a row is (z_j, z_j - z_p), z_p the nearest detection of the previous
        frame within the TSI radius; a row without one has velocity 0 and
        ``has_v`` False (it is gated out)."""
        if self.cfg.model != "pv":
            return z, None
        m = z.shape[0]
        zz = np.zeros((m, 4))
        zz[:, :2] = z
        has_v = np.zeros(m, np.bool_)
        P = self.prev_all
        if m and len(P):
            r = self.cfg.v_max * 1.0 + self.cfg.pair_margin
            d = np.hypot(z[:, None, 0] - P[None, :, 0], z[:, None, 1] - P[None, :, 1])
            p = np.argmin(d, axis=1)
            has_v = d[np.arange(m), p] <= r
            zz[has_v, 2:] = z[has_v] - P[p[has_v]]
        return zz, has_v

    def _duplicates(self):
        c = self.cfg
        live = [t for t in self.tracks if t.status != TrackStatus.TENTATIVE]
        doomed = {}
        for a in range(len(live)):
            for b in range(a + 1, len(live)):
                ta, tb = live[a], live[b]
                close = math.hypot(ta.x[0] - tb.x[0], ta.x[1] - tb.x[1]) < c.d_dup
                same = bool(ta.validated) and ta.validated == tb.validated
                if close and same:
                    n = ta.dup.get(tb.tid, 0) + 1
                else:
                    n = 0
                ta.dup[tb.tid] = n
                tb.dup[ta.tid] = n
                if n >= c.dup_frames:
                    age_a, age_b = self.k - ta.born, self.k - tb.born
                    if age_a != age_b:
                        loser = ta if age_a < age_b else tb
                    else:
                        loser = ta if ta.tid > tb.tid else tb
                    doomed[loser.tid] = "duplicate"
        if not doomed:
            return []
        self.tracks = [t for t in self.tracks if t.tid not in doomed]
        return [(tid, why) for tid, why in doomed.items()]


def _touches_edge(mask):
    """Whether a blob lies at the image border: its patch is its tight box grown by
    the same margin on every side, cut at the image border, so the margins of the
    silhouette to the patch's edges are unequal exactly when the patch was cut (the
    blob lies within the margin of the border)."""
    rows = np.nonzero(mask.any(axis=1))[0]
    cols = np.nonzero(mask.any(axis=0))[0]
    if len(rows) == 0:
        return True
    gaps = (rows[0], mask.shape[0] - 1 - rows[-1], cols[0], mask.shape[1] - 1 - cols[-1])
    return min(gaps) < max(gaps)


def _check_detections(detections, name):
    """``(z, masks)`` of one frame's detections after checking them: ``z`` finite
    (m, 2) and one 2-D binary mask per measurement."""
    try:
        z_raw, masks = detections.z, detections.masks
    except AttributeError:
        raise TypeError(f"{name} must have attributes z (m, 2) and masks "
                        f"(e.g. an ImageDetections), got {type(detections).__name__}") from None
    z = as_array(z_raw, f"{name}.z")
    if z.size == 0:
        z = z.reshape(0, 2)
    if z.ndim != 2 or z.shape[1] != 2:
        raise ValueError(f"{name}.z must have shape (m, 2), got {z.shape}")
    masks = list(masks)
    if len(masks) != z.shape[0]:
        raise ValueError(f"{name}.masks must hold one patch per measurement "
                         f"({z.shape[0]}), got {len(masks)}")
    for j, M in enumerate(masks):
        if not (isinstance(M, np.ndarray) and M.dtype == np.bool_ and M.ndim == 2):
            M = as_bool_matrix(M, f"{name}.masks[{j}]")
            masks[j] = M
        if M.size == 0:
            raise ValueError(f"{name}.masks[{j}] must not be empty")
    return z, masks


def run_jpda_tracker(detections, config=None):
    """Run a tracker over a list of per-frame detections; returns the list of
    :class:`FrameReport`.  A detection with a NaN or infinite position is an error
    (``ValueError`` naming the frame), never silently dropped.

    Examples
    --------
    The kinematic JPDA against the paper's FJPDA on the same detections: confirmed tracks
    at the last frame:

    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> for variant in ("JPDA", "FJPDA"):
    ...     last = run_jpda_tracker(detections, JPDATrackerConfig(variant=variant))[-1]
    ...     print(variant, sorted(t.tid for t in last.tracks if t.status == "confirmed"))
    JPDA [2, 5]
    FJPDA [2, 5]
    """
    if config is not None and not isinstance(config, JPDATrackerConfig):
        raise TypeError(f"config must be a JPDATrackerConfig, got {type(config).__name__}")
    trk = JPDATracker(config)
    return [trk.step(d, f"detections[{k}]") for k, d in enumerate(detections)]


