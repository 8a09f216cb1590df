//! Keyholes (beyond the paper): a contour and some of its holes joined into one loop by
//! zero-width slits.
//!
//! Where a bay of a contour closes into a hole one slice up (or a hole opens into a bay), the
//! hole has no hole on the other slice to continue from, and capping it alone hangs a dome
//! from the hole into the bay, through which the outer wall passes as it sweeps from the
//! bay's rim up to the closed mouth. The topology that changes there is the void's, not the
//! material's: the exterior on one slice is the exterior and the hole on the other. Joined
//! to its contour by a slit across the closed mouth, the hole becomes part of one loop that
//! the contour on the other slice skins onto 1-to-1: the bay's walls rise to the hole's
//! walls, and the two sides of the slit come down to the bay's two mouth corners, an arch
//! over the mouth.
//!
//! In (one plane frame, mm): the contour (counter-clockwise), the holes to join (clockwise),
//! its other holes (slits must not cross them), and the other slice's contours that it links
//! to, projected into this plane: every slit's midpoint must lie outside them, over the void
//! the mouth closes.
//! Out: one [`Slit`] per hole, as vertex indices, or `None` if some hole has no admissible
//! slit. [`keyhole_loop`] turns them into the loop for any point type, so the caller can
//! build it from the contours' own points bit for bit.
//!
//! The slit of each hole is a segment from a point of the loop so far (the contour and the
//! holes already joined) to a point of the hole that crosses and touches no contour, hole or
//! earlier slit except at its own two ends, and whose midpoint lies in the material and
//! outside the other slice's contour. Among such slits of about the shortest length (within
//! a factor of [`ROUND_FACTORS`], up to [`CLEAR_SEARCH`] times the shortest), the shortest
//! whose middle half (its quarter, half and three-quarter points) lies outside the other
//! slice's contours wins; if none does, the shortest round's slit lying least inside them.
//! The wall that closes the mouth lies over the other slice's void, while a thin wall
//! elsewhere between the hole and the outside lies over the other slice's thin wall, its
//! midpoint at best just outside it. (On the skull the shortest slit of one keyhole, 1.2 mm,
//! crossed such a wall with its midpoint 0.3 mm from the next slice's bone, 35 mm from the
//! bay's mouth, where a 1.6 mm slit lay 1.6 mm clear; the bay's wall then swept across to
//! the hole's, 1,164 faces crossing others. Ranking by the midpoint alone moved another
//! keyhole's slit onto a long crossing whose ends lay over the next slice's bone, 2,319
//! faces; preferring the clearest over the shortest clear slit cost the tilted GE head 2,750
//! crossing faces.) A clear slit whose outer end lies deep in a bay of the other slice, far
//! round from its open field ([`BayDepth`]), gives way to a clear one up to
//! [`SHALLOW_SEARCH`] times as long that ends near it: the mouth, not the bay's inside.

use std::cell::OnceCell;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::distance_map::{bbox_of, inside_mask, neighbours, Grid};
use super::polygon::{
    boxes_disjoint, clear_of, dist, least_signed_distance, perimeter, segments_intersect,
    BoundaryIndex, Point,
};

/// Candidate slits are tried shortest first, in rounds up to this many times the shortest
/// candidate's length (then all of them).
const ROUND_FACTORS: [f64; 4] = [2.0, 4.0, 16.0, 64.0];

/// A foot closer than this fraction of its edge's length to a vertex is put on the vertex:
/// no near-duplicate points in the loops.
const SNAP: f64 = 0.02;

/// A point on a ring: `t` of the way along edge `edge` (from vertex `edge` to the next);
/// `t == 0` is the vertex itself. Ring 0 is the contour, ring `k + 1` the `k`-th hole joined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foot {
    pub ring: usize,
    pub edge: usize,
    pub t: f64,
}

/// A slit from a point of the loop so far to a point of the hole it joins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slit {
    pub from: Foot,
    pub to: Foot,
}

fn at(rings: &[&[Point]], f: Foot) -> Point {
    let r = rings[f.ring];
    let (a, b) = (r[f.edge], r[(f.edge + 1) % r.len()]);
    [a[0] + f.t * (b[0] - a[0]), a[1] + f.t * (b[1] - a[1])]
}

/// The slits joining `holes` (in order) to `contour`, their ends searched every `step` mm
/// along the rings; see the module doc. With `mouths`, `outside_of` is the other slice and a
/// clear slit ending deep in one of its bays gives way to one ending near its open field
/// ([`BayDepth`]); without, `outside_of` only says where the slits' midpoints may lie (the
/// holes of an intermediate loop, joined with notches opening towards its section's void).
pub fn slits(
    contour: &[Point],
    holes: &[&[Point]],
    other_holes: &[&[Point]],
    outside_of: &[&[Point]],
    step: f64,
    mouths: bool,
) -> Option<Vec<Slit>> {
    if !(step.is_finite() && step > 0.0) {
        return None;
    }
    let mut rings: Vec<&[Point]> = vec![contour];
    let mut made: Vec<(Point, Point)> = Vec::new();
    let mut out = Vec::with_capacity(holes.len());
    let bay_depth: OnceCell<Option<BayDepth>> = OnceCell::new();
    // The clearance of every candidate slit asks these, thousands of times per hole.
    let other_slice: Vec<BoundaryIndex> =
        outside_of.iter().map(|o| BoundaryIndex::new(o)).collect();
    // Every boundary a slit must keep off: the contour, the holes (ring `k + 1` is the
    // `k`-th, so a slit's feet index these too) and the other holes. Every admissible slit
    // also asks whether its midpoint lies in the contour, in no hole.
    let walls: Vec<BoundaryIndex> = std::iter::once(contour)
        .chain(holes.iter().copied())
        .chain(other_holes.iter().copied())
        .map(BoundaryIndex::new)
        .collect();
    for &hole in holes {
        if hole.len() < 3 {
            return None;
        }
        rings.push(hole);
        let h = rings.len() - 1;
        let admissible = |s: &Slit| {
            let (a, b) = (at(&rings, s.from), at(&rings, s.to));
            let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
            walls[0].contains(mid)
                && !walls[1..].iter().any(|w| w.contains(mid))
                && !other_slice.iter().any(|o| o.contains(mid))
                && !crosses_walls(a, b, &walls, s)
                && !made.iter().any(|&(p, q)| segments_intersect(a, b, p, q))
        };
        // How far the middle half lies outside the other slice's contours: the least signed
        // distance (negative inside) at those points.
        let clearance = |s: &Slit| {
            middle_half(&rings, s)
                .iter()
                .map(|&p| least_signed_distance(&other_slice, p))
                .fold(f64::INFINITY, f64::min)
        };
        // Whether the slit's outer end lies near the open field on the other slice, not deep
        // in a bay there (see [`BayDepth`]); the field is built once, when first asked.
        let shallow = |s: &Slit| {
            if !mouths || s.from.ring != 0 {
                return true;
            }
            let depth = bay_depth.get_or_init(|| BayDepth::new(contour, outside_of));
            depth
                .as_ref()
                .is_none_or(|d| d.at(at(&rings, s.from)) <= DEEP_BAY_MM)
        };
        let clear = |s: &Slit| slit_lies_clear(&rings, s, &other_slice);
        let slit = shortest_clear(&rings, h, step, admissible, clear, clearance, shallow)?;
        made.push((at(&rings, slit.from), at(&rings, slit.to)));
        out.push(slit);
    }
    Some(out)
}

