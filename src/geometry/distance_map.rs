//! Exact Euclidean distance maps of polygon sets on a raster (the paper's "discrete distance
//! map", computed by a linear-time distance/feature transform instead of rendering cones).
//!
//! In: a [`Grid`] (sample `(row, col)` sits at `origin + (col, row) · cell_mm`, in mm) and closed
//! polygons in the same mm frame. Out: per-sample unsigned or signed distances (mm, `f32`,
//! negative inside by the even–odd rule); for a set of contours, the nearest, second and third
//! nearest contour at every sample ([`nearest_contours`], from which zones and bisecting edges
//! follow); and the raw transform [`distance_transform`] (squared distance and nearest site)
//! of any sampled function.
//!
//! How the sub-pixel accuracy is obtained: samples within [`SEED_BAND_CELLS`] of a polygon are
//! seeded with their exact squared distance to its segments; the Felzenszwalb–Huttenlocher
//! lower envelope of `f(site) + |x − site|²` then picks, for every sample, a seed near the true
//! foot point (not exactly: a seed a few cells to the side can win by sitting deeper in the
//! band, which alone would leave errors of half a cell at depth); finally the distance is
//! re-evaluated exactly, walking from that seed's segment along its polygon while the distance
//! decreases, which reaches the true foot point; a forward and a backward raster sweep
//! (8SSEDT-like) then pass better segments between neighbouring samples, which fixes the bands
//! near bisectors where the seed fell on the wrong part of the boundary and the local minima of
//! wiggly contours. Measured against a brute-force distance on random star polygons the error is at the level of the f32 storage (5e-6 cell); on noisy
//! (wiggly but simple) polygons a few isolated samples keep a foot point on a neighbouring
//! wiggle, up to 0.06 cell (see the tests).
//!
//! The walk and the sweeps are most of the cost, and a caller rarely needs exact values
//! everywhere: [`SeedField`] stops after the transform (every sample gets the exact distance
//! to its seed's segment: never below the true distance, above it by less than 2.5 cells),
//! and [`nearest_contours_within`] walks and sweeps only the samples of a mask the caller
//! builds from it (branching: where `∂M_t` can pass and around zone boundaries; capping:
//! near the boundary, the ridge and the deepest samples). Outside the mask values are the
//! seed distances, with exact signs.
//!
//! Invariants: deterministic (rayon only splits independent rows/columns), no panics on any
//! finite input; distances are never below the exact distance by more than rounding, since
//! each is the exact distance to some boundary segment.

use rayon::prelude::*;

use super::polygon::{bbox, dist, Point};
use super::GeometryError;

/// Samples closer than this (in cells) to a polygon are seeds of the transform.
pub const SEED_BAND_CELLS: f64 = 1.5;

/// No site: returned as the feature of samples when the input function has no finite value.
pub const NO_SITE: u32 = u32::MAX;

/// A raster in the common plane frame: `width × height` samples, row-major.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// World position of sample (0, 0), mm.
    pub origin: Point,
    /// Sample spacing, mm.
    pub cell_mm: f64,
    pub width: usize,
    pub height: usize,
}

impl Grid {
    /// The grid covering `bbox = [min_x, min_y, max_x, max_y]` with `margin_cells` samples to
    /// spare on every side. Fails on a non-finite box or a non-positive cell, and when the
    /// raster would exceed `max_cells` samples (the caller decides whether to coarsen).
    pub fn covering(
        bbox: [f64; 4],
        cell_mm: f64,
        margin_cells: usize,
        max_cells: usize,
    ) -> Result<Grid, GeometryError> {
        if !(cell_mm.is_finite() && cell_mm > 0.0) {
            return Err(GeometryError::InvalidParameter(format!(
                "raster cell must be a positive number of mm, got {cell_mm}"
            )));
        }
        if bbox.iter().any(|v| !v.is_finite()) || bbox[2] < bbox[0] || bbox[3] < bbox[1] {
            return Err(GeometryError::NonFinite(format!(
                "bounding box {bbox:?} is not a finite box"
            )));
        }
        let m = margin_cells as f64;
        let w = ((bbox[2] - bbox[0]) / cell_mm).ceil() + 2.0 * m + 1.0;
        let h = ((bbox[3] - bbox[1]) / cell_mm).ceil() + 2.0 * m + 1.0;
        if w * h > max_cells as f64 {
            return Err(GeometryError::RasterTooLarge(format!(
                "{w} × {h} samples at {cell_mm} mm exceed the cap of {max_cells}"
            )));
        }
        Ok(Grid {
            origin: [bbox[0] - m * cell_mm, bbox[1] - m * cell_mm],
            cell_mm,
            width: w as usize,
            height: h as usize,
        })
    }

