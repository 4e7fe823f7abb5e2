"""Track-quality measures for the feature-JPDA scenes.

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
  attributed to the clutter object (bar, foliage, glare) nearest to it, within
  ``match_gate``, in most of those frames; failing a clutter object, to
  ``"vehicle"`` if a vehicle lies within ``match_gate`` (a duplicate of a
  vehicle's track, or a fragment of its blob), else to ``"other"`` (speckle);
* ID switches, fragmentations, MOTA and MOTP after CLEAR-MOT, but from the
  per-frame matching above, which has no continuity rule (a still-valid match is
  not kept), so a nearby false or duplicate track that is momentarily closer takes
  the match and counts switches; :func:`clear_mot_metrics` gives the standard
  CLEAR-MOT and identity measures computed by py-motmetrics;
* crossing outcome (kept / swap / break): the pair's track IDs at the two ends of
  the scene's score window (10 frames either side of a crossing);
* follower: frames from the follower's full entry until it has its own
  confirmed track (one never matched to the leader before);
* complexity: feasible joint events per frame, and the share of kinematically
  validated pairs that the feature gate removed.

:func:`scene_trial` renders a scene once, segments it once and runs several tracker
configurations on the same detections; :func:`paired_comparison` decides one variant
against another on paired runs (an interval of the mean paired difference and an
exact sign test).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..core.validation import as_array, as_int, as_positive

from ..stats import Estimate, mcnemar_exact, paired_diff_ci
from .feature_scenes import check_scene

__all__ = ["SceneMetrics", "match_tracks", "scene_metrics", "vehicle_mask_iou",
           "SameFrames", "same_frames_error",
           "MOT_METRICS", "clear_mot_metrics", "HOTA_METRICS", "hota_metrics",
           "SceneTrial", "scene_trial", "scene_trials", "scene_run",
           "PairedComparison", "paired_comparison", "crossing_trial"]

_REPORTED = ("confirmed", "memory")


class SceneMetrics(NamedTuple):
    """The measures of one tracker run over one scene (see the module docstring), as
    :func:`scene_metrics` returns them; ``tmr`` is ``tmr_num / tmr_den``.

    Examples
    --------
    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> from trackcore.trackers.jpda_tracker import run_jpda_tracker
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> m = scene_metrics(scene, run_jpda_tracker(detections))
    >>> m.tmr_num, m.tmr_den, round(m.tmr, 3), m.crossing
    (71, 114, 0.623, 'break')
    """
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
    mean_events_kin: float = float("nan")  # events per frame of the same tracks without the
                                           # feature gate (kinematic validation only)

    @property
    def tmr(self):
        """Track maintenance rate of this sequence (NaN if no eligible frame)."""
        return self.tmr_num / self.tmr_den if self.tmr_den else float("nan")

    @property
    def events_per_frame(self):
        """Mean feasible joint events per frame, summed over clusters."""
        return self.mean_events

    @property
    def swapped(self):
        """Whether the pair's track IDs were exchanged across the score window."""
        return self.crossing == "swap"

    @property
    def kept(self):
        """Whether the pair kept their track IDs across the score window."""
        return self.crossing == "kept"


def match_tracks(truth_xy, truth_present, reports, match_gate=10.0):
    """Per frame, the matched track ID of every truth object (-1 = none) and
    the distances: returns ``(ids (K, n) int, dist (K, n))``.  ``truth_xy`` is
    (K, n, 2), ``truth_present`` (K, n) and ``reports`` holds at least K frames.

    Examples
    --------
    Two vehicles cross at frame 30 of a measurement-level crossing.  Around it, the
    track matched to each (-1: none within 10 px): vehicle 0 passes from track 3 to
    track 2, which vehicle 1 held until then; vehicle 1 is then mostly unmatched:

    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> from trackcore.trackers.jpda_tracker import run_jpda_tracker
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> ids, dist = match_tracks(scene.xy, scene.present, run_jpda_tracker(detections))
    >>> ids.shape
    (60, 2)
    >>> ids[25:35].T
    array([[ 3,  3,  3,  3,  3,  2,  2, -1,  2,  2],
           [ 2,  2,  2,  2,  2, -1, -1,  2, -1, -1]])
    """
    truth_present = np.asarray(truth_present)
    if truth_present.ndim != 2 or truth_present.dtype != np.bool_:
        raise ValueError("truth_present must be a 2-D boolean array (K, n), got "
                         f"shape {truth_present.shape} and dtype {truth_present.dtype}")
    K, n = truth_present.shape
    truth_xy = as_array(truth_xy, "truth_xy", shape=(K, n, 2), finite=False)
    if np.any(~np.isfinite(truth_xy[truth_present])):
        raise ValueError("truth_xy must be finite wherever truth_present is True")
    if len(reports) < K:
        raise ValueError(f"reports must hold at least K = {K} frames, got {len(reports)}")
    match_gate = as_positive(match_gate, "match_gate")
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


