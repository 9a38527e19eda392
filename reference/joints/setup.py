"""Constraint set-up: from the Domain's joints to the Model's constraint fields, checked at t = 0.

When the Domain is initialised (paper §4.3, ``Initialization``) its joints are
split by the layout of their formulation (§4.2.3): the multiplier ones
(:class:`~reference.joints.Jacobian`, the augmented Lagrangian) give rows with
multipliers, the :class:`~reference.joints.MasterSlave` ones eliminated coordinates.
This module

1. hands them to their formulations, which validate them and lay out the
   :class:`~reference.state.Model`'s constraint fields (:func:`constraint_fields`):
   the joint tables, each row's ε, the fixed sparsity of ``B M⁻¹ Bᵀ``
   (:mod:`reference.joints.sparse`) and the master/slave parameters;
3. refuses redundant, unregularised constraints, naming the joints of the loop
   (:func:`check_redundancy`), and makes initial velocities consistent with the
   velocity constraints (:func:`project_initial_velocities`) — both with the
   step's own sparse factor of ``B M⁻¹ Bᵀ`` (docs/formulation.md §7).

:func:`constraint_matrices` gives Φ, Φ_t, B and B M⁻¹ as dense arrays for
tests and tools; the step never forms them.
"""

from __future__ import annotations

import hashlib
from typing import Callable

import numpy as np

from reference.joints.assembly import (
    apply_inverse_mass, assemble_constraints, assemble_w, jacobian_times, sparse_cholesky, sparse_solve,
    subtract_transpose,
)
from reference.joints.formulations import LAYOUTS, layout_of
from reference.joints.joint import PRESCRIBED, Joint
from reference.scalar import REMEMBERED, build_time_form
from reference.state import Model, State

DEPENDENT_PIVOT = 1e-10
"""A constraint row whose Cholesky pivot in ``B M⁻¹ Bᵀ`` is below this fraction of
its diagonal entry (its remainder's M⁻¹-norm below 1e-5 of its own) depends on
the rows before it.  The pivot is a difference of squares, so round-off leaves
~1e-15 of the diagonal in a truly dependent row; the independent rows of the
rigid four-bar (tests/test_pendulum.py) stay above 3e-4."""


def multiplier_joints(joints: list[Joint]) -> list[Joint]:
    """Joints with rows in the Lagrange-multiplier system (``formulation.multipliers``), in order."""
    return [j for j in joints if j.formulation.multipliers]


def constraint_fields(joints: list[Joint], n_nodes: int, tf_index: Callable, beam_nodes: set,
                      fixed: set) -> tuple[dict, np.ndarray]:
    """The :class:`~reference.state.Model` fields of the constraints — each layout's own
    (:meth:`~reference.joints.formulation.JointFormulation.model_fields` of every layout of
    :data:`~reference.joints.formulations.LAYOUTS`, with its joints in the Domain's order) — and
    per node (N,) 1 for a node of any joint, else 0.

    Parameters
    ----------
    joints : list of Joint
        All joints of the Domain.
    n_nodes : int
        Number of nodes N.
    tf_index : callable(TimeFunction) → int
        The row of a time function in the Model's table (added if new).
    beam_nodes, fixed : set of int
        Ids of the nodes of elements, and of the nodes with fixed coordinates.
    """
    for joint in joints:
        try:
            layout_of(joint.formulation)
        except ValueError as exc:
            raise ValueError(f"joint {joint.label!r}: {exc}") from None
    fields: dict = {}
    for layout in LAYOUTS:
        own = [j for j in joints if isinstance(j.formulation, layout)]
        fields.update(layout.model_fields(own, n_nodes, tf_index, beam_nodes, fixed))
    node_constrained = np.zeros(n_nodes, dtype=np.int64)
    for joint in joints:
        for body in (joint.body_i, joint.body_j):
            if body is not None:
                node_constrained[body.id] = 1
    return fields, node_constrained


