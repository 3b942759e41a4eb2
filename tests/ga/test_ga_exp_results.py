"""lieint.ga.exp against mpmath, converters on coefficient arrays, results as multivectors."""

import subprocess
import sys

import clifford
import mpmath
import numpy as np
import pytest
import scipy.linalg
from conftest import random_rotation, random_skew

import lieint
import lieint.scenes
from lieint import ga
from lieint.ga.exponential import rotor_exp_of_skew, simple_planes


def _non_simple(rng, n, scale=1.0):
    """A random skew matrix: with n ≥ 4 its bivector is non-simple (all angles distinct)."""
    X = random_skew(rng, n, scale=scale)
    theta = simple_planes(X)[0]
    assert np.all(theta > 1e-3) or n < 4
    return X


def _mp_rotor_exp(B: np.ndarray, alg) -> np.ndarray:
    """e^B by its Taylor series in 50-digit arithmetic, products from clifford's own table."""
    mpmath.mp.dps = 50
    J, S = alg._J, alg._S
    Bm = np.array([mpmath.mpf(float(c)) for c in B], dtype=object)
    term = np.array([mpmath.mpf(1)] + [mpmath.mpf(0)] * (alg.size - 1), dtype=object)
    out = term.copy()
    for k in range(1, 80):
        term = (term[:, None] * (Bm[J] * S)).sum(axis=0) / k
        out = out + term
    return np.array([float(c) for c in out])


@pytest.mark.parametrize("n", [4, 5, 6])
@pytest.mark.slow
def test_exp_matches_a_50_digit_series(rng, n):
    """The rotor coefficients themselves, against an independent high-precision series."""
    alg = ga.algebra(n)
    for _ in range(2):
        X = _non_simple(rng, n, scale=2.0)
        B = 0.5 * alg.bivector(X)
        ref = _mp_rotor_exp(B, alg)
        ours = ga.exp(B, n=n)
        assert np.max(np.abs(ours - ref)) < 2e-15


@pytest.mark.parametrize("n", [4, 5, 6, 7, 8])
def test_exp_rotation_matches_mpmath_expm_and_scipy(rng, n):
    """R of e^{ω/2} against mpmath's expm (50 digits), and against scipy's expm."""
    mpmath.mp.dps = 50
    X = _non_simple(rng, n, scale=1.5)
    Q = ga.rotor_to_matrix(ga.exp(ga.skew_to_bivector(X) / 2))
    ref = np.array(mpmath.expm(mpmath.matrix(X.tolist())).tolist(), dtype=float)
    assert np.linalg.norm(Q - ref) / np.linalg.norm(ref) < 4e-15
    # scipy's expm (scaling and squaring) is off by up to ~2e-14 on such matrices
    # (benchmarks/ga_figures.py prints both): the two agree to within expm's own error
    E = scipy.linalg.expm(X)
    assert np.linalg.norm(Q - E) / np.linalg.norm(E) < 4e-15 + 2 * np.linalg.norm(E - ref) / np.linalg.norm(ref)


def test_exp_handles_repeated_angles_and_small_bivectors():
    for n in (4, 6):
        X = np.zeros((n, n))
        for k in range(n // 2):
            X[2 * k, 2 * k + 1] = 1.1  # isoclinic: the planes are not unique, the rotor is
        X = X - X.T
        R = rotor_exp_of_skew(X, 0.5)
        np.testing.assert_allclose(ga.rotor_to_matrix(R, n=n), scipy.linalg.expm(X), atol=1e-15)
        tiny = 1e-12 * X
        np.testing.assert_allclose(ga.rotor_to_matrix(rotor_exp_of_skew(tiny, 0.5), n=n), np.eye(n) + tiny, atol=1e-24)


def test_clifford_exp_is_inaccurate_on_non_simple_bivectors(rng):
    """Why lieint.ga.exp exists: clifford's series errs visibly on a non-simple bivector."""
    n = 7
    X = _non_simple(rng, n, scale=2.0)
    B = ga.skew_to_bivector(X) / 2
    ref = ga.to_values(ga.exp(B))  # itself checked against a 50-digit series above
    assert np.max(np.abs(B.exp().value - ref)) > 1e-10
    assert isinstance(ga.exp(B), clifford.MultiVector)


def test_exp_rejects_other_grades():
    _, blades = clifford.Cl(4)
    with pytest.raises(ValueError, match="bivector"):
        ga.exp(blades["e1"] + blades["e12"])


# -- converters -----------------------------------------------------------------------------


def test_converters_read_coefficient_arrays_with_n(rng):
    """The arrays a rotor system returns convert back with n (the AttributeError is gone)."""
    top = ga.RotorEulerTop(np.diag([1.0, 2.0, 3.0]))
    sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.3, 1, 0.2]), (0, 0.5), h=0.05)
    rotors = sol.states["rotor"]
    Q = ga.rotor_to_matrix(rotors, n=3)
    np.testing.assert_allclose(Q, top.rotation_matrix(rotors), atol=1e-15)
    layout, _ = clifford.Cl(3)
    np.testing.assert_allclose(ga.rotor_to_matrix(rotors, n=layout), Q, atol=0)
    X = random_skew(rng, 5, (4,))
    coeffs = ga.to_values(ga.skew_to_bivector(X))
    np.testing.assert_allclose(ga.bivector_to_skew(coeffs, n=5), X, atol=0)
    R = ga.matrix_to_rotor(random_rotation(rng, 4, (3,)), as_multivector=False)
    np.testing.assert_allclose(
        ga.rotor_to_matrix(ga.matrix_to_rotor(ga.rotor_to_matrix(R, n=4), reference=R), n=4),
        ga.rotor_to_matrix(R, n=4),
        atol=1e-14,
    )


