//! Property tests of `geometry::sections`: random sets of contours (overlapping, crossing
//! themselves, holes anywhere) resolve into a valid section, and that section is the region
//! the contours mean, checked point by point against winding numbers computed here.

use bskin::geometry::polygon::{point_segment_distance, signed_area, Point};
use bskin::geometry::sections::{defect, resolved};
use bskin::section::Contour;
use proptest::prelude::*;

/// How many times the closed polygon winds round `p` (counter-clockwise positive).
fn winding(pts: &[Point], p: Point) -> i32 {
    let n = pts.len();
    let mut w = 0;
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        let side = (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1]);
        if a[1] <= p[1] && b[1] > p[1] && side > 0.0 {
            w += 1;
        } else if a[1] > p[1] && b[1] <= p[1] && side < 0.0 {
            w -= 1;
        }
    }
    w
}

fn near_an_edge(contours: &[Contour], p: Point, eps: f64) -> bool {
    contours.iter().any(|c| {
        let n = c.points.len();
        (0..n).any(|i| point_segment_distance(p, c.points[i], c.points[(i + 1) % n]) < eps)
    })
}

/// A contour of `n` points at the given angles and radii round `c`: simple when the angles
/// are sorted, crossing itself often when not. Holes are wound clockwise, as the NDJSON
/// reader leaves them.
fn contour(c: Point, mut angles: Vec<f64>, radii: &[f64], sorted: bool, hole: bool) -> Contour {
    if sorted {
        angles.sort_by(f64::total_cmp);
    }
    let mut points: Vec<Point> = angles
        .iter()
        .zip(radii)
        .map(|(t, r)| [c[0] + r * t.cos(), c[1] + r * t.sin()])
        .collect();
    if (signed_area(&points) < 0.0) != hole {
        points.reverse();
    }
    Contour { points, hole }
}

fn contours() -> impl Strategy<Value = Vec<Contour>> {
    let one = (
        (-8.0..8.0f64, -8.0..8.0f64),
        prop::collection::vec((0.0..std::f64::consts::TAU, 1.5..7.0f64), 3..10),
        any::<bool>(),
        prop::bool::weighted(0.3),
    )
        .prop_map(|((x, y), pts, sorted, hole)| {
            let (angles, radii): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
            contour([x, y], angles, &radii, sorted, hole)
        });
    prop::collection::vec(one, 1..5)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn resolved_sections_are_valid_and_are_the_region_the_contours_wind_round(cs in contours()) {
        let region = resolved(&cs);
        prop_assert_eq!(defect(&region), None, "{:?}", region);
        // Point by point: inside the region (even-odd over its contours, which are disjoint
        // and nested) exactly where more outer contours than holes wind round the point, each
        // contour counted once (its non-zero fill). Points within a hair of any edge are
        // skipped: the region's points are snapped to a grid.
        let mut checked = 0;
        for i in 0..80 {
            for j in 0..80 {
                let p = [-16.0 + 0.4 * i as f64 + 0.013, -16.0 + 0.4 * j as f64 + 0.007];
                if near_an_edge(&cs, p, 1e-4) || near_an_edge(&region, p, 1e-4) {
                    continue;
                }
                let want: i32 = cs
                    .iter()
                    .map(|c| {
                        let filled = i32::from(winding(&c.points, p) != 0);
                        if c.hole { -filled } else { filled }
                    })
                    .sum::<i32>();
                let got = region.iter().filter(|c| winding(&c.points, p) != 0).count() % 2 == 1;
                prop_assert_eq!(got, want > 0, "at {:?}: {:?} -> {:?}", p, cs, region);
                checked += 1;
            }
        }
        prop_assert!(checked > 6000);
    }

    #[test]
    fn a_valid_section_is_found_valid_and_resolves_to_the_same_area(
        (x, y) in (-5.0..5.0f64, -5.0..5.0f64),
        pts in prop::collection::vec((0.0..0.5f64, 4.0..8.0f64), 6..12),
    ) {
        // A star, a hole inside its core (at least 6 points, no two more than a quarter turn
        // apart, radii at least 4: its edges pass at least 2.8 from the centre; the hole's
        // radius is 2), and an island in the hole.
        let n = pts.len();
        let (angles, radii): (Vec<f64>, Vec<f64>) = pts
            .into_iter()
            .enumerate()
            .map(|(k, (jitter, r))| ((k as f64 + jitter) * std::f64::consts::TAU / n as f64, r))
            .unzip();
        let outer = contour([x, y], angles, &radii, true, false);
        let ring = |r: f64, hole: bool| {
            let angles: Vec<f64> = (0..12).map(|k| k as f64 * std::f64::consts::TAU / 12.0).collect();
            contour([x, y], angles, &[r; 12], true, hole)
        };
        let section = vec![outer, ring(2.0, true), ring(1.0, false)];
        prop_assert_eq!(defect(&section), None);
        let area = |cs: &[Contour]| -> f64 { cs.iter().map(|c| signed_area(&c.points)).sum() };
        let r = resolved(&section);
        prop_assert_eq!(r.len(), 3);
        prop_assert!((area(&r) - area(&section)).abs() < 1e-6 * area(&section).abs().max(1.0));
    }
}
