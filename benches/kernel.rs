//! Kernel benchmark: Algorithm 1 (fewest control points) fits per second on noisy star
//! contours of 100, 1,000 and 5,000 points at 0.1 mm. `cargo bench --bench kernel`.
//! The same contours feed `scripts/bench_kernel_peer.py` (via `examples/kernel_peer.rs`).

use bskin::bspline::samples::noisy_star as star;
use bskin::bspline::{fit_fewest, FitOptions};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

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
