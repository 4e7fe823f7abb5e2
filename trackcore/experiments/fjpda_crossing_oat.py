"""Feature-JPDA chapter (004): the Fig 7 crossing under every reading (issue 29).

``fjpda-crossing-oat``: the measurement-level crossing of
``book/004-feature-jpda/07-extensions.ipynb`` at a closest approach of 3 px
(:func:`~trackcore.scenarios.feature_metrics.crossing_trial`, the scene of
:class:`~trackcore.experiments.fjpda_extensions.FjpdaCrossingConfig`), every tracker with
the paper's duplicate rule (its complete tracker).  On each drawn crossing it runs, on
the same detections, every cell of :data:`CELLS`:

* the correlation x template grid (eight cells, FJPDA only: JPDA uses no correlation and
  no template, so its outcome is the same in all eight; its one run is ``"JPDA cu"``);
* the default cell (canvas, updated with guard) with one other reading changed, memory,
  tsi, rho-weight, measurement or clutter-density, each applied to both trackers.

Every tracker assumes the chapter's default clutter density, 1e-5 px^-2 (``lam``), except
the cell ``"lam"``, which assumes the crossing's own foliage density, one blob per frame
in its 120 x 120 px window (``lam_matched``, 1/120^2 px^-2, the density of the 07 runs).
A row holds per tracker ``"<tracker> <cell>.crossing"``, the crossing outcome's code (an
index into :data:`~trackcore.experiments.fjpda_extensions.CROSSING_OUTCOMES`).

``fjpda-crossing-oat-vel``: the measurement reading "position and velocity", which the
tracker could not run when ``fjpda-crossing-oat`` was declared (``model="pv"`` of
:class:`~trackcore.trackers.jpda_tracker.JPDATrackerConfig`, whose docstring states the
reading): the cell ``"pv"`` alone (JPDA and FJPDA, every other reading at the default
cell), on the same master seed and run count as ``fjpda-crossing-oat``, so that its run
``i`` is the same crossing (the same detections) as run ``i`` there and the pv cell is
paired with nothing outside its own row.

``fjpda-crossing-readings2``: the two readings declared after the session-13 review,
each cell of :data:`READINGS2_CELLS` JPDA and FJPDA at the default cell (canvas, updated
with guard, 1e-5 px^-2, duplicate rule on) with one reading changed: the duplicate
distance ``d_dup`` 2 px (at the 3 px closest approach) or the closest approach 2, 4 or
5 px (at ``d_dup`` 5 px).  Each cell draws its own crossing from the run's stream, in
the order of the cells (:func:`readings2_trial`); within a cell both trackers run on the
same detections, so each cell is paired within itself.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scenarios.feature_metrics import crossing_trial
from ._checks import check_finite, check_names
from ._core import Experiment, register
from .fjpda_extensions import CROSSING_OUTCOMES, _crossing_scene
from .registry import _Config

__all__ = ["CELLS", "CROSSING_OAT_RUNS", "FJPDA_CROSSING_OAT_SEED",
           "FJPDA_CROSSING_READINGS2_SEED", "OAT_CELLS", "READINGS2_CELLS",
           "FjpdaCrossingOatConfig", "FjpdaCrossingReadings2Config", "cell_label",
           "readings2_trial"]

_VISIBLE = {"template_update": False, "template_from": "fully_visible"}
_SLIDING = {"correlation": "sliding"}
_BOTH = ("JPDA", "FJPDA")
#: cell key -> (reading varied alone or "" for the grid, its value as claims.yml names
#: it (the grid: "correlation, template"), the trackers run, the trackers' overrides);
#: "lam" takes the config's ``lam_matched``
CELLS = {
    "cu": ("", "canvas, updated with guard", _BOTH, {}),
    "cn": ("", "canvas, updated without guard", ("FJPDA",), {"template_guard": False}),
    "cf": ("", "canvas, fixed first", ("FJPDA",), {"template_update": False}),
    "cv": ("", "canvas, first fully visible", ("FJPDA",), _VISIBLE),
    "su": ("", "sliding, updated with guard", ("FJPDA",), _SLIDING),
    "sn": ("", "sliding, updated without guard", ("FJPDA",),
           {**_SLIDING, "template_guard": False}),
    "sf": ("", "sliding, fixed first", ("FJPDA",), {**_SLIDING, "template_update": False}),
    "sv": ("", "sliding, first fully visible", ("FJPDA",), {**_SLIDING, **_VISIBLE}),
    "mem1": ("memory", "1", _BOTH, {"memory_frames": 1}),
    "tsi": ("tsi", "not validated by the variant", _BOTH, {"tsi_from": "unvalidated"}),
    "rho": ("rho-weight", "normalised per track", _BOTH, {"rho_weight": "normalised"}),
    "rw": ("measurement", "position, random-walk state", _BOTH, {"model": "rw"}),
    "lam": ("clutter-density", "matched to the scene", _BOTH, {}),
    "pv": ("measurement", "position and velocity", _BOTH, {"model": "pv"}),
}
#: the cells of fjpda-crossing-oat (every cell but "pv", the store of fjpda-crossing-oat-vel)
OAT_CELLS = tuple(k for k in CELLS if k != "pv")
#: the master seed (fresh: no other experiment uses 20160325 + 770) and the crossings
FJPDA_CROSSING_OAT_SEED = 20160325 + 770
CROSSING_OAT_RUNS = 2000


def cell_label(key):
    """The claims.yml label of cell ``key`` (the grid's default cell is
    ``"canvas, updated with guard"``).

    Examples
    --------
    >>> cell_label("sf"), cell_label("mem1")
    ('sliding, fixed first', 'canvas, updated with guard; memory: 1')
    """
    reading, value, _, _ = CELLS[key]
    return f"{CELLS['cu'][1]}; {reading}: {value}" if reading else value


@dataclass(frozen=True)
class FjpdaCrossingOatConfig(_Config):
    """The crossing under every reading: ``cells`` (keys of :data:`CELLS`, ``"cu"``
    first if any grid cell is run, since the grid's FJPDA cells pair with ``"JPDA cu"``;
    by default :data:`OAT_CELLS`), ``lam`` the clutter density (px^-2) every cell but ``"lam"`` assumes,
    ``lam_matched`` the one cell ``"lam"`` assumes; the scene (``min_sep`` px,
    ``heading_b_deg``, ``pd``, ``n_frames``, ``conflict``) as
    :class:`~trackcore.experiments.fjpda_extensions.FjpdaCrossingConfig`.

    Examples
    --------
    >>> config = FjpdaCrossingOatConfig()
    >>> v = config.variants()
    >>> len(v), list(v)[:3]
    (19, ['JPDA cu', 'FJPDA cu', 'FJPDA cn'])
    >>> v["FJPDA cu"].lam, round(v["JPDA lam"].lam * 120**2, 6), v["FJPDA rw"].model
    (1e-05, 1.0, 'rw')
    >>> all(c.duplicate_deletion for c in v.values())
    True
    >>> [c.model for c in FjpdaCrossingOatConfig(cells=("pv",)).variants().values()]
    ['pv', 'pv']
    >>> FjpdaCrossingOatConfig(cells=("mem1", "cu"))
    Traceback (most recent call last):
        ...
    ValueError: cells must start with 'cu', got ('mem1', 'cu')
    """

    cells: tuple = OAT_CELLS
    lam: float = 1e-5
    lam_matched: float = 1.0 / 120**2
    min_sep: float = 3.0
    heading_b_deg: float = 20.0
    pd: float = 0.98
    n_frames: int = 36
    conflict: int = 18

    _KINDS = {"cells": tuple, "lam": float, "lam_matched": float,  # noqa: RUF012
              "min_sep": float, "heading_b_deg": float, "pd": float, "n_frames": int,
              "conflict": int}

    def __post_init__(self):
        check_names(self.cells, "cells", tuple(CELLS), "cell")
        if any(not CELLS[k][0] for k in self.cells) and self.cells[0] != "cu":
            raise ValueError(f"cells must start with 'cu', got {self.cells!r}")
        for name in ("lam", "lam_matched", "min_sep", "heading_b_deg", "pd"):
            check_finite(getattr(self, name), name)
        for name in ("lam", "lam_matched"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.min_sep < 0:
            raise ValueError(f"min_sep must be >= 0, got {self.min_sep}")
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

    def variants(self) -> dict:
        """``{"<tracker> <cell>": JPDATrackerConfig}``, the duplicate rule on in every
        one, in the order of ``cells`` (JPDA before FJPDA)."""
        from ..trackers.jpda_tracker import JPDATrackerConfig

        out = {}
        for key in self.cells:
            _, _, trackers, kw = CELLS[key]
            lam = self.lam_matched if key == "lam" else self.lam
            for t in trackers:
                out[f"{t} {key}"] = JPDATrackerConfig(variant=t, lam=lam, **kw)
        return out

    def scene(self) -> dict:
        """Keyword arguments of :func:`~trackcore.scenarios.feature_metrics.crossing_trial`."""
        return _crossing_scene(self)


def _call(config):
    return (config.variants(),), config.scene()


def _extract(out, config):
    """Per tracker: the crossing outcome's code (int8, index into CROSSING_OUTCOMES)."""
    return {f"{t}.crossing": np.int8(CROSSING_OUTCOMES.index(m.crossing))
            for t, m in out.items()}


