"""The stepper contract, driven by the registries: every method × every built-in system × every
front end (integrate, scenes through ``lieint run``, streamed runs with a resume).

Nothing here lists methods or systems by hand: a method added to the registry or a system added
to the catalog is covered (and must come with a case below, or the coverage test fails).
"""

from __future__ import annotations

import functools
import re
import textwrap

import h5py
import numpy as np
import pytest
from conftest import fitted_slope

import lieint
import lieint.cli
from lieint.catalog import _builtin, make_system
from lieint.methods.registry import method_specs

SPECS = method_specs()
METHODS = list(SPECS)

# -- built-in systems: one representative body per catalog entry ---------------------------------

B3 = [[0.5, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]]
#: a ball's body fits inside it: tr B ≤ M r²
B_BALL = [[0.1, 0.0, 0.0], [0.0, 0.15, 0.0], [0.0, 0.0, 0.2]]
#: catalog name → (TOML parameters, TOML initial values); also used to write scenes
SYSTEM_CASES = {
    "euler_top": ({"B": B3}, {"angular_velocity": [0.3, 1.0, 0.4]}),
    "heavy_top": (
        {"mass_tensor": B3, "mass": 1.0, "center_of_mass": [0.0, 0.1, 0.3], "gravity": [0.0, 0.0, -9.81]},
        {"angular_velocity": [0.3, 1.0, 0.4]},
    ),
    "free_body": (
        {"mass_tensor": B3, "mass": 2.0, "gravity": [0.0, 0.0, -9.81]},
        {"angular_velocity": [0.3, 1.0, 0.4], "velocity": [1.0, 0.0, 2.0]},
    ),
    "rolling_ball": (
        {
            "mass_tensor": B_BALL,
            "mass": 1.0,
            "radius": 1.0,
            "center_of_mass": [0.0, 0.1, -0.2],
            "gravity": [0.0, 0.0, -9.81],
        },
        {"angular_velocity": [0.3, 1.0, 0.4]},
    ),
    "chaplygin_ball": ({"mass_tensor": B_BALL, "mass": 1.0, "radius": 1.0}, {"angular_velocity": [0.3, 1.0, 0.4]}),
    "central_force_particle": (
        {"mass": 1.0, "centre": [0.0, 0.0, 0.1], "potential": "kepler", "strength": 1.0},
        {"position": [1.0, 0.0, 0.1], "velocity": [0.0, 1.1, 0.2]},
    ),
    "constant_force_particle": (
        {"mass": 2.0, "force": [0.0, 0.5, -9.81]},
        {"position": [0.0, 0.0, 1.0], "velocity": [1.0, 0.0, 2.0]},
    ),
    # the egg ρ² + z² + 0.3 z³ = 1 under gravity along its axis; (1, 0, 0) lies on it
    "surface_particle": (
        {
            "mass": 1.0,
            "surface": "revolution",
            "profile": [0.0, 0.0, 1.0, 0.3],
            "axis": [0.0, 0.0, 1.0],
            "force": [0.0, 0.0, -1.0],
        },
        {"position": [1.0, 0.0, 0.0], "velocity": [0.0, 0.8, 0.3]},
    ),
    "atoms_body": (
        {
            "masses": [1.0, 2.0, 1.5, 1.0, 0.7],
            "positions": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -1.0, -1.0], [0.5, -0.3, 0.2]],
        },
        {"angular_velocity": [0.3, 1.0, 0.4], "velocity": [0.2, 0.0, -0.1]},
    ),
    "motor_rigid_body": (
        {
            "mass_tensor": B3,
            "mass": 2.0,
            "gravity": [0.0, 0.0, -9.81],
            "springs": [[0.5, 0.0, 0.0, 0.5, 0.0, 1.0, 8.0, 0.2], [-0.5, 0.0, 0.0, -0.5, 0.0, 1.0, 8.0, 0.2]],
        },
        {"angular_velocity": [0.3, 1.0, 0.4], "velocity": [0.2, 0.0, 0.1]},
    ),
}

