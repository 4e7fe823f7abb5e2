"""Monte Carlo uncertainty: the intervals that decide every verdict in the book.

One place for the statistics the chapters use to say "X beats Y", "target met" or "the
paper's claim fails":

* :func:`mean_ci` -- an interval of a mean over Monte Carlo runs;
* :func:`paired_diff_ci` and :func:`ratio_ci` -- the difference or ratio of two means, with
  the runs resampled *together* when they are paired (same seeds, same scans);
* :func:`diff_ci` -- the same for two independent samples;
* :func:`paired_rate_diff_ci` -- :func:`paired_diff_ci` of paired 0/1 runs drawn as
  multinomial counts, for tens of thousands of runs;
* :func:`rate_ci` / :func:`wilson_interval` -- the Wilson score interval of a rate
  (lost tracks, success rates) :cite:p:`wilson1927`;
* :func:`mcnemar_exact` -- the exact two-sided McNemar (sign) test on paired binary outcomes
  :cite:p:`mcnemar1947`;
* :func:`compare` and :func:`band_verdict` -- verdicts taken on an interval: a difference
  whose interval contains zero is a tie; a target band is *met* only when the whole interval
  lies inside it, *missed* when the whole interval lies outside, and *undecided* otherwise.

Which interval a mean, a paired difference or a ratio of means gets depends on the data
and the number of runs ``n``; the rule exists to keep one promise, measured by simulation
in ``tests/test_stats_coverage.py``: at every ``n`` a function accepts, its "95 %" interval
covers the true value in at least 93 % of experiments on normal, lognormal (sigma = 1) and
Bernoulli(0.05) runs (pairs: correlated draws of each family).

* **0/1 runs** (events): the exact Clopper-Pearson interval of a rate (:func:`mean_ci`),
  Newcombe's hybrid score interval of a paired difference of rates
  (:func:`paired_diff_ci`), an adjusted log-ratio interval of a paired ratio of rates
  (:func:`ratio_ci`), at any ``n >= 2``.  From ``BCA_RUNS`` = 500 runs on, with at least
  ``MIN_EVENTS`` = 10 events and non-events (differing runs for pairs), the BCa bootstrap.
* **other values**: at least ``MIN_RUNS`` = 40 runs, else a ValueError (the mean of 30
  lognormal runs was covered in only 92.7 % of experiments).  The studentized bootstrap interval
  (bootstrap-t; :cite:t:`efron1993bootstrap`, ch. 12), taken as the hull of its
  equal-tailed and symmetric forms, for means below ``BCA_RUNS`` runs and for every
  difference and ratio; the bias-corrected and accelerated (BCa) bootstrap (ch. 14) for
  means from ``BCA_RUNS`` runs on, where it reaches 93 % too.  A studentized interval never
  reaches past what the statistic can be on a resample of the runs (a mean stays within the
  runs' smallest and largest values, a ratio of positive-denominator runs within their
  per-run ratios): with one dominant run the bootstrap-t ends can otherwise land far outside
  anything the runs could give.  Such an interval's method ends in "range-limited".
* runs that are all equal (or a difference or ratio that is the same in every run) have
  no interval: a ValueError, never a zero-width interval, so :func:`compare` never calls
  a degenerate interval a tie.  Runs nearly all equal (too many resamples without spread,
  spreads below 1e-9 of the values counting as none) are a ValueError too.  0/1 runs are the exception: all-zero runs still get the
  exact interval of a rate, e.g. ``[0, 0.52]`` for 0 events in 5 runs.

Bootstrap intervals draw 10 000 resamples (at most ``N_BOOT_MAX`` = 10^6) from a fixed
seed, so that a notebook prints the same interval on every machine; the BCa acceleration
comes from the exact jackknife of the statistic (O(n) for means, differences and ratios).
Values of any finite size are accepted: huge ones (~1e300) are rescaled by a power of two
internally.  :func:`diff_ci` (independent samples) and :func:`bootstrap_ci` (any statistic)
keep the BCa interval at every ``n``; their coverage is not part of the promise.  The
resampled means and spreads are summed by private numba kernels in NumPy's own summation
order, so they equal the plain NumPy expressions bit for bit, and the last 1024 intervals
are remembered by the content of their samples (an interval is a pure function of the
values and the arguments), so asking twice costs one bootstrap.

Every interval is returned as an :class:`Estimate`, which formats as ``value [lo, hi]``::

    >>> import numpy as np
    >>> errors = np.random.default_rng(1).gamma(4.0, 0.025, size=40)  # one value per run
    >>> est = mean_ci(errors)     # 40 runs at least
    >>> f"{est:.3f}"
    '0.090 [0.077, 0.105]'
"""
from __future__ import annotations

import functools
import hashlib
import math
from collections import OrderedDict
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.special import ndtr, ndtri
from scipy.stats import beta as _beta_dist
from scipy.stats import binom

from . import _stats_kernels as _K

__all__ = [
    "Estimate",
    "Comparison",
    "mean_ci",
    "diff_ci",
    "paired_diff_ci",
    "paired_rate_diff_ci",
    "ratio_ci",
    "bootstrap_ci",
    "rate_ci",
    "wilson_interval",
    "mcnemar_exact",
    "compare",
    "band_verdict",
    "LEVEL",
    "N_BOOT",
    "N_BOOT_MAX",
    "MIN_RUNS",
    "BCA_RUNS",
    "MIN_EVENTS",
]

LEVEL = 0.95
"""Confidence level of every interval in the book unless a cell says otherwise."""

N_BOOT = 10_000
"""Bootstrap resamples per interval."""

N_BOOT_MAX = 1_000_000
"""Largest ``n_boot`` accepted (a larger request is a ValueError, not a MemoryError)."""

MIN_RUNS = 40
"""Fewest runs of non-0/1 values :func:`mean_ci`, :func:`paired_diff_ci` and
:func:`ratio_ci` accept: below it no interval here reaches 93 % coverage on skewed
(lognormal) runs, so they refuse with a ValueError."""

BCA_RUNS = 500
"""From this many runs on, :func:`mean_ci` and (for 0/1 runs only, with ``MIN_EVENTS``)
:func:`paired_diff_ci` and :func:`ratio_ci` use the BCa interval, which reaches 93 %
coverage there on every family tested; below it, the studentized interval (other values)
or the exact / score interval (0/1 values).  Differences and ratios of non-0/1 runs use
the studentized interval at every n."""

