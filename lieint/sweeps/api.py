""":func:`sweep`: plan a sweep from a scene (or from systems and initial states) and run it."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from numpy.typing import ArrayLike

from .plan import SweepError, plan_from_scene, plan_from_systems

if TYPE_CHECKING:
    from distributed import Client

    from ..scenes import Scene
    from ..systems.base import LieGroupSystem
    from .engine import SweepReport

__all__ = ["sweep"]


def sweep(
    scene: Scene | str | os.PathLike | dict | None = None,
    vary: Sequence[str] | dict | None = None,
    *,
    out: str | os.PathLike,
    ensemble: int | None = None,
    seed: int = 0,
    spread: float | None = None,
    chunk: int | None = None,
    scheduler: str | Client | None = None,
    workers: int | None = None,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool | str = "auto",
    backend: str = "auto",
    systems: LieGroupSystem | Sequence[LieGroupSystem] | None = None,
    y0: Mapping[str, ArrayLike] | Sequence[Mapping[str, ArrayLike]] | None = None,
    t_span: tuple[float, float] | None = None,
    h: float | None = None,
    method: str = "rkmk4",
    coordinates: str | None = None,
    project: bool = False,
    save_every: int = 1,
    outputs: Sequence[str] = (),
    indicators: Sequence[str] = (),
    indicator_vector: ArrayLike | None = None,
    connect_timeout: float = 20.0,
) -> SweepReport:
    """Integrate a parameter and initial-condition sweep on dask and store it in Zarr.

    The members are the product of the varied scene keys' values and an ensemble of initial
    states; they are cut into chunks of ``chunk`` members, each integrated as one batched
    ensemble (compiled where a kernel covers the system) on a dask worker, and committed to the
    Zarr store ``out`` as it finishes. The result is the same, bit for bit, wherever and in
    whatever order the chunks run; an interrupted sweep continues with ``resume=True``.

    Parameters
    ----------
    scene : path, str, dict or Scene
        A scene TOML file, an embedded scene's name (``lieint scenes``), TOML text or its dict.
    vary : dict or list of str, optional
        ``{"body.principal_moments[0]": values, ...}`` or ``["KEY=START:STOP:NUM", ...]``
        (:func:`lieint.sweeps.parse_vary`); keys of ``[body]``, ``[support]``, ``[forces]``
        and ``[initial]`` (:mod:`lieint.sweeps.keys`).
    out : path
        The Zarr store to write (``SWEEP.zarr``).
    ensemble, seed, spread : optional
        ``ensemble`` initial states per point: the initial angular velocity (or Ω) plus a seeded
        Gaussian perturbation of standard deviation ``spread`` (default: the scene's
        ``[ensemble]`` spread). Without it the scene's own ``[ensemble]`` (if any) applies.
    chunk : int, optional
        Members per chunk (default: a multiple of the ensemble size giving about 32 chunks).
        Chunks are the unit of work, of retry and of resume.
    scheduler : None, str or distributed.Client
        None: a LocalCluster on this machine; ``"tcp://host:8786"``: an existing cluster;
        ``"synchronous"``: in this process, without dask.
    workers : int, optional
        Worker processes of the LocalCluster (default: the number of CPUs).
    resume, overwrite : bool
        Continue an interrupted store of the same sweep (committed chunks are skipped), or
        replace an existing one.
    progress : bool or "auto"
        dask's progress bar of the chunks ("auto": on a terminal).
    backend : {"auto", "numpy", "numba"}
        As for :func:`lieint.integrate`.
    systems, y0 : optional
        Instead of a scene: a system or list of systems (the parameter points; same state
        fields) and an initial state or list of states (each may be batched), all run by every
        system; then ``t_span`` and ``h`` are required and the arguments below apply.
    t_span : (float, float), optional
        ``(t0, t1)`` of a sweep of given systems (as :func:`lieint.integrate`).
    h : float, optional
        The step of a sweep of given systems (sweeps run fixed-step methods).
    method : str, default "rkmk4"
        The fixed-step method of a sweep of given systems (:func:`lieint.method_names`).
    coordinates : {"exp", "cayley"}, optional
        Its coordinate map (as :func:`lieint.integrate`).
    project : bool, default False
        Project the state onto its manifold after every step.
    save_every : int, default 1
        Store every k-th step (and the last one).
    outputs : sequence of str, default ()
        Outputs or invariants of the systems to store besides the state (a scene names its
        own in ``[output]``).
    indicators : sequence of str, default ()
        Chaos indicators to store per member, from ``"megno"`` (⟨Y⟩ at the end of the run:
        → 2 quasi-periodic, → 0 near a stable periodic orbit, grows like λt/2 if chaotic) and
        ``"lyapunov"`` (the largest Lyapunov exponent from the same tangent vector), both as
        :func:`lieint.megno` computes them on the exact tangent map of the sweep's method and
        step (:mod:`lieint.sweeps.indicators`; not compiled, and several times the cost of the
        integration). Each is a variable along ``member`` of the store: a MEGNO map of the grid.
    indicator_vector : array_like, shape (dim,), optional
        The initial tangent vector of every member, in the coordinates of
        :func:`lieint.tangent.chart_of` (default: :func:`lieint.megno`'s for one body, so that
        ``lieint.megno`` on one member reproduces its stored values).
    connect_timeout : float, default 20
        Seconds allowed to reach ``scheduler`` (an address), complete dask's handshake and check
        the versions of the scheduler and its workers — all before anything is created.

    Returns
    -------
    SweepReport
        Chunks computed and skipped, wall time, workers, back ends (:class:`~lieint.sweeps.engine.SweepReport`).

    Raises
    ------
    SweepError
        A key the scene does not have, a value that makes the scene invalid, an adaptive method
        (sweeps run fixed-step methods), an unknown indicator or one the method cannot give
        (no tangent map), an existing store without ``resume``/``overwrite``, a
        store of another sweep or not a lieint sweep store (``overwrite`` replaces nothing
        else), a store another process is writing (its pid, host and start time), a scheduler
        that cannot be reached or runs other versions, or a chunk that failed on every retry;
        :class:`~lieint.sweeps.store.NoSpaceError` (a SweepError) when the disk is full.
    lieint.limits.LimitError
        A sweep beyond a size limit (values, points, members, chunks, a chunk's memory,
        workers): the message names the flag and the environment variable that raises it.

    Examples
    --------
    Three Dzhanibekov tops with I₁ = 1, 1.25, 1.5, in this process (no cluster):

    >>> import os, tempfile, lieint
    >>> out = os.path.join(tempfile.mkdtemp(), "flip.zarr")
    >>> report = lieint.sweep(
    ...     "dzhanibekov", ["body.principal_moments[0]=1:1.5:3"], out=out, scheduler="synchronous", progress=False
    ... )
    >>> report.status, report.nmembers
    ('complete', 3)
    >>> import xarray as xr
    >>> ds = xr.open_zarr(out)
    >>> ds["body.principal_moments[0]"].values.tolist(), ds["drift_energy"].shape
    ([1.0, 1.25, 1.5], (3,))
    """
    from .engine import run_sweep

    if systems is not None or y0 is not None:
        if scene is not None or vary:
            raise SweepError("give either a `scene` (with `vary`) or `systems` and `y0`, not both")
        if systems is None or y0 is None or t_span is None or h is None:
            raise SweepError("a sweep of given systems needs `systems`, `y0`, `t_span` and `h`")
        if ensemble is not None:
            raise SweepError("`ensemble` applies to scenes; give the initial states as `y0`")
        plan = plan_from_systems(
            systems,
            y0,
            t_span,
            h=h,
            method=method,
            coordinates=coordinates,
            project=project,
            save_every=save_every,
            outputs=outputs,
            chunk=chunk,
            indicators=indicators,
            indicator_vector=indicator_vector,
        )
    else:
        if scene is None:
            raise SweepError("`scene` (a TOML file, an embedded scene's name, TOML text or a dict) is required")
        plan = plan_from_scene(
            scene,
            vary,
            ensemble=ensemble,
            seed=seed,
            spread=spread,
            chunk=chunk,
            indicators=indicators,
            indicator_vector=indicator_vector,
        )
    return run_sweep(
        plan,
        out,
        scheduler=scheduler,
        workers=workers,
        resume=resume,
        overwrite=overwrite,
        progress=progress,
        backend=backend,
        connect_timeout=connect_timeout,
    )
