"""Every configuration and parameter record of the HPDA chapter checks its fields when it
is built, and the step-level SMC-PHD functions re-check a model record changed with
``_replace``: bad input gives a ValueError/TypeError that names the field."""
import math

import numpy as np
import pytest

from trackcore.association import hpda_betas, hpda_mixture_loglik
from trackcore.scenarios import HpdaParameters, hpda_stress_clutter_mean
from trackcore.trackers import (ClusteringConfig, HpdaPfConfig, SmcPhdConfig, smc_phd_filter,
                                smc_phd_model, smc_phd_step)

NAN = float("nan")
BASE = {"pd": 0.9, "clutter_density_xy": 3e-8}


@pytest.mark.parametrize("field, value, exc", [
    ("pi11", 1.1, ValueError), ("pi11", -0.1, ValueError), ("pi12", NAN, ValueError),
    ("T", NAN, ValueError), ("T", 0.0, ValueError), ("T", "10", TypeError),
    ("sigma_r", -1.0, ValueError), ("sigma_r", 0.0, ValueError), ("sigma_r", NAN, ValueError),
    ("sigma_theta", 0.0, ValueError), ("sigma_a", -1e-3, ValueError),
    ("a_m", math.inf, ValueError), ("snr", -1.0, ValueError), ("pd", 1.0, ValueError),
    ("pd", 0.0, ValueError), ("clutter_density_xy", 0.0, ValueError),
    ("n_particles", 0, ValueError), ("n_particles", 2.5, TypeError),
    ("n_particles", NAN, TypeError), ("p_confirm", 1.5, ValueError),
    ("p_terminate", 1.0, ValueError), ("gate_probability", 1.0, ValueError),
    ("p_initial", 0.0, ValueError), ("p_delete", -1e-3, ValueError),
    ("velocity_std", NAN, ValueError), ("tentative_sigma_a", -1.0, ValueError),
    ("max_confirmed", 0, ValueError), ("max_tentative", 0, ValueError),
    ("duplicate_scans", -1, ValueError), ("selection", "best", ValueError),
    ("tentative_yield", 1, TypeError), ("mode_tpm", ((1, 0, 0), (0, 1, 0)), ValueError),
    ("mode_tpm", ((0.5, 0.6, -0.1), (0, 1, 0), (0, 0, 1)), ValueError),
    ("mode_tpm", ((NAN, 1, 0), (0, 1, 0), (0, 0, 1)), ValueError),
])
def test_hpda_config_checks_every_field(field, value, exc):
    with pytest.raises(exc, match=field):
        HpdaPfConfig(**{"snr": 10.0, **BASE, field: value})


def test_hpda_config_cross_field_checks_and_normalisation():
    with pytest.raises(ValueError, match="p_terminate"):
        HpdaPfConfig(snr=10.0, **BASE, p_confirm=0.5, p_terminate=0.6)
    with pytest.raises(ValueError, match="p_delete"):
        HpdaPfConfig(snr=10.0, **BASE, p_delete=0.95)
    cfg = HpdaPfConfig(snr=np.float64(10), **BASE, n_particles=np.int32(50),
                       mode_tpm=np.eye(3))
    assert type(cfg.snr) is float and type(cfg.n_particles) is int
    assert cfg.mode_tpm == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    assert cfg.pi11 == 0.99   # the same death prior as the SMC-PHD survival probability
    assert cfg.pi11 == SmcPhdConfig(**BASE).p_survival


@pytest.mark.parametrize("field, value, exc", [
    ("sigma_r", 0.0, ValueError), ("sigma_theta", NAN, ValueError),
    ("eps_w", NAN, ValueError), ("eps_w", 0.0, ValueError), ("link_d2", -1.0, ValueError),
    ("link_d2", math.inf, ValueError), ("link_motion_std", -1.0, ValueError),
    ("link_motion_std", NAN, ValueError), ("seed_every_scan", "yes", TypeError),
    ("gated_support", 0, TypeError), ("eta", 0, ValueError), ("tau_b", 1.5, TypeError),
    ("tau_d", 0, ValueError), ("n_particles", -3, ValueError), ("pd", 1.2, ValueError),
    ("max_tracks", 0, ValueError), ("T", -10.0, ValueError),
])
def test_clustering_config_checks_every_field(field, value, exc):
    with pytest.raises(exc, match=field):
        ClusteringConfig(**{**BASE, field: value})


