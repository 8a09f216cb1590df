//! Machinery shared by branching and capping: zones of a set of contours (the points nearer
//! to one contour than to the others, bounded by the bisecting edges), extraction of zone
//! loops at sub-pixel precision, and a compression that keeps shared bisecting edges shared.
//!
//! In: the nearest-contours summary of a contour set on one [`Grid`]. Out: zone fields whose
//! zero level is the bisecting edge, world-space loops, and
//! compressed loops in which every chain shared by two loops is compressed identically.
//!
//! Invariant that makes the shared edges exact: for a sample whose two nearest contours are
//! `i` and `j`, the zone fields satisfy `ψ_i = d_i − d_j = −ψ_j` bit for bit (IEEE subtraction
//! is sign-symmetric), so marching squares puts the crossings of both zones' boundaries at
//! identical points.

use std::collections::HashMap;

use rayon::prelude::*;

use super::distance_map::{Grid, NearestContours};
use super::marching_squares::iso_loops;
use super::polygon::{dist, is_simple, signed_area, Point};
use super::simplify::{simplify_closed, simplify_open};

/// Stands for zero in zone fields, with a sign: marching squares counts a sample equal to the
/// level as inside, so an exact tie between two zones must be inside exactly one of them (and
/// `−0.0 == 0.0`, so a signed zero would not do). Representable in `f32`.
const TIE: f64 = 1e-30;

/// `−ψ_i` at sample `k`, where `ψ_i = d_i − min_{j≠i} d_j` is negative inside the zone of
/// contour `i` (the zone's boundary is the bisecting edge). Exact where `i` is one of the two
/// nearest contours, which is where the zone boundary runs except in cells where three zones
/// meet; elsewhere `ψ_i ≥ d_3 − d_1 > 0` and that bound is used (`−∞` when no other contour
/// is near, which marching squares counts as outside). An exact tie goes to the nearer
/// label. A zone with no neighbour is everything (`+∞`).
#[inline]
pub(crate) fn neg_psi(near: &NearestContours, i: u32, k: usize) -> f64 {
    let (d1, d2) = (near.min1[k] as f64, near.min2[k] as f64);
    if near.label1[k] == i {
        let v = d2 - d1;
        if v == 0.0 {
            TIE
        } else {
            v
        }
    } else if near.label2[k] == i {
        let v = d1 - d2;
        if v == 0.0 {
            -TIE
        } else {
            v
        }
    } else {
        -(near.min3[k] as f64 - d1).max(TIE)
    }
}

/// A rectangle of samples, rows `r0..=r1` and columns `c0..=c1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Window {
    pub r0: usize,
    pub r1: usize,
    pub c0: usize,
    pub c1: usize,
}

impl Window {
    /// The least window holding `a` (if any) and `b`.
    fn cover(a: Option<Window>, b: Window) -> Window {
        a.map_or(b, |a| Window {
            r0: a.r0.min(b.r0),
            r1: a.r1.max(b.r1),
            c0: a.c0.min(b.c0),
            c1: a.c1.max(b.c1),
        })
    }

    /// The bounding window of the samples `k` with `inside(k)`, per label `label(k)` (labels
    /// `0..count`, others ignored), grown by two samples and clamped to the raster; `None`
    /// for a label with no sample. One pass over the raster for all labels, in bands of rows
    /// in parallel (the union of boxes does not depend on how the rows were split).
    pub(crate) fn per_label<I, L>(
        grid: &Grid,
        count: usize,
        inside: &I,
        label: &L,
    ) -> Vec<Option<Window>>
    where
        I: Fn(usize) -> bool + Sync,
        L: Fn(usize) -> u32 + Sync,
    {
        let (w, h) = (grid.width, grid.height);
        let union = |mut a: Vec<Option<Window>>, b: Vec<Option<Window>>| {
            for (x, y) in a.iter_mut().zip(b) {
                *x = match y {
                    Some(q) => Some(Window::cover(*x, q)),
                    None => *x,
                };
            }
            a
        };
        let mut out = (0..h)
            .into_par_iter()
            .with_min_len(16)
            .fold(
                || vec![None; count],
                |mut acc: Vec<Option<Window>>, r| {
                    for c in 0..w {
                        let k = r * w + c;
                        let l = label(k) as usize;
                        if l >= count || !inside(k) {
                            continue;
                        }
                        let sample = Window {
                            r0: r,
                            r1: r,
                            c0: c,
                            c1: c,
                        };
                        acc[l] = Some(Window::cover(acc[l], sample));
                    }
                    acc
                },
            )
            .reduce(|| vec![None; count], union);
        for b in out.iter_mut().flatten() {
            b.r0 = b.r0.saturating_sub(2);
            b.c0 = b.c0.saturating_sub(2);
            b.r1 = (b.r1 + 2).min(h - 1);
            b.c1 = (b.c1 + 2).min(w - 1);
        }
        out
    }
}

