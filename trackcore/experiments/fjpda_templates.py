"""Feature-JPDA chapter (004): the template cells the readings runs left out, HOTA, and the
occlusion map (issue 29).

``fjpda-templates-<key>``, one experiment per ambiguity scene of
:data:`~trackcore.experiments.fjpda_readings.READINGS_SCENES`, with the SAME master
seed as ``fjpda-readings-<key>`` and its first 100 runs: run i renders and segments the
same scene as the readings store's run i (the generator of run i depends only on the
seed and i), so its rows pair run by run with the readings rows.  On those detections
it runs JPDA, FJPDA at the defaults and FJPDA with the sliding correlation and a fixed
template (as in the readings store: the rows must agree, a check that the runs are the
same), and the four template cells not run there (:data:`NEW_CELLS`): updated without
the drift guard, and fixed from the first fully visible silhouette, each with the canvas
and the sliding correlation.  A row holds per tracker the readings fields
(``V.<field>``, ``V.false_<source>``) and TrackEval's HOTA, DetA and AssA
(``V.hota_<name>``, :func:`~trackcore.scenarios.feature_metrics.hota_metrics`).

``fjpda-occlusion-map``: 40 runs; each renders the occlusion crossing at every offset
of :data:`MAP_OFFSETS` (the centroids' closest approach sqrt(13) c px; the pair's blobs
merge for longer as c falls) and runs JPDA and the four FJPDA correlation x template
cells at every memory length of :data:`MAP_MEMORY`, on the same detections.  A row
holds per offset the merged frames (``c<c>.merged``) and per tracker the TMR counts and
false tracks (``c<c>.<tracker>.<field>``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scenarios.feature_metrics import HOTA_METRICS, hota_metrics, scene_metrics
from ._checks import check_finite, check_jitter, check_names
from ._core import Experiment, register
from .fjpda_readings import (FALSE_SOURCES, FJPDA_READINGS_SEED, READING_VARIANTS,
                             READINGS_SCENES, _FIELDS, _SCENES)
from .registry import _Config

__all__ = ["MAP_CELLS", "MAP_MEMORY", "MAP_OFFSETS", "NEW_CELLS", "TEMPLATE_VARIANTS",
           "FjpdaOcclusionMapConfig", "FjpdaTemplatesConfig"]

#: the template cells the readings stores did not run: glue suffix -> tracker label
NEW_CELLS = {"cn": "FJPDA, canvas, no guard", "cv": "FJPDA, canvas, first fully visible",
             "sn": "FJPDA, sliding, no guard", "sv": "FJPDA, sliding, first fully visible"}
_VISIBLE = {"template_update": False, "template_from": "fully_visible"}
#: tracker label -> (variant, keywords of matched_config)
TEMPLATE_VARIANTS = {
    **{k: READING_VARIANTS[k] for k in ("JPDA", "FJPDA", "FJPDA, sliding, fixed")},
    NEW_CELLS["cn"]: ("FJPDA", {"template_guard": False}),
    NEW_CELLS["cv"]: ("FJPDA", dict(_VISIBLE)),
    NEW_CELLS["sn"]: ("FJPDA", {"correlation": "sliding", "template_guard": False}),
    NEW_CELLS["sv"]: ("FJPDA", {"correlation": "sliding", **_VISIBLE}),
}
#: the occlusion map's axes: crossing offsets c (px), memory lengths (frames) and the
#: FJPDA cells (glue suffix -> matched_config keywords) beside JPDA
MAP_OFFSETS = (10.0, 6.0, 4.0, 2.0)
MAP_MEMORY = (1.0, 2.0, 4.0)
MAP_CELLS = {"cu": {}, "cf": {"template_update": False},
             "su": {"correlation": "sliding"},
             "sf": {"correlation": "sliding", "template_update": False}}
_MAP_FIELDS = ("tmr_num", "tmr_den", "false_tracks")


@dataclass(frozen=True)
class FjpdaTemplatesConfig(_Config):
    """One scene (as :class:`~trackcore.experiments.fjpda_readings.FjpdaReadingsConfig`:
    ``scene`` and camera ``jitter`` px) run with :data:`TEMPLATE_VARIANTS`.

    Examples
    --------
    JPDA, the two cells shared with the readings runs, then :data:`NEW_CELLS`:

    >>> config = FjpdaTemplatesConfig("S3", 5.0)
    >>> labels = list(config.variants())
    >>> len(labels), labels[2], labels[-1]
    (7, 'FJPDA, sliding, fixed', 'FJPDA, sliding, first fully visible')
    >>> config.variants()[labels[-1]].template_from
    'fully_visible'
    """

    scene: str
    jitter: float

    _KINDS = {"scene": str, "jitter": float}  # noqa: RUF012

    def __post_init__(self):
        if not isinstance(self.scene, str) or self.scene not in _SCENES:
            raise ValueError(f"scene must be one of {_SCENES}, got {self.scene!r}")
        check_jitter(self.jitter)

    def variants(self) -> dict:
        """``{label: JPDATrackerConfig}`` of :data:`TEMPLATE_VARIANTS`."""
        from ..trackers.jpda_tracker import matched_config

        return {label: matched_config(v, float(self.jitter), **kw)
                for label, (v, kw) in TEMPLATE_VARIANTS.items()}


def templates_trial(rng, scene_name, variants, jitter):
    """One run: ``{label: (SceneMetrics, HOTA dict)}`` of every tracker of
    ``variants`` on the same rendered and segmented scene."""
    from ..scenarios.feature_metrics import scene_run

    scene, _, reports = scene_run(rng, scene_name, variants, jitter=jitter)
    return {label: (scene_metrics(scene, reps), hota_metrics(scene, reps))
            for label, reps in reports.items()}


def _templates_call(config):
    return (config.scene, config.variants(), float(config.jitter)), {}


def metric_columns(row, label, m):
    """Add one tracker's scene metrics and its false tracks by source to a stored row."""
    for field, dtype in _FIELDS.items():
        row[f"{label}.{field}"] = dtype(getattr(m, field))
    src = dict(m.false_sources)
    if set(src) - set(FALSE_SOURCES):
        raise ValueError(f"false-track sources {sorted(src)} are not among "
                         f"FALSE_SOURCES {FALSE_SOURCES}")
    for s in FALSE_SOURCES:
        row[f"{label}.false_{s}"] = np.int64(src.get(s, 0))


