"""Scenes: the engine simulates only what a scene calls for; bad scenes fail with located errors."""

import dataclasses
import textwrap

import numpy as np
import pytest

import lieint
from lieint.cli import main
from lieint.scenes import SceneError, build_system, embedded_scenes, load_scene, parse_scene, run_scene

TOP = """
[scene]
name = "top"

[body]
principal_moments = [1.0, 2.0, 3.0]

[support]
type = "fixed_point"

[initial]
angular_velocity = [0.1, 1.0, 0.2]

[integrator]
method = "rkmk4"
step = 0.01
t_end = 1.0

[output]
quantities = {outputs}
"""

BALL = """
[scene]
name = "ball"

[body]
mass_tensor = [[0.10, 0.0, 0.0], [0.0, 0.15, 0.0], [0.0, 0.0, 0.20]]
mass = 1.0
radius = 1.0
{extra_body}

[support]
type = "rolling"

[forces]
gravity = {gravity}

[initial]
angular_velocity = [1.0, 2.0, 0.5]

[integrator]
method = "rkmk4"
step = 0.01
t_end = 1.0

[output]
quantities = {outputs}
"""


def top_scene(outputs):
    return parse_scene(TOP.format(outputs=outputs))


def ball_scene(outputs, gravity="[0.0, 0.0, -9.81]", extra_body=""):
    return parse_scene(BALL.format(outputs=outputs, gravity=gravity, extra_body=extra_body))


def test_every_embedded_scene_runs():
    scenes = embedded_scenes()
    assert {"dzhanibekov", "manakov_4d", "lagrange_top", "chaplygin_ball", "offset_ball", "incline_ball"} <= set(scenes)
    for scene in scenes.values():
        result = run_scene(scene)
        assert result.solution.success
        assert set(result.outputs) == set(scene.outputs)


def test_every_whole_scene_the_guide_shows_runs():
    # a TOML block of docs/guide.md with a [body] table is a scene a user may copy: it must read and run
    import re
    from pathlib import Path

    guide = (Path(__file__).resolve().parents[2] / "docs" / "guide.md").read_text()
    scenes = [block for block in re.findall(r"```toml\n(.*?)```", guide, re.S) if "[body]" in block]
    assert len(scenes) >= 2
    for block in scenes:
        result = run_scene(parse_scene(block, "docs/guide.md"))
        assert result.solution.success and set(result.outputs) == set(result.scene.outputs)


def test_a_scene_without_orientation_output_steps_a_smaller_state():
    lean, _ = build_system(top_scene('["energy", "casimirs"]'))
    full, _ = build_system(top_scene('["energy", "orientation"]'))
    assert list(lean.fields) == ["A"] and list(full.fields) == ["A", "R"]
    a, b = run_scene(top_scene('["energy"]')), run_scene(top_scene('["energy", "orientation"]'))
    assert a.solution.states["A"].nbytes * 2 == sum(v.nbytes for v in b.solution.states.values())
    np.testing.assert_allclose(a.outputs["energy"], b.outputs["energy"], rtol=1e-15)


def test_the_chaplygin_specialisation_is_chosen_when_the_ball_qualifies():
    assert type(build_system(ball_scene('["energy"]'))[0]) is lieint.ChaplyginBall
    offset = build_system(ball_scene('["energy"]', extra_body="center_of_mass = [0.0, 0.0, -0.1]"))[0]
    assert type(offset) is lieint.RollingBall
    tilted = build_system(ball_scene('["energy"]', gravity="[1.0, 0.0, -9.81]"))[0]
    assert type(tilted) is lieint.RollingBall and "G" in tilted.fields
    assert "center" in tilted.fields  # the energy on an incline needs the height of the centre


