"""Marcum Q1 by regime: accuracy against a 60-digit reference on both sides of every
switch between algorithms, the far tails of Q1 and 1 - Q1, bounded cost for every finite
input, and the exact limits.

Reference: Python's ``decimal`` at 60 digits, evaluating at the exact double inputs the
defining double sums of Poisson probabilities (``Q1 = P(M <= J)``, ``1 - Q1 = P(J < M)``
with ``J ~ Poisson(a^2/2)``, ``M ~ Poisson(b^2/2)``), each summed over the outer index
until the terms are below 1e-45 of the sum and past both modes.  The kernels never use
these double sums: the series regime uses single sums rearranged from them and the
large-``xi`` regime an asymptotic expansion in erfc and incomplete gamma functions.
"""
from __future__ import annotations

import math
import time
from decimal import Decimal, localcontext

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trackcore.detection import (
    log_marcum_detection_probability,
    log_marcum_miss_probability,
    log_marcum_q1,
    log_marcum_q1_complement,
    marcum_detection_probability,
    marcum_miss_probability,
    marcum_q1,
    marcum_q1_complement,
)
from trackcore.detection.marcum import (
    XI_ASYMPTOTIC,
    Z_FORWARD,
    log_marcum_detection_probability_scalar_kernel,
    log_marcum_q1_pair_kernel,
)

TOL = 1e-12          # relative accuracy promised where the value is a normal double


def reference(a: float, b: float, digits: int = 60):
    """(Q1, 1 - Q1) at the exact doubles ``a, b`` as Decimals (see the module notes)."""
    with localcontext() as ctx:
        ctx.prec = digits
        x = Decimal(a) * Decimal(a) / 2
        y = Decimal(b) * Decimal(b) / 2
        tiny = Decimal(10) ** -45

        def poisson_terms(lam):
            """Yield p_lam(n), n = 0, 1, ... (exact recurrence)."""
            p = (-lam).exp()
            n = 0
            while True:
                yield p
                n += 1
                p = p * lam / n

        # Q1 = sum_n p_x(n) P(M <= n)
        q = Decimal(0)
        cdf_y = Decimal(0)
        py = poisson_terms(y)
        px = poisson_terms(x)
        n = 0
        while True:
            cdf_y += next(py)
            t = next(px) * cdf_y
            q += t
            if n > x and n > y and t <= tiny * q:
                break
            n += 1
        # 1 - Q1 = sum_{k>=1} p_y(k) P(J <= k - 1)
        p = Decimal(0)
        cdf_x = Decimal(0)
        py = poisson_terms(y)
        px = poisson_terms(x)
        next(py)
        k = 1
        while True:
            cdf_x += next(px)
            t = next(py) * cdf_x
            p += t
            if k > x and k > y and (t <= tiny * p or p == 0):
                break
            k += 1
        return q, p


def _rel(value, ref):
    ref = float(ref)
    return abs(value / ref - 1.0)


def _check(a, b, tol=TOL):
    """Q1, 1 - Q1 and both logs against the reference at (a, b)."""
    q, p = reference(a, b)
    for got_log, got, ref in ((log_marcum_q1(a, b), marcum_q1(a, b), q),
                              (log_marcum_q1_complement(a, b), marcum_q1_complement(a, b), p)):
        lref = float(ref.ln()) if ref > 0 else -math.inf
        if ref > Decimal("1e-300"):
            assert _rel(got, ref) < tol, (a, b, got, ref)
        assert abs(got_log - lref) <= tol * max(1.0, abs(lref)), (a, b, got_log, lref)


# ----------------------------------------------------------------------------- book regime
@pytest.mark.parametrize("pfa", [1e-2, 1e-4, 1e-6, 1e-8])
def test_book_regime_snr_minus5_to_40db(pfa):
    """P_D, 1 - P_D and their logs at SNR -5..40 dB (1 dB steps) within 1e-12 relative,
    the far tails included (at 40 dB ``1 - P_D`` is about e^-9000: log form)."""
    for db in np.arange(-5.0, 40.01, 1.0):
        snr = 10.0 ** (db / 10.0)
        a, b = math.sqrt(2.0 * snr), math.sqrt(-2.0 * math.log(pfa))
        q, p = reference(a, b)
        pd = marcum_detection_probability(snr, pfa)
        pm = marcum_miss_probability(snr, pfa)
        lpd = log_marcum_detection_probability(snr, pfa)
        lpm = log_marcum_miss_probability(snr, pfa)
        # the snr interface rounds a and b once more: allow the conditioning of Q1
        tol = TOL + 4e-16 * b * abs(b - a) + 4e-16 * a * abs(b - a)
        for got, got_log, ref in ((pd, lpd, q), (pm, lpm, p)):
            lref = float(ref.ln())
            if ref > Decimal("1e-300"):
                assert _rel(got, ref) < tol, (db, pfa, got, ref)
            assert abs(got_log - lref) <= tol * max(1.0, abs(lref)), (db, pfa, got_log, lref)
        assert log_marcum_detection_probability_scalar_kernel(snr, math.log(pfa)) == lpd


