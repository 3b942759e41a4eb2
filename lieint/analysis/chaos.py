"""Chaos indicators from the tangent map of the numerical flow: Lyapunov exponents and MEGNO.

Both carry tangent vectors along a run with the exact derivative of the method's map
(:mod:`lieint.tangent`), in the tangent coordinates of :func:`lieint.tangent.chart_of`
(docs/theory.md §12):

* :func:`lyapunov` — Benettin's algorithm (Benettin, Galgani, Giorgilli & Strelcyn 1980): k
  vectors, re-orthonormalised by a QR decomposition every ``every`` steps; the exponents are
  the time averages of ``log |diag R|``. The limit does not depend on the norm of the
  coordinates; at finite times it does by ``O(1/t)``.
* :func:`megno` — the Mean Exponential Growth factor of Nearby Orbits (Cincotta & Simó 2000):
  ``Y(t) = (2/t) ∫₀ᵗ s d(log |δ|)`` and its running mean ``⟨Y⟩(t)``; ``⟨Y⟩ → 2`` for
  quasi-periodic motion, ``→ 0`` near a stable periodic orbit, and it grows like ``λt/2`` for
  chaotic motion. The integral is summed step by step, ``s`` the midpoint of each step, and
  ``⟨Y⟩`` by the trapezoidal rule (second order in h; a one-sided sum would add ``O(h/t)``).

The tangent vectors are renormalised before their growth could reach the complex step's
limit (a vector grown by 10²⁰ would make ``ε²|v|²`` felt in the real part). The steps run on the
compiled engine where the method's tangent steps are compiled (the 3D top's RKMK methods,
splittings and Moser–Veselov maps, the RKMK methods of the n-D top, the 3D heavy top and ball,
:mod:`lieint.tangent.compiled`),
the whole run in one call of the loop: the re-orthonormalisations (modified Gram–Schmidt in the
chart's norm) and MEGNO's sums are taken in the steps there. Elsewhere they run on the generic
path; ``backend_reason`` says which.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..methods.base import Method
from ..systems.base import LieGroupSystem
from ..tangent.coordinates import TangentChart
from ..tangent.flow import BACKEND_REASON, TangentStepper, step_schedule

__all__ = ["LyapunovSpectrum", "Megno", "lyapunov", "megno"]


@dataclass(frozen=True)
class LyapunovSpectrum:
    """Lyapunov exponents of a run and how they converged.

    Attributes
    ----------
    exponents : ndarray, shape (..., k)
        The k largest exponents at the end of the run, in decreasing order (1/time).
    t : ndarray, shape (m,)
        The times of the history (every re-orthonormalisation).
    history : ndarray, shape (m, ..., k)
        The exponents as estimated up to each time of ``t``.
    y : dict of ndarray
        The final state.
    chart : TangentChart
        The tangent coordinates.
    method : str
        The method's name.
    h : float
        The step.
    backend_reason : str
        Where the tangent steps ran: the compiled engine (:mod:`lieint.tangent.compiled`) or
        the generic path, and why.
    """

    exponents: np.ndarray
    t: np.ndarray
    history: np.ndarray
    y: dict = field(repr=False)
    chart: TangentChart = field(repr=False)
    method: str = ""
    h: float = 0.0
    backend_reason: str = BACKEND_REASON

    def pairing_defect(self) -> np.ndarray:
        """``max_i |λ_i + λ_{k+1−i}|`` per body: zero for a full Hamiltonian spectrum (± pairs).

        Returns
        -------
        ndarray, shape (...)
            The largest sum of paired exponents (meaningful when k is the whole dimension).
        """
        return np.max(np.abs(self.exponents + self.exponents[..., ::-1]), axis=-1)


@dataclass(frozen=True)
class Megno:
    """MEGNO of a run: ``⟨Y⟩`` and its history.

    Attributes
    ----------
    mean : ndarray, shape (...)
        ``⟨Y⟩`` at the end of the run (→ 2 quasi-periodic, grows like ``λt/2`` chaotic).
    t : ndarray, shape (m,)
        The times of the history (every step, or every ``save_every``-th).
    y_history : ndarray, shape (m, ...)
        ``Y(t)``.
    mean_history : ndarray, shape (m, ...)
        ``⟨Y⟩(t)``.
    lyapunov : ndarray, shape (...)
        The largest exponent estimated from the same vector, ``log|δ(T)|/T``.
    lyapunov_history : ndarray, shape (m, ...)
        ``log|δ(t)|/t`` at the times ``t`` (→ 0 like ``log(t)/t`` on a torus).
    y : dict of ndarray
        The final state.
    method : str
        The method's name.
    h : float
        The step.
    backend_reason : str
        Where the tangent steps ran: the compiled engine (:mod:`lieint.tangent.compiled`) or
        the generic path, and why.
    """

    mean: np.ndarray
    t: np.ndarray
    y_history: np.ndarray
    mean_history: np.ndarray
    lyapunov: np.ndarray
    lyapunov_history: np.ndarray
    y: dict = field(repr=False)
    method: str = ""
    h: float = 0.0
    backend_reason: str = BACKEND_REASON


def _start(system, y0, t_span, h, method, coordinates, backend="auto"):
    stepper = TangentStepper(system, method, coordinates, backend)
    y = system.validate_state(y0)
    t0, t1, starts, sizes = step_schedule(t_span, h, None)
    return stepper, y, t0, t1, starts, sizes


def _initial_vectors(chart: TangentChart, batch: tuple[int, ...], k: int, vectors, seed: int) -> np.ndarray:
    """k orthonormal starting vectors per body: the user's, or random ones (seeded)."""
    if vectors is None:
        V = np.random.default_rng(seed).normal(size=(*batch, chart.dim, k))
    else:
        V = np.asarray(vectors, dtype=float)
        if V.shape[-1] != chart.dim or V.shape[0] != k:
            raise ValueError(f"`vectors` must have shape ({k}, {chart.dim}); got shape {V.shape}.")
        V = np.broadcast_to(np.moveaxis(V, 0, -1), (*batch, chart.dim, k))
    Q, Rm = np.linalg.qr(V)
    if np.any(np.abs(np.diagonal(Rm, axis1=-2, axis2=-1)) < 1e-12):
        raise ValueError("`vectors` must be linearly independent.")
    return np.moveaxis(Q, -1, 0)


