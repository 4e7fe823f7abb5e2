"""Track-quality measures for the feature-JPDA scenes (chapter spec section 7).

Truth-to-track matching per frame: Hungarian assignment on centroid distance
between the *vehicles* present in the frame and the confirmed and memory
tracks, gated at ``match_gate`` (10 px).  From the matches:

* track maintenance rate (TMR): for every vehicle, its eligible frames are
  those where it is fully visible, from 3 frames after it first appears; its
  primary track is the first track ID matched to it; it is maintained at a
  frame if matched to its primary track.  TMR = maintained / eligible;
* coverage: as TMR, any matched track counts;
* false tracks: tracks that were confirmed and matched to no vehicle in at
  least half of their confirmed (confirmed or memory) frames; each is
  attributed to the clutter object (bar, foliage) nearest to it, within
  ``match_gate``, in most of those frames, else to ``"other"`` (speckle,
  fragments);
* CLEAR-MOT ID switches, fragmentations, MOTA and MOTP;
* crossing outcome (kept / swap / break) 10 frames either side of a conflict;
* follower: frames from the follower's full entry until it has its own
  confirmed track (one never matched to the leader before).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..stats import wilson_interval  # noqa: F401  (re-exported for the chapter's notebooks)

__all__ = ["SceneMetrics", "match_tracks", "scene_metrics", "vehicle_mask_iou",
           "SceneTrial", "scene_trial", "scene_trials"]

_REPORTED = ("confirmed", "memory")


class SceneMetrics(NamedTuple):
    tmr_num: int
    tmr_den: int
    coverage_num: int
    false_tracks: int
    false_track_frames: int
    id_switches: int
    fragmentations: int
    mota: float
    motp: float
    crossing: str            # "kept", "swap", "break" or "" (no crossing)
    follower_delay: int      # frames until the follower's own confirmed track (-1 = never)
    mean_events: float
    max_events: int
    valid_removed: float     # share of kinematic validation entries removed by the feature gate
    assoc_ms: float          # mean association time per frame
    false_sources: tuple = ()  # ((source name, false tracks), ...) sorted by name

    @property
    def tmr(self):
        return self.tmr_num / self.tmr_den if self.tmr_den else float("nan")


def match_tracks(truth_xy, truth_present, reports, match_gate=10.0):
    """Per frame, the matched track ID of every truth object (-1 = none) and
    the distances: returns ``(ids (K, n) int, dist (K, n))``."""
    K, n = truth_present.shape
    ids = np.full((K, n), -1, np.int64)
    dist = np.full((K, n), np.nan)
    for k in range(K):
        objs = np.nonzero(truth_present[k])[0]
        tr = [s for s in reports[k].tracks if s.status in _REPORTED]
        if len(objs) == 0 or not tr:
            continue
        P = np.array([[s.x, s.y] for s in tr])
        D = np.hypot(truth_xy[k, objs, None, 0] - P[None, :, 0],
                     truth_xy[k, objs, None, 1] - P[None, :, 1])
        cost = np.where(D <= match_gate, D, 1e9)
        rows, cols = linear_sum_assignment(cost)
        for r, cix in zip(rows, cols):
            if D[r, cix] <= match_gate:
                ids[k, objs[r]] = tr[cix].tid
                dist[k, objs[r]] = D[r, cix]
    return ids, dist


def scene_metrics(scene, reports, match_gate=10.0):
    """All measures of one tracker run over one scene (vehicles are the truth)."""
    veh = np.nonzero(scene.is_vehicle)[0]
    xy = scene.xy[:, veh]
    present = scene.present[:, veh]
    visible = scene.visible[:, veh]
    K, n = present.shape
    ids, dist = match_tracks(xy, present, reports, match_gate)
    tmr_num = tmr_den = cov = 0
    idsw = frag = 0
    primary = {}
    for o in range(n):
        seen = np.nonzero(present[:, o])[0]
        if len(seen) == 0:
            continue
        first = seen[0]
        matched = np.nonzero(ids[:, o] >= 0)[0]
        if len(matched):
            primary[o] = ids[matched[0], o]
        elig = visible[:, o].copy()
        elig[:first + 3] = False
        tmr_den += int(elig.sum())
        cov += int((elig & (ids[:, o] >= 0)).sum())
        if o in primary:
            tmr_num += int((elig & (ids[:, o] == primary[o])).sum())
        last = -1
        was = False
        for k in range(K):
            cur = ids[k, o]
            if cur >= 0:
                if last >= 0 and cur != last:
                    idsw += 1
                if not was and last >= 0:
                    frag += 1
                last = cur
                was = True
            elif present[k, o]:
                was = False
    # false tracks
    conf_frames, matched_frames = {}, {}
    matched_ids = [set(ids[k][ids[k] >= 0].tolist()) for k in range(K)]
    for k in range(K):
        for s in reports[k].tracks:
            if s.status in _REPORTED:
                conf_frames[s.tid] = conf_frames.get(s.tid, 0) + 1
                if s.tid in matched_ids[k]:
                    matched_frames[s.tid] = matched_frames.get(s.tid, 0) + 1
    false_ids = [t for t, nf in conf_frames.items() if matched_frames.get(t, 0) < 0.5 * nf]
    false_frames = sum(conf_frames[t] for t in false_ids)
    false_sources = _false_track_sources(scene, reports, set(false_ids), match_gate)
    # MOTA / MOTP over present vehicles
    gt = int(present.sum())
    fn = int((present & (ids < 0)).sum())
    fp = sum(sum(1 for s in reports[k].tracks if s.status in _REPORTED) for k in range(K)) \
        - int((ids >= 0).sum())
    mota = 1.0 - (fn + fp + idsw) / gt if gt else float("nan")
    motp = float(np.nanmean(dist)) if np.any(ids >= 0) else float("nan")
    # crossing
    crossing = ""
    if scene.conflict_frame >= 0 and len(scene.pair) == 2:
        a, b = (int(np.nonzero(veh == p)[0][0]) for p in scene.pair)
        k0, k1 = scene.conflict_frame - 10, scene.conflict_frame + 10
        before, after = (ids[k0, a], ids[k0, b]), (ids[k1, a], ids[k1, b])
        if min(before) < 0 or min(after) < 0 or before[0] == before[1]:
            crossing = "break"
        elif after == before:
            crossing = "kept"
        elif after == (before[1], before[0]):
            crossing = "swap"
        else:
            crossing = "break"
    # follower (S3): the second vehicle of the pair
    follower_delay = -1
    if scene.name == "S3":
        lead, fol = (int(np.nonzero(veh == p)[0][0]) for p in scene.pair)
        full = np.nonzero(visible[:, fol])[0]
        if len(full):
            enter = full[0]
            lead_ids = set()
            for k in range(K):
                if ids[k, lead] >= 0:
                    lead_ids.add(int(ids[k, lead]))
                if k < enter:
                    continue
                tid = ids[k, fol]
                if tid >= 0 and tid not in lead_ids:
                    st = [s.status for s in reports[k].tracks if s.tid == tid][0]
                    if st == "confirmed":
                        follower_delay = k - enter
                        break
    ev = np.array([r.n_events for r in reports])
    vk = sum(r.n_valid_kin for r in reports)
    vv = sum(r.n_valid for r in reports)
    return SceneMetrics(tmr_num, tmr_den, cov, len(false_ids), false_frames, idsw, frag,
                        float(mota), motp, crossing, follower_delay, float(ev.mean()),
                        int(ev.max()), (vk - vv) / vk if vk else 0.0,
                        float(np.mean([r.assoc_ms for r in reports])), false_sources)


def _false_track_sources(scene, reports, false_ids, match_gate):
    """Attribute each false track to the clutter object nearest to it (within
    ``match_gate``) in most of its reported frames, else to ``"other"``."""
    if not false_ids:
        return ()
    clutter = np.nonzero(~np.asarray(scene.is_vehicle))[0]
    votes = {t: {} for t in false_ids}
    for k, rep in enumerate(reports):
        for s in rep.tracks:
            if s.tid not in votes or s.status not in _REPORTED:
                continue
            src = "other"
            if len(clutter):
                c = scene.xy[k, clutter]
                d = np.hypot(c[:, 0] - s.x, c[:, 1] - s.y)
                ok = scene.present[k, clutter] & (d <= match_gate)
                if ok.any():
                    src = scene.names[clutter[np.argmin(np.where(ok, d, np.inf))]]
            votes[s.tid][src] = votes[s.tid].get(src, 0) + 1
    counts = {}
    for v in votes.values():
        best = max(sorted(v), key=v.get)
        counts[best] = counts.get(best, 0) + 1
    return tuple(sorted(counts.items()))


def vehicle_mask_iou(scene, masks, margin=3):
    """IoU of the segmented foreground against every fully visible vehicle's
    rendered mask, frame by frame, inside the vehicle's box grown by
    ``margin`` px (so other objects do not count).  Returns an array of IoUs."""
    from ..detection.image import mask_iou
    K = scene.xy.shape[0]
    n0 = scene.frames.shape[0] - K
    out = []
    for k in range(K):
        lab = scene.labels[n0 + k]
        for i in np.nonzero(scene.is_vehicle)[0]:
            if not scene.visible[k, i]:
                continue
            truth = lab == i + 1
            rr, cc = np.nonzero(truth)
            r0, r1 = max(rr.min() - margin, 0), rr.max() + margin + 1
            c0, c1 = max(cc.min() - margin, 0), cc.max() + margin + 1
            out.append(mask_iou(masks[k][r0:r1, c0:c1], truth[r0:r1, c0:c1]))
    return np.array(out)


class SceneTrial(NamedTuple):
    """One Monte Carlo run of one scene: the vehicles' truth and, per tracker
    variant, its metrics and per-frame reported track positions."""
    truth_xy: np.ndarray          # (K, n_vehicles, 2)
    truth_present: np.ndarray     # (K, n_vehicles)
    metrics: dict                 # variant label -> SceneMetrics
    positions: dict               # variant label -> list of (n_k, 2) arrays


def scene_trial(rng, scene_name, variants, method="vibe"):
    """Render ``scene_name`` with ``rng``, segment it once, and run every
    tracker configuration of ``variants`` (label -> JPDATrackerConfig) on the
    same detections."""
    return scene_trials(rng, scene_name, {method: variants})[method]


def scene_trials(rng, scene_name, variants_by_method):
    """Render ``scene_name`` once with ``rng`` and, for every segmentation
    method of ``variants_by_method`` (method -> {label -> JPDATrackerConfig}),
    segment the same frames and run that method's tracker configurations.
    Methods run in the dict's order and share ``rng`` (only ``"vibe"`` draws
    from it), so ``{"vibe": v, "running_average": w}["vibe"]`` equals
    ``scene_trial(rng, scene_name, v, "vibe")``.  Returns
    ``{method: SceneTrial}``."""
    from ..trackers.jpda_tracker import run_jpda_tracker
    from .feature_scenes import render_scene, segment_scene
    if not isinstance(variants_by_method, dict) or not variants_by_method:
        raise ValueError("variants_by_method must be a non-empty dict method -> variants")
    scene = render_scene(scene_name, rng)
    veh = np.nonzero(scene.is_vehicle)[0]
    out = {}
    for method, variants in variants_by_method.items():
        dets, _ = segment_scene(scene, method, rng)
        metrics, positions = {}, {}
        for label, cfg in variants.items():
            reps = run_jpda_tracker(dets, cfg)
            metrics[label] = scene_metrics(scene, reps)
            positions[label] = [np.array([[s.x, s.y] for s in r.tracks if s.status in _REPORTED])
                                .reshape(-1, 2) for r in reps]
        out[method] = SceneTrial(scene.xy[:, veh], scene.present[:, veh], metrics, positions)
    return out
