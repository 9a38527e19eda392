# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # Lesson 7 — Joined, kinked and curved beams
#
# A Beam2 element measures its curvature from the relative rotation of its two end triads,
# $\psi = \log(\Lambda_1^{\mathsf T}\Lambda_2)$, as $K = (\psi - \psi_0)/L_0$. That is exact when
# the element is straight at rest ($\psi_0 = 0$). When two beams share a node at an angle, the
# element next to the node would see a *kinked* reference ($\psi_0 \neq 0$). A small extra
# rotation $\delta$ then changes $\psi$ by $J_r(\psi_0)^{-1}\delta$, not by $\delta$, where
#
# $$J_r(\psi)^{-1} = I + \tfrac12\tilde\psi + \Big(\frac{1}{a^2} - \frac{1+\cos a}{2a\sin a}\Big)\tilde\psi^2,\qquad a = |\psi| ,$$
#
# and the element is too stiff by $|J_r(\psi_0)^{-1}\delta|^2/|\delta|^2$ in the directions normal to
# $\psi_0$: a strain measure that is not right for a kinked reference.
#
# The cure: every element is straight **in its own section frame**, and each end $a$ refers to it
# through a constant offset rotation $O_a$ from the node frame,
#
# $$\Lambda_a = A(q_a)\,O_a, \qquad O_a = A(q_a^0)^{\mathsf T}\Lambda_a^0 ,$$
#
# so the element always sees $\psi_0 = 0$ and $\Gamma_0 = E_1$. The node's rotary inertia is the
# sum of its elements' tensors turned into the node frame, $J = \sum O_a\,\mathrm{diag}(\rho J)\,O_a^{\mathsf T}\,L_0/2$.

# %%
import math
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import reference
from reference.domain import Domain
from reference.elements import Beam2Formulation, Section
from reference.elements.beam2 import beam2_assemble
from reference.interactions import Clamp, NodalLoad, SmoothStep
from reference.io.deck import load_deck
from reference.rotation import EulerParameters, RotationVector, right_jacobian_inverse

FIGURES = Path("figures") / "07_curved_beams"  # this lesson's figures, saved next to where it runs
FIGURES.mkdir(parents=True, exist_ok=True)

QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
MODELS = Path(reference.__file__).resolve().parents[1] / "models"
section = Section(EA=1e4, GA2=1e4, GA3=1e4, GJ=1.5, EI2=2.0, EI3=2.0, rhoA=1.0, rhoJ1=0.05, rhoJ2=0.05, rhoJ3=0.05)

# %% [markdown]
# ## 1. The kink, measured
# One element along $x$ whose node frames are turned by $\pm$kink/2 against it: the
# configuration next to a shared node. Rotate node 2 by $\delta$ about its body $x$ axis and read
# the curvature the engine computes; the old measure is evaluated from $J_r(\psi_0)^{-1}$.

# %%
def kink_ratio(kink_deg, delta=1e-6):
    d = Domain()
    a = math.radians(kink_deg)
    q1 = RotationVector([0, 0, -a / 2]).to_euler_parameters().q
    q2 = RotationVector([0, 0, a / 2]).to_euler_parameters().q
    n1, n2 = d.add_node([0.0, 0, 0], rotation=q1), d.add_node([0.5, 0, 0], rotation=q2)
    d.add_element(Beam2Formulation(section), (n1, n2), frames=([1.0, 0, 0, 0], [1.0, 0, 0, 0]))
    m = d.initialization()
    x = np.array([n1.position, n2.position])
    q = np.array([q1, EulerParameters(q2).product(RotationVector([delta, 0, 0]).to_euler_parameters()).q])
    S, s_el = np.zeros((2, 6)), np.zeros(40)
    b = m.elements[0]  # the Beam2 family's plain data (reference.elements.beam2.Beam2Data)
    beam2_assemble(x, q, b.conn, b.offset, b.L0, b.psi0, b.gamma0, b.stiff, S, s_el)
    new = np.linalg.norm(s_el[15:18]) * b.L0[0] / delta
    old = np.linalg.norm(right_jacobian_inverse([0, 0, a]) @ [1.0, 0, 0])
    return new, old


kinks = np.linspace(0.0, 150.0, 11)
ratios = np.array([kink_ratio(k) for k in kinks])
print("90° kink: |K| L0/δ with offsets %.9f, with K = (ψ − ψ0)/L0 %.4f" % kink_ratio(90.0))

fig, ax = plt.subplots(figsize=(5, 3))
ax.plot(kinks, ratios[:, 1] ** 2, "o-", label=r"$K=(\psi-\psi_0)/L_0$: energy factor")
ax.plot(kinks, ratios[:, 0] ** 2, "s-", label="section-frame offsets")
ax.set_xlabel("kink angle [deg]")
ax.set_ylabel(r"$|K|^2 L_0^2/\delta^2$")
ax.set_title("Figure 1 — bending stiffness next to a kinked node")
ax.legend()
plt.savefig(FIGURES / "figure1.png", dpi=120, bbox_inches="tight")
plt.show()

