"""Monte Carlo runner: independent, reproducible runs on any executor.

Run ``i`` of ``n_runs`` with master seed ``seed`` calls::

    trial(rng_i, *args, **kwargs)          # default
    trial(rng_i, i, *args, **kwargs)       # with pass_index=True

where ``rng_i = numpy.random.default_rng(numpy.random.SeedSequence(seed).spawn(n_runs)[i])``.
The results come back as a list in run order, bit-identical whether the runs go
serially (``executor=None``), on a ``concurrent.futures`` ``ThreadPoolExecutor``
or ``ProcessPoolExecutor``, or on a Dask cluster through
``distributed.Client(...).get_executor()``: each task receives the child
``SeedSequence`` objects (small and picklable), never a ``Generator``, and builds
its generators where it runs.  Runs are sent in chunks so that per-task
overhead stays small.

For process pools and Dask the ``trial`` function (and ``args``/``kwargs``)
must be picklable: define it at module level in an importable module (e.g. a
``trackcore.scenarios`` trial).  Dask pickles with ``cloudpickle`` and so also
accepts functions defined in a notebook cell.

Process pools and OpenMP
------------------------
numba's default threading layer on Linux is GNU OpenMP, and a process that has
run a ``parallel=True`` kernel must not ``fork()``: the children abort ("fork()
called from a process already using GNU OpenMP") and a fork-based
``ProcessPoolExecutor`` reports ``BrokenProcessPool``.  :func:`process_pool`
returns a pool whose workers start from a clean ``forkserver`` (or ``spawn``)
process instead; use it, or Dask, rather than a bare ``ProcessPoolExecutor()``.

The environment variable ``TRACKCORE_MAX_WORKERS`` caps the workers of every
:func:`process_pool`; at 1 the pool is an :class:`InlineExecutor` that runs each task in
the calling process (the same rows: runs depend only on their seed).  The test suite sets
it to 1 for the notebooks it executes: its two pytest-xdist workers already keep both
cores busy, and a pool of worker processes on top would only add their start-up (each
imports the package and loads its compiled kernels, about 3 CPU-seconds).

Progress
--------
Off by default, so nothing reaches stored notebook outputs.  ``progress=True``
writes one line per finished chunk to the *process's* standard error
(``sys.__stderr__``: the terminal or Jupyter kernel log, not the notebook cell),
and the same message always goes to the ``logging`` logger
``"trackcore.montecarlo"`` at DEBUG level.  ``progress`` may also be a callable
``progress(done, total)`` called in the submitting process after every chunk.
"""
from __future__ import annotations

import logging
import math
import multiprocessing
import sys
import os
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait

import numpy as np

from .core.rng import spawn_seed_sequences
from .core.validation import as_count, as_int

__all__ = ["run", "stack_results", "default_chunksize", "process_pool", "InlineExecutor",
           "MAX_WORKERS_ENV"]

logger = logging.getLogger("trackcore.montecarlo")

#: Target number of tasks a run is split into on an executor.
_TARGET_TASKS = 32
#: Largest process pool :func:`process_pool` makes (its workers all start at once).
_MAX_WORKERS = 1024
#: Environment variable capping the workers of :func:`process_pool` (1: in-process).
MAX_WORKERS_ENV = "TRACKCORE_MAX_WORKERS"


class InlineExecutor(Executor):
    """A ``concurrent.futures`` executor that runs each task in the calling process,
    when it is submitted; what :func:`process_pool` returns when ``TRACKCORE_MAX_WORKERS``
    is 1.

    Examples
    --------
    >>> import operator
    >>> from trackcore.montecarlo import InlineExecutor, run
    >>> draw = operator.methodcaller("random")
    >>> with InlineExecutor() as ex:
    ...     inline = run(draw, 6, seed=3, executor=ex)
    >>> inline == run(draw, 6, seed=3)
    True
    """

    def submit(self, fn, /, *args, **kwargs):
        """Call ``fn`` with the given arguments now; a done ``Future`` holds its result
        (or its exception, raised by ``result()`` as a pool's future would)."""
        future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # delivered by future.result(), as a pool would
            future.set_exception(exc)
        return future


def _env_max_workers():
    """The cap ``TRACKCORE_MAX_WORKERS`` sets (None if unset or empty)."""
    raw = os.environ.get(MAX_WORKERS_ENV, "").strip()
    if not raw:
        return None
    try:
        cap = int(raw)
    except ValueError:
        raise ValueError(f"{MAX_WORKERS_ENV} must be a positive integer, got {raw!r}") from None
    if not 1 <= cap <= _MAX_WORKERS:
        raise ValueError(f"{MAX_WORKERS_ENV} must lie in [1, {_MAX_WORKERS}], got {cap}")
    return cap


