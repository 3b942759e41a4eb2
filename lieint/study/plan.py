"""The plan of a study: which methods run on a scene, over which sweep, in which variants.

The plan is read from the method registry (:func:`lieint.methods.method_specs`): every
registered method whose :meth:`~lieint.methods.Method.check_system` accepts the scene's system
joins, whatever its family — a method added in one new module of :mod:`lieint.methods` appears
in ``lieint compare`` without any edit here. What a method is decides its sweep:

* fixed-step methods sweep the step ``h = 2^j h_scene`` around the scene's own step (``h`` =
  span / n with n the nearest whole number of steps; about ``GRID`` of them are saved);
* methods with their own step-size control (adaptive RKMK pairs, scipy's solvers) sweep the
  relative tolerance, with ``atol = rtol · ATOL_RATIO``, down to a tightest tolerance that
  depends on the order (``TIGHTEST_BY_ORDER``: low-order methods would take minutes there).

scipy's solvers run in two variants, both labelled: without projection ("plain") and with the
saved copies projected onto the manifold ("projected saves"; the solver's own state is never
touched, so its error control and its steps are those of the plain run). lieint's own methods
follow the scene's ``project`` flag.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..methods.registry import get_method, method_specs

__all__ = ["GRID", "PlanEntry", "Variant", "study_plan"]

#: saved points per run (fixed-step runs save every n // GRID steps, scipy's at GRID + 1 times):
#: the error is the largest over them
GRID = 100
#: step factors ``h / h_scene`` of fixed-step sweeps, coarse to fine
FIXED_FACTORS = (8.0, 4.0, 2.0, 1.0, 0.5, 0.25)
FIXED_FACTORS_QUICK = (4.0, 2.0, 1.0, 0.5)
#: low orders need more steps for the same error: their sweep is shifted finer by this factor
LOW_ORDER_SHIFT = {1: 0.25, 2: 0.5}
#: relative tolerances of methods with their own step-size control, loose to tight
TOLERANCES = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
TOLERANCES_QUICK = (1e-5, 1e-7, 1e-9, 1e-11)
#: the tightest tolerance of a low-order method (its steps grow like rtol^(-1/p): below these the
#: sweep costs minutes and says nothing new); variable-order methods stop at 1e-9
TIGHTEST_BY_ORDER = {1: 1e-5, 2: 1e-6, 3: 1e-7, 4: 1e-8, 5: 1e-9}
TIGHTEST_VARIABLE = 1e-9
ATOL_RATIO = 1e-2


@dataclass(frozen=True)
class Variant:
    """How a method is run: its label in tables and legends and whether it projects."""

    name: str
    project: bool


#: scipy's two honest baselines
SCIPY_VARIANTS = (Variant("plain", False), Variant("projected saves", True))


@dataclass(frozen=True)
class PlanEntry:
    """One method of a study and its sweep.

    Attributes
    ----------
    method : str
        The registry name.
    family : str
        Its family in the registry ("rkmk", "rk", "rkmk-embedded", "scipy", …).
    kind : {"fixed", "adaptive"}
        Swept over steps (``settings`` are step counts over the span) or over tolerances
        (``settings`` are relative tolerances).
    settings : tuple
        Coarse/loose to fine/tight.
    variants : tuple of Variant
    """

    method: str
    family: str
    kind: str
    settings: tuple
    variants: tuple[Variant, ...]

    def label(self, setting, span: float) -> str:
        """The setting as tables print it: ``h=0.01`` or ``rtol=1e-07``."""
        if self.kind == "fixed":
            return f"h={span / setting:.4g}"
        return f"rtol={setting:.0e}"


def fixed_steps(span: float, h_scene: float, order: int | None, quick: bool) -> tuple[int, ...]:
    """Step counts of a fixed-step sweep: ``n = round(span / (factor · h_scene))``."""
    shift = LOW_ORDER_SHIFT.get(order or 0, 1.0)
    counts = []
    for factor in FIXED_FACTORS_QUICK if quick else FIXED_FACTORS:
        n = max(1, round(span / (factor * shift * h_scene)))
        if n not in counts:
            counts.append(n)
    return tuple(counts)


def study_plan(system, scene, methods=None, *, quick: bool = True, skipped: dict | None = None) -> list[PlanEntry]:
    """The plan for ``scene`` (whose system is ``system``).

    Parameters
    ----------
    system : LieGroupSystem
        The scene's system (methods are asked whether they apply to it).
    scene : Scene
        Gives the span, the step around which fixed steps are swept, and ``project``.
    methods : None, "all" or list of str
        None and "all": every registered method that applies; else the names given, in the
        registry's order (a name that does not apply is an error, unless ``skipped`` is given).
    quick : bool
        The quick sweep (fewer points) of the main job, or the full one.
    skipped : dict, optional
        When given, a named method that does not apply is left out and recorded here
        (name → the method's reason) instead of raising — for studies over several scenes.

    Raises
    ------
    ValueError
        An unknown name or a method that cannot step this system, naming it.
    """
    specs = method_specs()
    if methods is None or (isinstance(methods, str) and methods == "all"):
        names, strict = list(specs), False
    else:
        methods = [methods] if isinstance(methods, str) else list(methods)
        unknown = [m for m in methods if m not in specs]
        if unknown:
            raise ValueError(f"`methods`: {unknown[0]!r} is not a method; choose from {list(specs)}")
        names, strict = [m for m in specs if m in methods], True
    span = scene.t_end - scene.t_start
    entries = []
    for name in names:
        spec = specs[name]
        try:
            get_method(name).check_system(system)
        except ValueError as exc:
            if strict and skipped is None:
                raise
            if strict:
                skipped[name] = str(exc)
            continue
        if spec.adaptive:
            tols = TOLERANCES_QUICK if quick else TOLERANCES
            tightest = TIGHTEST_BY_ORDER.get(spec.order, 0.0) if spec.order else TIGHTEST_VARIABLE
            tols = tuple(t for t in tols if t >= tightest)
            settings, kind = tols, "adaptive"
        else:
            settings, kind = fixed_steps(span, scene.step, spec.order, quick), "fixed"
        if spec.family == "scipy":
            variants = SCIPY_VARIANTS
        else:
            variants = (Variant("projected steps" if scene.project else "plain", bool(scene.project)),)
        entries.append(PlanEntry(name, spec.family, kind, settings, variants))
    return entries
