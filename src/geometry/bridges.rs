//! Joining the pieces of a split zone into one intermediate contour (beyond the paper).
//!
//! A contour's zone can meet the intermediate section in several pieces: a thin wall whose
//! stretches over gaps in the other section are too thin to reach the mid-plane (the skull's
//! vault: one contour above, its zone meeting the mid-plane as a U under one part of the ring
//! and an arc under another). One closed curve per contour cannot bound several pieces, and
//! keeping only the largest leaves the contour's wall over the others with nothing to join
//! but that piece, half a slice below: its surface sweeps sideways across the gap and folds.
//!
//! So the pieces are joined by bridges: straight, zero-width slits from a vertex of one piece
//! to a vertex of another, running through the contour's own footprint outside the
//! intermediate section. The loop goes out along a slit, round the other piece and back, so
//! it bounds every piece (the slits add no area) and the contour's wall over a gap rises from
//! the slit, a wall that begins between the slices. The slit's two edges are one loop's, in
//! opposite directions, so a mesh stitched along the loops stays closed.
//!
//! In: the pieces (counter-clockwise, pairwise disjoint; the first is kept whatever happens),
//! the contour (counter-clockwise), and every loop of the problem (which tile the section:
//! bridges may not cross them). Bridges are tried shortest first (Kruskal): a bridge is taken
//! when it joins two groups not yet joined, crosses no loop edge, no contour edge and no
//! bridge taken, has its midpoint inside the contour and outside every loop, and starts at
//! vertices no other bridge uses. Pieces that no bridge reaches are dropped. Deterministic.

use super::polygon::{boxes_disjoint, contains, segments_intersect, signed_area, Point};

/// Closest vertex pairs tried per pair of pieces.
const CANDIDATES_PER_PAIR: usize = 8;

/// The joined loop, the number of pieces joined (1 = only the first) and the total area of
/// the pieces dropped.
#[derive(Clone, Debug, PartialEq)]
pub struct Joined {
    pub points: Vec<Point>,
    pub pieces: usize,
    pub dropped_area: f64,
}

/// A bridge: from vertex `from.1` of piece `from.0` to vertex `to.1` of piece `to.0`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bridge {
    from: (usize, usize),
    to: (usize, usize),
}