def test_no_contact_path_and_no_orientation_unless_asked():
    system, _ = build_system(ball_scene('["energy", "casimirs"]'))
    assert list(system.fields) == ["A", "Gamma"]
    system, _ = build_system(ball_scene('["contact_path"]'))
    assert list(system.fields) == ["A", "Gamma", "R", "center"]
    result = run_scene(ball_scene('["contact_path"]'))
    path = result.outputs["contact_path"]
    # The contact point stays on the plane: to truncation error with the SE(n) reconstruction
    # (measured 2.3e-11 over 100 steps), exactly with the projection onto the constraint.
    assert np.max(np.abs(path[:, 2])) < 1e-10
    projected = run_scene(dataclasses.replace(ball_scene('["contact_path"]'), project=True))
    assert np.max(np.abs(projected.outputs["contact_path"][:, 2])) < 1e-15


def test_no_gravity_term_without_gravity_or_without_an_offset():
    text = TOP.format(outputs='["energy"]').replace("[support]", "[forces]\ngravity = [0, 0, -9.81]\n\n[support]")
    text = text.replace("principal_moments = [1.0, 2.0, 3.0]", "principal_moments = [1.0, 2.0, 3.0]\nmass = 1.0")
    system, _ = build_system(parse_scene(text))
    assert type(system) is lieint.EulerTop  # X_G = 0: gravity exerts no torque
    heavy = text.replace("mass = 1.0", "mass = 1.0\ncenter_of_mass = [0, 0, 0.2]")
    assert type(build_system(parse_scene(heavy))[0]) is lieint.HeavyTop


def test_incline_scene_acceleration_matches_5_7_g_sin_theta():
    result = run_scene(embedded_scenes()["incline_ball"])
    c, t = result.outputs["center"], result.solution.t
    accel = 2 * (c[-1, 0] - c[0, 0]) / t[-1] ** 2
    assert abs(accel - 5 / 7 * 9.81 * np.sin(np.pi / 6)) / accel < 1e-8


def write(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(textwrap.dedent(text))
    return path


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (
            lambda s: s.replace('method = "rkmk4"', 'method = "rkmk4"\nstepsize = 0.1'),
            r"\[integrator\] stepsize \(line 16\): unknown key 'stepsize'; allowed keys are",
        ),
        (lambda s: s.replace('type = "fixed_point"\n', ""), r"\[support\] \(line 8\): missing required key 'type'"),
        (
            lambda s: s.replace("step = 0.01", 'step = "fast"'),
            r"\[integrator\] step \(line 16\): 'fast' uses something outside the scene grammar",
        ),
        (lambda s: s.replace("step = 0.01", "step = true"), r"\[integrator\] step \(line 16\): expected a number"),
        (
            lambda s: s.replace("angular_velocity = [0.1, 1.0, 0.2]", "angular_velocity = [0.1, 1.0]"),
            r"\[initial\] angular_velocity \(line 12\): expected an array of shape \(3,\) .*got shape \(2,\)",
        ),
        (
            lambda s: s.replace("t_end = 1.0", "t_end = 1.0\n[extras]\nx = 1"),
            r"\[extras\] \(line 18\): unknown table; allowed tables are",
        ),
        (lambda s: s.replace("t_end = 1.0", "t_end = = 1.0"), r"not valid TOML: .*line 17"),
        (
            lambda s: s.replace('type = "fixed_point"', 'type = "hovering"'),
            r"\[support\] type \(line 9\): must be one of \['fixed_point', 'rolling', 'free'\]; got 'hovering'",
        ),
        (
            lambda s: s.replace('quantities = ["energy"]', 'quantities = ["energy", "contact_path"]'),
            r"\[output\] quantities: 'contact_path' is not an output of this scene's system \(EulerTop\)",
        ),
        (
            lambda s: s.replace('method = "rkmk4"', 'method = "rk5"'),
            r"\[integrator\] method \(line 15\): unknown method 'rk5'",
        ),
        (
            lambda s: s.replace("principal_moments = [1.0, 2.0, 3.0]", "principal_moments = [1.0, -1.0, 3.0]"),
            r"\[body\] principal_moments \(line 6\): must be positive; got \[1.0, -1.0, 3.0\]",
        ),
    ],
)
def test_bad_scene_files_name_the_key_and_line(tmp_path, edit, match):
    path = write(tmp_path, edit(TOP.format(outputs='["energy"]')))
    with pytest.raises(SceneError, match=match):
        scene = load_scene(path)
        build_system(scene)


