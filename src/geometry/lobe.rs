//! Lobe walks (beyond the paper): the medial tree of a lobe that the curve beside a region's
//! end curve has and the end curve lacks, where the lobe is too wide, bent or branched for an
//! arm spur ([`super::spur`]).
//!
//! A branching's intermediate contour can end short of a whole lobe of the contour half a
//! slice away: on the GE head, a lobe of skull 81 mm deep and 19 mm wide on average, with
//! bays and sub-lobes of its own (surface 82). Skinned as they are, the lobe's walls all join
//! the few points of the loop across its root, and the chord-length fractions of the two
//! curves drift apart by the lobe's length along the rest of them (MeshLab counted 2,680
//! faces of that surface crossing others; 807 with the walk). An arm spur needs every cross
//! chord of the lobe to stay inside it, which a lobe with sub-lobes never passes. Here the loop grows the lobe's medial tree instead: the
//! skeleton of the lobe's raster, pruned of short twigs, walked round like a tent's ridge
//! poles, out along each branch and back, so each wall of the lobe rises to the branch
//! beside it. The walk adds no area, and every tree edge is used once in each direction.
//!
//! In: the loop and its neighbour in one 2-D frame with the same orientation, the lobe (the
//! neighbour's samples from where they leave the loop's reach to where they return, closed
//! by the chord across its root), `reach` (mm; twigs shorter than this are pruned), `step`
//! (mm; the raster is half of it) and `tol` (mm; the branches' compression). Out: the loop
//! vertex nearest the tree's root and the walk from the root out and back to it, or `None`
//! where the tree crosses either curve or the way from the vertex to the root is not clear.

use std::collections::VecDeque;

use super::polygon::{bbox, dist, point_segment_distance, segments_intersect, signed_area};
use super::polygon::{BoundaryIndex, Point};
use super::ridge::crosses_polygon;
use super::simplify::simplify_open;
use super::spur::departure;

/// Most raster cells of a lobe; a larger lobe is rastered coarser.
const MAX_CELLS: f64 = 1_048_576.0;

/// The loop vertex the walk leaves from, and the walk (see the module doc).
pub fn lobe_walk(
    lp: &[Point],
    neighbour: &[Point],
    lobe: &[Point],
    reach: f64,
    step: f64,
    tol: f64,
    max_link: f64,
) -> Option<(usize, Vec<Point>)> {
    let b = bbox(lobe);
    let area = (b[2] - b[0] + 2.0 * step) * (b[3] - b[1] + 2.0 * step);
    let cell = (0.5 * step).max((area / MAX_CELLS).sqrt());
    if !(cell.is_finite() && cell > 0.0) || lobe.len() < 3 {
        return None;
    }
    let raster = Raster::of(lobe, b, cell);
    let skeleton = raster.thinned();
    let base = (lobe[lobe.len() - 1], lobe[0]);
    let root_mid = [0.5 * (base.0[0] + base.1[0]), 0.5 * (base.0[1] + base.1[1])];
    let root = (0..skeleton.len())
        .filter(|&i| skeleton[i])
        .min_by(|&i, &j| {
            dist(raster.point(i), root_mid).total_cmp(&dist(raster.point(j), root_mid))
        })?;
    let tree = Tree::grow(&raster, &skeleton, root);
    // Twigs: branches shorter than the reach, and those ending at the root's chord (the
    // skeleton's fork into the corners where the lobe is cut off from the loop).
    let near_base = |p: Point| point_segment_distance(p, base.0, base.1) < reach;
    let kept = tree.pruned(reach, |i| near_base(raster.point(i)));
    let poles = tree.poles(&kept, |i| raster.point(i), tol);

    let root_p = raster.point(root);
    let v = departure(lp, root_p, max_link)?;
    let eps = step / 16.0;
    let edges: Vec<(Point, Point)> = poles
        .iter()
        .flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1])))
        .collect();
    if edges.is_empty()
        || edges
            .iter()
            .any(|&(a, c)| crosses_polygon(a, c, neighbour, eps) || crosses_polygon(a, c, lp, eps))
        || crossing_edges(&edges)
    {
        return None;
    }
    let ccw = signed_area(lp) > 0.0;
    Some((v, walk(&poles, root_p, lp[v], ccw)))
}

/// Whether two edges of the tree that share no end cross or touch.
fn crossing_edges(edges: &[(Point, Point)]) -> bool {
    (0..edges.len()).any(|i| {
        (i + 1..edges.len()).any(|j| {
            let ((a, b), (c, d)) = (edges[i], edges[j]);
            let shared = a == c || a == d || b == c || b == d;
            !shared && segments_intersect(a, b, c, d)
        })
    })
}

