use bskin::geometry::distance_map::{
    distance_transform, inside_mask, signed_distance, unsigned_distance, Grid,
};
use bskin::geometry::marching_squares::iso_loops;
use bskin::geometry::polygon::Point;
use std::time::Instant;
fn ellipse(cx: f64, cy: f64, a: f64, b: f64, n: usize) -> Vec<Point> {
    (0..n)
        .map(|k| {
            let t = k as f64 * std::f64::consts::TAU / n as f64;
            [cx + a * t.cos(), cy + b * t.sin()]
        })
        .collect()
}
#[test]
#[ignore]
fn prof() {
    let lower = ellipse(0.0, 0.0, 50.0, 30.0, 2000);
    let grid = Grid::covering([-50.0, -30.0, 50.0, 30.0], 0.05, 3, 1 << 24).unwrap();
    let _ = unsigned_distance(&grid, &[&lower]);
    let t = Instant::now();
    let u = unsigned_distance(&grid, &[&lower]);
    eprintln!("unsigned {:?}", t.elapsed());
    let t = Instant::now();
    let _m = inside_mask(&grid, &[&lower]);
    eprintln!("mask {:?}", t.elapsed());
    let t = Instant::now();
    let _s = signed_distance(&grid, &[&lower]);
    eprintln!("signed {:?}", t.elapsed());
    let f: Vec<f64> = u
        .iter()
        .map(|&v| if v < 0.07 { 0.0 } else { f64::INFINITY })
        .collect();
    let t = Instant::now();
    let _ = distance_transform(&f, grid.width, grid.height);
    eprintln!("edt {:?}", t.elapsed());
    let t = Instant::now();
    let l = iso_loops(
        &u.iter().map(|&v| 3.0 - v).collect::<Vec<f32>>(),
        grid.width,
        grid.height,
        0.0,
    );
    eprintln!("iso {:?} {}", t.elapsed(), l.len());
}
