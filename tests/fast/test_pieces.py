"""The generic compiled kernel (:mod:`lieint.fast.generic`) against the generic numpy path, for
every built-in system that declares compiled pieces × every method with a compiled form.

Registry-driven: the systems come from the catalog (one variant per layout each declaration can
take: with and without R, centre, tilted gravity, offset centre of mass, a non-diagonal mass
tensor, n = 3 and 4), the methods from the method registry. The kernel compiles once per
installation (about 15 s on a cold cache) and serves every system.
"""

from __future__ import annotations

import numpy as np
import pytest
from bodies import at_rest, first_step_round_off, initial, initial_batch, spd, variants
from conftest import EVERY_FORM

import lieint
from lieint.catalog import _builtin
from lieint.fast.pieces import ACTION, FIELD, GENERATOR, CompiledPieces
from lieint.methods.registry import get_method, method_specs


def _compiled(adaptive: bool) -> list[tuple[str, str | None]]:
    """(name, coordinates) of every registered method and coordinate map with a compiled form
    that compiled pieces step (RKMK, products of exponentials, classical RK: conftest's
    ``EVERY_FORM``; a map with stage code of its own, such as Moser–Veselov on the 3D top, is
    tested in tests/fast)."""
    out = []
    for name, spec in method_specs().items():
        for coordinates in spec.coordinates or (None,):
            method = get_method(name, coordinates=coordinates)
            form = method.compiled()
            # the energy-keeping pairs run compiled on the 3D top only (tests/adaptive/), the maps
            # (Moser–Veselov, splittings) on the tops' forms only (tests/fast/test_compiled_*.py)
            family = getattr(form, "family", None)
            if family in EVERY_FORM and method.adaptive == adaptive and not getattr(form, "keeps_energy", False):
                out.append((name, coordinates))
    return out


#: fixed-step methods with a compiled form, in every coordinate map (exp and Cayley)
FIXED = _compiled(adaptive=False)
#: embedded pairs with a compiled form, in every coordinate map
PAIRS = _compiled(adaptive=True)


#: the fixed-step RKMK methods (exp coordinates) one 3D heavy top or Chaplygin ball runs in vectors
VECTOR_METHODS = {m for m, c in FIXED if lieint.get_method(m).compiled().family == "rkmk" and c != "cayley"}

CASES = [(n, name) for n in (3, 4) for name in variants(n)]


def test_every_builtin_system_on_so_or_se_declares_a_compiled_form():
    """Every catalog system whose group is SO(n)/SE(n) (times vectors) at n ≥ 3, in the variants
    above, has a compiled declaration; the catalog's other systems are named here and why."""
    covered = {name.split("/")[0] for name in variants(3)} | {"euler_top"}
    elsewhere = {  # not rigid bodies on SO(n)/SE(n) × Rᵐ with a compiled declaration
        "central_force_particle",
        "constant_force_particle",
        "surface_particle",
        "atoms_body",  # a FreeBody built from atoms: compiled through FreeBody (checked below)
        "motor_rigid_body",  # geometric-algebra state (motors)
        "prescribed_rotation",  # time-dependent sampled rates
    }
    assert covered | elsewhere == set(_builtin())
    for n in (3, 4):
        for name, system in variants(n).items():
            assert system.compiled() is not None, name
    atoms = lieint.catalog.make_system(
        "atoms_body", {"masses": np.ones(4), "positions": np.vstack([np.eye(3), -np.ones(3)])}
    )
    assert isinstance(atoms, lieint.FreeBody) == (atoms.compiled() is not None)


