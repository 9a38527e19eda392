"""ParaView output: one VTKHDF file per run (``NAME.vtkhdf``, transient PolyData, read by ParaView ≥ 5.12).

Each output step holds

- points: the beam nodes, and for every rigid body its centre of mass and its
  named points (the rigid bar's ends);
- line cells: one polyline per beam element (the beam centrelines) and one segment per
  rigid body from its centre to each named point (its axis); a rigid body without
  named points is a vertex cell.  A Beam2 element is its chord; an element of a family
  that draws more (``curve_segments`` > 1: ``beam3``, ``beam2_se3``) is sub-sampled at
  equal steps of its parameter, the points placed by the element's own interpolation
  (``ElementFormulation.curve``: beam3's quadratic shape functions, beam2_se3's
  helicoid), not on chords; such a point carries the velocity and triad of the
  element's node nearest to it;
- point data: ``displacement`` and ``velocity`` (inertial), the nodal triad as
  ``triad_1``, ``triad_2``, ``triad_3`` (inertial components of the body axes);
- cell data: section forces ``N`` and moments ``M`` (section frame) of each
  element (from the results when they hold them, else computed), zero on
  rigid-body cells.

The topology is written once and replayed for every step (the format's offsets).
The per-step arrays are read from the results file a block of outputs at a time
(never the whole history: memory stays bounded), computed by one compiled loop
over the points and written in blocks; they are single precision (plotting
needs no more, and it halves the file; ``displacement`` keeps small motions
that single-precision coordinates would round).  ``--vtk-every`` thins the
output further.  The file is written with h5py (VTKHDF is HDF5); ``vtk`` is not
needed to write it.
"""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np

from reference.elements.families import resultants
from reference.elements.formulation import end_offsets
from reference.state import element_work
from reference.generated import rotation_maps as rm
from reference.jit import inlined, kernel

BLOCK = 64
"""Output steps computed and written together."""
_rotation_matrix = inlined(rm.rotation_matrix)


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """A(q) (…, 3, 3) of Euler parameters (…, 4), scalar first, body → inertial (reference.rotation)."""
    e0, e = q[..., 0], q[..., 1:]
    A = np.einsum("...i,...j->...ij", 2.0 * e, e)
    diag = e0**2 - np.einsum("...i,...i->...", e, e)
    A[..., 0, 0] += diag
    A[..., 1, 1] += diag
    A[..., 2, 2] += diag
    A[..., 0, 1] -= 2.0 * e0 * e[..., 2]
    A[..., 1, 0] += 2.0 * e0 * e[..., 2]
    A[..., 0, 2] += 2.0 * e0 * e[..., 1]
    A[..., 2, 0] -= 2.0 * e0 * e[..., 1]
    A[..., 1, 2] -= 2.0 * e0 * e[..., 0]
    A[..., 2, 1] += 2.0 * e0 * e[..., 0]
    return A


def safe_name(name: str) -> str:
    """``name`` as a file name: letters, digits, ``. _ -`` kept, anything else ``_`` (no path escapes)."""
    cleaned = re.sub(r"[^A-Za-z0-9._-]", "_", name).lstrip(".")
    return cleaned or "flexmbs"


