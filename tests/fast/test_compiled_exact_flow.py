"""The stepped exact flow of the free 3D top on the compiled engine (:mod:`lieint.fast.top3_exact`).

Truths that do not depend on the compiled code: a 40-digit Taylor series of the flow
(tests/taylor_reference.py), exact rational arithmetic (``fractions.Fraction``) for the
double-double operations, and the numpy path (long double and fractions) as the reference
algorithm of the short step and of Jacobi's elliptic functions.
"""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest

import lieint
from lieint.fast import double_double as dd
from lieint.fast.elliptic import jacobi_elliptic as compiled_jacobi
from lieint.fast.top3_exact import SHORT_PHASE, exact_increments, step_phases
from lieint.systems.euler_top_exact import jacobi_elliptic
from lieint.systems.euler_top_step import SHORT_PHASE as NUMPY_SHORT_PHASE
from lieint.systems.euler_top_step import euler_top_step_minus_identity

EPS = np.finfo(float).eps

#: (moments, Π): generic (Hairer–Vilmart's body), flat, unordered moments, symmetric I₁ = I₂, close
#: to the separatrix (p ≈ 4e-6), and near the attitude frame's singular direction (I₂ ≈ I₃)
CASES = [
    ((0.6, 0.8, 1.0), (1.8, 0.4, -0.9)),
    ((1.0, 2.0, 3.0), (0.3, 2.0, 1.2)),
    ((3.0, 1.0, 2.0), (0.6, -1.0, 0.8)),
    ((1.0, 1.0, 2.0), (-0.95026339, -1.49014769, 0.07217848)),
    ((1.0, 2.0, 3.0), (0.51961329, 2.0, 0.9)),
    ((1.0, 2.0, 2.0001), (0.09548303, 0.03558624, -0.50629166)),
]


def test_jacobi_elliptic_is_the_numpy_paths_algorithm_bit_for_bit():
    u = np.random.default_rng(3).uniform(-12.0, 12.0, 64)
    for p in (1.0, 0.7, 0.5, 0.3, 1e-3, 1e-9, 1e-16, 1e-300):
        for got, want in zip(compiled_jacobi(u, p), jacobi_elliptic(u, p), strict=True):
            np.testing.assert_array_equal(got, want, err_msg=f"p = {p}")
    for got, want in zip(compiled_jacobi(u, 0.0), jacobi_elliptic(u, 0.0), strict=True):  # the separatrix
        np.testing.assert_allclose(got, want, rtol=0, atol=2 * EPS)


def _exact(x):
    return Fraction(float(x[0])) + Fraction(float(x[1]))


def test_double_double_operations_are_accurate_to_2_to_the_minus_100():
    rng = np.random.default_rng(5)
    for _ in range(200):
        a = float(rng.uniform(-4, 4)), 0.0
        a = dd.two_sum(a[0], float(rng.uniform(-1, 1)) * 1e-17 * abs(a[0]))
        b = dd.two_prod(float(rng.uniform(0.1, 3)), float(rng.uniform(0.1, 3)))
        A, B = _exact(a), _exact(b)
        assert _exact(dd.two_prod(a[0], b[0])) == Fraction(a[0]) * Fraction(b[0])
        for got, want in (
            (dd.dd_add(*a, *b), A + B),
            (dd.dd_mul(*a, *b), A * B),
            (dd.dd_div(*a, *b), A / B),
        ):
            assert abs(_exact(got) - want) <= 2.0**-100 * abs(want), (a, b)
        root = dd.dd_sqrt(*b)
        assert abs(_exact(root) ** 2 - B) <= 2.0**-100 * B


