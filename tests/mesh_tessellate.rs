//! `mesh::tessellate` and `mesh::seal` on their own: the triangles stay within the chordal
//! tolerance of the surface, the end loops are in the mesh exactly and each of their edges is
//! the mesh's only open edge there (used once, in the direction the neighbour needs), the
//! seal closes exactly what a tiling leaves open, and the rows that fold are counted.

use std::collections::HashMap;
use std::f64::consts::PI;

use bskin::bspline::{fit_common, skin, FitOptions};
use bskin::mesh::crossings::crossing_faces;
use bskin::mesh::{
    seal, seal_problem, tessellate, tessellate_each, with_edge_points, RowLoops, Triangle,
};

type P3 = [f64; 3];

/// A vase: circles of varying radius at z = 0, 6, 12, 18, and a cap point at z = 22.
fn vase() -> (Vec<Vec<P3>>, bskin::bspline::SkinnedSurface) {
    let radii = [10.0, 13.0, 9.0, 11.0];
    let mut curves: Vec<Vec<P3>> = radii
        .iter()
        .enumerate()
        .map(|(k, &r)| {
            (0..160)
                .map(|j| {
                    let t = 2.0 * PI * j as f64 / 160.0;
                    [r * t.cos(), r * t.sin(), 6.0 * k as f64]
                })
                .collect()
        })
        .collect();
    curves.push(vec![[0.0, 0.0, 22.0]]);
    let fit = fit_common(&curves, &FitOptions::new(0.05)).unwrap();
    (curves, skin(&fit.curves).unwrap())
}

fn dist(p: &P3, q: &P3) -> f64 {
    (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>().sqrt()
}

fn key(p: &P3) -> [u64; 3] {
    [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()]
}

/// Directed edge uses minus uses of the reverse, per directed edge with a positive balance.
fn open_edges(tris: &[Triangle]) -> Vec<([u64; 3], [u64; 3])> {
    let mut bal: HashMap<([u64; 3], [u64; 3]), i64> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (key(&t[k]), key(&t[(k + 1) % 3]));
            *bal.entry((a, b)).or_default() += 1;
            *bal.entry((b, a)).or_default() -= 1;
        }
    }
    let mut v: Vec<_> = bal
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .map(|(e, _)| e)
        .collect();
    v.sort();
    v
}

#[test]
fn vase_is_within_the_chordal_tolerance_and_open_only_along_its_bottom_loop() {
    let (curves, s) = vase();
    let chordal = 0.02;
    let tris = tessellate(&s, &curves[0], &curves[4], chordal);
    // Open edges: exactly the bottom loop's, along its direction (the patch below it, if any,
    // would use them against it).
    let mut expected: Vec<_> = (0..curves[0].len())
        .map(|i| {
            (
                key(&curves[0][i]),
                key(&curves[0][(i + 1) % curves[0].len()]),
            )
        })
        .collect();
    expected.sort();
    assert_eq!(open_edges(&tris), expected);
    // Distance of the triangles' centres and edge midpoints to the surface. Between the bottom
    // loop and the next curve (z = 6) the mesh moves from the surface onto the loop, which is
    // within the fit tolerance of it, fading out by that curve; above, the chordal tolerance.
    let fit_tol = 0.05;
    let (mut worst, mut worst_band): (f64, f64) = (0.0, 0.0);
    for t in &tris {
        let c: P3 = std::array::from_fn(|d| (t[0][d] + t[1][d] + t[2][d]) / 3.0);
        let m: P3 = std::array::from_fn(|d| 0.5 * (t[0][d] + t[1][d]));
        let band = t.iter().any(|p| p[2] < 6.0 - 1e-9);
        for p in [c, m] {
            let d = s.closest_point(&p).0;
            if band {
                worst_band = worst_band.max(d);
            } else {
                worst = worst.max(d);
            }
        }
    }
    eprintln!(
        "{} triangles, worst chord deviation {worst:.4} mm, {worst_band:.4} mm next to the loop",
        tris.len()
    );
    assert!(
        worst_band <= fit_tol + chordal,
        "{worst_band} mm next to the loop"
    );
    assert!(worst <= chordal, "chord deviation {worst} mm");
    // Outward: positive enclosed volume once the bottom is closed by a fan.
    let o = curves[0].iter().fold([0.0; 3], |a, p| {
        std::array::from_fn(|d| a[d] + p[d] / 160.0)
    });
    let mut closed = tris.clone();
    for i in 0..curves[0].len() {
        closed.push([o, curves[0][(i + 1) % 160], curves[0][i]]);
    }
    assert!(open_edges(&closed).is_empty());
    let vol: f64 = closed
        .iter()
        .map(|[p, q, r]| {
            (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0])
                + p[2] * (q[0] * r[1] - q[1] * r[0]))
                / 6.0
        })
        .sum();
    assert!(vol > 0.0, "volume {vol}");
    // A finer tolerance gives more triangles.
    assert!(tessellate(&s, &curves[0], &curves[4], chordal / 4.0).len() > tris.len());
}

