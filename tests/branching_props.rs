//! Known-answer and property tests of the branching geometry: distance maps against brute
//! force, intermediate contours of 1-to-1, 1-to-2, 2-to-2, 1-to-3 and random m-to-n problems,
//! and caps. Each test prints the accuracy it measured (run with `--nocapture` to see it).

use bskin::geometry::branching::{
    intermediate_contours, intermediate_contours_at, Intermediate, IntermediateContours,
};
use bskin::geometry::capping::cap;
use bskin::geometry::distance_map::{signed_distance, Grid};
use bskin::geometry::polygon::{
    boundary_distance, contains, is_simple, is_weakly_simple, signed_area, Point,
};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn ellipse(cx: f64, cy: f64, a: f64, b: f64, n: usize) -> Vec<Point> {
    (0..n)
        .map(|k| {
            let t = k as f64 * std::f64::consts::TAU / n as f64;
            [cx + a * t.cos(), cy + b * t.sin()]
        })
        .collect()
}

/// A random star-shaped contour around `c` with radii in about `[0.6 r, 1.4 r]`.
fn star(rng: &mut ChaCha8Rng, c: Point, r: f64, n: usize) -> Vec<Point> {
    let terms: Vec<(f64, f64)> = (1..=4)
        .map(|k| {
            (
                rng.random_range(0.0..0.25) / k as f64,
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    (0..n)
        .map(|i| {
            let t = i as f64 * std::f64::consts::TAU / n as f64;
            let s: f64 = terms
                .iter()
                .enumerate()
                .map(|(k, (a, ph))| a * ((k + 1) as f64 * t + ph).cos())
                .sum();
            let rr = r * (1.0 + s);
            [c[0] + rr * t.cos(), c[1] + rr * t.sin()]
        })
        .collect()
}

/// Signed distance to the union of disjoint filled contours, by brute force.
fn union_sd(set: &[&[Point]], p: Point) -> f64 {
    let d = set
        .iter()
        .map(|c| boundary_distance(c, p))
        .fold(f64::INFINITY, f64::min);
    if set.iter().any(|c| contains(c, p)) {
        -d
    } else {
        d
    }
}

fn loops(v: &[Intermediate]) -> Vec<&Vec<Point>> {
    v.iter()
        .filter_map(|i| match i {
            Intermediate::Loop(l) => Some(l),
            Intermediate::Point(_) => None,
        })
        .collect()
}

/// Worst gap between the two tilings of M: every vertex of a loop of one side that is not on
/// a bisecting edge shared with its own side (farther than `cell` from the side's other
/// loops) lies on ∂M, so it must lie on some loop of the other side. Both directions. Also
/// counts how many of those vertices are vertices of the other side bit for bit.
fn tiling_gap_counts(r: &IntermediateContours, cell: f64) -> (f64, usize, usize) {
    let (lo, up) = (loops(&r.lower), loops(&r.upper));
    let one_way = |a: &[&Vec<Point>], b: &[&Vec<Point>]| -> (f64, usize, usize) {
        let (mut worst, mut same, mut total): (f64, usize, usize) = (0.0, 0, 0);
        for (i, l) in a.iter().enumerate() {
            for &p in l.iter() {
                let own = a
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, o)| boundary_distance(o, p))
                    .fold(f64::INFINITY, f64::min);
                if own <= cell {
                    continue;
                }
                let other = b
                    .iter()
                    .map(|o| boundary_distance(o, p))
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(other);
                total += 1;
                same += b.iter().any(|o| o.contains(&p)) as usize;
            }
        }
        (worst, same, total)
    };
    let (g1, s1, t1) = one_way(&lo, &up);
    let (g2, s2, t2) = one_way(&up, &lo);
    (g1.max(g2), s1 + s2, t1 + t2)
}

fn tiling_gap(r: &IntermediateContours, cell: f64) -> f64 {
    tiling_gap_counts(r, cell).0
}

fn check_loops_valid(r: &IntermediateContours) {
    for lp in loops(&r.lower).into_iter().chain(loops(&r.upper)) {
        assert!(lp.len() >= 3);
        assert!(signed_area(lp) > 0.0, "loop not counter-clockwise");
        // Simple but for the slits of bridges joining a split zone's pieces.
        assert!(is_weakly_simple(lp), "loop not simple (slits aside)");
    }
}

fn area_sum(v: &[Intermediate]) -> f64 {
    loops(v).iter().map(|l| signed_area(l)).sum()
}

#[test]
fn distance_map_matches_brute_force_on_random_stars() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let cell = 0.1;
    let mut worst_cells: f64 = 0.0;
    let (mut worst_noisy, mut samples_noisy, mut above): (f64, usize, usize) = (0.0, 0, 0);
    for case in 0..6 {
        let mut a = star(&mut rng, [0.0, 0.0], 6.0, 60 + 20 * case);
        let mut b = star(&mut rng, [14.0, 3.0], 4.0, 40 + 50 * case);
        if case >= 3 {
            // Noisy contours (like compiled CT contours): many local minima of the distance
            // along the contour. Kept simple, as compiled contours are.
            for p in a.iter_mut().chain(b.iter_mut()) {
                p[0] += rng.random_range(-0.04..0.04);
                p[1] += rng.random_range(-0.04..0.04);
            }
            assert!(is_simple(&a) && is_simple(&b));
        }
        let set: Vec<&[Point]> = vec![&a, &b];
        let grid = Grid::covering([-10.0, -9.0, 21.0, 10.0], cell, 2, 1 << 22).unwrap();
        let d = signed_distance(&grid, &set);
        // Every other row and column: brute force is the slow part of this test.
        for r in (0..grid.height).step_by(2) {
            for c in (case % 2..grid.width).step_by(2) {
                let p = grid.point(r, c);
                let e = union_sd(&set, p);
                let got = d[r * grid.width + c] as f64;
                let err = (got - e).abs() / cell;
                if case >= 3 {
                    worst_noisy = worst_noisy.max(err);
                    samples_noisy += 1;
                    above += (err > 0.01) as usize;
                } else {
                    worst_cells = worst_cells.max(err);
                }
            }
        }
    }
    eprintln!(
        "distance map vs brute force: smooth stars max error {worst_cells:.2e} cell; noisy \
         stars max {worst_noisy:.2e} cell, {above} of {samples_noisy} samples above 0.01 cell"
    );
    // f32 storage alone accounts for ~1e-6 mm at these magnitudes.
    assert!(worst_cells < 1e-3, "max error {worst_cells} cell");
    // On wiggly contours a few isolated samples deep inside keep a foot point on a
    // neighbouring wiggle.
    assert!(worst_noisy < 0.1, "max error {worst_noisy} cell");
    assert!(
        above * 1000 < samples_noisy,
        "{above} samples above 0.01 cell"
    );
}

