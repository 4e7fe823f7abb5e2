"""The HPDA chapter's extensions (book/000-hpda/07-extensions.ipynb) as experiments.

Every experiment reruns :func:`~trackcore.scenarios.run_hpda_trial` with the master
seeds of the chapter's Monte Carlo comparison (case ``c``: ``HPDA_SEED + c``), so run
``i`` sees the scans of run ``i`` of ``hpda-mc-case<c>``:

* ``hpda-ext-prior-case1/2``: HPDA's ``pi11`` and SMC-PHD's ``p_survival`` swept
  together (:class:`HpdaPriorSweepConfig`);
* ``hpda-ext-ladder-case1/2``: the clustering hybrid's printed reading with the
  strong reading's changes added one at a time (:class:`HpdaLadderConfig`);
* ``hpda-ext-factor-pd`` / ``-clutter``: case 1 with only ``P_D`` lowered or only
  the clutter raised (:class:`~trackcore.experiments.HpdaMonteCarloConfig`);
* ``hpda-ext-snr-linear`` / ``-db``: case 2's HPDA-PF with SNR 5 read as linear and
  as 5 dB (:class:`~trackcore.experiments.HpdaMonteCarloConfig`);
* ``hpda-ext-birth-case1/2``: SMC-PHD alone with a birth mass per return, at every
  death prior (:class:`HpdaBirthSweepConfig`);
* ``hpda-ext-birth-factor-pd`` / ``-clutter``: SMC-PHD alone in the one-factor
  environments, both birth models at every death prior, on the first 50 scans
  (:class:`HpdaBirthSweepConfig`);
* ``hpda-ext-turn``: T11b, HPDA-PF with its turn model and with constant-velocity
  particles only, at every death prior, scored in the turns (:class:`HpdaTurnConfig`).

A row holds the estimated count per scan (int16) of every tracker and variant and, in
the prior sweep, SMC-PHD's sum of the particle weights per variant and scan (float32,
the ``sum`` reading of its count): the only per-run quantities the page's tables and
verdicts use. Every experiment runs 100 runs (version 2; version 1 stored 20 or 30, too
few for an interval); run ``i`` is the same in both versions.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..scenarios.hpda_scenario import hpda_parameters, hpda_truth, run_hpda_trial
from ._checks import check_names
from ._core import Experiment, register
from .registry import HPDA_SEED, HpdaMonteCarloConfig

__all__ = [
    "HpdaBirthSweepConfig",
    "HpdaConfirmConfig",
    "HpdaLadderConfig",
    "HpdaPriorSweepConfig",
    "HpdaTurnConfig",
]

_NB = "book/000-hpda/07-extensions.ipynb"

#: The clustering hybrid's readings, each adding one change of the strong reading to
#: the printed (literal) one: tracker-config overrides of ``clustering_literal``.
LADDER_READINGS = {
    "literal": {},
    "chi2_gate": {"link_d2": 9.2103},
    "motion": {"link_d2": 9.2103, "link_motion_std": 1.5},
    "every_scan": {"link_d2": 9.2103, "link_motion_std": 1.5, "seed_every_scan": True},
    "gated_support": {
        "link_d2": 9.2103,
        "link_motion_std": 1.5,
        "seed_every_scan": True,
        "gated_support": True,
    },
}


def _check_algorithms(config, allowed):
    bad = [a for a in config.algorithms if a not in allowed]
    if bad:
        raise ValueError(
            f"algorithms of {type(config).__name__} must be some of {allowed}, "
            f"got {bad}"
        )


@dataclass(frozen=True)
class HpdaPriorSweepConfig(HpdaMonteCarloConfig):
    """The death prior swept: for every value ``v`` in ``priors``, HPDA's ``pi11`` and
    SMC-PHD's ``p_survival`` both set to ``v`` and ``algorithms`` (some of ``hpda``,
    ``phd``) run on the same scans; the other fields as in
    :class:`~trackcore.experiments.HpdaMonteCarloConfig`.

    Examples
    --------
    >>> from trackcore.experiments.hpda_extensions import HpdaPriorSweepConfig
    >>> cfg = HpdaPriorSweepConfig(1, priors=(0.98, 0.995))
    >>> cfg.variants()[0]
    {'hpda': {'pi11': 0.98}, 'phd': {'p_survival': 0.98}}
    """

    algorithms: tuple = ("hpda", "phd")
    priors: tuple = (0.98, 0.99, 0.995)

    _KINDS: ClassVar[dict] = {**HpdaMonteCarloConfig._KINDS, "priors": "floats"}

    def __post_init__(self):
        super().__post_init__()
        _check_algorithms(self, ("hpda", "phd"))
        check_names(self.priors, "priors")
        for v in self.priors:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < 1:
                raise ValueError(f"every prior must be a number in (0, 1), got {v!r}")

    def variants(self):
        return tuple(
            {"hpda": {"pi11": v}, "phd": {"p_survival": v}} for v in self.priors
        )


@dataclass(frozen=True)
class HpdaLadderConfig(HpdaMonteCarloConfig):
    """The clustering hybrid's printed reading (``clustering_literal``) with the strong
    reading's changes added one at a time: ``readings`` are keys of
    :data:`LADDER_READINGS`, all run on the same scans; the other fields as in
    :class:`~trackcore.experiments.HpdaMonteCarloConfig`.

    Examples
    --------
    >>> from trackcore.experiments.hpda_extensions import HpdaLadderConfig
    >>> cfg = HpdaLadderConfig(2, readings=("literal", "chi2_gate"))
    >>> cfg.variants()
    ({'clustering_literal': {}}, {'clustering_literal': {'link_d2': 9.2103}})
    """

    algorithms: tuple = ("clustering_literal",)
    readings: tuple = tuple(LADDER_READINGS)

    _KINDS: ClassVar[dict] = {**HpdaMonteCarloConfig._KINDS, "readings": tuple}

    def __post_init__(self):
        super().__post_init__()
        _check_algorithms(self, ("clustering_literal",))
        check_names(self.readings, "readings", LADDER_READINGS, "reading")

    def variants(self):
        return tuple({"clustering_literal": LADDER_READINGS[r]} for r in self.readings)


#: SMC-PHD's birth models (the chapter's ``phd_birth`` reading): tracker-config
#: overrides of ``phd``. ``total``: Table 2's P_birth = 0.2 as a scan's births, split
#: over the previous scan's returns (the default); ``per_return``: 0.2/11 on every
#: return of the previous scan.
BIRTH_READINGS = {
    "total": {"birth_model": "per_scan", "birth_mass": 0.2},
    "per_return": {"birth_model": "per_return", "birth_mass": 0.2 / 11},
}


@dataclass(frozen=True)
class HpdaBirthSweepConfig(HpdaPriorSweepConfig):
    """SMC-PHD's birth model swept with the death prior: for every prior ``v`` in
    ``priors`` and every key ``b`` of :data:`BIRTH_READINGS` in ``births`` (the
    variants in that order, births fastest), SMC-PHD's ``p_survival = v`` and the
    birth overrides ``BIRTH_READINGS[b]``; ``keep_scans`` (``None``: all) runs only
    the first scans (the filter is causal); the other fields as in
    :class:`HpdaPriorSweepConfig` (``algorithms`` must be ``("phd",)``).

    Examples
    --------
    >>> cfg = HpdaBirthSweepConfig(2, priors=(0.99,), births=("total", "per_return"))
    >>> [v["phd"]["birth_model"] for v in cfg.variants()]
    ['per_scan', 'per_return']
    >>> round(cfg.variants()[1]["phd"]["birth_mass"], 4)
    0.0182
    """

    algorithms: tuple = ("phd",)
    births: tuple = ("per_return",)
    keep_scans: int | None = None

    _KINDS: ClassVar[dict] = {
        **HpdaPriorSweepConfig._KINDS,
        "births": tuple,
        "keep_scans": int,
    }

    def __post_init__(self):
        k = self.keep_scans
        if k is not None and (
            isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1
        ):
            raise ValueError(f"keep_scans must be None or an integer >= 1, got {k!r}")
        super().__post_init__()
        _check_algorithms(self, ("phd",))
        check_names(self.births, "births", BIRTH_READINGS, "birth model")

    def scenario(self):
        """The scenario overrides; ``keep_scans`` also shortens the runs to as many
        scans (the filter is causal, so its first scans are as in a full run)."""
        sc = super().scenario()
        return sc if self.keep_scans is None else {**sc, "n_scans": self.keep_scans}

    def variants(self):
        return tuple(
            {"phd": {"p_survival": v, **BIRTH_READINGS[b]}}
            for v in self.priors
            for b in self.births
        )


def _fresh(rng):
    """A generator equal to ``rng`` as ``montecarlo.run`` hands it to a trial: from a
    copy of its seed sequence, so that its ``spawn`` starts again at the first child."""
    ss = rng.bit_generator.seed_seq
    return np.random.default_rng(
        np.random.SeedSequence(
            ss.entropy, spawn_key=ss.spawn_key, pool_size=ss.pool_size
        )
    )


def _variants_trial(rng, case, algorithms, variants, scenario_overrides=None):
    """:func:`run_hpda_trial` once per tracker-override dict in ``variants``, each from
    a fresh copy of run ``i``'s generator (so on the same scans and particle streams
    as separate ``montecarlo.run`` calls with the same seed); returns the results."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    return [
        run_hpda_trial(
            _fresh(rng),
            case,
            algorithms,
            overrides=ov,
            scenario_overrides=scenario_overrides,
        )
        for ov in variants
    ]