    pub fn len(&self) -> usize {
        self.width * self.height
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// World position of sample `(row, col)`.
    pub fn point(&self, row: usize, col: usize) -> Point {
        [
            self.origin[0] + col as f64 * self.cell_mm,
            self.origin[1] + row as f64 * self.cell_mm,
        ]
    }

    /// Raster (pixel) coordinates `[col, row]` of a world point, as `iso_loops` uses them.
    pub fn to_pixel(&self, p: Point) -> Point {
        [
            (p[0] - self.origin[0]) / self.cell_mm,
            (p[1] - self.origin[1]) / self.cell_mm,
        ]
    }

    /// World point of raster coordinates `[col, row]` (the inverse of [`Grid::to_pixel`]).
    pub fn to_world(&self, p: Point) -> Point {
        [
            self.origin[0] + p[0] * self.cell_mm,
            self.origin[1] + p[1] * self.cell_mm,
        ]
    }
}

/// One-dimensional lower envelope of the parabolas `f(p) + (q − p)²` (Felzenszwalb &
/// Huttenlocher 2012, Algorithm 1), over the sites `p` where `f` is finite. Writes the
/// minimum and its site for every `q`; `NO_SITE` and `+∞` when there is no site.
fn envelope_1d(f: &[f64], d: &mut [f64], site: &mut [u32], v: &mut Vec<usize>, z: &mut Vec<f64>) {
    v.clear();
    z.clear();
    for (q, &fq) in f.iter().enumerate() {
        if !fq.is_finite() {
            continue;
        }
        let qf = q as f64;
        // Drop the parabolas that the new one hides entirely.
        let mut s = f64::NEG_INFINITY;
        while let Some(&p) = v.last() {
            let pf = p as f64;
            s = ((fq + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf));
            if let Some(&zl) = z.last() {
                if s <= zl {
                    v.pop();
                    z.pop();
                    s = f64::NEG_INFINITY;
                    continue;
                }
            }
            break;
        }
        v.push(q);
        z.push(s);
    }
    if v.is_empty() {
        d.fill(f64::INFINITY);
        site.fill(NO_SITE);
        return;
    }
    let mut j = 0;
    for q in 0..f.len() {
        let qf = q as f64;
        while j + 1 < v.len() && z[j + 1] < qf {
            j += 1;
        }
        let p = v[j];
        let dq = qf - p as f64;
        d[q] = dq * dq + f[p];
        site[q] = p as u32;
    }
}

/// Exact 2-D distance transform of a sampled function, in cell units: for every sample `x`,
/// `min over sites s of f(s) + |x − s|²` and the flat index of a minimising site (`f` is `+∞`
/// where there is no site). Linear time: one envelope pass per column, then one per row.
pub fn distance_transform(f: &[f64], width: usize, height: usize) -> (Vec<f64>, Vec<u32>) {
    let feature = feature_transform(f, width, height);
    let d2 = feature
        .iter()
        .enumerate()
        .map(|(k, &s)| {
            if s == NO_SITE {
                return f64::INFINITY;
            }
            let s = s as usize;
            let dr = (k / width) as f64 - (s / width) as f64;
            let dc = (k % width) as f64 - (s % width) as f64;
            f[s] + dr * dr + dc * dc
        })
        .collect();
    (d2, feature)
}

/// The minimising site of [`distance_transform`] alone (flat index, `NO_SITE` when `f` has no
/// finite value), without materialising the distances.
fn feature_transform(f: &[f64], width: usize, height: usize) -> Vec<u32> {
    let (w, h) = (width, height);
    if f.len() != w * h || w == 0 || h == 0 {
        return vec![NO_SITE; f.len()];
    }
    // Pass 1, along columns, written column-major so pass 2 can split rows freely. Both
    // passes work on bands of `BLOCK` columns (rows) so the transposing reads stay in cache.
    const BLOCK: usize = 16;
    let mut g_t = vec![0.0f64; w * h];
    let mut row_t = vec![0u32; w * h];
    g_t.par_chunks_mut(h * BLOCK)
        .zip(row_t.par_chunks_mut(h * BLOCK))
        .enumerate()
        .for_each_init(
            || (vec![0.0; h * BLOCK], Vec::new(), Vec::new()),
            |(cols, v, z), (b, (g, rows))| {
                let c0 = b * BLOCK;
                let n = g.len() / h;
                for r in 0..h {
                    for (i, &x) in f[r * w + c0..r * w + c0 + n].iter().enumerate() {
                        cols[i * h + r] = x;
                    }
                }
                for i in 0..n {
                    let span = i * h..(i + 1) * h;
                    envelope_1d(
                        &cols[span.clone()],
                        &mut g[span.clone()],
                        &mut rows[span],
                        v,
                        z,
                    );
                }
            },
        );
    // Pass 2, along rows.
    let mut feature = vec![NO_SITE; w * h];
    feature.par_chunks_mut(w * BLOCK).enumerate().for_each_init(
        || {
            (
                vec![0.0; w * BLOCK],
                vec![0.0; w],
                vec![0u32; w],
                Vec::new(),
                Vec::new(),
            )
        },
        |(rows, d, cols, v, z), (b, feat)| {
            let r0 = b * BLOCK;
            let n = feat.len() / w;
            for c in 0..w {
                for (i, &x) in g_t[c * h + r0..c * h + r0 + n].iter().enumerate() {
                    rows[i * w + c] = x;
                }
            }
            for i in 0..n {
                let r = r0 + i;
                envelope_1d(&rows[i * w..(i + 1) * w], d, cols, v, z);
                for c in 0..w {
                    let sc = cols[c];
                    feat[i * w + c] = if sc == NO_SITE {
                        NO_SITE
                    } else {
                        let sr = row_t[sc as usize * h + r];
                        if sr == NO_SITE {
                            NO_SITE
                        } else {
                            sr * w as u32 + sc
                        }
                    };
                }
            }
        },
    );
    feature
}

/// The segments of a polygon set, flattened, with their geometry precomputed for the inner
/// loops (start, direction, inverse squared length) and each segment's polygon so its
/// neighbours along the polygon can be found without a division.
struct Segments {
    /// Start point, direction `b − a`, and `1 / |b − a|²` (0 for a zero-length segment).
    geom: Vec<(Point, Point, f64)>,
    /// Polygon of each segment.
    poly: Vec<u32>,
    /// Global index of each polygon's first segment, and one past the last.
    first: Vec<usize>,
}

impl Segments {
    fn new(polys: &[&[Point]]) -> Self {
        let total: usize = polys.iter().map(|p| p.len()).sum();
        let mut geom = Vec::with_capacity(total);
        let mut poly = Vec::with_capacity(total);
        let mut first = Vec::with_capacity(polys.len() + 1);
        for (k, p) in polys.iter().enumerate() {
            first.push(geom.len());
            for i in 0..p.len() {
                let (a, b) = (p[i], p[(i + 1) % p.len()]);
                let d = [b[0] - a[0], b[1] - a[1]];
                let len2 = d[0] * d[0] + d[1] * d[1];
                geom.push((a, d, if len2 > 0.0 { 1.0 / len2 } else { 0.0 }));
                poly.push(k as u32);
            }
        }
        first.push(geom.len());
        Segments { geom, poly, first }
    }

