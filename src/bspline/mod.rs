//! The B-spline kernel (paper §2.1, §2.4–2.6; METHOD.md §5–8): closed cubic curves, fitting
//! within a tolerance, common knot vectors, skinning. Pure: no I/O, no channels, no DICOM.

/// Errors of the B-spline kernel; each states the numbers involved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BsplineError {
    #[error("invalid knot vector: {0}")]
    InvalidKnots(String),
    #[error("degenerate input: {0}")]
    Degenerate(String),
}