/// Joins `pieces` (see the module doc).
pub fn join_pieces(pieces: &[Vec<Point>], contour: &[Point], loops: &[&[Point]]) -> Joined {
    let k = pieces.len();
    if k <= 1 {
        return Joined {
            points: pieces.first().cloned().unwrap_or_default(),
            pieces: k,
            dropped_area: 0.0,
        };
    }
    // Candidate bridges, shortest first; ties by piece and vertex index.
    let mut candidates: Vec<(f64, Bridge)> = Vec::new();
    for i in 0..k {
        for j in i + 1..k {
            let mut best: Vec<(f64, Bridge)> = Vec::with_capacity(CANDIDATES_PER_PAIR + 1);
            for (a, &p) in pieces[i].iter().enumerate() {
                for (b, &q) in pieces[j].iter().enumerate() {
                    let d = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                    if best.len() == CANDIDATES_PER_PAIR && d >= best[best.len() - 1].0 {
                        continue;
                    }
                    let at = best.partition_point(|c| c.0 <= d);
                    best.insert(
                        at,
                        (
                            d,
                            Bridge {
                                from: (i, a),
                                to: (j, b),
                            },
                        ),
                    );
                    best.truncate(CANDIDATES_PER_PAIR);
                }
            }
            candidates.extend(best);
        }
    }
    candidates.sort_by(|x, y| {
        x.0.total_cmp(&y.0)
            .then(x.1.from.cmp(&y.1.from))
            .then(x.1.to.cmp(&y.1.to))
    });
    let mut group: Vec<usize> = (0..k).collect();
    fn root(group: &mut [usize], mut i: usize) -> usize {
        while group[i] != i {
            group[i] = group[group[i]];
            i = group[i];
        }
        i
    }
    let mut taken: Vec<Bridge> = Vec::new();
    for (_, br) in candidates {
        let (ga, gb) = (root(&mut group, br.from.0), root(&mut group, br.to.0));
        if ga == gb {
            continue;
        }
        let used = |end: (usize, usize)| taken.iter().any(|t| t.from == end || t.to == end);
        if used(br.from) || used(br.to) {
            continue;
        }
        let (p, q) = (pieces[br.from.0][br.from.1], pieces[br.to.0][br.to.1]);
        if !clear(p, q, contour, loops, &taken, pieces) {
            continue;
        }
        group[ga.max(gb)] = ga.min(gb);
        taken.push(br);
    }
    // Walk the tree of bridges from the first piece.
    let mut children: Vec<Vec<(usize, usize, usize)>> = vec![Vec::new(); k];
    let mut reached = vec![false; k];
    reached[0] = true;
    let mut frontier = vec![0usize];
    while let Some(i) = frontier.pop() {
        for br in &taken {
            for (here, there) in [(br.from, br.to), (br.to, br.from)] {
                if here.0 == i && !reached[there.0] {
                    reached[there.0] = true;
                    children[i].push((here.1, there.0, there.1));
                    frontier.push(there.0);
                }
            }
        }
    }
    for c in children.iter_mut() {
        c.sort_unstable();
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

/// Piece `i` from vertex `start` round to `start` again (both emitted), with every child's
/// tour inserted after the vertex its bridge leaves from, and that vertex repeated after it.
fn tour(
    pieces: &[Vec<Point>],
    children: &[Vec<(usize, usize, usize)>],
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
        for &(at, child, child_start) in &children[i] {
            if at == v {
                tour(pieces, children, child, child_start, out);
                out.push(pieces[i][v]);
            }
        }
    }
}

/// Whether the segment p–q may be a bridge: it crosses no edge of the loops, of the contour
/// or of a bridge taken (edges ending at p or q excepted), and its midpoint lies inside the
/// contour and outside every loop.
fn clear(
    p: Point,
    q: Point,
    contour: &[Point],
    loops: &[&[Point]],
    taken: &[Bridge],
    pieces: &[Vec<Point>],
) -> bool {
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
    if taken.iter().any(|t| {
        let (a, b) = (pieces[t.from.0][t.from.1], pieces[t.to.0][t.to.1]);
        crosses(a, b)
    }) {
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
        let j = join_pieces(&pieces, &contour, &loops);
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
        let j = join_pieces(&pieces, &contour, &loops);
        assert_eq!((j.pieces, j.points.clone()), (1, a));
        assert_eq!(j.dropped_area, 3.0);
    }

    #[test]
    fn bridges_do_not_cross_other_loops() {
        // A loop of the other section sits between the pieces, inside the contour.
        let contour = rect(0.0, 0.0, 10.0, 3.0);
        let a = rect(0.0, 1.0, 3.0, 2.0);
        let b = rect(7.0, 1.0, 10.0, 2.0);
        let wall = rect(4.0, 0.5, 6.0, 2.5);
        let pieces = vec![a.clone(), b.clone()];
        let loops: Vec<&[Point]> = vec![&a, &b, &wall];
        let j = join_pieces(&pieces, &contour, &loops);
        // Around the obstacle there is no straight bridge between vertices: dropped.
        assert_eq!(j.pieces, 1);
        assert_eq!(j.dropped_area, 3.0);
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
        let j = join_pieces(&pieces, &contour, &loops);
        assert_eq!(j.pieces, 1, "{:?}", j.points);
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
        let j = join_pieces(&pieces, &contour, &loops);
        assert_eq!(j.pieces, 3);
        assert!((signed_area(&j.points) - 10.0).abs() < 1e-12);
        assert_eq!(j.points.len(), 12 + 4);
    }
}
