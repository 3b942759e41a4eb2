"""Streaming runs: HDF5 output, checkpoints, kill -9 and Ctrl-C with resume, monitors, plots."""

import os
import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import assert_identical, read_all

import lieint
import lieint.cli
from lieint.runs import StoreError

SLOW_SCENE = """
[scene]
name = "4D top, long"

[body]
mass_tensor = [[0.5, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.7, 0], [0, 0, 0, 2.3]]

[support]
type = "fixed_point"

[initial]
omega = [[0.0, -0.3, 0.5, -0.2], [0.3, 0.0, -0.4, 0.6], [-0.5, 0.4, 0.0, -0.1], [0.2, -0.6, 0.1, 0.0]]

[integrator]
method = "lie_midpoint"
backend = "numpy"  # the generic path, slow enough to be caught live
step = 0.002
t_end = {t_end}
project = true
save_every = 7

[output]
quantities = ["energy", "casimirs", "manakov", "orientation"]
"""


def scene_file(tmp_path, t_end=50.0, name="slow.toml"):
    path = tmp_path / name
    path.write_text(SLOW_SCENE.format(t_end=t_end))
    return path


def start(args, tmp_path):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(
        [sys.executable, "-m", "lieint", "run", *args],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_for_checkpoint(out, proc, min_step=1000, timeout=60.0):
    ckpt = Path(str(out) + ".checkpoint")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        if ckpt.exists():
            try:
                with h5py.File(ckpt, "r") as f:
                    if int(f.attrs["k"]) >= min_step:
                        return
            except OSError:
                pass  # being replaced: the rename is atomic, try again
        time.sleep(0.05)
    raise AssertionError("no checkpoint appeared")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ref")
    scene = scene_file(tmp)
    report = lieint.run(scene, tmp / "ref.h5", progress=False)
    assert report.status == "complete"
    return read_all(tmp / "ref.h5")


@pytest.mark.slow
def test_uninterrupted_run_writes_plain_hdf5(reference):
    data, attrs = reference
    assert attrs["status"] == "complete" and attrs["steps_done"] == attrs["planned_steps"] == 25_000
    assert attrs["lieint_version"] == lieint.__version__ and "4D top, long" in attrs["scene"]
    assert attrs["method"] == "lie_midpoint" and len(attrs["scene_fingerprint"]) == 64
    m = data["t"].size
    assert m == 25_000 // 7 + 2 and data["t"][-1] == 50.0
    assert np.all(np.diff(data["t"]) > 0)
    assert data["states/A"].shape == (m, 4, 4) and data["invariants/manakov"].shape == (m, 2)


@pytest.mark.slow
def test_kill_9_then_resume_is_bit_for_bit(tmp_path, reference):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    proc = start([str(scene), "--out", str(out), "--checkpoint-every", "1500", "--quiet"], tmp_path)
    wait_for_checkpoint(out, proc, min_step=3000)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL
    partial, attrs = read_all(out)  # readable after SIGKILL (SWMR)
    assert attrs["status"] == "running" and 0 < partial["t"].size < reference[0]["t"].size
    done = subprocess.run(
        [sys.executable, "-m", "lieint", "run", str(scene), "--out", str(out), "--resume", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    resumed, attrs = read_all(out)
    assert attrs["status"] == "complete"
    assert_identical(resumed, reference[0])  # no gaps, no duplicates, same bits
    assert not Path(str(out) + ".checkpoint").exists()


@pytest.mark.slow
def test_ctrl_c_stops_cleanly_and_resumes(tmp_path, reference):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    proc = start([str(scene), "--out", str(out), "--checkpoint-every", "1500"], tmp_path)
    wait_for_checkpoint(out, proc, min_step=1500)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "interrupted at step" in stdout and "--resume" in stdout
    data, attrs = read_all(out)
    assert attrs["status"] == "interrupted"
    with h5py.File(str(out) + ".checkpoint", "r") as f:
        assert f.attrs["rows"] == data["t"].size  # everything written is flushed and accounted for
    report = lieint.run(scene, out, resume=True, progress=False)
    assert report.status == "complete"
    assert_identical(read_all(out)[0], reference[0])


def test_existing_output_and_foreign_checkpoints_are_refused(tmp_path):
    scene = scene_file(tmp_path, t_end=0.2)
    out = tmp_path / "run.h5"
    lieint.run(scene, out, progress=False)
    with pytest.raises(StoreError, match="exists; pass --overwrite to replace it or --resume to continue it"):
        lieint.run(scene, out, progress=False)
    with pytest.raises(StoreError, match=r"no checkpoint .* to resume from"):
        lieint.run(scene, out, resume=True, progress=False)
    # an interrupted run of one scene cannot be resumed with another
    other = scene_file(tmp_path, t_end=5.0, name="other.toml")
    report = lieint.run(other, out, overwrite=True, progress=False, max_drift={"energy": 1e-16})
    assert report.status == "stopped"
    changed = tmp_path / "changed.toml"
    changed.write_text(other.read_text().replace("step = 0.002", "step = 0.001"))
    with pytest.raises(StoreError, match="written for a different scene"):
        lieint.run(changed, out, resume=True, progress=False)
    with h5py.File(str(out) + ".checkpoint", "r+") as f:
        f.attrs["lieint_version"] = "0.0.1"
    # a changed checkpoint fails its SHA-256 ...
    with pytest.raises(StoreError, match="is damaged: its SHA-256 does not match its contents"):
        lieint.run(other, out, resume=True, progress=False)
    # ... and one written by another version (its digest consistent) is refused for that reason
    from lieint.runs.store import _arrays_digest

    with h5py.File(str(out) + ".checkpoint", "r+") as f:
        attrs = {k: v for k, v in f.attrs.items() if k != "sha256"}
        f.attrs["sha256"] = _arrays_digest({k: d[()] for k, d in f["engine"].items()}, attrs)
    with pytest.raises(StoreError, match=r"written by lieint 0.0.1, this is"):
        lieint.run(other, out, resume=True, progress=False)


def test_max_drift_stops_with_a_clear_message(tmp_path, capsys):
    scene = scene_file(tmp_path, t_end=5.0)
    code = lieint.cli.main(
        ["run", str(scene), "--out", str(tmp_path / "r.h5"), "--quiet", "--max-drift", "energy=1e-15"]
    )
    out = capsys.readouterr().out
    assert code == 3
    assert "energy drift" in out and "exceeded --max-drift energy=1e-15" in out and "rows up to here are saved" in out
    code = lieint.cli.main(["run", str(scene), "--out", str(tmp_path / "s.h5"), "--max-drift", "flux=1"])
    assert code == 2 and "'flux' is not an invariant this run saves" in capsys.readouterr().err


def test_monitor_and_plain_progress_lines(tmp_path):
    scene = scene_file(tmp_path, t_end=2.0)
    import io

    stream = io.StringIO()
    lieint.run(scene, tmp_path / "m.h5", monitor_every=200, stream=stream)
    text = stream.getvalue()
    assert "[monitor] step" in text and "energy" in text
    assert "step 1000/1000 (100.0%)" in text and "steps/s" in text and "ETA" in text


@pytest.mark.slow
def test_disk_full_keeps_what_was_written_and_resumes(tmp_path, monkeypatch, reference):
    from lieint.runs import store

    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    real_append = store.OutputFile.append
    calls = {"n": 0}

    def failing_append(self, t, groups):
        calls["n"] += 1
        if calls["n"] == 6:
            raise OSError(28, "No space left on device")
        return real_append(self, t, groups)

    monkeypatch.setattr(store.OutputFile, "append", failing_append)
    with pytest.raises(OSError, match="No space left"):
        lieint.run(scene, out, progress=False, checkpoint_every=1)
    monkeypatch.setattr(store.OutputFile, "append", real_append)
    partial, _ = read_all(out)
    assert partial["t"].size > 1  # the rows written before the failure are intact
    lieint.run(scene, out, resume=True, progress=False)
    assert_identical(read_all(out)[0], reference[0])


def test_unwritable_and_corrupt_outputs(tmp_path):
    scene = scene_file(tmp_path, t_end=0.2)
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("x")
    with pytest.raises(StoreError, match="cannot create the output file"):
        lieint.run(scene, blocker / "run.h5", progress=False)
    with pytest.raises(StoreError, match=r"directory of the output .* does not exist"):
        lieint.run(scene, tmp_path / "missing" / "run.h5", progress=False)
    out = tmp_path / "run.h5"
    lieint.run(scene, out, progress=False, max_drift={"energy": 1e-18})
    out.write_bytes(b"this is not HDF5" * 100)
    with pytest.raises(StoreError, match=r"cannot reopen the output file .* to resume \(corrupt or unreadable\)"):
        lieint.run(scene, out, resume=True, progress=False)
    from lieint.runs.plot import PlotError, plot_run

    with pytest.raises(PlotError, match="cannot open"):
        plot_run(out)


@pytest.mark.slow
def test_memory_stays_flat(tmp_path):
    """Peak Python memory does not grow with the length of the run (4× the rows, same peak)."""
    peaks, written = [], []
    for t_end in (3.0, 12.0):
        path = tmp_path / f"flat{t_end:g}.toml"
        path.write_text(scene_file(tmp_path, t_end=t_end).read_text().replace("save_every = 7", "save_every = 1"))
        lieint.run(path, tmp_path / "warm.h5", progress=False, overwrite=True)  # imports, caches out of the way
        tracemalloc.start()
        lieint.run(path, tmp_path / f"flat{t_end:g}.h5", progress=False)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        with h5py.File(tmp_path / f"flat{t_end:g}.h5") as f:
            written.append(sum(ds.nbytes for g in ("states", "invariants") for ds in f[g].values()))
    assert written[1] > 3.5 * written[0]
    # measured: 5.46 MB and 5.53 MB for 0.9 MB and 3.6 MB written — set by the segment, not the run
    assert peaks[1] < 1.2 * peaks[0], (peaks, written)


def test_memory_stays_flat_on_the_compiled_engine(tmp_path, monkeypatch):
    """The compiled engine runs segments of up to SEGMENT_BYTES of rows (its rate would plan far
    longer ones): once a run is longer than one segment its peak memory no longer grows (measured
    at the real 4 MiB: 53.5, 55.0, 55.0 MB for 24,000, 48,000 and 96,000 steps of rkmk4). With
    64 KiB segments both runs here are many segments long."""
    from lieint.runs import streamed

    monkeypatch.setattr(streamed, "SEGMENT_BYTES", 64 << 10)
    peaks = []
    for t_end in (3.0, 12.0):
        path = tmp_path / f"fast{t_end:g}.toml"
        text = scene_file(tmp_path, t_end=t_end).read_text().replace("save_every = 7", "save_every = 1")
        path.write_text(text.replace('backend = "numpy"', 'backend = "numba"'))
        lieint.run(path, tmp_path / "warm.h5", progress=False, overwrite=True)
        tracemalloc.start()
        report = lieint.run(path, tmp_path / f"fast{t_end:g}.h5", progress=False)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        assert report.status == "complete"
        with h5py.File(tmp_path / f"fast{t_end:g}.h5") as f:
            assert f.attrs["backend"] == "numba"
    assert peaks[1] < 1.2 * peaks[0], peaks


def test_files_open_with_xarray_and_plot(tmp_path):
    xr = pytest.importorskip("xarray")
    scene = scene_file(tmp_path, t_end=1.0)
    out = tmp_path / "x.h5"
    lieint.run(scene, out, progress=False)
    ds = xr.open_dataset(out, engine="h5netcdf", group="invariants")
    assert ds["energy"].shape == (73,)
    states = xr.open_dataset(out, engine="h5netcdf", group="states")
    assert states["R"].shape == (73, 4, 4)
    from lieint.runs.plot import plot_run

    for suffix in (".png", ".svg"):
        fig = plot_run(out, tmp_path / f"fig{suffix}")
        assert fig.exists() and fig.stat().st_size > 1000


def test_ensemble_scene_runs_as_one_batch_and_is_saved_per_member(tmp_path):
    text = SLOW_SCENE.format(t_end=1.0).replace(
        "[integrator]", "[ensemble]\ncount = 5\nseed = 3\nspread = 0.05\n\n[integrator]"
    )
    path = tmp_path / "ens.toml"
    path.write_text(text)
    out = tmp_path / "e.h5"
    lieint.run(path, out, progress=False)
    data, _ = read_all(out)
    assert data["states/A"].shape == (73, 5, 4, 4) and data["invariants/energy"].shape == (73, 5)
    members = data["states/A"][0]
    assert np.all(np.ptp(members, axis=0) > 0) or np.ptp(members) > 0.01  # different initial conditions
    from lieint.runs.plot import plot_run

    assert plot_run(out).exists()
    # the same members from a file
    np.save(tmp_path / "members.npy", np.broadcast_to(np.zeros((4, 4)), (3, 4, 4)))
    path.write_text(
        SLOW_SCENE.format(t_end=1.0).replace("[integrator]", '[ensemble]\nfile = "members.npy"\n\n[integrator]')
    )
    lieint.run(path, out, overwrite=True, progress=False)
    assert read_all(out)[0]["states/A"].shape == (73, 3, 4, 4)


def test_the_planned_segment_never_exceeds_the_longest_segment_run():
    """A plan left to grow past what a segment may hold overflowed a float after ~500 short
    segments; the plan follows the measured rate and stays within [1, cap]."""
    from lieint.runs.runner import next_segment_plan

    plan = 1000
    for _ in range(10_000):  # segments cut to 200 steps by --checkpoint-every, each done in 0.1 ms
        plan = next_segment_plan(plan, 200, 1e-4, cap=50_000)
        assert 1 <= plan <= 50_000
    assert plan == 50_000
    for _ in range(50):  # then each segment takes 10 s: the plan shrinks to the rate (0.25 s)
        plan = next_segment_plan(plan, min(plan, 50_000), 10.0 * min(plan, 50_000) / 50_000, cap=50_000)
    assert plan == 1250
    assert next_segment_plan(1, 1, 100.0, cap=10) == 1


@pytest.mark.parametrize(
    "every",
    [
        pytest.param({"monitor_every": 1}, id="monitor-every-1"),
        pytest.param({"checkpoint_every": 1}, id="checkpoint-every-1", marks=pytest.mark.slow),  # ~13 s: 600 fsyncs
    ],
)
def test_a_run_cut_into_600_one_step_segments_completes(tmp_path, every):
    """Every segment one step long (a checkpoint or a monitor line after each): on the code that
    grew the plan ×4 per segment without bound this died at step ~510 with OverflowError."""
    from lieint.scenes import embedded_scene, load_scene, run_scene

    scene = embedded_scene("dzhanibekov").text.replace("t_end = 60.0", "t_end = 6.0")
    path = tmp_path / "dz.toml"
    path.write_text(scene, encoding="utf-8")
    with open(os.devnull, "w") as quiet:
        report = lieint.runs.run(path, tmp_path / "r.h5", progress=False, stream=quiet, **every)
    assert (report.status, report.steps_done, report.rows) == ("complete", 600, 61)
    reference = run_scene(load_scene(path)).solution
    with h5py.File(tmp_path / "r.h5", "r") as f:
        assert np.array_equal(f["states/A"][()], reference.states["A"])  # the same bits as one call
