"""lieint's long-time methods against the reference Fortran codes, side by side in one run.

Run: ``LIEINT_REFERENCE_CODES=DIR OPENBLAS_NUM_THREADS=1 python benchmarks/reference_codes.py``
(``--codes DIR`` instead of the variable; ``--hog`` times a second time while another
CPU-bound process runs; ``--quick`` for a smoke run; ``--markdown PATH`` also writes the tables
as a Markdown page). A few minutes; every method timed runs on lieint's compiled engine
(``exact_flow``'s one-shot steps of item 3, |λh| > 1, on the numpy path's closed form).

DIR holds copies of two public codes, which are compiled here and never copied into lieint:

* ``dmv10.f`` (or ``DMV10.FI``): E. Hairer and G. Vilmart, the preprocessed discrete
  Moser–Veselov algorithm, subroutines DMV2, DMV4, DMV6, DMV8, DMV10 (J. Phys. A 39 (2006)
  13225–13235; from Hairer's software page, https://www.unige.ch/~hairer/software.html);
* ``frb_step.f``: E. Celledoni, F. Fassò, N. Säfström and A. Zanna, the exact free rigid body
  step FRB_STEP (ACM TOMS Algorithm 903, https://calgo.acm.org/, file
  ``0903/Original-Submission/Fortran77/Src/frb_step.f``).

gfortran (``apt-get install gfortran``) compiles both with a small driver written here
(:data:`DRIVER`: the step loops, a zero potential for DMV, FRB_STEP's unit-momentum scaling) at
``-O2`` into a shared library in a temporary directory, called through ``ctypes``. (numpy's
f2py would do too, but needs meson; a ctypes call costs about a microsecond, and every timing
below is of a loop inside the Fortran, its call overhead subtracted.) Without gfortran or the
codes the script says what is missing and exits with status 0.

Conventions. DMV's state is the body momentum Π and a quaternion (scalar first) of the attitude,
moved by right multiplication in the body frame; FRB_STEP's is Π (``|Π| = 1``, moments
``I₁ < I₂ < I₃``) and the attitude matrix. Both are lieint's ``(A, R)`` with ``A = −Π̂`` in the
principal frame. The lieint side always calls the public API (``lieint.integrate``), so the same
script measures whatever form of the steps lieint has.

1. Agreement: lieint's ``moser_veselov``, ``moser_veselov4/6/8/10`` against DMV2/4/6/8/10 and
   ``exact_flow`` against FRB_STEP, 10⁴ steps of h = 0.01 on three motions (max over Π and R
   of ``max|lieint − Fortran|``, Π relative to |Π|), and the one-shot ``exact_solution`` against
   FRB_STEP stepped.
2. Hairer–Vilmart's Figure 1 set-up: body (0.6, 0.8, 1.0), Π₀ = (1.8, 0.4, −0.9), R₀ = Id
   (the authors' example driver), h = 0.1, T = 10: each method's error against the exact
   solution (``EulerTop.exact_solution``), and lieint's over the Fortran's.
3. Round-off growth of the exact steps: stepped ``exact_flow`` and stepped FRB_STEP (h = 0.1
   and 1, T = 1000) against each one's own one-shot solution (one step of T), and the relative
   energy error at T, on the flat body (1, 2, 3) and Hairer–Vilmart's (0.6, 0.8, 1.0): medians
   over six starts, the body's Π₀ and five within 10⁻³ of it (one run is one draw of a random
   walk of roundings).
4. CPU time per step, one thread: the marginal cost of a step in a call of N steps (the least
   over interleaved rounds of ``(t(N) − t(N/10)) / 0.9N``), lieint for one body and per body of a
   batch of 200, the Fortran for one body (a loop of single-body steps); ratios lieint / Fortran,
   and which of lieint's paths ran (``compiled``: the compiled engine; ``numpy``: the generic
   path, for a method the engine does not cover on the 3D top).
"""

from __future__ import annotations

import argparse
import ctypes
import os
import shutil
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from functools import partial
from pathlib import Path

import numpy as np

import lieint
from lieint.groups.bivectors import hat, vee

#: where the script looks for the codes when ``--codes`` is not given
ENV = "LIEINT_REFERENCE_CODES"

#: accepted file names (compared case-insensitively)
DMV_NAMES = ("dmv10.f", "dmv10.fi", "dmv10.for")
FRB_NAMES = ("frb_step.f", "frb_step.for")

