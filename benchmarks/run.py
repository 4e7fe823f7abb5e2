"""Run every benchmark and write benchmarks/results/benchmarks.json.

    python -m benchmarks.run            # all workloads (several minutes on 2 cores)
    python -m benchmarks.run kf imm     # a subset (other rows kept; each row records when
                                        # and at which commit it was measured)

Workloads: kf, imm, pf, phd, jpda, hpda, marcum, roofline.

Each workload runs trackcore and its peer (filterpy or Stone Soup) on the same inputs in
the same process, checks that they agree, and records the median process CPU time per step
(wall time beside it; see ``_common.Stopwatch`` for why CPU time on a shared machine). The book's
appendix "Performance" plots the JSON file; it never times anything itself.
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

from ._common import load_average, machine_description

# Single-threaded BLAS for the peers (and numpy): a per-core comparison.  Must be set before
# numpy is imported, i.e. run the benchmarks as ``python -m benchmarks.run``.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

RESULTS = Path(__file__).resolve().parent / "results" / "benchmarks.json"


def _workloads():
    from . import bench_association, bench_filters, bench_marcum, bench_pf, bench_phd, roofline
    items = {
        "kf": bench_filters.bench_kf,
        "imm": bench_filters.bench_imm,
        "pf": bench_pf.bench_pf,
        "phd": bench_phd.bench_phd,
    }
    items.update(bench_association.WORKLOADS)
    items.update(bench_marcum.WORKLOADS)
    return items, roofline.run


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    items, roofline = _workloads()
    chosen = argv or list(items)
    unknown = [a for a in chosen if a not in items and a != "roofline"]
    if unknown:
        print(f"unknown workload(s) {unknown}; choose from {sorted(items)} or roofline")
        return 2
    previous = json.loads(RESULTS.read_text()) if RESULTS.exists() else {"results": []}
    kept = [r for r in previous.get("results", []) if r.get("key") not in chosen]
    machine = machine_description()
    out = {"machine": machine, "results": kept,
           "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS")}
    for key in chosen:
        if key == "roofline":
            continue
        t0 = time.perf_counter()
        rows = items[key]()
        for r in rows:
            r["key"] = key
            r["measured"] = {"date": machine["date"], "commit": machine["commit"],
                             "load_average_1_5_15min": machine["load_average_1_5_15min"]}
            print(json.dumps(r))
        out["results"].extend(rows)
        print(f"# {key}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    if not argv or "roofline" in argv:
        out["roofline"] = roofline()
    elif "roofline" in previous:
        out["roofline"] = previous["roofline"]
    out["machine"]["load_average_at_end_1_5_15min"] = load_average()
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(out, indent=1, sort_keys=True) + "\n")
    print(f"wrote {RESULTS}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
