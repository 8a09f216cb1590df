//! Fitting one closed contour (paper §2.4, METHOD §6) and Algorithm 1 (fewest control points).
//!
//! In: contour points P_0..P_m (closed: P_m → P_0 is an edge, P_m ≠ P_0), a number of control
//! points n+1 or a tolerance. Out: a [`ContourFit`]: the curve, each point's closest-point
//! parameter and true distance, the maximum, and whether every point is within tolerance.
//!
//! - Parameters: chord length, Eq. 3 (u_0 = 0, closing edge included, scaled to [0, n+1)).
//! - m = n: interpolation on Eq. 4 knots (averaging, d = 1). n > m: interpolate D(t), insert
//!   n − m points on D so that all n+1 are as evenly spaced (by arc length on D) as possible,
//!   interpolate those. m > n: least squares on Eq. 5 knots, then Rogers–Fog parameter
//!   correction (u_0 fixed, at most `max_corrections` = 7 rounds), keeping the best round
//!   (by max residual: more rounds can make it worse, as the paper warns).
//! - Beyond the paper, both switchable or harmless: between rounds, points outside 0.9 × tol
//!   get more least-squares weight (`minimax_weights`, Lawson-style); and a fit whose residual
//!   cannot reach 1.5 × tol even if the last round's improvement rate continued is abandoned
//!   early (it would fail anyway; this makes the failing trials of the searches cheap).
//! - Success: every point's *true* distance to the curve ≤ tolerance, and so is every extra
//!   point (resampled on D(t), or filling a knot span that holds no point): a curve that
//!   swings away between the points does not follow the contour. |P_j − C(u_j)| is an
//!   upper bound of it, so it is checked first, then a local projection, and the global
//!   search only where that still exceeds the tolerance.
//! - The normal equations are solved in O(n) ([`CyclicBandedMatrix`]); a fit costs O(m + n)
//!   per round, Algorithm 1 O(log m) fits.
//! - Parameters and knots are in [0, n+1); contours may be in any dimension D (the pipeline
//!   uses D = 3, patient mm).
//!
//! Input cleaning ([`clean_contour`]): non-finite coordinates are an error; consecutive
//! repeated points (and a last point repeating the first) are *dropped*, not rejected — a
//! repeated point adds no geometry but would give a zero chord and two equal parameters.
//! "Repeated" means closer than 1e-12 × the contour's bounding-box diagonal. Fewer than four
//! distinct points, zero length and collinear points are [`BsplineError::Degenerate`].
//!
//! Algorithm 1 deviates from the paper's Step 6 on purpose: the paper returns "the previous
//! curve fitted on T_pre", which is the *last tried* knot vector and can be a failed one (e.g.
//! success at 45, failures at 42, 43, 44 → it returns the failed 43). We keep the invariant
//! "N_upp is feasible, its fit is stored" and return that fit.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::basis;
use super::closed_curve::ClosedCurve;
use super::cyclic_solver::CyclicBandedMatrix;
use super::knot_vector::PeriodicKnotVector;
use super::vecops::{add, dist, dot, norm, scale, sub};
use super::BsplineError;

/// Options of the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Maximum allowed distance (same unit as the points, mm in the pipeline).
    pub tolerance: f64,
    /// Bound on Rogers–Fog correction rounds (the paper uses 7: more can make things worse).
    pub max_corrections: usize,
    /// Beyond the paper: between correction rounds, raise the least-squares weight of every
    /// point outside 0.9 × tolerance by (error / (0.9 tol))² (Lawson-style reweighting towards
    /// the minimax fit). The paper's criterion is a max error, least squares minimises the
    /// sum of squares; reweighting lets fewer control points meet the tolerance. `false`
    /// gives the paper's plain least squares.
    pub minimax_weights: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            tolerance: 0.1,
            max_corrections: 7,
            minimax_weights: true,
        }
    }
}

impl FitOptions {
    /// Options with this tolerance and the paper's 7 correction rounds.
    pub fn new(tolerance: f64) -> Self {
        Self {
            tolerance,
            ..Self::default()
        }
    }

