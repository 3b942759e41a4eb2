"""Sweeps on a real dask LocalCluster of two worker processes.

* the distributed sweep equals, bit for bit, the one-process ensemble;
* a worker process SIGKILLed mid-sweep: its chunk is recomputed and the result is unchanged;
* the client (``lieint sweep --scheduler ADDRESS`` in a subprocess) SIGKILLed mid-sweep:
  ``--resume`` skips the committed chunks and completes the same result.
"""

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from conftest import assert_same_sweep

zarr = pytest.importorskip("zarr")
distributed = pytest.importorskip("distributed")
xr = pytest.importorskip("xarray")

import lieint  # noqa: E402
from lieint.scenes import embedded_scene  # noqa: E402
from lieint.sweeps import sweep  # noqa: E402

# a heavy top runs on the generic (numpy) path: chunks of about half a second each
HEAVY = """
[scene]
name = "heavy"
[body]
principal_moments = [1.0, 1.0, 0.5]
mass = 1.0
center_of_mass = [0.0, 0.0, 0.3]
[support]
type = "fixed_point"
[forces]
gravity = { magnitude = 9.81, incline = 0.0 }
[initial]
angular_velocity = [0.5, 0.0, 10.0]
[integrator]
method = "rkmk4"
step = 0.002
t_end = T_END
save_every = 50
[output]
quantities = ["energy", "casimirs"]
"""

VARY = {"forces.gravity.incline": np.linspace(0.0, 0.7, 8)}


