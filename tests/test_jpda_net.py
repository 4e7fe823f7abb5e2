"""The exact JPDA hypothesis net: equal to the enumeration, to brute force and to Stone
Soup's EHM/EHM2 trees on random instances (property tests), also with weights spanning
hundreds of decades (the scaled net's certificate and its log-space fallback, against the
log-space enumeration and exact rational arithmetic), the output check, event counts
beyond the double range, the automatic choice, the limits on the work, and the
enumerators' up-front checks."""
from __future__ import annotations

import itertools
import math
import time
import warnings
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trackcore.association import (
    feasible_event_count,
    feasible_events,
    jpda_marginals,
    permanent,
)
from trackcore.association import jpda as jpda_module
from trackcore.association._jpda_net import (
    LOG_TINY,
    MAX_CELLS,
    MAX_COST,
    MAX_SLOTS,
    net_marginals,
    net_marginals_log,
    plan_size,
)
from trackcore.association.jpda import (
    COLUMN_SUM_TOLERANCE,
    ENUMERATE_MAX_PRODUCT,
    MAX_ENUMERATED_EVENTS,
    MAX_LISTED_ENTRIES,
    MAX_LISTED_EVENTS,
    MAX_PERMANENT_OPERATIONS,
    _net_inputs,
)

RTOL = 1e-12


def instance(rng, m, T, p_valid):
    valid = rng.random((m, T)) < p_valid
    lik = rng.uniform(1e-4, 0.05, (m, T))
    pd = rng.uniform(0.5, 0.99, T)
    lam = 10 ** rng.uniform(-4, -2)
    rho = rng.uniform(0.3, 1.0, (m, T))
    return lik, valid, pd, lam, rho


def assert_equal_marginals(a, b, rtol=RTOL):
    """Equal to ``rtol`` relative wherever the value is a normal double, zero together."""
    a = np.asarray(a)
    b = np.asarray(b)
    assert a.shape == b.shape
    assert np.array_equal(a == 0, b == 0)
    big = np.abs(b) > 1e-250
    np.testing.assert_allclose(a[big], b[big], rtol=rtol, atol=0)


def exact_count(m, T):
    """Feasible events of the all-valid m x T matrix: sum_k C(T, k) m!/(m - k)!."""
    return sum(math.comb(T, k) * math.perm(m, k) for k in range(min(m, T) + 1))


def brute_force(lik, valid, pd, lam):
    """Target-oriented product enumeration with itertools (parametric form)."""
    m, T = valid.shape
    choices = [[-1] + [j for j in range(m) if valid[j, t]] for t in range(T)]
    acc = np.zeros((m + 1, T))
    total = 0.0
    for ev in itertools.product(*choices):
        det = [j for j in ev if j >= 0]
        if len(det) != len(set(det)):
            continue
        w = 1.0
        for t, j in enumerate(ev):
            w *= pd[t] * lik[j, t] / lam if j >= 0 else 1.0 - pd[t]
        total += w
        for t, j in enumerate(ev):
            acc[j + 1, t] += w
    return acc / total


# ----------------------------------------------------------------------------- Stone Soup
class _Hyp:
    """The two attributes Stone Soup's EHM trees read from a hypothesis."""

    def __init__(self, measurement, probability):
        self.measurement = measurement
        self.probability = probability


def stonesoup_ehm(lik, valid, pd, lam, rho=None, tree=True):
    """Marginals from Stone Soup's ``EHMTree`` (EHM2 with ``tree=True``, EHM otherwise),
    run on each cluster of ``TrackClusterer`` as ``JPDAwithEHM``/``JPDAwithEHM2`` do."""
    from stonesoup.dataassociator._ehm import EHMTree, TrackClusterer
    from stonesoup.types.numeric import Probability

    m, T = valid.shape
    w = lik * (1.0 if rho is None else np.clip(rho, 0.0, None)) / lam
    hyps = {}
    for t in range(T):
        hs = [_Hyp(None, Probability(1.0 - pd[t]))]
        for j in range(m):
            if valid[j, t]:
                hs.append(_Hyp(f"z{j}", Probability(pd[t] * w[j, t])))
        hyps[t] = hs
    out = np.zeros((m + 1, T))
    for cluster in TrackClusterer(hyps).clustered_hypotheses:
        post = EHMTree(cluster, make_tree=tree).get_posterior_hypotheses()
        for t, pairs in post.items():
            for h, p in pairs:
                row = 0 if h.measurement is None else int(h.measurement[1:]) + 1
                out[row, t] = float(p)
    return out