    pub(crate) fn validate(&self) -> Result<(), BsplineError> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(BsplineError::InvalidArgument(format!(
                "tolerance must be positive and finite, got {}",
                self.tolerance
            )));
        }
        Ok(())
    }
}

/// A fitted contour.
#[derive(Debug, Clone, PartialEq)]
pub struct ContourFit<const D: usize> {
    pub curve: ClosedCurve<D>,
    /// The cleaned contour points the fit refers to (see [`clean_contour`]).
    pub points: Vec<[f64; D]>,
    /// Per point: parameter of its closest point found on the curve.
    pub params: Vec<f64>,
    /// Per point: distance to that closest point. It is the true (global) distance for the
    /// points that decide `max_error`, and an upper bound of it (a local projection from the
    /// fitted parameter, in practice equal) for points below the maximum.
    pub errors: Vec<f64>,
    /// Maximum over the points of the true distance to the curve (exact).
    pub max_error: f64,
    /// Every point within the tolerance.
    pub met: bool,
}

impl<const D: usize> ContourFit<D> {
    /// Number of control points, n+1.
    pub fn n_control(&self) -> usize {
        self.curve.control().len()
    }
}

/// Finite check and removal of consecutive repeated points (see the module doc).
/// May return a single point (a zero-length contour); never an empty list.
pub fn clean_contour<const D: usize>(points: &[[f64; D]]) -> Result<Vec<[f64; D]>, BsplineError> {
    if points.is_empty() {
        return Err(BsplineError::Degenerate("contour has 0 points".into()));
    }
    if let Some(i) = points.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
        return Err(BsplineError::NonFinite(format!(
            "contour point {i} of {} is {:?}",
            points.len(),
            points[i]
        )));
    }
    let (lo, hi) = super::vecops::bbox(points.iter());
    let diag = dist(&lo, &hi);
    let eps = 1e-12 * diag;
    let mut out: Vec<[f64; D]> = Vec::with_capacity(points.len());
    for p in points {
        match out.last() {
            Some(q) if dist(p, q) <= eps => {}
            _ => out.push(*p),
        }
    }
    while out.len() > 1 && dist(&out[0], &out[out.len() - 1]) <= eps {
        out.pop();
    }
    Ok(out)
}

/// Cleans and checks that the contour can carry a closed cubic curve: ≥ 4 distinct points,
/// non-zero length, not collinear.
pub(crate) fn prepare_contour<const D: usize>(
    points: &[[f64; D]],
) -> Result<Vec<[f64; D]>, BsplineError> {
    let pts = clean_contour(points)?;
    if pts.len() < 4 {
        return Err(BsplineError::Degenerate(format!(
            "contour has {} distinct points ({} given), a closed cubic needs at least 4",
            pts.len(),
            points.len()
        )));
    }
    check_not_collinear(&pts)?;
    Ok(pts)
}

fn check_not_collinear<const D: usize>(pts: &[[f64; D]]) -> Result<(), BsplineError> {
    // Approximate diameter: farthest from P_0, then farthest from that.
    let far = |from: &[f64; D]| {
        pts.iter()
            .copied()
            .max_by(|a, b| dist(a, from).total_cmp(&dist(b, from)))
            .unwrap_or(*from)
    };
    let a = far(&pts[0]);
    let b = far(&a);
    let ab = sub(&b, &a);
    let len = norm(&ab);
    if !(len > 0.0) {
        return Err(BsplineError::Degenerate(format!(
            "contour of {} points has zero length",
            pts.len()
        )));
    }
    let dir = scale(&ab, 1.0 / len);
    let off = pts
        .iter()
        .map(|p| {
            let ap = sub(p, &a);
            norm(&sub(&ap, &scale(&dir, dot(&ap, &dir))))
        })
        .fold(0.0, f64::max);
    if off <= 1e-9 * len {
        return Err(BsplineError::Degenerate(format!(
            "contour of {} points is collinear (max offset {off:.3e} from a line of length {len:.3e})",
            pts.len()
        )));
    }
    Ok(())
}