class SameFrames(NamedTuple):
    """Tracker A against tracker B on the same frames of one sequence, as
    :func:`same_frames_error` returns it: ``pairs`` (vehicle, frame) pairs where both
    have a track matched to the vehicle, ``diff_sum`` the sum over them of
    ``err_A - err_B`` (px), and beside it each tracker's own-frames MOTP (``own_a``,
    ``own_b``, px, NaN without a match; the ``motp`` of :func:`scene_metrics`) over its
    ``matched_a`` (``matched_b``) matched pairs.  ``diff`` is the mean difference over
    the common pairs (NaN when there is none).

    Examples
    --------
    >>> r = SameFrames(4, -2.0, 1.5, 2.0, 6, 4)
    >>> r.diff, round(r.own_a - r.own_b, 2)
    (-0.5, -0.5)
    """
    pairs: int
    diff_sum: float
    own_a: float
    own_b: float
    matched_a: int
    matched_b: int

    @property
    def diff(self):
        """Mean ``err_A - err_B`` (px) over the common pairs (NaN if none)."""
        return self.diff_sum / self.pairs if self.pairs else float("nan")


def same_frames_error(dist_a, dist_b):
    """The position errors of two trackers on the same frames of one sequence.

    ``dist_a`` and ``dist_b`` are the (K, n) distances of :func:`match_tracks` for the
    two trackers' reports against the same vehicles (NaN where no track is matched: the
    match rule of :func:`scene_metrics`'s MOTP).  Over the (vehicle, frame) pairs where
    BOTH have a matched track, the sum of ``err_A - err_B``; the own-frames MOTP of each
    (the mean over its own matched pairs, as :func:`scene_metrics` computes it) beside.
    Where the two keep the vehicles in different frames, the own-frames difference
    compares different frames; the same-frames one does not.  A sequence with no
    common pair has ``pairs == 0`` (its ``diff`` is NaN: it contributes nothing).

    Examples
    --------
    FJPDA against JPDA on the measurement-level crossing: here both keep the vehicles
    in the same 89 (vehicle, frame) pairs, so the two differences agree:

    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> from trackcore.trackers.jpda_tracker import JPDATrackerConfig, run_jpda_tracker
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> dist = {v: match_tracks(scene.xy, scene.present, run_jpda_tracker(
    ...     detections, JPDATrackerConfig(variant=v)))[1] for v in ("FJPDA", "JPDA")}
    >>> r = same_frames_error(dist["FJPDA"], dist["JPDA"])
    >>> r.pairs, r.matched_a, r.matched_b, round(r.diff, 4), round(r.own_a - r.own_b, 4)
    (89, 89, 89, 0.011, 0.011)

    Where A keeps a vehicle in frames B loses, the own-frames difference can point the
    other way (A: 0.5 px in frames 0-4, 3 px in 5-9; B only in 5-9, at 2.5 px):

    >>> a = np.array([[0.5]] * 5 + [[3.0]] * 5)
    >>> b = np.array([[np.nan]] * 5 + [[2.5]] * 5)
    >>> r = same_frames_error(a, b)
    >>> r.pairs, r.diff, r.own_a - r.own_b
    (5, 0.5, -0.75)
    """
    a = np.asarray(dist_a, float)
    b = np.asarray(dist_b, float)
    if a.ndim != 2 or a.shape != b.shape:
        raise ValueError(f"dist_a and dist_b must be 2-D arrays (K, n) of one shape, got "
                         f"{a.shape} and {b.shape}")
    if np.any(a[~np.isnan(a)] < 0) or np.any(b[~np.isnan(b)] < 0) \
            or np.any(np.isinf(a)) or np.any(np.isinf(b)):
        raise ValueError("dist_a and dist_b must hold distances >= 0 or NaN (unmatched)")
    ma, mb = ~np.isnan(a), ~np.isnan(b)
    both = ma & mb
    own_a = float(np.nanmean(a)) if ma.any() else float("nan")
    own_b = float(np.nanmean(b)) if mb.any() else float("nan")
    return SameFrames(int(both.sum()), float(np.sum(a[both] - b[both])), own_a, own_b,
                      int(ma.sum()), int(mb.sum()))


