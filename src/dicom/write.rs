//! Writing a real DICOM CT series (used for phantoms and tests).
//!
//! In: slices in HU ([`SliceImage`]: frame, size, spacing, values) and [`WriteOptions`]. Out: one
//! CT Image Storage file per slice in `dir`, explicit VR little endian with file meta, and the
//! list of paths written (in slice order).
//!
//! Choices and invariants:
//! - pixels are signed 16-bit (BitsAllocated = BitsStored = 16, HighBit 15, PixelRepresentation
//!   1), RescaleSlope 1, RescaleIntercept 0: HU are stored as they are, rounded to whole numbers
//!   and clamped to −32767..32767; `f32::MIN` (padding) is stored as −32768 and declared as
//!   PixelPaddingValue, so a read-back gives the same values;
//! - Study, Series, Frame of Reference and SOP Instance UIDs are `2.25.<decimal>` derived from
//!   `seed` (same seed → same UIDs, different seeds → different studies);
//! - decimal strings are printed with the shortest representation that reads back equal when it
//!   fits DICOM's 16 characters, otherwise with as many digits as fit;
//! - file names are a hash of the SOP Instance UID (`shuffle_names`, the default), so file order
//!   is not slice order, or `IM00001.dcm`… in slice order;
//! - every file is written to a temporary name in `dir` and renamed, so a reader never sees a
//!   half-written file.

use std::path::{Path, PathBuf};

use dicom_core::value::PrimitiveValue;
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::meta::FileMetaTableBuilder;
use dicom_object::InMemDicomObject;
use rayon::prelude::*;

use super::open::error_chain;
use crate::error::{Error, Result};
use crate::section::SliceImage;

/// How to label and name the series.
#[derive(Clone, Debug)]
pub struct WriteOptions {
    /// Seed of every UID.
    pub seed: u64,
    /// SeriesDescription (e.g. "bskin phantom tube-split").
    pub description: String,
    pub series_number: i32,
    pub patient_name: String,
    /// Name files by a hash (file order ≠ slice order) instead of `IM00001.dcm`…
    pub shuffle_names: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            seed: 1,
            description: "bskin phantom".into(),
            series_number: 1,
            patient_name: "Phantom^bskin".into(),
            shuffle_names: true,
        }
    }
}

impl WriteOptions {
    /// Options for a phantom: description `"bskin phantom <shape>"`, the phantom's seed.
    pub fn for_phantom(spec: &crate::phantom::PhantomSpec) -> Self {
        WriteOptions {
            seed: spec.seed,
            description: format!("bskin phantom {}", spec.shape),
            ..WriteOptions::default()
        }
    }
}

/// Writes `slices` as a CT series in `dir` (created if missing); returns the paths, in slice
/// order.
pub fn write_ct_series(
    dir: &Path,
    slices: &[SliceImage],
    opts: &WriteOptions,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::Output {
        path: dir.to_path_buf(),
        source: e,
    })?;
    for s in slices {
        if s.hu.len() != s.rows * s.cols
            || s.rows == 0
            || s.cols == 0
            || s.rows > 65535
            || s.cols > 65535
        {
            return Err(Error::bad_input(
                dir,
                format!(
                    "slice {}: {} values for a {}×{} image",
                    s.index,
                    s.hu.len(),
                    s.cols,
                    s.rows
                ),
            ));
        }
    }
    let study = uid(opts.seed, "study", 0);
    let series = uid(opts.seed, "series", 0);
    let frame_of_ref = uid(opts.seed, "frame-of-reference", 0);
    slices
        .par_iter()
        .enumerate()
        .map(|(k, s)| {
            let sop = uid(opts.seed, "sop", k as u64);
            let name = if opts.shuffle_names {
                format!("{:016x}.dcm", hash64(sop.as_bytes(), opts.seed))
            } else {
                format!("IM{:05}.dcm", k + 1)
            };
            let path = dir.join(&name);
            let obj = slice_object(s, k, opts, &study, &series, &frame_of_ref, &sop);
            let file = obj
                .with_meta(
                    FileMetaTableBuilder::new().transfer_syntax(uids::EXPLICIT_VR_LITTLE_ENDIAN),
                )
                .map_err(|e| Error::bad_input(&path, format!("file meta: {}", error_chain(&e))))?;
            let tmp = dir.join(format!(".{name}.tmp"));
            file.write_to_file(&tmp).map_err(|e| Error::Output {
                path: tmp.clone(),
                source: std::io::Error::other(error_chain(&e)),
            })?;
            std::fs::rename(&tmp, &path).map_err(|e| Error::Output {
                path: path.clone(),
                source: e,
            })?;
            Ok(path)
        })
        .collect()
}

