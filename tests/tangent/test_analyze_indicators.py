"""``lieint analyze SCENE --lyapunov / --megno / --max-error-estimate``: the scene's own method, step
and span, the same numbers as the Python calls, and named errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import lieint
import lieint.cli
import lieint.scenes
from lieint.scenes import embedded_scenes
from lieint.scenes.engine import build_system


def test_megno_and_spectrum_are_those_of_the_python_calls(capsys):
    assert lieint.cli.main(["analyze", "dzhanibekov", "--megno", "--lyapunov", "--t-end", "20", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["indicators"]
    scene = embedded_scenes()["dzhanibekov"]
    system, y0 = build_system(scene)
    m = lieint.megno(system, y0, (scene.t_start, 20.0), scene.step, method=scene.method)
    spec = lieint.lyapunov(system, y0, (scene.t_start, 20.0), scene.step, method=scene.method)
    assert report["h"] == scene.step and report["t_end"] == 20.0 and report["method"] == scene.method
    assert np.allclose(report["megno"], np.atleast_1d(m.mean), rtol=1e-12)
    assert np.allclose(report["lyapunov"][0], spec.exponents, rtol=1e-12)
    assert len(report["labels"]) == spec.chart.dim


def test_printed_form_says_what_the_numbers_mean(capsys):
    assert lieint.cli.main(["analyze", "dzhanibekov", "--megno", "--t-end", "5"]) == 0
    out = capsys.readouterr().out
    assert "MEGNO <Y> = " in out and "-> 2 regular" in out and "exact tangent map" in out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--t-end", "5"], "--t-end applies to --lyapunov, --megno and --max-error-estimate only"),
        (["--megno", "--t-end", "-1"], "--t-end must be a finite time after"),
        (["--megno", "--t-end", "nan"], "--t-end must be a finite time after"),
    ],
)
def test_bad_options_are_named(args, message, capsys):
    assert lieint.cli.main(["analyze", "dzhanibekov", *args]) == 2
    assert message in capsys.readouterr().err


def test_an_adaptive_scene_takes_fixed_steps_of_its_step(tmp_path, capsys):
    text = (Path(lieint.scenes.__file__).parent / "examples" / "dzhanibekov.toml").read_text()
    path = tmp_path / "adaptive.toml"
    path.write_text(text.replace('method = "rkmk4"', 'method = "rkmk45"\nrtol = 1e-8'))
    assert lieint.cli.main(["analyze", str(path), "--megno", "--t-end", "2"]) == 0
    assert "rkmk45, h = 0.01, t_end = 2 fixed steps" in capsys.readouterr().out


def test_max_error_estimate_reports_the_trust_horizon_of_the_python_call(capsys):
    """``--max-error-estimate TOL``: the horizon of :func:`lieint.trust_horizon` with the scene's
    method and step, printed and in JSON; a bad tolerance is refused by name."""
    assert lieint.cli.main(["analyze", "dzhanibekov", "--max-error-estimate", "1e-12", "--t-end", "10", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["indicators"]
    scene = lieint.scenes.embedded_scenes()["dzhanibekov"]
    system, y0 = build_system(scene)
    run = lieint.trust_horizon(system, y0, (scene.t_start, 10.0), scene.step, method=scene.method, tolerance=1e-12)
    assert np.isfinite(run.horizon) and report["trust_horizon"] == [run.horizon]
    assert report["error_estimate"] == [run.estimate[-1]]
    assert lieint.cli.main(["analyze", "dzhanibekov", "--max-error-estimate", "1e-3", "--t-end", "2"]) == 0
    assert "trust horizon not reached: the error estimate is" in capsys.readouterr().out
    for bad in ("0", "-1", "nan"):
        assert lieint.cli.main(["analyze", "dzhanibekov", "--max-error-estimate", bad]) == 2
        assert "--max-error-estimate must be a finite positive error" in capsys.readouterr().err
