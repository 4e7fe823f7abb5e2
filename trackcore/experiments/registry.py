"""The book's registered experiments: config records, trial calls and row extractors.

Each config record is a frozen dataclass that validates itself when built and knows
how to apply ``--set key=value`` overrides (:meth:`with_overrides`, values given as
strings on the command line are parsed to the field's type).
"""
from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np

from ..scenarios.houles import houles_imm_trial
from ..scenarios.hpda_scenario import (
    HPDA_ALGORITHMS,
    HPDA_METRICS,
    HpdaParameters,
    hpda_parameters,
    run_hpda_trial,
)
from ._core import Experiment, register

__all__ = ["HpdaMonteCarloConfig", "HoulesConfig"]


def _parse(value, kind, name):
    """A ``--set`` value (str) or a Python value, converted to ``kind``."""
    if kind is float:
        if isinstance(value, bool):
            raise TypeError(f"{name} must be a number, got {value!r}")
        try:
            out = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a number, got {value!r}") from None
        if not math.isfinite(out):
            raise ValueError(f"{name} must be finite, got {value!r}")
        return out
    if kind is int:
        if isinstance(value, str):
            try:
                value = int(value)
            except ValueError:
                raise ValueError(f"{name} must be an integer, got {value!r}") from None
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be an integer, got {value!r}")
        return int(value)
    if kind is tuple:
        if isinstance(value, str):
            value = tuple(v.strip() for v in value.split(",") if v.strip())
        if not isinstance(value, (tuple, list)):
            raise TypeError(f"{name} must be a sequence of names, got {value!r}")
        return tuple(str(v) for v in value)
    raise AssertionError(kind)  # pragma: no cover


class _Config:
    """Shared ``with_overrides`` of the config records."""

    _KINDS: dict = {}

    def with_overrides(self, overrides):
        kinds = self._KINDS
        unknown = sorted(set(overrides) - set(kinds))
        if unknown:
            raise ValueError(f"unknown config field(s) {unknown} for {type(self).__name__}; "
                             f"fields: {sorted(kinds)}")
        parsed = {k: _parse(v, kinds[k], k) for k, v in overrides.items()}
        return dataclasses.replace(self, **parsed)


# ------------------------------------------------------------------------------ HPDA (000)
_SCENARIO_FIELDS = ("pd", "snr", "clutter_mean", "sigma_r", "sigma_theta")


@dataclass(frozen=True)
class HpdaMonteCarloConfig(_Config):
    """One environment of the HPDA chapter's Monte Carlo comparison.

    ``case`` 1, 2 (the paper's) or 3 (the book's stress case); ``algorithms`` the
    trackers run on the same scans (keys of ``HPDA_ALGORITHMS``); ``pd``, ``snr``,
    ``clutter_mean``, ``sigma_r``, ``sigma_theta``: scenario overrides of the case's
    :class:`~trackcore.scenarios.HpdaParameters` (``None``: the case's value).
    """

    case: int
    algorithms: tuple
    pd: float | None = None
    snr: float | None = None
    clutter_mean: float | None = None
    sigma_r: float | None = None
    sigma_theta: float | None = None

    _KINDS = {"case": int, "algorithms": tuple, "pd": float, "snr": float,
              "clutter_mean": float, "sigma_r": float, "sigma_theta": float}

    def __post_init__(self):
        if isinstance(self.case, bool) or not isinstance(self.case, (int, np.integer)) \
                or self.case not in (1, 2, 3):
            raise ValueError(f"case must be 1, 2 or 3, got {self.case!r}")
        if not isinstance(self.algorithms, tuple) or not self.algorithms:
            raise TypeError(f"algorithms must be a non-empty tuple, got {self.algorithms!r}")
        for a in self.algorithms:
            if a not in HPDA_ALGORITHMS:
                raise ValueError(f"unknown algorithm {a!r} in algorithms; expected some of "
                                 f"{HPDA_ALGORITHMS}")
        if len(set(self.algorithms)) != len(self.algorithms):
            raise ValueError(f"algorithms must not repeat, got {self.algorithms}")
        self.parameters()  # HpdaParameters validates the overrides

    def scenario(self) -> dict:
        return {k: getattr(self, k) for k in _SCENARIO_FIELDS if getattr(self, k) is not None}

    def parameters(self) -> HpdaParameters:
        return dataclasses.replace(hpda_parameters(self.case), **self.scenario())


def _hpda_call(config):
    kwargs = {"metrics": True}
    if config.scenario():
        kwargs["scenario_overrides"] = config.scenario()
    return (config.case, config.algorithms), kwargs


