"""Clutter everywhere (chapter 003's metric reading, session 6): the lazily drawn
lattice cubes of trackcore.scenarios.tbd_radar and the grid experiment that runs them."""
import numpy as np
import pytest

from trackcore.experiments import get
from trackcore.experiments.tbd_grid import GRID_SEED, TbdGridEverywhereConfig, _configs
from trackcore.scenarios import simulate_tbd_radar, tbd_paired_trial
from trackcore.scenarios.tbd_radar import (
    _cube_clutter,
    _cubes_needed,
    _everywhere_trial,
    _with_cubes,
)

CFG = TbdGridEverywhereConfig()


def _rng(i):
    return np.random.default_rng(np.random.SeedSequence(GRID_SEED, spawn_key=(i,)))


def test_registered_as_declared():
    e = get("tbd-grid-everywhere-base-25")
    assert (e.runs, e.seed) == (500, GRID_SEED), "500 runs of the grid's seed, declared"
    assert e.config.scenario == "base" and e.config.processing_radius == 2500.0


def test_a_cube_is_the_same_whenever_it_is_drawn():
    field = np.random.SeedSequence(7, spawn_key=(2,))
    args = (5000.0, 0.119, 3.16, 300.0, np.zeros(3), 7500.0)
    a = _cube_clutter(field, 3, (4, -2, 1), *args)
    b = _cube_clutter(field, 3, (4, -2, 1), *args)
    c = _cube_clutter(field, 4, (4, -2, 1), *args)
    assert all(np.array_equal(x, y) for x, y in zip(a, b)), "a cube's points are fixed"
    assert not np.array_equal(a[0], c[0]), "another scan draws other points"
    lo, hi = np.array([4, -2, 1]) * 5000.0, np.array([5, -1, 2]) * 5000.0
    assert np.all((a[0] >= lo) & (a[0] < hi)), "the points lie in their cube"


def test_cube_density_and_the_base_sphere():
    field = np.random.SeedSequence(11)
    args = (5000.0, 0.119, 3.16, 300.0)
    n = sum(_cube_clutter(field, k, (9, 9, 9), *args, np.zeros(3), 1.0)[0].shape[0]
            for k in range(400))
    assert abs(n / 400 - 0.119 * 125) < 4 * np.sqrt(0.119 * 125 / 400), f"{n / 400}"
    inside = _cube_clutter(field, 0, (0, 0, 0), *args, np.zeros(3), 1e6)
    assert inside[0].shape[0] == 0, "points inside the base sphere are the base field's"


def test_with_cubes_appends_to_each_scan(tbd_truth_prm):
    truth, prm = tbd_truth_prm
    base = simulate_tbd_radar(truth, prm, _rng(0))
    assert _with_cubes(base, {}) is base, "no cubes: the base scans themselves"
    cubes = {(5, 0, 0, 0): (np.ones((2, 3)), np.zeros(2), np.full(2, 4.0)),
             (1, 3, 0, 0): (np.ones((1, 3)), np.zeros(1), np.full(1, 5.0))}
    s = _with_cubes(base, cubes)
    for k in range(base.n_scans):
        old, new = base.scan(k), s.scan(k)
        extra = {1: 1, 5: 2}.get(k, 0)
        assert new[0].shape[0] == old[0].shape[0] + extra, f"scan {k}"
        assert np.array_equal(new[0][: old[0].shape[0]], old[0]), "base rows first"
    assert not s.is_target[-1] and s.snr[s.offsets[2] - 1] == 5.0


def test_needed_cubes_only_outside_the_base_sphere():
    p = np.zeros((3, 3))
    c = np.array([[0.0, 0, 0], [5000.0, 0, 0], [20000.0, 0, 0]])
    need = _cubes_needed(c, p, 2500.0, 7500.0, 5000.0, 0.0)
    assert {q[0] for q in need} == {2}, "only the window that leaves the sphere"
    want = {(2, i, j, m) for i in (3, 4) for j in (-1, 0) for m in (-1, 0)}
    assert need == want, "x in [17.5, 22.5] km, y and z in [-2.5, 2.5] km: 2 x 2 x 2"


def test_runs_that_stay_in_the_sphere_are_the_stored_runs(tbd_truth_prm):
    truth, prm = tbd_truth_prm
    cfgs = _configs(TbdGridEverywhereConfig())
    for i in (1, 5):
        a = tbd_paired_trial(_rng(i), cfgs, prm, truth)
        b = _everywhere_trial(_rng(i), cfgs, prm, truth)
        assert b.rounds == 1 and max(b.reach.values()) < 5000.0, f"run {i} stays in"
        for k in cfgs:
            assert np.array_equal(a.errors[k], b.errors[k]), f"run {i}, {k}"


def test_a_lost_track_is_fed_clutter(tbd_truth_prm):
    """Started 30 km off, every tracker's windows leave the base sphere; the trial adds
    cubes until each window lies in simulated clutter, the same way every time."""
    truth, prm = tbd_truth_prm
    cfgs = {"A": _configs(TbdGridEverywhereConfig())["A"]}
    P0 = np.diag([30000.0 ** 2] * 3 + [20.0 ** 2] * 3)
    a = _everywhere_trial(_rng(3), cfgs, prm, truth, P0=P0)
    b = _everywhere_trial(_rng(3), cfgs, prm, truth, P0=P0)
    assert a.rounds > 1 and a.reach["A"] > 5000.0, (a.rounds, a.reach)
    assert np.array_equal(a.errors["A"], b.errors["A"]), "deterministic"


def test_bad_config():
    with pytest.raises(ValueError, match="cube"):
        TbdGridEverywhereConfig(cube=10.0)
    with pytest.raises(ValueError, match="trackers"):
        TbdGridEverywhereConfig(trackers=("A", "Bg"))
    with pytest.raises(ValueError, match="cube"):
        _everywhere_trial(_rng(0), {}, cube=-1.0)


@pytest.fixture(scope="module")
def tbd_truth_prm():
    prm, truth = CFG.radar()
    return truth, prm
