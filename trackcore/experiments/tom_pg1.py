"""The TOM-IMM chapter's runs without a gate (P_G = 1; 001-03, the gate reading), and
the jointly tuned TOM on Table 1's runs at every gate.

``tom-imm-houles-pg1``: Singer, CAR (5 m/s^2), the declared TOM and the jointly tuned
TOM of 001-05 on Table 1's seed (20261123), with no gate and the clutter filling a
6 km square around the target: Table 1's 2 km square with its own draws, plus the
ring out to 6 km drawn after them (:func:`~trackcore.scenarios.houles_measurements`,
``outer_window``), so the target measurements are Table 1's.  Rows: per filter the
window mean squares, the largest and the last squared position error (every
threshold, a lost track), and the longest streak of scans on which the target
measurement's NIS exceeds the 0.99 gate's threshold (the gate-miss definition read
without a gate).

``tom-imm-houles-pg1-rep``: the same four filters and environment on 10000 runs of a
seed no other experiment uses (20261203), a replication whose count was fixed from the
power of the first 3000 runs before it ran; it alone decides the P_G = 1 cells of the
chapter's failure-rate claims.

``tom-imm-houles-tuned-gates``: the jointly tuned TOM and the velocity-heading variant's
best point of 001-05 on Table 1's runs at P_G = 0.99, 0.999 and 0.9999 (the same
measurements as ``tom-imm-houles`` and ``tom-imm-houles-gates``, so paired with Singer,
CAR and the declared TOM there): per gate and filter the window mean squares, the largest
and last squared error and the target's gating per scan.

``tom-imm-houles-postturn`` and ``tom-imm-houles-pg1-postturn``: Singer, CAR, the declared
and the jointly tuned TOM on Table 1's runs at the three gates, and on the 3000 runs of
``tom-imm-houles-pg1`` without a gate: per filter the mean squared position error in the
5 s after each turn (t = 36-40 and 71-75 s) and the largest squared error.

``tom-imm-houles-onset`` and ``tom-imm-houles-pg1-onset``: Singer alone on the same runs
(Table 1's at the three gates; the 3000 without a gate): its mean squared position error
in the first 5 s of each turn (t = 21-25 and 56-60 s), in the rest of the manoeuvring
window (t = 26-40 and 61-75 s), and its largest squared error.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scenarios.houles import houles_imm_trial, window_mse
from ._checks import check_names
from ._core import Experiment, register
from .registry import _Config, _houles_model_set, houles_sweep_trial
from .tom_cause import _check_environment, _tom_variant

__all__ = ["TomGatesConfig", "TomNoGateConfig"]

SEED = 20261123  # Table 1's seed
#: chi-square 0.99 quantile, 2 dof: the chapter's default gate
GATE99 = 9.210340371976182
#: The jointly tuned TOM of 001-05 (u, sigma_s turn and centre, Markov diagonal).
TUNED = "tom:u=50.0,sigma_s_turn=10.0,sigma_s_centre=0.0,p_stay=0.95"
FILTERS = ("singer", "car:5.0", "tom", TUNED)
#: The velocity-heading variant's best point of 001-05.
VBEST = "tom:u=55.0,sigma_s_turn=30.0,sigma_s_centre=0.5,p_stay=0.98,heading=velocity"


def _model_set(key):
    """A filter key: a TOM key of :mod:`.tom_cause` or a Singer/CAR key of the
    registry's :class:`~.registry.HoulesSweepConfig`."""
    if isinstance(key, str) and key.startswith("tom"):
        return _tom_variant(key)
    return _houles_model_set(key)


@dataclass(frozen=True)
class TomNoGateConfig(_Config):
    """Filters on the Houles scenario without a gate, in clutter of ``clutter_density``
    (1/m^2) filling an ``outer_window`` (m) square; ``filters`` as in
    :class:`~.registry.HoulesSweepConfig` plus the TOM keys of :mod:`.tom_cause`;
    ``pg`` the gate probability (1: no gate); ``pd`` the detection probability.

    Examples
    --------
    >>> c = TomNoGateConfig()
    >>> c.pg, c.outer_window, c.filters[:2]
    (1.0, 6000.0, ('singer', 'car:5.0'))
    >>> TomNoGateConfig(outer_window=1000.0)
    Traceback (most recent call last):
    ...
    ValueError: outer_window must exceed the 2000 m square, got 1000.0
    """

    filters: tuple = FILTERS
    pg: float = 1.0
    clutter_density: float = 2e-6
    pd: float = 1.0
    outer_window: float = 6000.0

    _KINDS = {"filters": tuple, "pg": float, "clutter_density": float, "pd": float,
              "outer_window": float}

    def __post_init__(self):
        check_names(self.filters, "filters", item="filter")
        for key in self.filters:
            _model_set(key)  # raises on a bad key
        _check_environment(self, ("pg", "clutter_density", "pd", "outer_window"))
        if not self.outer_window > 2000.0:
            raise ValueError(f"outer_window must exceed the 2000 m square, got "
                             f"{self.outer_window}")


