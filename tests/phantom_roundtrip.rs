//! Phantom → DICOM files → scan/select/decode must give back exactly what was generated:
//! positions, orientation, spacing, HU (noise-free), slice order whatever the file names; and a
//! tilted, unevenly spaced phantom must load with its tilt and gaps reported.

use std::path::Path;

use bskin::dicom::{decode_slice, scan, select_series, write_ct_series, WriteOptions};
use bskin::phantom::{generate, PhantomSpec, Shape};

fn small(shape: Shape) -> PhantomSpec {
    PhantomSpec {
        shape,
        rows: 60,
        cols: 64,
        pixel_spacing: [1.6, 1.5],
        slices: 14,
        slice_spacing: 6.5,
        noise_sd_hu: 0.0,
        ..PhantomSpec::default()
    }
}

fn roundtrip(spec: &PhantomSpec, dir: &Path) -> bskin::dicom::Series {
    let vol = generate(spec).unwrap();
    let opts = WriteOptions {
        description: format!("bskin phantom {}", spec.shape),
        seed: spec.seed,
        ..WriteOptions::default()
    };
    let paths = write_ct_series(dir, &vol.slices, &opts).unwrap();
    assert_eq!(paths.len(), spec.slices);
    let sc = scan(dir).unwrap();
    assert_eq!(sc.not_dicom, 0);
    assert!(sc.unreadable.is_empty(), "{:?}", sc.unreadable);
    let s = select_series(&sc, None, dir).unwrap().clone();
    assert_eq!(s.slices.len(), vol.slices.len());
    assert_eq!(s.description, opts.description);
    assert_eq!(s.modality, "CT");
    assert_eq!(s.spacing, spec.pixel_spacing);
    assert_eq!((s.rows, s.cols), (spec.rows, spec.cols));
    for (k, (h, want)) in s.slices.iter().zip(&vol.slices).enumerate() {
        // Exact: positions were rounded to 1 µm and printed in their shortest exact form.
        assert_eq!(h.frame, want.frame, "slice {k}");
        // The file written for slice k is the one sorted at k.
        assert_eq!(h.source.path, paths[k]);
        let img = decode_slice(&s, h, k).unwrap();
        assert_eq!(img.frame, want.frame);
        assert_eq!(img.spacing, want.spacing);
        assert_eq!(img.hu, want.hu, "HU differ on slice {k}");
    }
    s
}

#[test]
fn noise_free_phantom_round_trips_exactly_and_file_order_is_not_slice_order() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = small(Shape::TorusFlat);
    let s = roundtrip(&spec, tmp.path());
    assert!(s.problems.is_empty(), "{:?}", s.problems);
    assert_eq!(s.tilt_deg, 0.0);
    // Names are hashes: sorting by name must not give the slice order (else the test is weak).
    let mut by_name: Vec<_> = s.slices.iter().map(|h| h.source.path.clone()).collect();
    by_name.sort();
    let by_height: Vec<_> = s.slices.iter().map(|h| h.source.path.clone()).collect();
    assert_ne!(by_name, by_height);
}

#[test]
fn reversed_file_names_still_sort_by_position() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = small(Shape::TubeSplit);
    let vol = generate(&spec).unwrap();
    let opts = WriteOptions {
        shuffle_names: false,
        ..WriteOptions::default()
    };
    let paths = write_ct_series(tmp.path(), &vol.slices, &opts).unwrap();
    // Rename so that names (and InstanceNumbers' order, which stays) run backwards.
    let n = paths.len();
    for (k, p) in paths.iter().enumerate() {
        std::fs::rename(p, tmp.path().join(format!("z{:03}.tmp", n - k))).unwrap();
    }
    for k in 0..n {
        let from = tmp.path().join(format!("z{:03}.tmp", n - k));
        std::fs::rename(from, tmp.path().join(format!("{:03}.dcm", n - k))).unwrap();
    }
    let sc = scan(tmp.path()).unwrap();
    let s = select_series(&sc, None, tmp.path()).unwrap();
    for (k, h) in s.slices.iter().enumerate() {
        assert_eq!(h.frame.origin, vol.slices[k].frame.origin);
        assert_eq!(h.source.path, tmp.path().join(format!("{:03}.dcm", n - k)));
        assert_eq!(h.instance_number, Some(k as i64 + 1));
    }
    let img = decode_slice(s, &s.slices[5], 5).unwrap();
    assert_eq!(img.hu, vol.slices[5].hu);
}

#[test]
fn tilted_uneven_phantom_reports_tilt_and_gaps() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = PhantomSpec {
        tilt_deg: 18.5,
        uneven: true,
        noise_sd_hu: 20.0,
        ..small(Shape::TubesCrossing)
    };
    let vol = generate(&spec).unwrap();
    write_ct_series(tmp.path(), &vol.slices, &WriteOptions::default()).unwrap();
    let sc = scan(tmp.path()).unwrap();
    let s = select_series(&sc, None, tmp.path()).unwrap();
    assert!((s.tilt_deg - 18.5).abs() < 1e-3, "tilt {}", s.tilt_deg);
    assert!(
        s.problems.iter().any(|p| p.contains("gantry tilt 18.50°")),
        "{:?}",
        s.problems
    );
    let gaps = s
        .problems
        .iter()
        .find(|p| p.contains("uneven slice spacing"))
        .unwrap_or_else(|| panic!("{:?}", s.problems));
    // 14 slices, pattern ×[1, .75, 1, 2.5, 1, 1.25]: the 2.5× gaps are the 4th and 10th.
    assert!(gaps.contains("2 gap(s) > 1.5× median"), "{gaps}");
    for (k, h) in s.slices.iter().enumerate() {
        assert_eq!(h.frame, vol.slices[k].frame);
    }
    // Noisy values round-trip too (they are whole numbers).
    let img = decode_slice(s, &s.slices[7], 7).unwrap();
    assert_eq!(img.hu, vol.slices[7].hu);
}

#[test]
fn every_shape_writes_and_reads() {
    for shape in Shape::ALL {
        let tmp = tempfile::tempdir().unwrap();
        let spec = PhantomSpec {
            rows: 24,
            cols: 24,
            pixel_spacing: [4.0, 4.0],
            slices: 5,
            slice_spacing: 15.0,
            ..small(shape)
        };
        let s = roundtrip(&spec, tmp.path());
        assert!(s.description.ends_with(shape.name()));
    }
}