/// Whether the middle half of every slit of `slits` (joining `rings`: the contour, then the
/// holes in their order) lies clear of the contours `outside_of`, as [`slits`] asks of the
/// slits it prefers: over the void on that side, not over its material.
pub fn lie_clear(rings: &[&[Point]], slits: &[Slit], outside_of: &[&[Point]]) -> bool {
    let other_slice: Vec<BoundaryIndex> =
        outside_of.iter().map(|o| BoundaryIndex::new(o)).collect();
    slits.iter().all(|s| {
        rings.get(s.from.ring).is_some()
            && rings.get(s.to.ring).is_some()
            && slit_lies_clear(rings, s, &other_slice)
    })
}

/// A slit's middle half: its quarter, half and three-quarter points.
fn middle_half(rings: &[&[Point]], s: &Slit) -> [Point; 3] {
    let (a, b) = (at(rings, s.from), at(rings, s.to));
    [0.25, 0.5, 0.75].map(|t| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])])
}

/// Whether the slit's middle half lies clear of `other_slice`: a clearance above [`CLEAR`],
/// without measuring it.
fn slit_lies_clear(rings: &[&[Point]], s: &Slit, other_slice: &[BoundaryIndex]) -> bool {
    middle_half(rings, s)
        .iter()
        .all(|&p| clear_of(other_slice, p, CLEAR))
}

/// Where along `a`–`b` (0 to 1) the point closest to `p` lies.
fn project(a: Point, b: Point, p: Point) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The point `t` of the way along edge `e` of a ring of `n` points, as a foot snapped to a
/// vertex when close.
fn snapped(ring: usize, n: usize, e: usize, t: f64) -> Foot {
    let (edge, t) = if t < SNAP {
        (e, 0.0)
    } else if t > 1.0 - SNAP {
        ((e + 1) % n, 0.0)
    } else {
        (e, t)
    };
    Foot { ring, edge, t }
}

/// The nearest points of `ring` to `p` that are local minima of the distance along the
/// ring (each distinct foot once).
fn local_feet(ring_id: usize, ring: &[Point], p: Point, out: &mut Vec<Foot>) {
    let n = ring.len();
    // Where along each edge its point nearest to `p` lies.
    let nearest: Vec<f64> = (0..n)
        .map(|e| project(ring[e], ring[(e + 1) % n], p))
        .collect();
    for (e, &t) in nearest.iter().enumerate() {
        let interior = t > 0.0 && t < 1.0;
        // A vertex is a local minimum when the edges either side both end nearest at it.
        let at_vertex = t == 0.0 && nearest[(e + n - 1) % n] == 1.0;
        if interior || at_vertex {
            let f = snapped(ring_id, n, e, t);
            if out.last() != Some(&f) {
                out.push(f);
            }
        }
    }
}

/// A `clearance` above this (mm) counts as lying clear.
const CLEAR: f64 = 0.0;

/// A slit lying clear is looked for up to this many times the shortest candidate's length
/// (the rounds of [`ROUND_FACTORS`] up to it) once a slit that does not lie clear is
/// admissible: a wall closing the mouth can be thicker than the thin wall over the other
/// slice's bone. Further out, longer slits take the GE head's fringed keyholes onto worse
/// crossings (64: 41,082 -> 41,432 crossing faces there).
const CLEAR_SEARCH: f64 = 4.0;

