"""Tests for trackcore.filters.particle (propagation, ESS, resampling, bootstrap step)."""
import math

import numpy as np
import pytest
from filterpy import monte_carlo as fpmc
from hypothesis import given, settings, strategies as st
from hypothesis.extra import numpy as hnp
from scipy import stats

from trackcore.filters.particle import (
    bootstrap_step, effective_sample_size, loglik_gaussian_position, loglik_range_bearing,
    multinomial_resample, noise_factor, propagate_linear, propagate_linear_kernel,
    residual_resample, resample_particles,
    stratified_indices_kernel, stratified_resample, systematic_indices_kernel,
    systematic_resample, weighted_mean_cov)

SCHEMES = {
    "systematic": systematic_resample,
    "stratified": stratified_resample,
    "residual": residual_resample,
    "multinomial": multinomial_resample,
}


def cv(T=1.0):
    F = np.eye(4)
    F[0, 2] = F[1, 3] = T
    return F


def dwna(T, q):
    G = np.array([[T * T / 2, 0], [0, T * T / 2], [T, 0], [0, T]])
    return q * G @ G.T, math.sqrt(q) * G


weights_strategy = hnp.arrays(
    np.float64, st.integers(1, 25),
    elements=st.floats(0.0, 1.0, allow_nan=False, allow_infinity=False)).filter(
        lambda w: w.sum() > 1e-3)


# ---------------------------------------------------------------- propagation
def test_noise_factor_singular_and_full_rank():
    Q, G = dwna(0.5, 2.0)
    L = noise_factor(Q)
    assert L.shape == (4, 2)
    np.testing.assert_allclose(L @ L.T, Q, atol=1e-14)
    Qf = np.array([[2.0, 0.3], [0.3, 1.0]])
    Lf = noise_factor(Qf)
    assert Lf.shape == (2, 2)
    np.testing.assert_allclose(Lf @ Lf.T, Qf, atol=1e-14)
    assert noise_factor(np.zeros((3, 3))).shape == (3, 0)
    with pytest.raises(ValueError, match="Q"):
        noise_factor(np.diag([1.0, -1.0]))


def test_propagate_matches_numpy_reference_and_is_deterministic():
    rng = np.random.default_rng(1)
    X = rng.standard_normal((50, 4))
    F = cv(0.7)
    Q, G = dwna(0.7, 1.5)
    L = noise_factor(Q)
    out1 = propagate_linear(X, F, Q, np.random.default_rng(5))
    out2 = propagate_linear(X, F, Q, np.random.default_rng(5))
    np.testing.assert_array_equal(out1, out2)
    W = np.random.default_rng(5).standard_normal((50, L.shape[1]))
    np.testing.assert_allclose(out1, X @ F.T + W @ L.T, rtol=0, atol=1e-12)
    # explicit noise factor and in-place output
    Y = X.copy()
    propagate_linear(Y, F, None, np.random.default_rng(5), noise_factor=L, out=Y)
    np.testing.assert_array_equal(Y, out1)
    assert np.array_equal(X, np.random.default_rng(1).standard_normal((50, 4)))  # input untouched


@pytest.mark.parametrize("k", [0, 1, 2, 3, 4])
def test_propagate_simd_path_gives_the_scalar_bits(k):
    """n = 4 with k in {2, 4} on C-contiguous arrays takes a flat loop that LLVM vectorises
    across particles; it must give exactly the bits of the scalar per-particle loop (taken
    by Fortran-ordered arrays) and of the left-to-right sums written out in Python."""
    rng = np.random.default_rng(3)
    N = 1001
    X = rng.standard_normal((N, 4)) * [1e3, 1e3, 10.0, 10.0]
    F = rng.standard_normal((4, 4))
    L = rng.standard_normal((4, k))
    fast = np.empty_like(X)
    propagate_linear_kernel(X, F, L, np.random.default_rng(7), fast)
    slow = np.empty((N, 4), order="F")
    propagate_linear_kernel(np.asfortranarray(X), F, L, np.random.default_rng(7), slow)
    assert np.array_equal(fast, slow)
    inplace = X.copy()
    propagate_linear_kernel(inplace, F, L, np.random.default_rng(7), inplace)
    assert np.array_equal(fast, inplace)
    W = np.random.default_rng(7).standard_normal((N, k))
    for i in (0, 1, 500, N - 1):
        for a in range(4):
            s = F[a, 0] * X[i, 0] + F[a, 1] * X[i, 1] + F[a, 2] * X[i, 2] + F[a, 3] * X[i, 3]
            for c in range(k):
                s += L[a, c] * W[i, c]
            assert fast[i, a] == s


