"""The tangent map of the numerical flow against central finite differences of whole runs.

The truth is :func:`lieint.integrate` run from perturbed initial states (rotations moved by
``scipy.linalg.expm``, see ``tangent_cases``), differenced centrally with the step chosen by a
sweep; it shares no code with :mod:`lieint.tangent`. Tolerances: the tangent map is the exact
derivative of the same map, so the difference is the finite difference's own error, which the
sweep measures (``change``): the test asks 1e-6 relative, the target of the issue, and checks
that the sweep's own uncertainty is below it (else the comparison would say nothing).
"""

from __future__ import annotations

import numpy as np
import pytest
from tangent_cases import applicable_methods, central_difference, initial, systems

import lieint
from lieint.tangent import TangentStepper, chart_of

CASES = [(n, label) for n in (3, 4) for label in systems(n)]


@pytest.mark.slow
@pytest.mark.parametrize(("n", "label"), CASES)
def test_one_step_of_every_method_matches_central_differences(n, label):
    """Every registered method with a tangent map, every built-in body, n = 3 and 4: the
    derivative of one step along a random direction, 1e-6 relative."""
    system = systems(n)[label]
    y0 = initial(system)
    chart = chart_of(system)
    V = np.random.default_rng(7).normal(size=(1, chart.dim))
    methods = applicable_methods(system)
    assert methods, label
    for name, coordinates in methods:
        h = 0.05

        method = lieint.get_method(name, coordinates=coordinates)

        def flow(y, method=method, h=h):  # one step of the method's map (an embedded pair: its order-p solution)
            return method.step(system, 0.0, y, h, method.init(system, 0.0, y, h)).y

        run = lieint.tangent_flow(system, y0, (0.0, h), h=h, method=name, coordinates=coordinates, vectors=V)
        for v, dv in zip(V, run.vectors, strict=True):
            truth, change = central_difference(flow, system, y0, v)
            scale = np.max(np.abs(truth))
            assert change < 1e-7 * scale, (label, name, coordinates, change / scale)
            assert np.max(np.abs(dv - truth)) < 1e-6 * scale, (label, name, coordinates)


WHOLE_RUNS = [
    ("euler_top", "rkmk4", "exp"),
    ("euler_top", "rkmk4", "cayley"),
    ("euler_top", "moser_veselov", None),
    ("euler_top", "splitting2", None),
    ("euler_top", "lie_midpoint", None),
    ("heavy_top", "rkmk4", "exp"),
    ("heavy_top", "splitting2", None),
    ("heavy_top", "lie_midpoint", None),
    ("heavy_top/no R", "splitting2", None),
    ("chaplygin_ball", "rkmk4", "cayley"),
    ("rolling_ball", "rkmk6", "exp"),
    ("free_body", "lie_euler", "exp"),
]


@pytest.mark.slow
@pytest.mark.parametrize(("label", "name", "coordinates"), WHOLE_RUNS)
def test_whole_run_jacobian_matches_central_differences(label, name, coordinates):
    """The whole Jacobian ∂y(T)/∂y₀ over 100 steps (T = 2, h = 0.02), 1e-6 relative."""
    system = systems(3)[label]
    y0 = initial(system, scale=0.7)
    T, h = 2.0, 0.02

    def flow(y):
        sol = lieint.integrate(system, y, (0.0, T), h=h, method=name, coordinates=coordinates)
        return {k: v[-1] for k, v in sol.states.items()}

    run = lieint.tangent_flow(system, y0, (0.0, T), h=h, method=name, coordinates=coordinates)
    assert run.nsteps == 100
    J = run.jacobian
    scale = np.max(np.abs(J))
    for j in range(run.chart.dim):
        truth, change = central_difference(flow, system, y0, np.eye(run.chart.dim)[j])
        assert change < 1e-7 * scale, (j, change / scale)
        assert np.max(np.abs(J[:, j] - truth)) < 1e-6 * scale, (j, np.max(np.abs(J[:, j] - truth)) / scale)
    # the real part is the method's run (the compiled one where there is one)
    ref = flow(y0)
    for k in ref:
        assert np.max(np.abs(run.y[k] - ref[k])) < 1e-12 * max(1.0, np.max(np.abs(ref[k])))


