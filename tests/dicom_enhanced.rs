//! Enhanced (multi-frame) MR: one file, many frames, per-frame positions from the functional
//! groups. Each frame becomes a slice `SliceSource { path, frame: Some(k) }`. Skipped with a
//! message when the shared data is absent.

mod common;
use common::shared;

use bskin::dicom::{decode_slice, scan, select_series};

fn check(sub: &str) {
    let Some(dir) = shared(sub) else {
        return;
    };
    let sc = scan(&dir).unwrap();
    for s in &sc.series {
        eprintln!(
            "{sub}: {} problems {:?} errors {:?} spacing {:?}",
            s.summary(),
            s.problems,
            s.errors,
            s.slice_spacing
        );
    }
    let s = select_series(&sc, None, &dir).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.slices.len(), 8);
    assert_eq!((s.rows, s.cols), (256, 256));
    // Sorted along the normal, one file, distinct frames.
    for w in s.slices.windows(2) {
        assert!(w[1].height > w[0].height);
        assert_eq!(w[0].source.path, w[1].source.path);
    }
    let mut frames: Vec<u32> = s.slices.iter().map(|h| h.source.frame.unwrap()).collect();
    frames.sort();
    frames.dedup();
    assert_eq!(frames.len(), 8);
    for (i, h) in s.slices.iter().enumerate() {
        let img = decode_slice(s, h, i).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(img.hu.len(), 256 * 256);
        let max = img.hu.iter().copied().fold(f32::MIN, f32::max);
        assert!(max > 0.0, "frame {} is empty", h.source.frame.unwrap());
    }
}

#[test]
fn philips_enhanced_mr() {
    check("mr/enhanced-multiframe/philips_enhanced");
}

#[test]
fn siemens_multiframe_mr() {
    check("mr/enhanced-multiframe/siemens_multiframe");
}
