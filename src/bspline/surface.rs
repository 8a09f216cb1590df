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

/// Sample intervals per patch side: (SEED+1)² points per patch, precomputed.
const SEED_SAMPLES: usize = 4;
const SEED_POINTS: usize = (SEED_SAMPLES + 1) * (SEED_SAMPLES + 1);

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
    /// Per patch: S on a regular (SEED+1)² grid of its parameter rectangle (row-major in u).
    patch_samples: Vec<[P3; SEED_POINTS]>,
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
        let mut surf = Self {
            u_knots,
            v_knots,
            control,
            v_bar,
            v_spans,
            patch_boxes,
            patch_samples: Vec::new(),
        };
        let samples: Vec<[P3; SEED_POINTS]> = (0..surf.patch_boxes.len())
            .map(|idx| {
                let (ua, ub, va, vb) = surf.patch_rect(idx);
                std::array::from_fn(|q| {
                    let (a, c) = (q / (SEED_SAMPLES + 1), q % (SEED_SAMPLES + 1));
                    surf.eval(
                        ua + (ub - ua) * a as f64 / SEED_SAMPLES as f64,
                        va + (vb - va) * c as f64 / SEED_SAMPLES as f64,
                    )
                })
            })
            .collect();
        surf.patch_samples = samples;
        Ok(surf)
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
                // derivs2 rather than eval: on acceptance (the usual case) it is reused.
                let dn = self.derivs2(un, vn);
                let fnew = dist(&dn[0], p);
                if fnew <= f {
                    improved = fnew < f;
                    u = un;
                    v = vn;
                    f = fnew;
                    d = dn;
                    break;
                }
                du *= 0.5;
                dv *= 0.5;
            }
            // Parameter steps below 1e-10 move the point by ~1e-9 mm: converged.
            if !improved || (du.abs() + dv.abs()) < 1e-10 {
                break;
            }
        }
        (f, u, v)
    }

    /// The true distance from `p` to the surface: (distance, u, v). The patch whose
    /// control-point bounding box is nearest (a lower bound, by the convex hull property) is
    /// sampled on a 5×5 grid and refined by Newton; then see [`Self::closest_point_hint`].
    /// Deterministic, single-threaded; callers parallelise over points.
    pub fn closest_point(&self, p: &P3) -> (f64, f64, f64) {
        let first = self
            .patch_boxes
            .iter()
            .enumerate()
            .map(|(i, (lo, hi))| (box_dist(p, lo, hi), i))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let best = match first {
            Some((_, idx)) => {
                let seed = self.patch_seed(p, idx);
                let r = self.closest_point_from(p, seed.1, seed.2);
                if r.0 < seed.0 {
                    r
                } else {
                    seed
                }
            }
            None => (f64::INFINITY, 0.0, 0.0),
        };
        self.refine_patches(p, best)
    }

    /// As [`Self::closest_point`], seeded with a parameter guess (for a contour point: its
    /// curve parameter and the curve's v̄_k), which makes the search much cheaper: Newton from
    /// the hint gives a tight bound, then only patches whose bounding box is nearer than it
    /// are visited, in order of that lower bound; for each, the nearest of its 5×5
    /// precomputed samples seeds Newton (skipped when that seed lies within one sample cell
    /// of the best solution so far: same basin). A competing minimum is missed only if Newton
    /// from the best sample of its patch does not reach it.
    pub fn closest_point_hint(&self, p: &P3, u0: f64, v0: f64) -> (f64, f64, f64) {
        let best = self.closest_point_from(p, u0, v0);
        self.refine_patches(p, best)
    }

    /// Parameter rectangle (u_a, u_b, v_a, v_b) of patch `idx`.
    fn patch_rect(&self, idx: usize) -> (f64, f64, f64, f64) {
        let nq = self.v_spans.len();
        let (s, q) = (idx / nq, idx % nq);
        let k = self.v_spans[q];
        let ud = self.u_knots.domain();
        let vk = self.v_knots.knots();
        (ud[s], ud[s + 1], vk[k], vk[k + 1])
    }

    /// Best precomputed sample of patch `idx`: (distance, u, v).
    fn patch_seed(&self, p: &P3, idx: usize) -> (f64, f64, f64) {
        let (ua, ub, va, vb) = self.patch_rect(idx);
        let (q, d) = self.patch_samples[idx]
            .iter()
            .enumerate()
            .map(|(q, x)| (q, dist(x, p)))
            .fold((0, f64::INFINITY), |b, c| if c.1 < b.1 { c } else { b });
        let (a, c) = (q / (SEED_SAMPLES + 1), q % (SEED_SAMPLES + 1));
        (
            d,
            ua + (ub - ua) * a as f64 / SEED_SAMPLES as f64,
            va + (vb - va) * c as f64 / SEED_SAMPLES as f64,
        )
    }

    fn refine_patches(&self, p: &P3, mut best: (f64, f64, f64)) -> (f64, f64, f64) {
        let mut cand: Vec<(f64, usize)> = self
            .patch_boxes
            .iter()
            .enumerate()
            .map(|(i, (lo, hi))| (box_dist(p, lo, hi), i))
            .filter(|c| c.0 < best.0 * (1.0 - 1e-12))
            .collect();
        cand.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (lb, idx) in cand {
            if lb >= best.0 * (1.0 - 1e-12) {
                break;
            }
            // Newton from every candidate patch's best sample, even when that sample is
            // farther than the best so far: in a coarse patch (e.g. next to a cap) the nearest
            // sample can be millimetres from the patch's own closest point.
            let seed = self.patch_seed(p, idx);
            let (ua, ub, va, vb) = self.patch_rect(idx);
            let du = (seed.1 - best.1).abs();
            let du = du.min(self.u_knots.period() - du);
            if seed.0 >= best.0
                && du <= (ub - ua) / SEED_SAMPLES as f64
                && (seed.2 - best.2).abs() <= (vb - va) / SEED_SAMPLES as f64
            {
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