def _int16(count, what):
    count = np.asarray(count)
    small = count.astype(np.int16)
    if not np.array_equal(small, count):
        raise ValueError(f"{what}: a count does not fit in int16")
    return small


def _variants_call(config):
    return (config.case, config.algorithms, config.variants()), {
        "scenario_overrides": config.scenario() or None
    }


def _variants_extract(outs, config):
    """Per tracker: the count per variant and scan, ``(variants, scans)`` int16; for
    SMC-PHD also its sum of weights per variant and scan (float32)."""
    row = {
        f"{a}.count": np.stack([_int16(o[a]["count"], a) for o in outs])
        for a in config.algorithms
    }
    if "phd" in config.algorithms:
        row["phd.sum_w"] = np.stack(
            [np.asarray(o["phd"]["aux"], dtype=np.float32) for o in outs]
        )
    return row


def _births_extract(outs, config):
    """SMC-PHD's count (int16) and sum of weights (float32) per variant and scan, the
    first ``config.keep_scans`` scans."""
    row = _variants_extract(outs, config)
    k = config.keep_scans
    return {name: x[:, :k] for name, x in row.items()} if k else row


def _counts_call(config):
    return (config.case, config.algorithms), {
        "scenario_overrides": config.scenario() or None
    }


def _counts_extract(out, config):
    """Per tracker: the count per scan (int16)."""
    return {f"{a}.count": _int16(out[a]["count"], a) for a in config.algorithms}


