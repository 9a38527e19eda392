"""ParaView output: one VTKHDF file per run that VTK's own reader reads back, step by step, with its
points, cells and arrays; rigid-body-only models; names that are not file names."""

from __future__ import annotations

import numpy as np
import pytest
import vtk

from reference.domain import Domain, SolverSettings
from reference.elements import Section
from reference.interactions import Gravity, NodalLoad, Ramp
from reference.io.vtk import rotation_matrices, safe_name, write_vtk
from reference.rotation import EulerParameters, RotationVector

from conftest import cantilever

SEC = Section(EA=1e3, GA2=1e3, GA3=1e3, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2, rhoJ3=1e-2)


def read(path, step):
    reader = vtk.vtkHDFReader()
    reader.SetFileName(str(path))
    reader.UpdateInformation()
    times = reader.GetOutputInformation(0).Get(vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    reader.UpdateTimeStep(times[step])
    return reader.GetOutput(), times


def test_vtk_round_trip(tmp_path):
    d, nodes = cantilever(4, SEC)
    d.add_rigid_bar("bar", (2.0, 0.0, 0.0), (2.0, 1.0, 0.0), SEC, axis2=(1.0, 0.0, 0.0))
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.0, 1e-2]), time_function=Ramp(0.0, 0.05, 0.0, 1.0)))
    d.solver = SolverSettings(dt=1e-3, t_end=0.05, output_every=10)
    r = d.solve()
    path = write_vtk(d, r, tmp_path / "vtk", "cantilever")
    assert path.name == "cantilever.vtkhdf" and len(list((tmp_path / "vtk").iterdir())) == 1
    for step in range(len(r.time)):
        poly, times = read(path, step)
        assert len(times) == len(r.time) == 6 and times[step] == r.time[step]
        # 5 beam nodes + the bar's centre and its three named points; 4 elements + 3 axis segments
        assert poly.GetNumberOfPoints() == 5 + 1 + 3
        assert poly.GetNumberOfLines() == 4 + 3
        pd, cd = poly.GetPointData(), poly.GetCellData()
        for name in ("displacement", "velocity", "triad_1", "triad_2", "triad_3"):
            assert pd.GetArray(name).GetNumberOfComponents() == 3, name
        for name in ("N", "M"):
            assert cd.GetArray(name).GetNumberOfTuples() == 7, name
        assert np.allclose(poly.GetPoints().GetPoint(4), r.position("beam:4")[step], atol=1e-7)  # single precision
        assert np.allclose(pd.GetArray("displacement").GetTuple3(4), r.position("beam:4")[step] - [1.0, 0.0, 0.0],
                           rtol=1e-6, atol=1e-12)
        t1 = np.array(pd.GetArray("triad_1").GetTuple3(4))
        t2 = np.array(pd.GetArray("triad_2").GetTuple3(4))
        assert abs(t1 @ t2) < 1e-6 and abs(np.linalg.norm(t1) - 1.0) < 1e-6  # single precision arrays
        # the bar's end (its points are start, end, centre) moves with it: half the length from the centre
        assert np.linalg.norm(np.subtract(poly.GetPoints().GetPoint(7), poly.GetPoints().GetPoint(5))) == \
            pytest.approx(0.5, abs=1e-6)
    # the cantilever loaded along z bends about section axis 2 only; the rigid bar's segments carry nothing
    M = np.array([cd.GetArray("M").GetTuple3(k) for k in range(7)])
    assert M[0, 1] != 0.0 and M[0, 0] == 0.0 and M[0, 2] == 0.0
    assert np.all(M[4:] == 0.0)
    _, expected = d.elements[0].formulation.section_resultants(
        r.positions[-1][[0, 1]], r.rotations[-1][[0, 1]],
        d.elements[0].formulation.reference_state(r.positions[0][[0, 1]], r.rotations[0][[0, 1]]))
    assert np.allclose(M[0], expected[3:], rtol=1e-6, atol=1e-12)  # single precision arrays