/// Chord-length parameters (Eq. 3) in [0, n_control): u_0 = 0, u_j ∝ polygon length to P_j,
/// the closed length (with P_m → P_0) mapping to n_control. Needs a cleaned contour.
pub fn chord_params<const D: usize>(points: &[[f64; D]], n_control: usize) -> Vec<f64> {
    let m1 = points.len();
    let mut u = Vec::with_capacity(m1);
    let mut acc = 0.0;
    for j in 0..m1 {
        u.push(acc);
        acc += dist(&points[j], &points[(j + 1) % m1]);
    }
    let s = n_control as f64 / acc;
    u.iter_mut().for_each(|x| *x *= s);
    u
}

/// Eq. 4 (averaging, d = 1): domain knots for interpolation, `params.len() == n_control`.
pub fn knots_interpolation(
    params: &[f64],
    n_control: usize,
) -> Result<PeriodicKnotVector, BsplineError> {
    if params.len() != n_control {
        return Err(BsplineError::InvalidArgument(format!(
            "Eq. 4 needs as many parameters as control points, got {} and {}",
            params.len(),
            n_control
        )));
    }
    let n1 = n_control;
    let psi = |i: usize| {
        if i < n1 {
            params[i]
        } else {
            params[i - n1] + n1 as f64
        }
    };
    let mut d = Vec::with_capacity(n1 + 1);
    d.push(0.0);
    for j in 1..n1 {
        d.push((psi(j - 1) + psi(j) + psi(j + 1)) / 3.0);
    }
    d.push(n1 as f64);
    PeriodicKnotVector::try_new(&d)
}

/// Eq. 5: domain knots for approximation, `params.len() > n_control`; every span holds at
/// least one parameter (for the initial parameters).
pub fn knots_approximation(
    params: &[f64],
    n_control: usize,
) -> Result<PeriodicKnotVector, BsplineError> {
    let m1 = params.len();
    if m1 <= n_control {
        return Err(BsplineError::InvalidArgument(format!(
            "Eq. 5 needs more parameters than control points, got {m1} and {n_control}"
        )));
    }
    let n1 = n_control;
    let delta = m1 as f64 / n1 as f64;
    let u = |k: usize| if k < m1 { params[k] } else { n1 as f64 };
    let mut d = Vec::with_capacity(n1 + 1);
    d.push(0.0);
    for j in 1..n1 {
        let x = j as f64 * delta;
        let k = (x.floor() as usize).min(m1 - 1);
        let t = x - k as f64;
        d.push((1.0 - t) * u(k) + t * u(k + 1));
    }
    d.push(n1 as f64);
    PeriodicKnotVector::try_new(&d)
}

/// Weight of the second difference of a triple of control points held straight, against a
/// data point's 1: as much as one more point wherever the contour has none of its own.
/// Measured with weights 0.1, 0.3, 1, 3 and 10 (every empty span held straight, at
/// `--chordal 0.4`): crossing faces on the abdomen 80, 67, 66, 73, 97 (97 without), the
/// skull 0, 2, 2, 2, 12 (0 without), the GE head 1 839, 1 903, 1 081, 1 910, 1 115 (1 083
/// without). At 0.1, 0.3 and 3 the GE head's surface 98 takes a fan that sweeps through its
/// neighbours 131 and 140, which stage 6, judging one region at a time, cannot see.
pub(crate) const STRAIGHT_WEIGHT: f64 = 1.0;

