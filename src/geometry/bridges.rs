//! Joining the pieces of a split zone into one intermediate contour (beyond the paper).
//!
//! A contour's zone can meet the intermediate section in several pieces: a thin wall whose
//! stretches over gaps in the other section are too thin to reach the mid-plane (the skull's
//! vault: one contour above, its zone meeting the mid-plane as a U under one part of the ring
//! and an arc under another). One closed curve per contour cannot bound several pieces, and
//! keeping only the largest leaves the contour's wall over the others with nothing to join
//! but that piece, half a slice below: its surface sweeps sideways across the gap and folds.
//!
//! So the pieces are joined by bridges: zero-width slits from a vertex of one piece to a
//! vertex of another, running through the contour's own footprint outside the intermediate
//! section. The loop goes out along a slit, round the other piece and back, so it bounds
//! every piece (the slits add no area) and the contour's wall over a gap rises from the slit,
//! a wall that begins between the slices. The slit's two edges are one loop's, in opposite
//! directions, so a mesh stitched along the loops stays closed.
//!
//! In: the pieces (counter-clockwise, pairwise disjoint; the first is kept whatever happens),
//! the contour (counter-clockwise), every loop of the problem (which tile the section:
//! bridges may not cross them) and the raster cell. Straight bridges are tried first,
//! shortest first (Kruskal): a bridge is taken when it joins two groups not yet joined,
//! crosses no loop edge, no contour edge and no bridge taken, has its midpoint inside the
//! contour and outside every loop, and starts at vertices no other bridge uses.
//!
//! A curved footprint (a ring of bone whose zone meets the mid-plane in arcs round it) often
//! has no straight line from one piece to the next that stays inside it. The groups still
//! apart are then reached by polyline bridges: a breadth-first search over the raster's cells
//! inside the contour and outside every loop, from the first piece's group to the nearest
//! vertex of another, shortened greedily where each segment passes the straight bridge's
//! tests. Before, such pieces were dropped and sealed flat: on the GE head a third of one
//! zone's area (1 411 of 4 522 mm²), under a wall that then fanned across it. Pieces that no
//! bridge reaches are dropped. Deterministic.

use std::collections::{BTreeMap, VecDeque};

use super::distance_map::{inside_mask, paint_inside, Grid};
use super::polygon::{bbox, boxes_disjoint, contains, segments_intersect, signed_area, Point};

/// Closest vertex pairs tried per pair of pieces.
const CANDIDATES_PER_PAIR: usize = 8;

/// Most cells of the raster polyline bridges are searched on (the cell is coarsened to fit).
const MAX_PATH_CELLS: usize = 1_000_000;

/// Most polyline bridges tried (found by the search, then refused by the segment tests)
/// before the remaining pieces are dropped.
const MAX_PATH_TRIES: usize = 16;

/// The joined loop, the number of pieces joined (1 = only the first) and the total area of
/// the pieces dropped.
#[derive(Clone, Debug, PartialEq)]
pub struct Joined {
    pub points: Vec<Point>,
    pub pieces: usize,
    pub dropped_area: f64,
}

/// A vertex of a piece: (piece, vertex).
type End = (usize, usize);

/// A straight bridge tried: its squared length and its two ends.
type Candidate = (f64, End, End);

/// A bridge: from vertex `from.1` of piece `from.0` to vertex `to.1` of piece `to.0`, through
/// the points `via` (empty for a straight bridge).
#[derive(Clone, Debug, PartialEq)]
struct Bridge {
    from: End,
    to: End,
    via: Vec<Point>,
}

fn root(group: &mut [usize], mut i: usize) -> usize {
    while group[i] != i {
        group[i] = group[group[i]];
        i = group[i];
    }
    i
}

