//! Contour alignment (paper §2.3, METHOD.md §4): choose where each closed curve of a region
//! starts, so that the surface joins corresponding points of consecutive curves.
//!
//! In: the region's curves bottom to top, each a closed loop of 3-D points or a single point.
//! Out: the index at which each curve should start ([`align_starts`]), and, where chord
//! length joins consecutive loops across a bay or a wall, a warp of the parameters along
//! them ([`chord_warps`], on the loops in their plane, started as aligned).
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
//!
//! A start fixes the join at one point only; along the loop, equal fractions drift apart
//! wherever one loop is longer than the next (wiggles, a bump, a lobe). [`chord_warps`]
//! measures that drift by nearest points and, where it folds the surface, bends the
//! parameters of the next loop by a smooth map that takes it out, or by the matching of the
//! two loops that joins them by the shortest rulings (dynamic time warping), whichever folds
//! less (Algorithm 2 then fits the loop's points at those parameters:
//! `bspline::fit_common_warped`). Where one loop has a whole lobe the other lacks, no join at
//! bounded speed keeps the rulings apart; [`fan_tables`] then joins such loops by the
//! shortest rulings with fans allowed (one loop standing still while the other goes round the
//! lobe), each loop parameterised by the matching's own steps (`bspline::fit_common_densest`).

use super::polygon::{proper_crossings, Point};

/// Upper bound on the start candidates tried on the first loop: evenly spaced over it, so a
/// 5,000-point contour costs no more than a 256-point one. The greedy chain from each
/// candidate still visits every curve's every point.
const MAX_CANDIDATES: usize = 256;

fn d2<const D: usize>(a: [f64; D], b: [f64; D]) -> f64 {
    (0..D).map(|d| (a[d] - b[d]).powi(2)).sum()
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
        starts[k] = joining_start(&a, curves[k], spacing);
    }
    starts
}

/// Index of the point of loop `b` from which its chord-length join with `a` is closest (see
/// the module doc), to `spacing` mm along the loops.
fn joining_start<const D: usize>(a: &Loop<D>, b: &[[f64; D]], spacing: f64) -> usize {
    let b = Loop::new(b, 0);
    // Every shift at a coarse resolution, then the neighbourhood of the best at a fine one.
    let n = COARSE_SAMPLES;
    let coarse = best_shift(&a.samples(n), &b.samples(n), 0, n);
    let length = a.length().max(b.length());
    let fine = ((length / spacing.max(1e-9)).ceil() as usize).clamp(COARSE_SAMPLES, FINE_SAMPLES);
    let ratio = fine.div_ceil(COARSE_SAMPLES);
    let centre = coarse * fine / COARSE_SAMPLES;
    let (sa, sb) = (a.samples(fine), b.samples(fine));
    let shift = best_shift(&sa, &sb, centre + fine - ratio, 2 * ratio + 1);
    b.vertex_at(shift as f64 / fine as f64)
}

/// Among the shifts `first, first + 1, … (count of them, modulo n)` of two loops' `n`
/// arc-length samples each, the one (in [0, n)) at which `sb` lies closest on average to `sa`.
fn best_shift<const D: usize>(
    sa: &[[f64; D]],
    sb: &[[f64; D]],
    first: usize,
    count: usize,
) -> usize {
    let n = sa.len();
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
struct Loop<'a, const D: usize> {
    points: &'a [[f64; D]],
    start: usize,
    /// `cum[i]`: arc length from the start to its i-th point; `cum[n]`: the whole length.
    cum: Vec<f64>,
}

