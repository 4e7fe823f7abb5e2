"""The cause factorial of the SPRT chapter: its cells and the helpers that read them."""
import numpy as np
import pytest

from trackcore.experiments.sprt import (CAUSE_GEOMETRIES, CAUSE_MODELS, CAUSE_PRIORS,
                                        CAUSE_SIGNS, cause_cells)
from trackcore.experiments.sprt import _cell as parse_cell
from trackcore.scenarios._sprt_book import cause_column, paired_effect

AXES = (CAUSE_GEOMETRIES, CAUSE_MODELS, CAUSE_PRIORS, CAUSE_SIGNS)


def test_cells_follow_the_declared_order():
    cells = cause_cells(2)
    assert len(cells) == 7 * 2 * 2 * 2 and len(set(cells)) == len(cells), "56 distinct cells"
    for g in CAUSE_GEOMETRIES:
        for m in CAUSE_MODELS:
            for f in CAUSE_PRIORS:
                for b in CAUSE_SIGNS:
                    j = cause_column(g, m, f, b, *AXES)
                    sc, cfg, _ = parse_cell(2, cells[j])
                    got = (sc.alpha_deg, sc.lead_deg, cfg.target_model,
                           cfg.beta_std_factor, cfg.beta_min)
                    assert got == (*g, m, f, b), f"column {j} is the cell {got}"


def test_s3_short_cells():
    sc, _, _ = parse_cell(3, cause_cells(3)[cause_column((45.0, 15.0), "cv", 2.0, None,
                                                        *AXES)])
    assert sc.t_end == 80.0, "S3 with lead +15 ends at 80 s, as declared with the family"


def test_bad_level():
    with pytest.raises(ValueError, match="level"):
        cause_column((1.0, 2.0), "cv", 2.0, None, *AXES)


def test_paired_effect():
    rng = np.random.default_rng(0)
    d = np.where(rng.random((400, 2)) < 0.9, 0, 1)
    d[:, 1] = np.where(rng.random(400) < 0.5, 0, d[:, 0])   # cell 1 succeeds more often
    k = rng.integers(3, 12, size=(400, 2))
    k[:, 1] = k[:, 0] - rng.integers(0, 3, size=400)
    e = paired_effect(d, k, 0, 1)
    ok = d == 0
    both = ok[:, 0] & ok[:, 1]
    assert e["dsucc"].value == pytest.approx(ok[:, 1].mean() - ok[:, 0].mean()), "rates"
    assert e["dscan"].value == pytest.approx((k[both, 1] - k[both, 0]).mean()), "scans"
    assert e["dsucc"].lo > 0 and e["dscan"].hi < 0, "the helpful side is decided"
    assert paired_effect(d[:30], k[:30], 0, 1)["dscan"] is None, "too few runs: no interval"
    with pytest.raises(ValueError, match="2-D"):
        paired_effect(d[:, 0], k[:, 0], 0, 1)


def test_effect_verdict():
    from trackcore.scenarios._sprt_book import effect_verdict
    from trackcore.stats import Estimate

    def est(lo, hi):
        return Estimate((lo + hi) / 2, lo, hi, 0.95, 100, "test")

    assert effect_verdict(est(0.01, 0.05), 0.02, "above") == "helps", "above 0 helps"
    assert effect_verdict(est(-0.7, -0.1), 0.5, "below") == "helps", "fewer scans help"
    assert effect_verdict(est(0.1, 0.7), 0.5, "below") == "hurts", "more scans hurt"
    assert effect_verdict(est(-0.01, 0.015), 0.02, "above") == "none", "equivalence"
    assert effect_verdict(est(-0.01, 0.03), 0.02, "above") == "undecided", "a tie"
    assert effect_verdict(None, 0.02, "above") == "undecided", "no interval"
    with pytest.raises(ValueError, match="helpful"):
        effect_verdict(est(0, 1), 0.02, "up")


def test_effect_verdict_checks_equivalence_first():
    """The declared rule (index, "Choices we made"): effects within the margin are "no
    cause", even when the interval excludes 0 (a small effect decided on many runs); the
    earlier order tested "helps" / "hurts" first and called these helping or hurting."""
    from trackcore.scenarios._sprt_book import effect_verdict
    from trackcore.stats import Estimate

    def est(lo, hi):
        return Estimate((lo + hi) / 2, lo, hi, 0.95, 5000, "test")

    assert effect_verdict(est(0.002, 0.008), 0.02, "above") == "none", "small gain"
    assert effect_verdict(est(-0.008, -0.002), 0.02, "above") == "none", "small loss"
    assert effect_verdict(est(-0.4, -0.1), 0.5, "below") == "none", "a few scans fewer"
    assert effect_verdict(est(0.1, 0.4), 0.5, "below") == "none", "a few scans more"
    assert effect_verdict(est(0.002, 0.03), 0.02, "above") == "helps", "past the margin"
    assert effect_verdict(est(-0.03, -0.002), 0.02, "above") == "hurts", "past the margin"


def test_paired_effect_without_spread():
    d = np.zeros((100, 2), dtype=int)
    k = np.full((100, 2), 5)
    k[:3, 1] = 4                       # three runs differ: no studentized interval
    e = paired_effect(d, k, 0, 1)
    assert e["dscan"] is None and e["why"] == "3 runs differ", "no interval, said why"