@pytest.mark.parametrize("n,name", CASES)
@pytest.mark.slow
def test_compiled_and_generic_agree_for_every_method(n, name):
    """Every fixed-step compiled method, with and without projection, to 1e-12 relative to the
    state's size (RKMK in exp coordinates: the same stages, exp and dexp⁻¹ by other formulas)."""
    system = variants(n)[name]
    y0 = initial(system, np.random.default_rng(1))
    assert {("rkmk4", "cayley"), ("rk4", None), ("cf4", None), ("cg4a", None)} <= set(FIXED)
    for method, coordinates in FIXED:
        for project in (False, True):
            kw = dict(t_span=(0.0, 0.4), h=0.02, method=method, coordinates=coordinates, project=project)
            fast = lieint.integrate(system, y0, backend="numba", **kw)
            ref = lieint.integrate(system, y0, backend="numpy", **kw)
            # one 3D heavy top, Chaplygin or rolling ball runs RKMK in exp coordinates unprojected in
            # vectors (tests/fast/test_one_body_vectors.py), everything else on its pieces
            vectors = n == 3 and name.split("/")[0] in ("heavy_top", "chaplygin_ball", "rolling_ball")
            vectors = vectors and coordinates != "cayley" and not project and method in VECTOR_METHODS
            path = "in vectors" if vectors else "compiled pieces"
            assert fast.stats.backend == "numba" and path in fast.stats.backend_reason, (method, coordinates, project)
            for field, expected in ref.states.items():
                scale = max(1.0, float(np.max(np.abs(expected))))
                err = float(np.max(np.abs(fast.states[field] - expected))) / scale
                assert err < 1e-12, (method, coordinates, project, field, err)


