"""Tests for trackcore.core: validation, log-space maths, RNG plumbing."""
import math

import numba as nb
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.special import logsumexp as scipy_logsumexp
from scipy.stats import multivariate_normal

from trackcore import core


# --------------------------------------------------------------------------- validation
def test_as_array_converts_and_checks_shape():
    a = core.as_array([[1, 2], [3, 4]], "P", shape=(2, 2))
    assert a.dtype == np.float64 and a.flags.c_contiguous
    with pytest.raises(ValueError, match="P must have shape"):
        core.as_array([1, 2, 3], "P", shape=(2, 2))
    with pytest.raises(ValueError, match="x must have 1 dimension"):
        core.as_array([[1.0]], "x", ndim=1)


@pytest.mark.parametrize("bad", ["abc", None, [1 + 2j], np.array(["a"]), [object()]])
def test_as_array_rejects_non_numeric_with_type_error(bad):
    with pytest.raises(TypeError, match="z must be"):
        core.as_array(bad, "z")


@pytest.mark.parametrize("bad", [[1.0, np.nan], [np.inf, 0.0]])
def test_as_array_rejects_non_finite(bad):
    with pytest.raises(ValueError, match="x must contain only finite values"):
        core.as_array(bad, "x")


def test_as_covariance_checks_symmetry_and_psd():
    P = core.as_covariance([[2.0, 0.5], [0.5, 1.0]], "P", 2)
    assert np.array_equal(P, P.T)
    core.as_covariance(np.zeros((2, 2)), "Q")  # PSD singular is fine
    with pytest.raises(ValueError, match="P must be symmetric"):
        core.as_covariance([[1.0, 0.5], [0.0, 1.0]], "P")
    with pytest.raises(ValueError, match="R must be positive semi-definite"):
        core.as_covariance([[1.0, 2.0], [2.0, 1.0]], "R")
    with pytest.raises(ValueError, match="S must be positive definite"):
        core.as_covariance(np.zeros((2, 2)), "S", strict=True)
    with pytest.raises(ValueError, match=r"P must be \(3, 3\)"):
        core.as_covariance(np.eye(2), "P", 3)


def test_as_measurements_handles_empty_scans():
    for empty in ([], np.zeros((0, 2)), np.array([])):
        z = core.as_measurements(empty, "z", 2)
        assert z.shape == (0, 2)
    assert core.as_measurements([1.0, 2.0], "z", 2).shape == (1, 2)
    assert core.as_measurements([1.0, 2.0, 3.0], "z", 1).shape == (3, 1)
    with pytest.raises(ValueError, match=r"z must have shape \(m, 2\)"):
        core.as_measurements(np.zeros((3, 3)), "z", 2)


def test_scalar_and_probability_checks():
    assert core.as_probability(0.3, "pd") == 0.3
    for bad in (-0.1, 1.1):
        with pytest.raises(ValueError, match=r"pd must be a probability in \[0, 1\]"):
            core.as_probability(bad, "pd")
    with pytest.raises(ValueError, match=r"pfa must be a probability in \(0, 1\)"):
        core.as_probability(1.0, "pfa", open_low=True, open_high=True)
    with pytest.raises(TypeError, match="pd must be a real number"):
        core.as_probability("0.5", "pd")
    with pytest.raises(TypeError, match="pd must be a real number"):
        core.as_probability(True, "pd")
    with pytest.raises(ValueError, match="pd must be finite"):
        core.as_probability(float("nan"), "pd")
    with pytest.raises(ValueError, match="T must be > 0"):
        core.as_positive(0.0, "T")
    with pytest.raises(ValueError, match="q must be >= 0"):
        core.as_nonnegative(-1.0, "q")
    with pytest.raises(ValueError, match=r"w must contain probabilities in \[0, 1\]"):
        core.as_probabilities([0.2, 1.2], "w")


def test_count_and_int_checks():
    assert core.as_count(3, "m") == 3
    assert core.as_count(np.int64(0), "m") == 0
    with pytest.raises(ValueError, match="m must be >= 0"):
        core.as_count(-1, "m")
    with pytest.raises(TypeError, match="n must be an integer"):
        core.as_count(2.5, "n")
    with pytest.raises(TypeError, match="n must be an integer"):
        core.as_int(True, "n")


def test_as_rng_requires_generator():
    core.as_rng(np.random.default_rng(1))
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        core.as_rng(1)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        core.as_rng(np.random.RandomState(1))