def test_rotation_matrices_match_the_reference_convention(rng):
    q = rng.normal(size=(5, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for qi, A in zip(q, rotation_matrices(q)):
        assert np.allclose(A, EulerParameters(qi).matrix(), atol=1e-14)


def test_rigid_body_only_model_and_every(tmp_path):
    d = Domain("../../escaped/\u0000name")
    d.add_rigid_body("ball", 1.0, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0])
    d.add_rigid_body("stick", 1.0, [1.0, 2.0, 2.0], [1.0, 0.0, 0.0], points={"tip": [1.5, 0.0, 0.0]})
    d.add_interaction(Gravity(np.array([0.0, 0.0, -9.81])))
    d.solver = SolverSettings(dt=1e-3, t_end=0.1, output_every=10)
    r = d.solve()
    path = write_vtk(d, r, tmp_path / "vtk", d.name, every=5)
    assert path.parent == tmp_path / "vtk" and path.name == safe_name(d.name) + ".vtkhdf"
    poly, times = read(path, 2)
    assert list(times) == list(r.time[::5]) and poly.GetNumberOfPoints() == 3
    assert poly.GetNumberOfVerts() == 1 and poly.GetNumberOfLines() == 1
    assert poly.GetPoints().GetPoint(0)[2] == pytest.approx(-0.5 * 9.81 * r.time[10] ** 2, rel=1e-6)


@pytest.mark.parametrize("family", ["beam3", "beam2_se3"])
def test_curved_families_draw_their_own_interpolation(tmp_path, family):
    """A quarter arc (R = 2) of 2 elements, at rest and then turned and shifted rigidly: each element is one
    polyline of 9 points; the inner points lie on the element's own curve, not on its chords — beam2_se3's
    helicoid is the exact circle (to 1e-6 R, single precision), beam3's the quadratic through its three nodes
    (to 1e-6 R against the shape functions evaluated here; its largest distance from the circle, 3e-4 R here,
    is the quadratic's error, while a chord's mid-point lies 0.076 R inside) — and they move with the nodes
    (a superposed rigid motion moves them rigidly, to 1e-6 R)."""
    from reference.io.results import Results

    R = 2.0
    d = Domain("arc")
    d.add_beam("arc", (R, 0.0, 0.0), (0.0, R, 0.0), 2, SEC, axis2=(0.0, 0.0, 1.0), center=(0.0, 0.0, 0.0),
               element=family)
    x0 = np.array([n.position for n in d.nodes])
    q0 = np.array([n.rotation for n in d.nodes])
    turn = RotationVector(np.array([0.3, -0.2, 0.9])).to_euler_parameters()
    A, shift = turn.matrix(), np.array([0.5, -1.0, 2.0])
    x1 = x0 @ A.T + shift
    q1 = np.array([turn.product(EulerParameters(q)).q for q in q0])
    zeros = np.zeros((2, len(d.nodes), 3))
    r = Results(time=np.array([0.0, 1.0]), labels=[n.label for n in d.nodes], positions=np.array([x0, x1]),
                rotations=np.array([q0, q1]), velocities=zeros, angular_velocities=zeros,
                element_labels=[e.label for e in d.elements], section_forces=np.zeros((2, 2, 3)),
                section_moments=np.zeros((2, 2, 3)))
    path = write_vtk(d, r, tmp_path, family)
    at_rest, _ = read(path, 0)
    moved, _ = read(path, 1)
    assert at_rest.GetNumberOfLines() == 2
    lines = at_rest.GetLines()
    ids, cells = vtk.vtkIdList(), []
    lines.InitTraversal()
    while lines.GetNextCell(ids):
        cells.append([ids.GetId(k) for k in range(ids.GetNumberOfIds())])
    assert [len(c) for c in cells] == [9, 9]
    pts0 = np.array([at_rest.GetPoints().GetPoint(k) for k in range(at_rest.GetNumberOfPoints())])
    pts1 = np.array([moved.GetPoints().GetPoint(k) for k in range(moved.GetNumberOfPoints())])
    for e, cell in enumerate(cells):
        element = d.elements[e]
        ends = x0[list(element.nodes[:2])]
        inner = pts0[cell[1:-1]]
        xi = np.arange(1, 8) / 8.0
        if family == "beam2_se3":
            assert np.allclose(np.linalg.norm(inner, axis=1), R, atol=1e-6 * R, rtol=0)
        else:
            mid = x0[element.nodes[2]]
            t = xi[:, None]
            quadratic = (1 - t) * (1 - 2 * t) * ends[0] + t * (2 * t - 1) * ends[1] + 4 * t * (1 - t) * mid
            assert np.allclose(inner, quadratic, atol=1e-6 * R, rtol=0)
            assert np.max(np.abs(np.linalg.norm(inner, axis=1) - R)) < 1e-3 * R
        chord = (1 - xi[:, None]) * ends[0] + xi[:, None] * ends[1]
        assert np.linalg.norm(inner[3] - chord[3]) > 0.07 * R  # the element's middle is not on its chord
        assert np.allclose(pts1[cell], pts0[cell] @ A.T + shift, atol=1e-6 * R, rtol=0)
