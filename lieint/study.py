"""Work–precision studies: what accuracy costs in time, per method, on one scene.

For each method of the registry that applies to the scene's system (:func:`lieint.method_names`;
a method added in one file joins the study without any edit here) the study sweeps the step
size (fixed-step methods) or the tolerance (adaptive methods: the RKMK pairs and scipy's
``solve_ivp`` solvers, the latter with and without projection of the saved copies; and the
peer library lielab on the 3D top when it is installed), and measures

* the global error — ``max_t ‖y(t) − y_ref(t)‖ / ‖y(0)‖`` on the scene's main field — against
  the exact solution where one exists (the 3D Euler top: Jacobi elliptic functions; the uniform
  ball on an incline: ``(n+2)/(n+4) g sin θ``), else against a DOP853 solution at rtol 1e-13;
* the CPU time, the median of repeats timed in one run;
* the invariants' largest relative drifts.

It writes the table (CSV and JSON), the work–precision plot (error against CPU time, log–log,
one line per method) and the drift of the invariants against time over a long run.
"""

from __future__ import annotations

import csv
import json
import statistics
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from .ivp import integrate
from .methods.registry import get_method, method_specs
from .scenes import Scene, build_system
from .systems import EulerTop, RollingBall

__all__ = [
    "DEFAULT_METHODS",
    "StudyRow",
    "plot_long_run",
    "plot_work_precision",
    "reference_for",
    "run_study",
    "study_plan",
    "write_table",
]

#: the methods of the quick study (the README's main job); ``methods="all"`` runs every method
DEFAULT_METHODS = (
    "rkmk4",
    "rkmk6",
    "rk4",
    "rkmk45",
    "rkmk853",
    "scipy:RK45",
    "scipy:DOP853",
    "scipy:Radau",
    "scipy:LSODA",
)
#: steps over the span, by order of the method (fixed-step sweeps)
STEPS_BY_ORDER = {1: (2000, 8000, 32000), 2: (1000, 4000, 16000), 3: (500, 2000, 8000)}
STEPS_DEFAULT = (250, 500, 1000, 2000, 4000, 8000)
TOLERANCES = (1e-5, 1e-7, 1e-9, 1e-11)
#: scipy's implicit and variable-order solvers are slow at tight tolerances: stop at 1e-9
TOLERANCES_IMPLICIT = (1e-5, 1e-7, 1e-9)
_IMPLICIT = {"scipy:Radau", "scipy:BDF", "scipy:LSODA"}


def study_plan(system, methods=None) -> dict[str, tuple]:
    """method → its sweep (step counts of fixed-step methods, tolerances of adaptive ones), for
    the registered methods that apply to ``system``: ``DEFAULT_METHODS``, every method
    (``"all"``), or the names given."""
    specs = method_specs()
    if methods is None:
        names = [m for m in DEFAULT_METHODS if m in specs]
    elif methods == "all":
        names = list(specs)
    else:
        unknown = [m for m in methods if m not in specs and m != "lielab"]
        if unknown:
            raise ValueError(f"`methods`: {unknown[0]!r} is not a method; choose from {list(specs)} or 'lielab'")
        names = [m for m in methods if m != "lielab"]
    plan = {}
    for name in names:
        spec = specs[name]
        try:
            get_method(name).check_system(system)
        except ValueError:
            if methods not in (None, "all"):
                raise
            continue
        if spec.adaptive:
            plan[name] = TOLERANCES_IMPLICIT if name in _IMPLICIT else TOLERANCES
        else:
            plan[name] = STEPS_BY_ORDER.get(spec.order, STEPS_DEFAULT)
    return plan


@dataclass
class StudyRow:
    """One run of the sweep."""

    method: str
    setting: str  # "h=…" or "rtol=…"
    projection: bool
    steps: int
    nfev: int
    cpu_time: float
    error: float
    energy_drift: float
    casimir_drift: float
    orthogonality: float


def reference_for(scene: Scene, system, y0):
    """``(field, ref(t) → array, kind)``: the truth the errors are measured against."""
    if isinstance(system, EulerTop) and system.n == 3:
        return "A", (lambda t: system.exact_solution(t, y0)["A"]), "exact (Jacobi elliptic)"
    if (
        isinstance(system, RollingBall)
        and scene.gravity is not None
        and np.allclose(system.B_C, system.B_C[0, 0] * np.eye(system.n))
        and not np.any(system.center_of_mass)
        and "center" in system.fields
        and not np.any(y0["Omega"])
    ):
        n, lam, M, r = system.n, system.B_C[0, 0], system.mass, system.radius
        g_t = scene.gravity - (scene.gravity @ system.normal) * system.normal
        accel = g_t * M * r * r / (M * r * r + 2 * lam)  # MATH.md §4, from rest
        return (
            "center",
            (lambda t: y0["center"] + 0.5 * np.multiply.outer(t - scene.t_start, accel)),
            (f"exact ((n+2)/(n+4) g sin θ, n = {n})"),
        )
    field = next(iter(system.fields))
    ref = integrate(
        system,
        y0,
        (scene.t_start, scene.t_end),
        method="scipy:DOP853",
        rtol=1e-13,
        atol=1e-15,
        t_eval=np.linspace(scene.t_start, scene.t_end, 2001),
    )
    from scipy.interpolate import CubicSpline

    spline = CubicSpline(ref.t, ref.states[field], axis=0)
    return field, spline, "DOP853 at rtol 1e-13 (interpolated)"


