//! The "just decoding" baseline of the pipeline benchmark (`scripts/bench/run.sh`): scans a
//! DICOM directory with `bskin::dicom` (the same header scan and series selection as `bskin
//! run`), then decodes every slice to HU with `bskin::dicom::decode_slice` (the same reader the
//! load stage uses), in parallel over the rayon pool like the load stage (or one by one with
//! `--serial`), and drops each image at once. Nothing else: no segmentation, no geometry.
//!
//! Prints one line of JSON on stdout: slices, pixels, scan and decode seconds, and a checksum
//! of the HU values (so the decode cannot be skipped and copies can be compared).
//!
//! Usage: `cargo run --release --example decode_only -- DIR [--series S] [--serial]`

use std::path::PathBuf;
use std::time::Instant;

use rayon::prelude::*;

fn main() {
    let mut dir: Option<PathBuf> = None;
    let mut series: Option<String> = None;
    let mut serial = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--series" => series = args.next(),
            "--serial" => serial = true,
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
