//! Sample contours with a known family, for tests, benchmarks and the kernel peer comparison:
//! one generator so the criterion benchmark, `examples/kernel_peer.rs` and the property tests
//! measure the same shapes.

use std::f64::consts::PI;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A star-shaped closed contour of `m` points around the origin: radius
/// `r0 (1 + Σ_k a_k cos(kθ + φ_k))` over harmonics k = 2..5 with Σ|a_k| ≤ 0.45 (so it stays
/// star-shaped), angles jittered, plus uniform noise of amplitude `noise` (mm) on each
/// coordinate. Counter-clockwise, P_0 at θ ≈ 0; deterministic for a seed (ChaCha8).
pub fn noisy_star(m: usize, r0: f64, noise: f64, seed: u64) -> Vec<[f64; 2]> {
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
