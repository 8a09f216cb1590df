//! Input compilation on the project's phantoms: contour points against the analytic surface
//! (noise-free and with the default noise), holes and orientation, and independence from file
//! order and thread count.

mod common;

use bskin::config::ContoursConfig;
use bskin::dicom::{self, WriteOptions};
use bskin::geometry::polygon::{is_simple, signed_area};
use bskin::io::ndjson::{NdjsonWriter, SeriesRecord};
use bskin::phantom::{generate, PhantomSpec, Shape};
use bskin::pipeline::run_contours;
use bskin::stages::Control;
use bskin::Section;

fn compile(spec: &PhantomSpec, shuffle_names: bool) -> (Vec<Section>, Vec<u8>) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("series");
    let vol = generate(spec).unwrap();
    let opts = WriteOptions {
        shuffle_names,
        ..WriteOptions::for_phantom(spec)
    };
    dicom::write_ct_series(&dir, &vol.slices, &opts).unwrap();
    let scan = dicom::scan(&dir).unwrap();
    let series = dicom::select_series(&scan, None, &dir).unwrap().clone();
    let config = ContoursConfig::default();
    let header = SeriesRecord::new(&Default::default(), &config.contour);
    let mut w = NdjsonWriter::new(Vec::new(), &header).unwrap();
    let mut sections = Vec::new();
    run_contours(&series, &config, &Control::new(), &mut |c| {
        // File names differ between namings; everything else must not.
        let mut s = c.section.clone();
        s.source = Default::default();
        w.write_section(&s).unwrap();
        sections.push(c.section.clone());
        Ok(())
    })
    .unwrap();
    (sections, w.finish().unwrap())
}

/// Largest distance of a contour point (3-D, patient mm) to the analytic surface.
fn max_surface_distance(shape: Shape, sections: &[Section]) -> (f64, usize) {
    let mut worst = 0.0f64;
    let mut n = 0;
    for s in sections {
        for c in &s.contours {
            for &p in &c.points {
                worst = worst.max(shape.signed_distance(s.frame.to_patient(p)).abs());
                n += 1;
            }
        }
    }
    (worst, n)
}

#[test]
fn contour_points_lie_on_the_analytic_surface() {
    // 0.5 mm pixels: linear interpolation across a partly covered pixel biases a crossing by
    // up to ~0.09 pixel, and concave creases of the unions add to it.
    let fine = PhantomSpec {
        rows: 192,
        cols: 192,
        pixel_spacing: [0.5, 0.5],
        ..Default::default()
    };
    for shape in Shape::ALL {
        let clean = PhantomSpec {
            shape,
            noise_sd_hu: 0.0,
            ..fine.clone()
        };
        let (sections, _) = compile(&clean, true);
        let (d_clean, n) = max_surface_distance(shape, &sections);
        let noisy = PhantomSpec {
            shape,
            ..fine.clone()
        };
        let (sections, _) = compile(&noisy, true);
        let (d_noisy, _) = max_surface_distance(shape, &sections);
        eprintln!("{}: {n} points, max distance {d_clean:.3} mm noise-free, {d_noisy:.3} mm with 20 HU noise", shape.name());
        assert!(d_clean <= 0.1, "{}: {d_clean} mm noise-free", shape.name());
        assert!(d_noisy <= 0.2, "{}: {d_noisy} mm with noise", shape.name());
    }
}

#[test]
fn flat_torus_has_ccw_outer_and_cw_hole_on_every_slice_through_the_ring() {
    let spec = PhantomSpec {
        shape: Shape::TorusFlat,
        ..Default::default()
    };
    let (sections, _) = compile(&spec, true);
    let mut ring_slices = 0;
    for s in &sections {
        for c in &s.contours {
            assert!(
                is_simple(&c.points),
                "slice {}: contour not simple",
                s.index
            );
            assert_eq!(
                signed_area(&c.points) < 0.0,
                c.hole,
                "slice {}: orientation",
                s.index
            );
        }
        if s.contours.len() == 2 {
            assert!(
                !s.contours[0].hole && s.contours[1].hole,
                "slice {}: outer then its hole",
                s.index
            );
            ring_slices += 1;
        }
    }
    assert!(ring_slices > 5, "{ring_slices} slices through the ring");
}

#[test]
fn file_order_does_not_change_the_output() {
    let spec = PhantomSpec {
        shape: Shape::TubesCrossing,
        ..Default::default()
    };
    let (_, hashed) = compile(&spec, true);
    let (_, ordered) = compile(&spec, false);
    assert!(hashed.len() > 1000);
    assert_eq!(hashed, ordered);
}
