"""Scene events in streamed runs (``lieint run --out``): recorded in the file, the same as in
memory, and bit-identical after an interruption and ``--resume``."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from conftest import FLIPS

import lieint
import lieint.cli
from lieint.methods.registry import method_specs
from lieint.scenes import embedded_scenes, parse_scene, run_scene
from lieint.systems.euler_top_exact import euler_top_flip_times


def read_all(path):
    """Every dataset of a run file (rows and events) and its status."""
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
        return out, str(f.attrs["status"])


def flips_scene(tmp_path, method, t_end, save_every=20):
    text = FLIPS.replace('method = "rkmk853"', f'method = "{method}"').replace("t_end = 60.0", f"t_end = {t_end}")
    text = text.replace("step = 0.01", "step = 0.02").replace("save_every = 20", f"save_every = {save_every}")
    if not method_specs()[method].adaptive:
        text = text.replace("rtol = 1e-13\natol = 1e-16\n", "")
    path = tmp_path / f"flips-{method.replace(':', '_')}.toml"
    path.write_text(text)
    return path


def test_a_streamed_run_records_the_flips_as_in_memory(tmp_path):
    scene = flips_scene(tmp_path, "rkmk853", 60.0)
    out = tmp_path / "flips.h5"
    assert lieint.cli.main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    data, status = read_all(out)
    assert status == "complete"
    memory = run_scene(parse_scene(scene.read_text())).solution
    np.testing.assert_array_equal(data["events/flip/t"], memory.t_events[0])
    np.testing.assert_array_equal(data["events/flip/A"], memory.y_events[0]["A"])
    exact = euler_top_flip_times([1.0, 2.0, 3.0], [0.01, 1.0, 0.01], 60.0)
    assert data["events/flip/t"].size == exact.size == 3
    assert np.max(np.abs(data["events/flip/t"] - exact)) <= 1e-8
    # the event states lie on the orbit of A₀ (|A| kept)
    A0 = data["states/A"][0]
    assert np.allclose(np.linalg.norm(data["events/flip/A"], axis=(-2, -1)), np.linalg.norm(A0), rtol=1e-13, atol=0)


@pytest.mark.parametrize("method", ["rkmk4", "rkmk6", "rkmk853", "splitting4", "scipy:DOP853"])
@pytest.mark.slow
def test_resumed_runs_record_the_same_events_bit_for_bit(tmp_path, method):
    """Fixed steps (cubic and quintic interpolants: the latter carries an earlier step across
    the checkpoint), adaptive steps (two earlier steps), a method without an increment, and
    scipy (recomputed from the start)."""
    scene = flips_scene(tmp_path, method, 32.0, save_every=1)
    whole, parts = tmp_path / "whole.h5", tmp_path / "parts.h5"
    assert lieint.run(scene, whole, progress=False).status == "complete"
    # interrupted right before the step that holds each flip (row k is the state after k steps),
    # so that the step after each resume locates an event with the interpolant it rebuilds
    with h5py.File(whole, "r") as f:
        before = np.searchsorted(f["t"][()], f["events/flip/t"][()]) - 1
    assert before.size == 2 and 0 < before[0] < before[1]
    if method.startswith("scipy:"):  # rows on the h grid, not at scipy's steps; resumed from the start
        before = [10, 30]
    report = lieint.run(scene, parts, progress=False, stop_after=int(before[0]), checkpoint_every=7)
    assert report.status == "interrupted" and report.steps_done == before[0]
    report = lieint.run(scene, parts, resume=True, progress=False, stop_after=int(before[1] - before[0]))
    # (a scipy run's replay of the steps on disk may reach the end in this call)
    assert report.status == "interrupted" or method.startswith("scipy:")
    if report.status != "complete":
        assert lieint.run(scene, parts, resume=True, progress=False).status == "complete"
    a, _ = read_all(whole)
    b, _ = read_all(parts)
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    exact = euler_top_flip_times([1.0, 2.0, 3.0], [0.01, 1.0, 0.01], 32.0)
    assert a["events/flip/t"].size == exact.size == 2


def test_a_terminal_event_ends_the_streamed_run_at_the_event(tmp_path):
    text = (
        embedded_scenes()["incline_ball"].text
        + '\n[[events]]\nname = "leaves the incline"\noutput = "center"\ncomponent = 0\nvalue = 3.0\nterminal = true\n'
    )
    scene = tmp_path / "incline.toml"
    scene.write_text(text)
    out = tmp_path / "incline.h5"
    report = lieint.run(scene, out, progress=False)
    assert report.status == "complete"
    data, _ = read_all(out)
    t_event = data["events/leaves the incline/t"]
    assert t_event.size == 1 and data["t"][-1] == t_event[0]
    a = 5 / 7 * 9.81 * np.sin(np.pi / 6)  # (n+2)/(n+4) g sin θ down the slope
    assert abs(t_event[0] - np.sqrt(2 * 3.0 / a)) < 1e-10
    memory = run_scene(parse_scene(text)).solution
    assert t_event[0] == memory.t_events[0][0]