class Layout:
    """Static topology: the points (beam nodes, rigid-body centres and named points) and the cells.

    ``p0`` (P, 3) are the points in the configuration ``x0`` (N, 3), ``q0`` (N, 4) — by default the
    nodes' at t = 0 — from which ``displacement`` is measured.
    """

    def __init__(self, domain, x0=None, q0=None):
        self.curves, self._lines_seen = [], []
        beam = sorted({i for e in domain.elements for i in e.nodes})
        in_beam = set(beam)
        self.rigid = [n for n in domain.nodes if n.id not in in_beam]
        point_of = {nid: k for k, nid in enumerate(beam)}
        self.node_of_point = list(beam)  # node whose motion carries each point
        self.offsets = [np.zeros(3)] * len(beam)  # body-frame offset of each point
        lines = [self._element_line(domain, e, point_of) for e in domain.elements]
        vertices = []
        for body in self.rigid:
            centre = len(self.node_of_point)
            self.node_of_point.append(body.id)
            self.offsets.append(np.zeros(3))
            A0 = rotation_matrices(np.asarray(body.rotation, dtype=float))
            points = getattr(body, "points", {}) or {}
            for p in points.values():
                self.node_of_point.append(body.id)
                self.offsets.append(A0.T @ (np.asarray(p, dtype=float) - body.position))
                lines.append((centre, len(self.node_of_point) - 1))
            if not points:
                vertices.append(centre)
        self.node_points = len(self.node_of_point)  # the points the compiled loop fills; the curves' follow
        for curve in self.curves:  # an inner curve point moves in the output as its nearest node (velocity, triad)
            curve["first"] = len(self.node_of_point)
            for k, j in zip(curve["points"], curve["nearest"]):
                lines[curve["element"]][k] = len(self.node_of_point)
                self.node_of_point.append(j)
                self.offsets.append(np.zeros(3))
        self.node_of_point = np.array(self.node_of_point, dtype=np.int64)
        self.offsets = np.array(self.offsets, dtype=float).reshape(-1, 3)
        self.lines = [np.array(line, dtype=np.int64) for line in lines]
        self.vertices = np.array(vertices, dtype=np.int64)
        self.n_elements = len(domain.elements)
        x0 = np.array([n.position for n in domain.nodes], dtype=float).reshape(-1, 3) if x0 is None else x0
        q0 = np.array([n.rotation for n in domain.nodes], dtype=float).reshape(-1, 4) if q0 is None else q0
        A = rotation_matrices(np.asarray(q0, dtype=float)[self.node_of_point])
        self.p0 = np.asarray(x0, dtype=float)[self.node_of_point] + np.einsum("pij,pj->pi", A, self.offsets)
        self.curve_points(np.asarray(x0, dtype=float), np.asarray(q0, dtype=float), self.p0)

    def _element_line(self, domain, element, point_of) -> list:
        """The point ids of an element's polyline, first end to second: its nodes at their parameters
        ``node_xi`` and, for ``curve_segments`` > 1, placeholders (−1) for the inner points, recorded in
        :attr:`curves` with the element's nodes, their section-frame offsets and each point's parameter."""
        f = element.formulation
        segments, node_xi = int(f.curve_segments), list(f.node_xi)
        line = [-1] * (segments + 1)
        for a, xi in enumerate(node_xi):
            line[int(round(xi * segments))] = point_of[element.nodes[a]]
        inner = [k for k in range(segments + 1) if line[k] < 0]
        if inner:
            q0 = [domain.node(i).rotation for i in element.nodes]
            offsets = end_offsets(q0, q0 if element.frames is None else element.frames)
            xi = np.array(inner, dtype=float) / segments
            nearest = [element.nodes[int(np.argmin(np.abs(np.array(node_xi) - t)))] for t in xi]
            self.curves.append({"element": len(self._lines_seen), "formulation": f, "nodes": list(element.nodes),
                                "offsets": offsets, "xi": xi, "points": inner, "nearest": nearest})
        self._lines_seen.append(line)
        return line

    def curve_points(self, X: np.ndarray, Q: np.ndarray, out: np.ndarray) -> None:
        """Place the inner curve points of one configuration (node positions X (N, 3), Euler parameters Q
        (N, 4)) into ``out`` (P, 3) from each element's interpolation (section triads ``q ⊗ o``)."""
        p = np.empty(4)
        for curve in self.curves:
            nodes = curve["nodes"]
            triads = np.empty((len(nodes), 4))
            for a, i in enumerate(nodes):
                rm.quat_product(Q[i], curve["offsets"][a], p)
                triads[a] = p
            first = curve["first"]
            out[first:first + len(curve["xi"])] = curve["formulation"].curve(X[nodes], triads, curve["xi"])

    @property
    def n_points(self) -> int:
        return len(self.node_of_point)

    @property
    def n_cells(self) -> int:
        return len(self.vertices) + len(self.lines)


