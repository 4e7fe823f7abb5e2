"""HPDA-PF against valid distance-only filters (book/000-hpda/08-valid-comparators.ipynb).

Case 3 (the stress environment) with the SNR rho swept over the ``stress_rho``
reading and the death prior Pi_11 fixed per experiment (``hpda-cmp-pi<Pi_11>``).  Run
``i`` uses the chapter's case-3 master seed, so its scans at rho = 10 are those of run
``i`` of ``hpda-mc-case3`` and, at rho = 10 and Pi_11 = 0.99, its HPDA-PF run is that
run's too (same data and particle streams).

The scans of run ``i`` differ between the values of rho only in their amplitudes: the
detections are drawn as ``(1 + rho) E > -(1 + rho) ln P_D`` with the same ``E`` and
``P_D`` held at 0.9, and the clutter positions are the same draws.  The distance-only
filters never read an amplitude, so each runs once per run (on the first rho's scans)
and is paired with HPDA-PF at every rho; the trial checks that the positions agree.

A row holds, per tracker (``hpda.rho<r>`` for every rho, ``nn-likelihood``, ``ipda``),
the estimated count per scan (int16) and the per-run metrics of
:func:`~trackcore.scenarios.hpda_run_metrics`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..scenarios.hpda_scenario import (
    HPDA_METRICS,
    hpda_parameters,
    hpda_run_metrics,
    hpda_tracker_configs,
    hpda_truth,
    simulate_hpda_scans,
)
from ..trackers.hpda_pf import hpda_pf_run
from ._checks import check_finite, check_names
from ._core import Experiment, register
from .registry import HPDA_SEED, _Config

__all__ = ["HpdaComparatorConfig", "HpdaSnConfig"]

_NB = "book/000-hpda/08-valid-comparators.ipynb"
#: the valid distance-only filters (HPDA-PF's selection rules of the same names)
COMPARATORS = ("nn-likelihood", "ipda")
#: the stress SNRs of the chapter's ``stress_rho`` reading
RHOS = (2.0, 3.0, 5.0, 10.0)
#: the death priors of the chapter's ``pi11`` reading
PRIORS = (0.98, 0.99, 0.995)


@dataclass(frozen=True)
class HpdaComparatorConfig(_Config):
    """Case 3 at death prior ``pi11`` (HPDA-PF's and the comparators' Pi_11): HPDA-PF at
    every SNR in ``rhos`` and the distance-only ``comparators`` (some of
    :data:`COMPARATORS`) on the same scans.

    Examples
    --------
    >>> from trackcore.experiments.hpda_comparators import HpdaComparatorConfig
    >>> cfg = HpdaComparatorConfig(0.99)
    >>> cfg.rhos, cfg.comparators
    ((2.0, 3.0, 5.0, 10.0), ('nn-likelihood', 'ipda'))
    >>> HpdaComparatorConfig(1.5)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: pi11 must lie in (0, 1), got 1.5
    """

    pi11: float
    rhos: tuple = RHOS
    comparators: tuple = COMPARATORS

    _KINDS: ClassVar[dict] = {"pi11": float, "rhos": "floats", "comparators": tuple}

    def __post_init__(self):
        check_finite(self.pi11, "pi11")
        if not 0.0 < self.pi11 < 1.0:
            raise ValueError(f"pi11 must lie in (0, 1), got {self.pi11!r}")
        check_names(self.rhos, "rhos")
        for r in self.rhos:
            check_finite(r, "rhos")
            if r < 0:
                raise ValueError(f"every value of rhos must be >= 0, got {r!r}")
        check_names(self.comparators, "comparators", COMPARATORS, "comparator")


def _comparators_trial(rng, pi11, rhos, comparators):
    """Simulate run ``i``'s case-3 scans at every rho (data stream first, as
    :func:`~trackcore.scenarios.run_hpda_trial`), run HPDA-PF on each with the first
    tracker stream and every comparator once with the next ones; per tracker the count
    per scan and the per-run metrics."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    seqs = rng.bit_generator.seed_seq.spawn(2 + len(comparators))
    truth = hpda_truth("B", n_scans=hpda_parameters(3).n_scans)
    out, first = {}, None
    for r in rhos:
        params = dataclasses.replace(hpda_parameters(3), snr=float(r))
        scans = simulate_hpda_scans(truth, params, np.random.default_rng(seqs[0]))
        if first is None:
            first = (scans, params)
        elif not (np.array_equal(scans.z, first[0].z)
                  and np.array_equal(scans.offsets, first[0].offsets)):
            raise AssertionError(f"the scans at rho = {r} differ in position from the "
                                 f"first rho's: the comparators cannot be shared")
        cfg = dataclasses.replace(hpda_tracker_configs(params)["hpda"], pi11=pi11)
        res = hpda_pf_run(scans.z, scans.amplitude, scans.offsets, cfg,
                          np.random.default_rng(seqs[1]))
        out[f"hpda.rho{r:g}"] = res
    scans, params = first
    base = dataclasses.replace(hpda_tracker_configs(params)["hpda"], pi11=pi11)
    for q, name in enumerate(comparators):
        cfg = dataclasses.replace(base, selection=name)
        out[name] = hpda_pf_run(scans.z, scans.amplitude, scans.offsets, cfg,
                                np.random.default_rng(seqs[2 + q]))
    return {k: (v.count, hpda_run_metrics(v, truth)) for k, v in out.items()}