def test_physical_errors_surface_as_scene_errors():
    with pytest.raises(SceneError, match=r"\[body\] center_of_mass \(line 9\): must lie inside the ball"):
        build_system(ball_scene('["energy"]', extra_body="center_of_mass = [0.0, 0.0, -1.5]"))
    with pytest.raises(SceneError, match=r"\[forces\] gravity \(line 15\): expected an array of shape \(3,\)"):
        ball_scene('["energy"]', gravity="[0.0, -9.81]")


def test_a_scene_is_never_evaluated_as_code(tmp_path):
    marker = tmp_path / "pwned"
    evil = TOP.format(outputs='["energy"]').replace(
        "step = 0.01", f"step = \"__import__('os').system('touch {marker}')\""
    )
    with pytest.raises(SceneError, match="outside the scene grammar"):
        parse_scene(evil)
    assert not marker.exists()


def test_expressions_in_numbers():
    scene = parse_scene(TOP.format(outputs='["energy"]').replace("t_end = 1.0", 't_end = "2*pi"'))
    assert scene.t_end == pytest.approx(2 * np.pi)


def test_cli_run_and_scenes(tmp_path, capsys):
    assert main(["scenes"]) == 0
    assert "dzhanibekov" in capsys.readouterr().out
    assert main(["scenes", "--show", "incline_ball"]) == 0
    assert 'incline = "pi/6"' in capsys.readouterr().out
    path = write(tmp_path, TOP.format(outputs='["energy", "orientation"]'))
    out_file = tmp_path / "run.npz"
    assert main(["run", str(path), "--save", str(out_file)]) == 0
    out = capsys.readouterr().out
    assert "integrated: A, R with rkmk4" in out and "energy" in out
    data = np.load(out_file)
    assert set(data.files) == {"t", "energy", "orientation"} and data["orientation"].shape == (101, 3, 3)
    assert main(["run", str(tmp_path / "missing.toml")]) == 2
    assert "cannot read scene file" in capsys.readouterr().err


# -- a scene's text never reaches the terminal raw; every error names the key and line ------------------

ESCAPES = "\\u001b[2J\\u001b]0;pwned\\u0007\\nforged line"  # clear screen, window title, a forged line


@pytest.mark.slow
def test_a_scene_name_with_escape_codes_prints_escaped(tmp_path):
    """``lieint run``, ``lieint info`` and ``lieint plot`` of a scene whose name and description
    hold terminal control codes: no control character reaches stdout or stderr."""
    import subprocess
    import sys

    text = TOP.format(outputs='["energy", "orientation"]').replace('name = "top"', f'name = "top{ESCAPES}"')
    text = text.replace("[body]", f'description = "d{ESCAPES}"\n\n[body]')
    path = write(tmp_path, text)
    assert parse_scene(text).name == "top\\x1b[2J\\x1b]0;pwned\\x07\\nforged line"
    outputs = []
    for args in (["run", str(path)], ["run", str(path), "--out", "r.h5", "--quiet"], ["info", "r.h5"],
                 ["plot", "r.h5"]):  # fmt: skip
        done = subprocess.run([sys.executable, "-m", "lieint", *args], cwd=tmp_path, capture_output=True, text=True,
                              timeout=120)  # fmt: skip
        assert done.returncode == 0, (args, done.stderr)
        outputs.append(done.stdout + done.stderr)
    for printed in outputs:
        assert not any(ord(c) < 32 and c not in "\n" for c in printed), repr(printed)
        assert "\x1b" not in printed and "\nforged line" not in printed
    assert "top\\x1b[2J\\x1b]0;pwned\\x07\\nforged line" in outputs[0]  # escaped, still readable
    assert "top\\x1b[2J" in outputs[2]  # info shows the name the run recorded, escaped


