"""001-03 without a gate: the 6 km clutter ring, the failure grid, the store's rows."""
import numpy as np
import pytest

from trackcore.experiments import get, load, run_experiment, verify_sample
from trackcore.experiments.tom_cause import _tom_variant
from trackcore.experiments.tom_pg1 import TUNED, TomNoGateConfig, _nis_streak
from trackcore.montecarlo import run, stack_results
from trackcore.scenarios import (
    FAILURE_DEFINITIONS,
    failure_comparison,
    failure_grid,
    houles_imm_trial,
    houles_measurements,
    houles_truth,
    window_mse,
)
from trackcore.stats import rate_ci
from trackcore.trackers import (
    car_imm_model_set,
    markov_matrix,
    singer_imm_model_set,
    tom_imm_model_set,
)

SEED = 20261123


def _truth():
    return houles_truth(np.arange(0.0, 91.0))


def test_the_ring_keeps_every_draw_of_the_inner_square():
    tr = _truth()
    a = houles_measurements(tr, np.random.default_rng(3))
    b = houles_measurements(tr, np.random.default_rng(3), outer_window=6000.0)
    for k in range(tr.shape[0]):
        za = a.z[a.offsets[k]:a.offsets[k + 1]]
        zb = b.z[b.offsets[k]:b.offsets[k + 1]]
        assert np.array_equal(zb[:len(za)], za), f"scan {k}: the inner draws changed"
        ring = np.abs(zb[len(za):] - tr[k, :2]).max(axis=1)
        assert np.all((ring > 1000.0) & (ring <= 3000.0)), f"scan {k}: a ring point misplaced"
        assert np.array_equal(b.z[b.target_index[k]], a.z[a.target_index[k]]), f"scan {k}"


def test_the_ring_has_the_papers_density():
    tr = _truth()
    b = houles_measurements(tr, np.random.default_rng(4), outer_window=6000.0)
    per_scan = np.diff(b.offsets).mean() - 1.0  # minus the target
    assert abs(per_scan - 72.0) < 4.0, f"{per_scan:.1f} false returns per scan, expected 72"


@pytest.mark.parametrize("outer, match", [(1500.0, "must exceed window"),
                                          (-1.0, "outer_window"),
                                          (1e7, "must be at most")])
def test_a_bad_outer_window_raises(outer, match):
    with pytest.raises(ValueError, match=match):
        houles_measurements(_truth(), np.random.default_rng(0), outer_window=outer)


def test_multi_setting_tom_keys_equal_the_direct_model_set():
    ms = _tom_variant(TUNED)
    ref = tom_imm_model_set(u=50.0, sigma_s_turn=10.0, sigma_s_centre=0.0,
                            transition=markov_matrix(3, 0.95))
    assert np.array_equal(ms.transition, ref.transition), "Markov matrix"
    assert all(np.array_equal(a, b) for a, b in zip(ms.Q, ref.Q)), "process noise"
    assert ms.labels == ref.labels, "labels (lateral inputs)"
    with pytest.raises(ValueError, match="distinct NAMEs"):
        _tom_variant("tom:u=50.0,u=60.0")


def test_nis_streak_counts_runs_and_skips_misses():
    nis = np.array([[10.0, 10.0, np.nan, 10.0, 1.0, 10.0],
                    [1.0, 10.0, 1.0, 10.0, 10.0, 1.0]])
    assert _nis_streak(nis).tolist() == [3, 2], "a NaN neither counts nor breaks a run"


def test_failure_grid_matches_the_direct_definitions():
    r = np.random.default_rng(8)
    mx = r.random((60, 3)) * 1.2e6
    last = mx * r.random((60, 3))
    miss = r.random((60, 3)) < 0.2
    g = failure_grid(mx, last, miss)
    assert tuple(g) == FAILURE_DEFINITIONS, "every definition, in order"
    fl = mx > 500.0**2
    c = g["error > 500 m at some time"]
    assert np.array_equal(c.failed, fl), "failed runs at 500 m"
    assert c.rate[2].value == rate_ci(fl[:, 2], 60).value, "TOM's rate"
    assert c.tom_minus_car == failure_comparison(fl, 2, 1), "TOM − CAR"
    assert np.array_equal(g["still > 200 m at t = 90 s"].failed, last > 200.0**2), "lost"
    assert np.array_equal(g["3 gate misses in a row"].failed, miss), "gate misses"
    with pytest.raises(ValueError, match="gate_missed must be a bool array"):
        failure_grid(mx, last, miss.astype(int))
    with pytest.raises(ValueError, match="one shape"):
        failure_grid(mx, last[:, :2], miss)


def test_rows_equal_the_direct_runs():
    sets = [singer_imm_model_set(), car_imm_model_set(sigma_cv=5.0), tom_imm_model_set(),
            _tom_variant(TUNED)]
    d = stack_results(run(houles_imm_trial, 2, SEED, args=(sets,),
                          kwargs={"pg": 1.0, "outer_window": 6000.0}))
    res = run_experiment("tom-imm-houles-pg1", runs=2, write=False, progress=False)
    assert np.array_equal(res["window_mse"], window_mse(d.pos_err2)), "window mean squares"
    assert np.array_equal(res["last_err2"], d.pos_err2[..., -1]), "last squared error"
    assert np.array_equal(res["nis_streak"], np.stack([_nis_streak(n) for n in d.nis]))


def test_the_store_verifies_and_the_config_checks():
    e = get("tom-imm-houles-pg1")
    assert (e.seed, e.runs, e.version) == (SEED, 3000, "1"), e
    assert verify_sample(load("tom-imm-houles-pg1"), indices=[0, 2999]).checked == 2
    with pytest.raises(ValueError, match="outer_window must exceed"):
        TomNoGateConfig(outer_window=2000.0)
    with pytest.raises(ValueError, match="pg must be in"):
        TomNoGateConfig(pg=0.0)
    with pytest.raises(ValueError, match="unknown filter key"):
        TomNoGateConfig(filters=("tom:bogus=1",))


def test_tuned_gate_rows_equal_the_direct_runs():
    from trackcore.experiments.tom_pg1 import VBEST

    sets = [_tom_variant(TUNED), _tom_variant(VBEST)]
    res = run_experiment("tom-imm-houles-tuned-gates", runs=2, write=False, progress=False)
    for g, pg in enumerate((0.99, 0.999, 0.9999)):
        d = stack_results(run(houles_imm_trial, 2, SEED, args=(sets,), kwargs={"pg": pg}))
        assert np.array_equal(res["window_mse"][:, g], window_mse(d.pos_err2)), pg
        assert np.array_equal(res["target_gated"][:, g], d.target_gated), pg


def test_bad_tuned_gate_configs_raise():
    from trackcore.experiments.tom_pg1 import TomGatesConfig

    with pytest.raises(ValueError, match="every gate probability"):
        TomGatesConfig(gates=(0.99, 1.5))
    with pytest.raises(TypeError, match="gates must be a non-empty tuple"):
        TomGatesConfig(gates=())
    with pytest.raises(ValueError, match="clutter_density must be >= 0"):
        TomGatesConfig(clutter_density=-1.0)
