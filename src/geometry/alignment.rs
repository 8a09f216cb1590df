//! Contour alignment (paper §2.3, METHOD.md §4): choose where each closed curve of a region
//! starts, so that the surface joins corresponding points of consecutive curves.
//!
//! In: the region's curves bottom to top, each a closed loop of 3-D points or a single point.
//! Out: the index at which each curve should start ([`align_starts`]).
//!
//! The paper's baseline ([`baseline`]): for every candidate start on the first loop, take the
//! nearest point of the next curve, and so on; the shortest chain wins. Its nearest point is
//! blind to which side of a wall it lies on: where a wall is thinner than the distance between
//! slices (the skull's bone, 0.5–1 mm at 1 mm slices), it is often on the far side, the next
//! loop then runs the other way round the wall from its start, and the surface between them
//! sweeps through the wall (MeshLab counted 27,000 crossing faces on the skull from this).
//! Beyond the paper, the skinned surface joins the points of consecutive loops that have the
//! same chord-length fraction (paper Eq. 3), so each loop after the first starts where that
//! join is closest: the cyclic shift minimising the mean distance between the points of equal
//! arc-length fraction. The first loop keeps the start of the shortest baseline. Ties go to
//! the lowest index, so the result is deterministic.
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

/// Arc-length samples per loop for the search over every cyclic shift.
const COARSE_SAMPLES: usize = 128;
/// Most arc-length samples per loop when the best shift is refined.
const FINE_SAMPLES: usize = 2048;

/// Start index of every curve (0 for single points): the first loop's from [`baseline`], each
/// next loop's where its chord-length join with the previous loop is closest (module doc).
/// `spacing` is the resolution (mm along the loops) to which that start is refined.
pub fn align_starts(curves: &[&[[f64; 3]]], spacing: f64) -> Vec<usize> {
    let mut starts = baseline(curves);
    for k in 1..curves.len() {
        if curves[k - 1].len() < 3 || curves[k].len() < 3 {
            continue;
        }
        let a = Loop::new(curves[k - 1], starts[k - 1]);
        let b = Loop::new(curves[k], 0);
        // Every shift at a coarse resolution, then the neighbourhood of the best at a fine one.
        let coarse = best_shift(&a, &b, COARSE_SAMPLES, 0, COARSE_SAMPLES);
        let length = a.length().max(b.length());
        let fine =
            ((length / spacing.max(1e-9)).ceil() as usize).clamp(COARSE_SAMPLES, FINE_SAMPLES);
        let ratio = fine.div_ceil(COARSE_SAMPLES);
        let centre = coarse * fine / COARSE_SAMPLES;
        let shift = best_shift(&a, &b, fine, centre + fine - ratio, 2 * ratio + 1);
        starts[k] = b.vertex_at(shift as f64 / fine as f64);
    }
    starts
}

/// Among the shifts `first, first + 1, … (count of them, modulo n)` of `n` arc-length samples,
/// the one (in [0, n)) at which loop `b`'s samples lie closest on average to loop `a`'s.
fn best_shift(a: &Loop, b: &Loop, n: usize, first: usize, count: usize) -> usize {
    let (sa, sb) = (a.samples(n), b.samples(n));
    let mut best = (f64::INFINITY, 0);
    for c in 0..count {
        let shift = (first + c) % n;
        let total: f64 = (0..n).map(|i| d2(sa[i], sb[(i + shift) % n]).sqrt()).sum();
        if total < best.0 {
            best = (total, shift);
        }
    }
    best.1
}

/// A closed loop read from a start index, with its cumulative arc length.
struct Loop<'a> {
    points: &'a [[f64; 3]],
    start: usize,
    /// cum[i]: arc length from the start to its i-th point; cum[n]: the whole length.
    cum: Vec<f64>,
}

impl<'a> Loop<'a> {
    fn new(points: &'a [[f64; 3]], start: usize) -> Self {
        let n = points.len();
        let mut cum = Vec::with_capacity(n + 1);
        cum.push(0.0);
        for i in 0..n {
            let (p, q) = (points[(start + i) % n], points[(start + i + 1) % n]);
            cum.push(cum[i] + d2(p, q).sqrt());
        }
        Loop { points, start, cum }
    }

    fn length(&self) -> f64 {
        self.cum[self.points.len()]
    }

    fn point(&self, i: usize) -> [f64; 3] {
        self.points[(self.start + i) % self.points.len()]
    }

    /// `count` points evenly spaced by arc length, the first at the start.
    fn samples(&self, count: usize) -> Vec<[f64; 3]> {
        let len = self.length();
        let mut out = Vec::with_capacity(count);
        let mut i = 0;
        for s in 0..count {
            let at = len * s as f64 / count as f64;
            while i + 1 < self.points.len() && self.cum[i + 1] <= at {
                i += 1;
            }
            let seg = self.cum[i + 1] - self.cum[i];
            let t = if seg > 0.0 {
                (at - self.cum[i]) / seg
            } else {
                0.0
            };
            let (p, q) = (self.point(i), self.point(i + 1));
            out.push(std::array::from_fn(|d| p[d] + t * (q[d] - p[d])));
        }
        out
    }

    /// Index (in the original list) of the point nearest to arc-length fraction `f`.
    fn vertex_at(&self, f: f64) -> usize {
        let at = f.rem_euclid(1.0) * self.length();
        let i = self
            .cum
            .partition_point(|&c| c <= at)
            .clamp(1, self.points.len())
            - 1;
        let j = if self.cum[i + 1] - at < at - self.cum[i] {
            i + 1
        } else {
            i
        };
        (self.start + j) % self.points.len()
    }
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
