//! Ridge caps (beyond the paper): the cap of a contour that is not star-shaped around its
//! innermost point.
//!
//! The paper caps a contour onto one point. Where the contour does not see all of itself from
//! that point — a curved sliver of bone, a C, a contour with deep bays — the surface's lines
//! from the contour to the point pass through the contour's own wall and the cap folds. Here
//! such a contour caps onto a zero-width loop instead: a path along its ridge, out and back,
//! like the roof of a tent. Each side of the contour rises to the pass of the path beside it.
//!
//! In: a simple counter-clockwise contour (mm) and a sample step (mm). Out: the loop (the
//! path's points out, then its interior points back, so every interior point appears twice and
//! each path edge once in each direction: a mesh zipped onto it closes), or `None` where no
//! path passes the checks below (the caller keeps the point).
//!
//! The path pairs the contour's points at equal arc length either side of a tip `a`: the
//! midpoint of `C(a + s)` and `C(a − s)` for s from 0 to half the perimeter. The tip chosen
//! makes the pairs closest (least summed cross-chord length), which on a sliver puts them
//! across its width and the path on its medial line. Kept only if every cross chord and the
//! path stay inside the contour and the path is simple; then compressed like the contours.

use super::polygon::{
    boundary_distance, contains, dist, orient, perimeter, point_segment_distance,
    segments_intersect, Point,
};
use super::simplify::simplify_open;

/// cos 45°: a path turning back by more than 135° folds.
const FOLD_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// A cross chord shorter than this many sample steps may fail its checks by a tip (8 cells).
const SHORT_CHORD_STEPS: f64 = 16.0;
/// The path may be cut back at each tip by at most 1/TIP_TRIM_MAX of its samples.
const TIP_TRIM_MAX: usize = 8;
/// Most samples of the ridge path.
const MAX_SAMPLES: usize = 2048;
/// Tip positions per contour in the coarse search (pairs of them are tried: quadratic).
const TIP_GRID: usize = 64;
/// Cross chords per candidate pair of tips in the coarse search (twice that when refining).
const CHORD_SAMPLES: usize = 32;
/// Refinement of each tip: this many steps either side, each 1/REFINE_STEPS of a coarse step.
const REFINE_STEPS: i32 = 8;

/// Whether every edge of the counter-clockwise `contour` faces `p` (p is in its kernel): the
/// lines from `p` to the contour then do not cross the contour. An edge may miss by `slack`
/// (mm, `p`'s distance behind its line).
pub fn is_star_around(contour: &[Point], p: Point, slack: f64) -> bool {
    let n = contour.len();
    (0..n).all(|i| {
        let (a, b) = (contour[i], contour[(i + 1) % n]);
        let len = dist(a, b);
        len == 0.0 || orient(a, b, p) >= -slack * len
    })
}

