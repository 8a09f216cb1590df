//! Stage 1: load slices. A pluggable source yields slice images in ascending height; this
//! stage decodes them a batch at a time in parallel and sends them on in order.
//!
//! Pixels are decoded only here, when a slice enters the pipeline, and at most
//! `batch + channel_depth` images are alive between this stage and the next.

use std::time::Instant;

use crossbeam_channel::Sender;
use rayon::prelude::*;

use super::{Control, StageStats};
use crate::section::SliceImage;
use crate::Result;

pub const STAGE: &str = "load";

/// A series of slice images, sorted by height, that can be decoded one by one from any
/// thread. Implemented by the DICOM reader and by the phantom generator; segmentation tools'
/// outputs that are already contours enter later, as sections.
pub trait SliceImages: Sync {
    /// Number of slices.
    fn count(&self) -> usize;
    /// Decode slice `index` (0 = lowest) to HU.
    fn load(&self, index: usize) -> Result<SliceImage>;
}

/// Decode every slice in order and send it on; stops early when the run is cancelled or the
/// next stage has gone.
pub fn run(
    source: &dyn SliceImages,
    batch: usize,
    pool: &rayon::ThreadPool,
    out: Sender<SliceImage>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    let n = source.count();
    let mut start = 0;
    while start < n {
        ctl.check()?;
        let end = (start + batch.max(1)).min(n);
        let t = Instant::now();
        // Only the batch runs in the pool; this loop blocks on the channel, so it stays here.
        let images: Vec<Result<SliceImage>> = pool.install(|| {
            (start..end)
                .into_par_iter()
                .map(|i| source.load(i))
                .collect()
        });
        stats.busy += t.elapsed();
        for image in images {
            let image = image?;
            stats.items += 1;
            if out.send(image).is_err() {
                // The next stage stopped; its own result says why.
                return Ok(stats);
            }
        }
        start = end;
    }
    Ok(stats)
}

/// A DICOM series decodes its slices on demand, in sorted order.
impl SliceImages for crate::dicom::Series {
    fn count(&self) -> usize {
        self.slices.len()
    }

    fn load(&self, index: usize) -> Result<SliceImage> {
        crate::dicom::decode_slice(self, &self.slices[index], index)
    }
}
