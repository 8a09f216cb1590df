//! Tessellation of skinned surfaces into triangles that close up into a watertight mesh.
//!
//! In: a surface, the exact end curves of its region (a closed loop, or a single point) and a
//! chordal tolerance (mm). Out: triangles with vertices in patient mm, wound so that
//! `(b − a) × (c − a)` points along `S_u × S_v`: outwards for outer walls (counter-clockwise
//! contours, v rising along the slice normal) and out of the material for hole walls
//! (clockwise contours).
//!
//! Watertight by construction: neighbouring regions share their end loops (intermediate
//! contours tiling a branching plane, cap ridge loops, contours where a region is split), so
//! the boundary rows of the grid are replaced by the region's own end-loop points, bit for bit,
//! and zipped to the first interior row in the order of their parameter u on the boundary
//! iso-curve. Two patches meeting at a loop then use each of its edges once, in opposite
//! directions (the lower patch's top rows traverse the loop against u, the upper patch's
//! bottom rows along it). A point end is one apex vertex with a fan.
//!
//! Adaptive: per u knot span and per v interval between curves, the number of samples keeps
//! the chord deviation of the triangles, bounded by `(1/8)·|d|²·max|S_dd|` along every triangle
//! edge direction `d` (second derivatives sampled on each patch), below the chordal tolerance.
//! Rows are sampled at every curve's v̄_k, so the mesh passes through every fitted curve.
//!
//! Where a row loops through itself by less than the chordal tolerance (the surface folds
//! below the mesh's resolution), the written mesh may cut the loop off at its crossing
//! ([`RowLoops::Cut`]): the fold is not a shape of the object, and a mesh checker counts it
//! as faces crossing one another.

use crate::bspline::surface::SkinnedSurface;
use crate::bspline::vecops::{add, dot, norm, scale, sub};
use crate::geometry::polygon::{crosses_itself, dist, orient, proper_crossing, Point};
use crate::section::SliceFrame;

pub mod crossings;

pub type Triangle = [[f64; 3]; 3];
type P3 = [f64; 3];

/// Most samples per u knot span or per v interval (a guard against pathological curvature).
pub const MAX_SAMPLES_PER_SPAN: usize = 64;
/// [`RowLoops::Cut`] cuts off loops of fewer samples than this: loops within the chordal
/// tolerance span a few samples, since samples are spaced for that tolerance.
const LOOP_REACH: usize = 32;
/// Row samples closer than this fraction of the mean spacing are merged.
const MIN_SAMPLE_GAP: f64 = 0.01;
/// Most rounds of adding row samples between a slit's or ridge's two visits of a vertex.
const SLIT_ROUNDS: usize = 4;
/// Second-derivative samples per patch side (corners and interior points).
const PROBES: usize = 5;

/// Triangles of `s` with its end rows replaced by the loops `bottom` (at v = v̄_0) and `top`
/// (at v = v̄_last), each a closed loop in the direction of u starting where u = 0 (as the
/// fitted curves do) or a single point, and the grid fine enough that the triangles stay
/// within `chordal_mm` of the surface.
pub fn tessellate(s: &SkinnedSurface, bottom: &[P3], top: &[P3], chordal_mm: f64) -> Vec<Triangle> {
    let mut tris = Vec::new();
    tessellate_each(s, bottom, top, chordal_mm, RowLoops::Keep, |t| tris.push(t));
    tris
}

/// What a tessellation does where an interior row loops through itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowLoops {
    /// The rows as the surface has them: to judge a surface by its folds (stage 6).
    Keep,
    /// Each loop of fewer than [`LOOP_REACH`] samples, none of them further than the
    /// chordal tolerance from where its edges cross, is cut off there: its samples move
    /// onto the crossing point ([`cut_loops`]). For the mesh files: their vertices stay
    /// within the chordal tolerance of the surface, and the fold leaves the mesh.
    Cut,
}

/// The interior rows of a tessellation (iso-curves v = const, as meshed), how many of them
/// cross themselves, and how many loops were cut off them ([`RowLoops::Cut`]).
///
/// A surface's curves lie in parallel planes and its height along their normal is monotone in
/// v (see [`crate::bspline::skinning`]), so each plane between its end curves meets it in one
/// iso-curve, which lies in that plane: the surface passes through itself exactly where an
/// iso-curve crosses itself. Counting the mesh's rows that do so finds the folds a mesh
/// checker sees (MeshLab's faces crossing their own surface) wherever a row passes through
/// them, at the cost of one sweep per row. Crossings between different surfaces are not
/// counted; nor is a surface whose first row has no area to take a plane from. Rows are
/// counted as meshed: after any loops were cut off.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Folds {
    pub rows: usize,
    pub folded: usize,
    pub loops_cut: usize,
    pub cusps_cut: usize,
}

impl Folds {
    /// Cuts `row`'s small loops if `loops` says so, then counts it.
    fn mesh_row(
        &mut self,
        frame: &Option<SliceFrame>,
        row: &mut [P3],
        loops: RowLoops,
        chordal_mm: f64,
    ) {
        self.rows += 1;
        let Some(f) = frame else { return };
        let mut flat = in_plane(f, row);
        if loops == RowLoops::Cut {
            self.loops_cut += cut_loops(f, row, &mut flat, chordal_mm);
            self.cusps_cut += cut_cusps(row, &mut flat, chordal_mm);
        }
        if crosses_itself(&flat) {
            self.folded += 1;
        }
    }
}

/// `row`'s points in `frame`'s plane.
fn in_plane(frame: &SliceFrame, row: &[P3]) -> Vec<Point> {
    row.iter().map(|&p| frame.to_plane(p)).collect()
}

/// Cuts off the closed row's loops that [`RowLoops::Cut`] describes, `row` and `flat` (the
/// row in `frame`'s plane) together; returns how many. Where edge i crosses edge j a few
/// samples on, samples i+1..=j move to the crossing, each by at most `bound`: the edges
/// either side shorten to the crossing and those between collapse to no length, so the row
/// keeps its sample count (the triangles on them have two equal corners and are dropped,
/// which keeps every other edge used once each way). Rows are scanned from sample 0 on,
/// taking the nearest crossing edge first, so the result is the same on every run.
pub fn cut_loops(frame: &SliceFrame, row: &mut [P3], flat: &mut [Point], bound: f64) -> usize {
    let n = row.len();
    if n < 4 {
        return 0;
    }
    let mut cut = 0;
    let mut i = 0;
    while i < n {
        let (a, b) = (flat[i], flat[(i + 1) % n]);
        let mut next = i + 1;
        for s in 2..LOOP_REACH.min(n - 1) {
            let j = (i + s) % n;
            let Some(along) = proper_crossing(a, b, flat[j], flat[(j + 1) % n]) else {
                continue;
            };
            let (p, q) = (row[i], row[(i + 1) % n]);
            let x = add(&p, &scale(&sub(&q, &p), along));
            if (1..=s).any(|k| dist2(&row[(i + k) % n], &x) > bound * bound) {
                continue;
            }
            let xf = frame.to_plane(x);
            for k in 1..=s {
                row[(i + k) % n] = x;
                flat[(i + k) % n] = xf;
            }
            cut += 1;
            next = i + s;
            break;
        }
        i = next;
    }
    cut
}

/// Most passes of [`cut_cusps`] over a row: a cusp cut can leave a smaller one beside it.
const CUSP_PASSES: usize = 4;

/// Cuts off the closed row's cusps, `row` and `flat` (the row in its plane) together;
/// returns how many. Where the row turns back (by more than a right angle) at a sample and
/// both edges there are no longer than `bound`, the sample moves onto the shorter edge's
/// other end: the edge collapses as [`cut_loops`]' do, the row keeps its sample count, and
/// every vertex stays a point of the surface within `bound` of the one it replaces. A spur's
/// tip, reached by a longer edge, stays: that is a shape of the object (shortened by a
/// tolerance, a thin spur's tip took the skull's rows across one another).
///
/// Such a cusp is a hook of the surface smaller than the mesh resolves (the skull's surface
/// 1 at z 694.674: the row runs 0.005 mm down and back); the row does not cross itself, but
/// the triangles from the next row fan across the hook and cross one another.
pub fn cut_cusps(row: &mut [P3], flat: &mut [Point], bound: f64) -> usize {
    let n = row.len();
    if n < 4 {
        return 0;
    }
    let mut cut = 0;
    for _ in 0..CUSP_PASSES {
        let before = cut;
        for i in 0..n {
            // The nearest samples either side at another point (collapsed edges skipped).
            let (Some(p), Some(q)) = (
                (1..n)
                    .map(|k| (i + n - k) % n)
                    .find(|&k| flat[k] != flat[i]),
                (1..n).map(|k| (i + k) % n).find(|&k| flat[k] != flat[i]),
            ) else {
                return cut;
            };
            let turn = (flat[i][0] - flat[p][0]) * (flat[q][0] - flat[i][0])
                + (flat[i][1] - flat[p][1]) * (flat[q][1] - flat[i][1]);
            if turn >= 0.0 {
                continue;
            }
            let (le, lf) = (dist(flat[p], flat[i]), dist(flat[i], flat[q]));
            if le.max(lf) > bound {
                continue;
            }
            let onto = if le <= lf { p } else { q };
            // The samples between p and q (collapsed onto i before) move with it.
            let (at, fl) = (row[onto], flat[onto]);
            let mut k = (p + 1) % n;
            while k != q {
                row[k] = at;
                flat[k] = fl;
                k = (k + 1) % n;
            }
            cut += 1;
        }
        if cut == before {
            break;
        }
    }
    cut
}

