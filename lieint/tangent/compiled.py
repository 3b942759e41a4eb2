"""The tangent map on the compiled engine, where a system's form has compiled tangent steps.

:mod:`lieint.tangent.flow` carries k tangent vectors as complex copies of the state (the complex
step) on the generic numpy path. Where the compiled engine has the derivative of the method's
step written out, the same steps run there instead: the complex copies are read as a real state
and its derivatives (``Im z / ε``), stepped together in forward mode, and written back as complex
copies. Both paths compute the derivative of the same discrete map, to round-off; the compiled one
costs about one step per tangent vector instead of a complex run each. Compiled tangent steps:

* the 3D Euler top (:mod:`lieint.fast.top3_tangent`): its RKMK methods in exponential coordinates
  (``lie_euler``, ``rkmk2/3/4/6``: dexp⁻¹ truncated), its commutator-free and Crouch–Grossman
  methods (``cf3``, ``cf4``, ``cg3``, ``cg4a``), its splittings into exact rotations
  (``splitting2/4/6``) and its Moser–Veselov maps (``moser_veselov``, ``moser_veselov_composed4/6``);
* the n-dimensional top, n ≥ 4 (:mod:`lieint.fast.topn_tangent`), the 3D heavy top
  (:mod:`lieint.fast.heavy3_tangent`), the 3D Chaplygin ball (:mod:`lieint.fast.chaplygin3_tangent`)
  and the 3D rolling ball with an offset centre of mass, gravity or an incline
  (:mod:`lieint.fast.rolling3_tangent`): their RKMK methods in exponential coordinates (and, on
  the 3D bodies, the commutator-free and Crouch–Grossman methods).

Every RKMK method's embedded pair (``rkmk23``, ``rkmk45``, ``rkmk853``; not the energy-keeping
ones) has its propagated solution's tangent steps there too: with its controller held fixed, a
pair's step is the RKMK step of its weights b. The steps may be a grid (h, a last step of its own)
or a schedule of any sizes (``steps``: an adaptive run's accepted steps), which the loop reads
step by step. Everything else — other systems and methods — runs on the generic path, and says so
(:func:`compiled_reason`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..control import Plan

__all__ = ["COMPILED_REASON", "CompiledLyapunov", "CompiledMegno", "CompiledTangent", "compiled_reason"]

#: what a result says when its tangent map ran on the compiled engine
COMPILED_REASON = (
    "compiled engine: the method's tangent steps in forward mode "
    "(lieint.fast.top3_tangent, topn_tangent, heavy3_tangent, chaplygin3_tangent, rolling3_tangent)"
)

#: the map families with compiled tangent steps on the 3D top (and RKMK: its forms are RKMKForm)
_FAMILIES = ("splitting", "moser_veselov")


@dataclass(frozen=True)
class _Steps(Plan):
    """A run's steps as the engine's loop reads them: equal steps h and a last one of its own size,
    or (``sizes``) a schedule of steps of any sizes — an adaptive run's accepted steps held fixed."""

    last: float = 0.0
    sizes: np.ndarray | None = None

    @property
    def last_step(self) -> float:
        return self.last


def compiled_reason(system, method) -> str:
    """Why the tangent map of ``method`` on ``system`` does not run compiled ("" when it does)."""
    from ..fast.forms import ExpProductForm, MapForm, RKMKForm, Top3Form

    form, entry = _declared(system)
    if entry is None:
        return (
            "compiled tangent steps exist for the Euler top in every dimension, the 3D heavy top, the 3D "
            "Chaplygin ball and the 3D rolling ball only"
        )
    body = None if isinstance(form, Top3Form) else entry[0]
    meth = method.compiled()
    if body is not None:
        what = f"{method.name!r} has no compiled tangent steps on the {body} (compiled: RKMK in exponential "
        what += "coordinates with truncated dexp⁻¹"
        what += ", the commutator-free and Crouch–Grossman methods)" if body in _PRODUCTS else ")"
    else:
        what = (
            f"{method.name!r} has no compiled tangent steps (compiled: RKMK in exponential coordinates with "
            "truncated dexp⁻¹, the commutator-free and Crouch–Grossman methods, the splittings into exact "
            "rotations and the Moser–Veselov maps of the 3D top)"
        )
    if isinstance(meth, RKMKForm):
        # an embedded pair steps its propagated solution (its controller held fixed): RKMK with the
        # pair's weights b; the energy-keeping pairs project onto the energy level (not RKMK)
        plain = meth.coordinates == "exp" and meth.degree is not None and not meth.keeps_energy
        return "" if plain else what
    if isinstance(meth, ExpProductForm):  # the commutator-free and Crouch–Grossman methods
        return "" if body is None or body in _PRODUCTS else what
    if body is not None or not isinstance(meth, MapForm) or meth.family not in _FAMILIES or not meth.covers(form):
        return what
    if meth.degree:
        return f"{method.name!r}: its modified moments depend on the state (no compiled tangent steps)"
    return ""


