"""Feature-JPDA chapter (004): the measurement reading "position and velocity" (issue 29).

``fjpda-oat-vel``: the runs of ``fjpda-oat`` (:func:`~trackcore.experiments.fjpda_oat.oat_trial`:
run ``i`` renders ``OAT_SCENES[i % 6]``, segmented once by ViBe) for the value the
one-at-a-time store could not run, because the tracker had no such measurement: the
detector reports the target's velocity as well as its position (``model="pv"`` of
:class:`~trackcore.trackers.jpda_tracker.JPDATrackerConfig`, whose docstring states the
reading).  JPDA and FJPDA run at the chapter's default cell (canvas correlation, template
updated with guard, :func:`~trackcore.trackers.jpda_tracker.matched_config` for the
scene's jitter, c_I 0.6, lam 1e-5) with ``model="pv"`` and, on the same render and
detections, at the default cell itself, so that the pv cell's FJPDA - JPDA differences
are paired within this store, on master seed :data:`FJPDA_OAT_VEL_SEED` (fresh: disjoint
from ``fjpda-oat``'s, ``fjpda-confirm-s3``'s and the calibration renders' seeds).
The rows are those of ``fjpda-oat`` for the value keys ``"default"`` and ``"pv"``.

``fjpda-oat-dup``: the same design for the reading "duplicate-distance" declared after the
session-13 review: JPDA and FJPDA at the default cell with ``d_dup`` 2 px (not scaled
with the jitter, as the default 5 px is not) and, on the same render and detections, at
the default cell itself, 200 fresh seeds per scene, master seed
:data:`FJPDA_OAT_DUP_SEED`.

``fjpda-confirm-pv``: the confirmation of the pv cell's false tracks beside the glare and
side by side, declared in session 15 after a hostile review's fresh seeds had not
replicated the 200-seed glare value: the trial of ``fjpda-oat-vel``
(:func:`~trackcore.experiments.fjpda_oat.oat_trial`, run ``i`` renders
``CONFIRM_PV_SCENES[i % 2]``, segmented by ViBe) with JPDA and FJPDA at the pv cell only
(``VARIED_VEL["pv"]``), :data:`CONFIRM_PV_RUNS` runs on the fresh master seed
:data:`FJPDA_CONFIRM_PV_SEED`.  The size: the review's 1000-seed pilot put the side-by-side
difference near 0.025 per sequence with a 95 % half-width of about 0.023; intervals narrow
as 1/sqrt(n), so 2000 seeds per scene give about 0.016.
"""
from __future__ import annotations

from dataclasses import dataclass

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

__all__ = ["CONFIRM_PV_RUNS", "CONFIRM_PV_SCENES", "FJPDA_CONFIRM_PV_SEED",
           "FJPDA_OAT_DUP_SEED", "FJPDA_OAT_VEL_SEED", "OAT_VEL_RUNS", "VARIED_DUP",
           "VARIED_VEL", "FjpdaConfirmPvConfig", "FjpdaOatDupConfig", "FjpdaOatVelConfig"]

#: value key -> (reading, value as claims.yml names it, segmentation, tracker overrides)
VARIED_VEL = {
    "default": VARIED["default"],
    "pv": ("measurement", "position and velocity", "vibe", {"model": "pv"}),
}
#: the master seed of fjpda-oat-vel (fjpda-oat: FJPDA_OAT_SEED, fjpda-confirm-s3: + 1,
#: the calibration renders: + 2 to + 7)
FJPDA_OAT_VEL_SEED = FJPDA_OAT_SEED + 10
assert FJPDA_OAT_VEL_SEED > FJPDA_CALIBRATION_SEED + len(OAT_SCENES) - 1
#: value key -> (reading, value, segmentation, tracker overrides) of fjpda-oat-dup
VARIED_DUP = {
    "default": VARIED["default"],
    "dd2": ("duplicate-distance", "2 px", "vibe", {"d_dup": 2.0}),
}
#: the master seed of fjpda-oat-dup (fresh: no other store, notebook or review uses it)
FJPDA_OAT_DUP_SEED = FJPDA_OAT_SEED + 20
#: runs of fjpda-oat-vel (and fjpda-oat-dup): 200 per scene
OAT_VEL_RUNS = 200 * len(OAT_SCENES)
#: the scenes of fjpda-confirm-pv: run i renders CONFIRM_PV_SCENES[i % 2]
CONFIRM_PV_SCENES = ("glare", "side-by-side")
#: runs of fjpda-confirm-pv: 2000 per scene
CONFIRM_PV_RUNS = 2000 * len(CONFIRM_PV_SCENES)
#: the master seed of fjpda-confirm-pv, fresh: no other store, notebook or review uses it
FJPDA_CONFIRM_PV_SEED = FJPDA_OAT_SEED + 40