# attitude from sampled body rates (data only): w(t) = (0.3 cos t, 1 − 0.2 t, 0.4 sin 2t) at
# 41 times on [0, 4] (the spans below stay inside), from a turn of 0.3 about the z axis
_RATE_TIMES = np.linspace(0.0, 4.0, 41)
SYSTEM_CASES["prescribed_rotation"] = (
    {
        "times": _RATE_TIMES.tolist(),
        "rates": [[0.3 * np.cos(t), 1.0 - 0.2 * t, 0.4 * np.sin(2.0 * t)] for t in _RATE_TIMES],
    },
    {"R": [[np.cos(0.3), -np.sin(0.3), 0.0], [np.sin(0.3), np.cos(0.3), 0.0], [0.0, 0.0, 1.0]]},
)


def test_every_builtin_system_has_a_case():
    assert set(SYSTEM_CASES) == set(_builtin()), "add a case for each built-in system"


def system_of(name):
    """The system of a case alone (cheap: no initial state, which may compile a kernel)."""
    parameters, _ = SYSTEM_CASES[name]
    return make_system(name, {k: np.asarray(v) if isinstance(v, list) else v for k, v in parameters.items()})


def build(name):
    system = system_of(name)
    return system, system.initial_state(**{k: np.asarray(v) for k, v in SYSTEM_CASES[name][1].items()})


def applies(method, system) -> bool:
    try:
        method.check_system(system)
    except ValueError:
        return False
    return True


# -- orders: each method finds a problem with a known solution it applies to ----------------------