impl<'a, const D: usize> Loop<'a, D> {
    fn new(points: &'a [[f64; D]], start: usize) -> Self {
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

    fn point(&self, i: usize) -> [f64; D] {
        self.points[(self.start + i) % self.points.len()]
    }

    /// `count` points evenly spaced by arc length, the first at the start.
    fn samples(&self, count: usize) -> Vec<[f64; D]> {
        self.at_fractions((0..count).map(|s| s as f64 / count as f64))
    }

    /// The points at fractions `fs` (non-decreasing, in [0, 1)) of the length from the start:
    /// one walk along the loop.
    fn at_fractions(&self, fs: impl Iterator<Item = f64>) -> Vec<[f64; D]> {
        let len = self.length();
        let mut i = 0;
        fs.map(|f| {
            let at = len * f;
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
            std::array::from_fn(|d| p[d] + t * (q[d] - p[d]))
        })
        .collect()
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

/// Samples per loop on which [`chord_warps`] matches consecutive loops.
const WARP_SAMPLES: usize = 512;
/// Harmonics of a warp: the drift it corrects is the slow sum of small differences in
/// length along the loops, not any one feature.
const WARP_HARMONICS: usize = 3;
/// A warp may speed a loop up or slow it down at most this much against chord length.
const WARP_MAX_SPEED: f64 = 2.0;
/// Entries of a warp table (fractions at common parameters j / WARP_TABLE, j = 0..=it).
const WARP_TABLE: usize = 1024;
/// Blend heights at which a warp must cross itself less than chord length does.
const WARP_BLENDS: [f64; 5] = [1.0 / 6.0, 2.0 / 6.0, 0.5, 4.0 / 6.0, 5.0 / 6.0];

/// Per loop of a region (bottom to top, 2-D in their common plane; `None` for a cap point),
/// where the surface should meet it: `Some(table)` gives the loop's own chord-length
/// fraction at the common parameters j / [`WARP_TABLE`] (increasing, from 0 to 1), `None`
/// means chord length itself. Every loop is `None` unless some warp helps.
///
/// The skinned surface joins the points of consecutive loops at equal parameters, and with
/// chord length (paper Eq. 3) those are points at equal fractions of each loop's length.
/// Where one loop has wiggles, a bump or a stretch of wall the next lacks, the fractions
/// drift apart along the rest of the loop, up to several millimetres, and the surface
/// between them folds where the drift carries a join across a bay or a thin wall (the
/// skull's surface 110: two loops within 1 mm of each other almost everywhere, joined up to
/// 2.6 % of 500 mm apart). Each loop's nearest points on the next give the drift; a smooth
/// map (the identity plus [`WARP_HARMONICS`] harmonics vanishing at the start, fitted with
/// Huber weights so a lobe that one loop lacks does not pull it) takes it out. Where the
/// drift is too sharp for that (a slit or an inlet of one loop beside a bump of the other),
/// the matching of the loops' samples by the shortest rulings ([`matched_warp`]) follows it.
/// A warp is kept only where it stays within [`WARP_MAX_SPEED`] of chord length both ways
/// and the blends of the two loops cross themselves less than without it; otherwise the
/// next loop keeps its chord-length relation to this one.
pub fn chord_warps(loops: &[Option<Vec<Point>>]) -> Vec<Option<Vec<f64>>> {
    let n = loops.len();
    let identity: Vec<f64> = (0..=WARP_TABLE)
        .map(|j| j as f64 / WARP_TABLE as f64)
        .collect();
    let mut tables: Vec<Vec<f64>> = vec![identity.clone(); n];
    let mut any = false;
    for k in 1..n {
        let (Some(a), Some(b)) = (&loops[k - 1], &loops[k]) else {
            continue;
        };
        let phi = (a.len() >= 3 && b.len() >= 3)
            .then(|| warp_between(a, b))
            .flatten();
        any |= phi.is_some();
        tables[k] = match phi {
            Some(phi) => tables[k - 1].iter().map(|&s| phi.at(s)).collect(),
            None => tables[k - 1].clone(),
        };
    }
    if !any {
        return vec![None; n];
    }
    tables
        .into_iter()
        .zip(loops)
        .map(|(t, l)| l.as_ref().map(|_| t))
        .collect()
}

/// Loop `b`'s fraction φ(s) matching loop `a`'s fraction s.
enum Warp {
    /// φ(s) = s + Σ_m a_m (cos 2πms − 1) + b_m sin 2πms, the slow drift. `coef` holds a_1,
    /// b_1, a_2, b_2, … (see [`harmonics`]).
    Harmonic { coef: Vec<f64> },
    /// φ(i / n) = `table[i]`, linear between: the matching of [`matched_warp`].
    Matched { table: Vec<f64> },
}

impl Warp {
    fn at(&self, s: f64) -> f64 {
        match self {
            Warp::Harmonic { coef } => {
                let offset: f64 = harmonics(s)
                    .zip(coef.chunks(2))
                    .map(|((_, sin, cos), c)| c[0] * (cos - 1.0) + c[1] * sin)
                    .sum();
                (s + offset).clamp(0.0, 1.0)
            }
            Warp::Matched { table } => {
                let n = table.len() - 1;
                let x = s.clamp(0.0, 1.0) * n as f64;
                let i = (x.floor() as usize).min(n - 1);
                table[i] + (x - i as f64) * (table[i + 1] - table[i])
            }
        }
    }

    /// dφ/ds of a harmonic warp (a matched one's lies within [`WARP_MAX_SPEED`] by
    /// construction).
    fn speed(coef: &[f64], s: f64) -> f64 {
        1.0 + harmonics(s)
            .zip(coef.chunks(2))
            .map(|((w, sin, cos), c)| w * (c[1] * cos - c[0] * sin))
            .sum::<f64>()
    }
}

/// Per harmonic m = 1..=[`WARP_HARMONICS`] at s: (2πm, sin 2πms, cos 2πms). The warp's
/// basis is cos 2πms − 1 and sin 2πms, which vanish at s = 0.
fn harmonics(s: f64) -> impl Iterator<Item = (f64, f64, f64)> {
    (1..=WARP_HARMONICS).map(move |m| {
        let w = std::f64::consts::TAU * m as f64;
        let (sin, cos) = (w * s).sin_cos();
        (w, sin, cos)
    })
}

/// The warp from loop `a` to loop `b` (see [`chord_warps`]), if it is kept: of the harmonic
/// warp (the drift's slow part) and the matched one ([`matched_warp`], which also follows a
/// feature one loop has and the other lacks), the one whose blends cross themselves least,
/// if fewer times than chord length's; on a tie the harmonic one.
fn warp_between(a: &[Point], b: &[Point]) -> Option<Warp> {
    let n = WARP_SAMPLES;
    let (la, lb) = (Loop::new(a, 0), Loop::new(b, 0));
    let (sa, sb) = (la.samples(n), lb.samples(n));
    let crossings = |warp: &Warp| {
        // φ is increasing (its speed is positive), so its samples are in order along b.
        let warped = lb.at_fractions((0..n).map(|i| warp.at(i as f64 / n as f64)));
        blends_crossing(&sa, &warped)
    };
    // Most loops join cleanly: nothing to measure.
    let plain = blends_crossing(&sa, &sb);
    if plain == 0 {
        return None;
    }
    let mut best: Option<(usize, Warp)> = None;
    for warp in [harmonic_warp(&sa, &sb), Some(matched_warp(&sa, &sb))]
        .into_iter()
        .flatten()
    {
        let c = crossings(&warp);
        if c < best.as_ref().map_or(plain, |b| b.0) {
            best = Some((c, warp));
        }
    }
    best.map(|b| b.1)
}

/// The harmonic warp fitted to the drift of `sa`'s nearest samples on `sb` (both `n` samples
/// by arc length), if its speed stays within [`WARP_MAX_SPEED`] of chord length both ways.
fn harmonic_warp(sa: &[Point], sb: &[Point]) -> Option<Warp> {
    let n = sa.len();
    // Drift: the fraction of b's nearest sample minus a's own, wrapped to (−½, ½].
    let drift: Vec<f64> = sa
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let j = (0..n)
                .min_by(|&x, &y| d2(*p, sb[x]).total_cmp(&d2(*p, sb[y])))
                .unwrap_or(i);
            let d = (j as f64 - i as f64) / n as f64;
            d - d.round()
        })
        .collect();
    let coef = fit_warp(&drift)?;
    let speeds_ok = (0..n).all(|i| {
        let v = Warp::speed(&coef, i as f64 / n as f64);
        (1.0 / WARP_MAX_SPEED..=WARP_MAX_SPEED).contains(&v)
    });
    speeds_ok.then_some(Warp::Harmonic { coef })
}

/// The matching of `sa`'s samples to `sb`'s (both `n` by arc length, started where they
/// correspond) that joins them by the shortest rulings in all: dynamic time warping with
/// the steps (1, 1) and (k, 1), (1, k) for k up to [`MATCH_MAX_STEP`], so the match advances
/// on both loops at every step and its speed lies within [`WARP_MAX_SPEED`] of chord length
/// both ways. Where one loop has a feature the other lacks (a slit, an inlet, a bump), the
/// harmonic warp only smooths the drift out; the matching stays on the feature's near wall
/// until both loops go on alike. Symmetric weights (a step's cells along its long side
/// count once each, its first one twice, so a step of k weighs k + 1) keep it from
/// favouring any step.
fn matched_warp(sa: &[Point], sb: &[Point]) -> Warp {
    let n = sa.len();
    let w = n + 1;
    // Sample n is sample 0 again: the match closes on the start. Each distance is read by
    // several steps, so they are computed once.
    let dist: Vec<f64> = (0..w * w)
        .map(|c| d2(sa[(c / w) % n], sb[(c % w) % n]).sqrt())
        .collect();
    let d = |i: usize, j: usize| dist[i * w + j];
    let mut cost = vec![f64::INFINITY; w * w];
    // The step that reached each cell: k > 0 is (k, 1), k < 0 is (1, −k).
    let mut step = vec![1i8; w * w];
    cost[0] = 0.0;
    let max = MATCH_MAX_STEP as usize;
    for i in 1..w {
        for j in 1..w {
            let (mut best, mut how) = (f64::INFINITY, 1i8);
            for k in 1..=max.min(i) {
                let c = cost[(i - k) * w + j - 1]
                    + d(i + 1 - k, j)
                    + (0..k).map(|m| d(i - m, j)).sum::<f64>();
                if c < best {
                    (best, how) = (c, k as i8);
                }
            }
            for k in 2..=max.min(j) {
                let c = cost[(i - 1) * w + j - k]
                    + d(i, j + 1 - k)
                    + (0..k).map(|m| d(i, j - m)).sum::<f64>();
                if c < best {
                    (best, how) = (c, -(k as i8));
                }
            }
            cost[i * w + j] = best;
            step[i * w + j] = how;
        }
    }
    // Walk back from (n, n): both indices fall at every step, so the path's vertices give
    // φ at every i they visit, linear between.
    let mut path = vec![(n, n)];
    let (mut i, mut j) = (n, n);
    while i > 0 || j > 0 {
        let k = step[i * w + j];
        (i, j) = if k > 0 {
            (i - k as usize, j - 1)
        } else {
            (i - 1, j - (-k) as usize)
        };
        path.push((i, j));
    }
    path.reverse();
    let mut table = vec![0.0; w];
    for pair in path.windows(2) {
        let ((i0, j0), (i1, j1)) = (pair[0], pair[1]);
        for (i, t) in table.iter_mut().enumerate().take(i1 + 1).skip(i0) {
            let f = (i - i0) as f64 / (i1 - i0) as f64;
            *t = (j0 as f64 + f * (j1 - j0) as f64) / n as f64;
        }
    }
    Warp::Matched {
        table: smoothed(&table),
    }
}

/// Longest step of a matching ([`matched_warp`]), in samples along one loop per sample
/// along the other: the most it may speed up or slow down against chord length. Longer
/// steps (3, 5) followed more slits but folded more surfaces elsewhere (README).
const MATCH_MAX_STEP: i8 = WARP_MAX_SPEED as i8;

/// Half-width, in samples, of the box filter [`smoothed`] applies twice.
const MATCH_SMOOTHING: usize = 8;

/// `table` (φ at i / n, from 0 to 1) with its offset φ(s) − s averaged twice over
/// 2 [`MATCH_SMOOTHING`] + 1 samples round the loop, then shifted back to φ(0) = 0. A
/// matching's steps make φ's speed jump between ½, 1 and 2 from sample to sample; the
/// parameters of a loop's points fitted on a common knot vector would follow those jumps
/// with knots. An average of speeds within [½, 2] stays there, so φ stays increasing and
/// within [`WARP_MAX_SPEED`], and the offset is periodic, so φ(1) = 1 still.
fn smoothed(table: &[f64]) -> Vec<f64> {
    let n = table.len() - 1;
    let mut offset: Vec<f64> = (0..n).map(|i| table[i] - i as f64 / n as f64).collect();
    let h = MATCH_SMOOTHING.min(n / 2);
    for _ in 0..2 {
        offset = (0..n)
            .map(|i| {
                (0..=2 * h)
                    .map(|k| offset[(i + n + k - h) % n])
                    .sum::<f64>()
                    / (2 * h + 1) as f64
            })
            .collect();
    }
    let o0 = offset[0];
    (0..=n)
        .map(|i| (i as f64 / n as f64 + offset[i % n] - o0).clamp(0.0, 1.0))
        .collect()
}

/// Proper self-crossings of the blends at the [`WARP_BLENDS`] heights of two loops' samples
/// paired in order.
fn blends_crossing(sa: &[Point], sb: &[Point]) -> usize {
    WARP_BLENDS
        .iter()
        .map(|&t| {
            let blend: Vec<Point> = sa
                .iter()
                .zip(sb)
                .map(|(p, q)| [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])])
                .collect();
            proper_crossings(&blend, usize::MAX)
        })
        .sum()
}

