"""The tangent map inherits the map's structure: symplectic / Poisson maps give tangent maps
that keep the Poisson tensor, to round-off, after 10⁴ steps.

The statement tested is ``M P(y₀) Mᵀ = P(y_N)`` with ``M = ∂y_N/∂y₀`` and P the Poisson tensor
of the equations in the tangent coordinates (``tangent_cases.poisson_tensor``, derived there
and in docs/theory.md): for the top with its attitude P is the inverse of the canonical
symplectic form of T*SO(n) in the body trivialisation, so the statement is ``Mᵀ ω M = ω``;
for the reduced tops (A alone; A and Γ) P is the Lie–Poisson tensor of so(n)* and se(n)*,
which is degenerate (Casimirs), and the Poisson statement is the one that applies.

Tolerance: the defect is measured relative to ``‖M‖²‖P‖`` (its size if M had no structure),
and 1e-12 leaves room for 10⁴ steps of round-off (ε·√N·‖M‖ growth ≈ 1e-14). Against the same
settings a method that is not Poisson (RKMK4, the midpoint rule on the Lie–Poisson equations)
shows a defect many orders above it: the test can fail.
"""

from __future__ import annotations

import numpy as np
import pytest
from tangent_cases import initial, poisson_tensor, systems

import lieint


def _defect(system, y0, method, steps, h):
    run = lieint.tangent_flow(system, y0, (0.0, steps * h), h=h, method=method)
    M = run.jacobian
    P0, P1 = poisson_tensor(system, y0), poisson_tensor(system, run.y)
    return np.max(np.abs(M @ P0 @ M.T - P1)) / (np.max(np.abs(M)) ** 2 * np.max(np.abs(P0)))


@pytest.mark.slow
@pytest.mark.parametrize("method", ["moser_veselov", "splitting2"])
def test_symplectic_free_top_with_attitude_after_ten_thousand_steps(method):
    top = lieint.EulerTop(np.diag([1.0, 2.0, 3.0]))
    y0 = initial(top, scale=0.8)
    assert _defect(top, y0, method, 10_000, 0.05) < 1e-12


@pytest.mark.parametrize(
    ("label", "n", "method"),
    [
        ("euler_top/no R", 3, "moser_veselov"),
        ("euler_top/no R", 4, "moser_veselov"),
        ("euler_top/no R", 4, "splitting2"),
        ("euler_top", 4, "splitting2"),
        ("heavy_top/no R", 3, "splitting2"),
        ("heavy_top/no R", 4, "splitting2"),
    ],
)
def test_poisson_maps_keep_the_poisson_tensor(label, n, method):
    """Lie–Poisson (so(n)*, se(n)*) and symplectic (T*SO(4)) maps, 2000 steps."""
    system = systems(n)[label]
    assert _defect(system, initial(system, scale=0.8), method, 2000, 0.05) < 1e-12


@pytest.mark.parametrize("method", ["rkmk4", "lie_midpoint"])
def test_methods_that_are_not_poisson_fail_the_same_check(method):
    """Their defect is their truncation error in the structure (RKMK4: O(h⁴)), ≥ 100× the
    tolerance above at h = 0.1."""
    top = lieint.EulerTop(np.diag([1.0, 2.0, 3.0]))
    assert _defect(top, initial(top, scale=0.8), method, 1000, 0.1) > 1e-10