def test_propagate_noise_covariance():
    F = cv(1.0)
    Q, G = dwna(1.0, 0.8)
    X = np.zeros((200_000, 4)) + np.array([1.0, 2.0, 3.0, 4.0])
    Y = propagate_linear(X, F, None, np.random.default_rng(2), noise_factor=G)
    np.testing.assert_allclose(Y.mean(axis=0), F @ X[0], atol=0.02)
    np.testing.assert_allclose(np.cov(Y.T), Q, atol=0.01)


def test_propagate_bad_input():
    X = np.zeros((3, 4))
    with pytest.raises(TypeError, match="rng"):
        propagate_linear(X, cv(), np.eye(4), 0)
    with pytest.raises(ValueError, match="F"):
        propagate_linear(X, np.eye(3), np.eye(4), np.random.default_rng())
    with pytest.raises(ValueError, match="Q"):
        propagate_linear(X, cv(), -np.eye(4), np.random.default_rng())
    with pytest.raises(ValueError, match="particles"):
        propagate_linear(np.array([[np.nan] * 4]), cv(), np.eye(4), np.random.default_rng())
    with pytest.raises(ValueError, match="noise_factor"):
        propagate_linear(X, cv(), None, np.random.default_rng(), noise_factor=np.eye(3))
    # empty particle set is fine
    assert propagate_linear(np.zeros((0, 4)), cv(), np.eye(4), np.random.default_rng()).shape == (0, 4)


# ---------------------------------------------------------------- ESS and moments
@settings(max_examples=60, deadline=None, derandomize=True)
@given(hnp.arrays(np.float64, st.integers(1, 40), elements=st.floats(-700, 700)))
def test_ess_bounds_and_shift_invariance(logw):
    ess = effective_sample_size(logw)
    assert 1.0 - 1e-12 <= ess <= logw.size * (1 + 1e-12)
    assert effective_sample_size(logw + 123.0) == pytest.approx(ess, rel=1e-12)
    w = np.exp(logw - logw.max())
    w /= w.sum()
    assert ess == pytest.approx(1.0 / np.sum(w ** 2), rel=1e-10)


def test_ess_special_cases():
    assert effective_sample_size(np.zeros(7)) == pytest.approx(7.0)
    assert effective_sample_size([0.0, -np.inf, -np.inf]) == pytest.approx(1.0)
    assert effective_sample_size([-1e5]) == 1.0
    for bad in ([np.nan, 0.0], [np.inf, 0.0], [-np.inf, -np.inf], []):
        with pytest.raises(ValueError, match="logw"):
            effective_sample_size(bad)


def test_weighted_mean_cov_matches_numpy():
    rng = np.random.default_rng(3)
    X = rng.standard_normal((500, 3))
    logw = rng.normal(size=500) * 2 - 1000.0
    m, P = weighted_mean_cov(X, logw)
    w = np.exp(logw - logw.max())
    w /= w.sum()
    np.testing.assert_allclose(m, w @ X, atol=1e-13)
    np.testing.assert_allclose(P, np.cov(X.T, aweights=w, bias=True), atol=1e-13)
    m1, P1 = weighted_mean_cov(X[:1], [0.0])
    np.testing.assert_array_equal(m1, X[0])
    np.testing.assert_array_equal(P1, np.zeros((3, 3)))


# ---------------------------------------------------------------- resampling
@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_resampling_determinism_and_dtype(scheme):
    w = np.random.default_rng(0).random(100)
    a = SCHEMES[scheme](w, np.random.default_rng(9))
    b = SCHEMES[scheme](w, np.random.default_rng(9))
    assert a.dtype == np.int64 and a.shape == (100,)
    np.testing.assert_array_equal(a, b)
    assert a.min() >= 0 and a.max() < 100
    assert SCHEMES[scheme](w, np.random.default_rng(9), n_out=37).shape == (37,)
    assert SCHEMES[scheme](w, np.random.default_rng(9), n_out=0).shape == (0,)


