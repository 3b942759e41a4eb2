"""The sweep store keeps what run files keep: one writer, --overwrite only of a lieint sweep store,
a checksum per committed chunk (damage named by `lieint info`, recomputed by --resume, never read
as data), and a full disk that ends with one message and resumes identically.

The writers are real processes (``python -m lieint sweep``); the cluster tests are in
tests/sweeps/test_sweeps_cluster.py.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")
xr = pytest.importorskip("xarray")

from lieint.sweeps import open_sweep, sweep  # noqa: E402
from lieint.sweeps.info import inspect_sweep  # noqa: E402
from lieint.sweeps.integrity import DamagedStoreError, StoreError  # noqa: E402

TOP = """
[scene]
name = "top"
[body]
principal_moments = [1.0, 2.0, 3.0]
[support]
type = "fixed_point"
[initial]
angular_velocity = [0.01, 1.0, 0.01]
[integrator]
method = "rkmk4"
step = 0.02
t_end = T_END
save_every = 10
[output]
quantities = ["energy", "casimirs"]
"""
VARY = ["body.principal_moments[0]=1:1.4:6"]


def scene(tmp_path, t_end="2.0") -> Path:
    path = tmp_path / "top.toml"
    path.write_text(TOP.replace("T_END", t_end), encoding="utf-8")
    return path


def cli(args, cwd, timeout=300, **kw):
    return subprocess.run(
        [sys.executable, "-m", "lieint", *args], cwd=cwd, capture_output=True, text=True, timeout=timeout, **kw
    )


def sweep_args(path, out, *extra):
    return ["sweep", str(path), "--vary", VARY[0], "--chunk", "1", "--scheduler", "synchronous", "--out", str(out),
            "--quiet", *extra]  # fmt: skip


def data(path) -> dict:
    """Every member array of a store, read with plain zarr (no verification)."""
    root = zarr.open_group(str(path), mode="r", use_consolidated=False)
    names = [n for n in root.array_keys() if n.startswith(("state_", "drift_")) or n in ("energy", "casimirs")]
    return {n: root[n][...] for n in sorted(names)}


def assert_same(a, b):
    assert a.keys() == b.keys() and a
    for name in a:
        assert np.array_equal(a[name], b[name]), name  # bit for bit


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ref")
    report = sweep(scene(tmp), VARY, out=tmp / "ref.zarr", chunk=1, scheduler="synchronous")
    assert report.status == "complete" and report.nchunks == 6
    return data(tmp / "ref.zarr")


def snapshot(path: Path) -> dict:
    """What a path is, to the byte: kind, contents of every file, link targets."""
    out = {}
    for root, dirs, files in os.walk(path, followlinks=False):
        for name in dirs + files:
            full = Path(root) / name
            if full.is_symlink():
                out[str(full)] = ("link", os.readlink(full))
            elif full.is_file():
                out[str(full)] = ("file", full.read_bytes())
    st = os.lstat(path)
    return {"mode": st.st_mode, "entries": out, "link": os.readlink(path) if path.is_symlink() else None}


# -- one writer ------------------------------------------------------------------------------------


@pytest.mark.parametrize("second", [[], ["--resume"], ["--overwrite"]], ids=["sweep", "resume", "overwrite"])
@pytest.mark.slow
def test_a_second_writer_is_refused_at_once_and_the_first_finishes_intact(tmp_path, reference, second):
    path = scene(tmp_path, t_end="20.0")  # about a second a chunk: long enough to be met live
    out = tmp_path / "s.zarr"
    first = subprocess.Popen([sys.executable, "-m", "lieint", *sweep_args(path, out)], cwd=tmp_path,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        lock = Path(str(out) + ".lock")
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not (out.exists() and str(first.pid) in _read(lock)):
            assert first.poll() is None, first.communicate()
            time.sleep(0.05)
        tic = time.monotonic()
        other = cli(sweep_args(path, out, *second), tmp_path)
        assert time.monotonic() - tic < 30  # refused at once (the interpreter's start included)
        assert other.returncode == 2, other.stderr
        assert f"being written by process {first.pid} on host" in other.stderr, other.stderr
        assert "only one writer per sweep store" in other.stderr and "started 20" in other.stderr
        assert other.stderr.count("\n") == 1 and "Traceback" not in other.stderr
        assert first.poll() is None, "the first sweep ended before the second was refused: the test proves nothing"
        _, err = first.communicate(timeout=600)
        assert first.returncode == 0, err
    finally:
        if first.poll() is None:
            first.kill()
    ref = sweep(path, VARY, out=tmp_path / "ref20.zarr", chunk=1, scheduler="synchronous")
    assert ref.status == "complete"
    assert_same(data(out), data(tmp_path / "ref20.zarr"))  # the refused writer changed nothing
    assert inspect_sweep(out).state == "complete"
    assert not Path(str(out) + ".lock").exists()  # the lock goes with the sweep


def _read(path: Path) -> str:
    try:
        return path.read_text()
    except OSError:
        return ""


# -- --overwrite replaces only a lieint sweep store ------------------------------------------------------


@pytest.mark.slow
def test_overwrite_refuses_what_is_not_a_lieint_sweep_store_and_leaves_it_untouched(tmp_path, reference):
    path = scene(tmp_path)
    thesis = tmp_path / "thesis"
    thesis.mkdir()
    (thesis / "chapter1.tex").write_text("\\chapter{Rigid bodies}\n")
    (thesis / "zarr.json").write_text('{"zarr_format": 3, "node_type": "group", "attributes": {}}')
    plain = tmp_path / "notes.txt"
    plain.write_text("do not delete\n")
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    store = tmp_path / "real.zarr"
    sweep(path, VARY, out=store, chunk=1, scheduler="synchronous")
    link = tmp_path / "link.zarr"
    link.symlink_to(store)
    dangling = tmp_path / "dangling.zarr"
    dangling.symlink_to(tmp_path / "nowhere")
    foreign = tmp_path / "foreign.zarr"
    shutil.copytree(store, foreign)
    (foreign / "my_results.csv").write_text("1,2,3\n")
    cases = {
        thesis: "is not a lieint sweep store (no 'lieint_sweep' attribute)",
        plain: "is a regular file, not a lieint sweep store",
        fifo: "is a FIFO (named pipe), not a lieint sweep store",
        link: "is a symbolic link, not a lieint sweep store",
        dangling: "is a symbolic link, not a lieint sweep store",
        foreign: "holds entries lieint did not write ('my_results.csv')",
    }
    before = {target: snapshot(target) for target in cases}
    for target, expected in cases.items():
        tic = time.monotonic()
        done = cli(sweep_args(path, target, "--overwrite"), tmp_path, timeout=60)
        assert time.monotonic() - tic < 30
        assert done.returncode == 2, (target, done.stderr)
        assert "--overwrite refused" in done.stderr and expected in done.stderr, done.stderr
        assert "left untouched" in done.stderr and done.stderr.count("\n") == 1, done.stderr
        assert snapshot(target) == before[target], target  # not a byte changed
    assert_same(data(store), reference)  # the store behind the link too
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert not leftovers, leftovers
    # a lieint sweep store is replaced
    done = cli(sweep_args(path, store, "--overwrite"), tmp_path)
    assert done.returncode == 0, done.stderr
    assert_same(data(store), reference)


# -- checksums ----------------------------------------------------------------------------------------


def _chunk_file(store: Path, name: str, chunk: int) -> Path:
    root = zarr.open_group(str(store), mode="r", use_consolidated=False)
    arr = root[name]
    return store / name / arr.metadata.encode_chunk_key((chunk,) + (0,) * (arr.ndim - 1))


@pytest.mark.slow
def test_deleted_truncated_and_garbage_chunks_are_named_never_read_and_recomputed(tmp_path, reference):
    path = scene(tmp_path)
    out = tmp_path / "s.zarr"
    assert cli(sweep_args(path, out), tmp_path).returncode == 0
    _chunk_file(out, "state_A", 1).unlink()
    victim = _chunk_file(out, "energy", 3)
    victim.write_bytes(victim.read_bytes()[:7])
    garbage = _chunk_file(out, "state_A", 4)
    garbage.write_bytes(os.urandom(garbage.stat().st_size))
    tic = time.monotonic()
    info = cli(["info", str(out)], tmp_path, timeout=60)
    assert time.monotonic() - tic < 30
    assert info.returncode == 1, info.stdout
    text = info.stdout
    assert "damaged: chunk 1: state_A: its file is missing" in text, text
    assert "chunk 3: energy: its file is truncated (7 of" in text, text
    assert "chunk 4: state_A: its file fails its SHA-256 (changed bytes)" in text, text
    assert "--resume recomputes these chunks" in text
    with pytest.raises(DamagedStoreError, match=r"chunk 1: state_A: its file is missing; chunk 3: .*chunk 4"):
        open_sweep(out)
    masked = open_sweep(out, damaged="mask")  # the good chunks read, the damaged ones NaN: never their files
    values = masked["state_A"].values
    assert np.all(np.isnan(values[[1, 3, 4]])) and np.array_equal(values[[0, 2, 5]], reference["state_A"][[0, 2, 5]])
    assert masked["chunk_committed"].values.tolist() == [1, 0, 1, 0, 0, 1]
    resumed = cli(sweep_args(path, out, "--resume"), tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert "recomputed 3 committed chunks that failed their checksums (1, 3, 4)" in resumed.stderr
    assert "(3 computed, 3 already committed)" in resumed.stdout
    assert_same(data(out), reference)
    assert inspect_sweep(out).state == "complete"
    ds = open_sweep(out)
    assert np.array_equal(ds["state_A"].values, reference["state_A"])


def test_damage_to_the_records_and_the_layout(tmp_path, reference):
    path = scene(tmp_path)
    out = tmp_path / "s.zarr"
    sweep(path, VARY, out=out, chunk=1, scheduler="synchronous")
    _chunk_file(out, "chunk_committed", 2).write_bytes(b"\x00garbage")  # a flag that cannot be read
    _chunk_file(out, "chunk_sha256", 5).unlink()  # a record gone: chunk 5 no longer proves itself
    _chunk_file(out, "chunk_committed", 0).unlink()  # a flag gone: it reads 0, in a complete store
    info = inspect_sweep(out)
    assert info.state == "damaged" and info.exit_code == 1, info.text()
    assert "chunk 0: its commit flag is missing (the store was complete)" in info.text()
    assert "chunk 2: its commit flag cannot be read" in info.text()
    assert "chunk 5: its checksum record is missing or unreadable" in info.text()
    assert np.all(np.isnan(open_sweep(out, damaged="mask")["state_A"].values[[0, 2, 5]]))
    report = sweep(path, VARY, out=out, chunk=1, scheduler="synchronous", resume=True)
    assert sorted(report.damaged) == [2, 5] and report.computed == 3  # chunk 0 reads as never committed
    assert_same(data(out), reference)
    # the layout: an array's metadata changed
    meta = out / "state_A" / "zarr.json"
    doc = json.loads(meta.read_text())
    doc["fill_value"] = 0.0
    meta.write_text(json.dumps(doc))
    info = inspect_sweep(out)
    assert info.state == "damaged" and "the layout: state_A/zarr.json: its file" in info.text(), info.text()
    assert "--overwrite" in info.text()
    with pytest.raises(StoreError, match=r"cannot resume .*the layout: state_A/zarr.json.*--overwrite"):
        sweep(path, VARY, out=out, chunk=1, scheduler="synchronous", resume=True)
    with pytest.raises(DamagedStoreError, match="layout"):
        open_sweep(out)


def test_an_interrupted_store_reads_its_uncommitted_members_as_nan(tmp_path, reference):
    """A store whose writer was killed after three chunks: info says resumable, open_sweep reads
    the others as NaN whatever their files hold, --resume completes the same result."""
    from lieint.sweeps import plan_from_scene
    from lieint.sweeps.chunk import compute_chunk
    from lieint.sweeps.store import SweepStore

    path = scene(tmp_path)
    out = tmp_path / "s.zarr"
    plan = plan_from_scene(path, VARY, chunk=1)
    store = SweepStore(out, plan)
    for c in (0, 2, 3):
        store.commit(compute_chunk(plan, c), "first")
    half = compute_chunk(plan, 4)
    store.root["state_A"][4:5] = half.states["A"] + 1.0  # written, never committed: must not be read
    info = inspect_sweep(out)
    assert info.state == "interrupted" and info.exit_code == 3 and info.resumable, info.text()
    assert "3 of 6 chunks committed; resumable" in info.text()
    ds = open_sweep(out)
    A = ds["state_A"].values
    assert np.all(np.isnan(A[[1, 4, 5]])) and np.array_equal(A[[0, 2, 3]], reference["state_A"][[0, 2, 3]])
    report = sweep(path, VARY, out=out, chunk=1, scheduler="synchronous", resume=True)
    assert (report.computed, report.skipped) == (3, 3)
    assert_same(data(out), reference)


def test_info_says_running_interrupted_unreadable_and_unchecked_within_seconds(tmp_path):
    path = scene(tmp_path)
    plain = tmp_path / "plain"
    plain.mkdir()
    for target in (plain, tmp_path / "nothing.zarr"):
        done = cli(["info", str(target)], tmp_path, timeout=60)
        assert done.returncode == 1 and "Traceback" not in done.stderr, (done.stdout, done.stderr)
    many = tmp_path / "many.zarr"
    sweep(path, ["body.principal_moments[0]=1:1.4:100"], out=many, chunk=1, scheduler="synchronous")
    tic = time.monotonic()
    # a deadline that has passed before the first file is read (opening the store alone takes
    # longer): on a fast machine 0.05 s sufficed to verify all 100 chunks
    hurried = inspect_sweep(many, timeout=1e-6)
    assert time.monotonic() - tic < 5
    assert hurried.state == "unchecked" and hurried.exit_code == 5, hurried.text()
    assert "could not check within the deadline" in hurried.text() and "damaged" not in hurried.text()
    full = inspect_sweep(many, timeout=60)
    assert full.state == "complete" and full.exit_code == 0, full.text()
    assert "100 committed chunks verified" in full.text()


# -- a full disk ------------------------------------------------------------------------------------------


def _limit_file_size(size):
    import resource

    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    return apply


@pytest.mark.slow
def test_the_file_size_limit_ends_with_one_message_and_the_sweep_resumes(tmp_path):
    """ulimit -f below the file of the state's chunk (every row saved, one chunk of six members)
    but above every other file: the kernel refuses the write (EFBIG), the sweep ends with one
    line and exit status 4 and resumes identically; without LIEINT_SKIP_ROOM_CHECK the same
    limit is refused before anything is created."""
    path = tmp_path / "every.toml"
    path.write_text(TOP.replace("T_END", "8.0").replace("save_every = 10", "save_every = 1"), encoding="utf-8")
    args = ["sweep", str(path), "--vary", VARY[0], "--chunk", "6", "--scheduler", "synchronous", "--quiet", "--out"]
    assert cli([*args, str(tmp_path / "probe.zarr")], tmp_path).returncode == 0
    probe = tmp_path / "probe.zarr"
    big = _chunk_file(probe, "state_A", 0).stat().st_size
    others = max(f.stat().st_size for f in probe.rglob("*") if f.is_file() and "state_A" not in f.parts)
    assert big > 1.2 * others, (big, others)
    limit = (big + others) // 2
    out = tmp_path / "s.zarr"
    full = cli([*args, str(out)], tmp_path, env=dict(os.environ, LIEINT_SKIP_ROOM_CHECK="1"),
               preexec_fn=_limit_file_size(limit))  # fmt: skip
    assert full.returncode == 4, (full.returncode, full.stderr)
    assert full.stderr.count("\n") == 1 and "Traceback" not in full.stderr, full.stderr
    assert "the disk is full or the file-size limit (ulimit -f) was reached" in full.stderr
    assert "File too large" in full.stderr and "continue with --resume" in full.stderr
    assert inspect_sweep(out).resumable
    done = cli([*args, str(out), "--resume"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert_same(data(out), data(probe))
    refused = cli([*args, str(tmp_path / "r.zarr")], tmp_path, preexec_fn=_limit_file_size(limit))
    assert refused.returncode == 2 and "the file-size limit (ulimit -f) is" in refused.stderr, refused.stderr
    assert "--chunk" in refused.stderr and not (tmp_path / "r.zarr").exists()


def _unshare_works() -> bool:
    if shutil.which("unshare") is None:
        return False
    return subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode == 0


@pytest.mark.skipif(not _unshare_works(), reason="needs user and mount namespaces (unshare -rm) for a small tmpfs")
@pytest.mark.slow
def test_a_full_tmpfs_ends_with_one_message_and_the_sweep_resumes(tmp_path, reference):
    """A real full disk: a 120 kB tmpfs in a private mount namespace; the store is copied out
    after a resume on the same tmpfs made larger."""
    path = scene(tmp_path)
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    keep = tmp_path / "kept.zarr"
    lieint = f"{sys.executable} -m lieint " + " ".join(sweep_args(path, mnt / "s.zarr"))
    script = f"""
