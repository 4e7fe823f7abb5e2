"""Tests for trackcore.detection.sprt (Wald's SPRT, eq 4 of Jeong & Hong 1996)."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from trackcore.detection import (sprt_summary, SPRT_H0, SPRT_H1, SPRT_UNDECIDED, SprtState, sprt_decide,
                                 sprt_step, sprt_symmetric_error, sprt_test, sprt_thresholds,
                                 wald_asn, wald_error_probabilities, wald_gaussian_oc_asn,
                                 wald_oc)


def test_thresholds_paper_values():
    g0, g1 = sprt_thresholds(0.05, 0.05)
    assert g1 == pytest.approx(math.log(19.0), abs=1e-12)
    assert g0 == pytest.approx(-math.log(19.0), abs=1e-12)
    assert round(g1, 2) == 2.94
    assert sprt_symmetric_error(5.3) == pytest.approx(1.0 / (1.0 + math.exp(5.3)), rel=1e-12)
    assert round(sprt_symmetric_error(5.3), 5) == 0.00497
    assert sprt_thresholds(0.005, 0.005)[1] == pytest.approx(5.293, abs=1e-3)


@pytest.mark.parametrize("pm,pf", [(0.05, 0.05), (0.01, 0.1), (0.2, 0.001), (0.3, 0.6)])
def test_thresholds_formula_and_inverse(pm, pf):
    g0, g1 = sprt_thresholds(pm, pf)
    assert g1 == pytest.approx(math.log((1 - pm) / pf), rel=1e-12, abs=1e-12)
    assert g0 == pytest.approx(math.log(pm / (1 - pf)), rel=1e-12, abs=1e-12)
    pf2, pm2 = wald_error_probabilities(g0, g1)
    assert pf2 == pytest.approx(pf, rel=1e-10)
    assert pm2 == pytest.approx(pm, rel=1e-10)


@pytest.mark.parametrize("pm,pf", [(0.0, 0.1), (0.1, 1.0), (-0.1, 0.1), (0.6, 0.5),
                                   (float("nan"), 0.1)])
def test_thresholds_bad_input(pm, pf):
    with pytest.raises(ValueError, match="p_miss|p_false"):
        sprt_thresholds(pm, pf)


def test_thresholds_type_error():
    with pytest.raises(TypeError, match="p_miss"):
        sprt_thresholds("0.1", 0.1)
    with pytest.raises(ValueError, match="gamma"):
        sprt_symmetric_error(-1.0)


def test_decide_first_crossing():
    llr = np.array([[0.5, -1.0, -3.0, 5.0],   # H0 at scan 3 (not H1 later)
                    [1.0, 3.0, -5.0, 0.0],    # H1 at scan 2
                    [0.0, 0.1, -0.1, 0.2],    # undecided
                    [2.94, 0.0, 0.0, 0.0]])   # boundary counts as a crossing
    d, k = sprt_decide(llr, -2.94, 2.94)
    assert d.tolist() == [SPRT_H0, SPRT_H1, SPRT_UNDECIDED, SPRT_H1]
    assert k.tolist() == [3, 2, 0, 1]
    assert sprt_decide(llr[0], -2.94, 2.94) == (SPRT_H0, 3)
    assert sprt_decide(np.zeros((3, 0)), -1, 1)[0].tolist() == [-1, -1, -1]


def test_sprt_test_and_online_step_agree():
    rng = np.random.default_rng(1)
    inc = rng.normal(-0.4, 1.0, size=30)
    res = sprt_test(inc, -2.0, 2.5)
    st_ = SprtState()
    for v in inc:
        st_ = sprt_step(st_, v, -2.0, 2.5)
    assert (st_.decision, st_.scan) == (res.decision, res.scan)
    assert st_.llr == pytest.approx(res.llr[-1])
    assert st_.k == 30
    assert res.decision != SPRT_UNDECIDED
    # empty sequence: undecided
    empty = sprt_test([], -1.0, 1.0)
    assert (empty.decision, empty.scan, empty.llr.size) == (SPRT_UNDECIDED, 0, 0)


def test_bad_inputs_decide():
    with pytest.raises(ValueError, match="gamma0"):
        sprt_decide(np.zeros(3), 0.5, 1.0)
    with pytest.raises(ValueError, match="gamma1"):
        sprt_decide(np.zeros(3), -0.5, -0.1)
    with pytest.raises(ValueError, match="llr"):
        sprt_decide(np.array([0.0, np.nan]), -1, 1)
    with pytest.raises(ValueError, match="llr"):
        sprt_decide(np.zeros((2, 2, 2)), -1, 1)
    with pytest.raises(TypeError, match="state"):
        sprt_step((0.0, 0), 0.1, -1, 1)
    with pytest.raises(ValueError, match="increment"):
        sprt_step(SprtState(), np.inf, -1, 1)


def test_wald_oc_h0_h1_and_zero_limit():
    g0, g1 = sprt_thresholds(0.02, 0.07)
    assert wald_oc(1.0, g0, g1) == pytest.approx(1 - 0.07, rel=1e-12)
    assert wald_oc(-1.0, g0, g1) == pytest.approx(0.02, rel=1e-10)
    assert wald_oc(1e-7, g0, g1) == pytest.approx(wald_oc(0.0, g0, g1), rel=1e-5)
    assert wald_oc(0.0, g0, g1) == pytest.approx(g1 / (g1 - g0))
    h = np.linspace(-3, 3, 7)
    L = wald_oc(h, g0, g1)
    assert np.all(np.diff(L) > 0)      # larger h (stronger H0 drift) -> more H0 decisions
    assert np.isfinite(wald_oc(400.0, g0, g1))
    assert isinstance(wald_oc(1.0, g0, g1), float)
    assert isinstance(wald_gaussian_oc_asn(-0.3, 1.0, g0, g1)[0], float)


def test_wald_asn_formula_and_errors():
    g0, g1 = -2.944, 2.944
    asn = wald_asn(-0.6, g0, g1, 0.95)
    assert asn == pytest.approx((0.95 * g0 + 0.05 * g1) / -0.6)
    with pytest.raises(ValueError, match="mean_increment"):
        wald_asn(0.0, g0, g1, 0.95)
    with pytest.raises(ValueError, match="p_decide_h0"):
        wald_asn(-0.6, g0, g1, 1.5)
    with pytest.raises(ValueError, match="negative"):
        wald_asn(0.6, g0, g1, 0.95)


def test_wald_gaussian_matches_simulation():
    # small drift per step: overshoot is small, Wald's approximations are accurate
    mu, sd, g0, g1 = -0.005, 0.1, -2.0, 2.0
    L, asn = wald_gaussian_oc_asn(mu, sd * sd, g0, g1)
    rng = np.random.default_rng(7)
    paths = np.cumsum(rng.normal(mu, sd, size=(3000, 2500)), axis=1)
    d, k = sprt_decide(paths, g0, g1)
    assert np.all(d >= 0)
    assert np.mean(d == 0) == pytest.approx(L, abs=0.02)
    assert np.mean(k) == pytest.approx(asn, rel=0.06)
    # zero drift limit
    L0, asn0 = wald_gaussian_oc_asn(0.0, 0.09, g0, g1)
    assert L0 == pytest.approx(0.5)
    assert asn0 == pytest.approx(4.0 / 0.09)
    with pytest.raises(ValueError, match="var"):
        wald_gaussian_oc_asn(0.0, 0.0, g0, g1)


@settings(max_examples=50, deadline=None)
@given(st.floats(1e-6, 0.49), st.floats(1e-6, 0.49))
def test_thresholds_property(pm, pf):
    g0, g1 = sprt_thresholds(pm, pf)
    assert g0 < 0 < g1
    pf2, pm2 = wald_error_probabilities(g0, g1)
    assert pf2 == pytest.approx(pf, rel=1e-8)
    assert pm2 == pytest.approx(pm, rel=1e-8)


def test_summary():
    llr = np.array([[-1.0, -3.0, -5.0], [1.0, 3.0, 4.0], [-0.5, 0.5, -0.5], [-4.0, -4.0, -4.0]])
    s = sprt_summary(llr, -2.0, 2.0)
    assert (s.n_runs, s.p_correct, s.p_wrong, s.p_undecided) == (4, 0.5, 0.25, 0.25)
    assert s.mean_scan_correct == 1.5 and s.mean_scan_wrong == 2.0 and s.mean_scan == pytest.approx(5 / 3)
    assert s.counts_correct.tolist() == [1, 1, 0] and s.counts_wrong.tolist() == [0, 1, 0]
    # mean path: [-1.125, -0.875, -1.375] never crosses +-2
    assert s.mean_llr_crossing == 0
    s1 = sprt_summary(llr, -2.0, 2.0, truth=1)
    assert s1.p_correct == 0.25 and s1.p_wrong == 0.5
    assert np.isnan(sprt_summary(llr[2:3], -2.0, 2.0).mean_scan_correct)
    with pytest.raises(ValueError, match="truth"):
        sprt_summary(llr, -2.0, 2.0, truth=2)
    with pytest.raises(ValueError, match="llr"):
        sprt_summary(np.zeros((0, 3)), -2.0, 2.0)