/// [`tessellate`], handing each triangle to `emit` as it is made, row by row: only two rows
/// of samples are held, so a long surface streams into a mesh file in bounded memory. Returns
/// how many of the rows cross themselves ([`Folds`]).
pub fn tessellate_each(
    s: &SkinnedSurface,
    bottom: &[P3],
    top: &[P3],
    chordal_mm: f64,
    loops: RowLoops,
    mut emit: impl FnMut(Triangle),
) -> Folds {
    let (mut us, vs) = sample_params(s, chordal_mm);
    let vb = s.v_bar();
    let (v0, v1) = (vb[0], vb[1]);
    let (vr1, vr) = (vb[vb.len() - 2], vb[vb.len() - 1]);
    let (bottom, top) = (dedup_loop(bottom), dedup_loop(top));
    let mut ends = (
        End::new(s, &us, v0, bottom.clone()),
        End::new(s, &us, vr, top.clone()),
    );
    // A loop that visits a vertex twice (a slit) needs row samples between the visits, or the
    // zip fans both visits from one row vertex: an edge of four triangles.
    // The points' parameters are found on the row samples, so they move a little when
    // samples are added: check again (a few rounds settle it).
    let period = s.u_knots().period();
    for _ in 0..SLIT_ROUNDS {
        let mut gaps = ends.0.slit_gaps(&us, period);
        gaps.extend(ends.1.slit_gaps(&us, period));
        if gaps.is_empty() {
            break;
        }
        // Three evenly spaced samples in each.
        us.extend(gaps.iter().flat_map(|&(a, b)| {
            (1..=3).map(move |q| (a + (b - a) * q as f64 / 4.0).rem_euclid(period))
        }));
        merge_samples(&mut us, &gaps, period);
        ends = (
            End::new(s, &us, v0, bottom.clone()),
            End::new(s, &us, vr, top.clone()),
        );
    }
    let (bottom, top) = ends;
    let nu = us.len();
    let last = vs.len() - 1;
    // Interior rows only (1..last): rows 0 and `last` are the end loops. Rows before the
    // second curve (after the second-to-last) move towards the end loop (see `End::offsets`).
    let row = |v: f64| -> Vec<P3> {
        let (wb, wt) = (fade((v - v0) / (v1 - v0)), fade((vr - v) / (vr - vr1)));
        (0..nu)
            .map(|k| {
                let mut p = s.eval(us[k], v);
                for (w, end) in [(wb, &bottom), (wt, &top)] {
                    if w > 0.0 && !end.offsets.is_empty() {
                        p = add(&p, &scale(&end.offsets[k], w));
                    }
                }
                p
            })
            .collect()
    };
    let mut fins = DropFins::new(&mut emit);
    let mut push = |t: Triangle| fins.push(t);
    let mut lower = row(vs[1]);
    let frame = SliceFrame::of_loop(&lower);
    let mut folds = Folds::default();
    folds.mesh_row(&frame, &mut lower, loops, chordal_mm);
    zip_end(&us, &bottom, &lower, false, &mut push);
    for &v in &vs[2..last] {
        let mut upper = row(v);
        folds.mesh_row(&frame, &mut upper, loops, chordal_mm);
        for i in 0..nu {
            let i1 = (i + 1) % nu;
            let (a, b, c, d) = (lower[i], lower[i1], upper[i1], upper[i]);
            push([a, b, c]);
            push([a, c, d]);
        }
        lower = upper;
    }
    zip_end(&us, &top, &lower, true, &mut push);
    fins.finish();
    folds
}

/// The triangles passed on, but none with two corners equal, and no pair of consecutive
/// triangles that are one triangle each way round: where a loop runs out to a spur's tip
/// and back and both passes fan from one row vertex, the zip makes such a fin, of no area
/// and with its edges used four times. Dropping the pair leaves the edges either side their
/// one use each way, and the tip out of the mesh. A triangle is held back one step for this.
struct DropFins<F: FnMut(Triangle)> {
    emit: F,
    held: Option<Triangle>,
}

impl<F: FnMut(Triangle)> DropFins<F> {
    fn new(emit: F) -> Self {
        DropFins { emit, held: None }
    }

    fn push(&mut self, t: Triangle) {
        if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
            return;
        }
        match self.held.take() {
            Some(h) if (0..3).any(|k| t == [h[k], h[(k + 2) % 3], h[(k + 1) % 3]]) => {}
            Some(h) => {
                (self.emit)(h);
                self.held = Some(t);
            }
            None => self.held = Some(t),
        }
    }

    fn finish(mut self) {
        if let Some(h) = self.held.take() {
            (self.emit)(h);
        }
    }
}

/// 1 at s = 0 falling to 0 at s = 1 (and beyond) with zero slope at both: a smoothstep.
fn fade(s: f64) -> f64 {
    if s.is_nan() || s >= 1.0 {
        return 0.0;
    }
    let s = s.max(0.0);
    1.0 - s * s * (3.0 - 2.0 * s)
}

/// One end of a surface's mesh: its exact loop (or point), where the loop's points fall on
/// the boundary iso-curve, and the loop's offsets from that iso-curve at the row samples.
struct End {
    points: Vec<P3>,
    /// Parameters u of the points on the boundary iso-curve, unwrapped to rise monotonically
    /// from t_0 ∈ [0, period) to t_m = t_0 + period (m + 1 entries; none for a point).
    t: Vec<f64>,
    /// Per row sample u_k: the loop at u_k (linear between its points) minus S(u_k, v). The
    /// fitted end curve strays from the exact loop by up to the fit tolerance, each surface
    /// sharing the loop its own way; zipped straight to the loop, two surfaces leaving a
    /// branching seam at a narrow angle folded through each other (the standing torus).
    /// Moving the rows up to the next curve by these offsets, faded out by it, makes each
    /// surface's mesh leave the loop itself. Empty for a point (a cap point is exact).
    offsets: Vec<P3>,
}

impl End {
    fn new(s: &SkinnedSurface, us: &[f64], v: f64, points: Vec<P3>) -> End {
        if points.len() < 2 {
            return End {
                points,
                t: Vec::new(),
                offsets: Vec::new(),
            };
        }
        let period = s.u_knots().period();
        let m = points.len();
        let boundary: Vec<P3> = us.iter().map(|&u| s.eval(u, v)).collect();
        // Each point is projected near where the previous one was, not anywhere: where the
        // loop runs out along a slit and back (a bridge between the pieces of a split zone,
        // see `geometry::bridges`) the nearest point of the curve is as often on the other
        // pass, and the zip would fan both passes from the same row vertex. The curve follows
        // the loop, so a step is expected at the edge's length along the curve and looked
        // for within three times that, plus four sample spacings; the first point near
        // u = 0, where the fit put it (a slit's base lies on both passes). Along the curve,
        // not along u: a curve that stands still over a stretch of u while the other end
        // fans (`geometry::alignment::fan_match`) takes no length there.
        let length: f64 = (0..m)
            .map(|i| dist2(&points[i], &points[(i + 1) % m]).sqrt())
            .sum();
        let arc = Arc::new(us, &boundary, period);
        let (curve_len, h) = (arc.total(), arc.total() / us.len() as f64);
        let per_mm = curve_len / length.max(1e-300);
        // Each point's expected step from the previous one (point 0's from the last). Points
        // move on by at least a quarter of it, and keep a quarter of each later step as room
        // before the loop closes at t_0 + period: points that project past the close (onto
        // the curve's start again, where the loop returns beside a ridge's tip) still fit.
        let steps: Vec<f64> = (0..m)
            .map(|i| {
                period * dist2(&points[i], &points[(i + m - 1) % m]).sqrt() / length.max(1e-300)
            })
            .collect();
        let mut reserve = vec![0.0; m + 1];
        for i in (0..m).rev() {
            reserve[i] = reserve[i + 1] + 0.25 * steps[(i + 1) % m];
        }
        let mut t = Vec::with_capacity(m + 1);
        for (i, p) in points.iter().enumerate() {
            let expect = (length > 0.0 && curve_len > 0.0).then(|| match i {
                // The loop's first point is the fitted curve's, at u = 0.
                0 => (0.0, 4.0 * h),
                _ => {
                    let edge = per_mm * dist2(&points[i], &points[i - 1]).sqrt();
                    (arc.at(t[i - 1]) + edge, 3.0 * edge + 4.0 * h)
                }
            });
            let raw = project_u(s, us, &boundary, &arc, v, p, expect);
            if i == 0 {
                t.push(raw);
                continue;
            }
            let prev = t[i - 1];
            let step = (raw - prev).rem_euclid(period);
            // A point that projects behind the previous one (where the curve rounds the tip
            // of a ridge loop, or backs along a slit) still moves on by a little: two points
            // at one parameter would share their row vertices (see `slit_gaps`).
            let least = 0.25 * steps[i];
            let next = if step < 0.5 * period {
                prev + step.max(least)
            } else {
                prev + least
            };
            t.push(next.min(t[0] + period - reserve[i]).max(prev));
        }
        t.push(t[0] + period);
        let offsets = us
            .iter()
            .zip(&boundary)
            .map(|(&u, b)| {
                let u = if u < t[0] { u + period } else { u };
                let i = t.partition_point(|&ti| ti <= u).clamp(1, m) - 1;
                let span = t[i + 1] - t[i];
                let a = if span > 0.0 { (u - t[i]) / span } else { 0.0 };
                let (p, q) = (points[i], points[(i + 1) % m]);
                let at: P3 = std::array::from_fn(|d| p[d] + a * (q[d] - p[d]));
                sub(&at, b)
            })
            .collect();
        End { points, t, offsets }
    }