#[test]
fn one_to_one_concentric_circles_give_the_mean_circle() {
    let (r1, r2, cell) = (12.0, 7.0, 0.1);
    let a = ellipse(2.0, 1.0, r1, r1, 600);
    let b = ellipse(2.0, 1.0, r2, r2, 600);
    let r = intermediate_contours(&[&a], &[&b], cell).unwrap();
    check_loops_valid(&r);
    let mut worst: f64 = 0.0;
    for lp in loops(&r.lower).into_iter().chain(loops(&r.upper)) {
        for p in lp {
            worst = worst.max(((p[0] - 2.0).hypot(p[1] - 1.0) - 0.5 * (r1 + r2)).abs());
        }
    }
    eprintln!("1-to-1 circles: radius error max {:.4} cell", worst / cell);
    assert!(worst < cell / 2.0);
}

#[test]
fn one_to_two_ellipse_over_two_discs() {
    let cell = 0.1;
    let lower = ellipse(0.0, 0.0, 30.0, 12.0, 720);
    let d1 = ellipse(-15.0, 0.0, 10.0, 10.0, 360);
    let d2 = ellipse(15.0, 0.0, 10.0, 10.0, 360);
    let (a1, a2): (Vec<&[Point]>, Vec<&[Point]>) = (vec![&lower], vec![&d1, &d2]);
    let r = intermediate_contours(&a1, &a2, cell).unwrap();
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    check_loops_valid(&r);
    let lo = loops(&r.lower);
    let up = loops(&r.upper);
    assert_eq!((lo.len(), up.len()), (1, 2));

    // The lower intermediate contour is ∂M: φ_M = ½(d_A1 + d_A2) vanishes on it.
    let phi = |p: Point| 0.5 * (union_sd(&a1, p) + union_sd(&a2, p));
    let worst_phi = lo[0].iter().map(|&p| phi(p).abs()).fold(0.0, f64::max);
    // The upper loops' outer parts (away from the bisector x = 0) lie on the lower loop.
    let mut worst_outer: f64 = 0.0;
    // On the bisector x = 0 (compressed to a few points since it is straight): every point of
    // one upper loop there is a point of the other, bit for bit.
    let mut worst_bisector: f64 = 0.0;
    let mut shared = 0;
    for (k, lp) in up.iter().enumerate() {
        let other = up[1 - k];
        for &p in lp.iter() {
            if p[0].abs() > cell {
                worst_outer = worst_outer.max(boundary_distance(lo[0], p));
            } else {
                worst_bisector = worst_bisector.max(p[0].abs());
                if phi(p) < -cell {
                    assert!(other.contains(&p), "bisector point {p:?} not shared");
                }
                shared += other.contains(&p) as usize;
            }
        }
    }
    let (union_gap, same, total) = tiling_gap_counts(&r, cell);
    eprintln!(
        "1-to-2: |φ_M| on lower loop ≤ {:.4} cell; upper outer parts to lower loop ≤ {:.2e} cell; \
         bisector |x| ≤ {:.2e} cell ({shared} shared points); tiling gap {:.2e} cell; \
         {same} of {total} ∂M vertices identical on both sides",
        worst_phi / cell,
        worst_outer / cell,
        worst_bisector / cell,
        union_gap / cell
    );
    assert!(shared >= 2);
    assert!(worst_phi < 0.3 * cell);
    assert!(worst_outer < 0.3 * cell);
    assert!(worst_bisector < 0.5 * cell);
    assert!(union_gap < 0.01 * cell);
    assert!(same + 2 >= total, "{same} of {total} ∂M vertices shared");
    let (al, au) = (area_sum(&r.lower), area_sum(&r.upper));
    assert!((al - au).abs() < 0.002 * al, "areas {al} vs {au}");
}

