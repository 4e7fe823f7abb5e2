"""HPDA's existence update is the IPDA update when the gate holds one measurement, and the
HPDA-PF tracker's specialised inner-loop kernels equal the general ones of trackcore."""
import math

import numpy as np
import pytest
from scipy import stats

from trackcore.association import (existence_predict, existence_update, hpda_existence_delta,
                                   pda_update)
from trackcore.filters import kf_predict
from trackcore.models import range_bearing, range_bearing_jacobian
from trackcore.models.measurement import wrap_angle
from trackcore.scenarios import hpda_parameters, hpda_truth, simulate_hpda_scans
from trackcore.trackers import HpdaPfConfig, hpda_pf_run
from trackcore.trackers.hpda_pf import _cv_predict, _gate_and_select, _pda1_update


def ipda_posterior(p_prev, pi11, pd, pg, lam, likelihoods):
    """Integrated PDA (Musicki, Evans & Stankovic 1994), parametric clutter density
    ``lam``: ``delta = P_D P_G (1 - sum_i p_i / lam)`` with the gate-truncated
    likelihoods ``p_i = N(z_i; z_hat, S) / P_G``; posterior
    ``(1 - delta) P^- / (1 - delta P^-)``."""
    p_pred = pi11 * p_prev
    p = np.asarray(likelihoods, dtype=float) / pg
    delta = pd * pg * (1.0 - p.sum() / lam)
    return (1.0 - delta) * p_pred / (1.0 - delta * p_pred)


@pytest.mark.parametrize("seed", range(20))
def test_existence_update_with_one_measurement_is_ipda(seed):
    rng = np.random.default_rng(seed)
    snr = rng.uniform(0.5, 20)
    pd = rng.uniform(0.3, 0.99)
    tau = -(1 + snr) * math.log(pd)
    pg = rng.uniform(0.8, 0.999)
    S = np.diag(rng.uniform(10, 100, 2) ** 2)
    S[0, 1] = S[1, 0] = 0.3 * math.sqrt(S[0, 0] * S[1, 1])
    g2 = stats.chi2.ppf(pg, 2)
    vg = math.pi * g2 * math.sqrt(np.linalg.det(S))
    lam = rng.uniform(0.01, 3.0) / vg
    nu = rng.normal(size=2) * np.sqrt(np.diag(S)) * 0.8
    nd = stats.multivariate_normal(np.zeros(2), S).pdf(nu)
    p_prev, pi11 = rng.uniform(0.01, 0.99), rng.uniform(0.9, 1.0)
    delta = hpda_existence_delta(1, 1, nd, snr, tau, pg, lam, vg)
    ours = existence_update(existence_predict(p_prev, pi11), delta)
    ref = ipda_posterior(p_prev, pi11, pd, pg, lam, [nd])
    assert ours == pytest.approx(ref, rel=1e-12, abs=1e-15)
    # and with no measurement, both give the miss update delta = P_D P_G
    miss = existence_update(existence_predict(p_prev, pi11),
                            hpda_existence_delta(0, 0, 0.0, snr, tau, pg, lam, vg))
    assert miss == pytest.approx(ipda_posterior(p_prev, pi11, pd, pg, lam, []), rel=1e-12)


def test_existence_chain_of_hits_and_misses_is_ipda():
    rng = np.random.default_rng(1)
    snr, pd, pg, pi11 = 5.0, 0.6, 0.99, 0.99
    tau = -(1 + snr) * math.log(pd)
    vg, lam = 5.4, 8e-4
    p_h = p_i = 0.01
    for _ in range(200):
        if rng.random() < 0.6:
            nd = math.exp(-0.5 * rng.chisquare(2)) / (2 * math.pi * vg / (math.pi * 9.21))
            p_h = existence_update(existence_predict(p_h, pi11),
                                   hpda_existence_delta(1, 1, nd, snr, tau, pg, lam, vg))
            p_i = ipda_posterior(p_i, pi11, pd, pg, lam, [nd])
        else:
            p_h = existence_update(existence_predict(p_h, pi11),
                                   hpda_existence_delta(0, 0, 0.0, snr, tau, pg, lam, vg))
            p_i = ipda_posterior(p_i, pi11, pd, pg, lam, [])
        assert p_h == pytest.approx(p_i, rel=1e-12, abs=1e-15)


def test_tracker_rules_coincide_when_no_gate_holds_two_returns():
    # no clutter: every gate holds at most one return, so eq (15), the strongest and
    # the nearest neighbour pick the same measurement and the runs are identical
    from dataclasses import replace
    p = replace(hpda_parameters(1), clutter_mean=0.0)
    truth = hpda_truth(n_scans=120)
    s = simulate_hpda_scans(truth, p, np.random.default_rng(0))
    runs = {}
    for rule in ("hpda", "nearest", "strongest"):
        cfg = HpdaPfConfig(pd=p.pd, snr=p.snr, clutter_density_xy=1e-9, n_particles=100,
                           selection=rule)
        runs[rule] = hpda_pf_run(s.z, s.amplitude, s.offsets, cfg, np.random.default_rng(4))
    d = runs["hpda"].diagnostics
    assert d[0, 0] > 50 and d[0, 2] == 0 and d[1, 2] == 0
    for rule in ("nearest", "strongest"):
        np.testing.assert_array_equal(runs[rule].count, runs["hpda"].count)
        np.testing.assert_array_equal(runs[rule].estimates, runs["hpda"].estimates)