    /// Where the loop visits a vertex twice, the gaps (a, b), a < b, that need row samples:
    /// the zip joins each loop point to the row samples from the one before it to the one
    /// before the next point, so the two visits share a row vertex (an edge of four
    /// triangles) unless a sample lies between the point after one visit and the other
    /// visit. Either way round the loop (a ridge loop visits the points beside its tips
    /// either side of the tip), a gap holding fewer than three samples is listed.
    fn slit_gaps(&self, us: &[f64], period: f64) -> Vec<(f64, f64)> {
        use std::collections::HashMap;
        let key = |p: &P3| p.map(f64::to_bits);
        let mut first: HashMap<[u64; 3], usize> = HashMap::new();
        let mut gaps = Vec::new();
        for (j, p) in self.points.iter().enumerate() {
            let Some(&i) = first.get(&key(p)) else {
                first.insert(key(p), j);
                continue;
            };
            // t has m + 1 entries: t[j + 1] exists for the last point too (t_0 + period).
            for (a, b) in [
                (self.t[i + 1], self.t[j]),
                (self.t[j + 1], self.t[i] + period),
            ] {
                if b <= a || b.is_nan() {
                    continue;
                }
                if us.iter().filter(|&&u| within(u, a, b, period)).count() < 3 {
                    gaps.push((a, b));
                }
            }
        }
        gaps
    }
}

/// Sorts the row samples and merges those that lie a hair apart (added for both ends or in
/// two rounds: a column of vertices that coincide in the STL's float32 would make degenerate
/// triangles); one sample in a slit's gap is enough to keep two visits apart. But the gap
/// beside a ridge's tip can be narrower than the merging distance (the Siemens abdomen's:
/// 0.7 % of the mean spacing), and merging took all its samples, leaving an edge of four
/// triangles: a gap of `gaps` left empty gets its middle back.
fn merge_samples(us: &mut Vec<f64>, gaps: &[(f64, f64)], period: f64) {
    us.sort_by(f64::total_cmp);
    let close = MIN_SAMPLE_GAP * period / us.len() as f64;
    us.dedup_by(|b, a| *b - *a <= close);
    let empty: Vec<f64> = gaps
        .iter()
        .filter(|&&(a, b)| !us.iter().any(|&u| within(u, a, b, period)))
        .map(|&(a, b)| (0.5 * (a + b)).rem_euclid(period))
        .collect();
    us.extend(empty);
    us.sort_by(f64::total_cmp);
}

/// Whether `u` lies strictly between `a` and `b` (a < b), round a closed curve of `period`.
fn within(u: f64, a: f64, b: f64, period: f64) -> bool {
    let d = (u - a).rem_euclid(period);
    d > 0.0 && d < b - a
}

/// The u and v parameters of the grid: every u knot and every v̄_k, with as many samples in
/// between as the chordal tolerance needs. At least one interior row.
pub fn sample_params(s: &SkinnedSurface, chordal_mm: f64) -> (Vec<f64>, Vec<f64>) {
    let ud = s.u_knots().domain().to_vec();
    let vb = s.v_bar().to_vec();
    let (nus, nvs) = (ud.len() - 1, vb.len() - 1);
    // Per u span and per v interval: max |S_uu|, |S_vv|, |S_uv| over its patches.
    let mut m_u = vec![[0.0f64; 3]; nus];
    let mut m_v = vec![[0.0f64; 3]; nvs];
    for (i, uw) in ud.windows(2).enumerate() {
        for (j, vw) in vb.windows(2).enumerate() {
            let mut m = [0.0f64; 3];
            for a in 0..PROBES {
                let u = uw[0] + (uw[1] - uw[0]) * a as f64 / (PROBES - 1) as f64;
                for b in 0..PROBES {
                    let v = vw[0] + (vw[1] - vw[0]) * b as f64 / (PROBES - 1) as f64;
                    let d = s.derivs2(u, v);
                    for (mk, dk) in m.iter_mut().zip([d[3], d[5], d[4]]) {
                        *mk = mk.max(norm(&dk));
                    }
                }
            }
            for k in 0..3 {
                m_u[i][k] = m_u[i][k].max(m[k]);
                m_v[j][k] = m_v[j][k].max(m[k]);
            }
        }
    }
    // (1/8)(h_u² M_uu + 2 h_u h_v M_uv + h_v² M_vv) ≤ (1/8)(h_u² (M_uu + M_uv) + h_v² (M_vv +
    // M_uv)): half the budget to each direction.
    let tol = chordal_mm.max(1e-9);
    let count = |len: f64, m: f64| -> usize {
        let h = (4.0 * tol / m.max(1e-300)).sqrt();
        ((len / h).ceil() as usize).clamp(1, MAX_SAMPLES_PER_SPAN)
    };
    let mut us = Vec::new();
    for (i, w) in ud.windows(2).enumerate() {
        let n = count(w[1] - w[0], m_u[i][0] + m_u[i][2]);
        for k in 0..n {
            us.push(w[0] + (w[1] - w[0]) * k as f64 / n as f64);
        }
    }
    let mut vs = Vec::new();
    for (j, w) in vb.windows(2).enumerate() {
        let mut n = count(w[1] - w[0], m_v[j][1] + m_v[j][2]);
        if nvs == 1 {
            n = n.max(2);
        }
        for k in 0..n {
            vs.push(w[0] + (w[1] - w[0]) * k as f64 / n as f64);
        }
    }
    vs.push(vb[nvs]);
    (us, vs)
}

/// Join an end (loop or point) to the adjacent interior `row` (sampled at `us`). `top`: the
/// end is above the row (v = v̄_last), else below it. Fins are dropped ([`without_fins`]).
fn zip_end(us: &[f64], end: &End, row: &[P3], top: bool, push: &mut impl FnMut(Triangle)) {
    let mut zip = Vec::with_capacity(us.len() + end.points.len());
    zip_end_all(us, end, row, top, &mut |t| zip.push(t));
    without_fins(zip).into_iter().for_each(push);
}

/// The triangles of one zip without the pairs that are one triangle each way round. Where
/// an end loop runs out along a spur and back, and both passes fan from one row vertex,
/// the zip makes such a pair (a fin: no area, its edges used four times). [`DropFins`]
/// drops those made one after the other; a spur branching off a spur makes them nested
/// (the MR enhanced-multiframe series 301 at `--threshold 200`: a ridge cap's branch), and
/// a loop starting on a spur makes one pair at the zip's start and end (series 5). Dropping
/// a pair takes one use each way from each of its edges, so the mesh stays closed.
fn without_fins(zip: Vec<Triangle>) -> Vec<Triangle> {
    use std::collections::HashMap;
    type Key = [[u64; 3]; 3];
    // The corners from the least (by bits), keeping the turn: one key per oriented triangle.
    let key = |t: &Triangle| -> Key {
        let b = t.map(|p| p.map(f64::to_bits));
        let k = (0..3).min_by_key(|&k| b[k]).unwrap_or(0);
        [b[k], b[(k + 1) % 3], b[(k + 2) % 3]]
    };
    let mut open: HashMap<Key, Vec<usize>> = HashMap::new();
    let mut keep = vec![true; zip.len()];
    for (i, t) in zip.iter().enumerate() {
        let reverse = key(&[t[0], t[2], t[1]]);
        if let Some(j) = open.get_mut(&reverse).and_then(Vec::pop) {
            keep[i] = false;
            keep[j] = false;
        } else {
            open.entry(key(t)).or_default().push(i);
        }
    }
    zip.into_iter()
        .zip(keep)
        .filter_map(|(t, k)| k.then_some(t))
        .collect()
}

fn zip_end_all(us: &[f64], end: &End, row: &[P3], top: bool, push: &mut impl FnMut(Triangle)) {
    let n = us.len();
    // Orientation as in the grid: a quad (row j: a→b, row j+1: d←c) gives [a,b,c], [a,c,d].
    let tri_row = |lo: P3, lo1: P3, hi: P3| if top { [lo, lo1, hi] } else { [hi, lo1, lo] };
    let points = &end.points;
    if points.len() < 2 {
        let apex = points[0];
        for i in 0..n {
            push(tri_row(row[i], row[(i + 1) % n], apex));
        }
        return;
    }
    let (m, t) = (points.len(), &end.t);
    let period = t[m] - t[0];
    // Row parameters unwrapped from the last sample at or before t_0.
    let j0 = us.partition_point(|&u| u <= t[0]).saturating_sub(1);
    let r: Vec<f64> = (0..=n)
        .map(|k| us[(j0 + k) % n] + period * ((j0 + k) / n) as f64)
        .collect();
    let (mut i, mut k) = (0, 0);
    while i < m || k < n {
        let advance_end = k == n || (i < m && t[i + 1] <= r[k + 1]);
        let (rk, rk1) = (row[(j0 + k) % n], row[(j0 + k + 1) % n]);
        let (pi, pi1) = (points[i % m], points[(i + 1) % m]);
        if advance_end {
            // Edge p_i → p_{i+1} of the end with the row vertex r_k.
            push(if top { [rk, pi1, pi] } else { [pi, pi1, rk] });
            i += 1;
        } else {
            push(tri_row(rk, rk1, pi));
            k += 1;
        }
    }
}