/// An admissible slit from rings `0..h` to ring `h` among the local minima of the distance
/// from points every `step` mm along either side to the other (a mouth's narrowest crossing
/// rarely ends at a vertex of either), tried in rounds of growing length: the shortest with
/// a `clearance` above [`CLEAR`] of the first round holding one (searched up to
/// [`CLEAR_SEARCH`] times the shortest once any slit is admissible), or failing that the
/// greatest `clearance` of the first round holding an admissible slit.
///
/// `clear(s)` must say whether `clearance(s) > CLEAR`: the values are only measured for the
/// slits that do not lie clear, when their round ends without a clear one.
fn shortest_clear(
    rings: &[&[Point]],
    h: usize,
    step: f64,
    admissible: impl Fn(&Slit) -> bool,
    clear: impl Fn(&Slit) -> bool,
    clearance: impl Fn(&Slit) -> f64,
    shallow: impl Fn(&Slit) -> bool,
) -> Option<Slit> {
    let mut all: Vec<(f64, Slit)> = Vec::new();
    let mut feet = Vec::new();
    let len2 = |s: &Slit| {
        let (a, b) = (at(rings, s.from), at(rings, s.to));
        (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
    };
    // Points every `step` along ring `r`, as feet.
    let samples = |r: usize| -> Vec<Foot> {
        let ring = rings[r];
        let n = ring.len();
        let mut out = Vec::new();
        for e in 0..n {
            let (a, b) = (ring[e], ring[(e + 1) % n]);
            let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            let pieces = ((len / step).ceil() as usize).clamp(1, 1 << 16);
            for k in 0..pieces {
                let t = k as f64 / pieces as f64;
                // Samples beside a vertex are the vertex (the next edge's first sample).
                if k == 0 || (SNAP..=1.0 - SNAP).contains(&t) {
                    out.push(Foot {
                        ring: r,
                        edge: e,
                        t,
                    });
                }
            }
        }
        out
    };
    // Slits from `sample` to its local feet on ring `onto`, the sample at the slit's `from`
    // end when it lies on a ring before the hole (slits run from a contour ring to the hole).
    let mut reach = |sample: Foot, onto: usize| {
        feet.clear();
        local_feet(onto, rings[onto], at(rings, sample), &mut feet);
        all.extend(
            feet.iter()
                .map(|&foot| {
                    if sample.ring < onto {
                        Slit {
                            from: sample,
                            to: foot,
                        }
                    } else {
                        Slit {
                            from: foot,
                            to: sample,
                        }
                    }
                })
                .map(|s| (len2(&s), s)),
        );
    };
    let hole_samples = samples(h);
    for r in 0..h.min(rings.len()) {
        for from in samples(r) {
            reach(from, h);
        }
        for &to in &hole_samples {
            reach(to, r);
        }
    }
    let key = |s: &Slit| (s.from.ring, s.from.edge, s.to.ring, s.to.edge);
    all.retain(|c| c.0 > 0.0);
    // Shortest first; ties in index order, so the choice is deterministic.
    all.sort_by(|x, y| {
        x.0.total_cmp(&y.0)
            .then(key(&x.1).cmp(&key(&y.1)))
            .then(x.1.from.t.total_cmp(&y.1.from.t))
            .then(x.1.to.t.total_cmp(&y.1.to.t))
    });
    all.dedup_by(|x, y| x.1 == y.1);
    let min = all.first()?.0;
    let mut start = 0;
    let mut fallback: Option<Slit> = None;
    // The shortest admissible slit lying clear but ending deep in a bay, with its squared
    // length: a clear slit ending near the open field is looked for up to
    // [`SHALLOW_SEARCH`] times its length, and it is kept if there is none.
    let mut deep: Option<(f64, Slit)> = None;
    for limit in ROUND_FACTORS
        .iter()
        .map(|f| f * f * min)
        .chain(std::iter::once(f64::INFINITY))
    {
        if deep.is_none() && fallback.is_some() && limit > CLEAR_SEARCH * CLEAR_SEARCH * min {
            break;
        }
        let end = all.partition_point(|c| c.0 < limit);
        // Shortest first, the first admissible slit lying clear; the others kept, to be
        // tried by how far they lie clear (the sort is stable: ties stay shortest first).
        let mut unclear: Vec<usize> = Vec::new();
        for (i, &(l2, slit)) in all.iter().enumerate().take(end).skip(start) {
            if let Some((d2, d)) = deep {
                if l2 > SHALLOW_SEARCH * SHALLOW_SEARCH * d2 {
                    return Some(d);
                }
            }
            if clear(&slit) {
                if admissible(&slit) {
                    if shallow(&slit) {
                        return Some(slit);
                    }
                    deep.get_or_insert((l2, slit));
                }
            } else if fallback.is_none() && deep.is_none() {
                unclear.push(i);
            }
        }
        // Past a deep slit only a shallow clear one is looked for; no fallback is needed.
        if deep.is_none() && fallback.is_none() {
            let mut unclear: Vec<(f64, usize)> = unclear
                .into_iter()
                .map(|i| (clearance(&all[i].1), i))
                .collect();
            unclear.sort_by(|x, y| y.0.total_cmp(&x.0));
            fallback = unclear
                .iter()
                .find(|&&(_, i)| admissible(&all[i].1))
                .map(|&(_, i)| all[i].1);
        }
        start = end;
    }
    deep.map(|(_, d)| d).or(fallback)
}

/// A slit whose outer end lies deeper than this (mm) into a bay of the other slice ends over
/// that bay's inside, not over its mouth (see [`BayDepth`]).
const DEEP_BAY_MM: f64 = 10.0;

/// Past a clear slit ending deep in a bay, a clear one ending near the open field is looked
/// for up to this many times its length.
const SHALLOW_SEARCH: f64 = 8.0;

/// How far into a bay of the other slice a point lies: the length of the shortest path from
/// it to the open field around both slices that keeps over the other slice's void (outside
/// its contours), on a raster with 8-neighbour steps.
///
/// The wall that closes a bay's mouth into a hole lies over the mouth: beyond its outer side
/// the void of the other slice opens at once. A thin wall elsewhere can lie over that slice's
/// void too, where the bay is wider than the hole, but beyond it the void is still the bay's
/// inside, a long way round from the open field (skull surface 353: a 1.8 mm slit lying
/// 1.05 mm clear of the next contour, 30 mm inside its bay).
struct BayDepth {
    grid: Grid,
    dist: Vec<f64>,
}

/// Samples along the longer side of a [`BayDepth`] raster, and its finest cell (mm).
const BAY_RASTER: f64 = 400.0;
const BAY_CELL_MM: f64 = 0.25;

impl BayDepth {
    fn new(contour: &[Point], outside_of: &[&[Point]]) -> Option<Self> {
        if outside_of.is_empty() {
            return None;
        }
        let both: Vec<&[Point]> = std::iter::once(contour)
            .chain(outside_of.iter().copied())
            .collect();
        let b = bbox_of(&both);
        let cell = ((b[2] - b[0]).max(b[3] - b[1]) / BAY_RASTER).max(BAY_CELL_MM);
        // Two samples of open field all round (at cell centres: the box shifted by half a
        // cell); the cell bounds the size.
        let h = 0.5 * cell;
        let grid = Grid::covering(
            [b[0] + h, b[1] + h, b[2] + h, b[3] + h],
            cell,
            2,
            usize::MAX,
        )
        .ok()?;
        let (width, height) = (grid.width, grid.height);
        let solid = inside_mask(&grid, outside_of);
        // Dijkstra from the raster's border through the void.
        let mut dist = vec![f64::INFINITY; width * height];
        let mut heap = BinaryHeap::new();
        for r in 0..height {
            for c in 0..width {
                let k = r * width + c;
                if (r == 0 || c == 0 || r == height - 1 || c == width - 1) && !solid[k] {
                    dist[k] = 0.0;
                    heap.push(Reverse((0u64, k)));
                }
            }
        }
        let diagonal = std::f64::consts::SQRT_2 * cell;
        while let Some(Reverse((bits, k))) = heap.pop() {
            let d = f64::from_bits(bits);
            if d > dist[k] {
                continue;
            }
            let (r, c) = (k / width, k % width);
            for (rr, cc) in neighbours(r, c, width, height) {
                let j = rr * width + cc;
                if solid[j] {
                    continue;
                }
                let nd = d + if rr != r && cc != c { diagonal } else { cell };
                if nd < dist[j] {
                    dist[j] = nd;
                    // Non-negative floats order as their bits.
                    heap.push(Reverse((nd.to_bits(), j)));
                }
            }
        }
        Some(BayDepth { grid, dist })
    }

    /// The depth at `p`: the least over the samples round it plus the way there (a point on
    /// a contour of this slice may lie over the other slice's material by a hair).
    fn at(&self, p: Point) -> f64 {
        let g = &self.grid;
        let q = g.to_pixel(p);
        let (c, r) = (q[0].round() as isize, q[1].round() as isize);
        let mut best = f64::INFINITY;
        for rr in r - 1..=r + 1 {
            for cc in c - 1..=c + 1 {
                if rr < 0 || cc < 0 || rr >= g.height as isize || cc >= g.width as isize {
                    continue;
                }
                let (rr, cc) = (rr as usize, cc as usize);
                best = best.min(self.dist[rr * g.width + cc] + dist(p, g.point(rr, cc)));
            }
        }
        best
    }
}

/// Whether `a`–`b` meets an edge of `walls` other than the edges at its own two feet (the
/// first walls are the rings that the feet of `s` index).
fn crosses_walls(a: Point, b: Point, walls: &[BoundaryIndex], s: &Slit) -> bool {
    // The edges a foot lies on: its own edge, and the one before when it is a vertex.
    let own = |w: usize, i: usize, f: Foot| {
        let n = walls[w].points().len();
        f.ring == w && (i == f.edge || (f.t == 0.0 && (i + 1) % n == f.edge))
    };
    walls.iter().enumerate().any(|(w, index)| {
        // A wall whose box lies strictly off the slit's has every edge's box off it too.
        let bx = index.bbox();
        if boxes_disjoint([bx[0], bx[1]], [bx[2], bx[3]], a, b) {
            return false;
        }
        let wall = index.points();
        let n = wall.len();
        (0..n).any(|i| {
            if own(w, i, s.from) || own(w, i, s.to) {
                return false;
            }
            let (p, q) = (wall[i], wall[(i + 1) % n]);
            !boxes_disjoint(p, q, a, b) && segments_intersect(a, b, p, q)
        })
    })
}

/// Where slit ends are searched along the rings (mm) for `hole`: fine against its size, as a
/// mouth may be narrow, but not below the contours' own precision.
pub fn search_step(hole: &[Point]) -> f64 {
    (perimeter(hole) / 256.0).max(0.02)
}

/// `rings` (the contour, then the holes `slits` join) with the feet of `slits` and `also`
/// inserted, and the keyhole loop joining them by `slits`, cut into pieces of at most `step`
/// mm: for points in the plane or in space. `also` are the slits of the same rings' other
/// keyhole on the same slice (the region across the slice ends or starts on that one: see
/// `stages::s3_correspondence::Joined::also`): with their feet in both loops, the two share
/// every ring vertex.
pub fn join_rings<const D: usize>(
    rings: &[&[[f64; D]]],
    slits: &[Slit],
    also: &[Slit],
    step: f64,
) -> (Vec<Vec<[f64; D]>>, Vec<[f64; D]>) {
    let lerp = |a: [f64; D], b: [f64; D], t: f64| -> [f64; D] {
        std::array::from_fn(|d| a[d] + t * (b[d] - a[d]))
    };
    let feet: Vec<Slit> = slits.iter().chain(also).copied().collect();
    let with: Vec<Vec<[f64; D]>> = rings
        .iter()
        .enumerate()
        .map(|(r, pts)| with_feet(pts, r, &feet, lerp))
        .collect();
    let refs: Vec<&[[f64; D]]> = with.iter().map(|r| r.as_slice()).collect();
    let pieces = |a: [f64; D], b: [f64; D]| {
        let len = (0..D).map(|d| (b[d] - a[d]).powi(2)).sum::<f64>().sqrt();
        ((len / step).ceil() as usize).clamp(1, 4096)
    };
    let between = |a: [f64; D], b: [f64; D], n: usize| -> Vec<[f64; D]> {
        (1..n).map(|s| lerp(a, b, s as f64 / n as f64)).collect()
    };
    let joined = keyhole_loop_among(&refs, slits, &feet, pieces, between);
    (with, joined)
}

/// Ring `ring` of a keyhole with the feet of `slits` that fall inside its edges inserted
/// (`lerp(a, b, t)`), so the loop and the contour on its own share every vertex.
pub fn with_feet<T: Copy>(
    points: &[T],
    ring: usize,
    slits: &[Slit],
    lerp: impl Fn(T, T, f64) -> T,
) -> Vec<T> {
    let n = points.len();
    let mut inserted: Vec<(usize, f64)> = feet_on(ring, slits)
        .filter(|f| f.t > 0.0)
        .map(|f| (f.edge, f.t))
        .collect();
    inserted.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    inserted.dedup();
    let mut out = Vec::with_capacity(n + inserted.len());
    let mut next = inserted.iter().peekable();
    for i in 0..n {
        out.push(points[i]);
        while let Some(&&(e, t)) = next.peek() {
            if e != i {
                break;
            }
            out.push(lerp(points[i], points[(i + 1) % n], t));
            next.next();
        }
    }
    out
}

fn feet_on(ring: usize, slits: &[Slit]) -> impl Iterator<Item = Foot> + '_ {
    slits
        .iter()
        .flat_map(|s| [s.from, s.to])
        .filter(move |f| f.ring == ring)
}

