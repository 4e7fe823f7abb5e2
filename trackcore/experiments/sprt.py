"""Experiments of the SPRT chapter (002): the decisions of the paper's test per run.

A config names one of the paper's scenarios and a tuple of *cells*, each a set of
changes to the scenario (:class:`~trackcore.scenarios.SprtAcmScenario` fields, e.g. the
geometry ``alpha_deg=45;lead_deg=0``) and to the filters
(:class:`~trackcore.trackers.SprtAcmFilterConfig` fields, e.g. ``target_model=boost``).
Run ``i`` simulates every cell from the same generator state (common random numbers, as
the chapter's notebooks do when they run several settings with one master seed), so
each cell's rows are exactly the runs of ``sprt_acm_monte_carlo(scenario, n, seed,
config)``.  A row keeps, per cell, the test's decision ``d`` (0: H0, the right answer
under H0; 1: H1; -1: undecided at the end of the run) and its decision scan ``k``
(1-based, 0 when undecided) at the cell's threshold ``gamma``: the compact result
that the chapter's sweeps decide their verdicts on.

Registered (the book's seeds and run counts, 06-sensitivity):

* ``sprt-s1-geometry``: S1 on 7 x 7 geometries (target course 30..60 deg, pursuer
  lead -20..10 deg), 5000 runs on S1's seed;
* ``sprt-t10-s2``, ``sprt-t10-s3``: the turn-tolerant target filters (boost, IMM,
  IMM with the release cue, IMM 50/50) with the 20 % prior, 5000 runs each;
* ``sprt-t10-boost-rep-s2``, ``sprt-t10-boost-rep-s3``: the boost's replication on
  5000 runs of other seeds;
* ``sprt-boost-robust-s2``, ``sprt-boost-robust-s3``: the boost's window and acceleration
  (3 x 3 cells, 20 % prior) on the 1000 runs of S2's / S3's seed.

and the chapter's declared geometry family (index, "Readings"; issue 27):

* ``sprt-s1-family``: S1 in the family's cells other than G-A (45/0), on the 5000 runs of
  S1's verdicts (seed + 500);
* ``sprt-s2-family``, ``sprt-s3-family``: S2 / S3 in the cells other than G-B (7.5/-15),
  on the 1000 runs of their verdicts (seed + 2, seed + 3); S3's two cells with lead +15
  end at t = 80 s (the target passes within 8 sigma_r of the pursuer after that);
* ``sprt-cause-s2``, ``sprt-cause-s3``: the cause factorial (target filter CV / boost x
  prior 200 % / 20 % x 1/r free / >= 1/20 km x the 7 declared S2/S3 geometries), 5000
  runs of their own seeds (seed + 3000 + n);
* ``sprt-calib-s1-family``: the calibration over S1's declared family (G-A and the five
  other cells): decisions and "ever reaches +gamma" of Lambda and of its decoy-filter and
  target-filter pairs, on S1's 5000 verdict runs (seed + 500; 05-extensions);
* ``sprt-filters-s1``, ``-s2``, ``-s3``: each scenario's settings of 06-sensitivity (the
  prior of eq 28, the target filters at the printed and the 20 % prior, each decoy
  filter's prior alone, the decoy's speed and sigma_v) on the 1000 runs of its seed
  (seed + n), with the target-filter pair, a0's NIS, a1's sign of 1/r and the IMM's mode
  probabilities, and the paper's filters decided at every threshold of MATCH_GAMMAS;
* ``sprt-obs-s1``: the observability of the decoy filter (02-matched-filters): whether
  b0's inverse range ends negative, in the six cells of S1's family, on the 1000 runs of
  S1's evidence (seed + 1);
* ``sprt-early-s1-family``: Lambda's fall over scans 1-5 minus its fall over scans 6-10
  (03-scenarios), in the six cells of S1's family, on S1's 5000 verdict runs (seed + 500).
* ``sprt-s2-family-5k``, ``sprt-s3-family-5k``: S2 / S3 in the family's cells other than
  G-B on 5000 runs of a stream of their own (seed + 4000 + n; declared after a review
  found the 1000-run cells too small for an interval of the mean scan on success);
* ``sprt-calib-s1-met``: the calibration statistics of ``sprt-calib-s1-family`` in the
  13 cells of ``sprt-s1-geometry`` where S1 reproduces, on S1's 5000 verdict runs
  (seed + 500; 06-sensitivity);
* ``sprt-fss-confirm-s1``: the fixed-sample-size confirmation set (04-fixed-sample-size):
  the SPRT's decision and the FSS test's at N = 7 and 8 in the six cells of S1's family,
  on 40000 fresh runs of a new seed (seed + 6000; declared after a review found the
  5000 runs of 04 too few to decide FSS(7) against the SPRT);
* ``sprt-fss-curve-s1``: the FSS curve (04-fixed-sample-size): the SPRT's decision and scan
  and the FSS test's decision at every N = 1..16 in the six cells of S1's family, on
  20000 fresh runs of a new seed (seed + 7000; declared after a review found the saving
  and "faster than FSS" left open where these cheap runs decide them);
* ``sprt-calib-ga``: the calibration statistics of ``sprt-calib-s1-family`` in G-A alone
  on 60000 fresh runs of a new seed (seed + 8000; declared after a review found the
  decoy-filter pair above Ville's bound in G-A where the 5000 runs tie; 05-extensions).
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from ..detection import sprt_decide
from ..scenarios.sprt_acm import (SprtAcmScenario, sprt_acm_filter_config,
                                  sprt_acm_measurements, sprt_acm_scenario, sprt_acm_truth)
from ..trackers.sprt_discriminator import SprtAcmFilterConfig, sprt_acm_discriminate
from ._checks import check_names
from ._core import Experiment, register
from .registry import _Config

__all__ = ["SprtCellsConfig", "calib_statistics", "cell_of", "decision_summary", "t10_cell"]

SEED = 20261123  # the chapter's seed
_NB06 = "book/002-sprt-acm/06-sensitivity.ipynb"
_SCENARIO_KEYS = {f.name for f in dataclasses.fields(SprtAcmScenario)} - {"name"}
_FILTER_KEYS = {f.name for f in dataclasses.fields(SprtAcmFilterConfig)}
_STRING_KEYS = {"target_model"}


@functools.lru_cache(maxsize=256)
def _cell(scenario, cell):
    """The (scenario, filter config, truth) of a cell ``"name=value;name=value"`` ("" for the
    paper's settings)."""
    if not isinstance(cell, str):
        raise TypeError(f"a cell must be a str, got {cell!r}")
    sc_changes, f_changes = {}, {}
    for part in filter(None, (p.strip() for p in cell.split(";"))):
        name, eq, value = (s.strip() for s in part.partition("="))
        if not eq or not value:
            raise ValueError(f"cell {cell!r}: expected name=value, got {part!r}")
        if name in _STRING_KEYS:
            parsed = value
        else:
            try:
                parsed = float(value)
            except ValueError:
                raise ValueError(f"cell {cell!r}: {name} must be a number, "
                                 f"got {value!r}") from None
        if name in _SCENARIO_KEYS:
            target = sc_changes
        elif name in _FILTER_KEYS:
            target = f_changes
        else:
            raise ValueError(f"cell {cell!r}: unknown setting {name!r}; expected a "
                             f"scenario field {sorted(_SCENARIO_KEYS)} or a filter field "
                             f"{sorted(_FILTER_KEYS)}")
        if name in target:
            raise ValueError(f"cell {cell!r}: {name} set twice")
        target[name] = parsed
    sc = sprt_acm_scenario(scenario, **sc_changes)
    return sc, sprt_acm_filter_config(sc, **f_changes), sprt_acm_truth(sc)


@dataclass(frozen=True)
class SprtCellsConfig(_Config):
    """Scenario ``scenario`` (1, 2 or 3) of the paper under each of ``cells`` (a
    non-empty tuple of distinct ``"name=value;..."`` strings of scenario and filter
    changes, ``""`` the paper's settings), with ``H1`` true when ``h1_true``.

    Examples
    --------
    >>> from trackcore.experiments.sprt import SprtCellsConfig, cell_of
    >>> c = SprtCellsConfig(1, ("", cell_of(alpha_deg=45.0, lead_deg=-15.0)))
    >>> c.cells
    ('', 'alpha_deg=45.0;lead_deg=-15.0')
    >>> SprtCellsConfig(4)
    Traceback (most recent call last):
    ...
    ValueError: scenario must be 1, 2 or 3, got 4
    >>> SprtCellsConfig(1, ("alpha=3",))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: cell 'alpha=3': unknown setting 'alpha'; ...
    """

    scenario: int
    cells: tuple = ("",)
    h1_true: bool = False

    _KINDS = {"scenario": int, "cells": tuple}

    def __post_init__(self):
        if isinstance(self.scenario, bool) or self.scenario not in (1, 2, 3):
            raise ValueError(f"scenario must be 1, 2 or 3, got {self.scenario!r}")
        if not isinstance(self.cells, tuple) or not self.cells:
            raise TypeError(f"cells must be a non-empty tuple, got {self.cells!r}")
        check_names(self.cells, "cells", item="cell")
        if not isinstance(self.h1_true, bool):
            raise TypeError(f"h1_true must be a bool, got {self.h1_true!r}")
        for c in self.cells:
            _cell(self.scenario, c)  # raises on a bad cell


def _each_cell(rng, scenario, cells, h1_true):
    """Yield ``(j, scenario, discrimination)`` for every cell, each run from the same
    generator state (= sprt_acm_trial(rng, sc, cfg, h1_true), with the truth computed once
    per cell)."""
    state = rng.bit_generator.state
    for j, c in enumerate(cells):
        sc, cfg, truth = _cell(scenario, c)
        rng.bit_generator.state = state
        z = sprt_acm_measurements(sc, rng, truth, h1_true=h1_true)
        out = sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, sc.T, cfg)
        if not bool(out.ok):
            raise ValueError(f"cell {c!r}: a filter covariance lost positive definiteness")
        yield j, sc, out