# ----------------------------------------------------------------------------- properties
@settings(max_examples=150, deadline=None)
@given(m=st.integers(1, 8), T=st.integers(1, 5), seed=st.integers(0, 2**31),
       feature=st.booleans(), nonparametric=st.booleans())
def test_property_net_equals_enumeration(m, T, seed, feature, nonparametric):
    rng = np.random.default_rng(seed)
    lik, valid, pd, lam, rho = instance(rng, m, T, rng.uniform(0.1, 1.0))
    if rng.random() < 0.2:
        lik[rng.random((m, T)) < 0.3] = 0.0           # zero likelihoods on valid pairs
    if rng.random() < 0.2:
        pd[0] = 1.0
    kw = dict(rho=rho if feature else None)
    if nonparametric:
        kw.update(mode="nonparametric", V=float(rng.uniform(50, 500)))
    try:
        ref, n_ref = jpda_marginals(lik, valid, pd, lam, method="enumerate", **kw)
    except ValueError as exc:
        with pytest.raises(ValueError, match="zero probability"):
            jpda_marginals(lik, valid, pd, lam, method="net", **kw)
        assert "zero probability" in str(exc)
        return
    got, n = jpda_marginals(lik, valid, pd, lam, method="net", **kw)
    assert n == n_ref
    assert_equal_marginals(got, ref)
    np.testing.assert_allclose(got.sum(axis=0), 1.0, atol=1e-13)


@settings(max_examples=100, deadline=None)
@given(m=st.integers(1, 9), T=st.integers(1, 6), seed=st.integers(0, 2**31),
       feature=st.booleans())
def test_property_net_equals_stonesoup_ehm2_and_ehm(m, T, seed, feature):
    rng = np.random.default_rng(seed)
    lik, valid, pd, lam, rho = instance(rng, m, T, rng.uniform(0.2, 1.0))
    rho = rho if feature else None
    got, _ = jpda_marginals(lik, valid, pd, lam, rho=rho, method="net")
    vv = valid if rho is None else valid & (rho >= 0.6)
    assert_equal_marginals(got, stonesoup_ehm(lik, vv, pd, lam, rho, tree=True))
    assert_equal_marginals(got, stonesoup_ehm(lik, vv, pd, lam, rho, tree=False))


@settings(max_examples=60, deadline=None)
@given(m=st.integers(1, 7), T=st.integers(1, 5), seed=st.integers(0, 2**31))
def test_property_net_equals_brute_force(m, T, seed):
    rng = np.random.default_rng(seed)
    lik, valid, pd, lam, _ = instance(rng, m, T, rng.uniform(0.1, 1.0))
    got, n = jpda_marginals(lik, valid, pd, lam, method="net")
    assert_equal_marginals(got, brute_force(lik, valid, pd, lam), rtol=1e-11)
    assert n == feasible_event_count(valid) == len(feasible_events(valid))


def test_larger_instances_against_stonesoup_ehm2():
    """Sizes the enumeration cannot reach quickly (up to 10 targets, 16 measurements)."""
    rng = np.random.default_rng(2026)
    for T, m, p in [(8, 14, 0.5), (10, 16, 0.35), (6, 12, 1.0), (10, 10, 0.6)]:
        lik, valid, pd, lam, rho = instance(rng, m, T, p)
        got, n = jpda_marginals(lik, valid, pd, lam, rho=rho, method="net")
        vv = valid & (rho >= 0.6)
        assert_equal_marginals(got, stonesoup_ehm(lik, vv, pd, lam, rho, tree=True))
        assert n == feasible_event_count(vv)


