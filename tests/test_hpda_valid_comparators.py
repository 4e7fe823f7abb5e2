"""The valid distance-only existence updates (nearest neighbour with its own
likelihood, IPDA), HPDA-PF's selection rules that use them, and their experiments."""
import math

import numpy as np
import pytest

from trackcore.association import existence_update, hpda_existence_delta
from trackcore.association.existence import ipda_existence_delta, nn_existence_delta
from trackcore.experiments.hpda_comparators import HpdaComparatorConfig
from trackcore.trackers import HpdaPfConfig, hpda_pf_run
from trackcore.trackers.hpda_pf import clutter_likelihood_ratios

Z999 = 3.29  # two-sided 99.9 % normal quantile: a fixed-seed check that fails rarely


def _mean_and_se(selection, clutter_mean, snr, n=40_000, seed=7):
    x = clutter_likelihood_ratios(selection, clutter_mean, snr, 0.9, 0.99, n,
                                  np.random.default_rng(seed))
    return x.mean(), x.std(ddof=1) / math.sqrt(n)


@pytest.mark.parametrize("selection", ["nn-likelihood", "ipda"])
@pytest.mark.parametrize("clutter_mean", [0.3, 1.0, 2.0])
def test_valid_rules_have_mean_ratio_one_on_clutter(selection, clutter_mean):
    mean, se = _mean_and_se(selection, clutter_mean, 3.0)
    assert abs(mean - 1.0) < Z999 * se, (selection, clutter_mean, mean, se)


def test_eq19_at_the_nearest_rank_is_biased_on_clutter():
    mean, se = _mean_and_se("nearest", 1.0, 10.0)
    assert mean - 1.0 > Z999 * se, (mean, se)
    assert 1.10 < mean < 1.25, mean  # about 1.16 at lambda V_G = 1


def test_ipda_hand_computed_and_hpda_single_return():
    # delta = P_D P_G - P_D sum N / lambda = 0.891 - 0.9 * 0.15 / 2 = 0.8235
    d = ipda_existence_delta([0.1, 0.05], 0.9, 0.99, 2.0)
    assert d == pytest.approx(0.8235, abs=1e-12)
    # (1 - delta) p / (1 - delta p) at p = 0.5: 0.08825 / 0.58825
    assert existence_update(0.5, d) == pytest.approx(0.08825 / 0.58825, rel=1e-12)
    assert ipda_existence_delta([], 0.9, 0.99, 2.0) == pytest.approx(0.891)
    # one return: IPDA's update is eq (19)'s (q = 1)
    one = ipda_existence_delta([0.07], 0.9, 0.99, 2.0)
    tau = -(1 + 10.0) * math.log(0.9)
    assert one == pytest.approx(hpda_existence_delta(1, 1, 0.07, 10.0, tau, 0.99, 2.0, 3.0))


def test_nn_hand_computed():
    # L = 1 - 0.9 (1 - exp(-1/2)) + 0.9 * 0.05 / 2
    want = 1.0 - (1.0 - 0.9 * (1.0 - math.exp(-0.5)) + 0.0225)
    assert nn_existence_delta(2, 1.0, 0.05, 0.9, 0.99, 2.0) == pytest.approx(want, 1e-12)
    assert nn_existence_delta(0, 0.0, 0.0, 0.9, 0.99, 2.0) == pytest.approx(0.891)


@pytest.mark.parametrize("call, name", [
    (lambda: nn_existence_delta(-1, 1.0, 0.05, 0.9, 0.99, 2.0), "m"),
    (lambda: nn_existence_delta(1, -1.0, 0.05, 0.9, 0.99, 2.0), "d2"),
    (lambda: nn_existence_delta(1, 1.0, 0.05, 1.5, 0.99, 2.0), "pd"),
    (lambda: nn_existence_delta(1, 1.0, 0.05, 0.9, 0.99, 0.0), "clutter_density"),
    (lambda: ipda_existence_delta([0.1, -0.1], 0.9, 0.99, 2.0), "normal_densities"),
    (lambda: ipda_existence_delta([[0.1]], 0.9, 0.99, 2.0), "normal_densities"),
    (lambda: ipda_existence_delta([0.1], 0.9, 1.2, 2.0), "pg"),
    (lambda: clutter_likelihood_ratios("far", 1.0, 3.0, 0.9, 0.99, 10, 1), "selection"),
    (lambda: clutter_likelihood_ratios("ipda", -1.0, 3.0, 0.9, 0.99, 10, 1),
     "clutter_mean"),
    (lambda: clutter_likelihood_ratios("ipda", 1.0, 3.0, 0.9, 0.99, 1.5, 1), "n_draws"),
    (lambda: HpdaPfConfig(0.9, 10.0, 3e-8, selection="far"), "selection"),
    (lambda: HpdaComparatorConfig(1.5), "pi11"),
    (lambda: HpdaComparatorConfig(0.99, comparators=("sn",)), "comparators"),
    (lambda: HpdaComparatorConfig(0.99, rhos=(3.0, -1.0)), "rhos"),
])
def test_bad_input_names_the_argument(call, name):
    with pytest.raises((ValueError, TypeError), match=name):
        call()


@pytest.mark.parametrize("selection", ["nn-likelihood", "ipda"])
def test_tracker_runs_with_the_valid_rules(selection):
    from trackcore.scenarios import hpda_parameters, hpda_truth, simulate_hpda_scans
    p = hpda_parameters(3)
    truth = hpda_truth("B", n_scans=40)
    s = simulate_hpda_scans(truth, p, np.random.default_rng(3))
    cfg = HpdaPfConfig(pd=p.pd, snr=p.snr, clutter_density_xy=p.clutter_density_xy,
                       sigma_r=p.sigma_r, sigma_theta=p.sigma_theta, n_particles=100,
                       selection=selection)
    a = hpda_pf_run(s.z, s.amplitude, s.offsets, cfg, np.random.default_rng(1))
    b = hpda_pf_run(s.z, s.amplitude, s.offsets, cfg, np.random.default_rng(1))
    assert np.array_equal(a.count, b.count), "a seeded run must repeat"
    assert a.count.shape == (40,) and a.count.min() >= 0, a.count
    assert np.all(a.aux >= 0), "the tentative-track count must be non-negative"