fn slice_object(
    s: &SliceImage,
    k: usize,
    opts: &WriteOptions,
    study: &str,
    series: &str,
    frame_of_ref: &str,
    sop: &str,
) -> InMemDicomObject {
    let mut o = InMemDicomObject::new_empty();
    let mut put = |tag: Tag, vr: VR, v: PrimitiveValue| {
        o.put(DataElement::new(tag, vr, v));
    };
    let st = |v: &str| PrimitiveValue::from(v);
    let ds = |v: &[f64]| PrimitiveValue::Strs(v.iter().map(|x| fmt_ds(*x)).collect());
    let f = &s.frame;
    let height = f.height();
    let mut pixels = Vec::with_capacity(s.hu.len());
    let mut padded = false;
    for &v in &s.hu {
        let q = if v == f32::MIN {
            padded = true;
            -32768i16
        } else {
            v.round().clamp(-32767.0, 32767.0) as i16
        };
        pixels.push(q as u16);
    }

    put(tags::SPECIFIC_CHARACTER_SET, VR::CS, st("ISO_IR 100"));
    put(
        tags::IMAGE_TYPE,
        VR::CS,
        PrimitiveValue::Strs(
            ["ORIGINAL", "PRIMARY", "AXIAL"]
                .iter()
                .map(|v| v.to_string())
                .collect(),
        ),
    );
    put(tags::SOP_CLASS_UID, VR::UI, st(uids::CT_IMAGE_STORAGE));
    put(tags::SOP_INSTANCE_UID, VR::UI, st(sop));
    put(tags::STUDY_DATE, VR::DA, st("20260101"));
    put(tags::STUDY_TIME, VR::TM, st("120000"));
    put(tags::ACCESSION_NUMBER, VR::SH, PrimitiveValue::Empty);
    put(tags::MODALITY, VR::CS, st("CT"));
    put(tags::MANUFACTURER, VR::LO, st("bskin"));
    put(
        tags::REFERRING_PHYSICIAN_NAME,
        VR::PN,
        PrimitiveValue::Empty,
    );
    put(tags::SERIES_DESCRIPTION, VR::LO, st(&opts.description));
    put(tags::PATIENT_NAME, VR::PN, st(&opts.patient_name));
    put(tags::PATIENT_ID, VR::LO, st("BSKIN-PHANTOM"));
    put(tags::PATIENT_BIRTH_DATE, VR::DA, PrimitiveValue::Empty);
    put(tags::PATIENT_SEX, VR::CS, st("O"));
    put(tags::SLICE_THICKNESS, VR::DS, ds(&[slice_thickness(s)]));
    put(tags::KVP, VR::DS, PrimitiveValue::Empty);
    put(tags::PATIENT_POSITION, VR::CS, st("HFS"));
    put(tags::STUDY_INSTANCE_UID, VR::UI, st(study));
    put(tags::SERIES_INSTANCE_UID, VR::UI, st(series));
    put(tags::STUDY_ID, VR::SH, st("1"));
    put(
        tags::SERIES_NUMBER,
        VR::IS,
        st(&opts.series_number.to_string()),
    );
    put(tags::INSTANCE_NUMBER, VR::IS, st(&(k + 1).to_string()));
    put(tags::IMAGE_POSITION_PATIENT, VR::DS, ds(&f.origin));
    put(
        tags::IMAGE_ORIENTATION_PATIENT,
        VR::DS,
        ds(&[f.row[0], f.row[1], f.row[2], f.col[0], f.col[1], f.col[2]]),
    );
    put(tags::FRAME_OF_REFERENCE_UID, VR::UI, st(frame_of_ref));
    put(
        tags::POSITION_REFERENCE_INDICATOR,
        VR::LO,
        PrimitiveValue::Empty,
    );
    put(tags::SLICE_LOCATION, VR::DS, ds(&[height]));
    put(tags::SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16));
    put(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, st("MONOCHROME2"));
    put(tags::ROWS, VR::US, PrimitiveValue::from(s.rows as u16));
    put(tags::COLUMNS, VR::US, PrimitiveValue::from(s.cols as u16));
    put(tags::PIXEL_SPACING, VR::DS, ds(&s.spacing));
    put(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(16u16));
    put(tags::BITS_STORED, VR::US, PrimitiveValue::from(16u16));
    put(tags::HIGH_BIT, VR::US, PrimitiveValue::from(15u16));
    put(
        tags::PIXEL_REPRESENTATION,
        VR::US,
        PrimitiveValue::from(1u16),
    );
    if padded {
        put(
            tags::PIXEL_PADDING_VALUE,
            VR::SS,
            PrimitiveValue::from(-32768i16),
        );
    }
    put(tags::WINDOW_CENTER, VR::DS, st("300"));
    put(tags::WINDOW_WIDTH, VR::DS, st("1500"));
    put(tags::RESCALE_INTERCEPT, VR::DS, st("0"));
    put(tags::RESCALE_SLOPE, VR::DS, st("1"));
    put(tags::RESCALE_TYPE, VR::LO, st("HU"));
    put(tags::PIXEL_DATA, VR::OW, PrimitiveValue::U16(pixels.into()));
    o
}

