"""Simulated coverage of the intervals that decide the book's verdicts.

The promise (book/conventions.md, statistics section): at every number of runs ``n`` that
:func:`~trackcore.stats.mean_ci`, :func:`~trackcore.stats.paired_diff_ci` and
:func:`~trackcore.stats.ratio_ci` accept, their 95 % intervals cover the true value in at
least 93 % of repeated experiments on three families of per-run values:

* ``normal``: N(0, 1) (``mean_ci``); pairs ``x = 4 + W1``, ``y = 5 + W2``;
* ``lognormal``: ``exp(Z)``, sigma = 1 (skewness 6.2); pairs ``x = exp(W1)``,
  ``y = 1.25 exp(W2)``;
* ``bernoulli``: 0/1 with P(1) = 0.05; pairs ``x = [Phi(W1) < 0.05]``,
  ``y = [Phi(W2) < 0.05]``;

where ``(W1, W2)`` are standard normal with correlation 0.5 (a shared run effect:
``W = sqrt(.5) Z0 + sqrt(.5) Z``), so the pairs are correlated like two methods on the same
seeds.  True values: the mean (0, e^0.5, 0.05); differences (-1, -0.25 e^0.5, 0); ratios
(0.8, 0.8, 1).  A ratio is only defined when ``mean(y) > 0``; coverage of ``ratio_ci`` is
over the samples it accepts.

Where a function refuses an ``n`` (fewer than ``MIN_RUNS`` runs of non-0/1 values) the test
checks that it refuses with a ValueError.

Fast default: ``REPS = 400`` replications per cell and ``n_boot = 1000`` resamples inside
the intervals (the functions accept ``n_boot``; the book uses 10 000).  A cell fails when
its coverage is below ``0.93 - 3 sd``, ``sd = sqrt(0.93 * 0.07 / REPS)`` (0.038 at 400
replications: a cell at 0.89 or below fails).  Heavier setting, for a study::

    TRACKCORE_COVERAGE_REPS=4000 TRACKCORE_COVERAGE_NS=5,10,20,30,50,100,200,500,1000 \\
        pytest -p no:xdist tests/test_stats_coverage.py -s

(``-s`` prints each cell's coverage.)  The 0/1 intervals are also checked exactly (no
simulation: every count weighted by its probability) by ``test_binary_exact_coverage``.
"""
import math
import os

import numpy as np
import pytest
from scipy.special import gammaln
from scipy.stats import binom, multivariate_normal

from trackcore.stats import MIN_RUNS, mean_ci, paired_diff_ci, ratio_ci

REPS = int(os.environ.get("TRACKCORE_COVERAGE_REPS", "400"))
NS = [int(v) for v in os.environ.get("TRACKCORE_COVERAGE_NS", "5,10,20,50,100,200").split(",")]
N_BOOT = int(os.environ.get("TRACKCORE_COVERAGE_NBOOT", "1000"))
TARGET = 0.93
MARGIN = 3.0 * math.sqrt(TARGET * (1 - TARGET) / REPS)
P = 0.05
ZP = -1.6448536269514722  # Phi^-1(0.05)

TRUE = {("mean", "normal"): 0.0, ("mean", "lognormal"): math.exp(0.5),
        ("mean", "bernoulli"): P,
        ("diff", "normal"): -1.0, ("diff", "lognormal"): -0.25 * math.exp(0.5),
        ("diff", "bernoulli"): 0.0,
        ("ratio", "normal"): 0.8, ("ratio", "lognormal"): 0.8, ("ratio", "bernoulli"): 1.0}


def draw(kind, family, n, rng):
    """One experiment: ``(x,)`` for mean_ci, ``(x, y)`` paired runs otherwise."""
    z0, z1, z2 = rng.standard_normal((3, n))
    if kind == "mean":
        return ({"normal": z1, "lognormal": np.exp(z1),
                 "bernoulli": (z1 < ZP).astype(float)}[family],)
    w1 = math.sqrt(0.5) * (z0 + z1)
    w2 = math.sqrt(0.5) * (z0 + z2)
    if family == "normal":
        return 4.0 + w1, 5.0 + w2
    if family == "lognormal":
        return np.exp(w1), 1.25 * np.exp(w2)
    return (w1 < ZP).astype(float), (w2 < ZP).astype(float)


FUNCS = {"mean": mean_ci, "diff": paired_diff_ci, "ratio": ratio_ci}