set -u
mount -t tmpfs -o size=120k tmpfs {mnt}
LIEINT_SKIP_ROOM_CHECK=1 {lieint} > {tmp_path}/full.out 2> {tmp_path}/full.err
echo $? > {tmp_path}/full.rc
{sys.executable} -m lieint info {mnt}/s.zarr > {tmp_path}/info.out
mount -o remount,size=64m {mnt}
{lieint} --resume > {tmp_path}/resume.out 2> {tmp_path}/resume.err
echo $? > {tmp_path}/resume.rc
cp -r {mnt}/s.zarr {keep}
"""
    subprocess.run(["unshare", "-rm", "sh", "-c", script], check=True, timeout=600, cwd=tmp_path)
    err = (tmp_path / "full.err").read_text()
    assert (tmp_path / "full.rc").read_text().strip() == "4", err
    assert err.count("\n") == 1 and "Traceback" not in err and "No space left on device" in err, err
    assert "resumable" in (tmp_path / "info.out").read_text()
    assert (tmp_path / "resume.rc").read_text().strip() == "0", (tmp_path / "resume.err").read_text()
    assert_same(data(keep), reference)


# -- Ctrl-C ---------------------------------------------------------------------------------------------


def test_an_interrupt_amid_asynchronous_writes_still_prints_one_line(tmp_path):
    # an interrupt while zarr's asynchronous writes are in flight leaves coroutines never awaited
    # (seen once under load: six lines of RuntimeWarning after the message); here the interrupt
    # comes with such a coroutine held by its traceback, as it did there
    path = scene(tmp_path)
    script = f"""
