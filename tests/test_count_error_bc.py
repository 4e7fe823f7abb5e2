"""The jackknife bias-corrected count error e-bc of count_error_ci (kind="e-bc")."""
import numpy as np
import pytest

from trackcore.scenarios import count_error_ci
from trackcore.scenarios.hpda_scenario import _e_bc
from trackcore.stats import MIN_RUNS


def _direct(D):
    """R e - (R - 1) * mean of the leave-one-run-out e, written out run by run."""
    R = D.shape[0]
    e = np.abs(D.mean(axis=0)).mean()
    loo = [np.abs(np.delete(D, i, axis=0).mean(axis=0)).mean() for i in range(R)]
    return R * e - (R - 1) * np.mean(loo)


def test_e_bc_matches_the_jackknife_written_out():
    rng = np.random.default_rng(3)
    D = rng.integers(-2, 3, size=(12, 25)).astype(float)
    got = _e_bc(np.ones((1, 12)), D)[0]
    assert got == pytest.approx(_direct(D), abs=1e-12), "e-bc differs from its definition"


def test_e_bc_of_a_resample_with_repeated_runs():
    rng = np.random.default_rng(4)
    D = rng.normal(size=(6, 10))
    idx = np.array([0, 0, 3, 5, 5, 5])
    W = np.bincount(idx, minlength=6)[None].astype(float)
    got = _e_bc(W, D)[0]
    assert got == pytest.approx(_direct(D[idx]), abs=1e-12), (
        "weights of repeated runs must act as the repeated sample"
    )


def test_the_correction_removes_a_known_noise_bias():
    """Runs whose mean count misses the truth by delta_k, a known spread of values, plus
    unit noise per run: e is biased upward by the noise, e-bc is not (to the accuracy of
    200 repetitions of 100 runs)."""
    rng = np.random.default_rng(20070828)
    delta = np.linspace(-0.3, 0.3, 200)
    true_e = np.abs(delta).mean()
    e, ebc = [], []
    for _ in range(200):
        D = delta + rng.normal(size=(100, delta.size))
        e.append(np.abs(D.mean(axis=0)).mean())
        ebc.append(_e_bc(np.ones((1, 100)), D)[0])
    bias_e, bias_bc = np.mean(e) - true_e, np.mean(ebc) - true_e
    assert bias_e > 0.012, f"the synthetic case should bias e upward, got {bias_e:.4f}"
    assert abs(bias_bc) < 0.003, f"e-bc keeps a bias of {bias_bc:.4f}"


def test_count_error_ci_e_bc_interval():
    rng = np.random.default_rng(5)
    n_true = np.r_[np.zeros(10), np.ones(20), 2 * np.ones(10)]
    a = n_true + rng.integers(0, 2, size=(MIN_RUNS, n_true.size))
    b = n_true + rng.integers(-2, 1, size=(MIN_RUNS, n_true.size))
    est = count_error_ci(a, n_true, kind="e-bc")
    assert est.value == pytest.approx(_e_bc(np.ones((1, MIN_RUNS)), a - n_true)[0]), (
        "the estimate must be e-bc of the runs given"
    )
    assert est.lo <= est.value <= est.hi, "the interval must contain the estimate"
    assert est.value < count_error_ci(a, n_true).value, "the correction lowers e here"
    d = count_error_ci(a, n_true, kind="e-bc", versus=b)
    eb = count_error_ci(b, n_true, kind="e-bc")
    assert d.value == pytest.approx(est.value - eb.value), "paired value: a difference"
    u = count_error_ci(a, n_true, kind="e-bc", versus=b, paired=False)
    assert u.value == pytest.approx(d.value), "same value, independent resampling"


def test_count_error_ci_e_bc_refuses_few_runs_and_bad_kind():
    n_true = np.ones(5)
    few = np.ones((MIN_RUNS - 1, 5))
    with pytest.raises(ValueError, match="count_error_ci needs at least 40"):
        count_error_ci(few, n_true, kind="e-bc")
    with pytest.raises(ValueError, match="kind"):
        count_error_ci(np.ones((MIN_RUNS, 5)), n_true, kind="ebc")


def test_count_error_ci_e_bc_gives_no_widened_interval():
    """Runs centred on the truth leave e-bc outside the central 95 % of its bootstrap
    distribution (the jackknife does not remove the bias at |0|): no interval, no widening."""
    rng = np.random.default_rng(5)
    n_true = np.r_[np.zeros(10), np.ones(20), 2 * np.ones(10)]
    a = n_true + rng.integers(-1, 2, size=(MIN_RUNS, n_true.size))
    with pytest.raises(ValueError, match="bootstrap distribution"):
        count_error_ci(a, n_true, kind="e-bc")


@pytest.mark.parametrize("seed", range(6))
def test_integer_kernel_gives_the_float_kernels_bits(seed):
    from trackcore.scenarios.hpda_scenario import (
        _exact_in_integers, _loo_e_mean, _loo_e_mean_int)

    rng = np.random.default_rng(seed)
    n, K, b = int(rng.integers(2, 120)), int(rng.integers(1, 400)), 64
    D = rng.integers(-3, 4, size=(n, K)).astype(float)
    W = np.stack([np.bincount(rng.integers(0, n, n), minlength=n) for _ in range(b)])
    W = W.astype(float)
    S = W @ D
    assert _exact_in_integers(D, W), "small integer counts are exact"
    fast = _loo_e_mean_int(W.astype(np.int64), S.astype(np.int64), D.astype(np.int64))
    assert np.array_equal(fast, _loo_e_mean(W, S, D)), "integer and float kernels differ"


def test_non_integer_or_huge_counts_take_the_float_kernel():
    from trackcore.scenarios.hpda_scenario import _exact_in_integers

    W = np.ones((3, 4))
    assert not _exact_in_integers(np.full((4, 5), 0.5), W), "Σw counts are not integers"
    assert not _exact_in_integers(np.full((4, 5), 2.0**50), W), "sums would not be exact"
    assert not _exact_in_integers(np.full((4, 5), np.nan), W), "NaN is not an integer"
