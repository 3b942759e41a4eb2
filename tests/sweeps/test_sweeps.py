"""Sweeps in one process: keys, plans, chunks, the Zarr store, resume, stacked systems.

The cluster tests (two worker processes, a killed worker, a killed client) are in
tests/sweeps/test_sweeps_cluster.py.
"""

import sys

import numpy as np
import pytest

pytest.importorskip("zarr")
xr = pytest.importorskip("xarray")

import lieint  # noqa: E402
from lieint.sweeps import SweepError, open_sweep, parse_key, parse_vary, plan_from_scene, sweep  # noqa: E402
from lieint.sweeps.chunk import compute_chunk  # noqa: E402
from lieint.sweeps.store import StoreError  # noqa: E402
from lieint.systems.stacked import stack_systems  # noqa: E402

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
angular_velocity = [0.01, 1.0, 0.01]
[integrator]
method = "rkmk4"
step = 0.02
t_end = 2.0
save_every = 10
[output]
quantities = ["energy", "casimirs"]
"""

HEAVY = """
[scene]
name = "heavy"
[body]
principal_moments = [1.0, 1.0, 0.5]
mass = 1.0
center_of_mass = [0.0, 0.0, 0.3]
[support]
type = "fixed_point"
[forces]
gravity = { magnitude = 9.81, incline = 0.0 }
[initial]
angular_velocity = [0.5, 0.0, 10.0]
[integrator]
method = "rkmk4"
step = 0.01
t_end = 0.5
save_every = 5
[output]
quantities = ["energy", "gamma_norm"]
"""


def test_keys_parse_and_set_against_the_scene_schema():
    data = tomllib.loads(HEAVY)
    key = parse_key("body.principal_moments[0]", data)
    assert key.changes_system and key.get(data) == 1.0
    assert key.set(data, 1.5)["body"]["principal_moments"] == [1.5, 1.0, 0.5]
    assert data["body"]["principal_moments"][0] == 1.0  # a copy
    assert parse_key("forces.gravity.incline", data).set(data, 0.3)["forces"]["gravity"]["incline"] == 0.3
    assert not parse_key("initial.angular_velocity[2]", data).changes_system
    omega = tomllib.loads(TOP.replace("angular_velocity = [0.01, 1.0, 0.01]", "omega = [[0,1,0],[-1,0,0],[0,0,0]]"))
    set_ = parse_key("initial.omega[0][1]", omega).set(omega, 2.0)["initial"]["omega"]
    assert set_[0][1] == 2.0 and set_[1][0] == -2.0  # its skew partner too


@pytest.mark.parametrize(
    ("key", "match"),
    [
        ("body.principal_moment[0]", r"unknown key 'principal_moment' of \[body\]; allowed keys are"),
        ("bodies.mass", r"unknown table 'bodies'"),
        ("integrator.step", r"the \[integrator\] table cannot be varied"),
        ("body.principal_moments", r"names an array, not a number; index it, e.g. 'body.principal_moments\[0\]'"),
        ("body.principal_moments[3]", r"index 3 is out of range for 'body.principal_moments', which has 3 entries"),
        ("body.radius", r"the scene has no 'body.radius' to vary"),
        ("forces.gravity.angle", r"gravity as a table has 'magnitude' and 'incline'; got 'angle'"),
        ("body.mass[0]", r"'body.mass' is not an array"),
        ("body..mass", r"is not of the form table.key"),
    ],
)
def test_bad_keys_are_refused_with_what_was_expected(key, match):
    with pytest.raises(SweepError, match=match):
        plan_from_scene(HEAVY, {key: [1.0]})


def test_vary_specs():
    assert parse_vary("body.mass=1:2:5")[1].tolist() == [1.0, 1.25, 1.5, 1.75, 2.0]
    assert parse_vary("forces.gravity.incline=0,pi/6")[1].tolist() == pytest.approx([0.0, np.pi / 6])
    for bad, match in [
        ("body.mass", "expects KEY=START:STOP:NUM"),
        ("body.mass=1:2:0", "NUM must be a positive integer"),
        ("body.mass=1:2", "expected START:STOP:NUM or V1,V2"),
        ("body.mass=a", "'a' is not a number"),
    ]:
        with pytest.raises(SweepError, match=match):
            parse_vary(bad)


def test_plan_members_are_the_product_and_chunks_cover_them_once():
    plan = plan_from_scene(
        TOP, ["body.principal_moments[0]=1:1.4:3", "initial.angular_velocity[2]=0.01,0.02"], ensemble=5, spread=0.01
    )
    assert (plan.npoints, plan.ensemble, plan.nmembers) == (6, 5, 30)
    assert plan.point_values(0) == (1.0, 0.01) and plan.point_values(1) == (1.0, 0.02)
    assert plan.point_values(5) == (1.4, 0.02)
    plan.chunk = 7
    ranges = [plan.chunk_range(c) for c in range(plan.nchunks)]
    assert ranges[0] == (0, 7) and ranges[-1] == (28, 30)
    assert sum(b - a for a, b in ranges) == 30


def test_refusals():
    with pytest.raises(SweepError, match=r"a sweep runs fixed-step methods.*'rkmk45' is adaptive"):
        plan_from_scene(TOP.replace('method = "rkmk4"', 'method = "rkmk45"'))
    with pytest.raises(SweepError, match="'scipy:DOP853' is self-controlled"):
        plan_from_scene(TOP.replace('method = "rkmk4"', 'method = "scipy:DOP853"'))
    with pytest.raises(SweepError, match=r"`spread`.*is required for an ensemble"):
        plan_from_scene(TOP, ensemble=3)
    # (a free top takes any positive moments, I₁ = 6 > I₂ + I₃ too: tests/systems/test_euler_top_moments.py)
    with pytest.raises(
        SweepError, match=r"the scene at body.principal_moments\[0\] = -1 is invalid: .*must be positive"
    ):
        plan_from_scene(TOP, {"body.principal_moments[0]": [1.0, -1.0]})
    with pytest.raises(
        SweepError, match=r"body.principal_moments\[2\] = 3 is invalid: .*must satisfy I_i <= I_j \+ I_k"
    ):
        plan_from_scene(HEAVY, {"body.principal_moments[2]": [0.5, 3.0]})  # a heavy top needs a mass distribution
    with pytest.raises(SweepError, match="`chunk` must be a positive integer"):
        plan_from_scene(TOP, chunk=0)


def test_a_key_that_changes_the_system_kind_is_refused(tmp_path):
    # X_G = 0 turns the heavy top into an Euler top with other state fields
    scene = HEAVY.replace('["energy", "gamma_norm"]', '["energy"]')
    with pytest.raises(SweepError, match=r"center_of_mass\[2\] = 0 the scene builds EulerTop with \['A'\].*HeavyTop"):
        sweep(scene, {"body.center_of_mass[2]": [0.3, 0.0]}, out=tmp_path / "s.zarr", scheduler="synchronous")
    assert not (tmp_path / "s.zarr").exists()  # refused before anything ran


def test_sweep_equals_independent_runs_and_is_read_by_xarray(tmp_path):
    """Every member against lieint.integrate of a top built independently from I and w."""
    out = tmp_path / "top.zarr"
    moments = [1.0, 1.2, 1.4]
    report = sweep(
        TOP,
        {"body.principal_moments[0]": moments},
        ensemble=4,
        seed=7,
        spread=0.05,
        out=out,
        scheduler="synchronous",
        chunk=4,
    )
    assert (report.status, report.computed, report.skipped, report.nmembers) == ("complete", 3, 0, 12)
    ds = xr.open_zarr(out)
    assert ds.attrs["status"] == "complete" and ds["chunk_committed"].values.tolist() == [1, 1, 1]
    assert ds["body.principal_moments[0]"].values.tolist() == np.repeat(moments, 4).tolist()
    assert ds["time"].values == pytest.approx(np.linspace(0.0, 2.0, 11), abs=1e-15)
    w = np.array([0.01, 1.0, 0.01]) + 0.05 * np.random.default_rng(7).normal(size=(4, 3))
    for p, I1 in enumerate(moments):
        top = lieint.EulerTop.from_principal_moments([I1, 2.0, 3.0], orientation=False)
        sol = lieint.integrate(top, top.initial_state(angular_velocity=w), (0.0, 2.0), h=0.02, save_every=10)
        sel = slice(4 * p, 4 * p + 4)
        for field in ("A",):
            assert np.array_equal(ds[f"state_{field}"].values[sel], np.swapaxes(sol.states[field], 0, 1))
        assert np.array_equal(ds["drift_energy"].values[sel], sol.drift("energy"))
        assert np.array_equal(ds["energy"].values[sel], sol.invariants["energy"].T)
    # the grid view: one dimension per key
    grid = open_sweep(out, grid=True)
    assert grid["drift_casimirs"].sel({"body.principal_moments[0]": 1.2}).shape == (4,)
    assert float(grid["drift_casimirs"].max()) < 1e-13  # a Lie-group method keeps the Casimirs
    meta = ds["chunk_info"].sel(info="backend").values.tolist()
    assert (
        all(b in ("numba", "numpy") for b in meta)
        and ds["chunk_info"].sel(info="method").values.tolist() == ["rkmk4"] * 3
    )
    assert np.all(ds["chunk_stats"].sel(stat="wall_time").values > 0) and set(
        ds["chunk_info"].sel(info="worker").values.tolist()
    ) == {"local"}


def test_store_refuses_overwrite_and_foreign_resume_and_resumes_its_own(tmp_path):
    out = tmp_path / "s.zarr"
    kw = dict(out=out, scheduler="synchronous", chunk=1)
    sweep(TOP, {"body.principal_moments[0]": [1.0, 1.1]}, **kw)
    with pytest.raises(StoreError, match="exists; pass --resume"):
        sweep(TOP, {"body.principal_moments[0]": [1.0, 1.1]}, **kw)
    with pytest.raises(StoreError, match="holds another sweep"):
        sweep(TOP, {"body.principal_moments[0]": [1.0, 1.2]}, resume=True, **kw)
    again = sweep(TOP, {"body.principal_moments[0]": [1.0, 1.1]}, resume=True, **kw)
    assert (again.computed, again.skipped) == (0, 2)
    (tmp_path / "plain").mkdir()
    with pytest.raises(StoreError, match="is not a lieint sweep store"):
        sweep(TOP, out=tmp_path / "plain", resume=True, scheduler="synchronous")


def test_resume_recomputes_exactly_the_uncommitted_chunks(tmp_path):
    """A store whose writer died after committing chunk 0 and half-writing chunk 1."""
    from lieint.sweeps.store import SweepStore

    plan = plan_from_scene(TOP, {"body.principal_moments[0]": [1.0, 1.1, 1.2]}, chunk=1)
    store = SweepStore(tmp_path / "s.zarr", plan)
    store.commit(compute_chunk(plan, 0), "first")
    half = compute_chunk(plan, 1)
    store.root["state_A"][1:2] = half.states["A"] + 1.0  # data written, never flagged committed
    report = sweep(TOP, {"body.principal_moments[0]": [1.0, 1.1, 1.2]}, out=tmp_path / "s.zarr", chunk=1,
                   scheduler="synchronous", resume=True)  # fmt: skip
    assert (report.computed, report.skipped) == (2, 1)
    ds = xr.open_zarr(tmp_path / "s.zarr")
    assert (
        ds["chunk_info"].sel(info="session").values[0] == "first"
        and ds["chunk_info"].sel(info="session").values[1] != "first"
    )
    whole = sweep(TOP, {"body.principal_moments[0]": [1.0, 1.1, 1.2]}, out=tmp_path / "w.zarr", chunk=1,
                  scheduler="synchronous")  # fmt: skip
    assert whole.computed == 3
    ref = xr.open_zarr(tmp_path / "w.zarr")
    for name in ("state_A", "energy", "drift_energy"):
        assert np.array_equal(ds[name].values, ref[name].values)


def test_systems_and_states_instead_of_a_scene(tmp_path):
    tops = [lieint.EulerTop(np.diag(b)) for b in ([1.0, 2.0, 3.0, 4.0], [1.5, 2.0, 3.0, 4.0])]
    rng = np.random.default_rng(3)
    X = rng.normal(size=(3, 4, 4))
    states = [tops[0].initial_state(Omega=X[:2] - np.swapaxes(X[:2], -1, -2)),
              tops[0].initial_state(Omega=X[2] - X[2].T)]  # fmt: skip
    report = sweep(systems=tops, y0=states, t_span=(0, 1), h=0.01, out=tmp_path / "s.zarr",
                   outputs=["energy"], scheduler="synchronous", chunk=3)  # fmt: skip
    assert report.nmembers == 6
    ds = xr.open_zarr(tmp_path / "s.zarr")
    for p, top in enumerate(tops):
        y0 = {k: np.concatenate([states[0][k], states[1][k][None]]) for k in states[0]}
        sol = lieint.integrate(top, y0, (0, 1), h=0.01)
        assert np.array_equal(ds["state_A"].values[3 * p : 3 * p + 3], np.swapaxes(sol.states["A"], 0, 1))
        assert np.array_equal(ds["drift_energy"].values[3 * p : 3 * p + 3], sol.drift("energy"))
    grid = open_sweep(tmp_path / "s.zarr", grid=True)
    assert grid["drift_energy"].dims == ("point", "ensemble_member") and grid["drift_energy"].shape == (2, 3)
    with pytest.raises(SweepError, match="either a `scene`"):
        sweep(TOP, systems=tops, y0=states, t_span=(0, 1), h=0.01, out=tmp_path / "x.zarr")


def test_stacked_tops_equal_each_top_run_alone():
    """Stacked 4D Euler tops (different B) and heavy tops (different mass and gravity): one batch."""
    rng = np.random.default_rng(5)
    tops = [lieint.EulerTop(np.diag(b)) for b in ([1.0, 2.0, 3.0, 4.0], [1.0, 1.5, 3.5, 4.0])]
    X = rng.normal(size=(3, 4, 4))
    Omega = X - np.swapaxes(X, -1, -2)
    heavy = [
        lieint.HeavyTop(np.diag([0.25, 0.25, 0.75]), 1.0, [0, 0, 0.3], [0, 0, -9.81]),
        lieint.HeavyTop(np.diag([0.25, 0.25, 0.75]), 2.0, [0, 0, 0.3], [0, 4.9, -8.5]),
    ]
    w = rng.normal(size=(3, 3)) * 3
    cases = [
        (tops, [t.initial_state(Omega=Omega) for t in tops]),
        (heavy, [t.initial_state(angular_velocity=w) for t in heavy]),
    ]
    for systems, states in cases:
        stacked = stack_systems(systems, [3, 3])
        both = {k: np.concatenate([s[k] for s in states]) for k in states[0]}
        sol = lieint.integrate(stacked, both, (0, 1), h=0.01, project=True)
        for i, system in enumerate(systems):
            # the stacked system runs the generic path: so does each top alone (the 4D top alone
            # would otherwise run the compiled kernel, whose round-off differs)
            alone = lieint.integrate(system, states[i], (0, 1), h=0.01, project=True, backend="numpy")
            for k in alone.states:
                np.testing.assert_allclose(sol.states[k][:, 3 * i : 3 * i + 3], alone.states[k], rtol=0, atol=1e-13)
            np.testing.assert_allclose(sol.drift("energy")[3 * i : 3 * i + 3], alone.drift("energy"), atol=1e-15)
            assert np.max(sol.drift("casimirs")) < 1e-12
    assert "manakov" not in stack_systems(tops, [1, 1]).invariants  # its normalisation is per body
    assert stack_systems([tops[0], heavy[0]], [1, 1]) is None


@pytest.mark.parametrize("backend", ["numpy", "auto"])
def test_a_heavy_top_incline_sweep_runs_stacked_and_matches_each_point(tmp_path, backend):
    """On the generic path the points (one heavy top per incline) run stacked as one batch; with
    the compiled kernel each point runs compiled in its own call (faster than a stacked generic
    batch). Either way each point equals its own run."""
    out = tmp_path / "h.zarr"
    angles = [0.0, 0.3, 0.6]
    sweep(HEAVY, {"forces.gravity.incline": angles}, out=out, scheduler="synchronous", chunk=3, backend=backend)
    ds = xr.open_zarr(out)
    stats = ds["chunk_stats"]
    if backend == "numpy":
        assert stats.sel(stat="stacked").values.tolist() == [1] and stats.sel(stat="batches").values.tolist() == [1]
    else:
        assert stats.sel(stat="stacked").values.tolist() == [0] and stats.sel(stat="batches").values.tolist() == [3]
    for p, theta in enumerate(angles):
        g = 9.81 * np.array([np.sin(theta), 0.0, -np.cos(theta)])
        top = lieint.HeavyTop(np.diag([0.25, 0.25, 0.75]), 1.0, [0, 0, 0.3], g, orientation=False)
        sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.5, 0.0, 10.0]), (0, 0.5), h=0.01,
                               save_every=5, backend=backend)  # fmt: skip
        np.testing.assert_allclose(ds["state_Gamma"].values[p], sol.states["Gamma"], rtol=0, atol=1e-13)
        np.testing.assert_allclose(ds["energy"].values[p], sol.invariants["energy"], rtol=1e-14)


def test_import_lieint_does_not_import_dask_or_zarr():
    import subprocess

    code = "import sys, lieint, lieint.sweeps; print(any(m in sys.modules for m in ('dask', 'distributed', 'zarr')))"
    assert (
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
        == "False"
    )


def test_cli_sweep(tmp_path, capsys):
    from lieint.cli import main

    scene = tmp_path / "top.toml"
    scene.write_text(TOP, encoding="utf-8")
    out = tmp_path / "cli.zarr"
    args = ["sweep", str(scene), "--vary", "body.principal_moments[0]=1:1.2:2", "--ensemble", "3", "--spread", "0.01"]
    assert main([*args, "--out", str(out), "--scheduler", "synchronous", "--chunk", "3"]) == 0
    assert "6 members in 2 chunks (2 computed, 0 already committed) on synchronous" in capsys.readouterr().out
    assert main([*args, "--out", str(out), "--scheduler", "synchronous", "--chunk", "3"]) == 2
    assert "exists; pass --resume" in capsys.readouterr().err
    assert main([*args, "--out", str(out), "--scheduler", "synchronous", "--chunk", "3", "--resume"]) == 0
    assert "(0 computed, 2 already committed)" in capsys.readouterr().out
    bad = ["sweep", str(scene), "--vary", "body.principal_moments[0]", "--out", str(tmp_path / "x.zarr")]
    assert main(bad) == 2
    assert "--vary expects KEY=START:STOP:NUM" in capsys.readouterr().err
    assert main(["sweep", "dzhanibekov", "--out", str(tmp_path / "y.zarr"), "--scheduler", "nowhere"]) == 2
    assert "`scheduler` must be a scheduler address" in capsys.readouterr().err
    assert not (tmp_path / "y.zarr").exists()
    with pytest.raises(SweepError, match="`workers` must be a positive integer"):
        sweep(TOP, out=tmp_path / "z.zarr", workers=0)


def test_an_ensemble_from_a_file_travels_with_the_plan(tmp_path, monkeypatch):
    """The scene's [ensemble] file is read once, on the client: workers need not see it."""
    w = np.array([[0.01, 1.0, 0.01], [0.02, 1.0, 0.0], [0.0, 1.0, 0.03]])
    np.save(tmp_path / "members.npy", w)
    scene = tmp_path / "top.toml"
    scene.write_text(TOP + '[ensemble]\nfile = "members.npy"\n', encoding="utf-8")
    plan = plan_from_scene(scene, {"body.principal_moments[0]": [1.0, 1.2]})
    (tmp_path / "members.npy").unlink()  # as on a remote worker
    out = tmp_path / "f.zarr"
    from lieint.sweeps.engine import run_sweep

    run_sweep(plan, out, scheduler="synchronous")
    ds = xr.open_zarr(out)
    top = lieint.EulerTop.from_principal_moments([1.2, 2.0, 3.0], orientation=False)
    sol = lieint.integrate(top, top.initial_state(angular_velocity=w), (0.0, 2.0), h=0.02, save_every=10)
    assert np.array_equal(ds["state_A"].values[3:], np.swapaxes(sol.states["A"], 0, 1))


@pytest.mark.parametrize("backend", ["numpy", "auto"])
def test_the_member_that_refuses_a_chunk_its_step_is_named(tmp_path, backend):
    """Two points in one chunk (stacked into one batch on the generic path, one call each when
    compiled); h |w| = 50 > 2π at the second: the error names that member and its value."""
    vary = {"initial.angular_velocity[2]": [10.0, 5000.0]}
    with pytest.raises(lieint.groups.base.DexpinvRangeError) as caught:
        sweep(HEAVY, vary, out=tmp_path / "s.zarr", chunk=2, scheduler="synchronous", backend=backend)
    assert "member 1 (point 1, initial.angular_velocity[2] = 5000, ensemble member 0)" in str(caught.value)
    assert "its first step has ‖h ξ‖ = 50" in str(caught.value)
