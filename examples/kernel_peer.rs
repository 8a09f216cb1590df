//! Feeds the kernel benchmark peer (`scripts/bench_kernel_peer.py`): generates deterministic
//! noisy star contours (100, 1,000, 5,000 points; ChaCha8, seed fixed), fits each with
//! Algorithm 1 at the given tolerance, and writes one JSON file with, per contour: the points,
//! bskin's control-point count, knots and control points (so the script can measure bskin's
//! error with the same dense sampler it uses for scipy), bskin's own true max error, and the
//! fit time (median of repeated runs, ms).
//!
//! Usage: `cargo run --release --example kernel_peer -- OUT.json [TOLERANCE_MM=0.1]`

use std::time::Instant;

use bskin::bspline::samples::noisy_star as star;
use bskin::bspline::{fit_fewest, FitOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = args
        .get(1)
        .ok_or("usage: kernel_peer OUT.json [TOLERANCE_MM]")?;
    let tol: f64 = match args.get(2) {
        Some(s) => s.parse()?,
        None => 0.1,
    };
    let opts = FitOptions::new(tol);
    let mut cases = Vec::new();
    for (m, seed) in [(100usize, 1u64), (1000, 2), (5000, 3)] {
        let pts = star(m, 30.0, 0.02, seed);
        let fit = fit_fewest(&pts, &opts)?;
        let reps = (20_000 / m).clamp(5, 200);
        let mut times = Vec::with_capacity(reps);
        for _ in 0..reps {
            let t = Instant::now();
            let f = fit_fewest(&pts, &opts)?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(f);
        }
        times.sort_by(f64::total_cmp);
        let ms = times[times.len() / 2];
        eprintln!(
            "{m:>5} points: {} control points, max error {:.5} mm, {ms:.3} ms",
            fit.n_control(),
            fit.max_error
        );
        cases.push(serde_json::json!({
            "points": pts,
            "bskin": {
                "n_control": fit.n_control(),
                "max_error": fit.max_error,
                "ms": ms,
                "domain_knots": fit.curve.knots().domain(),
                "control": fit.curve.control(),
                "met": fit.met,
            }
        }));
    }
    let doc = serde_json::json!({ "tolerance": tol, "cases": cases });
    std::fs::write(out, serde_json::to_string(&doc)?)?;
    Ok(())
}