/// Arc length along the closed polyline through an iso-curve's samples.
struct Arc<'a> {
    us: &'a [f64],
    period: f64,
    /// `cum[k]`: from sample 0 to sample k; `cum[n]`: round the whole loop.
    cum: Vec<f64>,
}

impl<'a> Arc<'a> {
    fn new(us: &'a [f64], samples: &[P3], period: f64) -> Self {
        let n = samples.len();
        let mut cum = Vec::with_capacity(n + 1);
        cum.push(0.0);
        for k in 0..n {
            cum.push(cum[k] + dist2(&samples[k], &samples[(k + 1) % n]).sqrt());
        }
        Arc { us, period, cum }
    }

    fn total(&self) -> f64 {
        self.cum[self.cum.len() - 1]
    }

    /// Arc length at parameter `u` (any real: whole turns add the total), linear between
    /// samples.
    fn at(&self, u: f64) -> f64 {
        let (turns, w) = (u.div_euclid(self.period), u.rem_euclid(self.period));
        let n = self.us.len();
        let k = self.us.partition_point(|&x| x <= w).clamp(1, n) - 1;
        let next = if k + 1 < n {
            self.us[k + 1]
        } else {
            self.period
        };
        let f = if next > self.us[k] {
            ((w - self.us[k]) / (next - self.us[k])).clamp(0.0, 1.0)
        } else {
            0.0
        };
        turns * self.total() + self.cum[k] + f * (self.cum[k + 1] - self.cum[k])
    }
}

/// Parameter u of the closest point to `p` on the iso-curve S(·, v): nearest of the samples
/// `us` (points `boundary`, arc lengths `arc`), then Newton on |C(u) − p|², kept within one
/// sample spacing. With `expect` = (s_e, reach), only samples within `reach` of arc length
/// s_e count, and each is scored by its distance plus half its distance from s_e along the
/// curve: of two passes of the curve equally near `p`, the expected one wins.
fn project_u(
    s: &SkinnedSurface,
    us: &[f64],
    boundary: &[P3],
    arc: &Arc,
    v: f64,
    p: &P3,
    expect: Option<(f64, f64)>,
) -> f64 {
    let period = s.u_knots().period();
    let total = arc.total();
    let mut best = (f64::INFINITY, 0.0);
    // Only the samples in reach are scored: arc lengths rise with the sample index, so they
    // are one or two runs of it (the window may wrap round u = 0), visited in index order.
    let n = us.len();
    let cum = &arc.cum[..n];
    let runs = match expect {
        Some((se, reach)) if 2.0 * reach < total => {
            let lo = (se - reach).rem_euclid(total);
            let hi = lo + 2.0 * reach;
            let first = cum.partition_point(|&c| c < lo);
            if hi < total {
                [0..0, first..cum.partition_point(|&c| c <= hi)]
            } else {
                [0..cum.partition_point(|&c| c <= hi - total), first..n]
            }
        }
        _ => [0..0, 0..n],
    };
    for k in runs.into_iter().flatten() {
        let (u, q) = (us[k], &boundary[k]);
        let mut score = dist2(q, p).sqrt();
        if let Some((se, reach)) = expect {
            let ds = (cum[k] - se + 0.5 * total).rem_euclid(total) - 0.5 * total;
            if ds.abs() > reach {
                continue;
            }
            score += 0.5 * ds.abs();
        }
        if score < best.0 {
            best = (score, u);
        }
    }
    if best.0.is_infinite() {
        // No sample within reach (samples far apart along the curve): the nearest of all.
        return project_u(s, us, boundary, arc, v, p, None);
    }
    let h = period / us.len() as f64;
    let (u0, mut u) = (best.1, best.1);
    for _ in 0..8 {
        let d = s.derivs2(u, v);
        let e = sub(&d[0], p);
        let g = dot(&d[1], &e);
        let hess = dot(&d[1], &d[1]) + dot(&d[3], &e);
        if hess <= 0.0 || !hess.is_finite() {
            break;
        }
        let next = (u - g / hess).clamp(u0 - h, u0 + h);
        if (next - u).abs() < 1e-12 * period {
            u = next;
            break;
        }
        u = next;
    }
    u.rem_euclid(period).min(period * (1.0 - f64::EPSILON))
}

/// The loop without consecutive repeated points (cyclically); a loop of one distinct point
/// becomes that point.
fn dedup_loop(l: &[P3]) -> Vec<P3> {
    let mut out: Vec<P3> = Vec::with_capacity(l.len());
    for p in l {
        if out.last() != Some(p) {
            out.push(*p);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    out
}

fn dist2(a: &P3, b: &P3) -> f64 {
    let d = sub(a, b);
    dot(&d, &d)
}

/// `(b − a) × (c − a)` (not normalised).
pub fn normal(t: &Triangle) -> [f64; 3] {
    cross(&sub(&t[1], &t[0]), &sub(&t[2], &t[0]))
}

/// A point's bits, to match the points loops share exactly.
fn bits(p: &P3) -> [u64; 3] {
    p.map(f64::to_bits)
}

/// A directed edge by its points' bits.
pub(crate) type EdgeKey = ([u64; 3], [u64; 3]);

/// The edge between `a` and `b` either way round, its points in the order of their bits.
fn undirected(a: P3, b: P3) -> (P3, P3) {
    if bits(&a) <= bits(&b) {
        (a, b)
    } else {
        (b, a)
    }
}

/// The edge between `a` and `b` either way round, by its points' bits in order: the key
/// under which loops that share it, in either direction, find it.
pub(crate) fn undirected_key(a: &P3, b: &P3) -> EdgeKey {
    let (a, b) = undirected(*a, *b);
    (bits(&a), bits(&b))
}

/// Each directed edge's uses minus its reverse's (see [`directed_edges`]).
type Balance = std::collections::HashMap<EdgeKey, i64>;

/// A problem's directed edges (see [`directed_edges`]): the balance of each, and all of them
/// in the loops' order.
type DirectedEdges = (Balance, Vec<(P3, P3)>);

/// The edges of a problem's end loops as their patches use them (a `top` loop's against its
/// direction), in the loops' order, and the balance of each: its uses minus its reverse's.
/// Where the loops tile the plane every balance is 0.
fn directed_edges(ends: &[(&[P3], bool)]) -> DirectedEdges {
    let mut balance = Balance::default();
    let mut order: Vec<(P3, P3)> = Vec::new();
    for (_, a, b) in patch_edges(ends) {
        *balance.entry((bits(&a), bits(&b))).or_default() += 1;
        *balance.entry((bits(&b), bits(&a))).or_default() -= 1;
        order.push((a, b));
    }
    (balance, order)
}

/// Each edge of a problem's end loops as its patch uses it (a `top` loop's against its
/// direction), in the loops' order, with its loop's index; loops of fewer than two distinct
/// points have none.
fn patch_edges<'a>(ends: &'a [(&[P3], bool)]) -> impl Iterator<Item = (usize, P3, P3)> + 'a {
    ends.iter().enumerate().flat_map(|(k, &(l, top))| {
        let l = dedup_loop(l);
        let n = if l.len() < 2 { 0 } else { l.len() };
        (0..n).map(move |i| {
            let (a, b) = (l[i], l[(i + 1) % n]);
            if top {
                (k, b, a)
            } else {
                (k, a, b)
            }
        })
    })
}

/// Triangles closing what the end loops of one problem leave open on their plane.
///
/// `ends`: every region end of one branching or cap problem, as `(loop, top)`: `top` when it
/// is the region's last curve (its patch uses each loop edge against the loop's direction),
/// else its first (along it). Where the loops tile the plane exactly, every directed edge is
/// matched by its reverse and nothing is returned. The distance-map loops sometimes leave part
/// of the plane uncovered or covered twice (a sliver a few hundredths of a cell wide where
/// three loops meet on the phantoms; gaps of up to a few hundred edges on the skull): the
/// unmatched edges then form closed cycles, each split into simple cycles and closed with flat
/// triangles (ear clipping) using its edges in the opposite direction. Deterministic: cycles
/// are walked in the order of the loops' points. Where two loops' edges cross, the cycle is
/// a figure of eight that only [`seal_problem`] closes without overlaps.
pub fn seal(ends: &[(&[P3], bool)]) -> Vec<Triangle> {
    let (balance, order) = directed_edges(ends);
    seal_edges(balance, &order)
}

