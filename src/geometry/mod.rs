//! The planar geometry kernel: polygons, marching squares, polygon compression, input
//! compilation of a slice, distance maps. Pure: no I/O, no channels, no DICOM types.

pub mod alignment;
pub mod contours;
pub mod marching_squares;
pub mod polygon;
pub mod simplify;

/// Errors of the geometry kernel; each states the numbers involved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error("degenerate polygon: {0}")]
    Degenerate(String),
    #[error("non-finite value: {0}")]
    NonFinite(String),
}
