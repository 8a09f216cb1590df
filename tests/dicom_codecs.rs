//! Decoder tests on single images: the NEMA WG04 set in `../shared/data/codecs/` (REF vs each
//! codec, lossless exactly) and pydicom's odd files (no preamble, no file meta, big endian,
//! truncated). Skipped with a message when the shared data is absent.

mod common;
use common::shared;

use std::path::PathBuf;

use bskin::dicom::{decode_file, scan, DecodedImage};

/// (max, mean) |Δ| between two decoded images of the same size, over the pixels that are
/// padding in neither (lossy codecs may move a value onto or off the padding value).
fn diff(a: &DecodedImage, b: &DecodedImage) -> (f32, f64) {
    assert_eq!((a.rows, a.cols), (b.rows, b.cols));
    let mut max = 0f32;
    let mut sum = 0f64;
    let mut n = 0usize;
    for (x, y) in a.hu.iter().zip(&b.hu) {
        if *x == f32::MIN || *y == f32::MIN {
            continue;
        }
        let d = (x - y).abs();
        max = max.max(d);
        sum += d as f64;
        n += 1;
    }
    (max, sum / n.max(1) as f64)
}

/// Value range of an image (padding excluded).
fn range(a: &DecodedImage) -> f32 {
    let v = a.hu.iter().filter(|v| **v != f32::MIN);
    let (lo, hi) = v.fold((f32::MAX, f32::MIN), |(lo, hi), x| (lo.min(*x), hi.max(*x)));
    hi - lo
}

/// Codec/image pairs our decoders are known to fail on, with the text of the error.
fn known_failure(image: &str, codec: &str) -> Option<&'static str> {
    match (image, codec) {
        // jpeg-decoder: no 12-bit DCT (JPEG process 4); all NEMA JPLY images are 12-bit.
        (_, "JPLY") => Some("SamplePrecision(12)"),
        // CharLS rejects this stream (it carries non-default LSE preset thresholds).
        ("MR1", "JLSL") => Some("JPEG-LS"),
        _ => None,
    }
}

