"""Tests for trackcore.trackers.sprt_discriminator (hypothesis-matched EKFs, eqs 19-25)."""
import math

import numpy as np
import pytest

from trackcore.filters import ekf_update, imm_mix, imm_mode_update, kf_predict
from trackcore.models import (cv_process_noise, cv_transition, modified_polar_F, modified_polar_f,
                              modified_polar_Q, range_bearing_doppler,
                              range_bearing_doppler_jacobian)
from trackcore.scenarios import sprt_acm_measurements, sprt_acm_scenario, sprt_acm_truth
from trackcore.trackers import SprtAcmFilterConfig, sprt_acm_discriminate, sprt_acm_llr


@pytest.fixture(scope="module")
def run_data():
    sc = sprt_acm_scenario(1)
    truth = sprt_acm_truth(sc)
    z = sprt_acm_measurements(sc, np.random.default_rng(5), truth)
    return sc, truth, z


def _target_modes_reference(cfg, T):
    """The post-release target filter as (list of mode PSDs per scan k, PI, mu0).

    Written from the documented behaviour, not from the kernel: the boost raises the
    noise of every prediction that *starts* less than ``boost_time`` after the release
    (the prediction to post-release index k starts at (k - 1) T after it); the IMM starts
    from ``mu_release`` or, if unset, from the stationary law of its mode chain.
    """
    q_cv = cfg.sigma_v**2
    q_m = cfg.manoeuvre_accel**2 * T
    if cfg.target_model == "cv":
        return (lambda k: [q_cv]), None, None
    if cfg.target_model == "boost":
        return (lambda k: [q_m if (k - 1) * T < cfg.boost_time else q_cv]), None, None
    p1, p2 = cfg.p_stay_cv, cfg.p_stay_manoeuvre
    PI = np.array([[p1, 1 - p1], [1 - p2, p2]])
    w, v = np.linalg.eig(PI.T)
    stationary = np.real(v[:, np.argmin(np.abs(w - 1))])
    m = float(stationary[1] / stationary.sum()) if cfg.mu_release is None else cfg.mu_release
    return (lambda k: [q_cv, q_m]), PI, np.array([1 - m, m])