@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_resampling_n_equal_one_and_degenerate(scheme):
    assert SCHEMES[scheme]([3.0], np.random.default_rng(0)).tolist() == [0]
    # all mass on one particle
    w = np.zeros(10)
    w[6] = 2.5
    np.testing.assert_array_equal(SCHEMES[scheme](w, np.random.default_rng(0)), np.full(10, 6))


@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_resampling_tiny_weights(scheme):
    w = np.array([0.0, 3e-320, 1e-320, 0.0])
    idx = SCHEMES[scheme](w, np.random.default_rng(0), n_out=1000)
    assert set(idx.tolist()) <= {1, 2}
    assert 600 < np.sum(idx == 1) < 900


@pytest.mark.parametrize("scheme", list(SCHEMES))
@pytest.mark.parametrize("bad", [[0.0, 0.0, 0.0], [0.5, np.nan], [0.5, np.inf], [0.5, -0.1], []])
def test_resampling_bad_weights(scheme, bad):
    with pytest.raises(ValueError, match="w"):
        SCHEMES[scheme](bad, np.random.default_rng(0))


@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_resampling_bad_types(scheme):
    with pytest.raises(TypeError, match="rng"):
        SCHEMES[scheme]([1.0, 2.0], 42)
    with pytest.raises(ValueError, match="n_out"):
        SCHEMES[scheme]([1.0, 2.0], np.random.default_rng(), n_out=-1)
    with pytest.raises(ValueError, match="w"):
        SCHEMES[scheme](np.ones((2, 2)), np.random.default_rng())


@settings(max_examples=25, deadline=None, derandomize=True)
@given(weights_strategy)
def test_resampling_unbiased(w):
    """E[count_i] = N w_i, checked by Monte Carlo with a 5-sigma tolerance."""
    N = w.size
    p = w / w.sum()
    reps = 1500
    for k, (name, fn) in enumerate(SCHEMES.items()):
        rng = np.random.default_rng(1000 + k)
        counts = np.zeros(N)
        for _ in range(reps):
            counts += np.bincount(fn(w, rng), minlength=N)
        mean = counts / reps
        # multinomial variance bounds the variance of every scheme here
        sd = np.sqrt(N * p * (1 - p) / reps)
        assert np.all(np.abs(mean - N * p) <= 5 * sd + 1e-9), name


@settings(max_examples=60, deadline=None, derandomize=True)
@given(weights_strategy, st.integers(0, 2 ** 32 - 1), st.integers(1, 60))
def test_count_bounds(w, seed, n_out):
    p = w / w.sum()
    for fn in (systematic_resample, residual_resample):
        c = np.bincount(fn(w, np.random.default_rng(seed), n_out=n_out), minlength=w.size)
        assert c.sum() == n_out
        assert np.all(c >= np.floor(n_out * p - 1e-9))
        assert np.all(c <= np.ceil(n_out * p + 1e-9))
    c = np.bincount(stratified_resample(w, np.random.default_rng(seed), n_out=n_out),
                    minlength=w.size)
    assert np.all(np.abs(c - n_out * p) < 2 + 1e-9)
    # zero-weight particles are never selected
    for fn in SCHEMES.values():
        idx = fn(w, np.random.default_rng(seed), n_out=n_out)
        assert np.all(p[idx] > 0)


@pytest.mark.parametrize("seed", range(5))
def test_systematic_and_stratified_equal_filterpy_with_same_uniforms(seed):
    w = np.random.default_rng(seed).random(200) ** 3
    w /= w.sum()
    np.random.seed(seed)
    fp = fpmc.systematic_resample(w)
    np.random.seed(seed)
    u0 = np.random.random()
    ours = np.empty(200, dtype=np.int64)
    systematic_indices_kernel(w, u0, ours)
    np.testing.assert_array_equal(ours, fp)
    np.random.seed(seed)
    fp = fpmc.stratified_resample(w)
    np.random.seed(seed)
    u = np.random.random(200)
    stratified_indices_kernel(w, u, ours)
    np.testing.assert_array_equal(ours, fp)


def _pooled_counts(fn, w, reps, draw):
    counts = np.zeros(w.size)
    for _ in range(reps):
        counts += np.bincount(draw(fn, w), minlength=w.size)
    return counts


