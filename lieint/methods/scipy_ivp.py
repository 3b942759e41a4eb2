"""Adapter running any ``scipy.integrate.solve_ivp`` method on a lieint system.

The state dict (with all its batch members) is flattened into one vector, so an ensemble
is one ODE system for scipy: the step size and the error control are shared by all
members. ``project=True`` restarts the solver at every saved time from the projected state
(scipy offers no hook inside a step), so the projection acts at the save points only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SCIPY_SOLVERS", "ScipyMethod"]

#: solve_ivp's methods and their orders (None: variable order).
SCIPY_SOLVERS = {"RK23": 3, "RK45": 5, "DOP853": 8, "Radau": 5, "BDF": None, "LSODA": None}


@dataclass(frozen=True)
class ScipyMethod:
    """``scipy.integrate.solve_ivp(method=solver)`` on the embedded equations.

    Parameters
    ----------
    solver : str
        One of ``SCIPY_SOLVERS`` ("RK45", "DOP853", "Radau", "LSODA", …).
    """

    solver: str

    kind = "scipy"
    coordinates = None

    def __post_init__(self):
        if self.solver not in SCIPY_SOLVERS:
            raise ValueError(f"Unknown scipy solver {self.solver!r}; choose from {list(SCIPY_SOLVERS)}.")

    @property
    def name(self) -> str:
        return f"scipy:{self.solver}"

    @property
    def order(self) -> int | None:
        return SCIPY_SOLVERS[self.solver]

    def solve(self, system, y0: dict, t_save: np.ndarray, rtol: float, atol: float, project: bool):
        """Integrate and return ``(states at t_save, nfev, success, message)``."""
        from scipy.integrate import solve_ivp

        layout = [(k, v.shape) for k, v in y0.items()]

        def pack(y):
            return np.concatenate([y[k].reshape(-1) for k, _ in layout])

        def unpack(z):
            out, start = {}, 0
            for k, shape in layout:
                size = int(np.prod(shape))
                out[k] = z[start : start + size].reshape(shape)
                start += size
            return out

        def rhs(t, z):
            return pack(system.vector_field(t, unpack(z)))

        states = {k: np.empty((len(t_save),) + shape) for k, shape in layout}
        nfev, success, message = 0, True, "The solver successfully reached the end of the integration interval."
        if not project:
            sol = solve_ivp(
                rhs, (t_save[0], t_save[-1]), pack(y0), method=self.solver, t_eval=t_save, rtol=rtol, atol=atol
            )
            nfev, success, message = sol.nfev, sol.success, sol.message
            m = sol.y.shape[1]
            for j in range(m):
                for k, v in unpack(sol.y[:, j]).items():
                    states[k][j] = v
            if m < len(t_save):
                states = {k: v[:m] for k, v in states.items()}
            return states, nfev, success, message
        y = y0
        for k, v in y.items():
            states[k][0] = v
        for j in range(1, len(t_save)):
            sol = solve_ivp(rhs, (t_save[j - 1], t_save[j]), pack(y), method=self.solver, rtol=rtol, atol=atol)
            nfev += sol.nfev
            if not sol.success:
                states = {k: v[:j] for k, v in states.items()}
                return states, nfev, False, sol.message
            y = system.project(unpack(sol.y[:, -1]))
            for k, v in y.items():
                states[k][j] = v
        return states, nfev, success, message
