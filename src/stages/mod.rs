//! The pipeline stages, in order. Each is a thin adapter over the kernel: it receives items
//! from a channel, does its work (in parallel with rayon where there is some), and sends the
//! results on, in input order. The channels themselves are created in [`crate::pipeline`].
//!
//! 1. [`s1_load`]: slice images from a pluggable source (a DICOM series, a phantom).
//! 2. [`s2_contours`]: threshold segmentation, contour extraction, polygon compression.
//! 3. [`s3_correspondence`]: overlap links between adjacent sections → branching problems.
//! 4. [`s4_branching`]: intermediate contours and caps by distance maps; regions assembled.
//! 5. [`s5_alignment`]: the shortest baseline per region, so surfaces are not twisted.
//! 6. [`s6_fitting`]: every region's curves on one common knot vector (Algorithm 2).
//! 7. [`s7_skinning`]: one bicubic surface per region, and its tolerance certificate.
//! 8. [`s8_write`]: mesh and report, written under temporary names and renamed.

pub mod s1_load;
pub mod s2_contours;
pub mod s3_correspondence;
pub mod s4_branching;
pub mod s5_alignment;
pub mod s6_fitting;
pub mod s7_skinning;
pub mod s8_write;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The log target of the warnings stages record ([`Control::warn`]): a default run keeps
/// them off the screen, where hundreds (one per capped contour of an MR series) would bury
/// the summary, and lists them in report.json and, a line per kind, in the summary.
pub const WARNINGS_TARGET: &str = "bskin::run_warnings";

/// Shared by all stages of one run: one flag that every stage checks, so one failure (or
/// Ctrl-C) stops the whole pipeline.
#[derive(Clone, Debug, Default)]
pub struct Control {
    cancelled: Arc<AtomicBool>,
    warnings: Arc<Mutex<Vec<String>>>,
    notes: Arc<Mutex<Vec<String>>>,
}

impl Control {
    pub fn new() -> Self {
        Self::default()
    }

    /// A control whose flag is `flag` (e.g. set by a Ctrl-C handler).
    pub fn with_flag(flag: Arc<AtomicBool>) -> Self {
        Control {
            cancelled: flag,
            ..Default::default()
        }
    }

    /// Record a warning for the report, and log it under [`WARNINGS_TARGET`] (off a default
    /// run's screen: the summary lists each kind once; `-v` shows each as it happens).
    pub fn warn(&self, message: String) {
        tracing::warn!(target: WARNINGS_TARGET, "{message}");
        if let Ok(mut w) = self.warnings.lock() {
            w.push(message);
        }
    }

    /// Record a note for the report: something the run did that needs no action (logged at
    /// info level, so it stays off a default run's screen).
    pub fn note(&self, message: String) {
        tracing::info!("{message}");
        if let Ok(mut n) = self.notes.lock() {
            n.push(message);
        }
    }

    /// The notes so far, sorted.
    pub fn notes(&self) -> Vec<String> {
        let mut n = self.notes.lock().map(|n| n.clone()).unwrap_or_default();
        n.sort();
        n
    }

    /// The warnings so far, sorted (stages push them from parallel work in any order).
    pub fn warnings(&self) -> Vec<String> {
        let mut w = self.warnings.lock().map(|w| w.clone()).unwrap_or_default();
        w.sort();
        w
    }

    pub fn cancel(&self) {
        self.cancelled.store(true, Ordering::SeqCst);
    }

    pub fn is_cancelled(&self) -> bool {
        self.cancelled.load(Ordering::SeqCst)
    }

    /// `Err(Cancelled)` once the run is being stopped.
    pub fn check(&self) -> crate::Result<()> {
        if self.is_cancelled() {
            Err(crate::Error::Cancelled)
        } else {
            Ok(())
        }
    }
}

/// What one stage did: items through it and time spent working (not waiting on channels).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct StageStats {
    pub stage: &'static str,
    pub items: usize,
    #[serde(serialize_with = "seconds")]
    pub busy: Duration,
}

fn seconds<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}