def _cells_trial(rng, scenario, cells, h1_true):
    """One run of every cell from the same generator state: (d, k) per cell."""
    d = np.empty(len(cells), dtype=np.int8)
    k = np.empty(len(cells), dtype=np.int16)
    for j, sc, out in _each_cell(rng, scenario, cells, h1_true):
        d[j], k[j] = sprt_decide(out.llr, -sc.gamma, sc.gamma)
    return d, k


def _cells_call(config):
    return (config.scenario, config.cells, config.h1_true), {}


def _cells_extract(out, config):
    d, k = out
    return {"d": d, "k": k}


def cell_of(**changes):
    """The cell string of scenario and filter ``changes`` (in the order given), e.g.
    ``cell_of(alpha_deg=45.0, lead_deg=0.0)`` is ``"alpha_deg=45.0;lead_deg=0.0"``.

    Examples
    --------
    >>> from trackcore.experiments.sprt import cell_of
    >>> cell_of(alpha_deg=45.0, lead_deg=0.0)
    'alpha_deg=45.0;lead_deg=0.0'
    >>> cell_of(beta_std_factor=0.2, target_model="boost")
    'beta_std_factor=0.2;target_model=boost'
    >>> cell_of()  # the paper's settings
    ''
    """
    for name, value in changes.items():
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            raise TypeError(f"{name} must be a number or a str, got {value!r}")
    return ";".join(f"{name}={value}" for name, value in changes.items())