def _check_count(k, dim: int, name: str) -> int:
    if k is None:
        return dim
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= dim:
        raise ValueError(f"`{name}` must be an integer from 1 to the tangent dimension {dim}; got {k!r}.")
    return int(k)


def _check_every(every) -> int:
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"`every` must be a positive integer (steps between re-orthonormalisations); got {every!r}.")
    return int(every)


def lyapunov(
    system: LieGroupSystem,
    y0: dict[str, ArrayLike],
    t_span: tuple[float, float],
    h: float,
    method: str | Method = "rkmk4",
    *,
    k: int | None = None,
    coordinates: str | None = None,
    every: int = 10,
    vectors: ArrayLike | None = None,
    seed: int = 0,
    backend: str = "auto",
) -> LyapunovSpectrum:
    """Lyapunov exponents of a run (Benettin's QR algorithm on the exact tangent map).

    Parameters
    ----------
    system : LieGroupSystem
        The system.
    y0 : dict of array_like
        The initial state (a batch of bodies gives each its spectrum).
    t_span : tuple of float
        ``(t0, t1)``.
    h : float
        The fixed step (the grid of :func:`lieint.integrate`).
    method : str or Method, default "rkmk4"
        The method (one with a tangent map: :data:`lieint.tangent.flow.REFUSED`).
    k : int, optional
        How many exponents (the largest k); default the whole tangent dimension.
    coordinates : {"exp", "cayley"}, optional
        The coordinate map of a Lie-group method.
    every : int, default 10
        Steps between re-orthonormalisations (and history entries).
    vectors : array_like, shape (k, dim), optional
        The initial tangent vectors (orthonormalised first); default random, from ``seed``.
    seed : int, default 0
        Seed of the random initial vectors.
    backend : {"auto", "numpy", "numba"}, default "auto"
        Where the tangent steps run (:class:`lieint.tangent.TangentStepper`: the compiled
        engine where the method's tangent steps are compiled); ``backend_reason`` says.

    Returns
    -------
    LyapunovSpectrum
        The exponents, in decreasing order, and their history.

    Raises
    ------
    ValueError
        A bad argument, named; a method without a tangent map.

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> spec = lieint.lyapunov(top, y0, (0.0, 50.0), h=0.05)
    >>> spec.exponents.shape, bool(abs(spec.exponents).max() < 0.2)  # regular: all → 0 like log(t)/t
    ((3,), True)
    """
    stepper, y, t0, t1, starts, sizes = _start(system, y0, t_span, h, method, coordinates, backend)
    chart = stepper.chart
    k = _check_count(k, chart.dim, "k")
    every = _check_every(every)
    batch = system.batch_shape(y)
    V = _initial_vectors(chart, batch, k, vectors, seed)
    z = stepper.seed(y, V)
    state = stepper.init(t0, z, float(sizes[0]))
    if not stepper.compiled_reason and state is None:
        times, history_arr, y = _lyapunov_compiled(stepper, z, starts, sizes, every, t0, t1, float(h))
    else:
        times, history_arr, y = _lyapunov_steps(stepper, z, state, starts, sizes, every, t0, t1, h, batch, k)
    order = np.argsort(-history_arr[-1], axis=-1)
    exps = np.take_along_axis(history_arr[-1], order, axis=-1)
    hist = np.take_along_axis(history_arr, np.broadcast_to(order, history_arr.shape), axis=-1)
    return LyapunovSpectrum(
        exps, np.asarray(times), hist, y, chart, stepper.method.name, float(h), stepper.backend_reason
    )


