"""Tests for trackcore.association.hpda (Kim & Song 2007, eqs 6-19)."""
import math

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st
from scipy import integrate, special, stats

from trackcore.association import (
    existence_predict, existence_update, hpda_betas, hpda_conditional_rank_probabilities,
    hpda_existence_delta, hpda_false_rank_probabilities, hpda_log_rank_probabilities,
    hpda_measurement_count_probability, hpda_mixture_loglik, hpda_rank_probabilities,
    hpda_rank_probabilities_printed, hpda_select, pa_bar, pa_bar_alternating, rank_gamma,
    rank_probability_q, simulate_existence_posterior, simulate_hpda_ranks)


def tau_of(pd, rho):
    return -(1 + rho) * math.log(pd)


# ---------------------------------------------------------------- closed forms
def test_q_is_beta_form_and_sums_to_one():
    for rho in (0.0, 1.0, 5.0, 10.0):
        for m in (1, 2, 3, 10, 57):
            q = rank_probability_q(np.arange(1, m + 1), m, rho)
            assert q.sum() == pytest.approx(1.0, abs=1e-12)
            c = 1 / (1 + rho)
            l = np.arange(1, m + 1)
            beta = c * special.comb(m - 1, l - 1) * special.beta(l - 1 + c, m - l + 1)
            np.testing.assert_allclose(q, beta, rtol=1e-10)


def test_q_table_values_from_spec():
    # spec section 3.3 formula column
    assert rank_probability_q(1, 2, 5) == pytest.approx(0.85714, abs=5e-6)
    assert rank_probability_q(3, 3, 5) == pytest.approx(0.07692, abs=5e-6)
    assert rank_probability_q(1, 10, 10) == pytest.approx(0.77795, abs=5e-6)
    assert rank_probability_q(10, 10, 5) == pytest.approx(1 / (10 + 9 * 5), rel=1e-12)


def test_gamma_and_pabar_match_printed_products_small_m():
    for rho in (5.0, 10.0):
        for l in range(1, 12):
            g = 1.0
            for j in range(1, l):
                g *= ((j - 1) * (1 + rho) + 1) / (j * (1 + rho))
            assert rank_gamma(l, rho) == pytest.approx(g, rel=1e-12)
        for m in range(1, 16):
            assert pa_bar(m, rho) == pytest.approx(pa_bar_alternating(m, rho), rel=1e-9)


def test_alternating_sum_cancels_at_m70():
    # erratum E12
    assert pa_bar_alternating(70, 5) > 5.0
    assert pa_bar(70, 5) == pytest.approx(0.45744, abs=1e-5)


def test_joint_probabilities_sum_to_pm():
    for (rho, pg, lv) in [(10, 1.0, 5.0), (5, 0.9, 1.0), (5, 0.99, 0.0043)]:
        tau = 2.0
        for m in range(1, 12):
            pt = hpda_rank_probabilities(m, rho, tau, pg, lv)
            pf = hpda_false_rank_probabilities(m, rho, tau, pg, lv)
            pm = hpda_measurement_count_probability(m, rho, tau, pg, lv)
            np.testing.assert_allclose(pt + pf, pm, rtol=1e-12)
            pd = math.exp(-tau / (1 + rho))
            mu = stats.poisson(lv).pmf
            assert pm == pytest.approx((1 - pd * pg) * mu(m) + pd * pg * mu(m - 1), rel=1e-12)
            assert pt.sum() == pytest.approx(pd * pg * mu(m - 1), rel=1e-12)


def test_spec_table_values():
    # spec 3.3: rho = 10, lambda V_G = 5, tau = 2, P_G = 1
    pt = hpda_rank_probabilities(3, 10, 2, 1, 5)
    np.testing.assert_allclose(pt, [6.1572e-2, 5.5974e-3, 3.0531e-3], rtol=1e-4)
    pr = hpda_rank_probabilities_printed(3, 10, 2, 1, 5)
    assert pr[2] == pytest.approx(3.7431e-3, rel=1e-4)          # E10: printed l = m is wrong
    np.testing.assert_allclose(pr[:2], pt[:2], rtol=1e-10)       # l < m printed is right
    assert hpda_rank_probabilities(1, 10, 2, 1, 5)[0] == pytest.approx(5.6178e-3, rel=1e-4)


