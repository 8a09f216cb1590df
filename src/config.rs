//! Run configuration: plain data built by the CLI (the library never depends on clap).

use crate::geometry::contours::ContourOptions;

/// How the stages are connected and run.
#[derive(Clone, Debug, PartialEq)]
pub struct PipelineOptions {
    /// Capacity of every channel between stages, in items (slices or regions). Small, so a
    /// slow consumer slows the producer instead of filling memory.
    pub channel_depth: usize,
    /// Slices decoded or segmented together by one stage's rayon batch. Bounds the pixels in
    /// flight together with `channel_depth`.
    pub batch: usize,
}

impl Default for PipelineOptions {
    fn default() -> Self {
        PipelineOptions {
            channel_depth: 4,
            batch: rayon::current_num_threads().max(2),
        }
    }
}

/// Everything `bskin contours` needs besides its input and output.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContoursConfig {
    pub contour: ContourOptions,
    pub pipeline: PipelineOptions,
}

/// Default chordal tolerance of the mesh, as a fraction of the fitting tolerance.
pub const DEFAULT_CHORDAL: f64 = 0.1;

/// Default most curves of one surface: longer chains are split into segments.
pub const DEFAULT_MAX_CURVES: usize = 128;

/// Everything `bskin run` needs besides its input and output directory.
#[derive(Clone, Debug, PartialEq)]
pub struct RunConfig {
    pub contour: ContourOptions,
    pub pipeline: PipelineOptions,
    /// Fitting tolerance: every input contour point within this of its surface (mm).
    pub tolerance_mm: f64,
    /// Raster cell of the distance maps (branching and capping), mm.
    pub cell_mm: f64,
    /// Chordal tolerance of the mesh, as a fraction of `tolerance_mm`: the triangles stay
    /// within `mesh_chordal * tolerance_mm` of the surfaces.
    pub mesh_chordal: f64,
    /// Most curves of one surface: a longer chain of 1-to-1 links becomes several surfaces
    /// sharing the contour where one ends and the next begins, so the memory a region holds
    /// until it closes does not grow with the number of slices.
    pub max_curves: usize,
    /// Cap distance for a series of a single section (mm): half of it on each side.
    pub fallback_spacing_mm: f64,
    /// Which files the writer stage produces.
    pub outputs: OutputOptions,
}

/// The patient coordinate system of every geometric output (meshes, CAD files, samples).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CoordinateSystem {
    /// DICOM patient coordinates: x to the patient's left, y to posterior, z to head.
    #[default]
    Lps,
    /// x to the patient's right, y to anterior, z to head (NIfTI, 3D Slicer, ITK-SNAP world).
    /// From LPS: x → −x, y → −y, a rotation by 180° about z, so orientation (triangle winding,
    /// outward normals) is kept.
    Ras,
}

impl CoordinateSystem {
    /// "LPS" or "RAS", as written into the report and file headers.
    pub fn name(self) -> &'static str {
        match self {
            CoordinateSystem::Lps => "LPS",
            CoordinateSystem::Ras => "RAS",
        }
    }

    /// A point given in DICOM patient LPS, in this system. Exact (sign changes only).
    pub fn from_lps(self, p: [f64; 3]) -> [f64; 3] {
        match self {
            CoordinateSystem::Lps => p,
            CoordinateSystem::Ras => [-p[0], -p[1], p[2]],
        }
    }
}

/// Output files of `bskin run` besides `report.json` (always written).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutputOptions {
    /// `mesh.stl`.
    pub stl: bool,
    /// `mesh.obj` (Wavefront OBJ, one group per surface).
    pub obj: bool,
    /// `mesh.ply` (binary little-endian PLY).
    pub ply: bool,
    /// `mesh.3mf` (3MF package, for 3D-printing slicers).
    pub three_mf: bool,
    /// `surfaces.step`.
    pub step: bool,
    /// `surfaces.igs`.
    pub iges: bool,
    /// `samples.json`: points of each surface by bskin's own evaluation, for checking the CAD
    /// files against an independent kernel (debugging / CI).
    pub samples: bool,
    /// Coordinate system of every geometric output.
    pub coordinates: CoordinateSystem,
    /// Whether the mesh written is searched for faces crossing one another (report.json's
    /// `mesh.crossing_faces`; see [`crate::io::crossing_check`]).
    pub check_crossings: bool,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            stl: true,
            obj: false,
            ply: false,
            three_mf: false,
            step: true,
            iges: true,
            samples: false,
            coordinates: CoordinateSystem::Lps,
            check_crossings: true,
        }
    }
}

impl OutputOptions {
    /// From a comma-separated list of formats (`stl`, `obj`, `ply`, `3mf`, `step`, `igs`; `stp` and
    /// `iges` are accepted too). Samples stay off; coordinates are LPS; the crossing check is on.
    pub fn from_formats(list: &str) -> Result<Self, String> {
        let mut o = OutputOptions {
            stl: false,
            obj: false,
            ply: false,
            three_mf: false,
            step: false,
            iges: false,
            samples: false,
            coordinates: CoordinateSystem::Lps,
            check_crossings: true,
        };
        for f in list.split(',').map(str::trim).filter(|f| !f.is_empty()) {
            match f.to_ascii_lowercase().as_str() {
                "stl" => o.stl = true,
                "obj" => o.obj = true,
                "ply" => o.ply = true,
                "3mf" => o.three_mf = true,
                "step" | "stp" => o.step = true,
                "igs" | "iges" => o.iges = true,
                other => {
                    return Err(format!(
                        "unknown format {other:?}; choose from stl, obj, ply, 3mf, step, igs"
                    ))
                }
            }
        }
        Ok(o)
    }
}

impl RunConfig {
    /// Defaults for a tolerance: the distance-map cell a quarter of it (at most 0.1 mm),
    /// polygon compression a tenth of it (at most the default 0.05 mm).
    pub fn with_tolerance(tolerance_mm: f64) -> Self {
        let contour = ContourOptions {
            compress_tol_mm: (tolerance_mm / 10.0).min(ContourOptions::default().compress_tol_mm),
            ..Default::default()
        };
        RunConfig {
            contour,
            pipeline: PipelineOptions::default(),
            tolerance_mm,
            cell_mm: (tolerance_mm / 4.0).min(0.1),
            mesh_chordal: DEFAULT_CHORDAL,
            max_curves: DEFAULT_MAX_CURVES,
            fallback_spacing_mm: 1.0,
            outputs: OutputOptions::default(),
        }
    }
}