def exact_top_problem(T=5.0):
    """The 3D Euler top against its Jacobi-elliptic solution."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    return top, y0, T, lambda y: y["A"], top.exact_solution([T], y0)["A"][-1]


def harmonic_particle_problem():
    """A particle in the field V = ½ k r² against its exact ellipse."""
    k, m, T = 2.0, 0.5, 5.0
    osc = lieint.CentralForceParticle(m, [0.0, 0.0, 0.0], "harmonic", strength=k)
    q0, v0 = np.array([1.0, 0.2, 0.0]), np.array([0.0, 0.7, 0.3])
    w = np.sqrt(k / m)
    exact = q0 * np.cos(w * T) + v0 / w * np.sin(w * T)
    return osc, osc.initial_state(position=q0, velocity=v0), T, lambda y: y["q"], exact


def great_circle_problem():
    """A free particle on a sphere against its exact great circle."""
    r, speed, T = 1.7, 1.3, 4.0
    p = lieint.SurfaceParticle(1.0, lieint.systems.Sphere(3, r))
    u, w = np.array([1.0, 2.0, 2.0]) / 3.0, np.array([2.0, -2.0, 1.0]) / 3.0
    exact = r * (np.cos(speed / r * T) * u + np.sin(speed / r * T) * w)
    return p, p.initial_state(position=r * u, velocity=speed * w), T, lambda y: y["q"], exact


def prescribed_rotation_problem():
    """Ṙ = RΩ(t) (a generator of t only) with R(t) = exp(a(t)Â) exp(b(t)B̂) in closed form."""
    from scipy.linalg import expm

    from lieint.groups.bivectors import hat

    A, B = hat(np.array([0.3, -0.5, 0.8])), hat(np.array([0.6, 0.2, -0.4]))

    def omega(t):
        E = expm(0.5 * t * t * B)
        return E.T @ ((0.7 * np.cos(t) + 0.3) * A) @ E + t * B

    system, T = lieint.PrescribedRotation(omega), 3.0
    exact = expm((0.7 * np.sin(T) + 0.3 * T) * A) @ expm(0.5 * T * T * B)
    return system, system.initial_state(), T, lambda y: y["R"], exact


#: problems with an exact solution; a method takes the first one it applies to
ORDER_PROBLEMS = [exact_top_problem, harmonic_particle_problem, great_circle_problem, prescribed_rotation_problem]


def fixed_steps(method, system, y0, T, n):
    """n steps of size T/n through the contract itself: init once, then step."""
    h = T / n
    t, y = 0.0, y0
    state = method.init(system, t, y, h)
    for _ in range(n):
        result = method.step(system, t, y, h, state)
        y, state, t = result.y, result.state, t + h
    return y


@pytest.mark.parametrize("name", METHODS)
@pytest.mark.slow
def test_every_method_reaches_its_order(name):
    spec, method = SPECS[name], lieint.get_method(name)
    for problem in ORDER_PROBLEMS:
        system, y0, T, field, exact = problem()
        if applies(method, system):
            break
    else:
        pytest.fail(f"no order problem applies to {name!r}; add one to ORDER_PROBLEMS")
    if method.self_controlled:
        # scipy's solvers choose their own steps: they must converge as the tolerance shrinks
        tols = [1e-5, 1e-7, 1e-9, 1e-11]
        errs = [
            np.linalg.norm(
                field(lieint.integrate(system, y0, (0, T), method=name, rtol=tol, atol=tol, t_eval=[0, T]).states)[-1]
                - exact
            )
            for tol in tols
        ]
        assert errs[-1] < 1e-7 and errs[-1] < errs[0] / 100, errs
        return
    if spec.family == "exact":
        # an exact flow has no order: its error is round-off at any step
        errs = [np.linalg.norm(field(fixed_steps(method, system, y0, T, n)) - exact) for n in (1, 3, 10)]
        assert max(errs) < 1e-12, errs
        return
    p = spec.order
    n0 = {1: 400, 2: 100, 3: 50}.get(p, 25 if p <= 5 else 10)
    ns = [n0, 2 * n0, 4 * n0, 8 * n0]
    if p >= 8:
        ns = [6, 8, 11, 16]
    if spec.family == "rkmk-energy":
        # over T = 20: with the energy kept only the error along the orbit is left, and at T = 5
        # the 8th-order pair's endpoint error happens to cancel in part (slope 7.5 there, fitted
        # 8.1 at T = 20); steps such that the errors stay above the ~1e-12 round-off floor
        system, y0, T, field, exact = exact_top_problem(20.0)
        ns = [round({3: 200, 5: 50}.get(p, 24) * 2 ** (k / 2)) for k in range(4)]
    errs = [np.linalg.norm(field(fixed_steps(method, system, y0, T, n)) - exact) for n in ns]
    slope = fitted_slope([T / n for n in ns], errs)
    # a projection onto the energy level keeps the base order and may raise it (on the 3D top
    # only the error along the orbit accumulates: tests/methods/test_energy_projection.py)
    at_least = p >= 6 or spec.family == "rkmk-energy"
    assert abs(slope - p) <= 0.3 or (at_least and slope >= p - 0.3), (slope, errs)


# -- every method × every built-in system through integrate --------------------------------------


@pytest.mark.parametrize("system_name", list(SYSTEM_CASES))
@pytest.mark.parametrize("name", METHODS)
@pytest.mark.slow
def test_every_method_integrates_every_builtin_system(name, system_name):
    system, y0 = build(system_name)
    method = lieint.get_method(name)
    if not applies(method, system):
        with pytest.raises(ValueError, match="method"):
            lieint.integrate(system, y0, (0.0, 0.5), h=0.05, method=name)
        return
    sol = lieint.integrate(system, y0, (0.0, 0.5), h=0.05, method=name, rtol=1e-9, atol=1e-9, project=True)
    assert sol.success and sol.stats.method == name
    assert sol.stats.nsteps > 0 and sol.stats.nfev >= sol.stats.nsteps
    assert sol.t[0] == 0.0 and sol.t[-1] == pytest.approx(0.5, abs=1e-12)
    for field, values in sol.states.items():
        assert np.all(np.isfinite(values)), field
    # the result is the same run a tight reference gives (each method within its own accuracy)
    ref = lieint.integrate(system, y0, (0.0, 0.5), method="scipy:DOP853", rtol=1e-12, atol=1e-12, t_eval=[0.0, 0.5])
    close = 0.05 if (SPECS[name].order or 8) >= 2 else 0.5  # Lie–Euler: O(h) = O(0.05 · |ẍ|)
    for field in sol.states:
        assert np.allclose(sol.states[field][-1], ref.states[field][-1], atol=close), field
    for inv_name, inv in system.invariants.items():
        drift = float(np.max(sol.drift(inv_name)))
        if inv.kind == "defect":
            assert drift <= 1e-10, (inv_name, drift)  # projection keeps the constraint
        elif SPECS[name].order and SPECS[name].order >= 3:
            assert drift <= 1e-3, (inv_name, drift)


# -- every method through the scene front ends ----------------------------------------------------


def toml_value(v):
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return f'"{v}"'
    return repr(float(v))


def scene_text(system_name, method, *, t_end=0.6, step=0.02, coordinates=None, quantities=None, save_every=1):
    parameters, initial = SYSTEM_CASES[system_name]
    params = ", ".join(f"{k} = {toml_value(v)}" for k, v in parameters.items())
    init = "\n".join(f"{k} = {toml_value(v)}" for k, v in initial.items())
    system, _ = build(system_name)
    quantities = quantities or sorted(system.invariants)
    coords = f'coordinates = "{coordinates}"\n' if coordinates else ""
    tols = "rtol = 1e-8\natol = 1e-8\n" if SPECS[method].adaptive else ""
    return (
        textwrap.dedent(
            f"""\
        [scene]
        name = "{system_name} with {method}"

        [body]
        system = "{system_name}"
        parameters = {{ {params} }}

        [initial]
        """
        )
        + init
        + textwrap.dedent(
            f"""

        [integrator]
        method = "{method}"
        step = {step}
        t_end = {t_end}
        project = true
        save_every = {save_every}
        """
        )
        + tols
        + coords
        + textwrap.dedent(
            f"""
        [output]
        quantities = {toml_value(list(quantities))}
        """
        )
    )


def write_scene(tmp_path, system_name, method, **kw):
    path = tmp_path / f"{system_name}-{method.replace(':', '_')}.toml"
    path.write_text(scene_text(system_name, method, **kw))
    return path


def read_run(path):
    with h5py.File(path, "r") as f:
        data = {"t": f["t"][()]}
        for group in ("states", "invariants", "outputs"):
            if group in f:
                data.update({f"{group}/{k}": v[()] for k, v in f[group].items()})
        return data, dict(f.attrs)


def first_applicable_system(name) -> str | None:
    """The first built-in system case the method applies to (None: none of them)."""
    method = lieint.get_method(name)
    for system_name in SYSTEM_CASES:
        if applies(method, build(system_name)[0]):
            return system_name
    return None


@pytest.mark.parametrize("name", METHODS)
@pytest.mark.slow
def test_every_method_runs_a_scene_streamed_and_resumed(name, tmp_path, capsys):
    # long enough for an adaptive method to take several steps before the stop
    system_name = first_applicable_system(name)
    assert system_name is not None, f"no built-in system case that {name!r} applies to: add one to SYSTEM_CASES"
    scene = write_scene(tmp_path, system_name, name, t_end=3.0 if SPECS[name].adaptive else 0.6)
    assert lieint.cli.main(["run", str(scene)]) == 0
    assert f"with {name}" in capsys.readouterr().out
    whole, interrupted = tmp_path / "whole.h5", tmp_path / "parts.h5"
    assert lieint.cli.main(["run", str(scene), "--out", str(whole), "--quiet"]) == 0
    report = lieint.run(scene, interrupted, progress=False, stop_after=2, checkpoint_every=1)
    assert report.status == "interrupted", report.message
    assert lieint.cli.main(["run", str(scene), "--out", str(interrupted), "--resume", "--quiet"]) == 0
    a, attrs_a = read_run(whole)
    b, attrs_b = read_run(interrupted)
    assert attrs_a["status"] == attrs_b["status"] == "complete"
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)  # a resumed run is the same run
    assert int(attrs_a["steps_done"]) > 0 and int(attrs_a["nfev"]) >= int(attrs_a["steps_done"])


@pytest.mark.parametrize("system_name", list(SYSTEM_CASES))
@pytest.mark.slow
def test_every_builtin_system_runs_from_a_scene_and_plots(system_name, tmp_path):
    scene = write_scene(tmp_path, system_name, "rkmk4")
    out = tmp_path / "run.h5"
    assert lieint.cli.main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    assert lieint.cli.main(["plot", str(out), "--out", str(tmp_path / "run.png")]) == 0
    assert (tmp_path / "run.png").stat().st_size > 0


# -- coordinates: honoured where they apply, refused where they do not ---------------------------


@pytest.mark.parametrize("name", METHODS)
def test_coordinates_are_honoured_or_refused(name, tmp_path):
    system, y0 = build("euler_top")
    spec = SPECS[name]
    if "cayley" in spec.coordinates:
        exp = lieint.integrate(system, y0, (0, 1), h=0.1, method=name, coordinates="exp", rtol=1e-4, atol=1e-4)
        cay = lieint.integrate(system, y0, (0, 1), h=0.1, method=name, coordinates="cayley", rtol=1e-4, atol=1e-4)
        assert exp.stats.coordinates == "exp" and cay.stats.coordinates == "cayley"
        assert not np.array_equal(exp.states["A"][-1], cay.states["A"][-1])
        scene = lieint.scenes.load_scene(write_scene(tmp_path, "euler_top", name, coordinates="cayley"))
        assert lieint.scenes.run_scene(scene).solution.stats.coordinates == "cayley"
    else:
        with pytest.raises(ValueError, match=f"`coordinates` = 'cayley' does not apply to '{name}'"):
            lieint.integrate(system, y0, (0, 1), h=0.1, method=name, coordinates="cayley")
        with pytest.raises(lieint.scenes.SceneError, match="coordinates"):
            lieint.scenes.load_scene(write_scene(tmp_path, "euler_top", name, coordinates="cayley"))


# -- scipy methods take real steps ------------------------------------------------------------------


@pytest.mark.parametrize("name", [n for n, s in SPECS.items() if s.family == "scipy"])
def test_scipy_methods_report_the_steps_they_take(name, tmp_path, capsys):
    system, y0 = build("euler_top")
    sol = lieint.integrate(system, y0, (0, 3.0), method=name, rtol=1e-8, atol=1e-8)
    assert sol.stats.nsteps > 3 and sol.nsteps == sol.stats.nsteps
    assert sol.stats.nfev > sol.stats.nsteps
    scene = write_scene(tmp_path, "euler_top", name, t_end=3.0)
    in_memory = lieint.scenes.run_scene(lieint.scenes.load_scene(scene)).solution
    out = tmp_path / "s.h5"
    lieint.run(scene, out, progress=False)
    _, attrs = read_run(out)
    assert int(attrs["steps_done"]) == in_memory.stats.nsteps > 3


# -- a scene whose method does not apply to its system is refused, not a traceback -------------


@functools.cache
def first_refusing_system(name) -> str | None:
    """The first built-in system case the method does not apply to (None: it applies to all).

    Called while the tests are collected, in every test process: it builds the systems only
    (an initial state may compile a kernel) and remembers its answers."""
    method = lieint.get_method(name)
    for system_name in SYSTEM_CASES:
        if not applies(method, system_of(system_name)):
            return system_name
    return None


@pytest.mark.parametrize("name", [n for n in METHODS if first_refusing_system(n) is not None])
def test_a_method_that_does_not_apply_to_the_scene_is_refused(name, tmp_path, capsys):
    system_name = first_refusing_system(name)
    scene = write_scene(tmp_path, system_name, name)
    out = tmp_path / "refused.h5"
    for argv in (["run", str(scene)], ["run", str(scene), "--out", str(out), "--quiet"]):
        assert lieint.cli.main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("lieint run: ") and re.search(rf"`?method`? {re.escape(repr(name))}", err), err
        assert "Traceback" not in err
    assert not out.exists()  # nothing is written for a run that cannot start


@pytest.mark.parametrize("name", [n for n in METHODS if first_refusing_system(n) is not None])
def test_integrate_names_the_method_argument_when_it_does_not_apply(name):
    system, y0 = build(first_refusing_system(name))[:2]
    with pytest.raises(ValueError, match=rf"^`method` {re.escape(repr(name))}"):
        lieint.integrate(system, y0, (0.0, 0.1), h=0.01, method=name)


def _arrays(value):
    """Every numpy array reachable from a method's fields (tuples, lists, nested dataclasses)."""
    stack = [value]
    while stack:
        x = stack.pop()
        if isinstance(x, np.ndarray):
            yield x
        elif isinstance(x, (tuple, list)):
            stack.extend(x)
        elif hasattr(x, "__dataclass_fields__"):
            stack.extend(getattr(x, name) for name in x.__dataclass_fields__)


@pytest.mark.parametrize("name", METHODS)
def test_every_method_s_coefficients_are_read_only(name):
    # get_method hands out one object per name and options: a coefficient changed through one
    # use (the Crouch–Grossman weights were writable) would change every later run
    method = lieint.get_method(name)
    writable = [a for a in _arrays(method) if a.flags.writeable]
    assert not writable, f"{name}: {len(writable)} writable coefficient arrays"
