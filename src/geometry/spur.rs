//! Arm spurs (beyond the paper): a thin arm that the curve beside a region's end curve has and
//! the end curve lacks, most often an arm that grows between an intermediate contour and the
//! next contour.
//!
//! A branching's intermediate contour often ends well short of an arm that the contour half a
//! slice away has: on the skull, a sliver of bone 2 mm wide that reaches 100 mm further one
//! slice up. Skinned as they are, both walls of the arm join the loop's last few points: two
//! sheets half a slice apart fan out over 100 mm, nearly flat and 2 mm apart, and cross
//! (MeshLab counted 6,457 crossing faces on one such surface). Here the loop grows a
//! zero-width spur along the arm's medial line, in its own plane, out and back, so each wall
//! of the arm rises from the spur beside it, as contours rise to ridge loops at caps
//! ([`super::ridge`]). The spur adds no area, so the loop still tiles its plane with the
//! loops it shares it with.
//!
//! In: the loop and its neighbour (the next curve of the region) in one 2-D frame, with the
//! same orientation; `reach` (mm): the neighbour's points farther than this outside the loop
//! belong to an arm; `step` (mm) the sampling; `tol` (mm) the spur's compression. Out: the
//! loop with one spur per arm that passes the checks below, each leaving from the loop vertex
//! nearest the arm's base (visited twice), its points out and then back, so every spur edge
//! is used once in each direction and a mesh zipped onto the loop stays closed.
//!
//! An arm is a run of the neighbour's samples farther than `reach` outside the loop, at least
//! [`ARM_REACHES`] reaches deep. Its two walls pair at equal fractions of their lengths from the
//! base, with the tip that makes the pairs closest, like a ridge loop's sides; the arm must be
//! [`ARM_RATIO`] times deeper than the pairs' mean distance. Where the root widens, the walls
//! are paired again from where its chords come clean, and the spur runs through the pairs'
//! midpoints. It is kept only if every cross chord stays inside the neighbour, the spur
//! crosses neither curve nor folds, and one of the loop's own vertices lies within
//! [`ARM_REACHES`] reaches of its root: no vertex is inserted, as the loops across the plane
//! share the loop's vertices and no others. A run that fails these checks gets a walk round
//! its lobe's medial tree instead, if one fits ([`super::lobe`]); such spurs are marked, for
//! the caller keeps them only where they help.

use std::collections::HashMap;

use super::lobe::lobe_walk;
use super::polygon::{
    boundary_distance, contains, dist, perimeter, point_segment_distance, segments_intersect, Point,
};
use super::ridge::{crosses_polygon, settled_path, ArcLength};

/// An arm is at least this many reaches deep...
pub const ARM_REACHES: f64 = 4.0;
/// ...and this many times deeper than it is wide on average (the mean cross chord): wider
/// lobes fan out without folding.
pub const ARM_RATIO: f64 = 3.0;
/// Most samples of the neighbour.
const MAX_SAMPLES: usize = 16384;
/// Tip positions tried per arm in the coarse search, and cross chords per candidate.
const TIP_GRID: usize = 64;
const CHORD_SAMPLES: usize = 32;
/// A cross chord shorter than this many steps may fail its checks.
const SHORT_CHORD_STEPS: f64 = 4.0;

/// A spur: it leaves the loop at vertex `from`, walks `walk` and comes back to the vertex.
/// An arm's walk is its path from the base to the tip and back; a lobe's, the round of its
/// medial tree ([`super::lobe`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Spur {
    pub from: usize,
    pub walk: Vec<Point>,
    /// A lobe's walk rather than an arm's: the caller keeps it only where it helps.
    pub lobe: bool,
}