/// Same clamp as marching squares: crossings stay a hair away from the samples.
const T_MARGIN: f64 = 1e-4;

/// Zero-level loops of `min(g, n)` (inside = `≥ 0`) in world coordinates, with every crossing
/// placed on the field that really crosses there.
///
/// Marching squares on the sampled `min(g, n)` interpolates, on a grid edge whose ends take
/// the minimum from different fields, between a value of `g` and a value of `n`: near the
/// corner where the two zero sets meet the crossing then lies on neither. Each crossing is
/// recomputed here from the two fields' own linear interpolants along its edge (the exit of
/// `{g ≥ 0} ∩ {n ≥ 0}`), parameterised from the edge's first sample so that a neighbour whose
/// `n` is negated gets the same point bit for bit, and a loop of the other section (same `g`)
/// gets the same point on the mid-section boundary. The topology is marching squares' own.
/// `g` and `n` must return the values as rounded into the `f32` field.
///
/// `window` (rows `r0..=r1`, columns `c0..=c1`), when given, must hold every sample where
/// `min(g, n) ≥ 0` with two samples to spare inside the raster (or reach the raster's edge):
/// marching squares then runs on the window alone and gives the same loops, the same points
/// bit for bit (they are moved to raster coordinates, integers exactly, before the crossings
/// are placed), at the cost of the window instead of the whole raster.
pub(crate) fn zone_loops<G, N>(grid: &Grid, g: &G, n: &N, window: Option<Window>) -> Vec<Vec<Point>>
where
    G: Fn(usize) -> f64 + Sync,
    N: Fn(usize) -> f64 + Sync,
{
    let (w, h) = (grid.width, grid.height);
    let win = window.unwrap_or(Window {
        r0: 0,
        r1: h.saturating_sub(1),
        c0: 0,
        c1: w.saturating_sub(1),
    });
    if grid.is_empty() || win.r1 < win.r0 || win.c1 < win.c0 || win.r1 >= h || win.c1 >= w {
        return Vec::new();
    }
    let (ww, wh) = (win.c1 - win.c0 + 1, win.r1 - win.r0 + 1);
    let mut field = vec![0.0f32; ww * wh];
    field.par_chunks_mut(ww).enumerate().for_each(|(i, row)| {
        let start = (win.r0 + i) * w + win.c0;
        for (v, k) in row.iter_mut().zip(start..) {
            *v = g(k).min(n(k)) as f32;
        }
    });
    let mut loops = iso_loops(&field, ww, wh, 0.0);
    let offset = [win.c0 as f64, win.r0 as f64];
    for lp in loops.iter_mut() {
        for p in lp.iter_mut() {
            *p = [p[0] + offset[0], p[1] + offset[1]];
            // The edge the crossing lies on: one pixel coordinate is an exact integer.
            let (a, b, horizontal) = if p[1].fract() == 0.0 && p[0].fract() != 0.0 {
                let (r, c) = (p[1], p[0].floor());
                if r < 0.0 || c < 0.0 || r >= h as f64 || c + 1.0 >= w as f64 {
                    continue;
                }
                let k = r as usize * w + c as usize;
                (k, k + 1, true)
            } else if p[0].fract() == 0.0 && p[1].fract() != 0.0 {
                let (r, c) = (p[1].floor(), p[0]);
                if r < 0.0 || c < 0.0 || r + 1.0 >= h as f64 || c >= w as f64 {
                    continue;
                }
                let k = r as usize * w + c as usize;
                (k, k + w, false)
            } else {
                continue;
            };
            let (ga, gb, na, nb) = (g(a), g(b), n(a), n(b));
            let inside_a = ga.min(na) >= 0.0;
            if inside_a == (gb.min(nb) >= 0.0) || !(ga.is_finite() && gb.is_finite()) {
                continue;
            }
            // Zero of one field along the edge, from sample a; only where it changes sign.
            let zero = |fa: f64, fb: f64| {
                ((fa >= 0.0) != (fb >= 0.0) && fa.is_finite() && fb.is_finite())
                    .then(|| fa / (fa - fb))
            };
            let (tg, tn) = (zero(ga, gb), zero(na, nb));
            let t = if inside_a {
                // Leaving the region: the first field to go negative.
                match (tg.filter(|_| gb < 0.0), tn.filter(|_| nb < 0.0)) {
                    (Some(x), Some(y)) => x.min(y),
                    (Some(x), None) | (None, Some(x)) => x,
                    (None, None) => continue,
                }
            } else {
                // Entering it: the last field to become non-negative.
                match (tg.filter(|_| ga < 0.0), tn.filter(|_| na < 0.0)) {
                    (Some(x), Some(y)) => x.max(y),
                    (Some(x), None) | (None, Some(x)) => x,
                    (None, None) => continue,
                }
            };
            let t = t.clamp(T_MARGIN, 1.0 - T_MARGIN);
            if horizontal {
                p[0] = p[0].floor() + t;
            } else {
                p[1] = p[1].floor() + t;
            }
        }
    }
    loops
        .into_iter()
        .map(|lp| lp.into_iter().map(|p| grid.to_world(p)).collect())
        .collect()
}