register(Experiment(
    name="fjpda-crossing-oat",
    description=("Feature-JPDA chapter, the Fig 7 crossing under every reading: crossing "
                 "outcomes at 3 px, duplicate rule on, of FJPDA in the correlation x "
                 "template grid and of JPDA and FJPDA with memory, tsi, rho-weight, "
                 "measurement and clutter-density changed one at a time"),
    trial=crossing_trial, call=_call, extract=_extract, config=FjpdaCrossingOatConfig(),
    seed=FJPDA_CROSSING_OAT_SEED, runs=CROSSING_OAT_RUNS, version="1",
    notebook="book/004-feature-jpda/09-crossing-readings.ipynb"))

register(Experiment(
    name="fjpda-crossing-oat-vel",
    description=("Feature-JPDA chapter, the Fig 7 crossing with the detector's velocity "
                 "measured: crossing outcomes at 3 px, duplicate rule on, of JPDA and "
                 "FJPDA with model pv at the default cell, on the crossings of "
                 "fjpda-crossing-oat (same seed and runs)"),
    trial=crossing_trial, call=_call, extract=_extract,
    config=FjpdaCrossingOatConfig(cells=("pv",)),
    seed=FJPDA_CROSSING_OAT_SEED, runs=CROSSING_OAT_RUNS, version="1",
    notebook="book/004-feature-jpda/09-crossing-readings.ipynb"))


