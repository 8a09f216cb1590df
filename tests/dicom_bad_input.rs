//! Bad input never panics: non-DICOM files are counted, truncated files and missing or absurd
//! attributes are reported naming the file, and selection refuses what cannot be processed.

use std::path::{Path, PathBuf};

use bskin::dicom::{decode_slice, scan, select_series, write_ct_series, WriteOptions};
use bskin::phantom::{generate, PhantomSpec, Shape};
use dicom_core::value::PrimitiveValue;
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::tags;

fn phantom(dir: &Path, seed: u64, number: i32) -> Vec<PathBuf> {
    let spec = PhantomSpec {
        shape: Shape::Blobs,
        rows: 32,
        cols: 32,
        pixel_spacing: [3.0, 3.0],
        slices: 6,
        slice_spacing: 12.0,
        seed,
        ..PhantomSpec::default()
    };
    let vol = generate(&spec).unwrap();
    let opts = WriteOptions {
        seed,
        series_number: number,
        ..WriteOptions::default()
    };
    write_ct_series(dir, &vol.slices, &opts).unwrap()
}

/// Rewrites `path` after `f` edits its data set.
fn edit(path: &Path, f: impl FnOnce(&mut dicom_object::InMemDicomObject)) {
    let mut obj = dicom_object::open_file(path).unwrap();
    f(&mut obj);
    obj.write_to_file(path).unwrap();
}

#[test]
fn non_dicom_files_are_counted_not_fatal() {
    let tmp = tempfile::tempdir().unwrap();
    phantom(tmp.path(), 1, 1);
    std::fs::write(tmp.path().join("README.txt"), "not an image").unwrap();
    std::fs::write(tmp.path().join("empty"), b"").unwrap();
    std::fs::create_dir(tmp.path().join("sub")).unwrap();
    std::fs::write(tmp.path().join("sub/noise.bin"), vec![0xA5u8; 4000]).unwrap();
    let sc = scan(tmp.path()).unwrap();
    assert_eq!(sc.not_dicom, 3);
    assert_eq!(sc.files, 9);
    assert!(select_series(&sc, None, tmp.path()).is_ok());
}

#[test]
fn only_non_dicom_gives_no_series_saying_what_was_found() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("a.txt"), "hello").unwrap();
    std::fs::write(tmp.path().join("b.txt"), "world").unwrap();
    let sc = scan(tmp.path()).unwrap();
    let e = select_series(&sc, None, tmp.path()).unwrap_err();
    assert!(matches!(e, bskin::Error::NoSeries { .. }));
    let m = e.to_string();
    assert!(m.contains("2 file(s), 2 not DICOM"), "{m}");
}

#[test]
fn missing_directory_is_an_io_error() {
    let e = scan(Path::new("/nonexistent/bskin-test")).unwrap_err();
    assert!(matches!(e, bskin::Error::Io { .. }), "{e}");
}

#[test]
fn truncated_files_are_reported_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let paths = phantom(tmp.path(), 2, 1);
    // Cut inside the header: the scan cannot read it.
    let head_cut = &paths[1];
    let bytes = std::fs::read(head_cut).unwrap();
    std::fs::write(head_cut, &bytes[..400]).unwrap();
    // Cut inside the pixel data: headers read fine, decoding must fail with the file name.
    let pix_cut = &paths[3];
    let bytes = std::fs::read(pix_cut).unwrap();
    std::fs::write(pix_cut, &bytes[..bytes.len() - 700]).unwrap();

    let sc = scan(tmp.path()).unwrap();
    assert_eq!(sc.unreadable.len(), 1, "{:?}", sc.unreadable);
    assert_eq!(&sc.unreadable[0].0, head_cut);
    eprintln!("header cut: {}", sc.unreadable[0].1);
    let s = select_series(&sc, None, tmp.path()).unwrap();
    assert_eq!(s.slices.len(), 5);
    let mut failed = 0;
    for (i, h) in s.slices.iter().enumerate() {
        if let Err(e) = decode_slice(s, h, i) {
            let m = e.to_string();
            eprintln!("pixel cut: {m}");
            assert!(m.contains(&pix_cut.display().to_string()), "{m}");
            failed += 1;
        }
    }
    assert_eq!(failed, 1);
}

#[test]
fn missing_position_refuses_the_series_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let paths = phantom(tmp.path(), 3, 1);
    edit(&paths[2], |o| {
        o.remove_element(tags::IMAGE_POSITION_PATIENT);
    });
    let sc = scan(tmp.path()).unwrap();
    let s = &sc.series[0];
    assert_eq!(s.errors.len(), 1);
    assert_eq!(s.errors[0].0, paths[2]);
    let e = select_series(&sc, None, tmp.path()).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains(&paths[2].display().to_string()) && m.contains("ImagePositionPatient"),
        "{m}"
    );
}

