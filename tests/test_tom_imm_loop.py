"""The TOM-IMM-PDAF kernel against a straightforward loop written here from the paper.

Three target-oriented models with distinct lateral inputs, distinct noises, an
asymmetric Markov matrix and unequal initial probabilities, so that every part of the
cycle matters: the heading of eq. (8) (each of the three heading rules), IMM mixing,
``v_s <- u_j`` before each model's prediction with that model's ``Phi(phi)`` and
``Q_j(phi)``, gating with the union of the model gates, the parametric PDA per model,
model probabilities, the moment-matched combination, the Cartesian output and the
``v_s <- 0`` reset, with the two covariance readings kept as ablations (the ``v_s``
variance zeroed at the reset; the covariance rotated into the new heading's frame).
The data cover P_D = 1 and P_D < 1, with and without clutter, so that scans with no
validated measurement and no clutter (the branch where every PDA hypothesis is
impossible and the prediction is kept) are exercised.  The loop uses plain numpy and
scipy (no trackcore kernel) and must agree with :func:`trackcore.trackers.imm_pdaf_track`
to 1e-9.
"""
import math

import numpy as np
import pytest
from scipy.stats import chi2

from trackcore.scenarios import houles_measurements, houles_truth
from trackcore.trackers import imm_pdaf_track, tom_model_set, two_point_init

U = np.array([0.0, 55.0, -80.0])           # distinct lateral inputs (m/s)
SIG_S = np.array([2.0, 15.0, 25.0])        # distinct lateral noises (m/s^2)
SIG_F = np.array([1.0, 1.5, 0.5])          # distinct forward noises (m/s^2)
PI = np.array([[0.90, 0.06, 0.04],
               [0.10, 0.85, 0.05],
               [0.05, 0.15, 0.80]])
MU0 = np.array([0.7, 0.2, 0.1])
R = 400.0 * np.eye(2)
H = np.hstack([np.eye(2), np.zeros((2, 2))])


def _rot(phi):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, s], [s, -c]])


def _phi_matrix(phi, T=1.0):
    F = np.eye(4)
    F[:2, 2:] = T * _rot(phi)
    return F


def _q_dwna(phi, var_f, var_s, T=1.0):
    """Q = Gamma S Gamma^T, Gamma = [T^2/2 R(phi); T I] (eq. 7, q12 corrected)."""
    G = np.vstack([0.5 * T**2 * _rot(phi), T * np.eye(2)])
    return G @ np.diag([var_f, var_s]) @ G.T


def _gauss(nu, S):
    return math.exp(-0.5 * nu @ np.linalg.solve(S, nu)) / (2 * math.pi * math.sqrt(np.linalg.det(S)))