def test_embedded_pair_with_its_accepted_steps_held_fixed():
    """rkmk45 adaptive: the map of the run that the controller chose, its steps held fixed
    (``steps=np.diff(sol.t)``), against central differences of runs with those steps."""
    system = systems(3)["heavy_top"]
    y0 = initial(system, scale=0.7)
    sol = lieint.integrate(system, y0, (0.0, 3.0), method="rkmk45", rtol=1e-8, atol=1e-10, save_every=1)
    steps = np.diff(sol.t)
    assert steps.size > 10 and np.ptp(steps) > 0  # the controller changed the step

    method = lieint.get_method("rkmk45")

    def flow(y):  # the run's map: the method's steps of the sizes the controller accepted
        t = 0.0
        for hk in steps:
            y, t = method.step(system, t, y, float(hk)).y, t + hk
        return y

    run = lieint.tangent_flow(system, y0, (0.0, 3.0), method="rkmk45", steps=steps)
    assert run.backend_reason.startswith("compiled engine")  # the steps' schedule, in the loop
    assert np.allclose(run.y["A"], sol.states["A"][-1], rtol=0, atol=1e-12)
    J = run.jacobian
    scale = np.max(np.abs(J))
    for j in range(run.chart.dim):
        truth, _ = central_difference(flow, system, y0, np.eye(run.chart.dim)[j])
        assert np.max(np.abs(J[:, j] - truth)) < 1e-6 * scale


def test_bodies_of_a_batch_have_their_own_tangent_maps():
    """A batch of 3 bodies gives each body's Jacobian, as three runs one at a time."""
    system = systems(3)["heavy_top"]
    rng = np.random.default_rng(4)
    X = rng.normal(size=(3, 3, 3))
    y0 = system.initial_state(Omega=X - np.swapaxes(X, -1, -2))
    run = lieint.tangent_flow(system, y0, (0.0, 1.0), h=0.05)
    assert run.jacobian.shape == (3, 9, 9)
    for b in range(3):
        one = lieint.tangent_flow(system, {k: v[b] for k, v in y0.items()}, (0.0, 1.0), h=0.05)
        assert np.allclose(run.jacobian[b], one.jacobian, rtol=0, atol=1e-12 * np.abs(one.jacobian).max())


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"method": "exact_flow"}, "Jacobi elliptic"),
        ({"method": "RK45"}, "scipy"),
        ({"method": "moser_veselov6"}, "modified moments"),
        ({"method": "rkmk45+energy"}, "energy projection"),
        ({"h": -0.1}, "`h` must be a finite positive"),
        ({"h": None}, "exactly one of `h`"),
        ({"h": None, "steps": [0.5, 0.4]}, "add up to"),
        ({"vectors": np.ones((2, 5))}, "`vectors` must have shape (k, 6)"),
        ({"vectors": np.full((1, 6), np.nan)}, "`vectors` must be finite"),
    ],
)
def test_bad_arguments_are_named(kwargs, message):
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    args = {"h": 0.1} | kwargs
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        lieint.tangent_flow(top, y0, (0.0, 1.0), **args)


def test_a_step_that_drops_the_imaginary_part_is_refused_not_wrong():
    """A user's method that casts the state to real would silently lose the derivative: the
    stepper turns numpy's ComplexWarning into an error naming the method."""

    class Real(lieint.methods.rkmk.RKMK):
        def step(self, system, t, y, h, state=None):
            result = super().step(system, t, y, h, state)
            result.y["A"] = result.y["A"].astype(float)
            return result

    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    method = Real("rkmk4-real", lieint.methods.tableaux.RK4, dexpinv_degree=2)
    with pytest.raises(ValueError, match="casts the complex state to real"):
        TangentStepper(top, method).step(0.0, TangentStepper(top, method).seed(y0, np.eye(6)), 0.1)


def test_labels_name_the_coordinates():
    chart = chart_of(lieint.HeavyTop.lagrange(1.0, 1.5, 1.0, 0.3))
    assert chart.dim == 9
    assert chart.labels() == [
        "A[0,1]", "A[0,2]", "A[1,2]", "Gamma[0]", "Gamma[1]", "Gamma[2]", "R:δ[0,1]", "R:δ[0,2]", "R:δ[1,2]"
    ]  # fmt: skip
