"""Roofline of this machine: memory bandwidth and the cost of the elementary operations a
particle filter is made of (sin, cos, exp, atan2, sqrt, one normal draw), in numba."""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ._common import median_time


@nb.njit(cache=True)
def _triad(a, b, c, s):
    for i in range(a.shape[0]):
        a[i] = b[i] + s * c[i]


@nb.njit(cache=True)
def _apply(op, x, out):
    n = x.shape[0]
    if op == 0:
        for i in range(n):
            out[i] = math.sin(x[i])
    elif op == 1:
        for i in range(n):
            out[i] = math.cos(x[i])
    elif op == 2:
        for i in range(n):
            out[i] = math.exp(-x[i])
    elif op == 3:
        for i in range(n):
            out[i] = math.atan2(x[i], 1.0 + x[i])
    elif op == 4:
        for i in range(n):
            out[i] = math.sqrt(x[i])
    elif op == 5:
        for i in range(n):
            out[i] = math.log(1.0 + x[i])
    else:
        for i in range(n):
            out[i] = x[i] * 1.0000001 + 0.5


@nb.njit(cache=True)
def _normals(rng, out):
    for i in range(out.shape[0]):
        out[i] = rng.standard_normal()


OPS = ("sin", "cos", "exp", "atan2", "sqrt", "log", "fma")


def run() -> dict:
    n = 1 << 24  # 16 Mi doubles = 128 MiB per array: far beyond cache
    a = np.zeros(n)
    b = np.random.default_rng(0).random(n)
    c = np.random.default_rng(1).random(n)
    _triad(a, b, c, 0.5)
    t = median_time(lambda: _triad(a, b, c, 0.5), repeat=5)
    bandwidth = 3 * 8 * n / t / 1e9  # STREAM triad counts 3 arrays moved
    m = 1 << 20
    x = np.random.default_rng(2).random(m) * 3.0
    out = np.empty(m)
    ns = {}
    for k, name in enumerate(OPS):
        _apply(k, x, out)
        ns[name] = median_time(lambda: _apply(k, x, out), repeat=7) / m * 1e9
    rng = np.random.default_rng(3)
    _normals(rng, out)
    ns["normal_draw"] = median_time(lambda: _normals(rng, out), repeat=7) / m * 1e9
    return {"memory_bandwidth_GBps_triad_1core": bandwidth, "ns_per_op_1core": ns}


if __name__ == "__main__":
    import json
    print(json.dumps(run(), indent=1))