def test_independent_clusters_equal_separate_problems():
    rng = np.random.default_rng(8)
    lik, valid, pd, lam, _ = instance(rng, 10, 6, 0.0)
    valid[:5, :3] = rng.random((5, 3)) < 0.7
    valid[5:, 3:] = rng.random((5, 3)) < 0.7
    whole, n = jpda_marginals(lik, valid, pd, lam, method="net")
    a, na = jpda_marginals(lik[:5, :3], valid[:5, :3], pd[:3], lam, method="enumerate")
    b, nb_ = jpda_marginals(lik[5:, 3:], valid[5:, 3:], pd[3:], lam, method="enumerate")
    assert n == na * nb_
    assert_equal_marginals(whole[np.ix_([0, 1, 2, 3, 4, 5], [0, 1, 2])], a)
    assert_equal_marginals(whole[np.ix_([0, 6, 7, 8, 9, 10], [3, 4, 5])], b)
    assert np.all(whole[1:6, 3:] == 0) and np.all(whole[6:, :3] == 0)


def test_tiny_likelihoods_and_extreme_weights():
    rng = np.random.default_rng(1)
    lik, valid, pd, lam, _ = instance(rng, 7, 4, 1.0)
    ref, _ = jpda_marginals(lik, valid, pd, lam, method="net")
    tiny, _ = jpda_marginals(lik * 1e-200, valid, pd, lam * 1e-200, method="net")
    assert_equal_marginals(tiny, ref, rtol=1e-13)
    # one pair a hundred orders of magnitude likelier than the others
    lik2 = lik.copy()
    lik2[2, 1] = 1e100
    a, _ = jpda_marginals(lik2, valid, pd, lam, method="net")
    b, _ = jpda_marginals(lik2, valid, pd, lam, method="enumerate")
    assert_equal_marginals(a, b)
    assert a[3, 1] == pytest.approx(1.0, abs=1e-15)


def test_pd_one_and_empty_gates():
    valid = np.array([[1, 1, 0], [1, 0, 0]], bool)
    lik = np.full((2, 3), 0.02)
    beta, _ = jpda_marginals(lik, valid, [0.9, 1.0, 0.8], 1e-3, method="net")
    ref, _ = jpda_marginals(lik, valid, [0.9, 1.0, 0.8], 1e-3, method="enumerate")
    assert_equal_marginals(beta, ref)
    assert beta[0, 1] == 0.0 and beta[0, 2] == 1.0
    for method in ("net", "enumerate"):
        with pytest.raises(ValueError, match="zero probability"):
            jpda_marginals(lik, valid, [0.9, 0.9, 1.0], 1e-3, method=method)


# ----------------------------------------------------------------------------- choice
def test_auto_keeps_small_problems_on_the_enumeration_bit_for_bit():
    rng = np.random.default_rng(4)
    seen = 0
    for _ in range(200):
        m, T = int(rng.integers(1, 7)), int(rng.integers(1, 5))
        lik, valid, pd, lam, rho = instance(rng, m, T, rng.uniform(0.1, 0.9))
        if np.prod(1.0 + valid.sum(axis=0)) > ENUMERATE_MAX_PRODUCT:
            continue
        seen += 1
        for kw in ({}, {"rho": rho}):
            a, na = jpda_marginals(lik, valid, pd, lam, **kw)
            b, nb_ = jpda_marginals(lik, valid, pd, lam, method="enumerate", **kw)
            assert np.array_equal(a, b) and na == nb_
    assert seen > 50


def test_auto_uses_the_net_for_large_problems_and_all_valid_10x10_is_prompt():
    rng = np.random.default_rng(6)
    lik = rng.uniform(1e-3, 0.05, (10, 10))
    valid = np.ones((10, 10), bool)
    jpda_marginals(lik, valid, 0.9, 1e-3)                 # load the compiled kernels
    t0 = time.perf_counter()
    beta, n = jpda_marginals(lik, valid, 0.9, 1e-3)
    assert time.perf_counter() - t0 < 0.5                 # about a millisecond
    assert n == exact_count(10, 10) == 234662231
    b2, _ = jpda_marginals(lik, valid, 0.9, 1e-3, method="net")
    assert np.array_equal(beta, b2)
    np.testing.assert_allclose(beta.sum(axis=0), 1.0, atol=1e-13)


def test_bad_method():
    with pytest.raises(ValueError, match="method"):
        jpda_marginals(np.ones((1, 1)), np.ones((1, 1), bool), 0.9, 1e-3, method="fast")