/// Joins `pieces` (see the module doc); `cell_mm`: the raster cell of the problem.
pub fn join_pieces(
    pieces: &[Vec<Point>],
    contour: &[Point],
    loops: &[&[Point]],
    cell_mm: f64,
) -> Joined {
    let k = pieces.len();
    if k <= 1 {
        return Joined {
            points: pieces.first().cloned().unwrap_or_default(),
            pieces: k,
            dropped_area: 0.0,
        };
    }
    // Candidate bridges, shortest first; ties by piece and vertex index.
    let mut candidates: Vec<Candidate> = Vec::new();
    for i in 0..k {
        for j in i + 1..k {
            let mut best: Vec<Candidate> = Vec::with_capacity(CANDIDATES_PER_PAIR + 1);
            for (a, &p) in pieces[i].iter().enumerate() {
                for (b, &q) in pieces[j].iter().enumerate() {
                    let d = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                    if best.len() == CANDIDATES_PER_PAIR && d >= best[best.len() - 1].0 {
                        continue;
                    }
                    let at = best.partition_point(|c| c.0 <= d);
                    best.insert(at, (d, (i, a), (j, b)));
                    best.truncate(CANDIDATES_PER_PAIR);
                }
            }
            candidates.extend(best);
        }
    }
    candidates.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut group: Vec<usize> = (0..k).collect();
    let mut taken: Vec<Bridge> = Vec::new();
    // Every segment of the bridges taken, kept as they are taken.
    let mut slits: Vec<[Point; 2]> = Vec::new();
    for (_, from, to) in candidates {
        let (ga, gb) = (root(&mut group, from.0), root(&mut group, to.0));
        if ga == gb || used(&taken, from) || used(&taken, to) {
            continue;
        }
        let (p, q) = (pieces[from.0][from.1], pieces[to.0][to.1]);
        if !clear(p, q, contour, loops, &slits) {
            continue;
        }
        slits.push([p, q]);
        group[ga.max(gb)] = ga.min(gb);
        taken.push(Bridge {
            from,
            to,
            via: Vec::new(),
        });
    }
    if (0..k).any(|i| root(&mut group, i) != 0) {
        path_bridges(
            pieces, contour, loops, cell_mm, &mut group, &mut taken, slits,
        );
    }
    // Walk the tree of bridges from the first piece.
    let mut children: Vec<Vec<Child>> = vec![Vec::new(); k];
    let mut reached = vec![false; k];
    reached[0] = true;
    let mut frontier = vec![0usize];
    while let Some(i) = frontier.pop() {
        for br in &taken {
            for (here, there, forward) in [(br.from, br.to, true), (br.to, br.from, false)] {
                if here.0 == i && !reached[there.0] {
                    reached[there.0] = true;
                    let mut via = br.via.clone();
                    if !forward {
                        via.reverse();
                    }
                    children[i].push(Child {
                        at: here.1,
                        piece: there.0,
                        start: there.1,
                        via,
                    });
                    frontier.push(there.0);
                }
            }
        }
    }
    for c in children.iter_mut() {
        c.sort_by_key(|x| (x.at, x.piece, x.start));
    }
    let mut points = Vec::new();
    tour(pieces, &children, 0, 0, &mut points);
    // The first piece's tour ends back at its start: the loop closes there implicitly.
    points.pop();
    let dropped_area = (0..k)
        .filter(|&i| !reached[i])
        .map(|i| signed_area(&pieces[i]))
        .fold(0.0, |a, b| a + b);
    Joined {
        points,
        pieces: reached.iter().filter(|&&r| r).count(),
        dropped_area,
    }
}

/// Whether a bridge taken starts or ends at this vertex.
fn used(taken: &[Bridge], end: End) -> bool {
    taken.iter().any(|t| t.from == end || t.to == end)
}

/// A piece reached from piece `i`: its bridge leaves `i` at vertex `at` and runs through
/// `via` to vertex `start` of `piece`.
#[derive(Clone, Debug)]
struct Child {
    at: usize,
    piece: usize,
    start: usize,
    via: Vec<Point>,
}

/// The raster polyline bridges are searched on: samples inside the contour and outside every
/// loop are free. A sample stands for the cell of side `grid.cell_mm` centred on it.
struct FreeCells {
    grid: Grid,
    free: Vec<bool>,
}

impl FreeCells {
    fn new(contour: &[Point], loops: &[&[Point]], cell_mm: f64) -> Option<Self> {
        let b = bbox(contour);
        let (dx, dy) = (b[2] - b[0], b[3] - b[1]);
        if !(dx.max(dy).is_finite() && dx.max(dy) > 0.0 && cell_mm > 0.0) {
            return None;
        }
        let area = (dx + 2.0 * cell_mm) * (dy + 2.0 * cell_mm);
        let cell = cell_mm.max((area / MAX_PATH_CELLS as f64).sqrt());
        // Cells tile the box with one to spare all round: samples at their centres, so the
        // box shifted by half a cell.
        let h = 0.5 * cell;
        let grid = Grid::covering(
            [b[0] + h, b[1] + h, b[2] + h, b[3] + h],
            cell,
            1,
            usize::MAX,
        )
        .ok()?;
        let mut free = inside_mask(&grid, &[contour]);
        for l in loops {
            paint_inside(&grid, &[l], &mut free, false);
        }
        Some(FreeCells { grid, free })
    }