def test_multinomial_distribution_agrees_with_filterpy():
    w = np.array([0.05, 0.3, 0.02, 0.13, 0.2, 0.3])
    reps = 3000
    np.random.seed(11)
    fp = _pooled_counts(fpmc.multinomial_resample, w, reps, lambda f, w: f(w))
    rng = np.random.default_rng(11)
    ours = _pooled_counts(multinomial_resample, w, reps, lambda f, w: f(w, rng))
    _, pval, _, _ = stats.chi2_contingency(np.vstack([fp, ours]))
    assert pval > 1e-4
    # per-draw count variance is the multinomial one, N w (1 - w)
    rng = np.random.default_rng(12)
    c = np.array([np.bincount(multinomial_resample(w, rng), minlength=6) for _ in range(4000)])
    np.testing.assert_allclose(c.var(axis=0), 6 * w * (1 - w), rtol=0.12)


def _filterpy_residual_fixed(w, rng):
    """filterpy 2.0.0's residual_resample with its residual bug fixed.

    filterpy normalises ``weights - num_copies``; the algorithm it cites (Liu &
    Chen 1998) uses ``N * weights - num_copies``.  With the bug the residuals are
    negative whenever some ``N w_i >= 1`` (always, as sum N w_i = N), and the
    counts are biased (e.g. w = [.31, .05, .27, .02, .35] never selects index 1).
    """
    N = len(w)
    num_copies = np.floor(N * w).astype(int)
    idx = np.repeat(np.arange(N), num_copies)
    residual = N * w - num_copies
    residual /= residual.sum()
    cs = np.cumsum(residual)
    cs[-1] = 1.0
    return np.concatenate([idx, np.searchsorted(cs, rng.random(N - idx.size))])


def test_residual_agrees_with_filterpy():
    w = np.array([0.31, 0.05, 0.27, 0.02, 0.35])
    # deterministic part: floor(N w_i) copies of i in index order, exactly as filterpy
    np.random.seed(0)
    fp = fpmc.residual_resample(w)
    ours = residual_resample(w, np.random.default_rng(0))
    k = int(np.floor(5 * w).sum())
    np.testing.assert_array_equal(ours[:k], fp[:k])
    # residual part: filterpy draws it multinomially, we systematically; the
    # marginal counts agree (compare with filterpy's algorithm, bug fixed)
    reps = 4000
    rng_fp = np.random.default_rng(3)
    fpc = _pooled_counts(_filterpy_residual_fixed, w, reps, lambda f, w: f(w, rng_fp))
    rng = np.random.default_rng(3)
    ourc = _pooled_counts(residual_resample, w, reps, lambda f, w: f(w, rng))
    _, pval, _, _ = stats.chi2_contingency(np.vstack([fpc, ourc]))
    assert pval > 1e-4
    np.testing.assert_allclose(ourc / reps, 5 * w, atol=0.03)


def test_resample_particles():
    X = np.arange(12.0).reshape(6, 2)
    with np.errstate(divide="ignore"):
        logw = np.log([0.0, 1.0, 0.0, 0.0, 3.0, 0.0]) - 500
    for scheme in SCHEMES:
        Y, lw = resample_particles(X, logw, np.random.default_rng(0), scheme=scheme)
        assert Y.shape == X.shape
        assert set(map(tuple, Y)) <= {tuple(X[1]), tuple(X[4])}
        np.testing.assert_allclose(lw, -np.log(6))
    Y, lw = resample_particles(X, logw, np.random.default_rng(0), n_out=3)
    assert Y.shape == (3, 2) and lw.shape == (3,)
    with pytest.raises(ValueError, match="scheme"):
        resample_particles(X, logw, np.random.default_rng(0), scheme="bogus")
    with pytest.raises(ValueError, match="logw"):
        resample_particles(X, np.full(6, -np.inf), np.random.default_rng(0))
    with pytest.raises(ValueError, match="logw"):
        resample_particles(X, np.zeros(5), np.random.default_rng(0))


# ---------------------------------------------------------------- likelihoods
def test_loglik_gaussian_position_matches_scipy():
    rng = np.random.default_rng(4)
    X = rng.standard_normal((40, 4)) * 3
    z = np.array([0.5, -1.0])
    R = np.array([[2.0, 0.4], [0.4, 0.7]])
    ref = stats.multivariate_normal(mean=z, cov=R).logpdf(X[:, :2])
    np.testing.assert_allclose(loglik_gaussian_position(X, z, R), ref, rtol=1e-12)
    with pytest.raises(ValueError, match="R"):
        loglik_gaussian_position(X, z, np.eye(3))
    with pytest.raises(ValueError, match="R"):
        loglik_gaussian_position(X, z, np.zeros((2, 2)))
    assert loglik_gaussian_position(np.zeros((0, 4)), z, R).shape == (0,)


