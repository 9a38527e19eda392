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
from dataclasses import dataclass, field

import numpy as np

from reference.algorithms import ALGORITHMS, Algorithm
from reference.algorithms.staggered import OK
from reference.elements import Beam2Formulation, Element, Section
from reference.elements.formulation import beam2_resultants
from reference.interactions import Constant, FixedCoordinates, Gravity, Interaction, NodalLoad, TimeFunction
from reference.joints import Jacobian, Joint, MasterSlave, joint_frame
from reference.joints.master_slave import master_slave_parameters
from reference.joints.assembly import apply_inverse_mass, assemble_constraints
from reference.joints.joint import ROWS
from reference.joints.reactions import reactions
from reference.nodes import Node
from reference.generated import rotation_maps as rm
from reference.rotation import EulerParameters
from reference.state import Model, Record, Scratch, State


class SolverDiverged(RuntimeError):
    """The run produced non-finite values; the results written so far are kept."""


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


@dataclass
class Results:
    """Time histories of a run, as arrays in memory (the results file holds the same).

    ``time`` (n,), ``position``/``velocity``/``angular_velocity`` (n,N,3),
    ``rotation`` (n,N,4), ``energy`` dict of (n,) arrays, ``labels`` (N,),
    ``status`` ("completed" or why it stopped), ``wall_time`` [s].
    Joints (J): ``joint_labels``, ``reaction_forces`` and ``reaction_moments``
    (n,J,3), the force and the moment about the joint point that each joint
    exerts on its body_i, inertial [N], [N m] (NaN where not computed:
    master/slave joints).  Elements (E): ``element_labels`` (``"beam/i"``),
    ``section_forces``/``section_moments`` (n,E,3) at the midpoint, section
    frame.  ``multipliers`` (n,m) the Lagrange multipliers (``M a + Bᵀλ = Q``).

    Node keys are ids, labels, or the aliases ``BEAM:start`` and ``BEAM:end``
    (the first and last node ``BEAM:i`` of a meshed beam).
    """

    time: np.ndarray
    labels: list
    positions: np.ndarray
    rotations: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    energy: dict
    constraint_violation: np.ndarray
    velocity_constraint_violation: np.ndarray
    status: str = "completed"
    wall_time: float = 0.0
    attrs: dict = field(default_factory=dict)
    joint_labels: list = field(default_factory=list)
    reaction_forces: np.ndarray | None = None
    reaction_moments: np.ndarray | None = None
    element_labels: list = field(default_factory=list)
    section_forces: np.ndarray | None = None
    section_moments: np.ndarray | None = None
    multipliers: np.ndarray | None = None

    def index(self, key) -> int:
        """Column of a node: an id, a label, or ``BEAM:start`` / ``BEAM:end``."""
        if isinstance(key, (int, np.integer)):
            return int(key)
        if key in self.labels:
            return self.labels.index(key)
        beam, _, which = str(key).rpartition(":")
        if which in ("start", "end"):
            numbered = [(int(lbl.rpartition(":")[2]), k) for k, lbl in enumerate(self.labels)
                        if lbl.rpartition(":")[0] == beam and lbl.rpartition(":")[2].isdigit()]
            if numbered:
                return (min if which == "start" else max)(numbered)[1]
        raise KeyError(f"no node labelled {key!r}; labels are e.g. {self.labels[:4]}")

    def position(self, key) -> np.ndarray:
        return self.positions[:, self.index(key)]

    def rotation(self, key) -> np.ndarray:
        return self.rotations[:, self.index(key)]

    def velocity(self, key) -> np.ndarray:
        return self.velocities[:, self.index(key)]

    def angular_velocity(self, key) -> np.ndarray:
        return self.angular_velocities[:, self.index(key)]

    def joint_index(self, joint) -> int:
        if joint in self.joint_labels:
            return self.joint_labels.index(joint)
        raise KeyError(f"no joint labelled {joint!r}; joints are {self.joint_labels}")

    def element_index(self, beam, element=None) -> int:
        """Column of an element: its label ``"beam/i"``, or ``(beam, i)``."""
        label = str(beam) if element is None else f"{beam}/{int(element)}"
        if label in self.element_labels:
            return self.element_labels.index(label)
        raise KeyError(f"no element labelled {label!r}; elements are e.g. {self.element_labels[:4]}")

    def reaction(self, joint) -> tuple[np.ndarray, np.ndarray]:
        """``(force, moment)`` (n, 3) each: what ``joint`` exerts on its body_i, moment about the
        joint point, inertial components [N], [N m]."""
        k = self.joint_index(joint)
        return self.reaction_forces[:, k], self.reaction_moments[:, k]

    def section_force(self, beam, element=None) -> np.ndarray:
        """Force resultant N (n, 3) at the midpoint of element ``beam/element``, section frame [N]."""
        return self.section_forces[:, self.element_index(beam, element)]

    def section_moment(self, beam, element=None) -> np.ndarray:
        """Moment resultant M (n, 3) at the midpoint of element ``beam/element``, section frame [N m]."""
        return self.section_moments[:, self.element_index(beam, element)]


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
        self.solver = SolverSettings()
        self.metadata: dict = {}
        self.checks: dict = {}
        self.crosscheck: dict = {}
        self.deck_text: str = ""
        self.deck_path: str = ""
        self._labels: dict[str, Node] = {}
        self._model: Model | None = None
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

    def add_interaction(self, interaction: Interaction) -> Interaction:
        """Add a boundary condition (fixed coordinates) or a load (nodal load, gravity)."""
        if isinstance(interaction, FixedCoordinates):
            self.boundary_conditions.append(interaction)
        elif isinstance(interaction, (NodalLoad, Gravity)):
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
        """Smallest per-element stability limit of the explicit scheme [s]."""
        limits = [e.formulation.critical_time_step(self._length(e)) for e in self.elements]
        return min(limits) if limits else math.inf

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
            row_nodes=np.array([[j.body_i.id, -1 if j.body_j is None else j.body_j.id]
                                for j in lagrange for _ in range(j.n_equations)], dtype=np.int64).reshape(-1, 2),
            ms_master=np.array([j.body_j.id for j in ms], dtype=np.int64),
            ms_slave=np.array([j.body_i.id for j in ms], dtype=np.int64),
            ms_kind=np.array([0 if j.kind == "spherical" else 1 for j in ms], dtype=np.int64),
            ms_par=np.array([master_slave_parameters(j) for j in ms]).reshape(len(ms), 9),
            **jt,
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

    def constraint_matrices(self, model: Model, x=None, q=None, t: float = 0.0):
        """Global Φ (m,), Φ_t (m,), B (m, 6N) and B M⁻¹ at a configuration (default: initial)."""
        N, m = len(self.nodes), model.n_constraints
        x = np.array([n.position for n in self.nodes]) if x is None else x
        q = np.array([n.rotation for n in self.nodes]) if q is None else q
        PHI, PHIt, Bg, BM = np.zeros(m), np.zeros(m), np.zeros((m, 6 * N)), np.zeros((m, 6 * N))
        assemble_constraints(model, x, q, float(t), PHI, PHIt, Bg, np.zeros(6), np.zeros((6, 12)), np.zeros(6),
                             np.zeros(10), np.zeros(120))
        apply_inverse_mass(model, Bg, BM)
        return PHI, PHIt, Bg, BM

    def check_constraints(self, model: Model) -> None:
        """Refuse redundant constraints that are not regularised (ε = 0), naming the joints.

        Gram–Schmidt on the rows of B in the M⁻¹ inner product ``⟨a, b⟩ = a M⁻¹ bᵀ``
        (the metric of ``B M⁻¹ Bᵀ``): a row whose remainder is below 1e-9 of its
        own norm depends on the earlier rows.
        """
        if model.n_constraints == 0:
            return
        _, _, Bg, _ = self.constraint_matrices(model)
        owner = [joint for joint in self.multiplier_joints() for _ in range(joint.n_equations)]
        basis, redundant = [], []
        for r, row in enumerate(Bg):
            own = row @ self._minv_apply(model, row)
            vec = row.copy()
            for e, me in basis:
                vec -= (vec @ me) * e
            mv = self._minv_apply(model, vec)
            remainder = vec @ mv
            if remainder <= 1e-18 * own:
                redundant.append(r)
            else:
                basis.append((vec / np.sqrt(remainder), mv / np.sqrt(remainder)))
        bad = sorted({owner[r].label for r in redundant if owner[r].formulation.epsilon == 0.0},
                     key=[j.label for j in self.joints].index)
        if bad:
            raise ValueError(
                f"redundant constraints: {len(redundant)} equation(s) of joint(s) {', '.join(bad)} depend on "
                "the others (e.g. a planar linkage of rigid bodies closed in 3D); give those joints a "
                "formulation with epsilon > 0 to regularise them, or replace a revolute joint by a "
                "spherical or universal one"
            )

    @staticmethod
    def _minv_apply(model: Model, row: np.ndarray) -> np.ndarray:
        """``M⁻¹ row`` with the lumped, block-diagonal M (fixed coordinates: M⁻¹ = 0)."""
        blocks = row.reshape(-1, 6)
        out = np.empty_like(blocks)
        out[:, :3] = blocks[:, :3] * model.free[:, :3] / model.mass[:, None]
        rot = blocks[:, 3:] * model.free[:, 3:]
        out[:, 3:] = np.einsum("nab,nb->na", model.inertia_inv, rot) * model.free[:, 3:]
        return out.reshape(-1)

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
        )
        if self.solver.consistent_initial_velocities and self.joints:
            self.project_initial_velocities(self._model or self.initialization(), self.state)
        return self.state

    def project_initial_velocities(self, model: Model, state: State) -> None:
        """Make the initial velocities consistent: ``V = V0 − M⁻¹Bᵀ (B M⁻¹ Bᵀ)⁻¹ (B V0 + Φ_t)``.

        The M-orthogonal projection changes the kinetic energy least; for a
        mechanism driven from rest it gives the velocities of the driven motion.
        """
        _, PHIt, Bg, BM = self.constraint_matrices(model, state.x, state.q, state.t)
        V0 = np.concatenate([state.v, state.w], axis=1).reshape(-1)
        W = BM @ Bg.T
        lam = np.linalg.lstsq(W, Bg @ V0 + PHIt, rcond=1e-12)[0]
        V = (V0 - BM.T @ lam).reshape(-1, 6)
        state.v[:], state.w[:] = V[:, :3], V[:, 3:]

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
              progress=None) -> Results:
        """Run from t = 0 to ``t_end`` (paper: Solve, Fig. 9) and return the time histories.

        Parameters
        ----------
        t_end, dt : float, optional
            Override the deck's end time and step.
        results_path : path, optional
            HDF5 results file written incrementally (the contract of reference/io/results.py).
        progress : callable(fraction, t), optional
            Called after every output.

        Raises
        ------
        SolverDiverged
            When the state becomes non-finite; records up to then are kept
            (and the file, if any, is closed with that status).
        """
        t_end = self.solver.t_end if t_end is None else float(t_end)
        algo = self.algorithm(dt)
        n_total = int(round(t_end / algo.dt))
        if n_total < 1 or abs(n_total * algo.dt - t_end) > 1e-9 * max(t_end, 1.0):
            raise ValueError(f"t_end = {t_end} is not a whole number of steps of dt = {algo.dt}")
        model = self.initialization()
        state = self.initial_conditions()
        every = max(int(self.solver.output_every), 1)
        N = len(self.nodes)
        scratch, rec = Scratch.for_model(model), Record.empty(N, model.n_constraints)
        records = []
        writer = None
        if results_path is not None:
            from reference.io.results import ResultsWriter

            writer = ResultsWriter(results_path, self, algo)
        status = "completed"
        wall0 = _time.perf_counter()
        try:
            done = 0
            while True:
                chunk = min(every, n_total - done)
                t_record = state.t
                code = algo.advance(model, state, chunk, rec, scratch)
                self._store(rec, t_record, records, writer)
                if code != OK:
                    status, message = algo.failure(code, records[-1]["time"], self)
                    raise SolverDiverged(message)
                done += chunk
                if progress is not None and chunk > 0:
                    progress(done / n_total, state.t)
                if chunk == 0:
                    break
        except KeyboardInterrupt:
            status = f"interrupted at t = {state.t:.6g}"
            raise
        finally:
            if writer is not None:
                writer.close(status)
        return self._results(records, status, _time.perf_counter() - wall0, algo)

    def outputs(self, model: Model, x, q, lam, t: float) -> dict:
        """Derived outputs of one record: joint reactions (all joints, NaN for master/slave ones)
        and element section resultants (``reference/joints/reactions.py``, :func:`beam2_resultants`)."""
        force, moment = reactions(model, x, q, lam, t)
        J = len(self.joints)
        out = {"reaction_force": np.full((J, 3), np.nan), "reaction_moment": np.full((J, 3), np.nan)}
        rows = [k for k, j in enumerate(self.joints) if not isinstance(j.formulation, MasterSlave)]
        out["reaction_force"][rows], out["reaction_moment"][rows] = force, moment
        E = model.conn.shape[0]
        out["section_force"], out["section_moment"] = np.zeros((E, 3)), np.zeros((E, 3))
        beam2_resultants(x, q, model.conn, model.L0, model.psi0, model.gamma0, model.stiff,
                         out["section_force"], out["section_moment"], np.zeros(24))
        return out

    def _store(self, rec: Record, t: float, records: list, writer) -> None:
        entry = {
            "time": t, "position": rec.x.copy(), "rotation": rec.q.copy(), "velocity": rec.v.copy(),
            "angular_velocity": rec.w.copy(), "violation_norm": rec.constraint[0],
            "velocity_violation_norm": rec.constraint[1], "multipliers": rec.lam.copy(),
            "kinetic": rec.energy[0], "strain": rec.energy[1], "external_work": rec.energy[2],
            "dissipated": rec.energy[3],
            **self.outputs(self.model, rec.x, rec.q, rec.lam, t),
        }
        records.append(entry)
        if writer is not None:
            writer.append(entry)

    def _results(self, records, status, wall, algo) -> Results:
        def stack(key):
            return np.array([r[key] for r in records])

        return Results(
            time=stack("time"), labels=[n.label for n in self.nodes], positions=stack("position"),
            rotations=stack("rotation"), velocities=stack("velocity"),
            angular_velocities=stack("angular_velocity"),
            energy={k: stack(k) for k in ("kinetic", "strain", "external_work", "dissipated")},
            constraint_violation=stack("violation_norm"),
            velocity_constraint_violation=stack("velocity_violation_norm"),
            status=status, wall_time=wall, attrs={"algorithm": algo.name, "dt": algo.dt},
            joint_labels=[j.label for j in self.joints], reaction_forces=stack("reaction_force"),
            reaction_moments=stack("reaction_moment"), element_labels=[e.label for e in self.elements],
            section_forces=stack("section_force"), section_moments=stack("section_moment"),
            multipliers=stack("multipliers").reshape(len(records), -1),
        )