@pytest.fixture(scope="module")
def client():
    threads = {k: "1" for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0", env=threads
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The heavy-top sweep run in this process (no dask)."""
    out = tmp_path_factory.mktemp("ref") / "ref.zarr"
    sweep(HEAVY.replace("T_END", "0.3"), VARY, out=out, chunk=1, scheduler="synchronous")
    return xr.open_zarr(out)


@pytest.mark.slow
def test_distributed_equals_the_one_process_ensemble_bit_for_bit(client, tmp_path):
    """A compiled ensemble (SIMD lanes, 64 members a chunk) against one integrate call on all 192."""
    out = tmp_path / "top.zarr"
    scene = embedded_scene("dzhanibekov").text.replace("t_end = 60.0", "t_end = 10.0")
    report = sweep(scene, ensemble=192, seed=3, spread=0.02, chunk=64, out=out, scheduler=client)
    assert (report.status, report.computed, report.workers) == ("complete", 3, 2)
    ds = xr.open_zarr(out)
    assert set(ds["chunk_info"].sel(info="backend").values.tolist()) == {"numba"}
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    w = np.array([0.01, 1.0, 0.01]) + 0.02 * np.random.default_rng(3).normal(size=(192, 3))
    sol = lieint.integrate(top, top.initial_state(angular_velocity=w), (0, 10), h=0.01, project=True, save_every=10)
    assert sol.stats.backend == "numba"
    for field in ("A", "R"):
        swept, here = ds[f"state_{field}"].values, np.swapaxes(sol.states[field], 0, 1)
        assert np.array_equal(swept, here), _mismatch(swept, here)
    assert np.array_equal(ds["drift_energy"].values, sol.drift("energy"))


def _mismatch(swept, here) -> str:
    """Where and by how much, and which compiled specialisations this process holds."""
    from lieint.fast import lanes

    members = np.flatnonzero(np.abs(swept - here).reshape(len(swept), -1).max(axis=1) > 0)
    return (
        f"max |difference| {np.abs(swept - here).max():.3e} in members {members[:10].tolist()} ...; "
        f"run_lanes signatures in this process: {getattr(lanes.run_lanes, 'signatures', '-')}"
    )


@pytest.mark.slow
def test_a_worker_killed_mid_sweep_changes_nothing(client, tmp_path, reference):
    out = tmp_path / "killed.zarr"
    before = client.run(os.getpid)
    killed = []

    def kill_one_worker():
        # wait until both workers are busy with chunks, then SIGKILL one of them mid-chunk
        deadline = time.time() + 60
        while time.time() < deadline:
            busy = [w for w, tasks in client.processing().items() if tasks]
            if len(busy) == 2:
                time.sleep(0.05)
                os.kill(before[busy[0]], signal.SIGKILL)
                killed.append(busy[0])
                return
            time.sleep(0.02)

    thread = threading.Thread(target=kill_one_worker)
    thread.start()
    report = sweep(HEAVY.replace("T_END", "0.3"), VARY, out=out, chunk=1, scheduler=client)
    thread.join()
    assert killed, "the test did not manage to kill a worker mid-sweep"
    assert report.status == "complete" and report.computed == 8
    ds = xr.open_zarr(out)
    assert ds["chunk_committed"].values.tolist() == [1] * 8
    assert_same_sweep(ds, reference)
    client.wait_for_workers(2, timeout=60)  # the nanny restarted the killed worker
    assert set(client.run(os.getpid).values()) != set(before.values())


def test_resume_after_the_client_is_killed_skips_committed_chunks(client, tmp_path):
    scene = tmp_path / "heavy.toml"
    # longer chunks than the other tests (about a second each): the client is killed after its first
    # commit, before its last (a client slower than the workers commits in bursts)
    scene.write_text(HEAVY.replace("T_END", "2.0"), encoding="utf-8")
    out = tmp_path / "resumed.zarr"
    cmd = [sys.executable, "-m", "lieint", "sweep", str(scene), "--vary", "forces.gravity.incline=0:0.7:4",
           "--chunk", "1", "--scheduler", client.scheduler.address, "--out", str(out), "--quiet"]  # fmt: skip
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    proc = subprocess.Popen(cmd, env=env, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        committed = 0
        deadline = time.time() + 120
        while time.time() < deadline and proc.poll() is None:
            if (out / "chunk_committed" / "zarr.json").exists():
                # the one array, not the whole group, which the client may be adding arrays to
                committed = int(np.sum(zarr.open_array(str(out / "chunk_committed"), mode="r")[...]))
                if committed >= 1:
                    break
            time.sleep(0.05)
        assert proc.poll() is None, f"the sweep ended before it could be killed: {proc.communicate()}"
        os.killpg(proc.pid, signal.SIGKILL)  # the client, mid-sweep
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    partial = xr.open_zarr(out, consolidated=False)
    done = np.flatnonzero(partial["chunk_committed"].values == 1)
    assert 1 <= done.size < 4 and partial.attrs["status"] == "running"
    sessions = partial["chunk_info"].sel(info="session").values[done].tolist()
    report = sweep(scene, ["forces.gravity.incline=0:0.7:4"], out=out, chunk=1, scheduler=client, resume=True)
    assert report.skipped == done.size and report.computed == 4 - done.size
    ds = xr.open_zarr(out)
    assert (
        ds["chunk_info"].sel(info="session").values[done].tolist() == sessions
    )  # committed chunks were not recomputed
    whole = sweep(scene, ["forces.gravity.incline=0:0.7:4"], out=tmp_path / "whole.zarr", chunk=1, scheduler=client)
    assert whole.computed == 4
    assert_same_sweep(ds, xr.open_zarr(tmp_path / "whole.zarr"))


def test_a_chunk_that_fails_stops_the_sweep_and_keeps_the_committed_ones(client, tmp_path):
    """A step past the dexp⁻¹ radius raises on every retry: the sweep names the chunk and stops."""
    out = tmp_path / "fails.zarr"
    vary = {"initial.angular_velocity[2]": [10.0, 5000.0]}  # h |w| = 10 > 2π at the second point
    with pytest.raises(lieint.sweeps.SweepError, match=r"chunk 1 \(members 1..1\) failed after 2 retries: .*dexp"):
        sweep(HEAVY.replace("T_END", "0.01"), vary, out=out, chunk=1, scheduler=client)
    ds = xr.open_zarr(out, consolidated=False)
    assert ds.attrs["status"] == "failed" and "DexpinvRangeError" in ds.attrs["message"]
    assert ds["chunk_committed"].values.tolist() in ([1, 0], [0, 0])  # chunk 0 is kept if it finished first


# -- schedulers that cannot be used: refused before anything is created ------------------------------


def _server(mode: str):
    """A loopback TCP server that accepts and then never answers ("silent") or answers bytes
    that are not dask's protocol ("garbage"); returns its port (a daemon thread serves it)."""
    import socket

    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(16)
    held = []

    def serve():
        while True:
            conn, _ = listener.accept()
            held.append(conn)  # never closed, never answered
            if mode == "garbage":  # a length prefix of 2⁶⁴ − 1 frames: distributed would allocate exabytes
                conn.sendall(b"\xff" * 4096)
            elif mode == "http":  # read as a frame length of 3 EiB, which distributed tries to allocate
                conn.sendall(b"HTTP/1.1 200 OK\r\n\r\n")

    threading.Thread(target=serve, daemon=True).start()
    return listener.getsockname()[1]


@pytest.mark.parametrize(
    ("address", "expected"),
    [
        ("silent", "did not complete dask's handshake within 2 s"),  # the deadline given (the default's own test below)
        ("garbage", "it does not speak dask's protocol (ValueError"),
        ("http", "it does not speak dask's protocol (MemoryError: Unable to allocate 3.07 EiB"),
        ("file:///etc/passwd", "whose scheme 'file' is not one of dask's"),
        ("tcp://127.0.0.1", "tcp://HOST:PORT"),
    ],
)
@pytest.mark.slow
def test_a_scheduler_that_cannot_be_used_is_refused_in_one_line_and_nothing_is_created(tmp_path, address, expected):
    if address in ("silent", "garbage", "http"):
        address = f"tcp://127.0.0.1:{_server(address)}"
    out = tmp_path / "s.zarr"
    tic = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-m", "lieint", "sweep", "dzhanibekov", "--vary", "body.principal_moments[0]=1:1.2:3",
         "--scheduler", address, "--out", str(out), "--quiet", "--connect-timeout", "2"],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )  # fmt: skip
    seconds = time.monotonic() - tic
    assert seconds <= 12, seconds
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert expected in done.stderr, done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr
    assert list(tmp_path.iterdir()) == []  # no store, no lock, no temporary


