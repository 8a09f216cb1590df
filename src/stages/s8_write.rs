//! Stage 8: writers. Surfaces arrive in region order; each is put into the output coordinate
//! system ([`CoordinateSystem`]: DICOM LPS, or RAS), tessellated once and streamed into the
//! meshes asked for ([`MeshWriters`]: `mesh.stl`, `mesh.obj`, `mesh.ply`, `mesh.3mf`), and
//! summarised for `report.json`. The CAD files (`surfaces.step`, `surfaces.igs`) and the
//! optional `samples.json` need every surface, so the surfaces are kept as they arrive and
//! those files are written at the end, in region order. Which files are written is
//! [`OutputOptions`]. Files are written under temporary names and renamed only
//! when complete, so a failed or interrupted run leaves no half-written output.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crossbeam_channel::Receiver;

use super::s7_skinning::Surface;
use super::{Control, StageStats};
use crate::bspline::SkinnedSurface;
use crate::config::{CoordinateSystem, OutputOptions};
use crate::io::atomic::AtomicFile;
use crate::io::cad::CadMeta;
use crate::io::crossing_check::{CrossingCheck, CrossingSummary, SLAB_FACES};
use crate::io::meshes::MeshWriters;
use crate::io::report::{FileReport, Report, SurfaceReport};
use crate::mesh::{tessellate_each, with_edge_points, RowLoops, Triangle};
use crate::region::{CurveOrigin, RegionCurve};
use crate::{Error, Result};

pub const STAGE: &str = "write";

pub use crate::io::meshes::{OBJ_FILE, PLY_FILE, STL_FILE as MESH_FILE};
pub const STEP_FILE: &str = "surfaces.step";
pub const IGES_FILE: &str = "surfaces.igs";
pub const SAMPLES_FILE: &str = "samples.json";
pub const REPORT_FILE: &str = "report.json";

/// What the writers produced.
#[derive(Debug, Default)]
pub struct Written {
    pub surfaces: Vec<SurfaceReport>,
    pub files: Vec<FileReport>,
    /// The mesh's faces crossing one another; `None` when no mesh was written or the check
    /// was turned off.
    pub crossings: Option<CrossingSummary>,
    pub stats: StageStats,
}

fn output_error(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::Output {
        path: path.to_path_buf(),
        source: e,
    }
}

/// The first and last slice of a region's contours and keyhole loops; for a region with
/// neither (between intermediate contours only), the slices its intermediate contours lie
/// between.
fn slice_span(curves: &[RegionCurve]) -> [usize; 2] {
    let own: Vec<usize> = curves
        .iter()
        .filter_map(|c| match c.origin {
            CurveOrigin::Contour { slice, .. } | CurveOrigin::Keyhole { slice } => Some(slice),
            _ => None,
        })
        .collect();
    let slices = if own.is_empty() {
        curves
            .iter()
            .flat_map(|c| match c.origin {
                CurveOrigin::Intermediate { below, above } => vec![below, above],
                CurveOrigin::Cap { slice } => vec![slice],
                _ => Vec::new(),
            })
            .collect()
    } else {
        own
    };
    [
        slices.iter().min().copied().unwrap_or(0),
        slices.iter().max().copied().unwrap_or(0),
    ]
}

pub fn summarise(s: &Surface, tolerance: f64) -> SurfaceReport {
    SurfaceReport {
        id: s.region.id,
        kind: if s.region.hole { "hole" } else { "outer" },
        control_points: [s.surface.n_u(), s.surface.n_v()],
        knots: [
            s.surface.u_knots().extended().len(),
            s.surface.v_knots().knots().len(),
        ],
        curves: s.region.curves.len(),
        slices: slice_span(&s.region.curves),
        input_points: s.region.input_points(),
        certified_points: s.error.points,
        max_error_mm: s.error.max_mm,
        mean_error_mm: s.error.mean_mm,
        rms_error_mm: s.error.rms_mm,
        curve_fit_max_mm: s.curve_fit_max_mm,
        tolerance_mm: tolerance,
        tolerance_met: s.tolerance_met,
        triangles: 0,
        seal_triangles: 0,
        mesh_rows: 0,
        folded_rows: 0,
        row_loops_cut: 0,
        row_cusps_cut: 0,
    }
}