MIN_EVENTS = 10
"""0/1 runs with fewer events (or non-events; for paired runs: fewer discordant pairs) than
this keep the exact / score interval at any number of runs."""

_CHUNK = 2_000  # resamples per vectorised block (bounds memory at n_runs * _CHUNK floats)


# --------------------------------------------------------------------------- records

@dataclass(frozen=True)
class Estimate:
    """A point estimate with its confidence interval.

    Attributes
    ----------
    value : float
        The estimate (a mean, a difference or ratio of means, a rate).
    lo, hi : float
        The interval's ends.
    level : float
        Its confidence level (0.95 unless stated).
    n : int
        The number of runs (or trials) behind it.
    method : str
        How the interval was made, e.g. ``"BCa bootstrap"`` or ``"Wilson"``.

    ``format(est, ".3f")`` gives ``"0.094 [0.071, 0.118]"``; a ``%`` format gives
    ``"92.5 [90.8, 94.0] %"`` (one percent sign, after the interval).

    Examples
    --------
    >>> from trackcore.stats import Estimate
    >>> est = Estimate(0.094, 0.071, 0.118, n=40, method="BCa bootstrap")
    >>> f"{est:.3f}"
    '0.094 [0.071, 0.118]'
    >>> est.contains(0.1), est.contains(0.2)
    (True, False)
    """

    value: float
    lo: float
    hi: float
    level: float = LEVEL
    n: int = 0
    method: str = ""

    def __post_init__(self):
        for name in ("value", "lo", "hi"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
                raise TypeError(f"Estimate: {name} must be a number, got {v!r}")
            if not math.isfinite(v):
                raise ValueError(f"Estimate: {name} must be finite, got {v!r}")
        if isinstance(self.n, bool) or not isinstance(self.n, (int, np.integer)) or self.n < 0:
            raise ValueError(f"Estimate: n must be a non-negative integer, got {self.n!r}")
        if not isinstance(self.method, str):
            raise TypeError(f"Estimate: method must be a string, got {self.method!r}")
        if not self.lo <= self.hi:
            raise ValueError(f"Estimate: need lo <= hi, got [{self.lo}, {self.hi}]")
        if not self.lo <= self.value <= self.hi:
            raise ValueError(f"Estimate: value {self.value} lies outside its interval "
                             f"[{self.lo}, {self.hi}]")
        if not 0.0 < self.level < 1.0:
            raise ValueError(f"Estimate: level must lie in (0, 1), got {self.level}")

    def __format__(self, format_spec: str) -> str:
        format_spec = format_spec or ".3g"
        if format_spec.endswith("%"):
            inner = format_spec[:-1] + "f"
            v, lo, hi = (format(100.0 * float(x), inner)
                         for x in (self.value, self.lo, self.hi))
            return f"{v} [{lo}, {hi}] %"
        v, lo, hi = (format(float(x), format_spec) for x in (self.value, self.lo, self.hi))
        return f"{v} [{lo}, {hi}]"

    def __str__(self) -> str:
        return format(self, ".3g")

    def contains(self, x: float) -> bool:
        """Whether ``x`` lies inside the interval (ends included)."""
        return bool(self.lo <= x <= self.hi)

    @property
    def half_width(self) -> float:
        return 0.5 * (self.hi - self.lo)


@dataclass(frozen=True)
class Comparison:
    """The outcome of :func:`compare`: an interval for ``A - B`` (or ``A / B``) and the
    verdict it supports.

    ``verdict`` is ``"A < B"``, ``"A > B"`` or ``"tie"`` with the names given to
    :func:`compare`; ``better`` names the better one (or ``None`` for a tie).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import compare
    >>> rng = np.random.default_rng(1)
    >>> cv = rng.gamma(4.0, 0.25, size=50)                  # per-run RMSE, same seeds
    >>> res = compare(0.8 * cv + rng.normal(0, 0.02, 50), cv, names=("IMM", "CV"))
    >>> res.verdict, res.better
    ('IMM < CV', 'IMM')
    """

    a: str
    b: str
    effect: Estimate
    kind: str          # "difference" or "ratio"
    verdict: str
    better: str | None

    def __str__(self) -> str:
        op = "-" if self.kind == "difference" else "/"
        return f"{self.a} {op} {self.b} = {self.effect}: {self.verdict}"


# --------------------------------------------------------------------------- helpers

def _as_runs(x, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a 1-D array of numbers") from None
    if a.ndim != 1:
        raise ValueError(f"{name} must be 1-D (one value per run), got shape {a.shape}")
    if a.size < 2:
        raise ValueError(f"{name} needs at least 2 runs, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf")
    return a


def _check_level(level) -> float:
    try:
        level = float(level)
    except (TypeError, ValueError):
        raise TypeError("level must be a number in (0, 1)") from None
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    return level


def _check_n_boot(n_boot) -> int:
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)):
        raise TypeError("n_boot must be an integer")
    if n_boot < 100:
        raise ValueError(f"n_boot must be at least 100, got {n_boot}")
    if n_boot > N_BOOT_MAX:
        raise ValueError(f"n_boot must be at most {N_BOOT_MAX}, got {n_boot}")
    return int(n_boot)


def _bca(theta_hat, boot, jack, level, n, method):
    """BCa interval from bootstrap replicates and jackknife values."""
    boot = np.asarray(boot, float)
    boot = boot[np.isfinite(boot)]
    if boot.size == 0:
        raise ValueError("every bootstrap replicate is non-finite")
    alpha = 0.5 * (1.0 - level)
    if np.all(boot == boot[0]):  # a degenerate sample (all runs equal)
        return Estimate(float(theta_hat), float(boot[0]), float(boot[0]), level, n, method)
    prop = (np.count_nonzero(boot < theta_hat)
            + 0.5 * np.count_nonzero(boot == theta_hat)) / boot.size
    if prop < alpha or prop > 1.0 - alpha:
        # The estimate lies outside the central 1 - 2 alpha of its own bootstrap
        # distribution (a statistic such as |mean| that noise biases): the bias correction
        # of BCa is then beyond the range where its transformation argument holds and
        # would squeeze the interval onto the estimate.  Use the basic bootstrap interval
        # (2 theta - q_hi, 2 theta - q_lo), which, like BCa, corrects against the bias
        # (the percentile interval would double it), widened to contain the estimate.
        q_lo, q_hi = np.quantile(boot, [alpha, 1.0 - alpha])
        lo, hi = 2.0 * theta_hat - q_hi, 2.0 * theta_hat - q_lo
        return Estimate(float(theta_hat), min(float(lo), float(theta_hat)),
                        max(float(hi), float(theta_hat)), level, n,
                        method + " (basic: bias beyond BCa's range)")
    z0 = ndtri(prop)
    a = _acceleration(np.asarray(jack, float))
    z = ndtri(np.array([alpha, 1.0 - alpha]))
    adj = ndtr(z0 + (z0 + z) / (1.0 - a * (z0 + z)))
    lo, hi = np.quantile(boot, adj)
    lo = min(float(lo), float(theta_hat))
    hi = max(float(hi), float(theta_hat))
    return Estimate(float(theta_hat), lo, hi, level, n, method)


