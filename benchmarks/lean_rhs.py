"""Lean right-hand sides for the DOP853 baselines: each built-in system's equations in plain numpy.

A baseline that integrates lieint's own ``system.vector_field`` with ``solve_ivp`` pays for
lieint's generality (state dictionaries, batched shapes, the group action's infinitesimal
form) at every evaluation — measured 6–18× the cost of the same equations written out, as a
user of scipy would. Every "× DOP853" figure of the benchmarks is therefore measured against
these functions, lieint's vector field only beside it.

:func:`lean_rhs` returns ``f(t, z)`` on the flat state (the system's ``fields`` in order,
each raveled, as ``np.concatenate``), for

* the Euler top ``Ȧ = [A, Ω]``, ``Ṙ = RΩ``: n = 3 in floats on the vectors ``A = −Π̂``,
  ``Π̇ = Π × w``, ``w = J⁻¹Π`` with the inertia tensor ``J = tr(B) − B``; n ≥ 4 in numpy with
  Ω from A in the eigenbasis of B, ``Ω_ij = −Ã_ij/(b_i + b_j)``, as one ``n² × n²`` matrix;
* the heavy top, adding ``M X_G ∧ Γ`` and ``Γ̇ = −ΩΓ`` (n = 3: ``Π̇ = Π × w + M X_G × Γ``);
* the rolling ball with an offset centre of mass (n = 3, any gravity): ``B_K Ω̇ + Ω̇ B_K =
  B_K Ω² − Ω² B_K − M (X_G + κ) ∧ (G + Ω²κ)``, in vectors ``J_K ẇ = w × B_K w − M f × l``
  (``f = G + Ω²κ``, ``l = X_G + κ``, ``J_K = tr(B_K) − B_K``), ``Γ̇ = −ΩΓ``, ``Ġ = −ΩG``,
  ``Ṙ = RΩ``, centre ``ṗ = r RΩΓ``;
* the Chaplygin ball ``Ȧ = [A, Ω]`` with ``B_K(Γ) = B_C + M r² ΓΓᵀ`` (n = 3: ``w = J_K⁻¹Π``;
  n ≥ 4: Ω from ``−A = B_K Ω + Ω B_K`` as one ``d × d`` linear solve, the matrix linear in B_K),
  ``Γ̇ = −ΩΓ``, R and the centre as the ball's.

:func:`check` compares one with ``system.vector_field`` at random states (the benchmarks call
it before timing; ``tests/benchmarks/test_lean_rhs.py`` too).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

import lieint

__all__ = ["check", "flatten", "lean_rhs", "unflatten"]


def flatten(system, y: dict) -> np.ndarray:
    """The state as one vector, fields in ``system.fields`` order."""
    return np.concatenate([np.asarray(y[name], dtype=float).ravel() for name in system.fields])


def unflatten(system, z: np.ndarray) -> dict:
    out, start = {}, 0
    for name, shape in system.fields.items():
        size = int(np.prod(shape))
        out[name] = z[start : start + size].reshape(shape)
        start += size
    return out


def _slices(system) -> dict[str, slice]:
    out, start = {}, 0
    for name, shape in system.fields.items():
        size = int(np.prod(shape))
        out[name] = slice(start, start + size)
        start += size
    return out


def lean_rhs(system) -> Callable[[float, np.ndarray], np.ndarray]:
    """``f(t, z)`` of the system's equations in plain numpy (see the module docstring)."""
    n = system.n
    if isinstance(system, lieint.EulerTop):
        return _euler_top3(system) if n == 3 else _euler_top(system)
    if isinstance(system, lieint.HeavyTop):
        return _heavy_top3(system) if n == 3 else _heavy_top(system)
    if isinstance(system, lieint.ChaplyginBall):
        return _chaplygin3(system) if n == 3 else _chaplygin(system)
    if isinstance(system, lieint.RollingBall) and n == 3:
        return _rolling_ball3(system)
    raise NotImplementedError(f"no lean right-hand side for {system!r}")


