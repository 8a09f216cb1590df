//! `report.json`, version 7: what a `bskin run` read, made and measured. Documented field by
//! field in the README. Floating-point values are as computed (shortest round-trip form), so
//! the same input gives the same bytes, except for the timing and memory fields (and so
//! report.json's own size).

use serde::Serialize;

use crate::io::crossing_check::{CrossingSummary, SurfaceCrossing};
use crate::io::ndjson::ThresholdRecord;
use crate::section::SeriesSummary;
use crate::stages::StageStats;

pub const FORMAT: &str = "bskin-report";
/// 2: `input.slice_spacing_mm` added; `input.threshold` an object (was Rust debug text);
/// `coordinates` follows `--ras`. 3: `mesh` (chordal tolerance, triangle totals) and per
/// surface `seal_triangles` added; `files` lists report.json too. 4: `notes` added (what needs
/// no action, such as a split zone bridges joined whole, which version 3 listed as warnings).
/// 5: per surface `mesh_rows` and `folded_rows`, and `mesh.folded_surfaces` and
/// `mesh.folded_rows`: where the mesh folds through itself. 6: `mesh.crossing_faces` and
/// `mesh.crossings`: faces of the written mesh crossing another, between surfaces too. 7: per
/// surface `row_loops_cut` and `mesh.row_loops_cut`: loops within the chordal tolerance cut off
/// the mesh's rows (`folded_rows` counts the rows as meshed, after the cuts). 8: per surface
/// `row_cusps_cut` and `mesh.row_cusps_cut`: cusps within the chordal tolerance cut off the
/// mesh's rows.
pub const VERSION: u32 = 8;

#[derive(Serialize, Debug, Clone)]
pub struct Report {
    pub format: &'static str,
    pub version: u32,
    pub series: SeriesSummary,
    pub input: InputReport,
    pub tolerance_mm: f64,
    pub units: &'static str,
    /// "LPS" (DICOM patient) or "RAS".
    pub coordinates: &'static str,
    pub surfaces: Vec<SurfaceReport>,
    pub surfaces_total: usize,
    pub input_points_total: usize,
    pub control_points_total: usize,
    /// input_points_total / control_points_total: the paper's data reduction, against the
    /// compressed contours the surfaces were fitted to.
    pub reduction_ratio: f64,
    /// input.points_raw / control_points_total: against the contours before compression
    /// (what a marching-squares polyline of the same slices would hold).
    pub reduction_ratio_raw: f64,
    pub max_error_mm: f64,
    pub tolerance_met: bool,
    pub mesh: Option<MeshReport>,
    pub files: Vec<FileReport>,
    pub timings: Timings,
    pub peak_rss_mb: Option<f64>,
    pub warnings: Vec<String>,
    /// Informational: what the run did that needs no action.
    pub notes: Vec<String>,
}

#[derive(Serialize, Debug, Clone, Default)]
pub struct InputReport {
    pub slices: usize,
    pub empty_slices: usize,
    pub contours: usize,
    pub holes: usize,
    /// Contour points before and after polygon compression.
    pub points_raw: usize,
    pub points_compressed: usize,
    /// Distance between consecutive slices along their normal (mm); `None` (null) for a single
    /// slice.
    pub slice_spacing_mm: Option<SliceSpacing>,
    /// `{"above": HU}` or `{"range": [lo, hi]}`: the segmentation of the images, or, for
    /// contours read from NDJSON, the one its header records (null when it records none).
    pub threshold: Option<ThresholdRecord>,
    pub min_area_mm2: f64,
    pub fill_holes: bool,
    pub compress_tol_mm: f64,
}

#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct SliceSpacing {
    pub min: f64,
    pub mean: f64,
    pub max: f64,
}

