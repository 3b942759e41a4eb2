"""Events declared in scenes: ``[[events]]`` tables located by ``run_scene`` and ``lieint run``."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import FLIPS

import lieint.cli
from lieint.scenes import SceneError, embedded_scenes, parse_scene, run_scene
from lieint.systems.euler_top_exact import euler_top_flip_times


def test_the_scene_records_each_flip_of_the_dzhanibekov_top():
    run = run_scene(parse_scene(FLIPS))
    exact = euler_top_flip_times([1.0, 2.0, 3.0], [0.01, 1.0, 0.01], 60.0)
    found = run.solution.t_events[0]
    # rtol 1e-13 (not 1e-12) since rkmk853 takes DOP853's steps: see docs/measurements/adaptive.md
    assert found.size == exact.size == 3
    assert np.max(np.abs(found - exact)) <= 1e-8


def test_a_terminal_event_stops_the_ball_at_the_end_of_the_incline():
    base = embedded_scenes()["incline_ball"].text
    text = (
        base
        + '\n[[events]]\nname = "leaves the incline"\noutput = "center"\ncomponent = 0\nvalue = 3.0\nterminal = true\n'
    )
    run = run_scene(parse_scene(text))
    a = 5 / 7 * 9.81 * np.sin(np.pi / 6)  # the centre accelerates at (n+2)/(n+4) g sin θ down the slope
    t_leave = np.sqrt(2 * 3.0 / a)
    sol = run.solution
    assert sol.success and sol.t[-1] == sol.t_events[0][0]
    assert abs(sol.t_events[0][0] - t_leave) < 1e-10  # rkmk4 is exact on this uniform acceleration
    assert sol.y_events[0]["center"][0, 0] == pytest.approx(3.0, abs=1e-12)


def test_lieint_run_prints_the_event_times(tmp_path, capsys):
    path = tmp_path / "flips.toml"
    path.write_text(FLIPS.replace("t_end = 60.0", "t_end = 15.0"))
    assert lieint.cli.main(["run", str(path)]) == 0
    assert "event 'flip': 1 times [10.91691349" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('[[events]]\noutput = "nope"\n', "not an output"),
        ('[[events]]\noutput = "angular_velocity"\ncomponent = [0]\n', "must pick one number"),
        ('[[events]]\noutput = "energy"\nterminal = "yes"\n', "terminal"),
        ('[[events]]\noutput = "energy"\ncolour = 1\n', "unknown key 'colour'"),
    ],
)
def test_bad_events_are_refused_by_name(extra, message):
    with pytest.raises(SceneError, match=message):
        run_scene(parse_scene(FLIPS.split("[[events]]")[0] + extra))
