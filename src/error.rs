//! The library's error type. Every variant says where (stage, slice, file) and what went wrong;
//! the kernel's own errors ([`crate::bspline::BsplineError`], [`crate::geometry::GeometryError`])
//! are wrapped with that context here.

use std::path::PathBuf;

use crate::section::SliceSource;

pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file or directory could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// An output file could not be written (exit code 3).
    #[error("cannot write {path}: {source}")]
    Output {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// Input that is not usable as given: the message names the file and the problem.
    #[error("{path}: {message}")]
    BadInput { path: PathBuf, message: String },

    /// No usable image series was found.
    #[error("{path}: {message}")]
    NoSeries { path: PathBuf, message: String },

    /// Several volumetric series and no `--series` to choose one.
    #[error("{path}: {message}")]
    AmbiguousSeries { path: PathBuf, message: String },

    /// A slice failed in a pipeline stage.
    #[error("stage {stage}, slice {index} ({source_file}): {message}")]
    Slice {
        stage: &'static str,
        index: usize,
        source_file: SliceSource,
        message: String,
    },

    /// A B-spline kernel failure, with the region and contour it concerns.
    #[error("stage {stage}, {context}: {source}")]
    Kernel {
        stage: &'static str,
        context: String,
        #[source]
        source: crate::bspline::BsplineError,
    },

    /// A geometry kernel failure (polygons, distance maps), with its context.
    #[error("stage {stage}, {context}: {source}")]
    Geometry {
        stage: &'static str,
        context: String,
        #[source]
        source: crate::geometry::GeometryError,
    },

    /// A command-line value that cannot be used (exit code 2, like clap's own errors).
    #[error("{option}: {message}")]
    Usage { option: String, message: String },

    /// No contour in any section: there is nothing to fit, and no output is written. The
    /// caller names the input and the threshold.
    #[error(
        "the segmentation is empty: no contour in any of its {sections} slices ({dropped} \
         smaller than the minimum area dropped); nothing was written"
    )]
    EmptySegmentation { sections: usize, dropped: usize },

    /// A bug: something the code should have prevented (a panicking stage, say).
    #[error("internal error: {0}")]
    Internal(String),

    /// The run was cancelled (Ctrl-C, or a consumer went away).
    #[error("cancelled")]
    Cancelled,
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    pub fn usage(option: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Usage {
            option: option.into(),
            message: message.into(),
        }
    }

    pub fn bad_input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::BadInput {
            path: path.into(),
            message: message.into(),
        }
    }
}