#[test]
fn seal_closes_a_tiling_gap_and_nothing_else() {
    let sq = |x0: f64, x1: f64| -> Vec<P3> {
        vec![
            [x0, 0.0, 1.0],
            [x1, 0.0, 1.0],
            [x1, 1.0, 1.0],
            [x0, 1.0, 1.0],
        ]
    };
    // One rectangle below, split in two above, with the split's end points on both sides.
    let below = vec![
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [2.0, 0.0, 1.0],
        [2.0, 1.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let (l, r) = (sq(0.0, 1.0), sq(1.0, 2.0));
    assert!(seal(&[(&below, true), (&l, false), (&r, false)]).is_empty());
    // The right piece a little narrower: a sliver 1.9..2 uncovered above.
    let r2 = sq(1.0, 1.9);
    let below2 = vec![
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.9, 0.0, 1.0],
        [2.0, 0.0, 1.0],
        [2.0, 1.0, 1.0],
        [1.9, 1.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let ends: Vec<(&[P3], bool)> = vec![(&below2, true), (&l, false), (&r2, false)];
    let s = seal(&ends);
    assert_eq!(s.len(), 2);
    assert!(open_edges(&with_stand_in_patches(&s, &ends)).is_empty());
    let area: f64 = s.iter().map(flat_area).sum();
    assert!((area.abs() - 0.1).abs() < 1e-12, "sliver area {area}");
}

/// Stand-in patches for the end loops of a seal test: each loop's edges as its patch uses
/// them (a `top` loop's against its direction), closed by an apex of its own off the plane.
fn stand_in_patches(ends: &[(&[P3], bool)]) -> Vec<Triangle> {
    let mut out = Vec::new();
    for (lp, top) in ends {
        let n = lp.len() as f64;
        let apex = [
            lp.iter().map(|p| p[0]).sum::<f64>() / n,
            lp.iter().map(|p| p[1]).sum::<f64>() / n,
            if *top { 0.0 } else { 2.0 },
        ];
        for i in 0..lp.len() {
            let (a, b) = (lp[i], lp[(i + 1) % lp.len()]);
            out.push(if *top { [b, a, apex] } else { [a, b, apex] });
        }
    }
    out
}

/// `seal` and the stand-in patches of `ends` (see [`stand_in_patches`]).
fn with_stand_in_patches(seal: &[Triangle], ends: &[(&[P3], bool)]) -> Vec<Triangle> {
    seal.iter().copied().chain(stand_in_patches(ends)).collect()
}

/// Whether no directed edge of `tris` is used more than once (with no open edges: every
/// edge once each way).
fn each_edge_once_each_way(tris: &[Triangle]) -> bool {
    let mut uses: HashMap<([u64; 3], [u64; 3]), usize> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            *uses.entry((key(&t[k]), key(&t[(k + 1) % 3]))).or_default() += 1;
        }
    }
    uses.values().all(|&n| n == 1)
}

/// `seal` and the stand-in patches of `ends` with `points` put into them, as the mesh's end
/// rows take them (see [`with_edge_points`]).
fn with_patches_on_rows(
    seal: &[Triangle],
    ends: &[(&[P3], bool)],
    points: &[[P3; 3]],
) -> Vec<Triangle> {
    let rows: Vec<Vec<P3>> = ends
        .iter()
        .map(|(lp, _)| with_edge_points(lp, points))
        .collect();
    let rows: Vec<(&[P3], bool)> = rows
        .iter()
        .zip(ends)
        .map(|(lp, e)| (lp.as_slice(), e.1))
        .collect();
    with_stand_in_patches(seal, &rows)
}

/// Points in the plane z = 1.
fn at_height_1(xy: &[[f64; 2]]) -> Vec<P3> {
    xy.iter().map(|&[x, y]| [x, y, 1.0]).collect()
}

/// The signed area of a triangle in a plane z = const, counter-clockwise positive.
fn flat_area([p, q, r]: &Triangle) -> f64 {
    0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))
}

