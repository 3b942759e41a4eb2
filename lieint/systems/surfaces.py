"""Surfaces ``h(q) = 1`` in Rⁿ given as data, for a particle constrained to one (docs/theory.md §10).

Each surface is a function ``h`` with its gradient ``∇h`` and its Hessian quadratic form
``q̇ᵀ ∇²h q̇`` (what the constraint force needs), batched over leading axes:

* :class:`Sphere` — ``h(q) = |q − C|² / r²``;
* :class:`Ellipsoid` — ``h(q) = Σᵢ ((q − C)ᵢ / aᵢ)²`` (semi-axes along the coordinate axes);
* :class:`SurfaceOfRevolution` — about the axis ``(C, e)`` by its profile: with
  ``z = ⟨q − C, e⟩`` and ``ρ² = |q − C|² − z²`` (squared distance to the axis),
  ``h(q) = ρ² + P(z)`` for a polynomial ``P(z) = Σₖ pₖ zᵏ``; the meridian is
  ``ρ = √(1 − P(z))``. ``P(z) = z²`` is the unit sphere, ``P(z) = z² + εz³`` an egg.

The gradient of a surface of revolution is ``2(q − C − z e) + P'(z) e``, a combination of
``q − C`` and ``e``: this is why a force along e keeps Clairaut's trivector ``(q − C) ∧ q̇ ∧ e``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from .._validation import as_float_array, check_finite_positive, check_vector, describe

__all__ = ["Ellipsoid", "Sphere", "Surface", "SurfaceOfRevolution", "make_surface"]


class Surface(ABC):
    """A level set ``{q : h(q) = 1}`` in Rⁿ (see the module docstring).

    Attributes
    ----------
    n : int
        Dimension of the ambient space.
    centre : ndarray, shape (n,)
        The centre C (the point the surface is described about).
    """

    n: int
    centre: np.ndarray
    #: the axis e of a surface of revolution (None for other surfaces)
    axis: np.ndarray | None = None

    @abstractmethod
    def h(self, q: np.ndarray) -> np.ndarray:
        """``h(q)``, shape ``q.shape[:-1]``."""

    @abstractmethod
    def gradient(self, q: np.ndarray) -> np.ndarray:
        """``∇h(q)``, shape ``q.shape``."""

    @abstractmethod
    def hessian_form(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``vᵀ ∇²h(q) v``, shape ``q.shape[:-1]``."""

    def point(self, direction) -> np.ndarray:
        """The point of the surface on the ray from C along ``direction`` (found by Newton on
        the ray's parameter, to round-off)."""
        d = check_vector(direction, "direction", self.n, batch=True)
        norm = np.linalg.norm(d, axis=-1, keepdims=True)
        if np.any(norm == 0):
            raise ValueError("`direction` must be a nonzero vector.")
        d = d / norm
        s = np.ones(d.shape[:-1] + (1,))
        for _ in range(100):
            q = self.centre + s * d
            g = self.h(q)[..., None] - 1.0
            ds = g / np.sum(self.gradient(q) * d, axis=-1, keepdims=True)
            s = s - ds
            if np.all(np.abs(ds) <= 4e-16 * np.abs(s)):
                break
        return self.centre + s * d


class Sphere(Surface):
    """The sphere ``|q − C| = r``: ``h(q) = |q − C|² / r²``.

    Parameters
    ----------
    n : int
        Dimension of the ambient space (≥ 2).
    radius : float
        r > 0.
    centre : array_like, shape (n,), optional
        C (default the origin).
    """

    def __init__(self, n: int, radius: float = 1.0, centre=None):
        self.n = _check_dimension(n)
        self.radius = check_finite_positive(radius, "radius")
        self.centre = np.zeros(self.n) if centre is None else check_vector(centre, "centre", self.n)
        self._k = 1.0 / self.radius**2

    def h(self, q):
        d = q - self.centre
        return self._k * np.sum(d * d, axis=-1)

    def gradient(self, q):
        return 2.0 * self._k * (q - self.centre)

    def hessian_form(self, q, v):
        return 2.0 * self._k * np.sum(v * v, axis=-1)

    def __repr__(self) -> str:
        return f"Sphere(n={self.n}, radius={self.radius:g}, centre={describe(self.centre)})"


class Ellipsoid(Surface):
    """The ellipsoid ``Σᵢ ((q − C)ᵢ / aᵢ)² = 1``.

    Parameters
    ----------
    semi_axes : array_like, shape (n,)
        Positive semi-axes ``aᵢ`` along the coordinate axes.
    centre : array_like, shape (n,), optional
        C (default the origin).
    """

    def __init__(self, semi_axes, centre=None):
        a = as_float_array(semi_axes, "semi_axes")
        if a.ndim != 1 or a.size < 2 or np.any(a <= 0):
            raise ValueError(f"`semi_axes` must be a vector of n ≥ 2 positive numbers; got {describe(a)}.")
        self.semi_axes, self.n = a, a.size
        self.centre = np.zeros(self.n) if centre is None else check_vector(centre, "centre", self.n)
        self._k = 1.0 / a**2

    def h(self, q):
        d = q - self.centre
        return np.sum(self._k * d * d, axis=-1)

    def gradient(self, q):
        return 2.0 * self._k * (q - self.centre)

    def hessian_form(self, q, v):
        return 2.0 * np.sum(self._k * v * v, axis=-1)

    def __repr__(self) -> str:
        return f"Ellipsoid(semi_axes={describe(self.semi_axes)}, centre={describe(self.centre)})"


