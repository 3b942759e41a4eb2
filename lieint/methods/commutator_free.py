"""Commutator-free and Crouch–Grossman methods: compositions of exponentials of frozen generators.

Instead of one exponential of a combination corrected by dexp⁻¹ (RKMK), these methods compose
several exponentials of plain linear combinations of the stage generators — no commutators,
no dexp⁻¹. With the right action of lieint's systems (``ġ = g ξ``), the flow of the frozen
generator ``ξ_k`` for a time τ is ``y ↦ ρ(exp(τ ξ_k), y)``, and a stage (or the step) applies
the exponentials one after the other::

    Y_i = ρ(exp(h Σ_k α^{i,J}_k ξ_k), … ρ(exp(h Σ_k α^{i,1}_k ξ_k), y₀) …),
    ξ_k = ξ(t + c_k h, Y_k),
    y₁  = ρ(exp(h Σ_k β^J_k ξ_k), … ρ(exp(h Σ_k β^1_k ξ_k), y₀) …),

exponential 1 first. Summing the weights of a stage (of the step) gives the classical tableau
``a_ij = Σ_l α^{i,l}_j`` (``b_j = Σ_l β^l_j``), which must have the method's order (checked
when the module is imported); the extra, non-commutative order conditions are checked by the
fitted orders in the tests.

Methods (order, stages, exponentials per step):

* ``cf3`` (3, 3, 2) and ``cf4`` (4, 4, 2): Celledoni, Marthinsen, Owren, *Commutator-free Lie
  group methods*, Future Gener. Comput. Syst. 19 (2003) 341–352 (CF3 with Heun's third-order
  tableau; CF4 with the classical RK4 tableau, Table 2 of the paper).
* ``cg3`` (3, 3, 3): Crouch, Grossman, *Numerical integration of ordinary differential
  equations on manifolds*, J. Nonlinear Sci. 3 (1993) 1–33.
* ``cg4a`` (4, 5, 5): Owren, Marthinsen, *Runge–Kutta methods adapted to manifolds and based on
  rigid frames*, BIT 39 (1999) 116–142 (the method "CG4a", coefficients to 16 digits).

A Crouch–Grossman method is the special case with one frozen generator per exponential
(``y₁ = ρ(exp(h b_s ξ_s), … ρ(exp(h b_1 ξ_1), y₀))``).

Every method here runs compiled wherever RKMK does — the Euler top of any dimension, the heavy
top, the free body, both balls; fixed steps, batches, dense output, events, ``t_eval`` — from
its weights as data (:meth:`CommutatorFree.compiled`, :class:`lieint.fast.forms.ExpProductForm`:
one stage function per system form serves every such method); the numpy path below is the
reference it is tested against.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from ..dense import Increment
from ..fast.forms import ExpProductForm
from .base import Method, MethodSpec, StepResult
from .registry import register
from .tableau import ButcherTableau

__all__ = ["CF3", "CF4", "CG3", "CG4A", "CommutatorFree"]


@dataclass(frozen=True, eq=False)
class CommutatorFree(Method):
    """A method that composes exponentials of combinations of frozen generators.

    Parameters
    ----------
    name : str
    order : int
        The order p (the summed classical tableau is checked to have it).
    c : array_like, shape (s,)
        Nodes.
    stages : tuple of tuples of array_like
        ``stages[i]`` lists the weight vectors ``α^{i,l}`` (length s, zero from entry i on)
        of the exponentials that build stage i, in the order they are applied.
    output : tuple of array_like
        The weight vectors ``β^l`` of the step's exponentials, in the order they are applied.
    source : str
        Where the coefficients come from.

    Notes
    -----
    s generator evaluations and ``Σ_i (exponentials of stage i) + len(output)`` exponentials
    per step; the new state is the old one moved by a group element, so the invariants of the
    group action are kept to round-off.
    """

    name: str
    order: int
    c: tuple
    stages: tuple
    output: tuple
    source: str = ""

    group_action = True
    coordinates = None

    def __post_init__(self):
        s = len(self.c)
        weights = [np.asarray(w, dtype=float) for stage in self.stages for w in stage]
        weights += [np.asarray(w, dtype=float) for w in self.output]
        if len(self.stages) != s or any(w.shape != (s,) for w in weights):
            raise ValueError(f"{self.name}: every weight vector must have {s} entries, one per stage.")
        for i, stage in enumerate(self.stages):
            if any(np.any(np.asarray(w)[i:] != 0) for w in stage):
                raise ValueError(f"{self.name}: stage {i} may only use earlier stages (explicit method).")
        # the summed classical tableau must have the order (raises otherwise)
        ButcherTableau(f"{self.name} (summed)", self.classical_A, self.classical_b, np.asarray(self.c), self.order)

    @property
    def classical_A(self) -> np.ndarray:
        s = len(self.c)
        return np.array(
            [np.sum([np.asarray(w, float) for w in st], axis=0) if st else np.zeros(s) for st in self.stages]
        )

    @property
    def classical_b(self) -> np.ndarray:
        return np.sum([np.asarray(w, float) for w in self.output], axis=0)

    @property
    def exponentials(self) -> int:
        """Exponentials per step."""
        return sum(len(st) for st in self.stages) + len(self.output)

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        group = system.group
        xis: list = []
        for i, stage in enumerate(self.stages):
            yi = y
            for w in stage:
                u = _combine(group, w, xis, h)
                if u is not None:
                    yi = system.act(group.exp(u), yi)
            xis.append(system.generator(t + self.c[i] * h, yi))
        y1, g = y, None
        for w in self.output:
            u = _combine(group, w, xis, h)
            if u is None:
                continue
            gl = group.exp(u)
            y1 = system.act(gl, y1)
            # ρ(g₂, ρ(g₁, y)) = ρ(g₁g₂, y) for a right action: the step's element is g₁g₂…
            g = gl if g is None else group.multiply(g, gl)
        return StepResult(y1, None, len(self.c), None, dense=Increment(g=g))

    def compiled(self):
        """The compiled engine's form (:class:`lieint.fast.forms.ExpProductForm`): the weight
        vectors of every exponential as rows, stage after stage and then the step's; None for a
        subclass that changes the step (it integrates something else)."""
        if not self.steps_as(CommutatorFree, ("step",)):
            return None
        rows = [w for stage in self.stages for w in stage] + list(self.output)
        counts = [len(stage) for stage in self.stages] + [len(self.output)]
        bounds = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        s = len(self.c)
        weights = np.array(rows, dtype=float).reshape(len(rows), s)
        return ExpProductForm(np.asarray(self.c, dtype=float), weights, bounds)


def _combine(group, weights, xis: list, h: float):
    """``h Σ_k w_k ξ_k`` over the stages computed so far, skipping zero weights; None if all zero."""
    pairs = [(float(w) * h, x) for w, x in zip(weights[: len(xis)], xis, strict=True) if w != 0.0]
    if not pairs:
        return None
    return group.lincomb([p for p, _ in pairs], [x for _, x in pairs])


def _cg(name: str, order: int, A, b, c, source: str) -> CommutatorFree:
    """A Crouch–Grossman method: one exponential per nonzero a_ij (j = 1, …, i−1) and per b_j."""
    s = len(c)

    def unit(j, value):
        e = np.zeros(s)
        e[j] = value
        e.flags.writeable = False  # coefficients are data shared by every use of the method
        return e

    stages = tuple(tuple(unit(j, A[i][j]) for j in range(i) if A[i][j] != 0.0) for i in range(s))
    output = tuple(unit(j, b[j]) for j in range(s) if b[j] != 0.0)
    return CommutatorFree(name, order, tuple(c), stages, output, source)


CF3 = CommutatorFree(
    "cf3",
    3,
    (0.0, 1 / 3, 2 / 3),
    ((), ((1 / 3, 0.0, 0.0),), ((0.0, 2 / 3, 0.0),)),
    ((1 / 3, 0.0, 0.0), (-1 / 12, 0.0, 3 / 4)),
    "Celledoni, Marthinsen, Owren (2003)",
)

CF4 = CommutatorFree(
    "cf4",
    4,
    (0.0, 0.5, 0.5, 1.0),
    (
        (),
        ((0.5, 0.0, 0.0, 0.0),),
        ((0.0, 0.5, 0.0, 0.0),),
        ((0.5, 0.0, 0.0, 0.0), (-0.5, 0.0, 1.0, 0.0)),
    ),
    ((1 / 4, 1 / 6, 1 / 6, -1 / 12), (-1 / 12, 1 / 6, 1 / 6, 1 / 4)),
    "Celledoni, Marthinsen, Owren (2003), Table 2",
)

CG3 = _cg(
    "cg3",
    3,
    [[0, 0, 0], [3 / 4, 0, 0], [119 / 216, 17 / 108, 0]],
    [13 / 51, -2 / 3, 24 / 17],
    [0.0, 3 / 4, 17 / 24],
    "Crouch, Grossman (1993)",
)

CG4A = _cg(
    "cg4a",
    4,
    [
        [0, 0, 0, 0, 0],
        [0.8177227988124852, 0, 0, 0, 0],
        [0.3199876375476427, 0.0659864263556022, 0, 0, 0],
        [0.9214417194464946, 0.4997857776773573, -1.0969984448371582, 0, 0],
        [0.3552358559023322, 0.2390958372307326, 1.3918565724203246, -1.1092979392113465, 0],
    ],
    [0.1370831520630755, -0.0183698531564020, 0.7397813985370780, -0.1907142565505889, 0.3322195591068374],
    [0.0, 0.8177227988124852, 0.3859740639032449, 0.3242290522866937, 0.8768903263420429],
    "Owren, Marthinsen (1999), CG4a",
)

_METHODS = {
    "cf3": (CF3, "cf", "commutator-free, order 3, 3 stages, 2 exponentials (Celledoni–Marthinsen–Owren)"),
    "cf4": (CF4, "cf", "commutator-free, order 4, 4 stages, 2 exponentials (Celledoni–Marthinsen–Owren)"),
    "cg3": (CG3, "cg", "Crouch–Grossman, order 3, 3 stages (Crouch–Grossman 1993)"),
    "cg4a": (CG4A, "cg", "Crouch–Grossman, order 4, 5 stages (Owren–Marthinsen 1999, CG4a)"),
}


def _build(method: CommutatorFree, coordinates: str | None = None) -> CommutatorFree:
    return method


for _name, (_method, _family, _text) in _METHODS.items():
    register(MethodSpec(_name, _family, _method.order, partial(_build, _method), (), False, _text))
