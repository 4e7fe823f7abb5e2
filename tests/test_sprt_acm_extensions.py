"""Pinned S2/S3 runs, the decoy-only statistic, the manoeuvre-tolerant target filters,
record validation and the calibration helpers of the SPRT chapter (Jeong & Hong 1996)."""
import dataclasses
import math

import numpy as np
import pytest

import trackcore.detection.sprt as sprt_mod
import trackcore.models.modified_polar as mp_mod
import trackcore.scenarios.sprt_acm as scen_mod
import trackcore.trackers.sprt_discriminator as disc_mod
from trackcore.detection import (first_crossing_scan, gaussian_llr_walks, sprt_decide,
                                 sprt_summary, wald_error_probabilities,
                                 wald_expected_stopping_llr)
from trackcore.scenarios import (sprt_acm_filter_config, sprt_acm_measurements,
                                 sprt_acm_monte_carlo, sprt_acm_scenario, sprt_acm_truth)
from trackcore.trackers import SprtAcmFilterConfig, sprt_acm_discriminate

IDX = [0, 3, 7, 11]  # scans k = 1, 4, 8, 12

# Lambda (eq 21) and the decoy-filter-only statistic -Lambda_b0 + Lambda_a1 of four runs
# (sprt_acm_monte_carlo(scenario, 4, 2024 + n)) at scans 1, 4, 8, 12, the paper's filters
PINNED = {
    2: dict(
        llr=[[-1.7807568, -2.76140254, -6.95588674, -19.80616761],
             [-0.22471905, 0.80776479, 0.37308844, -8.20376993],
             [0.08513307, 0.74979112, -2.06117307, -14.08283725],
             [-0.01027713, 0.42700990, -1.46741849, -24.18348348]],
        acm=[[0.0, 1.06495878, -6.44299038, -17.94976169],
             [0.0, -0.79245985, 1.22491813, -7.90716981],
             [0.0, -2.68155755, -7.15239616, -19.25816687],
             [0.0, 0.18365598, -3.4868527, -27.26783898]],
        scans=[8, 12, 9, 11], scans_acm=[8, 12, 7, 11],
        boost=[[-1.7807568, -1.27779121, -19.70207938, -39.97124995],
               [-0.22471905, -0.65810097, -4.8935689, -19.08177721],
               [0.08513307, -3.61210240, -12.16145593, -30.43016214],
               [-0.01027713, -1.32850697, -14.4756724, -44.62887272]],
        scans_boost=[7, 9, 7, 6]),
    3: dict(
        llr=[[-2.34330333, 0.09645558, -0.88217237, -27.5344984],
             [1.2207746, 2.11898639, -0.00860942, -22.61395908],
             [-3.59742249, -3.90196888, -7.28118403, -47.45058906],
             [-0.19416326, 0.21709702, -2.27479142, -20.54110061]],
        acm=[[0.0, -0.98248214, -6.9146965, -35.3289559],
             [0.0, -1.90773221, 1.28803112, -22.33158212],
             [0.0, -0.04232829, -4.28544513, -42.94937804],
             [0.0, -0.63168147, -5.50126333, -23.7876654]],
        scans=[11, 10, 8, 10], scans_acm=[8, 10, 9, 8],
        boost=[[-2.34330333, -2.05126319, -17.38620922, -47.3931178],
               [1.2207746, -2.15534506, -14.69362189, -36.64651148],
               [-3.59742249, -4.06637887, -16.82289267, -58.46853014],
               [-0.19416326, -0.9427192, -19.87344983, -40.38626785]],
        scans_boost=[6, 6, 6, 5]),
}


@pytest.mark.parametrize("num", [2, 3])
def test_s2_s3_pinned_runs_and_decoy_only_statistic(num):
    sc = sprt_acm_scenario(num)
    res = sprt_acm_monte_carlo(sc, 4, 2024 + num)
    p = PINNED[num]
    assert res.ok.all()
    np.testing.assert_allclose(res.llr[:, IDX], p["llr"], rtol=1e-7, atol=1e-7)
    acm = -res.lam[..., 1] + res.lam[..., 2]
    np.testing.assert_allclose(acm[:, IDX], p["acm"], rtol=1e-7, atol=1e-7)
    d, k = sprt_decide(res.llr, -sc.gamma, sc.gamma)
    assert d.tolist() == [0, 0, 0, 0] and k.tolist() == p["scans"]
    d, k = sprt_decide(acm, -sc.gamma, sc.gamma)
    assert d.tolist() == [0, 0, 0, 0] and k.tolist() == p["scans_acm"]
    cfg = sprt_acm_filter_config(sc, target_model="boost", beta_std_factor=0.2)
    boost = sprt_acm_monte_carlo(sc, 4, 2024 + num, config=cfg)
    np.testing.assert_allclose(boost.llr[:, IDX], p["boost"], rtol=1e-7, atol=1e-7)
    assert sprt_decide(boost.llr, -sc.gamma, sc.gamma)[1].tolist() == p["scans_boost"]
    # the target filters of both statistics agree before the decoy filters start (k = 1)
    np.testing.assert_allclose(res.llr[:, 0], -res.lam[:, 0, 0] + res.lam[:, 0, 3])


