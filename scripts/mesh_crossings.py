#!/usr/bin/env python3
"""Where a `bskin run` mesh crosses itself: MeshLab's self-intersection selection, per surface.

In: OUT_DIR from `bskin run ... --formats stl,ply` (mesh.stl, mesh.ply for the faces of each
surface, report.json). Prints the crossing faces of the whole mesh, then per surface (most
first, the first --top): faces crossing any face, faces crossing a face of the same surface
(that surface's triangles checked alone), the surface's id, kind, control points, curves and
slices. Writes OUT_DIR/crossings.json with every surface's row. Needs trimesh, numpy and
pymeshlab (the versions .ci/run pins). Slow on big meshes: one MeshLab pass per surface.
Usage: mesh_crossings.py OUT_DIR [--top 40]
"""

import argparse
import json
import os
import re

import numpy as np
import pymeshlab
import trimesh


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--top", type=int, default=40)
    a = ap.parse_args()
    with open(os.path.join(a.out_dir, "report.json")) as f:
        report = json.load(f)
    ranges = []
    with open(os.path.join(a.out_dir, "mesh.ply"), "rb") as f:
        for line in f:
            line = line.decode("latin1").strip()
            if line == "end_header":
                break
            m = re.match(r"comment surface (\d+) faces (\d+) (\d+)", line)
            if m:
                ranges.append(tuple(int(x) for x in m.groups()))
    stl = os.path.join(a.out_dir, "mesh.stl")
    tris = np.asarray(trimesh.load(stl, force="mesh", process=False).triangles)
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(stl)
    ms.compute_selection_by_self_intersections_per_face()
    sel = ms.current_mesh().face_selection_array()
    print(f"{stl}: {len(sel)} faces, {int(sel.sum())} crossing another ({100 * sel.mean():.2f} %)")
    surfaces = {s["id"]: s for s in report["surfaces"]}
    rows = []
    for sid, first, count in ranges:
        crossing = int(sel[first : first + count].sum())
        if crossing == 0:
            continue
        t = tris[first : first + count]
        own = pymeshlab.MeshSet()
        own.add_mesh(
            pymeshlab.Mesh(vertex_matrix=t.reshape(-1, 3), face_matrix=np.arange(3 * count).reshape(-1, 3))
        )
        own.meshing_merge_close_vertices(threshold=pymeshlab.PercentageValue(0.0))
        own.compute_selection_by_self_intersections_per_face()
        s = surfaces[sid]
        rows.append(
            {
                "id": sid,
                "crossing": crossing,
                "crossing_own": int(own.current_mesh().selected_face_number()),
                "faces": count,
                "kind": s["kind"],
                "control_points": s["control_points"],
                "curves": s["curves"],
                "slices": s["slices"],
            }
        )
    rows.sort(key=lambda r: (-r["crossing"], r["id"]))
    own_total = sum(r["crossing_own"] for r in rows)
    print(f"{len(rows)} surfaces cross something; {own_total} faces cross their own surface")
    for r in rows[: a.top]:
        print(
            f"surface {r['id']:5d} {r['kind']:5s}: {r['crossing']:7d} crossing ({r['crossing_own']} own) "
            f"of {r['faces']} faces, control points {r['control_points']}, {r['curves']} curves, "
            f"slices {r['slices']}"
        )
    with open(os.path.join(a.out_dir, "crossings.json"), "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