def test_quadrature_of_printed_densities_matches_eq10():
    # eqs (7)-(9): integrate the four densities i-iv and compare with (10)
    rho, tau, pg, lv = 5.0, 2.0, 0.9, 5.0
    c = 1 / (1 + rho)
    pd, pfa = math.exp(-tau * c), math.exp(-tau)
    mu = stats.poisson(lv).pmf
    fact = math.factorial

    def dens(a, l, m):
        G = math.exp(-a) / pfa
        H = math.exp(-c * a) / pd
        tot = 0.0
        if l >= 2:
            tot += pd * pg * H * fact(m - 1) / (fact(l - 2) * fact(m - l)) * G ** (l - 2) * (1 - G) ** (m - l) * G * mu(m - 1)
        tot += ((1 - pd) * pg + (1 - pg)) * fact(m) / (fact(l - 1) * fact(m - l)) * G ** (l - 1) * (1 - G) ** (m - l) * G * mu(m)
        if l <= m - 1:
            tot += pd * pg * (1 - H) * fact(m - 1) / (fact(l - 1) * fact(m - l - 1)) * G ** (l - 1) * (1 - G) ** (m - l - 1) * G * mu(m - 1)
        return tot

    for m in (1, 2, 3, 5):
        pf = hpda_false_rank_probabilities(m, rho, tau, pg, lv)
        for l in range(1, m + 1):
            val, _ = integrate.quad(dens, tau, np.inf, args=(l, m), epsabs=1e-14, epsrel=1e-12)
            assert val == pytest.approx(pf[l - 1], rel=1e-8)


# ---------------------------------------------------------------- Monte Carlo
def test_monte_carlo_order_statistics_within_4_stderr():
    rng = np.random.default_rng(20070828)
    n = 400_000
    rho, tau, pg, lv = 10.0, 2.0, 0.9, 5.0
    counts = simulate_hpda_ranks(rng, n, rho, tau, pg, lv, 8)
    for m in range(1, 9):
        pt = hpda_rank_probabilities(m, rho, tau, pg, lv)
        for l in range(1, m + 1):
            k = counts[m, l]
            p = pt[l - 1]
            se = math.sqrt(p * (1 - p) / n)
            assert abs(k / n - p) < 4 * se + 1e-12, (m, l, k / n, p)
        pm = hpda_measurement_count_probability(m, rho, tau, pg, lv)
        se = math.sqrt(pm * (1 - pm) / n)
        assert abs(counts[m].sum() / n - pm) < 4 * se


def test_monte_carlo_rejects_printed_lm_branch():
    rng = np.random.default_rng(7)
    n = 400_000
    counts = simulate_hpda_ranks(rng, n, 10.0, 2.0, 1.0, 5.0, 3)
    for m in (1, 3):
        pr = hpda_rank_probabilities_printed(m, 10.0, 2.0, 1.0, 5.0)[m - 1]
        p = counts[m, m] / n
        se = math.sqrt(p * (1 - p) / n)
        assert abs(p - pr) > 6 * se
        # while the corrected branch agrees
        pc = hpda_rank_probabilities(m, 10.0, 2.0, 1.0, 5.0)[m - 1]
        assert abs(p - pc) < 4 * se


# ---------------------------------------------------------------- edge cases
def test_m_zero():
    assert hpda_rank_probabilities(0, 10, 2, 1, 5).shape == (0,)
    assert hpda_measurement_count_probability(0, 10, 2, 0.9, 5) == pytest.approx(
        (1 - math.exp(-2 / 11) * 0.9) * math.exp(-5))
    pt, pf = hpda_conditional_rank_probabilities(0, 10, 2, 1, 5)
    assert pt.shape == pf.shape == (0,)
    assert hpda_existence_delta(0, 0, 0.0, 10, 2, 0.99, 1e-3, 5) == pytest.approx(
        math.exp(-2 / 11) * 0.99)
    assert hpda_select([]) == -1
    assert hpda_betas([], [], [], 1.0).shape == (0,)


def test_stability_m_500():
    for lv in (1.0, 5.0, 50.0, 400.0):
        lpt, lpf, lpm = hpda_log_rank_probabilities(500, 5, 3, 0.99, lv)
        assert np.all(np.isfinite(lpt)) and np.all(np.isfinite(lpf)) and np.isfinite(lpm)
        pt = hpda_rank_probabilities(500, 5, 3, 0.99, lv)
        assert np.all(np.isfinite(pt)) and np.all(pt >= 0)
        ct, cf = hpda_conditional_rank_probabilities(500, 5, 3, 0.99, lv)
        np.testing.assert_allclose(ct + cf, 1.0, rtol=1e-12)
        np.testing.assert_allclose(np.log(ct), lpt - lpm, rtol=1e-9)
        # log-sum of the joint target probabilities equals log(P_D P_G mu_F(m-1))
        pd = math.exp(-3 / 6)
        assert special.logsumexp(lpt) == pytest.approx(
            math.log(pd * 0.99) + stats.poisson(lv).logpmf(499), rel=1e-10)


def test_no_clutter():
    pt, pf = hpda_conditional_rank_probabilities(1, 10, 1, 0.99, 0.0)
    assert pt[0] == pytest.approx(1.0) and pf[0] == pytest.approx(0.0)
    with pytest.raises(ValueError, match="probability 0"):
        hpda_conditional_rank_probabilities(2, 10, 1, 0.99, 0.0)
    assert hpda_rank_probabilities(2, 10, 1, 0.99, 0.0).tolist() == [0.0, 0.0]