/// [`seal`] from the loops' directed edges.
fn seal_edges(mut balance: Balance, order: &[(P3, P3)]) -> Vec<Triangle> {
    use std::collections::{BTreeMap, HashMap};
    type Key = [u64; 3];
    // Seal edges: the reverse of every edge with a positive balance, as many times.
    let mut out_edges: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    let mut points: Vec<P3> = Vec::new();
    let mut index: HashMap<Key, usize> = HashMap::new();
    let mut id = |p: P3, points: &mut Vec<P3>| {
        *index.entry(bits(&p)).or_insert_with(|| {
            points.push(p);
            points.len() - 1
        })
    };
    for &(a, b) in order {
        // Every edge of `order` has a balance (see `directed_edges`).
        let Some(bal) = balance.get_mut(&(bits(&a), bits(&b))) else {
            continue;
        };
        while *bal > 0 {
            *bal -= 1;
            let (ia, ib) = (id(a, &mut points), id(b, &mut points));
            out_edges.entry(ib).or_default().push(ia);
        }
    }
    let mut tris = Vec::new();
    while let Some((&start, _)) = out_edges.iter().find(|(_, v)| !v.is_empty()) {
        // Walk the seal edges from `start` (every vertex is balanced); each time the walk
        // comes back to a vertex on its path, that stretch is a simple cycle: triangulate it.
        let mut path = vec![start];
        let mut on_path: HashMap<usize, usize> = HashMap::from([(start, 0)]);
        while let Some(next) = path.last().and_then(|at| {
            out_edges
                .get_mut(at)
                .and_then(|v| (!v.is_empty()).then(|| v.remove(0)))
        }) {
            if let Some(&p) = on_path.get(&next) {
                let cycle: Vec<P3> = path[p..].iter().map(|&k| points[k]).collect();
                for &k in &path[p + 1..] {
                    on_path.remove(&k);
                }
                path.truncate(p + 1);
                if cycle.len() > 8 {
                    tracing::debug!("seal: a cycle of {} edges", cycle.len());
                }
                tris.extend(triangulate(&cycle));
            } else {
                on_path.insert(next, path.len());
                path.push(next);
            }
        }
    }
    tris
}

/// The edges of one problem's end loops (`ends` as in [`seal`]) that two loops on the same
/// side of its plane run opposite ways: chains where two regions' loops meet, each region's
/// patch reaching them from its own side (a branching's pieces of one intermediate contour).
/// Each once, as `[a, b]` of the first loop that has it, in the loops' order.
pub fn shared_edges(ends: &[(&[P3], bool)]) -> Vec<[P3; 2]> {
    let loops: Vec<(Vec<(P3, P3)>, bool)> = ends
        .iter()
        .map(|(l, top)| {
            let l = dedup_loop(l);
            let m = if l.len() < 2 { 0 } else { l.len() };
            ((0..m).map(|i| (l[i], l[(i + 1) % m])).collect(), *top)
        })
        .collect();
    let mut runs: std::collections::HashMap<EdgeKey, Vec<usize>> = Default::default();
    for (k, (edges, _)) in loops.iter().enumerate() {
        for (a, b) in edges {
            runs.entry((bits(a), bits(b))).or_default().push(k);
        }
    }
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    for (k, (edges, top)) in loops.iter().enumerate() {
        for &(a, b) in edges {
            let against = runs.get(&(bits(&b), bits(&a)));
            let shared = against.is_some_and(|o| o.iter().any(|&j| j != k && loops[j].1 == *top));
            if shared && seen.insert(undirected_key(&a, &b)) {
                out.push([a, b]);
            }
        }
    }
    out
}

/// [`seal`] on one problem's end loops, after putting a point where two of their unmatched
/// edges cross onto both edges; with those points, as `[a, b, x]`: `x` on the edge between
/// `a` and `b` (in the order of their bits). The mesh puts each into the region's end row
/// too ([`with_edge_points`]), so the patches and the seal share it; the fitted curves keep
/// the loops as they were.
///
/// Where one loop's edge crosses another's, the plane is covered twice on one side of the
/// crossing and left open on the other (the distance-map loops of a branching do this where
/// they meet at a shallow angle): the unmatched edges make a figure of eight, which no
/// triangles on its own vertices close without overlapping one another or the patches next
/// to it. Split at the crossing, it is two simple cycles, one each way round.
///
/// First, a corner of a thin triangle (or the corners of a thin polygon) of unmatched edges,
/// within `sliver_mm` of the opposite edge, is put on that edge ([`sliver_points`]), where it
/// is kept if the seal then uses every edge once each way.
pub fn seal_problem(ends: &[(&[P3], bool)], sliver_mm: f64) -> (Vec<Triangle>, Vec<[P3; 3]>) {
    let (balance, order) = directed_edges(ends);
    let mut slivers = sliver_points(ends, &balance, sliver_mm);
    while !slivers.is_empty() {
        let split = split_loops(ends, &slivers);
        let split_ends = as_ends(&split);
        let split_balance = directed_edges(&split_ends).0;
        let Some((triangles, mut points)) = seal_crossing(&split_ends, &split_balance) else {
            break;
        };
        // The writer puts all of a problem's points into the loops as given, so a crossing
        // may not lie on an edge that only the split made (between the corners put on one
        // edge and its ends): that edge's slivers are dropped and the rest tried again (one
        // problem can hold dozens of slivers and a crossing).
        let crossed: std::collections::HashSet<EdgeKey> = points
            .iter()
            .map(|[a, b, _]| undirected_key(a, b))
            .collect();
        let spoilt: Vec<EdgeKey> = made_edges(&slivers)
            .into_iter()
            .filter(|(made, _)| crossed.contains(made))
            .map(|(_, long)| long)
            .collect();
        let before = slivers.len();
        slivers.retain(|[p, q, _]| !spoilt.contains(&undirected_key(p, q)));
        if slivers.len() == before {
            points.extend(slivers);
            return (triangles, points);
        }
    }
    seal_crossing(ends, &balance).unwrap_or_else(|| (seal_edges(balance, &order), Vec::new()))
}

/// The edges that putting `slivers` (`[p, q, v]`) on their edges makes, each with the long
/// edge `p`–`q` it is part of: between `p`, the corners in order along the edge (as
/// [`with_edge_points`] puts them), and `q`.
fn made_edges(slivers: &[[P3; 3]]) -> Vec<(EdgeKey, EdgeKey)> {
    let mut on: std::collections::BTreeMap<EdgeKey, (P3, P3, Vec<P3>)> = Default::default();
    for [p, q, v] in slivers {
        on.entry(undirected_key(p, q))
            .or_insert_with(|| (*p, *q, Vec::new()))
            .2
            .push(*v);
    }
    let mut out = Vec::new();
    for (long, (p, q, vs)) in on {
        let chain: Vec<P3> = std::iter::once(p)
            .chain(in_order_along(&p, &q, &vs))
            .chain([q])
            .collect();
        out.extend(
            chain
                .windows(2)
                .map(|w| (undirected_key(&w[0], &w[1]), long)),
        );
    }
    out
}

/// [`seal_problem`] without slivers: the seal with the crossing points put on their edges,
/// dropping those that leave an edge used more than twice; `None` where none is left to drop
/// and edges are still overused. `balance`: of the loops' edges ([`directed_edges`]).
fn seal_crossing(
    ends: &[(&[P3], bool)],
    balance: &Balance,
) -> Option<(Vec<Triangle>, Vec<[P3; 3]>)> {
    let mut crossings = crossing_points(ends, balance);
    // Every crossing first. Three edges crossing one another near a point can make a small
    // triangle that the cycles wind round twice, its edges then used more than twice: the
    // crossings at such edges' ends are dropped and the rest split again, until every edge
    // is used once each way.
    loop {
        let points: Vec<[P3; 3]> = crossings.iter().flatten().copied().collect();
        let split = split_loops(ends, &points);
        let (balance, order) = directed_edges(&as_ends(&split));
        let triangles = seal_edges(balance, &order);
        let overused = overused_ends(&order, &triangles);
        if overused.is_empty() {
            return Some((triangles, points));
        }
        let before = crossings.len();
        crossings.retain(|[[_, _, x], _]| !overused.contains(&bits(x)));
        if crossings.len() == before {
            return None;
        }
    }
}

/// Each loop of `ends` with `points` put on its edges ([`with_edge_points`]).
fn split_loops(ends: &[(&[P3], bool)], points: &[[P3; 3]]) -> Vec<(Vec<P3>, bool)> {
    ends.iter()
        .map(|(l, top)| (with_edge_points(l, points), *top))
        .collect()
}

/// `loops` as [`seal`] takes them.
fn as_ends(loops: &[(Vec<P3>, bool)]) -> Vec<(&[P3], bool)> {
    loops.iter().map(|(l, top)| (l.as_slice(), *top)).collect()
}