def _form(kernel, model: Model):
    """A joint kernel called once per model or run: its Python form for a model of few joints (nothing to
    compile), the compiled kernel for many (:func:`reference.scalar.build_time_form`)."""
    return build_time_form(kernel, model.joints.i.shape[0])


def constraint_blocks(model: Model, x, q, t: float):
    """Φ (m,), Φ_t (m,) and the joints' blocks of B and B M⁻¹ (J, 6, 12) at a configuration.

    Evaluated by the step's kernels (:func:`reference.joints.assembly.assemble_constraints`,
    ``apply_inverse_mass``), in their Python form for a model of few joints (:func:`_form`): once per model or
    run, where compiling them would cost more than it saves.
    """
    m, J = model.n_constraints, model.joints.i.shape[0]
    PHI, PHIt, Bj, BMj = np.zeros(m), np.zeros(m), np.zeros((J, 6, 12)), np.zeros((J, 6, 12))
    x, q = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(q, dtype=float)
    _form(assemble_constraints, model)(model, x, q, float(t), PHI, PHIt, Bj, np.zeros(10), np.zeros(120))
    _form(apply_inverse_mass, model)(model, Bj, BMj)
    return PHI, PHIt, Bj, BMj


def constraint_matrices(model: Model, x, q, t: float = 0.0):
    """Global Φ (m,), Φ_t (m,), B (m, 6N) and B M⁻¹ (m, 6N) at a configuration, dense.

    Columns ``[v_n | ω_n]`` per node n (inertial velocity, body-frame angular
    velocity).  A convenience for tests and tools (the step never forms these arrays).
    """
    PHI, PHIt, Bj, BMj = constraint_blocks(model, x, q, t)
    N, m = x.shape[0], model.n_constraints
    Bg, BM = np.zeros((m, 6 * N)), np.zeros((m, 6 * N))
    for k in range(Bj.shape[0]):
        r0, mk = model.joints.row0[k], model.joints.neq[k]
        for side, n in enumerate((model.joints.i[k], model.joints.j[k])):
            if n >= 0:
                Bg[r0:r0 + mk, 6 * n:6 * n + 6] += Bj[k, :mk, 6 * side:6 * side + 6]
                BM[r0:r0 + mk, 6 * n:6 * n + 6] += BMj[k, :mk, 6 * side:6 * side + 6]
    return PHI, PHIt, Bg, BM


def dependent_rows(model: Model, Bj, BMj):
    """Sparse Cholesky of ``B M⁻¹ Bᵀ`` dropping dependent rows: the factor and the dropped rows' flags.

    A row is dropped when its pivot — the squared M⁻¹-norm of what remains of
    it after the rows eliminated before it are projected out, as in
    Gram–Schmidt — is below :data:`DEPENDENT_PIVOT` of its own squared norm.
    """
    Lx, dependent = np.zeros(model.joints.pattern.L_rowidx.shape[0]), np.zeros(model.n_constraints, dtype=np.int64)
    _form(assemble_w, model)(model, Bj, BMj, Lx)
    _form(sparse_cholesky, model)(model, Lx, np.zeros(model.n_constraints), 0.0, DEPENDENT_PIVOT, dependent)
    return Lx, dependent


