#!/usr/bin/env python3
"""Check a `bskin run` output directory's meshes with independent readers (trimesh, lib3mf).

In: OUT_DIR holding report.json and mesh.stl plus mesh.obj, mesh.ply and/or mesh.3mf (from
`bskin run --formats stl,obj,ply,3mf`). Checks:
  - each of mesh.obj and mesh.ply loads in trimesh (process=False: nothing merged or dropped),
    mesh.3mf in lib3mf (the 3MF Consortium's reader, strict mode: any spec violation fails),
    and holds the same number of triangles as mesh.stl and as report.json's surfaces;
  - its triangles are mesh.stl's, in the same order and with the same vertex order (so the
    same winding), within the STL's float32 rounding; bounds, area and signed volume agree;
  - mesh.obj names one object per surface with triangles, `surface_<id>` as in report.json;
    mesh.3mf is in millimetres, names the coordinate system in its Description, is manifold
    and oriented where welded mesh.stl is watertight, and holds one triangle set per surface
    with triangles, `surface_<id>` with its triangles in order;
  - the header comments / STL header name the coordinate system of report.json.
With --lps-dir LPS_DIR (OUT_DIR being the same input run with --ras): report.json says "RAS"
there and "LPS" in LPS_DIR, every vertex of every mesh is the LPS one with x and y negated
(exactly), and the signed volumes are equal (a rotation keeps the winding outward; a
reflection would flip their sign).
Exit status 0 when all checks pass, 1 otherwise.
Usage: check_meshes.py OUT_DIR [--lps-dir LPS_DIR]
"""

import argparse
import json
import os
import re
import sys

import numpy as np
import trimesh


def load(path):
    m = trimesh.load(path, process=False, force="mesh")
    if not isinstance(m, trimesh.Trimesh):
        raise RuntimeError(f"{path}: trimesh gave {type(m).__name__}, not a mesh")
    return m


def load_3mf(path, report, failures):
    """mesh.3mf through lib3mf in strict mode, as a trimesh (float32 coordinates, as read)."""
    import lib3mf

    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    reader = model.QueryReader("3mf")
    reader.SetStrictModeActive(True)
    reader.ReadFromFile(path)
    for i in range(reader.GetWarningCount()):
        failures.append(f"mesh.3mf: lib3mf warning {reader.GetWarning(i)}")
    if model.GetUnit() != lib3mf.ModelUnit.MilliMeter:
        failures.append(f"mesh.3mf: unit {model.GetUnit()}, not millimetres")
    meta = model.GetMetaDataGroup()
    description = " ".join(meta.GetMetaData(i).GetValue() for i in range(meta.GetMetaDataCount())
                           if meta.GetMetaData(i).GetName() == "Description")
    if f"patient {report['coordinates']}" not in description:
        failures.append(f"mesh.3mf: Description metadata does not name {report['coordinates']}")
    objects = model.GetMeshObjects()
    found = []
    while objects.MoveNext():
        found.append(objects.GetCurrentMeshObject())
    if len(found) != 1:
        raise RuntimeError(f"{path}: {len(found)} mesh objects, expected 1")
    obj = found[0]
    vertices = np.array([list(p.Coordinates) for p in obj.GetVertices()], dtype=np.float64)
    faces = np.array([list(t.Indices) for t in obj.GetTriangleIndices()], dtype=np.int64)
    # Triangle sets: one per surface with triangles, in report order, covering its range.
    want = [(f"surface_{s['id']}", s["triangles"]) for s in report["surfaces"] if s["triangles"] > 0]
    sets, first = [], 0
    for i in range(obj.GetTriangleSetCount()):
        ts = obj.GetTriangleSet(i)
        tris = list(ts.GetTriangleList())
        sets.append((ts.GetIdentifier(), len(tris)))
        if tris != list(range(first, first + len(tris))):
            failures.append(f"mesh.3mf: triangle set {ts.GetIdentifier()} is not triangles "
                            f"{first}.. in order")
        first += len(tris)
    if sets != want:
        failures.append(f"mesh.3mf: triangle sets {sets[:3]}… differ from report.json's {want[:3]}…")
    return trimesh.Trimesh(vertices, faces, process=False), obj.IsManifoldAndOriented()


def header_text(path):
    """The STL's 80-byte header, the OBJ's comment lines, or the PLY's header."""
    with open(path, "rb") as f:
        data = f.read(1 << 16)
    if path.endswith(".stl"):
        return data[:80].decode("ascii", "replace")
    if path.endswith(".ply"):
        return data[: data.index(b"end_header")].decode("ascii", "replace")
    return "\n".join(l for l in data.decode("utf-8", "replace").splitlines() if l.startswith("#"))