/// The spurs of the loop `lp` into the arms of `neighbour` (see the module doc), in the order
/// of their vertices, at most one per vertex.
pub fn arm_spurs(lp: &[Point], neighbour: &[Point], reach: f64, step: f64, tol: f64) -> Vec<Spur> {
    let mut spurs: Vec<Spur> = Vec::new();
    let length = perimeter(neighbour);
    if lp.len() < 3 || neighbour.len() < 3 || !(step > 0.0 && step < reach && length.is_finite()) {
        return spurs;
    }
    let n = ((length / step).ceil() as usize).clamp(16, MAX_SAMPLES);
    let at = ArcLength::new(neighbour);
    let samples: Vec<Point> = (0..n)
        .map(|j| at.point(j as f64 * length / n as f64))
        .collect();
    let near = EdgeGrid::new(lp, reach);
    let far: Vec<bool> = samples.iter().map(|&p| !near.within(p, reach)).collect();
    // Runs never wrap: count from a sample near the loop.
    let Some(s0) = far.iter().position(|&f| !f) else {
        return spurs;
    };
    let mut j = 0;
    while j < n {
        if !far[(s0 + j) % n] {
            j += 1;
            continue;
        }
        let start = j;
        while j < n && far[(s0 + j) % n] {
            j += 1;
        }
        let run: Vec<Point> = (start..j).map(|k| samples[(s0 + k) % n]).collect();
        // Consecutive samples are closer than `reach`, so a run far from every edge of the
        // loop is all inside or all outside it.
        if contains(lp, run[0]) {
            continue;
        }
        let spur = arm_spur(lp, neighbour, &run, reach, step, tol).or_else(|| {
            lobe_walk(lp, neighbour, &run, reach, step, tol, ARM_REACHES * reach).map(
                |(from, walk)| Spur {
                    from,
                    walk,
                    lobe: true,
                },
            )
        });
        if let Some(spur) = spur {
            if spurs.iter().all(|s| s.from != spur.from) {
                spurs.push(spur);
            }
        }
    }
    spurs.sort_by_key(|s| s.from);
    spurs
}

/// `lp` with `spurs` (from [`arm_spurs`]) inserted: after each spur's vertex, its walk
/// (`lift`ed into `lp`'s type) and the vertex again.
pub fn with_spurs<T: Copy>(lp: &[T], spurs: &[Spur], lift: impl Fn(Point) -> T) -> Vec<T> {
    let extra: usize = spurs.iter().map(|s| s.walk.len() + 1).sum();
    let mut out = Vec::with_capacity(lp.len() + extra);
    let mut next = spurs.iter().peekable();
    for (i, &p) in lp.iter().enumerate() {
        out.push(p);
        if let Some(s) = next.next_if(|s| s.from == i) {
            out.extend(s.walk.iter().map(|&q| lift(q)));
            out.push(p);
        }
    }
    out
}