/// Index of foot `f` in its ring after [`with_feet`].
fn index_after_feet(f: Foot, slits: &[Slit]) -> usize {
    let mut before: Vec<(usize, f64)> = feet_on(f.ring, slits)
        .filter(|g| g.t > 0.0 && (g.edge, g.t) < (f.edge, f.t))
        .map(|g| (g.edge, g.t))
        .collect();
    before.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    before.dedup();
    f.edge + before.len() + usize::from(f.t > 0.0)
}

/// The keyhole loop of `rings` (the contour, then the joined holes in the order of `slits`,
/// each already [`with_feet`]): the contour's points, and at each slit's foot the slit's
/// interior points (`between(a, b, pieces)`: the `pieces − 1` points dividing `a`–`b`
/// evenly), the hole from the slit's end round to it again, the slit's points back and the
/// foot again. `pieces(a, b)` says how many pieces a slit is cut into.
pub fn keyhole_loop<T: Copy>(
    rings: &[&[T]],
    slits: &[Slit],
    pieces: impl Fn(T, T) -> usize,
    between: impl Fn(T, T, usize) -> Vec<T>,
) -> Vec<T> {
    keyhole_loop_among(rings, slits, slits, pieces, between)
}

/// [`keyhole_loop`] of rings [`with_feet`] of `feet` (the slits' own and others').
fn keyhole_loop_among<T: Copy>(
    rings: &[&[T]],
    slits: &[Slit],
    feet: &[Slit],
    pieces: impl Fn(T, T) -> usize,
    between: impl Fn(T, T, usize) -> Vec<T>,
) -> Vec<T> {
    let ends: Vec<(usize, usize)> = slits
        .iter()
        .map(|s| (index_after_feet(s.from, feet), index_after_feet(s.to, feet)))
        .collect();
    let mut out = Vec::new();
    emit(0, 0, rings, slits, &ends, &pieces, &between, &mut out);
    out
}

