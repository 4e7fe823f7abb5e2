"""The TBD chapter's stronger baselines (trackcore/trackers/tbd_baselines.py)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
from trackcore.scenarios.tbd_radar import TBD_INITIAL_COVARIANCE as P0
from trackcore.trackers import TbdTrackerConfig, run_tbd_tracker
from trackcore.trackers.tbd_baselines import run_tbd_gated_b, run_tbd_imm, run_tbd_snr_ekf

K = 60


@pytest.fixture(scope="module")
def run():
    prm = TbdRadarParameters()
    truth = tbd_radar_truth(prm)
    scans = simulate_tbd_radar(truth, prm, np.random.default_rng(5))
    cut = scans.offsets[K]
    short = replace(scans, positions=scans.positions[:cut], range_rate=scans.range_rate[:cut],
                    snr=scans.snr[:cut], offsets=scans.offsets[: K + 1])
    x0 = truth.states[0] + np.array([150.0, -100.0, 50.0, 5.0, -5.0, 0.0])
    return short, x0


def test_ungated_b_is_method_b(run):
    scans, x0 = run
    cfg = TbdTrackerConfig(method="B", gate=math.inf)
    ref = run_tbd_tracker(scans, x0, P0, np.random.default_rng(1), cfg)
    got = run_tbd_gated_b(scans, x0, P0, np.random.default_rng(1), cfg)
    assert np.array_equal(got.estimates, ref.estimates), "gate = inf must give method B"
    assert np.array_equal(got.resampled, ref.resampled), "same resampling as method B"


def test_closed_gate_never_updates(run):
    scans, x0 = run
    cfg = TbdTrackerConfig(method="B", gate=1e-12)
    got = run_tbd_gated_b(scans, x0, P0, np.random.default_rng(1), cfg)
    assert not got.accepted.any(), "a zero gate accepts nothing"
    assert np.allclose(got.ess, 600), "without updates the weights stay uniform"
    opened = run_tbd_gated_b(scans, x0, P0, np.random.default_rng(1),
                             TbdTrackerConfig(method="B"))
    assert opened.accepted.mean() > 0.5, "A's gate accepts most scans near the truth"


def test_snr_covariance_at_the_threshold_is_method_a(run):
    scans, x0 = run
    tau = 10.0 ** 0.5
    flat = replace(scans, snr=np.full_like(scans.snr, tau))
    cfg = TbdTrackerConfig(method="A")
    ref = run_tbd_tracker(flat, x0, P0, np.random.default_rng(1), cfg)
    got = run_tbd_snr_ekf(flat, x0, P0, cfg, threshold=tau)
    assert np.allclose(got.estimates, ref.estimates, rtol=1e-12, atol=1e-9), (
        "every detection at the threshold: the calibrated sigma, method A")
    real = run_tbd_snr_ekf(scans, x0, P0, cfg)
    s = real.ess[np.isfinite(real.ess)]
    assert s.size and np.all((s >= 25.0) & (s <= cfg.pseudo_sigmas[0])), (
        "sigma_p,k lies between the floor and the calibrated sigma")


def test_imm_of_one_model_is_method_a(run):
    scans, x0 = run
    cfg = TbdTrackerConfig(method="A")
    ref = run_tbd_tracker(scans, x0, P0, np.random.default_rng(1), cfg)
    one = run_tbd_imm(scans, x0, P0, cfg, sigma_a=(15.0,), transition=((1.0,),))
    assert np.allclose(one.estimates, ref.estimates, rtol=1e-12, atol=1e-9), (
        "an IMM of the one model A uses is method A")
    two = run_tbd_imm(scans, x0, P0, cfg, sigma_a=(15.0, 15.0))
    assert np.allclose(two.estimates, ref.estimates, rtol=1e-9, atol=1e-6), (
        "two copies of A's model mix to method A")
    imm = run_tbd_imm(scans, x0, P0, cfg)
    assert np.all((imm.ess >= 0) & (imm.ess <= 1)), "model probabilities lie in [0, 1]"
    err = np.linalg.norm(imm.estimates[:, :3] - tbd_radar_truth().states[:K, :3], axis=1)
    assert np.isfinite(err).all(), "the IMM's estimates are finite"


def test_bad_input(run):
    scans, x0 = run
    with pytest.raises(ValueError, match="method"):
        run_tbd_gated_b(scans, x0, P0, 1, TbdTrackerConfig(method="A"))
    with pytest.raises(ValueError, match="options"):
        run_tbd_snr_ekf(scans, x0, P0, TbdTrackerConfig(method="A", roughening=0.2))
    with pytest.raises(ValueError, match="transition"):
        run_tbd_imm(scans, x0, P0, TbdTrackerConfig(method="A"),
                    transition=((0.5, 0.4), (0.1, 0.9)))
    with pytest.raises(ValueError, match="threshold"):
        run_tbd_snr_ekf(scans, x0, P0, TbdTrackerConfig(method="A"), threshold=-1.0)
