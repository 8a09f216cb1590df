#!/usr/bin/env python3
"""Check a `bskin run` output directory with an independent CAD kernel (OpenCASCADE via OCP).

In: OUT_DIR holding report.json, surfaces.step, surfaces.igs and samples.json (the latter from
`bskin run --write-samples`), and optionally mesh.stl. Checks, each file on its own:
  - it loads (STEPControl_Reader / IGESControl_Reader), transfers to faces, and the shape
    passes BRepCheck_Analyzer;
  - the number of B-spline surfaces equals report.json's surfaces_total;
  - each surface is cubic x cubic and closed in u (IsUClosed; IsUPeriodic is reported);
  - every point of samples.json, evaluated on the CAD surface at the same (u, v) (the mapping
    is the identity: the writers keep bskin's knots), lies within TOL mm of bskin's own point.
Surfaces are matched to samples by file order; if a file's order differs, each sample set is
matched to the surface that reproduces it best.
mesh.stl is only described here (trimesh: watertight, winding consistent, volume); scripts/check_mesh.py
checks it.
Exit status 0 when all checks pass, 1 otherwise. Usage: check_cad.py OUT_DIR [--tol MM]
"""

import argparse
import json
import math
import os
import sys

TOL_MM = 1e-6


def load_step(path):
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    r = STEPControl_Reader()
    if r.ReadFile(path) != IFSelect_RetDone:
        raise RuntimeError(f"STEPControl_Reader could not read {path}")
    r.TransferRoots()
    return r.OneShape()


def load_iges(path):
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.IGESControl import IGESControl_Reader

    r = IGESControl_Reader()
    if r.ReadFile(path) != IFSelect_RetDone:
        raise RuntimeError(f"IGESControl_Reader could not read {path}")
    r.TransferRoots()
    return r.OneShape()


def bspline_faces(shape):
    """The B-spline surfaces of the shape's faces, in exploration order."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineSurface
    from OCP.GeomAbs import GeomAbs_BSplineSurface
    from OCP.GeomAdaptor import GeomAdaptor_Surface
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    # OCP 8 exposes static methods without the "_s" suffix that OCP 7 used.
    to_face = getattr(TopoDS, "Face", None) or getattr(TopoDS, "Face_s")
    surface_of = getattr(BRep_Tool, "Surface_s", None) or getattr(BRep_Tool, "Surface")
    out, others = [], 0
    if shape is None or shape.IsNull():
        return out, others
    exp = TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():
        face = to_face(exp.Current())
        surf = surface_of(face)
        if GeomAdaptor_Surface(surf).GetType() == GeomAbs_BSplineSurface:
            bs = surf if isinstance(surf, Geom_BSplineSurface) else Geom_BSplineSurface.DownCast(surf)
            out.append(bs)
        else:
            others += 1
        exp.Next()
    return out, others


def deviation(surf, samples):
    worst = 0.0
    for u, v, x, y, z in samples["points"]:
        p = surf.Value(u, v)
        worst = max(worst, math.dist((p.X(), p.Y(), p.Z()), (x, y, z)))
    return worst


def check_file(label, shape, report, samples, tol):
    """Returns (ok, summary dict)."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    surfs, others = bspline_faces(shape)
    expected = report["surfaces_total"]
    failures = []
    valid = bool(BRepCheck_Analyzer(shape).IsValid()) if not shape.IsNull() else False
    if not valid:
        failures.append("BRepCheck_Analyzer: shape not valid")
    if len(surfs) != expected:
        failures.append(f"{len(surfs)} B-spline surfaces, report.json says {expected}")
    if others:
        failures.append(f"{others} faces are not B-spline surfaces")
    closed = sum(1 for s in surfs if s.IsUClosed())
    periodic = sum(1 for s in surfs if s.IsUPeriodic())
    if closed != len(surfs):
        failures.append(f"only {closed} of {len(surfs)} surfaces are closed in u")
    degrees = sorted({(s.UDegree(), s.VDegree()) for s in surfs})
    if any(d != (3, 3) for d in degrees):
        failures.append(f"degrees {degrees}, expected (3, 3)")
    max_dev = None
    if samples is not None and len(surfs) == len(samples["surfaces"]):
        devs = [deviation(s, smp) for s, smp in zip(surfs, samples["surfaces"])]
        if max(devs, default=0.0) > tol:
            # Maybe another order: match each sample set to its best surface.
            devs = [min(deviation(s, smp) for s in surfs) for smp in samples["surfaces"]]
        max_dev = max(devs, default=0.0)
        if max_dev > tol:
            bad = [i for i, d in enumerate(devs) if d > tol]
            failures.append(
                f"max deviation {max_dev:.3e} mm > {tol:g} mm on surfaces {bad[:10]}"
            )
    elif samples is not None:
        failures.append("cannot compare samples: surface counts differ")
    summary = {
        "file": label,
        "valid": valid,
        "bspline_surfaces": len(surfs),
        "expected": expected,
        "u_closed": closed,
        "u_periodic": periodic,
        "degrees": degrees,
        "max_deviation_mm": max_dev,
        "failures": failures,
    }
    return not failures, summary


def mesh_info(path):
    """What trimesh says about the STL (information only)."""
    try:
        import trimesh
    except ImportError:
        return {"error": "trimesh not installed"}
    m = trimesh.load(path, force="mesh")
    return {
        "triangles": int(len(m.faces)),
        "is_watertight": bool(m.is_watertight),
        "is_winding_consistent": bool(m.is_winding_consistent),
        "volume_mm3": float(m.volume),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--tol", type=float, default=TOL_MM, help="max deviation (mm)")
    a = ap.parse_args()
    d = a.out_dir
    with open(os.path.join(d, "report.json")) as f:
        report = json.load(f)
    samples_path = os.path.join(d, "samples.json")
    samples = None
    if os.path.exists(samples_path):
        with open(samples_path) as f:
            samples = json.load(f)
    else:
        print(f"check_cad: no {samples_path} (run with --write-samples): "
              "evaluation not compared", file=sys.stderr)

    ok = True
    results = []
    for label, name, loader in [
        ("STEP", "surfaces.step", load_step),
        ("IGES", "surfaces.igs", load_iges),
    ]:
        path = os.path.join(d, name)
        try:
            shape = loader(path)
            good, summary = check_file(label, shape, report, samples, a.tol)
        except Exception as e:  # a reader failure is a check failure, reported as such
            good, summary = False, {"file": label, "failures": [f"{type(e).__name__}: {e}"]}
        ok &= good
        results.append(summary)
        status = "ok" if good else "FAILED"
        print(f"check_cad: {label} {name}: {status}: "
              + ", ".join(f"{k}={v}" for k, v in summary.items() if k not in ("file", "failures")))
        for msg in summary["failures"]:
            print(f"check_cad:   {label}: {msg}")

    stl = os.path.join(d, "mesh.stl")
    if os.path.exists(stl):
        info = mesh_info(stl)
        print("check_cad: mesh.stl (information, not checked): "
              + ", ".join(f"{k}={v}" for k, v in info.items()))
    files = {f["name"]: f["bytes"] for f in report.get("files", [])}
    print("check_cad: files " + ", ".join(f"{k} {v} B" for k, v in files.items()))
    if samples is None:
        ok = False
    n_checks = len(results)
    passed = sum(1 for r in results if not r["failures"])
    print(f"check_cad: {passed} passed, {n_checks - passed} failed")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
