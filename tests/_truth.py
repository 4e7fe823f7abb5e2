"""Shared test helper: noise-free truth trajectories."""
import numpy as np

from trackcore.models import cv_transition


def straight_track(K, x0, T=1.0):
    """K states of a 3-D constant-velocity target [x, y, z, vx, vy, vz] from x0."""
    F = cv_transition(T, dim=3)
    xs = [np.array(x0, float)]
    for _ in range(K - 1):
        xs.append(F @ xs[-1])
    return np.array(xs)