#[test]
fn two_to_two_and_one_to_three_tile_the_same_mid_section() {
    let cell = 0.1;
    // 2-to-2: two discs below, two shifted ellipses above, crossing over.
    let l1 = ellipse(-8.0, 0.0, 7.0, 7.0, 300);
    let l2 = ellipse(8.0, 0.0, 7.0, 7.0, 300);
    let u1 = ellipse(0.0, 6.0, 12.0, 5.0, 300);
    let u2 = ellipse(0.0, -7.0, 12.0, 4.0, 300);
    // 1-to-3: a wide ellipse over three discs.
    let w = ellipse(0.0, 0.0, 26.0, 9.0, 600);
    let t: Vec<Vec<Point>> = [-17.0, 0.0, 17.0]
        .iter()
        .map(|&x| ellipse(x, 0.0, 7.0, 7.0, 300))
        .collect();
    type Section<'a> = Vec<&'a [Point]>;
    let cases: Vec<(&str, Section, Section)> = vec![
        ("2-to-2", vec![&l1, &l2], vec![&u1, &u2]),
        ("1-to-3", vec![&w], vec![&t[0], &t[1], &t[2]]),
        ("3-to-1", vec![&t[0], &t[1], &t[2]], vec![&w]),
    ];
    for (name, a1, a2) in cases {
        let r = intermediate_contours(&a1, &a2, cell).unwrap();
        check_loops_valid(&r);
        assert_eq!(loops(&r.lower).len(), a1.len(), "{name}: {:?}", r.warnings);
        assert_eq!(loops(&r.upper).len(), a2.len(), "{name}: {:?}", r.warnings);
        let (gap, same, total) = tiling_gap_counts(&r, cell);
        let (al, au) = (area_sum(&r.lower), area_sum(&r.upper));
        eprintln!(
            "{name}: tiling gap {:.2e} cell, areas {al:.4} / {au:.4} mm², {same} of {total} ∂M \
             vertices identical on both sides",
            gap / cell
        );
        assert!(gap < 0.01 * cell, "{name}: gap {gap}");
        assert!(
            same + 2 >= total,
            "{name}: {same} of {total} ∂M vertices shared"
        );
        assert!((al - au).abs() < 0.003 * al, "{name}: areas {al} vs {au}");
    }
}

#[test]
fn unconnected_contour_degenerates_to_a_point_with_a_warning() {
    let cell = 0.1;
    let big = ellipse(0.0, 0.0, 10.0, 10.0, 300);
    let far = ellipse(30.0, 0.0, 3.0, 3.0, 100);
    let top = ellipse(0.0, 0.0, 8.0, 8.0, 300);
    let r = intermediate_contours(&[&big, &far], &[&top], cell).unwrap();
    check_loops_valid(&r);
    assert!(matches!(r.lower[0], Intermediate::Loop(_)));
    let Intermediate::Point(p) = r.lower[1] else {
        panic!("expected a point: {:?}", r.lower[1])
    };
    // M is the disc of radius 9; the point of M nearest to the far contour is near (9, 0).
    assert!(
        (p[0] - 9.0).abs() < 2.0 * cell && p[1].abs() < 2.0 * cell,
        "{p:?}"
    );
    assert!(r.warnings.iter().any(|w| w.contains("lower contour 1")));
    // No overlap at all: everything closes at its own innermost point.
    let r = intermediate_contours(&[&far], &[&top], cell).unwrap();
    assert!(matches!(r.lower[0], Intermediate::Point(p) if (p[0] - 30.0).abs() < cell));
    assert!(!r.warnings.is_empty());
}