#: the driver compiled with the codes (written for this benchmark; Fortran 77 like the codes)
DRIVER = """\
C     Step loops around the reference codes for lieint's benchmark.
C     LXDMV: NSTEP steps of DMV<IORD> with no potential (RPAR(11..13): the moments).
      SUBROUTINE LXDMV(IORD,AM,Q,H,NSTEP,AI)
      IMPLICIT NONE
      INTEGER IORD,NSTEP,I,IPAR(20)
      DOUBLE PRECISION AM(3),Q(4),H,AI(3),RPAR(20)
      EXTERNAL LXZERO
      DO I=1,20
        RPAR(I)=0.0D0
        IPAR(I)=0
      END DO
      DO I=1,3
        RPAR(10+I)=AI(I)
      END DO
      IF (IORD.EQ.2) CALL DMV2(AM,Q,LXZERO,H,NSTEP,RPAR,IPAR)
      IF (IORD.EQ.4) CALL DMV4(AM,Q,LXZERO,H,NSTEP,RPAR,IPAR)
      IF (IORD.EQ.6) CALL DMV6(AM,Q,LXZERO,H,NSTEP,RPAR,IPAR)
      IF (IORD.EQ.8) CALL DMV8(AM,Q,LXZERO,H,NSTEP,RPAR,IPAR)
      IF (IORD.EQ.10) CALL DMV10(AM,Q,LXZERO,H,NSTEP,RPAR,IPAR)
      END
C     The free body: no potential.
      SUBROUTINE LXZERO(Q,POTP,RPAR,IPAR)
      IMPLICIT NONE
      DOUBLE PRECISION Q(4),POTP(3),RPAR(*)
      INTEGER IPAR(*)
      POTP(1)=0.0D0
      POTP(2)=0.0D0
      POTP(3)=0.0D0
      END
C     LXFRB: NSTEP steps of FRB_STEP. It takes |PI| = 1: the momentum is scaled to unit
C     norm once and the step by |PI| (the free body's equations are homogeneous).
      SUBROUTINE LXFRB(PI,Q,H,AI,NSTEP,NP)
      IMPLICIT NONE
      INTEGER NSTEP,NP,I,J,K
      DOUBLE PRECISION PI(3),Q(3,3),H,AI(3),G,PIN(3),POUT(3),QOUT(3,3)
      G=SQRT(PI(1)**2+PI(2)**2+PI(3)**2)
      DO I=1,3
        PIN(I)=PI(I)/G
      END DO
      DO K=1,NSTEP
        CALL FRB_STEP(POUT,QOUT,H*G,AI,PIN,Q,NP)
        DO I=1,3
          PIN(I)=POUT(I)
          DO J=1,3
            Q(I,J)=QOUT(I,J)
          END DO
        END DO
      END DO
      DO I=1,3
        PI(I)=PIN(I)*G
      END DO
      END
"""


class ReferenceCodesUnavailable(RuntimeError):
    """No compiler, or no copy of the codes where the user pointed (the message says which)."""


def locate(directory: str | os.PathLike | None = None) -> tuple[Path, Path]:
    """The two source files in ``directory`` (default: ``$LIEINT_REFERENCE_CODES``)."""
    given = directory if directory is not None else os.environ.get(ENV)
    if not given:
        raise ReferenceCodesUnavailable(
            f"no copy of the reference codes: set {ENV}=DIR or pass --codes DIR, DIR holding Hairer–Vilmart's "
            "dmv10.f (https://www.unige.ch/~hairer/software.html) and TOMS 903's frb_step.f (https://calgo.acm.org/)."
        )
    root = Path(given).expanduser()
    if not root.is_dir():
        raise ReferenceCodesUnavailable(f"{ENV} / --codes: {str(root)!r} is not a directory.")
    files = {p.name.lower(): p for p in root.iterdir() if p.is_file()}
    found = []
    for names, what in ((DMV_NAMES, "Hairer–Vilmart's dmv10.f"), (FRB_NAMES, "TOMS 903's frb_step.f")):
        match = next((files[n] for n in names if n in files), None)
        if match is None:
            raise ReferenceCodesUnavailable(f"{str(root)!r} holds no {what} (looked for {', '.join(names)}).")
        found.append(match)
    return found[0], found[1]


def compiler() -> str:
    path = shutil.which(os.environ.get("FC", "gfortran"))
    if path is None:
        raise ReferenceCodesUnavailable(
            "no Fortran compiler: install gfortran (Debian/Ubuntu: apt-get install gfortran) or set FC."
        )
    return path