def _fresh_seed(seed):
    """An unspawned copy of a SeedSequence, so repeated calls give the same children."""
    if isinstance(seed, np.random.SeedSequence):
        return np.random.SeedSequence(entropy=seed.entropy, spawn_key=seed.spawn_key,
                                      pool_size=seed.pool_size)
    return seed


def _run_chunk(trial, start, seeds, pass_index, args, kwargs):
    """Executed on the worker: run the trials for consecutive run indices."""
    out = []
    for k, ss in enumerate(seeds):
        rng = np.random.default_rng(ss)
        if pass_index:
            out.append(trial(rng, start + k, *args, **kwargs))
        else:
            out.append(trial(rng, *args, **kwargs))
    return out


def default_chunksize(n_runs: int) -> int:
    """Runs per task on an executor: ``ceil(n_runs / 32)`` (at least 1).

    Examples
    --------
    >>> from trackcore.montecarlo import default_chunksize
    >>> default_chunksize(10), default_chunksize(1000)
    (1, 32)
    """
    n_runs = as_count(n_runs, "n_runs")
    return max(1, math.ceil(n_runs / _TARGET_TASKS))


def process_pool(max_workers=None, start_method="forkserver"):
    """A ``ProcessPoolExecutor`` whose workers do not ``fork()`` this process.

    ``start_method`` is ``"forkserver"`` (default) or ``"spawn"``; both are safe
    after numba has started OpenMP threads (see the module docstring).
    ``max_workers`` is at most 1024 (such a pool starts all its workers at its
    first task), and at most ``TRACKCORE_MAX_WORKERS`` where that variable is set; a cap
    of 1 gives an :class:`InlineExecutor` (no worker process).  Use as a
    context manager: ``with process_pool(2) as ex: run(trial, n, seed, executor=ex)``.

    Examples
    --------
    >>> import operator
    >>> from trackcore.montecarlo import process_pool, run
    >>> draw = operator.methodcaller("random")         # trial(rng) = rng.random(), picklable
    >>> with process_pool(2) as ex:
    ...     parallel = run(draw, 6, seed=3, executor=ex)
    ...
    >>> parallel == run(draw, 6, seed=3)     # the same runs as serially
    True
    """
    if start_method not in ("forkserver", "spawn"):
        raise ValueError(f"start_method must be 'forkserver' or 'spawn', got {start_method!r}")
    if max_workers is not None:
        max_workers = as_int(max_workers, "max_workers", minimum=1)
        if max_workers > _MAX_WORKERS:
            # a forkserver/spawn pool starts all its workers at the first submit
            raise ValueError(f"max_workers must be at most {_MAX_WORKERS}, got {max_workers}")
    cap = _env_max_workers()
    if cap is not None:
        max_workers = cap if max_workers is None else min(max_workers, cap)
        if max_workers == 1:
            return InlineExecutor()
    return ProcessPoolExecutor(max_workers=max_workers,
                               mp_context=multiprocessing.get_context(start_method))


def _progress_callback(progress):
    if progress is None or progress is False:
        def report(done, total):
            logger.debug("montecarlo: %d/%d runs done", done, total)
        return report
    if progress is True:
        def report(done, total):
            logger.debug("montecarlo: %d/%d runs done", done, total)
            stream = sys.__stderr__
            if stream is not None:
                stream.write(f"montecarlo: {done}/{total} runs done\n")
                stream.flush()
        return report
    if callable(progress):
        def report(done, total):
            logger.debug("montecarlo: %d/%d runs done", done, total)
            progress(done, total)
        return report
    raise TypeError(f"progress must be a bool or a callable progress(done, total), "
                    f"got {type(progress).__name__}")


