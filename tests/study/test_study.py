"""The work–precision study: references checked against independent solutions, honest timings
and back ends, the metadata, the plan read from the registry, the equal-cost table."""

import json
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lieint
from lieint.compare import default_scene
from lieint.methods import registry
from lieint.methods.base import Method, MethodSpec
from lieint.methods.scipy_ivp import StateLayout
from lieint.scenes import embedded_scene
from lieint.study import (
    equal_cost,
    prepare,
    reference_for,
    run_study,
    state_error,
    study_plan,
    timed,
    write_table,
)
from lieint.study.figures import long_run_methods
from lieint.study.measure import measure_point
from lieint.study.plan import PlanEntry, Variant
from lieint.study.reference import RESOLVED, _dop853, state_scale


def _scipy_truth(system, y0, t, rtol=1e-13):
    """An independent solution: scipy's DOP853 on the embedded equations, at the times t."""
    layout = StateLayout(y0)
    sol = solve_ivp(
        lambda s, z: layout.pack(system.vector_field(s, layout.unpack(z))),
        (t[0], t[-1]),
        layout.pack(y0),
        method="DOP853",
        rtol=rtol,
        atol=rtol * 1e-2,
        t_eval=t,
    )
    return layout.unpack_many(sol.y)


@pytest.mark.parametrize(("name", "t_end"), [("dzhanibekov", 20.0), ("incline_ball", 2.0)])
def test_exact_references_cover_the_whole_state_and_match_an_independent_solution(name, t_end):
    scene, system, y0 = prepare(replace(embedded_scene(name), t_end=t_end))
    ref = reference_for(scene, system, y0)
    assert ref.exact and set(ref.fields) == set(system.fields)  # R (and the centre) included
    t = np.linspace(0.0, t_end, 301)
    exact, truth = ref.evaluate(t), _scipy_truth(system, y0, t)
    for field in ref.fields:
        # measured: 3.8e-12 (A), 1.9e-12 (R) on the top; ≤ 4.7e-12 on the incline
        assert np.max(np.abs(exact[field] - truth[field])) < 5e-11, field
    R = exact["R"]
    assert np.max(np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3))) < 1e-13
    if name == "dzhanibekov":  # the space momentum R A Rᵀ is constant along the exact attitude
        m = R @ exact["A"] @ np.swapaxes(R, -1, -2)
        assert np.max(np.abs(m - m[0])) < 1e-13


def test_numerical_reference_estimates_its_own_error_conservatively():
    # on the top, where the exact solution tells the numerical reference's true error
    scene, system, y0 = prepare(replace(default_scene(), t_end=30.0))
    exact, numerical = reference_for(scene, system, y0), _dop853(scene, system, y0)
    assert not numerical.exact and "rtol 1e-13" in numerical.kind
    t = np.linspace(0.0, 30.0, 401)
    true_error, _ = state_error(t, numerical.evaluate(t), exact, state_scale(y0, exact.fields))
    assert true_error <= numerical.floor < 100 * max(true_error, 1e-15)


def _point(scene_name, method, n, t_end=20.0, **scene_changes):
    scene, system, y0 = prepare(replace(embedded_scene(scene_name), t_end=t_end, **scene_changes))
    ref = reference_for(scene, system, y0)
    entry = PlanEntry(method, "rkmk", "fixed", (n,), (Variant("plain", False),))
    row = measure_point(scene, system, y0, entry, entry.variants[0], n, ref, state_scale(y0, ref.fields), repeats=1)
    return row, scene, system, y0


def _kernel_declining_steps_above(monkeypatch, h_max: float) -> None:
    """A compiled engine that declines steps above ``h_max`` (the engine itself covers every
    step): how the study sees a run the driver sends down the generic path."""
    from lieint import driver, loops

    fixed_loop = loops.fixed_loop

    def declining(run, y0):
        if run.plan.h > h_max:
            return loops._FixedLoop(run, f"this kernel declines steps above {h_max}")
        return fixed_loop(run, y0)

    monkeypatch.setattr(driver, "fixed_loop", declining)


def test_a_fallback_to_the_generic_path_is_recorded_and_said(monkeypatch):
    _kernel_declining_steps_above(monkeypatch, 0.5)
    coarse, _, system, y0 = _point("dzhanibekov", "rkmk6", 100, t_end=100.0)
    fine, *_ = _point("dzhanibekov", "rkmk6", 10000, t_end=100.0)
    direct = lieint.integrate(system, y0, (0.0, 100.0), h=1.0, method="rkmk6", save_every=1)
    assert coarse.backend == direct.stats.backend == "numpy"  # what the driver really ran
    assert coarse.fallback and "declines steps above 0.5" in coarse.backend_reason
    assert fine.backend == "numba" and not fine.fallback
    assert coarse.series != fine.series and "fallback" in coarse.series  # separate curves in the figures