def reference_tom_imm(scans, x0, P0, *, pd, pg, lam, heading, reset_var=False,
                      rotate=False):
    """The TOM-IMM-PDAF cycle, one scan at a time, written out directly."""
    r = U.size
    phi = math.atan2(x0[3], x0[2])
    phi_frame = phi                       # the frame the model covariances are in
    B = np.eye(4)
    B[2:, 2:] = _rot(phi)
    X = [B @ x0 for _ in range(r)]
    P = [B @ P0 @ B.T for _ in range(r)]
    mu = MU0.copy()
    p1 = x0[:2].copy()                    # combined position at k - 1
    p2 = x0[:2] - x0[2:]                  # ... at k - 2 (the first measurement)
    p3 = 2 * p2 - p1                      # ... at k - 3 (extrapolated back)
    vel = x0[2:].copy()                   # combined Cartesian velocity at k - 1
    gamma = math.inf if pg == 1.0 else chi2.ppf(pg, 2)
    out_x, out_P, out_mu, out_phi = [], [], [], []
    for scan in scans:
        # heading, eq. (8)
        a, b = {"chord": (p2, p1), "chord_literal": (p3, p2),
                "velocity": (np.zeros(2), vel)}[heading]
        if np.hypot(*(b - a)) >= 1e-6:
            phi = math.atan2(b[1] - a[1], b[0] - a[0])
        if rotate:
            # velocity in the old frame -> Cartesian -> the new frame
            Bv = np.eye(4)
            Bv[2:, 2:] = _rot(phi) @ _rot(phi_frame)
            P = [Bv @ Pj @ Bv.T for Pj in P]
        phi_frame = phi
        # mixing
        cbar = PI.T @ mu
        Xm, Pmix = [], []
        for j in range(r):
            w = PI[:, j] * mu / cbar[j]
            xm = sum(w[i] * X[i] for i in range(r))
            Pmix.append(sum(w[i] * (P[i] + np.outer(X[i] - xm, X[i] - xm)) for i in range(r)))
            Xm.append(xm)
        # lateral input, prediction
        xp, Pp, zp, S = [], [], [], []
        for j in range(r):
            x = Xm[j].copy()
            x[3] = U[j]
            F = _phi_matrix(phi)
            xp.append(F @ x)
            Pp.append(F @ Pmix[j] @ F.T + _q_dwna(phi, SIG_F[j] ** 2, SIG_S[j] ** 2))
            zp.append(H @ xp[j])
            S.append(H @ Pp[j] @ H.T + R)
        # validated set: union of the model gates
        valid = [z for z in scan
                 if any((z - zp[j]) @ np.linalg.solve(S[j], z - zp[j]) <= gamma
                        for j in range(r))]
        # PDA per model
        like = np.empty(r)
        for j in range(r):
            nus = [z - zp[j] for z in valid]
            L = np.array([pd * _gauss(nu, S[j]) for nu in nus])
            miss = lam * (1.0 - pd * pg)
            norm = miss + L.sum()
            like[j] = norm
            if norm == 0.0:
                # no clutter and nothing validated: every hypothesis is impossible,
                # keep the prediction (the model likelihoods are all equal)
                X[j], P[j] = xp[j], Pp[j]
                continue
            beta = L / norm
            beta0 = miss / norm
            W = Pp[j] @ H.T @ np.linalg.inv(S[j])
            nu = sum((beta[i] * nus[i] for i in range(len(nus))), np.zeros(2))
            X[j] = xp[j] + W @ nu
            Pc = Pp[j] - W @ S[j] @ W.T
            spread = sum((beta[i] * np.outer(nus[i], nus[i]) for i in range(len(nus))),
                         np.zeros((2, 2))) - np.outer(nu, nu)
            P[j] = beta0 * Pp[j] + (1 - beta0) * Pc + W @ spread @ W.T
        # model probabilities (all likelihoods zero: the predicted probabilities)
        mu = cbar * like / np.sum(cbar * like) if np.sum(cbar * like) > 0 else cbar.copy()
        # combination and Cartesian output
        xc = sum(mu[j] * X[j] for j in range(r))
        Pcm = sum(mu[j] * (P[j] + np.outer(X[j] - xc, X[j] - xc)) for j in range(r))
        B = np.eye(4)
        B[2:, 2:] = _rot(phi)
        out_x.append(B @ xc)
        out_P.append(B @ Pcm @ B.T)
        out_mu.append(mu.copy())
        out_phi.append(phi)
        # remember the combined estimate for eq. (8), then reset v_s
        p3, p2, p1 = p2, p1, xc[:2].copy()
        vel = (B @ xc)[2:]
        for j in range(r):
            X[j] = X[j].copy()
            X[j][3] = 0.0
            if reset_var:
                P[j] = P[j].copy()
                P[j][3, :] = 0.0
                P[j][:, 3] = 0.0
    return np.array(out_x), np.array(out_P), np.array(out_mu), np.array(out_phi)


def _data(seed, clutter, pd=1.0):
    truth = houles_truth(np.arange(61.0))   # 60 s: the straight leg and the first turn
    rng = np.random.default_rng(seed)
    s = houles_measurements(truth, rng, clutter_density=clutter, window=1500.0, pd=pd)
    # the two-point start uses target measurements at t = 0, 1 (drawn here if missed)
    z01 = [s.z[s.target_index[k]] if s.target_index[k] >= 0
           else truth[k, :2] + rng.normal(0.0, 20.0, 2) for k in (0, 1)]
    x0, P0 = two_point_init(z01[0], z01[1], R)
    return s.scans()[2:], x0, P0


CASES = [  # seed, clutter density, P_G, P_D
    (1, 0.0, 1.0, 1.0),
    (2, 4e-6, 0.9999, 1.0),
    (4, 0.0, 0.99, 0.7),    # misses without clutter: empty scans, nothing validated
    (5, 4e-6, 0.999, 0.8),
]


def _check(heading, case, reset_var=False, rotate=False):
    seed, clutter, pg, pd = case
    scans, x0, P0 = _data(seed, clutter, pd)
    models = tom_model_set(U, SIG_S, sigma_f=SIG_F, transition=PI, mu0=MU0, heading=heading,
                           reset_vs_variance=reset_var, rotate_covariance=rotate)
    res = imm_pdaf_track(models, scans, x0, P0, R, pd=pd, pg=pg, clutter_density=clutter)
    xs, Ps, mus, phis = reference_tom_imm(scans, x0, P0, pd=pd, pg=pg, lam=clutter,
                                          heading=heading, reset_var=reset_var,
                                          rotate=rotate)
    np.testing.assert_allclose(res.heading, phis, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.x, xs, rtol=1e-9, atol=1e-9 * np.abs(xs).max())
    np.testing.assert_allclose(res.P, Ps, rtol=1e-9, atol=1e-9 * np.abs(Ps).max())
    np.testing.assert_allclose(res.mu, mus, rtol=0, atol=1e-9)
    return scans, res, mus


