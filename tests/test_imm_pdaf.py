"""Tests for trackcore.trackers.imm_pdaf (IMM-PDAF with Singer, CAR and TOM model sets)."""
import math

import numpy as np
import pytest

from trackcore.association import gate_threshold, mahalanobis_gate
from trackcore.models import tom_process_noise, tom_transition
from trackcore.scenarios import houles_measurements, houles_truth
from trackcore.scenarios._tom_book import filterpy_imm_run
from trackcore.trackers import (
    IMMModelSet,
    car_imm_model_set,
    imm_pdaf_track,
    imm_pdaf_track_packed,
    markov_matrix,
    pack_scans,
    singer_imm_model_set,
    tom_imm_model_set,
    two_point_init,
)

R = 400.0 * np.eye(2)
TRUTH = houles_truth(np.arange(91.0))


def _clean_run(seed):
    """P_D = 1, no clutter: one measurement per scan, plus the two-point init."""
    s = houles_measurements(TRUTH, np.random.default_rng(seed), clutter_density=0.0)
    zs = s.z  # one row per scan, in scan order
    x0, P0 = two_point_init(zs[0], zs[1], R)
    return zs[2:], x0, P0


@pytest.mark.parametrize("make", [car_imm_model_set, singer_imm_model_set])
@pytest.mark.parametrize("seed", [0, 1])
def test_equals_filterpy_imm_without_clutter(make, seed):
    models = make()
    zs, x0, P0 = _clean_run(seed)
    res = imm_pdaf_track(models, list(zs[:, None, :]), x0, P0, R, pd=1.0, pg=1.0,
                         clutter_density=0.0)
    xs, Ps, mus = filterpy_imm_run(models, zs, x0, P0, R)
    idx = models.out_index
    np.testing.assert_allclose(res.x, xs[:, idx], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(res.P, Ps[:, idx][:, :, idx], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(res.mu, mus, rtol=1e-9, atol=1e-12)


def test_tom_identical_models_is_the_tom_kalman_cycle():
    """Three identical TOM models (u = 0) make the IMM a single KF with the TOM cycle:
    heading from the chord of the last two estimates, v_s <- 0, predict, update."""
    models = tom_imm_model_set(u=0.0, sigma_f=2.0, sigma_s_centre=15.0, sigma_s_turn=15.0)
    zs, x0, P0 = _clean_run(3)
    res = imm_pdaf_track(models, list(zs[:, None, :]), x0, P0, R, pd=1.0, pg=1.0,
                         clutter_density=0.0)
    phi = math.atan2(x0[3], x0[2])
    c, s = math.cos(phi), math.sin(phi)
    B = np.eye(4)
    B[2:, 2:] = [[c, s], [s, -c]]
    x, P = B @ x0, B @ P0 @ B.T
    prev2, prev1 = x0[:2] - x0[2:], x0[:2].copy()
    H = np.hstack([np.eye(2), np.zeros((2, 2))])
    for k, z in enumerate(zs):
        phi = math.atan2(prev1[1] - prev2[1], prev1[0] - prev2[0])
        x = x.copy()
        x[3] = 0.0
        F = tom_transition(phi, 1.0)
        x, P = F @ x, F @ P @ F.T + tom_process_noise(phi, 1.0, 2.0, 15.0)
        S = H @ P @ H.T + R
        Kg = P @ H.T @ np.linalg.inv(S)
        x = x + Kg @ (z - H @ x)
        IKH = np.eye(4) - Kg @ H
        P = IKH @ P @ IKH.T + Kg @ R @ Kg.T
        c, s = math.cos(phi), math.sin(phi)
        Rot = np.array([[c, s], [s, -c]])
        np.testing.assert_allclose(res.x[k, :2], x[:2], rtol=1e-9, atol=1e-8)
        np.testing.assert_allclose(res.x[k, 2:], Rot @ x[2:], rtol=1e-9, atol=1e-8)
        assert res.heading[k] == pytest.approx(phi, abs=1e-12)
        prev2, prev1 = prev1, x[:2].copy()


def test_tom_lateral_input_moves_prediction_right():
    """With the target flying straight north, the +u model predicts u*T to the east."""
    models = tom_imm_model_set()
    x0 = np.array([0.0, 0.0, 0.0, 400.0])
    P0 = np.diag([100.0, 100.0, 100.0, 100.0])
    res = imm_pdaf_track(models, [np.zeros((0, 2))], x0, P0, R, clutter_density=0.0)
    # no measurement: combined = mixture of predictions; predictions per model
    # are 400 m north and (0, +70, -70) m east; mu after an empty scan = mu0 @ Pi
    c = models.mu0 @ models.transition
    assert res.x[0, 0] == pytest.approx(c[1] * 70.0 - c[2] * 70.0, abs=1e-9)
    assert res.x[0, 1] == pytest.approx(400.0, abs=1e-9)
    np.testing.assert_allclose(res.mu[0], c, atol=1e-15)
    assert res.heading[0] == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("make", [singer_imm_model_set, car_imm_model_set, tom_imm_model_set])
def test_empty_scans_markov_only(make):
    models = make()
    x0 = np.array([0.0, 0.0, 100.0, 50.0])
    P0 = np.eye(4) * 50.0
    res = imm_pdaf_track(models, [[] for _ in range(4)], x0, P0, R)
    mu = models.mu0.copy()
    for k in range(4):
        mu = mu @ models.transition
        np.testing.assert_allclose(res.mu[k], mu, atol=1e-14)
    assert np.all(np.isfinite(res.x)) and res.gated.shape == (0,)
    # the covariance grows without measurements
    assert np.all(np.diff([np.trace(P[:2, :2]) for P in res.P]) > 0)


def test_gated_is_union_of_model_gates():
    models = car_imm_model_set()
    s = houles_measurements(TRUTH[:12], np.random.default_rng(11), clutter_density=5e-5,
                            window=600.0)
    x0, P0 = two_point_init(s.z[s.target_index[0]], s.z[s.target_index[1]], R)
    z, off = s.z[s.offsets[2]:], s.offsets[2:] - s.offsets[2]
    res = imm_pdaf_track_packed(models, z, off, x0, P0, R, clutter_density=5e-5)
    # scan 0: recompute the per-model gates from the mixed predictions
    gamma = gate_threshold(0.99, 2)
    X = np.array([x0] * 3)
    Pm = np.array([P0] * 3)
    c = models.mu0 @ models.transition
    union = np.zeros(off[1], bool)
    for j in range(3):
        w = models.transition[:, j] * models.mu0 / c[j]
        xm = w @ X
        Pmix = sum(w[i] * (Pm[i] + np.outer(X[i] - xm, X[i] - xm)) for i in range(3))
        xp = models.F[j] @ xm
        Pp = models.F[j] @ Pmix @ models.F[j].T + models.Q[j]
        S = models.H @ Pp @ models.H.T + R
        mask, _ = mahalanobis_gate(z[:off[1]], models.H @ xp, S, gamma)
        union |= mask
    np.testing.assert_array_equal(res.gated[:off[1]], union)
    assert res.gated.sum() < res.gated.size  # clutter was rejected


def test_houles_small_monte_carlo_sane():
    errs = {name: [] for name in ("Singer", "CAR", "TOM")}
    sets = dict(Singer=singer_imm_model_set(), CAR=car_imm_model_set(), TOM=tom_imm_model_set())
    for seed in range(20):
        s = houles_measurements(TRUTH, np.random.default_rng(100 + seed))
        x0, P0 = two_point_init(s.z[s.target_index[0]], s.z[s.target_index[1]], R)
        z, off = s.z[s.offsets[2]:], s.offsets[2:] - s.offsets[2]
        for name, ms in sets.items():
            res = imm_pdaf_track_packed(ms, z, off, x0, P0, R)
            assert np.allclose(res.mu.sum(axis=1), 1.0)
            e = np.linalg.norm(res.x[:20, :2] - TRUTH[2:22, :2], axis=1)
            errs[name].append(np.sqrt(np.mean(e**2)))
    for name, v in errs.items():
        # before the first turn every filter tracks to well below the 20 m noise per axis
        assert np.median(v) < 25.0, (name, np.median(v))


def test_model_set_builders():
    car = car_imm_model_set(omega=0.2)
    assert car.F.shape == (3, 4, 4) and car.labels[0] == "CV"
    np.testing.assert_allclose(car.transition, markov_matrix(3, 0.9))
    sing = singer_imm_model_set()
    assert sing.F.shape == (3, 6, 6)
    np.testing.assert_array_equal(sing.F[0, 4:, :], 0.0)  # CV: acceleration forced to 0
    tom = tom_imm_model_set(u=60.0)
    np.testing.assert_array_equal(tom.u, [0.0, 60.0, -60.0])
    assert tom.var_s[0] < tom.var_s[1] == tom.var_s[2]
    np.testing.assert_allclose(markov_matrix(3, 0.9).sum(axis=1), 1.0)


def test_pack_scans():
    z, off = pack_scans([np.zeros((0, 2)), [[1.0, 2.0]], np.ones((3, 2))])
    assert z.shape == (4, 2)
    np.testing.assert_array_equal(off, [0, 0, 1, 4])
    with pytest.raises(ValueError, match=r"scans\[1\]"):
        pack_scans([np.zeros((1, 2)), np.zeros((1, 3))])


def test_bad_inputs():
    models = car_imm_model_set()
    x0, P0 = np.zeros(4), np.eye(4)
    scans = [np.zeros((1, 2))]
    with pytest.raises(TypeError, match="models"):
        imm_pdaf_track("car", scans, x0, P0, R)
    with pytest.raises(ValueError, match="x0"):
        imm_pdaf_track(models, scans, np.zeros(3), P0, R)
    with pytest.raises(ValueError, match="P0"):
        imm_pdaf_track(models, scans, x0, -np.eye(4), R)
    with pytest.raises(ValueError, match="R"):
        imm_pdaf_track(models, scans, x0, P0, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="pd"):
        imm_pdaf_track(models, scans, x0, P0, R, pd=1.2)
    with pytest.raises(ValueError, match="pg"):
        imm_pdaf_track(models, scans, x0, P0, R, pg=0.0)
    with pytest.raises(ValueError, match="clutter_density"):
        imm_pdaf_track(models, scans, x0, P0, R, clutter_density=-1.0)
    with pytest.raises(ValueError, match=r"scans\[0\]"):
        imm_pdaf_track(models, [np.full((1, 2), np.nan)], x0, P0, R)
    with pytest.raises(ValueError, match="offsets"):
        imm_pdaf_track_packed(models, np.zeros((2, 2)), np.array([0, 1]), x0, P0, R)
    with pytest.raises(ValueError, match="offsets"):
        imm_pdaf_track_packed(models, np.zeros((2, 2)), np.array([0.0, 2.0]), x0, P0, R)
    with pytest.raises(ValueError, match="transition"):
        car_imm_model_set(transition=np.full((3, 3), 0.5))
    with pytest.raises(ValueError, match="mu0"):
        car_imm_model_set(mu0=(0.5, 0.5, 0.5))
    with pytest.raises(ValueError, match="p_stay"):
        markov_matrix(3, 1.5)
    with pytest.raises(ValueError, match="sigma_s_turn"):
        tom_imm_model_set(sigma_s_turn=-1.0)
    with pytest.raises(ValueError, match="kind"):
        tom_imm_model_set(kind="white")
    with pytest.raises(ValueError, match="tau"):
        singer_imm_model_set(tau=(0.0, 5.0))
    with pytest.raises(ValueError, match="R"):
        two_point_init([0, 0], [1, 1], -np.eye(2))
    # the TOM's frame needs a heading: a zero initial velocity is an error, not phi0 = 0
    with pytest.raises(ValueError, match="x0"):
        imm_pdaf_track(tom_imm_model_set(), scans, np.zeros(4), P0, R)
    with pytest.raises(ValueError, match="sigma_s"):
        tom_model_set([0.0], [1e200])
    with pytest.raises(TypeError, match="rotate_covariance"):
        tom_imm_model_set(rotate_covariance=1)


# ---------------------------------------------------------------- records and builders
import dataclasses  # noqa: E402

from trackcore.trackers import (  # noqa: E402
    TOM_HEADINGS,
    ct_imm_model_set,
    cv_model_set,
    tom_model_set,
)


def test_model_set_record_validates_every_field():
    good = car_imm_model_set()
    for field, value, err in [
        ("T", -1.0, ValueError), ("T", float("nan"), ValueError), ("T", "1", TypeError),
        ("F", np.zeros((3, 4, 5)), ValueError), ("Q", -np.ones((3, 4, 4)), ValueError),
        ("Q", np.full((3, 4, 4), np.nan), ValueError), ("H", np.zeros((2, 6)), ValueError),
        ("transition", np.full((3, 3), 0.5), ValueError), ("mu0", [0.5, 0.5, 0.5], ValueError),
        ("mu0", [1.1, -0.1, 0.0], ValueError), ("embed", np.eye(4)[:, :3], ValueError),
        ("init_var", -np.ones(4), ValueError), ("out_index", [0.0, 1.0, 2.0, 3.0], TypeError),
        ("out_index", [0, 1, 2, 9], ValueError), ("labels", ("a", "b"), ValueError),
        ("name", 3, TypeError), ("tom", 1, TypeError), ("cwna", "no", TypeError),
        ("u", np.zeros(2), ValueError), ("var_s", -np.ones(3), ValueError),
        ("var_f", np.full(3, np.inf), ValueError), ("heading", "compass", ValueError),
    ]:
        with pytest.raises(err, match=field):
            dataclasses.replace(good, **{field: value})
    with pytest.raises(ValueError, match="T"):
        IMMModelSet("x", ("CV",), np.eye(4)[None], np.zeros((1, 4, 4)), np.eye(2, 4),
                    np.ones((1, 1)), np.ones(1), np.eye(4), np.zeros(4), np.arange(4), T=-1)
    # TOM needs the 4-state
    sing = singer_imm_model_set()
    with pytest.raises(ValueError, match="tom"):
        dataclasses.replace(sing, tom=True)
    # TOM-only fields on a non-TOM set would be ignored silently: refused
    for field, value in [("u", np.full(3, 70.0)), ("var_f", np.ones(3)),
                         ("var_s", np.ones(3)), ("cwna", True), ("heading", "velocity"),
                         ("reset_vs_variance", True), ("rotate_covariance", True)]:
        with pytest.raises(ValueError, match=field):
            dataclasses.replace(good, **{field: value})
    # ... while zeros and defaults (what replace() passes back) are accepted
    dataclasses.replace(good, u=np.zeros(3), var_f=np.zeros(3), name="CAR again")
    tom = tom_imm_model_set()
    for field in ("reset_vs_variance", "rotate_covariance"):
        assert getattr(dataclasses.replace(tom, **{field: True}), field) is True
        with pytest.raises(TypeError, match=field):
            dataclasses.replace(tom, **{field: "yes"})


def test_markov_matrix_checks_r():
    with pytest.raises(ValueError, match="r"):
        markov_matrix(2.5, 0.9)
    with pytest.raises(TypeError, match="r"):
        markov_matrix(True, 0.9)
    with pytest.raises(ValueError, match="r"):
        markov_matrix(0, 0.9)
    np.testing.assert_array_equal(markov_matrix(1, 0.3), [[1.0]])
    np.testing.assert_allclose(markov_matrix(2.0, 0.9), [[0.9, 0.1], [0.1, 0.9]])
    np.testing.assert_allclose(markov_matrix(4, 0.7).sum(axis=1), 1.0)


def test_general_builders():
    ct = ct_imm_model_set([0.0, -0.15, 0.1], [1.0, 8.0, 8.0])
    assert ct.r == 3 and ct.labels[0] == "CV" and not ct.tom
    np.testing.assert_allclose(ct.mu0, [0.8, 0.1, 0.1])
    car = car_imm_model_set(omega=0.14)
    np.testing.assert_allclose(ct_imm_model_set([0.0, 0.14, -0.14], [1.0, 8.0, 8.0]).F, car.F)
    assert car.name == "CAR-IMM"
    kf = cv_model_set(sigma=2.0)
    assert kf.r == 1 and kf.name == "CV-KF"
    np.testing.assert_array_equal(kf.transition, [[1.0]])
    tom = tom_model_set([0.0], [3.0])
    assert tom.r == 1 and tom.tom and tom.heading == "chord"
    assert set(TOM_HEADINGS) == {"chord", "chord_literal", "velocity", "chord_mean2",
                                 "chord_mean3", "smoothed", "heading_rate_kf"}
    t3 = tom_imm_model_set(heading="chord_literal", kind="cwna")
    assert t3.heading == "chord_literal" and t3.cwna and t3.labels[1].endswith("(right)")
    t4 = tom_model_set([0.0, 50.0, -50.0, 20.0], [1.0, 2.0, 3.0, 4.0], sigma_f=[1, 2, 3, 4])
    np.testing.assert_allclose(t4.var_f, [1, 4, 9, 16])
    np.testing.assert_allclose(t4.mu0.sum(), 1.0)
    with pytest.raises(ValueError, match="sigma_s"):
        tom_model_set([0.0, 1.0], [1.0])
    with pytest.raises(ValueError, match="sigma_f"):
        tom_model_set([0.0, 1.0], [1.0, 1.0], sigma_f=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="heading"):
        tom_model_set([0.0], [1.0], heading="gps")
    with pytest.raises(ValueError, match="sigmas"):
        ct_imm_model_set([0.0, 0.1], [1.0, -1.0])
    with pytest.raises(ValueError, match="omegas"):
        ct_imm_model_set([], [])


def test_cv_model_set_is_a_kalman_filter():
    """One CV model, P_D = 1, no clutter, no gate: the IMM-PDAF is the Kalman filter."""
    from trackcore.models import cv_process_noise
    zs, x0, P0 = _clean_run(5)
    res = imm_pdaf_track(cv_model_set(), list(zs[:, None, :]), x0, P0, R, pg=1.0,
                         clutter_density=0.0)
    F = np.eye(4)
    F[0, 2] = F[1, 3] = 1.0
    Q = cv_process_noise(1.0, 1.0)
    H = np.hstack([np.eye(2), np.zeros((2, 2))])
    x, P = x0.copy(), P0.copy()
    for k, z in enumerate(zs):
        x, P = F @ x, F @ P @ F.T + Q
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        x = x + K @ (z - H @ x)
        P = (np.eye(4) - K @ H) @ P
        np.testing.assert_allclose(res.x[k], x, rtol=1e-9, atol=1e-8)
        np.testing.assert_allclose(res.P[k], P, rtol=1e-8, atol=1e-8)
    np.testing.assert_array_equal(res.mu, 1.0)


def test_kernels_are_not_public():
    import trackcore.models as models
    import trackcore.trackers as trackers
    for mod in (models, trackers):
        assert not [n for n in mod.__all__ if n.endswith("_kernel")
                    and n.startswith(("tom_", "chord_", "imm_pdaf"))]
