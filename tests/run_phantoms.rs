//! End to end on the project's phantoms: DICOM series on disk → `run_surfaces` → mesh and
//! report, checked against the analytic surface. For each shape: the number of surfaces, every
//! input contour point within the tolerance (true distance), and the distance between the
//! mesh and the analytic surface both ways, caps and junctions included.

mod common;

use bskin::config::RunConfig;
use bskin::phantom::{PhantomSpec, Shape};
use common::*;

const TOLERANCE: f64 = 0.5;
/// Bar for the distance between output and truth, both ways, at 1 mm slices.
const BAR_MM: f64 = 1.0;

struct Figures {
    surfaces: usize,
    max_error: f64,
}

/// `expected` = (outer walls, hole walls).
fn check(spec: PhantomSpec, expected: (usize, usize), bar: f64) -> Figures {
    let tmp = tempfile::tempdir().unwrap();
    let series = write_phantom(&spec, tmp.path());
    let out = tmp.path().join("out");
    let config = RunConfig::with_tolerance(TOLERANCE);
    let summary = run_dir(&series, &out, &config).expect("run");
    let surfaces = &summary.written.surfaces;
    let name = spec.shape.name();
    let holes = surfaces.iter().filter(|s| s.kind == "hole").count();
    assert_eq!(
        (surfaces.len() - holes, holes),
        expected,
        "{name}: (outer, hole) surface counts"
    );
    let max_error = surfaces.iter().map(|s| s.max_error_mm).fold(0.0, f64::max);
    for s in surfaces {
        assert!(
            s.tolerance_met && s.max_error_mm <= TOLERANCE,
            "{name}: surface {} max error {} mm",
            s.id,
            s.max_error_mm
        );
    }
    let tris = read_stl(&out.join("mesh.stl"));
    let (mesh_to_truth, worst) = tris
        .iter()
        .flatten()
        .map(|&v| (spec.shape.signed_distance(v).abs(), v))
        .fold((0.0, [0.0; 3]), |a, b| if b.0 > a.0 { b } else { a });
    let heights = spec.slice_heights();
    let (lo, hi) = (heights[0], heights[heights.len() - 1]);
    let mut truth = truth_points(spec.shape, lo, hi, 0.5, 0.25);
    let step = truth.len().div_ceil(3000).max(1);
    truth = truth.into_iter().step_by(step).collect();
    let truth_to_mesh = max_distance_to_mesh(&truth, &tris);
    eprintln!(
        "{name} (tilt {}°, uneven {}): {} surfaces, {} control points for {} input points, max error {max_error:.3} mm, mesh→truth {mesh_to_truth:.3} mm, truth→mesh {truth_to_mesh:.3} mm",
        spec.tilt_deg,
        spec.uneven,
        surfaces.len(),
        surfaces.iter().map(|s| s.control_points[0] * s.control_points[1]).sum::<usize>(),
        surfaces.iter().map(|s| s.input_points).sum::<usize>(),
    );
    assert!(mesh_to_truth <= bar, "{name}: mesh vertex {worst:?} is {mesh_to_truth:.3} mm from the analytic surface (bar {bar})");
    assert!(
        truth_to_mesh <= bar,
        "{name}: analytic surface point {truth_to_mesh:.3} mm from the mesh (bar {bar})"
    );
    Figures {
        surfaces: surfaces.len(),
        max_error,
    }
}

fn spec(shape: Shape) -> PhantomSpec {
    PhantomSpec {
        shape,
        slices: 89,
        slice_spacing: 1.0,
        ..Default::default()
    }
}

#[test]
fn tube_split_gives_three_surfaces() {
    check(spec(Shape::TubeSplit), (3, 0), BAR_MM);
}

#[test]
fn tubes_crossing_merge_then_split_gives_five_surfaces() {
    check(spec(Shape::TubesCrossing), (5, 0), BAR_MM);
}

#[test]
fn standing_torus_gives_four_surfaces() {
    check(spec(Shape::TorusStanding), (4, 0), BAR_MM);
}

#[test]
fn flat_torus_closes_like_a_torus() {
    // An outer wall and a hole wall meeting on ridge loops: no membrane over the hole, so
    // the analytic surface is met both ways.
    let f = check(spec(Shape::TorusFlat), (1, 1), BAR_MM);
    assert_eq!(f.surfaces, 2);
}

#[test]
fn one_tube_into_three() {
    // Just above the fork the three discs overlap pairwise around a small void, a real hole
    // for a slice or two: its wall is the sixth surface. Where the discs part, the void opens
    // into the gap between them, so the hole joins its contour in a keyhole, and the
    // branching starts from that loop: a fifth outer surface, from the keyhole to the
    // intermediate contours.
    check(spec(Shape::TubeThree), (5, 1), BAR_MM);
}

#[test]
fn separate_blobs() {
    check(spec(Shape::Blobs), (3, 0), BAR_MM);
}

#[test]
fn tilted_and_uneven_slices() {
    let s = PhantomSpec {
        tilt_deg: 15.0,
        uneven: true,
        ..spec(Shape::TubeSplit)
    };
    // Gaps up to 2.5 mm: the caps sit half a gap beyond the last contour, so the bar scales.
    let f = check(s, (3, 0), 1.5);
    assert!(f.max_error <= TOLERANCE);
}
