"""The ``exec-stats`` directive: the page "Execution statistics", rendered at build time.

It reads ``.ci/exec_stats.json``, written by the pytest hook in ``book/conftest.py`` at
every test session that executes notebooks (not in git), and renders one row per
notebook of the book: wall time of its last strict nbval run, status, cells, date and
commit of that run, and the Monte Carlo runs the notebook re-simulated to check its
stored results (read from the notebook's stored outputs, the lines "re-simulated k of N
stored runs" that :func:`trackcore.experiments.verify_sample` prints; strict nbval makes
those equal to the fresh run's). Without a record it says so plainly.

The ``store-runs`` directive renders one row per registered experiment: its notebook, its
run count before the experiment store existed (``book/appendix/run_counts.yml``), its run
count now, and the CPU time a run takes and the whole experiment would take to regenerate
(``benchmarks/results/regen_times.json``, written by ``python -m benchmarks.regen_times``).
"""
from __future__ import annotations

import json
import re
from pathlib import Path

from docutils import nodes
from sphinx.util.docutils import SphinxDirective

_ROOT = Path(__file__).resolve().parents[2]
STATS_FILE = _ROOT / ".ci" / "exec_stats.json"
_VERIFIED = re.compile(r"re-simulated (\d+) of (\d+) stored runs")


def _notebooks():
    return sorted(p.relative_to(_ROOT).as_posix() for p in (_ROOT / "book").rglob("*.ipynb")
                  if ".ipynb_checkpoints" not in p.parts and "_build" not in p.parts)


def runs_verified(path: Path):
    """(checked, stored) summed over the verification lines of a notebook's outputs."""
    try:
        nb = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    checked = stored = 0
    for cell in nb.get("cells", []):
        for out in cell.get("outputs", []):
            text = out.get("text", "")
            text = "".join(text) if isinstance(text, list) else text
            for k, n in _VERIFIED.findall(text):
                checked, stored = checked + int(k), stored + int(n)
    return (checked, stored) if stored else None


def _table(header, rows, widths):
    table = nodes.table(classes=["exec-stats"])
    group = nodes.tgroup(cols=len(header))
    table += group
    for w in widths:
        group += nodes.colspec(colwidth=w)
    thead = nodes.thead()
    group += thead
    body = nodes.tbody()
    group += body
    for target, cells in ((thead, [header]), (body, rows)):
        for cells_row in cells:
            row = nodes.row()
            for c in cells_row:
                entry = nodes.entry()
                entry += nodes.paragraph(text=str(c))
                row += entry
            target += row
    return table


class ExecStats(SphinxDirective):
    has_content = False

    def run(self):
        self.env.note_dependency(str(STATS_FILE))
        try:
            stats = json.loads(STATS_FILE.read_text())
        except (OSError, ValueError):
            stats = None
        if not stats:
            return [nodes.paragraph(text=(
                "No test run is on record in this checkout: .ci/exec_stats.json does not "
                "exist (it is written by pytest and is not part of the repository). Run "
                "pytest (or pytest on some notebooks) and rebuild the book to fill this "
                "table."))]
        rows, total, n_ok = [], 0.0, 0
        for nb in _notebooks():
            rec = stats.get(nb)
            ver = (rec or {}).get("runs_verified") or runs_verified(_ROOT / nb)
            ver_txt = f"{ver[0]} of {ver[1]}" if ver else "—"
            if rec is None:
                rows.append((nb, "—", "no record", "—", ver_txt, "—"))
                continue
            total += rec["seconds"]
            n_ok += rec["status"] == "passed"
            rows.append((nb, f"{rec['seconds']:.1f}", rec["status"],
                         f"{rec['cells']}" + (f" ({rec['failed_cells']} failed)"
                                              if rec.get("failed_cells") else ""),
                         ver_txt, f"{rec['date']}, {rec.get('commit') or '?'}"))
        dates = sorted(r["date"] for r in stats.values())
        intro = nodes.paragraph(text=(
            f"{len(stats)} notebooks on record, {n_ok} passed; their times add up to "
            f"{total / 60:.1f} min of notebook execution (one process each; the test "
            f"suite runs two at a time). Records from {dates[0]} to {dates[-1]}."))
        header = ("notebook", "wall time (s)", "status", "cells",
                  "Monte Carlo runs re-simulated (of stored)", "recorded (UTC), commit")
        return [intro, _table(header, rows, (34, 10, 8, 8, 14, 22))]


RUN_COUNTS = _ROOT / "book" / "appendix" / "run_counts.yml"
REGEN_FILE = _ROOT / "benchmarks" / "results" / "regen_times.json"


def store_rows():
    """Rows (experiment, notebook, runs before, runs now, CPU s per run, CPU min to
    regenerate) and the totals dict, from the registry, run_counts.yml and regen_times.json."""
    import yaml

    from trackcore import experiments

    before = yaml.safe_load(RUN_COUNTS.read_text())["before"]
    try:
        regen = json.loads(REGEN_FILE.read_text())
    except (OSError, ValueError):
        regen = {"experiments": {}}
    rows = []
    tot = {"before": 0, "now_old": 0, "now_new": 0, "cpu": 0.0, "measured": 0,
           "stored": 0, "experiments": 0, "date": regen.get("date_utc", "—")}
    for name in experiments.names():
        exp = experiments.get(name)
        b = before.get(name)
        m = regen["experiments"].get(name)
        stored = experiments.status(name) == "current"
        tot["experiments"] += 1
        tot["stored"] += stored
        if b is not None:
            tot["before"] += b
            tot["now_old"] += exp.runs
        else:
            tot["now_new"] += exp.runs
        if m:
            tot["cpu"] += m["cpu_estimate"]
            tot["measured"] += 1
        rows.append((name, Path(exp.notebook).stem if exp.notebook else "—",
                     "new" if b is None else f"{b}", f"{exp.runs}" + ("" if stored else " (not run)"),
                     f"{m['cpu_per_run']:.3g}" if m else "—",
                     f"{m['cpu_estimate'] / 60:.1f}" if m else "—"))
    return rows, tot


class StoreRuns(SphinxDirective):
    has_content = False

    def run(self):
        self.env.note_dependency(str(RUN_COUNTS))
        self.env.note_dependency(str(REGEN_FILE))
        rows, t = store_rows()
        intro = nodes.paragraph(text=(
            f"{t['experiments']} registered experiments, {t['stored']} with stored results. "
            f"The experiments that existed before the store had {t['before']} runs in all and "
            f"have {t['now_old']} now; the new ones add {t['now_new']}. Regenerating the "
            f"{t['measured']} measured stores takes {t['cpu'] / 3600:.1f} CPU-hours run "
            f"serially (measured {t['date']} UTC), so about {t['cpu'] / 120:.0f} minutes on two "
            f"worker processes or a two-worker LocalCluster if two workers run twice as fast."))
        header = ("experiment", "notebook", "runs before the store", "runs now",
                  "CPU per run (s)", "CPU to regenerate (min)")
        return [intro, _table(header, rows, (30, 24, 10, 10, 10, 12))]


def setup(app):
    app.add_directive("exec-stats", ExecStats)
    app.add_directive("store-runs", StoreRuns)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
