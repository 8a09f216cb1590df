#!/usr/bin/env python3
"""Attributes a `perf record --call-graph dwarf` profile of bskin to pipeline stages.

Usage:  perf script -i perf.data -F tid,ip,sym --no-inline | perf_stages.py --freq HZ [--top N]

Each sample's stage is decided by the first frame, from the leaf up, that belongs to one stage
(bskin::stages::sN_*, or a kernel module used by one stage only: geometry::branching/capping/
distance_map/zones -> branching, geometry::contours -> contours, bskin::dicom / codecs ->
load, bspline::fit/common_knots/... -> fitting, bspline::skinning/surface -> skinning, ...);
shared helpers (polygon, marching_squares, simplify, libm, malloc) are attributed to the
stage that called them. Samples with no stage frame are "rayon/idle" when a rayon_core frame
is present, else "other".

Prints: samples and CPU seconds per stage, the top self symbols with the stage they were
charged to, and the top self symbols of each stage.
"""
import argparse
import collections
import re
import sys

RULES = [
    (re.compile(r"bskin::stages::s1_load"), "load"),
    (re.compile(r"bskin::stages::s2_contours"), "contours"),
    (re.compile(r"bskin::stages::s3_correspondence"), "correspondence"),
    (re.compile(r"bskin::stages::s4_branching"), "branching"),
    (re.compile(r"bskin::stages::s5_alignment"), "alignment"),
    (re.compile(r"bskin::stages::s6_fitting"), "fitting"),
    (re.compile(r"bskin::stages::s7_skinning"), "skinning"),
    (re.compile(r"bskin::stages::s8_write"), "write"),
    (re.compile(r"bskin::geometry::(branching|capping|distance_map|zones)"), "branching"),
    (re.compile(r"bskin::geometry::contours"), "contours"),
    (re.compile(r"bskin::geometry::overlap"), "correspondence"),
    (re.compile(r"bskin::geometry::alignment"), "alignment"),
    (re.compile(r"bskin::bspline::(fit|common_knots|closed_curve|knot_vector|cyclic_solver)"), "fitting"),
    (re.compile(r"bskin::bspline::(skinning|surface)"), "skinning"),
    (re.compile(r"bskin::io::(stl|report)|bskin::mesh"), "write"),
    (re.compile(r"bskin::dicom::|dicom_pixeldata|dicom_parser|dicom_object|charls|jpeg|openjp2"), "load"),
    (re.compile(r"bskin::phantom"), "phantom"),
]


def classify(frames):
    for f in frames:
        for rx, stage in RULES:
            if rx.search(f):
                return stage
    if any("rayon_core" in f for f in frames):
        return "rayon/idle"
    return "other"


def samples(stream):
    tid, frames = None, []
    for line in stream:
        line = line.rstrip("\n")
        if not line.strip():
            if tid is not None:
                yield tid, frames
            tid, frames = None, []
        elif not line.startswith("\t"):
            tid, frames = line.split()[0], []
        else:
            parts = line.strip().split(None, 1)
            frames.append(parts[1] if len(parts) > 1 else "?")
    if tid is not None:
        yield tid, frames


def short(sym, n=90):
    sym = re.sub(r"<.*>", "<..>", sym) if len(sym) > n else sym
    return sym[:n]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--freq", type=float, required=True, help="perf record -F value (Hz)")
    ap.add_argument("--top", type=int, default=15)
    a = ap.parse_args()
    by_stage = collections.Counter()
    by_sym = collections.Counter()
    by_stage_sym = collections.defaultdict(collections.Counter)
    total = 0
    for tid, frames in samples(sys.stdin):
        if not frames:
            continue
        total += 1
        st = classify(frames)
        sym = short(frames[0])
        by_stage[st] += 1
        by_sym[(sym, st)] += 1
        by_stage_sym[st][sym] += 1
    print(f"{total} samples at {a.freq:g} Hz = {total / a.freq:.1f} CPU s\n")
    print("| stage | samples | % | CPU s |")
    print("|---|---:|---:|---:|")
    for st, n in by_stage.most_common():
        print(f"| {st} | {n} | {100 * n / total:.1f} | {n / a.freq:.2f} |")
    print(f"\ntop {a.top} self symbols (stage charged):\n")
    print("| % | symbol | stage |")
    print("|---:|---|---|")
    for (sym, st), n in by_sym.most_common(a.top):
        print(f"| {100 * n / total:.1f} | `{sym}` | {st} |")
    for st, _ in by_stage.most_common(6):
        print(f"\n{st}: " + "; ".join(f"{short(s, 60)} {100 * n / total:.1f}%"
                                       for s, n in by_stage_sym[st].most_common(6)))


if __name__ == "__main__":
    main()