@dataclass(frozen=True)
class FjpdaOatVelConfig(FjpdaOatConfig):
    """:class:`~trackcore.experiments.fjpda_oat.FjpdaOatConfig` over the values of
    :data:`VARIED_VEL` (``"default"`` first).

    Examples
    --------
    >>> config = FjpdaOatVelConfig()
    >>> config.values, len(config.scenes)
    (('default', 'pv'), 6)
    >>> method, pair = config.variants(3)["pv"]
    >>> method, pair["FJPDA"].model, pair["JPDA"].model, round(pair["JPDA"].r_std, 2)
    ('vibe', 'pv', 'pv', 5.1)
    >>> FjpdaOatVelConfig(values=("default", "rw"))
    Traceback (most recent call last):
        ...
    ValueError: unknown value 'rw' in values; expected some of ('default', 'pv')
    """

    values: tuple = tuple(VARIED_VEL)
    _VARIED = VARIED_VEL


@dataclass(frozen=True)
class FjpdaOatDupConfig(FjpdaOatConfig):
    """:class:`~trackcore.experiments.fjpda_oat.FjpdaOatConfig` over the values of
    :data:`VARIED_DUP` (``"default"`` first).

    Examples
    --------
    >>> method, pair = FjpdaOatDupConfig().variants(3)["dd2"]
    >>> method, pair["FJPDA"].d_dup, pair["JPDA"].d_dup, pair["JPDA"].duplicate_deletion
    ('vibe', 2.0, 2.0, True)
    """

    values: tuple = tuple(VARIED_DUP)
    _VARIED = VARIED_DUP


@dataclass(frozen=True)
class FjpdaConfirmPvConfig(FjpdaOatConfig):
    """:class:`~trackcore.experiments.fjpda_oat.FjpdaOatConfig` over the pv cell only
    (``VARIED_VEL["pv"]``), in the scenes of :data:`CONFIRM_PV_SCENES`.

    Examples
    --------
    >>> config = FjpdaConfirmPvConfig()
    >>> config.scenes, config.values
    (('glare', 'side-by-side'), ('pv',))
    >>> method, pair = config.variants(1)["pv"]
    >>> method, pair["FJPDA"].model, pair["JPDA"].model
    ('vibe', 'pv', 'pv')
    >>> FjpdaConfirmPvConfig(values=("default",))
    Traceback (most recent call last):
        ...
    ValueError: unknown value 'default' in values; expected some of ('pv',)
    """

    scenes: tuple = CONFIRM_PV_SCENES
    values: tuple = ("pv",)
    _VARIED = {"pv": VARIED_VEL["pv"]}  # noqa: RUF012
    _FIRST = None


def _register():
    register(Experiment(
        name="fjpda-oat-vel",
        description=("Feature-JPDA chapter, the measurement reading 'position and "
                     "velocity': JPDA and FJPDA at the default cell with the detector's "
                     "velocity measured (model pv) and at the default cell, in glare, side "
                     "by side, occlusion, S3 and the S1 layout under 5 and 3 px"),
        trial=oat_trial, call=_oat_call, extract=_oat_extract, config=FjpdaOatVelConfig(),
        seed=FJPDA_OAT_VEL_SEED, runs=OAT_VEL_RUNS, version="1",
        notebook="book/004-feature-jpda/08-readings-one-at-a-time.ipynb"))

    register(Experiment(
        name="fjpda-oat-dup",
        description=("Feature-JPDA chapter, the reading 'duplicate-distance': JPDA and "
                     "FJPDA at the default cell with d_dup 2 px and at the default cell, "
                     "in glare, side by side, occlusion, S3 and the S1 layout under 5 and "
                     "3 px"),
        trial=oat_trial, call=_oat_call, extract=_oat_extract, config=FjpdaOatDupConfig(),
        seed=FJPDA_OAT_DUP_SEED, runs=OAT_VEL_RUNS, version="1",
        notebook="book/004-feature-jpda/08-readings-one-at-a-time.ipynb"))

    register(Experiment(
        name="fjpda-confirm-pv",
        description=(f"Feature-JPDA chapter, confirmation of the false tracks of the "
                     f"measurement 'position and velocity' beside the glare and side by "
                     f"side at {CONFIRM_PV_RUNS // 2} fresh seeds per scene: JPDA and "
                     f"FJPDA at the default cell with model pv"),
        trial=oat_trial, call=_oat_call, extract=_oat_extract,
        config=FjpdaConfirmPvConfig(), seed=FJPDA_CONFIRM_PV_SEED, runs=CONFIRM_PV_RUNS,
        version="1", notebook="book/004-feature-jpda/08-readings-one-at-a-time.ipynb"))


_register()
