"""The Moser–Veselov maps of the 3D top on the compiled engine (:mod:`lieint.fast.top3_mv`).

``moser_veselov``, its compositions and its modified-moment forms ``moser_veselov4/6/8/10`` run
compiled on the 3D top; the compiled step must be the numpy path's map (the same equation solved
to round-off, the same group action), checked over 10⁴ steps against the numpy path and — where
gfortran and a copy of Hairer–Vilmart's codes are present — against DMV2 … DMV10, which nobody
here wrote. The truths that do not depend on the code: the Fortran maps, and the invariants the
maps keep exactly (energy, |Π|, R on SO(3)).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import lieint
from lieint.groups.bivectors import hat, vee
from lieint.methods.modified_mv import ModifiedMoserVeselov
from lieint.methods.moser_veselov import MoserVeselov

#: every Moser–Veselov form the registry offers for the 3D top
MV_METHODS = (
    "moser_veselov",
    "moser_veselov_composed4",
    "moser_veselov_composed6",
    "moser_veselov4",
    "moser_veselov6",
    "moser_veselov8",
    "moser_veselov10",
)

_ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("reference_codes_bench", _ROOT / "benchmarks" / "reference_codes.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def _tilted_top() -> lieint.EulerTop:
    """A body whose principal frame is not the user's (the engine works in the principal frame)."""
    Q, _ = np.linalg.qr(np.random.default_rng(7).normal(size=(3, 3)))
    Q[:, 0] *= np.sign(np.linalg.det(Q))
    return lieint.EulerTop(Q @ np.diag([0.3, 0.5, 0.7]) @ Q.T)


def _relative_difference(a: dict, b: dict) -> float:
    """max over A (relative to its size) and R of the entries' difference."""
    scale = float(np.max(np.abs(b["A"])))
    return max(float(np.max(np.abs(a["A"] - b["A"]))) / scale, float(np.max(np.abs(a["R"] - b["R"]))))


def _last(sol) -> dict:
    return {k: v[-1] for k, v in sol.states.items()}


@pytest.mark.parametrize("name", MV_METHODS)
def test_the_compiled_step_is_the_numpy_paths_map_over_ten_thousand_steps(name):
    # measured 2026-12-01: ≤ 6.1e-13 (diagonal bodies, 10⁴ steps of h = 0.01), the size of the
    # numpy path's own distance from Hairer–Vilmart's Fortran (≤ 4.6e-13): a round-off walk
    top = lieint.EulerTop.from_principal_moments(bench.HV_MOMENTS)
    y0 = bench.state(bench.HV_PI0)
    nsteps = 10_000 if name in ("moser_veselov", "moser_veselov4", "moser_veselov10") else 2_000
    kw = dict(t_span=(0.0, nsteps * 0.01), h=0.01, method=name, save_every=nsteps)
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba" and "Moser–Veselov map" in fast.stats.backend_reason
    assert ref.stats.backend == "numpy"
    assert _relative_difference(_last(fast), _last(ref)) < 2e-12


@pytest.mark.parametrize("name", ["moser_veselov", "moser_veselov_composed4", "moser_veselov6"])
def test_a_body_off_its_principal_frame_steps_as_on_the_numpy_path(name):
    top = _tilted_top()
    y0 = top.initial_state(angular_velocity=[0.4, -1.1, 0.7])
    kw = dict(t_span=(0.0, 20.0), h=0.01, method=name, save_every=100)
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba"
    for field in ("A", "R"):
        scale = float(np.max(np.abs(ref.states[field])))
        assert float(np.max(np.abs(fast.states[field] - ref.states[field]))) / scale < 1e-12, field


@pytest.fixture(scope="module")
def codes():
    try:
        with bench.reference_codes() as compiled:
            yield compiled
    except bench.ReferenceCodesUnavailable as why:
        pytest.skip(f"no Fortran reference to compare with: {why}")


@pytest.mark.reference_codes
@pytest.mark.parametrize(("name", "order"), bench.MV_PAIRS)
def test_the_compiled_maps_are_hairer_vilmarts_dmv_maps(codes, name, order):
    # 10⁴ steps of h = 0.01 on the benchmark's three motions; measured 2026-12-01 (compiled,
    # numpy path): ≤ 7.1e-13 and ≤ 4.6e-13 away from the separatrix, ≤ 4.9e-12 and ≤ 4.2e-12
    # at 1e-6 from it (the phase there is ill-conditioned: a round-off walk amplified)
    for label, moments, Pi0 in bench.motions():
        Pi, q = codes.dmv(order, moments, Pi0, [1.0, 0.0, 0.0, 0.0], 0.01, 10_000)
        top = lieint.EulerTop.from_principal_moments(moments)
        sol = lieint.integrate(top, bench.state(Pi0), (0.0, 100.0), h=0.01, method=name, save_every=10_000)
        assert sol.stats.backend == "numba", label
        bound = 2e-11 if "separatrix" in label else 2e-12
        assert bench.difference(_last(sol), Pi, bench.quaternion_to_rotation(q)) < bound, label