@pytest.mark.parametrize("args,name", [
    ((-1, 10, 2, 1, 5), "m"), ((2.5, 10, 2, 1, 5), "m"), ((3, -1, 2, 1, 5), "snr"),
    ((3, 10, -2, 1, 5), "tau"), ((3, 10, 2, 1.2, 5), "pg"), ((3, 10, 2, 1, -5), "clutter_mean"),
    ((3, float("nan"), 2, 1, 5), "snr"), ((3, 10, 2, 1, float("nan")), "clutter_mean"),
])
def test_bad_input(args, name):
    with pytest.raises((ValueError, TypeError), match=name):
        hpda_rank_probabilities(*args)
    with pytest.raises((ValueError, TypeError), match=name):
        hpda_measurement_count_probability(*args)


def test_bad_input_other():
    with pytest.raises(TypeError, match="m"):
        hpda_rank_probabilities("3", 10, 2, 1, 5)
    with pytest.raises(ValueError, match="target_density"):
        hpda_betas([np.nan], [0.1], [0.1], 1.0)
    with pytest.raises(ValueError, match="p_target"):
        hpda_betas([1.0], [0.1, 0.2], [0.1], 1.0)
    with pytest.raises(ValueError, match="gate_volume"):
        hpda_betas([1.0], [0.1], [0.1], 0.0)
    with pytest.raises(ValueError, match="s must"):
        hpda_existence_delta(2, 3, 0.1, 10, 1, 0.99, 1e-3, 5)
    with pytest.raises(ValueError, match="delta"):
        existence_update(0.5, 1.5)
    with pytest.raises(ValueError, match="p_pred"):
        existence_update(1.5, 0.5)
    with pytest.raises(ValueError, match="l must"):
        rank_probability_q(4, 3, 5)


# ---------------------------------------------------------------- association & existence
def _example_a():
    pd, rho, pg = 0.9, 10.0, 0.99
    tau = tau_of(pd, rho)
    S = np.diag([70.0 ** 2, 0.0035 ** 2])
    g2 = stats.chi2.ppf(0.99, 2)
    vg = math.pi * g2 * math.sqrt(np.linalg.det(S))
    lam = 1.5 / vg
    offs = np.array([(2.7, 1.2), (0.1, -0.1), (-1.2, 1.5)])
    d2 = (offs ** 2).sum(axis=1)
    nd = np.exp(-0.5 * d2) / (2 * math.pi * math.sqrt(np.linalg.det(S)))
    return pd, rho, pg, tau, vg, lam, nd


def test_worked_example_a():
    pd, rho, pg, tau, vg, lam, nd = _example_a()
    assert vg == pytest.approx(7.0891, abs=1e-4)
    pt = hpda_rank_probabilities(3, rho, tau, pg, 1.5)
    pf = hpda_false_rank_probabilities(3, rho, tau, pg, 1.5)
    np.testing.assert_allclose(pt, [0.19611, 0.01783, 0.00972], atol=5e-6)
    np.testing.assert_allclose(pf, [0.04123, 0.21951, 0.22762], atol=5e-6)
    b = hpda_betas(nd / pg, pt, pf, vg)
    np.testing.assert_allclose(b, [0.2195, 0.2722, 0.0304], atol=5e-5)
    s = hpda_select(b)
    assert s == 1
    ppred = existence_predict(0.7, 0.98, 0.0)
    assert ppred == pytest.approx(0.686)
    d = hpda_existence_delta(3, s + 1, nd[s], rho, tau, pg, lam, vg)
    assert d == pytest.approx(-1.4031, abs=5e-5)
    assert existence_update(ppred, d) == pytest.approx(0.8400, abs=5e-5)
    d1 = hpda_existence_delta(3, 1, nd[0], rho, tau, pg, lam, vg)
    assert d1 == pytest.approx(0.5791, abs=5e-5)
    assert existence_update(ppred, d1) == pytest.approx(0.4791, abs=5e-5)
    # (19) equals direct Bayes with the selected rank (spec 4.2)
    ct, cf = hpda_conditional_rank_probabilities(3, rho, tau, pg, 1.5)
    pmv = hpda_measurement_count_probability(3, rho, tau, pg, 1.5)
    like_h = pt[s] * nd[s] / pg + pf[s] / vg
    like_nh = stats.poisson(1.5).pmf(3) / vg
    post = like_h * ppred / (like_h * ppred + like_nh * (1 - ppred))
    assert existence_update(ppred, d) == pytest.approx(post, rel=1e-12)


