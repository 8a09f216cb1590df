//! Skinning (paper §2.6, METHOD §8): r+1 closed curves on one knot vector → one surface.
//!
//! In: curves C_0..C_r (r ≥ 1) on the same [`PeriodicKnotVector`](super::PeriodicKnotVector) (n+1 control points each);
//! C_0 and/or C_r may be a point (all control points equal: a cap). Out: a [`SkinnedSurface`]
//! with (n+1)×(r+3) control points that reproduces C_k exactly at v = v̄_k.
//!
//! - v̄: centripetal, averaged over the control-point columns i (columns where all curves
//!   share the control point carry no information and are skipped):
//!   v̄_k = v̄_{k−1} + (r / #columns) Σ_i √|B_{i,k} − B_{i,k−1}| / Σ_j √|B_{i,j} − B_{i,j−1}|.
//!   Two consecutive identical curves give v̄_k = v̄_{k−1}: an error.
//! - Heights kept monotone (beyond the paper). When the curves lie in parallel planes (slices,
//!   intermediate planes, caps), the surface's height along their normal is one cubic spline in
//!   v through the planes' heights. Centripetal steps follow how far the control points move,
//!   not how far apart the planes are: an intermediate contour 0.08 mm below a contour (a
//!   plane moved to t = 0.92) whose zone cuts 2 mm off it gets a step as long as a whole
//!   slice's, and the height spline dips below the intermediate plane, folding the surface
//!   through its neighbour's. So if the heights of the control net go back anywhere, v̄ is
//!   moved towards the planes' own spacing, v̄^P_k = r (h_k − h_0)/(h_r − h_0), in tenths,
//!   v̄ = (1 − α) v̄^C + α v̄^P, and the first α whose control heights never go back is kept
//!   (the spline is then monotone: variation diminishing). At α = 1 the height is linear in v
//!   wherever the end tangents are the parabola or the chord (interpolation reproduces it).
//! - V = {0,0,0,0, v_1..v_{r−1}, r,r,r,r}, v_{j+1} = (v̄_j + v̄_{j+1} + v̄_{j+2}) / 3.
//! - Column i: V_{i,0} = B_{i,0}, V_{i,1} − V_{i,0} = (v_1/3) T_{i,0}, interior rows
//!   Σ_j V_{i,j} M_j(v̄_k) = B_{i,k} (k = 1..r−1), V_{i,r+1} − V_{i,r+2} = −((r − v_{r−1})/3)
//!   T_{i,r}, V_{i,r+2} = B_{i,r}. One (r+3)² matrix for every column: LU once.
//! - End tangents T: derivative of the parabola through the first (last) three points
//!   (B_{i,0}, B_{i,1}, B_{i,2} at v̄_0..v̄_2: Bessel's end condition); the chord for r = 1.
//! - Caps. At a cap every column starts at the cap point Q, so S(·, 0) ≡ Q and the surface has
//!   a tangent plane at Q only if all S_v(u, 0) = Σ_i N_i(u) T_{i,0} lie in one plane. The
//!   per-column parabola tangents do not (a cone point / crease). We project each T_{i,0} onto
//!   the plane through Q orthogonal to the neighbouring curve's normal (Newell normal of C_1's
//!   control polygon: for a contour in a slice plane it is the slice normal, and the cap sits
//!   on the slice axis), which gives a smooth dome with its tangent plane parallel to the
//!   slices. Within that plane every column's tangent is its projected chord
//!   (B_{i,1} − Q)/v̄_1, all scaled by one least-squares factor fitted to the projected
//!   parabola tangents: one factor keeps the rows near the cap shrunken copies of the
//!   neighbour, where per-column tangents crossed (see `cap_tangents`). If the neighbour has
//!   no normal (degenerate polygon), the tangents are left unprojected.

use nalgebra::{DMatrix, Dyn, LU};

use super::basis;
use super::closed_curve::ClosedCurve;
use super::knot_vector::ClampedKnotVector;
use super::surface::SkinnedSurface;
use super::vecops::{add, dist, dot, norm, scale, sub};
use super::BsplineError;

type P3 = [f64; 3];

/// How a surface leaves its first or arrives at its last curve (the end tangents).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkinEnd {
    /// Bessel's parabola through the first (last) three curves.
    Free,
    /// A cap: a point, or a ridge loop where an annulus closes. The surface arrives parallel
    /// to the slices (see the module doc), so the outer and hole walls that share a ridge meet
    /// smoothly, as on the top of a torus, instead of in a crease.
    Cap,
    /// An intermediate contour where surfaces branch: the chord to the next curve. Sibling
    /// surfaces meet along a seam of the contour; with Bessel's tangents both can arrive
    /// almost tangent to each other, a knife edge that folds through itself (the standing
    /// torus), where the chord meets the seam at the angle the contours make.
    Seam,
}

