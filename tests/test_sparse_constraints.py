"""The sparse constraint stage (reference/joints/sparse.py, reference/joints/assembly.py).

The stage must give what the dense formulation gives — the stabilised impulse
``(B M⁻¹ Bᵀ + ε/(h h_k) I) Λ = B V* + Φ_t + Φ/h``, ``V = V* − M⁻¹ Bᵀ Λ`` — solved
here densely with numpy from ``Domain.constraint_matrices``, at states along
real trajectories; and its factor must stay linear in size for chains and trees.
"""

from __future__ import annotations

import numpy as np
import pytest

from flexmbs.bench_scaling import LINK, spherical_chain, two_beams
from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.interactions import Gravity
from reference.io.deck import load_deck
from reference.joints.assembly import OK, assemble_constraints, constraint_impulse, factor_constraints
from reference.joints.setup import constraint_blocks
from reference.joints.sparse import constraint_pattern, jacobian_csr_structure
from reference.state import Scratch
from tests.test_pendulum import four_bar

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent


def binary_tree(depth: int) -> Domain:
    """Rigid links in a binary tree (each link carries two children), spherical joints, gravity."""
    d = Domain("tree")
    root = d.add_rigid_bar("r", (0.0, 0.0, 0.0), (0.1, 0.0, 0.0), Section(**LINK))
    d.add_joint("spherical", root, None, (0.0, 0.0, 0.0))
    level = [(root, np.array([0.1, 0.0, 0.0]))]
    for g in range(depth):
        nxt = []
        for k, (parent, tip) in enumerate(level):
            for side in (-1.0, 1.0):
                end = tip + np.array([0.1, 0.05 * side * 2.0 ** -g, 0.01 * side])
                child = d.add_rigid_bar(f"l{g}_{k}_{side:+.0f}", tip, end, Section(**LINK))
                d.add_joint("spherical", child, parent, tip)
                nxt.append((child, end))
        level = nxt
    d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
    d.solver = SolverSettings(dt=1e-4, t_end=0.02, output_every=50)
    return d


def dense_impulse(domain, model, x, q, t, v, w, h, hk):
    """The constraint stage, dense (numpy): corrected velocities and λ."""
    PHI, PHIt, Bg, BM = domain.constraint_matrices(model, x, q, t)
    V = np.concatenate([v, w], axis=1).reshape(-1)
    W = BM @ Bg.T + np.diag(model.joints.eps / (h * hk))
    Lam = np.linalg.solve(W, Bg @ V + PHIt + PHI / h)
    Vn = (V - BM.T @ Lam).reshape(-1, 6)
    return Vn[:, :3], Vn[:, 3:], Lam / hk


CASES = {
    "three-bar": lambda: load_deck(ROOT / "models" / "three_bar.toml", overrides={"t_end": 0.2}).domain,
    "chain": lambda: spherical_chain(12, steps=200),
    "tree": lambda: binary_tree(3),
    "closed loop (regularised)": lambda: four_bar(1e-9),
}


@pytest.mark.parametrize("name", list(CASES))
def test_sparse_stage_equals_the_dense_solve(name):
    """At the states of a run (t = 0 and every output), the compiled sparse stage and a dense
    numpy solve of the same equations agree to round-off: |ΔV| ≤ 1e-11 max|V*| (the dense solve's
    own error is cond(W) ε ≈ 1e-13 here) and |Δλ| ≤ 1e-9 max|λ| (λ carries 1/h²)."""
    d = CASES[name]()
    r = d.solve()
    model = d.model
    scratch = Scratch.for_model(model)
    rng = np.random.default_rng(1)
    h = d.solver.dt
    for n in range(len(r.time)):
        x, q = r.positions[n], r.rotations[n]
        v = r.velocities[n] + 0.1 * rng.standard_normal(r.velocities[n].shape)  # a predictor V* off the manifold
        w = r.angular_velocities[n] + 0.1 * rng.standard_normal(r.velocities[n].shape)
        w[model.nodes.free[:, 3:] == 0.0] = 0.0
        v[model.nodes.free[:, :3] == 0.0] = 0.0
        for hk in (h, 0.5 * h):
            assemble_constraints(model, x, q, r.time[n], scratch.PHI, scratch.PHIt, scratch.Bj, scratch.prim_phi,
                                 scratch.prim_B)
            assert factor_constraints(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, h, hk) == OK
            vs, ws = v.copy(), w.copy()
            constraint_impulse(model, scratch.Bj, scratch.BMj, scratch.Lx, scratch.work, scratch.PHI, scratch.PHIt,
                               vs, ws, h, hk, scratch.lam)
            vd, wd, lam = dense_impulse(d, model, x, q, r.time[n], v, w, h, hk)
            scale = max(np.abs(v).max(), np.abs(w).max())
            assert np.abs(vs - vd).max() <= 1e-11 * scale
            assert np.abs(ws - wd).max() <= 1e-11 * scale
            assert np.abs(scratch.lam - lam).max() <= 1e-9 * np.abs(lam).max()


