"""Input validation shared by every public trackcore function.

Public functions validate their inputs once with these helpers and then hand
contiguous float64 arrays to numba kernels that assume valid input.  Every
error names the offending argument and says what was expected.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = [
    "as_array",
    "as_vector",
    "as_matrix",
    "as_square_matrix",
    "as_covariance",
    "as_measurements",
    "as_scalar",
    "as_positive",
    "as_nonnegative",
    "as_probability",
    "as_probabilities",
    "as_count",
    "as_int",
    "as_rng",
    "as_bool_matrix",
    "as_offsets",
    "finite_result",
]


def _describe(x) -> str:
    return type(x).__name__


def as_array(x, name: str, *, ndim=None, shape=None, finite: bool = True,
             allow_empty: bool = True) -> np.ndarray:
    """Return ``x`` as a C-contiguous float64 array after checking it.

    ``ndim`` is an int or a tuple of allowed ints; ``shape`` is a tuple whose
    entries are ints or ``None`` (any size).  Raises ``TypeError`` for
    non-numeric input (strings, objects, complex, booleans are accepted as 0/1
    only when they come as numeric arrays) and ``ValueError`` for a wrong shape
    or non-finite entries.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import as_array
    >>> as_array([1, 2, 3], "x", ndim=1)
    array([1., 2., 3.])
    >>> as_array([[1.0, np.nan]], "P")
    Traceback (most recent call last):
        ...
    ValueError: P must contain only finite values (found NaN or inf)
    """
    if isinstance(x, (str, bytes)) or x is None:
        raise TypeError(f"{name} must be a numeric array, got {_describe(x)}")
    try:
        arr = np.asarray(x)
    except Exception as exc:  # pragma: no cover - ragged input etc.
        raise TypeError(f"{name} must be a numeric array ({exc})") from None
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_):
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if np.issubdtype(arr.dtype, np.complexfloating):
        raise TypeError(f"{name} must be real, got complex dtype {arr.dtype}")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            raise ValueError(
                f"{name} must have {' or '.join(map(str, allowed))} dimension(s), "
                f"got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(
                s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if not allow_empty and arr.size == 0:
        raise ValueError(f"{name} must not be empty")
    if finite and arr.size and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (found NaN or inf)")
    return arr


def as_vector(x, name: str, n: int | None = None, *, finite: bool = True) -> np.ndarray:
    """A 1-D float64 array, optionally of length ``n``.

    Examples
    --------
    >>> from trackcore.core import as_vector
    >>> as_vector([1, 2], "x0", 2)
    array([1., 2.])
    >>> as_vector([1, 2, 3], "x0", 2)
    Traceback (most recent call last):
        ...
    ValueError: x0 must have shape (2), got (3,)
    """
    return as_array(x, name, shape=(n,), finite=finite)


def as_matrix(x, name: str, shape=(None, None), *, finite: bool = True) -> np.ndarray:
    """A 2-D float64 array of the given shape (``None`` = any size).

    Examples
    --------
    >>> from trackcore.core import as_matrix
    >>> as_matrix([[1, 0, 0]], "H", (1, None))
    array([[1., 0., 0.]])
    >>> as_matrix([1, 0], "H")
    Traceback (most recent call last):
        ...
    ValueError: H must have shape (any, any), got (2,)
    """
    return as_array(x, name, shape=tuple(shape), finite=finite)


def as_square_matrix(x, name: str, n: int | None = None) -> np.ndarray:
    """A 2-D float64 square matrix, optionally ``n`` by ``n``.

    Examples
    --------
    >>> from trackcore.core import as_square_matrix
    >>> as_square_matrix([[1, 2], [3, 4]], "F", 2)
    array([[1., 2.],
           [3., 4.]])
    >>> as_square_matrix([[1, 2, 3]], "F")
    Traceback (most recent call last):
        ...
    ValueError: F must be square, got shape (1, 3)
    """
    arr = as_array(x, name, ndim=2)
    if arr.shape[0] != arr.shape[1] or (n is not None and arr.shape[0] != n):
        want = f"({n}, {n})" if n is not None else "square"
        raise ValueError(f"{name} must be {want}, got shape {arr.shape}")
    return arr


#: The positive semi-definiteness rule (see :func:`as_covariance`): eigenvalues of a
#: covariance down to ``-PSD_RTOL * max|eig|`` are rounding.
PSD_RTOL = 1e-9


def _psd_tolerance(eig, rtol: float = PSD_RTOL) -> float:
    """The rule's tolerance for a matrix with (ascending) eigenvalues ``eig``."""
    return rtol * max(float(np.max(np.abs(eig))), 1e-300)


