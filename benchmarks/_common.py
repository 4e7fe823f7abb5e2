"""Shared helpers for the benchmarks: timing, machine description, result records."""
from __future__ import annotations

import os
import platform
import statistics
import subprocess
import time


def median_time(fn, repeat: int = 5, number: int = 1) -> float:
    """Median CPU time (``time.process_time``) in seconds of ``number`` calls of ``fn``
    over ``repeat`` trials."""
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        for _ in range(number):
            fn()
        times.append((time.process_time() - t0) / number)
    return statistics.median(times)


class Stopwatch:
    """Context manager measuring wall time and this process's CPU time (all its threads).

    On a shared, oversubscribed machine the wall time of a long run includes the time the
    process waited for a core (preemption), which a short run escapes: wall-time ratios
    between a fast and a slow implementation are then biased.  CPU time
    (``time.process_time``) counts only the time actually spent computing, for both, and is
    what the benchmarks report as ``seconds_per_*``; the wall time is kept beside it.
    """

    def __enter__(self):
        self._w = time.perf_counter()
        self._c = time.process_time()
        return self

    def __exit__(self, *exc):
        self.wall = time.perf_counter() - self._w
        self.cpu = time.process_time() - self._c
        return False


def load_average() -> list:
    """The 1, 5 and 15 minute load averages (``os.getloadavg``), rounded."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return []


def machine_description() -> dict:
    import numba
    import numpy
    import scipy

    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        mem_kb = int(open("/proc/meminfo").read().split()[1])
    except (OSError, ValueError, IndexError):
        mem_kb = 0
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=False).stdout.strip()
    except OSError:
        commit = ""
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "memory_gib": round(mem_kb / 2**20, 1),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "platform": platform.platform(),
        "commit": commit,
        "load_average_1_5_15min": load_average(),
        "date": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
    }


def record(workload: str, implementation: str, size, seconds_per_step: float, unit: str = "step",
           wall=None, **extra) -> dict:
    """One result row: ``seconds_per_<unit>`` is the median CPU time per unit of work;
    ``wall`` (optional list of per-trial wall times per unit) is stored with its median.
    ``trials`` (in ``extra``) are stored in repetition order, so that the trials of two
    implementations timed in the same repetitions pair up by index."""
    out = {"workload": workload, "implementation": implementation, "size": size,
           "seconds_per_" + unit: seconds_per_step, "clock": "process CPU time",
           "trials_order": "repetition"}
    if wall is not None:
        out["wall_seconds_per_" + unit] = statistics.median(wall)
        out["wall_trials"] = list(wall)
    out.update(extra)
    return out
