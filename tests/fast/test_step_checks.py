"""Edges of the compiled kernels found by a hostile review: what they must not do silently.

* A method or system that changes the equations (a subclass overriding ``step``, a generator set
  on the instance) integrates something else than the declaration says: it runs the generic path.
* ``project=True`` after a coarse classical step (singular values of R beyond √3, where one
  Newton–Schulz step diverges) still ends on SO(n), as the generic path's polar factor does.
* An empty ensemble and a tiny ``atol`` run as on the generic path; a state that becomes
  non-finite while projected is reported as such, not as an SVD error.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import lieint
from lieint.methods import RKMK, tableaux

TOP3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
X = np.random.default_rng(0).standard_normal((4, 4))


def top4():
    return lieint.EulerTop(np.diag([1.0, 2.0, 3.0, 4.0]))


@dataclasses.dataclass(frozen=True)
class Halving(RKMK):
    """RKMK4 whose every step halves the momentum: other dynamics than the tableau's."""

    def step(self, system, t, y, h, state=None):
        result = super().step(system, t, y, h, state)
        return dataclasses.replace(result, y={**result.y, "A": 0.5 * result.y["A"]})


@pytest.mark.parametrize("n", [3, 4])
def test_a_method_subclass_that_changes_the_step_runs_what_it_defines(n):
    system = TOP3 if n == 3 else top4()
    y0 = system.initial_state(A=X[:n, :n] - X[:n, :n].T)
    method = Halving("halving", tableaux.RK4, dexpinv_degree=2)
    assert method.compiled() is None
    sol = lieint.integrate(system, y0, (0.0, 1.0), h=0.1, method=method)
    reference = lieint.integrate(system, y0, (0.0, 1.0), h=0.1, method=method, backend="numpy")
    assert sol.stats.backend == "numpy"
    np.testing.assert_array_equal(sol.states["A"], reference.states["A"])
    assert np.linalg.norm(sol.states["A"][-1]) < 1e-2 * np.linalg.norm(y0["A"])


@pytest.mark.parametrize("n", [3, 4])
def test_a_generator_set_on_the_instance_is_what_runs(n):
    system = TOP3.__class__.from_principal_moments([1.0, 2.0, 3.0]) if n == 3 else top4()
    y0 = system.initial_state(A=X[:n, :n] - X[:n, :n].T)
    system.generator = lambda t, y: np.zeros_like(y["A"])  # a frozen body
    assert system.compiled() is None
    for method in ("rkmk4", "rkmk45"):
        sol = lieint.integrate(system, y0, (0.0, 1.0), h=0.1, method=method)
        np.testing.assert_allclose(sol.states["A"][-1], y0["A"], atol=1e-15)


@pytest.mark.parametrize(("n", "scale"), [(3, 1.0), (3, 8.0), (4, 8.0)])
@pytest.mark.slow
def test_projection_after_a_coarse_classical_step_ends_on_the_group_like_the_generic_path(n, scale):
    # rk4 at h = 0.5 on a fast top leaves R with singular values up to ~2.3: one Newton–Schulz
    # step from there diverged (R ~ 1e121 reported as a finished run) or blew up to NaN
    system = TOP3 if n == 3 else top4()
    if n == 4:
        y0 = system.initial_state(A=scale * (X - X.T) / 4.0)
    else:
        y0 = system.initial_state(angular_velocity=scale * np.array([0.3, 1.0, 0.4]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", lieint.LieStepWarning)
        sol = lieint.integrate(system, y0, (0.0, 3.0), h=0.5, method="rk4", project=True)
        reference = lieint.integrate(system, y0, (0.0, 3.0), h=0.5, method="rk4", project=True, backend="numpy")
    assert sol.stats.backend == "numba"
    assert sol.t[-1] == reference.t[-1]
    R = sol.states["R"][np.isfinite(sol.states["R"]).all(axis=(-2, -1))]
    assert np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(n)).max() < 1e-14
    if reference.t[-1] == 3.0:
        np.testing.assert_allclose(sol.states["R"], reference.states["R"], atol=1e-12)
        np.testing.assert_allclose(sol.states["A"], reference.states["A"], atol=1e-12 * np.abs(y0["A"]).max())


def test_an_empty_ensemble_runs_adaptively_like_the_generic_path():
    y0 = TOP3.initial_state(angular_velocity=np.zeros((0, 3)))
    sol = lieint.integrate(TOP3, y0, (0.0, 1.0), method="rkmk45")
    assert sol.states["A"].shape[1:] == (0, 3, 3) and sol.t[-1] == 1.0


def test_a_tiny_atol_does_not_overflow_the_first_step():
    y0 = TOP3.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        sol = lieint.integrate(TOP3, y0, (0.0, 1.0), method="rkmk45", atol=1e-200)
    assert sol.t[-1] == 1.0


def test_a_state_that_blows_up_while_projected_is_reported_as_non_finite_on_every_path():
    y0 = TOP3.initial_state(angular_velocity=8.0 * np.array([1.5, 5.0, 2.0]))
    for backend in ("numpy", "auto"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", lieint.LieStepWarning)
            sol = lieint.integrate(TOP3, y0, (0.0, 3.0), h=0.5, method="rk4", project=True, backend=backend)
        assert not sol.success and "non-finite" in sol.message, (backend, sol.message)
        assert np.isfinite(sol.states["R"]).all()