def as_covariance(x, name: str, n: int | None = None, *, strict: bool = False,
                  rtol: float = PSD_RTOL) -> np.ndarray:
    """A symmetric positive semi-definite (``strict``: definite) matrix.

    Symmetry is checked to ``rtol`` relative to the largest entry; the returned
    matrix is exactly symmetrised.  Semi-definiteness allows eigenvalues down
    to ``-rtol * max|eig|`` to absorb rounding.

    This is the one PSD rule of the package.  The filters apply it to every
    covariance argument (here) and to every covariance a filter call returns
    (:func:`covariance_result_violation`): a negative eigenvalue that is rounding
    at an argument's own scale can be far from rounding at the scale of the result
    (an ``R`` with eigenvalue ``-1e-9`` against a posterior of scale ``1e-8``);
    such a call raises ``ValueError`` naming the argument instead of returning a
    covariance with a negative variance.  A result that fails the rule although no
    argument has a negative eigenvalue (beyond the eigenvalue solver's rounding)
    fails through the rounding of the computation itself; it is returned with its
    negative eigenvalues set to 0 (:func:`psd_projection`).  Results that pass the
    rule are returned as computed.

    Examples
    --------
    >>> from trackcore.core import as_covariance
    >>> as_covariance([[2.0, 1.0], [1.0, 2.0]], "P", 2)
    array([[2., 1.],
           [1., 2.]])
    >>> as_covariance([[1.0, 2.0], [2.0, 1.0]], "P")    # eigenvalues 3 and -1
    Traceback (most recent call last):
        ...
    ValueError: P must be positive semi-definite (smallest eigenvalue -1)
    """
    arr = as_square_matrix(x, name, n)
    if arr.size == 0:
        return arr
    scale = max(float(np.max(np.abs(arr))), 1e-300)
    if np.max(np.abs(arr - arr.T)) > rtol * scale * 10:
        raise ValueError(f"{name} must be symmetric")
    arr = 0.5 * (arr + arr.T)
    eig = np.linalg.eigvalsh(arr)
    tol = _psd_tolerance(eig, rtol)
    if strict and eig[0] <= 0:
        raise ValueError(f"{name} must be positive definite (smallest eigenvalue {eig[0]:.3g})")
    if eig[0] < -tol:
        raise ValueError(
            f"{name} must be positive semi-definite (smallest eigenvalue {eig[0]:.3g})")
    return np.ascontiguousarray(arr)


#: An argument's negative eigenvalue above ``-PSD_NOISE * max|eig|`` is the eigenvalue
#: solver's own rounding (an exactly singular matrix), not a property of the matrix.
PSD_NOISE = 100 * np.finfo(np.float64).eps


