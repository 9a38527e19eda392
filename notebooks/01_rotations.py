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
# flexmbs has three parametrisations: **Euler parameters** (the engine's state: no
# singularity), the **rotation vector** ψ (axis × angle, the exponential map) and
# **Rodrigues parameters** (tan(a/2)·axis, infinite at a half turn).
#
# Conventions (stated once, in `reference/rotation.py`): Euler parameters scalar first;
# `A(q)` maps body components to inertial ones; angular velocities in the body frame.

# %%
import numpy as np

from reference.rotation import EulerParameters, RodriguesParameters, RotationVector, right_jacobian

psi = np.array([0.3, -1.2, 0.8])
R = RotationVector(psi)
q = R.to_euler_parameters()
print("rotation vector", psi, "angle", np.linalg.norm(psi))
print("Euler parameters", q.q)
print("Rodrigues", R.to(RodriguesParameters).g)

# %% [markdown]
# All three describe the same matrix. Composition is the quaternion product:
# `A(q ⊗ p) = A(q) A(p)`.

# %%
p = RotationVector([0.0, 0.0, 0.5]).to_euler_parameters()
assert np.allclose(q.product(p).matrix(), q.matrix() @ p.matrix(), atol=1e-14)
assert np.allclose(EulerParameters.from_matrix(R.matrix()).matrix(), R.matrix(), atol=1e-14)

# %% [markdown]
# ## Near a half turn
# Euler parameters and the rotation vector are fine at π; Rodrigues parameters are not.

# %%
half = RotationVector([0.0, 0.0, np.pi])
print("EP at pi:", half.to_euler_parameters().q)
try:
    half.to(RodriguesParameters)
except ValueError as err:
    print("Rodrigues:", err)

# %% [markdown]
# ## Updating Euler parameters: the trapezoidal (Cayley) rule
# The engine integrates `q̇ = ½ q ⊗ (0, ω)` with ω held over the step. The trapezoidal
# rule has a closed form, `q ⊗ p`, `p = (1 − h²|ω|²/16, (h/2) ω)/(1 + h²|ω|²/16)`:
# exactly unit, and equal to the exact `q ⊗ exp(hω)` up to third order in h|ω|.

# %%
w = np.array([2.0, -1.0, 0.5])
errors = []
for h in (0.04, 0.02, 0.01):
    cayley = q.cayley_update(w, h).q
    exact = q.product(RotationVector(h * w).to_euler_parameters()).q
    errors.append(np.linalg.norm(cayley - exact))
orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
print("errors", errors, "observed orders", orders)
assert np.all(np.abs(orders - 3.0) < 0.1)  # the lesson: third order

# %% [markdown]
# ## The tangent operator
# A small change δψ of the rotation vector is a body-frame rotation `J_r(ψ) δψ`:
# `exp((ψ + δψ)~) ≈ exp(ψ̃) exp((J_r δψ)~)` — the operator the Beam2 element uses for the
# exact variation of its relative rotation.

# %%
d = 1e-6 * np.array([1.0, 2.0, -1.0])
lhs = RotationVector.from_matrix(R.matrix().T @ RotationVector(psi + d).matrix()).psi
assert np.allclose(lhs, right_jacobian(psi) @ d, atol=1e-11)
print("J_r(psi) =\n", right_jacobian(psi))
