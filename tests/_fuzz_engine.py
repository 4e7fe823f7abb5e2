"""Machinery of the fuzz suite (``tests/test_fuzz_public_api.py``).

* :func:`public_callables` lists every public callable of the fuzzed packages, read from
  their ``__all__``, so a new function is fuzzed without editing the suite.
* :func:`case_specs` turns a valid example call into the cases of one function: the valid
  call itself, then mutations of each argument (wrong ndim or length, NaN, inf, 1e300,
  1e-300, negative or out-of-range values, non-PSD covariances, empty inputs, int, Fortran
  and strided arrays, wrong types, records with a bad field).
* :class:`Runner` runs the cases of a function in a child process (``spawn``, so the child
  never inherits threads of the test process) that it watches from outside: a case that
  uses more than its CPU-time limit is a hang (the child is killed, so a numba loop that
  never returns fails the test instead of hanging the suite); a child that dies is a crash.
  The child classifies everything else (:func:`classify`).
* A numba kernel that writes out of bounds may corrupt memory without crashing at once
  (glibc may only notice at a later ``free``, e.g. when the child exits).  With the
  environment variable ``TRACKCORE_FUZZ_BOUNDSCHECK=1`` the child compiles every kernel
  with bounds checks (``NUMBA_BOUNDSCHECK=1``, in a numba cache of its own under the
  temporary directory), so each such access is reported at the case that makes it.

Nothing here decides what is acceptable: the test file holds the policy tables.
"""
from __future__ import annotations

import copy
import dataclasses
import importlib
import inspect
import math
import multiprocessing
import numbers
import os
import time
import traceback
import warnings

import numpy as np

PACKAGES = (
    "trackcore.core",
    "trackcore.models",
    "trackcore.filters",
    "trackcore.association",
    "trackcore.detection",
    "trackcore.trackers",
    "trackcore.scenarios",
    "trackcore.metrics",
    "trackcore.stats",
    "trackcore.montecarlo",
    "trackcore.plotting",
)

#: CPU seconds a mutated call may use before it counts as a hang
CASE_CPU_LIMIT = 5.0
#: CPU seconds for the valid call, which may include compiling numba kernels on a cold cache
VALID_CPU_LIMIT = 300.0
#: wall-clock limit of a mutated call (one blocked on something other than the CPU)
CASE_WALL_LIMIT = 120.0
#: wall-clock limit of the valid call (compiling on a loaded machine)
VALID_WALL_LIMIT = 900.0


# ------------------------------------------------------------------ public surface
def is_kernel(obj) -> bool:
    try:
        from numba.core.registry import CPUDispatcher
    except ImportError:  # pragma: no cover
        return False
    return isinstance(obj, CPUDispatcher)


def public_names():
    """``{package: [names in __all__]}`` of the fuzzed packages (a package or module
    without ``__all__`` gives ``None``)."""
    out = {}
    for pkg in PACKAGES:
        mod = importlib.import_module(pkg)
        names = getattr(mod, "__all__", None)
        out[pkg] = None if names is None else list(names)
    return out


def public_callables():
    """``{name: (package, object)}`` of every public callable that is not a numba kernel.

    Raises ``RuntimeError`` when two packages export different objects under one name
    (the suite keys its tables by bare name)."""
    out = {}
    for pkg, names in public_names().items():
        mod = importlib.import_module(pkg)
        for name in names or ():
            obj = getattr(mod, name)
            if not callable(obj) or is_kernel(obj):
                continue
            if name in out and out[name][1] is not obj:
                raise RuntimeError(f"{name} is exported by both {out[name][0]} and {pkg}")
            out[name] = (pkg, obj)
    return out


def resolve(name):
    return public_callables()[name][1]