/// A rectangle below, split in two above, the right piece's side crossing the rectangle's at
/// (2, 0.5): covered twice below the crossing, open above it. The unmatched edges make a
/// figure of eight of no net area; split at the crossing they are two triangles, one each way
/// round, which the patches and the seal close with every edge used once each way.
#[test]
fn seal_problem_splits_loops_that_cross_into_a_gap_and_an_overlap() {
    let below = at_height_1(&[[0., 0.], [1., 0.], [2., 0.], [2., 1.], [1., 1.], [0., 1.]]);
    let l = at_height_1(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]]);
    let r = at_height_1(&[
        [1., 0.],
        [2., 0.],
        [2.2, 0.3],
        [1.8, 0.7],
        [2., 1.],
        [1., 1.],
    ]);
    let ends: Vec<(&[P3], bool)> = vec![(&below, true), (&l, false), (&r, false)];
    let (tris, points) = seal_problem(&ends, SLIVER_MM);
    // One crossing, on the rectangle's side and on the piece's.
    assert_eq!(points.len(), 2, "{points:?}");
    for [_, _, x] in &points {
        assert!((x[0] - 2.0).abs() < 1e-12 && (x[1] - 0.5).abs() < 1e-12 && x[2] == 1.0);
    }
    // The loops as the patches' end rows take them, each with the crossing point once.
    let rows: Vec<(Vec<P3>, bool)> = ends
        .iter()
        .map(|(lp, top)| (with_edge_points(lp, &points), *top))
        .collect();
    assert_eq!(
        rows.iter().map(|(lp, _)| lp.len()).collect::<Vec<_>>(),
        [7, 4, 7]
    );
    assert_eq!(rows[0].0[3], points[0][2]);
    // Two triangles, 0.05 each, not overlapping: their areas add up to the lobes'.
    let areas: Vec<f64> = tris.iter().map(flat_area).collect();
    let total: f64 = areas.iter().map(|a| a.abs()).sum();
    assert!((total - 0.1).abs() < 1e-12, "{areas:?}");
    assert!(areas.iter().any(|&a| a > 0.0) && areas.iter().any(|&a| a < 0.0));
    // With stand-in patches on the rows: closed, and no edge used twice the same way.
    let all = with_patches_on_rows(&tris, &ends, &points);
    assert!(open_edges(&all).is_empty());
    assert!(each_edge_once_each_way(&all));
    // Loops that tile the plane get neither triangles nor points.
    let tile = at_height_1(&[[1., 0.], [2., 0.], [2., 1.], [1., 1.]]);
    let (tris, points) = seal_problem(&[(&below, true), (&l, false), (&tile, false)], SLIVER_MM);
    assert!(tris.is_empty() && points.is_empty());
}

/// Thinnest seal triangle whose corner `seal_problem` may put on the opposite edge here.
const SLIVER_MM: f64 = 0.05;

