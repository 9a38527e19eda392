# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # Lesson 10 — Vibration modes, linear buckling and what happens after it
#
# About an equilibrium the equations of motion, linearised in the small increments $\boldsymbol\delta$
# (displacements and rotation increments) and reduced to the motions the joints allow
# ($\boldsymbol\delta = \mathbf Z\boldsymbol\eta$, $\mathbf B\mathbf Z = 0$), are
# $\mathbf M\ddot{\boldsymbol\eta} + \mathbf K\boldsymbol\eta = 0$. Trying
# $\boldsymbol\eta = \boldsymbol\phi\, e^{i\omega t}$ gives the **generalized eigenproblem**
#
# $$\mathbf K\,\boldsymbol\phi = \omega^2\,\mathbf M\,\boldsymbol\phi ,$$
#
# whose eigenvalues $\omega^2$ are the squared natural frequencies and whose eigenvectors are the mode
# shapes. $\mathbf K$ is the derived tangent the implicit algorithms already use — material stiffness,
# geometric stiffness of the pre-stress, the joints' $\lambda\cdot\partial\mathbf B^{\mathsf T}$ term — so a
# pendulum's gravity stiffness and a column's loss of stiffness under thrust are in it.
# `algorithm = "modes"` solves it (docs/formulation.md §11); `algorithm = "buckling"` asks instead for
# the load factor $\mu$ at which $\mathbf K$ itself becomes singular.
#
# Every job of this lesson is short: one eigenproblem, or a few load steps and one. Each runs with
# `backend = "auto"`, which takes the **reference path** (the same equations in plain NumPy,
# `docs/reference_path.md`) when its estimated run time is at most 15 s: the results are the compiled
# path's to the Newton tolerance, and the lesson does not wait minutes for numba to compile the kernels
# of the implicit algorithms on its first run.

# %%
import os
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipk

import reference
from flexmbs.verification import analytic
from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.interactions import Clamp, Gravity, NodalLoad, Ramp
from reference.validation import ModelWarning

FIGURES = Path("figures") / "10_modes_buckling"  # this lesson's figures, saved next to where it runs
FIGURES.mkdir(parents=True, exist_ok=True)

QUICK = os.environ.get("FLEXMBS_QUICK") == "1"
MODELS = Path(reference.__file__).resolve().parents[1] / "models"
AUTO = {"solver.backend": "auto"}  # short jobs on the reference path: nothing to compile (docs/reference_path.md)

SLENDER = Section(EA=1e7, GA2=1e7, GA3=1e7, GJ=0.8, EI2=1.0, EI3=4.0, rhoA=1.0, rhoJ1=2e-6, rhoJ2=1e-8, rhoJ3=4e-8)
"""An Euler–Bernoulli-like beam: shear and rotary inertia move its third bending mode by < 3e-5."""


def cantilever(n):
    """A cantilever of length 1 along x, clamped at x = 0, n Beam2 elements: ``(domain, nodes)``."""
    d = Domain("cantilever")
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), n, SLENDER)
    d.add_interaction(Clamp(nodes[0]))
    return d, nodes


# %% [markdown]
# ## 1. A cantilever against Euler–Bernoulli
#
# The clamped–free Euler–Bernoulli beam vibrates at $\omega_k = (\beta_k L)^2\sqrt{EI/(\rho A L^4)}$ with
# $\beta L = 1.8751, 4.6941, 7.8548$ the roots of $\cos\beta L\cosh\beta L = -1$. flexmbs lumps each
# element's mass onto its two nodes. A lumped linear element underestimates a wave's frequency by
# $(kh)^2/24$ for wave number $k$ and element length $h$: the error falls **four times per halving of the
# element** (order 2), as for the consistent mass matrix, which overestimates by about as much
# (Strang & Fix 1973, §6.3) — a lumped matrix is diagonal and cheap, and its error is of the same order.
#
# The solver returns the modes in order of frequency, of every kind: bending in either plane, torsion,
# extension. To compare like with like, each mode is named by the motion that carries most of its kinetic
# energy: the largest of $\sqrt{\rho A}\,|u_x|$, $\sqrt{\rho A}\,|u_y|$, $\sqrt{\rho A}\,|u_z|$ and
# $\sqrt{\rho J_1}\,|\theta_x|$ over the nodes (the bending rotations follow their translations).