def _acceleration(jack):
    """BCa acceleration from jackknife values; rescaled when the plain sums overflow
    (data of magnitude ~1e100 and beyond), so that it is finite for every finite input."""
    with np.errstate(over="ignore", invalid="ignore"):
        d = jack.mean() - jack
        num, den = np.sum(d ** 3), 6.0 * (np.sum(d * d) ** 1.5)
    if not (np.isfinite(num) and np.isfinite(den)):
        s = np.max(np.abs(jack))  # finite: the jackknife values are means of finite data
        d = jack / s
        d = d.mean() - d
        num, den = np.sum(d ** 3), 6.0 * (np.sum(d * d) ** 1.5)
    return float(num / den) if den > 0 else 0.0


def _scale(*arrays) -> float:
    """A power of two that brings the largest magnitude in ``arrays`` near 1, or 1.0 when
    the values are of ordinary size (so that ordinary data give bit-identical intervals).
    Dividing by a power of two is exact; it keeps sums of huge values finite."""
    m = max(float(np.max(np.abs(a))) for a in arrays)
    if m == 0.0 or 1e-100 < m < 1e100:
        return 1.0
    return float(2.0 ** math.floor(math.log2(m)))


def _is_binary(*arrays) -> bool:
    return all(bool(np.all((a == 0.0) | (a == 1.0))) for a in arrays)


def _boot_means(samples, paired, n_boot, seed):
    """Bootstrap means of each sample: returns one ``(n_boot,)`` array per sample."""
    rng = np.random.default_rng(seed)
    out = [np.empty(n_boot) for _ in samples]
    done = 0
    while done < n_boot:
        b = min(_CHUNK, n_boot - done)
        if paired:
            idx = _draw(rng, samples[0].size, b)
            for o, s in zip(out, samples):
                o[done:done + b] = _K.boot_means(s, idx)
        else:
            for o, s in zip(out, samples):
                o[done:done + b] = _K.boot_means(s, _draw(rng, s.size, b))
        done += b
    return out


def _draw(rng, n, b):
    """``b`` resamples of ``n`` run indices: ``rng.integers(0, n, size=(b, n))``, drawn as
    32-bit integers (the same values NumPy draws as 64-bit ones for ``n < 2**31``, in half
    the memory; ``tests/test_stats_kernels.py`` checks it)."""
    return rng.integers(0, n, size=(b, n), dtype=np.int32 if n < 2 ** 31 else np.int64)


def _jack_means(x):
    """Leave-one-out means of ``x``."""
    return (x.sum() - x) / (x.size - 1)


def _order_stat(sorted_t, k):
    """The ``k``-th smallest (1-based, clipped to the sample) of a sorted array."""
    return float(sorted_t[min(max(k, 1), sorted_t.size) - 1])


def _studentized(theta, se, t, level, n, method, bounds):
    """Studentized (bootstrap-t) interval from replicates ``t = (theta* - theta) / se*``.

    The hull of the equal-tailed interval ``(theta - t_hi se, theta - t_lo se)`` and the
    symmetric one ``theta -/+ |t|_level se``: the equal-tailed one follows a real skew, the
    symmetric one guards against a skew that is only noise in a small sample; the hull
    covers whenever either does.  ``t`` may hold +-inf (a resample with no spread).

    ``bounds = (lo, hi)`` is the range the statistic can take on any resample of these runs
    (``None`` for a side without one); the interval is cut to it.  When one run dominates,
    resamples without it have a tiny ``se*`` and a huge ``t``, and the bootstrap-t ends can
    land far outside anything the runs could produce (a ratio of positive errors with a
    negative lower end); no such end is kept.  The method then says "range-limited"."""
    t = t[~np.isnan(t)]
    if t.size < 100:
        raise ValueError("too few usable bootstrap replicates for a studentized interval")
    alpha = 0.5 * (1.0 - level)
    b = t.size
    ts = np.sort(t)
    t_lo = _order_stat(ts, int(math.floor(alpha * (b + 1))))
    t_hi = _order_stat(ts, int(math.ceil((1.0 - alpha) * (b + 1))))
    q = _order_stat(np.sort(np.abs(t)), int(math.ceil(level * (b + 1))))
    with np.errstate(invalid="ignore", over="ignore"):
        lo = min(theta - t_hi * se, theta - q * se)
        hi = max(theta - t_lo * se, theta + q * se)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(
            f"the runs have too few distinct values for a studentized interval at n = {n} "
            "(too many resamples have no spread); use more runs, or rate_ci for 0/1 outcomes")
    cut = False
    if bounds[0] is not None and lo < bounds[0]:
        lo, cut = bounds[0], True
    if bounds[1] is not None and hi > bounds[1]:
        hi, cut = bounds[1], True
    if cut:
        method += ", range-limited"
    return Estimate(float(theta), min(float(lo), float(theta)), max(float(hi), float(theta)),
                    level, n, method)


def _student_mean(v, level, n_boot, seed, method):
    """Studentized bootstrap interval of the mean of ``v`` (resampling the runs)."""
    n = v.size
    rng = np.random.default_rng(seed)
    m, se = v.mean(), v.std(ddof=1) / math.sqrt(n)
    tol = _REL_TOL * float(np.max(np.abs(v)))
    t = np.empty(n_boot)
    done = 0
    while done < n_boot:
        b = min(_CHUNK, n_boot - done)
        mb, vb = _K.boot_mean_var(v, _draw(rng, n, b))
        sb = np.sqrt(vb)
        sb[sb <= tol] = 0.0  # spread at rounding level is no spread
        with np.errstate(divide="ignore", invalid="ignore"):
            t[done:done + b] = (mb - m) / (sb / math.sqrt(n))
        done += b
    return _studentized(m, se, t, level, n, method, (float(v.min()), float(v.max())))


