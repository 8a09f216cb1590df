//! Pixel decoding: one slice of a series into Hounsfield units.
//!
//! In: a [`Series`] and one of its [`SliceHeader`]s. Out: a [`SliceImage`] with `rows × cols`
//! HU values. dicom-pixeldata does the decoding (every codec the crate is built with) and the
//! BitsStored masking / sign extension; we apply the modality LUT ourselves (slope and intercept
//! from the header scan: per frame for enhanced objects) because padding must be recognised on
//! the *stored* value before rescaling. Padding pixels (PixelPaddingValue, or the range up to
//! PixelPaddingRangeLimit) become `f32::MIN` so that no threshold selects them.
//!
//! Errors name the file and, for multi-frame files, the frame.
//!
//! Transfer syntaxes tested against uncompressed references (tests/dicom_transcoded.rs,
//! tests/dicom_codecs.rs): implicit/explicit VR LE, explicit VR BE, deflated, RLE, JPEG lossless
//! (process 14, SV1), JPEG-LS lossless and near-lossless (system CharLS: libcharls must be
//! installed to build), JPEG 2000 lossless and lossy (pure-Rust openjp2). Not decodable: 12-bit
//! lossy JPEG (process 4; jpeg-decoder has no 12-bit DCT) — the error says so and how to
//! convert; and the NEMA MR1_JLSL stream, which CharLS rejects.

use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;
use dicom_pixeldata::{ConvertOptions, ModalityLutOption, PixelDecoder, Rescale};

use std::path::Path;

use super::attr::{self, FrameGroups};
use super::open::{error_chain, open, ts_name, Opened};
use super::series::{Series, SliceHeader};
use crate::error::{Error, Result};
use crate::section::SliceImage;

/// Decodes `slice` (of `series`) into HU; `index` is its position in the sorted series.
pub fn decode_slice(series: &Series, slice: &SliceHeader, index: usize) -> Result<SliceImage> {
    let img = decode_frame(
        &slice.source.path,
        slice.source.frame,
        Some((slice.slope, slice.intercept)),
        &slice.transfer_syntax,
    )?;
    if img.rows != slice.rows
        || img.cols != slice.cols
        || img.rows != series.rows
        || img.cols != series.cols
    {
        return Err(Error::bad_input(
            &slice.source.path,
            format!(
                "{}decoded image is {}×{}, header scan said {}×{}",
                frame_prefix(slice.source.frame),
                img.cols,
                img.rows,
                slice.cols,
                slice.rows
            ),
        ));
    }
    Ok(SliceImage {
        index,
        frame: slice.frame,
        source: slice.source.clone(),
        rows: img.rows,
        cols: img.cols,
        spacing: slice.spacing,
        hu: img.hu,
    })
}

/// One decoded frame without geometry: for decoder tests and tools that look at single files.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedImage {
    pub rows: usize,
    pub cols: usize,
    /// Row-major values after the modality LUT (HU for CT); padding is `f32::MIN`.
    pub hu: Vec<f32>,
}

/// Decodes frame `frame` (0-based; `None` = single-frame) of the file at `path`, with the
/// file's own RescaleSlope/Intercept (functional groups first for enhanced objects).
pub fn decode_file(path: &Path, frame: Option<u32>) -> Result<DecodedImage> {
    decode_frame(path, frame, None, "")
}

fn frame_prefix(frame: Option<u32>) -> String {
    match frame {
        Some(k) => format!("frame {}: ", k + 1),
        None => String::new(),
    }
}

