//! Stage 7: skinning (paper §2.6) and the tolerance certificate. A region's curves become one
//! bicubic surface, closed in u and open in v; then every input contour point's TRUE distance
//! to that surface is measured (closest point, seeded at the point's curve parameter), which
//! is what the report calls the surface error.

use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};
use rayon::prelude::*;

use super::s6_fitting::{describe, FittedRegion};
use super::{Control, StageStats};
use crate::bspline::skinning::{skin_ends, SkinEnd};
use crate::bspline::surface::SkinnedSurface;
use crate::mesh::crossings::{crossing_faces, crossing_pairs};
use crate::mesh::{tessellate_each, Triangle};
use crate::region::{CurveOrigin, Region, RegionCurve};
use crate::section::{dot, SliceFrame};
use crate::{Error, Result};

pub const STAGE: &str = "skinning";

/// Error statistics of a surface against its input contour points (mm).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    pub points: usize,
    pub max_mm: f64,
    pub mean_mm: f64,
    pub rms_mm: f64,
}

/// One output surface.
#[derive(Clone, Debug)]
pub struct Surface {
    pub region: Region,
    pub surface: SkinnedSurface,
    /// Distances of the input contour points to the surface.
    pub error: ErrorStats,
    /// Largest curve-fitting error over all curves of the region (intermediate ones too).
    pub curve_fit_max_mm: f64,
    pub tolerance_met: bool,
}

/// The surface through a region's fitted curves, with the end conditions its end curves ask
/// for (a cap, a branching seam, or free).
pub fn skin(fitted: &FittedRegion) -> Result<SkinnedSurface> {
    let FittedRegion { region, fit } = fitted;
    let end = |c: Option<&RegionCurve>| match c.map(|c| c.origin) {
        Some(CurveOrigin::Cap { .. }) => SkinEnd::Cap,
        Some(CurveOrigin::Intermediate { .. }) => SkinEnd::Seam,
        _ => SkinEnd::Free,
    };
    let ends = [end(region.curves.first()), end(region.curves.last())];
    skin_ends(&fit.curves, ends).map_err(|e| Error::Kernel {
        stage: STAGE,
        context: describe(region),
        source: e,
    })
}

/// Chordal tolerance, in fitting tolerances, of the mesh a choice between surfaces is judged
/// on (a lobe's walk in stage 5, a fanning join in stage 6): the one the README's crossing
/// counts are measured at, fixed so that the surfaces do not depend on the output's
/// `--chordal`.
const JUDGE_CHORDAL: f64 = 0.4;

/// Faces crossing another face ([`crossing_faces`]) in the mesh of the surface through
/// `fitted`'s curves, at [`JUDGE_CHORDAL`] fitting tolerances; `usize::MAX` if it cannot be
/// skinned.
pub fn crossing_faces_of(fitted: &FittedRegion, tolerance: f64) -> usize {
    crossing_faces_of_all(std::slice::from_ref(fitted), tolerance)
}

/// [`crossing_faces_of`] for the meshes of several surfaces together (the segments of one
/// region, which share the curves where they meet): faces crossing a face of any of them.
pub fn crossing_faces_of_all(fitted: &[FittedRegion], tolerance: f64) -> usize {
    let mut faces = Vec::new();
    for f in fitted {
        match judged_mesh(f, tolerance) {
            Some(m) => faces.extend(m),
            None => return usize::MAX,
        }
    }
    crossing_faces(&faces)
}

/// The mesh a choice between surfaces is judged on, at [`JUDGE_CHORDAL`] fitting
/// tolerances; `None` if the surface cannot be skinned.
fn judged_mesh(fitted: &FittedRegion, tolerance: f64) -> Option<Vec<Triangle>> {
    let surface = skin(fitted).ok()?;
    let c = &fitted.region.curves;
    let (bottom, top) = (&c[0].points, &c[c.len() - 1].points);
    let mut faces = Vec::new();
    let chordal = JUDGE_CHORDAL * tolerance;
    tessellate_each(&surface, bottom, top, chordal, |t| faces.push(t));
    Some(faces)
}

