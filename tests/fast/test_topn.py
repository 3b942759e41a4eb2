"""The compiled n-dimensional top (lieint.fast.topn) must match the generic numpy path.

Every registered fixed-step method whose ``compiled()`` declares a family with stage code on
every system form (conftest's ``EVERY_FORM``: RKMK in exponential and in Cayley coordinates,
the products of exponentials, classical RK) is run on both paths, for n = 4, 5, 6, 8, with
and without the orientation, batched, thinned by ``save_every``; a run cut into segments
(streamed, interrupted and resumed) gives the bits of one that is not; the dexp⁻¹ range is
the generic path's to the last bit of the step.
Small n, few steps: the kernel compiles once (one type signature), about 13 s on a cold cache.
"""

import numpy as np
import pytest
from conftest import EVERY_FORM, compiled_methods, random_rotation, random_skew
from scipy.linalg import expm

import lieint
from lieint.groups.so import so_ad_spectral_radius

COMPILED = compiled_methods()
#: the RKMK methods among them again in Cayley coordinates (the kernel steps both maps)
CAYLEY = [name for name in COMPILED if lieint.get_method(name).compiled().family == "rkmk"]


def test_the_registry_has_compiled_methods_of_both_kinds():
    kinds = {lieint.get_method(name).compiled().family for name in COMPILED}
    assert kinds == set(EVERY_FORM) and {"rkmk4", "rk4", "cf4", "cg4a"} <= set(COMPILED)


def top(n, rng, diagonal):
    b = np.linspace(0.6, 1.9, n)
    if diagonal:
        return np.diag(b)
    Q = random_rotation(rng, n)
    Q[:, 0] *= -1  # an improper eigenbasis on purpose: the kernel must fix its orientation
    return Q @ np.diag(b) @ Q.T


@pytest.mark.parametrize(
    "method,coordinates", [(name, None) for name in COMPILED] + [(name, "cayley") for name in CAYLEY]
)
@pytest.mark.parametrize("n", [4, 5, 6, 8, 9])  # 9: past the unrolled products, BLAS behind them
@pytest.mark.slow
def test_topn_matches_the_generic_path(rng, method, coordinates, n):
    B = top(n, rng, diagonal=n % 2 == 0)
    project = n in (5, 8)
    Omega = random_skew(rng, n, (2,), scale=1.5)
    for orientation in (True, False):
        system = lieint.EulerTop(B, orientation=orientation)
        R = random_rotation(rng, n, (2,)) if orientation else None
        y0 = system.initial_state(Omega=Omega, R=R)
        kw = dict(t_span=(0.0, 0.405), h=0.01, method=method, coordinates=coordinates, project=project, save_every=7)
        fast = lieint.integrate(system, y0, backend="numba", **kw)
        ref = lieint.integrate(system, y0, backend="numpy", **kw)
        assert fast.stats.backend == "numba" and ref.stats.backend == "numpy"
        assert "compiled" in fast.stats.backend_reason and f"{n}D top" in fast.stats.backend_reason
        assert ("Cayley" in fast.stats.backend_reason) == (coordinates == "cayley")
        assert np.array_equal(fast.t, ref.t) and fast.t[-1] == 0.405
        assert list(fast.states) == list(ref.states) == (["A", "R"] if orientation else ["A"])
        assert fast.states["A"].shape == ref.states["A"].shape == (fast.t.size, 2, n, n)
        np.testing.assert_allclose(fast.states["A"], ref.states["A"], rtol=0, atol=1e-12)
        if orientation:
            np.testing.assert_allclose(fast.states["R"], ref.states["R"], rtol=0, atol=1e-12)
        assert fast.nsteps == ref.nsteps and fast.nfev == ref.nfev


