"""Core layer: validation, log-space maths, RNG plumbing."""
from .logmath import (LOG_2PI, cholesky_logpdf_kernel, gaussian_logpdf, logsumexp,
                      logsumexp_kernel, normalize_log_weights, normalize_log_weights_kernel)
from .rng import generator_for_run, make_rng, spawn_generators, spawn_seed_sequences
from .validation import (as_array, as_bool_matrix, as_count, as_covariance, as_int,
                         as_matrix, as_measurements, as_nonnegative, as_offsets, as_positive,
                         as_probabilities, as_probability, as_rng, as_scalar,
                         as_square_matrix, as_vector)