@pytest.mark.parametrize("name", MV_METHODS)
def test_the_compiled_maps_keep_energy_casimir_and_orthogonality(name):
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top, y0, (0.0, 200.0), h=0.02, method=name, save_every=100)
    assert sol.stats.backend == "numba"
    for invariant in ("energy", "casimirs", "orthogonality", "momentum"):
        assert float(np.max(sol.drift(invariant))) < 1e-13, invariant


def test_an_ensemble_is_each_body_alone_and_the_numpy_batch():
    top = lieint.EulerTop.from_principal_moments(bench.HV_MOMENTS)
    rng = np.random.default_rng(11)
    Pis = np.array(bench.HV_PI0) * (1 + 0.2 * rng.normal(size=(9, 3)))
    ys = top.initial_state(A=-hat(Pis))
    for name in ("moser_veselov", "moser_veselov8"):
        kw = dict(t_span=(0.0, 5.0), h=0.01, method=name, save_every=50)
        batch = lieint.integrate(top, ys, **kw)
        ref = lieint.integrate(top, ys, backend="numpy", **kw)
        assert batch.stats.backend == "numba"
        for m in range(9):
            alone = lieint.integrate(top, {k: v[m] for k, v in ys.items()}, **kw)
            for field in ("A", "R"):
                np.testing.assert_array_equal(batch.states[field][:, m], alone.states[field])
        assert _relative_difference(_last(batch), _last(ref)) < 1e-12


def test_the_modified_moments_raise_the_order_as_on_the_numpy_path():
    """Fitted orders of the compiled forms against the exact solution (Hairer–Vilmart's body)."""
    top = lieint.EulerTop.from_principal_moments(bench.HV_MOMENTS)
    y0 = bench.state(bench.HV_PI0)
    exact = {k: v[-1] for k, v in top.exact_solution([2.0], y0).items()}
    hs = np.array([0.2, 0.1, 0.05])
    for name, order in (("moser_veselov", 2), ("moser_veselov4", 4), ("moser_veselov6", 6)):
        errors = []
        for h in hs:
            sol = lieint.integrate(top, y0, (0.0, 2.0), h=h, method=name)
            assert sol.stats.backend == "numba"
            errors.append(_relative_difference(_last(sol), exact))
        slope = float(np.polyfit(np.log(hs), np.log(errors), 1)[0])
        assert abs(slope - order) < 0.3, (name, slope)


def test_dense_output_events_and_t_eval_are_the_numpy_paths():
    """The compiled steps report their increment (Cayley coordinates of ω): dense output, events
    and t_eval rows interpolate on the group as the numpy path's, from R₀ᵀR₁."""
    top = _tilted_top()
    y0 = top.initial_state(angular_velocity=[0.4, -1.1, 0.7])
    path = lieint.integrate(top, y0, (0.0, 4.0), h=0.02, method="moser_veselov", backend="numpy").states["A"][:, 0, 1]
    level = 0.5 * (path.min() + path.max())  # a level the motion crosses

    def crossing(t, y):
        return y["A"][..., 0, 1] - level

    for name in ("moser_veselov", "moser_veselov_composed4", "moser_veselov10"):
        kw = dict(h=0.02, method=name, events=crossing, dense_output=True, t_eval=np.linspace(0.0, 4.0, 11))
        fast = lieint.integrate(top, y0, (0.0, 4.0), backend="numba", **kw)
        ref = lieint.integrate(top, y0, (0.0, 4.0), backend="numpy", **kw)
        assert fast.stats.backend == "numba" and len(fast.t_events[0]) == len(ref.t_events[0]) > 0, name
        np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-12)
        midway = np.linspace(0.013, 3.97, 9)
        for field in ("A", "R"):
            np.testing.assert_allclose(fast.states[field], ref.states[field], rtol=0, atol=1e-12)
            np.testing.assert_allclose(fast.sol(midway)[field], ref.sol(midway)[field], rtol=0, atol=1e-12)
        R = fast.sol(midway)["R"]  # on the group between the steps
        np.testing.assert_allclose(np.swapaxes(R, -1, -2) @ R, np.broadcast_to(np.eye(3), R.shape), atol=1e-14)