#: the forms with compiled tangent steps, by class name (the 3D top's and the n-D top's own, the
#: heavy top's and the balls' lanes form, :attr:`lieint.fast.forms.PiecesForm.lanes`): what a
#: message calls the body, and the prefix of its layouts' names in :mod:`lieint.fast.tangent_layouts`
#: (``<prefix>TangentLayout``, ``<prefix>MegnoLayout``, ``<prefix>LyapunovLayout``)
_FORMS = {
    "Top3Form": ("3D top", "Top3"),
    "TopNForm": ("n-dimensional top", "TopN"),
    "HeavyTop3Form": ("3D heavy top", "HeavyTop3"),
    "Chaplygin3Form": ("3D Chaplygin ball", "Chaplygin3"),
    "RollingBall3Form": ("3D rolling ball", "RollingBall3"),
}
#: the bodies besides the 3D top whose products of exponentials have compiled tangent steps too
_PRODUCTS = ("3D heavy top", "3D Chaplygin ball", "3D rolling ball")


def _declared(system):
    """``system``'s form with compiled tangent steps (its lanes form for compiled pieces) and its
    :data:`_FORMS` entry, or None for the entry when it has none."""
    form = system.compiled()
    form = getattr(form, "lanes", form)
    return form, _FORMS.get(type(form).__name__)


def _layouts(system):
    """The layouts of ``system``'s compiled tangent form: (tangent, MEGNO, Lyapunov) classes and the
    form they are built from."""
    from ..fast import tangent_layouts

    form, (_, prefix) = _declared(system)
    kinds = ("Tangent", "Megno", "Lyapunov")
    return form, tuple(getattr(tangent_layouts, f"{prefix}{kind}Layout") for kind in kinds)


def _grid(sizes: np.ndarray) -> _Steps:
    """The steps ``sizes`` as the engine's loop takes them: equal steps and a last of its own
    size as a grid, steps of other sizes as a schedule."""
    sizes = np.asarray(sizes, dtype=float)
    n = int(sizes.size)
    schedule = None if n == 1 or np.all(sizes[:-1] == sizes[0]) else np.ascontiguousarray(sizes)
    return _Steps(0.0, float(sizes.sum()), float(sizes[0]), n, float(sizes[-1]), schedule)


class _CompiledRun:
    """A layout of a 3D body with tangent vectors (:mod:`lieint.fast.tangent_layouts`) and its engine,
    for one method and a batch; :meth:`_steps` runs a grid of steps in one call of the loop."""

    def __init__(self, system, method, batch: tuple[int, ...], layout):
        from ..fast.engine import Engine

        self.batch, self.layout = tuple(batch), layout
        self.N = math.prod(self.batch)
        self.engine = Engine(layout, method.compiled(), self.batch, False, layout.module, system.group)

    def _steps(self, y: dict, dy: list[dict], steps: _Steps, saves: np.ndarray):
        """The final rows (N, d) and the user's fields of the rows saved after the steps ``saves``."""
        Y = np.ascontiguousarray(self.layout.pack(y, dy, self.N))
        new, rows = self.engine.advance({"Y": Y}, 0, steps.nsteps, steps, saves, False)
        return new["Y"], rows

    def _sums(self, y, dy, sizes, every: int, name: str):
        """The final state and the layout's sums ``name`` after every ``every``-th step and the
        last, with those steps' numbers (1-based)."""
        steps = _grid(sizes)
        saves = steps.saves_between(every, 0, steps.nsteps)
        Y, rows = self._steps(y, dy, steps, saves)
        final = self.layout.user(Y[None], self.batch)
        return {k: v[0] for k, v in final.items() if k != name}, rows[name], saves