/// The lobe rastered: cell centres inside it.
struct Raster {
    origin: Point,
    cell: f64,
    width: usize,
    height: usize,
    inside: Vec<bool>,
}

impl Raster {
    fn of(lobe: &[Point], b: [f64; 4], cell: f64) -> Raster {
        // One empty cell round the box, so thinning never looks past the edge.
        let origin = [b[0] - 1.5 * cell, b[1] - 1.5 * cell];
        let width = ((b[2] - b[0]) / cell).ceil() as usize + 4;
        let height = ((b[3] - b[1]) / cell).ceil() as usize + 4;
        let index = BoundaryIndex::new(lobe);
        let mut raster = Raster {
            origin,
            cell,
            width,
            height,
            inside: Vec::new(),
        };
        raster.inside = (0..width * height)
            .map(|i| index.contains(raster.point(i)))
            .collect();
        raster
    }

    fn point(&self, i: usize) -> Point {
        let (row, col) = (i / self.width, i % self.width);
        [
            self.origin[0] + (col as f64 + 0.5) * self.cell,
            self.origin[1] + (row as f64 + 0.5) * self.cell,
        ]
    }

    /// The eight neighbours of an interior cell, clockwise from north (Zhang–Suen's P2..P9,
    /// with north as row + 1).
    fn ring(&self, i: usize) -> [usize; 8] {
        let w = self.width;
        [
            i + w,
            i + w + 1,
            i + 1,
            i - w + 1,
            i - w,
            i - w - 1,
            i - 1,
            i + w - 1,
        ]
    }

    fn interior(&self, i: usize) -> bool {
        let (row, col) = (i / self.width, i % self.width);
        row > 0 && col > 0 && row + 1 < self.height && col + 1 < self.width
    }

    /// Zhang–Suen thinning of the inside: a one-cell-wide, 8-connected skeleton on the lobe's
    /// medial line.
    fn thinned(&self) -> Vec<bool> {
        let mut on = self.inside.clone();
        let mut changed = true;
        while changed {
            changed = false;
            for pass in 0..2 {
                let gone: Vec<usize> = (0..on.len())
                    .filter(|&i| on[i] && self.interior(i))
                    .filter(|&i| {
                        let p = self.ring(i).map(|k| on[k]);
                        let count = p.iter().filter(|&&x| x).count();
                        let rises = (0..8).filter(|&k| !p[k] && p[(k + 1) % 8]).count();
                        let (n, e, s, w) = (p[0], p[2], p[4], p[6]);
                        // Zhang–Suen's P2·P4·P6 = P4·P6·P8 = 0 (first pass), P2·P4·P8 =
                        // P2·P6·P8 = 0 (second).
                        let side = if pass == 0 {
                            !(e && s && (n || w))
                        } else {
                            !(n && w && (e || s))
                        };
                        (2..=6).contains(&count) && rises == 1 && side
                    })
                    .collect();
                changed |= !gone.is_empty();
                for i in gone {
                    on[i] = false;
                }
            }
        }
        on
    }
}

/// The skeleton's cells reached from the root, as a breadth-first tree.
struct Tree {
    /// Cells in the order reached; `parent[k]` indexes into it (the root's is itself).
    cells: Vec<usize>,
    parent: Vec<usize>,
    /// Path length (mm) from each cell's parent.
    step: Vec<f64>,
    children: Vec<Vec<usize>>,
}

/// A branch of the pruned tree between two nodes (the root, forks and tips), compressed: its
/// points from the node nearer the root, and the index of the branch it leaves from.
struct Pole {
    points: Vec<Point>,
    from: Option<usize>,
}

impl Tree {
    fn grow(raster: &Raster, skeleton: &[bool], root: usize) -> Tree {
        let mut order = vec![usize::MAX; skeleton.len()];
        let mut tree = Tree {
            cells: vec![root],
            parent: vec![0],
            step: vec![0.0],
            children: vec![Vec::new()],
        };
        order[root] = 0;
        let mut queue = VecDeque::from([0usize]);
        while let Some(k) = queue.pop_front() {
            let i = tree.cells[k];
            if !raster.interior(i) {
                continue;
            }
            for (d, j) in raster.ring(i).into_iter().enumerate() {
                if skeleton[j] && order[j] == usize::MAX {
                    order[j] = tree.cells.len();
                    tree.children[k].push(order[j]);
                    tree.children.push(Vec::new());
                    tree.cells.push(j);
                    tree.parent.push(k);
                    let diagonal = d % 2 == 1;
                    tree.step
                        .push(raster.cell * if diagonal { 2f64.sqrt() } else { 1.0 });
                    queue.push_back(order[j]);
                }
            }
        }
        tree
    }