# ----------------------------------------------------------------------------- limits
def test_enumeration_checks_its_size_first():
    valid = np.ones((14, 14), bool)
    lik = np.full((14, 14), 0.01)
    feasible_event_count(np.ones((2, 2), bool))   # load the compiled kernels before timing
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=r"14 measurements x 14 targets.* has 1\.\d+e\+13 "
                                         "feasible events.*MAX_ENUMERATED_EVENTS"):
        jpda_marginals(lik, valid, 0.9, 1e-3, method="enumerate")
    # too many even to count: named as such
    with pytest.raises(ValueError, match="more feasible events than the hypothesis net can "
                                         "count.*MAX_ENUMERATED_EVENTS"):
        jpda_marginals(np.full((30, 30), 0.01), np.ones((30, 30), bool), 0.9, 1e-3,
                       method="enumerate")
    assert time.perf_counter() - t0 < 5.0
    assert exact_count(14, 14) > MAX_ENUMERATED_EVENTS
    # all-valid 9 x 8 (about 1.5e7 events) is still enumerated
    assert exact_count(9, 8) <= MAX_ENUMERATED_EVENTS


def test_net_limits_raise_naming_them_and_the_size_fast():
    feasible_event_count(np.ones((2, 2), bool))   # load the compiled kernels
    t0 = time.process_time()
    valid = np.ones((30, 30), bool)
    with pytest.raises(ValueError, match=rf"30 measurements x 30 targets.*MAX_SLOTS = {MAX_SLOTS}"):
        jpda_marginals(np.full((30, 30), 0.01), valid, 0.9, 1e-3)
    with pytest.raises(ValueError, match="30 measurements x 30 targets.*MAX_SLOTS"):
        feasible_event_count(valid)
    # all-valid 22 x 22: within the frontier limit, over the stored values and the cost
    valid = np.ones((22, 22), bool)
    with pytest.raises(ValueError, match=r"22 measurements x 22 targets.*MAX_CELLS = 2\*\*26"
                                         r".*MAX_COST"):
        jpda_marginals(np.full((22, 22), 0.01), valid, 0.9, 1e-3)
    assert time.process_time() - t0 < 1.0
    assert MAX_CELLS == 2**26 and MAX_COST == 1e9


def test_largest_benchmarked_net_is_within_the_limits():
    """The fully overlapping 20 targets x 40 measurements of the benchmarks (the end of
    the scaling series) is within the limits; all-valid 22 x 22 is not (above)."""
    cost, cells, slots = plan_size(np.ones((40, 20), bool), 1)
    assert cost < MAX_COST and cells < MAX_CELLS and slots <= MAX_SLOTS


def test_event_count_without_enumeration():
    feasible_event_count(np.ones((3, 3), bool))
    t0 = time.perf_counter()
    assert feasible_event_count(np.ones((12, 12), bool)) == exact_count(12, 12) == 53334454417
    assert time.perf_counter() - t0 < 0.5
    assert feasible_event_count(np.ones((18, 7), bool)) == exact_count(18, 7)
    assert feasible_event_count(np.zeros((0, 3), bool)) == 1
    rng = np.random.default_rng(3)
    for _ in range(30):
        m, T = int(rng.integers(1, 9)), int(rng.integers(1, 6))
        valid = rng.random((m, T)) < 0.5
        A = np.hstack([valid.T.astype(float), np.eye(T)])
        assert feasible_event_count(valid) == round(permanent(A)) == len(feasible_events(valid))


def test_listing_checks_its_size_first():
    with pytest.raises(ValueError, match="12 measurements x 12 targets.*MAX_LISTED_EVENTS"):
        feasible_events(np.ones((12, 12), bool))
    assert exact_count(12, 12) > MAX_LISTED_EVENTS
    # 2**20 events, but 500 targets: the listing would have 5.2e8 entries (3.9 GiB)
    valid = np.zeros((20, 500), bool)
    valid[np.arange(20), np.arange(20)] = True
    t0 = time.process_time()
    with pytest.raises(ValueError, match=r"1\.04858e\+06 feasible events.*MAX_LISTED_ENTRIES"):
        feasible_events(valid)
    assert time.process_time() - t0 < 1.0
    assert 2**20 <= MAX_LISTED_EVENTS and 2**20 * 500 > MAX_LISTED_ENTRIES