/// Skins the curves; see the module doc. An end curve that is a point is a cap, other ends
/// are free.
pub fn skin(curves: &[ClosedCurve<3>]) -> Result<SkinnedSurface, BsplineError> {
    let end = |c: Option<&ClosedCurve<3>>| {
        if c.is_some_and(|c| c.is_point()) {
            SkinEnd::Cap
        } else {
            SkinEnd::Free
        }
    };
    skin_ends(curves, [end(curves.first()), end(curves.last())])
}

/// Skins the curves with the given kinds of start and end (see [`SkinEnd`]).
pub fn skin_ends(
    curves: &[ClosedCurve<3>],
    ends: [SkinEnd; 2],
) -> Result<SkinnedSurface, BsplineError> {
    if curves.len() < 2 {
        return Err(BsplineError::InvalidArgument(format!(
            "skinning needs at least 2 curves, got {}",
            curves.len()
        )));
    }
    let r = curves.len() - 1;
    let uk = curves[0].knots().clone();
    let n1 = uk.n_control();
    for (k, c) in curves.iter().enumerate().skip(1) {
        if c.knots().n_control() != n1 {
            return Err(BsplineError::InvalidArgument(format!(
                "curve {k} has {} control points, curve 0 has {n1}",
                c.knots().n_control()
            )));
        }
        let tol = 1e-9 * n1 as f64;
        if let Some(j) = (0..=n1).find(|&j| (c.knots().domain()[j] - uk.domain()[j]).abs() > tol) {
            return Err(BsplineError::InvalidArgument(format!(
                "curve {k} domain knot ξ_{j} = {} differs from curve 0's {}",
                c.knots().domain()[j],
                uk.domain()[j]
            )));
        }
    }
    for (k, c) in curves.iter().enumerate() {
        if c.is_point() && k != 0 && k != r {
            return Err(BsplineError::Degenerate(format!(
                "curve {k} of {} is a point; caps are only allowed at either end",
                r + 1
            )));
        }
    }
    let b = |i: usize, k: usize| curves[k].control()[i];

    // v̄ (centripetal, averaged over columns).
    let mut inc = vec![0.0f64; r + 1];
    let mut used = 0usize;
    for i in 0..n1 {
        let lens: Vec<f64> = (1..=r)
            .map(|k| dist(&b(i, k), &b(i, k - 1)).sqrt())
            .collect();
        let total: f64 = lens.iter().sum();
        if total > 0.0 {
            used += 1;
            for k in 1..=r {
                inc[k] += lens[k - 1] / total;
            }
        }
    }
    if used == 0 {
        return Err(BsplineError::Degenerate(format!(
            "all {} curves coincide",
            r + 1
        )));
    }
    let mut v_bar = vec![0.0f64; r + 1];
    for k in 1..=r {
        let d = inc[k] * r as f64 / used as f64;
        if !(d > 1e-12 * r as f64) {
            return Err(BsplineError::Degenerate(format!(
                "curves {} and {k} coincide (v̄ step {d:.3e})",
                k - 1
            )));
        }
        v_bar[k] = v_bar[k - 1] + d;
    }
    v_bar[r] = r as f64;
    let v_bar = monotone_v_bar(curves, ends, v_bar)?;
    let (vk, control) = control_net(curves, ends, &v_bar, n1)?;
    SkinnedSurface::try_new(uk, vk, control, v_bar)
}

/// `centripetal`, or, where the heights of its control net go back, the first blend towards
/// the planes' spacing whose heights do not (module doc). Only the first column of each
/// trial net is solved for: every column has the same heights.
fn monotone_v_bar(
    curves: &[ClosedCurve<3>],
    ends: [SkinEnd; 2],
    centripetal: Vec<f64>,
) -> Result<Vec<f64>, BsplineError> {
    let Some((normal, planes)) = plane_spacing(curves) else {
        return Ok(centripetal);
    };
    let rises = |v_bar: &[f64]| -> Result<bool, BsplineError> {
        let (_, column) = control_net(curves, ends, v_bar, 1)?;
        Ok(heights_monotone(&column, &normal))
    };
    if rises(&centripetal)? {
        return Ok(centripetal);
    }
    let r = centripetal.len() - 1;
    for alpha in TOWARDS_PLANES {
        let mut blend: Vec<f64> = centripetal
            .iter()
            .zip(&planes)
            .map(|(c, p)| (1.0 - alpha) * c + alpha * p)
            .collect();
        blend[r] = r as f64;
        if alpha == 1.0 || rises(&blend)? {
            return Ok(blend);
        }
    }
    Ok(planes)
}

/// The blends of v̄ tried, from centripetal towards the planes' spacing (module doc).
const TOWARDS_PLANES: [f64; 10] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];