def test_imm_with_identical_modes_and_empty_boost_equal_the_cv_filter():
    sc = sprt_acm_scenario(2)
    truth = sprt_acm_truth(sc)
    z = sprt_acm_measurements(sc, np.random.default_rng(3), truth)
    base = sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, sc.T)
    assert np.all(np.isnan(base.mu))
    # manoeuvre PSD a^2 T equal to the CV PSD sigma_v^2: both modes are the CV model
    same = SprtAcmFilterConfig(target_model="imm", manoeuvre_accel=2.0 / math.sqrt(sc.T))
    imm = sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, sc.T, same)
    np.testing.assert_allclose(imm.llr, base.llr, rtol=1e-9, atol=1e-9)
    assert np.all(np.isfinite(imm.mu)) and np.all((imm.mu >= 0) & (imm.mu <= 1))
    none = SprtAcmFilterConfig(target_model="boost", boost_time=0.0)
    np.testing.assert_array_equal(
        sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own, sc.T, none).llr, base.llr)


def test_imm_detects_a_turn_in_the_target_filter_on_the_target():
    # S3, 200 runs: the manoeuvre mode of a0 gains probability at the turn (k = 2)
    sc = sprt_acm_scenario(3)
    res = sprt_acm_monte_carlo(sc, 200, 5, config=sprt_acm_filter_config(
        sc, target_model="imm"))
    mu_a0 = res.mu[:, :4, 0].mean(axis=0)
    mu_b1 = res.mu[:, :4, 1].mean(axis=0)
    cfg = SprtAcmFilterConfig()
    assert mu_a0[0] == pytest.approx(cfg.manoeuvre_probability_at_release)
    assert mu_a0[1] > mu_a0[0] and mu_a0[1] > mu_b1[1]