def test_permanent_recursion_and_limit():
    t0 = time.perf_counter()
    assert permanent(np.ones((2, 30))) == 870.0
    permanent(np.ones((2, 30)))
    rng = np.random.default_rng(2)
    for T, n in [(2, 20), (3, 24), (4, 18)]:
        A = rng.random((T, n))
        bf = sum(np.prod([A[i, p[i]] for i in range(T)])
                 for p in itertools.permutations(range(n), T))
        assert permanent(A) == pytest.approx(bf, rel=1e-12)
    assert time.perf_counter() - t0 < 30.0
    t0 = time.process_time()
    for shape in [(30, 40), (25, 30), (22, 40)]:
        with pytest.raises(ValueError, match=rf"shape \({shape[0]}, {shape[1]}\).*"
                                             r"MAX_PERMANENT_OPERATIONS = 2\*\*30"):
            permanent(np.ones(shape))
    assert time.process_time() - t0 < 0.5
    assert MAX_PERMANENT_OPERATIONS == 2**30


def test_permanent_of_long_thin_matrices_does_not_overflow():
    """The operation counts are exact integers: no OverflowError from 2.0**n."""
    assert permanent(np.ones((2, 1100))) == 1100.0 * 1099.0
    assert permanent(np.ones((1, 5000))) == 5000.0
    assert permanent(np.ones((0, 2000))) == 1.0
    with pytest.raises(ValueError, match="MAX_PERMANENT_OPERATIONS"):
        permanent(np.ones((40, 1100)))


# ----------------------------------------------------------------------------- wide ranges
def assert_close_wide(got, ref, rtol):
    """``rtol`` relative where the reference is above 1e-280, 1e-280 absolute below;
    structural zeros together."""
    got = np.asarray(got)
    ref = np.asarray(ref)
    assert np.all(np.isfinite(got))
    big = ref > 1e-280
    np.testing.assert_allclose(got[big], ref[big], rtol=rtol, atol=0)
    assert np.all(np.abs(got[~big] - ref[~big]) <= 1e-280)


def wide_instance(rng, m, T):
    valid = rng.random((m, T)) < rng.uniform(0.3, 1.0)
    lik = 10.0 ** rng.uniform(-150, 150, (m, T))
    lam = 10.0 ** rng.uniform(-150, 0)
    pd = rng.uniform(0.05, 0.99, T)
    rho = rng.uniform(0.3, 1.0, (m, T))
    return lik, valid, pd, lam, rho


@settings(max_examples=200, deadline=None)
@given(m=st.integers(1, 8), T=st.integers(1, 5), seed=st.integers(0, 2**31),
       feature=st.booleans(), nonparametric=st.booleans())
def test_property_wide_weights_net_equals_log_space_enumeration(m, T, seed, feature,
                                                               nonparametric):
    """Likelihoods 10^U(-150, 150), lam = 10^U(-150, 0): pair weights spanning up to 600
    decades.  The net (scaled where certified, in log space otherwise) equals the
    log-space enumeration to 1e-10 relative wherever the marginal exceeds 1e-280; every
    value is finite and every column sums to 1."""
    rng = np.random.default_rng(seed)
    lik, valid, pd, lam, rho = wide_instance(rng, m, T)
    kw = dict(rho=rho if feature else None)
    if nonparametric:
        kw.update(mode="nonparametric", V=float(10.0 ** rng.uniform(-50, 50)))
    ref, n_ref = jpda_marginals(lik, valid, pd, lam, method="enumerate", **kw)
    got, n = jpda_marginals(lik, valid, pd, lam, method="net", **kw)
    assert n == n_ref
    assert_close_wide(got, ref, rtol=1e-10)
    np.testing.assert_allclose(got.sum(axis=0), 1.0, atol=1e-12)
    auto, _ = jpda_marginals(lik, valid, pd, lam, **kw)
    assert_close_wide(auto, ref, rtol=1e-10)


