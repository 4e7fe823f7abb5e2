"""Tests for trackcore.detection.amplitude."""
import math

import numpy as np
import pytest
from scipy import stats

from trackcore.detection import (amplitude_likelihood_ratio, exponential_amplitude_threshold,
                                 clutter_amplitude_pdf, exponential_detection_probability,
                                 exponential_false_alarm_probability, sample_clutter_amplitudes,
                                 sample_target_amplitudes, target_amplitude_pdf)


def test_threshold_round_trip_and_spec_values():
    assert exponential_amplitude_threshold(0.9, 10) == pytest.approx(1.159, abs=5e-4)   # E18
    assert exponential_amplitude_threshold(0.6, 5) == pytest.approx(3.065, abs=5e-4)
    assert exponential_false_alarm_probability(exponential_amplitude_threshold(0.9, 10)) == pytest.approx(0.314, abs=5e-4)
    assert exponential_false_alarm_probability(exponential_amplitude_threshold(0.6, 5)) == pytest.approx(0.047, abs=5e-4)
    assert exponential_detection_probability(2.0, 10) == pytest.approx(0.834, abs=5e-4)
    for pd in (0.1, 0.5, 0.9, 0.999):
        assert exponential_detection_probability(exponential_amplitude_threshold(pd, 3.3), 3.3) == pytest.approx(pd)


def test_pdfs_match_scipy():
    a = np.linspace(0, 20, 11)
    np.testing.assert_allclose(target_amplitude_pdf(a, 10), stats.expon(scale=11).pdf(a))
    np.testing.assert_allclose(clutter_amplitude_pdf(a), stats.expon().pdf(a))


def test_likelihood_ratio():
    tau, rho = 1.159, 10.0
    a = np.array([tau, 3.0, 10.0])
    c = 1 / 11
    pd, pfa = math.exp(-tau * c), math.exp(-tau)
    expect = (c * np.exp(-c * a) / pd) / (np.exp(-a) / pfa)
    np.testing.assert_allclose(amplitude_likelihood_ratio(a, rho, tau), expect, rtol=1e-12)
    assert amplitude_likelihood_ratio(tau, rho, tau) == pytest.approx(c)
    assert amplitude_likelihood_ratio(np.zeros(0), rho, tau).shape == (0,)


def test_sampling_distributions():
    rng = np.random.default_rng(1)
    t = sample_target_amplitudes(rng, 200_000, 5.0, 3.0)
    c = sample_clutter_amplitudes(rng, 200_000, 3.0)
    assert t.min() >= 3.0 and c.min() >= 3.0
    assert abs(t.mean() - 9.0) < 4 * 6.0 / math.sqrt(200_000)
    assert abs(c.mean() - 4.0) < 4 * 1.0 / math.sqrt(200_000)
    assert sample_clutter_amplitudes(rng, 0, 3.0).shape == (0,)
    # memorylessness: raw Exp(1+rho) thresholded equals tau + Exp(1+rho)
    raw = rng.exponential(6.0, 400_000)
    kept = raw[raw > 3.0]
    assert stats.ks_2samp(kept, t).pvalue > 1e-3
    assert kept.size / raw.size == pytest.approx(exponential_detection_probability(3.0, 5.0), abs=4 * 0.001)


def test_bad_input():
    with pytest.raises(ValueError, match="pd"):
        exponential_amplitude_threshold(0.0, 10)
    with pytest.raises(ValueError, match="pd"):
        exponential_amplitude_threshold(1.5, 10)
    with pytest.raises(ValueError, match="snr"):
        exponential_amplitude_threshold(0.9, -1)
    with pytest.raises(ValueError, match="tau"):
        exponential_detection_probability(-1, 10)
    with pytest.raises(ValueError, match="a must not contain NaN"):
        amplitude_likelihood_ratio([2.0, np.nan], 10, 1.0)
    with pytest.raises(ValueError, match="a must not contain NaN"):
        target_amplitude_pdf(np.nan, 10)
    with pytest.raises(ValueError, match="a must be >= tau"):
        amplitude_likelihood_ratio([0.5], 10, 1.0)
    with pytest.raises(TypeError, match="rng"):
        sample_target_amplitudes(1, 10, 5, 3)
    with pytest.raises(ValueError, match="n"):
        sample_clutter_amplitudes(np.random.default_rng(), -1, 3)