class SurfaceOfRevolution(Surface):
    """The surface ``ρ² + P(z) = 1`` about the axis through C along e (module docstring).

    Parameters
    ----------
    profile : array_like, shape (k,)
        Coefficients ``p₀, p₁, …`` of ``P(z) = Σ pₖ zᵏ`` in increasing powers; the meridian is
        ``ρ(z) = √(1 − P(z))``. ``[0, 0, 1]`` is the unit sphere.
    axis : array_like, shape (n,)
        Direction e of the axis (normalised here).
    centre : array_like, shape (n,), optional
        The point C of the axis where z = 0 (default the origin).
    """

    def __init__(self, profile, axis, centre=None):
        p = as_float_array(profile, "profile")
        if p.ndim != 1 or p.size < 3 or not np.any(p[2:] != 0):
            raise ValueError(
                "`profile` must be the coefficients [p0, p1, p2, ...] of P(z) in increasing powers, of degree "
                f"≥ 2 (the surface is ρ² + P(z) = 1); got {describe(p)}."
            )
        e = as_float_array(axis, "axis")
        if e.ndim != 1 or e.size < 2 or not np.linalg.norm(e) > 0:
            raise ValueError(f"`axis` must be a nonzero vector of dimension n ≥ 2; got {describe(e)}.")
        self.n = e.size
        self.axis = e / np.linalg.norm(e)
        self.profile = p
        self._dp = np.polynomial.polynomial.polyder(p)
        self._ddp = np.polynomial.polynomial.polyder(self._dp)
        self.centre = np.zeros(self.n) if centre is None else check_vector(centre, "centre", self.n)

    def _split(self, q):
        d = q - self.centre
        z = d @ self.axis
        return d, z

    def h(self, q):
        d, z = self._split(q)
        rho2 = np.sum(d * d, axis=-1) - z * z
        return rho2 + np.polynomial.polynomial.polyval(z, self.profile)

    def gradient(self, q):
        d, z = self._split(q)
        dP = np.polynomial.polynomial.polyval(z, self._dp)
        return 2.0 * (d - z[..., None] * self.axis) + dP[..., None] * self.axis

    def hessian_form(self, q, v):
        _, z = self._split(q)
        vz = v @ self.axis
        ddP = np.polynomial.polynomial.polyval(z, self._ddp)
        return 2.0 * (np.sum(v * v, axis=-1) - vz * vz) + ddP * vz * vz

    def __repr__(self) -> str:
        return (
            f"SurfaceOfRevolution(profile={describe(self.profile)}, axis={describe(self.axis)}, "
            f"centre={describe(self.centre)})"
        )


#: surface kinds a scene can name
SURFACE_KINDS = ("sphere", "ellipsoid", "revolution")


def make_surface(kind: str, *, n: int | None = None, radius=None, semi_axes=None, profile=None, axis=None, centre=None):
    """A surface from data (what scenes give): ``kind`` and the keywords that kind takes.

    Parameters
    ----------
    kind : {"sphere", "ellipsoid", "revolution"}
    n : int, optional
        Dimension of a sphere (default: from ``centre``, else 3).
    radius : float
        Sphere radius.
    semi_axes : array_like
        Ellipsoid semi-axes.
    profile, axis : array_like
        Surface of revolution (see :class:`SurfaceOfRevolution`).
    centre : array_like, optional
        C.
    """
    given = {"radius": radius, "semi_axes": semi_axes, "profile": profile, "axis": axis}
    takes = {"sphere": {"radius"}, "ellipsoid": {"semi_axes"}, "revolution": {"profile", "axis"}}
    if kind not in takes:
        raise ValueError(f"`surface` must be one of {list(SURFACE_KINDS)} or a Surface; got {kind!r}.")
    extra = sorted(k for k, v in given.items() if v is not None and k not in takes[kind])
    if extra:
        raise ValueError(f"`{extra[0]}` does not apply to a {kind!r} surface; it takes {sorted(takes[kind])}.")
    missing = sorted(k for k in takes[kind] if given[k] is None and not (kind == "sphere"))
    if missing:
        raise ValueError(f"a {kind!r} surface needs `{missing[0]}`.")
    if kind == "sphere":
        if n is None:
            n = 3 if centre is None else np.size(centre)
        return Sphere(n, 1.0 if radius is None else radius, centre)
    if kind == "ellipsoid":
        return Ellipsoid(semi_axes, centre)
    return SurfaceOfRevolution(profile, axis, centre)


def _check_dimension(n) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"`n` must be an integer ≥ 2; got {n!r}.")
    return int(n)
