"""Feature-JPDA chapter (004): the open readings varied one at a time (issue 29).

``fjpda-oat``: run ``i`` renders the ambiguity scene ``OAT_SCENES[i % 6]`` (glare, side by
side, occlusion, S3 under 5 px, the S1 layout under 5 and 3 px, at the camera jitters of
:data:`~trackcore.experiments.fjpda_readings.READINGS_SCENES`), segments it once by ViBe
and once by the running average and runs JPDA and FJPDA, each at the default cell (canvas
correlation, template updated with guard, matched to the scene's jitter by
:func:`~trackcore.trackers.jpda_tracker.matched_config`, c_I 0.6) and at every value of
:data:`VARIED`, one reading changed at a time for both trackers of the pair: every pair
is a paired FJPDA - JPDA comparison on the same rendered scene.  The running-average
pair tracks the running average's detections; every other pair the ViBe detections.
A row holds the scene index (``scene``) and per tracker ``"<tracker> <value key>"`` the
readings fields (``V.<field>``, ``V.false_<source>``), plus the position error ``V.motp``.

The clutter density "matched to the scene" follows :func:`clutter_per_frame` and
:func:`matched_density`: the mean number per frame of ViBe detections none of whose
pixels lies on a vehicle's rendered pixels, divided by the image area (240 x 320 px),
measured per scene on :data:`CALIBRATION_RUNS` calibration renders of the master seed
:data:`FJPDA_CALIBRATION_SEED` (disjoint from the runs'); the values, measured before
any run, are frozen in :data:`MATCHED_LAM`.

``fjpda-confirm-s3``: the configuration, trial and rows of
``fjpda-readings-s3-jitter5`` restricted to JPDA and the four correlation x template
cells (no S3 ablations), on 600 fresh seeds (:data:`FJPDA_OAT_SEED` + 1): the S3
false-track parts had 200 seeds where the S1 layout's got 600.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import check_names
from ._core import Experiment, register
from .fjpda_readings import READING_VARIANTS, READINGS_SCENES, FjpdaReadingsConfig
from .fjpda_templates import metric_columns
from .registry import _Config

__all__ = [
    "CALIBRATION_RUNS",
    "CONFIRM_S3_RUNS",
    "FJPDA_CALIBRATION_SEED",
    "FJPDA_OAT_SEED",
    "IMAGE_AREA",
    "MATCHED_LAM",
    "OAT_RUNS",
    "OAT_SCENES",
    "VARIED",
    "FjpdaConfirmS3Config",
    "FjpdaOatConfig",
    "clutter_per_frame",
    "matched_density",
    "oat_trial",
    "scene_of_run",
]

#: the scenes of fjpda-oat (keys of READINGS_SCENES), run i renders OAT_SCENES[i % 6]
OAT_SCENES = ("glare", "side-by-side", "occlusion", "s3-jitter5", "s1-jitter5", "s1-jitter3")
#: value key -> (reading, value as claims.yml names it, segmentation, tracker overrides);
#: "lam" takes the scene's matched density (MATCHED_LAM)
VARIED = {
    "default": ("", "", "vibe", {}),
    "seg_ra": ("segmentation", "running average", "running_average", {}),
    "mem1": ("memory", "1", "vibe", {"memory_frames": 1}),
    "tsi": ("tsi", "not validated by the variant", "vibe", {"tsi_from": "unvalidated"}),
    "rho": ("rho-weight", "normalised per track", "vibe", {"rho_weight": "normalised"}),
    "rw": ("measurement", "position, random-walk state", "vibe", {"model": "rw"}),
    "gate20": ("gate-size", "20 px", "vibe", {"gate_max": 20.0}),
    "lam": ("clutter-density", "matched to the scene", "vibe", {}),
}
#: the image area (px^2) the clutter count is spread over
IMAGE_AREA = 240 * 320
#: calibration renders per scene for the matched density, and their master seed
CALIBRATION_RUNS = 50
FJPDA_OAT_SEED = 20160325 + 600
FJPDA_CALIBRATION_SEED = FJPDA_OAT_SEED + 2
#: the matched clutter density (px^-2) per scene of OAT_SCENES, measured by
#: matched_density(key) before any run (declared; tests check it recomputes)
MATCHED_LAM = {"glare": 7.075320512820513e-06, "side-by-side": 4.3402777777777775e-09,
               "occlusion": 4.734848484848485e-09, "s3-jitter5": 2.3567708333333333e-06,
               "s1-jitter5": 6.923363095238095e-06, "s1-jitter3": 6.938244047619047e-06}
#: runs of fjpda-oat (200 per scene) and of fjpda-confirm-s3
OAT_RUNS = 200 * len(OAT_SCENES)
CONFIRM_S3_RUNS = 600


def clutter_per_frame(scene, detections, margin=4):
    """Per scene frame, the detections none of whose blob pixels lies on a vehicle's
    rendered pixels (``scene.labels``, image coordinates, as the detections): an array
    of counts.  ``margin`` is the crop margin of
    :func:`~trackcore.detection.image.detect_blobs` (its default, 4 px).

    Examples
    --------
    >>> from trackcore.scenarios.feature_scenes import render_scene, segment_scene
    >>> scene = render_scene("glare", np.random.default_rng(0), jitter=5.0)
    >>> dets, _ = segment_scene(scene, "vibe", np.random.default_rng(1))
    >>> counts = clutter_per_frame(scene, dets)
    >>> len(counts) == len(dets), int(counts.min()) >= 0
    (True, True)
    """
    from ..scenarios.feature_scenes import N_WARMUP

    H, W = scene.labels.shape[1:]
    veh = np.nonzero(scene.is_vehicle)[0] + 1
    out = np.zeros(len(detections), np.int64)
    for k, det in enumerate(detections):
        on_vehicle = np.isin(scene.labels[N_WARMUP + k], veh)
        for (r0, c0, r1, c1), m in zip(det.boxes, det.masks):
            R0, C0 = max(r0 - margin, 0), max(c0 - margin, 0)
            if m.shape != (min(r1 + margin, H) - R0, min(c1 + margin, W) - C0):
                raise ValueError(f"a detection crop of shape {m.shape} does not match its "
                                 f"box with a {margin} px margin")
            crop = on_vehicle[R0:R0 + m.shape[0], C0:C0 + m.shape[1]]
            out[k] += not np.any(crop & m)
    return out


def matched_density(key, runs=CALIBRATION_RUNS, seed=FJPDA_CALIBRATION_SEED):
    """The clutter density (px^-2) matched to the scene ``key`` (of :data:`OAT_SCENES`):
    the mean of :func:`clutter_per_frame` over the frames of ``runs`` calibration renders
    (run ``j`` of scene ``i`` uses the stream ``j`` of ``SeedSequence(seed + i)``, ViBe
    detections at the scene's jitter), over :data:`IMAGE_AREA`.  A scene without a
    clutter detection in its calibration frames gets the floor of one detection over
    them (the tracker needs a density > 0; the smallest count a finite calibration
    distinguishes from none).

    Examples
    --------
    >>> lam = matched_density("glare", runs=2)
    >>> 0 < lam < 1e-3
    True
    """
    from ..core.rng import generator_for_run
    from ..scenarios.feature_scenes import render_scene, segment_scene

    i = OAT_SCENES.index(key)
    name, jitter, _ = READINGS_SCENES[key]
    counts = []
    for j in range(runs):
        rng = generator_for_run(seed + i, j, runs)
        scene = render_scene(name, rng, jitter=jitter)
        dets, _ = segment_scene(scene, "vibe", rng)
        counts.append(clutter_per_frame(scene, dets))
    counts = np.concatenate(counts)
    return max(float(counts.sum()), 1.0) / (counts.size * IMAGE_AREA)


@dataclass(frozen=True)
class FjpdaOatConfig(_Config):
    """The one-at-a-time runs: ``scenes`` (keys of
    :data:`~trackcore.experiments.fjpda_readings.READINGS_SCENES`, run ``i`` renders
    ``scenes[i % len(scenes)]``), ``values`` (keys of :data:`VARIED`, ``"default"``
    first) and ``lam`` the matched clutter density per scene (px^-2, each > 0).

    Examples
    --------
    >>> config = FjpdaOatConfig()
    >>> config.scenes[:4], len(config.scenes), len(config.values)
    (('glare', 'side-by-side', 'occlusion', 's3-jitter5'), 6, 8)
    >>> v = config.variants(0)
    >>> sorted(v)[:3], v["mem1"][1]["FJPDA"].memory_frames
    (['default', 'gate20', 'lam'], 1)
    >>> FjpdaOatConfig(values=("memory",))
    Traceback (most recent call last):
        ...
    ValueError: unknown value 'memory' in values; expected some of ('default', 'seg_ra', 'mem1', 'tsi', 'rho', 'rw', 'gate20', 'lam')
    """

    scenes: tuple = OAT_SCENES
    values: tuple = tuple(VARIED)
    lam: tuple = ()

    _KINDS = {"scenes": tuple, "values": tuple, "lam": "floats"}  # noqa: RUF012
    _VARIED = VARIED  # the value keys (a subclass may name others)
    _FIRST = "default"  # the value every config starts with (None: any)

    def __post_init__(self):
        check_names(self.scenes, "scenes", tuple(READINGS_SCENES), "scene")
        check_names(self.values, "values", tuple(self._VARIED), "value")
        if self._FIRST is not None and self.values[0] != self._FIRST:
            raise ValueError(f"values must start with {self._FIRST!r}, got {self.values!r}")
        lam = self.lam or tuple(MATCHED_LAM.get(s) for s in self.scenes)
        if len(lam) != len(self.scenes) or any(
                x is None or not np.isfinite(x) or x <= 0 for x in lam):
            raise ValueError(f"lam must hold one density > 0 per scene, got {lam!r}")
        object.__setattr__(self, "lam", tuple(float(x) for x in lam))

    def variants(self, i):
        """Scene ``i`` (an index of ``scenes``): ``{value: (segmentation,
        {"JPDA": cfg, "FJPDA": cfg})}``."""
        from ..trackers.jpda_tracker import matched_config

        jitter = float(READINGS_SCENES[self.scenes[i]][1])
        out = {}
        for v in self.values:
            _, _, method, kw = self._VARIED[v]
            kw = {"lam": self.lam[i]} if v == "lam" else kw
            out[v] = (method, {t: matched_config(t, jitter, **kw) for t in ("JPDA", "FJPDA")})
        return out


def scene_of_run(rng, n_scenes):
    """The scene index of a store's run: its index ``i`` (the spawn key of
    ``SeedSequence(seed).spawn(n)[i]``, the generator of run ``i``) modulo ``n_scenes``.

    Examples
    --------
    >>> from trackcore.core.rng import generator_for_run
    >>> [scene_of_run(generator_for_run(5, i, 10), 4) for i in (0, 3, 6)]
    [0, 3, 2]
    """
    ss = rng.bit_generator.seed_seq
    if not isinstance(ss, np.random.SeedSequence) or len(ss.spawn_key) != 1:
        raise ValueError("a run needs the store's generator of run i "
                         "(SeedSequence(seed).spawn(n)[i])")
    return int(ss.spawn_key[0]) % n_scenes


def oat_trial(rng, config):
    """One run: ``(scene index, {"<tracker> <value>": SceneMetrics})``: the scene of
    :func:`scene_of_run` rendered once, segmented by ViBe (first, drawing from ``rng``)
    and by the running average, every pair of ``config.variants`` on its detections.

    Examples
    --------
    Run 1 of a store renders the second scene (side by side); here only the default pair
    and the one-frame memory run:

    >>> from trackcore.core.rng import generator_for_run
    >>> config = FjpdaOatConfig(values=("default", "mem1"))
    >>> i, out = oat_trial(generator_for_run(7, 1, 6), config)
    >>> i, sorted(out)
    (1, ['FJPDA default', 'FJPDA mem1', 'JPDA default', 'JPDA mem1'])
    """
    from ..scenarios.feature_metrics import scene_metrics

    i, scene, runs = _oat_runs(rng, config)
    return i, {label: scene_metrics(scene, reports) for label, (_, reports) in runs.items()}


def _oat_runs(rng, config):
    """The tracker runs of one run of :func:`oat_trial`, before any metric: ``(scene
    index, scene, {"<tracker> <value>": (config, frame reports)})``, with the same draws
    in the same order (shared by the trials that read more of the runs than
    :func:`oat_trial` stores)."""
    from ..scenarios.feature_scenes import render_scene, segment_scene
    from ..trackers.jpda_tracker import run_jpda_tracker

    i = scene_of_run(rng, len(config.scenes))
    name, jitter, _ = READINGS_SCENES[config.scenes[i]]
    scene = render_scene(name, rng, jitter=jitter)
    variants = config.variants(i)
    dets = {}
    for method in ("vibe", "running_average"):
        if any(m == method for m, _ in variants.values()):
            dets[method] = segment_scene(scene, method, rng)[0]
    runs = {}
    for v, (method, pair) in variants.items():
        for t, cfg in pair.items():
            runs[f"{t} {v}"] = (cfg, run_jpda_tracker(dets[method], cfg))
    return i, scene, runs


def _oat_call(config):
    return (config,), {}


def _oat_extract(out, config):
    i, metrics = out
    row = {"scene": np.int64(i)}
    for label, m in metrics.items():
        metric_columns(row, label, m)
        row[f"{label}.motp"] = np.float64(m.motp)
    return row


@dataclass(frozen=True)
class FjpdaConfirmS3Config(FjpdaReadingsConfig):
    """S3 under 5 px as in ``fjpda-readings-s3-jitter5``, without the S3 ablations:
    JPDA and the four correlation x template cells.

    Examples
    --------
    >>> list(FjpdaConfirmS3Config().variants())
    ['JPDA', 'FJPDA', 'FJPDA, canvas, fixed', 'FJPDA, sliding, updated', 'FJPDA, sliding, fixed']
    """

    scene: str = "S3"
    jitter: float = 5.0
    extras: tuple = ()

    def __post_init__(self):
        super().__post_init__()
        if self.extras:
            raise ValueError(f"the S3 confirmation runs no extras, got {self.extras!r}")

    def variants(self) -> dict:
        from ..trackers.jpda_tracker import matched_config

        return {label: matched_config(v, float(self.jitter), **kw)
                for label, (v, kw) in READING_VARIANTS.items()}


_NB = "book/004-feature-jpda/08-readings-one-at-a-time.ipynb"


def _register():
    from .fjpda_readings import _call, _extract, readings_trial

    if all(MATCHED_LAM.get(s) is not None for s in OAT_SCENES):
        register(Experiment(
            name="fjpda-oat",
            description=("Feature-JPDA chapter, the readings one at a time: JPDA and FJPDA "
                         "at the default cell and at each other value of segmentation, "
                         "memory, tsi, rho-weight, measurement, gate-size and "
                         "clutter-density, in glare, side by side, occlusion, S3 and the "
                         "S1 layout under 5 and 3 px"),
            trial=oat_trial, call=_oat_call, extract=_oat_extract, config=FjpdaOatConfig(),
            seed=FJPDA_OAT_SEED, runs=OAT_RUNS, version="1", notebook=_NB))
    register(Experiment(
        name="fjpda-confirm-s3",
        description=(f"Feature-JPDA chapter, confirmation of the false tracks in S3 under "
                     f"5 px at {CONFIRM_S3_RUNS} fresh seeds: JPDA and the four "
                     f"correlation x template cells on the same detections"),
        trial=readings_trial, call=_call, extract=_extract, config=FjpdaConfirmS3Config(),
        seed=FJPDA_OAT_SEED + 1, runs=CONFIRM_S3_RUNS, version="1", notebook=_NB))


_register()
