//! Analytic phantoms: shapes with a known surface, sampled as CT slices.
//!
//! Pure: no DICOM here. [`shapes`] defines the signed distance functions (patient mm, negative
//! inside); [`sample`] turns a [`PhantomSpec`] into a [`PhantomVolume`] of HU slices with partial
//! volume and seeded noise. `dicom::write_ct_series` writes such a volume as a real CT series.

pub mod sample;
pub mod shapes;

pub use sample::{generate, PhantomSpec, PhantomVolume, BACKGROUND_HU, OBJECT_HU};
pub use shapes::Shape;
