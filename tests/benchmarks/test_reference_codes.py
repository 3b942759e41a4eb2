"""lieint against the reference Fortran codes at a small size: Hairer–Vilmart's DMV2 … DMV10 and
TOMS 903's FRB_STEP, compiled by ``benchmarks/reference_codes.py`` (which times them too).

Skipped unless gfortran is installed and ``LIEINT_REFERENCE_CODES`` names a directory holding
``dmv10.f`` and ``frb_step.f`` (see that script's docstring for where to get them)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import lieint

pytestmark = pytest.mark.reference_codes

_spec = importlib.util.spec_from_file_location(
    "reference_codes", Path(__file__).resolve().parents[2] / "benchmarks" / "reference_codes.py"
)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


@pytest.fixture(scope="module")
def codes():
    try:
        with bench.reference_codes() as compiled:
            yield compiled
    except bench.ReferenceCodesUnavailable as why:
        pytest.skip(str(why))


@pytest.mark.parametrize(("name", "order"), bench.MV_PAIRS)
def test_moser_veselov_forms_are_the_dmv_maps(codes, name, order):
    # 1000 steps of h = 0.1 on Figure 1's motion (measured: ≤ 2e-13 for every order)
    Pi, q = codes.dmv(order, bench.HV_MOMENTS, bench.HV_PI0, [1.0, 0.0, 0.0, 0.0], 0.1, 1000)
    y = bench.run_lieint(name, bench.HV_MOMENTS, bench.state(bench.HV_PI0), 0.1, 1000)
    assert bench.difference(y, Pi, bench.quaternion_to_rotation(q)) < 1e-12


def test_exact_flow_is_frb_step(codes):
    Pi0 = np.array([0.3, 2.0, 1.2])
    Pi, R = codes.frb((1.0, 2.0, 3.0), Pi0, np.eye(3), 0.1, 1000)
    y = bench.run_lieint("exact_flow", (1.0, 2.0, 3.0), bench.state(Pi0), 0.1, 1000)
    assert bench.difference(y, Pi, R) < 2e-12


def test_figure_1_order_10_within_twice_dmv10(codes):
    top = lieint.EulerTop.from_principal_moments(bench.HV_MOMENTS)
    y0 = bench.state(bench.HV_PI0)
    exact = {k: v[-1] for k, v in top.exact_solution([10.0], y0).items()}
    Pi, q = codes.dmv(10, bench.HV_MOMENTS, bench.HV_PI0, [1.0, 0.0, 0.0, 0.0], 0.1, 100)
    reference = bench.difference(exact, Pi, bench.quaternion_to_rotation(q))
    mine = bench.difference(bench.run_lieint("moser_veselov10", bench.HV_MOMENTS, y0, 0.1, 100), bench.momentum(exact),
                            exact["R"])  # fmt: skip
    assert 1e-13 < reference < 1e-10  # DMV10 measured 9.7e-12
    assert mine <= 2.0 * reference, (mine, reference)


def test_a_missing_copy_is_named(tmp_path, monkeypatch):
    monkeypatch.delenv(bench.ENV, raising=False)
    with pytest.raises(bench.ReferenceCodesUnavailable, match="set LIEINT_REFERENCE_CODES=DIR or pass --codes DIR"):
        bench.locate()
    with pytest.raises(bench.ReferenceCodesUnavailable, match=r"holds no Hairer–Vilmart's dmv10\.f"):
        bench.locate(tmp_path)
    (tmp_path / "DMV10.FI").write_text("")
    with pytest.raises(bench.ReferenceCodesUnavailable, match=r"holds no TOMS 903's frb_step\.f"):
        bench.locate(tmp_path)
    with pytest.raises(bench.ReferenceCodesUnavailable, match="is not a directory"):
        bench.locate(tmp_path / "nowhere")


def test_a_missing_compiler_is_named(monkeypatch):
    monkeypatch.setenv("FC", "no-such-fortran-compiler")
    with pytest.raises(bench.ReferenceCodesUnavailable, match="no Fortran compiler: install gfortran"):
        bench.compiler()
