//! Closed (periodic) cubic B-spline curves in D dimensions (paper Eq. 1, METHOD §5).
//!
//! In: a [`PeriodicKnotVector`] with n+1 control points and n+1 control points `[f64; D]`.
//! Out: C(t) = Σ_{i=0}^{n+3} B_{i mod (n+1)} N_{i,4}(t), t ∈ [0, n+1) (any t is wrapped),
//! its first and second derivatives, and the true (global) point-to-curve distance.
//! Invariants: `control.len() == knots.n_control()`, every coordinate finite (checked by
//! [`ClosedCurve::try_new`]). Queries (`eval`, `distance_to`, …) never panic; a non-finite
//! parameter or query point yields NaN coordinates/distance, which callers must treat as
//! invalid input (the constructors and fitters reject NaN with an error). The curve is C²
//! everywhere, including across the seam t = 0 ≡ n+1, because the knots are extended
//! periodically and the control points are reused cyclically.

use super::basis;
use super::knot_vector::PeriodicKnotVector;
use super::vecops::{bbox, box_dist, dist, dot, is_finite, sub};
use super::BsplineError;

/// Samples per span when seeding the projection.
/// Smallest sub-interval of a span the global search splits down to, as a fraction.
const LEAF_DIVISIONS: f64 = 32.0;

/// A closed cubic B-spline curve.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedCurve<const D: usize> {
    knots: PeriodicKnotVector,
    control: Vec<[f64; D]>,
}

impl<const D: usize> ClosedCurve<D> {
    /// Validates that there are exactly n+1 finite control points for the knot vector.
    pub fn try_new(
        knots: PeriodicKnotVector,
        control: Vec<[f64; D]>,
    ) -> Result<Self, BsplineError> {
        if control.len() != knots.n_control() {
            return Err(BsplineError::InvalidArgument(format!(
                "got {} control points, expected {} for {} domain knots",
                control.len(),
                knots.n_control(),
                knots.domain().len()
            )));
        }
        if let Some(i) = control.iter().position(|p| !is_finite(p)) {
            return Err(BsplineError::NonFinite(format!(
                "control point {i} is {:?}",
                control[i]
            )));
        }
        Ok(Self { knots, control })
    }

    /// The degenerate curve of a cap: every control point equals `p` (C(t) ≡ p).
    pub fn point(knots: PeriodicKnotVector, p: [f64; D]) -> Result<Self, BsplineError> {
        let n = knots.n_control();
        Self::try_new(knots, vec![p; n])
    }

    pub fn knots(&self) -> &PeriodicKnotVector {
        &self.knots
    }

    pub fn control(&self) -> &[[f64; D]] {
        &self.control
    }

    /// True when all control points coincide (a cap point).
    pub fn is_point(&self) -> bool {
        self.control.iter().all(|c| *c == self.control[0])
    }

    /// (span in extended indexing, wrapped t, the span's four control points).
    #[inline]
    fn local(&self, t: f64) -> (usize, f64, [[f64; D]; 4]) {
        let t = self.knots.wrap(t);
        let s = self.knots.span(t);
        let n1 = self.control.len();
        let c = std::array::from_fn(|a| self.control[(s + a) % n1]);
        (s + 3, t, c)
    }

    /// C(t) by de Boor's algorithm.
    pub fn eval(&self, t: f64) -> [f64; D] {
        let (k, t, c) = self.local(t);
        basis::de_boor(self.knots.extended(), k, t, c)
    }

    /// (C(t), C'(t), C''(t)).
    pub fn derivs(&self, t: f64) -> ([f64; D], [f64; D], [f64; D]) {
        let (k, t, c) = self.local(t);
        let b = basis::ders(self.knots.extended(), k, t);
        let mut out = [[0.0; D]; 3];
        for (d, o) in out.iter_mut().enumerate() {
            for a in 0..4 {
                for x in 0..D {
                    o[x] += b[d][a] * c[a][x];
                }
            }
        }
        (out[0], out[1], out[2])
    }

    /// (C(t), C'(t)), cheaper than [`Self::derivs`].
    pub fn eval_d1(&self, t: f64) -> ([f64; D], [f64; D]) {
        let (k, t, c) = self.local(t);
        let (b0, b1) = basis::values_d1(self.knots.extended(), k, t);
        let mut p = [0.0; D];
        let mut d = [0.0; D];
        for a in 0..4 {
            for x in 0..D {
                p[x] += b0[a] * c[a][x];
                d[x] += b1[a] * c[a][x];
            }
        }
        (p, d)
    }

    /// Bounding boxes of each span's four control points (they hold the span's piece).
    pub fn span_boxes(&self) -> Vec<([f64; D], [f64; D])> {
        let n1 = self.control.len();
        (0..n1)
            .map(|s| bbox((0..4).map(|a| &self.control[(s + a) % n1])))
            .collect()
    }

