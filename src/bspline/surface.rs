//! The skinned surface (paper §2.6, METHOD §8): bicubic, closed in u, open (clamped) in v.
//!
//! In: a periodic u knot vector with n+1 control points per row, a clamped v knot vector with
//! r+3 control points per column, the (n+1)×(r+3) control grid (row-major: index
//! i·(r+3) + j), and the curve parameters v̄_0 = 0 < … < v̄_r = r. Out: S(u, v) =
//! Σ_i Σ_j V_{i mod (n+1), j} N_{i,4}(u) M_{j,4}(v), its partial derivatives up to second
//! order, iso-curves, and the true point-to-surface distance ([`SkinnedSurface::closest_point`]).
//! Invariants: sizes agree, every coordinate finite; u wraps, v is clamped to [0, r].

use super::basis;
use super::closed_curve::ClosedCurve;
use super::knot_vector::{ClampedKnotVector, PeriodicKnotVector};
use super::vecops::{bbox, box_dist, dist, dot, is_finite, sub};
use super::BsplineError;

type P3 = [f64; 3];

/// Samples per patch side when seeding the projection.
const SEED_SAMPLES: usize = 4;

/// Bicubic B-spline surface, closed in u, open in v.
#[derive(Debug, Clone, PartialEq)]
pub struct SkinnedSurface {
    u_knots: PeriodicKnotVector,
    v_knots: ClampedKnotVector,
    control: Vec<P3>,
    v_bar: Vec<f64>,
    /// Non-empty v spans (indices into the v knots).
    v_spans: Vec<usize>,
    /// Per patch (u span s, v span index q), index s·|v_spans| + q: bounding box of its 16
    /// control points, which holds the patch (convex hull property).
    patch_boxes: Vec<(P3, P3)>,
}

impl SkinnedSurface {
    /// Validates sizes and finiteness; `v_bar` must be increasing and inside the v domain.
    pub fn try_new(
        u_knots: PeriodicKnotVector,
        v_knots: ClampedKnotVector,
        control: Vec<P3>,
        v_bar: Vec<f64>,
    ) -> Result<Self, BsplineError> {
        let (nu, nv) = (u_knots.n_control(), v_knots.n_control());
        if control.len() != nu * nv {
            return Err(BsplineError::InvalidArgument(format!(
                "got {} control points, expected {nu}×{nv} = {}",
                control.len(),
                nu * nv
            )));
        }
        if let Some(i) = control.iter().position(|p| !is_finite(p)) {
            return Err(BsplineError::NonFinite(format!(
                "surface control point ({}, {}) is {:?}",
                i / nv,
                i % nv,
                control[i]
            )));
        }
        let (a, b) = v_knots.domain();
        if v_bar.iter().any(|x| !x.is_finite() || *x < a || *x > b)
            || v_bar.windows(2).any(|w| w[1] <= w[0])
        {
            return Err(BsplineError::InvalidArgument(format!(
                "v̄ {v_bar:?} not increasing inside [{a}, {b}]"
            )));
        }
        let vk = v_knots.knots();
        let v_spans: Vec<usize> = (3..vk.len() - 4).filter(|&k| vk[k] < vk[k + 1]).collect();
        let mut patch_boxes = Vec::with_capacity(nu * v_spans.len());
        for s in 0..nu {
            for &k in &v_spans {
                let pts: Vec<P3> = (0..4)
                    .flat_map(|a| (0..4).map(move |c| (a, c)))
                    .map(|(a, c)| control[((s + a) % nu) * nv + k - 3 + c])
                    .collect();
                patch_boxes.push(bbox(pts.iter()));
            }
        }
        Ok(Self {
            u_knots,
            v_knots,
            control,
            v_bar,
            v_spans,
            patch_boxes,
        })
    }

