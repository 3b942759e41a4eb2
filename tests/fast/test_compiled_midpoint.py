"""The implicit Lie–Poisson midpoint on the compiled engine (lieint.fast.midpoint): the numpy
path's rule and iteration through the systems' compiled pieces.

Truths that do not depend on the compiled code: the numpy path (lieint.methods.midpoint), and the
quadratic first integrals the rule keeps to its solver's tolerance (the energy of the free top,
tr A², |Γ|, ⟨Π, Γ⟩, RᵀR = I: Cooper 1987), which the compiled steps must keep as well.
"""

from __future__ import annotations

import numpy as np
import pytest
from bodies import applies, coverage_systems, initial, initial_batch, variants

import lieint

METHOD = lieint.get_method("lie_midpoint")
#: every built-in system the midpoint applies to, and the 5D top (the n-D top's pieces)
SYSTEMS = {label: s for label, s in coverage_systems().items() if applies(METHOD, s)}
SYSTEMS["euler_top n=5"] = lieint.EulerTop(np.diag([0.5, 0.8, 1.1, 1.4, 1.9]))


def test_the_midpoint_applies_to_both_tops_in_several_dimensions():
    assert {"euler_top n=3", "euler_top n=4", "euler_top n=5", "heavy_top n=3", "heavy_top n=4"} <= set(SYSTEMS)


@pytest.mark.parametrize("label", sorted(SYSTEMS))
@pytest.mark.parametrize("project", [False, True])
def test_the_compiled_midpoint_is_the_numpy_paths(label, project):
    """Over 200 steps of h = 0.02 (a non-diagonal heavy top too): the same states to 1e-13 of
    their scale (measured ≤ 1.5e-15 over 40 steps), the same steps."""
    system = SYSTEMS[label]
    y0 = initial(system, np.random.default_rng(3))
    kw = dict(t_span=(0.0, 4.0), h=0.02, method="lie_midpoint", project=project, save_every=20)
    fast = lieint.integrate(system, y0, **kw)
    ref = lieint.integrate(system, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba" and "implicit midpoint" in fast.stats.backend_reason
    np.testing.assert_array_equal(fast.t, ref.t)
    for name, values in ref.states.items():
        scale = max(1.0, float(np.abs(values).max()))
        np.testing.assert_allclose(fast.states[name], values, rtol=0, atol=1e-13 * scale, err_msg=name)


@pytest.mark.parametrize("label", ["euler_top n=3", "euler_top n=4", "heavy_top n=3"])
def test_the_compiled_midpoint_keeps_the_quadratic_invariants(label):
    """2,000 unprojected steps: the energy (the free tops'; the heavy top's T − M⟨Γ, X_G⟩ is
    quadratic too), the Casimirs, |Γ| and RᵀR = I kept to the solver's tolerance, as on the
    numpy path (the rule is not a Lie-group method: the space momentum is kept only to O(h²))."""
    system = SYSTEMS[label]
    y0 = initial(system, np.random.default_rng(5))
    sol = lieint.integrate(system, y0, (0.0, 40.0), h=0.02, method="lie_midpoint", project=False, save_every=500)
    assert sol.stats.backend == "numba"
    kept = ["energy", "casimirs"] + (["gamma_norm"] if "heavy" in label else [])
    for name in kept:
        assert np.max(sol.drift(name)) < 1e-12, name
    assert np.max(sol.invariants["orthogonality"]) < 1e-12


def test_a_batch_is_each_body_alone():
    """Each body iterates to its own tolerance: a batch of 5 heavy tops (threads over bodies) gives
    each body's own run bit for bit."""
    system = variants(3)["heavy_top"]
    y0 = initial_batch(system, np.random.default_rng(11), 5)
    kw = dict(t_span=(0.0, 1.0), h=0.02, method="lie_midpoint", save_every=10)
    batch = lieint.integrate(system, y0, **kw)
    for m in range(5):
        alone = lieint.integrate(system, {k: v[m] for k, v in y0.items()}, **kw)
        for name in system.fields:
            assert np.array_equal(batch.states[name][:, m], alone.states[name]), (m, name)


def test_dense_output_events_and_t_eval_are_the_numpy_paths():
    """The midpoint has no increment in the algebra: the compiled run keeps its states and the
    observer interpolates them as the numpy path does (the rows at ``t_eval``, the interpolant
    between the steps and an event's time)."""
    system = SYSTEMS["heavy_top n=3"]
    y0 = initial(system, np.random.default_rng(2))

    def crossing(t, y):
        return y["A"][..., 0, 1]

    kw = dict(t_span=(0.0, 3.0), h=0.01, method="lie_midpoint", dense_output=True,
              t_eval=np.linspace(0.0, 3.0, 11), events=crossing)  # fmt: skip
    fast = lieint.integrate(system, y0, **kw)
    ref = lieint.integrate(system, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba"
    for name, values in ref.states.items():
        np.testing.assert_allclose(fast.states[name], values, rtol=0, atol=1e-13 * max(1, np.abs(values).max()))
    between = np.linspace(0.013, 2.987, 7)
    for name, values in ref.sol(between).items():
        np.testing.assert_allclose(fast.sol(between)[name], values, rtol=0, atol=1e-12 * max(1, np.abs(values).max()))
    assert len(ref.t_events[0]) > 0
    np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-12)


def test_a_step_whose_iteration_diverges_raises_the_numpy_paths_error():
    """h‖Ω‖/2 well above 1: the fixed-point iteration diverges on both paths, and both name the step."""
    system = SYSTEMS["euler_top n=3"]
    y0 = system.initial_state(angular_velocity=[3.0, 40.0, 2.0])
    for backend in ("numba", "numpy"):
        with pytest.raises(RuntimeError, match="did not converge"):
            lieint.integrate(system, y0, (0.0, 1.0), h=0.5, method="lie_midpoint", backend=backend)
