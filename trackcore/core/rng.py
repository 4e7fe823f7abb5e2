"""Random-number plumbing: explicit generators and reproducible spawning.

Randomness enters trackcore only through an explicit ``numpy.random.Generator``.
Monte Carlo run ``i`` of ``n`` with master seed ``seed`` always receives
``SeedSequence(seed).spawn(n)[i]``, so results do not depend on how runs are
scheduled.  numba kernels accept a ``Generator`` argument directly.
"""
from __future__ import annotations

import numbers

import numpy as np

from .validation import as_count, as_int

__all__ = ["spawn_seed_sequences", "spawn_generators", "generator_for_run", "make_rng"]


def _seed_sequence(seed) -> np.random.SeedSequence:
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise TypeError(f"seed must be a non-negative integer or SeedSequence, got {type(seed).__name__}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    return np.random.SeedSequence(int(seed))


def spawn_seed_sequences(seed, n):
    """The ``n`` child seed sequences of ``SeedSequence(seed)``.

    Examples
    --------
    >>> from trackcore.core import spawn_seed_sequences
    >>> children = spawn_seed_sequences(2024, 3)
    >>> len(children), children[1].spawn_key
    (3, (1,))
    """
    n = as_count(n, "n")
    return _seed_sequence(seed).spawn(n)


def spawn_generators(seed, n):
    """``n`` independent generators: ``default_rng(SeedSequence(seed).spawn(n)[i])``.

    Examples
    --------
    >>> from trackcore.core import spawn_generators
    >>> rngs = spawn_generators(2024, 3)
    >>> [round(float(r.random()), 4) for r in rngs]
    [0.6506, 0.1238, 0.9212]
    """
    return [np.random.default_rng(s) for s in spawn_seed_sequences(seed, n)]


def generator_for_run(seed, i, n):
    """The generator Monte Carlo run ``i`` of ``n`` gets (same as
    ``spawn_generators(seed, n)[i]``).

    Examples
    --------
    >>> from trackcore.core import generator_for_run, spawn_generators
    >>> a = generator_for_run(2024, 2, 3).random()
    >>> b = spawn_generators(2024, 3)[2].random()
    >>> bool(a == b)
    True
    """
    n = as_count(n, "n")
    i = as_int(i, "i")
    if not (0 <= i < n):
        raise ValueError(f"i must be in [0, {n}), got {i}")
    ss = _seed_sequence(seed)
    if ss is seed:  # a caller's SeedSequence: spawn from it, as spawn_generators does
        return np.random.default_rng(ss.spawn(n)[i])
    # SeedSequence(seed).spawn(n)[i] without building the n - 1 other children
    return np.random.default_rng(np.random.SeedSequence(ss.entropy, spawn_key=(i,)))


def make_rng(seed):
    """A ``Generator`` from an int/SeedSequence seed (a Generator is returned as is).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import make_rng
    >>> rng = make_rng(7)
    >>> round(float(rng.random()), 4) == round(float(make_rng(7).random()), 4)
    True
    >>> make_rng(rng) is rng
    True
    """
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(_seed_sequence(seed))
