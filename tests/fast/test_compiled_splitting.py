"""The splittings into exact flows on the compiled engine: the free 3D top's rotations in its
principal frame (:mod:`lieint.fast.top3_split`), the heavy top's and the n-D top's through their
compiled pieces (:mod:`lieint.fast.pieces_split`): the numpy path's map.

Truths that do not depend on the compiled code: the numpy path on the body given in its
principal frame (a diagonal mass tensor, where the numpy path's rotations are exact plane
rotations), and the invariants every piece keeps exactly (the Casimir |Π|, the space momentum,
R on SO(3)).
"""

from __future__ import annotations

import numpy as np
import pytest

import lieint

#: (method, options) of the splittings the compiled form covers
SPLITTINGS = (
    ("splitting2", {}),
    ("splitting4", {}),
    ("splitting6", {}),
    ("splitting4", {"split": "213"}),
    ("splitting2", {"split": "132"}),
    ("splitting4", {"composition": "suzuki"}),
    ("splitting6", {"composition": "triple_jump"}),
)


def _tilted():
    """The body (0.3, 0.5, 0.7) of eigenvalues b, with its principal frame P off the user's."""
    Q, _ = np.linalg.qr(np.random.default_rng(7).normal(size=(3, 3)))
    Q[:, 0] *= np.sign(np.linalg.det(Q))
    return lieint.EulerTop(Q @ np.diag([0.3, 0.5, 0.7]) @ Q.T)


def _last(sol) -> dict:
    return {k: v[-1] for k, v in sol.states.items()}


