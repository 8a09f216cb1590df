//! Shared generators for the `bspline_*` tests (included with `#[path]`; no tests of its own).
#![allow(dead_code)]
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// A star-shaped closed contour of `m` points around the origin: radius
/// `r0 (1 + Σ_k a_k cos(kθ + φ_k))` with Σ|a_k| ≤ 0.45 (so it stays star-shaped), angles
/// jittered, plus uniform noise of amplitude `noise` (mm) on each coordinate. CCW, P_0 at θ ≈ 0.
pub fn star(m: usize, r0: f64, noise: f64, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let harmonics: Vec<(f64, f64, f64)> = (2..6)
        .map(|k| {
            (
                k as f64,
                rng.random_range(0.0..0.11),
                rng.random_range(0.0..2.0 * PI),
            )
        })
        .collect();
    (0..m)
        .map(|j| {
            let th = 2.0 * PI * (j as f64 + rng.random_range(-0.3..0.3)) / m as f64;
            let r = r0
                * (1.0
                    + harmonics
                        .iter()
                        .map(|(k, a, ph)| a * (k * th + ph).cos())
                        .sum::<f64>());
            [
                r * th.cos() + rng.random_range(-noise..=noise),
                r * th.sin() + rng.random_range(-noise..=noise),
            ]
        })
        .collect()
}

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
