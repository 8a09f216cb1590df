#!/usr/bin/env python3
"""bskin pipeline benchmark: bskin next to the peers users run today, measured in the same run.

Driven by scripts/bench/run.sh (which installs the Python peers and builds bskin); it can also
be run directly:  bench.py --bskin BIN --decode BIN --python PY --work DIR [--quick] [--reps N]

What it does, per case (a generated 512x512x300 tube-split series with branching; the real
skull phantom ../shared/data/ct/philips-skull-phantom-1mm and its JPEG-LS and JPEG-lossless
copies when present), running the tools alternately, --reps times each:
  decode    examples/decode_only: scan + decode every slice with bskin::dicom (the baseline
            of the "within 2x of decoding" goal)
  contours  `bskin contours DIR -o /dev/null`  vs  peer_contours.py (pydicom + scikit-image
            find_contours + approximate_polygon, single process; --jobs 2 row in full runs)
  run       `bskin run DIR -o OUT` (mesh.stl + report.json)  vs  peer_vtk.py (VTK read ->
            flying edges -> windowed sinc -> 90 % quadric decimation -> binary STL)
and the memory-scaling check: peak RSS of `bskin run` on the 300-slice series and on the same
shape cut into 5x more slices (1,500 slices of 512x512).

Every figure is measured with /usr/bin/time (wall, user+sys CPU, max RSS of the process).
A tool whose first run takes longer than --long seconds is not repeated (said in the table).

Prints: a markdown table per case (tool, runs, wall min/median s, CPU s median, peak RSS MB
max, slices/s at median wall), the ratios bskin/peer, bskin's per-stage busy times from
OUT/report.json (timings.stages), and the memory-scaling figures. Writes everything measured
to WORK/results.json.
"""
import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
DATA = os.path.normpath(os.path.join(ROOT, "..", "shared", "data"))


def log(msg):
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def timed(cmd, stdout=subprocess.DEVNULL):
    """Runs cmd under /usr/bin/time; returns wall s, cpu s, peak RSS MB, stdout text."""
    tf = os.path.join(ARGS.work, ".time")
    full = ["/usr/bin/time", "-o", tf, "-f", "%e %U %S %M"] + cmd
    p = subprocess.run(full, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-2000:]}")
    with open(tf) as f:
        line = f.read().strip().splitlines()[-1]
    e, u, s, m = line.split()
    return {"wall": float(e), "cpu": float(u) + float(s), "user": float(u), "sys": float(s),
            "rss_mb": int(m) / 1024.0, "stdout": p.stdout}


def count_slices(d):
    n = 0
    for _, _, fs in os.walk(d):
        n += len(fs)
    return n


def phantom(name, slices, spacing):
    d = os.path.join(ARGS.work, "data", name)
    if os.path.isdir(d) and count_slices(d) == slices:
        return d
    if os.path.isdir(d):
        shutil.rmtree(d)
    cmd = [ARGS.bskin, "-q", "phantom", "tube-split", "--size", str(ARGS.size), "--pixel",
           str(ARGS.pixel), "--slices", str(slices), "--slice-spacing", str(spacing), "-o", d]
    log("generating: " + " ".join(cmd))
    subprocess.run(cmd, check=True)
    return d


def tools_for(case_dir, out_dir, full):
    """full: also the 2-process contours peer."""
    py = ARGS.python
    t = [
        ("decode (bskin::dicom)", "decode", [ARGS.decode, case_dir]),
        ("bskin contours", "contours", [ARGS.bskin, "-q", "contours", case_dir, "-o", os.devnull]),
        ("peer contours (pydicom+skimage, 1 proc)", "contours",
         [py, os.path.join(HERE, "peer_contours.py"), case_dir]),
    ]
    if full:
        t.append(("peer contours (pydicom+skimage, 2 procs)", "contours",
                  [py, os.path.join(HERE, "peer_contours.py"), case_dir, "--jobs", "2"]))
    t += [
        ("bskin run", "run", [ARGS.bskin, "-q", "run", case_dir, "-o", os.path.join(out_dir, "bskin")]),
        ("peer VTK (flying edges+sinc+decimate+STL)", "run",
         [py, os.path.join(HERE, "peer_vtk.py"), case_dir, "-o", os.path.join(out_dir, "vtk.stl")]),
    ]
    return t