    /// Which cells stay: from each cell, the branches whose farthest tip lies at least `reach`
    /// beyond it, and always the longest (so the trunk reaches the farthest tip), except
    /// branches whose tips all lie where `twig` holds.
    fn pruned(&self, reach: f64, twig: impl Fn(usize) -> bool) -> Vec<bool> {
        let m = self.cells.len();
        // Height: path length to the farthest non-twig tip below (−∞ if none).
        let mut height = vec![f64::NEG_INFINITY; m];
        let children = &self.children;
        for k in (0..m).rev() {
            if children[k].is_empty() && !twig(self.cells[k]) {
                height[k] = 0.0;
            }
            for &c in &children[k] {
                height[k] = height[k].max(height[c] + self.step[c]);
            }
        }
        let mut kept = vec![false; m];
        kept[0] = height[0].is_finite();
        for k in 0..m {
            if !kept[k] {
                continue;
            }
            // Of equals, the child reached first (max_by keeps the last).
            let longest =
                children[k].iter().rev().copied().max_by(|&a, &b| {
                    (height[a] + self.step[a]).total_cmp(&(height[b] + self.step[b]))
                });
            for &c in &children[k] {
                let length = height[c] + self.step[c];
                kept[c] = length.is_finite() && (Some(c) == longest || length >= reach);
            }
        }
        kept
    }

    /// The kept tree as compressed branches, in breadth-first order from the root.
    fn poles(&self, kept: &[bool], at: impl Fn(usize) -> Point, tol: f64) -> Vec<Pole> {
        let children: Vec<Vec<usize>> = self
            .children
            .iter()
            .map(|c| c.iter().copied().filter(|&k| kept[k]).collect())
            .collect();
        let mut poles: Vec<Pole> = Vec::new();
        // (first cell of a branch, the node it leaves from, the pole that node ends)
        let mut queue: VecDeque<(usize, usize, Option<usize>)> =
            children[0].iter().map(|&c| (c, 0, None)).collect();
        while let Some((first, node, from)) = queue.pop_front() {
            let mut chain = vec![node, first];
            let mut k = first;
            while children[k].len() == 1 {
                k = children[k][0];
                chain.push(k);
            }
            let pts: Vec<Point> = chain.iter().map(|&c| at(self.cells[c])).collect();
            let idx = poles.len();
            poles.push(Pole {
                points: simplify_open(&pts, tol),
                from,
            });
            queue.extend(children[k].iter().map(|&c| (c, k, Some(idx))));
        }
        poles
    }
}

/// The walk round the tree of `poles` from `root`, whose way in comes from `entry`: at each
/// node the branches in turn counter-clockwise from the way back (clockwise for a clockwise
/// loop), so the walk keeps the tree on the loop's inner side and never crosses itself.
fn walk(poles: &[Pole], root: Point, entry: Point, ccw: bool) -> Vec<Point> {
    // The branches leaving each pole's tip, and (last) those leaving the root.
    let mut leaving: Vec<Vec<usize>> = vec![Vec::new(); poles.len() + 1];
    for (i, p) in poles.iter().enumerate() {
        leaving[p.from.unwrap_or(poles.len())].push(i);
    }
    let mut out = vec![root];
    visit(poles, &leaving, poles.len(), root, entry, ccw, &mut out);
    out
}

