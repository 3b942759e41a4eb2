"""The ``lieint`` command line: thin -- parse, build, call the library, print."""

from __future__ import annotations

import argparse
import math
import sys
import warnings

from ._arguments import positive_float, positive_int

__all__ = ["main"]


def _build_parser() -> argparse.ArgumentParser:
    from .compare import add_compare_parser, default_scene

    scene = default_scene()
    parser = argparse.ArgumentParser(prog="lieint", description="Structure-preserving integrators for rigid bodies.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    add_compare_parser(sub, scene)
    sub.add_parser(
        "methods",
        help="list the method names lieint.integrate accepts",
        description="List the method names lieint.integrate accepts, with family, order and coordinates.",
    )
    run = sub.add_parser(
        "run",
        help="integrate a scene (a TOML file, or the name of an embedded scene)",
        description=(
            "Integrate a scene: a TOML file declaring body, support, forces, initial state, integrator "
            "and outputs (see `lieint scenes` for the embedded examples, `lieint scenes --show NAME` for "
            "their text). Only the effects the scene calls for are simulated. Prints the system that was "
            "assembled, the run's cost, and for each requested output its drift (invariants) or its final "
            "value (states)."
        ),
    )
    run.add_argument("scene", help="path of a scene TOML file, or the name of an embedded scene")
    run.add_argument(
        "--save",
        metavar="FILE.npz",
        help="also save the saved times and the requested outputs to a NumPy .npz file (plain arrays)",
    )
    run.add_argument(
        "--out",
        metavar="RUN.h5",
        help="stream states, times and invariants into this HDF5 file as the run goes (flat memory, "
        "checkpoints, resumable); without it the run is held in memory",
    )
    run.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    run.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted --out run from its checkpoint (RUN.h5.checkpoint)",
    )
    run.add_argument(
        "--checkpoint-every",
        type=positive_int,
        metavar="STEPS",
        help="write the checkpoint every STEPS steps (besides every --checkpoint-seconds, default 60 s)",
    )
    run.add_argument(
        "--checkpoint-seconds",
        type=positive_float,
        default=60.0,
        metavar="S",
        help="write the checkpoint at least every S seconds of wall time (default: 60)",
    )
    run.add_argument(
        "--stop-after",
        type=positive_int,
        metavar="STEPS",
        help="stop (resumable with --resume) after STEPS steps of this call",
    )
    run.add_argument("--quiet", action="store_true", help="no progress bar or progress lines")
    run.add_argument(
        "--monitor-every",
        type=positive_int,
        metavar="STEPS",
        help="print each saved invariant's drift so far every STEPS steps",
    )
    run.add_argument(
        "--max-drift",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="stop the run once the drift of invariant NAME exceeds VALUE (repeatable)",
    )
    run.add_argument(
        "--max-error-estimate",
        type=positive_float,
        metavar="E",
        help="with --out: carry the run's estimated global error (as lieint.trust_horizon) and report when it first "
        "exceeds E (printed, and recorded for lieint info); the run goes on",
    )
    run.add_argument(
        "--stop-at-horizon",
        action="store_true",
        help="with --max-error-estimate: stop the run once every member's estimated error exceeds E",
    )
    plot = sub.add_parser(
        "plot",
        help="draw a streamed run: invariant drifts, orientation or contact path, spread",
        description="Draw what a streamed run holds (lieint run --out RUN.h5): each invariant's "
        "drift against time on log axes, the orientation (body axis) or the contact "
        "path, and for ensembles the spread over members (median and 10-90%% band).",
    )
    plot.add_argument("run", metavar="RUN.h5", help="the HDF5 file written by lieint run --out")
    plot.add_argument("--out", metavar="FIG", help="output figure, .png or .svg (default: RUN.png beside the file)")
    plot.add_argument(
        "--timeout",
        type=positive_float,
        default=20.0,
        metavar="S",
        help="seconds allowed for reading the file, all stages together (default: 20)",
    )
    info = sub.add_parser(
        "info",
        help="say what state a run file or sweep store is in (complete, interrupted and resumable, running, damaged)",
        description="Report the state of a run file written by lieint run --out, or of a sweep store written by "
        "lieint sweep --out: complete; running (the process holding it); interrupted, resumable or not and why; or "
        "damaged, with where (a run: superblock, a dataset's rows failing their Fletcher-32 checksum, attributes, "
        "checkpoint; a sweep: the chunks whose files fail their SHA-256). The whole command ends within --timeout "
        "seconds: what it could not read in that time is reported as not checked, never as damaged. Exit status 0 "
        "complete, 3 incomplete but intact, 1 damaged or unreadable, 5 could not check within the deadline.",
    )
    info.add_argument("run", metavar="RUN.h5|SWEEP.zarr", help="a run file (lieint run --out) or a sweep store")
    info.add_argument(
        "--timeout",
        type=positive_float,
        default=4.0,
        metavar="S",
        help="seconds allowed for reading and verifying it, all stages together (default: 4)",
    )
    scenes = sub.add_parser(
        "scenes",
        help="list the embedded example scenes",
        description="List the embedded example scenes, or print one with --show.",
    )
    scenes.add_argument("--show", metavar="NAME", help="print the TOML text of one embedded scene")
    analyze = sub.add_parser(
        "analyze",
        help="count toward integrability and decide holonomy for a scene's system",
        description="At the scene's initial state: the reduction equation (docs/theory.md §7) dim(phase space) - "
        "#independent integrals - isotropy - (1 if an invariant measure), with the numerical ranks, and "
        "whether the velocity constraint is holonomic (Frobenius test by Lie brackets). Nothing is integrated; "
        "an ensemble is analysed at its first member.",
    )
    analyze.add_argument("scene", help="a scene TOML file or an embedded scene's name")
    analyze.add_argument(
        "--integrals", choices=("momentum", "manakov"), default="momentum", help="which first integrals to count"
    )
    analyze.add_argument("--json", action="store_true", help="print JSON instead of the equation's form")
    analyze.add_argument(
        "--lyapunov",
        action="store_true",
        help="also integrate the scene and print its Lyapunov spectrum (exact tangent map of its method and step)",
    )
    analyze.add_argument(
        "--megno", action="store_true", help="also integrate the scene and print its MEGNO (2: regular; grows: chaotic)"
    )
    analyze.add_argument(
        "--max-error-estimate",
        type=float,
        default=None,
        metavar="TOL",
        help="also integrate the scene with its global error estimated (local errors by step doubling carried "
        "by the tangent map) and print the time at which the estimate exceeds TOL: the trust horizon",
    )
    analyze.add_argument(
        "--t-end",
        type=float,
        default=None,
        metavar="T",
        help="end of the run for --lyapunov/--megno/--max-error-estimate (default: the scene's)",
    )
    _add_sweep_parser(sub)
    return parser


