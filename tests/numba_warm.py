"""Compile trackcore's numba kernels into their on-disk cache once, on every core, before
the whole test suite starts (``book/conftest.py`` calls :func:`warm` from the pytest-xdist
controller when the cache is empty).

From a clean clone no kernel is compiled yet, and numba does not coordinate processes: two
xdist workers (or two notebook kernels) that reach the same kernel at the same time both
compile it (the HPDA-PF kernel alone takes about 20 s) and the second copy is wasted. Here
the modules' docstring examples, which call almost every kernel, run in a pool of
processes that takes one module at a time, the modules with the most kernels first; the
compiled kernels land in numba's cache, from which every later process loads them. The
examples' results are discarded: ``tests/test_doctests.py`` checks them.
"""
from __future__ import annotations

import contextlib
import doctest
import importlib
import io
import multiprocessing
import os
import pkgutil
import re
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
_JIT = re.compile(r"@(?:nb\.|numba\.)?(?:njit|jit)\b")


def kernel_modules(root: Path = ROOT) -> list[str]:
    """The modules of trackcore that define numba kernels, the most kernels first."""
    import trackcore

    found = []
    for info in pkgutil.walk_packages(trackcore.__path__, "trackcore."):
        if info.ispkg or info.name.endswith("__main__"):
            continue
        path = root / (info.name.replace(".", "/") + ".py")
        try:
            n = len(_JIT.findall(path.read_text(encoding="utf-8")))
        except OSError:
            continue
        if n:
            found.append((-n, info.name))
    return [name for _, name in sorted(found)]


def cache_is_empty(root: Path = ROOT) -> bool:
    """True when numba's cache holds no kernel of trackcore yet."""
    base = os.environ.get("NUMBA_CACHE_DIR")
    where = Path(base) if base else root / "trackcore"
    return not where.is_dir() or next(where.rglob("*.nbi"), None) is None


def _run_examples(module_name: str) -> tuple[str, float]:
    """Run one module's docstring examples (their output discarded); its seconds."""
    t0 = time.perf_counter()
    # a failing or unimportable module is test_doctests.py's to report
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()), \
            contextlib.suppress(Exception):
        module = importlib.import_module(module_name)
        finder = doctest.DocTestFinder(exclude_empty=True)
        runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
        for test in finder.find(module, module_name):
            runner.run(test)
    return module_name, time.perf_counter() - t0


def warm(processes: int = 2) -> list[tuple[str, float]]:
    """Compile the kernels that the examples reach, ``processes`` modules at a time;
    ``[(module, seconds)]`` in the order they finished."""
    if isinstance(processes, bool) or not isinstance(processes, int) or processes < 1:
        raise ValueError(f"processes must be a positive integer, got {processes!r}")
    modules = kernel_modules()
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=processes, mp_context=ctx) as ex:
        return list(ex.map(_run_examples, modules, chunksize=1))


if __name__ == "__main__":
    t = time.perf_counter()
    done = warm()
    for name, s in done:
        print(f"{s:7.1f} s  {name}")
    print(f"{time.perf_counter() - t:.1f} s in all")
