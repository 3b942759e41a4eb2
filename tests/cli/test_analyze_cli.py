"""``lieint analyze``: the count and the holonomy verdict of a scene, printed and as JSON."""

from __future__ import annotations

import json

import pytest

import lieint.cli


@pytest.mark.parametrize(
    "scene, equation, holonomy",
    [
        ("dzhanibekov", "Euler top n = 3: 6 − 1 − 3 − 1 = 1", "→ holonomic"),
        ("manakov_4d", "Euler top n = 4: 12 − 1 − 6 − 2 = 3", "→ holonomic"),
        ("chaplygin_ball", "Chaplygin ball n = 3: 8 − 1 − 3 − 2 − 1 = 1", "reach 5 (depth 1) → nonholonomic"),
        ("kepler", "particle in a central field n = 3: 6 − 1 − 3 − 1 = 1", "→ holonomic"),
        (
            "clairaut_egg",
            "surface of revolution n = 3: 4 − 1 − 1 − 1 = 1",
            "admissible velocities 2, Lie brackets reach 2",
        ),
        ("atoms_top", "count toward integrability: not available", "admissible velocities 6, Lie brackets reach 6"),
    ],
)
def test_analyze_prints_the_reduction_equation(scene, equation, holonomy, capsys):
    assert lieint.cli.main(["analyze", scene]) == 0
    out = capsys.readouterr().out
    assert equation in out and holonomy in out


def test_analyze_json_with_the_manakov_family(capsys):
    assert lieint.cli.main(["analyze", "manakov_4d", "--integrals", "manakov", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["count"]["terms"] == [12, 1, 6, 2, 1, 1] and data["count"]["result"] == 1
    assert data["count"]["equation"] == "12 − 1 − 6 − 2 − 1 − 1 = 1"
    assert data["holonomy"]["holonomic"] is True and data["count_error"] is None


def test_analyze_a_rolling_ball_scene_file(tmp_path, capsys):
    path = tmp_path / "ball.toml"
    path.write_text(lieint.scenes.embedded_scenes()["offset_ball"].text)
    assert lieint.cli.main(["analyze", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["holonomy"]["holonomic"] is False and data["holonomy"]["closure_dimension"] == 5
    assert "RollingBall" in data["count_error"]


def test_analyze_unknown_scene_is_refused(capsys):
    assert lieint.cli.main(["analyze", "no_such_scene"]) == 2
    assert "no embedded scene of that name" in capsys.readouterr().err


def test_analyze_an_ensemble_at_its_first_member(tmp_path, capsys):
    path = tmp_path / "ensemble.toml"
    path.write_text(
        """
[scene]
name = "ensemble top"
[body]
mass_tensor = [[0.5, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]]
[support]
type = "fixed_point"
[initial]
angular_velocity = [0.3, 1.0, 0.4]
[ensemble]
count = 4
seed = 1
spread = 0.01
[integrator]
method = "rkmk4"
step = 0.01
t_end = 1.0
[output]
quantities = ["energy"]
"""
    )
    assert lieint.cli.main(["analyze", str(path)]) == 0
    assert "Euler top n = 3: 6 − 1 − 3 − 1 = 1" in capsys.readouterr().out
