"""The HPDA chapter's presentation helpers (trackcore.scenarios._hpda_book)."""
import math
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest

from trackcore.scenarios import _hpda_book as hb
from trackcore.scenarios import hpda_parameters, hpda_tracker_configs, hpda_truth
from trackcore.stats import Estimate, rate_ci


def test_private_module_exports_nothing():
    import trackcore.scenarios as sc
    assert hb.__all__ == []
    assert not hasattr(sc, "table2_rows") and not hasattr(sc, "mc_row")


def test_table2_rows_name_the_parameters_once():
    p1, p2 = hpda_parameters(1), hpda_parameters(2)
    rows = hb.table2_rows(p1, p2, hpda_tracker_configs(p1))
    assert len(rows) == 26 and all(len(r) == 3 for r in rows)
    names = [r[0] for r in rows]
    assert len(set(names)) == len(names), "a parameter appears twice"
    got = {r[0]: r[2] for r in rows}
    assert got["P_D"] == f"{p1.pd:g} | {p2.pd:g}"
    assert got["T [s]"] == "10"
    assert got["gate g^2 (P_G = 0.99)"] == f"{-2 * math.log(0.01):.4f}"


def test_flow_chart_boxes_and_arrows():
    fig = hb.flow_chart(["a", ("b", "c"), "d"], loop_from=1, loop_label="again")
    ax = fig.axes[0]
    assert len(ax.patches) == 4, "one box per text"
    texts = [t.get_text() for t in ax.texts]
    assert texts[:4] == ["a", "b", "c", "d"] and "again" in texts
    # arrows: a->b, a->c, b->d, c->d, and the way back
    assert sum(t.get_text() == "" for t in ax.texts) == 5
    plt.close(fig)
    with pytest.raises(ValueError, match="steps"):
        hb.flow_chart([])
    with pytest.raises(ValueError, match="steps"):
        hb.flow_chart(["a", 3])


def test_track_segments_longest_first():
    ids = np.array([[0, -1], [0, 1], [0, 1], [2, -1]])
    est = np.arange(4 * 2 * 4, dtype=float).reshape(4, 2, 4)
    segs = hb.track_segments(SimpleNamespace(ids=ids, estimates=est))
    assert [s[0] for s in segs] == [0, 1, 2]
    _, ks, xy = segs[1]
    assert ks.tolist() == [1, 2] and np.array_equal(xy, est[[1, 2], [1, 1], :2])
    assert hb.track_segments(SimpleNamespace(ids=-np.ones((3, 2)), estimates=est)) == []


def test_truth_lines_frames_the_truth():
    truth = hpda_truth()
    fig, ax = plt.subplots()
    hb.truth_lines(ax, truth)
    xy = truth.states[truth.alive][:, :2]
    assert ax.get_xlim() == pytest.approx((xy[:, 0].min() - 700, xy[:, 0].max() + 700))
    assert len(ax.lines) == truth.alive.shape[1] + 2  # tracks, legend entry, sensor
    plt.close(fig)


def _rates(seed):
    r = np.random.default_rng(seed)
    pairs = r.integers(50, 100, 4)
    windows = r.integers(50, 100, 4)
    return {"pairs": pairs, "links": r.integers(0, 50, 4), "windows": windows,
            "rois": r.integers(0, 50, 4)}


def test_link_rate_table_rows_and_glue():
    rates = {(c, rd): _rates(10 * c + i) for c in (1, 2)
             for i, rd in enumerate(("clustering_literal", "clustering"))}
    bins = ("a", "b", "c", "d")
    rows, glued = hb.link_rate_table(rates, bins)
    assert len(rows) == 4 and all(len(r) == len(hb.LINK_HEADERS) for r in rows)
    lit = rates[1, "clustering_literal"]
    assert rows[2][:3] == ("c", int(lit["pairs"][2]),
                           f"{rate_ci(int(lit['links'][2]), int(lit['pairs'][2])):.2f}")
    t = rates[2, "clustering"]
    assert glued["hpda_roi_rate_strong_2"] == (
        f"{rate_ci(int(t['rois'].sum()), int(t['windows'].sum())):.2f}")
    assert glued["hpda_link_rate_literal_far"] == (
        f"{rate_ci(int(lit['links'][3]), int(lit['pairs'][3])):.2f}")
    assert len(glued) == 10


def test_per_run_delay_leaves_out_empty_runs():
    x = np.array([[1.0, 3.0], [np.nan, np.nan], [np.nan, 5.0]])
    assert hb.per_run_delay(x).tolist() == [2.0, 5.0]
    with pytest.raises(ValueError, match="2-D"):
        hb.per_run_delay([1.0, 2.0])


def test_mc_row_formats_every_column():
    r = np.random.default_rng(3)
    n = 60
    m = {"sq_count_error": r.random(n), "abs_count_error": r.random(n),
         "ospa": 100 * r.random(n), "false_tracks": r.random(n)}
    e = Estimate(0.1234, 0.1, 0.15, 0.95, n, "test")
    row = hb.mc_row(e, e, m, r.random(n), np.array([1.0]))
    assert len(row) == len(hb.MC_KEYS) == len(hb.MC_HEADERS)
    assert row[0] == f"{e:.3f}" and row[1] == f"{e:+.3f}"
    assert row[-1] == "—", "one run: no interval"
    assert row[3].startswith(f"{np.sqrt(m['sq_count_error'].mean()):.2f} [")
    assert row[2].startswith(f"{m['abs_count_error'].mean():.3f} [")


def _est(lo, hi):
    return Estimate((lo + hi) / 2, lo, hi, 0.95, 100, "test")


