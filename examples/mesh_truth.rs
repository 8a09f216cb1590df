//! Measures a mesh (binary STL, patient mm) against a phantom's analytic surface, for the mesh
//! comparison of scripts/bench/mesh_vs_vtk.py: triangles, bytes, distance both ways, enclosed
//! volume against the shape's volume.
//!
//! Usage: `cargo run --release --example mesh_truth -- SHAPE MESH.stl [--z LO:HI]`
//! Prints one line of JSON on stdout.
//!
//! - mesh → truth: |signed distance| of the shape at every vertex and triangle centroid (exact
//!   for capsules and tori; for the blobs' ellipsoids the signed distance is the usual
//!   first-order estimate, see src/phantom/shapes.rs).
//! - truth → mesh: points of the analytic surface (marching squares on the signed distance at
//!   planes 0.5 mm apart within `--z`, 0.1 mm raster) to the nearest triangle, found through a
//!   uniform grid of triangle boxes.
//! - volume: the mesh's signed volume (Σ a·(b×c)/6; positive when normals point outwards);
//!   the shape's closed form, or its ray integration on a 0.2 mm grid (`Shape::volume`).

#[path = "../tests/common/mod.rs"]
mod common;

use bskin::phantom::Shape;
use common::{point_triangle, read_stl, truth_points};
use rayon::prelude::*;

type Tri = [[f64; 3]; 3];

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: mesh_truth SHAPE MESH.stl [--z LO:HI]";
    if args.len() < 2 {
        eprintln!("{usage}");
        std::process::exit(2);
    }
    let shape = Shape::from_name(&args[0]).unwrap_or_else(|| {
        eprintln!("mesh_truth: unknown shape {:?}", args[0]);
        std::process::exit(2)
    });
    let path = std::path::Path::new(&args[1]);
    let (mut z_lo, mut z_hi) = (shape.bounds()[0][2], shape.bounds()[1][2]);
    if let Some(i) = args.iter().position(|a| a == "--z") {
        let parsed = args.get(i + 1).and_then(|s| {
            let (a, b) = s.split_once(':')?;
            Some((a.parse::<f64>().ok()?, b.parse::<f64>().ok()?))
        });
        match parsed {
            Some((a, b)) => (z_lo, z_hi) = (a, b),
            None => {
                eprintln!("{usage}");
                std::process::exit(2)
            }
        }
    }
    let tris = read_stl(path);
    let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);

    // Mesh → truth.
    let samples: Vec<[f64; 3]> = tris
        .iter()
        .flat_map(|t| {
            let c = std::array::from_fn(|x| (t[0][x] + t[1][x] + t[2][x]) / 3.0);
            [t[0], t[1], t[2], c]
        })
        .collect();
    let d: Vec<f64> = samples
        .par_iter()
        .map(|&p| shape.signed_distance(p).abs())
        .collect();
    let m2t_max = d.iter().copied().fold(0.0, f64::max);
    let m2t_mean = d.iter().sum::<f64>() / d.len().max(1) as f64;

    // Truth → mesh.
    let truth = truth_points(shape, z_lo, z_hi, 0.5, 0.1);
    let grid = TriGrid::new(&tris, 2.0);
    let t2m: Vec<f64> = truth.par_iter().map(|&p| grid.distance(p, &tris)).collect();
    let t2m_max = t2m.iter().copied().fold(0.0, f64::max);
    let t2m_mean = t2m.iter().sum::<f64>() / t2m.len().max(1) as f64;

    let volume: f64 = tris
        .iter()
        .map(|t| {
            let (a, b, c) = (t[0], t[1], t[2]);
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        })
        .sum::<f64>()
        / 6.0;
    let truth_volume = shape.exact_volume().unwrap_or_else(|| shape.volume(0.2));
    println!(
        "{{\"shape\":\"{}\",\"mesh\":\"{}\",\"triangles\":{},\"bytes\":{},\
         \"mesh_to_truth_max_mm\":{:.4},\"mesh_to_truth_mean_mm\":{:.4},\
         \"truth_to_mesh_max_mm\":{:.4},\"truth_to_mesh_mean_mm\":{:.4},\"truth_points\":{},\
         \"volume_mm3\":{:.1},\"truth_volume_mm3\":{:.1},\"volume_error_pct\":{:.3}}}",
        shape.name(),
        path.display(),
        tris.len(),
        bytes,
        m2t_max,
        m2t_mean,
        t2m_max,
        t2m_mean,
        truth.len(),
        volume,
        truth_volume,
        100.0 * (volume - truth_volume) / truth_volume
    );
}

/// Triangles bucketed by their bounding boxes on a uniform grid; nearest-triangle queries
/// visit rings of cells outwards until the ring is farther than the best distance found.
struct TriGrid {
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    cells: Vec<Vec<u32>>,
}

impl TriGrid {
    fn new(tris: &[Tri], cell: f64) -> TriGrid {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in tris {
            for v in t {
                for x in 0..3 {
                    lo[x] = lo[x].min(v[x]);
                    hi[x] = hi[x].max(v[x]);
                }
            }
        }
        let dims: [usize; 3] =
            std::array::from_fn(|x| ((hi[x] - lo[x]) / cell).floor() as usize + 1);
        let mut cells = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        for (i, t) in tris.iter().enumerate() {
            let idx = |v: f64, x: usize| (((v - lo[x]) / cell).floor() as usize).min(dims[x] - 1);
            let a: [usize; 3] = std::array::from_fn(|x| {
                idx(t.iter().map(|v| v[x]).fold(f64::INFINITY, f64::min), x)
            });
            let b: [usize; 3] = std::array::from_fn(|x| {
                idx(t.iter().map(|v| v[x]).fold(f64::NEG_INFINITY, f64::max), x)
            });
            for k in a[2]..=b[2] {
                for j in a[1]..=b[1] {
                    for ii in a[0]..=b[0] {
                        cells[(k * dims[1] + j) * dims[0] + ii].push(i as u32);
                    }
                }
            }
        }
        TriGrid {
            origin: lo,
            cell,
            dims,
            cells,
        }
    }

    fn distance(&self, p: [f64; 3], tris: &[Tri]) -> f64 {
        let c: [i64; 3] =
            std::array::from_fn(|x| ((p[x] - self.origin[x]) / self.cell).floor() as i64);
        let max_ring = *self.dims.iter().max().unwrap_or(&1) as i64 + 1;
        let mut best = f64::INFINITY;
        for ring in 0..=max_ring {
            // Every point of a cell in this ring is at least (ring − 1) cells away.
            if best.is_finite() && (ring - 1) as f64 * self.cell > best {
                break;
            }
            for k in c[2] - ring..=c[2] + ring {
                for j in c[1] - ring..=c[1] + ring {
                    for i in c[0] - ring..=c[0] + ring {
                        let on_ring = (k - c[2]).abs() == ring
                            || (j - c[1]).abs() == ring
                            || (i - c[0]).abs() == ring;
                        if !on_ring {
                            continue;
                        }
                        let inside = |v: i64, x: usize| v >= 0 && v < self.dims[x] as i64;
                        if !(inside(i, 0) && inside(j, 1) && inside(k, 2)) {
                            continue;
                        }
                        let cell =
                            (k as usize * self.dims[1] + j as usize) * self.dims[0] + i as usize;
                        for &t in &self.cells[cell] {
                            best = best.min(point_triangle(p, &tris[t as usize]));
                        }
                    }
                }
            }
        }
        best
    }
}
