"""Tests for trackcore.detection.marcum (Marcum Q1, P_D of a square-law detector).

Reference: mpmath is not installed in the book's environment, so the high-precision
reference is an independent 50-digit evaluation with Python's ``decimal`` module of the
Poisson-mixture form Q1 = sum_n Pois(n; a^2/2) P(Pois(b^2/2) <= n) and of its
complement sum_n Pois(n; a^2/2) P(Pois(b^2/2) > n) (exact rational recurrences, no logs,
no truncation heuristics shared with the kernel).  The mixture form itself is checked
against adaptive quadrature of the Rician integral and against scipy.stats.ncx2.sf.
"""
from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, special
from scipy.stats import ncx2

from trackcore.detection import (
    log_marcum_detection_probability,
    log_marcum_miss_probability,
    log_marcum_q1,
    log_marcum_q1_complement,
    marcum_detection_probability,
    marcum_miss_probability,
    marcum_q1,
    marcum_q1_complement,
    rician_log_likelihood_ratio,
    square_law_threshold,
    swerling1_detection_probability,
    swerling1_miss_probability,
)
from trackcore.detection.marcum import log_marcum_q1_pair_kernel


# ----------------------------------------------------------------------------- reference
def decimal_reference(lam: float, mu: float, digits: int = 50):
    """(Q1, 1 - Q1) at ``lam = a^2/2``, ``mu = b^2/2`` to ~``digits - 10`` digits."""
    with localcontext() as ctx:
        ctx.prec = digits
        L = Decimal(lam)
        M = Decimal(mu)
        n_max = int(lam + mu + 30.0 * (lam + mu) ** 0.5 + 200)
        # p_mu(i) for i = 0..n_max+1 and the upper tails P(Pois(mu) > i)
        pm = [(-M).exp()]
        for i in range(1, n_max + 2):
            pm.append(pm[-1] * M / i)
        upper = [Decimal(0)] * (n_max + 2)
        acc = Decimal(0)
        for i in range(n_max + 1, -1, -1):
            upper[i] = acc
            acc += pm[i]
        # the part of P(Pois(mu) > n_max + 1) not in the list is < 1e-60 for these n_max
        q = Decimal(0)
        qc = Decimal(0)
        cdf = Decimal(0)
        pl = (-L).exp()
        for n in range(n_max + 1):
            cdf += pm[n]
            q += pl * cdf
            qc += pl * upper[n]
            pl = pl * L / (n + 1)
        return float(q), float(qc)


SNR_DB = np.arange(-5.0, 25.01, 1.0)
PFA = np.array([1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8])


@pytest.fixture(scope="module")
def reference_grid():
    rows = []
    for db in SNR_DB:
        snr = 10.0 ** (db / 10.0)
        for pfa in PFA:
            q, qc = decimal_reference(snr, -np.log(pfa))
            rows.append((snr, pfa, q, qc))
    return np.array(rows)


# ----------------------------------------------------------------------------- accuracy
def test_pd_matches_high_precision_reference(reference_grid):
    snr, pfa, q, qc = reference_grid.T
    pd = marcum_detection_probability(snr, pfa)
    pm = marcum_miss_probability(snr, pfa)
    assert np.max(np.abs(pd / q - 1.0)) < 1e-9
    assert np.max(np.abs(pm / qc - 1.0)) < 1e-9
    # the log forms carry the same information (relative error -> absolute in log)
    assert np.max(np.abs(log_marcum_detection_probability(snr, pfa) - np.log(q))) < 1e-9
    assert np.max(np.abs(log_marcum_miss_probability(snr, pfa) - np.log(qc))) < 1e-9


def test_marcum_q1_matches_reference_with_a_b(reference_grid):
    snr, pfa, q, qc = reference_grid.T
    a = np.sqrt(2.0 * snr)
    b = np.sqrt(-2.0 * np.log(pfa))
    assert np.max(np.abs(marcum_q1(a, b) / q - 1.0)) < 1e-9
    assert np.max(np.abs(marcum_q1_complement(a, b) / qc - 1.0)) < 1e-9


def test_tabulated_sample_values():
    # the usual P_D table of a square-law detector at P_fa = 1e-6
    pd = marcum_detection_probability(10.0 ** (np.array([5.0, 10.0, 13.0, 15.0]) / 10.0), 1e-6)
    np.testing.assert_allclose(pd, [4.585e-3, 0.24805, 0.87444, 0.997225], rtol=2e-4)
    miss = marcum_miss_probability(100.0, 1e-6)
    assert abs(miss / 1.92e-19 - 1.0) < 0.01
    assert 1.0 - marcum_detection_probability(100.0, 1e-6) == 0.0  # why the complement is needed


