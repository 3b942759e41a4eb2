"""Tangent coordinates of a system's state: how a perturbation of the state is written.

A state is a dict of fields; a tangent vector at ``y`` is one flat vector ``v`` of
:attr:`TangentChart.dim` numbers, field after field (in :attr:`LieGroupSystem.fields` order):

* a group-valued field (kind ``"rotation"``: the attitude R) is perturbed on the right,
  ``R ↦ R exp(δ̂)``, ``δ ∈ so(n)`` in bivector coordinates (``e_i ∧ e_j``, i < j, row-major:
  :func:`lieint.groups.bivectors.bivector_coordinates`) — the right-trivialised tangent space,
  the body-frame angular displacement for a rigid body;
* a momentum (kind ``"bivector"``: A in the dual algebra so(n)*) is perturbed additively,
  ``A ↦ A + δ̂A``, in the same bivector coordinates;
* every other field (vectors, points, velocities) additively on its entries.

So a tangent vector of a 3D top with attitude is ``(δA₁₂, δA₁₃, δA₂₃, δ₁₂, δ₁₃, δ₂₃)``. The
readout of a perturbed state inverts this to first order: ``δ = vee(R₀ᵀ dR)`` (skew when R₀ is
orthogonal), ``δA`` the upper triangle of ``dA``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..systems.base import LieGroupSystem

__all__ = ["TangentChart", "chart_of"]


@dataclass(frozen=True)
class TangentChart:
    """The tangent coordinates of one system's state (see the module docstring).

    Attributes
    ----------
    names : tuple of str
        The state fields, in order.
    kinds : tuple of str
        ``"rotation"``, ``"bivector"`` or ``"flat"`` per field: how it is perturbed.
    shapes : tuple of tuple of int
        The field shapes (per body).
    sizes : tuple of int
        Tangent coordinates per field.
    """

    names: tuple[str, ...]
    kinds: tuple[str, ...]
    shapes: tuple[tuple[int, ...], ...]
    sizes: tuple[int, ...]

    @property
    def dim(self) -> int:
        """Number of tangent coordinates of one body's state."""
        return sum(self.sizes)

    @property
    def offsets(self) -> dict[str, slice]:
        """field name → its slice of a tangent vector."""
        out, start = {}, 0
        for name, size in zip(self.names, self.sizes, strict=True):
            out[name] = slice(start, start + size)
            start += size
        return out

    def labels(self) -> list[str]:
        """One label per tangent coordinate ("A[0,1]", "R:δ[0,2]", "Gamma[1]", …)."""
        out: list[str] = []
        for name, kind, shape in zip(self.names, self.kinds, self.shapes, strict=True):
            if kind == "flat":
                out += [f"{name}[{','.join(map(str, idx))}]" for idx in np.ndindex(*shape)]
            else:
                i, j = np.triu_indices(shape[-1], k=1)
                prefix = f"{name}:δ" if kind == "rotation" else name
                out += [f"{prefix}[{a},{b}]" for a, b in zip(i, j, strict=True)]
        return out

    def perturb(self, y: dict, v: np.ndarray, scale: complex | float) -> dict:
        """The state ``y`` moved along the tangent vectors ``v`` by ``scale`` (to first order).

        Parameters
        ----------
        y : dict of ndarray
            A state of batch shape ``b``.
        v : ndarray, shape (k, ..., dim)
            k tangent vectors at each body of ``y``.
        scale : float or complex
            The step along them (``1j·ε`` for the complex step).

        Returns
        -------
        dict of ndarray
            k perturbed copies of ``y`` on a new leading axis, shape ``(k, *b, *field)``;
            rotations are moved as ``R (I + scale·δ̂)`` (``exp`` to first order, exact to
            round-off for the complex step, whose ``scale²`` is below the smallest double).
        """
        out = {}
        for name, kind, shape in zip(self.names, self.kinds, self.shapes, strict=True):
            part = v[..., self.offsets[name]]
            base = np.asarray(y[name])[None]
            if kind == "flat":
                out[name] = base + scale * part.reshape(part.shape[:-1] + shape)
            else:
                n = shape[-1]
                i, j = np.triu_indices(n, k=1)
                X = np.zeros(part.shape[:-1] + (n, n), dtype=part.dtype)
                X[..., i, j] = part
                X[..., j, i] = -part
                out[name] = base + scale * (base @ X if kind == "rotation" else X)
        return out

    def read(self, y: dict, dy: dict) -> np.ndarray:
        """Tangent coordinates of a first-order change ``dy`` of the state ``y``.

        Parameters
        ----------
        y : dict of ndarray
            The state, batch shape ``b``.
        dy : dict of ndarray
            Changes of each field, shape ``(k, *b, *field)``.

        Returns
        -------
        ndarray, shape (k, ..., dim)
            ``vee(Rᵀ dR)`` for rotations, the upper triangle for momenta, the entries else.
        """
        parts = []
        for name, kind, shape in zip(self.names, self.kinds, self.shapes, strict=True):
            d = np.asarray(dy[name])
            lead = d.shape[: d.ndim - len(shape)]
            if kind == "flat":
                parts.append(d.reshape(lead + (-1,)))
                continue
            if kind == "rotation":
                d = np.swapaxes(np.asarray(y[name]), -1, -2)[None] @ d
                d = 0.5 * (d - np.swapaxes(d, -1, -2))
            i, j = np.triu_indices(shape[-1], k=1)
            parts.append(d[..., i, j])
        return np.concatenate(parts, axis=-1)


def chart_of(system: LieGroupSystem) -> TangentChart:
    """The tangent coordinates of ``system``'s state (see the module docstring).

    Parameters
    ----------
    system : LieGroupSystem
        The system; its :attr:`field_kinds` say which fields are rotations and momenta.

    Returns
    -------
    TangentChart
        The chart.
    """
    names, kinds, shapes, sizes = [], [], [], []
    for name, shape in system.fields.items():
        declared = system.field_kinds.get(name, "")
        square = len(shape) == 2 and shape[0] == shape[1]
        if declared in ("rotation", "bivector") and square:
            kind = declared
            size = shape[0] * (shape[0] - 1) // 2
        else:
            kind, size = "flat", math.prod(shape)
        names.append(name)
        kinds.append(kind)
        shapes.append(tuple(shape))
        sizes.append(size)
    return TangentChart(tuple(names), tuple(kinds), tuple(shapes), tuple(sizes))
