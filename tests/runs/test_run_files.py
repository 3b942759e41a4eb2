"""Run files under attack: concurrent writers, hostile paths, full disks, damaged files, limits.

Every scenario runs real processes (``python -m lieint``), as a user would.
"""

import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import lieint
from lieint.runs.info import inspect_run
from lieint.runs.plot import PlotError, plot_run

SCENE = """
[scene]
name = "4D top"

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
save_every = 1

[output]
quantities = ["energy", "casimirs", "orientation"]
"""

T_END = 28.0  # 14,000 steps on the generic path: a few seconds, long enough to be caught live
PLANNED = 14_000  # T_END / step


def scene_file(tmp_path, t_end=T_END, name="s.toml"):
    path = tmp_path / name
    path.write_text(SCENE.format(t_end=t_end))
    return path


def read_all(path):
    with h5py.File(path, "r") as f:  # plain open: a completed or resumed file needs no SWMR flag
        out = {"t": f["t"][()]}
        for group in ("states", "invariants", "outputs"):
            if group in f:
                out.update({f"{group}/{k}": v[()] for k, v in f[group].items()})
        return out


def assert_identical(a, b):
    assert a.keys() == b.keys()
    for key in a:
        assert a[key].shape == b[key].shape, key
        assert np.array_equal(a[key], b[key]), key


def cli(args, cwd, **kw):
    return subprocess.run(
        [sys.executable, "-m", "lieint", *args], cwd=cwd, capture_output=True, text=True, timeout=120, **kw
    )


_STARTED: list[subprocess.Popen] = []


def start(args, cwd):
    proc = subprocess.Popen(
        [sys.executable, "-m", "lieint", *args],
        cwd=cwd,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    _STARTED.append(proc)
    return proc


@pytest.fixture(autouse=True)
def _no_writer_outlives_its_test():
    """A test that fails while its writer runs (a timeout on a loaded machine) ends that writer:
    left running, it would load the machine for the tests after it."""
    yield
    while _STARTED:
        proc = _STARTED.pop()
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def wait_for_rows(out, proc, rows=200, timeout=60.0):
    """Until the live run holds its lock and has written ``rows`` rows."""
    deadline = time.monotonic() + timeout
    lock = Path(str(out) + ".lock")
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        if str(proc.pid) not in (lock.read_text() if lock.exists() else ""):
            time.sleep(0.05)
            continue
        try:
            with h5py.File(out, "r", swmr=True) as f:
                if f["t"].shape[0] >= rows:
                    return
        except (OSError, KeyError):
            pass
        time.sleep(0.05)
    raise AssertionError("the run wrote no rows")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ref")
    report = lieint.run(scene_file(tmp), tmp / "ref.h5", progress=False)
    assert report.status == "complete"
    return read_all(tmp / "ref.h5")


# -- one writer -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "first, second",
    [([], []), ([], ["--resume"]), ([], ["--overwrite"]), (["--overwrite"], ["--overwrite"])],
    ids=["run+run", "run+resume", "run+overwrite", "overwrite+overwrite"],
)
@pytest.mark.slow
def test_a_second_writer_is_refused_at_once_and_the_first_finishes_intact(tmp_path, reference, first, second):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    if first:  # something to overwrite: a finished run of another length
        lieint.run(scene_file(tmp_path, t_end=0.5, name="short.toml"), out, progress=False)
    proc = start(["run", str(scene), "--out", str(out), "--quiet", "--checkpoint-every", "500", *first], tmp_path)
    wait_for_rows(out, proc)
    tic = time.monotonic()
    other = cli(["run", str(scene), "--out", str(out), "--quiet", *second], tmp_path)
    assert time.monotonic() - tic < 10
    assert other.returncode == 2, other.stderr
    assert f"being written by process {proc.pid} on host" in other.stderr and "only one writer" in other.stderr
    assert "started 20" in other.stderr  # the holder's start time
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    assert_identical(read_all(out), reference)  # the refused writer changed nothing
    assert not Path(str(out) + ".lock").exists()  # the lock goes with the run