def reference(z, truth, T, cfg):
    """Independent Python route through the foundation's public EKF and IMM functions."""
    Phi = cv_transition(T)
    Qa = cv_process_noise(T, cfg.sigma_v**2, kind="cwna")
    Ra = np.diag([cfg.sigma_r**2, cfg.sigma_theta**2, cfg.sigma_rdot**2])
    Rb = np.array([[cfg.sigma_theta**2]])
    own = truth.own
    n0 = truth.n_pre
    psds, PI, mu0 = _target_modes_reference(cfg, T)

    def u_a(j):
        return np.r_[own[j, :2] - own[j - 1, :2] - T * own[j - 1, 2:], own[j, 2:] - own[j - 1, 2:]]

    def tupdate(x, P, zz):
        up = ekf_update(x, P, zz, range_bearing_doppler(x), range_bearing_doppler_jacobian(x), Ra,
                        angle_index=1)
        return up.x, up.P, up.loglik + 1.5 * math.log(2 * math.pi), up.nis

    x = np.array([z.z_pre[0, 0] * math.cos(z.z_pre[0, 1]), z.z_pre[0, 0] * math.sin(z.z_pre[0, 1]),
                  0, 0])
    P = np.diag([cfg.init_pos_std**2] * 2 + [cfg.init_vel_std**2] * 2)
    for i in range(1, n0):
        x, P = kf_predict(x, P, Phi, Qa)
        x, P, _, _ = tupdate(x - u_a(i), P, z.z_pre[i])
    xp, Pp = kf_predict(x, P, Phi, Qa)
    xp = xp - u_a(n0)
    K = z.z_a.shape[0]
    lam = np.zeros((K, 4))
    nis = np.full((K, 4), np.nan)
    mu_out = np.full((K, 2), np.nan)
    tgt = {}
    acm = {}
    acc = np.zeros(4)
    for k in range(K):
        j = n0 + k
        for slot, (col, zz) in enumerate(((0, z.z_a[k]), (3, z.z_b[k]))):
            if k == 0:
                modes = [tupdate(xp, Pp, zz) for _ in psds(k)]
                mu = None if PI is None else mu0.copy()
                ll, v = modes[0][2], modes[0][3]
            else:
                xs, Ps, mu = tgt[col]
                if PI is not None:
                    xs, Ps, c_bar = imm_mix(mu, PI, np.array(xs), np.array(Ps))
                out = []
                for m, q in enumerate(psds(k)):
                    xm, Pm = kf_predict(xs[m], Ps[m], Phi, cv_process_noise(T, q, kind="cwna"))
                    out.append(tupdate(xm - u_a(j), Pm, zz))
                modes = out
                if PI is None:
                    ll, v = modes[0][2], modes[0][3]
                else:
                    lls = np.array([o[2] for o in modes])
                    ll = math.log(np.sum(c_bar * np.exp(lls)))
                    mu = imm_mode_update(c_bar, lls)
                    v = float(np.sum(c_bar * np.array([o[3] for o in modes])))
            tgt[col] = ([o[0] for o in modes], [o[1] for o in modes], mu)
            if mu is not None:
                mu_out[k, slot] = mu[1]
            acc[col] += ll
            nis[k, col] = v
        for col, zz in ((1, z.z_b[k]), (2, z.z_a[k])):
            if k == 0:
                f = cfg.beta_std_factor
                if col == 2 and cfg.beta_std_factor_a1 is not None:   # a1's own prior
                    f = cfg.beta_std_factor_a1
                x0 = np.array([zz[1], 1 / zz[0]])
                if cfg.beta_min is not None:   # the sign constraint: truncate 1/r
                    x0[1] = max(x0[1], cfg.beta_min)
                acm[col] = (x0, np.diag([cfg.sigma_theta**2, (f / zz[0])**2]))
                continue
            x, P = acm[col]
            ub = own[j, :2] - own[j - 1, :2]
            F = modified_polar_F(x, ub)
            Pp2 = F @ P @ F.T + modified_polar_Q(x, T, cfg.sigma_p)
            xp2 = modified_polar_f(x, ub)
            up = ekf_update(xp2, Pp2, zz[1:2], xp2[:1], np.array([[1.0, 0.0]]), Rb, angle_index=0)
            xu = up.x.copy()
            if cfg.beta_min is not None:
                xu[1] = max(xu[1], cfg.beta_min)
            acm[col] = (xu, up.P)
            acc[col] += up.loglik + 0.5 * math.log(2 * math.pi)
            nis[k, col] = up.nis
        lam[k] = acc
    return lam, nis, mu_out


@pytest.mark.parametrize("changes", [dict(beta_std_factor=2.0), dict(beta_std_factor=0.5),
                                     dict(target_model="boost"),
                                     dict(target_model="boost", boost_time=5.0),
                                     dict(target_model="boost", boost_time=4.0),
                                     dict(target_model="boost", boost_time=0.5),
                                     dict(target_model="imm", beta_std_factor=0.2),
                                     dict(target_model="imm", mu_release=1.0),
                                     dict(target_model="imm", mu_release=0.0,
                                          p_stay_cv=0.8, p_stay_manoeuvre=0.6),
                                     dict(beta_std_factor_a1=0.2),
                                     dict(beta_std_factor=0.2, beta_std_factor_a1=3.0),
                                     dict(beta_min=1 / 20000.0),
                                     dict(beta_min=1 / 500.0, target_model="boost")])