#[allow(clippy::too_many_arguments)]
fn emit<T: Copy>(
    ring: usize,
    start: usize,
    rings: &[&[T]],
    slits: &[Slit],
    ends: &[(usize, usize)],
    pieces: &impl Fn(T, T) -> usize,
    between: &impl Fn(T, T, usize) -> Vec<T>,
    out: &mut Vec<T>,
) {
    let pts = rings[ring];
    let n = pts.len();
    for k in 0..n {
        let i = (start + k) % n;
        out.push(pts[i]);
        // Holes joined at this point, in the order they were joined.
        for (s, &(from, to)) in slits.iter().zip(ends) {
            if s.from.ring != ring || from != i {
                continue;
            }
            let (a, b) = (pts[i], rings[s.to.ring][to]);
            let inner = between(a, b, pieces(a, b).max(1));
            out.extend(inner.iter().copied());
            emit(s.to.ring, to, rings, slits, ends, pieces, between, out);
            out.push(b);
            out.extend(inner.iter().rev().copied());
            out.push(a);
        }
    }
}

/// The keyhole loop `joined` (counter-clockwise: the material on its left) with its slits
/// opened into channels `width` wide: every point the loop visits twice (a slit's feet and
/// interior points) moves `width / 2` to the left of the slit's direction there, so the two
/// passes of a slit part, each into the material beside it. For a loop a region runs on
/// through (see `stages::s3_correspondence::Problem::Link`), where no other region shares
/// its points: its fitted curve takes each pass of a zero-width slit its own way, and the
/// passes crossed. Slits open one at a time, in loop order, each only if the loop then
/// does not cross itself, else each of its passes alone (the other staying put) if that
/// does not (a slit shorter than the channel is wide, a foot at a sharp corner, the ring
/// running beside a pass); `None` if the loop has slits and none opens.
pub fn open_slits(joined: &[Point], width: f64) -> Option<Vec<Point>> {
    use std::collections::HashMap;
    let n = joined.len();
    if n < 3 || !(width.is_finite() && width > 0.0) {
        return None;
    }
    let key = |p: &Point| p.map(f64::to_bits);
    let mut visits: HashMap<[u64; 2], usize> = HashMap::new();
    for p in joined {
        *visits.entry(key(p)).or_default() += 1;
    }
    let twice = |p: &Point| visits[&key(p)] >= 2;
    let moved: Vec<Point> = (0..n)
        .map(|i| {
            let p = joined[i];
            if !twice(&p) {
                return p;
            }
            // Along the slit: a foot takes the direction of its slit, not of the ring, so
            // the passes part across the slit and the ring only gets a notch.
            let (prev, next) = (joined[(i + n - 1) % n], joined[(i + 1) % n]);
            let (a, b) = match (twice(&prev), twice(&next)) {
                (false, true) => (p, next),
                (true, false) => (prev, p),
                _ => (prev, next),
            };
            let d = [b[0] - a[0], b[1] - a[1]];
            let len = d[0].hypot(d[1]);
            if len.is_nan() || len <= 0.0 {
                return p;
            }
            let h = 0.5 * width / len;
            [p[0] - h * d[1], p[1] + h * d[0]]
        })
        .collect();
    // One slit: the points visited twice that a run of such points along the loop reaches,
    // runs sharing a point being the two passes of one slit (or of slits sharing a foot).
    let mut slit_of_point: HashMap<[u64; 2], usize> = HashMap::new();
    let mut parent: Vec<usize> = Vec::new();
    fn root(parent: &mut [usize], mut s: usize) -> usize {
        while parent[s] != s {
            parent[s] = parent[parent[s]];
            s = parent[s];
        }
        s
    }
    // Start where a run cannot wrap round the loop's end.
    let first = (0..n).find(|&i| !twice(&joined[i]))?;
    let mut run_of = vec![usize::MAX; n];
    let mut current: Option<usize> = None;
    for k in 1..=n {
        let i = (first + k) % n;
        if !twice(&joined[i]) {
            current = None;
            continue;
        }
        let r = *current.get_or_insert_with(|| {
            parent.push(parent.len());
            parent.len() - 1
        });
        run_of[i] = r;
        match slit_of_point.get(&key(&joined[i])) {
            Some(&other) => {
                let (a, b) = (root(&mut parent, other), root(&mut parent, r));
                parent[a.max(b)] = a.min(b);
            }
            None => {
                slit_of_point.insert(key(&joined[i]), r);
            }
        }
    }
    if parent.is_empty() {
        return Some(joined.to_vec());
    }
    let mut slits: Vec<usize> = Vec::new();
    for r in 0..parent.len() {
        let s = root(&mut parent, r);
        if !slits.contains(&s) {
            slits.push(s);
        }
    }
    let roots: Vec<usize> = (0..parent.len()).map(|r| root(&mut parent, r)).collect();
    let mut out = joined.to_vec();
    let mut opened = 0;
    // Moves the points of the runs `pick` admits, if the loop then does not cross itself.
    let mut open = |out: &mut Vec<Point>, pick: &dyn Fn(usize) -> bool| {
        let mut trial = out.clone();
        for i in (0..n).filter(|&i| run_of[i] != usize::MAX && pick(run_of[i])) {
            trial[i] = moved[i];
        }
        let ok = !crate::geometry::polygon::crosses_itself(&trial);
        if ok {
            *out = trial;
            opened += 1;
        }
        ok
    };
    for s in slits {
        if open(&mut out, &|r| roots[r] == s) {
            continue;
        }
        // A pass that cannot move (the ring runs within half the channel beside it) stays,
        // and the other moves alone: the passes still part, by half the width.
        for run in (0..roots.len()).filter(|&r| roots[r] == s) {
            open(&mut out, &|r| r == run);
        }
    }
    (opened > 0).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::{circle, is_weakly_simple, signed_area};

    fn lerp(a: Point, b: Point, t: f64) -> Point {
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
    }

    fn between(a: Point, b: Point, k: usize) -> Vec<Point> {
        (1..k).map(|s| lerp(a, b, s as f64 / k as f64)).collect()
    }

    /// A block's keyhole loop, its slit opened into a channel: the points off the slit stay,
    /// the slit's two passes part by the width, the loop stays simple and counter-clockwise
    /// and loses about the channel's area.
    #[test]
    fn opened_slits_part_by_their_width() {
        let block = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0], [0.0, 20.0]];
        let hole = vec![[15.0, 8.0], [15.0, 14.0], [25.0, 14.0], [25.0, 8.0]];
        // From the top edge's midpoint down to the hole's top edge.
        let s = Slit {
            from: Foot {
                ring: 0,
                edge: 2,
                t: 0.5,
            },
            to: Foot {
                ring: 1,
                edge: 1,
                t: 0.5,
            },
        };
        let rings: Vec<Vec<Point>> = [block.as_slice(), hole.as_slice()]
            .iter()
            .enumerate()
            .map(|(r, pts)| with_feet(pts, r, &[s], lerp))
            .collect();
        let refs: Vec<&[Point]> = rings.iter().map(|r| r.as_slice()).collect();
        let joined = keyhole_loop(&refs, &[s], |_, _| 4, between);
        let opened = open_slits(&joined, 0.4).expect("simple");
        assert_eq!(opened.len(), joined.len());
        let moved: Vec<(Point, Point)> = joined
            .iter()
            .zip(&opened)
            .filter(|(a, b)| a != b)
            .map(|(a, b)| (*a, *b))
            .collect();
        // The slit's feet and its 3 interior points, twice each.
        assert_eq!(moved.len(), 10, "{moved:?}");
        for (a, b) in &moved {
            assert!((dist(*a, *b) - 0.2).abs() < 1e-12, "{a:?} → {b:?}");
        }
        // Interior slit points: x = 20 ± 0.2, the passes 0.4 apart.
        let xs: Vec<f64> = moved
            .iter()
            .filter(|(a, _)| a[1] > 14.0 && a[1] < 20.0)
            .map(|(_, b)| b[0])
            .collect();
        assert!(xs
            .iter()
            .all(|x| (x - 19.8).abs() < 1e-9 || (x - 20.2).abs() < 1e-9));
        assert!(xs.iter().any(|x| (x - 19.8).abs() < 1e-9));
        assert!(xs.iter().any(|x| (x - 20.2).abs() < 1e-9));
        let (before, after) = (signed_area(&joined), signed_area(&opened));
        assert!(
            after > 0.0 && before - after > 0.3 * 6.0 * 0.4,
            "{before} → {after}"
        );
        assert!(before - after < 1.2 * 6.0 * 0.4, "{before} → {after}");
        // A loop without slits comes back as it was; a channel wider than the block would
        // cross its sides: no opening.
        assert_eq!(open_slits(&block, 0.4), Some(block.clone()));
        assert_eq!(open_slits(&joined, 100.0), None);
    }

    /// Two slits: one opens; the other's channel, as wide, would leave the block on one
    /// side, so that pass stays and only the other may move. Each slit is judged alone.
    #[test]
    fn each_slit_opens_only_where_the_loop_stays_simple() {
        let block = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0], [0.0, 20.0]];
        let top = vec![[15.0, 8.0], [15.0, 14.0], [25.0, 14.0], [25.0, 8.0]];
        let low = vec![[2.0, 1.0], [2.0, 3.0], [6.0, 3.0], [6.0, 1.0]];
        let foot = |ring, edge, t| Foot { ring, edge, t };
        let slits = [
            Slit {
                from: foot(0, 2, 0.5),
                to: foot(1, 1, 0.5),
            },
            Slit {
                from: foot(0, 0, 0.1),
                to: foot(2, 3, 0.5),
            },
        ];
        let rings: Vec<Vec<Point>> = [block.as_slice(), top.as_slice(), low.as_slice()]
            .iter()
            .enumerate()
            .map(|(r, pts)| with_feet(pts, r, &slits, lerp))
            .collect();
        let refs: Vec<&[Point]> = rings.iter().map(|r| r.as_slice()).collect();
        let joined = keyhole_loop(&refs, &slits, |_, _| 4, between);
        // Both open at 0.4 mm: two slits of five points, each visited twice.
        let narrow = open_slits(&joined, 0.4).expect("both open");
        let moved = joined.iter().zip(&narrow).filter(|(a, b)| a != b).count();
        assert_eq!(moved, 20);
        // At 12 mm the low slit's left pass would run out through the block's left side.
        let wide = open_slits(&joined, 12.0).expect("the top slit opens");
        assert!(!crate::geometry::polygon::crosses_itself(&wide));
        assert!(wide.iter().all(|p| p[0] >= 0.0), "{wide:?}");
        // The top slit's interior points part to x = 14 and 26.
        let parted = |x: f64| wide.iter().any(|p| (p[0] - x).abs() < 1e-9 && p[1] > 15.0);
        assert!(parted(14.0) && parted(26.0));
    }

    /// A 40 × 20 block with a 10 × 10 hole near its top edge; and the block on the slice
    /// below, with a bay where the hole is that opens through the top edge, 8 mm wide at
    /// the mouth.
    fn bay_and_hole() -> (Vec<Point>, Vec<Point>, Vec<Point>) {
        let block = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0], [0.0, 20.0]];
        let hole = vec![
            [15.0, 8.0],
            [15.0, 18.0],
            [20.0, 18.0],
            [25.0, 18.0],
            [25.0, 8.0],
        ];
        let bay = vec![
            [0.0, 0.0],
            [40.0, 0.0],
            [40.0, 20.0],
            [24.0, 20.0],
            [24.0, 8.0],
            [16.0, 8.0],
            [16.0, 20.0],
            [0.0, 20.0],
        ];
        (block, hole, bay)
    }

    /// The loop of one contour and its joined holes, checked for what every keyhole is:
    /// weakly simple, counter-clockwise, with the material's area.
    fn loop_of(contour: &[Point], holes: &[&[Point]], s: &[Slit]) -> Vec<Point> {
        let rings: Vec<Vec<Point>> = std::iter::once(contour)
            .chain(holes.iter().copied())
            .enumerate()
            .map(|(r, pts)| with_feet(pts, r, s, lerp))
            .collect();
        let refs: Vec<&[Point]> = rings.iter().map(|r| r.as_slice()).collect();
        let l = keyhole_loop(&refs, s, |_, _| 4, between);
        let want: f64 = signed_area(contour) + holes.iter().map(|h| signed_area(h)).sum::<f64>();
        assert!(
            (signed_area(&l) - want).abs() < 1e-9,
            "{} vs {want}",
            signed_area(&l)
        );
        assert!(is_weakly_simple(&l), "{l:?}");
        l
    }

    #[test]
    fn a_hole_over_a_bay_joins_across_the_closed_mouth() {
        let (block, hole, bay) = bay_and_hole();
        let s = slits(&block, &[&hole], &[], &[&bay], 0.5, true).expect("a slit exists");
        // Straight up from the hole's top edge to the block's top edge (from x = 40 to 0),
        // across the mouth, 2 mm.
        let (a, b) = (
            at(&[&block, &hole], s[0].from),
            at(&[&block, &hole], s[0].to),
        );
        assert_eq!((s[0].from.ring, s[0].from.edge, s[0].to.ring), (0, 2, 1));
        assert!(
            (a[1] - 20.0).abs() < 1e-12 && (b[1] - 18.0).abs() < 1e-12,
            "{a:?} {b:?}"
        );
        assert!(
            (a[0] - b[0]).abs() < 1e-9 && a[0] > 16.0 && a[0] < 24.0,
            "{a:?} {b:?}"
        );
        let l = loop_of(&block, &[&hole], &s);
        // The block and the hole with their feet, the slit's 3 interior points out and
        // back, the hole's foot and the block's again.
        let inserted = [s[0].from, s[0].to].iter().filter(|f| f.t > 0.0).count();
        assert_eq!(l.len(), 4 + 5 + inserted + 3 + 1 + 3 + 1);
        assert!(l.contains(&a) && l.contains(&b));
    }

    /// The hole reaches within 1 mm of the block's left side and `top` mm of its top. On the
    /// other slice the bay under it opens through the top edge (x 16–24), and its left wall
    /// is 0.4 mm thick: the 1 mm slit to the left side is the shortest, and its midpoint lies
    /// just outside the other slice's contour, but most of it lies over that wall. The slit
    /// must close the mouth. Returns its two ends.
    fn slit_past_a_thin_wall(top: f64) -> (Point, Point) {
        let y = 20.0 - top;
        let block = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0], [0.0, 20.0]];
        let hole = vec![[1.0, 8.0], [1.0, y], [20.0, y], [25.0, y], [25.0, 8.0]];
        let bay = vec![
            [0.0, 0.0],
            [40.0, 0.0],
            [40.0, 20.0],
            [24.0, 20.0],
            [24.0, y],
            [25.0, y],
            [25.0, 8.0],
            [0.4, 8.0],
            [0.4, y],
            [16.0, y],
            [16.0, 20.0],
            [0.0, 20.0],
        ];
        let s = slits(&block, &[&hole], &[], &[&bay], 0.25, true).expect("a slit exists");
        loop_of(&block, &[&hole], &s);
        (
            at(&[&block, &hole], s[0].from),
            at(&[&block, &hole], s[0].to),
        )
    }

    #[test]
    fn a_thin_wall_over_the_other_slices_wall_is_passed_for_the_mouth() {
        // 1.8 mm at the mouth: the same round of lengths as the 1 mm wall; 3 mm: the next.
        for top in [1.8, 3.0] {
            let (a, b) = slit_past_a_thin_wall(top);
            assert!(
                (a[1] - 20.0).abs() < 1e-12 && (b[1] - (20.0 - top)).abs() < 1e-12,
                "{top}: {a:?} {b:?}"
            );
            assert!(a[0] > 16.0 && a[0] < 24.0, "{top}: {a:?} {b:?}");
        }
    }

    #[test]
    fn a_thin_wall_over_the_inside_of_a_bay_is_passed_for_the_mouth() {
        // On the other slice the bay under the hole is wider than the hole and reaches past
        // the block's top, but opens to the field only through a channel at the bottom
        // (x 18–22). The 3.5 mm top wall lies clear over the bay's inside, 40 mm round from
        // the field; the 12 mm wall over the channel closes the mouth.
        let block = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 40.0], [0.0, 40.0]];
        let hole = vec![[10.0, 12.0], [10.0, 36.5], [30.0, 36.5], [30.0, 12.0]];
        let other = vec![
            [-2.0, -2.0],
            [18.0, -2.0],
            [18.0, 5.0],
            [8.0, 5.0],
            [8.0, 42.0],
            [32.0, 42.0],
            [32.0, 5.0],
            [22.0, 5.0],
            [22.0, -2.0],
            [42.0, -2.0],
            [42.0, 45.0],
            [-2.0, 45.0],
        ];
        let depth = BayDepth::new(&block, &[&other]).expect("a field");
        assert!(depth.at([20.0, 40.0]) > 40.0, "{}", depth.at([20.0, 40.0]));
        assert!(depth.at([20.0, 0.0]) < 4.0, "{}", depth.at([20.0, 0.0]));
        // Without the bay depth, the short wall wins.
        let top = slits(&block, &[&hole], &[], &[&other], 0.5, false).expect("a slit exists");
        assert!((at(&[&block, &hole], top[0].from)[1] - 40.0).abs() < 1e-12);
        let s = slits(&block, &[&hole], &[], &[&other], 0.5, true).expect("a slit exists");
        loop_of(&block, &[&hole], &s);
        let (a, b) = (
            at(&[&block, &hole], s[0].from),
            at(&[&block, &hole], s[0].to),
        );
        assert!(
            a[1].abs() < 1e-12 && (b[1] - 12.0).abs() < 1e-12,
            "{a:?} {b:?}"
        );
        assert!(a[0] > 18.0 && a[0] < 22.0, "{a:?} {b:?}");
    }

    #[test]
    fn a_slit_stays_over_the_other_slices_void() {
        // Below, the block has no bay: there is nothing to open into.
        let (block, hole, _) = bay_and_hole();
        assert_eq!(slits(&block, &[&hole], &[], &[&block], 0.5, true), None);
    }

    #[test]
    fn slits_keep_off_the_other_holes() {
        let (block, hole, bay) = bay_and_hole();
        // A thin hole across the whole way out: every other way's midpoint lies over the
        // material below.
        let wide = vec![[10.0, 18.5], [10.0, 19.5], [30.0, 19.5], [30.0, 18.5]];
        assert_eq!(slits(&block, &[&hole], &[&wide], &[&bay], 0.5, true), None);
        // One that leaves the middle of the mouth free.
        let short = vec![[10.0, 18.5], [10.0, 19.5], [19.0, 19.5], [19.0, 18.5]];
        let s = slits(&block, &[&hole], &[&short], &[&bay], 0.5, true).expect("a way past it");
        let a = at(&[&block, &hole], s[0].from);
        assert!(a[0] > 19.0 && a[0] < 24.0, "{a:?}");
    }

    #[test]
    fn several_holes_join_one_after_another() {
        let outer = circle(0.0, 0.0, 20.0, 64, true);
        let h1 = circle(-8.0, 0.0, 4.0, 24, false);
        let h2 = circle(8.0, 0.0, 4.0, 24, false);
        // Below, a small disc in the middle: the void it leaves is everywhere else.
        let below = circle(0.0, 0.0, 2.0, 16, true);
        let s = slits(&outer, &[&h1, &h2], &[], &[&below], 0.5, true).expect("both join");
        // The way between the holes passes over the disc, so each joins the rim.
        assert!(s.iter().all(|s| s.from.ring == 0));
        let l = loop_of(&outer, &[&h1, &h2], &s);
        // Feet inside an edge add a point to their ring.
        let inserted = s
            .iter()
            .flat_map(|s| [s.from, s.to])
            .filter(|f| f.t > 0.0)
            .count();
        assert_eq!(l.len(), 64 + inserted + 2 * (3 + 24 + 1 + 3 + 1));
    }

    #[test]
    fn a_hole_may_join_through_a_hole_joined_before() {
        // The second hole lies behind the first, seen from the rim.
        let outer = circle(0.0, 0.0, 20.0, 64, true);
        let h1 = circle(12.0, 0.0, 3.0, 24, false);
        let h2 = circle(4.0, 0.0, 3.0, 24, false);
        let below = circle(-10.0, 0.0, 4.0, 16, true);
        let s = slits(&outer, &[&h1, &h2], &[], &[&below], 0.5, true).expect("both join");
        assert_eq!(s[1].from.ring, 1, "{s:?}");
        loop_of(&outer, &[&h1, &h2], &s);
    }
}
