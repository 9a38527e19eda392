"""Exudyn's linearised matrices of a translated model, and what its eigen-solve lacks.

:func:`matrices` reads Exudyn's mass matrix, stiffness, constraint Jacobian and forces
at the initial state from its static solver, as ``ComputeODE2Eigenvalues`` gets them;
:func:`constraint_hessian` adds the constraint forces' stiffness Exudyn leaves out;
:func:`lumped` block-lumps its consistent beam mass into flexmbs' lumped one; :func:`lowest`
solves for the lowest modes by shift-invert Lanczos.  :mod:`crosscheck.exudyn_modes` uses them
(its docstring says why each is needed).
"""

from __future__ import annotations

import numpy as np

from crosscheck.exudyn_model import Unsupported

DIFFERENCE_STEP = 1e-4
"""Central-difference step of the constraint equations in their coordinates (:func:`constraint_hessian`):
Exudyn's joint equations are at most quartic in the Euler parameters and linear in the positions, so
the truncation is ~1e-8 and the round-off of the second differences ~1e-16/h² = 1e-8, relative."""


def matrices(t, settings):
    """Exudyn's mass matrix, stiffness (−∂f/∂q), transposed constraint Jacobian ``C_qᵀ`` (n2 × nAE) and
    forces f (ODE2 right-hand side) at the initial state, from its static solver (as its eigen-solver
    gets them)."""
    s = t.exu.MainSolverStatic()
    s.InitializeSolver(t.mbs, settings)
    n2 = s.GetODE2size()
    s.ComputeMassMatrix(t.mbs)
    M = np.array(s.GetSystemMassMatrix())
    s.ComputeODE2RHS(t.mbs)
    f = np.array(s.GetSystemResidual())[:n2]
    s.ComputeJacobianODE2RHS(t.mbs, scalarFactor_ODE2=-1.0, scalarFactor_ODE2_t=0.0, scalarFactor_ODE1=0.0)
    s.ComputeJacobianAE(t.mbs, scalarFactor_ODE2=1.0, scalarFactor_ODE2_t=0.0, scalarFactor_ODE1=0.0,
                        velocityLevel=False)
    J = np.array(s.GetSystemJacobian())
    return s, M[:n2, :n2], J[:n2, :n2], J[:n2, n2:], f