# %%
def families(shapes, section):
    """Each mode's family (a beam along x): "axial", "bending y", "bending z" or "torsion", by the largest
    mass-weighted amplitude of its shape (modes/shape: per mode, per node, 3 displacements and 3 rotations)."""
    weights = np.array([np.sqrt(section.rhoA)] * 3 + [np.sqrt(section.rhoJ1)])
    amplitude = np.abs(shapes[:, :, :4]).max(axis=1) * weights  # (modes, 4): u_x, u_y, u_z, θ_x
    return np.array(["axial", "bending y", "bending z", "torsion"])[amplitude.argmax(axis=1)]


meshes = (16, 32) if QUICK else (16, 32, 64, 128)
errors = {}
for n in meshes:
    d, _ = cantilever(n)
    d.solver = SolverSettings(algorithm="modes", modes=8, backend="auto")
    r = d.solve()
    kind = families(r.data("modes/shape"), SLENDER)
    w = 2 * np.pi * r.data("modes/frequency")[kind == "bending z"][:3]
    exact = np.array(analytic.CANTILEVER_BETA_L[:3]) ** 2 * np.sqrt(SLENDER.EI2 / SLENDER.rhoA)
    errors[n] = w / exact - 1
    print(f"{n:4d} elements: bending towards z, relative errors", "  ".join(f"{e:+.2e}" for e in errors[n]))
order = np.log2(np.abs(errors[meshes[-2]] / errors[meshes[-1]]))
print("observed order", np.round(order, 2))

# %% tags=["check"] jupyter={"source_hidden": true}
# the lumped Beam2 mesh error at 32 elements: measured -2.6e-4, -2.4e-4, +6.0e-4 (docs/formulation.md §11)
assert np.all(np.abs(errors[32]) < 1e-3)
# second order: the ratio of successive errors is 4 up to higher-order terms (measured 1.9-2.1)
assert np.all((order > 1.8) & (order < 2.2)), order

# %%
fig, ax = plt.subplots(figsize=(5.4, 3.4))
for k in range(3):
    ax.loglog(meshes, [abs(errors[n][k]) for n in meshes], "o-", label=f"mode {k + 1}")
ax.loglog(meshes, [3e-4 * (32 / n) ** 2 for n in meshes], "k:", label="slope 2")
ax.set_xlabel("elements")
ax.set_ylabel("|relative frequency error|")
ax.legend(fontsize=8)
ax.set_title("Figure 1: bending frequencies of a cantilever converge at order 2")
fig.tight_layout()
fig.savefig(FIGURES / "figure1.png", dpi=120, bbox_inches="tight")

# %% [markdown]
# The ten modes of `models/cantilever_modes.toml` (32 elements, bending stiffness 1 towards z and 4 towards y)
# in 3D: pick a mode in the list, play it, drag to turn the beam, shift-drag to pan, the wheel zooms.
# `flexmbs view out/cantilever_modes/results.h5` writes the same view as one HTML file that works offline.

# %%
import tempfile

from flexmbs.view import Show
from reference.io.deck import load_deck

scratch = Path(tempfile.mkdtemp(prefix="lesson10-"))
load_deck(MODELS / "cantilever_modes.toml", overrides=AUTO).solve(results_path=scratch / "cantilever_modes.h5")
Show(scratch / "cantilever_modes.h5")

