"""Tests for trackcore.montecarlo: reproducibility on every executor, ordering, validation."""
import io
import operator
import sys
from collections import namedtuple
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from trackcore.montecarlo import default_chunksize, process_pool, run, stack_results

Result = namedtuple("Result", "mean path")


def random_walk_trial(rng, n_steps=20, scale=1.0):
    """A small but real trial: a random walk with Gaussian steps."""
    steps = rng.normal(0.0, scale, size=(n_steps, 2))
    path = np.cumsum(steps, axis=0)
    return {"final": path[-1], "max_abs": float(np.max(np.abs(path))), "n": rng.integers(0, 10)}


def indexed_trial(rng, i):
    return i, float(rng.random())


def namedtuple_trial(rng):
    path = rng.normal(size=5)
    return Result(float(path.mean()), path)


def failing_trial(rng):
    raise RuntimeError("trial failed on purpose")


def _expected(seed, n, **kw):
    out = []
    for ss in np.random.SeedSequence(seed).spawn(n):
        out.append(random_walk_trial(np.random.default_rng(ss), **kw))
    return out


def _assert_identical(a, b):
    assert len(a) == len(b)
    for ra, rb in zip(a, b):
        assert ra.keys() == rb.keys()
        for k in ra:
            assert np.array_equal(ra[k], rb[k]), k


def test_serial_matches_definition_and_order():
    res = run(random_walk_trial, 37, seed=2026)
    _assert_identical(res, _expected(2026, 37))
    assert run(random_walk_trial, 0, seed=1) == []


def test_args_kwargs_and_index():
    res = run(random_walk_trial, 5, 3, args=(7,), kwargs={"scale": 2.0})
    _assert_identical(res, _expected(3, 5, n_steps=7, scale=2.0))
    res = run(indexed_trial, 9, 4, pass_index=True, chunksize=2)
    assert [r[0] for r in res] == list(range(9))
    assert [r[1] for r in res] == [float(np.random.default_rng(s).random())
                                   for s in np.random.SeedSequence(4).spawn(9)]


def test_seed_sequence_input_is_repeatable():
    ss = np.random.SeedSequence(11)
    a = run(random_walk_trial, 4, ss)
    b = run(random_walk_trial, 4, ss)
    _assert_identical(a, b)
    _assert_identical(a, _expected(11, 4))


@pytest.mark.parametrize("chunksize", [None, 1, 4, 100])
def test_thread_and_process_pools_bit_identical(chunksize):
    serial = run(random_walk_trial, 50, seed=5)
    with ThreadPoolExecutor(max_workers=3) as ex:
        _assert_identical(run(random_walk_trial, 50, 5, executor=ex, chunksize=chunksize), serial)
    with ProcessPoolExecutor(max_workers=2) as ex:
        _assert_identical(run(random_walk_trial, 50, 5, executor=ex, chunksize=chunksize), serial)


@pytest.mark.parametrize("start_method", ["forkserver", "spawn"])
def test_process_pool_without_fork_bit_identical(start_method):
    serial = run(random_walk_trial, 12, seed=6)
    with process_pool(2, start_method=start_method) as ex:
        _assert_identical(run(random_walk_trial, 12, 6, executor=ex), serial)
    with pytest.raises(ValueError, match="start_method"):
        process_pool(2, start_method="fork")
    with pytest.raises(ValueError, match="max_workers"):
        process_pool(0)


def test_dask_executor_bit_identical():
    distributed = pytest.importorskip("distributed")
    import cloudpickle

    # Dask workers are fresh processes that cannot import this test module by name,
    # so ship its functions by value.
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    try:
        serial = run(random_walk_trial, 40, seed=8)
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client:
            ex = client.get_executor()
            _assert_identical(run(random_walk_trial, 40, 8, executor=ex), serial)
            _assert_identical(run(random_walk_trial, 40, 8, executor=ex, chunksize=3), serial)
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def test_trial_exception_propagates():
    with pytest.raises(RuntimeError, match="on purpose"):
        run(failing_trial, 3, 0)
    with ThreadPoolExecutor(max_workers=2) as ex:
        with pytest.raises(RuntimeError, match="on purpose"):
            run(failing_trial, 3, 0, executor=ex)


def test_progress_callback_and_stderr(monkeypatch, capsys):
    calls = []
    run(random_walk_trial, 10, 1, progress=lambda d, t: calls.append((d, t)), chunksize=4)
    assert calls == [(4, 10), (8, 10), (10, 10)]
    calls.clear()
    with ThreadPoolExecutor(max_workers=2) as ex:
        run(random_walk_trial, 10, 1, executor=ex, progress=lambda d, t: calls.append((d, t)),
            chunksize=4)
    assert sorted(calls)[-1] == (10, 10) and len(calls) == 3
    fake = io.StringIO()
    monkeypatch.setattr(sys, "__stderr__", fake)
    run(random_walk_trial, 3, 1, progress=True, chunksize=2)
    assert fake.getvalue() == "montecarlo: 2/3 runs done\nmontecarlo: 3/3 runs done\n"
    # default: nothing written anywhere a notebook would store
    fake.truncate(0); fake.seek(0)
    run(random_walk_trial, 3, 1)
    out = capsys.readouterr()
    assert fake.getvalue() == "" and out.out == "" and out.err == ""


