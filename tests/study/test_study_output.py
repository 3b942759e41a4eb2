"""What a person reads from `lieint compare` and `lieint plot`: a table that fits a terminal, figures
whose series can be told apart, legends and notes inside the figure, notes where err/rtol is far
above 1, and long runs thinned to what a figure can show."""

import math
from dataclasses import replace

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from lieint._plotting import MARKERS, PALETTE, envelope, log_floor, series_styles
from lieint.compare import default_scene
from lieint.methods.registry import method_specs
from lieint.study import Reference, Study, StudyRow, format_equal_cost, format_rows
from lieint.study.figures import (
    _draw,
    family_groups,
    long_run_invariants,
    plot_work_precision,
    plot_work_precision_families,
    representative_rows,
)
from lieint.study.notes import FAR_ABOVE, rtol_notes
from lieint.study.table import equal_cost

# -- a synthetic study: every registered method, its longest labels, no integration --------------


def _row(method, family, variant, projection, setting, *, error, rtol=None, h=None, cpu=1e-3, fallback=False):
    return StudyRow(
        scene="synthetic",
        method=method,
        family=family,
        variant=variant,
        setting=setting,
        projection=projection,
        h=h,
        rtol=rtol,
        steps=123456,
        rejected=0,
        nfev=1234567,
        backend="numpy" if fallback else "numba",
        backend_reason="",
        fallback=fallback,
        threads=1,
        cpu_min=cpu,
        cpu_median=cpu,
        wall_min=cpu,
        wall_median=cpu,
        cold_wall=cpu,
        repeats=3,
        error=error,
        resolved=error > 1e-12,
        energy_drift=1.2e-10,
        casimir_drift=3.4e-15,
        orthogonality=5.6e-16,
        success=True,
    )


def synthetic_study(ratio=3.0, methods=None):
    """Four points per series of every registered method (or ``methods``); adaptive series err at
    ``ratio`` × rtol, the first of them 1000× more: err/rtol far above 1."""
    specs = method_specs()
    rows = []
    for name in methods or specs:
        spec = specs[name]
        variants = (
            [("plain", False), ("projected saves", True)] if spec.family == "scipy" else [("projected steps", True)]
        )
        for vname, proj in variants:
            for j in range(4):
                cpu = 3e-4 * 30**j * (1 + 0.01 * (len(rows) % 7))
                if spec.adaptive:
                    rtol = 10.0 ** (-5 - 2 * j)
                    factor = 1000.0 if name == "rkmk45" else 1.0
                    rows.append(
                        _row(
                            name,
                            spec.family,
                            vname,
                            proj,
                            f"rtol={rtol:.0e}",
                            error=ratio * factor * rtol,
                            rtol=rtol,
                            cpu=cpu,
                        )
                    )
                else:
                    h = 0.00125 / 2**j
                    rows.append(
                        _row(name, spec.family, vname, proj, f"h={h:.4g}", error=10.0 ** (-3 - 2 * j), h=h, cpu=cpu)
                    )
    rows.append(_row("rkmk6", "rkmk", "projected steps", True, "h=0.3", error=1e-3, h=0.3, fallback=True))
    scene = default_scene()
    reference = Reference("exact (synthetic)", None, ("A", "R"), 1e-13, True)
    metadata = {"machine": {"processor": "test CPU"}, "numba_threads": 1, "sweep": "quick"}
    return Study(scene, reference, [], rows, metadata)


@pytest.fixture(scope="module")
def study():
    return synthetic_study()


# -- the table ------------------------------------------------------------------------------------


def test_the_printed_table_fits_120_columns_for_every_registered_method(study):
    rows = format_rows(study)
    assert max(map(len, rows.splitlines())) <= 120
    ec = format_equal_cost(study)
    budgets = equal_cost(study)["budgets_ms"]
    assert len(budgets) >= 9 and ec.splitlines()[0].count("≤") == len(budgets)  # every budget shown
    assert max(map(len, ec.splitlines())) <= 120
    # every row is there, with its method, setting, error and err/rtol
    body = rows.splitlines()[2:]
    assert len(body) == len(study.rows)
    assert "moser_veselov_composed4" in rows and "scipy:DOP853 (proj.)" in rows and "rtol=1e-11" in rows


