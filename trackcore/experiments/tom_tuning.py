"""The TOM-IMM chapter's grids, searches and fresh seeds (001-05, sections 3, 5-7).

The grid seed of 001-05 (20261125) is split into streams, as the page always did:
``SeedSequence(20261125).spawn(3)`` gives the grid seeds (stream 0), the fresh seeds
(stream 1) and the fixed-size T9 sample (stream 2).  A config's ``stream`` field names
the stream: run ``i`` of an experiment here uses ``SeedSequence(20261125).spawn(3)
[stream].spawn(n)[i]``, the run ``trackcore.montecarlo.run`` gives for that stream, so
the stored rows are the runs the page computed live before.  It still depends only on
(experiment, config, seed, i): :func:`_on_stream` re-keys the store's generator for run
``i`` (``SeedSequence(seed).spawn(n)[i]``, spawn key ``(i,)``) to spawn key
``(stream, i)``.  ``stream = -1`` keeps the store's own seeding.

* ``tom-tuning-grid`` (stream 0, 200 runs, P_G = 0.9999): Singer, the chord TOM and the
  literal index (u = 70 and 100 m/s), then every point the page's grids and searches
  score: the chord TOM's grid and search, the velocity-heading variant's, and the
  known-rate reference's;
* ``tom-tuning-fresh`` (stream 1, 1000 runs, P_G = 0.9999): Singer, CAR, the chapter's
  TOM and the three points the searches chose;
* ``tom-tuning-t9`` (stream 2, P_G = 0.9999): Singer and the best-manoeuvring point at
  the run count declared before its runs (``T9_RUNS``, from the fresh seeds' variance);
* ``tom-cause-no-clutter`` (Table 1's seed 20261123, 1000 runs): Singer, CAR and the
  TOM without clutter, the failure anatomy of each run.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ..scenarios.houles import houles_imm_trial, window_mse
from ._core import Experiment, register
from .tom_ladder import LadderConfig, _ladder_call

__all__: list[str] = []

GRID_SEED = 20261125  # spawns the grid seeds, the fresh seeds and the T9 sample
TABLE1_SEED = 20261123
_NB = "book/001-tom-imm/05-why-the-claim-fails.ipynb"
#: The declared run count of the T9 sample (001-05's "Choices we made").
T9_RUNS = 5000


def _on_stream(rng, stream, *args, **kwargs):
    """``houles_imm_trial`` on run ``i`` of stream ``stream`` of the store's seed: the
    generator's seed sequence (spawn key ``(i,)``) re-keyed to ``(stream, i)``."""
    if stream < 0:
        return houles_imm_trial(rng, *args, **kwargs)
    ss = rng.bit_generator.seed_seq
    if not isinstance(ss, np.random.SeedSequence) or len(ss.spawn_key) != 1:
        raise ValueError("a stream run needs the store's generator of run i "
                         "(SeedSequence(seed).spawn(n)[i])")
    child = np.random.SeedSequence(ss.entropy, spawn_key=(stream, *ss.spawn_key),
                                   pool_size=ss.pool_size)
    return houles_imm_trial(np.random.default_rng(child), *args, **kwargs)


@dataclass(frozen=True)
class StreamConfig(LadderConfig):
    """Filters (keys of :class:`~.tom_ladder.LadderConfig`) on the Houles scenario on
    stream ``stream`` of the seed (-1: the seed itself); ``pg``, ``clutter_density``
    (1/m^2) and ``pd`` as there."""

    stream: int = -1

    _KINDS = {**LadderConfig._KINDS, "stream": int}

    def __post_init__(self):
        super().__post_init__()
        if isinstance(self.stream, bool) or not isinstance(self.stream, int) \
                or self.stream < -1:
            raise ValueError(f"stream must be an int >= -1, got {self.stream!r}")


def _stream_call(config):
    args, kwargs = _ladder_call(config)
    return (config.stream, *args), kwargs


def _mse_extract(run, config):
    """Per filter: the window mean squares and the largest squared position error."""
    e = np.asarray(run.pos_err2, dtype=np.float64)
    return {"window_mse": window_mse(e), "max_err2": e.max(axis=-1)}


def tom_key(u, st, sc, p, heading="chord"):
    """The filter key of a TOM setting of the page's grids: (u, sigma_s turn, sigma_s
    centre, Markov diagonal) and the heading."""
    key = f"tom:u={float(u)!r},sigma_s_turn={float(st)!r},sigma_s_centre={float(sc)!r}"
    key += f",p_stay={float(p)!r}"
    return key if heading == "chord" else f"{key},heading={heading}"


def ref_key(cv, ct, p):
    """The filter key of a known-rate reference setting (CV noise, turn noise, p_ii)."""
    return f"ct:cv={float(cv)!r},ct={float(ct)!r},p_stay={float(p)!r}"