def test_topn_single_body_and_two_batch_dimensions(rng):
    system = lieint.EulerTop(top(5, rng, diagonal=False))
    Omega = random_skew(rng, 5, (2, 2))
    y0 = system.initial_state(Omega=Omega, R=random_rotation(rng, 5, (2, 2)))
    kw = dict(t_span=(0.0, 0.3), h=0.01, method="rkmk4", save_every=4)
    fast = lieint.integrate(system, y0, backend="auto", **kw)
    ref = lieint.integrate(system, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba" and fast.states["R"].shape == (fast.t.size, 2, 2, 5, 5)
    for name in ("A", "R"):
        np.testing.assert_allclose(fast.states[name], ref.states[name], rtol=0, atol=1e-12)
    one = lieint.integrate(system, {k: v[1, 0] for k, v in y0.items()}, backend="auto", **kw)
    assert one.stats.threads == 1 and "serial" in one.stats.backend_reason
    for name in ("A", "R"):  # each body alone gives the bits it gets in the ensemble
        assert np.array_equal(one.states[name], fast.states[name][:, 1, 0])
    # the invariants of the action are kept: spectrum of A, space momentum, R on SO(5)
    assert np.max(fast.drift("casimirs")) < 1e-13
    assert np.max(fast.invariants["orthogonality"]) < 1e-13


SCENE4 = """
[scene]
name = "4D top"

[body]
mass_tensor = [[0.5, 0.1, 0, 0], [0.1, 1.0, 0, 0], [0, 0, 1.7, 0.2], [0, 0, 0.2, 2.3]]

[support]
type = "fixed_point"

[initial]
omega = [[0, -0.3, 0.5, -0.2], [0.3, 0, -0.4, 0.6], [-0.5, 0.4, 0, -0.1], [0.2, -0.6, 0.1, 0]]

[integrator]
method = "{method}"
step = 0.01
t_end = 3.005
save_every = 7
project = true

[output]
quantities = ["orientation"]
"""


@pytest.mark.parametrize("method", ["rkmk4", "rk4"])
def test_topn_segments_streamed_and_resumed_equal_one_run(tmp_path, method):
    import h5py

    from lieint.scenes import build_system, load_scene

    path = tmp_path / "top4.toml"
    path.write_text(SCENE4.format(method=method))
    scene = load_scene(path)
    system, y0 = build_system(scene)
    whole = lieint.integrate(system, y0, (0.0, 3.005), h=0.01, method=method, project=True, save_every=7)
    assert whole.stats.backend == "numba"
    out = tmp_path / "top4.h5"
    first = lieint.run(path, out, progress=False, checkpoint_every=13, stop_after=101)
    assert first.status == "interrupted", first.message
    rest = lieint.run(path, out, progress=False, checkpoint_every=29, resume=True)
    assert rest.status == "complete", rest.message
    with h5py.File(out) as f:
        assert f.attrs["backend"] == "numba"
        assert np.array_equal(f["t"][()], whole.t)
        assert np.array_equal(f["states/A"][()], whole.states["A"])
        assert np.array_equal(f["states/R"][()], whole.states["R"])


def _two_plane_omega(rng, n):
    """A body velocity with rotation angles 2, 0.6, 0.4, … in random planes: the Frobenius
    bound (and the one from ‖u²‖) is loose, so the range is decided by the exact test."""
    angles = [2.0, 0.6, 0.4, 0.2][: n // 2]
    D = np.zeros((n, n))
    for k, a in enumerate(angles):
        D[2 * k + 1, 2 * k], D[2 * k, 2 * k + 1] = a, -a
    Q = random_rotation(rng, n)
    return Q @ D @ Q.T


@pytest.mark.parametrize("n", [4, 7])
def test_topn_range_just_passes_and_just_fails_on_both_paths(rng, n):
    # RKMK2's second stage is u = h Ω(A₀): θ₁ + θ₂ of it is h times that of Ω₀
    system = lieint.EulerTop(top(n, rng, diagonal=False))
    y0 = system.initial_state(Omega=_two_plane_omega(rng, n))
    u = system.angular_velocity(y0["A"])
    rho = float(so_ad_spectral_radius(u))
    assert np.linalg.norm(u) > rho * 1.05 and np.sqrt(2 * np.linalg.norm(u @ u)) > rho * 1.05
    h_edge = 2 * np.pi / rho
    kw = dict(method="rkmk2")
    inside = h_edge * (1 - 1e-9)
    with pytest.warns(lieint.LieStepWarning, match="too large for this motion"):  # on both paths alike
        fast = lieint.integrate(system, y0, (0.0, inside), h=inside, backend="numba", **kw)
    with pytest.warns(lieint.LieStepWarning, match="too large for this motion"):
        ref = lieint.integrate(system, y0, (0.0, inside), h=inside, backend="numpy", **kw)
    assert fast.stats.backend == "numba" and fast.nsteps == 1
    for name in ("A", "R"):
        np.testing.assert_allclose(fast.states[name], ref.states[name], rtol=0, atol=1e-12)
    outside = h_edge * (1 + 1e-9)
    for backend in ("numpy", "numba"):
        with pytest.raises(lieint.DexpinvRangeError, match="Lie step too large for exponential coordinates"):
            lieint.integrate(system, y0, (0.0, outside), h=outside, backend=backend, **kw)


def test_the_kernels_cayley_map_is_orthogonal_to_round_off_at_any_step(rng):
    # partial pivoting: I − u/2 has singular values ≥ 1, and the map stays orthogonal to the
    # solve's accuracy from tiny to absurd steps (the Cayley path has no range limit); the exact dcay⁻¹
    # against the generic group's formula; a non-finite u gives NaN (the state is reported)
    from lieint.fast.cayley import cayley_into, dcayinv_into
    from lieint.groups.so import SO

    for n in (4, 6, 9):
        Q, L, T, W, tmp, out = (np.empty((n, n)) for _ in range(6))
        for scale in (1e-8, 0.3, 3.0, 100.0, 1e4, 1e9, 1e17):
            u = random_skew(rng, n)
            u *= scale / np.linalg.norm(u, 2)
            cayley_into(u, Q, L, T)
            if scale > 1e4 and np.isnan(Q).all():
                # off the group by more than OFF_GROUP (θ ≳ 1e10): not the map any more, NaN
                # (reported, or a trial step rejected); at 1e17 also a zero pivot
                continue
            # orthogonal to 8nε at every step: the solve is accurate to ε·cond(I − u/2), cond ≈
            # θ₁/2 (2e-13 at n = 9, θ₁ = 1e4; O(1) at 1e17, as numpy's solve), and a map left
            # off the group by less than OFF_GROUP is brought back onto it (orthogonal_polish)
            assert np.abs(Q.T @ Q - np.eye(n)).max() <= 8 * n * np.finfo(float).eps, (n, scale)
            assert np.linalg.det(Q) > 0, (n, scale)  # a rotation, as cay(u) is
            if scale > 1e4:
                continue
            exact = np.linalg.solve(np.eye(n) - u / 2, np.eye(n) + u / 2)
            # both solves are backward stable: they agree to ε times cond(I − u/2) ≈ θ₁/2
            np.testing.assert_allclose(Q, exact, rtol=0, atol=1e-15 * n * max(1.0, scale))
            xi = random_skew(rng, n)
            dcayinv_into(u, xi, out, W, tmp)
            expected = SO(n).dcayinv(-u, xi)
            np.testing.assert_allclose(out, expected, rtol=0, atol=1e-14 * max(1.0, scale**2))
        u[0, 1] = np.nan
        cayley_into(u, Q, L, T)
        assert np.isnan(Q).all()
        # a huge u: NaN (reported, or a rejected trial step) or a finite map, never an error
        huge = random_skew(rng, n) * 1e307
        cayley_into(huge, Q, L, T)
        assert np.isnan(Q).all() or np.isfinite(Q).all()
        bad, good = random_skew(rng, n), random_skew(rng, n)
        bad[0, 1], bad[1, 0] = np.inf, -np.inf
        both = SO(n).cay(np.stack([bad, good]))  # the generic map: one bad element spoils no other
        assert not np.isfinite(both[0]).all() and np.allclose(both[1], SO(n).cay(good), rtol=0, atol=1e-15)


def test_the_cayley_maps_unpivoted_shortcut_is_partial_pivotings_own_result(rng):
    # I − u/2 column diagonally dominant (Σ_r |u_rc| < 2): elimination keeps the dominance, so
    # partial pivoting would not swap and the shortcut that skips its search is the same
    # operations — the same bits — on both sides of the threshold and at random dominant steps
    # (4 ≤ n ≤ 6: the unrolled elimination of lieint.fast.small_cayley; 7, 8: the loops)
    # (beyond the dominance: partial pivoting, then the polish onto the orthogonal matrices)
    from lieint.fast.cayley import _column_dominant, _eliminate, cayley_into
    from lieint.fast.skew import orthogonal_polish

    for n in (4, 5, 6, 7, 8):
        Q, L, T, ref = np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
        for target in (1e-6, 0.5, 1.99, 2.01, 4.0):
            u = random_skew(rng, n)
            u *= target / np.abs(u).sum(axis=0).max()  # the largest column sum is the target
            assert _column_dominant(u) == (target < 2.0)
            cayley_into(u, Q, L, T)
            _eliminate(u, ref, L, True)
            if target > 2.0:
                orthogonal_polish(ref, L, 0, T, 0)
            assert np.array_equal(Q, ref), (n, target)
            assert np.array_equal(np.signbit(Q), np.signbit(ref)), (n, target)  # zeros' signs too
        sparse = np.zeros((n, n))  # zero multipliers and signed zeros in the elimination
        sparse[0, 1], sparse[1, 0], sparse[2, n - 1], sparse[n - 1, 2] = 0.3, -0.3, -0.0, 0.0
        cayley_into(sparse, Q, L, T)
        _eliminate(sparse, ref, L, True)
        assert np.array_equal(Q, ref) and np.array_equal(np.signbit(Q), np.signbit(ref)), n
        assert not _column_dominant(np.full((n, n), np.nan)) and not _column_dominant(np.full((n, n), np.inf))


def test_the_principal_frame_conversions_are_numpys_and_skew(rng):
    # skew(PᵀAP), RP in and skew(PÃPᵀ), R̃Pᵀ out, for stacks of any n: the numpy expressions to
    # round-off, A exactly skew, and out ∘ in the identity to round-off
    from lieint.fast.principal import to_principal, to_user

    for n in (4, 6, 9, 12):
        P = random_rotation(rng, n)
        A = np.stack([random_skew(rng, n) for _ in range(5)]).reshape(5, 1, n, n)
        R = np.stack([random_rotation(rng, n) for _ in range(5)]).reshape(5, 1, n, n)
        At, Rt = to_principal(A, R, P)
        assert At.shape == Rt.shape == (5, n, n)
        expected = P.T @ A.reshape(5, n, n) @ P
        np.testing.assert_allclose(At, 0.5 * (expected - np.swapaxes(expected, -1, -2)), rtol=0, atol=1e-14)
        np.testing.assert_allclose(Rt, R.reshape(5, n, n) @ P, rtol=0, atol=1e-14)
        assert np.array_equal(At, -np.swapaxes(At, -1, -2))
        Au, Ru = to_user(At, Rt, P)
        np.testing.assert_allclose(Au, A.reshape(5, n, n), rtol=0, atol=1e-14)
        np.testing.assert_allclose(Ru, R.reshape(5, n, n), rtol=0, atol=1e-14)
        assert np.array_equal(Au, -np.swapaxes(Au, -1, -2))
        alone, none = to_user(At, None, P)
        assert none is None and np.array_equal(alone, Au)


def test_a_loose_adaptive_cayley_run_rejects_its_overflowing_trial_steps(rng):
    # rtol 1e-2 on a fast 6D top: trial steps overflow the state; both paths reject them and
    # finish (the compiled elimination once divided by a zero pivot, the generic path's LAPACK
    # solve raised "Singular matrix")
    system = lieint.EulerTop(top(6, np.random.default_rng(5), diagonal=False))
    y0 = system.initial_state(Omega=random_skew(np.random.default_rng(6), 6, (3,)))
    for backend in ("numba", "numpy"):
        kw = dict(method="rkmk853", coordinates="cayley", rtol=1e-2, atol=1e-2, backend=backend)
        sol = lieint.integrate(system, y0, (0.0, 100.0), **kw)
        assert sol.success and sol.t[-1] == 100.0 and sol.stats.nrejected > 0, (backend, sol.message)
        assert np.isfinite(sol.states["A"]).all()


def test_the_kernel_range_test_and_exponential_against_numpy_and_mpmath(rng):
    import mpmath

    from lieint.fast.topn import expm_skew, so_ad_radius_exceeds

    mpmath.mp.dps = 30
    for n in (4, 5, 9, 16):
        for scale in (1e-6, 0.01, 0.3, 1.0, 3.0, 30.0):  # every Taylor degree, and squarings
            u = random_skew(rng, n)
            u *= scale / np.linalg.norm(u, 2)
            Q = expm_skew(u)
            if n <= 9:  # to round-off, ε times the condition ~θ (scipy's expm errs by 1e-13 at θ = 30)
                exact = np.array(mpmath.expm(mpmath.matrix(u.tolist())).tolist(), dtype=float)
                np.testing.assert_allclose(Q, exact, rtol=0, atol=2e-15 * max(1.0, scale))
            np.testing.assert_allclose(Q, expm(u), rtol=0, atol=4e-15 * max(1.0, scale**2))
            assert np.abs(Q.T @ Q - np.eye(n)).max() < 1e-14
            rho = float(so_ad_spectral_radius(u))
            assert so_ad_radius_exceeds(u) == int(rho >= 2 * np.pi)
            for f in (1 - 1e-10, 1 + 1e-10):
                assert so_ad_radius_exceeds(u * (2 * np.pi / rho * f)) == int(f > 1)
    assert so_ad_radius_exceeds(np.full((4, 4), np.nan)) == 2  # not a "too large step"


def test_topn_reports_a_non_finite_state_like_the_generic_path(rng):
    system = lieint.EulerTop(top(4, rng, diagonal=True))
    y0 = system.initial_state(Omega=random_skew(rng, 4, scale=50.0))
    kw = dict(t_span=(0.0, 40.0), h=0.2, method="rk4", save_every=5)
    with pytest.warns(lieint.LieStepWarning):
        fast = lieint.integrate(system, y0, backend="numba", **kw)
    with pytest.warns(lieint.LieStepWarning):
        ref = lieint.integrate(system, y0, backend="numpy", **kw)
    assert not fast.success and not ref.success
    assert "non-finite" in fast.message and "non-finite" in ref.message
    assert np.isfinite(fast.states["A"]).all() and fast.t.size >= 1
    # the rows kept are the generic path's: the first row and the finite saved rows before it
    assert np.array_equal(fast.t, ref.t)
    np.testing.assert_allclose(fast.states["A"], ref.states["A"], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("diagonal", [True, False])
def test_the_bound_a_run_keeps_is_above_the_radius_of_its_rows(rng, diagonal, radius_spy):
    # the compiled loop keeps max ‖M ∘ Ã‖_F over the states it saves; below π/h it answers the
    # step check without the rows: it must bound the generic radius of every row of the run,
    # and a step that reaches π/h must still be reported (the rows are looked at then)
    n = 5
    system = lieint.EulerTop(top(n, rng, diagonal=diagonal))
    y0 = system.initial_state(Omega=np.stack([random_skew(rng, n, scale=s) for s in (0.5, 2.0, 1.0)]))
    sol = lieint.integrate(system, y0, (0.0, 3.0), method="rkmk4", h=0.05, save_every=7)
    with pytest.warns(lieint.LieStepWarning):
        lieint.integrate(system, y0, (0.0, 30.0), method="rkmk4", h=1.5, coordinates="cayley")
    seen = radius_spy
    generic = so_ad_spectral_radius(system.generator(0.0, sol.states)).max()
    (bound, answer), (big_bound, _) = seen
    assert sol.stats.backend == "numba"
    # ‖Ω‖_F² = 2 Σ θ_k² lies between (θ₁ + θ₂)² and 2⌊n/2⌋ θ₁² (= 4θ₁² for n = 5)
    assert generic <= bound * (1 + 1e-13) and bound <= 2 * generic * (1 + 1e-13)
    assert answer == bound  # below π/h: the kept bound answers
    assert big_bound >= np.pi / 1.5


def test_the_closed_form_exponential_of_so4_is_exp_to_round_off(rng):
    # against a 40-digit matrix exponential (mpmath), over norms 1e-9 … 20 and the special
    # cases: zero, one rotation plane (θ₊ = θ₋), an isoclinic rotation (θ₋ = 0)
    import mpmath

    from lieint.fast.skew import expm_so4_into

    eps = np.finfo(float).eps
    plane = np.zeros((4, 4))
    plane[0, 1], plane[1, 0] = 0.7, -0.7
    isoclinic = np.zeros((4, 4))
    isoclinic[0, 1], isoclinic[2, 3] = 1.3, 1.3
    isoclinic -= isoclinic.T
    cases = [np.zeros((4, 4)), plane, isoclinic]
    for _ in range(60):
        u = random_skew(rng, 4)
        cases.append(u * 10 ** rng.uniform(-9, 1.3) / np.linalg.norm(u))
    Q = np.empty((4, 4))
    for u in cases:
        expm_so4_into(u, Q)
        with mpmath.workdps(40):
            ref = np.array(mpmath.expm(mpmath.matrix(u.tolist())).tolist(), dtype=float)
        assert np.max(np.abs(Q - ref)) <= 4 * eps, np.max(np.abs(Q - ref)) / eps
        assert np.max(np.abs(Q.T @ Q - np.eye(4))) <= 4 * eps
    expm_so4_into(np.zeros((4, 4)), Q)
    assert np.array_equal(Q, np.eye(4))