# ----------------------------------------------------------------------------- regimes
BOUNDARY_RATIOS = [0.05, 0.5, 0.97, 1.0, 1.03, 2.0, 20.0]


@pytest.mark.parametrize("ratio", BOUNDARY_RATIOS)
@pytest.mark.parametrize("side", [1.0 - 1e-9, 1.0 + 1e-9])
def test_series_asymptotic_switch_xi_40(ratio, side):
    """Just below xi = a b = 40 (series) and just above (asymptotic expansion)."""
    xi = XI_ASYMPTOTIC * side
    a = math.sqrt(xi / ratio)
    b = ratio * a
    _check(a, b)


@pytest.mark.parametrize("side", [-1e-7, 1e-7])
@pytest.mark.parametrize("x", [0.0, 0.3, 2.0, 10.0, 17.0])
def test_series_side_switch_y_equals_x_plus_1(x, side):
    """The series computes Q1 for y > x + 1 and 1 - Q1 otherwise (x = a^2/2, y = b^2/2)."""
    a = math.sqrt(2.0 * x)
    b = math.sqrt(2.0 * (x + 1.0 + side))
    _check(a, b)


@pytest.mark.parametrize("side", [1.0 - 1e-9, 1.0 + 1e-9])
@pytest.mark.parametrize("b", [0.01, 0.3, 1.0, 1.5, 1.99])
def test_complement_series_switch_x_equals_1(b, side):
    """The 1 - Q1 series (y <= x + 1, xi < 40) sums ``y^{k-1}/k! e_{k-1}`` for x < 1 and
    the rearranged ``(xy)^{k-1}/(k!(k-1)!) f_{k-1}`` for x >= 1: both sides of x = 1."""
    a = math.sqrt(2.0 * side)
    assert 0.5 * b * b <= 0.5 * a * a + 1.0 and a * b < XI_ASYMPTOTIC
    _check(a, b)


@pytest.mark.parametrize("factor", [0.5, 0.99, 1.01, 2.0])
def test_underflowing_leading_factor_of_the_asymptotic_expansion(factor):
    """Where the leading factor ``sqrt(b/a)/2 erfcx(t)`` of the expansion falls below
    1e-290 (only for ``z = (b - a)^2/2`` near 1e305: here a = 1e153, b near 6.3e-121) the
    kernel forms its logarithm from logs instead.  On both sides of that switch
    ``log(1 - Q1)`` is finite and equals the leading asymptotics ``-z + log(sqrt(b/a)/2
    erfcx(t))`` (relative 1e-15, which at this size is ``-z`` to the last digit), and the
    values underflow to 0 and 1 as they should."""
    from scipy.special import erfcx

    a = 1e153
    b = 6.3e-121 * factor
    t = (a - b) / math.sqrt(2.0)
    lead = 0.5 * math.sqrt(b / a) * erfcx(t)
    assert (lead > 1e-290) == (factor > 1.0)
    z = t * t
    expected = -z + 0.5 * (math.log(b) - math.log(a)) + math.log(0.5 * erfcx(t))
    got = log_marcum_q1_complement(a, b)
    assert math.isfinite(got) and got == pytest.approx(expected, rel=1e-15)
    lq, lp = log_marcum_q1_pair_kernel(a, b)
    assert lp == got and lq == 0.0
    assert marcum_q1_complement(a, b) == 0.0 and marcum_q1(a, b) == 1.0


@pytest.mark.parametrize("sign", [-1.0, 1.0])
@pytest.mark.parametrize("side", [1.0 - 1e-9, 1.0 + 1e-9])
@pytest.mark.parametrize("a", [8.0, 20.0, 60.0])
def test_forward_backward_recurrence_switch_z_30(a, side, sign):
    """H_n by forward recurrence for z = (b - a)^2/2 <= 30, backward above."""
    b = a + sign * math.sqrt(2.0 * Z_FORWARD * side)
    _check(a, b)


