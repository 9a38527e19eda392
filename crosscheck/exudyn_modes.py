"""Exudyn's eigen-solve on a flexmbs deck (Exudyn 1.13, ``MainSystem.ComputeODE2Eigenvalues``).

:func:`modes` translates a :class:`~reference.domain.Domain` with the cross-check's
translation (:func:`crosscheck.exudyn_model.build`), brings it, when asked
(``about = "static"``), to its static equilibrium under the deck's loads at ``t_end``
with Exudyn's static solver, and calls Exudyn's eigen-solver on that state.  It
returns the frequencies [Hz] and the mode shapes mapped to the deck's nodes —
per node the displacement [m, inertial] and the rotation increment [rad, node
frame], ``δA = A δθ̃`` — with the wall time of the eigen call alone.

Two variants of Exudyn's solver:

* **dense** (default): Euler-parameter nodes (:class:`~crosscheck.exudyn_items.Translation`),
  every joint, clamp and weld an ``ObjectJointGeneric``; Exudyn projects its mass
  and stiffness matrices onto the null space of its constraint Jacobian (a dense SVD)
  and solves the dense symmetric problem (``scipy.linalg.eigh``): all modes, O(n³) —
  1.4 s at 900 coordinates, 6.1 s at 2,000 (cantilevers of 128 and 280 elements; above
  1,000 Exudyn prints a warning about its dense linear solver).  ``damped=True`` solves Exudyn's first-order
  (complex) problem with its damping matrix: frequency ``|λ|/2π`` and damping ratio
  ``−Re λ/|λ|`` (no shapes).
* **sparse**: rotation-vector Lie-group nodes (six coordinates, no normalisation
  equation), clamps and fixed coordinates as coordinate constraints whose
  coordinates the eigen-solve removes (``constrainedCoordinates``), and the lowest
  ``n_modes`` by shift-invert Lanczos at σ = 0 (``scipy.sparse.linalg.eigsh``).  Exudyn
  refuses algebraic equations on this path, so it takes models without joints
  (nor welded kinks), whose fixed rotations are all three or belong to a node whose
  frame is the inertial one (a rotation-vector coordinate is a body-frame rotation
  only there), and without rigid-body modes (σ = 0 must not be an eigenvalue).
  Exudyn exports its matrices dense even here (3.2 GB at 10,000 coordinates).

**What Exudyn's linearisation leaves out.**  Its stiffness matrix is the Jacobian of
the applied and elastic forces alone: the constraint forces' term ``λ·∂(C_qᵀ)/∂q``
is in none of Exudyn's Jacobians (checked: with the multipliers of the hanging
double pendulum set, the ODE2 block of the static solver's Jacobian stays zero, for
analytic and numerical differentiation alike).  A mechanism whose stiffness is its
constraint forces — a pendulum under gravity — gets zero frequencies, and Exudyn's
static solver cannot bring one to equilibrium (its Jacobian is singular once its
load-step stabiliser is gone).  ``joint_reactions=True`` adds that term: λ are the
multipliers that balance Exudyn's forces at the configuration (least squares; exact
at an equilibrium), the Hessian the second differences of Exudyn's own constraint
equations (:func:`crosscheck.exudyn_matrices.constraint_hessian`); the constrained
problem (null space of ``C_q``, ``scipy.linalg.null_space``) is then solved here with
Exudyn's matrices (:func:`_own_modes`, :func:`crosscheck.exudyn_matrices.lowest`).  About a static
equilibrium the stiffness is Exudyn's ODE2 Jacobian by numerical differentiation:
the analytic one of ``ObjectBeamGeometricallyExact`` leaves out the derivatives of
its nodes' G matrices and of the SE(3) tangent operator (its source says so) — for a
cantilever bent by end moments (0.3 N m) under a 0.3 N axial force it gave a first
frequency 5.5 % above the numerical Jacobian's; the two agree to 2e-7 on straight
states and at the unstressed reference, where the analytic one is used.

**The two beam elements** (flexmbs Beam2, ``docs/formulation.md`` §3, and Exudyn's
``ObjectBeamGeometricallyExact`` of the same length and section, as the translation
maps it, :func:`crosscheck.exudyn_items.beams`), for differences beyond 0.1 %:

* both are two-node, shear-deformable (Simo–Reissner) elements on rigid-body nodes
  with one constant strain per element (flexmbs: one-point integration at the
  midpoint; Exudyn: interpolation on SE(3), the strains from the logarithm of the
  relative frame of the two nodes).  The strain measures — flexmbs
  ``Γ = A_mᵀ(x₂ − x₁)/L − e₁`` with the midpoint triad ``A_m = A₁ exp(ψ̃/2)``,
  ``K = ψ/L``; Exudyn the parts of ``log_SE3(H₁⁻¹H₂)/L`` less ``e₁`` — agree to first
  order about an unstressed straight state, so **about the reference the stiffness
  matrices are the same**: Exudyn's (rotation-vector nodes) equals the central
  differences of flexmbs' Beam2 forces to 3e-11 (8 elements, skew axis).  They differ
  at second order in the element's rotation ψ (``J⁻¹(ψ)`` against ``exp(−ψ̃/2)`` on the
  relative position: ``ψ̃²/12`` against ``ψ̃²/8``), which enters the geometric
  stiffness about a stressed state: a difference of order ``N ψ²`` per element, falling
  as the square of the element size.
* **the mass differs**: Exudyn 1.13.6 integrates the kinetic energy with the linear
  shape functions — a *consistent* mass, ``ρA L/3`` on the diagonal and ``ρA L/6``
  between the two nodes, the same for ``ρJ`` (read from its exported mass matrix) —
  where flexmbs *lumps* ``ρA L/2`` and ``(L/2) ρJ`` at each node.  A bending wave of
  wavenumber k on elements of length h then runs at ``ω_h/ω ≈ 1 + (kh)²/8`` in Exudyn
  (stiffness ``(kh)²/24``, mass ``(kh)²/12``) and ``1 + (kh)²/24`` in flexmbs: Exudyn's
  frequencies are higher by about ``(kh)²/12`` — measured 1.6e-3 for the third bending
  mode of a 64-element cantilever (9.8356 against 9.8201 Hz), 5e-5 for its first axial
  and torsional modes (+2.5e-5 and −2.5e-5 about the closed forms: the bar's textbook
  ``±(kh)²/24``).  ``lumped_mass=True`` (sparse variant) block-lumps Exudyn's mass
  matrix (each node's 3×3 blocks summed over its row: exactly flexmbs' lumped mass) and
  solves with Exudyn's stiffness: the frequencies flexmbs must reproduce, its stiffness
  being Exudyn's to 3e-11.  Mode vectors are mass-normalised with the mass solved with.
* Exudyn's mass-proportional damping is a connector per node to ground
  (:func:`crosscheck.exudyn_items.damping`), the same forces ``−c m v``, ``−c J ω``
  with flexmbs' lumped m and J (so not exactly proportional to Exudyn's mass).

Refusals are :class:`~crosscheck.exudyn_model.Unsupported` (one line): what the
translation cannot express (:func:`crosscheck.exudyn_model.check_supported`) and what
the sparse variant cannot take (:func:`check_sparse`); an Exudyn static solve that
fails is :class:`~crosscheck.exudyn_model.ExudynFailed`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from crosscheck.exudyn_items import TRANSLATORS, clamps, matrix
from crosscheck.exudyn_matrices import constraint_hessian, lowest, lumped, matrices
from crosscheck.exudyn_model import DENSE_LIMIT, SUBDIVISIONS, ExudynFailed, Unsupported, build, solver_settings
from reference.rotation import quaternion_product

ABOUT = ("reference", "static")
"""The configurations :func:`modes` linearises about: the deck's t = 0, or its static equilibrium at ``t_end``."""
@dataclass
class ExudynModes:
    """Exudyn's modes of a deck.

    ``eigenvalue`` (n,): ω² [rad²/s²] of the undamped problem, signed (negative: an
    unstable direction), or the complex eigenvalues λ [1/s] of the damped one;
    ``frequency`` (n,) [Hz]: ``√|ω²|/2π`` or ``|λ|/2π``; ``damping_ratio`` (n,):
    ``−Re λ/|λ|`` (zero undamped); ``shape`` (n, N, 6) per mode and deck node the
    displacement [m, inertial] and rotation increment [rad, node frame], each mode
    mass-normalised with the mass matrix solved with (sign arbitrary), None for the
    damped problem; ``wall_time`` [s] Exudyn's eigen call alone (``joint_reactions``,
    ``lumped_mass``: the whole solve here, :func:`_own_modes`);
    ``coordinates`` the coordinates of Exudyn's problem before constraints;
    ``method`` one line saying what was solved.
    """

    eigenvalue: np.ndarray
    frequency: np.ndarray
    damping_ratio: np.ndarray
    shape: np.ndarray | None
    wall_time: float
    coordinates: int
    method: str


