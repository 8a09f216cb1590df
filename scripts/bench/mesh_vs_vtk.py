#!/usr/bin/env python3
"""bskin's outputs next to the mesh a user would otherwise make, on the project's phantoms.

For each phantom shape: `bskin phantom` writes the series, `bskin run` fits it (STL, STEP,
IGES), and the VTK peer (scripts/bench/peer_vtk.py: flying edges, windowed-sinc smoothing,
quadric decimation) meshes the same series at decimation targets from 0 to 0.99 (see DECIMATION). Every mesh is
measured against the shape's analytic surface by examples/mesh_truth.rs (distance both ways,
volume against the shape's). The peer mesh reported is the most decimated one whose maximum
distance to the truth (the larger of the two directions) is no worse than bskin's, i.e. the
smallest file a user gets at the same maximum error.

Usage: scripts/bench/mesh_vs_vtk.py [--shapes a,b] [--size N --pixel MM --slices N
       --slice-spacing MM] [--tolerance MM] [--work DIR] [--python PY]
Needs: a release build of bskin and the mesh_truth example (the script builds both with cargo),
and a Python with vtk, numpy and pydicom for the peer (--python; scripts/bench/run.sh makes
such a venv). Prints a markdown table; writes DIR/mesh_vs_vtk.json.
"""
import argparse
import json
import os
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SHAPES = ["tube-split", "tubes-crossing", "torus-standing", "torus-flat", "blobs", "tube-three"]
DECIMATION = [0.0, 0.9, 0.95, 0.98, 0.99]


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.exit(f"mesh_vs_vtk: {' '.join(cmd)} failed ({r.returncode}):\n{r.stderr}")
    return r.stdout


def measure(tool, shape, stl):
    m = json.loads(run([tool, shape, stl]))
    m["max_mm"] = max(m["mesh_to_truth_max_mm"], m["truth_to_mesh_max_mm"])
    return m


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--pixel", type=float, default=0.4)
    ap.add_argument("--slices", type=int, default=91)
    ap.add_argument("--slice-spacing", type=float, default=1.0)
    ap.add_argument("--tolerance", type=float, default=0.5)
    ap.add_argument("--work", default="/tmp/bskin-mesh-vs-vtk")
    ap.add_argument("--python", default=sys.executable)
    a = ap.parse_args()
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    run(["cargo", "build", "--release", "--quiet", "--bin", "bskin", "--example", "mesh_truth"],
        cwd=ROOT)
    bskin = os.path.join(target, "release", "bskin")
    truth = os.path.join(target, "release", "examples", "mesh_truth")
    os.makedirs(a.work, exist_ok=True)
    rows = []
    for shape in a.shapes.split(","):
        series = os.path.join(a.work, shape)
        run([bskin, "phantom", shape, "-o", series, "-q", "--size", str(a.size), "--pixel",
             str(a.pixel), "--slices", str(a.slices), "--slice-spacing", str(a.slice_spacing)])
        out = os.path.join(a.work, shape + "-bskin")
        t0 = time.perf_counter()
        run([bskin, "run", series, "-o", out, "-q", "--tolerance", str(a.tolerance)])
        t_bskin = time.perf_counter() - t0
        report = json.load(open(os.path.join(out, "report.json")))
        files = {f["name"]: f["bytes"] for f in report.get("files", [])}
        mb = measure(truth, shape, os.path.join(out, "mesh.stl"))
        mb.update(tool="bskin", seconds=round(t_bskin, 3), step_bytes=files.get("surfaces.step"),
                  iges_bytes=files.get("surfaces.igs"),
                  control_points=report.get("control_points_total"))
        peers = []
        for r in DECIMATION:
            stl = os.path.join(a.work, f"{shape}-vtk-{r}.stl")
            t0 = time.perf_counter()
            run([a.python, os.path.join(ROOT, "scripts", "bench", "peer_vtk.py"), series, "-o",
                 stl, "--reader", "pydicom", "--decimate", str(r)])
            m = measure(truth, shape, stl)
            m.update(tool=f"vtk (decimate {r})", seconds=round(time.perf_counter() - t0, 3))
            peers.append(m)
        fit = [m for m in peers if m["max_mm"] <= mb["max_mm"]]
        best = min(fit, key=lambda m: m["bytes"]) if fit else min(peers, key=lambda m: m["max_mm"])
        best["matched"] = bool(fit)
        rows.append({"shape": shape, "bskin": mb, "vtk": best, "vtk_all": peers})
        print(f"{shape}: done", file=sys.stderr)
    json.dump({"args": vars(a), "rows": rows}, open(os.path.join(a.work, "mesh_vs_vtk.json"), "w"),
              indent=1)
    print(f"phantoms {a.size}x{a.size}x{a.slices}, pixel {a.pixel} mm, slices {a.slice_spacing} mm;"
          f" bskin --tolerance {a.tolerance}")
    print("| shape | tool | triangles | STL bytes | STEP / IGES bytes | max mesh→truth / "
          "truth→mesh mm | volume error % | s |")
    print("|---|---|---|---|---|---|---|---|")
    for row in rows:
        for m in (row["bskin"], row["vtk"]):
            cad = (f"{m['step_bytes']} / {m['iges_bytes']}" if m["tool"] == "bskin" else "—")
            tool = m["tool"] + ("" if m["tool"] == "bskin" or m.get("matched") else
                                " (none as close: the closest)")
            print(f"| {row['shape']} | {tool} | {m['triangles']} | {m['bytes']} | {cad} | "
                  f"{m['mesh_to_truth_max_mm']:.3f} / {m['truth_to_mesh_max_mm']:.3f} | "
                  f"{m['volume_error_pct']:+.2f} | {m['seconds']:.2f} |")


if __name__ == "__main__":
    main()
