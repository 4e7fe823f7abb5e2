"""Execution statistics of the notebooks: one small pytest hook, nothing else.

Every test session that executes notebooks (``pytest --nbval``, as configured in
``pyproject.toml``) merges, per notebook, its wall time (the sum of its cells' setup,
call and teardown), its status, its cell counts and the Monte Carlo runs it re-simulated to
check its stored results into ``.ci/exec_stats.json`` (not in
git). The appendix page "Execution statistics" is rendered from that file at build time
(``book/_ext/exec_stats.py``). Under pytest-xdist the controller records (the workers'
reports reach it); the workers do not write.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import time
from collections import defaultdict
from pathlib import Path

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
                                capture_output=True, text=True, timeout=10).stdout.strip()
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
