"""Tests for trackcore.association.jpda (exact JPDA, feature form of eqs 5-6)."""
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from trackcore.association.jpda import (
    feasible_event_count,
    feasible_events,
    feature_validation,
    jpda_clusters,
    jpda_marginals,
    permanent,
)

FIG4 = np.array([[0, 1], [1, 1], [1, 0]], dtype=bool)


# ---------------------------------------------------------------- references
def brute_force(lik, valid, pd, lam, rho=None, mode="parametric", V=None, c_I=0.6):
    """Target-oriented product enumeration with itertools (independent of the
    numba measurement-oriented depth-first kernel)."""
    m, T = valid.shape
    pd = np.broadcast_to(np.asarray(pd, float), (T,))
    if rho is not None:
        valid = valid & (rho >= c_I)
    choices = [[-1] + [j for j in range(m) if valid[j, t]] for t in range(T)]
    acc = np.zeros((m + 1, T))
    total = 0.0
    n = 0
    for ev in itertools.product(*choices):
        det = [j for j in ev if j >= 0]
        if len(det) != len(set(det)):
            continue
        n += 1
        w = 1.0
        for t, j in enumerate(ev):
            if j >= 0:
                f = lik[j, t] * (rho[j, t] if rho is not None else 1.0)
                w *= pd[t] * f / (lam if mode == "parametric" else 1.0)
            else:
                w *= 1.0 - pd[t]
        if mode == "nonparametric":
            phi = m - len(det)
            w *= math.factorial(phi) / V ** phi
        total += w
        for t, j in enumerate(ev):
            acc[j + 1, t] += w
    return acc / total, n


def permanent_marginals(lik, valid, pd, lam):
    """Parametric JPDA marginals from rectangular permanents (Ryser):
    A[t, j] = pd_t L_{j,t} / lam on valid pairs, A[t, m + t] = 1 - pd_t;
    beta_{j,t} = A[t, j] per(A without row t, column j) / per(A)."""
    m, T = valid.shape
    A = np.zeros((T, m + T))
    A[:, :m] = (np.where(valid, lik, 0.0) * pd / lam).T
    A[np.arange(T), m + np.arange(T)] = 1.0 - pd
    c = permanent(A)
    beta = np.zeros((m + 1, T))
    for t in range(T):
        for j in range(m):
            if A[t, j] > 0:
                sub = np.delete(np.delete(A, t, axis=0), j, axis=1)
                beta[j + 1, t] = A[t, j] * permanent(sub) / c
        sub = np.delete(np.delete(A, t, axis=0), m + t, axis=1)
        beta[0, t] = A[t, m + t] * permanent(sub) / c
    return beta


def random_instance(rng, m, T, p_valid=0.7):
    valid = rng.random((m, T)) < p_valid
    lik = rng.uniform(1e-4, 0.05, (m, T))
    pd = rng.uniform(0.6, 0.95, T)
    lam = 10 ** rng.uniform(-4, -2)
    rho = rng.uniform(0.3, 1.0, (m, T))
    return lik, valid, pd, lam, rho


# ---------------------------------------------------------------- Fig 4
def test_fig4_eight_events_then_six():
    ev = feasible_events(FIG4)
    expected = {(-1, -1), (-1, 0), (-1, 1), (1, -1), (1, 0), (2, -1), (2, 0), (2, 1)}
    assert {tuple(e) for e in ev} == expected
    assert len(ev) == 8 == feasible_event_count(FIG4)
    rho = np.ones((3, 2))
    rho[1, 1] = 0.5       # feature gate removes (z2, T2)
    ev6 = feasible_events(feature_validation(FIG4, rho))
    assert {tuple(e) for e in ev6} == {(-1, -1), (-1, 0), (1, -1), (1, 0), (2, -1), (2, 0)}
    _, n = jpda_marginals(np.full((3, 2), 0.01), FIG4, 0.9, 1e-3, rho=rho)
    assert n == 6


def test_event_count_equals_permanent():
    rng = np.random.default_rng(4)
    for _ in range(30):
        m, T = rng.integers(0, 7), rng.integers(1, 5)
        valid = rng.random((m, T)) < 0.6
        A = np.hstack([valid.T.astype(float), np.eye(T)])
        assert feasible_event_count(valid) == round(permanent(A))
        assert len(feasible_events(valid)) == feasible_event_count(valid)


def test_permanent_against_itertools():
    rng = np.random.default_rng(2)
    for T, n in [(1, 1), (2, 3), (3, 3), (3, 6), (4, 5)]:
        A = rng.random((T, n))
        bf = sum(np.prod([A[i, p[i]] for i in range(T)])
                 for p in itertools.permutations(range(n), T))
        assert permanent(A) == pytest.approx(bf, rel=1e-12)
    assert permanent(np.zeros((0, 3))) == 1.0
    with pytest.raises(ValueError, match="A"):
        permanent(np.ones((3, 2)))