    fn len(&self) -> usize {
        self.geom.len()
    }

    /// End points of segment `s`.
    fn ends(&self, s: usize) -> (Point, Point) {
        let (a, d, _) = self.geom[s];
        (a, [a[0] + d[0], a[1] + d[1]])
    }

    /// Squared distance from `x` to segment `s`.
    #[inline]
    fn dist_sq(&self, x: Point, s: usize) -> f64 {
        let (a, d, inv) = self.geom[s];
        let v = [x[0] - a[0], x[1] - a[1]];
        let t = ((v[0] * d[0] + v[1] * d[1]) * inv).clamp(0.0, 1.0);
        let e = [v[0] - t * d[0], v[1] - t * d[1]];
        e[0] * e[0] + e[1] * e[1]
    }

    /// Exact distance from `x` to the boundary near segment `s`, and the segment realising
    /// it: starting at `s`, walk along the polygon both ways while the distance decreases.
    /// The nearest seed is only nearly right (a grid seed a few cells to the side of the true
    /// foot point can win the envelope by sitting slightly deeper in the band), but it lies in
    /// the basin of the true foot point, where the distance along the contour is unimodal.
    fn descend(&self, x: Point, s: usize) -> (f64, usize) {
        let k = self.poly[s] as usize;
        let (lo, hi) = (self.first[k], self.first[k + 1]);
        let next = |j: usize| if j + 1 == hi { lo } else { j + 1 };
        let prev = |j: usize| if j == lo { hi - 1 } else { j - 1 };
        let start = self.dist_sq(x, s);
        let mut best = (start, s);
        for forward in [true, false] {
            let (mut j, mut d) = (s, start);
            for _ in lo..hi {
                let nj = if forward { next(j) } else { prev(j) };
                let nd = self.dist_sq(x, nj);
                if nd >= d {
                    break;
                }
                j = nj;
                d = nd;
            }
            if d < best.0 {
                best = (d, j);
            }
        }
        (best.0.sqrt(), best.1)
    }
}

/// Squared distance from `p` to the segment `a`–`b`.
#[inline]
fn segment_distance_sq(p: Point, a: Point, b: Point) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let v = [p[0] - a[0], p[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        ((v[0] * d[0] + v[1] * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let e = [v[0] - t * d[0], v[1] - t * d[1]];
    e[0] * e[0] + e[1] * e[1]
}

/// Whether all samples of the 3 × 3 neighbourhood of `(r, c)` carry the same label.
#[inline]
fn uniform(label: &[u32], r: usize, c: usize, w: usize, h: usize) -> bool {
    let own = label[r * w + c];
    if r > 0 && c > 0 && r + 1 < h && c + 1 < w {
        // Interior: three rows of three, without the clamping.
        let k = r * w + c;
        return [k - w - 1, k - 1, k + w - 1]
            .iter()
            .all(|&s| label[s..s + 3].iter().all(|&l| l == own));
    }
    let (r0, r1) = (r.saturating_sub(1), (r + 1).min(h - 1));
    let (c0, c1) = (c.saturating_sub(1), (c + 1).min(w - 1));
    (r0..=r1).all(|nr| label[nr * w + c0..=nr * w + c1].iter().all(|&l| l == own))
}

/// The 8-neighbourhood of sample `(r, c)` inside a `w × h` raster.
pub(crate) fn neighbours(
    r: usize,
    c: usize,
    w: usize,
    h: usize,
) -> impl Iterator<Item = (usize, usize)> {
    let rows = r.saturating_sub(1)..=(r + 1).min(h - 1);
    rows.flat_map(move |nr| {
        let cols = c.saturating_sub(1)..=(c + 1).min(w - 1);
        cols.map(move |nc| (nr, nc))
    })
    .filter(move |&(nr, nc)| (nr, nc) != (r, c))
}

/// One sweep of feature propagation in the manner of Danielsson's 8SSEDT: rows in order
/// (top to bottom when `forward`), each scanned one way against the four neighbours already
/// visited, then back against its other side. Every sample tries its neighbours' segments and
/// keeps any that is nearer. This moves the right foot point into the samples where the
/// envelope's choice and the walk along the contour stopped short: across bisectors between
/// distant parts of the boundary, and out of the local minima of wiggly contours.
fn sweep(
    grid: &Grid,
    segs: &Segments,
    dist: &mut [f64],
    seg: &mut [u32],
    forward: bool,
    exact: Option<&[bool]>,
) {
    let wanted = |k: usize| exact.is_none_or(|m| m[k]);
    let (w, h) = (grid.width as i64, grid.height as i64);
    let first: [(i64, i64); 4] = if forward {
        [(0, -1), (-1, -1), (-1, 0), (-1, 1)]
    } else {
        [(0, 1), (1, 1), (1, 0), (1, -1)]
    };
    // Try the segment of sample `n` at sample `k` (position `x`): one exact evaluation in
    // squared distance decides; walk on only from a segment that is nearer.
    let mut try_from = |k: usize, n: usize, x: Point| {
        let t = seg[n];
        if t == NO_SITE || t == seg[k] {
            return;
        }
        let d = dist[k];
        if segs.dist_sq(x, t as usize) < d * d {
            let (d, best) = segs.descend(x, t as usize);
            dist[k] = d;
            seg[k] = best as u32;
        }
    };
    for rr in 0..h {
        let r = if forward { rr } else { h - 1 - rr };
        for cc in 0..w {
            let c = if forward { cc } else { w - 1 - cc };
            let k = (r * w + c) as usize;
            if !wanted(k) {
                continue;
            }
            let x = grid.point(r as usize, c as usize);
            for (or, oc) in first {
                let (nr, nc) = (r + or, c + oc);
                if nr >= 0 && nc >= 0 && nr < h && nc < w {
                    try_from(k, (nr * w + nc) as usize, x);
                }
            }
        }
        // Back along the row against the other side.
        let oc = if forward { 1 } else { -1 };
        for cc in 0..w {
            let c = if forward { w - 1 - cc } else { cc };
            let nc = c + oc;
            if nc >= 0 && nc < w && wanted((r * w + c) as usize) {
                let x = grid.point(r as usize, c as usize);
                try_from((r * w + c) as usize, (r * w + nc) as usize, x);
            }
        }
    }
}

/// Check that every polygon has at least 3 finite points.
pub fn validate_polygons(polys: &[&[Point]], what: &str) -> Result<(), GeometryError> {
    for (k, p) in polys.iter().enumerate() {
        if p.len() < 3 {
            return Err(GeometryError::Degenerate(format!(
                "{what} {k} has {} points, at least 3 are needed",
                p.len()
            )));
        }
        if let Some(i) = p
            .iter()
            .position(|q| !(q[0].is_finite() && q[1].is_finite()))
        {
            return Err(GeometryError::NonFinite(format!(
                "{what} {k}, point {i} is {:?}",
                p[i]
            )));
        }
    }
    Ok(())
}

/// Bounding box of a set of polygons.
pub fn bbox_of(polys: &[&[Point]]) -> [f64; 4] {
    polys.iter().fold(
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ],
        |b, p| {
            let q = bbox(p);
            [
                b[0].min(q[0]),
                b[1].min(q[1]),
                b[2].max(q[2]),
                b[3].max(q[3]),
            ]
        },
    )
}

/// Unsigned distance (mm) from every sample to the nearest boundary of the polygon set.
/// Samples are `+∞` only when the set has no segment.
pub fn unsigned_distance(grid: &Grid, polys: &[&[Point]]) -> Vec<f32> {
    let segs = Segments::new(polys);
    let (dist, _) = distance_and_segment(grid, &segs);
    dist.iter().map(|&d| d as f32).collect()
}

/// Exact distance (mm) from every sample to the set's boundary, and the global index of the
/// segment realising it (`NO_SITE` when the set has no segment).
fn distance_and_segment(grid: &Grid, segs: &Segments) -> (Vec<f64>, Vec<u32>) {
    let (mut dist, mut seg) = seed_distance_and_segment(grid, segs);
    refine(grid, segs, &mut dist, &mut seg, None);
    (dist, seg)
}

/// The first, cheap stage of [`distance_and_segment`]: every sample gets the exact distance to
/// the segment of the seed the feature transform chose for it. That is the distance to some
/// segment, so never below the true distance, and above it by about a cell at most (the seed
/// lies within [`SEED_BAND_CELLS`] of a foot point near the true one).
fn seed_distance_and_segment(grid: &Grid, segs: &Segments) -> (Vec<f64>, Vec<u32>) {
    let (w, h, cell) = (grid.width, grid.height, grid.cell_mm);
    // Seeds: exact squared distance in cell² units, and the segment that realises it.
    let mut f = vec![f64::INFINITY; w * h];
    let mut seg_of = vec![NO_SITE; w * h];
    let band = SEED_BAND_CELLS * cell;
    for s in 0..segs.len() {
        let (a, b) = segs.ends(s);
        // Long segments are walked in pieces about one cell long, so the visited boxes hug
        // the segment instead of covering its whole bounding box.
        let len = dist(a, b);
        let pieces = ((len / cell).ceil() as usize).clamp(1, 1 << 24);
        for piece in 0..pieces {
            let t0 = piece as f64 / pieces as f64;
            let t1 = (piece + 1) as f64 / pieces as f64;
            let p0 = [a[0] + t0 * (b[0] - a[0]), a[1] + t0 * (b[1] - a[1])];
            let p1 = [a[0] + t1 * (b[0] - a[0]), a[1] + t1 * (b[1] - a[1])];
            let lo = grid.to_pixel([p0[0].min(p1[0]) - band, p0[1].min(p1[1]) - band]);
            let hi = grid.to_pixel([p0[0].max(p1[0]) + band, p0[1].max(p1[1]) + band]);
            let c0 = lo[0].ceil().max(0.0) as usize;
            let r0 = lo[1].ceil().max(0.0) as usize;
            let c1 = (hi[0].floor().min(w as f64 - 1.0)).max(-1.0);
            let r1 = (hi[1].floor().min(h as f64 - 1.0)).max(-1.0);
            if c1 < 0.0 || r1 < 0.0 {
                continue;
            }
            for r in r0..=r1 as usize {
                for c in c0..=c1 as usize {
                    let d2 = segment_distance_sq(grid.point(r, c), a, b) / (cell * cell);
                    if d2 < f[r * w + c] {
                        f[r * w + c] = d2;
                        seg_of[r * w + c] = s as u32;
                    }
                }
            }
        }
    }
    let feature = feature_transform(&f, w, h);
    let mut dist = vec![f64::INFINITY; w * h];
    let mut seg = vec![NO_SITE; w * h];
    dist.par_chunks_mut(w)
        .zip(seg.par_chunks_mut(w))
        .enumerate()
        .for_each(|(r, (drow, srow))| {
            for c in 0..w {
                let site = feature[r * w + c];
                if site == NO_SITE || seg_of[site as usize] == NO_SITE {
                    continue;
                }
                let s = seg_of[site as usize];
                drow[c] = segs.dist_sq(grid.point(r, c), s as usize).sqrt();
                srow[c] = s;
            }
        });
    (dist, seg)
}

/// The second stage of [`distance_and_segment`], at the samples of `exact` (all when `None`):
/// walk from the seed's segment to the true foot point, then sweep better segments in from
/// the neighbours. Samples outside `exact` keep their seed distance.
fn refine(grid: &Grid, segs: &Segments, dist: &mut [f64], seg: &mut [u32], exact: Option<&[bool]>) {
    let w = grid.width;
    dist.par_chunks_mut(w)
        .zip(seg.par_chunks_mut(w))
        .enumerate()
        .for_each(|(r, (drow, srow))| {
            for c in 0..w {
                if srow[c] == NO_SITE || exact.is_some_and(|m| !m[r * w + c]) {
                    continue;
                }
                let (d, s) = segs.descend(grid.point(r, c), srow[c] as usize);
                drow[c] = d;
                srow[c] = s as u32;
            }
        });
    sweep(grid, segs, dist, seg, true, exact);
    sweep(grid, segs, dist, seg, false, exact);
}

/// For every sample, the distances to the nearest, second and third nearest contours of a set
/// (each contour a polygon of `polys`), with the labels (indices into `polys`) of the first
/// two. `min1` is signed (negative inside the nearest contour, even–odd) when `signed`;
/// `min2`, `min3` are unsigned.
///
/// One distance transform for the whole set, not one per contour: the nearest contour comes
/// with the feature transform, and the second and third are only needed where zones meet,
/// which is where a sample's 3 × 3 neighbourhood holds other labels; there they are
/// evaluated exactly from the neighbours' segments. Elsewhere `min2` and `min3` are `+∞`
/// ("far"). Every grid edge crossed by a bisecting edge has ends of different labels, so
/// both ends get exact values.
pub struct NearestContours {
    pub min1: Vec<f32>,
    pub label1: Vec<u32>,
    pub min2: Vec<f32>,
    pub label2: Vec<u32>,
    pub min3: Vec<f32>,
}

/// The [`NearestContours`] of the polygon set on the grid (labels are indices into `polys`,
/// [`NO_SITE`] where none).
pub fn nearest_contours(grid: &Grid, polys: &[&[Point]], signed: bool) -> NearestContours {
    nearest_contours_within(grid, SeedField::new(grid, polys, signed), None)
}

/// The cheap first stage of a distance map (see [`SeedField`]), from which a caller decides
/// where it needs exact values before paying for them.
pub(crate) struct SeedField<'a> {
    polys: &'a [&'a [Point]],
    segs: Segments,
    /// Distance to the seed's segment (mm): exact for some segment, so never below the true
    /// distance, and above it by about a cell at most.
    pub dist: Vec<f64>,
    seg: Vec<u32>,
    /// Inside mask (even–odd), empty when unsigned.
    pub inside: Vec<bool>,
    signed: bool,
}

impl<'a> SeedField<'a> {
    pub fn new(grid: &Grid, polys: &'a [&'a [Point]], signed: bool) -> Self {
        let segs = Segments::new(polys);
        let (dist, seg) = seed_distance_and_segment(grid, &segs);
        let inside = if signed {
            inside_mask(grid, polys)
        } else {
            Vec::new()
        };
        SeedField {
            polys,
            segs,
            dist,
            seg,
            inside,
            signed,
        }
    }