for _kind, _cls, _runs, _what in (
    ("prior", HpdaPriorSweepConfig, 100,
     "the death prior: HPDA's Pi_11 and SMC-PHD's P_S swept together over 0.98, 0.99, "
     "0.995"),
    ("ladder", HpdaLadderConfig, 100,
     "the clustering hybrid one change at a time: the printed reading and four steps to "
     "the strong one"),
):
    for _case in (1, 2):
        register(
            Experiment(
                name=f"hpda-ext-{_kind}-case{_case}",
                description=f"HPDA chapter, {_what} in case {_case} (counts per scan)",
                trial=_variants_trial,
                call=_variants_call,
                extract=_variants_extract,
                config=_cls(_case),
                seed=HPDA_SEED + _case,
                runs=_runs,
                version="2",
                notebook=_NB,
            )
        )
for _name, _what, _over in (
    ("pd", "only P_D lowered to 0.6", {"pd": 0.6}),
    ("clutter", "only the clutter raised to lambda V = 50", {"clutter_mean": 50.0}),
):
    register(
        Experiment(
            name=f"hpda-ext-factor-{_name}",
            description=f"HPDA chapter, the attribution of Fig. 9: case 1 with {_what} "
            f"(HPDA-PF, SMC-PHD, clustering strong; counts per scan)",
            trial=run_hpda_trial,
            call=_counts_call,
            extract=_counts_extract,
            config=HpdaMonteCarloConfig(1, ("hpda", "phd", "clustering"), **_over),
            seed=HPDA_SEED + 1,
            runs=100,
            version="2",
            notebook=_NB,
        )
    )