def _ratio_se(x, y, r, paired):
    """Delta-method standard error of ``mean(x) / mean(y)`` along the last axis."""
    nx, ny = x.shape[-1], y.shape[-1]
    my = y.mean(axis=-1)
    if paired:
        res = x - np.asarray(r)[..., None] * y
        return np.sqrt(np.sum(res * res, axis=-1) / (nx * (nx - 1))) / np.abs(my)
    vx, vy = x.var(axis=-1, ddof=1), y.var(axis=-1, ddof=1)
    return np.sqrt(vx / nx + np.asarray(r) ** 2 * vy / ny) / np.abs(my)


def _student_ratio(x, y, paired, level, n_boot, seed, n, method):
    """Studentized bootstrap interval of ``mean(x) / mean(y)``."""
    rng = np.random.default_rng(seed)
    r = x.mean() / y.mean()
    se = float(_ratio_se(x, y, r, paired))
    t = np.empty(n_boot)
    done = 0
    while done < n_boot:
        b = min(_CHUNK, n_boot - done)
        if paired:
            mx, my, ss = _K.boot_paired_ratio(x, y, _draw(rng, x.size, b))
        else:
            mx, vx = _K.boot_mean_var(x, _draw(rng, x.size, b))
            my, vy = _K.boot_mean_var(y, _draw(rng, y.size, b))
        if np.any(my <= 0):
            raise ValueError(_ZERO_DEN.format(k=int(np.sum(my <= 0)), b=b))
        rb = mx / my
        # the delta-method standard error of _ratio_se, from the kernels' sums
        if paired:
            seb = np.sqrt(ss / (x.size * (x.size - 1))) / np.abs(my)
        else:
            seb = np.sqrt(vx / x.size + rb ** 2 * vy / y.size) / np.abs(my)
        seb[seb <= _REL_TOL * abs(r)] = 0.0  # spread at rounding level is no spread
        with np.errstate(divide="ignore", invalid="ignore"):
            t[done:done + b] = (rb - r) / seb
        done += b
    return _studentized(r, se, t, level, n, method, _ratio_bounds(x, y, paired))


def _ratio_bounds(x, y, paired):
    """The range of ``mean(x) / mean(y)`` over every resample, when ``y > 0`` in every run:
    paired, a weighted mean of the per-run ratios ``x_i / y_i`` (weights ``y_i``); unpaired,
    between the corner ratios of the two samples' ranges.  ``(None, None)`` otherwise."""
    if not np.all(y > 0):
        return (None, None)
    if paired:
        q = x / y
        return (float(q.min()), float(q.max()))
    corners = [a / b for a in (x.min(), x.max()) for b in (y.min(), y.max())]
    return (float(min(corners)), float(max(corners)))


_REL_TOL = 1e-9  # resample spreads below this, relative to the values, are rounding noise

_ZERO_DEN = ("ratio_ci: {k} of {b} resamples have mean(y) <= 0, where the ratio is "
             "undefined (y is zero or negative in too many runs); compare the runs with "
             "paired_diff_ci instead")


def _exact_rate(k, n, level, value, method):
    """Clopper-Pearson interval of ``k`` events in ``n`` runs (coverage >= level for every
    event probability)."""
    alpha = 0.5 * (1.0 - level)
    lo = 0.0 if k == 0 else float(_beta_dist.ppf(alpha, k, n - k + 1))
    hi = 1.0 if k == n else float(_beta_dist.ppf(1.0 - alpha, k + 1, n - k))
    return Estimate(float(value), min(lo, float(value)), max(hi, float(value)), level, n,
                    method)


def _cells(x, y):
    """Counts of paired 0/1 runs: both 1, only x, only y, neither."""
    both = int(np.sum((x == 1) & (y == 1)))
    only_x = int(np.sum((x == 1) & (y == 0)))
    only_y = int(np.sum((x == 0) & (y == 1)))
    return both, only_x, only_y, x.size - both - only_x - only_y


def _newcombe_diff(x, y, level, paired):
    """Newcombe's hybrid score interval of ``mean(x) - mean(y)`` for 0/1 runs (Newcombe,
    Statistics in Medicine 17, 2635-2650, 1998, method 10): Wilson intervals of the two rates combined with the
    correlation of paired runs (0 for independent samples)."""
    z = float(ndtri(0.5 + level / 2))
    nx, ny = x.size, y.size
    kx, ky = int(x.sum()), int(y.sum())
    p1, p2 = kx / nx, ky / ny
    l1, u1 = wilson_interval(kx, nx, z)
    l2, u2 = wilson_interval(ky, ny, z)
    phi = 0.0
    if paired:
        a, b, c, d = _cells(x, y)
        den = math.sqrt(float((a + b) * (c + d) * (a + c) * (b + d)))
        phi = (a * d - b * c) / den if den > 0 else 0.0
    dl = math.sqrt(max((p1 - l1) ** 2 - 2 * phi * (p1 - l1) * (u2 - p2) + (u2 - p2) ** 2, 0.0))
    du = math.sqrt(max((u1 - p1) ** 2 - 2 * phi * (u1 - p1) * (p2 - l2) + (p2 - l2) ** 2, 0.0))
    value = float(x.mean() - y.mean())
    n = nx if paired else nx + ny
    return Estimate(value, min(p1 - p2 - dl, value), max(p1 - p2 + du, value), level, n,
                    "Newcombe score (paired 0/1 runs)" if paired else "Newcombe score (0/1 runs)")


def _adjusted_log_ratio(x, y, level):
    """Interval of ``mean(x) / mean(y)`` for paired 0/1 runs: a Wald interval of the log
    ratio with one pseudo-event added to each rate and two to the discordant count,
    ``(a + b + 1) / (a + c + 1) * exp(+-z sqrt((b + c + 2) / ((a + b + 1)(a + c + 1))))``
    (``a`` runs with both events, ``b`` only x, ``c`` only y)."""
    z = float(ndtri(0.5 + level / 2))
    a, b, c, _ = _cells(x, y)
    r = (a + b + 1) / (a + c + 1)
    s = math.sqrt((b + c + 2) / ((a + b + 1) * (a + c + 1)))
    value = float(x.mean() / y.mean())
    return Estimate(value, min(r * math.exp(-z * s), value), max(r * math.exp(z * s), value),
                    level, x.size, "adjusted log-ratio score (paired 0/1 runs)")


