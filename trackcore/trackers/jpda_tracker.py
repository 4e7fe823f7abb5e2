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

with deletion on misses (tentative: 1st; reserved and memory: 2nd
consecutive), on an oversized gate (semi-major axis sqrt(gamma lambda_max(S))
> G_th) and on a duplicate counter reaching 3 (close positions and equal,
non-empty validated measurement sets on 3 consecutive frames; the track with
the shorter history goes, on a tie the larger ID).  Unused measurements seed
new tentative tracks by two-step initialisation (TSI).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import beta as beta_dist

from ..association.gating import mahalanobis_gate_kernel
from ..association.jpda import jpda_clusters, jpda_marginals
from ..association.pda import pda_update_kernel
from ..filters.kalman import cholesky_lower_kernel, kf_predict_kernel
from ..detection.image import ncc
from ..models.measurement import position_matrix
from ..models.motion import cv_process_noise, cv_transition

__all__ = [
    "JPDATrackerConfig",
    "TrackStatus",
    "TrackSnapshot",
    "FrameReport",
    "JPDATracker",
    "run_jpda_tracker",
]

VARIANTS = ("GNN", "JPDA", "FJPDA-gate", "FJPDA")


class TrackStatus:
    TENTATIVE = "tentative"
    RESERVED = "reserved"
    CONFIRMED = "confirmed"
    MEMORY = "memory"