/// The loop of largest |area| among those with the wanted orientation (`ccw` = positive
/// area), with how many such loops there were and their total |area|.
pub(crate) fn largest_loop(loops: &[Vec<Point>], ccw: bool) -> (Option<usize>, usize, f64) {
    let mut best: Option<(usize, f64)> = None;
    let (mut count, mut total) = (0, 0.0);
    for (k, lp) in loops.iter().enumerate() {
        let a = signed_area(lp);
        if (a > 0.0) != ccw || a == 0.0 {
            continue;
        }
        count += 1;
        total += a.abs();
        if best.is_none_or(|(_, b)| a.abs() > b) {
            best = Some((k, a.abs()));
        }
    }
    (best.map(|b| b.0), count, total)
}

fn key(p: Point) -> (u64, u64) {
    (p[0].to_bits(), p[1].to_bits())
}

/// Douglas–Peucker on an open chain with both ends kept, run in a canonical direction (from
/// the end with the smaller key) so the same chain traversed either way compresses to the
/// same points.
fn simplify_chain(chain: &[Point], tol: f64) -> Vec<Point> {
    let n = chain.len();
    if n <= 2 {
        return chain.to_vec();
    }
    let reversed = key(chain[n - 1]) < key(chain[0]);
    let pts: Vec<Point> = if reversed {
        chain.iter().rev().copied().collect()
    } else {
        chain.to_vec()
    };
    let mut out = simplify_open(&pts, tol);
    if reversed {
        out.reverse();
    }
    out
}

/// A closed loop compressed from a canonical start and orientation, then put back in the
/// input's orientation: equal loops compress equally whatever their start or direction.
fn simplify_whole(lp: &[Point], tol: f64) -> Vec<Point> {
    let reversed = signed_area(lp) < 0.0;
    let mut pts: Vec<Point> = lp.to_vec();
    if reversed {
        pts.reverse();
    }
    let start = (0..pts.len()).min_by_key(|&i| key(pts[i])).unwrap_or(0);
    pts.rotate_left(start);
    let mut out = simplify_closed(&pts, tol);
    if reversed {
        out.reverse();
    }
    out
}

/// Points closer than this fraction of the compression tolerance are taken as one point, for
/// every loop at once (see [`snap_close_points`]).
const SNAP_FRACTION: f64 = 0.04;