import asyncio, sys
import lieint.sweeps
from lieint import cli

def interrupted(*args, **kwargs):
    pending = asyncio.sleep(0)  # a coroutine the interrupt leaves unawaited
    raise KeyboardInterrupt

lieint.sweeps.sweep = interrupted
sys.exit(cli.main(["sweep", {str(path)!r}, "--vary", "body.principal_moments[0]=1:1.4:2", "--out",
                   {str(tmp_path / "s.zarr")!r}, "--quiet"]))
"""
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 130 and proc.stderr.count("\n") == 1, proc.stderr
    assert "continue with --resume" in proc.stderr and "never awaited" not in proc.stderr


@pytest.mark.slow
def test_ctrl_c_stops_with_one_line_and_resumes(tmp_path):
    # 120 chunks, not the module's 6: on a fast machine the 5 chunks after the first commit
    # finished before the signal was handled, and the test could only skip
    vary = "body.principal_moments[0]=1:1.4:120"
    path = scene(tmp_path, t_end="2.0")
    expected = sweep(path, [vary], out=tmp_path / "ref.zarr", chunk=1, scheduler="synchronous")
    assert expected.status == "complete" and expected.nchunks == 120
    out = tmp_path / "s.zarr"
    args = ["sweep", str(path), "--vary", vary, "--chunk", "1", "--scheduler", "synchronous", "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "lieint", *args, "--quiet"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if (out / "chunk_committed" / "c" / "0").exists():
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and err.count("\n") == 1 and "continue with --resume" in err, err
    assert inspect_sweep(out).resumable
    assert cli([*args, "--quiet", "--resume"], tmp_path).returncode == 0
    assert_same(data(out), data(tmp_path / "ref.zarr"))
