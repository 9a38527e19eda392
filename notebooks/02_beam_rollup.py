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
# The Beam2 element (Simo–Reissner kinematics, one-point integration; `docs/formulation.md` §3)
# measures its strains at the midpoint of an element of length $L_0$:
#
# $$x' = \frac{x_2 - x_1}{L_0},\quad \psi = \log(A_1^{\mathsf T}A_2),\quad A_m = A_1\exp(\tilde\psi/2),\quad
# \Gamma = A_m^{\mathsf T}x' - \Gamma_0,\quad K = \frac{\psi - \psi_0}{L_0},$$
#
# with the strain energy
#
# $$U = \frac{L_0}{2}\left(\Gamma^{\mathsf T}C_\Gamma\Gamma + K^{\mathsf T}C_K K\right),\qquad
# C_\Gamma = \mathrm{diag}(EA, GA_2, GA_3),\ C_K = \mathrm{diag}(GJ, EI_2, EI_3).$$
#
# Its internal force is the **exact gradient** of $U$ with respect to the nodal displacements and
# body-frame rotations, and its tangent stiffness the exact derivative of that force. Neither is written
# by hand. The code a run executes is reached in three files:
#
# 1. `derivations/beam2.py` — the equations above in sympy, differentiated symbolically
#    (the tangent: `derivations/tangents.py`);
# 2. `reference/generated/beam2.py` — the code sympy writes from them: `internal_forces` returns $U$
#    and the force vector $S$ of one element (`reference/generated/tangents.py`: `beam2_tangent`, $K$);
# 3. `reference/plain/elements.py` — the **reference path**: `element_forces` and `element_tangent` run
#    that generated code with NumPy on every element of a model at once, turn the moments into the
#    nodes' frames and add them up per node.
#
# The compiled path runs the same generated code through numba (`docs/reference_path.md`); a test
# checks that both give the same numbers. Here we call the reference path on one element and check the
# two claims numerically: $S$ is the gradient of $U$, $K$ the derivative of $S$.

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import reference
from flexmbs.verification.analytic import elastica_tip, polygon_tip
from reference.domain import Domain
from reference.elements import Section
from reference.io.deck import load_deck
from reference.plain.elements import ADAPTERS, element_forces, element_tangent
from reference.rotation import EulerParameters, RotationVector

FIGURES = Path("figures") / "02_beam_rollup"  # this lesson's figures, saved next to where it runs
FIGURES.mkdir(parents=True, exist_ok=True)

QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
# the repository, wherever the notebook runs from (the editable install points here)
ROOT = Path(reference.__file__).resolve().parents[1]

beam2 = ADAPTERS["beam2"]  # what the reference path calls for a Beam2 element: two generated functions
print("forces: ", beam2.forces.__module__ + "." + beam2.forces.__name__)
print("tangent:", beam2.tangent_function.__module__ + "." + beam2.tangent_function.__name__)

# %% [markdown]
# One element of length 1 m along $x$, as a model of two nodes (`Domain`, the object a deck builds).
# `element_forces(model, x, q)` takes the nodes' positions $x$ (N × 3) and Euler parameters $q$ (N × 4)
# and returns $S$ (N × 6: per node the force and the body-frame moment) and $U$:

# %%
section = Section(EA=10.0, GA2=3.0, GA3=4.0, GJ=2.0, EI2=5.0, EI3=7.0, rhoA=1.0, rhoJ1=0.2, rhoJ2=0.1, rhoJ3=0.1)
one = Domain("one element")
one.add_beam("beam", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 1, section)
model = one.initialization()  # the plain arrays every algorithm works on: connectivity, L0, stiffness, …

# a large deformation of the element
x = np.array([[0.0, 0.0, 0.0], [0.8, 0.3, 0.2]])
q = np.array([RotationVector([0.1, 0.2, -0.1]).to_euler_parameters().q,
              RotationVector([0.5, -0.4, 0.9]).to_euler_parameters().q])
S, U = element_forces(model, x, q)
print("strain energy U =", U, "J")
print("S [N | N m], one row per node:\n", np.array2string(S, precision=4))


def moved(k, s):
    """(x, q) after moving coordinate k (0–5 node 1, 6–11 node 2; 3–5 are body-frame rotations) by s."""
    node, rot, comp = k // 6, (k % 6) >= 3, k % 3
    xp, qp, d = x.copy(), q.copy(), np.zeros(3)
    d[comp] = s
    if rot:  # q ← q ⊗ exp(δθ): a rotation in the body frame
        qp[node] = EulerParameters(q[node]).product(RotationVector(d).to_euler_parameters()).q
    else:
        xp[node] += d
    return xp, qp


eps = 1e-6
fd = np.array([(element_forces(model, *moved(k, eps))[1] - element_forces(model, *moved(k, -eps))[1]) / (2 * eps)
               for k in range(12)])
