"""
Regular or chaotic? Poincaré sections of three heavy tops
=========================================================

Three heavy tops at the same energy and the same Casimir ``⟨Π, Γ⟩ = 0``, eight motions each,
cut by the section ``Π₁ = 0`` (crossed upwards) and drawn in the plane ``(Γ₃/|Γ|, Π₂)``. The
crossings are found by ``lieint.poincare``: events on the dense output on the group, refined by
the secant method on the interpolant to round-off.

What to conclude: the Lagrange top (symmetric, centre of mass on the axis) and the Kovalevskaya
top (``I₁ = I₂ = 2 I₃``, centre of mass in the equatorial plane) have a fourth integral, so every
motion stays on a two-dimensional torus and its crossings line up on a curve (for the Lagrange
top the axial momentum Π₃ is constant on each curve). The generic top (moments 1, 1.5, 2,
centre of mass off every axis) has no such integral: at this energy most motions scatter their
crossings over a region of the section — chaos — beside a few islands of curves. The MEGNO of
each motion, printed, says the same in one number (2: regular, growing: chaotic).
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import lieint
from lieint.groups import hat

full = os.environ.get("LIEINT_FULL_EXAMPLES") == "1"
T = 1500.0 if full else 300.0
ENERGY = 2.0
g = 9.81
tops = {
    "Lagrange top": lieint.HeavyTop.lagrange(1.0, 0.5, mass=1.0, length=0.2, orientation=False),
    "Kovalevskaya top": lieint.HeavyTop.kovalevskaya(1.0, mass=1.0, length=0.1, orientation=False),
    "generic top": lieint.HeavyTop(
        lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B,
        1.0,
        [0.1, 0.05, 0.08],
        [0.0, 0.0, -g],
        orientation=False,
    ),
}


def states_at_energy(top, count, rng):
    """``count`` states with ``⟨Π, Γ⟩ = 0`` and energy ENERGY: Γ random on its sphere, Π ⟂ Γ
    scaled so that ``T(Π) − M⟨Γ, X_G⟩ = ENERGY``."""
    out = []
    while len(out) < count:
        Gamma = rng.normal(size=3)
        Gamma *= g / np.linalg.norm(Gamma)
        Pi = rng.normal(size=3)
        Pi -= (Pi @ Gamma) / (Gamma @ Gamma) * Gamma
        A = -hat(Pi)
        kinetic = float(top.top.energy(A))
        potential = float(top.energy(np.zeros((3, 3)), Gamma))  # −M⟨Γ, X_G⟩
        if ENERGY - potential <= 0:
            continue
        out.append({"A": A * np.sqrt((ENERGY - potential) / kinetic), "Gamma": Gamma})
    return out


def section(t, y):
    return y["A"][..., 1, 2]  # Π₁ (A = −Π̂)


fig, axes = plt.subplots(1, 3, figsize=(14, 4.6), sharey=False)
for ax, (name, top) in zip(axes, tops.items(), strict=True):
    rng = np.random.default_rng(3)
    starts = states_at_energy(top, 8, rng)
    for k, y0 in enumerate(starts):
        cut = lieint.poincare(top, y0, (0.0, T), section, h=0.01)
        # A = −Π̂: Π₂ = −A₁₃ (0-based [0, 2])
        ax.plot(cut.y["Gamma"][:, 2] / g, -cut.y["A"][:, 0, 2], ".", ms=1.5, color=plt.cm.tab10(k))
    batch = {key: np.stack([s[key] for s in starts]) for key in starts[0]}
    m = lieint.megno(top, batch, (0.0, 200.0), h=0.05)
    print(name, "MEGNO of the eight motions at t = 200:", np.array2string(m.mean, precision=2))
    ax.set_title(f"{name} (E = {ENERGY:g})")
    ax.set_xlabel("Γ₃ / |Γ|")
    ax.set_ylabel("Π₂")
fig.tight_layout()
plt.show()