/// The spur into the arm `run` (the neighbour's samples, in order, from where it leaves the
/// loop's reach to where it comes back): the loop vertex it leaves from and its points from
/// the base to the tip.
fn arm_spur(
    lp: &[Point],
    neighbour: &[Point],
    run: &[Point],
    reach: f64,
    step: f64,
    tol: f64,
) -> Option<Spur> {
    let m = run.len().checked_sub(1)?;
    if m < 8 {
        return None;
    }
    let base = mid(run[0], run[m]);
    let depth = run.iter().map(|&p| dist(p, base)).fold(0.0, f64::max);
    if depth < ARM_REACHES * reach {
        return None;
    }
    // The run at index position x (samples are evenly spaced along the neighbour).
    let along = |x: f64| {
        let x = x.clamp(0.0, m as f64);
        let i = (x.floor() as usize).min(m - 1);
        let t = x - i as f64;
        let (p, q) = (run[i], run[i + 1]);
        [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]
    };
    // A chord's ends are interpolated between samples, off the wall by up to a corner's cut
    // (a 15° corner cuts about a sixteenth of a step): touching within that is not crossing.
    let eps = step / 16.0;
    let crosses_neighbour = |a: Point, b: Point| crosses_polygon(a, b, neighbour, eps);
    let clean = |(p, q): (Point, Point)| {
        let c = mid(p, q);
        (contains(neighbour, c) || boundary_distance(neighbour, c) < eps)
            && !crosses_neighbour(p, q)
    };

    let (width, tip) = closest_pairing(&along, 0.0, m as f64);
    if depth < ARM_RATIO * width {
        return None;
    }
    // Where the arm's root widens into the rest of the contour, or the run starts on straight
    // stretches either side of it, the first chords run along the wall and cut its corners:
    // the arm proper starts after the last chord in the first half that fails. Its walls
    // are paired again from there, so that neither is longer by the root's share.
    let half = (tip.max(m as f64 - tip).ceil() as usize).max(8);
    let walls = |lo: f64, tip: f64, hi: f64, s: f64| {
        (along(lo + s * (tip - lo)), along(hi - s * (hi - tip)))
    };
    let root = (1..half / 2)
        .rev()
        .find(|&i| !clean(walls(0.0, tip, m as f64, i as f64 / half as f64)))
        .map_or(0.0, |i| (i + 1) as f64 / half as f64);
    let (lo, hi) = (root * tip, m as f64 - root * (m as f64 - tip));
    let (_, tip) = closest_pairing(&along, lo, hi);

    // Every cross chord of the arm proper inside the neighbour. A thin arm's chords are short
    // and a kink of the wall may spoil one: the path through them is checked below.
    let half = ((tip - lo).max(hi - tip).ceil() as usize).max(8);
    let mut path = Vec::with_capacity(half + 1);
    for i in 0..=half {
        let (p, q) = walls(lo, tip, hi, i as f64 / half as f64);
        if i > 0 && i < half && !clean((p, q)) && dist(p, q) >= SHORT_CHORD_STEPS * step {
            return None;
        }
        path.push(mid(p, q));
    }
    let path = settled_path(&path, tol, |a, b| {
        crosses_neighbour(a, b) || crosses_polygon(a, b, lp, eps)
    })?;

    // It may cross the neighbour where the arm's neck is thinner than its base.
    let v = departure(lp, path[0], ARM_REACHES * reach)?;
    let back = path[..path.len() - 1].iter().rev().copied();
    let walk = path.iter().copied().chain(back).collect();
    Some(Spur {
        from: v,
        walk,
        lobe: false,
    })
}

/// The loop vertex nearest `root`, if it lies within `max_link` of it and the way there is
/// clear of the loop: where a spur leaves the loop.
pub(super) fn departure(lp: &[Point], root: Point, max_link: f64) -> Option<usize> {
    let n = lp.len();
    let v = (0..n).min_by(|&a, &b| dist(lp[a], root).total_cmp(&dist(lp[b], root)))?;
    let clear = (0..n)
        .filter(|&i| i != v && (i + 1) % n != v)
        .all(|i| !segments_intersect(lp[v], root, lp[i], lp[(i + 1) % n]));
    (dist(lp[v], root) <= max_link && clear).then_some(v)
}

fn mid(p: Point, q: Point) -> Point {
    [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])]
}

/// The tip in (lo, hi) that splits the run's stretch lo..hi into two walls whose points at
/// equal fractions from the ends are closest on average, and that mean distance: a coarse
/// grid of tips, then refined around the best.
fn closest_pairing(along: &impl Fn(f64) -> Point, lo: f64, hi: f64) -> (f64, f64) {
    let mean_chord = |tip: f64, k: usize| -> f64 {
        (0..k)
            .map(|i| {
                let s = i as f64 / k as f64;
                dist(along(lo + s * (tip - lo)), along(hi - s * (hi - tip)))
            })
            .sum::<f64>()
            / k as f64
    };
    let coarse = (hi - lo) / TIP_GRID as f64;
    let mut best = (f64::INFINITY, 0.5 * (lo + hi));
    for i in 1..TIP_GRID {
        let tip = lo + i as f64 * coarse;
        let c = mean_chord(tip, CHORD_SAMPLES);
        if c < best.0 {
            best = (c, tip);
        }
    }
    let centre = best.1;
    for d in -8..=8 {
        let tip = centre + d as f64 * coarse / 8.0;
        let c = mean_chord(tip, 2 * CHORD_SAMPLES);
        if c < best.0 {
            best = (c, tip);
        }
    }
    best
}

