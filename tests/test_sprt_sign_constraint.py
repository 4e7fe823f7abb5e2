"""The sign constraint of the SPRT chapter's decoy filters (``beta_min``: the inverse range
of the modified-polar EKF truncated from below)."""
import math

import numpy as np
import pytest

from trackcore.scenarios import sprt_acm_measurements, sprt_acm_scenario, sprt_acm_truth
from trackcore.trackers import SprtAcmFilterConfig, sprt_acm_discriminate


@pytest.fixture(scope="module")
def batch():
    sc = sprt_acm_scenario(2)
    truth = sprt_acm_truth(sc)
    rng = np.random.default_rng(11)
    zs = [sprt_acm_measurements(sc, rng, truth) for _ in range(30)]
    z_pre, z_a, z_b = (np.stack([getattr(z, f) for z in zs]) for f in ("z_pre", "z_a", "z_b"))
    return sc, truth, z_pre, z_a, z_b


def _run(batch, **changes):
    sc, truth, z_pre, z_a, z_b = batch
    return sprt_acm_discriminate(z_pre, z_a, z_b, truth.own, sc.T,
                                 SprtAcmFilterConfig(**changes))


def test_none_is_the_paper(batch):
    free, default = _run(batch, beta_min=None), _run(batch)
    np.testing.assert_array_equal(free.lam, default.lam)


def test_constraint_binds_and_holds(batch):
    free = _run(batch)
    bound = 1 / 20000.0
    assert np.nanmin(free.beta) < 0, "S2's decoy filters turn their 1/r negative unconstrained"
    held = _run(batch, beta_min=bound)
    assert held.ok.all(), "the constrained filters stay positive definite"
    assert np.nanmin(held.beta) >= bound, "1/r never below the bound"
    assert not np.allclose(held.llr, free.llr), "the constraint changes Lambda"
    # the target filters are untouched by a constraint on the decoy filters
    np.testing.assert_array_equal(held.lam[..., [0, 3]], free.lam[..., [0, 3]])


def test_inactive_bound_changes_nothing(batch):
    free = _run(batch)
    held = _run(batch, beta_min=1e-300)
    # a decoy filter (b0: beta column 0, Lambda column 1; a1: 1 and 2) whose 1/r never
    # falls below the bound runs exactly as the free one
    kept = 0
    for b_col, l_col in ((0, 1), (1, 2)):
        keep = np.nanmin(free.beta[..., b_col], axis=1) >= 1e-300
        kept += keep.sum()
        np.testing.assert_array_equal(held.lam[keep, :, l_col], free.lam[keep, :, l_col])
    assert kept > 0, "some decoy filter keeps its 1/r positive in some run"


@pytest.mark.parametrize("bad", [0.0, -1e-4, math.nan, math.inf])
def test_bad_bound(bad):
    with pytest.raises(ValueError, match="beta_min"):
        SprtAcmFilterConfig(beta_min=bad)


def test_bad_bound_type():
    with pytest.raises(TypeError, match="beta_min"):
        SprtAcmFilterConfig(beta_min=True)