def decision_summary(d, k, min_runs=None):
    """The success rate (Wilson interval) and the mean decision scan on success
    (bootstrap interval; ``None`` with fewer than ``min_runs`` successes, default
    :data:`trackcore.stats.MIN_RUNS`) of decisions ``d`` and decision scans ``k``,
    with ``d`` and ``k`` as int64 arrays: ``{"d", "k", "success", "ksucc"}``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.experiments.sprt import decision_summary
    >>> d = np.array([0] * 45 + [1] * 5)      # 45 right decisions, 5 wrong
    >>> k = np.arange(50) % 7 + 2             # their decision scans
    >>> r = decision_summary(d, k)
    >>> f"{r['success']:.1%}", f"{r['ksucc']:.2f}"
    ('90.0 [78.6, 95.7] %', '4.87 [4.25, 5.49]')
    >>> decision_summary(d[:10], k[:10])["ksucc"] is None   # fewer than MIN_RUNS successes
    True
    """
    from ..stats import MIN_RUNS, mean_ci, rate_ci

    d = np.asarray(d).astype(np.int64)
    k = np.asarray(k).astype(np.int64)
    if d.ndim != 1 or d.shape != k.shape or d.size == 0:
        raise ValueError(f"d and k must be non-empty 1-D arrays of one length, got "
                         f"{d.shape} and {k.shape}")
    min_runs = MIN_RUNS if min_runs is None else min_runs
    ok = d == 0
    ksucc = mean_ci(k[ok]) if ok.sum() >= min_runs else None
    return dict(d=d, k=k, success=rate_ci(int(ok.sum()), d.size), ksucc=ksucc)


#: 06-sensitivity, S1's geometry sweep: target courses and pursuer leads (deg).
GEO_ALPHAS = tuple(float(a) for a in np.arange(30.0, 61.0, 5.0))
GEO_LEADS = tuple(float(x) for x in np.arange(-20.0, 11.0, 5.0))
#: 06-sensitivity, T10's target filters (their changes to the paper's filters).
T10_MODELS = {
    "boost": dict(target_model="boost"),
    "imm": dict(target_model="imm"),
    "imm_cue": dict(target_model="imm", mu_release=1.0),
    "imm_5050": dict(target_model="imm", mu_release=0.5, p_stay_cv=0.5,
                     p_stay_manoeuvre=0.5),
}


def t10_cell(model):
    """The cell of T10's target filter ``model`` with the 20 % prior of 1/r.

    Examples
    --------
    >>> from trackcore.experiments.sprt import t10_cell
    >>> t10_cell("boost")
    'beta_std_factor=0.2;target_model=boost'
    >>> t10_cell("imm_cue")
    'beta_std_factor=0.2;target_model=imm;mu_release=1.0'
    """
    return cell_of(beta_std_factor=0.2, **T10_MODELS[model])


register(Experiment(
    name="sprt-s1-geometry",
    description=("SPRT chapter, S1 on 49 geometries (target course 30..60 deg x pursuer "
                 "lead -20..10 deg): decision and decision scan per run"),
    trial=_cells_trial, call=_cells_call, extract=_cells_extract,
    config=SprtCellsConfig(1, tuple(cell_of(alpha_deg=a, lead_deg=lead) for lead in GEO_LEADS
                                    for a in GEO_ALPHAS)),
    seed=SEED + 1, runs=5000, version="1", notebook=_NB06))
for _n in (2, 3):
    register(Experiment(
        name=f"sprt-t10-s{_n}",
        description=(f"SPRT chapter, T10 in S{_n}: boost, IMM, IMM with the release cue "
                     "and IMM 50/50 target filters, 20 % prior of 1/r"),
        trial=_cells_trial, call=_cells_call, extract=_cells_extract,
        config=SprtCellsConfig(_n, tuple(t10_cell(m) for m in T10_MODELS)),
        seed=SEED + 1000 + _n, runs=5000, version="1", notebook=_NB06))
    register(Experiment(
        name=f"sprt-t10-boost-rep-s{_n}",
        description=(f"SPRT chapter, T10 in S{_n}: the boost filter with the 20 % prior "
                     "replicated on other seeds"),
        trial=_cells_trial, call=_cells_call, extract=_cells_extract,
        config=SprtCellsConfig(_n, (t10_cell("boost"),)),
        seed=SEED + 2000 + _n, runs=5000, version="1", notebook=_NB06))


