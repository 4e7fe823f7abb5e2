"""HPDA-PF's faster inner-loop kernels compute the same bits as the general ones (issue 24):
the division-free angle wrap (``_wrap_near``) where the kernels use it, and the EKF moments
without a reshape.  Whole tracker runs are checked against the stored rows by
``python -m trackcore.experiments verify`` (and tests/test_hpda_ipda.py checks the
inlined inner-loop kernels against the general ones)."""
import math

import numpy as np
import pytest

from trackcore.association.hpda import _mixture_loglik_polar, _wrap_near
from trackcore.models.measurement import (range_bearing_jacobian_kernel, range_bearing_kernel,
                                          wrap_angle_kernel)
from trackcore.trackers.hpda_pf import _ekf_moments, _ipda_log_term, _particle_moments_polar


def _bits(x):
    return np.float64(x).tobytes()


EDGES = [0.0, -0.0, 3.0, -3.0, math.nextafter(3.0, 4.0), math.nextafter(-3.0, -4.0),
         math.pi, -math.pi, math.nextafter(-math.pi, 0.0), math.nextafter(math.pi, 4.0),
         2.0 * math.pi, -2.0 * math.pi, 1e-300, -1e-300, 5e-324, 7.0, -7.0, 1e6, -1e6,
         math.inf, -math.inf, math.nan]


@pytest.mark.parametrize("a", EDGES)
def test_wrap_near_edges_bitwise(a):
    assert _bits(_wrap_near(a)) == _bits(wrap_angle_kernel(a)), a


def test_wrap_near_random_bitwise():
    rng = np.random.default_rng(24)
    xs = np.concatenate([rng.uniform(-3.2, 3.2, 20000), rng.uniform(-20.0, 20.0, 20000),
                         rng.normal(0.0, 1e-3, 5000)])
    for a in xs:
        assert _bits(_wrap_near(a)) == _bits(wrap_angle_kernel(a)), a


def _old_mixture(rng_i, brg_i, z, Rinv, c, log_pt, log_pf_vg):
    """``_mixture_loglik_polar`` as it was, with the general wrap (plain Python)."""
    r0 = z[0] - rng_i
    r1 = wrap_angle_kernel(z[1] - brg_i)
    ll = c - 0.5 * (Rinv[0, 0] * r0 * r0 + 2.0 * Rinv[0, 1] * r0 * r1 + Rinv[1, 1] * r1 * r1)
    if math.isnan(ll):
        ll = -math.inf
    u = ll + log_pt
    hi = max(u, log_pf_vg)
    if hi == -math.inf:
        return -math.inf
    lo = u if hi == log_pf_vg else log_pf_vg
    return hi + math.log(1.0 + math.exp(lo - hi))


def test_mixture_and_ipda_terms_bitwise():
    rng = np.random.default_rng(7)
    R = np.diag([150.0 ** 2, math.radians(3.0) ** 2])
    Rinv = np.linalg.inv(R)
    for _ in range(2000):
        z = np.array([rng.uniform(100.0, 20000.0), rng.uniform(-math.pi, math.pi)])
        r, b = z[0] + rng.normal(0, 300.0), z[1] + rng.normal(0, 0.3) * rng.choice([1, 20])
        args = (r, b, z, Rinv, -12.3, math.log(0.3), math.log(1e-9))
        assert _bits(_mixture_loglik_polar(*args)) == _bits(_old_mixture(*args))
        Zs = z.reshape(1, 2)
        got = _ipda_log_term(Zs, 0, r, b, Rinv, -1.5)
        r1 = wrap_angle_kernel(z[1] - b)
        r0 = z[0] - r
        want = -1.5 - 0.5 * (Rinv[0, 0] * r0 * r0 + 2.0 * Rinv[0, 1] * r0 * r1
                             + Rinv[1, 1] * r1 * r1)
        assert _bits(got) == _bits(want)


@pytest.mark.parametrize("seed", range(10))
def test_particle_moments_polar_bitwise(seed):
    rng = np.random.default_rng(seed)
    N = 500
    # a cloud straddling the -pi/pi seam for odd seeds
    b0 = math.pi - 0.01 if seed % 2 else rng.uniform(-3.0, 3.0)
    r = rng.uniform(3000.0, 9000.0)
    X = np.zeros((N, 4))
    X[:, 0] = r * np.cos(b0) + rng.normal(0, 200.0, N)
    X[:, 1] = r * np.sin(b0) + rng.normal(0, 200.0, N)
    R = np.diag([150.0 ** 2, math.radians(3.0) ** 2])
    zhat, S = np.zeros(2), np.zeros((2, 2))
    rg, br, rel = np.zeros(N), np.zeros(N), np.zeros(N)
    _particle_moments_polar(X, zhat, S, R, rg, br, rel)
    ref = math.atan2(X[0, 1], X[0, 0])
    want_rel = np.array([wrap_angle_kernel(math.atan2(X[i, 1], X[i, 0]) - ref)
                         for i in range(N)])
    assert rel.tobytes() == want_rel.tobytes()
    sr = sb = 0.0
    for i in range(N):
        sr += math.sqrt(X[i, 0] * X[i, 0] + X[i, 1] * X[i, 1])
        sb += want_rel[i]
    assert _bits(zhat[0]) == _bits(sr / N)
    assert _bits(zhat[1]) == _bits(wrap_angle_kernel(ref + sb / N))


@pytest.mark.parametrize("seed", range(20))
def test_ekf_moments_bitwise(seed):
    rng = np.random.default_rng(seed)
    X1 = np.array([[rng.normal(0, 5000.0), rng.normal(0, 5000.0), rng.normal(0, 20.0),
                    rng.normal(0, 20.0)]])
    if seed == 0:
        X1[0, 1] = -0.0
    A = rng.normal(size=(4, 4))
    P = A @ A.T * 100.0 + np.eye(4)
    R = np.diag([150.0 ** 2, math.radians(3.0) ** 2])
    zhat, S, H3 = np.zeros(2), np.zeros((2, 2)), np.zeros((1, 2, 4))
    _ekf_moments(X1, P, R, zhat, S, H3)
    zw, Hw = np.zeros((1, 2)), np.zeros((1, 2, 4))
    range_bearing_kernel(X1, 0.0, 0.0, zw)
    range_bearing_jacobian_kernel(X1, 0.0, 0.0, Hw)
    assert zhat.tobytes() == zw[0].tobytes()
    assert H3.tobytes() == Hw.tobytes()
    H = Hw[0]
    Sw = np.zeros((2, 2))
    for a in range(2):
        for b in range(2):
            s = R[a, b]
            for c in range(2):
                for d in range(2):
                    s += H[a, c] * P[c, d] * H[b, d]
            Sw[a, b] = s
    assert S.tobytes() == Sw.tobytes()
