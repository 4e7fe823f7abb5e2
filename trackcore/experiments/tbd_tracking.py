"""The TBD chapter's tracking experiments (book/003-tbd-pf/04-tracking.ipynb).

Methods A, B and C (and their ablations) on the chapter's radar scenario, through
:func:`trackcore.scenarios.tbd_paired_trial`, and the calibration of method A's
pseudo-measurement noise.  Every experiment is named ``tbd-tracking-*``; the
``-25`` / ``-10`` suffix is the processing radius (2.5 km / 1 km).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ._checks import check_finite, check_names
from ._core import Experiment, register
from .registry import _Config

__all__ = ["TbdCalibrationConfig", "TbdTrackingConfig"]

#: The chapter's master seed (the calibration uses ``TBD_SEED + 10``).
TBD_SEED = 20160307
_NB = "book/003-tbd-pf/04-tracking.ipynb"
_RADII = {2500.0: "25", 1000.0: "10"}


def _check_scenario(config):
    for name in ("processing_radius", "snr0_db", "clutter_density"):
        check_finite(getattr(config, name), name)
    if config.processing_radius <= 0:
        raise ValueError(f"processing_radius must be > 0, got {config.processing_radius}")
    if config.clutter_density < 0:
        raise ValueError(f"clutter_density must be >= 0, got {config.clutter_density}")


@functools.lru_cache(maxsize=16)
def _scenario(processing_radius, snr0_db, clutter_density):
    """The radar parameters and the truth (whose mean SNR follows ``snr0_db``)."""
    from ..scenarios import TbdRadarParameters, tbd_radar_truth

    prm = TbdRadarParameters(processing_radius=float(processing_radius),
                             snr0_db=float(snr0_db), clutter_density=float(clutter_density))
    return prm, tbd_radar_truth(prm)


def _tracker(key, processing_radius):
    """The tracker named ``key``: ``A``, ``B``, ``C`` (the chapter's), ``A1`` (A given one
    detection's noise, the literal reading) or ``C<N>`` (C with ``N`` particles)."""
    from ..trackers import TbdTrackerConfig

    if not isinstance(key, str):
        raise TypeError(f"a tracker key must be a str, got {key!r}")
    R = float(processing_radius)
    if key in ("A", "B", "C"):
        return TbdTrackerConfig(method=key, processing_radius=R)
    if key == "A1":
        return TbdTrackerConfig(method="A", processing_radius=R, pseudo_covariance="sensor")
    if key.startswith("C") and key[1:].isdigit() and int(key[1:]) > 0:
        return TbdTrackerConfig(method="C", processing_radius=R, n_particles=int(key[1:]))
    raise ValueError(f"unknown tracker key {key!r}; expected 'A', 'B', 'C', 'A1' or 'C<N>' "
                     f"(C with N particles)")


@dataclass(frozen=True)
class TbdTrackingConfig(_Config):
    """Trackers of the TBD chapter run on the same detections and start per run.

    ``trackers``: keys of :func:`_tracker` (``A``, ``B``, ``C``, ``A1``, ``C<N>``);
    ``processing_radius`` (m; 2500 or 1000 for the calibrated A); ``nees_scans``: the
    first scans of the method-A trackers' NEES stored (0: none); ``snr0_db`` and
    ``clutter_density``: overrides of the scenario (:class:`TbdRadarParameters`).

    Examples
    --------
    >>> from trackcore.experiments.tbd_tracking import TbdTrackingConfig
    >>> cfg = TbdTrackingConfig(("A", "B", "C600"), processing_radius=1000.0)
    >>> cfg.trackers, cfg.nees_scans
    (('A', 'B', 'C600'), 0)
    """

    trackers: tuple
    processing_radius: float = 2500.0
    nees_scans: int = 0
    snr0_db: float = 3.0
    clutter_density: float = 2.820

    _KINDS = {"trackers": tuple, "processing_radius": float, "nees_scans": int,
              "snr0_db": float, "clutter_density": float}

    def __post_init__(self):
        check_names(self.trackers, "trackers")
        _check_scenario(self)
        for key in self.trackers:
            _tracker(key, self.processing_radius)  # raises on a bad key or radius
        n = self.nees_scans
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 0 <= n <= 250:
            raise ValueError(f"nees_scans must be an integer in [0, 250], got {n!r}")
        _scenario(self.processing_radius, self.snr0_db, self.clutter_density)

    def tracker_configs(self) -> dict:
        return {k: _tracker(k, self.processing_radius) for k in self.trackers}


def _tracking_call(config):
    prm, truth = _scenario(config.processing_radius, config.snr0_db, config.clutter_density)
    return (config.tracker_configs(), prm, truth), {}


def _tracking_extract(out, config):
    """Per tracker its error per scan ``err.KEY`` (250 scans; every table, figure and
    verdict of the page derives from them), the method-A trackers' NEES over the first
    ``nees_scans`` scans ``nees.KEY``, and the shared start ``x0`` (the pairing check)."""
    row = {"x0": np.asarray(out.x0, dtype=np.float64)}
    for key in config.trackers:
        row[f"err.{key}"] = np.asarray(out.errors[key], dtype=np.float64)
        if config.nees_scans and key in out.nees:
            row[f"nees.{key}"] = np.asarray(out.nees[key][:config.nees_scans],
                                            dtype=np.float64)
    return row


@dataclass(frozen=True)
class TbdCalibrationConfig(_Config):
    """Method A's pseudo-measurement errors with the window on the truth, over the first
    ``window`` scans, at ``processing_radius`` (m), with the scenario overrides
    ``snr0_db`` and ``clutter_density``.

    Examples
    --------
    >>> from trackcore.experiments.tbd_tracking import TbdCalibrationConfig
    >>> cfg = TbdCalibrationConfig(processing_radius=1000.0)
    >>> cfg.window, cfg.snr0_db, cfg.clutter_density
    (100, 3.0, 2.82)
    """

    processing_radius: float = 2500.0
    window: int = 100
    snr0_db: float = 3.0
    clutter_density: float = 2.820

    _KINDS = {"processing_radius": float, "window": int, "snr0_db": float,
              "clutter_density": float}

    def __post_init__(self):
        _check_scenario(self)
        w = self.window
        if isinstance(w, bool) or not isinstance(w, (int, np.integer)) or not 1 <= w <= 250:
            raise ValueError(f"window must be an integer in [1, 250], got {w!r}")
        _scenario(self.processing_radius, self.snr0_db, self.clutter_density)


def _calibration_trial(rng, params, truth):
    """One run of the calibration: the detections of a run and the errors of ``p̄`` (and
    of its Doppler) with the processing window centred on the truth."""
    from ..scenarios import simulate_tbd_radar
    from ..trackers import TbdTrackerConfig, pseudo_measurement_errors

    scans = simulate_tbd_radar(truth, params, rng)
    cfg = TbdTrackerConfig(method="A", processing_radius=params.processing_radius)
    return pseudo_measurement_errors(scans, truth.states, cfg)


def _calibration_call(config):
    prm, truth = _scenario(config.processing_radius, config.snr0_db, config.clutter_density)
    return (prm, truth), {}


def _calibration_extract(out, config):
    """Over the first ``window`` scans: the mean square position error of ``p̄`` per axis
    ``ms_p`` and of its Doppler ``ms_v`` (NaN scans left out), the scans with a ``p̄``
    ``n_valid`` and those more than 500 m off ``n_far``."""
    dp, dv = out[0][:config.window], out[1][:config.window]
    return {"ms_p": np.float64(np.nanmean(dp**2)), "ms_v": np.float64(np.nanmean(dv**2)),
            "n_valid": np.int64(np.sum(np.isfinite(dv))),
            "n_far": np.int64(np.sum(np.linalg.norm(dp, axis=1) > 500.0))}


def _register():
    from ..scenarios import tbd_paired_trial

    for R, rk in _RADII.items():
        km = f"R = {R / 1000:.1f} km"
        register(Experiment(
            name=f"tbd-tracking-calibration-{rk}",
            description=f"TBD chapter, method A's pseudo-measurement noise calibrated at {km} "
                        f"(window on the truth, scans 1..100)",
            trial=_calibration_trial, call=_calibration_call, extract=_calibration_extract,
            config=TbdCalibrationConfig(processing_radius=R), seed=TBD_SEED + 10, runs=200,
            version="1", notebook=_NB))
        for kind, what, trackers, nees, runs in (
                ("main", "Table 3, Figs 10 and 13: methods A, B and C", ("A", "B", "C"),
                 100, {2500.0: 1000, 1000.0: 500}[R]),
                ("literal", "A given one detection's noise (ablation), paired with Table 3",
                 ("A1",), 100, 200),
                ("sweep", "Figs 11-12: method C with N = 10..1000 particles (not 600)",
                 tuple(f"C{n}" for n in (10, 30, 50, 100, 200, 400, 800, 1000)), 0, 200)):
            register(Experiment(
                name=f"tbd-tracking-{kind}-{rk}",
                description=f"TBD chapter at {km}, {what} (error per scan per run)",
                trial=tbd_paired_trial, call=_tracking_call, extract=_tracking_extract,
                config=TbdTrackingConfig(trackers, processing_radius=R, nees_scans=nees),
                seed=TBD_SEED, runs=runs, version="1", notebook=_NB))


_register()
