"""
Counting toward integrability, checked on the motion
====================================================

The lecture predicts integrability by counting: the dimension of the phase space, less the
independent first integrals, the symmetries that keep their level set, and an invariant measure
(for a nonholonomic system), leaves the dimension of the reduced motion — 1 means integrable
(``6 − 1 − 3 − 1 = 1`` for the 3D top). ``lieint.analysis.integrability_count`` does that count at
a state. Here it is set beside what the motion itself says: MEGNO ``⟨Y⟩`` (→ 2 for a motion on a
torus, growing like ``λt/2`` for a chaotic one) and the largest Lyapunov exponent ``log|δ(t)|/t``
(→ 0 like ``log(t)/t`` on a torus), both from one tangent vector carried by the exact tangent map
of RKMK4.

The heavy tops are not in ``integrability_count``; their count is written in the same way:
``T*SO(3)`` has dimension 6, less the energy, the vertical angular momentum and the rotations
about the vertical, ``6 − 1 − 1 − 1 = 3`` (not enough reduced); the Lagrange and the Kovalevskaya
tops have one more integral, which with its Hamiltonian flow takes two more: ``= 1``.

What to conclude: every motion the count calls integrable has ``⟨Y⟩`` near 2 and an exponent
that falls like ``log(t)/t`` (the dotted line); the generic heavy top's ``⟨Y⟩`` grows linearly
and its exponent stays. On a torus ``⟨Y⟩`` approaches 2 from below like ``2 − (C log t + D)/t``,
C set by the torus and the initial tangent vector (``2 − π log(x)/x`` when ``|δ| = √(1 +
x²)|δ(0)|``), so the 4D top with this vector is still at 1.90 at t = 2000 and at 1.97 by t =
8000 (the guide's "Is this motion regular or chaotic?"). The 4D Chaplygin ball, whose count the
lecture leaves open (it writes ``15 − 1 − 6 − 3 − 1 = 3``; the terms it names sum to 4), is
printed with its error bars — the same quantities at ``h/2`` and at ``2T``. At full size (T =
2000, ``LIEINT_FULL_EXAMPLES=1``, about 6 CPU minutes, most of them the 4D ball's, whose tangent
steps run on the generic path) its ``⟨Y⟩`` is 35.6 (33.9 at h/2) and 62.0 at 2T — it grows about
in proportion to T, the ``λt/2`` of chaos — while its exponent stays at 0.036 (0.035 at h/2, 0.033
at 2T): chaotic for this mass tensor and state, a numerical hint, not a proof. The
quick size shown here (T = 100) is too short to tell a weak exponent from a slow torus; set
``LIEINT_FULL_EXAMPLES=1`` for T = 2000.
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import lieint
from lieint.analysis import integrability_count
from lieint.groups.bivectors import hat

full = os.environ.get("LIEINT_FULL_EXAMPLES") == "1"
T = 2000.0 if full else 100.0
H = 0.05
SAVE = 20 if full else 4  # history entries: every SAVE-th step

rng = np.random.default_rng(4)
Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
X = rng.normal(size=(4, 4))
Omega4 = 0.5 * (X - X.T)
B4_ball = Q @ np.diag([0.06, 0.09, 0.12, 0.15]) @ Q.T
B3 = lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B
w = np.array([1.0, 2.0, 1.5])


def counted(system, integrals="momentum", **initial):
    """The count at ``system``'s state (the full phase space, orientation kept) as an equation."""
    count = integrability_count(system, system.initial_state(**initial), integrals=integrals, verbose=False)
    return count.equation()