/// [`crossing_faces_of`] per band between consecutive curves (`curves − 1` of them), each
/// crossing face counted in the band its centroid's height lies in (all curves lie in
/// parallel planes; faces beyond an end curve count in the end band). `None` if the surface
/// cannot be skinned or its curves have no plane.
pub fn crossing_bands(fitted: &FittedRegion, tolerance: f64) -> Option<Vec<usize>> {
    let curves = &fitted.region.curves;
    let frame = curves
        .iter()
        .find(|c| c.points.len() >= 3)
        .and_then(|c| SliceFrame::of_loop(&c.points))?;
    let normal = frame.normal();
    let height = |p: &[f64; 3]| dot(*p, normal);
    let heights: Vec<f64> = curves
        .iter()
        .map(|c| c.points.first().map_or(f64::NAN, height))
        .collect();
    let faces = judged_mesh(fitted, tolerance)?;
    let mut crossing = vec![false; faces.len()];
    for (i, j) in crossing_pairs(&faces) {
        crossing[i] = true;
        crossing[j] = true;
    }
    let bands = heights.len().saturating_sub(1).max(1);
    let rising = heights[heights.len() - 1] >= heights[0];
    let mut counts = vec![0usize; bands];
    for (t, _) in faces.iter().zip(&crossing).filter(|(_, &c)| c) {
        let centroid: [f64; 3] = std::array::from_fn(|d| (t[0][d] + t[1][d] + t[2][d]) / 3.0);
        let h = height(&centroid);
        // The first band whose upper curve lies beyond the face.
        let k = (1..heights.len())
            .position(|k| {
                if rising {
                    h <= heights[k]
                } else {
                    h >= heights[k]
                }
            })
            .unwrap_or(bands - 1);
        counts[k.min(bands - 1)] += 1;
    }
    Some(counts)
}

pub fn skin_region(fitted: FittedRegion, tolerance: f64) -> Result<Surface> {
    let surface = skin(&fitted)?;
    let FittedRegion { region, fit } = fitted;
    let v_bar = surface.v_bar();
    let mut dists: Vec<f64> = Vec::new();
    for (k, c) in region.curves.iter().enumerate() {
        if !matches!(c.origin, CurveOrigin::Contour { .. }) {
            continue;
        }
        let d: Vec<f64> = fit.points[k]
            .par_iter()
            .zip(&fit.params[k])
            .map(|(p, &u)| surface.closest_point_hint(p, u, v_bar[k]).0)
            .collect();
        dists.extend(d);
    }
    let n = dists.len().max(1) as f64;
    let error = ErrorStats {
        points: dists.len(),
        max_mm: dists.iter().copied().fold(0.0, f64::max),
        mean_mm: dists.iter().sum::<f64>() / n,
        rms_mm: (dists.iter().map(|d| d * d).sum::<f64>() / n).sqrt(),
    };
    let curve_fit_max_mm = fit.max_errors.iter().copied().fold(0.0, f64::max);
    tracing::debug!(
        "{}: {}×{} control points, {} input points, max error {:.4} mm",
        describe(&region),
        surface.n_u(),
        surface.n_v(),
        error.points,
        error.max_mm
    );
    Ok(Surface {
        tolerance_met: error.max_mm <= tolerance && fit.met,
        region,
        surface,
        error,
        curve_fit_max_mm,
    })
}

pub fn run(
    input: Receiver<FittedRegion>,
    tolerance: f64,
    out: Sender<Surface>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    for fitted in input.iter() {
        ctl.check()?;
        let t = Instant::now();
        let s = skin_region(fitted, tolerance)?;
        stats.busy += t.elapsed();
        stats.items += 1;
        if out.send(s).is_err() {
            break;
        }
    }
    Ok(stats)
}
