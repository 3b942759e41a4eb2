"""Streaming runs: integrate a scene in segments, append to HDF5, checkpoint, monitor.

A run can be left overnight: memory stays flat, checkpoints are atomic, Ctrl-C stops cleanly at
the next segment boundary with everything flushed, and ``resume=True`` continues a run killed
even by SIGKILL, bit for bit (:mod:`lieint.runs.streamed`). Exactly one process writes a run
file (:mod:`lieint.runs.lock`), ``overwrite`` replaces only a lieint run
(:mod:`lieint.runs.files`), and a full disk or file-size limit ends the run resumable.

:class:`~lieint.runs.streamed.StreamedRun` is one run (``start`` or ``resume``, ``segment``,
``checkpoint``, ``finish``); :func:`run` drives it with progress, monitors, checkpoint timing
and Ctrl-C.
"""

from __future__ import annotations

import json
import math
import os
import signal
import stat
import sys
import threading
import time
from pathlib import Path
from typing import TextIO

import numpy as np

from ..scenes import Scene
from .progress import progress_bar
from .store import NoSpaceError, StoreError
from .streamed import RunReport, StreamedRun, human_bytes, scene_fingerprint

__all__ = ["RunReport", "StreamedRun", "run", "scene_fingerprint"]

_SEGMENT_SECONDS = 0.25  # aim for segments of about this wall time (progress, Ctrl-C latency)
_CROSSING_LINES = 10  # trust-horizon lines printed per call (an ensemble may have thousands)


# -- the run ---------------------------------------------------------------------------------------


def run(
    scene: Scene | str | os.PathLike,
    out: str | os.PathLike,
    *,
    overwrite: bool = False,
    resume: bool = False,
    checkpoint_every: int | None = None,
    checkpoint_seconds: float | None = 60.0,
    progress: bool | str = "auto",
    monitor_every: int | None = None,
    max_drift: dict[str, float] | None = None,
    stop_after: int | None = None,
    max_error_estimate: float | None = None,
    stop_at_horizon: bool = False,
    stream: TextIO | None = None,
) -> RunReport:
    """Integrate a scene, streaming the saved series into an HDF5 file.

    Exactly one process writes a run file: the run holds an OS-level lock on ``RUN.h5.lock``
    from before it looks at the file until it has ended (:mod:`lieint.runs.lock`); a second
    writer is refused at once with the holder's pid, host and start time.

    Parameters
    ----------
    scene : Scene, str or path
        A :class:`lieint.scenes.Scene`, a TOML path, or an embedded scene's name.
    out : str or path
        The HDF5 output; refused if it exists unless ``overwrite`` or ``resume``.
    overwrite, resume : bool
        Start anew over an existing output, or continue it from its checkpoint
        (``RUN.h5.checkpoint``), which must come from the same scene and lieint version.
        ``overwrite`` replaces only a lieint run file (:func:`lieint.runs.files.check_replaceable`).
    checkpoint_every : int, optional
        Write the checkpoint every this many steps (besides ``checkpoint_seconds``).
    checkpoint_seconds : float, optional
        ... and at least this often in wall time (default 60 s).
    progress : "auto", bool
        A tqdm bar on a terminal, periodic plain lines otherwise ("auto"); False is quiet.
    monitor_every : int, optional
        Print each saved invariant's drift so far every this many steps.
    max_drift : dict, optional
        ``{name: value}``: stop with a clear message once an invariant's drift (of any ensemble
        member, :mod:`lieint.drift`) exceeds value.
    stop_after : int, optional
        Stop (resumable, like an interruption) after this many steps of this call.
    max_error_estimate : float, optional
        Carry the run's estimated global error beside it (:func:`lieint.trust_horizon`'s
        estimate, on the run's grid: :mod:`lieint.runs.trust`) and report when it first
        exceeds this tolerance, member by member: a line on ``stream`` when it happens, the
        file's attribute ``trust_horizon`` (``lieint info``) and :attr:`RunReport.trust_horizon`.
        Needs a fixed-step method of known order with a tangent map; costs one complex step and
        two half steps of the generic numpy path per step, until every member has crossed.
    stop_at_horizon : bool, default False
        Stop the run (status "stopped", resumable) once every member has crossed
        ``max_error_estimate``.
    stream : file, optional
        Where progress and monitor lines go (default ``sys.stderr``).

    Returns
    -------
    RunReport
        ``status`` is "complete", "interrupted" (Ctrl-C or ``stop_after``), "stopped"
        (``max_drift``, ``stop_at_horizon``), "failed" (the state became non-finite) or
        "no-space" (the disk is full or the file-size limit was reached: the rows up to the
        last checkpoint are safe, resume once there is room).

    Examples
    --------
    >>> import os, tempfile, lieint
    >>> out = os.path.join(tempfile.mkdtemp(), "flip.h5")
    >>> report = lieint.run("dzhanibekov", out, progress=False)  # an embedded scene
    >>> report.status, report.rows, sorted(report.drifts)
    ('complete', 601, ['casimirs', 'energy', 'orthogonality'])
    >>> lieint.run("dzhanibekov", out, progress=False, overwrite=True).status  # it exists now
    'complete'
    """
    from ..scenes import load_scene
    from .lock import RunLock

    stream = sys.stderr if stream is None else stream
    _check_arguments(overwrite, resume, checkpoint_every, monitor_every, stop_after, checkpoint_seconds)
    if not isinstance(stop_at_horizon, (bool, np.bool_)):
        raise TypeError(f"`stop_at_horizon` must be True or False; got {stop_at_horizon!r}.")
    if stop_at_horizon and max_error_estimate is None:
        raise ValueError("`stop_at_horizon` needs `max_error_estimate` (the tolerance whose horizon stops the run).")
    if not isinstance(scene, Scene):
        scene = _resolve_scene(scene, load_scene)
    out = Path(out)
    if not out.parent.exists():
        raise StoreError(f"the directory of the output {str(out)!r} does not exist")
    if not out.parent.is_dir():
        raise StoreError(f"cannot create the output file {str(out)!r}: {str(out.parent)!r} is not a directory")
    with RunLock(out):  # held until the run has ended: one writer per run file
        _check_output(out, overwrite, resume)
        streamed = StreamedRun(scene, out, max_error_estimate, stop_at_horizon)
        limits = _check_limits(max_drift, streamed.invariant_names)
        if not resume:
            _check_room(streamed)
        with file_size_signal_ignored():
            return _Session(
                streamed, stream, progress, checkpoint_every, checkpoint_seconds, monitor_every, stop_after, limits
            ).run(resume)