def _hpda_extract(out, config):
    """Per run and tracker: the count per scan (int16), the confirmation and termination
    delays per target, the per-run metrics; SMC-PHD's sum of weights per scan; HPDA-PF's
    selection diagnostics; the number of measurements."""
    row = {"n_measurements": np.int64(out["n_measurements"])}
    for a in config.algorithms:
        rec = out[a]
        count = np.asarray(rec["count"])
        small = count.astype(np.int16)
        if not np.array_equal(small, count):
            raise ValueError(f"{a}: a count does not fit in int16")
        row[f"{a}.count"] = small
        row[f"{a}.conf_delay"] = np.asarray(rec["conf_delay"], dtype=np.float64)
        row[f"{a}.term_delay"] = np.asarray(rec["term_delay"], dtype=np.float64)
        for m in HPDA_METRICS:
            row[f"{a}.{m}"] = np.float64(rec["metrics"][m])
        if a == "phd":
            row["phd.aux"] = np.asarray(rec["aux"], dtype=np.float64)
        if a == "hpda":
            row["hpda.diagnostics"] = np.asarray(rec["diagnostics"], dtype=np.float64)
    return row


HPDA_SEED = 20070828
HPDA_ALGS = {
    1: ("hpda", "phd", "clustering", "clustering_literal"),
    2: ("hpda", "phd", "clustering", "clustering_literal"),
    3: ("hpda", "hpda_sn", "hpda_nn", "phd"),
}
for _case, _what in ((1, "benign case 1 (P_D, rho, lambda V) = (0.9, 10, 10)"),
                     (2, "hostile case 2 (0.6, 5, 50)"),
                     (3, "stress case 3 (coarse sensor, ~1 false return per gate)")):
    register(Experiment(
        name=f"hpda-mc-case{_case}",
        description=f"HPDA chapter, Figs 8-9 Monte Carlo, {_what}: "
                    f"{', '.join(HPDA_ALGS[_case])} on the same 451 scans",
        trial=run_hpda_trial, call=_hpda_call, extract=_hpda_extract,
        config=HpdaMonteCarloConfig(_case, HPDA_ALGS[_case]),
        seed=HPDA_SEED + _case, runs=100, version="1",
        notebook="book/000-hpda/06-monte-carlo.ipynb"))


# -------------------------------------------------------------------------- TOM-IMM (001)
@dataclass(frozen=True)
class HoulesConfig(_Config):
    """Table 1 of the TOM-IMM chapter: Singer-, CAR- and TOM-IMM-PDAFs on the Houles
    scenario in clutter.  ``car_sigma_cv`` CAR's CV noise (m/s^2), ``pg`` the gate
    probability, ``clutter_density`` (1/m^2), ``pd`` the detection probability."""

    car_sigma_cv: float = 5.0
    pg: float = 0.99
    clutter_density: float = 2e-6
    pd: float = 1.0

    _KINDS = {"car_sigma_cv": float, "pg": float, "clutter_density": float, "pd": float}

    def __post_init__(self):
        for name in self._KINDS:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating)) \
                    or not math.isfinite(v):
                raise ValueError(f"{name} must be a finite number, got {v!r}")
        if self.car_sigma_cv <= 0:
            raise ValueError(f"car_sigma_cv must be > 0, got {self.car_sigma_cv}")
        if not 0 < self.pg < 1:
            raise ValueError(f"pg must be in (0, 1), got {self.pg}")
        if self.clutter_density < 0:
            raise ValueError(f"clutter_density must be >= 0, got {self.clutter_density}")
        if not 0 < self.pd <= 1:
            raise ValueError(f"pd must be in (0, 1], got {self.pd}")


@functools.lru_cache(maxsize=8)
def _houles_model_sets(car_sigma_cv):
    from ..trackers import car_imm_model_set, singer_imm_model_set, tom_imm_model_set

    return (singer_imm_model_set(), car_imm_model_set(sigma_cv=car_sigma_cv),
            tom_imm_model_set())


def _houles_call(config):
    return (list(_houles_model_sets(config.car_sigma_cv)),), {
        "pg": config.pg, "clutter_density": config.clutter_density, "pd": config.pd}


def _houles_extract(run, config):
    """Squared position error (Singer, CAR, TOM; t = 1..90) and the target's gating
    (t = 2..90: 1 gated, 0 outside every gate, -1 missed)."""
    return {"pos_err2": np.asarray(run.pos_err2, dtype=np.float64),
            "target_gated": np.asarray(run.target_gated, dtype=np.int8)}


register(Experiment(
    name="tom-imm-houles",
    description="TOM-IMM chapter, Table 1: Singer-, CAR- and TOM-IMM-PDAF on the Houles "
                "scenario in clutter (not yet stored; its notebook runs it live)",
    trial=houles_imm_trial, call=_houles_call, extract=_houles_extract,
    config=HoulesConfig(), seed=20261123, runs=1000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))