class ReferenceCodes:
    """The compiled codes (see :func:`reference_codes`): DMV2 … DMV10 and FRB_STEP, with lieint's states."""

    def __init__(self, library: Path):
        self._lib = ctypes.CDLL(str(library))
        self._dmv, self._frb = self._lib.lxdmv_, self._lib.lxfrb_
        self._dmv.restype = self._frb.restype = None

    @staticmethod
    def _ptr(a: np.ndarray):
        return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

    def dmv(self, order: int, moments, Pi, quaternion, h: float, nsteps: int):
        """``nsteps`` steps of DMV<order>: ``(Π, q)`` after them (``q`` scalar first)."""
        if order not in (2, 4, 6, 8, 10):
            raise ValueError(f"`order` must be 2, 4, 6, 8 or 10; got {order!r}.")
        am = np.array(Pi, dtype=float)
        q = np.array(quaternion, dtype=float)
        ai = np.array(moments, dtype=float)
        self._dmv(
            ctypes.byref(ctypes.c_int(order)), self._ptr(am), self._ptr(q), ctypes.byref(ctypes.c_double(h)),
            ctypes.byref(ctypes.c_int(nsteps)), self._ptr(ai),
        )  # fmt: skip
        return am, q

    def frb(self, moments, Pi, R, h: float, nsteps: int, quadrature: int = 0):
        """``nsteps`` steps of FRB_STEP (exact elliptic integrals for ``quadrature = 0``): ``(Π, R)``."""
        ai = np.array(moments, dtype=float)
        if not (ai[0] < ai[1] < ai[2]):
            raise ValueError(f"FRB_STEP needs I₁ < I₂ < I₃; got {ai}.")
        p = np.array(Pi, dtype=float)
        Q = np.asfortranarray(np.array(R, dtype=float))
        self._frb(
            self._ptr(p), self._ptr(Q), ctypes.byref(ctypes.c_double(h)), self._ptr(ai),
            ctypes.byref(ctypes.c_int(nsteps)), ctypes.byref(ctypes.c_int(quadrature)),
        )  # fmt: skip
        return p, np.ascontiguousarray(Q)


@contextmanager
def reference_codes(directory=None):
    """Compile the codes with :data:`DRIVER` in a temporary directory; yield a :class:`ReferenceCodes`.

    Raises :class:`ReferenceCodesUnavailable` naming what is missing (the compiler or the files).
    """
    fc = compiler()
    dmv, frb = locate(directory)
    with tempfile.TemporaryDirectory(prefix="lieint-reference-") as tmp:
        tmp = Path(tmp)
        (tmp / "driver.f").write_text(DRIVER)
        library = tmp / "libreference.so"
        # -x f77: the sources are compiled where they are, whatever their extension (DMV10.FI)
        cmd = [fc, "-O2", "-fPIC", "-shared", "-std=legacy", "-o", str(library), "-x", "f77", str(tmp / "driver.f"),
               str(dmv), str(frb)]  # fmt: skip
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            raise ReferenceCodesUnavailable(f"compiling the reference codes failed:\n{run.stderr[-2000:]}")
        yield ReferenceCodes(library)


# -- lieint's states and the Fortran's --------------------------------------------------------


def quaternion_to_rotation(q) -> np.ndarray:
    """The rotation matrix of a unit quaternion ``(w, x, y, z)``."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(np.asarray(q, dtype=float), scalar_first=True).as_matrix()


def rotation_to_quaternion(R) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(np.asarray(R, dtype=float)).as_quat(scalar_first=True)


def state(Pi, R=None) -> dict:
    """lieint's state of the diagonal top: ``A = −Π̂``, R (default the identity)."""
    Pi = np.asarray(Pi, dtype=float)
    return {"A": -hat(Pi), "R": np.eye(3) if R is None else np.asarray(R, dtype=float)}


def momentum(y) -> np.ndarray:
    return -vee(y["A"])


#: (lieint method, DMV order)
MV_PAIRS = (("moser_veselov", 2), ("moser_veselov4", 4), ("moser_veselov6", 6), ("moser_veselov8", 8),
            ("moser_veselov10", 10))  # fmt: skip

#: Hairer & Vilmart (2006), Figure 1: the body and initial data of the authors' example driver
HV_MOMENTS = (0.6, 0.8, 1.0)
HV_PI0 = (1.8, 0.4, -0.9)


