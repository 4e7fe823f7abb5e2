"""The book's Monte Carlo experiments: named, stored per run, verified by sampling.

An **experiment** (:class:`Experiment`) is an existing trackcore trial function plus a
validated, frozen config record, a master seed, a run count and a row extractor that
reduces one trial result to the flat per-run metrics a notebook needs.  Run ``i``
depends only on (experiment, config, seed, ``i``): it is computed with
``numpy.random.default_rng(SeedSequence(seed).spawn(n)[i])`` through
:func:`trackcore.montecarlo.run`, exactly as the notebooks did before, so the rows are
bit-identical serially, on :func:`trackcore.montecarlo.process_pool` workers and on a
Dask cluster, and the first ``m`` rows of a larger store are the rows of an ``m``-run
experiment.

Command line (``python -m trackcore.experiments --help``)::

    python -m trackcore.experiments list
    python -m trackcore.experiments run NAME [--runs N] [--seed S] [--set key=value ...]
        [--workers K [--dask] | --scheduler tcp://host:port] [--out PATH]
    python -m trackcore.experiments verify [NAME ...] [--fraction 1.0] [--workers K]

**Store.** One Parquet file per experiment, ``results/NAME.parquet`` for the book's
config and seed (in git), ``results/local/NAME-<config hash>-seed<S>.parquet`` for any
other (not in git).  A row is one run; scalar metrics are plain columns and fixed-shape
arrays (a count per scan, a delay per target) are fixed-size list columns whose shape
is in the metadata.  The file's key-value metadata holds the experiment name and
``version``, the config and its hash, the seed, the run count, the code version (package
version and git commit), the wall and CPU time and the executor.  Parquet (pyarrow)
rather than Zarr: the rows are a table (one record per run, typed columns, a few
thousand runs), which is Parquet's model; one self-describing compressed file per
experiment with its metadata in the footer is easy to commit, diff by metadata and copy,
where Zarr's chunked N-d arrays are a directory of many small files made for large
arrays read in slices, which these stores are not.

**Staleness.** :func:`load` refuses a missing store, or one made for another config,
seed or experiment ``version`` (bumped by hand when a trial's meaning changes), or with
too few runs, with :class:`StaleResultsError` naming the exact command that regenerates
it.  The code version is recorded but not checked (it changes at every commit): what
catches a silent change of the code under an unchanged version is the sampled
re-simulation, :func:`verify_sample`, which every ported notebook runs: a fresh random
sample (from OS entropy) of at least 20 runs and 1 % of the runs is re-simulated and
compared with the stored rows, integers and booleans bit for bit and floats to a
relative tolerance of ``FLOAT_RTOL`` = 1e-6 (the same code on the same platform gives
equal bits; the tolerance leaves room for another CPU's rounding, amplified along a
trajectory, never for a changed
algorithm).  ``verify --fraction 1.0`` re-runs everything.

**Another CPU.** The stores were computed on an x86-64 CPU with AVX-512.  On an emulated
CPU without it (``verify --emulate-cpu``, :mod:`trackcore.experiments.cpu`: numpy's and
OpenBLAS's AVX-512 kernels off, numba compiling for a generic CPU) 132 of 245 re-simulated
rows of the 46 stores differed in their last bits, by at most 7.4e-12 relative (TBD errors,
HPDA OSPA/GOSPA, JPDA MOTP), and no integer or boolean column changed: all 245 passed
``FLOAT_RTOL``.  A notebook that checks a rebuilt run against a stored one uses the same rule,
:func:`matches`; a config float a page recomputes (a calibrated noise level) selects the
book's config when it is within ``FLOAT_RTOL`` of it (:meth:`Experiment.configure`).
"""
from . import registry  # noqa: F401  (registers the book's experiments)
from ._core import (
    FLOAT_RTOL,
    book_check,
    Experiment,
    MissingResultsError,
    Results,
    StaleResultsError,
    Verification,
    VerificationError,
    check_store,
    code_version,
    compare_rows,
    compute_rows,
    config_hash,
    get,
    load,
    matches,
    names,
    obtain,
    read_metadata,
    register,
    results_dir,
    run_experiment,
    sample_size,
    status,
    verify_sample,
    write_store,
)
from .registry import HoulesConfig, HoulesSweepConfig, HpdaMonteCarloConfig

__all__ = [
    "FLOAT_RTOL", "Experiment", "HoulesConfig", "HoulesSweepConfig", "HpdaMonteCarloConfig", "MissingResultsError",
    "Results", "StaleResultsError", "Verification", "VerificationError", "book_check", "check_store",
    "code_version", "compare_rows", "compute_rows", "config_hash", "get", "load", "matches", "names",
    "obtain", "read_metadata", "register", "results_dir", "run_experiment", "sample_size",
    "status", "verify_sample", "write_store",
]
