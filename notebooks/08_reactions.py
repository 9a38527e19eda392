# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # Lesson 8 — Joint reactions from the Lagrange multipliers
#
# A joint does two things: it removes degrees of freedom, and it transmits forces. The
# multipliers that enforce the constraints *are* those forces. With the equations of motion
#
# $$M\,a + B^{\mathsf T}\lambda = Q, \qquad B = \frac{\partial \dot\Phi}{\partial V},$$
#
# the constraint forces on the nodes are $-B^{\mathsf T}\lambda$. The columns of $B$ are, node by
# node, $[v\ (\text{inertial}) \mid \omega\ (\text{body frame})]$, so for a joint with rows $r$
# acting on body $i$ (offset $s_i$ to the joint point, body-fixed)
#
# $$F_i = -B_{r,v_i}^{\mathsf T}\lambda_r, \qquad
#   M_{P} = A_i\left(-B_{r,\omega_i}^{\mathsf T}\lambda_r\right) - (A_i s_i)\times F_i .$$
#
# $F_i$ is the force the joint exerts on body $i$ and $M_P$ its moment about the joint point,
# both in inertial components. flexmbs writes them for every joint and every output
# (`/joints/reaction_force`, `/joints/reaction_moment`; `docs/results.md`), and a drive's
# reaction moment along its axis is the driving torque.
#
# This lesson checks them against Newton's laws on a pendulum, then uses them on the
# three-bar mechanism: the crank torque must deliver exactly the power the mechanism stores.

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import reference
from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.interactions import Gravity
from reference.io.deck import load_deck
from reference.observables import parse
from reference.rotation import EulerParameters

FIGURES = Path("figures") / "08_reactions"  # this lesson's figures, saved next to where it runs
FIGURES.mkdir(parents=True, exist_ok=True)

MODELS = Path(reference.__file__).resolve().parents[1] / "models"
QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
g = 9.81

# %% [markdown]
# ## 1. A falling pendulum
#
# A rigid bar (mass $m$, length $\ell$) pinned at one end by a revolute joint about $y$ and
# released from the horizontal. Let $\varphi$ be its angle below the horizontal and
# $J_P$ its moment of inertia about the pin. Energy and the moment equation about the pin give
#
# $$\dot\varphi^2 = \frac{2 m g r \sin\varphi}{J_P}, \qquad \ddot\varphi = \frac{m g r\cos\varphi}{J_P},
# \qquad r = \ell/2,$$
#
# and Newton's law for the centre of mass gives the pin force on the bar,
#
# $$F = m\,a_c - m\,\mathbf g, \qquad
#   a_c = r\ddot\varphi\,(-\sin\varphi, 0, -\cos\varphi) + r\dot\varphi^2(-\cos\varphi, 0, \sin\varphi).$$

# %%
m, ell = 1.0, 1.0
bar_section = Section(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0,
                      rhoA=m / ell, rhoJ1=1e-4, rhoJ2=1e-4, rhoJ3=1e-4)
pendulum = Domain("falling pendulum")
bar = pendulum.add_rigid_bar("bar", [0.0, 0.0, 0.0], [ell, 0.0, 0.0], bar_section)
pendulum.add_joint("revolute", bar, None, [0.0, 0.0, 0.0], axis=[0.0, 1.0, 0.0], label="pin")
pendulum.add_interaction(Gravity([0.0, 0.0, -g]))
pendulum.solver = SolverSettings(dt=1e-3, t_end=0.6 if QUICK else 1.2, output_every=5)
result = pendulum.solve()

r = ell / 2
J_P = bar.inertia[1, 1] + m * r**2  # about the pin: the centre's inertia about y plus m r²
c = result.position("bar")
phi = np.arctan2(-c[:, 2], c[:, 0])
phid2 = 2 * m * g * r * np.sin(phi) / J_P
phidd = m * g * r * np.cos(phi) / J_P
a_c = (r * phidd[:, None] * np.column_stack([-np.sin(phi), 0 * phi, -np.cos(phi)])
       + r * phid2[:, None] * np.column_stack([-np.cos(phi), 0 * phi, np.sin(phi)]))
