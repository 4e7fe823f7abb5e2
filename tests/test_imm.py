"""Tests for trackcore.filters.imm."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from trackcore.filters import (IMMRun, IMMStep, imm_combine, imm_filter_run, imm_mix,
                               imm_mode_update, imm_step, kf_predict, kf_update)
from trackcore.models import (coordinated_turn_transition, cv_process_noise, cv_transition,
                              position_matrix)


def two_mode_problem():
    T = 1.0
    Fs = np.stack([cv_transition(T), coordinated_turn_transition(0.2, T)])
    Qs = np.stack([cv_process_noise(T, 0.01), cv_process_noise(T, 1.0)])
    H, R = position_matrix(), np.eye(2) * 4.0
    PI = np.array([[0.95, 0.05], [0.1, 0.9]])
    xs = np.array([[0.0, 0.0, 10.0, 0.0], [1.0, -1.0, 9.0, 1.0]])
    Ps = np.stack([np.eye(4) * 10.0, np.eye(4) * 20.0])
    mu = np.array([0.7, 0.3])
    return xs, Ps, mu, PI, Fs, Qs, H, R


def reference_mix(mu, PI, xs, Ps):
    c = mu @ PI
    W = PI * mu[:, None] / c[None, :]
    x0 = W.T @ xs
    P0 = np.stack([sum(W[i, j] * (Ps[i] + np.outer(xs[i] - x0[j], xs[i] - x0[j]))
                       for i in range(len(mu))) for j in range(len(mu))])
    return x0, P0, c


@pytest.mark.parametrize("seed", range(5))
def test_mix_and_combine_match_reference(seed):
    rng = np.random.default_rng(seed)
    r, n = 3, 4
    xs = rng.normal(size=(r, n))
    A = rng.normal(size=(r, n, n))
    Ps = A @ A.transpose(0, 2, 1) + np.eye(n)
    mu = rng.dirichlet(np.ones(r))
    PI = rng.dirichlet(np.ones(r), size=r)
    for got, want in zip(imm_mix(mu, PI, xs, Ps), reference_mix(mu, PI, xs, Ps)):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    x, P = imm_combine(mu, xs, Ps)
    np.testing.assert_allclose(x, mu @ xs, rtol=1e-12, atol=1e-14)
    Pref = sum(mu[j] * (Ps[j] + np.outer(xs[j] - x, xs[j] - x)) for j in range(r))
    np.testing.assert_allclose(P, Pref, rtol=1e-12)
    # identity PI: no mixing
    x0, P0, c = imm_mix(mu, np.eye(r), xs, Ps)
    np.testing.assert_allclose(x0, xs, rtol=1e-14)
    np.testing.assert_allclose(c, mu, rtol=1e-14)


def test_mix_unreachable_mode_keeps_estimate():
    xs = np.array([[1.0, 2.0], [3.0, 4.0]])
    Ps = np.stack([np.eye(2), 2 * np.eye(2)])
    x0, P0, c = imm_mix([1.0, 0.0], np.array([[1.0, 0.0], [0.0, 1.0]]), xs, Ps)
    assert c[1] == 0.0
    np.testing.assert_array_equal(x0[1], xs[1])
    np.testing.assert_array_equal(P0[1], Ps[1])


def test_mode_update_log_space():
    c = np.array([0.3, 0.7])
    mu = imm_mode_update(c, [-2000.0, -2001.0])  # exp() of both underflows
    want = c * np.exp([0.0, -1.0])
    np.testing.assert_allclose(mu, want / want.sum(), rtol=1e-13)
    np.testing.assert_allclose(imm_mode_update(c, [0.0, 0.0]), c, rtol=1e-15)
    np.testing.assert_allclose(imm_mode_update(c, [-np.inf, 1.0]), [0.0, 1.0])
    with pytest.raises(ValueError, match="no mode"):
        imm_mode_update([1.0, 0.0], [-np.inf, 0.0])
    with pytest.raises(ValueError, match="logliks"):
        imm_mode_update(c, [np.nan, 0.0])
    with pytest.raises(ValueError, match="logliks"):
        imm_mode_update(c, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="c_bar"):
        imm_mode_update([0.5, 0.6], [0.0, 0.0])


def test_step_equals_manual_cycle():
    xs, Ps, mu, PI, Fs, Qs, H, R = two_mode_problem()
    z = np.array([12.0, 1.0])
    st_ = imm_step(xs, Ps, mu, PI, Fs, Qs, z, H, R)
    assert isinstance(st_, IMMStep)
    x0, P0, c = imm_mix(mu, PI, xs, Ps)
    lls = []
    for j in range(2):
        xp, Pp = kf_predict(x0[j], P0[j], Fs[j], Qs[j])
        u = kf_update(xp, Pp, z, H, R)
        np.testing.assert_allclose(st_.xs[j], u.x, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(st_.Ps[j], u.P, rtol=1e-12, atol=1e-12)
        lls.append(u.loglik)
    np.testing.assert_allclose(st_.logliks, lls, rtol=1e-12)
    mu_ref = c * np.exp(lls)
    np.testing.assert_allclose(st_.mu, mu_ref / mu_ref.sum(), rtol=1e-12)
    x, P = imm_combine(st_.mu, st_.xs, st_.Ps)
    np.testing.assert_allclose(st_.x, x, rtol=1e-14)
    np.testing.assert_allclose(st_.P, P, rtol=1e-14)
    # empty scan: prediction only, mode probabilities = c_bar
    e = imm_step(xs, Ps, mu, PI, Fs, Qs, np.zeros(0), H, R)
    np.testing.assert_allclose(e.mu, c, rtol=1e-14)
    np.testing.assert_array_equal(e.logliks, [0.0, 0.0])


def test_run_equals_steps_and_detects_manoeuvre():
    xs, Ps, mu, PI, Fs, Qs, H, R = two_mode_problem()
    rng = np.random.default_rng(11)
    # truth: straight for 30 scans, then a 0.2 rad/s turn for 30 scans
    x = np.array([0.0, 0.0, 10.0, 0.0])
    zs = []
    for k in range(60):
        x = (Fs[0] if k < 30 else Fs[1]) @ x
        zs.append(H @ x + 2.0 * rng.normal(size=2))
    zs = np.array(zs)
    zs[10] = np.nan  # a missed scan
    run = imm_filter_run(zs, xs, Ps, mu, PI, Fs, Qs, H, R)
    assert isinstance(run, IMMRun)
    assert run.loglik[10] == 0.0
    cur = (xs, Ps, mu)
    for k in range(60):
        z = zs[k] if not np.isnan(zs[k, 0]) else np.zeros(0)
        s = imm_step(*cur, PI, Fs, Qs, z, H, R)
        cur = (s.xs, s.Ps, s.mu)
        np.testing.assert_allclose(run.x[k], s.x, rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(run.P[k], s.P, rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(run.mu[k], s.mu, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(run.mu.sum(axis=1), 1.0, rtol=1e-14)
    # the turn mode dominates during the turn and not before it
    assert run.mu[25:30, 1].mean() < 0.3 and run.mu[45:60, 1].mean() > 0.7


def test_bad_inputs():
    xs, Ps, mu, PI, Fs, Qs, H, R = two_mode_problem()
    z = np.zeros(2)
    with pytest.raises(ValueError, match="PI"):
        imm_step(xs, Ps, mu, np.array([[0.9, 0.2], [0.1, 0.9]]), Fs, Qs, z, H, R)
    with pytest.raises(ValueError, match="PI"):
        imm_mix(mu, np.array([[1.5, -0.5], [0.1, 0.9]]), xs, Ps)
    with pytest.raises(ValueError, match="PI"):
        imm_mix(mu, np.eye(3), xs, Ps)
    with pytest.raises(ValueError, match="mu"):
        imm_mix([0.5, 0.6], PI, xs, Ps)
    with pytest.raises(ValueError, match="mu"):
        imm_combine([-0.5, 1.5], xs, Ps)
    with pytest.raises(ValueError, match="mu"):
        imm_step(xs, Ps, [1.0], PI, Fs, Qs, z, H, R)
    with pytest.raises(ValueError, match="Ps"):
        imm_mix(mu, PI, xs, np.stack([np.eye(4), -np.eye(4)]))
    with pytest.raises(ValueError, match="Ps"):
        imm_combine(mu, xs, np.eye(4))
    with pytest.raises(ValueError, match="xs"):
        imm_combine(mu, np.zeros(4), Ps)
    with pytest.raises(ValueError, match="xs"):
        imm_combine(mu, np.full((2, 4), np.nan), Ps)
    with pytest.raises(ValueError, match="Fs"):
        imm_step(xs, Ps, mu, PI, Fs[:1], Qs, z, H, R)
    with pytest.raises(ValueError, match="Qs"):
        imm_step(xs, Ps, mu, PI, Fs, -Qs, z, H, R)
    with pytest.raises(ValueError, match="H"):
        imm_step(xs, Ps, mu, PI, Fs, Qs, z, np.eye(4), R)
    with pytest.raises(ValueError, match="R"):
        imm_filter_run(np.zeros((3, 2)), xs, Ps, mu, PI, Fs, Qs, H, np.eye(3))
    with pytest.raises(ValueError, match="zs"):
        imm_filter_run(np.array([[np.nan, 1.0]]), xs, Ps, mu, PI, Fs, Qs, H, R)
    with pytest.raises(ValueError, match="not positive definite"):
        imm_step(xs, np.zeros((2, 4, 4)), mu, PI, Fs, np.zeros((2, 4, 4)), z, H,
                 np.zeros((2, 2)))
    with pytest.raises(TypeError, match="z"):
        imm_step(xs, Ps, mu, PI, Fs, Qs, "zz", H, R)


@given(st.integers(0, 2**32 - 1), st.integers(2, 4))
@settings(max_examples=30, deadline=None)
def test_mode_probabilities_stay_normalised(seed, r):
    rng = np.random.default_rng(seed)
    n = 4
    Fs = np.stack([coordinated_turn_transition(w, 1.0) for w in rng.normal(0, 0.2, r)])
    Qs = np.stack([cv_process_noise(1.0, q) for q in rng.uniform(0.01, 2.0, r)])
    PI = rng.dirichlet(np.ones(r) * 0.5, size=r)
    mu0 = rng.dirichlet(np.ones(r))
    xs0 = rng.normal(size=(r, n))
    Ps0 = np.stack([np.eye(n) * 5.0] * r)
    zs = rng.normal(size=(15, 2)) * 100.0  # wild measurements: likelihoods underflow
    run = imm_filter_run(zs, xs0, Ps0, mu0, PI, Fs, Qs, position_matrix(), np.eye(2) * 0.01)
    assert np.all(np.isfinite(run.mu)) and np.all(run.mu >= 0)
    np.testing.assert_allclose(run.mu.sum(axis=1), 1.0, rtol=1e-12)
    assert np.all(np.isfinite(run.P)) and np.all(np.isfinite(run.loglik))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_run_names_arguments_as_written_and_rejects_overflow():
    """Errors of imm_filter_run name xs0, Ps0, mu0 (issue 17); overflow raises."""
    xs, Ps, mu, PI, Fs, Qs, H, R = two_mode_problem()
    zs = np.zeros((3, H.shape[0]))
    base = dict(zs=zs, xs0=xs, Ps0=Ps, mu0=mu, PI=PI, Fs=Fs, Qs=Qs, H=H, R=R)
    for name, bad in (("xs0", np.full_like(xs, np.nan)), ("Ps0", -Ps), ("mu0", mu * 0.5),
                      ("xs0", xs[:, :0]), ("mu0", np.r_[mu, 0.0])):
        with pytest.raises(ValueError, match=name):
            imm_filter_run(**{**base, name: bad})
    with pytest.raises(ValueError, match="overflows|no mode has positive probability"):
        imm_filter_run(**{**base, "zs": np.full((3, H.shape[0]), 1e300)})
    with pytest.raises(ValueError, match="overflows"):
        imm_combine(mu, xs + 1e300 * np.arange(len(mu))[:, None], Ps)