@pytest.mark.parametrize("side", [1.0 - 1e-9, 1.0 + 1e-9])
@pytest.mark.parametrize("a", [2.0, 12.0])
def test_erfcx_switch_t_25(a, side):
    """erfcx(t) from exp(t^2) erfc(t) below t = |b - a|/sqrt 2 = 25, asymptotic above."""
    b = a + 25.0 * math.sqrt(2.0) * side
    _check(a, b)


@pytest.mark.parametrize("a, b", [(0.5, 3.0), (2.0, 5.26), (4.0, 3.0), (14.1, 5.26), (25.0, 6.07),
                                  (1.0, 0.2), (8.0, 1.0), (6.3, 6.35), (6.35, 6.3), (80.0, 0.5),
                                  (0.5, 80.0), (141.4, 5.26), (141.4, 150.0), (100.0, 101.0),
                                  (1000.0, 1000.0), (9.0, 4.5), (4.5, 9.0), (0.01, 3.0),
                                  (3.0, 0.01), (1e-3, 1e-3), (0.2, 0.01)])
def test_scattered_points(a, b):
    _check(a, b)


def test_random_points_against_reference():
    """200 log-uniform points, a and b in [1e-3, 200], half of them with b near a."""
    rng = np.random.default_rng(20261124)
    for i in range(200):
        a = float(10 ** rng.uniform(-3, 2.3))
        b = float(a * (1 + rng.normal(0, 0.05))) if i % 2 else float(10 ** rng.uniform(-3, 2.3))
        # the function's own conditioning (relative change ~ e b |b - a| for input error e)
        _check(a, b, tol=TOL + 4e-16 * (a + b) * abs(b - a))


# ----------------------------------------------------------------------------- far tails
def test_far_tails_exact():
    # Q1(2, 40) = 1.2928564846e-315 (a subnormal double); scipy's ncx2.sf returns 0
    q, _ = reference(2.0, 40.0)
    assert marcum_q1(2.0, 40.0) == pytest.approx(float(q), rel=1e-8)   # subnormal spacing
    assert log_marcum_q1(2.0, 40.0) == pytest.approx(float(q.ln()), rel=1e-14)
    _, p = reference(40.0, 2.0)
    assert log_marcum_q1_complement(40.0, 2.0) == pytest.approx(float(p.ln()), rel=1e-14)
    # 1 - P_D at 20 dB, P_fa = 1e-6, where 1 - marcum_detection_probability is 0.0
    _, p = reference(math.sqrt(200.0), math.sqrt(-2.0 * math.log(1e-6)))
    assert marcum_miss_probability(100.0, 1e-6) == pytest.approx(float(p), rel=1e-12)
    # both logs at once
    lq, lp = log_marcum_q1_pair_kernel(14.1, 5.26)
    q, p = reference(14.1, 5.26)
    assert lq == pytest.approx(float(q.ln()), rel=1e-12, abs=1e-300)
    assert lp == pytest.approx(float(p.ln()), rel=1e-13)


# ----------------------------------------------------------------------------- no hang
def _best_time(fn, *args, repeat=5):
    fn(*args)
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best


@pytest.mark.parametrize("fn", [marcum_q1, marcum_q1_complement, log_marcum_q1,
                                log_marcum_q1_complement])
def test_huge_arguments_answer_within_a_millisecond(fn):
    for a, b in [(1e300, 1.0), (3e4, 1.0), (1.0, 3e4), (1e300, 1e300), (1e-300, 1e300),
                 (1e150, 1e-148), (0.0, 1e300), (1e300, 0.0)]:
        assert _best_time(fn, a, b) < 1e-3, (fn.__name__, a, b)
    assert marcum_q1(1e300, 1.0) == 1.0
    assert marcum_q1(3e4, 1.0) == 1.0
    assert marcum_q1_complement(3e4, 1.0) == 0.0
    assert marcum_q1(1.0, 3e4) == 0.0
    assert marcum_q1(1e300, 1e300) == 0.5


@pytest.mark.parametrize("fn", [marcum_detection_probability, marcum_miss_probability,
                                log_marcum_detection_probability, log_marcum_miss_probability])
def test_detection_probability_at_huge_snr(fn):
    for snr in (1e300, 1e30, 1e8):
        assert _best_time(fn, snr, 1e-6) < 1e-3
    assert marcum_detection_probability(1e300, 1e-6) == 1.0
    assert log_marcum_miss_probability(1e300, 1e-6) < -1e299


