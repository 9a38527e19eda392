"""ParaView output: one ``.vtp`` file per output step and a ``.pvd`` collection.

Each step's polydata holds

- points: the beam nodes, and for every rigid body its centre of mass and its
  named points (the rigid bar's ends);
- line cells: one per Beam2 element (the beam centrelines) and one segment per
  rigid body from its centre to each named point (its axis);
- point data: ``displacement`` and ``velocity`` (inertial), the nodal triad as
  ``triad_1``, ``triad_2``, ``triad_3`` (inertial components of the body axes);
- cell data: section forces ``N`` and moments ``M`` (section frame) of each
  element, zero on rigid-body segments.

``vtk`` is imported here only, where it is used.
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from reference.generated import rotation_maps as rm


def _matrix(q) -> np.ndarray:
    out = np.empty(9)
    rm.rotation_matrix(q, out)
    return out.reshape(3, 3)


def _geometry(domain):
    """Static topology: which points exist and which cells join them."""
    beam_nodes = sorted({i for e in domain.elements for i in e.nodes})
    rigid = [n for n in domain.nodes if n.id not in set(beam_nodes)]
    return beam_nodes, rigid


def write_vtk(domain, results, directory, name: str = "flexmbs") -> Path:
    """Write ``directory/name_#####.vtp`` for every output time and ``directory/name.pvd``.

    Returns the path of the ``.pvd`` file.
    """
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    beam_nodes, rigid = _geometry(domain)
    x0 = np.array([n.position for n in domain.nodes])
    references = [e.formulation.reference_state(x0[list(e.nodes)], np.array([domain.nodes[i].rotation for i in e.nodes]))
                  for e in domain.elements]
    point_of = {nid: k for k, nid in enumerate(beam_nodes)}
    stored = getattr(results, "section_forces", None) is not None and results.section_forces.shape[1:] == (
        len(domain.elements), 3)
    entries = []
    for step, t in enumerate(results.time):
        X, Q, V = results.positions[step], results.rotations[step], results.velocities[step]
        pts, disp, vel, triads = [], [], [], []
        for nid in beam_nodes:
            pts.append(X[nid])
            disp.append(X[nid] - x0[nid])
            vel.append(V[nid])
            triads.append(_matrix(Q[nid]))
        lines, forces, moments = [], [], []
        for k, (e, ref) in enumerate(zip(domain.elements, references)):
            i, j = e.nodes
            lines.append((point_of[i], point_of[j]))
            if stored:  # the results' own section resultants (/elements/section_force, _moment)
                forces.append(results.section_forces[step, k])
                moments.append(results.section_moments[step, k])
            else:
                _, stress = e.formulation.section_resultants(X[[i, j]], Q[[i, j]], ref)
                forces.append(stress[:3])
                moments.append(stress[3:])
        for body in rigid:
            A = _matrix(Q[body.id])
            centre = len(pts)
            pts.append(X[body.id])
            disp.append(X[body.id] - x0[body.id])
            vel.append(V[body.id])
            triads.append(A)
            for p in getattr(body, "points", {}).values():
                offset = _matrix(body.rotation).T @ (p - body.position)
                pts.append(X[body.id] + A @ offset)
                disp.append(pts[-1] - p)
                vel.append(V[body.id] + A @ np.cross(results.angular_velocities[step][body.id], offset))
                triads.append(A)
                lines.append((centre, len(pts) - 1))
                forces.append(np.zeros(3))
                moments.append(np.zeros(3))

        poly = vtk.vtkPolyData()
        points = vtk.vtkPoints()
        points.SetData(numpy_to_vtk(np.asarray(pts, dtype=float), deep=True))
        poly.SetPoints(points)
        cells = vtk.vtkCellArray()
        for a, b in lines:
            line = vtk.vtkLine()
            line.GetPointIds().SetId(0, a)
            line.GetPointIds().SetId(1, b)
            cells.InsertNextCell(line)
        poly.SetLines(cells)

        def add(data, name, values):
            arr = numpy_to_vtk(np.asarray(values, dtype=float).reshape(len(values), -1), deep=True)
            arr.SetName(name)
            data.AddArray(arr)

        add(poly.GetPointData(), "displacement", disp)
        add(poly.GetPointData(), "velocity", vel)
        T = np.asarray(triads)
        for k in range(3):
            add(poly.GetPointData(), f"triad_{k + 1}", T[:, :, k])
        add(poly.GetCellData(), "N", forces if forces else np.zeros((0, 3)))
        add(poly.GetCellData(), "M", moments if moments else np.zeros((0, 3)))

        path = directory / f"{name}_{step:05d}.vtp"
        writer = vtk.vtkXMLPolyDataWriter()
        writer.SetFileName(str(path))
        writer.SetInputData(poly)
        writer.SetDataModeToBinary()
        writer.Write()
        entries.append((float(t), path.name))

    pvd = directory / f"{name}.pvd"
    body = "\n".join(f'    <DataSet timestep="{t!r}" group="" part="0" file={quoteattr(f)}/>' for t, f in entries)
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                   f"  <Collection>\n{body}\n  </Collection>\n</VTKFile>\n", encoding="utf-8")
    return pvd