def _templates_extract(out, config):
    row = {}
    for label, (m, hota) in out.items():
        metric_columns(row, label, m)
        for name in HOTA_METRICS:
            row[f"{label}.hota_{name}"] = np.float64(hota[name])
    return row


@dataclass(frozen=True)
class FjpdaOcclusionMapConfig(_Config):
    """The occlusion map: crossing ``offsets`` (px, each in [0, 30]), ``memory``
    lengths (frames, whole numbers in [1, 100]) and camera ``jitter`` (px).

    Examples
    --------
    JPDA and the four FJPDA cells at each memory length:

    >>> config = FjpdaOcclusionMapConfig()
    >>> labels = list(config.variants())
    >>> len(labels), labels[:5]
    (15, ['JPDA m1', 'cu m1', 'cf m1', 'su m1', 'sf m1'])
    >>> FjpdaOcclusionMapConfig(memory=(1.5,))
    Traceback (most recent call last):
        ...
    ValueError: memory must hold whole numbers in [1, 100], got 1.5
    """

    offsets: tuple = MAP_OFFSETS
    memory: tuple = MAP_MEMORY
    jitter: float = 3.0

    _KINDS = {"offsets": "floats", "memory": "floats", "jitter": float}  # noqa: RUF012

    def __post_init__(self):
        check_names(self.offsets, "offsets")
        for c in self.offsets:
            check_finite(c, "offsets")
            if not 0 <= c <= 30:
                raise ValueError(f"offsets must lie in [0, 30] px, got {c!r}")
        check_names(self.memory, "memory")
        for m in self.memory:
            check_finite(m, "memory")
            if m < 1 or m > 100 or not float(m).is_integer():
                raise ValueError(f"memory must hold whole numbers in [1, 100], got {m!r}")
        check_jitter(self.jitter)

    def variants(self) -> dict:
        """``{label: JPDATrackerConfig}``: JPDA and :data:`MAP_CELLS` per memory."""
        from ..trackers.jpda_tracker import matched_config

        out = {}
        for m in self.memory:
            out[f"JPDA m{m:g}"] = matched_config("JPDA", float(self.jitter),
                                               memory_frames=int(m))
            for cell, kw in MAP_CELLS.items():
                out[f"{cell} m{m:g}"] = matched_config("FJPDA", float(self.jitter),
                                                     memory_frames=int(m), **kw)
        return out


def occlusion_map_trial(rng, offsets, variants, jitter):
    """One run: per offset ``(merged frames, {label: SceneMetrics})``, every offset
    rendered and segmented in turn from ``rng``."""
    from ..scenarios.feature_scenes import render_scene, segment_scene
    from ..trackers.jpda_tracker import run_jpda_tracker

    out = {}
    for c in offsets:
        scene = render_scene("occlusion", rng, jitter=jitter, crossing_offset=c)
        dets, _ = segment_scene(scene, "vibe", rng)
        out[c] = (int(scene.merged.sum()),
                  {label: scene_metrics(scene, run_jpda_tracker(dets, cfg))
                   for label, cfg in variants.items()})
    return out


def _map_call(config):
    return (tuple(float(c) for c in config.offsets), config.variants(),
            float(config.jitter)), {}


def _map_extract(out, config):
    row = {}
    for c, (merged, metrics) in out.items():
        row[f"c{c:g}.merged"] = np.int64(merged)
        for label, m in metrics.items():
            for f in _MAP_FIELDS:
                row[f"c{c:g}.{label}.{f}"] = np.int64(getattr(m, f))
    return row


_NB = "book/004-feature-jpda/07-extensions.ipynb"
for _i, (_key, (_scene, _jitter, _)) in enumerate(READINGS_SCENES.items()):
    register(Experiment(
        name=f"fjpda-templates-{_key}",
        description=(f"Feature-JPDA chapter, template cells and HOTA at 100 seeds, {_key} "
                     f"(the runs of fjpda-readings-{_key}): "
                     f"{', '.join(TEMPLATE_VARIANTS)}"),
        trial=templates_trial, call=_templates_call, extract=_templates_extract,
        config=FjpdaTemplatesConfig(_scene, _jitter),
        seed=FJPDA_READINGS_SEED + _i, runs=100, version="1", notebook=_NB))

FJPDA_MAP_SEED = FJPDA_READINGS_SEED + 20
register(Experiment(
    name="fjpda-occlusion-map",
    description=("Feature-JPDA chapter, occlusion map: crossing offset x memory length "
                 "x correlation and template, TMR and false tracks of JPDA and FJPDA"),
    trial=occlusion_map_trial, call=_map_call, extract=_map_extract,
    config=FjpdaOcclusionMapConfig(), seed=FJPDA_MAP_SEED, runs=40, version="1",
    notebook=_NB))