def _rician_tail(a, b):
    f = lambda x: x * np.exp(-0.5 * (x - a) ** 2) * special.i0e(a * x)
    return integrate.quad(f, b, np.inf, epsabs=0.0, epsrel=1e-13, limit=200)[0]


def _rician_head(a, b):
    f = lambda x: x * np.exp(-0.5 * (x - a) ** 2) * special.i0e(a * x)
    return integrate.quad(f, 0.0, b, epsabs=0.0, epsrel=1e-13, limit=200)[0]


@pytest.mark.parametrize("a,b", [(0.5, 3.0), (2.0, 5.26), (4.0, 3.0), (14.1, 5.26),
                                 (25.0, 6.07), (1.0, 0.2), (8.0, 1.0)])
def test_against_quadrature_of_the_definition(a, b):
    assert abs(marcum_q1(a, b) / _rician_tail(a, b) - 1.0) < 1e-10
    assert abs(marcum_q1_complement(a, b) / _rician_head(a, b) - 1.0) < 1e-10


def test_against_scipy_ncx2():
    snr = 10.0 ** (np.linspace(-5.0, 25.0, 61) / 10.0)
    for pfa in PFA:
        tau = -np.log(pfa)
        want = ncx2.sf(2.0 * tau, 2, 2.0 * snr)
        ok = want > 1e-300
        np.testing.assert_allclose(marcum_detection_probability(snr, pfa)[ok], want[ok], rtol=1e-9)
        head = ncx2.cdf(2.0 * tau, 2, 2.0 * snr)
        use = head > 1e-12  # ncx2.cdf loses relative accuracy below that, the kernel does not
        np.testing.assert_allclose(marcum_miss_probability(snr, pfa)[use], head[use], rtol=1e-9)


def test_special_values():
    for pfa in PFA:
        assert marcum_detection_probability(0.0, pfa) == pytest.approx(pfa, rel=1e-14)
        assert marcum_miss_probability(0.0, pfa) == pytest.approx(1.0 - pfa, rel=1e-14)
    assert marcum_q1(0.0, 0.0) == 1.0
    assert marcum_q1(3.0, 0.0) == 1.0
    assert marcum_q1_complement(3.0, 0.0) == 0.0
    assert log_marcum_q1_complement(3.0, 0.0) == -np.inf
    assert marcum_q1(0.0, 2.0) == pytest.approx(np.exp(-2.0), rel=1e-15)
    # deep tails stay finite in log space
    assert log_marcum_q1(0.0, 50.0) == pytest.approx(-1250.0, rel=1e-14)
    assert log_marcum_q1_complement(40.0, 1.0) < -700.0
    assert np.isfinite(log_marcum_q1_complement(40.0, 1.0))
    lq, lqc = log_marcum_q1_pair_kernel(3.0, 4.0)
    assert np.exp(lq) + np.exp(lqc) == pytest.approx(1.0, abs=1e-15)


def test_shapes_and_scalars():
    assert isinstance(marcum_q1(1.0, 2.0), float)
    assert isinstance(marcum_detection_probability(3.0, 1e-6), float)
    out = marcum_q1(np.ones((2, 3)), np.array([1.0, 2.0, 3.0]))
    assert out.shape == (2, 3)
    assert marcum_detection_probability(np.zeros(0), 1e-6).shape == (0,)
    both = marcum_detection_probability(np.array([1.0, 2.0]), np.array([1e-6, 1e-3]))
    np.testing.assert_allclose(both, [marcum_detection_probability(1.0, 1e-6),
                                      marcum_detection_probability(2.0, 1e-3)], rtol=1e-14)


@settings(max_examples=60, deadline=None)
@given(st.floats(0.0, 30.0), st.floats(0.0, 30.0))
def test_q_plus_complement_is_one(a, b):
    assert marcum_q1(a, b) + marcum_q1_complement(a, b) == pytest.approx(1.0, abs=1e-13)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 20.0), st.floats(0.01, 10.0), st.floats(0.01, 2.0))
def test_monotone(a, b, d):
    assert marcum_q1(a + d, b) >= marcum_q1(a, b) * (1.0 - 1e-13)
    assert marcum_q1(a, b + d) <= marcum_q1(a, b) * (1.0 + 1e-13)


# ----------------------------------------------------------------------------- Swerling I
def test_swerling1_closed_form_by_quadrature():
    for S in (0.5, 3.0, 10.0, 50.0):
        for pfa in (1e-2, 1e-6):
            f = lambda s: marcum_detection_probability(s, pfa) * np.exp(-s / S) / S
            val = integrate.quad(f, 0.0, np.inf, epsabs=0.0, epsrel=1e-11, limit=200)[0]
            assert val == pytest.approx(swerling1_detection_probability(S, pfa), rel=1e-9)
    assert swerling1_miss_probability(1e6, 1e-6) == pytest.approx(
        1.0 - 1e-6 ** (1.0 / (1.0 + 1e6)), rel=1e-6)
    assert swerling1_miss_probability(1e6, 1e-6) > 0.0


