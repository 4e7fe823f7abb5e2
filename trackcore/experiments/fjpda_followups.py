"""Feature-JPDA chapter (004): the follow-ups of the ninth review (issue 29).

``fjpda-s3-threshold``: the S3 threshold sweep extended below 0.4.  The SAME master
seed and run count (200) as ``fjpda-readings-s3-jitter5``, so run i renders and
segments the same scene as that store's run i (the generator of run i depends only on
the seed, i and the run count); on those detections it runs JPDA and FJPDA at the
defaults (their rows must equal the readings rows, a check that the runs are the same)
and FJPDA with c_I at each value of :data:`S3_LOW_THRESHOLDS`.  A row holds per tracker
the readings fields (``V.<field>``, ``V.false_<source>``); no py-motmetrics.

``fjpda-occlusion-map-long``: the occlusion map at memories as long as its merges.  The
SAME master seed and run count (40) as ``fjpda-occlusion-map``, so every offset of every
run is the same render and segmentation; JPDA and the four FJPDA cells of
:data:`~trackcore.experiments.fjpda_templates.MAP_CELLS` at every memory of
:data:`MAP_LONG_MEMORY` (6, 11 and 15 frames: one frame longer than the merges of 5, 10
and 14 frames at the offsets 6, 4 and 2 px).  Rows as in ``fjpda-occlusion-map``.

``fjpda-confirm-s1-jitter5`` and ``fjpda-confirm-s1-jitter3``: the confirmation of the
false tracks FJPDA - JPDA in the S1 layout (issue 29, session 10).  The configuration,
trial and rows of ``fjpda-readings-s1-jitter5`` / ``-jitter3`` (JPDA and the four reading
cells on the same detections), on fresh master seeds (:data:`FJPDA_CONFIRM_SEED` + i for
the i-th key of :data:`CONFIRM_SCENES`) and :data:`CONFIRM_RUNS` runs: at 150 seeds a
replication's 95 % intervals of the sliding cells were about 0.10 per sequence wide on
each side under 5 px and 0.06-0.08 under 3 px; intervals narrow as 1/sqrt(n), so 600
runs give about 0.05 and 0.04, enough to decide a difference of about 0.05.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scenarios.feature_metrics import scene_metrics
from ._checks import check_finite, check_jitter, check_names
from ._core import Experiment, register
from .fjpda_readings import (
    FJPDA_READINGS_SEED,
    READINGS_SCENES,
    FjpdaReadingsConfig,
    _call,
    _extract,
    readings_trial,
)
from .fjpda_templates import (
    FJPDA_MAP_SEED,
    FjpdaOcclusionMapConfig,
    _map_call,
    _map_extract,
    metric_columns,
    occlusion_map_trial,
)
from .registry import _Config

__all__ = ["CONFIRM_RUNS", "CONFIRM_SCENES", "FJPDA_CONFIRM_SEED", "MAP_LONG_MEMORY",
           "S3_LOW_THRESHOLDS", "FjpdaS3ThresholdConfig", "count_word", "confirm_rows"]

#: the c_I values of the extended S3 sweep (the readings store ran 0.4 to 0.8)
S3_LOW_THRESHOLDS = (0.3, 0.2)
#: the memories of the long occlusion map (frames)
MAP_LONG_MEMORY = (6.0, 11.0, 15.0)


@dataclass(frozen=True)
class FjpdaS3ThresholdConfig(_Config):
    """S3 under camera ``jitter`` px: JPDA, FJPDA and FJPDA at each c_I of
    ``thresholds`` (each in (0, 1)).

    Examples
    --------
    >>> config = FjpdaS3ThresholdConfig()
    >>> list(config.variants())
    ['JPDA', 'FJPDA', 'FJPDA, c_I 0.3', 'FJPDA, c_I 0.2']
    >>> config.variants()["FJPDA, c_I 0.2"].c_I
    0.2
    >>> FjpdaS3ThresholdConfig(thresholds=(1.5,))
    Traceback (most recent call last):
        ...
    ValueError: thresholds must lie in (0, 1), got 1.5
    """

    thresholds: tuple = S3_LOW_THRESHOLDS
    jitter: float = 5.0

    _KINDS = {"thresholds": "floats", "jitter": float}  # noqa: RUF012

    def __post_init__(self):
        check_names(self.thresholds, "thresholds")
        for c in self.thresholds:
            check_finite(c, "thresholds")
            if not 0 < c < 1:
                raise ValueError(f"thresholds must lie in (0, 1), got {c!r}")
        check_jitter(self.jitter)

    def variants(self) -> dict:
        """``{label: JPDATrackerConfig}``: JPDA, FJPDA, then FJPDA per c_I."""
        from ..trackers.jpda_tracker import matched_config

        j = float(self.jitter)
        out = {"JPDA": matched_config("JPDA", j), "FJPDA": matched_config("FJPDA", j)}
        for c in self.thresholds:
            out[f"FJPDA, c_I {c:.1f}"] = matched_config("FJPDA", j, c_I=float(c))
        return out


def threshold_trial(rng, variants, jitter):
    """One run of S3: ``{label: SceneMetrics}`` on the same rendered and segmented
    scene."""
    from ..scenarios.feature_metrics import scene_run

    scene, _, reports = scene_run(rng, "S3", variants, jitter=jitter)
    return {label: scene_metrics(scene, reps) for label, reps in reports.items()}


def _threshold_call(config):
    return (config.variants(), float(config.jitter)), {}


def _threshold_extract(out, config):
    row = {}
    for label, m in out.items():
        metric_columns(row, label, m)
    return row


_NB = "book/004-feature-jpda/07-extensions.ipynb"
_S3_INDEX = list(READINGS_SCENES).index("s3-jitter5")
register(Experiment(
    name="fjpda-s3-threshold",
    description=("Feature-JPDA chapter, S3 under 5 px of jitter, c_I 0.3 and 0.2 (the runs "
                 "of fjpda-readings-s3-jitter5): JPDA, FJPDA and FJPDA per c_I"),
    trial=threshold_trial, call=_threshold_call, extract=_threshold_extract,
    config=FjpdaS3ThresholdConfig(), seed=FJPDA_READINGS_SEED + _S3_INDEX, runs=200,
    version="1", notebook=_NB))

register(Experiment(
    name="fjpda-occlusion-map-long",
    description=("Feature-JPDA chapter, occlusion map at memories 6, 11 and 15 frames "
                 "(the renders of fjpda-occlusion-map): TMR and false tracks of JPDA and "
                 "FJPDA"),
    trial=occlusion_map_trial, call=_map_call, extract=_map_extract,
    config=FjpdaOcclusionMapConfig(memory=MAP_LONG_MEMORY), seed=FJPDA_MAP_SEED, runs=40,
    version="1", notebook=_NB))

#: the scenes of the S1 confirmation runs (keys of READINGS_SCENES), in seed order
CONFIRM_SCENES = ("s1-jitter5", "s1-jitter3")
#: runs per confirmation scene (declared from the replication's interval widths)
CONFIRM_RUNS = 600
#: master seed of the confirmation runs (fresh: no other experiment uses it)
FJPDA_CONFIRM_SEED = 20160325 + 400
for _i, _key in enumerate(CONFIRM_SCENES):
    _config = FjpdaReadingsConfig(*READINGS_SCENES[_key])
    register(Experiment(
        name=f"fjpda-confirm-{_key}",
        description=(f"Feature-JPDA chapter, confirmation of the false tracks in {_key} "
                     f"at {CONFIRM_RUNS} fresh seeds: "
                     f"{', '.join(_config.variants())} on the same detections"),
        trial=readings_trial, call=_call, extract=_extract, config=_config,
        seed=FJPDA_CONFIRM_SEED + _i, runs=CONFIRM_RUNS, version="1", notebook=_NB))


def count_word(c):
    """How a comparison of counts (lower is better, A against B) reads in prose: "fewer"
    or "more" (A than B) when its interval decides, "a tie" when the interval contains
    0, "no interval" when there is none; never typed by hand.

    Examples
    --------
    >>> from trackcore.experiments.fjpda_readings import compare
    >>> rng = np.random.default_rng(1)
    >>> x = rng.poisson(1.0, 200)
    >>> y = x + rng.poisson(0.5, 200)
    >>> count_word(compare(x, y, ("FJPDA", "JPDA"))), count_word(compare(y, x))
    ('fewer', 'more')
    >>> count_word(compare(x, x + rng.choice([-1, 1], 200)))
    'a tie'
    """
    if c.verdict == "tie":
        return "a tie"
    if c.verdict == f"{c.a} better":
        return "fewer"
    if c.verdict == f"{c.b} better":
        return "more"
    return "no interval"


def confirm_rows(stores, readings_cells):
    """The S1 confirmation: per store key of :data:`CONFIRM_SCENES` and reading cell of
    :data:`~trackcore.experiments.fjpda_readings.CELLS`, false tracks FJPDA - JPDA on
    the confirmation runs (``stores``: key -> Results or column dict).  Returns
    ``{(scene_key, cell): comparison}`` and table rows (key, tracker, 200-seed
    difference from ``readings_cells[scene_key, cell, "false"]`` if present, the
    confirmation's difference, its reading by :func:`count_word`).

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> j = rng.poisson(1.0, 60)
    >>> cols = {f"{t}.false_tracks": j - (t != "JPDA") * (j > 0) for t in
    ...         ("JPDA", "FJPDA", "FJPDA, canvas, fixed", "FJPDA, sliding, updated",
    ...          "FJPDA, sliding, fixed")}
    >>> conf, rows = confirm_rows({"s1-jitter5": cols}, {})
    >>> sorted(conf)[:2], rows[0][2], rows[0][4]
    ([('j5', 'cf'), ('j5', 'cu')], '-', 'fewer')
    """
    from .fjpda_readings import CELLS, SCENE_KEYS, compare, per_run

    conf, rows = {}, []
    for key, res in stores.items():
        s = SCENE_KEYS[key]
        for cell, tracker in CELLS.items():
            x, y = (per_run(res, t, "false_tracks") for t in (tracker, "JPDA"))
            c = conf[s, cell] = compare(x, y, (tracker, "JPDA"), True)
            old = readings_cells.get((s, cell, "false"))
            rows.append((key, tracker, "-" if old is None else format(old.diff, ".2g"),
                         format(c.diff, ".2g"), count_word(c)))
    return conf, rows