# -- n = 3: float arithmetic on the vectors (A = −Π̂: A[1,2], A[2,0], A[0,1] = Π; Ω = ŵ) ----------


def _solve3(m, c):
    """``x`` with ``m x = c`` for a 3 × 3 matrix given as 9 floats (row-major), by cofactors."""
    m0, m1, m2, m3, m4, m5, m6, m7, m8 = m
    c0, c1, c2 = c
    k0, k3, k6 = m4 * m8 - m5 * m7, m5 * m6 - m3 * m8, m3 * m7 - m4 * m6
    det = m0 * k0 + m1 * k3 + m2 * k6
    x0 = (k0 * c0 + (m2 * m7 - m1 * m8) * c1 + (m1 * m5 - m2 * m4) * c2) / det
    x1 = (k3 * c0 + (m0 * m8 - m2 * m6) * c1 + (m2 * m3 - m0 * m5) * c2) / det
    x2 = (k6 * c0 + (m1 * m6 - m0 * m7) * c1 + (m0 * m4 - m1 * m3) * c2) / det
    return x0, x1, x2


def _bivector_rate(d1, d2, d3):
    """The 9 entries of ``−d̂`` (the rate of A = −Π̂ for Π̇ = d)."""
    return [0.0, d3, -d2, -d3, 0.0, d1, d2, -d1, 0.0]


def _r_hat(R, w1, w2, w3):
    """The 9 entries of ``R ŵ`` (R as 9 floats, row-major)."""
    out = []
    for i in (0, 3, 6):
        r0, r1, r2 = R[i], R[i + 1], R[i + 2]
        out += [r1 * w3 - r2 * w2, r2 * w1 - r0 * w3, r0 * w2 - r1 * w1]
    return out


def _jinv(B):
    """The inverse inertia tensor ``(tr(B) − B)⁻¹`` as 9 floats."""
    return np.linalg.inv(np.trace(B) * np.eye(3) - B).ravel().tolist()


def _euler_top3(system):
    j0, j1, j2, j3, j4, j5, j6, j7, j8 = _jinv(system.B)
    s = _slices(system)
    r = s.get("R")

    def f(t, z):
        a = z.tolist()
        p1, p2, p3 = a[5], a[6], a[1]
        w1, w2, w3 = j0 * p1 + j1 * p2 + j2 * p3, j3 * p1 + j4 * p2 + j5 * p3, j6 * p1 + j7 * p2 + j8 * p3
        out = _bivector_rate(p2 * w3 - p3 * w2, p3 * w1 - p1 * w3, p1 * w2 - p2 * w1)
        if r is not None:
            out += _r_hat(a[r], w1, w2, w3)
        return np.array(out)

    return f


def _heavy_top3(system):
    j0, j1, j2, j3, j4, j5, j6, j7, j8 = _jinv(system.B)
    m1, m2, m3 = (system.mass * system.center_of_mass).tolist()
    s = _slices(system)
    g, r = s["Gamma"].start, s.get("R")

    def f(t, z):
        a = z.tolist()
        p1, p2, p3 = a[5], a[6], a[1]
        g1, g2, g3 = a[g], a[g + 1], a[g + 2]
        w1, w2, w3 = j0 * p1 + j1 * p2 + j2 * p3, j3 * p1 + j4 * p2 + j5 * p3, j6 * p1 + j7 * p2 + j8 * p3
        # Π̇ = Π × w + M X_G × Γ,  Γ̇ = Γ × w
        out = _bivector_rate(
            p2 * w3 - p3 * w2 + m2 * g3 - m3 * g2,
            p3 * w1 - p1 * w3 + m3 * g1 - m1 * g3,
            p1 * w2 - p2 * w1 + m1 * g2 - m2 * g1,
        )
        out += [g2 * w3 - g3 * w2, g3 * w1 - g1 * w3, g1 * w2 - g2 * w1]
        if r is not None:
            out += _r_hat(a[r], w1, w2, w3)
        return np.array(out)

    return f