# ------------------------------------------------------------------ examples
class Example:
    """A valid call: positional and keyword arguments; ``cpu_limit`` overrides
    :data:`CASE_CPU_LIMIT` for the mutated calls of a slow function; ``skip`` names
    arguments not to mutate (with the reason given in the example table)."""

    def __init__(self, *args, **kwargs):
        self.args = args
        self.kwargs = kwargs
        self.skip = {}
        self.cpu_limit = CASE_CPU_LIMIT
        self.extras = []

    def rejects(self, case_id, *args, match=None, **kwargs):
        """An extra case (a known hard input) that must raise ``ValueError`` or
        ``TypeError``, with a message matching the regular expression ``match``."""
        self.extras.append((case_id, args, kwargs, "error", match))
        return self

    def accepts(self, case_id, *args, **kwargs):
        """An extra case that must return a finite result (or raise a clear error)."""
        self.extras.append((case_id, args, kwargs, "any", None))
        return self

    def no_mutate(self, **reasons):
        self.skip.update(reasons)
        return self

    def limit(self, seconds):
        self.cpu_limit = float(seconds)
        return self


def call(*args, **kwargs) -> Example:
    return Example(*args, **kwargs)


# ------------------------------------------------------------------ mutations
def _is_prob_array(a) -> bool:
    return a.size > 0 and np.all((a >= 0) & (a <= 1))


def _float_array_mutations(a):
    """Mutations of a float (or integer-valued) array argument."""
    out = []
    a = np.asarray(a)
    fa = a.astype(np.float64)
    flat_idx = 0
    if fa.size:
        for tag, v in (("nan", np.nan), ("inf", np.inf), ("-inf", -np.inf), ("1e300", 1e300)):
            b = fa.copy()
            b.flat[flat_idx] = v
            out.append((tag, b))
        out.append(("*1e-300", fa * 1e-300))
        if np.any(fa != 0):
            b = fa.copy()
            nz = int(np.flatnonzero(fa)[0])
            b.flat[nz] = -abs(b.flat[nz]) if b.flat[nz] > 0 else abs(b.flat[nz])
            out.append(("sign", b))
        if _is_prob_array(fa):
            for tag, v in (("-0.1", -0.1), ("1.1", 1.1)):
                b = fa.copy()
                b.flat[flat_idx] = v
                out.append((tag, b))
    # shapes
    out.append(("ndim+1", fa[np.newaxis]))
    if fa.ndim >= 1:
        out.append(("ndim-1", fa[0] if fa.shape[0] else np.zeros(fa.shape[1:])))
        out.append(("len+1", np.concatenate([fa, fa[:1] if fa.shape[0] else
                                              np.zeros((1,) + fa.shape[1:])], axis=0)))
        out.append(("empty", fa[:0]))
        if fa.ndim >= 2:
            out.append(("cols+1", np.concatenate([fa, fa[..., :1]], axis=-1)))
            if fa.shape[-1] > 1:
                out.append(("cols=1", fa[..., :1]))
    if fa.ndim == 2 and fa.shape[0] == fa.shape[1] and fa.shape[0] >= 2:
        sym = np.allclose(fa, fa.T)
        if sym:
            b = fa.copy()
            b[0, 1] += 1.0 + abs(b[0, 1])
            out.append(("asymmetric", b))
            lam = np.linalg.eigvalsh(0.5 * (fa + fa.T))
            if lam[0] >= 0:
                b = fa.copy()
                b[0, 0] = -1.0 - abs(b[0, 0])
                out.append(("non-psd", b))
    # layouts (the result must equal the valid call's)
    if fa.ndim >= 2:
        out.append(("fortran", np.asfortranarray(fa)))
    if fa.ndim >= 1 and fa.shape[0] > 0:
        big = np.repeat(fa, 2, axis=0)
        out.append(("strided", big[::2]))
    if fa.size and np.all(fa == np.round(fa)) and np.all(np.abs(fa) < 2**31):
        out.append(("int", fa.astype(np.int64)))
    return out


#: mutations that only change the memory layout or dtype: the result must not change
LAYOUT_TAGS = {"fortran", "strided", "int"}


def _scalar_mutations(v):
    out = [("nan", math.nan), ("inf", math.inf), ("-inf", -math.inf), ("1e300", 1e300),
           ("1e-300", 1e-300), ("0", 0.0), ("-1", -1.0), ("str", "x"), ("None", None)]
    if isinstance(v, float) and 0.0 <= v <= 1.0:
        out += [("-0.1", -0.1), ("1.1", 1.1)]
    if float(v) != 0.0:
        out.append(("neg", -float(v)))
    out.append(("array2", np.array([float(v), float(v)])))
    return out