/// The loops with each short edge closer than `eps` made one point (its first point met,
/// loops and points in order), where that edge is an edge of every loop holding either end:
/// merging it then only drops a repeat from each, and never pinches a loop.
///
/// Loops traced zone by zone meet at junctions that each finds on its own: where the boundary
/// of `M_t` passes a hair from a sample, or a third contour makes two zones' ψ differ, two
/// zones can end their shared bisecting edge at two junction points a thousandth of a cell
/// apart, each loop holding both. The two loops then overlap on the edge between them, which
/// a mesh stitched from the loops uses four times (GE head, slices 7–8). One point mends it.
pub(crate) fn snap_close_points(loops: &[Vec<Point>], eps: f64) -> Vec<Vec<Point>> {
    let mut at: HashMap<(u64, u64), Vec<(usize, usize)>> = HashMap::new();
    for (l, lp) in loops.iter().enumerate() {
        for (i, &p) in lp.iter().enumerate() {
            at.entry(key(p)).or_default().push((l, i));
        }
    }
    // Whether every visit of `a` has `b` next to it in its loop (either side).
    let beside = |a: Point, b: Point| {
        at.get(&key(a)).is_some_and(|visits| {
            visits.iter().all(|&(l, i)| {
                let lp = &loops[l];
                let n = lp.len();
                n > 3 && (lp[(i + 1) % n] == b || lp[(i + n - 1) % n] == b)
            })
        })
    };
    let bin = |p: Point| ((p[0] / eps).floor() as i64, (p[1] / eps).floor() as i64);
    let mut bins: HashMap<(i64, i64), Vec<Point>> = HashMap::new();
    let mut to: HashMap<(u64, u64), Point> = HashMap::new();
    let mut snapped = false;
    for &p in loops.iter().flatten() {
        if to.contains_key(&key(p)) {
            continue;
        }
        let (bx, by) = bin(p);
        let mut best: Option<(f64, Point)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for &c in bins.get(&(bx + dx, by + dy)).into_iter().flatten() {
                    let d = dist(c, p);
                    if d <= eps && best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, c));
                    }
                }
            }
        }
        match best {
            Some((_, c)) if beside(p, c) && beside(c, p) => {
                snapped = true;
                to.insert(key(p), c);
            }
            _ => {
                bins.entry((bx, by)).or_default().push(p);
                to.insert(key(p), p);
            }
        }
    }
    if !snapped {
        return loops.to_vec();
    }
    loops
        .iter()
        .map(|lp| {
            let mut out: Vec<Point> = Vec::with_capacity(lp.len());
            for p in lp {
                let c = to.get(&key(*p)).copied().unwrap_or(*p);
                if out.last() != Some(&c) {
                    out.push(c);
                }
            }
            while out.len() > 1 && out.first() == out.last() {
                out.pop();
            }
            out
        })
        .collect()
}

/// Compress every loop within `tol`, keeping chains shared between loops identical: each
/// loop is cut into runs of consecutive points owned by the same set of loops (points are
/// compared bit for bit), the cut points are kept, and each run is compressed in a canonical
/// direction. A loop whose compression is not simple is retried at half the tolerance, and
/// left as it was after 6 tries. Points closer than a small fraction of `tol` are made one
/// point first ([`snap_close_points`]).
pub(crate) fn simplify_shared(loops: &[Vec<Point>], tol: f64) -> Vec<Vec<Point>> {
    let loops = &snap_close_points(loops, SNAP_FRACTION * tol);
    let mut owners: HashMap<(u64, u64), Vec<u32>> = HashMap::new();
    for (id, lp) in loops.iter().enumerate() {
        for &p in lp {
            let o = owners.entry(key(p)).or_default();
            if o.last() != Some(&(id as u32)) {
                o.push(id as u32);
            }
        }
    }
    let empty: Vec<u32> = Vec::new();
    loops
        .iter()
        .map(|lp| {
            let n = lp.len();
            if n <= 4 {
                return lp.clone();
            }
            let sig: Vec<&Vec<u32>> = lp
                .iter()
                .map(|&p| owners.get(&key(p)).unwrap_or(&empty))
                .collect();
            let starts: Vec<usize> = (0..n).filter(|&k| sig[k] != sig[(k + n - 1) % n]).collect();
            let mut t = tol;
            for _ in 0..6 {
                let out = if starts.is_empty() {
                    simplify_whole(lp, t)
                } else {
                    let mut out = Vec::with_capacity(n);
                    for (r, &s) in starts.iter().enumerate() {
                        let e = starts[(r + 1) % starts.len()];
                        let len = (e + n - s - 1) % n + 1;
                        let chain: Vec<Point> = (0..len).map(|k| lp[(s + k) % n]).collect();
                        out.extend(simplify_chain(&chain, t));
                    }
                    out
                };
                if out.len() >= 3 && is_simple(&out) {
                    return out;
                }
                t *= 0.5;
            }
            lp.clone()
        })
        .collect()
}

