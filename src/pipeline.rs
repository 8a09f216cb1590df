//! Channel wiring: every stage of a run, connected by bounded channels, in one place.
//!
//! Each stage runs on its own thread inside a `thread::scope` and hands its results to the
//! next through a `crossbeam_channel::bounded` channel of `channel_depth` items, so a slow
//! stage slows the ones before it (backpressure) instead of filling memory. A failing stage
//! sets the shared cancel flag; the others see it, or see their channel close, and stop. The
//! first real error (in pipeline order) is returned; a cancellation only if nothing failed.

use std::thread;

use crossbeam_channel::bounded;

use std::path::Path;

use crate::bspline::fit::FitOptions;
use crate::config::{ContoursConfig, RunConfig};
use crate::section::Section;
use crate::stages::s1_load::{self, SliceImages};
use crate::stages::s2_contours::{self, CompiledSection};
use crate::stages::s8_write::Written;
use crate::stages::{
    s3_correspondence, s4_branching, s5_alignment, s6_fitting, s7_skinning, s8_write, Control,
    StageStats,
};
use crate::{Error, Result};

/// Totals of a `contours` run (and of the input side of a `run`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContoursSummary {
    pub stages: Vec<StageStats>,
    pub sections: usize,
    pub empty_sections: usize,
    pub contours: usize,
    pub holes: usize,
    pub points_raw: usize,
    pub points_compressed: usize,
    pub dropped_small: usize,
    /// Heights (along the slice normal, mm) of the first and last section, and the smallest
    /// and largest distance between consecutive sections (sections arrive in ascending height).
    pub heights: Option<(f64, f64)>,
    pub spacing_range: Option<(f64, f64)>,
}

/// Load → contours → `sink`, which receives every section in ascending height on the calling
/// thread (the writer stage).
pub fn run_contours(
    source: &dyn SliceImages,
    config: &ContoursConfig,
    ctl: &Control,
    sink: &mut dyn FnMut(&CompiledSection) -> Result<()>,
) -> Result<ContoursSummary> {
    let depth = config.pipeline.channel_depth.max(1);
    let batch = config.pipeline.batch.max(1);
    let (images_tx, images_rx) = bounded(depth);
    let (sections_tx, sections_rx) = bounded(depth);
    let mut summary = ContoursSummary::default();

    let front = front_pool()?;
    let (load, contours, write) = thread::scope(|scope| {
        let load = scope
            .spawn(|| cancel_on_error(ctl, s1_load::run(source, batch, &front, images_tx, ctl)));
        let contours = scope.spawn(|| {
            cancel_on_error(
                ctl,
                s2_contours::run(images_rx, &config.contour, batch, &front, sections_tx, ctl),
            )
        });
        // The loop owns the receiver, so it is dropped as soon as the loop ends, early or
        // not: a stage still waiting to send then gets an error instead of waiting forever.
        let write = (|| {
            for compiled in sections_rx {
                ctl.check()?;
                let s = &compiled.section;
                summary.sections += 1;
                summary.empty_sections += usize::from(s.contours.is_empty());
                summary.contours += s.contours.len();
                summary.holes += s.contours.iter().filter(|c| c.hole).count();
                summary.points_raw += compiled.points_raw;
                summary.points_compressed +=
                    s.contours.iter().map(|c| c.points.len()).sum::<usize>();
                summary.dropped_small += compiled.dropped_small;
                sink(&compiled)?;
            }
            Ok(())
        })();
        let write = cancel_on_error(ctl, write);
        (join(load), join(contours), write)
    });
    let mut failure = None;
    let load = settle(load, &mut failure);
    let contours = settle(contours, &mut failure);
    settle(write, &mut failure);
    if let Some(e) = failure {
        return Err(e);
    }
    summary.stages = load.into_iter().chain(contours).collect();
    Ok(summary)
}

impl ContoursSummary {
    /// `(min, mean, max)` distance between consecutive sections (mm); `None` for fewer than
    /// two sections.
    pub fn slice_spacing(&self) -> Option<(f64, f64, f64)> {
        let (first, last) = self.heights?;
        let (lo, hi) = self.spacing_range?;
        let mean = (last - first).abs() / (self.sections - 1) as f64;
        Some((lo, mean, hi))
    }

    fn count(&mut self, compiled: &CompiledSection) {
        self.count_section(
            &compiled.section,
            compiled.points_raw,
            compiled.dropped_small,
        );
    }

