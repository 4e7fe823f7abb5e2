"""trackcore.experiments.tbd_grid: the TBD chapter's verdict grid (003-06)."""
import numpy as np
import pytest

from trackcore import montecarlo
from trackcore.experiments import get, names, run_experiment
from trackcore.experiments.tbd_grid import (
    CALIBRATED,
    GRID_SEED,
    SCENARIOS,
    TbdGridConfig,
    tbd_grid_capped,
    tbd_grid_columns,
    tbd_grid_lost,
    tbd_grid_values,
)
from trackcore.experiments.tbd_tracking import _scenario
from trackcore.scenarios import tbd_paired_trial
from trackcore.trackers import TbdTrackerConfig, tbd_run_outcomes


def test_the_grid_is_registered_with_the_declared_counts():
    want = {f"tbd-grid-{s}-{r}" for s in SCENARIOS for r in ("25", "10")}
    assert want <= set(names()), sorted(want - set(names()))
    assert get("tbd-grid-base-25").runs == 1000, "pooled with main-25's 1000 to 2000"
    assert get("tbd-grid-base-10").runs == 500, "pooled with main-10's 500 to 1000"
    for r in ("25", "10"):
        for s in ("clut4", "snr6", "snr6-clut4"):
            assert get(f"tbd-grid-{s}-{r}").runs == 200, f"{s}-{r}: 200 runs declared"
            assert get(f"tbd-grid-calibration-{s}-{r}").runs == 200
    assert get("tbd-grid-strong-25").runs == 500
    assert all(get(n).seed == GRID_SEED for n in want), "one fresh seed for the grid"
    for n in want:
        bl = get(n.replace("tbd-grid-", "tbd-grid-baselines-"))
        assert (bl.runs, bl.seed) == (get(n).runs, GRID_SEED), f"{n}: baselines on its runs"


def test_the_baselines_share_the_cells_scene():
    """Runs 0..1 of the stronger baselines at 1 km, +3 dB: the cell's start, B gated
    with B's particle stream (gate = inf would give B), the SNR rule within its bounds."""
    res = run_experiment("tbd-grid-baselines-snr6-10", runs=2, write=False, progress=False)
    cell = run_experiment("tbd-grid-snr6-10", runs=2, write=False, progress=False)
    assert np.array_equal(res["x0"], cell["x0"]), "the baselines do not start as the cell"
    assert res["m100"].shape == (2, 3), "one column per stronger baseline"
    assert np.all(np.isfinite(res["m100"])), "finite errors"
    with pytest.raises(ValueError, match="tracker key"):
        TbdGridConfig(trackers=("Bx",))


def test_the_scenario_follows_snr0_db():
    """The truth's mean SNR at k = 0 is snr0_db (it used to ignore the override)."""
    for snr in (3.0, 6.0):
        _, truth = _scenario(2500.0, snr, 2.820)
        assert np.isclose(10 * np.log10(truth.mean_snr[0]), snr), f"SNR0 {snr} dB not honoured"


def test_rows_equal_the_direct_computation():
    """Runs 0..1 of the +3 dB cell at 1 km: what montecarlo.run of the trial gives."""
    cfg = TbdGridConfig(scenario="snr6", processing_radius=1000.0)
    prm, truth = cfg.radar()
    sp = CALIBRATED["snr6", 1000.0]
    trk = {"A": TbdTrackerConfig(method="A", processing_radius=1000.0, pseudo_sigma=sp[0],
                                 pseudo_sigma_rr=sp[1]),
           "B": TbdTrackerConfig(method="B", processing_radius=1000.0),
           "C": TbdTrackerConfig(method="C", processing_radius=1000.0)}
    direct = montecarlo.run(tbd_paired_trial, 2, GRID_SEED, args=(trk, prm, truth))
    res = run_experiment("tbd-grid-snr6-10", runs=2, write=False, progress=False)
    E = np.array([[r.errors[k] for k in "ABC"] for r in direct])
    assert np.allclose(res["m100"], E[:, :, :100].mean(axis=2)), "m100 differs"
    assert np.allclose(res["call"], np.minimum(E, 6000.0).mean(axis=2)), "capped differs"
    assert np.allclose(res["sd"], E.std(axis=2)), "sd differs"
    for j in range(3):
        out = tbd_run_outcomes(E[:, j])
        assert np.array_equal(res["outcome"][:, j] > 0, out.lost), "lost flags differ"
    assert np.array_equal(res["x0"], [r.x0[0] for r in direct]), "x0 differs"


def test_capped_and_lost():
    assert np.array_equal(tbd_grid_capped([100.0, 9000.0], 2500.0), [100.0, 7500.0])
    code = np.array([[0, 1, 2], [3, 0, 0]])
    assert np.array_equal(tbd_grid_lost(code, "lost"), code > 0)
    assert np.array_equal(tbd_grid_lost(code, "diverged"), code >= 2)
    with pytest.raises(ValueError, match="loss"):
        tbd_grid_lost(code, "gone")
    with pytest.raises(ValueError, match="outcome"):
        tbd_grid_lost(code.astype(float), "lost")
    with pytest.raises(ValueError, match="0..3"):
        tbd_grid_lost(code + 1, "lost")


