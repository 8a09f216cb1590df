//! The "just decoding" baseline of the pipeline benchmark (`scripts/bench/run.sh`): scans a
//! DICOM directory with `bskin::dicom` (the same header scan and series selection as `bskin
//! run`), then decodes every slice to HU with `bskin::dicom::decode_slice` (the same reader the
//! load stage uses), in parallel over the rayon pool like the load stage (or one by one with
//! `--serial`), and drops each image at once. Nothing else: no segmentation, no geometry.
//!
//! Prints one line of JSON on stdout: slices, pixels, scan and decode seconds, and a checksum
//! of the HU values (so the decode cannot be skipped and copies can be compared).
//!
//! `--contend MS` reproduces, outside the pipeline, what the load stage meets during a `run`:
//! it decodes from a thread outside the rayon pool in batches of `rayon::current_num_threads()`
//! (as `s1_load` does), timing the batches as the stage's busy time, while another thread keeps
//! the same global pool busy with parallel jobs of MS ms each (as the branching stage's
//! distance maps do). Without contention the busy time is the decode time; with it, it shows
//! how long the batches wait for a pool worker.
//!
//! Usage: `cargo run --release --example decode_only -- DIR [--series S] [--serial] [--contend MS]`

use std::path::PathBuf;
use std::time::Instant;

use rayon::prelude::*;

fn main() {
    let mut dir: Option<PathBuf> = None;
    let mut series: Option<String> = None;
    let mut serial = false;
    let mut contend: Option<u64> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--series" => series = args.next(),
            "--serial" => serial = true,
            "--contend" => contend = args.next().and_then(|v| v.parse().ok()),
            _ if dir.is_none() => dir = Some(PathBuf::from(a)),
            _ => {
                eprintln!("usage: decode_only DIR [--series S] [--serial]");
                std::process::exit(2);
            }
        }
    }
    let Some(dir) = dir else {
        eprintln!("usage: decode_only DIR [--series S] [--serial]");
        std::process::exit(2);
    };

    let t0 = Instant::now();
    let scan = bskin::dicom::scan(&dir).unwrap_or_else(|e| fail(e));
    let s = bskin::dicom::select_series(&scan, series.as_deref(), &dir).unwrap_or_else(|e| fail(e));
    let scan_s = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let one = |i: usize| -> (usize, f64) {
        let img = bskin::dicom::decode_slice(s, &s.slices[i], i).unwrap_or_else(|e| fail(e));
        let sum: f64 = img
            .hu
            .iter()
            .filter(|v| **v > f32::MIN)
            .map(|v| *v as f64)
            .sum();
        (img.hu.len(), sum)
    };
    if let Some(ms) = contend {
        contended(s, ms);
        return;
    }
    let (pixels, checksum) = if serial {
        (0..s.slices.len())
            .map(one)
            .fold((0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
    } else {
        (0..s.slices.len())
            .into_par_iter()
            .map(one)
            .reduce(|| (0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
    };
    let decode_s = t1.elapsed().as_secs_f64();
    println!(
        "{{\"slices\":{},\"pixels\":{},\"scan_s\":{:.4},\"decode_s\":{:.4},\"threads\":{},\"checksum\":{:.1}}}",
        s.slices.len(),
        pixels,
        scan_s,
        decode_s,
        if serial { 1 } else { rayon::current_num_threads() },
        checksum
    );
}

fn fail(e: impl std::fmt::Display) -> ! {
    eprintln!("decode_only: {e}");
    std::process::exit(1);
}

/// Decode in batches from a non-pool thread while another thread floods the global pool with
/// `ms`-millisecond jobs; prints the batches' total busy time.
fn contended(s: &bskin::dicom::Series, ms: u64) {
    use std::sync::atomic::{AtomicBool, Ordering};
    let stop = AtomicBool::new(false);
    let batch = rayon::current_num_threads().max(2);
    let n = s.slices.len();
    let spin = |ms: u64| {
        let t = Instant::now();
        let mut x = 0u64;
        while t.elapsed().as_millis() < ms as u128 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
    };
    let (busy, jobs) = std::thread::scope(|scope| {
        let flood = scope.spawn(|| {
            let mut jobs = 0usize;
            while !stop.load(Ordering::Relaxed) {
                (0..64).into_par_iter().for_each(|_| spin(ms));
                jobs += 64;
            }
            jobs
        });
        // Let the flood occupy the pool first, as branching does once it has work.
        std::thread::sleep(std::time::Duration::from_millis(50));
        let loader = scope.spawn(|| {
            let mut busy = 0.0;
            let mut start = 0;
            while start < n {
                let end = (start + batch).min(n);
                let t = Instant::now();
                let imgs: Vec<usize> = (start..end)
                    .into_par_iter()
                    .map(|i| {
                        bskin::dicom::decode_slice(s, &s.slices[i], i)
                            .unwrap_or_else(|e| fail(e))
                            .hu
                            .len()
                    })
                    .collect();
                std::hint::black_box(imgs);
                busy += t.elapsed().as_secs_f64();
                start = end;
            }
            busy
        });
        let busy = loader.join().unwrap();
        stop.store(true, Ordering::Relaxed);
        (busy, flood.join().unwrap())
    });
    println!(
        "{{\"slices\":{n},\"batch\":{batch},\"contend_ms\":{ms},\"load_busy_s\":{busy:.4},\"flood_jobs\":{jobs}}}"
    );
}
