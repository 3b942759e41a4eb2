"""The built-in bodies the tests run, one variant per compiled layout a system's declaration can
take (with and without R, centre, tilted gravity, offset centre of mass, a non-diagonal mass
tensor), at any dimension n, with fixed seeds: the same bodies every run."""

from __future__ import annotations

import numpy as np

import lieint


def spd(rng, n, lo, hi):
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return Q @ np.diag(rng.uniform(lo, hi, n)) @ Q.T


def incline(n, angle=0.3):
    g = np.zeros(n)
    g[-1], g[0] = -9.81 * np.cos(angle), 9.81 * np.sin(angle)
    return g


def variants(n: int) -> dict[str, lieint.LieGroupSystem]:
    """Each built-in compiled layout at dimension n (a fixed seed: the same bodies every run)."""
    rng = np.random.default_rng(10 + n)
    down = -9.81 * np.eye(n)[-1]
    ball = spd(rng, n, 0.05, 0.2)
    return {
        "heavy_top": lieint.HeavyTop(spd(rng, n, 0.5, 1.5), 1.0, 0.2 * rng.normal(size=n), down),
        "heavy_top/diagonal, no R": lieint.HeavyTop(
            np.diag(rng.uniform(0.5, 1.5, n)), 1.0, 0.2 * rng.normal(size=n), down, orientation=False
        ),
        "free_body": lieint.FreeBody(spd(rng, n, 0.5, 1.5), 2.0, down),
        "free_body/no gravity, no R": lieint.FreeBody(spd(rng, n, 0.5, 1.5), 2.0, orientation=False),
        "chaplygin_ball": lieint.ChaplyginBall(ball, 1.0, 1.0),
        "chaplygin_ball/no centre, no R": lieint.ChaplyginBall(ball, 1.0, 1.0, orientation=False, track_center=False),
        "rolling_ball/offset": lieint.RollingBall(ball, 1.0, 1.0, 0.1 * rng.normal(size=n), down),
        "rolling_ball/offset, incline": lieint.RollingBall(ball, 1.0, 1.0, 0.1 * rng.normal(size=n), incline(n)),
        "rolling_ball/no gravity, no centre": lieint.RollingBall(ball, 1.0, 1.0, track_center=False),
    }


def initial(system, rng):
    X = rng.normal(size=(system.n, system.n))
    return system.initial_state(Omega=X - X.T)


def first_step_round_off(system, y, ctrl) -> float:
    """100 ε‖f₀‖/‖f₁ − f₀‖ (scaled norms, h₀ of the generic controller): the relative round-off
    of the first trial step when the vector field is computed another way."""
    eps = np.finfo(float).eps
    f0 = system.vector_field(0.0, y)
    scale = {k: ctrl.atol + ctrl.rtol * np.abs(v) for k, v in y.items()}

    def norm(z):  # scaled by its largest ratio first: a tiny atol would overflow the squares
        r = np.concatenate([(z[k] / scale[k]).ravel() for k in z])
        top = float(np.max(np.abs(r)))
        return top * float(np.sqrt(np.sum((r / top) ** 2))) if top > 0 else 0.0

    d0, d1 = norm(y), norm(f0)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    f1 = system.vector_field(0.0, {k: y[k] + h0 * f0[k] for k in y})
    change = norm({k: f1[k] - f0[k] for k in y})
    return 100 * eps * max(1.0, d1 / change) if change > 0 else 100 * eps


def initial_batch(system, rng, bodies):
    X = rng.normal(size=(bodies, system.n, system.n))
    return system.initial_state(Omega=X - np.swapaxes(X, -1, -2))


def at_rest(system, y0):
    """``y0`` with the body at rest (the free body's vector field vanishes there)."""
    return system.initial_state(Omega=np.zeros((system.n, system.n)))


def coverage_systems() -> dict[str, lieint.LieGroupSystem]:
    """The built-in systems the registry-driven coverage tests run every method on, by label
    (``"euler_top n=3"``, …): both tops' forms, every variant of n = 3, the heavy top at n = 4."""
    out = {
        "euler_top n=3": lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0]),
        "euler_top n=4": lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5])),
    }
    out.update({f"{name} n=3": system for name, system in variants(3).items() if "/" not in name})
    out["heavy_top n=4"] = variants(4)["heavy_top"]
    return out


def registered_methods() -> list[tuple[str, str | None]]:
    """(name, coordinates) of every registered method in each of its coordinate maps."""
    from lieint.methods.registry import method_specs

    return [(name, c) for name, spec in method_specs().items() for c in (spec.coordinates or (None,))]


def applies(method, system) -> bool:
    """Whether ``method`` accepts ``system`` (its ``check_system``)."""
    try:
        method.check_system(system)
    except (TypeError, ValueError):
        return False
    return True


def body3(kind, rng, full=True, diagonal=False):
    """A 3D heavy top, Chaplygin ball or rolling ball with an offset centre of mass (gravity along
    the plane's normal, ``kind`` "rolling ball", or tilted, "ball on an incline": the incline's G a
    field of the state); ``full``: with R (and the ball's centre); ``diagonal``: a diagonal mass
    tensor (the principal frame the user's)."""
    if kind == "heavy top":
        B = np.diag(rng.uniform(0.5, 1.5, 3)) if diagonal else spd(rng, 3, 0.5, 1.5)
        return lieint.HeavyTop(B, 1.3, 0.3 * rng.normal(size=3), [0.0, 0.0, -9.81], orientation=full)
    B = np.diag(rng.uniform(0.05, 0.2, 3)) if diagonal else spd(rng, 3, 0.05, 0.2)
    if kind == "Chaplygin ball":
        return lieint.ChaplyginBall(B, 1.0, 0.8, orientation=full, track_center=full)
    offset = rng.normal(size=3)
    offset *= 0.1 / np.linalg.norm(offset)  # B_C − M X_G X_Gᵀ stays positive definite
    gravity = [0.0, 0.0, -9.81] if kind == "rolling ball" else 9.81 * np.array([np.sin(0.4), 0.0, -np.cos(0.4)])
    return lieint.RollingBall(B, 1.2, 0.8, offset, gravity, orientation=full, track_center=full)


def spin_field(y0) -> str:
    """The name of a state's momentum field (A; the rolling ball's Ω)."""
    return "Omega" if "Omega" in y0 else "A"


def assert_states_close(fast, ref, tol, where=""):
    """The same fields in the same order, each within ``tol`` of ``ref`` relative to its size."""
    assert list(fast) == list(ref), where
    for name, values in ref.items():
        scale = max(1.0, np.abs(values).max())
        np.testing.assert_allclose(fast[name], values, rtol=0, atol=tol * scale, err_msg=f"{where} {name}")