def modes(domain, n_modes: int = 10, about: str = "reference", sparse: bool = False, damped: bool = False,
          joint_reactions: bool = False, lumped_mass: bool = False) -> ExudynModes:
    """The lowest ``n_modes`` modes of ``domain`` by Exudyn's eigen-solver (the module docstring).

    Parameters
    ----------
    domain : reference.domain.Domain
    n_modes : int
        How many of the lowest (the dense variant computes all and keeps these).
    about : {"reference", "static"}
        Linearise about the deck's t = 0, or its static equilibrium under the loads at
        ``t_end`` (Exudyn's static solver, ``solver.load_steps`` steps, more when it fails).
    sparse : bool
        Exudyn's sparse variant (:func:`check_sparse` says what it takes).
    damped : bool
        The first-order problem with Exudyn's damping matrix (dense only).
    joint_reactions : bool
        Add the constraint forces' stiffness that Exudyn leaves out (dense, undamped).
    lumped_mass : bool
        Exudyn's stiffness with the lumped mass of flexmbs (sparse, undamped).

    Raises
    ------
    Unsupported
        One line: an untranslatable deck, or a combination the variant cannot take.
    ExudynFailed
        Exudyn's static solver did not reach the deck's loads.
    """
    if about not in ABOUT:
        raise ValueError(f"about = {about!r}: linearise about one of {', '.join(ABOUT)}")
    if int(n_modes) < 1:
        raise ValueError(f"n_modes = {n_modes}: ask for at least one mode")
    for wanted, clash, why in ((sparse, damped, "Exudyn's sparse eigen-solve is undamped: use sparse=False"),
                               (sparse, joint_reactions, "the sparse variant has no joints: use sparse=False"),
                               (lumped_mass, not sparse, "the mass is lumped in the sparse variant's coordinates: "
                                                         "use sparse=True"),
                               (damped, joint_reactions or lumped_mass, "joint_reactions and lumped_mass solve the "
                                                                        "undamped problem: use damped=False")):
        if wanted and clash:
            raise Unsupported(why)
    t = translated(domain, about, sparse)
    settings = _settings(about, sparse)
    if joint_reactions or lumped_mass:
        return _own_modes(t, settings, int(n_modes), joint_reactions)
    fixed = _fixed_coordinates(t) if sparse else []
    t0 = time.perf_counter()
    try:
        values, vectors = t.mbs.ComputeODE2Eigenvalues(
            simulationSettings=settings, useSparseSolver=sparse, numberOfEigenvalues=0 if damped else int(n_modes),
            constrainedCoordinates=fixed, ignoreAlgebraicEquations=sparse, useAbsoluteValues=False,
            computeComplexEigenvalues=damped)
    except (RuntimeError, ValueError) as exc:  # scipy's factorisation at σ = 0, ARPACK, Exudyn's refusals
        raise Unsupported(f"Exudyn's eigen-solve failed: {' '.join(str(exc).split())[:200]}"
                          + ("; a model with rigid-body or mechanism modes needs sparse=False" if sparse else "")) \
            from None
    wall = time.perf_counter() - t0
    n2 = len(t.mbs.systemData.GetODE2Coordinates())
    if damped:
        return _damped(values, n2, wall, int(n_modes))
    method = ("sparse shift-invert Lanczos (σ = 0), constrained coordinates removed" if sparse else
              "dense, null space of the constraint Jacobian (SVD)")
    return _undamped(np.real(values), shapes(t, np.asarray(vectors)[:n2]), wall, n2,
                     f"Exudyn ComputeODE2Eigenvalues, {method}")