/// A rectangle below, cut in two above by a chain whose ends lie off the rectangle's sides:
/// at the bottom by `off` (outside for negative, inside for positive), at the top on the
/// side, between its vertices. Each end leaves a thin triangle of unmatched edges; sealed
/// flat, the chain would cross the rectangle's side there, and the patches either side of
/// the plane touch off their vertices. Within the bound, each corner is put on the side
/// instead: no seal triangle, the rectangle's row takes both chain ends, and every edge is
/// used once each way. Beyond it, the bottom triangle is sealed as before.
#[test]
fn seal_problem_puts_a_chain_end_just_off_a_loop_onto_its_edge() {
    let below = at_height_1(&[[0., 0.], [2., 0.], [2., 1.], [0., 1.]]);
    for off in [-0.01, 0.01, 0.0] {
        let v = [1.0, off, 1.0];
        let left = at_height_1(&[[0., 0.], [1., off], [1., 1.], [0., 1.]]);
        let right = at_height_1(&[[1., off], [2., 0.], [2., 1.], [1., 1.]]);
        let ends: Vec<(&[P3], bool)> = vec![(&below, true), (&left, false), (&right, false)];
        let (tris, points) = seal_problem(&ends, SLIVER_MM);
        assert!(tris.is_empty(), "off {off}: {tris:?}");
        assert_eq!(points.len(), 2, "off {off}: {points:?}");
        let row = with_edge_points(&below, &points);
        assert_eq!(
            row,
            vec![below[0], v, below[1], below[2], [1., 1., 1.], below[3]],
            "off {off}"
        );
        assert!(with_edge_points(&left, &points) == left);
        assert!(with_edge_points(&right, &points) == right);
        let all = with_patches_on_rows(&tris, &ends, &points);
        assert!(open_edges(&all).is_empty() && each_edge_once_each_way(&all));
    }
    // A gap wider than the bound is a gap: sealed by a triangle, and its corner stays put.
    let left = at_height_1(&[[0., 0.], [1., -0.2], [1., 1.], [0., 1.]]);
    let right = at_height_1(&[[1., -0.2], [2., 0.], [2., 1.], [1., 1.]]);
    let ends: Vec<(&[P3], bool)> = vec![(&below, true), (&left, false), (&right, false)];
    let (tris, points) = seal_problem(&ends, SLIVER_MM);
    assert_eq!(tris.len(), 1, "{tris:?}");
    assert!((flat_area(&tris[0]).abs() - 0.2).abs() < 1e-12);
    assert_eq!(points, vec![[[0., 1., 1.], [2., 1., 1.], [1., 1., 1.]]]);
    let all = with_patches_on_rows(&tris, &ends, &points);
    assert!(open_edges(&all).is_empty() && each_edge_once_each_way(&all));
}

/// As above, but the two pieces' sides along the chain cross each other just above the chain's
/// end: the crossing lies on the right piece's side that ends at the sliver's corner, an edge
/// of the loop as given, so the writer can put both points in. Both are kept: the corner goes
/// on the rectangle's side, and the seal closes with the patches. Before, any crossing on an
/// edge at a sliver's corner gave up every sliver of the problem (on the GE head, a branching
/// with 20 slivers whose touching faces were left).
#[test]
fn seal_problem_keeps_a_sliver_whose_corner_ends_a_crossed_edge() {
    let below = at_height_1(&[[0., 0.], [2., 0.], [2., 1.], [0., 1.]]);
    let v = [1.0, -0.01, 1.0];
    let left = at_height_1(&[
        [0., 0.],
        [1., -0.01],
        [0.7, 0.2],
        [0.45, 0.6],
        [1., 1.],
        [0., 1.],
    ]);
    let right = at_height_1(&[[0.5, 0.5], [1., -0.01], [2., 0.], [2., 1.], [1., 1.]]);
    let ends: Vec<(&[P3], bool)> = vec![(&below, true), (&left, false), (&right, false)];
    let (tris, points) = seal_problem(&ends, SLIVER_MM);
    assert_eq!(
        with_edge_points(&below, &points),
        vec![below[0], v, below[1], below[2], [1., 1., 1.], below[3]],
        "{points:?}"
    );
    let crossed = [[0.5, 0.5, 1.0], v];
    assert!(
        points
            .iter()
            .any(|[a, b, _]| crossed.contains(a) && crossed.contains(b)),
        "{points:?}"
    );
    let all = with_patches_on_rows(&tris, &ends, &points);
    assert!(open_edges(&all).is_empty());
    assert!(each_edge_once_each_way(&all));
}

