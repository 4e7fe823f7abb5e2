"""trackcore.stats: intervals, their coverage by simulation, verdicts and bad input."""
import math

import numpy as np
import pytest
from scipy.stats import binomtest

import trackcore.stats as stats_module
from trackcore.stats import (BCA_RUNS, MIN_RUNS, N_BOOT_MAX, Estimate, band_verdict,
                             bootstrap_ci, compare, diff_ci, mcnemar_exact, mean_ci,
                             paired_diff_ci, rate_ci, ratio_ci, wilson_interval)


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


def test_degenerate_sample_gives_no_zero_width_interval():
    with pytest.raises(ValueError, match="same"):
        mean_ci([2.0] * 40)
    e = mean_ci(np.zeros(40))  # 0/1 runs without an event: the exact interval of a rate
    assert (e.value, e.lo) == (0.0, 0.0) and e.hi > 0.05


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
    x = np.random.default_rng(4).exponential(1.0, BCA_RUNS)  # mean_ci's BCa range
    g = bootstrap_ci(lambda a: a.mean(axis=1), x)
    m = mean_ci(x)
    assert g.value == pytest.approx(m.value)
    assert m.method == "BCa bootstrap"
    assert (g.lo, g.hi) == pytest.approx((m.lo, m.hi), rel=1e-12)  # same resamples, BCa
    med = bootstrap_ci(lambda a: np.median(a, axis=1), x)
    assert med.lo <= np.median(x) <= med.hi


def test_bootstrap_ci_resamples_rows_of_multi_column_samples():
    # the resamples and leave-one-out samples are whole rows, drawn as rng.integers does
    from trackcore.stats import _leave_one_out_indices

    assert _leave_one_out_indices(3).tolist() == [[1, 2], [0, 2], [0, 1]]
    cols = np.random.default_rng(2).exponential(1.0, size=(60, 2))
    seen = {}

    def stat(b):
        seen.setdefault(b.shape[0], b)
        return b[..., 0].mean(axis=1) / b[..., 1].mean(axis=1)

    est = bootstrap_ci(stat, cols, n_boot=200, seed=3)
    idx = np.random.default_rng(3).integers(0, 60, size=(200, 60))
    assert np.array_equal(seen[200], cols[idx])
    assert np.array_equal(seen[60][7], np.delete(cols, 7, axis=0))
    assert est.lo < est.value < est.hi


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


@pytest.mark.parametrize("dist, n", [("normal", 40), ("exponential", 40), ("exponential", 200)])
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
    assert "basic" not in bootstrap_ci(lambda a: a.mean(axis=1), x).method


# ----------------------------------------------------------------- methods by n and data
# (the coverage behind these choices: tests/test_stats_coverage.py)

def test_mean_ci_methods_by_n_and_data():
    rng = np.random.default_rng(20)
    assert mean_ci(rng.normal(size=MIN_RUNS)).method == "studentized bootstrap"
    assert mean_ci(rng.normal(size=BCA_RUNS - 1)).method == "studentized bootstrap"
    assert mean_ci(rng.normal(size=BCA_RUNS)).method == "BCa bootstrap"
    with pytest.raises(ValueError, match=f"at least {MIN_RUNS} runs"):
        mean_ci(rng.normal(size=MIN_RUNS - 1))
    # 0/1 runs: the exact interval below BCA_RUNS or with few events, BCa otherwise
    few = (rng.random(BCA_RUNS) < 0.01).astype(float)
    assert few.sum() < 10 and mean_ci(few).method.startswith("Clopper-Pearson")
    many = (rng.random(BCA_RUNS) < 0.2).astype(float)
    assert mean_ci(many).method == "BCa bootstrap"
    assert mean_ci([0.0, 1.0]).method.startswith("Clopper-Pearson")  # any n >= 2


def test_clopper_pearson_matches_scipy():
    for k, n in ((0, 5), (1, 5), (3, 40), (40, 40), (7, 499)):
        e = mean_ci((np.arange(n) < k).astype(float))
        ci = binomtest(k, n).proportion_ci(0.95, method="exact")
        assert (e.lo, e.hi) == pytest.approx((ci.low, ci.high), abs=1e-10)
        assert e.value == k / n and e.lo < e.hi


def test_studentized_interval_is_the_hull_of_equal_tailed_and_symmetric():
    x = np.random.default_rng(21).lognormal(0, 1, 60)
    e = mean_ci(x, n_boot=2000, seed=3)
    rng = np.random.default_rng(3)
    m, se = x.mean(), x.std(ddof=1) / math.sqrt(x.size)
    r = x[rng.integers(0, x.size, size=(2000, x.size))]
    t = np.sort((r.mean(1) - m) / (r.std(1, ddof=1) / math.sqrt(x.size)))
    q = np.sort(np.abs(t))[math.ceil(0.95 * 2001) - 1]
    lo = min(m - t[math.ceil(0.975 * 2001) - 1] * se, m - q * se)
    hi = max(m - t[math.floor(0.025 * 2001) - 1] * se, m + q * se)
    assert (e.lo, e.hi) == pytest.approx((lo, hi), rel=1e-12)
    assert e.hi - e.value > e.value - e.lo  # right-skewed runs: the upper side is longer