def _call(config):
    return ([_model_set(k) for k in config.filters],), {
        "pg": config.pg, "clutter_density": config.clutter_density, "pd": config.pd,
        "outer_window": config.outer_window}


def _nis_streak(nis, threshold=GATE99):
    """Per filter, the longest run of scans whose target NIS exceeds ``threshold``
    (a missed detection, NaN, neither counts nor breaks a run)."""
    nis = np.asarray(nis, dtype=np.float64)
    best = np.zeros(nis.shape[0], dtype=np.int64)
    cur = np.zeros_like(best)
    for k in range(nis.shape[1]):
        col = nis[:, k]
        cur = np.where(col > threshold, cur + 1, np.where(np.isnan(col), cur, 0))
        best = np.maximum(best, cur)
    return best.astype(np.int16)


def _extract(run, config):
    """Per filter: window mean squares, largest and last squared error, NIS streak."""
    e = np.asarray(run.pos_err2, dtype=np.float64)  # (filters, 90)
    return {"window_mse": window_mse(e), "max_err2": e.max(axis=-1),
            "last_err2": np.ascontiguousarray(e[:, -1]),
            "nis_streak": _nis_streak(run.nis)}


register(Experiment(
    name="tom-imm-houles-pg1",
    description=("TOM-IMM chapter, no gate (P_G = 1): Singer, CAR, the declared and the "
                 "jointly tuned TOM on Table 1's seed, clutter in a 6 km square"),
    trial=houles_imm_trial, call=_call, extract=_extract,
    config=TomNoGateConfig(), seed=SEED, runs=3000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))

#: The replication's seed: a stream no other experiment of the book uses.
REP_SEED = 20261203

register(Experiment(
    name="tom-imm-houles-pg1-rep",
    description=("TOM-IMM chapter, no gate (P_G = 1), a replication on a new seed: the "
                 "four filters of tom-imm-houles-pg1, 10000 runs fixed from its power"),
    trial=houles_imm_trial, call=_call, extract=_extract,
    config=TomNoGateConfig(), seed=REP_SEED, runs=10000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))


@dataclass(frozen=True)
class TomGatesConfig(_Config):
    """TOM settings (keys of :mod:`.tom_cause`) on the Houles scenario at every gate
    probability of ``gates``, each on the same measurements; ``clutter_density``
    (1/m^2) and ``pd`` as in :class:`~.registry.HoulesConfig`.

    Examples
    --------
    >>> c = TomGatesConfig(filters=("singer",))
    >>> c.gates, c.filters
    ((0.99, 0.999, 0.9999), ('singer',))
    >>> TomGatesConfig(gates=(0.99, 1.5))
    Traceback (most recent call last):
    ...
    ValueError: every gate probability must be in (0, 1], got 1.5
    """

    filters: tuple = (TUNED, VBEST)
    gates: tuple = (0.99, 0.999, 0.9999)
    clutter_density: float = 2e-6
    pd: float = 1.0

    _KINDS = {"filters": tuple, "gates": "floats", "clutter_density": float, "pd": float}

    def __post_init__(self):
        check_names(self.filters, "filters", item="filter")
        for key in self.filters:
            _model_set(key)
        if not isinstance(self.gates, tuple) or not self.gates:
            raise TypeError(f"gates must be a non-empty tuple, got {self.gates!r}")
        for g in self.gates:
            if isinstance(g, bool) or not isinstance(g, (int, float)) or not 0 < g <= 1:
                raise ValueError(f"every gate probability must be in (0, 1], got {g!r}")
        _check_environment(self, ("clutter_density", "pd"))


def _gates_call(config):
    return ([_model_set(k) for k in config.filters], config.gates), {
        "pd": config.pd, "clutter_density": config.clutter_density}


def _gates_extract(runs, config):
    """Per gate and filter: window mean squares, largest and last squared error, and
    the target's gating per scan (1 gated, 0 outside every gate, -1 missed)."""
    e = np.stack([np.asarray(r.pos_err2, dtype=np.float64) for r in runs])  # (G, F, 90)
    return {"window_mse": window_mse(e), "max_err2": e.max(axis=-1),
            "last_err2": np.ascontiguousarray(e[..., -1]),
            "target_gated": np.stack([np.asarray(r.target_gated, dtype=np.int8)
                                      for r in runs])}