/// Nominal thickness: the pixel spacing is no guide, so 1 mm unless told otherwise. Readers
/// use positions, not this.
fn slice_thickness(_s: &SliceImage) -> f64 {
    1.0
}

/// A DS value: at most 16 characters, the shortest exact form when it fits.
pub(crate) fn fmt_ds(v: f64) -> String {
    let v = if v == 0.0 || !v.is_finite() { 0.0 } else { v };
    let s = format!("{v}");
    if s.len() <= 16 {
        return s;
    }
    for p in (0..=15).rev() {
        let s = format!("{v:.p$}");
        if s.len() <= 16 {
            return s;
        }
    }
    for p in (0..=9).rev() {
        let s = format!("{v:.p$e}");
        if s.len() <= 16 {
            return s;
        }
    }
    "0".into()
}

/// `2.25.<decimal of a 128-bit hash of (seed, role, k)>`: a valid, deterministic UID.
pub(crate) fn uid(seed: u64, role: &str, k: u64) -> String {
    let mut bytes = role.as_bytes().to_vec();
    bytes.extend_from_slice(&k.to_le_bytes());
    let hi = hash64(&bytes, seed);
    let lo = hash64(&bytes, seed ^ 0x5DEE_CE66_D1CE_4E5B);
    let v = ((hi as u128) << 64 | lo as u128).max(1);
    format!("2.25.{v}")
}

/// FNV-1a over the bytes, seeded, finished with SplitMix64: cheap and well spread.
fn hash64(bytes: &[u8], seed: u64) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64 ^ seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^ (h >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ds_fits_and_reads_back() {
        for v in [
            0.0,
            -0.0,
            1.5,
            -50.8,
            123.456789,
            1.0 / 3.0,
            -1e-7,
            1.0e7 + 1.0 / 7.0,
        ] {
            let s = fmt_ds(v);
            assert!(s.len() <= 16, "{s}");
            let back: f64 = s.parse().unwrap();
            assert!((back - v).abs() <= 1e-9 * v.abs().max(1.0), "{v} -> {s}");
        }
        assert_eq!(fmt_ds(-50.8), "-50.8");
    }

    #[test]
    fn uids_are_valid_and_deterministic() {
        let a = uid(7, "sop", 3);
        assert_eq!(a, uid(7, "sop", 3));
        assert_ne!(a, uid(8, "sop", 3));
        assert_ne!(a, uid(7, "sop", 4));
        assert!(a.len() <= 64);
        assert!(a.starts_with("2.25."));
        let digits = &a[5..];
        assert!(digits.chars().all(|c| c.is_ascii_digit()) && !digits.starts_with('0'));
    }
}
