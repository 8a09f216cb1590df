//! Run configuration: plain data built by the CLI (the library never depends on clap).

use crate::geometry::contours::ContourOptions;

/// How the stages are connected and run.
#[derive(Clone, Debug, PartialEq)]
pub struct PipelineOptions {
    /// Capacity of every channel between stages, in items (slices or regions). Small, so a
    /// slow consumer slows the producer instead of filling memory.
    pub channel_depth: usize,
    /// Slices decoded or segmented together by one stage's rayon batch. Bounds the pixels in
    /// flight together with `channel_depth`.
    pub batch: usize,
}

impl Default for PipelineOptions {
    fn default() -> Self {
        PipelineOptions {
            channel_depth: 4,
            batch: rayon::current_num_threads().max(2),
        }
    }
}

/// Everything `bskin contours` needs besides its input and output.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContoursConfig {
    pub contour: ContourOptions,
    pub pipeline: PipelineOptions,
}