def test_wide_tables_keep_every_column(study):
    wide = format_rows(study, wide=True)
    assert max(map(len, wide.splitlines())) > 120  # the point of --wide
    for column in ("CPU min [ms]", "wall med [ms]", "evals", "variant"):
        assert column in wide.splitlines()[0]
    md = format_rows(study, "markdown")  # the measurement pages' tables stay wide
    assert "CPU med [ms]" in md.splitlines()[0]


def test_a_fallback_is_flagged_in_the_narrow_table(study):
    line = next(line for line in format_rows(study).splitlines() if "h=0.3" in line)
    assert "numpy!" in line


# -- notes ----------------------------------------------------------------------------------------


def test_a_series_far_above_its_rtol_gets_a_note_that_says_why(study):
    notes = rtol_notes(study)
    assert [n.number for n in notes] == [1]
    (note,) = notes
    assert note.series == ("rkmk45 [numba]",)
    assert "|A|" in note.text and "t²" in note.text and "+energy" in note.text and "theory.md §13" in note.text
    marked = [line for line in format_rows(study).splitlines() if line.rstrip().endswith("[1]")]
    assert len(marked) == 4 and all(line.startswith("rkmk45 ") for line in marked)


def test_no_note_when_every_series_is_near_its_rtol():
    assert rtol_notes(synthetic_study(ratio=FAR_ABOVE / 2000)) == []  # rkmk45 then at FAR_ABOVE / 2
    assert "[1]" not in format_rows(synthetic_study(ratio=FAR_ABOVE / 2000))


def test_saturated_and_unresolved_errors_do_not_make_notes():
    study = synthetic_study(methods=["rkmk853"])
    study.rows[0] = replace(study.rows[0], error=1.9)  # lost the phase altogether: says nothing of rtol
    assert rtol_notes(study) == []
    study.rows[1] = replace(study.rows[1], error=5e-5, resolved=False)  # 5e2 × rtol, but only a bound
    assert rtol_notes(study) == []
    study.rows[2] = replace(study.rows[2], error=5e-7)  # 5e2 × rtol 1e-9
    (note,) = rtol_notes(study)
    assert note.series == ("rkmk853 [numba]",) and "|A|" in note.text and "5e+02 × rtol" in note.text
    other = synthetic_study(methods=["scipy:RK45"])
    other.rows[3] = replace(other.rows[3], error=3e-8)  # 3e3 × rtol 1e-11
    (note,) = rtol_notes(other)
    assert note.series == ("scipy:RK45 (plain) [numba]",) and "rtol bounds each step's local error" in note.text


# -- figures --------------------------------------------------------------------------------------


def _series_lines(fig):
    ax = fig.axes[0]
    return [line for line in ax.get_lines() if line.get_label() and not line.get_label().startswith("_")][:-2]


def _inside(inner, outer, slack=1.0):
    return (
        inner.x0 >= outer.x0 - slack
        and inner.y0 >= outer.y0 - slack
        and inner.x1 <= outer.x1 + slack
        and inner.y1 <= outer.y1 + slack
    )


def test_every_figure_gives_each_series_its_own_colour_and_marker(study):
    groups = family_groups(study)
    assert {key.split("_")[0] for key, _, _ in groups} >= {"fixed", "adaptive", "long", "classical"}
    for _key, title, rows in groups:
        fig = _draw(study, rows, title)
        lines = _series_lines(fig)
        assert len(lines) == len({r.series for r in rows})
        colours = [matplotlib.colors.to_hex(line.get_color()) for line in lines]
        markers = [line.get_marker() for line in lines]
        assert len(set(colours)) == len(colours), (title, colours)
        assert len(set(markers)) == len(markers), (title, markers)
        matplotlib.pyplot.close(fig)