#: 06-sensitivity, the boost's robustness: its window after the release (s) and the
#: acceleration its noise covers (m/s^2), with the 20 % prior.
BOOST_TIMES = (1.0, 2.0, 4.0)
BOOST_ACCELS = (5.0, 10.0, 20.0)


def boost_cell(boost_time, accel):
    """The cell of the boost with window ``boost_time`` and acceleration ``accel`` and the
    20 % prior of 1/r."""
    return cell_of(beta_std_factor=0.2, target_model="boost", boost_time=float(boost_time),
                   manoeuvre_accel=float(accel))


for _n in (2, 3):
    register(Experiment(
        name=f"sprt-boost-robust-s{_n}",
        description=(f"SPRT chapter, the boost's robustness in S{_n}: windows 1, 2, 4 s x "
                     "accelerations 5, 10, 20 m/s^2, 20 % prior, on the verdict runs"),
        trial=_cells_trial, call=_cells_call, extract=_cells_extract,
        config=SprtCellsConfig(_n, tuple(boost_cell(bt, acc) for bt in BOOST_TIMES
                                         for acc in BOOST_ACCELS)),
        seed=SEED + _n, runs=1000, version="1", notebook=_NB06))

#: The declared geometry family (target course, pursuer lead; deg) besides the defaults:
#: S1's cells other than G-A (45, 0); S2's and S3's add G-A to them (G-B is their default).
FAMILY_S1 = ((33.8, 0.0), (33.8, -15.0), (33.8, 15.0), (45.0, -15.0), (45.0, 15.0))
FAMILY_S23 = ((45.0, 0.0),) + FAMILY_S1


def family_cell(scenario, alpha, lead):
    """The cell of the declared family at target course ``alpha`` and pursuer lead
    ``lead`` (deg); S3 with lead +15 ends at t = 80 s (declared with the family: later the
    target passes within 8 sigma_r of the pursuer)."""
    if scenario == 3 and lead > 0:
        return cell_of(alpha_deg=float(alpha), lead_deg=float(lead), t_end=80.0)
    return cell_of(alpha_deg=float(alpha), lead_deg=float(lead))


register(Experiment(
    name="sprt-s1-family",
    description=("SPRT chapter, the declared geometry family: S1 in 33.8/0, 33.8/-15, "
                 "33.8/+15, 45/-15, 45/+15 (course/lead, deg) on S1's verdict runs"),
    trial=_cells_trial, call=_cells_call, extract=_cells_extract,
    config=SprtCellsConfig(1, tuple(family_cell(1, a, lead) for a, lead in FAMILY_S1)),
    seed=SEED + 500, runs=5000, version="1", notebook=_NB06))
for _n in (2, 3):
    register(Experiment(
        name=f"sprt-s{_n}-family",
        description=(f"SPRT chapter, the declared geometry family: S{_n} in 45/0, 33.8/0, "
                     "33.8/-15, 33.8/+15, 45/-15, 45/+15 (course/lead, deg) on its verdict "
                     "runs"),
        trial=_cells_trial, call=_cells_call, extract=_cells_extract,
        config=SprtCellsConfig(_n, tuple(family_cell(_n, a, lead) for a, lead in FAMILY_S23)),
        seed=SEED + _n, runs=1000, version="1", notebook=_NB06))


#: The cause factorial of S2/S3 (issue 27, declared before its runs): target filter x
#: prior of eq (28) x sign constraint of 1/r x geometry (G-B and the declared family).
CAUSE_GEOMETRIES = ((7.5, -15.0),) + FAMILY_S23
CAUSE_MODELS = ("cv", "boost")
CAUSE_PRIORS = (2.0, 0.2)
#: the sign constraint: the decoy filters' 1/r kept >= 1/(20 km), 20 times the range at
#: the release (None: free, the paper)
CAUSE_BETA_MIN = 1.0 / 20000.0
CAUSE_SIGNS = (None, CAUSE_BETA_MIN)


def cause_cell(scenario, alpha, lead, model, prior, beta_min):
    """The cell of the cause factorial: the family cell at (``alpha``, ``lead``) with
    target filter ``model``, prior factor ``prior`` of eq (28) and sign constraint
    ``beta_min`` (None: free)."""
    filt = dict(target_model=model, beta_std_factor=float(prior))
    if beta_min is not None:
        filt["beta_min"] = float(beta_min)
    return family_cell(scenario, alpha, lead) + ";" + cell_of(**filt)


def cause_cells(scenario):
    """Every cell of the cause factorial of ``scenario`` (2 or 3), geometry slowest, then
    target filter, prior and sign."""
    return tuple(cause_cell(scenario, a, lead, m, f, b) for a, lead in CAUSE_GEOMETRIES
                 for m in CAUSE_MODELS for f in CAUSE_PRIORS for b in CAUSE_SIGNS)


for _n in (2, 3):
    register(Experiment(
        name=f"sprt-cause-s{_n}",
        description=(f"SPRT chapter, the cause factorial of S{_n}: target filter (CV, "
                     "boost) x prior of 1/r (200 %, 20 %) x sign of 1/r (free, >= "
                     "1/20 km) x the 7 declared geometries, on the same runs"),
        trial=_cells_trial, call=_cells_call, extract=_cells_extract,
        config=SprtCellsConfig(_n, cause_cells(_n)),
        seed=SEED + 3000 + _n, runs=5000, version="1", notebook=_NB06))