/// Where three unmatched edges of one problem's loops (`ends` as in [`seal`], `balance` from
/// [`directed_edges`]) close a triangle with a corner within `sliver_mm` of the opposite
/// edge, that edge from another loop than the corner's two: the corner put on the edge, as
/// `[a, b, v]` (see [`seal_problem`]).
///
/// Such a sliver is where two pieces of an intermediate contour, cut apart by a chain, put
/// the chain's end just off the edge of the loop they tile. Sealed with a flat triangle, the
/// chain runs across that edge, and the patches either side of the plane touch there, off
/// their vertices: where the slices are tilted, float rounding puts the touch either side of
/// the plane, and mesh checkers count both faces as crossing. With the corner on the edge,
/// the loops meet at it.
///
/// Then thin polygons: an unmatched edge and a path of two to [`MAX_SLIVER_CORNERS`] corners
/// back along it on other loops' unmatched edges, each corner within `sliver_mm` of the edge
/// and nearer its start than the one before: all the corners go on the edge. Two pieces'
/// sides along a chain can run that close over a millimetre (the GE head's tongue at
/// (2.6, −8.7, −13.6): 0.011 mm apart), where flat triangles sealing the gap pass a hair from
/// the loops' vertices and the patches touch them.
fn sliver_points(ends: &[(&[P3], bool)], balance: &Balance, sliver_mm: f64) -> Vec<[P3; 3]> {
    use std::collections::{HashMap, HashSet};
    // Every unmatched edge used once, as its patch uses it, with its loop.
    let edges: Vec<(usize, P3, P3)> = patch_edges(ends)
        .filter(|(_, a, b)| balance.get(&(bits(a), bits(b))) == Some(&1))
        .collect();
    let mut loop_of: HashMap<EdgeKey, usize> = HashMap::new();
    let mut next: HashMap<[u64; 3], Vec<P3>> = HashMap::new();
    for &(k, a, b) in &edges {
        loop_of.entry((bits(&a), bits(&b))).or_insert(k);
        next.entry(bits(&a)).or_default().push(b);
    }
    let mut seen: HashSet<[[u64; 3]; 3]> = HashSet::new();
    let mut long_edges: HashSet<EdgeKey> = HashSet::new();
    let mut out = Vec::new();
    for &(_, a, b) in &edges {
        for v in next.get(&bits(&b)).into_iter().flatten() {
            if bits(v) == bits(&a) || !loop_of.contains_key(&(bits(v), bits(&a))) {
                continue;
            }
            let mut key = [bits(&a), bits(&b), bits(v)];
            key.sort_unstable();
            if !seen.insert(key) {
                continue;
            }
            // The corner nearest the opposite edge, the first of equals.
            let corners = [(a, b, *v), (b, *v, a), (*v, a, b)];
            let Some((d, p, q, r)) = corners
                .iter()
                .filter_map(|&(p, q, r)| Some((off_segment(&r, &p, &q)?.0, p, q, r)))
                .min_by(|x, y| x.0.total_cmp(&y.0))
            else {
                continue;
            };
            let of = |x: &P3, y: &P3| loop_of.get(&(bits(x), bits(y))).copied();
            let long = of(&p, &q);
            if d <= sliver_mm
                && long != of(&q, &r)
                && long != of(&r, &p)
                && long_edges.insert(undirected_key(&p, &q))
            {
                let (p, q) = undirected(p, q);
                out.push([p, q, r]);
            }
        }
    }
    // Then thin polygons: a long edge and a path of other loops' edges back along it, every
    // corner within `sliver_mm` of it (two pieces' sides along one chain that run a
    // hundredth of a millimetre apart: one side's corners go on the other's edge).
    let mut corners: HashSet<[u64; 3]> = out.iter().map(|[.., v]| bits(v)).collect();
    for &(k, p, q) in &edges {
        if long_edges.contains(&undirected_key(&p, &q)) {
            continue;
        }
        let ctx = SliverPath {
            p,
            q,
            of: k,
            next: &next,
            loop_of: &loop_of,
            sliver_mm,
        };
        let mut path = Vec::new();
        if ctx.back(q, 1.0, &mut path)
            && path.iter().all(|v| !corners.contains(&bits(v)))
            && long_edges.insert(undirected_key(&p, &q))
        {
            let (a, b) = undirected(p, q);
            corners.extend(path.iter().map(bits));
            out.extend(path.into_iter().map(|v| [a, b, v]));
        }
    }
    out
}

/// Longest path of corners [`sliver_points`] puts on one edge.
const MAX_SLIVER_CORNERS: usize = 6;

/// The search for a thin polygon of unmatched edges along edge `p`→`q` of loop `of`.
struct SliverPath<'a> {
    p: P3,
    q: P3,
    of: usize,
    next: &'a std::collections::HashMap<[u64; 3], Vec<P3>>,
    loop_of: &'a std::collections::HashMap<EdgeKey, usize>,
    sliver_mm: f64,
}

impl SliverPath<'_> {
    /// Whether unmatched edges of other loops than `of` lead from `at` (at `t` along `p`→`q`)
    /// back to `p` through at least two and at most [`MAX_SLIVER_CORNERS`] corners, each
    /// nearer `p` than the one before and within `sliver_mm` of the edge; `path` then holds
    /// them (the first found, in the order of `next`).
    fn back(&self, at: P3, t: f64, path: &mut Vec<P3>) -> bool {
        let other = |a: &P3, b: &P3| {
            self.loop_of
                .get(&(bits(a), bits(b)))
                .is_some_and(|&l| l != self.of)
        };
        for w in self.next.get(&bits(&at)).into_iter().flatten() {
            if !other(&at, w) {
                continue;
            }
            if bits(w) == bits(&self.p) {
                if path.len() >= 2 {
                    return true;
                }
                continue;
            }
            if path.len() == MAX_SLIVER_CORNERS {
                continue;
            }
            let Some((off, along)) = off_segment(w, &self.p, &self.q) else {
                continue;
            };
            if off <= self.sliver_mm && along < t {
                path.push(*w);
                if self.back(*w, along, path) {
                    return true;
                }
                path.pop();
            }
        }
        false
    }
}

/// How far `r` lies from segment `pq`, and where its foot falls along it (0 at `p`, 1 at
/// `q`), where the foot falls strictly inside the segment.
fn off_segment(r: &P3, p: &P3, q: &P3) -> Option<(f64, f64)> {
    let d = sub(q, p);
    let t = dot(&sub(r, p), &d) / dot(&d, &d);
    (t > 0.0 && t < 1.0).then(|| (dist2(r, &add(p, &scale(&d, t))).sqrt(), t))
}

/// The end points of the edges that the patches (each loop edge once, in `order` from
/// [`directed_edges`]) and the seal `triangles` do not use exactly once each way: none where
/// no edge is shared by more than two faces.
fn overused_ends(
    order: &[(P3, P3)],
    triangles: &[Triangle],
) -> std::collections::BTreeSet<[u64; 3]> {
    let mut uses: std::collections::HashMap<EdgeKey, u32> = Default::default();
    let edges = order.iter().copied().chain(
        triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]),
    );
    for (a, b) in edges {
        *uses.entry((bits(&a), bits(&b))).or_default() += 1;
    }
    uses.iter()
        .filter(|(&(a, b), &n)| n != 1 || uses.get(&(b, a)) != Some(&1))
        .flat_map(|(&(a, b), _)| [a, b])
        .collect()
}

/// The loop `l` with each of `points` (`[a, b, x]`, see [`seal_problem`]) put between `a` and
/// `b` where they are neighbours in it, either way round, in order along the edge.
pub fn with_edge_points(l: &[P3], points: &[[P3; 3]]) -> Vec<P3> {
    if points.is_empty() || l.len() < 2 {
        return l.to_vec();
    }
    let mut on: std::collections::HashMap<EdgeKey, Vec<P3>> = Default::default();
    for [a, b, x] in points {
        on.entry((bits(a), bits(b))).or_default().push(*x);
    }
    let n = l.len();
    let mut out = Vec::with_capacity(n + points.len());
    for i in 0..n {
        let (a, b) = (l[i], l[(i + 1) % n]);
        out.push(a);
        let (lo, hi) = undirected(a, b);
        if let Some(xs) = on.get(&(bits(&lo), bits(&hi))) {
            out.extend(in_order_along(&a, &b, xs));
        }
    }
    out
}

/// `xs` (points on the edge from `a` to `b`) in order from `a`, each once.
fn in_order_along(a: &P3, b: &P3, xs: &[P3]) -> Vec<P3> {
    let d = sub(b, a);
    let mut along: Vec<(f64, P3)> = xs.iter().map(|x| (dot(&sub(x, a), &d), *x)).collect();
    along.sort_by(|u, v| u.0.total_cmp(&v.0).then(bits(&u.1).cmp(&bits(&v.1))));
    along.dedup_by(|u, v| u.1 == v.1);
    along.into_iter().map(|(_, x)| x).collect()
}