def run_case(name, case_dir, full, reps):
    out_dir = os.path.join(ARGS.work, "out", name)
    os.makedirs(out_dir, exist_ok=True)
    slices = count_slices(case_dir)
    tools = tools_for(case_dir, out_dir, full)
    runs = {label: [] for label, _, _ in tools}
    extra = {}
    for rep in range(reps):
        for label, kind, cmd in tools:
            rs = runs[label]
            if rs and rs[0]["wall"] > ARGS.long:
                continue
            log(f"{name} rep {rep + 1}/{reps}: {label}")
            try:
                r = timed(cmd)
            except RuntimeError as e:
                log(f"  FAILED: {e}")
                extra.setdefault("failures", []).append(f"{label}: {str(e)[:500]}")
                continue
            rs.append(r)
            out = r.pop("stdout").strip()
            if label == "bskin run":
                with open(os.path.join(out_dir, "bskin", "report.json")) as f:
                    rep_json = json.load(f)
                r["stages"] = rep_json.get("timings", {}).get("stages")
                r["report_wall"] = rep_json.get("timings", {}).get("wall_s",
                                   rep_json.get("timings", {}).get("wall"))
                r["report_peak_rss_mb"] = rep_json.get("peak_rss_mb")
                r["surfaces"] = rep_json.get("surfaces_total")
                r["max_error_mm"] = rep_json.get("max_error_mm")
                r["tolerance_met"] = rep_json.get("tolerance_met")
            elif out:
                try:
                    extra[label] = json.loads(out.splitlines()[-1])
                except ValueError:
                    pass
            log(f"  wall {r['wall']:.2f} s, cpu {r['cpu']:.2f} s, rss {r['rss_mb']:.0f} MB")
    return {"case": name, "dir": case_dir, "slices": slices, "runs": runs, "tool_output": extra,
            "kinds": {label: kind for label, kind, _ in tools}}


def summary(rs):
    w = [r["wall"] for r in rs]
    return {"n": len(rs), "wall_min": min(w), "wall_med": statistics.median(w),
            "cpu_med": statistics.median(r["cpu"] for r in rs),
            "rss_max": max(r["rss_mb"] for r in rs)}


