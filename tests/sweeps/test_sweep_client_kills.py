"""The sweep client (``lieint sweep`` in a subprocess) SIGKILLed at ten random instants, then
``--resume``: the store equals an uninterrupted one and no worker outlives its client (its own
file, the suite's longest test: the test runner's processes share the work better)."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import assert_same_sweep

zarr = pytest.importorskip("zarr")
distributed = pytest.importorskip("distributed")
xr = pytest.importorskip("xarray")

import lieint  # noqa: E402

# -- the client killed at random instants: nothing lost, nothing left running ---------------------------


def _session(sid: int) -> list[int]:
    """Live processes of the session ``sid`` (the killed client's workers would be there)."""
    alive = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[0] != "Z" and int(fields[3]) == sid:  # state, ppid, pgrp, session
            alive.append(int(entry))
    return alive


# a 4D top stepped by the Strang splitting: the generic path (its exact sub-flows beyond the 3D top
# have no compiled kernel: a declared exception, tests/fast/test_numpy_path_exceptions.py), so that
# its chunks take long enough (about a second each) for kills to land between commits
GENERIC_4D = """
[scene]
name = "4D top, generic path"
[body]
mass_tensor = [[0.5, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.7, 0], [0, 0, 0, 2.3]]
[support]
type = "fixed_point"
[initial]
omega = [[0.0, -0.3, 0.5, -0.2], [0.3, 0.0, -0.4, 0.6], [-0.5, 0.4, 0.0, -0.1], [0.2, -0.6, 0.1, 0.0]]
[integrator]
method = "splitting2"
step = 0.002
t_end = 1.5
project = true
save_every = 10
[output]
quantities = ["energy", "casimirs"]
"""


@pytest.mark.slow
def test_ten_kills_of_the_client_then_resume_give_the_uninterrupted_store_and_leave_no_worker(tmp_path):
    """``lieint sweep --workers 2`` (a LocalCluster of two worker processes) SIGKILLed at 10
    random instants of its run (half at a random fraction of its duration, half a random time
    after a random number of further commits), each time resumed: the final store equals an uninterrupted one
    bit for bit, no worker process outlives its client by 10 s, and a normal end prints nothing
    on stderr (no warnings from distributed)."""
    scene = tmp_path / "top4.toml"
    scene.write_text(GENERIC_4D, encoding="utf-8")
    cmd = [sys.executable, "-m", "lieint", "sweep", str(scene), "--vary", "initial.omega[0][1]=-0.6:0.6:12",
           "--chunk", "1", "--workers", "2", "--quiet", "--out"]  # fmt: skip
    tic = time.monotonic()
    whole = subprocess.run([*cmd, str(tmp_path / "whole.zarr")], capture_output=True, text=True, timeout=600)
    duration = time.monotonic() - tic
    assert whole.returncode == 0, whole.stderr
    assert whole.stderr == "", whole.stderr  # no warnings from distributed on a normal end
    out = tmp_path / "s.zarr"
    rng = np.random.default_rng(2026)
    committed_before = []
    for attempt in range(10):
        committed = _committed(out)
        committed_before.append(committed)
        args = [*cmd, str(out)] + (["--resume"] if out.exists() else [])
        proc = subprocess.Popen(args, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if attempt % 2 == 0 or committed >= 11:
            # anywhere in its run: starting, computing, committing
            time.sleep(float(rng.uniform(0.2, 1.1)) * duration)
        else:
            # a random instant after a random number of further commits: a time fraction alone
            # lands before the first commit or after the last one when the machine's speed
            # changes between runs, and the kills must also meet a store partly committed
            target = int(rng.integers(committed + 1, 12))
            deadline = time.monotonic() + 2 * duration
            while _committed(out) < target and proc.poll() is None and time.monotonic() < deadline:
                time.sleep(0.02)
            time.sleep(float(rng.uniform(0.0, 0.5)) * duration / 12)
        if proc.poll() is not None:
            continue  # it finished first: the next attempt resumes a complete store
        os.kill(proc.pid, signal.SIGKILL)  # the client only: its workers must end by themselves
        proc.wait(timeout=30)
        deadline = time.monotonic() + 10
        while _session(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = _session(proc.pid)
        for pid in left:  # leave the machine clean whatever the outcome
            os.kill(pid, signal.SIGKILL)
        assert not left, f"attempt {attempt}: worker processes {left} outlived their client by 10 s"
    done = subprocess.run([*cmd, str(out), "--resume"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert_same_sweep(lieint.sweeps.open_sweep(out), lieint.sweeps.open_sweep(tmp_path / "whole.zarr"))
    assert any(0 < c < 12 for c in committed_before), f"no resume met a partly committed store: {committed_before}"


def _committed(out) -> int:
    try:
        return int(np.sum(zarr.open_array(str(out / "chunk_committed"), mode="r")[...]))
    except Exception:
        return 0