# %% [markdown]
# ## 2. A mechanism: the double pendulum
#
# Two uniform rigid bars (length 1, mass 1) hang on revolute joints. Linearising Lagrange's equations in
# the two absolute angles gives a $2\times2$ problem with $\mathbf K = g\,\mathrm{diag}(m_1c_1 + m_2l_1,\ m_2c_2)$
# (`flexmbs.verification.analytic.double_pendulum_frequencies`). flexmbs knows nothing of angles: it
# linearises 12 coordinates with 10 constraint equations, and gravity's stiffness reaches the two free
# motions only through the joints' term $\lambda\cdot\partial\mathbf B^{\mathsf T}$ — the multipliers are the
# bars' weights. Without gravity nothing resists the two motions: they become **zero modes**, and their
# number equals the **mobility** $6\times\text{bodies} - \operatorname{rank}\mathbf B$ = 2.

# %%
def double_pendulum(gravity):
    bar = Section(EA=1.0, GA2=1.0, GA3=1.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=0.02, rhoJ2=0.01, rhoJ3=0.01)
    d = Domain("double pendulum")
    upper = d.add_rigid_bar("upper", (0, 0, 0), (0, 0, -1), bar)
    lower = d.add_rigid_bar("lower", (0, 0, -1), (0, 0, -2), bar)
    d.add_joint("revolute", upper, None, (0, 0, 0), axis=(0, 1, 0))
    d.add_joint("revolute", lower, upper, (0, 0, -1), axis=(0, 1, 0))
    if gravity:
        d.add_interaction(Gravity((0.0, 0.0, -9.81)))
    d.solver = SolverSettings(algorithm="modes", modes=2, backend="auto")
    return d


r = double_pendulum(True).solve()
J = 0.01 + 1.0 / 12.0  # each bar's inertia about its centre: ρJ2 L + ρA L³/12
w_exact, _ = analytic.double_pendulum_frequencies(1.0, 0.5, J, 1.0, 1.0, 0.5, J, 9.81)
w = 2 * np.pi * r.data("modes/frequency")
print("ω flexmbs    ", w, "rad/s\nω Lagrange   ", w_exact, "rad/s")
print("mobility", int(r.data("modes/mobility")), " zero modes", int(r.data("modes/zero_modes")))

free = double_pendulum(False).solve()
print("without gravity:", [str(k) for k in free.data("modes/kind")], " mobility", int(free.data("modes/mobility")))

# %% tags=["check"] jupyter={"source_hidden": true}
# rigid bodies, no mesh: the same linear equations in other coordinates, equal to round-off (1e-9)
assert np.allclose(w, w_exact, rtol=1e-9, atol=0.0)
assert int(r.data("modes/mobility")) == 2 and int(r.data("modes/zero_modes")) == 0
assert int(free.data("modes/zero_modes")) == int(free.data("modes/mobility")) == 2

# %% [markdown]
# ## 3. Centrifugal stiffening: a spinning cantilever
#
# Spin the cantilever about an axis through its clamped root, perpendicular to it, at a constant rate
# $\Omega$. In the frame that spins with it the beam is at rest, stretched by the centrifugal force
# $\rho A\Omega^2 x$: a **relative equilibrium**. `about = "rotation"` (deck keys `spin_rate`, `spin_axis`,
# `spin_point`) finds it by Newton and linearises there, in the spinning frame, where the perturbations feel
# the Coriolis force $2\mathbf M\tilde\Omega\dot{\mathbf u}$ (a gyroscopic, skew damping matrix) and the centrifugal
# $\mathbf M\tilde\Omega^2\mathbf u$ (docs/formulation.md §11). The tension $T(x) = \rho A\Omega^2(L^2 - x^2)/2$ stiffens the
# bending out of the plane of rotation (**flap**); in the plane (**lead-lag**) the centrifugal force also pulls
# the deflected beam outward, which cancels $\Omega^2$ of it: $\omega_\text{lag}^2 = \omega_\text{flap}^2 - \Omega^2$ for the
# uniform beam. The published flapwise frequencies (Hodges & Rutkowski 1981), in $\bar\omega = \omega\sqrt{\rho AL^4/EI}$
# against $\lambda = \Omega\sqrt{\rho AL^4/EI}$ — here $EI = \rho A = L = 1$, so rad/s are the table's units.
#
# The solver does this when the deck (or `SolverSettings`) says `about = "rotation"` with a `spin_rate` and a
# `spin_axis`: the shapes it returns are then complex (the Coriolis coupling puts the lead-lag motion a
# quarter period out of phase with the stretching), stored as `modes/shape` and `modes/shape_imaginary`. A mode
# is flapwise when its displacements along the spin axis $z$ are larger than those along $y$.