#[derive(Serialize, Debug, Clone)]
pub struct SurfaceReport {
    pub id: usize,
    /// "outer" or "hole" wall.
    pub kind: &'static str,
    /// `[nu, nv]`: control points around (closed u) and along (open v).
    pub control_points: [usize; 2],
    /// Sizes of the u (periodic, extended) and v (clamped) knot vectors.
    pub knots: [usize; 2],
    /// Curves skinned: contours, intermediate contours and caps.
    pub curves: usize,
    /// Lowest and highest slice index the surface spans.
    pub slices: [usize; 2],
    pub input_points: usize,
    /// Points whose true distance to the surface was measured: the input contour points and
    /// the points fitted along their edges (at most twice the tolerance apart).
    pub certified_points: usize,
    /// Largest true distance of the certified points to the surface.
    pub max_error_mm: f64,
    pub mean_error_mm: f64,
    pub rms_error_mm: f64,
    /// Largest curve-fitting error over all its curves (intermediate ones too).
    pub curve_fit_max_mm: f64,
    pub tolerance_mm: f64,
    pub tolerance_met: bool,
    /// Triangles of this surface in the mesh files, its seal triangles included.
    pub triangles: usize,
    /// Flat triangles closing slivers where its end loops do not tile their plane.
    pub seal_triangles: usize,
    /// Interior rows of its mesh (iso-curves between its end loops, one plane each), and how
    /// many of them cross themselves: where the surface folds through itself
    /// ([`crate::mesh::Folds`]). 0 and 0 when no mesh file was written.
    pub mesh_rows: usize,
    pub folded_rows: usize,
    /// Loops within the chordal tolerance cut off its rows ([`crate::mesh::RowLoops::Cut`]):
    /// folds below the mesh's resolution, which its mesh leaves out.
    pub row_loops_cut: usize,
    /// Cusps within the chordal tolerance cut off its rows ([`crate::mesh::cut_cusps`]):
    /// hooks below the mesh's resolution, where a row turns back over a short edge.
    pub row_cusps_cut: usize,
}

/// How the mesh files were tessellated; absent when no mesh file was asked for.
#[derive(Serialize, Debug, Clone)]
pub struct MeshReport {
    /// `--chordal`: the chordal tolerance as a fraction of the fitting tolerance.
    pub chordal_fraction: f64,
    /// The chordal tolerance: triangles stay within it of the surfaces (mm), except up to the
    /// first curve from a shared end loop, where they move onto the loop, and where a row's
    /// loop or cusp is cut off (`row_loops_cut`, `row_cusps_cut`), whose vertices move by at
    /// most this much.
    pub chordal_mm: f64,
    pub triangles: usize,
    pub seal_triangles: usize,
    /// Surfaces with a folded row, and their folded rows in all (per surface:
    /// `folded_rows`). Crossings between different surfaces are not counted here.
    pub folded_surfaces: usize,
    pub folded_rows: usize,
    /// Loops cut off rows in all (per surface: `row_loops_cut`).
    pub row_loops_cut: usize,
    /// Cusps cut off rows in all (per surface: `row_cusps_cut`).
    pub row_cusps_cut: usize,
    /// Faces of the mesh, as `mesh.stl` holds it (single precision), crossing another face
    /// that shares no vertex with them, within a surface or between two; null when the check
    /// was turned off (`--no-crossing-check`).
    pub crossing_faces: Option<u64>,
    /// Per pair of surfaces (the same id twice: a surface through itself), their faces in
    /// those crossings and where they lie on average; most faces first.
    pub crossings: Vec<SurfaceCrossing>,
}

#[derive(Serialize, Debug, Clone)]
pub struct FileReport {
    pub name: String,
    pub bytes: u64,
}

#[derive(Serialize, Debug, Clone, Default)]
pub struct Timings {
    pub wall_s: f64,
    /// Time each stage spent working (not waiting on its channels).
    pub stages: Vec<StageStats>,
}

/// Kinds of warning listed in the human summary, each by its first warning and how many more
/// are like it; further kinds are counted (every warning is in report.json).
const SUMMARY_KINDS: usize = 6;

/// A warning's kind: its text with every number replaced by `#`, so the same message about
/// other slices, contours, points or areas is the same kind ("slices #–#: lower contour #: its
/// zone meets the intermediate section (t = #) in # pieces; …").
fn warning_kind(warning: &str) -> String {
    let chars: Vec<char> = warning.chars().collect();
    let mut kind = String::with_capacity(warning.len());
    let mut in_number = false;
    for (i, &c) in chars.iter().enumerate() {
        let digit_next = chars.get(i + 1).is_some_and(|n| n.is_ascii_digit());
        let numeric = c.is_ascii_digit()
            || (in_number && c == '.' && digit_next)
            || ((c == '-' || c == '−')
                && digit_next
                && (i == 0 || !chars[i - 1].is_alphanumeric()));
        if !numeric {
            kind.push(c);
        } else if !in_number {
            kind.push('#');
        }
        in_number = numeric;
    }
    kind
}

