"""Explicit Butcher tableaux as checked data."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .order_conditions import order_residuals, tree_size, tree_string

__all__ = ["ButcherTableau", "EmbeddedPair"]


@dataclass(frozen=True, eq=False)
class ButcherTableau:
    """An explicit Runge–Kutta tableau ``(A, b, c)`` of a declared order.

    Checked on creation: ``A`` strictly lower triangular (explicit), ``Σ_j a_ij = c_i``,
    and every rooted-tree order condition up to ``order`` holds to 1e-13.

    Parameters
    ----------
    name : str
        Human-readable name ("classical RK4", "Butcher 6(7)").
    A : array_like, shape (s, s)
        Stage coefficients (strictly lower triangular).
    b : array_like, shape (s,)
        Weights.
    c : array_like, shape (s,)
        Nodes; stage i is evaluated at ``t + c_i h``.
    order : int
        The order the tableau is claimed to have.
    """

    name: str
    A: np.ndarray
    b: np.ndarray
    c: np.ndarray
    order: int
    stages: int = field(init=False)

    def __post_init__(self):
        A = np.atleast_2d(np.asarray(self.A, dtype=float))
        b = np.atleast_1d(np.asarray(self.b, dtype=float))
        c = np.atleast_1d(np.asarray(self.c, dtype=float))
        s = b.shape[0]
        if A.shape != (s, s) or c.shape != (s,) or b.ndim != 1:
            raise ValueError(
                f"Tableau {self.name!r}: `A` must be ({s}, {s}) and `c` ({s},) for {s} weights `b`; "
                f"got A {A.shape}, b {b.shape}, c {c.shape}."
            )
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b)) and np.all(np.isfinite(c))):
            raise ValueError(f"Tableau {self.name!r}: coefficients must be finite.")
        if np.any(np.triu(A) != 0):
            raise ValueError(
                f"Tableau {self.name!r}: `A` must be strictly lower triangular (explicit method); "
                f"got nonzero entries on or above the diagonal."
            )
        if not np.allclose(A.sum(axis=1), c, rtol=0, atol=1e-14):
            raise ValueError(f"Tableau {self.name!r}: row sums of `A` must equal `c`; got {A.sum(axis=1)} vs {c}.")
        if isinstance(self.order, bool) or not isinstance(self.order, (int, np.integer)) or self.order < 1:
            raise ValueError(f"Tableau {self.name!r}: `order` must be an integer >= 1; got {self.order!r}.")
        for tree, residual in order_residuals(A, b, int(self.order)):
            if abs(residual) > 1e-13:
                raise ValueError(
                    f"Tableau {self.name!r} does not have order {self.order}: the condition for the "
                    f"tree {tree_string(tree)} (order {tree_size(tree)}) fails by {residual:.3g}."
                )
        for key, val in (("A", A), ("b", b), ("c", c)):
            val.setflags(write=False)
            object.__setattr__(self, key, val)
        object.__setattr__(self, "order", int(self.order))
        object.__setattr__(self, "stages", s)

    def __repr__(self) -> str:
        return f"ButcherTableau({self.name!r}, stages={self.stages}, order={self.order})"


def _check_weights(tableau: ButcherTableau, weights: np.ndarray, order: int, label: str) -> None:
    """Raise ``ValueError`` unless ``weights`` meet, with ``tableau.A``, every condition up to ``order``."""
    for tree, residual in order_residuals(tableau.A, weights, order):
        if abs(residual) > 1e-12:
            raise ValueError(
                f"{label} weights of {tableau.name!r} fail the order-{order} "
                f"condition for the tree {tree_string(tree)} by {residual:.3g}"
            )


@dataclass(frozen=True, eq=False)
class EmbeddedPair:
    """A tableau of order p with a second weight vector ``b_hat`` of order q < p.

    Both weight vectors are checked against every rooted-tree condition of their order. A step
    propagates the order-p solution; the difference of the two solutions estimates the error of
    the order-q one, which a step-size controller uses (exponent ``1/(q + 1)``).

    Parameters
    ----------
    tableau : ButcherTableau
        The order-p method (its ``b``).
    b_hat : array_like, shape (s,)
        Embedded weights.
    embedded_order : int
        q, the order of ``b_hat``.
    b_hat_low : array_like, shape (s,), optional
        A second, lower-order embedded solution (DOP853's order-3 weights ``b̂₃``). With it the
        two estimates ``e = y₁ − ŷ₁`` and ``e₃ = y₁ − ŷ₃`` are combined as in DOP853 (Hairer,
        Nørsett & Wanner, *Solving ODEs I*, §II.10, and scipy's ``DOP853``):
        ``err = ‖e‖² / √(‖e‖² + 0.01‖e₃‖²)``, which behaves like ``O(h^p)`` for small h, so the
        controller's exponent is ``1/p`` (:attr:`error_order` = p − 1).
    low_order : int, optional
        The order of ``b_hat_low`` (required with it).
    """

    tableau: ButcherTableau
    b_hat: np.ndarray
    embedded_order: int
    b_hat_low: np.ndarray | None = None
    low_order: int | None = None

    def __post_init__(self):
        b_hat = np.asarray(self.b_hat, dtype=float)
        if b_hat.shape != (self.tableau.stages,):
            raise ValueError(f"`b_hat` must have {self.tableau.stages} weights; got shape {b_hat.shape}.")
        if not 1 <= self.embedded_order < self.tableau.order:
            raise ValueError(
                f"`embedded_order` must be between 1 and {self.tableau.order - 1}; got {self.embedded_order!r}."
            )
        _check_weights(self.tableau, b_hat, self.embedded_order, "embedded")
        b_hat.setflags(write=False)
        object.__setattr__(self, "b_hat", b_hat)
        if (self.b_hat_low is None) != (self.low_order is None):
            raise ValueError("`b_hat_low` and `low_order` go together.")
        if self.b_hat_low is not None:
            low = np.asarray(self.b_hat_low, dtype=float)
            if low.shape != b_hat.shape or not 1 <= self.low_order < self.embedded_order:
                raise ValueError(
                    f"`b_hat_low` must have {self.tableau.stages} weights of an order between 1 and "
                    f"{self.embedded_order - 1}; got shape {low.shape}, order {self.low_order!r}."
                )
            _check_weights(self.tableau, low, self.low_order, "low-order")
            low.setflags(write=False)
            object.__setattr__(self, "b_hat_low", low)

    @property
    def order(self) -> int:
        return self.tableau.order

    @property
    def stages(self) -> int:
        return self.tableau.stages

    @property
    def error_order(self) -> int:
        """The order q of the error estimate in the controller's exponent ``1/(q + 1)``: the
        embedded order, or p − 1 when DOP853's combined estimate is used (scipy's
        ``error_estimator_order`` of ``DOP853`` is 7)."""
        return self.embedded_order if self.b_hat_low is None else self.order - 1

    def __repr__(self) -> str:
        return f"EmbeddedPair({self.tableau.name!r}, order={self.order}({self.embedded_order}))"
