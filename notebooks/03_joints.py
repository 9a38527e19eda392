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
# A spherical joint keeps a point of body i on a point of body j:
# `Φ = x_j + A_j s'_j − x_i − A_i s'_i = 0`. The engine needs its velocity Jacobian B,
# `Φ̇ = B [v_i, ω_i, v_j, ω_j]`, with ω in the body frames. sympy derives it by perturbing
# `A → A (I + δθ̃)` and differentiating — here is that derivation, as in `derivations/joints.py`.

# %%
import sympy as sp

from derivations.rotation_maps import rotation_matrix, skew

xi, si = sp.Matrix(sp.symbols("x_i0:3")), sp.Matrix(sp.symbols("s_i0:3"))
qi = sp.symbols("e0 e1 e2 e3")
dth = sp.Matrix(sp.symbols("dtheta0:3"))
A = rotation_matrix(qi)
phi = -(xi + A * (sp.eye(3) + skew(dth)) * si)  # body i's side of the spherical joint
B_omega = phi.jacobian(dth).subs({d: 0 for d in dth})
print("∂Φ/∂ω_i =")
sp.pprint(sp.simplify(B_omega - A * skew(si)))  # the textbook result: +A_i s̃'_i

# %%
assert sp.simplify(B_omega - A * skew(si)) == sp.zeros(3, 3)

# %% [markdown]
# ## Lagrange multipliers on a pendulum
# A rigid bar on a spherical joint to the ground, spinning about the vertical. The
# stabilised multipliers keep ‖Φ‖ at the size of one step's linearisation error,
# `h² v²/(2l)`, and energy is conserved to second order.

# %%
import os

import numpy as np

from reference.domain import Domain, SolverSettings
from reference.interactions import Gravity
from reference.rotation import RotationVector

QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
d = Domain("spherical pendulum")
th = np.radians(60.0)
com = 0.5 * np.array([np.sin(th), 0.0, -np.cos(th)])
R = RotationVector([0.0, np.pi / 2 - th, 0.0])
bar = d.add_rigid_body("bar", 1.0, [1e-3, 1 / 12, 1 / 12], com, R.to_euler_parameters().q)
d.add_joint("spherical", bar, None, [0.0, 0.0, 0.0])
d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
bar.velocity = np.cross([0.0, 0.0, 2.0], com)
bar.angular_velocity = R.matrix().T @ np.array([0.0, 0.0, 2.0])
d.solver = SolverSettings(dt=1e-3, t_end=5.0 if QUICK else 50.0, output_every=50)
r = d.solve()
E = r.energy["kinetic"] + 9.81 * r.position("bar")[:, 2]
print("max ‖Φ‖ = %.2e, energy error = %.2e" % (r.constraint_violation.max(), abs(E - E[0]).max() / abs(E[0])))
assert r.constraint_violation.max() < 1e-5 and abs(E - E[0]).max() < 1e-3 * abs(E[0])