/// The common path: open fully, decode one frame, stored values → HU, padding → `f32::MIN`.
/// `rescale` comes from the header scan when known, else from the file.
fn decode_frame(
    path: &Path,
    frame: Option<u32>,
    rescale: Option<(f64, f64)>,
    ts_uid: &str,
) -> Result<DecodedImage> {
    let at = frame_prefix(frame);
    let fail = |m: String| Error::bad_input(path, format!("{at}{m}"));
    let obj = match open(path, false) {
        Ok(Opened::Dicom(o)) => o,
        Ok(_) => return Err(fail("not a DICOM image (changed since the scan?)".into())),
        Err(m) => return Err(fail(m)),
    };
    let ts = if ts_uid.is_empty() {
        obj.meta().transfer_syntax().to_string()
    } else {
        ts_uid.to_string()
    };
    let decoded = obj
        .decode_pixel_data_frame(frame.unwrap_or(0))
        .map_err(|e| {
            let why = error_chain(&e);
            fail(format!(
                "cannot decode pixel data ({}): {why}{}",
                ts_name(&ts),
                hint(&why)
            ))
        })?;
    let (rows, cols) = (decoded.rows() as usize, decoded.columns() as usize);
    if decoded.samples_per_pixel() != 1 {
        return Err(fail(format!(
            "{} samples per pixel: only greyscale images have HU",
            decoded.samples_per_pixel()
        )));
    }
    // Identity modality LUT: the stored values, masked to BitsStored and sign-extended.
    let opts = ConvertOptions::new().with_modality_lut(ModalityLutOption::Override(Rescale {
        slope: 1.0,
        intercept: 0.0,
    }));
    let stored: Vec<f64> = decoded
        .to_vec_frame_with_options(0, &opts)
        .map_err(|e| fail(format!("cannot convert pixel values: {}", error_chain(&e))))?;
    if stored.len() != rows * cols {
        return Err(fail(format!(
            "{} pixel values for a {cols}×{rows} image",
            stored.len()
        )));
    }
    let (slope, intercept) = match rescale {
        Some(r) => r,
        None => file_rescale(&obj, frame),
    };
    let signed = decoded.pixel_representation() == dicom_pixeldata::PixelRepresentation::Signed;
    let padding = padding_range(&obj, signed, decoded.bits_stored());
    let hu = stored
        .iter()
        .map(|&v| match padding {
            Some((lo, hi)) if v >= lo && v <= hi => f32::MIN,
            _ => (v * slope + intercept) as f32,
        })
        .collect();
    Ok(DecodedImage { rows, cols, hu })
}

/// RescaleSlope/Intercept of a frame as the file states them (1 and 0 when absent).
fn file_rescale(obj: &InMemDicomObject, frame: Option<u32>) -> (f64, f64) {
    let g = FrameGroups::new(obj, frame.map(|k| k as usize));
    let get = |tag| {
        g.floats(tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE, tag, "")
            .ok()
            .flatten()
            .and_then(|v| v.first().copied())
    };
    (
        get(tags::RESCALE_SLOPE).unwrap_or(1.0),
        get(tags::RESCALE_INTERCEPT).unwrap_or(0.0),
    )
}

/// What to do about decoder limitations we know of.
fn hint(why: &str) -> &'static str {
    if why.contains("SamplePrecision(12)") {
        // jpeg-decoder (dicom-pixeldata's native JPEG codec) decodes 12-bit lossless JPEG but
        // not 12-bit DCT (process 2 & 4).
        " (12-bit lossy JPEG is not supported by the built-in pure-Rust JPEG decoder; convert \
         the series to an uncompressed transfer syntax first, e.g. `dcmdjpeg` or \
         `gdcmconv --raw`)"
    } else {
        ""
    }
}

/// The stored-value range that marks padding, if the file declares one.
fn padding_range(obj: &InMemDicomObject, signed: bool, bits_stored: u16) -> Option<(f64, f64)> {
    let interpret = |v: i64| -> f64 {
        // PixelPaddingValue is US or SS; a US value written for signed pixels is a bit pattern.
        let bits = u32::from(bits_stored.clamp(1, 32));
        if signed && v >= 0 && bits < 64 && v >= (1i64 << (bits - 1)) && v < (1i64 << bits) {
            (v - (1i64 << bits)) as f64
        } else {
            v as f64
        }
    };
    let a = interpret(attr::int(obj, tags::PIXEL_PADDING_VALUE)?);
    let b = attr::int(obj, tags::PIXEL_PADDING_RANGE_LIMIT)
        .map(interpret)
        .unwrap_or(a);
    Some((a.min(b), a.max(b)))
}
