//! Property tests of arm spurs (`geometry::spur`): on random curved slivers (a ring sector of
//! random radius, width and sweep, anywhere, either orientation) whose loop covers only the
//! start, the neighbour's arm gets one spur, which runs inside the arm along its medial arc
//! nearly to its tip, outside the loop; the spurred loop is weakly simple, has the loop's area
//! and visits each spur point twice but the tip. And on random T-shaped lobes on a block
//! (trunk and crossbar of random widths and lengths), every spur or lobe walk stays inside
//! the lobe, walks each of its edges once each way, leaves the loop's area as it was, and
//! opens into a simple loop when moved a hair outwards: it never crosses itself.

use bskin::geometry::polygon::{
    boundary_distance, contains, dist, is_simple, is_weakly_simple, signed_area, Point,
};
use bskin::geometry::spur::{arm_spurs, with_spurs};
use proptest::prelude::*;

/// A ring sector round `c` of radii r0 < r1 over angles a0..a1, `n` points per side,
/// counter-clockwise (clockwise when `!ccw`).
fn band(c: Point, r0: f64, r1: f64, a0: f64, a1: f64, n: usize, ccw: bool) -> Vec<Point> {
    let at = |r: f64, k: usize| {
        let a = a0 + (a1 - a0) * k as f64 / n as f64;
        [c[0] + r * a.cos(), c[1] + r * a.sin()]
    };
    let mut pts: Vec<Point> = (0..=n).map(|k| at(r1, k)).collect();
    pts.extend((0..=n).rev().map(|k| at(r0, k)));
    if !ccw {
        pts.reverse();
    }
    pts
}

/// A 40 × 20 block with a vertex every mm along its top, counter-clockwise, and the block
/// with a T on top: a trunk `w` wide from x = `c` − w/2 up to y = 20 + `h`, a crossbar `t`
/// thick from `c − left` to `c + right`.
fn block_and_t(c: f64, w: f64, h: f64, left: f64, right: f64, t: f64) -> (Vec<Point>, Vec<Point>) {
    let mut block = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0]];
    block.extend((1..40).rev().map(|x| [x as f64, 20.0]));
    block.push([0.0, 20.0]);
    let (x0, x1, y1) = (c - w / 2.0, c + w / 2.0, 20.0 + h);
    let mut tee = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0]];
    tee.extend([
        [x1, 20.0],
        [x1, y1],
        [c + right, y1],
        [c + right, y1 + t],
        [c - left, y1 + t],
        [c - left, y1],
        [x0, y1],
        [x0, 20.0],
    ]);
    tee.push([0.0, 20.0]);
    (block, tee)
}

