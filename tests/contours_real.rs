//! The real CT series in `../shared/data/ct/` give contours (the tilted, variable-spacing and
//! JPEG 2000 ones included). Skipped with a message when the shared data is absent.

use std::path::{Path, PathBuf};
use std::time::Instant;

use bskin::config::ContoursConfig;
use bskin::dicom;
use bskin::geometry::polygon::{is_simple, signed_area};
use bskin::pipeline::run_contours;
use bskin::stages::Control;

fn shared(sub: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(sub);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipped: shared data not found at {}", p.display());
        None
    }
}

fn contours_of(sub: &str, slices: usize) {
    let Some(dir) = shared(sub) else { return };
    let t = Instant::now();
    let scan = dicom::scan(&dir).unwrap();
    let series = dicom::select_series(&scan, None, &dir).unwrap().clone();
    let mut last_height = f64::NEG_INFINITY;
    let summary = run_contours(
        &series,
        &ContoursConfig::default(),
        &Control::new(),
        &mut |c| {
            let s = &c.section;
            assert!(
                s.frame.height() > last_height,
                "{sub}: sections in ascending height"
            );
            last_height = s.frame.height();
            for k in &s.contours {
                assert!(
                    k.points.len() >= 3 && is_simple(&k.points),
                    "{sub}: slice {} contour not simple",
                    s.index
                );
                assert_eq!(
                    signed_area(&k.points) < 0.0,
                    k.hole,
                    "{sub}: slice {} orientation",
                    s.index
                );
            }
            Ok(())
        },
    )
    .unwrap();
    eprintln!(
        "{sub}: {} slices, {} contours ({} holes), {} points before compression, {} after, {:.2} s",
        summary.sections,
        summary.contours,
        summary.holes,
        summary.points_raw,
        summary.points_compressed,
        t.elapsed().as_secs_f64()
    );
    assert_eq!(summary.sections, slices);
    assert!(summary.contours > slices / 2, "{sub}: bone on most slices");
    assert!(
        summary.points_compressed < summary.points_raw,
        "{sub}: compression"
    );
}

#[test]
fn philips_skull_phantom() {
    contours_of("ct/philips-skull-phantom-1mm", 140);
}

#[test]
fn ge_head_tilted_variable_spacing() {
    contours_of("ct/ge-human-head-tilt-variable-spacing", 28);
}

#[test]
fn siemens_abdomen_jpeg2000_empty_uids() {
    contours_of("ct/siemens-abdomen-20-j2k-empty-uids", 20);
}