def test_loglik_range_bearing_matches_scipy_and_wraps():
    rng = np.random.default_rng(5)
    X = rng.standard_normal((30, 4)) * 100
    sensor = (10.0, -20.0)
    z = np.array([80.0, 2.0])
    R = np.diag([4.0, 0.01])
    dx, dy = X[:, 0] - sensor[0], X[:, 1] - sensor[1]
    nu = np.column_stack([z[0] - np.hypot(dx, dy), z[1] - np.arctan2(dy, dx)])
    nu[:, 1] = (nu[:, 1] + np.pi) % (2 * np.pi) - np.pi
    ref = stats.multivariate_normal(mean=[0, 0], cov=R).logpdf(nu)
    np.testing.assert_allclose(loglik_range_bearing(X, z, R, sensor), ref, rtol=1e-12)
    # a particle just below +pi and a measurement just above -pi: innovation is small
    p = np.array([[-100.0, 1e-3, 0.0, 0.0]])
    zb = np.array([100.0, -np.pi + 1e-4])
    ll = loglik_range_bearing(p, zb, R)
    ref = stats.multivariate_normal(mean=[0, 0], cov=R).logpdf([0.0, 1e-4 - 1e-5])
    assert ll[0] == pytest.approx(ref, abs=1e-6)
    with pytest.raises(ValueError, match="z"):
        loglik_range_bearing(X, [1.0, 2.0, 3.0], R)
    with pytest.raises(ValueError, match="sensor"):
        loglik_range_bearing(X, z, R, sensor=(1.0,))


@pytest.mark.parametrize("n, order", [(4, "C"), (4, "F"), (6, "C")])
def test_bootstrap_weighting_gives_the_loglik_bits(n, order):
    """The bootstrap step weighs range-bearing particles in two passes (atan2 only, then a
    call-free, vectorised pass); it must add exactly the bits of the one-loop
    loglik_range_bearing, wrapped bearing innovations included."""
    from trackcore.filters.particle import _inv_logdet, _weigh_range
    rng = np.random.default_rng(4)
    N = 3001
    X = np.zeros((N, n))
    X[:, :2] = [-1000.0, 0.0] + 40.0 * rng.standard_normal((N, 2))  # bearings around +-pi
    X[:, 2:] = rng.standard_normal((N, n - 2))
    X = np.asarray(X, order=order)
    z = np.array([1010.0, np.pi - 0.005])
    R = np.array([[90.0, 0.02], [0.02, 4e-4]])
    sensor = (3.0, -2.0)
    logw = rng.standard_normal(N)
    ref = logw + loglik_range_bearing(np.ascontiguousarray(X), z, R, sensor)
    Rinv, logdet = _inv_logdet(R)
    out = logw.copy()
    top = _weigh_range(X, 0, N, z, Rinv, -0.5 * (2 * math.log(2 * math.pi) + logdet), 1,
                       *sensor, out)
    assert np.array_equal(out, ref)
    assert top == ref.max()
    wrapped = np.abs(z[1] - np.arctan2(X[:, 1] - sensor[1], X[:, 0] - sensor[0])) > np.pi
    assert 0.2 < wrapped.mean() < 0.8


def test_loglik_parallel_path_equals_serial_path():
    rng = np.random.default_rng(6)
    X = rng.standard_normal((50_000, 4)) * 100  # above the prange threshold
    z = np.array([120.0, 0.3])
    R = np.diag([4.0, 0.01])
    full = loglik_range_bearing(X, z, R, parallel=True)
    parts = np.concatenate([loglik_range_bearing(X[i:i + 10_000], z, R)
                            for i in range(0, 50_000, 10_000)])
    np.testing.assert_array_equal(full, parts)
    fullp = loglik_gaussian_position(X, z, R, parallel=True)
    partsp = np.concatenate([loglik_gaussian_position(X[i:i + 10_000], z, R)
                             for i in range(0, 50_000, 10_000)])
    np.testing.assert_array_equal(fullp, partsp)


