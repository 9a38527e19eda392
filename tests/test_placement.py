"""The model's set-up over all the elements of a family at once (reference/elements/placement.py, the families'
``lumped_masses`` and ``rest_states``, Domain.critical_time_step) gives the numbers of the element-by-element loop
bit for bit, on a random mesh of every family with straight, curved and kinked beams, random section frames and a
rigid body: the lumped masses and rotary inertias (node frames), the reference states, the critical step."""

import numpy as np

from reference.domain import Domain
from reference.elements import Section
from reference.elements.formulation import end_offsets, rotation_matrices, vector_norms
from reference.generated import rotation_maps as rm
from reference.interactions import Clamp
from reference.rotation import EulerParameters


def unit_quaternions(rng, k):
    q = rng.standard_normal((k, 4))
    return q / np.linalg.norm(q, axis=1)[:, None]


def random_domain(seed: int) -> Domain:
    """Beams of the three families sharing nodes: straight, arcs (every end kinked from its node), a random
    kink, elements between nodes of random frames with random section frames, and a rigid body."""
    rng = np.random.default_rng(seed)
    d = Domain("random")

    def section():
        return Section(**{k: float(rng.uniform(0.5, 3.0)) for k in
                          ("EA", "GA2", "GA3", "GJ", "EI2", "EI3", "rhoA", "rhoJ1", "rhoJ2", "rhoJ3")})

    a = d.add_beam("straight", (0, 0, 0), (1.0, 0.3, 0.1), 5, section())
    b = d.add_beam("arc", a[-1].position, a[-1].position + np.array([1.0, 1.0, 0.0]), 7, section(),
                   center=a[-1].position + np.array([0.0, 1.0, 0.0]), start_node=a[-1], axis2=(0.0, 0.0, 1.0))
    c = d.add_beam("kink", b[-1].position, b[-1].position + rng.uniform(-1, 1, 3), 4, section(), start_node=b[-1],
                   element="beam3")
    e = d.add_beam("se3", c[-1].position, c[-1].position + rng.uniform(-1, 1, 3), 6, section(), start_node=c[-1],
                   element="beam2_se3")
    d.add_beam("se3arc", (0, 0, 0), (0.0, -1.0, 1.0), 5, section(), start_node=a[0], element="beam2_se3",
               center=(0.0, 0.0, 1.0), axis2=(1.0, 0.0, 0.0))
    d.add_beam("b3arc", e[-1].position, e[-1].position + np.array([0.5, 0.5, 0.0]), 3, section(), start_node=e[-1],
               element="beam3", center=e[-1].position + np.array([0.5, 0.0, 0.0]), axis2=(0.0, 0.0, 1.0))
    ids = [d.add_node(rng.uniform(-3, 3, 3), rotation=q) for q in unit_quaternions(rng, 5)]
    form = d.elements[0].formulation
    for k in range(4):
        d.add_element(form, (ids[k], ids[k + 1]), f"random/{k}", frames=unit_quaternions(rng, 2))
    d.add_element(form, (ids[4], a[2]), "random/node frames")
    d.add_rigid_body("body", 2.0, (0.1, 0.2, 0.3), (5, 5, 5), rotation=unit_quaternions(rng, 1)[0])
    d.add_interaction(Clamp(a[0]))
    return d


def element_loop(d: Domain):
    """The lumped masses and inertias of the element-by-element loop: per element its formulation's
    ``lumped_mass``, per end the offset by the compiled quaternion product and ``O J Oᵀ`` with ``O`` the
    offset's matrix (J where the offset is the identity)."""
    mass = np.array([n.mass for n in d.nodes], dtype=float)
    inertia = np.array([n.inertia for n in d.nodes], dtype=float).reshape(-1, 3, 3)
    for element in d.elements:
        xs = np.array([d.nodes[i].position for i in element.nodes])
        qs = np.array([d.nodes[i].rotation for i in element.nodes])
        ps = qs if element.frames is None else element.frames
        for a, (i, (m, J)) in enumerate(zip(element.nodes, element.formulation.lumped_mass(xs))):
            offset = np.empty(4)
            rm.quat_product(qs[a] * np.array([1.0, -1.0, -1.0, -1.0]), ps[a], offset)
            mass[i] += m
            if offset[0] == 1.0 and not offset[1:].any():
                inertia[i] += J
            else:
                O = EulerParameters(offset).matrix()
                inertia[i] += O @ J @ O.T
    return mass, inertia


