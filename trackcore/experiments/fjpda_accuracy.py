"""Feature-JPDA chapter (004): the position error on the same frames, every reading
(issue 29, claim ``fjpda-fig6-accuracy``).

``fjpda-accuracy``: the runs of ``fjpda-oat`` (the SAME master seed
:data:`~trackcore.experiments.fjpda_oat.FJPDA_OAT_SEED` and 200 runs per scene: run ``i``
renders ``OAT_SCENES[i % 6]``, segments it once by ViBe, first, and once by the running
average, as :func:`~trackcore.experiments.fjpda_oat.oat_trial` does, so the renders and
detections are those whose false tracks and TMR the chapter reports).  On them it runs
every cell of the claim's readings:

* the correlation x template grid: JPDA and FJPDA at the default cell (canvas, updated
  with guard) and FJPDA in the seven other cells of :data:`GRID_CELLS` (JPDA uses no
  correlation and no template: each grid cell is paired with ``"JPDA default"``);
* the default cell with one reading changed (:data:`VARIED_ACC`: the values of
  ``fjpda-oat``, the measurement "position and velocity" and the duplicate distance 2 px),
  each applied to both trackers, JPDA and FJPDA paired within the value.

The trackers are built by the one-at-a-time config
(:class:`~trackcore.experiments.fjpda_oat.FjpdaOatConfig`, with the value tables of
``fjpda-oat``, ``fjpda-oat-vel`` and ``fjpda-oat-dup``) and the grid overrides of
:data:`~trackcore.experiments.fjpda_crossing_oat.CELLS`.  Every tracker's reports are
matched to the vehicles by :func:`~trackcore.scenarios.feature_metrics.match_tracks` (the
match of the MOTP of :func:`~trackcore.scenarios.feature_metrics.scene_metrics`); each
FJPDA cell is compared with its JPDA by
:func:`~trackcore.scenarios.feature_metrics.same_frames_error`.  A row holds the scene
index (``scene``); per cell ``c`` (a key of :data:`VARIED_ACC` or :data:`GRID_CELLS`)
the common (vehicle, frame) pairs ``sf <c>.pairs`` and the sum of FJPDA - JPDA errors over
them ``sf <c>.diff_sum`` (px); per tracker ``"<tracker> <c>"`` its own-frames MOTP
``.motp`` (px, NaN without a match; the column of ``fjpda-oat``) and matched pairs
``.matched``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import check_names
from ._core import Experiment, register
from .fjpda_crossing_oat import CELLS
from .fjpda_oat import FJPDA_OAT_SEED, OAT_RUNS, VARIED, FjpdaOatConfig, scene_of_run
from .fjpda_oat_vel import VARIED_DUP, VARIED_VEL
from .fjpda_readings import READINGS_SCENES

__all__ = ["ACCURACY_RUNS", "GRID_CELLS", "VARIED_ACC", "FjpdaAccuracyConfig",
           "accuracy_trial", "cell_pair"]

#: value key -> (reading, value as claims.yml names it, segmentation, tracker overrides):
#: the values of fjpda-oat, then "position and velocity" and the duplicate distance 2 px
VARIED_ACC = {**VARIED, "pv": VARIED_VEL["pv"], "dd2": VARIED_DUP["dd2"]}
#: the seven correlation x template cells beside the default (FJPDA only, ViBe):
#: key -> FJPDA overrides of matched_config
GRID_CELLS = {k: CELLS[k][3] for k in ("cn", "cf", "cv", "su", "sn", "sf", "sv")}
#: runs: those of fjpda-oat (200 per scene)
ACCURACY_RUNS = OAT_RUNS


def cell_pair(cell):
    """The two tracker labels compared in cell ``cell``: ``(FJPDA, JPDA)``.

    Examples
    --------
    >>> cell_pair("mem1"), cell_pair("sf")
    (('FJPDA mem1', 'JPDA mem1'), ('FJPDA sf', 'JPDA default'))
    """
    if cell in GRID_CELLS:
        return f"FJPDA {cell}", "JPDA default"
    if cell in VARIED_ACC:
        return f"FJPDA {cell}", f"JPDA {cell}"
    raise ValueError(f"unknown cell {cell!r}; expected one of "
                     f"{tuple(VARIED_ACC) + tuple(GRID_CELLS)}")


@dataclass(frozen=True)
class FjpdaAccuracyConfig(FjpdaOatConfig):
    """:class:`~trackcore.experiments.fjpda_oat.FjpdaOatConfig` over the values of
    :data:`VARIED_ACC` (``"default"`` first), plus the FJPDA grid ``cells`` (keys of
    :data:`GRID_CELLS`) run on the ViBe detections beside ``"JPDA default"``.

    Examples
    --------
    >>> config = FjpdaAccuracyConfig()
    >>> len(config.values), config.values[-2:], config.cells
    (10, ('pv', 'dd2'), ('cn', 'cf', 'cv', 'su', 'sn', 'sf', 'sv'))
    >>> grid = config.grid(3)
    >>> grid["sv"].correlation, grid["sv"].template_from, grid["cn"].template_guard
    ('sliding', 'fully_visible', False)
    >>> FjpdaAccuracyConfig(cells=("cu",))
    Traceback (most recent call last):
        ...
    ValueError: unknown cell 'cu' in cells; expected some of ('cn', 'cf', 'cv', 'su', 'sn', 'sf', 'sv')
    """

    values: tuple = tuple(VARIED_ACC)
    cells: tuple = tuple(GRID_CELLS)

    _KINDS = {**FjpdaOatConfig._KINDS, "cells": tuple}  # noqa: RUF012
    _VARIED = VARIED_ACC

    def __post_init__(self):
        super().__post_init__()
        check_names(self.cells, "cells", tuple(GRID_CELLS), "cell", empty=True)

    def grid(self, i):
        """Scene ``i``: ``{cell: FJPDA config}`` of the grid cells (ViBe detections)."""
        from ..trackers.jpda_tracker import matched_config

        jitter = float(READINGS_SCENES[self.scenes[i]][1])
        return {c: matched_config("FJPDA", jitter, **GRID_CELLS[c]) for c in self.cells}

    def compared(self):
        """The cells compared, values first: ``(cell, (FJPDA label, JPDA label))``."""
        return [(c, cell_pair(c)) for c in self.values + self.cells]


def accuracy_trial(rng, config):
    """One run: ``(scene index, {cell: SameFrames})``, FJPDA against its JPDA of every
    cell of ``config.compared()``: the scene of
    :func:`~trackcore.experiments.fjpda_oat.scene_of_run` rendered once, segmented by
    ViBe (first, drawing from ``rng``) and by the running average, as
    :func:`~trackcore.experiments.fjpda_oat.oat_trial` does.

    Examples
    --------
    Run 1 of a store renders side by side; here the default pair, one changed reading and
    one grid cell:

    >>> from trackcore.core.rng import generator_for_run
    >>> config = FjpdaAccuracyConfig(values=("default", "mem1"), cells=("sf",))
    >>> i, out = accuracy_trial(generator_for_run(7, 1, 6), config)
    >>> i, list(out), out["sf"].matched_b == out["default"].matched_b
    (1, ['default', 'mem1', 'sf'], True)
    """
    from ..scenarios.feature_metrics import match_tracks, same_frames_error
    from ..scenarios.feature_scenes import check_scene, render_scene, segment_scene
    from ..trackers.jpda_tracker import run_jpda_tracker

    i = scene_of_run(rng, len(config.scenes))
    name, jitter, _ = READINGS_SCENES[config.scenes[i]]
    scene = render_scene(name, rng, jitter=jitter)
    check_scene(scene)
    variants = config.variants(i)
    dets = {}
    for method in ("vibe", "running_average"):
        if any(m == method for m, _ in variants.values()) or (
                method == "vibe" and config.cells):
            dets[method] = segment_scene(scene, method, rng)[0]
    runs = {f"{t} {v}": (method, cfg)
            for v, (method, pair) in variants.items() for t, cfg in pair.items()}
    runs.update({f"FJPDA {c}": ("vibe", cfg) for c, cfg in config.grid(i).items()})
    veh = np.nonzero(scene.is_vehicle)[0]
    xy, present = scene.xy[:, veh], scene.present[:, veh]
    dist = {label: match_tracks(xy, present, run_jpda_tracker(dets[method], cfg))[1]
            for label, (method, cfg) in runs.items()}
    return i, {c: same_frames_error(dist[a], dist[b]) for c, (a, b) in config.compared()}


def _call(config):
    return (config,), {}


def _extract(out, config):
    i, cells = out
    row = {"scene": np.int64(i)}
    pairs = dict(config.compared())
    for c, r in cells.items():
        a, b = pairs[c]
        row[f"sf {c}.pairs"] = np.int64(r.pairs)
        row[f"sf {c}.diff_sum"] = np.float64(r.diff_sum)
        for label, own, n in ((a, r.own_a, r.matched_a), (b, r.own_b, r.matched_b)):
            row[f"{label}.motp"] = np.float64(own)
            row[f"{label}.matched"] = np.int64(n)
    return row


def _register():
    register(Experiment(
        name="fjpda-accuracy",
        description=("Feature-JPDA chapter, the position error FJPDA - JPDA on the frames "
                     "where both keep a vehicle, on the runs of fjpda-oat: the correlation "
                     "x template grid and each other reading changed alone (segmentation, "
                     "memory, tsi, rho-weight, measurement, gate-size, clutter-density, "
                     "duplicate-distance)"),
        trial=accuracy_trial, call=_call, extract=_extract, config=FjpdaAccuracyConfig(),
        seed=FJPDA_OAT_SEED, runs=ACCURACY_RUNS, version="1",
        notebook="book/004-feature-jpda/10-accuracy-same-frames.ipynb"))


_register()