gap = float(np.max(np.abs(fd - S.reshape(-1))) / np.max(np.abs(S)))
print("relative gap between S and central differences of U:", gap)

# %% [markdown]
# The tangent stiffness $K = \partial S/\partial[\delta x_1, \delta\theta_1, \delta x_2, \delta\theta_2]$
# (12 × 12 here: the static and implicit algorithms' Newton matrix is made of such blocks) against central
# differences of $S$, column by column:

# %%
K = element_tangent(model, x, q).toarray()  # a sparse (6N × 6N) matrix: every element's block at its nodes
fd_K = np.column_stack([(element_forces(model, *moved(k, eps))[0] - element_forces(model, *moved(k, -eps))[0]).reshape(-1)
                        / (2 * eps) for k in range(12)])
tangent_gap = float(np.max(np.abs(fd_K - K)) / np.max(np.abs(K)))
print("relative gap between K and central differences of S:", tangent_gap)

# %% tags=["check"] jupyter={"source_hidden": true}
# central differences err by O(eps²) (~1e-12) plus the round-off of U or S divided by eps (~1e-16 / 1e-6);
# a sign or a factor wrong in one entry of the derivation would give a gap of order 1
assert gap < 1e-8 and tangent_gap < 1e-8

# %% [markdown]
# ## The paper's first example: a beam rolled into a circle
# A tip moment $M = k\pi EI/L$ bends the cantilever into an arc of angle $k\pi$ (the elastica of pure
# bending is a circle of curvature $M/EI$):
#
# $$x_{tip} = L\frac{\sin k\pi}{k\pi},\qquad z_{tip} = L\frac{1 - \cos k\pi}{k\pi};$$
#
# at $k = 2$ it closes into a circle. With 12 elements every element carries the same curvature and no
# force, so the discrete answer is a **regular polygon of unstrained chords** (`polygon_tip`); the
# dynamic run (the load factor $k$ is the time, with damping) adds a small lag behind it.
#
# The model is the deck `models/embedded_beam.toml` (its keys: `docs/deck.md`). Its model and
# solver tables are printed below; the `[checks]` tables after them state what `flexmbs check`
# verifies, each with its tolerance and the reason for it.

# %%
deck_text = (ROOT / "models" / "embedded_beam.toml").read_text()
print(deck_text[:deck_text.index("[checks.")].strip())

# %%
domain = load_deck(ROOT / "models" / "embedded_beam.toml", overrides={"t_end": 1.0} if QUICK else None).domain
result = domain.solve()
tip = result.position("beam:12")
ks = result.time
errors = np.array([np.linalg.norm(p - elastica_tip(10, k)) for p, k in zip(tip, ks)]) / 10
lag = np.array([np.linalg.norm(p - polygon_tip(10, 12, k)) for p, k in zip(tip, ks)]) / 10
discretisation = np.array([np.linalg.norm(polygon_tip(10, 12, k) - elastica_tip(10, k)) for k in ks]) / 10
worst_error_percent = float(100 * errors.max())
print("worst tip error over the whole history: %.3f %% of L at k = %.2f" % (worst_error_percent, ks[errors.argmax()]))

fig, ax = plt.subplots(figsize=(6.0, 5.0))
for k in (0.25, 0.5, 1.0, 1.5, 2.0):
    if k > ks[-1] + 1e-9:
        continue
    i = int(np.argmin(abs(ks - k)))
    ax.plot(result.positions[i, :, 0], result.positions[i, :, 2], "o-", ms=3, label=f"k = {k}")
    th = k * np.pi * np.linspace(0, 1, 100)
    ax.plot(10 * np.sin(th) / (k * np.pi), 10 * (1 - np.cos(th)) / (k * np.pi), "k:", lw=0.7)
ax.set_aspect("equal")
ax.set_xlabel("x [m]")
ax.set_ylabel("z [m]")
ax.set_title("Figure 1 — roll-up: 12 Beam2 elements; dotted: elastica arcs")
ax.legend(fontsize=8)
plt.savefig(FIGURES / "figure1.png", dpi=120, bbox_inches="tight")
plt.show()

fig, ax = plt.subplots(figsize=(6.4, 3.6))
ax.plot(ks, 100 * errors, label="tip − elastica (total)")
ax.plot(ks, 100 * lag, "--", label="tip − 12-element polygon (dynamic lag)")
ax.plot(ks, 100 * discretisation, ":", label="polygon − elastica (discretisation)")
ax.set_xlabel("load factor k (= time) [–]")
ax.set_ylabel("tip error / L [%]")
ax.set_title("Figure 2 — where the error comes from")
ax.legend(fontsize=8)
plt.savefig(FIGURES / "figure2.png", dpi=120, bbox_inches="tight")
plt.show()

# %% tags=["check"] jupyter={"source_hidden": true}
assert errors.max() < 5e-3

