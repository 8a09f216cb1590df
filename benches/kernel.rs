//! Kernel benchmark: Algorithm 1 (fewest control points) fits per second on noisy star
//! contours of 100, 1,000 and 5,000 points at 0.1 mm. `cargo bench --bench kernel`.
//! The same contours feed `scripts/bench_kernel_peer.py` (via `examples/kernel_peer.rs`).

use std::f64::consts::PI;

use bskin::bspline::{fit_fewest, FitOptions};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Same generator and seeds as `examples/kernel_peer.rs`.
fn star(m: usize, r0: f64, noise: f64, seed: u64) -> Vec<[f64; 2]> {
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

fn fewest(c: &mut Criterion) {
    let opts = FitOptions::new(0.1);
    let mut g = c.benchmark_group("fit_fewest_0.1mm");
    for (m, seed) in [(100usize, 1u64), (1000, 2), (5000, 3)] {
        let pts = star(m, 30.0, 0.02, seed);
        g.throughput(Throughput::Elements(1));
        g.bench_with_input(BenchmarkId::from_parameter(m), &pts, |b, pts| {
            b.iter(|| fit_fewest(pts, &opts).map(|f| f.n_control()))
        });
    }
    g.finish();
}

criterion_group!(benches, fewest);
criterion_main!(benches);
