"""Small named validators for user input.

Every public entry point funnels its arguments through these helpers so that a bad
argument raises a ``ValueError``/``TypeError`` that names the argument, states what was
expected and shows what was received -- never a deep numpy traceback or a silent NaN.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np

#: numpy's float64 dtype (an array's ``dtype is`` it: the usual native float64)
_FLOAT64 = np.dtype(np.float64)

__all__ = [
    "as_float_array",
    "check_finite_positive",
    "check_rotation",
    "check_skew",
    "check_square_trailing",
    "describe",
]


def describe(x: np.ndarray, limit: int = 6) -> str:
    """Short human-readable description of an array for error messages."""
    x = np.asarray(x)
    if x.size <= limit:
        return np.array2string(x, separator=", ", formatter={"float_kind": lambda v: f"{v:.6g}"}).replace("\n", "")
    return f"array of shape {x.shape}"


def is_clifford(value) -> bool:
    """True for clifford MultiVectors and arrays of them (without importing clifford)."""
    if type(value).__module__.startswith("clifford"):
        return True
    return (
        isinstance(value, np.ndarray)
        and value.dtype == object
        and value.size > 0
        and (type(value.ravel()[0]).__module__.startswith("clifford"))
    )


def as_bivector_array(value, name: str) -> np.ndarray:
    """A bivector argument as a float array: clifford bivectors become skew matrices."""
    if is_clifford(value):
        from .ga.algebra import bivector_to_skew

        try:
            return bivector_to_skew(value)
        except ValueError as exc:
            raise ValueError(f"`{name}`: {exc}") from None
    return as_float_array(value, name)


def is_scipy_rotation(value: object) -> bool:
    """True for a :class:`scipy.spatial.transform.Rotation` (without importing scipy).

    Parameters
    ----------
    value : object
        Anything.

    Returns
    -------
    bool
        Whether ``value`` is a scipy ``Rotation``.

    Examples
    --------
    >>> from scipy.spatial.transform import Rotation
    >>> from lieint.rotations import is_scipy_rotation
    >>> is_scipy_rotation(Rotation.identity()), is_scipy_rotation([[1.0, 0.0], [0.0, 1.0]])
    (True, False)
    """
    return type(value).__name__ == "Rotation" and type(value).__module__.startswith("scipy.spatial.transform")


def as_rotation_array(value, name: str) -> np.ndarray:
    """An orientation argument as a float array: a scipy ``Rotation`` (one, or a stack) becomes its
    matrices ``(3, 3)`` or ``(k, 3, 3)`` (body to space, ``apply(X) == R @ X``)."""
    if is_scipy_rotation(value):
        return np.asarray(value.as_matrix(), dtype=float)
    return as_float_array(value, name)


def as_float_array(value, name: str, *, allow_nonfinite: bool = False, field: str | None = None) -> np.ndarray:
    """Convert ``value`` to a float64 array, or raise naming ``name`` (``name['field']`` with
    ``field``, the label made only for a message).

    Raises
    ------
    TypeError
        If ``value`` is not numeric (strings, objects, complex numbers).
    ValueError
        If it holds NaN or inf (unless ``allow_nonfinite``).
    """
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.size <= 64:
        # a small float64 array (one body's field): finite when the sum of its entries as Python
        # floats is (0.3 µs against numpy's isfinite and reduction, 1.2 µs); a sum that
        # overflows takes the exact check below
        total = sum(value.ravel().tolist())
        if total - total == 0.0:
            return value
    if field is not None:
        name = f"{name}['{field}']"
    if value is None:
        raise TypeError(f"`{name}` must be an array of real numbers; got None.")
    try:
        arr = np.asarray(value)
    except Exception as exc:  # ragged sequences and the like
        raise TypeError(f"`{name}` must be an array of real numbers; got {type(value).__name__}.") from exc
    if not _is_real(arr.dtype):
        raise TypeError(f"`{name}` must be an array of real numbers; got dtype {arr.dtype}.")
    arr = arr.astype(np.float64, copy=False)
    if not allow_nonfinite and not all_finite(arr):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"`{name}` must be finite; got {arr[tuple(bad)]} at index {tuple(int(i) for i in bad)}.")
    return arr


@lru_cache(maxsize=64)
def _is_real(dtype: np.dtype) -> bool:
    """Floating, integer or boolean (once per dtype: ``issubdtype`` costs a microsecond a call)."""
    return dtype.kind != "O" and (
        np.issubdtype(dtype, np.floating) or np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.bool_)
    )


def all_finite(arr: np.ndarray) -> bool:
    """True when every entry of ``arr`` is finite (one reduction: ``np.all`` adds a Python wrapper)."""
    return bool(np.logical_and.reduce(np.isfinite(arr), axis=None))


def check_square_trailing(arr: np.ndarray, name: str, n: int | None = None) -> int:
    """Check that ``arr`` has shape ``(..., n, n)``; return n."""
    if arr.ndim < 2 or arr.shape[-1] != arr.shape[-2]:
        expected = "(..., n, n)" if n is None else f"(..., {n}, {n})"
        raise ValueError(f"`{name}` must have shape {expected}; got shape {arr.shape}.")
    if n is not None and arr.shape[-1] != n:
        raise ValueError(
            f"`{name}` must have shape (..., {n}, {n}) for this system of dimension n = {n}; got shape {arr.shape}."
        )
    return arr.shape[-1]


def check_skew(arr: np.ndarray, name: str, rtol: float = 1e-10) -> np.ndarray:
    """Check that ``arr`` is skew-symmetric (a bivector) to ``rtol``; return its skew part."""
    entries = arr.ravel().tolist() if arr.size == 9 else None
    total = sum(entries) if entries is not None else 0.0
    if entries is not None and total - total == 0.0:  # one finite 3 × 3: Python floats, 4× faster
        a, b, c, d, e, f, g, h, i = entries
        err = max(2.0 * abs(a), 2.0 * abs(e), 2.0 * abs(i), abs(b + d), abs(c + g), abs(f + h))
        if err == 0.0:  # exactly skew: its skew part is itself
            return arr.copy()
        scale = max(abs(x) for x in entries)
    elif _many_3x3(arr):
        from .fast.checks import skew_defect_3

        err, scale = skew_defect_3(arr)
        if not err > 0:  # exactly skew: its skew part is itself, bit for bit
            return arr.copy()
    else:
        # np.maximum.reduce: np.max's result without its Python wrapper (a few microseconds a
        # call); one temporary, made absolute in place (four before: a batch of 4,096 tops
        # checks in 100–160 instead of 175 µs)
        defect = arr + arr.swapaxes(-1, -2)
        err = np.maximum.reduce(np.abs(defect, out=defect), axis=None, initial=0.0)
        if not err > 0:  # exactly skew (or empty): its skew part is itself, bit for bit
            return arr.copy()
        scale = np.maximum.reduce(np.abs(arr), axis=None, initial=0.0)
    arr_t = arr.swapaxes(-1, -2)
    if err > rtol * max(scale, 1e-300):
        raise ValueError(
            f"`{name}` must be skew-symmetric (a bivector, X^T = -X); "
            f"got max |X + X^T| = {err:.3g} for max |X| = {scale:.3g}."
        )
    return 0.5 * (arr - arr_t)


def check_rotation(arr: np.ndarray, name: str, atol: float = 1e-10) -> None:
    """Check that every matrix of ``arr`` lies in SO(n) (orthogonal, det = +1)."""
    n = arr.shape[-1]
    if arr.size == 9:  # one 3 × 3 (a single body): Python floats, a sixth of numpy's time
        worst, smallest_det = _rotation_defects_3(arr)
    elif _many_3x3(arr):
        from .fast.checks import rotation_defects_3

        worst, smallest_det = rotation_defects_3(arr)
    elif arr.ndim == 2:  # one n × n matrix (a single body): 2-D products, a dot, no reductions
        D = arr.T @ arr
        D -= _eye(n)
        flat = D.ravel()
        worst = math.sqrt(float(flat @ flat))  # NaN for a non-finite R: it fails the test below
        smallest_det = None
    else:
        worst = _largest_orthogonality_defect(arr)
        smallest_det = None
    if not worst <= atol:  # NaN fails too
        raise ValueError(
            f"`{name}` must be a rotation in SO({n}) (R^T R = I, det R = +1); got ||R^T R - I|| = {worst:.3g}."
        )
    if smallest_det is None and arr.ndim == 2:
        smallest_det = float(_det(arr))
    elif smallest_det is None:
        smallest_det = np.minimum.reduce(_det(arr), axis=None, initial=np.inf)
    if smallest_det < 0:
        raise ValueError(
            f"`{name}` must be a rotation in SO({n}) with det R = +1; got det R = "
            f"{float(smallest_det):.6g} (a reflection)."
        )


#: from this many 3 × 3 matrices on, the checks run compiled (:mod:`lieint.fast.checks`: at 64,
#: 2 µs against numpy's 6 for skewness and 42 for rotations; at 4,096, 56 against 101 and 36
#: against 199), importing numba on first use: a batch of bodies is what the compiled kernels run
_COMPILED_CHECKS_FROM = 64


def _many_3x3(arr: np.ndarray) -> bool:
    """A stack of at least ``_COMPILED_CHECKS_FROM`` 3 × 3 matrices."""
    return arr.ndim >= 3 and arr.shape[-2:] == (3, 3) and arr.size >= 9 * _COMPILED_CHECKS_FROM


def _rotation_defects_3(arr: np.ndarray) -> tuple[float, float]:
    """``‖RᵀR − I‖_F`` and ``det R`` of one 3 × 3 matrix, in Python floats."""
    a, b, c, d, e, f, g, h, i = arr.ravel().tolist()
    # RᵀR from the columns (a, d, g), (b, e, h), (c, f, i)
    g00, g11, g22 = a * a + d * d + g * g - 1.0, b * b + e * e + h * h - 1.0, c * c + f * f + i * i - 1.0
    g01, g02, g12 = a * b + d * e + g * h, a * c + d * f + g * i, b * c + e * f + h * i
    worst = math.sqrt(g00 * g00 + g11 * g11 + g22 * g22 + 2.0 * (g01 * g01 + g02 * g02 + g12 * g12))
    return worst, a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def _largest_orthogonality_defect(arr: np.ndarray) -> float:
    """The largest ``‖RᵀR − I‖_F`` over the matrices of ``arr`` (..., n, n)."""
    # the Frobenius norm as np.linalg.norm computes it, without its Python wrapper (sqrt is
    # monotone: the root of the largest sum is the largest norm)
    D = arr.swapaxes(-1, -2) @ arr - _eye(arr.shape[-1])
    return math.sqrt(np.maximum.reduce(np.add.reduce(D * D, axis=(-2, -1)), axis=None, initial=0.0))


def _det(arr: np.ndarray) -> np.ndarray:
    """``np.linalg.det`` of float64 ``(..., n, n)`` matrices checked already: its LAPACK gufunc
    called directly (the wrapper's own checks cost more than the 3 × 3 determinant)."""
    if _DET_GUFUNC is not None and arr.dtype == np.float64:
        return _DET_GUFUNC(arr)
    return np.linalg.det(arr)


try:  # numpy's gufunc behind np.linalg.det (numpy 1.x and 2.x); the public function otherwise
    from numpy.linalg._umath_linalg import det as _DET_GUFUNC
except ImportError:  # pragma: no cover
    _DET_GUFUNC = None


@lru_cache(maxsize=16)
def _eye(n: int) -> np.ndarray:
    """The identity of size n (read-only: shared between calls)."""
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def check_finite_positive(value, name: str) -> float:
    """Check a scalar is a finite number > 0; return it as float."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"`{name}` must be a positive finite number; got {value!r}.")
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"`{name}` must be a positive finite number; got {v!r}.")
    return v


def check_choice(value, name: str, choices: Sequence[str]) -> str:
    """Check ``value`` is one of ``choices``; list them in the message."""
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"`{name}` must be one of {list(choices)}; got {value!r}.")
    return value


def check_vector(value, name: str, n: int, *, batch: bool = False) -> np.ndarray:
    """A finite vector of dimension n (shape ``(n,)``, or ``(..., n)`` with ``batch``)."""
    arr = as_float_array(value, name)
    ok = arr.shape[-1:] == (n,) and (batch or arr.ndim == 1)
    if not ok:
        expected = f"(..., {n})" if batch else f"({n},)"
        raise ValueError(f"`{name}` must be a vector of dimension n = {n} (shape {expected}); got shape {arr.shape}.")
    return arr