def test_the_connect_deadline_defaults_to_twenty_seconds_everywhere():
    """The deadline the refusals above are given explicitly (2 s, to keep the suite quick) is by
    default 20 s in the command line, the Python call and the cluster alike."""
    import inspect

    import lieint.cli  # not imported by `import lieint`: alone, this test must import it itself
    from lieint.sweeps.cluster import CONNECT_SECONDS

    parser = lieint.cli._build_parser()
    args = parser.parse_args(["sweep", "dzhanibekov", "--vary", "body.mass=1:2:2", "--out", "s.zarr"])
    assert args.connect_timeout == CONNECT_SECONDS == 20.0
    assert inspect.signature(sweep).parameters["connect_timeout"].default == CONNECT_SECONDS


def test_a_scheduler_without_workers_is_refused(tmp_path):
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=None) as empty:
        with pytest.raises(lieint.sweeps.SweepError, match=r"has no workers; start some \(dask worker tcp://"):
            sweep(HEAVY.replace("T_END", "0.01"), VARY, out=tmp_path / "s.zarr", scheduler=empty.scheduler_address)
    assert not (tmp_path / "s.zarr").exists()


def test_a_scheduler_of_other_versions_or_with_workers_without_lieint_is_refused():
    """What the probe answered, checked against this process (the probe itself is exercised by
    every test above that names a scheduler address)."""
    from lieint.sweeps.cluster import check_versions

    here = distributed.versions.get_versions()["packages"]
    ok = {w: lieint.__version__ for w in ("tcp://127.0.0.1:1", "tcp://127.0.0.1:2")}
    assert check_versions("tcp://h:1", {"scheduler": dict(here), "workers": ok}) == 2
    cases = [
        ({**here, "distributed": "2020.1.0"}, ok, r"runs distributed 2020.1.0, this process " + here["distributed"]),
        ({**here, "python": "3.8.1.final.0"}, ok, r"runs Python 3.8.1.final.0, this process"),
        (here, {"tcp://127.0.0.1:1": "0.0.1"}, r"tcp://127.0.0.1:1 runs lieint 0.0.1; every worker needs lieint"),
        (here, {"tcp://127.0.0.1:1": "!ModuleNotFoundError: No module named 'lieint'"},
         r"cannot import lieint \(ModuleNotFoundError: No module named 'lieint'\)"),
    ]  # fmt: skip
    for scheduler, workers, match in cases:
        with pytest.raises(lieint.sweeps.SweepError, match=match):
            check_versions("tcp://h:1", {"scheduler": scheduler, "workers": workers})