def test_studentized_refuses_runs_with_too_few_distinct_values():
    x = np.r_[np.zeros(MIN_RUNS + 4), 3.0]  # most resamples of 35 runs have no spread
    with pytest.raises(ValueError, match="too few distinct values"):
        mean_ci(x)


def test_paired_diff_of_binary_runs_is_newcombe():
    rng = np.random.default_rng(22)
    x = (rng.random(80) < 0.3).astype(float)
    y = np.where(rng.random(80) < 0.7, x, (rng.random(80) < 0.3)).astype(float)
    e = paired_diff_ci(x, y)
    assert e.method == "Newcombe score (paired 0/1 runs)"
    f = paired_diff_ci(y, x)
    assert (f.value, f.lo, f.hi) == pytest.approx((-e.value, -e.hi, -e.lo), abs=1e-12)
    # uncorrelated cells (phi = 0) give the independent-samples hybrid of two Wilson intervals
    x0 = np.array([1, 1, 0, 0] * 10, float)
    y0 = np.array([1, 0, 1, 0] * 10, float)
    g = paired_diff_ci(x0, y0)
    lo1, hi1 = wilson_interval(20, 40)
    assert g.value == 0.0
    assert g.hi == pytest.approx(math.hypot(0.5 - lo1, hi1 - 0.5), abs=1e-12)
    # identical 0/1 runs: a real interval around 0, not [0, 0]; compare calls it a tie
    z = np.zeros(30)
    d = paired_diff_ci(z, z)
    assert d.lo < 0 < d.hi
    assert compare(z, z).verdict == "tie" and compare(z, z).effect.half_width > 0.05


def test_paired_diff_of_binary_runs_uses_bca_with_many_runs_and_discordant_pairs():
    rng = np.random.default_rng(23)
    x = (rng.random(BCA_RUNS) < 0.3).astype(float)
    y = (rng.random(BCA_RUNS) < 0.3).astype(float)
    assert paired_diff_ci(x, y).method == "paired BCa bootstrap"
    y2 = x.copy()
    y2[:3] = 1 - y2[:3]  # 3 discordant runs: too few for the bootstrap
    assert paired_diff_ci(x, y2).method.startswith("Newcombe")


def test_paired_diff_of_other_values_is_studentized_at_every_n():
    rng = np.random.default_rng(24)
    for n in (MIN_RUNS, 2 * BCA_RUNS):
        x, y = rng.lognormal(size=n), rng.lognormal(size=n)
        assert paired_diff_ci(x, y).method == "paired studentized bootstrap"
    with pytest.raises(ValueError, match="at least"):
        paired_diff_ci(rng.normal(size=10), rng.normal(size=10))
    x = rng.normal(size=40)
    with pytest.raises(ValueError, match="same"):
        paired_diff_ci(x, x)          # identical runs: no interval ...
    with pytest.raises(ValueError, match="same"):
        compare(x, x)                 # ... and no "tie" drawn from a zero-width one
    with pytest.raises(ValueError, match="same"):
        paired_diff_ci(np.arange(40.0) + 1, np.arange(40.0))  # a constant difference


def test_ratio_ci_methods_and_refusals():
    rng = np.random.default_rng(25)
    x, y = rng.lognormal(size=60), rng.lognormal(size=60)
    assert ratio_ci(x, y).method == "paired studentized bootstrap"
    assert ratio_ci(x, y, paired=False).method == "studentized bootstrap"
    xb, yb = rng.lognormal(size=BCA_RUNS), rng.lognormal(size=BCA_RUNS)
    assert ratio_ci(xb, yb).method == "paired studentized bootstrap"  # at every n
    xs = (rng.random(BCA_RUNS) < 0.3).astype(float)
    ys = (rng.random(BCA_RUNS) < 0.3).astype(float)
    assert ratio_ci(xs, ys).method == "paired BCa bootstrap"  # many 0/1 runs and events
    with pytest.raises(ValueError, match="same"):
        ratio_ci(2.0 * y, y)          # the same ratio in every run
    with pytest.raises(ValueError, match="at least"):
        ratio_ci(x[:10], y[:10])
    # y zero in most runs: resamples with mean(y) = 0 are refused, not silently dropped
    y0 = np.r_[np.zeros(39), 1.5]
    with pytest.raises(ValueError, match="resamples have mean"):
        ratio_ci(rng.lognormal(size=40), y0)