#[test]
fn nema_wg04_every_codec_against_ref() {
    let Some(root) = shared("codecs") else {
        return;
    };
    // (folder, lossy bound on the mean |Δ| as a fraction of the image's value range, or None
    // for lossless: exact equality)
    let codecs: [(&str, Option<f64>); 7] = [
        ("RLE", None),
        ("JPLL", None),
        ("JLSL", None),
        ("J2KR", None),
        ("JLSN", Some(0.01)),
        ("J2KI", Some(0.03)),
        ("JPLY", Some(0.03)),
    ];
    let mut failures = Vec::new();
    for image in ["CT1", "CT2", "MR1", "MR2", "MR3", "MR4", "NM1"] {
        let reference = decode_file(&root.join("REF").join(format!("{image}_UNC")), None)
            .unwrap_or_else(|e| panic!("{e}"));
        for (codec, bound) in codecs {
            let path = root.join(codec).join(format!("{image}_{codec}"));
            if !path.exists() {
                continue;
            }
            match decode_file(&path, None) {
                Ok(img) => {
                    let (max, mean) = diff(&img, &reference);
                    let r = range(&reference) as f64;
                    eprintln!(
                        "{image} {codec}: max |Δ| {max}, mean {mean:.3} ({:.4} of range {r})",
                        mean / r
                    );
                    match bound {
                        None if max != 0.0 => {
                            failures.push(format!("{image} {codec}: lossless but max |Δ| {max}"))
                        }
                        Some(b) if mean > b * r => failures.push(format!(
                            "{image} {codec}: mean |Δ| {mean} > {b} × range {r}"
                        )),
                        _ => {}
                    }
                }
                Err(e) => {
                    let m = e.to_string();
                    match known_failure(image, codec) {
                        Some(why) if m.contains(why) => {
                            eprintln!("{image} {codec}: KNOWN FAILURE: {m}")
                        }
                        _ => failures.push(format!("{image} {codec}: {m}")),
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn pydicom_odd_files_scan_without_panic() {
    let Some(dir) = shared("codecs/pydicom-test-files") else {
        return;
    };
    let sc = scan(&dir).unwrap();
    eprintln!(
        "pydicom-test-files: {} files, {} not DICOM, {} unreadable, {} series",
        sc.files,
        sc.not_dicom,
        sc.unreadable.len(),
        sc.series.len()
    );
    for (p, why) in &sc.unreadable {
        eprintln!("  unreadable {}: {why}", p.display());
    }
    for n in &sc.notes {
        eprintln!("  note: {n}");
    }
    let name_of = |p: &std::path::Path| p.file_name().unwrap().to_string_lossy().to_string();
    // Explicit VR files without preamble or file meta (little and big endian) are recognised
    // as DICOM; they happen to be RT plans, so they are non-image objects, not unreadable.
    for name in ["ExplVR_LitEndNoMeta.dcm", "ExplVR_BigEndNoMeta.dcm"] {
        assert!(
            sc.non_image.iter().any(|(p, _)| name_of(p) == name),
            "{name} not recognised as a DICOM non-image object"
        );
    }
    // Truncated files are reported naming the file.
    assert!(sc
        .unreadable
        .iter()
        .any(|(p, _)| name_of(p) == "rtplan_truncated.dcm"));
    assert!(sc.series.iter().any(|s| s
        .slices
        .iter()
        .any(|h| name_of(&h.source.path) == "CT_small.dcm")));
}

/// Writes `src`'s data set without preamble and meta (bare), and with meta but no preamble.
fn strip(src: &std::path::Path, dir: &std::path::Path) -> (PathBuf, PathBuf) {
    use dicom_dictionary_std::uids;
    use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};
    let obj = dicom_object::open_file(src).unwrap();
    let ts = TransferSyntaxRegistry
        .get(uids::EXPLICIT_VR_LITTLE_ENDIAN)
        .unwrap();
    assert_eq!(
        obj.meta().transfer_syntax(),
        uids::EXPLICIT_VR_LITTLE_ENDIAN
    );
    let bare = dir.join("bare.dcm");
    let mut f = std::fs::File::create(&bare).unwrap();
    obj.write_dataset_with_ts(&mut f, ts).unwrap();
    let no_preamble = dir.join("no_preamble.dcm");
    let mut f = std::fs::File::create(&no_preamble).unwrap();
    obj.write_meta(&mut f).unwrap();
    obj.write_dataset_with_ts(&mut f, ts).unwrap();
    (bare, no_preamble)
}

#[test]
fn files_without_preamble_or_meta_decode() {
    let Some(dir) = shared("codecs/pydicom-test-files") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let (bare, no_preamble) = strip(&dir.join("CT_small.dcm"), tmp.path());
    let reference = decode_file(&dir.join("CT_small.dcm"), None).unwrap();
    for p in [&bare, &no_preamble] {
        assert_eq!(decode_file(p, None).unwrap(), reference, "{}", p.display());
    }
    let sc = scan(tmp.path()).unwrap();
    assert_eq!(sc.not_dicom, 0);
    assert!(sc.unreadable.is_empty(), "{:?}", sc.unreadable);
    assert_eq!(sc.series.len(), 1);
    assert_eq!(sc.series[0].slices.len(), 1, "duplicate position: one kept");
}

#[test]
fn pydicom_mr_small_variants_decode_alike() {
    let Some(dir) = shared("codecs/pydicom-test-files") else {
        return;
    };
    let reference = decode_file(&dir.join("MR_small.dcm"), None).unwrap_or_else(|e| panic!("{e}"));
    for name in [
        "MR_small_implicit.dcm",
        "MR_small_bigendian.dcm",
        "MR_small_expb.dcm",
        "MR_small_RLE.dcm",
        "MR_small_jp2klossless.dcm",
        "MR_small_jpeg_ls_lossless.dcm",
    ] {
        let img = decode_file(&dir.join(name), None).unwrap_or_else(|e| panic!("{e}"));
        let (max, _) = diff(&img, &reference);
        assert_eq!(max, 0.0, "{name}");
    }
    // A truncated file is an error naming it, not a panic.
    let e = decode_file(&dir.join("MR_truncated.dcm"), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("MR_truncated.dcm"), "{e}");
}