for _name, _what, _snr in (
    ("linear", "SNR 5 read as linear (the book's reading)", 5.0),
    ("db", "SNR 5 read as 5 dB (rho = 3.16)", 10**0.5),
):
    register(
        Experiment(
            name=f"hpda-ext-snr-{_name}",
            description=f"HPDA chapter, case 2's HPDA-PF with {_what} "
            "(counts per scan)",
            trial=run_hpda_trial,
            call=_counts_call,
            extract=_counts_extract,
            config=HpdaMonteCarloConfig(2, ("hpda",), snr=_snr),
            seed=HPDA_SEED + 2,
            runs=100,
            version="2",
            notebook=_NB,
        )
    )
for _case in (1, 2):
    register(
        Experiment(
            name=f"hpda-ext-birth-case{_case}",
            description=f"HPDA chapter, SMC-PHD with a birth mass of 0.2/11 per return "
            f"at P_S = 0.98, 0.99, 0.995 in case {_case} (counts and sums of weights "
            "per scan)",
            trial=_variants_trial,
            call=_variants_call,
            extract=_births_extract,
            config=HpdaBirthSweepConfig(_case),
            seed=HPDA_SEED + _case,
            runs=100,
            version="1",
            notebook=_NB,
        )
    )
for _name, _what, _over in (
    ("pd", "only P_D lowered to 0.6", {"pd": 0.6}),
    ("clutter", "only the clutter raised to lambda V = 50", {"clutter_mean": 50.0}),
):
    register(
        Experiment(
            name=f"hpda-ext-birth-factor-{_name}",
            description=f"HPDA chapter, the attribution of Fig. 9's early over-count: "
            f"SMC-PHD in case 1 with {_what}, both birth models at P_S = 0.98, 0.99, "
            "0.995 (runs of the first 50 scans: counts and sums of weights)",
            trial=_variants_trial,
            call=_variants_call,
            extract=_births_extract,
            config=HpdaBirthSweepConfig(
                1, births=tuple(BIRTH_READINGS), keep_scans=50, **_over
            ),
            seed=HPDA_SEED + 1,
            runs=100,
            version="1",
            notebook=_NB,
        )
    )


# ------------------------------------------------------ T4: the confirmation set
#: T4's confirmation set (declared before its runs, issue 25): a seed of its own, no
#: run of which is a run of the chapter's other stores, and enough paired runs to
#: decide HPDA-PF against the strong clustering hybrid at every Pi_11.
CONFIRM_SEED, CONFIRM_RUNS = 20261204, 1000


@dataclass(frozen=True)
class HpdaConfirmConfig(HpdaMonteCarloConfig):
    """T4's confirmation set: HPDA-PF at every ``pi11`` in ``priors`` and the strong
    clustering hybrid (which has no survival prior, so it runs once) on the same scans;
    the other fields as in :class:`~trackcore.experiments.HpdaMonteCarloConfig`
    (``algorithms`` must be ``("hpda", "clustering")``).

    Examples
    --------
    >>> from trackcore.experiments.hpda_extensions import HpdaConfirmConfig
    >>> HpdaConfirmConfig(1).priors
    (0.98, 0.99, 0.995)
    >>> HpdaConfirmConfig(1, algorithms=("hpda", "phd"))
    Traceback (most recent call last):
    ...
    ValueError: algorithms of HpdaConfirmConfig must be ('hpda', 'clustering'), got ('hpda', 'phd')
    """

    algorithms: tuple = ("hpda", "clustering")
    priors: tuple = (0.98, 0.99, 0.995)

    _KINDS: ClassVar[dict] = {**HpdaMonteCarloConfig._KINDS, "priors": "floats"}

    def __post_init__(self):
        super().__post_init__()
        if tuple(self.algorithms) != ("hpda", "clustering"):
            raise ValueError(
                f"algorithms of {type(self).__name__} must be ('hpda', 'clustering'), "
                f"got {tuple(self.algorithms)}"
            )
        check_names(self.priors, "priors")
        for v in self.priors:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < 1:
                raise ValueError(f"every prior must be a number in (0, 1), got {v!r}")


