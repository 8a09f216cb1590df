//! DICOM input: header scan, series grouping and sorting, pixel decoding to HU, phantom writer.
//!
//! The only module that sees dicom-rs types: everything it hands out is ours ([`Scan`],
//! [`Series`], [`SliceHeader`], [`crate::section::SliceImage`]). Typical use:
//!
//! ```no_run
//! # fn main() -> bskin::Result<()> {
//! let dir = std::path::Path::new("study/");
//! let scan = bskin::dicom::scan(dir)?;
//! let series = bskin::dicom::select_series(&scan, None, dir)?;
//! for (i, s) in series.slices.iter().enumerate() {
//!     let img = bskin::dicom::decode_slice(series, s, i)?;
//!     # let _ = img;
//! }
//! # Ok(()) }
//! ```

mod attr;
pub mod decode;
mod open;
pub mod scan;
pub mod series;
pub mod write;

pub use decode::{decode_file, decode_slice, DecodedImage};
pub use scan::{scan, Scan};
pub use series::{select_series, Series, SliceHeader, SpacingStats};
pub use write::{write_ct_series, WriteOptions};