#[test]
fn caps_of_disc_annulus_and_two_holed_plate() {
    let cell = 0.1;
    let disc = ellipse(4.0, -3.0, 9.0, 9.0, 500);
    let c = cap(&disc, &[], cell, 0.0).unwrap();
    let Intermediate::Point(p) = c.outer else {
        panic!()
    };
    eprintln!(
        "cap of a disc: centre error {:.2e} cell",
        (p[0] - 4.0).hypot(p[1] + 3.0) / cell
    );
    assert!((p[0] - 4.0).hypot(p[1] + 3.0) < cell / 2.0);

    let outer = ellipse(0.0, 0.0, 18.0, 18.0, 700);
    let mut hole = ellipse(0.0, 0.0, 6.0, 6.0, 300);
    hole.reverse();
    let c = cap(&outer, &[&hole], cell, 0.0).unwrap();
    let mut worst: f64 = 0.0;
    for lp in loops(&[c.outer.clone(), c.holes[0].clone()]) {
        for p in lp {
            worst = worst.max((p[0].hypot(p[1]) - 12.0).abs());
        }
    }
    eprintln!(
        "cap of an annulus: ridge radius error {:.4} cell",
        worst / cell
    );
    assert!(worst < cell / 2.0);

    // Two holes: the outer contour closes onto the loop around both hole zones; each hole
    // onto its own zone; the three caps share the ridge chains.
    let plate = ellipse(0.0, 0.0, 24.0, 14.0, 700);
    let mut h1 = ellipse(-10.0, 0.0, 4.0, 4.0, 200);
    let mut h2 = ellipse(10.0, 0.0, 4.0, 4.0, 200);
    h1.reverse();
    h2.reverse();
    let c = cap(&plate, &[&h1, &h2], cell, 0.0).unwrap();
    let all: Vec<Intermediate> = std::iter::once(c.outer.clone())
        .chain(c.holes.iter().cloned())
        .collect();
    let ls = loops(&all);
    assert_eq!(ls.len(), 3, "{:?}", c.warnings);
    for lp in &ls {
        assert!(signed_area(lp) > 0.0 && is_simple(lp));
    }
    // The hole caps together cover the outer cap's region.
    let (ao, ah) = (signed_area(ls[0]), signed_area(ls[1]) + signed_area(ls[2]));
    assert!((ao - ah).abs() < 0.003 * ao, "areas {ao} vs {ah}");
    // Every point of a hole cap surrounds its hole.
    assert!(contains(ls[1], [-10.0, 0.0]) && contains(ls[2], [10.0, 0.0]));
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 12,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Random star-shaped m-to-n problems: loops are simple, counter-clockwise, inside the
    /// footprint A1 ∪ A2 (plus one cell), and both sides tile M alike.
    #[test]
    fn random_m_to_n_problems(
        seed in any::<u64>(),
        m in 1usize..=2,
        n in 1usize..=3,
        t in 0.1f64..0.9,
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let cell = 0.15;
        // Contours of one section along x, far enough apart not to touch (radius ≤ 1.4 r).
        let lower: Vec<Vec<Point>> = (0..m)
            .map(|i| star(&mut rng, [i as f64 * 18.0, 0.0], 6.0, 80))
            .collect();
        let span = (m as f64 - 1.0) * 18.0;
        let upper: Vec<Vec<Point>> = (0..n)
            .map(|k| {
                let x = if n == 1 { span / 2.0 } else { k as f64 * span.max(12.0) / (n as f64 - 1.0) };
                let y = rng.random_range(-2.0..2.0);
                star(&mut rng, [x, y], if n > m { 4.0 } else { 6.0 }, 60)
            })
            .collect();
        let a1: Vec<&[Point]> = lower.iter().map(|v| v.as_slice()).collect();
        let a2: Vec<&[Point]> = upper.iter().map(|v| v.as_slice()).collect();
        // The plane the rule chooses, and a random one: the same properties hold at any t.
        let chosen = intermediate_contours(&a1, &a2, cell).unwrap();
        let forced = intermediate_contours_at(&a1, &a2, cell, t).unwrap();
        for r in [&chosen, &forced] {
            prop_assert!(r.t > 0.0 && r.t < 1.0);
            prop_assert_eq!(r.lower.len(), m);
            prop_assert_eq!(r.upper.len(), n);
            check_loops_valid(r);
            for lp in loops(&r.lower).into_iter().chain(loops(&r.upper)) {
                for &p in lp.iter() {
                    let inside = a1.iter().chain(a2.iter()).any(|c| contains(c, p));
                    let near = a1.iter().chain(a2.iter())
                        .map(|c| boundary_distance(c, p)).fold(f64::INFINITY, f64::min);
                    prop_assert!(inside || near <= cell, "point {:?} outside the footprint", p);
                }
            }
            if r.warnings.is_empty() {
                let (al, au) = (area_sum(&r.lower), area_sum(&r.upper));
                prop_assert!((al - au).abs() < 0.01 * al.max(1.0), "areas {} vs {}", al, au);
                // Usually 0 (every vertex on ∂M shared bit for bit): 190 of 191 of seeds
                // 0..300 without warnings; where the tracing gives up on a corner, within a
                // cell (worst of 1,500 random cases: 0.51 cell, at a forced t).
                prop_assert!(tiling_gap(r, cell) < cell);
            }
        }
        // Deterministic: a second run is identical.
        prop_assert_eq!(intermediate_contours(&a1, &a2, cell).unwrap(), chosen);
        prop_assert_eq!(intermediate_contours_at(&a1, &a2, cell, t).unwrap(), forced);
    }
}

