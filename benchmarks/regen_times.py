"""What it costs to regenerate every stored experiment, measured run by run.

    python -m benchmarks.regen_times                 # every experiment with a store (~15 CPU-min)
    python -m benchmarks.regen_times hpda-mc-case1   # some experiments (updates their entries)

Regenerating the whole store (``python -m trackcore.experiments run all``) takes hours, so
this script measures a sample instead.  For each registered experiment whose store is
current it first runs one run untimed (numba compiles, or loads its cache), then
re-computes stored runs one at a time, spread evenly over the store, until at least
``MIN_CPU`` seconds of CPU or ``MAX_SAMPLE`` runs are spent (at least ``MIN_SAMPLE``).
Each run's CPU time (``time.process_time`` around the trial, as
:func:`trackcore.experiments.compute_rows` measures it) is recorded, and each recomputed
row is compared with the stored one (so the measurement is also a verification).  CPU time
is used because the machine is shared: a run's wall time includes the time it waited for a
core, its CPU time does not.

The estimated time of a whole experiment is its mean CPU time per run times its stored
runs; with ``K`` worker processes the runs are independent, so the ideal wall time is
that sum divided by ``K`` (the scale appendix measures how close two workers come).

Results go to ``benchmarks/results/regen_times.json``; the appendix "Execution statistics"
renders them with the run counts of ``book/appendix/run_counts.yml``.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from ._common import load_average, machine_description

RESULTS = Path(__file__).resolve().parent / "results" / "regen_times.json"
MIN_CPU = 2.0  # seconds of CPU to spend per experiment (at least MIN_SAMPLE runs)
MIN_SAMPLE = 3
MAX_SAMPLE = 20


def spread_indices(runs: int, k: int) -> list[int]:
    """``k`` distinct run indices spread evenly over ``0 .. runs-1`` (first and last
    included when ``k >= 2``)."""
    if runs < 1 or k < 1:
        raise ValueError("runs and k must be >= 1")
    k = min(k, runs)
    return sorted({int(x + 0.5) for x in np.linspace(0, runs - 1, k)})


def measure(name: str) -> dict:
    """Per-run CPU seconds of a sample of one experiment's stored runs (see the module
    docstring); raises :class:`trackcore.experiments.VerificationError` if a recomputed row
    differs from the stored one."""
    from trackcore import experiments
    from trackcore.experiments._core import compare_rows, compute_rows

    res = experiments.load(name)
    exp, config, seed, runs = res.experiment, res.config, res.meta["seed"], res.runs
    t0 = time.perf_counter()
    compute_rows(exp, config, seed, runs, indices=[0])  # warm-up: compile or load the cache
    warm = time.perf_counter() - t0
    order = spread_indices(runs, MAX_SAMPLE)
    # visit the spread indices in an interleaved order, so a short sample still spans the store
    order = order[::2] + order[1::2]
    cpu, done = [], []
    for i in order:
        rows, c = compute_rows(exp, config, seed, runs, indices=[i])
        compare_rows(res.row(i), rows[0], i)
        cpu.append(c)
        done.append(i)
        if len(done) >= MIN_SAMPLE and sum(cpu) >= MIN_CPU:
            break
    per_run = float(np.mean(cpu))
    return {
        "runs": runs,
        "sample": done,
        "cpu_seconds_sample": [round(c, 4) for c in cpu],
        "cpu_per_run": round(per_run, 5),
        # from the rounded per-run cost, so that the record is consistent with itself
        # (tests/test_run_counts.py) also for cheap runs times many runs
        "cpu_estimate": round(round(per_run, 5) * runs, 1),
        "warm_up_wall": round(warm, 2),
        "store_wall_seconds": res.meta.get("wall_seconds"),
        "store_executor": res.meta.get("executor"),
    }


def main(argv: list[str]) -> int:
    from trackcore import experiments

    names = argv or [n for n in experiments.names() if experiments.status(n) == "current"]
    record = json.loads(RESULTS.read_text()) if RESULTS.exists() and argv else {}
    record.setdefault("experiments", {})
    t0 = time.perf_counter()
    for n in names:
        r = measure(n)
        record["experiments"][n] = r
        print(f"{n:38s} {r['runs']:6d} runs  {r['cpu_per_run']:9.4f} s/run  "
              f"{r['cpu_estimate'] / 60:8.1f} CPU-min  (sample {len(r['sample'])})", flush=True)
    record["machine"] = machine_description()
    record["load_average_end"] = load_average()
    record["date_utc"] = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    record["measure_wall_seconds"] = round(time.perf_counter() - t0, 1)
    RESULTS.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    total = sum(r["cpu_estimate"] for r in record["experiments"].values())
    print(f"{len(record['experiments'])} experiments: {total / 3600:.2f} CPU-hours serially")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
