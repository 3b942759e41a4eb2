import numpy as np
import pytest

from lieint.methods import RKMK, ButcherTableau, tableaux
from lieint.methods.order_conditions import order_residuals, rooted_trees


def test_number_of_rooted_trees():
    # OEIS A000081
    assert [len(rooted_trees(p)) for p in range(1, 9)] == [1, 1, 2, 4, 9, 20, 48, 115]


@pytest.mark.parametrize("tab", list(tableaux.TABLEAUX.values()), ids=list(tableaux.TABLEAUX))
def test_every_tableau_has_its_order_and_not_more(tab):
    assert max(abs(r) for _, r in order_residuals(tab.A, tab.b, tab.order)) < 1e-14
    assert max(abs(r) for _, r in order_residuals(tab.A, tab.b, tab.order + 1)) > 1e-6


def test_wrong_row_sum_is_rejected():
    with pytest.raises(ValueError, match="row sums of `A` must equal `c`"):
        ButcherTableau("bad", A=[[0, 0], [1, 0]], b=[0.5, 0.5], c=[0, 0.5], order=2)


def test_overclaimed_order_names_the_failing_tree():
    with pytest.raises(ValueError, match=r"does not have order 3: the condition for the tree \[•\] \(order 2\)|tree"):
        ButcherTableau("heun?", A=[[0, 0], [1, 0]], b=[0.5, 0.5], c=[0, 1], order=3)


def test_implicit_tableau_is_rejected():
    with pytest.raises(ValueError, match="strictly lower triangular"):
        ButcherTableau("implicit", A=[[0.5]], b=[1.0], c=[0.5], order=1)


def test_tableau_is_immutable():
    with pytest.raises(ValueError):
        tableaux.RK4.A[1, 0] = 3.0


def test_lie_method_rejects_a_truncation_that_caps_the_order():
    with pytest.raises(ValueError, match="caps an order-6 RKMK method at order 5"):
        RKMK("x", tableaux.BUTCHER6, dexpinv_degree=3)
    with pytest.raises(ValueError, match="`coordinates` must be one of"):
        RKMK("x", tableaux.RK4, coordinates="quaternion")
    m = RKMK("rkmk4-exact", tableaux.RK4, dexpinv_degree=None)
    assert m.order == 4 and m.stages == 4
    assert np.isclose(tableaux.RK4.b.sum(), 1.0)
