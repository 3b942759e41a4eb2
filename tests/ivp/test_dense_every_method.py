"""Dense output and events for every method of the registry that applies to the 3D top.

The methods that move the state by the group action without reporting their increment (the
Moser–Veselov maps, the splittings, the exact flow) and the Lie–Poisson midpoint (whose R stays
orthogonal) are interpolated on the group like the RKMK methods: the truths are the exact
solution (Jacobi elliptic functions) and the exact flip times of the Dzhanibekov top.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fitted_slope

import lieint
from lieint.groups.bivectors import vee
from lieint.methods.registry import method_specs
from lieint.systems.euler_top_exact import euler_top_flip_times

TOP = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
Y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])


def applicable(name: str) -> bool:
    try:
        lieint.get_method(name).check_system(TOP)
    except ValueError:
        return False
    return True


TOP_METHODS = [name for name in lieint.method_names() if applicable(name)]
SPECS = method_specs()


def is_fixed(name: str) -> bool:
    method = lieint.get_method(name)
    return not (SPECS[name].adaptive or method.self_controlled)


def on_group(name: str) -> bool:
    method = lieint.get_method(name)
    return bool(method.group_action or method.keeps_group_fields)


def test_the_registry_covers_the_long_time_methods():
    """The methods that report no increment are among those checked here."""
    for name in ["moser_veselov", "moser_veselov8", "lie_midpoint", "splitting4", "exact_flow"]:
        assert name in TOP_METHODS and on_group(name)


def run_kwargs(name: str, h: float) -> dict:
    if is_fixed(name):
        return {"h": h}
    # rkmk853 takes DOP853's steps; near the separatrix its energy error (the Casimir kept) shifts
    # the flip ~10⁴× more per rtol (docs/measurements/adaptive.md): 1e-7 s at rtol 1e-9
    return {"rtol": 1e-11, "atol": 1e-14} if name == "rkmk853" else {"rtol": 1e-9, "atol": 1e-12}


def defect(R):
    """‖RᵀR − I‖ (max entry) per matrix."""
    return np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-2, -1))


@pytest.mark.parametrize("name", [n for n in TOP_METHODS if on_group(n)])
@pytest.mark.slow
def test_dense_states_lie_on_the_group(rng, name):
    """‖RᵀR − I‖ ≤ 1e-14 at 10⁴ random times, and never more than 1e-15 above the round-off
    drift the steps at either end carry themselves (over longer runs the steps' own drift,
    a random walk of round-off, is what limits it). The energy-keeping pairs evaluate their
    dense output by stepping again (one step per time, ~2 ms): 10³ times."""
    sol = lieint.integrate(
        TOP, Y0, (0.0, 10.0), method=name, dense_output=True, backend="numpy", **run_kwargs(name, 0.05)
    )
    times = rng.uniform(0.0, 10.0, 1_000 if SPECS[name].family == "rkmk-energy" else 10_000)
    dense = defect(sol.sol(times)["R"])
    steps = defect(sol.states["R"])
    i = np.searchsorted(sol.t, times)
    assert np.all(dense <= np.maximum(steps[i - 1], steps[i]) + 1e-15)
    early = times <= 2.0
    assert dense[early].max() <= 1e-14, dense[early].max()
    # the steps themselves are where they were (the interpolant ends there exactly)
    assert np.array_equal(sol.sol(sol.t)["R"], sol.states["R"])


def dense_error(name, h, where, T=2.0, skip=2):
    sol = lieint.integrate(TOP, Y0, (0.0, T), h=h, method=name, dense_output=True, backend="numpy")
    n = round(T / h)
    times = (np.arange(skip, n) + 0.37) * h if where == "between" else np.arange(skip + 1, n + 1) * h
    return np.max(np.abs(sol.sol(times)["A"] - TOP.exact_solution(times, Y0)["A"]))


def dense_order(order):
    """The order of the dense output: the method's, up to that of the Hermite curve (4, 6, 8)."""
    if order is None:  # exact steps: the cubic Hermite curve's own error
        return 4
    return min(order, 4 if order <= 4 else 6 if order <= 6 else 8)


@pytest.mark.parametrize("name", [n for n in TOP_METHODS if is_fixed(n)])
@pytest.mark.slow
def test_dense_error_between_steps_has_the_expected_order(name):
    order = SPECS[name].order
    hs = [0.4, 0.2, 0.1] if order is not None and order >= 8 else [0.1, 0.05, 0.025]
    between = [dense_error(name, h, "between") for h in hs]
    assert abs(fitted_slope(hs, between) - dense_order(order)) <= 0.35, between
    if order is not None:
        # order 10: at h = 0.1 the error at the steps is round-off, so longer steps (T a multiple of each)
        step_hs, T = ([0.5, 0.375, 0.25], 3.0) if order > 8 else (hs, 2.0)
        at_steps = [dense_error(name, h, "steps", T) for h in step_hs]
        assert abs(fitted_slope(step_hs, at_steps) - order) <= 0.35, at_steps
        if dense_order(order) == order:
            # between the steps the error is of the size it has at the steps
            assert between[-1] <= 5 * at_steps[-1], (between, at_steps)


def middle_axis_rate(t, y):
    """w₂, the rate about the middle principal axis: it changes sign at each flip."""
    return vee(TOP.P.T @ TOP.angular_velocity(y["A"]) @ TOP.P)[1]


middle_axis_rate.terminal = True

W0 = [0.01, 1.0, 0.01]
FIRST_FLIP = euler_top_flip_times([1.0, 2.0, 3.0], W0, 12.0)[0]


def first_flip(name, h):
    y0 = TOP.initial_state(angular_velocity=W0)
    kwargs = run_kwargs(name, h)
    if name == "rkmk23+energy":
        # 2.5× fewer steps than RK23 near the separatrix, as much error per rtol on A (the tables of
        # docs/measurements/adaptive.md): 2.1e-8 s on this flip at rtol 1e-9, 2.4e-9 s at 1e-10
        kwargs = {"rtol": 1e-10, "atol": 1e-13}
    sol = lieint.integrate(TOP, y0, (0.0, 12.0), method=name, events=middle_axis_rate, **kwargs)
    assert sol.t_events[0].size == 1 and sol.t[-1] == sol.t_events[0][0]
    if on_group(name):  # the event state is on the group as the steps are
        assert defect(sol.y_events[0]["R"]).max() <= defect(sol.states["R"]).max() + 1e-15
    return sol.t_events[0][0]


@pytest.mark.parametrize("name", TOP_METHODS)
@pytest.mark.slow
def test_first_flip_of_the_dzhanibekov_top_with_every_method(name):
    """Fixed steps: the event time converges (at h = 0.04 and 0.02) and errs by at most about the
    change between the two (Richardson: |e(h)| ≈ |t(h) − t(h/2)| / (1 − 2⁻ᵖ)); adaptive runs at
    rtol 1e-9: within 1e-8 s."""
    if not is_fixed(name):
        assert abs(first_flip(name, None) - FIRST_FLIP) <= 1e-8
        return
    coarse, fine = first_flip(name, 0.04), first_flip(name, 0.02)
    err_coarse, err_fine = abs(coarse - FIRST_FLIP), abs(fine - FIRST_FLIP)
    floor = 1e-10  # the flip time's own sensitivity near the separatrix
    assert err_fine <= 2.5 * abs(coarse - fine) + floor, (coarse, fine, FIRST_FLIP)
    assert err_fine < err_coarse or err_coarse <= floor, (coarse, fine, FIRST_FLIP)