/// Walks the branches leaving `node` (`leaving[at]`), whose way back goes to `back`.
fn visit(
    poles: &[Pole],
    leaving: &[Vec<usize>],
    at: usize,
    node: Point,
    back: Point,
    ccw: bool,
    out: &mut Vec<Point>,
) {
    let turn = |i: usize| {
        let q = poles[i].points[1];
        let (d, e) = (
            [back[0] - node[0], back[1] - node[1]],
            [q[0] - node[0], q[1] - node[1]],
        );
        let a = (d[0] * e[1] - d[1] * e[0]).atan2(d[0] * e[0] + d[1] * e[1]);
        let a = if a <= 0.0 {
            a + std::f64::consts::TAU
        } else {
            a
        };
        if ccw {
            a
        } else {
            std::f64::consts::TAU - a
        }
    };
    let mut order = leaving[at].clone();
    order.sort_by(|&a, &b| turn(a).total_cmp(&turn(b)));
    for i in order {
        let pts = &poles[i].points;
        out.extend(pts[1..].iter().copied());
        let tip = pts[pts.len() - 1];
        visit(poles, leaving, i, tip, pts[pts.len() - 2], ccw, out);
        out.extend(pts[..pts.len() - 1].iter().rev().copied());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::spur::{arm_spurs, with_spurs};

    /// A 40 × 20 block with a vertex every mm along its top, counter-clockwise.
    fn block() -> Vec<Point> {
        let mut pts = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0]];
        pts.extend((1..40).rev().map(|x| [x as f64, 20.0]));
        pts.push([0.0, 20.0]);
        pts
    }

    /// The block with a T on top: a trunk 4 mm wide up to y = 35, a crossbar 30 mm wide.
    fn block_with_t() -> Vec<Point> {
        let mut pts = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0]];
        pts.extend([
            [22.0, 20.0],
            [22.0, 35.0],
            [35.0, 35.0],
            [35.0, 39.0],
            [5.0, 39.0],
            [5.0, 35.0],
            [18.0, 35.0],
            [18.0, 20.0],
        ]);
        pts.push([0.0, 20.0]);
        pts
    }

    #[test]
    fn thinning_leaves_a_connected_line_down_a_bar() {
        let bar = vec![[0.0, 0.0], [20.0, 0.0], [20.0, 4.0], [0.0, 4.0]];
        let raster = Raster::of(&bar, bbox(&bar), 0.25);
        let skeleton = raster.thinned();
        let cells: Vec<usize> = (0..skeleton.len()).filter(|&i| skeleton[i]).collect();
        assert!(cells.len() > 40, "{} cells", cells.len());
        // Away from the ends (where it forks into the corners) it runs along the middle.
        for &i in &cells {
            let p = raster.point(i);
            if (3.0..17.0).contains(&p[0]) {
                assert!((p[1] - 2.0).abs() <= 0.25, "{p:?}");
            }
        }
        let tree = Tree::grow(&raster, &skeleton, cells[0]);
        assert_eq!(tree.cells.len(), cells.len(), "one 8-connected piece");
    }

    #[test]
    fn a_branched_lobe_gets_a_walk_round_its_tree() {
        for ccw in [true, false] {
            let (mut lp, mut t) = (block(), block_with_t());
            if !ccw {
                lp.reverse();
                t.reverse();
            }
            let spurs = arm_spurs(&lp, &t, 2.0, 0.5, 0.05);
            assert_eq!(spurs.len(), 1, "{spurs:?}");
            let s = &spurs[0];
            assert!(s.lobe, "the T's chords leave it: no arm spur");
            assert!(dist(lp[s.from], [20.0, 20.0]) <= 1.0, "{:?}", lp[s.from]);
            let (first, last) = (s.walk[0], s.walk[s.walk.len() - 1]);
            assert_eq!(first, last, "the walk comes back to its root");
            // Up the trunk and out to both ends of the crossbar, inside the T.
            let xs = s.walk.iter().map(|p| p[0]);
            assert!(xs.clone().fold(f64::INFINITY, f64::min) < 9.0);
            assert!(xs.fold(f64::NEG_INFINITY, f64::max) > 31.0);
            for p in &s.walk {
                let trunk = (18.0..=22.0).contains(&p[0]) && (20.0..=39.0).contains(&p[1]);
                let bar = (5.0..=35.0).contains(&p[0]) && (35.0..=39.0).contains(&p[1]);
                assert!(trunk || bar, "{p:?} outside the T");
            }
            // Every edge of the walk is walked once each way, so the loop gains no area.
            let spurred = with_spurs(&lp, &spurs, |p| p);
            assert!((signed_area(&spurred) - signed_area(&lp)).abs() < 1e-9);
            let mut edges: Vec<(Point, Point)> = s.walk.windows(2).map(|w| (w[0], w[1])).collect();
            edges.push((lp[s.from], first));
            edges.push((last, lp[s.from]));
            for &(a, b) in &edges {
                let ways = |x: Point, y: Point| edges.iter().filter(|&&e| e == (x, y)).count();
                assert_eq!((ways(a, b), ways(b, a)), (1, 1), "{a:?} → {b:?}");
            }
            // (That it never crosses itself: tests/spur_props.rs opens random walks up.)
        }
    }

    #[test]
    fn a_tree_that_would_cross_the_loop_gives_no_walk() {
        let t = block_with_t();
        let lobe = t[3..11].to_vec();
        let walk = lobe_walk(&block(), &t, &lobe, 2.0, 0.5, 0.05, 8.0);
        assert!(walk.is_some_and(|(_, w)| w.len() > 4));
        // The loop has a slab 1 mm wide up through the crossbar: the tree would cross it.
        let mut lp = block();
        let at = lp.iter().position(|&p| p == [26.0, 20.0]).unwrap();
        lp.splice(at + 1..at + 1, [[26.0, 45.0], [25.0, 45.0]]);
        assert!(lobe_walk(&lp, &t, &lobe, 2.0, 0.5, 0.05, 8.0).is_none());
        // Nor where the loop's nearest vertex is farther from the root than the link allows.
        assert!(lobe_walk(&block(), &t, &lobe, 2.0, 0.5, 0.05, 0.1).is_none());
    }
}