# %%
from flexmbs.verification.analytic import ROTATING_CANTILEVER_FLAP

ROUND = Section(EA=1e7, GA2=1e7, GA3=1e7, GJ=0.8, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-6, rhoJ2=1e-8, rhoJ3=1e-8)


def blade(n):
    """A round cantilever of length 1 along x, clamped at the origin, n Beam2 elements."""
    d = Domain("spinning cantilever")
    nodes = d.add_beam("blade", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), n, ROUND, axis2=(0.0, 1.0, 0.0))
    d.add_interaction(Clamp(nodes[0]))
    return d


def first_modes(d, rate):
    """The first flapwise and lead-lag frequencies ω̄ of ``d`` spinning at ``rate`` about z through the root, and
    the largest damping ratio of the two lowest modes (one of each family)."""
    d.solver = SolverSettings(algorithm="modes", modes=2, about="rotation", spin_rate=rate, spin_axis=(0.0, 0.0, 1.0),
                              backend="auto")
    r = d.solve()
    shape = np.abs(r.data("modes/shape"))
    imaginary = r.data("modes/shape_imaginary")  # written when the problem is gyroscopic (Ω ≠ 0)
    if imaginary.shape == shape.shape:
        shape = shape + np.abs(imaginary)
    amplitude = shape[:, :, :3].max(axis=1)  # (modes, 3): the largest |u_x|, |u_y|, |u_z| over the nodes
    flapwise = amplitude[:, 2] >= amplitude[:, 1]  # flap is along the spin axis z, lead-lag along y
    w = 2 * np.pi * r.data("modes/frequency")  # EI = ρA = L = 1: ω in rad/s is the table's ω̄
    return float(w[flapwise][0]), float(w[~flapwise][0]), float(np.max(np.abs(r.data("modes/damping_ratio"))))


rates = [0.0, 6.0, 12.0] if QUICK else [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0]
flap, lag, zeta = zip(*(first_modes(blade(16), rate) for rate in rates))
published = np.array([ROTATING_CANTILEVER_FLAP[int(r)][0] for r in rates])
for rate, f, g, p in zip(rates, flap, lag, published):
    print(f"λ = {rate:4.1f}: flap {f:8.4f} (published {p:.4f}, {f / p - 1:+.1e})   "
          f"lag {g:8.4f} (√(ω̄² − λ²) = {np.sqrt(p**2 - rate**2):.4f})")
print(f"largest damping ratio {max(zeta):.1e}: no damping anywhere, the gyroscopic roots are imaginary")

# %% tags=["check"] jupyter={"source_hidden": true}
# 16 elements: the second-order mesh error of the first mode, measured -1.0e-3 (λ = 0) to -2.5e-4 (λ = 12) flap,
# -1.0e-3 to -1.4e-3 lead-lag; 2e-3 bounds it (32 elements quarter it: the report's 0.5 % check)
assert np.all(np.abs(np.array(flap) / published - 1) < 2e-3)
assert np.all(np.abs(np.array(lag) / np.sqrt(published**2 - np.array(rates) ** 2) - 1) < 2e-3)
# no damping anywhere: the gyroscopic problem's roots are imaginary
assert max(zeta) < 1e-9

