"""The compiled path must match the generic numpy path (the reference) to round-off."""

import numpy as np
import pytest
from conftest import compiled_methods, random_rotation

import lieint

COMPILED = compiled_methods()


def well_conditioned_top(rng, diagonal=True):
    I = np.array([1.1, 1.7, 2.3])
    b = (I.sum() - 2 * I) / 2
    if diagonal:
        return lieint.EulerTop(np.diag(b))
    Q = random_rotation(rng, 3)
    Q[:, 0] *= -1  # an improper eigenbasis on purpose: the kernel must fix its orientation
    return lieint.EulerTop(Q @ np.diag(b) @ Q.T)


@pytest.mark.parametrize("method", COMPILED)
@pytest.mark.parametrize("project", [False, True])
@pytest.mark.parametrize("diagonal", [True, False])
@pytest.mark.slow
def test_fast_path_matches_the_generic_path(rng, method, project, diagonal):
    top = well_conditioned_top(rng, diagonal)
    y0 = top.initial_state(angular_velocity=rng.normal(size=(3, 3)), R=random_rotation(rng, 3, (3,)))
    kw = dict(t_span=(0.0, 5.0), h=0.01, method=method, project=project, save_every=50)
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert fast.stats["backend"] == "numba" and ref.stats["backend"] == "numpy"
    np.testing.assert_allclose(fast.t, ref.t)
    scale = np.abs(ref.states["A"]).max()
    np.testing.assert_allclose(fast.states["A"], ref.states["A"], atol=1e-13 * scale)
    np.testing.assert_allclose(fast.states["R"], ref.states["R"], atol=1e-13)
    assert fast.nsteps == ref.nsteps and fast.nfev == ref.nfev


@pytest.mark.slow
def test_auto_uses_the_kernel_only_where_it_applies(rng):
    top = well_conditioned_top(rng)
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    assert lieint.integrate(top, y0, (0, 1), h=0.1).stats["backend"] == "numba"
    cayley = lieint.integrate(top, y0, (0, 1), h=0.1, coordinates="cayley").stats  # the generic kernel
    assert cayley["backend"] == "numba" and "compiled pieces on so(3), RKMK (Cayley)" in cayley.backend_reason
    assert lieint.integrate(top, y0, (0, 1), h=0.1, method="lie_midpoint").stats["backend"] == "numba"  # its pieces
    assert lieint.integrate(top, y0, (0, 1), h=0.1, dexpinv_degree=None).stats["backend"] == "numpy"
    four = lieint.EulerTop(np.eye(4))  # the n-dimensional kernel (lieint.fast.topn)
    assert lieint.integrate(four, four.initial_state(Omega=np.zeros((4, 4))), (0, 1), h=0.1).stats.backend == "numba"
    two = lieint.EulerTop(np.eye(2))
    with pytest.raises(
        ValueError,
        match=r"`backend='numba'`: no compiled kernel covers this run: EulerTop \(n = 2\) declares no compiled form",
    ):
        lieint.integrate(two, two.initial_state(Omega=np.zeros((2, 2))), (0, 1), h=0.1, backend="numba")
    with pytest.raises(ValueError, match=r"`backend` must be one of"):
        lieint.integrate(top, y0, (0, 1), h=0.1, backend="gpu")


def test_fast_path_top_without_orientation_and_a_partial_last_step(rng):
    top = lieint.EulerTop(well_conditioned_top(rng).B, orientation=False)
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    a = lieint.integrate(top, y0, (0, 1.05), h=0.1, backend="numba")
    b = lieint.integrate(top, y0, (0, 1.05), h=0.1, backend="numpy")
    assert list(a.states) == ["A"] and a.t[-1] == 1.05
    np.testing.assert_allclose(a.states["A"], b.states["A"], atol=1e-14)


@pytest.mark.slow
def test_fast_path_keeps_the_invariants(rng):
    top = well_conditioned_top(rng)
    y0 = top.initial_state(angular_velocity=rng.normal(size=(100, 3)))
    sol = lieint.integrate(top, y0, (0, 100), h=0.01, method="rkmk4", project=True, save_every=1000)
    assert np.max(sol.drift("casimirs")) < 1e-12
    assert np.max(sol.invariants["orthogonality"]) < 1e-14


