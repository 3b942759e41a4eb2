"""``max_step`` with scipy's semantics: no trial step of an adaptive method is longer (lieint's pairs
on the compiled engine and on the numpy path, scipy's solvers given it), either way in time;
refused for fixed-step methods and for a bad value, with the argument named."""

from __future__ import annotations

import numpy as np
import pytest

import lieint
from lieint.systems.euler_top_exact import euler_top_flip_times

MOMENTS = [1.0, 2.0, 3.0]
TOP = lieint.EulerTop.from_principal_moments(MOMENTS)
Y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
FLIP_W0 = [0.01, 1.0, 0.01]

CASES = [
    ("rkmk45", "auto"), ("rkmk45", "numpy"), ("rkmk853", "auto"), ("rkmk853", "numpy"), ("rkmk23", "auto"),
    ("rkmk45+energy", "numpy"), ("scipy:RK45", "auto"), ("scipy:DOP853", "auto"), ("scipy:LSODA", "auto"),
]  # fmt: skip


def steps(sol) -> np.ndarray:
    return np.abs(np.diff(sol.t))


@pytest.mark.parametrize("span", [(0.0, 10.0), (10.0, 0.0)])
@pytest.mark.parametrize(("name", "backend"), CASES)
def test_no_accepted_step_exceeds_max_step(name, backend, span):
    """Every accepted step (every row saved, save_every = 1) at most max_step, the largest equal
    to it (the bound binds: without it the steps are longer), the run still reaching t1."""
    options = {"method": name, "rtol": 1e-6, "atol": 1e-9, "backend": backend}
    free = lieint.integrate(TOP, Y0, span, **options)
    bound = 0.4 * float(steps(free).max())
    sol = lieint.integrate(TOP, Y0, span, max_step=bound, **options)
    assert sol.success and sol.t[-1] == span[1]
    assert sol.stats.backend == ("numba" if backend == "auto" and not name.startswith("scipy") else free.stats.backend)
    assert steps(sol).max() <= bound * (1 + 1e-12), (steps(sol).max(), bound)
    assert steps(sol).max() >= 0.999 * bound  # the bound binds somewhere
    assert sol.stats.nsteps > free.stats.nsteps


@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_the_first_trial_step_is_bounded_too(backend):
    """scipy bounds its estimate of the first step by max_step (and a given first_step is cut
    to it at the first step): the first row follows at most max_step after t0."""
    for kw in ({}, {"first_step": 0.5}):
        sol = lieint.integrate(TOP, Y0, (0.0, 1.0), method="rkmk45", rtol=1e-3, max_step=0.01, backend=backend, **kw)
        assert 0 < sol.t[1] - sol.t[0] <= 0.01


@pytest.mark.parametrize("name", ["rkmk45", "scipy:RK45"])
@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_first_step_and_max_step_backward(name, backend):
    """Both are sizes (positive) either way in time: backward, the first step is −first_step,
    and no step is longer than max_step."""
    sol = lieint.integrate(TOP, Y0, (3.0, 0.0), method=name, rtol=1e-6, first_step=0.01, max_step=0.2, backend=backend)
    assert sol.t[0] == 3.0 and sol.t[-1] == 0.0
    assert sol.t[1] - sol.t[0] == pytest.approx(-0.01, abs=1e-15)
    assert steps(sol).max() <= 0.2 * (1 + 1e-12)
    with pytest.raises(ValueError, match=r"`first_step` = 4 must not exceed the span \|t1 - t0\| = 3"):
        lieint.integrate(TOP, Y0, (3.0, 0.0), method=name, first_step=4.0)


@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_compiled_and_numpy_paths_take_the_same_steps_under_max_step(backend):
    ref = lieint.integrate(TOP, Y0, (0.0, 5.0), method="rkmk45", rtol=1e-6, max_step=0.05, backend="numpy")
    sol = lieint.integrate(TOP, Y0, (0.0, 5.0), method="rkmk45", rtol=1e-6, max_step=0.05, backend=backend)
    assert (sol.stats.nsteps, sol.stats.nrejected, sol.nfev) == (ref.stats.nsteps, ref.stats.nrejected, ref.nfev)
    np.testing.assert_allclose(sol.t, ref.t, rtol=0, atol=1e-12)


def flip(t, y):
    return y["A"][0, 2]  # −I₂ Ω₁₃: zero with the middle-axis component (a flip)


@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_max_step_resolves_the_dzhanibekov_flips(backend):
    """The Dzhanibekov top (the embedded scene's body and spin, T = 60) at scipy's default
    tolerances (rtol 1e-3, atol 1e-6): rkmk853's steps of up to 3.4 s jump across the
    separatrix passages and its events count four flips where there are three; with
    max_step = 0.5 it finds the three at the exact times (Jacobi elliptic) to 1e-4 s."""
    exact = euler_top_flip_times(MOMENTS, FLIP_W0, 60.0)
    y0 = TOP.initial_state(angular_velocity=FLIP_W0)
    options = {"method": "rkmk853", "rtol": 1e-3, "atol": 1e-6, "events": flip, "backend": backend}
    free = lieint.integrate(TOP, y0, (0.0, 60.0), **options)
    assert exact.size == 3 and free.t_events[0].size != 3  # unresolved: the wrong number of flips
    sol = lieint.integrate(TOP, y0, (0.0, 60.0), max_step=0.5, **options)
    np.testing.assert_allclose(sol.t_events[0], exact, rtol=0, atol=1e-4)
    back = lieint.integrate(TOP, {k: v[-1] for k, v in sol.states.items()}, (60.0, 0.0), max_step=0.5, **options)
    np.testing.assert_allclose(back.t_events[0], exact[::-1], rtol=0, atol=1e-3)


def test_max_step_inf_is_scipys_default_no_bound():
    a = lieint.integrate(TOP, Y0, (0.0, 5.0), method="rkmk45", rtol=1e-6)
    b = lieint.integrate(TOP, Y0, (0.0, 5.0), method="rkmk45", rtol=1e-6, max_step=np.inf)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.states["R"], b.states["R"])
    c = lieint.integrate(TOP, Y0, (0.0, 5.0), method="RK45", rtol=1e-6, max_step=float("inf"))
    assert c.success


@pytest.mark.parametrize(
    ("value", "error"),
    [(0.0, ValueError), (-0.1, ValueError), (float("nan"), ValueError), (-np.inf, ValueError), ("0.1", TypeError),
     (True, TypeError), ([0.1], TypeError), (None, None)],
)  # fmt: skip
@pytest.mark.parametrize("name", ["rkmk45", "scipy:RK45"])
def test_a_bad_max_step_is_refused_naming_it(name, value, error):
    if error is None:  # None: no bound, the default
        assert lieint.integrate(TOP, Y0, (0.0, 1.0), method=name, max_step=value).success
        return
    with pytest.raises(error, match=r"`max_step` must be a positive number, the largest step size .*; got"):
        lieint.integrate(TOP, Y0, (0.0, 1.0), method=name, max_step=value)


@pytest.mark.parametrize("name", ["rkmk4", "moser_veselov", "exact_flow", "rk4"])
def test_max_step_is_refused_for_fixed_step_methods(name):
    with pytest.raises(ValueError, match=rf"`max_step` applies to adaptive methods.*{name!r} takes fixed steps"):
        lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, method=name, max_step=0.05)
