#!/usr/bin/env python3
"""End-to-end peer of the bskin benchmark (scripts/bench/run.sh): the surface pipeline most
users run today with the `vtk` Python package.

read the series -> vtkFlyingEdges3D at the threshold (HU) -> vtkWindowedSincPolyDataFilter
(20 iterations, pass band 0.1, normalised coordinates) -> vtkQuadricDecimation (target
reduction 0.9, or --decimate) -> vtkSTLWriter (binary) to OUT.

Reading (--reader): `vtk` = vtkDICOMImageReader on the directory (uncompressed transfer
syntaxes only; it applies RescaleSlope/Intercept itself: the skull phantom's scalar range comes
out as -1024..1033 HU, so the threshold is given in HU); `pydicom` = pydicom reads and sorts the
slices (by ImagePositionPatient . normal), applies the rescale, and the volume is handed to VTK
as a vtkImageData (needed for JPEG / JPEG-LS copies, which vtkDICOMImageReader cannot decode);
`auto` (default) = vtk when every file is uncompressed, else pydicom.

Needs: vtk, numpy, pydicom (+ pylibjpeg, pylibjpeg-libjpeg for compressed copies).
Prints one line of JSON on stdout: reader, triangles before/after decimation, seconds per step.
"""
import argparse
import json
import os
import sys
import time

import numpy as np
import vtk
from vtk.util import numpy_support

UNCOMPRESSED = {"1.2.840.10008.1.2", "1.2.840.10008.1.2.1", "1.2.840.10008.1.2.2"}


def read_pydicom(d):
    import pydicom
    files = [os.path.join(r, f) for r, _, fs in os.walk(d) for f in fs]
    slices = []
    for p in files:
        try:
            ds = pydicom.dcmread(p)
        except Exception:
            continue
        if "PixelData" not in ds or "ImagePositionPatient" not in ds:
            continue
        iop = np.array([float(v) for v in ds.ImageOrientationPatient])
        h = float(np.dot([float(v) for v in ds.ImagePositionPatient], np.cross(iop[:3], iop[3:])))
        hu = ds.pixel_array.astype(np.float32) * float(getattr(ds, "RescaleSlope", 1.0)) \
            + float(getattr(ds, "RescaleIntercept", 0.0))
        slices.append((h, hu, [float(v) for v in ds.PixelSpacing],
                       [float(v) for v in ds.ImagePositionPatient], iop))
    slices.sort(key=lambda s: s[0])
    vol = np.stack([s[1] for s in slices])  # (z, rows, cols)
    dz = (slices[-1][0] - slices[0][0]) / max(1, len(slices) - 1)
    dr, dc = slices[0][2]
    img = vtk.vtkImageData()
    img.SetDimensions(vol.shape[2], vol.shape[1], vol.shape[0])
    img.SetSpacing(dc, dr, dz)
    # Patient coordinates when the slices are axial (row along +x, column along +y), so the
    # mesh can be compared with bskin's in place; otherwise only z is placed.
    ipp, iop = slices[0][3], slices[0][4]
    if np.allclose(iop, [1, 0, 0, 0, 1, 0], atol=1e-6):
        img.SetOrigin(ipp[0], ipp[1], slices[0][0])
    else:
        img.SetOrigin(0.0, 0.0, slices[0][0])
    arr = numpy_support.numpy_to_vtk(vol.ravel(), deep=True, array_type=vtk.VTK_FLOAT)
    img.GetPointData().SetScalars(arr)
    del vol, slices
    return img


def all_uncompressed(d):
    import pydicom
    for r, _, fs in os.walk(d):
        for f in fs:
            try:
                ds = pydicom.dcmread(os.path.join(r, f), stop_before_pixels=True)
            except Exception:
                continue
            if str(ds.file_meta.TransferSyntaxUID) not in UNCOMPRESSED:
                return False
    return True


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--threshold", type=float, default=300.0)
    ap.add_argument("--reader", choices=["auto", "vtk", "pydicom"], default="auto")
    ap.add_argument("--decimate", type=float, default=0.9,
                    help="quadric decimation target reduction (0 = none)")
    a = ap.parse_args()
    t = {}
    t0 = time.perf_counter()
    reader = a.reader
    if reader == "auto":
        reader = "vtk" if all_uncompressed(a.dir) else "pydicom"
    if reader == "vtk":
        r = vtk.vtkDICOMImageReader()
        r.SetDirectoryName(a.dir)
        r.Update()
        img = r.GetOutput()
    else:
        img = read_pydicom(a.dir)
    t["read"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputData(img)
    fe.SetValue(0, a.threshold)
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    fe.Update()
    tris_iso = fe.GetOutput().GetNumberOfCells()
    t["flying_edges"] = time.perf_counter() - t1

    t1 = time.perf_counter()
    sm = vtk.vtkWindowedSincPolyDataFilter()
    sm.SetInputConnection(fe.GetOutputPort())
    sm.SetNumberOfIterations(20)
    sm.SetPassBand(0.1)
    sm.BoundarySmoothingOff()
    sm.FeatureEdgeSmoothingOff()
    sm.NonManifoldSmoothingOn()
    sm.NormalizeCoordinatesOn()
    sm.Update()
    t["smooth"] = time.perf_counter() - t1

    t1 = time.perf_counter()
    dec = vtk.vtkQuadricDecimation()
    dec.SetInputConnection(sm.GetOutputPort())
    dec.SetTargetReduction(a.decimate)
    dec.Update()
    tris = dec.GetOutput().GetNumberOfCells()
    t["decimate"] = time.perf_counter() - t1

    t1 = time.perf_counter()
    w = vtk.vtkSTLWriter()
    w.SetInputConnection(dec.GetOutputPort())
    w.SetFileTypeToBinary()
    w.SetFileName(a.out)
    w.Write()
    t["write"] = time.perf_counter() - t1
    t["total"] = time.perf_counter() - t0
    print(json.dumps({"reader": reader, 
                      "scalar_range": list(img.GetScalarRange()),
                      "triangles_iso": tris_iso, "triangles": tris,
                      "seconds": {k: round(v, 3) for k, v in t.items()},
                      "vtk": vtk.vtkVersion.GetVTKVersion()}))


if __name__ == "__main__":
    sys.exit(main())
