"""Feature-JPDA chapter (004): the duplicate-track rule (the paper's Fig 8 and its
conclusion) under every reading (issue 29, session 14).

``fjpda-dup-readings``: S3 under 5 px of camera jitter (the scene of
``fjpda-scenes-s3-jitter5``, ``fjpda-dup-mot`` and ``fjpda-confirm-s3``),
:data:`DUP_READINGS_RUNS` runs on a fresh master seed (:data:`FJPDA_DUP_READINGS_SEED`).
Every run is one run of :func:`~trackcore.experiments.fjpda_oat.oat_trial` restricted to
that scene: rendered once, segmented by ViBe (first) and by the running average, and on
those detections, per cell, each tracker runs **with** the duplicate rule (the chapter's
default, ``d_dup`` 5 px, ``dup_frames`` 3) and **without** it (``duplicate_deletion=False``,
as ``fjpda-scenes-s3-jitter5`` and ``fjpda-dup-mot`` build it).  The cells
(:data:`DUP_VALUES`) are the declared design of the neighbouring claims: the
correlation x template grid (:data:`GRID`, FJPDA only: JPDA uses no rho, so its one cell,
the default, stands for every grid cell) and, from the default cell, every other value
of the other readings varied one at a time for both trackers (those of
:data:`~trackcore.experiments.fjpda_oat.VARIED`, the measurement "position and velocity"
and the duplicate distance 2 px).  The duplicate distance 2 px changes ``d_dup`` of the
"with" arm only: without the rule ``d_dup`` is never read, so that cell's "without" arm is
the default cell's.  Every config comes from the existing builders
(:func:`~trackcore.trackers.jpda_tracker.matched_config` through
:class:`~trackcore.experiments.fjpda_oat.FjpdaOatConfig`).

A row holds the scene index (``scene``, always 0) and, per tracker label ``"<arm>
<value>"`` (arm ``JPDA``, ``FJPDA``, ``JPDA nodup`` or ``FJPDA nodup``), the columns of
``fjpda-oat`` (``V.<field>``, ``V.false_<source>``, ``V.motp``) and the follower's delay
``V.follower_delay`` (frames from its full entry until its own confirmed track, -1 for
never: :class:`~trackcore.scenarios.feature_metrics.SceneMetrics`).  Since version 2
(session 15) a row also holds the follower's full-entry frame ``follower_entry``
(:func:`follower_entry`, -1 if never fully visible) and, per tracker label **with** the rule
(arm ``JPDA`` or ``FJPDA``), the frame of its first duplicate deletion
``V.first_dup_deletion`` (:func:`first_deletion`, -1 for none); the trial
(:func:`dup_trial`) is :func:`~trackcore.experiments.fjpda_oat.oat_trial`'s, with the same
draws, keeping the scene and the trackers' frame reports for these two columns, so every
other column is unchanged.

:func:`dup_rule_effect` is the comparison notebook 05 makes for the default cell (the
follower tracked within 10 frames, with minus without, its interval and exact McNemar
test; the false tracks with minus without), moved here so that notebook 11 applies the
same computation to every cell.  :func:`premise_seeds` marks the seeds on which the run
with the rule deletes a duplicate before the follower's full entry (the premise of the
measure ``dup-follow-premise``, session 15), :func:`premise_effect` applies
:func:`dup_rule_effect` to them, and :func:`removed_share` is the share of false tracks the
rule removes (the size reported beside ``fjpda-conclusion-duplicates``).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ._core import Experiment, register
from .fjpda_oat import (
    FJPDA_CALIBRATION_SEED,
    FJPDA_OAT_SEED,
    OAT_SCENES,
    VARIED,
    FjpdaOatConfig,
    _oat_call,
    _oat_extract,
)
from .fjpda_oat_vel import FJPDA_OAT_DUP_SEED, FJPDA_OAT_VEL_SEED, VARIED_DUP, VARIED_VEL
from .fjpda_readings import CELLS, READING_VARIANTS
from .fjpda_templates import NEW_CELLS, TEMPLATE_VARIANTS

__all__ = ["DUP_READINGS_RUNS", "DUP_VALUES", "FJPDA_DUP_READINGS_SEED", "FOLLOW_WITHIN",
           "GRID", "NOT_APPLICABLE", "DupRuleEffect", "FjpdaDupReadingsConfig", "cell_label",
           "dup_rule_effect", "dup_trial", "first_deletion", "follower_entry",
           "follower_tracked", "premise_effect", "premise_seeds", "removed_share"]

_TEMPLATES = ("updated with guard", "updated without guard", "fixed first",
              "first fully visible")
_SUFFIX = {"updated with guard": "u", "updated without guard": "n", "fixed first": "f",
           "first fully visible": "v"}
_LABELS = {**CELLS, **NEW_CELLS}  # glue suffix -> tracker label of the stores
_KW = {**READING_VARIANTS, **TEMPLATE_VARIANTS}  # tracker label -> (variant, keywords)
#: the correlation x template grid: glue suffix -> (correlation, template, FJPDA keywords
#: of matched_config), in the order of the claims' grid (correlation first); "cu" is the
#: default cell
GRID = {f"{c[0]}{_SUFFIX[t]}": (c, t, dict(_KW[_LABELS[f"{c[0]}{_SUFFIX[t]}"]][1]))
        for c in ("canvas", "sliding") for t in _TEMPLATES}
#: value key -> (reading, value as claims.yml names it, segmentation, tracker keywords):
#: the default cell, the seven other grid cells (FJPDA only), then the values varied one
#: at a time (both trackers)
DUP_VALUES = {
    "default": VARIED["default"],
    **{k: ("correlation, template", f"{c}, {t}", "vibe", kw)
       for k, (c, t, kw) in GRID.items() if k != "cu"},
    **{k: v for k, v in VARIED.items() if k != "default"},
    "pv": VARIED_VEL["pv"],
    "dd2": VARIED_DUP["dd2"],
}
#: master seed of fjpda-dup-readings (fresh: fjpda-oat + 30; fjpda-oat is + 0,
#: fjpda-confirm-s3 + 1, the calibration renders + 2 to + 7, fjpda-oat-vel + 10,
#: fjpda-oat-dup + 20)
FJPDA_DUP_READINGS_SEED = FJPDA_OAT_SEED + 30
assert FJPDA_DUP_READINGS_SEED not in (
    FJPDA_OAT_VEL_SEED, FJPDA_OAT_DUP_SEED,
    *range(FJPDA_OAT_SEED, FJPDA_CALIBRATION_SEED + len(OAT_SCENES)))
#: runs of fjpda-dup-readings (as fjpda-confirm-s3)
DUP_READINGS_RUNS = 600
#: the follower counts as tracked when its own confirmed track comes within this many
#: frames of its full entry (the measure dup-follow)
FOLLOW_WITHIN = 10
#: the glued text of a cell whose premise is absent (measure dup-follow-premise)
NOT_APPLICABLE = ("not applicable: no seed has a duplicate deleted before the follower's "
                  "full entry")


def cell_label(value):
    """The claims' cell label of a value key of :data:`DUP_VALUES` (the default cell is
    ``"canvas, updated with guard"``).

    Examples
    --------
    >>> cell_label("default"), cell_label("sf")
    ('canvas, updated with guard', 'sliding, fixed first')
    >>> cell_label("dd2")
    'canvas, updated with guard; duplicate-distance: 2 px'
    """
    reading, val, _, _ = DUP_VALUES[value]
    if value == "default":
        return "canvas, updated with guard"
    if reading == "correlation, template":
        return val
    return f"canvas, updated with guard; {reading}: {val}"


@dataclass(frozen=True)
class FjpdaDupReadingsConfig(FjpdaOatConfig):
    """:class:`~trackcore.experiments.fjpda_oat.FjpdaOatConfig` on S3 under 5 px only,
    over the values of :data:`DUP_VALUES` (``"default"`` first), each tracker with and
    without the duplicate rule.

    Examples
    --------
    >>> config = FjpdaDupReadingsConfig()
    >>> config.scenes, len(config.values)
    (('s3-jitter5',), 17)
    >>> v = config.variants(0)
    >>> sorted(v["default"][1]), sorted(v["sf"][1])
    (['FJPDA', 'FJPDA nodup', 'JPDA', 'JPDA nodup'], ['FJPDA', 'FJPDA nodup'])
    >>> sorted(v["dd2"][1]), v["dd2"][1]["JPDA"].d_dup
    (['FJPDA', 'JPDA'], 2.0)
    >>> v["mem1"][1]["FJPDA nodup"].duplicate_deletion
    False
    >>> FjpdaDupReadingsConfig(values=("default", "cx"))
    Traceback (most recent call last):
        ...
    ValueError: unknown value 'cx' in values; expected some of ('default', 'cn', 'cf', 'cv', 'su', 'sn', 'sf', 'sv', 'seg_ra', 'mem1', 'tsi', 'rho', 'rw', 'gate20', 'lam', 'pv', 'dd2')
    """

    scenes: tuple = ("s3-jitter5",)
    values: tuple = tuple(DUP_VALUES)
    _VARIED = DUP_VALUES

    def variants(self, i):
        """Scene ``i``: ``{value: (segmentation, {arm: JPDATrackerConfig})}``, arms
        ``JPDA``, ``FJPDA`` (with the rule) and ``JPDA nodup``, ``FJPDA nodup`` (without
        it); JPDA only in the default cell of the grid, no "without" arm for ``dd2``."""
        out = {}
        for v, (method, pair) in super().variants(i).items():
            arms = {}
            for t, cfg in pair.items():
                if t == "JPDA" and v in GRID:
                    continue
                arms[t] = cfg
                if v != "dd2":
                    arms[f"{t} nodup"] = dataclasses.replace(cfg, duplicate_deletion=False)
            out[v] = (method, arms)
        return out


def follower_entry(scene):
    """The follower's full entry: the first frame at which the second vehicle of the
    scene's pair (S3's follower) is fully visible, as
    :class:`~trackcore.scenarios.feature_metrics.SceneMetrics` counts ``follower_delay``
    from; -1 if it is never fully visible or the scene is not S3.

    Examples
    --------
    >>> from trackcore.scenarios.feature_scenes import render_scene
    >>> scene = render_scene("S3", np.random.default_rng(0))
    >>> k = follower_entry(scene)
    >>> fol = scene.pair[1]
    >>> bool(scene.visible[k, fol]), bool(scene.visible[:k, fol].any())
    (True, False)
    >>> follower_entry(render_scene("S2a", np.random.default_rng(0)))
    -1
    """
    from ..scenarios.feature_scenes import check_scene

    check_scene(scene)
    if scene.name != "S3":
        return -1
    veh = np.nonzero(scene.is_vehicle)[0]
    fol = int(np.nonzero(veh == scene.pair[1])[0][0])
    full = np.nonzero(scene.visible[:, veh][:, fol])[0]
    return int(full[0]) if len(full) else -1


def first_deletion(reports, reason="duplicate"):
    """The frame (``FrameReport.k``) of a tracker run's first track deletion for
    ``reason`` (``"duplicate"``: :meth:`JPDATracker._duplicates
    <trackcore.trackers.jpda_tracker.JPDATracker>`), -1 if none.

    Examples
    --------
    >>> from trackcore.trackers.jpda_tracker import FrameReport
    >>> reps = [FrameReport(k, (), 0, 0, 0, d, 0.0)
    ...         for k, d in enumerate([(), ((3, "miss"),), ((5, "duplicate"),), ()])]
    >>> first_deletion(reps), first_deletion(reps, "miss"), first_deletion(reps, "gate")
    (2, 1, -1)
    """
    for r in reports:
        if any(why == reason for _, why in r.deleted):
            return int(r.k)
    return -1


def dup_trial(rng, config):
    """One run: :func:`~trackcore.experiments.fjpda_oat.oat_trial` (the same draws and
    metrics) returning also the follower's full-entry frame and, per tracker label with
    the rule, its first duplicate deletion: ``(scene index, {label: SceneMetrics},
    follower_entry, {label: first_deletion})``.

    Examples
    --------
    >>> from trackcore.core.rng import generator_for_run
    >>> config = FjpdaDupReadingsConfig(values=("default",))
    >>> i, metrics, entry, first = dup_trial(generator_for_run(7, 1, 6), config)
    >>> i, sorted(metrics), sorted(first)
    (0, ['FJPDA default', 'FJPDA nodup default', 'JPDA default', 'JPDA nodup default'], ['FJPDA default', 'JPDA default'])
    >>> entry > 0
    True
    """
    from ..scenarios.feature_metrics import scene_metrics
    from .fjpda_oat import _oat_runs

    i, scene, runs = _oat_runs(rng, config)
    out = {label: scene_metrics(scene, reports) for label, (_, reports) in runs.items()}
    first = {label: first_deletion(reports) for label, (cfg, reports) in runs.items()
             if cfg.duplicate_deletion}
    return i, out, follower_entry(scene), first


def _extract(out, config):
    """The columns of ``fjpda-oat``, per tracker label ``follower_delay``, the follower's
    full-entry frame and, per label with the rule, its first duplicate deletion."""
    i, metrics, entry, first = out
    row = _oat_extract((i, metrics), config)
    for label, m in metrics.items():
        row[f"{label}.follower_delay"] = np.int64(m.follower_delay)
    row["follower_entry"] = np.int64(entry)
    for label, k in first.items():
        row[f"{label}.first_dup_deletion"] = np.int64(k)
    return row


def follower_tracked(delay, within=FOLLOW_WITHIN):
    """Per run, whether the follower got its own confirmed track within ``within``
    frames of its full entry (``0 <= delay <= within``; -1 is never).

    Examples
    --------
    >>> follower_tracked([-1, 0, 10, 11]).tolist()
    [False, True, True, False]
    """
    d = np.asarray(delay)
    return (d >= 0) & (d <= within)


class DupRuleEffect(NamedTuple):
    """The duplicate rule, with minus without on the same runs (:func:`dup_rule_effect`).

    Examples
    --------
    >>> e = dup_rule_effect([3, -1] * 30, [3, 3] * 30, [1] * 60, [2] * 60)
    >>> e.only_with, e.only_without, format(e.follow_with, ".2f")
    (0, 30, '0.50 [0.38, 0.62]')
    """

    follow_with: object     # share of runs with the follower tracked, with the rule (Wilson)
    follow_without: object  # the same without it
    follow_diff: object     # with minus without, paired interval (or NoInterval)
    only_with: int          # runs where only the run with the rule tracks the follower
    only_without: int       # runs where only the run without it does
    p_mcnemar: float        # exact McNemar test of only_with against only_without
    false: object           # false tracks, with minus without (a PairedComparison)


def dup_rule_effect(delay_with, delay_without, false_with, false_without,
                    within=FOLLOW_WITHIN):
    """The duplicate rule's effect on the same runs, as notebook 05 computes it for the
    default cell: the follower tracked within ``within`` frames with and without the
    rule (Wilson intervals), its paired difference with minus without
    (:func:`~trackcore.stats.paired_diff_ci`, or a
    :class:`~trackcore.experiments.fjpda_readings.NoInterval` where it has none), the
    discordant runs and their exact McNemar test, and the false tracks with minus
    without (:func:`~trackcore.experiments.fjpda_readings.compare`).

    Examples
    --------
    >>> rng = np.random.default_rng(3)
    >>> without = np.where(rng.random(60) < 0.5, 4, -1)
    >>> with_ = np.where(rng.random(60) < 0.2, 3, without)
    >>> e = dup_rule_effect(with_, without, rng.poisson(1.0, 60), rng.poisson(1.2, 60))
    >>> e.only_with, e.only_without, format(e.follow_diff, ".2f")
    (4, 0, '0.07 [0.00, 0.13]')

    No discordant run: a zero difference (0/1 runs have a paired score interval); false
    tracks equal in every run have no interval:

    >>> e = dup_rule_effect(without, without, [2] * 60, [2] * 60)
    >>> format(e.follow_diff, ".2f"), format(e.false.diff, ".2f"), e.p_mcnemar
    ('0.00 [0.00, 0.00]', '0.00 (no interval)', 1.0)
    """
    from ..stats import mcnemar_exact, paired_diff_ci, rate_ci
    from .fjpda_readings import compare, estimate

    f_with, f_without = follower_tracked(delay_with, within), follower_tracked(
        delay_without, within)
    if f_with.shape != f_without.shape:
        raise ValueError(f"paired runs needed, got {f_with.shape} and {f_without.shape}")
    n = f_with.size
    b = int(np.sum(f_with & ~f_without))
    c = int(np.sum(~f_with & f_without))
    return DupRuleEffect(
        rate_ci(int(f_with.sum()), n), rate_ci(int(f_without.sum()), n),
        estimate(paired_diff_ci, f_with.astype(float), f_without.astype(float)), b, c,
        mcnemar_exact(b, c),
        compare(np.asarray(false_with, float), np.asarray(false_without, float),
                ("with", "without")))



def premise_seeds(first_dup, entry):
    """Per run, whether the run with the rule deleted a duplicate track (at frame
    ``first_dup``, -1 for none) strictly before the follower's full entry (``entry``, -1
    for never): the premise of the measure ``dup-follow-premise``.  Both arms are the same
    run until the first deletion, so the premise holds in the run without the rule too.

    Examples
    --------
    >>> premise_seeds([-1, 3, 9, 10, 4], [8, 8, 8, 10, -1]).tolist()
    [False, True, False, False, False]
    """
    d, e = np.asarray(first_dup), np.asarray(entry)
    if d.shape != e.shape:
        raise ValueError(f"paired runs needed, got {d.shape} and {e.shape}")
    return (d >= 0) & (e >= 0) & (d < e)


def premise_effect(delay_with, delay_without, false_with, false_without, premise,
                   within=FOLLOW_WITHIN):
    """:func:`dup_rule_effect` on the premise seeds only (``premise``, a boolean mask
    from :func:`premise_seeds`), and their count: ``(DupRuleEffect or None, n)``; None
    when no seed has the premise (the cell is not applicable, :data:`NOT_APPLICABLE`).

    Examples
    --------
    >>> prem = np.array([True, False] * 30)
    >>> e, n = premise_effect([3, -1] * 30, [-1, -1] * 30, [1] * 60, [2] * 60, prem)
    >>> n, e.only_with, e.only_without, format(e.follow_with, ".2f")
    (30, 30, 0, '1.00 [0.89, 1.00]')
    >>> premise_effect([3] * 4, [3] * 4, [0] * 4, [0] * 4, [False] * 4)
    (None, 0)
    """
    m = np.asarray(premise, bool)
    cols = [np.asarray(x) for x in (delay_with, delay_without, false_with, false_without)]
    if any(c.shape != m.shape for c in cols):
        raise ValueError(f"premise has shape {m.shape}; the runs have "
                         f"{[c.shape for c in cols]}")
    n = int(m.sum())
    if n == 0:
        return None, 0
    return dup_rule_effect(*(c[m] for c in cols), within=within), n


def removed_share(false_with, false_without):
    """The share of the false tracks that the rule removes, ``(without - with) /
    without`` of the mean false tracks per sequence on paired runs, with a 95 % interval
    (``1 - ratio_ci(with, without)``, :func:`~trackcore.stats.ratio_ci`, paired: a
    studentized paired bootstrap of the ratio of means); a
    :class:`~trackcore.experiments.fjpda_readings.NoInterval` where the runs give no
    interval, None where no run has a false track without the rule (no share).

    Examples
    --------
    >>> rng = np.random.default_rng(5)
    >>> without = rng.poisson(2.0, 200)
    >>> with_ = np.maximum(without - rng.poisson(0.5, 200), 0)
    >>> format(removed_share(with_, without), ".2f")
    '0.19 [0.14, 0.23]'
    >>> removed_share([0] * 40, [0] * 40) is None
    True
    >>> format(removed_share([1] * 40, [2] * 40), ".2f")
    '0.50 (no interval)'
    """
    from ..stats import Estimate, ratio_ci
    from .fjpda_readings import NoInterval

    w, wo = np.asarray(false_with, float), np.asarray(false_without, float)
    if w.shape != wo.shape:
        raise ValueError(f"paired runs needed, got {w.shape} and {wo.shape}")
    if not wo.mean() > 0:
        return None
    try:
        r = ratio_ci(w, wo, paired=True)
    except ValueError:
        return NoInterval(1.0 - w.mean() / wo.mean())
    return Estimate(1.0 - r.value, 1.0 - r.hi, 1.0 - r.lo, r.level, r.n, r.method)

register(Experiment(
    name="fjpda-dup-readings",
    description=("Feature-JPDA chapter, the duplicate rule under every reading: S3 under "
                 "5 px, JPDA and FJPDA with and without duplicate deletion in the "
                 "correlation x template grid (FJPDA) and each value varied one at a time "
                 "from the default cell, on the same detections"),
    trial=dup_trial, call=_oat_call, extract=_extract, config=FjpdaDupReadingsConfig(),
    seed=FJPDA_DUP_READINGS_SEED, runs=DUP_READINGS_RUNS, version="2",
    notebook="book/004-feature-jpda/11-duplicate-rule-readings.ipynb"))