def test_default_chunksize():
    assert default_chunksize(0) == 1
    assert default_chunksize(10) == 1
    assert default_chunksize(1000) == 32


def test_bad_input():
    with pytest.raises(TypeError, match="trial"):
        run(42, 3, 0)
    with pytest.raises(ValueError, match="n_runs"):
        run(random_walk_trial, -1, 0)
    with pytest.raises(TypeError, match="n_runs"):
        run(random_walk_trial, 2.5, 0)
    with pytest.raises(ValueError, match="seed"):
        run(random_walk_trial, 2, -3)
    with pytest.raises(TypeError, match="seed"):
        run(random_walk_trial, 2, "abc")
    with pytest.raises(TypeError, match="seed"):
        run(random_walk_trial, 2, np.random.default_rng(0))
    with pytest.raises(TypeError, match="executor"):
        run(random_walk_trial, 2, 0, executor="threads")
    with pytest.raises(TypeError, match="progress"):
        run(random_walk_trial, 2, 0, progress="yes")
    with pytest.raises(ValueError, match="chunksize"):
        run(random_walk_trial, 2, 0, chunksize=0)
    with pytest.raises(TypeError, match="args"):
        run(random_walk_trial, 2, 0, args=[3])
    with pytest.raises(TypeError, match="kwargs"):
        run(random_walk_trial, 2, 0, kwargs=[("scale", 1.0)])


def test_stack_results():
    res = run(random_walk_trial, 6, 2)
    st = stack_results(res)
    assert st["final"].shape == (6, 2) and st["max_abs"].shape == (6,)
    assert np.array_equal(st["final"][3], res[3]["final"])
    nt = stack_results(run(namedtuple_trial, 4, 2))
    assert isinstance(nt, Result) and nt.path.shape == (4, 5) and nt.mean.shape == (4,)
    tp = stack_results(run(indexed_trial, 3, 2, pass_index=True))
    assert isinstance(tp, tuple) and np.array_equal(tp[0], [0, 1, 2])
    arr = stack_results([np.ones(3), np.zeros(3)])
    assert arr.shape == (2, 3)
    assert stack_results([1.0, 2.0]).shape == (2,)
    with pytest.raises(ValueError, match="results"):
        stack_results([])
    with pytest.raises(ValueError, match="keys"):
        stack_results([{"a": 1}, {"b": 2}])
    with pytest.raises(ValueError, match="inconsistent"):
        stack_results([np.ones(2), np.ones(3)])
    with pytest.raises(TypeError, match="results"):
        stack_results(np.ones(3))


def test_counts_beyond_64_bits_are_value_errors():
    with pytest.raises(ValueError, match="n_runs must fit"):
        run(lambda rng: 0, 2**70, 1)
    with pytest.raises(ValueError, match="max_workers must fit"):
        process_pool(2**70)
    with pytest.raises(ValueError, match="max_workers must be at most 1024"):
        process_pool(2**40)
    with pytest.raises(ValueError, match="n_runs must be an integer of magnitude"):
        default_chunksize(1e300)


def test_max_workers_env_caps_process_pools(monkeypatch):
    """TRACKCORE_MAX_WORKERS caps process_pool; at 1 the runs go in this process, the
    same rows as a pool and as serially; a bad value is a ValueError naming it."""
    from trackcore.montecarlo import InlineExecutor

    draw = operator.methodcaller("random")
    monkeypatch.setenv("TRACKCORE_MAX_WORKERS", "1")
    with process_pool(4) as ex:
        assert isinstance(ex, InlineExecutor), "a cap of 1 runs in this process"
        inline = run(draw, 9, seed=5, executor=ex)
    assert inline == run(draw, 9, seed=5), "the inline executor changed the runs"
    monkeypatch.setenv("TRACKCORE_MAX_WORKERS", "2")
    with process_pool(4) as ex:
        assert ex._max_workers == 2, "the cap must bound the pool's workers"
        assert run(draw, 9, seed=5, executor=ex) == inline, "the capped pool changed the runs"
    for bad in ("0", "two", "-1"):
        monkeypatch.setenv("TRACKCORE_MAX_WORKERS", bad)
        with pytest.raises(ValueError, match="TRACKCORE_MAX_WORKERS"):
            process_pool(2)


def test_inline_executor_delivers_exceptions_through_the_future():
    from trackcore.montecarlo import InlineExecutor

    with InlineExecutor() as ex:
        fut = ex.submit(operator.truediv, 1, 0)
    with pytest.raises(ZeroDivisionError):
        fut.result()