def test_ranking_verdict():
    assert hb.ranking_verdict(_est(-2, -1), _est(-3, -0.1)) == "met"
    assert hb.ranking_verdict(_est(-2, -1), _est(0.1, 1)) == "missed"
    assert hb.ranking_verdict(_est(-2, -1), _est(-1, 1)) == "tie"
    with pytest.raises(TypeError, match="Estimate"):
        hb.ranking_verdict(0.1)
    with pytest.raises(TypeError, match="Estimate"):
        hb.ranking_verdict()


def test_labelled_and_gospa_parts():
    d = [_est(-2, -1), _est(0.5, 1.5)]
    assert hb.labelled(d, ("a", "b"), {"a": "A", "b": "B"}) == (
        f"A {d[0]:+.3f}; B {d[1]:+.3f}")
    assert hb.labelled([1.5], ["a"], {"a": "A"}, ".1f") == "A 1.5"
    met = {"x": {"gospa_localisation": np.array([1000.0, 3000.0]),
                 "gospa_missed": np.zeros(2), "gospa_false": np.full(2, 500.0)}}
    assert hb.gospa_parts(met, ["x"]).tolist() == [[2.0, 0.0, 0.5]]


def test_interval_text_formats_or_says_there_is_none():
    from trackcore.scenarios._hpda_book import NO_INTERVAL, interval_text
    from trackcore.stats import mean_ci

    x = np.linspace(0.0, 1.0, 50)
    assert interval_text(lambda: mean_ci(x), "+.2f") == format(mean_ci(x), "+.2f")

    def too_few():
        raise ValueError("runs must be at least 40")

    assert interval_text(too_few) == NO_INTERVAL
    from trackcore.stats import Estimate

    basic = Estimate(0.5, 0.4, 0.7, n=40, method="BCa bootstrap (basic: bias beyond BCa's range)")
    assert interval_text(lambda: basic) == NO_INTERVAL


def test_per_run_error_and_the_measures_of_a_pair():
    from trackcore.scenarios import count_error_ci
    from trackcore.stats import paired_diff_ci

    n_true = np.array([1.0, 2.0, 2.0])
    counts = np.array([[1, 2, 3], [0, 2, 2]])
    assert hb.per_run_error(counts, n_true).tolist() == [1 / 3, 1 / 3]
    with pytest.raises(ValueError, match="counts must be"):
        hb.per_run_error(counts[:, :2], n_true)
    rng = np.random.default_rng(3)
    truth = np.repeat([1.0, 2.0, 3.0], 10)
    h = truth + rng.integers(-1, 2, size=(50, 30))
    x = truth + rng.integers(-1, 3, size=(50, 30))
    own, pair = hb.own_measures(x, truth), hb.paired_measures(h, x, truth)
    assert list(own) == ["e", "ebc"] and list(pair) == ["de", "debc", "dabs"]
    assert own["e"]() == count_error_ci(x, truth)
    assert pair["de"]() == count_error_ci(h, truth, versus=x)
    direct = paired_diff_ci(np.abs(h - truth).mean(1), np.abs(x - truth).mean(1))
    assert pair["dabs"]() == direct


def test_rerun_stored_reproduces_a_stored_run_or_raises():
    from dataclasses import dataclass

    from trackcore.experiments import Experiment, VerificationError, run_experiment

    @dataclass(frozen=True)
    class Toy:
        mean: float = 1.0

    toy = Experiment("toy-rerun", "normal draws",
                     trial=lambda rng, mean, n=3: rng.normal(mean, size=n),
                     call=lambda c: ((), {"mean": c.mean}),
                     extract=lambda r, c: {"x": np.asarray(r, dtype=float)[:3]},
                     config=Toy(), seed=11, runs=6, version="1")
    res = run_experiment(toy, write=False, progress=False)
    out = hb.rerun_stored(res, 4, n=5)  # extra trial arguments, the row still checked
    assert out.shape == (5,) and np.array_equal(out[:3], res["x"][4])
    res.columns["x"][2, 0] += 1.0
    with pytest.raises(VerificationError, match="run 2"):
        hb.rerun_stored(res, 2)
    with pytest.raises(ValueError, match="run index"):
        hb.rerun_stored(res, 6)


def test_min_separation_and_the_printed_death_states():
    xy = np.array([[[0.0, 0.0, 0, 0], [3.0, 4.0, 0, 0], [np.nan] * 4],
                   [[0.0, 0.0, 0, 0], [0.0, 1.0, 0, 0], [0.0, 0.5, 0, 0]]])
    alive = np.array([[True, True, False], [True, False, True]])
    assert hb.min_separation(SimpleNamespace(states=xy, alive=alive)) == 0.5
    lone = SimpleNamespace(states=xy, alive=np.array([[True, False, False]] * 2))
    assert hb.min_separation(lone) == math.inf
    truth, cv = hpda_truth("B"), hpda_truth("A")
    for t in range(6):
        d = truth.deaths[t]
        assert np.allclose(cv.states[d, t, :2], hb.DEATHS_CV[t], atol=1e-6)
        assert np.allclose(truth.states[d, t], hb.DEATHS_B[t], atol=0.06)
    assert 2000 < hb.min_separation(truth) < 3000


def test_paired_typical_median_and_share_of_wins():
    rng = np.random.default_rng(3)
    x = rng.exponential(1.0, 200)
    h = x + 0.1  # worse in every run by 0.1 ...
    h[:10] -= 50.0  # ... but for ten runs far better: the mean favours h
    med, wins = hb.paired_typical(h, x)
    assert (h - x).mean() < 0
    assert math.isclose(med.value, 0.1) and med.lo <= 0.1 <= med.hi
    assert wins.value == 10 / 200 and wins.method == "Wilson"
    ties = hb.paired_typical(x, x)[1]
    assert ties.value == 0.0  # a tie is no win
    with pytest.raises(ValueError, match="paired"):
        hb.paired_typical(h, x[:5])
