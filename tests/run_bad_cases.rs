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
fn empty_segmentation_is_an_error_and_writes_nothing() {
    let images = synthetic(5, 32, |_, _, _| -1000.0);
    let tmp = tempfile::tempdir().unwrap();
    let e = run_images(&images, tmp.path(), &RunConfig::with_tolerance(0.5)).unwrap_err();
    assert!(
        matches!(
            e,
            bskin::Error::EmptySegmentation {
                sections: 5,
                dropped: 0
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("nothing was written"), "{e}");
    let left: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
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
    // All dropped: an empty segmentation, which says how many it dropped.
    match run(&images) {
        Err(bskin::Error::EmptySegmentation { dropped, .. }) => {
            assert!(dropped > 4000, "{dropped} dropped")
        }
        other => panic!(
            "expected an empty segmentation, got {:?}",
            other.map(|_| ())
        ),
    }
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

/// The error of `run`, which must fail, run on a thread so that a hang fails the test (after
/// 120 s) instead of stalling it.
fn error_in_time(what: &str, run: impl FnOnce() -> bskin::Result<()> + Send + 'static) -> String {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(run().map_err(|e| e.to_string()));
    });
    rx.recv_timeout(std::time::Duration::from_secs(120))
        .unwrap_or_else(|_| panic!("{what}: the run did not end within 120 s"))
        .expect_err(what)
}

#[test]
fn a_stage_that_fails_mid_run_ends_the_run_with_its_error() {
    // One disc, then two, then one...: every transition is a branching problem, so the
    // later stages are slower than loading and segmentation, which run ahead until the
    // channels are full and they wait to send. Slice 40 of 60 lies below slice 39, so
    // correspondence fails there. Every stage must then stop: one left waiting to send into a
    // channel that nobody reads would hang the run.
    let mut images = synthetic(60, 48, |k, x, y| {
        if k % 2 == 0 {
            disc(x, y, 24.0, 24.0, 12.0)
        } else {
            disc(x, y, 15.0, 24.0, 6.0).max(disc(x, y, 33.0, 24.0, 6.0))
        }
    });
    images.0[40].frame.origin[2] = 38.5;
    let e = error_in_time("a slice out of order", move || {
        let tmp = tempfile::tempdir().unwrap();
        run_images(&images, tmp.path(), &RunConfig::with_tolerance(0.5)).map(|_| ())
    });
    assert!(e.contains("ascending") && e.contains("synthetic/40"), "{e}");
}

#[test]
fn a_writer_that_fails_at_once_ends_the_run_with_its_error() {
    // The output "directory" is a file, so the writers fail before reading a surface. Every
    // stage upstream must then stop (its channel is closed), down to the loader, which has
    // far more slices than the channels hold.
    let images = synthetic(60, 40, |_, x, y| disc(x, y, 20.0, 20.0, 8.0));
    let tmp = tempfile::tempdir().unwrap();
    let not_a_dir = tmp.path().join("file");
    std::fs::write(&not_a_dir, b"x").unwrap();
    let e = error_in_time("writing under a file", move || {
        bskin::pipeline::run_surfaces(
            bskin::pipeline::RunInput::Images(&images),
            &RunConfig::with_tolerance(0.5),
            &not_a_dir,
            &bskin::stages::Control::new(),
            &|_| {},
        )
        .map(|_| ())
    });
    assert!(e.contains("file"), "{e}");
}

#[test]
fn a_contour_sink_that_fails_ends_the_run_with_its_error() {
    // `bskin contours` into a closed pipe: the sink fails on the first section, by which time
    // extraction has filled the channel and waits to send. It must stop, not hang.
    let images = synthetic(60, 48, |_, x, y| disc(x, y, 24.0, 24.0, 12.0));
    let e = error_in_time("a failing sink", move || {
        let mut sink = |_: &bskin::stages::s2_contours::CompiledSection| -> bskin::Result<()> {
            std::thread::sleep(std::time::Duration::from_millis(200));
            Err(bskin::Error::Internal("the sink is closed".into()))
        };
        bskin::pipeline::run_contours(
            &images,
            &bskin::config::ContoursConfig::default(),
            &bskin::stages::Control::new(),
            &mut sink,
        )
        .map(|_| ())
    });
    assert!(e.contains("the sink is closed"), "{e}");
}