@dataclass(frozen=True)
class JPDATrackerConfig:
    """Tracker parameters (pixels, frames); defaults are the spec's section 7."""
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
    model: str = "cv"               # "cv" or "rw" (position-only random walk, ablation)
    q_rw: float = 4.0               # random-walk position variance per frame, px^2
    template_update: bool = True
    tsi_feature: bool = False       # ablation: TSI pairs need rho(z_p, z_c) >= c_I
    feature_lr: tuple | None = None  # (a1, b1, a0, b0): FJPDA weights by the Beta likelihood
                                     # ratio g1(rho)/g0(rho) instead of rho (extension)

    def __post_init__(self):
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, got {self.variant!r}")
        if self.model not in ("cv", "rw"):
            raise ValueError(f"model must be 'cv' or 'rw', got {self.model!r}")
        for name in ("sigma_a", "r_std", "gamma", "lam", "v_max", "gate_max", "d_dup"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not 0.0 <= self.pd <= 1.0:
            raise ValueError(f"pd must be a probability in [0, 1], got {self.pd}")
        if not -1.0 <= self.c_I <= 1.0:
            raise ValueError(f"c_I must lie in [-1, 1], got {self.c_I}")
        if self.feature_lr is not None and (len(self.feature_lr) != 4
                                            or min(self.feature_lr) <= 0):
            raise ValueError("feature_lr must be four positive Beta parameters (a1, b1, a0, b0)")
        if int(self.dup_frames) != self.dup_frames or self.dup_frames < 1:
            raise ValueError(f"dup_frames must be a positive integer, got {self.dup_frames}")

    @property
    def uses_features(self):
        return self.variant in ("FJPDA-gate", "FJPDA")


class TrackSnapshot(NamedTuple):
    """One track after a frame: ID, status, position [x, y], gate half-widths
    (sqrt(gamma S_xx), sqrt(gamma S_yy)) of the frame's gate, age (frames)."""
    tid: int
    status: str
    x: float
    y: float
    gate_x: float
    gate_y: float
    age: int


class FrameReport(NamedTuple):
    """What happened at one frame."""
    k: int
    tracks: tuple            # TrackSnapshot of every live track after the frame
    n_events: int            # feasible joint events, summed over clusters
    n_valid_kin: int         # kinematically validated (j, t) pairs
    n_valid: int             # pairs validated by the variant (feature-gated for F*)
    deleted: tuple           # (tid, reason) deleted at this frame
    assoc_ms: float          # wall time of gating + association + update (ms)


@dataclass
class _Track:
    tid: int
    x: np.ndarray
    P: np.ndarray
    template: np.ndarray
    born: int
    status: str = TrackStatus.TENTATIVE
    hits: int = 0                 # consecutive hits in the current state
    misses: int = 0               # consecutive misses
    dup: dict = field(default_factory=dict)
    validated: frozenset = frozenset()
    gate: tuple = (0.0, 0.0)


class JPDATracker:
    """The tracker; call :meth:`step` once per frame with that frame's
    :class:`trackcore.detection.ImageDetections` (or any object with ``z``
    (m, 2) and a list ``masks`` of m binary patches)."""

    def __init__(self, config: JPDATrackerConfig | None = None):
        self.cfg = config if config is not None else JPDATrackerConfig()
        c = self.cfg
        if c.model == "cv":
            self.F = cv_transition(1.0)
            self.Q = cv_process_noise(1.0, c.sigma_a ** 2)
            self.H = position_matrix(2, 4)
        else:
            self.F = np.eye(2)
            self.Q = c.q_rw * np.eye(2)
            self.H = np.eye(2)
        self.R = c.r_std ** 2 * np.eye(2)
        self.tracks: list[_Track] = []
        self.prev_z = np.zeros((0, 2))
        self.prev_masks: list = []
        self.next_id = 1
        self.k = 0

    # ------------------------------------------------------------ helpers
    def _new_track(self, zc, zp, mask):
        R = self.R
        if self.cfg.model == "cv":
            x = np.array([zc[0], zc[1], zc[0] - zp[0], zc[1] - zp[1]])
            P = np.block([[R, R], [R, 2 * R]])
        else:
            x = np.array(zc, float)
            P = R.copy()
        t = _Track(self.next_id, x, P, mask, self.k)
        self.next_id += 1
        return t

    # ------------------------------------------------------------ one frame
    def step(self, detections):
        c = self.cfg
        z = np.asarray(detections.z, float).reshape(-1, 2)
        masks = list(detections.masks)
        if len(masks) != z.shape[0]:
            raise ValueError("detections.masks must hold one patch per measurement")
        m = z.shape[0]
        t0 = time.perf_counter()
        T = len(self.tracks)
        xp, Pp, S_all, zp_all = [], [], [], []
        valid_kin = np.zeros((m, T), bool)
        lik = np.zeros((m, T))
        nx = self.F.shape[0]
        L = np.zeros((2, 2))
        gmask = np.zeros(m, np.bool_)
        d2 = np.empty(m)
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
                mahalanobis_gate_kernel(z, zpred, L, c.gamma, -1, gmask, d2)
                valid_kin[:, i] = gmask
                if gmask.any():
                    lik[gmask, i] = np.exp(-0.5 * d2[gmask]) / (
                        2 * np.pi * L[0, 0] * L[1, 1])
        rho = np.zeros((m, T))
        if c.uses_features:
            for j, i in zip(*np.nonzero(valid_kin)):
                rho[j, i] = ncc(self.tracks[i].template, masks[j])
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
                    nu = z - zp_all[i]
                    d2[:, i] = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(S_all[i]), nu)
                cost = np.where(valid, d2, 1e12)
                rows, cols = linear_sum_assignment(cost)
                for j, i in zip(rows, cols):
                    if valid[j, i]:
                        beta[0, i] = 0.0
                        beta[j + 1, i] = 1.0
            n_events = 0
        else:
            for trk, mea in jpda_clusters(valid):
                if len(mea) == 0:
                    n_events += 1
                    continue
                ix = np.ix_(mea, trk)
                sub_valid = valid[ix]
                sub_lik = lik[ix]
                if c.variant == "FJPDA" and c.feature_lr is not None:
                    r = np.clip(rho[ix], 1e-6, 1 - 1e-6)
                    a1, b1, a0, b0 = c.feature_lr
                    lr = np.exp(beta_dist.logpdf(r, a1, b1) - beta_dist.logpdf(r, a0, b0))
                    b, n = jpda_marginals(sub_lik * lr, sub_valid, c.pd, c.lam)
                elif c.variant == "FJPDA":
                    b, n = jpda_marginals(sub_lik, valid_kin[ix], c.pd, c.lam,
                                          rho=rho[ix], c_I=c.c_I)
                else:
                    b, n = jpda_marginals(sub_lik, sub_valid, c.pd, c.lam)
                n_events += n
                beta[0, trk] = b[0]
                beta[np.ix_(mea + 1, trk)] = b[1:]
        # state update
        hit = valid.any(axis=0) if m else np.zeros(T, bool)
        for i, tr in enumerate(self.tracks):
            sel = np.nonzero(valid[:, i])[0]
            xo, Po = np.empty(nx), np.empty((nx, nx))
            ok = pda_update_kernel(xp[i], Pp[i], np.ascontiguousarray(z[sel]), zp_all[i], self.H,
                                   self.R, np.ascontiguousarray(beta[sel + 1, i]),
                                   float(max(0.0, 1.0 - beta[sel + 1, i].sum())), -1, xo, Po,
                                   np.empty(2), np.empty((2, 2)), np.empty((nx, 2)))
            if not ok:
                raise ValueError("innovation covariance lost positive definiteness")
            was_memory = tr.status == TrackStatus.MEMORY
            tr.x, tr.P = xo, Po
            tr.validated = frozenset(sel.tolist())
            gx, gy = math.sqrt(c.gamma * S_all[i][0, 0]), math.sqrt(c.gamma * S_all[i][1, 1])
            tr.gate = (gx, gy)
            if c.uses_features and c.template_update and len(sel) and not was_memory:
                jb = sel[np.argmax(beta[sel + 1, i])]
                if beta[jb + 1, i] >= 0.5 and rho[jb, i] >= c.c_I:
                    tr.template = masks[jb]
        assoc_ms = 1e3 * (time.perf_counter() - t0)
        # track management
        deleted = []
        keep = []
        for i, tr in enumerate(self.tracks):
            h = bool(hit[i])
            Si = S_all[i]             # 2x2: largest eigenvalue in closed form
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
                    if tr.misses >= 2:
                        reason = "miss"
            if reason is None:
                keep.append(tr)
            else:
                deleted.append((tr.tid, reason))
        self.tracks = keep
        if c.duplicate_deletion:
            deleted += self._duplicates()
        # two-step initialisation from measurements outside every gate
        used = valid.any(axis=1) if T else np.zeros(m, bool)
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
        self.prev_masks = [masks[j] for j in new_prev]
        snaps = tuple(TrackSnapshot(tr.tid, tr.status, float(tr.x[0]), float(tr.x[1]),
                                    tr.gate[0], tr.gate[1], self.k - tr.born)
                      for tr in self.tracks)
        rep = FrameReport(self.k, snaps, int(n_events), int(valid_kin.sum()),
                          int(valid.sum()), tuple(deleted), assoc_ms)
        self.k += 1
        return rep

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


def run_jpda_tracker(detections, config=None):
    """Run a tracker over a list of per-frame detections; returns the list of
    :class:`FrameReport`."""
    trk = JPDATracker(config)
    return [trk.step(d) for d in detections]