    pub fn u_knots(&self) -> &PeriodicKnotVector {
        &self.u_knots
    }
    pub fn v_knots(&self) -> &ClampedKnotVector {
        &self.v_knots
    }
    /// Control grid, row-major: [`Self::n_u`] rows of [`Self::n_v`].
    pub fn control(&self) -> &[P3] {
        &self.control
    }
    /// V_{i,j}.
    pub fn control_point(&self, i: usize, j: usize) -> P3 {
        self.control[i * self.n_v() + j]
    }
    /// n+1 (distinct control points around u).
    pub fn n_u(&self) -> usize {
        self.u_knots.n_control()
    }
    /// r+3 (control points along v).
    pub fn n_v(&self) -> usize {
        self.v_knots.n_control()
    }
    /// v̄_k: the parameter at which the surface reproduces input curve k.
    pub fn v_bar(&self) -> &[f64] {
        &self.v_bar
    }

    /// Derivatives up to order 2: [S, S_u, S_v, S_uu, S_uv, S_vv].
    pub fn derivs2(&self, u: f64, v: f64) -> [P3; 6] {
        let u = self.u_knots.wrap(u);
        let s = self.u_knots.span(u);
        let nu_b = basis::ders(self.u_knots.extended(), s + 3, u);
        let (a, b) = self.v_knots.domain();
        let v = v.clamp(a, b);
        let k = self.v_knots.span(v);
        let nv_b = basis::ders(self.v_knots.knots(), k, v);
        let (nu, nv) = (self.n_u(), self.n_v());
        let mut out = [[0.0; 3]; 6];
        const ORD: [(usize, usize); 6] = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)];
        for ia in 0..4 {
            let row = ((s + ia) % nu) * nv + k - 3;
            for jb in 0..4 {
                let c = &self.control[row + jb];
                for (o, &(du, dv)) in out.iter_mut().zip(ORD.iter()) {
                    let w = nu_b[du][ia] * nv_b[dv][jb];
                    for x in 0..3 {
                        o[x] += w * c[x];
                    }
                }
            }
        }
        out
    }

    /// S(u, v).
    pub fn eval(&self, u: f64, v: f64) -> P3 {
        let u = self.u_knots.wrap(u);
        let s = self.u_knots.span(u);
        let nu_b = basis::values(self.u_knots.extended(), s + 3, u);
        let (a, b) = self.v_knots.domain();
        let v = v.clamp(a, b);
        let k = self.v_knots.span(v);
        let nv_b = basis::values(self.v_knots.knots(), k, v);
        let (nu, nv) = (self.n_u(), self.n_v());
        let mut out = [0.0; 3];
        for (ia, wa) in nu_b.iter().enumerate() {
            let row = ((s + ia) % nu) * nv + k - 3;
            for (jb, wb) in nv_b.iter().enumerate() {
                let c = &self.control[row + jb];
                for x in 0..3 {
                    out[x] += wa * wb * c[x];
                }
            }
        }
        out
    }

    /// (S, S_u, S_v).
    pub fn partials(&self, u: f64, v: f64) -> (P3, P3, P3) {
        let d = self.derivs2(u, v);
        (d[0], d[1], d[2])
    }

    /// The closed iso-curve S(·, v) on the u knots.
    pub fn iso_curve(&self, v: f64) -> Result<ClosedCurve<3>, BsplineError> {
        let (a, b) = self.v_knots.domain();
        let v = v.clamp(a, b);
        let k = self.v_knots.span(v);
        let m = basis::values(self.v_knots.knots(), k, v);
        let nv = self.n_v();
        let ctrl = (0..self.n_u())
            .map(|i| {
                let mut p = [0.0; 3];
                for (jb, w) in m.iter().enumerate() {
                    let c = &self.control[i * nv + k - 3 + jb];
                    for x in 0..3 {
                        p[x] += w * c[x];
                    }
                }
                p
            })
            .collect();
        ClosedCurve::try_new(self.u_knots.clone(), ctrl)
    }

    /// Local closest point from (u0, v0): Newton on ½|S − P|² (Gauss–Newton with damping
    /// where the Hessian is not positive definite, e.g. at a cap pole), u wrapping, v clamped
    /// (a step pushing v out of [0, r] continues along the boundary in u). Returns
    /// (distance, u, v); never worse than the seed.
    pub fn closest_point_from(&self, p: &P3, u0: f64, v0: f64) -> (f64, f64, f64) {
        let (va, vb) = self.v_knots.domain();
        let period = self.u_knots.period();
        let mut u = self.u_knots.wrap(u0);
        let mut v = v0.clamp(va, vb);
        let mut d = self.derivs2(u, v);
        let mut f = dist(&d[0], p);
        for _ in 0..40 {
            let r = sub(&d[0], p);
            let gu = dot(&r, &d[1]);
            let gv = dot(&r, &d[2]);
            let juu = dot(&d[1], &d[1]);
            let juv = dot(&d[1], &d[2]);
            let jvv = dot(&d[2], &d[2]);
            let (huu, huv, hvv) = (
                juu + dot(&r, &d[3]),
                juv + dot(&r, &d[4]),
                jvv + dot(&r, &d[5]),
            );
            let scale = (juu + jvv).max(1e-300);
            let solve = |a: f64, b: f64, c: f64| -> Option<(f64, f64)> {
                let det = a * c - b * b;
                if a > 0.0 && det > 1e-14 * scale * scale {
                    Some(((-gu * c + gv * b) / det, (gu * b - gv * a) / det))
                } else {
                    None
                }
            };
            let (mut du, mut dv) = solve(huu, huv, hvv)
                .or_else(|| {
                    let lam = 1e-6 * scale;
                    solve(juu + lam, juv, jvv + lam)
                })
                .unwrap_or((0.0, 0.0));
            // On the v boundary with the step pointing out: slide along u only.
            if (v <= va && dv < 0.0) || (v >= vb && dv > 0.0) {
                dv = 0.0;
                du = if huu > 1e-12 * scale {
                    -gu / huu
                } else if juu > 0.0 {
                    -gu / juu
                } else {
                    0.0
                };
            }
            let lim = 0.5 * period;
            du = du.clamp(-lim, lim);
            let mut improved = false;
            for _ in 0..12 {
                let un = self.u_knots.wrap(u + du);
                let vn = (v + dv).clamp(va, vb);
                let fnew = dist(&self.eval(un, vn), p);
                if fnew <= f {
                    improved = fnew < f || (du == 0.0 && dv == 0.0);
                    u = un;
                    v = vn;
                    f = fnew;
                    break;
                }
                du *= 0.5;
                dv *= 0.5;
            }
            if !improved || (du.abs() + dv.abs()) < 1e-13 * period {
                break;
            }
            d = self.derivs2(u, v);
        }
        (f, u, v)
    }

    /// The true distance from `p` to the surface: (distance, u, v). Patches are visited in
    /// order of the distance to their control-point bounding box (a lower bound, by the convex
    /// hull property); each is seeded on a 5×5 sample grid and refined by Newton; the search
    /// stops when the next lower bound is not below the best distance. Deterministic.
    pub fn closest_point(&self, p: &P3) -> (f64, f64, f64) {
        let nq = self.v_spans.len();
        let mut order: Vec<(f64, usize)> = self
            .patch_boxes
            .iter()
            .enumerate()
            .map(|(i, (lo, hi))| (box_dist(p, lo, hi), i))
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let ud = self.u_knots.domain();
        let vk = self.v_knots.knots();
        let mut best = (f64::INFINITY, 0.0, 0.0);
        for (lb, idx) in order {
            if lb >= best.0 * (1.0 - 1e-12) {
                break;
            }
            let (s, q) = (idx / nq, idx % nq);
            let k = self.v_spans[q];
            let (ua, ub, va, vb) = (ud[s], ud[s + 1], vk[k], vk[k + 1]);
            let mut seed = (f64::INFINITY, ua, va);
            for a in 0..=SEED_SAMPLES {
                let u = ua + (ub - ua) * a as f64 / SEED_SAMPLES as f64;
                for c in 0..=SEED_SAMPLES {
                    let v = va + (vb - va) * c as f64 / SEED_SAMPLES as f64;
                    let dd = dist(&self.eval(u, v), p);
                    if dd < seed.0 {
                        seed = (dd, u, v);
                    }
                }
            }
            if seed.0 >= best.0 && lb > 0.0 {
                // The samples of this patch are no better; Newton from them rarely is.
                continue;
            }
            let r = self.closest_point_from(p, seed.1, seed.2);
            if r.0 < best.0 {
                best = r;
            }
        }
        best
    }
}
