"""Feature-JPDA chapter, extensions: the measurement-level crossing experiments.

``book/004-feature-jpda/07-extensions.ipynb`` runs JPDA and FJPDA (and, at 3 px, the
likelihood-ratio extension FJPDA-LR and JPDA with the paper's duplicate rule) on the
same drawn crossings (:func:`~trackcore.scenarios.feature_metrics.crossing_trial`) at a
closest approach of 3, 8 and 16 px.  One experiment per separation,
``fjpda-ext-<sep>px``; a row holds each tracker's crossing outcome as a small integer
code (an index into :data:`CROSSING_OUTCOMES`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scenarios.feature_metrics import crossing_trial
from ._checks import check_finite, check_names
from ._core import Experiment, register
from .registry import _Config

__all__ = ["CROSSING_OUTCOMES", "CROSSING_TRACKERS", "FjpdaCrossingConfig"]

#: The crossing outcomes of :class:`~trackcore.scenarios.SceneMetrics`; a stored code
#: ``k`` means ``CROSSING_OUTCOMES[k]`` ("" : the scene has no crossing).
CROSSING_OUTCOMES = ("kept", "swap", "break", "")
#: The tracker labels a config may name (the notebook's labels).
CROSSING_TRACKERS = ("JPDA", "FJPDA", "FJPDA-LR", "JPDA, duplicate rule")
#: Every label a config may name: those, and FJPDA with the duplicate rule (the paper's
#: complete tracker, ``fjpda-ext-3px-dup``).
_TRACKERS = (*CROSSING_TRACKERS, "FJPDA, duplicate rule")


_finite = check_finite


@dataclass(frozen=True)
class FjpdaCrossingConfig(_Config):
    """One separation of the chapter's measurement-level crossing.

    ``min_sep`` the closest approach of the two centroids (px); ``trackers`` labels of
    :data:`CROSSING_TRACKERS` run on the same detections; ``lam`` the trackers' clutter
    density (px^-2); ``feature_lr`` the Beta parameters ``(a1, b1, a0, b0)`` of the
    likelihood ratio of FJPDA-LR (fitted in the notebook); ``heading_b_deg`` vehicle
    B's heading (degrees), ``pd``, ``n_frames`` and ``conflict`` the scene's detection
    probability, length and frame of closest approach.

    Examples
    --------
    >>> config = FjpdaCrossingConfig(3.0)
    >>> config.trackers, round(config.lam * 1e5, 3), config.n_frames
    (('JPDA', 'FJPDA'), 6.944, 36)
    >>> FjpdaCrossingConfig(-1.0)
    Traceback (most recent call last):
        ...
    ValueError: min_sep must be >= 0, got -1.0
    """

    min_sep: float
    trackers: tuple = ("JPDA", "FJPDA")
    lam: float = 1.0 / 120**2
    feature_lr: tuple = ()
    heading_b_deg: float = 20.0
    pd: float = 0.98
    n_frames: int = 36
    conflict: int = 18

    _KINDS = {"min_sep": float, "trackers": tuple, "lam": float, "feature_lr": "floats",
              "heading_b_deg": float, "pd": float, "n_frames": int, "conflict": int}

    def __post_init__(self):
        for name in ("min_sep", "lam", "heading_b_deg", "pd"):
            _finite(getattr(self, name), name)
        if self.min_sep < 0:
            raise ValueError(f"min_sep must be >= 0, got {self.min_sep}")
        if self.lam <= 0:
            raise ValueError(f"lam must be > 0, got {self.lam}")
        if not 0 < self.pd <= 1:
            raise ValueError(f"pd must be in (0, 1], got {self.pd}")
        for name in ("n_frames", "conflict"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise TypeError(f"{name} must be an integer, got {v!r}")
        if not 3 <= self.n_frames <= 10_000:
            raise ValueError(f"n_frames must be in [3, 10000], got {self.n_frames}")
        if not 0 <= self.conflict < self.n_frames:
            raise ValueError(f"conflict must be in [0, n_frames), got {self.conflict}")
        check_names(self.trackers, "trackers", _TRACKERS, "tracker")
        if not isinstance(self.feature_lr, tuple):
            raise TypeError(f"feature_lr must be a tuple, got {self.feature_lr!r}")
        if "FJPDA-LR" in self.trackers and len(self.feature_lr) != 4:
            raise ValueError(f"feature_lr must hold four Beta parameters (a1, b1, a0, b0) "
                             f"when trackers include FJPDA-LR, got {self.feature_lr!r}")
        for v in self.feature_lr:
            _finite(v, "feature_lr")
            if v <= 0:
                raise ValueError(f"every feature_lr parameter must be > 0, got {v!r}")

    def variants(self) -> dict:
        """``{label: JPDATrackerConfig}`` in the order of ``trackers``."""
        from ..trackers.jpda_tracker import JPDATrackerConfig

        make = {
            "JPDA": lambda: JPDATrackerConfig(variant="JPDA", lam=self.lam,
                                              duplicate_deletion=False),
            "FJPDA": lambda: JPDATrackerConfig(variant="FJPDA", lam=self.lam,
                                               duplicate_deletion=False),
            "FJPDA-LR": lambda: JPDATrackerConfig(variant="FJPDA", lam=self.lam,
                                                  feature_lr=self.feature_lr,
                                                  duplicate_deletion=False),
            "JPDA, duplicate rule": lambda: JPDATrackerConfig(variant="JPDA",
                                                              lam=self.lam),
            "FJPDA, duplicate rule": lambda: JPDATrackerConfig(variant="FJPDA",
                                                               lam=self.lam),
        }
        return {t: make[t]() for t in self.trackers}

    def scene(self) -> dict:
        """Keyword arguments of :func:`~trackcore.scenarios.feature_metrics.crossing_trial`."""
        return _crossing_scene(self)


def _crossing_scene(config) -> dict:
    """The crossing's keyword arguments of
    :func:`~trackcore.scenarios.feature_metrics.crossing_trial` from a config with
    ``heading_b_deg``, ``pd``, ``n_frames``, ``conflict`` and ``min_sep`` (shared by every
    crossing experiment of the chapter)."""
    return {"heading_b": math.radians(config.heading_b_deg), "pd": config.pd,
            "n_frames": config.n_frames, "conflict": config.conflict,
            "min_sep": config.min_sep}


def _call(config):
    return (config.variants(),), config.scene()


def _extract(out, config):
    """Per tracker: the crossing outcome's code (int8, index into CROSSING_OUTCOMES)."""
    return {f"{t}.crossing": np.int8(CROSSING_OUTCOMES.index(out[t].crossing))
            for t in config.trackers}


