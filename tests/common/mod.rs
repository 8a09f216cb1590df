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

fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Whether the segment pq passes through the interior of triangle `t`: its ends strictly on
/// both sides of the plane and the crossing point strictly inside, each beyond `eps` mm.
fn segment_crosses_triangle(p: [f64; 3], q: [f64; 3], t: &[[f64; 3]; 3], eps: f64) -> bool {
    let n = cross3(sub(t[1], t[0]), sub(t[2], t[0]));
    let len = dot(n, n).sqrt();
    if len == 0.0 {
        return false;
    }
    let n = [n[0] / len, n[1] / len, n[2] / len];
    let (dp, dq) = (dot(sub(p, t[0]), n), dot(sub(q, t[0]), n));
    if !((dp > eps && dq < -eps) || (dp < -eps && dq > eps)) {
        return false;
    }
    let s = dp / (dp - dq);
    let x: [f64; 3] = std::array::from_fn(|d| p[d] + s * (q[d] - p[d]));
    (0..3).all(|i| {
        let (a, b) = (t[i], t[(i + 1) % 3]);
        let e = sub(b, a);
        let el = dot(e, e).sqrt();
        // Distance of x inside the edge's line, in the triangle's plane.
        el > 0.0 && dot(cross3(e, sub(x, a)), n) / el > eps
    })
}

/// Which faces of a triangle soup cross another face sharing no vertex with it (an edge of one
/// passes through the other's interior by more than `eps` mm), as MeshLab's self-intersection
/// selection finds them. Candidate pairs from a grid of bounding boxes.
pub fn crossing_faces(tris: &[[[f64; 3]; 3]], eps: f64) -> Vec<bool> {
    use std::collections::{HashMap, HashSet};
    let edge_sum: f64 = tris
        .iter()
        .map(|t| {
            (0..3)
                .map(|i| dot(sub(t[i], t[(i + 1) % 3]), sub(t[i], t[(i + 1) % 3])).sqrt())
                .sum::<f64>()
        })
        .sum();
    let cell = (2.0 * edge_sum / (3 * tris.len().max(1)) as f64).max(1e-6);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, t) in tris.iter().enumerate() {
        let lo: [i64; 3] = std::array::from_fn(|d| {
            (t.iter().map(|p| p[d]).fold(f64::MAX, f64::min) / cell).floor() as i64
        });
        let hi: [i64; 3] = std::array::from_fn(|d| {
            (t.iter().map(|p| p[d]).fold(f64::MIN, f64::max) / cell).floor() as i64
        });
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    grid.entry([x, y, z]).or_default().push(i);
                }
            }
        }
    }
    let mut tested: HashSet<(usize, usize)> = HashSet::new();
    let mut crossing = vec![false; tris.len()];
    for faces in grid.values() {
        for (k, &i) in faces.iter().enumerate() {
            for &j in &faces[k + 1..] {
                let (a, b) = (&tris[i], &tris[j]);
                if a.iter().any(|p| b.contains(p)) || !tested.insert((i.min(j), i.max(j))) {
                    continue;
                }
                let hit = (0..3).any(|e| segment_crosses_triangle(a[e], a[(e + 1) % 3], b, eps))
                    || (0..3).any(|e| segment_crosses_triangle(b[e], b[(e + 1) % 3], a, eps));
                if hit {
                    crossing[i] = true;
                    crossing[j] = true;
                }
            }
        }
    }
    crossing
}