# ---------------------------------------------------------------- correctness
def test_brute_force_and_permanent_agree_with_kernel():
    rng = np.random.default_rng(7)
    for _ in range(40):
        m, T = int(rng.integers(0, 7)), int(rng.integers(1, 5))
        lik, valid, pd, lam, rho = random_instance(rng, m, T)
        beta, n = jpda_marginals(lik, valid, pd, lam)
        ref, nref = brute_force(lik, valid, pd, lam)
        assert n == nref
        np.testing.assert_allclose(beta, ref, atol=1e-12)
        np.testing.assert_allclose(beta, permanent_marginals(lik, valid, pd, lam), atol=1e-9)
        # feature form
        beta_f, nf = jpda_marginals(lik, valid, pd, lam, rho=rho)
        ref_f, nref_f = brute_force(lik, valid, pd, lam, rho=rho)
        assert nf == nref_f <= n
        np.testing.assert_allclose(beta_f, ref_f, atol=1e-12)
        # nonparametric form
        V = float(rng.uniform(50, 500))
        beta_n, _ = jpda_marginals(lik, valid, pd, lam, mode="nonparametric", V=V)
        ref_n, _ = brute_force(lik, valid, pd, lam, mode="nonparametric", V=V)
        np.testing.assert_allclose(beta_n, ref_n, atol=1e-12)


def test_dense_case_many_events():
    rng = np.random.default_rng(11)
    lik, _, pd, lam, _ = random_instance(rng, 6, 4)
    valid = np.ones((6, 4), bool)
    beta, n = jpda_marginals(lik, valid, pd, lam)
    # sum_k C(4,k) * 6!/(6-k)! = 1 + 24 + 180 + 480 + 360
    assert n == 1045
    np.testing.assert_allclose(beta, permanent_marginals(lik, valid, pd, lam), atol=1e-9)


def test_single_track_reduces_to_pdaf():
    """One track: beta_j = e_j / (b + sum e), e_j = L_j, b = lam (1 - pd) / pd."""
    rng = np.random.default_rng(3)
    for m in range(0, 6):
        L = rng.uniform(1e-3, 0.1, (m, 1))
        pd, lam = 0.85, 3e-3
        beta, n = jpda_marginals(L, np.ones((m, 1), bool), pd, lam)
        b = lam * (1 - pd) / pd
        denom = b + L.sum()
        assert n == m + 1
        np.testing.assert_allclose(beta[1:, 0], L[:, 0] / denom, rtol=1e-12)
        assert beta[0, 0] == pytest.approx(b / denom, rel=1e-12)


def test_single_track_matches_foundation_pda_betas():
    from trackcore.association import pda_betas
    rng = np.random.default_rng(5)
    for m in range(0, 5):
        L = rng.uniform(1e-3, 0.1, m)
        pd, lam = 0.9, 2e-3
        beta, _ = jpda_marginals(L[:, None], np.ones((m, 1), bool), pd, lam)
        beta0, betas = pda_betas(L, pd, 1.0, lam)
        assert beta[0, 0] == pytest.approx(beta0, abs=1e-12)
        np.testing.assert_allclose(beta[1:, 0], betas, atol=1e-12)


def test_jpda_betas_in_pda_update_give_symmetric_psd_spread():
    """Eq (9) corrected: P = b0 P + (1 - b0) Pc + W (sum b nu nu^T - nu nu^T) W^T
    is symmetric PSD, and the spread term itself is PSD."""
    from trackcore.association import pda_update
    from trackcore.models import cv_process_noise, cv_transition, position_matrix
    rng = np.random.default_rng(12)
    H = position_matrix(2, 4)
    R = np.eye(2)
    P = cv_process_noise(1.0, 0.3, 2) * 10 + np.eye(4)
    x = np.array([10.0, 20.0, 1.0, -1.0])
    for _ in range(20):
        m = int(rng.integers(0, 5))
        z = H @ x + rng.normal(0, 2.0, (m, 2))
        S = H @ P @ H.T + R
        nu = z - H @ x
        lik = np.exp(-0.5 * np.einsum("ij,jk,ik->i", nu, np.linalg.inv(S), nu)) / (
            2 * np.pi * np.sqrt(np.linalg.det(S)))
        beta, _ = jpda_marginals(lik[:, None], np.ones((m, 1), bool), 0.9, 1e-3)
        up = pda_update(x, P, z, H @ x, H, R, beta[1:, 0], beta[0, 0])
        assert np.allclose(up.P, up.P.T, atol=1e-12)
        assert np.linalg.eigvalsh(up.P).min() > 0
        spread = (beta[1:, 0, None, None] * nu[:, :, None] * nu[:, None, :]).sum(0) \
            - np.outer(up.innovation_combined, up.innovation_combined)
        assert np.linalg.eigvalsh(spread).min() > -1e-10
        x, P = cv_transition(1.0) @ up.x, cv_transition(1.0) @ up.P @ cv_transition(1.0).T + \
            cv_process_noise(1.0, 0.3)


