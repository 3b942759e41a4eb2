"""Optional dependencies: the extras that install them, and a clear error when one is missing.

``pip install lieint`` integrates; geometric algebra (:mod:`lieint.ga`), figures and sweeps need
the extras ``lieint[ga]`` (clifford), ``lieint[plot]`` (matplotlib) and ``lieint[sweep]`` (dask,
distributed, zarr, xarray).
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["EXTRAS", "MissingExtraError", "extra_of", "require"]

#: the extra that installs each optional top-level package
EXTRAS = {
    "clifford": "ga",
    "matplotlib": "plot",
    "dask": "sweep",
    "distributed": "sweep",
    "zarr": "sweep",
    "xarray": "sweep",
}


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names the extra that installs it."""


def extra_of(module: str | None) -> str | None:
    """The extra that installs the top-level package of ``module`` (None: not an optional one)."""
    return EXTRAS.get((module or "").split(".")[0])


def missing_message(package: str, purpose: str) -> str:
    """``purpose needs package: pip install "lieint[extra]"``."""
    extra = extra_of(package)
    how = f'pip install "lieint[{extra}]"' if extra else f"pip install {package}"
    return f"{purpose} needs {package}, which is not installed: {how}"


def require(module: str, purpose: str) -> ModuleType:
    """Import ``module``, or raise :class:`MissingExtraError` saying which extra installs it.

    Parameters
    ----------
    module : str
        The module to import (e.g. ``"matplotlib.pyplot"``).
    purpose : str
        What needs it, for the message (e.g. ``"lieint.ga"``).

    Returns
    -------
    module
        The imported module.
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        package = (exc.name or module).split(".")[0]
        if extra_of(package) is None:
            raise
        raise MissingExtraError(missing_message(package, purpose), name=package) from exc