/// Least-squares curve on `knots` through `pts` at `params` plus fixed `extras`; the
/// control points `k, k+1, k+2` (mod n+1) for each `k` in `straight` are also held straight
/// (their second difference towards 0, weighted [`STRAIGHT_WEIGHT`]): over spans without
/// data of the contour's own, a straight control polygon moves the curve at an even pace
/// instead of ringing (see [`super::common_knots`]).
pub(crate) fn solve_lsq<const D: usize>(
    pts: &[[f64; D]],
    params: &[f64],
    weights: Option<&[f64]>,
    extras: &[([f64; D], f64)],
    straight: &[usize],
    knots: &PeriodicKnotVector,
) -> Result<ClosedCurve<D>, BsplineError> {
    let n1 = knots.n_control();
    let total = pts.len() + extras.len();
    if total < n1 {
        return Err(BsplineError::Singular(format!(
            "{total} data points for {n1} control points"
        )));
    }
    let ext = knots.extended();
    let mut a = CyclicBandedMatrix::zeros(n1);
    let mut rhs = vec![[0.0; D]; n1];
    let data = pts
        .iter()
        .zip(params.iter())
        .enumerate()
        .map(|(j, (p, u))| (p, u, weights.map_or(1.0, |w| w[j])))
        .chain(extras.iter().map(|(p, u)| (p, u, 1.0)));
    for (p, &u, w) in data {
        let t = knots.wrap(u);
        let s = knots.span(t);
        let b = basis::values(ext, s + 3, t);
        let sw = w.sqrt();
        a.add_span_outer(s, &b.map(|x| x * sw));
        for (k, bk) in b.iter().enumerate() {
            let r = &mut rhs[(s + k) % n1];
            for x in 0..D {
                r[x] += w * bk * p[x];
            }
        }
    }
    // Second differences of the control points, towards zero: the right-hand side takes
    // nothing.
    let c = STRAIGHT_WEIGHT.sqrt();
    for &k in straight {
        a.add_span_outer(k % n1, &[c, -2.0 * c, c, 0.0]);
    }
    a.solve(&mut rhs)?;
    ClosedCurve::try_new(knots.clone(), rhs)
}