/// Each vertex moved `d` to the right of the way round: a zero-width walk opens into a thin
/// band, which is simple only if the walk never crosses itself.
fn opened(pts: &[Point], d: f64) -> Vec<Point> {
    let n = pts.len();
    let unit = |a: Point, b: Point| {
        let l = dist(a, b);
        [(b[0] - a[0]) / l, (b[1] - a[1]) / l]
    };
    (0..n)
        .map(|i| {
            let (p, q, r) = (pts[(i + n - 1) % n], pts[i], pts[(i + 1) % n]);
            let (e, f) = (unit(p, q), unit(q, r));
            let off = if e[0] * f[0] + e[1] * f[1] < -0.999 {
                e
            } else {
                let s = [e[1] + f[1], -e[0] - f[0]];
                let l = s[0].hypot(s[1]);
                [s[0] / l, s[1] / l]
            };
            [q[0] + d * off[0], q[1] + d * off[1]]
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn a_walk_round_a_lobe_stays_inside_it_and_never_crosses_itself(
        c in 14.0f64..26.0,
        w in 2.0f64..6.0,
        h in 6.0f64..20.0,
        left in 4.0f64..12.0,
        right in 4.0f64..12.0,
        t in 2.0f64..6.0,
        ccw in any::<bool>(),
    ) {
        let (mut lp, mut tee) = block_and_t(c, w, h, left, right, t);
        if !ccw {
            lp.reverse();
            tee.reverse();
        }
        let spurs = arm_spurs(&lp, &tee, 2.0, 0.5, 0.05);
        // One spur: a lobe walk where the T's chords leave it, an arm spur where they do not.
        prop_assert_eq!(spurs.len(), 1);
        for s in &spurs {
            for &p in &s.walk {
                prop_assert!(p[1] > 20.0, "{:?} not beyond the loop", p);
                prop_assert!(contains(&tee, p) || boundary_distance(&tee, p) < 1e-9, "{:?} outside the T", p);
            }
            let mut edges: Vec<(Point, Point)> = s.walk.windows(2).map(|e| (e[0], e[1])).collect();
            edges.push((lp[s.from], s.walk[0]));
            edges.push((s.walk[s.walk.len() - 1], lp[s.from]));
            for &(a, b) in &edges {
                let ways = |x: Point, y: Point| edges.iter().filter(|&&e| e == (x, y)).count();
                prop_assert_eq!((ways(a, b), ways(b, a)), (1, 1));
            }
        }
        let spurred = with_spurs(&lp, &spurs, |p| p);
        prop_assert!((signed_area(&spurred) - signed_area(&lp)).abs() < 1e-9);
        let outwards = if ccw { 1e-3 } else { -1e-3 };
        prop_assert!(is_simple(&opened(&spurred, outwards)));
        // Opened the other way its two sides overlap: the check can fail.
        prop_assert!(!is_simple(&opened(&spurred, -outwards)));
    }

    #[test]
    fn a_spur_runs_along_the_arm_the_loop_lacks(
        c in (-200.0f64..200.0, -200.0f64..200.0),
        radius in 30.0f64..150.0,
        width in 1.0f64..4.0,
        start in 0.0f64..std::f64::consts::TAU,
        covered in 10.0f64..60.0,
        arm in 20.0f64..120.0,
        ccw in any::<bool>(),
    ) {
        let c = [c.0, c.1];
        let (r0, r1) = (radius - width / 2.0, radius + width / 2.0);
        // Sweeps from arc lengths along the medial line; about one point per mm.
        let (a1, a2) = (start + covered / radius, start + (covered + arm) / radius);
        let lp = band(c, r0, r1, start, a1, covered.ceil() as usize, ccw);
        let nb = band(c, r0, r1, start, a2, (covered + arm).ceil() as usize, ccw);
        let reach = 2.0;
        let spurs = arm_spurs(&lp, &nb, reach, reach / 4.0, 0.03);
        prop_assert_eq!(spurs.len(), 1);
        // A thin arc is an arm, not a lobe: its walk is the path out and back.
        prop_assert!(!spurs[0].lobe);
        let walk = &spurs[0].walk;
        let path = &walk[..walk.len().div_ceil(2)];
        let polar = |p: Point| {
            let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
            (dx.hypot(dy), (dy.atan2(dx) - start).rem_euclid(std::f64::consts::TAU))
        };
        for (i, &p) in path.iter().enumerate() {
            let (r, a) = polar(p);
            // In the arm, beyond the loop, on the medial arc (sampling and compression
            // keep it within a quarter of the width; the tip's last chords are the shortest).
            // The last point is the tip, on the arm's end edge: anywhere across its width
            // (radius 74.57, width 1: 0.306 off the medial arc, 0.19 from the inner corner).
            let off = if i + 1 == path.len() { 0.5 * width + 1e-6 } else { 0.25 * width + 0.05 };
            prop_assert!(a >= a1 - start - 1e-9 && a <= a2 - start + 1e-9, "angle {} of {}..{}", a, a1 - start, a2 - start);
            prop_assert!(!contains(&lp, p));
            prop_assert!(contains(&nb, p) || (r - radius).abs() <= width / 2.0 + 1e-6);
            prop_assert!((r - radius).abs() <= off, "radius {} of {} at point {} of {}", r, radius, i, path.len());
        }
        // It reaches the arm's tip, within the width, and starts within a few reaches of
        // the loop's end.
        let (_, tip) = polar(path[path.len() - 1]);
        prop_assert!((a2 - start - tip) * radius <= width + 0.5, "tip {} mm short", (a2 - start - tip) * radius);
        let (_, root) = polar(path[0]);
        prop_assert!((root - (a1 - start)) * radius <= 4.0 * reach + width, "root {} mm out", (root - (a1 - start)) * radius);
        // The spurred loop: same area, weakly simple, spur points visited twice but the tip.
        let spurred = with_spurs(&lp, &spurs, |p| p);
        prop_assert!((signed_area(&spurred) - signed_area(&lp)).abs() <= 1e-9 * signed_area(&lp).abs().max(1.0));
        prop_assert!(is_weakly_simple(&spurred));
        let visits = |q: Point| spurred.iter().filter(|&&p| p == q).count();
        prop_assert_eq!(visits(path[path.len() - 1]), 1);
        for &p in &path[..path.len() - 1] {
            prop_assert_eq!(visits(p), 2);
        }
        prop_assert_eq!(visits(lp[spurs[0].from]), 2);
    }
}
