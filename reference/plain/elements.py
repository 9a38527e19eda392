"""The element families' internal forces, tangents and section resultants in plain NumPy.

The reference twin of the families' compiled calls (:mod:`reference.elements.families`:
``assemble_forces``, ``tangent_values``, ``resultants``): the same generated element code
(``reference/generated/beam2.py``, ``beam2_se3.py``, ``beam3.py``, ``tangents.py``), run by
:func:`reference.plain.vectorise.twin` on all of a family's elements at once (element after element for a
few), in the same frames.

The driver, common to every family (one pass per family of ``model.elements``, elements in chunks of
:data:`CHUNK`):

1. gather each element's node positions and Euler parameters, end by end, as (3, E) and (4, E) arrays;
2. its section triads ``p_a = q_a ⊗ o_a`` (the generated ``quat_product``; ``o_a`` the end's constant
   offset, :class:`reference.state.Model`);
3. the family's element functions in the section frames (below);
4. the ends' moments back to the node frames, ``A(o_a) S_sec`` (:func:`reference.elements.formulation.to_node_frame`),
   and a tangent as ``T K Tᵀ``, ``T = blockdiag(I, A(o_1), …, I, A(o_n))``
   (:func:`reference.elements.formulation.tangent_to_node_frames`);
5. add into the nodes' (N, 6) sums, element after element, end after end (the compiled scatter's order),
   or into a sparse (6N, 6N) matrix.

Conventions: :mod:`reference.plain.model` (forces per node ``[inertial force, body-frame moment]``;
tangent columns per node ``[inertial δx, body-frame δθ]`` under ``x ← x + δx``, ``q ← q ⊗ exp(δθ)``,
the static update, ``ψ = 0`` in :func:`reference.newton_blocks.store_block`).

**What a family gives the reference path.** An adapter object with three methods on E elements of the
family at once, structure-of-arrays (``x`` (n, 3, E) node positions and ``p`` (n, 4, E) section triads,
end order of ``data.conn``; ``data`` the family's plain data, ``sl`` the slice of its elements):

- ``evaluate(data, sl, x, p) → (s (6n, E), U (E,), N (3, E), M (3, E))``: the internal forces
  ``[S_u1, S_θ1, …]`` with moments in the section frames, the strain energies [J], and the section
  resultants (force [N], moment [N m], section frame) a results file stores for the element;
- ``tangent(data, sl, x, p) → K (6n, 6n, E)``: ``∂s/∂[δx1, δθ1, …]`` in the section frames.

The family's class may carry it as the attribute ``plain`` (looked up first); the engine's three families
have theirs here in :data:`ADAPTERS`, each a few lines naming the generated functions and the data fields
they take.  Nothing else of a family is needed: its data's ``conn``, ``index`` and, where its section frames
are not the node frames, ``offset`` (E, n, 4) (:class:`reference.elements.beam2.Beam2Data`); the frames and
the assembly are the driver's.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from reference.elements.families import family_of
from reference.elements.formulation import to_node_frame
from reference.generated import beam2 as generated_beam2
from reference.generated import beam2_se3 as generated_se3
from reference.generated import beam3 as generated_beam3
from reference.generated import rotation_maps as rm
from reference.generated import sensitivities as generated_sensitivities
from reference.generated import tangents as generated_tangents
from reference.plain.vectorise import twin

CHUNK = 1024
"""Elements evaluated at once: the generated code keeps every intermediate (thousands for beam3's tangent)
as an array of this length until it returns, so the chunk, not the mesh, sets the memory a call needs."""


def _columns(a) -> np.ndarray:
    """``a`` (E, …, k) as (…, k, E): per element rows turned into the structure-of-arrays layout."""
    return np.moveaxis(np.asarray(a, dtype=float), 0, -1)


class TwoNodeBeam:
    """Adapter of a two-node family whose generated functions take
    ``(x1, x2, p1, p2, L0, psi0, gamma0, c, …)`` (Beam2, beam2_se3): ``forces(…, s, strain, stress) → U``
    and ``tangent(…, s, K)``, resultants at the one integration point (Beam2's midpoint; beam2_se3's
    strains are constant on the element)."""

    def __init__(self, forces, tangent):
        self.forces, self.tangent_function = forces, tangent

    @staticmethod
    def _inputs(data, sl, x, p) -> tuple:
        return (x[0], x[1], p[0], p[1], np.asarray(data.L0[sl], dtype=float), _columns(data.psi0[sl]),
                _columns(data.gamma0[sl]), _columns(data.stiff[sl]))

    def evaluate(self, data, sl, x, p):
        """Forces (12, E), energies (E,) and the resultants (3, E) twice (module docstring)."""
        E = x.shape[-1]
        s, strain, stress = np.empty((12, E)), np.empty((6, E)), np.empty((6, E))
        U = twin(self.forces, E)(*self._inputs(data, sl, x, p), s, strain, stress)
        return s, U, stress[:3], stress[3:]

    def tangent(self, data, sl, x, p):
        """The 12×12 section-frame tangents (12, 12, E)."""
        E = x.shape[-1]
        s, K = np.empty((12, E)), np.empty((144, E))
        twin(self.tangent_function, E)(*self._inputs(data, sl, x, p), s, K)
        return K.reshape(12, 12, E)


class QuadraticBeam:
    """Adapter of beam3 (``derivations/beam3.py``): ``internal_forces(x1, x2, x3, p1, p2, p3, L0, gamma0,
    kappa0, c, s, u, strain, stress) → U``; the tangent from the two Gauss points' Hessians
    (``gauss_hessian`` of each point's inputs ``u``) and ``tangent``; resultants the mean of the two
    Gauss points' (:meth:`reference.elements.beam3.Beam3Formulation.section_resultants`)."""

    forces = staticmethod(generated_beam3.internal_forces)
    hessian = staticmethod(generated_beam3.gauss_hessian)
    tangent_function = staticmethod(generated_beam3.tangent)

    @staticmethod
    def _inputs(data, sl, x, p) -> tuple:
        return (x[0], x[1], x[2], p[0], p[1], p[2], np.asarray(data.L0[sl], dtype=float),
                _columns(data.gamma0[sl]), _columns(data.kappa0[sl]), _columns(data.stiff[sl]))

    def _forces(self, data, sl, x, p):
        E = x.shape[-1]
        s, u, strain, stress = np.empty((18, E)), np.empty((18, E)), np.empty((12, E)), np.empty((12, E))
        U = twin(self.forces, E)(*self._inputs(data, sl, x, p), s, u, strain, stress)
        return s, U, u, stress

    def evaluate(self, data, sl, x, p):
        """Forces (18, E), energies (E,) and the two Gauss points' mean resultants (3, E) twice."""
        s, U, _, stress = self._forces(data, sl, x, p)
        return s, U, 0.5 * (stress[0:3] + stress[6:9]), 0.5 * (stress[3:6] + stress[9:12])

    def tangent(self, data, sl, x, p):
        """The 18×18 section-frame tangents (18, 18, E), as the compiled family computes them: the forces
        first (their by-product ``u``, each Gauss point's strain inputs), the points' Hessians, the tangent."""
        _, _, u, _ = self._forces(data, sl, x, p)
        inputs = self._inputs(data, sl, x, p)
        L0, gamma0, kappa0, c = inputs[6:]
        E = x.shape[-1]
        hessians, s, K = np.empty((162, E)), np.empty((18, E)), np.empty((324, E))
        for g in range(2):
            twin(self.hessian, E)(u[9 * g:9 * g + 9], gamma0[3 * g:3 * g + 3], kappa0[3 * g:3 * g + 3], c, L0,
                         hessians[81 * g:81 * g + 81])
        twin(self.tangent_function, E)(*inputs, hessians, s, K)
        return K.reshape(18, 18, E)


ADAPTERS = {
    "beam2": TwoNodeBeam(generated_beam2.internal_forces, generated_tangents.beam2_tangent),
    "beam2_se3": TwoNodeBeam(generated_se3.internal_forces, generated_se3.tangent),
    "beam3": QuadraticBeam(),
}
"""The engine's families' adapters by deck name (module docstring)."""


def adapter(formulation: type):
    """The reference-path adapter of an element family's formulation class: its ``plain`` attribute, else
    :data:`ADAPTERS`' entry.

    Raises
    ------
    ValueError
        For a family that has neither.
    """
    own = getattr(formulation, "plain", None)
    if own is not None:
        return own
    try:
        return ADAPTERS[formulation.family]
    except KeyError:
        raise ValueError(f"element family {formulation.family!r} has no reference-path functions; give its "
                         "class a `plain` adapter (reference.plain.elements) or use backend = \"compiled\"") from None


def _families(model):
    """``(data, adapter, slices)`` of every family of the model that has elements; ``slices`` its chunks."""
    for data in model.elements:
        E = int(data.conn.shape[0])
        if E:
            yield data, adapter(family_of(data)), [slice(k, min(E, k + CHUNK)) for k in range(0, E, CHUNK)]


def _ends(data, sl, x, q) -> tuple:
    """The chunk's node positions (n, 3, E), section triads ``p = q ⊗ o`` (n, 4, E) and offsets (n, 4, E); a
    family whose data have no ``offset`` works in the node frames (``o`` the identity, ``p = q``)."""
    conn = data.conn[sl]
    X = np.asarray(x, dtype=float)[conn].transpose(1, 2, 0)
    Q = np.asarray(q, dtype=float)[conn].transpose(1, 2, 0)
    if getattr(data, "offset", None) is None:
        O = np.zeros_like(Q)
        O[:, 0] = 1.0
        return X, Q, O
    O = np.asarray(data.offset[sl], dtype=float).transpose(1, 2, 0)
    P = np.empty_like(Q)
    for a in range(conn.shape[1]):
        twin(rm.quat_product, len(conn))(Q[a], O[a], P[a])
    return X, P, O


def _node_frames(s, O) -> np.ndarray:
    """Section-frame forces ``s`` (6n, E) to the nodes' frames (n, 6, E): each end's moment ``A(o_a) S_θa``."""
    n = O.shape[0]
    s = s.reshape(n, 6, -1)
    out = np.empty_like(s)
    out[:, :3] = s[:, :3]
    for a in range(n):
        twin(to_node_frame, s.shape[-1])(O[a], s[a, 3:], out[a, 3:])
    return out


def element_forces(model, x, q) -> tuple[np.ndarray, float]:
    """The internal forces of every element family, summed per node, and the strain energy.

    Parameters
    ----------
    model : reference.state.Model
    x, q : ndarray (N, 3), (N, 4)
        Node positions [m] and Euler parameters.

    Returns
    -------
    S : ndarray (N, 6)
        ``[inertial force (N), body-frame moment (N m)]`` per node: what
        :func:`reference.elements.families.assemble_forces` adds into ``S``, in the same order
        (element by element, end by end).
    U : float
        The elements' strain energy [J] (a NumPy sum: its last bits may differ from the compiled sum's).
    """
    S, U = np.zeros((len(x), 6)), 0.0
    for data, family, slices in _families(model):
        for sl in slices:
            X, P, O = _ends(data, sl, x, q)
            s, energy, _, _ = family.evaluate(data, sl, X, P)
            forces = _node_frames(s, O)  # (n, 6, E)
            np.add.at(S, data.conn[sl].reshape(-1), forces.transpose(2, 0, 1).reshape(-1, 6))
            U += float(np.sum(energy))
    return S, U


def element_resultants(model, x, q) -> tuple[np.ndarray, np.ndarray]:
    """Every element's section resultants, rows in the Domain's element order (``data.index``).

    Returns ``N``, ``M`` (E, 3): force [N] (1 axial, 2, 3 shear) and moment [N m] (1 torsion, 2, 3
    bending) in the section frame, as :func:`reference.elements.families.resultants` (Beam2 and beam2_se3
    at their one integration point, beam3 the mean of its two Gauss points).
    """
    E = model.n_elements
    N, M = np.zeros((E, 3)), np.zeros((E, 3))
    for data, family, slices in _families(model):
        for sl in slices:
            X, P, _ = _ends(data, sl, x, q)
            _, _, n, m = family.evaluate(data, sl, X, P)
            N[data.index[sl]], M[data.index[sl]] = n.T, m.T
    return N, M


def _offset_matrices(O) -> np.ndarray:
    """``A(o_a)`` (E, n, 3, 3) of the ends' offsets ``O`` (n, 4, E), column by column the map of
    :func:`~reference.elements.formulation.to_node_frame` (the same arithmetic as the forces' moments)."""
    n, E = O.shape[0], O.shape[2]
    A = np.empty((E, n, 3, 3))
    out = np.empty((3, E))
    for a in range(n):
        for k in range(3):
            twin(to_node_frame, E)(O[a], np.repeat(np.eye(3)[:, k:k + 1], E, axis=1), out)
            A[:, a, :, k] = out.T
    return A


def element_tangent(model, x, q) -> sp.csr_matrix:
    """The element families' tangent stiffness ``∂S/∂δ`` (6N, 6N), node frames, fixed coordinates included.

    Each element's block ``T K_sec Tᵀ`` (module docstring) added at its nodes' rows and columns: what
    :func:`reference.elements.families.tangent_values` writes with ``c_k = 1`` and ``ψ = 0``, assembled.
    """
    N = len(x)
    blocks, rows = [], []
    for data, family, slices in _families(model):
        for sl in slices:
            X, P, O = _ends(data, sl, x, q)
            K = family.tangent(data, sl, X, P).transpose(2, 0, 1)  # (E, 6n, 6n)
            n = O.shape[0]
            T = np.zeros(K.shape)
            T[:, np.arange(6 * n), np.arange(6 * n)] = 1.0
            for a, A in enumerate(np.moveaxis(_offset_matrices(O), 1, 0)):
                T[:, 6 * a + 3:6 * a + 6, 6 * a + 3:6 * a + 6] = A
            blocks.append(T @ K @ T.transpose(0, 2, 1))
            rows.append((6 * data.conn[sl][:, :, None] + np.arange(6)).reshape(len(K), 6 * n))
    if not blocks:
        return sp.csr_matrix((6 * N, 6 * N))
    r = np.concatenate([np.repeat(idx[:, :, None], idx.shape[1], axis=2).reshape(-1) for idx in rows])
    c = np.concatenate([np.repeat(idx[:, None, :], idx.shape[1], axis=1).reshape(-1) for idx in rows])
    values = np.concatenate([b.reshape(-1) for b in blocks])
    return sp.csr_matrix(sp.coo_matrix((values, (r, c)), shape=(6 * N, 6 * N)))


SECTION_DERIVATIVES = {
    "beam2": generated_sensitivities.beam2_section_derivative,
    "beam2_se3": generated_sensitivities.beam2_se3_section_derivative,
    "beam3": generated_sensitivities.beam3_section_derivative,
}
"""The engine's families' generated ``∂S/∂c`` (derivations/sensitivities.py) by deck name: the force kernel's
inputs but the stiffness ``c`` (its last), writing ``ds`` (6n × 6, row-major)."""


def element_stiffness_derivatives(model, x, q) -> list:
    """``∂S/∂c`` of every element by its six section stiffnesses ``c = (EA, GA2, GA3, GJ, EI2, EI3)``, node frames.

    One pass over the families (chunks of :data:`CHUNK`), the generated kernels of :data:`SECTION_DERIVATIVES`
    (or a family class's ``section_derivative``) in the section frames, each column's moments mapped to the node
    frames as the forces' (:func:`_node_frames`).

    Returns
    -------
    list of (index (E,), conn (E, n), ds (E, n, 6, 6))
        Per chunk the elements' Domain numbers, nodes and ``ds[e, a, k, j] = ∂S_{a,k}/∂c_j`` (node a's
        coordinate k: inertial force [N per unit of c_j], body-frame moment).
    """
    out = []
    for data, family, slices in _families(model):
        formulation = family_of(data)
        kernel = getattr(formulation, "section_derivative", None) or SECTION_DERIVATIVES[formulation.family]
        for sl in slices:
            X, P, O = _ends(data, sl, x, q)
            E, n = X.shape[-1], X.shape[0]
            ds = np.empty((6 * n * 6, E))
            twin(kernel, E)(*family._inputs(data, sl, X, P)[:-1], ds)
            columns = ds.reshape(6 * n, 6, E).reshape(6 * n, 6 * E)  # column j of element e at j E + e
            blocks = _node_frames(columns, np.tile(O, (1, 1, 6))).reshape(n, 6, 6, E)  # (n, 6, j, E)
            out.append((np.asarray(data.index[sl]), data.conn[sl], blocks.transpose(3, 0, 1, 2)))
    return out


__all__ = ["ADAPTERS", "CHUNK", "QuadraticBeam", "TwoNodeBeam", "adapter", "element_forces",
           "element_resultants", "element_stiffness_derivatives", "element_tangent", "SECTION_DERIVATIVES"]