def run(trial, n_runs, seed, executor=None, progress=False, args=(), kwargs=None, *,
        pass_index=False, chunksize=None):
    """Run ``trial`` ``n_runs`` times with independent, reproducible generators.

    Parameters
    ----------
    trial : callable
        ``trial(rng, *args, **kwargs)`` (or ``trial(rng, i, *args, **kwargs)`` with
        ``pass_index=True``) returning anything picklable.
    n_runs : int
        Number of runs (``0`` gives ``[]``).
    seed : int or numpy.random.SeedSequence
        Master seed; run ``i`` uses ``SeedSequence(seed).spawn(n_runs)[i]``.  A
        ``SeedSequence`` is used through an unspawned copy, so the call is repeatable.
    executor : concurrent.futures.Executor, optional
        ``None`` runs serially in this process.  Any object with a
        ``submit(fn, *args) -> Future`` method works (thread/process pools,
        ``distributed.Client.get_executor()``).
    progress : bool or callable
        See the module docstring; default off.
    args, kwargs
        Extra arguments passed to every trial.
    pass_index : bool
        Also pass the run index ``i`` as second argument.
    chunksize : int, optional
        Runs per submitted task (default :func:`default_chunksize`).

    Returns
    -------
    list
        The ``n_runs`` results in run order.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.montecarlo import run
    >>> def trial(rng, scale):
    ...     return scale * rng.standard_normal()
    ...
    >>> values = run(trial, 4, seed=1, args=(10.0,))
    >>> print(np.round(values, 3))
    [ -6.403  24.857  14.424 -22.302]
    >>> bool(np.array_equal(values, run(trial, 4, seed=1, args=(10.0,))))   # repeatable
    True
    >>> bool(run(trial, 10, seed=1, args=(10.0,))[2] == values[2])   # run i ignores n_runs
    True
    """
    if not callable(trial):
        raise TypeError(f"trial must be callable, got {type(trial).__name__}")
    n_runs = as_count(n_runs, "n_runs")
    seeds = spawn_seed_sequences(_fresh_seed(seed), n_runs)  # validates seed
    if not isinstance(args, tuple):
        raise TypeError(f"args must be a tuple, got {type(args).__name__}")
    kwargs = {} if kwargs is None else kwargs
    if not isinstance(kwargs, dict):
        raise TypeError(f"kwargs must be a dict, got {type(kwargs).__name__}")
    if not isinstance(pass_index, (bool, np.bool_)):
        raise TypeError(f"pass_index must be a bool, got {type(pass_index).__name__}")
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise TypeError(f"executor must be None or have a submit() method "
                        f"(concurrent.futures.Executor), got {type(executor).__name__}")
    chunksize = (default_chunksize(n_runs) if chunksize is None
                 else as_int(chunksize, "chunksize", minimum=1))
    report = _progress_callback(progress)

    bounds = [(s, min(s + chunksize, n_runs)) for s in range(0, n_runs, chunksize)]
    if executor is None:
        results = []
        for start, stop in bounds:
            results.extend(_run_chunk(trial, start, seeds[start:stop], pass_index, args, kwargs))
            report(stop, n_runs)
        return results

    futures = {}
    for j, (start, stop) in enumerate(bounds):
        fut = executor.submit(_run_chunk, trial, start, seeds[start:stop], pass_index,
                              args, kwargs)
        futures[fut] = j
    chunks = [None] * len(bounds)
    pending = set(futures)
    done_runs = 0
    try:
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                j = futures[fut]
                chunks[j] = fut.result()
                done_runs += bounds[j][1] - bounds[j][0]
                report(done_runs, n_runs)
    except BaseException:
        for fut in pending:
            fut.cancel()
        raise
    return [r for chunk in chunks for r in chunk]


def _stack(values, name):
    try:
        return np.stack([np.asarray(v) for v in values])
    except ValueError as exc:
        raise ValueError(f"{name}: results have inconsistent shapes ({exc})") from None


def stack_results(results):
    """Stack a list of per-run results into arrays with the run axis first.

    * list of dicts (same keys) -> dict of arrays, ``out[key][i]`` is run ``i``;
    * list of tuples / NamedTuples -> tuple (same NamedTuple type) of arrays;
    * list of arrays or scalars -> one array.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.montecarlo import stack_results
    >>> out = stack_results([{"rmse": 1.0, "err": [0.0, 1.0]}, {"rmse": 2.0, "err": [1.0, 1.0]}])
    >>> out["rmse"], out["err"].shape
    (array([1., 2.]), (2, 2))
    >>> stack_results([(1, 2.0), (3, 4.0)])
    (array([1, 3]), array([2., 4.]))
    """
    if not isinstance(results, (list, tuple)):
        raise TypeError(f"results must be a list of per-run results, got {type(results).__name__}")
    if len(results) == 0:
        raise ValueError("results must not be empty (cannot infer the structure of a run)")
    first = results[0]
    if isinstance(first, dict):
        keys = list(first)
        for i, r in enumerate(results):
            if not isinstance(r, dict) or set(r) != set(keys):
                raise ValueError(f"results[{i}] does not have the keys of results[0]: {keys}")
        return {k: _stack([r[k] for r in results], f"results[...][{k!r}]") for k in keys}
    if isinstance(first, tuple):
        n = len(first)
        for i, r in enumerate(results):
            if not isinstance(r, tuple) or len(r) != n:
                raise ValueError(f"results[{i}] is not a tuple of length {n} like results[0]")
        cols = [_stack([r[j] for r in results], f"results[...][{j}]") for j in range(n)]
        if hasattr(first, "_fields"):
            return type(first)(*cols)
        return tuple(cols)
    return _stack(results, "results")