def scene_metrics(scene, reports, match_gate=10.0):
    """All measures of one tracker run over one scene (vehicles are the truth).

    Examples
    --------
    The paper's FJPDA on a measurement-level crossing of a van and a sedan:

    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> from trackcore.trackers.jpda_tracker import run_jpda_tracker
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> m = scene_metrics(scene, run_jpda_tracker(detections))
    >>> round(m.tmr, 3), m.false_tracks, m.id_switches, round(m.mota, 3), m.crossing
    (0.623, 0, 2, 0.725, 'break')
    """
    check_scene(scene)
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
    window = tuple(getattr(scene, "score_window", (-1, -1)) or (-1, -1))
    if window[0] < 0 and scene.conflict_frame >= 0:
        window = (scene.conflict_frame - 10, scene.conflict_frame + 10)
    if window[0] >= 0 and len(scene.pair) == 2:
        a, b = (int(np.nonzero(veh == p)[0][0]) for p in scene.pair)
        k0, k1 = window
        if k1 >= K:
            raise ValueError(f"scene's crossing score window {window} ends past its {K} "
                             f"frames (a conflict frame needs 10 frames after it)")
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
                        float(np.mean([r.assoc_ms for r in reports])), false_sources,
                        float(np.mean([r.n_events_kin for r in reports])))


def _false_track_sources(scene, reports, false_ids, match_gate):
    """Attribute each false track to the clutter object nearest to it (within
    ``match_gate``) in most of its reported frames; failing one, to ``"vehicle"``
    if a vehicle lies within ``match_gate``; else to ``"other"``."""
    if not false_ids:
        return ()
    clutter = np.nonzero(~np.asarray(scene.is_vehicle))[0]
    vehicles = np.nonzero(np.asarray(scene.is_vehicle))[0]
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
            if src == "other" and len(vehicles):
                v = scene.xy[k, vehicles]
                dv = np.hypot(v[:, 0] - s.x, v[:, 1] - s.y)
                if np.any(scene.present[k, vehicles] & (dv <= match_gate)):
                    src = "vehicle"
            votes[s.tid][src] = votes[s.tid].get(src, 0) + 1
    counts = {}
    for v in votes.values():
        best = max(sorted(v), key=v.get)
        counts[best] = counts.get(best, 0) + 1
    return tuple(sorted(counts.items()))


#: The measures of :func:`clear_mot_metrics` (py-motmetrics names).
MOT_METRICS = ("mota", "motp", "num_switches", "num_fragmentations", "idf1",
               "mostly_tracked", "mostly_lost", "num_unique_objects")


