"""Work–precision studies: what accuracy costs in time, on every scene, with nothing hidden.

A study (``lieint compare`` on the command line) runs, on one scene,

* every registered method that applies to the scene's system (:mod:`.plan`: the registry is
  read, so a method added in one new module joins without an edit here), swept over the step
  (fixed-step methods, around the scene's own step) or the tolerance (adaptive RKMK pairs and
  scipy's solvers, the latter without projection and with the saved copies projected);
* each point timed after a warm-up, CPU and wall time, min and median of the timed calls, with
  the back end that actually ran it and a fallback to the generic path flagged (:mod:`.measure`);
* the error over the whole state against the exact solution where one exists (the 3D top with
  its attitude; the uniform ball on an incline) or against DOP853 at rtol 1e-13 whose own error
  is estimated by a second run (:mod:`.reference`); errors the reference cannot resolve are
  marked;
* the machine and thread settings (:mod:`.machine`),

and writes the tables (:mod:`.table`: CSV/JSON with the metadata, an equal-cost table of the
error each method reaches within a CPU budget), the notes that explain what a reader sees
(:mod:`.notes`) and the figures (:mod:`.figures`).

Examples
--------
>>> from dataclasses import replace
>>> from lieint.compare import default_scene
>>> from lieint.study import run_study
>>> study = run_study(replace(default_scene(), t_end=2.0), methods=["rkmk4"], repeats=1)
>>> {row.backend for row in study.rows}
{'numba'}
"""

from __future__ import annotations

from .figures import plot_long_run, plot_work_precision, plot_work_precision_families
from .machine import machine_info, set_threads
from .measure import StudyRow, Timing, timed
from .plan import PlanEntry, Variant, study_plan
from .reference import Reference, reference_for, state_error
from .sweep import DEFAULT_THREADS, MAX_SECONDS, QUICK_MAX_SECONDS, Study, prepare, run_study_full
from .table import as_dict, equal_cost, format_equal_cost, format_rows, write_table

__all__ = [
    "DEFAULT_THREADS",
    "MAX_SECONDS",
    "QUICK_MAX_SECONDS",
    "PlanEntry",
    "Reference",
    "Study",
    "StudyRow",
    "Timing",
    "Variant",
    "as_dict",
    "equal_cost",
    "format_equal_cost",
    "format_rows",
    "machine_info",
    "plot_long_run",
    "plot_work_precision",
    "plot_work_precision_families",
    "prepare",
    "reference_for",
    "run_study",
    "set_threads",
    "state_error",
    "study_plan",
    "timed",
    "write_table",
]


def run_study(
    scene,
    *,
    methods=None,
    quick: bool = True,
    repeats: int = 3,
    threads: int | None = DEFAULT_THREADS,
    backend: str = "auto",
    max_seconds: float | str | None = "auto",
    skip_inapplicable: bool = False,
    progress=None,
    compile_jobs: int | None = 1,
) -> Study:
    """Run the work–precision study of ``scene``.

    Parameters
    ----------
    scene : Scene
        The scene (its span, step, ``project`` flag and tolerance set the sweeps).
    methods : None, "all" or list of str
        Every registered method that applies (None, "all"), or these names.
    quick : bool, default True
        The quick sweep (4 steps or tolerances per method) or the full one.
    repeats : int, default 3
        Timed calls per point after the warm-up (fewer for slow points, see ``max_seconds``).
    threads : int or None, default 1
        Threads of numba's compiled kernels during the study (None: numba's default); restored
        afterwards.
    backend : {"auto", "numpy"}
        "numpy" runs every fixed-step method on the generic path (same-path comparisons).
    max_seconds : float, "auto" or None, default "auto"
        A series (method and variant) stops after a point whose median CPU time per call
        exceeds this; the points left out are listed in ``metadata["skipped"]`` (None: never;
        "auto": ``QUICK_MAX_SECONDS`` = 1 s in the quick sweep, ``MAX_SECONDS`` = 5 s in the full
        one). Points slower than 0.5 s (quick) or 2 s (full) are timed once.
    skip_inapplicable : bool, default False
        Leave out named methods that do not apply to this scene's system, listing them with
        their reasons in ``metadata["not_applicable"]``, instead of raising ``ValueError``.
    progress : callable, optional
        Called with each :class:`StudyRow` as it is measured.
    compile_jobs : int or None, default 1
        Processes compiling at once when numba's disk cache is cold (None: one per usable CPU,
        what ``lieint compare`` uses); the kernels of every compiled series are then compiled
        before anything is timed, and ``metadata["compiled_ahead"]`` says how. With 1, each
        series compiles in this process as it starts. The processes are started by ``spawn``,
        which imports the caller's main module again: a script that asks for more than one
        keeps its work under ``if __name__ == "__main__":``.

    Returns
    -------
    Study
    """
    return run_study_full(
        scene,
        methods=methods,
        quick=quick,
        repeats=repeats,
        threads=threads,
        backend=backend,
        max_seconds=max_seconds,
        skip_inapplicable=skip_inapplicable,
        progress=progress,
        compile_jobs=compile_jobs,
    )
