//! Stage 6: closed B-spline fitting on a common knot vector (paper §2.4–2.5, Algorithm 2).
//! Every curve of a region — contours, intermediate contours, caps — is fitted on one knot
//! vector within the tolerance, at chord-length parameters or, where those would fold the
//! surface between two loops, at warped ones ([`chord_warps`]); where the surface still
//! crosses itself (or a fence: on a cap's ridge loop, or on a chain where its end loop meets a
//! sibling's: [`s7_skinning::Crossings`]), also with the loops joined by fans
//! ([`fan_tables`]), cut into segments ([`fit_segments`]), and with a curve halfway between a
//! crossing band's loops ([`with_halfway_curves`]), each kept if it crosses less. Regions are
//! fitted as they arrive, several at once, and leave in arrival order.

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};
use rayon::prelude::*;

use super::s7_skinning::{self, Crossings};
use super::{Control, StageStats};
use crate::bspline::common_knots::{fit_common_densest, CommonFit};
use crate::bspline::fit::FitOptions;
use crate::geometry::alignment::{
    chord_join_folds, chord_warps, fan_tables, RegionFans, FAN_SLACKS,
};
use crate::geometry::branching::halfway_loop;
use crate::geometry::polygon::{centroid, dist};
use crate::region::{CurveOrigin, Region, RegionCurve};
use crate::section::{dot, SliceFrame};
use crate::{Error, Result};

pub const STAGE: &str = "fitting";

/// A region and its curves on one knot vector.
#[derive(Clone, Debug)]
pub struct FittedRegion {
    pub region: Region,
    pub fit: CommonFit<3>,
}

/// Fit a region's curves on one knot vector. Loops are densified first (see [`densify`]), so
/// the tolerance holds along the contour polygons' edges, not only at their vertices. Where
/// the surface would cross itself, the loops may be joined by fans instead ([`fan_joined`]);
/// the curves then start where those joins put them.
pub fn fit(region: Region, opts: &FitOptions) -> Result<FittedRegion> {
    Ok(fit_judged(region, opts)?.0)
}

/// The crossing faces per band of a fitted region and in all
/// ([`s7_skinning::crossing_bands`]), where they were measured on the way: a judged mesh is
/// most of a small region's cost.
type Judged = Option<(Vec<usize>, Crossings)>;

/// [`fit`], and its [`Judged`] crossings.
fn fit_judged(region: Region, opts: &FitOptions) -> Result<(FittedRegion, Judged)> {
    let warps = warps(&region);
    let fitted = fit_warped(region, &warps, opts)?;
    Ok(fan_joined(fitted, opts))
}

/// Stage 6's fit of a region: [`fit`]; or, where that surface crosses itself (or a cap's
/// fence: [`s7_skinning::Crossings`]), the region cut into segments ([`Region::split_at`])
/// at both loops of each join that folds at chord length or whose band holds crossing faces
/// ([`s7_skinning::crossing_bands`]), so that each such join is a segment of its own, and
/// the segments fitted alone, if their meshes together cross less
/// ([`Crossings::fewer_than`]) and they meet the tolerance as the whole did. One surface has
/// one parameterisation for all its loops: a fan that joins a lobe one loop has and the next
/// lacks stands every loop beyond still over the lobe's stretch, and a warp that takes the
/// lobe's drift out of one join puts it into the next (GE head surface 233: 17 loops, a
/// tongue 40 mm long at its first; 1 318 faces crossing its own surface, against 197 in its
/// four segments). The segments meet where the loop's own points are, as a long chain's do.
/// Each surface kept that still crosses itself may then take halfway curves
/// ([`with_halfway_curves`]).
pub fn fit_segments(region: Region, opts: &FitOptions) -> Result<Vec<FittedRegion>> {
    Ok(segments_of(region, opts)?
        .into_iter()
        .map(|(fitted, judged)| with_halfway_curves(fitted, judged, opts))
        .collect())
}

