"""Which runs the compiled engine serves, registry-driven: every registered method (in each of
its coordinate maps) × every built-in system it applies to × every front end — a plain run, an
event, dense output, ``t_eval``, a batch of two — runs compiled when the system and the method
declare compiled forms, and otherwise says why in ``sol.stats.backend_reason``, with one of the
declared reasons below (the table of docs/architecture.md).
"""

from __future__ import annotations

import numpy as np
import pytest
from bodies import applies, coverage_systems, initial, initial_batch, registered_methods, variants

import lieint
from lieint.fast.forms import MapForm, PrescribedForm
from lieint.methods.registry import get_method

#: why a run leaves the compiled engine: the only reasons there may be
DECLARED = (
    "declares no compiled form",  # the system (particles, atoms as such, GA bodies, prescribed rates)
    "has no compiled form",  # the method (not yet compiled: see the guide's table)
    "has no compiled adaptive form",
    "scipy's solve_ivp solver",
)


def _rates4(t):
    X = np.array([[0.0, np.sin(t), 0.3, 0.1], [0.0, 0.0, np.cos(t), 0.2], [0.0, 0.0, 0.0, 0.4], [0.0] * 4])
    return X - X.T


#: the prescribed rotations (generators of t alone, the Magnus methods' systems), 3D and 4D
PRESCRIBED = {
    "prescribed_rotation n=3": lieint.PrescribedRotation(lambda t: np.array([np.sin(t), 0.5, np.cos(t)])),
    "prescribed_rotation n=4": lieint.PrescribedRotation(_rates4, n=4),
}
SYSTEMS = {**coverage_systems(), **PRESCRIBED}


def _initial(system, rng, bodies: int | None = None):
    """A start of ``system`` (``bodies`` of them in a batch): a random attitude for a prescribed
    rotation, a random momentum for the bodies (tests/bodies.py)."""
    if isinstance(system, lieint.PrescribedRotation):
        Q, _ = np.linalg.qr(rng.normal(size=(*(() if bodies is None else (bodies,)), system.n, system.n)))
        Q[..., :, 0] *= np.sign(np.linalg.det(Q))[..., None]  # det +1
        return system.initial_state(R=Q)
    return initial(system, rng) if bodies is None else initial_batch(system, rng, bodies)


def _front_ends(system, y0, t1):
    def flip(t, y):
        return np.asarray(y["A"] if "A" in y else y["R"])[..., 0, 1] - 0.12345

    flip.terminal = False
    yield "plain", y0, {}
    yield "events", y0, {"events": flip}
    yield "dense output", y0, {"dense_output": True}
    yield "t_eval", y0, {"t_eval": np.linspace(0.0, t1, 5)}
    yield "batch", _initial(system, np.random.default_rng(3), 2), {}


@pytest.mark.parametrize("label", sorted(SYSTEMS))
@pytest.mark.slow
def test_every_method_and_front_end_runs_compiled_or_says_why(label):
    system = SYSTEMS[label]
    y0 = _initial(system, np.random.default_rng(2))
    h, t1 = 0.01, 0.03
    for name, coordinates in registered_methods():
        method = get_method(name, coordinates=coordinates)
        if not applies(method, system):
            continue
        form, meth = system.compiled(), method.compiled()
        # a map with stage code of its own (Moser–Veselov) declares the system forms it covers; one
        # with stage code for compiled pieces only (the midpoint) runs a top on its pieces (generic)
        pieces = getattr(form, "generic", None)
        covered = meth is not None and (
            not isinstance(meth, MapForm)
            or (form is not None and (meth.covers(form) or (pieces is not None and meth.covers(pieces))))
        )
        if isinstance(form, PrescribedForm):  # a generator of t alone: only the Magnus methods read it by step
            covered = isinstance(meth, MapForm) and meth.covers(form)
        expected = form is not None and covered and not method.self_controlled
        for front, state, keywords in _front_ends(system, y0, t1):
            kw = dict(keywords)
            if method.adaptive or method.self_controlled:
                kw.update(rtol=1e-6, atol=1e-9)
            else:
                kw["h"] = h
            sol = lieint.integrate(system, state, (0.0, t1), method=name, coordinates=coordinates, **kw)
            where = (label, name, coordinates, front, sol.stats.backend_reason)
            assert sol.success, where
            if expected:
                assert sol.stats.backend == "numba", where
            else:
                assert sol.stats.backend != "numba", where
                assert any(reason in sol.stats.backend_reason for reason in DECLARED), where