def _pose_rates3(out, a, s, w1, w2, w3, g1, g2, g3, radius):
    """``Ṙ = Rŵ`` and the centre's ``ṗ = r R (w × Γ)`` where the state has them."""
    if "R" in s:
        R = a[s["R"]]
        out += _r_hat(R, w1, w2, w3)
        if "center" in s:
            v1, v2, v3 = w2 * g3 - w3 * g2, w3 * g1 - w1 * g3, w1 * g2 - w2 * g1
            out += [radius * (R[i] * v1 + R[i + 1] * v2 + R[i + 2] * v3) for i in (0, 3, 6)]


def _contact_inertia_solve(bk, c):
    """``x`` with ``(tr(B_K) − B_K) x = c`` (B_K as 9 floats)."""
    tr = bk[0] + bk[4] + bk[8]
    return _solve3([tr - bk[0], -bk[1], -bk[2], -bk[3], tr - bk[4], -bk[5], -bk[6], -bk[7], tr - bk[8]], c)


def _rolling_ball3(system):
    bc = system.B_C.ravel().tolist()
    M, radius = system.mass, system.radius
    x1, x2, x3 = system.center_of_mass.tolist()
    s = _slices(system)
    g = s["Gamma"].start
    gg = s["G"].start if "G" in s else None
    gravity = system.gravity is not None
    g_normal = float(system.gravity @ system.normal) if gravity else 0.0

    def f(t, z):
        a = z.tolist()
        w1, w2, w3 = a[7], a[2], a[3]  # Ω = ŵ: Ω[2,1], Ω[0,2], Ω[1,0]
        g1, g2, g3 = a[g], a[g + 1], a[g + 2]
        k1, k2, k3 = radius * g1, radius * g2, radius * g3
        l1, l2, l3 = x1 + k1, x2 + k2, x3 + k3  # the lever X_G + κ
        # B_K = B_C + M (X_G κᵀ + κ X_Gᵀ + κκᵀ) = B_C + M (X_G κᵀ + κ lᵀ)
        bk = [
            bc[0] + M * (x1 * k1 + k1 * l1), bc[1] + M * (x1 * k2 + k1 * l2), bc[2] + M * (x1 * k3 + k1 * l3),
            bc[3] + M * (x2 * k1 + k2 * l1), bc[4] + M * (x2 * k2 + k2 * l2), bc[5] + M * (x2 * k3 + k2 * l3),
            bc[6] + M * (x3 * k1 + k3 * l1), bc[7] + M * (x3 * k2 + k3 * l2), bc[8] + M * (x3 * k3 + k3 * l3),
        ]  # fmt: skip
        # the force f = G + Ω²κ, Ω²κ = w (w·κ) − |w|² κ
        wk, ww = w1 * k1 + w2 * k2 + w3 * k3, w1 * w1 + w2 * w2 + w3 * w3
        f1, f2, f3 = w1 * wk - ww * k1, w2 * wk - ww * k2, w3 * wk - ww * k3
        if gg is not None:
            f1, f2, f3 = f1 + a[gg], f2 + a[gg + 1], f3 + a[gg + 2]
        elif gravity:
            f1, f2, f3 = f1 + g_normal * g1, f2 + g_normal * g2, f3 + g_normal * g3
        # (tr(B_K) − B_K) ẇ = w × B_K w − M f × l
        b1 = bk[0] * w1 + bk[1] * w2 + bk[2] * w3
        b2 = bk[3] * w1 + bk[4] * w2 + bk[5] * w3
        b3 = bk[6] * w1 + bk[7] * w2 + bk[8] * w3
        c = (
            w2 * b3 - w3 * b2 - M * (f2 * l3 - f3 * l2),
            w3 * b1 - w1 * b3 - M * (f3 * l1 - f1 * l3),
            w1 * b2 - w2 * b1 - M * (f1 * l2 - f2 * l1),
        )
        d1, d2, d3 = _contact_inertia_solve(bk, c)
        out = [0.0, -d3, d2, d3, 0.0, -d1, -d2, d1, 0.0]  # Ω̇ = (ẇ)^
        out += [g2 * w3 - g3 * w2, g3 * w1 - g1 * w3, g1 * w2 - g2 * w1]  # Γ̇ = Γ × w
        if gg is not None:  # Ġ = G × w
            G1, G2, G3 = a[gg], a[gg + 1], a[gg + 2]
            out += [G2 * w3 - G3 * w2, G3 * w1 - G1 * w3, G1 * w2 - G2 * w1]
        _pose_rates3(out, a, s, w1, w2, w3, g1, g2, g3, radius)
        return np.array(out)

    return f


