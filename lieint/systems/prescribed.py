"""A rotation driven by prescribed body rates: ``Ṙ = R Ω(t)`` with Ω(t) given (attitude
reconstruction from measured body rates, e.g. gyroscope samples).

The generator depends on t only (structure tag ``"time_only"``), which is what Magnus methods
(:mod:`lieint.methods.magnus`) need; every Lie-group method applies as well.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validation import as_float_array, as_rotation_array, check_rotation, describe
from ..fast.forms import PrescribedForm
from ..groups.bivectors import hat
from ..groups.so import SO, project_to_so
from .base import Invariant, LieGroupSystem, Output, State
from .rigid import orthogonality_invariant

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["PrescribedRotation"]

#: what the compiled declaration stands for (see :meth:`LieGroupSystem.dynamics_as`)
_DYNAMICS = ("generator", "act", "infinitesimal_action", "project", "body_rate", "body_rates")


class PrescribedRotation(LieGroupSystem):
    """Orientation R ∈ SO(n) moved by a prescribed body angular velocity: ``Ṙ = R Ω(t)``.

    Parameters
    ----------
    rates : callable or array_like
        Either a function ``rates(t)`` returning the body rate at one time — a vector
        ``(3,)`` (n = 3, ``Ω = ŵ``) or a skew matrix ``(n, n)`` — or samples ``(m, 3)`` /
        ``(m, n, n)`` at ``times``.
    times : array_like, shape (m,), optional
        Strictly increasing sample times of array ``rates`` (m ≥ 4). Between the samples Ω is
        the not-a-knot cubic spline of the samples (error O(Δt⁴) for smooth rates; the
        integration is only as accurate as that); outside ``[times[0], times[-1]]`` it is
        refused.
    n : int, default 3
        Dimension (for function rates that return skew matrices of another size).

    Notes
    -----
    State ``{"R": (..., n, n)}``; right action ``ρ(g, R) = R g``; generator ``ξ(t) = Ω(t)``.
    Invariant ``orthogonality`` (``‖RᵀR − I‖``, a defect). Output ``orientation``.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> spin = lieint.PrescribedRotation(lambda t: np.array([0.0, 0.0, 1.0]))
    >>> sol = lieint.integrate(spin, spin.initial_state(), (0.0, np.pi / 2), h=0.1, method="magnus4")
    >>> bool(np.allclose(sol.states["R"][-1] @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    True
    """

    autonomous = False
    structure = frozenset({"time_only"})

    def __init__(self, rates: Callable[[float], ArrayLike] | ArrayLike, times: ArrayLike | None = None, *, n: int = 3):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ValueError(f"`n` must be an integer >= 2; got {n!r}.")
        self.n = int(n)
        self._spline = None  # sampled rates: their cubic spline
        if callable(rates):
            if times is not None:
                raise ValueError("`times` applies to sampled `rates` only; got a function and times.")
            self._omega: Callable[[float], np.ndarray] = self._checked(rates)
            self.times = None
        else:
            self._omega = self._sampled(rates, times)
        self.group = SO(self.n)
        self.fields = {"R": (self.n, self.n)}

    def _as_skew(self, value, name: str) -> np.ndarray:
        arr = as_float_array(value, name)
        if arr.shape == (3,) and self.n == 3:
            return hat(arr)
        if arr.shape == (self.n, self.n) and np.allclose(arr, -arr.T, rtol=0, atol=1e-12 * max(1.0, np.abs(arr).max())):
            return arr
        raise ValueError(
            f"`{name}` must be a body rate vector (3,) (n = 3) or a skew ({self.n}, {self.n}) matrix; "
            f"got {describe(arr)}."
        )

    def _checked(self, fn):
        def omega(t):
            return self._as_skew(fn(float(t)), f"rates({float(t):g})")

        omega(0.0)  # fail early with a clear message
        return omega

    def _sampled(self, rates, times):
        from scipy.interpolate import CubicSpline

        if times is None:
            raise ValueError("`times` is required with sampled `rates` (one time per sample).")
        t = as_float_array(times, "times")
        w = as_float_array(rates, "rates")
        if t.ndim != 1 or t.size < 4 or np.any(np.diff(t) <= 0):
            raise ValueError(f"`times` must be at least 4 strictly increasing times; got {describe(t)}.")
        if w.shape == (t.size, 3) and self.n == 3:
            w = hat(w)
        if w.shape != (t.size, self.n, self.n) or not np.allclose(w, -np.swapaxes(w, -1, -2), atol=1e-12):
            raise ValueError(
                f"`rates` must be samples (m, 3) (n = 3) or skew matrices (m, {self.n}, {self.n}) with m = "
                f"{t.size} = len(times); got shape {w.shape}."
            )
        self.times = t
        spline = self._spline = CubicSpline(t, w, axis=0)

        def omega(s):
            s = float(s)
            # a step may overshoot by round-off; beyond that the samples say nothing
            if not t[0] - 1e-12 * max(1.0, abs(t[0])) <= s <= t[-1] + 1e-12 * max(1.0, abs(t[-1])):
                raise ValueError(f"the body rates are sampled on [{t[0]}, {t[-1]}]; asked for t = {s}.")
            X = spline(s)
            return 0.5 * (X - X.T)

        return omega

    # -- the LieGroupSystem contract ---------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray:
        X = self._omega(float(np.asarray(t).reshape(-1)[0]))  # ξ depends on one time only
        batch = self.batch_shape(y)
        return np.broadcast_to(X, (*batch, self.n, self.n)).copy() if batch else X

    def body_rates(self, times: ArrayLike) -> np.ndarray:
        """Ω at each of ``times`` (what :meth:`body_rate` gives at one): sampled rates' spline
        evaluated at all of them at once, a rates function called at each.

        Parameters
        ----------
        times : array_like, shape (m,)
            Times (inside the samples' range for sampled rates).

        Returns
        -------
        ndarray, shape (m, n, n)
            Ω at each time, skew.
        """
        t = np.asarray(times, dtype=float).reshape(-1)
        if self._spline is None or t.size == 0:
            return np.array([self._omega(s) for s in t]).reshape(t.size, self.n, self.n)
        lo, hi = self.times[0], self.times[-1]
        outside = (t < lo - 1e-12 * max(1.0, abs(lo))) | (t > hi + 1e-12 * max(1.0, abs(hi)))
        if outside.any():
            raise ValueError(f"the body rates are sampled on [{lo}, {hi}]; asked for t = {t[np.argmax(outside)]}.")
        X = self._spline(t)
        return 0.5 * (X - np.swapaxes(X, -1, -2))

    def compiled(self) -> PrescribedForm | None:
        """The compiled engine's form (:class:`lieint.fast.forms.PrescribedForm`): n and
        :meth:`body_rates`, which the Magnus methods' steps read at their nodes; None for a
        subclass with other dynamics.

        Returns
        -------
        PrescribedForm or None
            The form (one object per system), or None.
        """
        if not self.dynamics_as(PrescribedRotation, _DYNAMICS):
            return None
        form = self.__dict__.get("_form")
        if form is None:
            form = self.__dict__["_form"] = PrescribedForm(self.n, self.body_rates)
        return form

    def body_rate(self, t: float) -> np.ndarray:
        """Ω(t), the prescribed body angular velocity.

        Parameters
        ----------
        t : float
            One time (inside the samples' range for sampled rates).

        Returns
        -------
        ndarray, shape (n, n)
            Ω(t), skew.
        """
        return self._omega(float(t))

    def act(self, g: np.ndarray, y: State) -> State:
        return {"R": y["R"] @ g}

    def relative_element(self, y0: State, y1: State) -> np.ndarray:
        """``g = R₀ᵀ R₁``.

        Parameters
        ----------
        y0, y1 : dict of ndarray
            The states at the two ends of a step.

        Returns
        -------
        ndarray, shape (..., n, n)
            ``R₀ᵀ R₁``.
        """
        return np.swapaxes(y0["R"], -1, -2) @ y1["R"]

    def infinitesimal_action(self, xi: np.ndarray, y: State) -> State:
        return {"R": y["R"] @ xi}

    def project(self, y: State) -> State:
        return {"R": project_to_so(y["R"])}

    @property
    def invariants(self) -> dict[str, Invariant]:
        return {"orthogonality": orthogonality_invariant()}

    @property
    def outputs(self) -> dict[str, Output]:
        out = dict(super().outputs)
        out["orientation"] = Output(lambda t, y: y["R"], (self.n, self.n), "orientation R (body to space)", "rotation")
        return out

    def initial_state(self, *, R: ArrayLike | Rotation | None = None) -> State:
        """``{"R": R}`` (default: the identity).

        Parameters
        ----------
        R : array_like, shape (..., n, n), or scipy Rotation, optional
            The initial orientation, body to space.

        Returns
        -------
        dict of ndarray
            ``{"R": (*batch, n, n)}``.
        """
        R = np.eye(self.n) if R is None else as_rotation_array(R, "R")
        if R.shape[-2:] != (self.n, self.n):
            raise ValueError(f"`R` must have shape (..., {self.n}, {self.n}); got shape {R.shape}.")
        check_rotation(R, "R")
        return {"R": R.copy()}

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)
        check_rotation(out["R"], f"{name}['R']")
        return out
