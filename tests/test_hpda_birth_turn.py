"""SMC-PHD's birth mass per return, the birth and turn experiments of the HPDA chapter
(07-extensions) and the single-run report of 05-single-runs."""

from dataclasses import replace

import numpy as np
import pytest

from trackcore.core import spawn_seed_sequences
from trackcore.experiments import _core
from trackcore.experiments.hpda_extensions import (
    BIRTH_READINGS,
    CV_ONLY_TPM,
    HpdaBirthSweepConfig,
    HpdaTurnConfig,
    _identity_report,
    _median_run,
    _turn_errors,
    _turn_mask,
)
from trackcore.scenarios import (
    hpda_parameters,
    hpda_tracker_configs,
    hpda_truth,
    run_hpda_trial,
    simulate_hpda_scans,
)
from trackcore.trackers.hpda_pf import TrackerRun
from trackcore.trackers.smc_phd import SmcPhdConfig, smc_phd_run


def _scans(n=12, seed=1):
    p = replace(hpda_parameters(1), n_scans=n)
    return p, simulate_hpda_scans(hpda_truth(n_scans=n), p, np.random.default_rng(seed))


def test_birth_model_is_validated():
    with pytest.raises(ValueError, match="birth_model"):
        SmcPhdConfig(pd=0.9, clutter_density_xy=1e-7, birth_model="each")
    with pytest.raises(ValueError, match="birth_model"):
        SmcPhdConfig(pd=0.9, clutter_density_xy=1e-7, birth_model=1)


def test_per_return_birth_scales_with_the_returns():
    """No survivors (P_S = 0) and no detections (a far-away scan): after scan k the
    mass is the births times 1 - P_D, i.e. ``birth_mass * m_(k-1) * (1 - P_D)`` per
    return and ``birth_mass * (1 - P_D)`` per scan."""
    z = np.array([[9000.0, 0.1]] * 4 + [[9000.0, 0.2]] * 2)  # 4 returns, then 2
    off = np.array([0, 4, 6])
    for model, expect in (("per_scan", 0.2), ("per_return", 0.2 * 4)):
        cfg = SmcPhdConfig(
            pd=0.9, clutter_density_xy=1e-3, p_survival=0.0, birth_model=model, birth_mass=0.2
        )
        run = smc_phd_run(z, off, cfg, np.random.default_rng(0))
        # the births sit on the first scan's returns, far (in range) from nothing
        assert run.aux[1] <= expect + 1e-9, f"{model}: {run.aux[1]} > {expect}"
        assert run.aux[1] >= expect * 0.1 - 1e-9, f"{model}: births lost {run.aux[1]}"


def test_per_scan_default_is_the_explicit_per_scan():
    p, sc = _scans()
    cfg = hpda_tracker_configs(p)["phd"]
    a = smc_phd_run(sc.z, sc.offsets, cfg, np.random.default_rng(3))
    b = smc_phd_run(
        sc.z, sc.offsets, replace(cfg, birth_model="per_scan"), np.random.default_rng(3)
    )
    assert np.array_equal(a.aux, b.aux), "the default birth model must be per_scan"


def test_birth_sweep_config_validates_and_orders_variants():
    cfg = HpdaBirthSweepConfig(1, priors=(0.98, 0.99), births=tuple(BIRTH_READINGS))
    v = cfg.variants()
    assert [x["phd"]["p_survival"] for x in v] == [0.98, 0.98, 0.99, 0.99], v
    assert [x["phd"]["birth_model"] for x in v[:2]] == ["per_scan", "per_return"], v
    with pytest.raises(ValueError, match="birth model"):
        HpdaBirthSweepConfig(1, births=("each",))
    with pytest.raises(ValueError, match="keep_scans"):
        HpdaBirthSweepConfig(1, keep_scans=0)
    with pytest.raises(ValueError, match="algorithms"):
        HpdaBirthSweepConfig(1, algorithms=("hpda",))
    assert HpdaBirthSweepConfig(1, keep_scans=50).scenario() == {"n_scans": 50}


def test_birth_rows_equal_the_direct_runs():
    e = _core.get("hpda-ext-birth-factor-clutter")
    cfg = e.configure({"priors": (0.99,), "births": ("per_return",), "keep_scans": 8})
    ((row, _),) = _core._rows_for_indices(e, cfg, e.seed, 100, [0])
    rng = np.random.default_rng(spawn_seed_sequences(e.seed, 100)[0])
    out = run_hpda_trial(
        rng,
        1,
        ("phd",),
        overrides=cfg.variants()[0],
        scenario_overrides={"clutter_mean": 50.0, "n_scans": 8},
    )
    assert np.array_equal(row["phd.count"][0], out["phd"]["count"]), "counts differ"
    assert np.allclose(row["phd.sum_w"][0], out["phd"]["aux"], rtol=1e-6), "sums differ"


def _run_at(truth, offset):
    K, n = truth.alive.shape
    est = np.full((K, 8, 4), np.nan)
    ids = np.full((K, 8), -1)
    est[:, :n, :2] = truth.states[:, :, :2] + offset
    ids[:, :n] = np.arange(n)
    ne = np.full(K, n)
    return TrackerRun(np.full(K, n), est, ids, ne, np.zeros(K))


def test_turn_errors_on_exact_and_shifted_estimates():
    truth = hpda_truth()
    mask = _turn_mask(truth, after=10)
    assert mask.sum() == (truth.modes >= 2).sum() + 10 * 6, "20 turn + 10 after each"
    err = _turn_errors(_run_at(truth, 0.0), truth)
    assert np.allclose(err[[0, 2]], 0.0) and np.allclose(err[[1, 3]], 0.0), err
    err = _turn_errors(_run_at(truth, 300.0), truth)  # 424 m off: hits, RMSE 424
    assert np.allclose(err[[0, 2]], np.hypot(300, 300)), err
    err = _turn_errors(_run_at(truth, 400.0), truth)  # 566 m off: every scan a miss
    assert np.isnan(err[0]) and err[1] == 1.0, err


def test_turn_config():
    v = HpdaTurnConfig(1, priors=(0.99,)).variants()
    assert v == ({"hpda": {"pi11": 0.99}}, {"hpda": {"pi11": 0.99, "mode_tpm": CV_ONLY_TPM}}), v
    with pytest.raises(ValueError, match="algorithms"):
        HpdaTurnConfig(1, algorithms=("phd",))


def test_median_run_and_identity_report():
    assert _median_run([5.0, 1.0, 3.0, 3.0]) == 2, "the 2nd of 4, ties to the lower index"
    assert _median_run(np.arange(100.0)[::-1]) == 50, "the 50th smallest of 100"
    with pytest.raises(ValueError):
        _median_run([])
    truth = hpda_truth()
    n_id, frag, cover = _identity_report(_run_at(truth, 0.0), truth)
    assert n_id == 6 and (frag == 0).all() and np.allclose(cover, 1.0), (n_id, frag)
    run = _run_at(truth, 0.0)
    run.ids[200:, 0] = 7  # target 0 handed to a new identity at scan 200
    n_id, frag, _ = _identity_report(run, truth)
    assert frag[0] == 0 and n_id == 7, "target 0 died at scan 200: one scan is not 5"
    run.ids[250:, 1] = 9  # target 1 (scans 100-350) handed over at scan 250
    n_id, frag, _ = _identity_report(run, truth)
    assert frag[1] == 1 and n_id == 8, (n_id, frag)