    /// Signed seed distance at sample `k` (negative inside when signed).
    pub fn signed(&self, k: usize) -> f64 {
        if self.signed && self.inside[k] {
            -self.dist[k]
        } else {
            self.dist[k]
        }
    }

    /// The polygon of the seed's segment at sample `k` ([`NO_SITE`] when none).
    pub fn label(&self, k: usize) -> u32 {
        let s = self.seg[k];
        if s == NO_SITE {
            NO_SITE
        } else {
            self.segs.poly[s as usize]
        }
    }
}

/// Samples within `cells` (Chebyshev) of a sample whose 3 × 3 neighbourhood holds another
/// seed label than its own, in any of `fields`: where zones meet, give or take the seeds'
/// error. Added to `mask`.
pub(crate) fn mark_label_band(grid: &Grid, fields: &[&SeedField], cells: usize, mask: &mut [bool]) {
    let (w, h) = (grid.width, grid.height);
    let mut edge = vec![false; w * h];
    for f in fields {
        if f.polys.len() < 2 {
            continue;
        }
        let label: Vec<u32> = (0..w * h).into_par_iter().map(|k| f.label(k)).collect();
        edge.par_chunks_mut(w).enumerate().for_each(|(r, row)| {
            for (c, e) in row.iter_mut().enumerate() {
                *e |= !uniform(&label, r, c, w, h);
            }
        });
    }
    // Dilate by a square of side 2·cells + 1: along rows, then along columns.
    let mut rows = vec![false; w * h];
    rows.par_chunks_mut(w).enumerate().for_each(|(r, out)| {
        let src = &edge[r * w..(r + 1) * w];
        // Set samples, in order; each output sample looks at the first one not left of its
        // window.
        let on: Vec<usize> = (0..w).filter(|&c| src[c]).collect();
        let mut j = 0;
        for (c, o) in out.iter_mut().enumerate() {
            while j < on.len() && on[j] + cells < c {
                j += 1;
            }
            *o = j < on.len() && on[j] <= c + cells;
        }
    });
    mask.par_chunks_mut(w).enumerate().for_each(|(r, out)| {
        let (r0, r1) = (r.saturating_sub(cells), (r + cells).min(h - 1));
        for (c, o) in out.iter_mut().enumerate() {
            if !*o {
                *o = (r0..=r1).any(|rr| rows[rr * w + c]);
            }
        }
    });
}