/// The warnings grouped by kind, in the order each kind first appears: its first warning
/// and how many there are.
fn warning_kinds(warnings: &[String]) -> Vec<(&str, usize)> {
    let mut kinds: Vec<(String, &str, usize)> = Vec::new();
    for w in warnings {
        let kind = warning_kind(w);
        match kinds.iter_mut().find(|k| k.0 == kind) {
            Some(k) => k.2 += 1,
            None => kinds.push((kind, w, 1)),
        }
    }
    kinds.into_iter().map(|(_, first, n)| (first, n)).collect()
}

impl Report {
    /// The human summary `bskin run` prints on stderr: a few lines whatever the number of
    /// surfaces (input, surfaces and their fit, coordinates, time and memory, files written
    /// with their sizes, the first warnings). `dir` is the output directory as shown.
    pub fn summary(&self, dir: &str) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let i = &self.input;
        let spacing = match i.slice_spacing_mm {
            Some(sp) if (sp.max - sp.min) <= 1e-3 * sp.max => format!(", {:.3} mm apart", sp.mean),
            Some(sp) => format!(", {:.3}–{:.3} mm apart", sp.min, sp.max),
            None => String::new(),
        };
        let _ = writeln!(
            s,
            "bskin: input: {} slices{spacing}, {} contours ({} holes), {} points after compression ({} before)",
            i.slices, i.contours, i.holes, i.points_compressed, i.points_raw
        );
        let worst = self
            .surfaces
            .iter()
            .max_by(|a, b| a.max_error_mm.total_cmp(&b.max_error_mm));
        let holes = self.surfaces.iter().filter(|x| x.kind == "hole").count();
        let _ = writeln!(
            s,
            "bskin: {} surfaces ({holes} hole walls), {} control points for {} input points \
             (reduction {:.2}×, {:.2}× against the points before compression)",
            self.surfaces_total,
            self.control_points_total,
            self.input_points_total,
            self.reduction_ratio,
            self.reduction_ratio_raw
        );
        let unmet = self.surfaces.iter().filter(|x| !x.tolerance_met).count();
        let _ = writeln!(
            s,
            "bskin: max error {:.4} mm{} (true distance), tolerance {} mm {}",
            self.max_error_mm,
            worst.map_or(String::new(), |w| format!(" on surface {}", w.id)),
            self.tolerance_mm,
            if self.tolerance_met {
                "met by every surface".to_string()
            } else {
                format!("NOT met by {unmet} surface(s)")
            }
        );
        let triangles: usize = self.surfaces.iter().map(|x| x.triangles).sum();
        let _ = writeln!(
            s,
            "bskin: {triangles} triangles, coordinates {} {}; {:.2} s{}",
            self.coordinates,
            self.units,
            self.timings.wall_s,
            self.peak_rss_mb
                .map_or(String::new(), |m| format!(", peak memory {m:.0} MB"))
        );
        let mut files: Vec<String> = self
            .files
            .iter()
            .map(|f| format!("{} ({})", f.name, human_bytes(f.bytes)))
            .collect();
        files.push("report.json".into());
        let _ = writeln!(s, "bskin: wrote {} in {dir}", files.join(", "));
        let kinds = warning_kinds(&self.warnings);
        for &(first, n) in kinds.iter().take(SUMMARY_KINDS) {
            let _ = match n {
                1 => writeln!(s, "bskin: warning: {first}"),
                _ => writeln!(s, "bskin: warning: {first} (and {} more like it)", n - 1),
            };
        }
        if kinds.len() > SUMMARY_KINDS {
            let rest: usize = kinds[SUMMARY_KINDS..].iter().map(|k| k.1).sum();
            let _ = writeln!(
                s,
                "bskin: … and {rest} more warning(s) of {} other kind(s) in report.json",
                kinds.len() - SUMMARY_KINDS
            );
        }
        if !self.notes.is_empty() {
            let _ = writeln!(s, "bskin: {} note(s) in report.json", self.notes.len());
        }
        s
    }
}

/// `1234` → "1.2 kB", decimal units.
fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b < 1e3 {
        format!("{b} B")
    } else if b < 1e6 {
        format!("{:.1} kB", b / 1e3)
    } else if b < 1e9 {
        format!("{:.1} MB", b / 1e6)
    } else {
        format!("{:.2} GB", b / 1e9)
    }
}