def dependency_rows(model: Model, Lx, dependent, positions) -> list[int]:
    """The constraint rows taking part in the dependencies of the dropped rows at ``positions``.

    A dropped row p is ``Σ_k c_k`` (earlier rows k) with ``Lᵀ c = L[p, :p]ᵀ``
    (its factor row in the orthonormalised basis mapped back to the rows);
    the rows with ``|c_k| > 1e-8 max |c|`` and p itself are returned.
    """
    if len(positions) == 0:
        return []
    import scipy.sparse
    import scipy.sparse.linalg

    m = model.n_constraints
    ncol = np.diff(model.joints.pattern.L_colptr)
    cols = np.repeat(np.arange(m), ncol)
    values = Lx.copy()
    values[model.joints.pattern.L_colptr[:-1][dependent == 1]] = 1.0  # dropped rows: unit pivot, zero column
    L = scipy.sparse.csr_matrix((values, (model.joints.pattern.L_rowidx, cols)), shape=(m, m))
    row_perm = np.argsort(model.joints.pattern.row_iperm)
    rows: set[int] = set()
    for p in positions:
        rhs = np.zeros(m)
        lrow = L.getrow(p)
        rhs[lrow.indices] = lrow.data
        rhs[p] = 0.0
        rhs[dependent == 1] = 0.0
        c = scipy.sparse.linalg.spsolve_triangular(L.T.tocsr(), rhs, lower=False)
        big = np.abs(c) > 1e-8 * max(np.abs(c).max(), 1e-300)
        rows.update(row_perm[np.flatnonzero(big)].tolist() + [int(row_perm[p])])
    return sorted(rows)


def _digest(*parts) -> bytes:
    """A digest of the values of ``parts``: nested (named) tuples of arrays and numbers, with their shapes and
    types."""
    h = hashlib.blake2b(digest_size=20)

    def walk(part):
        if isinstance(part, tuple):
            h.update(b"(")
            for item in part:
                walk(item)
            h.update(b")")
        elif isinstance(part, np.ndarray):
            h.update(f"{part.dtype.str}{part.shape}".encode())
            h.update(np.ascontiguousarray(part).tobytes())
        else:
            h.update(repr(part).encode())

    walk(parts)
    return h.digest()


REDUNDANCY_CHECKED: dict = {}
"""Digests of the models (joints, nodes, time functions) and configurations :func:`check_redundancy` passed, the
newest :data:`reference.scalar.REMEMBERED` of them: ``Domain.solve`` rebuilds the model and checks it again at
every call, and a study that solves one model again and again would otherwise repeat the check in Python."""


def check_redundancy(model: Model, lagrange: list[Joint], x, q) -> None:
    """Refuse redundant constraints that are not regularised (ε = 0), naming the joints.

    The rows of B at ``(x, q)`` (the initial configuration) are orthogonalised
    in the M⁻¹ inner product ``⟨a, b⟩ = a M⁻¹ bᵀ`` (the metric of ``B M⁻¹ Bᵀ``)
    by the sparse Cholesky factorisation of ``B M⁻¹ Bᵀ`` in the elimination
    order of the step (:func:`dependent_rows`): a row whose pivot is negligible
    depends on the rows eliminated before it.  Cost as for one step's
    factorisation; a model and configuration that passed are remembered (:data:`REDUNDANCY_CHECKED`).

    Parameters
    ----------
    model : Model
    lagrange : list of Joint
        The multiplier joints, in the order of their rows (:func:`multiplier_joints`).
    x, q : arrays (N, 3), (N, 4)
        Positions and Euler parameters.

    Raises
    ------
    ValueError
        ``redundant constraints: …`` (:func:`redundancy_message`): the equations that stay redundant
        once the regularised rows (ε > 0, which give way) are discounted, each loop with its fix.
    """
    if model.n_constraints == 0:
        return
    key = _digest(model.joints, model.nodes, model.time_functions, np.asarray(x, dtype=float),
                  np.asarray(q, dtype=float), tuple(j.formulation.epsilon for j in lagrange))
    if key in REDUNDANCY_CHECKED:
        return
    _check_redundancy(model, lagrange, x, q)
    if len(REDUNDANCY_CHECKED) >= REMEMBERED:
        REDUNDANCY_CHECKED.pop(next(iter(REDUNDANCY_CHECKED)))
    REDUNDANCY_CHECKED[key] = True


