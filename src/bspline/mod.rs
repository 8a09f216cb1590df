//! The B-spline kernel (paper §2.1, §2.4–2.6; METHOD.md §5–8): closed cubic curves, fitting
//! within a tolerance, common knot vectors, skinning. Pure: no I/O, no channels, no DICOM.
//!
//! In: contours as slices of points `[f64; D]` (patient mm; D = 3 in the pipeline, 2 in many
//! tests). Out: closed cubic B-spline curves ([`ClosedCurve`]) on per-contour or common
//! ([`PeriodicKnotVector`]) knot vectors, and bicubic surfaces closed in u, open in v
//! ([`SkinnedSurface`]). Every constructor validates its input and returns a
//! [`BsplineError`] that states the numbers; no input makes the kernel panic or return NaN.
//! The kernel is single-threaded and deterministic; callers parallelise across regions/points.
//!
//! Layout, one file per concept:
//! - [`knot_vector`]: periodic (u) and clamped (v) cubic knot vectors.
//! - [`basis`]: cubic B-spline basis functions, derivatives, de Boor.
//! - [`closed_curve`]: closed cubic curves: evaluation, derivatives, true point distance.
//! - [`cyclic_solver`]: O(n) solver for the cyclic banded normal equations.
//! - [`fit`]: one contour on its own knot vector, and Algorithm 1 (fewest control points).
//! - [`common_knots`]: Algorithm 2 (all contours of a region on one knot vector).
//! - [`skinning`] / [`surface`]: interpolation across the curves, and the resulting surface.
//!
//! # Example
//!
//! ```
//! use bskin::bspline::{fit_common, fit_fewest, skin, FitOptions};
//! use std::f64::consts::TAU;
//!
//! // A circle of radius 10 mm, 200 points, 0.01 mm: 8 control points (the ripple bound
//! // R·(2π/N)⁴/768 ≤ tol predicts ≥ 7; least squares is not minimax; see the tests).
//! let circle: Vec<[f64; 2]> = (0..200)
//!     .map(|j| { let t = TAU * j as f64 / 200.0; [10.0 * t.cos(), 10.0 * t.sin()] })
//!     .collect();
//! let fit = fit_fewest(&circle, &FitOptions::new(0.01))?;
//! assert!(fit.met && fit.max_error <= 0.01);
//! assert_eq!(fit.n_control(), 8);
//!
//! // A cone-like region: three circles and a cap point, one knot vector, one surface.
//! let ring = |r: f64, z: f64| -> Vec<[f64; 3]> {
//!     (0..100).map(|j| { let t = TAU * j as f64 / 100.0; [r * t.cos(), r * t.sin(), z] }).collect()
//! };
//! let region = vec![ring(10.0, 0.0), ring(8.0, 2.0), ring(5.0, 4.0), vec![[0.0, 0.0, 5.0]]];
//! let common = fit_common(&region, &FitOptions::new(0.05))?;
//! assert!(common.met);
//! let surface = skin(&common.curves)?;
//! let v2 = surface.v_bar()[2];
//! let p = surface.eval(1.0, v2);
//! approx::assert_abs_diff_eq!(p[2], 4.0, epsilon = 1e-9); // reproduces curve 2 at v̄_2
//! let (d, _, _) = surface.closest_point(&[10.0, 0.0, 0.0]);
//! assert!(d <= 0.05);
//! # Ok::<(), bskin::bspline::BsplineError>(())
//! ```
//!
//! # Where METHOD.md / the paper are wrong or ambiguous (re-derived and tested here)
//!
//! 1. **Algorithms 1 and 2, Step 6** return "the curve(s) fitted on T_pre", the *last tried*
//!    knot vector, which can be a failed one (success at 45, failures at 42, 43, 44 → the
//!    failed 43). We keep the invariant "N_upp is feasible and its fit is stored" and return
//!    that. Both algorithms also assume feasibility is monotone in N; it is not (a 1,000-point
//!    star at 0.1 mm: 20 fits, 21 does not, 22 does, 23–26 do not, 27 does), so the result is
//!    small, not minimal.
//! 2. **Eq. 5**: the extracted text reads `k = j × d`; it is k = ⌊j·d⌋ (METHOD has it right),
//!    with u_{m+1} = n+1. **Eq. 4** with d = 1 never needs ψ_{−1} (METHOD defines it; harmless).
//! 3. **Rogers–Fog with 7 rounds** converges linearly (it alternates least squares and foot
//!    points); many fits that fail after 7 rounds pass after 30. We keep 7 (the paper's bound,
//!    [`FitOptions::max_corrections`]) and add Lawson-style minimax reweighting
//!    ([`FitOptions::minimax_weights`], beyond the paper): the success criterion is a max
//!    error while least squares minimises a sum of squares.
//! 4. **Success by true distance**: |P_j − C(u_j)| is only an upper bound; we decide by the
//!    global point-to-curve distance (checked only where the bound exceeds the tolerance).
//! 5. **Algorithm 2, n > m_i**: the paper resamples a short contour only to place its own
//!    knots; but N control points cannot be fitted to fewer than N points (NᵀN is singular),
//!    so the resampled points are also fitting data (errors are measured on the originals).
//! 6. **Gap filling** (Fig. 5) does not say where to sample. One point per span exactly at the
//!    span midpoints makes the periodic cubic collocation matrix singular for an even count
//!    (its symbol 1 + 23z + 23z² + z³ vanishes at z = −1); we sample at 1/3 and 2/3.
//! 7. **N_max is not always feasible** in Algorithm 2: at N_max the largest contour is fitted
//!    on the *averaged* knots, not its own, and gap filling turns its interpolation into
//!    approximation. We return the N_max curves with `met = false` and per-curve errors.
//! 8. **Skinning, v̄**: the paper's formula is garbled in the text; METHOD's reading (average
//!    over columns of the normalised centripetal steps) is right, but a column whose control
//!    points coincide on all curves gives 0/0: such columns are skipped. Two identical
//!    consecutive curves give a zero step: an error.
//! 9. **End tangents**: V_{i,1} − V_{i,0} = (v_1/3)·T_{i,0} is the clamped end derivative
//!    C′(0) = 3(V_1 − V_0)/v_1 with v_1 the first interior knot (r when r = 1, where the
//!    parabola is unavailable and we use the chord).
//! 10. **Caps**: the per-column parabola tangents at a cap point are not coplanar, so the
//!     surface has a cone point there. We project them into the plane orthogonal to the
//!     neighbouring contour's normal, giving a tangent plane at the cap (a smooth dome); see
//!     [`skinning`].
//! 11. **"The surface error at each slice equals the curve-fitting error"** (METHOD §8): the
//!     surface contains each curve, so a point's distance to the surface is *at most* its
//!     distance to the curve, and can be smaller; it is not equal in general.

