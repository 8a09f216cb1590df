//! The real CT series in `../shared/data/ct/` must scan, select and decode, with their known
//! traps reported (GE: gantry tilt and variable spacing; Siemens: empty UIDs, JPEG 2000).
//! Skipped with a message when the shared data is absent.

mod common;
use common::shared;

use std::time::Instant;

use bskin::dicom::{decode_slice, scan, select_series, Series};

/// Decodes every slice; returns (min HU ignoring padding, max HU, padding pixels, seconds).
fn decode_all(series: &Series) -> (f32, f32, usize, f64) {
    let t = Instant::now();
    let (mut lo, mut hi, mut pad) = (f32::MAX, f32::MIN, 0usize);
    for (i, s) in series.slices.iter().enumerate() {
        let img = decode_slice(series, s, i).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(img.hu.len(), series.rows * series.cols);
        assert_eq!(img.index, i);
        for &v in &img.hu {
            if v == f32::MIN {
                pad += 1;
            } else {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    (lo, hi, pad, t.elapsed().as_secs_f64())
}

fn report(name: &str, s: &Series, fig: (f32, f32, usize, f64)) {
    eprintln!(
        "{name}: {} slices, {:?}, spacing {:?}, tilt {:.2}°, HU {}..{}, {} padding px, decode {:.2} s\n  problems: {:#?}",
        s.slices.len(),
        s.transfer_syntaxes,
        s.slice_spacing,
        s.tilt_deg,
        fig.0,
        fig.1,
        fig.2,
        fig.3,
        s.problems
    );
}

fn assert_sorted(s: &Series) {
    for w in s.slices.windows(2) {
        assert!(
            w[1].height > w[0].height,
            "{} not above {}",
            w[1].source,
            w[0].source
        );
    }
}

#[test]
fn philips_skull_phantom() {
    let Some(dir) = shared("ct/philips-skull-phantom-1mm") else {
        return;
    };
    let t = Instant::now();
    let sc = scan(&dir).unwrap();
    eprintln!("scan {}: {:.2} s", dir.display(), t.elapsed().as_secs_f64());
    assert_eq!(
        sc.series.len(),
        1,
        "{:#?}",
        sc.series.iter().map(|s| s.summary()).collect::<Vec<_>>()
    );
    let s = select_series(&sc, None, &dir).unwrap();
    assert_eq!(s.slices.len(), 140);
    assert_eq!((s.rows, s.cols), (512, 512));
    assert_sorted(s);
    let st = s.slice_spacing.unwrap();
    assert!((st.median - 1.0).abs() < 0.01, "{st:?}");
    assert!(s.tilt_deg < 0.1);
    assert!(s.errors.is_empty());
    let fig = decode_all(s);
    report("philips", s, fig);
    assert!(fig.0 < -900.0 && fig.1 > 300.0, "{fig:?}");
}

#[test]
fn ge_head_tilt_and_variable_spacing() {
    let Some(dir) = shared("ct/ge-human-head-tilt-variable-spacing") else {
        return;
    };
    let t = Instant::now();
    let sc = scan(&dir).unwrap();
    eprintln!("scan {}: {:.2} s", dir.display(), t.elapsed().as_secs_f64());
    let s = select_series(&sc, None, &dir).unwrap();
    assert_eq!(s.slices.len(), 28);
    assert_sorted(s);
    assert!((s.tilt_deg - 18.5).abs() < 0.3, "tilt {}", s.tilt_deg);
    assert!(
        s.problems.iter().any(|p| p.contains("gantry tilt")),
        "{:?}",
        s.problems
    );
    assert!(
        s.problems
            .iter()
            .any(|p| p.contains("uneven slice spacing")),
        "{:?}",
        s.problems
    );
    let fig = decode_all(s);
    report("ge", s, fig);
    assert!(fig.0 < -900.0 && fig.1 > 300.0, "{fig:?}");
}

#[test]
fn siemens_abdomen_empty_uids_j2k() {
    let Some(dir) = shared("ct/siemens-abdomen-20-j2k-empty-uids") else {
        return;
    };
    let t = Instant::now();
    let sc = scan(&dir).unwrap();
    eprintln!("scan {}: {:.2} s", dir.display(), t.elapsed().as_secs_f64());
    assert_eq!(sc.series.len(), 1);
    let s = select_series(&sc, None, &dir).unwrap();
    assert_eq!(s.uid, None);
    assert!(s.key.starts_with("dir="), "{}", s.key);
    assert!(s
        .problems
        .iter()
        .any(|p| p.contains("SeriesInstanceUID is empty")));
    assert_eq!(s.slices.len(), 20);
    assert!(
        s.transfer_syntaxes.iter().any(|t| t.contains("2000")),
        "{:?}",
        s.transfer_syntaxes
    );
    assert_sorted(s);
    let fig = decode_all(s);
    report("siemens", s, fig);
    assert!(fig.0 < -900.0 && fig.1 > 300.0, "{fig:?}");
}

#[test]
fn whole_ct_folder_is_ambiguous_and_lists_series() {
    let Some(dir) = shared("ct") else {
        return;
    };
    let t = Instant::now();
    let sc = scan(&dir).unwrap();
    eprintln!("scan {}: {:.2} s", dir.display(), t.elapsed().as_secs_f64());
    assert_eq!(sc.series.len(), 3);
    let e = select_series(&sc, None, &dir).unwrap_err();
    let m = e.to_string();
    assert!(matches!(e, bskin::Error::AmbiguousSeries { .. }), "{m}");
    assert!(m.contains("--series") && m.contains("140 slice"), "{m}");
}
