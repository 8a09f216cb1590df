//! Channel wiring: every stage of a run, connected by bounded channels, in one place.
//!
//! Each stage runs on its own thread inside a `thread::scope` and hands its results to the
//! next through a `crossbeam_channel::bounded` channel of `channel_depth` items, so a slow
//! stage slows the ones before it (backpressure) instead of filling memory. A failing stage
//! sets the shared cancel flag; the others see it, or see their channel close, and stop. The
//! first real error (in pipeline order) is returned; a cancellation only if nothing failed.

use std::thread;

use crossbeam_channel::bounded;

use crate::config::ContoursConfig;
use crate::stages::s1_load::{self, SliceImages};
use crate::stages::s2_contours::{self, CompiledSection};
use crate::stages::{Control, StageStats};
use crate::{Error, Result};

/// Totals of a `contours` run.
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

    let (load, contours, write) = thread::scope(|scope| {
        let load =
            scope.spawn(|| cancel_on_error(ctl, s1_load::run(source, batch, images_tx, ctl)));
        let contours = scope.spawn(|| {
            cancel_on_error(
                ctl,
                s2_contours::run(images_rx, &config.contour, batch, sections_tx, ctl),
            )
        });
        let write = (|| {
            for compiled in sections_rx.iter() {
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
        // Dropping the receiver (end of the closure above) unblocks any stage still sending.
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
