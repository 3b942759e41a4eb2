"""The trust horizon of a streamed run (``lieint run SCENE --out RUN.h5 --max-error-estimate E``).

Checked against :func:`lieint.trust_horizon` on the same scene (the same horizon time, bit for
bit, per member), through an interruption and resume, and bad input refused by name.
"""

import io
import json

import h5py
import numpy as np
import pytest

import lieint
import lieint.cli
from lieint.runs.info import inspect_run
from lieint.scenes import build_system, parse_scene

#: the asymmetric top near its separatrix: rkmk4 at h = 0.1 loses 1e-5 by t ≈ 10
TOP = """
[scene]
name = "top"
[body]
principal_moments = [1.0, 2.0, 3.0]
[support]
type = "fixed_point"
[initial]
angular_velocity = [0.3, 1.0, 0.4]
orientation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
[integrator]
method = "METHOD"
step = 0.1
t_end = 14.0
save_every = 10
[output]
quantities = ["energy"]
"""
TOL = 1e-5


def scene(method="rkmk4", ensemble=""):
    return parse_scene(TOP.replace("METHOD", method) + ensemble)


def direct(sc, tol=TOL):
    system, y0 = build_system(sc)
    return lieint.trust_horizon(system, y0, (sc.t_start, sc.t_end), sc.step, sc.method, tolerance=tol)


def test_a_streamed_run_reports_the_horizon_of_trust_horizon_member_by_member(tmp_path):
    sc = scene(ensemble="[ensemble]\ncount = 2\nseed = 3\nspread = 0.3\n")
    truth = direct(sc)
    assert np.isfinite(truth.horizon[0]) and np.isinf(truth.horizon[1])  # one crosses by t = 14, one not
    out, lines = tmp_path / "r.h5", io.StringIO()
    report = lieint.run(sc, out, progress=False, max_error_estimate=TOL, stream=lines)
    assert report.status == "complete" and report.steps_done == 140  # the run goes on past the horizon
    record = report.trust_horizon
    assert record["horizon"] == [truth.horizon[0], None]  # the same grid time, bit for bit
    assert record["estimated_to"] == truth.t[-1] == 14.0  # carried to the end: a member never crossed
    assert record["largest_estimate"] == np.max(truth.estimate, axis=0).tolist()
    shown = lines.getvalue()
    assert shown.count("[trust horizon]") == 1
    assert f"[trust horizon] member 0: the estimated global error exceeds --max-error-estimate 1e-05 at t = " \
           f"{truth.horizon[0]:.6g}" in shown  # fmt: skip
    with h5py.File(out, "r") as f:
        assert json.loads(f.attrs["trust_horizon"]) == record
    text = inspect_run(out).text()
    assert f"horizon    member 0: t = {truth.horizon[0]:g}: the estimated global error exceeds 1e-05 there" in text
    assert "horizon    member 1: not reached by t = 14: the largest error estimate is" in text


def test_an_interrupted_run_resumes_its_estimate_bit_for_bit(tmp_path):
    sc = scene()
    whole = lieint.run(sc, tmp_path / "w.h5", progress=False, max_error_estimate=TOL).trust_horizon
    assert whole["horizon"] == [direct(sc).horizon]
    out = tmp_path / "r.h5"
    first = lieint.run(sc, out, progress=False, max_error_estimate=TOL, stop_after=40, checkpoint_every=20)
    assert first.status == "interrupted" and first.trust_horizon["horizon"] == [None]  # not yet at t = 4
    with pytest.raises(ValueError, match=r"`max_error_estimate`: this run was started with 1e-05; .*got 0.001"):
        lieint.run(sc, out, progress=False, resume=True, max_error_estimate=1e-3)
    resumed = lieint.run(sc, out, progress=False, resume=True, max_error_estimate=TOL)
    assert resumed.status == "complete" and resumed.trust_horizon == whole
    plain = tmp_path / "p.h5"
    lieint.run(sc, plain, progress=False, stop_after=40)
    with pytest.raises(ValueError, match="`max_error_estimate`: this run was started without it"):
        lieint.run(sc, plain, progress=False, resume=True, max_error_estimate=TOL)