def _check_redundancy(model: Model, lagrange: list[Joint], x, q) -> None:
    """:func:`check_redundancy` itself, for a model not yet checked."""
    _, _, Bj, BMj = constraint_blocks(model, x, q, 0.0)
    Lx, dependent = dependent_rows(model, Bj, BMj)
    redundant = np.flatnonzero(dependent[model.joints.pattern.row_iperm])
    owner = [joint for joint in lagrange for _ in range(joint.n_equations)]
    loops: dict = {}
    for r in redundant:
        if owner[r].formulation.epsilon != 0.0:
            continue  # a regularised row: a compliance, not a constraint
        involved = dependency_rows(model, Lx, dependent, model.joints.pattern.row_iperm[[r]])
        if any(owner[k].formulation.epsilon != 0.0 for k in involved):
            continue  # the dependency goes through a regularised row: the compliance absorbs it
        labels = frozenset(owner[k].label for k in involved)
        loops[labels] = loops.get(labels, 0) + 1
    if not loops:
        return
    raise ValueError(redundancy_message(lagrange, loops))


MESSAGE_LENGTH = 200
"""The redundancy message's length: the loops beyond it are counted, not listed."""


def redundancy_message(lagrange: list[Joint], loops: dict) -> str:
    """One line: how many equations are redundant once the regularised joints are discounted, and each
    loop (joints in the order of the deck) with the joint to regularise (docs/deck.md, "Redundant
    constraints", gives the other fixes).  ``loops``: joint labels of a loop → its redundant equations."""
    order = {j.label: k for k, j in enumerate(lagrange)}
    kinds = {j.label: j for j in lagrange}
    n = sum(loops.values())
    head = f"redundant constraints: {n} equation(s) stay dependent after regularisation: "
    tail = " (docs/deck.md, redundant constraints)"
    parts = []
    for labels, count in sorted(loops.items(), key=lambda item: min(order[x] for x in item[0])):
        loop = sorted(labels, key=order.__getitem__)
        stiff = [x for x in loop if kinds[x].formulation.epsilon == 0.0]
        settable = [x for x in stiff if kinds[x].kind != PRESCRIBED]  # a prescribed displacement has no epsilon
        fix = (f"epsilon > 0 on {settable[-1]}" if settable else
               f"remove the prescribed displacement {stiff[-1]} or the constraint it repeats")
        parts.append(f"{count} in the loop {', '.join(loop)}, fix: {fix}")
    shown = []
    for k, part in enumerate(parts):
        rest = len(parts) - k - 1
        more = f"; {rest} more loop(s)" if rest else ""
        if shown and len(head + "; ".join(shown + [part]) + more + tail) > MESSAGE_LENGTH:
            shown.append(f"{len(parts) - k} more loop(s)")
            break
        shown.append(part)
    return head + "; ".join(shown) + tail


RIGID_SIZE = 2 * 10**7
"""Largest ``rows × columns`` of the dense least-squares problem of :func:`rigid_body_correction`
(160 MB); a larger model skips it and gets the nodal projection only."""


def flexible_bodies(n_nodes: int, element_nodes) -> np.ndarray:
    """Per node (N,) the number of its flexible body — the nodes joined by elements — or −1 for a node
    of no element (a rigid body, a point mass). ``element_nodes``: each element's node ids."""
    import scipy.sparse
    import scipy.sparse.csgraph

    pairs = np.array([(e[0], n) for e in element_nodes for n in e[1:]], dtype=np.int64).reshape(-1, 2)
    graph = scipy.sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n_nodes, n_nodes))
    _, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    body = np.full(n_nodes, -1, dtype=np.int64)
    used = np.unique(pairs)
    body[used] = np.unique(label[used], return_inverse=True)[1]
    return body


