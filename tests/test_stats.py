"""trackcore.stats: intervals, their coverage by simulation, verdicts and bad input."""
import math

import numpy as np
import pytest
from scipy.stats import binomtest

from trackcore.stats import (Estimate, band_verdict, bootstrap_ci, compare, diff_ci,
                             mcnemar_exact, mean_ci, paired_diff_ci, rate_ci, ratio_ci,
                             wilson_interval)


# ----------------------------------------------------------------- formatting and records

def test_estimate_format():
    e = Estimate(0.0943, 0.0711, 0.1182, n=100, method="x")
    assert f"{e:.3f}" == "0.094 [0.071, 0.118]"
    assert f"{Estimate(0.925, 0.908, 0.94):.1%}" == "92.5 [90.8, 94.0] %"
    assert str(e) == "0.0943 [0.0711, 0.118]"
    assert e.contains(0.1) and not e.contains(0.2)
    assert e.half_width == pytest.approx(0.02355)


@pytest.mark.parametrize("kw", [dict(value=float("nan"), lo=0, hi=1),
                                dict(value=0.5, lo=1, hi=0),
                                dict(value=0.5, lo=0, hi=1, level=1.0)])
def test_estimate_rejects_bad_fields(kw):
    with pytest.raises(ValueError):
        Estimate(**kw)


# ----------------------------------------------------------------- exact values

def test_mean_ci_is_reproducible_and_brackets_the_mean():
    x = np.random.default_rng(1).normal(3.0, 2.0, 200)
    a, b = mean_ci(x), mean_ci(x)
    assert a == b
    assert a.value == pytest.approx(x.mean())
    assert a.lo < a.value < a.hi
    # close to the normal-theory interval for a symmetric sample of 200
    half = 1.96 * x.std(ddof=1) / math.sqrt(x.size)
    assert a.half_width == pytest.approx(half, rel=0.08)


def test_degenerate_sample_gives_a_point_interval():
    e = mean_ci([2.0, 2.0, 2.0])
    assert (e.value, e.lo, e.hi) == (2.0, 2.0, 2.0)


def test_paired_diff_uses_the_pairing():
    rng = np.random.default_rng(2)
    common = rng.normal(0, 10, 100)        # large run-to-run variation shared by both
    x = common + rng.normal(0, 0.1, 100)
    y = common + 0.2 + rng.normal(0, 0.1, 100)
    paired = paired_diff_ci(x, y)
    unpaired = diff_ci(x, y)
    assert paired.hi < 0                    # the pairing resolves a 0.2 difference
    assert unpaired.lo < 0 < unpaired.hi    # ignoring it cannot
    assert paired.value == pytest.approx(unpaired.value)


def test_ratio_ci():
    rng = np.random.default_rng(3)
    y = rng.gamma(4.0, 5.0, 300)
    x = 0.9 * y * rng.lognormal(0, 0.05, 300)
    r = ratio_ci(x, y)
    assert r.value == pytest.approx(x.mean() / y.mean())
    assert r.lo < 0.9 * 1.0013 < r.hi or r.contains(0.9)
    assert r.hi < 1.0


def test_bootstrap_ci_general_statistic_matches_mean_ci():
    x = np.random.default_rng(4).exponential(1.0, 150)
    g = bootstrap_ci(lambda a: a.mean(axis=1), x)
    m = mean_ci(x)
    assert g.value == pytest.approx(m.value)
    assert g.lo == pytest.approx(m.lo, rel=0.05) and g.hi == pytest.approx(m.hi, rel=0.05)
    med = bootstrap_ci(lambda a: np.median(a, axis=1), x)
    assert med.lo <= np.median(x) <= med.hi


def test_wilson_against_closed_form_and_scipy():
    lo, hi = wilson_interval(5, 10)
    assert (lo, hi) == pytest.approx((0.2365931, 0.7634069), abs=1e-6)
    ci = binomtest(7, 40).proportion_ci(0.95, method="wilson")
    e = rate_ci(7, 40)
    assert (e.lo, e.hi) == pytest.approx((ci.low, ci.high), abs=1e-12)
    assert rate_ci(np.array([True, False, True, True]), 4).value == 0.75
    assert rate_ci(0, 50).lo == 0.0 and rate_ci(50, 50).hi == 1.0


def test_mcnemar_exact():
    # 15 discordant pairs one way, 1 the other: p = 2 * P(Bin(16, 1/2) <= 1)
    assert mcnemar_exact(15, 1) == pytest.approx(2 * 17 / 2 ** 16)
    assert mcnemar_exact(0, 0) == 1.0
    assert mcnemar_exact(3, 3) == 1.0


# ----------------------------------------------------------------- verdicts

def test_compare_verdicts():
    rng = np.random.default_rng(5)
    base = rng.normal(10, 3, 200)
    better = base - 1.0 + rng.normal(0, 0.2, 200)
    same = base + rng.normal(0, 0.2, 200)
    c = compare(better, base, ("HPDA", "PHD"))
    assert c.verdict == "HPDA < PHD" and c.better == "HPDA"
    assert compare(same, base).verdict == "tie" and compare(same, base).better is None
    c = compare(better, base, ("a", "b"), lower_is_better=False)
    assert c.better == "b"
    r = compare(better, base, kind="ratio")
    assert r.effect.hi < 1 and r.verdict == "A < B"
    assert "A - B" in str(compare(better, base))


