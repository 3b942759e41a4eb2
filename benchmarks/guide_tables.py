"""Regenerate the documentation's work–precision tables from real ``lieint compare`` runs.

Each table of ``docs/measurements/work_precision.md`` between ``<!-- study-table: ID -->`` and
``<!-- /study-table -->`` is printed by the command written next to it; this script runs each
command once (through the same code as the command line, :func:`lieint.compare.studies`), prints
every table with its command, and with ``--write`` puts them into that page.
``tests/project/test_guide_tables.py`` checks that every row shown can be produced by the command
printed next to it.

    OPENBLAS_NUM_THREADS=1 python benchmarks/guide_tables.py [--write]
"""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path

#: the page that holds the generated tables
PAGE = Path(__file__).resolve().parents[1] / "docs" / "measurements" / "work_precision.md"

#: (table id, command, what is shown: "rows" or "equal-cost")
TABLES = (
    ("default-rows", "lieint compare --methods lie_euler,rkmk2,rkmk4,rkmk6,rk4,scipy:DOP853 --repeats 5", "rows"),
    (
        "default-equal-cost",
        "lieint compare --methods lie_euler,rkmk2,rkmk4,rkmk6,rk4,scipy:DOP853 --repeats 5",
        "equal-cost",
    ),
    ("incline-rows", "lieint compare incline_ball --methods rkmk4,rk4,rkmk853,scipy:DOP853 --repeats 5", "rows"),
)

BLOCK = re.compile(r"<!-- study-table: (?P<id>[\w-]+) -->\n.*?<!-- /study-table -->", re.S)


def parse_command(command: str):
    """The parsed arguments of a ``lieint compare ...`` command line."""
    from lieint.cli import _build_parser

    words = shlex.split(command)
    if words[:2] != ["lieint", "compare"]:
        raise ValueError(f"not a `lieint compare` command: {command!r}")
    return _build_parser().parse_args(words[1:])


def render(table_id: str, command: str, kind: str, study) -> str:
    """The page's block of one table."""
    from lieint.study import format_equal_cost, format_rows

    meta = study.metadata
    machine = meta["machine"]
    body = format_rows(study, "markdown") if kind == "rows" else format_equal_cost(study, "markdown")
    what = "error reached within a CPU budget (ms)" if kind == "equal-cost" else "every point of the sweep"
    return (
        f"<!-- study-table: {table_id} -->\n"
        f"`{command}` — {what}; {study.scene.name}, T = {study.span:g}, against {study.reference.kind}; "
        f"one run on {machine['processor']} ({machine['cpu_count']} CPUs, load average {machine['load_average']}), "
        f"numba threads {meta['numba_threads']}, "
        f"{machine['date'][:10]}; `*`: below 10× the reference's floor.\n\n"
        f"{body}\n"
        "<!-- /study-table -->"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"replace the tables in {PAGE}")
    opts = parser.parse_args()
    from lieint.compare import studies

    results: dict[str, object] = {}
    blocks = {}
    for table_id, command, kind in TABLES:
        if command not in results:
            (_, study), *more = list(studies(parse_command(command)))
            if more:
                raise ValueError(f"the tables' commands study one scene each: {command!r}")
            results[command] = study
        blocks[table_id] = render(table_id, command, kind, results[command])
        print(blocks[table_id], end="\n\n")
    if opts.write:
        text = PAGE.read_text(encoding="utf-8")
        missing = set(blocks) - {m.group("id") for m in BLOCK.finditer(text)}
        if missing:
            raise SystemExit(f"{PAGE} has no block for {sorted(missing)}")
        PAGE.write_text(BLOCK.sub(lambda m: blocks[m.group("id")], text), encoding="utf-8")
        print(f"wrote {len(blocks)} tables into {PAGE}")


if __name__ == "__main__":
    main()