def coverage(kind, family, n, reps=REPS, seed=0):
    """Simulated coverage of FUNCS[kind] and the number of accepted samples."""
    rng = np.random.default_rng([seed, n, list(FUNCS).index(kind),
                                 ("normal", "lognormal", "bernoulli").index(family)])
    truth, hits, used = TRUE[kind, family], 0, 0
    for r in range(reps):
        data = draw(kind, family, n, rng)
        if kind == "ratio" and not data[1].mean() > 0:
            continue  # the ratio of means is undefined on this sample
        est = FUNCS[kind](*data, n_boot=N_BOOT, seed=r)
        used += 1
        hits += est.lo <= truth <= est.hi
    return hits / max(used, 1), used


CELLS = [(k, f, n) for k in FUNCS for f in ("normal", "lognormal", "bernoulli") for n in NS]


@pytest.mark.parametrize("kind, family, n", CELLS)
def test_coverage_at_least_93_percent(kind, family, n):
    if family != "bernoulli" and n < MIN_RUNS:
        with pytest.raises(ValueError, match="at least"):
            FUNCS[kind](*draw(kind, family, n, np.random.default_rng(0)), n_boot=N_BOOT)
        return
    cov, used = coverage(kind, family, n)
    print(f"\n{kind:5s} {family:9s} n={n:5d} coverage {cov:.3f} ({used} samples)")
    assert used >= REPS // 5, f"only {used} accepted samples"
    sd = math.sqrt(TARGET * (1 - TARGET) / used)
    assert cov >= TARGET - 3.0 * sd, (
        f"{kind} on {family} runs at n = {n}: coverage {cov:.3f} below "
        f"{TARGET} - 3 sd ({TARGET - 3.0 * sd:.3f}) over {used} samples")


def _paired_cells(n, tail=1e-9):
    """All paired 0/1 outcomes (a both, b only x, c only y) with their probabilities."""
    p11 = float(multivariate_normal(mean=[0, 0], cov=[[1, 0.5], [0.5, 1]]).cdf([ZP, ZP]))
    q = np.array([p11, P - p11, P - p11, 1 - 2 * P + p11])
    amax = int(binom.ppf(1 - tail, n, q[0])) + 1
    bmax = int(binom.ppf(1 - tail, n, q[1])) + 1
    a, b, c = (g.ravel() for g in np.meshgrid(np.arange(amax + 1), np.arange(bmax + 1),
                                             np.arange(bmax + 1), indexing="ij"))
    d = n - a - b - c
    ok = d >= 0
    a, b, c, d = a[ok], b[ok], c[ok], d[ok]
    lp = (gammaln(n + 1) - gammaln(a + 1) - gammaln(b + 1) - gammaln(c + 1) - gammaln(d + 1)
          + a * np.log(q[0]) + b * np.log(q[1]) + c * np.log(q[2]) + d * np.log(q[3]))
    return a, b, c, np.exp(lp)


def _pair(a, b, c, n):
    x = np.zeros(n)
    y = np.zeros(n)
    x[:a + b] = 1
    y[:a] = 1
    y[a + b:a + b + c] = 1
    return x, y


@pytest.mark.parametrize("n", [5, 10, 11, 20, 50, 110, 200])
def test_binary_exact_coverage(n):
    """Exact coverage on Bernoulli(0.05) runs, every outcome weighted by its probability
    (n = 11 and 110 are where the Wilson interval dips below 93 % at p = 0.05)."""
    k = np.arange(n + 1)
    w = binom.pmf(k, n, P)
    keep = w > 1e-12
    cov = sum(wk * mean_ci((np.arange(n) < kk).astype(float)).contains(P)
              for kk, wk in zip(k[keep], w[keep]))
    assert cov >= TARGET, f"mean_ci, n = {n}: exact coverage {cov:.4f}"
    a, b, c, w = _paired_cells(n)
    keep = w > 1e-10
    hit_d = hit_r = acc_r = 0.0
    for ai, bi, ci, wi in zip(a[keep], b[keep], c[keep], w[keep]):
        x, y = _pair(int(ai), int(bi), int(ci), n)
        hit_d += wi * paired_diff_ci(x, y).contains(0.0)
        if ai + ci > 0:
            acc_r += wi
            hit_r += wi * ratio_ci(x, y).contains(1.0)
    total = w[keep].sum()
    print(f"\nn={n}: exact coverage mean_ci {cov:.4f}, paired_diff_ci {hit_d / total:.4f}, "
          f"ratio_ci {hit_r / acc_r:.4f}")
    assert hit_d / total >= TARGET, f"paired_diff_ci, n = {n}: exact coverage {hit_d / total:.4f}"
    assert hit_r / acc_r >= TARGET, f"ratio_ci, n = {n}: exact coverage {hit_r / acc_r:.4f}"
