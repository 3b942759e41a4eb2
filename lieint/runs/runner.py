"""Streaming runs: integrate a scene in segments, append to HDF5, checkpoint, monitor.

A run can be left overnight: memory stays flat (each segment's saved rows are written and
dropped), checkpoints are atomic, Ctrl-C stops cleanly at the next segment boundary with
everything flushed, and ``resume=True`` continues a run killed even by SIGKILL. The run is
stepped by the one driver (:class:`lieint.driver.Driver`), whose carry is exact across segment
boundaries, so the resumed result equals an uninterrupted run bit for bit, with no gaps and no
duplicate rows (rows written after the last checkpoint are dropped and recomputed identically).
scipy's solvers keep state that cannot be saved: their runs resume by recomputing from the start
and skipping the rows on disk (the same bits, at the cost of the recomputation).

:class:`StreamedRun` is one run (``start`` or ``resume``, ``segment``, ``checkpoint``,
``finish``); :func:`run` drives it with progress, monitors, checkpoint timing and Ctrl-C.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import signal
import stat
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..drift import DriftMonitor
from ..driver import Carry, Driver, Segment
from ..methods.registry import get_method
from ..scenes import Scene, build_system, scene_solver_options
from .store import Checkpoint, NoSpaceError, OutputFile, StoreError, available_room

__all__ = ["RunReport", "StreamedRun", "run", "scene_fingerprint"]

_SEGMENT_SECONDS = 0.25  # aim for segments of about this wall time (progress, Ctrl-C latency)


@dataclass
class RunReport:
    """How a streamed run ended."""

    path: Path
    status: str  # "complete" | "interrupted" | "stopped" | "failed" | "no-space"
    steps_done: int
    nsteps: int | None
    rows: int
    message: str
    drifts: dict[str, float] = field(default_factory=dict)


def scene_fingerprint(scene: Scene) -> str:
    """SHA-256 of what determines the numbers: every field except where the scene came from."""
    data = {}
    for name, value in scene.__dict__.items():
        if name in ("source", "text", "description", "name"):
            continue
        data[name] = _plain(value)
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return value


def _scene_text(scene: Scene) -> str:
    return scene.text if scene.text is not None else json.dumps({"scene": scene.name}, default=str)


class StreamedRun:
    """One streamed run of a scene into an HDF5 file (see the module docstring).

    Build it with :meth:`start` (a new file) or :meth:`resume` (continue from the checkpoint),
    then call :meth:`segment` until :attr:`done`, :meth:`checkpoint` when due, and :meth:`finish`.
    """

    def __init__(self, scene: Scene, out: Path):
        from .. import __version__

        self.version = __version__
        self.scene, self.out = scene, Path(out)
        self.system, y0 = build_system(scene)
        options = scene_solver_options(scene)
        method = get_method(options.pop("method"), coordinates=options.pop("coordinates"))
        self.driver = Driver(self.system, method, (scene.t_start, scene.t_end), **options)
        self.y0 = self.driver.initial(y0)
        self.batch_ndim = len(self.system.batch_shape(self.y0))
        declared = self.system.invariants
        self.invariant_names = [q for q in scene.outputs if q in declared]
        self.output_names = [q for q in scene.outputs if q not in declared and q not in self.system.fields]
        self.kinds = {name: declared[name].kind for name in self.invariant_names}
        self.fingerprint = scene_fingerprint(scene)
        self.checkpoint_file = Checkpoint(self.out)
        self.carry: Carry | None = None
        self.output: OutputFile | None = None
        self.monitor: DriftMonitor | None = None
        self.k_checkpointed: int | None = None  # step and rows of the last checkpoint written or read
        self.rows_checkpointed = 0
        self._row_bytes: int | None = None

    # -- sizes ------------------------------------------------------------------------------
    def row_bytes(self) -> int:
        """Bytes of one saved row (time, states, invariants, outputs of every member)."""
        if self._row_bytes is None:
            t0 = np.array([self.driver.t0])
            rows = self.rows_of(t0, {k: np.asarray(v)[None] for k, v in self.y0.items()})
            self._row_bytes = 8 + sum(np.asarray(v).nbytes for g in rows.values() for v in g.values())
        return self._row_bytes

    def planned_rows(self) -> int | None:
        """Rows the whole run will save, when known in advance."""
        d = self.driver
        if d.kind == "fixed":
            return d.plan.nsteps // d.save_every + 2
        if d.kind == "scipy" and d.save_times is not None:
            return int(d.save_times.size)
        return None

    def room_for(self, steps: int) -> int:
        """The steps (at most ``steps``) whose rows fit on the disk and under the file-size limit
        (``ulimit -f``); :class:`NoSpaceError` when not even one more row fits.

        Checked before each segment, so that a full disk ends the run as resumable with its file
        intact, instead of failing inside HDF5 (whose file is then left half-written).
        """
        room, where = available_room(self.out)
        every = self.driver.save_every
        rows = steps // every + 1  # rows a segment of `steps` steps saves at most
        if self.output.growth(rows) <= room:
            return steps
        lo, hi = 0, rows  # the most rows that fit (growth is monotone in rows)
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.output.growth(mid) <= room:
                lo = mid
            else:
                hi = mid - 1
        if lo < 1:
            raise NoSpaceError(f"{where}: no room for more rows")
        return max(1, min(steps, (lo - 1) * every if lo > 1 else 1))

    @property
    def max_segment_steps(self) -> int:
        """Steps whose saved rows fit in :data:`SEGMENT_BYTES` (memory flat in the run's length)."""
        return max(1, SEGMENT_BYTES // self.row_bytes()) * self.driver.save_every

    # -- rows -------------------------------------------------------------------------------
    def rows_of(self, t: np.ndarray, states: dict) -> dict[str, dict[str, np.ndarray]]:
        """States, invariants and derived outputs of saved rows, grouped as in the file."""
        tt = t.reshape(t.shape + (1,) * self.batch_ndim)
        groups = {"states": states}
        if self.invariant_names:
            groups["invariants"] = self.system.evaluate_invariants(tt, states, self.invariant_names)
        if self.output_names:
            groups["outputs"] = self.system.evaluate_outputs(tt, states, self.output_names)
        return groups

    def _dataset_attrs(self) -> dict:
        attrs = {}
        outputs = self.system.outputs
        for name, shape in self.system.fields.items():
            attrs[("states", name)] = {
                "kind": outputs[name].kind if name in outputs else "",
                "trailing_ndim": len(shape),
            }
        for name in self.invariant_names:
            attrs[("invariants", name)] = {"kind": self.kinds[name]}
        for name in self.output_names:
            o = outputs[name]
            attrs[("outputs", name)] = {"kind": o.kind, "trailing_ndim": len(o.shape)}
        return attrs

    # -- start and resume ---------------------------------------------------------------------
    def start(self) -> None:
        """Begin a new output file (the caller has made sure it may be written); the file is
        built beside the old one and renamed over it (:func:`lieint.runs.files.publish`)."""
        self.checkpoint_file.remove()
        self.carry = self.driver.start(self.y0)
        first = self.driver.loop.first_row(self.carry)
        rows = self.rows_of(first.t, first.states)
        self.output = OutputFile.create(
            self.out,
            {
                "lieint_version": self.version,
                "scene": _scene_text(self.scene),
                "scene_fingerprint": self.fingerprint,
                "scene_name": self.scene.name,
                "method": self.driver.method.name,
                "h": self.scene.step,
                # −1 when the method chooses its own steps (adaptive and scipy methods)
                "planned_steps": self.driver.total_steps() or -1,
                "steps_done": 0,
                "nfev": 0,
                "nrejected": 0,
                "backend": self.driver.backend,
                "status": "running",
                "save_every": self.scene.save_every,
                "batch_ndim": self.batch_ndim,
                # which saved invariants measure a defect (plots show their size, not a drift)
                "defects": ",".join(sorted(n for n, k in self.kinds.items() if k == "defect")),
            },
            {g: {n: v[0] for n, v in a.items()} for g, a in rows.items() if a},
            self.driver.t0,
            self._dataset_attrs(),
        )
        initial = {n: v[0] for n, v in rows.get("invariants", {}).items()}
        self.monitor = DriftMonitor(self.kinds, initial, self.batch_ndim)

    def resume(self) -> str:
        """Continue from the checkpoint; returns a line saying where the run resumes."""
        arrays, attrs = self.checkpoint_file.read()
        reasons = []
        if attrs.get("scene_fingerprint") != self.fingerprint:
            reasons.append("it was written for a different scene (its fingerprint differs)")
        if attrs.get("lieint_version") != self.version:
            reasons.append(f"it was written by lieint {attrs.get('lieint_version')}, this is {self.version}")
        if reasons:
            raise StoreError(f"refusing to resume from {str(self.checkpoint_file.path)!r}: " + "; ".join(reasons))
        rows = int(attrs["rows"])
        self.k_checkpointed, self.rows_checkpointed = int(attrs["k"]), rows
        first = {k[6:]: v for k, v in arrays.items() if k.startswith("first:")}
        self.monitor = DriftMonitor(self.kinds, first, self.batch_ndim)
        if attrs.get("replay"):
            return self._replay(rows)
        # the same back end as the interrupted run: its carry is in that back end's representation
        self.driver.backend_request = str(attrs["backend"])
        self.carry = self.driver.start(self.y0)
        self.carry.state = {k[6:]: v for k, v in arrays.items() if k.startswith("state:")}
        method_state = {k[7:]: v for k, v in arrays.items() if k.startswith("method:")}
        self.carry.method_state = method_state or None
        self.carry.k, self.carry.t = int(attrs["k"]), float(attrs["t"])
        self.carry.h = None if math.isnan(float(attrs["h"])) else float(attrs["h"])
        self.carry.nfev, self.carry.nrejected = int(attrs["nfev"]), int(attrs["nrejected"])
        for name in self.kinds:
            self.monitor.worst[name] = arrays[f"drift:{name}"]
        self.output = OutputFile.reopen(self.out, rows)
        return f"resuming at step {self.carry.k} (t = {self.carry.t:.6g}) with {rows} saved rows"

    def _replay(self, rows: int) -> str:
        """scipy's solvers: recompute from the start, skipping the ``rows`` saved already."""
        self.carry = self.driver.start(self.y0)
        first = self.driver.loop.first_row(self.carry)
        self.monitor.update(self.rows_of(first.t, first.states).get("invariants", {}))
        self.output = OutputFile.reopen(self.out, rows)
        have = 1
        while have < rows and not self.driver.done(self.carry):
            seg = self.driver.advance(self.carry, 1000)
            keep = min(seg.rows, rows - have)
            if keep:
                part = self.rows_of(seg.t[:keep], {k: v[:keep] for k, v in seg.states.items()})
                self.monitor.update(part.get("invariants", {}))
            if keep < seg.rows:  # rows past what was saved: write them now
                self._write(Segment(seg.t[keep:], {k: v[keep:] for k, v in seg.states.items()}))
            have += seg.rows
        return f"resuming {self.driver.method.name} by recomputing from t = {self.driver.t0:g} ({rows} rows on disk)"

    # -- stepping -------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.driver.done(self.carry)

    def segment(self, max_steps: int) -> Segment:
        """Advance by at most ``max_steps`` accepted steps; write and monitor the saved rows.

        Raises :class:`~lieint.runs.store.NoSpaceError` *before* stepping when the rows could
        not be written (a full disk, the file-size limit): the file then stays intact and the run
        ends as resumable instead of failing inside HDF5.
        """
        seg = self.driver.advance(self.carry, self.room_for(max_steps))
        self._write(seg)
        return seg

    def _write(self, seg: Segment) -> None:
        if seg.rows == 0:
            return
        groups = self.rows_of(seg.t, seg.states)
        self.output.append(seg.t, {g: a for g, a in groups.items() if a})
        if self.invariant_names:
            self.monitor.update(groups["invariants"])

    def checkpoint(self) -> None:
        """Write the checkpoint atomically (the carry, the monitor, the rows written)."""
        c = self.carry
        arrays: dict[str, np.ndarray] = {f"first:{n}": v for n, v in self.monitor.initial.items()}
        arrays.update({f"drift:{n}": np.asarray(v) for n, v in self.monitor.worst.items()})
        replay = not self.driver.checkpointable
        if not replay:
            arrays.update({f"state:{k}": np.asarray(v) for k, v in c.state.items()})
            arrays.update({f"method:{k}": np.asarray(v) for k, v in (c.method_state or {}).items()})
        self.checkpoint_file.write(
            arrays,
            {
                "lieint_version": self.version,
                "scene_fingerprint": self.fingerprint,
                "backend": self.driver.backend,
                "replay": replay,
                "k": c.k,
                "t": c.t,
                "h": float("nan") if c.h is None else c.h,
                "nfev": c.nfev,
                "nrejected": c.nrejected,
                "rows": self.output.rows,
            },
        )
        self.k_checkpointed, self.rows_checkpointed = c.k, self.output.rows
        self._record_counts()

    def _record_counts(self) -> None:
        c = self.carry
        self.output.set_attrs(steps_done=c.k, nfev=c.nfev, nrejected=c.nrejected)

    def finish(self, status: str) -> None:
        """Record how the run ended; a complete run drops its checkpoint."""
        if status == "complete":
            self._record_counts()
            self.output.set_attrs(status="complete")
            self.checkpoint_file.remove()
        elif status == "failed":  # deterministic: resuming would fail again at the same step
            self._record_counts()
            self.output.set_attrs(status="failed")
            self.checkpoint_file.remove()
        else:
            self.checkpoint()
            self.output.set_attrs(status=status)

    def close(self) -> None:
        if self.output is not None:
            self.output.close()


# -- progress ------------------------------------------------------------------------------------


def _progress(total: float, done: float, unit: str, enabled, stream):
    if not enabled:
        return None
    if enabled == "auto":
        enabled = hasattr(stream, "isatty") and stream.isatty()
        if not enabled:
            return _PlainProgress(total, done, unit, stream)
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit=unit, unit_scale=True, file=stream, smoothing=0.1, dynamic_ncols=True)


class _PlainProgress:
    """Periodic plain lines when not on a terminal (logs, CI)."""

    def __init__(self, total: float, done: float, unit: str, stream, every: float = 10.0):
        self.total, self.n, self.unit, self.stream, self.every = total, done, unit, stream, every
        self.start, self.start_n, self.last = time.monotonic(), done, 0.0

    def update(self, k: float) -> None:
        self.n += k
        now = time.monotonic()
        if now - self.last >= self.every or self.n >= self.total:
            self.last = now
            rate = (self.n - self.start_n) / max(now - self.start, 1e-9)
            eta = (self.total - self.n) / rate if rate > 0 else float("inf")
            print(
                f"{self.unit} {self.n:.6g}/{self.total:.6g} ({100 * self.n / self.total:.1f}%), "
                f"{rate:.3g} {'steps' if self.unit == 'step' else 'time units'}/s, ETA {eta:.0f} s",
                file=self.stream,
                flush=True,
            )

    def close(self) -> None:
        pass


# -- the run ---------------------------------------------------------------------------------------

#: saved rows of one segment are held in memory until written: at most about this many bytes
SEGMENT_BYTES = 4 << 20


def run(
    scene,
    out,
    *,
    overwrite: bool = False,
    resume: bool = False,
    checkpoint_every: int | None = None,
    checkpoint_seconds: float | None = 60.0,
    progress="auto",
    monitor_every: int | None = None,
    max_drift: dict[str, float] | None = None,
    stop_after: int | None = None,
    stream=None,
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
    stream : file, optional
        Where progress and monitor lines go (default ``sys.stderr``).

    Returns
    -------
    RunReport
        ``status`` is "complete", "interrupted" (Ctrl-C or ``stop_after``), "stopped"
        (``max_drift``), "failed" (the state became non-finite) or "no-space" (the disk is
        full or the file-size limit was reached: the rows up to the last checkpoint are safe,
        resume once there is room).
    """
    from ..scenes import load_scene
    from .lock import RunLock

    stream = sys.stderr if stream is None else stream
    _check_arguments(overwrite, resume, checkpoint_every, monitor_every, stop_after, checkpoint_seconds)
    if not isinstance(scene, Scene):
        scene = _resolve_scene(scene, load_scene)
    out = Path(out)
    if not out.parent.exists():
        raise StoreError(f"the directory of the output {str(out)!r} does not exist")
    if not out.parent.is_dir():
        raise StoreError(f"cannot create the output file {str(out)!r}: {str(out.parent)!r} is not a directory")
    with RunLock(out):  # held until the run has ended: one writer per run file
        _check_output(out, overwrite, resume)
        streamed = StreamedRun(scene, out)
        limits = _check_limits(max_drift, streamed.invariant_names)
        if not resume:
            _check_room(streamed)
        with _file_size_signal_ignored():
            return _Session(
                streamed, stream, progress, checkpoint_every, checkpoint_seconds, monitor_every, stop_after, limits
            ).run(resume)


class _Session:
    """The loop of one call of :func:`run`: segments sized to come back on time (progress,
    monitors, checkpoints, Ctrl-C) and to hold at most :data:`SEGMENT_BYTES` of rows."""

    def __init__(
        self, streamed, stream, progress, checkpoint_every, checkpoint_seconds, monitor_every, stop_after, limits
    ):
        self.s, self.stream, self.progress = streamed, stream, progress
        self.checkpoint_every, self.checkpoint_seconds = checkpoint_every, checkpoint_seconds
        self.monitor_every, self.stop_after, self.limits = monitor_every, stop_after, limits
        self.stop = threading.Event()

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
                    bar = _progress(total, s.carry.k, "step", self.progress, self.stream)
                else:
                    bar = _progress(s.driver.t1 - s.driver.t0, s.carry.t - s.driver.t0, "t", self.progress, self.stream)
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
            from .store import hdf5_broken

            intact = s.output is not None and not hdf5_broken() and s.output.f.id.valid
            rows = s.output.rows if intact else s.rows_checkpointed
            if intact:
                s.close()
        k = s.carry.k if s.carry is not None else 0
        drifts = s.monitor.largest() if s.monitor is not None else {}
        return RunReport(s.out, status, k, total, rows, message, drifts)

    @staticmethod
    def _end_without_space(s: StreamedRun) -> None:
        """Record the state reached where the file still takes it (a stop before writing leaves
        HDF5 intact: checkpoint and status are small); else leave the last checkpoint as it is."""
        from .store import hdf5_broken

        if s.output is None or hdf5_broken():
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
            k0, t0 = s.carry.k, s.carry.t
            tic = time.monotonic()
            seg = s.segment(self._budget(chunk, k_start, last_ckpt_step, last_monitor))
            wall = time.monotonic() - tic
            if bar is not None:
                bar.update(s.carry.k - k0 if total is not None else s.carry.t - t0)
            chunk = max(1, int(chunk * min(4.0, max(0.25, _SEGMENT_SECONDS / max(wall, 1e-6)))))
            k = s.carry.k
            if seg.failure:
                return "failed", seg.failure
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
    from .files import check_replaceable, describe_kind

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
            f"the run needs about {_bytes(need)} for {rows} saved rows but only {_bytes(free)} are free in "
            f"{str(streamed.out.parent)!r}; free space, {how}"
        )
    import resource

    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY and need > soft:
        raise StoreError(
            f"the run needs about {_bytes(need)} for {rows} saved rows but the file-size limit (ulimit -f) is "
            f"{_bytes(soft)}; raise the limit, {how}"
        )


def _bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} TB"  # pragma: no cover


class _file_size_signal_ignored:
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