def _lyapunov_steps(stepper, z, state, starts, sizes, every, t0, t1, h, batch, k):
    """:func:`lyapunov`'s steps and QR decompositions on the generic path: the times of the
    history, the history ``(m, *batch, k)`` and the final state."""
    sums = np.zeros((*batch, k))
    times, history = [], []
    n = len(sizes)
    y = None
    with np.errstate(over="ignore", invalid="ignore"):
        for first in range(0, n, every):  # `every` steps (compiled where they can be), then a QR
            last_of = min(first + every, n)
            z, state = stepper.advance(z, starts[first:last_of], sizes[first:last_of], state)
            step = last_of - 1
            tk, hk = starts[step], sizes[step]
            last = step == n - 1
            y, W = stepper.split(z)
            Q, Rm = np.linalg.qr(np.moveaxis(W, 0, -1))  # (*b, dim, k), (*b, k, k)
            growth = np.abs(np.diagonal(Rm, axis1=-2, axis2=-1))
            if not np.all(np.isfinite(growth)) or np.any(growth == 0):
                raise FloatingPointError(
                    f"the tangent vectors became non-finite or degenerate at t = {tk + hk:g}; reduce `h` = {h:g}."
                )
            sums += np.log(growth)
            t = t1 if last else float(tk + hk)
            times.append(t)
            history.append(sums / (t - t0))
            z = stepper.seed(y, np.moveaxis(Q, -1, 0))
    return times, np.asarray(history), y


def _lyapunov_compiled(stepper, z, starts, sizes, every: int, t0: float, t1: float, h: float):
    """:func:`lyapunov` on the compiled engine (:class:`lieint.tangent.compiled.CompiledLyapunov`:
    the steps and the re-orthonormalisations in one call of the loop)."""
    from ..tangent.compiled import COMPILED_REASON, CompiledLyapunov
    from ..tangent.flow import COMPLEX_STEP

    names = stepper.chart.names
    first = z[names[0]]
    k = first.shape[0]
    batch = first.shape[1 : first.ndim - len(stepper.system.fields[names[0]])]
    y = {name: np.ascontiguousarray(z[name][0].real) for name in names}
    dy = [{name: z[name][m].imag / COMPLEX_STEP for name in names} for m in range(k)]
    y1, sums, saves = CompiledLyapunov(stepper.system, stepper.method, k, batch, every, len(sizes)).run(
        y, dy, sizes, every
    )
    if not (np.all(np.isfinite(sums)) and all(np.all(np.isfinite(v)) for v in y1.values())):
        raise FloatingPointError(
            f"the tangent vectors became non-finite or degenerate before t = {t1:g}; reduce `h` = {h:g}."
        )
    times = starts[saves - 1] + sizes[saves - 1]
    times[-1] = t1  # the last step lands on t1, as the step-by-step sums take it
    stepper.backend_reason = COMPILED_REASON
    return list(times), sums / (times - t0).reshape((-1,) + (1,) * (sums.ndim - 1)), y1