# ---------------------------------------------------------------- fused bootstrap step
def _composed_step(X, logw, F, L, z, R, rng, sensor=(0.0, 0.0)):
    Xp = propagate_linear(X, F, None, rng, noise_factor=L)
    lw = logw - np.logaddexp.reduce(logw)
    lw = lw + loglik_range_bearing(Xp, z, R, sensor)
    lev = np.logaddexp.reduce(lw)
    lw -= lev
    ess = 1.0 / np.sum(np.exp(2 * lw))
    idx = systematic_resample(np.exp(lw), rng)
    return Xp[idx], lev, ess


@pytest.mark.parametrize("N", [1, 7, 1000, 30_000])
def test_bootstrap_step_equals_composition(N):
    rng0 = np.random.default_rng(8)
    X = rng0.normal(size=(N, 4)) * [10, 10, 1, 1] + [100, 50, 1, -1]
    logw = rng0.normal(size=N)
    F = cv(1.0)
    _, L = dwna(1.0, 0.5)
    z = np.array([112.0, 0.45])
    R = np.diag([4.0, 0.003])
    ref_X, ref_lev, ref_ess = _composed_step(X, logw, F, L, z, R, np.random.default_rng(21),
                                             sensor=(1.0, 2.0))
    Xw, lw = X.copy(), logw.copy()
    res = bootstrap_step(Xw, lw, F, L, z, R, np.random.default_rng(21), sensor=(1.0, 2.0))
    assert res.particles is Xw and res.logw is lw  # updated in place
    assert res.resampled
    np.testing.assert_allclose(Xw, ref_X, rtol=0, atol=1e-9)
    np.testing.assert_allclose(lw, -np.log(N))
    assert res.log_evidence == pytest.approx(ref_lev, rel=1e-10, abs=1e-10)
    assert res.ess == pytest.approx(ref_ess, rel=1e-9)
    # determinism, serial and threaded
    for parallel in (False, True):
        X2, lw2 = X.copy(), logw.copy()
        r2 = bootstrap_step(X2, lw2, F, L, z, R, np.random.default_rng(21), sensor=(1.0, 2.0),
                            parallel=parallel)
        np.testing.assert_array_equal(X2, Xw)
        assert r2.log_evidence == res.log_evidence and r2.ess == res.ess


def test_bootstrap_step_empty_scan_and_threshold():
    rng0 = np.random.default_rng(9)
    X = rng0.normal(size=(100, 4))
    logw = rng0.normal(size=100)
    F = cv(1.0)
    _, L = dwna(1.0, 0.5)
    Xw, lw = X.copy(), logw.copy()
    res = bootstrap_step(Xw, lw, F, L, [], np.eye(2), np.random.default_rng(1), ess_threshold=0.0)
    assert not res.resampled and res.log_evidence == 0.0
    np.testing.assert_allclose(lw, logw - np.logaddexp.reduce(logw), atol=1e-14)
    np.testing.assert_allclose(Xw, propagate_linear(X, F, None, np.random.default_rng(1),
                                                    noise_factor=L), atol=1e-12)
    # empty scan with the default threshold resamples the prior weights
    res = bootstrap_step(X.copy(), logw.copy(), F, L, np.zeros(0), None, np.random.default_rng(1))
    assert res.resampled and res.ess == pytest.approx(effective_sample_size(logw))


def test_bootstrap_pf_tracks_kalman_filter_posterior():
    """Linear-Gaussian position model: the bootstrap PF mean approaches the KF mean."""
    rng = np.random.default_rng(10)
    F = cv(1.0)
    Q, L = dwna(1.0, 0.2)
    H = np.eye(2, 4)
    R = np.eye(2) * 4.0
    x_true = np.array([0.0, 0.0, 1.0, 0.5])
    m, P = x_true.copy(), np.diag([4.0, 4.0, 1.0, 1.0])
    N = 40_000
    X = rng.multivariate_normal(m, P, size=N)
    logw = np.zeros(N)
    scratch = np.empty_like(X)
    for _ in range(10):
        x_true = F @ x_true + L @ rng.standard_normal(2)
        z = H @ x_true + rng.multivariate_normal([0, 0], R)
        m, P = F @ m, F @ P @ F.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        m, P = m + K @ (z - H @ m), (np.eye(4) - K @ H) @ P
        bootstrap_step(X, logw, F, L, z, R, rng, model="position", scratch=scratch)
        pm, pP = weighted_mean_cov(X, logw)
        sd = np.sqrt(np.diag(P))
        assert np.all(np.abs(pm - m) < 0.1 * sd + 4 * sd / np.sqrt(N) * 5)
        np.testing.assert_allclose(np.diag(pP), np.diag(P), rtol=0.1)