def test_matches_foundation_route(run_data, changes):
    sc, truth, z = run_data
    cfg = SprtAcmFilterConfig(**changes)
    res = sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, sc.T, cfg)
    lam, nis, mu = reference(z, truth, sc.T, cfg)
    assert res.ok
    np.testing.assert_allclose(res.lam, lam, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(res.nis, nis, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(res.mu, mu, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(res.llr, -lam[:, 0] - lam[:, 1] + lam[:, 2] + lam[:, 3], atol=1e-8)


def test_structure_first_scan(run_data):
    sc, truth, z = run_data
    res = sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, sc.T)
    K = sc.n_post
    assert res.lam.shape == (K, 4) and res.llr.shape == (K,) and res.beta.shape == (K, 2)
    assert res.lam[0, 1] == 0.0 and res.lam[0, 2] == 0.0          # ACM filters start at k = 1
    assert np.isnan(res.nis[0, 1]) and np.isnan(res.nis[0, 2])
    assert np.all(np.isfinite(res.nis[1:]))
    assert res.beta[0, 0] == pytest.approx(1 / z.z_b[0, 0])
    np.testing.assert_allclose(res.llr, sprt_acm_llr(res.lam))


def test_swapping_tracks_negates_llr(run_data):
    sc, truth, z = run_data
    r1 = sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, sc.T)
    r2 = sprt_acm_discriminate(z.z_pre, z.z_b, z.z_a, truth.own, sc.T)
    np.testing.assert_allclose(r2.llr, -r1.llr, atol=1e-10)
    np.testing.assert_allclose(r2.lam[:, [3, 2, 1, 0]], r1.lam, atol=1e-10)


def test_batch_equals_single(run_data):
    sc, truth, z = run_data
    zs = [sprt_acm_measurements(sc, np.random.default_rng(s), truth) for s in range(3)]
    batch = sprt_acm_discriminate(np.stack([q.z_pre for q in zs]), np.stack([q.z_a for q in zs]),
                                  np.stack([q.z_b for q in zs]), truth.own, sc.T)
    assert batch.llr.shape == (3, sc.n_post) and batch.ok.all()
    for i, q in enumerate(zs):
        single = sprt_acm_discriminate(q.z_pre, q.z_a, q.z_b, truth.own, sc.T)
        np.testing.assert_array_equal(single.llr, batch.llr[i])


def test_empty_post_release(run_data):
    sc, truth, z = run_data
    own = truth.own[:truth.n_pre]
    res = sprt_acm_discriminate(z.z_pre, np.zeros((0, 3)), np.zeros((0, 3)), own, sc.T)
    assert res.llr.shape == (0,) and res.ok


def test_bad_input(run_data):
    sc, truth, z = run_data
    args = [z.z_pre, z.z_a, z.z_b, truth.own, sc.T]
    with pytest.raises(ValueError, match="z_a"):
        sprt_acm_discriminate(z.z_pre, z.z_a[:, :2], z.z_b, truth.own, sc.T)
    with pytest.raises(ValueError, match="z_b"):
        sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b[:-1], truth.own, sc.T)
    with pytest.raises(ValueError, match="own_states"):
        sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own[:-1], sc.T)
    with pytest.raises(ValueError, match="z_pre"):
        sprt_acm_discriminate(np.zeros((0, 3)), z.z_a, z.z_b, truth.own[truth.n_pre:], sc.T)
    bad = z.z_a.copy()
    bad[3, 0] = -1.0
    with pytest.raises(ValueError, match="ranges"):
        sprt_acm_discriminate(z.z_pre, bad, z.z_b, truth.own, sc.T)
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="z_a"):
        sprt_acm_discriminate(z.z_pre, bad, z.z_b, truth.own, sc.T)
    with pytest.raises(ValueError, match="T"):
        sprt_acm_discriminate(*args[:4], 0.0)
    with pytest.raises(TypeError, match="config"):
        sprt_acm_discriminate(*args, config={"sigma_r": 5})
    with pytest.raises(ValueError, match="sigma_r"):
        SprtAcmFilterConfig(sigma_r=0.0)
    with pytest.raises(ValueError, match="lam"):
        sprt_acm_llr(np.zeros((3, 5)))