/// The points where two unmatched edges of the loops (`balance` from [`directed_edges`])
/// cross properly, by crossing: both edges' `[a, b, x]`. Each point is computed from the two
/// segments in a fixed order of their end points, so both edges, and every copy of them, get
/// it bit for bit.
fn crossing_points(ends: &[(&[P3], bool)], balance: &Balance) -> Vec<[[P3; 3]; 2]> {
    let Some(frame) = ends.iter().find_map(|(l, _)| SliceFrame::of_loop(l)) else {
        return Vec::new();
    };
    // Every unmatched edge of positive length: its ends, and in the plane.
    let mut edges: Vec<([P3; 2], [[f64; 2]; 2])> = Vec::new();
    for (l, _) in ends {
        let n = l.len();
        for i in 0..n {
            let (a, b) = (l[i], l[(i + 1) % n]);
            if n > 1 && a != b && balance.get(&(bits(&a), bits(&b))).is_some_and(|&m| m != 0) {
                // In the fixed order of their bits.
                let (a, b) = undirected(a, b);
                edges.push(([a, b], [frame.to_plane(a), frame.to_plane(b)]));
            }
        }
    }
    edges.sort_by(|x, y| {
        let low = |e: &[[f64; 2]; 2]| e[0][0].min(e[1][0]);
        low(&x.1)
            .total_cmp(&low(&y.1))
            .then((bits(&x.0[0]), bits(&x.0[1])).cmp(&(bits(&y.0[0]), bits(&y.0[1]))))
    });
    edges.dedup_by(|x, y| x.0 == y.0);
    let mut found: Vec<[[P3; 3]; 2]> = Vec::new();
    for (i, e) in edges.iter().enumerate() {
        let high = e.1[0][0].max(e.1[1][0]);
        for f in edges[i + 1..]
            .iter()
            .take_while(|f| f.1[0][0].min(f.1[1][0]) <= high)
        {
            let (s, t) = if (bits(&e.0[0]), bits(&e.0[1])) <= (bits(&f.0[0]), bits(&f.0[1])) {
                (e, f)
            } else {
                (f, e)
            };
            let ([p, q], [p2, q2]) = *s;
            let ([r, u], [r2, u2]) = *t;
            // A proper crossing only: touching, shared ends and collinear overlaps are not.
            let Some(along) = proper_crossing(p2, q2, r2, u2) else {
                continue;
            };
            let x: P3 = std::array::from_fn(|d| p[d] + along * (q[d] - p[d]));
            found.push([[p, q, x], [r, u, x]]);
        }
    }
    found
}

/// Least sine of an ear's corner angle that [`triangulate`] clips while it has such ears.
const MIN_EAR_SINE: f64 = 1e-9;

/// How close (mm) another vertex may come to an ear's new diagonal before it stands in the
/// ear's way. A seal cycle can hold a vertex exactly half-way along a diagonal (the pieces of
/// a chain sampled at a fixed step), float rounding putting it either side by 10⁻¹⁵ mm; cut
/// there, the ear leaves a triangle without area with that vertex on its edge (a T-junction),
/// and the patch rising from the vertex touches the ear's face. Below the rounding of an STL
/// file's float32 coordinates (3·10⁻⁵ mm at 256 mm), so a vertex it would put across the
/// diagonal blocks the ear too.
const EAR_DIAGONAL_SLACK_MM: f64 = 1e-5;

/// Triangles of a simple closed polygon lying in a plane, in its own orientation: ear clipping
/// in the plane of its Newell normal, ears with a corner angle first; where no proper ear is
/// left (collinear points: a T-junction's zero-area sliver), the most convex corner goes.
fn triangulate(poly: &[P3]) -> Vec<Triangle> {
    let n = poly.len();
    let mut out = Vec::with_capacity(n.saturating_sub(2));
    if n < 3 {
        return out;
    }
    let mut nrm = [0.0; 3];
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    // In-plane axes with e1 × e2 along the normal: the polygon is counter-clockwise in them.
    let len = norm(&nrm).max(1e-300);
    let nz = [nrm[0] / len, nrm[1] / len, nrm[2] / len];
    let helper = if nz[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = {
        let c = cross(&helper, &nz);
        let l = norm(&c);
        [c[0] / l, c[1] / l, c[2] / l]
    };
    let e2 = cross(&nz, &e1);
    let q: Vec<[f64; 2]> = poly.iter().map(|p| [dot(p, &e1), dot(p, &e2)]).collect();
    let mut idx: Vec<usize> = (0..n).collect();
    while idx.len() > 3 {
        let m = idx.len();
        let corner = |k: usize| (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
        let is_ear = |k: usize| {
            let (a, b, c) = corner(k);
            let slack = EAR_DIAGONAL_SLACK_MM * (q[a][0] - q[c][0]).hypot(q[a][1] - q[c][1]);
            orient(q[a], q[b], q[c]) > 0.0
                && idx.iter().all(|&j| {
                    j == a
                        || j == b
                        || j == c
                        || q[j] == q[a]
                        || q[j] == q[b]
                        || q[j] == q[c]
                        || !(orient(q[a], q[b], q[j]) >= 0.0
                            && orient(q[b], q[c], q[j]) >= 0.0
                            && orient(q[c], q[a], q[j]) >= -slack)
                })
        };
        // An ear with a corner of no angle (three points of a straight run of edges) would
        // be a triangle without area, which an STL file's rounding can turn over: such ears
        // go only when no other is left.
        let sharp = |k: usize| {
            let (a, b, c) = corner(k);
            let len = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).hypot(u[1] - v[1]);
            let (ab, bc) = (len(q[a], q[b]), len(q[b], q[c]));
            orient(q[a], q[b], q[c]) > MIN_EAR_SINE * ab * bc
        };
        let k = (0..m)
            .find(|&k| sharp(k) && is_ear(k))
            .or_else(|| (0..m).find(|&k| is_ear(k)))
            .unwrap_or_else(|| {
                (0..m)
                    .max_by(|&x, &y| {
                        let (a, b, c) = corner(x);
                        let (d, e, f) = corner(y);
                        orient(q[a], q[b], q[c]).total_cmp(&orient(q[d], q[e], q[f]))
                    })
                    .unwrap_or(0)
            });
        let (a, b, c) = corner(k);
        out.push([poly[a], poly[b], poly[c]]);
        idx.remove(k);
    }
    out.push([poly[idx[0]], poly[idx[1]], poly[idx[2]]]);
    out.retain(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0]);
    out
}