def test_factor_grows_linearly_for_chains_and_trees():
    """Minimum-degree ordering: a chain's and a tree's Cholesky factor has no fill beyond the
    blocks of W (the joint graph is chordal, a leaf is eliminated first), so its size is
    proportional to the number of joints; a closed loop adds one row of blocks along the loop."""
    for K in (100, 200, 400):
        jt_i, jt_j, neq = np.arange(K), np.arange(K) - 1, np.full(K, 3)
        p = constraint_pattern(jt_i, jt_j, neq)
        # W's lower triangle: 6 per diagonal block + 9 per neighbouring pair
        assert p.nnz == 6 * K + 9 * (K - 1)
    tree = binary_tree(5).model  # 63 links, 63 joints: node 0 carries the ground joint and two children
    J = tree.joints.i.shape[0]
    pairs = sum(1 for a in range(J) for b in range(a) if {tree.joints.i[a], tree.joints.j[a]} - {-1}
                & {tree.joints.i[b], tree.joints.j[b]} - {-1})
    assert tree.joints.pattern.L_rowidx.shape[0] == 6 * J + 9 * pairs
    # a ring of K links (closed loop): fill along the loop, still linear in K
    for K in (100, 200):
        jt_i, jt_j = np.arange(K), (np.arange(K) - 1) % K
        p = constraint_pattern(jt_i, jt_j, np.full(K, 3))
        assert p.nnz <= 6 * K + 9 * K + 9 * 2 * K


def test_jacobian_csr_structure_gives_the_dense_B():
    """The scipy.sparse face of B (for the implicit algorithms) is the dense B of constraint_matrices."""
    import scipy.sparse

    d = load_deck(ROOT / "models" / "three_bar.toml").domain
    model = d.model
    x = np.array([n.position for n in d.nodes]) + 0.01
    q = np.array([n.rotation for n in d.nodes])
    _, _, Bg, _ = d.constraint_matrices(model, x, q, 0.3)
    _, _, Bj, _ = constraint_blocks(model, x, q, 0.3)
    indptr, indices, source = jacobian_csr_structure(model.joints.i, model.joints.j, model.joints.neq, len(d.nodes))
    B = scipy.sparse.csr_matrix((Bj.reshape(-1)[source], indices, indptr), shape=Bg.shape)
    assert np.array_equal(B.toarray(), Bg)


def test_consistent_initial_velocities_equal_the_dense_projection():
    """The sparse projection of the initial velocities equals the dense least-squares one
    (V0 − M⁻¹Bᵀ W⁺(B V0 + Φ_t)) to 1e-12 on a chain started with random velocities."""
    d = spherical_chain(8)
    d.solver.consistent_initial_velocities = True
    rng = np.random.default_rng(2)
    for node in d.nodes:
        node.velocity, node.angular_velocity = rng.standard_normal(3), rng.standard_normal(3)
    model = d.initialization()
    state = d.initial_conditions()
    _, PHIt, Bg, BM = d.constraint_matrices(model)
    V0 = np.concatenate([np.array([n.velocity for n in d.nodes]), np.array([n.angular_velocity for n in d.nodes])],
                        axis=1).reshape(-1)
    lam = np.linalg.lstsq(BM @ Bg.T, Bg @ V0 + PHIt, rcond=1e-12)[0]
    V = (V0 - BM.T @ lam).reshape(-1, 6)
    assert np.abs(state.v - V[:, :3]).max() <= 1e-12 * np.abs(V0).max()
    assert np.abs(state.w - V[:, 3:]).max() <= 1e-12 * np.abs(V0).max()
    assert np.abs(Bg @ np.concatenate([state.v, state.w], axis=1).reshape(-1) + PHIt).max() <= 1e-12


def test_welded_beams_move_as_the_beams_sharing_a_node():
    """A `fixed` joint welding two beams gives the motion of the same beams sharing the node:
    tip deflection equal within 1e-12 of itself after 200 steps (round-off of the projection
    over the steps; measured 2e-16)."""
    tips = []
    for welded in (False, True):
        d = two_beams(welded, n_elements=8, steps=200)
        tips.append(d.solve().position("b:8")[-1])
    assert abs(tips[1][2] - tips[0][2]) <= 1e-12 * abs(tips[0][2])
    assert abs(tips[0][2]) > 0.0
