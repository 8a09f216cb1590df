//! Stage 5: contour alignment (METHOD.md §4). Each region's loops are rotated to start on the
//! region's shortest greedy baseline; shapes and orientation are unchanged.

use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};

use super::{Control, StageStats};
use crate::geometry::alignment::baseline;
use crate::region::Region;
use crate::Result;

pub const STAGE: &str = "alignment";

pub fn align(region: &mut Region) {
    let curves: Vec<&[[f64; 3]]> = region.curves.iter().map(|c| c.points.as_slice()).collect();
    let starts = baseline(&curves);
    for (c, s) in region.curves.iter_mut().zip(starts) {
        c.points.rotate_left(s);
    }
}

pub fn run(input: Receiver<Region>, out: Sender<Region>, ctl: &Control) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    for mut region in input.iter() {
        ctl.check()?;
        let t = Instant::now();
        align(&mut region);
        stats.busy += t.elapsed();
        stats.items += 1;
        if out.send(region).is_err() {
            break;
        }
    }
    Ok(stats)
}