/// Whether the blends of two loops joined at equal chord-length fractions (both started at
/// their first point) cross themselves: the only case in which [`chord_warps`] or
/// [`fan_match`] has anything to take out.
pub fn chord_join_folds(a: &[Point], b: &[Point]) -> bool {
    if a.len() < 3 || b.len() < 3 {
        return false;
    }
    let n = WARP_SAMPLES;
    blends_crossing(&Loop::new(a, 0).samples(n), &Loop::new(b, 0).samples(n)) > 0
}

/// A join of two loops in which either may stand still while the other moves on: the
/// matching of [`fan_match`].
#[derive(Clone, Debug, PartialEq)]
pub struct FanMatch {
    /// Index of the point loop `b` starts at (loop `a` keeps its start).
    pub start_b: usize,
    /// The matched chord-length fractions (of `a`, and of `b` from `start_b`), from (0, 0)
    /// to (1, 1), each step moving one loop or both by one sample.
    pub path: Vec<(f64, f64)>,
    /// Proper self-crossings of the matched samples' blends (as [`chord_warps`] counts).
    pub blends: usize,
    /// Total length of the matching's rulings (mm, one per matched sample pair).
    pub length: f64,
}

/// Starts of loop `b` tried by [`fan_match`], evenly spaced along it.
const FAN_STARTS: usize = 16;