def _need_runs(n, name):
    if n < MIN_RUNS:
        raise ValueError(
            f"{name} has {n} runs; intervals of means of non-0/1 values need at least "
            f"{MIN_RUNS} runs (below that none reaches 93 % coverage on skewed runs); "
            "use more runs, or rate_ci / 0/1 arrays for event outcomes")


def _no_spread(name, v):
    raise ValueError(
        f"{name} is the same ({v:g}) in every run: with no spread there is no interval; "
        "a zero-width interval would claim certainty that the runs do not give")


# --------------------------------------------------------------------------- intervals

_MEMO: OrderedDict = OrderedDict()
_MEMO_SIZE = 1024  # intervals remembered (a few hundred bytes each)


def _memo_key(name, args, kwargs):
    """A key of an interval call: the function, each sample's dtype, shape and a digest of
    its bytes, and the keyword arguments; ``None`` (not remembered) for anything else."""
    parts = [name]
    for a in args:
        arr = np.asarray(a)
        if arr.dtype.kind not in "biuf":
            return None
        digest = hashlib.blake2b(np.ascontiguousarray(arr).tobytes(), digest_size=16)
        parts.append((arr.dtype.str, arr.shape, digest.digest()))
    try:
        parts.append(tuple(sorted(kwargs.items())))
        hash(parts[-1])
    except TypeError:
        return None
    return tuple(parts)


def _memoized(f):
    """Remember the last ``_MEMO_SIZE`` intervals by the content of their samples.  An
    interval is a pure function of the values and the arguments (the resampling seed is one
    of them), so a notebook that asks twice for the same interval gets the same
    :class:`Estimate` without a second bootstrap; a changed array has a new digest, so it
    is never served a stale one.  Errors are not remembered."""
    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        key = _memo_key(f.__name__, args, kwargs)
        if key is None:
            return f(*args, **kwargs)
        hit = _MEMO.get(key)
        if hit is not None:
            _MEMO.move_to_end(key)
            return hit
        est = f(*args, **kwargs)
        _MEMO[key] = est
        if len(_MEMO) > _MEMO_SIZE:
            _MEMO.popitem(last=False)
        return est
    return wrapper

@_memoized
def mean_ci(x, *, level: float = LEVEL, n_boot: int = N_BOOT, seed: int = 0) -> Estimate:
    """Interval of the mean of ``x`` (one value per Monte Carlo run).

    * 0/1 values (events): the exact Clopper-Pearson interval of the rate
      (Clopper and Pearson, Biometrika 26, 404-413, 1934), unless there are ``n >= BCA_RUNS`` runs with at least
      ``MIN_EVENTS`` events and non-events (then BCa);
    * other values: ``n >= MIN_RUNS`` runs are required (ValueError below); the studentized
      bootstrap interval for ``n < BCA_RUNS``, the BCa bootstrap interval from ``BCA_RUNS``
      runs on; values that are all equal have no interval (ValueError).

    Parameters
    ----------
    x : array_like, shape (n,)
        Per-run values, finite.
    level : float
        Confidence level (default 0.95).
    n_boot : int
        Bootstrap resamples (default 10 000, at most ``N_BOOT_MAX``).
    seed : int
        Seed of the resampling stream, fixed so that the interval is reproducible.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import mean_ci
    >>> errors = np.random.default_rng(1).gamma(4.0, 0.025, size=40)   # one value per run
    >>> est = mean_ci(errors)
    >>> f"{est:.3f}"
    '0.090 [0.077, 0.105]'
    >>> est.method
    'studentized bootstrap'
    """
    x = _as_runs(x, "x")
    level, n_boot = _check_level(level), _check_n_boot(n_boot)
    n = x.size
    if _is_binary(x):
        k = int(x.sum())
        if n < BCA_RUNS or min(k, n - k) < MIN_EVENTS:
            return _exact_rate(k, n, level, x.mean(), "Clopper-Pearson exact (0/1 runs)")
    else:
        if np.all(x == x[0]):
            _no_spread("x", x[0])
        _need_runs(n, "x")
    s = _scale(x)
    if s != 1.0:
        e = mean_ci(x / s, level=level, n_boot=n_boot, seed=seed)
        return Estimate(e.value * s, e.lo * s, e.hi * s, level, e.n, e.method)
    if n < BCA_RUNS:
        return _student_mean(x, level, n_boot, seed, "studentized bootstrap")
    (boot,) = _boot_means([x], True, n_boot, seed)
    return _bca(x.mean(), boot, _jack_means(x), level, n, "BCa bootstrap")


@_memoized
def paired_diff_ci(x, y, *, level: float = LEVEL, n_boot: int = N_BOOT,
                   seed: int = 0) -> Estimate:
    """Interval of ``mean(x) - mean(y)`` for paired runs (run ``i`` of ``x`` and of ``y``
    share their seed): the runs are resampled together.

    0/1 runs: Newcombe's paired score interval unless ``n >= BCA_RUNS`` and at least
    ``MIN_EVENTS`` runs differ (then BCa). Other values: ``n >= MIN_RUNS`` runs, the
    studentized bootstrap interval of the mean of ``x - y`` at every ``n`` (BCa fell short
    of 93 % on differences of skewed runs even at 500 runs); a difference that is the same
    in every run is a ValueError, not a zero-width interval.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import paired_diff_ci
    >>> rng = np.random.default_rng(3)
    >>> common = rng.normal(1.0, 0.5, size=50)            # same seeds: shared run-to-run spread
    >>> x, y = common + 0.05 + rng.normal(0, 0.01, 50), common
    >>> f"{paired_diff_ci(x, y):.3f}"
    '0.049 [0.045, 0.051]'
    """
    x, y = _as_runs(x, "x"), _as_runs(y, "y")
    if x.size != y.size:
        raise ValueError(f"paired samples need equal lengths, got x {x.size} and y {y.size}")
    level, n_boot = _check_level(level), _check_n_boot(n_boot)
    n = x.size
    if _is_binary(x, y):
        _, b, c, _ = _cells(x, y)
        if n < BCA_RUNS or b + c < MIN_EVENTS:
            return _newcombe_diff(x, y, level, paired=True)
    s = _scale(x, y)
    if s != 1.0:
        e = paired_diff_ci(x / s, y / s, level=level, n_boot=n_boot, seed=seed)
        return Estimate(e.value * s, e.lo * s, e.hi * s, level, e.n, e.method)
    d = x - y
    if not _is_binary(x, y):
        if np.all(d == d[0]):
            _no_spread("x - y", d[0])
        _need_runs(n, "x")
        return _student_mean(d, level, n_boot, seed, "paired studentized bootstrap")
    (boot,) = _boot_means([d], True, n_boot, seed)
    return _bca(d.mean(), boot, _jack_means(d), level, d.size, "paired BCa bootstrap")