def clear_mot_metrics(scene, reports, match_gate=10.0):
    """CLEAR-MOT (MOTA, MOTP in px, ID switches, fragmentations), IDF1 and the
    mostly tracked / mostly lost counts of one tracker run over one scene, computed
    by py-motmetrics: the vehicles present in a frame are the objects, the
    confirmed and memory tracks the hypotheses, matched on Euclidean distance up to
    ``match_gate`` px.  Unlike :func:`match_tracks`, CLEAR-MOT keeps a frame's
    match if it is still within the gate at the next frame, so a momentarily closer
    track does not take it.  Returns ``{name: value}`` for :data:`MOT_METRICS`
    (MOTP in px, not squared).

    Examples
    --------
    The same run as in :func:`scene_metrics`'s example, by py-motmetrics (which keeps a
    match while it stays in the gate: one switch, not two):

    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> from trackcore.trackers.jpda_tracker import run_jpda_tracker
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> mot = clear_mot_metrics(scene, run_jpda_tracker(detections))
    >>> round(mot["mota"], 3), mot["num_switches"], round(mot["idf1"], 3)
    (0.733, 1.0, 0.727)
    """
    import motmetrics as mm

    check_scene(scene)
    veh = np.nonzero(scene.is_vehicle)[0]
    K = scene.xy.shape[0]
    # the same checks of the arguments as the per-frame matching
    match_tracks(scene.xy[:, veh], scene.present[:, veh], reports, match_gate)
    match_gate = float(match_gate)
    acc = mm.MOTAccumulator(auto_id=True)
    for k in range(K):
        objs = [int(o) for o in veh if scene.present[k, o]]
        tr = [s for s in reports[k].tracks if s.status in _REPORTED]
        D = np.full((len(objs), len(tr)), np.nan)
        if objs and tr:
            P = np.array([[s.x, s.y] for s in tr])
            X = scene.xy[k, objs]
            D = np.hypot(X[:, None, 0] - P[None, :, 0], X[:, None, 1] - P[None, :, 1])
            D[D > match_gate] = np.nan
        acc.update(objs, [s.tid for s in tr], D)
    out = _mot_host().compute(acc, metrics=list(MOT_METRICS), return_dataframe=False)
    return {name: float(out[name]) for name in MOT_METRICS}


_MOT_HOST = []   # py-motmetrics' metrics host, made once per process (it keeps no state)


def _mot_host():
    """py-motmetrics' ``metrics.create()``, made at the first call and reused: building
    it registers every metric again (about 3 ms, a tenth of a call of
    :func:`clear_mot_metrics`), and its ``compute`` keeps its cache per call."""
    if not _MOT_HOST:
        import motmetrics as mm

        _MOT_HOST.append(mm.metrics.create())
    return _MOT_HOST[0]


#: The measures of :func:`hota_metrics` (TrackEval's names; each the mean over its
#: 19 localisation thresholds alpha = 0.05, 0.10, ..., 0.95, as TrackEval reports them).
HOTA_METRICS = ("HOTA", "DetA", "AssA")


def hota_metrics(scene, reports, match_gate=10.0):
    """HOTA, DetA and AssA of one tracker run over one scene, computed by
    TrackEval's HOTA (the ``trackeval`` package): the vehicles present in a frame are
    the ground truth, the confirmed and memory tracks the tracker's detections, and
    the similarity of a vehicle and a track is ``max(0, 1 - d / match_gate)`` for
    their centroid distance ``d`` px (1 on the vehicle, 0 at and beyond the gate),
    so HOTA's threshold alpha asks for ``d <= (1 - alpha) match_gate``.  Returns
    ``{name: value}`` for :data:`HOTA_METRICS`, each the mean over alpha.

    Examples
    --------
    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> from trackcore.trackers.jpda_tracker import run_jpda_tracker
    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> {k: round(v, 3) for k, v in hota_metrics(scene, run_jpda_tracker(detections)).items()}
    {'HOTA': 0.65, 'DetA': 0.674, 'AssA': 0.627}
    """
    check_scene(scene)
    veh = np.nonzero(scene.is_vehicle)[0]
    K = scene.xy.shape[0]
    match_tracks(scene.xy[:, veh], scene.present[:, veh], reports, match_gate)
    match_gate = float(match_gate)
    frames = []
    for k in range(K):
        objs = [int(o) for o in veh if scene.present[k, o]]
        tr = [s for s in reports[k].tracks if s.status in _REPORTED]
        sim = np.zeros((len(objs), len(tr)))
        if objs and tr:
            P = np.array([[s.x, s.y] for s in tr])
            X = scene.xy[k, objs]
            D = np.hypot(X[:, None, 0] - P[None, :, 0], X[:, None, 1] - P[None, :, 1])
            sim = np.maximum(0.0, 1.0 - D / match_gate)
        frames.append((objs, [s.tid for s in tr], sim))
    return _trackeval_hota(frames)