#[test]
fn degenerate_inputs_do_not_panic() {
    let cell = 0.2;
    let disc = ellipse(0.0, 0.0, 5.0, 5.0, 100);
    let line: Vec<Point> = vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
    let dup: Vec<Point> = vec![[1.0, 1.0]; 5];
    let mut cw = disc.clone();
    cw.reverse();
    for bad in [&line, &dup, &cw] {
        if let Ok(r) = intermediate_contours(&[bad], &[&disc], cell) {
            check_loops_valid(&r);
            assert_eq!((r.lower.len(), r.upper.len()), (1, 1));
        }
        if let Ok(r) = intermediate_contours(&[&disc], &[bad, &disc], cell) {
            check_loops_valid(&r);
        }
        let _ = cap(bad, &[], cell, 0.0);
        let _ = cap(&disc, &[bad], cell, 0.0);
    }
    // Infinite coordinates and bad cells are refused (huge rasters are coarsened: see the
    // unit test in branching.rs, a full-size raster is too slow for a debug test run).
    let inf: Vec<Point> = vec![[0.0, 0.0], [f64::INFINITY, 0.0], [0.0, 1.0]];
    assert!(intermediate_contours(&[&inf], &[&disc], cell).is_err());
    assert!(cap(&inf, &[], cell, 0.0).is_err());
    assert!(cap(&disc, &[], f64::NAN, 0.0).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 8,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// A random star-shaped plate with a random star-shaped hole closes like a torus: the
    /// outer contour's cap and the hole's cap are one and the same ridge loop, lying in the
    /// material, around the hole.
    #[test]
    fn random_annulus_caps_onto_one_ridge_loop(seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let cell = 0.15;
        let outer = star(&mut rng, [0.0, 0.0], 12.0, 120);
        let hx = rng.random_range(-1.0..1.0);
        let mut hole = star(&mut rng, [hx, 0.0], 3.0, 60);
        hole.reverse();
        let c = cap(&outer, &[&hole], cell, 0.0).unwrap();
        let (Intermediate::Loop(o), Intermediate::Loop(h)) = (&c.outer, &c.holes[0]) else {
            return Err(TestCaseError::fail(format!("expected loops: {:?}", c.warnings)));
        };
        prop_assert!(signed_area(o) > 0.0 && is_simple(o));
        prop_assert_eq!(o, h);
        prop_assert!(contains(o, [0.0, 0.0]) || contains(o, hole[0]));
        for &p in o.iter() {
            prop_assert!(contains(&outer, p) && !contains(&hole, p), "{:?} not in the material", p);
        }
    }
}

/// Signed distance at `t` of the way between the sections: `(1 − t)·d_A1 + t·d_A2`.
fn phi_t(a1: &[&[Point]], a2: &[&[Point]], t: f64, p: Point) -> f64 {
    (1.0 - t) * union_sd(a1, p) + t * union_sd(a2, p)
}

/// The checks of a clean result at its `t`: loops valid, one per contour, both sides tile
/// the same `M_t` (shared ∂M vertices, equal areas), and the lower loops of a single lower
/// contour lie on `∂M_t` where they are not on a bisector.
fn check_clean_at_t(
    name: &str,
    r: &IntermediateContours,
    a1: &[&[Point]],
    a2: &[&[Point]],
    cell: f64,
) {
    assert!(
        r.warnings.is_empty(),
        "{name} at t = {}: {:?}",
        r.t,
        r.warnings
    );
    check_loops_valid(r);
    assert_eq!(loops(&r.lower).len(), a1.len(), "{name} at t = {}", r.t);
    assert_eq!(loops(&r.upper).len(), a2.len(), "{name} at t = {}", r.t);
    let (gap, same, total) = tiling_gap_counts(r, cell);
    let (al, au) = (area_sum(&r.lower), area_sum(&r.upper));
    let worst_phi = if a1.len() == 1 {
        loops(&r.lower)[0]
            .iter()
            .map(|&p| phi_t(a1, a2, r.t, p).abs())
            .fold(0.0, f64::max)
    } else {
        0.0
    };
    eprintln!(
        "{name} at t = {}: tiling gap {:.2e} cell, areas {al:.4} / {au:.4} mm², {same} of \
         {total} ∂M_t vertices identical on both sides, |φ_t| on a single lower loop ≤ {:.4} \
         cell",
        r.t,
        gap / cell,
        worst_phi / cell
    );
    assert!(gap < 0.01 * cell, "{name} at t = {}: gap {gap}", r.t);
    assert!(
        same + 2 >= total,
        "{name} at t = {}: {same} of {total} shared",
        r.t
    );
    assert!(
        (al - au).abs() < 0.003 * al,
        "{name} at t = {}: areas {al} vs {au}",
        r.t
    );
    assert!(
        worst_phi < 0.3 * cell,
        "{name} at t = {}: |φ_t| {worst_phi}",
        r.t
    );
}

/// A horseshoe: the ring between radii `r1` and `r2` round the origin, open where |θ| < `gap`
/// (towards +x), counter-clockwise.
fn horseshoe(r1: f64, r2: f64, gap: f64, n: usize) -> Vec<Point> {
    let arc = |r: f64, k: usize| {
        let th = gap + (2.0 * std::f64::consts::PI - 2.0 * gap) * k as f64 / n as f64;
        [r * th.cos(), r * th.sin()]
    };
    (0..=n)
        .map(|k| arc(r2, k))
        .chain((0..=n).rev().map(|k| arc(r1, k)))
        .collect()
}

/// A horseshoe 10 mm thick under a disc at each of its tips: M_½ is in two pieces, one at each
/// tip, so the horseshoe's zone (everything) meets it twice, and no straight slit inside the
/// horseshoe joins them (it would cross the opening); a slit that follows the horseshoe
/// round does (`geometry::bridges`' polyline bridges).
fn horseshoe_under_two_discs() -> (Vec<Point>, Vec<Point>, Vec<Point>) {
    let band = horseshoe(15.0, 25.0, 0.5, 300);
    let tip = |s: f64| [20.0 * (0.65f64).cos(), s * 20.0 * (0.65f64).sin()];
    let (l, r) = (tip(1.0), tip(-1.0));
    (
        band,
        ellipse(l[0], l[1], 5.0, 5.0, 200),
        ellipse(r[0], r[1], 5.0, 5.0, 200),
    )
}

#[test]
fn a_split_round_a_bend_is_joined_at_the_mid_plane() {
    let cell = 0.15;
    let (lower, left, right) = horseshoe_under_two_discs();
    let (a1, a2): (Vec<&[Point]>, Vec<&[Point]>) = (vec![&lower], vec![&left, &right]);
    let half = intermediate_contours_at(&a1, &a2, cell, 0.5).unwrap();
    // Before the polyline bridges the tip piece was dropped at ½ and the plane moved down.
    assert!(
        half.notes.iter().any(|w| w.contains("lower contour 0")
            && w.contains("2 pieces; joined 2")
            && w.contains("dropped 0.0000")),
        "{:?} / {:?}",
        half.notes,
        half.warnings
    );
    let r = intermediate_contours(&a1, &a2, cell).unwrap();
    assert_eq!(r.t, 0.5);
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    check_loops_valid(&r);
    // Both sides cover the same M_½ (the slit adds no area).
    let (al, au) = (area_sum(&r.lower), area_sum(&r.upper));
    assert!((al - au).abs() < 0.003 * al, "areas {al} vs {au}");
    let Intermediate::Loop(lo) = &r.lower[0] else {
        panic!()
    };
    // One piece under both discs.
    let centre = |c: &[Point]| {
        let n = c.len() as f64;
        [
            c.iter().map(|p| p[0]).sum::<f64>() / n,
            c.iter().map(|p| p[1]).sum::<f64>() / n,
        ]
    };
    assert!(contains(lo, centre(&left)) && contains(lo, centre(&right)));
    // Deterministic.
    assert_eq!(intermediate_contours(&a1, &a2, cell).unwrap(), r);
}

#[test]
fn a_merge_round_a_bend_is_joined_at_the_mid_plane() {
    // The same problem upside down: the upper horseshoe's zone splits at t = ½, and a slit
    // round the bend joins it there.
    let cell = 0.15;
    let (band, left, right) = horseshoe_under_two_discs();
    let (a1, a2): (Vec<&[Point]>, Vec<&[Point]>) = (vec![&left, &right], vec![&band]);
    let r = intermediate_contours(&a1, &a2, cell).unwrap();
    assert_eq!(r.t, 0.5);
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    check_loops_valid(&r);
    assert_eq!((loops(&r.lower).len(), loops(&r.upper).len()), (2, 1));
    // Mirror image of the downward case: the same plane, mirrored.
    let down = intermediate_contours(&[&band], &[&left, &right], cell).unwrap();
    assert!(
        (r.t - (1.0 - down.t)).abs() < 1e-12,
        "{} vs {}",
        r.t,
        down.t
    );
}

#[test]
fn a_split_that_bridges_join_whole_keeps_the_mid_plane() {
    // A long band under two discs far apart at its ends: the band's zone meets M_½ in two
    // pieces, but a straight slit through the band joins them, so the plane stays at ½
    // instead of moving near the band.
    let cell = 0.15;
    let lower = ellipse(0.0, 0.0, 30.0, 4.0, 400);
    let left = ellipse(-24.0, 0.0, 5.0, 5.0, 200);
    let right = ellipse(25.0, 0.0, 4.0, 4.0, 200);
    for (a1, a2, side) in [
        (vec![&lower[..]], vec![&left[..], &right[..]], "lower"),
        (vec![&left[..], &right[..]], vec![&lower[..]], "upper"),
    ] {
        let r = intermediate_contours(&a1, &a2, cell).unwrap();
        assert_eq!(r.t, 0.5, "{side}");
        // Nothing is lost, so the join is a note, not a warning.
        assert!(r.warnings.is_empty(), "{side}: {:?}", r.warnings);
        assert!(
            r.notes
                .iter()
                .any(|w| w.contains(&format!("{side} contour"))
                    && w.contains("joined 2 by bridges, dropped 0.0000")),
            "{side}: {:?}",
            r.notes
        );
        let band = if side == "lower" {
            &r.lower[0]
        } else {
            &r.upper[0]
        };
        let Intermediate::Loop(lo) = band else {
            panic!("{side}")
        };
        assert!(
            contains(lo, [-24.0, 0.0]) && contains(lo, [25.0, 0.0]),
            "{side}"
        );
    }
}

#[test]
fn a_split_on_both_sides_keeps_the_mid_plane_with_a_note() {
    // One problem holding a band under two discs (a lower zone splits at t = ½ and mends
    // towards 0) beside two discs under a band (an upper zone splits and mends towards 1):
    // no single plane mends both.
    let cell = 0.2;
    let band_lo = ellipse(0.0, 0.0, 30.0, 4.0, 400);
    let l1 = ellipse(-24.0, 0.0, 5.0, 5.0, 200);
    let l2 = ellipse(25.0, 0.0, 4.0, 4.0, 200);
    let band_up = ellipse(0.0, 40.0, 30.0, 4.0, 400);
    let u1 = ellipse(-24.0, 40.0, 5.0, 5.0, 200);
    let u2 = ellipse(25.0, 40.0, 4.0, 4.0, 200);
    let r = intermediate_contours(&[&band_lo, &u1, &u2], &[&l1, &l2, &band_up], cell).unwrap();
    assert_eq!(r.t, 0.5);
    // The bridges below join every piece, so no plane mending both loses nothing: a note.
    assert!(
        r.notes.iter().any(|w| w.contains("both sections")),
        "{:?}",
        r.notes
    );
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    check_loops_valid(&r);
    // Each band's zone meets the plane in two pieces (under the two discs); a bridge through
    // the band joins them, so both sections' loops still tile the same intermediate section.
    let joined = r
        .notes
        .iter()
        .filter(|w| w.contains("in 2 pieces; joined 2 by bridges, dropped 0.0000"))
        .count();
    assert_eq!(joined, 2, "{:?}", r.notes);
    let (lo, up) = (area_sum(&r.lower), area_sum(&r.upper));
    println!("split bands: lower loops {lo:.3} mm², upper loops {up:.3} mm²");
    assert!((lo - up).abs() < 1e-6 * lo, "{lo} vs {up}");
    assert!(tiling_gap(&r, cell) <= cell, "gap {}", tiling_gap(&r, cell));
}

#[test]
fn a_split_mended_near_the_mid_plane_moves_the_plane() {
    // A band 8 mm thick under two discs 12 mm apart: the band's zone meets M_½ under each
    // disc (the gap between them is 6 mm from either), but at t = 0.35 it spans the gap. A
    // straight slit would join the pieces at ½ too; a plane that near the middle is kept
    // anyway (only planes nearer a section than NEAR_SECTION_T give way to bridges).
    let cell = 0.15;
    let band = ellipse(0.0, 0.0, 30.0, 4.0, 400);
    let left = ellipse(-11.0, 0.0, 5.0, 5.0, 200);
    let right = ellipse(11.0, 0.0, 5.0, 5.0, 200);
    let half = intermediate_contours_at(&[&band], &[&left, &right], cell, 0.5).unwrap();
    assert!(
        half.notes.iter().any(|w| w.contains("in 2 pieces")),
        "{:?}",
        half.notes
    );
    for (a1, a2, t, side) in [
        (vec![&band[..]], vec![&left[..], &right[..]], 0.35, "lower"),
        (vec![&left[..], &right[..]], vec![&band[..]], 0.65, "upper"),
    ] {
        let r = intermediate_contours(&a1, &a2, cell).unwrap();
        assert!((r.t - t).abs() < 1e-12, "{side}: t = {}", r.t);
        // Mended: nothing split, joined or dropped at the moved plane.
        assert!(r.warnings.is_empty(), "{side}: {:?}", r.warnings);
        assert!(
            !r.notes.iter().any(|w| w.contains("pieces")),
            "{side}: {:?}",
            r.notes
        );
        check_clean_at_t(side, &r, &a1, &a2, cell);
        let lone = if side == "lower" { &r.lower } else { &r.upper };
        let Intermediate::Loop(lo) = &lone[0] else {
            panic!("{side}")
        };
        assert!(
            contains(lo, [-11.0, 0.0]) && contains(lo, [0.0, 0.0]) && contains(lo, [11.0, 0.0]),
            "{side}: one loop under both discs and across the gap"
        );
        assert_eq!(intermediate_contours(&a1, &a2, cell).unwrap(), r, "{side}");
    }
}

#[test]
fn properties_hold_at_any_plane_position() {
    let cell = 0.1;
    let lower = ellipse(0.0, 0.0, 30.0, 12.0, 720);
    let d1 = ellipse(-15.0, 0.0, 10.0, 10.0, 360);
    let d2 = ellipse(15.0, 0.0, 10.0, 10.0, 360);
    let w = ellipse(0.0, 0.0, 26.0, 9.0, 600);
    let t3: Vec<Vec<Point>> = [-17.0, 0.0, 17.0]
        .iter()
        .map(|&x| ellipse(x, 0.0, 7.0, 7.0, 300))
        .collect();
    type Section<'a> = Vec<&'a [Point]>;
    let l1 = ellipse(-8.0, 0.0, 7.0, 7.0, 300);
    let l2 = ellipse(8.0, 0.0, 7.0, 7.0, 300);
    let u1 = ellipse(0.0, 6.0, 12.0, 5.0, 300);
    let u2 = ellipse(0.0, -7.0, 12.0, 4.0, 300);
    // Towards the section of several contours the intermediate section falls apart into
    // their pieces (the single contour's zone then meets it several times): only the planes
    // on the single contour's side, or near the middle, give one piece per zone.
    let (down, up, mid) = (vec![0.08, 0.25, 0.5], vec![0.5, 0.75, 0.92], vec![0.5]);
    let cases: Vec<(&str, Section, Section, Vec<f64>)> = vec![
        ("1-to-2", vec![&lower], vec![&d1, &d2], down.clone()),
        ("2-to-1", vec![&d1, &d2], vec![&lower], up.clone()),
        ("1-to-3", vec![&w], vec![&t3[0], &t3[1], &t3[2]], down),
        ("3-to-1", vec![&t3[0], &t3[1], &t3[2]], vec![&w], up),
        ("2-to-2", vec![&l1, &l2], vec![&u1, &u2], mid),
    ];
    for (name, a1, a2, ts) in cases {
        for t in ts {
            let r = intermediate_contours_at(&a1, &a2, cell, t).unwrap();
            assert_eq!(r.t, t);
            check_clean_at_t(name, &r, &a1, &a2, cell);
        }
    }
    let a = ellipse(0.0, 0.0, 5.0, 5.0, 100);
    for bad in [0.0, 1.0, -0.1, f64::NAN] {
        assert!(intermediate_contours_at(&[&a], &[&a], cell, bad).is_err());
    }
}
