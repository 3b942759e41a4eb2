"""What a reader of a study needs told: the series whose global error is far above their rtol.

A tolerance bounds each step's local error, not the global error, so err/rtol of a few, even a
few tens, is ordinary. Far above that (``FAR_ABOVE``) the table and the figures carry a numbered
note that says why, so that a newcomer does not conclude the method is broken:

* the plain adaptive Lie pairs (``rkmk23``, ``rkmk45``, ``rkmk853``): a Lie-group step keeps the
  Casimir ``|A|`` exactly, so its energy error is a pure frequency error and the phase error grows
  like t² instead of t; near a separatrix (the default scene starts next to the top's unstable
  middle axis) the global error is several orders of magnitude above rtol (docs/theory.md §13).
  The ``+energy`` pairs keep the energy too and follow rtol on every built-in system;
* any other method: the global error also carries how the motion amplifies the local errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["FAR_ABOVE", "Note", "rtol_notes", "series_note_numbers"]

#: err/rtol from which a series gets a note
FAR_ABOVE = 100.0
#: a point whose error is this large has lost the motion's phase altogether (the error saturates
#: near 2‖y(0)‖): its err/rtol says nothing about the tolerance and is not counted
SATURATED = 1e-2

_LIE_PAIR = (
    "{names}: global error up to {worst:.0e} × rtol here. A Lie-group step keeps the Casimir |A| "
    "exactly, so its energy error is a pure frequency error and the phase error grows like t² instead "
    "of t; near a separatrix (the default scene starts next to the top's unstable middle axis) the "
    "plain pairs' global error is several orders of magnitude above rtol. The '+energy' pairs keep "
    "the energy as well and follow rtol on every built-in system: take rkmk853+energy for an answer "
    "to a tolerance (docs/theory.md §13)."
)
_OTHER = (
    "{names}: global error up to {worst:.0e} × rtol here. rtol bounds each step's local error; the "
    "global error also carries how the motion amplifies local errors (near a separatrix every flip "
    "magnifies a phase error)."
)


@dataclass(frozen=True)
class Note:
    """A numbered note: the series it explains and its text."""

    number: int
    series: tuple[str, ...]
    text: str


def _worst_ratio(rows) -> float:
    ratios = [
        r.error / r.rtol
        for r in rows
        # an unresolved error is only a bound; a saturated one says nothing about rtol
        if r.success and r.rtol and math.isfinite(r.error) and r.resolved and r.error < SATURATED
    ]
    return max(ratios, default=float("nan"))


def rtol_notes(study) -> list[Note]:
    """The notes of ``study``: one for the plain Lie pairs, one for any other series, each only
    when some series of that kind reaches err/rtol ≥ ``FAR_ABOVE``."""
    by_series: dict[str, list] = {}
    for row in study.rows:
        if row.rtol is not None:
            by_series.setdefault(row.series, []).append(row)
    groups: dict[str, list[tuple[str, float]]] = {"lie": [], "other": []}
    for label, rows in by_series.items():
        worst = _worst_ratio(rows)
        if math.isfinite(worst) and worst >= FAR_ABOVE:
            groups["lie" if rows[0].family == "rkmk-embedded" else "other"].append((label, worst))
    notes = []
    for kind, template in (("lie", _LIE_PAIR), ("other", _OTHER)):
        if groups[kind]:
            labels = tuple(label for label, _ in groups[kind])
            names = ", ".join(dict.fromkeys(label.split(" [")[0] for label in labels))
            worst = max(w for _, w in groups[kind])
            notes.append(Note(len(notes) + 1, labels, template.format(names=names, worst=worst)))
    return notes


def series_note_numbers(notes: list[Note]) -> dict[str, int]:
    """``{series label: note number}``."""
    return {label: note.number for note in notes for label in note.series}
