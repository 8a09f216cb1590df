//! Awkward inputs through the whole pipeline: objects cut by the image edge, on one slice
//! only, in a one-slice series, thousands of tiny islands, two objects touching on one slice.
//! Each must give a clear result (surfaces that meet the tolerance) or a clear error, never a
//! panic.

mod common;

use bskin::config::RunConfig;
use common::*;

fn disc(x: f64, y: f64, cx: f64, cy: f64, r: f64) -> f32 {
    if (x - cx).hypot(y - cy) <= r {
        1000.0
    } else {
        0.0
    }
}

fn run(images: &VecImages) -> bskin::Result<bskin::pipeline::RunSummary> {
    let tmp = tempfile::tempdir().unwrap();
    run_images(images, tmp.path(), &RunConfig::with_tolerance(0.5))
}

fn assert_met(s: &bskin::pipeline::RunSummary) {
    for r in &s.written.surfaces {
        assert!(
            r.tolerance_met,
            "surface {} max error {}",
            r.id, r.max_error_mm
        );
    }
}

#[test]
fn object_cut_by_the_image_edge() {
    // A cylinder whose axis runs along the left edge: every contour touches the border.
    let images = synthetic(8, 40, |_, x, y| disc(x, y, 0.0, 20.0, 10.0));
    let s = run(&images).unwrap();
    assert_eq!(s.written.surfaces.len(), 1);
    assert_met(&s);
}

#[test]
fn object_on_one_slice_only() {
    let images = synthetic(6, 40, |k, x, y| {
        if k == 3 {
            disc(x, y, 20.0, 20.0, 8.0)
        } else {
            0.0
        }
    });
    let s = run(&images).unwrap();
    // One contour capped half a slice below and above.
    assert_eq!(s.written.surfaces.len(), 1);
    assert_eq!(s.written.surfaces[0].curves, 3);
    assert_met(&s);
}

#[test]
fn series_of_a_single_slice() {
    let images = synthetic(1, 40, |_, x, y| disc(x, y, 20.0, 20.0, 8.0));
    let s = run(&images).unwrap();
    assert_eq!(s.written.surfaces.len(), 1);
    assert_met(&s);
}

#[test]
fn empty_segmentation_gives_no_surface_and_no_error() {
    let images = synthetic(5, 32, |_, _, _| -1000.0);
    let s = run(&images).unwrap();
    assert!(s.written.surfaces.is_empty());
    assert_eq!(s.input.contours, 0);
}

#[test]
fn thousands_of_tiny_islands() {
    // A 2-pixel checkerboard of speckles: all below the minimum area, dropped and counted.
    let images = synthetic(4, 200, |k, x, y| {
        if ((x as usize / 2) + (y as usize / 2) + k).is_multiple_of(2)
            && (x as usize).is_multiple_of(2)
            && (y as usize).is_multiple_of(2)
        {
            1000.0
        } else {
            0.0
        }
    });
    let s = run(&images).unwrap();
    assert!(
        s.input.dropped_small > 4000,
        "{} dropped",
        s.input.dropped_small
    );
    assert!(s.written.surfaces.is_empty());
    // With no minimum area they are kept and every one becomes a small closed surface.
    let mut config = RunConfig::with_tolerance(0.5);
    config.contour.min_area_mm2 = 0.0;
    let tmp = tempfile::tempdir().unwrap();
    let s = run_images(&images, tmp.path(), &config).unwrap();
    assert!(
        s.written.surfaces.len() > 1000,
        "{} surfaces",
        s.written.surfaces.len()
    );
    assert_met(&s);
}

#[test]
fn two_objects_that_touch_on_one_slice_only() {
    // Two cylinders that merge on slice 4 only: 2-to-1 then 1-to-2.
    let images = synthetic(9, 60, |k, x, y| {
        let gap = if k == 4 { 0.0 } else { 6.0 };
        disc(x, y, 30.0 - 9.0 - gap / 2.0, 30.0, 9.5).max(disc(
            x,
            y,
            30.0 + 9.0 + gap / 2.0,
            30.0,
            9.5,
        ))
    });
    let s = run(&images).unwrap();
    // Two below, the merged slice's region, two above.
    assert_eq!(
        s.written.surfaces.len(),
        5,
        "{:?}",
        s.written
            .surfaces
            .iter()
            .map(|r| r.slices)
            .collect::<Vec<_>>()
    );
    assert_met(&s);
}