/// [`nearest_contours`] from a seed field, exact at the samples of `exact` (all when `None`)
/// and at their neighbours' zone boundaries. Elsewhere `min1` is the seed distance, above the
/// true one by about a cell at most, and the label the seed's: a caller passes a mask that
/// covers, with a margin larger than that, every sample where it needs values (the zero
/// sets it extracts and the zones' boundaries).
pub(crate) fn nearest_contours_within(
    grid: &Grid,
    field: SeedField,
    exact: Option<&[bool]>,
) -> NearestContours {
    let (w, h) = (grid.width, grid.height);
    let SeedField {
        polys,
        segs,
        mut dist,
        mut seg,
        inside,
        signed,
    } = field;
    refine(grid, &segs, &mut dist, &mut seg, exact);
    let label_of = |s: u32| {
        if s == NO_SITE {
            NO_SITE
        } else {
            segs.poly[s as usize]
        }
    };
    if polys.len() == 1 {
        // One contour: it is the nearest everywhere, and there is no second.
        let min1 = dist
            .iter()
            .zip(&seg)
            .enumerate()
            .map(|(k, (&d, &s))| {
                let d = if s == NO_SITE { f64::INFINITY } else { d };
                (if signed && inside[k] { -d } else { d }) as f32
            })
            .collect();
        let label1 = seg
            .iter()
            .map(|&s| if s == NO_SITE { NO_SITE } else { 0 })
            .collect();
        return NearestContours {
            min1,
            label1,
            min2: vec![f32::INFINITY; w * h],
            label2: vec![NO_SITE; w * h],
            min3: vec![f32::INFINITY; w * h],
        };
    }
    let raw_label: Vec<u32> = seg.iter().map(|&s| label_of(s)).collect();
    // Pass A: a sample's nearest contour may be one its neighbours found (the transform's
    // choice can differ at exact ties and in rare near-ties); settle it first, so pass B
    // sees every neighbour's final label.
    // Only samples next to another label can change: collect those changes per row, then
    // apply them (no copy of the whole field).
    let changes: Vec<Vec<(usize, f64, u32)>> = (0..h)
        .into_par_iter()
        .map(|r| {
            let mut row = Vec::new();
            for c in 0..w {
                let k = r * w + c;
                let own = raw_label[k];
                if own == NO_SITE || uniform(&raw_label, r, c, w, h) {
                    continue;
                }
                let x = grid.point(r, c);
                let (mut bd, mut bs) = (dist[k], seg[k]);
                for (nr, nc) in neighbours(r, c, w, h) {
                    let t = seg[nr * w + nc];
                    let lt = raw_label[nr * w + nc];
                    if lt == NO_SITE || lt == own {
                        continue;
                    }
                    let (d, s) = segs.descend(x, t as usize);
                    // Ties go to the lower label, everywhere alike.
                    if d < bd || (d == bd && lt < label_of(bs)) {
                        bd = d;
                        bs = s as u32;
                    }
                }
                if bs != seg[k] {
                    row.push((k, bd, bs));
                }
            }
            row
        })
        .collect();
    let (mut best_d, mut best_seg) = (dist, seg);
    for (k, d, s) in changes.into_iter().flatten() {
        best_d[k] = d;
        best_seg[k] = s;
    }
    let best_label: Vec<u32> = best_seg.iter().map(|&s| label_of(s)).collect();
    let mut out = NearestContours {
        min1: vec![f32::INFINITY; w * h],
        label1: vec![NO_SITE; w * h],
        min2: vec![f32::INFINITY; w * h],
        label2: vec![NO_SITE; w * h],
        min3: vec![f32::INFINITY; w * h],
    };
    // Pass B: second and third nearest from the neighbours' final segments.
    out.min1
        .par_chunks_mut(w)
        .zip(out.label1.par_chunks_mut(w))
        .zip(out.min2.par_chunks_mut(w))
        .zip(out.label2.par_chunks_mut(w))
        .zip(out.min3.par_chunks_mut(w))
        .enumerate()
        .for_each(|(r, ((((m1, l1), m2), l2), m3))| {
            // (distance, label) candidates: own first, then one per other label nearby.
            let mut cand: Vec<(f64, u32)> = Vec::with_capacity(9);
            for c in 0..w {
                let k = r * w + c;
                let own = best_label[k];
                if own == NO_SITE {
                    continue;
                }
                let d1 = best_d[k];
                m1[c] = if signed && inside[k] { -d1 } else { d1 } as f32;
                l1[c] = own;
                if uniform(&best_label, r, c, w, h) {
                    continue;
                }
                cand.clear();
                cand.push((d1, own));
                let x = grid.point(r, c);
                for (nr, nc) in neighbours(r, c, w, h) {
                    let t = best_seg[nr * w + nc];
                    let lt = best_label[nr * w + nc];
                    if lt == NO_SITE || cand.iter().any(|&(_, l)| l == lt) {
                        continue;
                    }
                    cand.push((segs.descend(x, t as usize).0, lt));
                }
                // The own entry stays first: it is the nearest by pass A.
                cand[1..].sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                if let Some(&(d2, lab2)) = cand.get(1) {
                    m2[c] = d2 as f32;
                    l2[c] = lab2;
                }
                if let Some(&(d3, _)) = cand.get(2) {
                    m3[c] = d3 as f32;
                }
            }
        });
    out
}