@pytest.mark.parametrize("method", ["lie_euler", "rkmk4", "rkmk6"])
@pytest.mark.parametrize("project", [False, True])
def test_ensemble_lanes_match_the_generic_path(rng, method, project):
    top = well_conditioned_top(rng, diagonal=False)
    n = 70  # above the lanes threshold, not a multiple of the block
    y0 = top.initial_state(angular_velocity=rng.normal(size=(n, 3)), R=random_rotation(rng, 3, (n,)))
    kw = dict(t_span=(0.0, 2.0), h=0.01, method=method, project=project, save_every=50)
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    scale = np.abs(ref.states["A"]).max()
    np.testing.assert_allclose(fast.states["A"], ref.states["A"], atol=1e-13 * scale)
    np.testing.assert_allclose(fast.states["R"], ref.states["R"], atol=1e-13)


@pytest.mark.parametrize("orientation", [True, False])
def test_the_lanes_write_the_users_rows_themselves(rng, orientation):
    # the kernel writes A = −(PΠ)^ and R = R(q)Pᵀ where it keeps a row (the starting state's
    # first): exactly skew in a turned principal frame, the generic path's values, and no R for
    # a top without one
    top = lieint.EulerTop(well_conditioned_top(rng, diagonal=False).B, orientation=orientation)
    n = 70
    y0 = top.initial_state(angular_velocity=rng.normal(size=(n, 3)))
    kw = dict(t_span=(0.0, 1.0), h=0.01, method="rkmk4", save_every=30)
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert "SIMD lanes" in fast.stats.backend_reason and list(fast.states) == list(ref.states)
    A = fast.states["A"]
    assert A.shape == (5, n, 3, 3) and np.array_equal(A, -np.swapaxes(A, -1, -2))
    for name in ref.states:
        np.testing.assert_allclose(fast.states[name], ref.states[name], rtol=0, atol=1e-13 * max(1.0, np.abs(A).max()))


@pytest.mark.parametrize("method", ["rkmk4", "rkmk6"])
def test_a_lanes_result_depends_on_neither_its_position_nor_its_neighbours(rng, method):
    """The SIMD lanes' arithmetic (explicit fused multiply-adds, strict IEEE otherwise) rounds
    alike in a vector register and in the scalar remainder of a pass, and in a block whose
    neighbour needed the trigonometric coefficients (|ω|h ≥ 0.1): the same body gives the same
    bits in a call of 133 bodies (two blocks) and in one of 64 where it sits 5 lanes earlier."""
    top = well_conditioned_top(rng, diagonal=False)
    n = 133
    w = rng.normal(size=(n, 3))
    w[40] *= 60.0  # this body's steps reach θ = |ω| h ≥ 0.1: its block takes the scalar fix-up
    y0 = top.initial_state(angular_velocity=w, R=random_rotation(rng, 3, (n,)))
    kw = dict(t_span=(0.0, 0.5), h=0.01, method=method, save_every=10)
    whole = lieint.integrate(top, y0, **kw)
    part = lieint.integrate(top, {k: v[5:69] for k, v in y0.items()}, **kw)
    assert whole.stats.backend == part.stats.backend == "numba"
    for name in ("A", "R"):
        assert np.array_equal(part.states[name], whole.states[name][:, 5:69]), name


@pytest.mark.parametrize("diagonal", [True, False])
@pytest.mark.parametrize("batch", [(), (3,)])
def test_the_kernels_step_check_radius_is_the_generic_one(rng, diagonal, batch):
    # the 3D kernel computes max |ω| over the saved rows for integrate's LieStepWarning check;
    # the generic check evaluates ξ = Ω at the saved states and takes so(3)'s ad radius |ω|
    from lieint.driver import Driver
    from lieint.groups.so import so_ad_spectral_radius
    from lieint.methods.registry import get_method

    top = well_conditioned_top(rng, diagonal)  # an improper eigenbasis when not diagonal
    y0 = top.validate_state(top.initial_state(angular_velocity=rng.normal(size=batch + (3,))))
    driver = Driver(top, get_method("rkmk4"), (0.0, 3.0), h=0.01, save_every=7)
    sol = driver.run(y0)
    radius = driver.generator_radius(sol.states)
    assert driver.backend == "numba" and radius is not None
    generic = float(np.max(so_ad_spectral_radius(top.generator(0.0, sol.states))))
    assert radius == pytest.approx(generic, rel=1e-13)
    # the generic path leaves it to the step check
    numpy_driver = Driver(top, get_method("rkmk4"), (0.0, 3.0), h=0.01, save_every=7, backend="numpy")
    assert numpy_driver.generator_radius(numpy_driver.run(y0).states) is None