#: The grids of 001-05 (u, sigma_s turn, sigma_s centre, p_ii) and the reference's.
GRID = tuple(itertools.product([40.0, 55.0, 70.0], [10.0, 20.0, 30.0], [0.5, 1.0, 3.0],
                               [0.9, 0.95, 0.98]))
VGRID = tuple(itertools.product([40.0, 55.0, 70.0], [20.0, 30.0, 45.0], [0.5, 1.0, 3.0],
                                [0.95, 0.98]))
REF_GRID = tuple(itertools.product([0.25, 0.5, 1.0], [1.0, 2.0, 4.0, 8.0],
                                   [0.9, 0.95, 0.98]))
#: The points the page's searches score past the grids (in the order they score them).
CHORD_EXT = (
    (35.0, 20.0, 0.5, 0.95),
    (45.0, 20.0, 0.5, 0.95),
    (40.0, 15.0, 0.5, 0.95),
    (40.0, 20.0, 0.25, 0.95),
    (50.0, 20.0, 0.5, 0.95),
    (45.0, 15.0, 0.5, 0.95),
    (45.0, 30.0, 0.5, 0.95),
    (45.0, 20.0, 0.25, 0.95),
    (45.0, 20.0, 1.0, 0.95),
    (45.0, 20.0, 0.5, 0.9),
    (45.0, 20.0, 0.5, 0.98),
    (50.0, 20.0, 0.25, 0.95),
    (45.0, 15.0, 0.25, 0.95),
    (45.0, 30.0, 0.25, 0.95),
    (45.0, 20.0, 0.1, 0.95),
    (45.0, 20.0, 0.25, 0.9),
    (45.0, 20.0, 0.25, 0.98),
    (40.0, 15.0, 0.25, 0.95),
    (50.0, 15.0, 0.25, 0.95),
    (45.0, 10.0, 0.25, 0.95),
    (45.0, 15.0, 0.1, 0.95),
    (45.0, 15.0, 0.25, 0.9),
    (45.0, 15.0, 0.25, 0.98),
    (55.0, 15.0, 0.25, 0.95),
    (50.0, 10.0, 0.25, 0.95),
    (50.0, 15.0, 0.1, 0.95),
    (50.0, 15.0, 0.5, 0.95),
    (50.0, 15.0, 0.25, 0.9),
    (50.0, 15.0, 0.25, 0.98),
    (55.0, 10.0, 0.25, 0.95),
    (50.0, 7.0, 0.25, 0.95),
    (50.0, 10.0, 0.1, 0.95),
    (50.0, 10.0, 0.5, 0.95),
    (50.0, 10.0, 0.25, 0.9),
    (50.0, 10.0, 0.25, 0.98),
    (45.0, 10.0, 0.1, 0.95),
    (55.0, 10.0, 0.1, 0.95),
    (50.0, 7.0, 0.1, 0.95),
    (50.0, 10.0, 0.03, 0.95),
    (50.0, 10.0, 0.1, 0.9),
    (50.0, 10.0, 0.1, 0.98),
    (45.0, 10.0, 0.03, 0.95),
    (55.0, 10.0, 0.03, 0.95),
    (50.0, 7.0, 0.03, 0.95),
    (50.0, 15.0, 0.03, 0.95),
    (50.0, 10.0, 0.0, 0.95),
    (50.0, 10.0, 0.03, 0.9),
    (50.0, 10.0, 0.03, 0.98),
    (35.0, 20.0, 0.5, 0.9),
    (40.0, 15.0, 0.5, 0.9),
    (40.0, 20.0, 0.25, 0.9),
    (40.0, 20.0, 0.5, 0.85),
    (50.0, 20.0, 0.5, 0.9),
    (45.0, 15.0, 0.5, 0.9),
    (45.0, 30.0, 0.5, 0.9),
    (45.0, 20.0, 1.0, 0.9),
    (45.0, 20.0, 0.5, 0.85),
    (50.0, 15.0, 0.5, 0.9),
    (50.0, 30.0, 0.5, 0.9),
    (50.0, 20.0, 0.25, 0.9),
    (50.0, 20.0, 1.0, 0.9),
    (50.0, 20.0, 0.5, 0.85),
    (55.0, 20.0, 0.25, 0.9),
    (50.0, 30.0, 0.25, 0.9),
    (50.0, 20.0, 0.1, 0.9),
    (50.0, 20.0, 0.25, 0.85),
    (45.0, 20.0, 0.1, 0.9),
    (55.0, 20.0, 0.1, 0.9),
    (50.0, 15.0, 0.1, 0.9),
    (50.0, 30.0, 0.1, 0.9),
    (50.0, 20.0, 0.03, 0.9),
    (50.0, 20.0, 0.1, 0.85),
    (50.0, 20.0, 0.1, 0.95),
    (45.0, 20.0, 0.03, 0.9),
    (55.0, 20.0, 0.03, 0.9),
    (50.0, 15.0, 0.03, 0.9),
    (50.0, 30.0, 0.03, 0.9),
    (50.0, 20.0, 0.0, 0.9),
    (50.0, 20.0, 0.03, 0.85),
    (50.0, 20.0, 0.03, 0.95),
    (45.0, 20.0, 0.0, 0.9),
    (55.0, 20.0, 0.0, 0.9),
    (50.0, 15.0, 0.0, 0.9),
    (50.0, 30.0, 0.0, 0.9),
    (50.0, 20.0, 0.0, 0.85),
    (50.0, 20.0, 0.0, 0.95),
)
VEL_EXT = (
    (50.0, 30.0, 0.5, 0.98),
    (60.0, 30.0, 0.5, 0.98),
    (55.0, 30.0, 0.25, 0.98),
    (55.0, 30.0, 0.5, 0.99),
)
REF_EXT = (
    (0.1, 1.0, 0.98),
    (0.25, 0.5, 0.98),
    (0.25, 1.0, 0.99),
    (0.1, 0.5, 0.98),
    (0.5, 0.5, 0.98),
    (0.25, 0.25, 0.98),
    (0.25, 0.5, 0.95),
    (0.25, 0.5, 0.99),
    (0.1, 0.25, 0.98),
    (0.5, 0.25, 0.98),
    (0.25, 0.0, 0.98),
    (0.25, 0.25, 0.95),
    (0.25, 0.25, 0.99),
    (0.05, 0.25, 0.98),
    (0.1, 0.0, 0.98),
    (0.1, 0.25, 0.95),
    (0.1, 0.25, 0.99),
    (0.05, 0.0, 0.98),
    (0.1, 0.0, 0.95),
    (0.1, 0.0, 0.99),
    (0.0, 0.0, 0.98),
    (0.05, 0.0, 0.95),
    (0.05, 0.0, 0.99),
    (0.0, 0.25, 0.98),
    (0.0, 0.0, 0.95),
    (0.0, 0.0, 0.99),
)
LITERAL = ("singer", "tom", "tom:heading=chord_literal",
           "tom:u=100.0,heading=chord_literal")
