"""Moser–Veselov, the Lie–Poisson midpoint rule and the splittings: fitted orders on the 3D and 4D
top and the heavy top (against the elliptic solution or DOP853 at 1e-13), what each keeps to
round-off, bounded energy against RKMK4's drift in short discriminating runs, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fitted_slope

import lieint
from lieint.methods.moser_veselov import moser_veselov_increment

TOP3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
Y3 = TOP3.initial_state(angular_velocity=[0.3, 1.0, 0.4])
_X4 = np.array([[0, 0.4, -0.3, 0.2], [0, 0, 0.7, -0.5], [0, 0, 0, 0.6], [0, 0, 0, 0]])
TOP4 = lieint.EulerTop(np.diag([0.5, 0.9, 1.3, 2.0]))
Y4 = TOP4.initial_state(Omega=_X4 - _X4.T)
HEAVY = lieint.HeavyTop(np.diag([0.5, 1.0, 1.5]), 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])
YH = HEAVY.initial_state(angular_velocity=[0.3, 1.0, 0.4])


def reference(system, y0, T):
    if system is TOP3:
        return {k: v[-1] for k, v in TOP3.exact_solution([T], y0).items() if k in y0}
    sol = lieint.integrate(system, y0, (0.0, T), method="scipy:DOP853", rtol=1e-13, atol=1e-13, t_eval=[0.0, T])
    return {k: v[-1] for k, v in sol.states.items()}


def fitted_order(method, system, y0, T, ns):
    ref = reference(system, y0, T)
    errs = []
    for n in ns:
        sol = lieint.integrate(system, y0, (0.0, T), h=T / n, method=method)
        errs.append(max(np.max(np.abs(sol.states[k][-1] - ref[k])) for k in ref))
    return fitted_slope([T / n for n in ns], errs), errs


ORDER_CASES = [
    ("moser_veselov", "top3", 2, (40, 80, 160)),
    ("moser_veselov", "top4", 2, (40, 80, 160)),
    ("moser_veselov4", "top3", 4, (40, 80, 160)),
    ("moser_veselov6", "top3", 6, (20, 40, 80)),
    ("moser_veselov8", "top3", 8, (10, 20, 40)),
    ("moser_veselov_composed4", "top3", 4, (40, 80, 160)),
    ("moser_veselov_composed4", "top4", 4, (40, 80, 160)),
    ("moser_veselov_composed6", "top3", 6, (40, 80, 160)),
    ("moser_veselov_composed6", "top4", 6, (40, 80, 160)),
    ("lie_midpoint", "top3", 2, (40, 80, 160)),
    ("lie_midpoint", "top4", 2, (40, 80, 160)),
    ("lie_midpoint", "heavy", 2, (60, 120, 240)),
    ("splitting2", "top3", 2, (40, 80, 160)),
    ("splitting2", "top4", 2, (40, 80, 160)),
    ("splitting2", "heavy", 2, (60, 120, 240)),
    ("splitting4", "top3", 4, (40, 80, 160)),
    ("splitting4", "top4", 4, (40, 80, 160)),
    ("splitting4", "heavy", 4, (60, 120, 240)),
    ("splitting6", "top3", 6, (20, 40, 80)),
    ("splitting6", "top4", 6, (20, 40, 80)),
    ("splitting6", "heavy", 6, (30, 60, 120)),
]
SYSTEMS = {"top3": (TOP3, Y3, 5.0), "top4": (TOP4, Y4, 3.0), "heavy": (HEAVY, YH, 3.0)}


@pytest.mark.parametrize(("method", "body", "order", "ns"), ORDER_CASES)
@pytest.mark.slow
def test_fitted_orders(method, body, order, ns):
    system, y0, T = SYSTEMS[body]
    slope, errs = fitted_order(method, system, y0, T, ns)
    assert abs(slope - order) <= 0.1, (slope, errs)


@pytest.mark.parametrize("split", ["123", "213", "312"])
@pytest.mark.parametrize("composition", ["yoshida", "suzuki", "triple_jump"])
def test_every_split_and_composition_has_its_order(split, composition):
    method = lieint.get_method("splitting4", split=split, composition=composition)
    slope, errs = fitted_order(method, TOP3, Y3, 5.0, (40, 80, 160))
    assert abs(slope - 4) <= 0.1, (slope, errs)


@pytest.mark.slow
def test_heavy_top_splitting_with_the_exact_free_flow():
    for order in (2, 4):
        method = lieint.get_method(f"splitting{order}", free="exact")
        slope, errs = fitted_order(method, HEAVY, YH, 3.0, (60, 120, 240))
        assert abs(slope - order) <= 0.1, (slope, errs)


# -- what each method keeps -------------------------------------------------------------------


@pytest.mark.parametrize("n", [4, 6])
def test_moser_veselov_keeps_energy_casimirs_manakov_and_momentum_to_round_off(n, rng):
    top = lieint.EulerTop(np.diag(np.linspace(0.5, 2.0, n)))
    X = rng.normal(size=(n, n)) * 0.5
    y0 = top.initial_state(Omega=X - X.T)
    sol = lieint.integrate(top, y0, (0.0, 50.0), h=0.05, method="moser_veselov", save_every=10)
    for name in ("energy", "casimirs", "manakov", "momentum"):
        assert np.max(sol.drift(name)) < 1e-13, (name, np.max(sol.drift(name)))
    assert np.max(sol.drift("orthogonality")) < 1e-13


def test_moser_veselov_compositions_keep_what_moser_veselov_keeps():
    for name in ("moser_veselov_composed4", "moser_veselov_composed6"):
        sol = lieint.integrate(TOP4, Y4, (0.0, 20.0), h=0.1, method=name)
        for inv in ("energy", "casimirs", "manakov", "momentum"):
            assert np.max(sol.drift(inv)) < 1e-13, (name, inv)


def test_moser_veselov_is_symmetric(rng):
    y1 = lieint.get_method("moser_veselov").step(TOP3, 0.0, Y3, 0.3, None).y
    back = lieint.get_method("moser_veselov").step(TOP3, 0.3, y1, -0.3, None).y
    for k in Y3:
        np.testing.assert_allclose(back[k], Y3[k], atol=1e-14)


def test_moser_veselov_solves_its_equation_to_round_off(rng):
    from conftest import random_rotation, random_skew

    P = random_rotation(rng, 5)
    top = lieint.EulerTop(P @ np.diag([0.3, 0.7, 1.0, 1.4, 2.2]) @ P.T)
    A = top.momentum(random_skew(rng, 5, (3,)))
    h = 0.2
    omega, iterations = moser_veselov_increment(top.inertia, A, h)
    assert iterations <= 6
    # h A = B ωᵀ − ω B, ω orthogonal, and (equivalently) h A₁ = ωᵀB − Bω for A₁ = ωᵀAω
    B = top.B
    np.testing.assert_allclose(B @ np.swapaxes(omega, -1, -2) - omega @ B, h * A, atol=1e-14)
    np.testing.assert_allclose(np.swapaxes(omega, -1, -2) @ omega, np.broadcast_to(np.eye(5), omega.shape), atol=1e-14)
    A1 = np.swapaxes(omega, -1, -2) @ A @ omega
    np.testing.assert_allclose(np.swapaxes(omega, -1, -2) @ B - B @ omega, h * A1, atol=1e-14)


def test_moser_veselov_refuses_a_step_newton_cannot_solve():
    with pytest.raises(RuntimeError, match=r"Moser–Veselov step h = 1000: Newton did not reach round-off.*smaller `h`"):
        moser_veselov_increment(TOP3.inertia, Y3["A"] * 50, 1000.0)


def test_lie_midpoint_keeps_the_quadratic_invariants():
    sol = lieint.integrate(TOP3, Y3, (0.0, 50.0), h=0.1, method="lie_midpoint")
    for name in ("energy", "casimirs", "orthogonality"):
        assert np.max(sol.drift(name)) < 1e-13, name
    sol = lieint.integrate(HEAVY, YH, (0.0, 5.0), h=0.01, method="lie_midpoint")
    for name in ("energy", "casimirs", "gamma_norm", "orthogonality"):
        assert np.max(sol.drift(name)) < 1e-13, name
    # n = 4: the Casimirs tr A² and the Pfaffian are quadratic, so the whole spectrum is kept
    sol = lieint.integrate(TOP4, Y4, (0.0, 20.0), h=0.05, method="lie_midpoint")
    assert np.max(sol.drift("energy")) < 1e-13
    assert np.max(sol.drift("casimirs")) < 1e-13
    # n = 5: energy and tr A² are kept; tr A⁴ is quartic and is not (the spectrum errs at O(h²))
    top5 = lieint.EulerTop(np.diag([0.4, 0.8, 1.1, 1.5, 2.0]))
    X = np.triu(np.arange(1.0, 26.0).reshape(5, 5) % 7 - 3.0, 1) * 0.2
    sol = lieint.integrate(top5, top5.initial_state(Omega=X - X.T), (0.0, 20.0), h=0.05, method="lie_midpoint")
    trA2 = np.einsum("...ij,...ji->...", sol.states["A"], sol.states["A"])
    trA4 = np.einsum("...ij,...ji->...", *(2 * [sol.states["A"] @ sol.states["A"]]))
    assert np.max(sol.drift("energy")) < 1e-13
    assert np.max(np.abs(trA2 / trA2[0] - 1)) < 1e-13
    assert 1e-8 < np.max(np.abs(trA4 / trA4[0] - 1)) < 1e-2


@pytest.mark.parametrize("name", ["splitting2", "splitting4", "splitting6"])
def test_splittings_keep_casimirs_momentum_and_the_heavy_top_leaves(name):
    sol = lieint.integrate(TOP4, Y4, (0.0, 20.0), h=0.05, method=name)
    for inv in ("casimirs", "momentum", "orthogonality"):
        assert np.max(sol.drift(inv)) < 1e-13, inv
    sol = lieint.integrate(HEAVY, YH, (0.0, 5.0), h=0.01, method=name)
    for inv in ("casimirs", "gamma_norm", "orthogonality"):
        assert np.max(sol.drift(inv)) < 1e-13, inv


def growth_exponent(t, err, decades=2.0):
    running = np.maximum.accumulate(np.abs(err))
    keep = t >= t[-1] / 10.0**decades
    return float(np.polyfit(np.log(t[keep]), np.log(running[keep]), 1)[0])


def energy_error(system, y0, method, h, steps):
    # every step saved: a sparse sample of an oscillating error lets its running maximum climb
    sol = lieint.integrate(system, y0, (0.0, h * steps), h=h, method=method)
    H = system.evaluate_invariants(sol.t, sol.states, ["energy"])["energy"]
    return sol.t, (H - H[0]) / abs(H[0])


LAGRANGE = lieint.HeavyTop.lagrange(1.0, 0.6, 1.0, 0.4)
YL = LAGRANGE.initial_state(angular_velocity=[0.5, 0.2, 4.0], R=lieint.groups.so3_exp(lieint.groups.hat([0.4, 0, 0])))


@pytest.mark.slow
def test_moser_veselov_energy_round_off_is_a_random_walk_not_a_drift():
    # 64 tops within 1e-3 of Y3, 2000 steps each (one batched run). The step used to round its
    # increment ω = I + K, and the 3D top (moments 1, 2, 3: a flat body, b₃ = 0) keeps ω₃₃
    # exactly, so the rounding error of ω's diagonal repeated from step to step and each top's
    # energy drifted one way for hundreds of steps: rms 6.3e-14 … 6.9e-14 after 2000 steps on
    # three seeds, 20 times the 3.1e-15 … 4.0e-15 of a random walk of the per-step round-off
    # (7e-17 a step), which the step from K = ω − I gives.
    rng = np.random.default_rng(20261122)
    y0 = TOP3.initial_state(angular_velocity=np.array([0.3, 1.0, 0.4]) + 1e-3 * rng.normal(size=(64, 3)))
    sol = lieint.integrate(TOP3, y0, (0.0, 100.0), h=0.05, method="moser_veselov", save_every=500)
    H = TOP3.energy(sol.states["A"])
    rms = np.sqrt(np.mean(((H - H[0]) / np.abs(H[0])) ** 2, axis=1))
    assert rms[-1] < 1.5e-14, rms
    # and it grows like √t (4 × the steps: 1.8 × the rms), not like t
    assert rms[-1] < 3.0 * rms[1], rms


@pytest.mark.slow
@pytest.mark.parametrize(("body", "h"), [("top3", 0.1), ("lagrange", 0.02)])
def test_splitting_energy_stays_bounded_while_rkmk4_drifts(body, h):
    # the heavy top with an off-axis centre of mass is chaotic: the running maximum of a bounded
    # error still climbs as the orbit explores, so the short run uses the integrable Lagrange top
    system, y0 = (LAGRANGE, YL) if body == "lagrange" else SYSTEMS[body][:2]
    steps = 20_000
    t, err = energy_error(system, y0, "splitting2", h, steps)
    t4, err4 = energy_error(system, y0, "rkmk4", h, steps)
    # over the last two decades of the run: bounded (≈ 0) against a linear drift (≈ 1)
    assert growth_exponent(t, err) < 0.1
    assert growth_exponent(t4, err4) > 0.8


@pytest.mark.slow
def test_splitting_energy_error_on_the_chaotic_heavy_top_is_bounded_and_of_order_two():
    # The heavy top of benchmarks/long_time.py (centre of mass off the axis: chaotic). A bounded
    # error of a symplectic method of order 2 is h²·(a function of the state) (backward error
    # analysis), with no trend; a drift — of the method or a biased round-off — would shift the
    # mean of the signed error and raise the maxima of later windows, and round-off would not
    # scale with h². Every step is sampled (the running maximum of a sparse sample still
    # climbs).
    T = 400.0
    scaled = []
    for h in (0.04, 0.02):
        t, err = energy_error(HEAVY, YH, "splitting2", h, round(T / h))
        first, second = err[t <= T / 2], err[t > T / 2]
        peak = np.max(np.abs(err))
        assert np.max(np.abs(second)) < 1.15 * np.max(np.abs(first)), h
        assert abs(np.mean(second) - np.mean(first)) < 0.05 * peak, h
        scaled.append(peak / h**2)
    assert scaled[0] == pytest.approx(scaled[1], rel=0.1), scaled


# -- bad input --------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["moser_veselov", "lie_midpoint", "splitting2", "exact_flow"])
def test_methods_refuse_systems_they_do_not_apply_to(name):
    ball = lieint.catalog.make_system(
        "chaplygin_ball", {"mass_tensor": np.diag([0.1, 0.15, 0.2]), "mass": 1.0, "radius": 1.0}
    )
    y0 = ball.initial_state(angular_velocity=np.array([0.3, 1.0, 0.4]))
    with pytest.raises(ValueError, match=f"`method` '{name}'"):
        lieint.integrate(ball, y0, (0.0, 1.0), h=0.1, method=name)


def test_splitting_options_are_checked():
    with pytest.raises(ValueError, match="`split` must be an order of the principal axes"):
        lieint.get_method("splitting2", split="124")
    with pytest.raises(ValueError, match="`composition` must be one of"):
        lieint.get_method("splitting4", composition="blanes")
    with pytest.raises(ValueError, match="`free` must be one of"):
        lieint.get_method("splitting2", free="numeric")
    with pytest.raises(ValueError, match="`split` names an order of the three principal axes"):
        lieint.integrate(TOP4, Y4, (0.0, 1.0), h=0.1, method=lieint.get_method("splitting2", split="123"))
    with pytest.raises(ValueError, match="free='exact' needs a 3D body"):
        lieint.integrate(TOP4, Y4, (0.0, 1.0), h=0.1, method=lieint.get_method("splitting2", free="exact"))


def test_batched_members_step_as_single_runs(rng):
    y = TOP3.initial_state(angular_velocity=rng.normal(size=(3, 3)))
    for name in ("moser_veselov", "lie_midpoint", "splitting4", "exact_flow"):
        batch = lieint.integrate(TOP3, y, (0.0, 1.0), h=0.1, method=name).states["A"][-1]
        for i in range(3):
            one = lieint.integrate(TOP3, {k: v[i] for k, v in y.items()}, (0.0, 1.0), h=0.1, method=name)
            np.testing.assert_allclose(batch[i], one.states["A"][-1], atol=1e-13, err_msg=name)


def test_modified_moser_veselov_is_orders_more_accurate_at_the_cost_of_mv():
    T, h = 5.0, 0.125
    exact = TOP3.exact_solution([T], Y3)
    errors, cost = {}, {}
    for name in ("moser_veselov", "moser_veselov4", "moser_veselov6", "moser_veselov8"):
        sol = lieint.integrate(TOP3, Y3, (0.0, T), h=h, method=name)
        errors[name] = max(np.max(np.abs(sol.states[k][-1] - exact[k][-1])) for k in ("A", "R"))
        cost[name] = sol.stats.nfev
        for inv in ("energy", "casimirs", "momentum"):
            assert np.max(sol.drift(inv)) < 1e-13, (name, inv)
    # one MV solve per step for all of them (Newton iterations within one of each other) …
    assert max(cost.values()) <= 1.4 * cost["moser_veselov"], cost
    # … and each order gains at least two digits here (measured: 1e-2, 5e-6, 8e-8, 7e-11)
    assert errors["moser_veselov4"] < 1e-2 * errors["moser_veselov"]
    assert errors["moser_veselov6"] < 1e-1 * errors["moser_veselov4"]
    assert errors["moser_veselov8"] < 1e-2 * errors["moser_veselov6"]


def test_modified_moments_reduce_to_the_body_at_h_zero():
    from lieint.methods.modified_mv import modified_moments

    np.testing.assert_allclose(modified_moments([1.0, 2.0, 3.0], np.array([0.3, 2.0, 1.2]), 0.0, 3), [1.0, 2.0, 3.0])


def test_modified_moser_veselov_needs_a_3d_top():
    with pytest.raises(ValueError, match=r"`method` 'moser_veselov4' .* needs a 3D top; got n = 4"):
        lieint.integrate(TOP4, Y4, (0.0, 1.0), h=0.1, method="moser_veselov4")