// Numeric kernels index several arrays in lockstep (basis values, control points, coordinates),
// where index loops read like the formulas they implement.
#![allow(clippy::needless_range_loop)]
// `!(x > eps)` is deliberate throughout: it is also true for NaN, which must be rejected.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod basis;
pub mod closed_curve;
pub mod common_knots;
pub mod cyclic_solver;
pub mod fit;
pub mod knot_vector;
pub mod samples;
pub mod skinning;
pub mod surface;

pub use closed_curve::ClosedCurve;
pub use common_knots::{fit_common, fit_common_densest, fit_common_warped, CommonFit};
pub use cyclic_solver::CyclicBandedMatrix;
pub use fit::{chord_params, clean_contour, fit_contour, fit_fewest, ContourFit, FitOptions};
pub use knot_vector::{ClampedKnotVector, PeriodicKnotVector};
pub use skinning::{skin, skin_ends, SkinEnd};
pub use surface::SkinnedSurface;

/// Errors of the B-spline kernel; each states the numbers involved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BsplineError {
    /// A knot vector failed validation (count, monotonicity, range, finiteness).
    #[error("invalid knot vector: {0}")]
    InvalidKnots(String),
    /// Input geometry that cannot define a curve or surface (too few points, zero length,
    /// collinear points, coincident curves, a cap point in the middle of a region).
    #[error("degenerate input: {0}")]
    Degenerate(String),
    /// A coordinate or parameter is NaN or infinite.
    #[error("non-finite input: {0}")]
    NonFinite(String),
    /// Arguments inconsistent with each other (control-point counts, mismatched knot vectors).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A linear system was numerically singular (e.g. a knot span holds no parameter).
    #[error("singular system: {0}")]
    Singular(String),
}

/// Euclidean helpers shared by the kernel's files.
pub(crate) mod vecops {
    #[inline]
    pub fn sub<const D: usize>(a: &[f64; D], b: &[f64; D]) -> [f64; D] {
        std::array::from_fn(|i| a[i] - b[i])
    }
    #[inline]
    pub fn add<const D: usize>(a: &[f64; D], b: &[f64; D]) -> [f64; D] {
        std::array::from_fn(|i| a[i] + b[i])
    }
    #[inline]
    pub fn scale<const D: usize>(a: &[f64; D], s: f64) -> [f64; D] {
        std::array::from_fn(|i| a[i] * s)
    }
    #[inline]
    pub fn dot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
        (0..D).map(|i| a[i] * b[i]).sum()
    }
    #[inline]
    pub fn norm<const D: usize>(a: &[f64; D]) -> f64 {
        dot(a, a).sqrt()
    }
    #[inline]
    pub fn dist<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
        norm(&sub(a, b))
    }
    #[inline]
    pub fn is_finite<const D: usize>(a: &[f64; D]) -> bool {
        a.iter().all(|x| x.is_finite())
    }
    /// Distance from `p` to the axis-aligned box `[lo, hi]` (0 inside): a lower bound for the
    /// distance to any curve/surface piece inside the convex hull of its control points.
    #[inline]
    pub fn box_dist<const D: usize>(p: &[f64; D], lo: &[f64; D], hi: &[f64; D]) -> f64 {
        let mut s = 0.0;
        for i in 0..D {
            let d = if p[i] < lo[i] {
                lo[i] - p[i]
            } else if p[i] > hi[i] {
                p[i] - hi[i]
            } else {
                0.0
            };
            s += d * d;
        }
        s.sqrt()
    }
    pub fn bbox<'a, const D: usize>(
        pts: impl Iterator<Item = &'a [f64; D]>,
    ) -> ([f64; D], [f64; D]) {
        let mut lo = [f64::INFINITY; D];
        let mut hi = [f64::NEG_INFINITY; D];
        for p in pts {
            for i in 0..D {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        (lo, hi)
    }
}