class _Session:
    """The loop of one call of :func:`run`: segments sized to come back on time (progress,
    monitors, checkpoints, Ctrl-C) and to hold at most :data:`~lieint.runs.streamed.SEGMENT_BYTES` of rows."""

    def __init__(
        self, streamed, stream, progress, checkpoint_every, checkpoint_seconds, monitor_every, stop_after, limits
    ):
        self.s, self.stream, self.progress = streamed, stream, progress
        self.checkpoint_every, self.checkpoint_seconds = checkpoint_every, checkpoint_seconds
        self.monitor_every, self.stop_after, self.limits = monitor_every, stop_after, limits
        self.stop = threading.Event()
        self.crossings_shown = 0

    def run(self, resume: bool) -> RunReport:
        s = self.s
        total = s.driver.total_steps()
        previous = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.signal(signal.SIGINT, lambda *_: self.stop.set())
        bar = None
        try:
            try:
                resumed_at = s.resume() if resume else (s.start() or "")
                if resumed_at:
                    print(resumed_at, file=self.stream, flush=True)
                if total is not None:
                    bar = progress_bar(total, s.carry.k, "step", self.progress, self.stream)
                else:
                    bar = progress_bar(
                        s.driver.t1 - s.driver.t0, s.carry.t - s.driver.t0, "t", self.progress, self.stream
                    )
                s.checkpoint()
                status, message = self._loop(bar, total)
                s.finish(status)
            except NoSpaceError as exc:
                status = "no-space"
                self._end_without_space(s)
                message = self._no_space_message(exc)
        finally:
            if bar is not None:
                bar.close()
            if previous is not None:
                signal.signal(signal.SIGINT, previous)
            intact = s.output is not None and not s.output.broken and s.output.f.id.valid
            rows = s.output.rows if intact else s.rows_checkpointed
            if intact:
                s.close()
        k = s.carry.k if s.carry is not None else 0
        drifts = s.monitor.largest() if s.monitor is not None else {}
        horizon = json.loads(s.horizon.record()) if s.horizon is not None else None
        return RunReport(s.out, status, k, total, rows, message, drifts, horizon)

    @staticmethod
    def _end_without_space(s: StreamedRun) -> None:
        """Record the state reached where the file still takes it (a stop before writing leaves
        HDF5 intact: checkpoint and status are small); else leave the last checkpoint as it is."""
        if s.output is None or s.output.broken:
            if s.output is not None:
                s.output.abandon()
            return
        try:
            s.finish("no-space")
        except NoSpaceError:
            s.output.abandon()

    def _no_space_message(self, exc) -> str:
        s = self.s
        saved = (
            f"the rows up to the last checkpoint (step {s.k_checkpointed}) are safe"
            if s.k_checkpointed is not None
            else "nothing was saved"
        )
        resume = "continue with --resume" if s.k_checkpointed is not None else "start again"
        return (
            f"the disk is full or the file-size limit (ulimit -f) was reached: {exc}. The run stopped; {saved}. "
            f"Free space (or raise the limit) and {resume}."
        )

    def _show_crossings(self, s: StreamedRun) -> None:
        """A line for each member whose error estimate crossed in the last segment (the first
        :data:`_CROSSING_LINES` of the call; a large ensemble's others are in the file)."""
        for member, t in s.crossed:
            self.crossings_shown += 1
            if self.crossings_shown > _CROSSING_LINES:
                if self.crossings_shown == _CROSSING_LINES + 1:
                    print("[trust horizon] … the other members' horizons are recorded in the file (lieint info)",
                          file=self.stream, flush=True)  # fmt: skip
                continue
            which = f"member {member}: " if s.horizon.horizon.size > 1 else ""
            print(
                f"[trust horizon] {which}the estimated global error exceeds --max-error-estimate "
                f"{s.horizon.tolerance:g} at t = {t:.6g}",
                file=self.stream,
                flush=True,
            )

    def _budget(self, chunk: int, k_start: int, last_ckpt_step: int, last_monitor: int) -> int:
        """Steps of the next segment: on time for the stop, a monitor line and a checkpoint."""
        k = self.s.carry.k
        budget = min(chunk, self.s.max_segment_steps)
        if self.stop_after is not None:
            budget = min(budget, k_start + self.stop_after - k)
        if self.monitor_every:
            budget = min(budget, last_monitor + self.monitor_every - k)
        if self.checkpoint_every is not None:
            budget = min(budget, last_ckpt_step + self.checkpoint_every - k)
        return max(budget, 1)

    def _loop(self, bar, total) -> tuple[str, str]:
        s, stream = self.s, self.stream
        chunk = 1000 if total is None else max(1, min(total, 1000))
        k_start = s.carry.k
        last_ckpt_time, last_ckpt_step, last_monitor = time.monotonic(), s.carry.k, s.carry.k
        while not s.done:
            if s.stop_at_horizon and s.horizon.done and s.carry.k >= s.horizon.k:
                return "stopped", (
                    f"every member's estimated global error exceeded --max-error-estimate {s.horizon.tolerance:g} by "
                    f"t = {float(np.max(s.horizon.horizon)):.6g} (step {s.carry.k}); the run stopped there "
                    "(--stop-at-horizon), the rows up to here are saved"
                )
            k0, t0 = s.carry.k, s.carry.t
            tic = time.monotonic()
            seg = s.segment(self._budget(chunk, k_start, last_ckpt_step, last_monitor))
            wall = time.monotonic() - tic
            if bar is not None:
                bar.update(s.carry.k - k0 if total is not None else s.carry.t - t0)
            chunk = next_segment_plan(chunk, s.carry.k - k0, wall, s.max_segment_steps)
            k = s.carry.k
            if seg.failure:
                return "failed", seg.failure
            self._show_crossings(s)
            worst = s.monitor.largest()
            exceeded = [(n, worst[n], v) for n, v in self.limits.items() if not worst[n] <= v]
            if exceeded:
                n, got, limit = exceeded[0]
                return "stopped", (
                    f"{n} drift {got:.3g} exceeded --max-drift {n}={limit:g} by step {k} "
                    f"(t = {s.carry.t:.6g}); the run stopped, the rows up to here are saved"
                )
            if self.monitor_every and k - last_monitor >= self.monitor_every:
                last_monitor = k
                print(
                    f"[monitor] step {k}: " + ", ".join(f"{n} {v:.3e}" for n, v in worst.items()),
                    file=stream,
                    flush=True,
                )
            if self.stop.is_set() or (self.stop_after is not None and k - k_start >= self.stop_after and not s.done):
                return "interrupted", f"interrupted at step {k} (t = {s.carry.t:.6g}); continue with --resume"
            now = time.monotonic()
            due_steps = self.checkpoint_every is not None and k - last_ckpt_step >= self.checkpoint_every
            due_time = self.checkpoint_seconds is not None and now - last_ckpt_time >= self.checkpoint_seconds
            if due_steps or due_time:
                s.checkpoint()
                last_ckpt_time, last_ckpt_step = now, k
        return "complete", f"complete: {s.carry.k} steps, {s.output.rows} saved rows"