fn cross(a: &P3, b: &P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn passed(input: &[Triangle]) -> Vec<Triangle> {
        let mut out = Vec::new();
        let mut fins = DropFins::new(|t| out.push(t));
        for &t in input {
            fins.push(t);
        }
        fins.finish();
        out
    }

    #[test]
    fn shared_edges_are_where_siblings_on_one_side_meet() {
        let sq = |x0: f64, x1: f64, z: f64| -> Vec<P3> {
            vec![[x0, 0.0, z], [x1, 0.0, z], [x1, 1.0, z], [x0, 1.0, z]]
        };
        // Two lower regions end at the two halves of a rectangle the upper region starts at;
        // the halves meet along x = 1. A keyhole's slit (an edge and its reverse in one
        // loop) is not a chain between siblings.
        let (left, right, whole) = (sq(0.0, 1.0, 2.0), sq(1.0, 2.0, 2.0), sq(0.0, 2.0, 2.0));
        let mut whole = whole;
        whole.splice(2..2, [[1.5, 0.5, 2.0], [2.0, 1.0, 2.0]]);
        let ends: Vec<(&[P3], bool)> = vec![(&left, true), (&right, true), (&whole, false)];
        let shared = shared_edges(&ends);
        assert_eq!(shared, vec![[[1.0, 0.0, 2.0], [1.0, 1.0, 2.0]]]);
        // The same halves as the upper side's pieces: still a chain between siblings.
        let ends: Vec<(&[P3], bool)> = vec![(&whole, true), (&left, false), (&right, false)];
        assert_eq!(shared_edges(&ends).len(), 1);
        // One half below, the other above: they meet across the plane, not side by side.
        let ends: Vec<(&[P3], bool)> = vec![(&left, true), (&right, false)];
        assert!(shared_edges(&ends).is_empty());
    }

    #[test]
    fn nested_fins_and_a_fin_across_the_zips_start_are_dropped() {
        let (a, b, c, d, e) = (
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [2.0, 1.0, 0.0],
        );
        // A spur b–c with a spur of its own at c, c–d: fins nested like brackets.
        let nested = vec![
            [a, e, b],
            [a, b, c],
            [a, c, d],
            [a, d, c],
            [a, c, b],
            [a, b, e],
        ];
        assert!(without_fins(nested).is_empty());
        // Out at the zip's start, back at its end; the same triangle twice the same way
        // round stays.
        let across = vec![[a, b, c], [d, e, c], [d, e, c], [e, a, d], [c, b, a]];
        assert_eq!(without_fins(across), vec![[d, e, c], [d, e, c], [e, a, d]]);
    }

    #[test]
    fn a_fin_is_dropped_and_everything_else_passes_in_order() {
        let (a, b, c, d) = ([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]);
        // A fan from a over b, the spur's tip c and back to b, then on to d.
        assert_eq!(
            passed(&[[a, d, b], [a, b, c], [b, a, c], [a, b, d]]),
            vec![[a, d, b], [a, b, d]]
        );
        // The same triangle twice the same way round is not a fin; a degenerate one goes.
        assert_eq!(
            passed(&[[a, b, c], [a, b, c], [a, a, d], [c, b, d]]),
            vec![[a, b, c], [a, b, c], [c, b, d]]
        );
        assert!(passed(&[]).is_empty());
    }

    /// The Siemens abdomen's ridge tip at `--chordal 0.4`: 221 row samples over a period of
    /// 157, the tip's gap (0.0022, 0.0075) after the sample at 0, the three samples put in it
    /// 0.0013 apart, within the 0.0071 that merges samples. Merging alone emptied the gap.
    #[test]
    fn merging_keeps_a_sample_in_every_slit_gap_and_drops_hairs() {
        let (period, n) = (157.0, 221);
        let mut us: Vec<f64> = (0..n).map(|k| period * k as f64 / n as f64).collect();
        let gap = (0.0022, 0.0075);
        us.extend((1..=3).map(|q| gap.0 + (gap.1 - gap.0) * q as f64 / 4.0));
        // A hair from two rounds, and a gap across the period's end.
        us.push(us[7] + 1e-9);
        let wrap = (period - 0.002, period + 0.001);
        us.extend([period - 0.001, 0.0005]);
        merge_samples(&mut us, &[gap, wrap], period);
        assert!(us.windows(2).all(|w| w[0] < w[1]));
        for (a, b) in [gap, wrap] {
            assert!(
                us.iter().any(|&u| within(u, a, b, period)),
                "({a}, {b}): {:?}",
                &us[..4]
            );
        }
        assert_eq!(us.len(), n + 2, "{:?}", &us[..5]);
        // Without the gaps, merging alone leaves the tip's gap empty.
        let mut alone: Vec<f64> = (0..n).map(|k| period * k as f64 / n as f64).collect();
        alone.extend((1..=3).map(|q| gap.0 + (gap.1 - gap.0) * q as f64 / 4.0));
        merge_samples(&mut alone, &[], period);
        assert!(!alone.iter().any(|&u| within(u, gap.0, gap.1, period)));
    }

    /// A 10 mm square at z = 3 traversed by 40 samples, with a loop `size` mm across on its
    /// bottom side after sample 5: forward 2·size, back over the path, forward again.
    fn looped_row(size: f64) -> Vec<P3> {
        let mut row: Vec<P3> = (0..40)
            .map(|k| {
                let s = k as f64 / 10.0;
                let (x, y) = match k / 10 {
                    0 => (s, 0.0),
                    1 => (1.0, s - 1.0),
                    2 => (3.0 - s, 1.0),
                    _ => (0.0, 4.0 - s),
                };
                [10.0 * x, 10.0 * y, 3.0]
            })
            .collect();
        let p = row[5];
        let at = |dx: f64, dy: f64| [p[0] + dx * size, p[1] + dy * size, 3.0];
        let looped = [at(2.0, 0.0), at(1.5, 0.5), at(1.0, -0.5), at(3.0, 0.0)];
        row.splice(6..6, looped);
        row
    }

    #[test]
    fn a_loop_within_the_bound_is_cut_at_its_crossing_wherever_it_starts() {
        let row = looped_row(0.02);
        let frame = SliceFrame::of_loop(&row).unwrap();
        assert!(crosses_itself(&in_plane(&frame, &row)));
        for start in [0, 5, 7, 8, 43] {
            let mut r = row.clone();
            r.rotate_left(start);
            let mut f = in_plane(&frame, &r);
            assert_eq!(cut_loops(&frame, &mut r, &mut f, 0.05), 1, "start {start}");
            assert!(!crosses_itself(&f), "start {start}");
            assert_eq!(f, in_plane(&frame, &r));
            r.rotate_right(start);
            // Samples 6 and 7 (out along the loop and back) move onto the crossing, where
            // edge 5–6 meets edge 7–8, 1.25 loop sizes along; nothing else moves.
            let x = [row[5][0] + 0.025, row[5][1], 3.0];
            for (k, (p, q)) in r.iter().zip(&row).enumerate() {
                if k == 6 || k == 7 {
                    assert!(dist2(p, &x) < 1e-20, "start {start}: {k} at {p:?}");
                } else {
                    assert_eq!(p, q, "start {start}: {k}");
                }
            }
        }
    }

    /// `looped_row(0.0)`'s square with a hook after sample 5: 0.04 mm on along the bottom
    /// side, 0.01 mm back and 0.01 mm down, then 0.05 mm on: the row turns back but does not
    /// cross itself.
    fn hooked_row() -> Vec<P3> {
        let mut row = looped_row(0.0);
        row.drain(6..10);
        let p = row[5];
        let hook = [[0.04, 0.0], [0.03, -0.01], [0.08, 0.0]];
        row.splice(6..6, hook.map(|[x, y]| [p[0] + x, y, 3.0]));
        row
    }

    #[test]
    fn a_hook_within_the_bound_is_cut_and_nothing_else_moves() {
        let row = hooked_row();
        let frame = SliceFrame::of_loop(&row).unwrap();
        let (mut r, mut f) = (row.clone(), in_plane(&frame, &row));
        assert!(!crosses_itself(&f));
        assert_eq!(cut_loops(&frame, &mut r, &mut f, 0.1), 0);
        assert_eq!(cut_cusps(&mut r, &mut f, 0.1), 1);
        assert_eq!(f, in_plane(&frame, &r));
        // The hook's tip (sample 6) moves onto its short edge's other end; no turn back left.
        for (k, (p, q)) in r.iter().zip(&row).enumerate() {
            assert_eq!(p, if k == 6 { &row[7] } else { q }, "{k}");
        }
        assert_eq!(cut_cusps(&mut r, &mut f, 0.1), 0);
    }

    #[test]
    fn cusps_beyond_the_bound_and_corners_are_left_as_they_are() {
        let row = hooked_row();
        let frame = SliceFrame::of_loop(&row).unwrap();
        let (mut r, mut f) = (row.clone(), in_plane(&frame, &row));
        assert_eq!(cut_cusps(&mut r, &mut f, 0.03), 0);
        assert_eq!(r, row);
        // A square's right-angle corners and a sharp star's tips (edges of 7 mm) stay.
        let mut square = looped_row(0.0);
        square.drain(6..10);
        let star: Vec<P3> = (0..40)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 40.0;
                let r = if k % 2 == 0 { 10.0 } else { 3.0 };
                [r * t.cos(), r * t.sin(), -1.0]
            })
            .collect();
        for row in [square, star] {
            let frame = SliceFrame::of_loop(&row).unwrap();
            let (mut r, mut f) = (row.clone(), in_plane(&frame, &row));
            assert_eq!(cut_cusps(&mut r, &mut f, 0.5), 0);
            assert_eq!(r, row);
        }
    }

    #[test]
    fn loops_beyond_the_bound_and_simple_rows_are_left_as_they_are() {
        for (row, bound) in [(looped_row(0.02), 0.01), (looped_row(2.0), 0.5)] {
            let frame = SliceFrame::of_loop(&row).unwrap();
            let (mut r, mut f) = (row.clone(), in_plane(&frame, &row));
            assert_eq!(cut_loops(&frame, &mut r, &mut f, bound), 0);
            assert_eq!(r, row);
        }
        // A star with 7 points, sampled finely: simple, so nothing to cut.
        let star: Vec<P3> = (0..700)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 700.0;
                let r = 10.0 + 6.0 * (7.0 * t).cos();
                [r * t.cos(), r * t.sin(), -1.0]
            })
            .collect();
        let frame = SliceFrame::of_loop(&star).unwrap();
        let (mut r, mut f) = (star.clone(), in_plane(&frame, &star));
        assert_eq!(cut_loops(&frame, &mut r, &mut f, 1.0), 0);
        assert_eq!(r, star);
    }

    /// A seal cycle (the GE head's, at a branching) with a vertex half-way along the diagonal
    /// its first ear would cut, 10⁻¹² mm beyond it. Clipped there, the rest ended in a
    /// triangle without area, the vertex on its edge; the vertex now blocks that ear, and
    /// every triangle has area, together the polygon's.
    #[test]
    fn a_vertex_on_an_ears_diagonal_blocks_the_ear() {
        let (a, g, c): (P3, P3, P3) = (
            [-65.9486, 7.6417, 2.0],
            [-66.0327, 7.2221, 2.0],
            [-66.1614, 7.303, 2.0],
        );
        // Half-way from a to c, pushed off the diagonal a–c to the side away from g (where
        // a test without slack let the ear at g be cut).
        let (dx, dy) = (c[0] - a[0], c[1] - a[1]);
        let off = 1e-12 / dx.hypot(dy);
        let d = [
            (a[0] + c[0]) / 2.0 + dy * off,
            (a[1] + c[1]) / 2.0 - dx * off,
            2.0,
        ];
        let poly = [a, g, c, [-66.155, 7.4565, 2.0], d, [-64.9277, 10.2296, 2.0]];
        let area = |t: &[P3]| {
            let n = t.len();
            (0..n)
                .map(|i| t[i][0] * t[(i + 1) % n][1] - t[(i + 1) % n][0] * t[i][1])
                .sum::<f64>()
                / 2.0
        };
        assert!(orient([a[0], a[1]], [c[0], c[1]], [d[0], d[1]]) != 0.0);
        let tris = triangulate(&poly);
        assert_eq!(tris.len(), 4);
        let least = tris
            .iter()
            .map(|t| area(t).abs())
            .fold(f64::INFINITY, f64::min);
        assert!(least > 1e-4, "a triangle of {least} mm²");
        let total: f64 = tris.iter().map(|t| area(t)).sum();
        assert!(
            (total - area(&poly)).abs() < 1e-12,
            "{total} against {}",
            area(&poly)
        );
    }
}
