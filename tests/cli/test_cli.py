"""The command line: `lieint compare` (the work-precision study), `lieint methods`."""

import json
import subprocess
import sys

import pytest

from lieint.cli import main
from lieint.scenes import embedded_scenes


def test_compare_prints_the_table_and_writes_files(tmp_path, capsys):
    code = main(["compare", "--methods", "rkmk4,rk4,scipy:DOP853", "--t-end", "5", "--out-dir", str(tmp_path)])
    assert code == 0
    out = capsys.readouterr().out
    for word in (  # the table that fits a terminal
        "method [variant]",
        "step/tol",
        "back end",
        "CPU [ms]",
        "error",
        "err/rtol",
        "energy",
        "Casimirs",
        "scipy:DOP853 (proj.)",
        "numba threads 1",
        "error reached within a CPU budget",
    ):
        assert word in out
    assert "exact (Jacobi elliptic, attitude by quadrature)" in " ".join(out.split())  # wrapped at 118 columns
    for name in ("work_precision.csv", "work_precision.json", "work_precision.png", "long_run.png"):
        assert (tmp_path / name).stat().st_size > 100
    assert (tmp_path / "work_precision_fixed_lie.png").exists() and (tmp_path / "work_precision_classical.png").exists()
    argv = ["compare", "--methods", "rkmk4,scipy:DOP853", "--t-end", "2", "--repeats", "1", "--no-plots", "--wide"]
    assert main([*argv, "--out-dir", str(tmp_path / "wide")]) == 0
    wide = capsys.readouterr().out
    for word in ("variant", "CPU min [ms]", "CPU med [ms]", "wall min [ms]", "wall med [ms]", "energy drift"):
        assert word in wide
    rows = json.loads((tmp_path / "work_precision.json").read_text())["rows"]
    assert {r["method"] for r in rows} == {"rkmk4", "rk4", "scipy:DOP853"}
    assert {r["variant"] for r in rows if r["method"] == "scipy:DOP853"} == {"plain", "projected saves"}


def test_compare_all_studies_every_embedded_scene(tmp_path, capsys):
    argv = ["compare", "--all", "--methods", "rkmk4,scipy:DOP853", "--t-end", "0.5", "--repeats", "1"]
    assert main([*argv, "--no-plots", "--format", "json", "--out-dir", str(tmp_path)]) == 0
    studies = {s["scene"]: s for s in json.loads(capsys.readouterr().out)}
    scenes = embedded_scenes()
    assert set(studies) == {s.name for s in scenes.values()}
    for key, scene in scenes.items():
        study = studies[scene.name]
        assert {(r["method"], r["variant"]) for r in study["rows"]} >= {
            ("scipy:DOP853", "plain"),
            ("scipy:DOP853", "projected saves"),
        }
        assert all(r["success"] and r["error"] is not None for r in study["rows"])
        assert study["metadata"]["reference"]["exact"] == (key in ("dzhanibekov", "incline_ball"))
        assert (tmp_path / key / "work_precision.json").exists()


def test_study_on_the_incline_uses_the_exact_solution(tmp_path, capsys):
    argv = ["compare", "incline_ball", "--methods", "rkmk4", "--t-end", "0.5", "--repeats", "1", "--no-plots"]
    assert main([*argv, "--out-dir", str(tmp_path)]) == 0
    assert "exact ((n+2)/(n+4) g sin θ, n = 3, with R and Ω)" in capsys.readouterr().out


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
    for opt in (
        "--all",
        "--methods",
        "--repeats",
        "--threads",
        "--full",
        "--t-end",
        "--out-dir",
        "--no-plots",
        "--format",
    ):
        assert opt in out


def test_import_is_light():
    heavy = "('scipy', 'clifford', 'numba', 'h5py', 'matplotlib')"
    code = f"import sys, lieint; print(int(any(m.split('.')[0] in {heavy} for m in sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "0"  # heavy dependencies are imported only where used


def test_warmup_lists_its_systems_and_refuses_an_unknown_one(capsys):
    """``lieint warmup`` reaches its command (not the top-level help): ``--list`` names the
    systems it compiles for, an unknown system is an error naming the choices."""
    assert main(["warmup", "--list"]) == 0
    listed = capsys.readouterr().out.split()
    assert {"euler_top", "heavy_top", "chaplygin_ball"} <= set(listed) and "COMMAND" not in listed
    assert main(["warmup", "no_such_body"]) == 2
    err = capsys.readouterr().err
    assert "unknown system(s) ['no_such_body']" in err and "euler_top" in err