@pytest.mark.parametrize(("name", "options"), SPLITTINGS)
def test_the_compiled_splitting_is_the_numpy_paths_map(name, options):
    # measured 2026-12-01, 2000 steps of h = 0.01: ≤ 1.0e-13 (the numpy path moves by up to
    # 4e-14 when its initial state moves by one ulp: a round-off walk)
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    method = lieint.get_method(name, **options)
    kw = dict(t_span=(0.0, 20.0), h=0.01, method=method, save_every=100)
    fast = lieint.integrate(top, y0, **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba" and "splitting into exact rotations" in fast.stats.backend_reason
    for field in ("A", "R"):
        np.testing.assert_allclose(fast.states[field], ref.states[field], rtol=0, atol=1e-12, err_msg=field)
    assert fast.stats.nfev == ref.stats.nfev  # one per Strang step


def test_a_tilted_body_is_the_same_body_in_its_principal_frame():
    """The compiled form works in the principal frame: a body given with a non-diagonal B steps as
    the same body given diagonal. Measured over 10⁴ steps: A 2.6e-14 (splitting2), 2.5e-13
    (splitting4), R 3.1e-13, 1.9e-12 — the size of the phase walk that one ulp in the initial
    state makes on the numpy path (2.4e-13, 3.6e-13 in R), times the few ulps of the conversion
    into the principal frame. The numpy path itself, rotating the tilted body in the user's frame
    with P Q Pᵀ, is 9e-11 away, its |Π| drifting by 1.7e-11."""
    tilt = _tilted()
    P = tilt.inertia.P
    diagonal = lieint.EulerTop.from_principal_moments(tilt.inertia.principal_moments)
    y0 = tilt.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    yd = {"A": P.T @ y0["A"] @ P, "R": y0["R"] @ P}
    for name in ("splitting2", "splitting4"):
        kw = dict(t_span=(0.0, 100.0), h=0.01, method=name, save_every=1000)
        fast = lieint.integrate(tilt, y0, **kw)
        ref = lieint.integrate(diagonal, yd, backend="numpy", **kw)
        assert fast.stats.backend == "numba"
        np.testing.assert_allclose(P.T @ fast.states["A"] @ P, ref.states["A"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(fast.states["R"] @ P, ref.states["R"], rtol=0, atol=5e-12)
        for invariant in ("casimirs", "momentum", "orthogonality"):
            assert float(np.max(fast.drift(invariant))) < 1e-13, (name, invariant)


def test_dense_output_and_events_are_the_numpy_paths():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    path = lieint.integrate(top, y0, (0.0, 5.0), h=0.05, method="splitting2", backend="numpy").states["A"][:, 0, 1]
    level = 0.5 * (path.min() + path.max())

    def crossing(t, y):
        return y["A"][..., 0, 1] - level

    for name in ("splitting2", "splitting6"):
        kw = dict(h=0.05, method=name, dense_output=True, events=crossing)
        fast = lieint.integrate(top, y0, (0.0, 5.0), **kw)
        ref = lieint.integrate(top, y0, (0.0, 5.0), backend="numpy", **kw)
        assert fast.stats.backend == "numba" and len(fast.t_events[0]) == len(ref.t_events[0]) > 0
        np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-12)
        midway = np.linspace(0.013, 4.97, 9)
        for field in ("A", "R"):
            np.testing.assert_allclose(fast.sol(midway)[field], ref.sol(midway)[field], rtol=0, atol=1e-12)


def test_an_ensemble_is_each_body_alone():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    w = np.array([0.3, 1.0, 0.4]) * (1 + 0.3 * np.random.default_rng(2).normal(size=(5, 3)))
    ys = top.initial_state(angular_velocity=w)
    kw = dict(t_span=(0.0, 5.0), h=0.01, method="splitting4", save_every=100)
    batch = lieint.integrate(top, ys, **kw)
    assert batch.stats.backend == "numba"
    for m in range(5):
        alone = lieint.integrate(top, {k: v[m] for k, v in ys.items()}, **kw)
        np.testing.assert_array_equal(batch.states["A"][:, m], alone.states["A"])


#: bodies of the pieces' splitting (lieint.fast.pieces_split) with diagonal mass tensors, where the
#: numpy path's plane rotations are exact: the heavy top in 3 and 4 dimensions, the 4D and 5D tops
DIAGONAL = {
    "heavy top n=3": lieint.HeavyTop(np.diag([0.7, 1.0, 1.4]), 1.0, [0.1, 0.05, 0.3], [0.0, 0.0, -9.81]),
    "heavy top n=4": lieint.HeavyTop(np.diag([0.6, 0.9, 1.2, 1.5]), 1.2, [0.1, 0.0, 0.2, 0.3], [0, 0, 0, -9.81]),
    "top n=4": lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5])),
    "top n=5": lieint.EulerTop(np.diag([0.5, 0.8, 1.1, 1.4, 1.9])),
}


def _spinning(system, seed):
    X = np.random.default_rng(seed).normal(size=(system.n, system.n))
    return system.initial_state(Omega=X - X.T)


