"""Method names that :func:`lieint.integrate` accepts, and how they are built."""

from __future__ import annotations

from . import tableaux
from .adaptive import ADAPTIVE_PAIRS, AdaptiveLieMethod, embedded_pair
from .classical import ClassicalRK
from .lie import COORDINATES, LieMethod
from .scipy_ivp import SCIPY_SOLVERS, ScipyMethod

__all__ = ["get_method", "methods"]

#: RKMK methods by name: name → tableau (the method has the tableau's order).
LIE_TABLEAUX = {
    "lie_euler": tableaux.EULER,
    "rkmk2": tableaux.HEUN,
    "rkmk3": tableaux.KUTTA3,
    "rkmk4": tableaux.RK4,
    "rkmk6": tableaux.BUTCHER6,
}

#: Classical RK baselines on the embedded equations.
CLASSICAL_TABLEAUX = {"rk4": tableaux.RK4}

_AUTO = "auto"


def methods() -> list[str]:
    """The method names :func:`lieint.integrate` accepts.

    Examples
    --------
    >>> import lieint
    >>> "rkmk4" in lieint.methods()
    True
    """
    return [*LIE_TABLEAUX, *ADAPTIVE_PAIRS, *CLASSICAL_TABLEAUX, *(f"scipy:{s}" for s in SCIPY_SOLVERS)]


def get_method(method="rkmk4", coordinates: str | None = None, dexpinv_degree=_AUTO):
    """Build the method object for a name (or check and return a method object).

    Parameters
    ----------
    method : str or LieMethod or ClassicalRK or ScipyMethod
        A name from :func:`methods`, or a method object built by the user.
    coordinates : {"exp", "cayley"}, optional
        Coordinate map of Lie-group methods (default "exp"). Rejected for other methods.
    dexpinv_degree : int, None or "auto"
        dexp⁻¹ truncation of Lie-group methods: "auto" keeps degree ``p − 2`` (the least that
        preserves order p), None uses the exact closed form.
    """
    if isinstance(method, (LieMethod, AdaptiveLieMethod, ClassicalRK, ScipyMethod)):
        if coordinates is not None and getattr(method, "coordinates", None) != coordinates:
            raise ValueError(
                f"`coordinates` = {coordinates!r} conflicts with the method object {method.name!r} "
                f"(coordinates {method.coordinates!r}); set them on the method instead."
            )
        return method
    if not isinstance(method, str):
        raise TypeError(f"`method` must be a method name or a method object; got {type(method).__name__}.")
    if method in LIE_TABLEAUX:
        coords = "exp" if coordinates is None else coordinates
        if coords not in COORDINATES:
            raise ValueError(f"`coordinates` must be one of {list(COORDINATES)}; got {coords!r}.")
        tab = LIE_TABLEAUX[method]
        degree = max(tab.order - 2, 0) if dexpinv_degree == _AUTO else dexpinv_degree
        name = method if coords == "exp" else f"{method}[cayley]"
        return LieMethod(name, tab, coordinates=coords, dexpinv_degree=degree)
    if method in ADAPTIVE_PAIRS:
        coords = "exp" if coordinates is None else coordinates
        pair = embedded_pair(ADAPTIVE_PAIRS[method])
        degree = pair.order - 2 if dexpinv_degree == _AUTO else dexpinv_degree
        name = method if coords == "exp" else f"{method}[cayley]"
        return AdaptiveLieMethod(name, pair, coordinates=coords, dexpinv_degree=degree)
    if coordinates is not None and coordinates != "exp":
        raise ValueError(
            f"`coordinates` applies to Lie-group methods only ({[*LIE_TABLEAUX, *ADAPTIVE_PAIRS]}); "
            f"got coordinates={coordinates!r} with method={method!r}."
        )
    if method in CLASSICAL_TABLEAUX:
        return ClassicalRK(method, CLASSICAL_TABLEAUX[method])
    if method.startswith("scipy:") and method[6:] in SCIPY_SOLVERS:
        return ScipyMethod(method[6:])
    raise ValueError(f"`method`: unknown method {method!r}; valid names are {methods()}.")
