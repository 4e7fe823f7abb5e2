"""Whole-book execution time, cold, per notebook and per chapter.

    python -m benchmarks.book_times            # every notebook of the book (about 10 min)
    python -m benchmarks.book_times 003-tbd-pf # one chapter directory under book/

For every chapter directory (in the table-of-contents order) the numba on-disk caches of
``trackcore`` and ``benchmarks`` are deleted first, so the chapter's first notebook pays for
compiling every kernel it uses -- what a reader with a fresh clone pays.  Each notebook is
then executed top to bottom by ``nbclient`` (the engine behind ``jupyter execute`` and the
book build) in a fresh kernel, one notebook at a time, and its wall time and the kernel's
CPU time are recorded.  Nothing is written to the notebooks.

Results go to ``benchmarks/results/book_times.json`` with the machine description (the load
average is part of it: on a shared machine the wall time includes waiting for a core).  The
appendix "Performance" plots that file.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ._common import load_average, machine_description

ROOT = Path(__file__).resolve().parent.parent
RESULTS = Path(__file__).resolve().parent / "results" / "book_times.json"
CHAPTERS = ("000-hpda", "001-tom-imm", "002-sprt-acm", "003-tbd-pf", "004-feature-jpda",
            "appendix")

# Executed at the end of every notebook, inside its kernel: the kernel's CPU time (all threads).
_CPU_PROBE = "import time as _t, resource as _r; print(_t.process_time(), " \
             "_r.getrusage(_r.RUSAGE_CHILDREN).ru_utime + _r.getrusage(_r.RUSAGE_CHILDREN).ru_stime)"


def clear_numba_caches() -> int:
    """Delete numba's on-disk caches (``*.nbi``, ``*.nbc``) under trackcore/ and benchmarks/;
    returns the number of files removed."""
    n = 0
    for sub in ("trackcore", "benchmarks"):
        for pattern in ("*.nbi", "*.nbc"):
            for f in (ROOT / sub).rglob(pattern):
                f.unlink()
                n += 1
    return n


def time_notebook(path: Path, timeout: int = 1800) -> dict:
    """Execute one notebook in a fresh kernel: wall seconds, the kernel's own CPU seconds and
    the CPU seconds of the child processes the kernel reaped (fork-started process pools).
    Workers of a forkserver pool (``trackcore.montecarlo.process_pool``) are grandchildren
    and are not counted; the wall time is the figure of record."""
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(_CPU_PROBE))
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3",
                            resources={"metadata": {"path": str(path.parent)}})
    t0 = time.perf_counter()
    client.execute()
    wall = time.perf_counter() - t0
    out = nb.cells[-1].outputs[0]["text"].split()
    return {"notebook": str(path.relative_to(ROOT)), "wall_seconds": round(wall, 2),
            "kernel_cpu_seconds": round(float(out[0]), 2),
            "worker_cpu_seconds": round(float(out[1]), 2)}


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    chosen = argv or list(CHAPTERS)
    unknown = [c for c in chosen if c not in CHAPTERS]
    if unknown:
        print(f"unknown chapter(s) {unknown}; choose from {CHAPTERS}")
        return 2
    previous = json.loads(RESULTS.read_text()) if RESULTS.exists() else {"notebooks": []}
    rows = [r for r in previous.get("notebooks", []) if r["chapter"] not in chosen]
    machine = machine_description()
    for chapter in chosen:
        removed = clear_numba_caches()
        for path in sorted((ROOT / "book" / chapter).glob("*.ipynb")):
            r = time_notebook(path)
            r.update(chapter=chapter, cold_cache_files_removed=removed,
                     load_average_1_5_15min=load_average())
            removed = 0
            rows.append(r)
            print(json.dumps(r), flush=True)
            _write(machine, rows)   # after every notebook: a failure keeps what was measured
    print(f"wrote {RESULTS}")
    return 0


def _write(machine: dict, rows: list) -> None:
    order = {c: i for i, c in enumerate(CHAPTERS)}
    rows.sort(key=lambda r: (order[r["chapter"]], r["notebook"]))
    machine["load_average_at_end_1_5_15min"] = load_average()
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps({"machine": machine, "notebooks": rows}, indent=1) + "\n")


if __name__ == "__main__":
    raise SystemExit(main())