F_closed = m * a_c + np.array([0.0, 0.0, m * g])
F_pin, M_pin = result.reaction("pin")

fig, ax = plt.subplots(figsize=(6.4, 3.6))
for k, name in ((0, "x"), (2, "z")):
    ax.plot(result.time, F_pin[:, k], label=f"$F_{name}$ from the multipliers")
    ax.plot(result.time, F_closed[:, k], "k:", label=f"$F_{name}$ Newton (closed form)")
ax.set_xlabel("t [s]")
ax.set_ylabel("pin force on the bar [N]")
ax.set_title("Figure 1 — falling pendulum: joint reaction against Newton's law")
ax.legend(fontsize=8)
fig.tight_layout()

err = np.max(np.linalg.norm(F_pin[1:] - F_closed[1:], axis=1)) / (m * g)
print(f"largest difference from the closed form after t = 0: {err:.1e} of the weight")
fig.savefig(FIGURES / "figure1.png", dpi=120, bbox_inches="tight")

# %% tags=["check"] jupyter={"source_hidden": true}
# O(h²): the central difference and the stabilised multipliers are second order (measured 8e-6 at h = 1e-3)
assert err < 1e-3

# %% [markdown]
# The moment of the pin about the pin itself has no $y$ component — a revolute joint about $y$
# cannot resist rotation about $y$ — but nothing stops it from having $x$ and $z$ components:
# here they are zero because the motion is planar and the bar's principal axes lie in and out of
# the plane.

# %%
print(f"max |M_y| = {np.max(np.abs(M_pin[:, 1])):.1e} N m,  max |M| = {np.max(np.linalg.norm(M_pin, axis=1)):.1e} N m")

# %% tags=["check"] jupyter={"source_hidden": true}
assert np.max(np.abs(M_pin[:, 1])) < 1e-9

# %% [markdown]
# ## 2. The three-bar mechanism: torque, power and pin forces
#
# The crank of `models/three_bar.toml` is driven by a `rotation_drive` — a one-equation joint
# that prescribes the crank's rotation. Its reaction moment about the axis is the torque the
# motor must deliver. With no loads and no gravity, the motor's power is the only energy input:
#
# $$\tau\,\omega_{\text{crank}} = \frac{d}{dt}\left(T + U\right).$$
#
# The same quantity can be named as an *observable* (`docs/observables.md`), the grammar the
# deck's `[crosscheck]` tables, `flexmbs plot --observable` and this lesson share.

# %%
three_bar = load_deck(MODELS / "three_bar.toml", overrides={"t_end": 2.0 if QUICK else 10.0}).domain
three_bar.solver.output_every = 5
tb = three_bar.solve()
torque_obs = parse("reaction_moment.z:crank drive", three_bar)
print(torque_obs.describe())
tau = torque_obs.evaluate(tb)
omega = np.array([EulerParameters(q).matrix() @ w for q, w in zip(tb.rotation("crank"), tb.angular_velocity("crank"))])
power = tau * omega[:, 2]
stored = tb.energy["kinetic"] + tb.energy["strain"]
rate = np.gradient(stored, tb.time)
work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(tb.time))])
balance = np.max(np.abs(work - (stored - stored[0]))) / np.max(np.abs(stored))
print(f"work of the crank torque − stored energy: {balance:.1e} of the peak stored energy")

fig, axes = plt.subplots(2, 1, figsize=(6.4, 5.4), sharex=True)
axes[0].plot(tb.time, tau, label=r"crank torque $\tau$")
axes[0].plot(tb.time, parse("reaction_force.norm:A", three_bar).evaluate(tb), label=r"$|F_A|$, pin A on the coupler [N]")
axes[0].set_ylabel("torque [N m] / force [N]")
axes[0].legend(fontsize=8)
axes[1].plot(tb.time, power, label=r"$\tau\,\omega$")
axes[1].plot(tb.time, rate, "k:", label=r"$d(T+U)/dt$")
axes[1].set_xlabel("t [s]")
axes[1].set_ylabel("power [W]")
axes[1].legend(fontsize=8)
axes[0].set_title("Figure 2 — three-bar: driving torque, pin force and the power balance")
fig.tight_layout()
fig.savefig(FIGURES / "figure2.png", dpi=120, bbox_inches="tight")