/// Two pieces above a rectangle whose sides along the chain between them run up to 0.006 apart
/// (the left one bowed away through two points): a thin polygon of four edges, not a triangle.
/// Both corners go on the right piece's side, in order, and nothing needs sealing. Before,
/// only triangles were slivers: the gap was sealed with two flat triangles whose edge passed
/// a hair from the loops' vertices (on the GE head, a chain end's tongue where three
/// patches touched).
#[test]
fn seal_problem_puts_a_thin_polygons_corners_on_its_long_edge() {
    let below = at_height_1(&[[0., 0.], [2., 0.], [2., 1.], [0., 1.]]);
    let left = at_height_1(&[
        [0., 0.],
        [1., 0.],
        [0.996, 0.3],
        [0.994, 0.7],
        [1., 1.],
        [0., 1.],
    ]);
    let right = at_height_1(&[[1., 0.], [2., 0.], [2., 1.], [1., 1.]]);
    let ends: Vec<(&[P3], bool)> = vec![(&below, true), (&left, false), (&right, false)];
    let (tris, points) = seal_problem(&ends, SLIVER_MM);
    assert!(tris.is_empty(), "{tris:?}");
    assert_eq!(
        with_edge_points(&right, &points),
        vec![right[0], right[1], right[2], right[3], left[3], left[2]],
        "{points:?}"
    );
    assert!(with_edge_points(&left, &points) == left);
    // The chain's ends lie on the rectangle's sides (triangles without area).
    assert_eq!(
        with_edge_points(&below, &points),
        vec![below[0], left[1], below[1], below[2], left[4], below[3]]
    );
    let all = with_patches_on_rows(&tris, &ends, &points);
    assert!(open_edges(&all).is_empty() && each_edge_once_each_way(&all));
    // Wider than the bound at one corner: sealed as before, and no corner of it moves.
    let left = at_height_1(&[
        [0., 0.],
        [1., 0.],
        [0.996, 0.3],
        [0.9, 0.7],
        [1., 1.],
        [0., 1.],
    ]);
    let ends: Vec<(&[P3], bool)> = vec![(&below, true), (&left, false), (&right, false)];
    let (tris, points) = seal_problem(&ends, SLIVER_MM);
    assert!(
        points.iter().all(|[.., v]| *v == left[1] || *v == left[4]),
        "{points:?}"
    );
    assert_eq!(tris.len(), 2);
}

/// Two pieces above a square, each bulging past its bottom side, where they overlap: the
/// plane there is covered twice above and not at all below. Split at every crossing, the
/// seal winds round that patch of plane twice and uses its edges twice the same way;
/// `seal_problem` drops the crossings at those edges' ends and splits the rest, and what it
/// returns closes with the patches, every edge used once each way (split at all six
/// crossings, it did not: checked).
#[test]
fn seal_problem_drops_the_crossings_that_would_use_an_edge_twice() {
    let below = at_height_1(&[[0., 0.], [2., 0.], [2., 2.], [1.1, 2.], [0.9, 2.], [0., 2.]]);
    let left = at_height_1(&[[0., 0.], [1.3, -0.3], [0.9, 2.], [0., 2.]]);
    let right = at_height_1(&[[0.7, -0.3], [2., 0.], [2., 2.], [1.1, 2.]]);
    let ends: Vec<(&[P3], bool)> = vec![(&below, true), (&left, false), (&right, false)];
    let (tris, points) = seal_problem(&ends, SLIVER_MM);
    // Of the six crossings, only the pieces' sides crossing inside the square is kept.
    assert_eq!(points.len(), 2, "{points:?}");
    for [_, _, x] in &points {
        assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 1.425).abs() < 1e-12);
    }
    let all = with_patches_on_rows(&tris, &ends, &points);
    assert!(open_edges(&all).is_empty());
    assert!(each_edge_once_each_way(&all));
}