def _add_sweep_parser(sub) -> None:
    warm = sub.add_parser(
        "warmup",
        help="compile the compiled engine's kernels ahead of the first run (clusters, CI)",
        description=(
            "Compile the compiled engine's kernels for the built-in systems (each with fixed-step RKMK in "
            "exponential and Cayley coordinates, the embedded pairs' controller loop, classical RK, the "
            "commutator-free and Crouch–Grossman methods and, for the tops, their maps and SIMD lanes) into "
            "numba's disk cache, so that later runs start at once. Items already cached "
            "take a fraction of a second."
        ),
    )
    warm.add_argument("systems", nargs="*", metavar="SYSTEM", help="which systems (default: all; see --list)")
    warm.add_argument("--list", action="store_true", help="list the systems warmup knows and exit")
    warm.add_argument(
        "--jobs",
        type=positive_int,
        default=None,
        metavar="N",
        help="processes compiling at once (default: one per usable CPU; numba compiles one kernel at a time in a "
        "process)",
    )
    sw = sub.add_parser(
        "sweep",
        help="integrate a parameter / initial-condition sweep of a scene on dask, into a Zarr store",
        description=(
            "Integrate the product of the varied scene keys (and an ensemble of initial states) in chunks, each "
            "one batched ensemble on a dask worker (a LocalCluster by default, or an existing cluster with "
            "--scheduler), committed to one Zarr store that xarray.open_zarr reads with the varied keys as "
            "coordinates. Keys: body.principal_moments[0], body.mass, forces.gravity.incline, "
            "initial.angular_velocity[2], ... --megno and --lyapunov also store each member's chaos indicators (a "
            "MEGNO map of the grid). An interrupted sweep continues with --resume."
        ),
    )
    sw.add_argument("scene", help="path of a scene TOML file, or the name of an embedded scene")
    sw.add_argument(
        "--vary",
        action="append",
        default=[],
        metavar="KEY=START:STOP:NUM",
        help="vary a scene key over NUM values from START to STOP (or KEY=V1,V2,...); repeatable: the product",
    )
    sw.add_argument("--ensemble", type=positive_int, metavar="N", help="N initial states per point (Gaussian)")
    sw.add_argument("--seed", type=int, default=0, help="seed of the ensemble (default: 0)")
    sw.add_argument(
        "--spread", type=float, help="standard deviation of the ensemble's perturbation (default: the scene's)"
    )
    sw.add_argument("--out", required=True, metavar="SWEEP.zarr", help="the Zarr store to write")
    where = sw.add_mutually_exclusive_group()
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="address of a running dask scheduler (tcp://host:8786), or 'synchronous' for this process",
    )
    where.add_argument("--workers", type=positive_int, metavar="K", help="worker processes of the local cluster")
    sw.add_argument("--chunk", type=positive_int, metavar="M", help="members per chunk (default: ~32 chunks)")
    sw.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted store: committed chunks are verified (SHA-256) and skipped, damaged ones "
        "recomputed",
    )
    sw.add_argument("--overwrite", action="store_true", help="replace an existing lieint sweep store (nothing else)")
    sw.add_argument(
        "--connect-timeout",
        type=positive_float,
        default=20.0,
        metavar="S",
        help="seconds allowed to reach --scheduler and check its versions (default: 20)",
    )
    sw.add_argument(
        "--megno",
        action="store_true",
        help="also store each member's MEGNO <Y> at the end (2: regular; grows: chaotic), on the exact tangent map",
    )
    sw.add_argument(
        "--lyapunov",
        action="store_true",
        help="also store each member's largest Lyapunov exponent (from the same tangent vector as --megno)",
    )
    sw.add_argument("--quiet", action="store_true", help="no progress bar")


