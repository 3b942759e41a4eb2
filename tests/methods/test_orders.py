"""Convergence orders fitted from step-size sweeps against exact solutions."""

import numpy as np
import pytest
from conftest import fitted_slope, random_rotation, random_skew
from scipy.linalg import expm

import lieint
from lieint.groups import SO
from lieint.systems import LieGroupSystem

LIE = {"lie_euler": 1, "rkmk2": 2, "rkmk3": 3, "rkmk4": 4, "rkmk6": 6}
STEPS = {1: [0.02, 0.01, 0.005, 0.0025], 6: [0.4, 0.2, 0.1, 0.05]}


@pytest.fixture(scope="module")
def top_problem():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    T = 5.0
    return top, y0, T, top.exact_solution([T], y0)["A"][-1]


@pytest.mark.parametrize("coordinates", ["exp", "cayley"])
@pytest.mark.parametrize("method", list(LIE))
def test_rkmk_orders_against_the_exact_3d_top(top_problem, method, coordinates):
    top, y0, T, exact = top_problem
    p = LIE[method]
    hs = STEPS.get(p, [0.2, 0.1, 0.05, 0.025])
    errs = [
        np.linalg.norm(
            lieint.integrate(top, y0, (0, T), h=h, method=method, coordinates=coordinates, save_every=10**9).states[
                "A"
            ][-1]
            - exact
        )
        for h in hs
    ]
    assert abs(fitted_slope(hs, errs) - p) <= 0.3, errs


@pytest.mark.parametrize("degree", [None, "auto"])
def test_rkmk6_order_with_exact_and_truncated_dexpinv(top_problem, degree):
    top, y0, T, exact = top_problem
    hs = STEPS[6]
    errs = [
        np.linalg.norm(
            lieint.integrate(top, y0, (0, T), h=h, method="rkmk6", dexpinv_degree=degree, save_every=10**9).states["A"][
                -1
            ]
            - exact
        )
        for h in hs
    ]
    assert fitted_slope(hs, errs) >= 5.7


def test_classical_rk4_order(top_problem):
    top, y0, T, exact = top_problem
    hs = [0.2, 0.1, 0.05, 0.025]
    errs = [
        np.linalg.norm(lieint.integrate(top, y0, (0, T), h=h, method="rk4", save_every=10**9).states["A"][-1] - exact)
        for h in hs
    ]
    assert abs(fitted_slope(hs, errs) - 4) <= 0.3


class RotatingFrameRotor(LieGroupSystem):
    """Ṙ = R Ω(t) with Ω(t) = e^{tW} Ω₀ e^{−tW}: explicitly time dependent and non-commuting.

    With S = R e^{tW}, Ṡ = S (Ω₀ + W), so R(t) = R₀ exp(t(Ω₀ + W)) exp(−tW) exactly.
    A user-defined system: it exercises the LieGroupSystem contract from outside the package.
    """

    def __init__(self, Omega0, W):
        self.Omega0, self.W = Omega0, W
        self.n = Omega0.shape[-1]
        self.group = SO(self.n)
        self.fields = {"R": (self.n, self.n)}

    def generator(self, t, y):
        E = expm(t * self.W)
        return E @ self.Omega0 @ E.T

    def act(self, g, y):
        return {"R": y["R"] @ g}

    def infinitesimal_action(self, xi, y):
        return {"R": y["R"] @ xi}

    def exact(self, R0, t):
        return R0 @ expm(t * (self.Omega0 + self.W)) @ expm(-t * self.W)


@pytest.mark.parametrize("coordinates", ["exp", "cayley"])
@pytest.mark.parametrize("method", ["rkmk2", "rkmk3", "rkmk4", "rkmk6"])
def test_orders_on_an_explicitly_time_dependent_generator(rng, method, coordinates):
    n = 4
    sys_ = RotatingFrameRotor(random_skew(rng, n, (), 1.0), random_skew(rng, n, (), 2.0))
    R0 = random_rotation(rng, n)
    T = 2.0
    exact = sys_.exact(R0, T)
    p = LIE[method]
    # ‖hW‖ must be small for the asymptotic regime: at h = 0.2 RKMK3 still shows slope 3.8.
    hs = [0.05, 0.025, 0.0125, 0.00625] if p < 6 else [0.2, 0.1, 0.05, 0.025]
    errs = [
        np.linalg.norm(
            lieint.integrate(
                sys_, {"R": R0}, (0, T), h=h, method=method, coordinates=coordinates, save_every=10**9
            ).states["R"][-1]
            - exact
        )
        for h in hs
    ]
    assert abs(fitted_slope(hs, errs) - p) <= 0.3, errs
