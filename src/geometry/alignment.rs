//! Contour alignment (paper §2.3, METHOD.md §4): choose where each closed curve of a region
//! starts so that the u = 0 seam runs straight up the surface instead of twisting.
//!
//! In: the region's curves bottom to top, each a closed loop of 3-D points or a single point.
//! Out: the index at which each curve should start. For every candidate start on the first
//! loop, a baseline is built greedily (the nearest point of the next curve, and so on); the
//! shortest baseline wins. Ties go to the lowest index, so the result is deterministic.

/// Upper bound on the start candidates tried on the first loop: evenly spaced over it, so a
/// 5,000-point contour costs no more than a 256-point one. The greedy chain from each
/// candidate still visits every curve's every point.
const MAX_CANDIDATES: usize = 256;

fn d2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

fn nearest(curve: &[[f64; 3]], p: [f64; 3]) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, &q) in curve.iter().enumerate() {
        let d = d2(p, q);
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

/// Start index of every curve (0 for single points). Empty curves are not allowed.
pub fn baseline(curves: &[&[[f64; 3]]]) -> Vec<usize> {
    let Some(first) = curves.first() else {
        return Vec::new();
    };
    let step = first.len().div_ceil(MAX_CANDIDATES).max(1);
    let mut best: Option<(f64, Vec<usize>)> = None;
    for start in (0..first.len()).step_by(step) {
        let mut path = Vec::with_capacity(curves.len());
        path.push(start);
        let mut p = first[start];
        let mut length = 0.0;
        for c in &curves[1..] {
            let k = nearest(c, p);
            length += d2(p, c[k]).sqrt();
            p = c[k];
            path.push(k);
        }
        if best.as_ref().is_none_or(|(l, _)| length < *l) {
            best = Some((length, path));
        }
    }
    best.map(|(_, p)| p).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(n: usize, r: f64, z: f64, phase: f64) -> Vec<[f64; 3]> {
        (0..n)
            .map(|k| {
                let a = phase + k as f64 * std::f64::consts::TAU / n as f64;
                [r * a.cos(), r * a.sin(), z]
            })
            .collect()
    }

    #[test]
    fn rotated_rings_align_on_a_straight_seam() {
        let a = ring(40, 10.0, 0.0, 0.0);
        // The second ring's list starts a quarter turn later; the third's half a turn.
        let b: Vec<[f64; 3]> = {
            let mut v = ring(40, 10.0, 1.0, 0.0);
            v.rotate_left(10);
            v
        };
        let c: Vec<[f64; 3]> = {
            let mut v = ring(40, 10.0, 2.0, 0.0);
            v.rotate_left(20);
            v
        };
        let starts = baseline(&[&a, &b, &c]);
        assert_eq!(starts, vec![0, 30, 20]);
    }

    #[test]
    fn a_cap_point_first_gives_one_candidate() {
        let cap = [[0.0, 0.0, -0.5]];
        let a = ring(12, 3.0, 0.0, 0.3);
        let starts = baseline(&[&cap, &a]);
        assert_eq!(starts.len(), 2);
        assert_eq!(starts[0], 0);
    }
}