def _int_mutations(v):
    return [("-1", -1), ("0", 0), ("2.5", 2.5), ("nan", math.nan), ("inf", math.inf),
            ("1e300", 1e300), ("2**70", 2**70), ("str", "x"), ("None", None),
            ("float", float(v))]


def _namedtuple_mutations(t):
    out = []
    for f in t._fields:
        v = getattr(t, f)
        if isinstance(v, (bool, np.bool_)):
            continue
        if isinstance(v, numbers.Integral):
            out.append((f"{f}=-1", t._replace(**{f: -1})))
            continue
        if isinstance(v, numbers.Real):
            out.append((f"{f}=nan", t._replace(**{f: math.nan})))
            if 0.0 <= v <= 1.0:
                out.append((f"{f}=1.1", t._replace(**{f: 1.1})))
            elif v > 0:
                out.append((f"{f}=-{v:g}", t._replace(**{f: -float(v)})))
            continue
        if isinstance(v, np.ndarray) and v.dtype.kind == "f" and v.size:
            b = v.copy()
            b.flat[0] = np.nan
            out.append((f"{f}[0]=nan", t._replace(**{f: b})))
    return out


def _dataclass_mutations(d):
    out = []
    for f in dataclasses.fields(d):
        if not f.init:
            continue
        v = getattr(d, f.name)
        if isinstance(v, (bool, np.bool_)):
            continue
        if isinstance(v, numbers.Integral):
            out.append((f"{f.name}=-1", (d, {f.name: -1})))
        elif isinstance(v, numbers.Real):
            out.append((f"{f.name}=nan", (d, {f.name: math.nan})))
            if 0.0 <= v <= 1.0:
                out.append((f"{f.name}=1.1", (d, {f.name: 1.1})))
            elif v > 0:
                out.append((f"{f.name}=-{v:g}", (d, {f.name: -float(v)})))
    return out


class _Replace:
    """A dataclass with fields replaced, built inside the case (construction may raise)."""

    def __init__(self, obj, changes):
        self.obj = obj
        self.changes = changes

    def build(self):
        return dataclasses.replace(self.obj, **self.changes)


def mutations(value):
    """``[(tag, mutated value)]`` for one argument's valid value."""
    if isinstance(value, (bool, np.bool_)):
        return [("str", "x"), ("None", None), ("nan", math.nan)]
    if isinstance(value, np.random.Generator):
        return [("None", None), ("seed", 0)]
    if isinstance(value, str):
        return [("bogus", "no-such-option"), ("None", None), ("number", 3)]
    if isinstance(value, numbers.Integral):
        return _int_mutations(value)
    if isinstance(value, numbers.Real):
        return _scalar_mutations(float(value))
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fiu":
            muts = _float_array_mutations(value)
            if value.dtype.kind in "iu":
                muts = [(t, v) for t, v in muts if t not in ("int",)]
                muts.append(("float", value.astype(np.float64)))
            muts.append(("str", "x"))
            return muts
        if value.dtype.kind == "b":
            out = [("ndim+1", value[np.newaxis]), ("str", "x")]
            if value.size:
                b = value.astype(np.float64)
                b.flat[0] = np.nan
                out.append(("nan", b))
                b = value.astype(np.float64)
                b.flat[0] = 2.0
                out.append(("2", b))
            out.append(("empty", value[:0]))
            return out
        return [("None", None)]
    if isinstance(value, tuple) and hasattr(value, "_fields"):
        return _namedtuple_mutations(value) + [("None", None)]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return [(t, _Replace(*v)) for t, v in _dataclass_mutations(value)] + [("None", None)]
    if isinstance(value, (list, tuple)):
        out = [("None", None)]
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            arr = None
        if arr is not None and arr.dtype.kind == "f":
            out += [(t, v) for t, v in _float_array_mutations(arr)
                    if t not in ("fortran", "strided")]
        else:
            out.append(("empty", type(value)() if isinstance(value, list) else ()))
            # mutate the first element that is an array (e.g. a list of scans)
            for i, item in enumerate(value):
                if isinstance(item, np.ndarray) and item.dtype.kind == "f":
                    for t, v in _float_array_mutations(item):
                        if t in LAYOUT_TAGS:
                            continue
                        seq = list(value)
                        seq[i] = v
                        out.append((f"[{i}]{t}", type(value)(seq) if isinstance(value, list)
                                    else tuple(seq)))
                    break
        return out
    if isinstance(value, dict):
        return [("None", None), ("empty", {})]
    if callable(value):
        return [("None", None), ("number", 3)]
    return [("None", None)]