def _undamped(values, shape, wall: float, n2: int, method: str) -> ExudynModes:
    return ExudynModes(values, np.sqrt(np.abs(values)) / (2.0 * np.pi), np.zeros(len(values)), shape, wall, n2, method)


def check_sparse(t) -> None:
    """Raise :class:`Unsupported` naming what Exudyn's sparse eigen-solve cannot take (the module docstring):
    a joint, a welded kink (an element end at an angle to its node frame), fixed rotations of a turned frame."""
    if t.domain.joints:
        raise Unsupported(f"joint {t.domain.joints[0].label!r}: Exudyn's sparse eigen-solve takes no algebraic "
                          "equations (joints); use sparse=False")
    if len(t.mbs.systemData.GetAECoordinates()) != len(t.fixed):
        raise Unsupported("a beam element meets its node at an angle (a welded kink in Exudyn, a joint): Exudyn's "
                          "sparse eigen-solve takes no joints; use sparse=False")
    for bc in t.domain.boundary_conditions:
        node = t.domain.node(bc.node)
        rotations = sorted(k for k in bc.dofs if k >= 3)
        turned = [q for q in (node.rotation, t.primary[node.id]) if abs(abs(float(q[0])) - 1.0) > 1e-14]
        if rotations and len(rotations) < 3 and turned:
            raise Unsupported(f"node {node.label!r} fixes rotations {rotations} of a turned frame: Exudyn's "
                              "rotation-vector coordinates are body-frame rotations only for the inertial frame; "
                              "use sparse=False")


