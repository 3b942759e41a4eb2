"""The free top with any positive principal moments, as Euler's equations need: bodies from the
papers that break the triangle inequality (no mass distribution has them), against the exact
solution and an independent scipy reference, with several methods and both back ends."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lieint
from lieint.groups.bivectors import hat, vee
from lieint.scenes import SceneError, build_system, parse_scene, run_scene

#: Hairer & Vilmart's "water" body; two of Principia's test bodies
WATER, FLAT_DOUBLE, PRINCIPIA = (0.345, 0.653, 1.0), (3.0, 3.0, 9.0), (3.0, 5.0, 9.0)
BODIES = [WATER, FLAT_DOUBLE, PRINCIPIA]
W0 = [0.3, 1.0, 0.4]


def reference_motion(moments, w0, t):
    """Euler's equations ``I ẇ = (I w) × w`` with the attitude ``Ṙ = R ŵ``, solved by scipy's
    DOP853 at tolerances near round-off: a truth that uses neither lieint's integrators nor its
    elliptic functions."""
    I = np.asarray(moments, dtype=float)

    def rhs(_, z):
        w, R = z[:3], z[3:].reshape(3, 3)
        return np.concatenate([np.cross(I * w, w) / I, (R @ hat(w)).ravel()])

    sol = solve_ivp(rhs, (0.0, t[-1]), np.concatenate([w0, np.eye(3).ravel()]), "DOP853", t, rtol=1e-13, atol=1e-15)
    return sol.y[:3].T, sol.y[3:].T.reshape(-1, 3, 3)


@pytest.mark.parametrize("moments", BODIES)
def test_the_bodies_from_the_papers_are_accepted_and_said_to_be_no_mass_distribution(moments):
    top = lieint.EulerTop.from_principal_moments(moments)
    assert np.allclose(top.principal_moments, moments, rtol=1e-15)
    assert not top.has_mass_distribution and np.min(top.b) < 0
    # the equations' condition: every pair sum b_i + b_j (a principal moment) is positive
    assert np.all(top.b.sum() - top.b > 0)
    assert "no mass distribution" in type(top).__doc__
    assert lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0]).has_mass_distribution
    assert lieint.EulerTop.from_principal_moments([1.0, 1.0, 2.0]).has_mass_distribution  # a flat plate


@pytest.mark.parametrize("moments", BODIES)
def test_the_exact_solution_against_an_independent_reference(moments):
    top = lieint.EulerTop.from_principal_moments(moments)
    y0 = top.initial_state(angular_velocity=W0)
    t = np.linspace(0.0, 30.0, 61)
    exact = top.exact_solution(t, y0)
    w_ref, R_ref = reference_motion(moments, W0, t)
    assert np.max(np.abs(vee(exact["Omega"]) - w_ref)) < 1e-11
    assert np.max(np.abs(exact["R"] - R_ref)) < 1e-10


@pytest.mark.parametrize("moments", BODIES)
@pytest.mark.parametrize(
    ("method", "kw", "tol", "energy", "geometric"),
    [
        ("rkmk4", {"h": 0.01}, 1e-7, 1e-9, True),
        ("rkmk6", {"h": 0.02}, 1e-8, 1e-10, True),
        ("rkmk45", {"rtol": 1e-10, "atol": 1e-12}, 1e-7, 1e-8, True),
        ("rkmk853+energy", {"rtol": 1e-10, "atol": 1e-12}, 1e-7, 1e-13, True),
        ("cf4", {"h": 0.01}, 1e-7, 1e-9, True),
        ("moser_veselov", {"h": 0.005}, 1e-3, 1e-13, True),
        ("moser_veselov4", {"h": 0.01}, 1e-6, 1e-13, True),
        ("lie_midpoint", {"h": 0.005}, 1e-3, 1e-13, True),
        ("splitting4", {"h": 0.01}, 1e-6, 1e-8, True),
        ("exact_flow", {"h": 0.5}, 1e-11, 1e-12, True),
        ("rk4", {"h": 0.01}, 1e-7, 1e-9, False),
        ("DOP853", {"rtol": 1e-11, "atol": 1e-13}, 1e-8, 1e-9, False),
    ],
)
@pytest.mark.slow
def test_methods_keep_the_invariants_and_follow_the_exact_motion(moments, method, kw, tol, energy, geometric):
    top = lieint.EulerTop.from_principal_moments(moments)
    y0 = top.initial_state(angular_velocity=W0)
    sol = lieint.integrate(top, y0, (0.0, 20.0), method=method, **kw)
    assert sol.success and sol.status == 0
    exact = top.exact_solution(sol.t, y0)
    assert np.max(np.abs(sol.states["A"] - exact["A"])) < tol
    assert np.max(np.abs(sol.states["R"] - exact["R"])) < 10 * tol
    assert sol.drift("energy") < energy
    assert sol.drift("manakov") < max(energy, 1e-13) * 10
    if geometric:  # the group action keeps the spectrum of A and the space momentum
        assert sol.drift("casimirs") < 1e-13
        assert sol.drift("momentum") < 1e-12


@pytest.mark.parametrize("moments", [WATER, PRINCIPIA])
@pytest.mark.parametrize("method", ["rkmk4", "rk4", "rkmk45", "rkmk853"])
def test_the_compiled_kernels_take_these_bodies(moments, method):
    top = lieint.EulerTop.from_principal_moments(moments)
    y0 = top.initial_state(angular_velocity=np.array([W0, [0.1, -2.0, 0.7]]))
    adaptive = lieint.get_method(method).adaptive
    kw = {"method": method} | ({"rtol": 1e-6, "atol": 1e-8} if adaptive else {"h": 0.01})
    fast = lieint.integrate(top, y0, (0.0, 4.0), backend="numba", **kw)
    slow = lieint.integrate(top, y0, (0.0, 4.0), backend="numpy", **kw)
    assert fast.stats.backend == "numba" and fast.success
    assert (fast.nsteps, fast.stats.nrejected, fast.nfev) == (slow.nsteps, slow.stats.nrejected, slow.nfev)
    # fixed steps: the same grid, equal to round-off; adaptive pairs: within the controller's
    # round-off floor, 10 rtol, as for any body (tests/fast/test_embedded_pairs.py)
    tol = 10 * kw["rtol"] if adaptive else 1e-12
    assert np.max(np.abs(fast.t - slow.t)) <= tol
    assert np.max(np.abs(fast.states["A"] - slow.states["A"])) <= tol
    assert np.max(np.abs(fast.states["R"] - slow.states["R"])) <= tol


def test_an_n_dimensional_top_with_a_negative_eigenvalue():
    top = lieint.EulerTop(np.diag([-0.2, 1.0, 2.0, 3.0]))  # b_1 + b_2 = 0.8 > 0: a valid free top
    assert not top.has_mass_distribution
    X = np.random.default_rng(4).normal(size=(4, 4))
    y0 = top.initial_state(Omega=X - X.T)
    # |Ω| ≈ 3.3: h = 0.01 leaves the fourth-order methods a 1e-7 energy error; Moser–Veselov
    # keeps the energy and the Manakov integrals to round-off, every method the Casimirs
    for method, bound in (("rkmk4", 1e-6), ("moser_veselov", 1e-13), ("splitting4", 1e-6)):
        sol = lieint.integrate(top, y0, (0.0, 10.0), h=0.01, method=method)
        assert sol.drift("casimirs") < 1e-13 and sol.drift("energy") < bound and sol.drift("manakov") < bound
    # high-order convergence at t = 10 (a well-posed motion): halving h cuts RKMK6's error at least
    # 2⁵-fold (measured 118 and 76 from h = 0.02, 0.01, 0.005 against 0.0025)
    end = {h: lieint.integrate(top, y0, (0.0, 10.0), h=h, method="rkmk6").states["A"][-1] for h in (0.02, 0.01, 0.005)}
    ratio = np.max(np.abs(end[0.02] - end[0.005])) / np.max(np.abs(end[0.01] - end[0.005]))
    assert ratio > 32 and np.max(np.abs(end[0.01] - end[0.005])) < 1e-8


@pytest.mark.parametrize(
    ("B", "match"),
    [
        (np.diag([-1.0, 1.0, 2.0]), r"b_i \+ b_j > 0 for every pair .* b_1 \+ b_2 = 0"),
        (np.diag([-2.0, 1.0, 3.0]), r"b_i \+ b_j > 0 for every pair .* b_1 \+ b_2 = -1"),
        (np.diag([-1.0, -1.0, 5.0, 5.0]), r"b_i \+ b_j > 0"),
    ],
)
def test_what_the_equations_do_not_admit_is_refused(B, match):
    with pytest.raises(ValueError, match=match):
        lieint.EulerTop(B)


def test_systems_that_need_a_mass_distribution_refuse_these_bodies():
    B = lieint.EulerTop.from_principal_moments(PRINCIPIA).B
    hint = r"positive semi-definite .*no mass distribution has it; the free top alone, lieint.EulerTop"
    with pytest.raises(ValueError, match=r"`mass_tensor` must be " + hint):
        lieint.HeavyTop(B, 1.0, [0.0, 0.0, 0.1], [0.0, 0.0, -9.81])
    with pytest.raises(ValueError, match=r"triangle inequality .*the free top alone"):
        lieint.HeavyTop.lagrange(3.0, 9.0, mass=1.0, length=0.5)
    with pytest.raises(ValueError, match=r"`mass_tensor` must be positive semi-definite"):
        lieint.FreeBody(B, 1.0)
    with pytest.raises(ValueError, match=r"`mass_tensor` must be positive semi-definite"):
        lieint.ChaplyginBall(B / 100, mass=1.0, radius=1.0)
    with pytest.raises(ValueError, match=r"`mass_tensor` must be positive semi-definite"):
        lieint.RollingBall(B / 100, mass=1.0, radius=1.0, center_of_mass=[0.0, 0.0, -0.1], gravity=[0.0, 0.0, -9.81])


SCENE = """
[scene]
name = "principia"

[body]
principal_moments = [3.0, 5.0, 9.0]
{extra_body}

[support]
type = "fixed_point"

[initial]
angular_velocity = [0.3, 1.0, 0.4]
{forces}
[integrator]
method = "rkmk4"
step = 0.01
t_end = 5.0

[output]
quantities = ["energy", "casimirs"]
"""


def test_a_free_top_scene_takes_any_positive_moments():
    result = run_scene(parse_scene(SCENE.format(extra_body="", forces="")))
    assert result.solution.success and np.max(result.solution.drift("casimirs")) < 1e-13
    assert not result.system.has_mass_distribution


def test_a_heavy_top_scene_names_the_triangle_inequality():
    text = SCENE.format(
        extra_body="mass = 1.0\ncenter_of_mass = [0.0, 0.0, 0.2]", forces="\n[forces]\ngravity = [0.0, 0.0, -9.81]\n"
    )
    with pytest.raises(SceneError, match=r"\[body\] principal_moments \(line 6\): must satisfy I_i <= I_j \+ I_k"):
        build_system(parse_scene(text))