@pytest.mark.parametrize("method", COMPILED)
def test_both_paths_warn_alike_at_the_edge_of_resolution(rng, method):
    # near h |ω| = π the numerical orbits of coarse steps differ from the exact one, so the
    # decision is taken on each run's own saved states: both paths must take the same one
    # (or refuse the step alike, beyond the dexp⁻¹ radius)
    import warnings

    top = well_conditioned_top(rng, diagonal=False)
    y0 = top.initial_state(angular_velocity=[0.2, 2.0, 0.3])
    w = top.angular_velocity(top.exact_solution(np.linspace(0, 20, 2001), y0)["A"])
    h_edge = np.pi / float(np.max(np.sqrt(np.sum(w * w, axis=(-2, -1)) / 2)))  # |ω| = ‖Ω‖_F/√2
    decisions = []
    for factor in (0.5, 0.8, 0.95, 1.05, 1.1):
        outcome = {}
        for backend in ("numba", "numpy"):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    lieint.integrate(top, y0, (0.0, 20.0), h=factor * h_edge, method=method, backend=backend)
                except lieint.DexpinvRangeError:
                    outcome[backend] = "refused"
                    continue
            outcome[backend] = any(issubclass(c.category, lieint.LieStepWarning) for c in caught)
        assert outcome["numba"] == outcome["numpy"], (factor, outcome)
        decisions.append(outcome["numba"])
    assert decisions[0] is False and any(d is True or d == "refused" for d in decisions[1:])


def test_the_fused_multiply_add_rounds_once_in_scalar_code_and_in_simd_lanes():
    """``fma(1 + 2⁻³⁰, 1 − 2⁻³⁰, −1) = −2⁻⁶⁰`` exactly (the product rounded first gives 0), in a
    loop long enough to be vectorised and in its scalar remainder alike."""
    from numba import njit

    from lieint.fast.fused import fma

    @njit
    def fused(a, b, c, out):
        for i in range(a.size):
            out[i] = fma(a[i], b[i], c[i])

    n = 37  # a vectorised body and a scalar remainder
    a, b, c = np.full(n, 1 + 2.0**-30), np.full(n, 1 - 2.0**-30), np.full(n, -1.0)
    out = np.empty(n)
    fused(a, b, c, out)
    assert np.all(out == -(2.0**-60)) and np.all(a * b + c == 0.0)


def test_lanes_quaternions_are_scipys_rotations_near_every_pivot(rng):
    """The lanes kernel's quaternion conversions (Shepperd's four pivots) against scipy's
    ``Rotation``: random rotations and rotations by π about each axis and near it."""
    from scipy.spatial.transform import Rotation

    from lieint.fast.quaternions import lanes_from_matrices, matrices_from_lanes

    axes = np.eye(3)
    vectors = np.concatenate([rng.normal(size=(200, 3)), np.pi * axes, (np.pi - 1e-9) * axes, 1e-12 * axes])
    R = Rotation.from_rotvec(vectors).as_matrix()
    q = lanes_from_matrices(R)  # (4, N) as (w, x, y, z)
    expected = Rotation.from_matrix(R).as_quat()  # (N, 4) as (x, y, z, w)
    same = np.minimum(
        np.abs(q.T[:, [1, 2, 3, 0]] - expected).max(axis=1), np.abs(q.T[:, [1, 2, 3, 0]] + expected).max(axis=1)
    )
    assert same.max() < 1e-15
    # back to matrices: products of two components, a few ulps (scipy's own quaternion → matrix
    # of the same rotations errs by 6.7e-16 over 5,000 of them; ours by 8.3e-16)
    np.testing.assert_allclose(matrices_from_lanes(q), R, rtol=0, atol=2e-15)
