"""Tables of a study: the rows (text, Markdown, CSV, JSON) and the equal-cost table.

The equal-cost table answers "what error does each method reach for a given CPU budget": for
each series (method, variant, back end) and each budget B it shows the smallest error among the
points *measured* at a median CPU time ≤ B — no interpolation, no extrapolation ("—" when no
point of the series is that cheap). An error the reference cannot resolve is shown with ``*``.

Printed tables fit a 120-column terminal by default (:data:`NARROW_COLUMNS`: the series, the
setting, the back end, steps, median CPU time, the error and err/rtol, the invariants' drifts
and the notes of :mod:`.notes`); ``wide=True`` (``lieint compare --wide``) prints every column,
and Markdown and CSV are always wide.

Files: ``work_precision.csv`` (the metadata as ``# key: value`` comment lines, then one line per
point; ``pandas.read_csv(path, comment="#")`` reads it) and ``work_precision.json`` (metadata,
reference, rows and the equal-cost table).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict
from pathlib import Path

__all__ = [
    "BUDGETS_MS",
    "NARROW_COLUMNS",
    "WIDE_COLUMNS",
    "equal_cost",
    "format_equal_cost",
    "format_rows",
    "write_table",
]

#: CPU budgets of the equal-cost table, in milliseconds
BUDGETS_MS = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0, 30000.0)


def equal_cost(study, budgets_ms=BUDGETS_MS) -> dict:
    """``{"budgets_ms": [...], "series": {label: [error or None per budget]}, "resolved": {...}}``.

    Only budgets between the cheapest and the dearest point of the study are kept.
    """
    rows = [r for r in study.rows if math.isfinite(r.error)]
    if not rows:
        return {"budgets_ms": [], "series": {}, "resolved": {}}
    cheapest = min(r.cpu_median for r in rows) * 1e3
    dearest = max(r.cpu_median for r in rows) * 1e3
    budgets = [b for b in budgets_ms if cheapest <= b <= 3 * dearest]
    series = {}
    for row in rows:
        series.setdefault(row.series, []).append(row)
    table, flags = {}, {}
    for label, points in series.items():
        errors, marks = [], []
        for b in budgets:
            within = [p for p in points if p.cpu_median * 1e3 <= b]
            best = min(within, key=lambda p: p.error) if within else None
            errors.append(None if best is None else best.error)
            marks.append(None if best is None else best.resolved)
        table[label], flags[label] = errors, marks
    return {"budgets_ms": budgets, "series": table, "resolved": flags}


def _err(value, resolved) -> str:
    if value is None:
        return "—"
    return f"{value:.1e}" + ("" if resolved else "*")


def _short_series(label: str) -> str:
    """A series label for the narrow table: scipy's variants abbreviated, the back end (a column
    of the rows table) left out but for a fallback."""
    name, _, backend = label.partition(" [")
    name = name.replace("(projected saves)", "(proj.)")
    return name + (" (fallback!)" if "fallback" in backend else "")


def format_equal_cost(study, fmt: str = "table", wide: bool | None = None) -> str:
    """The equal-cost table as aligned text, Markdown or CSV (``wide``: full series labels;
    default: wide except for aligned text)."""
    wide = fmt != "table" if wide is None else wide
    ec = equal_cost(study)
    head = ["method [back end]" if wide else "method"] + [f"≤ {b:g} ms" for b in ec["budgets_ms"]]
    body = [
        [label if wide else _short_series(label)]
        + [_err(v, ok) for v, ok in zip(values, ec["resolved"][label], strict=True)]
        for label, values in ec["series"].items()
    ]
    return _render(head, body, fmt)


WIDE_COLUMNS = (
    ("method", "method", "{}"),
    ("variant", "variant", "{}"),
    ("setting", "step/tol", "{}"),
    ("backend", "back end", "{}"),
    ("steps", "steps", "{:d}"),
    ("nfev", "evals", "{:d}"),
    ("cpu_min", "CPU min [ms]", "ms"),
    ("cpu_median", "CPU med [ms]", "ms"),
    ("wall_min", "wall min [ms]", "ms"),
    ("wall_median", "wall med [ms]", "ms"),
    ("error", "error", "err"),
    ("energy_drift", "energy drift", "{:.1e}"),
    ("casimir_drift", "Casimir drift", "{:.1e}"),
    ("orthogonality", "‖RᵀR−I‖", "{:.1e}"),
)
_COLUMNS = WIDE_COLUMNS  # the name earlier code used

#: the columns of the printed table (fits 120 columns for every registered method)
NARROW_COLUMNS = (
    ("series", "method [variant]", "{}"),
    ("setting", "step/tol", "{}"),
    ("backend", "back end", "{}"),
    ("steps", "steps", "{:d}"),
    ("cpu_median", "CPU [ms]", "ms"),
    ("error", "error", "err"),
    ("err_per_rtol", "err/rtol", "ratio"),
    ("energy_drift", "energy", "{:.1e}"),
    ("casimir_drift", "Casimirs", "{:.1e}"),
    ("orthogonality", "‖RᵀR−I‖", "{:.1e}"),
    ("note", "note", "{}"),
)


def _narrow_value(row, key, notes):
    if key == "series":
        label = row.method if row.family != "scipy" else f"{row.method} ({'proj.' if row.projection else 'plain'})"
        return label
    if key == "err_per_rtol":
        ok = row.success and row.rtol and math.isfinite(row.error)
        return row.error / row.rtol if ok else float("nan")
    if key == "note":
        number = notes.get(row.series)
        return f"[{number}]" if number else ""
    return getattr(row, key)


def _cell(row, key, spec, notes=None) -> str:
    value = _narrow_value(row, key, notes or {}) if key in ("series", "err_per_rtol", "note") else getattr(row, key)
    if key == "backend" and row.fallback:
        return f"{value} (fallback!)" if notes is None else f"{value}!"
    if spec == "ratio":
        if not math.isfinite(value):
            return "—"
        return f"{value:.1e}" + ("" if row.resolved else "*")
    if spec == "ms":
        return f"{1e3 * value:.3g}" if math.isfinite(value) else "—"
    if spec == "err":
        return _err(value if math.isfinite(value) else None, row.resolved) if row.success else "failed"
    if isinstance(value, float) and not math.isfinite(value):
        return "—"
    return spec.format(value)


def format_rows(study, fmt: str = "table", wide: bool | None = None) -> str:
    """The rows as aligned text ("table"), Markdown, CSV or JSON (the JSON of :func:`as_dict`).

    ``wide``: every column (:data:`WIDE_COLUMNS`) or the narrow set (:data:`NARROW_COLUMNS`,
    with err/rtol and the notes of :func:`lieint.study.notes.rtol_notes`, ``!`` after a fallback's
    back end); default: narrow for aligned text, wide for Markdown and CSV.
    """
    if fmt == "json":
        return json.dumps(as_dict(study), indent=2, allow_nan=False)
    wide = fmt != "table" if wide is None else wide
    if wide:
        head = [title for _, title, _ in WIDE_COLUMNS]
        body = [[_cell(r, key, spec) for key, _, spec in WIDE_COLUMNS] for r in study.rows]
        return _render(head, body, fmt)
    from .notes import rtol_notes, series_note_numbers

    notes = series_note_numbers(rtol_notes(study))
    head = [title for _, title, _ in NARROW_COLUMNS]
    body = [[_cell(r, key, spec, notes) for key, _, spec in NARROW_COLUMNS] for r in study.rows]
    return _render(head, body, fmt)


def _render(head, body, fmt: str) -> str:
    if fmt == "csv":
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(head)
        writer.writerows(body)
        return buf.getvalue().rstrip("\n")
    if fmt == "markdown":
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        return "\n".join(lines + ["| " + " | ".join(c) + " |" for c in body])
    if fmt != "table":
        raise ValueError(f"`fmt` must be 'table', 'markdown', 'csv' or 'json'; got {fmt!r}.")
    widths = [max(len(head[i]), *(len(c[i]) for c in body)) if body else len(head[i]) for i in range(len(head))]

    def just(cells):  # names left, numbers right
        return "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        )

    line = just(head).rstrip()
    rows = [just(r).rstrip() for r in body]
    return "\n".join([line, "-" * len(line), *rows])


def _clean(value):
    """JSON-safe: non-finite floats become None."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def as_dict(study) -> dict:
    """The study as plain data: scene, metadata, reference, rows, equal-cost table."""
    return _clean(
        {
            "scene": study.scene.name,
            "metadata": study.metadata,
            "rows": [{**asdict(r), "series": r.series} for r in study.rows],
            "equal_cost": equal_cost(study),
        }
    )


def write_table(study, out_dir) -> tuple[Path, Path]:
    """Write ``work_precision.csv`` and ``work_precision.json`` into ``out_dir``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, json_path = out_dir / "work_precision.csv", out_dir / "work_precision.json"
    data = as_dict(study)
    fields = sorted({f for r in study.rows for f in r.field_errors})
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        fh.write(f"# scene: {study.scene.name}\n")
        for key, value in data["metadata"].items():
            fh.write(f"# {key}: {json.dumps(value)}\n")
        plain = [k for k in data["rows"][0] if k != "field_errors"] if data["rows"] else []
        writer = csv.DictWriter(fh, fieldnames=plain + [f"error[{f}]" for f in fields], lineterminator="\n")
        writer.writeheader()
        for row in data["rows"]:
            errs = row.pop("field_errors")
            writer.writerow({**row, **{f"error[{f}]": errs.get(f) for f in fields}})
    with open(json_path, "w", encoding="utf-8") as fh:
        json.dump(data, fh, indent=2, allow_nan=False)
    return csv_path, json_path