/// Bilinear interpolation in a grid cell: corners `[v(r, c), v(r, c+1), v(r+1, c), v(r+1, c+1)]`
/// at local coordinates `(u, v)` in `[0, 1]²`, with its gradient. Written so that negating
/// the corners negates every result bit for bit.
fn bilinear(f: [f64; 4], u: f64, v: f64) -> (f64, f64, f64) {
    let val =
        f[0] * (1.0 - u) * (1.0 - v) + f[1] * u * (1.0 - v) + f[2] * (1.0 - u) * v + f[3] * u * v;
    let du = (f[1] - f[0]) * (1.0 - v) + (f[3] - f[2]) * v;
    let dv = (f[2] - f[0]) * (1.0 - u) + (f[3] - f[1]) * u;
    (val, du, dv)
}

/// The four sides of a grid cell.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Side {
    Top,
    Bottom,
    Left,
    Right,
}

const SIDES: [Side; 4] = [Side::Top, Side::Right, Side::Bottom, Side::Left];

/// What following a zero curve found: the crossings passed, the cell it stopped in, and the
/// junction with the other curve there (when looking for one).
type Followed = (Vec<Point>, (usize, usize), Option<Point>);

/// Walking the zero curves of two sampled fields cell by cell, with crossings placed exactly
/// as [`zone_loops`] places them (so they coincide bit for bit with other loops' vertices).
struct Tracer<'a> {
    grid: &'a Grid,
    g: &'a (dyn Fn(usize) -> f64 + Sync),
    n: &'a (dyn Fn(usize) -> f64 + Sync),
}

impl Tracer<'_> {
    fn field(&self, on_g: bool, k: usize) -> f64 {
        if on_g {
            (self.g)(k)
        } else {
            (self.n)(k)
        }
    }

    /// End samples of a side of cell (c, r), first sample first (left or top end).
    fn side_samples(&self, c: usize, r: usize, side: Side) -> (usize, usize) {
        let w = self.grid.width;
        match side {
            Side::Top => (r * w + c, r * w + c + 1),
            Side::Bottom => ((r + 1) * w + c, (r + 1) * w + c + 1),
            Side::Left => (r * w + c, (r + 1) * w + c),
            Side::Right => (r * w + c + 1, (r + 1) * w + c + 1),
        }
    }

    /// Pixel position of the field's zero on a side, if the field changes sign there.
    fn crossing(&self, on_g: bool, c: usize, r: usize, side: Side) -> Option<Point> {
        let (a, b) = self.side_samples(c, r, side);
        let (fa, fb) = (self.field(on_g, a), self.field(on_g, b));
        if !(fa.is_finite() && fb.is_finite()) || (fa >= 0.0) == (fb >= 0.0) {
            return None;
        }
        let t = (fa / (fa - fb)).clamp(T_MARGIN, 1.0 - T_MARGIN);
        let (c, r) = (c as f64, r as f64);
        Some(match side {
            Side::Top => [c + t, r],
            Side::Bottom => [c + t, r + 1.0],
            Side::Left => [c, r + t],
            Side::Right => [c + 1.0, r + t],
        })
    }

    /// The side of cell (c, r) a pixel point lies on, if any (up to the rounding of the
    /// world ↔ pixel round trip).
    fn side_of(c: usize, r: usize, p: Point) -> Option<Side> {
        const EPS: f64 = 1e-7;
        let (u, v) = (p[0] - c as f64, p[1] - r as f64);
        let along = |t: f64| t > 0.0 && t < 1.0;
        if v.abs() < EPS && along(u) {
            Some(Side::Top)
        } else if (v - 1.0).abs() < EPS && along(u) {
            Some(Side::Bottom)
        } else if u.abs() < EPS && along(v) {
            Some(Side::Left)
        } else if (u - 1.0).abs() < EPS && along(v) {
            Some(Side::Right)
        } else {
            None
        }
    }

    /// Corner values of both fields in cell (c, r), if all finite.
    fn cell(&self, c: usize, r: usize) -> Option<([f64; 4], [f64; 4])> {
        let w = self.grid.width;
        let k = [
            r * w + c,
            r * w + c + 1,
            (r + 1) * w + c,
            (r + 1) * w + c + 1,
        ];
        let gv = [
            (self.g)(k[0]),
            (self.g)(k[1]),
            (self.g)(k[2]),
            (self.g)(k[3]),
        ];
        let nv = [
            (self.n)(k[0]),
            (self.n)(k[1]),
            (self.n)(k[2]),
            (self.n)(k[3]),
        ];
        gv.iter()
            .chain(&nv)
            .all(|v| v.is_finite())
            .then_some((gv, nv))
    }

    /// Where both zero curves meet in cell (c, r), in pixel coordinates.
    fn junction(&self, c: usize, r: usize) -> Option<Point> {
        let (gv, nv) = self.cell(c, r)?;
        let mixed = |f: &[f64; 4]| f.iter().any(|&v| v >= 0.0) && f.iter().any(|&v| v < 0.0);
        if !(mixed(&gv) && mixed(&nv)) {
            return None;
        }
        let (u, v) = solve_corner(gv, nv)?;
        Some([c as f64 + u, r as f64 + v])
    }

    /// Follow one field's zero curve from the crossing `p` on a side of cell (c, r) into that
    /// cell and on, cell by cell, collecting the crossings passed, until a cell holding a
    /// junction with the other field (returned with its cell) or `stop` cell is reached.
    /// Gives up after a few cells, at a saddle, or at the raster's edge.
    fn follow(
        &self,
        on_g: bool,
        start: (usize, usize),
        p: Point,
        stop: Option<(usize, usize)>,
    ) -> Option<Followed> {
        let (w, h) = (self.grid.width, self.grid.height);
        let (mut c, mut r) = start;
        let mut entry = Self::side_of(c, r, p)?;
        let mut path = Vec::new();
        for _ in 0..6 {
            if stop == Some((c, r)) {
                return Some((path, (c, r), None));
            }
            if stop.is_none() {
                if let Some(j) = self.junction(c, r) {
                    return Some((path, (c, r), Some(j)));
                }
            }
            let exits: Vec<Side> = SIDES
                .iter()
                .copied()
                .filter(|&s| s != entry && self.crossing(on_g, c, r, s).is_some())
                .collect();
            let [exit] = exits[..] else {
                return None;
            };
            path.push(self.crossing(on_g, c, r, exit)?);
            let (nc, nr, ne) = match exit {
                Side::Top if r > 0 => (c, r - 1, Side::Bottom),
                Side::Bottom if r + 2 < h => (c, r + 1, Side::Top),
                Side::Left if c > 0 => (c - 1, r, Side::Right),
                Side::Right if c + 2 < w => (c + 1, r, Side::Left),
                _ => return None,
            };
            (c, r, entry) = (nc, nr, ne);
        }
        None
    }
}