def test_filter_config_validates_every_field():
    cfg = SprtAcmFilterConfig()
    assert cfg.manoeuvre_probability_at_release == pytest.approx(0.05 / 0.55)
    assert cfg.replace(beta_std_factor=0.2).beta_std_factor == 0.2
    for name in ("sigma_r", "sigma_theta", "sigma_rdot", "beta_std_factor", "init_pos_std",
                 "init_vel_std", "manoeuvre_accel", "p_stay_cv", "p_stay_manoeuvre"):
        for bad in (0.0, -1.0, float("nan"), float("inf")):
            with pytest.raises(ValueError, match=name):
                SprtAcmFilterConfig(**{name: bad})
    for name in ("sigma_v", "sigma_p", "boost_time"):
        with pytest.raises(ValueError, match=name):
            SprtAcmFilterConfig(**{name: -0.1})
        with pytest.raises(ValueError, match=name):
            SprtAcmFilterConfig(**{name: float("nan")})
        assert getattr(SprtAcmFilterConfig(**{name: 0.0}), name) == 0.0
    for name in ("p_stay_cv", "p_stay_manoeuvre"):
        with pytest.raises(ValueError, match=name):
            SprtAcmFilterConfig(**{name: 1.0})
    with pytest.raises(TypeError, match="sigma_r"):
        SprtAcmFilterConfig(sigma_r="5")
    with pytest.raises(TypeError, match="beta_std_factor"):
        SprtAcmFilterConfig(beta_std_factor=True)
    with pytest.raises(ValueError, match="target_model"):
        SprtAcmFilterConfig(target_model="ukf")
    with pytest.raises(TypeError, match="target_model"):
        SprtAcmFilterConfig(target_model=1)
    for bad in (0.0, -0.2, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="beta_std_factor_a1"):
            SprtAcmFilterConfig(beta_std_factor_a1=bad)
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="mu_release"):
            SprtAcmFilterConfig(mu_release=bad)
    with pytest.raises(TypeError, match="mu_release"):
        SprtAcmFilterConfig(mu_release="1")
    with pytest.raises(TypeError, match="beta_std_factor_a1"):
        SprtAcmFilterConfig(beta_std_factor_a1=True)
    assert SprtAcmFilterConfig(mu_release=0.0).manoeuvre_probability_at_release == 0.0
    with pytest.raises(TypeError, match="unknown"):
        cfg.replace(sigma=1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.sigma_r = 1.0
    sc = sprt_acm_scenario(1)
    with pytest.raises(TypeError, match="unknown"):
        sprt_acm_filter_config(sc, gamma=3.0)
    with pytest.raises(ValueError, match="beta_std_factor"):
        sprt_acm_filter_config(sc, beta_std_factor=-2.0)
    with pytest.raises(TypeError, match="scenario"):
        sprt_acm_filter_config("S1")
    with pytest.raises(TypeError, match="config"):
        sprt_acm_monte_carlo(sc, 2, 0, config={"sigma_r": 5.0})
    with pytest.raises(TypeError, match="h1_true"):
        sprt_acm_monte_carlo(sc, 2, 0, h1_true="yes")


@pytest.mark.parametrize("field,value,exc", [
    ("t_end", float("nan"), ValueError), ("t_release", float("inf"), ValueError),
    ("alpha_deg", float("nan"), ValueError), ("decoy_speed", float("nan"), ValueError),
    ("turn_accel", 0.0, ValueError), ("target_accel_psd", float("nan"), ValueError),
    ("R0", -1.0, ValueError), ("gamma", 0.0, ValueError), ("t_end", 30.0, ValueError),
    ("T", "2", TypeError), ("sigma_r", None, TypeError), ("lead_deg", True, TypeError),
    ("name", 1, TypeError), ("T", 1e-9, ValueError),
])
def test_scenario_validates_every_field(field, value, exc):
    with pytest.raises(exc, match=field):
        sprt_acm_scenario(1, **{field: value})


def test_scenario_nan_end_time_is_a_clear_error():
    with pytest.raises(ValueError, match="t_end must be finite"):
        sprt_acm_scenario(1, t_end=float("nan"))


def test_no_kernel_is_public():
    import trackcore.detection
    import trackcore.models
    import trackcore.scenarios
    import trackcore.trackers
    mods = (sprt_mod, mp_mod, scen_mod, disc_mod)
    for mod in mods:
        assert not [n for n in mod.__all__ if n.endswith("_kernel")], mod.__name__
    # nor does a package re-export a kernel of these modules
    kernels = {n for mod in mods for n in vars(mod) if n.endswith("_kernel")
               and getattr(vars(mod)[n], "__module__", "") == mod.__name__}
    assert kernels >= {"sprt_decide_kernel", "modified_polar_f_kernel",
                       "modified_polar_F_kernel", "sprt_acm_discriminate_kernel"}
    for pkg in (trackcore.detection, trackcore.models, trackcore.scenarios, trackcore.trackers):
        assert not kernels & set(pkg.__all__), pkg.__name__
    # the kernels are still there for the package, imported from their modules
    assert callable(sprt_mod.sprt_decide_kernel) and callable(mp_mod.modified_polar_f_kernel)


def test_scenario_that_passes_too_close_is_refused_by_name():
    # S3 with alpha 45, lead 20 brings the pursuer within about 5 m of the target: the
    # range noise would give non-positive ranges, so the scenario is refused, not the data
    sc = sprt_acm_scenario(3, alpha_deg=45.0, lead_deg=20.0)
    with pytest.raises(ValueError, match="scenario S3: the target comes within"):
        sprt_acm_monte_carlo(sc, 3, 0)
    with pytest.raises(ValueError, match="t_end"):
        sprt_acm_measurements(sc, np.random.default_rng(0))
    # ending the run before the close pass is accepted
    ok = sprt_acm_monte_carlo(sprt_acm_scenario(3, alpha_deg=45.0, lead_deg=20.0,
                                                t_end=75.0), 3, 0)
    assert ok.ok.all() and np.all(np.isfinite(ok.llr))
    # a decoy whose apparent range shrinks to the pursuer is refused as well
    with pytest.raises(ValueError, match="decoy"):
        sprt_acm_monte_carlo(sprt_acm_scenario(3, decoy_speed=-20.0), 2, 0)


def test_a1_only_prior_and_imm_release_cue():
    sc = sprt_acm_scenario(2)
    base = sprt_acm_monte_carlo(sc, 20, 7)
    a1 = sprt_acm_monte_carlo(sc, 20, 7, config=sprt_acm_filter_config(
        sc, beta_std_factor_a1=0.2))
    # b0 (track b) is untouched, a1 (track a) changes
    np.testing.assert_array_equal(a1.lam[..., 1], base.lam[..., 1])
    np.testing.assert_array_equal(a1.lam[..., [0, 3]], base.lam[..., [0, 3]])
    assert not np.allclose(a1.lam[:, 2:, 2], base.lam[:, 2:, 2])
    same = sprt_acm_monte_carlo(sc, 20, 7, config=sprt_acm_filter_config(
        sc, beta_std_factor_a1=2.0))
    np.testing.assert_array_equal(same.llr, base.llr)
    cue = sprt_acm_filter_config(sc, target_model="imm", mu_release=1.0)
    assert cue.manoeuvre_probability_at_release == 1.0
    res = sprt_acm_monte_carlo(sc, 20, 7, config=cue)
    assert np.all(res.mu[:, 0, :] == 1.0) and np.all(res.mu[:, 1:, :] < 1.0)


def test_first_crossing_scan_interpolates():
    path = np.array([-1.0, -2.0, -4.0, -3.0])
    assert first_crossing_scan(path, -3.0) == pytest.approx(2.5)
    assert first_crossing_scan(path, -0.5) == pytest.approx(0.5)   # from Lambda(0) = 0
    assert first_crossing_scan(path, -2.0) == pytest.approx(2.0)
    assert math.isnan(first_crossing_scan(path, -5.0))
    assert first_crossing_scan(-path, 3.0) == pytest.approx(2.5)
    assert math.isnan(first_crossing_scan(path, 1.0))
    with pytest.raises(ValueError, match="level"):
        first_crossing_scan(path, 0.0)
    with pytest.raises(ValueError, match="path"):
        first_crossing_scan(np.zeros((2, 2)), -1.0)
    s = sprt_summary(np.array([[-1.0, -2.0, -4.0], [-1.0, -2.0, -4.0]]), -3.0, 3.0)
    assert s.mean_llr_crossing == 3 and s.mean_llr_crossing_scan == pytest.approx(2.5)
    assert math.isnan(sprt_summary(np.zeros((2, 3)), -3.0, 3.0).mean_llr_crossing_scan)


def test_gaussian_llr_walks_are_true_likelihood_ratios():
    rng = np.random.default_rng(11)
    W = gaussian_llr_walks(0.5, 200_000, 3, rng)
    assert W.shape == (200_000, 3)
    # E_H0[exp(Lambda(k))] = 1 for a true likelihood ratio (std of the mean ~ 0.005-0.01)
    np.testing.assert_allclose(np.exp(W).mean(axis=0), 1.0, atol=0.04)
    np.testing.assert_allclose(W[:, 0].mean(), -0.25, atol=0.01)
    W1 = gaussian_llr_walks(0.5, 1000, 2, np.random.default_rng(1), h1_true=True)
    assert W1[:, 0].mean() > 0
    # Ville's inequality: a true LLR ever reaches gamma with probability <= e^-gamma, so
    # the SPRT errs with probability <= (1 - P_M) e^-gamma1 (Wald's bound); here both
    # are far from the MC error (std ~ 0.001)
    W2 = gaussian_llr_walks(1.0, 100_000, 200, rng)
    d, _ = sprt_decide(W2, -2.0, 2.0)
    assert np.mean((W2 >= 2.0).any(axis=1)) < math.exp(-2.0) - 0.005
    assert np.mean(d == 1) <= np.mean((W2 >= 2.0).any(axis=1))
    assert np.mean(d == 1) < wald_error_probabilities(-2.0, 2.0)[0]
    # per-scan variances: a non-stationary true LLR; the scalar form is its special case
    v = np.array([0.2, 0.5, 1.0, 2.0])
    Wv = gaussian_llr_walks(v, 200_000, 4, np.random.default_rng(4))
    np.testing.assert_allclose(np.diff(np.r_[0.0, Wv.mean(axis=0)]), -v / 2, atol=0.01)
    np.testing.assert_allclose(np.exp(Wv).mean(axis=0), 1.0, atol=0.05)
    np.testing.assert_array_equal(
        gaussian_llr_walks(0.5, 10, 3, np.random.default_rng(2)),
        gaussian_llr_walks(np.full(3, 0.5), 10, 3, np.random.default_rng(2)))
    with pytest.raises(ValueError, match="n_scans"):
        gaussian_llr_walks(v, 10, 3, rng)
    with pytest.raises(ValueError, match="var"):
        gaussian_llr_walks(np.array([1.0, 0.0, 1.0]), 10, 3, rng)
    for bad in (dict(var=0.0), dict(var=float("nan"))):
        with pytest.raises(ValueError, match="var"):
            gaussian_llr_walks(bad["var"], 10, 2, rng)
    with pytest.raises(ValueError, match="n_runs"):
        gaussian_llr_walks(1.0, -1, 2, rng)
    with pytest.raises(TypeError, match="rng"):
        gaussian_llr_walks(1.0, 1, 2, 42)
    with pytest.raises(TypeError, match="h1_true"):
        gaussian_llr_walks(1.0, 1, 2, rng, h1_true=1)


def test_wald_expected_stopping_llr():
    g = math.log(19.0)
    pf, _ = wald_error_probabilities(-g, g)
    assert wald_expected_stopping_llr(-g, g, 1 - pf) == pytest.approx(-g * math.tanh(g / 2))
    assert wald_expected_stopping_llr(-1.0, 2.0, 1.0) == -1.0
    with pytest.raises(ValueError, match="p_decide_h0"):
        wald_expected_stopping_llr(-1.0, 1.0, 1.5)
    with pytest.raises(ValueError, match="gamma0"):
        wald_expected_stopping_llr(1.0, 1.0, 0.5)


def test_huge_and_tiny_inputs_give_clear_errors_or_finite_results():
    from trackcore.detection import (SprtState, sprt_step, sprt_symmetric_error,
                                     wald_gaussian_oc_asn)
    from trackcore.models import modified_polar_F, modified_polar_f, modified_polar_Q
    from trackcore.trackers import sprt_acm_llr
    assert sprt_symmetric_error(1e300) == 0.0
    with pytest.raises(ValueError, match="overflow"):
        modified_polar_F([0.1, 1e300], [1e300, 1.0])
    assert np.all(np.isfinite(modified_polar_f([0.1, 1e300], [1e300, 1e300])))
    with pytest.raises(ValueError, match="overflow"):
        modified_polar_Q([0.1, 1e300], 1e300, 1e300)
    with pytest.raises(ValueError, match="mean / var"):
        wald_gaussian_oc_asn(1e300, 1e-300, -1.0, 1.0)
    with pytest.raises(ValueError, match="var"):
        gaussian_llr_walks(1e308, 3, 5, np.random.default_rng(0))
    with pytest.raises(ValueError, match="lam"):
        sprt_acm_llr(np.full((2, 4), 1e308))
    assert np.isnan(sprt_acm_llr(np.full((1, 4), np.nan))).all()  # a failed run stays NaN
    assert first_crossing_scan([1e308, -1e308], -1.0) == pytest.approx(1.5)
    # the online state validates its fields, and the step cannot overflow silently
    for bad, exc in ((dict(llr=float("nan")), ValueError), (dict(k=-1), ValueError),
                     (dict(decision=2), ValueError), (dict(decision=0, scan=0), ValueError),
                     (dict(k=1.5), TypeError), (dict(scan=3), ValueError)):
        with pytest.raises(exc):
            SprtState(**bad)
    with pytest.raises(ValueError, match="overflow"):
        sprt_step(SprtState(llr=1e308), 1e308, -1.0, 1.0)
    # scenario and measurement magnitudes far beyond any sonar are refused by name
    for field in ("R0", "target_speed", "decoy_speed", "sigma_r", "T", "turn_accel"):
        with pytest.raises(ValueError, match=field):
            sprt_acm_scenario(2, **{field: 1e300})
    with pytest.raises(ValueError, match="t_release"):
        sprt_acm_scenario(1, t_release=1e-300)
    with pytest.raises(ValueError, match="R0"):
        sprt_acm_scenario(1, R0=1e-300)
    sc = sprt_acm_scenario(1)
    truth = sprt_acm_truth(sc)
    z = sprt_acm_measurements(sc, np.random.default_rng(0), truth)
    big = z.z_a.copy()
    big[2, 0] = 1e300
    with pytest.raises(ValueError, match="z_a"):
        sprt_acm_discriminate(z.z_pre, big, z.z_b, truth.own, sc.T)
    with pytest.raises(ValueError, match="own_states"):
        sprt_acm_discriminate(z.z_pre, z.z_a, z.z_b, truth.own * 1e300, sc.T)
    for field in ("sigma_r", "manoeuvre_accel", "beta_std_factor"):
        with pytest.raises(ValueError, match=field):
            SprtAcmFilterConfig(**{field: 1e300})