GRID_FILTERS = (LITERAL + tuple(tom_key(*q) for q in GRID + CHORD_EXT)
                + tuple(tom_key(*q, heading="velocity") for q in VGRID + VEL_EXT)
                + tuple(ref_key(*q) for q in REF_GRID + REF_EXT))
#: The points the searches chose: best total (chord), best total (velocity heading),
#: best manoeuvring (chord).
BEST, VBEST, BEST_MAN = (50.0, 10.0, 0.0, 0.95), (55.0, 30.0, 0.5, 0.98), \
    (50.0, 20.0, 0.0, 0.9)
FRESH_FILTERS = ("singer", "car:5.0", "tom", tom_key(*BEST),
                 tom_key(*VBEST, heading="velocity"), tom_key(*BEST_MAN))


def _anatomy_extract(run, config):
    """Per filter: the largest and the last squared position error, the first time
    (s) the error exceeds 200 m (NaN: never) and the first time the target measurement
    fell outside every gate (inf: never)."""
    from ..scenarios._tom_book import anatomy_columns

    cols = anatomy_columns(np.asarray(run.pos_err2, dtype=np.float64),
                           np.asarray(run.target_gated))
    return {k: np.ascontiguousarray(v) for k, v in cols.items()}


#: name: (description, extract, config, seed, runs)
_EXPERIMENTS = {
    "tom-tuning-grid": (
        ("the grid seeds: Singer, the literal index, every point of the chord, "
         "velocity-heading and known-rate searches"), _mse_extract,
        StreamConfig(filters=GRID_FILTERS, pg=0.9999, stream=0), GRID_SEED, 200),
    "tom-tuning-fresh": (
        ("the fresh seeds: Singer, CAR, the chapter's TOM and the three points the "
         "searches chose, P_G = 0.9999"), _mse_extract,
        StreamConfig(filters=FRESH_FILTERS, pg=0.9999, stream=1), GRID_SEED, 1000),
    "tom-tuning-t9": (
        ("T9: Singer and the best-manoeuvring TOM at the run count declared from the "
         "fresh seeds' variance, P_G = 0.9999"), _mse_extract,
        StreamConfig(filters=("singer", tom_key(*BEST_MAN)), pg=0.9999, stream=2),
        GRID_SEED, T9_RUNS),
    "tom-cause-no-clutter": (
        ("where the TOM fails: Singer, CAR and the TOM on Table 1's seed without "
         "clutter, the failure anatomy"), _anatomy_extract,
        StreamConfig(filters=("singer", "car:5.0", "tom"), clutter_density=0.0),
        TABLE1_SEED, 1000),
}
for _name, (_what, _extract, _config, _seed, _runs) in _EXPERIMENTS.items():
    register(Experiment(
        name=_name, description=f"TOM-IMM chapter, {_what}", trial=_on_stream,
        call=_stream_call, extract=_extract, config=_config, seed=_seed, runs=_runs,
        version="1", notebook=_NB))
