"""Tests for trackcore.metrics: hand-computed cases, edge cases, properties, bad input."""
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra import numpy as hnp
from scipy.stats import chi2

from trackcore.metrics import (cardinality_error, chi2_bounds, gospa, nees, nis, ospa,
                               position_rmse, rmse, velocity_rmse)


# ----------------------------------------------------------------------------- RMSE

def test_rmse_hand_computed():
    est = np.array([[1.0, 2.0], [3.0, 4.0]])
    truth = np.array([0.0, 0.0])
    np.testing.assert_allclose(rmse(est, truth), [math.sqrt(5.0), math.sqrt(10.0)])
    assert rmse(est, truth, axis=None) == pytest.approx(math.sqrt(30.0 / 4))


def test_position_rmse_over_runs_per_step():
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(5, 4))
    est = truth + rng.normal(size=(200, 5, 4))
    got = position_rmse(est, truth)
    want = np.sqrt(np.mean((est[..., 0] - truth[:, 0]) ** 2 + (est[..., 1] - truth[:, 1]) ** 2,
                           axis=0))
    assert got.shape == (5,)
    np.testing.assert_allclose(got, want, rtol=1e-14)
    wantv = np.sqrt(np.mean(np.sum((est[..., 2:] - truth[:, 2:]) ** 2, -1), axis=0))
    np.testing.assert_allclose(velocity_rmse(est, truth), wantv, rtol=1e-14)
    # 3-D: positions are the first three components.
    e3 = np.zeros((2, 6)); e3[:, :3] = [1.0, 2.0, 2.0]
    np.testing.assert_allclose(position_rmse(e3, np.zeros(6), dim=3), [3.0, 3.0])
    assert position_rmse(e3[0], np.zeros(6), dim=3) == pytest.approx(3.0)