def near_separatrix(moments, G: float, delta: float) -> np.ndarray:
    """Π with ``|Π| = G`` and ``2H I₂ / G² = 1 + δ`` (relative energy distance δ from the separatrix), Π₂ = 0."""
    I1, I2, I3 = moments
    # 2H/G² = cos²a/I₁ + sin²a/I₃ = (1 + δ)/I₂
    c2 = ((1 + delta) / I2 - 1 / I3) / (1 / I1 - 1 / I3)
    return G * np.array([np.sqrt(c2), 0.0, np.sqrt(1 - c2)])


def motions():
    """(label, moments, Π₀) of the agreement runs."""
    return [
        ("HV body (0.6, 0.8, 1), Figure 1 data", HV_MOMENTS, np.array(HV_PI0)),
        ("flat body (1, 2, 3), w0 = (0.3, 1, 0.4)", (1.0, 2.0, 3.0), np.array([0.3, 2.0, 1.2])),
        ("HV body, 1e-6 from the separatrix", HV_MOMENTS, near_separatrix(HV_MOMENTS, 2.0, 1e-6)),
    ]


def run_lieint(name: str, moments, y0, h: float, nsteps: int) -> dict:
    top = lieint.EulerTop.from_principal_moments(moments)
    sol = lieint.integrate(top, y0, (0.0, nsteps * h), h=h, method=name, save_every=nsteps)
    return {k: v[-1] for k, v in sol.states.items()}


def difference(y, Pi, R) -> float:
    """max over Π (relative to |Π|) and R of the entries' difference."""
    p = momentum(y)
    return max(float(np.max(np.abs(p - Pi)) / np.linalg.norm(Pi)), float(np.max(np.abs(y["R"] - R))))


# -- 1, 2, 3 ----------------------------------------------------------------------------------


def agreement(codes: ReferenceCodes, out, nsteps: int) -> None:
    h = 0.01
    out.section(f"1. Agreement with the reference codes: {nsteps} steps of h = {h}")
    out.table(["motion", "lieint", "reference", "max difference"])
    for label, moments, Pi0 in motions():
        y0 = state(Pi0)
        for name, order in MV_PAIRS:
            Pi, q = codes.dmv(order, moments, Pi0, [1.0, 0.0, 0.0, 0.0], h, nsteps)
            y = run_lieint(name, moments, y0, h, nsteps)
            out.row([label, name, f"DMV{order}", f"{difference(y, Pi, quaternion_to_rotation(q)):.1e}"])
        Pi, R = codes.frb(moments, Pi0, np.eye(3), h, nsteps)
        y = run_lieint("exact_flow", moments, y0, h, nsteps)
        out.row([label, "exact_flow", "FRB_STEP", f"{difference(y, Pi, R):.1e}"])
        y_exact = lieint.EulerTop.from_principal_moments(moments).exact_solution([h * nsteps], y0)
        y_exact = {k: v[-1] for k, v in y_exact.items()}
        out.row([label, "exact_solution (one shot)", "FRB_STEP", f"{difference(y_exact, Pi, R):.1e}"])


def figure_1(codes: ReferenceCodes, out) -> None:
    h, T = 0.1, 10.0
    n = round(T / h)
    top = lieint.EulerTop.from_principal_moments(HV_MOMENTS)
    y0 = state(HV_PI0)
    exact = {k: v[-1] for k, v in top.exact_solution([T], y0).items()}
    out.section(
        f"2. Hairer–Vilmart Figure 1 set-up: body {HV_MOMENTS}, Π0 = {HV_PI0}, R0 = Id, h = {h}, T = {T:g}; "
        "error at T against the exact solution (max over Π/|Π| and R)"
    )
    out.table(["order", "lieint", "error", "reference", "error", "lieint / reference"])
    for name, order in MV_PAIRS:
        Pi, q = codes.dmv(order, HV_MOMENTS, HV_PI0, [1.0, 0.0, 0.0, 0.0], h, n)
        ref = difference(exact, Pi, quaternion_to_rotation(q))
        mine = difference(run_lieint(name, HV_MOMENTS, y0, h, n), momentum(exact), exact["R"])
        out.row([str(order), name, f"{mine:.2e}", f"DMV{order}", f"{ref:.2e}", f"{mine / ref:.2f}"])


#: the starts of table 3 besides each body's own: its Π₀ perturbed by this much (relative, seeded)
ROUND_OFF_STARTS, ROUND_OFF_SPREAD = 5, 1e-3