def test_m_zero_gives_beta0_one():
    beta, n = jpda_marginals(np.zeros((0, 3)), np.zeros((0, 3), bool), [0.9, 0.8, 0.7], 1e-4)
    assert beta.shape == (1, 3) and n == 1
    np.testing.assert_array_equal(beta, np.ones((1, 3)))
    beta, n = jpda_marginals(np.zeros((0, 2)), np.zeros((0, 2)), 0.9, 1e-4, rho=np.zeros((0, 2)))
    np.testing.assert_array_equal(beta, np.ones((1, 2)))


def test_empty_gate_track_is_missed_with_certainty():
    valid = np.array([[1, 0], [1, 0]], bool)
    beta, _ = jpda_marginals(np.full((2, 2), 0.02), valid, 0.9, 1e-3)
    assert beta[0, 1] == 1.0
    assert np.all(beta[1:, 1] == 0.0)


def test_rho_one_equals_plain_and_rho_scales_likelihood():
    rng = np.random.default_rng(9)
    lik, valid, pd, lam, rho = random_instance(rng, 5, 3)
    plain = jpda_marginals(lik, valid, pd, lam)
    ones = jpda_marginals(lik, valid, pd, lam, rho=np.ones_like(lik))
    np.testing.assert_allclose(plain[0], ones[0], atol=1e-15)
    rho = np.clip(rho, 0.6, 1.0)          # all pass the gate: only the factor acts
    f = jpda_marginals(lik, valid, pd, lam, rho=rho)
    g = jpda_marginals(lik * rho, valid, pd, lam)
    np.testing.assert_allclose(f[0], g[0], atol=1e-14)


def test_log_space_no_underflow():
    """Likelihoods and clutter density both ~1e-200: linear products of
    several such terms underflow, log space does not."""
    rng = np.random.default_rng(1)
    lik, valid, pd, lam, _ = random_instance(rng, 6, 4)
    valid[:] = True
    ref, _ = jpda_marginals(lik, valid, pd, lam)
    tiny, _ = jpda_marginals(lik * 1e-200, valid, pd, lam * 1e-200)
    np.testing.assert_allclose(tiny, ref, atol=1e-12)


def test_pd_one_and_zero():
    lik = np.array([[0.02], [0.01]])
    beta, _ = jpda_marginals(lik, np.ones((2, 1), bool), 1.0, 1e-3)
    assert beta[0, 0] == 0.0 and beta[1:, 0].sum() == pytest.approx(1.0)
    beta, _ = jpda_marginals(lik, np.ones((2, 1), bool), 0.0, 1e-3)
    assert beta[0, 0] == 1.0
    with pytest.raises(ValueError, match="zero probability"):
        jpda_marginals(np.zeros((1, 1)), np.zeros((1, 1), bool), 1.0, 1e-3)


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize("kwargs, match", [
    (dict(lik=np.ones((2, 3))), "lik"),
    (dict(lik=-np.ones((3, 2))), "lik"),
    (dict(lik=np.full((3, 2), np.nan)), "lik"),
    (dict(valid=np.ones((3, 3))), "lik"),
    (dict(valid=np.full((3, 2), 2)), "valid"),
    (dict(valid=np.ones(3)), "valid"),
    (dict(pd=[0.9, 1.2]), "pd"),
    (dict(pd=[0.9]), "pd"),
    (dict(pd=-0.1), "pd"),
    (dict(lam=0.0), "lam"),
    (dict(lam=-1.0), "lam"),
    (dict(rho=np.ones((2, 2))), "rho"),
    (dict(rho=np.full((3, 2), 1.5)), "rho"),
    (dict(mode="other"), "mode"),
    (dict(mode="nonparametric"), "V"),
    (dict(mode="nonparametric", V=-2.0), "V"),
])
def test_bad_input_raises(kwargs, match):
    args = dict(lik=np.full((3, 2), 0.01), valid=FIG4, pd=[0.9, 0.8], lam=1e-3)
    args.update(kwargs)
    with pytest.raises((ValueError, TypeError), match=match):
        jpda_marginals(**args)