/// The edges of a closed polygon bucketed on a square grid, to ask which lie within a
/// distance of a point without visiting them all.
struct EdgeGrid<'a> {
    pts: &'a [Point],
    cell: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
}

impl<'a> EdgeGrid<'a> {
    /// `cell` (mm) at least the distances asked of [`EdgeGrid::within`].
    fn new(pts: &'a [Point], cell: f64) -> Self {
        let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        let n = pts.len();
        let key = |x: f64| (x / cell).floor() as i64;
        for i in 0..n {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            // The cells an edge passes through: those of its pieces at most a cell long.
            let pieces = (dist(a, b) / cell).ceil().max(1.0) as usize;
            for s in 0..=pieces {
                let t = s as f64 / pieces as f64;
                let c = (key(a[0] + t * (b[0] - a[0])), key(a[1] + t * (b[1] - a[1])));
                let edges = cells.entry(c).or_default();
                if edges.last() != Some(&i) {
                    edges.push(i);
                }
            }
        }
        EdgeGrid { pts, cell, cells }
    }

    /// Whether some edge lies within `r` ≤ the cell of `p`. Such an edge has a piece end
    /// within 1.5 cells of `p`: two cells away at most.
    fn within(&self, p: Point, r: f64) -> bool {
        let n = self.pts.len();
        let (cx, cy) = (
            (p[0] / self.cell).floor() as i64,
            (p[1] / self.cell).floor() as i64,
        );
        (cx - 2..=cx + 2).any(|x| {
            (cy - 2..=cy + 2).any(|y| {
                self.cells.get(&(x, y)).is_some_and(|edges| {
                    edges
                        .iter()
                        .any(|&i| point_segment_distance(p, self.pts[i], self.pts[(i + 1) % n]) < r)
                })
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::{circle, signed_area};

    /// An arm spur's path from the base to the tip: the first half of its walk.
    fn path(s: &Spur) -> &[Point] {
        &s.walk[..s.walk.len().div_ceil(2)]
    }

    /// The axis-aligned rectangle x0..x1 × y0..y1, counter-clockwise.
    fn rect(x0: f64, x1: f64, y0: f64, y1: f64) -> Vec<Point> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    /// A ring sector of radii r0 < r1 over angles a0..a1, counter-clockwise.
    fn arc_band(r0: f64, r1: f64, a0: f64, a1: f64, n: usize) -> Vec<Point> {
        let at = |r: f64, k: usize| {
            let a = a0 + (a1 - a0) * k as f64 / n as f64;
            [r * a.cos(), r * a.sin()]
        };
        let mut pts: Vec<Point> = (0..=n).map(|k| at(r1, k)).collect();
        pts.extend((0..=n).rev().map(|k| at(r0, k)));
        pts
    }

    #[test]
    fn a_bar_reaching_beyond_the_loop_gets_a_spur_along_its_middle() {
        // The loop is a bar 2 mm wide and 30 mm long; its neighbour the same bar 70 mm long.
        let lp = rect(0.0, 2.0, 0.0, 30.0);
        let bar = rect(0.0, 2.0, 0.0, 70.0);
        let spurs = arm_spurs(&lp, &bar, 2.0, 0.5, 0.05);
        assert_eq!(spurs.len(), 1, "{spurs:?}");
        let s = &spurs[0];
        let s_path = path(s);
        // From the loop's end nearest the arm, along the bar's middle, to its far end.
        assert!(lp[s.from][1] == 30.0, "{:?}", lp[s.from]);
        for p in s_path {
            assert!(
                (p[0] - 1.0).abs() < 1e-6 && p[1] > 30.0 && p[1] <= 70.0,
                "{p:?}"
            );
        }
        assert!(s_path[0][1] < 36.0, "{:?}", s_path[0]);
        assert!(s_path[s_path.len() - 1][1] > 69.0, "{:?}", s_path.last());
        // Out and back: the loop gains no area, each spur point but the tip is visited twice
        // and the vertex it leaves from again.
        let spurred = with_spurs(&lp, &spurs, |p| p);
        assert_eq!(spurred.len(), lp.len() + 2 * s_path.len());
        assert!((signed_area(&spurred) - signed_area(&lp)).abs() < 1e-9);
        let visits = |q: Point| spurred.iter().filter(|&&p| p == q).count();
        assert_eq!(visits(lp[s.from]), 2);
        assert_eq!(visits(s_path[s_path.len() - 1]), 1);
        for &p in &s_path[..s_path.len() - 1] {
            assert_eq!(visits(p), 2);
        }
    }

    #[test]
    fn a_curved_arm_gets_a_spur_on_its_medial_arc() {
        // A sliver of a ring (radius 49–51) over 0–1.6 rad; the loop covers 0–0.4 of it.
        let lp = arc_band(49.0, 51.0, 0.0, 0.4, 40);
        let arm = arc_band(49.0, 51.0, 0.0, 1.6, 160);
        let spurs = arm_spurs(&lp, &arm, 2.0, 0.5, 0.05);
        assert_eq!(spurs.len(), 1, "{spurs:?}");
        let path = path(&spurs[0]);
        for p in path {
            let (r, a) = (p[0].hypot(p[1]), p[1].atan2(p[0]));
            assert!(a > 0.4 && a <= 1.6 + 1e-9, "angle {a}");
            if a < 1.55 {
                assert!((r - 50.0).abs() < 0.1, "radius {r} at angle {a}");
            }
        }
        let end = path[path.len() - 1];
        assert!(end[1].atan2(end[0]) > 1.57);
    }

    #[test]
    fn a_wider_neighbour_or_a_lobe_gets_no_spur() {
        // A neighbour 3 mm wider all round: nothing of it is an arm.
        let disc = circle(0.0, 0.0, 10.0, 128, true);
        let wider = circle(0.0, 0.0, 13.0, 128, true);
        assert!(arm_spurs(&disc, &wider, 2.0, 0.5, 0.05).is_empty());
        // A lobe as wide as it is deep fans out without folding.
        let block = rect(0.0, 40.0, 0.0, 20.0);
        let mut lobed = block.clone();
        lobed.splice(
            3..3,
            [[30.0, 20.0], [30.0, 40.0], [10.0, 40.0], [10.0, 20.0]],
        );
        assert!(arm_spurs(&block, &lobed, 2.0, 0.5, 0.05).is_empty());
        // The same block with a bar 2 mm wide where the lobe was gets one, if the block has
        // a vertex near the bar's root (a spur leaves from one of the loop's own vertices:
        // the loops across the plane share them, and no other).
        let mut armed = block.clone();
        armed.splice(
            3..3,
            [[21.0, 20.0], [21.0, 40.0], [19.0, 40.0], [19.0, 20.0]],
        );
        assert!(arm_spurs(&block, &armed, 2.0, 0.5, 0.05).is_empty());
        let mut dense = block.clone();
        dense.splice(3..3, (1..40).rev().map(|x| [x as f64, 20.0]));
        let spurs = arm_spurs(&dense, &armed, 2.0, 0.5, 0.05);
        assert_eq!(spurs.len(), 1);
        assert_eq!(dense[spurs[0].from], [20.0, 20.0]);
    }

    #[test]
    fn the_edge_grid_finds_every_edge_within_reach() {
        let poly = circle(3.0, -2.0, 17.0, 37, true);
        let grid = EdgeGrid::new(&poly, 1.5);
        let n = poly.len();
        for i in 0..400 {
            let p = [
                3.0 + 25.0 * ((i * 37 % 101) as f64 / 50.0 - 1.0),
                -2.0 + 25.0 * ((i * 53 % 97) as f64 / 48.5 - 1.0),
            ];
            let exact = (0..n).any(|k| point_segment_distance(p, poly[k], poly[(k + 1) % n]) < 1.5);
            assert_eq!(grid.within(p, 1.5), exact, "{p:?}");
        }
    }
}