/// Marching squares cuts the corner where two zero sets meet (where the mid-section's
/// boundary meets a bisecting edge): the loop of `min(g, n)` jumps from a crossing of one
/// field straight to a crossing of the other, and where the two meet at a shallow angle the
/// cut can skip whole cells whose samples all lie outside. Put the corner back: for each loop
/// edge whose ends lie on different fields, follow the first end's zero curve cell by cell
/// (collecting its crossings) to the cell where the two curves meet, solve `g = n = 0` there
/// for the bilinear interpolants (Newton from the cell centre), then follow the second end's
/// zero curve back from that end to the same cell. Crossings are placed as [`zone_loops`]
/// places them and the corner is odd in `n`, so the loop across the bisecting edge and the
/// other section's loops get the same points bit for bit. The loop is returned unchanged if
/// the result would not be simple.
pub(crate) fn insert_junctions(
    lp: &[Point],
    grid: &Grid,
    g: &(dyn Fn(usize) -> f64 + Sync),
    n: &(dyn Fn(usize) -> f64 + Sync),
) -> Vec<Point> {
    let (w, h) = (grid.width, grid.height);
    if w < 2 || h < 2 {
        return lp.to_vec();
    }
    let tracer = Tracer { grid, g, n };
    // Whether a loop vertex (pixel) is a zero of g rather than n: the one nearer zero along
    // its grid edge.
    let on_g = |c: usize, r: usize, x: Point| -> Option<bool> {
        let (gv, nv) = tracer.cell(c, r)?;
        let (u, v) = (x[0] - c as f64, x[1] - r as f64);
        Some(bilinear(gv, u, v).0.abs() <= bilinear(nv, u, v).0.abs())
    };
    let len = lp.len();
    let mut out = Vec::with_capacity(len + 8);
    let mut inserted = false;
    for i in 0..len {
        let (p, q) = (lp[i], lp[(i + 1) % len]);
        out.push(p);
        let (pp, qp) = (grid.to_pixel(p), grid.to_pixel(q));
        // The cell the segment p → q crosses (marching squares keeps segments in one cell).
        let mid = [0.5 * (pp[0] + qp[0]), 0.5 * (pp[1] + qp[1])];
        let (cf, rf) = (mid[0].floor(), mid[1].floor());
        if !(cf >= 0.0 && rf >= 0.0 && cf < (w - 1) as f64 && rf < (h - 1) as f64) {
            continue;
        }
        let cell = (cf as usize, rf as usize);
        let (Some(p_on_g), Some(q_on_g)) = (on_g(cell.0, cell.1, pp), on_g(cell.0, cell.1, qp))
        else {
            continue;
        };
        if p_on_g == q_on_g {
            continue;
        }
        // Forward along p's curve to the junction, backward along q's curve to its cell.
        let Some((ahead, jcell, Some(j))) = tracer.follow(p_on_g, cell, pp, None) else {
            continue;
        };
        let Some((mut back, _, _)) = tracer.follow(q_on_g, cell, qp, Some(jcell)) else {
            continue;
        };
        back.reverse();
        let added: Vec<Point> = ahead
            .into_iter()
            .chain(std::iter::once(j))
            .chain(back)
            .map(|x| grid.to_world(x))
            .filter(|&x| x != p && x != q)
            .collect();
        inserted |= !added.is_empty();
        out.extend(added);
    }
    if inserted && !is_simple(&out) {
        return lp.to_vec();
    }
    out
}

