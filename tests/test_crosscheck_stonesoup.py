"""Cross-check trackcore's OSPA/GOSPA against Stone Soup 1.9.1 on random point sets.

Stone Soup conventions (stonesoup/metricgenerator/ospametric.py):
* ``GOSPAMetric.compute_gospa_metric(measured, truth)`` has ``alpha = 2`` fixed;
  ``distance`` is the p-th root, while ``localisation``, ``missed`` and
  ``false`` are reported as p-th powers (``distance**p`` is their sum).  This
  is exactly the convention of :func:`trackcore.metrics.gospa`.
* ``OSPAMetric.compute_OSPA_distance(tracks, truths)`` finds its assignment by
  minimising the sum of the cut-off distances, not of their p-th powers.  For
  ``p = 1`` that is the OSPA definition and the values agree to rounding; for
  ``p > 1`` Stone Soup's value can exceed the OSPA minimum, which trackcore
  computes exactly, so there we check ``ours <= stonesoup`` and equality to
  Stone Soup when given Stone Soup's own assignment objective.
"""
import datetime

import numpy as np
import pytest

stonesoup = pytest.importorskip("stonesoup")
from scipy.optimize import linear_sum_assignment  # noqa: E402
from stonesoup.measures import Euclidean  # noqa: E402
from stonesoup.metricgenerator.ospametric import GOSPAMetric, OSPAMetric  # noqa: E402
from stonesoup.types.state import State  # noqa: E402

from trackcore.metrics import gospa, ospa  # noqa: E402

T0 = datetime.datetime(2026, 11, 23)


def _states(points):
    return [State(np.asarray(x, float).reshape(-1, 1), timestamp=T0) for x in points]


def _random_sets(rng, n_pairs, d=2, max_size=7):
    for _ in range(n_pairs):
        X = rng.uniform(0.0, 10.0, (rng.integers(0, max_size + 1), d))
        Y = rng.uniform(0.0, 10.0, (rng.integers(0, max_size + 1), d))
        if len(X) + len(Y):            # Stone Soup needs a timestamp from some state
            yield X, Y


@pytest.mark.parametrize("p", [1, 2, 3])
@pytest.mark.parametrize("c", [2.0, 5.0])
def test_gospa_equals_stonesoup(p, c):
    rng = np.random.default_rng(100 + 10 * p + int(c))
    metric = GOSPAMetric(c=c, p=p, measure=Euclidean())
    worst = 0.0
    for X, Y in _random_sets(rng, 200):
        ss, _ = metric.compute_gospa_metric(_states(X), _states(Y))
        ours = gospa(X, Y, c=c, p=p, alpha=2)
        for key in ("distance", "localisation", "missed", "false"):
            worst = max(worst, abs(float(ss.value[key]) - getattr(ours, key)))
    assert worst < 1e-9


def test_ospa_p1_equals_stonesoup():
    rng = np.random.default_rng(7)
    for c in (2.0, 5.0):
        metric = OSPAMetric(c=c, p=1, measure=Euclidean())
        diffs = [abs(metric.compute_OSPA_distance(_states(X), _states(Y)).value
                     - ospa(X, Y, c=c, p=1).distance) for X, Y in _random_sets(rng, 300)]
        assert max(diffs) < 1e-9


def test_ospa_p_inf_versus_stonesoup():
    rng = np.random.default_rng(8)
    metric = OSPAMetric(c=4.0, p=np.inf, measure=Euclidean())
    n_checked = 0
    for X, Y in _random_sets(rng, 200, max_size=4):
        ss = metric.compute_OSPA_distance(_states(X), _states(Y)).value
        ours = ospa(X, Y, c=4.0, p=np.inf).distance
        # Stone Soup's p = inf value is max over the min-sum assignment, an upper bound
        assert ours <= ss + 1e-12
        if len(X) != len(Y):
            assert ours == ss == 4.0
        n_checked += 1
    assert n_checked > 150


@pytest.mark.parametrize("p", [2, 3])
def test_ospa_p_gt_1_versus_stonesoup(p):
    """ours <= Stone Soup always; equal when the min-sum assignment is also min-sum-of-powers."""
    rng = np.random.default_rng(9 + p)
    c = 4.0
    metric = OSPAMetric(c=c, p=p, measure=Euclidean())
    n_equal = n_lower = 0
    for X, Y in _random_sets(rng, 300):
        ss = metric.compute_OSPA_distance(_states(X), _states(Y)).value
        ours = ospa(X, Y, c=c, p=p).distance
        assert ours <= ss + 1e-9
        # Recompute with Stone Soup's objective (sum of capped distances) through ours' maths
        A, B = (X, Y) if len(X) <= len(Y) else (Y, X)
        n = len(B)
        if len(A) == 0:
            ref = c
        else:
            capped = np.minimum(np.linalg.norm(A[:, None] - B[None], axis=-1), c)
            r, k = linear_sum_assignment(capped)
            ref = ((np.sum(capped[r, k] ** p) + c ** p * (n - len(A))) / n) ** (1 / p)
        assert abs(ss - ref) < 1e-9
        if abs(ss - ours) < 1e-9:
            n_equal += 1
        else:
            n_lower += 1
    assert n_equal > 200          # the objectives usually pick the same assignment
    assert n_lower > 0            # ...but not always: this is the documented difference
