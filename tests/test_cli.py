"""The command line: `lieint compare` (the work-precision study), `lieint methods`."""

import json
import subprocess
import sys

import pytest

from lieint.cli import main
from lieint.compare import default_scene
from lieint.study import run_study


def test_compare_prints_the_table_and_writes_files(tmp_path, capsys):
    code = main(["compare", "--methods", "rkmk4,rk4,scipy:DOP853", "--t-end", "5", "--out-dir", str(tmp_path)])
    assert code == 0
    out = capsys.readouterr().out
    for word in ("method", "step/tol", "steps", "CPU [s]", "error", "energy drift", "Casimir drift", "|RᵀR-I|"):
        assert word in out
    assert "exact (Jacobi elliptic)" in out
    for name in ("work_precision.csv", "work_precision.json", "work_precision.png", "long_run.png"):
        assert (tmp_path / name).stat().st_size > 100
    rows = json.loads((tmp_path / "work_precision.json").read_text())
    assert {r["method"] for r in rows} == {"rkmk4", "rk4", "scipy:DOP853"}
    assert {r["projection"] for r in rows if r["method"] == "scipy:DOP853"} == {True, False}


def test_study_errors_fall_with_the_step_and_lie_methods_keep_casimirs():
    from dataclasses import replace

    rows, _ = run_study(replace(default_scene(), t_end=5.0), quick=True, repeats=1, methods=["rkmk4", "rk4"])
    rk = [r for r in rows if r.method == "rkmk4"]
    assert rk[0].error > 100 * rk[-1].error  # h = 0.02 → 0.00125 over the quick sweep
    assert all(r.casimir_drift < 1e-13 for r in rk)
    # measured: 7.5e-13 against 6.4e-15 (ratio 117) at T = 5
    assert max(r.casimir_drift for r in rows if r.method == "rk4") > 50 * max(r.casimir_drift for r in rk)


def test_study_on_the_incline_uses_the_exact_acceleration(tmp_path, capsys):
    assert main(["compare", "incline_ball", "--methods", "rkmk4", "--no-plots", "--out-dir", str(tmp_path)]) == 0
    assert "exact ((n+2)/(n+4) g sin θ, n = 3)" in capsys.readouterr().out


def test_unknown_method_and_scene_are_clear_errors(capsys, tmp_path):
    assert main(["compare", "--methods", "rk5", "--out-dir", str(tmp_path)]) == 2
    assert "'rk5' is not a method" in capsys.readouterr().err
    assert main(["compare", "nowhere", "--out-dir", str(tmp_path)]) == 2
    assert "no scene file 'nowhere'" in capsys.readouterr().err


def test_bad_option_is_rejected_by_the_parser(capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--t-end", "-1"])
    assert "expected a positive" in capsys.readouterr().err


def test_methods_subcommand(capsys):
    assert main(["methods"]) == 0
    assert {"rkmk4", "rkmk45", "rkmk853"} <= set(capsys.readouterr().out.split())


def test_console_script_help_explains_every_option():
    out = subprocess.run(
        [sys.executable, "-m", "lieint", "compare", "--help"], capture_output=True, text=True, check=True
    ).stdout
    for opt in ("--methods", "--full", "--t-end", "--out-dir", "--no-plots", "--format"):
        assert opt in out


def test_import_is_light():
    heavy = "('scipy', 'clifford', 'numba', 'h5py', 'matplotlib')"
    code = f"import sys, lieint; print(int(any(m.split('.')[0] in {heavy} for m in sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "0"  # heavy dependencies are imported only where used