# %%
fig, ax = plt.subplots(figsize=(5.4, 3.4))
ax.plot(rates, flap, "o-", label="flap (out of plane)")
ax.plot(rates, lag, "s-", label="lead-lag (in plane)")
ax.plot(rates, published, "k+", ms=10, label="Hodges & Rutkowski 1981")
ax.plot(rates, rates, ":", color="0.5", label="1P: ω = Ω")
ax.set_xlabel("spin rate λ")
ax.set_ylabel("first frequency ω̄")
ax.legend(fontsize=8)
ax.set_title("Figure 2: a Campbell diagram (flexmbs campbell DECK --rates 0:12:13)")
fig.tight_layout()
fig.savefig(FIGURES / "figure2.png", dpi=120, bbox_inches="tight")

# %% [markdown]
# ## 4. Linear buckling of an Euler column
#
# A cantilever column under a compressive dead tip load $P$ buckles at $P_\text{cr} = \pi^2 EI/(4L^2)$.
# Pre-stress changes the tangent: $\mathbf K(P) \approx \mathbf K_0 + \mu\,\mathbf K_g$, with the geometric
# stiffness $\mathbf K_g$ of the reference load. The structure loses its stiffness at the lowest $\mu$ with
#
# $$(\mathbf K_0 + \mu\,\mathbf K_g)\,\boldsymbol\phi = 0 ,$$
#
# and $\mu P$ is the critical load. `algorithm = "buckling"` takes $\mathbf K_g$ as the change of the tangent
# between the static equilibria at $t = 0$ and at `t_end` (load factor 1). Beam2's one-point integration
# makes the column slightly too stiff: its buckling load lies above $\pi^2EI/(4L^2)$ by $(kh)^2/6$,
# $k = \pi/(2L)$ — second order again.

# %%
P_cr = np.pi**2 * SLENDER.EI2 / 4.0


def column(n, algorithm="buckling", t_end=1.0, steps=1, imperfection=0.0):
    """The cantilever as a column: a dead tip force −P_cr along x (times the load factor t, a ramp), plus
    ``imperfection`` × P_cr across it along z."""
    d, nodes = cantilever(n)
    d.add_interaction(NodalLoad(nodes[-1], (-P_cr, 0.0, imperfection * P_cr),
                                time_function=Ramp(0.0, 10.0, 0.0, 10.0)))
    d.solver = SolverSettings(algorithm=algorithm, modes=2, t_end=t_end, load_steps=steps, backend="auto")
    return d


factors = {}
for n in (16, 32):
    factors[n] = column(n).solve().data("buckling/load_factor")
    expected = (np.pi / 2 / n) ** 2 / 6
    print(f"{n} elements: load factors {factors[n].round(6)}; error {factors[n][0] - 1:+.3e}, (kh)²/6 = {expected:.3e}"
          "; the second factor is the stiff plane's (EI3 = 4 EI2)")

# %% tags=["check"] jupyter={"source_hidden": true}
# Beam2's error is (kh)²/6 to within 5 % (its next terms are of order (kh)⁴); the second factor is the other plane
for n, mu in factors.items():
    assert abs((mu[0] - 1) / ((np.pi / 2 / n) ** 2 / 6) - 1) < 0.05 and abs(mu[1] / (4 * mu[0]) - 1) < 1e-6

# %% [markdown]
# `models/lateral_buckling.toml` is the harder case: a cantilever loaded at the tip across its stiff plane
# buckles sideways and twists (lateral–torsional buckling, $4.0126\sqrt{EI_\text{lat}GJ}/L^2$ for an
# infinitely stiff plane; 1.2 % more at a stiffness ratio 1 : 100, through the pre-buckling bending).

# %%
lateral = load_deck(MODELS / "lateral_buckling.toml", overrides=AUTO).solve(results_path=scratch / "lateral_buckling.h5")
mu = lateral.data("buckling/load_factor")
exact = analytic.lateral_buckling_cantilever(100.0, 1.0, 1.0, 1.0)
print(f"lateral buckling: P_cr = {4 * mu[0]:.5f} N, rod bifurcation {exact:.5f} N ({4 * mu[0] / exact - 1:+.1e})")