/// [`fit_segments`] before [`with_halfway_curves`].
fn segments_of(region: Region, opts: &FitOptions) -> Result<Vec<(FittedRegion, Judged)>> {
    let n = region.curves.len();
    let (whole, judged) = fit_judged(region.clone(), opts)?;
    if n <= 2 {
        return Ok(vec![(whole, judged)]);
    }
    let Some((bands, now)) = judged.or_else(|| s7_skinning::crossing_bands(&whole, opts.tolerance))
    else {
        return Ok(vec![(whole, None)]);
    };
    let unsplit = |whole: FittedRegion, bands: Vec<usize>| vec![(whole, Some((bands, now)))];
    if now.total() == 0 {
        return Ok(unsplit(whole, bands));
    }
    let Some(loops) = plane_loops(&whole.region) else {
        return Ok(unsplit(whole, bands));
    };
    let folds: Vec<bool> = loops
        .windows(2)
        .map(|w| match (&w[0], &w[1]) {
            (Some(a), Some(b)) => chord_join_folds(a, b),
            _ => false,
        })
        .collect();
    let cut = |k: usize| folds[k] || bands[k] > 0;
    let joints: Vec<usize> = (1..n - 1).filter(|&k| cut(k - 1) || cut(k)).collect();
    if joints.is_empty() {
        return Ok(unsplit(whole, bands));
    }
    let segments: Result<Vec<(FittedRegion, Judged)>> = region
        .split_at(&joints)
        .into_par_iter()
        .map(|r| fit_judged(r, opts))
        .collect();
    let Ok((fits, judged)): Result<(Vec<FittedRegion>, Vec<Judged>)> =
        segments.map(|s| s.into_iter().unzip())
    else {
        return Ok(unsplit(whole, bands));
    };
    Ok(
        if (fits.iter().all(|s| s.fit.met) || !whole.fit.met)
            && s7_skinning::crossings_of_all(&fits, opts.tolerance).fewer_than(&now)
        {
            fits.into_iter().zip(judged).collect()
        } else {
            unsplit(whole, bands)
        },
    )
}

/// [`fit`] at the given warps, on knots spread as the densest loop's
/// ([`fit_common_densest`]: where a fan stands a loop still, the paper's average of the
/// loops' own knots leaves too few there for the loop that moves).
fn fit_warped(
    region: Region,
    warps: &[Option<Vec<f64>>],
    opts: &FitOptions,
) -> Result<FittedRegion> {
    let max_gap = EDGE_SAMPLES_PER_TOLERANCE * opts.tolerance;
    let curves: Vec<Vec<[f64; 3]>> = region
        .curves
        .iter()
        .map(|c| {
            if c.points.len() >= 3 {
                densify(&c.points, max_gap)
            } else {
                c.points.clone()
            }
        })
        .collect();
    let fit = fit_common_densest(&curves, warps, opts).map_err(|e| Error::Kernel {
        stage: STAGE,
        context: describe(&region),
        source: e,
    })?;
    Ok(FittedRegion { region, fit })
}

/// Which joins to fan though chord length does not fold them: those whose band crosses, and
/// the joins either side. The fitted curves' parameters are not their chord length, so bands
/// the fit bends cross where the samples' blends do not; and a cubic band is bent by its
/// neighbours' joins as well (at `--chordal 0.4`, fanning the neighbours too took the crossing
/// faces from 5 333 to 5 300 on the GE head; fanning every join, 5 307).
fn joins_near_crossing_bands(bands: &[usize]) -> Vec<bool> {
    (0..bands.len())
        .map(|k| {
            bands[k.saturating_sub(1)..(k + 2).min(bands.len())]
                .iter()
                .any(|&b| b > 0)
        })
        .collect()
}

/// A region refitted with its loops joined by [`fan_tables`] where its surface crosses
/// itself or the fence on a cap's ridge loop, and the refit, within the tolerance, crosses
/// less ([`Crossings::fewer_than`]; both meshed as stage 5 judges a lobe's walk:
/// [`s7_skinning::crossings_of`]). The joins fanned are those
/// chord length folds and those whose band of the surface, or a band next to it, holds
/// crossing faces ([`s7_skinning::crossing_bands`]). Where one loop has a lobe the
/// next lacks, no join at bounded speed keeps their rulings apart, and the bands between a
/// contour and an intermediate contour or keyhole loop are where that happens most (GE head:
/// 8 518 of the 13 821 faces crossing their own surface were in two-loop bands). Each of
/// [`FAN_SLACKS`] is tried: which starts a fan may take is judged by the surface too; and the
/// loops matched as if moved to one centroid, kept only where that leaves the region no fold
/// (it ignores where the loops lie, so it can sweep a band across a neighbour's:
/// kept wherever it crossed less, the GE head's crossing faces rose 5 537 → 6 384).
fn fan_joined(fitted: FittedRegion, opts: &FitOptions) -> (FittedRegion, Judged) {
    match s7_skinning::crossing_bands(&fitted, opts.tolerance) {
        Some((bands, now)) => fan_joined_from(fitted, bands, now, opts),
        None => (fitted, None),
    }
}