def _arg_items(example: Example, names):
    items = [(names[i] if i < len(names) else f"args[{i}]", ("pos", i), v)
             for i, v in enumerate(example.args)]
    items += [(k, ("kw", k), v) for k, v in example.kwargs.items()]
    return items


def case_specs(example: Example, names):
    """``[(case_id, where, k)]``: the valid call first (``"valid"``, ``where = None``),
    then one case per mutation ``k`` of each argument, ``"<argument>=<tag>"``.  ``names``
    are the parameter names of the positional arguments (from the signature)."""
    specs = [("valid", None, None)]
    seen = set()
    for argname, where, value in _arg_items(example, names):
        if argname in example.skip:
            continue
        for k, (tag, _) in enumerate(mutations(value)):
            cid = f"{argname}={tag}"
            if cid in seen:
                continue
            seen.add(cid)
            specs.append((cid, where, k))
    for j, extra in enumerate(example.extras):
        specs.append((f"issue:{extra[0]}", ("extra", j), None))
    return specs


def build_case(example: Example, spec):
    """``(args, kwargs)`` of one case, applied to a fresh example."""
    _, where, k = spec
    args = list(example.args)
    kwargs = dict(example.kwargs)
    if where is None:
        return tuple(args), kwargs
    if where[0] == "extra":
        _, eargs, ekwargs, _, _ = example.extras[where[1]]
        return tuple(eargs), dict(ekwargs)
    if where[0] == "pos":
        args[where[1]] = mutations(args[where[1]])[k][1]
    else:
        kwargs[where[1]] = mutations(kwargs[where[1]])[k][1]
    return tuple(args), kwargs


def positional_names(func):
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):
        return []
    names = []
    for p in sig.parameters.values():
        if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD):
            names.append(p.name)
        elif p.kind == p.VAR_POSITIONAL:
            names += [f"{p.name}[{i}]" for i in range(8)]
    return names


# ------------------------------------------------------------------ outputs
_SKIP_TYPES = ("Axes", "Figure", "Markdown", "Generator", "SeedSequence", "Executor",
               "ProcessPoolExecutor", "Logger")


def nonfinite_paths(obj, path="out", depth=0, out=None, seen=None):
    """``[(path, kind)]`` of the non-finite numbers in a result (``kind``: ``nan``,
    ``inf`` or ``-inf``)."""
    if out is None:
        out, seen = [], set()
    if depth > 6 or len(out) > 20:
        return out
    if id(obj) in seen and not isinstance(obj, (float, int)):
        return out
    seen.add(id(obj))
    if isinstance(obj, (bool, np.bool_, str, bytes)) or obj is None:
        return out
    if isinstance(obj, (numbers.Real, np.floating)) and not isinstance(obj, numbers.Integral):
        v = float(obj)
        if not math.isfinite(v):
            out.append((path, "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")))
        return out
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc" and obj.size:
            bad = ~np.isfinite(obj)
            if bad.any():
                vals = obj[bad]
                kinds = set()
                if np.isnan(vals).any():
                    kinds.add("nan")
                if np.any(vals == np.inf):
                    kinds.add("inf")
                if np.any(vals == -np.inf):
                    kinds.add("-inf")
                for k in sorted(kinds):
                    out.append((path, k))
        elif obj.dtype == object:
            for i, v in enumerate(obj.flat[:50]):
                nonfinite_paths(v, f"{path}[{i}]", depth + 1, out, seen)
        return out
    if type(obj).__name__ in _SKIP_TYPES or type(obj).__module__.startswith("matplotlib"):
        return out
    if isinstance(obj, tuple) and hasattr(obj, "_fields"):
        for f in obj._fields:
            nonfinite_paths(getattr(obj, f), f"{path}.{f}", depth + 1, out, seen)
        return out
    if isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj[:200]):
            nonfinite_paths(v, f"{path}[{i}]", depth + 1, out, seen)
        return out
    if isinstance(obj, dict):
        for k, v in list(obj.items())[:200]:
            nonfinite_paths(v, f"{path}[{k!r}]", depth + 1, out, seen)
        return out
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            nonfinite_paths(getattr(obj, f.name), f"{path}.{f.name}", depth + 1, out, seen)
        return out
    return out