def test_ratio_ci_of_binary_runs():
    x = np.array([1, 1, 1, 0, 0, 0, 0, 0, 1, 0] * 4, float)
    y = np.array([1, 0, 0, 1, 0, 0, 0, 0, 1, 0] * 4, float)
    e = ratio_ci(x, y)
    a, b, c = 8, 8, 4  # both, only x, only y
    r = (a + b + 1) / (a + c + 1)
    s = math.sqrt((b + c + 2) / ((a + b + 1) * (a + c + 1)))
    assert e.method == "adjusted log-ratio score (paired 0/1 runs)"
    assert e.value == pytest.approx(16 / 12)
    assert (e.lo, e.hi) == pytest.approx((r * math.exp(-1.959963985 * s),
                                          r * math.exp(1.959963985 * s)), rel=1e-9)
    assert ratio_ci(y, y).lo < 1.0 < ratio_ci(y, y).hi  # identical runs: not [1, 1]
    with pytest.raises(ValueError, match="mean\\(y\\) > 0"):
        ratio_ci(x, np.zeros(40))


def test_diff_ci_of_constant_samples():
    e = diff_ci(np.zeros(20), np.zeros(30))
    assert e.lo < 0 < e.hi and e.method == "Newcombe score (0/1 runs)"
    with pytest.raises(ValueError, match="same"):
        diff_ci(np.full(20, 3.0), np.full(30, 2.0))


def test_compare_refuses_a_zero_width_interval(monkeypatch):
    monkeypatch.setattr(stats_module, "paired_diff_ci",
                        lambda *a, **k: Estimate(0.0, 0.0, 0.0, n=40))
    with pytest.raises(ValueError, match="zero width"):
        compare(np.arange(40.0), np.arange(40.0) + 1)


# ----------------------------------------------------------------- review findings F3, F4, F8

def test_huge_but_finite_values():
    rng = np.random.default_rng(26)
    for n in (40, BCA_RUNS):
        x = rng.normal(size=n)
        big = mean_ci(x * 2.0 ** 1000)     # ~1e301: squares and cubes overflow unscaled
        ref = mean_ci(x)
        assert (big.value, big.lo, big.hi) == pytest.approx(
            (ref.value * 2.0 ** 1000, ref.lo * 2.0 ** 1000, ref.hi * 2.0 ** 1000), rel=1e-9)
    e = paired_diff_ci(rng.normal(size=40) * 1e300, rng.normal(size=40) * 1e300)
    assert math.isfinite(e.lo) and math.isfinite(e.hi)
    r = ratio_ci(rng.lognormal(size=40) * 1e300, rng.lognormal(size=40))
    assert math.isfinite(r.hi) and r.lo > 1e299
    # the review's sample: BCa acceleration from cubes of 1e300 (bootstrap_ci, any n >= 2)
    g = bootstrap_ci(lambda a: a.mean(axis=1), [1e300, -1e300, 1e300, 2e300])
    assert g.lo <= 7.5e299 <= g.hi
    with pytest.raises(ValueError, match=f"at least {MIN_RUNS}"):
        mean_ci([1e300, -1e300, 1e300, 2e300])  # a clear error naming x, not numpy's


def test_n_boot_is_capped():
    with pytest.raises(ValueError, match=f"at most {N_BOOT_MAX}"):
        mean_ci(np.arange(40.0), n_boot=10 ** 9)


def test_estimate_value_must_lie_in_its_interval():
    with pytest.raises(ValueError, match="outside"):
        Estimate(5.0, 0.0, 1.0)
    assert Estimate(1.0, 0.0, 1.0).contains(1.0)


def test_spread_at_rounding_level_is_no_spread():
    # 47 runs equal up to rounding (0.1 + 0.2 and 0.3), 3 that differ: most resamples
    # have a spread of 1e-17, which must not studentize to an enormous t
    x = np.r_[np.full(24, 0.1 + 0.2), np.full(23, 0.3), [0.2, 0.25, 0.28]]
    with pytest.raises(ValueError, match="too few distinct values"):
        mean_ci(x)


def test_studentized_intervals_stay_within_what_the_runs_can_give():
    """One dominant run: the bootstrap-t ends would fall outside the runs' range; they are
    cut to it (a mean within [min, max], a ratio of positive runs within the per-run ratios)
    and the method says so. Ordinary runs are untouched."""
    rng = np.random.default_rng(5)
    x, y = rng.gamma(4.0, 25.0, size=60), rng.gamma(4.0, 25.0, size=60)
    x[7] = 13000.0  # one diverged run
    e = mean_ci(x)
    assert x.min() <= e.lo < e.value < e.hi <= x.max(), e
    assert e.lo == x.min() and e.method.endswith("range-limited"), e
    d = paired_diff_ci(x, y)
    assert (x - y).min() <= d.lo and d.hi <= (x - y).max(), d
    for paired in (True, False):
        r = ratio_ci(x, y, paired=paired)
        assert r.lo > 0.0 and r.method.endswith("range-limited"), r
        q = x / y if paired else np.array([a / b for a in (x.min(), x.max())
                                           for b in (y.min(), y.max())])
        assert q.min() <= r.lo and r.hi <= q.max(), r
    r = ratio_ci(y, x)
    assert (y / x).min() <= r.lo and r.hi <= (y / x).max(), r
    ok = mean_ci(rng.normal(1.0, 0.1, size=60))
    assert "range-limited" not in ok.method, ok