pub fn run(
    input: Receiver<Surface>,
    out_dir: &Path,
    tolerance: f64,
    chordal_mm: f64,
    outputs: &OutputOptions,
    ctl: &Control,
    upstream: &mut dyn FnMut() -> Result<()>,
) -> Result<Written> {
    let mut written = Written {
        stats: StageStats {
            stage: STAGE,
            ..Default::default()
        },
        ..Default::default()
    };
    let system = outputs.coordinates;
    let mut meshes = MeshWriters::create(out_dir, outputs)?;
    let mut check = if meshes.any() && outputs.check_crossings {
        Some(CrossingCheck::in_dir(out_dir).map_err(output_error(out_dir))?)
    } else {
        None
    };
    let keep = outputs.step || outputs.iges || outputs.samples;
    let mut kept: Vec<SkinnedSurface> = Vec::new();
    for s in input.iter() {
        ctl.check()?;
        let t = Instant::now();
        let mut report = summarise(&s, tolerance);
        let surface = in_system(s.surface, system)?;
        if meshes.any() {
            let curves = &s.region.curves;
            // With the points the seal put where two loops' edges cross (the fitted curves
            // leave them out).
            let seal_points = &s.region.seal_points;
            let (bottom, top) = match (curves.first(), curves.last()) {
                (Some(b), Some(t)) => (
                    with_edge_points(&b.points, seal_points),
                    with_edge_points(&t.points, seal_points),
                ),
                _ => return Err(Error::Internal("region without curves".into())),
            };
            // The end loops and seals are shared with neighbouring surfaces vertex for vertex;
            // the mapping to the output system is a sign change, exact, so they stay shared.
            let map = |pts: &[[f64; 3]]| -> Vec<[f64; 3]> {
                pts.iter().map(|&p| system.from_lps(p)).collect()
            };
            // STL in chunks as the rows are made; OBJ/PLY index the whole surface.
            const CHUNK: usize = 4096;
            let whole = meshes.wants_whole_surfaces();
            let (mut chunk, mut all) = (Vec::with_capacity(CHUNK), Vec::new());
            let mut failed: Option<Error> = None;
            let mut count = 0;
            let id = report.id;
            // mesh.stl and the crossing check take the triangles in the same chunks.
            let mut stream = |chunk: &[Triangle]| -> Result<()> {
                meshes.write_stl(chunk)?;
                match check.as_mut() {
                    Some(c) => c.add(id, chunk).map_err(output_error(out_dir)),
                    None => Ok(()),
                }
            };
            let mut take = |t: Triangle| {
                count += 1;
                if whole {
                    all.push(t);
                }
                chunk.push(t);
                if chunk.len() == CHUNK {
                    if failed.is_none() {
                        failed = stream(&chunk).err();
                    }
                    chunk.clear();
                }
            };
            let folds = tessellate_each(
                &surface,
                &map(&bottom),
                &map(&top),
                chordal_mm,
                RowLoops::Cut,
                &mut take,
            );
            for t in &s.region.seal {
                take(t.map(|p| system.from_lps(p)));
            }
            if let Some(e) = failed {
                return Err(e);
            }
            stream(&chunk)?;
            meshes.write_indexed(report.id, &all)?;
            report.triangles = count;
            report.seal_triangles = s.region.seal.len();
            report.mesh_rows = folds.rows;
            report.folded_rows = folds.folded;
            report.row_loops_cut = folds.loops_cut;
            report.row_cusps_cut = folds.cusps_cut;
        }
        written.surfaces.push(report);
        if keep {
            kept.push(surface);
        }
        written.stats.busy += t.elapsed();
        written.stats.items += 1;
    }
    ctl.check()?;
    // The stages before have all returned once the input is drained, but one may have failed
    // after handing on its last item: no file gets its final name until all have succeeded.
    upstream()?;
    let t = Instant::now();
    // Before any file gets its final name: a check that fails fails the run.
    if let Some(check) = check {
        let mut search = check.search(SLAB_FACES).map_err(output_error(out_dir))?;
        while search.next_slabs().map_err(output_error(out_dir))? {
            ctl.check()?;
        }
        let found = search.summary();
        tracing::info!(
            "mesh: {} of {} faces cross another ({} slabs searched, {:.1} s)",
            found.crossing_faces,
            found.faces,
            found.slabs,
            t.elapsed().as_secs_f64()
        );
        written.crossings = Some(found);
    }
    for path in meshes.commit()? {
        written.files.push(file_report(&path)?);
    }
    let refs: Vec<&SkinnedSurface> = kept.iter().collect();
    type Writer = fn(&mut AtomicFile, &[&SkinnedSurface], &CadMeta) -> std::io::Result<()>;
    let writers: [(bool, &str, Writer); 3] = [
        (outputs.step, STEP_FILE, |f, s, m| {
            crate::io::step::write_step(f, s, m)
        }),
        (outputs.iges, IGES_FILE, |f, s, m| {
            crate::io::iges::write_iges(f, s, m)
        }),
        (outputs.samples, SAMPLES_FILE, |f, s, m| {
            crate::io::samples::write_samples(f, s, m.coordinates)
        }),
    ];
    for (on, name, write) in writers {
        if !on {
            continue;
        }
        ctl.check()?;
        let path = out_dir.join(name);
        let meta = CadMeta {
            file_name: name.to_string(),
            coordinates: system.name(),
            ..Default::default()
        };
        let mut f = AtomicFile::create(&path)?;
        write(&mut f, &refs, &meta).map_err(output_error(&path))?;
        f.commit()?;
        written.files.push(file_report(&path)?);
    }
    written.stats.busy += t.elapsed();
    Ok(written)
}

