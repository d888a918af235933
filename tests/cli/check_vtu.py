#!/usr/bin/env python3
"""Runs `tetcollide mesh convert IN OUT.vtu` and opens OUT.vtu with VTK's XML reader
(the one ParaView uses): the point and cell counts must match, every cell must be a
VTK_TETRA with positive volume, and node_id, boundary and quality must be there.

Usage: check_vtu.py TETCOLLIDE IN OUT.vtu NODES TETS
"""
import subprocess
import sys

from vtkmodules.vtkCommonCore import vtkFileOutputWindow, vtkOutputWindow
from vtkmodules.vtkCommonDataModel import VTK_TETRA
from vtkmodules.vtkFiltersVerdict import vtkMeshQuality
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader


def main():
    exe, mesh, out, nodes, tets = sys.argv[1:6]
    subprocess.run([exe, "mesh", "convert", mesh, out], check=True)
    # Route VTK warnings and errors to a file we can inspect.
    log = out + ".vtklog"
    window = vtkFileOutputWindow()
    window.SetFileName(log)
    window.SetFlush(True)
    vtkOutputWindow.SetInstance(window)
    open(log, "w").close()

    reader = vtkXMLUnstructuredGridReader()
    reader.SetFileName(out)
    reader.Update()
    messages = open(log).read()
    if messages.strip():
        sys.exit("VTK reported:\n" + messages)
    grid = reader.GetOutput()
    errors = []
    if grid.GetNumberOfPoints() != int(nodes):
        errors.append(f"{grid.GetNumberOfPoints()} points, expected {nodes}")
    if grid.GetNumberOfCells() != int(tets):
        errors.append(f"{grid.GetNumberOfCells()} cells, expected {tets}")
    for i in range(grid.GetNumberOfCells()):
        if grid.GetCellType(i) != VTK_TETRA:
            errors.append(f"cell {i} has type {grid.GetCellType(i)}")
            break
    for name in ("node_id", "boundary"):
        if grid.GetPointData().GetArray(name) is None:
            errors.append(f"no point array {name}")
    if grid.GetCellData().GetArray("quality") is None:
        errors.append("no cell array quality")
    quality = vtkMeshQuality()
    quality.SetInputData(grid)
    quality.SetTetQualityMeasureToVolume()
    quality.Update()
    volumes = quality.GetOutput().GetCellData().GetArray("Quality")
    total = sum(volumes.GetValue(i) for i in range(volumes.GetNumberOfTuples()))
    if min(volumes.GetValue(i) for i in range(volumes.GetNumberOfTuples())) <= 0:
        errors.append("a tet with non-positive volume")
    if errors:
        sys.exit("; ".join(errors))
    print(f"VTK read {out}: {nodes} points, {tets} tets, volume {total}")


if __name__ == "__main__":
    main()
