//! Contour alignment: where each loop of a region starts. Known answers (rotated rings, a wall
//! thinner than the slice distance, where a nearest point lies on the wall's far face) and a
//! property: on random loops, the chosen start joins the loops at least as
//! closely as their true correspondence does.

use bskin::geometry::alignment::align_starts;
use proptest::prelude::*;

type P3 = [f64; 3];

/// Mean distance between the points of equal arc-length fraction of two loops read from the
/// given starts: what the skinned surface joins (chord-length parameters).
fn join_distance(a: &[P3], sa: usize, b: &[P3], sb: usize) -> f64 {
    let samples = |p: &[P3], s: usize, n: usize| -> Vec<P3> {
        let m = p.len();
        let q: Vec<P3> = (0..m).map(|i| p[(s + i) % m]).collect();
        let mut cum = vec![0.0];
        for i in 0..m {
            let (x, y) = (q[i], q[(i + 1) % m]);
            cum.push(cum[i] + dist(x, y));
        }
        let len = cum[m];
        let mut j = 0;
        (0..n)
            .map(|k| {
                let at = len * k as f64 / n as f64;
                while cum[j + 1] <= at {
                    j += 1;
                }
                let t = (at - cum[j]) / (cum[j + 1] - cum[j]);
                let (x, y) = (q[j], q[(j + 1) % m]);
                std::array::from_fn(|d| x[d] + t * (y[d] - x[d]))
            })
            .collect()
    };
    let n = 1000;
    let (pa, pb) = (samples(a, sa, n), samples(b, sb, n));
    pa.iter().zip(&pb).map(|(x, y)| dist(*x, *y)).sum::<f64>() / n as f64
}

fn dist(a: P3, b: P3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn ring(n: usize, r: f64, z: f64) -> Vec<P3> {
    (0..n)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / n as f64;
            [r * a.cos(), r * a.sin(), z]
        })
        .collect()
}

/// A counter-clockwise stadium (two half circles of radius `r` joined by straight sides of
/// length `len` along y), centred on (cx, 0), `n` points per half circle and per side.
fn stadium(cx: f64, r: f64, len: f64, z: f64, n: usize) -> Vec<P3> {
    let mut out = Vec::new();
    let h = 0.5 * len;
    for k in 0..n {
        // Right side, going up.
        out.push([cx + r, -h + len * k as f64 / n as f64, z]);
    }
    for k in 0..n {
        let a = std::f64::consts::PI * k as f64 / n as f64;
        out.push([cx + r * a.cos(), h + r * a.sin(), z]);
    }
    for k in 0..n {
        out.push([cx - r, h - len * k as f64 / n as f64, z]);
    }
    for k in 0..n {
        let a = std::f64::consts::PI * (1.0 + k as f64 / n as f64);
        out.push([cx + r * a.cos(), -h + r * a.sin(), z]);
    }
    out
}

#[test]
fn rotated_rings_start_on_a_straight_seam() {
    let a = ring(40, 10.0, 0.0);
    let mut b = ring(40, 10.0, 1.0);
    b.rotate_left(10);
    let mut c = ring(40, 10.0, 2.0);
    c.rotate_left(20);
    assert_eq!(align_starts(&[&a, &b, &c], 0.1), vec![0, 30, 20]);
}

#[test]
fn a_cap_point_keeps_its_single_start() {
    let cap = [[0.0, 0.0, -0.5]];
    let a = ring(12, 3.0, 0.0);
    let starts = align_starts(&[&cap, &a, &cap], 0.1);
    assert_eq!(starts.len(), 3);
    assert_eq!((starts[0], starts[2]), (0, 0));
}

