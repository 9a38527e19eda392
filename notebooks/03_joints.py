# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # Lesson 3 — Joints, constraint Jacobians and Lagrange multipliers
#
# A spherical joint keeps a point of body $i$ on a point of body $j$:
#
# $$\Phi = x_j + A_j s'_j - x_i - A_i s'_i = 0,$$
#
# with $s'$ the joint point in each body's frame. The engine needs the velocity Jacobian $B$,
# $\dot\Phi = B\,[v_i, \omega_i, v_j, \omega_j]$, with the angular velocities $\omega$ **in the body frames**.
# A body-frame rotation perturbs $A \to A(I + \tilde{\delta\theta})$, so the columns of $B$ for $\omega_i$ are
# $\partial\Phi/\partial\delta\theta_i$ at $\delta\theta_i = 0$. sympy derives it exactly as
# `derivations/joints.py` does for every joint (`docs/formulation.md` §5).

# %%
from pathlib import Path

import sympy as sp

try:
    from IPython.display import display
except ImportError:  # run as a plain script
    display = sp.pprint

from derivations.rotation_maps import skew

A = sp.Matrix(3, 3, lambda r, c: sp.Symbol(f"a_{r + 1}{c + 1}"))  # a generic rotation matrix A_i
s = sp.Matrix(sp.symbols("s_1:4"))                                 # the joint point s'_i in body i
x = sp.Matrix(sp.symbols("x_1:4"))
dth = sp.Matrix(sp.symbols("delta_theta_1:4"))
phi_i = -(x + A * (sp.eye(3) + skew(dth)) * s)                     # body i's side of Φ
B_omega = phi_i.jacobian(dth).xreplace({d: 0 for d in dth})
display(sp.Eq(sp.Symbol(r"\partial\Phi/\partial\omega_i"), B_omega, evaluate=False))

# %% [markdown]
# The matrix above is $A_i\,\tilde s'_i$ written out — the textbook result
# $B_{\omega_i} = +A_i\tilde s'_i$ (Nikravesh 1988, ch. 11). sympy confirms it symbolically:

# %%
textbook = A * skew(s)
display(sp.Eq(sp.Symbol(r"A_i \tilde{s}'_i"), textbook, evaluate=False))

# %% tags=["check"] jupyter={"source_hidden": true}
assert sp.simplify(B_omega - textbook) == sp.zeros(3, 3)
assert phi_i.jacobian(x) == -sp.eye(3)  # and the v_i columns are −I

# %% [markdown]
# ## The same Jacobian in the code that runs
# The engine does not contain this formula typed in by hand: it contains what sympy derived. Every joint
# kind is a choice among ten **primitive** constraints (a spherical joint the three rows of $\Phi$ above, a
# revolute those three and two dot-1 rows $u_{1,i}\cdot u_{3,j} = u_{2,i}\cdot u_{3,j} = 0$ that keep the
# axes parallel), and a joint's Jacobian is reached in three files:
#
# 1. `derivations/joints.py` — the primitives and their Jacobian $B$, by differentiation as above;
# 2. `reference/generated/joints.py` — the code sympy writes: `joint_primitives` returns the ten $\Phi$ and
#    their $B$ (10 × 12, columns $[v_i, \omega_i, v_j, \omega_j]$) for one pair of bodies;
# 3. `reference/plain/constraints.py` — the **reference path**: `joint_rows` evaluates the primitives of
#    every joint at once with NumPy and keeps each joint's rows (a drive combines two of them with its time
#    function); `Evaluation.constraints` (`reference/plain/model.py`) places them in the model's
#    $B$ (m × 6N, six columns per node).
#
# Here they are on the three-bar mechanism (paper §5.2; lesson 4 steps it): four revolute joints and the
# crank's rotation drive, 21 rows on 7 nodes. Joint `O1` is the crank's pivot: body $i$ the crank (a rigid
# body, its node at its centre of mass), body $j$ the ground:

# %%
import numpy as np

import reference
from reference.io.deck import load_deck
from reference.plain.model import Evaluation
from reference.rotation import EulerParameters, RotationVector

ROOT = Path(reference.__file__).resolve().parents[1]  # the repository, wherever the notebook runs from
bar = load_deck(ROOT / "models" / "three_bar.toml").domain
model = bar.initialization()  # the plain arrays the algorithms work on (model.joints: one row per joint)
start = bar.initial_conditions()
phi, B, phi_t = Evaluation(model).constraints(start.x, start.q, 0.0)  # Φ (m,), B (m × 6N, sparse), ∂Φ/∂t
print("rows of each joint:", {j.label: f"{j.kind}, {j.n_equations}" for j in bar.joints})

