"""The result of :func:`lieint.integrate` (built in one place, :meth:`lieint.driver.Driver.solution`)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .drift import drift as _drift

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["Invariants", "Solution"]


class Invariants(Mapping):
    """Lazy mapping name → invariant series ``(m, *batch, ...)``.

    Each invariant is computed from the saved states on first access and cached, so a run
    pays only for the invariants it looks at.
    """

    def __init__(self, system, t: np.ndarray, states: dict):
        self._system = system
        self._t = t
        self._states = states
        self._cache: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._cache:
            declared = self._system.invariants
            if name not in declared:
                raise KeyError(f"Unknown invariant {name!r}; this system provides {list(declared)}.")
            batch_ndim = len(_batch_shape(self._system, self._states))
            t = self._t.reshape(self._t.shape + (1,) * batch_ndim)
            self._cache[name] = declared[name](t, self._states)
        return self._cache[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._system.invariants)

    def __len__(self) -> int:
        return len(self._system.invariants)

    def __repr__(self) -> str:
        return f"Invariants({list(self)})"


@dataclass
class Solution:
    """Saved trajectory of an integration (what :func:`lieint.integrate` returns).

    The states are kept by field (``states["A"]``, ``states["R"]``, time first); :attr:`y`
    gives them in :func:`scipy.integrate.solve_ivp`'s layout, and ``status``, ``success``,
    ``message``, ``t_events``, ``y_events`` and ``sol`` mean what they mean on scipy's
    ``OdeResult``.

    Attributes
    ----------
    t : ndarray, shape (m,)
        Saved times.
    states : dict of ndarray
        Each state field at the saved times, shape ``(m, *batch, ...)``.
    system : LieGroupSystem
        The system that was integrated.
    invariants : Mapping of ndarray
        Lazily evaluated invariants, shape ``(m, *batch, ...)``.
    method : str
        The method's name.
    stats : Stats
        Steps, rejections, evaluations, CPU and wall time, back end and settings
        (:class:`lieint.Stats`).
    success : bool
        False if the run stopped early (non-finite state, solver failure).
    message : str
        What happened, and what to do about it when it failed.
    status : int
        As scipy's ``OdeResult.status``: −1 the run failed (``success`` is False), 0 it
        reached ``t1``, 1 a terminal event stopped it.
    sol : DenseOutput or None
        With ``dense_output=True``: the continuous solution ``sol.sol(t)`` on the group
        (:class:`lieint.dense.DenseOutput`); None otherwise.
    t_events : list of ndarray or None
        With ``events``: the times of each event (:mod:`lieint.events`); None otherwise.
    y_events : list of dict or None
        With ``events``: the states at those times (dicts of ``(k, ...)`` arrays).

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    >>> sol = lieint.integrate(top, y0, (0.0, 1.0), h=0.1, method="rkmk4")
    >>> sol.status, sol.success, float(sol.t[-1])
    (0, True, 1.0)
    >>> sol.states["R"].shape, sol.y.shape
    ((11, 3, 3), (18, 11))
    >>> float(sol.drift("energy")) < 1e-8
    True
    """

    t: np.ndarray
    states: dict[str, np.ndarray]
    system: Any
    method: str
    stats: Any
    success: bool
    message: str
    invariants: Invariants = field(init=False, repr=False)
    sol: Any = field(default=None, repr=False)
    t_events: Any = field(default=None, repr=False)
    y_events: Any = field(default=None, repr=False)
    status: int | None = field(default=None)

    def __post_init__(self) -> None:
        self.invariants = Invariants(self.system, self.t, self.states)
        if self.status is None:  # a terminal event sets 1 (lieint.observe)
            self.status = 0 if self.success else -1

    @property
    def y(self) -> np.ndarray:
        """The saved states in scipy's layout: shape ``(n_components, m)``, one column per time.

        A column is the state flattened as scipy's baselines flatten it: the fields in the
        order of :attr:`states` (the system's ``fields``: e.g. ``A`` then ``R``), each
        flattened in C order over its batch and field axes ``(*batch, ...)`` — for one 3D
        top, rows 0–8 are ``A.ravel()`` and rows 9–17 ``R.ravel()``. A new array on every
        access.

        Examples
        --------
        >>> import numpy as np, lieint
        >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        >>> sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.0, 1.0, 0.1]), (0, 1), h=0.5)
        >>> bool(np.array_equal(sol.y[:9, -1], sol.states["A"][-1].ravel()))
        True
        """
        m = self.t.size
        return np.concatenate([np.asarray(v).reshape(m, -1) for v in self.states.values()], axis=1).T

    def _keep_rows(self, keep: np.ndarray) -> None:
        """Keep only the saved rows where ``keep`` is True (the lazy invariants follow)."""
        if np.all(keep):
            return
        self.t = self.t[keep]
        self.states = {k: v[keep] for k, v in self.states.items()}
        self.__post_init__()

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading batch shape of the ensemble (``()`` for one body)."""
        return _batch_shape(self.system, self.states)

    @property
    def nsteps(self) -> int:
        """Accepted steps (every method, scipy's included)."""
        return self.stats.nsteps

    @property
    def nfev(self) -> int:
        """Generator / vector-field evaluations (one evaluation moves all members)."""
        return self.stats.nfev

    def drift(self, name: str) -> np.ndarray | float:
        """Drift of an invariant, per ensemble member (a float for one body).

        Integrals: ``max_t ‖I(t) − I(0)‖ / ‖I(0)‖`` (norms over the invariant's own axes),
        absolute where ``I(0) = 0``; defects (e.g. ``orthogonality``): ``max_t ‖D(t)‖``. The same
        definition as the monitors of streamed runs, the plots and the study
        (:mod:`lieint.drift`).

        Parameters
        ----------
        name : str
            An invariant of the system (``sol.invariants``: e.g. "energy", "casimirs",
            "orthogonality").

        Returns
        -------
        float or ndarray
            The drift (a float for one body, shape ``batch_shape`` for an ensemble).

        Raises
        ------
        KeyError
            For a name the system does not provide (the message lists those it does).

        Examples
        --------
        >>> import lieint
        >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        >>> sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.1, 1.0, 0.1]), (0, 10), h=0.01)
        >>> bool(sol.drift("energy") < 1e-9), bool(sol.drift("orthogonality") < 1e-12)
        (True, True)
        """
        declared = self.system.invariants
        if name not in declared:
            raise KeyError(f"Unknown invariant {name!r}; this system provides {list(declared)}.")
        return _drift(self.invariants[name], declared[name].kind, len(self.batch_shape))

    def outputs(self, names: Iterable[str]) -> dict[str, np.ndarray]:
        """Named outputs or invariants of the system over the saved times.

        Parameters
        ----------
        names : iterable of str
            Names from ``sol.system.outputs`` (e.g. "angular_velocity", "orientation") or
            ``sol.invariants``.

        Returns
        -------
        dict of ndarray
            name → values, shape ``(m, *batch, ...)``.
        """
        t = self.t.reshape(self.t.shape + (1,) * len(self.batch_shape))
        return {
            name: (
                self.invariants[name]
                if name in self.system.invariants
                else self.system.evaluate_outputs(t, self.states, [name])[name]
            )
            for name in names
        }

    def rotation(self, field: str = "R", *, atol: float = 1e-9) -> Rotation:
        """The saved orientations as a :class:`scipy.spatial.transform.Rotation` (3D bodies).

        Parameters
        ----------
        field : str, default "R"
            The state field (or output) holding the orientation R (body to space: a body point
            X is at ``R X``, which is what ``Rotation.apply(X)`` gives).
        atol : float, default 1e-9
            Largest ``‖RᵀR − I‖_F`` accepted: results of methods that do not keep R on SO(3)
            (classical RK, scipy's solvers) need ``project=True`` or a larger ``atol``.

        Returns
        -------
        scipy.spatial.transform.Rotation
            A stack of ``m·prod(batch)`` rotations, time first (:func:`lieint.rotations.from_solution`;
            quaternions: :func:`lieint.rotations.to_quaternion`).

        Examples
        --------
        >>> import lieint
        >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        >>> sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.0, 0.0, 0.5]), (0, 2), h=0.5)
        >>> sol.rotation()[-1].as_rotvec().round(12).tolist()  # 2 s at 0.5 rad/s about e3
        [0.0, 0.0, 1.0]
        """
        from .rotations import from_solution

        return from_solution(self, field, atol=atol)

    def multivectors(self, name: str) -> Any:
        """A bivector-, rotor- or vector-valued field or output as clifford multivectors.

        Parameters
        ----------
        name : str
            A state field or output whose declared kind has a multivector form: ``"A"`` (a
            bivector), ``"rotor"``, ``"R"``/``"orientation"`` (rotors, sign continuous in time),
            vectors and points, PGA motors and lines (:mod:`lieint.ga.results`).

        Returns
        -------
        clifford.MVArray
            Shape ``(m, *batch)`` over the saved times.
        """
        from .ga.results import solution_multivectors  # clifford is imported on use only

        return solution_multivectors(self, name)

    def __repr__(self) -> str:
        return (
            f"Solution(method={self.method!r}, saved={self.t.size}, batch={self.batch_shape}, nsteps={self.nsteps}, "
            f"nfev={self.nfev}, status={self.status}, success={self.success}, fields={list(self.states)})"
        )


def _batch_shape(system, states: dict) -> tuple[int, ...]:
    """The batch shape of saved rows ``states`` (``(m, *batch, ...)`` per field): the system's of
    their first row."""
    return system.batch_shape({k: v[0] for k, v in states.items()})
