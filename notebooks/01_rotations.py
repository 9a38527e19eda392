# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # Lesson 1 — Finite rotations and their parametrisations
#
# The paper's abstract `Rotation` class (§4.2.1, Fig. 3) hides *how* a rotation is stored.
# flexmbs has three parametrisations of the same rotation matrix $A \in SO(3)$:
#
# * **Euler parameters** $q = (e_0, \mathbf e)$, $|q| = 1$ — the engine's state, no singularity:
#
#   $$A(q) = (2e_0^2 - 1)\,I + 2\,(\mathbf e\mathbf e^{\mathsf T} + e_0\tilde{\mathbf e});$$
#
# * the **rotation vector** $\psi$ (axis × angle, $a = |\psi|$), the exponential map
#
#   $$A = \exp(\tilde\psi) = I + \frac{\sin a}{a}\tilde\psi + \frac{1-\cos a}{a^2}\tilde\psi^2;$$
#
# * **Rodrigues parameters** $g = \tan(a/2)\,\hat\psi$, infinite at a half turn.
#
# Conventions (stated once, in `reference/rotation.py`): Euler parameters scalar first;
# $A(q)$ maps body components to inertial ones; angular velocities in the body frame.
# The equations are collected in `docs/formulation.md` §1.

# %%
import numpy as np

from reference.rotation import EulerParameters, RodriguesParameters, RotationVector, right_jacobian

psi = np.array([0.3, -1.2, 0.8])
R = RotationVector(psi)
q = R.to_euler_parameters()
print("rotation vector", psi, "angle", np.linalg.norm(psi))
print("Euler parameters", q.q)
print("Rodrigues", R.to(RodriguesParameters).g)

# %% tags=["check"] jupyter={"source_hidden": true}
assert np.allclose(q.matrix(), R.matrix(), atol=1e-14) and np.allclose(q.matrix() @ q.matrix().T, np.eye(3), atol=1e-14)

# %% [markdown]
# Composition is the quaternion product, $A(q\otimes p) = A(q)\,A(p)$, with
# $q\otimes p = (q_0p_0 - \mathbf q\cdot\mathbf p,\; q_0\mathbf p + p_0\mathbf q + \mathbf q\times\mathbf p)$.
# Finite rotations do **not** commute: $q\otimes p \ne p\otimes q$ unless the axes are parallel.

# %%
p = RotationVector([0.0, 0.0, 0.5]).to_euler_parameters()
print("‖A(q⊗p) − A(p⊗q)‖ =", np.linalg.norm(q.product(p).matrix() - p.product(q).matrix()))

# %% tags=["check"] jupyter={"source_hidden": true}
assert np.allclose(q.product(p).matrix(), q.matrix() @ p.matrix(), atol=1e-14)

# %% [markdown]
# ## Near a half turn
# Along a rotation about a fixed axis, the Euler parameters stay bounded (they live on the
# unit sphere), the rotation vector grows linearly — and must jump from $\pi$ to $-\pi$ to stay
# on its principal branch — while the Rodrigues parameters blow up as $\tan(a/2)$.

# %%
from pathlib import Path

import matplotlib.pyplot as plt

FIGURES = Path("figures") / "01_rotations"  # this lesson's figures, saved next to where it runs
FIGURES.mkdir(parents=True, exist_ok=True)

angles = np.linspace(0.0, 1.98 * np.pi, 400)
axis = np.array([0.0, 0.6, 0.8])
ep = np.array([RotationVector(a * axis).to_euler_parameters().q for a in angles])
rv = np.array([np.linalg.norm(RotationVector.from_matrix(RotationVector(a * axis).matrix()).psi) for a in angles])
rodrigues = np.abs(np.tan(angles / 2))
fig, ax = plt.subplots(figsize=(6.4, 3.8))
ax.plot(np.degrees(angles), np.linalg.norm(ep, axis=1), label="‖q‖ (Euler parameters)")
ax.plot(np.degrees(angles), ep[:, 0], "--", label="e0 = cos(a/2)")
ax.plot(np.degrees(angles), rv, label="|ψ| from log(A), principal branch [rad]")
ax.plot(np.degrees(angles), np.minimum(rodrigues, 10), ":", label="|g| = |tan(a/2)| (clipped at 10)")
ax.set_xlabel("rotation angle a [deg]")
ax.set_ylabel("size of the parameters [–]")
ax.set_title("Figure 1 — three parametrisations along one axis")
ax.legend(fontsize=7)
plt.savefig(FIGURES / "figure1.png", dpi=120, bbox_inches="tight")
plt.show()

half = RotationVector([0.0, 0.0, np.pi])
print("Euler parameters at π:", half.to_euler_parameters().q)
try:
    half.to(RodriguesParameters)
except ValueError as err:
    print("Rodrigues parameters at π:", err)

# %% [markdown]
# ## Updating Euler parameters: the trapezoidal (Cayley) rule
# The engine integrates the kinematic equation $\dot q = \tfrac12\,q\otimes(0, \omega)$ with $\omega$
# (body frame) held over the step. The trapezoidal rule has a closed form,
#
# $$q^{n+1} = q^n\otimes p,\qquad p = \frac{\left(1 - h^2|\omega|^2/16,\ \tfrac h2\omega\right)}{1 + h^2|\omega|^2/16},$$
#
# exactly of unit norm and equal to the exact $q\otimes\exp(h\omega)$ up to third order in $h|\omega|$
# (`docs/formulation.md` §8). Figure 2 measures that order.

