"""Orientations to and from :class:`scipy.spatial.transform.Rotation` and quaternions (n = 3).

lieint's orientation ``R`` (the state field of every rotating body, ``(..., 3, 3)``) maps the
body frame to space: a point with body coordinates ``X`` is at ``q = R X`` in space (for a body
with a fixed point at the origin). scipy's :class:`~scipy.spatial.transform.Rotation` means the
same: ``Rotation.from_matrix(R).apply(X) == R @ X``. So the conversions are the matrix itself,
nothing transposed.

Quaternions ``q = w + x i + y j + z k`` of unit norm stand for ``R`` with scipy's convention
(``R = I + 2w [v]× + 2 [v]×²``, ``v = (x, y, z)``; ``q`` and ``−q`` are the same rotation). The
order of the components is explicit everywhere: ``scalar_first=True`` is ``(w, x, y, z)``
(common in mechanics and in Hamilton's notation), ``scalar_first=False`` is ``(x, y, z, w)``
(scipy's default). It has no default here, because mixing them up gives a valid but wrong
rotation that no check can catch.

Batches: arrays keep their leading shape (``(..., 3, 3)`` ↔ ``(..., 4)``); a
:class:`~scipy.spatial.transform.Rotation` holds one rotation or a 1-D stack, so a batch of
shape ``(m, k)`` becomes a stack of ``m·k`` rotations in C order (time first for a result).

Inputs: ``initial_state(R=...)`` of every rotating body accepts a ``Rotation`` (one, or a
stack: a batch); a quaternion goes through :func:`from_quaternion`.

Examples
--------
>>> import numpy as np, lieint
>>> from scipy.spatial.transform import Rotation
>>> from lieint import rotations
>>> start = Rotation.from_euler("zyx", [30, 10, -5], degrees=True)
>>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
>>> y0 = top.initial_state(angular_velocity=[0.0, 0.0, 1.0], R=start)
>>> sol = lieint.integrate(top, y0, (0.0, 1.0), h=0.1, method="rkmk4")
>>> path = rotations.from_solution(sol)  # a stack of 11 rotations, one per saved time
>>> # a steady spin about the body axis e3 at 1 rad/s: R(t) = R(0) exp(t ê3)
>>> expected = start * Rotation.from_rotvec([0.0, 0.0, 1.0])
>>> bool(np.allclose(path[-1].as_matrix(), expected.as_matrix(), atol=1e-12))
True
>>> q = rotations.to_quaternion(sol.states["R"], scalar_first=True)  # (11, 4), sign-continuous
>>> q.shape
(11, 4)
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from ._validation import as_float_array, check_finite_positive, check_rotation, is_scipy_rotation

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["from_quaternion", "from_scipy", "from_solution", "is_scipy_rotation", "to_quaternion", "to_scipy"]


#: how far from SO(3) a matrix may be (‖RᵀR − I‖_F) to be converted as it is
ROTATION_ATOL = 1e-9


def _rotation_matrices(R: ArrayLike, name: str, atol: float = ROTATION_ATOL) -> np.ndarray:
    """``R`` as float ``(..., 3, 3)`` rotation matrices, checked (orthogonal to ``atol``, det +1)."""
    arr = as_float_array(R, name)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(
            f"`{name}` must be rotation matrices of shape (..., 3, 3) (scipy's Rotation and quaternions are "
            f"three-dimensional); got shape {arr.shape}."
        )
    atol = check_finite_positive(atol, "atol")
    try:
        check_rotation(arr, name, atol=atol)
    except ValueError as exc:
        raise ValueError(
            f"{exc} The conversions take matrices within `atol` = {atol:g} of SO(3); a result of a method "
            "that does not keep R on SO(3) (classical RK, scipy's solvers) drifts off it: integrate with "
            "project=True, or pass a larger `atol` to take the nearest rotations (scipy's from_matrix)."
        ) from None
    return arr


def to_scipy(R: ArrayLike, *, atol: float = ROTATION_ATOL) -> Rotation:
    """The orientations ``R`` as a :class:`scipy.spatial.transform.Rotation`.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (body to space: ``q = R X``), e.g. ``sol.states["R"]``.
    atol : float, default 1e-9
        Largest ``‖RᵀR − I‖_F`` accepted; within it, scipy takes the nearest rotation.

    Returns
    -------
    scipy.spatial.transform.Rotation
        One rotation for ``(3, 3)``; a stack of ``prod(...)`` rotations (C order) otherwise,
        with ``apply(X) == R @ X``.

    Examples
    --------
    >>> import numpy as np
    >>> from lieint.rotations import to_scipy
    >>> quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    >>> to_scipy(quarter).as_rotvec().round(12).tolist()
    [0.0, 0.0, 1.570796326795]
    """
    from scipy.spatial.transform import Rotation

    arr = _rotation_matrices(R, "R", atol)
    if arr.ndim == 2:
        return Rotation.from_matrix(arr)
    return Rotation.from_matrix(arr.reshape(-1, 3, 3))


def from_scipy(rotation: Rotation) -> np.ndarray:
    """The rotation matrices of a :class:`scipy.spatial.transform.Rotation`.

    Parameters
    ----------
    rotation : scipy.spatial.transform.Rotation
        One rotation or a stack.

    Returns
    -------
    ndarray, shape (3, 3) or (k, 3, 3)
        ``R`` with ``R @ X == rotation.apply(X)``: lieint's orientation (body to space), e.g.
        for ``initial_state(R=...)`` (which also takes the ``Rotation`` itself).

    Examples
    --------
    >>> from scipy.spatial.transform import Rotation
    >>> from lieint.rotations import from_scipy
    >>> from_scipy(Rotation.from_rotvec([[0.0, 0.0, 0.1], [0.2, 0.0, 0.0]])).shape
    (2, 3, 3)
    """
    if not is_scipy_rotation(rotation):
        raise TypeError(f"`rotation` must be a scipy.spatial.transform.Rotation; got {type(rotation).__name__}.")
    return np.asarray(rotation.as_matrix(), dtype=float)


def to_quaternion(
    R: ArrayLike, *, scalar_first: bool, continuous: bool = True, atol: float = ROTATION_ATOL
) -> np.ndarray:
    """Unit quaternions of the orientations ``R``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (body to space).
    scalar_first : bool
        ``True``: components ``(w, x, y, z)``; ``False``: ``(x, y, z, w)`` (scipy's default).
        Required: see the module docstring.
    continuous : bool, default True
        Choose the sign of each quaternion (``q`` and ``−q`` are the same rotation) so that
        the series is continuous along the first axis (the time axis of a result): each
        ``q[k]`` has a nonnegative inner product with ``q[k − 1]``, and the first one has
        ``w ≥ 0``. ``False``: the sign scipy's conversion gives, member by member.
    atol : float, default 1e-9
        Largest ``‖RᵀR − I‖_F`` accepted (as :func:`to_scipy`).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions.

    Examples
    --------
    >>> import numpy as np
    >>> from lieint.rotations import to_quaternion
    >>> quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    >>> (to_quaternion(quarter, scalar_first=True) * np.sqrt(2)).round(12).tolist()
    [1.0, 0.0, 0.0, 1.0]
    >>> (to_quaternion(quarter, scalar_first=False) * np.sqrt(2)).round(12).tolist()
    [0.0, 0.0, 1.0, 1.0]
    """
    from scipy.spatial.transform import Rotation

    _check_flag(scalar_first, "scalar_first")
    _check_flag(continuous, "continuous")
    arr = _rotation_matrices(R, "R", atol)
    batch = arr.shape[:-2]
    q = np.asarray(Rotation.from_matrix(arr.reshape(-1, 3, 3)).as_quat(), dtype=float).reshape(batch + (4,))
    if continuous:  # scalar-last here: w is the last component
        if q.ndim == 1:
            q = q if q[3] >= 0 else -q
        else:
            q = q.copy()
            q[0] *= np.where(q[0][..., 3:] < 0, -1.0, 1.0)
            for k in range(1, q.shape[0]):
                q[k] *= np.where(np.sum(q[k] * q[k - 1], axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return np.roll(q, 1, axis=-1) if scalar_first else q


def from_quaternion(q: ArrayLike, *, scalar_first: bool) -> np.ndarray:
    """Rotation matrices of quaternions.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, normalised here as scipy does (a zero quaternion is refused).
    scalar_first : bool
        ``True``: ``q`` is ``(w, x, y, z)``; ``False``: ``(x, y, z, w)`` (scipy's default).
        Required: see the module docstring.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Rotation matrices (body to space), e.g. for ``initial_state(R=...)``.

    Examples
    --------
    >>> import numpy as np
    >>> from lieint.rotations import from_quaternion
    >>> half = np.cos(np.pi / 4)
    >>> from_quaternion([half, 0.0, 0.0, half], scalar_first=True).round(12)  # 90° about z
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    from scipy.spatial.transform import Rotation

    _check_flag(scalar_first, "scalar_first")
    arr = as_float_array(q, "q")
    if arr.ndim < 1 or arr.shape[-1] != 4:
        raise ValueError(f"`q` must be quaternions of shape (..., 4); got shape {arr.shape}.")
    norms = np.linalg.norm(arr, axis=-1)
    if np.any(norms == 0.0):
        bad = np.argwhere(np.atleast_1d(norms) == 0.0)[0]
        raise ValueError(
            f"`q` must be nonzero quaternions; got a zero quaternion at index {tuple(int(i) for i in bad)}."
        )
    batch = arr.shape[:-1]
    last = np.roll(arr, -1, axis=-1) if scalar_first else arr
    return np.asarray(Rotation.from_quat(last.reshape(-1, 4)).as_matrix(), dtype=float).reshape(batch + (3, 3))


class SolutionLike(Protocol):
    """What :func:`from_solution` reads of a result (:class:`lieint.Solution` is the one).

    A protocol, so that this module (below the solution in the layers) need not import it.
    """

    states: dict[str, np.ndarray]
    system: Any

    def outputs(self, names: Iterable[str]) -> dict[str, np.ndarray]: ...


def from_solution(sol: SolutionLike, field: str = "R", *, atol: float = ROTATION_ATOL) -> Rotation:
    """The saved orientations of a result as a :class:`scipy.spatial.transform.Rotation`.

    Parameters
    ----------
    sol : Solution
        A result of a 3D body that carries its orientation (:func:`lieint.integrate`).
    field : str, default "R"
        The state field holding the orientation, or an output of kind rotation (e.g. the
        atoms' ``"R"``).
    atol : float, default 1e-9
        Largest ``‖RᵀR − I‖_F`` accepted (the result's ``orthogonality`` invariant): a method
        that does not keep R on SO(3) needs ``project=True`` or a larger ``atol``.

    Returns
    -------
    scipy.spatial.transform.Rotation
        A stack of ``m·prod(batch)`` rotations: time first, then the ensemble members in C
        order (``sol.t.size`` rotations for one body).

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4]), (0, 1), h=0.25)
    >>> len(lieint.rotations.from_solution(sol))
    5
    """
    return to_scipy(_orientation_of(sol, field), atol=atol)


def _orientation_of(sol: SolutionLike, field: str) -> np.ndarray:
    """The orientation series ``(m, *batch, 3, 3)`` of a result: a state field or an output."""
    if field in sol.states:
        return sol.states[field]
    outputs = getattr(sol.system, "outputs", {})
    if field in outputs:
        return sol.outputs([field])[field]
    raise ValueError(
        f"`field` = {field!r} is neither a state field {list(sol.states)} nor an output of this system "
        f"({sorted(outputs)}); the orientation is usually 'R' (this system may not carry it)."
    )


def _check_flag(value: object, name: str) -> None:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be True or False; got {value!r}.")
