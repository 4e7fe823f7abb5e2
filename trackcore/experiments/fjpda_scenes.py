"""Feature-JPDA chapter (004), the scene results: JPDA, FJPDA and their ablations on
the rendered scenes of ``book/004-feature-jpda/05-scene-results.ipynb``.

One experiment per scene of the notebook (``fjpda-scenes-<key>``): every run renders
the scene once, segments it once by ViBe and runs every tracker variant on the same
detections (:func:`trackcore.scenarios.feature_metrics.scene_trial`), with the
notebook's master seeds (20160325 + 100 + i for the i-th scene) and 50 runs.  A row
holds, per tracker variant, the deterministic scalar fields of its
:class:`~trackcore.scenarios.feature_metrics.SceneMetrics` (``assoc_ms``, a timing,
and ``false_sources`` are left out; ``crossing`` is coded as an integer, see
:data:`CROSSING_CODES`).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..scenarios.feature_metrics import scene_trial
from ._checks import check_jitter, check_names
from ._core import Experiment, register
from .registry import _Config

__all__ = [
    "ABLATIONS",
    "BASE",
    "CROSSING_CODES",
    "EXPERIMENTS",
    "FJPDA_SCENE_FIELDS",
    "FjpdaSceneConfig",
]

#: The notebook's ablations: key -> {variant label: (base tracker, config keywords)}.
ABLATIONS = {
    "tsi": {"FJPDA, TSI from unvalidated": ("FJPDA", {"tsi_from": "unvalidated"})},
    "rho": {"FJPDA, normalised ρ": ("FJPDA", {"rho_weight": "normalised"})},
    "guard": {"FJPDA, no drift guard": ("FJPDA", {"template_guard": False})},
    "memory": {
        "JPDA, memory 1": ("JPDA", {"memory_frames": 1}),
        "FJPDA, memory 1": ("FJPDA", {"memory_frames": 1}),
        "JPDA, memory 6": ("JPDA", {"memory_frames": 6}),
        "FJPDA, memory 6": ("FJPDA", {"memory_frames": 6}),
    },
    "dup": {
        "JPDA, no duplicate deletion": ("JPDA", {"duplicate_deletion": False}),
        "FJPDA, no duplicate deletion": ("FJPDA", {"duplicate_deletion": False}),
    },
}
#: The trackers of every scene (FJPDA-gate only with the ``gate`` ablation).
BASE = ("JPDA", "FJPDA-gate", "FJPDA")
_ABLATION_KEYS = ("gate",) + tuple(ABLATIONS)
_SCENES = ("jitter", "glare", "side_by_side", "occlusion", "S3")
#: experiment label: (experiment name suffix, scene, camera jitter in px, ablations)
EXPERIMENTS = {
    "S1, jitter 0 px": ("s1-jitter0", "jitter", 0.0, ()),
    "S1, jitter 3 px": ("s1-jitter3", "jitter", 3.0, ()),
    "S1, jitter 5 px": ("s1-jitter5", "jitter", 5.0, ("tsi",)),
    "glare": ("glare", "glare", 5.0, ("gate", "tsi", "rho")),
    "side by side": ("side-by-side", "side_by_side", 5.0, ("gate", "rho", "guard")),
    "occlusion": ("occlusion", "occlusion", 3.0, ("gate", "memory", "guard")),
    "S3, jitter 5 px": ("s3-jitter5", "S3", 5.0, ("gate", "dup")),
}
#: SceneMetrics fields stored per variant (integers bit for bit, floats to FLOAT_RTOL).
FJPDA_SCENE_FIELDS = {
    "tmr_num": np.int64, "tmr_den": np.int64, "coverage_num": np.int64,
    "false_tracks": np.int64, "false_track_frames": np.int64, "id_switches": np.int64,
    "fragmentations": np.int64, "mota": np.float64, "motp": np.float64,
    "crossing": np.int8, "follower_delay": np.int64, "mean_events": np.float64,
    "max_events": np.int64, "valid_removed": np.float64, "mean_events_kin": np.float64,
}
#: ``SceneMetrics.crossing`` as stored: "" (no crossing) 0, "kept" 1, "swap" 2, "break" 3.
CROSSING_CODES = {"": 0, "kept": 1, "swap": 2, "break": 3}


@dataclass(frozen=True)
class FjpdaSceneConfig(_Config):
    """One scene of the chapter's scene results: ``scene`` (a scene of
    :func:`~trackcore.scenarios.feature_scenes.render_scene` among ``jitter``,
    ``glare``, ``side_by_side``, ``occlusion``, ``S3``), camera ``jitter`` (px, the
    trackers matched to it) and ``ablations`` run on the same detections (keys among
    ``gate``, ``tsi``, ``rho``, ``guard``, ``memory``, ``dup``).

    Examples
    --------
    JPDA and FJPDA, then the trackers of each ablation:

    >>> list(FjpdaSceneConfig("glare", 5.0, ("tsi",)).variants())
    ['JPDA', 'FJPDA', 'FJPDA, TSI from unvalidated']
    >>> FjpdaSceneConfig("glare", 5.0, ("wind",))
    Traceback (most recent call last):
        ...
    ValueError: unknown ablation 'wind' in ablations; expected some of ('gate', 'tsi', 'rho', 'guard', 'memory', 'dup')
    """

    scene: str
    jitter: float
    ablations: tuple = ()

    _KINDS = {"scene": str, "jitter": float, "ablations": tuple}  # noqa: RUF012

    def with_overrides(self, overrides):
        if not isinstance(overrides, dict):
            raise TypeError(f"overrides must be a dict, got {type(overrides).__name__}")
        overrides = dict(overrides)
        base = self
        if "scene" in overrides:
            base = dataclasses.replace(self, scene=overrides.pop("scene"))
        return _Config.with_overrides(base, overrides) if overrides else base

    def __post_init__(self):
        if not isinstance(self.scene, str) or self.scene not in _SCENES:
            raise ValueError(f"scene must be one of {_SCENES}, got {self.scene!r}")
        check_jitter(self.jitter)
        check_names(self.ablations, "ablations", _ABLATION_KEYS, "ablation", empty=True)

    def variants(self) -> dict:
        """The tracker configurations, label -> JPDATrackerConfig, in the notebook's
        order (JPDA, FJPDA, FJPDA-gate with ``gate``, then the ablations')."""
        return _variants(float(self.jitter), self.ablations)


def _variants(jitter, ablations):
    from ..trackers.jpda_tracker import matched_config

    out = {v: matched_config(v, jitter) for v in BASE if v != "FJPDA-gate"}
    if "gate" in ablations:
        out["FJPDA-gate"] = matched_config("FJPDA-gate", jitter)
    for a in ablations:
        for label, (v, kw) in ABLATIONS.get(a, {}).items():
            out[label] = matched_config(v, jitter, **kw)
    return out


def _call(config):
    return (config.scene, config.variants()), {"jitter": float(config.jitter)}


def _extract(trial, config):
    """Per variant ``V``: columns ``V.<field>`` for every field of FJPDA_SCENE_FIELDS."""
    row = {}
    for label, m in trial.metrics.items():
        for field, dtype in FJPDA_SCENE_FIELDS.items():
            value = getattr(m, field)
            if field == "crossing":
                value = CROSSING_CODES[value]
            row[f"{label}.{field}"] = dtype(value)
    return row


FJPDA_SCENES_SEED = 20160325 + 100
_NB = "book/004-feature-jpda/05-scene-results.ipynb"
for _i, (_label, (_key, _scene, _jitter, _abl)) in enumerate(EXPERIMENTS.items()):
    _config = FjpdaSceneConfig(_scene, _jitter, _abl)
    register(Experiment(
        name=f"fjpda-scenes-{_key}",
        description=(f"Feature-JPDA chapter, scene results, {_label}: "
                     f"{', '.join(_config.variants())} on the same detections"),
        trial=scene_trial, call=_call, extract=_extract, config=_config,
        seed=FJPDA_SCENES_SEED + _i, runs=50, version="1", notebook=_NB))