/// The matching of two loops by the shortest rulings in all, where a ruling may fan: dynamic
/// time warping of their [`WARP_SAMPLES`] samples with the steps (1, 1), (1, 0) and (0, 1),
/// for each of [`FAN_STARTS`] starts of `b` (its own start among them), keeping of those
/// whose rulings are at most `slack` times as long in all as the shortest start's the one
/// whose blends cross themselves least (then the shorter rulings, then the earlier start).
/// A start far from where the loops correspond is matched by one fan over half the loop,
/// whose blends collapse and so cross little (GE head surface 233: 5 crossings at 10.6
/// times the shortest rulings' length, against 6 at the shortest); yet a lobe's walls may
/// need rulings twice as long to fan across its root (surface 135). Stage 6 tries both
/// ([`FAN_SLACKS`]). `None`
/// for a loop of fewer than three points.
///
/// [`matched_warp`] bounds its speed, so that one loop's fractions stay a function of the
/// other's; a lobe one loop has and the other lacks (GE head surface 135: a band of bone
/// that the intermediate contour half a slice up lacks, 37 % of the contour's length) then
/// has nowhere to go but along the rest of the loop, and the rulings cross wholesale. Here both loops are
/// parameterised by the matching's own steps, so the lobe's walls fan onto the points the
/// other loop has at its root, as a cap's walls fan onto its point. A matching with a bad
/// start cannot recover (it is closed at both ends), hence the several starts.
pub fn fan_match(a: &[Point], b: &[Point], slack: f64) -> Option<FanMatch> {
    if a.len() < 3 || b.len() < 3 {
        return None;
    }
    let n = WARP_SAMPLES;
    let sa = Loop::new(a, 0).samples(n);
    let lb = Loop::new(b, 0);
    let mut starts: Vec<usize> = (0..FAN_STARTS)
        .map(|k| lb.vertex_at(k as f64 / FAN_STARTS as f64))
        .collect();
    starts.dedup();
    let tried: Vec<FanMatch> = starts
        .into_iter()
        .map(|start| {
            let sb = Loop::new(b, start).samples(n);
            let (path, length) = fan_path(&sa, &sb);
            let (pa, pb): (Vec<Point>, Vec<Point>) = path[..path.len() - 1]
                .iter()
                .map(|&(i, j)| (sa[i % n], sb[j % n]))
                .unzip();
            let blends = blends_crossing(&pa, &pb);
            let path = path
                .iter()
                .map(|&(i, j)| (i as f64 / n as f64, j as f64 / n as f64))
                .collect();
            FanMatch {
                start_b: start,
                path,
                blends,
                length,
            }
        })
        .collect();
    let shortest = tried.iter().map(|m| m.length).fold(f64::INFINITY, f64::min);
    tried
        .into_iter()
        // Infinite slack admits any start, also where the shortest rulings have no length
        // (∞ · 0 is NaN, which admits none).
        .filter(|m| slack == f64::INFINITY || m.length <= slack * shortest)
        .min_by(|x, y| x.blends.cmp(&y.blends).then(x.length.total_cmp(&y.length)))
}