/// The ridge loop of `contour` (see the module doc), sampled every `step` mm before
/// compression within `tol` mm, its path's ends `tip_mm` back along it from the contour's
/// tips (at most 1/[`TIP_TRIM_MAX`] of it).
pub fn ridge_loop(contour: &[Point], step: f64, tol: f64, tip_mm: f64) -> Option<Vec<Point>> {
    let length = perimeter(contour);
    if !(length.is_finite() && step > 0.0 && length > 8.0 * step) {
        return None;
    }
    let at = ArcLength::new(contour);
    // Tips a and b split the contour into the sides a→b and b→a; the side a→b at fraction
    // s pairs with the side b→a at fraction 1 − s. The tips giving the shortest chords on
    // average win: on a coarse grid of tip positions, then refined around the best.
    let mean_chord = |a: f64, b: f64, k: usize| -> f64 {
        let lb = if b > a { b - a } else { b + length - a };
        let la = length - lb;
        (1..k)
            .map(|i| {
                let s = i as f64 / k as f64;
                dist(at.point(a + s * lb), at.point(a - s * la))
            })
            .sum::<f64>()
            / (k - 1) as f64
    };
    let coarse = length / TIP_GRID as f64;
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for i in 0..TIP_GRID {
        for j in i + 2..i + TIP_GRID - 1 {
            let (a, b) = (i as f64 * coarse, (j % TIP_GRID) as f64 * coarse);
            let c = mean_chord(a, b, CHORD_SAMPLES);
            if c < best.0 {
                best = (c, a, b);
            }
        }
    }
    let fine = coarse / REFINE_STEPS as f64;
    let (_, a0, b0) = best;
    for da in -REFINE_STEPS..=REFINE_STEPS {
        for db in -REFINE_STEPS..=REFINE_STEPS {
            let (a, b) = (a0 + da as f64 * fine, b0 + db as f64 * fine);
            let c = mean_chord(a, b, 2 * CHORD_SAMPLES);
            if c < best.0 {
                best = (c, a, b);
            }
        }
    }
    let (_, a, b) = best;
    let lb = (b - a).rem_euclid(length);
    let la = length - lb;
    let half = ((lb.max(la) / step).ceil() as usize).clamp(8, MAX_SAMPLES);
    let pair = |i: usize| {
        let s = i as f64 / half as f64;
        (at.point(a + s * lb), at.point(a - s * la))
    };
    let path: Vec<Point> = (0..=half)
        .map(|i| {
            let (p, r) = pair(i);
            [0.5 * (p[0] + r[0]), 0.5 * (p[1] + r[1])]
        })
        .collect();

    // Every cross chord inside the contour: it may touch the contour (at its ends, or along
    // a straight stretch at a tip) but not cross it, and its midpoint is inside or on it.
    // Near a tip a dent may spoil short chords: the path is cut back past them (the tip's
    // contour points then rise to the path's new end), if that leaves most of it.
    let eps = 1e-9 * length;
    let crosses_contour = |a: Point, b: Point| crosses_polygon(a, b, contour, eps);
    let on_or_inside = |p: Point| contains(contour, p) || boundary_distance(contour, p) < eps;
    let (mut first, mut last) = (0, half);
    for (i, &mid) in path.iter().enumerate().take(half).skip(1) {
        let (p, r) = pair(i);
        if on_or_inside(mid) && !crosses_contour(p, r) {
            continue;
        }
        if dist(p, r) >= SHORT_CHORD_STEPS * step {
            return None;
        }
        if i < half / 2 {
            first = first.max(i + 1);
        } else {
            last = last.min(i - 1);
        }
    }
    if first > half / TIP_TRIM_MAX || last < half - half / TIP_TRIM_MAX {
        return None;
    }
    // The fitted contour rounds a sharp tip by up to the fitting tolerance; a path ending at
    // the polygon's tip then pokes out past the fitted one, and the cap folds there (skull
    // surface 389: a sliver capped onto its ridge, 9 faces crossing). Its ends stay back.
    let back = |from: usize, step: isize, bound: usize| {
        let (mut k, mut run) = (from, 0.0);
        while k != bound {
            let next = (k as isize + step) as usize;
            run += dist(path[k], path[next]);
            if run > tip_mm {
                break;
            }
            k = next;
        }
        k
    };
    first = back(first, 1, half / TIP_TRIM_MAX);
    last = back(last, -1, half - half / TIP_TRIM_MAX);
    let kept = settled_path(&path[first..=last], tol, crosses_contour)?;
    let k = kept.len();
    if k < 3 {
        return None;
    }
    // Out along the path, back over its interior points.
    let mut ridge = kept.clone();
    ridge.extend(kept[1..k - 1].iter().rev());
    Some(ridge)
}

