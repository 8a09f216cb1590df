//! `report.json`, version 1: what a `bskin run` read, made and measured. Documented field by
//! field in the README. Floating-point values are as computed (shortest round-trip form), so
//! the same input gives the same bytes, except for the timing and memory fields.

use serde::Serialize;

use crate::section::SeriesSummary;
use crate::stages::StageStats;

pub const FORMAT: &str = "bskin-report";
pub const VERSION: u32 = 1;

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
    pub files: Vec<FileReport>,
    pub timings: Timings,
    pub peak_rss_mb: Option<f64>,
    pub warnings: Vec<String>,
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
    pub threshold: String,
    pub min_area_mm2: f64,
    pub fill_holes: bool,
    pub compress_tol_mm: f64,
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
    pub triangles: usize,
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

/// Peak resident set size of this process so far (Linux: VmHWM), in MB.
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}
