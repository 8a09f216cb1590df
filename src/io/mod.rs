//! Formats read and written: contour NDJSON, and atomic (write-then-rename) output files.

pub mod atomic;
pub mod listing;
pub mod ndjson;
pub mod report;
pub mod stl;
