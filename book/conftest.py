"""Execution statistics of the notebooks, and the worker cap of their process pools.

Every test session that executes notebooks (``pytest --nbval``, as configured in
``pyproject.toml``) merges, per notebook, its wall time (the sum of its cells' setup,
call and teardown), its status, its cell counts and the Monte Carlo runs it re-simulated to
check its stored results into ``.ci/exec_stats.json`` (not in
git). The appendix page "Execution statistics" is rendered from that file at build time
(``book/_ext/exec_stats.py``). Under pytest-xdist the controller records (the workers'
reports reach it); the workers do not write.

Under pytest-xdist each notebook's kernel starts with ``TRACKCORE_MAX_WORKERS`` set to the
cores per xdist worker (at least 1; ``trackcore.montecarlo.process_pool`` reads it): with
``-n 2`` on two cores the pools of HPDA 06-08 and feature-JPDA 05-07 run their re-simulated
runs in the kernel's own process (the same rows), instead of starting worker processes that
would only compete with the other xdist worker for the same cores; OpenBLAS runs
single-threaded there for the same reason (``pytest_configure``).
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import pytest

_ROOT = Path(__file__).resolve().parent.parent
STATS_FILE = _ROOT / ".ci" / "exec_stats.json"
_VERIFIED = re.compile(r"re-simulated (\d+) of (\d+) stored runs")
_seen = defaultdict(lambda: {"seconds": 0.0, "cells": 0, "failed": 0, "skipped": 0})


def runs_verified(path):
    """[checked, stored] Monte Carlo runs a notebook re-simulated to check its stored results:
    the sum over its "re-simulated k of N stored runs" lines (of the outputs as stored, which
    a passing strict nbval run has just found equal to the fresh ones), or None."""
    try:
        nb = json.loads((_ROOT / path).read_text())
    except (OSError, ValueError):
        return None
    found = [(int(k), int(n)) for c in nb.get("cells", []) for o in c.get("outputs", [])
             for k, n in _VERIFIED.findall("".join(o.get("text", "")))]
    return [sum(k for k, _ in found), sum(n for _, n in found)] if found else None


def _pool_cap():
    """Cores per xdist worker (None outside xdist or where one worker has several)."""
    n = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0") or 0)
    if n < 1:
        return None
    per = (os.cpu_count() or 1) // n
    return None if per > 1 else 1


def pytest_configure(config):
    """With one core per pytest-xdist worker, OpenBLAS runs single-threaded in the workers
    and in the notebooks' kernels (they inherit the environment): its second thread would
    spin-wait on a core the other worker is using. Measured on two cores with the other
    one busy, twelve bootstrap intervals of the HPDA chapter took 3.3-4.5x the wall time and
    3.4-3.9x the CPU time with OpenBLAS's default threads (two runs of each). Set here, in the controller, before the
    workers start and load numpy; a user's own setting is kept."""
    n = getattr(config.option, "numprocesses", None)
    if isinstance(n, int) and n >= 1 and (os.cpu_count() or 1) // n <= 1:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    _warm_numba(config, n)


def _warm_numba(config, n):
    """The whole suite under pytest-xdist, from an empty numba cache (a clean clone): the
    kernels are compiled once, ``n`` modules at a time, before the workers start
    (``tests/numba_warm.py``), so that no two workers or notebook kernels compile the same
    kernel at once. ``TRACKCORE_NUMBA_WARM=0`` switches it off."""
    if os.environ.get("PYTEST_XDIST_WORKER") or os.environ.get("TRACKCORE_NUMBA_WARM") == "0":
        return
    if not (isinstance(n, int) and n >= 2) or \
            config.args_source is not pytest.Config.ArgsSource.TESTPATHS:
        return
    sys.path.insert(0, str(_ROOT / "tests"))   # the pool's processes import it by name
    try:
        import numba_warm

        if not numba_warm.cache_is_empty():
            return
        t0 = time.perf_counter()
        done = numba_warm.warm(n)
    finally:
        sys.path.remove(str(_ROOT / "tests"))
    sys.stderr.write(f"numba kernels of {len(done)} modules compiled into the cache on {n} "
                     f"processes in {time.perf_counter() - t0:.0f} s\n")


_CAP_SET = []   # whether this hook set the variable (a user's own setting is left alone)


def pytest_runtest_setup(item):
    # before the notebook's kernel starts (its collector's setup follows this hook)
    cap = _pool_cap()
    if cap is not None and "TRACKCORE_MAX_WORKERS" not in os.environ:
        os.environ["TRACKCORE_MAX_WORKERS"] = str(cap)
        _CAP_SET.append(True)


def pytest_runtest_teardown(item, nextitem):
    # the kernel keeps its own copy; the tests under tests/ run without the cap
    if _CAP_SET and (nextitem is None or not str(nextitem.path).endswith(".ipynb")):
        os.environ.pop("TRACKCORE_MAX_WORKERS", None)
        _CAP_SET.clear()


def pytest_runtest_logreport(report):
    if os.environ.get("PYTEST_XDIST_WORKER"):
        return
    path, sep, _ = report.nodeid.partition("::")
    if not sep or not path.endswith(".ipynb"):
        return
    rec = _seen[path]
    rec["seconds"] += float(getattr(report, "duration", 0.0) or 0.0)
    if report.when == "call":
        rec["cells"] += 1
        rec["skipped"] += bool(report.skipped)
    if report.failed:
        rec["failed"] += 1


def pytest_sessionfinish(session, exitstatus):
    if os.environ.get("PYTEST_XDIST_WORKER") or not _seen:
        return
    try:
        stats = json.loads(STATS_FILE.read_text())
    except (OSError, ValueError):
        stats = {}
    try:
        commit = subprocess.run(["git", "-C", str(_ROOT), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True, timeout=10,
                                check=False).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    for path, rec in _seen.items():
        status = "failed" if rec["failed"] else "skipped" if rec["cells"] == rec["skipped"] \
            else "passed"
        stats[path] = {"seconds": round(rec["seconds"], 1), "status": status,
                       "cells": rec["cells"], "failed_cells": rec["failed"],
                       "runs_verified": runs_verified(path),
                       "date": when, "commit": commit}
    STATS_FILE.parent.mkdir(exist_ok=True)
    tmp = STATS_FILE.with_suffix(".tmp")
    tmp.write_text(json.dumps(dict(sorted(stats.items())), indent=1) + "\n")
    tmp.replace(STATS_FILE)
    _seen.clear()