def _time(fn, repeats):
    times, result = [], None
    for _ in range(repeats):
        t0 = time.process_time()
        result = fn()
        times.append(time.process_time() - t0)
    return statistics.median(times), result


def _row(method, setting, projection, sol, cpu, field, ref, scale) -> StudyRow:
    err = float(np.max(np.linalg.norm((sol.states[field] - ref(sol.t)).reshape(sol.t.size, -1), axis=1)) / scale)
    inv = sol.invariants
    return StudyRow(
        method=method,
        setting=setting,
        projection=projection,
        steps=int(sol.nsteps),
        nfev=int(sol.nfev),
        cpu_time=cpu,
        error=err,
        energy_drift=float(np.max(sol.drift("energy"))) if "energy" in inv else float("nan"),
        casimir_drift=float(np.max(sol.drift("casimirs"))) if "casimirs" in inv else float("nan"),
        orthogonality=float(np.max(inv["orthogonality"][-1])) if "orthogonality" in inv else float("nan"),
    )


def lielab_top3(system, y0, span):
    """A runner for the peer library lielab (optional extra ``lieint[bench]``) on the 3D top:
    its default adaptive Munthe-Kaas flow on SO(3) × R³ with the body angular velocity; returns
    ``run(rtol) → (t, A(t), nfev)`` or None when lielab is not installed."""
    try:
        from lielab.domain import RN, SO, CompositeAlgebra, CompositeManifold, rn, so
        from lielab.integrate import HomogeneousIVPSystem, IVPOptions
        from lielab.integrate import solve_ivp as lielab_solve
    except ImportError:
        return None
    from .groups.bivectors import hat, vee

    P = system.P if np.linalg.det(system.P) > 0 else system.P * np.array([1.0, 1.0, -1.0])
    moments = system.principal_moments
    w0 = vee(system.angular_velocity(P.T @ y0["A"] @ P))

    def generator(t, y):
        w = np.asarray(y[1].serialize())
        return CompositeAlgebra([so.from_vector(w), rn.from_vector(np.cross(moments * w, w) / moments)])

    dynamics = HomogeneousIVPSystem(generator)
    start = CompositeManifold([SO(3), RN.from_vector(w0)])

    def run(rtol):
        opts = IVPOptions()
        opts.reltol, opts.abstol = rtol, rtol * 1e-2
        sol = lielab_solve(dynamics, list(span), start, opts)
        w = np.asarray(sol.ybar)[:, -3:]
        A = P @ (-hat(moments * w)) @ P.T
        return np.asarray(sol.t), A, len(sol.t)

    return run