def same_result(a, b, depth=0) -> bool:
    """Numeric equality of two results (NaN equals NaN); objects that are not numbers,
    arrays or containers of them are not compared."""
    if depth > 6:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a2, b2 = np.asarray(a), np.asarray(b)
        if a2.shape != b2.shape:
            return False
        if a2.dtype == object or b2.dtype == object:
            return all(same_result(x, y, depth + 1) for x, y in zip(a2.flat, b2.flat))
        if a2.dtype.kind in "fc" or b2.dtype.kind in "fc":
            return bool(np.array_equal(a2, b2, equal_nan=True))
        return bool(np.array_equal(a2, b2))
    if isinstance(a, (numbers.Number, np.generic)) and isinstance(b, (numbers.Number,
                                                                       np.generic)):
        if isinstance(a, float) or isinstance(b, float):
            return (a == b) or (math.isnan(float(a)) and math.isnan(float(b)))
        return a == b
    if type(a).__name__ in _SKIP_TYPES or type(a).__module__.startswith("matplotlib"):
        return True
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same_result(x, y, depth + 1) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_result(a[k], b[k], depth + 1) for k in a)
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b):
        return all(same_result(getattr(a, f.name), getattr(b, f.name), depth + 1)
                   for f in dataclasses.fields(a))
    return True


# ------------------------------------------------------------------ the child
#: numpy's LinAlgError and AxisError are ValueErrors (AxisError also an IndexError), but
#: they name no argument of the public call: they count as unclear errors
_NOT_CLEAR = (np.linalg.LinAlgError, IndexError)


def _materialise(v):
    if type(v).__name__ == "_Replace":  # by name: the engine may be loaded twice (__main__)
        return v.build()
    return v


def classify_extra(func, args, kwargs, expect, match, allowed=()):
    """:func:`classify` for an extra case: one that must raise (``expect == "error"``)
    returning is ``accepted`` and an error whose message does not match ``match`` is
    ``unclear-error``."""
    import re

    status, detail, result = classify(func, args, kwargs, None, False, allowed)
    if expect == "error":
        if status in ("ok", "nonfinite", "mismatch"):
            return "accepted", "returned instead of raising ValueError/TypeError", result
        if status == "error" and match and re.search(match, detail) is None:
            return "unclear-error", f"{detail} (should match {match!r})", result
    return status, detail, result


