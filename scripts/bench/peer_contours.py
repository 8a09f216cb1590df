#!/usr/bin/env python3
"""Contours peer of the bskin benchmark (scripts/bench/run.sh): what `bskin contours` does, the
way a Python user does it today.

For every slice of the one series in DIR: read it with pydicom (pixel data decoded by pydicom's
own handlers or pylibjpeg for JPEG / JPEG-LS), sort slices by ImagePositionPatient . normal,
apply the modality LUT (RescaleSlope/Intercept) to get HU, skimage.measure.find_contours at the
threshold (marching squares, sub-pixel), skimage.measure.approximate_polygon at the same
tolerance as bskin's --compress-tol (0.05 mm, converted to pixels), drop contours whose area is
under --min-area mm^2 (bskin's default 4), and write the contours as one JSON line per slice to
OUT (default /dev/null), like `bskin contours -o /dev/null`.

Single process by default; --jobs N spreads slices over N processes (multiprocessing), which
is how it could be parallelised: slices are independent.

Needs: pydicom, numpy, scikit-image (+ pylibjpeg, pylibjpeg-libjpeg for compressed copies).
Prints one line of JSON on stdout: slices, contours, points, seconds.
"""
import argparse
import json
import os
import sys
import time

import numpy as np
import pydicom
from skimage.measure import approximate_polygon, find_contours


def header(path):
    try:
        ds = pydicom.dcmread(path, stop_before_pixels=True)
    except Exception:
        return None
    if "ImagePositionPatient" not in ds or "ImageOrientationPatient" not in ds:
        return None
    iop = np.array([float(v) for v in ds.ImageOrientationPatient])
    normal = np.cross(iop[:3], iop[3:])
    h = float(np.dot([float(v) for v in ds.ImagePositionPatient], normal))
    return h, path


def slice_contours(args):
    path, threshold, tol_mm, min_area = args
    ds = pydicom.dcmread(path)
    slope = float(getattr(ds, "RescaleSlope", 1.0))
    intercept = float(getattr(ds, "RescaleIntercept", 0.0))
    hu = ds.pixel_array.astype(np.float32) * slope + intercept
    dr, dc = (float(v) for v in ds.PixelSpacing)  # between rows, between columns
    tol_px = tol_mm / min(dr, dc)
    out = []
    npoints = 0
    for c in find_contours(hu, threshold):
        p = approximate_polygon(c, tolerance=tol_px)
        # shoelace area in mm^2 (rows scaled by dr, columns by dc)
        y, x = p[:, 0] * dr, p[:, 1] * dc
        area = 0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1)))
        if area < min_area:
            continue
        pts = np.round(np.column_stack([p[:, 1] * dc, p[:, 0] * dr]), 4)
        out.append(pts.tolist())
        npoints += len(pts)
    return out, npoints


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("-o", "--out", default=os.devnull)
    ap.add_argument("--threshold", type=float, default=300.0)
    ap.add_argument("--compress-tol", type=float, default=0.05)
    ap.add_argument("--min-area", type=float, default=4.0)
    ap.add_argument("--jobs", type=int, default=1)
    a = ap.parse_args()
    t0 = time.perf_counter()
    files = [os.path.join(r, f) for r, _, fs in os.walk(a.dir) for f in fs]
    heads = sorted(h for h in map(header, files) if h is not None)
    work = [(p, a.threshold, a.compress_tol, a.min_area) for _, p in heads]
    if a.jobs > 1:
        import multiprocessing as mp
        pool = mp.Pool(a.jobs)
        results = pool.imap(slice_contours, work, chunksize=4)
    else:
        results = map(slice_contours, work)
    ncont = npts = 0
    with open(a.out, "w") as f:
        for i, (contours, n) in enumerate(results):
            f.write(json.dumps({"index": i, "contours": contours}) + "\n")
            ncont += len(contours)
            npts += n
    print(json.dumps({"slices": len(work), "contours": ncont, "points": npts,
                      "seconds": round(time.perf_counter() - t0, 3), "jobs": a.jobs}))


if __name__ == "__main__":
    sys.exit(main())
