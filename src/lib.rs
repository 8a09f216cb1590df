//! bskin: bicubic B-spline surfaces from stacks of cross-sections.
//!
//! The method is J. Jeong et al., "B-Spline Surface Approximation to Cross-Sections Using
//! Distance Maps" (1999); `METHOD.md` in the shared folder restates it. The crate is layered:
//!
//! - [`geometry`] and [`bspline`]: the pure kernel (polygons, marching squares, distance maps,
//!   closed B-spline curves, common knot vectors, skinning). No I/O, no DICOM types.
//! - [`dicom`]: the only module that sees DICOM: header scan, series grouping, pixel decoding,
//!   and the phantom writer.
//! - [`stages`]: one module per pipeline stage, in reading order; each is a thin adapter over the
//!   kernel. [`pipeline`] wires them with bounded channels, in one place.
//! - [`io`]: the formats we read and write (contour NDJSON, reports).

// The API docs are for developers, read with private items (`cargo doc --document-private-items`),
// so public items may point to the private helpers that explain them.
#![allow(rustdoc::private_intra_doc_links)]

pub mod bspline;
pub mod config;
pub mod dicom;
pub mod error;
pub mod exit_codes;
pub mod geometry;
pub mod io;
pub mod mesh;
pub mod phantom;
pub mod pipeline;
pub mod region;
pub mod section;
pub mod stages;

pub use error::{Error, Result};
pub use section::{Contour, Section, SeriesSummary, SliceFrame, SliceImage};
