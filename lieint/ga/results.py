"""Results in the user's algebra: state fields and outputs as clifford multivectors.

Each field and output of a system declares what it is (its ``kind``, see
:class:`lieint.systems.Output`); that is enough to hand it back as multivectors:

========== ===================== ==============================================
kind       stored as             returned as
========== ===================== ==============================================
bivector   skew ``(n, n)``       bivectors of Cl(n)
rotation   ``R ∈ SO(n)``         rotors of Spin(n) (sign continuous in time)
rotor      ``2ⁿ`` coefficients   rotors of Cl(n)
vector     ``(n,)``              vectors of Cl(n)
point      ``(n,)``              vectors of Cl(n) (the point's position)
motor      16 coefficients       motors of the PGA Cl(3,0,1)
line       16 coefficients       bivectors (lines) of the PGA Cl(3,0,1)
========== ===================== ==============================================

A time series or a batch comes back as a ``clifford.MVArray`` (shape ``(m, *batch)``), a
single value as a ``clifford.MultiVector``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .algebra import _to_mv, algebra
from .exponential import matrix_to_rotor

__all__ = ["MULTIVECTOR_KINDS", "as_multivectors", "read_multivectors", "solution_multivectors"]

#: kinds of fields and outputs that have a multivector form
MULTIVECTOR_KINDS = ("bivector", "rotation", "rotor", "vector", "point", "motor", "line")


def _continuous_sign(S: np.ndarray) -> np.ndarray:
    """Flip rotors ``(m, *batch, 2ⁿ)`` along the first axis so that consecutive ones have a
    nonnegative inner product (the double cover's sign follows the motion)."""
    if S.shape[0] < 2:
        return S
    dots = np.sum(S[1:] * S[:-1], axis=-1, keepdims=True)
    flips = np.cumprod(np.where(dots < 0, -1.0, 1.0), axis=0)
    return np.concatenate([S[:1], S[1:] * flips], axis=0)


def as_multivectors(values, kind: str, *, time_axis: bool = False):
    """Multivector form of values of a declared ``kind`` (see the module table).

    Parameters
    ----------
    values : array_like
        ``(*lead, *trailing)`` with the kind's trailing shape.
    kind : str
        One of :data:`MULTIVECTOR_KINDS`.
    time_axis : bool
        The first axis is time: rotors from rotations get a sign continuous along it.

    Returns
    -------
    clifford.MultiVector or clifford.MVArray
    """
    values = np.asarray(values, dtype=float)
    if kind in ("bivector", "rotation"):
        if values.ndim < 2 or values.shape[-1] != values.shape[-2]:
            raise ValueError(f"values of kind {kind!r} must be (..., n, n) matrices; got shape {values.shape}.")
        ga = algebra(values.shape[-1])
        if kind == "bivector":
            coeffs = ga.bivector(values)
        else:
            coeffs = matrix_to_rotor(values, as_multivector=False)
            if time_axis:
                coeffs = _continuous_sign(coeffs)
        return _to_mv(coeffs, ga)
    if kind in ("vector", "point"):
        ga = algebra(values.shape[-1])
        return _to_mv(ga.vector(values), ga)
    if kind == "rotor":
        size = values.shape[-1]
        n = size.bit_length() - 1 if size > 0 else 0
        if 2**n != size:
            raise ValueError(f"values of kind 'rotor' must hold 2ⁿ coefficients; got shape {values.shape}.")
        return _to_mv(values, algebra(n))
    if kind in ("motor", "line"):
        from .pga import PGA

        if values.shape[-1] != PGA.size:
            raise ValueError(f"values of kind {kind!r} must hold the 16 PGA coefficients; got shape {values.shape}.")
        return PGA.multivectors(values)
    raise ValueError(f"values of kind {kind!r} have no multivector form; kinds with one are {list(MULTIVECTOR_KINDS)}.")


def _kind_of(system, name: str) -> str:
    outputs = system.outputs
    if name not in outputs:
        raise ValueError(f"Unknown field or output {name!r}; this system provides {sorted(outputs)}.")
    kind = outputs[name].kind
    if kind not in MULTIVECTOR_KINDS:
        usable = sorted(k for k, o in outputs.items() if o.kind in MULTIVECTOR_KINDS)
        raise ValueError(
            f"{name!r} is of kind {kind!r}, which has no multivector form; the fields and outputs of this system "
            f"that have one are {usable}."
        )
    return kind


def solution_multivectors(solution, name: str):
    """``solution.multivectors(name)``: a field or output over the saved times as an MVArray
    of shape ``(m, *batch)`` (see :meth:`lieint.Solution.multivectors`)."""
    kind = _kind_of(solution.system, name)
    values = solution.states[name] if name in solution.states else solution.outputs([name])[name]
    return as_multivectors(values, kind, time_axis=True)


def read_multivectors(path, name: str):
    """A field or output of a streamed run file (:func:`lieint.run`) as multivectors.

    Parameters
    ----------
    path : str or Path
        The HDF5 file of the run.
    name : str
        A state field or a saved output whose ``kind`` has a multivector form.

    Returns
    -------
    clifford.MVArray
        Shape ``(m, *batch)`` over the saved times.
    """
    import h5py

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"`path`: no run file at {str(path)!r}.")
    with h5py.File(path, "r") as f:
        for group in ("states", "outputs"):
            if group in f and name in f[group]:
                ds = f[group][name]
                kind = ds.attrs.get("kind", "")
                kind = kind.decode() if isinstance(kind, bytes) else str(kind)
                values = ds[...]
                break
        else:
            present = sorted(set(f["states"]) | set(f["outputs"] if "outputs" in f else ()))
            raise ValueError(f"`name`: {name!r} is not saved in {str(path)!r}; it holds {present}.")
    if kind not in MULTIVECTOR_KINDS:
        raise ValueError(f"{name!r} in {str(path)!r} is of kind {kind!r}, which has no multivector form.")
    return as_multivectors(values, kind, time_axis=True)