def print_case(c):
    print(f"\n### {c['case']}  ({c['slices']} slices, {c['dir']})\n")
    print("| tool | runs | wall min s | wall median s | CPU s (median) | peak RSS MB | slices/s |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    S = {}
    for label, rs in c["runs"].items():
        if not rs:
            continue
        s = S[label] = summary(rs)
        print(f"| {label} | {s['n']} | {s['wall_min']:.2f} | {s['wall_med']:.2f} | "
              f"{s['cpu_med']:.2f} | {s['rss_max']:.0f} | {c['slices'] / s['wall_med']:.1f} |")
    print()

    def ratio(a, b, what):
        if a in S and b in S:
            sa, sb = S[a], S[b]
            print(f"- {what}: wall (median) {sa['wall_med'] / sb['wall_med']:.2f}, "
                  f"wall (min) {sa['wall_min'] / sb['wall_min']:.2f}, "
                  f"CPU {sa['cpu_med'] / sb['cpu_med']:.2f}, RSS {sa['rss_max'] / sb['rss_max']:.2f}")
    ratio("bskin contours", "peer contours (pydicom+skimage, 1 proc)",
          "bskin contours / peer contours (1 proc)")
    ratio("bskin contours", "peer contours (pydicom+skimage, 2 procs)",
          "bskin contours / peer contours (2 procs)")
    ratio("bskin run", "peer VTK (flying edges+sinc+decimate+STL)",
          "bskin run / peer VTK (goal: wall <= 0.20)")
    ratio("bskin run", "decode (bskin::dicom)", "bskin run / decode only (goal: wall <= 2)")
    ratio("bskin contours", "decode (bskin::dicom)", "bskin contours / decode only")
    for f in c["tool_output"].get("failures", []):
        print(f"- FAILED: {f}")
    vt = c["tool_output"].get("peer VTK (flying edges+sinc+decimate+STL)")
    if vt:
        print(f"- VTK peer: reader {vt['reader']}, {vt['triangles_iso']} triangles from flying "
              f"edges, {vt['triangles']} after decimation; its steps (s, last run): {vt['seconds']}")
    br = c["runs"].get("bskin run") or []
    if br and br[-1].get("stages"):
        st = br[-1]["stages"]
        print(f"- bskin run: {br[-1].get('surfaces')} surfaces, max error "
              f"{br[-1].get('max_error_mm')} mm, tolerance met: {br[-1].get('tolerance_met')}; "
              f"report.json peak_rss_mb {br[-1].get('report_peak_rss_mb')}")
        print("\nbskin run, per-stage busy time (s) from report.json, each run:\n")
        names = [s.get("stage") for s in st]
        print("| run | wall s | " + " | ".join(names) + " |")
        print("|---|---:|" + "---:|" * len(names))
        for i, r in enumerate(br):
            vals = {s.get("stage"): s.get("busy_s", s.get("busy")) for s in r["stages"]}
            print(f"| {i + 1} | {r['wall']:.2f} | " +
                  " | ".join(f"{vals.get(n, 0):.2f}" for n in names) + " |")


def main():
    global ARGS
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bskin", required=True)
    ap.add_argument("--decode", required=True)
    ap.add_argument("--python", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--quick", action="store_true",
                    help="256x256x100 synthetic series, no real data, no 2-process peer, 5x scaling on 100 slices")
    ap.add_argument("--reps", type=int, default=None, help="runs per tool (default 3, quick 2)")
    ap.add_argument("--copy-reps", type=int, default=2,
                    help="runs per tool on the transcoded copies of the skull (default 2)")
    ap.add_argument("--long", type=float, default=120.0,
                    help="a tool whose first run takes longer than this (s) is run once")
    ap.add_argument("--no-real", action="store_true", help="skip the real skull series")
    ap.add_argument("--no-scaling", action="store_true", help="skip the 5x memory-scaling check")
    ap.add_argument("--cases", default=None,
                    help="comma list among synthetic,skull,skull-jpegls,skull-jpegll")
    ARGS = ap.parse_args()
    q = ARGS.quick
    ARGS.reps = ARGS.reps or (2 if q else 3)
    ARGS.size, ARGS.pixel = (256, 0.4) if q else (512, 0.2)
    n_syn, dz = (100, 0.9) if q else (300, 0.3)
    os.makedirs(ARGS.work, exist_ok=True)
    t_start = time.time()

    cases = [("synthetic", lambda: phantom(f"tube-split-{ARGS.size}x{n_syn}", n_syn, dz))]
    skull = os.path.join(DATA, "ct", "philips-skull-phantom-1mm")
    tr = os.path.join(DATA, "transcoded", "philips-skull-phantom-1mm")
    if not q and not ARGS.no_real:
        if os.path.isdir(skull):
            cases.append(("skull", lambda: skull))
        else:
            log(f"skipped: {skull} not found")
        for name, sub in (("skull-jpegls", "jpegls_lossless_1.2.840.10008.1.2.4.80"),
                          ("skull-jpegll", "jpeg_lossless_sv1_1.2.840.10008.1.2.4.70")):
            if os.path.isdir(os.path.join(tr, sub)):
                cases.append((name, lambda s=sub: os.path.join(tr, s)))
            else:
                log(f"skipped: {os.path.join(tr, sub)} not found")
    if ARGS.cases:
        want = ARGS.cases.split(",")
        cases = [c for c in cases if c[0] in want]

    results = {"machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                           "loadavg_start": os.getloadavg()},
               "params": {"size": ARGS.size, "pixel_mm": ARGS.pixel, "slices": n_syn,
                          "slice_spacing_mm": dz, "reps": ARGS.reps, "long_s": ARGS.long},
               "cases": []}
    for name, mk in cases:
        copy = name.startswith("skull-")
        results["cases"].append(run_case(name, mk(), full=not q and not copy,
                                         reps=min(ARGS.reps, ARGS.copy_reps) if copy else ARGS.reps))

    if not ARGS.no_scaling:
        d1 = phantom(f"tube-split-{ARGS.size}x{n_syn}", n_syn, dz)
        d5 = phantom(f"tube-split-{ARGS.size}x{5 * n_syn}", 5 * n_syn, dz / 5)
        sc = []
        for label, d in ((f"{n_syn} slices", d1), (f"{5 * n_syn} slices", d5)):
            log(f"scaling: bskin run on {label}")
            out = os.path.join(ARGS.work, "out", "scaling", label.split()[0])
            r = timed([ARGS.bskin, "-q", "run", d, "-o", out])
            r.pop("stdout")
            with open(os.path.join(out, "report.json")) as f:
                rj = json.load(f)
            r["stages"] = rj.get("timings", {}).get("stages")
            r["report_peak_rss_mb"] = rj.get("peak_rss_mb")
            r["slices"] = count_slices(d)
            sc.append((label, r))
            log(f"  wall {r['wall']:.2f} s, rss {r['rss_mb']:.0f} MB")
        results["scaling"] = sc

    results["machine"]["loadavg_end"] = os.getloadavg()
    results["total_s"] = time.time() - t_start
    with open(os.path.join(ARGS.work, "results.json"), "w") as f:
        json.dump(results, f, indent=1)

    m = results["machine"]
    print(f"\n## bskin benchmark  ({m['cpus']} CPUs, {m['platform']}; load average at start "
          f"{m['loadavg_start'][0]:.1f}, at end {m['loadavg_end'][0]:.1f}; "
          f"{ARGS.reps} runs per tool ({min(ARGS.reps, ARGS.copy_reps)} on the transcoded copies), alternated, "
          f"a tool whose first run exceeds {ARGS.long:.0f} s runs once; synthetic = bskin phantom tube-split "
          f"--size {ARGS.size} --pixel {ARGS.pixel} --slices {n_syn} --slice-spacing {dz})")
    for c in results["cases"]:
        print_case(c)
    if "scaling" in results:
        (l1, r1), (l5, r5) = results["scaling"]
        print("\n### memory scaling (bskin run, same shape, 5x more slices of the same size)\n")
        print("| series | wall s | CPU s | peak RSS MB (time) | peak_rss_mb (report.json) |")
        print("|---|---:|---:|---:|---:|")
        for l, r in results["scaling"]:
            print(f"| {l} | {r['wall']:.2f} | {r['cpu']:.2f} | {r['rss_mb']:.0f} | "
                  f"{r['report_peak_rss_mb'] or 0:.0f} |")
        print(f"\n- peak RSS growth: {100 * (r5['rss_mb'] / r1['rss_mb'] - 1):+.0f} % "
              f"(goal: < +20 %, and <= 150 MB at 300 slices)")
        names = [s.get("stage") for s in r5["stages"] or []]
        if names:
            print("- per-stage busy s, " + l1 + ": " + ", ".join(
                f"{s.get('stage')} {s.get('busy_s', s.get('busy', 0)):.2f}" for s in r1["stages"]))
            print("- per-stage busy s, " + l5 + ": " + ", ".join(
                f"{s.get('stage')} {s.get('busy_s', s.get('busy', 0)):.2f}" for s in r5["stages"]))
    print(f"\nbenchmark time: {results['total_s'] / 60:.1f} min; raw figures: "
          f"{os.path.join(ARGS.work, 'results.json')}")


if __name__ == "__main__":
    main()