def test_as_bool_matrix():
    v = core.as_bool_matrix([[1, 0], [0, 1]], "valid", (2, 2))
    assert v.dtype == bool
    with pytest.raises(ValueError, match="valid must contain only 0/1"):
        core.as_bool_matrix([[2, 0]], "valid")
    with pytest.raises(ValueError, match="valid must have shape"):
        core.as_bool_matrix([1, 0], "valid")


# --------------------------------------------------------------------------- log maths
@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.integers(1, 30),
              elements=st.floats(-800, 800, allow_nan=False)))
def test_logsumexp_matches_scipy(a):
    assert math.isclose(core.logsumexp(a), scipy_logsumexp(a), rel_tol=1e-12, abs_tol=1e-12)


def test_logsumexp_edge_cases_and_axis():
    assert core.logsumexp([]) == -np.inf
    assert core.logsumexp([-np.inf, -np.inf]) == -np.inf
    assert core.logsumexp([-1e4, -1e4]) == pytest.approx(-1e4 + math.log(2), rel=1e-15)
    a = np.random.default_rng(0).normal(size=(3, 4, 5))
    for ax in (0, 1, 2, -1):
        np.testing.assert_allclose(core.logsumexp(a, axis=ax), scipy_logsumexp(a, axis=ax), rtol=1e-13)
    with pytest.raises(ValueError, match="a must not contain NaN"):
        core.logsumexp([0.0, np.nan])


