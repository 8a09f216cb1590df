#!/usr/bin/env python3
"""bskin's Algorithm 1 against scipy's periodic splprep on the same contours.

Setup:   pip install scipy numpy
Run:     python3 scripts/bench_kernel_peer.py [--tol 0.1] [--json /tmp/kernel_peer.json]
         (builds and runs `cargo run --release --example kernel_peer`; set CARGO_TARGET_DIR as usual)

The example writes deterministic noisy star contours (100, 1,000, 5,000 points) with bskin's
fits (control points, knots, time). For scipy, `splprep(per=1, k=3, s=s)` is run with the
smoothing factor s searched by bisection (log scale) for the fewest control points whose max
error meets the same tolerance. Both curves' max errors are measured here by the SAME method:
the true distance from every contour point to the curve, found by dense sampling (spacing
<= tol/50) then Newton refinement of the foot point. Times: bskin = one Algorithm 1 run
(median); scipy = one splprep call at the chosen s (median) and the whole s search.
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np
from scipy.interpolate import BSpline, splev, splprep
from scipy.spatial import cKDTree


def true_max_distance(points, ev, u0, u1, length, tol):
    """Max over points of the distance to the curve ev(u, der) on [u0, u1)."""
    n = max(2000, int(np.ceil(length / (tol / 50.0))))
    us = np.linspace(u0, u1, n, endpoint=False)
    samples = ev(us, 0)
    d, idx = cKDTree(samples).query(points)
    u = us[idx]
    h = (u1 - u0) / n
    best = d.copy()
    lo, hi = u - h, u + h
    for _ in range(8):
        c, c1, c2 = ev(u, 0), ev(u, 1), ev(u, 2)
        r = c - points
        g = np.sum(r * c1, axis=1)
        hess = np.sum(c1 * c1, axis=1) + np.sum(r * c2, axis=1)
        hess = np.where(hess > 1e-12, hess, np.sum(c1 * c1, axis=1) + 1e-300)
        u = np.clip(u - g / hess, lo, hi)
        dd = np.linalg.norm(ev(u, 0) - points, axis=1)
        best = np.minimum(best, dd)
    return float(best.max())


def bskin_evaluator(domain, control):
    domain = np.asarray(domain)
    n1 = len(domain) - 1
    p = float(n1)
    t = np.concatenate([domain[n1 - 3:n1] - p, domain, domain[1:4] + p])
    c = np.asarray(control)
    c = np.vstack([c, c[:3]])
    spl = BSpline(t, c, 3, extrapolate="periodic")
    return (lambda u, der: spl(np.mod(u, p), nu=der)), 0.0, p


def scipy_evaluator(tck):
    def ev(u, der):
        return np.array(splev(np.mod(u, 1.0), tck, der=der)).T
    return ev, 0.0, 1.0


def scipy_fit(points, s):
    closed = np.vstack([points, points[:1]])
    tck, _ = splprep(closed.T, per=1, k=3, s=s, quiet=1)
    return tck


def scipy_ctrl(tck):
    return len(tck[0]) - 7  # distinct control points of a periodic cubic


def search_scipy(points, tol, length):
    m = len(points)

    def err(s):
        tck = scipy_fit(points, s)
        ev, a, b = scipy_evaluator(tck)
        return true_max_distance(points, ev, a, b, length, tol), tck

    t0 = time.perf_counter()
    best = None  # (ctrl, s, err)
    lo, hi = 0.0, m * tol * tol
    e, tck = err(hi)
    grow = 0
    while e <= tol and grow < 10:
        best = min(best or (10**9, 0, 0), (scipy_ctrl(tck), hi, e))
        lo, hi = hi, hi * 4
        e, tck = err(hi)
        grow += 1
    if lo == 0.0:
        lo = hi * 1e-8
        e0, tck0 = err(lo)
        if e0 <= tol:
            best = min(best or (10**9, 0, 0), (scipy_ctrl(tck0), lo, e0))
    for _ in range(30):
        mid = np.sqrt(lo * hi)
        e, tck = err(mid)
        if e <= tol:
            best = min(best or (10**9, 0, 0), (scipy_ctrl(tck), mid, e))
            lo = mid
        else:
            hi = mid
        if hi / lo < 1.0001:
            break
    search_ms = (time.perf_counter() - t0) * 1e3
    if best is None:
        e, tck = err(0.0)
        best = (scipy_ctrl(tck), 0.0, e)
    ctrl, s, e = best
    reps = 20 if m <= 1000 else 5
    times = []
    for _ in range(reps):
        t1 = time.perf_counter()
        scipy_fit(points, s)
        times.append((time.perf_counter() - t1) * 1e3)
    return ctrl, float(np.median(times)), search_ms, e


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tol", type=float, default=0.1)
    ap.add_argument("--json", default="/tmp/kernel_peer.json")
    ap.add_argument("--no-run", action="store_true", help="reuse an existing JSON")
    a = ap.parse_args()
    if not a.no_run:
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        subprocess.run(["cargo", "run", "--release", "--quiet", "--example", "kernel_peer", "--",
                        a.json, str(a.tol)], cwd=root, check=True)
    doc = json.load(open(a.json))
    tol = doc["tolerance"]
    rows = []
    for case in doc["cases"]:
        pts = np.asarray(case["points"])
        length = float(np.sum(np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)))
        b = case["bskin"]
        ev, u0, u1 = bskin_evaluator(b["domain_knots"], b["control"])
        b_err = true_max_distance(pts, ev, u0, u1, length, tol)
        s_ctrl, s_ms, s_search, s_err = search_scipy(pts, tol, length)
        rows.append((len(pts), b["n_control"], b["ms"], b_err, b["max_error"], s_ctrl, s_ms, s_search, s_err))
    print(f"tolerance {tol} mm; errors = max true distance, measured identically for both")
    hdr = ("points", "bskin ctrl", "bskin ms", "bskin err", "(own)", "scipy ctrl", "scipy fit ms",
           "scipy search ms", "scipy err")
    print("| " + " | ".join(hdr) + " |")
    print("|" + "---|" * len(hdr))
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.2f} | {r[3]:.4f} | {r[4]:.4f} | {r[5]} | {r[6]:.2f} | {r[7]:.0f} | {r[8]:.4f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