k = [j.label for j in bar.joints].index("O1")
rows = slice(model.joints.row0[k], model.joints.row0[k] + model.joints.neq[k])
i, j = model.joints.i[k], model.joints.j[k]
print(f"joint O1: primitives {model.joints.rows[k, :5].tolist()}, body i = node {bar.nodes[i].label!r}, "
      f"body j = {'the ground' if j < 0 else bar.nodes[j].label}; its ‖Φ‖ at t = 0: {np.linalg.norm(phi[rows]):.1e}")
print("B of joint O1 on [v_i | ω_i] of node i (rows: the spherical three, then the two dot-1):")
print(np.array2string(B[rows, 6 * i:6 * i + 6].toarray(), precision=4, suppress_small=True))

# %% [markdown]
# Its first three rows are the spherical joint's: $-I$ on $v_i$ and, on $\omega_i$, the formula sympy derived
# above, $A_i\tilde s'_i$, here with the crank's rotation $A_i$ and the pivot $s'_i$ stored in the crank's
# frame (`model.joints.par[k, 0:3]`, half the crank's length from its centre):

# %%
A_i = EulerParameters(start.q[i]).matrix()
values = {**dict(zip(A, A_i.reshape(-1))), **dict(zip(s, model.joints.par[k, 0:3]))}
derived = np.array(textbook.xreplace(values), dtype=float)
spherical_gap = float(np.abs(B[rows, 6 * i + 3:6 * i + 6].toarray()[:3] - derived).max())
print("A_i s̃'_i from the sympy cell:\n", np.array2string(derived, precision=4, suppress_small=True))
print("largest difference from the engine's rows:", spherical_gap)

# %% [markdown]
# And the whole $B$ (all five joints, all 42 columns) is the derivative of $\Phi$: moving each coordinate of
# each node by $\pm\epsilon$ (a rotation in the body frame, $q \leftarrow q\otimes\exp(\delta\theta)$) and
# differencing $\Phi$ gives its columns.

# %%
ev = Evaluation(model)


def moved(c, size):
    """Node positions and Euler parameters with coordinate c (6 per node: δx, then body-frame δθ) moved by size."""
    x, q, d = start.x.copy(), start.q.copy(), np.zeros(3)
    node, d[c % 3] = c // 6, size
    if c % 6 >= 3:
        q[node] = EulerParameters(q[node]).product(RotationVector(d).to_euler_parameters()).q
    else:
        x[node] += d
    return x, q


eps = 1e-6
fd_B = np.column_stack([(ev.constraints(*moved(c, eps), 0.0)[0] - ev.constraints(*moved(c, -eps), 0.0)[0]) / (2 * eps)
                        for c in range(B.shape[1])])
jacobian_gap = float(np.abs(fd_B - B.toarray()).max())
print(f"B is {B.shape[0]} × {B.shape[1]}; largest difference from central differences of Φ: {jacobian_gap:.1e}")

# %% tags=["check"] jupyter={"source_hidden": true}
assert spherical_gap < 1e-14  # the same formula evaluated twice: round-off of a 3 × 3 product
# central differences err by O(eps²) times Φ's third derivatives (lengths ~1 m) plus round-off ~1e-16 / eps
assert jacobian_gap < 1e-8

# %% [markdown]
# ## Lagrange multipliers on a spherical pendulum
# A rigid bar on a spherical joint to the ground, swinging around the vertical (a conical
# pendulum started off its steady cone, so it also nods). The constraint forces are $B^{\mathsf T}\lambda$;
# the stabilised multipliers (`docs/formulation.md` §7) solve
#
# $$\Big(B M^{-1}B^{\mathsf T} + \frac{\varepsilon}{h^2}I\Big)\lambda = \frac1h BV^* + \frac1{h^2}\Phi + \frac1h\Phi_t$$
#
# each step, which keeps $\|\Phi\|$ at one step's linearisation error, about $h^2v^2/(2l)$, instead of letting it drift.

# %%
import os

import matplotlib.pyplot as plt

from reference.domain import Domain, SolverSettings
from reference.interactions import Gravity

FIGURES = Path("figures") / "03_joints"  # this lesson's figures, saved next to where it runs
FIGURES.mkdir(parents=True, exist_ok=True)

QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
d = Domain("spherical pendulum")
th = np.radians(60.0)
com = 0.5 * np.array([np.sin(th), 0.0, -np.cos(th)])
R = RotationVector([0.0, np.pi / 2 - th, 0.0])
bar = d.add_rigid_body("bar", 1.0, [1e-3, 1 / 12, 1 / 12], com, rotation=R.to_euler_parameters().q)
d.add_joint("spherical", bar, None, [0.0, 0.0, 0.0])
d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
bar.velocity = np.cross([0.0, 0.0, 2.0], com)
bar.angular_velocity = R.matrix().T @ np.array([0.0, 0.0, 2.0])
d.solver = SolverSettings(dt=1e-3, t_end=5.0 if QUICK else 50.0, output_every=10)
r = d.solve()
c = r.position("bar")
E = r.energy["kinetic"] + 9.81 * c[:, 2]
print("max ‖Φ‖ = %.2e m, energy error = %.2e" % (r.constraint_violation.max(), abs(E - E[0]).max() / abs(E[0])))

fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.0, 3.8))
ax.plot(c[:, 0], c[:, 1], lw=0.8)
ax.set_aspect("equal")
ax.set_xlabel("x [m]")
ax.set_ylabel("y [m]")
ax.set_title("Figure 1 — centre of mass, top view", fontsize=10)
bx.semilogy(r.time[1:], r.constraint_violation[1:], label="‖Φ‖ [m]")
bx.semilogy(r.time[1:], np.abs(E[1:] - E[0]) / abs(E[0]) + 1e-17, label="|E − E(0)| / |E(0)| [–]")
bx.set_xlabel("time t [s]")
bx.set_ylabel("constraint violation, energy error")
bx.set_title("Figure 2 — bounded drift, conserved energy", fontsize=10)
bx.legend(fontsize=8)
plt.savefig(FIGURES / "figure1.png", dpi=120, bbox_inches="tight")
plt.show()

# %% tags=["check"] jupyter={"source_hidden": true}
assert r.constraint_violation.max() < 1e-5 and abs(E - E[0]).max() < 1e-3 * abs(E[0])

# %% [markdown]
# ## Exercises
# **Exercise 1.** A *dot-1* constraint keeps two body-fixed unit vectors perpendicular:
# $\Phi = a_i^{\mathsf T}a_j$ with $a = A a'$. Derive $\partial\Phi/\partial\omega_i$ with sympy as above and check it
# against the formula $(a_i\times a_j)^{\mathsf T}A_i$ of `docs/formulation.md` §5.
#
# **Exercise 2 (change the model and rerun).** Rerun the spherical pendulum with half the step,
# $h = 5\times10^{-4}$ s, over its first second. *What you should see:* the drift bound
# $h^2v^2/(2l)$ predicts the largest $\|\Phi\|$ to fall by about 4.
#
# Try them before you open the answers below (click the collapsed cells to show them).
#
# ## Answers

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 1
Aj = sp.Matrix(3, 3, lambda r, c: sp.Symbol(f"b_{r + 1}{c + 1}"))
ai, aj = sp.Matrix(sp.symbols("p_1:4")), sp.Matrix(sp.symbols("r_1:4"))
phi_dot1 = ((A * (sp.eye(3) + skew(dth)) * ai).T * (Aj * aj))[0]
derived = sp.Matrix([[sp.diff(phi_dot1, t) for t in dth]]).xreplace({t: 0 for t in dth})
# δΦ = (A δθ̃ a')ᵀ a_j = δθ · (a' × Aᵀ a_j); for a rotation matrix A (a' × Aᵀa_j) = Aᵀ(a_i × a_j)
formula = ai.cross(A.T * Aj * aj).T
assert sp.expand(derived - formula) == sp.zeros(1, 3)
Ar = sp.Matrix(RotationVector([0.3, -0.2, 0.5]).matrix())  # and with a real rotation: (a_i × a_j)ᵀ A_i
vals = {**dict(zip(A, Ar)), **dict(zip(Aj, sp.Matrix(RotationVector([-0.1, 0.4, 0.2]).matrix()))),
        **dict(zip(ai, [1, 0, 0])), **dict(zip(aj, [0, 1, 0]))}
assert (derived.xreplace(vals) - ((Ar * sp.Matrix([1, 0, 0])).cross(Aj.xreplace(vals) * sp.Matrix([0, 1, 0]))).T * Ar).norm() < 1e-12
print("exercise 1: the dot-1 row for ω_i is (a'_i × A_iᵀ a_j)ᵀ = (a_i × a_j)ᵀ A_i")

# %% tags=["solution", "rerun"] jupyter={"source_hidden": true}
# Exercise 2
peaks = []
for h in (1e-3, 5e-4):
    d2 = Domain("spherical pendulum")
    b2 = d2.add_rigid_body("bar", 1.0, [1e-3, 1 / 12, 1 / 12], com, rotation=R.to_euler_parameters().q)
    d2.add_joint("spherical", b2, None, [0.0, 0.0, 0.0])
    d2.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
    b2.velocity = np.cross([0.0, 0.0, 2.0], com)
    b2.angular_velocity = R.matrix().T @ np.array([0.0, 0.0, 2.0])
    d2.solver = SolverSettings(dt=h, t_end=1.0, output_every=1)
    peaks.append(d2.solve().constraint_violation.max())
print("max ‖Φ‖: h = 1e-3: %.2e, h = 5e-4: %.2e, ratio %.2f" % (*peaks, peaks[0] / peaks[1]))
assert 3.0 < peaks[0] / peaks[1] < 5.0