def covariance_result_violation(P, what: str, arguments):
    """The PSD rule of :func:`as_covariance` applied to a result.

    ``P`` is an ``(n, n)`` covariance or an ``(r, n, n)`` stack that a call computed
    from covariance ``arguments`` (``(name, matrix or stack)`` pairs, each already
    accepted by :func:`as_covariance`).  Returns ``None`` when every matrix of ``P``
    passes the rule.  Otherwise returns ``(message, blamed, bad)``: ``blamed`` is True
    when an argument has a negative eigenvalue beyond the solver's rounding
    (``PSD_NOISE``), rounding at the argument's own scale but not at the result's, and
    the message names it; else the violation is rounding of the computation itself
    (for instance an exactly singular ``R`` far larger than ``P``).  ``bad`` lists the
    indices of the failing matrices of the stack.  (The fast path, a Cholesky
    factorisation that succeeds, and the action taken are in the filters.)
    """
    P = np.asarray(P, dtype=np.float64)
    stack = P.reshape((-1,) + P.shape[-2:])
    eig = np.linalg.eigvalsh(0.5 * (stack + np.swapaxes(stack, -1, -2)))
    bad = [j for j in range(stack.shape[0]) if eig[j, 0] < -_psd_tolerance(eig[j])]
    if not bad:
        return None
    worst = min(bad, key=lambda j: eig[j, 0])
    where = f"{what}[{worst}]" if P.ndim == 3 else what
    msg = (f"{where} is not positive semi-definite (smallest eigenvalue "
           f"{eig[worst, 0]:.3g}, largest {eig[worst, -1]:.3g})")
    blamed = []
    for name, A in arguments:
        A = np.asarray(A, dtype=np.float64)
        if A.size == 0:
            continue
        ea = np.linalg.eigvalsh(A.reshape((-1,) + A.shape[-2:]))
        rel = ea[:, 0] / np.maximum(np.max(np.abs(ea), axis=1), 1e-300)
        j = int(np.argmin(rel))
        if rel[j] < -PSD_NOISE:
            label = f"{name}[{j}]" if A.ndim == 3 else name
            blamed.append((label, f"{label} (smallest eigenvalue {ea[j, 0]:.3g}, largest "
                                  f"{ea[j, -1]:.3g})"))
    if blamed:
        names = " and ".join(label for label, _ in blamed)
        return (f"{msg}: {', '.join(text for _, text in blamed)} must be positive "
                f"semi-definite at the scale of the result; a negative eigenvalue that is "
                f"rounding at its own scale is not rounding there (pass a positive "
                f"semi-definite {names}, e.g. with its negative eigenvalues set to 0)",
                True, bad)
    return msg, False, bad


def psd_projection(A):
    """The symmetric matrix ``A`` with its negative eigenvalues set to 0."""
    w, V = np.linalg.eigh(0.5 * (A + A.T))
    out = (V * np.maximum(w, 0.0)) @ V.T
    return 0.5 * (out + out.T)


def as_measurements(z, name: str, d: int | None = None) -> np.ndarray:
    """A scan of measurements as an ``(m, d)`` array; ``m = 0`` is valid.

    Accepts ``[]`` or an empty array for an empty scan (returned as shape
    ``(0, d)`` when ``d`` is known) and a 1-D array of length ``d`` as one
    measurement.

    Examples
    --------
    >>> from trackcore.core import as_measurements
    >>> as_measurements([], "z", 2).shape           # an empty scan
    (0, 2)
    >>> as_measurements([3.0, 4.0], "z", 2)         # one measurement
    array([[3., 4.]])
    >>> as_measurements([[1.0, 2.0, 3.0]], "z", 2)
    Traceback (most recent call last):
        ...
    ValueError: z must have shape (m, 2), got (1, 3)
    """
    if isinstance(z, (list, tuple)) and len(z) == 0:
        return np.zeros((0, d if d is not None else 0))
    arr = as_array(z, name, ndim=(1, 2))
    if arr.ndim == 1:
        if arr.size == 0:
            return np.zeros((0, d if d is not None else 0))
        if d is None or arr.size == d:
            arr = arr.reshape(1, -1)
        elif d == 1:
            arr = arr.reshape(-1, 1)
        else:
            raise ValueError(f"{name} must have shape (m, {d}), got {arr.shape}")
    if arr.shape[0] == 0 and d is not None:
        return np.zeros((0, d))
    if d is not None and arr.shape[1] != d:
        raise ValueError(f"{name} must have shape (m, {d}), got {arr.shape}")
    return arr


