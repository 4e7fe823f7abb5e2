"""Presentation helpers of the SPRT chapter (book/002-sprt-acm), so that the
notebooks show the checks and experiments and not the bookkeeping.

This module is private (its name starts with an underscore): it is not re-exported by
``trackcore.scenarios`` and is not part of the public API. Nothing here computes a
result of the book; the notebooks use these helpers to check the public functions of
``trackcore`` against independent routes.
"""

from __future__ import annotations

import numpy as np

__all__: list[str] = []  # private: nothing is re-exported


def central_jacobian(f, x, steps) -> np.ndarray:
    """Jacobian of ``f`` at ``x`` by central differences, column ``j`` with step
    ``steps[j]``: ``(f(x + h e_j) - f(x - h e_j)) / (2 h)``.

    ``f`` maps a 1-D array to a 1-D array; ``steps`` has one positive step per entry
    of ``x``.
    """
    x = np.asarray(x, dtype=float)
    steps = np.asarray(steps, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"x must be a 1-D array, got shape {x.shape}")
    if steps.shape != x.shape or not np.all(steps > 0):
        raise ValueError(f"steps must be {x.size} positive numbers, got {steps}")
    cols = []
    for j, h in enumerate(steps):
        e = np.zeros(x.size)
        e[j] = h
        cols.append((np.asarray(f(x + e)) - np.asarray(f(x - e))) / (2 * h))
    return np.stack(cols, axis=-1)
