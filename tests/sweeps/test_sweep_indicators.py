"""Chaos indicators per member of a sweep (``indicators=("megno", "lyapunov")``, ``--megno``).

The stored values are checked against :func:`lieint.megno` run directly on each member, against
the closed form of ⟨Y⟩ for a sheared torus (the spherical top, tests/tangent/test_megno_truths.py
derives it), through damage and resume, and bad input is refused by name.
"""

import sys

import numpy as np
import pytest
from scipy.integrate import quad

pytest.importorskip("zarr")
pytest.importorskip("xarray")

import lieint
from lieint.cli import main
from lieint.groups.bivectors import bivector_coordinates
from lieint.scenes import build_system, parse_scene
from lieint.sweeps import SweepError, open_sweep, sweep
from lieint.sweeps.info import inspect_sweep
from lieint.sweeps.integrity import DamagedStoreError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

TOP = """
[scene]
name = "top"
[body]
principal_moments = [1.0, 2.0, 3.0]
[support]
type = "fixed_point"
[initial]
angular_velocity = [0.3, 1.0, 0.4]
[integrator]
method = "rkmk4"
step = 0.05
t_end = 5.0
save_every = 50
[output]
quantities = ["energy"]
"""
MOMENTS = [1.0, 1.5, 2.5]


def _chunk_file(store, name, c):
    return store / name / "c" / str(c)


def test_stored_indicators_equal_lieint_megno_on_each_member_and_survive_damage_and_resume(tmp_path):
    out = tmp_path / "m.zarr"
    # 3 points × 2 members in chunks of 4: chunks of mixed points, run as stacked tops (numpy)
    kw = dict(out=out, ensemble=2, spread=0.2, chunk=4, scheduler="synchronous", progress=False, backend="numpy")
    sweep(TOP, {"body.principal_moments[0]": MOMENTS}, indicators=("megno", "lyapunov"), **kw)
    ds = open_sweep(out)
    assert ds["megno"].dims == ("member",) and ds["lyapunov"].dims == ("member",)
    assert ds.attrs["plan"]["indicators"] == ["megno", "lyapunov"]
    megno, lyap = ds["megno"].values, ds["lyapunov"].values
    for m in range(6):
        data = tomllib.loads(TOP)
        data["body"]["principal_moments"][0] = MOMENTS[m // 2]
        system, _ = build_system(parse_scene(data))
        y0 = {"A": ds["state_A"].values[m, 0]}
        direct = lieint.megno(system, y0, (0.0, 5.0), 0.05, "rkmk4")
        assert ds["body.principal_moments[0]"].values[m] == MOMENTS[m // 2]
        assert abs(megno[m] - direct.mean) <= 1e-12 * max(1.0, abs(direct.mean)), m
        assert abs(lyap[m] - direct.lyapunov) <= 1e-12, m
    assert len(set(np.round(megno, 6))) == 6  # every member has its own value (not a broadcast)
    grid = open_sweep(out, grid=True)
    assert grid["megno"].dims == ("body.principal_moments[0]", "ensemble_member")
    assert "indicators megno, lyapunov per member" in inspect_sweep(out).text()

    _chunk_file(out, "megno", 1).unlink()
    with pytest.raises(DamagedStoreError, match="chunk 1: megno: its file is missing"):
        open_sweep(out)
    report = sweep(TOP, {"body.principal_moments[0]": MOMENTS}, indicators=("megno", "lyapunov"), resume=True, **kw)
    assert (report.computed, report.skipped) == (1, 1) and list(report.damaged) == [1]
    again = open_sweep(out)
    assert np.array_equal(again["megno"].values, megno) and np.array_equal(again["lyapunov"].values, lyap)
    with pytest.raises(SweepError, match="holds another sweep"):  # the indicators are part of the sweep
        sweep(TOP, {"body.principal_moments[0]": MOMENTS}, indicators=("megno",), resume=True, **kw)


def test_a_megno_map_of_spherical_tops_follows_the_closed_form(tmp_path):
    """Spherical tops (I, I, I) perturbed along their momentum: ``|δ(t)| = |δ(0)| √(1 + (t/I)²)``,
    so ``⟨Y⟩(T) = 2 − 2 Ti₂(x)/x`` and the exponent ``log √(1 + x²)/T`` with ``x = T/I`` — the slow
    approach to 2 of a torus, ``≈ 2 − π log(x)/x``."""
    tops = [lieint.EulerTop.from_principal_moments([moment] * 3) for moment in MOMENTS]
    y0 = tops[0].initial_state(angular_velocity=[0.3, -0.5, 0.4])
    chart = lieint.tangent.chart_of(tops[0])
    vector = np.zeros(chart.dim)
    vector[chart.offsets["A"]] = bivector_coordinates(y0["A"])  # the same direction for every I
    T, h = 40.0, 0.1
    sweep(systems=tops, y0=y0, t_span=(0.0, T), h=h, out=tmp_path / "s.zarr", indicators=["megno", "lyapunov"],
          indicator_vector=vector, chunk=3, scheduler="synchronous", progress=False, backend="numpy")  # fmt: skip
    ds = open_sweep(tmp_path / "s.zarr")
    for p, moment in enumerate(MOMENTS):
        x = T / moment
        truth = 2.0 - 2.0 * quad(lambda u: np.arctan(u) / u, 0.0, x, epsabs=1e-14, epsrel=1e-13)[0] / x
        # RKMK4 is exact here (Ω constant); what remains are the quadratures of the sums: the
        # midpoint rule in Y, |ΔY| ≤ h²/(6I²), and the trapezoidal rule in ⟨Y⟩, h² (4/(3I²))/12
        tol = h**2 / (6.0 * moment**2) + h**2 * (4.0 / (3.0 * moment**2)) / 12.0
        assert abs(ds["megno"].values[p] - truth) <= tol, (moment, ds["megno"].values[p], truth)
        assert ds["lyapunov"].values[p] == pytest.approx(0.5 * np.log1p(x**2) / T, rel=1e-9)
    assert np.all(np.diff(ds["megno"].values) < 0)  # a slower shear (larger I) is further from 2


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"indicators": ["fli"]}, r"`indicators`: 'fli' is not a chaos indicator .*\['lyapunov', 'megno'\]"),
        ({"indicators": ["megno", "megno"]}, "names an indicator twice"),
        ({"indicators": 3}, "`indicators` must be a sequence of names"),
        ({"indicators": ["megno"], "indicator_vector": [1.0, 0.0]}, r"`indicator_vector` must be .* 3 tangent"),
        ({"indicators": ["megno"], "indicator_vector": [0.0, 0.0, 0.0]}, "`indicator_vector` must be a nonzero"),
        ({"indicator_vector": [1.0, 0.0, 0.0]}, "`indicator_vector` applies only with `indicators`"),
        (
            {"indicators": ["megno"], "method": "moser_veselov4"},
            r"`indicators` \['megno'\] are computed on the tangent map .* 'moser_veselov4' on EulerTop has none",
        ),
    ],
)
def test_bad_indicator_input_is_refused_by_name(tmp_path, kwargs, message):
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    with pytest.raises(SweepError, match=message):
        sweep(systems=top, y0=y0, t_span=(0.0, 1.0), h=0.1, out=tmp_path / "x.zarr", scheduler="synchronous",
              **kwargs)  # fmt: skip
    assert not (tmp_path / "x.zarr").exists()


