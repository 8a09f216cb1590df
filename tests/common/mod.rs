//! Shared helpers of the end-to-end tests: phantom series on disk, runs of the pipeline, and
//! distances between a mesh and a phantom's analytic surface.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// `../shared/data/<sub>` beside the checkout, or `None` with a "skipped" note (CI has it;
/// a bare checkout may not).
pub fn shared(sub: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(sub);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipped: shared data not found at {}", p.display());
        None
    }
}

use bskin::config::RunConfig;
use bskin::dicom::{self, WriteOptions};
use bskin::geometry::marching_squares::iso_loops;
use bskin::phantom::{generate, PhantomSpec, Shape};
use bskin::pipeline::{run_surfaces, RunInput, RunSummary};
use bskin::stages::Control;

/// Writes the phantom as a DICOM CT series under `dir`.
pub fn write_phantom(spec: &PhantomSpec, dir: &Path) -> PathBuf {
    let vol = generate(spec).expect("phantom");
    let out = dir.join(spec.shape.name());
    dicom::write_ct_series(&out, &vol.slices, &WriteOptions::default()).expect("write series");
    out
}

/// Scans `series_dir`, runs the whole pipeline into `out`.
pub fn run_dir(series_dir: &Path, out: &Path, config: &RunConfig) -> bskin::Result<RunSummary> {
    let scan = dicom::scan(series_dir)?;
    let series = dicom::select_series(&scan, None, series_dir)?.clone();
    std::fs::create_dir_all(out).unwrap();
    run_surfaces(
        RunInput::Images(&series),
        config,
        out,
        &Control::new(),
        &|_| {},
    )
}

/// Triangles of a binary STL.
pub fn read_stl(path: &Path) -> Vec<[[f64; 3]; 3]> {
    let b = std::fs::read(path).unwrap();
    let n = u32::from_le_bytes(b[80..84].try_into().unwrap()) as usize;
    assert_eq!(b.len(), 84 + 50 * n, "STL size matches its triangle count");
    (0..n)
        .map(|t| {
            let base = 84 + 50 * t + 12;
            let f = |k: usize| {
                f32::from_le_bytes(b[base + 4 * k..base + 4 * k + 4].try_into().unwrap()) as f64
            };
            [[f(0), f(1), f(2)], [f(3), f(4), f(5)], [f(6), f(7), f(8)]]
        })
        .collect()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Distance from `p` to triangle `t` (Ericson, Real-Time Collision Detection §5.1.5).
pub fn point_triangle(p: [f64; 3], t: &[[f64; 3]; 3]) -> f64 {
    let (a, b, c) = (t[0], t[1], t[2]);
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    let closest = if d1 <= 0.0 && d2 <= 0.0 {
        a
    } else {
        let bp = sub(p, b);
        let (d3, d4) = (dot(ab, bp), dot(ac, bp));
        let cp = sub(p, c);
        let (d5, d6) = (dot(ab, cp), dot(ac, cp));
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        let lerp =
            |o: [f64; 3], d: [f64; 3], s: f64| [o[0] + s * d[0], o[1] + s * d[1], o[2] + s * d[2]];
        if d3 >= 0.0 && d4 <= d3 {
            b
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            lerp(a, ab, d1 / (d1 - d3))
        } else if d6 >= 0.0 && d5 <= d6 {
            c
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            lerp(a, ac, d2 / (d2 - d6))
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            lerp(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)))
        } else {
            let denom = 1.0 / (va + vb + vc);
            let (v, w) = (vb * denom, vc * denom);
            [
                a[0] + ab[0] * v + ac[0] * w,
                a[1] + ab[1] * v + ac[1] * w,
                a[2] + ab[2] * v + ac[2] * w,
            ]
        }
    };
    let d = sub(p, closest);
    dot(d, d).sqrt()
}

/// Points on the analytic surface: marching squares on the shape's signed distance at planes
/// `z_step` apart within `[z_lo, z_hi]`, on a raster of `cell` mm (an independent truth: no
/// phantom sampling, no noise).
pub fn truth_points(shape: Shape, z_lo: f64, z_hi: f64, z_step: f64, cell: f64) -> Vec<[f64; 3]> {
    let n = (90.0 / cell) as usize;
    let x0 = -45.0;
    let mut out = Vec::new();
    let mut z = z_lo;
    while z <= z_hi {
        let field: Vec<f32> = (0..n * n)
            .map(|k| {
                -shape.signed_distance([x0 + (k % n) as f64 * cell, x0 + (k / n) as f64 * cell, z])
                    as f32
            })
            .collect();
        for lp in iso_loops(&field, n, n, 0.0) {
            out.extend(lp.iter().map(|p| [x0 + p[0] * cell, x0 + p[1] * cell, z]));
        }
        z += z_step;
    }
    out
}

/// Largest distance from `points` to the mesh (brute force over triangles near each point).
pub fn max_distance_to_mesh(points: &[[f64; 3]], tris: &[[[f64; 3]; 3]]) -> f64 {
    use rayon::prelude::*;
    points
        .par_iter()
        .map(|&p| {
            tris.iter()
                .map(|t| point_triangle(p, t))
                .fold(f64::INFINITY, f64::min)
        })
        .reduce(|| 0.0, f64::max)
}

/// Slice images held in memory: a source for tests that build their own pixels.
pub struct VecImages(pub Vec<bskin::SliceImage>);

impl bskin::stages::s1_load::SliceImages for VecImages {
    fn count(&self) -> usize {
        self.0.len()
    }
    fn load(&self, index: usize) -> bskin::Result<bskin::SliceImage> {
        Ok(self.0[index].clone())
    }
}

/// `n` axial slices of `size`² pixels (1 mm), 1 mm apart, with pixels from `f(slice, x, y)`.
pub fn synthetic(n: usize, size: usize, f: impl Fn(usize, f64, f64) -> f32) -> VecImages {
    VecImages(
        (0..n)
            .map(|k| bskin::SliceImage {
                index: k,
                frame: bskin::SliceFrame {
                    origin: [0.0, 0.0, k as f64],
                    row: [1.0, 0.0, 0.0],
                    col: [0.0, 1.0, 0.0],
                },
                source: bskin::section::SliceSource {
                    path: format!("synthetic/{k}").into(),
                    frame: None,
                },
                rows: size,
                cols: size,
                spacing: [1.0, 1.0],
                hu: (0..size * size)
                    .map(|i| f(k, (i % size) as f64, (i / size) as f64))
                    .collect(),
            })
            .collect(),
    )
}

/// Runs the whole pipeline on in-memory images.
pub fn run_images(images: &VecImages, out: &Path, config: &RunConfig) -> bskin::Result<RunSummary> {
    std::fs::create_dir_all(out).unwrap();
    run_surfaces(
        RunInput::Images(images),
        config,
        out,
        &Control::new(),
        &|_| {},
    )
}