def test_worked_example_b():
    pd, rho, pg = 0.6, 5.0, 0.99
    tau = tau_of(pd, rho)
    S = np.diag([75.0 ** 2, 0.0025 ** 2])
    g2 = stats.chi2.ppf(0.99, 2)
    vg = math.pi * g2 * math.sqrt(np.linalg.det(S))
    lam = 50 / (math.pi * 1e8) * 5000.0
    assert vg == pytest.approx(5.425, abs=1e-3)
    nd = math.exp(-1.0) / (2 * math.pi * math.sqrt(np.linalg.det(S)))
    d_hit = hpda_existence_delta(1, 1, nd, rho, tau, pg, lam, vg)
    assert d_hit == pytest.approx(-234.85, abs=0.01)
    p = 0.5
    out = []
    for ev in ("hit", "hit", "miss", "miss", "miss"):
        pp = existence_predict(p, 0.98)
        d = d_hit if ev == "hit" else hpda_existence_delta(0, 0, 0, rho, tau, pg, lam, vg)
        p = existence_update(pp, d)
        out.append(p)
    np.testing.assert_allclose(out, [0.9956, 0.9999, 0.9519, 0.8494, 0.6685], atol=5e-5)


def test_mixture_loglik_matches_direct():
    rng = np.random.default_rng(3)
    X = np.column_stack([rng.normal(3000, 50, 200), rng.normal(4000, 50, 200),
                         np.zeros(200), np.zeros(200)])
    R = np.diag([50.0 ** 2, np.deg2rad(0.1) ** 2])
    z = np.array([5000.0, math.atan2(4000, 3000)])
    ll = hpda_mixture_loglik(X, z, R, 0.7, 0.3, 6.0)
    h = np.column_stack([np.hypot(X[:, 0], X[:, 1]), np.arctan2(X[:, 1], X[:, 0])])
    nd = stats.multivariate_normal(np.zeros(2), R).pdf(z - h)
    np.testing.assert_allclose(ll, np.log(nd * 0.7 + 0.3 / 6.0), rtol=1e-10)
    # far-away particles do not underflow: clutter floor
    X[:, 0] += 1e6
    ll = hpda_mixture_loglik(X, z, R, 0.7, 0.3, 6.0)
    np.testing.assert_allclose(ll, math.log(0.3 / 6.0), rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(m=st.integers(1, 60), rho=st.floats(0.0, 50.0), pd=st.floats(0.05, 0.99),
       pg=st.floats(0.5, 1.0), lv=st.floats(1e-3, 100.0))
@example(m=49, rho=0.0, pd=0.5, pg=1.0, lv=1.0)  # found by CI: flat ranks, rounding only
def test_property_conditional_probabilities(m, rho, pd, pg, lv):
    tau = tau_of(pd, rho) if rho > 0 else 0.5
    ct, cf = hpda_conditional_rank_probabilities(m, rho, tau, pg, lv)
    assert np.all(ct >= 0) and np.all(cf >= 0)
    np.testing.assert_allclose(ct + cf, 1.0, rtol=1e-10)
    # stronger ranks at least as likely to be the target, up to rounding: the log-gamma form
    # carries a relative error of order m * eps (5.7e-14 at m = 49 with rho = 0, where all
    # ranks are equally likely and the exact differences are zero)
    assert np.all(np.diff(ct) <= 1e-12 * ct.max())
    lpt, lpf, lpm = hpda_log_rank_probabilities(m, rho, tau, pg, lv)
    np.testing.assert_allclose(np.exp(lpt - lpm), ct, rtol=1e-8, atol=1e-300)


@settings(max_examples=40, deadline=None)
@given(p=st.floats(0.0, 1.0), d=st.floats(-1e4, 1.0))
def test_property_existence_update_in_unit_interval(p, d):
    v = existence_update(p, d)
    assert 0.0 <= v <= 1.0
    if d <= 0 and p > 0:
        assert v >= p - 1e-12


def test_existence_recursion_matches_monte_carlo():
    g2 = 9.21
    pg = 1 - math.exp(-g2 / 2)
    rho, pd, lv = 10.0, 0.9, 1.5
    tau = tau_of(pd, rho)
    vg = math.pi * g2
    ne, nh = simulate_existence_posterior(np.random.default_rng(5), 2_000_000, 2, 1, (1.0, 0.5),
                                          0.3, rho, tau, g2, lv, 0.5)
    ph = nh / ne
    se = math.sqrt(ph * (1 - ph) / ne)
    nd = math.exp(-0.5 * 1.25) / (2 * math.pi)
    post = existence_update(0.5, hpda_existence_delta(2, 1, nd, rho, tau, pg, lv / vg, vg))
    assert ne > 5000 and abs(ph - post) < 4 * se
    with pytest.raises(ValueError, match="s must"):
        simulate_existence_posterior(np.random.default_rng(), 10, 1, 2, (0, 0), 0.3, 10, 1, 9, 1, .5)
