"""The method registry: names users pass as ``method=``, with what each method is.

Every module of :mod:`lieint.methods` registers its methods when it is imported, by calling
:func:`register` with a :class:`~lieint.methods.base.MethodSpec`; the registry imports every
module of the package the first time a name is looked up (so ``import lieint`` stays light and
a method added in one new file is known everywhere: to :func:`lieint.integrate`, scenes, streamed
runs, the study, ``lieint methods`` and the tests that iterate the registry).
"""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path
from typing import Any

from .base import Method, MethodSpec

__all__ = ["AUTO", "get_method", "method_names", "method_specs", "register"]


class _Auto:
    """The default of options whose value depends on the method (e.g. dexp⁻¹ degree p − 2)."""

    def __repr__(self) -> str:
        return "'auto'"


#: the "method decides" default of build options
AUTO = _Auto()

_SPECS: dict[str, MethodSpec] = {}
_discovered = False


def register(spec: MethodSpec) -> MethodSpec:
    """Add a method to the registry (called at import time by the method's module)."""
    if not isinstance(spec, MethodSpec):
        raise TypeError(f"`spec` must be a MethodSpec; got {type(spec).__name__}.")
    old = _SPECS.get(spec.name)
    if old is not None and _origin(old) != _origin(spec):
        raise ValueError(f"a method named {spec.name!r} is registered already by {_origin(old)} ({old.description!r}).")
    _SPECS[spec.name] = spec
    return spec


def _origin(spec: MethodSpec) -> str:
    """The module that defined a spec's builder (re-importing that module may register it again)."""
    build = getattr(spec.build, "func", spec.build)
    return getattr(build, "__module__", "?")


def _discover() -> None:
    global _discovered
    if _discovered:
        return
    # the method modules are found on disk, beside this one, and imported by name: the registry
    # sits below them (they import it to register) and never imports the package itself
    here = Path(__file__).resolve().parent
    for info in pkgutil.iter_modules([str(here)]):
        if not info.name.startswith("_"):
            importlib.import_module(f"{__package__}.{info.name}")
    _discovered = True


#: listing order of the families (others follow in alphabetical order, scipy's baselines last)
_FAMILY_ORDER = ("rkmk", "rkmk-embedded", "rk")


def _listing_key(spec: MethodSpec):
    family = _FAMILY_ORDER.index(spec.family) if spec.family in _FAMILY_ORDER else len(_FAMILY_ORDER)
    return (spec.family == "scipy", family, spec.family, spec.order or 0, spec.name)


def method_specs() -> dict[str, MethodSpec]:
    """Every registered method: name → :class:`~lieint.methods.base.MethodSpec` (Lie-group
    methods first, by family and order; scipy's baselines last)."""
    _discover()
    return {spec.name: spec for spec in sorted(_SPECS.values(), key=_listing_key)}


def method_names() -> list[str]:
    """The method names :func:`lieint.integrate` accepts.

    Returns
    -------
    list of str
        Lie-group methods first, by family and order; scipy's baselines last (named
        "scipy:RK45" etc.; :func:`get_method` also takes them bare).

    Examples
    --------
    >>> import lieint
    >>> "rkmk4" in lieint.method_names()
    True
    """
    return list(method_specs())


def get_method(method: str | Method = "rkmk4", coordinates: str | None = None, **options: Any) -> Method:
    """Build the method object for a name (or check and return a method object).

    Parameters
    ----------
    method : str or Method
        A name from :func:`method_names`, or a method object built by the user. scipy's
        solvers may be named bare, as :func:`scipy.integrate.solve_ivp` names them: "RK45"
        is "scipy:RK45" (likewise "RK23", "DOP853", "Radau", "BDF", "LSODA").
    coordinates : {"exp", "cayley"}, optional
        Coordinate map of Lie-group methods (default: the method's first, "exp"). Refused for
        methods without coordinates.
    **options
        Build options the method declares (e.g. ``dexpinv_degree`` of RKMK: "auto" keeps
        degree ``p − 2``, the least that preserves order p; None uses the exact closed form).
        An option equal to ``AUTO`` (or the string "auto") means the method's default.

    Returns
    -------
    Method
        The method object (built once per name, coordinates and options: methods are
        stateless).

    Raises
    ------
    ValueError
        An unknown name (the message lists the valid ones), coordinates the method has not,
        an option it does not take.

    Examples
    --------
    >>> import lieint
    >>> m = lieint.get_method("rkmk4", coordinates="cayley")
    >>> m.name, m.order, m.adaptive
    ('rkmk4[cayley]', 4, False)
    >>> lieint.get_method("RK45").name  # scipy's solver, named bare
    'scipy:RK45'
    """
    if not options and coordinates is None and type(method) is str:  # a name alone: built already?
        cached = _BUILT.get((method, None, ()))
        if cached is not None and _SPECS.get(method) is cached[0]:
            return cached[1]
    options = {k: v for k, v in options.items() if not (v is AUTO or (isinstance(v, str) and v == "auto"))}
    if isinstance(method, Method):
        if coordinates is not None and method.coordinates != coordinates:
            raise ValueError(
                f"`coordinates` = {coordinates!r} conflicts with the method object {method.name!r} "
                f"(coordinates {method.coordinates!r}); set them on the method instead."
            )
        if options:
            raise ValueError(
                f"options {sorted(options)} apply to method names only; {method.name!r} is a method object."
            )
        return method
    if not isinstance(method, str):
        raise TypeError(f"`method` must be a method name or a method object; got {type(method).__name__}.")
    _discover()
    spec = _SPECS.get(method)  # the sorted listing is built only for messages (it costs a sort per call)
    if spec is None and f"scipy:{method}" in _SPECS:  # scipy's bare names, as solve_ivp takes them
        method = f"scipy:{method}"
        spec = _SPECS[method]
    if spec is None:
        raise ValueError(
            f"`method`: unknown method {method!r}; valid names are {list(method_specs())} "
            "(scipy's also bare: 'RK45', 'DOP853', …)."
        )
    if coordinates is not None:
        if not spec.coordinates:
            with_coords = [name for name, s in method_specs().items() if s.coordinates]
            raise ValueError(
                f"`coordinates` = {coordinates!r} does not apply to {method!r}, which has no coordinate map; "
                f"methods with coordinates: {with_coords}."
            )
        if coordinates not in spec.coordinates:
            raise ValueError(f"`coordinates` must be one of {list(spec.coordinates)}; got {coordinates!r}.")
    unknown = sorted(set(options) - set(spec.options))
    if unknown:
        allowed = f"its options are {list(spec.options)}" if spec.options else "it takes no options"
        raise ValueError(f"`{unknown[0]}` does not apply to {method!r}: {allowed}.")
    try:  # methods are frozen (stateless): one object per spec and build arguments
        key = (method, coordinates, tuple(sorted((k, type(v), v) for k, v in options.items())))
        cached = _BUILT.get(key)
    except TypeError:  # an unhashable option value: build it every time
        return spec.build(coordinates=coordinates, **options)
    if cached is not None and cached[0] is spec:
        return cached[1]
    built = spec.build(coordinates=coordinates, **options)
    if len(_BUILT) >= 256:
        _BUILT.clear()
    _BUILT[key] = (spec, built)
    return built


#: built methods by ``(name, coordinates, options)``, with the spec that built them (a spec
#: registered again under the name builds afresh)
_BUILT: dict[tuple, tuple[MethodSpec, Method]] = {}
