"""
Work–precision on the 3D top
============================

The default scene — an asymmetric top started near its unstable middle axis, T = 100 — with
fixed-step Lie-group and classical methods, adaptive RKMK pairs and scipy's DOP853 (plain, and
with its saved copies projected), each against the exact solution: the body momentum in Jacobi
elliptic functions and the attitude R from it, so the error covers the whole state. Each point is
timed after a warm-up (median CPU time of the timed calls, numba on one thread) and the legend
names the back end that ran it; the same fixed-step RKMK4 is also run on the generic numpy path
(``backend="numpy"``), the fair comparison for the adaptive pairs, which always run there.

What to conclude: at equal error the compiled fixed-step methods (RKMK4/RKMK6 and classical RK4
with projection) are the cheapest by an order of magnitude. On the same generic (numpy) path, the
adaptive pairs place their steps where the flips are and beat fixed-step RKMK4 at tight
tolerances, but not at loose ones, where their per-step cost dominates. RKMK6's error stops
falling near 1e-10: round-off, amplified near the separatrix (the compiled and the generic path
differ by as much), not the reference, whose floor is drawn. Only the Lie-group methods keep the
Casimirs at round-off whatever their error (see the table).
"""

import os
from dataclasses import replace

import matplotlib.pyplot as plt

from lieint.compare import default_scene
from lieint.study import format_rows, plot_work_precision, run_study

full = os.environ.get("LIEINT_FULL_EXAMPLES") == "1"
scene = replace(default_scene(), t_end=100.0 if full else 30.0)
repeats = 5 if full else 2
study = run_study(
    scene,
    quick=not full,
    repeats=repeats,
    methods=["rkmk4", "rkmk6", "rk4", "rkmk45", "rkmk853", "scipy:DOP853"],
)
# the same fixed-step RKMK4 on the generic path: a series of its own, "rkmk4 [numpy]"
generic = run_study(scene, quick=not full, repeats=repeats, methods=["rkmk4"], backend="numpy")
study.rows += generic.rows

fig = plot_work_precision(study)
print(study.describe())
print(format_rows(study))
plt.show()