/// Inside mask of the polygon set by the even–odd rule, with the same crossing rule as
/// [`super::polygon::contains`] (so a sample is inside here exactly when `contains` says so
/// for a single polygon). Scanline fill: linear in samples plus crossings.
pub fn inside_mask(grid: &Grid, polys: &[&[Point]]) -> Vec<bool> {
    let mut mask = vec![false; grid.len()];
    paint_inside(grid, polys, &mut mask, true);
    mask
}

/// Sets the samples of `mask` that [`inside_mask`] would mark inside `polys` to `value`,
/// leaving the others as they are: one polygon painted after another (a region's outline,
/// then each obstacle cut from it) without a mask per polygon.
pub fn paint_inside(grid: &Grid, polys: &[&[Point]], mask: &mut [bool], value: bool) {
    let (w, h) = (grid.width, grid.height);
    // (row, x) of every crossing of a polygon edge with a sample row.
    let mut crossings: Vec<(usize, f64)> = Vec::new();
    for p in polys {
        let n = p.len();
        for i in 0..n {
            let (a, b) = (p[i], p[(i + 1) % n]);
            let lo = grid.to_pixel([0.0, a[1].min(b[1])])[1].floor().max(0.0);
            let hi = grid.to_pixel([0.0, a[1].max(b[1])])[1]
                .ceil()
                .min(h as f64 - 1.0);
            if hi < lo {
                continue;
            }
            for r in lo as usize..=hi as usize {
                let y = grid.point(r, 0)[1];
                if (a[1] > y) != (b[1] > y) {
                    let x = a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                    crossings.push((r, x));
                }
            }
        }
    }
    crossings.sort_by(|u, v| u.0.cmp(&v.0).then(u.1.total_cmp(&v.1)));
    let mut k = 0;
    while k < crossings.len() {
        let r = crossings[k].0;
        let end = k + crossings[k..].iter().take_while(|c| c.0 == r).count();
        // A sample is inside when an odd number of crossings lie strictly to its right, i.e.
        // when it lies in [x_1, x_2), [x_3, x_4), … of the sorted crossings.
        let mut j = k;
        while j + 1 < end {
            let (x0, x1) = (crossings[j].1, crossings[j + 1].1);
            let c0 = grid.to_pixel([x0, 0.0])[0].ceil().max(0.0);
            let c1 = grid.to_pixel([x1, 0.0])[0].ceil().min(w as f64);
            if c1 > c0 {
                for c in c0 as usize..c1 as usize {
                    let x = grid.point(r, c)[0];
                    if x >= x0 && x < x1 {
                        mask[r * w + c] = value;
                    }
                }
                // `ceil` of the pixel coordinate may miss the sample exactly at x0 after
                // rounding; check the one before.
                if c0 >= 1.0 {
                    let c = c0 as usize - 1;
                    let x = grid.point(r, c)[0];
                    if x >= x0 && x < x1 {
                        mask[r * w + c] = value;
                    }
                }
            }
            j += 2;
        }
        k = end;
    }
}