def coordinate_clamps(t) -> None:
    """Clamps and fixed coordinates of the sparse variant: one coordinate constraint per fixed coordinate.

    Its translations are the inertial ones (as the deck's), its rotations the
    rotation vector's components (:func:`check_sparse`); the eigen-solve removes
    these coordinates (:func:`_fixed_coordinates`), a static solve enforces them.
    """
    eii, mbs = t.eii, t.mbs
    ground = mbs.AddNode(eii.NodePointGround())
    anchor = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    t.fixed = []
    for bc in t.domain.boundary_conditions:
        node = t.nodes[t.domain.node(bc.node).id]
        for k in sorted(bc.dofs):
            t.fixed.append((node, k))
            marker = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=k))
            mbs.AddObject(eii.ObjectConnectorCoordinate(markerNumbers=[anchor, marker]))


SPARSE_TRANSLATORS = tuple(coordinate_clamps if f is clamps else f for f in TRANSLATORS)
"""The translators of the sparse variant: clamps as coordinate constraints."""


def _fixed_coordinates(t) -> list:
    return sorted(int(t.mbs.GetNodeODE2Index(node)) + k for node, k in t.fixed)


def translated(domain, about: str, sparse: bool):
    """The Exudyn translation in the state to linearise about: t = 0, or Exudyn's static equilibrium
    under the loads at ``t_end`` (copied to its initial state, multipliers included)."""
    t_end = float(domain.solver.t_end)
    if about == "reference":
        return _built(domain, sparse, t_end)
    steps = max(int(domain.solver.load_steps), 1)
    for k in SUBDIVISIONS:
        t = _built(domain, sparse, t_end)
        solver, settings, label = solver_settings(domain, t_end / (steps * k), t_end, steps * k, algorithm="static")
        if len(t.mbs.systemData.GetODE2Coordinates()) > DENSE_LIMIT:
            settings.linearSolver.solverType = t.exu.LinearSolverType.EigenSparse
        try:
            ok = solver.SolveSystem(t.mbs, settings)
        except Exception as exc:  # a failed solve raises in some versions: the same one line
            ok = " ".join(str(exc).split())[:200] or type(exc).__name__
        reached = float(solver.it.currentTime)
        if ok is True and reached >= t_end * (1.0 - 1e-9):
            break
    else:
        cause = f" ({ok})" if isinstance(ok, str) else ""
        raise ExudynFailed(f"Exudyn's {label} did not reach the deck's loads: it stopped at load factor "
                           f"{reached:.6g} of {t_end:g}{cause} with up to {steps * SUBDIVISIONS[-1]} adaptive load "
                           "steps; a mechanism held by its joints alone cannot be solved by it (its Jacobian lacks "
                           "the constraint forces' stiffness): linearise about the reference where that is an "
                           "equilibrium, else try more load steps (solver.load_steps)")
    exu = t.exu
    t.mbs.systemData.SetSystemState(t.mbs.systemData.GetSystemState(exu.ConfigurationType.Current),
                                    exu.ConfigurationType.Initial)
    return t