/// A wall 0.8 mm thick, 40 mm long, and the next slice's wall 0.7 mm to the side: from a point
/// on the first loop's right face, the nearest point of the next loop is on its *left* face,
/// and a surface joining the loops there runs up one face and down the other, through the
/// wall (the paper's greedy nearest point). Each loop must start on the face where the
/// previous one does.
#[test]
fn a_thin_wall_is_not_crossed_by_the_seam() {
    let a = stadium(0.0, 0.4, 40.0, 0.0, 50);
    let b = stadium(0.7, 0.4, 40.0, 1.0, 50);
    let c = stadium(0.0, 0.4, 40.0, 2.0, 50);
    // The trap: nearest to a's right face (index 10, x = 0.4) is b's left face (x = 0.3).
    let nearest = (0..b.len())
        .min_by(|&i, &j| dist(a[10], b[i]).total_cmp(&dist(a[10], b[j])))
        .unwrap();
    assert!(b[nearest][0] < 0.7, "nearest {:?}", b[nearest]);
    let loops: Vec<&[P3]> = vec![&a, &b, &c];
    let starts = align_starts(&loops, 0.1);
    for (k, w) in loops.windows(2).enumerate() {
        let ours = join_distance(w[0], starts[k], w[1], starts[k + 1]);
        println!(
            "thin wall, slices {k}-{}: joined {ours:.2} mm apart on average",
            k + 1
        );
        // Each point joined to its counterpart: one slice (1 mm) up and 0.7 mm aside.
        assert!(
            ours < 1.3,
            "starts {starts:?} join slices {k}, {} at {ours}",
            k + 1
        );
    }
    // Every loop starts on the same face (side of its centre line) as the first.
    let side = |p: P3, cx: f64| p[0] > cx;
    let first = side(a[starts[0]], 0.0);
    assert_eq!(side(b[starts[1]], 0.7), first, "starts {starts:?}");
    assert_eq!(side(c[starts[2]], 0.0), first, "starts {starts:?}");
}

/// A random star-shaped loop: radius 1 + Σ a_k cos(k t + φ_k), times `r`.
fn star(terms: &[(f64, f64)], r: f64, z: f64, n: usize, phase: f64) -> Vec<P3> {
    (0..n)
        .map(|i| {
            let t = phase + i as f64 * std::f64::consts::TAU / n as f64;
            let s: f64 = terms
                .iter()
                .enumerate()
                .map(|(k, (a, ph))| a * ((k + 2) as f64 * t + ph).cos())
                .sum();
            [r * (1.0 + s) * t.cos(), r * (1.0 + s) * t.sin(), z]
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Two slices of one random shape, the second slightly scaled, shifted and sampled with a
    /// different point count from a random start: the chosen start joins them at least as
    /// closely as their true correspondence (the same angle), up to the spacing of points.
    #[test]
    fn chosen_start_joins_at_least_as_closely_as_the_truth(
        terms in prop::collection::vec((0.0f64..0.12, 0.0f64..std::f64::consts::TAU), 3),
        r in 5.0f64..40.0,
        scale in 0.9f64..1.1,
        n in 40usize..200,
        m in 40usize..200,
        start in 0usize..1000,
        dx in -1.0f64..1.0,
    ) {
        let a = star(&terms, r, 0.0, n, 0.0);
        let mut b = star(&terms, r * scale, 1.0, m, 0.0);
        for p in b.iter_mut() {
            p[0] += dx;
        }
        let s = start % m;
        b.rotate_left(s);
        let truth = (m - s) % m; // b's index of the angle 0, where a starts
        let c: Vec<&[P3]> = vec![&a, &b];
        let ours = align_starts(&c, 0.05 * r);
        let d_ours = join_distance(&a, ours[0], &b, ours[1]);
        let d_truth = join_distance(&a, ours[0], &b, (truth + ours[0] * m / n) % m);
        // One point of b's spacing of slack: starts are points, not fractions between them.
        let spacing = std::f64::consts::TAU * r * 1.4 / m as f64;
        prop_assert!(
            d_ours <= d_truth + spacing,
            "ours {ours:?} join at {d_ours:.3}, the truth at {d_truth:.3} (spacing {spacing:.3})"
        );
    }
}