/// Surfaces named in [`fold_warning`], most folded rows first.
const FOLD_WARNING_SURFACES: usize = 5;

/// The warning for a mesh that folds through itself: how many surfaces and rows, and the
/// surfaces with the most folded rows. `None` when no row of any surface crosses itself.
pub fn fold_warning(surfaces: &[SurfaceReport]) -> Option<String> {
    let mut folded: Vec<&SurfaceReport> = surfaces.iter().filter(|s| s.folded_rows > 0).collect();
    if folded.is_empty() {
        return None;
    }
    // Stable: ties keep surface order, so the text is the same on every run.
    folded.sort_by_key(|s| std::cmp::Reverse(s.folded_rows));
    let rows: usize = surfaces.iter().map(|s| s.mesh_rows).sum();
    let bad: usize = folded.iter().map(|s| s.folded_rows).sum();
    let worst: Vec<String> = folded
        .iter()
        .take(FOLD_WARNING_SURFACES)
        .map(|s| {
            format!(
                "surface {} (slices {}–{}, {} of {} rows)",
                s.id, s.slices[0], s.slices[1], s.folded_rows, s.mesh_rows
            )
        })
        .collect();
    Some(format!(
        "mesh: {} of {} surfaces fold through themselves ({bad} of {rows} mesh rows cross \
         themselves; each surface's `folded_rows`); most: {}",
        folded.len(),
        surfaces.len(),
        worst.join(", ")
    ))
}

/// Surface pairs named in [`crossing_warning`].
const CROSSING_WARNING_PAIRS: usize = 3;

/// The warning for a mesh whose faces cross one another: how many, and the pairs of surfaces
/// with the most. `None` when none do.
pub fn crossing_warning(found: &CrossingSummary) -> Option<String> {
    if found.crossing_faces == 0 {
        return None;
    }
    let worst: Vec<String> = found
        .pairs
        .iter()
        .take(CROSSING_WARNING_PAIRS)
        .map(|p| {
            let [x, y, z] = p.at;
            let which = match p.surfaces {
                [a, b] if a == b => format!("surface {a} through itself"),
                [a, b] => format!("surfaces {a} and {b}"),
            };
            format!(
                "{which} ({} faces, about ({x:.1}, {y:.1}, {z:.1}))",
                p.faces
            )
        })
        .collect();
    Some(format!(
        "mesh: {} of {} faces cross another face, so the mesh is not a valid solid there \
         (slicers and CAD may need to repair it; `mesh.crossings`); most: {}",
        found.crossing_faces,
        found.faces,
        worst.join(", ")
    ))
}

