//! The planar geometry kernel: polygons, marching squares, polygon compression, input
//! compilation of a slice, distance maps, correspondence by overlap, intermediate contours of
//! branching problems and caps. Pure: no I/O, no channels, no DICOM types.

pub mod alignment;
pub mod branching;
pub mod bridges;
pub mod capping;
pub mod conform;
pub mod contours;
pub mod distance_map;
pub mod keyhole;
pub mod lobe;
pub mod marching_squares;
pub mod overlap;
pub mod polygon;
pub mod ridge;
pub mod sections;
pub mod simplify;
pub mod spur;
mod zones;

/// Errors of the geometry kernel; each states the numbers involved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error("degenerate polygon: {0}")]
    Degenerate(String),
    #[error("non-finite value: {0}")]
    NonFinite(String),
    #[error("empty input: {0}")]
    Empty(String),
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    #[error("raster too large: {0}")]
    RasterTooLarge(String),
}
