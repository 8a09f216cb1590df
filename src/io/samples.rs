//! `samples.json` (written with `bskin run --write-samples`): points of every surface by
//! bskin's own evaluation, so an independent CAD kernel can check `surfaces.step` and
//! `surfaces.igs` (scripts/check_cad.py).
//!
//! In: surfaces in region order (the order of the faces in the CAD files). Out: JSON
//! `{"format": "bskin-samples", "version": 1, "units": "mm", "coordinates": "LPS" | "RAS",
//! "parameterisation": …,
//! "surfaces": [{"index", "u_domain": [a, b], "v_domain": [c, d], "points": [[u, v, x, y, z], …]}]}`.
//! (u, v) are bskin's parameters, which are also the CAD files' parameters (identity mapping:
//! the writers keep bskin's knot values; see [`super::cad`]). The samples sit on a fixed grid
//! that includes both v ends, u = 0 (the seam) and points between knots. Deterministic.

use std::io::{self, Write};

use serde::Serialize;

use crate::bspline::SkinnedSurface;

pub const FORMAT: &str = "bskin-samples";
pub const VERSION: u32 = 1;

/// Fractions of the u and v domains sampled.
const U_FRACTIONS: [f64; 9] = [0.0, 0.037, 0.13, 0.25, 0.41, 0.5, 0.66, 0.83, 0.991];
const V_FRACTIONS: [f64; 6] = [0.0, 0.02, 0.29, 0.5, 0.77, 1.0];

#[derive(Serialize)]
struct Samples {
    format: &'static str,
    version: u32,
    units: &'static str,
    coordinates: &'static str,
    parameterisation: &'static str,
    surfaces: Vec<SurfaceSamples>,
}

#[derive(Serialize)]
struct SurfaceSamples {
    index: usize,
    u_domain: [f64; 2],
    v_domain: [f64; 2],
    points: Vec<[f64; 5]>,
}

/// Writes the samples of `surfaces`, whose coordinates are in `coordinates` ("LPS" or "RAS");
/// see the module doc.
pub fn write_samples<W: Write>(
    out: W,
    surfaces: &[&SkinnedSurface],
    coordinates: &'static str,
) -> io::Result<()> {
    let surfaces = surfaces
        .iter()
        .enumerate()
        .map(|(index, s)| {
            let d = s.u_knots().domain();
            let (ua, ub) = (d[0], d[d.len() - 1]);
            let (va, vb) = s.v_knots().domain();
            let mut points = Vec::with_capacity(U_FRACTIONS.len() * V_FRACTIONS.len());
            for fu in U_FRACTIONS {
                let u = ua + fu * (ub - ua);
                for fv in V_FRACTIONS {
                    let v = va + fv * (vb - va);
                    let p = s.eval(u, v);
                    points.push([u, v, p[0], p[1], p[2]]);
                }
            }
            SurfaceSamples {
                index,
                u_domain: [ua, ub],
                v_domain: [va, vb],
                points,
            }
        })
        .collect();
    let doc = Samples {
        format: FORMAT,
        version: VERSION,
        units: "mm",
        coordinates,
        parameterisation: "identity: CAD (u, v) = bskin (u, v)",
        surfaces,
    };
    let mut out = io::BufWriter::new(out);
    serde_json::to_writer(&mut out, &doc).map_err(io::Error::other)?;
    out.write_all(b"\n")?;
    out.flush()
}