def _rigid_maps(model: Model, x, q, nodes) -> np.ndarray:
    """(n, 6, 6): for each of ``nodes`` the map from a rigid motion ``(v_c, ω)`` of their body (velocity of
    its centre of mass c, inertial angular velocity) to the node's ``(v_n, ω_n)``:
    ``v_n = v_c + ω × (x_n − x_c)``, ``ω_n = A_nᵀ ω`` (body frame, A_n the node's rotation matrix)."""
    from reference.rotation import EulerParameters, skew

    mass = model.nodes.mass[nodes]
    centre = mass @ x[nodes] / mass.sum()
    T = np.zeros((len(nodes), 6, 6))
    for k, n in enumerate(nodes):
        T[k, :3, :3] = np.eye(3)
        T[k, :3, 3:] = -skew(x[n] - centre)
        T[k, 3:, 3:] = EulerParameters(q[n]).matrix().T
    return T


def _pair_constraints(model: Model, q) -> list:
    """Each master/slave pair's velocity constraints: ``(C, master, slave)`` with ``C [V_m; V_s] = 0``
    (rows spanning the complement of the pair's motions ``V = T u``, :mod:`reference.joints.master_slave`)."""
    import scipy.linalg

    from reference.joints.master_slave import _pair_matrices

    pair_matrices = getattr(_pair_matrices, "py_func", _pair_matrices)
    out = []
    T, A_m, A_s = np.zeros((12, 9)), np.zeros(9), np.zeros(9)
    for k in range(model.master_slave.master.shape[0]):
        d = pair_matrices(model, k, q, T, A_m, A_s)
        out.append((scipy.linalg.null_space(T[:, :d].T).T, model.master_slave.master[k], model.master_slave.slave[k]))
    return out


def rigid_body_correction(model: Model, state: State, body: np.ndarray) -> None:
    """Add to the initial velocities the rigid motions of the bodies that make the velocity constraints
    hold with least kinetic energy, in place: each flexible body moves as one rigid body, each other node
    of a joint as itself.

    ``body`` (N,): :func:`flexible_bodies`. The correction is ``ΔV = T y``, ``T`` the rigid motions of the
    bodies (:func:`_rigid_maps`, restricted to those their fixed coordinates allow) and of the other nodes;
    ``y`` minimises the kinetic energy ``½ yᵀ (Tᵀ M T) y`` subject to ``B T y = −(B V0 + Φ_t)`` and the
    master/slave pairs' velocity constraints (least squares, dependent rows dropped by the SVD). A model
    whose drives cannot be followed by rigid bodies (a clamped beam driven at its tip) is left with the
    residual that :func:`project_initial_velocities` then removes at the joints' nodes; so is a model too
    large for the dense problem (:data:`RIGID_SIZE`) or whose masses overflow it.
    """
    import scipy.linalg

    pairs = _pair_constraints(model, state.q)
    joint_nodes = [n for n in (*model.joints.i, *model.joints.j, *(p[1] for p in pairs), *(p[2] for p in pairs))
                   if n >= 0]
    groups = sorted({int(body[n]) if body[n] >= 0 else -1 - int(n) for n in joint_nodes})
    if not any(g >= 0 for g in groups):
        return
    maps, column = {}, {}  # node → (its map to the group's columns (6, k)), group → first column
    Mr, cols = [], 0
    for g in groups:
        nodes = np.flatnonzero(body == g) if g >= 0 else np.array([-1 - g])
        T = _rigid_maps(model, state.x, state.q, nodes) if g >= 0 else np.eye(6)[None]
        fixed = np.concatenate([T[k][model.nodes.free[n] == 0.0] for k, n in enumerate(nodes)])
        basis = scipy.linalg.null_space(fixed) if len(fixed) else np.eye(6)
        mass = np.zeros((basis.shape[1], basis.shape[1]))
        for k, n in enumerate(nodes):
            Tn = T[k] @ basis
            maps[int(n)] = Tn
            Mn = np.zeros((6, 6))
            Mn[:3, :3], Mn[3:, 3:] = model.nodes.mass[n] * np.eye(3), model.nodes.inertia[n]
            mass += Tn.T @ Mn @ Tn
        column[g], cols = cols, cols + basis.shape[1]
        Mr.append(mass)
    m = model.n_constraints + sum(p[0].shape[0] for p in pairs)
    if m * cols > RIGID_SIZE or cols == 0:
        return

    def columns(n):
        g = int(body[n]) if body[n] >= 0 else -1 - int(n)
        return slice(column[g], column[g] + maps[int(n)].shape[1])

    _, PHIt, Bj, _ = constraint_blocks(model, state.x, state.q, state.t)
    A, r = np.zeros((m, cols)), np.zeros(m)
    _form(jacobian_times, model)(model, Bj, state.v, state.w, r[:model.n_constraints])
    r[:model.n_constraints] = -(r[:model.n_constraints] + PHIt)
    for k in range(Bj.shape[0]):
        r0, mk = model.joints.row0[k], model.joints.neq[k]
        for side, n in enumerate((model.joints.i[k], model.joints.j[k])):
            if n >= 0:
                A[r0:r0 + mk, columns(n)] += Bj[k, :mk, 6 * side:6 * side + 6] @ maps[int(n)]
    row = model.n_constraints
    for C, master, slave in pairs:
        V = np.concatenate([state.v[master], state.w[master], state.v[slave], state.w[slave]])
        A[row:row + len(C), columns(master)] += C[:, :6] @ maps[int(master)]
        A[row:row + len(C), columns(slave)] += C[:, 6:] @ maps[int(slave)]
        r[row:row + len(C)] = -C @ V
        row += len(C)
    mass = scipy.linalg.block_diag(*Mr)
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(r)) and np.all(np.isfinite(mass))):
        return  # an overflowing mass or a non-finite velocity: the nodal projection alone
    try:
        L = scipy.linalg.cholesky(mass, lower=True)
        u = scipy.linalg.lstsq(scipy.linalg.solve_triangular(L, A.T, lower=True).T, r)[0]
    except np.linalg.LinAlgError:
        return  # masses too far apart for the dense factorisation: the nodal projection alone
    y = scipy.linalg.solve_triangular(L.T, u, lower=False)
    for n, Tn in maps.items():
        g = int(body[n]) if body[n] >= 0 else -1 - n
        dV = Tn @ y[column[g]:column[g] + Tn.shape[1]]
        state.v[n] += dV[:3]
        state.w[n] += dV[3:]


