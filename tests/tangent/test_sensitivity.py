"""Parameter sensitivities ∂y(T)/∂θ against central finite differences of whole runs.

The truth rebuilds each body through its public constructor with a perturbed parameter and
runs :func:`lieint.integrate` (compiled) from the same initial state (Γ = Rᵀg following g, a
ball's centre following r), differenced centrally with the step chosen by a sweep
(``tangent_cases.parameter_difference``): it shares no code with :mod:`lieint.tangent`.
1e-6 relative per column, and the sweep's own uncertainty below it.
"""

from __future__ import annotations

import numpy as np
import pytest
from tangent_cases import parameter_bodies, parameter_difference

import lieint

RUN = {"t_span": (0.0, 1.0), "h": 0.05}


def _body(label):
    build, params, keywords = parameter_bodies()[label]
    system = build(**params)
    return system, system.initial_state(**keywords)


def _check(label, method, names, coordinates=None):
    system, y0 = _body(label)
    got = lieint.sensitivity(
        system, y0, h=RUN["h"], t_span=RUN["t_span"], method=method, parameters=names, coordinates=coordinates
    )
    for name in names:
        truth, uncertainty = parameter_difference(label, name, method=method, coordinates=coordinates, **RUN)
        mine = got.of(name)
        overall = np.max(np.abs(got.jacobian))
        for c in range(truth.shape[-1]):
            scale = np.max(np.abs(truth[:, c]))
            floor = 1e-10 * overall  # a parameter the motion does not feel (a free body's mass) has a zero column
            assert uncertainty[c] < 1e-7 * scale + floor, (label, name, c, uncertainty[c], scale)
            assert np.max(np.abs(mine[:, c] - truth[:, c])) < 1e-6 * scale + floor, (label, name, c)


@pytest.mark.parametrize("label", list(parameter_bodies()))
def test_every_parameter_of_every_body_matches_central_differences(label):
    """rkmk4, 20 steps: every parameter each built-in body offers, every component."""
    system, _ = _body(label)
    _check(label, "rkmk4", list(system.parameter_values()))


@pytest.mark.parametrize(
    ("label", "method", "names", "coordinates"),
    [
        ("euler_top", "moser_veselov", ["B"], None),
        ("heavy_top", "lie_midpoint", ["center_of_mass", "gravity"], None),
        ("chaplygin_ball", "rkmk4", ["radius"], "cayley"),
        ("heavy_top", "splitting2", ["mass", "center_of_mass"], None),
    ],
)
def test_other_methods_match_central_differences(label, method, names, coordinates):
    """The Moser–Veselov map (a Newton solve in B), the midpoint's fixed point, Cayley
    coordinates, a splitting (its gravity kick)."""
    _check(label, method, names, coordinates)


def test_a_splitting_refuses_the_mass_tensor_by_name():
    """A splitting rotates about the principal axes of B, which the complex step cannot turn."""
    system, y0 = _body("heavy_top")
    with pytest.raises(ValueError, match=r"`method` 'splitting2' rotates about the principal axes.*mass_tensor\[0,0\]"):
        lieint.sensitivity(system, y0, (0.0, 0.1), h=0.05, method="splitting2", parameters=["mass", "mass_tensor"])


def test_bad_parameters_are_refused_by_name():
    system, y0 = _body("heavy_top")
    span = (0.0, 0.1)
    with pytest.raises(ValueError, match=r"`parameters` names 'radius'.*HeavyTop.*\['mass_tensor', 'mass'"):
        lieint.sensitivity(system, y0, span, h=0.05, parameters=["radius"])
    with pytest.raises(TypeError, match=r"`parameters` must be a list of names .* got 3"):
        lieint.sensitivity(system, y0, span, h=0.05, parameters=[3])
    with pytest.raises(TypeError, match=r"`parameters` must be a list of parameter names; got float"):
        lieint.sensitivity(system, y0, span, h=0.05, parameters=2.5)
    with pytest.raises(ValueError, match=r"`parameters` must name at least one"):
        lieint.sensitivity(system, y0, span, h=0.05, parameters=[])
    with pytest.raises(ValueError, match=r"names a parameter twice"):
        lieint.sensitivity(system, y0, span, h=0.05, parameters=["mass", "mass"])
    with pytest.raises(ValueError, match=r"`method` 'exact_flow' has no tangent map"):
        lieint.sensitivity(
            lieint.EulerTop(np.diag([1.0, 2.0, 3.0])), {"A": y0["A"], "R": y0["R"]}, span, h=0.05, method="exact_flow"
        )
    ball = lieint.ChaplyginBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0)
    with pytest.raises(ValueError, match=r"'normal'.*cannot offer.*Γ = Rᵀν"):
        lieint.sensitivity(ball, ball.initial_state(angular_velocity=[1, 0, 0]), span, h=0.05, parameters=["normal"])
    flat = lieint.RollingBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0, gravity=[0, 0, -9.81])
    with pytest.raises(ValueError, match=r"'gravity'.*cannot offer.*along the plane's normal"):
        lieint.sensitivity(flat, flat.initial_state(angular_velocity=[1, 0, 0]), span, h=0.05, parameters="gravity")
    no_attitude = lieint.HeavyTop(np.diag([1.0, 1.4, 1.9]), 1.0, [0, 0, 0.2], [0, 0, -9.81], orientation=False)
    with pytest.raises(ValueError, match=r"'gravity'.*without the attitude R"):
        lieint.sensitivity(
            no_attitude, no_attitude.initial_state(angular_velocity=[1, 0, 0]), span, h=0.05, parameters=["gravity"]
        )
    atoms = lieint.AtomsBody([1.0, 1.0, 1.0, 1.0], np.vstack([np.eye(3), -np.ones((1, 3))]))
    with pytest.raises(ValueError, match=r"AtomsBody offers no numeric parameters"):
        lieint.sensitivity(atoms, atoms.initial_state(angular_velocity=[1, 0, 0]), span, h=0.05)
    with pytest.raises(ValueError, match=r"`name` must be one of the parameters of this result \['mass'\]"):
        lieint.sensitivity(system, y0, span, h=0.05, parameters=["mass"]).of("gravity")


