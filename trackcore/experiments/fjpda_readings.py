"""Feature-JPDA chapter (004), the readings at 200 seeds per scene (issue 29).

One experiment per ambiguity scene, ``fjpda-readings-<key>``, each with 200 runs on
fresh master seeds (``FJPDA_READINGS_SEED + i`` for the i-th scene of
:data:`READINGS_SCENES`).  Every run renders the scene once, segments it once by ViBe
and runs, on the same detections, JPDA and FJPDA in the four cells of the declared
readings ``correlation`` (canvas, sliding) x ``template`` (updated with guard, fixed
first) (:data:`READING_VARIANTS`); the S3 experiment adds the ablations of the S3
loss (:data:`S3_VARIANTS`: the first fully visible template, and c_I from 0.4 to
0.8).  A row holds, per tracker, the false tracks by source (the attribution of
:func:`~trackcore.scenarios.feature_metrics.scene_metrics`), the track maintenance
counts, our ID-switch count and the joint events; for :data:`MOT_VARIANTS` also the
CLEAR-MOT and identity measures of py-motmetrics
(:func:`~trackcore.scenarios.feature_metrics.clear_mot_metrics`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scenarios.feature_metrics import MOT_METRICS, clear_mot_metrics, scene_metrics
from ._checks import check_jitter, check_names
from ._core import Experiment, register
from .registry import _Config

__all__ = [
    "CELLS",
    "FALSE_SOURCES",
    "FjpdaReadingsConfig",
    "MOT_VARIANTS",
    "READINGS_SCENES",
    "READING_VARIANTS",
    "S3_VARIANTS",
    "SCENE_KEYS",
    "NoInterval",
    "estimate",
    "per_run",
    "compare",
    "NO_TRACK",
    "confirms_nothing",
]

#: tracker label -> (variant, keywords of matched_config): the reading cells.
READING_VARIANTS = {
    "JPDA": ("JPDA", {}),
    "FJPDA": ("FJPDA", {}),
    "FJPDA, canvas, fixed": ("FJPDA", {"template_update": False}),
    "FJPDA, sliding, updated": ("FJPDA", {"correlation": "sliding"}),
    "FJPDA, sliding, fixed": ("FJPDA", {"correlation": "sliding",
                                        "template_update": False}),
}
#: the ablations of the S3 loss (``extras=("s3",)``).
S3_VARIANTS = {
    "FJPDA, canvas, first fully visible": (
        "FJPDA", {"template_update": False, "template_from": "fully_visible"}),
    **{f"FJPDA, c_I {c:.1f}": ("FJPDA", {"c_I": c}) for c in (0.4, 0.5, 0.7, 0.8)},
}
#: the trackers whose runs are also scored by py-motmetrics.
MOT_VARIANTS = ("JPDA", "FJPDA", "FJPDA, sliding, fixed")
#: the sources a false track is attributed to (a scene has only some of them).
FALSE_SOURCES = ("glare", "bar", "foliage", "vehicle", "other")
_FIELDS = {"tmr_num": np.int64, "tmr_den": np.int64, "coverage_num": np.int64,
           "false_tracks": np.int64, "id_switches": np.int64,
           "mean_events": np.float64, "mean_events_kin": np.float64,
           "valid_removed": np.float64}
_SCENES = ("jitter", "glare", "side_by_side", "occlusion", "S3")
#: experiment key -> (scene, camera jitter in px, extras)
READINGS_SCENES = {
    "glare": ("glare", 5.0, ()),
    "s3-jitter5": ("S3", 5.0, ("s3",)),
    "occlusion": ("occlusion", 3.0, ()),
    "side-by-side": ("side_by_side", 5.0, ()),
    "s1-jitter5": ("jitter", 5.0, ()),
    "s1-jitter3": ("jitter", 3.0, ()),
}


@dataclass(frozen=True)
class FjpdaReadingsConfig(_Config):
    """One scene of the readings runs: ``scene`` (a scene of
    :func:`~trackcore.scenarios.feature_scenes.render_scene` among ``jitter``,
    ``glare``, ``side_by_side``, ``occlusion``, ``S3``), camera ``jitter`` (px, the
    trackers matched to it) and ``extras`` (``("s3",)`` adds :data:`S3_VARIANTS`).

    Examples
    --------
    S3 runs the four reading cells beside JPDA, then its ablations:

    >>> config = FjpdaReadingsConfig("S3", 5.0, ("s3",))
    >>> labels = list(config.variants())
    >>> len(labels), labels[:3], labels[-1]
    (10, ['JPDA', 'FJPDA', 'FJPDA, canvas, fixed'], 'FJPDA, c_I 0.8')
    >>> FjpdaReadingsConfig("S4", 5.0)
    Traceback (most recent call last):
        ...
    ValueError: scene must be one of ('jitter', 'glare', 'side_by_side', 'occlusion', 'S3'), got 'S4'
    """

    scene: str
    jitter: float
    extras: tuple = ()

    _KINDS = {"scene": str, "jitter": float, "extras": tuple}  # noqa: RUF012

    def __post_init__(self):
        if not isinstance(self.scene, str) or self.scene not in _SCENES:
            raise ValueError(f"scene must be one of {_SCENES}, got {self.scene!r}")
        check_jitter(self.jitter)
        check_names(self.extras, "extras", ("s3",), "extra", empty=True)

    def variants(self) -> dict:
        """``{label: JPDATrackerConfig}``: the reading cells, then the extras'."""
        from ..trackers.jpda_tracker import matched_config

        table = dict(READING_VARIANTS)
        if "s3" in self.extras:
            table.update(S3_VARIANTS)
        return {label: matched_config(v, float(self.jitter), **kw)
                for label, (v, kw) in table.items()}