/// A lower loop whose side is a straight run of 41 points on a slanted line (their
/// rounding bends it by 10⁻¹⁶ mm either way), and an upper loop bowed 0.05 mm out beyond
/// that side. The seal fans the run from the bow's apex: no triangle is without area (ear
/// clipping's first ears along the run were: three points of the run each, which an STL
/// file's float32 rounding turns over), and the triangles cover the gap once.
#[test]
fn seal_fans_a_straight_run_rather_than_clip_it() {
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let at = |along: f64, out: f64| -> P3 { [along * c + out * s, along * s - out * c, 1.0] };
    let run: Vec<P3> = (0..=40).map(|k| at(0.05 * k as f64, 0.0)).collect();
    let lower: Vec<P3> = run
        .iter()
        .copied()
        .chain([at(2.0, -1.0), at(0.0, -1.0)])
        .collect();
    let upper: Vec<P3> = vec![run[0], at(1.0, 0.05), run[40], at(2.0, -1.0), at(0.0, -1.0)];
    let ends: Vec<(&[P3], bool)> = vec![(&lower, true), (&upper, false)];
    let tris = seal(&ends);
    assert_eq!(tris.len(), 40);
    let areas: Vec<f64> = tris.iter().map(flat_area).collect();
    let least = areas.iter().map(|a| a.abs()).fold(f64::INFINITY, f64::min);
    assert!(least > 1e-4, "a sliver of {least} mm²");
    let total: f64 = areas.iter().sum();
    let sum_abs: f64 = areas.iter().map(|a| a.abs()).sum();
    assert!((total.abs() - 0.05).abs() < 1e-12 && (sum_abs - 0.05).abs() < 1e-12);
    assert!(open_edges(&with_stand_in_patches(&tris, &ends)).is_empty());
}

/// A peanut (lobes 19 mm, waist 1 mm from its centre) at z = 0 and z = 4, the second loop
/// listed from `shift` of its 200 points later. A quarter turn joins each lobe to the waist,
/// and the rows half-way cross themselves (the blends of the loops' points of equal
/// chord-length fraction do, as a 2-D check of the same loops shows); from the same point or
/// an eighth of a turn later, they do not.
fn peanuts(shift: usize) -> (Vec<Vec<P3>>, bskin::bspline::SkinnedSurface) {
    let n = 200;
    let at = |j: usize, z: f64| -> P3 {
        let t = 2.0 * PI * j as f64 / n as f64;
        let r = 10.0 + 9.0 * (2.0 * t).cos();
        [r * t.cos(), r * t.sin(), z]
    };
    let curves: Vec<Vec<P3>> = vec![
        (0..n).map(|j| at(j, 0.0)).collect(),
        (0..n).map(|j| at((j + shift) % n, 4.0)).collect(),
    ];
    let fit = fit_common(&curves, &FitOptions::new(0.05)).unwrap();
    (curves, skin(&fit.curves).unwrap())
}

#[test]
fn folded_rows_are_the_rows_that_cross_themselves() {
    for (shift, folds) in [(0, false), (25, false), (50, true)] {
        let (curves, s) = peanuts(shift);
        let (bottom, top) = (&curves[0], &curves[1]);
        let mut count = 0;
        let f = tessellate_each(&s, bottom, top, 0.02, RowLoops::Keep, |_| count += 1);
        assert!(f.rows > 0 && count > 0, "{f:?}");
        if folds {
            // The middle rows fold; the rows next to either loop are still peanuts.
            assert!(f.folded > 0 && f.folded < f.rows, "{f:?}");
        } else {
            assert_eq!(f.folded, 0, "{f:?}");
        }
    }
    // The vase's rows are circles.
    let (curves, s) = vase();
    let f = tessellate_each(&s, &curves[0], &curves[4], 0.02, RowLoops::Keep, |_| {});
    assert_eq!(f.folded, 0, "{f:?}");
    assert!(f.rows > 0);
}