    fn width(&self) -> usize {
        self.grid.width
    }

    fn height(&self) -> usize {
        self.grid.height
    }

    fn centre(&self, k: usize) -> Point {
        self.grid.point(k / self.width(), k % self.width())
    }

    /// The free cells within one cell of the one `p` lies in (row-major order).
    fn free_near(&self, p: Point) -> Vec<usize> {
        let [c, r] = self.grid.to_pixel(p).map(|v| (v + 0.5).floor());
        if !(c >= 0.0 && r >= 0.0 && c < self.width() as f64 && r < self.height() as f64) {
            return Vec::new();
        }
        let (r, c) = (r as usize, c as usize);
        let mut out = Vec::new();
        for rr in r.saturating_sub(1)..=(r + 1).min(self.height() - 1) {
            for cc in c.saturating_sub(1)..=(c + 1).min(self.width() - 1) {
                let k = rr * self.width() + cc;
                if self.free[k] {
                    out.push(k);
                }
            }
        }
        out
    }
}

/// Joins the groups still apart from the first piece's by polyline bridges (module doc).
fn path_bridges(
    pieces: &[Vec<Point>],
    contour: &[Point],
    loops: &[&[Point]],
    cell_mm: f64,
    group: &mut [usize],
    taken: &mut Vec<Bridge>,
    mut slits: Vec<[Point; 2]>,
) {
    let Some(grid) = FreeCells::new(contour, loops, cell_mm) else {
        return;
    };
    let mut refused: Vec<(usize, usize)> = Vec::new();
    for _ in 0..MAX_PATH_TRIES {
        let k = pieces.len();
        if (0..k).all(|i| root(group, i) == 0) {
            return;
        }
        // Sources: free cells next to the first group's unused vertices; targets: next to
        // the other groups'. The first vertex to claim a cell keeps it.
        let mut ends: Vec<(usize, usize)> = Vec::new();
        let mut origin: Vec<u32> = vec![u32::MAX; grid.free.len()];
        let mut target: BTreeMap<usize, (usize, usize)> = BTreeMap::new();
        let mut queue = VecDeque::new();
        for (i, piece) in pieces.iter().enumerate() {
            let home = root(group, i) == 0;
            for (v, &p) in piece.iter().enumerate() {
                if used(taken, (i, v)) || (!home && refused.contains(&(i, v))) {
                    continue;
                }
                for cell in grid.free_near(p) {
                    if home {
                        if origin[cell] == u32::MAX {
                            origin[cell] = ends.len() as u32;
                            queue.push_back(cell);
                        }
                    } else {
                        target.entry(cell).or_insert((i, v));
                    }
                }
                if home {
                    ends.push((i, v));
                }
            }
        }
        let mut prev: Vec<u32> = vec![u32::MAX; grid.free.len()];
        let mut found = None;
        while let Some(cell) = queue.pop_front() {
            if let Some(&end) = target.get(&cell) {
                found = Some((cell, end));
                break;
            }
            let (r, c) = ((cell / grid.width()) as i64, (cell % grid.width()) as i64);
            for (dr, dc) in [
                (-1, 0),
                (0, -1),
                (0, 1),
                (1, 0),
                (-1, -1),
                (-1, 1),
                (1, -1),
                (1, 1),
            ] {
                let (rr, cc) = (r + dr, c + dc);
                if rr < 0 || cc < 0 || rr >= grid.height() as i64 || cc >= grid.width() as i64 {
                    continue;
                }
                let n = rr as usize * grid.width() + cc as usize;
                // A diagonal step only between two free cells: never across a corner.
                let corner_free = dr == 0
                    || dc == 0
                    || (grid.free[rr as usize * grid.width() + c as usize]
                        && grid.free[r as usize * grid.width() + cc as usize]);
                if grid.free[n] && origin[n] == u32::MAX && corner_free {
                    origin[n] = origin[cell];
                    prev[n] = cell as u32;
                    queue.push_back(n);
                }
            }
        }
        let Some((end_cell, end)) = found else {
            return;
        };
        let Some(&start) = ends.get(origin[end_cell] as usize) else {
            return;
        };
        let mut cells = vec![end_cell];
        while let Some(&p) = cells.last().map(|&c| &prev[c]) {
            if p == u32::MAX {
                break;
            }
            cells.push(p as usize);
        }
        cells.reverse();
        let mut path = vec![pieces[start.0][start.1]];
        path.extend(cells.iter().map(|&c| grid.centre(c)));
        path.push(pieces[end.0][end.1]);
        match shorten(&path, contour, loops, &slits) {
            Some(via) => {
                let mut pts = vec![path[0]];
                pts.extend_from_slice(&via);
                pts.push(path[path.len() - 1]);
                slits.extend(pts.windows(2).map(|w| [w[0], w[1]]));
                let (ga, gb) = (root(group, start.0), root(group, end.0));
                group[ga.max(gb)] = ga.min(gb);
                taken.push(Bridge {
                    from: start,
                    to: end,
                    via,
                });
            }
            None => refused.push(end),
        }
    }
}