@_memoized
def paired_rate_diff_ci(x, y, *, level: float = LEVEL, n_boot: int = N_BOOT,
                        seed: int = 0) -> Estimate:
    """:func:`paired_diff_ci` of paired 0/1 runs (the difference of two rates), at a cost
    that does not grow with the number of runs.

    Where :func:`paired_diff_ci` takes the paired BCa bootstrap (from ``BCA_RUNS`` runs
    with ``MIN_EVENTS`` discordant runs), it resamples every run: about 3.5 s per interval
    at 40 000 runs.  The per-run difference takes only the values -1, 0 and +1, so a
    resample's mean is fixed by how many of each it draws; a multinomial draw of the three
    counts gives bootstrap means with exactly the same distribution, and the jackknife is
    the same.  The interval therefore agrees with :func:`paired_diff_ci`'s up to bootstrap
    noise (``tests/test_sprt_book.py`` checks it), not digit for digit: a different random
    stream.  With fewer runs or discordant runs it is :func:`paired_diff_ci` itself
    (Newcombe's score interval).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import paired_rate_diff_ci
    >>> x = np.r_[np.ones(900), np.zeros(100)]
    >>> y = np.r_[np.ones(850), np.zeros(150)]
    >>> f"{paired_rate_diff_ci(x, y):+.1%}"
    '+5.0 [+3.8, +6.5] %'
    """
    x, y = _as_runs(x, "x"), _as_runs(y, "y")
    if x.size != y.size:
        raise ValueError(f"paired samples need equal lengths, got x {x.size} and y {y.size}")
    if not _is_binary(x, y):
        raise ValueError("paired_rate_diff_ci needs 0/1 runs in x and y; use paired_diff_ci")
    level, n_boot = _check_level(level), _check_n_boot(n_boot)
    _, b, c, _ = _cells(x, y)
    n = x.size
    if n < BCA_RUNS or b + c < MIN_EVENTS:
        return paired_diff_ci(x, y, level=level, n_boot=n_boot, seed=seed)
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(n, [b / n, c / n, 1.0 - (b + c) / n], size=n_boot)
    boot = (counts[:, 0] - counts[:, 1]) / n
    d = x - y
    return _bca(d.mean(), boot, _jack_means(d), level, n,
                "paired BCa bootstrap (multinomial resampling)")


@_memoized
def diff_ci(x, y, *, level: float = LEVEL, n_boot: int = N_BOOT, seed: int = 0) -> Estimate:
    """Interval of ``mean(x) - mean(y)`` for independent samples (resampled separately),
    BCa bootstrap. Two 0/1 samples that are each all-equal get Newcombe's score interval;
    two other samples that are each all-equal are a ValueError (no zero-width interval).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import diff_ci
    >>> rng = np.random.default_rng(2)
    >>> x, y = rng.normal(1.0, 0.2, size=60), rng.normal(0.8, 0.2, size=50)   # independent runs
    >>> est = diff_ci(x, y)
    >>> f"{est:.3f}"
    '0.225 [0.150, 0.299]'
    >>> est.lo > 0            # x's mean is larger
    True
    """
    x, y = _as_runs(x, "x"), _as_runs(y, "y")
    level, n_boot = _check_level(level), _check_n_boot(n_boot)
    if np.all(x == x[0]) and np.all(y == y[0]):
        if _is_binary(x, y):
            return _newcombe_diff(x, y, level, paired=False)
        _no_spread("each of x and y", x[0] - y[0])
    s = _scale(x, y)
    if s != 1.0:
        e = diff_ci(x / s, y / s, level=level, n_boot=n_boot, seed=seed)
        return Estimate(e.value * s, e.lo * s, e.hi * s, level, e.n, e.method)
    bx, by = _boot_means([x, y], False, n_boot, seed)
    # jackknife over the pooled observations: leave one out of x, then one out of y
    jack = np.concatenate([_jack_means(x) - y.mean(), x.mean() - _jack_means(y)])
    return _bca(x.mean() - y.mean(), bx - by, jack, level, x.size + y.size, "BCa bootstrap")


@_memoized
def ratio_ci(x, y, *, paired: bool = True, level: float = LEVEL, n_boot: int = N_BOOT,
             seed: int = 0) -> Estimate:
    """Interval of ``mean(x) / mean(y)`` (e.g. one filter's RMSE as a fraction of another's).

    ``paired=True`` resamples run ``i`` of both together (same seeds); ``mean(y)`` must be
    positive, and so must every resample's (a ValueError says how many are not).
    Paired 0/1 runs: an adjusted log-ratio score interval unless ``n >= BCA_RUNS`` with at
    least ``MIN_EVENTS`` events, non-events and differing runs (then BCa). Other values:
    ``MIN_RUNS`` runs per sample at least, the studentized bootstrap interval at every
    ``n`` (BCa fell just short of 93 % on ratios of skewed runs at 500 runs).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import ratio_ci
    >>> rng = np.random.default_rng(4)
    >>> y = rng.gamma(4.0, 0.25, size=50)                 # filter B's RMSE per run
    >>> x = 0.8 * y * rng.uniform(0.9, 1.1, size=50)      # filter A's, on the same runs
    >>> f"{ratio_ci(x, y):.3f}"
    '0.808 [0.791, 0.824]'
    """
    x, y = _as_runs(x, "x"), _as_runs(y, "y")
    if paired and x.size != y.size:
        raise ValueError(f"paired samples need equal lengths, got x {x.size} and y {y.size}")
    if not y.mean() > 0:
        raise ValueError("ratio_ci needs mean(y) > 0")
    level, n_boot = _check_level(level), _check_n_boot(n_boot)
    n = x.size if paired else x.size + y.size
    method = "paired BCa bootstrap" if paired else "BCa bootstrap"
    nmin = min(x.size, y.size)
    if paired and _is_binary(x, y):
        a, b, c, _ = _cells(x, y)
        kx, ky = a + b, a + c
        if (nmin < BCA_RUNS or b + c < MIN_EVENTS
                or min(kx, ky, n - kx, n - ky) < MIN_EVENTS):
            return _adjusted_log_ratio(x, y, level)
    else:
        if paired and np.all(x * y.mean() == y * x.mean()):
            _no_spread("x / y", x.mean() / y.mean())
        if not paired and np.all(x == x[0]) and np.all(y == y[0]):
            _no_spread("each of x and y", x[0] / y[0])
        _need_runs(nmin, "x" if x.size <= y.size else "y")
    sx, sy = _scale(x), _scale(y)
    if sx != 1.0 or sy != 1.0:
        e = ratio_ci(x / sx, y / sy, paired=paired, level=level, n_boot=n_boot, seed=seed)
        f = sx / sy
        return Estimate(e.value * f, e.lo * f, e.hi * f, level, e.n, e.method)
    if not (paired and _is_binary(x, y)):
        return _student_ratio(x, y, paired, level, n_boot, seed, n,
                              method.replace("BCa", "studentized"))
    bx, by = _boot_means([x, y], paired, n_boot, seed)
    bad = int(np.sum(by <= 0))
    if bad:
        raise ValueError(_ZERO_DEN.format(k=bad, b=n_boot))
    boot = bx / by
    if paired:
        jack = _jack_means(x) / _jack_means(y)
    else:
        jack = np.concatenate([_jack_means(x) / y.mean(), x.mean() / _jack_means(y)])
    return _bca(x.mean() / y.mean(), boot, jack, level, n, method)


