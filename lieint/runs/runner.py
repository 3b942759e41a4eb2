"""Streaming runs: integrate a scene in segments, append to HDF5, checkpoint, monitor.

A run can be left overnight: memory stays flat (each segment's saved rows are written and
dropped), checkpoints are atomic, Ctrl-C stops cleanly at the next segment boundary with
everything flushed, and ``resume=True`` continues a run killed even by SIGKILL. Because the
engine's state is exact across segment boundaries, the resumed result equals an uninterrupted
run bit for bit, with no gaps and no duplicate rows (rows written after the last checkpoint
are dropped and recomputed identically).
"""

from __future__ import annotations

import hashlib
import json
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..engine import Plan, make_engine
from ..methods.registry import get_method
from ..scenes import Scene, build_system, collect_outputs
from .store import Checkpoint, OutputFile, StoreError

__all__ = ["RunReport", "run", "scene_fingerprint"]

_SEGMENT_SECONDS = 0.25  # aim for segments of about this wall time (progress, Ctrl-C latency)


@dataclass
class RunReport:
    """How a streamed run ended."""

    path: Path
    status: str  # "complete" | "interrupted" | "stopped" | "failed"
    steps_done: int
    nsteps: int
    rows: int
    message: str
    drifts: dict[str, float] = field(default_factory=dict)


def scene_fingerprint(scene: Scene) -> str:
    """SHA-256 of what determines the numbers: every field except where the scene came from."""
    data = {}
    for name, value in scene.__dict__.items():
        if name in ("source", "text", "description", "name"):
            continue
        if isinstance(value, np.ndarray):
            value = value.tolist()
        elif isinstance(value, dict):
            value = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in value.items()}
        elif isinstance(value, tuple):
            value = list(value)
        data[name] = value
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def _scene_text(scene: Scene) -> str:
    return scene.text if scene.text is not None else json.dumps({"scene": scene.name}, default=str)


class _Monitor:
    """Running maxima of each invariant's drift: relative to its first row (defects: size)."""

    def __init__(self, system, first: dict[str, np.ndarray], names):
        self.names = list(names)
        self.defects = set(getattr(system, "defects", ()))
        self.first = first
        self.worst = {name: 0.0 for name in self.names}

    def update(self, rows: dict[str, np.ndarray]) -> None:
        for name in self.names:
            v = rows[name]
            if v.shape[0] == 0:
                continue
            axes = tuple(range(1, v.ndim))
            if name in self.defects:
                d = np.abs(v)
            else:
                ref = self.first[name]
                scale = np.sqrt(np.sum(ref * ref)) if ref.size else 0.0
                d = np.abs(v - ref) / (scale if scale > 0 else 1.0)
            worst = float(np.max(d, axis=axes).max()) if axes else float(np.max(d))
            self.worst[name] = max(self.worst[name], worst)


def _progress(total: int, done: int, enabled, stream):
    if not enabled:
        return None
    if enabled == "auto":
        enabled = hasattr(stream, "isatty") and stream.isatty()
        if not enabled:
            return _PlainProgress(total, done, stream)
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit="step", unit_scale=True, file=stream, smoothing=0.1, dynamic_ncols=True)


