"""The exact JPDA hypothesis net: equal to the enumeration, to brute force and to Stone
Soup's EHM/EHM2 trees on random instances (property tests), the automatic choice, the
limits on the work, and the enumerators' up-front checks."""
from __future__ import annotations

import itertools
import math
import time

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
from trackcore.association.jpda import (
    ENUMERATE_MAX_PRODUCT,
    MAX_ENUMERATED_EVENTS,
    MAX_LISTED_EVENTS,
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
    with pytest.raises(ValueError, match="MAX_ENUMERATED_EVENTS"):
        jpda_marginals(lik, valid, 0.9, 1e-3, method="enumerate")
    assert time.perf_counter() - t0 < 5.0
    assert exact_count(14, 14) > MAX_ENUMERATED_EVENTS


def test_net_limits_raise_naming_them():
    valid = np.ones((30, 30), bool)
    with pytest.raises(ValueError, match="frontier slots"):
        jpda_marginals(np.full((30, 30), 0.01), valid, 0.9, 1e-3)
    with pytest.raises(ValueError, match="frontier slots"):
        feasible_event_count(valid)


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
    with pytest.raises(ValueError, match="MAX_LISTED_EVENTS"):
        feasible_events(np.ones((12, 12), bool))
    assert exact_count(12, 12) > MAX_LISTED_EVENTS


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
    with pytest.raises(ValueError, match="MAX_PERMANENT_OPERATIONS"):
        permanent(np.ones((30, 40)))