def test_columns_of_series():
    E = np.zeros((2, 3, 250))
    E[0, 1, 50:70] = 9000.0  # lost, back
    E[1, 2, 200:] = 9000.0  # lost, diverged
    cols = tbd_grid_columns(E, 1000.0)
    assert np.array_equal(cols["outcome"], [[0, 1, 0], [0, 0, 2]]), cols["outcome"]
    assert np.isclose(cols["mall"][0, 1], 20 * 9000.0 / 250), cols["mall"]
    assert np.isclose(cols["call"][0, 1], 20 * 6000.0 / 250), cols["call"]
    assert np.isclose(cols["c100"][0, 1], 20 * 6000.0 / 100), cols["c100"]
    with pytest.raises(ValueError, match="errors"):
        tbd_grid_columns(np.zeros(5), 1000.0)


def test_values_select_the_held_runs():
    cols = {k: np.arange(12.0).reshape(4, 3) for k in ("m100", "mall", "sd")}
    cols.update({k: -np.arange(12.0).reshape(4, 3) for k in ("c100", "call", "sdc")})
    cols["outcome"] = np.array([[0, 0, 0], [0, 1, 0], [0, 0, 2], [3, 0, 0]])
    pm = tbd_grid_values(cols, "ABC", "100", "paper mean")
    assert np.array_equal(pm["B"], [1.0, 4.0, 7.0, 10.0]), pm
    cap = tbd_grid_values(cols, "ABC", "all", "capped")
    assert np.array_equal(cap["A"], [0.0, -3.0, -6.0, -9.0]), cap
    held = tbd_grid_values(cols, "ABC", "sd", "held runs", "lost")
    assert np.array_equal(held["C"], [2.0]), held
    held_d = tbd_grid_values(cols, "ABC", "sd", "held runs", "diverged")
    assert np.array_equal(held_d["A"], [0.0, 3.0]), held_d
    with pytest.raises(ValueError, match="stat"):
        tbd_grid_values(cols, "ABC", "max", "capped")
    with pytest.raises(ValueError, match="metric"):
        tbd_grid_values(cols, "ABC", "100", "median")
    with pytest.raises(ValueError, match="among"):
        tbd_grid_values(cols, ("A", "B", "X"), "100", "held runs")


def test_bad_configs_raise_clear_errors():
    with pytest.raises(ValueError, match="scenario"):
        TbdGridConfig(scenario="fog")
    with pytest.raises(ValueError, match="processing_radius"):
        TbdGridConfig(processing_radius=1500.0)
    with pytest.raises(ValueError, match="tracker key"):
        TbdGridConfig(trackers=("A", "D"))


def test_why_rows_are_cs_runs_of_the_cell():
    """tbd-grid-why-*: runs 0..2 of C alone at 1 km with 4x clutter carry the outcome
    codes of C in the cell's stored trial, and their scan classes count every scan."""
    from trackcore.experiments.tbd_grid import WHY_RUNS, WHY_SCENARIOS

    assert WHY_RUNS == 200 and set(WHY_SCENARIOS) == set(SCENARIOS), "declared cells"
    why = run_experiment("tbd-grid-why-clut4-10", runs=3, write=False, progress=False)
    cell = run_experiment("tbd-grid-clut4-10", runs=3, write=False, progress=False)
    assert np.array_equal(why["outcome"][:, 0], cell["outcome"][:, 2]), "not C's runs"
    onset = np.asarray(why["onset"])
    total = why["n_t"] + why["n_f"] + why["n_e"]
    want = np.where(onset >= 0, onset, 250)
    assert np.array_equal(total, want), f"scans before the onset {total} vs {want}"
    assert np.all(why["pre_f"] <= np.minimum(10, total)), "pre_f counts at most 10 scans"
    assert np.all(why["n_proc"][total > 0] >= 0), "detections per scan"


def test_why_scan_classes():
    from types import SimpleNamespace

    from trackcore.experiments.tbd_grid import _why_extract, _why_scans

    scans = SimpleNamespace(scan_index=np.array([0, 0, 1, 2, 2]), n_scans=4,
                            is_target=np.array([True, False, False, False, True]))
    track = SimpleNamespace(processed=np.array([True, True, True, False, False]))
    assert _why_scans(track, scans).tolist() == [1, 2, 0, 0], "target / false / empty"
    E = np.full(30, 100.0)
    E[12:] = 2000.0  # lost from scan 12
    kinds = np.array([1] * 8 + [2] * 4 + [0] * 10 + [1] * 8, dtype=np.int8)
    out = SimpleNamespace(errors=E, kinds=kinds, n_processed=np.full(30, 3))
    row = _why_extract(out, TbdGridConfig(trackers=("C",), processing_radius=1000.0))
    assert (row["onset"], row["n_t"], row["n_f"], row["n_e"]) == (12, 8, 4, 0), row
    assert row["pre_f"] == 4 and np.isclose(row["post_t"], 8 / 18), row
    assert row["n_proc"] == 3.0 and row["outcome"].tolist() == [3], row