def test_swerling1_by_monte_carlo():
    rng = np.random.default_rng(3)
    n = 10 ** 6
    S = 10.0 ** 0.8
    pfa = 1e-4
    tau = square_law_threshold(pfa)
    power = S * rng.standard_exponential(n)
    noise = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2.0)
    zeta = np.abs(np.sqrt(power) + noise) ** 2
    p_hat = np.mean(zeta >= tau)
    p = swerling1_detection_probability(S, pfa)
    assert abs(p_hat - p) < 3.0 * np.sqrt(p * (1 - p) / n)


def test_nonfluctuating_by_monte_carlo():
    rng = np.random.default_rng(4)
    n = 10 ** 6
    S, pfa = 10.0, 1e-4
    noise = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2.0)
    p_hat = np.mean(np.abs(np.sqrt(S) + noise) ** 2 >= square_law_threshold(pfa))
    p = marcum_detection_probability(S, pfa)
    assert abs(p_hat - p) < 3.0 * np.sqrt(p * (1 - p) / n)


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("fn", [marcum_detection_probability, marcum_miss_probability,
                                log_marcum_detection_probability, log_marcum_miss_probability,
                                swerling1_detection_probability, swerling1_miss_probability])
def test_bad_snr_and_pfa(fn):
    with pytest.raises(ValueError, match="snr"):
        fn(-0.1, 1e-6)
    with pytest.raises(ValueError, match="snr"):
        fn(np.array([1.0, np.nan]), 1e-6)
    with pytest.raises(TypeError, match="snr"):
        fn("10 dB", 1e-6)
    for bad in (0.0, 1.0, 1.5, -1e-3):
        with pytest.raises(ValueError, match="pfa"):
            fn(3.0, bad)
    with pytest.raises(ValueError, match="pfa"):
        fn(3.0, np.inf)
    with pytest.raises(ValueError, match="broadcast"):
        fn(np.ones(3), np.full(2, 1e-3))


def test_bad_a_b():
    with pytest.raises(ValueError, match="a must"):
        marcum_q1(-1.0, 2.0)
    with pytest.raises(ValueError, match="b must"):
        marcum_q1_complement(1.0, -2.0)
    with pytest.raises(ValueError, match="b must"):
        marcum_q1(1.0, np.nan)
    with pytest.raises(TypeError, match="a must"):
        marcum_q1(None, 1.0)
    with pytest.raises(ValueError, match="pfa"):
        square_law_threshold(0.0)


def test_rician_likelihood_ratio():
    zeta = np.array([0.0, 0.5, 3.0, 30.0, 2000.0])
    S = 4.0
    want = np.log(special.i0(2 * np.sqrt(S * zeta[:4]))) - S
    np.testing.assert_allclose(rician_log_likelihood_ratio(zeta[:4], S), want, rtol=1e-13)
    assert np.isfinite(rician_log_likelihood_ratio(2000.0, S))   # no overflow
    # a likelihood ratio averages to 1 under the noise density e^{-zeta}
    f = lambda z: np.exp(rician_log_likelihood_ratio(z, S) - z)
    assert integrate.quad(f, 0.0, np.inf)[0] == pytest.approx(1.0, rel=1e-10)
    # its tail above tau integrates to P_D (the p_1 mass above the threshold)
    tau = 10 ** 0.5
    assert integrate.quad(f, tau, np.inf)[0] == pytest.approx(
        marcum_detection_probability(S, np.exp(-tau)), rel=1e-9)
    with pytest.raises(ValueError, match="zeta"):
        rician_log_likelihood_ratio(-1.0, S)
    with pytest.raises(ValueError, match="snr"):
        rician_log_likelihood_ratio(1.0, -S)


def test_detection_probability_is_the_public_marcum_name():
    from trackcore import detection

    assert detection.detection_probability is detection.marcum_detection_probability
    # the definition: P_D = Q1(sqrt(2 snr), sqrt(-2 ln pfa)) with linear SNR
    snr, pfa = 10 ** (13 / 10), 1e-6
    expected = detection.marcum_q1(np.sqrt(2 * snr), np.sqrt(-2 * np.log(pfa)))
    assert detection.detection_probability(snr, pfa) == pytest.approx(expected, rel=1e-12)
    with pytest.raises(ValueError, match="pfa"):
        detection.detection_probability(1.0, 1.0)
    with pytest.raises(ValueError, match="snr"):
        detection.detection_probability(-1.0, 1e-3)