def readings_trial(rng, scene_name, variants, jitter):
    """One run: ``{label: (SceneMetrics, py-motmetrics dict or None)}`` of every
    tracker of ``variants`` on the same rendered and segmented scene."""
    from ..scenarios.feature_metrics import scene_run

    scene, _, reports = scene_run(rng, scene_name, variants, jitter=jitter)
    return {label: (scene_metrics(scene, reps),
                    clear_mot_metrics(scene, reps) if label in MOT_VARIANTS else None)
            for label, reps in reports.items()}


def _call(config):
    return (config.scene, config.variants(), float(config.jitter)), {}


def _extract(out, config):
    """Per tracker ``V``: ``V.<field>``, ``V.false_<source>`` and, for
    :data:`MOT_VARIANTS`, ``V.mm_<measure>``."""
    row = {}
    for label, (m, mot) in out.items():
        for field, dtype in _FIELDS.items():
            row[f"{label}.{field}"] = dtype(getattr(m, field))
        src = dict(m.false_sources)
        unknown = set(src) - set(FALSE_SOURCES)
        if unknown:
            raise ValueError(f"false-track sources {sorted(unknown)} are not among "
                             f"FALSE_SOURCES {FALSE_SOURCES}")
        for s in FALSE_SOURCES:
            row[f"{label}.false_{s}"] = np.int64(src.get(s, 0))
        if mot is not None:
            for name in MOT_METRICS:
                row[f"{label}.mm_{name}"] = np.float64(mot[name])
    return row


FJPDA_READINGS_SEED = 20160325 + 300
_NB = "book/004-feature-jpda/07-extensions.ipynb"
for _i, (_key, (_scene, _jitter, _extras)) in enumerate(READINGS_SCENES.items()):
    _config = FjpdaReadingsConfig(_scene, _jitter, _extras)
    register(Experiment(
        name=f"fjpda-readings-{_key}",
        description=(f"Feature-JPDA chapter, readings at 200 seeds, {_key}: "
                     f"{', '.join(_config.variants())} on the same detections"),
        trial=readings_trial, call=_call, extract=_extract, config=_config,
        seed=FJPDA_READINGS_SEED + _i, runs=200, version="1", notebook=_NB))


