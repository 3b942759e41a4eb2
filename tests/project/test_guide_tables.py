"""Every row of the documentation's work–precision tables can be produced by the command printed next to it.

The tables (``docs/measurements/work_precision.md``, blocks ``<!-- study-table: ID -->``) are written by
``benchmarks/guide_tables.py``. Here each block's command is parsed by the real command-line
parser and planned by the real study plan: every row shown must be a point of that plan (a
subset check, so a method registered later does not break this test), and the cheap rows are
re-run to check that the command reproduces the printed error and back end.
"""

import importlib.util
import re
from pathlib import Path

import pytest

from lieint.compare import selected_scenes
from lieint.study import prepare, reference_for, study_plan
from lieint.study.measure import measure_point
from lieint.study.reference import state_scale

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "measurements" / "work_precision.md"
BLOCK = re.compile(r"<!-- study-table: (?P<id>[\w-]+) -->\n(?P<body>.*?)<!-- /study-table -->", re.S)
SERIES = re.compile(r"^(?P<method>\S+)(?: \((?P<variant>[^)]+)\))? \[(?P<backend>[^\]]+)\]$")


def _script():
    spec = importlib.util.spec_from_file_location("guide_tables", ROOT / "benchmarks" / "guide_tables.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _blocks():
    out = []
    for m in BLOCK.finditer(PAGE.read_text(encoding="utf-8")):
        body = m.group("body")
        command = re.search(r"`(lieint compare[^`]*)`", body)
        lines = [line for line in body.splitlines() if line.startswith("|")]
        cells = [[c.strip() for c in line.strip("|").split("|")] for line in lines if not line.startswith("|---")]
        out.append((m.group("id"), command.group(1) if command else None, cells))
    return out


BLOCKS = _blocks()


def test_the_measurements_page_has_the_generated_tables_with_their_commands():
    script = _script()
    assert {tid for tid, _, _ in BLOCKS} == {tid for tid, _, _ in script.TABLES}
    commands = {tid: cmd for tid, cmd, _ in script.TABLES}
    for tid, command, cells in BLOCKS:
        assert command == commands[tid], f"{tid}: the page's command is not the one the script runs"
        assert len(cells) >= 2, f"{tid}: no table under the command (run benchmarks/guide_tables.py --write)"


def _plan(command):
    args = _script().parse_command(command)
    scenes = selected_scenes(args.scene, args.all, args.t_end)
    assert len(scenes) == 1
    scene, system, y0 = prepare(next(iter(scenes.values())))
    methods = None
    if args.methods and args.methods.strip() != "all":
        methods = [m.strip() for m in args.methods.split(",")]
    plan = study_plan(system, scene, methods, quick=not args.full)
    return scene, system, y0, plan, args


@pytest.mark.parametrize(("table_id", "command", "cells"), BLOCKS, ids=[b[0] for b in BLOCKS])
def test_every_row_is_a_point_the_command_produces(table_id, command, cells):
    scene, system, y0, plan, args = _plan(command)
    T = scene.t_end - scene.t_start
    head, rows = cells[0], cells[1:]
    if head[0] == "method [back end]":  # the equal-cost table: one row per series
        series = {(e.method, v.name if e.family == "scipy" else None) for e in plan for v in e.variants}
        for row in rows:
            m = SERIES.match(row[0])
            assert m, row[0]
            assert (m.group("method"), m.group("variant")) in series, row[0]
        return
    col = {name: i for i, name in enumerate(head)}
    points = {(e.method, v.name, e.label(s, T)): (e, v, s) for e in plan for v in e.variants for s in e.settings}
    rerun = []
    for row in rows:
        key = (row[col["method"]], row[col["variant"]], row[col["step/tol"]])
        assert key in points, f"{table_id}: {key} is not produced by `{command}`"
        error = row[col["error"]]
        if float(row[col["CPU med [ms]"]]) <= 20 and not error.endswith("*") and float(error) >= 1e-7:
            rerun.append((points[key], row))
    # the cheap rows, re-run: the printed error (2 digits) and back end are what the command gives
    reference = reference_for(scene, system, y0)
    scale = state_scale(y0, reference.fields)
    for (entry, variant, setting), row in rerun[:12]:
        got = measure_point(
            scene, system, y0, entry, variant, setting, reference, scale, repeats=1, warm_up=False, backend=args.backend
        )
        shown = float(row[col["error"]])
        assert abs(got.error - shown) <= 0.06 * shown, (row, got.error)
        assert got.backend == row[col["back end"]].replace(" (fallback!)", ""), row
