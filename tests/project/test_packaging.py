"""Packaging: the extras (ga, plot, sweep) and what works without them, the py.typed marker."""

import re
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())

#: run Python with the optional packages made unimportable (as in an install without the extras)
BLOCKER = textwrap.dedent(
    """
    import importlib.abc, sys
    class _Missing(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name.split(".")[0] in {blocked!r}:
                raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
            return None
    sys.meta_path.insert(0, _Missing())
    """
)


def run_without(blocked, code, *args):
    script = BLOCKER.format(blocked=sorted(blocked)) + textwrap.dedent(code)
    command = [sys.executable, "-c", script, *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=ROOT)


def requirement_name(req: str) -> str:
    return re.split(r"[\s\[<>=!;~]", req, maxsplit=1)[0].lower()


def test_the_core_install_has_no_figure_or_algebra_library():
    core = {requirement_name(r) for r in PYPROJECT["project"]["dependencies"]}
    assert core.isdisjoint({"clifford", "matplotlib", "dask", "xarray", "zarr"})
    extras = PYPROJECT["project"]["optional-dependencies"]
    assert {requirement_name(r) for r in extras["ga"]} == {"clifford"}
    assert {requirement_name(r) for r in extras["plot"]} == {"matplotlib"}


def test_the_test_extra_names_the_other_extras_instead_of_repeating_them():
    extras = PYPROJECT["project"]["optional-dependencies"]
    test = extras["test"]
    assert "lieint[ga,plot,sweep]" in test
    names = [requirement_name(r) for r in test]
    assert len(names) == len(set(names))  # no requirement twice
    repeated = set(names) & {requirement_name(r) for e in ("ga", "plot", "sweep") for r in extras[e]}
    assert not repeated


def test_py_typed_is_declared_and_present():
    assert "py.typed" in PYPROJECT["tool"]["setuptools"]["package-data"]["lieint"]
    assert (ROOT / "lieint" / "py.typed").is_file()


@pytest.mark.slow
def test_the_wheel_carries_py_typed(tmp_path):
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), ROOT],
        capture_output=True,
        text=True,
        timeout=600,
    )
    if built.returncode != 0:
        pytest.skip(f"no wheel could be built here: {built.stderr[-300:]}")
    (wheel,) = tmp_path.glob("lieint-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "lieint/py.typed" in names
    assert "lieint/scenes/examples/dzhanibekov.toml" in names


@pytest.mark.slow
def test_integrating_needs_no_extra():
    result = run_without(
        ["clifford", "matplotlib", "dask", "distributed", "zarr", "xarray"],
        """
        import lieint
        top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
        sol = lieint.integrate(top, y0, (0.0, 10.0), h=0.01, method="rkmk4")
        adaptive = lieint.integrate(top, y0, (0.0, 10.0), method="rkmk45", t_eval=[5.0, 10.0])
        print(sol.status, float(sol.drift("casimirs")) < 1e-13, adaptive.t.tolist(), sol.rotation()[-1].magnitude() > 0)
        assert "clifford" not in __import__("sys").modules and "matplotlib" not in __import__("sys").modules
        """,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["0", "True", "[5.0,", "10.0]", "True"]


def test_geometric_algebra_without_clifford_names_the_extra():
    result = run_without(
        ["clifford"],
        """
        try:
            import lieint.ga
        except ImportError as exc:
            print(type(exc).__name__, "|", exc)
        """,
    )
    assert result.returncode == 0, result.stderr
    expected = 'lieint.ga (geometric algebra) needs clifford, which is not installed: pip install "lieint[ga]"'
    assert result.stdout.strip() == f"MissingExtraError | {expected}"


def test_the_command_line_without_matplotlib_names_the_extra(tmp_path):
    # before the study's work: the figures cannot be drawn
    result = run_without(["matplotlib"], "from lieint.cli import main; raise SystemExit(main())", "compare")
    assert result.returncode == 2
    expected = 'the figures of lieint compare needs matplotlib, which is not installed: pip install "lieint[plot]"'
    assert f"lieint compare: {expected}" in result.stderr
    assert "--no-plots" in result.stderr and "Traceback" not in result.stderr
    # a run file's figure
    run = subprocess.run(
        [sys.executable, "-m", "lieint", "run", "dzhanibekov", "--out", str(tmp_path / "run.h5"), "--quiet"],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )
    assert run.returncode == 0, run.stderr
    main = "from lieint.cli import main; raise SystemExit(main())"
    result = run_without(["matplotlib"], main, "plot", str(tmp_path / "run.h5"))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert (
        'lieint plot: lieint plot needs matplotlib, which is not installed: pip install "lieint[plot]"' in result.stderr
    )