def _confirm_trial(rng, case, priors, scenario_overrides=None):
    """HPDA-PF at every prior in ``priors`` and the strong clustering hybrid once, all
    on run ``i``'s scans: the first call runs both trackers (data stream, then HPDA-PF's,
    then the hybrid's), the others HPDA-PF alone from a fresh copy of the generator (so
    the same scans and the same particle stream). Returns ``(counts (P, K), counts (K,))``."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    hpda, hybrid = [], None
    for j, v in enumerate(priors):
        algs = ("hpda", "clustering") if j == 0 else ("hpda",)
        out = run_hpda_trial(_fresh(rng), case, algs, overrides={"hpda": {"pi11": v}},
                             scenario_overrides=scenario_overrides)
        hpda.append(out["hpda"]["count"])
        if j == 0:
            hybrid = out["clustering"]["count"]
    return np.stack(hpda), hybrid


def _confirm_call(config):
    return (config.case, config.priors), {"scenario_overrides": config.scenario() or None}


def _confirm_extract(out, config):
    """HPDA-PF's count per prior and scan ``(priors, scans)`` and the hybrid's count per
    scan, int16."""
    hpda, hybrid = out
    return {"hpda.count": _int16(hpda, "hpda"), "clustering.count": _int16(hybrid, "clustering")}


register(
    Experiment(
        name="hpda-t4-confirm",
        description="HPDA chapter, T4's confirmation set: HPDA-PF at Pi_11 = 0.98, 0.99, "
        "0.995 and the strong clustering hybrid in case 1 on a seed of its own (counts "
        "per scan)",
        trial=_confirm_trial,
        call=_confirm_call,
        extract=_confirm_extract,
        config=HpdaConfirmConfig(1),
        seed=CONFIRM_SEED,
        runs=CONFIRM_RUNS,
        version="1",
        notebook="book/000-hpda/06-monte-carlo.ipynb",
    )
)


# ----------------------------------------------------------------------- T11b: turns
#: HPDA-PF's control without a turn model: every mode moves to constant velocity.
CV_ONLY_TPM = ((1.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.0, 0.0))
#: Scans after a turn's end counted with the turn (where a filter without a turn
#: model still lags), and the radius within which an estimate counts as a hit [m].
TURN_AFTER, TURN_RADIUS = 10, 500.0
#: The columns of a row's ``hpda.turn`` (per variant).
TURN_COLUMNS = ("rmse_turn", "miss_turn", "rmse_straight", "miss_straight")


def _turn_mask(truth, after=TURN_AFTER):
    """``(K, n_targets)`` bool: the scans of each target's turn and the ``after``
    scans after it, while the target lives."""
    turning = truth.modes >= 2
    mask = turning.copy()
    for t in range(turning.shape[1]):
        ks = np.flatnonzero(turning[:, t])
        if ks.size:
            mask[ks[-1] + 1 : ks[-1] + 1 + after, t] = True
    return mask & truth.alive


def _turn_errors(run, truth, after=TURN_AFTER, radius=TURN_RADIUS):
    """Position errors of a tracker run's estimates in the turns and in straight
    flight: per live target and scan the distance to the nearest estimate, a hit
    when within ``radius``. Returns the RMSE over the hits and the share of misses,
    in the turns (and ``after`` scans after) and elsewhere, pooled over the targets
    (``TURN_COLUMNS``; NaN RMSE where there is no hit)."""
    K, C = run.estimates.shape[:2]
    if truth.alive.shape[0] != K:
        raise ValueError(f"run has {K} scans, truth {truth.alive.shape[0]}")
    valid = np.arange(C)[None, :] < run.n_estimates[:, None]
    E = np.where(valid[..., None], run.estimates[..., :2], np.nan)
    Y = truth.states[..., :2]
    dd = np.hypot(
        E[:, :, None, 0] - Y[:, None, :, 0], E[:, :, None, 1] - Y[:, None, :, 1]
    )
    d = np.min(np.where(np.isnan(dd), np.inf, dd), axis=1)
    hit = truth.alive & (d <= radius)
    turn = _turn_mask(truth, after)
    out = []
    for g in (turn, truth.alive & ~turn):
        h = g & hit
        out += [
            float(np.sqrt(np.mean(d[h] ** 2))) if h.any() else math.nan,
            1.0 - h.sum() / g.sum(),
        ]
    return np.array(out)


@dataclass(frozen=True)
class HpdaTurnConfig(HpdaPriorSweepConfig):
    """HPDA-PF (T11b) with its turn model and with constant-velocity particles only
    (:data:`CV_ONLY_TPM`), at every ``pi11`` in ``priors``, on the same scans and
    particle streams; the other fields as in :class:`HpdaPriorSweepConfig`
    (``algorithms`` must be ``("hpda",)``).

    Examples
    --------
    >>> cfg = HpdaTurnConfig(1, priors=(0.99,))
    >>> [sorted(v["hpda"]) for v in cfg.variants()]
    [['pi11'], ['mode_tpm', 'pi11']]
    """

    algorithms: tuple = ("hpda",)

    def __post_init__(self):
        super().__post_init__()
        _check_algorithms(self, ("hpda",))

    def variants(self):
        return tuple(
            {"hpda": dict(pi11=v, **extra)}
            for v in self.priors
            for extra in ({}, {"mode_tpm": CV_ONLY_TPM})
        )


def _turn_trial(rng, case, variants, scenario_overrides=None):
    """HPDA-PF once per override dict in ``variants`` (fresh copies of run ``i``'s
    generator: the same scans and particle streams), scored by :func:`_turn_errors`;
    returns ``(variants, 4)``."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    params = hpda_parameters(case)
    if scenario_overrides:
        params = dataclasses.replace(params, **scenario_overrides)
    truth = hpda_truth("B", n_scans=params.n_scans)
    rows = []
    for ov in variants:
        out = run_hpda_trial(
            _fresh(rng),
            case,
            ("hpda",),
            keep_estimates=True,
            overrides=ov,
            scenario_overrides=scenario_overrides,
        )
        rows.append(_turn_errors(out["hpda"]["run"], truth))
    return np.array(rows)