/// Circles of radius 10 at z = 0, 1 and 2 (40 control points each, uniform knots), the middle
/// one with control points 10–13 bunched within 5`d` mm and doubling back along the circle, so
/// that its curve makes a loop about 3`d` mm across: a surface folding through itself below
/// the mesh's resolution. With the end loops sampled from its end curves.
fn pleated(d: f64) -> (Vec<P3>, Vec<P3>, bskin::bspline::SkinnedSurface) {
    use bskin::bspline::{ClosedCurve, PeriodicKnotVector};
    let n = 40;
    let circle = |z: f64| -> Vec<P3> {
        (0..n)
            .map(|j| {
                let t = 2.0 * PI * j as f64 / n as f64;
                [10.0 * t.cos(), 10.0 * t.sin(), z]
            })
            .collect()
    };
    let mut middle = circle(1.0);
    let (p, t) = (middle[10], PI / 2.0);
    let (along, out) = ([-t.sin(), t.cos(), 0.0], [t.cos(), t.sin(), 0.0]);
    for (k, (a, b)) in [(0.0, 0.0), (5.0, 0.0), (-2.0, 0.1), (3.0, 0.0)]
        .iter()
        .enumerate()
    {
        middle[10 + k] = std::array::from_fn(|c| p[c] + d * (a * along[c] + b * out[c]));
    }
    let knots = PeriodicKnotVector::uniform(n).unwrap();
    let curves: Vec<ClosedCurve<3>> = [circle(0.0), middle, circle(2.0)]
        .into_iter()
        .map(|c| ClosedCurve::try_new(knots.clone(), c).unwrap())
        .collect();
    let s = skin(&curves).unwrap();
    let period = s.u_knots().period();
    let end = |v: f64| -> Vec<P3> {
        (0..400)
            .map(|j| s.eval(period * j as f64 / 400.0, v))
            .collect()
    };
    let vb = s.v_bar();
    (end(vb[0]), end(vb[vb.len() - 1]), s)
}

#[test]
fn loops_within_the_chordal_tolerance_are_cut_off_and_the_mesh_stays_closed() {
    let chordal = 0.05;
    for (d, within) in [(0.005, true), (0.01, true), (0.05, false)] {
        let (bottom, top, s) = pleated(d);
        let mesh = |loops| {
            let mut tris = Vec::new();
            let f = tessellate_each(&s, &bottom, &top, chordal, loops, |t| tris.push(t));
            (f, tris)
        };
        let ((kept, as_is), (cut, meshed)) = (mesh(RowLoops::Keep), mesh(RowLoops::Cut));
        assert!(kept.folded > 0 && kept.loops_cut == 0, "d {d}: {kept:?}");
        if !within {
            // A loop of 0.15 mm is a fold the mesh shows (the rows near its tip, where it
            // narrows, lose theirs).
            assert!(cut.folded > 0, "d {d}: {cut:?}");
            continue;
        }
        assert!(cut.loops_cut > 0 && cut.folded == 0, "d {d}: {cut:?}");
        assert!(
            crossing_faces(&as_is) > 0 && crossing_faces(&meshed) == 0,
            "d {d}"
        );
        // Open only along the end loops, as before; a few triangles fewer (those with two
        // corners on a cut loop).
        assert_eq!(open_edges(&meshed), open_edges(&as_is), "d {d}");
        assert!(meshed.len() < as_is.len());
        // The new vertices are the loops' crossings: within the chordal tolerance of a
        // vertex the rows had.
        let old: std::collections::HashSet<[u64; 3]> = as_is.iter().flatten().map(key).collect();
        for p in meshed.iter().flatten().filter(|p| !old.contains(&key(p))) {
            let near = as_is
                .iter()
                .flatten()
                .map(|q| dist(p, q))
                .fold(f64::INFINITY, f64::min);
            assert!(near <= chordal, "d {d}: {p:?} is {near} mm from the rows");
        }
    }
}