#: The calibration decomposition (issue 27, declared before its runs): the S1 family's
#: six cells (G-A first), on the 5000 runs of S1's verdicts (seed + 500).
CALIB_GEOMETRIES = ((45.0, 0.0),) + FAMILY_S1
#: the three statistics of a run: Lambda of eq (21), the decoy-filter pair
#: Lambda_a1 - Lambda_b0 and the target-filter pair Lambda_b1 - Lambda_a0
CALIB_STATS = ("full", "dec", "tgt")


def calib_statistics(lam):
    """The three statistics of :data:`CALIB_STATS` from ``lam[..., :] = [Lambda_a0,
    Lambda_b0, Lambda_a1, Lambda_b1]``, stacked on a new last axis; the first is
    :func:`~trackcore.trackers.sprt_acm_llr`'s eq (21), the sum of the other two.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.experiments.sprt import calib_statistics
    >>> lam = np.array([[1.0, 2.0, 0.5, 3.0],     # Lambda_a0, b0, a1, b1 at scan 1
    ...                 [2.0, 4.0, 1.0, 5.0]])    # and at scan 2
    >>> calib_statistics(lam)                     # Lambda, decoy pair, target pair
    array([[ 0.5, -1.5,  2. ],
           [ 0. , -3. ,  3. ]])
    """
    lam = np.asarray(lam, dtype=float)
    if lam.ndim < 1 or lam.shape[-1] != 4:
        raise ValueError(f"lam must have last dimension 4 (a0, b0, a1, b1), got shape "
                         f"{lam.shape}")
    dec = lam[..., 2] - lam[..., 1]
    tgt = lam[..., 3] - lam[..., 0]
    return np.stack([dec + tgt, dec, tgt], axis=-1)


def _calib_trial(rng, scenario, cells, h1_true):
    """One run of every cell from the same generator state: per cell and statistic the
    SPRT's decision and scan at the cell's +-gamma and whether the statistic ever reaches
    +gamma."""
    shape = (len(cells), len(CALIB_STATS))
    d = np.empty(shape, dtype=np.int8)
    k = np.empty(shape, dtype=np.int16)
    ever = np.empty(shape, dtype=np.int8)
    for j, sc, out in _each_cell(rng, scenario, cells, h1_true):
        stats = calib_statistics(out.lam)
        for s in range(len(CALIB_STATS)):
            d[j, s], k[j, s] = sprt_decide(stats[:, s], -sc.gamma, sc.gamma)
            ever[j, s] = bool(np.any(stats[:, s] >= sc.gamma))
    return d, k, ever


def _calib_extract(out, config):
    d, k, ever = out
    cols = {}
    for s, name in enumerate(CALIB_STATS):
        cols[f"d_{name}"] = d[:, s]
        cols[f"k_{name}"] = k[:, s]
        cols[f"ever_{name}"] = ever[:, s]
    return cols


register(Experiment(
    name="sprt-calib-s1-family",
    description=("SPRT chapter, calibration of S1 over the declared family (45/0, 33.8/0, "
                 "33.8/-15, 33.8/+15, 45/-15, 45/+15): decisions and 'ever reaches "
                 "+gamma' of Lambda, its decoy-filter pair and its target-filter pair"),
    trial=_calib_trial, call=_cells_call, extract=_calib_extract,
    config=SprtCellsConfig(1, tuple(family_cell(1, a, lead)
                                    for a, lead in CALIB_GEOMETRIES)),
    seed=SEED + 500, runs=5000, version="1", notebook="book/002-sprt-acm/05-extensions.ipynb"))


#: 06-sensitivity's per-scenario settings on the 1000 runs of S_n's seed (SEED + n): the
#: prior of eq (28) (factors of 1/z_r(1)), the target filters at the printed and the 20 %
#: prior, each decoy filter's prior alone, and the other parameters.
FILTER_FACTORS = (2.0, 1.0, 0.5, 0.2, 0.1)
FILTER_ONE = {"a1": dict(beta_std_factor=2.0, beta_std_factor_a1=0.2),
              "b0": dict(beta_std_factor=0.2, beta_std_factor_a1=2.0)}
FILTER_CASES = {"decoy_6.4": ({"decoy_speed": 6.4}, {}),
                "decoy_25.6": ({"decoy_speed": 25.6}, {}),
                "sigma_v_1": ({}, {"sigma_v": 1.0}),
                "sigma_v_4": ({}, {"sigma_v": 4.0})}
#: the thresholds at which the first cell's full and decoy-only tests are decided
MATCH_GAMMAS = tuple(float(g) for g in np.arange(1.0, 9.01, 0.25))


def filters_cells(scenario_changes=None):
    """The ``(key, cell)`` pairs of the per-scenario settings, the printed filters first:
    ``("prior", f)``, ``("model", m, f)`` (m in :data:`T10_MODELS`, f 2.0 or 0.2),
    ``("one", "a1" | "b0")``, ``("case", label)``, with ``scenario_changes`` (scenario
    fields, e.g. ``{"decoy_speed": 10.0}``) in every cell (a case's own change wins)."""
    sc = dict(scenario_changes or {})
    out = [(("prior", f), cell_of(**sc, beta_std_factor=f)) for f in FILTER_FACTORS]
    out += [(("model", m, f), cell_of(**sc, beta_std_factor=f, **T10_MODELS[m]))
            for m in T10_MODELS for f in (2.0, 0.2)]
    out += [(("one", w), cell_of(**sc, **ch)) for w, ch in FILTER_ONE.items()]
    out += [(("case", lab), cell_of(**{**sc, **s}, **fch))
            for lab, (s, fch) in FILTER_CASES.items()]
    return out