def _trackeval_hota(frames):
    """TrackEval's HOTA of one sequence given per frame ``(gt ids, tracker ids,
    similarity (n_gt, n_tracker))``: the ids are relabelled 0..n-1 as TrackEval
    expects; returns the means over alpha of :data:`HOTA_METRICS`."""
    from trackeval.metrics import HOTA

    gt_map, tr_map = {}, {}
    gt_ids, tr_ids, sims = [], [], []
    for g, t, s in frames:
        gt_ids.append(np.array([gt_map.setdefault(i, len(gt_map)) for i in g], int))
        tr_ids.append(np.array([tr_map.setdefault(i, len(tr_map)) for i in t], int))
        sims.append(np.asarray(s, float).reshape(len(g), len(t)))
    data = {"num_gt_ids": len(gt_map), "num_tracker_ids": len(tr_map),
            "num_gt_dets": sum(map(len, gt_ids)),
            "num_tracker_dets": sum(map(len, tr_ids)),
            "gt_ids": gt_ids, "tracker_ids": tr_ids, "similarity_scores": sims}
    res = HOTA().eval_sequence(data)
    return {name: float(np.mean(res[name])) for name in HOTA_METRICS}


def vehicle_mask_iou(scene, masks, margin=3):
    """IoU of the segmented foreground against every fully visible vehicle's
    rendered mask, frame by frame, inside the vehicle's box grown by
    ``margin`` px (so other objects do not count).  ``masks`` is (K, H, W), one
    foreground mask per scene frame.  Returns an array of IoUs.

    Examples
    --------
    Segmentation quality of scene S1 (selective running average): the IoU of the
    foreground with each fully visible vehicle's mask:

    >>> from trackcore.scenarios.feature_scenes import render_scene, segment_scene
    >>> scene = render_scene("S1", np.random.default_rng(0))
    >>> detections, masks = segment_scene(scene, "running_average")
    >>> iou = vehicle_mask_iou(scene, masks)
    >>> iou.size, round(float(np.median(iou)), 3), round(float(iou.min()), 3)
    (70, 1.0, 1.0)
    """
    from ..detection.image import mask_iou
    check_scene(scene)
    K = scene.xy.shape[0]
    n0 = scene.frames.shape[0] - K
    masks = np.asarray(masks)
    if masks.shape != (K,) + scene.labels.shape[1:]:
        raise ValueError(f"masks must have shape {(K,) + scene.labels.shape[1:]} (one mask "
                         f"per scene frame), got {masks.shape}")
    if masks.dtype != np.bool_:
        raise ValueError(f"masks must be boolean, got dtype {masks.dtype}")
    margin = as_int(margin, "margin", minimum=0)
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
    variant, its metrics and per-frame reported track positions.

    Examples
    --------
    What :func:`scene_trial` returns (one per run):

    >>> SceneTrial._fields
    ('truth_xy', 'truth_present', 'metrics', 'positions')
    """
    truth_xy: np.ndarray          # (K, n_vehicles, 2)
    truth_present: np.ndarray     # (K, n_vehicles)
    metrics: dict                 # variant label -> SceneMetrics
    positions: dict               # variant label -> list of (n_k, 2) arrays


def _check_variants(variants, name="variants"):
    from ..trackers.jpda_tracker import JPDATrackerConfig
    if not isinstance(variants, dict) or not variants:
        raise ValueError(f"{name} must be a non-empty dict label -> JPDATrackerConfig")
    for label, cfg in variants.items():
        if not isinstance(cfg, JPDATrackerConfig):
            raise TypeError(f"{name}[{label!r}] must be a JPDATrackerConfig, "
                            f"got {type(cfg).__name__}")


def scene_run(rng, scene_name, variants, method="vibe", jitter=None):
    """Render ``scene_name`` with ``rng`` (camera ``jitter`` in px, default the
    scene's), segment it once by ``method`` and run every tracker configuration
    of ``variants`` (label -> JPDATrackerConfig) on the same detections.
    Returns ``(scene, detections, reports)`` with ``reports`` label -> list of
    :class:`trackcore.trackers.jpda_tracker.FrameReport`.

    Examples
    --------
    Scene S1 rendered, segmented and tracked (every tracker of ``variants`` would run on
    the same detections):

    >>> from trackcore.trackers.jpda_tracker import JPDATrackerConfig
    >>> scene, detections, reports = scene_run(np.random.default_rng(0), "S1",
    ...                                        {"FJPDA": JPDATrackerConfig()},
    ...                                        method="running_average")
    >>> scene.frames.shape, len(detections), len(reports["FJPDA"])  # 10 warm-up frames
    ((80, 240, 320), 70, 70)
    >>> round(scene_metrics(scene, reports["FJPDA"]).tmr, 3)
    0.985
    """
    from ..trackers.jpda_tracker import run_jpda_tracker
    from .feature_scenes import render_scene, segment_scene
    _check_variants(variants)
    scene = render_scene(scene_name, rng, jitter=jitter)
    dets, _ = segment_scene(scene, method, rng)
    return scene, dets, {label: run_jpda_tracker(dets, cfg) for label, cfg in variants.items()}


def _trial(scene, reports):
    veh = np.nonzero(scene.is_vehicle)[0]
    metrics, positions = {}, {}
    for label, reps in reports.items():
        metrics[label] = scene_metrics(scene, reps)
        positions[label] = [np.array([[s.x, s.y] for s in r.tracks if s.status in _REPORTED])
                            .reshape(-1, 2) for r in reps]
    return SceneTrial(scene.xy[:, veh], scene.present[:, veh], metrics, positions)


def scene_trial(rng, scene_name, variants, method="vibe", jitter=None):
    """:func:`scene_run`, reduced to a :class:`SceneTrial` (metrics and positions):
    one Monte Carlo run for :func:`trackcore.montecarlo.run`.

    Examples
    --------
    One Monte Carlo run of scene S1 (a bar and a foliage blob besides the vehicles):

    >>> from trackcore.trackers.jpda_tracker import JPDATrackerConfig
    >>> trial = scene_trial(np.random.default_rng(0), "S1", {"FJPDA": JPDATrackerConfig()},
    ...                     method="running_average")
    >>> m = trial.metrics["FJPDA"]
    >>> round(m.tmr, 3), m.false_tracks, m.false_sources
    (0.985, 2, (('bar', 1), ('foliage', 1)))
    """
    scene, _, reports = scene_run(rng, scene_name, variants, method, jitter)
    return _trial(scene, reports)


def scene_trials(rng, scene_name, variants_by_method, jitter=None):
    """Render ``scene_name`` once with ``rng`` and, for every segmentation
    method of ``variants_by_method`` (method -> {label -> JPDATrackerConfig}),
    segment the same frames and run that method's tracker configurations.
    Methods run in the dict's order and share ``rng`` (only ``"vibe"`` draws
    from it), so ``{"vibe": v, "running_average": w}["vibe"]`` equals
    ``scene_trial(rng, scene_name, v, "vibe")``.  Returns
    ``{method: SceneTrial}``.

    Examples
    --------
    One rendering, one :class:`SceneTrial` per segmentation method (here one method):

    >>> from trackcore.trackers.jpda_tracker import JPDATrackerConfig
    >>> trials = scene_trials(np.random.default_rng(0), "S1",
    ...                       {"running_average": {"FJPDA": JPDATrackerConfig()}})
    >>> {method: round(t.metrics["FJPDA"].tmr, 3) for method, t in trials.items()}
    {'running_average': 0.985}
    """
    from ..trackers.jpda_tracker import run_jpda_tracker
    from .feature_scenes import render_scene, segment_scene
    if not isinstance(variants_by_method, dict) or not variants_by_method:
        raise ValueError("variants_by_method must be a non-empty dict method -> variants")
    for method, variants in variants_by_method.items():
        _check_variants(variants, f"variants_by_method[{method!r}]")
    scene = render_scene(scene_name, rng, jitter=jitter)
    out = {}
    for method, variants in variants_by_method.items():
        dets, _ = segment_scene(scene, method, rng)
        out[method] = _trial(scene, {label: run_jpda_tracker(dets, cfg)
                                     for label, cfg in variants.items()})
    return out


def crossing_trial(rng, variants, **crossing_kwargs):
    """One run of the measurement-level crossing: draw the detections of
    :func:`trackcore.scenarios.feature_scenes.crossing_detections` (keyword
    arguments passed on) and run every tracker configuration of ``variants`` on
    them.  Returns ``{label: SceneMetrics}``.

    Examples
    --------
    >>> from trackcore.trackers.jpda_tracker import JPDATrackerConfig
    >>> out = crossing_trial(np.random.default_rng(0), {"FJPDA": JPDATrackerConfig(),
    ...                      "GNN": JPDATrackerConfig(variant="GNN")}, n_frames=40, conflict=20)
    >>> {k: (round(m.tmr, 3), m.crossing) for k, m in out.items()}
    {'FJPDA': (0.608, 'break'), 'GNN': (0.608, 'break')}
    """
    from ..trackers.jpda_tracker import run_jpda_tracker
    from .feature_scenes import crossing_detections
    _check_variants(variants)
    dets, scene = crossing_detections(rng, **crossing_kwargs)
    return {label: scene_metrics(scene, run_jpda_tracker(dets, cfg))
            for label, cfg in variants.items()}


class PairedComparison(NamedTuple):
    """Variant A against variant B on the same runs (seeds).

    ``mean_a``, ``mean_b``: the means over runs; ``diff``: the paired BCa interval
    of mean(A) - mean(B); ``a_better`` / ``b_better``: runs where A (B) did
    strictly better; ``p_sign``: exact two-sided sign test (McNemar on the runs
    that differ); ``verdict``: ``"A better"``, ``"B better"`` (with the names
    given) or ``"tie"``, decided by the interval of the difference.

    Examples
    --------
    What :func:`paired_comparison` returns:

    >>> rng = np.random.default_rng(0)
    >>> a = rng.poisson(0.5, 40)
    >>> c = paired_comparison(a, a + rng.poisson(1.0, 40), names=("FJPDA", "JPDA"))
    >>> c.a, c.b, round(c.mean_a, 3), round(c.mean_b, 3), c.a_better, c.b_better
    ('FJPDA', 'JPDA', 0.6, 1.825, 29, 0)
    """
    a: str
    b: str
    mean_a: float
    mean_b: float
    diff: Estimate
    a_better: int
    b_better: int
    p_sign: float
    verdict: str


def paired_comparison(x, y, names=("A", "B"), lower_is_better=True):
    """Decide A (per-run values ``x``) against B (``y``, same runs): the paired
    interval of the mean difference decides (a tie unless it excludes 0); the
    exact sign test on the runs that differ is reported beside it.

    Examples
    --------
    Per-run ID switches of two trackers on the same 40 runs (lower is better; at least
    40 runs are needed for the interval): A has fewer on every run that differs:

    >>> rng = np.random.default_rng(0)
    >>> a = rng.poisson(0.5, 40)
    >>> b = a + rng.poisson(1.0, 40)
    >>> c = paired_comparison(a, b, names=("FJPDA", "JPDA"))
    >>> c.verdict, c.a_better, c.b_better, f"{c.p_sign:.1e}"
    ('FJPDA better', 29, 0, '3.7e-09')
    >>> round(c.diff.value, 3), c.diff.hi < 0  # the interval of mean(A) - mean(B) excludes 0
    (-1.225, True)
    """
    x = as_array(x, "x", ndim=1)
    y = as_array(y, "y", ndim=1)
    if x.size != y.size or x.size < 2:
        raise ValueError(f"x and y must be paired runs of equal length >= 2, "
                         f"got {x.size} and {y.size}")
    if len(names) != 2 or not all(isinstance(v, str) for v in names):
        raise TypeError("names must be two strings")
    d = paired_diff_ci(x, y)
    sign = 1.0 if lower_is_better else -1.0
    a_better = int(np.sum(sign * (x - y) < 0))
    b_better = int(np.sum(sign * (x - y) > 0))
    if d.hi < 0 or d.lo > 0:
        a_wins = (d.hi < 0) == lower_is_better
        verdict = f"{names[0]} better" if a_wins else f"{names[1]} better"
    else:
        verdict = "tie"
    return PairedComparison(names[0], names[1], float(x.mean()), float(y.mean()), d,
                            a_better, b_better, mcnemar_exact(a_better, b_better), verdict)