# %% tags=["check"] jupyter={"source_hidden": true}
assert np.all(np.abs(ratios[:, 0] - 1.0) < 1e-6)

# %% [markdown]
# ## 2. A curved beam: the quarter circle
# `add_beam(..., center=c)` (deck key `center`) meshes the shorter arc: nodes on the arc with
# their frames on the tangent, chords as elements. A cantilever on a quarter circle of radius $R$,
# clamped at one end, with a small out-of-plane tip force $P$: bending moment
# $M = PR\sin\beta$ and torque $T = PR(1-\cos\beta)$ at the angle $\beta$ from the tip, so by
# Castigliano
#
# $$w = PR^3\Big(\frac{\pi}{4EI} + \frac{3\pi/4 - 2}{GJ}\Big) + \frac{PR\,\pi}{2\,GA}.$$
#
# The static state is reached by damped dynamics (mass-proportional damping, load applied smoothly).

# %%
def quarter_circle(n, R=1.0, P=1e-3, T=15.0):
    d = Domain()
    arc = d.add_beam("arc", [R, 0, 0], [0, R, 0], n, section, axis2=(0, 0, 1.0), center=[0, 0, 0])
    d.add_interaction(Clamp(arc[0]))
    d.add_interaction(NodalLoad(arc[-1], np.array([0, 0, P]), time_function=SmoothStep(0.0, T / 5)))
    dt = 0.5 * d.critical_time_step()
    d.solver.dt, d.solver.t_end, d.solver.damping = T / math.ceil(T / dt), T, 4.0
    d.solver.output_every = 10**9
    return d.solve().position(arc[-1].label)[-1, 2]


EI, GJ, GA = section.EI2, section.GJ, section.GA3
exact = 1e-3 * (math.pi / (4 * EI) + (3 * math.pi / 4 - 2) / GJ) + 1e-3 * math.pi / (2 * GA)
meshes = [4, 8, 16] if QUICK else [4, 8, 16, 32]
errors = np.array([abs(quarter_circle(n) / exact - 1) for n in meshes])
orders = np.log2(errors[:-1] / errors[1:])
print("relative errors", errors, "observed orders", orders)

fig, ax = plt.subplots(figsize=(5, 3))
ax.loglog(meshes, errors, "o-", label="quarter circle, tip deflection")
ax.loglog(meshes, errors[0] * (meshes[0] / np.array(meshes)) ** 2, "--", label=r"$O(h^2)$")
ax.set_xlabel("elements")
ax.set_ylabel("relative error")
ax.set_title("Figure 2 — chords on the arc converge at second order")
ax.legend()
plt.savefig(FIGURES / "figure2.png", dpi=120, bbox_inches="tight")
plt.show()

# %% tags=["check"] jupyter={"source_hidden": true}
assert np.all(orders[1:] > 1.8)

# %% [markdown]
# ## 3. Large deflection: the 45° bend of Bathe & Bolourchi
# `models/curved_cantilever.toml`: radius 100, an eighth of a circle, clamped, a dead
# out-of-plane tip force held at 300, 450 and 600. The bend is built from two arcs joined at a
# node whose frame is deliberately off the tangent (the node keeps it; the offsets make the joint
# exact). Published tip positions of Simo & Vu-Quoc (1986) are marked.

# %%
deck = load_deck(MODELS / "curved_cantilever.toml")  # the Domain (deck.domain) and the deck's checks
res = deck.solve()
tip = res.position("arc2:8")
fig = plt.figure(figsize=(5.5, 4))
ax = fig.add_subplot(projection="3d")


def along(label):
    """Position of a node along the bend: arc1:0 … arc1:7, mid, arc2:1 … arc2:8."""
    if label == "mid":
        return 8
    beam, i = label.split(":")
    return int(i) + (8 if beam == "arc2" else 0)


order = np.argsort([along(lbl) for lbl in res.labels])
ax.plot(*res.positions[0][order].T, "-", color="gray", label="unloaded")
distances = {}  # the tip's distance from the published equilibrium, over the radius R = 100
for name in ("tip_300", "tip_450", "tip_600"):
    spec = deck.checks[name]
    k = int(np.argmin(np.abs(res.time - spec["at"])))
    ax.plot(*res.positions[k][order].T, "-o", ms=2, label=f"P = {name[4:]}")
    ax.scatter(*spec["value"], marker="x", color="k")
    distances[name] = np.linalg.norm(tip[k] - spec["value"]) / 100.0
    print(f"{name}: tip {tip[k].round(2)}, published {spec['value']}, distance {distances[name]:.2%} of R")
ax.set_title("Figure 3 — 45° bend, equilibria (× Simo & Vu-Quoc)")
ax.legend(fontsize=7)
plt.savefig(FIGURES / "figure3.png", dpi=120, bbox_inches="tight")
plt.show()

# %% tags=["check"] jupyter={"source_hidden": true}
assert all(distances[name] < deck.checks[name]["tolerance"] for name in distances)  # the deck's own tolerances