/// The unit normal of parallel planes holding every curve's control points (to 1e-9 of the
/// heights' scale), and v̄ in proportion to the planes' heights along it; `None` if the curves
/// are not planar in parallel planes, or two share a plane.
fn plane_spacing(curves: &[ClosedCurve<3>]) -> Option<(P3, Vec<f64>)> {
    let normal = curves.iter().find_map(|c| newell_normal(c.control()))?;
    let mut heights = Vec::with_capacity(curves.len());
    for c in curves {
        let (lo, hi) =
            c.control()
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    let h = dot(p, &normal);
                    (lo.min(h), hi.max(h))
                });
        if !(hi - lo <= 1e-9 * (1.0 + hi.abs().max(lo.abs()))) {
            return None;
        }
        heights.push(0.5 * (lo + hi));
    }
    let r = curves.len() - 1;
    let total = heights[r] - heights[0];
    let mut v_bar = vec![0.0; r + 1];
    for k in 1..=r {
        let step = (heights[k] - heights[k - 1]) / total;
        // Not one way (or a shared plane): no spacing to follow.
        if !(step > 1e-9) {
            return None;
        }
        v_bar[k] = v_bar[k - 1] + step * r as f64;
    }
    v_bar[r] = r as f64;
    Some((normal, v_bar))
}

/// Whether the heights along `normal` of a column of the control net never go back in v
/// (every column has the same heights: each curve lies in one plane).
fn heights_monotone(column: &[P3], normal: &P3) -> bool {
    let h: Vec<f64> = column.iter().map(|p| dot(p, normal)).collect();
    let (first, last) = (h[0], h[h.len() - 1]);
    let sign = if last >= first { 1.0 } else { -1.0 };
    let slack = 1e-9 * (1.0 + (last - first).abs());
    h.windows(2).all(|w| sign * (w[1] - w[0]) >= -slack)
}

/// Newell's normal of a closed polygon, unit; `None` if it vanishes (a point, a segment).
fn newell_normal(points: &[P3]) -> Option<P3> {
    let n = points.len();
    let c = scale(
        &points.iter().fold([0.0; 3], |acc, p| add(&acc, p)),
        1.0 / n as f64,
    );
    let mut normal = [0.0; 3];
    for i in 0..n {
        let (a, b) = (sub(&points[i], &c), sub(&points[(i + 1) % n], &c));
        normal = add(
            &normal,
            &[
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ],
        );
    }
    let len = norm(&normal);
    (len > 0.0).then(|| scale(&normal, 1.0 / len))
}