#[test]
fn inconsistent_or_absurd_geometry_is_an_error_naming_the_file() {
    type Edit = fn(&mut dicom_object::InMemDicomObject);
    let cases: [(&str, Edit); 4] = [
        ("PixelSpacing", |o| {
            o.put(DataElement::new(
                tags::PIXEL_SPACING,
                VR::DS,
                PrimitiveValue::from("2.5\\2.5"),
            ));
        }),
        ("not orthogonal", |o| {
            o.put(DataElement::new(
                tags::IMAGE_ORIENTATION_PATIENT,
                VR::DS,
                PrimitiveValue::from("1\\0\\0\\0.6\\0.8\\0"),
            ));
        }),
        ("PixelSpacing", |o| {
            o.put(DataElement::new(
                tags::PIXEL_SPACING,
                VR::DS,
                PrimitiveValue::from("0\\-1"),
            ));
        }),
        ("not unit", |o| {
            o.put(DataElement::new(
                tags::IMAGE_ORIENTATION_PATIENT,
                VR::DS,
                PrimitiveValue::from("2\\0\\0\\0\\1\\0"),
            ));
        }),
    ];
    for (want, f) in cases {
        let tmp = tempfile::tempdir().unwrap();
        let paths = phantom(tmp.path(), 4, 1);
        edit(&paths[4], f);
        let sc = scan(tmp.path()).unwrap();
        let e = select_series(&sc, None, tmp.path()).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains(&paths[4].display().to_string()) && m.contains(want),
            "{want}: {m}"
        );
    }
}

#[test]
fn duplicate_positions_keep_the_first() {
    let tmp = tempfile::tempdir().unwrap();
    let paths = phantom(tmp.path(), 5, 1);
    let copy = tmp.path().join("zzzz-copy.dcm");
    std::fs::copy(&paths[2], &copy).unwrap();
    let sc = scan(tmp.path()).unwrap();
    let s = select_series(&sc, None, tmp.path()).unwrap();
    assert_eq!(s.slices.len(), 6);
    assert!(s.slices.iter().all(|h| h.source.path != copy));
    assert!(
        s.problems
            .iter()
            .any(|p| p.contains("duplicate") && p.contains("zzzz-copy.dcm")),
        "{:?}",
        s.problems
    );
}

#[test]
fn several_series_need_a_selector() {
    let tmp = tempfile::tempdir().unwrap();
    phantom(&tmp.path().join("a"), 10, 3);
    phantom(&tmp.path().join("b"), 11, 4);
    let sc = scan(tmp.path()).unwrap();
    assert_eq!(sc.series.len(), 2);
    let e = select_series(&sc, None, tmp.path()).unwrap_err();
    assert!(matches!(e, bskin::Error::AmbiguousSeries { .. }));
    let m = e.to_string();
    assert!(
        m.contains("#3 ") && m.contains("#4 ") && m.contains("--series"),
        "{m}"
    );
    let s = select_series(&sc, Some("4"), tmp.path()).unwrap();
    assert_eq!(s.number, Some(4));
    let uid = s.uid.clone().unwrap();
    assert_eq!(
        select_series(&sc, Some(&uid), tmp.path()).unwrap().uid,
        Some(uid)
    );
    let e = select_series(&sc, Some("99"), tmp.path()).unwrap_err();
    assert!(matches!(e, bskin::Error::NoSeries { .. }), "{e}");
}

#[test]
fn localizer_is_not_volumetric() {
    let tmp = tempfile::tempdir().unwrap();
    let paths = phantom(tmp.path(), 12, 1);
    for p in &paths {
        edit(p, |o| {
            o.put(DataElement::new(
                tags::IMAGE_TYPE,
                VR::CS,
                PrimitiveValue::from("ORIGINAL\\PRIMARY\\LOCALIZER"),
            ));
        });
    }
    let sc = scan(tmp.path()).unwrap();
    assert!(sc.series[0].localizer);
    let m = select_series(&sc, None, tmp.path())
        .unwrap_err()
        .to_string();
    assert!(m.contains("1 localizer(s) skipped"), "{m}");
}

#[test]
fn localizer_inside_an_axial_series_is_dropped_with_a_note() {
    let tmp = tempfile::tempdir().unwrap();
    let paths = phantom(tmp.path(), 13, 1);
    edit(&paths[0], |o| {
        o.put(DataElement::new(
            tags::IMAGE_TYPE,
            VR::CS,
            PrimitiveValue::from("ORIGINAL\\PRIMARY\\LOCALIZER"),
        ));
        o.put(DataElement::new(
            tags::IMAGE_ORIENTATION_PATIENT,
            VR::DS,
            PrimitiveValue::from("1\\0\\0\\0\\0\\-1"),
        ));
    });
    let sc = scan(tmp.path()).unwrap();
    let s = select_series(&sc, None, tmp.path()).unwrap();
    assert_eq!(s.slices.len(), 5);
    assert!(
        s.problems
            .iter()
            .any(|p| p.contains("1 localizer image(s)")),
        "{:?}",
        s.problems
    );
    assert!(sc.summary().contains("5 slice(s)"), "{}", sc.summary());
}

#[test]
fn write_options_for_phantom_name_the_shape() {
    let spec = PhantomSpec {
        shape: Shape::TorusStanding,
        seed: 9,
        ..PhantomSpec::default()
    };
    let o = WriteOptions::for_phantom(&spec);
    assert_eq!(o.description, "bskin phantom torus-standing");
    assert_eq!(o.seed, 9);
}
