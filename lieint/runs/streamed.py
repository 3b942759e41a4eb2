"""One streamed run of a scene into an HDF5 file: start or resume, segments, checkpoints, finish.

The run is stepped by the one driver (:class:`lieint.driver.Driver`), whose carry is exact across
segment boundaries, so a resumed result equals an uninterrupted run bit for bit, with no gaps and
no duplicate rows (rows written after the last checkpoint are dropped and recomputed
identically). scipy's solvers keep state that cannot be saved: their runs resume by recomputing
from the start and skipping the rows on disk (the same bits, at the cost of the recomputation).

Memory is flat in the length of the run: a segment holds at most :data:`SEGMENT_BYTES` of saved
rows, which are written and dropped; and each segment is first checked to fit on the disk and
under the file-size limit (:meth:`StreamedRun.room_for`).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..drift import DriftMonitor
from ..driver import Carry, Driver, Segment
from ..methods.registry import get_method
from ..scenes import Scene, build_system, scene_solver_options
from ..scenes.engine import scene_events
from .run_events import StreamedEvents
from .store import Checkpoint, NoSpaceError, OutputFile, StoreError, available_room
from .trust import RunHorizon

__all__ = ["SEGMENT_BYTES", "RunReport", "StreamedRun", "scene_fingerprint"]

#: saved rows of one segment are held in memory until written: at most about this many bytes
SEGMENT_BYTES = 4 << 20


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
    #: with ``max_error_estimate``: the tolerance, per member the time the estimated global
    #: error first exceeded it (None: not reached), the largest estimate, the time estimated to
    trust_horizon: dict | None = None


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
    With ``max_error_estimate`` it carries the run's trust horizon (:mod:`lieint.runs.trust`),
    and with ``stop_at_horizon`` its segments end at the step where every member has crossed.
    """

    def __init__(self, scene: Scene, out: Path, max_error_estimate: float | None = None, stop_at_horizon: bool = False):
        from .._version import __version__

        self.version = __version__
        self.scene, self.out = scene, Path(out)
        self.system, y0 = build_system(scene)
        options = scene_solver_options(scene)
        method = get_method(options.pop("method"), coordinates=options.pop("coordinates"))
        #: the scene's [[events]], recorded in the file (None without events)
        self.events: StreamedEvents | None = None
        if scene.events:
            self.events = StreamedEvents(
                self.system,
                method,
                scene.t_start,
                scene_events(self.system, y0, scene),
                project=bool(options.get("project", False)),
            )
        observer = self.events.observer if self.events is not None else None
        self.driver = Driver(self.system, method, (scene.t_start, scene.t_end), **options, observer=observer)
        self.y0 = self.driver.initial(y0)
        #: the trust horizon carried beside the run (:mod:`lieint.runs.trust`), or None
        self.horizon: RunHorizon | None = None
        #: the members whose estimate crossed in the last segment, and when
        self.crossed: list[tuple[int, float]] = []
        #: end the run's segments at the step where every member has crossed
        self.stop_at_horizon = bool(stop_at_horizon)
        if max_error_estimate is not None:
            if self.driver.kind != "fixed":
                raise ValueError(
                    f"`max_error_estimate` needs a fixed-step method (the estimate is carried on the run's grid of "
                    f"step h); the scene's method {method.name!r} chooses its own steps"
                )
            self.horizon = RunHorizon(self.system, y0, method, self.driver.plan, max_error_estimate)
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
            }
            | ({"trust_horizon": self.horizon.record()} if self.horizon is not None else {}),
            {g: {n: v[0] for n, v in a.items()} for g, a in rows.items() if a},
            self.driver.t0,
            self._dataset_attrs(),
        )
        if self.events is not None:
            self.events.create(self.output.f, self.driver.user_state(self.carry))
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
        if self.horizon is not None:  # before the file is touched: a refusal leaves it as it was
            self.horizon.restore(arrays, attrs)
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
        if self.events is not None:
            self.events.restore(self.output.f, arrays, attrs, self.carry.t, self.driver.user_state(self.carry))
        return f"resuming at step {self.carry.k} (t = {self.carry.t:.6g}) with {rows} saved rows"

    def _replay(self, rows: int) -> str:
        """scipy's solvers: recompute from the start, skipping the ``rows`` saved already."""
        self.carry = self.driver.start(self.y0)
        first = self.driver.loop.first_row(self.carry)
        self.monitor.update(self.rows_of(first.t, first.states).get("invariants", {}))
        self.output = OutputFile.reopen(self.out, rows)
        if self.events is not None:
            self.events.restart(self.output.f)
        have = 1
        while have < rows and not self.driver.done(self.carry):
            seg = self.driver.advance(self.carry, 1000)
            keep = min(seg.rows, rows - have)
            if keep:
                part = self.rows_of(seg.t[:keep], {k: v[:keep] for k, v in seg.states.items()})
                self.monitor.update(part.get("invariants", {}))
            if keep < seg.rows:  # rows past what was saved: write them now
                self._write(Segment(seg.t[keep:], {k: v[keep:] for k, v in seg.states.items()}))
            elif self.events is not None:
                self.events.write_new(self.output.f)
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
        steps = self.room_for(max_steps)
        if self.horizon is not None:
            # the estimate follows its own copy of the run, so it may go first: with
            # stop_at_horizon the segment then ends exactly where the last member crossed
            k = self.carry.k
            self.crossed = self.horizon.advance(k + steps)
            if self.stop_at_horizon and self.horizon.done:
                steps = max(0, min(steps, self.horizon.k - k))
        seg = self.driver.advance(self.carry, steps)
        self._write(seg)
        return seg

    def _write(self, seg: Segment) -> None:
        if self.events is not None:
            self.events.write_new(self.output.f)
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
        extra = {}
        if self.events is not None and not replay:
            event_arrays, extra = self.events.checkpoint()
            arrays.update(event_arrays)
        if self.horizon is not None:
            horizon_arrays, horizon_attrs = self.horizon.checkpoint()
            arrays.update(horizon_arrays)
            extra = {**extra, **horizon_attrs}
        self.checkpoint_file.write(
            arrays,
            {
                **extra,
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
        more = {"trust_horizon": self.horizon.record()} if self.horizon is not None else {}
        self.output.set_attrs(steps_done=c.k, nfev=c.nfev, nrejected=c.nrejected, **more)

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


def human_bytes(n: float) -> str:
    """A byte count in words (kB, MB, GB: powers of 1000)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} TB"  # pragma: no cover