def _call(config):
    return (config.pi11, config.rhos, config.comparators), {}


def _extract(out, config):
    row = {}
    for key, (count, metrics) in out.items():
        small = np.asarray(count).astype(np.int16)
        if not np.array_equal(small, count):
            raise ValueError(f"{key}: a count does not fit in int16")
        row[f"{key}.count"] = small
        for m in HPDA_METRICS:
            row[f"{key}.{m}"] = np.float64(metrics[m])
    return row


for _p in PRIORS:
    register(
        Experiment(
            name=f"hpda-cmp-pi{_p:g}",
            description="HPDA chapter, case 3 at Pi_11 = "
            f"{_p:g}: HPDA-PF at rho = 2, 3, 5, 10 and the valid distance-only "
            "filters (nearest neighbour with its own likelihood, IPDA) on the same scans",
            trial=_comparators_trial,
            call=_call,
            extract=_extract,
            config=HpdaComparatorConfig(_p),
            seed=HPDA_SEED + 3,
            runs=100,
            version="1",
            notebook=_NB,
        )
    )


@dataclass(frozen=True)
class HpdaSnConfig(_Config):
    """Case 3 at death prior ``pi11``: HPDA-PF with the strongest-neighbour rule at
    every SNR in ``rhos``.

    Examples
    --------
    >>> from trackcore.experiments.hpda_comparators import HpdaSnConfig
    >>> HpdaSnConfig(0.98).rhos
    (2.0, 3.0, 5.0, 10.0)
    """

    pi11: float
    rhos: tuple = RHOS

    _KINDS: ClassVar[dict] = {"pi11": float, "rhos": "floats"}

    def __post_init__(self):
        HpdaComparatorConfig(self.pi11, self.rhos)  # the same checks


def _sn_call(config):
    return (config.pi11, config.rhos), {}


def _sn_trial(rng, pi11, rhos):
    """HPDA-PF with the strongest-neighbour rule in place of eq (15) on run ``i``'s
    case-3 scans at every rho, on the streams of :func:`_comparators_trial` (scans from
    the first child, particles from the second), so each run is paired with the
    ``hpda.rho<r>`` run of ``hpda-cmp-pi<Pi_11>`` by common random numbers."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    seqs = rng.bit_generator.seed_seq.spawn(2)
    truth = hpda_truth("B", n_scans=hpda_parameters(3).n_scans)
    out = {}
    for r in rhos:
        params = dataclasses.replace(hpda_parameters(3), snr=float(r))
        scans = simulate_hpda_scans(truth, params, np.random.default_rng(seqs[0]))
        cfg = dataclasses.replace(hpda_tracker_configs(params)["hpda_sn"], pi11=pi11)
        res = hpda_pf_run(scans.z, scans.amplitude, scans.offsets, cfg,
                          np.random.default_rng(seqs[1]))
        out[f"sn.rho{r:g}"] = res
    return {k: (v.count, hpda_run_metrics(v, truth)) for k, v in out.items()}


for _p in PRIORS:
    register(
        Experiment(
            name=f"hpda-sn-pi{_p:g}",
            description="HPDA chapter, case 3 at Pi_11 = "
            f"{_p:g}: HPDA-PF with the strongest-neighbour rule at rho = 2, 3, 5, 10, "
            f"paired with hpda-cmp-pi{_p:g}'s HPDA-PF runs (same scans and particle streams)",
            trial=_sn_trial,
            call=_sn_call,
            extract=_extract,
            config=HpdaSnConfig(_p),
            seed=HPDA_SEED + 3,
            runs=100,
            version="1",
            notebook=_NB,
        )
    )
