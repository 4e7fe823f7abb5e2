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
never: :class:`~trackcore.scenarios.feature_metrics.SceneMetrics`).

:func:`dup_rule_effect` is the comparison notebook 05 makes for the default cell (the
follower tracked within 10 frames, with minus without, its interval and exact McNemar
test; the false tracks with minus without), moved here so that notebook 11 applies the
same computation to every cell.
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
    oat_trial,
)
from .fjpda_oat_vel import FJPDA_OAT_DUP_SEED, FJPDA_OAT_VEL_SEED, VARIED_DUP, VARIED_VEL
from .fjpda_readings import CELLS, READING_VARIANTS
from .fjpda_templates import NEW_CELLS, TEMPLATE_VARIANTS

__all__ = ["DUP_READINGS_RUNS", "DUP_VALUES", "FJPDA_DUP_READINGS_SEED", "FOLLOW_WITHIN",
           "GRID", "DupRuleEffect", "FjpdaDupReadingsConfig", "cell_label",
           "dup_rule_effect", "follower_tracked"]

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


def _extract(out, config):
    """The columns of ``fjpda-oat`` and, per tracker label, ``follower_delay``."""
    row = _oat_extract(out, config)
    for label, m in out[1].items():
        row[f"{label}.follower_delay"] = np.int64(m.follower_delay)
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


register(Experiment(
    name="fjpda-dup-readings",
    description=("Feature-JPDA chapter, the duplicate rule under every reading: S3 under "
                 "5 px, JPDA and FJPDA with and without duplicate deletion in the "
                 "correlation x template grid (FJPDA) and each value varied one at a time "
                 "from the default cell, on the same detections"),
    trial=oat_trial, call=_oat_call, extract=_extract, config=FjpdaDupReadingsConfig(),
    seed=FJPDA_DUP_READINGS_SEED, runs=DUP_READINGS_RUNS, version="1",
    notebook="book/004-feature-jpda/11-duplicate-rule-readings.ipynb"))
