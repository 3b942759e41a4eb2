"""scipy's ``solve_ivp`` solvers on a lieint system: the baselines.

scipy's solvers choose their own steps, so they are not stepped by lieint's controllers: the
driver (:mod:`lieint.driver`) starts scipy's ``OdeSolver`` for the method (RK23, RK45, DOP853,
Radau, BDF, LSODA) and calls its ``step()`` — exactly what ``solve_ivp`` does — saving either the
accepted steps or, through scipy's dense output, the requested save times. So step counts are
real, and a projection is applied to the *saved copies only*: the solver's own state is never
touched (projecting it would restart the solver at every save point and change its errors).

The state dict (with all its batch members) is flattened into one vector, so an ensemble is
one ODE system for scipy: the step size and the error control are shared by all members.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from .base import Method, MethodSpec
from .registry import register

__all__ = ["SCIPY_SOLVERS", "ScipyMethod", "StateLayout"]

#: solve_ivp's methods and their orders (None: variable order).
SCIPY_SOLVERS = {"RK23": 3, "RK45": 5, "DOP853": 8, "Radau": 5, "BDF": None, "LSODA": None}


class StateLayout:
    """Flatten a state dict into one vector and back (fields in a fixed order)."""

    def __init__(self, y: dict):
        self.fields = [(k, np.shape(v)) for k, v in y.items()]
        self.sizes = [int(np.prod(shape)) for _, shape in self.fields]

    def pack(self, y: dict) -> np.ndarray:
        return np.concatenate([np.asarray(y[k], dtype=float).reshape(-1) for k, _ in self.fields])

    def unpack(self, z: np.ndarray) -> dict:
        out, start = {}, 0
        for (k, shape), size in zip(self.fields, self.sizes, strict=True):
            out[k] = z[start : start + size].reshape(shape)
            start += size
        return out

    def unpack_many(self, Z: np.ndarray) -> dict:
        """Columns of ``Z`` (size, m) as a dict of ``(m, *shape)`` arrays."""
        out, start = {}, 0
        m = Z.shape[1]
        for (k, shape), size in zip(self.fields, self.sizes, strict=True):
            out[k] = np.ascontiguousarray(Z[start : start + size].T).reshape((m, *shape))
            start += size
        return out


@dataclass(frozen=True)
class ScipyMethod(Method):
    """``scipy.integrate.solve_ivp(method=solver)`` on the embedded equations.

    Parameters
    ----------
    solver : str
        One of ``SCIPY_SOLVERS`` ("RK45", "DOP853", "Radau", "LSODA", …).
    first_step : float, optional
        The solver's first step (scipy's ``first_step``; default: scipy's estimate).
    max_step : float, optional
        The solver's largest step (scipy's ``max_step``; default: no bound).
    """

    solver: str
    first_step: float | None = None
    max_step: float | None = None

    self_controlled = True

    def __post_init__(self):
        if self.solver not in SCIPY_SOLVERS:
            raise ValueError(f"`solver`: unknown scipy solver {self.solver!r}; choose from {list(SCIPY_SOLVERS)}.")

    @property
    def name(self) -> str:  # type: ignore[override]
        return f"scipy:{self.solver}"

    @property
    def order(self) -> int | None:  # type: ignore[override]
        return SCIPY_SOLVERS[self.solver]

    def start(self, system, t0: float, y0: dict, t1: float, rtol: float, atol: float, first_step=None):
        """scipy's ``OdeSolver`` for this system from ``(t0, y0)`` towards ``t1``, and the layout."""
        from scipy.integrate import _ivp

        layout = StateLayout(y0)

        def rhs(t, z):
            return layout.pack(system.vector_field(t, layout.unpack(z)))

        cls = getattr(_ivp, self.solver)
        first_step = self.first_step if first_step is None else first_step
        options = {} if first_step is None else {"first_step": first_step}
        if self.max_step is not None:
            options["max_step"] = self.max_step
        return cls(rhs, t0, layout.pack(y0), t1, rtol=rtol, atol=atol, **options), layout

    def step(self, system, t, y, h, state):
        raise TypeError(
            f"{self.name} chooses its own steps inside scipy; it is run by lieint's driver through "
            "`start` (use lieint.integrate), not stepped with a given h."
        )


def _build(solver: str, coordinates: str | None = None) -> ScipyMethod:
    return ScipyMethod(solver)


for _solver, _order in SCIPY_SOLVERS.items():
    register(
        MethodSpec(
            f"scipy:{_solver}",
            "scipy",
            _order,
            partial(_build, _solver),
            adaptive=True,
            description=f"scipy.integrate.solve_ivp(method={_solver!r}) on the embedded equations",
        )
    )
