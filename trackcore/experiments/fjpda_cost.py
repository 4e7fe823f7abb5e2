"""Feature-JPDA chapter (004): measured cluster sizes and rates, and CLEAR-MOT for the
duplicate rule (issue 29, items 6 and 2; session 11).

``fjpda-clusters-<key>``, one per ambiguity scene of :data:`CLUSTER_SCENES` (the scenes
of the ``fjpda-complexity`` rule), :data:`CLUSTER_RUNS` runs on fresh master seeds
(:data:`FJPDA_COST_SEED` + i for the i-th scene): every run renders the scene, segments
it by ViBe and runs FJPDA frame by frame; before each frame the kinematic validation of
FJPDA's tracks is recomputed with the tracker's own kernels (its pair count must equal
the frame report's ``n_valid_kin``, a check) and split into clusters.  A row holds, summed
over the frames of the run: the clusters with 1, 2, 3 and 4 or more tracks (clusters
holding at least one measurement); over the clusters with at least two tracks their
tracks, measurements, cells (sum of m_c T_c) and kinematically validated pairs; over
all frames the validated pairs and those the feature gate removed (``n_valid_kin -
n_valid``) and the events with and without the gate.  It decides the measured rates
that drive notebook 06's cluster ratios (``fjpda_events_ratio_3`` / ``_8``).

``fjpda-dup-mot``: S3 under 5 px of jitter, :data:`DUP_RUNS` runs on a fresh master seed
(:data:`FJPDA_COST_SEED` + 10): JPDA and FJPDA with and without duplicate deletion on the
same detections, each scored by py-motmetrics
(:func:`~trackcore.scenarios.feature_metrics.clear_mot_metrics`) and by the false-track
count of :func:`~trackcore.scenarios.feature_metrics.scene_metrics`.  It reports the
CLEAR-MOT ID switches with minus without the rule (paired), not deciding any rule.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scenarios.feature_metrics import MOT_METRICS, clear_mot_metrics, scene_metrics
from ._checks import check_jitter
from ._core import Experiment, register
from .registry import _Config

__all__ = [
    "CLUSTER_COLUMNS",
    "CLUSTER_RUNS",
    "CLUSTER_SCENES",
    "DUP_RUNS",
    "DUP_VARIANTS",
    "FjpdaClusterConfig",
    "FjpdaDupMotConfig",
    "cluster_instance",
    "cluster_trial",
    "dup_mot_trial",
    "events_ratio",
    "kinematic_validation",
    "pooled_rates",
    "simulated_events",
]

#: experiment key -> (scene, camera jitter in px): the scenes of the complexity rule
CLUSTER_SCENES = {
    "glare": ("glare", 5.0),
    "side-by-side": ("side_by_side", 5.0),
    "occlusion": ("occlusion", 3.0),
    "s1-jitter3": ("jitter", 3.0),
    "s1-jitter5": ("jitter", 5.0),
    "s3-jitter5": ("S3", 5.0),
}
#: runs per cluster scene (declared before running)
CLUSTER_RUNS = 100
#: runs of the duplicate-rule CLEAR-MOT store (declared before running)
DUP_RUNS = 200
#: master seed (fresh: no other experiment uses 20160325 + 500 .. + 510)
FJPDA_COST_SEED = 20160325 + 500
#: the columns of a cluster row (all int64 sums over the frames of one run)
CLUSTER_COLUMNS = ("clusters_1", "clusters_2", "clusters_3", "clusters_4plus",
                   "multi_tracks", "multi_meas", "multi_cells", "multi_pairs",
                   "pairs_kin", "pairs_removed", "events_kin", "events")
#: tracker label -> (variant, keywords of matched_config) of the duplicate-rule store
DUP_VARIANTS = {
    "JPDA": ("JPDA", {}),
    "JPDA, no duplicate deletion": ("JPDA", {"duplicate_deletion": False}),
    "FJPDA": ("FJPDA", {}),
    "FJPDA, no duplicate deletion": ("FJPDA", {"duplicate_deletion": False}),
}
_SCENES = ("jitter", "glare", "side_by_side", "occlusion", "S3")


def _check_scene(scene):
    if not isinstance(scene, str) or scene not in _SCENES:
        raise ValueError(f"scene must be one of {_SCENES}, got {scene!r}")


@dataclass(frozen=True)
class FjpdaClusterConfig(_Config):
    """One scene of the cluster measurement: ``scene`` and camera ``jitter`` (px).

    Examples
    --------
    >>> FjpdaClusterConfig("glare", 5.0).scene
    'glare'
    >>> FjpdaClusterConfig("S4", 5.0)
    Traceback (most recent call last):
        ...
    ValueError: scene must be one of ('jitter', 'glare', 'side_by_side', 'occlusion', 'S3'), got 'S4'
    """

    scene: str
    jitter: float

    _KINDS = {"scene": str, "jitter": float}  # noqa: RUF012

    def __post_init__(self):
        _check_scene(self.scene)
        check_jitter(self.jitter)


def kinematic_validation(tracker, z):
    """The (m, T) kinematic validation matrix that ``tracker`` (a
    :class:`~trackcore.trackers.jpda_tracker.JPDATracker`) will compute at its next
    :meth:`step` for the measurement positions ``z`` (m, 2), by the tracker's own
    prediction and gate kernels; the tracker is not changed.

    Examples
    --------
    >>> from trackcore.scenarios.feature_scenes import crossing_detections
    >>> from trackcore.trackers.jpda_tracker import JPDATracker, JPDATrackerConfig
    >>> detections, _ = crossing_detections(np.random.default_rng(0))
    >>> tracker = JPDATracker(JPDATrackerConfig(variant="FJPDA"))
    >>> for d in detections[:30]:
    ...     _ = tracker.step(d)
    >>> v = kinematic_validation(tracker, detections[30].z)
    >>> int(v.sum()) == tracker.step(detections[30]).n_valid_kin
    True
    """
    from ..trackers import jpda_tracker as jt

    z = np.ascontiguousarray(np.asarray(z, float).reshape(-1, 2))
    m, T = z.shape[0], len(tracker.tracks)
    valid = np.zeros((m, T), bool)
    if not m:
        return valid
    nx = tracker.F.shape[0]
    L = np.zeros((2, 2))
    gmask = np.zeros(m, np.bool_)
    d2 = np.empty(m)
    for i, tr in enumerate(tracker.tracks):
        x, P = np.empty(nx), np.empty((nx, nx))
        jt.kf_predict_kernel(tr.x, tr.P, tracker.F, tracker.Q, x, P)
        S = tracker.H @ P @ tracker.H.T + tracker.R
        if not jt.cholesky_lower_kernel(S, L):
            raise ValueError("innovation covariance lost positive definiteness")
        jt.mahalanobis_gate_kernel(z, tracker.H @ x, L, tracker.cfg.gamma, -1, gmask, d2)
        valid[:, i] = gmask
    return valid


def cluster_trial(rng, scene_name, jitter):
    """One run: ``{column: int}`` for :data:`CLUSTER_COLUMNS` (see the module
    docstring) of FJPDA on ``scene_name`` rendered with ``rng`` and segmented by ViBe.

    Examples
    --------
    The glare scene under 5 px of jitter: every cluster holds one track in this run, and
    the feature gate removes 29 of the 92 kinematically validated pairs:

    >>> import numpy as np
    >>> row = cluster_trial(np.random.default_rng(0), "glare", 5.0)
    >>> row["clusters_1"], row["clusters_2"], row["pairs_kin"], row["pairs_removed"]
    (63, 0, 92, 29)
    """
    from ..association.jpda import _clusters
    from ..scenarios.feature_scenes import render_scene, segment_scene
    from ..trackers.jpda_tracker import JPDATracker, matched_config

    scene = render_scene(scene_name, rng, jitter=jitter)
    dets, _ = segment_scene(scene, "vibe", rng)
    tracker = JPDATracker(matched_config("FJPDA", float(jitter)))
    out = dict.fromkeys(CLUSTER_COLUMNS, 0)
    for k, d in enumerate(dets):
        valid = kinematic_validation(tracker, d.z)
        rep = tracker.step(d, f"detections[{k}]")
        if int(valid.sum()) != rep.n_valid_kin:
            raise RuntimeError(f"frame {k}: the recomputed kinematic validation holds "
                               f"{int(valid.sum())} pairs, the tracker {rep.n_valid_kin}")
        for trk, mea in _clusters(valid):
            if len(mea) == 0:
                continue
            n = len(trk)
            out["clusters_" + (str(n) if n < 4 else "4plus")] += 1
            if n >= 2:
                out["multi_tracks"] += n
                out["multi_meas"] += len(mea)
                out["multi_cells"] += n * len(mea)
                out["multi_pairs"] += int(valid[np.ix_(mea, trk)].sum())
        out["pairs_kin"] += rep.n_valid_kin
        out["pairs_removed"] += rep.n_valid_kin - rep.n_valid
        out["events_kin"] += rep.n_events_kin
        out["events"] += rep.n_events
    return out


def _cluster_call(config):
    return (config.scene, float(config.jitter)), {}


def _cluster_extract(out, config):
    return {c: np.int64(out[c]) for c in CLUSTER_COLUMNS}


@dataclass(frozen=True)
class FjpdaDupMotConfig(_Config):
    """The duplicate-rule CLEAR-MOT runs: ``scene`` and camera ``jitter`` (px).

    Examples
    --------
    >>> list(FjpdaDupMotConfig().variants())
    ['JPDA', 'JPDA, no duplicate deletion', 'FJPDA', 'FJPDA, no duplicate deletion']
    """

    scene: str = "S3"
    jitter: float = 5.0

    _KINDS = {"scene": str, "jitter": float}  # noqa: RUF012

    def __post_init__(self):
        _check_scene(self.scene)
        check_jitter(self.jitter)

    def variants(self) -> dict:
        """``{label: JPDATrackerConfig}`` of :data:`DUP_VARIANTS`."""
        from ..trackers.jpda_tracker import matched_config

        return {label: matched_config(v, float(self.jitter), **kw)
                for label, (v, kw) in DUP_VARIANTS.items()}


def dup_mot_trial(rng, scene_name, variants, jitter):
    """One run: ``{label: (false tracks, py-motmetrics dict)}`` on the same detections.

    Examples
    --------
    S3 under 5 px of jitter, JPDA and FJPDA with and without duplicate deletion:

    >>> import numpy as np
    >>> c = FjpdaDupMotConfig()
    >>> out = dup_mot_trial(np.random.default_rng(0), c.scene, c.variants(), c.jitter)
    >>> {k: (ft, int(mot["num_switches"])) for k, (ft, mot) in out.items()}
    ... # doctest: +NORMALIZE_WHITESPACE
    {'JPDA': (1, 2), 'JPDA, no duplicate deletion': (1, 2), 'FJPDA': (2, 4),
     'FJPDA, no duplicate deletion': (2, 4)}
    """
    from ..scenarios.feature_metrics import scene_run

    scene, _, reports = scene_run(rng, scene_name, variants, jitter=jitter)
    return {label: (scene_metrics(scene, reps).false_tracks, clear_mot_metrics(scene, reps))
            for label, reps in reports.items()}


def _dup_call(config):
    return (config.scene, config.variants(), float(config.jitter)), {}


def _dup_extract(out, config):
    row = {}
    for label, (ft, mot) in out.items():
        row[f"{label}.false_tracks"] = np.int64(ft)
        for name in MOT_METRICS:
            row[f"{label}.mm_{name}"] = np.float64(mot[name])
    return row


_NB06 = "book/004-feature-jpda/06-complexity.ipynb"
for _i, (_key, (_scene, _jitter)) in enumerate(CLUSTER_SCENES.items()):
    register(Experiment(
        name=f"fjpda-clusters-{_key}",
        description=(f"Feature-JPDA chapter, measured cluster sizes and validation and "
                     f"feature-gate rates of FJPDA, {_key}"),
        trial=cluster_trial, call=_cluster_call, extract=_cluster_extract,
        config=FjpdaClusterConfig(_scene, _jitter), seed=FJPDA_COST_SEED + _i,
        runs=CLUSTER_RUNS, version="1", notebook=_NB06))

register(Experiment(
    name="fjpda-dup-mot",
    description=("Feature-JPDA chapter, S3 under 5 px of jitter: CLEAR-MOT of JPDA and "
                 "FJPDA with and without duplicate deletion on the same detections"),
    trial=dup_mot_trial, call=_dup_call, extract=_dup_extract,
    config=FjpdaDupMotConfig(), seed=FJPDA_COST_SEED + 10, runs=DUP_RUNS,
    version="1", notebook="book/004-feature-jpda/05-scene-results.ipynb"))


# ---------------------------------------------------------------- analysis (06)
def pooled_rates(rows):
    """The declared rates of the measured clusters, pooled over ``rows`` (stores or
    mappings ``column -> per-run array`` of ``fjpda-clusters-*``): ``p`` validated
    pairs per cell of the clusters of two or more tracks (NaN without such a cluster),
    ``r`` the share of validated pairs the feature gate removes, ``clutter`` the extra
    measurements per multi-track cluster (at least 0, NaN without such a cluster) and
    ``n_multi`` the number of those clusters.

    Examples
    --------
    >>> row = dict.fromkeys(CLUSTER_COLUMNS, np.array([0, 0]))
    >>> row.update(clusters_2=np.array([1, 1]), multi_tracks=np.array([2, 2]),
    ...            multi_meas=np.array([3, 2]), multi_cells=np.array([6, 4]),
    ...            multi_pairs=np.array([4, 3]), pairs_kin=np.array([6, 4]),
    ...            pairs_removed=np.array([1, 1]))
    >>> {k: round(v, 3) for k, v in pooled_rates([row]).items()}
    {'p': 0.7, 'r': 0.2, 'clutter': 0.5, 'n_multi': 2}
    """
    tot = {c: 0 for c in CLUSTER_COLUMNS}
    for row in rows:
        for c in CLUSTER_COLUMNS:
            tot[c] += int(np.sum(np.asarray(row[c], dtype=np.int64)))
    n_multi = tot["clusters_2"] + tot["clusters_3"] + tot["clusters_4plus"]
    nan = float("nan")
    return {
        "p": tot["multi_pairs"] / tot["multi_cells"] if tot["multi_cells"] else nan,
        "r": tot["pairs_removed"] / tot["pairs_kin"] if tot["pairs_kin"] else nan,
        "clutter": (max(0.0, (tot["multi_meas"] - tot["multi_tracks"]) / n_multi)
                    if n_multi else nan),
        "n_multi": n_multi,
    }


def cluster_instance(rng, T, p, r, clutter):
    """One simulated cluster of notebook 06's model: ``T`` targets, ``m = T +
    Poisson(clutter)`` measurements (measurement t is target t's, the rest clutter),
    every pair validated with probability ``p``; in the gated matrix a wrong pair also
    fails the feature gate with probability ``r``.  Returns ``(valid, gated)`` (m, T).

    Examples
    --------
    >>> v, g = cluster_instance(np.random.default_rng(0), 3, 0.7, 0.5, 2.0)
    >>> v.shape[1], bool(np.all(g <= v))
    (3, True)
    """
    m = T + rng.poisson(clutter)
    valid = rng.random((m, T)) < p
    wrong = np.ones((m, T), bool)
    idx = np.arange(T)
    wrong[idx, idx] = False
    gated = valid & ~(wrong & (rng.random((m, T)) < r))
    return valid, gated


def simulated_events(rng, T, n, p, r, clutter):
    """Feasible events of ``n`` clusters of :func:`cluster_instance`, without and with
    the feature gate: two arrays of length ``n``.

    Examples
    --------
    >>> plain, feat = simulated_events(np.random.default_rng(0), 3, 5, 0.7, 0.5, 2.0)
    >>> plain.shape, bool(np.all(feat <= plain))
    ((5,), True)
    """
    from ..association import feasible_event_count

    plain, feat = np.zeros(n), np.zeros(n)
    for i in range(n):
        v, g = cluster_instance(rng, T, p, r, clutter)
        plain[i], feat[i] = feasible_event_count(v), feasible_event_count(g)
    return plain, feat


def events_ratio(plain, gated):
    """``ratio_ci(plain, gated)`` (paired ratio of means), or where it refuses the runs
    (too few, or all equal) the ratio of means as a
    :class:`~trackcore.experiments.fjpda_readings.NoInterval` (NaN without runs).

    Examples
    --------
    >>> format(events_ratio([3, 3], [2, 2]), ".2f")
    '1.50 (no interval)'
    >>> format(events_ratio([], []), ".2f")
    'nan (no interval)'
    """
    from ..stats import ratio_ci
    from .fjpda_readings import NoInterval

    x, y = np.asarray(plain, float), np.asarray(gated, float)
    try:
        return ratio_ci(x, y)
    except ValueError:
        return NoInterval(x.mean() / y.mean() if x.size and y.mean() > 0 else float("nan"))