/// Signed distance (mm) to the boundary of the polygon set, negative inside (even–odd).
pub fn signed_distance(grid: &Grid, polys: &[&[Point]]) -> Vec<f32> {
    let mut d = unsigned_distance(grid, polys);
    let inside = inside_mask(grid, polys);
    for (v, &i) in d.iter_mut().zip(&inside) {
        if i {
            *v = -*v;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::{boundary_distance, contains};

    /// A star-shaped polygon round `c` with radii in `r` (counter-clockwise).
    fn star(rng: &mut impl rand::Rng, c: Point, r: std::ops::Range<f64>, n: usize) -> Vec<Point> {
        (0..n)
            .map(|k| {
                let th = k as f64 * std::f64::consts::TAU / n as f64;
                let rad = rng.random_range(r.clone());
                [c[0] + rad * th.cos(), c[1] + rad * th.sin()]
            })
            .collect()
    }

    #[test]
    fn painting_a_region_then_clearing_obstacles_matches_contains_sample_by_sample() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..20 {
            let region = star(&mut rng, [0.0, 0.0], 6.0..10.0, 40);
            // Obstacles overlapping the region and each other, one nested in another: each is
            // cleared on its own, so the nested one stays cleared (by parity over the set of
            // obstacles it would be inside again).
            let a = star(&mut rng, [4.0, 1.0], 2.0..4.0, 17);
            let b = star(&mut rng, [-3.0, -2.0], 2.0..5.0, 23);
            let nested = star(&mut rng, [-3.0, -2.0], 0.5..1.0, 9);
            let obstacles: Vec<&[Point]> = vec![&a, &b, &nested];
            let grid = Grid::covering(bbox(&region), 0.13, 2, 1 << 20).unwrap();
            let mut mask = inside_mask(&grid, &[&region]);
            for o in &obstacles {
                paint_inside(&grid, &[o], &mut mask, false);
            }
            for r in 0..grid.height {
                for c in 0..grid.width {
                    let p = grid.point(r, c);
                    let want = contains(&region, p) && !obstacles.iter().any(|o| contains(o, p));
                    assert_eq!(mask[r * grid.width + c], want, "sample {p:?}");
                }
            }
        }
    }

    fn brute_1d(f: &[f64]) -> Vec<f64> {
        (0..f.len())
            .map(|q| {
                f.iter()
                    .enumerate()
                    .map(|(p, &fp)| fp + ((q as f64) - p as f64).powi(2))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    }

    #[test]
    fn envelope_matches_brute_force_on_arbitrary_functions() {
        let f = [
            3.0,
            f64::INFINITY,
            0.5,
            7.0,
            f64::INFINITY,
            0.0,
            2.25,
            9.0,
            f64::INFINITY,
        ];
        let mut d = vec![0.0; f.len()];
        let mut s = vec![0; f.len()];
        envelope_1d(&f, &mut d, &mut s, &mut Vec::new(), &mut Vec::new());
        let b = brute_1d(&f);
        for q in 0..f.len() {
            assert!((d[q] - b[q]).abs() < 1e-12, "q={q}: {} vs {}", d[q], b[q]);
            let p = s[q] as usize;
            assert!((f[p] + (q as f64 - p as f64).powi(2) - b[q]).abs() < 1e-12);
        }
        let empty = [f64::INFINITY; 4];
        envelope_1d(
            &empty,
            &mut d[..4],
            &mut s[..4],
            &mut Vec::new(),
            &mut Vec::new(),
        );
        assert!(d[..4].iter().all(|v| v.is_infinite()) && s[..4].iter().all(|&v| v == NO_SITE));
    }

    #[test]
    fn transform_of_two_sites_is_the_squared_distance_to_the_nearer() {
        let (w, h) = (7, 5);
        let mut f = vec![f64::INFINITY; w * h];
        f[w + 1] = 0.0;
        f[3 * w + 5] = 0.0;
        let (d, feat) = distance_transform(&f, w, h);
        for r in 0..h {
            for c in 0..w {
                let a = ((r as f64 - 1.0).powi(2) + (c as f64 - 1.0).powi(2))
                    .min((r as f64 - 3.0).powi(2) + (c as f64 - 5.0).powi(2));
                assert_eq!(d[r * w + c], a);
                let s = feat[r * w + c] as usize;
                let (sr, sc) = (s / w, s % w);
                assert_eq!(
                    (r as f64 - sr as f64).powi(2) + (c as f64 - sc as f64).powi(2),
                    a
                );
            }
        }
    }

    /// Rasters wider and taller than the transform's bands of 16 columns and rows, and not a
    /// multiple of them, against a brute-force minimum over every site.
    #[test]
    fn transform_matches_brute_force_across_band_edges() {
        let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) as f64 / (1u64 << 31) as f64
        };
        // Dense seeds make the chosen site differ between neighbouring rows and columns,
        // so a sample given its neighbour's site is caught; sparse ones leave empty columns.
        for (w, h, density) in [
            (37, 41, 0.3),
            (16, 33, 0.3),
            (1, 50, 0.3),
            (50, 1, 0.3),
            (17, 16, 0.3),
            (37, 41, 0.01),
        ] {
            let f: Vec<f64> = (0..w * h)
                .map(|_| {
                    if next() < density {
                        4.0 * next()
                    } else {
                        f64::INFINITY
                    }
                })
                .collect();
            let (d, feat) = distance_transform(&f, w, h);
            for k in 0..w * h {
                let (r, c) = ((k / w) as f64, (k % w) as f64);
                let at =
                    |s: usize| f[s] + (r - (s / w) as f64).powi(2) + (c - (s % w) as f64).powi(2);
                let best = (0..w * h).map(at).fold(f64::INFINITY, f64::min);
                assert_eq!(d[k], best, "{w}×{h}, sample {k}");
                if best.is_finite() {
                    assert_eq!(at(feat[k] as usize), best, "{w}×{h}, site of sample {k}");
                } else {
                    assert_eq!(feat[k], NO_SITE);
                }
            }
        }
    }

    #[test]
    fn signed_distance_of_a_square_is_exact() {
        let sq: Vec<Point> = vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        let grid = Grid::covering([0.0, 0.0, 4.0, 4.0], 0.1, 10, 1 << 20).unwrap();
        let d = signed_distance(&grid, &[&sq]);
        let mut worst: f64 = 0.0;
        for r in 0..grid.height {
            for c in 0..grid.width {
                let p = grid.point(r, c);
                let mut e = boundary_distance(&sq, p);
                if contains(&sq, p) {
                    e = -e;
                }
                worst = worst.max((d[r * grid.width + c] as f64 - e).abs());
            }
        }
        assert!(worst < 1e-5, "worst error {worst} mm");
    }

    #[test]
    fn grid_rejects_bad_cells_and_caps_size() {
        assert!(Grid::covering([0.0, 0.0, 1.0, 1.0], 0.0, 1, 100).is_err());
        assert!(Grid::covering([0.0, 0.0, 1.0, f64::NAN], 0.1, 1, 100).is_err());
        assert!(Grid::covering([0.0, 0.0, 100.0, 100.0], 0.01, 1, 1 << 20).is_err());
    }
}