def _built(domain, sparse: bool, t_end: float):
    """The assembled translation: Euler-parameter nodes, or the sparse variant's (checked by :func:`check_sparse`)."""
    if not sparse:
        return build(domain, t_end=t_end)
    t = build(domain, t_end=t_end, translators=SPARSE_TRANSLATORS, lie_group=True)
    check_sparse(t)
    return t


def _settings(about: str, sparse: bool):
    """The eigen-solve's settings: Exudyn's sparse linear solver for the sparse variant; about a static
    equilibrium the ODE2 Jacobian by numerical differentiation (the analytic one of Exudyn's beam is
    incomplete in stressed states: the module docstring)."""
    import exudyn as exu

    settings = exu.SimulationSettings()
    settings.solution.file.write = False
    settings.solution.sensors.active = False
    settings.staticSolver.verboseMode = 0
    if sparse:
        settings.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    settings.staticSolver.newton.numericalDifferentiation.forODE2 = about == "static"
    return settings


def shapes(t, vectors: np.ndarray) -> np.ndarray:
    """Exudyn's mode vectors (ODE2 coordinates × modes) as (modes, N, 6) per deck node.

    Displacements are the position coordinates.  An Euler-parameter change ``δp`` is the
    body-frame rotation ``δθ = 2 vec(p* ⊗ δp)`` (``δp = ½ p ⊗ (0, δθ)``); a Lie-group node's
    rotation coordinates are linearised as the body-frame rotation itself (its mass block is the
    body-frame inertia; checked against the Euler-parameter translation to 3e-6 on a skew
    cantilever).  Both are in the frame of the Exudyn node, the node frame turned by ``o_p``, so
    ``δθ_node = A(o_p) δθ``.
    """
    exu, mbs = t.exu, t.mbs
    out = np.zeros((vectors.shape[1], len(t.domain.nodes), 6))
    initial = exu.ConfigurationType.Initial
    for i, node in enumerate(t.nodes):
        k = int(mbs.GetNodeODE2Index(node))
        out[:, i, :3] = vectors[k:k + 3].T
        if t.lie_group:
            theta = vectors[k + 3:k + 6]
        else:
            p = np.asarray(mbs.GetNodeParameter(node, "referenceCoordinates"))[3:] + \
                np.asarray(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates, configuration=initial))[3:]
            conj = p * np.array([1.0, -1.0, -1.0, -1.0])
            theta = np.array([2.0 * quaternion_product(conj, d)[1:] for d in vectors[k + 3:k + 7].T]).T
        out[:, i, 3:] = (matrix(t.primary[i]) @ theta).T
    return out