def test_bootstrap_step_bad_input():
    X = np.zeros((5, 4))
    lw = np.zeros(5)
    F, (_, L) = cv(), dwna(1.0, 1.0)
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="model"):
        bootstrap_step(X, lw, F, L, [1.0, 0.0], np.eye(2), rng, model="sonar")
    with pytest.raises(ValueError, match="z"):
        bootstrap_step(X, lw, F, L, [1.0, 0.0, 1.0], np.eye(3), rng)
    with pytest.raises(ValueError, match="logw"):
        bootstrap_step(X, np.zeros(4), F, L, [1.0, 0.0], np.eye(2), rng)
    with pytest.raises(ValueError, match="logw"):
        bootstrap_step(X, np.full(5, np.nan), F, L, [1.0, 0.0], np.eye(2), rng)
    with pytest.raises(ValueError, match="ess_threshold"):
        bootstrap_step(X, lw, F, L, [1.0, 0.0], np.eye(2), rng, ess_threshold=1.5)
    with pytest.raises(ValueError, match="R"):
        bootstrap_step(X, lw, F, L, [1.0, 0.0], -np.eye(2), rng)
    with pytest.raises(ValueError, match="particles"):
        bootstrap_step(np.zeros((0, 4)), np.zeros(0), F, L, [1.0, 0.0], np.eye(2), rng)
    with pytest.raises(TypeError, match="rng"):
        bootstrap_step(X, lw, F, L, [1.0, 0.0], np.eye(2), None)
    with pytest.raises(ValueError, match="L"):
        bootstrap_step(X, lw, F, np.ones((4, 5)), [1.0, 0.0], np.eye(2), rng)
    with pytest.raises(ValueError, match="scratch"):
        bootstrap_step(X, lw, F, L, [1.0, 0.0], np.eye(2), rng, scratch=np.empty((4, 4)))
    with pytest.raises(ValueError, match="scratch must not overlap"):
        bootstrap_step(X, lw, F, L, [1.0, 0.0], np.eye(2), rng, scratch=X)


def test_bootstrap_step_fast_validation_paths():
    """The cheap per-argument paths (plain float64 arrays, memoised R^-1) give the
    same results as the full checks, and still reject bad input."""
    F, (_, L) = cv(), dwna(1.0, 1.0)
    X0 = np.random.default_rng(3).normal(size=(50, 4)) * 10 + [100.0, 50.0, 1.0, 1.0]
    z = np.array([112.0, 0.46])
    outs = []
    for conv in (lambda a: a, lambda a: a.tolist()):   # plain arrays vs lists (full path)
        X, lw = X0.copy(), np.zeros(50)
        R = np.diag([4.0, 1e-3])
        r = bootstrap_step(conv(X), conv(lw), conv(F), conv(L), conv(z), conv(R),
                           np.random.default_rng(1))
        outs.append((r.particles.copy(), r.logw.copy(), r.log_evidence, r.ess))
    np.testing.assert_array_equal(outs[0][0], outs[1][0])
    np.testing.assert_array_equal(outs[0][1], outs[1][1])
    assert outs[0][2:] == outs[1][2:]
    # a different R after a cached one is not confused with it
    r1 = bootstrap_step(X0.copy(), np.zeros(50), F, L, z, np.diag([4.0, 1e-3]),
                        np.random.default_rng(1))
    r2 = bootstrap_step(X0.copy(), np.zeros(50), F, L, z, np.diag([9.0, 1e-3]),
                        np.random.default_rng(1))
    assert r1.log_evidence != r2.log_evidence
    # bad inputs after the good ones were cached
    with pytest.raises(ValueError, match="R"):
        bootstrap_step(X0.copy(), np.zeros(50), F, L, z, np.diag([4.0, -1e-3]),
                       np.random.default_rng(1))
    bad = X0.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="particles"):
        bootstrap_step(bad, np.zeros(50), F, L, z, np.eye(2), np.random.default_rng(1))
    lw = np.zeros(50)
    lw[:10] = -np.inf                  # -inf entries are valid (zero weight): full path
    r = bootstrap_step(X0.copy(), lw, F, L, z, np.eye(2), np.random.default_rng(1))
    assert np.all(np.isfinite(r.logw))
    with pytest.raises(ValueError, match="z"):
        bootstrap_step(X0.copy(), np.zeros(50), F, L, np.array([np.inf, 0.0]), np.eye(2),
                       np.random.default_rng(1))
    with pytest.raises(ValueError, match="F"):
        bootstrap_step(X0.copy(), np.zeros(50), F * np.nan, L, z, np.eye(2),
                       np.random.default_rng(1))
    r = bootstrap_step(X0.copy(), np.zeros(50), F, L, z, np.eye(2), np.random.default_rng(1),
                       sensor=np.array([0.0, 0.0]), ess_threshold=np.float64(1.0))
    assert r.resampled


