//! Timing of a realistic branching problem; ignored by default, run it in release:
//! `cargo test --release --test branching_perf -- --ignored --nocapture`.

use std::time::Instant;

/// CPU seconds used by this process so far (user + system, Linux), so the measurement means
/// something on a machine other builds are loading.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    // Fields 14 and 15 of stat (utime, stime) are 12 and 13 after the command name.
    (ticks(11) + ticks(12)) / 100.0
}

use bskin::geometry::branching::{intermediate_contours, Intermediate};
use bskin::geometry::capping::cap;
use bskin::geometry::polygon::Point;

fn ellipse(cx: f64, cy: f64, a: f64, b: f64, n: usize) -> Vec<Point> {
    (0..n)
        .map(|k| {
            let t = k as f64 * std::f64::consts::TAU / n as f64;
            [cx + a * t.cos(), cy + b * t.sin()]
        })
        .collect()
}

#[test]
#[ignore = "timing; run in release"]
fn one_to_two_over_100_by_60_mm_at_0_05_mm() {
    let lower = ellipse(0.0, 0.0, 50.0, 30.0, 2000);
    let u1 = ellipse(-24.0, 0.0, 25.0, 27.0, 1200);
    let u2 = ellipse(26.0, 2.0, 23.0, 25.0, 1200);
    let cell = 0.05;
    // Warm up rayon's pool so the measurement is the work alone.
    let _ = intermediate_contours(&[&lower], &[&u1, &u2], 1.0).unwrap();
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let r = intermediate_contours(&[&lower], &[&u1, &u2], cell).unwrap();
    let el = t.elapsed();
    let cpu = cpu_seconds() - cpu;
    let pts: Vec<usize> = r
        .lower
        .iter()
        .chain(&r.upper)
        .map(|i| match i {
            Intermediate::Loop(l) => l.len(),
            Intermediate::Point(_) => 1,
        })
        .collect();
    eprintln!(
        "1-to-2, 100 × 60 mm at {cell} mm ({} × {} samples): {:.0} ms wall, {:.0} ms CPU, \
         loop points {pts:?}, warnings {:?}",
        (100.0 / cell) as usize + 7,
        (60.0 / cell) as usize + 7,
        el.as_secs_f64() * 1e3,
        cpu * 1e3,
        r.warnings
    );
    let outer = ellipse(0.0, 0.0, 50.0, 30.0, 2000);
    let mut hole = ellipse(0.0, 0.0, 30.0, 12.0, 1000);
    hole.reverse();
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let c = cap(&outer, &[&hole], cell, 0.0).unwrap();
    eprintln!(
        "cap of a 100 × 60 mm annulus at {cell} mm: {:.0} ms wall, {:.0} ms CPU, warnings {:?}",
        t.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - cpu) * 1e3,
        c.warnings
    );
}

#[test]
#[ignore = "timing; run in release"]
fn ten_thousand_tiny_overlap_tests() {
    use bskin::geometry::overlap::{overlap_area, regions_overlap, Region};
    // A slice of 100 × 100 tiny contours (trabecular-bone-like) against a shifted copy.
    let lower: Vec<Vec<Point>> = (0..10_000)
        .map(|k| {
            ellipse(
                (k % 100) as f64 * 1.0,
                (k / 100) as f64 * 1.0,
                0.3,
                0.25,
                16,
            )
        })
        .collect();
    let upper: Vec<Vec<Point>> = lower
        .iter()
        .map(|c| c.iter().map(|p| [p[0] + 0.2, p[1] + 0.1]).collect())
        .collect();
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let mut hits = 0;
    let mut area = 0.0;
    for (a, b) in lower.iter().zip(&upper) {
        let (ra, rb) = (Region::filled(a), Region::filled(b));
        if regions_overlap(&ra, &rb, 0.01) {
            hits += 1;
            area += overlap_area(&ra, &rb, 0.02);
        }
    }
    eprintln!(
        "10 000 tiny pairs: {hits} overlap, total {area:.3} mm², {:.1} ms wall, {:.0} ms CPU",
        t.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - cpu) * 1e3
    );
    assert_eq!(hits, 10_000);
}

/// Contours as the input compilation makes them: marching squares on a 0.5 mm image, then
/// compressed within 0.05 mm (jagged at the pixel scale, hundreds of points).
fn compiled(f: impl Fn(f64, f64) -> f64, size: usize, pixel: f64) -> Vec<Vec<Point>> {
    use bskin::geometry::marching_squares::iso_loops;
    use bskin::geometry::simplify::simplify_closed;
    let field: Vec<f32> = (0..size * size)
        .map(|k| f((k % size) as f64 * pixel, (k / size) as f64 * pixel) as f32)
        .collect();
    iso_loops(&field, size, size, 0.0)
        .into_iter()
        .map(|l| {
            let mm: Vec<Point> = l.iter().map(|p| [p[0] * pixel, p[1] * pixel]).collect();
            simplify_closed(&mm, 0.05)
        })
        .collect()
}

#[test]
#[ignore = "timing; run in release"]
fn compiled_contours_one_to_two() {
    use bskin::geometry::polygon::{is_simple, signed_area};
    // A femur-like shaft below, splitting into two condyles above (with a little noise).
    let noise = |x: f64, y: f64| 0.3 * ((x * 1.7).sin() * (y * 2.3).cos());
    let below = compiled(
        |x, y| {
            1.0 - (((x - 50.0) / 30.0).powi(2) + ((y - 50.0) / 18.0).powi(2)).sqrt()
                + 0.01 * noise(x, y)
        },
        200,
        0.5,
    );
    let above = compiled(
        |x, y| {
            let a = 1.0 - (((x - 33.0) / 15.0).powi(2) + ((y - 52.0) / 16.0).powi(2)).sqrt();
            let b = 1.0 - (((x - 68.0) / 13.0).powi(2) + ((y - 48.0) / 15.0).powi(2)).sqrt();
            a.max(b) + 0.01 * noise(y, x)
        },
        200,
        0.5,
    );
    let lo: Vec<&[Point]> = below.iter().map(|v| v.as_slice()).collect();
    let up: Vec<&[Point]> = above.iter().map(|v| v.as_slice()).collect();
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let r = intermediate_contours(&lo, &up, 0.05).unwrap();
    eprintln!(
        "compiled {}-to-{} ({:?} / {:?} points) at 0.05 mm: {:.0} ms wall, {:.0} ms CPU, \
         warnings {:?}",
        lo.len(),
        up.len(),
        lo.iter().map(|c| c.len()).collect::<Vec<_>>(),
        up.iter().map(|c| c.len()).collect::<Vec<_>>(),
        t.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - cpu) * 1e3,
        r.warnings
    );
    for i in r.lower.iter().chain(&r.upper) {
        let Intermediate::Loop(l) = i else {
            panic!("degenerate: {i:?}")
        };
        assert!(signed_area(l) > 0.0 && is_simple(l));
        eprintln!(
            "  loop of {} points, area {:.2} mm²",
            l.len(),
            signed_area(l)
        );
    }
}
