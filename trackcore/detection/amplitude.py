"""Exponential (Swerling I/II power) amplitude model with a detection threshold.

Amplitudes are powers normalised to unit mean clutter: clutter ``a ~ Exp(1)``
(pdf ``p_0(a) = e^{-a}``), target ``a ~ Exp(1 + rho)`` (pdf
``p_1(a) = c e^{-c a}``, ``c = 1/(1+rho)``), ``rho`` the linear mean SNR.  A
return is reported iff ``a > tau``:

    P_D = exp(-tau c),   P_fa = exp(-tau),   tau = -(1 + rho) ln P_D.

(Kim & Song 2007, eqs 4-5 and assumption 2; erratum E18: the threshold is
derived from P_D, never the clustering window length "tau = 2".)  By
memorylessness, reported amplitudes are ``tau + Exp(1)`` (clutter) and
``tau + Exp(1 + rho)`` (target).
"""
from __future__ import annotations

import math

import numpy as np

from ..core.validation import (as_array, as_count, as_nonnegative, as_probability,
                               as_rng)

__all__ = [
    "exponential_amplitude_threshold",
    "exponential_detection_probability",
    "exponential_false_alarm_probability",
    "target_amplitude_pdf",
    "clutter_amplitude_pdf",
    "amplitude_likelihood_ratio",
    "sample_target_amplitudes",
    "sample_clutter_amplitudes",
]


def exponential_amplitude_threshold(pd, snr):
    """Threshold ``tau = -(1 + snr) ln P_D`` giving detection probability ``pd``.

    Examples
    --------
    >>> from trackcore.detection import exponential_amplitude_threshold
    >>> round(float(exponential_amplitude_threshold(0.9, snr=10.0)), 4)    # -(1 + 10) ln 0.9
    1.159
    """
    pd = as_probability(pd, "pd", open_low=True)
    snr = as_nonnegative(snr, "snr")
    return -(1.0 + snr) * math.log(pd)


def exponential_detection_probability(tau, snr):
    """``P_D = exp(-tau / (1 + snr))``.

    Examples
    --------
    >>> from trackcore.detection import exponential_detection_probability
    >>> round(float(exponential_detection_probability(1.159, snr=10.0)), 4)
    0.9
    """
    tau = as_nonnegative(tau, "tau")
    snr = as_nonnegative(snr, "snr")
    return math.exp(-tau / (1.0 + snr))


def exponential_false_alarm_probability(tau):
    """``P_fa = exp(-tau)`` (per resolution cell, unit-mean exponential clutter).

    Examples
    --------
    >>> from trackcore.detection import exponential_false_alarm_probability
    >>> round(float(exponential_false_alarm_probability(1.159)), 4)  # 31 % of clutter passes
    0.3138
    """
    tau = as_nonnegative(tau, "tau")
    return math.exp(-tau)


def _amps(a, name="a"):
    arr = as_array(a, name, finite=False)
    if np.isnan(arr).any():
        raise ValueError(f"{name} must not contain NaN")
    if arr.size and arr.min() < 0:
        raise ValueError(f"{name} must be >= 0")
    return arr


def target_amplitude_pdf(a, snr):
    """``p_1(a) = c e^{-c a}`` (eq 4), ``c = 1/(1+snr)``, ``a >= 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.detection import target_amplitude_pdf
    >>> print(np.round(target_amplitude_pdf(np.array([0.0, 1.0, 10.0]), snr=9.0), 4))   # c = 0.1
    [0.1    0.0905 0.0368]
    """
    arr = _amps(a)
    c = 1.0 / (1.0 + as_nonnegative(snr, "snr"))
    out = c * np.exp(-c * arr)
    return float(out) if out.ndim == 0 else out


def clutter_amplitude_pdf(a):
    """``p_0(a) = e^{-a}`` (eq 5), ``a >= 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.detection import clutter_amplitude_pdf
    >>> print(np.round(clutter_amplitude_pdf(np.array([0.0, 1.0, 10.0])), 4))
    [1.     0.3679 0.    ]
    """
    arr = _amps(a)
    out = np.exp(-arr)
    return float(out) if out.ndim == 0 else out


def amplitude_likelihood_ratio(a, snr, tau):
    """Likelihood ratio of a *reported* amplitude, target vs clutter:

        LR(a) = [p_1(a) / P_D] / [p_0(a) / P_fa] = c exp((1 - c)(a - tau)),  a >= tau.

    Amplitudes below ``tau`` cannot be reported and raise ``ValueError``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.detection import amplitude_likelihood_ratio
    >>> lr = amplitude_likelihood_ratio(np.array([2.0, 5.0, 10.0]), snr=9.0, tau=2.0)
    >>> print(np.round(lr, 3))
    [  0.1     1.488 133.943]
    >>> amplitude_likelihood_ratio(1.0, snr=9.0, tau=2.0)
    Traceback (most recent call last):
        ...
    ValueError: a must be >= tau = 2.0 (only reported amplitudes have a ratio)
    """
    arr = _amps(a)
    snr = as_nonnegative(snr, "snr")
    tau = as_nonnegative(tau, "tau")
    if arr.size and arr.min() < tau:
        raise ValueError(f"a must be >= tau = {tau} (only reported amplitudes have a ratio)")
    c = 1.0 / (1.0 + snr)
    out = c * np.exp((1.0 - c) * (arr - tau))
    return float(out) if out.ndim == 0 else out


def sample_target_amplitudes(rng, n, snr, tau):
    """``n`` reported target amplitudes: ``tau + Exp(mean 1 + snr)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.detection import sample_target_amplitudes
    >>> a = sample_target_amplitudes(np.random.default_rng(0), 100_000, snr=9.0, tau=2.0)
    >>> bool(a.min() >= 2.0), round(float(a.mean()), 1)         # tau + mean 1 + snr
    (True, 12.0)
    """
    rng = as_rng(rng)
    n = as_count(n, "n")
    snr = as_nonnegative(snr, "snr")
    tau = as_nonnegative(tau, "tau")
    return tau + rng.exponential(1.0 + snr, n)


def sample_clutter_amplitudes(rng, n, tau):
    """``n`` reported clutter amplitudes: ``tau + Exp(1)``.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.detection import sample_clutter_amplitudes
    >>> a = sample_clutter_amplitudes(np.random.default_rng(0), 100_000, tau=2.0)
    >>> bool(a.min() >= 2.0), round(float(a.mean()), 1)         # tau + 1
    (True, 3.0)
    """
    rng = as_rng(rng)
    n = as_count(n, "n")
    tau = as_nonnegative(tau, "tau")
    return tau + rng.exponential(1.0, n)
