"""RKMK in Cayley coordinates keeps the attitude on SO(n) at any step, on every path.

``cay(u)`` of a skew u is a rotation, but a solve computes it only to ``ε·cond(I − u/2)``: the
stages of a step far beyond its range (the step check warns) or of a trial step a loose
tolerance accepts reach θ ~ 1e17, where the computed map was off the group by O(1) — a 6D top's
R ended with ``‖RᵀR − I‖ = 31`` after one RKMK6 step of h = 2 (compiled) and 60 after h = 2.66
(generic), and a loose adaptive run's R grew to 1e6. Every Cayley map of n ≥ 4 is now brought
back onto the group when it is off by less than 1e-6, and is NaN beyond — not the map any more:
the step is reported, a trial step rejected (``lieint.fast.skew.orthogonal_polish``,
``lieint.groups.so.onto_rotations``). Every system with an attitude in n = 4 and 6, every
registry method in Cayley coordinates, compiled and generic.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from bodies import initial, variants

import lieint
from lieint.methods.registry import get_method, method_specs


def _cayley_methods() -> list[str]:
    out = []
    for name, spec in method_specs().items():
        if "cayley" in (spec.coordinates or ()):
            method = get_method(name, coordinates="cayley")
            if method.compiled() is not None:
                out.append(name)
    return out


def _systems() -> dict:
    rng = np.random.default_rng(3)
    out = {}
    for n in (4, 6):
        top = lieint.EulerTop(np.diag(np.linspace(1.0, 2.0, n)))
        out[f"euler_top/n={n}"] = (top, initial(top, rng))
    for name, system in variants(4).items():
        if "R" in system.fields:
            out[f"{name}/n=4"] = (system, initial(system, rng))
    return out


SYSTEMS = _systems()
METHODS = _cayley_methods()


def _defects(sol) -> np.ndarray:
    R = sol.states["R"]
    R = R[np.isfinite(R).all(axis=(-2, -1))]  # a non-finite row is reported, not a rotation
    n = R.shape[-1]
    return np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(n)).max(axis=(-2, -1)), np.linalg.det(R)


@pytest.mark.parametrize("backend", ["numba", "numpy"])
@pytest.mark.parametrize("label", sorted(SYSTEMS))
def test_the_attitude_stays_a_rotation_at_absurd_steps_and_loose_tolerances(label, backend):
    system, y0 = SYSTEMS[label]
    assert METHODS and {"rkmk4", "rkmk6", "rkmk853"} <= set(METHODS)
    finished = 0
    for name in METHODS:
        method = get_method(name, coordinates="cayley")
        kw = dict(rtol=1e-3, atol=1.0) if method.adaptive else dict(h=2.0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", lieint.LieStepWarning)  # warned: the step is far too large
            sol = lieint.integrate(system, y0, (0.0, 10.0), method=name, coordinates="cayley", backend=backend, **kw)
        assert sol.stats.backend == backend
        # a stage beyond about 1e16 meets a zero pivot: NaN, reported, the rows before it kept
        assert sol.success or "non-finite" in sol.message, (label, name, sol.message)
        finished += sol.success
        defect, det = _defects(sol)
        # each step moves R by an orthogonal factor: the defect grows by round-off a step
        assert defect.max() <= 1e-14 * (1 + sol.stats.nsteps), (label, name, backend, defect.max())
        assert np.all(det > 0), (label, name, backend)
    assert finished >= len(METHODS) // 2, (label, backend, finished)  # the runs reach t1 mostly


def test_both_paths_draw_the_line_at_the_same_distance_from_the_group():
    from lieint.fast.skew import OFF_GROUP
    from lieint.groups.so import _OFF_GROUP

    assert OFF_GROUP == _OFF_GROUP == 1e-6