/// [`fan_joined`] of a fit whose crossing bands are known.
fn fan_joined_from(
    fitted: FittedRegion,
    bands: Vec<usize>,
    now: Crossings,
    opts: &FitOptions,
) -> (FittedRegion, Judged) {
    if now.total() == 0 {
        return (fitted, Some((bands, now)));
    }
    let Some(loops) = plane_loops(&fitted.region) else {
        return (fitted, Some((bands, now)));
    };
    let also = joins_near_crossing_bands(&bands);
    // Also matched with every loop moved to one centroid: where a loop has drifted across
    // the plane from the one below, the shortest rulings run all one way round and crowd.
    let centred: Vec<Option<Vec<[f64; 2]>>> = loops
        .iter()
        .map(|l| {
            l.as_ref().map(|l| {
                let c = centroid(l);
                l.iter().map(|p| [p[0] - c[0], p[1] - c[1]]).collect()
            })
        })
        .collect();
    // The slacks' refits are independent and run in parallel (a large region's can be all
    // the work left in flight); the first that crosses least is kept.
    let mut plain: Vec<RegionFans> = Vec::new();
    for &slack in &FAN_SLACKS {
        // A slack that changes no join's start gives the same fit.
        if let Some(fans) = fan_tables(&loops, slack, &also) {
            if plain.last() != Some(&fans) {
                plain.push(fans);
            }
        }
    }
    let refit = |fans: &RegionFans| -> Option<(Crossings, FittedRegion)> {
        let mut region = fitted.region.clone();
        for (c, &s) in region.curves.iter_mut().zip(&fans.starts) {
            c.points.rotate_left(s);
        }
        let fanned = fit_warped(region, &fans.tables, opts).ok()?;
        fanned
            .fit
            .met
            .then(|| (s7_skinning::crossings_of(&fanned, opts.tolerance), fanned))
    };
    let mut best: Option<(Crossings, FittedRegion)> = None;
    let refits: Vec<Option<(Crossings, FittedRegion)>> = plain.par_iter().map(refit).collect();
    for (crossing, fanned) in refits.into_iter().flatten() {
        if crossing.fewer_than(best.as_ref().map_or(&now, |b| &b.0)) {
            best = Some((crossing, fanned));
        }
    }
    // The centred match is kept only where it folds nothing (see the doc), and blends that
    // cross at the samples leave little hope of that: spare the refit (most of its cost).
    if best.as_ref().is_some_and(|b| b.0.total() == 0) {
        return kept(best, fitted, (bands, now));
    }
    let centred = fan_tables(&centred, f64::INFINITY, &also)
        .filter(|fans| fans.blends == 0 && plain.last() != Some(fans));
    if let Some((clean, fanned)) = centred.as_ref().and_then(refit) {
        if clean.own == 0 && clean.fewer_than(best.as_ref().map_or(&now, |b| &b.0)) {
            best = Some((clean, fanned));
        }
    }
    kept(best, fitted, (bands, now))
}

/// The fanned refit that crossed least, if any crossed less, else `fitted` with its crossings.
fn kept(
    best: Option<(Crossings, FittedRegion)>,
    fitted: FittedRegion,
    judged: (Vec<usize>, Crossings),
) -> (FittedRegion, Judged) {
    match best {
        Some((_, fanned)) => (fanned, None),
        None => (fitted, Some(judged)),
    }
}

/// Distance-map cell of a halfway curve, in fitting tolerances (0.25 mm at the default). The
/// curve holds no input point, so it need not be finer: at the branching cell (0.1 mm) the
/// distance maps took most of the trials' time (GE head wall time 27 → 42 s, against 30 s
/// here), for no fewer crossings (1 769 faces against 1 783 on the GE head, 259 against 219
/// on the abdomen, our count at `--chordal 0.4`).
const HALFWAY_CELL_TOLERANCES: f64 = 0.5;