# %% [markdown]
# ## Exercises
# **Exercise 1.** Build a right-angle frame: two legs of length 1 along $x$ then $y$, **sharing** the
# corner node, clamped at the origin, with a small tip force $F$ along $z$. Beam theory gives
# $w = F\,(2L^3/3EI + L^3/GJ + 2L/GA)$ (each leg bends, the first also twists). Use
# `Domain.add_beam(..., start_node=...)` for the second leg (its `axis2` must not be along $y$),
# reach the static state as above, and check that the corner's rotary inertia is the sum of the two
# legs' tensors.
#
# **Exercise 2 (change the model and rerun).** Make the first leg of your frame twice as stiff in
# torsion ($GJ \to 2GJ$, leg 1 only) and rerun it. *What you should see:* only the twist term
# $FL^3/GJ$ changes — it halves — so the tip deflection falls from
# $F(2/3EI + 1/GJ + 2/GA)$ to $F(2/3EI + 1/2GJ + 2/GA)$ ($L = 1$), by about 30 %. (The answer
# reaches the static state with `algorithm = "static"`, lesson 2's Newton solution, which is quicker
# than damped dynamics.)
#
# Try them before you open the answers below (click the collapsed cells to show them).
#
# ## Answers

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 1
frame_section = Section(EA=1e4, GA2=1e4, GA3=1e4, GJ=2.0, EI2=2.0, EI3=2.0,
                        rhoA=1.0, rhoJ1=0.1, rhoJ2=0.05, rhoJ3=0.05)


def right_angle_frame(n=8, F=1e-3, T=15.0):
    d = Domain()
    leg1 = d.add_beam("leg1", [0.0, 0, 0], [1.0, 0, 0], n, frame_section)
    leg2 = d.add_beam("leg2", [1.0, 0, 0], [1.0, 1.0, 0], n, frame_section, axis2=(-1.0, 0, 0),
                      start_node=leg1[-1])
    d.add_interaction(Clamp(leg1[0]))
    d.add_interaction(NodalLoad(leg2[-1], np.array([0, 0, F]), time_function=SmoothStep(0.0, T / 5)))
    dt = 0.5 * d.critical_time_step()
    d.solver.dt, d.solver.t_end, d.solver.damping = T / math.ceil(T / dt), T, 4.0
    d.solver.output_every = 10**9
    return d, d.solve().position(leg2[-1].label)[-1, 2]


frame, w = right_angle_frame()
fs = frame_section
beam_theory = 1e-3 * (2 / (3 * fs.EI2) + 1 / fs.GJ + 2 / fs.GA3)
print(f"tip deflection {w:.6e}, beam theory {beam_theory:.6e}, relative {w / beam_theory - 1:+.2e}")
corner = frame.node("leg1:8").id
h = 1.0 / 8 / 2
print("corner inertia\n", frame.model.nodes.inertia[corner])
# leg 1 contributes diag(ρJ1, ρJ2, ρJ3) h about (x, y, z), leg 2 (along y) diag(ρJ2, ρJ1, ρJ3) h
assert np.allclose(frame.model.nodes.inertia[corner], np.diag([0.1 + 0.05, 0.05 + 0.1, 0.05 + 0.05]) * h, atol=1e-15)
assert abs(w / beam_theory - 1) < 5e-3   # 8 elements per leg: discretisation error about 0.15 %

# %% tags=["solution", "rerun"] jupyter={"source_hidden": true}
# Exercise 2
from dataclasses import replace  # noqa: E402

from reference.domain import SolverSettings  # noqa: E402


def static_frame(leg1_section, n=8, F=1e-3):
    d = Domain()
    leg1 = d.add_beam("leg1", [0.0, 0, 0], [1.0, 0, 0], n, leg1_section)
    leg2 = d.add_beam("leg2", [1.0, 0, 0], [1.0, 1.0, 0], n, frame_section, axis2=(-1.0, 0, 0), start_node=leg1[-1])
    d.add_interaction(Clamp(leg1[0]))
    d.add_interaction(NodalLoad(leg2[-1], np.array([0, 0, F])))
    d.solver = SolverSettings(algorithm="static", t_end=1.0, load_steps=1)
    return d.solve().position(leg2[-1].label)[-1, 2]


w_static, w_stiff = static_frame(frame_section), static_frame(replace(frame_section, GJ=2 * frame_section.GJ))
predicted_stiff = 1e-3 * (2 / (3 * fs.EI2) + 1 / (2 * fs.GJ) + 2 / fs.GA3)
print(f"static: GJ {w_static:.6e} (dynamic relaxation {w:.6e}); leg 1 with 2 GJ {w_stiff:.6e}, "
      f"beam theory {predicted_stiff:.6e}; deflection falls by {1 - w_stiff / w_static:.1%}")
assert abs(w_static / w - 1) < 1e-3  # the same equilibrium, by Newton and by damped dynamics
assert abs(w_stiff / predicted_stiff - 1) < 5e-3  # 8 elements per leg, as in exercise 1