def as_scalar(x, name: str, *, finite: bool = True) -> float:
    """A real number as a ``float`` (``finite``: also finite); a one-entry array is accepted.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import as_scalar
    >>> as_scalar(np.array([2]), "T")
    2.0
    >>> as_scalar(True, "T")
    Traceback (most recent call last):
        ...
    TypeError: T must be a real number, got bool
    """
    if isinstance(x, (bool, np.bool_)) or isinstance(x, (str, bytes)) or x is None:
        raise TypeError(f"{name} must be a real number, got {_describe(x)}")
    if isinstance(x, np.ndarray):
        if x.size != 1:
            raise ValueError(f"{name} must be a scalar, got shape {x.shape}")
        x = x.reshape(-1)[0]
    if not isinstance(x, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {_describe(x)}")
    v = float(x)
    if finite and not np.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


def as_positive(x, name: str) -> float:
    """A finite number ``> 0`` as a ``float``.

    Examples
    --------
    >>> from trackcore.core import as_positive
    >>> as_positive(2, "T")
    2.0
    >>> as_positive(0.0, "T")
    Traceback (most recent call last):
        ...
    ValueError: T must be > 0, got 0.0
    """
    v = as_scalar(x, name)
    if v <= 0:
        raise ValueError(f"{name} must be > 0, got {v}")
    return v


def as_nonnegative(x, name: str) -> float:
    """A finite number ``>= 0`` as a ``float``.

    Examples
    --------
    >>> from trackcore.core import as_nonnegative
    >>> as_nonnegative(0, "q")
    0.0
    >>> as_nonnegative(-1e-3, "q")
    Traceback (most recent call last):
        ...
    ValueError: q must be >= 0, got -0.001
    """
    v = as_scalar(x, name)
    if v < 0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    return v


def as_probability(p, name: str, *, open_low: bool = False, open_high: bool = False) -> float:
    """A probability in [0, 1]; ``open_low``/``open_high`` exclude 0/1.

    Examples
    --------
    >>> from trackcore.core import as_probability
    >>> as_probability(0.9, "pd")
    0.9
    >>> as_probability(1.0, "pd", open_high=True)
    Traceback (most recent call last):
        ...
    ValueError: pd must be a probability in [0, 1), got 1.0
    """
    v = as_scalar(p, name)
    lo_ok = v > 0 if open_low else v >= 0
    hi_ok = v < 1 if open_high else v <= 1
    if not (lo_ok and hi_ok):
        lo = "(0" if open_low else "[0"
        hi = "1)" if open_high else "1]"
        raise ValueError(f"{name} must be a probability in {lo}, {hi}, got {v}")
    return v


def as_probabilities(p, name: str, *, shape=None) -> np.ndarray:
    """A float64 array (of ``shape``, if given) whose entries are probabilities in [0, 1].

    Examples
    --------
    >>> from trackcore.core import as_probabilities
    >>> as_probabilities([0.9, 0.5], "pd", shape=(2,))
    array([0.9, 0.5])
    >>> as_probabilities([0.9, 1.5], "pd")
    Traceback (most recent call last):
        ...
    ValueError: pd must contain probabilities in [0, 1]
    """
    arr = as_array(p, name, shape=shape)
    if arr.size and (arr.min() < 0 or arr.max() > 1):
        raise ValueError(f"{name} must contain probabilities in [0, 1]")
    return arr


_INT_MAX = 2**63 - 1
_FLOAT_INT_MAX = 2**53


def as_int(n, name: str, *, minimum: int | None = None) -> int:
    """An integer (a float with an integer value, such as ``3.0``, is accepted).

    Integers must fit in 64 bits, since kernels take them as ``int64``; a float must
    be at most ``2**53`` in magnitude, beyond which it no longer holds every integer.

    Examples
    --------
    >>> from trackcore.core import as_int
    >>> as_int(5, "K", minimum=1)
    5
    >>> as_int(2.5, "K")
    Traceback (most recent call last):
        ...
    TypeError: K must be an integer, got float 2.5
    """
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (numbers.Integral,)):
        if isinstance(n, (float, np.floating)) and math.isfinite(n) and float(n).is_integer():
            if abs(float(n)) > _FLOAT_INT_MAX:
                raise ValueError(f"{name} must be an integer of magnitude at most 2**53 when "
                                 f"given as a float, got {float(n)!r}")
            n = int(n)
        else:
            raise TypeError(f"{name} must be an integer, got {_describe(n)} {n!r}"
                            if isinstance(n, (float, np.floating)) else
                            f"{name} must be an integer, got {_describe(n)}")
    n = int(n)
    if not -_INT_MAX <= n <= _INT_MAX:
        raise ValueError(f"{name} must fit in a 64-bit integer, got {n}")
    if minimum is not None and n < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {n}")
    return n