def _leave_one_out_indices(n: int) -> np.ndarray:
    """``(n, n - 1)`` run indices: row ``i`` is ``0..n-1`` without ``i``."""
    j = np.arange(n - 1)[None, :]
    return j + (j >= np.arange(n)[:, None])


def bootstrap_ci(statistic: Callable, *samples, paired: bool = True, level: float = LEVEL,
                 n_boot: int = N_BOOT, seed: int = 0) -> Estimate:
    """BCa interval of any statistic of one or more per-run samples.

    ``statistic(*arrays)`` receives arrays whose **first axis holds resamples**: shape
    ``(b, n)`` for each 1-D sample (or ``(b, n, ...)``), and returns ``(b,)`` values; e.g.
    ``lambda x: np.median(x, axis=1)``. It is also called once on the data with a leading
    axis of length 1 and on the ``n`` leave-one-out samples for the jackknife.
    ``paired=True`` resamples the same run indices in every sample (all the same length).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import bootstrap_ci
    >>> x = np.random.default_rng(5).exponential(1.0, size=80)
    >>> est = bootstrap_ci(lambda b: np.median(b, axis=1), x)
    >>> f"{est:.3f}"
    '0.811 [0.569, 1.041]'
    >>> est.method
    'BCa bootstrap'
    """
    if not callable(statistic):
        raise TypeError("statistic must be callable")
    if not samples:
        raise ValueError("bootstrap_ci needs at least one sample")
    arrs = []
    for i, s in enumerate(samples):
        a = np.asarray(s, dtype=float)
        if a.ndim < 1 or a.shape[0] < 2:
            raise ValueError(f"sample {i} needs at least 2 runs along its first axis")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"sample {i} contains NaN or inf")
        arrs.append(a)
    if paired and len({a.shape[0] for a in arrs}) != 1:
        raise ValueError("paired samples need the same number of runs")
    level, n_boot = _check_level(level), _check_n_boot(n_boot)

    def stat(*xs):
        v = np.asarray(statistic(*xs), float).reshape(-1)
        if v.size != xs[0].shape[0]:
            raise ValueError("statistic must return one value per resample (first axis)")
        return v

    theta = float(stat(*[a[None] for a in arrs])[0])
    rng = np.random.default_rng(seed)
    boot = np.empty(n_boot)
    done = 0
    while done < n_boot:
        b = min(_CHUNK // 4, n_boot - done)
        # np.take gathers whole rows of a multi-column sample several times faster
        # than fancy indexing, with the same values
        if paired:
            idx = rng.integers(0, arrs[0].shape[0], size=(b, arrs[0].shape[0]))
            res = [np.take(a, idx, axis=0) for a in arrs]
        else:
            res = [np.take(a, rng.integers(0, a.shape[0], size=(b, a.shape[0])), axis=0)
                   for a in arrs]
        boot[done:done + b] = stat(*res)
        done += b
    if paired:
        n = arrs[0].shape[0]
        loo = _leave_one_out_indices(n)
        jack = stat(*[np.take(a, loo, axis=0) for a in arrs])
    else:
        parts = []
        for j, a in enumerate(arrs):
            n = a.shape[0]
            loo = np.take(a, _leave_one_out_indices(n), axis=0)
            others = [np.repeat(o[None], n, axis=0) for o in arrs]
            others[j] = loo
            parts.append(stat(*others))
        jack = np.concatenate(parts)
        n = sum(a.shape[0] for a in arrs)
    return _bca(theta, boot, jack, level, n, "BCa bootstrap")


def wilson_interval(k, n, z: float = 1.959963984540054):
    """Wilson score interval for ``k`` successes in ``n`` trials (95 % for the default
    ``z``); element-wise on arrays. Returns ``(lo, hi)``.

    Examples
    --------
    >>> from trackcore.stats import wilson_interval
    >>> lo, hi = wilson_interval(3, 50)
    >>> round(lo, 4), round(hi, 4)
    (0.0206, 0.1622)
    """
    try:
        k = np.asarray(k, float)
        n = np.asarray(n, float)
        z = float(z)
    except (TypeError, ValueError):
        raise TypeError("wilson_interval: k, n and z must be numbers") from None
    if not (np.all(np.isfinite(k)) and np.all(np.isfinite(n)) and math.isfinite(z)):
        raise ValueError("wilson_interval: k, n and z must be finite")
    if np.any(n <= 0) or np.any(k < 0) or np.any(k > n):
        raise ValueError("wilson_interval: need 0 <= k <= n and n > 0")
    if not 0 < z <= 40:
        raise ValueError(f"wilson_interval: z must lie in (0, 40], got {z}")
    p = k / n
    den = 1 + z ** 2 / n
    centre = (p + z ** 2 / (2 * n)) / den
    half = z * np.sqrt(p * (1 - p) / n + z ** 2 / (4 * n ** 2)) / den
    # the exact ends at k = 0 and k = n are 0 and 1 (rounding would leave ~1e-17)
    lo = np.where(k == 0, 0.0, np.maximum(centre - half, 0.0))
    hi = np.where(k == n, 1.0, np.minimum(centre + half, 1.0))
    if lo.ndim == 0:
        return float(lo), float(hi)
    return lo, hi


def rate_ci(k, n, *, level: float = LEVEL) -> Estimate:
    """Wilson interval of the rate ``k / n`` (``k`` events in ``n`` runs) as an
    :class:`Estimate`. ``k`` may also be a boolean array with one entry per run.

    Examples
    --------
    >>> from trackcore.stats import rate_ci
    >>> f"{rate_ci(3, 50):.3f}"        # 3 track losses in 50 runs
    '0.060 [0.021, 0.162]'
    >>> f"{rate_ci(0, 5):.2f}"
    '0.00 [0.00, 0.43]'
    """
    level = _check_level(level)
    if n is None:
        raise TypeError("rate_ci: n is required")
    arr = np.asarray(k)
    if arr.ndim == 1 and arr.dtype == bool:
        if arr.size != n:
            raise ValueError(f"rate_ci: k has {arr.size} runs but n = {n}")
        k = int(arr.sum())
    for name, v in (("k", k), ("n", n)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise TypeError(f"rate_ci: {name} must be a count, got {v!r}")
        if not math.isfinite(v) or float(v) != int(v):
            raise ValueError(f"rate_ci: {name} must be a whole number, got {v!r}")
    z = float(ndtri(0.5 + level / 2))
    lo, hi = wilson_interval(int(k), int(n), z)
    return Estimate(int(k) / int(n), float(lo), float(hi), level, int(n), "Wilson")


def mcnemar_exact(b: int, c: int) -> float:
    """Exact two-sided McNemar test: the p-value of ``b`` runs where only A succeeds
    (or fails) against ``c`` where only B does, under equal odds. Returns 1.0 when
    ``b = c = 0``.

    Examples
    --------
    >>> from trackcore.stats import mcnemar_exact
    >>> round(mcnemar_exact(10, 2), 4)      # A alone succeeded in 10 runs, B alone in 2
    0.0386
    >>> round(mcnemar_exact(5, 5), 4)
    1.0
    """
    for name, v in (("b", b), ("c", c)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise TypeError(f"mcnemar_exact: {name} must be a count, got {v!r}")
        if not math.isfinite(v) or float(v) != int(v) or int(v) < 0:
            raise ValueError(f"mcnemar_exact: {name} must be a non-negative count, got {v!r}")
    b, c = int(b), int(c)
    if b + c == 0:
        return 1.0
    return float(min(1.0, 2.0 * binom.cdf(min(b, c), b + c, 0.5)))


# --------------------------------------------------------------------------- verdicts

def compare(x, y, names=("A", "B"), *, paired: bool = True, kind: str = "difference",
            lower_is_better: bool = True, level: float = LEVEL, n_boot: int = N_BOOT,
            seed: int = 0) -> Comparison:
    """Decide ``A`` against ``B`` on the interval of ``mean(x) - mean(y)``
    (``kind="difference"``) or ``mean(x) / mean(y)`` (``kind="ratio"``).

    The verdict is ``"A < B"`` when the whole interval lies below 0 (below 1 for a
    ratio), ``"A > B"`` when it lies above, and ``"tie"`` otherwise. ``better`` names the
    winner given ``lower_is_better``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.stats import compare
    >>> rng = np.random.default_rng(6)
    >>> base = rng.gamma(4.0, 0.25, size=60)              # per-run RMSE of B (same seeds for A)
    >>> res = compare(0.9 * base, base, names=("IMM", "CV"))
    >>> res.verdict, res.better
    ('IMM < CV', 'IMM')
    >>> f"{res.effect:.3f}"
    '-0.087 [-0.098, -0.076]'
    >>> compare(base + rng.normal(0, 0.05, 60), base, names=("IMM", "CV")).verdict
    'tie'
    """
    if kind not in ("difference", "ratio"):
        raise ValueError(f"kind must be 'difference' or 'ratio', got {kind!r}")
    if len(names) != 2 or not all(isinstance(s, str) for s in names):
        raise TypeError("names must be two strings")
    a, b = names
    if kind == "ratio":
        eff = ratio_ci(x, y, paired=paired, level=level, n_boot=n_boot, seed=seed)
        ref = 1.0
    elif paired:
        eff = paired_diff_ci(x, y, level=level, n_boot=n_boot, seed=seed)
        ref = 0.0
    else:
        eff = diff_ci(x, y, level=level, n_boot=n_boot, seed=seed)
        ref = 0.0
    if not eff.lo < eff.hi:  # no helper returns one; guard the promise anyway
        raise ValueError(f"compare: the interval {eff} has zero width; no verdict")
    if eff.hi < ref:
        verdict, low = f"{a} < {b}", a
    elif eff.lo > ref:
        verdict, low = f"{a} > {b}", b
    else:
        return Comparison(a, b, eff, kind, "tie", None)
    high = b if low == a else a
    return Comparison(a, b, eff, kind, verdict, low if lower_is_better else high)


def band_verdict(est: Estimate, lo: float | None = None, hi: float | None = None) -> str:
    """Decide a target band ``lo <= value <= hi`` (either end may be ``None``) on an
    interval: ``"met"`` when the whole interval lies inside the band, ``"missed"`` when it
    lies wholly outside, ``"undecided"`` when it straddles an end.

    Examples
    --------
    >>> from trackcore.stats import Estimate, band_verdict
    >>> band_verdict(Estimate(0.5, 0.45, 0.55), lo=0.4, hi=0.6)
    'met'
    >>> band_verdict(Estimate(0.5, 0.35, 0.55), lo=0.4, hi=0.6)
    'undecided'
    >>> band_verdict(Estimate(0.8, 0.7, 0.9), hi=0.6)
    'missed'
    """
    if not isinstance(est, Estimate):
        raise TypeError("band_verdict needs an Estimate")
    if lo is None and hi is None:
        raise ValueError("band_verdict needs lo, hi or both")
    lo_ = -math.inf if lo is None else float(lo)
    hi_ = math.inf if hi is None else float(hi)
    if math.isnan(lo_) or math.isnan(hi_) or lo_ > hi_:
        raise ValueError(f"band_verdict: invalid band [{lo}, {hi}]")
    if lo_ <= est.lo and est.hi <= hi_:
        return "met"
    if est.hi < lo_ or est.lo > hi_:
        return "missed"
    return "undecided"