def test_a_top_without_attitude_and_a_projected_run():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    fast = lieint.integrate(top, y0, (0.0, 10.0), h=0.01, method="moser_veselov6")
    ref = lieint.integrate(top, y0, (0.0, 10.0), h=0.01, method="moser_veselov6", backend="numpy")
    assert fast.stats.backend == "numba" and list(fast.states) == ["A"]
    np.testing.assert_allclose(fast.states["A"], ref.states["A"], rtol=0, atol=1e-13)
    full = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y1 = full.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    kw = dict(h=0.05, method="moser_veselov", project=True)
    fast = lieint.integrate(full, y1, (0.0, 10.0), **kw)
    ref = lieint.integrate(full, y1, (0.0, 10.0), backend="numpy", **kw)
    assert fast.stats.backend == "numba"
    assert _relative_difference(_last(fast), _last(ref)) < 1e-13


def test_a_step_newton_cannot_solve_stops_the_run_with_the_numpy_paths_message():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[15.0, 50.0, 20.0])
    message = r"Moser–Veselov step h = 1000: Newton did not reach round-off.*smaller `h`"
    for backend in ("numba", "numpy"):
        with pytest.raises(RuntimeError, match=message):
            lieint.integrate(top, y0, (0.0, 2000.0), h=1000.0, method="moser_veselov", backend=backend)


@pytest.mark.parametrize("n", [4, 6])
def test_the_n_dimensional_top_steps_as_on_the_numpy_path(n):
    """The n-D map (:mod:`lieint.fast.topn_mv`): the numpy path's Newton iteration on the
    Cayley parameter, for a diagonal and a tilted mass tensor; keeps the Casimirs and R on SO(n)."""
    rng = np.random.default_rng(n)
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    for B in (np.diag(np.linspace(0.6, 1.5, n)), Q @ np.diag(np.linspace(0.6, 1.5, n)) @ Q.T):
        top = lieint.EulerTop(B)
        M = rng.normal(size=(n, n))
        y0 = top.initial_state(A=top.momentum(M - M.T))
        for name in ("moser_veselov", "moser_veselov_composed4"):
            kw = dict(t_span=(0.0, 10.0), h=0.01, method=name, save_every=100)
            fast = lieint.integrate(top, y0, backend="numba", **kw)
            ref = lieint.integrate(top, y0, backend="numpy", **kw)
            assert fast.stats.backend == "numba" and f"{n}D top" in fast.stats.backend_reason, name
            # measured 2026-12-01: ≤ 1.1e-13 (n = 4, 5; 1000 steps)
            assert _relative_difference(_last(fast), _last(ref)) < 1e-12, name
            for invariant in ("energy", "casimirs", "orthogonality"):
                assert float(np.max(fast.drift(invariant))) < 1e-12, (name, invariant)


def test_the_n_dimensional_dense_output_is_the_numpy_paths():
    top = lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]))
    M = np.random.default_rng(4).normal(size=(4, 4))
    y0 = top.initial_state(A=top.momentum(M - M.T))
    for name in ("moser_veselov", "moser_veselov_composed6"):
        kw = dict(h=0.02, method=name, dense_output=True)
        fast = lieint.integrate(top, y0, (0.0, 1.0), backend="numba", **kw)
        ref = lieint.integrate(top, y0, (0.0, 1.0), backend="numpy", **kw)
        assert fast.stats.backend == "numba"
        midway = np.linspace(0.011, 0.99, 7)
        for field in ("A", "R"):
            np.testing.assert_allclose(fast.sol(midway)[field], ref.sol(midway)[field], rtol=0, atol=1e-12)


def test_an_n_dimensional_step_newton_cannot_solve_stops_the_run():
    top = lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]))
    M = np.random.default_rng(4).normal(size=(4, 4))
    y0 = top.initial_state(A=50 * top.momentum(M - M.T))
    for backend in ("numba", "numpy"):
        with pytest.raises(RuntimeError, match=r"Moser–Veselov step h = 1000: Newton did not reach round-off"):
            lieint.integrate(top, y0, (0.0, 2000.0), h=1000.0, method="moser_veselov", backend=backend)