class _PlainProgress:
    """Periodic plain lines when not on a terminal (logs, CI)."""

    def __init__(self, total: int, done: int, stream, every: float = 10.0):
        self.total, self.n, self.stream, self.every = total, done, stream, every
        self.start, self.start_n, self.last = time.monotonic(), done, 0.0

    def update(self, k: int) -> None:
        self.n += k
        now = time.monotonic()
        if now - self.last >= self.every or self.n >= self.total:
            self.last = now
            rate = (self.n - self.start_n) / max(now - self.start, 1e-9)
            eta = (self.total - self.n) / rate if rate > 0 else float("inf")
            print(
                f"step {self.n}/{self.total} ({100 * self.n / self.total:.1f}%), {rate:.3g} steps/s, ETA {eta:.0f} s",
                file=self.stream,
                flush=True,
            )

    def close(self) -> None:
        pass


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
    stream=None,
) -> RunReport:
    """Integrate a scene, streaming the saved series into an HDF5 file.

    Parameters
    ----------
    scene : Scene, str or path
        A :class:`lieint.scenes.Scene`, a TOML path, or an embedded scene's name.
    out : str or path
        The HDF5 output; refused if it exists unless ``overwrite`` or ``resume``.
    overwrite, resume : bool
        Start anew over an existing output, or continue it from its checkpoint
        (``RUN.h5.checkpoint``), which must come from the same scene and lieint version.
    checkpoint_every : int, optional
        Write the checkpoint every this many steps (besides ``checkpoint_seconds``).
    checkpoint_seconds : float, optional
        ... and at least this often in wall time (default 60 s).
    progress : "auto", bool
        A tqdm bar on a terminal, periodic plain lines otherwise ("auto"); False is quiet.
    monitor_every : int, optional
        Print each saved invariant's drift so far every this many steps.
    max_drift : dict, optional
        ``{name: value}``: stop with a clear message once an invariant's drift exceeds value.
    stream : file, optional
        Where progress and monitor lines go (default ``sys.stderr``).
    """
    from .. import __version__
    from ..scenes import load_scene

    stream = sys.stderr if stream is None else stream
    if not isinstance(scene, Scene):
        scene = _resolve_scene(scene, load_scene)
    out = Path(out)
    if overwrite and resume:
        raise ValueError(
            "`overwrite` and `resume` exclude each other: resume continues the file, overwrite replaces it."
        )
    if out.exists() and not (overwrite or resume):
        raise StoreError(f"the output {str(out)!r} exists; pass --overwrite to replace it or --resume to continue it")
    if resume and not out.exists():
        raise StoreError(f"nothing to resume: the output {str(out)!r} does not exist")
    if not out.parent.exists():
        raise StoreError(f"the directory of the output {str(out)!r} does not exist")

    system, y0 = build_system(scene)
    stepper = get_method(
        scene.method, coordinates=scene.coordinates if get_method(scene.method).kind == "lie" else None
    )
    plan = Plan.make(scene.t_start, scene.t_end, scene.step)
    save_steps = plan.save_steps(scene.save_every)
    invariant_names = [q for q in scene.outputs if q in system.invariant_functions]
    derived = [q for q in scene.outputs if q in ("contact_path", "angular_velocity")]  # not state fields
    max_drift = dict(max_drift or {})
    unknown = [name for name in max_drift if name not in invariant_names]
    if unknown:
        raise ValueError(
            f"`max_drift`: {unknown[0]!r} is not an invariant this run saves; saved invariants are "
            f"{invariant_names} (add it to [output] quantities)"
        )
    fingerprint = scene_fingerprint(scene)
    checkpoint = Checkpoint(out)
    if scene.project:
        y0 = system.project(y0)

    def rows_of(states):
        inv = system.invariants(None, states, invariant_names) if invariant_names else {}
        extra = collect_outputs(system, _Fake(states), derived) if derived else {}
        return {"states": states, "invariants": inv, "outputs": extra}

    if resume:
        arrays, attrs = checkpoint.read()
        reasons = []
        if attrs.get("scene_fingerprint") != fingerprint:
            reasons.append("it was written for a different scene (its fingerprint differs)")
        if attrs.get("lieint_version") != __version__:
            reasons.append(f"it was written by lieint {attrs.get('lieint_version')}, this is {__version__}")
        if reasons:
            raise StoreError(f"refusing to resume from {str(checkpoint.path)!r}: " + "; ".join(reasons))
        engine = make_engine(system, stepper, plan, y0, str(attrs["backend"]))
        internal = {k: v for k, v in arrays.items() if not k.startswith("drift:") and not k.startswith("first:")}
        k, rows, nfev = int(attrs["step"]), int(attrs["rows"]), int(attrs["nfev"])
        output = OutputFile.reopen(out, rows)
        first = {k[6:]: v for k, v in arrays.items() if k.startswith("first:")}
        monitor = _Monitor(system, first, invariant_names)
        monitor.worst.update({k[6:]: float(v) for k, v in arrays.items() if k.startswith("drift:")})
    else:
        if out.exists():
            out.unlink()
        checkpoint.remove()
        engine = make_engine(system, stepper, plan, y0, "auto")
        internal = engine.start(y0)
        first_rows = rows_of({k: v[None] for k, v in y0.items()})
        output = OutputFile.create(
            out,
            {
                "lieint_version": __version__,
                "scene": _scene_text(scene),
                "scene_fingerprint": fingerprint,
                "scene_name": scene.name,
                "method": stepper.name,
                "h": plan.h,
                "nsteps": plan.nsteps,
                "steps_done": 0,
                "backend": engine.name,
                "status": "running",
                "save_every": scene.save_every,
                # which saved invariants measure a defect (plots show their size, not a drift)
                "defects": ",".join(sorted(set(getattr(system, "defects", ())) & set(invariant_names))),
            },
            {g: {n: v[0] for n, v in a.items()} for g, a in first_rows.items() if a},
            plan.t0,
        )
        k, rows, nfev = 0, 1, 0
        monitor = _Monitor(system, {n: v[0] for n, v in first_rows["invariants"].items()}, invariant_names)

    def write_checkpoint():
        arrays = dict(internal)
        arrays.update({f"first:{n}": v for n, v in monitor.first.items()})
        arrays.update({f"drift:{n}": np.array(v) for n, v in monitor.worst.items()})
        checkpoint.write(
            arrays,
            {
                "lieint_version": __version__,
                "scene_fingerprint": fingerprint,
                "backend": engine.name,
                "step": k,
                "rows": output.rows,
                "nfev": nfev,
            },
        )
        output.set_attrs(steps_done=k)

    stop = threading.Event()
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGINT, lambda *_: stop.set())
    bar = _progress(plan.nsteps, k, progress, stream)
    status, message = "complete", ""
    chunk = max(1, min(plan.nsteps, 1000))
    last_ckpt_time, last_ckpt_step, last_monitor = time.monotonic(), k, k
    try:
        write_checkpoint()
        while k < plan.nsteps:
            k_to = min(plan.nsteps, k + chunk)
            seg_saves = save_steps[(save_steps > k) & (save_steps <= k_to)]
            tic = time.monotonic()
            seg = engine.advance(internal, k, k_to, plan, seg_saves, scene.project)
            wall = time.monotonic() - tic
            m = seg.states[next(iter(seg.states))].shape[0]
            groups = rows_of(seg.states) if m else {}
            output.append(np.array([plan.time(int(s)) for s in seg_saves[:m]]), {g: a for g, a in groups.items() if a})
            if m and invariant_names:
                monitor.update(groups["invariants"])
            nfev += seg.nfev
            if bar is not None:
                bar.update(seg.done - k)
            k = seg.done
            chunk = max(1, min(plan.nsteps, int(chunk * min(4.0, max(0.25, _SEGMENT_SECONDS / max(wall, 1e-6))))))
            if seg.failure:
                status, message = "failed", seg.failure
                break
            exceeded = [(n, monitor.worst[n], v) for n, v in max_drift.items() if monitor.worst[n] > v]
            if exceeded:
                n, got, limit = exceeded[0]
                status = "stopped"
                message = (
                    f"{n} drift {got:.3g} exceeded --max-drift {n}={limit:g} by step {k} "
                    f"(t = {plan.time(k):.6g}); the run stopped, the rows up to here are saved"
                )
                break
            if monitor_every and k - last_monitor >= monitor_every:
                last_monitor = k
                print(
                    f"[monitor] step {k}: " + ", ".join(f"{n} {v:.3e}" for n, v in monitor.worst.items()),
                    file=stream,
                    flush=True,
                )
            if stop.is_set():
                status = "interrupted"
                message = f"interrupted at step {k} of {plan.nsteps}; continue with --resume"
                break
            now = time.monotonic()
            due_steps = checkpoint_every is not None and k - last_ckpt_step >= checkpoint_every
            due_time = checkpoint_seconds is not None and now - last_ckpt_time >= checkpoint_seconds
            if due_steps or due_time:
                write_checkpoint()
                last_ckpt_time, last_ckpt_step = now, k
        if status == "complete":
            message = f"complete: {plan.nsteps} steps, {output.rows} saved rows"
            output.set_attrs(steps_done=k, status="complete")
            checkpoint.remove()
        else:
            write_checkpoint()
            output.set_attrs(status=status)
    finally:
        if bar is not None:
            bar.close()
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
        rows = output.rows
        output.close()
    return RunReport(out, status, k, plan.nsteps, rows, message, dict(monitor.worst))


class _Fake:
    """The minimal Solution-like view `collect_outputs` needs for derived outputs."""

    def __init__(self, states):
        self.states = states
        self.invariants = {}


def _resolve_scene(scene, load_scene):
    from ..scenes import embedded_scenes

    text = str(scene)
    if Path(text).exists() or text.endswith(".toml"):
        return load_scene(text)
    known = embedded_scenes()
    if text in known:
        return known[text]
    raise StoreError(f"no scene file {text!r} and no embedded scene of that name (embedded: {sorted(known)})")
