"""Systems, tangent vectors and the finite differences the tangent-map tests compare against.

The finite differences are written here from scratch — rotations moved by ``scipy.linalg.expm``,
runs by :func:`lieint.integrate` — so that they share no code with :mod:`lieint.tangent`.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.linalg import expm

import lieint
from lieint.methods.registry import get_method, method_specs


def _spd(rng, n, lo, hi):
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return Q @ np.diag(rng.uniform(lo, hi, n)) @ Q.T


def systems(n: int) -> dict[str, lieint.LieGroupSystem]:
    """One of each built-in body at dimension n (a fixed seed), non-diagonal mass tensors."""
    rng = np.random.default_rng(40 + n)
    down = -9.81 * np.eye(n)[-1]
    ball = _spd(rng, n, 0.05, 0.2)
    out = {
        "euler_top": lieint.EulerTop(_spd(rng, n, 0.5, 1.5)),
        "euler_top/no R": lieint.EulerTop(np.diag(rng.uniform(0.5, 1.5, n)), orientation=False),
        "heavy_top": lieint.HeavyTop(_spd(rng, n, 0.5, 1.5), 1.0, 0.2 * rng.normal(size=n), down),
        "heavy_top/no R": lieint.HeavyTop(
            np.diag(rng.uniform(0.5, 1.5, n)), 1.0, 0.2 * rng.normal(size=n), down, orientation=False
        ),
        "free_body": lieint.FreeBody(_spd(rng, n, 0.5, 1.5), 2.0, down),
        "chaplygin_ball": lieint.ChaplyginBall(ball, 1.0, 1.0),
        "rolling_ball": lieint.RollingBall(ball, 1.0, 1.0, 0.1 * rng.normal(size=n), down),
    }
    return out


def initial(system, seed: int = 2, scale: float = 1.0) -> dict:
    X = np.random.default_rng(seed).normal(size=(system.n, system.n))
    return system.initial_state(Omega=scale * 0.5 * (X - X.T))


def applicable_methods(system) -> list[tuple[str, str | None]]:
    """Every registered method (each coordinate map) that applies to ``system`` and has a
    tangent map (not among the refused families)."""
    out = []
    for name, spec in method_specs().items():
        for coordinates in spec.coordinates or (None,):
            method = get_method(name, coordinates=coordinates)
            try:
                method.check_system(system)
                lieint.tangent.TangentStepper(system, method)
            except (TypeError, ValueError):
                continue
            out.append((name, coordinates))
    return out


# -- perturbations, independently of lieint.tangent ------------------------------------------


def _skew(c, n):
    i, j = np.triu_indices(n, k=1)
    X = np.zeros((n, n))
    X[i, j], X[j, i] = c, -c
    return X


def move(system, y, v, e):
    """``y`` moved by ``e v``: rotations ``R expm(e δ̂)``, momenta and vectors additively."""
    out, start = {}, 0
    for name, shape in system.fields.items():
        kind = system.field_kinds.get(name, "")
        if kind in ("rotation", "bivector") and len(shape) == 2:
            n = shape[0]
            d = n * (n - 1) // 2
            X = _skew(v[start : start + d], n)
            out[name] = y[name] @ expm(e * X) if kind == "rotation" else y[name] + e * X
            start += d
        else:
            size = int(np.prod(shape))
            out[name] = y[name] + e * v[start : start + size].reshape(shape)
            start += size
    return out


def difference(system, y, yp, ym, e):
    """Central difference ``(yp − ym)/(2e)`` in tangent coordinates at ``y``."""
    parts = []
    for name, shape in system.fields.items():
        kind = system.field_kinds.get(name, "")
        d = (yp[name] - ym[name]) / (2 * e)
        if kind in ("rotation", "bivector") and len(shape) == 2:
            if kind == "rotation":
                d = y[name].T @ d
            i, j = np.triu_indices(shape[0], k=1)
            parts.append(0.5 * (d - d.T)[i, j])
        else:
            parts.append(d.ravel())
    return np.concatenate(parts)


def central_difference(flow, system, y0, v, steps=(1e-3, 3e-4, 1e-4, 3e-5, 1e-5)):
    """``DΦ(y₀) v`` by central differences of the map ``flow``, the step chosen by a sweep:
    the step whose difference changes least when it is divided by 3 (truncation error falls,
    round-off grows; where they balance, neighbours agree best)."""
    y1 = flow(y0)
    est = []
    for e in steps:
        est.append(difference(system, y1, flow(move(system, y0, v, e)), flow(move(system, y0, v, -e)), e))
    change = [np.max(np.abs(a - b)) for a, b in itertools.pairwise(est)]
    best = int(np.argmin(change))
    return est[best + 1], change[best]


def poisson_tensor(system, y) -> np.ndarray:
    """The Poisson tensor P(y) of the body's equations in tangent coordinates at ``y``: the
    one for which ``ż = P ∇H`` gives the system's equations (written out in docs/theory.md,
    § "The tangent flow").

    * momenta: ``{⟨A, X⟩, ⟨A, Y⟩} = ⟨A, [X, Y]⟩`` (``⟨·,·⟩`` the sum over i < j): Hamilton's
      equation ``Ȧ = [A, Ω]`` for ``T = −½⟨A, Ω⟩``;
    * attitude (T*SO(n), body trivialisation): ``{⟨A, X⟩, δ} = X``, ``{δ, δ} = 0``: ``δ̇ = Ω``;
    * body vector Γ (se(n)*, the heavy top without attitude): ``{Γ, ⟨A, X⟩} = X Γ``,
      ``{Γ, Γ} = 0``: ``Γ̇ = −ΩΓ`` and the gravity torque ``M X_G ∧ Γ`` of ``U = M⟨Γ, X_G⟩``.
    """
    n = system.n
    d = n * (n - 1) // 2
    i, j = np.triu_indices(n, k=1)
    E = np.zeros((d, n, n))
    E[np.arange(d), i, j], E[np.arange(d), j, i] = 1.0, -1.0
    A = y["A"]
    names = list(system.fields)
    size = {"A": d, "R": d, "Gamma": n}
    at = {k: sum(size[m] for m in names[: names.index(k)]) for k in names}
    P = np.zeros((sum(size[k] for k in names),) * 2)
    for a in range(d):
        for b in range(d):
            P[a, b] = np.sum(np.triu(A * (E[a] @ E[b] - E[b] @ E[a]), 1))
    if "R" in names:
        r = at["R"]
        P[:d, r : r + d] = np.eye(d)
        P[r : r + d, :d] = -np.eye(d)
    if "Gamma" in names:
        g = at["Gamma"]
        block = np.stack([E[a] @ y["Gamma"] for a in range(d)], axis=-1)  # (n, d): column X = XΓ
        P[g : g + n, :d] = block
        P[:d, g : g + n] = -block.T
    return P


# -- parameter sensitivities, independently of lieint.tangent ----------------------------------


def parameter_bodies() -> dict[str, tuple]:
    """Each built-in body (n = 3) as ``(build, parameters, initial keywords)``: ``build(**p)``
    calls the public constructor with the parameters ``p``, so a perturbed body is made the way
    a user makes one (and validated so)."""
    rng = np.random.default_rng(39)
    down = np.array([0.0, 0.0, -9.81])
    incline = np.array([1.5, 0.0, -9.6])
    ball = _spd(rng, 3, 0.05, 0.2)
    w = {"angular_velocity": [0.6, -0.4, 0.9]}
    return {
        "euler_top": (lambda **p: lieint.EulerTop(p["B"]), {"B": _spd(rng, 3, 0.5, 1.5)}, w),
        "heavy_top": (
            lambda **p: lieint.HeavyTop(p["mass_tensor"], p["mass"], p["center_of_mass"], p["gravity"]),
            {"mass_tensor": _spd(rng, 3, 0.5, 1.5), "mass": 1.0, "center_of_mass": [0.05, -0.1, 0.2], "gravity": down},
            w,
        ),
        "free_body": (
            lambda **p: lieint.FreeBody(p["mass_tensor"], p["mass"], p["gravity"]),
            {"mass_tensor": _spd(rng, 3, 0.5, 1.5), "mass": 2.0, "gravity": down},
            {**w, "velocity": [0.5, 0.0, 1.0]},
        ),
        "chaplygin_ball": (
            lambda **p: lieint.ChaplyginBall(p["mass_tensor"], p["mass"], p["radius"]),
            {"mass_tensor": ball, "mass": 1.0, "radius": 1.0},
            w,
        ),
        "rolling_ball": (
            lambda **p: lieint.RollingBall(p["mass_tensor"], p["mass"], p["radius"], p["center_of_mass"], p["gravity"]),
            {"mass_tensor": ball, "mass": 1.0, "radius": 1.0, "center_of_mass": [0.05, 0.1, -0.1], "gravity": incline},
            w,
        ),
    }


def parameter_directions(name: str, value) -> list[np.ndarray]:
    """Unit directions of a parameter's components: scalar, vector entries, and the upper
    triangle of a symmetric tensor (both off-diagonal entries together)."""
    value = np.asarray(value, dtype=float)
    if value.ndim == 0:
        return [np.array(1.0)]
    if value.ndim == 1:
        return list(np.eye(value.size))
    out = []
    for i, j in zip(*np.triu_indices(value.shape[0]), strict=True):
        E = np.zeros(value.shape)
        E[i, j] = E[j, i] = 1.0
        out.append(E)
    return out


def moved_initial_state(name: str, y0: dict, direction, e: float, normal=(0.0, 0.0, 1.0)) -> dict:
    """The initial state for the perturbed body: held, except Γ = Rᵀg (heavy top) or G = Rᵀg
    (incline) following g, and a ball's centre at the height r."""
    y = {k: np.array(v, dtype=float) for k, v in y0.items()}
    body_gravity = "G" if "G" in y else "Gamma" if "Gamma" in y else None  # a free body has none
    if name == "gravity" and body_gravity is not None:
        y[body_gravity] = y[body_gravity] + e * y["R"].T @ direction
    if name == "radius" and "center" in y:
        y["center"] = y["center"] + e * float(direction) * np.asarray(normal)
    return y