def test_the_overview_shows_about_eight_representative_series(study):
    rows = representative_rows(study)
    labels = list(dict.fromkeys(r.series for r in rows))
    assert 6 <= len(labels) <= 9
    assert {"rkmk4 [numba]", "rkmk853 [numba]", "rkmk853+energy [numba]", "rk4 [numba]"} <= set(labels)
    assert any(label.startswith("scipy:DOP853") for label in labels)


@pytest.mark.slow
def test_legend_title_and_notes_lie_inside_the_figure_and_apart(study, tmp_path):
    fig = _draw(study, [r for r in study.rows if r.family in ("rk", "scipy", "rkmk-embedded")][:400], "many series")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    tight = fig.get_tightbbox(renderer)  # in inches
    assert tight.x0 >= -0.01 and tight.y0 >= -0.01
    assert tight.x1 <= fig.get_figwidth() + 0.01 and tight.y1 <= fig.get_figheight() + 0.01
    legend = next(a.get_legend() for a in fig.axes if a.get_legend() is not None)
    leg = legend.get_window_extent(renderer)
    assert _inside(leg, box)
    ax = fig.axes[0]
    assert _inside(ax.title.get_window_extent(renderer), box)
    xlabel = ax.xaxis.label.get_window_extent(renderer)
    assert xlabel.y0 >= leg.y1 - 1, "the legend covers the x label"
    notes = [t for a in fig.axes[1:] for t in a.texts if t.get_text().startswith("[1]")]
    assert notes, "the note of the series far above rtol is printed under the legend"
    note = notes[0].get_window_extent(renderer)
    assert _inside(note, box) and note.y1 <= leg.y0 + 1, "the notes overlap the legend"
    matplotlib.pyplot.close(fig)
    # written to files: the overview and one per family
    assert plot_work_precision(study, tmp_path / "wp.png").stat().st_size > 10_000
    paths = plot_work_precision_families(study, tmp_path)
    assert {p.name for p in paths} >= {"work_precision_adaptive.png", "work_precision_classical.png"}


def test_styles_differ_in_colour_and_marker():
    styles = series_styles(len(MARKERS))
    assert len({c for c, _ in styles}) == len(styles) and len({m for _, m in styles}) == len(styles)
    assert len({c for c, _ in series_styles(len(PALETTE))}) == len(PALETTE)
    assert "v" not in MARKERS and "x" not in MARKERS  # kept for upper bounds and fallbacks
    with pytest.raises(ValueError, match="`n`"):
        series_styles(-1)


def test_the_long_run_panels_of_a_3d_top_are_not_its_manakov_integrals():
    import lieint

    top3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    assert long_run_invariants(top3) == ["energy", "casimirs", "momentum"]
    top4 = lieint.EulerTop(np.diag([0.5, 1.0, 1.7, 2.3]))
    assert "manakov" in long_run_invariants(top4)


# -- thinning and clamped zeros -------------------------------------------------------------------


def test_the_envelope_keeps_every_value_within_few_bins():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 400, 40_001)
    y = np.stack([np.sin(37 * t), np.cos(5 * t) + 0.01 * rng.standard_normal(t.size)], axis=1)
    y[17, 0] = np.nan
    x, lo, hi, thinned = envelope(t, y, 600)
    assert thinned and x.shape == (600,) and lo.shape == hi.shape == (600, 2)
    edges = np.linspace(0, t.size, 601).astype(int)
    for b in (0, 1, 299, 599):
        part = y[edges[b] : edges[b + 1]]
        assert np.all(lo[b] == np.nanmin(part, axis=0)) and np.all(hi[b] == np.nanmax(part, axis=0))
    assert np.nanmax(hi[:, 0]) == np.nanmax(y[:, 0]) and np.nanmin(lo[:, 0]) == np.nanmin(y[:, 0])
    assert np.all(np.isfinite(lo))  # a NaN does not wipe out its bin
    # short series are drawn as they are
    x2, lo2, hi2, thinned2 = envelope(t[:1000], y[:1000], 600)
    assert not thinned2 and lo2 is hi2 and x2.shape == (1000,)
    # bins equal in log t for log axes: every row still in one bin
    xl, lol, hil, _ = envelope(t[1:], y[1:, 1], 600, log=True)
    assert len(xl) <= 600 and np.nanmax(hil) == np.nanmax(y[1:, 1]) and np.nanmin(lol) == np.nanmin(y[1:, 1])
    assert np.all(np.diff(np.log(xl)) > 0)
    with pytest.raises(ValueError, match="`bins`"):
        envelope(t, y, 0)
    with pytest.raises(ValueError, match="positive, increasing"):
        envelope(t, y, 10, log=True)  # t[0] = 0