@pytest.mark.parametrize("field, value, exc", [
    ("pd", 1.1, ValueError), ("sigma_r", 0.0, ValueError), ("sigma_r", NAN, ValueError),
    ("n_birth", NAN, TypeError), ("n_birth", -1, ValueError), ("birth_mass", -0.1, ValueError),
    ("birth_mass", math.inf, ValueError), ("p_survival", 1.5, ValueError),
    ("n_per_target", 0, ValueError), ("kmeans_iterations", -1, ValueError),
    ("extraction_radius", 0.0, ValueError), ("max_estimates", 0, ValueError),
    ("max_particles", 10, ValueError), ("clutter_density_xy", NAN, ValueError),
])
def test_phd_config_checks_every_field(field, value, exc):
    with pytest.raises(exc, match=field):
        SmcPhdConfig(**{**BASE, field: value})


@pytest.mark.parametrize("field, value, exc", [
    ("sigma_r", NAN, ValueError), ("sigma_r", 0.0, ValueError), ("pd", 1.0, ValueError),
    ("snr", -1.0, ValueError), ("clutter_mean", -1.0, ValueError),
    ("clutter_mean", math.inf, ValueError), ("n_scans", 0, ValueError),
    ("n_scans", 4.5, TypeError), ("radius", 0.0, ValueError), ("T", NAN, ValueError),
    ("sigma_theta", 4.0, ValueError), ("a_m", -1.0, ValueError),
])
def test_parameters_check_every_field(field, value, exc):
    with pytest.raises(exc, match=field):
        HpdaParameters(**{"pd": 0.9, "snr": 10.0, "clutter_mean": 10.0, field: value})


def test_stress_clutter_mean():
    # lambda V_G = lambda V r g^2 sigma_r sigma_theta / radius^2 at the reference range
    lv = hpda_stress_clutter_mean(1.0)
    g2 = -2 * math.log(0.01)
    assert lv * 5000 * g2 * 150 * math.radians(3) / 1e8 == pytest.approx(1.0, rel=1e-12)
    assert hpda_stress_clutter_mean(0.5) == pytest.approx(lv / 2, rel=1e-12)
    with pytest.raises(ValueError, match="lambda_vg"):
        hpda_stress_clutter_mean(0.0)


def _model(**kw):
    T = 10.0
    F = np.array([[1, 0, T, 0], [0, 1, 0, T], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    return smc_phd_model(F, np.eye(4) * 0.01, np.diag([50.0 ** 2, 1e-4]), pd=0.9, ps=0.99,
                         clutter_intensity=1e-4, birth_mean=[3000.0, 0, 0, 0],
                         birth_cov=np.eye(4) * 100.0, n_birth=50, birth_rate=0.1, **kw)


@pytest.mark.parametrize("field, value, exc", [
    ("pd", 1.1, ValueError), ("pd", NAN, ValueError), ("ps", -0.5, ValueError),
    ("clutter_intensity", 0.0, ValueError), ("clutter_intensity", math.inf, ValueError),
    ("n_birth", NAN, TypeError), ("n_birth", -1, ValueError), ("birth_rate", -1.0, ValueError),
    ("F", [[1.0]], TypeError), ("F", np.full((4, 4), NAN), ValueError),
    ("L", np.eye(3), TypeError), ("R", np.eye(2).astype(np.float32), TypeError),
    ("R", np.array([[1.0, 0.1], [0.1, 1.0]]), ValueError), ("birth_mean", np.zeros(3), TypeError),
    ("sensor", (0.0, NAN), TypeError), ("gate", 0.0, ValueError),
])
def test_replaced_model_cannot_bypass_checks(field, value, exc):
    bad = _model()._replace(**{field: value})
    X, w = np.zeros((10, 4)), np.full(10, 0.1)
    z, off = np.array([[3000.0, 0.0]]), np.array([0, 1])
    with pytest.raises(exc, match=field):
        smc_phd_step(X, w, z, bad, np.random.default_rng(0))
    with pytest.raises(exc, match=field):
        smc_phd_filter(X, w, z, off, bad, np.random.default_rng(0))


def test_association_inputs_checked():
    X = np.array([[5000.0, 0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="symmetric"):
        hpda_mixture_loglik(X, [5000.0, 0.0], [[2500.0, 1.0], [0.0, 1e-6]], 0.5, 0.5, 5.0)
    with pytest.raises(ValueError, match="sensor"):
        hpda_mixture_loglik(X, [5000.0, 0.0], np.diag([2500.0, 1e-6]), 0.5, 0.5, 5.0,
                            sensor=(0.0, NAN))
    with pytest.raises(ValueError, match="p_target"):
        hpda_betas([0.1], [1.1], [0.2], 5.0)
    with pytest.raises(ValueError, match="p_false"):
        hpda_betas([0.1], [0.1], [-0.2], 5.0)