/// `s` (in DICOM patient LPS) in `system`. A B-spline maps to a B-spline of the mapped control
/// points under any affine map, so mapping the control points maps every output (mesh, CAD
/// files, samples) alike; RAS only changes signs, so it is exact.
fn in_system(s: SkinnedSurface, system: CoordinateSystem) -> Result<SkinnedSurface> {
    if system == CoordinateSystem::Lps {
        return Ok(s);
    }
    let control = s.control().iter().map(|&p| system.from_lps(p)).collect();
    SkinnedSurface::try_new(
        s.u_knots().clone(),
        s.v_knots().clone(),
        control,
        s.v_bar().to_vec(),
    )
    .map_err(|e| Error::Internal(format!("surface in {}: {e}", system.name())))
}

pub fn file_report(path: &Path) -> Result<FileReport> {
    let bytes = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    Ok(FileReport {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        bytes,
    })
}

/// Write `report.json` atomically; returns its path. Its own size is its last `files`
/// entry: the text is laid out again until the size it states is its size (the digits of a
/// size rarely change it, so this settles in two or three rounds).
pub fn write_report(out_dir: &Path, report: &Report) -> Result<PathBuf> {
    use std::io::Write;
    let path = out_dir.join(REPORT_FILE);
    let json_error = |e: serde_json::Error| Error::Output {
        path: path.clone(),
        source: e.into(),
    };
    let mut report = report.clone();
    report.files.push(FileReport {
        name: REPORT_FILE.to_string(),
        bytes: 0,
    });
    let mut text = Vec::new();
    for _ in 0..8 {
        text = serde_json::to_vec_pretty(&report).map_err(json_error)?;
        text.push(b'\n');
        let stated = report.files.last().map_or(0, |f| f.bytes);
        if stated == text.len() as u64 {
            break;
        }
        if let Some(f) = report.files.last_mut() {
            f.bytes = text.len() as u64;
        }
    }
    let mut f = AtomicFile::create(&path)?;
    f.write_all(&text).map_err(|e| Error::Output {
        path: path.clone(),
        source: e,
    })?;
    f.commit()?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(origin: CurveOrigin) -> RegionCurve {
        RegionCurve {
            points: vec![[0.0; 3]],
            origin,
        }
    }

    #[test]
    fn slice_span_is_the_contours_and_keyholes_else_the_intermediate_planes() {
        use CurveOrigin::*;
        let linked = [
            curve(Intermediate { below: 8, above: 9 }),
            curve(Contour {
                slice: 9,
                contour: 0,
            }),
            curve(Contour {
                slice: 10,
                contour: 2,
            }),
            curve(Cap { slice: 10 }),
        ];
        assert_eq!(slice_span(&linked), [9, 10]);
        let into_keyhole = [
            curve(Intermediate { below: 3, above: 4 }),
            curve(Keyhole { slice: 4 }),
        ];
        assert_eq!(slice_span(&into_keyhole), [4, 4]);
        let between_branchings = [
            curve(Intermediate { below: 3, above: 4 }),
            curve(Intermediate { below: 4, above: 5 }),
        ];
        assert_eq!(slice_span(&between_branchings), [3, 5]);
    }
}