def test_log_floor_marks_what_it_clamped():
    shown, clamped = log_floor(np.array([0.0, 1e-20, 1e-10, np.nan]), 1e-17)
    assert list(clamped) == [True, True, False, False]
    assert shown[0] == shown[1] == 1e-17 and shown[2] == 1e-10 and math.isnan(shown[3])


SCENE_4D = """
[scene]
name = "4D top, 40001 rows"
[body]
mass_tensor = [[0.5, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.7, 0], [0, 0, 0, 2.3]]
[support]
type = "fixed_point"
[initial]
omega = [[0.0, -0.3, 0.5, -0.2], [0.3, 0.0, -0.4, 0.6], [-0.5, 0.4, 0.0, -0.1], [0.2, -0.6, 0.1, 0.0]]
[integrator]
method = "rkmk4"
step = 0.01
t_end = 400.0
save_every = 1
[output]
quantities = ["energy", "casimirs", "orientation"]
"""


def test_plot_of_a_4d_run_draws_every_component_thinned_with_clamped_zeros_said(tmp_path):
    import lieint
    from lieint.runs.plot import BINS, DRIFT_FLOOR, run_figure
    from lieint.runs.reading import read_series

    scene = tmp_path / "s.toml"
    scene.write_text(SCENE_4D)
    out = tmp_path / "r.h5"
    lieint.run(scene, out, progress=False)
    fig = run_figure(out)
    fig.canvas.draw()
    title = fig.get_suptitle()
    assert "40,001 saved rows" in title and f"{BINS} bins" in title
    strips = [a for a in fig.axes if a.get_ylabel().startswith("(R e₁)_")]
    assert [a.get_ylabel() for a in strips] == [f"(R e₁)_{c}" for c in range(1, 5)]
    assert "every component" in strips[0].get_title()
    # every drawn series holds at most the envelope's 2 × BINS vertices, not 40,001 points
    for ax in fig.axes:
        for line in ax.get_lines():
            assert len(line.get_xdata()) <= 2 * BINS
        for poly in ax.collections:
            for path in poly.get_paths():
                assert len(path.vertices) <= 2 * BINS + 3
    # the envelope of (R e₁)_4 holds the file's extreme values
    data = read_series(out, 10**6)
    r41 = data["states/R"][:, 3, 0]
    (band,) = strips[3].collections
    ys = band.get_paths()[0].vertices[:, 1]
    assert np.isclose(ys.max(), r41.max()) and np.isclose(ys.min(), r41.min())
    # an invariant that stays exactly at its first value is drawn at the floor and said so
    drift = np.abs(data["invariants/energy"][1:] - data["invariants/energy"][0]) / abs(data["invariants/energy"][0])
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    said = any("drawn at" in label for label in labels)
    cas = data["invariants/casimirs"]
    clamped = (np.linalg.norm(cas[1:] - cas[0], axis=-1) / np.linalg.norm(cas[0]) < DRIFT_FLOOR).any() or (
        drift < DRIFT_FLOOR
    ).any()
    assert said == clamped
    matplotlib.pyplot.close(fig)


def test_lieint_compare_prints_at_most_120_columns(capsys, tmp_path):
    from lieint.cli import main

    argv = ["compare", "--methods", "rkmk4,rkmk853,rk4,scipy:DOP853", "--t-end", "5", "--repeats", "1"]
    assert main([*argv, "--no-plots", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "err/rtol" in out and "rkmk853" in out
    assert max(map(len, out.splitlines())) <= 120
    assert main([*argv, "--no-plots", "--wide", "--out-dir", str(tmp_path)]) == 0
    assert "CPU min [ms]" in capsys.readouterr().out