def test_stop_at_horizon_stops_the_run_there(tmp_path):
    sc = scene()
    report = lieint.run(sc, tmp_path / "s.h5", progress=False, max_error_estimate=TOL, stop_at_horizon=True)
    assert report.status == "stopped" and "(--stop-at-horizon)" in report.message
    t = direct(sc).horizon
    assert report.trust_horizon["horizon"] == [t] and report.steps_done == round(t / 0.1) < 140  # at the horizon
    with h5py.File(tmp_path / "s.h5", "r") as f:
        assert f["t"][-1] <= t and f.attrs["status"] == "stopped"


@pytest.mark.parametrize(
    ("kwargs", "method", "message"),
    [
        ({"max_error_estimate": 0.0}, "rkmk4", r"`max_error_estimate` must be a finite positive error; got 0.0"),
        ({"max_error_estimate": float("nan")}, "rkmk4", "`max_error_estimate` must be a finite positive error"),
        ({"max_error_estimate": "1e-3"}, "rkmk4", "`max_error_estimate` must be a finite positive error"),
        ({"stop_at_horizon": True}, "rkmk4", "`stop_at_horizon` needs `max_error_estimate`"),
        ({"max_error_estimate": TOL}, "rkmk45", "`max_error_estimate` needs a fixed-step method .* 'rkmk45'"),
        (
            {"max_error_estimate": TOL},
            "moser_veselov4",
            r"`max_error_estimate` cannot be estimated for this run: `method` 'moser_veselov4' has no tangent map",
        ),
    ],
)
def test_bad_input_is_refused_by_name_and_writes_nothing(tmp_path, kwargs, method, message):
    with pytest.raises(ValueError, match=message):
        lieint.run(scene(method), tmp_path / "x.h5", progress=False, **kwargs)
    assert not (tmp_path / "x.h5").exists()


def test_cli_run_max_error_estimate(tmp_path, capsys):
    path = tmp_path / "top.toml"
    path.write_text(TOP.replace("METHOD", "rkmk4"), encoding="utf-8")
    assert lieint.cli.main(["run", str(path), "--max-error-estimate", "1e-5"]) == 2
    assert "--max-error-estimate applies to a streamed run (--out RUN.h5)" in capsys.readouterr().err
    code = lieint.cli.main(["run", str(path), "--out", str(tmp_path / "c.h5"), "--max-error-estimate", "1e-5",
                            "--quiet"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    t = direct(scene()).horizon
    assert f"trust horizon t = {t:g}: the estimated global error exceeds 1e-05 there" in captured.out
    assert f"[trust horizon] the estimated global error exceeds --max-error-estimate 1e-05 at t = {t:.6g}" in (
        captured.err
    )


def test_a_large_ensemble_prints_ten_crossings_and_records_them_all(tmp_path):
    sc = scene(ensemble="[ensemble]\ncount = 12\nseed = 1\nspread = 0.3\n")
    truth = direct(sc, tol=1e-7)
    assert np.all(np.isfinite(truth.horizon))
    lines = io.StringIO()
    report = lieint.run(sc, tmp_path / "e.h5", progress=False, max_error_estimate=1e-7, stream=lines)
    assert report.trust_horizon["horizon"] == truth.horizon.tolist()
    shown = lines.getvalue()
    assert shown.count("[trust horizon] member ") == 10
    assert "the other members' horizons are recorded in the file (lieint info)" in shown
    text = inspect_run(tmp_path / "e.h5").text()
    assert f"horizon    12 of 12 members exceed 1e-07, the first at t = {min(truth.horizon):g}, the last at t = " \
           f"{max(truth.horizon):g}" in text  # fmt: skip