def round_off_growth(codes: ReferenceCodes, out, T: float) -> None:
    # one run's drift is one draw of a random walk (the two codes' roundings at the same start part
    # by factors up to 10 either way), so each cell is the median over nearby starts
    out.section(
        f"3. Round-off growth of the exact steps over T = {T:g}: distance of the stepped run from its own "
        "one-shot solution (max over Π/|Π| and R) and relative energy error at T, each the median over "
        f"{ROUND_OFF_STARTS + 1} starts (the body's Π0 and {ROUND_OFF_STARTS} within {ROUND_OFF_SPREAD:g} of it)"
    )
    out.table(["body", "h", "exact_flow drift", "FRB_STEP drift", "ratio", "exact_flow energy", "FRB_STEP energy"])
    bodies = [("flat (1, 2, 3)", (1.0, 2.0, 3.0), np.array([0.3, 2.0, 1.2])), ("HV (0.6, 0.8, 1)", HV_MOMENTS,
              np.array(HV_PI0))]  # fmt: skip
    for label, moments, Pi0 in bodies:
        top = lieint.EulerTop.from_principal_moments(moments)
        rng = np.random.default_rng(2010)
        starts = [Pi0] + [Pi0 * (1.0 + ROUND_OFF_SPREAD * rng.normal(size=3)) for _ in range(ROUND_OFF_STARTS)]
        for h in (0.1, 1.0):
            n = round(T / h)
            cells = []
            for P in starts:
                y0 = state(P)
                H0 = float(top.energy(y0["A"]))
                one_lieint = run_lieint("exact_flow", moments, y0, T, 1)
                one_frb = codes.frb(moments, P, np.eye(3), T, 1)
                stepped = run_lieint("exact_flow", moments, y0, h, n)
                Pi, R = codes.frb(moments, P, np.eye(3), h, n)
                cells.append(
                    (
                        difference(stepped, momentum(one_lieint), one_lieint["R"]),
                        difference(state(Pi, R), *one_frb),
                        abs(float(top.energy(stepped["A"])) / H0 - 1),
                        abs(float(top.energy(state(Pi)["A"])) / H0 - 1),
                    )
                )
            d_lieint, d_frb, e_lieint, e_frb = np.median(np.array(cells), axis=0)
            out.row([label, f"{h:g}", f"{d_lieint:.1e}", f"{d_frb:.1e}", f"{d_lieint / d_frb:.2f}", f"{e_lieint:.1e}",
                     f"{e_frb:.1e}"])  # fmt: skip


# -- 4: time per step -------------------------------------------------------------------------


