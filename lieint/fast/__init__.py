"""Compiled fast paths (numba), chosen by :func:`lieint.integrate` when they apply.

Only imported when first used, so ``import lieint`` stays light; numba compiles on the first
call in a fresh environment and caches the machine code on disk for later processes.
"""

from __future__ import annotations

import numpy as np

from ..groups.base import bernoulli_dexpinv_coefficients
from ..groups.bivectors import hat, vee

__all__ = ["Top3Kernel", "supports", "within_range"]


def supports(system, stepper) -> bool:
    """Whether a compiled kernel covers this system and method (else the generic path runs)."""
    from ..systems.euler_top import EulerTop

    if type(system) is not EulerTop or system.n != 3:
        return False
    if stepper.kind == "lie":
        return stepper.coordinates == "exp" and stepper.dexpinv_degree is not None
    return stepper.kind == "classical"


def within_range(system, stepper, y0, h) -> bool:
    """Cheap a-priori bound that every stage increment stays inside the dexp⁻¹ radius.

    ``|Π|`` is conserved, so ``|w| ≤ |Π|/I_min``; a stage increment is at most
    ``h · max_i Σ_j |a_ij| · |k|``. Requiring this below π (half the radius 2π of so(3)) leaves
    room for the higher dexp⁻¹ terms; otherwise the generic path runs and checks exactly.
    """
    if stepper.kind != "lie":
        return True
    A = y0["A"]
    pi_norm = np.sqrt(0.5 * np.sum(A * A, axis=(-2, -1)))
    wmax = float(np.max(pi_norm, initial=0.0)) / float(np.min(system.principal_moments))
    rows = np.abs(stepper.tableau.A).sum(axis=1)
    reach = h * wmax * max(float(np.max(rows)), float(np.abs(stepper.tableau.b).sum()))
    return reach < np.pi


class Top3Kernel:
    """The compiled 3D-top kernel with its own state representation ``(Π, R P)`` in the
    principal frame (P a proper eigenbasis of B), so that a run split into segments gives the
    same bits as one that is not: the conversion to ``(A, R)`` happens only on output."""

    def __init__(self, system, stepper):
        self.system, self.stepper = system, stepper
        P = system.P.copy()
        if np.linalg.det(P) < 0:  # a proper rotation keeps Π a vector (not a pseudo-vector)
            P[:, -1] *= -1.0
        self.P = P
        self.coeffs = bernoulli_dexpinv_coefficients(stepper.dexpinv_degree) if stepper.kind == "lie" else (1.0,)

    def start(self, y: dict) -> dict:
        self.batch = self.system.batch_shape(y)
        A = y["A"].reshape(-1, 3, 3)
        R = y["R"].reshape(-1, 3, 3) if "R" in y else np.broadcast_to(np.eye(3), A.shape)
        return {"pi": -vee(self.P.T @ A @ self.P), "R": np.ascontiguousarray(R @ self.P)}

    def advance(self, internal: dict, k_from: int, k_to: int, plan, save_steps, project: bool):
        from .top3 import integrate_top3

        tab = self.stepper.tableau
        out_pi, out_R, fin_pi, fin_R = integrate_top3(
            internal["pi"],
            internal["R"],
            self.system.principal_moments,
            tab.A,
            tab.b,
            self.coeffs,
            self.stepper.kind == "lie",
            plan.h,
            plan.last_step,
            k_from,
            k_to,
            plan.nsteps,
            save_steps,
            project,
        )
        return {"pi": fin_pi, "R": fin_R}, self._user(out_pi, out_R)

    def _user(self, pi, R) -> dict:
        lead = pi.shape[:-2]
        states = {"A": (self.P @ (-hat(pi)) @ self.P.T).reshape(lead + self.batch + (3, 3))}
        if "R" in self.system.fields:
            states["R"] = (R @ self.P.T).reshape(lead + self.batch + (3, 3))
        return states

    def user_state(self, internal: dict) -> dict:
        return {k: v[0] for k, v in self._user(internal["pi"][None], internal["R"][None]).items()}