@pytest.mark.slow
def test_the_lock_of_a_killed_writer_is_released(tmp_path, reference):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    proc = start(["run", str(scene), "--out", str(out), "--quiet", "--checkpoint-every", "500"], tmp_path)
    wait_for_rows(out, proc, rows=1200)
    proc.kill()
    proc.wait()
    assert Path(str(out) + ".lock").exists()  # left behind by SIGKILL, but no longer locked
    assert plot_run(out, tmp_path / "killed.png").exists()  # the SWMR flag is still set: read safely
    info = inspect_run(out)
    assert info.state == "interrupted" and info.resumable, info.text()
    assert "interrupted at step" in info.text() and f"of {PLANNED}; resumable" in info.text()
    done = cli(["run", str(scene), "--out", str(out), "--resume", "--quiet"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert "resuming at step" in done.stderr
    assert_identical(read_all(out), reference)
    assert inspect_run(out).state == "complete"


def test_a_stopped_run_opens_with_plain_h5py_and_plots(tmp_path, reference):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    report = lieint.run(scene, out, progress=False, stop_after=1000)
    assert report.status == "interrupted"
    with h5py.File(out) as f:  # closed cleanly: no SWMR flag needed
        assert f.attrs["status"] == "interrupted" and f["t"].shape == (1001,)
    info = inspect_run(out)
    assert info.exit_code == 3 and f"interrupted at step 1000 of {PLANNED}; resumable" in info.text()
    assert plot_run(out).exists()
    lieint.run(scene, out, progress=False, resume=True)
    assert_identical(read_all(out), reference)


def test_info_names_the_live_writer(tmp_path):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    proc = start(["run", str(scene), "--out", str(out), "--quiet"], tmp_path)
    try:
        wait_for_rows(out, proc)
        info = cli(["info", str(out)], tmp_path)
        assert info.returncode == 3, info.stdout + info.stderr
        assert f"running: being written by process {proc.pid}" in info.stdout
    finally:
        proc.kill()
        proc.wait()


# -- what --overwrite may replace, and links ---------------------------------------------------------


@pytest.mark.slow
def test_overwrite_refuses_what_is_not_a_lieint_run_and_leaves_it_untouched(tmp_path):
    scene = scene_file(tmp_path, t_end=0.1)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    foreign = tmp_path / "thesis.txt"
    foreign.write_text("three years of work")
    other_h5 = tmp_path / "data.h5"
    with h5py.File(other_h5, "w") as f:
        f["x"] = np.arange(5.0)
    directory = tmp_path / "adir"
    directory.mkdir()
    link = tmp_path / "link.h5"
    link.symlink_to(foreign)
    expected = {
        fifo: "is a FIFO (named pipe), not a lieint run file",
        foreign: "is not a lieint run file",
        other_h5: "is not a lieint run file",
        directory: "is a directory, not a lieint run file",
        link: "is a symbolic link, not a lieint run file",
    }
    before = other_h5.read_bytes()
    for target, message in expected.items():
        tic = time.monotonic()
        result = cli(["run", str(scene), "--out", str(target), "--overwrite", "--quiet"], tmp_path)
        assert time.monotonic() - tic < 10
        assert result.returncode == 2 and "--overwrite refused" in result.stderr, result.stderr
        assert message in result.stderr and "untouched" in result.stderr
    assert fifo.is_fifo() and directory.is_dir() and link.is_symlink()
    assert foreign.read_text() == "three years of work" and other_h5.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["s.toml", *(p.name for p in expected)])
    # a lieint run file is replaced
    out = tmp_path / "run.h5"
    assert cli(["run", str(scene), "--out", str(out), "--quiet"], tmp_path).returncode == 0
    assert cli(["run", str(scene), "--out", str(out), "--quiet", "--overwrite"], tmp_path).returncode == 0


@pytest.mark.slow
def test_links_planted_beside_a_run_are_never_followed(tmp_path, reference):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    victim = tmp_path / "victim.txt"
    victim.write_text("do not touch")
    for name in ("run.h5.checkpoint.tmp", "run.h5.checkpoint", ".run.h5.tmp"):
        (tmp_path / name).symlink_to(victim)
    result = cli(["run", str(scene), "--out", str(out), "--quiet", "--checkpoint-every", "300"], tmp_path)
    assert result.returncode == 0, result.stderr
    assert victim.read_text() == "do not touch"
    assert_identical(read_all(out), reference)
    # temporary files a killed writer left are removed; links of that form only as links
    stale = tmp_path / ".run.h5.0123456789abcdef.tmp"
    stale.write_bytes(b"half a file")
    stale_link = tmp_path / ".run.h5.checkpoint.fedcba9876543210.tmp"
    stale_link.symlink_to(victim)
    result = cli(["run", str(scene), "--out", str(out), "--quiet", "--overwrite"], tmp_path)
    assert result.returncode == 0, result.stderr
    assert not os.path.lexists(stale) and not os.path.lexists(stale_link)
    assert victim.read_text() == "do not touch"
    # a link at the lock's name is refused, not followed
    (tmp_path / "other.h5.lock").symlink_to(victim)
    result = cli(["run", str(scene), "--out", str(tmp_path / "other.h5"), "--quiet"], tmp_path)
    assert result.returncode == 2 and "is a symbolic link; refusing to use it" in result.stderr
    assert victim.read_text() == "do not touch" and not (tmp_path / "other.h5").exists()
    # and so is a link at the output when resuming
    link = tmp_path / "linked.h5"
    link.symlink_to(out)
    result = cli(["run", str(scene), "--out", str(link), "--quiet", "--resume"], tmp_path)
    assert result.returncode == 2 and "is a symbolic link, not a lieint run file" in result.stderr


# -- a full disk ---------------------------------------------------------------------------------------


def _limit_file_size(nbytes):
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (nbytes, nbytes))

    return apply


