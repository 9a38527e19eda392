"""ParaView output: every .vtp reads back with its points, cells and arrays; the .pvd parses."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import vtk

from reference.domain import SolverSettings
from reference.elements import Section
from reference.interactions import NodalLoad, Ramp
from reference.io.vtk import write_vtk

from conftest import cantilever


def test_vtk_round_trip(tmp_path):
    sec = Section(EA=1e3, GA2=1e3, GA3=1e3, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0, rhoJ1=2e-2, rhoJ2=1e-2, rhoJ3=1e-2)
    d, nodes = cantilever(4, sec)
    d.add_rigid_bar("bar", (2.0, 0.0, 0.0), (2.0, 1.0, 0.0), sec, axis2=(1.0, 0.0, 0.0))
    d.add_interaction(NodalLoad(nodes[-1], np.array([0.0, 0.0, 1e-2]), time_function=Ramp(0.0, 0.05, 0.0, 1.0)))
    d.solver = SolverSettings(dt=1e-3, t_end=0.05, output_every=10)
    r = d.solve()
    pvd = write_vtk(d, r, tmp_path / "vtk")
    entries = ET.parse(pvd).getroot().find("Collection").findall("DataSet")
    assert len(entries) == len(r.time) == 6
    for step, entry in enumerate(entries):
        reader = vtk.vtkXMLPolyDataReader()
        reader.SetFileName(str(pvd.parent / entry.get("file")))
        reader.Update()
        poly = reader.GetOutput()
        # 5 beam nodes + the bar's centre and its three named points; 4 elements + 3 axis segments
        assert poly.GetNumberOfPoints() == 5 + 1 + 3
        assert poly.GetNumberOfLines() == 4 + 3
        assert float(entry.get("timestep")) == r.time[step]
        pd, cd = poly.GetPointData(), poly.GetCellData()
        for name in ("displacement", "velocity", "triad_1", "triad_2", "triad_3"):
            assert pd.GetArray(name).GetNumberOfComponents() == 3, name
        for name in ("N", "M"):
            assert cd.GetArray(name).GetNumberOfTuples() == 7, name
        tip = np.array(poly.GetPoints().GetPoint(4))
        assert np.allclose(tip, r.position("beam:4")[step])
        # triads are orthonormal
        t1 = np.array(pd.GetArray("triad_1").GetTuple3(4))
        t2 = np.array(pd.GetArray("triad_2").GetTuple3(4))
        assert abs(t1 @ t2) < 1e-12 and abs(np.linalg.norm(t1) - 1.0) < 1e-12
    # the cantilever loaded along z bends about section axis 2 only; the rigid bar's segments carry nothing
    M = np.array([cd.GetArray("M").GetTuple3(k) for k in range(7)])
    assert M[0, 1] != 0.0 and M[0, 0] == 0.0 and M[0, 2] == 0.0
    assert np.all(M[4:] == 0.0)