@pytest.mark.parametrize("label", sorted(DIAGONAL))
@pytest.mark.parametrize(("name", "options"), [*SPLITTINGS[:3], ("splitting4", {"composition": "suzuki"})])
def test_the_pieces_splitting_is_the_numpy_paths_map(label, name, options):
    """The heavy top and the n-D top through their compiled pieces: the numpy path's Strang steps
    (kick, rotations, kick), 200 steps of h = 0.01 to 1e-13 of the states' scale (measured ≤ 3.6e-14
    over 100 steps), and the numpy path's step count."""
    system = DIAGONAL[label]
    y0 = _spinning(system, 1)
    method = lieint.get_method(name, **options)
    kw = dict(t_span=(0.0, 2.0), h=0.01, method=method, save_every=50)
    fast = lieint.integrate(system, y0, **kw)
    ref = lieint.integrate(system, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba" and "compiled pieces" in fast.stats.backend_reason
    assert "splitting into exact rotations" in fast.stats.backend_reason
    for field, values in ref.states.items():
        scale = max(1.0, float(np.abs(values).max()))
        np.testing.assert_allclose(fast.states[field], values, rtol=0, atol=1e-13 * scale, err_msg=field)


def test_the_pieces_splitting_of_a_tilted_heavy_top_keeps_what_each_piece_keeps():
    """A heavy top with a non-diagonal mass tensor (the rotations P exp(θ e_i∧e_j) Pᵀ): each piece
    is a group action, so over 2,000 steps the Casimir ⟨Π, Γ⟩, |Γ| and RᵀR = I move by round-off
    only (measured 1.4e-14, 2.4e-15, 1.9e-14; the numpy path, which forms P Q Pᵀ by products,
    drifts to 4.4e-12, 1.4e-12, 5.1e-12, and the two part by that much), and the energy error
    stays bounded as a splitting's does (within 2× of the numpy path's)."""
    B = np.array([[1.0, 0.2, 0.1], [0.2, 1.5, -0.1], [0.1, -0.1, 2.0]])
    system = lieint.HeavyTop(B, 1.0, [0.1, 0.05, 0.3], [0.0, 0.0, -9.81])
    y0 = system.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    kw = dict(t_span=(0.0, 20.0), h=0.01, method="splitting2", save_every=100)
    fast = lieint.integrate(system, y0, **kw)
    ref = lieint.integrate(system, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba"
    for name in ("casimirs", "gamma_norm"):
        assert float(np.max(fast.drift(name))) < 1e-13, name
    assert float(np.max(fast.invariants["orthogonality"])) < 1e-13
    assert float(np.max(fast.drift("energy"))) <= 2 * float(np.max(ref.drift("energy")))
    for field, values in ref.states.items():
        np.testing.assert_allclose(fast.states[field], values, rtol=0, atol=1e-10 * max(1.0, np.abs(values).max()))


@pytest.mark.parametrize("label", ["heavy top n=3", "top n=4"])
def test_the_pieces_splittings_dense_output_and_events_are_the_numpy_paths(label):
    """The steps report no increment: the interpolants take each step's element from its states,
    as the numpy path does (the attitude's R₀ᵀR₁), so the dense output and the events agree."""
    system = DIAGONAL[label]
    y0 = _spinning(system, 2)
    path = lieint.integrate(system, y0, (0.0, 3.0), h=0.02, method="splitting2", backend="numpy").states["A"][:, 0, 1]
    level = 0.5 * (path.min() + path.max())

    def crossing(t, y):
        return y["A"][..., 0, 1] - level

    kw = dict(h=0.02, method="splitting4", dense_output=True, events=crossing)
    fast = lieint.integrate(system, y0, (0.0, 3.0), **kw)
    ref = lieint.integrate(system, y0, (0.0, 3.0), backend="numpy", **kw)
    assert fast.stats.backend == "numba" and len(fast.t_events[0]) == len(ref.t_events[0]) > 0
    np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-12)
    midway = np.linspace(0.013, 2.97, 9)
    for field, values in ref.sol(midway).items():
        np.testing.assert_allclose(fast.sol(midway)[field], values, rtol=0, atol=1e-12 * max(1, np.abs(values).max()))


def test_the_exact_free_part_runs_on_the_numpy_path():
    exact = lieint.get_method("splitting2", free="exact")
    assert exact.compiled() is None
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4]), (0.0, 0.1), h=0.01, method=exact)
    assert sol.stats.backend == "numpy" and "has no compiled form" in sol.stats.backend_reason


def test_a_backward_run_is_the_numpy_paths():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    kw = dict(h=0.01, method="splitting4", dense_output=True)
    fast = lieint.integrate(top, y0, (5.0, 0.0), **kw)
    ref = lieint.integrate(top, y0, (5.0, 0.0), backend="numpy", **kw)
    assert fast.stats.backend == "numba" and fast.t[-1] == 0.0
    midway = np.linspace(4.9, 0.1, 5)
    for field in ("A", "R"):
        np.testing.assert_allclose(fast.states[field], ref.states[field], rtol=0, atol=1e-13)
        np.testing.assert_allclose(fast.sol(midway)[field], ref.sol(midway)[field], rtol=0, atol=1e-13)
