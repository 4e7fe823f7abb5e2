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
from ._checks import check_finite, check_names
from ._core import Experiment, register

__all__ = ["HoulesConfig", "HoulesSweepConfig", "HpdaMonteCarloConfig", "houles_sweep_trial"]


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
    if kind == "floats":
        if isinstance(value, str):
            value = tuple(v.strip() for v in value.split(",") if v.strip())
        if not isinstance(value, (tuple, list)):
            raise TypeError(f"{name} must be a sequence of numbers, got {value!r}")
        return tuple(_parse(v, float, name) for v in value)
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

    Examples
    --------
    >>> c = HpdaMonteCarloConfig(1, ("hpda", "phd"))
    >>> c.parameters().pd, c.parameters().snr
    (0.9, 10.0)
    >>> c.with_overrides({"pd": "0.8"}).scenario()
    {'pd': 0.8}
    >>> HpdaMonteCarloConfig(4, ("hpda",))
    Traceback (most recent call last):
    ...
    ValueError: case must be 1, 2 or 3, got 4
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
        check_names(self.algorithms, "algorithms", HPDA_ALGORITHMS, "algorithm")
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
    probability, ``clutter_density`` (1/m^2), ``pd`` the detection probability.

    Examples
    --------
    >>> HoulesConfig().with_overrides({"pg": "0.9999"})
    HoulesConfig(car_sigma_cv=5.0, pg=0.9999, clutter_density=2e-06, pd=1.0)
    >>> HoulesConfig(pg=1.0)
    Traceback (most recent call last):
    ...
    ValueError: pg must be in (0, 1), got 1.0
    """

    car_sigma_cv: float = 5.0
    pg: float = 0.99
    clutter_density: float = 2e-6
    pd: float = 1.0

    _KINDS = {"car_sigma_cv": float, "pg": float, "clutter_density": float, "pd": float}

    def __post_init__(self):
        for name in self._KINDS:
            check_finite(getattr(self, name), name)
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
    description="TOM-IMM chapter, Table 1 and Fig. 5: Singer-, CAR- and TOM-IMM-PDAF on the "
                "Houles scenario in clutter (error series and gating per run)",
    trial=houles_imm_trial, call=_houles_call, extract=_houles_extract,
    config=HoulesConfig(), seed=20261123, runs=1000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))


@dataclass(frozen=True)
class HoulesSweepConfig(_Config):
    """Variants of the Houles experiment reduced to per-run metrics (no error series).

    ``filters``: IMM-PDAFs run on the same measurements, each ``"singer"`` (the
    chapter's Singer-IMM), ``"singer:TAU:SIGMA_M"`` (its fast Singer model set to
    ``tau`` s and ``sigma_m`` m/s^2), ``"car:SIGMA_CV"`` (the CAR-IMM with that CV
    noise, m/s^2) or ``"tom"``; ``gates``: gate probabilities, each run with every
    filter on the same measurements; ``clutter_density`` (1/m^2) and ``pd`` as in
    :class:`HoulesConfig`; ``target_gated``: also store the target's gating per scan.

    Examples
    --------
    >>> s = HoulesSweepConfig(("singer", "tom"), gates=(0.99, 0.9999))
    >>> s.with_overrides({"gates": "0.9,0.99"}).gates
    (0.9, 0.99)
    >>> HoulesSweepConfig(("singer",), gates=(0.99, 0.99))
    Traceback (most recent call last):
    ...
    ValueError: gates must not repeat, got (0.99, 0.99)
    """

    filters: tuple
    gates: tuple = (0.99,)
    clutter_density: float = 2e-6
    pd: float = 1.0
    target_gated: int = 0

    _KINDS = {"filters": tuple, "gates": "floats", "clutter_density": float, "pd": float,
              "target_gated": int}

    def __post_init__(self):
        if not isinstance(self.filters, tuple) or not self.filters:
            raise TypeError(f"filters must be a non-empty tuple, got {self.filters!r}")
        for key in self.filters:
            _houles_model_set(key)  # raises on a bad key
        if not isinstance(self.gates, tuple) or not self.gates:
            raise TypeError(f"gates must be a non-empty tuple, got {self.gates!r}")
        for g in self.gates:
            if isinstance(g, bool) or not isinstance(g, (int, float)) or not 0 < g < 1:
                raise ValueError(f"every gate probability must be in (0, 1), got {g!r}")
        if len(set(self.gates)) != len(self.gates):
            raise ValueError(f"gates must not repeat, got {self.gates}")
        for name in ("clutter_density", "pd"):
            check_finite(getattr(self, name), name)
        if self.clutter_density < 0:
            raise ValueError(f"clutter_density must be >= 0, got {self.clutter_density}")
        if not 0 < self.pd <= 1:
            raise ValueError(f"pd must be in (0, 1], got {self.pd}")
        if self.target_gated not in (0, 1) or isinstance(self.target_gated, bool):
            raise ValueError(f"target_gated must be 0 or 1, got {self.target_gated!r}")


@functools.lru_cache(maxsize=64)
def _houles_model_set(key):
    """The IMM model set named by a filter key of :class:`HoulesSweepConfig`."""
    from ..trackers import car_imm_model_set, singer_imm_model_set, tom_imm_model_set

    if not isinstance(key, str):
        raise TypeError(f"a filter key must be a str, got {key!r}")
    kind, *nums = key.split(":")
    try:
        vals = [float(v) for v in nums]
    except ValueError:
        raise ValueError(f"filter key {key!r}: parameters must be numbers") from None
    if not all(math.isfinite(v) and v > 0 for v in vals):
        raise ValueError(f"filter key {key!r}: parameters must be finite and > 0")
    if kind == "singer" and not vals:
        return singer_imm_model_set()
    if kind == "singer" and len(vals) == 2:
        return singer_imm_model_set(tau=(20.0, vals[0]), sigma_m=(15.0, vals[1]))
    if kind == "car" and len(vals) == 1:
        return car_imm_model_set(sigma_cv=vals[0])
    if kind == "tom" and not vals:
        return tom_imm_model_set()
    raise ValueError(f"unknown filter key {key!r}; expected 'singer', 'singer:TAU:SIGMA_M', "
                     f"'car:SIGMA_CV' or 'tom'")


def houles_sweep_trial(rng, model_sets, gates, *, pd=1.0, clutter_density=2e-6):
    """One run of :func:`~trackcore.scenarios.houles_imm_trial` at every gate probability
    in ``gates``, each from the same generator state (so on the same measurements, as
    separate ``montecarlo.run`` calls with the same seed give); returns the runs.

    Examples
    --------
    Singer and TOM at two gate probabilities, on the same measurements:

    >>> import numpy as np
    >>> sets = [_houles_model_set("singer"), _houles_model_set("tom")]
    >>> runs = houles_sweep_trial(np.random.default_rng(1), sets, (0.99, 0.9999))
    >>> len(runs), np.asarray(runs[0].pos_err2).shape  # gates; (filters, scans)
    (2, (2, 90))
    """
    from ..core.validation import as_rng

    rng = as_rng(rng)
    state = rng.bit_generator.state
    out = []
    for pg in gates:
        rng.bit_generator.state = state
        out.append(houles_imm_trial(rng, model_sets, pd=pd, pg=pg,
                                    clutter_density=clutter_density))
    return out


def _sweep_call(config):
    return ([_houles_model_set(s) for s in config.filters], config.gates), {
        "pd": config.pd, "clutter_density": config.clutter_density}


def _sweep_extract(runs, config):
    """Per gate and filter: the window mean squares (total, manoeuvring,
    non-manoeuvring; what every RMSE of the chapter pools), the largest and the last
    squared position error (every failure threshold, a permanent loss) and, with
    ``target_gated``, the gating per scan (the gate-miss failures)."""
    from ..scenarios.houles import window_mse

    e = np.stack([np.asarray(r.pos_err2, dtype=np.float64) for r in runs])  # (G, F, 90)
    row = {"window_mse": window_mse(e), "max_err2": e.max(axis=-1),
           "last_err2": np.ascontiguousarray(e[..., -1])}
    if config.target_gated:
        row["target_gated"] = np.stack([np.asarray(r.target_gated, dtype=np.int8)
                                        for r in runs])
    return row


HOULES_SEED = 20261123
HOULES_CAL_SEED = 20261127
#: The fast Singer model's settings of the chapter's sweep: tau (s) by sigma_m from
#: Singer's rule with A_max = 60 m/s^2 at (P_max, P_0) = (0.5, 0), (0.2, 0.2), (0.1, 0.5).
SINGER_SWEEP = tuple((tau, 60.0 * math.sqrt((1 + 4 * pm - p0) / 3))
                     for tau in (5.0, 10.0, 20.0)
                     for pm, p0 in ((0.5, 0.0), (0.2, 0.2), (0.1, 0.5)))
_NB = "book/001-tom-imm/03-houles-monte-carlo.ipynb"
for _name, _desc, _config, _seed, _runs in (
        ("tom-imm-houles-gates",
         ("TOM-IMM chapter, the gate: the three IMM-PDAFs of Table 1 at P_G = 0.999 and "
          "0.9999 on Table 1's runs (per-run metrics and gating)"),
         HoulesSweepConfig(("singer", "car:5.0", "tom"), gates=(0.999, 0.9999), target_gated=1),
         HOULES_SEED, 1000),
        ("tom-imm-houles-car-prior",
         "TOM-IMM chapter, ablation: CAR-IMM with the prior CV noise 1 m/s^2 on Table 1's runs",
         HoulesSweepConfig(("car:1.0",)), HOULES_SEED, 1000),
        ("tom-imm-houles-singer-sweep",
         ("TOM-IMM chapter, Singer's tuning: nine fast Singer models on the first runs of "
          "Table 1"),
         HoulesSweepConfig(tuple(f"singer:{t!r}:{s!r}" for t, s in SINGER_SWEEP)),
         HOULES_SEED, 300),
        ("tom-imm-houles-car-calibration",
         ("TOM-IMM chapter, CAR's CV noise calibrated to the paper's CAR column: CAR-IMMs "
          "with CV noise 1, 2, 3, 5, 8 m/s^2 on a separate stream"),
         HoulesSweepConfig(tuple(f"car:{s!r}" for s in (1.0, 2.0, 3.0, 5.0, 8.0))),
         HOULES_CAL_SEED, 400)):
    register(Experiment(name=_name, description=_desc, trial=houles_sweep_trial,
                        call=_sweep_call, extract=_sweep_extract, config=_config, seed=_seed,
                        runs=_runs, version="1", notebook=_NB))

# the chapters' other registered experiments, one module each
from . import (
    fjpda_extensions,  # noqa: E402,F401  (feature-JPDA extensions, 004-07)
    fjpda_scenes,  # noqa: E402,F401  (feature-JPDA scene results, 004-05)
    hpda_extensions,  # noqa: E402,F401  (000-hpda/07's experiments)
    sprt,  # noqa: E402,F401  (SPRT chapter, 002-06: sprt-*)
    tbd_extensions,  # noqa: E402,F401  (TBD chapter, extensions page)
    tbd_grid,  # noqa: E402,F401  (TBD chapter, the verdict grid, 003-06)
    tbd_tracking,  # noqa: E402,F401  (the TBD chapter's tracking experiments)
    tom_cause,  # noqa: E402,F401  (001-05: registers tom-cause-*)
    fjpda_readings,  # noqa: E402,F401  (004: the readings at 200 seeds, issue 29)
)
from . import tom_pg1  # noqa: E402,F401  (001-03: tom-imm-houles-pg1, no gate)
from . import hpda_comparators  # noqa: E402,F401  (000-hpda/08: hpda-cmp-pi*)
from . import fjpda_templates  # noqa: E402,F401  (004: template cells, HOTA, occlusion map)
from . import fjpda_followups  # noqa: E402,F401  (004: S3 c_I 0.3/0.2, the long occlusion map)
from . import fjpda_cost  # noqa: E402,F401  (004: measured cluster rates, CLEAR-MOT of the duplicate rule)
from . import fjpda_oat  # noqa: E402,F401  (004: the readings one at a time, S3 confirmation)
from . import fjpda_oat_vel  # noqa: E402,F401  (004: the measurement "position and velocity")
from . import tom_ladder  # noqa: E402,F401  (001-05: the cause ladder, headings)
from . import tom_tuning  # noqa: E402,F401  (001-05: the grids, fresh seeds, T9, no clutter)
from . import fjpda_crossing_oat  # noqa: E402,F401  (004-09: the Fig 7 crossing under every reading)
from . import fjpda_accuracy  # noqa: E402,F401  (004-10: the position error on the same frames)
from . import fjpda_dup_readings  # noqa: E402,F401  (004-11: the duplicate rule under every reading)
from . import fjpda_map_readings  # noqa: E402,F401  (004-12: the occlusion map's pending cells and readings)
