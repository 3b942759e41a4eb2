"""The exact flow of the free 3D top as a method: any step, error at round-off.

One step moves the state by the exact body increment ``Q(h) = R(t)ᵀ R(t + h)``
(:func:`~lieint.systems.euler_top_attitude.euler_top_rotation`: Jacobi elliptic functions for
the momentum, an elliptic integral of the third kind for the rotation about the space
momentum) through the system's action: ``(A, R) ↦ (QᵀAQ, RQ)``. Its error is round-off
whatever h; it serves as the reference flow of long studies and as the free part of the
heavy-top splitting (``splitting2``… with ``free="exact"``).

Round-off over many steps. Stepped, the flow restarts from each rounded state, and a short
step is formed so that it errs by no more than the rounding of the new state
(:mod:`lieint.systems.euler_top_step`): the increment ``K = Q − I`` from the addition theorems
and small rotations, to a few ε‖K‖, applied without forming Q
(:meth:`lieint.EulerTop.act_near_identity`). Formed, as before, as the product of three frames
from the elliptic functions at the new phase, K was exact to ε *absolute* and ``I + K``
orthogonal to ε only: the gap ``G² − 2EI₁`` that sets the elliptic frequency moved by 7.4e-16 a
step on Hairer–Vilmart's body (0.6, 0.8, 1) with Π = (1.8, 0.4, −0.9) (the rounding of the new
state: 8e-17), and with w taken as A times the rounded reciprocals −1/(b_i + b_j) — for the flat
body with moments 1, 2, 3, ``fl(1/3)`` made w₃ too small by the same 5.6e-17 at every step — the
phase error of a long run grew like t² (T = 1000, h = 0.1, distance from the one-shot
solution: flat body 8.2e-11 then, 1.6e-12 … 4.6e-12 now, TOMS 903's FRB_STEP 2.0e-11;
Hairer–Vilmart's body 0.9e-12 … 2.6e-12 now, FRB_STEP 2.9e-12; benchmarks/reference_codes.py).

Compiled. On the 3D top the short step runs on the compiled engine (:mod:`lieint.fast.top3_exact`:
the same step in double-double arithmetic, batched over bodies, about 15 µs a body-step against
1.5 µs for FRB_STEP and 1.6 ms here); a run with a step longer than the short phase
(``|λh| > 1`` for some body) keeps this module's closed form, and says so in
``sol.stats.backend_reason``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..groups.bivectors import vee
from .base import Method, MethodSpec, StepResult
from .moser_veselov import act_near_identity, require_free_top
from .registry import register

__all__ = ["ExactFlow", "free_top_increment", "free_top_increment_minus_identity", "require_free_top3"]


def free_top_increment(inertia, A: np.ndarray, h: float) -> np.ndarray:
    """The exact body increment ``Q(h) ∈ SO(3)`` of the free 3D top from momenta A (batched).

    Parameters
    ----------
    inertia : InertiaOperator
        The body (n = 3).
    A : ndarray, shape (..., 3, 3)
        Body angular momentum bivectors.
    h : float
        The time step (any sign).
    """
    return np.eye(3) + free_top_increment_minus_identity(inertia, A, h)


def free_top_increment_minus_identity(inertia, A: np.ndarray, h: float) -> np.ndarray:
    """``Q(h) − I`` for the increment of :func:`free_top_increment`, without forming Q (batched).

    A short step (``|λh| ≤ 1``) is exact to a few ε‖K‖ and ``I + K`` orthogonal to ε‖K‖
    (:func:`~lieint.systems.euler_top_step.euler_top_step_minus_identity`); a longer one takes
    the closed form (:func:`~lieint.systems.euler_top_attitude.euler_top_rotation_minus_identity`).
    """
    from ..systems.euler_top_step import euler_top_step_minus_identity

    P = inertia.P
    At = A if inertia.diagonal else np.swapaxes(P, -1, -2) @ A @ P
    moments = inertia.principal_moments
    Pi = -vee(At).reshape(-1, 3)  # the body momenta in the principal frame (A = −Π̂)
    K = np.stack([euler_top_step_minus_identity(moments, p, h) for p in Pi]).reshape(A.shape)
    return K if inertia.diagonal else P @ K @ P.T


def require_free_top3(method_name: str, system) -> None:
    """Raise ``ValueError`` naming the method unless ``system`` is a free top with n = 3."""
    require_free_top(method_name, system)
    if system.inertia.n != 3:
        raise ValueError(
            f"`method` {method_name!r} (the exact elliptic flow) needs a 3D top; got n = {system.inertia.n}."
        )


@dataclass(frozen=True)
class ExactFlow(Method):
    """The exact flow of the free 3D top (see the module docstring).

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> sol = lieint.integrate(top, y0, (0.0, 5.0), h=2.5, method="exact_flow")
    >>> exact = top.exact_solution([5.0], y0)
    >>> bool(abs(sol.states["R"][-1] - exact["R"][-1]).max() < 1e-13)
    True
    """

    name: str = "exact_flow"
    order: int | None = None

    group_action = True
    #: exact at any step: no step-size warning applies
    any_step = True

    def check_system(self, system) -> None:
        require_free_top3(self.name, system)

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        K = free_top_increment_minus_identity(system.inertia, y["A"], h)
        return StepResult(act_near_identity(system, K, y), None, 1, None)

    def compiled(self):
        """The compiled engine's form: the short step in double-double arithmetic for the 3D top
        (:mod:`lieint.fast.top3_exact`; a long step there is cut into short ones)."""
        if not self.steps_as(ExactFlow, ("step", "check_system")):
            return None
        from ..fast.forms import MapForm

        return MapForm("exact_flow", COMPILED_EXACT_FLOW)


#: where the exact flow has compiled stage code: system form (class name) -> module
COMPILED_EXACT_FLOW = {"Top3Form": "lieint.fast.top3_exact"}


def _build(coordinates: str | None = None) -> ExactFlow:
    return ExactFlow()


register(
    MethodSpec(
        "exact_flow",
        "exact",
        None,
        _build,
        description="the exact flow of the free 3D top (elliptic functions and integrals), any step",
    )
)
