//! Stage 6: closed B-spline fitting on a common knot vector (paper §2.4–2.5, Algorithm 2).
//! Every curve of a region — contours, intermediate contours, caps — is fitted on one knot
//! vector within the tolerance. Regions are fitted a batch at a time in parallel and leave in
//! arrival order.

use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};
use rayon::prelude::*;

use super::{Control, StageStats};
use crate::bspline::common_knots::{fit_common, CommonFit};
use crate::bspline::fit::FitOptions;
use crate::region::Region;
use crate::{Error, Result};

pub const STAGE: &str = "fitting";

/// A region and its curves on one knot vector.
#[derive(Clone, Debug)]
pub struct FittedRegion {
    pub region: Region,
    pub fit: CommonFit<3>,
}

pub fn fit(region: Region, opts: &FitOptions) -> Result<FittedRegion> {
    let curves: Vec<Vec<[f64; 3]>> = region.curves.iter().map(|c| c.points.clone()).collect();
    let fit = fit_common(&curves, opts).map_err(|e| Error::Kernel {
        stage: STAGE,
        context: describe(&region),
        source: e,
    })?;
    Ok(FittedRegion { region, fit })
}

/// "region 7 (outer wall, slices 12–40)": for error messages.
pub fn describe(region: &Region) -> String {
    use crate::region::CurveOrigin::*;
    let slices: Vec<usize> = region
        .curves
        .iter()
        .map(|c| match c.origin {
            Contour { slice, .. } | Cap { slice } => slice,
            Intermediate { below, .. } => below,
        })
        .collect();
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

pub fn run(
    input: Receiver<Region>,
    opts: &FitOptions,
    batch: usize,
    out: Sender<FittedRegion>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    let mut regions = Vec::with_capacity(batch);
    while let Ok(first) = input.recv() {
        ctl.check()?;
        regions.push(first);
        while regions.len() < batch.max(1) {
            match input.try_recv() {
                Ok(r) => regions.push(r),
                Err(_) => break,
            }
        }
        let t = Instant::now();
        let fitted: Vec<Result<FittedRegion>> = std::mem::take(&mut regions)
            .into_par_iter()
            .map(|r| fit(r, opts))
            .collect();
        stats.busy += t.elapsed();
        for f in fitted {
            stats.items += 1;
            if out.send(f?).is_err() {
                return Ok(stats);
            }
        }
    }
    Ok(stats)
}