#: The chapter's master seed; separation ``s`` px runs with seed ``SEED + int(s)``.
FJPDA_EXT_SEED = 20160325
#: The likelihood ratio's Beta parameters ``(a1, b1, a0, b0)`` the notebook fits to the
#: correlations of 200 seeds (:func:`~trackcore.scenarios.feature_correlation_samples`
#: with seed ``FJPDA_EXT_SEED``); the notebook checks that its fit gives these.
FJPDA_EXT_LR = (256.11659209361454, 10.985589786265926, 6.93354850851969,
                6.9881949307119715)
_NB = "book/004-feature-jpda/07-extensions.ipynb"
for _sep, _runs, _trackers, _what in (
        (3.0, 800, CROSSING_TRACKERS,
         "JPDA, FJPDA, FJPDA-LR and JPDA with the duplicate rule"),
        (8.0, 400, ("JPDA", "FJPDA"), "JPDA and FJPDA"),
        (16.0, 400, ("JPDA", "FJPDA"), "JPDA and FJPDA")):
    register(Experiment(
        name=f"fjpda-ext-{_sep:.0f}px",
        description=f"Feature-JPDA chapter, extensions: crossing outcomes of {_what} on "
                    f"the same measurement-level crossings, closest approach {_sep:.0f} px",
        trial=crossing_trial, call=_call, extract=_extract,
        config=FjpdaCrossingConfig(
            _sep, _trackers, feature_lr=FJPDA_EXT_LR if "FJPDA-LR" in _trackers else ()),
        seed=FJPDA_EXT_SEED + int(_sep), runs=_runs, version="1", notebook=_NB))

#: the paper's complete tracker at 3 px: FJPDA with the duplicate rule on the first 400
#: crossings of fjpda-ext-3px (same seed and runs: paired run by run with the stored
#: outcomes of JPDA with the rule)
register(Experiment(
    name="fjpda-ext-3px-dup",
    description="Feature-JPDA chapter, extensions: crossing outcomes of FJPDA with the "
                "duplicate rule, closest approach 3 px (the crossings of fjpda-ext-3px)",
    trial=crossing_trial, call=_call, extract=_extract,
    config=FjpdaCrossingConfig(3.0, ("FJPDA, duplicate rule",)),
    seed=FJPDA_EXT_SEED + 3, runs=400, version="1", notebook=_NB))