def test_the_compiled_short_step_is_exact_to_its_own_round_off():
    # K = Q(h) − I against a 40-digit Taylor series of the flow, I + K orthogonal to 2ε‖K‖, and
    # close to the numpy path's step (long double there). The numpy path is within 4ε‖K‖ of the
    # series on these cases; the compiled step too except near the frame's singular direction
    # (I₂ ≈ I₃, h = −0.35): 5.6ε‖K‖ measured there — its three rotations' quaternions are
    # multiplied in doubles, where the numpy path carries long double to the end.
    from taylor_reference import taylor_flow

    for moments, Pi in CASES:
        for h in (0.1, -0.35):
            K = exact_increments(moments, np.array([Pi]), h)[0][0]
            with mpmath.workdps(40):
                _, R = taylor_flow([mpmath.mpf(v) for v in moments], [mpmath.mpf(v) for v in Pi], mpmath.mpf(h))
                K_ref = np.array((R - mpmath.eye(3)).tolist(), dtype=float)
            size = np.max(np.abs(K_ref))
            where = (moments, Pi, h)
            bound = 6 if moments[2] == 2.0001 else 4
            assert np.max(np.abs(K - K_ref)) <= bound * EPS * size, (where, np.max(np.abs(K - K_ref)) / (EPS * size))
            assert np.max(np.abs(K + K.T + K.T @ K)) <= 2 * EPS * size, where
            numpy_K = euler_top_step_minus_identity(moments, np.array(Pi), h)
            assert np.max(np.abs(K - numpy_K)) <= bound * EPS * size, where


def _taylor_K(moments, Pi, h):
    from taylor_reference import taylor_flow

    with mpmath.workdps(40):
        _, R = taylor_flow([mpmath.mpf(v) for v in moments], [mpmath.mpf(v) for v in Pi], mpmath.mpf(h))
        return np.array((R - mpmath.eye(3)).tolist(), dtype=float)


def test_the_closed_form_precession_keeps_the_step_exact_to_round_off_on_random_bodies():
    # ψ in closed form on random bodies, momenta and phases |λh| in (0.1, 1): K within 4ε‖K‖ of the
    # 40-digit series (measured ≤ 3.8ε, as with the quadrature of ψ it replaced)
    rng = np.random.default_rng(11)
    for _ in range(16):
        moments, Pi = rng.uniform(0.2, 3.0, 3), rng.normal(size=3)
        lam = step_phases(moments, Pi[None], 1.0)[0]
        h = rng.uniform(0.1, 1.0) / lam * rng.choice([-1.0, 1.0])
        K, K_ref = exact_increments(moments, Pi[None], h)[0][0], _taylor_K(moments, Pi, h)
        size = np.max(np.abs(K_ref))
        assert np.max(np.abs(K - K_ref)) <= 4 * EPS * size, (moments, Pi, h, np.max(np.abs(K - K_ref)) / (EPS * size))


def test_where_the_closed_form_precession_would_cancel_it_is_integrated():
    # I₃ the smallest moment after relabelling and Π₃ small all the step: ψ ≈ hG/I₂ is hG/I₃ less
    # a rest four times ψ, and the closed form would be 17–23ε‖K‖ off (measured with the fallback
    # switched off); the quadrature keeps it within 4ε‖K‖
    moments, Pi = np.array([0.52019207, 2.60911283, 2.62546544]), np.array([-0.02006345, -1.24874889, -0.31389947])
    lam = step_phases(moments, Pi[None], 1.0)[0]
    for phase in (0.5, -0.9):
        K, K_ref = exact_increments(moments, Pi[None], phase / lam)[0][0], _taylor_K(moments, Pi, phase / lam)
        size = np.max(np.abs(K_ref))
        assert np.max(np.abs(K - K_ref)) <= 4 * EPS * size, (phase, np.max(np.abs(K - K_ref)) / (EPS * size))


def test_the_short_phase_is_the_numpy_paths():
    assert SHORT_PHASE == NUMPY_SHORT_PHASE


def test_a_long_step_cut_into_short_ones_agrees_with_the_closed_form():
    # the compiled step's own fallback (a step whose |λh| grew past the short phase by rounding)
    from lieint.systems.euler_top_attitude import euler_top_rotation_minus_identity

    # the symmetric motion of CASES[3] passes close to the attitude frame's singular direction ±e₁,
    # where ψ̇ peaks: its substeps are cut again (to 104 at phase 12) and the chain of them is
    # 1.8e-13 from the closed form (measured), against ≤ 4e-14 on the others
    for (moments, Pi), atol in zip(CASES[:4], (1e-13, 1e-13, 1e-13, 4e-13), strict=True):
        lam = step_phases(moments, np.array([Pi]), 1.0)[0]
        for phase in (1.5, 12.0):
            K, pieces = exact_increments(moments, np.array([Pi]), phase / lam)
            closed = euler_top_rotation_minus_identity(moments, np.array(Pi) / moments, [phase / lam])[0]
            # ⌊|λh|⌋ + 1 substeps, or twice as many (again) where ψ's rules did not settle
            n = np.floor(phase / SHORT_PHASE) + 1
            assert pieces[0] in n * 2 ** np.arange(4), (moments, phase, pieces)
            np.testing.assert_allclose(K[0], closed, rtol=0, atol=atol)