def test_a_subclass_with_another_step_is_not_compiled():
    class Halved(MoserVeselov):
        def step(self, system, t, y, h, state=None):
            return super().step(system, t, y, 0.5 * h, state)

    assert Halved().compiled() is None
    assert MoserVeselov().compiled() is not None
    assert ModifiedMoserVeselov("moser_veselov4", 4).compiled().degree == 1


def test_the_evaluations_reported_are_the_newton_iterations():
    # the 3D maps' Newton stops when the next update would be below round-off (its quadratic
    # convergence), one iteration a solve before the numpy path's, which takes it and sees it:
    # at h = 0.01, 2 against 3 a solve
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    for name, solves in (("moser_veselov", 1), ("moser_veselov_composed4", 3), ("moser_veselov_composed6", 7)):
        sol = lieint.integrate(top, y0, (0.0, 1.0), h=0.01, method=name)
        numpy = lieint.integrate(top, y0, (0.0, 1.0), h=0.01, method=name, backend="numpy")
        assert sol.stats.backend == "numba" and sol.stats.nfev == 100 * solves * 2, name
        assert numpy.stats.nfev == 100 * solves * 3, name


@pytest.mark.slow
def test_the_first_compilation_of_the_kernel_is_announced(tmp_path):
    """In a fresh numba cache the Moser–Veselov kernel's compilation is announced on stderr."""
    script = textwrap.dedent(
        """
        import lieint
        top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
        sol = lieint.integrate(top, y0, (0.0, 1.0), h=0.1, method="moser_veselov4")
        assert sol.stats.backend == "numba"
        """
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "LIEINT_COMPILE_NOTICE": "1"}
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "compiling the top3_mv moser_veselov fixed kernel for first use" in run.stderr


def test_momentum_is_kept_in_the_principal_frame_conversion():
    """Π₁ = ωᵀΠ: the compiled step keeps |Π| of a tilted body to round-off over 10⁴ steps."""
    top = _tilted_top()
    y0 = top.initial_state(angular_velocity=[0.4, -1.1, 0.7])
    sol = lieint.integrate(top, y0, (0.0, 100.0), h=0.01, method="moser_veselov8", save_every=10_000)
    size0, size1 = np.linalg.norm(vee(y0["A"])), np.linalg.norm(vee(sol.states["A"][-1]))
    assert abs(size1 / size0 - 1.0) < 1e-13


def test_backward_runs_are_the_numpy_paths():
    """t_span backward (t1 < t0): the maps take h < 0 (the MV map is symmetric)."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    top4 = lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]))
    M = np.random.default_rng(4).normal(size=(4, 4))
    runs = (
        (top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4]), "moser_veselov6"),
        (top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4]), "moser_veselov_composed4"),
        (top4, top4.initial_state(A=top4.momentum(M - M.T)), "moser_veselov"),
    )
    for system, y0, name in runs:
        kw = dict(h=0.01, method=name, dense_output=True)
        fast = lieint.integrate(system, y0, (5.0, 0.0), **kw)
        ref = lieint.integrate(system, y0, (5.0, 0.0), backend="numpy", **kw)
        assert fast.stats.backend == "numba" and fast.t[-1] == 0.0, name
        midway = np.linspace(4.9, 0.1, 5)
        for field in ref.states:
            np.testing.assert_allclose(fast.states[field], ref.states[field], rtol=0, atol=1e-13, err_msg=name)
            np.testing.assert_allclose(fast.sol(midway)[field], ref.sol(midway)[field], rtol=0, atol=1e-13)


def test_a_diverging_newton_iteration_with_a_singular_jacobian_stops_the_run_with_the_numpy_paths_message():
    # a 6D top stepped at h = 10/6: Newton's iterates diverge until the Jacobian (or I − X/2) is
    # singular to round-off, which numba's LAPACK reports as LinAlgError; the run says instead what
    # the numpy path says
    rng = np.random.default_rng(2)
    Q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    top = lieint.EulerTop(Q @ np.diag(rng.uniform(0.5, 1.5, 6)) @ Q.T)
    W = rng.normal(size=(6, 6))
    y0 = top.initial_state(Omega=0.5 * (W - W.T))
    for method in ("moser_veselov", "moser_veselov_composed4"):
        for backend in ("numba", "numpy"):
            with pytest.raises(RuntimeError, match=r"Moser–Veselov step h = [0-9.]+: Newton did not reach round-off"):
                lieint.integrate(top, y0, (0.0, 10.0), h=10.0 / 6, method=method, backend=backend)