/// Halfway curves whose surface crosses more than this many times as many faces as the
/// region's before fans are not fanned: the fans took one such surface below the region's
/// count (abdomen: 232 against 135, fanned 101), none beyond (GE head: 6 441 against 455,
/// fanned 5 994; 2 597 against 18, 1 105), and their refits were most of the trials' time.
const HALFWAY_HOPELESS: usize = 2;

/// The region refitted ([`fit`]) with a curve halfway between the two loops of every band
/// that holds crossing faces ([`s7_skinning::crossing_bands`]): the paper's intermediate
/// contour of the two as a 1-to-1 link ([`halfway_loop`]), on the mid-plane; kept if its
/// surface crosses less ([`Crossings::fewer_than`]) and meets the tolerance as the region
/// did. Where one loop has a lobe or a fjord the other lacks, no join of the two keeps the
/// rulings apart, but the distance maps' blend grows the lobe out of the other loop by
/// half: each band then joins shapes half as far apart. A hole of the blend is filled, so
/// a ring keyholed on one side below a C open on the other shuts its slot halfway rather
/// than sweep the slit round to the mouth (abdomen surface 102, at `--chordal 0.4`: 153 →
/// 37 faces crossing it). The region's end loops stay as they are, so its neighbours still
/// meet it there.
fn with_halfway_curves(fitted: FittedRegion, judged: Judged, opts: &FitOptions) -> FittedRegion {
    let Some((bands, now)) =
        judged.or_else(|| s7_skinning::crossing_bands(&fitted, opts.tolerance))
    else {
        return fitted;
    };
    if now.total() == 0 {
        return fitted;
    }
    let Some(frame) = fitted.region.plane_frame() else {
        return fitted;
    };
    let loops = loops_in(&fitted.region, &frame);
    let normal = frame.normal();
    let cell = HALFWAY_CELL_TOLERANCES * opts.tolerance;
    let curves = &fitted.region.curves;
    let mut region = fitted.region.clone();
    region.curves.clear();
    for (k, lower) in curves.iter().enumerate() {
        region.curves.push(lower.clone());
        let Some(upper) = curves.get(k + 1) else {
            break;
        };
        let (Some(a), Some(b)) = (&loops[k], &loops[k + 1]) else {
            continue;
        };
        if bands[k] == 0 {
            continue;
        }
        let Some(mid) = halfway_loop(a, b, cell) else {
            continue;
        };
        let rise =
            0.5 * (dot(lower.points[0], normal) + dot(upper.points[0], normal)) - frame.height();
        let mut points: Vec<[f64; 3]> = mid
            .iter()
            .map(|&p| {
                let q = frame.to_patient(p);
                std::array::from_fn(|d| q[d] + rise * normal[d])
            })
            .collect();
        // The ruling from the lower loop's start to the upper's is the surface's seam: the
        // halfway curve starts where it crosses the mid-plane.
        let seam = [0.5 * (a[0][0] + b[0][0]), 0.5 * (a[0][1] + b[0][1])];
        let start = (0..mid.len())
            .min_by(|&i, &j| dist(mid[i], seam).total_cmp(&dist(mid[j], seam)))
            .unwrap_or(0);
        points.rotate_left(start);
        region.curves.push(RegionCurve {
            points,
            origin: CurveOrigin::Intermediate {
                below: lower.origin.slices().0,
                above: upper.origin.slices().1,
            },
        });
    }
    if region.curves.len() == curves.len() {
        return fitted;
    }
    // As `fit`, but the fans' refits (most of its cost) are spared where the halfway curves
    // alone cross far more than the region did.
    let warps = warps(&region);
    let Ok(warped) = fit_warped(region, &warps, opts) else {
        return fitted;
    };
    let Some((bands, plain)) = s7_skinning::crossing_bands(&warped, opts.tolerance) else {
        return fitted;
    };
    if plain.total() > HALFWAY_HOPELESS * now.total() {
        return fitted;
    }
    let (halfway, judged) = fan_joined_from(warped, bands, plain, opts);
    let crossings = judged.map_or_else(
        || s7_skinning::crossings_of(&halfway, opts.tolerance),
        |(_, c)| c,
    );
    if (halfway.fit.met || !fitted.fit.met) && crossings.fewer_than(&now) {
        halfway
    } else {
        fitted
    }
}

