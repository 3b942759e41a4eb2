"""Poincaré sections: crossings on the dense output, to round-off, in the asked direction.

Truths: the section function itself (its value at the crossings is round-off of its scale: the
secant refinement stops when the time stops changing), the sign of g on either side, an exact
integral of the motion at the crossings, and the convergence of the crossing times with h.
"""

from __future__ import annotations

import numpy as np
import pytest

import lieint

EPS = np.finfo(float).eps


def _lagrange():
    top = lieint.HeavyTop.lagrange(1.0, 0.5, mass=1.0, length=0.2, orientation=False)
    return top, top.initial_state(angular_velocity=[1.0, 0.5, 5.0])


def section(t, y):
    return y["A"][..., 1, 2]  # Π₁ (A = −Π̂)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_crossings_are_roots_of_the_section_to_round_off(direction):
    top, y0 = _lagrange()
    cut = lieint.poincare(top, y0, (0.0, 60.0), section, h=0.01, direction=direction)
    assert len(cut) > 10
    scale = np.max(np.abs(cut.solution.states["A"]))
    assert np.max(np.abs(cut.residual)) < 64 * EPS * scale
    # g has the asked sign change across each crossing (on the dense output)
    for t in cut.t:
        before, after = (float(section(s, cut.solution.sol(s))) for s in (t - 1e-4, t + 1e-4))
        assert np.sign(after - before) == np.sign(direction)
    # the spin w₃ of the Lagrange top is an exact integral: the section states keep it as the run does
    spin = top.evaluate_invariants(cut.t, cut.y, ["spin"])["spin"]
    assert np.max(np.abs(spin - spin[0])) < 1e-8 * abs(spin[0])


def test_crossing_times_converge_with_the_step():
    top, y0 = _lagrange()
    times = [lieint.poincare(top, y0, (0.0, 30.0), section, h=h).t for h in (0.04, 0.02, 0.01)]
    assert len({t.size for t in times}) == 1
    e1, e2 = np.max(np.abs(times[0] - times[2])), np.max(np.abs(times[1] - times[2]))
    assert e2 < e1 / 2.0**2  # at least second order (the interpolant's and RKMK4's)


def test_a_section_never_crossed_gives_no_points():
    top, y0 = _lagrange()
    cut = lieint.poincare(top, y0, (0.0, 5.0), lambda t, y: 1.0 + 0.0 * y["A"][..., 0, 1], h=0.01)
    assert len(cut) == 0 and cut.y["A"].shape == (0, 3, 3)


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"section": 3.0}, TypeError, "`section` must be a function"),
        ({"direction": "up"}, TypeError, "`direction` must be a number"),
        ({"dense_output": False}, ValueError, "`dense_output` is set by poincare"),
    ],
)
def test_bad_arguments_are_named(kwargs, error, message):
    top, y0 = _lagrange()
    args = {"section": section, "h": 0.01} | kwargs
    with pytest.raises(error, match=message):
        lieint.poincare(top, y0, (0.0, 1.0), **args)
