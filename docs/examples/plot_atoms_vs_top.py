"""
The rigid body as atoms
=======================

Seven atoms in four dimensions, held rigid by central reactions ``Rᵢ = Σₖ σᵢₖ (qₖ − qᵢ)``
whose tensions σ are solved at each instant from a linear system (the theory, §8). Nothing in
the atoms' equations knows about rotations, mass tensors or Lie algebras; yet they move as the
Euler top with ``B = Σ mᵢ XᵢXᵢᵀ``.

What to conclude: the atoms (DOP853 at 1e-13) and :class:`lieint.EulerTop` (DOP853 at 1e-13)
agree to the accuracy of the two integrations (about 1e-11 here) — the atoms are an
independent truth for the top's equations
``Ȧ = [A, Ω]``, ``Ṙ = RΩ``. The reactions are central: their sum and their total torque
``Σ qᵢ ∧ Rᵢ`` vanish to round-off, while each reaction is of the size of the centripetal forces.
"""

import os

import matplotlib.pyplot as plt
import numpy as np

import lieint
from lieint.groups.bivectors import wedge

full = os.environ.get("LIEINT_FULL_EXAMPLES") == "1"
rng = np.random.default_rng(4)
n, N = 4, 7
body = lieint.AtomsBody(rng.uniform(0.5, 2.0, N), rng.normal(size=(N, n)))
X = rng.normal(size=(n, n))
Om = (X - X.T) / 2
T = 10.0 if full else 2.0
times = np.linspace(0.0, T, 201)
tight = dict(method="scipy:DOP853", rtol=1e-13, atol=1e-13, t_eval=times)
atoms = lieint.integrate(body, body.initial_state(Omega=Om), (0.0, T), **tight)
top = body.euler_top()
ref = lieint.integrate(top, top.initial_state(Omega=Om), (0.0, T), **tight)

q, v = atoms.states["q"], atoms.states["v"]
dq = np.max(np.abs(q - np.einsum("tjk,ik->tij", ref.states["R"], body.body_positions)), axis=(1, 2))
dA = np.max(np.abs(body.body_momentum(q, v) - ref.states["A"]), axis=(1, 2)) / np.max(np.abs(ref.states["A"][0]))
R = body.reactions(q, v)
size = np.max(np.linalg.norm(R, axis=-1), axis=-1)
net_force = np.linalg.norm(R.sum(axis=1), axis=-1) / size
net_torque = np.linalg.norm(np.einsum("tijk->tjk", wedge(q, R)), axis=(1, 2)) / size

fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
axes[0].semilogy(times, np.maximum(dq, 1e-17), label="max |qᵢ − R Xᵢ| (top's R)")
axes[0].semilogy(times, np.maximum(dA, 1e-17), label="max |A − A_top| / |A|")
axes[0].semilogy(times, np.maximum(np.abs(atoms.invariants["distances"]).max(axis=1), 1e-17), label="distances kept")
axes[0].set_title(f"{N} atoms in n = {n} against the Euler top")
axes[0].set_xlabel("t")
axes[0].legend(fontsize=8)
axes[1].semilogy(times, np.maximum(net_force, 1e-17), label="|Σ Rᵢ| / max |Rᵢ|")
axes[1].semilogy(times, np.maximum(net_torque, 1e-17), label="|Σ qᵢ ∧ Rᵢ| / max |Rᵢ|")
axes[1].set_title("the reactions are central")
axes[1].set_xlabel("t")
axes[1].legend(fontsize=8)
fig.tight_layout()
print(f"atoms vs top: positions {dq.max():.1e}, momentum {dA.max():.1e} (relative)")
print(f"reactions: net force {net_force.max():.1e}, net torque {net_torque.max():.1e} of max |Rᵢ| = {size.max():.2f}")
