//! Tessellation of skinned surfaces into triangles, for meshes to look at and measure.
//!
//! In: a surface and a sampling density. Out: triangles with vertices in patient mm, wound so
//! that `(b − a) × (c − a)` points along `S_u × S_v`: outwards for outer walls
//! (counter-clockwise contours, v rising along the slice normal) and out of the material for
//! hole walls (clockwise contours). Rows are sampled at every input curve's v̄_k, so the mesh
//! passes through every fitted curve; triangles that collapse at a cap point are dropped.

use crate::bspline::surface::SkinnedSurface;

pub type Triangle = [[f64; 3]; 3];

/// Triangles of `s`, with `per_span` samples per u knot span and per interval between
/// consecutive curves in v.
pub fn tessellate(s: &SkinnedSurface, per_span: usize) -> Vec<Triangle> {
    let per_span = per_span.max(1);
    let domain = s.u_knots().domain();
    let mut us = Vec::new();
    for w in domain.windows(2) {
        for k in 0..per_span {
            us.push(w[0] + (w[1] - w[0]) * k as f64 / per_span as f64);
        }
    }
    let v_bar = s.v_bar();
    let mut vs = Vec::new();
    for w in v_bar.windows(2) {
        for k in 0..per_span {
            vs.push(w[0] + (w[1] - w[0]) * k as f64 / per_span as f64);
        }
    }
    if let Some(&last) = v_bar.last() {
        vs.push(last);
    }
    let grid: Vec<Vec<[f64; 3]>> = vs
        .iter()
        .map(|&v| us.iter().map(|&u| s.eval(u, v)).collect())
        .collect();
    let nu = us.len();
    let mut tris = Vec::with_capacity(2 * nu * vs.len());
    for j in 0..grid.len().saturating_sub(1) {
        for i in 0..nu {
            let i1 = (i + 1) % nu;
            let (a, b, c, d) = (grid[j][i], grid[j][i1], grid[j + 1][i1], grid[j + 1][i]);
            for t in [[a, b, c], [a, c, d]] {
                if area2(&t) > 1e-18 {
                    tris.push(t);
                }
            }
        }
    }
    tris
}

/// Squared norm of the (doubled) triangle area vector.
fn area2(t: &Triangle) -> f64 {
    let n = normal(t);
    n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
}

/// `(b − a) × (c − a)` (not normalised).
pub fn normal(t: &Triangle) -> [f64; 3] {
    let u = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
    let v = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}