def check_dir(d, failures):
    with open(os.path.join(d, "report.json")) as f:
        report = json.load(f)
    cs = report["coordinates"]
    expected = sum(s["triangles"] for s in report["surfaces"])
    stl_path = os.path.join(d, "mesh.stl")
    stl = load(stl_path)
    meshes = {"stl": stl}
    if len(stl.faces) != expected:
        failures.append(f"mesh.stl: {len(stl.faces)} triangles, report.json says {expected}")
    if f"patient {cs} " not in header_text(stl_path):
        failures.append(f"mesh.stl header does not name {cs}: {header_text(stl_path)!r}")
    # mesh.stl holds no shared vertices: welded by coordinates it is closed or not, and the
    # indexed formats must be the same as written, with no welding by the reader.
    stl_closed = trimesh.load(stl_path, force="mesh").is_watertight
    scale = max(1.0, float(np.abs(stl.vertices).max()))
    atol = 4 * np.finfo(np.float32).eps * scale
    for ext in ("obj", "ply", "3mf"):
        path = os.path.join(d, f"mesh.{ext}")
        if not os.path.exists(path):
            continue
        if ext == "3mf":
            m, oriented = load_3mf(path, report, failures)
            if oriented != stl_closed:
                failures.append(f"mesh.3mf: lib3mf manifold and oriented {oriented}, mesh.stl "
                                f"welded watertight {stl_closed}")
        else:
            m = load(path)
        meshes[ext] = m
        name = f"mesh.{ext}"
        if len(m.faces) != len(stl.faces):
            failures.append(f"{name}: {len(m.faces)} triangles, mesh.stl {len(stl.faces)}")
            continue
        dev = float(np.abs(m.triangles - stl.triangles).max()) if len(m.faces) else 0.0
        if dev > atol:
            failures.append(f"{name}: triangles differ from mesh.stl by {dev} mm (> {atol})")
        bdev = float(np.abs(m.bounds - stl.bounds).max()) if len(m.faces) else 0.0
        if bdev > atol:
            failures.append(f"{name}: bounds differ from mesh.stl by {bdev} mm")
        for what, a, b in [("area", m.area, stl.area), ("signed volume", m.volume, stl.volume)]:
            if abs(a - b) > 1e-5 * max(1.0, abs(b)):
                failures.append(f"{name}: {what} {a} vs mesh.stl {b}")
        if ext != "3mf" and f"patient {cs}" not in header_text(path):
            failures.append(f"{name}: header does not name {cs}")
        if m.is_watertight != stl_closed:
            failures.append(f"{name}: watertight {m.is_watertight} as written, mesh.stl welded "
                            f"{stl_closed}")
        print(f"check_meshes: {d}/{name}: {len(m.faces)} triangles, {len(m.vertices)} vertices, "
              f"max deviation from mesh.stl {dev:.3g} mm, volume {m.volume:.6g} mm3 "
              f"(stl {stl.volume:.6g}), watertight {m.is_watertight}")
    obj_path = os.path.join(d, "mesh.obj")
    if os.path.exists(obj_path):
        with open(obj_path) as f:
            names = [l.split()[1] for l in f if l.startswith("o ")]
        want = [f"surface_{s['id']}" for s in report["surfaces"] if s["triangles"] > 0]
        if names != want:
            failures.append(f"mesh.obj objects {names[:5]}… differ from report.json's {want[:5]}…")
    return report, meshes


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--lps-dir", help="the same run without --ras, to compare coordinates")
    a = ap.parse_args()
    failures = []
    report, meshes = check_dir(a.out_dir, failures)
    if len(meshes) == 1:
        failures.append("no mesh.obj, mesh.ply or mesh.3mf to check")
    if a.lps_dir:
        lps_report, lps_meshes = check_dir(a.lps_dir, failures)
        if (report["coordinates"], lps_report["coordinates"]) != ("RAS", "LPS"):
            failures.append(f"coordinates {report['coordinates']} / {lps_report['coordinates']},"
                            " expected RAS / LPS")
        flip = np.array([-1.0, -1.0, 1.0])
        for ext, m in meshes.items():
            l = lps_meshes.get(ext)
            if l is None:
                failures.append(f"mesh.{ext} missing in {a.lps_dir}")
                continue
            if m.triangles.shape != l.triangles.shape or not np.array_equal(m.triangles,
                                                                            l.triangles * flip):
                failures.append(f"mesh.{ext}: RAS triangles are not the LPS ones with x, y negated")
            if abs(m.volume - l.volume) > 1e-9 * max(1.0, abs(l.volume)):
                failures.append(f"mesh.{ext}: signed volume {m.volume} (RAS) vs {l.volume} (LPS)")
        print(f"check_meshes: RAS vs LPS: {len(meshes)} meshes compared, signed volume "
              f"{meshes['stl'].volume:.6g} / {lps_meshes['stl'].volume:.6g} mm3")
    for msg in failures:
        print(f"check_meshes: FAILED: {msg}")
    print(f"check_meshes: {'ok' if not failures else f'{len(failures)} failure(s)'}")
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main())