    /// A section whose contours had `points_raw` points before compression.
    fn count_section(&mut self, s: &Section, points_raw: usize, dropped_small: usize) {
        let h = s.frame.height();
        if let Some((first, last)) = self.heights {
            let d = (h - last).abs();
            self.spacing_range = Some(match self.spacing_range {
                Some((lo, hi)) => (lo.min(d), hi.max(d)),
                None => (d, d),
            });
            self.heights = Some((first, h));
        } else {
            self.heights = Some((h, h));
        }
        self.sections += 1;
        self.empty_sections += usize::from(s.contours.is_empty());
        self.contours += s.contours.len();
        self.holes += s.contours.iter().filter(|c| c.hole).count();
        self.points_raw += points_raw;
        self.points_compressed += s.contours.iter().map(|c| c.points.len()).sum::<usize>();
        self.dropped_small += dropped_small;
    }
}

/// Where a `run` gets its sections: slice images to segment (DICOM, phantom), or contours
/// that a segmentation tool already made (NDJSON).
pub enum RunInput<'a> {
    Images(&'a dyn SliceImages),
    Sections(Box<dyn Iterator<Item = Result<Section>> + Send + 'a>),
}

/// What a `run` did.
#[derive(Debug, Default)]
pub struct RunSummary {
    pub input: ContoursSummary,
    pub written: Written,
    pub stages: Vec<StageStats>,
}

/// The whole pipeline: sections → correspondence → branching → alignment → fitting →
/// skinning → writers in `out_dir`. `on_section` is called as each section enters
/// correspondence (progress).
pub fn run_surfaces(
    input: RunInput<'_>,
    config: &RunConfig,
    out_dir: &Path,
    ctl: &Control,
    on_section: &(dyn Fn(&Section) + Sync),
) -> Result<RunSummary> {
    let depth = config.pipeline.channel_depth.max(1);
    let batch = config.pipeline.batch.max(1);
    let fit_opts = FitOptions::new(config.tolerance_mm);
    let (transitions_tx, transitions_rx) = bounded(depth);
    let (regions_tx, regions_rx) = bounded(depth);
    let (aligned_tx, aligned_rx) = bounded(depth);
    let (fitted_tx, fitted_rx) = bounded(depth);
    let (surfaces_tx, surfaces_rx) = bounded(depth);
    let mut failure = None;
    let mut summary = RunSummary::default();

    thread::scope(|scope| {
        // Stages 1–3: from the input to transitions between adjacent sections.
        let front = scope.spawn(|| {
            let mut counts = ContoursSummary::default();
            let mut stats = Vec::new();
            let r = match input {
                RunInput::Images(source) => {
                    let (images_tx, images_rx) = bounded(depth);
                    let (sections_tx, sections_rx) = bounded::<CompiledSection>(depth);
                    let front = front_pool()?;
                    thread::scope(|inner| {
                        let load = inner.spawn(|| {
                            cancel_on_error(
                                ctl,
                                s1_load::run(source, batch, &front, images_tx, ctl),
                            )
                        });
                        let contours = inner.spawn(|| {
                            cancel_on_error(
                                ctl,
                                s2_contours::run(
                                    images_rx,
                                    &config.contour,
                                    batch,
                                    &front,
                                    sections_tx,
                                    ctl,
                                ),
                            )
                        });
                        // Correspondence owns the receiver and drops it when it returns,
                        // early or not, so that contour extraction, if waiting to send, gets
                        // an error and stops instead of waiting forever.
                        let sections = sections_rx.into_iter().map(|c| {
                            counts.count(&c);
                            on_section(&c.section);
                            Ok(c.section)
                        });
                        let corr = cancel_on_error(
                            ctl,
                            s3_correspondence::run(
                                sections,
                                config.fallback_spacing_mm,
                                transitions_tx,
                                ctl,
                            ),
                        );
                        let mut f = None;
                        stats.extend(settle(join(load), &mut f));
                        stats.extend(settle(join(contours), &mut f));
                        stats.extend(settle(corr, &mut f));
                        f.map_or(Ok(()), Err)
                    })
                }
                RunInput::Sections(iter) => {
                    let sections = iter.map(|s| {
                        let s = s2_contours::resolve(s?, ctl);
                        // Contours from elsewhere arrive compressed (or not): raw = as given.
                        let given = s.contours.iter().map(|c| c.points.len()).sum();
                        counts.count_section(&s, given, 0);
                        on_section(&s);
                        Ok(s)
                    });
                    let r = s3_correspondence::run(
                        sections,
                        config.fallback_spacing_mm,
                        transitions_tx,
                        ctl,
                    );
                    cancel_on_error(ctl, r).map(|s| stats.push(s))
                }
            };
            r.map(|()| (counts, stats))
        });
        let branching = scope.spawn(|| {
            cancel_on_error(
                ctl,
                s4_branching::run(
                    transitions_rx,
                    config.cell_mm,
                    config.tolerance_mm,
                    config.max_curves,
                    regions_tx,
                    ctl,
                ),
            )
        });
        let alignment = scope.spawn(|| {
            cancel_on_error(
                ctl,
                s5_alignment::run(regions_rx, aligned_tx, &fit_opts, ctl),
            )
        });
        // Regions are contours, not pixels: four per worker in flight keeps every core on
        // one while the largest is fitted.
        let fitting = scope.spawn(|| {
            cancel_on_error(
                ctl,
                s6_fitting::run(aligned_rx, &fit_opts, 4 * batch, fitted_tx, ctl),
            )
        });
        let skinning = scope.spawn(|| {
            cancel_on_error(
                ctl,
                s7_skinning::run(fitted_rx, config.tolerance_mm, surfaces_tx, ctl),
            )
        });
        // The writer joins the other stages before it commits its files (and they are
        // joined after it if it stops early).
        let mut handles = Some((front, [branching, alignment, fitting, skinning]));
        let mut join_upstream = |failure: &mut Option<Error>, summary: &mut RunSummary| {
            if let Some((front, rest)) = handles.take() {
                if let Some((counts, stats)) = settle(join(front), failure) {
                    summary.input = counts;
                    summary.stages.extend(stats);
                }
                for h in rest {
                    summary.stages.extend(settle(join(h), failure));
                }
            }
        };
        let written = cancel_on_error(
            ctl,
            s8_write::run(
                surfaces_rx,
                out_dir,
                config.tolerance_mm,
                config.mesh_chordal * config.tolerance_mm,
                &config.outputs,
                ctl,
                &mut || {
                    join_upstream(&mut failure, &mut summary);
                    match failure {
                        Some(_) => Err(Error::Cancelled),
                        // Empty files under final names would read as a result.
                        None if summary.input.contours == 0 => Err(Error::EmptySegmentation {
                            sections: summary.input.sections,
                            dropped: summary.input.dropped_small,
                        }),
                        None => Ok(()),
                    }
                },
            ),
        );
        join_upstream(&mut failure, &mut summary);
        if let Some(w) = settle(written, &mut failure) {
            summary.stages.push(w.stats.clone());
            summary.written = w;
        }
    });
    match failure {
        Some(e) => Err(e),
        None => {
            for s in &summary.stages {
                tracing::info!(
                    "stage {}: {} items, {:.3} s busy",
                    s.stage,
                    s.items,
                    s.busy.as_secs_f64()
                );
            }
            Ok(summary)
        }
    }
}

/// Decoding and segmentation get their own rayon workers: in the shared global pool their
/// batches would be injected from outside and served last, behind long branching jobs (the
/// skull run showed 54–98 s "busy" loading for 0.4 s of decoding). Only the batch work runs in
/// the pool; the stage loops, which block on channels, stay on their own threads (a blocking
/// loop inside a pool worker can be picked up by a waiting worker and deadlock).
fn front_pool() -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(|i| format!("bskin-front-{i}"))
        .build()
        .map_err(|e| Error::Internal(format!("cannot start worker threads: {e}")))
}

fn cancel_on_error<T>(ctl: &Control, r: Result<T>) -> Result<T> {
    if r.is_err() {
        ctl.cancel();
    }
    r
}

/// A panicking stage becomes an error rather than a second panic.
fn join<T>(h: thread::ScopedJoinHandle<'_, Result<T>>) -> Result<T> {
    h.join().unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        Err(Error::Internal(format!(
            "a pipeline stage panicked: {what}"
        )))
    })
}

/// Keep a stage's value, or record its error: the first real error wins over a cancellation
/// (which is only the other stages noticing that one failed).
fn settle<T>(r: Result<T>, failure: &mut Option<Error>) -> Option<T> {
    match r {
        Ok(v) => Some(v),
        Err(e) => {
            if failure.is_none() || matches!(failure, Some(Error::Cancelled)) {
                *failure = Some(e);
            }
            None
        }
    }
}
