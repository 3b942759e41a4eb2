"""The layouts' context tuples as passed to the compiled loops (:func:`lieint.fast.engine.typed_context`).

Truths: numba's own ``typeof`` of the plain tuple, and the runs' results with the plain tuple."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import lieint
from lieint.fast import engine
from lieint.fast.dispatch import TypedContext, typed_context
from lieint.groups import hat
from lieint.methods.registry import get_method


def _heavy_top():
    top = lieint.HeavyTop(np.diag([0.7, 1.0, 1.4]), 1.0, [0.1, 0.05, 0.3], [0.0, 0.0, -9.81])
    return top, top.initial_state(Omega=hat(np.array([0.5, 1.0, -0.3])))


def _pieces_context():
    top, y0 = _heavy_top()
    eng, reason = engine.engine_for(top, get_method("rkmk853+energy"), y0, adaptive=True)
    assert eng is not None, reason
    return eng.layout.context()


def test_a_context_with_a_bundle_is_typed_as_numba_types_the_tuple():
    ctx = _pieces_context()
    typed = typed_context(ctx)
    assert isinstance(typed, TypedContext) and tuple(typed) == tuple(ctx)
    assert numba.typeof(typed) == numba.typeof(tuple(ctx))


def test_the_type_is_worked_out_once_per_kind_of_context():
    first, second = typed_context(_pieces_context()), typed_context(_pieces_context())
    assert type(first) is type(second)
    ctx = _pieces_context()
    changed = (ctx[0], np.asfortranarray(np.ones((2, 2), dtype=np.int64)), *ctx[2:])  # another array layout
    other = typed_context(changed)
    assert type(other) is not type(first)
    assert numba.typeof(other) == numba.typeof(tuple(changed))


@pytest.mark.parametrize("ctx", [0, (np.zeros(3), np.zeros((2, 2)))])
def test_contexts_numba_types_in_c_pass_unchanged(ctx):
    assert typed_context(ctx) is ctx


@pytest.mark.parametrize("method", ["rkmk853+energy", "rkmk45", "rk4"])
def test_runs_with_typed_contexts_are_the_runs_with_plain_tuples_bit_for_bit(monkeypatch, method):
    top, y0 = _heavy_top()
    options = {"h": 0.05} if method == "rk4" else {"rtol": 1e-8, "atol": 1e-10}
    typed = lieint.integrate(top, y0, (0.0, 2.0), method=method, **options)
    assert typed.stats.backend == "numba", typed.stats.backend_reason
    monkeypatch.setattr(engine, "typed_context", lambda ctx: ctx)
    plain = lieint.integrate(top, y0, (0.0, 2.0), method=method, **options)
    for name in typed.states:
        np.testing.assert_array_equal(typed.states[name], plain.states[name])
    np.testing.assert_array_equal(typed.t, plain.t)
