"""The Domain: one multibody problem and its resolution (paper §4.3, Figs. 7–10).

The Domain owns the lists of nodes, elements, joints and interactions
(boundary conditions and loading).  ``solve()`` follows the paper's Fig. 9:
build the lists (done by the deck reader or by the ``add_*`` calls),
``initialization()`` (lumped masses, element reference states — the paper's
``Initialization`` and ``InitRotation_Euler_Param``), ``initial_conditions()``
(the paper's ``Give_Init_Conditions``), then ``solve_at`` time after time.
The per-step work of Fig. 10 (internal and external forces, the right-hand
side Q of eq. 5, the Lagrange multipliers, the update of the generalized
coordinates and of the Euler parameters) is done by the
:class:`~reference.algorithms.Algorithm` on plain arrays (:mod:`reference.state`),
so that it can be compiled and tested one step at a time.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from reference.algorithms import ALGORITHMS, Algorithm
from reference.algorithms.staggered import OK
from reference.elements import Beam2Formulation, Element, Section
from reference.elements.formulation import beam2_resultants
from reference.forces import ForceElement
from reference.io.results import MemoryRecorder, Results
from reference.interactions import (
    Constant, FixedCoordinates, Gravity, Interaction, LineLoad, NodalLoad, TimeFunction,
)
from reference.joints import Jacobian, Joint, MasterSlave, joint_frame
from reference.joints.master_slave import master_slave_parameters
from reference.joints.assembly import (
    apply_inverse_mass, assemble_constraints, assemble_w, jacobian_times, sparse_cholesky, sparse_solve,
    subtract_transpose,
)
from reference.joints.sparse import constraint_pattern
from reference.joints.joint import ROWS
from reference.monitor import TOLERANCE as GUARD_TOLERANCE, BlowUpMonitor
from reference.joints.reactions import joint_reactions
from reference.joints.reactions import scratch as reaction_scratch
from reference.nodes import Node
from reference.generated import rotation_maps as rm
from reference.rotation import EulerParameters
from reference.state import Model, Record, Scratch, State


DEPENDENT_PIVOT = 1e-10
"""A constraint row whose Cholesky pivot in ``B M⁻¹ Bᵀ`` is below this fraction of
its diagonal entry (its remainder's M⁻¹-norm below 1e-5 of its own) depends on
the rows before it.  The pivot is a difference of squares, so round-off leaves
~1e-15 of the diagonal in a truly dependent row; the independent rows of the
rigid four-bar (tests/test_pendulum.py) stay above 3e-4."""


class SolverDiverged(RuntimeError):
    """The run failed or blew up; the results written so far are kept."""


@dataclass
class SolverSettings:
    """Algorithm settings.

    Parameters
    ----------
    algorithm : str
        A name of :data:`reference.algorithms.ALGORITHMS`: ``"staggered_central_difference"``
        (Park, explicit), ``"static"`` (load stepping, Newton), ``"generalized_alpha"`` (implicit).
    dt : float
        Time step [s] (static: ``t_end / load_steps``).
    t_end : float
        End time [s] (static: the final load factor).
    damping : float
        Mass-proportional damping coefficient c [1/s] (force −c m v and moment
        −c J ω on every node), for quasi-static runs.
    output_every : int
        Output every this many steps (and at ``t_end``).
    consistent_initial_velocities : bool
        Project the initial velocities onto the velocity constraints at t = 0
        (``B V + Φ_t = 0``, the change of least kinetic energy), e.g. to start a
        mechanism at its full driving speed.
    load_steps : int
        Static: number of equal load steps from 0 to ``t_end``.
    rho_inf : float
        Generalized-α: spectral radius at infinite frequency (1: no numerical dissipation).
    tolerance, max_iterations : float, int, optional
        Newton settings of the implicit algorithms (None: the algorithm's default).
    """

    algorithm: str = "staggered_central_difference"
    dt: float = 1e-3
    t_end: float = 1.0
    damping: float = 0.0
    output_every: int = 1
    consistent_initial_velocities: bool = False
    load_steps: int = 1
    rho_inf: float = 0.8
    tolerance: float | None = None
    max_iterations: int | None = None


def free_block_inverse(inertia: np.ndarray, free_rot: np.ndarray) -> np.ndarray:
    """Per node, the inverse of the rotary inertia restricted to the free rotations, zero-padded.

    With some body-frame rotations fixed (ω_k = 0) and a full tensor J, the free
    accelerations solve ``J_ff ω̇_f = g_f``; a diagonal J gives ``1/J_kk`` as before.
    """
    out = np.zeros_like(inertia)
    for n in range(inertia.shape[0]):
        f = np.flatnonzero(free_rot[n] > 0.0)
        if f.size:
            out[n][np.ix_(f, f)] = np.linalg.inv(inertia[n][np.ix_(f, f)])
    return out


def beam_triad(axis: np.ndarray, axis2_hint) -> np.ndarray:
    """Section triad ``[e1 e2 e3]`` (columns) of a straight beam.

    ``e1`` along the beam, ``e2`` the hint made orthogonal to ``e1``,
    ``e3 = e1 × e2``.
    """
    e1 = np.asarray(axis, dtype=float)
    e1 = e1 / np.linalg.norm(e1)
    hint = np.asarray(axis2_hint, dtype=float)
    e2 = hint - hint.dot(e1) * e1
    if np.linalg.norm(e2) < 1e-9 * max(np.linalg.norm(hint), 1.0):
        raise ValueError(f"section axis 2 {hint.tolist()} is parallel to the beam axis {e1.tolist()}")
    e2 = e2 / np.linalg.norm(e2)
    return np.column_stack([e1, e2, np.cross(e1, e2)])


ARC_TOLERANCE = 1e-6


def arc_geometry(start, end, center, n_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and unit tangents of the shorter circular arc from ``start`` to ``end`` about ``center``.

    ``n_elements + 1`` points at equal angles ``φ_i = i θ/n`` on the arc
    (``θ < π`` the angle between the radii), tangents in the direction of
    travel.  ``start`` and ``end`` must be equidistant from ``center`` to a
    relative ``ARC_TOLERANCE`` (1e-6) of the radius, so that decimal
    coordinates with 7 significant digits are accepted; the radius is then
    interpolated linearly between the two so the end points are kept exactly.

    Raises
    ------
    ValueError
        Not equidistant, the centre on an end point, or start and end
        diametrically opposite (the arc's plane is undefined).
    """
    c = np.asarray(center, dtype=float)
    r1, r2 = np.asarray(start, dtype=float) - c, np.asarray(end, dtype=float) - c
    R1, R2 = np.linalg.norm(r1), np.linalg.norm(r2)
    if min(R1, R2) <= 0.0:
        raise ValueError("the center coincides with an end point")
    if abs(R1 - R2) > ARC_TOLERANCE * max(R1, R2):
        raise ValueError(f"start and end are not equidistant from center ({R1:.9g} and {R2:.9g}, relative "
                         f"difference {abs(R1 - R2) / max(R1, R2):.2g} > {ARC_TOLERANCE:g}); put both on one circle")
    e1, e2 = r1 / R1, r2 / R2
    normal = np.cross(e1, e2)
    sin_t, cos_t = np.linalg.norm(normal), float(e1 @ e2)
    if sin_t < ARC_TOLERANCE:
        raise ValueError("start and end are diametrically opposite about center (or coincide): the arc's plane is "
                         "undefined; split it into two arcs")
    theta = math.atan2(sin_t, cos_t)
    normal /= sin_t
    f1 = np.cross(normal, e1)
    phi = theta * np.arange(n_elements + 1) / n_elements
    radius = R1 + (R2 - R1) * np.arange(n_elements + 1) / n_elements
    radial = np.outer(np.cos(phi), e1) + np.outer(np.sin(phi), f1)
    points = c + radius[:, None] * radial
    points[0], points[-1] = start, end
    tangents = np.cross(normal, radial)
    return points, tangents


class Domain:
    """A multibody problem: nodes, elements, joints, interactions, solver settings.

    Build it with the ``add_*`` methods or from a model deck
    (:meth:`from_deck`), then call :meth:`solve`.
    """

    def __init__(self, name: str = "domain", description: str = ""):
        self.name = name
        self.description = description
        self.nodes: list[Node] = []
        self.elements: list[Element] = []
        self.joints: list = []
        self.boundary_conditions: list[Interaction] = []
        self.loading: list[Interaction] = []
        self.force_elements: list[ForceElement] = []
        self.solver = SolverSettings()
        self.metadata: dict = {}
        self.checks: dict = {}
        self.crosscheck: dict = {}
        self.deck_text: str = ""
        self.deck_path: str = ""
        self._labels: dict[str, Node] = {}
        self._model: Model | None = None
        self._output_cache = None
        self.state: State | None = None

    @classmethod
    def from_deck(cls, path, overrides=None) -> "Domain":
        """Read a TOML model deck (see ``docs/deck.md``)."""
        from reference.io.deck import load_deck

        return load_deck(path, overrides=overrides)

    def add_node(self, position, rotation=None, label=None, velocity=(0.0, 0.0, 0.0),
                 angular_velocity=(0.0, 0.0, 0.0)) -> Node:
        """Add a node; ``rotation`` are its Euler parameters (identity if omitted)."""
        node_id = len(self.nodes)
        label = label if label is not None else f"node:{node_id}"
        if label in self._labels:
            raise ValueError(f"a node labelled {label!r} already exists")
        node = Node(node_id, label, position,
                    np.array([1.0, 0, 0, 0]) if rotation is None else rotation, velocity, angular_velocity,
                    frame_given=rotation is not None)
        self.nodes.append(node)
        self._labels[label] = node
        self._model = None
        return node

    def node(self, key) -> Node:
        """Node by id (int) or label (str)."""
        if isinstance(key, Node):
            return key
        if isinstance(key, (int, np.integer)):
            if 0 <= key < len(self.nodes):
                return self.nodes[int(key)]
            raise KeyError(f"no node with id {key}; ids run from 0 to {len(self.nodes) - 1}")
        if key in self._labels:
            return self._labels[key]
        raise KeyError(f"no node labelled {key!r}")

    def add_element(self, formulation, nodes, label: str = "", frames=None) -> Element:
        """Add an element; ``frames`` its section triads at rest (Euler parameters per node, default: the node frames)."""
        frames = None if frames is None else np.array(frames, dtype=float).reshape(len(nodes), 4)
        element = Element(formulation, tuple(self.node(n).id for n in nodes), label, frames)
        self.elements.append(element)
        self._model = None
        return element

    def add_beam(self, label: str, start, end, n_elements: int, section: Section, axis2=(0.0, 1.0, 0.0),
                 start_node: Node | None = None, end_node: Node | None = None, center=None) -> list[Node]:
        """Mesh a straight beam, or a circular arc about ``center``, into ``n_elements`` Beam2 elements.

        Each element is straight in its own section frame (axis 1 along its
        chord, axis 2 the ``axis2`` hint made orthogonal to it).  New nodes,
        labelled ``f"{label}:{i}"``, get the beam's section triad on the beam's
        axis (straight beam) or on the arc's tangent (:func:`arc_geometry`);
        the kink between a node frame and an element's section frame is the
        element end's constant offset (:class:`reference.state.Model`), exact
        for any angle.  ``start_node``/``end_node`` reuse existing nodes: a
        node whose frame is given (a ``[[nodes]]`` rotation, a rigid body, or
        set by an earlier beam) keeps it; otherwise it takes this beam's end
        frame.  Arcs converge at second order in the element size to the
        circle (chords between nodes on the arc).
        """
        start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
        if n_elements < 1:
            raise ValueError(f"beam {label!r}: needs at least one element")
        if np.linalg.norm(end - start) <= 0.0:
            raise ValueError(f"beam {label!r}: start and end coincide")
        for node, point in ((start_node, start), (end_node, end)):
            if node is not None and np.linalg.norm(node.position - point) > 1e-12 * max(1.0, np.linalg.norm(point)):
                raise ValueError(f"beam {label!r}: node {node.label!r} is not at the beam's end point {point.tolist()}")
        if center is None:
            points = start + np.outer(np.arange(n_elements + 1) / n_elements, end - start)
            points[0], points[-1] = start, end
            tangents = np.tile(end - start, (n_elements + 1, 1))
        else:
            points, tangents = arc_geometry(start, end, center, n_elements)
        try:
            node_q = [EulerParameters.from_matrix(beam_triad(t, axis2)).q for t in tangents]
            elem_q = [EulerParameters.from_matrix(beam_triad(points[i + 1] - points[i], axis2)).q
                      for i in range(n_elements)]
        except ValueError as exc:
            raise ValueError(f"beam {label!r}: {exc}; choose another axis2") from None
        formulation = Beam2Formulation(section)
        nodes = []
        for i in range(n_elements + 1):
            reuse = start_node if i == 0 else end_node if i == n_elements else None
            if reuse is not None:
                if not reuse.frame_given:
                    reuse.rotation, reuse.frame_given = node_q[i].copy(), True
                nodes.append(reuse)
            else:
                node = self.add_node(points[i], node_q[i].copy(), f"{label}:{i}")
                nodes.append(node)
        for i in range(n_elements):
            self.add_element(formulation, (nodes[i], nodes[i + 1]), f"{label}/{i}", frames=(elem_q[i], elem_q[i]))
        return nodes

    def add_rigid_body(self, label: str, mass: float, inertia, position, rotation=None, points=None) -> Node:
        """Add a rigid body: one node at its centre of mass with ``S = 0`` (paper §3.1).

        Parameters
        ----------
        mass : float
            [kg].
        inertia : array (3,3) or (3,)
            Inertia about the centre of mass in the body frame [kg m²].
        position : array (3,)
            Centre of mass, inertial [m].
        rotation : array (4,), optional
            Euler parameters of the body frame.
        points : dict, optional
            Named points (inertial coordinates at t = 0) where joints attach.
        """
        inertia = np.asarray(inertia, dtype=float)
        inertia = np.diag(inertia) if inertia.shape == (3,) else inertia.reshape(3, 3)
        if not mass > 0.0 or not np.all(np.linalg.eigvalsh(0.5 * (inertia + inertia.T)) > 0.0):
            raise ValueError(f"rigid body {label!r}: mass and inertia must be positive")
        node = self.add_node(position, rotation, label)
        node.mass, node.inertia, node.frame_given = float(mass), inertia, True
        node.points = {name: np.asarray(p, dtype=float) for name, p in (points or {}).items()}
        return node

    def add_rigid_bar(self, label: str, start, end, section: Section, axis2=(0.0, 1.0, 0.0)) -> Node:
        """A beam declared rigid: one rigid body with the bar's mass distribution.

        Mass ``ρA L``; inertia about the centre in the section frame
        ``diag(ρJ1 L, ρJ2 L + ρA L³/12, ρJ3 L + ρA L³/12)`` — the uniform bar
        (the paper meshes its rigid bars with two Beam2 elements; a rigid bar
        has no deformation, so one body carries exactly the same inertia).
        Named points ``start``, ``end`` and ``centre``.
        """
        start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
        length = float(np.linalg.norm(end - start))
        if length <= 0.0:
            raise ValueError(f"rigid bar {label!r}: start and end coincide")
        q = EulerParameters.from_matrix(beam_triad(end - start, axis2)).q
        m = section.rhoA * length
        J = np.diag([section.rhoJ1 * length, section.rhoJ2 * length + m * length**2 / 12.0,
                     section.rhoJ3 * length + m * length**2 / 12.0])
        centre = 0.5 * (start + end)
        return self.add_rigid_body(label, m, J, centre, q, {"start": start, "end": end, "centre": centre})

    def add_joint(self, kind: str, body_i, body_j, point, axis=(0.0, 0.0, 1.0), reference=None, frame=None,
                  formulation=None, time_function: TimeFunction | None = None, mode: str = "position",
                  label: str = "") -> Joint:
        """Join ``body_i`` to ``body_j`` (``None``: the ground) at ``point`` about/along ``axis``.

        ``reference`` fixes the joint frame's u1 (see :func:`reference.joints.joint_frame`);
        a full ``frame`` (columns u1, u2, u3) may be given instead.  For a universal
        joint ``axis`` is the pin on body i (u1) and ``reference`` the pin on body j (u2).
        Drives take a ``time_function`` (θ(t) or s(t), or their rates with ``mode="velocity"``).
        """
        if frame is None and kind == "universal":
            if reference is None:
                raise ValueError("a universal joint needs the pin of body j as `reference`")
            u3 = np.cross(axis, reference)
            frame = joint_frame(u3, axis)
        frame = joint_frame(axis, reference) if frame is None else np.asarray(frame, dtype=float)
        joint = Joint(kind, None if body_i is None else self.node(body_i), None if body_j is None else self.node(body_j),
                      point, frame, formulation or Jacobian(), time_function or Constant(0.0), mode,
                      label or f"{kind}:{len(self.joints)}")
        self.joints.append(joint)
        self._model = None
        return joint

    def add_force_element(self, element: ForceElement) -> ForceElement:
        """Add a spring, damper or bushing (:mod:`reference.forces`)."""
        if not isinstance(element, ForceElement):
            raise TypeError(f"not a force element: {element!r}")
        self.force_elements.append(element)
        self._model = None
        return element

    def add_interaction(self, interaction: Interaction) -> Interaction:
        """Add a boundary condition (fixed coordinates) or a load (nodal or line load, gravity).

        A line load is kept in the loading list and lumped onto its nodes when
        the model is assembled (:meth:`LineLoad.nodal_loads`)."""
        if isinstance(interaction, FixedCoordinates):
            self.boundary_conditions.append(interaction)
        elif isinstance(interaction, (NodalLoad, Gravity, LineLoad)):
            self.loading.append(interaction)
        else:
            raise TypeError(f"unknown interaction {interaction!r}")
        self._model = None
        return interaction

    @property
    def model(self) -> Model:
        """The assembled plain-data model (built on first use)."""
        return self._model or self.initialization()

    def critical_time_step(self) -> float:
        """Smallest per-element stability limit of the explicit scheme [s].

        A force element of stiffness k adds the limit ``2/ω``, ``ω² = k (1/m_i + 1/m_j)``
        with each body's effective inverse mass at the attachment bounded by
        ``1/m + r²/J_min`` (and ``uᵀJ⁻¹u`` about the axis u of a torsional
        stiffness): the element oscillating against the bodies it connects.
        """
        limits = [e.formulation.critical_time_step(self._length(e)) for e in self.elements]
        if self.force_elements:
            lumped = self._lumped_masses()
            for fe in self.force_elements:
                rate = fe.stiffness_rate(lambda node: lumped[node.id])
                if rate > 0.0:
                    limits.append(2.0 / math.sqrt(rate))
        return min(limits) if limits else math.inf

    def _lumped_masses(self) -> list:
        """``(m, J)`` of every node with the elements' lumped masses added (as :meth:`initialization`)."""
        out = [[n.mass, np.array(n.inertia, dtype=float)] for n in self.nodes]
        for element in self.elements:
            xs = np.array([self.nodes[i].position for i in element.nodes])
            for i, (m, J) in zip(element.nodes, element.formulation.lumped_mass(xs)):
                out[i][0] += m
                out[i][1] = out[i][1] + J
        return [(m, J) for m, J in out]

    def _length(self, element: Element) -> float:
        a, b = (self.nodes[i].position for i in element.nodes)
        return float(np.linalg.norm(b - a))

    def initialization(self) -> Model:
        """Assemble the plain-data model: lumped masses, references, loads (paper: Initialization)."""
        N = len(self.nodes)
        mass = np.array([n.mass for n in self.nodes], dtype=float)
        inertia = np.array([n.inertia for n in self.nodes], dtype=float).reshape(N, 3, 3)
        conn = np.zeros((len(self.elements), 2), dtype=np.int64)
        offset = np.zeros((len(self.elements), 2, 4))
        L0 = np.zeros(len(self.elements))
        psi0 = np.zeros((len(self.elements), 3))
        gamma0 = np.zeros((len(self.elements), 3))
        stiff = np.zeros((len(self.elements), 6))
        for e, element in enumerate(self.elements):
            ids = list(element.nodes)
            xs = np.array([self.nodes[i].position for i in ids])
            qs = np.array([self.nodes[i].rotation for i in ids])
            ps = qs if element.frames is None else element.frames
            for a, i in enumerate(ids):
                rm.quat_product(qs[a] * np.array([1.0, -1.0, -1.0, -1.0]), ps[a], offset[e, a])
            # lumped rotary inertia: the section-frame diagonal, rotated into the node frame (O J Oᵀ)
            for a, (i, (m, J)) in enumerate(zip(ids, element.formulation.lumped_mass(xs))):
                O = EulerParameters(offset[e, a]).matrix()
                mass[i] += m
                inertia[i] += O @ J @ O.T
            ref = element.formulation.reference_state(xs, ps)
            conn[e] = ids
            L0[e], psi0[e], gamma0[e] = ref["L0"], ref["psi0"], ref["gamma0"]
            stiff[e] = element.formulation.section.stiffness
        massless = [n.label for n, m in zip(self.nodes, mass) if not m > 0.0]
        if massless:
            raise ValueError(f"nodes without mass (attach them to an element or give them a mass): {massless[:5]}")
        singular = [n.label for n, J in zip(self.nodes, inertia) if not np.linalg.det(J) > 0.0]
        if singular:
            raise ValueError(f"nodes without positive rotary inertia: {singular[:5]}")
        free = np.ones((N, 6))
        for bc in self.boundary_conditions:
            free[self.node(bc.node).id, list(bc.dofs)] = 0.0
        gravity = np.zeros(3)
        loads = [ld for ld in self.loading if isinstance(ld, NodalLoad)]
        loads += [nl for ld in self.loading if isinstance(ld, LineLoad) for nl in ld.nodal_loads()]
        for g in self.loading:
            if isinstance(g, Gravity):
                gravity += np.asarray(g.g, dtype=float)
        tfs: list[TimeFunction] = []

        def tf_index(tf):
            for k, known in enumerate(tfs):
                if known is tf:
                    return k
            tfs.append(tf)
            return len(tfs) - 1

        load_tf = np.array([tf_index(ld.time_function) for ld in loads], dtype=np.int64)
        lagrange = self.multiplier_joints()
        ms = self.master_slave_joints()
        J = len(lagrange)
        jt = {"jt_i": np.zeros(J, dtype=np.int64), "jt_j": np.zeros(J, dtype=np.int64), "jt_par": np.zeros((J, 24)),
              "jt_rows": np.full((J, 6), -1, dtype=np.int64), "jt_neq": np.zeros(J, dtype=np.int64),
              "jt_row0": np.zeros(J, dtype=np.int64), "jt_drive": np.zeros(J, dtype=np.int64),
              "jt_tf": np.zeros(J, dtype=np.int64)}
        row_eps, row0 = [], 0
        for k, joint in enumerate(lagrange):
            jt["jt_i"][k] = joint.body_i.id
            jt["jt_j"][k] = -1 if joint.body_j is None else joint.body_j.id
            jt["jt_par"][k] = joint.body_fixed()
            jt["jt_rows"][k, : len(ROWS[joint.kind])] = ROWS[joint.kind]
            jt["jt_neq"][k] = joint.n_equations
            jt["jt_row0"][k] = row0
            jt["jt_drive"][k] = joint.drive_code
            jt["jt_tf"][k] = tf_index(joint.time_function)
            row0 += joint.n_equations
            row_eps += [joint.formulation.epsilon] * joint.n_equations
        fes = self.force_elements
        fe = {"fe_kind": np.array([f.kind for f in fes], dtype=np.int64),
              "fe_i": np.array([f.body_i.id for f in fes], dtype=np.int64),
              "fe_j": np.array([-1 if f.body_j is None else f.body_j.id for f in fes], dtype=np.int64),
              "fe_par": np.array([f.body_fixed() for f in fes]).reshape(len(fes), 24),
              "fe_k": np.array([f.stiffness_damping()[0] for f in fes]).reshape(len(fes), 6),
              "fe_c": np.array([f.stiffness_damping()[1] for f in fes]).reshape(len(fes), 6),
              "fe_rest": np.array([f.rest() for f in fes], dtype=float),
              "fe_tf": np.array([-1 if getattr(f, "force_function", None) is None else tf_index(f.force_function)
                                 for f in fes], dtype=np.int64)}
        load_arm = np.zeros((len(loads), 3))
        for k, ld in enumerate(loads):
            if ld.point is not None and not ld.moment:
                node = self.node(ld.node)
                load_arm[k] = EulerParameters(node.rotation).matrix().T @ (np.asarray(ld.point, float) - node.position)
        node_constrained = np.zeros(N, dtype=np.int64)
        for joint in lagrange + ms:
            for body in (joint.body_i, joint.body_j):
                if body is not None:
                    node_constrained[body.id] = 1
        pars = [tf.parameters() for tf in tfs]
        width = max([len(p) for p in pars] + [1])
        tf_par = np.zeros((max(len(tfs), 1), width))
        for j, p in enumerate(pars):
            tf_par[j, : len(p)] = p
        self._model = Model(
            mass=mass, inertia=inertia, inertia_inv=free_block_inverse(inertia, free[:, 3:]), free=free,
            conn=conn, offset=offset, L0=L0, psi0=psi0, gamma0=gamma0, stiff=stiff,
            load_node=np.array([self.node(ld.node).id for ld in loads], dtype=np.int64),
            load_code=np.array([ld.code for ld in loads], dtype=np.int64),
            load_vec=np.array([np.asarray(ld.vector, dtype=float) for ld in loads]).reshape(len(loads), 3),
            load_tf=load_tf,
            tf_kind=np.array([tf.kind for tf in tfs] or [0], dtype=np.int64),
            tf_par=tf_par, gravity=gravity, damping=float(self.solver.damping),
            row_eps=np.array(row_eps, dtype=float),
            **self._constraint_pattern(jt, [joint.formulation.epsilon > 0.0 for joint in lagrange]),
            node_constrained=node_constrained, constrained_nodes=np.flatnonzero(node_constrained).astype(np.int64),
            ms_master=np.array([j.body_j.id for j in ms], dtype=np.int64),
            ms_slave=np.array([j.body_i.id for j in ms], dtype=np.int64),
            ms_kind=np.array([0 if j.kind == "spherical" else 1 for j in ms], dtype=np.int64),
            ms_par=np.array([master_slave_parameters(j) for j in ms]).reshape(len(ms), 9),
            load_arm=load_arm,
            **jt, **fe,
        )
        self.check_constraints(self._model)
        return self._model

    def multiplier_joints(self) -> list[Joint]:
        """Joints treated by Lagrange multipliers (the :class:`Jacobian` formulation)."""
        return [j for j in self.joints if not isinstance(j.formulation, MasterSlave)]

    def master_slave_joints(self) -> list[Joint]:
        """Joints treated by master/slave elimination, validated.

        Only spherical and revolute joints; the slave (``body_i``) must be a beam
        node at the joint point, slave of no other joint and master of none; the
        master (``body_j``) a body, not the ground; neither may have fixed coordinates.
        """
        joints = [j for j in self.joints if isinstance(j.formulation, MasterSlave)]
        beam_nodes = {i for e in self.elements for i in e.nodes}
        fixed = {self.node(bc.node).id for bc in self.boundary_conditions}
        slaves = [j.body_i.id for j in joints]
        masters = {j.body_j.id for j in joints if j.body_j is not None}
        for j in joints:
            problem = None
            if j.kind not in ("spherical", "revolute"):
                problem = f"master/slave is available for spherical and revolute joints, not {j.kind}"
            elif j.body_j is None:
                problem = "the master (body_j) of a master/slave joint cannot be the ground; use a clamp or fixed coordinates"
            elif j.body_i.id not in beam_nodes:
                problem = "the slave (body_i) of a master/slave joint must be a beam node"
            elif np.linalg.norm(j.body_i.position - j.point) > 1e-9 * max(1.0, np.linalg.norm(j.point)):
                problem = "the slave node must sit at the joint point"
            elif slaves.count(j.body_i.id) > 1 or j.body_i.id in masters:
                problem = f"node {j.body_i.label!r} is the slave of one master/slave joint and used by another"
            elif j.body_i.id in fixed or j.body_j.id in fixed:
                problem = "master and slave of a master/slave joint may not have fixed coordinates"
            if problem:
                raise ValueError(f"joint {j.label!r}: {problem}")
        return joints

    @staticmethod
    def _constraint_pattern(jt: dict, regularised: list) -> dict:
        """The Model's sparsity fields of ``B M⁻¹ Bᵀ`` (:func:`reference.joints.sparse.constraint_pattern`).

        The regularised joints (ε > 0) are eliminated last, so that
        :meth:`check_constraints` attributes a redundancy to them where it can.
        """
        pattern = constraint_pattern(jt["jt_i"], jt["jt_j"], jt["jt_neq"], np.array(regularised, dtype=np.int64))
        return {"row_iperm": pattern.row_iperm, "L_colptr": pattern.L_colptr, "L_rowidx": pattern.L_rowidx,
                "L_rowptr": pattern.L_rowptr, "L_rowcol": pattern.L_rowcol, "L_rowpos": pattern.L_rowpos,
                "wc_joints": pattern.wc_joints, "wc_pos": pattern.wc_pos}

    def _configuration(self, x=None, q=None):
        x = np.array([n.position for n in self.nodes]).reshape(-1, 3) if x is None else np.asarray(x, dtype=float)
        q = np.array([n.rotation for n in self.nodes]).reshape(-1, 4) if q is None else np.asarray(q, dtype=float)
        return x, q

    @staticmethod
    def _constraint_blocks(model: Model, x, q, t: float):
        """Φ, Φ_t and the joints' blocks of B and B M⁻¹ at a configuration."""
        m, J = model.n_constraints, model.jt_i.shape[0]
        PHI, PHIt, Bj, BMj = np.zeros(m), np.zeros(m), np.zeros((J, 6, 12)), np.zeros((J, 6, 12))
        assemble_constraints(model, x, q, float(t), PHI, PHIt, Bj, np.zeros(10), np.zeros(120))
        apply_inverse_mass(model, Bj, BMj)
        return PHI, PHIt, Bj, BMj

    @staticmethod
    def _dependent_rows(model: Model, Bj, BMj):
        """Sparse Cholesky of ``B M⁻¹ Bᵀ`` dropping dependent rows: the factor and the dropped rows' flags.

        A row is dropped when its pivot — the squared M⁻¹-norm of what remains of
        it after the rows eliminated before it are projected out, as in
        Gram–Schmidt — is below ``DEPENDENT_PIVOT`` of its own squared norm.
        """
        Lx, dependent = np.zeros(model.L_rowidx.shape[0]), np.zeros(model.n_constraints, dtype=np.int64)
        assemble_w(model, Bj, BMj, Lx)
        sparse_cholesky(model, Lx, np.zeros(model.n_constraints), 0.0, DEPENDENT_PIVOT, dependent)
        return Lx, dependent

    @staticmethod
    def _dependency_rows(model: Model, Lx, dependent, positions) -> list[int]:
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
        ncol = np.diff(model.L_colptr)
        cols = np.repeat(np.arange(m), ncol)
        values = Lx.copy()
        values[model.L_colptr[:-1][dependent == 1]] = 1.0  # dropped rows: unit pivot, zero column
        L = scipy.sparse.csr_matrix((values, (model.L_rowidx, cols)), shape=(m, m))
        row_perm = np.argsort(model.row_iperm)
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

    def constraint_matrices(self, model: Model, x=None, q=None, t: float = 0.0):
        """Global Φ (m,), Φ_t (m,), B (m, 6N) and B M⁻¹ at a configuration (default: initial), dense.

        A convenience for tests and tools (the step never forms these arrays).
        """
        x, q = self._configuration(x, q)
        PHI, PHIt, Bj, BMj = self._constraint_blocks(model, x, q, t)
        N, m = len(self.nodes), model.n_constraints
        Bg, BM = np.zeros((m, 6 * N)), np.zeros((m, 6 * N))
        for k in range(Bj.shape[0]):
            r0, mk = model.jt_row0[k], model.jt_neq[k]
            for side, n in enumerate((model.jt_i[k], model.jt_j[k])):
                if n >= 0:
                    Bg[r0:r0 + mk, 6 * n:6 * n + 6] += Bj[k, :mk, 6 * side:6 * side + 6]
                    BM[r0:r0 + mk, 6 * n:6 * n + 6] += BMj[k, :mk, 6 * side:6 * side + 6]
        return PHI, PHIt, Bg, BM

    def check_constraints(self, model: Model) -> None:
        """Refuse redundant constraints that are not regularised (ε = 0), naming the joints.

        The rows of B are orthogonalised in the M⁻¹ inner product ``⟨a, b⟩ = a M⁻¹ bᵀ``
        (the metric of ``B M⁻¹ Bᵀ``) by the sparse Cholesky factorisation of
        ``B M⁻¹ Bᵀ`` in the elimination order of the step
        (:meth:`_dependent_rows`): a row whose pivot is negligible depends on the
        rows eliminated before it.  Cost as for one step's factorisation.
        """
        if model.n_constraints == 0:
            return
        x, q = self._configuration()
        _, _, Bj, BMj = self._constraint_blocks(model, x, q, 0.0)
        Lx, dependent = self._dependent_rows(model, Bj, BMj)
        redundant = np.flatnonzero(dependent[model.row_iperm])
        owner = [joint for joint in self.multiplier_joints() for _ in range(joint.n_equations)]
        unregularised = [r for r in redundant if owner[r].formulation.epsilon == 0.0]
        involved = self._dependency_rows(model, Lx, dependent, model.row_iperm[unregularised])
        labels = {owner[r].label for r in involved}
        loop = [j for j in self.multiplier_joints() if j.label in labels]
        stiff = [j.label for j in loop if j.formulation.epsilon == 0.0]
        if not stiff:
            return
        revolute = [j.label for j in loop if j.kind == "revolute"]
        fix = f"regularise one of {', '.join(stiff)} (epsilon > 0, a compliance)"
        if len(revolute) >= 2:
            fix += (f", or replace revolute {revolute[-1]} by a spherical and {revolute[-2]} by a universal joint "
                    "(a spherical alone leaves one redundant)")
        raise ValueError(f"redundant constraints: {len(redundant)} equation(s) depend on the others in the loop of "
                         f"joints {', '.join(j.label for j in loop)}; {fix}")

    def initial_conditions(self) -> State:
        """State at t = 0 from the nodes' initial positions, rotations and velocities."""
        N = len(self.nodes)
        self.state = State(
            x=np.array([n.position for n in self.nodes]).reshape(N, 3),
            q=np.array([n.rotation for n in self.nodes]).reshape(N, 4),
            v=np.array([n.velocity for n in self.nodes]).reshape(N, 3),
            w=np.array([n.angular_velocity for n in self.nodes]).reshape(N, 3),
            f_prev=np.zeros((N, 6)),
            clock=np.zeros(4),
            angle=np.zeros(len(self.force_elements)),
        )
        if self.solver.consistent_initial_velocities and self.joints:
            self.project_initial_velocities(self._model or self.initialization(), self.state)
        return self.state

    def project_initial_velocities(self, model: Model, state: State) -> None:
        """Make the initial velocities consistent: ``V = V0 − M⁻¹Bᵀ (B M⁻¹ Bᵀ)⁻¹ (B V0 + Φ_t)``.

        The M-orthogonal projection changes the kinetic energy least; for a
        mechanism driven from rest it gives the velocities of the driven motion.
        Solved with the sparse factor of the step's pattern; dependent
        (regularised redundant) rows are dropped, which leaves the projection
        unchanged when the velocity constraints are consistent.
        """
        _, PHIt, Bj, BMj = self._constraint_blocks(model, state.x, state.q, state.t)
        Lx, _ = self._dependent_rows(model, Bj, BMj)
        rhs = np.zeros(model.n_constraints)
        jacobian_times(model, Bj, state.v, state.w, rhs)
        y = np.zeros_like(rhs)
        y[model.row_iperm] = rhs + PHIt
        sparse_solve(model, Lx, y)
        subtract_transpose(model, BMj, y[model.row_iperm], state.v, state.w)

    def algorithm(self, dt: float | None = None) -> Algorithm:
        """The solver's algorithm, looked up by name in :data:`reference.algorithms.ALGORITHMS`."""
        if self.solver.algorithm not in ALGORITHMS:
            raise ValueError(f"unknown algorithm {self.solver.algorithm!r}; available: {', '.join(ALGORITHMS)}")
        return ALGORITHMS[self.solver.algorithm].from_settings(self.solver, dt)

    def solve_at(self, time: float) -> State:
        """Advance the current state (initialised on first use) to ``time`` (paper: Solve_at)."""
        model = self._model or self.initialization()
        state = self.state if self.state is not None else self.initial_conditions()
        algo = self.algorithm()
        n = int(round((time - state.t) / algo.dt))
        if n > 0 and algo.advance(model, state, n, None, Scratch.for_model(model)) != OK:
            raise SolverDiverged(f"the solution became non-finite before t = {time}")
        return state

    def solve(self, t_end: float | None = None, dt: float | None = None, results_path=None,
              progress=None, monitor: bool = True) -> Results:
        """Run from t = 0 to ``t_end`` (paper: Solve, Fig. 9) and return the time histories.

        Records stream to the results file and are not kept in memory; the returned
        :class:`Results` reads them from the file when asked.  Without a file they are
        kept in preallocated arrays.  Whatever stops the run, the file is closed with
        a status saying how it ended (``"completed"``, ``"diverged after t = …"``,
        ``"interrupted at t = …"`` on Ctrl-C, ``"terminated at t = …"`` on SystemExit —
        the command line raises it on SIGTERM and SIGHUP — or ``"failed: <reason>"``),
        and :attr:`last_run` says where and how.

        Parameters
        ----------
        t_end, dt : float, optional
            Override the deck's end time and step.
        results_path : path, optional
            HDF5 results file (:mod:`reference.io.results`).
        progress : callable(fraction, t), optional
            Called after every output.
        monitor : bool
            Stop a run that blows up while finite (:mod:`reference.monitor`): the algorithm
            checks the energy balance every step (``Scratch.guard``), the Domain the energy
            balance and the deformation at every output.

        Raises
        ------
        SolverDiverged
            When the algorithm fails (non-finite state, singular constraints) or the
            monitor sees a blow-up; records up to then are kept.
        """
        t_end = self.solver.t_end if t_end is None else float(t_end)
        algo = self.algorithm(dt)
        steps = t_end / algo.dt
        n_total = int(round(steps)) if steps < 2.0**62 else 0
        if n_total < 1 or abs(n_total * algo.dt - t_end) > 1e-9 * max(t_end, 1.0):
            raise ValueError(f"t_end = {t_end} is not a whole number of steps of dt = {algo.dt}")
        self.last_run = {"path": None, "status": "not started", "t": 0.0}
        model = self.initialization()
        state = self.initial_conditions()
        every = max(int(self.solver.output_every), 1)
        scratch, rec = Scratch.for_model(model), Record.empty(len(self.nodes), model.n_constraints)
        watch = BlowUpMonitor(self, algo.dt, getattr(algo, "explicit", True)) if monitor else None
        scratch.guard[2] = GUARD_TOLERANCE if monitor else 0.0
        if results_path is not None:
            from reference.io.results import ResultsWriter

            sink = ResultsWriter(results_path, self, algo, template=self._record(rec, 0.0))
            self.last_run["path"] = str(results_path)
        else:
            sink = MemoryRecorder(n_total // every + 2, [n.label for n in self.nodes], [j.label for j in self.joints],
                                  [e.label for e in self.elements])
        status = "failed: stopped before the first step"
        wall0 = _time.perf_counter()
        try:
            done = 0
            while True:
                chunk = min(every, n_total - done)
                t_record = state.t
                code = algo.advance(model, state, chunk, rec, scratch)
                entry = self._record(rec, t_record)
                sink.append(entry)
                why = watch.check(rec.energy, rec.x) if watch is not None and code == OK else ""
                if why:
                    status = f"diverged after t = {t_record:.6g}"
                    raise SolverDiverged(f"{why} (stopped at t = {t_record:.6g}); results up to then are kept")
                if code != OK:
                    status, message = algo.failure(code, state.t, self)
                    if watch is not None:
                        message += watch.guard_report(scratch.guard, state.clock[2])
                    raise SolverDiverged(message)
                done += chunk
                if progress is not None and chunk > 0:
                    progress(done / n_total, state.t)
                if chunk == 0:
                    break
            status = "completed"
        except SolverDiverged:
            raise
        except KeyboardInterrupt:
            status = f"interrupted at t = {state.t:.6g}"
            raise
        except Exception as exc:
            status = f"failed: {type(exc).__name__}: {exc}"[:500]
            raise
        except BaseException:
            status = f"terminated at t = {state.t:.6g}"
            raise
        finally:
            self.last_run.update(status=status, t=state.t, energy=float(scratch.guard[4]),
                                 work=float(state.clock[2]))
            sink.close(status)
        return sink.results(_time.perf_counter() - wall0)

    def outputs(self, model: Model, x, q, lam, t: float) -> dict:
        """Derived outputs of one record: joint reactions (all joints, NaN for master/slave ones)
        and element section resultants (:func:`reference.joints.reactions.joint_reactions`,
        :func:`~reference.elements.formulation.beam2_resultants`); compiled, ~35 µs per output."""
        cache = self._output_cache
        if cache is None or cache[0] is not model:
            rows = [k for k, j in enumerate(self.joints) if not isinstance(j.formulation, MasterSlave)]
            cache = self._output_cache = (model, np.array(rows, dtype=np.int64), len(rows) < len(self.joints),
                                          reaction_scratch(), np.zeros(32))
        _, slot, partial, scratch, s_el = cache
        J, E = len(self.joints), model.conn.shape[0]
        force = np.full((J, 3), np.nan) if partial else np.empty((J, 3))
        moment = np.full((J, 3), np.nan) if partial else np.empty((J, 3))
        joint_reactions(model, x, q, lam, float(t), slot, force, moment, *scratch)
        section_force, section_moment = np.empty((E, 3)), np.empty((E, 3))
        beam2_resultants(x, q, model.conn, model.offset, model.L0, model.psi0, model.gamma0, model.stiff,
                         section_force, section_moment, s_el)
        return {"reaction_force": force, "reaction_moment": moment, "section_force": section_force,
                "section_moment": section_moment}

    def _record(self, rec: Record, t: float) -> dict:
        """One output record: record key → value (:data:`reference.io.results.DATASETS`)."""
        return {
            "time": t, "position": rec.x.copy(), "rotation": rec.q.copy(), "velocity": rec.v.copy(),
            "angular_velocity": rec.w.copy(), "violation_norm": rec.constraint[0],
            "velocity_violation_norm": rec.constraint[1], "multipliers": rec.lam.copy(),
            "kinetic": rec.energy[0], "strain": rec.energy[1], "external_work": rec.energy[2],
            "dissipated": rec.energy[3],
            **self.outputs(self.model, rec.x, rec.q, rec.lam, t),
        }