# ---------------------------------------------------------------- analysis (05)
#: the reading cells run: glue suffix -> tracker label (canvas/sliding x updated/fixed)
CELLS = {"cu": "FJPDA", "cf": "FJPDA, canvas, fixed",
         "su": "FJPDA, sliding, updated", "sf": "FJPDA, sliding, fixed"}
#: experiment key -> the short scene name of the chapter's glue keys
SCENE_KEYS = {"glare": "glare", "side-by-side": "side", "occlusion": "occl",
              "s1-jitter3": "j3", "s1-jitter5": "j5", "s3-jitter5": "s3"}


class NoInterval(float):
    """A mean (difference) whose runs are too few or (nearly) all equal: no interval
    exists, and it formats as ``"<value> (no interval)"`` (read as undecided); its
    ``lo`` and ``hi`` are NaN, so no comparison with them holds.

    Examples
    --------
    >>> d = NoInterval(0.25)
    >>> format(d, ".2f"), d.value, d.lo <= 0 <= d.hi
    ('0.25 (no interval)', 0.25, False)
    """

    lo = hi = float("nan")

    @property
    def value(self):
        return float(self)

    def __format__(self, fmt):
        return f"{format(float(self), fmt)} (no interval)"


def estimate(interval, *values):
    """``interval(*values)`` (an interval of :mod:`trackcore.stats`, e.g. ``mean_ci``
    or ``paired_diff_ci``), or, where it refuses the runs (fewer than ``MIN_RUNS``,
    or (nearly) all equal), the point value as a :class:`NoInterval` (a mean, or for
    two samples the mean difference).

    Examples
    --------
    Paired runs give their interval; runs all equal have none:

    >>> from trackcore.stats import mean_ci, paired_diff_ci
    >>> rng = np.random.default_rng(1)
    >>> x = rng.normal(1.0, 0.5, 40)
    >>> y = x + 0.3 + rng.normal(0.0, 0.2, 40)
    >>> format(estimate(paired_diff_ci, x, y), ".2f")
    '-0.27 [-0.32, -0.22]'
    >>> format(estimate(mean_ci, np.full(50, 2.0)), ".2f")
    '2.00 (no interval)'
    """
    try:
        return interval(*values)
    except ValueError:
        v = [np.asarray(x, float) for x in values]
        return NoInterval(v[0].mean() if len(v) == 1 else (v[0] - v[1]).mean())


def per_run(res, tracker, measure):
    """Per-run values of one tracker in a readings store: ``"tmr"`` (maintained over
    eligible frames; a run without an eligible frame counts 0 of 0 as NaN and is
    refused), ``"coverage"``, ``"events_same"`` (events per frame with the feature
    gate minus those of the same tracks without it), or a stored field
    (``false_tracks``, ``false_glare``, ``mm_idf1``, ...).

    Examples
    --------
    A store's columns (here a dict of two runs):

    >>> res = {"JPDA.tmr_num": np.array([8, 9]), "JPDA.tmr_den": np.array([10, 10]),
    ...        "JPDA.mean_events": np.array([3.0, 4.0]),
    ...        "JPDA.mean_events_kin": np.array([3.5, 4.0])}
    >>> per_run(res, "JPDA", "tmr").tolist(), per_run(res, "JPDA", "events_same").tolist()
    ([0.8, 0.9], [-0.5, 0.0])
    """
    def col(f):
        return np.asarray(res[f"{tracker}.{f}"], float)

    if measure in ("tmr", "coverage"):
        den = col("tmr_den")
        if np.any(den <= 0):
            raise ValueError(f"{tracker}: a run without an eligible frame has no {measure}")
        return col("tmr_num" if measure == "tmr" else "coverage_num") / den
    if measure == "events_same":
        return col("mean_events") - col("mean_events_kin")
    return col(measure)


#: the glued text of a tracker comparison whose premise is absent: the scorecard reads a
#: cell glued so as not applicable (the chapter's registry declares the premise)
NO_TRACK = "not applicable: neither tracker confirms a track in any run"


