"""Core layer: validation, log-space maths, RNG plumbing.

The numba kernels of :mod:`trackcore.core.logmath` (``logsumexp_kernel``,
``normalize_log_weights_kernel``, ``cholesky_logpdf_kernel``) are not public: they assume
valid input, and the package imports them from their module.
"""
from .logmath import LOG_2PI, gaussian_logpdf, logsumexp, normalize_log_weights
from .rng import generator_for_run, make_rng, spawn_generators, spawn_seed_sequences
from .validation import (as_array, as_bool_matrix, as_count, as_covariance, as_int,
                         as_matrix, as_measurements, as_nonnegative, as_offsets, as_positive,
                         as_probabilities, as_probability, as_rng, as_scalar,
                         as_square_matrix, as_vector, finite_result)

__all__ = [
    "LOG_2PI",
    "gaussian_logpdf",
    "logsumexp",
    "normalize_log_weights",
    "generator_for_run",
    "make_rng",
    "spawn_generators",
    "spawn_seed_sequences",
    "as_array",
    "as_bool_matrix",
    "as_count",
    "as_covariance",
    "as_int",
    "as_matrix",
    "as_measurements",
    "as_nonnegative",
    "as_offsets",
    "as_positive",
    "as_probabilities",
    "as_probability",
    "as_rng",
    "as_scalar",
    "as_square_matrix",
    "as_vector",
    "finite_result",
]