def project_initial_velocities(model: Model, state: State, body: np.ndarray | None = None) -> None:
    """Make the initial velocities consistent: ``V = V0 − M⁻¹Bᵀ (B M⁻¹ Bᵀ)⁻¹ (B V0 + Φ_t)``, in place.

    The M-orthogonal projection changes the kinetic energy least; for a
    mechanism driven from rest it gives the velocities of the driven motion.
    Solved with the sparse factor of the step's pattern; dependent
    (regularised redundant) rows are dropped, which leaves the projection
    unchanged when the velocity constraints are consistent.

    The projection moves only the nodes of the joints: a flexible body's other nodes would stay
    behind, and its elements start with a strain rate of the order of the drive's speed over an
    element's length. With ``body`` (:func:`flexible_bodies`) the velocities first get the rigid motions
    of the bodies that satisfy the constraints (:func:`rigid_body_correction`), and the projection then
    removes only what rigid bodies cannot follow.
    """
    if body is not None:
        rigid_body_correction(model, state, body)
    _, PHIt, Bj, BMj = constraint_blocks(model, state.x, state.q, state.t)
    Lx, _ = dependent_rows(model, Bj, BMj)
    rhs = np.zeros(model.n_constraints)
    _form(jacobian_times, model)(model, Bj, state.v, state.w, rhs)
    y = np.zeros_like(rhs)
    y[model.joints.pattern.row_iperm] = rhs + PHIt
    _form(sparse_solve, model)(model, Lx, y)
    _form(subtract_transpose, model)(model, BMj, y[model.joints.pattern.row_iperm], state.v, state.w)