# %% [markdown]
# Figure 2 separates the two error sources: the polygon's discretisation error (largest near
# $k = 1.3$, zero at $k = 2$ where the polygon closes exactly) and the lag of the damped dynamic run
# behind the static answer, largest when the load starts from rest: the total error peaks at
# 0.49 %<!-- check worst_error_percent rel 0.02 --> of $L$ at $k = 0.03$.
#
# ## The same roll-up as a static problem
# The roll-up is slow on purpose: the damped explicit run only approximates the sequence of
# equilibria. The `static` algorithm solves for them directly — Newton–Raphson on the derived
# tangent stiffness, the load factor $k$ advanced in `load_steps` steps
# (`models/embedded_beam_static.toml` differs from the dynamic deck in its `[solver]` table only).
# Twenty load steps of a 13-node model are a short job: `backend = "auto"` runs it on the reference path
# (`docs/reference_path.md`), which compiles nothing, and says so in the results (`backend_reason`):

# %%
static_text = (ROOT / "models" / "embedded_beam_static.toml").read_text()
print(static_text[static_text.index("[solver]"):static_text.index("[checks.")].strip())
static = load_deck(ROOT / "models" / "embedded_beam_static.toml", overrides={"solver.backend": "auto"}).domain.solve()
print("backend:", static.attrs["backend"], "—", static.attrs["backend_reason"])
static_lag = max(np.linalg.norm(p - polygon_tip(10, 12, k)) for p, k in zip(static.position("beam:12"), static.time)) / 10
print(f"{len(static.time) - 1} load steps; largest distance of the tip from the 12-element polygon: {static_lag:.1e} L")

# %% tags=["check"] jupyter={"source_hidden": true}
assert static_lag < 1e-8  # no inertia, no lag: Newton converges to the discrete equilibrium
assert static.attrs["backend"] == "reference"  # as the text says: the auto rule's estimate is far below 15 s

# %% [markdown]
# With no inertia there is no lag: every load step is the discrete equilibrium, the regular
# polygon, to Newton's round-off — in 20 load steps instead of 10,000 explicit ones.
#
# ## Exercises
# **Exercise 1.** The polygon's nodes lie on a circle of radius $L_0/(2\sin(k\pi/2n))$. By how much
# is it larger than the exact circle $L/(k\pi)$ at $k = 2$ with $n = 12$? Check against `polygon_tip`:
# at $k = 1$ the tip of the half-turn polygon is at height twice that radius.
#
# **Exercise 2.** The discretisation error falls as $h^2$: compute the worst polygon error over
# $0 \le k \le 2$ for 12 and 24 elements and check that their ratio is close to 4.
#
# **Exercise 3 (change the model and rerun).** Rerun the static deck with every element split
# in two (`overrides={"refine": 2}`, the command line's `--refine 2`). *What you should see:* the
# tip still sits on the (now 24-sided) polygon to round-off, and its distance from the elastica
# at $k = 1.3$, where the 12-element error is largest, falls by about 4.
#
# Try them before you open the answers below (click the collapsed cells to show them).
#
# ## Answers

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 1
n, L, k = 12, 10.0, 1.0
radius = (L / n) / (2 * np.sin(k * np.pi / (2 * n)))
print("polygon radius / exact radius at k = 2: %.5f" % ((L / n) / (2 * np.sin(2 * np.pi / (2 * n))) / (L / (2 * np.pi))))
assert abs(polygon_tip(L, n, k)[2] - 2 * radius) < 1e-12
assert abs((L / n) / (2 * np.sin(np.pi / n)) / (L / (2 * np.pi)) - 1.0115) < 1e-4  # 1.15 % larger

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 2
grid = np.linspace(0.01, 2.0, 400)
worst = [max(np.linalg.norm(polygon_tip(L, m, kk) - elastica_tip(L, kk)) for kk in grid) / L for m in (12, 24)]
print("worst polygon error / L: 12 elements %.2e, 24 elements %.2e, ratio %.2f" % (*worst, worst[0] / worst[1]))
assert abs(worst[0] / worst[1] - 4.0) < 0.1

# %% tags=["solution", "rerun"] jupyter={"source_hidden": true}
# Exercise 3
fine = load_deck(ROOT / "models" / "embedded_beam_static.toml", overrides={"refine": 2, "solver.backend": "auto"}).domain.solve()
i13 = int(np.argmin(abs(fine.time - 1.3)))
tip12, tip24 = static.position("beam:12")[i13], fine.position("beam:24")[i13]
e12, e24 = (np.linalg.norm(t - elastica_tip(L, 1.3)) / L for t in (tip12, tip24))
print(f"k = 1.3: tip − elastica: 12 elements {e12:.2e} L, 24 elements {e24:.2e} L, ratio {e12 / e24:.2f}")
assert np.linalg.norm(tip24 - polygon_tip(L, 24, 1.3)) < 1e-8 * L
assert abs(e12 / e24 - 4.0) < 0.2  # second order in the element length