def test_normalize_log_weights_survives_underflow():
    logw = np.array([-2000.0, -2001.0, -2003.0])
    w, total = core.normalize_log_weights(logw)
    assert math.isclose(np.exp(w).sum(), 1.0, rel_tol=1e-14)
    assert math.isclose(total, scipy_logsumexp(logw), rel_tol=1e-14)
    with pytest.raises(ValueError, match="logw has zero total weight"):
        core.normalize_log_weights([-np.inf, -np.inf])
    with pytest.raises(ValueError, match="logw must not contain NaN"):
        core.normalize_log_weights([0.0, np.nan])


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(0, 2**31 - 1))
def test_gaussian_logpdf_matches_scipy(n, seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    cov = A @ A.T + 0.1 * np.eye(n)
    mean = rng.normal(size=n)
    x = rng.normal(size=(7, n)) * 3
    ours = core.gaussian_logpdf(x, mean, cov)
    ref = multivariate_normal(mean, cov).logpdf(x)
    np.testing.assert_allclose(ours, np.atleast_1d(ref), rtol=1e-10, atol=1e-10)
    assert math.isclose(core.gaussian_logpdf(x[0], mean, cov), float(np.atleast_1d(ref)[0]),
                        rel_tol=1e-10, abs_tol=1e-10)


def test_gaussian_logpdf_far_tail_is_finite_log():
    # exp() of this underflows to 0, the log-density must not
    val = core.gaussian_logpdf([1e3], [0.0], [[1.0]])
    assert math.isclose(val, -0.5 * (math.log(2 * math.pi) + 1e6), rel_tol=1e-14)


def test_gaussian_logpdf_bad_input():
    with pytest.raises(ValueError, match="cov must be positive definite"):
        core.gaussian_logpdf([0.0, 0.0], [0.0, 0.0], np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"cov must be \(2, 2\)"):
        core.gaussian_logpdf([0.0, 0.0], [0.0, 0.0], np.eye(3))
    with pytest.raises(ValueError, match="x must have last dimension 2"):
        core.gaussian_logpdf([0.0, 0.0, 0.0], [0.0, 0.0], np.eye(2))
    with pytest.raises(ValueError, match="x must contain only finite"):
        core.gaussian_logpdf([np.nan, 0.0], [0.0, 0.0], np.eye(2))


def test_kernels_callable_from_numba():
    from trackcore.core.logmath import cholesky_logpdf_kernel, logsumexp_kernel

    @nb.njit
    def use(a, L, r):
        return logsumexp_kernel(a) + cholesky_logpdf_kernel(r, L)

    L = np.linalg.cholesky(np.array([[2.0, 0.3], [0.3, 1.0]]))
    r = np.array([0.5, -1.0])
    a = np.array([0.0, 1.0])
    expected = scipy_logsumexp(a) + multivariate_normal([0, 0], L @ L.T).logpdf(r)
    assert math.isclose(use(a, L, r), expected, rel_tol=1e-12)


# --------------------------------------------------------------------------- rng
def test_spawned_generators_match_seedsequence_contract():
    gens = core.spawn_generators(42, 5)
    children = np.random.SeedSequence(42).spawn(5)
    for g, c in zip(gens, children):
        assert g.standard_normal() == np.random.default_rng(c).standard_normal()
    g3 = core.generator_for_run(42, 3, 5)
    assert g3.standard_normal() == np.random.default_rng(children[3]).standard_normal()


def test_rng_bad_input():
    with pytest.raises(ValueError, match="seed must be >= 0"):
        core.spawn_generators(-1, 2)
    with pytest.raises(TypeError, match="seed must be a non-negative integer"):
        core.spawn_generators(1.5, 2)
    with pytest.raises(ValueError, match="n must be >= 0"):
        core.spawn_generators(1, -2)
    with pytest.raises(ValueError, match=r"i must be in \[0, 3\)"):
        core.generator_for_run(1, 3, 3)
    assert core.spawn_generators(1, 0) == []


def test_generator_usable_inside_numba_kernel():
    @nb.njit
    def draw(rng, n):
        out = np.empty(n)
        for i in range(n):
            out[i] = rng.standard_normal()
        return out

    a = draw(np.random.default_rng(7), 5)
    b = np.random.default_rng(7).standard_normal(5)
    np.testing.assert_array_equal(a, b)
    assert core.make_rng(7).standard_normal() == np.random.default_rng(np.random.SeedSequence(7)).standard_normal()


def test_as_offsets():
    from trackcore.core import as_offsets
    off = as_offsets([0, 2, 2, 5], 5)
    assert off.dtype == np.int64 and off.flags.c_contiguous and off.tolist() == [0, 2, 2, 5]
    assert as_offsets(np.array([0]), 0).tolist() == [0]          # K = 0 scans
    with pytest.raises(ValueError, match="scans.offsets must be a 1-D integer array"):
        as_offsets([0], 0, "scans.offsets", min_scans=1)
    for bad in ([0.0, 5.0], [[0, 5]], []):
        with pytest.raises(ValueError, match="offsets must be a 1-D integer array"):
            as_offsets(bad, 5)
    for bad in ([1, 5], [0, 4], [0, 3, 2, 5]):
        with pytest.raises(ValueError, match=r"offsets must start at 0.*\(5\)"):
            as_offsets(bad, 5)


# --------------------------------------------------------------------------- issue 17
def test_logsumexp_rejects_plus_inf_like_normalize_log_weights():
    for bad in ([np.inf, 0.0], [np.nan, 0.0]):
        with pytest.raises(ValueError, match="a must not contain NaN or \\+inf"):
            core.logsumexp(bad)
        with pytest.raises(ValueError, match="logw must not contain NaN or \\+inf"):
            core.normalize_log_weights(bad)
    assert core.logsumexp(np.zeros((2, 0)), axis=1).tolist() == [-np.inf, -np.inf]
    with pytest.raises(ValueError, match="axis=2"):
        core.logsumexp(np.zeros((2, 3)), axis=2)
    with pytest.raises(TypeError, match="axis"):
        core.logsumexp(np.zeros((2, 3)), axis=1.0)


def test_as_int_bounds():
    assert core.as_int(2.0**53, "n") == 2**53
    assert core.as_int(2**63 - 1, "n") == 2**63 - 1
    with pytest.raises(ValueError, match="n must be an integer of magnitude at most 2\\*\\*53"):
        core.as_int(1e300, "n")
    with pytest.raises(ValueError, match="n must fit in a 64-bit integer"):
        core.as_int(2**70, "n")
    for bad in (np.nan, np.inf, 2.5):
        with pytest.raises(TypeError, match="n must be an integer"):
            core.as_int(bad, "n")


def test_generator_for_run_index_checked_and_equal_to_spawn():
    with pytest.raises(TypeError, match="i must be an integer, got float"):
        core.generator_for_run(1, 2.5, 3)
    with pytest.raises(ValueError, match="n must fit"):
        core.generator_for_run(1, 0, 2**70)
    for seed in (0, 7, 2**80):
        gens = core.spawn_generators(seed, 4)
        for i in range(4):
            assert core.generator_for_run(seed, i, 4).random() == gens[i].random()
    # a huge n costs nothing: the i-th child is built directly
    g = core.generator_for_run(3, 2**62, 2**63 - 1)
    assert 0.0 <= g.random() < 1.0


def test_finite_result():
    x = np.array([1.0, 2.0])
    assert core.finite_result(x, "the value", "x") is x
    with pytest.raises(ValueError, match="the value is not finite.*check the magnitude of x"):
        core.finite_result(np.array([1.0, np.inf]), "the value", "x")