def next_segment_plan(planned: int, ran: int, wall: float, cap: int) -> int:
    """The steps to plan for the next segment, from the one just run.

    The aim is a segment of about :data:`_SEGMENT_SECONDS` of wall time: the rate measured on
    the ``ran`` steps just done (which may be fewer than ``planned`` when a checkpoint, a
    monitor line or the end cut the segment short) gives the steps that would take that long,
    changed by at most ×4 or ÷4 from the last plan (one slow or fast segment is noise). The plan
    never exceeds ``cap``, the longest segment that may be run (its rows must fit in memory):
    a plan left to grow past what is ever run grew ×4 after every short segment and overflowed
    a float after about 500 of them (a run with ``--checkpoint-every 200`` died at step 101,400).
    """
    rate_steps = max(ran, 1) * _SEGMENT_SECONDS / max(wall, 1e-6)
    bounded = min(4.0 * planned, max(planned / 4.0, rate_steps))
    return int(max(1, min(cap, bounded)))


def _check_arguments(overwrite, resume, checkpoint_every, monitor_every, stop_after, checkpoint_seconds) -> None:
    if overwrite and resume:
        raise ValueError(
            "`overwrite` and `resume` exclude each other: resume continues the file, overwrite replaces it."
        )
    for label, value in (
        ("checkpoint_every", checkpoint_every),
        ("monitor_every", monitor_every),
        ("stop_after", stop_after),
    ):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1):
            raise ValueError(f"`{label}` must be a positive integer; got {value!r}.")
    if checkpoint_seconds is not None and not (checkpoint_seconds > 0):
        raise ValueError(f"`checkpoint_seconds` must be a positive number; got {checkpoint_seconds!r}.")