@pytest.mark.slow
def test_a_compiled_run_with_events_dense_output_and_t_eval_is_the_generic_one():
    """The engine's events, dense output and t_eval rows against the generic path's, for a
    fixed-step and an adaptive method, in exponential and Cayley coordinates, on the 3D top
    (its own form) and the heavy top (compiled pieces)."""
    heavy = variants(3)["heavy_top"]
    for system in (SYSTEMS["euler_top n=3"], heavy, SYSTEMS["euler_top n=4"]):
        y0 = initial(system, np.random.default_rng(4))
        path = lieint.integrate(system, y0, (0.0, 2.0), h=0.01, backend="numpy").states["A"][:, 0, 1]
        level = 0.5 * (path.min() + path.max())  # a level the motion crosses

        def crossing(t, y, level=level):
            return y["A"][..., 0, 1] - level

        for kw in (dict(method="rkmk4", h=0.01), dict(method="rkmk6", h=0.02), dict(method="rkmk45")):
            for coordinates in ("exp", "cayley"):
                common = dict(events=crossing, dense_output=True, t_eval=np.linspace(0.0, 2.0, 13))
                tolerances = dict(rtol=1e-9, atol=1e-12)
                run = {
                    backend: lieint.integrate(
                        system, y0, (0.0, 2.0), coordinates=coordinates, backend=backend, **tolerances, **common, **kw
                    )
                    for backend in ("numba", "numpy")
                }
                fast, ref = run["numba"], run["numpy"]
                where = (type(system).__name__, kw, coordinates)
                assert fast.stats.backend == "numba" and ref.stats.backend == "numpy", where
                assert len(fast.t_events[0]) == len(ref.t_events[0]) > 0, where
                np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-11, err_msg=str(where))
                np.testing.assert_allclose(fast.t, ref.t, rtol=0, atol=1e-15)
                for field in ref.states:
                    np.testing.assert_allclose(fast.states[field], ref.states[field], rtol=0, atol=1e-11)
                    midway = np.linspace(0.05, 1.95, 7)
                    np.testing.assert_allclose(fast.sol(midway)[field], ref.sol(midway)[field], rtol=0, atol=1e-11)
                    np.testing.assert_allclose(fast.y_events[0][field], ref.y_events[0][field], rtol=0, atol=1e-10)


def test_a_terminal_event_ends_a_compiled_run_where_the_generic_one_ends():
    """A terminal event in the middle of a long compiled run: the run stops at the event (the
    steps taken beyond it in the same stretch are not kept), as the generic path's does."""
    top = SYSTEMS["euler_top n=3"]
    y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])

    def flip(t, y):
        return y["A"][..., 0, 2]

    flip.terminal = True
    for kw in (dict(method="rkmk4", h=0.01), dict(method="rkmk853", rtol=1e-10, atol=1e-12)):
        fast = lieint.integrate(top, y0, (0.0, 1000.0), events=flip, **kw)
        ref = lieint.integrate(top, y0, (0.0, 1000.0), events=flip, backend="numpy", **kw)
        assert fast.stats.backend == "numba" and fast.status == 1 if hasattr(fast, "status") else True
        assert fast.t[-1] == fast.t_events[0][-1] and fast.t[-1] < 20.0
        assert fast.stats.nsteps == ref.stats.nsteps
        np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-11)
        np.testing.assert_allclose(fast.states["A"][-1], ref.states["A"][-1], rtol=0, atol=1e-11)
        assert fast.t.size == ref.t.size