/// The point of the cell `[0, 1]²` where both bilinear interpolants vanish, by Newton from
/// the centre (odd in `n`: negating `n` gives the same point bit for bit). Points on the
/// cell's sides count (a bisecting edge through a row of samples, as symmetric input gives).
fn solve_corner(gv: [f64; 4], nv: [f64; 4]) -> Option<(f64, f64)> {
    let (mut u, mut v) = (0.5, 0.5);
    for _ in 0..20 {
        let (gf, gu, gvv) = bilinear(gv, u, v);
        let (nf, nu, nvv) = bilinear(nv, u, v);
        let det = gu * nvv - gvv * nu;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let du = (-gf * nvv + nf * gvv) / det;
        let dv = (-nf * gu + gf * nu) / det;
        u += du;
        v += dv;
        if !(u.is_finite() && v.is_finite()) || u.abs() > 4.0 || v.abs() > 4.0 {
            return None;
        }
        if du.abs() + dv.abs() < 1e-12 {
            let inside = |t: f64| (-1e-9..=1.0 + 1e-9).contains(&t);
            return (inside(u) && inside(v)).then(|| (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)));
        }
    }
    None
}

/// Distance from `p` to the nearest boundary of the polygon set.
pub(crate) fn set_distance(polys: &[&[Point]], p: Point) -> f64 {
    polys
        .iter()
        .map(|lp| super::polygon::boundary_distance(lp, p))
        .fold(f64::INFINITY, f64::min)
}