@pytest.mark.slow
def test_file_size_limit_gives_one_clear_message_and_the_run_resumes(tmp_path, reference):
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    size = 1_000_000  # the whole run writes about 1.6 MB
    env = dict(os.environ, LIEINT_SKIP_ROOM_CHECK="1")  # let it start and meet the limit on the way
    full = cli(
        ["run", str(scene), "--out", str(out), "--quiet", "--checkpoint-every", "200"],
        tmp_path,
        env=env,
        preexec_fn=_limit_file_size(size),
    )
    assert full.returncode == 4, (full.returncode, full.stderr)
    assert "Traceback" not in full.stderr and full.stderr.count("lieint run:") == 1, full.stderr
    assert "the disk is full or the file-size limit (ulimit -f) was reached" in full.stderr
    assert "rows up to the last checkpoint (step" in full.stderr and "--resume" in full.stderr
    info = inspect_run(out)
    assert info.resumable, info.text()
    done = cli(["run", str(scene), "--out", str(out), "--quiet", "--resume"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert_identical(read_all(out), reference)


@pytest.mark.slow
def test_a_write_failing_inside_hdf5_is_reported_once_and_the_run_resumes(tmp_path, reference):
    """As if another process filled the disk between lieint's room check and its write."""
    scene = scene_file(tmp_path)
    out = tmp_path / "run.h5"
    code = (
        "import sys\n"
        "from lieint.runs.runner import StreamedRun\n"
        "StreamedRun.room_for = lambda self, steps: steps  # no room check: HDF5 itself meets the limit\n"
        "from lieint.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    full = subprocess.run(
        [sys.executable, "-c", code, "run", str(scene), "--out", str(out), "--quiet", "--checkpoint-every", "200"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env=dict(os.environ, LIEINT_SKIP_ROOM_CHECK="1"),
        preexec_fn=_limit_file_size(1_000_000),
    )
    assert full.returncode == 4, (full.returncode, full.stderr)
    assert full.stderr.count("\n") == 1 and "Traceback" not in full.stderr, full.stderr
    assert "File too large (errno 27)" in full.stderr and "--resume" in full.stderr
    done = cli(["run", str(scene), "--out", str(out), "--quiet", "--resume"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert_identical(read_all(out), reference)
    assert inspect_run(out).state == "complete"


def test_a_run_that_cannot_fit_is_refused_before_it_starts(tmp_path):
    scene = scene_file(tmp_path)
    result = cli(
        ["run", str(scene), "--out", str(tmp_path / "r.h5"), "--quiet"],
        tmp_path,
        preexec_fn=_limit_file_size(300_000),
    )
    assert result.returncode == 2, result.stderr
    assert "but the file-size limit (ulimit -f) is 300 kB" in result.stderr
    assert "LIEINT_SKIP_ROOM_CHECK=1" in result.stderr
    assert not (tmp_path / "r.h5").exists()


# -- damaged files: info and plot within seconds ------------------------------------------------------


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fin")
    out = tmp / "run.h5"
    lieint.run(scene_file(tmp, t_end=2.0), out, progress=False)
    return out


def _timed(fn, *args):
    tic = time.monotonic()
    result = fn(*args)
    return result, time.monotonic() - tic


def test_info_of_an_intact_file(finished):
    info, seconds = _timed(inspect_run, finished)
    assert info.state == "complete" and info.exit_code == 0 and not info.problems
    assert "complete: 1000 of 1000 steps, 1001 rows" in info.text() and "every chunk verified" in info.text()
    assert seconds < 5


@pytest.mark.slow
def test_damage_at_known_places_is_reported_with_where(tmp_path, finished):
    data = bytearray(finished.read_bytes())
    with h5py.File(finished, "r") as f:
        chunk = f["states/A"].id.get_chunk_info(0)
    cases = {
        "superblock": (512 + 20, "damaged: the superblock at byte 512 fails its checksum"),
        "chunk": (chunk.byte_offset + 100, "damaged: /states/A rows 0–"),
    }
    for name, (offset, expected) in cases.items():
        path = tmp_path / f"{name}.h5"
        flipped = bytearray(data)
        flipped[offset] ^= 0x10
        path.write_bytes(bytes(flipped))
        result = cli(["info", str(path)], tmp_path)
        assert result.returncode == 1 and expected in result.stdout, result.stdout
        plot = cli(["plot", str(path)], tmp_path)
        assert plot.returncode == 2 and "Traceback" not in plot.stderr, plot.stderr
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(bytes(data[: len(data) // 2]))
    result = cli(["info", str(truncated)], tmp_path)
    assert result.returncode == 1 and f"truncated: the file is {len(data) // 2} bytes" in result.stdout
    # a changed attribute fails the attributes' SHA-256
    changed = tmp_path / "changed.h5"
    changed.write_bytes(bytes(data))
    with h5py.File(changed, "r+") as f:
        f.attrs["h"] = 0.5
    info = inspect_run(changed)
    assert info.state == "damaged" and "attributes fail their SHA-256" in info.text()


def test_random_truncations_and_flips_are_read_within_seconds(tmp_path, finished):
    data = finished.read_bytes()
    rng = np.random.default_rng(13)
    cases = []
    for i in range(4):
        cases.append((f"cut{i}", data[: int(rng.integers(0, len(data)))]))
    for i in range(8):
        flipped = bytearray(data)
        # half in the first 8 kB (superblock, object headers, B-trees), half anywhere
        at = int(rng.integers(0, 8192 if i % 2 == 0 else len(data)))
        flipped[at] ^= 1 << int(rng.integers(0, 8))
        cases.append((f"flip{i}", bytes(flipped)))
    for name, content in cases:
        path = tmp_path / f"{name}.h5"
        path.write_bytes(content)
        info, seconds = _timed(inspect_run, path)
        assert seconds < 5, (name, seconds)
        assert info.state in ("complete", "damaged", "unreadable"), info.text()
        try:
            _, seconds = _timed(plot_run, path, tmp_path / f"{name}.png")
        except PlotError as exc:
            assert str(exc), name
        assert seconds < 5, (name, seconds)


def test_plot_and_info_of_odd_inputs(tmp_path):
    one_row = tmp_path / "one.h5"
    scene = scene_file(tmp_path, t_end=0.002)
    lieint.run(scene, one_row, progress=False)
    assert plot_run(one_row).exists()  # one step: two rows (t0 and t1) plot
    with h5py.File(one_row, "r+") as f:  # keep the first row only
        for name in ["t"] + [f"{g}/{k}" for g in ("states", "invariants", "outputs") for k in f[g]]:
            f[name].resize((1,) + f[name].shape[1:])
    with pytest.raises(PlotError, match=r"holds 1 saved row\(s\); a plot needs at least two"):
        plot_run(one_row)
    result = cli(["plot", str(one_row)], tmp_path)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    empty = tmp_path / "empty.h5"
    empty.write_bytes(b"")
    assert inspect_run(empty).state == "unreadable"
    assert inspect_run(tmp_path).state == "unreadable"  # a directory
    assert "no such file" in inspect_run(tmp_path / "missing.h5").text()


# -- memory ---------------------------------------------------------------------------------------------

TOP3 = """
[scene]
name = "3D top, every step saved"

[body]
principal_moments = [1.0, 2.0, 3.0]

[support]
type = "fixed_point"

[initial]
angular_velocity = [0.01, 1.0, 0.01]

[integrator]
method = "rkmk4"
step = 0.01
t_end = {t_end}

[output]
quantities = ["energy", "casimirs", "orientation"]
"""


def _peak_rss_mb(args, cwd) -> float:
    proc = subprocess.Popen([sys.executable, "-m", "lieint", *args], cwd=cwd, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    return usage.ru_maxrss / 1024


@pytest.mark.slow
def test_peak_memory_is_flat_in_the_saved_rows(tmp_path):
    """10⁵ and 10⁶ saved rows (24 MB and 240 MB written): the same peak resident memory.

    Measured (benchmarks/run_files.py --full): 189.0 MB, 189.4 MB and, for 3·10⁶ rows, 192.0 MB.
    """
    peaks = {}
    for rows in (1_000, 100_000, 1_000_000):  # the first compiles and caches the kernel
        scene = tmp_path / f"top{rows}.toml"
        scene.write_text(TOP3.format(t_end=(rows - 1) * 0.01))
        peaks[rows] = _peak_rss_mb(["run", str(scene), "--out", str(tmp_path / f"top{rows}.h5"), "--quiet"], tmp_path)
        with h5py.File(tmp_path / f"top{rows}.h5") as f:
            assert f["t"].shape == (rows,)
    assert peaks[1_000_000] < 1.2 * peaks[100_000], peaks


# -- small things ----------------------------------------------------------------------------------------


def test_small_refusals_are_clear(tmp_path, capsys):
    from lieint.cli import main

    scene = scene_file(tmp_path, t_end=0.1)
    out = str(tmp_path / "r.h5")
    for bad in (["--max-drift", "energy=nan"], ["--max-drift", "energy=-1"]):
        assert main(["run", str(scene), "--out", out, "--quiet", *bad]) == 2
        assert "the limit of 'energy' must be a finite number >= 0" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", str(scene), "--out", out, "--checkpoint-every", "-5"])
    assert "expected a positive integer, got '-5'" in capsys.readouterr().err
    help_text = cli(["run", "--help"], tmp_path).stdout
    assert "default: 60" in help_text and "--checkpoint-every" in help_text
    # a NaN inside an array is reported as a NaN, not as a ragged array
    nan = tmp_path / "nan.toml"
    nan.write_text(scene.read_text().replace("[0.5, 0, 0, 0]", "[nan, 0, 0, 0]"))
    assert main(["run", str(nan)]) == 2
    assert "[body] mass_tensor (line 6): expected a finite number; got nan" in capsys.readouterr().err
    # a step far too large (exponential coordinates: beyond the dexp⁻¹ radius), held in memory:
    # the failure is a message, not a traceback
    big = tmp_path / "big.toml"
    text = re.sub(r'method = "lie_midpoint".*', 'method = "rkmk4"', scene.read_text())
    big.write_text(text.replace("step = 0.002", "step = 50.0").replace("t_end = 0.1", "t_end = 1000.0"))
    code = main(["run", str(big)])
    err = capsys.readouterr().err
    assert code == 2 and "Reduce the step `h`" in err


def test_mass_tensors_beyond_the_finite_range_are_refused():
    for B in (np.diag([1e300, 2e300, 3e300]), np.diag([1e-200, 2e-200, 3e-200])):
        with pytest.raises(ValueError, match=r"`B` must have its largest entry between 1e-100 and 1e\+100"):
            lieint.EulerTop(B)
    top = lieint.EulerTop(np.diag([1e90, 2e90, 3e90]))  # large but finite everywhere
    assert np.all(np.isfinite(top.b)) and np.all(np.isfinite(top.inertia.minus_inv_pair))


def test_a_reader_holding_the_file_does_not_stop_the_writer_from_reopening_it(tmp_path):
    """The writer reopens the run file after creating it (and on resume); a reader in another
    process that has it open at that instant (`lieint info`, a user's h5py.File, holding HDF5's
    shared file lock) must not make the run fail."""
    from lieint.runs.store import OutputFile

    out = tmp_path / "run.h5"
    lieint.run(scene_file(tmp_path, t_end=0.5), out, progress=False)
    holder = "import h5py, sys, time; f = h5py.File(sys.argv[1], 'r'); print('open', flush=True); time.sleep(60)"
    reader = subprocess.Popen([sys.executable, "-c", holder, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert reader.stdout.readline().strip() == "open"
        OutputFile._open_for_append(out, None).close()
    finally:
        reader.kill()
        reader.wait()


# -- one deadline for the whole command; out of time is not damaged ---------------------------------------


def test_info_out_of_time_says_so_with_its_own_exit_status_never_damaged(tmp_path, finished):
    for timeout in (0.001, 0.05, 0.3):
        info, seconds = _timed(inspect_run, finished, timeout)
        assert seconds < timeout + 2.0, (timeout, seconds)  # one deadline, not one per stage
        if info.state == "complete":
            continue  # a fast machine read it all in time: nothing to say
        assert info.state == "unchecked" and info.exit_code == 5, info.text()
        assert "could not check within the deadline" in info.text() and "damaged" not in info.text(), info.text()
    done = cli(["info", str(finished), "--timeout", "0.001"], tmp_path)
    assert done.returncode == 5 and "could not check within the deadline" in done.stdout, done.stdout
    assert inspect_run(finished, timeout=60).exit_code == 0


def test_a_file_hdf5_cannot_read_is_damaged_once(tmp_path, finished):
    data = bytearray(finished.read_bytes())
    data[1200:6000] = bytes(4800)  # object headers and B-trees zeroed: HDF5 refuses it
    path = tmp_path / "zeroed.h5"
    path.write_bytes(bytes(data))
    info = inspect_run(path)
    assert info.state == "damaged" and info.exit_code == 1, info.text()
    assert "damaged: damaged" not in info.text() and info.text().count("damaged") >= 1, info.text()
