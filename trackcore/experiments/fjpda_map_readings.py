"""Feature-JPDA chapter (004): the occlusion map's pending template cells and its open
readings (issue 29, session 15).

``fjpda-occlusion-map-readings``: the SAME master seed
(:data:`~trackcore.experiments.fjpda_templates.FJPDA_MAP_SEED`) and run count (40) as
``fjpda-occlusion-map``, and the same draws from each run's generator in the same order
(every offset of :data:`~trackcore.experiments.fjpda_templates.MAP_OFFSETS` rendered, then
segmented by ViBe, in turn), so every offset of every run is the same render and the same
ViBe segmentation as in the map; its JPDA rows at memory 1 and 2 must equal the map's, run
for run (a test checks it).  On those scenes it runs

* the eight cells the map left pending (:data:`MAP_NEW_CELLS`): FJPDA with the template
  updated without guard and fixed from the first fully visible silhouette, each with the
  canvas and the sliding correlation, at every memory of :data:`MAP_READINGS_MEMORY`,
  beside JPDA at the same memory (``"<cell> m<memory>"``, ``"JPDA m<memory>"``); FJPDA at
  the default cell and memory 2 (``"cu m2"``) is run again, a second check against the
  map;
* the readings varied one at a time from the default cell (canvas, updated with guard,
  memory 2) for both trackers (:data:`MAP_VARIED`, ``"JPDA <value>"`` and ``"FJPDA
  <value>"``): the running-average segmentation (its own detections and silhouettes of
  the same render; it draws no random numbers, so the renders stay the map's), tsi "not
  validated by the variant", rho normalised per track, the random-walk state, position
  and velocity measured, G_th 20 px, d_dup 2 px and the clutter density matched to the
  scene (``lam``).

The matched density is ``fjpda-oat``'s of the occlusion scene
(:data:`~trackcore.experiments.fjpda_oat.MATCHED_LAM` ``["occlusion"]``: no clutter
detection in its calibration frames, so the floor of one over them) at every offset: the
map's crossing is that scene with only the vehicles' crossing offset changed; the
background, the noise and the camera jitter that make the clutter are the scene's.

A row holds per offset the merged frames (``c<c>.merged``) and per tracker the TMR
counts, the covered frames and the false tracks (``c<c>.<label>.<field>``, the fields of
:data:`MAP_READINGS_FIELDS`).

``fjpda-occlusion-map-confirm`` (declared in session 15 after a review on fresh seeds):
the same trial (:func:`map_readings_trial`, the occlusion crossing at every offset of
:data:`~trackcore.experiments.fjpda_templates.MAP_OFFSETS`, ViBe, 3 px jitter) on a
fresh master seed (:data:`FJPDA_MAP_CONFIRM_SEED`), :data:`MAP_CONFIRM_RUNS` runs, with
JPDA and the map's four tying cells (:data:`MAP_CONFIRM_CELLS`: the sliding correlation
with the template fixed first, ``sf``, and fixed at the first fully visible silhouette,
``sv``) at memory 1 and 2 (:class:`FjpdaMapConfirmConfig`); the rows have the fields
above.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import check_finite, check_jitter, check_names
from ._core import Experiment, register
from .fjpda_oat import MATCHED_LAM, VARIED
from .fjpda_oat_vel import VARIED_DUP, VARIED_VEL
from .fjpda_templates import (
    FJPDA_MAP_SEED,
    MAP_OFFSETS,
    NEW_CELLS,
    TEMPLATE_VARIANTS,
    FjpdaOcclusionMapConfig,
)
from .registry import _Config

__all__ = ["FJPDA_MAP_CONFIRM_SEED", "MAP_CONFIRM_CELLS", "MAP_CONFIRM_RUNS",
           "FjpdaMapConfirmConfig", "MAP_NEW_CELLS", "MAP_READINGS_FIELDS", "MAP_READINGS_MEMORY", "MAP_VARIED",
           "FjpdaMapReadingsConfig", "map_cells", "map_readings_trial", "map_results",
           "side"]

#: the map's pending cells: glue suffix -> FJPDA keywords of matched_config
MAP_NEW_CELLS = {k: dict(TEMPLATE_VARIANTS[label][1]) for k, label in NEW_CELLS.items()}
#: the memories of the pending cells (frames): the values of the memory reading
MAP_READINGS_MEMORY = (1.0, 2.0)
#: value key -> (reading, value as claims.yml names it, segmentation, tracker keywords):
#: the readings varied one at a time from the default cell; "lam" takes ``config.lam``
MAP_VARIED = {
    **{k: VARIED[k] for k in ("seg_ra", "tsi", "rho", "rw")},
    "pv": VARIED_VEL["pv"],
    "dd2": VARIED_DUP["dd2"],
    "gate20": VARIED["gate20"],
    "lam": VARIED["lam"],
}
#: the stored fields per offset and tracker
MAP_READINGS_FIELDS = ("tmr_num", "tmr_den", "coverage_num", "false_tracks")


@dataclass(frozen=True)
class FjpdaMapReadingsConfig(_Config):
    """The map's readings: crossing ``offsets`` (px, each in [0, 30]), the ``memory``
    lengths of the pending cells (frames, whole numbers in [1, 100]), the ``values``
    varied (keys of :data:`MAP_VARIED`), camera ``jitter`` (px) and ``lam`` the matched
    clutter density (px^-2, > 0).

    Examples
    --------
    JPDA and the four pending cells per memory, the default FJPDA, then each value for
    both trackers:

    >>> config = FjpdaMapReadingsConfig()
    >>> v = config.variants()
    >>> len(v), list(v)[:5], list(v)[-2:]
    (27, ['JPDA m1', 'cn m1', 'cv m1', 'sn m1', 'sv m1'], ['JPDA lam', 'FJPDA lam'])
    >>> v["FJPDA seg_ra"][0], v["sv m2"][1].template_from, v["JPDA gate20"][1].gate_max
    ('running_average', 'fully_visible', 20.0)
    >>> FjpdaMapReadingsConfig(values=("mem1",))
    Traceback (most recent call last):
        ...
    ValueError: unknown value 'mem1' in values; expected some of ('seg_ra', 'tsi', 'rho', 'rw', 'pv', 'dd2', 'gate20', 'lam')
    """

    offsets: tuple = MAP_OFFSETS
    memory: tuple = MAP_READINGS_MEMORY
    values: tuple = tuple(MAP_VARIED)
    jitter: float = 3.0
    lam: float = MATCHED_LAM["occlusion"]

    _KINDS = {"offsets": "floats", "memory": "floats", "values": tuple,  # noqa: RUF012
              "jitter": float, "lam": float}

    def __post_init__(self):
        # the offsets, memories and jitter are checked as the map checks them
        FjpdaOcclusionMapConfig(self.offsets, self.memory, self.jitter)
        check_names(self.values, "values", tuple(MAP_VARIED), "value", empty=True)
        check_finite(self.lam, "lam")
        if not self.lam > 0:
            raise ValueError(f"lam must be > 0 px^-2, got {self.lam!r}")
        check_jitter(self.jitter)

    def variants(self) -> dict:
        """``{label: (segmentation, JPDATrackerConfig)}``: per memory JPDA and
        :data:`MAP_NEW_CELLS`, FJPDA at the default cell (``"cu m2"``, if memory 2 is
        run), then both trackers at each value of ``values``."""
        from ..trackers.jpda_tracker import matched_config

        j = float(self.jitter)
        out = {}
        for m in self.memory:
            out[f"JPDA m{m:g}"] = ("vibe", matched_config("JPDA", j, memory_frames=int(m)))
            for cell, kw in MAP_NEW_CELLS.items():
                out[f"{cell} m{m:g}"] = ("vibe", matched_config(
                    "FJPDA", j, memory_frames=int(m), **kw))
        if 2.0 in self.memory:
            out["cu m2"] = ("vibe", matched_config("FJPDA", j, memory_frames=2))
        for v in self.values:
            _, _, method, kw = MAP_VARIED[v]
            kw = {"lam": float(self.lam)} if v == "lam" else kw
            for t in ("JPDA", "FJPDA"):
                out[f"{t} {v}"] = (method, matched_config(t, j, **kw))
        return out


#: the confirmation's FJPDA cells: glue suffix -> matched_config keywords (the sliding
#: correlation, the template fixed first and fixed at the first fully visible silhouette)
MAP_CONFIRM_CELLS = {"sf": {"correlation": "sliding", "template_update": False},
                     "sv": {"correlation": "sliding", **MAP_NEW_CELLS["sv"]}}
#: master seed of fjpda-occlusion-map-confirm (fresh: 20160325 + 1320; no other store uses
#: it, and it lies outside the reviews' 1500000000-1510000010)
FJPDA_MAP_CONFIRM_SEED = 20160325 + 1320
#: runs of fjpda-occlusion-map-confirm (declared from the review's 560-run pilot)
MAP_CONFIRM_RUNS = 1000


@dataclass(frozen=True)
class FjpdaMapConfirmConfig(_Config):
    """The confirmation of the map's tying cells: crossing ``offsets`` (px, each in [0,
    30]), ``memory`` lengths (frames, whole numbers in [1, 100]) and camera ``jitter``
    (px), checked as the map checks them.

    Examples
    --------
    >>> v = FjpdaMapConfirmConfig().variants()
    >>> list(v)
    ['JPDA m1', 'sf m1', 'sv m1', 'JPDA m2', 'sf m2', 'sv m2']
    >>> v["sv m2"][1].template_from, v["sf m2"][1].template_update, v["sf m1"][1].correlation
    ('fully_visible', False, 'sliding')
    >>> FjpdaMapConfirmConfig(memory=(0.5,))
    Traceback (most recent call last):
        ...
    ValueError: memory must hold whole numbers in [1, 100], got 0.5
    """

    offsets: tuple = MAP_OFFSETS
    memory: tuple = MAP_READINGS_MEMORY
    jitter: float = 3.0

    _KINDS = {"offsets": "floats", "memory": "floats",  # noqa: RUF012
              "jitter": float}

    def __post_init__(self):
        FjpdaOcclusionMapConfig(self.offsets, self.memory, self.jitter)

    def variants(self) -> dict:
        """``{label: ("vibe", JPDATrackerConfig)}``: per memory JPDA and
        :data:`MAP_CONFIRM_CELLS` (``"<cell> m<memory>"``)."""
        from ..trackers.jpda_tracker import matched_config

        j = float(self.jitter)
        out = {}
        for m in self.memory:
            out[f"JPDA m{m:g}"] = ("vibe", matched_config("JPDA", j, memory_frames=int(m)))
            for cell, kw in MAP_CONFIRM_CELLS.items():
                out[f"{cell} m{m:g}"] = ("vibe", matched_config(
                    "FJPDA", j, memory_frames=int(m), **kw))
        return out


def map_readings_trial(rng, offsets, variants, jitter):
    """One run: per offset ``(merged frames, {label: SceneMetrics})``.  Every offset is
    rendered and segmented by ViBe in turn from ``rng`` exactly as
    :func:`~trackcore.experiments.fjpda_templates.occlusion_map_trial` does (the same
    scenes); the running average (no random numbers) segments the same render for the
    trackers that ask for it.

    Examples
    --------
    >>> from trackcore.experiments.fjpda_templates import occlusion_map_trial
    >>> from trackcore.trackers.jpda_tracker import matched_config
    >>> cfg = matched_config("JPDA", 3.0)
    >>> a = map_readings_trial(np.random.default_rng(3), (10.0, 4.0),
    ...                        {"JPDA": ("vibe", cfg)}, 3.0)
    >>> b = occlusion_map_trial(np.random.default_rng(3), (10.0, 4.0), {"JPDA": cfg}, 3.0)
    >>> [a[c][0] for c in a] == [b[c][0] for c in b]  # merged frames
    True
    >>> a[4.0][1]["JPDA"].tmr_num == b[4.0][1]["JPDA"].tmr_num
    True
    """
    from ..scenarios.feature_metrics import scene_metrics
    from ..scenarios.feature_scenes import render_scene, segment_scene
    from ..trackers.jpda_tracker import run_jpda_tracker

    methods = {method for method, _ in variants.values()}
    out = {}
    for c in offsets:
        scene = render_scene("occlusion", rng, jitter=jitter, crossing_offset=c)
        dets = {"vibe": segment_scene(scene, "vibe", rng)[0]}
        if "running_average" in methods:
            dets["running_average"] = segment_scene(scene, "running_average")[0]
        out[c] = (int(scene.merged.sum()),
                  {label: scene_metrics(scene, run_jpda_tracker(dets[method], cfg))
                   for label, (method, cfg) in variants.items()})
    return out


def _call(config):
    return (tuple(float(c) for c in config.offsets), config.variants(),
            float(config.jitter)), {}


def _extract(out, config):
    row = {}
    for c, (merged, metrics) in out.items():
        row[f"c{c:g}.merged"] = np.int64(merged)
        for label, m in metrics.items():
            for f in MAP_READINGS_FIELDS:
                row[f"c{c:g}.{label}.{f}"] = np.int64(getattr(m, f))
    return row


def map_cells(memory=MAP_READINGS_MEMORY, values=tuple(MAP_VARIED)):
    """The store's comparisons, in the order of the claims' grid: ``{key: (FJPDA label,
    JPDA label, claims' cell label)}``, the pending cells per memory (longest first; key
    ``"<cell>_m<memory>"``), the default cell (key ``"default"``, the map's own cell, run
    again, if memory 2 is run), then the readings ``values`` of :data:`MAP_VARIED` (key:
    the value).

    Examples
    --------
    >>> cells = map_cells()
    >>> cells["cn_m2"]
    ('cn m2', 'JPDA m2', 'canvas, updated without guard, 2')
    >>> cells["tsi"][2]
    'canvas, updated with guard, 2; tsi: not validated by the variant'
    >>> list(cells)[7:10]
    ['sv_m1', 'default', 'seg_ra']
    """
    from .fjpda_dup_readings import GRID

    out = {}
    for m in sorted(memory, reverse=True):
        for cell in MAP_NEW_CELLS:
            corr, tpl, _ = GRID[cell]
            out[f"{cell}_m{m:g}"] = (f"{cell} m{m:g}", f"JPDA m{m:g}",
                                     f"{corr}, {tpl}, {m:g}")
    if 2.0 in memory:
        out["default"] = ("cu m2", "JPDA m2", "canvas, updated with guard, 2")
    for v in values:
        reading, value, _, _ = MAP_VARIED[v]
        out[v] = (f"FJPDA {v}", f"JPDA {v}", f"canvas, updated with guard, 2; {reading}: {value}")
    return out


def map_results(res, offsets=MAP_OFFSETS, memory=MAP_READINGS_MEMORY,
                values=tuple(MAP_VARIED)):
    """The TMR, FJPDA - JPDA, paired over the runs of a store of this design (a
    ``Results`` or a dict of columns), per offset and comparison of :func:`map_cells`
    (of ``memory`` and ``values``):
    ``{(offset, key): (glued text, comparison)}`` and table rows (the claims' cell label
    and the text at each offset).  The text is the difference with its 95 % interval
    (``format(diff, ".2g")``), or
    :data:`~trackcore.experiments.fjpda_readings.NO_TRACK` where neither tracker confirms
    a track in any run (:func:`~trackcore.experiments.fjpda_readings.confirms_nothing`:
    the measure's premise is absent).

    Examples
    --------
    Two runs-worth of columns at one offset, the readings left out; JPDA keeps more
    frames than every FJPDA cell:

    >>> rng = np.random.default_rng(4)
    >>> cols = {}
    >>> for label in ("JPDA m2", "cn m2", "cv m2", "sn m2", "sv m2", "cu m2"):
    ...     cols[f"c6.{label}.tmr_den"] = np.full(40, 100)
    ...     cols[f"c6.{label}.tmr_num"] = rng.integers(60, 70, 40) + 30 * (label[0] == "J")
    ...     cols[f"c6.{label}.coverage_num"] = np.full(40, 90)
    ...     cols[f"c6.{label}.false_tracks"] = np.zeros(40, int)
    >>> cells, rows = map_results(cols, offsets=(6.0,), memory=(2.0,), values=())
    >>> cells[6.0, "cn_m2"][1].verdict, rows[0][0]
    ('JPDA better', 'canvas, updated without guard, 2')
    >>> cols = {k: 0 * v for k, v in cols.items() if "tmr_den" not in k} | {
    ...     k: v for k, v in cols.items() if "tmr_den" in k}
    >>> map_results(cols, offsets=(6.0,), memory=(2.0,), values=())[1][0][1]
    'not applicable: neither tracker confirms a track in any run'
    """
    from .fjpda_readings import NO_TRACK, compare, confirms_nothing, per_run

    cells = {}
    table = map_cells(memory, values)
    for c in offsets:
        for key, (fj, jp, _) in table.items():
            a, b = f"c{c:g}.{fj}", f"c{c:g}.{jp}"
            d = compare(per_run(res, a, "tmr"), per_run(res, b, "tmr"), ("FJPDA", "JPDA"),
                        False)
            text = NO_TRACK if confirms_nothing(res, [a, b]) else format(d.diff, ".2g")
            cells[c, key] = (text, d)
    rows = [(label, *(cells[c, key][0] for c in offsets))
            for key, (_, _, label) in table.items()]
    return cells, rows


def side(text):
    """Where a glued difference lies against 0, read as the scorecard reads it: ``"below
    0"`` (its interval wholly below 0: the occlusion loss appears), ``"above 0"``, ``"a
    tie"``, ``"no interval"`` or ``"not applicable"``.

    Examples
    --------
    >>> side("-0.26 [-0.29, -0.23]"), side("0.0077 [-0.0099, 0.18]"), side("-0.02 (no interval)")
    ('below 0', 'a tie', 'no interval')
    >>> side("not applicable: neither tracker confirms a track in any run")
    'not applicable'
    """
    import re

    if text.startswith("not applicable"):
        return "not applicable"
    m = re.fullmatch(r"\S+ \[(\S+), (\S+)\]", text)
    if m is None:
        return "no interval"
    lo, hi = float(m.group(1)), float(m.group(2))
    return "above 0" if lo > 0 else "below 0" if hi < 0 else "a tie"


register(Experiment(
    name="fjpda-occlusion-map-readings",
    description=("Feature-JPDA chapter, the occlusion map's pending template cells (no "
                 "guard, first fully visible; memory 1 and 2) and its readings one at a "
                 "time (the renders of fjpda-occlusion-map): TMR, coverage and false "
                 "tracks of JPDA and FJPDA"),
    trial=map_readings_trial, call=_call, extract=_extract,
    config=FjpdaMapReadingsConfig(), seed=FJPDA_MAP_SEED, runs=40, version="1",
    notebook="book/004-feature-jpda/12-occlusion-map-readings.ipynb"))


register(Experiment(
    name="fjpda-occlusion-map-confirm",
    description=("Feature-JPDA chapter, confirmation of the occlusion map's tying cells "
                 "(sliding correlation, template fixed first and first fully visible; "
                 "memory 1 and 2) on fresh seeds: TMR, coverage and false tracks of JPDA "
                 "and FJPDA"),
    trial=map_readings_trial, call=_call, extract=_extract,
    config=FjpdaMapConfirmConfig(), seed=FJPDA_MAP_CONFIRM_SEED, runs=MAP_CONFIRM_RUNS,
    version="1", notebook="book/004-feature-jpda/12-occlusion-map-readings.ipynb"))