/// The path's inner points kept when it is shortened greedily (each step to the farthest
/// point, halving back, whose segment passes [`clear`] against the loops, the contour, the
/// slits taken and the segments kept), or `None` where a step of one cell does not pass.
fn shorten(
    path: &[Point],
    contour: &[Point],
    loops: &[&[Point]],
    slits: &[[Point; 2]],
) -> Option<Vec<Point>> {
    let last = path.len() - 1;
    let mut kept: Vec<Point> = vec![path[0]];
    let mut segments: Vec<[Point; 2]> = slits.to_vec();
    let mut i = 0;
    while i < last {
        let mut j = last;
        loop {
            if clear(path[i], path[j], contour, loops, &segments) {
                break;
            }
            if j == i + 1 {
                return None;
            }
            j = i + (j - i) / 2;
        }
        segments.push([path[i], path[j]]);
        kept.push(path[j]);
        i = j;
    }
    kept.pop();
    kept.remove(0);
    Some(kept)
}

/// Piece `i` from vertex `start` round to `start` again (both emitted), with every child's
/// tour inserted after the vertex its bridge leaves from (out along the bridge's points and
/// back), and that vertex repeated after it.
fn tour(
    pieces: &[Vec<Point>],
    children: &[Vec<Child>],
    i: usize,
    start: usize,
    out: &mut Vec<Point>,
) {
    let n = pieces[i].len();
    for s in 0..=n {
        let v = (start + s) % n;
        out.push(pieces[i][v]);
        if s == n {
            break;
        }
        for ch in &children[i] {
            if ch.at == v {
                out.extend_from_slice(&ch.via);
                tour(pieces, children, ch.piece, ch.start, out);
                out.extend(ch.via.iter().rev());
                out.push(pieces[i][v]);
            }
        }
    }
}

/// Whether the segment p–q may be a bridge or a bridge's segment: it crosses no edge of the
/// loops, of the contour or of `slits` (edges ending at p or q excepted, unless they run
/// along it), and its midpoint lies inside the contour and outside every loop.
fn clear(p: Point, q: Point, contour: &[Point], loops: &[&[Point]], slits: &[[Point; 2]]) -> bool {
    if p == q {
        return false;
    }
    let crosses = |a: Point, b: Point| -> bool {
        if a == p || a == q || b == p || b == q {
            // An edge from an end of the bridge: it only meets the bridge there, unless it
            // runs along it (a bridge on an existing edge would give that edge to 3 faces).
            return along(p, q, a, b);
        }
        !boxes_disjoint(a, b, p, q) && segments_intersect(p, q, a, b)
    };
    let edges_cross = |l: &[Point]| (0..l.len()).any(|e| crosses(l[e], l[(e + 1) % l.len()]));
    if edges_cross(contour) || loops.iter().any(|l| edges_cross(l)) {
        return false;
    }
    if slits.iter().any(|s| crosses(s[0], s[1])) {
        return false;
    }
    let mid = [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])];
    contains(contour, mid) && !loops.iter().any(|l| contains(l, mid))
}