def confirms_nothing(res, trackers, select=None):
    """Whether no tracker of ``trackers`` (labels of a readings store) confirms a single
    track in any run: no frame of a vehicle covered by a confirmed or memory track
    (``coverage_num``) and no confirmed false track (``false_tracks``), in every run
    selected by the boolean mask ``select`` (all runs if ``None``).  Then a comparison
    of those trackers has nothing to compare: its cell is not applicable
    (:data:`NO_TRACK`).

    Examples
    --------
    >>> res = {"JPDA.coverage_num": np.array([0, 0]), "JPDA.false_tracks": np.array([0, 0]),
    ...        "FJPDA.coverage_num": np.array([0, 3]), "FJPDA.false_tracks": np.array([0, 0])}
    >>> confirms_nothing(res, ["JPDA"]), confirms_nothing(res, ["JPDA", "FJPDA"])
    (True, False)
    >>> confirms_nothing(res, ["JPDA", "FJPDA"], select=np.array([True, False]))
    True
    """
    if isinstance(trackers, str) or not len(trackers):
        raise ValueError("trackers must be a non-empty list of tracker labels")
    for t in trackers:
        for f in ("coverage_num", "false_tracks"):
            v = np.asarray(res[f"{t}.{f}"])
            if select is not None:
                sel = np.asarray(select)
                if sel.dtype != bool or sel.shape != v.shape:
                    raise ValueError("select must be a boolean mask, one entry per run")
                v = v[sel]
            if np.any(v != 0):
                return False
    return True


def compare(x, y, names=("A", "B"), lower_is_better=True):
    """:func:`~trackcore.scenarios.feature_metrics.paired_comparison` of per-run
    values, except where no interval exists (fewer than ``MIN_RUNS`` runs, or the
    paired differences (nearly) all equal): then the difference is a
    :class:`NoInterval` and the verdict ``"no interval"``, never a tie.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> x = rng.normal(1.0, 0.5, 40)
    >>> y = x + 0.3 + rng.normal(0.0, 0.2, 40)
    >>> c = compare(x, y, ("FJPDA", "JPDA"))
    >>> format(c.diff, ".2f"), c.verdict, c.a_better, c.b_better
    ('-0.27 [-0.32, -0.22]', 'FJPDA better', 39, 1)
    >>> c = compare(np.full(40, 2.0), np.full(40, 1.5), ("FJPDA", "JPDA"))
    >>> format(c.diff, ".2f"), c.verdict
    ('0.50 (no interval)', 'no interval')

    A mean difference that is zero but for float rounding (shares of different
    denominators) is printed as 0:

    >>> x = np.array([1 / 3, 2 / 3, 0.1, 0.7] * 10)
    >>> y = np.roll(x, 1)
    >>> float(np.mean(x - y)) == 0.0, format(compare(x, y).diff, ".2g")
    (False, '0 [-0.16, 0.16]')
    """
    from dataclasses import replace

    from ..scenarios.feature_metrics import PairedComparison, paired_comparison
    from ..stats import mcnemar_exact

    try:
        c = paired_comparison(x, y, names, lower_is_better)
    except ValueError:
        x, y = np.asarray(x, float), np.asarray(y, float)
        d = (x - y) if lower_is_better else (y - x)
        a_b, b_b = int(np.sum(d < 0)), int(np.sum(d > 0))
        return PairedComparison(*names, float(x.mean()), float(y.mean()),
                                NoInterval(np.mean(x - y)), a_b, b_b,
                                mcnemar_exact(a_b, b_b), "no interval")
    d = c.diff  # a mean difference of 1e-18 is a zero in float rounding
    if d.value != 0 and abs(d.value) < 1e-12 * max(1.0, abs(d.lo), abs(d.hi)) \
            and d.lo <= 0 <= d.hi:
        c = c._replace(diff=replace(d, value=0.0))
    return c