/// Least squares + Rogers–Fog correction on fixed knots; `met` by true distance. The
/// returned fit's `params`/`errors` are residual-level (upper bounds); [`finalize`] makes them
/// true distances.
pub(crate) fn fit_on_knots<const D: usize>(
    pts: &[[f64; D]],
    params0: &[f64],
    extras: &[([f64; D], f64)],
    straight: &[usize],
    knots: &PeriodicKnotVector,
    opts: &FitOptions,
) -> Result<ContourFit<D>, BsplineError> {
    let tol = opts.tolerance;
    let mut u = params0.to_vec();
    let mut weights: Vec<f64> = Vec::new();
    let mut best: Option<(f64, ClosedCurve<D>, Vec<f64>, Vec<f64>)> = None;
    let mut prev_worst = f64::INFINITY;
    for round in 0..=opts.max_corrections {
        let w = (!weights.is_empty()).then_some(weights.as_slice());
        let curve = match solve_lsq(pts, &u, w, extras, straight, knots) {
            Ok(c) => c,
            // Corrected parameters can empty a span; keep the best earlier round.
            Err(e) if best.is_none() => return Err(e),
            Err(_) => break,
        };
        let mut res = Vec::with_capacity(pts.len());
        let mut next = u.clone();
        let mut worst = 0.0f64;
        for (j, p) in pts.iter().enumerate() {
            let (c, d1) = curve.eval_d1(u[j]);
            let r = sub(p, &c);
            let e = norm(&r);
            worst = worst.max(e);
            res.push(e);
            if j > 0 {
                let g = dot(&d1, &d1);
                if g > 0.0 {
                    // Rogers–Fog: one Gauss–Newton step of the foot point, at most one span.
                    let du = (dot(&r, &d1) / g).clamp(-1.0, 1.0);
                    next[j] = knots.wrap(u[j] + du);
                }
            }
        }
        if best.as_ref().is_none_or(|b| worst < b.0) {
            best = Some((worst, curve, u.clone(), res.clone()));
        }
        if worst <= tol || round == opts.max_corrections {
            break;
        }
        // Hopeless rounds: even continuing the last round's rate of improvement geometrically
        // over the remaining rounds would leave the residual above 1.5 × tolerance (it bounds
        // the true distance from above, hence the margin). Saves most of the cost of the
        // failing trials of Algorithms 1 and 2; convergence is linear and slowing, so the
        // extrapolation is optimistic and rarely abandons a fit that would have succeeded.
        if round >= 1 {
            let rate = (worst / prev_worst).min(1.0);
            let left = (opts.max_corrections - round) as i32;
            if worst * rate.powi(left) > 1.5 * tol {
                break;
            }
        }
        prev_worst = worst;
        if opts.minimax_weights {
            let lim = 0.9 * tol;
            if weights.is_empty() {
                weights = vec![1.0; pts.len()];
            }
            for (w, e) in weights.iter_mut().zip(&res) {
                if *e > lim {
                    *w *= (e / lim).powi(2);
                }
            }
        }
        u = next;
    }
    let (_, curve, u, res) = best.ok_or_else(|| BsplineError::Singular("no fit".into()))?;
    // Success by true distance: only points whose residual exceeds the tolerance need it;
    // stop at the first one that is truly outside.
    let mut errors = res;
    let mut params = u;
    let mut met = true;
    let mut boxes = Vec::new();
    for (j, p) in pts.iter().enumerate() {
        if errors[j] > tol {
            let (mut d, mut t) = curve.project_from(p, params[j]);
            if d > tol {
                if boxes.is_empty() {
                    boxes = curve.span_boxes();
                }
                (d, t) = curve.refine_boxes(p, (d, t), &boxes);
            }
            errors[j] = d;
            params[j] = t;
            if d > tol {
                met = false;
                break;
            }
        }
    }
    // The extras (points resampled on D(t), gap fillers on the polygon) sample the contour
    // where it has no points of its own; a curve that meets every original point but swings
    // away between them (seen: a 30-point contour on 32 averaged common knots reaching twice
    // its radius between points) must fail too, or the surface folds there.
    if met {
        for (x, t) in extras {
            if norm(&sub(x, &curve.eval(*t))) <= tol {
                continue;
            }
            let (d, t) = curve.project_from(x, *t);
            if d > tol {
                if boxes.is_empty() {
                    boxes = curve.span_boxes();
                }
                if curve.refine_boxes(x, (d, t), &boxes).0 > tol {
                    met = false;
                    break;
                }
            }
        }
    }
    let max_error = errors.iter().copied().fold(0.0, f64::max);
    Ok(ContourFit {
        curve,
        points: pts.to_vec(),
        params,
        errors,
        max_error,
        met,
    })
}

/// Per point: the closest point found by Newton from the fitted parameter (a local
/// projection, an upper bound of the true distance); then the global search
/// ([`ClosedCurve::distance_to_hint`]) in decreasing order of that bound until the bound falls
/// below the largest true distance found, so `max_error` is the exact maximum of the true
/// distances while most points pay only for the local projection. Recomputes `met`.
pub(crate) fn finalize<const D: usize>(mut fit: ContourFit<D>, tol: f64) -> ContourFit<D> {
    let m1 = fit.points.len();
    for j in 0..m1 {
        let (d, t) = fit.curve.project_from(&fit.points[j], fit.params[j]);
        fit.errors[j] = d;
        fit.params[j] = t;
    }
    let mut order: Vec<usize> = (0..m1).collect();
    order.sort_by(|&a, &b| fit.errors[b].total_cmp(&fit.errors[a]).then(a.cmp(&b)));
    let boxes = fit.curve.span_boxes();
    let mut max_error = 0.0f64;
    for j in order {
        if fit.errors[j] <= max_error {
            break;
        }
        let (d, t) = fit
            .curve
            .refine_boxes(&fit.points[j], (fit.errors[j], fit.params[j]), &boxes);
        fit.errors[j] = d;
        fit.params[j] = t;
        max_error = max_error.max(d);
    }
    fit.max_error = max_error;
    fit.met &= max_error <= tol; // a failing extra point (see fit_on_knots) still fails
    fit
}