class CompiledTangent(_CompiledRun):
    """The compiled tangent steps of one method on one top, 3D heavy top or 3D ball, for k vectors and a batch.

    Parameters
    ----------
    system : lieint.EulerTop, lieint.HeavyTop, lieint.ChaplyginBall or lieint.RollingBall
        An Euler top, a 3D heavy top, Chaplygin ball or rolling ball (:func:`compiled_reason` is "").
    method : Method
        One whose :func:`compiled_reason` is "" (RKMK in exponential coordinates, the
        splittings, the Moser–Veselov maps).
    k : int
        Tangent vectors per body.
    batch : tuple of int
        The bodies' batch shape.
    """

    def __init__(self, system, method, k: int, batch: tuple[int, ...]):
        form, (tangent, _, _) = _layouts(system)
        super().__init__(system, method, batch, tangent(form, k))

    def advance(self, y: dict, dy: list[dict], sizes: np.ndarray) -> tuple[dict, list[dict]]:
        """``y`` and its tangent vectors ``dy`` (k dicts of the fields' derivatives) after the
        steps ``sizes`` (equal ones with a last of its own size, or any schedule of sizes)."""
        steps = _grid(sizes)
        Y, _ = self._steps(y, dy, steps, np.empty(0, dtype=np.int64))
        return self.layout.unpack(Y, self.batch)


class CompiledMegno(_CompiledRun):
    """MEGNO's sums of one tangent vector carried by the compiled steps of one method on one 3D
    top (:func:`lieint.fast.tangent_sums.megno_update`): the whole run in one call of the loop,
    the sums saved every ``save_every`` steps.

    Parameters
    ----------
    system : lieint.EulerTop, lieint.HeavyTop, lieint.ChaplyginBall or lieint.RollingBall
        An Euler top, a 3D heavy top, Chaplygin ball or rolling ball (:func:`compiled_reason` is "").
    method : Method
        One whose :func:`compiled_reason` is "" (RKMK in exponential coordinates, the
        splittings, the Moser–Veselov maps).
    batch : tuple of int
        The bodies' batch shape.
    """

    def __init__(self, system, method, batch: tuple[int, ...]):
        form, (_, megno, _) = _layouts(system)
        super().__init__(system, method, batch, megno(form))

    def run(self, y: dict, dy: dict, sizes: np.ndarray, save_every: int):
        """The final state and the sums ``(elapsed, log|δ|, ∫ s dlog|δ|, ∫ Y dt, Y)`` (last axis)
        after the steps that a run saving every ``save_every``-th step and the last keeps,
        ``(m, *batch, 5)``, with those steps' numbers (1-based)."""
        return self._sums(y, [dy], sizes, save_every, "megno")


class CompiledLyapunov(_CompiledRun):
    """Benettin's sums of k tangent vectors carried by the compiled steps of one method on one 3D
    top, re-orthonormalised every ``every`` steps and after the last
    (:func:`lieint.fast.tangent_sums.lyapunov_update`), the whole run in one call of the loop.

    Parameters
    ----------
    system : lieint.EulerTop, lieint.HeavyTop, lieint.ChaplyginBall or lieint.RollingBall
        An Euler top, a 3D heavy top, Chaplygin ball or rolling ball (:func:`compiled_reason` is "").
    method : Method
        One whose :func:`compiled_reason` is "" (RKMK in exponential coordinates, the
        splittings, the Moser–Veselov maps).
    k : int
        Tangent vectors per body.
    batch : tuple of int
        The bodies' batch shape.
    every, total : int
        Steps between re-orthonormalisations, and the run's steps.
    """

    def __init__(self, system, method, k: int, batch: tuple[int, ...], every: int, total: int):
        form, (_, _, lyapunov) = _layouts(system)
        super().__init__(system, method, batch, lyapunov(form, k, every, total))

    def run(self, y: dict, dy: list[dict], sizes: np.ndarray, every: int):
        """The final state and the k sums of ``log |diag R|`` at every re-orthonormalisation,
        ``(m, *batch, k)``, with those steps' numbers (1-based)."""
        return self._sums(y, dy, sizes, every, "lyapunov")