#: cell key -> (reading, its value as claims.yml names it, closest approach px, d_dup px)
READINGS2_CELLS = {
    "dd2": ("duplicate-distance", "2 px", 3.0, 2.0),
    "ca2": ("closest-approach", "2 px", 2.0, 5.0),
    "ca4": ("closest-approach", "4 px", 4.0, 5.0),
    "ca5": ("closest-approach", "5 px", 5.0, 5.0),
}
#: the master seed of fjpda-crossing-readings2 (fresh: no other experiment, notebook or
#: review uses 20160325 + 780)
FJPDA_CROSSING_READINGS2_SEED = 20160325 + 780


def readings2_trial(rng, groups):
    """One run of fjpda-crossing-readings2: for each ``(key, variants, scene)`` of
    ``groups`` in order, one crossing drawn from ``rng`` and every tracker of
    ``variants`` run on it (:func:`~trackcore.scenarios.feature_metrics.crossing_trial`).
    Returns ``{"<tracker> <key>": SceneMetrics}``.

    Examples
    --------
    The first group of the store's config (the duplicate distance at 2 px), on one crossing:

    >>> import numpy as np
    >>> groups = FjpdaCrossingReadings2Config().groups()[:1]
    >>> out = readings2_trial(np.random.default_rng(0), groups)
    >>> sorted(out)
    ['FJPDA dd2', 'JPDA dd2']
    """
    out = {}
    for key, variants, scene in groups:
        res = crossing_trial(rng, variants, **scene)
        out |= {f"{t} {key}": m for t, m in res.items()}
    return out