/// `path` compressed within `tol` (its ends stay), if it stays a clean path: no edge
/// `crosses_contour`, no turn sharper than 135°, and non-adjacent edges at
/// least `tol` apart (or later vertex welding would merge the two runs). A spike of the
/// contour on one side makes a midpoint path run out and back, which these checks catch.
pub(super) fn settled_path(
    path: &[Point],
    tol: f64,
    crosses_contour: impl Fn(Point, Point) -> bool,
) -> Option<Vec<Point>> {
    if path.is_empty() {
        return None;
    }
    let kept = simplify_open(path, tol);
    let k = kept.len();
    for i in 0..k - 1 {
        if crosses_contour(kept[i], kept[i + 1]) {
            return None;
        }
        if i + 2 < k {
            let (a, b, c) = (kept[i], kept[i + 1], kept[i + 2]);
            let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
            if u[0] * v[0] + u[1] * v[1] < -FOLD_COS * dist(a, b) * dist(b, c) {
                return None;
            }
        }
        for j in i + 2..k - 1 {
            let (a, b, c, d) = (kept[i], kept[i + 1], kept[j], kept[j + 1]);
            let apart = [
                point_segment_distance(a, c, d),
                point_segment_distance(b, c, d),
                point_segment_distance(c, a, b),
                point_segment_distance(d, a, b),
            ]
            .into_iter()
            .fold(f64::INFINITY, f64::min);
            if segments_intersect(a, b, c, d) || apart < tol {
                return None;
            }
        }
    }
    Some(kept)
}

/// Whether segment ab [`crosses`] an edge of the closed polygon `poly`.
pub(super) fn crosses_polygon(a: Point, b: Point, poly: &[Point], eps: f64) -> bool {
    let n = poly.len();
    (0..n).any(|k| crosses(a, b, poly[k], poly[(k + 1) % n], eps))
}

/// Whether segments ab and cd cross at a point interior to both. Touching is not crossing,
/// and a point within `eps` (mm) of a line counts as on it: resampled points lie on the
/// contour's edges only within rounding.
pub(super) fn crosses(a: Point, b: Point, c: Point, d: Point, eps: f64) -> bool {
    let side = |p: Point, q: Point, r: Point| {
        let (x, e) = (orient(p, q, r), eps * dist(p, q));
        (x > e) as i8 - (x < -e) as i8
    };
    let (o1, o2) = (side(a, b, c), side(a, b, d));
    let (o3, o4) = (side(c, d, a), side(c, d, b));
    o1 * o2 < 0 && o3 * o4 < 0
}

/// Points of a closed polygon by arc length from its first vertex (any real, taken modulo the
/// perimeter).
pub(super) struct ArcLength<'a> {
    pts: &'a [Point],
    cum: Vec<f64>,
}

impl<'a> ArcLength<'a> {
    pub(super) fn new(pts: &'a [Point]) -> Self {
        let n = pts.len();
        let mut cum = Vec::with_capacity(n + 1);
        cum.push(0.0);
        for i in 0..n {
            cum.push(cum[i] + dist(pts[i], pts[(i + 1) % n]));
        }
        ArcLength { pts, cum }
    }

