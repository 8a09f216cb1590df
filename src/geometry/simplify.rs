//! Polygon compression within a tolerance (Douglas–Peucker on a closed polygon).
//!
//! Hand-written rather than imageproc's `approximate_polygon_dp`: that one measures distance to
//! the infinite line through a chord, not to the chord itself, so its output can leave points
//! farther than the tolerance, and it panics on closed input whose ends coincide. Here every
//! dropped point (and so, by convexity of the distance to a segment, every dropped edge) lies
//! within `tol` of the kept polygon, and the result stays simple: if simplification would make
//! a self-intersection, the tolerance is halved until it does not.

use super::polygon::{dist, is_simple, point_segment_distance, Point};

/// Compress a closed polygon. Returns at least 3 points when the input has at least 3.
pub fn simplify_closed(pts: &[Point], tol: f64) -> Vec<Point> {
    if pts.len() <= 4 || tol <= 0.0 {
        return pts.to_vec();
    }
    let mut t = tol;
    for _ in 0..8 {
        let out = simplify_once(pts, t);
        if is_simple(&out) {
            return out;
        }
        t *= 0.5;
    }
    pts.to_vec()
}

/// Compress an open chain, keeping its ends (Douglas–Peucker on segments).
pub fn simplify_open(pts: &[Point], tol: f64) -> Vec<Point> {
    let Some(last) = pts.len().checked_sub(1) else {
        return Vec::new();
    };
    let mut keep = vec![false; pts.len()];
    keep[0] = true;
    keep[last] = true;
    mark(pts, 0, last, tol, &mut keep);
    (0..pts.len())
        .filter(|&i| keep[i])
        .map(|i| pts[i])
        .collect()
}

fn simplify_once(pts: &[Point], tol: f64) -> Vec<Point> {
    let n = pts.len();
    // Split the loop at point 0 and the point farthest from it: two open chains.
    let far = (1..n)
        .max_by(|&a, &b| dist(pts[0], pts[a]).total_cmp(&dist(pts[0], pts[b])))
        .unwrap_or(n / 2);
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[far] = true;
    mark(pts, 0, far, tol, &mut keep);
    mark(pts, far, n, tol, &mut keep);
    let mut out: Vec<Point> = (0..n).filter(|&i| keep[i]).map(|i| pts[i]).collect();
    if out.len() < 3 {
        // Two points make no polygon: keep the point farthest from their chord.
        let (a, b) = (pts[0], pts[far]);
        let third = (1..n)
            .filter(|&i| i != far)
            .max_by(|&i, &j| {
                point_segment_distance(pts[i], a, b)
                    .total_cmp(&point_segment_distance(pts[j], a, b))
            })
            .unwrap_or(1);
        let mut idx = vec![0, far, third];
        idx.sort_unstable();
        out = idx.into_iter().map(|i| pts[i]).collect();
    }
    out
}

/// Mark the points of the chain `lo..=hi` (index `n` means point 0 again) that must stay
/// (Douglas–Peucker on segments). Iterative, so long chains cannot overflow the stack.
pub(crate) fn mark(pts: &[Point], lo: usize, hi: usize, tol: f64, keep: &mut [bool]) {
    let n = pts.len();
    let mut stack = vec![(lo, hi)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (pts[a % n], pts[b % n]);
        let mut worst = (0.0, a);
        for (i, &p) in pts.iter().enumerate().take(b).skip(a + 1) {
            let d = point_segment_distance(p, pa, pb);
            if d > worst.0 {
                worst = (d, i);
            }
        }
        if worst.0 > tol {
            keep[worst.1] = true;
            stack.push((a, worst.1));
            stack.push((worst.1, b));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::boundary_distance;

    #[test]
    fn circle_compresses_within_tolerance() {
        let pts: Vec<Point> = (0..720)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 720.0;
                [10.0 * a.cos(), 10.0 * a.sin()]
            })
            .collect();
        let out = simplify_closed(&pts, 0.05);
        assert!(out.len() < 60, "{} points", out.len());
        for p in &pts {
            assert!(boundary_distance(&out, *p) <= 0.05 + 1e-12);
        }
    }

    #[test]
    fn collinear_square_keeps_its_corners() {
        let mut pts = Vec::new();
        for k in 0..10 {
            pts.push([k as f64, 0.0]);
        }
        for k in 0..10 {
            pts.push([10.0, k as f64]);
        }
        for k in 0..10 {
            pts.push([10.0 - k as f64, 10.0]);
        }
        for k in 0..10 {
            pts.push([0.0, 10.0 - k as f64]);
        }
        let out = simplify_closed(&pts, 0.01);
        assert_eq!(
            out,
            vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]
        );
    }
}
