"""Re-verifying stored rows as on another CPU: an x86-64 machine without AVX-512.

The stored rows were computed on a CPU with AVX-512 (the book's machine), where numpy
dispatches its kernels (sums, ``linalg``) to AVX-512 code, OpenBLAS picks its SkylakeX
kernels and numba compiles for the host.  A reader's laptop without AVX-512 rounds some
sums differently in the last bits (differences of 1e-14 to 1e-11 relative were measured
in the TBD and HPDA trials).  :data:`EMULATED_CPU_ENV` is the one place that says how
such a machine is emulated here:

* ``NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL AVX512_SPR"``: numpy's AVX-512 dispatch
  targets off (on numpy 2.x the tier ``X86_V4`` must be named; naming only the
  ``AVX512*`` features leaves it on);
* ``OPENBLAS_CORETYPE=Haswell``: OpenBLAS (numpy's and scipy's) uses its AVX2 kernels,
  as it does on a CPU without AVX-512 (``NPY_DISABLE_CPU_FEATURES`` does not reach it);
* ``NUMBA_CPU_NAME=generic``: numba compiles for a generic x86-64, in a fresh
  ``NUMBA_CACHE_DIR`` so that no kernel compiled for the host is reused.

``python -m trackcore.experiments verify --emulate-cpu ...`` runs the verification in a
child process with this environment, after :func:`check_emulation` has confirmed inside
it that the settings took effect.
"""
from __future__ import annotations

import ctypes
import glob
import os
from pathlib import Path

#: The environment of an emulated x86-64 CPU without AVX-512 (see the module docstring).
EMULATED_CPU_ENV = {
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
    "OPENBLAS_CORETYPE": "Haswell",
    "NUMBA_CPU_NAME": "generic",
}
#: Set in the child process of ``verify --emulate-cpu`` (so that it does not re-launch).
MARKER = "TRACKCORE_EMULATED_CPU"
#: OpenBLAS kernel families that use AVX-512.
_AVX512_OPENBLAS = {"skylakex", "cooperlake", "sapphirerapids"}


def emulated_env(cache_dir, base=None) -> dict:
    """A copy of ``base`` (default ``os.environ``) with :data:`EMULATED_CPU_ENV`,
    ``NUMBA_CACHE_DIR=cache_dir`` (give an empty directory) and :data:`MARKER` set."""
    if not isinstance(cache_dir, (str, os.PathLike)):
        raise TypeError(f"cache_dir must be a path, got {type(cache_dir).__name__}")
    env = dict(os.environ if base is None else base)
    env.update(EMULATED_CPU_ENV)
    env["NUMBA_CACHE_DIR"] = str(cache_dir)
    env[MARKER] = "1"
    return env


def _openblas_cores() -> dict:
    """{library file: OpenBLAS kernel family} of the OpenBLAS libraries bundled with
    numpy and scipy (empty if none is found, e.g. a build against a system BLAS)."""
    import numpy

    out = {}
    site = Path(numpy.__file__).resolve().parent.parent
    for lib in sorted(glob.glob(str(site / "numpy.libs" / "*openblas*"))
                      + glob.glob(str(site / "scipy.libs" / "*openblas*"))):
        try:
            handle = ctypes.CDLL(lib)
        except OSError:
            continue
        for symbol in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename",
                       "openblas_get_corename64_", "openblas_get_corename"):
            fn = getattr(handle, symbol, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                out[Path(lib).name] = fn().decode()
                break
    return out


def emulation_state() -> dict:
    """What this process runs on: numpy's enabled dispatch targets, numba's target CPU
    and cache directory, and the OpenBLAS kernel families."""
    from numpy._core import _multiarray_umath as umath
    from numba.core import config

    features = umath.__cpu_features__
    return {
        "numpy_dispatch": [t for t in umath.__cpu_dispatch__ if features.get(t)],
        "numba_cpu": config.CPU_NAME or "host",
        "numba_cache_dir": config.CACHE_DIR or "",
        "openblas": _openblas_cores(),
    }


def check_emulation(state=None) -> str:
    """Raise ``RuntimeError`` unless this process (or ``state``, an
    :func:`emulation_state`) runs as a CPU without AVX-512; return a one-line summary."""
    state = emulation_state() if state is None else state
    problems = []
    wide = [t for t in state["numpy_dispatch"] if t == "X86_V4" or t.startswith("AVX512")]
    if wide:
        problems.append(f"numpy still dispatches to {', '.join(wide)} "
                        f"(NPY_DISABLE_CPU_FEATURES={os.environ.get('NPY_DISABLE_CPU_FEATURES')!r})")
    if state["numba_cpu"] != "generic":
        problems.append(f"numba compiles for {state['numba_cpu']!r}, not 'generic' "
                        f"(NUMBA_CPU_NAME)")
    wide_blas = {k: v for k, v in state["openblas"].items() if v.lower() in _AVX512_OPENBLAS}
    if wide_blas:
        problems.append(f"OpenBLAS uses AVX-512 kernels {wide_blas} (OPENBLAS_CORETYPE)")
    if problems:
        raise RuntimeError("the CPU emulation is not in effect: " + "; ".join(problems))
    blas = ", ".join(sorted(set(state["openblas"].values()))) or "not found"
    return (f"emulated CPU without AVX-512: numpy dispatch targets "
            f"{', '.join(state['numpy_dispatch']) or 'baseline only'}; OpenBLAS kernels "
            f"{blas}; numba target {state['numba_cpu']}, cache {state['numba_cache_dir']}")