def test_kernels_link_into_a_fresh_callers_kernel(tmp_path):
    """A user's njit loop calling the cached kernels must compile in a fresh process
    (a cached parallel=True callee would abort LLVM there; see particle.py)."""
    import subprocess
    import sys
    import textwrap
    code = textwrap.dedent("""
        import numba as nb, numpy as np
        from trackcore.filters.particle import bootstrap_step_kernel
        @nb.njit
        def run(X, lw, F, L, z, Rinv, rng, sc):
            for _ in range(3):
                bootstrap_step_kernel(X, lw, F, L, z, Rinv, 0.0, 1, 0.0, 0.0, rng, 1.0, sc)
            return X[0, 0]
        X = np.ones((50, 4)); F = np.eye(4); L = np.eye(4)[:, :2]
        print(run(X, np.zeros(50), F, L, np.array([1.0, 0.5]), np.eye(2),
                  np.random.default_rng(0), np.empty((50, 4))))
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]


# ---------------------------------------------------------------- non-finite (issue 17)
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_bootstrap_far_particle_gets_zero_weight_never_nan():
    F, L = cv(), dwna(1.0, 0.5)[1]
    rng = np.random.default_rng(0)
    for model, z, R in (("range_bearing", np.array([120.0, 0.4]), np.diag([25.0, 1e-3])),
                        ("position", np.array([100.0, 50.0]), 4.0 * np.eye(2))):
        X = np.array([100.0, 50.0, 1.0, 0.5]) + rng.normal(0, 5, (50, 4))
        X[3, :2] = [1e300, -1e300]
        res = bootstrap_step(X, np.zeros(50), F, L, z, R, rng, model, ess_threshold=0.0)
        assert res.logw[3] == -np.inf and np.all(np.isfinite(np.delete(res.logw, 3)))
        assert math.isfinite(res.ess) and math.isfinite(res.log_evidence)
        res = bootstrap_step(X, np.zeros(50), F, L, z, R, rng, model)  # resampled away
        assert np.all(np.isfinite(res.logw)) and np.all(np.abs(res.particles) < 1e6)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_bootstrap_raises_when_no_particle_has_likelihood():
    F, L = cv(), dwna(1.0, 0.5)[1]
    X = np.full((10, 4), 1e300)
    with pytest.raises(ValueError, match="every particle has likelihood zero"):
        bootstrap_step(X, np.zeros(10), F, np.zeros((4, 0)), [1.0, 0.5], np.eye(2),
                       np.random.default_rng(1))
    with pytest.raises(ValueError, match="overflow"):
        bootstrap_step(np.full((10, 4), 1e308), np.zeros(10), 10.0 * F, L, [], np.eye(2),
                       np.random.default_rng(1))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_logliks_are_minus_inf_not_nan_and_weights_skip_zero_mass():
    X = np.array([[1e300, -1e300, 0.0, 0.0], [10.0, 10.0, 0.0, 0.0]])
    for ll in (loglik_range_bearing(X, [14.0, 0.8], np.diag([4.0, 0.01])),
               loglik_gaussian_position(X, [10.0, 10.0], np.eye(2))):
        assert ll[0] == -np.inf and math.isfinite(ll[1])
    m, P = weighted_mean_cov(X, [-np.inf, 0.0])
    np.testing.assert_array_equal(m, X[1])
    assert np.all(P == 0.0)
    with pytest.raises(ValueError, match="overflows"):
        weighted_mean_cov(X, [0.0, 0.0])
    with pytest.raises(ValueError, match="overflows"):
        propagate_linear(np.full((3, 4), 1e308), 10.0 * cv(), np.zeros((4, 4)),
                         np.random.default_rng(0))
    idx = systematic_resample(np.array([1e308, 1e308, 1e308]), np.random.default_rng(0))
    assert sorted(idx.tolist()) == [0, 1, 2]