def classify(func, args, kwargs, valid_result, layout, allowed=()):
    """Run one call and classify it: ``(status, detail, result)`` with status
    ``ok`` (returned, every number finite or allowed), ``error``
    (``ValueError``/``TypeError``), ``bad-error`` (another exception), ``nonfinite``
    (detail: the non-finite paths that no entry of ``allowed`` covers) or ``mismatch``
    (a layout mutation whose result differs from the valid call's).  ``allowed`` holds
    ``(path pattern, kinds, check or None, reason)``: a non-finite number is allowed when
    its path matches the pattern (``*`` matches any text; a pattern without ``*`` matches
    the path and everything under it), its kind is listed and ``check(result, args,
    kwargs)`` returns True."""
    import matplotlib.pyplot as plt

    try:
        args = tuple(_materialise(a) for a in args)
        kwargs = {k: _materialise(v) for k, v in kwargs.items()}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with np.errstate(all="ignore"):
                result = func(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        if isinstance(exc, _NOT_CLEAR):  # ValueError subclasses that say nothing to a caller
            return "bad-error", f"{type(exc).__name__}: {str(exc)[:300]}", None
        return "error", f"{type(exc).__name__}: {str(exc)[:300]}", None
    except Exception as exc:  # noqa: BLE001 - classifying every other exception is the point
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" at {tb[-1].filename.split('/')[-1]}:{tb[-1].lineno}" if tb else ""
        return "bad-error", f"{type(exc).__name__}: {str(exc)[:300]}{where}", None
    finally:
        plt.close("all")
    bad = nonfinite_paths(result)
    if bad and allowed:
        ok_pred = {}
        keep = []
        for p, k in bad:
            hit = False
            for j, (pattern, kinds, pred, _) in enumerate(allowed):
                if path_matches(p, pattern) and k in kinds:
                    if pred is None:
                        hit = True
                    else:
                        if j not in ok_pred:
                            try:
                                ok_pred[j] = bool(pred(result, args, kwargs))
                            except Exception:  # noqa: BLE001 - a failing check allows nothing
                                ok_pred[j] = False
                        hit = ok_pred[j]
                    if hit:
                        break
            if not hit:
                keep.append((p, k))
        bad = keep
    if bad:
        return "nonfinite", bad, result
    if layout and valid_result is not None and not same_result(result, valid_result):
        return "mismatch", "result differs from the valid call's", result
    return "ok", "", result


def path_matches(path: str, pattern: str) -> bool:
    """``pattern`` with ``*`` wildcards; without one, ``path`` equal to it or below it."""
    import re

    if "*" not in pattern:
        return path == pattern or path.startswith(pattern + ".") or path.startswith(
            pattern + "[")
    rx = ".*".join(re.escape(part) for part in pattern.split("*"))
    return re.fullmatch(rx, path) is not None


def _cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system


def child_main(conn, examples_module, skip_cases, allowed_nonfinite):
    """Worker loop: ``("run", name, start)`` runs the cases of ``name`` from index
    ``start`` and reports ``("start", i, cid)`` before and ``("done", i, cid, status,
    detail)`` after each case, then ``("end", n_cases)``."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    import matplotlib

    matplotlib.use("Agg")
    try:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (16 << 30, 16 << 30))
    except (ImportError, ValueError, OSError):  # pragma: no cover
        pass
    mod = importlib.import_module(examples_module)
    while True:
        msg = conn.recv()
        if msg[0] == "stop":
            return
        _, name, start = msg
        try:
            func = resolve(name)
            make = mod.EXAMPLES[name]
            example = make()
            names = positional_names(func)
            specs = case_specs(example, names)
        except Exception as exc:  # noqa: BLE001
            conn.send(("setup-error", f"{type(exc).__name__}: {exc}"))
            continue
        conn.send(("n", len(specs), example.cpu_limit))
        ignore = tuple(allowed_nonfinite.get(name, ()))
        valid_result = None
        if start > 0:  # rerun the valid call (not reported) for the layout comparisons
            args, kwargs = build_case(make(), specs[0])
            _, _, valid_result = classify(func, args, kwargs, None, False, ignore)
        for i in range(start, len(specs)):
            cid = specs[i][0]
            if (name, cid) in skip_cases:
                conn.send(("done", i, cid, "skipped", "not run (pending hang)"))
                continue
            conn.send(("start", i, cid, _cpu_seconds()))
            tag = cid.split("=", 1)[-1]
            try:
                args, kwargs = build_case(example if i == 0 else make(), specs[i])
            except Exception as exc:  # noqa: BLE001
                conn.send(("done", i, cid, "setup-error", f"{type(exc).__name__}: {exc}"))
                continue
            t0 = _cpu_seconds()
            if specs[i][1] is not None and specs[i][1][0] == "extra":
                _, _, _, expect, match = example.extras[specs[i][1][1]]
                status, detail, result = classify_extra(func, args, kwargs, expect, match,
                                                        ignore)
            else:
                status, detail, result = classify(func, args, kwargs, valid_result,
                                                  tag in LAYOUT_TAGS, ignore)
            if i == 0:
                valid_result = result
            conn.send(("done", i, cid, status, detail, _cpu_seconds() - t0))
        conn.send(("end", len(specs)))


def _proc_cpu_seconds(pid) -> float | None:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
    except OSError:
        return None
    tck = os.sysconf("SC_CLK_TCK")
    return (int(fields[11]) + int(fields[12])) / tck


class Runner:
    """Runs the cases of one function after another in a watched child process."""

    def __init__(self, examples_module, skip_cases=frozenset(), allowed_nonfinite=None):
        self.examples_module = examples_module
        self.skip_cases = frozenset(skip_cases)
        self.allowed_nonfinite = dict(allowed_nonfinite or {})
        self.ctx = multiprocessing.get_context("spawn")
        self.proc = None
        self.conn = None
        self.restarts = 0
        self.cpu = {}  # (name, case id) -> CPU seconds of the call

    def _start(self):
        parent, child = self.ctx.Pipe()
        self.proc = self.ctx.Process(target=child_main,
                                     args=(child, self.examples_module, self.skip_cases,
                                           self.allowed_nonfinite),
                                     daemon=True)
        saved = dict(os.environ)
        if os.environ.get("TRACKCORE_FUZZ_BOUNDSCHECK"):
            # numba kernels compiled with bounds checks (an out-of-bounds access is an
            # IndexError, a bad error), in a cache of their own outside the repository
            import tempfile

            os.environ["NUMBA_BOUNDSCHECK"] = "1"
            os.environ.setdefault("NUMBA_CACHE_DIR", os.path.join(
                tempfile.gettempdir(), "trackcore-fuzz-boundscheck"))
        try:
            self.proc.start()  # the spawned child takes this environment
        finally:
            os.environ.clear()
            os.environ.update(saved)
        child.close()
        self.conn = parent

    def _kill(self):
        if self.proc is not None:
            self.proc.kill()
            self.proc.join(5)
        self.proc = None
        self.conn = None
        self.restarts += 1

    def close(self):
        """Stop the child; returns its exit code (non-zero: it died on the way out, e.g.
        glibc found a corrupted heap when freeing memory)."""
        code = None
        if self.proc is not None and self.proc.is_alive():
            try:
                self.conn.send(("stop",))
                self.proc.join(30)
            except (OSError, BrokenPipeError):
                pass
            if self.proc.is_alive():
                self.proc.kill()
                self.proc.join(5)
            code = self.proc.exitcode
        self.proc = None
        return code

    def run(self, name):
        """``[(case_id, status, detail)]`` of every case of ``name`` (statuses of
        :func:`classify`, plus ``hang``, ``crash``, ``skipped`` and ``setup-error``)."""
        results = []
        start = 0
        n_cases = None
        limit = CASE_CPU_LIMIT
        while True:
            if self.proc is None or not self.proc.is_alive():
                self._start()
            self.conn.send(("run", name, start))
            current = None  # (index, case id, cpu at start, wall at start)
            ended = False
            while True:
                if self.conn.poll(0.05):
                    try:
                        msg = self.conn.recv()
                    except (EOFError, OSError):
                        msg = None
                    if msg is None:
                        pass
                    elif msg[0] == "setup-error":
                        return [("setup", "setup-error", msg[1])]
                    elif msg[0] == "n":
                        n_cases, limit = msg[1], msg[2]
                        continue
                    elif msg[0] == "start":
                        current = (msg[1], msg[2], msg[3], time.monotonic())
                        continue
                    elif msg[0] == "done":
                        results.append((msg[2], msg[3], msg[4]))
                        self.cpu[(name, msg[2])] = msg[5] if len(msg) > 5 else 0.0
                        current = None
                        continue
                    elif msg[0] == "end":
                        ended = True
                        break
                if not self.proc.is_alive():
                    code = self.proc.exitcode
                    i = current[0] if current else start
                    cid = current[1] if current else "?"
                    results.append((cid, "crash", f"child died (exit code {code})"))
                    self._kill()
                    if current is None or i == 0:  # the valid call itself: stop here
                        return results
                    start = i + 1
                    break
                if current is not None:
                    cpu = _proc_cpu_seconds(self.proc.pid)
                    used = None if cpu is None else cpu - current[2]
                    lim = VALID_CPU_LIMIT if current[0] == 0 else limit
                    wall_lim = VALID_WALL_LIMIT if current[0] == 0 else CASE_WALL_LIMIT
                    wall = time.monotonic() - current[3]
                    if (used is not None and used > lim) or wall > wall_lim:
                        results.append((current[1], "hang",
                                        f"no answer after {used:.1f} s CPU, {wall:.1f} s wall"
                                        if used is not None else f"{wall:.1f} s wall"))
                        self._kill()
                        if current[0] == 0:
                            return results
                        start = current[0] + 1
                        break
            if ended or (n_cases is not None and start >= n_cases):
                return results


# ------------------------------------------------------------------ counts without pytest
OWN_MODULES = ("trackcore.core", "trackcore.filters", "trackcore.models.motion",
               "trackcore.models.measurement", "trackcore.metrics", "trackcore.montecarlo",
               "trackcore.association.gating", "trackcore.association.pda",
               "trackcore.plotting")


def main(argv=None):
    """Run the whole fuzz with the test module's tables; print the counts and every failure
    (``--pending`` prints the failures in other owners' files as table entries)."""
    import argparse
    import collections
    import sys

    ap = argparse.ArgumentParser()
    ap.add_argument("names", nargs="*")
    ap.add_argument("--pending", action="store_true")
    a = ap.parse_args(argv)
    T = importlib.import_module("test_fuzz_public_api")
    names = a.names or [n for n in T.FUZZED if n in T.X.EXAMPLES]
    # the engine as the test module sees it (this file may be running as __main__)
    r = T.E.Runner("_fuzz_examples", skip_cases=T._hang_cases(),
                   allowed_nonfinite=T.ALLOWED_NONFINITE)
    t0 = time.monotonic()
    counts = collections.Counter()
    groups = collections.defaultdict(list)
    try:
        for name in names:
            res = r.run(name)
            for cid, st, d in res:
                reason, _ = T.pending_reason(name, cid)
                if st in ("ok", "error"):
                    counts[st] += 1
                elif reason or st == "skipped":
                    counts["pending"] += 1
                else:
                    counts["FAIL"] += 1
                    mod = T.PUBLIC[name][1].__module__
                    own = mod.startswith(OWN_MODULES)
                    print(f"{'OWN ' if own else ''}{name}[{cid}] {st}: {str(d)[:200]}",
                          flush=True)
                    if st == "bad-error":
                        kind = str(d).split(":", 1)[0]
                    elif st == "nonfinite":
                        kind = "silent non-finite result"
                    else:
                        kind = st
                    groups[(name, kind, own, mod)].append(cid)
    finally:
        child_cpu = _proc_cpu_seconds(r.proc.pid) if r.proc is not None else None
        r.close()
    wall = time.monotonic() - t0
    if child_cpu is not None:
        print(f"child process CPU {child_cpu:.0f} s (since its last start)")
    cpu = collections.Counter()
    for (name, _), sec in r.cpu.items():
        cpu[name] += sec
    print("most CPU:", ", ".join(f"{n} {v:.1f} s" for n, v in cpu.most_common(12)))
    print(f"functions {len(names)}, cases {sum(counts.values())}: {dict(counts)}; "
          f"{wall:.0f} s wall, {sum(cpu.values()):.0f} s CPU in the calls, "
          f"{r.restarts} child restarts", flush=True)
    if a.pending:
        for (name, kind, own, mod), cids in sorted(groups.items()):
            if own:
                continue
            where = mod.replace("trackcore.", "").replace(".", "/") + ".py"
            print(f'    "{name}[{"|".join(cids)}]":\n        "{kind} ({where})",')
    return 0


if __name__ == "__main__":
    import sys

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    raise SystemExit(main())