def _turn_call(config):
    return (config.case, config.variants()), {
        "scenario_overrides": config.scenario() or None
    }


def _turn_extract(out, config):
    """HPDA-PF's errors per variant (``TURN_COLUMNS``, float64)."""
    return {"hpda.turn": np.asarray(out, dtype=np.float64)}


register(
    Experiment(
        name="hpda-ext-turn",
        description="HPDA chapter, T11b: HPDA-PF with its turn model and with constant-"
        "velocity particles only, at Pi_11 = 0.98, 0.99, 0.995 in case 1 (position "
        "errors in the turns and in straight flight)",
        trial=_turn_trial,
        call=_turn_call,
        extract=_turn_extract,
        config=HpdaTurnConfig(1),
        seed=HPDA_SEED + 1,
        runs=100,
        version="1",
        notebook=_NB,
    )
)


# ------------------------------------------------------------- Fig. 6: the single run
def _median_run(values):
    """The run that stands for a set of runs: the ``(n + 1) // 2``-th smallest of
    ``values`` (the 50th of 100), ties to the lower run index."""
    v = np.asarray(values, dtype=float)
    if v.ndim != 1 or v.size == 0 or np.isnan(v).any():
        raise ValueError("values must be a non-empty 1-D array without NaN")
    return int(np.argsort(v, kind="stable")[(v.size - 1) // 2])


def _identity_report(run, truth, radius=TURN_RADIUS, min_scans=5):
    """Track identities of a tracker run against the truth: the number of distinct
    identities, per target the fragmentation (the identities within ``radius`` of it
    for ``min_scans`` scans or more, minus one; 0 when none follows it) and the share
    of its life with an estimate within ``radius``."""
    K, C = run.ids.shape
    if truth.alive.shape[0] != K:
        raise ValueError(f"run has {K} scans, truth {truth.alive.shape[0]}")
    valid = np.arange(C)[None, :] < run.n_estimates[:, None]
    ids = np.where(valid, run.ids, -1)
    E, Y = run.estimates[..., :2], truth.states[..., :2]
    dd = np.hypot(
        E[:, :, None, 0] - Y[:, None, :, 0], E[:, :, None, 1] - Y[:, None, :, 1]
    )
    near = valid[..., None] & truth.alive[:, None, :]
    near &= np.nan_to_num(dd, nan=np.inf) <= radius
    frag, cover = [], []
    for t in range(truth.alive.shape[1]):
        _, n = np.unique(ids[near[:, :, t]], return_counts=True)
        frag.append(max(int((n >= min_scans).sum()) - 1, 0))
        life = truth.alive[:, t]
        hit = near[:, :, t].any(axis=1)[life]
        cover.append(float(hit.mean()) if life.any() else math.nan)
    return len(np.unique(ids[ids >= 0])), np.array(frag), np.array(cover)
