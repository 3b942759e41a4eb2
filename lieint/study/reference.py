"""The truth a study measures errors against, on the whole state, with its own accuracy.

Errors are taken on *every* field of the state (the momentum or angular velocity, the
orientation R, the centre, the gravity directions), as ``max_t ‖y(t) − y_ref(t)‖ / ‖y(0)‖`` with
the fields stacked into one vector. The reference is

* **exact** where a closed form exists:

  - the 3D Euler top: the body momentum ``A(t)`` in Jacobi elliptic functions
    (:meth:`lieint.EulerTop.exact_solution`) and the attitude ``R(t)`` from it. The space
    momentum ``R A Rᵀ`` is constant, so with ``ℓ = vee(A)``, ``R ℓ̂`` is a fixed unit vector
    ``m̂``: write ``R(t) = R₀ G₀ᵀ Z(φ(t)) G(t)``, with ``G(t)`` the rotation whose rows are an
    orthonormal frame ``(u₁, u₂, ℓ̂)`` built from ``ℓ̂(t)`` and a body axis, and ``Z(φ)`` the
    rotation by φ about ``e₃``. ``Ṙ = RΩ`` then gives the one scalar equation
    ``Ω − GᵀĠ = φ̇ GᵀE₃G`` (``E₃ = Z′(0)``), so ``φ̇ = ⟨Ω − GᵀĠ, GᵀE₃G⟩ / ⟨GᵀE₃G, GᵀE₃G⟩`` with
    ``Ȧ = [A, Ω]`` known exactly; φ is its integral by 16-point Gauss–Legendre quadrature on
    intervals of 0.05 (exact to round-off for this analytic integrand);
  - the uniform ball released from rest on an incline (docs/theory.md §4): the centre accelerates at
    ``a = g_t M r² / (M r² + 2λ)`` (``(n+2)/(n+4) g sin θ``), the ball turns in the plane of ``â``
    and the normal ν by ``φ(t) = |a| t² / (2r)``: ``R(t) = exp(φK) R₀`` with ``K = âνᵀ − νâᵀ``,
    ``Ω = Rᵀ φ̇ K R``, ``Γ = Rᵀν``, ``G = Rᵀg``;

  whose accuracy (``floor``) is the round-off of the formulas, ``EXACT_FLOOR`` relative;
* otherwise scipy's DOP853 at ``rtol = 1e-13`` (``atol = 1e-15``) with its dense output, and its
  own error estimated by a second run at ``rtol = 1e-12``: the largest difference of the two over
  the span is the floor (it measures the looser run's error, so it overstates the tighter one's —
  a conservative floor).

A measured error below ``RESOLVED × floor`` is not resolved by the reference (the reference's
error could be a tenth of it or more); the study marks such points instead of plotting them as
truth.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["EXACT_FLOOR", "RESOLVED", "Reference", "reference_for", "state_error"]

#: relative accuracy assumed for the closed forms (round-off of the elliptic functions and the
#: quadrature, measured against each other in tests/study/test_study.py)
EXACT_FLOOR = 1e-13
#: a measured error is resolved when it is at least this many times the reference's floor
RESOLVED = 10.0
#: tolerances of the numerical reference and of the run that estimates its error
REFERENCE_RTOL, CHECK_RTOL = 1e-13, 1e-12
#: Gauss–Legendre nodes per quadrature interval and the interval of the attitude quadrature
_GL_NODES, _GL_INTERVAL = 16, 0.05


@dataclass
class Reference:
    """The truth of a study.

    Attributes
    ----------
    kind : str
        What it is ("exact (…)" or "DOP853 at rtol 1e-13 …").
    evaluate : callable
        ``evaluate(t) -> dict``: every compared field at the times ``t`` (shape ``(m, …)``).
    fields : tuple of str
        The fields compared (the whole state).
    floor : float
        The reference's own relative error (estimated, see the module docstring).
    exact : bool
        True for a closed form.
    """

    kind: str
    evaluate: Callable[[np.ndarray], dict]
    fields: tuple[str, ...]
    floor: float
    exact: bool

    def resolved(self, error: float) -> bool:
        """Whether ``error`` is above what the reference can resolve."""
        return bool(error >= RESOLVED * self.floor)


def state_scale(y0: dict, fields) -> float:
    """``‖y(0)‖`` over ``fields`` stacked (1 when zero)."""
    return float(np.sqrt(sum(np.sum(np.square(y0[f])) for f in fields))) or 1.0


def state_error(t: np.ndarray, states: dict, reference: Reference, scale: float) -> tuple[float, dict]:
    """``(max_t ‖y − y_ref‖ / scale, {field: max_t ‖y_f − y_ref,f‖ / scale})`` at the saved times."""
    ref = reference.evaluate(np.asarray(t, dtype=float))
    total = np.zeros(len(t))
    per_field = {}
    for f in reference.fields:
        sq = np.sum(np.square(states[f] - ref[f]).reshape(len(t), -1), axis=1)
        total += sq
        per_field[f] = float(np.sqrt(np.max(sq)) / scale)
    return float(np.sqrt(np.max(total)) / scale), per_field


def reference_for(scene, system, y0: dict) -> Reference:
    """The exact solution where one exists for this scene and state, else DOP853 at rtol 1e-13."""
    ref = _exact_top3(scene, system, y0) or _exact_incline(scene, system, y0)
    return ref if ref is not None else _dop853(scene, system, y0)


# -- the 3D Euler top with its attitude ----------------------------------------------------------


def _exact_top3(scene, system, y0) -> Reference | None:
    from ..systems import EulerTop

    if not (isinstance(system, EulerTop) and system.n == 3) or set(system.fields) - {"A", "R"}:
        return None
    if np.shape(y0["A"]) != (3, 3):  # ensembles: the numerical reference
        return None
    t0 = float(scene.t_start)
    if "R" not in system.fields:
        return Reference(
            "exact (Jacobi elliptic)",
            lambda t: {"A": system.exact_solution(np.asarray(t) - t0, y0)["A"]},
            ("A",),
            EXACT_FLOOR,
            True,
        )
    attitude = _TopAttitude(system, y0, t0, float(scene.t_end))

    def evaluate(t):
        A, R = attitude(np.asarray(t, dtype=float))
        return {"A": A, "R": R}

    return Reference("exact (Jacobi elliptic, attitude by quadrature)", evaluate, ("A", "R"), EXACT_FLOOR, True)


_E3 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


class _TopAttitude:
    """``t ↦ (A(t), R(t))`` of the free 3D top (see the module docstring)."""

    def __init__(self, system, y0, t0: float, t1: float):
        self.system, self.y0, self.t0 = system, y0, t0
        nodes, weights = np.polynomial.legendre.leggauss(_GL_NODES)
        self.nodes, self.weights = 0.5 * (nodes + 1.0), 0.5 * weights  # on [0, 1]
        m = max(1, int(np.ceil((t1 - t0) / _GL_INTERVAL)))
        self.dt = (t1 - t0) / m
        grid = t0 + self.dt * np.arange(m + 1)
        # the body axis farthest from ℓ̂ over the run completes ℓ̂ to a frame without a singularity
        ell = _unit(self._ell(self._exact(grid)[0]))
        self.axis = int(np.argmin(np.max(np.abs(ell), axis=0)))
        _, _, G0 = self._frame(self._exact(np.array([t0])))
        self.left = y0["R"] @ G0[0].T
        increments = self._integral(grid[:-1], np.full(m, self.dt))
        self.phi_grid = np.concatenate([[0.0], np.cumsum(increments)])

    def _exact(self, t):
        ex = self.system.exact_solution(t - self.t0, self.y0)
        return ex["A"], ex["Omega"]

    @staticmethod
    def _ell(A):
        return np.stack([A[..., 2, 1], A[..., 0, 2], A[..., 1, 0]], axis=-1)

    def _frame(self, exact):
        """``φ̇``, and the frame G (rows u₁, u₂, ℓ̂) at the states ``exact = (A, Ω)``."""
        A, Om = exact
        ell, ell_dot = self._ell(A), self._ell(A @ Om - Om @ A)  # Ȧ = [A, Ω]
        norm = np.linalg.norm(ell, axis=-1, keepdims=True)
        u3 = ell / norm
        u3d = (ell_dot - np.sum(ell_dot * u3, axis=-1, keepdims=True) * u3) / norm
        e = np.zeros(3)
        e[self.axis] = 1.0
        c = u3 @ e
        w = e - c[:, None] * u3
        wd = -(u3d @ e)[:, None] * u3 - c[:, None] * u3d
        wn = np.linalg.norm(w, axis=-1, keepdims=True)
        u1 = w / wn
        u1d = (wd - np.sum(wd * u1, axis=-1, keepdims=True) * u1) / wn
        u2 = np.cross(u3, u1)
        u2d = np.cross(u3d, u1) + np.cross(u3, u1d)
        G, Gd = np.stack([u1, u2, u3], axis=-2), np.stack([u1d, u2d, u3d], axis=-2)
        K = np.swapaxes(G, -1, -2) @ _E3 @ G
        X = Om - np.swapaxes(G, -1, -2) @ Gd
        phidot = np.sum(X * K, axis=(-2, -1)) / np.sum(K * K, axis=(-2, -1))
        return phidot, exact, G

    def _integral(self, a, length):
        """``∫_a^{a+length} φ̇`` for arrays ``a``, ``length`` (Gauss–Legendre)."""
        t = a[:, None] + length[:, None] * self.nodes[None, :]
        phidot, _, _ = self._frame(self._exact(t.reshape(-1)))
        return length * (phidot.reshape(t.shape) @ self.weights)

    def __call__(self, t):
        j = np.clip(np.floor((t - self.t0) / self.dt).astype(int), 0, self.phi_grid.size - 1)
        start = self.t0 + j * self.dt
        phi = self.phi_grid[j] + self._integral(start, t - start)
        _, (A, _), G = self._frame(self._exact(t))
        c, s = np.cos(phi), np.sin(phi)
        Z = np.zeros((t.size, 3, 3))
        Z[:, 0, 0], Z[:, 0, 1], Z[:, 1, 0], Z[:, 1, 1], Z[:, 2, 2] = c, -s, s, c, 1.0
        return A, self.left @ Z @ G


# -- the uniform ball on an incline ---------------------------------------------------------------


def _exact_incline(scene, system, y0) -> Reference | None:
    from ..systems import RollingBall

    if not isinstance(system, RollingBall) or scene.gravity is None:
        return None
    n = system.n
    if not (
        np.allclose(system.B_C, system.B_C[0, 0] * np.eye(n))
        and not np.any(system.center_of_mass)
        and np.shape(y0["R"]) == (n, n)
        and not np.any(y0["Omega"])
        and set(system.fields) <= {"Omega", "Gamma", "G", "R", "center"}
    ):
        return None
    lam, M, r, nu = system.B_C[0, 0], system.mass, system.radius, system.normal
    g = np.asarray(scene.gravity, dtype=float)
    g_t = g - (g @ nu) * nu
    accel = g_t * M * r * r / (M * r * r + 2 * lam)  # docs/theory.md §4, from rest
    a = float(np.linalg.norm(accel))
    if a == 0.0:
        return None
    ahat = accel / a
    K = np.outer(ahat, nu) - np.outer(nu, ahat)
    t0, R0 = float(scene.t_start), y0["R"]
    fields = tuple(system.fields)

    def evaluate(t):
        tau = np.asarray(t, dtype=float) - t0
        phi = a * tau**2 / (2 * r)
        E = np.eye(n) + np.sin(phi)[:, None, None] * K + (1 - np.cos(phi))[:, None, None] * (K @ K)
        R = E @ R0
        Rt = np.swapaxes(R, -1, -2)
        out = {
            "R": R,
            "Omega": Rt @ ((a * tau / r)[:, None, None] * K) @ R,
            "Gamma": Rt @ nu,
            "G": Rt @ g,
        }
        if "center" in fields:
            out["center"] = y0["center"] + 0.5 * np.multiply.outer(tau**2, accel)
        return {f: out[f] for f in fields}

    return Reference(f"exact ((n+2)/(n+4) g sin θ, n = {n}, with R and Ω)", evaluate, fields, EXACT_FLOOR, True)


# -- the numerical reference ------------------------------------------------------------------------


def _dop853(scene, system, y0) -> Reference:
    from scipy.integrate import solve_ivp

    from ..methods.scipy_ivp import StateLayout

    layout = StateLayout(y0)

    def rhs(t, z):
        return layout.pack(system.vector_field(t, layout.unpack(z)))

    span = (float(scene.t_start), float(scene.t_end))
    z0 = layout.pack(y0)
    runs = [
        solve_ivp(rhs, span, z0, method="DOP853", rtol=rtol, atol=rtol * 1e-2, dense_output=True)
        for rtol in (REFERENCE_RTOL, CHECK_RTOL)
    ]
    for run in runs:
        if not run.success:
            raise RuntimeError(f"the DOP853 reference failed: {run.message}")
    fields = tuple(system.fields)
    scale = state_scale(y0, fields)
    check = np.linspace(*span, 2001)
    floor = float(np.max(np.linalg.norm(runs[0].sol(check) - runs[1].sol(check), axis=0)) / scale)
    tight = runs[0].sol

    def evaluate(t):
        return layout.unpack_many(np.atleast_2d(tight(np.asarray(t, dtype=float))))

    kind = f"DOP853 at rtol {REFERENCE_RTOL:g} (its error ≤ {floor:.1e}, from a second run at rtol {CHECK_RTOL:g})"
    return Reference(kind, evaluate, fields, max(floor, EXACT_FLOOR), False)
