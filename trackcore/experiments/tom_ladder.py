"""The TOM-IMM chapter's cause ladder and heading alternatives (001-05).

``tom-cause-ladder``: on Table 1's seed (20261123; runs 0-999 are Table 1's runs),
2000 runs at the default gate, each step changing one thing on the same
measurements: Singer (the reference of every ratio), the chapter's chord TOM, the
velocity heading, the velocity heading with the true-rate inputs, a known-rate
CT-IMM with the CAR-IMM's prior noises, and the zero-noise known-rate oracle; the
chord TOM with the true-rate inputs as a side branch.

``tom-cause-headings`` (P_G = 0.99, 0.999, 0.9999, the same measurements at each
gate) and ``tom-cause-headings-pg1`` (no gate, clutter in a 6 km square as
``tom-imm-houles-pg1``): the chord TOM against the headings the paper's sec. 3.1
names (the mean of the last 2 and 3 chords, a smoothed heading, a heading-and-rate
Kalman filter), each with its lateral input by the declared lag rule
(:func:`lag_rule_input`), and the literal reading (u = 70 m/s for every heading) as
an ablation; 1000 runs of Table 1's seed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scenarios.houles import (
    HOULES_INITIAL_STATE,
    HOULES_TURNS,
    houles_imm_trial,
    window_mse,
)
from ._core import Experiment, register
from .registry import _houles_model_set, houles_sweep_trial
from .tom_cause import (
    TomVariantsConfig,
    _FiltersAtGate,
    _tom_variant,
    _variants_call,
)
from .tom_pg1 import TomGatesConfig, TomNoGateConfig, _call, _extract, _gates_call

__all__: list[str] = []

SEED = 20261123  # Table 1's seed
_NB = "book/001-tom-imm/05-why-the-claim-fails.ipynb"
_SPEED = float(np.hypot(HOULES_INITIAL_STATE[2], HOULES_INITIAL_STATE[3]))


def true_rate_input(omega, speed=_SPEED, T=1.0):
    """The lateral input (m/s) that moves a TOM prediction exactly along a coordinated
    turn at ``omega`` (rad/s) and ``speed`` (m/s) over one scan ``T``: the lateral
    displacement of the next scan's chord in the frame of the last chord, over ``T``.
    Positive for a right turn (``omega < 0``). It serves both headings of the ladder:
    the chord is the last chord, and the velocity estimate of models that hold the
    velocity constant over a scan is the mean velocity of the last scan, which points
    along the last chord."""
    if not (isinstance(omega, (int, float)) and math.isfinite(omega) and omega != 0):
        raise ValueError(f"omega must be a finite nonzero number, got {omega!r}")
    w = abs(omega)
    d = 2.0 * speed / w * math.sin(w * T / 2) * math.sin(w * T)
    return math.copysign(d / T, -omega)


def _true_key(heading):
    (w1, w2) = HOULES_TURNS[0][2], HOULES_TURNS[1][2]  # right, then left
    u_r, u_l = true_rate_input(w1), -true_rate_input(w2)
    return f"tom:heading={heading},u_right={u_r:.3f},u_left={u_l:.3f}"


#: The ladder, step by step (the last key is the side branch).
LADDER = ("singer", "tom", "tom:heading=velocity", _true_key("velocity"),
          "ct:cv=1.0,ct=8.0,p_stay=0.9", "ct:cv=0.0,ct=0.0,p_stay=0.98",
          _true_key("chord"))

#: Declared lag rule: scans from the time a heading describes to the middle of the
#: scan it predicts (chord: 1), for each alternative heading.
LAG_SCANS = {"chord": 1.0, "chord_mean2": 1.5, "chord_mean3": 2.0, "smoothed": 2.0,
             "heading_rate_kf": 1.0}


def lag_rule_input(heading, u_paper=70.0):
    """The declared lateral input of a heading: the paper's ``u_paper`` for the chord,
    scaled by the heading's lag (:data:`LAG_SCANS`), so that every heading covers
    the same turn rates (the input a steady turn needs grows with the lag)."""
    return u_paper * LAG_SCANS[heading] / LAG_SCANS["chord"]


ALTERNATIVES = ("chord_mean2", "chord_mean3", "smoothed", "heading_rate_kf")
HEADINGS = (("tom",)
            + tuple(f"tom:heading={h},u={lag_rule_input(h)!r}" for h in ALTERNATIVES)
            + tuple(f"tom:heading={h}" for h in ALTERNATIVES[:3]))


def _model_set(key):
    if isinstance(key, str) and (key.startswith("tom") or key.startswith("ct:")):
        return _tom_variant(key)
    return _houles_model_set(key)


@dataclass(frozen=True)
class LadderConfig(_FiltersAtGate):
    """Filters (keys ``"singer"``, ``"car:S"``, TOM keys and ``"ct:..."`` keys of
    :mod:`.tom_cause`) on the Houles scenario at one gate; ``pg``, ``clutter_density``
    (1/m^2) and ``pd`` as in :class:`~.tom_cause.TomVariantsConfig`."""

    filters: tuple = LADDER
    pg: float = 0.99
    clutter_density: float = 2e-6
    pd: float = 1.0

    _filter_check = staticmethod(_model_set)


def _ladder_call(config):
    return config._model_call()


def _ladder_extract(run, config):
    """Per filter: window mean squares, the largest and the last squared error."""
    e = np.asarray(run.pos_err2, dtype=np.float64)
    return {"window_mse": window_mse(e), "max_err2": e.max(axis=-1),
            "last_err2": np.ascontiguousarray(e[:, -1])}


def _miss_streak(target_gated):
    """Longest run of scans with the target outside every gate (-1, a missed
    detection, neither counts nor breaks a run), over the last axis."""
    g = np.asarray(target_gated)
    best = np.zeros(g.shape[:-1], dtype=np.int64)
    cur = np.zeros_like(best)
    for k in range(g.shape[-1]):
        cur = np.where(g[..., k] == 0, cur + 1, np.where(g[..., k] == 1, 0, cur))
        best = np.maximum(best, cur)
    return best.astype(np.int16)


def _headings_extract(runs, config):
    """Per gate and filter: window mean squares, the largest and last squared error,
    and the longest streak of scans with the target outside every gate."""
    e = np.stack([np.asarray(r.pos_err2, dtype=np.float64) for r in runs])
    return {"window_mse": window_mse(e), "max_err2": e.max(axis=-1),
            "last_err2": np.ascontiguousarray(e[..., -1]),
            "miss_streak": _miss_streak(np.stack([np.asarray(r.target_gated)
                                                  for r in runs]))}


register(Experiment(
    name="tom-cause-ladder",
    description=("TOM-IMM chapter, the cause ladder: chord, velocity heading, "
                 "true-rate inputs, known-rate CT-IMM, zero-noise oracle, same runs"),
    trial=houles_imm_trial, call=_ladder_call, extract=_ladder_extract,
    config=LadderConfig(), seed=SEED, runs=2000, version="1", notebook=_NB))
register(Experiment(
    name="tom-cause-headings",
    description=("TOM-IMM chapter, the chord against the headings the paper names, "
                 "each with its lag-rule input, at three gates on Table 1's runs"),
    trial=houles_sweep_trial, call=_gates_call, extract=_headings_extract,
    config=TomGatesConfig(filters=HEADINGS, gates=(0.99, 0.999, 0.9999)),
    seed=SEED, runs=1000, version="1", notebook=_NB))
register(Experiment(
    name="tom-cause-headings-pg1",
    description=("TOM-IMM chapter, the chord against the headings the paper names, "
                 "no gate, clutter in a 6 km square, Table 1's runs"),
    trial=houles_imm_trial, call=_call, extract=_extract,
    config=TomNoGateConfig(filters=HEADINGS), seed=SEED, runs=1000, version="1",
    notebook=_NB))


#: Two more readings of the frame change (ablations), after the chapter's TOM (for its
#: velocity errors): the velocity re-projected into the new heading's frame, and the
#: v_s variance reset to a prior ((20 m/s)^2, (70 m/s)^2).
FRAME_READINGS = ("tom", "tom:rotate_covariance=1,reproject_velocity=1",
                  "tom:vs_prior_var=400.0", "tom:vs_prior_var=4900.0")


def _frame_extract(run, config):
    """Per filter: window mean squares, the largest squared position error, and the
    mean and largest squared velocity error over the run (a speed that runs away)."""
    e = np.asarray(run.pos_err2, dtype=np.float64)
    v = np.asarray(run.vel_err2, dtype=np.float64)
    return {"window_mse": window_mse(e), "max_err2": e.max(axis=-1),
            "vel_mse": v.mean(axis=-1), "max_vel_err2": v.max(axis=-1)}


register(Experiment(
    name="tom-cause-frame-readings",
    description=("TOM-IMM chapter, two more readings of the frame change: velocity "
                 "re-projected, v_s variance reset to a prior, on Table 1's runs"),
    trial=houles_imm_trial, call=_variants_call, extract=_frame_extract,
    config=TomVariantsConfig(FRAME_READINGS), seed=SEED, runs=1000, version="1",
    notebook=_NB))