# name -> (system for the motion, its initial state, the count)
top3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
top4 = lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]), orientation=False)
lagrange = lieint.HeavyTop.lagrange(1.0, 0.5, mass=1.0, length=0.2, orientation=False)
kovalevskaya = lieint.HeavyTop.kovalevskaya(1.0, mass=1.0, length=0.1, orientation=False)
generic = lieint.HeavyTop(B3, 1.0, [0.1, 0.05, 0.08], [0.0, 0.0, -9.81], orientation=False)
ball3 = lieint.ChaplyginBall(np.diag([0.08, 0.12, 0.16]), 1.0, 1.0, orientation=False, track_center=False)
ball4 = lieint.ChaplyginBall(B4_ball, 1.0, 1.0, orientation=False, track_center=False)
cases = {
    "3D top": (
        top3,
        top3.initial_state(angular_velocity=[1.0, 0.3, 0.2]),
        counted(lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0]), angular_velocity=[1.0, 0.3, 0.2]),
    ),
    "4D top (Manakov)": (
        top4,
        top4.initial_state(Omega=Omega4),
        counted(lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5])), "manakov", Omega=Omega4),
    ),
    "Lagrange top": (lagrange, lagrange.initial_state(angular_velocity=[1.0, 0.5, 5.0]), "6 − 1 − 1 − 1 − 1 − 1 = 1"),
    "Kovalevskaya top": (
        kovalevskaya,
        kovalevskaya.initial_state(angular_velocity=[1.0, 0.5, 1.0]),
        "6 − 1 − 1 − 1 − 1 − 1 = 1",
    ),
    "generic heavy top": (
        generic,
        generic.initial_state(angular_velocity=2.0 * w / np.linalg.norm(w)),
        "6 − 1 − 1 − 1 = 3",
    ),
    "3D Chaplygin ball": (
        ball3,
        ball3.initial_state(Omega=hat([0.3, 1.0, 0.4])),
        counted(lieint.ChaplyginBall(np.diag([0.08, 0.12, 0.16]), 1.0, 1.0), Omega=hat([0.3, 1.0, 0.4])),
    ),
    "4D Chaplygin ball (open)": (
        ball4,
        ball4.initial_state(Omega=Omega4),
        counted(lieint.ChaplyginBall(B4_ball, 1.0, 1.0), Omega=Omega4),
    ),
}

fig, (ax_y, ax_l) = plt.subplots(1, 2, figsize=(12, 4.6))
print(f"rkmk4, h = {H:g}, T = {T:g}; λ = log|δ(T)|/T from the MEGNO vector")
print(f"{'motion':26s} {'count':28s} {'<Y>(T)':>8s} {'λ(T)':>8s}")
for name, (system, y0, count) in cases.items():
    open_case = "open" in name
    # the open case runs to 2T, so that T and 2T are one run, and once more at h/2
    m = lieint.megno(system, y0, (0.0, 2 * T if open_case else T), h=H, save_every=SAVE)
    at_T = np.searchsorted(m.t, T - 1e-9)
    mean_T = float(m.mean_history[at_T])
    style = {"lw": 2.2, "color": "k"} if open_case else {"lw": 1.2, "color": f"C{len(ax_y.lines)}"}
    ax_y.plot(m.t, m.mean_history, label=name, **style)
    late = m.t >= 1.0
    ax_l.loglog(m.t[late], np.maximum(m.lyapunov_history[late], 1e-4), **style)
    lam_T = float(m.lyapunov_history[at_T])
    print(f"{name:26s} {count:28s} {mean_T:8.3f} {lam_T:8.4f}")
    if open_case:
        half = lieint.megno(system, y0, (0.0, T), h=H / 2, save_every=SAVE)
        print(
            f"{'':26s} error bars: <Y> {mean_T:.3f} at (h, T), {float(half.mean):.3f} at (h/2, T), "
            f"{float(m.mean):.3f} at (h, 2T); λ {lam_T:.4f}, {float(half.lyapunov):.4f}, {float(m.lyapunov):.4f}"
        )
t_guide = np.geomspace(3.0, 2 * T, 50)
ax_l.loglog(t_guide, np.log(t_guide) / t_guide, "k:", label="log(t)/t")
ax_y.axhline(2.0, color="0.5", lw=0.8, ls="--")
ax_y.set_yscale("symlog", linthresh=5.0, linscale=2.0)
top_value = max(float(np.max(line.get_ydata())) for line in ax_y.lines)
ticks = [v for v in (0, 1, 2, 3, 4, 5, 10, 20, 50, 100, 200, 500) if v <= 1.5 * top_value]
ax_y.set_yticks(ticks)
ax_y.set_yticklabels([str(v) for v in ticks])
ax_y.set_ylim(0.0, None)
ax_y.set_xlabel("t")
ax_y.set_ylabel("MEGNO ⟨Y⟩(t)")
ax_y.set_title("⟨Y⟩ → 2 on a torus, grows like λt/2 in chaos")
ax_y.legend(fontsize=8, loc="lower right" if full else "upper left")
ax_l.set_xlabel("t")
ax_l.set_ylabel("log|δ(t)| / t")
ax_l.set_ylim(1e-3, None)
ax_l.set_title("largest exponent: → 0 like log(t)/t on a torus")
ax_l.legend(fontsize=8)
fig.tight_layout()
