//! Property tests of keyholes (`geometry::keyhole`): on random contours with random holes and
//! a small contour in the middle of the other slice, slits are found, each is admissible, and the loop is the
//! material it joins (weakly simple, its area the contour's less the holes', every point of
//! contour and holes on it; with another keyhole's feet too, still so, and sharing every ring
//! vertex with that keyhole's loop); and with a thin wall beside the hole that lies over the other
//! slice's thin wall, the slit still closes the other slice's bay mouth.

use bskin::geometry::keyhole::{join_rings, keyhole_loop, slits, with_feet, Slit};
use bskin::geometry::polygon::{contains, is_weakly_simple, signed_area, Point};
use proptest::prelude::*;

fn lerp(a: Point, b: Point, t: f64) -> Point {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

/// A star-shaped loop round `c`: `radii` evenly spaced in angle, counter-clockwise (clockwise
/// when `!ccw`).
fn star(c: Point, radii: &[f64], ccw: bool) -> Vec<Point> {
    let n = radii.len();
    let mut pts: Vec<Point> = radii
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            [c[0] + r * a.cos(), c[1] + r * a.sin()]
        })
        .collect();
    if !ccw {
        pts.reverse();
    }
    pts
}

fn point_at(rings: &[&[Point]], ring: usize, edge: usize, t: f64) -> Point {
    let r = rings[ring];
    lerp(r[edge], r[(edge + 1) % r.len()], t)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn keyholes_are_the_material_they_join(
        outer_r in prop::collection::vec(28.0f64..34.0, 24..72),
        holes in prop::collection::vec(
            (0.0f64..std::f64::consts::TAU, 8.0f64..16.0, prop::collection::vec(3.0f64..4.5, 6..20)),
            1..4,
        ),
        below_r in prop::collection::vec(2.0f64..6.0, 8..40),
    ) {
        let outer = star([0.0, 0.0], &outer_r, true);
        // Holes on a ring round the middle, kept only where they miss the ones before.
        let mut hole_loops: Vec<Vec<Point>> = Vec::new();
        for (angle, dist, radii) in &holes {
            let c = [dist * angle.cos(), dist * angle.sin()];
            let clear = hole_loops.iter().all(|h| {
                let hc = h.iter().fold([0.0, 0.0], |s, p| [s[0] + p[0], s[1] + p[1]]);
                let hc = [hc[0] / h.len() as f64, hc[1] / h.len() as f64];
                (hc[0] - c[0]).hypot(hc[1] - c[1]) > 9.5
            });
            if clear {
                hole_loops.push(star(c, radii, false));
            }
        }
        let below = star([0.0, 0.0], &below_r, true);
        let refs: Vec<&[Point]> = hole_loops.iter().map(|h| h.as_slice()).collect();
        // The other slice's contour is a small disc in the middle, so a way out to the rim
        // always exists.
        let cuts = slits(&outer, &refs, &[], &[&below], 0.5, true);
        prop_assert!(cuts.is_some(), "no slits for {} holes", refs.len());
        let cuts = cuts.unwrap_or_default();
        prop_assert_eq!(cuts.len(), refs.len());
        let rings_in: Vec<&[Point]> = std::iter::once(outer.as_slice()).chain(refs.iter().copied()).collect();
        for Slit { from, to } in &cuts {
            prop_assert!(to.ring >= 1 && from.ring < to.ring);
            let a = point_at(&rings_in, from.ring, from.edge, from.t);
            let b = point_at(&rings_in, to.ring, to.edge, to.t);
            let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
            prop_assert!(contains(&outer, mid) && !refs.iter().any(|h| contains(h, mid)));
            prop_assert!(!contains(&below, mid), "slit over the other slice's material");
        }
        let rings: Vec<Vec<Point>> = rings_in
            .iter()
            .enumerate()
            .map(|(r, pts)| with_feet(pts, r, &cuts, lerp))
            .collect();
        let ring_refs: Vec<&[Point]> = rings.iter().map(|r| r.as_slice()).collect();
        let l = keyhole_loop(&ring_refs, &cuts, |_, _| 3, |a, b, k| {
            (1..k).map(|s| lerp(a, b, s as f64 / k as f64)).collect()
        });
        let want: f64 = rings_in.iter().map(|r| signed_area(r)).sum();
        prop_assert!((signed_area(&l) - want).abs() < 1e-6 * want.abs(), "area {} vs {}", signed_area(&l), want);
        prop_assert!(is_weakly_simple(&l));
        for r in &rings_in {
            prop_assert!(r.iter().all(|p| l.contains(p)));
        }
        // Another keyhole of the same rings (slits found against another slice's contour),
        // as where the region below ends on one loop and the region above starts on the
        // other: each with the other's feet, the two share every ring vertex bit for bit.
        let shifted = star([5.0, 3.0], &below_r, true);
        let other = slits(&outer, &refs, &[], &[&shifted], 0.5, true);
        prop_assert!(other.is_some(), "no slits against the shifted disc");
        if let Some(other) = other {
            let (ra, la) = join_rings(&rings_in, &cuts, &other, 0.7);
            let (rb, lb) = join_rings(&rings_in, &other, &cuts, 0.7);
            prop_assert_eq!(&ra, &rb);
            for r in &ra {
                prop_assert!(r.iter().all(|p| la.contains(p) && lb.contains(p)));
            }
            for l in [&la, &lb] {
                prop_assert!((signed_area(l) - want).abs() < 1e-6 * want.abs());
                prop_assert!(is_weakly_simple(l));
            }
        }
    }

    #[test]
    fn a_slit_closes_the_mouth_not_a_thin_wall_over_the_other_slices_wall(
        thin in 0.8f64..1.5,
        top_ratio in 1.2f64..3.5,
        right in 22.0f64..36.0,
        mouth_at in 0.0f64..1.0,
        mouth_w in 4.0f64..8.0,
        bay_wall in 0.3f64..0.45,
    ) {
        // A 40 × 20 block with a hole from x = `thin` (the thin left wall) to `right`, from
        // y = 8 up to a top wall `top_ratio` times as thick. On the other slice the hole is
        // a bay, its left wall `bay_wall` × `thin` thick (the thin slit's midpoint over the
        // bay, its quarter point over that wall), its mouth `mouth_w` wide through the top.
        let y = 20.0 - top_ratio * thin;
        let m0 = thin + 2.0 + mouth_at * (right - thin - 4.0 - mouth_w);
        let m1 = m0 + mouth_w;
        let block = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0], [0.0, 20.0]];
        let hole = vec![[thin, 8.0], [thin, y], [right, y], [right, 8.0]];
        let w = bay_wall * thin;
        let bay = vec![
            [0.0, 0.0],
            [40.0, 0.0],
            [40.0, 20.0],
            [m1, 20.0],
            [m1, y],
            [right, y],
            [right, 8.0],
            [w, 8.0],
            [w, y],
            [m0, y],
            [m0, 20.0],
            [0.0, 20.0],
        ];
        let cuts = slits(&block, &[&hole], &[], &[&bay], 0.25, true);
        prop_assert!(cuts.is_some(), "no slit");
        let cuts = cuts.unwrap_or_default();
        let rings: [&[Point]; 2] = [&block, &hole];
        let a = point_at(&rings, cuts[0].from.ring, cuts[0].from.edge, cuts[0].from.t);
        let b = point_at(&rings, cuts[0].to.ring, cuts[0].to.edge, cuts[0].to.t);
        prop_assert!(
            (a[1] - 20.0).abs() < 1e-9 && (b[1] - y).abs() < 1e-9 && a[0] > m0 && a[0] < m1,
            "slit {:?}-{:?}, mouth {}..{}", a, b, m0, m1
        );
    }
}
