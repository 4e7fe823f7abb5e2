"""001-05's cause ladder and heading alternatives: the new TOM headings and frame
readings, the ladder's keys and inputs, the chapter helpers and the stored rows."""
import math

import numpy as np
import pytest

from trackcore.experiments import get, run_experiment
from trackcore.experiments.tom_cause import TomVariantsConfig, _tom_variant
from trackcore.experiments.tom_ladder import (HEADINGS, LADDER, LadderConfig,
                                              lag_rule_input, true_rate_input)
from trackcore.montecarlo import run, stack_results
from trackcore.scenarios import HOULES_TURNS, houles_imm_trial, window_mse
from trackcore.scenarios._tom_book import (FAILURE_DEFS, failure_masks, heading_ratios,
                                           ladder_steps, step_word)
from trackcore.stats import Estimate
from trackcore.trackers import (TOM_HEADINGS, ct_imm_model_set, imm_pdaf_track,
                                markov_matrix, singer_imm_model_set, tom_imm_model_set)

SEED = 20261123
RATES = [0.0, HOULES_TURNS[0][2], HOULES_TURNS[1][2]]  # the scenario's true rates


def _turn(omega, speed=400.0, n=40):
    """Noise-free positions of a coordinated turn (t = 0..n-1 s), heading 0 at t = 0."""
    t = np.arange(n, dtype=float)
    if omega == 0:
        return np.column_stack([speed * t, 0 * t])
    return np.column_stack([speed / omega * np.sin(omega * t),
                            speed / omega * (1 - np.cos(omega * t))])


def _track(models, p, speed=400.0):
    x0 = np.array([p[1, 0], p[1, 1], speed, 0.0])
    v0 = (p[1] - p[0]) / 1.0
    x0[2:] = v0
    scans = [q[None, :] for q in p[2:]]
    return imm_pdaf_track(models, scans, x0, np.eye(4) * 1e-2, np.eye(2) * 1e-4, pg=1.0,
                          clutter_density=0.0, prev_position=p[0])


def test_true_rate_input_moves_the_prediction_along_the_turn():
    for omega in (-0.15, 0.1):
        p = _turn(omega)
        c1, c2 = p[5] - p[4], p[6] - p[5]
        f = c1 / np.linalg.norm(c1)
        s = np.array([f[1], -f[0]])  # right of the heading, the TOM convention
        assert true_rate_input(omega, speed=400.0) == pytest.approx(c2 @ s, rel=1e-9), omega
    assert true_rate_input(-0.15) > 0 > true_rate_input(0.1), "right turn is +u"
    with pytest.raises(ValueError, match="omega"):
        true_rate_input(0.0)


def test_every_heading_follows_a_straight_line():
    p = _turn(0.0)
    for h in TOM_HEADINGS:
        res = _track(tom_imm_model_set(heading=h), p)
        assert np.max(np.abs(res.heading[3:])) < 1e-6, h
        assert np.max(np.abs(res.x[:, :2] - p[2:])) < 1.0, h


def test_heading_rate_filter_leads_the_chord_in_a_steady_turn():
    omega = 0.1
    p = _turn(omega, n=60)
    step_dir = np.arctan2(*(np.diff(p, axis=0)[:, ::-1].T))  # direction of step k -> k+1
    chord = _track(tom_imm_model_set(heading="chord"), p).heading
    hr = _track(tom_imm_model_set(heading="heading_rate_kf"), p).heading
    target = step_dir[1:]  # the step the prediction at scan k covers (k - 1 -> k)
    wrap = lambda a: np.angle(np.exp(1j * a))  # noqa: E731
    late = slice(40, None)
    assert np.max(np.abs(wrap(hr[late] - target[late]))) < 0.01, "rate extrapolated"
    assert np.min(np.abs(wrap(chord[late] - target[late]))) > 0.08, "chord lags omega T"


def test_mean_and_smoothed_headings_lag_more_than_the_chord():
    p = _turn(0.1, n=50)
    lag = {}
    for h in ("chord", "chord_mean2", "chord_mean3", "smoothed"):
        head = _track(tom_imm_model_set(heading=h, u=0.0), p).heading
        lag[h] = float(np.median(np.abs(np.diff(np.unwrap(head))[30:])))
    assert all(abs(v - 0.1) < 0.01 for v in lag.values()), lag  # each turns at omega


def test_frame_reading_fields_are_checked():
    with pytest.raises(ValueError, match="needs rotate_covariance"):
        tom_imm_model_set(reproject_velocity=True)
    with pytest.raises(ValueError, match="not both"):
        tom_imm_model_set(reset_vs_variance=True, vs_prior_var=400.0)
    with pytest.raises(ValueError, match="vs_prior_var"):
        tom_imm_model_set(vs_prior_var=-1.0)
    assert tom_imm_model_set(vs_prior_var=400.0).vs_prior_var == 400.0