def test_coarse_rkmk6_steps_stay_compiled():
    # the compiled kernel checks the dexp⁻¹ radius exactly per stage: no fallback at h = 1
    coarse, *_ = _point("dzhanibekov", "rkmk6", 100, t_end=100.0)
    assert coarse.backend == "numba" and not coarse.fallback


def test_a_point_whose_run_raises_is_a_failed_row_with_its_reason():
    # RKMK4 at h = 20 on the top: stages far beyond the dexp⁻¹ series radius
    row, *_ = _point("dzhanibekov", "rkmk4", 5, t_end=100.0)
    assert not row.success and np.isnan(row.error) and not row.resolved
    assert "dexp" in row.message and row.repeats == 0


def test_scipy_projection_touches_the_saved_copies_only():
    study = run_study(replace(default_scene(), t_end=10.0), methods=["scipy:DOP853"], repeats=1, quick=True, threads=1)
    plain = [r for r in study.rows if r.variant == "plain"]
    projected = [r for r in study.rows if r.variant == "projected saves"]
    assert len(plain) == len(projected) >= 3
    for a, b in zip(plain, projected, strict=True):
        assert (a.steps, a.nfev, a.setting) == (b.steps, b.nfev, b.setting)  # the same solver run
        assert a.field_errors["A"] == b.field_errors["A"]  # the projection moves R only
        assert b.orthogonality < 1e-14 < a.orthogonality
    assert {r.series for r in study.rows} == {"scipy:DOP853 (plain) [scipy]", "scipy:DOP853 (projected saves) [scipy]"}


def test_study_records_machine_threads_backends_and_timings(tmp_path):
    study = run_study(replace(default_scene(), t_end=5.0), methods=["rkmk4", "rk4", "scipy:RK45"], repeats=2)
    meta = study.metadata
    assert meta["numba_threads"] == 1 and meta["machine"]["cpu_count"] >= 1
    for key in ("processor", "platform", "numpy", "scipy", "numba", "environment", "load_average", "date"):
        assert key in meta["machine"]
    assert "warm" in meta["timing"] and meta["reference"]["exact"]
    rows, kind = study  # unpacks as the earlier (rows, reference kind)
    assert rows is study.rows and kind == study.reference.kind
    for row in study.rows:
        assert row.backend == ("scipy" if row.family == "scipy" else "numba")
        assert row.threads == 1 and not row.fallback and row.success
        assert 0 < row.cpu_min <= row.cpu_median and 0 < row.wall_min <= row.wall_median
        assert 1 <= row.repeats <= 2 and np.isfinite(row.error)
    firsts = [r for r in study.rows if np.isfinite(r.cold_wall)]  # one warm-up per series
    assert len(firsts) == len({r.series for r in study.rows})
    csv_path, json_path = write_table(study, tmp_path)
    data = json.loads(json_path.read_text())
    assert data["metadata"]["machine"]["processor"] == meta["machine"]["processor"]
    assert {r["backend"] for r in data["rows"]} == {"numba", "scipy"}
    assert data["equal_cost"]["budgets_ms"]
    text = csv_path.read_text()
    assert "# numba_threads: 1" in text and "# machine:" in text
    header = next(line for line in text.splitlines() if not line.startswith("#"))
    for column in ("backend", "fallback", "cpu_min", "cpu_median", "wall_min", "wall_median", "error[R]"):
        assert column in header.split(",")


def test_errors_fall_with_the_step_and_lie_methods_keep_the_casimirs():
    study = run_study(replace(default_scene(), t_end=5.0), methods=["rkmk4", "rk4"], repeats=1)
    rk = [r for r in study.rows if r.method == "rkmk4"]
    # quick sweep h = 0.04 → 0.005 (factor 8, order 4): at least a factor 1000 (measured 4e3)
    assert rk[0].error > 1000 * rk[-1].error
    assert all(r.casimir_drift < 1e-13 for r in rk)
    assert max(r.casimir_drift for r in study.rows if r.method == "rk4") > 50 * max(r.casimir_drift for r in rk)


def test_points_the_reference_cannot_resolve_are_marked():
    study = run_study(replace(embedded_scene("chaplygin_ball"), t_end=2.0), methods=["rkmk853"], repeats=1)
    floor = study.reference.floor
    assert not study.reference.exact and floor > 0
    for row in study.rows:
        assert row.resolved == (row.error >= RESOLVED * floor)
    assert any(not r.resolved for r in study.rows) and any(r.resolved for r in study.rows)