/// Where the region's loops are parameterised off chord length so that consecutive loops
/// join where they correspond ([`chord_warps`]), seen in the plane of its first loop (all
/// its curves lie in parallel planes).
fn warps(region: &Region) -> Vec<Option<Vec<f64>>> {
    match plane_loops(region) {
        Some(loops) => chord_warps(&loops),
        None => Vec::new(),
    }
}

/// The region's loops in the plane of its first loop (all its curves lie in parallel
/// planes), `None` for a cap point; `None` if no curve is a loop.
fn plane_loops(region: &Region) -> Option<Vec<Option<Vec<[f64; 2]>>>> {
    Some(loops_in(region, &region.plane_frame()?))
}

/// The region's loops in `frame`'s plane, `None` for a cap point.
fn loops_in(region: &Region, frame: &SliceFrame) -> Vec<Option<Vec<[f64; 2]>>> {
    region
        .curves
        .iter()
        .map(|c| {
            (c.points.len() >= 3).then(|| c.points.iter().map(|&p| frame.to_plane(p)).collect())
        })
        .collect()
}

/// Longest gap between fitted points, in tolerances. Compression leaves long straight edges
/// with few vertices, and a spline checked only at those vertices can bulge between them
/// (seen on the standing-torus phantom: 1.1 mm off a flat side at a 0.5 mm tolerance).
const EDGE_SAMPLES_PER_TOLERANCE: f64 = 2.0;

/// The closed loop with points inserted evenly along every edge longer than `max_gap`.
pub fn densify(points: &[[f64; 3]], max_gap: f64) -> Vec<[f64; 3]> {
    let n = points.len();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        out.push(a);
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        let pieces = (len / max_gap).ceil();
        if pieces.is_finite() && pieces > 1.0 {
            let k = pieces as usize;
            for s in 1..k {
                let t = s as f64 / k as f64;
                out.push(std::array::from_fn(|d| a[d] + t * (b[d] - a[d])));
            }
        }
    }
    out
}

/// "region 7 (outer wall, slices 12–40)": for error messages.
pub fn describe(region: &Region) -> String {
    let slices: Vec<usize> = region.curves.iter().map(|c| c.origin.slices().0).collect();
    let (lo, hi) = (
        slices.iter().min().copied().unwrap_or(0),
        slices.iter().max().copied().unwrap_or(0),
    );
    let wall = if region.hole {
        "hole wall"
    } else {
        "outer wall"
    };
    format!(
        "region {} ({wall}, slices {lo}–{hi}, {} curves)",
        region.id,
        region.curves.len()
    )
}

