"""The contract between a system and the generic compiled loop (:mod:`lieint.fast.generic`):
the signatures of a system's compiled *pieces*, their declaration (:class:`CompiledPieces`) and
the compiled record they travel in (:data:`BUNDLE`).

* ``generator(y, params, W, v, a, work)`` writes ``ξ(y) = (W, v, a)``: W ∈ so(n), v ∈ Rⁿ the
  translation of se(n) (length 0 on SO(n)), a ∈ Rᵐ (length 0 without a vector factor);
* ``action(Q, t, a, y, params, out, work)`` writes ``ρ(g, y)`` for ``g = ((Q, t), a)``;
* ``vector_field(y, params, out, work)`` writes ``ẏ`` (classical RK, on the flattened state);
* ``projection(y, params, out, work)`` writes the projected state (``project=True``);
* ``energy(y, params, work) -> float``, optional: the system's conserved energy H(y), what the
  energy-keeping pairs move every step onto (:mod:`lieint.methods.energy_projection`; a system
  whose pieces declare none runs those pairs on the generic path);

``work`` is scratch memory of the length the pieces declare (:meth:`CompiledPieces.work_size`),
allocated once per run and thread. Passing the four pieces as one record (:data:`BUNDLE`, a
numba structref made once per declaration) costs one reference; each first-class function
argument cost about 3.5 µs a call (numba unpickles its signature twice to find its addresses).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit, types
from numba.core.types.function_type import CompileResultWAP
from numba.experimental import structref

__all__ = ["ACTION", "BUNDLE", "ENERGY", "FIELD", "GENERATOR", "CompiledPieces", "PiecesBundle"]

_vec = types.float64[::1]
_mat = types.float64[:, ::1]
#: ``generator(y, params, W, v, a, work)``: writes ξ(y) = (W, v, a)
GENERATOR = types.void(_vec, _vec, _mat, _vec, _vec, _vec)
#: ``action(Q, t, a, y, params, out, work)``: writes ρ(((Q, t), a), y)
ACTION = types.void(_mat, _vec, _vec, _vec, _vec, _vec, _vec)
#: ``vector_field(y, params, out, work)`` and ``projection(y, params, out, work)``
FIELD = types.void(_vec, _vec, _vec, _vec)
#: ``energy(y, params, work) -> H(y)``
ENERGY = types.float64(_vec, _vec, _vec)


@dataclass(frozen=True)
class CompiledPieces:
    """A system's compiled generator, action, vector field and projection: numba functions,
    compiled for the signatures :data:`GENERATOR`, :data:`ACTION`, :data:`FIELD`, :data:`FIELD`
    when first used (or declared with them); ``work``: the length of the scratch vector they
    are given, a number or a function of n; ``energy``: optionally, the conserved energy
    (:data:`ENERGY`), which the energy-keeping pairs need to run compiled."""

    generator: object
    action: object
    vector_field: object
    projection: object
    work: int | Callable[[int], int] = 0
    energy: object = None

    def work_size(self, n: int) -> int:
        """The scratch length for bodies of dimension n."""
        size = self.work(n) if callable(self.work) else self.work
        if not isinstance(size, (int, np.integer)) or size < 0:
            raise ValueError(f"`work` of compiled pieces must give a length >= 0; got {size!r} for n = {n}.")
        return int(size)

    @cached_property
    def functions(self) -> tuple:
        """The four pieces and the energy (a stand-in when none is declared) as first-class
        function values, resolved once (:class:`_Piece`)."""
        return tuple(self.piece(i) for i in range(5))

    def piece(self, i: int):
        """Piece i (generator, action, vector field, projection, energy) as a first-class
        function value, compiled for its signature on first use and kept (the energy's stand-in
        returns NaN when the pieces declare none)."""
        cache = self.__dict__.setdefault("_pieces", {})
        if i not in cache:
            energy = _unused_energy if self.energy is None else self.energy
            function = (self.generator, self.action, self.vector_field, self.projection, energy)[i]
            cache[i] = _Piece(function, (GENERATOR, ACTION, FIELD, FIELD, ENERGY)[i])
        return cache[i]

    @cached_property
    def bundle(self) -> PiecesBundle:
        """The four pieces in one compiled record, as the loops take them (:data:`BUNDLE`): made
        once per declaration, it passes into compiled code for the cost of one reference, where
        each first-class function argument costs ~3.5 µs per call (numba unpickles its signature
        twice to look up its addresses)."""
        return _bundle(*self.functions)

    def bundle_for(self, field: bool, projection: bool, energy: bool = False) -> PiecesBundle:
        """:attr:`bundle` with only the pieces a run calls compiled: the vector field (classical
        RK, an adaptive run's first trial step) when ``field``, the projection when
        ``projection``, the energy when ``energy`` (the energy-keeping pairs); the others are
        stand-ins that write or return NaN (a call the run was not to make shows, it does not
        pass). A cold first run of a system compiles a third less."""
        if field and projection and energy:
            return self.bundle
        key = (field, projection, energy)
        cache = self.__dict__.setdefault("_partial_bundles", {})
        if key not in cache:
            unused = _Piece(_unused_field, FIELD)
            vector_field = self.piece(2) if field else unused
            projector = self.piece(3) if projection else unused
            level = self.piece(4) if energy else _Piece(_unused_energy, ENERGY)
            cache[key] = _bundle(self.piece(0), self.piece(1), vector_field, projector, level)
        return cache[key]


class _Piece:
    """A compiled function as a first-class function value whose address and numba type are
    worked out once: numba's wrapper-address protocol, and ``_numba_type_`` so that typing the
    argument is an attribute read. Passing the numba function itself costs ~50 µs per argument
    per call (its compile result and address are looked up every time)."""

    def __init__(self, function, signature):
        if not hasattr(function, "get_compile_result"):
            raise TypeError(f"a compiled piece must be a numba function; got {type(function).__name__}.")
        try:
            result = function.get_compile_result(signature)
        except Exception as exc:  # numba's typing error: the piece does not take these arguments
            name = getattr(function, "__name__", repr(function))
            raise TypeError(
                f"the compiled piece {name!r} must take the arguments {signature.args} "
                f"(lieint.fast.pieces.GENERATOR, ACTION or FIELD, the last one the scratch vector `work`); "
                f"numba could not compile it for them: {str(exc).splitlines()[0]}"
            ) from None
        self._address = CompileResultWAP(result).address
        self._signature = signature
        self._numba_type_ = types.FunctionType(signature)

    def __wrapper_address__(self) -> int:
        return self._address

    def signature(self):
        return self._signature


@structref.register
class _BundleType(types.StructRef):
    """numba's type of :class:`PiecesBundle`."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class PiecesBundle(structref.StructRefProxy):
    """A system's compiled pieces as one compiled record (fields ``generator``, ``action``,
    ``vector_field``, ``projection``, ``energy``), made by :attr:`CompiledPieces.bundle`."""


structref.define_boxing(_BundleType, PiecesBundle)
#: the numba type of a bundle of pieces with the signatures above
BUNDLE = _BundleType(
    [
        ("generator", types.FunctionType(GENERATOR)),
        ("action", types.FunctionType(ACTION)),
        ("vector_field", types.FunctionType(FIELD)),
        ("projection", types.FunctionType(FIELD)),
        ("energy", types.FunctionType(ENERGY)),
    ]
)


@njit(FIELD, cache=True)
def _unused_field(y, params, out, work):
    """The stand-in of a piece a run does not call: NaN out (see :meth:`CompiledPieces.bundle_for`)."""
    for i in range(out.shape[0]):
        out[i] = np.nan


@njit(ENERGY, cache=True)
def _unused_energy(y, params, work):
    """The stand-in of an energy the pieces do not declare (or a run does not call): NaN."""
    return np.nan


@njit(BUNDLE(*BUNDLE.field_dict.values()), cache=True)
def _bundle(generator, action, vector_field, projection, energy):
    record = structref.new(BUNDLE)
    record.generator = generator
    record.action = action
    record.vector_field = vector_field
    record.projection = projection
    record.energy = energy
    return record