def test_filter_keys_of_the_ladder():
    ct = _tom_variant("ct:cv=1.0,ct=8.0,p_stay=0.9")
    ref = ct_imm_model_set(RATES, [1.0, 8.0, 8.0],
                           transition=markov_matrix(3, 0.9))
    assert np.allclose(ct.F, ref.F) and np.allclose(ct.Q, ref.Q), "known-rate CT-IMM"
    asym = _tom_variant("tom:heading=velocity,u_right=60.0,u_left=40.0")
    assert list(asym.u) == [0.0, 60.0, -40.0] and asym.heading == "velocity"
    for bad in ("ct:bogus=1", "tom:u=50.0,u_right=60.0", "ct:cv=1.0,p_stay=1.5"):
        with pytest.raises(ValueError):
            _tom_variant(bad)
    assert LADDER[0] == "singer" and len(LADDER) == 7
    assert [lag_rule_input(h) for h in ("chord", "chord_mean2", "chord_mean3")] == \
        [70.0, 105.0, 140.0]
    with pytest.raises(ValueError, match="pg must be in"):
        LadderConfig(pg=0.0)


def test_ladder_rows_equal_the_direct_runs():
    sets = [singer_imm_model_set(), tom_imm_model_set(),
            ct_imm_model_set(RATES, [0.0, 0.0, 0.0],
                             transition=markov_matrix(3, 0.98))]
    d = stack_results(run(houles_imm_trial, 2, SEED, args=(sets,))).pos_err2
    over = {"filters": ("singer", "tom", "ct:cv=0.0,ct=0.0,p_stay=0.98")}
    res = run_experiment("tom-cause-ladder", runs=2, overrides=over, write=False,
                         progress=False)
    assert np.array_equal(res["window_mse"], window_mse(d)), "window mean squares"
    assert np.array_equal(res["last_err2"], d[..., -1]), "last squared error"
    for name, runs in (("tom-cause-ladder", 2000), ("tom-cause-headings", 1000),
                       ("tom-cause-headings-pg1", 1000),
                       ("tom-cause-frame-readings", 1000)):
        e = get(name)
        assert (e.seed, e.runs, e.version) == (SEED, runs, "1"), e
    assert get("tom-cause-headings").config.filters == HEADINGS
    TomVariantsConfig(("tom:rotate_covariance=1,reproject_velocity=1",))


def test_failure_masks_and_ladder_helpers():
    rng = np.random.default_rng(0)
    mx = rng.uniform(0, 1200.0, (50, 3)) ** 2
    masks = failure_masks(mx, mx / 4, rng.integers(0, 5, (50, 3)))
    assert list(masks) == [k for k, _ in FAILURE_DEFS]
    assert np.array_equal(masks["f500"], mx > 500.0**2)
    with pytest.raises(ValueError, match="one shape"):
        failure_masks(mx, mx[:1], mx)
    assert step_word(Estimate(0.9, 0.8, 0.95)) == "better"
    assert step_word(Estimate(1.0, 0.95, 1.05)) == "tie"
    mse = rng.uniform(1, 2, (60, 3, 3))
    mse[:, 2] *= 0.5
    failed = np.zeros((60, 3), dtype=bool)
    st = ladder_steps(mse, failed, [1, 2])
    assert "total" not in st[0] and step_word(st[1]["total"]) == "better"
    failed[:, 1] = True
    assert heading_ratios(mse, {"f200": failed}, [1])[1, "f200"] is None
    with pytest.raises(ValueError, match="at least 2 steps"):
        ladder_steps(mse, failed, [1])


def test_moved_notebook_helpers():
    from trackcore.scenarios._tom_book import (grid_scores, local_search, scaled,
                                               verdict_word)

    e = scaled(Estimate(0.9, 0.8, 1.0), 2.0)
    assert (e.value, e.lo, e.hi) == (0.45, 0.4, 0.5)
    with pytest.raises(ValueError, match="positive"):
        scaled(e, 0.0)
    assert verdict_word(Estimate(0.79, 0.75, 0.82), 0.80) == "reproduced"
    assert verdict_word(Estimate(0.83, 0.82, 0.84), 0.80, None, 0.85) == \
        "reproduced within tolerance"
    assert verdict_word(Estimate(0.9, 0.88, 0.92), 0.80, None, 0.85) == "not reproduced"
    rng = np.random.default_rng(1)
    Es = rng.uniform(0, 100.0, (30, 90))
    Ep = np.stack([Es * 0.25, Es], axis=1)
    Ep[0, 1, 5] = 300.0**2  # one failure of the second point
    score, fr = grid_scores(Ep, Es)
    assert np.allclose(score[0], 0.5) and np.allclose(score[1], 1.0), score
    assert fr.tolist() == [0.0, 1 / 30]
    memo = {}

    def sc(points):
        memo.update({q: ((q[0] - 3) ** 2,) for q in points})

    sc([(0,)])
    assert local_search(memo, (0,), [[0, 1, 2, 3, 4, 5]], sc, lambda s: s[0]) == (3,)