def _chaplygin3(system):
    bc = system.B_C.ravel().tolist()
    Mr2, radius = system.mass * system.radius**2, system.radius
    s = _slices(system)
    g = s["Gamma"].start

    def f(t, z):
        a = z.tolist()
        p1, p2, p3 = a[5], a[6], a[1]
        g1, g2, g3 = a[g], a[g + 1], a[g + 2]
        bk = [bc[0] + Mr2 * g1 * g1, bc[1] + Mr2 * g1 * g2, bc[2] + Mr2 * g1 * g3,
              bc[3] + Mr2 * g2 * g1, bc[4] + Mr2 * g2 * g2, bc[5] + Mr2 * g2 * g3,
              bc[6] + Mr2 * g3 * g1, bc[7] + Mr2 * g3 * g2, bc[8] + Mr2 * g3 * g3]  # fmt: skip
        w1, w2, w3 = _contact_inertia_solve(bk, (p1, p2, p3))  # Π = (tr(B_K) − B_K) w
        out = _bivector_rate(p2 * w3 - p3 * w2, p3 * w1 - p1 * w3, p1 * w2 - p2 * w1)
        out += [g2 * w3 - g3 * w2, g3 * w1 - g1 * w3, g1 * w2 - g2 * w1]
        _pose_rates3(out, a, s, w1, w2, w3, g1, g2, g3, radius)
        return np.array(out)

    return f


# -- n ≥ 4: numpy matrices, Ω from A in an eigenbasis -----------------------------------------


def _pair_inverse(b):
    """``−1/(b_i + b_j)`` (the diagonal, where A vanishes, set to −1)."""
    pair = b[:, None] + b[None, :]
    return -1.0 / np.where(pair > 0, pair, 1.0)


def _omega_map(B):
    """The linear map ``A ↦ Ω`` on raveled n × n matrices: ``Ω = P ((PᵀAP) ⊙ (−1/(b_i + b_j))) Pᵀ``,
    ``B = P diag(b) Pᵀ``, as one ``n² × n²`` matrix (one product per evaluation)."""
    b, P = np.linalg.eigh(B)
    PP = np.kron(P, P)  # vec(P X Pᵀ) = (P ⊗ P) vec(X) for row-major vec
    return PP @ np.diag(_pair_inverse(b).ravel()) @ PP.T


def _euler_top(system):
    L = _omega_map(system.B)
    s, n = _slices(system), system.n
    r = s.get("R")

    def f(t, z):
        A = z[s["A"]]
        Om = (L @ A).reshape(n, n)
        dA = A.reshape(n, n) @ Om
        dA -= dA.T  # [A, Ω] = AΩ − ΩA = AΩ − (AΩ)ᵀ for skew A and Ω
        if r is None:
            return dA.ravel()
        return np.concatenate([dA.ravel(), (z[r].reshape(n, n) @ Om).ravel()])

    return f


def _heavy_top(system):
    L = _omega_map(system.B)
    MXG = system.mass * system.center_of_mass
    s, n = _slices(system), system.n
    r = s.get("R")

    def f(t, z):
        A = z[s["A"]]
        Gam = z[s["Gamma"]]
        Om = (L @ A).reshape(n, n)
        dA = A.reshape(n, n) @ Om + np.multiply.outer(MXG, Gam)
        dA -= dA.T  # [A, Ω] + M X_G ∧ Γ
        out = [dA.ravel(), -Om @ Gam]
        if r is not None:
            out.append((z[r].reshape(n, n) @ Om).ravel())
        return np.concatenate(out)

    return f


