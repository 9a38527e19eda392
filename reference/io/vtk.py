"""ParaView output: one VTKHDF file per run (``NAME.vtkhdf``, transient PolyData, read by ParaView ≥ 5.12).

Each output step holds

- points: the beam nodes, and for every rigid body its centre of mass and its
  named points (the rigid bar's ends);
- line cells: one per Beam2 element (the beam centrelines) and one segment per
  rigid body from its centre to each named point (its axis); a rigid body without
  named points is a vertex cell;
- point data: ``displacement`` and ``velocity`` (inertial), the nodal triad as
  ``triad_1``, ``triad_2``, ``triad_3`` (inertial components of the body axes);
- cell data: section forces ``N`` and moments ``M`` (section frame) of each
  element (from the results when they hold them, else computed), zero on
  rigid-body cells.

The topology is written once and replayed for every step (the format's offsets),
the per-step arrays are computed for all points at once and written in blocks;
the arrays are single precision (plotting needs no more, and it halves the file;
``displacement`` keeps small motions that single-precision coordinates would round).  ``--vtk-every`` thins the output further.  The file is
written with h5py (VTKHDF is HDF5); ``vtk`` is not needed to write it.
"""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np

from reference.elements.formulation import beam2_resultants

BLOCK = 64
"""Output steps computed and written together."""


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


class _Layout:
    """Static topology: the points (beam nodes, rigid-body centres and named points) and the cells."""

    def __init__(self, domain):
        beam = sorted({i for e in domain.elements for i in e.nodes})
        in_beam = set(beam)
        self.rigid = [n for n in domain.nodes if n.id not in in_beam]
        point_of = {nid: k for k, nid in enumerate(beam)}
        self.node_of_point = list(beam)  # node whose motion carries each point
        self.offsets = [np.zeros(3)] * len(beam)  # body-frame offset of each point
        lines = [(point_of[e.nodes[0]], point_of[e.nodes[1]]) for e in domain.elements]
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
        self.node_of_point = np.array(self.node_of_point, dtype=np.int64)
        self.offsets = np.array(self.offsets, dtype=float).reshape(-1, 3)
        self.with_offset = np.flatnonzero(np.any(self.offsets != 0.0, axis=1))  # rigid-body points off the centre
        self.lines = np.array(lines, dtype=np.int64).reshape(-1, 2)
        self.vertices = np.array(vertices, dtype=np.int64)
        self.n_elements = len(domain.elements)
        x0 = np.array([n.position for n in domain.nodes], dtype=float).reshape(-1, 3)
        q0 = np.array([n.rotation for n in domain.nodes], dtype=float).reshape(-1, 4)
        self.p0 = self.points(x0[None], q0[None])[0]

    @property
    def n_points(self) -> int:
        return len(self.node_of_point)

    @property
    def n_cells(self) -> int:
        return len(self.vertices) + len(self.lines)

    def points(self, X, Q):
        """Point positions (k, P, 3) and triads (k, P, 3, 3) from node positions (k, N, 3), rotations (k, N, 4)."""
        A = rotation_matrices(Q[:, self.node_of_point])
        pts = X[:, self.node_of_point]
        off = self.with_offset
        if len(off):
            pts[:, off] += np.einsum("kpij,pj->kpi", A[:, off], self.offsets[off])
        return pts, A