def test_equal_cost_table_shows_measured_points_only():
    study = run_study(replace(default_scene(), t_end=5.0), methods=["rkmk4", "scipy:DOP853"], repeats=1)
    ec = equal_cost(study)
    budgets = ec["budgets_ms"]
    assert budgets == sorted(budgets)
    for label, errors in ec["series"].items():
        rows = [r for r in study.rows if r.series == label]
        seen = [e for e in errors if e is not None]
        assert seen == sorted(seen, reverse=True)  # a larger budget never reaches a worse error
        assert all(e in {r.error for r in rows} for e in seen)
        for b, e in zip(budgets, errors, strict=True):
            cheap = [r.error for r in rows if 1e3 * r.cpu_median <= b]
            assert e == (min(cheap) if cheap else None)


def test_plan_reads_the_registry_so_a_new_method_joins(monkeypatch):
    scene, system, _ = prepare(replace(default_scene(), t_end=5.0))
    names = [e.method for e in study_plan(system, scene)]

    def applies(name):
        try:
            registry.get_method(name).check_system(system)
        except ValueError:
            return False
        return True

    # every registered method that applies, in the registry's order (families from every module)
    assert names == [m for m in lieint.method_names() if applies(m)]
    assert {"rkmk", "rkmk-embedded", "rk", "scipy"} <= {e.family for e in study_plan(system, scene)}
    spec = registry.method_specs()["rkmk4"]
    extra = MethodSpec("rkmk4_again", "test-family", 4, partial(spec.build), description="a copy of rkmk4")
    monkeypatch.setitem(registry._SPECS, extra.name, extra)
    plan = {e.method: e for e in study_plan(system, scene)}
    assert plan["rkmk4_again"].family == "test-family" and plan["rkmk4_again"].kind == "fixed"
    with pytest.raises(ValueError, match="'nope' is not a method"):
        study_plan(system, scene, ["nope"])


def test_fixed_sweeps_are_around_the_scene_step():
    scene, system, _ = prepare(embedded_scene("incline_ball"))
    plan = {e.method: e for e in study_plan(system, scene, ["rkmk4", "lie_euler"])}
    T = scene.t_end - scene.t_start
    steps = [T / n for n in plan["rkmk4"].settings]
    assert np.allclose(steps, [4 * scene.step, 2 * scene.step, scene.step, scene.step / 2])
    assert np.allclose([T / n for n in plan["lie_euler"].settings], np.array(steps) / 4)  # order 1: finer
    short = study_plan(system, replace(scene, t_end=0.1), ["rkmk4"])[0]
    assert len(short.settings) == 4  # a short span keeps its four distinct steps


def test_long_run_uses_the_scene_step():
    scene = embedded_scene("incline_ball")
    labels = [label for label, _ in long_run_methods(scene)]
    assert any(f"h = {scene.step:g} (the scene's step)" in label for label in labels)
    assert all(kw.get("h", scene.step) == scene.step for _, kw in long_run_methods(scene))


def test_timed_warms_up_once_and_stops_repeating_past_its_budget():
    calls = []
    timing, result = timed(lambda: calls.append(1) or len(calls), 5, budget=0.0)
    assert len(calls) == 2 and result == 2 and timing.repeats == 1  # warm-up + one timed call
    timing, _ = timed(lambda: None, 3, warm_up=False)
    assert timing.repeats == 3 and np.isnan(timing.cold_wall)
    assert timing.cpu_min <= timing.cpu_median and timing.wall_min <= timing.wall_median


def test_bad_arguments_are_clear_errors():
    scene = replace(default_scene(), t_end=1.0)
    with pytest.raises(ValueError, match="`repeats` must be a positive integer; got 0"):
        run_study(scene, methods=["rk4"], repeats=0)
    with pytest.raises(ValueError, match="`threads` must be a positive integer or None; got 0"):
        run_study(scene, methods=["rk4"], threads=0)
    with pytest.raises(ValueError, match="`backend` must be 'auto' or 'numpy'; got 'gpu'"):
        run_study(scene, methods=["rk4"], backend="gpu")
    # an ensemble scene is studied on its nominal trajectory, and says so
    study = run_study(replace(scene, ensemble={"count": 3, "seed": 1, "spread": 0.1}), methods=["rk4"], repeats=1)
    assert "nominal trajectory" in study.metadata["note"] and study.reference.exact


