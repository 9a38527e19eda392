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

This module assembles the model; beside it, :mod:`reference.building` checks what
the ``add_*`` calls are given and resolves node references (``"rod:start"``),
:mod:`reference.mesh` gives the beams' geometry, :mod:`reference.joints.setup` the
constraint set-up (joint tables, the redundancy check, consistent initial
velocities).  The solution loop (records, monitor, how a run ends) is :mod:`reference.solution`, a function
of a Domain that this module does not import: :meth:`Domain.solve` runs it through
:attr:`Domain.solution_loop`, its name resolved on the first solve.
"""

from __future__ import annotations

import math

import numpy as np

from reference.algorithms import ALGORITHMS, Algorithm, SolverSettings, resolve
from reference.elements import Element, Section
from reference.elements.families import ALWAYS_PACKED, DEFAULT_FAMILY, ELEMENT_FAMILIES
from reference.elements.formulation import formulation_groups, vector_norms
from reference.elements.placement import add_lumped_masses, no_elements, place
from reference.connector import GROUND
from reference.errors import SolverDiverged
from reference.forces import ForceElement, pack_force_elements
from reference.interactions import (
    Constant, FixedCoordinates, Gravity, Interaction, LineLoad, NodalLoad, TimeFunction, TimeFunctionTable,
    pack_loads,
)
from reference.io.results import Results
from reference.joints import Jacobian, Joint, joint_frame, setup
from reference.building import beam_arguments, resolve_node, with_axis2
from reference.validation import direction, vector
from reference.mesh import arc_geometry, beam_triad, default_axis2, section_frames, straight_line
from reference.nodes import Node
from reference.rotation import EulerParameters
from reference.state import Model, Nodes, State, new_clock
from reference.status import OK


def free_block_inverse(inertia: np.ndarray, free_rot: np.ndarray) -> np.ndarray:
    """Per node, the inverse of the rotary inertia restricted to the free rotations, zero-padded.

    With some body-frame rotations fixed (ω_k = 0) and a full tensor J, the free
    accelerations solve ``J_ff ω̇_f = g_f``; a diagonal J gives ``1/J_kk`` as before.
    """
    out = np.zeros_like(inertia)
    free = free_rot > 0.0
    whole = free.all(axis=1)
    out[whole] = np.linalg.inv(inertia[whole])  # the same LAPACK call per matrix as one at a time
    for n in np.flatnonzero(~whole):
        f = np.flatnonzero(free[n])
        if f.size:
            out[n][np.ix_(f, f)] = np.linalg.inv(inertia[n][np.ix_(f, f)])
    return out


class Domain:
    """A multibody problem: nodes, elements, joints, interactions, solver settings.

    Build it with the ``add_*`` methods or read it from a model deck
    (``reference.io.deck.load_deck(path).domain``: the deck reader builds a Domain, the Domain knows no
    deck), then call :meth:`solve`.
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
        self._labels: dict[str, Node] = {}
        self.beams: dict[str, list[Node]] = {}
        """Flexible beams by label: their nodes in order (what ``BEAM:start``, ``BEAM:mid``, ``BEAM:end``
        and ``BEAM:i`` name, :meth:`node`)."""
        self._model: Model | None = None
        self.state: State | None = None

    def add_node(self, position, *, rotation=None, label=None, velocity=(0.0, 0.0, 0.0),
                 angular_velocity=(0.0, 0.0, 0.0)) -> Node:
        """Add a node; ``rotation`` are its Euler parameters (identity if omitted)."""
        node_id = len(self.nodes)
        label = label if label is not None else f"node:{node_id}"
        if label in self._labels:
            raise ValueError(f"a node labelled {label!r} already exists")
        position = vector(position, f"node {label!r}: position")
        node = Node(node_id, label, position,
                    np.array([1.0, 0, 0, 0]) if rotation is None else rotation, velocity, angular_velocity,
                    frame_given=rotation is not None)
        self.nodes.append(node)
        self._labels[label] = node
        self._model = None
        return node

    def node(self, key) -> Node:
        """Node by id (int), label (str) or beam reference, as a deck names it (``docs/deck.md``, "Node
        references"): ``BEAM:start``, ``BEAM:mid``, ``BEAM:end``, ``BEAM:i`` of a beam of :attr:`beams`
        (:func:`reference.building.resolve_node`).

        Raises
        ------
        reference.validation.LabelError
            A ``KeyError`` of one line, the deck's wording: what is wrong and the fix (a close label).
        """
        return resolve_node(key, self.nodes, self._labels, self.beams)

    def add_element(self, formulation, nodes, label: str = "", frames=None) -> Element:
        """Add an element; ``frames`` its section triads at rest (Euler parameters per node, default: the node frames)."""
        frames = None if frames is None else np.array(frames, dtype=float).reshape(len(nodes), 4)
        element = Element(formulation, tuple(self.node(n).id for n in nodes), label, frames)
        self.elements.append(element)
        self._model = None
        return element

    def add_beam(self, label: str, start, end, n_elements: int | None = None, section: Section | None = None, *,
                 axis2=None, start_node: Node | None = None, end_node: Node | None = None, center=None,
                 element: str = DEFAULT_FAMILY) -> list[Node]:
        """Mesh a straight beam, or a circular arc about ``center``, into ``n_elements`` elements of the
        family ``element`` (a name of :data:`reference.elements.families.ELEMENT_FAMILIES`, two-node).

        The family chooses each element's section frames at rest
        (``formulation.rest_frames``): by default straight in its own section
        frame (axis 1 along its chord, axis 2 the ``axis2`` hint made orthogonal
        to it; ``axis2`` defaults to :data:`reference.mesh.DEFAULT_AXIS2` where that is never parallel to the beam, else
        :func:`default_axis2`); a helicoidal ``beam2_se3`` takes the beam's triads at the nodes,
        so its reference is the arc itself; a three-node family (``beam3``)
        gets a middle node per element (2 n_elements segments).  New nodes,
        labelled ``f"{label}:{i}"``, get the beam's section triad on the beam's
        axis (straight beam) or on the arc's tangent (:func:`reference.mesh.arc_geometry`);
        the kink between a node frame and an element's section frame is the
        element end's constant offset (:class:`reference.state.Model`), exact
        for any angle.  ``start_node``/``end_node`` reuse existing nodes: a
        node whose frame is given (a ``[[nodes]]`` rotation, a rigid body, or
        set by an earlier beam) keeps it; otherwise it takes this beam's end
        frame.  Chord-frame arcs converge at second order in the element size
        to the circle (chords between nodes on the arc).

        The checks and messages are the deck reader's (``beam 'rod': n_elements: expected an integer
        ≥ 1, got 8.0``); ``n_elements`` and ``section`` are required.
        """
        what = f"beam {label!r}"
        n_elements, start, end, center = beam_arguments(label, self.beams, n_elements, section, element,
                                                        start, end, center)
        start_node, end_node = (None if n is None else self.node(n) for n in (start_node, end_node))
        for node, point in ((start_node, start), (end_node, end)):
            if node is not None and np.linalg.norm(node.position - point) > 1e-12 * max(1.0, np.linalg.norm(point)):
                raise ValueError(f"{what}: node {node.label!r} is not at the beam's end point {point.tolist()}")
        formulation = ELEMENT_FAMILIES[element](section)
        segments = n_elements * (formulation.n_nodes - 1)
        if center is None:
            points, tangents = straight_line(start, end, segments)
        else:
            points, tangents = arc_geometry(start, end, center, segments)
        node_q, elem_q = with_axis2(what, axis2, lambda hint: section_frames(points, tangents, hint),
                                    lambda: default_axis2(start, end, center))
        nodes = []
        for i in range(segments + 1):
            reuse = start_node if i == 0 else end_node if i == segments else None
            if reuse is not None:
                if not reuse.frame_given:
                    reuse.rotation, reuse.frame_given = node_q[i].copy(), True
                nodes.append(reuse)
            else:
                node = self.add_node(points[i], rotation=node_q[i].copy(), label=f"{label}:{i}")
                nodes.append(node)
        for i in range(n_elements):
            self.add_element(formulation, formulation.mesh_nodes(nodes, i), f"{label}/{i}",
                             frames=formulation.rest_frames(node_q, elem_q, i))
        self.beams[label] = nodes
        return nodes

    def add_rigid_body(self, label: str, mass: float, inertia, position, *, rotation=None, points=None) -> Node:
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
        node = self.add_node(position, rotation=rotation, label=label)
        node.mass, node.inertia, node.frame_given = float(mass), inertia, True
        node.points = {name: np.asarray(p, dtype=float) for name, p in (points or {}).items()}
        return node

    def add_rigid_bar(self, label: str, start, end, section: Section, *, axis2=None) -> Node:
        """A beam declared rigid: one rigid body with the bar's mass distribution.

        Mass ``ρA L``; inertia about the centre in the section frame
        ``diag(ρJ1 L, ρJ2 L + ρA L³/12, ρJ3 L + ρA L³/12)`` — the uniform bar
        (the paper meshes its rigid bars with two beam elements; a rigid bar
        has no deformation, so one body carries exactly the same inertia).
        Named points ``start``, ``end`` and ``centre``.  The section needs only its mass data
        (``rhoA``, ``rhoJ1``…``rhoJ3``); ``axis2`` as for :meth:`add_beam`.
        """
        what = f"rigid bar {label!r}"
        if not isinstance(section, Section):
            raise ValueError(f"{what}: section: expected a reference.elements.Section, got {type(section).__name__}")
        start, end = vector(start, f"{what}: start"), vector(end, f"{what}: end")
        length = float(np.linalg.norm(end - start))
        if length <= 0.0:
            raise ValueError(f"{what}: start and end coincide")
        triad = with_axis2(what, axis2, lambda hint: beam_triad(end - start, hint), lambda: default_axis2(start, end))
        q = EulerParameters.from_matrix(triad).q
        m = section.rhoA * length
        J = np.diag([section.rhoJ1 * length, section.rhoJ2 * length + m * length**2 / 12.0,
                     section.rhoJ3 * length + m * length**2 / 12.0])
        centre = 0.5 * (start + end)
        return self.add_rigid_body(label, m, J, centre, rotation=q,
                                   points={"start": start, "end": end, "centre": centre})

    def add_joint(self, kind: str, body_i, body_j, point, *, axis=(0.0, 0.0, 1.0), reference=None, frame=None,
                  formulation=None, time_function: TimeFunction | None = None, mode: str = "position",
                  label: str = "", intended_offset: bool = False) -> Joint:
        """Join ``body_i`` to ``body_j`` (a node, its id or label; ``"ground"`` or ``None``: the ground) at
        ``point`` about/along ``axis``.

        ``reference`` fixes the joint frame's u1 (see :func:`reference.joints.joint_frame`);
        a full ``frame`` (columns u1, u2, u3) may be given instead.  For a universal
        joint ``axis`` is the pin on body i (u1) and ``reference`` the pin on body j (u2).
        Drives take a ``time_function`` (θ(t) or s(t), or their rates with ``mode="velocity"``); so does a
        ``"prescribed_displacement"`` (s(t) [m] of ``point`` along ``axis``, inertial; ``body_j`` the ground).
        Bodies are named as in a deck (:meth:`node`: ``"rod:start"``…); a joint of a body to itself is
        refused here, by label.  ``intended_offset``: the point lies away from both bodies by design
        (no warning, :func:`reference.validation.joint_offsets`).

        Takes 12 parameters: the deck's ``[[joints]]`` keys, all but the bodies and the point keyword-only, each
        named at the call.
        """
        what = f"joint {label or kind!r}"
        point, axis = vector(point, f"{what}: point"), direction(axis, f"{what}: axis")
        reference = None if reference is None else direction(reference, f"{what}: reference")
        if frame is None and kind == "universal":
            if reference is None:
                raise ValueError("a universal joint needs the pin of body j as `reference`")
            u3 = np.cross(axis, reference)
            if not np.linalg.norm(u3) > 1e-9 * np.linalg.norm(axis) * np.linalg.norm(reference):
                raise ValueError("the reference direction of a joint frame is parallel to its axis")
            frame = joint_frame(u3, axis)
        frame = joint_frame(axis, reference) if frame is None else np.asarray(frame, dtype=float)
        ends = [None if body is None or (isinstance(body, str) and body == GROUND) else self.node(body)
                for body in (body_i, body_j)]
        if ends[0] is not None and ends[0] is ends[1]:
            raise ValueError(f"{what}: body_i and body_j are the same body {ends[0].label!r}; "
                             "join two bodies, or a body and the ground (\"ground\" or None)")
        joint = Joint(kind, *ends, point, frame, formulation=formulation or Jacobian(),
                      time_function=time_function or Constant(0.0), mode=mode,
                      label=label or f"{kind}:{len(self.joints)}", intended_offset=bool(intended_offset))
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
        limits = []
        if self.elements:
            ends = np.array([e.nodes[:2] for e in self.elements], dtype=np.int64)
            x = np.array([n.position for n in self.nodes], dtype=float).reshape(-1, 3)
            lengths = vector_norms(x[ends[:, 1]] - x[ends[:, 0]])  # the elements' chords, each np.linalg.norm's
            # the limit of each (formulation, length) once: a uniform mesh repeats them
            for formulation, members in formulation_groups(self.elements):
                limits += [formulation.critical_time_step(L) for L in np.unique(lengths[members]).tolist()]
        if self.force_elements:
            lumped = self._lumped_masses()
            for fe in self.force_elements:
                rate = fe.stiffness_rate(lambda node: lumped[node.id])
                if rate > 0.0:
                    limits.append(2.0 / math.sqrt(rate))
        return min(limits) if limits else math.inf

    def _lumped_masses(self) -> list:
        """``(m, J)`` of every node with the elements' lumped masses added, J in the node frame."""
        mass, inertia, _ = self._lumped()
        return list(zip(mass, inertia))

    def _lumped(self, configuration: tuple | None = None):
        """Node masses (N,) and rotary inertias (N,3,3, node frames) with the elements' lumped masses added
        (element after element, in the Domain's order), and each family's elements placed at t = 0
        (:class:`~reference.elements.formulation.PlacedElements`, by family name: node positions, section
        triads and the end offsets ``o_a = q_a⁰* ⊗ p_a⁰``).  Each family's elements at once
        (:mod:`reference.elements.placement`); ``configuration`` the nodes' ``(x, q)`` if already made."""
        N = len(self.nodes)
        mass = np.array([n.mass for n in self.nodes], dtype=float)
        inertia = np.array([n.inertia for n in self.nodes], dtype=float).reshape(N, 3, 3)
        placed = place(self.elements, *(configuration or self._configuration()))
        add_lumped_masses(mass, inertia, placed)
        return mass, inertia, placed

    def _element_families(self, placed) -> tuple:
        """Each element family's plain data (:attr:`reference.state.Model.elements`), in registry order: the
        families the model uses and the engine's own (:data:`~reference.elements.families.ALWAYS_PACKED`)."""
        unknown = sorted(set(placed) - set(ELEMENT_FAMILIES))
        if unknown:
            raise ValueError(f"element family {unknown[0]!r} is not registered; known: {', '.join(ELEMENT_FAMILIES)} "
                             "(reference.elements.families.register)")
        return tuple(ELEMENT_FAMILIES[name].pack(placed[name] if name in placed else no_elements(ELEMENT_FAMILIES[name]))
                     for name in ELEMENT_FAMILIES if name in placed or name in ALWAYS_PACKED)

    def initialization(self) -> Model:
        """Assemble the plain-data model: lumped masses, references, loads (paper: Initialization).

        Each group of the :class:`~reference.state.Model` is packed by the classes of its objects:
        the element families, the loads (:func:`reference.interactions.pack_loads`), the joint
        formulations (:func:`reference.joints.setup.constraint_fields`) and the force elements
        (:func:`reference.forces.pack_force_elements`).
        """
        N = len(self.nodes)
        configuration = self._configuration()
        mass, inertia, placed = self._lumped(configuration)
        elements = self._element_families(placed)
        massless = [self.nodes[i].label for i in np.flatnonzero(~(mass > 0.0))]
        if massless:
            raise ValueError(f"nodes without mass (attach them to an element or give them a mass): {massless[:5]}")
        singular = [self.nodes[i].label for i in np.flatnonzero(~(np.linalg.det(inertia) > 0.0))]
        if singular:
            raise ValueError(f"nodes without positive rotary inertia: {singular[:5]}")
        free = np.ones((N, 6))
        for bc in self.boundary_conditions:
            free[self.node(bc.node).id, list(bc.dofs)] = 0.0
        gravity = np.zeros(3)
        for g in self.loading:
            if isinstance(g, Gravity):
                gravity += np.asarray(g.g, dtype=float)
        tfs = TimeFunctionTable()
        loads = pack_loads(self.loading, self.node, tfs.index)
        constraints, constrained = setup.constraint_fields(
            self.joints, N, tfs.index, {i for e in self.elements for i in e.nodes},
            {self.node(bc.node).id for bc in self.boundary_conditions})
        force_elements = pack_force_elements(self.force_elements, tfs.index)
        nodes = Nodes(mass, inertia, free_block_inverse(inertia, free[:, 3:]), free, constrained,
                      np.flatnonzero(constrained).astype(np.int64))
        self._model = Model(nodes=nodes, elements=elements, loads=loads, gravity=gravity,
                            damping=float(self.solver.damping), time_functions=tfs.pack(),
                            force_elements=force_elements, **constraints)
        setup.check_redundancy(self._model, setup.multiplier_joints(self.joints), *configuration)
        return self._model

    def _configuration(self, x=None, q=None):
        """Positions and Euler parameters: the nodes' initial ones where not given."""
        x = np.array([n.position for n in self.nodes]).reshape(-1, 3) if x is None else np.asarray(x, dtype=float)
        q = np.array([n.rotation for n in self.nodes]).reshape(-1, 4) if q is None else np.asarray(q, dtype=float)
        return x, q

    def constraint_matrices(self, model: Model, x=None, q=None, t: float = 0.0):
        """Global Φ (m,), Φ_t (m,), B (m, 6N) and B M⁻¹ at a configuration (default: initial), dense
        (:func:`reference.joints.setup.constraint_matrices`; the step never forms these arrays)."""
        return setup.constraint_matrices(model, *self._configuration(x, q), t)

    def initial_conditions(self) -> State:
        """State at t = 0 from the nodes' initial positions, rotations and velocities."""
        N = len(self.nodes)
        self.state = State(
            x=np.array([n.position for n in self.nodes]).reshape(N, 3),
            q=np.array([n.rotation for n in self.nodes]).reshape(N, 4),
            v=np.array([n.velocity for n in self.nodes]).reshape(N, 3),
            w=np.array([n.angular_velocity for n in self.nodes]).reshape(N, 3),
            f_prev=np.zeros((N, 6)),
            clock=new_clock(),
            angle=np.zeros(len(self.force_elements)),
        )
        if self.solver.consistent_initial_velocities and self.joints:
            setup.project_initial_velocities(self._model or self.initialization(), self.state,
                                             setup.flexible_bodies(N, [e.nodes for e in self.elements]))
        return self.state

    def algorithm(self, *, dt: float | None = None) -> Algorithm:
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
        if n > 0 and algo.advance(model, state, algo.start(model, state, self.critical_time_step()), n, None) != OK:
            raise SolverDiverged(f"the solution became non-finite before t = {time}")
        return state

    solution_loop = "reference.solution:solve"
    """The solution loop that :meth:`solve` runs, :func:`reference.solution.solve` (a function of a Domain), by
    name: resolved on the first solve as the algorithms' registry resolves its classes
    (:func:`reference.algorithms.resolve`), so the Domain, which assembles the problem, does not import the loop
    that drives it (the loop imports the records, the monitor and the results file)."""

    def solve(self, *, t_end: float | None = None, dt: float | None = None, results_path=None, progress=None,
              monitor: bool = True, deck=None) -> Results:
        """Run from t = 0 to ``t_end`` (paper: Solve, Fig. 9) and return the time histories:
        :func:`reference.solution.solve` on this Domain, whose parameters, statuses and errors
        (:class:`reference.errors.SolverDiverged`) these are."""
        return resolve(self.solution_loop)(self, t_end=t_end, dt=dt, results_path=results_path, progress=progress,
                                           monitor=monitor, deck=deck)