@kernel
def point_arrays(X, Q, V, W, node_of_point, offsets, p0, out):
    """Fill the per-point arrays ``out`` (6, k, P, 3), single precision, of k outputs: the points' positions,
    displacements and velocities and their triads' columns u1, u2, u3.

    A point at body-frame offset s from its node moves as x + A s with velocity
    v + A (ω × s) (ω body frame); its triad is A's columns (A from
    :func:`reference.generated.rotation_maps.rotation_matrix`).  X, V, W (k, N, 3),
    Q (k, N, 4) scalar first; ``node_of_point`` (P,), ``offsets`` (P, 3), ``p0``
    (P, 3) the reference positions.
    """
    A = np.empty(9)  # row-major
    for s in range(X.shape[0]):
        for p in range(node_of_point.shape[0]):
            n = node_of_point[p]
            _rotation_matrix(Q[s, n], A)
            s0, s1, s2 = offsets[p, 0], offsets[p, 1], offsets[p, 2]
            w0, w1, w2 = W[s, n, 0], W[s, n, 1], W[s, n, 2]
            c0, c1, c2 = w1 * s2 - w2 * s1, w2 * s0 - w0 * s2, w0 * s1 - w1 * s0
            for i in range(3):
                x = X[s, n, i] + A[3 * i] * s0 + A[3 * i + 1] * s1 + A[3 * i + 2] * s2
                out[0, s, p, i] = x
                out[1, s, p, i] = x - p0[p, i]
                out[2, s, p, i] = V[s, n, i] + A[3 * i] * c0 + A[3 * i + 1] * c1 + A[3 * i + 2] * c2
                out[3, s, p, i] = A[3 * i]
                out[4, s, p, i] = A[3 * i + 1]
                out[5, s, p, i] = A[3 * i + 2]


class _History:
    """Blocks of output records, read from the results file one block at a time (or from memory)."""

    NAMES = {"positions": "nodes/position", "rotations": "nodes/rotation", "velocities": "nodes/velocity",
             "angular_velocities": "nodes/angular_velocity", "section_forces": "elements/section_force",
             "section_moments": "elements/section_moment"}

    def __init__(self, results):
        self.results = results
        source = getattr(results, "source", None)
        in_memory = all(k in results.__dict__ for k in ("positions", "rotations", "velocities", "angular_velocities"))
        self.file = h5py.File(source, "r") if source is not None and not in_memory else None

    def block(self, start: int, stop: int, every: int) -> dict:
        """Outputs ``start:stop:every`` of every history (section arrays None where not stored)."""
        rows = slice(start, stop, every)
        out = {}
        for key, path in self.NAMES.items():
            if self.file is not None:
                out[key] = self.file[path][rows] if path in self.file else None
            else:
                value = self.results.__dict__.get(key)
                if value is None and key.startswith("section"):
                    value = getattr(self.results, key)
                out[key] = None if value is None else np.asarray(value)[rows]
        return out

    def close(self) -> None:
        if self.file is not None:
            self.file.close()


