"""The evaluations a compiled run reports (``sol.nfev``) are the numpy path's, for every
fixed-step method of the registry the engine runs on the 3D top, the 4D top and the heavy top.

The numpy path counts what its steps do (stages, a map's Newton or fixed-point iterations): the
truth here, since it shares nothing with the compiled loop's bookkeeping."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import lieint
from lieint.methods.registry import get_method, method_specs

#: the maps whose compiled solve stops Newton earlier than the numpy path (see
#: tests/fast/test_compiled_moser_veselov.py): on the 3D top, the Moser–Veselov family
EARLIER_NEWTON = {("3D top", name) for name in method_specs() if name.startswith("moser_veselov")}


def _systems():
    top3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    top4 = lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]))
    M = np.random.default_rng(1).normal(size=(4, 4))
    heavy = lieint.HeavyTop(np.diag([0.7, 1.0, 1.4]), 1.0, [0.1, 0.05, 0.3], [0.0, 0.0, -9.81])
    W = np.array([[0.0, -0.3, 1.0], [0.3, 0.0, -0.5], [-1.0, 0.5, 0.0]])
    return {
        "3D top": (top3, top3.initial_state(angular_velocity=[0.3, 1.0, 0.4])),
        "4D top": (top4, top4.initial_state(Omega=0.3 * (M - M.T))),
        "heavy top": (heavy, heavy.initial_state(Omega=W)),
    }


def _fixed_step_methods():
    return [name for name in method_specs() if not (m := get_method(name)).adaptive and not m.self_controlled]


@pytest.mark.parametrize("label", ["3D top", "4D top", "heavy top"])
def test_every_compiled_fixed_step_method_reports_the_numpy_paths_evaluations(label):
    system, y0 = _systems()[label]
    compared = 0
    for name in _fixed_step_methods():
        try:
            get_method(name).check_system(system)
        except ValueError:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fast = lieint.integrate(system, y0, (0.0, 0.2), h=0.01, method=name)
            if fast.stats.backend != "numba":
                continue
            numpy = lieint.integrate(system, y0, (0.0, 0.2), h=0.01, method=name, backend="numpy")
        compared += 1
        if (label, name) in EARLIER_NEWTON:
            assert 20 <= fast.nfev < numpy.nfev, (name, fast.nfev, numpy.nfev)
        else:
            assert fast.nfev == numpy.nfev, (name, fast.nfev, numpy.nfev)
    assert compared >= 12, compared