def test_cli_sweep_megno(tmp_path, capsys):
    scene = tmp_path / "top.toml"
    scene.write_text(TOP.replace("t_end = 5.0", "t_end = 1.0"), encoding="utf-8")
    out = tmp_path / "c.zarr"
    code = main(["sweep", str(scene), "--vary", "body.principal_moments[0]=1:1.5:2", "--megno", "--scheduler",
                 "synchronous", "--out", str(out), "--quiet"])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    ds = open_sweep(out)
    assert "megno" in ds and "lyapunov" not in ds and ds["megno"].shape == (2,)
    assert np.all(np.isfinite(ds["megno"].values))


def test_a_member_whose_tangent_run_fails_reads_nan_and_is_named(tmp_path, monkeypatch):
    """A batch whose tangent run fails is run member by member; only the failing member is lost."""
    import lieint.analysis.chaos as chaos

    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    y0 = top.initial_state(angular_velocity=[[0.3, 1.0, 0.4], [1.0, 0.3, 0.2], [0.2, 0.4, 1.0]])
    bad = y0["A"][1]
    real = chaos.megno

    def failing(system, y, *args, **kwargs):
        if np.any(np.all(np.isclose(y["A"], bad), axis=(-2, -1))):
            raise FloatingPointError("the tangent vector became non-finite at t = 0.5; reduce `h` = 0.1.")
        return real(system, y, *args, **kwargs)

    monkeypatch.setattr(chaos, "megno", failing)
    sweep(systems=top, y0=y0, t_span=(0.0, 1.0), h=0.1, out=tmp_path / "f.zarr", indicators=["megno"], chunk=3,
          scheduler="synchronous", progress=False, backend="numpy")  # fmt: skip
    ds = open_sweep(tmp_path / "f.zarr")
    values = ds["megno"].values
    assert np.isnan(values[1]) and np.all(np.isfinite(values[[0, 2]]))
    for m in (0, 2):
        one = {"A": y0["A"][m]}
        assert abs(values[m] - real(top, one, (0.0, 1.0), 0.1).mean) <= 1e-12
    assert "indicators of member 1: the tangent vector became non-finite" in str(
        ds["chunk_info"].sel(info="warnings").values[0]
    )