def write_vtk(domain, results, directory, name: str = "flexmbs", every: int = 1, about=None) -> Path:
    """Write ``directory/NAME.vtkhdf`` with every ``every``-th output of ``results``; return its path.

    ``name`` is made a safe file name (:func:`safe_name`).  ``about``: the configuration
    ``(x0 (N, 3), q0 (N, 4))`` the ``displacement`` is measured from (default: the nodes' at t = 0;
    a mode animation's, :mod:`reference.io.mode_animation`).
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{safe_name(name)}.vtkhdf"
    lay = Layout(domain, *(about or ()))
    every = max(int(every), 1)
    times = np.asarray(results.time, dtype=float)[::every]
    history = _History(results)
    try:
        with h5py.File(path, "w") as f:
            _write_vtk(f, lay, history, times, every, domain.model)
    finally:
        history.close()
    return path


def _write_vtk(f, lay: Layout, history: _History, times: np.ndarray, every: int, model) -> None:
    """The VTKHDF groups of the whole file: topology once, then the outputs ``times`` block by block."""
    n, P, C, E = len(times), lay.n_points, lay.n_cells, lay.n_elements
    root = f.create_group("VTKHDF")
    root.attrs["Version"] = np.array([2, 1], dtype=np.int64)
    root.attrs.create("Type", np.bytes_("PolyData"), dtype=h5py.string_dtype("ascii", len("PolyData")))
    root.create_dataset("NumberOfPoints", data=np.array([P], dtype=np.int64))
    empty = []
    for group, cells in (("Vertices", [np.array([v]) for v in lay.vertices]), ("Lines", lay.lines),
                         ("Polygons", empty), ("Strips", empty)):
        conn = np.concatenate(cells).astype(np.int64) if cells else np.zeros(0, dtype=np.int64)
        g = root.create_group(group)
        g.create_dataset("NumberOfCells", data=np.array([len(cells)], dtype=np.int64))
        g.create_dataset("NumberOfConnectivityIds", data=np.array([conn.size], dtype=np.int64))
        g.create_dataset("Offsets", data=np.concatenate([[0], np.cumsum([len(c) for c in cells])]).astype(np.int64))
        g.create_dataset("Connectivity", data=conn)
    names = ("displacement", "velocity", "triad_1", "triad_2", "triad_3")
    points = root.create_dataset("Points", shape=(n * P, 3), dtype="f4")
    pd, cd = root.create_group("PointData"), root.create_group("CellData")
    arrays = {name: pd.create_dataset(name, shape=(n * P, 3), dtype="f4") for name in names}
    forces = {name: cd.create_dataset(name, shape=(n * C, 3), dtype="f4") for name in ("N", "M")}
    st = root.create_group("Steps")
    st.attrs["NSteps"] = n
    st.create_dataset("Values", data=times)
    st.create_dataset("PartOffsets", data=np.zeros(n, dtype=np.int64))
    st.create_dataset("NumberOfParts", data=np.ones(n, dtype=np.int64))
    st.create_dataset("PointOffsets", data=np.arange(n, dtype=np.int64) * P)
    st.create_dataset("CellOffsets", data=np.zeros((n, 4), dtype=np.int64))
    st.create_dataset("ConnectivityIdOffsets", data=np.zeros((n, 4), dtype=np.int64))
    for group, size, keys in (("PointDataOffsets", P, arrays), ("CellDataOffsets", C, forces)):
        g = st.create_group(group)
        for key in keys:
            g.create_dataset(key, data=np.arange(n, dtype=np.int64) * size)
    buffers = np.empty((6, BLOCK, P, 3), dtype=np.float32)
    beams = slice(len(lay.vertices), len(lay.vertices) + E)
    for b0 in range(0, n, BLOCK):
        k = min(BLOCK, n - b0)
        h = history.block(b0 * every, (b0 + k - 1) * every + 1, every)
        X, Q = h["positions"], h["rotations"]
        out = buffers[:, :k]
        point_arrays(X, Q, h["velocities"], h["angular_velocities"], lay.node_of_point, lay.offsets, lay.p0, out)
        if lay.curves:
            curve = np.empty((P, 3))
            for s in range(k):
                lay.curve_points(X[s], Q[s], curve)
                inner = slice(lay.node_points, P)
                out[0, s, inner] = curve[inner]
                out[1, s, inner] = curve[inner] - lay.p0[inner]
        rows = slice(b0 * P, (b0 + k) * P)
        points[rows] = out[0].reshape(-1, 3)
        for name, values in zip(names, out[1:]):
            arrays[name][rows] = values.reshape(-1, 3)
        NM = np.zeros((2, k, C, 3), dtype=np.float32)
        if E:
            stored = h["section_forces"] is not None and h["section_forces"].shape[1:] == (E, 3) \
                and not np.isnan(h["section_forces"]).all()
            if stored:
                NM[0, :, beams], NM[1, :, beams] = h["section_forces"], h["section_moments"]
            else:
                Nb, Mb, work = np.zeros((E, 3)), np.zeros((E, 3)), element_work(model)
                for s in range(k):
                    resultants(model.elements, work, X[s], Q[s], Nb, Mb)
                    NM[0, s, beams], NM[1, s, beams] = Nb, Mb
        cells = slice(b0 * C, (b0 + k) * C)
        forces["N"][cells] = NM[0].reshape(-1, 3)
        forces["M"][cells] = NM[1].reshape(-1, 3)
