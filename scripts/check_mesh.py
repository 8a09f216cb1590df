#!/usr/bin/env python3
"""Check a `bskin run` mesh with independent mesh libraries (trimesh, and MeshLab's pymeshlab).

In: OUT_DIR/mesh.stl, and optionally TRUTH.json from `bskin phantom ... --truth TRUTH.json`
(the analytic shape's volume). Checks:
  - the mesh is watertight (every edge shared by exactly two faces, after trimesh merges
    identical vertices) and its winding is consistent;
  - its volume is positive (normals point outwards);
  - with --truth: the volume is within --volume-tol (relative, default 0.01) of the analytic one;
  - with --self-intersections: no two faces intersect, other than along the edge or at the
    vertex they share (MeshLab's per-face self-intersection selection, after pymeshlab merges
    identical vertices on loading the STL), and report.json's own count (mesh.crossing_faces)
    agrees that there are none or that there are some.
Prints one line of figures. Exit status 0 when all checks pass, 1 otherwise.
Usage: check_mesh.py OUT_DIR [--truth TRUTH.json] [--volume-tol 0.01] [--self-intersections]
"""

import argparse
import json
import os
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--truth", help="JSON with volume_mm3 (bskin phantom --truth)")
    ap.add_argument("--volume-tol", type=float, default=0.01)
    ap.add_argument("--self-intersections", action="store_true")
    a = ap.parse_args()

    import trimesh

    path = os.path.join(a.out_dir, "mesh.stl")
    mesh = trimesh.load(path, force="mesh")
    failures = []
    if not mesh.is_watertight:
        failures.append("not watertight")
    if not mesh.is_winding_consistent:
        failures.append("winding not consistent")
    volume = float(mesh.volume)
    if not volume > 0:
        failures.append(f"volume {volume:.1f} mm³ not positive (normals inwards?)")
    line = (
        f"{path}: {len(mesh.faces)} triangles, {os.path.getsize(path)} bytes, "
        f"watertight {mesh.is_watertight}, winding consistent {mesh.is_winding_consistent}, "
        f"volume {volume:.1f} mm³"
    )
    if a.truth:
        with open(a.truth) as f:
            truth = json.load(f)
        expected = float(truth["volume_mm3"])
        rel = (volume - expected) / expected
        line += f" vs {truth.get('shape', 'truth')} {expected:.1f} mm³ ({100 * rel:+.2f} %)"
        if abs(rel) > a.volume_tol:
            failures.append(
                f"volume off by {100 * rel:+.2f} % (allowed ±{100 * a.volume_tol:.2f} %)"
            )
    if a.self_intersections:
        import pymeshlab

        ms = pymeshlab.MeshSet()
        ms.load_new_mesh(path)
        ms.compute_selection_by_self_intersections_per_face()
        crossing = ms.current_mesh().selected_face_number()
        line += f", {crossing} self-intersecting faces"
        if crossing:
            failures.append(f"{crossing} faces intersect other faces")
        # bskin's own search (report.json, version 6 on) must not call clean what MeshLab
        # does not, nor the other way round.
        with open(os.path.join(a.out_dir, "report.json")) as f:
            own = (json.load(f).get("mesh") or {}).get("crossing_faces")
        line += f" (report.json: {own})"
        if own is not None and (own == 0) != (crossing == 0):
            failures.append(f"report.json counts {own} crossing faces, MeshLab {crossing}")
    print(line)
    for f in failures:
        print(f"FAIL: {f}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