/// Refine a grid maximum of the distance to the polygon set's boundary by a compass search
/// on the exact distance (the distance map peaks in a cone or a ridge, where a parabola fit
/// is biased; the exact function has no such bias). Starts at `start` with a step of one
/// cell and stops below 1e-4 cell.
pub(crate) fn refine_innermost(polys: &[&[Point]], start: Point, cell: f64) -> Point {
    let mut best = start;
    let mut value = set_distance(polys, start);
    let mut step = cell;
    // Sixteen directions: a ridge of the distance map rarely hides between all of them.
    let dirs: Vec<Point> = (0..16)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            [a.cos(), a.sin()]
        })
        .collect();
    let mut guard = 0;
    while step > 1e-4 * cell && guard < 400 {
        guard += 1;
        let mut moved = false;
        for d in &dirs {
            let q = [best[0] + step * d[0], best[1] + step * d[1]];
            let v = set_distance(polys, q);
            if v > value {
                value = v;
                best = q;
                moved = true;
                break;
            }
        }
        if !moved {
            step *= 0.5;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    type Edge = ((u64, u64), (u64, u64));

    /// How many times the loops use each edge (either direction).
    fn edge_uses(loops: &[Vec<Point>]) -> HashMap<Edge, usize> {
        let mut uses = HashMap::new();
        for lp in loops {
            for i in 0..lp.len() {
                let (a, b) = (key(lp[i]), key(lp[(i + 1) % lp.len()]));
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        uses
    }

    #[test]
    fn two_junctions_a_hair_apart_become_one() {
        // Zones L and R of one section tile the square [0, 2] × [0, 1]; U of the other
        // section is the square. L and R each found their own junction on the top side,
        // a = (1, 1) and a2 = (1.0001, 1): L ends its bisecting edge at a2, R at a, so both
        // hold the edge a–a2, and with U it is used three times.
        let (a, a2) = ([1.0, 1.0], [1.0001, 1.0]);
        let l = vec![[0.0, 0.0], [1.0, 0.0], a2, a, [0.0, 1.0]];
        let r = vec![[1.0, 0.0], [2.0, 0.0], [2.0, 1.0], a2, a];
        let u = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            a2,
            a,
            [0.0, 1.0],
        ];
        let before = [l, r, u];
        assert!(edge_uses(&before).values().any(|&n| n == 3));
        let out = snap_close_points(&before, 0.001);
        assert!(edge_uses(&out).values().all(|&n| n == 2), "{out:?}");
        // One point, the first met, in every loop.
        assert!(out.iter().all(|lp| lp.contains(&a2) && !lp.contains(&a)));
        assert_eq!(out.iter().map(|lp| lp.len()).collect::<Vec<_>>(), [4, 4, 6]);
    }

    #[test]
    fn close_points_that_are_not_an_edge_everywhere_stay() {
        // A loop passing a hair from itself (a pinch would follow), and two loops whose
        // corners nearly touch: merging either would change the loops' shape, not mend them.
        let pinch = vec![
            [0.0, 0.0],
            [2.0, 0.0],
            [1.0, 0.5],
            [2.0, 1.0],
            [0.0, 1.0],
            [1.0001, 0.5],
        ];
        let corner_a = vec![[3.0, 0.0], [4.0, 0.0], [4.0, 1.0]];
        let corner_b = vec![[4.0001, 1.0], [5.0, 1.0], [5.0, 2.0]];
        let loops = [pinch, corner_a, corner_b];
        assert_eq!(snap_close_points(&loops, 0.001), loops);
    }

    #[test]
    fn shared_chain_compresses_identically_both_ways() {
        // Two unit-ish squares sharing the wobbly edge x = 1.
        let wobble: Vec<Point> = (0..=20)
            .map(|k| [1.0 + 0.001 * ((k * 7 % 5) as f64), k as f64 * 0.05])
            .collect();
        let mut left: Vec<Point> = vec![[0.0, 1.0], [0.0, 0.0]];
        left.extend(wobble.iter().copied());
        let mut right: Vec<Point> = vec![[2.0, 0.0], [2.0, 1.0]];
        right.extend(wobble.iter().rev().copied());
        let out = simplify_shared(&[left, right.clone()], 0.01);
        let on_edge = |lp: &Vec<Point>| {
            let mut v: Vec<(u64, u64)> = lp
                .iter()
                .filter(|p| p[0] >= 1.0 && p[0] < 1.5)
                .map(|&p| key(p))
                .collect();
            v.sort();
            v
        };
        assert_eq!(on_edge(&out[0]), on_edge(&out[1]));
        assert!(out[0].len() < 10, "{:?}", out[0]);
        assert!(is_simple(&out[0]) && is_simple(&out[1]));
        // Same loop given twice in opposite directions and starts compresses to one shape.
        let mut back = right.clone();
        back.reverse();
        back.rotate_left(3);
        let both = simplify_shared(&[right, back], 0.01);
        let mut a: Vec<_> = both[0].iter().map(|&p| key(p)).collect();
        let mut b: Vec<_> = both[1].iter().map(|&p| key(p)).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b);
    }

    #[test]
    fn innermost_point_of_a_square_is_its_centre() {
        let sq: Vec<Point> = vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        let p = refine_innermost(&[&sq], [1.7, 2.3], 0.1);
        assert!(
            (p[0] - 2.0).abs() < 1e-3 && (p[1] - 2.0).abs() < 1e-3,
            "{p:?}"
        );
    }
}