def parameter_difference(label, name, steps=(1e-3, 3e-4, 1e-4, 3e-5, 1e-5), **run):
    """``∂y(T)/∂θ_c`` along every direction of parameter ``name`` by central differences of
    whole :func:`lieint.integrate` runs of bodies rebuilt by their constructors, the step chosen
    by a sweep (as :func:`central_difference`); returns (columns, the sweep's uncertainty)."""
    build, params, keywords = parameter_bodies()[label]
    base = build(**params)
    y0 = base.initial_state(**keywords)

    def flow(p, y):
        sol = lieint.integrate(build(**p), y, **run)
        return {k: v[-1] for k, v in sol.states.items()}

    y1 = flow(params, y0)
    columns, uncertainty = [], []
    for direction in parameter_directions(name, params[name]):
        est = []
        for e in steps:
            ends = []
            for s in (e, -e):
                p = dict(params)
                p[name] = np.asarray(params[name], dtype=float) + s * direction
                ends.append(flow(p, moved_initial_state(name, y0, direction, s)))
            est.append(difference(base, y1, ends[0], ends[1], e))
        change = [np.max(np.abs(a - b)) for a, b in itertools.pairwise(est)]
        best = int(np.argmin(change))
        columns.append(est[best + 1])
        uncertainty.append(change[best])
    return np.stack(columns, axis=-1), np.array(uncertainty)
