"""The command line: `lieint compare` on the embedded default scene, `lieint methods`."""

import json
import subprocess
import sys

import pytest

from lieint.cli import main
from lieint.compare import run_comparison


def test_compare_prints_a_table_per_method(capsys):
    assert main(["compare", "--methods", "rkmk4,rk4,scipy:DOP853", "--t-end", "5", "--step", "0.05"]) == 0
    out = capsys.readouterr().out
    for word in ("method", "step", "steps", "CPU [s]", "error", "energy drift", "Casimir drift", "|RᵀR-I|"):
        assert word in out
    lines = [ln for ln in out.splitlines() if ln.strip().startswith(("rkmk4", "rk4", "scipy:DOP853"))]
    assert len(lines) == 3


def test_compare_json_has_honest_numbers(capsys):
    assert main(["compare", "--methods", "rkmk2,rkmk4", "--t-end", "5", "--step", "0.05", "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    err = {r["method"]: r["error"] for r in rows}
    assert err["rkmk4"] < err["rkmk2"] < 1
    assert all(r["casimir_drift"] < 1e-13 for r in rows)


def test_compare_errors_shrink_at_the_method_order():
    e1, e2 = (run_comparison(["rkmk4"], h=h, t_end=5.0)[0].error for h in (0.1, 0.05))
    assert 12 < e1 / e2 < 20


def test_unknown_method_is_a_clear_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["compare", "--methods", "rk5"])
    assert exc.value.code == 2
    assert "unknown method(s) ['rk5']; valid names are" in capsys.readouterr().err


def test_bad_step_is_rejected_by_the_parser(capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--step", "-1"])
    assert "expected a positive" in capsys.readouterr().err


def test_methods_subcommand(capsys):
    assert main(["methods"]) == 0
    assert "rkmk4" in capsys.readouterr().out.split()


def test_console_script_help_explains_every_option():
    out = subprocess.run(
        [sys.executable, "-m", "lieint", "compare", "--help"], capture_output=True, text=True, check=True
    ).stdout
    for opt in ("--methods", "--step", "--t-end", "--coordinates", "--no-project", "--rtol", "--atol", "--format"):
        assert opt in out


def test_import_is_light():
    code = "import sys, lieint; print(int(any(m.startswith('scipy') for m in sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "0"  # scipy (and clifford) are imported only where used
