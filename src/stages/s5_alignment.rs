//! Stage 5: contour alignment (METHOD.md §4, and beyond the paper: see
//! [`crate::geometry::alignment`]). Each region's loops are rotated to start where they
//! correspond; shapes and orientation are unchanged.

use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};

use super::{Control, StageStats};
use crate::geometry::alignment::align_starts;
use crate::region::Region;
use crate::Result;

pub const STAGE: &str = "alignment";

/// `tolerance`: the fitting tolerance (mm); starts are placed to a quarter of it along the
/// loops.
pub fn align(region: &mut Region, tolerance: f64) {
    let curves: Vec<&[[f64; 3]]> = region.curves.iter().map(|c| c.points.as_slice()).collect();
    let starts = align_starts(&curves, 0.25 * tolerance);
    for (curve, s) in region.curves.iter_mut().zip(starts) {
        curve.points.rotate_left(s);
    }
}

pub fn run(
    input: Receiver<Region>,
    out: Sender<Region>,
    tolerance: f64,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    for mut region in input.iter() {
        ctl.check()?;
        let t = Instant::now();
        align(&mut region, tolerance);
        stats.busy += t.elapsed();
        stats.items += 1;
        if out.send(region).is_err() {
            break;
        }
    }
    Ok(stats)
}
