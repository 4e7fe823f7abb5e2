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