/// The slacks of [`fan_match`] that stage 6 tries: any start, and starts whose rulings are
/// at most half as long again as the shortest.
pub const FAN_SLACKS: [f64; 2] = [f64::INFINITY, 1.5];

/// A region's loops (bottom to top, `None` for a cap point) joined by [`fan_match`] where
/// chord length folds the join ([`chord_join_folds`]) or `also[k]` holds for the join of
/// loops k and k + 1 (stage 6: its band of the fitted surface crosses), and at chord length
/// elsewhere: where each loop should start, and its chord-length fraction at common
/// parameters (tables as [`chord_warps`] gives them, but flat wherever the loop stands still
/// while a neighbour fans). `None` where no join is fanned. Each fanned loop's start is
/// chosen with the loop below it already started where its own join put it.
///
/// The joins are merged into one path through all the loops' fractions: at a fraction of
/// loop k where the join below moves only loop k − 1 (or the one above only loop k + 1),
/// that move comes first; where both joins move loop k on, they move together. So every
/// join's rulings are kept, and each loop's fraction is a non-decreasing function of one
/// common parameter, each step of which moves some loop by one sample.
pub fn fan_tables(loops: &[Option<Vec<Point>>], slack: f64, also: &[bool]) -> Option<RegionFans> {
    let idx: Vec<usize> = (0..loops.len())
        .filter(|&k| loops[k].as_ref().is_some_and(|l| l.len() >= 3))
        .collect();
    if idx.len() < 2 || idx.windows(2).any(|w| w[1] != w[0] + 1) {
        return None;
    }
    let mut starts = vec![0usize; loops.len()];
    // The loop below the join, as started so far.
    let mut a: Vec<Point> = loops[idx[0]].clone().unwrap_or_default();
    // The merged path: per vertex, every loop's fraction so far (loops in `idx` order).
    let mut merged: Vec<Vec<f64>> = vec![vec![0.0], vec![1.0]];
    let mut any = false;
    let mut blends = 0;
    for w in idx.windows(2) {
        let mut b = loops[w[1]].clone().unwrap_or_default();
        // A loop a fan has started elsewhere takes the next with it (stage 5 had started
        // that one where its chord-length join with this loop's old start was closest), to
        // the finest resolution the search takes.
        if starts[w[0]] != 0 {
            starts[w[1]] = joining_start(&Loop::new(&a, 0), &b, 0.0);
            b.rotate_left(starts[w[1]]);
        }
        let join = if also.get(w[0]).copied().unwrap_or(false) || chord_join_folds(&a, &b) {
            fan_match(&a, &b, slack)
        } else {
            None
        };
        let path = match join {
            Some(m) => {
                any = true;
                blends += m.blends;
                b.rotate_left(m.start_b);
                starts[w[1]] = (starts[w[1]] + m.start_b) % b.len();
                m.path
            }
            None => vec![(0.0, 0.0), (1.0, 1.0)],
        };
        a = b;
        merged = merge_join(&merged, &path);
    }
    if !any {
        return None;
    }
    // The common parameter: each step counts its largest move in any loop.
    let mut at = vec![0.0];
    for v in merged.windows(2) {
        let step = v[0]
            .iter()
            .zip(&v[1])
            .map(|(x, y)| (y - x).abs())
            .fold(0.0f64, f64::max);
        at.push(at[at.len() - 1] + step);
    }
    let total = at[at.len() - 1];
    let len = WARP_TABLE.max(2 * merged.len());
    let mut tables: Vec<Option<Vec<f64>>> = vec![None; loops.len()];
    for (c, &k) in idx.iter().enumerate() {
        let mut p = 0;
        let table = (0..=len)
            .map(|m| {
                let x = total * m as f64 / len as f64;
                while p + 2 < at.len() && at[p + 1] <= x {
                    p += 1;
                }
                let (x0, x1) = (at[p], at[p + 1]);
                let t = if x1 > x0 {
                    ((x - x0) / (x1 - x0)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (f0, f1) = (merged[p][c], merged[p + 1][c]);
                (f0 + t * (f1 - f0)).clamp(0.0, 1.0)
            })
            .collect();
        tables[k] = Some(table);
    }
    Some(RegionFans {
        starts,
        tables,
        blends,
    })
}

/// A region's loops joined by fans ([`fan_tables`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RegionFans {
    /// Per loop: the index of the point it should start at (0 for a cap).
    pub starts: Vec<usize>,
    /// Per loop: its chord-length fraction at the common parameters j / (len − 1), as
    /// [`chord_warps`] gives them (`None` for a cap).
    pub tables: Vec<Option<Vec<f64>>>,
    /// Crossings of the fanned joins' blends, summed over those joins
    /// ([`FanMatch::blends`]).
    pub blends: usize,
}

/// The path `merged` (vertices of every loop's fraction so far, the last loop last) joined
/// with `join` (pairs of that last loop's fraction and the next loop's) into one path with
/// the next loop's fraction appended (see [`fan_tables`]). Both rise from 0 to 1 in the
/// shared fraction; between vertices it is linear in both.
fn merge_join(merged: &[Vec<f64>], join: &[(f64, f64)]) -> Vec<Vec<f64>> {
    let last = merged[0].len() - 1;
    let mut out: Vec<Vec<f64>> = Vec::with_capacity(merged.len() + join.len());
    let (mut a, mut b) = (0usize, 0usize);
    let mut now: Vec<f64> = merged[0].iter().copied().chain([join[0].1]).collect();
    out.push(now.clone());
    while a + 1 < merged.len() || b + 1 < join.len() {
        let x = now[last];
        let next_a = merged.get(a + 1);
        let next_b = join.get(b + 1);
        match (next_a, next_b) {
            // The path so far moves other loops at this fraction: they go first.
            (Some(q), _) if q[last] <= x => {
                now[..=last].copy_from_slice(q);
                a += 1;
            }
            // The join moves the next loop alone here.
            (_, Some(&(f, g))) if f <= x => {
                now[last + 1] = g;
                b += 1;
            }
            (Some(q), Some(&(f, g))) => {
                // Both move the shared loop on: to whichever vertex comes first.
                let y = q[last].min(f);
                let (p, (f0, g0)) = (&merged[a], join[b]);
                let ta = (y - p[last]) / (q[last] - p[last]);
                for (c, v) in now[..=last].iter_mut().enumerate() {
                    *v = p[c] + ta * (q[c] - p[c]);
                }
                now[last] = y;
                now[last + 1] = g0 + (y - f0) / (f - f0) * (g - g0);
                if q[last] <= y {
                    now[..=last].copy_from_slice(q);
                    a += 1;
                }
                if f <= y {
                    now[last + 1] = g;
                    b += 1;
                }
            }
            // One path has ended (both end at fraction 1): the other's rest.
            (Some(q), None) => {
                now[..=last].copy_from_slice(q);
                a += 1;
            }
            (None, Some(&(_, g))) => {
                now[last + 1] = g;
                b += 1;
            }
            (None, None) => break,
        }
        out.push(now.clone());
    }
    out
}

/// The path of the shortest rulings from sample pair (0, 0) to (n, n) (sample n is sample 0
/// again) with the steps (1, 1), (1, 0), (0, 1), each cell's ruling counted once, and its
/// total length. Ties go to the diagonal step, then to the step along `sa`.
fn fan_path(sa: &[Point], sb: &[Point]) -> (Vec<(usize, usize)>, f64) {
    let n = sa.len();
    debug_assert_eq!(sb.len(), n);
    let w = n + 1;
    // Sample n is sample 0 again: both loops extended so, not indexed modulo n in the inner
    // loop, which runs (n + 1)² times for each of 16 starts per join.
    let a: Vec<Point> = sa.iter().chain(sa.first()).copied().collect();
    let b: Vec<Point> = sb.iter().chain(sb.first()).copied().collect();
    // The step that reached each cell: 0 diagonal, 1 along a (i − 1), 2 along b (j − 1).
    let mut step = vec![0u8; w * w];
    // Costs of the row above and of this row.
    let mut above = vec![0.0; w];
    let mut here = vec![0.0; w];
    for j in 1..w {
        above[j] = above[j - 1] + d2(a[0], b[j]).sqrt();
        step[j] = 2;
    }
    for i in 1..w {
        let ai = a[i];
        here[0] = above[0] + d2(ai, b[0]).sqrt();
        step[i * w] = 1;
        for j in 1..w {
            let mut best = (above[j - 1], 0u8);
            if above[j] < best.0 {
                best = (above[j], 1);
            }
            if here[j - 1] < best.0 {
                best = (here[j - 1], 2);
            }
            here[j] = best.0 + d2(ai, b[j]).sqrt();
            step[i * w + j] = best.1;
        }
        std::mem::swap(&mut above, &mut here);
    }
    (path_back(&step, n), above[n])
}

/// The path from (0, 0) to (n, n) that `step` (of [`fan_path`]'s table) leads back along.
fn path_back(step: &[u8], n: usize) -> Vec<(usize, usize)> {
    let w = n + 1;
    let mut path = vec![(n, n)];
    let (mut i, mut j) = (n, n);
    while i > 0 || j > 0 {
        (i, j) = match step[i * w + j] {
            0 => (i - 1, j - 1),
            1 => (i - 1, j),
            _ => (i, j - 1),
        };
        path.push((i, j));
    }
    path.reverse();
    path
}

/// Least squares with Huber weights (a few reweighting rounds) of the harmonics to `drift`
/// sampled at s = i / n.
fn fit_warp(drift: &[f64]) -> Option<Vec<f64>> {
    let n = drift.len();
    let m = 2 * WARP_HARMONICS;
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            harmonics(i as f64 / n as f64)
                .flat_map(|(_, sin, cos)| [cos - 1.0, sin])
                .collect()
        })
        .collect();
    let mut weights = vec![1.0; n];
    let mut coef = vec![0.0; m];
    for _ in 0..5 {
        let mut ata = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut atb = nalgebra::DVector::<f64>::zeros(m);
        for (i, r) in rows.iter().enumerate() {
            for p in 0..m {
                atb[p] += weights[i] * r[p] * drift[i];
                for q in 0..m {
                    ata[(p, q)] += weights[i] * r[p] * r[q];
                }
            }
        }
        coef = ata.lu().solve(&atb)?.iter().copied().collect();
        let residual: Vec<f64> = rows
            .iter()
            .zip(drift)
            .map(|(r, d)| d - r.iter().zip(&coef).map(|(x, c)| x * c).sum::<f64>())
            .collect();
        let mut abs: Vec<f64> = residual.iter().map(|r| r.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let scale = 1.5 * abs[n / 2] + 1e-9;
        weights = residual
            .iter()
            .map(|r| 1.0 / (r.abs() / scale).max(1.0))
            .collect();
    }
    Some(coef)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shortest-rulings path by the whole cost table, indexed modulo n: [`fan_path`]
    /// as first written (but for the shared way back), to check the rolling rows against.
    fn fan_path_full_table(sa: &[Point], sb: &[Point]) -> (Vec<(usize, usize)>, f64) {
        let n = sa.len();
        let w = n + 1;
        let d = |i: usize, j: usize| d2(sa[i % n], sb[j % n]).sqrt();
        let mut cost = vec![f64::INFINITY; w * w];
        let mut step = vec![0u8; w * w];
        cost[0] = 0.0;
        for i in 0..w {
            for j in 0..w {
                if i == 0 && j == 0 {
                    continue;
                }
                let mut best = (f64::INFINITY, 0u8);
                if i > 0 && j > 0 {
                    best = (cost[(i - 1) * w + j - 1], 0);
                }
                if i > 0 && cost[(i - 1) * w + j] < best.0 {
                    best = (cost[(i - 1) * w + j], 1);
                }
                if j > 0 && cost[i * w + j - 1] < best.0 {
                    best = (cost[i * w + j - 1], 2);
                }
                cost[i * w + j] = best.0 + d(i, j);
                step[i * w + j] = best.1;
            }
        }
        (path_back(&step, n), cost[w * w - 1])
    }

    #[test]
    fn fan_path_matches_the_full_table_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for n in [3, 4, 17, 64] {
            for _ in 0..20 {
                let mut blob = |n: usize| -> Vec<Point> {
                    (0..n)
                        .map(|k| {
                            let th = k as f64 * std::f64::consts::TAU / n as f64;
                            let r = rng.random_range(2.0..10.0);
                            [r * th.cos(), r * th.sin()]
                        })
                        .collect()
                };
                let (sa, sb) = (blob(n), blob(n));
                let (path, length) = fan_path(&sa, &sb);
                let (want, want_length) = fan_path_full_table(&sa, &sb);
                assert_eq!(path, want, "n = {n}");
                assert_eq!(length.to_bits(), want_length.to_bits(), "n = {n}");
            }
        }
        // Ties (equal distances everywhere) go the same way too.
        let square: Vec<Point> = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert_eq!(
            fan_path(&square, &square),
            fan_path_full_table(&square, &square)
        );
    }

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

    /// Ripples just before the slot on one loop and just after it on the other: the drift
    /// rises and falls back within 1.2 rad, too sharp for the harmonics to follow within
    /// [`WARP_MAX_SPEED`]; the matching follows it.
    #[test]
    fn a_matching_takes_out_drift_too_sharp_for_the_harmonics() {
        let (a, b) = (rippled(3.2..3.6), rippled(2.5..3.1));
        assert_eq!(blend_crossings(&a, &b, None), 4);
        let (sa, sb) = (
            Loop::new(&a, 0).samples(WARP_SAMPLES),
            Loop::new(&b, 0).samples(WARP_SAMPLES),
        );
        assert!(harmonic_warp(&sa, &sb).is_none());
        let warps = chord_warps(&[Some(a.clone()), Some(b.clone())]);
        let table = warps[1].as_ref().expect("a matched warp");
        assert_eq!((table[0], table[WARP_TABLE]), (0.0, 1.0));
        // Increasing, and within the speed bound (of a table 1024 long from one 512 long,
        // linear between, so the bound holds for its steps too).
        let unit = 1.0 / WARP_TABLE as f64;
        assert!(table.windows(2).all(|w| {
            let v = (w[1] - w[0]) / unit;
            (1.0 / WARP_MAX_SPEED - 1e-9..=WARP_MAX_SPEED + 1e-9).contains(&v)
        }));
        assert_eq!(blend_crossings(&a, &b, Some(table)), 0);
    }

    /// A disc of radius 30 with a slot 2 mm wide and 15 mm deep opposite its start; with
    /// `wiggle`, the arc from 3.5 to 4.3 rad (just past the slot) carries ripples (amplitude
    /// 1.5 mm, 24 of them), which add length there and nowhere else: the slot then lies at a
    /// smaller fraction of the loop.
    fn slotted(wiggle: bool) -> Vec<Point> {
        rippled(if wiggle { 3.5..4.3 } else { 0.0..0.0 })
    }

    /// [`slotted`] with its ripples (96 per turn) on the arc `arc` (radians).
    fn rippled(arc: std::ops::Range<f64>) -> Vec<Point> {
        let n = 4000;
        let tau = std::f64::consts::TAU;
        let mut out = Vec::new();
        for k in 0..n {
            let a = tau * k as f64 / n as f64;
            let off = (a - std::f64::consts::PI).abs();
            let r = if off < 1.0 / 30.0 { 15.0 } else { 30.0 };
            let ripple = if arc.contains(&a) {
                1.5 * (96.0 * a).sin().abs()
            } else {
                0.0
            };
            out.push([(r + ripple) * a.cos(), (r + ripple) * a.sin()]);
        }
        out
    }

    fn blend_crossings(a: &[Point], b: &[Point], table: Option<&[f64]>) -> usize {
        let n = WARP_SAMPLES;
        let (sa, lb) = (Loop::new(a, 0).samples(n), Loop::new(b, 0));
        let at = |s: f64| -> f64 {
            table.map_or(s, |t| {
                let x = s * (t.len() - 1) as f64;
                let j = (x.floor() as usize).min(t.len() - 2);
                t[j] + (x - j as f64) * (t[j + 1] - t[j])
            })
        };
        WARP_BLENDS
            .iter()
            .map(|&t| {
                let blend: Vec<Point> = (0..n)
                    .map(|i| {
                        let (p, q) = (
                            sa[i],
                            lb.at_fractions(std::iter::once(at(i as f64 / n as f64)))[0],
                        );
                        [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]
                    })
                    .collect();
                proper_crossings(&blend, usize::MAX)
            })
            .sum()
    }

    #[test]
    fn a_warp_takes_out_the_drift_that_folds_a_slot() {
        let (a, b) = (slotted(false), slotted(true));
        // Chord length joins the slot's walls across it: the ripples' extra length shifts
        // the fractions by more than the slot is wide.
        assert!(blend_crossings(&a, &b, None) > 0);
        let warps = chord_warps(&[Some(a.clone()), Some(b.clone())]);
        let table = warps[1].as_ref().expect("a warp for the rippled loop");
        assert!(warps[0]
            .as_ref()
            .is_some_and(|t| t
                .iter()
                .enumerate()
                .all(|(j, &f)| (f - j as f64 / WARP_TABLE as f64).abs() < 1e-15)));
        assert_eq!(table.len(), WARP_TABLE + 1);
        assert_eq!((table[0], table[WARP_TABLE]), (0.0, 1.0));
        assert!(table.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(blend_crossings(&a, &b, Some(table)), 0);
    }

    #[test]
    fn loops_that_join_cleanly_keep_chord_length() {
        let a = slotted(false);
        let b: Vec<Point> = a.iter().map(|p| [1.02 * p[0], 1.02 * p[1]]).collect();
        assert_eq!(chord_warps(&[Some(a.clone()), Some(b)]), vec![None, None]);
        // A cap point and a loop: nothing to match.
        assert_eq!(chord_warps(&[None, Some(a)]), vec![None, None]);
    }

    #[test]
    fn a_cap_point_first_gives_one_candidate() {
        let cap = [[0.0, 0.0, -0.5]];
        let a = ring(12, 3.0, 0.0, 0.3);
        let starts = baseline(&[&cap, &a]);
        assert_eq!(starts.len(), 2);
        assert_eq!(starts[0], 0);
    }

    /// A random lattice path from (0, 0) to (n, n) with the steps (1, 1), (1, 0), (0, 1), as
    /// fractions: `moves` picks each step (0 both, 1 first, 2 second) while both can move.
    fn lattice(n: usize, moves: &[u8]) -> Vec<(f64, f64)> {
        let (mut i, mut j) = (0, 0);
        let mut out = vec![(0.0, 0.0)];
        for &m in moves.iter().cycle() {
            if i == n && j == n {
                break;
            }
            match m {
                _ if i == n => j += 1,
                _ if j == n => i += 1,
                0 => (i, j) = (i + 1, j + 1),
                1 => i += 1,
                _ => j += 1,
            }
            out.push((i as f64 / n as f64, j as f64 / n as f64));
        }
        out
    }

    proptest::proptest! {
        /// Three loops' joins merged: every coordinate rises from 0 to 1, each join's
        /// vertices all lie on the merged path's projection onto its two loops, in order,
        /// and every merged vertex projects onto each join's path.
        #[test]
        fn merged_joins_keep_every_join(
            n1 in 1usize..12,
            n2 in 1usize..12,
            m1 in proptest::collection::vec(0u8..3, 1..30),
            m2 in proptest::collection::vec(0u8..3, 1..30),
        ) {
            // Different lattices, so that one join's vertices fall inside the other's steps.
            let (j1, j2) = (lattice(n1, &m1), lattice(n2, &m2));
            let merged = merge_join(&merge_join(&[vec![0.0], vec![1.0]], &j1), &j2);
            proptest::prop_assert_eq!(&merged[0], &vec![0.0, 0.0, 0.0]);
            proptest::prop_assert_eq!(&merged[merged.len() - 1], &vec![1.0, 1.0, 1.0]);
            for w in merged.windows(2) {
                proptest::prop_assert!(w[0].iter().zip(&w[1]).all(|(x, y)| y >= x), "{:?}", w);
            }
            for (join, (x, y)) in [(&j1, (0, 1)), (&j2, (1, 2))] {
                let mut k = 0;
                for &(f, g) in join.iter() {
                    while k < merged.len() && (merged[k][x], merged[k][y]) != (f, g) {
                        k += 1;
                    }
                    proptest::prop_assert!(k < merged.len(), "join vertex ({}, {}) missing", f, g);
                }
                for v in &merged {
                    let (p, q) = (v[x], v[y]);
                    let on = join.windows(2).any(|s| {
                        let ((f0, g0), (f1, g1)) = (s[0], s[1]);
                        let cross = (f1 - f0) * (q - g0) - (g1 - g0) * (p - f0);
                        cross.abs() < 1e-12
                            && (f0.min(f1)..=f0.max(f1)).contains(&p)
                            && (g0.min(g1)..=g0.max(g1)).contains(&q)
                    });
                    proptest::prop_assert!(on, "merged vertex {:?} off join {:?}", v, join);
                }
            }
        }
    }
}