    /// Local closest point from the seed `t0`: Newton on g(t) = (C−P)·C′ with backtracking
    /// on |C−P|, t wrapping. Returns (distance, t); never worse than the seed.
    pub fn project_from(&self, p: &[f64; D], t0: f64) -> (f64, f64) {
        let period = self.knots.period();
        let mut t = self.knots.wrap(t0);
        let (mut c, mut d1, mut d2) = self.derivs(t);
        let mut f = dist(&c, p);
        for _ in 0..30 {
            let r = sub(&c, p);
            let g = dot(&r, &d1);
            let gn = dot(&d1, &d1);
            if gn <= 1e-300 {
                break;
            }
            let h = gn + dot(&r, &d2);
            // Gauss–Newton when the Hessian is not positive (far from the curve's centre).
            let mut step = if h > 1e-12 * gn { -g / h } else { -g / gn };
            let max_step = 0.5 * period;
            step = step.clamp(-max_step, max_step);
            let mut improved = false;
            for _ in 0..12 {
                let tn = self.knots.wrap(t + step);
                let cn = self.eval(tn);
                let fnew = dist(&cn, p);
                if fnew <= f {
                    t = tn;
                    f = fnew;
                    improved = true;
                    break;
                }
                step *= 0.5;
            }
            // A parameter step below 1e-11 moves the point by ~1e-10 mm: converged.
            if !improved || step.abs() < 1e-11 {
                break;
            }
            (c, d1, d2) = self.derivs(t);
        }
        (f, t)
    }

    /// The true distance from `p` to the curve and the parameter of the closest point:
    /// a local projection from the best span start gives an upper bound; then every span
    /// whose control-point bounding box (it holds the span's piece: convex hull property)
    /// is nearer than the current best is sampled and refined by Newton.
    pub fn distance_to(&self, p: &[f64; D]) -> (f64, f64) {
        let dom = self.knots.domain();
        let n1 = self.control.len();
        let mut best = (f64::INFINITY, 0.0);
        for &t in &dom[..n1] {
            let d = dist(&self.eval(t), p);
            if d < best.0 {
                best = (d, t);
            }
        }
        best = self.project_from(p, best.1);
        self.refine_global(p, best)
    }

    /// As [`Self::distance_to`], seeded with a parameter guess (e.g. the fitted parameter).
    pub fn distance_to_hint(&self, p: &[f64; D], t_hint: f64) -> (f64, f64) {
        let best = self.project_from(p, t_hint);
        self.refine_global(p, best)
    }

    /// As [`Self::distance_to_hint`] with the span boxes precomputed ([`Self::span_boxes`]),
    /// for many queries against one curve.
    pub fn distance_with_boxes(
        &self,
        p: &[f64; D],
        t_hint: f64,
        boxes: &[([f64; D], [f64; D])],
    ) -> (f64, f64) {
        let best = self.project_from(p, t_hint);
        self.refine_boxes(p, best, boxes)
    }

    fn refine_global(&self, p: &[f64; D], best: (f64, f64)) -> (f64, f64) {
        let boxes = self.span_boxes();
        self.refine_boxes(p, best, &boxes)
    }

    /// Global refinement of a local result `best` = (distance, t): every span whose box is
    /// nearer than `best` is searched by branch and bound. On span s of width w the curve
    /// moves at most L = 3·diag/w per unit of t (the hodograph's control points are 3·(B_{i+1}
    /// − B_i) over knot windows of at least w, and consecutive control points of the span lie
    /// in its box of diagonal diag), so no point of a sub-interval of width h is nearer than
    /// the distance at its middle minus L·h/2: sub-intervals that cannot beat `best` are
    /// dropped, the others halved down to w / 32 and refined by Newton from their middle.
    /// Sampling four points per span and one Newton run missed narrow minima (0.23 against
    /// 0.036 on a random curve).
    pub(crate) fn refine_boxes(
        &self,
        p: &[f64; D],
        mut best: (f64, f64),
        boxes: &[([f64; D], [f64; D])],
    ) -> (f64, f64) {
        let dom = self.knots.domain();
        let mut stack: Vec<(f64, f64)> = Vec::new();
        for (s, (lo, hi)) in boxes.iter().enumerate() {
            // Relative slack so that rounding never hides a nearer span.
            if box_dist(p, lo, hi) >= best.0 * (1.0 - 1e-12) {
                continue;
            }
            let (a, b) = (dom[s], dom[s + 1]);
            let lip = 3.0 * dist(lo, hi) / (b - a);
            let leaf = (b - a) / LEAF_DIVISIONS;
            stack.clear();
            stack.push((a, b));
            while let Some((x, y)) = stack.pop() {
                let m = 0.5 * (x + y);
                let d = dist(&self.eval(m), p);
                if d < best.0 {
                    best = (d, m);
                }
                if d - 0.5 * lip * (y - x) >= best.0 * (1.0 - 1e-12) {
                    continue;
                }
                if y - x <= leaf {
                    let r = self.project_from(p, m);
                    if r.0 < best.0 {
                        best = r;
                    }
                } else {
                    stack.push((m, y));
                    stack.push((x, m));
                }
            }
        }
        best
    }
}
