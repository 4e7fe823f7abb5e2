"""The TBD chapter's extensions page (book/003-tbd-pf/05-extensions.ipynb): its Monte Carlo
experiments, registered as ``tbd-ext-*``.

Every experiment runs one existing trial, :func:`~trackcore.scenarios.tbd_paired_trial`
(detections) or :func:`~trackcore.scenarios.tbd_intensity_trial` (intensity maps), with a
set of trackers on the same runs; :func:`tbd_extension_trackers` names them, in the
order of the stored columns.  A row holds, per tracker, the per-run numbers every table
and interval of the page uses: the mean error over scans k <= 100 and over the whole run
(the paper's metric), the run's outcome (0 not lost, 1 lost and back, 2 diverged, 3 still
lost: :func:`~trackcore.trackers.tbd_run_outcomes`); the error series (float32, for the
median-error figures only) where a figure needs them; the detections per scan in the
window (intensity maps).
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from ..scenarios import (
    TbdRadarParameters,
    tbd_intensity_trial,
    tbd_paired_trial,
    tbd_radar_truth,
)
from ..trackers import (
    IntensityGrid,
    IntensityTbdConfig,
    TbdTrackerConfig,
    intensity_tracker_config,
    tbd_run_outcomes,
)
from ._checks import check_finite
from ._core import Experiment, register
from .registry import _Config

__all__ = ["TbdExtensionsConfig", "tbd_extension_trackers"]

#: The tracker sets of the page (``TbdExtensionsConfig.block``).
BLOCKS = ("pda", "ablations", "scenario", "roughening", "maps")
#: The blocks whose rows keep the error series (a figure shows their medians).
SERIES_BLOCKS = ("pda", "maps")
_FLUCTUATIONS = ("lognormal", "swerling1")


@dataclass(frozen=True)
class TbdExtensionsConfig(_Config):
    """One Monte Carlo table of the TBD chapter's extensions page.

    ``block``: the trackers run on the same runs (see :func:`tbd_extension_trackers`):
    ``"pda"`` (C and the PDA-PF P), ``"ablations"`` (the variants of A, B and C),
    ``"scenario"`` (A with ``pseudo_sigma``, B and C), ``"roughening"`` (C with K = 0
    and 0.2) or ``"maps"`` (the raw-intensity filter I and C, P at 5 dB and at
    ``map_threshold`` dB, on intensity maps).  ``processing_radius`` (m): the trackers'
    window (for ``"maps"`` that of C and P; the maps' scenario keeps its default);
    ``fluctuation`` and ``clutter_density`` (cells per km^3 per scan): the scenario's;
    ``pseudo_sigma`` (m): method A's pseudo-measurement noise in ``"scenario"``
    (0 elsewhere); ``map_threshold`` (dB): the second threshold of ``"maps"``
    (0 elsewhere).

    Examples
    --------
    >>> from trackcore.experiments.tbd_extensions import TbdExtensionsConfig
    >>> cfg = TbdExtensionsConfig(block="pda", processing_radius=1000.0)
    >>> cfg.block, cfg.fluctuation, cfg.pseudo_sigma
    ('pda', 'lognormal', 0.0)
    """

    block: str
    processing_radius: float = 2500.0
    fluctuation: str = "lognormal"
    clutter_density: float = 2.820
    pseudo_sigma: float = 0.0
    map_threshold: float = 0.0

    _KINDS = {"block": str, "processing_radius": float, "fluctuation": str,
              "clutter_density": float, "pseudo_sigma": float, "map_threshold": float}

    def with_overrides(self, overrides):
        """The config with ``overrides`` ({field: value}, ``--set`` strings parsed)."""
        strs = {k: str(v) for k, v in overrides.items() if self._KINDS.get(k) is str}
        rest = {k: v for k, v in overrides.items() if k not in strs}
        out = super().with_overrides(rest) if rest else self
        return dataclasses.replace(out, **strs) if strs else out

    def __post_init__(self):
        if self.block not in BLOCKS:
            raise ValueError(f"block must be one of {BLOCKS}, got {self.block!r}")
        if self.fluctuation not in _FLUCTUATIONS:
            raise ValueError(f"fluctuation must be one of {_FLUCTUATIONS}, "
                             f"got {self.fluctuation!r}")
        for name in ("processing_radius", "clutter_density", "pseudo_sigma",
                     "map_threshold"):
            check_finite(getattr(self, name), name)
        if self.processing_radius <= 0:
            raise ValueError(f"processing_radius must be > 0, got {self.processing_radius}")
        if self.clutter_density < 0:
            raise ValueError(f"clutter_density must be >= 0, got {self.clutter_density}")
        if (self.block == "scenario") != (self.pseudo_sigma > 0):
            raise ValueError("pseudo_sigma must be > 0 for block 'scenario' and 0 "
                             f"otherwise, got {self.pseudo_sigma} for {self.block!r}")
        if (self.block == "maps") != (self.map_threshold > 0):
            raise ValueError("map_threshold must be > 0 for block 'maps' and 0 "
                             f"otherwise, got {self.map_threshold} for {self.block!r}")

    def radar(self) -> TbdRadarParameters:
        """The scenario's parameters."""
        kw = {"fluctuation": self.fluctuation, "clutter_density": self.clutter_density}
        if self.block != "maps":
            kw["processing_radius"] = self.processing_radius
        return TbdRadarParameters(**kw)


def _ablations(base):
    abl = {
        "A (default)": TbdTrackerConfig(method="A", **base),
        "A, no gate (literal)": TbdTrackerConfig(method="A", gate=np.inf, **base),
        "A, one detection's noise": TbdTrackerConfig(
            method="A", pseudo_covariance="sensor", **base),
        "A, sensor noise + spread": TbdTrackerConfig(
            method="A", pseudo_covariance="spread", **base),
        "A + Doppler": TbdTrackerConfig(method="A", use_doppler=True, **base),
        "A, r_m from previous estimate": TbdTrackerConfig(
            method="A", weight_reference="previous", **base),
        "B (default)": TbdTrackerConfig(method="B", **base),
        "B + Doppler": TbdTrackerConfig(method="B", use_doppler=True, **base),
        "B, r_m from previous estimate": TbdTrackerConfig(
            method="B", weight_reference="previous", **base),
        "C (default)": TbdTrackerConfig(method="C", **base),
    }
    for m in "BC":
        abl[f"{m}, P_fa = exp(-tau)"] = TbdTrackerConfig(
            method=m, pfa=np.exp(-(10**0.5)), **base)
        for sr in (100.0, 300.0):
            abl[f"{m}, sigma_r = {sr:.0f} m"] = TbdTrackerConfig(
                method=m, sigma_r=sr, **base)
        for sv in (20.0, 60.0):
            abl[f"{m}, sigma_v = {sv:.0f} m/s"] = TbdTrackerConfig(
                method=m, sigma_v=sv, **base)
        abl[f"{m}, Gaussian kernels"] = TbdTrackerConfig(method=m, kernel="gaussian", **base)
    return abl


@functools.lru_cache(maxsize=32)
def tbd_extension_trackers(config) -> dict:
    """The trackers of ``config`` (a :class:`TbdExtensionsConfig`): ``{label: config}``
    in the page's order (the order of the stored per-tracker columns).

    Examples
    --------
    >>> from trackcore.experiments.tbd_extensions import (
    ...     TbdExtensionsConfig, tbd_extension_trackers)
    >>> trk = tbd_extension_trackers(TbdExtensionsConfig(block="pda"))
    >>> {k: c.method for k, c in trk.items()}
    {'C': 'C', 'P': 'P'}
    """
    if not isinstance(config, TbdExtensionsConfig):
        raise TypeError(f"config must be a TbdExtensionsConfig, got {type(config).__name__}")
    R = config.processing_radius
    base = {"processing_radius": R}
    if config.block == "pda":
        return {m: TbdTrackerConfig(method=m, **base) for m in "CP"}
    if config.block == "ablations":
        return _ablations(base)
    if config.block == "scenario":
        return {"A": TbdTrackerConfig(method="A", pseudo_sigma=config.pseudo_sigma, **base),
                "B": TbdTrackerConfig(method="B", **base),
                "C": TbdTrackerConfig(method="C", **base)}
    if config.block == "roughening":
        return {f"K = {K}": TbdTrackerConfig(method="C", roughening=K, **base)
                for K in (0.0, 0.2)}
    grid = IntensityGrid()
    out = {"I (raw intensity)": IntensityTbdConfig()}
    thr = config.map_threshold
    for t, tag in ((5.0, "5 dB"), (thr, f"{thr:.1f} dB")):
        for m in "CP":
            out[f"{m}, {tag}"] = intensity_tracker_config(
                m, grid, threshold_db=t, processing_radius=R)
    return out


@functools.lru_cache(maxsize=1)
def _truth():
    return tbd_radar_truth()


def _call(config):
    return (tbd_extension_trackers(config), config.radar(), _truth()), {}


def _extract(result, config):
    """Per tracker: ``mean100``, ``mean_all``, ``outcome`` (int8); ``errors`` (float32
    series) for the figure blocks; ``n_processed`` (mean detections per scan in the
    window) for the detection-level trackers of ``"maps"``."""
    names = list(tbd_extension_trackers(config))
    E = np.array([result.errors[k] for k in names])  # (trackers, scans)
    out = tbd_run_outcomes(E)
    code = np.zeros(len(names), dtype=np.int8)
    code[out.transient], code[out.diverged], code[out.other] = 1, 2, 3
    row = {"mean100": E[:, :100].mean(axis=1), "mean_all": E.mean(axis=1),
           "outcome": code}
    if config.block in SERIES_BLOCKS:
        row["errors"] = E.astype(np.float32)
    if config.block == "maps":
        row["n_processed"] = np.array([result.n_processed[k].mean() for k in names[1:]])
    return row


SEED = 20160307
_NB = "book/003-tbd-pf/05-extensions.ipynb"
#: Method A's pseudo-measurement noise (m) calibrated on 100 runs of seed SEED + 10 for
#: each scenario (the page recomputes it and passes it as ``pseudo_sigma``).
CALIBRATED_SIGMA = {"swerling1": 464.4987775680545, "lambda1-1": 303.02814274779007,
                    "lambda1-2": 244.69073123879235}
#: The map threshold (dB) whose false-alarm density matches the detection scenario's,
#: to 0.1 dB (the page recomputes it).
MAP_THRESHOLD = 8.3
_EXPERIMENTS = (
    ("tbd-ext-pda-r25", "the PDA-PF against C at R = 2.5 km (error series)",
     TbdExtensionsConfig("pda"), 100),
    ("tbd-ext-pda-r10", "the PDA-PF against C at R = 1 km (error series)",
     TbdExtensionsConfig("pda", processing_radius=1000.0), 100),
    ("tbd-ext-ablations", "24 variants of methods A, B and C at R = 2.5 km",
     TbdExtensionsConfig("ablations"), 100),
    ("tbd-ext-scen-swerling1", "A (calibrated), B, C against a Swerling I target",
     TbdExtensionsConfig("scenario", fluctuation="swerling1",
                         pseudo_sigma=CALIBRATED_SIGMA["swerling1"]), 100),
    ("tbd-ext-scen-lambda1-1", "A (calibrated), B, C with lambda_1 = 1",
     TbdExtensionsConfig("scenario", clutter_density=2.820 * 1.0 / 0.5,
                         pseudo_sigma=CALIBRATED_SIGMA["lambda1-1"]), 100),
    ("tbd-ext-scen-lambda1-2", "A (calibrated), B, C with lambda_1 = 2",
     TbdExtensionsConfig("scenario", clutter_density=2.820 * 2.0 / 0.5,
                         pseudo_sigma=CALIBRATED_SIGMA["lambda1-2"]), 100),
    ("tbd-ext-rough-r25", "C with roughening K = 0 and 0.2 at R = 2.5 km",
     TbdExtensionsConfig("roughening"), 100),
    ("tbd-ext-rough-r10", "C with roughening K = 0 and 0.2 at R = 1 km",
     TbdExtensionsConfig("roughening", processing_radius=1000.0), 100),
    ("tbd-ext-maps", ("raw-intensity TBD against C and P on the same intensity maps "
                      "(error series)"),
     TbdExtensionsConfig("maps", processing_radius=1000.0, map_threshold=MAP_THRESHOLD),
     60),
)
for _name, _desc, _config, _runs in _EXPERIMENTS:
    register(Experiment(
        name=_name, description=f"TBD chapter, extensions: {_desc}",
        trial=tbd_intensity_trial if _config.block == "maps" else tbd_paired_trial,
        call=_call, extract=_extract, config=_config, seed=SEED, runs=_runs,
        version="1", notebook=_NB))