register(Experiment(
    name="tom-imm-houles-tuned-gates",
    description=("TOM-IMM chapter, one TOM per reading: the jointly tuned TOM and the "
                 "velocity-heading variant's best point on Table 1's runs at three gates"),
    trial=houles_sweep_trial, call=_gates_call, extract=_gates_extract,
    config=TomGatesConfig(), seed=SEED, runs=1000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))


def _post_mask():
    """The 5 s after each turn, t = 36-40 and 71-75 s, on the samples t = 1..90."""
    t = np.arange(1.0, 91.0)
    return ((t >= 36) & (t <= 40)) | ((t >= 71) & (t <= 75))


def _postturn_extract(run, config):
    """Per filter: the post-turn mean squared error and the largest squared error."""
    e = np.asarray(run.pos_err2, dtype=np.float64)  # (filters, 90)
    return {"post_mse": e[:, _post_mask()].mean(axis=-1), "max_err2": e.max(axis=-1)}


def _gates_postturn_extract(runs, config):
    """Per gate and filter: the post-turn mean squared error and the largest squared
    error."""
    e = np.stack([np.asarray(r.pos_err2, dtype=np.float64) for r in runs])  # (G, F, 90)
    return {"post_mse": e[..., _post_mask()].mean(axis=-1), "max_err2": e.max(axis=-1)}


register(Experiment(
    name="tom-imm-houles-postturn",
    description=("TOM-IMM chapter, the post-turn window: Singer, CAR, the declared and the "
                 "jointly tuned TOM on Table 1's runs at P_G = 0.99, 0.999 and 0.9999"),
    trial=houles_sweep_trial, call=_gates_call, extract=_gates_postturn_extract,
    config=TomGatesConfig(filters=FILTERS), seed=SEED, runs=1000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))

register(Experiment(
    name="tom-imm-houles-pg1-postturn",
    description=("TOM-IMM chapter, the post-turn window without a gate: Singer, CAR, the "
                 "declared and the jointly tuned TOM on the runs of tom-imm-houles-pg1"),
    trial=houles_imm_trial, call=_call, extract=_postturn_extract,
    config=TomNoGateConfig(), seed=SEED, runs=3000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))


def _onset_masks():
    """The first 5 s of each turn (t = 21-25 and 56-60 s) and the rest of the
    manoeuvring window (t = 26-40 and 61-75 s), on the samples t = 1..90."""
    t = np.arange(1.0, 91.0)
    onset = ((t >= 21) & (t <= 25)) | ((t >= 56) & (t <= 60))
    rest = ((t >= 26) & (t <= 40)) | ((t >= 61) & (t <= 75))
    return onset, rest


def _onset_columns(e):
    """Onset and rest mean squares and the largest squared error of ``e`` (..., 90)."""
    onset, rest = _onset_masks()
    return {"onset_mse": e[..., onset].mean(axis=-1), "rest_mse": e[..., rest].mean(axis=-1),
            "max_err2": e.max(axis=-1)}


def _onset_extract(run, config):
    """Per filter: onset and rest mean squares and the largest squared error."""
    return _onset_columns(np.asarray(run.pos_err2, dtype=np.float64))


def _gates_onset_extract(runs, config):
    """Per gate and filter: onset and rest mean squares, largest squared error."""
    return _onset_columns(np.stack([np.asarray(r.pos_err2, dtype=np.float64)
                                    for r in runs]))


register(Experiment(
    name="tom-imm-houles-onset",
    description=("TOM-IMM chapter, Singer at the turn onsets: Singer alone on Table 1's "
                 "runs at P_G = 0.99, 0.999 and 0.9999"),
    trial=houles_sweep_trial, call=_gates_call, extract=_gates_onset_extract,
    config=TomGatesConfig(filters=("singer",)), seed=SEED, runs=1000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))

register(Experiment(
    name="tom-imm-houles-pg1-onset",
    description=("TOM-IMM chapter, Singer at the turn onsets without a gate: Singer alone "
                 "on the runs of tom-imm-houles-pg1"),
    trial=houles_imm_trial, call=_call, extract=_onset_extract,
    config=TomNoGateConfig(filters=("singer",)), seed=SEED, runs=3000, version="1",
    notebook="book/001-tom-imm/03-houles-monte-carlo.ipynb"))