def _cpu(fn) -> float:
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def marginal_step_times(calls: dict, rounds: int) -> dict:
    """``{key: seconds per step}``: the least over ``rounds`` of ``(t(N) − t(N/10)) / 0.9N`` for
    each ``calls[key] = (call(nsteps), N)``, the contenders alternating within each round."""
    best = {key: float("inf") for key in calls}
    for _ in range(rounds):
        for key, (call, N) in calls.items():
            M = max(N // 10, 1)
            best[key] = min(best[key], (_cpu(partial(call, N)) - _cpu(partial(call, M))) / (N - M))
    return best


def _size(call, seconds: float, start: int = 10) -> int:
    """A step count for which one call takes about ``seconds``."""
    n = start
    while True:
        t = _cpu(partial(call, n))
        if t >= 0.05 or n >= 10**8:
            return max(int(n * seconds / max(t, 1e-9)), 20)
        n *= 10


def timings(codes: ReferenceCodes, out, quick: bool, label: str) -> None:
    h, batch = 0.01, 200
    moments, Pi0 = HV_MOMENTS, np.array(HV_PI0)
    top = lieint.EulerTop.from_principal_moments(moments)
    y0 = state(Pi0)
    rng = np.random.default_rng(5)
    y_batch = top.initial_state(A=-hat(Pi0 * (1 + 0.01 * rng.normal(size=(batch, 3)))))
    seconds, rounds = (0.1, 2) if quick else (0.3, 5)
    out.section(
        f"4. CPU time per step ({label}; load average {os.getloadavg()[0]:.2f}): body {moments}, Π0 = {HV_PI0}, "
        f"h = {h}; least of {rounds} interleaved rounds of (t(N) − t(N/10))/0.9N"
    )
    out.table(["lieint", "backend", "µs/step", f"µs/body-step (batch {batch})", "reference", "µs/step", "ratio",
               "ratio batch"])  # fmt: skip
    pairs = [*MV_PAIRS, ("exact_flow", "FRB")]
    for name, ref in pairs:

        def lie(n, name=name):
            lieint.integrate(top, y0, (0.0, n * h), h=h, method=name, save_every=n)

        def lie_batch(n, name=name):
            lieint.integrate(top, y_batch, (0.0, n * h), h=h, method=name, save_every=n)

        if ref == "FRB":

            def fortran(n):
                codes.frb(moments, Pi0, np.eye(3), h, n)
        else:

            def fortran(n, order=ref):
                codes.dmv(order, moments, Pi0, [1.0, 0.0, 0.0, 0.0], h, n)

        backend = lieint.integrate(top, y0, (0.0, 2 * h), h=h, method=name).stats.backend  # and warm up
        lie(2), lie_batch(2), fortran(2)
        calls = {
            "lieint": (lie, _size(lie, seconds)),
            "batch": (lie_batch, _size(lie_batch, seconds, start=2)),
            "fortran": (fortran, _size(fortran, seconds, start=1000)),
        }
        t = marginal_step_times(calls, rounds)
        per_body = t["batch"] / batch
        ref_name = "FRB_STEP" if ref == "FRB" else f"DMV{ref}"
        out.row([name, "compiled" if backend == "numba" else backend, f"{1e6 * t['lieint']:.3f}",
                 f"{1e6 * per_body:.3f}", ref_name, f"{1e6 * t['fortran']:.3f}", _ratio(t["lieint"] / t["fortran"]),
                 _ratio(per_body / t["fortran"])])  # fmt: skip


def _ratio(r: float) -> str:
    """Two significant digits below 10 (the compiled steps), whole numbers above."""
    return f"{r:.2f}" if r < 10 else f"{r:.0f}"


# -- output -----------------------------------------------------------------------------------


class Report:
    """Prints the tables as they come; keeps them for ``--markdown``."""

    def __init__(self):
        self.lines: list[str] = []
        self._widths: list[int] = []

    def section(self, title: str) -> None:
        print(f"\n{title}")
        self.lines += ["", f"**{title}**", ""]

    def table(self, header: list[str]) -> None:
        self._widths = [max(len(h), 12) for h in header]
        print("  ".join(f"{h:>{w}s}" for h, w in zip(header, self._widths, strict=True)))
        self.lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]

    def row(self, cells: list[str]) -> None:
        print("  ".join(f"{c:>{w}s}" for c, w in zip(cells, self._widths, strict=True)), flush=True)
        self.lines.append("| " + " | ".join(cells) + " |")

    def write(self, path: Path, command: str) -> None:
        head = [
            "---",
            "orphan: true",
            "---",
            "",
            "# lieint against the reference Fortran codes",
            "",
            f"Generated by `{command}` (benchmarks/reference_codes.py; its docstring says what each table measures).",
            f"Machine: {os.cpu_count()} CPUs; numpy {np.__version__}; lieint {lieint.__version__}; "
            f"{time.strftime('%Y-%m-%d')}.",
            "",
            "Timings are process CPU time on a shared machine: *idle* means no CPU-bound process of the "
            "benchmark's own, and each table gives the load average. Near the separatrix the differences between "
            "`exact_flow` and FRB_STEP are FRB_STEP's: lieint's exact solution agrees there with an "
            "extended-precision Taylor integrator (tests/systems/test_euler_top_exact.py).",
        ]
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(head + self.lines) + "\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--codes", metavar="DIR", help=f"directory of dmv10.f and frb_step.f (default: ${ENV})")
    parser.add_argument("--hog", action="store_true", help="time again while another CPU-bound process runs")
    parser.add_argument("--quick", action="store_true", help="a smoke run: fewer steps and rounds")
    parser.add_argument("--markdown", metavar="PATH", type=Path, help="also write the tables to PATH")
    args = parser.parse_args()
    try:
        with reference_codes(args.codes) as codes:
            out = Report()
            agreement(codes, out, 1000 if args.quick else 10_000)
            figure_1(codes, out)
            round_off_growth(codes, out, 100.0 if args.quick else 1000.0)
            timings(codes, out, args.quick, "idle")
            if args.hog:
                hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
                try:
                    time.sleep(1.0)
                    timings(codes, out, args.quick, "with another CPU-bound process running")
                finally:
                    hog.kill()
            if args.markdown:
                out.write(args.markdown, "python benchmarks/reference_codes.py " + " ".join(sys.argv[1:]))
    except ReferenceCodesUnavailable as why:
        print(f"benchmarks/reference_codes.py: skipped — {why}")
        return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