def write_vtk(domain, results, directory, name: str = "flexmbs", every: int = 1) -> Path:
    """Write ``directory/NAME.vtkhdf`` with every ``every``-th output of ``results``; return its path.

    ``name`` is made a safe file name (:func:`safe_name`).
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{safe_name(name)}.vtkhdf"
    lay = _Layout(domain)
    steps = np.arange(0, len(results.time), max(int(every), 1))
    n, P, C = len(steps), lay.n_points, lay.n_cells
    model = domain.model
    s_el = np.zeros(32)
    E = lay.n_elements
    stored = results.section_forces.shape[1:] == (E, 3) and not np.isnan(results.section_forces).all()
    with h5py.File(path, "w") as f:
        root = f.create_group("VTKHDF")
        root.attrs["Version"] = np.array([2, 1], dtype=np.int64)
        root.attrs.create("Type", np.bytes_("PolyData"), dtype=h5py.string_dtype("ascii", len("PolyData")))
        root.create_dataset("NumberOfPoints", data=np.array([P], dtype=np.int64))
        for group, conn in (("Vertices", lay.vertices.reshape(-1, 1)), ("Lines", lay.lines),
                            ("Polygons", np.zeros((0, 3), dtype=np.int64)), ("Strips", np.zeros((0, 3), dtype=np.int64))):
            g = root.create_group(group)
            g.create_dataset("NumberOfCells", data=np.array([len(conn)], dtype=np.int64))
            g.create_dataset("NumberOfConnectivityIds", data=np.array([conn.size], dtype=np.int64))
            g.create_dataset("Offsets", data=np.arange(0, conn.size + 1, max(conn.shape[1], 1), dtype=np.int64))
            g.create_dataset("Connectivity", data=conn.reshape(-1).astype(np.int64))
        points = root.create_dataset("Points", shape=(n * P, 3), dtype="f4")
        pd, cd = root.create_group("PointData"), root.create_group("CellData")
        arrays = {name: pd.create_dataset(name, shape=(n * P, 3), dtype="f4")
                  for name in ("displacement", "velocity", "triad_1", "triad_2", "triad_3")}
        forces = {name: cd.create_dataset(name, shape=(n * C, 3), dtype="f4") for name in ("N", "M")}
        st = root.create_group("Steps")
        st.attrs["NSteps"] = n
        st.create_dataset("Values", data=np.asarray(results.time, dtype=float)[steps])
        st.create_dataset("PartOffsets", data=np.zeros(n, dtype=np.int64))
        st.create_dataset("NumberOfParts", data=np.ones(n, dtype=np.int64))
        st.create_dataset("PointOffsets", data=np.arange(n, dtype=np.int64) * P)
        st.create_dataset("CellOffsets", data=np.zeros((n, 4), dtype=np.int64))
        st.create_dataset("ConnectivityIdOffsets", data=np.zeros((n, 4), dtype=np.int64))
        for group, size, names in (("PointDataOffsets", P, arrays), ("CellDataOffsets", C, forces)):
            g = st.create_group(group)
            for key in names:
                g.create_dataset(key, data=np.arange(n, dtype=np.int64) * size)
        node_rows = lay.node_of_point
        for b0 in range(0, n, BLOCK):
            idx = steps[b0:b0 + BLOCK]
            k = len(idx)
            X, Q = results.positions[idx], results.rotations[idx]
            V, W = results.velocities[idx], results.angular_velocities[idx]
            pts, A = lay.points(X, Q)
            rows = slice(b0 * P, (b0 + k) * P)
            points[rows] = pts.reshape(-1, 3)
            arrays["displacement"][rows] = (pts - lay.p0[None]).reshape(-1, 3)
            vel = V[:, node_rows]
            off = lay.with_offset
            if len(off):
                vel[:, off] += np.einsum("kpij,kpj->kpi", A[:, off],
                                         np.cross(W[:, node_rows[off]], lay.offsets[off][None]))
            arrays["velocity"][rows] = vel.reshape(-1, 3)
            for c in range(3):
                arrays[f"triad_{c + 1}"][rows] = A[..., :, c].reshape(-1, 3)
            NM = np.zeros((2, k, C, 3))
            beams = slice(len(lay.vertices), len(lay.vertices) + E)
            if stored:
                NM[0, :, beams], NM[1, :, beams] = results.section_forces[idx], results.section_moments[idx]
            else:
                for s in range(k):
                    beam2_resultants(X[s], Q[s], model.conn, model.offset, model.L0, model.psi0, model.gamma0,
                                     model.stiff, NM[0, s, beams], NM[1, s, beams], s_el)
            cells = slice(b0 * C, (b0 + k) * C)
            forces["N"][cells] = NM[0].reshape(-1, 3)
            forces["M"][cells] = NM[1].reshape(-1, 3)
    return path