/// Whether edge a–b, which shares an end with segment p–q, runs along it from that end.
fn along(p: Point, q: Point, a: Point, b: Point) -> bool {
    let (shared, other, far) = if a == p || a == q {
        (a, b, if a == p { q } else { p })
    } else {
        (b, a, if b == p { q } else { p })
    };
    if other == far {
        return true;
    }
    let u = [other[0] - shared[0], other[1] - shared[1]];
    let v = [far[0] - shared[0], far[1] - shared[1]];
    let cross = u[0] * v[1] - u[1] * v[0];
    let scale = (u[0].hypot(u[1]) * v[0].hypot(v[1])).max(f64::MIN_POSITIVE);
    cross.abs() <= 1e-12 * scale && u[0] * v[0] + u[1] * v[1] > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<Point> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    #[test]
    fn two_pieces_under_one_wall_become_one_loop_of_their_area() {
        // The contour: a wall 10 × 1.2; the pieces: its two ends, a little inside it.
        let contour = rect(-0.1, -0.1, 10.1, 1.1);
        let a = rect(0.0, 0.0, 3.0, 1.0);
        let b = rect(7.0, 0.0, 10.0, 1.0);
        let pieces = vec![a.clone(), b.clone()];
        let loops: Vec<&[Point]> = vec![&a, &b];
        let j = join_pieces(&pieces, &contour, &loops, 0.05);
        assert_eq!(j.pieces, 2);
        assert_eq!(j.dropped_area, 0.0);
        assert!(
            (signed_area(&j.points) - 6.0).abs() < 1e-12,
            "{:?}",
            j.points
        );
        // Every vertex of both pieces, and the slit's ends twice.
        assert_eq!(j.points.len(), 4 + 4 + 2);
        for p in a.iter().chain(&b) {
            assert!(j.points.contains(p));
        }
    }

    #[test]
    fn a_piece_out_of_the_contours_reach_is_dropped() {
        // The gap between the pieces is not inside the contour: no bridge.
        let contour = rect(0.0, 0.0, 3.0, 1.0);
        let a = rect(0.0, 0.0, 3.0, 1.0);
        let b = rect(7.0, 0.0, 10.0, 1.0);
        let pieces = vec![a.clone(), b.clone()];
        let loops: Vec<&[Point]> = vec![&a, &b];
        let j = join_pieces(&pieces, &contour, &loops, 0.05);
        assert_eq!((j.pieces, j.points.clone()), (1, a));
        assert_eq!(j.dropped_area, 3.0);
    }

    /// Whether some bridge segment of the joined loop (an edge not between two vertices of
    /// one piece) meets an edge of `other` anywhere but at a shared end point.
    fn crosses_loop(joined: &[Point], other: &[Point], pieces: &[&[Point]]) -> bool {
        let n = joined.len();
        (0..n).any(|i| {
            let (p, q) = (joined[i], joined[(i + 1) % n]);
            if pieces.iter().any(|pc| pc.contains(&p) && pc.contains(&q)) {
                return false;
            }
            (0..other.len()).any(|e| {
                let (a, b) = (other[e], other[(e + 1) % other.len()]);
                a != p && a != q && b != p && b != q && segments_intersect(p, q, a, b)
            })
        })
    }

    #[test]
    fn bridges_go_round_other_loops() {
        // A loop of the other section sits between the pieces, inside the contour: no
        // straight bridge, so a polyline one goes round it through the gap above or below.
        let contour = rect(0.0, 0.0, 10.0, 3.0);
        let a = rect(0.0, 1.0, 3.0, 2.0);
        let b = rect(7.0, 1.0, 10.0, 2.0);
        let wall = rect(4.0, 0.5, 6.0, 2.5);
        let pieces = vec![a.clone(), b.clone()];
        let loops: Vec<&[Point]> = vec![&a, &b, &wall];
        let j = join_pieces(&pieces, &contour, &loops, 0.05);
        assert_eq!((j.pieces, j.dropped_area), (2, 0.0));
        assert!(
            (signed_area(&j.points) - 6.0).abs() < 1e-9,
            "{:?}",
            j.points
        );
        assert!(!crosses_loop(&j.points, &wall, &[&a, &b]), "{:?}", j.points);
        assert!(
            !crosses_loop(&j.points, &contour, &[&a, &b]),
            "{:?}",
            j.points
        );
        for p in a.iter().chain(&b) {
            assert!(j.points.contains(p));
        }
        // The slit is walked out and back: every point off the pieces appears twice.
        for p in j.points.iter().filter(|p| !a.contains(p) && !b.contains(p)) {
            assert_eq!(j.points.iter().filter(|q| *q == p).count(), 2, "{p:?}");
        }
    }

    #[test]
    fn a_wall_across_the_contour_still_drops_the_piece() {
        // The other section's loop spans the contour from side to side: no way round.
        let contour = rect(0.0, 0.0, 10.0, 3.0);
        let a = rect(0.0, 1.0, 3.0, 2.0);
        let b = rect(7.0, 1.0, 10.0, 2.0);
        let wall = rect(4.0, -0.5, 6.0, 3.5);
        let pieces = vec![a.clone(), b.clone()];
        let loops: Vec<&[Point]> = vec![&a, &b, &wall];
        let j = join_pieces(&pieces, &contour, &loops, 0.05);
        assert_eq!(j.pieces, 1);
        assert_eq!(j.dropped_area, 3.0);
    }

    #[test]
    fn pieces_round_a_bend_join_along_it() {
        // A U-shaped wall (the contour) with a piece at the end of each arm: the line between
        // them leaves the wall, so the bridge follows the bend.
        let contour = vec![
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 10.0],
            [8.0, 10.0],
            [8.0, 2.0],
            [2.0, 2.0],
            [2.0, 10.0],
            [0.0, 10.0],
        ];
        let a = rect(0.2, 7.0, 1.8, 9.8);
        let b = rect(8.2, 7.0, 9.8, 9.8);
        let pieces = vec![a.clone(), b.clone()];
        let loops: Vec<&[Point]> = vec![&a, &b];
        let j = join_pieces(&pieces, &contour, &loops, 0.05);
        assert_eq!((j.pieces, j.dropped_area), (2, 0.0));
        let want = signed_area(&a) + signed_area(&b);
        assert!((signed_area(&j.points) - want).abs() < 1e-9);
        assert!(
            !crosses_loop(&j.points, &contour, &[&a, &b]),
            "{:?}",
            j.points
        );
        // The bridge turns the corners: it has points off both pieces.
        assert!(j.points.len() > a.len() + b.len() + 2);
        for p in &j.points {
            assert!(
                contains(&contour, *p) || contour.contains(p),
                "{p:?} outside the wall"
            );
        }
    }

    #[test]
    fn a_bridge_never_lies_on_a_loop_edge() {
        // Pieces whose nearest vertices are joined by an edge of another loop (the other
        // section's loop covering the gap): that edge is taken already.
        let contour = rect(-1.0, -1.0, 11.0, 2.0);
        let a = rect(0.0, 0.0, 3.0, 1.0);
        let b = rect(7.0, 0.0, 10.0, 1.0);
        let under = vec![[3.0, 0.0], [7.0, 0.0], [7.0, 1.0], [3.0, 1.0]];
        let pieces = vec![a.clone(), b.clone()];
        let loops: Vec<&[Point]> = vec![&a, &b, &under];
        let j = join_pieces(&pieces, &contour, &loops, 0.05);
        // No straight bridge; the polyline one goes round `under` through the contour's
        // margin, touching it nowhere.
        assert_eq!(j.pieces, 2, "{:?}", j.points);
        let n = j.points.len();
        for i in 0..n {
            let (p, q) = (j.points[i], j.points[(i + 1) % n]);
            if a.contains(&p) && a.contains(&q) || b.contains(&p) && b.contains(&q) {
                continue;
            }
            let mid = [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])];
            assert!(
                crate::geometry::polygon::boundary_distance(&under, mid) > 1e-6,
                "bridge segment {p:?}–{q:?} on the other loop"
            );
        }
        assert!(!crosses_loop(&j.points, &under, &[&a, &b]));
    }

    #[test]
    fn three_pieces_join_in_a_chain() {
        let contour = rect(-0.1, -0.1, 20.1, 1.1);
        let pieces = vec![
            rect(8.0, 0.0, 12.0, 1.0),
            rect(0.0, 0.0, 3.0, 1.0),
            rect(17.0, 0.0, 20.0, 1.0),
        ];
        let loops: Vec<&[Point]> = pieces.iter().map(|p| p.as_slice()).collect();
        let j = join_pieces(&pieces, &contour, &loops, 0.05);
        assert_eq!(j.pieces, 3);
        assert!((signed_area(&j.points) - 10.0).abs() < 1e-12);
        assert_eq!(j.points.len(), 12 + 4);
    }
}