def test_markdown_output_is_a_table_per_study(capsys, tmp_path):
    from lieint.cli import main

    argv = ["compare", "lagrange_top", "--methods", "rk4", "--t-end", "1", "--repeats", "1", "--no-plots"]
    assert main([*argv, "--format", "markdown", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("## Lagrange top: T = 1;") and "DOP853 at rtol 1e-13 (its error ≤" in out
    table = [line for line in out.splitlines() if line.startswith("| rk4 |")]
    assert len(table) >= 3 and all(line.count("|") == 15 for line in table)


def test_a_series_that_starts_on_a_fallback_warms_the_kernel_before_timing_it(monkeypatch):
    from lieint.study import sweep

    _kernel_declining_steps_above(monkeypatch, 1.0)
    calls = []
    warm = sweep._warm_kernel
    monkeypatch.setattr(sweep, "_warm_kernel", lambda *a: calls.append(a[3].method) or warm(*a))
    # the top's scene step 0.3: the coarsest RKMK6 step (1.2) is declined by the kernel
    study = run_study(replace(default_scene(), step=0.3), methods=["rkmk6"], repeats=1)
    assert study.rows[0].fallback and study.rows[-1].backend == "numba"
    assert calls == ["rkmk6"]
    assert len({r.series for r in study.rows}) == 2  # the fallback is a curve of its own


def test_a_series_stops_after_a_point_over_the_time_limit_and_says_so():
    study = run_study(replace(default_scene(), t_end=5.0), methods=["rkmk4"], repeats=1, max_seconds=1e-9)
    assert [r.setting for r in study.rows] == ["h=0.04"]  # the coarsest point only
    (skip,) = study.metadata["skipped"]
    assert skip["method"] == "rkmk4" and skip["settings"] == ["h=0.02", "h=0.01", "h=0.005"]
    assert "> 1e-09 s" in skip["reason"]
    with pytest.raises(ValueError, match="`max_seconds` must be a positive number, 'auto' or None; got 0"):
        run_study(replace(default_scene(), t_end=1.0), methods=["rk4"], max_seconds=0)


@dataclass(frozen=True)
class _BallsOnly(Method):
    """RKMK4 that declares it applies to rolling balls only (a method with requirements)."""

    name = "balls_only"
    order = 4

    def check_system(self, system):
        from lieint.systems import RollingBall

        if not isinstance(system, RollingBall):
            raise ValueError(f"`method` 'balls_only' steps rolling balls only; got {type(system).__name__}.")

    def step(self, system, t, y, h, state):
        return registry.get_method("rkmk4").step(system, t, y, h, state)


def test_a_method_that_does_not_apply_is_left_out_of_the_default_plan_and_of_studies_of_several_scenes(
    monkeypatch, capsys, tmp_path
):
    from lieint.cli import main

    spec = MethodSpec("balls_only", "test-family", 4, lambda coordinates=None: _BallsOnly())
    monkeypatch.setitem(registry._SPECS, spec.name, spec)
    scene, system, _ = prepare(replace(default_scene(), t_end=1.0))
    assert "balls_only" not in {e.method for e in study_plan(system, scene)}
    with pytest.raises(ValueError, match="rolling balls only"):
        study_plan(system, scene, ["balls_only"])
    argv = ["compare", "dzhanibekov", "incline_ball", "--methods", "balls_only", "--t-end", "0.2", "--repeats", "1"]
    assert main([*argv, "--no-plots", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "not applicable: balls_only: `method` 'balls_only' steps rolling balls only; got EulerTop." in out
    incline = json.loads((tmp_path / "incline_ball" / "work_precision.json").read_text())
    assert {r["method"] for r in incline["rows"]} == {"balls_only"}


def test_the_quick_sweep_stops_slow_series_sooner_and_warms_up_on_part_of_the_span(monkeypatch):
    from lieint.study import measure

    spans = []
    real = measure.integrate
    monkeypatch.setattr(measure, "integrate", lambda *a, **k: spans.append(a[2]) or real(*a, **k))
    scene = replace(default_scene(), t_end=2.0)
    quick = run_study(scene, methods=["rk4"], repeats=1)
    full = run_study(scene, methods=["rk4"], repeats=1, quick=False, max_seconds="auto")
    assert quick.metadata["max_seconds"] == 1.0 and full.metadata["max_seconds"] == 5.0
    # one warm-up per series over the first part of the span (at least ten steps), then whole
    # spans (compile_jobs = 1, the default: nothing is compiled ahead)
    short = [s for s in spans if s[1] < 2.0]
    assert quick.metadata["compiled_ahead"]["processes"] == full.metadata["compiled_ahead"]["processes"] == 0
    assert len(short) == 2 and all(0.1 <= s[1] < 2.0 for s in short)
    assert len(spans) - len(short) == len(quick.rows) + len(full.rows)
