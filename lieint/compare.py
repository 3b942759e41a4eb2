"""``lieint compare``: the main job, a work–precision study (:mod:`lieint.study`) on scenes.

The default scene is the embedded Dzhanibekov scene — an asymmetric 3D top (``I = (1, 2, 3)``)
started close to its unstable middle axis, where the body flips and the exact solution (Jacobi
elliptic functions, the attitude by quadrature) is the reference — integrated to T = 100.
``lieint compare SCENE ...`` studies the scenes named (embedded names or TOML files) and
``--all`` every embedded scene, so every built-in system.
"""

from __future__ import annotations

import sys
from dataclasses import replace

__all__ = ["DEFAULT_T_END", "add_compare_parser", "default_scene", "run_compare", "selected_scenes", "studies"]

DEFAULT_T_END = 100.0


def default_scene():
    """The default scene as a :class:`lieint.scenes.Scene`: the embedded Dzhanibekov top, T = 100."""
    from .scenes import embedded_scene

    return replace(embedded_scene("dzhanibekov"), t_end=DEFAULT_T_END, name="default scene (Dzhanibekov top)")


def add_compare_parser(sub, scene=None):
    """Add the ``compare`` sub-command to an ``argparse`` sub-parser collection."""
    import argparse

    from ._arguments import positive_float, positive_int

    scene = default_scene() if scene is None else scene
    moments = tuple(float(x) for x in scene.mass_tensor.trace() - scene.mass_tensor.diagonal())
    w0 = tuple(float(x) for x in scene.initial["angular_velocity"])
    cmp = sub.add_parser(
        "compare",
        help="work-precision study of the integrators on scenes (default: a 3D top near its unstable axis)",
        description=(
            "Work-precision study. On each scene every registered method that applies runs, swept over the "
            "step (fixed-step methods, around the scene's step) or the tolerance (adaptive RKMK pairs; scipy's "
            "solvers, plain and with their saved copies projected). Each point is timed after a warm-up "
            "(CPU and wall time, min and median) and records the back end that ran it (a fallback to the "
            "generic path is flagged). The error is taken over the whole state against the exact solution "
            f"where one exists (the default scene: a top with I = {moments} started at w = {w0}, close to its "
            "unstable middle axis, T = 100, with its attitude; a uniform ball on an incline) or else against "
            "DOP853 at rtol 1e-13 whose own error is estimated by a second run and printed; errors the "
            "reference cannot resolve are marked. Prints the table and the equal-cost table (error reached "
            "within each CPU budget), with numbered notes where a series' error is far above its rtol, and "
            "writes work_precision.csv/.json (with the machine and thread settings), work_precision.png "
            "(about eight representative methods), work_precision_<family>.png (one figure per method family, "
            "every series) and long_run.png (invariant drift at the scene's step) into --out-dir (one "
            "sub-directory per scene when several are studied). The printed table fits 120 columns; --wide "
            "prints every column."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    cmp.add_argument("scene", nargs="*", help="scene TOML files or embedded scene names (default: the default scene)")
    cmp.add_argument("--all", action="store_true", help="study every embedded scene (every built-in system)")
    cmp.add_argument(
        "--methods",
        help="comma-separated method names (default: every registered method that applies; 'all' is the same)",
    )
    cmp.add_argument("--repeats", type=positive_int, help="timed calls per point after the warm-up (3; --full: 5)")
    cmp.add_argument(
        "--threads", type=positive_int, default=1, help="threads of numba's compiled kernels during the study"
    )
    cmp.add_argument(
        "--backend",
        choices=("auto", "numpy"),
        default="auto",
        help="'numpy' runs every fixed-step method on the generic path (same-path comparisons)",
    )
    cmp.add_argument(
        "--max-seconds",
        type=positive_float,
        default=None,
        metavar="S",
        help="stop a method's sweep after a point taking more than S CPU seconds per call (listed as skipped; "
        "default: 1 s, with --full 5 s)",
    )
    cmp.add_argument(
        "--compile-jobs",
        type=positive_int,
        default=None,
        metavar="N",
        help="on a cold numba cache, compile the kernels of the compiled series before the study in N processes at "
        "once (default: one per usable CPU; 1: in this process as each series starts)",
    )
    cmp.add_argument("--full", action="store_true", help="the full sweep (6-8 points per method) and 5 repeats")
    cmp.add_argument("--t-end", type=positive_float, help="override the scenes' span (T = t_end - t_start)")
    cmp.add_argument("--out-dir", default="lieint-compare", help="where the tables and figures go")
    cmp.add_argument("--no-plots", action="store_true", help="write the tables only")
    cmp.add_argument(
        "--wide",
        action="store_true",
        help="print every column (min and median CPU and wall time, evaluations, variant); the default "
        "table fits 120 columns",
    )
    cmp.add_argument(
        "--long-run", type=positive_float, default=10.0, metavar="FACTOR", help="span of long_run.png in scene spans"
    )
    cmp.add_argument(
        "--format",
        choices=("table", "markdown", "csv", "json"),
        default="table",
        help="printed output: aligned text, Markdown, CSV or JSON (the files are always written)",
    )
    return cmp


def selected_scenes(names, all_scenes: bool, t_end=None) -> dict:
    """``{key: Scene}`` for the command line's scene arguments (see ``lieint compare --help``)."""
    from pathlib import Path

    from .scenes import SceneError, embedded_scenes, load_scene

    embedded = embedded_scenes()
    scenes = {}
    if all_scenes:
        scenes.update(embedded)
    for name in names:
        if Path(name).exists() or name.endswith(".toml"):
            scenes[Path(name).stem] = load_scene(name)
        elif name in embedded:
            scenes[name] = embedded[name]
        else:
            raise SceneError(
                f"no scene file {name!r} and no embedded scene of that name (embedded: {sorted(embedded)})"
            )
    if not scenes:
        scenes["default"] = default_scene()
    if t_end is not None:
        scenes = {k: replace(s, t_end=s.t_start + t_end) for k, s in scenes.items()}
    return scenes


def studies(args):
    """Yield ``(key, Study)`` for each scene of parsed ``lieint compare`` arguments — the one
    place that turns a command line into studies (``benchmarks/guide_tables.py`` uses it too, so
    a table printed next to a command is what that command computes)."""
    from .study import run_study

    scenes = selected_scenes(args.scene, args.all, args.t_end)
    methods = None
    if args.methods and args.methods.strip() != "all":
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    repeats = args.repeats or (5 if args.full else 3)
    several = len(scenes) > 1
    for key, scene in scenes.items():
        yield (
            key,
            run_study(
                scene,
                methods=methods,
                quick=not args.full,
                repeats=repeats,
                threads=args.threads,
                backend=args.backend,
                max_seconds="auto" if args.max_seconds is None else args.max_seconds,
                skip_inapplicable=several,  # over several scenes a named method may not apply to all
                compile_jobs=getattr(args, "compile_jobs", None),
            ),
        )


def run_compare(args) -> int:
    """Carry out ``lieint compare`` for parsed arguments; returns the exit status."""
    import json
    from pathlib import Path

    from .scenes import SceneError
    from .study import (
        as_dict,
        format_rows,
        plot_long_run,
        plot_work_precision,
        plot_work_precision_families,
        write_table,
    )

    try:
        several = len(selected_scenes(args.scene, args.all, args.t_end)) > 1
    except SceneError as exc:
        print(f"lieint compare: {exc}", file=sys.stderr)
        return 2
    if not args.no_plots:  # before the study's minute of work, not after it
        from ._optional import MissingExtraError, require

        try:
            require("matplotlib", "the figures of lieint compare")
        except MissingExtraError as exc:
            print(f"lieint compare: {exc} (or pass --no-plots for the tables only)", file=sys.stderr)
            return 2
    text = args.format in ("table", "markdown")
    out_root = Path(args.out_dir)
    results = []
    runs = studies(args)
    while True:
        try:
            key, study = next(runs)
        except StopIteration:
            break
        except (SceneError, ValueError) as exc:
            print(f"lieint compare: {exc}", file=sys.stderr)
            return 2
        out_dir = out_root / key if several else out_root
        written = list(write_table(study, out_dir))
        if not args.no_plots:
            written.append(plot_work_precision(study, out_dir / "work_precision.png"))
            written.extend(plot_work_precision_families(study, out_dir))
            written.append(plot_long_run(study.scene, out_dir / "long_run.png", factor=args.long_run))
        results.append(study)
        if text:
            _print_text(study, args.format, written, getattr(args, "wide", False))
        elif args.format == "csv":
            print(f"# scene: {study.scene.name}")
            print(format_rows(study, "csv"))
    if args.format == "json":
        data = [as_dict(s) for s in results]
        print(json.dumps(data[0] if len(data) == 1 else data, indent=2, allow_nan=False))
    return 0


def _print_text(study, fmt, written, wide: bool = False) -> None:
    import textwrap

    from .study import format_equal_cost, format_rows
    from .study.notes import rtol_notes

    meta = study.metadata
    machine = meta["machine"]
    heading = "## " if fmt == "markdown" else ""
    width = 118

    def say(text: str) -> None:
        if fmt == "markdown":
            print(text)
        else:
            print(textwrap.fill(text, width, subsequent_indent="  ", break_on_hyphens=False, break_long_words=False))

    say(f"{heading}{study.describe()}")
    variant = {v.name for e in study.plan if e.family != "scipy" for v in e.variants}
    say(
        f"machine: {machine['processor']}, {machine['cpu_count']} CPUs, load average {machine['load_average']}; "
        f"numba threads {meta['numba_threads']}; {meta['sweep']} sweep, up to {meta['repeats']} timed calls per "
        f"point after a warm-up; CPU = median per call in ms; lieint's methods: {', '.join(sorted(variant)) or '—'}; "
        "scipy's solvers plain and with projected saves (proj.); '*' = not resolved by the reference; "
        "'!' = fallback to the generic path"
    )
    print()
    wide = wide or fmt == "markdown"  # Markdown tables are for pages, not terminals: every column
    print(format_rows(study, fmt, wide=wide))
    print()
    print("error reached within a CPU budget (best measured point with median CPU time <= the budget):")
    print(format_equal_cost(study, fmt, wide=wide))
    notes = rtol_notes(study)
    if notes:
        print()
    for note in notes:
        say(f"[{note.number}] {note.text}")
    fallbacks = [r for r in study.rows if r.fallback]
    for r in fallbacks:
        say(f"fallback: {r.method} {r.setting} ran on the generic path: {r.backend_reason}")
    for name, reason in meta["not_applicable"].items():
        say(f"not applicable: {name}: {reason}")
    for skip in meta["skipped"]:
        say(f"skipped: {skip['method']} ({skip['variant']}) {', '.join(skip['settings'])}: {skip['reason']}")
    for r in study.rows:
        if not r.success:
            say(f"failed: {r.method} ({r.variant}) {r.setting}: {r.message}")
    say("wrote " + ", ".join(str(p) for p in written))
    print()