/// Peak resident set size of this process so far (Linux: VmHWM), in MB.
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surface(id: usize, rows: usize, folded: usize) -> SurfaceReport {
        SurfaceReport {
            id,
            kind: "outer",
            control_points: [8, 4],
            knots: [15, 8],
            curves: 2,
            slices: [id, id + 1],
            input_points: 100,
            certified_points: 100,
            max_error_mm: 0.1,
            mean_error_mm: 0.05,
            rms_error_mm: 0.06,
            curve_fit_max_mm: 0.1,
            tolerance_mm: 0.5,
            tolerance_met: true,
            triangles: 10,
            seal_triangles: 0,
            mesh_rows: rows,
            folded_rows: folded,
            row_loops_cut: 0,
            row_cusps_cut: 0,
        }
    }

    #[test]
    fn crossing_warning_names_the_pairs_with_most_faces_or_nothing() {
        let pair = |a, b, faces| SurfaceCrossing {
            surfaces: [a, b],
            faces,
            at: [1.25, -2.0, 30.04],
        };
        let mut found = CrossingSummary {
            faces: 1000,
            crossing_faces: 0,
            pairs: Vec::new(),
            slabs: 1,
        };
        assert_eq!(crossing_warning(&found), None);
        found.crossing_faces = 14;
        found.pairs = vec![pair(4, 4, 8), pair(2, 9, 4), pair(1, 3, 2), pair(5, 6, 2)];
        assert_eq!(
            crossing_warning(&found).unwrap(),
            "mesh: 14 of 1000 faces cross another face, so the mesh is not a valid solid there \
             (slicers and CAD may need to repair it; `mesh.crossings`); most: surface 4 through \
             itself (8 faces, about (1.2, -2.0, 30.0)), surfaces 2 and 9 (4 faces, about \
             (1.2, -2.0, 30.0)), surfaces 1 and 3 (2 faces, about (1.2, -2.0, 30.0))"
        );
    }

    #[test]
    fn warnings_of_one_kind_differ_only_in_their_numbers() {
        let k = warning_kind("slice 12: contour not star-shaped around its innermost point [-3.5, 370.68] and no ridge path");
        assert_eq!(
            k,
            "slice #: contour not star-shaped around its innermost point [#, #] and no ridge path"
        );
        assert_eq!(
            warning_kind("slices 2–3: lower contour 1: in 2 pieces; dropped 0.5 of 60.9105 mm²."),
            "slices #–#: lower contour #: in # pieces; dropped # of # mm²."
        );
        // A sign belongs to its number; a dash between words or numbers does not.
        assert_eq!(warning_kind("x −2 y-3 a-b 4-5"), "x # y-# a-b #-#");
        assert_eq!(
            warning_kind("slices 2–3: upper contour 1"),
            warning_kind("slices 40–41: upper contour 12")
        );
        assert_ne!(
            warning_kind("slices 2–3: upper contour 1"),
            warning_kind("slices 2–3: lower contour 1")
        );
    }

    #[test]
    fn the_summary_lists_each_kind_of_warning_once_with_how_many_more() {
        let mut warnings = vec!["mesh: 14 of 1000 faces cross another face".to_string()];
        for i in 0..500 {
            warnings.push(format!(
                "slice {i}: contour not star-shaped around [{i}.5, -{i}]"
            ));
        }
        for k in 0..8 {
            warnings.push(format!(
                "slices 3–4: kind {} number {k}",
                char::from(b'a' + k)
            ));
        }
        let kinds = warning_kinds(&warnings);
        assert_eq!(kinds.len(), 10);
        assert_eq!(kinds[0], (warnings[0].as_str(), 1));
        assert_eq!(
            kinds[1],
            ("slice 0: contour not star-shaped around [0.5, -0]", 500)
        );
        assert_eq!(kinds[9], ("slices 3–4: kind h number 7", 1));

        let report = Report {
            format: FORMAT,
            version: VERSION,
            series: SeriesSummary::default(),
            input: InputReport::default(),
            tolerance_mm: 0.5,
            units: "mm",
            coordinates: "LPS",
            surfaces_total: 1,
            input_points_total: 100,
            control_points_total: 32,
            reduction_ratio: 2.5,
            reduction_ratio_raw: 7.0,
            max_error_mm: 0.1,
            tolerance_met: true,
            surfaces: vec![surface(0, 10, 0)],
            mesh: None,
            files: Vec::new(),
            timings: Timings::default(),
            peak_rss_mb: None,
            warnings,
            notes: Vec::new(),
        };
        let summary = report.summary("out");
        assert!(
            summary.contains("(reduction 2.50×, 7.00× against the points before compression)"),
            "{summary}"
        );
        let lines: Vec<&str> = summary.lines().collect();
        assert!(lines.len() <= 12, "{summary}");
        assert!(lines.contains(&"bskin: warning: mesh: 14 of 1000 faces cross another face"));
        assert!(lines.contains(
            &"bskin: warning: slice 0: contour not star-shaped around [0.5, -0] (and 499 more \
              like it)"
        ));
        assert!(lines.contains(&"bskin: warning: slices 3–4: kind a number 0"));
        assert!(!summary.contains("kind e"), "{summary}");
        assert_eq!(
            lines.last(),
            Some(&"bskin: … and 4 more warning(s) of 4 other kind(s) in report.json")
        );
    }

    #[test]
    fn fold_warning_names_the_most_folded_surfaces_or_nothing() {
        assert_eq!(fold_warning(&[surface(0, 10, 0), surface(1, 12, 0)]), None);
        let w = fold_warning(&[surface(0, 10, 2), surface(1, 12, 0), surface(2, 20, 7)]).unwrap();
        assert_eq!(
            w,
            "mesh: 2 of 3 surfaces fold through themselves (9 of 42 mesh rows cross themselves; \
             each surface's `folded_rows`); most: surface 2 (slices 2–3, 7 of 20 rows), \
             surface 0 (slices 0–1, 2 of 10 rows)"
        );
    }
}
