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

/// Sample intervals per patch side: (SEED+1)² points per visited patch. Fine enough to
/// separate two basins in one patch (a sharp bend beside a flat cap puts two local minima of
/// the distance a third of a patch apart).
const SEED_SAMPLES: usize = 8;
/// Newton runs per candidate patch, from its lowest discrete local minima on the sample grid.
const SEEDS_PER_PATCH: usize = 3;
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
    /// Boxes of whole rows of patches (every u span of one v span), as a complete binary tree
    /// over the v spans: node 1 is the root, node i's children are 2i and 2i+1, row q is leaf
    /// `row_tree.len() / 2 + q`. The closest-point search descends it rather than measuring
    /// every patch, which made certifying a long surface quadratic in its length.
    row_tree: Vec<(P3, P3)>,
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
        // Boxes of each patch's Bézier net (tighter than its 16 B-spline control points,
        // which also cover the neighbouring patches): the closest-point search visits far
        // fewer patches. The patch lies in the convex hull of its Bézier net.
        let mu: Vec<[[f64; 4]; 4]> = (0..nu)
            .map(|s| bezier_matrix(u_knots.extended(), s + 3))
            .collect();
        let mv: Vec<[[f64; 4]; 4]> = v_spans
            .iter()
            .map(|&k| bezier_matrix(v_knots.knots(), k))
            .collect();
        let mut patch_boxes = Vec::with_capacity(nu * v_spans.len());
        for (s, mus) in mu.iter().enumerate() {
            for (q, &k) in v_spans.iter().enumerate() {
                let b = |a: usize, c: usize| control[((s + a) % nu) * nv + k - 3 + c];
                let mut net = [[0.0; 3]; 16];
                for (bu, row) in mus.iter().enumerate() {
                    for (bv, mvr) in mv[q].iter().enumerate() {
                        let mut pnt = [0.0; 3];
                        for a in 0..4 {
                            for c in 0..4 {
                                let w = row[a] * mvr[c];
                                if w != 0.0 {
                                    let x = b(a, c);
                                    for i in 0..3 {
                                        pnt[i] += w * x[i];
                                    }
                                }
                            }
                        }
                        net[bu * 4 + bv] = pnt;
                    }
                }
                let (mut lo, mut hi) = bbox(net.iter());
                // Rounding in the conversion: pad by a relative hair so the bound stays a bound.
                for i in 0..3 {
                    let pad = 1e-12 * (1.0 + lo[i].abs().max(hi[i].abs()));
                    lo[i] -= pad;
                    hi[i] += pad;
                }
                patch_boxes.push((lo, hi));
            }
        }
        let row_tree = row_tree(&patch_boxes, v_spans.len());
        Ok(Self {
            u_knots,
            v_knots,
            control,
            v_bar,
            v_spans,
            patch_boxes,
            row_tree,
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
        self.newton(p, u0, v0, None, (va, vb))
    }

    /// Newton as in [`Self::closest_point_from`]; with `u_box = Some((a, b))` u is clamped to
    /// [a, b] instead of wrapping, and v always to `v_box`: the minimum over one patch.
    fn newton(
        &self,
        p: &P3,
        u0: f64,
        v0: f64,
        u_box: Option<(f64, f64)>,
        (va, vb): (f64, f64),
    ) -> (f64, f64, f64) {
        let period = self.u_knots.period();
        let place_u = |u: f64| match u_box {
            Some((a, b)) => u.clamp(a, b),
            None => self.u_knots.wrap(u),
        };
        let mut u = place_u(u0);
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
            // Active bounds (KKT): a parameter on a bound whose gradient points out of the box
            // stays there; the other one moves by 1D Newton.
            let v_active = (v <= va && gv > 0.0) || (v >= vb && gv < 0.0);
            let u_active = u_box.is_some_and(|(a, b)| (u <= a && gu > 0.0) || (u >= b && gu < 0.0));
            let one_d = |g: f64, h: f64, j: f64| {
                if h > 1e-12 * scale {
                    -g / h
                } else if j > 0.0 {
                    -g / j
                } else {
                    0.0
                }
            };
            // Converged: the residual is orthogonal to the free directions (to 1e-10 rad).
            let pgu = if u_active { 0.0 } else { gu };
            let pgv = if v_active { 0.0 } else { gv };
            if (pgu * pgu + pgv * pgv).sqrt() <= 1e-10 * dist(&d[0], p) * scale.sqrt() {
                break;
            }
            match (u_active, v_active) {
                (true, true) => break,
                (false, true) => {
                    dv = 0.0;
                    du = one_d(gu, huu, juu);
                }
                (true, false) => {
                    du = 0.0;
                    dv = one_d(gv, hvv, jvv);
                }
                (false, false) => {}
            }
            let lim = 0.5 * period;
            du = du.clamp(-lim, lim);
            let mut improved = false;
            // First the (projected) Newton step; if clamping to the box spoils it, the
            // diagonally scaled gradient step, which stays a descent direction when projected.
            let gd = (
                if u_active { 0.0 } else { -gu / juu.max(1e-300) },
                if v_active { 0.0 } else { -gv / jvv.max(1e-300) },
            );
            'steps: for (mut su, mut sv) in [(du, dv), (gd.0.clamp(-lim, lim), gd.1)] {
                for _ in 0..12 {
                    let un = place_u(u + su);
                    let vn = (v + sv).clamp(va, vb);
                    // derivs2 rather than eval: on acceptance (the usual case) it is reused.
                    let dn = self.derivs2(un, vn);
                    let fnew = dist(&dn[0], p);
                    if fnew < f {
                        improved = true;
                        du = un - u;
                        dv = vn - v;
                        u = un;
                        v = vn;
                        f = fnew;
                        d = dn;
                        break 'steps;
                    }
                    su *= 0.5;
                    sv *= 0.5;
                }
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
    /// sampled (9×9, precomputed) and refined by Newton; then see [`Self::closest_point_hint`].
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
    /// are visited, in order of that lower bound (the box of the patch's Bézier net); for
    /// each, the lowest (up to 3) discrete local minima of the distance on its 9×9
    /// precomputed samples seed Newton runs kept inside the patch's parameter rectangle. A
    /// minimum is missed only if the sample grid does not separate its basin.
    pub fn closest_point_hint(&self, p: &P3, u0: f64, v0: f64) -> (f64, f64, f64) {
        let best = self.closest_point_from(p, u0, v0);
        self.refine_patches(p, best)
    }

    /// Patches whose box is nearer to `p` than `bound`, with that lower bound: the rows of
    /// [`Self::row_tree`] nearer than `bound`, then their patches.
    fn patches_nearer(&self, p: &P3, bound: f64) -> Vec<(f64, usize)> {
        let nq = self.v_spans.len();
        let leaves = self.row_tree.len() / 2;
        let mut out = Vec::new();
        let mut stack = vec![1usize];
        while let Some(i) = stack.pop() {
            let (lo, hi) = &self.row_tree[i];
            if box_dist(p, lo, hi) >= bound {
                continue;
            }
            if i < leaves {
                stack.extend([2 * i + 1, 2 * i]);
                continue;
            }
            let q = i - leaves;
            for idx in (q..self.patch_boxes.len()).step_by(nq) {
                let (lo, hi) = &self.patch_boxes[idx];
                let d = box_dist(p, lo, hi);
                if d < bound {
                    out.push((d, idx));
                }
            }
        }
        out
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

    /// S on the regular (SEED+1)² grid of patch `idx` (row-major in u), by tensor-product
    /// evaluation: (SEED+1) basis evaluations per direction instead of one pair per point.
    fn patch_grid(&self, idx: usize) -> [P3; SEED_POINTS] {
        const W: usize = SEED_SAMPLES + 1;
        let nq = self.v_spans.len();
        let (s, q) = (idx / nq, idx % nq);
        let k = self.v_spans[q];
        let (ua, ub, va, vb) = self.patch_rect(idx);
        let ue = self.u_knots.extended();
        let vk = self.v_knots.knots();
        let bu: [[f64; 4]; W] = std::array::from_fn(|a| {
            basis::values(ue, s + 3, ua + (ub - ua) * a as f64 / SEED_SAMPLES as f64)
        });
        let bv: [[f64; 4]; W] = std::array::from_fn(|c| {
            basis::values(vk, k, va + (vb - va) * c as f64 / SEED_SAMPLES as f64)
        });
        let (nu, nv) = (self.n_u(), self.n_v());
        // Rows first: r[a][c] = Σ_b M_b(v_c) V[(s+a) mod nu][k−3+b].
        let mut r = [[[0.0; 3]; W]; 4];
        for (a, ra) in r.iter_mut().enumerate() {
            let row = ((s + a) % nu) * nv + k - 3;
            for (c, rc) in ra.iter_mut().enumerate() {
                for (b, w) in bv[c].iter().enumerate() {
                    let x = &self.control[row + b];
                    for i in 0..3 {
                        rc[i] += w * x[i];
                    }
                }
            }
        }
        let mut out = [[0.0; 3]; SEED_POINTS];
        for (a, bua) in bu.iter().enumerate() {
            for c in 0..W {
                let o = &mut out[a * W + c];
                for (ia, w) in bua.iter().enumerate() {
                    for i in 0..3 {
                        o[i] += w * r[ia][c][i];
                    }
                }
            }
        }
        out
    }

    /// Best sample of patch `idx`: (distance, u, v).
    fn patch_seed(&self, p: &P3, idx: usize) -> (f64, f64, f64) {
        let mut out = [(f64::INFINITY, 0.0, 0.0); 1];
        self.patch_seeds(p, idx, &mut out);
        out[0]
    }

    /// The lowest discrete local minima (over the 8-neighbourhood) of the distance on patch
    /// `idx`'s sample grid, best first, into `out` (unused entries: infinite distance).
    fn patch_seeds(&self, p: &P3, idx: usize, out: &mut [(f64, f64, f64)]) {
        const W: usize = SEED_SAMPLES + 1;
        let (ua, ub, va, vb) = self.patch_rect(idx);
        let samples = self.patch_grid(idx);
        let mut d = [0.0f64; SEED_POINTS];
        for (dq, x) in d.iter_mut().zip(samples.iter()) {
            *dq = dist(x, p);
        }
        out.iter_mut().for_each(|o| *o = (f64::INFINITY, 0.0, 0.0));
        for q in 0..SEED_POINTS {
            let (a, c) = (q / W, q % W);
            let mut is_min = true;
            'nb: for da in -1i32..=1 {
                for dc in -1i32..=1 {
                    let (na, nc) = (a as i32 + da, c as i32 + dc);
                    if (da, dc) == (0, 0) || na < 0 || nc < 0 || na >= W as i32 || nc >= W as i32 {
                        continue;
                    }
                    if d[na as usize * W + nc as usize] < d[q] {
                        is_min = false;
                        break 'nb;
                    }
                }
            }
            if !is_min {
                continue;
            }
            let cand = (
                d[q],
                ua + (ub - ua) * a as f64 / SEED_SAMPLES as f64,
                va + (vb - va) * c as f64 / SEED_SAMPLES as f64,
            );
            // Insert into the sorted list of the lowest minima.
            if let Some(pos) = out.iter().position(|o| cand.0 < o.0) {
                for i in (pos + 1..out.len()).rev() {
                    out[i] = out[i - 1];
                }
                out[pos] = cand;
            }
        }
    }

    fn refine_patches(&self, p: &P3, mut best: (f64, f64, f64)) -> (f64, f64, f64) {
        let mut cand = self.patches_nearer(p, best.0 * (1.0 - 1e-12));
        cand.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (lb, idx) in cand {
            if lb >= best.0 * (1.0 - 1e-12) {
                break;
            }
            // Newton from the patch's lowest discrete minima, even when they are farther than
            // the best so far: in a coarse patch (e.g. next to a cap) the nearest sample can be
            // millimetres from the patch's own closest point. Newton is kept inside the
            // patch's rectangle: an unconstrained run can slide into another basin.
            let mut seeds = [(f64::INFINITY, 0.0, 0.0); SEEDS_PER_PATCH];
            self.patch_seeds(p, idx, &mut seeds);
            let (ua, ub, va, vb) = self.patch_rect(idx);
            for seed in seeds.iter().filter(|s| s.0.is_finite()) {
                let r = self.newton(p, seed.1, seed.2, Some((ua, ub)), (va, vb));
                if r.0 < best.0 {
                    best = r;
                }
            }
        }
        best
    }
}

/// See [`SkinnedSurface::row_tree`]: leaves are the unions of each v span's patch boxes.
fn row_tree(patch_boxes: &[(P3, P3)], nq: usize) -> Vec<(P3, P3)> {
    let empty = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let leaves = nq.max(1).next_power_of_two();
    let mut tree = vec![empty; 2 * leaves];
    for (idx, b) in patch_boxes.iter().enumerate() {
        let node = &mut tree[leaves + idx % nq];
        *node = union(node, b);
    }
    for i in (1..leaves).rev() {
        tree[i] = union(&tree[2 * i], &tree[2 * i + 1]);
    }
    tree
}

fn union(a: &(P3, P3), b: &(P3, P3)) -> (P3, P3) {
    (
        std::array::from_fn(|i| a.0[i].min(b.0[i])),
        std::array::from_fn(|i| a.1[i].max(b.1[i])),
    )
}

/// Rows: the four Bézier points of span `k` (t ∈ [u_k, u_{k+1}]) as combinations of the
/// span's four B-spline control points: b₀ = C(u_k), b₁ = b₀ + h/3·C′(u_k),
/// b₂ = b₃ − h/3·C′(u_{k+1}), b₃ = C(u_{k+1}) (h = u_{k+1} − u_k).
fn bezier_matrix(u: &[f64], k: usize) -> [[f64; 4]; 4] {
    let (a, b) = (u[k], u[k + 1]);
    let h = b - a;
    let da = basis::ders(u, k, a);
    let db = basis::ders(u, k, b);
    let mut m = [[0.0; 4]; 4];
    for i in 0..4 {
        m[0][i] = da[0][i];
        m[1][i] = da[0][i] + h / 3.0 * da[1][i];
        m[2][i] = db[0][i] - h / 3.0 * db[1][i];
        m[3][i] = db[0][i];
    }
    m
}

#[cfg(test)]
mod tests {
    use crate::bspline::{fit_common, skin, FitOptions};

    /// Every patch lies inside its Bézier-net box (the lower bound the search relies on).
    #[test]
    fn patch_boxes_contain_their_patches() {
        let ring = |r: f64, z: f64, w: f64| -> Vec<[f64; 3]> {
            (0..60)
                .map(|j| {
                    let t = std::f64::consts::TAU * j as f64 / 60.0;
                    let rr = r * (1.0 + w * (3.0 * t).cos());
                    [rr * t.cos(), rr * t.sin(), z]
                })
                .collect()
        };
        let region = vec![
            vec![[0.0, 0.0, 0.0]],
            ring(10.0, 1.0, 0.1),
            ring(12.0, 3.0, 0.2),
            ring(8.0, 5.0, 0.05),
        ];
        let f = fit_common(&region, &FitOptions::new(0.05)).unwrap();
        let s = skin(&f.curves).unwrap();
        for idx in 0..s.patch_boxes.len() {
            let (ua, ub, va, vb) = s.patch_rect(idx);
            let (lo, hi) = s.patch_boxes[idx];
            for a in 0..=10 {
                for c in 0..=10 {
                    let q = s.eval(
                        ua + (ub - ua) * a as f64 / 10.0,
                        va + (vb - va) * c as f64 / 10.0,
                    );
                    for i in 0..3 {
                        assert!(
                            q[i] >= lo[i] - 1e-9 && q[i] <= hi[i] + 1e-9,
                            "patch {idx}: {q:?} outside {lo:?}..{hi:?}"
                        );
                    }
                }
            }
        }
    }
}