def constraint_hessian(t, s, Ct: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The constraint forces' stiffness ``∂(C_qᵀλ)/∂q = Σ λ_i ∂²Φ_i/∂q²`` and the static multipliers λ.

    Exudyn's ``C_q`` of an Euler-parameter node is the gradient of Φ less its component
    along the parameters (exact on the tangent of the unit sphere, but not its derivative:
    differenced, it gave half the pendulum's stiffness), so the joints' gradient and
    Hessian are taken here from Exudyn's constraint residual Φ(q) itself, by central
    differences over the coordinates the joints involve (step :data:`DIFFERENCE_STEP`);
    the normalisation equations ``p·p − 1`` are exact (gradient ``2p``, Hessian ``2I``).
    λ solves ``∇Φᵀλ = f`` in least squares (exact at an equilibrium).  Returns
    ``(K_λ, λ, residual of that balance)``.
    """
    mbs, current = t.mbs, t.exu.ConfigurationType.Current
    q0 = np.array(mbs.systemData.GetODE2Coordinates(current))
    n2, nae = Ct.shape
    grad = np.array(Ct.T)
    normal = {}  # AE row → first Euler-parameter coordinate, every Euler-parameter node (welded ends too)
    for node in range(mbs.systemData.NumberOfNodes()):
        if mbs.GetNode(node)["nodeType"] == "RigidBodyEP":
            k = int(mbs.GetNodeODE2Index(node)) + 3
            normal[int(mbs.GetNodeAEIndex(node))] = k
            grad[int(mbs.GetNodeAEIndex(node))] = 0.0
            grad[int(mbs.GetNodeAEIndex(node)), k:k + 4] = \
                2.0 * (np.asarray(mbs.GetNode(node)["referenceCoordinates"])[3:] + q0[k:k + 4])
    joint = np.array(sorted(set(range(nae)) - set(normal)), dtype=int)
    involved = np.flatnonzero(np.any(Ct[:, joint] != 0.0, axis=1))
    h = DIFFERENCE_STEP

    def phi(*steps):
        q = q0.copy()
        for i, step in steps:
            q[i] += step
        mbs.systemData.SetODE2Coordinates(list(q), current)
        s.ComputeAlgebraicEquations(mbs, velocityLevel=False)
        return np.array(s.GetSystemResidual())[n2:][joint]

    for i in involved:
        grad[joint, i] = (phi((i, h)) - phi((i, -h))) / (2.0 * h)
    lam = np.linalg.lstsq(grad.T, f, rcond=None)[0]
    K = np.zeros((n2, n2))
    for row, k in normal.items():
        K[k:k + 4, k:k + 4] += 2.0 * lam[row] * np.eye(4)
    for a, i in enumerate(involved):
        for j in involved[a:]:
            H = sum(si * sj * (lam[joint] @ phi((i, si * h), (j, sj * h))) for si in (1, -1) for sj in (1, -1))
            K[i, j] += H / (4.0 * h * h)
            if j != i:
                K[j, i] += H / (4.0 * h * h)
    mbs.systemData.SetODE2Coordinates(list(q0), current)
    return K, lam, float(np.linalg.norm(grad.T @ lam - f))


def lumped(M: np.ndarray) -> np.ndarray:
    """Block-lump a mass matrix in six coordinates per node (u, θ): each node's 3×3 translational and
    rotational blocks summed over its block row, the coupling blocks dropped — from Exudyn's consistent
    beam mass (ρA L/3, ρA L/6 per element) the lumped ρA L/2 per node, and likewise for ρJ."""
    n = M.shape[0] // 3
    blocks = M.reshape(n, 3, n, 3)
    out = np.zeros_like(M)
    for b in range(n):  # translations with translations (even blocks), rotations with rotations (odd)
        out[3 * b:3 * b + 3, 3 * b:3 * b + 3] = blocks[b, :, b % 2::2, :].sum(axis=1)
    return out


def lowest(K: np.ndarray, M: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` lowest eigenpairs of ``K x = ω² M x`` (the symmetric part of K; M positive definite),
    ascending, by shift-invert Lanczos (``scipy.sparse.linalg.eigsh``) about σ = 0, or, where K is
    singular (mechanism modes), about ``σ = −10⁻⁶ max Kᵢᵢ/Mᵢᵢ``.  A dense solve would lose the lowest
    eigenvalues to the stiffest: its absolute error ``ε ω²_max`` is 1e-3 of a beam's first ``ω²`` when
    ``GA/(ρJ h²)`` is 1e13 (measured: 7e-6 between two dense solves of a 64-element cantilever); the dense
    ``scipy.linalg.eigh`` is kept for problems too small for Lanczos (``n ≥ size − 1``)."""
    from scipy.linalg import eigh
    from scipy.sparse import csc_matrix
    from scipy.sparse.linalg import eigsh

    K = 0.5 * (K + K.T)
    size = K.shape[0]
    if n >= size - 1:
        return eigh(K, M)
    shift = -1e-6 * float(np.max(np.abs(np.diag(K)) / np.diag(M)))
    for sigma in (0.0, shift):
        try:
            values, vectors = eigsh(csc_matrix(K), k=n, M=csc_matrix(M), sigma=sigma, which="LM")
            break
        except RuntimeError:  # "Factor is exactly singular": K − σM at σ = 0 of a mechanism
            continue
    else:
        raise Unsupported(f"K − σM is singular at σ = 0 and σ = {shift:.3g}: the mass matrix is singular (a "
                          "massless node or direction)")
    order = np.argsort(values)
    return values[order], vectors[:, order]