def _filters_trial(rng, scenario, cells, h1_true):
    """One run of every cell from the same generator state: per cell the decisions of
    Lambda and of the decoy-filter-only statistic at the cell's gamma, the target-filter
    pair at scans 2 and 8, the NIS of a0 at scan 2, a1's 1/r < 0 at scan 4 and the IMM's
    first four mode probabilities; for the first cell the decisions of both statistics at
    every threshold of :data:`MATCH_GAMMAS`."""
    nc, ng = len(cells), len(MATCH_GAMMAS)
    r = {name: np.empty(nc, dtype=np.int8) for name in ("d", "d_acm", "neg_a1")}
    r.update({name: np.empty(nc, dtype=np.int16) for name in ("k", "k_acm")})
    r.update({name: np.empty(nc) for name in ("tp2", "tp8", "nis_a0_2")})
    r["mu"] = np.empty((nc, 4))
    for name in ("gd_full", "gd_acm"):
        r[name] = np.empty(ng, dtype=np.int8)
    for name in ("gk_full", "gk_acm"):
        r[name] = np.empty(ng, dtype=np.int16)
    for j, sc, out in _each_cell(rng, scenario, cells, h1_true):
        acm = out.lam[:, 2] - out.lam[:, 1]
        r["d"][j], r["k"][j] = sprt_decide(out.llr, -sc.gamma, sc.gamma)
        r["d_acm"][j], r["k_acm"][j] = sprt_decide(acm, -sc.gamma, sc.gamma)
        r["tp2"][j] = out.lam[1, 3] - out.lam[1, 0]
        r["tp8"][j] = out.lam[7, 3] - out.lam[7, 0]
        r["nis_a0_2"][j] = out.nis[1, 0]
        r["neg_a1"][j] = out.beta[3, 1] < 0
        r["mu"][j] = out.mu[:4, 0]
        if j == 0:
            for i, g in enumerate(MATCH_GAMMAS):
                r["gd_full"][i], r["gk_full"][i] = sprt_decide(out.llr, -g, g)
                r["gd_acm"][i], r["gk_acm"][i] = sprt_decide(acm, -g, g)
    return r


def _filters_extract(out, config):
    return dict(out)


for _n in (1, 2, 3):
    register(Experiment(
        name=f"sprt-filters-s{_n}",
        description=(f"SPRT chapter, S{_n} on its 1000 verdict runs: the prior of eq (28), "
                     "the target filters, each decoy filter's prior alone, the decoy's "
                     "speed and sigma_v (decisions, target-filter pair, NIS, 1/r sign)"),
        trial=_filters_trial, call=_cells_call, extract=_filters_extract,
        config=SprtCellsConfig(_n, tuple(c for _, c in filters_cells())),
        seed=SEED + _n, runs=1000, version="1", notebook=_NB06))


#: The observability of the decoy filter (02-matched-filters; sprt-observability, declared
#: before its runs): S1 in the six cells of the declared family (G-A first; lead 0: the
#: pursuer heads at the decoy, whose bearing does not change; lead -15 or +15: it does),
#: on the 1000 runs of S1's evidence (seed + 1; the first 200 are 02's runs in G-A).
OBS_GEOMETRIES = CALIB_GEOMETRIES


def _obs_trial(rng, scenario, cells, h1_true):
    """One run of every cell from the same generator state: whether the decoy filter on
    the decoy (b0) ends the run with a negative inverse range, and its last estimate of
    1/r relative to the true one minus 1."""
    neg = np.empty(len(cells), dtype=np.int8)
    err = np.empty(len(cells))
    for j, sc, out in _each_cell(rng, scenario, cells, h1_true):
        _, _, truth = _cell(scenario, cells[j])
        d = truth.acm - truth.own[-1, :2]
        neg[j] = out.beta[-1, 0] < 0
        err[j] = out.beta[-1, 0] * np.hypot(d[0], d[1]) - 1.0
    return neg, err


def _obs_extract(out, config):
    neg, err = out
    return {"neg_end": neg, "rel_err_end": err}


register(Experiment(
    name="sprt-obs-s1",
    description=("SPRT chapter, observability of the decoy filter in S1: b0's inverse range "
                 "at the end (negative? relative error) in the six cells of the declared "
                 "family (45/0, 33.8/0, 33.8/-15, 33.8/+15, 45/-15, 45/+15) on the same runs"),
    trial=_obs_trial, call=_cells_call, extract=_obs_extract,
    config=SprtCellsConfig(1, tuple(family_cell(1, a, lead) for a, lead in OBS_GEOMETRIES)),
    seed=SEED + 1, runs=1000, version="1",
    notebook="book/002-sprt-acm/02-matched-filters.ipynb"))