def _check_output(out: Path, overwrite: bool, resume: bool) -> None:
    """What may be done with the output path (called with the run's lock held)."""
    from .files import check_replaceable, describe_kind, remove_stale_temps

    remove_stale_temps(out)  # left by a writer killed while creating the run or a checkpoint
    exists = os.path.lexists(out)
    if exists and not (overwrite or resume):
        raise StoreError(f"the output {str(out)!r} exists; pass --overwrite to replace it or --resume to continue it")
    if resume and not exists:
        raise StoreError(f"nothing to resume: the output {str(out)!r} does not exist")
    if overwrite:
        check_replaceable(out)  # only a lieint run file (or nothing) is ever replaced
    if resume:
        st = os.lstat(out)
        if not stat.S_ISREG(st.st_mode):
            raise StoreError(f"cannot resume {str(out)!r}: it is {describe_kind(st)}, not a lieint run file")


def _check_room(streamed: StreamedRun) -> None:
    """Refuse a run whose rows cannot fit on the disk or under the file-size limit (``ulimit -f``)."""
    from ..limits import env_flag

    rows = streamed.planned_rows()
    if rows is None or env_flag("LIEINT_SKIP_ROOM_CHECK"):
        return
    need = int(rows * streamed.row_bytes() * 1.05) + (1 << 20)  # data, chunk index and checksums
    how = "raise save_every, shorten the run, or set LIEINT_SKIP_ROOM_CHECK=1 to start anyway"
    try:
        st = os.statvfs(streamed.out.parent)
        free = st.f_bavail * st.f_frsize
    except OSError:
        free = None
    if free is not None and need > free:
        raise StoreError(
            f"the run needs about {human_bytes(need)} for {rows} saved rows but only {human_bytes(free)} are free in "
            f"{str(streamed.out.parent)!r}; free space, {how}"
        )
    import resource

    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY and need > soft:
        raise StoreError(
            f"the run needs about {human_bytes(need)} for {rows} saved rows but the file-size limit (ulimit -f) is "
            f"{human_bytes(soft)}; raise the limit, {how}"
        )


class file_size_signal_ignored:
    """Ignore SIGXFSZ while writing, so that passing ``ulimit -f`` makes write() fail with EFBIG
    (reported clearly) instead of killing the process (main thread only)."""

    def __enter__(self):
        self.previous = None
        if threading.current_thread() is threading.main_thread() and hasattr(signal, "SIGXFSZ"):
            self.previous = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        return self

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGXFSZ, self.previous)


def _check_limits(max_drift, names) -> dict[str, float]:
    limits = {}
    for name, value in dict(max_drift or {}).items():
        if name not in names:
            raise ValueError(
                f"`max_drift`: {name!r} is not an invariant this run saves; saved invariants are "
                f"{names} (add it to [output] quantities)"
            )
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"`max_drift`: the limit of {name!r} must be a number; got {value!r}") from None
        if not (v >= 0 and math.isfinite(v)):
            raise ValueError(f"`max_drift`: the limit of {name!r} must be a finite number >= 0; got {value!r}")
        limits[name] = v
    return limits


def _resolve_scene(scene, load_scene):
    from ..scenes import embedded_scenes

    text = str(scene)
    if Path(text).exists() or text.endswith(".toml"):
        return load_scene(text)
    known = embedded_scenes()
    if text in known:
        return known[text]
    raise StoreError(f"no scene file {text!r} and no embedded scene of that name (embedded: {sorted(known)})")