    pub(super) fn point(&self, s: f64) -> Point {
        let n = self.pts.len();
        let total = self.cum[n];
        let s = s.rem_euclid(total);
        let i = self.cum.partition_point(|&c| c <= s).clamp(1, n) - 1;
        let e = self.cum[i + 1] - self.cum[i];
        let t = if e > 0.0 { (s - self.cum[i]) / e } else { 0.0 };
        let (p, q) = (self.pts[i], self.pts[(i + 1) % n]);
        [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::circle;

    /// A ring sector of radii r0 < r1 over angles 0..sweep, counter-clockwise.
    fn arc_sliver(r0: f64, r1: f64, sweep: f64, n: usize) -> Vec<Point> {
        let mut pts: Vec<Point> = (0..=n)
            .map(|k| {
                let a = sweep * k as f64 / n as f64;
                [r1 * a.cos(), r1 * a.sin()]
            })
            .collect();
        pts.extend((0..=n).rev().map(|k| {
            let a = sweep * k as f64 / n as f64;
            [r0 * a.cos(), r0 * a.sin()]
        }));
        pts
    }

    #[test]
    fn a_disc_is_star_shaped_around_its_centre_and_a_sliver_is_not() {
        assert!(is_star_around(
            &circle(0.0, 0.0, 5.0, 64, true),
            [0.0, 0.0],
            0.0
        ));
        let s = arc_sliver(49.5, 50.5, 1.5, 100);
        let mid = [50.0 * 0.75f64.cos(), 50.0 * 0.75f64.sin()];
        assert!(!is_star_around(&s, mid, 0.0));
    }

    #[test]
    fn a_curved_sliver_caps_onto_its_medial_arc_out_and_back() {
        let s = arc_sliver(49.0, 51.0, 1.5, 200);
        let lp = ridge_loop(&s, 0.1, 0.05, 0.0).expect("a ridge");
        let k = lp.len() / 2 + 1; // path length in points
                                  // Every interior point of the path is visited twice, out and back.
        for i in 1..k - 1 {
            assert_eq!(lp[i], lp[lp.len() - i]);
        }
        // On the medial arc (radius 50) away from the tips, within the sampling.
        for p in &lp[..k] {
            let r = p[0].hypot(p[1]);
            let a = p[1].atan2(p[0]);
            if a > 0.05 && a < 1.45 {
                assert!((r - 50.0).abs() < 0.1, "radius {r} at angle {a}");
            }
        }
        // Spanning the sliver from end to end.
        let ang: Vec<f64> = lp.iter().map(|p| p[1].atan2(p[0])).collect();
        let (lo, hi) = ang
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &a| (l.min(a), h.max(a)));
        assert!(lo < 0.03 && hi > 1.47, "{lo} {hi}");
        // The path stays inside the sliver.
        for p in &lp {
            let d = (0..s.len())
                .map(|i| point_segment_distance(*p, s[i], s[(i + 1) % s.len()]))
                .fold(f64::MAX, f64::min);
            assert!(contains(&s, *p) || d < 1e-9);
        }
    }

    #[test]
    fn the_path_stays_back_from_the_tips_by_the_given_length() {
        // Radius 50: 2 mm along the medial arc is 0.04 rad (less up to a sample: the trim
        // stops short of exceeding it, and the path is then compressed).
        let s = arc_sliver(49.0, 51.0, 1.5, 200);
        let span = |tip_mm: f64| {
            let lp = ridge_loop(&s, 0.1, 0.05, tip_mm).expect("a ridge");
            let ang: Vec<f64> = lp.iter().map(|p| p[1].atan2(p[0])).collect();
            let lo = ang.iter().copied().fold(f64::MAX, f64::min);
            let hi = ang.iter().copied().fold(f64::MIN, f64::max);
            (lo, hi, lp)
        };
        let (lo, hi, _) = span(0.0);
        assert!(lo < 0.005 && hi > 1.495, "untrimmed: {lo} {hi}");
        let (lo, hi, lp) = span(2.0);
        assert!(
            lo > 0.035 && lo < 0.045 && hi < 1.465 && hi > 1.455,
            "trimmed: {lo} {hi}"
        );
        let k = lp.len() / 2 + 1;
        for i in 1..k - 1 {
            assert_eq!(lp[i], lp[lp.len() - i], "still out and back");
        }
        // A trim longer than the bound (an eighth of the path at each end) stops there.
        let (lo, hi, _) = span(1000.0);
        assert!(lo < 0.2 && hi > 1.3, "bounded: {lo} {hi}");
    }

    #[test]
    fn a_comb_gets_no_ridge() {
        // An E: pairing the ends of its outer prongs sends the middle prong's chords across
        // the gaps between the prongs, outside the contour.
        let e = vec![
            [0.0, 0.0],
            [20.0, 0.0],
            [20.0, 2.0],
            [2.0, 2.0],
            [2.0, 9.0],
            [20.0, 9.0],
            [20.0, 11.0],
            [2.0, 11.0],
            [2.0, 18.0],
            [20.0, 18.0],
            [20.0, 20.0],
            [0.0, 20.0],
        ];
        assert!(!is_star_around(&e, [1.0, 10.0], 0.0));
        assert!(ridge_loop(&e, 0.1, 0.05, 0.0).is_none());
    }
}
