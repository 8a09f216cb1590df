//! Shared generators for the `bspline_*` tests (included with `#[path]`; no tests of its own).
#![allow(dead_code)]
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

use std::f64::consts::PI;

#[allow(unused_imports)] // not every test that includes this file fits stars
pub use bskin::bspline::samples::noisy_star as star;

pub fn lift(points: &[[f64; 2]], z: f64) -> Vec<[f64; 3]> {
    points.iter().map(|p| [p[0], p[1], z]).collect()
}

pub fn circle(m: usize, r: f64) -> Vec<[f64; 2]> {
    ellipse(m, r, r)
}

pub fn ellipse(m: usize, a: f64, b: f64) -> Vec<[f64; 2]> {
    (0..m)
        .map(|j| {
            let th = 2.0 * PI * j as f64 / m as f64;
            [a * th.cos(), b * th.sin()]
        })
        .collect()
}

pub fn dist<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    (0..D).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}