def megno(
    system: LieGroupSystem,
    y0: dict[str, ArrayLike],
    t_span: tuple[float, float],
    h: float,
    method: str | Method = "rkmk4",
    *,
    coordinates: str | None = None,
    vector: ArrayLike | None = None,
    seed: int = 0,
    save_every: int = 1,
    backend: str = "auto",
) -> Megno:
    """MEGNO of a run (Cincotta & Simó 2000) from one tangent vector on the exact tangent map.

    Parameters
    ----------
    system : LieGroupSystem
        The system.
    y0 : dict of array_like
        The initial state (a batch of bodies: one MEGNO each, e.g. a map over a grid).
    t_span : tuple of float
        ``(t0, t1)``.
    h : float
        The fixed step.
    method : str or Method, default "rkmk4"
        The method (one with a tangent map).
    coordinates : {"exp", "cayley"}, optional
        The coordinate map of a Lie-group method.
    vector : array_like, shape (dim,), optional
        The initial tangent vector; default random, from ``seed``.
    seed : int, default 0
        Seed of the random initial vector.
    save_every : int, default 1
        Keep every ``save_every``-th step in the history (the sums use every step).
    backend : {"auto", "numpy", "numba"}, default "auto"
        Where the tangent steps run (:class:`lieint.tangent.TangentStepper`: the compiled
        engine where the method's tangent steps are compiled); ``backend_reason`` says.

    Returns
    -------
    Megno
        ``⟨Y⟩`` at the end, its history and the largest exponent from the same vector.

    Raises
    ------
    ValueError
        A bad argument, named; a method without a tangent map.

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    >>> y0 = top.initial_state(angular_velocity=[1.0, 0.3, 0.2])
    >>> result = lieint.megno(top, y0, (0.0, 200.0), h=0.05)
    >>> bool(abs(result.mean - 2.0) < 0.2)  # quasi-periodic
    True
    """
    stepper, y, t0, t1, starts, sizes = _start(system, y0, t_span, h, method, coordinates, backend)
    chart = stepper.chart
    save_every = _check_every(save_every)
    batch = system.batch_shape(y)
    V = _initial_vectors(chart, batch, 1, None if vector is None else np.asarray(vector)[None], seed)
    z = stepper.seed(y, V)
    state = stepper.init(t0, z, float(sizes[0]))
    if not stepper.compiled_reason and state is None:
        return _megno_compiled(stepper, z, starts, sizes, save_every, t0, t1, float(h))
    log_norm = np.zeros(batch)  # log|δ(t)|, renormalisations added back
    weighted = np.zeros(batch)  # ∫ s d log|δ|
    y_sum = np.zeros(batch)  # ∫ Y dt, by the trapezoidal rule (Y(t0) = 0)
    y_prev = np.zeros(batch)
    times, ys, means, exponents = [], [], [], []
    n = len(sizes)
    with np.errstate(over="ignore", invalid="ignore"):
        for step, (tk, hk) in enumerate(zip(starts, sizes, strict=True)):
            z, state = stepper.advance(z, starts[step : step + 1], sizes[step : step + 1], state)
            y, W = stepper.split(z)
            norm = np.linalg.norm(W[0], axis=-1)
            if not np.all(np.isfinite(norm)) or np.any(norm == 0):
                raise FloatingPointError(
                    f"the tangent vector became non-finite at t = {tk + hk:g}; reduce `h` = {h:g}."
                )
            last = step == n - 1
            t = t1 if last else float(tk + hk)
            dlog = np.log(norm)
            log_norm += dlog
            weighted += (0.5 * (tk + t) - t0) * dlog
            Y = 2.0 * weighted / (t - t0)
            y_sum += 0.5 * (y_prev + Y) * (t - tk)
            y_prev = Y
            if (step + 1) % save_every == 0 or last:
                times.append(t)
                ys.append(Y)
                means.append(y_sum / (t - t0))
                exponents.append(log_norm / (t - t0))
            z = stepper.seed(y, (W / norm[..., None]))
    return Megno(
        np.asarray(means[-1]),
        np.asarray(times),
        np.asarray(ys),
        np.asarray(means),
        log_norm / (t1 - t0),
        np.asarray(exponents),
        y,
        stepper.method.name,
        float(h),
        stepper.backend_reason,
    )


def _megno_compiled(stepper, z, starts, sizes, save_every: int, t0: float, t1: float, h: float) -> Megno:
    """:func:`megno` on the compiled engine (:class:`lieint.tangent.compiled.CompiledMegno`: the
    steps and the sums after each in one call of the loop)."""
    from ..tangent.compiled import COMPILED_REASON, CompiledMegno
    from ..tangent.flow import COMPLEX_STEP

    names = stepper.chart.names
    first = z[names[0]]
    batch = first.shape[1 : first.ndim - len(stepper.system.fields[names[0]])]
    y = {name: np.ascontiguousarray(z[name][0].real) for name in names}
    dy = {name: z[name][0].imag / COMPLEX_STEP for name in names}
    y1, sums, saves = CompiledMegno(stepper.system, stepper.method, batch).run(y, dy, sizes, save_every)
    if not (np.all(np.isfinite(sums)) and all(np.all(np.isfinite(v)) for v in y1.values())):
        raise FloatingPointError(f"the tangent vector became non-finite before t = {t1:g}; reduce `h` = {h:g}.")
    times = starts[saves - 1] + sizes[saves - 1]
    times[-1] = t1  # the last step lands on t1, as the step-by-step sums take it
    span = (times - t0).reshape((-1,) + (1,) * len(batch))
    means = sums[..., 3] / span
    exponents = sums[..., 1] / span
    return Megno(
        np.asarray(means[-1]),
        times,
        np.asarray(sums[..., 4]),
        means,
        sums[-1, ..., 1] / (t1 - t0),
        exponents,
        y1,
        stepper.method.name,
        h,
        COMPILED_REASON,
    )