def as_count(n, name: str) -> int:
    """A non-negative integer count.

    Examples
    --------
    >>> from trackcore.core import as_count
    >>> as_count(3.0, "n_runs")
    3
    >>> as_count(-1, "n_runs")
    Traceback (most recent call last):
        ...
    ValueError: n_runs must be >= 0, got -1
    """
    return as_int(n, name, minimum=0)


def as_rng(rng, name: str = "rng") -> np.random.Generator:
    """Require an explicit ``numpy.random.Generator`` (no hidden global state).

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import as_rng
    >>> rng = np.random.default_rng(0)
    >>> as_rng(rng) is rng
    True
    >>> as_rng(0)
    Traceback (most recent call last):
        ...
    TypeError: rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)), got int
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"{name} must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)), "
            f"got {_describe(rng)}")
    return rng


def as_bool_matrix(x, name: str, shape=(None, None)) -> np.ndarray:
    """A 2-D boolean array (of ``shape``, ``None`` = any size); 0/1 numbers are accepted.

    Examples
    --------
    >>> from trackcore.core import as_bool_matrix
    >>> as_bool_matrix([[1, 0], [0, 1]], "valid").tolist()
    [[True, False], [False, True]]
    >>> as_bool_matrix([[2, 0]], "valid")
    Traceback (most recent call last):
        ...
    ValueError: valid must contain only 0/1 or booleans
    """
    arr = np.asarray(x)
    if arr.dtype != np.bool_:
        if arr.dtype == object or not np.issubdtype(arr.dtype, np.number):
            raise TypeError(f"{name} must be a boolean array, got dtype {arr.dtype}")
        if arr.size and not np.all((arr == 0) | (arr == 1)):
            raise ValueError(f"{name} must contain only 0/1 or booleans")
        arr = arr.astype(bool)
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    return np.ascontiguousarray(arr)


def as_offsets(offsets, total: int, name: str = "offsets", *, min_scans: int = 0) -> np.ndarray:
    """Scan offsets of a concatenated run: a 1-D integer array of length ``K + 1``
    (``K >= min_scans``) rising from 0 to ``total`` (the number of measurements), so that
    scan ``k`` is ``z[offsets[k]:offsets[k + 1]]``.  Returns a contiguous int64 copy.

    Examples
    --------
    >>> from trackcore.core import as_offsets
    >>> as_offsets([0, 2, 2, 5], 5).tolist()       # 3 scans of 2, 0 and 3 measurements
    [0, 2, 2, 5]
    >>> as_offsets([0, 3, 2], 2)
    Traceback (most recent call last):
        ...
    ValueError: offsets must start at 0, be non-decreasing and end at the number of ...
    """
    off = np.asarray(offsets)
    if off.ndim != 1 or off.size < 1 + min_scans or not np.issubdtype(off.dtype, np.integer):
        raise ValueError(f"{name} must be a 1-D integer array of length K + 1 >= {1 + min_scans}, "
                         f"got {_describe(offsets)}")
    off = np.ascontiguousarray(off, dtype=np.int64)
    if off[0] != 0 or off[-1] != total or np.any(np.diff(off) < 0):
        raise ValueError(f"{name} must start at 0, be non-decreasing and end at the number of "
                         f"measurements ({total})")
    return off


def finite_result(x, what: str, cause: str):
    """Return ``x`` (a number or an array) if every entry is finite, else raise
    ``ValueError``: finite inputs whose ``what`` overflows (or becomes NaN through an
    overflow) get a clear error naming the arguments in ``cause``, never a silent
    ``inf`` or NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from trackcore.core import finite_result
    >>> finite_result(2.0, "the gain", "P and R")
    2.0
    >>> finite_result(np.array([1.0, np.inf]), "the gain", "P and R")
    Traceback (most recent call last):
        ...
    ValueError: the gain is not finite in floating point (it overflows); check the ...
    """
    arr = np.asarray(x)
    if arr.dtype.kind in "fc" and arr.size and not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} is not finite in floating point (it overflows); "
                         f"check the magnitude of {cause}")
    return x
