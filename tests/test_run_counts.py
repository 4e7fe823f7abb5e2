"""The run counts of the book's experiments before the store, and the regeneration record.

``book/appendix/run_counts.yml`` gives each registered experiment's run count before the
experiment store existed (or null for an experiment added since); the appendix "Execution
statistics" renders it beside today's counts and the measured cost of regenerating each store
(``benchmarks/results/regen_times.json``).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
import yaml

from trackcore import experiments

ROOT = Path(__file__).resolve().parents[1]
BEFORE = yaml.safe_load((ROOT / "book" / "appendix" / "run_counts.yml").read_text())["before"]
REGEN = json.loads((ROOT / "benchmarks" / "results" / "regen_times.json").read_text())


def test_every_registered_experiment_has_a_before_count():
    names = set(experiments.names())
    assert not names - set(BEFORE), f"run_counts.yml lacks {sorted(names - set(BEFORE))}"
    assert not set(BEFORE) - names, f"run_counts.yml lists unknown {sorted(set(BEFORE) - names)}"


@pytest.mark.parametrize("name", sorted(n for n, b in BEFORE.items() if b is not None))
def test_no_experiment_has_fewer_runs_than_before_the_store(name):
    runs = experiments.get(name).runs
    assert runs >= BEFORE[name], f"{name}: {runs} runs now, {BEFORE[name]} before the store"


def test_regeneration_record_matches_the_registry():
    rec = REGEN["experiments"]
    unknown = set(rec) - set(experiments.names())
    assert not unknown, f"regen_times.json measures unregistered experiments {sorted(unknown)}"
    for name, m in rec.items():
        assert m["runs"] == experiments.get(name).runs, (
            f"{name}: measured on a {m['runs']}-run store, registered with "
            f"{experiments.get(name).runs} runs; re-run python -m benchmarks.regen_times {name}")
        assert m["cpu_per_run"] > 0 and len(m["sample"]) >= 1, f"{name}: empty measurement"
        assert m["cpu_estimate"] == pytest.approx(m["cpu_per_run"] * m["runs"], rel=1e-3, abs=0.1)


def test_store_runs_table_renders_every_experiment():
    sys.path.insert(0, str(ROOT / "book" / "_ext"))
    try:
        import exec_stats
    finally:
        sys.path.pop(0)
    rows, tot = exec_stats.store_rows()
    assert [r[0] for r in rows] == experiments.names(), "one row per registered experiment"
    assert tot["now_old"] >= tot["before"], f"fewer runs now: {tot}"


def test_spread_indices():
    # benchmarks/ is a folder of the repository, not an installed package
    sys.path.insert(0, str(ROOT))
    try:
        from benchmarks.regen_times import spread_indices
    finally:
        sys.path.remove(str(ROOT))

    assert spread_indices(100, 3) == [0, 50, 99]
    assert spread_indices(2, 5) == [0, 1]
    with pytest.raises(ValueError, match="runs and k"):
        spread_indices(0, 3)
