//! Stages 2–3: input compilation. Each slice image is thresholded, its contours extracted at
//! sub-pixel precision and compressed; the pixels are dropped here and a [`Section`] goes on.
//!
//! Slices are processed a batch at a time in parallel; sections leave in input order, so the
//! output does not depend on the number of threads.

use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};
use rayon::prelude::*;

use super::{Control, StageStats};
use crate::geometry::contours::{extract_contours, ContourOptions};
use crate::geometry::sections::{defect, resolved};
use crate::section::{Section, SliceImage};
use crate::{Error, Result};

pub const STAGE: &str = "contours";

/// A section with the counts the run reports.
#[derive(Clone, Debug, PartialEq)]
pub struct CompiledSection {
    pub section: Section,
    pub points_raw: usize,
    pub dropped_small: usize,
}

/// Compile one slice image into its section.
pub fn compile(image: &SliceImage, opts: &ContourOptions) -> Result<CompiledSection> {
    if image.hu.len() != image.rows * image.cols {
        return Err(Error::Slice {
            stage: STAGE,
            index: image.index,
            source_file: image.source.clone(),
            message: format!(
                "pixel data holds {} values, expected {} × {}",
                image.hu.len(),
                image.rows,
                image.cols
            ),
        });
    }
    let out = extract_contours(&image.hu, image.cols, image.rows, image.spacing, opts);
    Ok(CompiledSection {
        section: Section {
            index: image.index,
            frame: image.frame,
            source: image.source.clone(),
            contours: out.contours,
        },
        points_raw: out.points_raw,
        dropped_small: out.dropped_small,
    })
}

/// A section from elsewhere (contour NDJSON) made one the construction can use: where its
/// contours cross or nest against their hole flags ([`defect`]), they are replaced by the
/// region they wind round ([`resolved`]) and a warning says what was wrong. A valid section
/// passes unchanged; contours extracted from images are valid by construction.
pub fn resolve(mut section: Section, ctl: &Control) -> Section {
    if let Some(d) = defect(&section.contours) {
        let given = section.contours.len();
        section.contours = resolved(&section.contours);
        ctl.warn(format!(
            "slice {}: {d}; its {given} contour(s) replaced by the {} bounding the region they \
             wind round",
            section.index,
            section.contours.len()
        ));
    }
    section
}

pub fn run(
    input: Receiver<SliceImage>,
    opts: &ContourOptions,
    batch: usize,
    pool: &rayon::ThreadPool,
    out: Sender<CompiledSection>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    let mut images = Vec::with_capacity(batch);
    // One blocking receive, then whatever else is already waiting, up to a batch.
    while let Ok(first) = input.recv() {
        ctl.check()?;
        images.push(first);
        while images.len() < batch.max(1) {
            match input.try_recv() {
                Ok(image) => images.push(image),
                Err(_) => break,
            }
        }
        let t = Instant::now();
        let sections: Vec<Result<CompiledSection>> = pool.install(|| {
            images
                .par_iter()
                .map(|image| compile(image, opts))
                .collect()
        });
        images.clear();
        stats.busy += t.elapsed();
        for section in sections {
            stats.items += 1;
            if out.send(section?).is_err() {
                return Ok(stats);
            }
        }
    }
    Ok(stats)
}