# %% tags=["check"] jupyter={"source_hidden": true}
assert abs(4 * mu[0] / exact - 1) < 2e-3  # 32 elements' second-order error, measured +7.5e-4 (the deck's check)

# %% [markdown]
# Its buckling modes in 3D: turn the view to see the tip move sideways out of the plane of the load (the
# static path to the reference load is the last entry of the list).

# %%
Show(scratch / "lateral_buckling.h5")

# %% [markdown]
# ## 5. Past the critical load
#
# Linear buckling says where the straight equilibrium stops being stable, not what happens next. The static
# algorithm follows the equilibrium path; at every load level it counts the **negative eigenvalues of the
# reduced tangent** $\mathbf K_r$. A negative eigenvalue is a direction $\boldsymbol\phi$ with
# $\boldsymbol\phi^{\mathsf T}\mathbf K_r\boldsymbol\phi < 0$: moving along it *releases* energy, so the
# equilibrium is not a minimum of the potential energy — it is unstable, even though Newton's method
# converges to it. The count comes from an $\mathbf L\mathbf D\mathbf L^{\mathsf T}$ factorisation (Sylvester's
# law of inertia: as many negative pivots as negative eigenvalues).
#
# A **perfect** column loaded to $1.5\,P_\text{cr}$ stays straight — the symmetric problem has no reason
# to leave the trivial branch — but the indicator sees one negative eigenvalue once $P > P_\text{cr}$ and
# says so in one line, with the critical load interpolated from the lowest eigenvalue.

# %%
steps = 15
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    perfect = column(16, "static", 1.5, steps).solve()
lines = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
print("\n".join(lines))
count = perfect.data("stability/negative_eigenvalues")
critical = perfect.data("stability/critical_load_factor")
print("negative eigenvalues per load level:", count.astype(int))
print("straight? max |tip z| =", np.max(np.abs(perfect.position("beam:end")[:, 2])))

# %% tags=["check"] jupyter={"source_hidden": true}
assert len(lines) == 1 and "bifurcation, 1 negative eigenvalue" in lines[0]
# load levels 0, 0.1, ..., 1.5: stable up to 1.0, one negative eigenvalue from 1.1 on
assert list(count) == [0] * 11 + [1] * 5
# the interpolated critical load is Beam2's buckling load at 16 elements (+1.6e-3) to the linear
# interpolation's error over a step of 0.1 (measured 2e-4)
assert abs(critical[0] - column(16).solve().data("buckling/load_factor")[0]) < 1e-3

# %% [markdown]
# A column with a small **imperfection** (a lateral force of $10^{-3}P$) leaves the straight line near
# $P_\text{cr}$ and follows the post-buckling branch, the *elastica*, which is stable: no negative
# eigenvalue anywhere. The inextensible elastica of the cantilever column (Timoshenko & Gere 1961, §2.7)
# with $p = \sin(\alpha/2)$ ($\alpha$ the tip rotation) has
# $P/P_\text{cr} = \bigl(2K(p)/\pi\bigr)^2$ and tip deflection $\delta/L = 2p/K(p)$ — it grows quickly just
# past $P_\text{cr}$ and the load rises only slowly after.

# %%
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    bent = column(16, "static", 1.5, steps, imperfection=1e-3).solve()
load = np.linspace(0.0, 1.5, steps + 1)
tip = bent.position("beam:end")[:, 2]


def elastica_deflection(ratio):
    """Tip deflection / L of the inextensible cantilever elastica at P/P_cr = ratio > 1."""
    m = brentq(lambda m: (2 * ellipk(m) / np.pi) ** 2 - ratio, 0.0, 0.999)
    return 2 * np.sqrt(m) / ellipk(m)


print(f"at 1.5 P_cr: tip deflection {tip[-1]:.5f} L, elastica {elastica_deflection(1.5):.5f} L "
      f"({tip[-1] / elastica_deflection(1.5) - 1:+.1e})")