def _early_trial(rng, scenario, cells, h1_true):
    """One run of every cell from the same generator state: Lambda's change over scans
    1-5 minus its change over scans 6-10, ``2 Lambda(5) - Lambda(10)`` (the measure of
    sprt-fig5-early-scans)."""
    out = np.empty(len(cells))
    for j, _sc, res in _each_cell(rng, scenario, cells, h1_true):
        out[j] = 2.0 * res.llr[4] - res.llr[9]
    return out


def _early_extract(out, config):
    return {"early_fall": out}


register(Experiment(
    name="sprt-early-s1-family",
    description=("SPRT chapter, the early fall of Lambda (scans 1-5 against 6-10) in S1's "
                 "declared family (45/0, 33.8/0, 33.8/-15, 33.8/+15, 45/-15, 45/+15) on "
                 "S1's verdict runs"),
    trial=_early_trial, call=_cells_call, extract=_early_extract,
    config=SprtCellsConfig(1, tuple(family_cell(1, a, lead)
                                    for a, lead in CALIB_GEOMETRIES)),
    seed=SEED + 500, runs=5000, version="1",
    notebook="book/002-sprt-acm/03-scenarios.ipynb"))


#: The S2/S3 family at 5000 runs (declared before its runs, after a review found the
#: 1000-run cells too small for T6): the six cells other than G-B on a new stream.
FAMILY_5K_RUNS = 5000
for _n in (2, 3):
    register(Experiment(
        name=f"sprt-s{_n}-family-5k",
        description=(f"SPRT chapter, the declared geometry family at 5000 runs: S{_n} in "
                     "45/0, 33.8/0, 33.8/-15, 33.8/+15, 45/-15, 45/+15 (course/lead, deg) "
                     "on a stream of its own"),
        trial=_cells_trial, call=_cells_call, extract=_cells_extract,
        config=SprtCellsConfig(_n, tuple(family_cell(_n, a, lead) for a, lead in FAMILY_S23)),
        seed=SEED + 4000 + _n, runs=FAMILY_5K_RUNS, version="1", notebook=_NB06))

#: Ville's bound where S1 reproduces (declared before its runs, after a review's
#: question): the 13 cells of sprt-s1-geometry where T1 and T2 hold.
CALIB_MET_GEOMETRIES = ((55.0, -20.0), (55.0, -15.0), (50.0, -10.0), (55.0, -10.0),
                        (50.0, -5.0), (55.0, -5.0), (40.0, 0.0), (45.0, 0.0), (50.0, 0.0),
                        (45.0, 5.0), (50.0, 5.0), (50.0, 10.0), (55.0, 10.0))
register(Experiment(
    name="sprt-calib-s1-met",
    description=("SPRT chapter, calibration of S1 in the 13 geometries of its sweep where "
                 "S1 reproduces: decisions and 'ever reaches +gamma' of Lambda, its "
                 "decoy-filter pair and its target-filter pair"),
    trial=_calib_trial, call=_cells_call, extract=_calib_extract,
    config=SprtCellsConfig(1, tuple(family_cell(1, a, lead)
                                    for a, lead in CALIB_MET_GEOMETRIES)),
    seed=SEED + 500, runs=5000, version="1", notebook=_NB06))


#: The fixed-sample-size confirmation set (declared before its runs, after a second fresh
#: review found FSS(7) - SPRT above 0 on 20000 pooled runs of its own seeds where the
#: book's 5000 runs of 04-fixed-sample-size tie): S1 in the six cells of the declared
#: family (G-A first) on FSS_CONFIRM_RUNS fresh runs of a seed no earlier run used. The
#: count was fixed before any run from the cost (3.0 ms of CPU per run for the six cells,
#: measured on already-seen runs) and the spread of the book's 5000 runs (half-width
#: 0.7 points of FSS(7) - SPRT at 5000 runs, about 0.25 at 40000).
FSS_CONFIRM_SEED = SEED + 6000
FSS_CONFIRM_RUNS = 40000
#: the fixed sample sizes whose decisions are kept (the paper's 8 and the book's 7)
FSS_CONFIRM_NS = (7, 8)


def _fss_trial(rng, scenario, cells, h1_true):
    """One run of every cell from the same generator state: the SPRT's decision and scan
    at the cell's +-gamma, and whether the fixed-sample-size test with N scans decides
    H0 (Lambda(N) < 0), for each N of :data:`FSS_CONFIRM_NS`."""
    d = np.empty(len(cells), dtype=np.int8)
    k = np.empty(len(cells), dtype=np.int16)
    fss = np.empty((len(cells), len(FSS_CONFIRM_NS)), dtype=np.int8)
    for j, sc, out in _each_cell(rng, scenario, cells, h1_true):
        d[j], k[j] = sprt_decide(out.llr, -sc.gamma, sc.gamma)
        fss[j] = [out.llr[n - 1] < 0 for n in FSS_CONFIRM_NS]
    return d, k, fss


def _fss_extract(out, config):
    d, k, fss = out
    cols = {"d": d, "k": k}
    for i, n in enumerate(FSS_CONFIRM_NS):
        cols[f"fss{n}_h0"] = fss[:, i]
    return cols