/// Fit regions as they arrive, up to `window` at once on the rayon pool, and pass them on
/// in arrival order. Regions differ in cost by orders of magnitude (a two-loop cap against a
/// 17-loop chain tried with fans and segments), so fitting them a batch at a time left cores
/// idle behind each batch's largest; here a core takes the next region as soon as it is free.
/// `busy` is the time with at least one region in flight.
pub fn run(
    input: Receiver<Region>,
    opts: &FitOptions,
    window: usize,
    out: Sender<FittedRegion>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    let window = window.max(1);
    let (done_tx, done_rx) = crossbeam_channel::unbounded::<(usize, Result<Vec<FittedRegion>>)>();
    let mut finished: BTreeMap<usize, Result<Vec<FittedRegion>>> = BTreeMap::new();
    let (mut started, mut emitted, mut next_id) = (0usize, 0usize, 0usize);
    let mut input = Some(input);
    let mut since: Option<Instant> = None;
    loop {
        ctl.check()?;
        let in_flight = started - emitted;
        let taking = input.as_ref().filter(|_| in_flight < window);
        if taking.is_none() && in_flight == 0 {
            break;
        }
        let never = crossbeam_channel::never();
        crossbeam_channel::select! {
            recv(taking.unwrap_or(&never)) -> region => match region {
                Ok(region) => {
                    since.get_or_insert_with(Instant::now);
                    let (seq, opts, done) = (started, *opts, done_tx.clone());
                    rayon::spawn_fifo(move || {
                        let fitted = catch_unwind(AssertUnwindSafe(|| fit_segments(region, &opts)))
                            .unwrap_or_else(|_| {
                                Err(Error::Internal("fitting a region panicked".into()))
                            });
                        // A receiver gone means the stage stopped on an error: nothing to do.
                        let _ = done.send((seq, fitted));
                    });
                    started += 1;
                }
                Err(_) => input = None,
            },
            recv(done_rx) -> done => {
                let (seq, fitted) = done.map_err(|_| Error::Internal("fitting workers gone".into()))?;
                finished.insert(seq, fitted);
                // Ids in emission order, as stage 4 numbers regions: a region cut into
                // segments moves the ids after it on.
                while let Some(fitted) = finished.remove(&emitted) {
                    emitted += 1;
                    for mut f in fitted? {
                        f.region.id = next_id;
                        next_id += 1;
                        stats.items += 1;
                        if out.send(f).is_err() {
                            return Ok(stats);
                        }
                    }
                }
                if started == emitted {
                    if let Some(t) = since.take() {
                        stats.busy += t.elapsed();
                    }
                }
            },
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::region::{CurveOrigin, RegionCurve};

    /// Two circles of `radius` 2 mm apart, of `n` points each.
    fn tube(radius: f64, n: usize) -> Region {
        let curves = (0..2)
            .map(|k| RegionCurve {
                points: (0..n)
                    .map(|i| {
                        let a = std::f64::consts::TAU * i as f64 / n as f64;
                        [radius * a.cos(), radius * a.sin(), 2.0 * k as f64]
                    })
                    .collect(),
                origin: CurveOrigin::Contour {
                    slice: k,
                    contour: 0,
                },
            })
            .collect();
        Region {
            id: 99,
            hole: false,
            curves,
            seal: Vec::new(),
            seal_points: Vec::new(),
            shared_edges: Vec::new(),
            joint_below: false,
            inserted: [0, 0],
        }
    }

    /// Stage 6 run over `regions` with `window` in flight: what it sent, and its result.
    fn run_over(regions: Vec<Region>, window: usize) -> (Vec<FittedRegion>, Result<StageStats>) {
        let (tx, rx) = crossbeam_channel::bounded(2);
        let (out_tx, out_rx) = crossbeam_channel::unbounded();
        // A stage that stopped early leaves the feeder's sends failing: that is not an error.
        let feeder = std::thread::spawn(move || {
            regions
                .into_iter()
                .try_for_each(|r| tx.send(r).map_err(|_| ()))
        });
        let result = run(rx, &FitOptions::new(0.5), window, out_tx, &Control::new());
        let _ = feeder.join();
        (out_rx.try_iter().collect(), result)
    }

    #[test]
    fn regions_leave_in_arrival_order_numbered_however_long_each_takes() {
        // Large and small regions interleaved, so later ones finish first.
        let radii: Vec<f64> = (0..12)
            .map(|k| if k % 3 == 0 { 60.0 } else { 5.0 + k as f64 })
            .collect();
        let regions = radii
            .iter()
            .map(|&r| tube(r, if r > 50.0 { 2000 } else { 24 }))
            .collect();
        let (fitted, result) = run_over(regions, 3);
        assert_eq!(result.unwrap().items, 12);
        assert_eq!(fitted.len(), 12);
        for (k, (f, &r)) in fitted.iter().zip(&radii).enumerate() {
            assert_eq!(f.region.id, k);
            let p = f.region.curves[0].points[0];
            assert!(
                (p[0].hypot(p[1]) - r).abs() < 1e-9,
                "region {k} is not the {k}th sent"
            );
        }
    }

    #[test]
    fn a_region_that_fails_stops_the_stage_after_those_before_it() {
        let mut bad = tube(8.0, 24);
        bad.curves[1].points[5] = [f64::NAN, 0.0, 2.0];
        let regions = vec![tube(10.0, 24), tube(12.0, 24), bad, tube(14.0, 24)];
        let (fitted, result) = run_over(regions, 4);
        let err = result.unwrap_err().to_string();
        assert!(err.contains("region 99"), "{err}");
        assert_eq!(fitted.len(), 2);
    }

    /// A disc of `radius` round the origin at height `z`, counter-clockwise from angle `from`
    /// to `to` (radians), then `inner` points back (a slot's walls, a slit), closed.
    fn arc_then(radius: f64, from: f64, to: f64, inner: &[[f64; 2]], z: f64) -> Vec<[f64; 3]> {
        (0..=96)
            .map(|i| {
                let a = from + (to - from) * i as f64 / 96.0;
                [radius * a.cos(), radius * a.sin()]
            })
            .chain(inner.iter().copied())
            .map(|p| [p[0], p[1], z])
            .collect()
    }

    /// A ring keyholed on the left (slit along y = 0 from the rim to its slot) below a C
    /// whose slot, 1.25 mm higher, opens on the right: no join of the two loops takes the
    /// slit's junction across to the mouth without the rulings crossing (abdomen surface 102).
    /// Halfway, the slot is shut: the ring's hole closes into the slit below it, and the C's
    /// slot opens from a notch on the right above it.
    #[test]
    fn a_ring_below_a_c_opening_at_its_far_end_gets_a_halfway_curve_and_no_crossing() {
        use std::f64::consts::{PI, TAU};
        let opts = FitOptions::new(0.5);
        let (r, h, shift) = (6.0f64, 0.5, 1.25);
        let (x0, x1) = (-3.0, 5.0);
        let lower = arc_then(
            r,
            -PI,
            PI,
            &[[x0, 0.0], [x0, h], [x1, h], [x1, -h], [x0, -h], [x0, 0.0]],
            0.0,
        );
        let rim = |y: f64| (r * r - y * y).sqrt();
        let (top, bottom) = (shift + h, shift - h);
        let upper = arc_then(
            r,
            (top / r).asin(),
            TAU + (bottom / r).asin(),
            &[
                [rim(bottom), bottom],
                [x0, bottom],
                [x0, top],
                [rim(top), top],
            ],
            2.0,
        );
        let mut region = tube(10.0, 3);
        region.curves[0].points = lower;
        region.curves[1].points = upper;
        crate::stages::s5_alignment::align(&mut region, &opts);
        let ends: Vec<Vec<[f64; 3]>> = region.curves.iter().map(|c| sorted(&c.points)).collect();
        let plain: Vec<FittedRegion> = segments_of(region.clone(), &opts)
            .unwrap()
            .into_iter()
            .map(|s| s.0)
            .collect();
        let before = s7_skinning::crossings_of_all(&plain, opts.tolerance);
        assert!(
            before.own > 50,
            "the two loops alone should cross: {before:?}"
        );
        let fitted = fit_segments(region, &opts).unwrap();
        assert_eq!(fitted.len(), 1);
        let fitted = &fitted[0];
        let after = s7_skinning::crossings_of(fitted, opts.tolerance);
        assert_eq!(after.total(), 0, "{before:?} → {after:?}");
        assert!(fitted.fit.met);
        let curves = &fitted.region.curves;
        assert_eq!(curves.len(), 3);
        // The ends are the region's own loops, so its neighbours still meet it there.
        assert_eq!(sorted(&curves[0].points), ends[0]);
        assert_eq!(sorted(&curves[2].points), ends[1]);
        assert!(matches!(
            curves[1].origin,
            CurveOrigin::Intermediate { below: 0, above: 1 }
        ));
        assert!(curves[1].points.iter().all(|p| (p[2] - 1.0).abs() < 1e-9));
    }

    fn sorted(points: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut v = points.to_vec();
        v.sort_by(|a, b| a.partial_cmp(b).expect("finite"));
        v
    }

    #[test]
    fn a_crossing_band_fans_its_own_join_and_both_neighbours() {
        assert_eq!(
            joins_near_crossing_bands(&[0, 0, 0, 3, 0, 0]),
            [false, false, true, true, true, false]
        );
        assert_eq!(joins_near_crossing_bands(&[2, 0, 0]), [true, true, false]);
        assert_eq!(joins_near_crossing_bands(&[0, 0, 1]), [false, true, true]);
        assert_eq!(joins_near_crossing_bands(&[0, 0]), [false, false]);
        assert_eq!(joins_near_crossing_bands(&[]), Vec::<bool>::new());
    }
}