def _lyapunov_tensor(n):
    """``T[a, b]``: the matrix of ``X ↦ E_ab X + X E_ab`` on skew X in the coordinates ``X_ij``
    (i < j), so that ``X ↦ BX + XB`` is ``Σ_ab B_ab T[a, b]`` (a ``d × d`` matrix, d = n(n−1)/2)."""
    iu, ju = np.triu_indices(n, 1)
    d = iu.size
    T = np.zeros((n, n, d, d))
    for k in range(d):
        X = np.zeros((n, n))
        X[iu[k], ju[k]], X[ju[k], iu[k]] = 1.0, -1.0
        for a in range(n):
            for b in range(n):
                E = np.zeros((n, n))
                E[a, b] = 1.0
                T[a, b, :, k] = (E @ X + X @ E)[iu, ju]
    return T, iu, ju


def _chaplygin(system):
    BC, Mr2, radius = system.B_C, system.mass * system.radius**2, system.radius
    s, n = _slices(system), system.n
    T, iu, ju = _lyapunov_tensor(n)
    M_C = np.tensordot(BC, T, axes=2)  # X ↦ B_C X + X B_C
    T_flat = T.reshape(n * n, -1)
    d = iu.size

    def f(t, z):
        A = z[s["A"]].reshape(n, n)
        Gam = z[s["Gamma"]]
        # Ω from −A = B_K Ω + Ω B_K, B_K = B_C + M r² ΓΓᵀ, as a d × d linear system
        M = M_C + Mr2 * (np.multiply.outer(Gam, Gam).ravel() @ T_flat).reshape(d, d)
        x = np.linalg.solve(M, -A[iu, ju])
        Om = np.zeros((n, n))
        Om[iu, ju] = x
        Om[ju, iu] = -x
        dA = A @ Om
        dA -= dA.T
        OmG = Om @ Gam
        out = [dA.ravel(), -OmG]
        if "R" in s:
            R = z[s["R"]].reshape(n, n)
            out.append((R @ Om).ravel())
            if "center" in s:
                out.append(radius * (R @ OmG))
        return np.concatenate(out)

    return f


def check(system, y0: dict, rtol: float = 1e-12, samples: int = 20, seed: int = 0) -> float:
    """The largest relative difference of :func:`lean_rhs` from ``system.vector_field`` at
    ``samples`` states near ``y0`` (its momentum-like field perturbed by 10 %, the state
    moved by the group action so it stays on the constraints); raises ``AssertionError``
    above ``rtol``."""
    f = lean_rhs(system)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for k in range(samples):
        y = {name: np.array(v, dtype=float) for name, v in y0.items()}
        if k:
            field = "Omega" if "Omega" in y else "A"
            X = rng.normal(size=y[field].shape) * 0.1 * np.max(np.abs(y[field]))
            y[field] = y[field] + X - X.T
            # a random rotation of the body: the state moves as the system's group acts
            Q, _ = np.linalg.qr(rng.normal(size=(system.n, system.n)))
            Q *= np.sign(np.linalg.det(Q))
            y = {**y, **_rotate(system, y, Q)}
        expected = flatten(system, system.vector_field(0.0, y))
        got = f(0.0, flatten(system, y))
        diff = float(np.max(np.abs(got - expected)) / max(1.0, float(np.max(np.abs(expected)))))
        worst = max(worst, diff)
    if worst > rtol:
        raise AssertionError(f"lean right-hand side of {system!r} differs from its vector_field by {worst:.3g}")
    return worst


def _rotate(system, y, Q):
    """The body-frame fields after ``R ↦ RQ`` (the vectors and bivectors seen by the rotated body)."""
    out = {}
    for name, v in y.items():
        if name in ("A", "Omega"):
            out[name] = Q.T @ v @ Q
        elif name in ("Gamma", "G"):
            out[name] = Q.T @ v
        elif name == "R":
            out[name] = v @ Q
    return out