def test_a_run_file_written_with_a_raw_name_is_printed_escaped(tmp_path):
    """A file from elsewhere (another tool, an older lieint) with a raw control code in its
    attributes: info escapes what it reads."""
    import h5py

    from lieint.runs.info import inspect_run

    path = write(tmp_path, TOP.format(outputs='["energy"]'))
    lieint.run(path, tmp_path / "r.h5", progress=False)
    with h5py.File(tmp_path / "r.h5", "r+") as f:
        f.attrs["scene_name"] = "x\x1b[2Jy"
    text = inspect_run(tmp_path / "r.h5").text()
    assert "x\\x1b[2Jy" in text and "\x1b" not in text


@pytest.mark.parametrize(
    ("body", "initial", "match"),
    [
        # the four messages that named the system's arguments (`B`, `Omega`, `A`, `y0['A']`)
        ("mass_tensor = [[1.0, 0.5], [0.0, 2.0]]", "omega = [[0.0, 1.0], [-1.0, 0.0]]",
         r"\[body\] mass_tensor \(line 6\): must be symmetric \(a mass tensor"),
        ("mass_tensor = [[1.0, 0.0], [0.0, 2.0]]", "omega = [[0.0, 1.0], [1.0, 0.0]]",
         r"\[initial\] omega \(line 12\): must be skew-symmetric"),
        ("mass_tensor = [[1.0, 0.0], [0.0, 2.0]]", "momentum = [[0.0, 1.0], [1.0, 0.0]]",
         r"\[initial\] momentum \(line 12\): must be skew-symmetric"),
        ("principal_moments = [1.0, 2.0, 3.0]", "angular_velocity = [1e308, 1e308, 1e308]",
         r"\[initial\] angular_velocity \(line 12\): gives an initial A beyond the floating-point range; got inf"),
        # and their neighbours
        ("mass_tensor = [[0.0, 0.0], [0.0, 0.0]]", "omega = [[0.0, 1.0], [-1.0, 0.0]]",
         r"\[body\] mass_tensor \(line 6\): must be a nonzero mass tensor"),
        ("principal_moments = [1.0, 2.0, 3.0]", "angular_velocity = [1, 1, 1]\norientation = [[1,0,0],[0,1,0],[0,0,2]]",
         r"\[initial\] orientation \(line 13\): must be a rotation in SO\(3\)"),
    ],
)  # fmt: skip
def test_a_system_refusing_a_scene_value_names_the_scene_key_and_line(tmp_path, body, initial, match):
    text = TOP.format(outputs='["energy"]').replace("principal_moments = [1.0, 2.0, 3.0]", body)
    text = text.replace("angular_velocity = [0.1, 1.0, 0.2]", initial)
    path = write(tmp_path, text)
    with pytest.raises(SceneError, match=match) as caught:
        build_system(load_scene(path))
    assert "`" not in str(caught.value).split(":", 2)[2][:12]  # no internal name up front


def test_a_member_that_refuses_the_batch_its_step_is_named(tmp_path):
    w = np.array([[0.1, 1.0, 0.1]] * 5)
    w[3] = [1e150, 1.0, 1.0]
    np.save(tmp_path / "members.npy", w)
    path = write(tmp_path, TOP.format(outputs='["energy"]') + '[ensemble]\nfile = "members.npy"\n')
    with pytest.raises(ValueError, match=r"member 3 of the ensemble \(0-based, \[initial\] angular_velocity = "
                                         r"\[1e\+150, 1, 1\]\): its first step has ‖h ξ‖ = 1e\+148"):  # fmt: skip
        run_scene(load_scene(path))
