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
from reference.rotation import EulerParameters

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
