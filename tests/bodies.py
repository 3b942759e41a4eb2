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