def _damped(values, n2: int, wall: float, n_modes: int) -> ExudynModes:
    """The lowest ``n_modes`` of Exudyn's complex eigenvalues (one of each conjugate pair), by |λ|."""
    lam = np.asarray(values, dtype=complex)
    lam = lam[lam.imag >= -1e-12 * np.maximum(np.abs(lam), 1.0)]
    lam = lam[np.argsort(np.abs(lam), kind="stable")][:n_modes]
    size = np.abs(lam)
    ratio = np.divide(-lam.real, size, out=np.zeros(len(lam)), where=size > 0.0)
    return ExudynModes(lam, size / (2.0 * np.pi), ratio, None, wall, n2,
                       "Exudyn ComputeODE2Eigenvalues, dense first-order (complex) problem with its damping matrix")


def _own_modes(t, settings, n_modes: int, joint_reactions: bool) -> ExudynModes:
    """The undamped problem solved here with Exudyn's matrices (the module docstring).

    ``joint_reactions``: ``K = −∂f/∂q + ∂(C_qᵀλ)/∂q`` with λ the least-squares multipliers
    of ``C_qᵀλ = f`` (static balance at the configuration), projected on the null space ``N``
    of ``C_q``.  Otherwise (the sparse variant, ``lumped_mass``): Exudyn's stiffness, its mass
    block-lumped (:func:`crosscheck.exudyn_matrices.lumped`), the fixed coordinates removed.
    ``(NᵀKN) x = ω² (NᵀMN) x`` with the symmetric part of ``NᵀKN``
    (:func:`crosscheck.exudyn_matrices.lowest`); the wall time is this whole solve (matrices,
    differences and eigen-solve).
    """
    from scipy.linalg import null_space

    t0 = time.perf_counter()
    s, M, K, Ct, f = matrices(t, settings)
    n2 = M.shape[0]
    if joint_reactions:
        K_lam, lam, residual = constraint_hessian(t, s, Ct, f)
        K = K + K_lam
        N = null_space(Ct.T)
        Kr, Mr = N.T @ K @ N, N.T @ M @ N
        method = ("Exudyn's matrices with the constraint forces' stiffness added (central differences of its "
                  f"constraint equations; residual of the static balance {residual:.1e} N), null-space eigen-solve "
                  "here")
    else:
        free = np.setdiff1d(np.arange(n2), _fixed_coordinates(t))
        N = None  # the free coordinates, selected
        Kr, Mr = K[np.ix_(free, free)], lumped(M)[np.ix_(free, free)]
        method = "Exudyn's stiffness with its mass block-lumped, fixed coordinates removed, eigen-solve here"
    s.FinalizeSolver(t.mbs, settings)
    values, x = lowest(Kr, Mr, n_modes)
    wall = time.perf_counter() - t0
    if N is None:
        vectors = np.zeros((n2, x.shape[1]))
        vectors[free] = x
    else:
        vectors = N @ x
    return _undamped(values, shapes(t, vectors), wall, n2, method)


TIMING_SECTION = dict(EA=1e4, GA2=1e4, GA3=1e4, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-4, rhoJ2=1e-4,
                      rhoJ3=1e-4)
"""The timing cantilever's section: the slender section of ``models/cantilever_vibration.toml``."""


def timing_cantilever(n_elements: int = 1666, length: float = 1.0):
    """A straight cantilever along +x of ``n_elements`` Beam2 elements (:data:`TIMING_SECTION`), clamped at
    x = 0: 6 (n_elements + 1) coordinates, 6 n_elements independent (9,996 at the default)."""
    from reference.domain import Domain
    from reference.elements import Section
    from reference.interactions import Clamp

    d = Domain(f"cantilever of {n_elements} elements")
    nodes = d.add_beam("beam", (0.0, 0.0, 0.0), (length, 0.0, 0.0), n_elements, Section(**TIMING_SECTION))
    d.add_interaction(Clamp(nodes[0]))
    return d


def exudyn_modes_timing(n_elements: int = 1666, n_modes: int = 20) -> tuple[np.ndarray, float]:
    """Exudyn's sparse eigen-solve of the lowest ``n_modes`` of :func:`timing_cantilever`: ``(frequencies [Hz],
    seconds)``, the eigen call alone (the model built and assembled before the clock starts)."""
    result = modes(timing_cantilever(n_elements), n_modes, sparse=True)
    return result.frequency, result.wall_time
