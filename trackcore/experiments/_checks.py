"""Validation shared by the experiments' config records (each names its field)."""
from __future__ import annotations

import math

import numpy as np


def check_finite(value, name: str) -> None:
    """``value`` is a finite real number (not a bool), else ``ValueError`` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")


def check_names(value, name: str, allowed=None, item: str = "name", *,
                empty: bool = False) -> None:
    """``value`` is a tuple (non-empty unless ``empty``) of distinct entries, each one of
    ``allowed`` when given; errors name the field ``name`` and the entry ``item``."""
    if not isinstance(value, tuple) or (not value and not empty):
        kind = "a tuple" if empty else "a non-empty tuple"
        raise TypeError(f"{name} must be {kind}, got {value!r}")
    if allowed is not None:
        for v in value:
            if v not in allowed:
                raise ValueError(f"unknown {item} {v!r} in {name}; expected some of "
                                 f"{tuple(allowed)}")
    if len(set(value)) != len(value):
        raise ValueError(f"{name} must not repeat, got {value}")


def check_jitter(value) -> None:
    """A pixel jitter: a finite real number >= 0 (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) \
            or not math.isfinite(value) or value < 0:
        raise ValueError(f"jitter must be a finite number >= 0 (px), got {value!r}")
