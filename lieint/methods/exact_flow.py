"""The exact flow of the free 3D top as a method: any step, error at round-off.

One step moves the state by the exact body increment ``Q(h) = R(t)ᵀ R(t + h)``
(:func:`~lieint.systems.euler_top_attitude.euler_top_rotation`: Jacobi elliptic functions for
the momentum, an elliptic integral of the third kind for the rotation about the space
momentum) through the system's action: ``(A, R) ↦ (QᵀAQ, RQ)``. Its error is round-off
whatever h; it serves as the reference flow of long studies and as the free part of the
heavy-top splitting (``splitting2``… with ``free="exact"``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..groups.bivectors import vee
from .base import Method, MethodSpec, StepResult
from .moser_veselov import require_free_top
from .registry import register

__all__ = ["ExactFlow", "free_top_increment", "require_free_top3"]


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
    from ..systems.euler_top_attitude import euler_top_rotation

    P = inertia.P
    At = A if inertia.diagonal else np.swapaxes(P, -1, -2) @ A @ P
    w = vee(At * inertia.minus_inv_pair)  # body angular velocity in the principal frame
    moments = inertia.principal_moments
    flat = w.reshape(-1, 3)
    Q = np.stack([euler_top_rotation(moments, wi, [h])[0] for wi in flat]).reshape(A.shape)
    return Q if inertia.diagonal else P @ Q @ P.T


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
        return StepResult(system.act(free_top_increment(system.inertia, y["A"], h), y), None, 1, None)


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