def _warmup(args) -> int:
    import time

    from .warmup import WARMUP_SYSTEMS, warmup

    if args.list:
        print("\n".join(WARMUP_SYSTEMS))
        return 0
    unknown = [name for name in args.systems if name not in WARMUP_SYSTEMS]
    if unknown:
        print(f"lieint warmup: unknown system(s) {unknown}; choose from {list(WARMUP_SYSTEMS)}", file=sys.stderr)
        return 2
    wall = time.perf_counter()
    print(f"{'system':16} {'method family':34} {'CPU s':>7} {'wall s':>7}  state")

    def report(item):
        state = "compiled" if item.compiled else "cached"
        print(f"{item.system:16} {item.family:34} {item.cpu:7.2f} {item.wall:7.2f}  {state}", flush=True)

    items = warmup(args.systems or None, report=report, jobs=args.jobs)
    total = sum(item.cpu for item in items)
    print(
        f"{len(items)} kernels ready ({total:.1f} s CPU, {time.perf_counter() - wall:.1f} s wall); later runs load "
        "them from numba's disk cache."
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``lieint`` console script."""
    from ._optional import extra_of, missing_message

    parser = _build_parser()
    args = parser.parse_args(argv)
    try:
        return _dispatch(args, parser)
    except ModuleNotFoundError as exc:  # an optional dependency (figures, geometric algebra, sweeps)
        if extra_of(exc.name) is None:
            raise
        message = str(exc) if "pip install" in str(exc) else missing_message(exc.name, f"lieint {args.command}")
        print(f"lieint {args.command}: {message}", file=sys.stderr)
        return 2


def _dispatch(args, parser) -> int:
    """Run the sub-command of the parsed ``args``."""
    if args.command == "methods":
        from .methods import method_specs

        for name, spec in method_specs().items():
            order = "var" if spec.order is None else str(spec.order)
            coords = "/".join(spec.coordinates) or "-"
            print(f"{name:16s} {spec.family:14s} order {order:>3s}  coords {coords:10s} {spec.description}")
        return 0
    if args.command == "compare":
        return _compare(args, parser)
    if args.command == "scenes":
        return _scenes(args)
    if args.command == "run":
        if not args.out and (args.max_error_estimate is not None or args.stop_at_horizon):
            flag = "--max-error-estimate" if args.max_error_estimate is not None else "--stop-at-horizon"
            _error("run", f"{flag} applies to a streamed run (--out RUN.h5); for a run in memory use lieint analyze "
                   "SCENE --max-error-estimate E")  # fmt: skip
            return 2
        return _run_streamed(args) if args.out else _run(args)
    if args.command == "plot":
        return _plot(args)
    if args.command == "analyze":
        return _analyze(args)
    if args.command == "sweep":
        return _sweep(args)
    if args.command == "info":
        return _info(args)
    if args.command == "warmup":
        return _warmup(args)
    parser.print_help()
    return 0


def _info(args) -> int:
    from .runs.info import inspect_run
    from .sweeps.info import inspect_sweep, is_sweep_store

    inspect = inspect_sweep if is_sweep_store(args.run) else inspect_run
    report = inspect(args.run, timeout=args.timeout)
    print(printable_lines(report.text()))
    return report.exit_code


def printable_lines(text: str) -> str:
    """Each line of ``text`` with its control characters escaped (:func:`lieint.text.printable`)."""
    from .text import printable

    return "\n".join(printable(line) for line in text.split("\n"))


def _error(command: str, exc) -> None:
    """One line on standard error: the command and the message, escaped (a scene's text may
    hold terminal control codes)."""
    from .text import printable

    print(f"lieint {command}: {printable(exc)}", file=sys.stderr)


def _compare(args, parser) -> int:
    from .compare import run_compare

    return run_compare(args)


def _scenes(args) -> int:
    from .scenes import SceneError, embedded_scene, embedded_scenes

    if args.show:
        try:
            print(embedded_scene(args.show).text, end="")
        except SceneError as exc:
            print(f"lieint scenes: {exc}", file=sys.stderr)
            return 2
        return 0
    from .text import printable

    for name, scene in embedded_scenes().items():
        print(f"{name:16s} {printable(scene.name)}: {printable(scene.description)}")
    return 0


def _run_streamed(args) -> int:
    from .runs import StoreError, run
    from .runs.trust import describe_horizon as horizon_summary
    from .scenes import SceneError

    limits = {}
    for item in args.max_drift:
        name, sep, value = item.partition("=")
        try:
            limits[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep or not name.strip():
            print(f"lieint run: --max-drift expects NAME=VALUE (e.g. energy=1e-8); got {item!r}", file=sys.stderr)
            return 2
    try:
        report = run(
            args.scene,
            args.out,
            overwrite=args.overwrite,
            resume=args.resume,
            checkpoint_every=args.checkpoint_every,
            checkpoint_seconds=args.checkpoint_seconds,
            progress=False if args.quiet else "auto",
            monitor_every=args.monitor_every,
            max_drift=limits,
            stop_after=args.stop_after,
            max_error_estimate=args.max_error_estimate,
            stop_at_horizon=args.stop_at_horizon,
        )
    except (SceneError, StoreError, ValueError) as exc:
        _error("run", exc)
        return 2
    print(printable_lines(f"{report.message} -> {report.path}"))
    if report.trust_horizon is not None:
        print(horizon_summary(report.trust_horizon))
    if report.status == "failed":
        _error("run", f"the run failed: {report.message}")
    for name, value in report.drifts.items():
        print(f"  {name:16s} max drift {value:.3e}")
    if report.status == "no-space":
        _error("run", report.message)
        from .runs.store import hdf5_broken

        if hdf5_broken():  # HDF5's exit handler would retry the failed writes: leave without it
            import os

            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(4)
    return {"complete": 0, "interrupted": 130, "stopped": 3, "no-space": 4}.get(report.status, 1)


def _plot(args) -> int:
    from .runs.plot import PlotError, plot_run

    try:
        path = plot_run(args.run, args.out, timeout=args.timeout)
    except PlotError as exc:
        _error("plot", exc)
        return 2
    print(f"wrote {path}")
    return 0


def _run(args) -> int:
    from pathlib import Path

    import numpy as np

    from .scenes import SceneError, embedded_scenes, load_scene, run_scene
    from .scenes.engine import nonfinite_members
    from .text import printable

    try:
        if Path(args.scene).exists() or args.scene.endswith(".toml"):
            scene = load_scene(args.scene)
        else:
            known = embedded_scenes()
            if args.scene not in known:
                raise SceneError(
                    f"no scene file {args.scene!r} and no embedded scene of that name (embedded: {sorted(known)})"
                )
            scene = known[args.scene]
        result = run_scene(scene)
    except (SceneError, ValueError) as exc:  # bad input and refused limits: the message says why
        _error("run", exc)
        return 2
    sol, system = result.solution, result.system
    stopped = ""
    if not sol.success:
        bad = nonfinite_members(sol)
        which = f" (members {bad[:10]}{' …' if len(bad) > 10 else ''} of the ensemble, 0-based)" if bad else ""
        stopped = f" — STOPPED: {sol.message}{which}"
    print(f"{printable(scene.name)} — {system!r}")
    print(
        f"integrated: {', '.join(system.fields)} with {sol.method}, h = {scene.step:g}, "
        f"{sol.nsteps} steps ({sol.stats.nrejected} rejected), {sol.nfev} evaluations, "
        f"CPU {sol.stats.cpu_time:.3f} s, {sol.stats.backend}{printable(stopped)}"
    )
    for ev, times in zip(scene.events, sol.t_events or [], strict=False):
        shown = np.array2string(times[:10], precision=10, separator=", ")
        print(f"  event {ev['name']!r}: {times.size} times {shown}{' …' if times.size > 10 else ''}")
    for name, values in result.outputs.items():
        if name in system.invariants:
            drift = np.max(sol.drift(name))
            kind = "max size" if system.invariants[name].kind == "defect" else "max relative drift"
            print(f"  {name:16s} {kind} {drift:.3e}")
        else:
            final = np.asarray(values[-1])
            text = np.array2string(final, precision=6, suppress_small=True).replace("\n", "")
            print(f"  {name:16s} final {text if final.size <= 9 else f'array {final.shape}'}")
    if args.save:
        try:
            np.savez(args.save, t=sol.t, **result.outputs)
        except OSError as exc:
            print(f"lieint run: cannot write {args.save!r}: {exc.strerror or exc}", file=sys.stderr)
            return 2
        print(f"saved t and {', '.join(result.outputs)} to {args.save}")
    return 0 if sol.success else 1


def _sweep(args) -> int:
    from .limits import LimitError
    from .scenes import SceneError
    from .sweeps import SweepError, sweep
    from .sweeps.store import NoSpaceError

    try:
        report = sweep(
            args.scene,
            args.vary,
            out=args.out,
            ensemble=args.ensemble,
            seed=args.seed,
            spread=args.spread,
            chunk=args.chunk,
            scheduler=args.scheduler,
            workers=args.workers,
            resume=args.resume,
            overwrite=args.overwrite,
            progress=False if args.quiet else "auto",
            indicators=[name for name in ("megno", "lyapunov") if getattr(args, name)],
            connect_timeout=args.connect_timeout,
        )
    except NoSpaceError as exc:
        _error("sweep", exc)
        return 4
    except KeyboardInterrupt:
        # an interrupt in the middle of zarr's asynchronous writes leaves coroutines that were never
        # awaited, and Python warns of each as it is freed (when this handler returns, or at exit);
        # the committed chunks are kept and the sweep resumes, so they tell the user nothing: the
        # one line below is what happened
        warnings.filterwarnings("ignore", message="coroutine .* was never awaited", category=RuntimeWarning)
        _error("sweep", "interrupted; the committed chunks are kept: continue with --resume")
        return 130
    except (SceneError, SweepError, LimitError) as exc:
        _error("sweep", exc)
        return 2
    if report.damaged:
        shown = ", ".join(str(c) for c in sorted(report.damaged)[:10]) + (" …" if len(report.damaged) > 10 else "")
        _error("sweep", f"recomputed {len(report.damaged)} committed chunks that failed their checksums ({shown})")
    print(
        printable_lines(
            f"{report.nmembers} members in {report.nchunks} chunks ({report.computed} computed, {report.skipped} "
            f"already committed) on {report.scheduler}, {', '.join(report.backends) or '-'}, "
            f"{report.wall_time:.1f} s -> {report.path}"
        )
    )
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


def _analyze(args) -> int:
    import json
    from pathlib import Path

    from .analysis.scene import analysis_json, analyze_scene, format_analysis, scene_indicators
    from .scenes import SceneError, embedded_scenes, load_scene

    try:
        if Path(args.scene).exists() or args.scene.endswith(".toml"):
            scene = load_scene(args.scene)
        else:
            known = embedded_scenes()
            if args.scene not in known:
                raise SceneError(
                    f"no scene file {args.scene!r} and no embedded scene of that name (embedded: {sorted(known)})"
                )
            scene = known[args.scene]
        result = analyze_scene(scene, integrals=args.integrals)
        integrates = args.lyapunov or args.megno or args.max_error_estimate is not None
        if args.t_end is not None and not integrates:
            raise ValueError("--t-end applies to --lyapunov, --megno and --max-error-estimate only")
        if args.max_error_estimate is not None and not (
            math.isfinite(args.max_error_estimate) and args.max_error_estimate > 0
        ):
            raise ValueError(f"--max-error-estimate must be a finite positive error; got {args.max_error_estimate:g}")
        if args.t_end is not None and not (math.isfinite(args.t_end) and args.t_end > scene.t_start):
            raise ValueError(
                f"--t-end must be a finite time after the scene's t_start = {scene.t_start:g}; got {args.t_end:g}"
            )
        if integrates:
            result["indicators"] = scene_indicators(
                scene,
                lyapunov=args.lyapunov,
                megno=args.megno,
                max_error_estimate=args.max_error_estimate,
                t_end=args.t_end,
            )
    except (SceneError, ValueError) as exc:
        _error("analyze", exc)
        return 2
    # JSON escapes control characters itself; the lecture's form is printed escaped
    text = json.dumps(analysis_json(result), indent=2, ensure_ascii=False) if args.json else format_analysis(result)
    print(text if args.json else printable_lines(text))
    return 0