def test_bad_type_raises():
    with pytest.raises(TypeError, match="lik"):
        jpda_marginals("abc", FIG4, 0.9, 1e-3)
    with pytest.raises(TypeError, match="lam"):
        jpda_marginals(np.full((3, 2), 0.01), FIG4, 0.9, "x")


# ---------------------------------------------------------------- clusters
def test_clusters():
    valid = np.array([[1, 0, 0], [1, 1, 0], [0, 0, 0], [0, 0, 1]], bool)
    cl = jpda_clusters(valid)
    got = sorted((tuple(t), tuple(j)) for t, j in cl)
    assert got == [((0, 1), (0, 1)), ((2,), (3,))]
    cl = jpda_clusters(np.zeros((0, 2), bool))
    assert sorted(tuple(t) for t, _ in cl) == [(0,), (1,)]


# ---------------------------------------------------------------- properties
@settings(max_examples=60, deadline=None)
@given(m=st.integers(0, 6), T=st.integers(1, 4), seed=st.integers(0, 2**31),
       feature=st.booleans())
def test_property_columns_sum_to_one_and_match_brute_force(m, T, seed, feature):
    rng = np.random.default_rng(seed)
    lik, valid, pd, lam, rho = random_instance(rng, m, T, p_valid=rng.uniform(0, 1))
    rho = rho if feature else None
    beta, n = jpda_marginals(lik, valid, pd, lam, rho=rho)
    assert beta.shape == (m + 1, T)
    assert np.all(beta >= 0)
    np.testing.assert_allclose(beta.sum(axis=0), 1.0, atol=1e-12)
    vv = valid if rho is None else valid & (rho >= 0.6)
    assert np.all(beta[1:][~vv] == 0.0)
    ref, nref = brute_force(lik, valid, pd, lam, rho=rho)
    assert n == nref
    np.testing.assert_allclose(beta, ref, atol=1e-12)
    # each measurement is assigned to at most one target in total probability
    assert np.all(beta[1:].sum(axis=1) <= 1 + 1e-12)


# ---------------------------------------------------------------- Stone Soup
def test_matches_stonesoup_jpda_on_shared_inputs():
    """Stone Soup's JPDA (PDAHypothesiser, P_G = 1) and jpda_marginals agree on
    the same predicted tracks and detections."""
    pytest.importorskip("stonesoup")
    import datetime
    from stonesoup.dataassociator.probability import JPDA
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    t0 = datetime.datetime(2016, 3, 25)
    t1 = t0 + datetime.timedelta(seconds=1)
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.09), ConstantVelocity(0.09)])
    mm = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    predictor, updater = KalmanPredictor(tm), KalmanUpdater(mm)
    pd, lam = 0.85, 2e-3
    hyp = PDAHypothesiser(predictor, updater, clutter_spatial_density=lam, prob_detect=pd,
                          prob_gate=1.0)
    assoc = JPDA(hyp)
    rng = np.random.default_rng(21)
    for _ in range(3):
        tracks = [Track([GaussianState(np.array([[10.0], [1.0], [20.0], [0.5]]),
                                       np.diag([2.0, 0.5, 2.0, 0.5]), timestamp=t0)]),
                  Track([GaussianState(np.array([[13.0], [-1.0], [21.0], [0.0]]),
                                       np.diag([1.5, 0.4, 1.5, 0.4]), timestamp=t0)])]
        zs = rng.normal([11.5, 20.8], 2.0, (3, 2))
        dets = {Detection(z.reshape(2, 1), timestamp=t1, measurement_model=mm) for z in zs}
        out = assoc.associate(tracks, dets, t1)
        det_list = sorted(dets, key=lambda d: tuple(d.state_vector.ravel()))
        lik = np.zeros((3, 2))
        ss = np.zeros((4, 2))
        for t, trk in enumerate(tracks):
            mp = updater.predict_measurement(predictor.predict(trk, timestamp=t1))
            S = np.asarray(mp.covar, float)
            for j, d in enumerate(det_list):
                nu = np.asarray(d.state_vector, float).ravel() - np.asarray(mp.state_vector, float).ravel()
                lik[j, t] = np.exp(-0.5 * nu @ np.linalg.solve(S, nu)) / (2 * np.pi * np.sqrt(np.linalg.det(S)))
            for h in out[trk]:
                p = float(h.probability)
                if h.measurement is None or not h:
                    ss[0, t] += p
                else:
                    ss[det_list.index(h.measurement) + 1, t] += p
        ours, _ = jpda_marginals(lik, np.ones((3, 2), bool), pd, lam)
        np.testing.assert_allclose(ours, ss, atol=1e-9)