def test_rmse_bad_input():
    with pytest.raises(ValueError, match="est"):
        rmse(np.zeros((3, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="truth"):
        rmse(np.zeros(2), [np.nan, 0.0])
    with pytest.raises(ValueError, match="est"):
        velocity_rmse(np.zeros((3, 3)), np.zeros(3), dim=2)
    with pytest.raises(ValueError, match="axis"):
        rmse(np.zeros((3, 2)), np.zeros(2), axis=4)
    with pytest.raises(TypeError, match="est"):
        rmse("abc", np.zeros(2))


# ----------------------------------------------------------------------------- NEES / NIS

def test_nees_nis_hand_computed_and_batched():
    P = np.array([[4.0, 0.0], [0.0, 1.0]])
    assert nees([2.0, 1.0], P) == pytest.approx(2.0)
    S = np.array([[2.0, 1.0], [1.0, 2.0]])
    nu = np.array([1.0, -1.0])
    assert nis(nu, S) == pytest.approx(nu @ np.linalg.solve(S, nu))
    rng = np.random.default_rng(1)
    A = rng.normal(size=(7, 3, 3))
    Ps = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(3)
    e = rng.normal(size=(7, 3))
    want = np.array([e[i] @ np.linalg.solve(Ps[i], e[i]) for i in range(7)])
    np.testing.assert_allclose(nees(e, Ps), want, rtol=1e-10)
    # broadcasting: (runs, steps, n) errors against one (n, n) covariance
    e2 = rng.normal(size=(4, 5, 3))
    out = nees(e2, Ps[0])
    assert out.shape == (4, 5)
    assert out[2, 3] == pytest.approx(e2[2, 3] @ np.linalg.solve(Ps[0], e2[2, 3]))


def test_nees_is_chi2_distributed():
    rng = np.random.default_rng(2)
    P = np.array([[2.0, 0.5], [0.5, 1.0]])
    e = rng.multivariate_normal(np.zeros(2), P, size=20000)
    assert abs(np.mean(nees(e, P)) - 2.0) < 0.06


def test_nees_bad_input():
    with pytest.raises(ValueError, match="P"):
        nees([1.0, 2.0], np.eye(3))
    with pytest.raises(ValueError, match="P"):
        nees([1.0, 2.0], [[1.0, 0.0], [0.0, -1.0]])
    with pytest.raises(ValueError, match="P"):
        nees([1.0, 2.0], [[1.0, 0.5], [0.0, 1.0]])
    with pytest.raises(ValueError, match="x_err"):
        nees([np.nan, 2.0], np.eye(2))
    with pytest.raises(ValueError, match="S"):
        nis([1.0], [[np.inf]])
    with pytest.raises(ValueError, match="nu"):
        nis(np.zeros((3, 2)), np.broadcast_to(np.eye(2), (4, 2, 2)))


def test_chi2_bounds():
    lo, hi = chi2_bounds(2, 1)
    assert lo == pytest.approx(chi2.ppf(0.025, 2)) and hi == pytest.approx(chi2.ppf(0.975, 2))
    lo, hi = chi2_bounds(4, 50, alpha=0.01)
    assert lo == pytest.approx(chi2.ppf(0.005, 200) / 50)
    assert hi == pytest.approx(chi2.ppf(0.995, 200) / 50)
    assert lo < 4 < hi
    # chi-square table: chi2(100) 2.5 % / 97.5 % = 74.2 / 129.6, divided by N = 50
    lo, hi = chi2_bounds(2, 50)
    assert round(lo, 1) == 1.5 and round(hi, 1) == 2.6
    for bad, exc in ((0, ValueError), (1.5, TypeError)):
        with pytest.raises(exc, match="dof"):
            chi2_bounds(bad, 10)
    with pytest.raises(ValueError, match="n_runs"):
        chi2_bounds(2, 0)
    with pytest.raises(ValueError, match="alpha"):
        chi2_bounds(2, 10, alpha=1.0)


# ----------------------------------------------------------------------------- OSPA

def _brute_ospa(X, Y, c, p):
    X, Y = np.asarray(X, float).reshape(-1, 2), np.asarray(Y, float).reshape(-1, 2)
    if len(X) > len(Y):
        X, Y = Y, X
    m, n = len(X), len(Y)
    if n == 0:
        return 0.0
    best = np.inf
    for perm in itertools.permutations(range(n), m):
        s = sum(min(c, np.linalg.norm(X[i] - Y[j])) ** p for i, j in enumerate(perm))
        best = min(best, s)
    return ((best + c ** p * (n - m)) / n) ** (1 / p)


def _brute_gospa(X, Y, c, p, alpha):
    X, Y = np.asarray(X, float).reshape(-1, 2), np.asarray(Y, float).reshape(-1, 2)
    if len(X) > len(Y):
        X, Y = Y, X
    m, n = len(X), len(Y)
    best = 0.0 if m == 0 else np.inf
    for perm in itertools.permutations(range(n), m):
        s = sum(min(c, np.linalg.norm(X[i] - Y[j])) ** p for i, j in enumerate(perm))
        best = min(best, s)
    return (best + c ** p / alpha * (n - m)) ** (1 / p)


def test_ospa_hand_computed():
    # one pair at distance 5, one extra point: ((5^1 + 10^1 * 1) / 2)^(1/1) = 7.5
    r = ospa([[0.0, 0.0]], [[3.0, 4.0], [100.0, 0.0]], c=10.0, p=1)
    assert r.distance == pytest.approx(7.5)
    assert r.localisation == pytest.approx(2.5)
    assert r.cardinality == pytest.approx(5.0)
    # p = 2: ((25 + 100)/2)^(1/2)
    r = ospa([[0.0, 0.0]], [[3.0, 4.0], [100.0, 0.0]], c=10.0, p=2)
    assert r.distance == pytest.approx(math.sqrt(62.5))
    assert r.distance ** 2 == pytest.approx(r.localisation ** 2 + r.cardinality ** 2)
    # cut-off: distance above c counts as c
    assert ospa([[0.0, 0.0]], [[30.0, 40.0]], c=10.0).distance == pytest.approx(10.0)


def test_ospa_uses_p_th_power_assignment():
    # 1-D X = {0, 1}, Y = {1, 3}: pairings with distances (1, 2) and (3, 0) tie in
    # the sum of distances but not in the sum of squares, so p = 2 must give sqrt(5 / 2).
    X = np.array([[0.0, 0.0], [1.0, 0.0]])
    Y = np.array([[1.0, 0.0], [3.0, 0.0]])
    assert ospa(X, Y, c=50.0, p=2).distance == pytest.approx(math.sqrt(5.0 / 2.0))
    assert ospa(X, Y, c=50.0, p=1).distance == pytest.approx(1.5)
    rng = np.random.default_rng(3)
    for _ in range(60):
        X = rng.uniform(0, 5, (rng.integers(0, 5), 2))
        Y = rng.uniform(0, 5, (rng.integers(0, 5), 2))
        for p in (1, 2.5):
            assert ospa(X, Y, 3.0, p).distance == pytest.approx(_brute_ospa(X, Y, 3.0, p),
                                                                abs=1e-12)


def test_ospa_empty_sets():
    assert ospa([], [], c=5.0) == (0.0, 0.0, 0.0)
    assert ospa(np.zeros((0, 2)), np.zeros((0, 2)), c=5.0, p=2).distance == 0.0
    assert ospa([], [[1.0, 2.0]], c=5.0).distance == 5.0
    assert ospa(np.zeros((3, 2)), [], c=5.0, p=3).distance == 5.0
    assert ospa([], [], c=5.0, p=np.inf).distance == 0.0


def test_ospa_p_inf():
    X = np.array([[0.0, 0.0], [5.0, 5.0]])
    Y = np.array([[0.0, 1.0], [5.0, 7.0]])
    assert ospa(X, Y, 10.0, np.inf).distance == pytest.approx(2.0)
    assert ospa(X, Y[:1], 10.0, np.inf).distance == 10.0
    # minimax pairing differs from the min-sum pairing here
    X = np.array([[0.0], [1.0]]) * np.array([[1.0, 0.0]])
    Y = np.array([[1.0, 0.0], [3.0, 0.0]])
    # pairs: {0-1,1-3}: max 2 ; {0-3,1-1}: max 3 -> 2
    assert ospa(X, Y, 10.0, np.inf).distance == pytest.approx(2.0)


def test_gospa_hand_computed_and_decomposition():
    X = [[0.0, 0.0], [1.0, 1.0]]          # estimates
    Y = [[3.0, 4.0]]                      # truth
    r = gospa(X, Y, c=10.0, p=2)          # (1,1)-(3,4): 13; one false: 100/2
    assert r.distance == pytest.approx(math.sqrt(63.0))
    assert (r.localisation, r.missed, r.false) == pytest.approx((13.0, 0.0, 50.0))
    assert (r.n_missed, r.n_false) == (0, 1)
    # a pair beyond the cut-off is one missed plus one false target
    r = gospa([[0.0, 0.0]], [[30.0, 0.0]], c=10.0, p=1)
    assert (r.distance, r.localisation, r.missed, r.false) == pytest.approx((10.0, 0.0, 5.0, 5.0))
    assert (r.n_missed, r.n_false) == (1, 1)
    # alpha = 1: unassigned points cost c^p each
    r = gospa([[0.0, 0.0]], [[0.0, 1.0], [50.0, 0.0]], c=4.0, p=1, alpha=1)
    assert r.distance == pytest.approx(1.0 + 4.0)
    assert (r.n_missed, r.n_false) == (1, 0)


def test_gospa_empty_sets():
    assert gospa([], [], c=2.0).distance == 0.0
    r = gospa([], [[0.0, 0.0], [1.0, 1.0]], c=2.0, p=2)
    assert r.distance == pytest.approx(math.sqrt(2 * 4.0 / 2))
    assert (r.missed, r.n_missed, r.false) == (4.0, 2, 0.0)
    r = gospa(np.zeros((3, 2)), np.zeros((0, 2)), c=2.0, p=1)
    assert (r.false, r.n_false, r.distance) == (3.0, 3, 3.0)


def test_gospa_matches_brute_force():
    rng = np.random.default_rng(4)
    for _ in range(60):
        X = rng.uniform(0, 5, (rng.integers(0, 5), 2))
        Y = rng.uniform(0, 5, (rng.integers(0, 5), 2))
        for p, alpha in ((1, 2), (2, 2), (2, 1), (3, 0.5)):
            r = gospa(X, Y, 2.0, p, alpha)
            assert r.distance == pytest.approx(_brute_gospa(X, Y, 2.0, p, alpha), abs=1e-12)
            assert r.distance ** p == pytest.approx(r.localisation + r.missed + r.false)


points = hnp.arrays(np.float64, st.tuples(st.integers(0, 4), st.just(2)),
                    elements=st.floats(-20, 20, allow_nan=False))


@settings(max_examples=150, deadline=None)
@given(points, points, points, st.sampled_from([1.0, 2.0, 3.0]), st.floats(0.5, 30))
def test_ospa_is_a_metric(X, Y, Z, p, c):
    dxy = ospa(X, Y, c, p).distance
    assert dxy == pytest.approx(ospa(Y, X, c, p).distance, abs=1e-12)   # symmetry
    assert 0.0 <= dxy <= c + 1e-12                                        # bounded by c
    assert ospa(X, X, c, p).distance == pytest.approx(0.0, abs=1e-12)    # identity
    assert dxy <= ospa(X, Z, c, p).distance + ospa(Z, Y, c, p).distance + 1e-9  # triangle


@settings(max_examples=100, deadline=None)
@given(points, points, points, st.sampled_from([1.0, 2.0]), st.floats(0.5, 30))
def test_gospa_is_a_metric(X, Y, Z, p, c):
    dxy = gospa(X, Y, c, p).distance
    assert dxy == pytest.approx(gospa(Y, X, c, p).distance, abs=1e-12)
    assert dxy <= gospa(X, Z, c, p).distance + gospa(Z, Y, c, p).distance + 1e-9


def test_set_metrics_bad_input():
    X = np.zeros((2, 2))
    for f in (ospa, gospa):
        with pytest.raises(ValueError, match="c"):
            f(X, X, c=0.0)
        with pytest.raises(ValueError, match="c"):
            f(X, X, c=-1.0)
        with pytest.raises(ValueError, match="p"):
            f(X, X, c=1.0, p=0.5)
        with pytest.raises(ValueError, match="same point dimension"):
            f(X, np.zeros((2, 3)), c=1.0)
        with pytest.raises(ValueError, match="Y"):
            f(X, [[np.nan, 0.0]], c=1.0)
        with pytest.raises(ValueError, match="X"):
            f(np.zeros((2, 2, 2)), X, c=1.0)
        with pytest.raises(TypeError, match="c"):
            f(X, X, c="1")
    for a in (0.0, 2.5, -1.0):
        with pytest.raises(ValueError, match="alpha"):
            gospa(X, X, c=1.0, alpha=a)
    with pytest.raises(ValueError, match="p"):
        gospa(X, X, c=1.0, p=np.inf)


# ----------------------------------------------------------------------------- cardinality

def test_cardinality_error():
    est = np.array([[1, 2, 3], [3, 2, 1]])
    true = np.array([2, 2, 2])
    s, e = cardinality_error(est, true)
    np.testing.assert_allclose(s, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(e, [1.0, 0.0, 1.0])
    r = cardinality_error([3.5, 1.0], [2, 2], axis=None)
    assert (r.bias, r.mae) == pytest.approx((0.25, 1.25))
    with pytest.raises(ValueError, match="est_counts"):
        cardinality_error([-1, 2], [2, 2])
    with pytest.raises(ValueError, match="true_counts"):
        cardinality_error([1, 2], [np.nan, 2])
    with pytest.raises(ValueError, match="est_counts"):
        cardinality_error(np.zeros((2, 3)), np.zeros(4))


# ----------------------------------------------------------------------------- numba kernels

def test_min_cost_assignment_kernel_matches_scipy():
    from scipy.optimize import linear_sum_assignment

    from trackcore.metrics import min_cost_assignment_kernel

    rng = np.random.default_rng(5)
    for trial in range(300):
        r = int(rng.integers(1, 9))
        k = int(rng.integers(r, 11))
        if trial % 3 == 0:
            cost = rng.integers(0, 4, size=(r, k)).astype(float)   # many ties
        else:
            cost = rng.exponential(size=(r, k))
        cols = np.full(r, -1, dtype=np.int64)
        total = min_cost_assignment_kernel(cost, cols)
        rows_s, cols_s = linear_sum_assignment(cost)
        assert total == pytest.approx(cost[rows_s, cols_s].sum(), rel=1e-12, abs=1e-12)
        assert len(set(cols.tolist())) == r and cols.min() >= 0 and cols.max() < k
        assert total == pytest.approx(cost[np.arange(r), cols].sum(), rel=1e-12, abs=1e-12)


def test_kernels_callable_from_numba():
    import numba as nb

    from trackcore.metrics import gospa_kernel, ospa_kernel

    @nb.njit
    def per_scan(Xs, Ys, c):
        out = np.empty((Xs.shape[0], 2))
        for k in range(Xs.shape[0]):
            out[k, 0] = ospa_kernel(Xs[k], Ys[k], c, 2.0)[0]
            out[k, 1] = gospa_kernel(Xs[k], Ys[k], c, 2.0, 2.0)[0]
        return out

    rng = np.random.default_rng(6)
    Xs, Ys = rng.normal(size=(4, 3, 2)), rng.normal(size=(4, 3, 2))
    got = per_scan(Xs, Ys, 1.5)
    for k in range(4):
        assert got[k, 0] == pytest.approx(_brute_ospa(Xs[k], Ys[k], 1.5, 2), abs=1e-12)
        assert got[k, 1] == pytest.approx(_brute_gospa(Xs[k], Ys[k], 1.5, 2, 2), abs=1e-12)


# --------------------------------------------------------------------------- scale (issue 17)
def test_ospa_scaled_form_equals_plain_powers():
    """The scaled form (used for large p or extreme c) gives the plain form's values."""
    from trackcore.metrics import _ospa_scaled_kernel, ospa_kernel
    rng = np.random.default_rng(17)
    for _ in range(200):
        X = rng.uniform(0, 5, (rng.integers(0, 5), 2))
        Y = rng.uniform(0, 5, (rng.integers(0, 5), 2))
        for p in (1.0, 2.0, 3.5):
            a = ospa_kernel(X, Y, 3.0, p)
            b = _ospa_scaled_kernel(X, Y, 3.0, p)
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("p", [1.0, 2.0, 25.0, 300.0, 1e300])
def test_ospa_scales_with_the_coordinates(p):
    rng = np.random.default_rng(int(min(p, 1e3)))
    X, Y = rng.uniform(0, 5, (3, 2)), rng.uniform(0, 5, (4, 2))
    ref = ospa(X, Y, 3.0, p)
    assert all(math.isfinite(v) for v in ref)
    for s in (1e-200, 1e200):
        got = ospa(s * X, s * Y, s * 3.0, p)
        np.testing.assert_allclose(np.array(got) / s, np.array(ref), rtol=1e-9)


def test_ospa_large_p_tends_to_the_largest_assigned_distance():
    X = np.array([[0.0, 0.0], [10.0, 0.0]])
    Y = np.array([[0.0, 1.0], [10.0, 3.0]])
    assert ospa(X, Y, 50.0, 1e4).distance == pytest.approx(3.0, rel=1e-3)
    assert ospa(X, Y, 50.0, 1e300).distance == pytest.approx(3.0, rel=1e-12)
    assert ospa(X, Y, 50.0, np.inf).distance == pytest.approx(3.0)


def test_gospa_large_p_and_unrepresentable_components():
    from trackcore.metrics import _gospa_scaled, gospa_kernel
    rng = np.random.default_rng(3)
    for _ in range(100):
        X = rng.uniform(0, 5, (rng.integers(0, 4), 2))
        Y = rng.uniform(0, 5, (rng.integers(0, 4), 2))
        for alpha in (2.0, 1.0):
            a = gospa_kernel(X, Y, 2.0, 3.0, alpha)
            b = _gospa_scaled(X, Y, 2.0, 3.0, alpha)
            np.testing.assert_allclose(b[:4], a[:4], rtol=1e-10, atol=1e-12)
            assert tuple(b[4:]) == tuple(a[4:])
    X = np.array([[0.0, 0.0], [1.0, 1.0]])
    Y = np.array([[0.5, 0.0], [1.0, 1.2]])
    r = gospa(X, Y, 1.0, 300.0)
    assert r.distance == pytest.approx(0.5 * (1 + 0.4 ** 300) ** (1 / 300), rel=1e-12)
    for c, p in ((100.0, 300.0), (1e300, 2.0), (1e-300, 2.0)):
        with pytest.raises(ValueError, match="distance\\*\\*p"):
            gospa(X, Y, c, p)


@pytest.mark.parametrize("bad", [np.nan, -np.inf, 0.5, -1.0])
def test_set_metric_order_rejected(bad):
    for f in (ospa, gospa):
        with pytest.raises(ValueError, match="p must"):
            f([[0.0, 0.0]], [[1.0, 1.0]], 5.0, bad)
    for c in (np.nan, np.inf, 0.0, -1.0):
        for f in (ospa, gospa):
            with pytest.raises(ValueError, match="c must"):
                f([[0.0, 0.0]], [[1.0, 1.0]], c, 2.0)


def test_rmse_and_quadratic_forms_at_extreme_scales():
    est = np.array([[1e300, 0.0], [0.0, 1e300]])
    truth = np.zeros(2)
    np.testing.assert_allclose(rmse(est, truth), [1e300 / math.sqrt(2)] * 2, rtol=1e-12)
    assert position_rmse(est, truth, dim=2, axis=None) == pytest.approx(1e300, rel=1e-12)
    assert rmse([[1.0, 2.0]], [[0.0, 0.0]]).tolist() == [1.0, 2.0]   # unchanged in range
    with pytest.raises(ValueError, match="overflows"):
        nees([1e300, 0.0], np.eye(2))
    with pytest.raises(ValueError, match="overflows"):
        nis([1e200], [[1e-200]])


def test_chi2_bounds_tiny_alpha_is_finite():
    lo, hi = chi2_bounds(2, 50, 1e-300)
    assert 0.0 <= lo < 2.0 < hi < np.inf
    assert chi2_bounds(2, 50) == (chi2.ppf(0.025, 100) / 50, chi2.ppf(0.975, 100) / 50)