def run_study(scene: Scene, *, quick: bool = True, repeats: int = 3, methods=None, progress=None):
    """Sweep the methods (``DEFAULT_METHODS``, ``"all"`` or the names given) on the scene;
    returns ``(rows, reference kind)``."""
    scene = replace(scene, outputs=tuple(dict.fromkeys((*scene.outputs, "orientation"))))
    system, y0 = build_system(scene)
    field, ref, kind = reference_for(scene, system, y0)
    scale = float(np.linalg.norm(y0[field])) or 1.0
    span = (scene.t_start, scene.t_end)
    T = scene.t_end - scene.t_start
    rows = []
    plan = study_plan(system, methods)
    specs = method_specs()
    for method, settings in plan.items():
        if quick:
            settings = settings[::2] if len(settings) > 3 else settings
        spec = specs[method]
        for value in settings:
            projections = (False, True) if spec.family == "scipy" else (True,)
            for proj in projections:
                if not spec.adaptive:
                    n = int(value)
                    save = max(1, n // 100)

                    def fn(n=n, save=save, proj=proj, method=method):
                        return integrate(system, y0, span, h=T / n, method=method, project=proj, save_every=save)

                    setting = f"h={T / n:.3g}"
                elif spec.family != "scipy":

                    def fn(tol=value, proj=proj, method=method):
                        return integrate(
                            system, y0, span, method=method, rtol=tol, atol=tol * 1e-2, project=proj, save_every=5
                        )

                    setting = f"rtol={value:.0e}"
                else:

                    def fn(tol=value, proj=proj, method=method):
                        return integrate(
                            system,
                            y0,
                            span,
                            method=method,
                            rtol=tol,
                            atol=tol * 1e-2,
                            project=proj,
                            t_eval=np.linspace(*span, 101),
                        )

                    setting = f"rtol={value:.0e}"
                fn()  # warm-up (compilation, caches)
                cpu, sol = _time(fn, repeats)
                rows.append(_row(method, setting, proj, sol, cpu, field, ref, scale))
                if progress:
                    progress(rows[-1])
    if (methods is None or "lielab" in methods) and isinstance(system, EulerTop) and system.n == 3:
        lielab = lielab_top3(system, y0, span)
        for tol in (TOLERANCES[::2] if quick else TOLERANCES) if lielab else ():
            lielab(tol)
            cpu, (t, A, steps) = _time(lambda tol=tol: lielab(tol), repeats)
            err = float(np.max(np.linalg.norm((A - ref(t)).reshape(t.size, -1), axis=1)) / scale)
            rows.append(
                StudyRow(
                    "lielab", f"rtol={tol:.0e}", False, steps, 0, cpu, err, float("nan"), float("nan"), float("nan")
                )
            )
    return rows, kind


def write_table(rows, out_dir: Path) -> tuple[Path, Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, json_path = out_dir / "work_precision.csv", out_dir / "work_precision.json"
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(asdict(rows[0])))
        writer.writeheader()
        writer.writerows(asdict(r) for r in rows)
    with open(json_path, "w", encoding="utf-8") as fh:
        json.dump(
            [
                {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in asdict(r).items()}
                for r in rows
            ],
            fh,
            indent=2,
        )
    return csv_path, json_path


def plot_work_precision(rows, path: Path, title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    colors = plt.get_cmap("tab20").colors
    groups: dict[str, list[StudyRow]] = {}
    for r in rows:
        label = r.method + (" + projected saves" if r.projection and r.method.startswith("scipy:") else "")
        groups.setdefault(label, []).append(r)
    for i, (label, rs) in enumerate(groups.items()):
        # in sweep order (coarse to fine), so each line runs from cheap and rough to dear and exact
        style = "-o" if not label.startswith(("scipy:", "lielab")) else "--s"
        if rs[0].method != "lielab" and not rs[0].method.startswith("scipy:") and get_method(rs[0].method).adaptive:
            style = "-^"
        ax.loglog(
            [r.cpu_time for r in rs],
            [max(r.error, 1e-16) for r in rs],
            style,
            ms=4,
            label=label,
            color=colors[(2 * i) % 20 if i < 10 else (2 * i + 1) % 20],
        )
    ax.set_xlabel("CPU time [s] (median of repeats)")
    ax.set_ylabel("global error  max_t |y − y_ref| / |y0|")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_long_run(scene: Scene, path: Path, factor: float = 10.0, h: float | None = None) -> Path:
    """Energy and Casimir drift against time over ``factor`` × the scene's span: RKMK4 against
    classical RK4 at the same step (default: the scene's step) and DOP853 at rtol 1e-9."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = scene.step if h is None else h
    system, y0 = build_system(replace(scene, outputs=tuple(dict.fromkeys((*scene.outputs, "energy")))))
    span = (scene.t_start, scene.t_start + factor * (scene.t_end - scene.t_start))
    T = span[1] - span[0]
    runs = {
        f"rkmk4, h = {h:g}": integrate(system, y0, span, h=h, method="rkmk4", save_every=max(1, int(T / h) // 500)),
        f"rk4, h = {h:g}": integrate(system, y0, span, h=h, method="rk4", save_every=max(1, int(T / h) // 500)),
        "DOP853, rtol 1e-9": integrate(
            system, y0, span, method="scipy:DOP853", rtol=1e-9, atol=1e-11, t_eval=np.linspace(*span, 501)
        ),
    }
    names = [n for n in ("energy", "casimirs") if n in system.invariants]
    fig, axes = plt.subplots(1, len(names), figsize=(6 * len(names), 4.2))
    axes = np.atleast_1d(axes)
    for ax, name in zip(axes, names, strict=True):
        for label, sol in runs.items():
            v = sol.invariants[name].reshape(sol.t.size, -1)
            d = np.linalg.norm(v - v[0], axis=1) / max(np.linalg.norm(v[0]), 1e-300)
            keep = sol.t > sol.t[0]
            ax.loglog(sol.t[keep] - sol.t[0], np.maximum(d[keep], 1e-17), label=label)
        ax.set_xlabel("t")
        ax.set_ylabel(f"relative {name} error")
        ax.set_title(f"{name} over a long run")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