fig, ax = plt.subplots(figsize=(5.4, 3.6))
ax.plot(tip, load, "o-", label="imperfect column (static path)")
ax.plot(perfect.position("beam:end")[:, 2], load, "s-", label="perfect column (stays straight)")
above = np.linspace(1.001, 1.5, 40)
ax.plot([elastica_deflection(x) for x in above], above, "k:", label="elastica")
unstable = count > 0
ax.plot(perfect.position("beam:end")[unstable, 2], load[unstable], "rx", ms=9, label="negative eigenvalue")
ax.set_xlabel("tip deflection across the column [m]")
ax.set_ylabel("P / P_cr")
ax.legend(fontsize=8)
ax.set_title("Figure 3: an Euler column past buckling")
fig.tight_layout()
fig.savefig(FIGURES / "figure3.png", dpi=120, bbox_inches="tight")

# %% tags=["check"] jupyter={"source_hidden": true}
assert not any(issubclass(w.category, ModelWarning) for w in caught)
assert not np.any(bent.data("stability/negative_eigenvalues"))
# 16 elements (Beam2's load +1.6e-3 high there) and the 1e-3 imperfection: measured -1.9e-5; 2e-3 bounds them
assert abs(tip[-1] / elastica_deflection(1.5) - 1) < 2e-3

# %% [markdown]
# ## 6. How a frequency moves with the design: eigenvalue sensitivities
#
# A designer asks how much a frequency moves when a stiffness or a mass does. Differentiating
# $\mathbf K\boldsymbol\phi = \omega^2\mathbf M\boldsymbol\phi$ along a parameter $p$, with the mode
# mass-normalised ($\boldsymbol\phi^{\mathsf T}\mathbf M\boldsymbol\phi = 1$), the change of the mode itself
# drops out (Fox & Kapoor 1968):
#
# $$\frac{d\omega^2}{dp} = \boldsymbol\phi^{\mathsf T}\Bigl(\frac{\partial\mathbf K}{\partial p}
#   - \omega^2\,\frac{\partial\mathbf M}{\partial p}\Bigr)\boldsymbol\phi ,$$
#
# one product per parameter after the one eigensolve. With joints the same holds on the constrained modes
# $\boldsymbol\phi = \mathbf Z\boldsymbol\phi_r$, as long as $p$ does not move the joints. An Euler–Bernoulli
# cantilever has $\omega \propto \sqrt{EI/\rho A}$, so $d\omega_1/dEI = \omega_1/(2EI)$ and
# $d\omega_1/d\rho A = -\omega_1/(2\rho A)$. A modes deck asks for them with
# `[sensitivities] parameters = ["sections.rect.EI2", "sections.rect.rhoA"]` (docs/deck.md); from Python,
# `eigen_sensitivities` runs them on the reference path. Below, the deck `cantilever_modes.toml`
# (a Timoshenko beam: its shear moves $\omega_1$ by 0.08 % from Euler–Bernoulli) against a central
# difference of two more eigensolves per parameter, whose own error, $h^2\omega'''/6$, is a few $10^{-7}$ of
# the slope at the relative step $h = 10^{-3}$.

# %%
from reference.io.deck_sensitivities import eigen_sensitivities  # noqa: E402

deck = MODELS / "cantilever_modes.toml"
names = ["sections.rect.EI2", "sections.rect.rhoA"]
omega, d_omega = eigen_sensitivities(deck, names)
step = 1e-3  # relative step of the central differences
central = []
for name in names:
    plus = eigen_sensitivities(deck, [], {name: 1.0 + step})[0][0]
    minus = eigen_sensitivities(deck, [], {name: 1.0 - step})[0][0]
    central.append((plus - minus) / (2 * step))  # EI2 = ρA = 1 in the deck
euler_bernoulli = [omega[0] / 2, -omega[0] / 2]
print(f"ω₁ = {omega[0]:.6f} rad/s")
for name, d, c, e in zip(names, d_omega[:, 0], central, euler_bernoulli):
    print(f"dω₁/d{name.split('.')[-1]:5s} = {d:+.8f}  central difference {c:+.8f} ({d / c - 1:+.1e}),"
          f"  Euler–Bernoulli ±ω₁/2 {e:+.6f} ({d / e - 1:+.1e})")