@dataclass(frozen=True)
class FjpdaCrossingReadings2Config(_Config):
    """The crossing with the duplicate distance or the closest approach changed:
    ``cells`` (keys of :data:`READINGS2_CELLS`), ``lam`` the clutter density every
    tracker assumes; the rest of the scene as :class:`FjpdaCrossingOatConfig`.

    Examples
    --------
    >>> c = FjpdaCrossingReadings2Config()
    >>> [(k, v["JPDA"].d_dup, s["min_sep"]) for k, v, s in c.groups()]
    [('dd2', 2.0, 3.0), ('ca2', 5.0, 2.0), ('ca4', 5.0, 4.0), ('ca5', 5.0, 5.0)]
    >>> all(cfg.duplicate_deletion for _, v, _ in c.groups() for cfg in v.values())
    True
    """

    cells: tuple = tuple(READINGS2_CELLS)
    lam: float = 1e-5
    heading_b_deg: float = 20.0
    pd: float = 0.98
    n_frames: int = 36
    conflict: int = 18

    _KINDS = {"cells": tuple, "lam": float, "heading_b_deg": float,  # noqa: RUF012
              "pd": float, "n_frames": int, "conflict": int}

    def __post_init__(self):
        check_names(self.cells, "cells", tuple(READINGS2_CELLS), "cell")
        FjpdaCrossingOatConfig(cells=("cu",), lam=self.lam,
                               heading_b_deg=self.heading_b_deg, pd=self.pd,
                               n_frames=self.n_frames, conflict=self.conflict)

    def groups(self) -> tuple:
        """``((key, {"JPDA": cfg, "FJPDA": cfg}, scene kwargs), ...)`` in the order of
        ``cells``, the duplicate rule on in every tracker."""
        from ..trackers.jpda_tracker import JPDATrackerConfig

        out = []
        for key in self.cells:
            _, _, sep, d_dup = READINGS2_CELLS[key]
            base = FjpdaCrossingOatConfig(cells=("cu",), lam=self.lam, min_sep=sep,
                                          heading_b_deg=self.heading_b_deg, pd=self.pd,
                                          n_frames=self.n_frames, conflict=self.conflict)
            variants = {t: JPDATrackerConfig(variant=t, lam=self.lam, d_dup=d_dup)
                        for t in _BOTH}
            out.append((key, variants, base.scene()))
        return tuple(out)


def _call2(config):
    return (config.groups(),), {}


register(Experiment(
    name="fjpda-crossing-readings2",
    description=("Feature-JPDA chapter, the Fig 7 crossing under the two readings "
                 "declared after the session-13 review: crossing outcomes of JPDA and "
                 "FJPDA at the default cell, duplicate rule on, with d_dup 2 px at 3 px "
                 "or the closest approach 2, 4 or 5 px at d_dup 5 px"),
    trial=readings2_trial, call=_call2,
    extract=_extract, config=FjpdaCrossingReadings2Config(),
    seed=FJPDA_CROSSING_READINGS2_SEED, runs=CROSSING_OAT_RUNS, version="1",
    notebook="book/004-feature-jpda/09-crossing-readings.ipynb"))
