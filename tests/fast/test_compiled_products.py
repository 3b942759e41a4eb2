"""The commutator-free and Crouch–Grossman methods on the compiled engine (family "cf",
:class:`lieint.fast.forms.ExpProductForm`): the numpy path's steps to round-off on each system
form, their dense output and events, the invariants of the action, and a subclass that changes
the step left on the numpy path. Lean: the full registry-driven comparisons are in
tests/fast/test_top3.py, test_topn.py and test_pieces.py (slow tier)."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import initial, variants

import lieint
from lieint.fast.forms import ExpProductForm
from lieint.methods.commutator_free import CF4, CommutatorFree

#: one system per system form: the 3D top, the n-D top, compiled pieces on se(3)
SYSTEMS = {
    "3D top": lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0]),
    "4D top": lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5])),
    "heavy top": variants(3)["heavy_top"],
}


def _relative(fast: dict, ref: dict) -> float:
    return max(float(np.max(np.abs(fast[k] - ref[k]))) / max(1.0, float(np.max(np.abs(ref[k])))) for k in ref)


@pytest.mark.parametrize("label", sorted(SYSTEMS))
def test_compiled_steps_dense_output_and_events_are_the_numpy_paths(label):
    system = SYSTEMS[label]
    y0 = initial(system, np.random.default_rng(5))
    path = lieint.integrate(system, y0, (0.0, 1.0), h=0.02, method="cf4", backend="numpy").states["A"][:, 0, 1]
    level = 0.5 * (path.min() + path.max())  # a level the motion crosses

    def crossing(t, y):
        return y["A"][..., 0, 1] - level

    midway = np.linspace(0.03, 0.97, 5)
    for method in ("cf3", "cg4a"):
        kw = dict(h=0.02, method=method, events=crossing, dense_output=True, t_eval=np.linspace(0.0, 1.0, 7))
        fast = lieint.integrate(system, y0, (0.0, 1.0), **kw)
        ref = lieint.integrate(system, y0, (0.0, 1.0), backend="numpy", **kw)
        where = (label, method, fast.stats.backend_reason)
        assert fast.stats.backend == "numba" and "product of exponentials" in fast.stats.backend_reason, where
        assert fast.nsteps == ref.nsteps and np.array_equal(fast.t, ref.t), where
        assert _relative(fast.states, ref.states) < 1e-13, where
        assert _relative(fast.sol(midway), ref.sol(midway)) < 1e-13, where
        assert len(fast.t_events[0]) == len(ref.t_events[0]) > 0, where
        np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-12, err_msg=str(where))


def test_a_compiled_batch_keeps_the_invariants_of_the_action():
    """The 3D top's spectrum of A and RᵀR = I over 400 cf4 steps of two bodies (threads): the
    step moves the state by group elements, so both are kept to round-off."""
    top = SYSTEMS["3D top"]
    y0 = top.initial_state(angular_velocity=[[0.3, 1.0, 0.4], [1.0, 0.1, -0.5]])
    sol = lieint.integrate(top, y0, (0.0, 4.0), h=0.01, method="cg4a", project=False)
    assert sol.stats.backend == "numba" and sol.states["A"].shape == (401, 2, 3, 3)
    casimir = np.sum(sol.states["A"] ** 2, axis=(-2, -1))
    assert np.max(np.abs(casimir / casimir[0] - 1.0)) < 1e-13
    R = sol.states["R"]
    assert np.max(np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3))) < 1e-13


def test_the_declared_form_is_the_methods_weights_and_a_changed_step_stays_on_the_numpy_path():
    form = CF4.compiled()
    assert isinstance(form, ExpProductForm) and form.stages == 4 and form.outputs == 2
    assert form.bounds.tolist() == [0, 0, 1, 2, 4, 6]  # stages 1, 2 one exponential, stage 3 two; the step two
    np.testing.assert_array_equal(form.weights[-2:], np.array(CF4.output))

    class Other(CommutatorFree):
        def step(self, system, t, y, h, state=None):  # integrates something else
            return super().step(system, t, y, 0.5 * h, state)

    other = Other("other", 4, CF4.c, CF4.stages, CF4.output)
    assert other.compiled() is None
    top = SYSTEMS["3D top"]
    sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4]), (0.0, 0.1), h=0.01, method=other)
    assert sol.stats.backend == "numpy" and "'other' has no compiled form" in sol.stats.backend_reason