def test_log_of_huge_tail_matches_leading_asymptotics():
    """For z = (a - b)^2/2 huge, log(1 - Q1) = -z + log(sqrt(b/a) / (2 t sqrt(pi))) + O(1/ab)."""
    a, b = 3e4, 1.0
    t = (a - b) / math.sqrt(2.0)
    lead = -t * t + math.log(math.sqrt(b / a) / (2.0 * t * math.sqrt(math.pi)))
    assert log_marcum_q1_complement(a, b) == pytest.approx(lead, rel=1e-12)


def test_whole_grid_bounded_finite_and_monotone():
    """Every (a, b) on a 300 x 300 log grid from 1e-300 to 1e300 (and 0): finite logs,
    probabilities in [0, 1], Q1 + (1 - Q1) = 1, Q1 non-decreasing in a and non-increasing
    in b along the grid lines, all within a bounded time."""
    g = np.concatenate([[0.0], np.geomspace(1e-300, 1e300, 150), np.geomspace(1e-3, 1e3, 150)])
    g = np.unique(g)
    A, B = np.meshgrid(g, g, indexing="ij")
    for fn in (marcum_q1, marcum_q1_complement, log_marcum_q1):
        fn(np.ones(2), 1.0)                  # load the compiled kernels before timing
    t0 = time.process_time()
    q = marcum_q1(A, B)
    p = marcum_q1_complement(A, B)
    lq = log_marcum_q1(A, B)
    elapsed = time.process_time() - t0
    assert elapsed < 2.0                      # about 0.05 s: at most 1 us per element here
    assert np.all((q >= 0) & (q <= 1) & (p >= 0) & (p <= 1))
    assert not np.any(np.isnan(lq)) and np.all(lq <= 0)
    np.testing.assert_allclose(q + p, 1.0, atol=2e-16)
    assert np.all(np.diff(q, axis=0) >= -1e-15 * q[1:])
    assert np.all(np.diff(q, axis=1) <= 1e-15 * q[:, :-1])


def test_non_finite_input_is_rejected():
    for fn in (marcum_q1, marcum_q1_complement, log_marcum_q1, log_marcum_q1_complement):
        for bad in (np.inf, np.nan, -np.inf):
            with pytest.raises(ValueError, match="a must"):
                fn(bad, 1.0)
            with pytest.raises(ValueError, match="b must"):
                fn(1.0, bad)
            with pytest.raises(ValueError, match="a must"):
                fn(np.array([1.0, bad]), 1.0)
    for fn in (marcum_detection_probability, marcum_miss_probability,
               log_marcum_detection_probability, log_marcum_miss_probability):
        for bad in (np.inf, np.nan):
            with pytest.raises(ValueError, match="snr"):
                fn(bad, 1e-6)
            with pytest.raises(ValueError, match="pfa"):
                fn(1.0, bad)


def test_scalar_fast_path_equals_array_path():
    rng = np.random.default_rng(5)
    a = 10 ** rng.uniform(-3, 3, 200)
    b = 10 ** rng.uniform(-3, 3, 200)
    for fn in (marcum_q1, marcum_q1_complement, log_marcum_q1, log_marcum_q1_complement):
        arr = fn(a, b)
        assert all(fn(float(x), float(y)) == v for x, y, v in zip(a, b, arr))
    snr = 10 ** rng.uniform(-1, 4, 100)
    for fn in (marcum_detection_probability, marcum_miss_probability,
               log_marcum_detection_probability, log_marcum_miss_probability):
        arr = fn(snr, 1e-6)
        assert all(fn(float(s), 1e-6) == v for s, v in zip(snr, arr))
        assert isinstance(fn(3, 1e-6), float)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 1e6), st.floats(0.0, 1e6))
def test_property_wide_range_consistent(a, b):
    q = marcum_q1(a, b)
    p = marcum_q1_complement(a, b)
    assert 0.0 <= q <= 1.0 and 0.0 <= p <= 1.0
    assert q + p == pytest.approx(1.0, abs=2e-16)
    lq, lp = log_marcum_q1(a, b), log_marcum_q1_complement(a, b)
    assert not math.isnan(lq) and not math.isnan(lp)
    if q > 1e-300:
        assert lq == pytest.approx(math.log(q), rel=1e-13, abs=1e-15)
    if p > 1e-300:
        assert lp == pytest.approx(math.log(p), rel=1e-13, abs=1e-15)