register(Experiment(
    name="sprt-fss-confirm-s1",
    description=("SPRT chapter, the fixed-sample-size confirmation set: S1 in the declared "
                 "family (45/0, 33.8/0, 33.8/-15, 33.8/+15, 45/-15, 45/+15), the SPRT's "
                 "decision and scan and the FSS test's decision at N = 7 and 8, fresh runs "
                 "of a new seed"),
    trial=_fss_trial, call=_cells_call, extract=_fss_extract,
    config=SprtCellsConfig(1, tuple(family_cell(1, a, lead)
                                    for a, lead in CALIB_GEOMETRIES)),
    seed=FSS_CONFIRM_SEED, runs=FSS_CONFIRM_RUNS, version="1",
    notebook="book/002-sprt-acm/04-fixed-sample-size.ipynb"))


#: The FSS curve beside the SPRT (declared before its runs, session 10, after a review
#: found the saving and "faster than FSS" kept their geometry reading open although the
#: six S1 cells are cheap to run): S1 in the six cells of the declared family (G-A first),
#: the SPRT's decision and scan and the FSS test's decision at every N = 1..16 on the same
#: runs, FSS_CURVE_RUNS fresh runs of a seed no earlier run used. The count was fixed
#: before any run from the cost (4.0 ms of CPU per run for the six cells, the measured cost
#: of sprt-fss-confirm-s1) and the spread of the paired differences there (a half-width of
#: about 0.3 points at 20000 runs, against the differences of several points between
#: neighbouring N outside G-A). N* and the saving are decided by the rule of
#: :func:`trackcore.scenarios._sprt_book.fss_n_star` (claims.yml, sprt-fss-saving).
FSS_CURVE_SEED = SEED + 7000
FSS_CURVE_RUNS = 20000
FSS_CURVE_NS = tuple(range(1, 17))


def ek_undecided_at_end(d, k, n_scans=FSS_CURVE_NS[-1]):
    """E[k] (a ``mean_ci`` Estimate) with runs still undecided at the end (``d < 0``)
    counted at ``n_scans`` scans instead of left out. A reading found after the runs
    (review 10, O1): the declared E[k] averages the decided runs only; this one is shown
    beside it and decides nothing.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.experiments.sprt import ek_undecided_at_end
    >>> d, k = np.tile([0, 1, -1, 0], 10), np.tile([2, 4, 0, 6], 10)
    >>> ek_undecided_at_end(d, k).value
    7.0
    """
    from ..stats import mean_ci

    d, k = np.asarray(d), np.asarray(k)
    return mean_ci(np.where(d < 0, n_scans, k).astype(float))


def _fss_curve_trial(rng, scenario, cells, h1_true):
    """One run of every cell from the same generator state: the SPRT's decision and scan
    at the cell's +-gamma, and whether the FSS test with N scans decides H0 (Lambda(N) <
    0) for each N of :data:`FSS_CURVE_NS`."""
    d = np.empty(len(cells), dtype=np.int8)
    k = np.empty(len(cells), dtype=np.int16)
    fss = np.empty((len(cells), len(FSS_CURVE_NS)), dtype=np.int8)
    for j, sc, out in _each_cell(rng, scenario, cells, h1_true):
        d[j], k[j] = sprt_decide(out.llr, -sc.gamma, sc.gamma)
        fss[j] = [out.llr[n - 1] < 0 for n in FSS_CURVE_NS]
    return d, k, fss


def _fss_curve_extract(out, config):
    d, k, fss = out
    cols = {"d": d, "k": k}
    for i, n in enumerate(FSS_CURVE_NS):
        cols[f"fss{n}_h0"] = fss[:, i]
    return cols


register(Experiment(
    name="sprt-fss-curve-s1",
    description=("SPRT chapter, the FSS curve: S1 in the declared family (45/0, 33.8/0, "
                 "33.8/-15, 33.8/+15, 45/-15, 45/+15), the SPRT's decision and scan and the "
                 "FSS test's decision at every N = 1..16 on the same runs, fresh runs of a "
                 "new seed"),
    trial=_fss_curve_trial, call=_cells_call, extract=_fss_curve_extract,
    config=SprtCellsConfig(1, tuple(family_cell(1, a, lead)
                                    for a, lead in CALIB_GEOMETRIES)),
    seed=FSS_CURVE_SEED, runs=FSS_CURVE_RUNS, version="1",
    notebook="book/002-sprt-acm/04-fixed-sample-size.ipynb"))


#: A larger calibration run in G-A (declared before its runs, session 10, after a fresh
#: review found the decoy-filter pair above Ville's bound in G-A, 5.78 [5.46, 6.11] % on
#: 20000 runs, where the book's 5000 runs tie): the statistics of sprt-calib-s1-family in
#: G-A alone on CALIB_GA_RUNS fresh runs of a seed no earlier run used. The count was fixed
#: from the book's interval (half-width 0.6 points at 5000 runs, so about 0.18 at 60000);
#: the rule (the direction rule against 1/19) is unchanged.
CALIB_GA_SEED = SEED + 8000
CALIB_GA_RUNS = 60000

register(Experiment(
    name="sprt-calib-ga",
    description=("SPRT chapter, calibration of S1 in G-A (45/0) on a larger fresh run: "
                 "decisions and 'ever reaches +gamma' of Lambda, its decoy-filter pair and "
                 "its target-filter pair"),
    trial=_calib_trial, call=_cells_call, extract=_calib_extract,
    config=SprtCellsConfig(1, (family_cell(1, 45.0, 0.0),)),
    seed=CALIB_GA_SEED, runs=CALIB_GA_RUNS, version="1",
    notebook="book/002-sprt-acm/05-extensions.ipynb"))
