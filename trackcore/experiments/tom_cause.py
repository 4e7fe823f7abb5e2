"""Experiments of the TOM-IMM chapter's page on why the claim fails (001-05).

Three fixed-design Monte Carlo experiments on the seed of Table 1 (20261123):

* ``tom-cause-straight-leg``: one CV Kalman filter and two single TOM models, no
  clutter, no gate (section 1, the chord's cost on the straight leg);
* ``tom-cause-readings``: four readings of the TOM cycle on Table 1's runs (section 2);
  Singer, CAR and the chapter's TOM on the same runs are the ``tom-imm-houles`` store;
* ``tom-cause-one-at-a-time``: each TOM parameter varied alone on Table 1's first 300
  runs (section 5).

The grids and searches, the fresh seeds, T9's sample and the runs without clutter are
stored too (:mod:`.tom_tuning`); the searches choose their next points from the stored
rows.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..scenarios.houles import HOULES_TIMES, houles_imm_trial, window_mse
from ._checks import check_finite, check_names
from ._core import Experiment, register
from .registry import _Config

__all__ = ["StraightLegConfig", "TomVariantsConfig"]

SEED = 20261123  # Table 1's seed
_NB = "book/001-tom-imm/05-why-the-claim-fails.ipynb"
#: The TOM settings a filter key may change, and how each value is read.
_TOM_KEYS = {"heading": str, "reset_vs_variance": bool, "rotate_covariance": bool,
             "u": float, "sigma_s_turn": float, "sigma_s_centre": float, "sigma_f": float,
             "p_stay": float, "u_right": float, "u_left": float,
             "reproject_velocity": bool, "vs_prior_var": float}
#: The settings of a known-rate coordinated-turn IMM key ``"ct:NAME=VALUE,..."``: the
#: CV model's and the turn models' DWNA noises (m/s^2) and the Markov diagonal; its
#: turn rates are the scenario's two true rates.
_CT_KEYS = {"cv": float, "ct": float, "p_stay": float}


def _finite(config, names):
    for name in names:
        check_finite(getattr(config, name), name)


def _check_environment(config, names=("pg", "clutter_density", "pd")):
    """Check a config's environment fields of ``names``: each finite, ``0 < pg <= 1``,
    ``clutter_density >= 0`` (1/m^2) and ``0 < pd <= 1``."""
    _finite(config, names)
    if "pg" in names and not 0 < config.pg <= 1:
        raise ValueError(f"pg must be in (0, 1], got {config.pg}")
    if config.clutter_density < 0:
        raise ValueError(f"clutter_density must be >= 0, got {config.clutter_density}")
    if not 0 < config.pd <= 1:
        raise ValueError(f"pd must be in (0, 1], got {config.pd}")


@functools.lru_cache(maxsize=64)
def _tom_variant(key):
    """The TOM-IMM model set of a filter key: ``"tom"`` (the chapter's) or
    ``"tom:NAME=VALUE"`` with NAME one of ``_TOM_KEYS`` (``p_stay``: the Markov
    diagonal; ``u_right``/``u_left``: unequal right and left inputs); several
    settings are joined by commas, ``"tom:u=50.0,p_stay=0.95"``; or a known-rate
    CT-IMM ``"ct:cv=1.0,ct=8.0,p_stay=0.9"`` (``_CT_KEYS``)."""
    from ..trackers import markov_matrix, tom_imm_model_set

    if not isinstance(key, str):
        raise TypeError(f"a filter key must be a str, got {key!r}")
    if key == "tom":
        return tom_imm_model_set()
    kind, _, settings = key.partition(":")
    names = {"tom": _TOM_KEYS, "ct": _CT_KEYS}.get(kind, {})
    kwargs = {}
    for setting in settings.split(","):
        name, _, value = setting.partition("=")
        if name not in names or not value or name in kwargs:
            raise ValueError(f"unknown filter key {key!r}; expected 'tom', "
                             f"'tom:NAME=VALUE[,NAME=VALUE...]' with distinct NAMEs in "
                             f"{sorted(_TOM_KEYS)}, or 'ct:NAME=VALUE,...' with NAMEs "
                             f"in {sorted(_CT_KEYS)}")
        kwargs[name] = _tom_value(key, name, value, names)
    if kind == "ct":
        return _known_rate_ct(key, **kwargs)
    if "p_stay" in kwargs:
        kwargs["transition"] = markov_matrix(3, kwargs.pop("p_stay"))
    if "u_right" in kwargs or "u_left" in kwargs:
        return _tom_asymmetric(key, **kwargs)
    return tom_imm_model_set(**kwargs)


def _known_rate_ct(key, cv=1.0, ct=8.0, p_stay=0.9):
    """A CV and two coordinated-turn models at the scenario's true turn rates."""
    from ..scenarios.houles import HOULES_TURNS
    from ..trackers import ct_imm_model_set, markov_matrix

    if not (cv >= 0 and ct >= 0 and 0 < p_stay < 1):
        raise ValueError(f"filter key {key!r}: need cv, ct >= 0 and 0 < p_stay < 1")
    omegas = [0.0, HOULES_TURNS[0][2], HOULES_TURNS[1][2]]
    return ct_imm_model_set(omegas, [cv, ct, ct], transition=markov_matrix(3, p_stay),
                            name="known-rate CT-IMM")


def _tom_asymmetric(key, u_right=70.0, u_left=70.0, sigma_f=1.0, sigma_s_centre=3.0,
                    sigma_s_turn=20.0, **kwargs):
    """The paper's three TOM models with a right input ``+u_right`` and a left input
    ``-u_left`` (m/s), the other settings as in ``tom_imm_model_set``."""
    from ..trackers import tom_model_set

    if "u" in kwargs:
        raise ValueError(f"filter key {key!r}: give u or u_right/u_left, not both")
    if not (u_right >= 0 and u_left >= 0):
        raise ValueError(f"filter key {key!r}: u_right and u_left must be >= 0")
    sc, st = sigma_s_centre, sigma_s_turn
    return tom_model_set([0.0, u_right, -u_left], [sc, st, st], sigma_f=sigma_f,
                         mu0=(0.8, 0.1, 0.1), **kwargs)


def _tom_value(key, name, value, names=_TOM_KEYS):
    """The value of one ``NAME=VALUE`` setting of a filter key, read as ``names``
    (``_TOM_KEYS`` or ``_CT_KEYS``) says."""
    kind_of = names[name]
    if kind_of is bool:
        if value not in ("0", "1"):
            raise ValueError(f"filter key {key!r}: {name} must be 0 or 1")
        return value == "1"
    if kind_of is str:
        return value
    try:
        return float(value)
    except ValueError:
        raise ValueError(f"filter key {key!r}: {name} must be a number") from None


class _FiltersAtGate(_Config):
    """Shared checks and call of the configs that run ``filters`` at one gate ``pg``
    (``clutter_density`` 1/m^2, ``pd``) on the same measurements: each key is checked
    by ``_filter_check`` (a TOM key of :func:`_tom_variant` unless a subclass says
    otherwise); a mixin, so each config keeps its own class and fields."""

    _KINDS = {"filters": tuple, "pg": float, "clutter_density": float, "pd": float}
    _filter_check = staticmethod(_tom_variant)

    def __post_init__(self):
        check_names(self.filters, "filters", item="filter")
        for key in self.filters:
            self._filter_check(key)  # raises on a bad key
        _check_environment(self)

    def _model_call(self):
        """The ``(args, kwargs)`` of the trial: the filters' model sets and the PDA."""
        return ([self._filter_check(k) for k in self.filters],), {
            "pg": self.pg, "clutter_density": self.clutter_density, "pd": self.pd}


@dataclass(frozen=True)
class TomVariantsConfig(_FiltersAtGate):
    """TOM-IMM variants on the Houles scenario, each run on the same measurements.

    ``filters``: keys ``"tom"`` or ``"tom:NAME=VALUE"`` (NAME: ``heading``,
    ``reset_vs_variance``, ``rotate_covariance`` (0 or 1), ``u``, ``sigma_s_turn``,
    ``sigma_s_centre``, ``sigma_f``, ``p_stay``); ``pg`` the gate probability,
    ``clutter_density`` (1/m^2), ``pd`` the detection probability.

    Examples
    --------
    >>> c = TomVariantsConfig(("tom", "tom:u=100.0"), pg=0.9999)
    >>> c.filters, c.pg, c.with_overrides({"pd": "0.9"}).pd
    (('tom', 'tom:u=100.0'), 0.9999, 0.9)
    >>> TomVariantsConfig(("tom",), pg=1.5)
    Traceback (most recent call last):
    ...
    ValueError: pg must be in (0, 1], got 1.5
    """

    filters: tuple
    pg: float = 0.99
    clutter_density: float = 2e-6
    pd: float = 1.0


def _variants_call(config):
    return config._model_call()


def _variants_extract(run, config):
    """Per filter: the window mean squares (total, manoeuvring, non-manoeuvring) and the
    largest squared position error (a failure: above 200 m at some time)."""
    e = np.asarray(run.pos_err2, dtype=np.float64)  # (filters, 90)
    return {"window_mse": window_mse(e), "max_err2": e.max(axis=-1)}


@dataclass(frozen=True)
class StraightLegConfig(_Config):
    """Section 1: a CV Kalman filter (DWNA ``cv_sigma`` m/s^2) and single TOM models
    (lateral noise ``tom_sigma_s``, ``sigma_f`` along track, m/s^2) without clutter
    and without a gate; rows summarise ``t0 <= t <= t1`` (s) and keep the prediction
    errors up to ``t_plot`` (s) for the figure.

    Examples
    --------
    >>> c = StraightLegConfig()
    >>> c.tom_sigma_s, c.t0, c.t1
    ((1.0, 3.0), 5.0, 19.0)
    >>> StraightLegConfig(t0=30.0, t1=20.0)
    Traceback (most recent call last):
    ...
    ValueError: need 2 <= t0 <= t1 <= 90, got t0 = 30.0, t1 = 20.0
    """

    cv_sigma: float = 1.0
    tom_sigma_s: tuple = (1.0, 3.0)
    sigma_f: float = 1.0
    t0: float = 5.0
    t1: float = 19.0
    t_plot: float = 19.0

    _KINDS = {"cv_sigma": float, "tom_sigma_s": "floats", "sigma_f": float,
              "t0": float, "t1": float, "t_plot": float}

    def __post_init__(self):
        _finite(self, ("cv_sigma", "sigma_f", "t0", "t1", "t_plot"))
        if not isinstance(self.tom_sigma_s, tuple) or not self.tom_sigma_s:
            raise TypeError(f"tom_sigma_s must be a non-empty tuple, got "
                            f"{self.tom_sigma_s!r}")
        for v in (self.cv_sigma, self.sigma_f, *self.tom_sigma_s):
            if isinstance(v, bool) or not isinstance(v, (int, float)) \
                    or not math.isfinite(v) or v < 0:
                raise ValueError(f"every noise must be finite and >= 0, got {v!r}")
        if not 2 <= self.t0 <= self.t1 <= HOULES_TIMES[-1]:
            raise ValueError(f"need 2 <= t0 <= t1 <= {HOULES_TIMES[-1]:g}, got "
                             f"t0 = {self.t0}, t1 = {self.t1}")
        if not 2 <= self.t_plot <= HOULES_TIMES[-1]:
            raise ValueError(f"t_plot must be in [2, {HOULES_TIMES[-1]:g}], got "
                             f"{self.t_plot}")


def _leg_call(config):
    from ..trackers import cv_model_set, tom_model_set

    sets = [cv_model_set(sigma=config.cv_sigma)] + [
        tom_model_set([0.0], [s], sigma_f=config.sigma_f) for s in config.tom_sigma_s]
    return (sets,), {"clutter_density": 0.0, "pg": 1.0}


def _leg_extract(run, config):
    """Per filter, means over the leg (t0..t1): squared position error, squared
    prediction error along and across the track, position and velocity NEES; and the
    prediction errors (along, across) for t = 2..t_plot (the figure)."""
    leg = (HOULES_TIMES >= config.t0) & (HOULES_TIMES <= config.t1)
    leg2 = leg[1:]  # arrays that start at t = 2
    e = np.asarray(run.pos_err2, dtype=np.float64)
    pe = np.asarray(run.pred_err, dtype=np.float64)[:, leg2]  # (filters, scans, 2)
    sel = HOULES_TIMES[1:] <= config.t_plot
    return {
        "leg_mse": e[:, leg].mean(axis=1),
        "leg_along2": (pe[..., 0] ** 2).mean(axis=1),
        "leg_lat2": (pe[..., 1] ** 2).mean(axis=1),
        "leg_nees_pos": np.asarray(run.nees_pos, dtype=np.float64)[:, leg2].mean(axis=1),
        "leg_nees_vel": np.asarray(run.nees_vel, dtype=np.float64)[:, leg2].mean(axis=1),
        "pred_err": np.ascontiguousarray(
            np.asarray(run.pred_err, dtype=np.float64)[:, sel]),
    }


#: Section 2's readings of the cycle (besides the chapter's chord TOM).
READINGS = ("tom:heading=chord_literal", "tom:heading=velocity",
            "tom:reset_vs_variance=1", "tom:rotate_covariance=1")
#: Section 5's one-at-a-time sweep: (parameter, values) around the chapter's TOM.
ONE_AT_A_TIME = (("u", (50.0, 60.0, 70.0, 80.0, 100.0)),
                 ("sigma_s_turn", (10.0, 20.0, 30.0, 40.0)),
                 ("sigma_s_centre", (1.0, 3.0, 10.0)),
                 ("sigma_f", (0.5, 1.0, 3.0)),
                 ("p_stay", (0.8, 0.9, 0.95, 0.98)))

register(Experiment(
    name="tom-cause-straight-leg",
    description=("TOM-IMM chapter, what the chord costs: a CV Kalman filter and single "
                 "TOM models on the straight leg, no clutter, no gate"),
    trial=houles_imm_trial, call=_leg_call, extract=_leg_extract,
    config=StraightLegConfig(), seed=SEED, runs=1000, version="1", notebook=_NB))
register(Experiment(
    name="tom-cause-readings",
    description=("TOM-IMM chapter, the readings of the cycle: literal index, velocity "
                 "heading, v_s variance reset, rotated covariance on Table 1's runs"),
    trial=houles_imm_trial, call=_variants_call, extract=_variants_extract,
    config=TomVariantsConfig(READINGS), seed=SEED, runs=1000, version="1",
    notebook=_NB))
register(Experiment(
    name="tom-cause-one-at-a-time",
    description=("TOM-IMM chapter, tuning one TOM parameter at a time on the first runs "
                 "of Table 1"),
    trial=houles_imm_trial, call=_variants_call, extract=_variants_extract,
    config=TomVariantsConfig(tuple(f"tom:{k}={v!r}" for k, vals in ONE_AT_A_TIME
                                   for v in vals)),
    seed=SEED, runs=300, version="1", notebook=_NB))
