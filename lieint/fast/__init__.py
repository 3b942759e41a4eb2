"""Compiled fast paths (numba), chosen by :func:`lieint.integrate` when they apply.

Only imported when first used, so ``import lieint`` stays light; numba compiles on the first
call in a fresh environment and caches the machine code on disk for later processes.
"""

from __future__ import annotations

import numpy as np

from ..groups.base import bernoulli_dexpinv_coefficients
from ..groups.bivectors import hat, vee

__all__ = ["run_fast", "supports"]


def supports(system, stepper) -> bool:
    """Whether a compiled kernel covers this system and method (else the generic path runs)."""
    from ..systems.euler_top import EulerTop

    if type(system) is not EulerTop or system.n != 3:
        return False
    if stepper.kind == "lie":
        return stepper.coordinates == "exp" and stepper.dexpinv_degree is not None
    return stepper.kind == "classical"


def _principal_frame(system):
    P = system.P.copy()
    if np.linalg.det(P) < 0:  # a proper rotation keeps Π a vector (not a pseudo-vector)
        P[:, -1] *= -1.0
    return P


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


def run_fast(system, stepper, y0, h, h_last, nsteps, save_steps, project):
    """Integrate with the compiled kernel; returns the saved states dict ``(m, *batch, …)``."""
    from .top3 import integrate_top3

    batch = system.batch_shape(y0)
    P = _principal_frame(system)
    A = y0["A"].reshape(-1, 3, 3)
    R = y0["R"].reshape(-1, 3, 3) if "R" in y0 else np.broadcast_to(np.eye(3), A.shape)
    pi0 = -vee(P.T @ A @ P)
    R0 = R @ P
    if stepper.kind == "lie":
        coeffs = bernoulli_dexpinv_coefficients(stepper.dexpinv_degree)
    else:
        coeffs = (1.0,)
    tab = stepper.tableau
    out_pi, out_R = integrate_top3(
        pi0,
        R0,
        system.principal_moments,
        tab.A,
        tab.b,
        coeffs,
        stepper.kind == "lie",
        h,
        h_last,
        nsteps,
        save_steps,
        project,
    )
    m = out_pi.shape[0]
    states = {"A": (P @ (-hat(out_pi)) @ P.T).reshape((m,) + batch + (3, 3))}
    if "R" in system.fields:
        states["R"] = (out_R @ P.T).reshape((m,) + batch + (3, 3))
    return states