@pytest.mark.parametrize("heading", ["chord", "chord_literal", "velocity"])
@pytest.mark.parametrize("case", CASES, ids=[f"seed{c[0]}" for c in CASES])
def test_tom_imm_equals_independent_loop(heading, case):
    scans, res, mus = _check(heading, case)
    seed, clutter, pg, pd = case
    # the case exercises what it should: the models disagree and all carry weight
    assert mus.min() < 0.05 and np.max(mus[:, 1]) > 0.5 and np.max(mus[:, 0]) > 0.5
    if clutter:
        assert sum(len(s) for s in scans) > 2 * len(scans)   # clutter was there
    else:
        # no clutter and P_D < 1: some scans are empty, so nothing is validated there
        assert (min(len(s) for s in scans) == 0) == (pd < 1)


@pytest.mark.parametrize("reset_var,rotate", [(True, False), (False, True), (True, True)])
@pytest.mark.parametrize("case", CASES, ids=[f"seed{c[0]}" for c in CASES])
def test_covariance_readings_equal_independent_loop(reset_var, rotate, case):
    _, res, _ = _check("chord", case, reset_var, rotate)
    # and they change the filter: the book's reading differs
    base = _check("chord", case)[1]
    assert np.max(np.abs(res.P - base.P)) > 1e-3


def test_empty_gate_keeps_the_prediction():
    """No clutter, nothing validated: the PDA keeps every model's prediction and the model
    probabilities stay at their predicted (mixed) values."""
    case = CASES[2]
    scans, x0, P0 = _data(case[0], case[1], case[3])
    k = next(i for i, s in enumerate(scans) if len(s) == 0)
    models = tom_model_set(U, SIG_S, sigma_f=SIG_F, transition=PI, mu0=MU0)
    a = imm_pdaf_track(models, scans[:k], x0, P0, R, pd=case[3], pg=case[2],
                       clutter_density=0.0)
    b = imm_pdaf_track(models, scans[:k + 1], x0, P0, R, pd=case[3], pg=case[2],
                       clutter_density=0.0)
    mu_prev = a.mu[-1] if k else MU0
    np.testing.assert_allclose(b.mu[-1], PI.T @ mu_prev, atol=1e-12)
    assert np.all(np.isfinite(b.x[-1])) and np.all(np.isfinite(b.P[-1]))
    # the combined estimate moved by one prediction: its covariance grew
    assert np.trace(b.P[-1][:2, :2]) > np.trace((a.P[-1] if k else P0)[:2, :2])


def test_heading_indices():
    """Default: the chord of the combined positions at k-2 and k-1 (scan k predicts from
    k-1 to k); literal eq. (8) index: the chord of k-3 and k-2; velocity: the direction of
    the combined velocity at k-1.  Checked on the tracker's own outputs."""
    scans, x0, P0 = _data(3, 0.0)
    out = {}
    for h in ("chord", "chord_literal", "velocity"):
        ms = tom_model_set(U, SIG_S, sigma_f=SIG_F, transition=PI, mu0=MU0, heading=h)
        out[h] = imm_pdaf_track(ms, scans, x0, P0, R, pg=1.0, clutter_density=0.0)
    p0 = x0[:2] - x0[2:]                    # the first measurement
    phi0 = math.atan2(x0[3], x0[2])

    def chord(a, b):
        return math.atan2(b[1] - a[1], b[0] - a[0])

    x = out["chord"].x
    pos = np.vstack([p0, x0[:2], x[:, :2]])  # positions at scans 0, 1, 2, ...
    np.testing.assert_allclose(out["chord"].heading,
                               [chord(pos[k], pos[k + 1]) for k in range(len(scans))],
                               atol=1e-12)
    x = out["chord_literal"].x
    pos = np.vstack([p0, x0[:2], x[:, :2]])
    lit = out["chord_literal"].heading
    assert lit[0] == pytest.approx(phi0, abs=1e-12)
    np.testing.assert_allclose(lit[1:], [chord(pos[k - 1], pos[k])
                                         for k in range(1, len(scans))], atol=1e-12)
    x = out["velocity"].x
    vel = np.vstack([x0[2:], x[:, 2:]])
    np.testing.assert_allclose(out["velocity"].heading,
                               [math.atan2(v[1], v[0]) for v in vel[:-1]], atol=1e-12)
    # in the turn (t = 20..35 s, scans 18..33 of the run) the three rules differ
    turn = slice(20, 33)
    assert np.max(np.abs(lit[turn] - out["chord"].heading[turn])) > 0.05
    assert np.max(np.abs(out["velocity"].heading[turn] - out["chord"].heading[turn])) > 0.05
