//! The planar geometry kernel: polygons, marching squares, polygon compression, distance maps.
//! Pure: no I/O, no channels, no DICOM types.

/// Errors of the geometry kernel; each states the numbers involved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    #[error("degenerate polygon: {0}")]
    Degenerate(String),
    #[error("non-finite value: {0}")]
    NonFinite(String),
}