def test_band_verdict():
    e = Estimate(0.92, 0.90, 0.94)
    assert band_verdict(e, 0.88, 0.98) == "met"
    assert band_verdict(e, 0.95, None) == "missed"
    assert band_verdict(e, None, 0.91) == "undecided"
    with pytest.raises(ValueError):
        band_verdict(e)
    with pytest.raises(TypeError):
        band_verdict(0.9, 0.8, 1.0)


# ----------------------------------------------------------------- coverage by simulation

def _coverage(make, truth, n_rep, seed, **kw):
    rng = np.random.default_rng(seed)
    hits = 0
    for _ in range(n_rep):
        hits += make(rng, **kw).contains(truth)
    return hits / n_rep


@pytest.mark.parametrize("dist, n", [("normal", 30), ("exponential", 40), ("exponential", 200)])
def test_mean_ci_coverage(dist, n):
    draw = {"normal": lambda r: r.normal(1.0, 2.0, n),
            "exponential": lambda r: r.exponential(1.0, n)}[dist]
    cov = _coverage(lambda r: mean_ci(draw(r), n_boot=1000), 1.0, 600, 11)
    # 600 replications: the binomial sd of a 0.95 coverage is 0.009
    assert 0.92 <= cov <= 0.975, cov


def test_paired_diff_and_ratio_coverage():
    def diff(r):
        c = r.gamma(2.0, 50.0, 60)
        return paired_diff_ci(c + r.normal(0, 5, 60), c + 2 + r.normal(0, 5, 60), n_boot=1000)

    def ratio(r):
        c = r.gamma(3.0, 10.0, 80)
        return ratio_ci(0.9 * c * r.lognormal(0, 0.2, 80), c * r.lognormal(0, 0.2, 80),
                        n_boot=1000)

    assert 0.92 <= _coverage(diff, -2.0, 600, 12) <= 0.975
    # E[lognormal(0, 0.2)] is the same for both arms, so the true ratio of means is 0.9
    assert 0.92 <= _coverage(ratio, 0.9, 600, 13) <= 0.975


def test_wilson_coverage():
    rng = np.random.default_rng(14)
    for p, n in ((0.05, 100), (0.3, 50), (0.9, 200)):
        k = rng.binomial(n, p, 4000)
        lo, hi = wilson_interval(k, n)
        cov = np.mean((lo <= p) & (p <= hi))
        assert 0.925 <= cov <= 0.975, (p, n, cov)


# ----------------------------------------------------------------- bad input

@pytest.mark.parametrize("call, exc", [
    (lambda: mean_ci([1.0]), ValueError),
    (lambda: mean_ci([[1.0, 2.0]]), ValueError),
    (lambda: mean_ci([1.0, float("nan")]), ValueError),
    (lambda: mean_ci(["a", "b"]), TypeError),
    (lambda: mean_ci([1.0, 2.0], level=1.5), ValueError),
    (lambda: mean_ci([1.0, 2.0], n_boot=10), ValueError),
    (lambda: mean_ci([1.0, 2.0], n_boot=1000.0), TypeError),
    (lambda: paired_diff_ci([1.0, 2.0], [1.0, 2.0, 3.0]), ValueError),
    (lambda: ratio_ci([1.0, 2.0], [-1.0, -2.0]), ValueError),
    (lambda: rate_ci(3, 2), ValueError),
    (lambda: rate_ci(1.5, 4), ValueError),
    (lambda: wilson_interval(float("nan"), 10), ValueError),
    (lambda: mcnemar_exact(-1, 2), ValueError),
    (lambda: compare([1.0, 2.0], [1.0, 2.0], kind="odds"), ValueError),
    (lambda: bootstrap_ci(3, [1.0, 2.0]), TypeError),
    (lambda: bootstrap_ci(lambda a: a.mean(axis=1), [1.0, 2.0], [1.0, 2.0, 3.0]), ValueError),
])
def test_bad_input(call, exc):
    with pytest.raises(exc):
        call()


def test_bca_falls_back_to_the_basic_interval_when_the_estimate_is_outside_its_bootstrap():
    # |mean| of zero-mean noise: noise biases every resample's |mean| upwards, so the
    # estimate sits below nearly all replicates.  BCa would squeeze the interval onto the
    # estimate; the basic interval (2 theta - q_hi, 2 theta - q_lo), which corrects against
    # the bias as BCa does, widened to contain the estimate, is returned instead.
    x = np.random.default_rng(3).normal(size=30)
    x = x - x.mean() + 1e-3  # |mean| = 1e-3, far below the typical resampled |mean|
    stat = lambda a: np.abs(a.mean(axis=1))  # noqa: E731
    est = bootstrap_ci(stat, x)
    assert "basic" in est.method
    assert est.hi == pytest.approx(est.value)
    # the lower end is 2 theta minus the 97.5 % point of |mean| of 30 draws (~2.24/sqrt(30))
    assert -0.6 < est.lo < -0.3
    # an unbiased statistic keeps BCa
    assert "basic" not in mean_ci(x).method