/// The closed interpolating curve of cleaned points on Eq. 4 knots (D(t) of the paper).
pub(crate) fn interpolate<const D: usize>(
    pts: &[[f64; D]],
) -> Result<(ClosedCurve<D>, Vec<f64>), BsplineError> {
    let n1 = pts.len();
    let u = chord_params(pts, n1);
    let knots = knots_interpolation(&u, n1)?;
    let c = solve_lsq(pts, &u, None, &[], &[], &knots)?;
    Ok((c, u))
}

#[derive(PartialEq)]
struct Gap {
    spacing: f64,
    index: usize,
}
impl Eq for Gap {}
impl PartialOrd for Gap {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Gap {
    fn cmp(&self, other: &Self) -> Ordering {
        // Largest spacing first; ties to the lowest index, for determinism.
        self.spacing
            .total_cmp(&other.spacing)
            .then(other.index.cmp(&self.index))
    }
}

/// The n > m case: the cleaned points with `n_control − m − 1` points of D(t) inserted so the
/// spacing along D is as even as possible (greedy: each new point halves... splits the gap
/// whose current spacing is largest). Returns the combined, ordered list and which entries are
/// original; P_0 stays first.
pub(crate) fn resample<const D: usize>(
    pts: &[[f64; D]],
    interp: &(ClosedCurve<D>, Vec<f64>),
    n_control: usize,
) -> (Vec<[f64; D]>, Vec<bool>) {
    let (d, u) = interp;
    let m1 = pts.len();
    let extra = n_control.saturating_sub(m1);
    let end = |j: usize| if j + 1 < m1 { u[j + 1] } else { m1 as f64 };
    const SUB: usize = 8;
    let lengths: Vec<f64> = (0..m1)
        .map(|j| {
            let (a, b) = (u[j], end(j));
            let mut l = 0.0;
            let mut prev = d.eval(a);
            for q in 1..=SUB {
                let c = d.eval(a + (b - a) * q as f64 / SUB as f64);
                l += dist(&prev, &c);
                prev = c;
            }
            l
        })
        .collect();
    let mut counts = vec![0usize; m1];
    let mut heap: BinaryHeap<Gap> = (0..m1)
        .map(|j| Gap {
            spacing: lengths[j],
            index: j,
        })
        .collect();
    for _ in 0..extra {
        if let Some(g) = heap.pop() {
            counts[g.index] += 1;
            heap.push(Gap {
                spacing: lengths[g.index] / (counts[g.index] + 1) as f64,
                index: g.index,
            });
        }
    }
    let mut out = Vec::with_capacity(n_control);
    let mut orig = Vec::with_capacity(n_control);
    for j in 0..m1 {
        out.push(pts[j]);
        orig.push(true);
        let (a, b) = (u[j], end(j));
        let c = counts[j];
        for q in 1..=c {
            out.push(d.eval(a + (b - a) * q as f64 / (c + 1) as f64));
            orig.push(false);
        }
    }
    (out, orig)
}

/// Splits a combined list into (originals with params, extras with params).
pub(crate) fn split_combined<const D: usize>(
    combined: &[[f64; D]],
    orig: &[bool],
    params: &[f64],
) -> (Vec<f64>, Vec<([f64; D], f64)>) {
    let mut po = Vec::new();
    let mut ex = Vec::new();
    for ((p, &o), &u) in combined.iter().zip(orig).zip(params) {
        if o {
            po.push(u);
        } else {
            ex.push((*p, u));
        }
    }
    (po, ex)
}

/// Fit with exactly `n_control` control points on the contour's own knot vector (Eq. 4, Eq. 5
/// or resampling as n+1 =, <, > m+1). Not finalized.
fn fit_n<const D: usize>(
    pts: &[[f64; D]],
    n_control: usize,
    interp: &mut Option<(ClosedCurve<D>, Vec<f64>)>,
    opts: &FitOptions,
) -> Result<ContourFit<D>, BsplineError> {
    let m1 = pts.len();
    if n_control < 4 {
        return Err(BsplineError::InvalidArgument(format!(
            "got {n_control} control points, a closed cubic needs at least 4"
        )));
    }
    // Resampling allocates n_control points: refuse absurd requests instead of exhausting
    // memory (more than 64 control points per contour point adds nothing).
    let cap = 64 * m1.max(1024);
    if n_control > cap {
        return Err(BsplineError::InvalidArgument(format!(
            "got {n_control} control points for {m1} contour points, at most {cap} allowed"
        )));
    }
    match n_control.cmp(&m1) {
        Ordering::Equal => {
            let u = chord_params(pts, n_control);
            let knots = knots_interpolation(&u, n_control)?;
            fit_on_knots(pts, &u, &[], &[], &knots, opts)
        }
        Ordering::Less => {
            let u = chord_params(pts, n_control);
            let knots = knots_approximation(&u, n_control)?;
            fit_on_knots(pts, &u, &[], &[], &knots, opts)
        }
        Ordering::Greater => {
            if interp.is_none() {
                *interp = Some(interpolate(pts)?);
            }
            let (combined, orig) = match interp {
                Some(i) => resample(pts, i, n_control),
                None => return Err(BsplineError::Singular("no interpolant".into())),
            };
            let u = chord_params(&combined, n_control);
            let knots = knots_interpolation(&u, n_control)?;
            let (po, ex) = split_combined(&combined, &orig, &u);
            fit_on_knots(pts, &po, &ex, &[], &knots, opts)
        }
    }
}

/// Fits `points` with exactly `n_control` control points (see the module doc); `met` says
/// whether the tolerance holds. Errors on degenerate input or a singular system.
pub fn fit_contour<const D: usize>(
    points: &[[f64; D]],
    n_control: usize,
    opts: &FitOptions,
) -> Result<ContourFit<D>, BsplineError> {
    opts.validate()?;
    let pts = prepare_contour(points)?;
    let fit = fit_n(&pts, n_control, &mut None, opts)?;
    Ok(finalize(fit, opts.tolerance))
}

/// Algorithm 1: the fewest control points (by binary search over 4..=m+1) whose fit meets the
/// tolerance. The search assumes feasibility is monotone in n, as the paper does; it is not
/// always, so the result is small, not necessarily minimal. m+1 (interpolation) always meets
/// it unless its system is singular, which is then the error returned.
pub fn fit_fewest<const D: usize>(
    points: &[[f64; D]],
    opts: &FitOptions,
) -> Result<ContourFit<D>, BsplineError> {
    opts.validate()?;
    let pts = prepare_contour(points)?;
    let fit = fewest_prepared(&pts, opts)?;
    Ok(finalize(fit, opts.tolerance))
}

/// Algorithm 1 on a prepared contour; not finalized.
pub(crate) fn fewest_prepared<const D: usize>(
    pts: &[[f64; D]],
    opts: &FitOptions,
) -> Result<ContourFit<D>, BsplineError> {
    let mut low = 3usize;
    let mut upp = pts.len();
    let mut best: Option<ContourFit<D>> = None;
    let mut interp = None;
    while upp - low > 1 {
        let now = (low + upp) / 2;
        match fit_n(pts, now, &mut interp, opts) {
            Ok(f) if f.met => {
                upp = now;
                best = Some(f);
            }
            _ => low = now,
        }
    }
    match best {
        Some(b) => Ok(b),
        None => fit_n(pts, upp, &mut interp, opts),
    }
}

/// Point on the closed polygon `pts` at chord parameter `t` (params `u`, period `period`).
pub(crate) fn polygon_at<const D: usize>(
    pts: &[[f64; D]],
    u: &[f64],
    period: f64,
    t: f64,
) -> [f64; D] {
    let m1 = pts.len();
    let j = u.partition_point(|&x| x <= t).saturating_sub(1).min(m1 - 1);
    let a = u[j];
    let b = if j + 1 < m1 { u[j + 1] } else { period };
    let s = if b > a {
        ((t - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    add(&scale(&pts[j], 1.0 - s), &scale(&pts[(j + 1) % m1], s))
}