def test_converters_say_when_they_cannot_tell():
    with pytest.raises(ValueError, match=r"pass `n`.*n=3 for Cl\(3\)"):
        ga.rotor_to_matrix(np.eye(8)[0])
    with pytest.raises(ValueError, match=r"16 coefficients of a multivector of Cl\(4\).*shape \(8,\)"):
        ga.rotor_to_matrix(np.eye(8)[0], n=4)
    with pytest.raises(ValueError, match=r"Cl\(3\) but `n` = 4"):
        ga.rotor_to_matrix(ga.matrix_to_rotor(np.eye(3)), n=4)
    from clifford import pga

    with pytest.raises(ValueError, match="Euclidean"):
        ga.rotor_to_matrix(np.eye(16)[0], n=pga.layout)


# -- results as multivectors ----------------------------------------------------------------


def test_solution_multivectors_of_fields_and_outputs(rng):
    top = lieint.EulerTop(np.diag([1.0, 1.5, 2.2, 3.0]))
    y0 = top.initial_state(Omega=random_skew(rng, 4, (2,), scale=3.0))
    sol = lieint.integrate(top, y0, (0.0, 2.0), h=0.01, save_every=20)
    A = sol.multivectors("A")
    assert isinstance(A, clifford.MVArray) and A.shape == (sol.t.size, 2)
    np.testing.assert_allclose(ga.bivector_to_skew(A), sol.states["A"], atol=0)
    S = sol.multivectors("R")  # rotors, sign continuous in time
    np.testing.assert_allclose(ga.rotor_to_matrix(S), sol.states["R"], atol=1e-13)
    vals = ga.to_values(S)
    assert np.all(np.sum(vals[1:] * vals[:-1], axis=-1) > 0)
    W = sol.multivectors("angular_velocity")
    np.testing.assert_allclose(ga.bivector_to_skew(W), sol.outputs(["angular_velocity"])["angular_velocity"], atol=0)
    with pytest.raises(ValueError, match=r"no multivector form|Unknown field"):
        sol.multivectors("casimirs")


@pytest.mark.slow
def test_multivectors_of_a_rotor_system_and_a_motor():
    top = ga.RotorForm(lieint.HeavyTop.lagrange(1.0, 0.5, 1.0, 0.3))
    sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.1, 0.2, 5.0]), (0, 0.2), h=0.01)
    S = sol.multivectors("rotor")
    np.testing.assert_allclose(ga.to_values(S), sol.states["rotor"], atol=0)
    body = ga.MotorRigidBody(np.diag([1.0, 2.0, 3.0]), 1.0, [0, 0, -9.81])
    sol = lieint.integrate(body, body.initial_state(angular_velocity=[0, 0, 1.0], velocity=[1, 0, 0]), (0, 0.2), h=0.01)
    M = sol.multivectors("motor")
    from clifford import pga

    assert M.shape == (sol.t.size,) and M[0].layout is pga.layout
    assert sol.multivectors("center")[-1].layout.dims == 3


def test_read_multivectors_from_a_run_file(tmp_path):
    scene = lieint.scenes.parse_scene(
        """
        [scene]
        name = "top"
        [body]
        system = "euler_top"
        parameters = { B = [[1.0, 0, 0], [0, 2.0, 0], [0, 0, 3.0]] }
        [initial]
        angular_velocity = [0.3, 1.0, 0.2]
        [integrator]
        method = "rkmk4"
        step = 0.01
        t_end = 0.5
        [output]
        quantities = ["orientation"]
        """
    )
    out = tmp_path / "run.h5"
    lieint.run(scene, out=out, progress=False)
    S = ga.read_multivectors(out, "orientation")
    import h5py

    with h5py.File(out) as f:
        R = f["outputs/orientation"][...]
    np.testing.assert_allclose(ga.rotor_to_matrix(S), R, atol=1e-13)
    with pytest.raises(ValueError, match="not saved"):
        ga.read_multivectors(out, "nothing")


def test_import_lieint_does_not_import_clifford():
    code = "import sys, lieint; lieint.method_names(); print('clifford' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