# %% tags=["check"] jupyter={"source_hidden": true}
# the integrated balance holds to the integrator's accuracy (output every 5 steps: trapezoid O(Δt²))
assert balance < 1e-3

# %% [markdown]
# The torque changes sign: over part of each revolution the mechanism gives energy back to the
# motor. The small ripple on top of the smooth curve is the flexible coupler's vibration; the
# cross-check (`flexmbs crosscheck models/three_bar.toml`) compares this torque and the force of
# pin A with Exudyn's own joint sensors.
#
# ## Exercises
#
# **Exercise 1.** For the falling pendulum of part 1, the pin force is largest at the bottom
# ($\varphi = 90°$). Show with the two formulas above that there $F = m g\,(1 + 2 m r^2 / J_P)$, which
# for a slender bar ($J_P = m\ell^2/3$) is $2.5\,m g$. Then run the pendulum long enough to pass
# the bottom and compare with the largest reaction the engine reports.
#
# **Exercise 2 (change the model and rerun).** Move the pin from the end of the bar to a quarter
# of its length (the bar from $x = -\ell/4$ to $3\ell/4$, the revolute joint still at the origin)
# and rerun part 1 past the bottom. *What you should see:* the same formula with $r = \ell/4$ and
# $J_P = m\ell^2/12 + m r^2$ predicts a smaller largest pin force, $\tfrac{13}{7}\,m g \approx 1.86\,m g$
# instead of $2.5\,m g$ — the centre of mass swings on a smaller circle.
#
# Try them before you open the answers below (click the collapsed cells to show them).
#
# ## Answers

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 1
prediction = m * g * (1 + 2 * m * r**2 / J_P)  # phi = 90°: phi_dot² = 2 m g r / J_P, phi_ddot = 0
longer = Domain("falling pendulum, to the bottom")
bar2 = longer.add_rigid_bar("bar", [0.0, 0.0, 0.0], [ell, 0.0, 0.0], bar_section)
longer.add_joint("revolute", bar2, None, [0.0, 0.0, 0.0], axis=[0.0, 1.0, 0.0], label="pin")
longer.add_interaction(Gravity([0.0, 0.0, -g]))
longer.solver = SolverSettings(dt=1e-3, t_end=1.2, output_every=1)
peak = np.max(np.linalg.norm(longer.solve().reaction("pin")[0], axis=1))
print(f"predicted {prediction:.4f} N, engine {peak:.4f} N, slender-bar value {2.5 * m * g:.4f} N")
assert abs(peak / prediction - 1) < 1e-3, "check the formula for F at the bottom"

# %% tags=["solution", "rerun"] jupyter={"source_hidden": true}
# Exercise 2
quarter = Domain("falling pendulum, pinned at a quarter")
bar3 = quarter.add_rigid_bar("bar", [-ell / 4, 0.0, 0.0], [3 * ell / 4, 0.0, 0.0], bar_section)
quarter.add_joint("revolute", bar3, None, [0.0, 0.0, 0.0], axis=[0.0, 1.0, 0.0], label="pin")
quarter.add_interaction(Gravity([0.0, 0.0, -g]))
quarter.solver = SolverSettings(dt=1e-3, t_end=1.2, output_every=1)
r_q = ell / 4
J_q = bar3.inertia[1, 1] + m * r_q**2
predicted_q = m * g * (1 + 2 * m * r_q**2 / J_q)
peak_q = np.max(np.linalg.norm(quarter.solve().reaction("pin")[0], axis=1))
print(f"pin at a quarter: predicted {predicted_q:.4f} N, engine {peak_q:.4f} N ({peak_q / (m * g):.3f} m g; 13/7 = {13 / 7:.3f})")
assert abs(peak_q / predicted_q - 1) < 1e-3  # as in exercise 1: O(h²) with h = 1e-3