def _top_and_states(rng, bodies=5):
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    w = np.array([0.3, 1.0, 0.4]) * (1 + 0.2 * rng.normal(size=(bodies, 3)))
    return top, top.initial_state(angular_velocity=w)


def test_runs_compiled_and_agrees_with_the_numpy_path(rng):
    top, y0 = _top_and_states(rng)
    compiled = lieint.integrate(top, y0, (0.0, 2.0), h=0.1, method="exact_flow")
    numpy = lieint.integrate(top, y0, (0.0, 2.0), h=0.1, method="exact_flow", backend="numpy")
    assert compiled.stats.backend == "numba", compiled.stats.backend_reason
    assert "exact flow" in compiled.stats.backend_reason
    for field in ("A", "R"):
        np.testing.assert_allclose(compiled.states[field], numpy.states[field], rtol=0, atol=2e-15)


def test_a_batch_is_each_body_alone_bit_for_bit(rng):
    top, y0 = _top_and_states(rng)
    batch = lieint.integrate(top, y0, (0.0, 1.0), h=0.1, method="exact_flow")
    for b in range(5):
        alone = lieint.integrate(top, {k: v[b] for k, v in y0.items()}, (0.0, 1.0), h=0.1, method="exact_flow")
        assert alone.stats.backend == "numba"
        for field in ("A", "R"):
            np.testing.assert_array_equal(batch.states[field][:, b], alone.states[field])


def test_a_steady_rotation_turns_about_its_axis():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.0, 0.0, 0.7])
    sol = lieint.integrate(top, y0, (0.0, 2.0), h=0.5, method="exact_flow")
    assert sol.stats.backend == "numba"
    c, s = np.cos(1.4), np.sin(1.4)
    np.testing.assert_allclose(sol.states["R"][-1], [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=4 * EPS)


def test_long_steps_take_the_numpy_paths_closed_form_and_say_so(rng):
    top, y0 = _top_and_states(rng, bodies=2)
    phases = step_phases(top.principal_moments, -lieint.groups.bivectors.vee(y0["A"]), 4.0)
    assert phases.max() > SHORT_PHASE  # the case this test is about
    sol = lieint.integrate(top, y0, (0.0, 8.0), h=4.0, method="exact_flow")
    assert sol.stats.backend == "numpy"
    assert "'exact_flow' steps with |λh| > 1" in sol.stats.backend_reason
    assert "closed form" in sol.stats.backend_reason
    numpy = lieint.integrate(top, y0, (0.0, 8.0), h=4.0, method="exact_flow", backend="numpy")
    np.testing.assert_array_equal(sol.states["R"], numpy.states["R"])
    with pytest.raises(ValueError, match="no compiled kernel covers this run: 'exact_flow' steps with"):
        lieint.integrate(top, y0, (0.0, 8.0), h=4.0, method="exact_flow", backend="numba")


def test_dense_output_from_the_compiled_steps(rng):
    top, y0 = _top_and_states(rng, bodies=1)
    y0 = {k: v[0] for k, v in y0.items()}
    t_eval = np.linspace(0.0, 2.0, 13)
    sol = lieint.integrate(top, y0, (0.0, 2.0), h=0.2, method="exact_flow", t_eval=t_eval)
    numpy = lieint.integrate(top, y0, (0.0, 2.0), h=0.2, method="exact_flow", t_eval=t_eval, backend="numpy")
    assert sol.stats.backend == "numba", sol.stats.backend_reason
    np.testing.assert_allclose(sol.states["R"], numpy.states["R"], rtol=0, atol=1e-14)