def test_a_batch_of_bodies_gives_each_body_its_own_columns_and_a_stack_is_refused():
    system, y0 = _body("heavy_top")
    w = [[0.6, -0.4, 0.9], [0.1, 0.8, -0.3]]
    batch = system.initial_state(angular_velocity=w)
    both = lieint.sensitivity(system, batch, (0.0, 0.5), h=0.05, parameters=["gravity"])
    assert both.jacobian.shape == (2, 9, 3)
    for i, wi in enumerate(w):
        one = lieint.sensitivity(system, system.initial_state(angular_velocity=wi), (0.0, 0.5), h=0.05,
                                 parameters=["gravity"])  # fmt: skip
        assert np.allclose(both.jacobian[i], one.jacobian, rtol=1e-12, atol=1e-14)
    from lieint.systems.stacked import stack_systems

    other = lieint.HeavyTop(np.diag([1.0, 1.4, 1.9]), 2.0, [0.0, 0.0, 0.1], [0.0, 0.0, -9.81])
    stack = stack_systems([system, other], [1, 1])
    with pytest.raises(ValueError, match=r"offers no numeric parameters .*one value per member"):
        lieint.sensitivity(stack, {k: np.stack([v, v]) for k, v in y0.items()}, (0.0, 0.1), h=0.05)


def _moments_tensor(I):
    """``B = diag(b)``, ``b_i = (I_j + I_k − I_i)/2``, written out here (not lieint's)."""
    I = np.asarray(I, dtype=float)
    return np.diag(0.5 * I.sum() - I)


@pytest.mark.parametrize("method", ["rkmk4", "splitting2"])
def test_principal_moments_of_a_lagrange_top_match_central_differences(method):
    """``moments`` of a diagonal 3D tensor (here I₁ = I₂, a Lagrange top): each moment alone
    moved, the top rebuilt from the moved moments, 20 steps; a splitting's axes stay put."""
    I, w = np.array([1.0, 1.0, 0.5]), [0.3, 0.2, 4.0]

    def top(moments):
        return lieint.HeavyTop(_moments_tensor(moments), 1.0, [0.0, 0.0, 0.2], [0.0, 0.0, -9.81])

    y0 = top(I).initial_state(angular_velocity=w)
    got = lieint.sensitivity(top(I), y0, (0.0, 1.0), h=0.05, method=method, parameters=["moments"])
    assert got.labels == ["moments[0]", "moments[1]", "moments[2]"]

    def end(moments):
        sol = lieint.integrate(top(moments), y0, (0.0, 1.0), h=0.05, method=method)
        return {k: v[-1] for k, v in sol.states.items()}

    for k in range(3):
        e = 1e-5 * np.eye(3)[k]
        plus, minus = end(I + e), end(I - e)
        dA = (plus["A"] - minus["A"]) / 2e-5
        dG = (plus["Gamma"] - minus["Gamma"]) / 2e-5
        truth = np.concatenate([dA[np.triu_indices(3, 1)], dG])
        assert np.max(np.abs(got.jacobian[:6, k] - truth)) < 1e-6 * np.max(np.abs(truth)), k


def test_moments_of_a_full_tensor_are_refused_by_name():
    system, y0 = _body("euler_top")
    with pytest.raises(ValueError, match=r"'moments'.*not diagonal.*differentiate with respect to 'B'"):
        lieint.sensitivity(system, y0, (0.0, 0.1), h=0.05, parameters=["moments"])


def test_the_flat_body_s_mass_tensor_derivatives_match_central_differences():
    # I = (1, 2, 3): B = diag(2, 1, 0) has an eigenvalue 0, where the dense complex solve over all
    # n² entries of Ω was singular (the diagonal's 2 b₃ Ω₃₃ = 0); every direction of B that keeps
    # the body a body both ways (all but B₃₃) against central differences of whole runs
    from tangent_cases import difference, parameter_directions

    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.6, -0.4, 0.9])
    got = lieint.sensitivity(top, y0, h=RUN["h"], t_span=RUN["t_span"], method="rkmk4", parameters=["B"])
    mine = got.of("B")

    def end(B):
        sol = lieint.integrate(lieint.EulerTop(B), y0, method="rkmk4", **RUN)
        return {k: v[-1] for k, v in sol.states.items()}

    y1 = end(top.B)
    checked = 0
    for c, D in enumerate(parameter_directions("B", top.B)):
        if D[2, 2]:
            continue  # b₃ − e < 0 is no body
        e = 1e-5
        truth = difference(top, y1, end(top.B + e * D), end(top.B - e * D), e)
        assert np.max(np.abs(mine[:, c] - truth)) < 1e-6 * np.max(np.abs(truth)) + 1e-9, c
        checked += 1
    assert checked == 5