def same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def test_vectorised_set_up_is_the_element_loop_bit_for_bit():
    for seed in range(3):
        d = random_domain(seed)
        mass, inertia, _ = d._lumped()
        loop_mass, loop_inertia = element_loop(d)
        assert same(mass, loop_mass) and same(inertia, loop_inertia)
        assert (~np.isclose(inertia[:, 0, 1], 0.0)).sum() > 5  # kinked ends: full tensors in the node frames
        model = d.initialization()
        families = {data.__class__.__name__: data for data in model.elements}
        assert {"Beam2Data", "Beam2SE3Data", "Beam3Data"} <= set(families)
        for data in model.elements:
            for k, e in enumerate(data.index):
                element = d.elements[e]
                x = np.array([d.nodes[i].position for i in element.nodes])
                p = (np.array([d.nodes[i].rotation for i in element.nodes]) if element.frames is None
                     else element.frames)
                ref = element.formulation.reference_state(x, p)  # one element alone
                assert ref["L0"] == data.L0[k]
                for name in ("psi0", "gamma0", "kappa0"):
                    if name in ref:
                        assert same(ref[name], getattr(data, name)[k]), (name, e)
        lengths = [float(np.linalg.norm(d.nodes[e.nodes[1]].position - d.nodes[e.nodes[0]].position))
                   for e in d.elements]
        assert d.critical_time_step() == min(e.formulation.critical_time_step(L) for e, L in zip(d.elements, lengths))


def test_array_helpers_are_the_per_vector_calls_bit_for_bit():
    rng = np.random.default_rng(11)
    v = rng.standard_normal((500, 3)) * rng.uniform(1e-3, 1e3, (500, 1))
    assert same(vector_norms(v), [np.linalg.norm(u) for u in v])  # a sum of squares rounds differently
    q, p = unit_quaternions(rng, 500), 1.0001 * unit_quaternions(rng, 500)
    one_by_one = np.empty((500, 4))
    for k in range(500):
        rm.quat_product(q[k] * np.array([1.0, -1.0, -1.0, -1.0]), p[k], one_by_one[k])
    assert same(end_offsets(q, p), one_by_one)
    assert same(rotation_matrices(p), [EulerParameters(u).matrix() for u in p])


def one_triad(axis, hint):
    """A straight beam's section triad, one beam at a time (the loop :func:`reference.mesh.beam_triads` replaces)."""
    e1 = axis / np.linalg.norm(axis)
    e2 = hint - hint.dot(e1) * e1
    e2 = e2 / np.linalg.norm(e2)
    return np.column_stack([e1, e2, np.cross(e1, e2)])


def test_meshed_section_frames_are_one_beam_at_a_time_bit_for_bit():
    """All four branches of Shepperd's method are taken (e0, e1, e2 or e3 the largest)."""
    from reference.mesh import beam_triads, section_frames
    from reference.rotation import shepperd

    rng = np.random.default_rng(5)
    axes = rng.standard_normal((4000, 3)) * rng.uniform(1e-3, 1e3, (4000, 1))
    hint = np.array([0.3, 1.0, -0.2])
    triads = np.array([one_triad(a, hint) for a in axes])
    assert same(beam_triads(axes, hint), triads)
    points = np.cumsum(axes, axis=0)
    node_q, elem_q = section_frames(points, axes, hint)
    assert same(node_q, [EulerParameters.from_matrix(R).q for R in triads])
    assert same(elem_q, [EulerParameters.from_matrix(one_triad(b - a, hint)).q for a, b in zip(points, points[1:])])
    trace = np.trace(triads, axis1=1, axis2=2)
    assert set(np.argmax(np.column_stack([trace, *np.diagonal(triads, axis1=1, axis2=2).T]), axis=1)) == {0, 1, 2, 3}
    assert (shepperd(triads)[:, 0] >= 0.0).all()