def test_selection_diagnostics_are_consistent():
    p = hpda_parameters(3)
    truth = hpda_truth(n_scans=40)
    s = simulate_hpda_scans(truth, p, np.random.default_rng(2))
    cfg = HpdaPfConfig(pd=p.pd, snr=p.snr, clutter_density_xy=p.clutter_density_xy,
                       sigma_r=p.sigma_r, sigma_theta=p.sigma_theta, n_particles=100)
    d = hpda_pf_run(s.z, s.amplitude, s.offsets, cfg, np.random.default_rng(3)).diagnostics
    assert d.shape == (2, 7)
    for row in d:
        assert row[0] >= row[1] >= row[2] >= max(row[3], row[4]) >= 0
    # dense clutter: the tentative tracks see several returns, and eq (15) departs from NN
    assert d[1, 2] > 0 and d[1, 3] > 0 and d[1, 5] / d[1, 0] > 0.5


def test_cv_predict_equals_kalman_predict():
    rng = np.random.default_rng(0)
    T = 10.0
    G = np.array([[T * T / 2, 0], [0, T * T / 2], [T, 0], [0, T]])
    Q = 0.01 ** 2 * G @ G.T
    F = np.array([[1, 0, T, 0], [0, 1, 0, T], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    for _ in range(50):
        x = rng.normal(size=4) * 1000
        A = rng.normal(size=(4, 4))
        P = A @ A.T + np.eye(4)
        xo, Po = np.zeros(4), np.zeros((4, 4))
        _cv_predict(x, P, T, Q, xo, Po)
        ref = kf_predict(x, P, F, Q)
        np.testing.assert_allclose(xo, ref[0], rtol=1e-13, atol=1e-9)
        np.testing.assert_allclose(Po, ref[1], rtol=1e-12, atol=1e-9)


def test_single_measurement_pda_equals_pda_update():
    rng = np.random.default_rng(1)
    R = np.diag([50.0 ** 2, np.radians(0.1) ** 2])
    for _ in range(100):
        x = rng.normal([3000, -2000, 1, -1], [3000, 3000, 2, 2])
        A = rng.normal(size=(4, 4))
        P = A @ A.T * 100 + np.eye(4)
        zh = range_bearing(x[None])[0]
        H = range_bearing_jacobian(x[None])[0]
        z = zh + rng.normal(size=2) * [60, 0.003]
        z[1] = wrap_angle(z[1])
        beta = rng.uniform()
        xo, Po = np.zeros(4), np.zeros((4, 4))
        _pda1_update(x, P, z, zh, H, R, beta, xo, Po, np.zeros((4, 2)), np.zeros((4, 4)),
                     np.zeros((4, 4)))
        ref = pda_update(x, P, z[None], zh, H, R, np.array([beta]), 1 - beta, angle_index=1)
        np.testing.assert_allclose(xo, ref.x, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(Po, ref.P, rtol=1e-10, atol=1e-9 * np.abs(ref.P).max())


def test_bearing_window_gate_equals_brute_force():
    rng = np.random.default_rng(0)
    for _ in range(3000):
        m = int(rng.integers(0, 40))
        Z = np.column_stack([rng.uniform(100, 10000, m), rng.uniform(-np.pi, np.pi, m)])
        A = rng.exponential(3, m)
        zh = np.array([rng.uniform(100, 10000), rng.uniform(-np.pi, np.pi)])
        sr, sb, rho = rng.uniform(10, 3000), rng.uniform(1e-4, 1.5), rng.uniform(-0.99, 0.99)
        S = np.array([[sr * sr, rho * sr * sb], [rho * sr * sb, sb * sb]])
        k = min(m, 5)
        if k:   # some returns inside the gate, some across the +-pi cut
            L = np.linalg.cholesky(S)
            Z[:k] = zh + (L @ rng.standard_normal((2, k))).T * 1.5
            Z[:k, 1] = wrap_angle(Z[:k, 1])
        border = np.argsort(Z[:, 1])
        bs = np.ascontiguousarray(Z[border, 1])
        buf = [np.zeros(max(m, 1), np.int64)] + [np.zeros(max(m, 1)) for _ in range(4)]
        out = _gate_and_select(Z, A, border, bs, zh, S, 9.21, 0.9, 0.99, 1 / 11, 1e-7, 0, *buf,
                               np.full(m + 1, -1.0))
        nu = Z - zh
        nu[:, 1] = wrap_angle(nu[:, 1])
        d2 = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(S), nu)
        val = np.nonzero(d2 <= 9.21)[0]
        val = val[np.argsort(-A[val])]
        assert out[0] == len(val)
        np.testing.assert_array_equal(buf[0][:out[0]], val)