def exact_rational(lik, valid, pd, lam):
    """Parametric marginals in exact rational arithmetic at the given doubles."""
    m, T = valid.shape
    F = Fraction
    choices = [[-1] + [j for j in range(m) if valid[j, t]] for t in range(T)]
    acc = [[F(0)] * T for _ in range(m + 1)]
    total = F(0)
    for ev in itertools.product(*choices):
        det = [j for j in ev if j >= 0]
        if len(det) != len(set(det)):
            continue
        w = F(1)
        for t, j in enumerate(ev):
            w *= F(pd[t]) * F(lik[j, t]) / F(lam) if j >= 0 else 1 - F(pd[t])
        total += w
        for t, j in enumerate(ev):
            acc[j + 1][t] += w
    return np.array([[float(acc[r][t] / total) for t in range(T)] for r in range(m + 1)])


REVIEW_CASE = dict(
    valid=np.array([[0, 1, 1, 1, 1], [1, 1, 1, 1, 1]], bool),
    lik=10.0 ** np.array([[-76.0, 62, 70, 67, -129], [134, 23, -68, -20, 5]]),
    pd=np.array([0.283, 0.299, 0.392, 0.784, 0.461]),
    lam=4.6e-73,
)


def test_wide_range_case_that_broke_the_scaled_net():
    """Pair weights from 1e-57 to 1e206: the scaled net's certificate fails (status 3),
    the log-space net and the public call equal exact rational arithmetic."""
    c = REVIEW_CASE
    logw, log_miss = _net_inputs(c["lik"], c["valid"], c["lik"], False, c["pd"],
                                 -math.log(c["lam"]))
    status = net_marginals(logw, c["valid"], log_miss, np.zeros(1))[3]
    assert status == 3
    ref = exact_rational(c["lik"], c["valid"], c["pd"], c["lam"])
    beta_log, status, _ = net_marginals_log(logw, c["valid"], log_miss, np.zeros(1))
    assert status == 0
    assert_close_wide(beta_log, ref, rtol=1e-12)
    for method in ("auto", "net", "enumerate"):
        beta, n = jpda_marginals(c["lik"], c["valid"], c["pd"], c["lam"], method=method)
        assert n == 26
        assert_close_wide(beta, ref, rtol=1e-12)


def test_wide_range_against_exact_rational_arithmetic():
    rng = np.random.default_rng(150)
    for _ in range(25):
        m, T = int(rng.integers(2, 5)), int(rng.integers(3, 5))
        lik, valid, pd, lam, _ = wide_instance(rng, m, T)
        ref = exact_rational(lik, valid, pd, lam)
        got, _ = jpda_marginals(lik, valid, pd, lam, method="net")
        assert_close_wide(got, ref, rtol=1e-12)


def test_certificate_keeps_ordinary_problems_in_the_scaled_net():
    """Gaussian likelihoods in 2-D gates, lam = 1e-6 .. 1e-2: status 0 (no log space)."""
    rng = np.random.default_rng(3)
    for T, m in [(8, 10), (12, 14), (16, 20)]:
        valid = np.ones((m, T), bool)
        lik = np.exp(-0.5 * rng.uniform(0, 9.2, (m, T))) / (2 * np.pi * 10 ** rng.uniform(-2, 2, T))
        for lam in (1e-2, 1e-4, 1e-6):
            logw, log_miss = _net_inputs(lik, valid, lik, False, np.full(T, 0.9), -math.log(lam))
            beta, _, _, status, _ = net_marginals(logw, valid, log_miss, np.zeros(1))
            assert status == 0
            np.testing.assert_allclose(beta.sum(axis=0), 1.0, atol=1e-13)
    assert LOG_TINY == pytest.approx(math.log(1e-290))


def test_underflowing_pair_product_is_kept():
    """lik * pd underflows to 0 in double precision; the weight is formed in log space,
    so the pair keeps its (dominant) probability, as in the enumeration."""
    valid = np.ones((3, 4), bool)
    lik = np.full((3, 4), 1e-300)
    lik[0, 0] = 1e-320                                    # subnormal: 1e-320 * 0.01 -> 0
    pd = np.full(4, 0.01)
    lam = 1e-310
    ref, _ = jpda_marginals(lik, valid, pd, lam, method="enumerate")
    got, _ = jpda_marginals(lik, valid, pd, lam, method="net")
    assert got[1, 0] > 0 and ref[1, 0] > 0
    assert_close_wide(got, ref, rtol=1e-10)