@pytest.mark.parametrize("n,name", CASES)
def test_the_bound_the_loop_keeps_is_above_the_radius_of_every_saved_row(n, name, radius_spy):
    """The compiled loop keeps ``max ‖W‖_F`` of ξ over the states it saves, for the step check:
    for every system and every fixed-step method (Lie and classical, segments split by
    ``save_every``) it bounds the generic radius of every row; a step that reaches π/h is still
    reported (the rows are then looked at), as on the generic path."""
    system = variants(n)[name]
    rng = np.random.default_rng(3)
    X = rng.normal(size=(3, n, n)) * np.array([0.5, 2.0, 1.0])[:, None, None]
    y0 = system.initial_state(Omega=X - np.swapaxes(X, -1, -2))
    seen = radius_spy  # the step check's answers, for the whole test
    for method, coordinates in FIXED:
        seen.clear()
        kw = dict(method=method, coordinates=coordinates, h=0.01, save_every=7)
        sol = lieint.integrate(system, y0, (0.0, 0.5), **kw)
        assert sol.stats.backend == "numba"
        generic = system.group.ad_spectral_radius(system.generator(0.0, sol.states)).max()
        ((bound, answer),) = seen
        # ‖W‖_F² = 2 Σ θ_k² lies between (θ₁ + θ₂)² and 2⌊n/2⌋ θ₁²
        assert generic <= bound * (1 + 1e-13) <= (2 * (n // 2)) ** 0.5 * generic * (1 + 1e-12), (method, bound)
        assert answer == bound  # below π/h: the kept bound answers
    with pytest.warns(lieint.LieStepWarning, match="too large for this motion"):
        lieint.integrate(system, y0, (0.0, 6.0), method="rkmk4", coordinates="cayley", h=3.0)
    assert seen[-1][0] >= np.pi / 3.0 and seen[-1][1] is None


@pytest.mark.parametrize("n,name", CASES)
@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")  # what numba would print
def test_a_run_that_blows_up_ends_cleanly_and_prints_nothing(n, name, capfd, monkeypatch):
    """Absurd steps for every system and every fixed-step method, compiled: each run ends as a
    run of the generic path may — finite states, a non-finite state reported, or a step refused
    — and nothing escapes from the compiled pieces (an exception raised inside a piece called
    through a function pointer cannot propagate: numba would print it and carry on with
    garbage). Which of the endings a run meets is not compared with the generic path's: at
    these steps both paths' round-off grows until the trajectories part. The first-compilation
    notice is silenced: whether this test or an earlier one in the process compiles a kernel
    first depends on the order the tests run in."""
    monkeypatch.setenv("LIEINT_COMPILE_NOTICE", "0")
    import warnings

    system = variants(n)[name]
    y0 = initial(system, np.random.default_rng(4))
    y0 = {k: (8.0 * v if k in ("A", "Omega") else v) for k, v in y0.items()}
    for method, coordinates in FIXED:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", lieint.LieStepWarning)
            try:
                run = lieint.integrate(system, y0, (0.0, 60.0), h=2.5, method=method, coordinates=coordinates)
            except lieint.DexpinvRangeError:
                continue
        assert run.stats.backend == "numba"
        finite = all(np.isfinite(v).all() for v in run.states.values())
        assert finite, (method, coordinates, "saved rows must be finite")
        assert run.success or "non-finite" in run.message, (method, coordinates, run.message)
    captured = capfd.readouterr()
    assert captured.err == "" and captured.out == "", captured.err[-2000:]


def test_ensembles_run_in_threads_and_equal_one_body_at_a_time():
    # the 4D ball: ensembles of the 3D one run in SIMD lanes (tests/fast/test_ensemble_lanes.py)
    system = variants(4)["rolling_ball/offset, incline"]
    rng = np.random.default_rng(2)
    X = rng.normal(size=(5, 4, 4))
    y0 = system.initial_state(Omega=X - np.swapaxes(X, -1, -2))
    kw = dict(t_span=(0.0, 1.0), h=0.05, method="rkmk4")
    batch = lieint.integrate(system, y0, backend="numba", **kw)
    assert "compiled pieces" in batch.stats.backend_reason
    for i in range(5):
        one = lieint.integrate(system, {k: v[i] for k, v in y0.items()}, backend="numba", **kw)
        for field in one.states:
            np.testing.assert_array_equal(batch.states[field][:, i], one.states[field])


def test_a_stage_beyond_the_dexpinv_radius_is_refused_as_on_the_generic_path():
    system = variants(3)["heavy_top"]
    y0 = system.initial_state(angular_velocity=[0.0, 0.0, 40.0])
    too_large = r"Lie step too large for exponential coordinates on se\(3\)"
    for backend in ("numpy", "numba"):
        with pytest.raises(lieint.DexpinvRangeError, match=too_large):
            lieint.integrate(system, y0, (0.0, 1.0), h=0.5, method="rkmk4", backend=backend)
    with pytest.raises(lieint.DexpinvRangeError, match=r"at step 1 \(t = 0\)"):
        lieint.integrate(system, y0, (0.0, 1.0), h=0.5, method="rkmk4", backend="numba")


def test_a_subclass_with_other_dynamics_runs_on_the_generic_path():
    class Damped(lieint.HeavyTop):
        def generator(self, t, y):
            return 0.9 * super().generator(t, y)

    system = Damped(np.diag([1.0, 2.0, 3.0]), 1.0, [0.0, 0.0, 0.2], [0.0, 0.0, -9.81])
    assert system.compiled() is None
    run = lieint.integrate(system, system.initial_state(angular_velocity=[1.0, 0.0, 0.5]), (0.0, 0.1), h=0.01)
    assert run.stats.backend == "numpy"


def _spinner_pieces(work_size=9):
    """Compiled pieces of a body spinning at a fixed Ω₀, ``Ṙ = RΩ₀`` on SO(3) (params: 3, Ω₀);
    the action takes its product in the scratch vector ``work``."""
    from numba import njit

    @njit(GENERATOR)
    def generator(y, par, W, v, a, work):
        for i in range(3):
            for j in range(3):
                W[i, j] = par[1 + 3 * i + j]

    @njit(ACTION)
    def action(Q, t, a, y, par, out, work):
        for i in range(3):
            for j in range(3):
                work[3 * i + j] = y[3 * i] * Q[0, j] + y[3 * i + 1] * Q[1, j] + y[3 * i + 2] * Q[2, j]
        out[:9] = work[:9]

    @njit(FIELD)
    def field(y, par, out, work):
        out[:] = (y.reshape(3, 3) @ par[1:].reshape(3, 3)).reshape(9)

    @njit(FIELD)
    def projection(y, par, out, work):
        out[:] = y

    return CompiledPieces(generator, action, field, projection, work=work_size)


_OMEGA0 = np.array([[0.0, -0.3, 0.2], [0.3, 0.0, -1.0], [-0.2, 1.0, 0.0]])


class _Spinner(lieint.LieGroupSystem):
    """A system from outside the package that declares compiled pieces."""

    def __init__(self, pieces):
        self.group = lieint.groups.SO(3)
        self.fields = {"R": (3, 3)}
        self.pieces = pieces

    def generator(self, t, y):
        return np.broadcast_to(_OMEGA0, y["R"].shape)

    def act(self, g, y):
        return {"R": y["R"] @ g}

    def infinitesimal_action(self, xi, y):
        return {"R": y["R"] @ xi}

    def compiled(self):
        from lieint.fast.forms import PiecesForm

        return PiecesForm(self.pieces, np.concatenate([[3.0], _OMEGA0.ravel()]), 3, False, 0, self.fields)


@pytest.mark.slow
def test_a_system_outside_the_package_opts_in_with_its_own_pieces():
    """The generic loop steps any system that declares compiled pieces: here a spinning body
    whose angular velocity is fixed, ``Ṙ = RΩ₀`` on SO(3), against ``R(t) = R₀ exp(tΩ₀)``, with
    every kind of method (fixed and adaptive, exp and Cayley, classical)."""
    from scipy.linalg import expm

    system = _Spinner(_spinner_pieces())
    # RKMK in exponential coordinates is exact for a constant generator (u = tΩ₀ solves
    # u' = dexp⁻¹_u(Ω₀) = Ω₀)
    run = lieint.integrate(system, {"R": np.eye(3)}, (0.0, 2.0), h=0.1, method="rkmk4", backend="numba")
    assert run.stats.backend == "numba"
    np.testing.assert_allclose(run.states["R"][-1], expm(2.0 * _OMEGA0), atol=1e-13)
    # the other kinds of method (Cayley coordinates, an embedded pair, classical RK on Ṙ = RΩ₀)
    # are not exact here: they take the generic path's steps
    for kw in (
        dict(h=0.1, method="rkmk4", coordinates="cayley"),
        dict(rtol=1e-8, atol=1e-10, method="rkmk853"),
        dict(h=0.1, method="rk4"),
    ):
        run = lieint.integrate(system, {"R": np.eye(3)}, (0.0, 2.0), backend="numba", **kw)
        ref = lieint.integrate(system, {"R": np.eye(3)}, (0.0, 2.0), backend="numpy", **kw)
        assert run.stats.backend == "numba" and ref.stats.backend == "numpy", kw
        np.testing.assert_allclose(run.states["R"], ref.states["R"], rtol=0, atol=1e-13)


@pytest.mark.slow
def test_pieces_with_the_wrong_arguments_or_scratch_are_refused_clearly():
    """Pieces written for other arguments (without the scratch vector ``work``, say) are refused
    with the signature they must take, not a numba traceback from inside the loop; a scratch
    length that is not a non-negative integer is refused too."""
    from numba import njit

    @njit
    def old_generator(y, par, W, v, a):  # the signature before the scratch vector
        W[0, 1] = 1.0

    good = _spinner_pieces()
    pieces = CompiledPieces(old_generator, good.action, good.vector_field, good.projection)
    with pytest.raises(TypeError, match=r"must take the arguments .*scratch vector `work`"):
        lieint.integrate(_Spinner(pieces), {"R": np.eye(3)}, (0.0, 1.0), h=0.1, backend="numba")
    for bad in (-1, 2.5, lambda n: -n):
        with pytest.raises(ValueError, match=r"`work` of compiled pieces must give a length >= 0"):
            lieint.integrate(_Spinner(_spinner_pieces(bad)), {"R": np.eye(3)}, (0.0, 1.0), h=0.1, backend="numba")


@pytest.mark.parametrize("n,name", CASES)
@pytest.mark.slow
def test_the_compiled_first_trial_step_is_the_generic_one(n, name):
    """The adaptive kernel's first trial step (the compiled vector field, twice) is the generic
    controller's to round-off, for every pair's error order, ordinary and absurd tolerances (a
    tiny atol overflows the squares of the norm) and a state at rest (the field's norm 0).

    Round-off here is the two vector fields' (the compiled and the generic one agree to a few
    ε‖f‖, not bit for bit) through ``d₂ = ‖f(y₀ + h₀f₀) − f₀‖/h₀``, a difference of nearly
    equal fields: its relative error is about ε‖f₀‖/‖f₁ − f₀‖ (3e-12 on the heavy top at
    rtol 1e-6), and the step's ``1/(q + 1)`` of that — the tolerance below, with a margin of 100."""
    from lieint.control import StepSizeController
    from lieint.loops import adaptive_loop

    system = variants(n)[name]
    rng = np.random.default_rng(5)
    moving = initial(system, rng)
    states = {"moving": moving, "batch": initial_batch(system, rng, 3), "resting": at_rest(system, moving)}
    for label, y0 in states.items():
        for rtol, atol in ((1e-6, 1e-9), (1e-10, 1e-13), (1e-3, 1e-200), (1e-12, 1.0)):
            for method, _ in PAIRS:
                run = lieint.driver.Driver(system, get_method(method), (0.0, 2.0), rtol=rtol, atol=atol)
                y = system.validate_state(y0)
                loop = adaptive_loop(run, y)
                assert loop.name == "numba", (name, label)
                ctrl = StepSizeController(rtol, atol)
                expected = ctrl.initial_step(system, 0.0, y, 2.0, run.method.error_order)
                got = loop.start(y).h
                assert got == pytest.approx(expected, rel=first_step_round_off(system, y, ctrl), abs=0), (
                    name, label, rtol, atol, method,
                )  # fmt: skip


@pytest.mark.parametrize("n,name", CASES)
@pytest.mark.slow
def test_compiled_adaptive_pairs_take_the_generic_paths_steps(n, name):
    """Every embedded pair (rkmk23, rkmk45, rkmk853) takes the generic controller's steps —
    the same accepted and rejected steps and evaluations, at the same times — and ends at the
    same state."""
    system = variants(n)[name]
    y0 = initial(system, np.random.default_rng(1))
    assert {"rkmk23", "rkmk45", "rkmk853"} <= {name for name, _ in PAIRS} and ("rkmk45", "cayley") in PAIRS
    for method, coordinates in PAIRS:
        for project in (False, True):
            kw = dict(t_span=(0.0, 0.5), method=method, coordinates=coordinates, rtol=1e-7, atol=1e-9, project=project)
            fast = lieint.integrate(system, y0, backend="numba", **kw)
            ref = lieint.integrate(system, y0, backend="numpy", **kw)
            assert "adaptive" in fast.stats.backend_reason
            steps = (fast.t.size, fast.stats.nrejected, fast.stats.nfev)
            assert steps == (ref.t.size, ref.stats.nrejected, ref.stats.nfev), (method, coordinates, project)
            # The error estimate y₁ − ŷ cancels the state down to its own size e: the two paths'
            # round-off ε|y| changes it by ε|y|/e relative and the next step by 1/(q + 1) of
            # that. After a step far inside the tolerance (e ~ 1e-13 |y|, the first steps) that
            # is ~1e-4: the decisions are the same, the step sizes agree to about 1e-5.
            np.testing.assert_allclose(fast.t, ref.t, rtol=1e-4)
            for field, expected in ref.states.items():
                scale = max(1.0, float(np.max(np.abs(expected[-1]))))
                err = float(np.max(np.abs(fast.states[field][-1] - expected[-1]))) / scale
                assert err < 1e-10, (method, coordinates, project, field, err)


@pytest.mark.parametrize("n", [4, 6])
@pytest.mark.slow
def test_the_adaptive_pairs_of_the_n_dimensional_top_run_compiled(n):
    """The Euler top for n ≥ 4 runs its fixed steps and its adaptive pairs in its own kernels
    (:mod:`lieint.fast.topn_adaptive`, in the principal frame, the error measured in the user's),
    taking the generic path's steps, with and without R, projected or not."""
    rng = np.random.default_rng(n)
    top = lieint.EulerTop(spd(rng, n, 0.5, 1.5))
    y0 = initial(top, rng)
    no_R = lieint.EulerTop(top.B, orientation=False)
    variants = [(top, False), (no_R, False), (top, True)]
    pairs = [name for name, coordinates in PAIRS if coordinates != "cayley"]  # the registry's
    assert {"rkmk23", "rkmk45", "rkmk853"} <= set(pairs)
    for i, method in enumerate(pairs):
        system, project = variants[i % len(variants)]
        state = y0 if system is top else {"A": y0["A"]}
        kw = dict(t_span=(0.0, 2.0), method=method, rtol=1e-8, atol=1e-10, project=project)
        fast = lieint.integrate(system, state, backend="numba", **kw)
        ref = lieint.integrate(system, state, backend="numpy", **kw)
        assert f"{n}D top (principal frame), adaptive" in fast.stats.backend_reason
        steps = (fast.t.size, fast.stats.nrejected, fast.nfev)
        assert steps == (ref.t.size, ref.stats.nrejected, ref.nfev), method
        for field, expected in ref.states.items():
            np.testing.assert_allclose(fast.states[field][-1], expected[-1], rtol=0, atol=1e-11)


@pytest.mark.parametrize("n", [3, 4, 6])
@pytest.mark.slow
def test_cayley_coordinates_run_compiled_on_the_euler_top(n):
    """The 3D top's kernels have no Cayley form: its Cayley runs (fixed and adaptive) go
    through the generic kernel; the n-D top's kernels (n ≥ 4) step Cayley coordinates
    themselves. Both agree with the generic path."""
    rng = np.random.default_rng(20 + n)
    top = lieint.EulerTop(spd(rng, n, 0.5, 1.5))
    y0 = initial(top, rng)
    kernel = "compiled pieces on so(3)" if n == 3 else f"{n}D top (principal frame)"
    for kw in (dict(h=0.02, method="rkmk4"), dict(method="rkmk45", rtol=1e-8, atol=1e-10)):
        fast = lieint.integrate(top, y0, (0.0, 1.0), coordinates="cayley", backend="numba", **kw)
        ref = lieint.integrate(top, y0, (0.0, 1.0), coordinates="cayley", backend="numpy", **kw)
        assert kernel in fast.stats.backend_reason and "Cayley" in fast.stats.backend_reason
        assert fast.t.size == ref.t.size
        for field, expected in ref.states.items():
            np.testing.assert_allclose(fast.states[field][-1], expected[-1], rtol=0, atol=1e-11)


def test_each_rkmk_family_compiles_its_own_coordinates():
    """The generic step's coordinates are a compile-time constant of its copies
    (:mod:`lieint.fast.generic_step`): each family's step takes its own coordinate map and
    dexp⁻¹ or dcay⁻¹, so a run in exponential coordinates never compiles the Cayley map; the
    energy pairs' families step through the plain form's copies."""
    from lieint.fast import generic, generic_energy, se_algebra

    def stage_code(namespace):
        form_step = namespace["step"].py_func.__globals__
        step = form_step["form_lie_step"].py_func.__globals__ if "form_lie_step" in form_step else form_step
        return step["lie_step"].py_func.__globals__

    expected = {
        "rkmk": (False, se_algebra.exp_map_n),
        "rkmk_uncounted": (False, se_algebra.exp_map_3),
        "rkmk_cayley": (True, se_algebra.cayley_map),
    }
    for family, (cayley, coordinate_map) in expected.items():
        for namespaces, name in (
            (generic.NAMESPACES, family),
            (generic_energy.NAMESPACES, family.replace("rkmk", "rkmk_energy")),
        ):
            scope = stage_code(namespaces[name])
            assert scope["CAYLEY"] is cayley, name
            assert scope["coordinate_map"] is coordinate_map, name