/// The v knots and the control net through the curves at the given v̄ (end tangents, the
/// shared system), for the first `n1` columns, column by column.
fn control_net(
    curves: &[ClosedCurve<3>],
    ends: [SkinEnd; 2],
    v_bar: &[f64],
    n1: usize,
) -> Result<(ClampedKnotVector, Vec<P3>), BsplineError> {
    let r = curves.len() - 1;
    let b = |i: usize, k: usize| curves[k].control()[i];
    let rf = r as f64;
    let interior: Vec<f64> = (0..r.saturating_sub(1))
        .map(|j| (v_bar[j] + v_bar[j + 1] + v_bar[j + 2]) / 3.0)
        .collect();
    let vk = ClampedKnotVector::try_from_interior(0.0, rf, &interior)?;
    let knots = vk.knots();
    let v1 = knots[4];
    let vr1 = knots[knots.len() - 5];

    // End tangents per column.
    let tangent_start = |i: usize| -> P3 {
        if r == 1 || ends[0] == SkinEnd::Seam {
            return scale(&sub(&b(i, 1), &b(i, 0)), 1.0 / v_bar[1]);
        }
        let (h1, h2) = (v_bar[1] - v_bar[0], v_bar[2] - v_bar[1]);
        let d1 = scale(&sub(&b(i, 1), &b(i, 0)), 1.0 / h1);
        let d2 = scale(&sub(&b(i, 2), &b(i, 1)), 1.0 / h2);
        scale(
            &sub(&scale(&d1, 2.0 * h1 + h2), &scale(&d2, h1)),
            1.0 / (h1 + h2),
        )
    };
    let tangent_end = |i: usize| -> P3 {
        if r == 1 {
            return scale(&sub(&b(i, 1), &b(i, 0)), 1.0 / v_bar[1]);
        }
        if ends[1] == SkinEnd::Seam {
            return scale(
                &sub(&b(i, r), &b(i, r - 1)),
                1.0 / (v_bar[r] - v_bar[r - 1]),
            );
        }
        let (h1, h2) = (v_bar[r - 1] - v_bar[r - 2], v_bar[r] - v_bar[r - 1]);
        let d1 = scale(&sub(&b(i, r - 1), &b(i, r - 2)), 1.0 / h1);
        let d2 = scale(&sub(&b(i, r), &b(i, r - 1)), 1.0 / h2);
        scale(
            &sub(&scale(&d2, 2.0 * h2 + h1), &scale(&d1, h2)),
            1.0 / (h1 + h2),
        )
    };
    let mut t0: Vec<P3> = (0..n1).map(tangent_start).collect();
    let mut tr: Vec<P3> = (0..n1).map(tangent_end).collect();
    if ends[0] == SkinEnd::Cap {
        cap_tangents(
            &mut t0,
            curves[0].control(),
            curves[1].control(),
            v_bar[1] - v_bar[0],
            1.0,
        );
    }
    if ends[1] == SkinEnd::Cap {
        // The end tangent follows increasing v, i.e. points from the neighbour to the cap.
        cap_tangents(
            &mut tr,
            curves[r].control(),
            curves[r - 1].control(),
            v_bar[r] - v_bar[r - 1],
            -1.0,
        );
    }

    // Shared system.
    let nv = r + 3;
    let mut a = DMatrix::<f64>::zeros(nv, nv);
    a[(0, 0)] = 1.0;
    a[(1, 0)] = -1.0;
    a[(1, 1)] = 1.0;
    for k in 1..r {
        let span = vk.span(v_bar[k]);
        let m = basis::values(knots, span, v_bar[k]);
        for (c, w) in m.iter().enumerate() {
            a[(k + 1, span - 3 + c)] = *w;
        }
    }
    a[(r + 1, r + 1)] = -1.0;
    a[(r + 1, r + 2)] = 1.0;
    a[(r + 2, r + 2)] = 1.0;
    let mut rhs = DMatrix::<f64>::zeros(nv, 3 * n1);
    for i in 0..n1 {
        for x in 0..3 {
            let col = 3 * i + x;
            rhs[(0, col)] = b(i, 0)[x];
            rhs[(1, col)] = v1 / 3.0 * t0[i][x];
            for k in 1..r {
                rhs[(k + 1, col)] = b(i, k)[x];
            }
            rhs[(r + 1, col)] = (rf - vr1) / 3.0 * tr[i][x];
            rhs[(r + 2, col)] = b(i, r)[x];
        }
    }
    let lu: LU<f64, Dyn, Dyn> = a.lu();
    let sol = lu.solve(&rhs).ok_or_else(|| {
        BsplineError::Singular(format!(
            "v interpolation system ({nv}×{nv}) for v̄ = {v_bar:?}"
        ))
    })?;
    let mut control = Vec::with_capacity(n1 * nv);
    for i in 0..n1 {
        for j in 0..nv {
            control.push([sol[(j, 3 * i)], sol[(j, 3 * i + 1)], sol[(j, 3 * i + 2)]]);
        }
    }
    Ok((vk, control))
}

/// Cap tangents in the plane orthogonal to the neighbouring curve's normal (see the module
/// doc): the projected chords from the cap to the neighbour's control points, all scaled by
/// the one factor that best matches the projected parabola tangents (least squares; 1 where
/// it is not positive). `cap` holds the cap's control points (one, or one per column of a
/// ridge loop); `h` is the v̄ step to the neighbour; `sign` is +1 at the start (tangents
/// point from the cap outwards), −1 at the end.
///
/// One factor, not each column's own tangent: near the cap the rows are the cap plus a
/// small multiple of the tangent curve Σ N_i(u) T_i, so with chords scaled alike they are
/// shrunken copies of the neighbour (a point cap) or blends of the ridge loop with it, and
/// simple where it is; the parabolas, each column bent by its own third curve, crossed
/// (Siemens abdomen surface 234, a contour capped at its innermost point: 229 crossing faces
/// within a quarter of the cap's height).
fn cap_tangents(t: &mut [P3], cap: &[P3], neighbour: &[P3], h: f64, sign: f64) {
    let Some(nn) = newell_normal(neighbour) else {
        return;
    };
    let proj = |v: &P3| sub(v, &scale(&nn, dot(v, &nn)));
    let chords: Vec<P3> = (0..t.len())
        .map(|i| scale(&proj(&sub(&neighbour[i], &cap[i % cap.len()])), sign / h))
        .collect();
    let (pc, cc) = t.iter().zip(&chords).fold((0.0, 0.0), |(pc, cc), (ti, c)| {
        (pc + dot(&proj(ti), c), cc + dot(c, c))
    });
    let factor = if cc > 0.0 && pc / cc > 0.0 && (pc / cc).is_finite() {
        pc / cc
    } else {
        1.0
    };
    for (ti, c) in t.iter_mut().zip(&chords) {
        *ti = scale(c, factor);
    }
}
