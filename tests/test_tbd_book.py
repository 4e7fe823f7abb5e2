"""trackcore.scenarios._tbd_book: bookkeeping of chapter 003's verdict grid."""
import numpy as np
import pytest

from trackcore.scenarios._tbd_book import direction_verdict, variant_effect
from trackcore.stats import MIN_RUNS, Estimate, compare

TRK = ("A", "B", "C")


def _cols(n, seed=0):
    g = np.random.default_rng(seed)
    base = g.lognormal(5.0, 0.3, (n, 3)) + np.array([60.0, 30.0, 0.0])
    out = {k: base + g.normal(0, 1, (n, 3)) for k in ("m100", "mall", "sd")}
    out["c100"], out["call"], out["sdc"] = out["m100"], out["mall"], out["sd"]
    out["outcome"] = np.zeros((n, 3), dtype=np.int8)
    out["outcome"][:5, 1] = 2
    return out


def test_a_pair_without_the_variant_is_the_books_value():
    book = {"tbd_g_base_25_pm_100_cb": ("-12", "C better")}
    got = variant_effect(_cols(50), "base_25", "imm", "A", "pm", ("paper mean", "lost"),
                         "100", "C", "B", book, {})
    assert got == ("tbd_imm_g_base_25_pm_100_cb", "-12", "C better")


def test_a_pair_with_the_variant_is_computed():
    c = _cols(60)
    key, e, v = variant_effect(c, "c4_10", "bg", "B", "pm", ("paper mean", "lost"),
                               "all", "B", "A", {}, {})
    r = compare(c["mall"][:, 1], c["mall"][:, 0], ("B", "A"))
    assert (key, e, v) == ("tbd_bg_g_c4_10_pm_all_ba", f"{r.effect:.0f}", r.verdict)


def test_held_runs_are_computed_and_too_few_listed():
    c = _cols(MIN_RUNS + 3)
    short = {}
    got = variant_effect(c, "base_25", "as", "A", "held", ("held runs", "diverged"),
                         "100", "C", "B", {}, short)
    assert got == ("tbd_as_g_base_25_held_100_cb", None, "n/a"), "5 runs held out"
    assert short == {"tbd_as_g_base_25_held_100_cb": MIN_RUNS - 2}
    with pytest.raises(ValueError, match="letter"):
        variant_effect(c, "base_25", "as", "D", "pm", ("paper mean", "lost"), "100",
                       "C", "B", {}, {})


def test_direction_verdict():
    below, above, tie = Estimate(-2, -3, -1), Estimate(2, 1, 3), Estimate(0, -1, 1)
    assert direction_verdict([below, below], "below") == "met"
    assert direction_verdict([below, tie], "below") == "undecided"
    assert direction_verdict([below, above], "below") == "missed"
    assert direction_verdict([above], "above") == "met"
    assert direction_verdict([below, tie], "above") == "missed"
    with pytest.raises(ValueError, match="expect"):
        direction_verdict([below], "less")
    with pytest.raises(ValueError, match="at least one"):
        direction_verdict([], "below")


def _sweep_stats(counts, radii):
    from trackcore.stats import Estimate

    e = Estimate(150.0, 140.0, 160.0)
    one = dict(mean=e, not_lost=None, median=145.0, div=0.02, oth=0.01, tr=0.03,
               lost=Estimate(0.06, 0.03, 0.09))
    return {R: {N: dict(one, not_lost=e if N > 10 else None) for N in counts}
            for R in radii}


def test_sweep_figure_draws_one_column_per_radius():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from trackcore.scenarios._tbd_book import sweep_figure

    fig = sweep_figure(_sweep_stats([10, 100, 600], [2500.0, 1000.0]), [10, 100, 600],
                       [2500.0, 1000.0])
    try:
        top = [ax.get_title() for ax in fig.axes[:2]]
        assert top == ["R = 2.5 km", "R = 1.0 km"], f"column titles {top}"
        bottom = fig.axes[2]
        heights = [p.get_height() for p in bottom.patches]
        # three stacked bars per N: diverged, still lost, transient
        assert len(heights) == 9, f"{len(heights)} bars, expected 3 per N"
        assert np.allclose(sorted(set(np.round(heights, 3))), [0.01, 0.02, 0.03]), (
            f"bar heights {heights}")
    finally:
        plt.close(fig)


def test_sweep_figure_names_what_is_missing():
    from trackcore.scenarios._tbd_book import sweep_figure

    with pytest.raises(ValueError, match="stats lacks"):
        sweep_figure(_sweep_stats([10], [2500.0]), [10, 600], [2500.0])
    with pytest.raises(ValueError, match="counts and radii"):
        sweep_figure({}, [], [2500.0])


def test_why_summary_counts_the_windows():
    from trackcore.scenarios._tbd_book import why_summary

    g = np.random.default_rng(1)
    n = 60
    n_f, n_e = g.integers(0, 60, n), g.integers(0, 20, n)
    cols = dict(onset=np.full(n, -1), n_t=250 - n_f - n_e, n_f=n_f, n_e=n_e,
                pre_f=np.zeros(n, dtype=int), post_t=np.full(n, np.nan))
    # run 0 lost at scan 20 (6 of its 10 scans before held only false alarms, then
    # the target in a quarter of the 230 scans after); run 1 lost at scan 0
    cols["onset"][:2] = 20, 0
    cols["n_t"][:2], cols["n_f"][:2], cols["n_e"][:2] = (10, 0), (8, 0), (2, 0)
    cols["pre_f"][0], cols["post_t"][:2] = 6, (0.25, 0.0)
    s = why_summary(cols)
    assert s["lost"] == 2 and s["pre"] == (6, 10), s
    assert s["post"] == (round(0.25 * 230), 230 + 250), s
    assert s["onset"] == 10.0, s
    assert np.isnan(s["shares"]["false"][1]), "a run lost at its first scan has no share"
    want = np.r_[8 / 20, (n_f / 250)[2:]]
    assert np.isclose(s["false"].value, want.mean()), (s["false"].value, want.mean())
    cols["n_e"][5] += 1
    with pytest.raises(ValueError, match="every scan before the onset"):
        why_summary(cols)