# %% tags=["check"] jupyter={"source_hidden": true}
# the formula against the central differences: the differences' own truncation, h²/6 · ω'''/ω' with
# ω ∝ (EI/ρA)^(1/2), is 1.25e-7 (EI) and 6.25e-7 (ρA) at h = 1e-3 (measured 1.6e-7 and 6.5e-7), their round-off
# at most 4e-10 of ω / 2e-3 = 2e-7: below the 1e-6 asked of it.  Against Euler–Bernoulli the Timoshenko beam's shear
# and rotary inertia leave 1.2e-3 (EI) and 4.6e-4 (ρA), measured: bound 2e-3
assert np.allclose(d_omega[:, 0], central, rtol=1e-6, atol=0.0)
assert np.allclose(d_omega[:, 0], euler_bernoulli, rtol=2e-3, atol=0.0)

# %% [markdown]
# ## Exercises
#
# **Exercise 1.** Pin both ends of the column (fix $y, z$ and the twist at $x = 0$, $y, z$ at $x = L$) and
# check that the lowest buckling load is $\pi^2EI/L^2$, four times the cantilever's. *Hint:*
# `FixedCoordinates(node, dofs)` with the coordinates numbered $x, y, z, r_x, r_y, r_z$ = 0 … 5. How far above
# $\pi^2EI/L^2$ is the 32-element answer, and why?
#
# **Exercise 2 (change the model and rerun).** Rerun the spinning cantilever of part 3 with 32 elements in place
# of 16, at $\lambda = 0$ and $\lambda = 12$. *What you should see:* Beam2 converges at second order, so the
# error of the first flap frequency against the published table falls by about 4 at both rates; the spin
# changes the mode, not the order.
#
# Try them before you open the answers below (click the collapsed cells to show them).
#
# ## Answers

# %% tags=["solution"] jupyter={"source_hidden": true}
# Exercise 1: Beam2's one-point geometric stiffness puts the load (πh/L)²/6 high (1.6e-3 at 32 elements)
from reference.interactions import FixedCoordinates  # noqa: E402

d = Domain("pinned column")
nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 32, SLENDER)
d.add_interaction(FixedCoordinates(nodes[0], (0, 1, 2, 3)))
d.add_interaction(FixedCoordinates(nodes[-1], (1, 2)))
d.add_interaction(NodalLoad(nodes[-1], (-1.0, 0.0, 0.0), time_function=Ramp(0.0, 10.0, 0.0, 10.0)))
d.solver = SolverSettings(algorithm="buckling", modes=1, backend="auto")
mu_pinned = d.solve().data("buckling/load_factor")[0]
print(f"pinned-pinned: {mu_pinned:.5f} N against π²EI/L² = {np.pi**2:.5f} N")
assert abs(mu_pinned / np.pi**2 - 1 - (np.pi / 32) ** 2 / 6) < 1e-4  # check of the exercise: Beam2's (kh)²/6

# %% tags=["solution", "rerun"] jupyter={"source_hidden": true}
# Exercise 2
errors = {}
for n in (16, 32):
    for rate in (0.0, 12.0):
        errors[n, rate] = first_modes(blade(n), rate)[0] / ROTATING_CANTILEVER_FLAP[int(rate)][0] - 1
for rate in (0.0, 12.0):
    print(f"λ = {rate:4.1f}: flap error {errors[16, rate]:+.2e} (16 elements), {errors[32, rate]:+.2e} (32), "
          f"ratio {errors[16, rate] / errors[32, rate]:.2f}")
    # second order: the ratio 4 up to the table's 4 decimals (5e-5 of ω̄, a few per cent of the 32-element error)
    assert 3.0 < errors[16, rate] / errors[32, rate] < 5.0
