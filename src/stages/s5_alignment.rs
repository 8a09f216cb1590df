//! Stage 5: contour alignment (METHOD.md §4, and beyond the paper: see
//! [`crate::geometry::alignment`]). Each region's loops are rotated to start where they
//! correspond; orientation is unchanged. Beyond the paper, the loop at either end of a
//! region (an intermediate contour, keyhole or contour; not a cap) first grows a spur into
//! each thin arm that the next curve has and it lacks ([`crate::geometry::spur`]), so that
//! the arm's walls have somewhere to rise from, and a walk round the medial tree of each
//! wider lobe ([`crate::geometry::lobe`]) where that makes the surface to the next curve fold
//! less: judged on the surface stages 6 and 7 would make, meshed ([`trial_crossings`]).

use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};

use super::s7_skinning::{crossings_of, Crossings};
use super::{s6_fitting, Control, StageStats};
use crate::bspline::fit::FitOptions;
use crate::geometry::alignment::align_starts;
use crate::geometry::spur::{arm_spurs, with_spurs, Spur};
use crate::region::{CurveOrigin, Region};
use crate::section::{dot, SliceFrame};
use crate::Result;

pub const STAGE: &str = "alignment";

/// `opts`: the options stage 6 fits with; starts are placed to a quarter of the tolerance
/// along the loops.
pub fn align(region: &mut Region, opts: &FitOptions) {
    add_arm_spurs(region, opts);
    rotate_to_starts(region, opts.tolerance);
}

fn rotate_to_starts(region: &mut Region, tolerance: f64) {
    let curves: Vec<&[[f64; 3]]> = region.curves.iter().map(|c| c.points.as_slice()).collect();
    let starts = align_starts(&curves, 0.25 * tolerance);
    for (curve, s) in region.curves.iter_mut().zip(starts) {
        curve.points.rotate_left(s);
    }
}

/// The [`Crossings`] of the mesh of the surface stages 6 and 7 would make of `region` with
/// `points` in place of curve `end`, aligned as stage 5 leaves it; [`Crossings::UNFIT`] if it
/// cannot be fitted. A walk's linear blends with the neighbour cross
/// themselves less often than the fitted surface does and can say better where the surface
/// is worse (GE head surface 87: 53 → 46 crossing blends, 2 485 → 3 709 crossing faces), so
/// the mesh itself is asked.
pub fn trial_crossings(
    region: &Region,
    end: usize,
    points: Vec<[f64; 3]>,
    opts: &FitOptions,
) -> Crossings {
    let mut trial = region.clone();
    trial.curves[end].points = points;
    rotate_to_starts(&mut trial, opts.tolerance);
    match s6_fitting::fit(trial, opts) {
        Ok(fitted) => crossings_of(&fitted, opts.tolerance),
        Err(_) => Crossings::UNFIT,
    }
}

/// An arm's points are farther than this many times the distance between the planes (or
/// [`ARM_TOLERANCES`] tolerances, if more) outside the end curve: walls that slope less
/// than 1 in 4 between the end curve and its neighbour.
const ARM_REACH_PLANES: f64 = 4.0;
const ARM_TOLERANCES: f64 = 2.0;

/// Spurs into the arms beside `region`'s end loops (caps excepted; see the module doc);
/// returns how many.
pub fn add_arm_spurs(region: &mut Region, opts: &FitOptions) -> usize {
    let tolerance = opts.tolerance;
    let n = region.curves.len();
    if n < 2 {
        return 0;
    }
    let mut count = 0;
    for (end, beside) in [(0, 1), (n - 1, n - 2)] {
        let (lp, next) = (&region.curves[end], &region.curves[beside]);
        if matches!(lp.origin, CurveOrigin::Cap { .. }) || lp.is_point() || next.is_point() {
            continue;
        }
        let Some(frame) = SliceFrame::of_loop(&lp.points) else {
            continue;
        };
        let gap = (dot(next.points[0], frame.normal()) - frame.height()).abs();
        let reach = (ARM_REACH_PLANES * gap).max(ARM_TOLERANCES * tolerance);
        let flat = |c: &[[f64; 3]]| c.iter().map(|&p| frame.to_plane(p)).collect::<Vec<_>>();
        let (a, b) = (flat(&lp.points), flat(&next.points));
        let (mut spurs, lobes): (Vec<Spur>, Vec<Spur>) =
            arm_spurs(&a, &b, reach, reach / 4.0, tolerance / 16.0)
                .into_iter()
                .partition(|s| !s.lobe);
        // A lobe's walk stays only where the surface to the neighbour then folds less: a
        // short, wide lobe fans out across its root without folding, and a walk there
        // only moves the join.
        let folds_with = |spurs: &[Spur]| {
            let points = with_spurs(&lp.points, spurs, |p| frame.to_patient(p));
            trial_crossings(region, end, points, opts)
        };
        let mut folds = None;
        for lobe in lobes {
            if folds.is_some_and(|f: Crossings| f.total() == 0) {
                break;
            }
            let mut trial = spurs.clone();
            let at = trial.partition_point(|s| s.from < lobe.from);
            trial.insert(at, lobe);
            // Each judgement fits and meshes the region: the first two run side by side.
            let (now, trial_folds) = match folds {
                Some(now) => (now, folds_with(&trial)),
                None => rayon::join(|| folds_with(&spurs), || folds_with(&trial)),
            };
            folds = Some(now);
            if trial_folds.fewer_than(&now) {
                (spurs, folds) = (trial, Some(trial_folds));
            }
        }
        // The loop's own vertices keep their coordinates bit for bit (the regions across the
        // plane share them); only the spurs' points are new.
        let points = with_spurs(&lp.points, &spurs, |p| frame.to_patient(p));
        if matches!(lp.origin, CurveOrigin::Contour { .. }) {
            region.inserted[usize::from(end != 0)] += points.len() - lp.points.len();
        }
        region.curves[end].points = points;
        count += spurs.len();
    }
    count
}

pub fn run(
    input: Receiver<Region>,
    out: Sender<Region>,
    opts: &FitOptions,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    for mut region in input.iter() {
        ctl.check()?;
        let t = Instant::now();
        align(&mut region, opts);
        stats.busy += t.elapsed();
        stats.items += 1;
        if out.send(region).is_err() {
            break;
        }
    }
    Ok(stats)
}