def test_output_check_falls_back_or_raises(monkeypatch):
    """A net result that fails the output check (here forced: NaN) is never returned:
    the enumeration replaces it when affordable, otherwise a ValueError says why."""
    rng = np.random.default_rng(9)
    lik, valid, pd, lam, _ = instance(rng, 6, 4, 1.0)
    ref, n_ref = jpda_marginals(lik, valid, pd, lam, method="enumerate")

    def broken(logw, valid, log_miss, lg_count):
        m, T = valid.shape
        beta = np.full((m + 1, T), np.nan)
        return beta, 1.0, 0, 0, np.zeros(3)

    def broken_log(logw, valid, log_miss, lg_count):
        m, T = valid.shape
        beta = np.full((m + 1, T), 0.3)                 # finite, columns not summing to 1
        return beta, 0, np.zeros(3)

    monkeypatch.setattr(jpda_module, "net_marginals", broken)
    monkeypatch.setattr(jpda_module, "net_marginals_log", broken_log)
    got, n = jpda_marginals(lik, valid, pd, lam, method="net")
    assert np.array_equal(got, ref) and n == n_ref
    big = np.ones((14, 14), bool)
    with pytest.raises(ValueError, match="failed their check.*MAX_ENUMERATED_EVENTS"):
        jpda_marginals(np.full((14, 14), 0.01), big, 0.9, 1e-3, method="net")
    assert COLUMN_SUM_TOLERANCE == 1e-9


# ----------------------------------------------------------------------------- huge counts
def test_event_counts_beyond_double_range_are_inf_not_overflow_error():
    """A chain of 600 targets (m = 1200) and 700 separated targets with 2 measurements
    each have more than 1.8e308 events: the count is math.inf, the marginals are right,
    nothing raises OverflowError."""
    T = 600
    valid = np.zeros((2 * T, T), bool)
    for t in range(T):
        valid[2 * t:2 * t + 3, t] = True
    assert feasible_event_count(valid) == math.inf
    beta, n = jpda_marginals(np.full(valid.shape, 0.01), valid, 0.9, 1e-3)
    assert n == math.inf and np.all(np.isfinite(beta))
    np.testing.assert_allclose(beta.sum(axis=0), 1.0, atol=1e-12)
    T = 700
    valid = np.zeros((2 * T, T), bool)
    for t in range(T):
        valid[2 * t:2 * t + 2, t] = True
    lik = np.random.default_rng(0).uniform(1e-3, 1e-2, valid.shape)
    beta, n = jpda_marginals(lik, valid, 0.9, 1e-3)
    assert n == math.inf
    one, n1 = jpda_marginals(lik[:2, :1], valid[:2, :1], 0.9, 1e-3, method="enumerate")
    assert n1 == 3
    np.testing.assert_allclose(beta[:3, 0], one[:, 0], rtol=1e-13)


def test_event_counts_above_2_53_are_floats_to_double_precision():
    """100 separated targets with 2 measurements each: 3**100 events (5.2e47), returned
    as a float within double rounding (rescaled by exact powers of two on the way);
    below 2**53 the count is an exact int."""
    T = 100
    valid = np.zeros((2 * T, T), bool)
    for t in range(T):
        valid[2 * t:2 * t + 2, t] = True
    n = feasible_event_count(valid)
    assert isinstance(n, float) and n == pytest.approx(3.0**100, rel=1e-15)
    small = np.zeros((2 * 33, 33), bool)
    for t in range(33):
        small[2 * t:2 * t + 2, t] = True
    n = feasible_event_count(small)                      # 3**33 = 5.6e15 < 2**53
    assert isinstance(n, int) and n == 3**33
    # 3**600 = 1.9e286: the partial counts are rescaled by 2**-512 on the way
    T = 600
    valid = np.zeros((2 * T, T), bool)
    for t in range(T):
        valid[2 * t:2 * t + 2, t] = True
    assert feasible_event_count(valid) == pytest.approx(float(3**600), rel=1e-13)


def test_product_bound_has_no_overflow_warning():
    valid = np.ones((3, 800), bool)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert jpda_module._product_bound(valid) == math.inf
        assert not jpda_module._product_at_most(valid, 100)
        beta, _ = jpda_marginals(np.full((3, 800), 0.01), valid, 0.5, 1e-3)
    assert np.all(np.isfinite(beta))
