# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # Lesson 2 — The geometrically exact beam and the roll-up
#
# The Beam2 element (Simo–Reissner kinematics, one-point integration): strains at the
# midpoint, `Γ = Amᵀ x' − Γ0` and `K = ψ/L0` with `ψ = log(A1ᵀA2)`. Its internal force is the
# **exact gradient** of the strain energy — derived in `derivations/beam2.py` and generated
# into `reference/generated/beam2.py`.

# %%
import os
from pathlib import Path

import numpy as np

from reference.analytic import elastica_tip, polygon_tip
from reference.domain import Domain
from reference.elements import Beam2Formulation, Section
from reference.rotation import RotationVector

import reference

QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
# the repository, wherever the notebook runs from (the editable install points here)
ROOT = Path(reference.__file__).resolve().parents[1]
section = Section(EA=10.0, GA2=3.0, GA3=4.0, GJ=2.0, EI2=5.0, EI3=7.0, rhoA=1.0, rhoJ1=0.2, rhoJ2=0.1, rhoJ3=0.1)
beam = Beam2Formulation(section)
x_ref = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
q_ref = np.array([[1.0, 0, 0, 0], [1.0, 0, 0, 0]])
reference = beam.reference_state(x_ref, q_ref)

# a large deformation of the element
x = np.array([[0.0, 0.0, 0.0], [0.8, 0.3, 0.2]])
q = np.array([RotationVector([0.1, 0.2, -0.1]).to_euler_parameters().q,
              RotationVector([0.5, -0.4, 0.9]).to_euler_parameters().q])
S, U = beam.internal_forces(x, q, reference)
print("strain energy", U)

# %% [markdown]
# Check it: central differences of U under nodal displacements and body-frame rotations.

# %%
fd = np.zeros(12)
eps = 1e-6
for k in range(12):
    node, rot, comp = k // 6, (k % 6) >= 3, k % 3
    vals = []
    for s in (eps, -eps):
        xp, qp = x.copy(), q.copy()
        d = np.zeros(3)
        d[comp] = s
        if rot:
            from reference.rotation import EulerParameters

            qp[node] = EulerParameters(q[node]).product(RotationVector(d).to_euler_parameters()).q
        else:
            xp[node] += d
        vals.append(beam.internal_forces(xp, qp, reference)[1])
    fd[k] = (vals[0] - vals[1]) / (2 * eps)
gap = np.max(np.abs(fd - S)) / np.max(np.abs(S))
print("relative gap to finite differences:", gap)
assert gap < 1e-8

# %% [markdown]
# ## The paper's first example: a beam rolled into a circle
# A moment `M = kπEI/L` at the tip bends the cantilever into an arc of angle kπ; at k = 2
# it closes into a circle. With 12 elements the discrete answer is a regular polygon of
# unstrained chords; the dynamic run (k is the time) adds a small damping lag.

# %%
domain = Domain.from_deck(ROOT / "models/embedded_beam.toml")
result = domain.solve()
for k in (0.5, 1.0, 1.5, 2.0):
    i = int(np.argmin(abs(result.time - k)))
    tip = result.position("beam:12")[i]
    print(f"k = {k}: tip {np.round(tip, 4)}  elastica {np.round(elastica_tip(10, k), 4)}  "
          f"polygon {np.round(polygon_tip(10, 12, k), 4)}")
errors = [np.linalg.norm(result.position("beam:12")[i] - elastica_tip(10, k)) / 10 for i, k in enumerate(result.time)]
print("worst tip error: %.3f %% of L" % (100 * max(errors)))
assert max(errors) < 5e-3

# %%
import matplotlib.pyplot as plt

fig, ax = plt.subplots()
for k in (0.25, 0.5, 1.0, 1.5, 2.0):
    i = int(np.argmin(abs(result.time - k)))
    ax.plot(result.positions[i, :, 0], result.positions[i, :, 2], "o-", ms=3, label=f"k = {k}")
ax.set_aspect("equal")
ax.legend()