# %%
w = np.array([2.0, -1.0, 0.5])
steps = np.array([0.16, 0.08, 0.04, 0.02, 0.01])
errors = []
for h in steps:
    cayley = q.cayley_update(w, h).q
    exact = q.product(RotationVector(h * w).to_euler_parameters()).q
    errors.append(np.linalg.norm(cayley - exact))
errors = np.array(errors)
orders = np.log2(errors[:-1] / errors[1:])
print("observed orders", orders)

fig, ax = plt.subplots(figsize=(5.4, 3.8))
ax.loglog(steps, errors, "o-", label="‖Cayley − exact‖")
ax.loglog(steps, errors[0] * (steps / steps[0]) ** 3, "k--", lw=0.8, label="slope 3")
ax.set_xlabel("time step h [s] (|ω| = 2.29 rad/s)")
ax.set_ylabel("error of one update [–]")
ax.set_title("Figure 2 — the Cayley update is third order per step")
ax.legend(fontsize=8)
plt.savefig(FIGURES / "figure2.png", dpi=120, bbox_inches="tight")
plt.show()

# %% tags=["check"] jupyter={"source_hidden": true}
assert np.all(np.abs(orders - 3.0) < 0.1)
assert abs(np.linalg.norm(q.cayley_update(w, 0.3).q) - 1.0) < 1e-15  # unit norm, exactly

# %% [markdown]
# ## The tangent operator
# A small change $\delta\psi$ of the rotation vector is a body-frame rotation $J_r(\psi)\,\delta\psi$:
#
# $$\exp(\widetilde{\psi+\delta\psi}) \approx \exp(\tilde\psi)\,\exp(\widetilde{J_r\delta\psi}),\qquad
# J_r(\psi) = I - \frac{1-\cos a}{a^2}\tilde\psi + \frac{a-\sin a}{a^3}\tilde\psi^2$$
#
# — the operator the Beam2 element uses for the exact variation of its relative rotation.

# %%
d = 1e-6 * np.array([1.0, 2.0, -1.0])
lhs = RotationVector.from_matrix(R.matrix().T @ RotationVector(psi + d).matrix()).psi
print("J_r(ψ) =\n", right_jacobian(psi))

# %% tags=["check"] jupyter={"source_hidden": true}
assert np.allclose(lhs, right_jacobian(psi) @ d, atol=1e-11)

# %% [markdown]
# ## Exercises
# **Exercise 1.** Write the Euler parameters of a rotation of 120° about $(1,1,1)/\sqrt3$ by hand
# ($e_0 = \cos 60°$, $\mathbf e = \sin 60°\,\hat n$) and check that it permutes the axes
# $x\to y\to z\to x$.
#
# **Exercise 2.** Updating with the *explicit* Euler rule $q^{n+1} = q^n + \tfrac h2\,q^n\otimes(0,\omega)$
# leaves the unit sphere. Over one turn at $|\omega| = 1$ rad/s with $h = 0.01$ s, how far does $|q|$
# drift? Predict it (each step multiplies $|q|^2$ by the same factor) and check by iterating.
#
# **Exercise 3 (change the model and rerun).** In the cell of Figure 2, double the angular
# velocity `w` and rerun it. *What you should see:* the error line moves up by a factor
# $2^3 = 8$ and keeps its slope 3 — the update depends on $h\omega$ only, so doubling $\omega$ at
# step $h$ gives exactly the error of the old $\omega$ at step $2h$.
#
# Try them before you open the answers below (click the collapsed cells to show them).
#
# ## Answers

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 1
n = np.ones(3) / np.sqrt(3.0)
q120 = EulerParameters(np.concatenate([[np.cos(np.pi / 3)], np.sin(np.pi / 3) * n]))
A120 = q120.matrix()
assert np.allclose(A120 @ [1, 0, 0], [0, 1, 0], atol=1e-14) and np.allclose(A120 @ [0, 1, 0], [0, 0, 1], atol=1e-14)
print("exercise 1: q =", q120.q.round(6), "maps x to y and y to z")

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 2: |q ⊗ (0, ω)| = |q| |ω|, orthogonal to q, so each step multiplies |q|² by 1 + h²|ω|²/4:
# after N = 2π/h steps |q| − 1 = (1 + h²|ω|²/4)^(N/2) − 1, about 8e-3 — the Cayley update stays at round-off.
h, omega = 0.01, np.array([0.0, 0.6, 0.8])
qe = np.array([1.0, 0.0, 0.0, 0.0])
N = int(round(2 * np.pi / h))
for _ in range(N):
    qe = qe + 0.5 * h * np.array([-qe[1:] @ omega, *(qe[0] * omega + np.cross(qe[1:], omega))])  # q ⊗ (0, ω)
drift = np.linalg.norm(qe) - 1.0
predicted = (1 + h**2 / 4) ** (N / 2) - 1
print(f"explicit Euler: |q| − 1 = {drift:.3e} (predicted {predicted:.3e})")
assert abs(drift - predicted) < 1e-3 * predicted

# %% tags=["solution", "rerun"] jupyter={"source_hidden": true}
# Exercise 3: Figure 2 again with 2ω
errors_2w = np.array([np.linalg.norm(q.cayley_update(2 * w, h).q
                                     - q.product(RotationVector(h * 2 * w).to_euler_parameters()).q) for h in steps])
print("error ratio (2ω : ω) at each step:", (errors_2w / errors).round(3))
print("observed orders with 2ω:", np.log2(errors_2w[:-1] / errors_2w[1:]).round(3))
assert abs(errors_2w[-1] / errors[-1] - 8.0) < 0.1  # (h|ω|)³: 8 at the smallest step
assert np.allclose(errors_2w[1:], errors[:-1], rtol=1e-6)  # 2ω at h is ω at 2h
