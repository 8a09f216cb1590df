//! Command-line arguments (clap derive). Turned into the library's plain configuration in
//! `main.rs`; the library never sees clap.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "bskin",
    version,
    about = "Bicubic B-spline surfaces from stacks of cross-sections (DICOM CT/MR)"
)]
pub struct Cli {
    /// Print nothing but errors (no progress, no summary).
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// Stage-level logs on stderr (-v info, -vv debug).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Worker threads for parallel work inside stages (default: all cores).
    #[arg(long, global = true)]
    pub threads: Option<usize>,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Reconstruct B-spline surfaces from a DICOM series (or contour NDJSON on stdin: -).
    Run(RunArgs),
    /// Write the compiled contours of a DICOM series as NDJSON.
    Contours(ContoursArgs),
    /// List the image series found under a directory.
    Info(InfoArgs),
    /// Write a DICOM CT series of an analytic phantom shape.
    Phantom(PhantomArgs),
}

#[derive(Args, Debug, Clone)]
pub struct SeriesArgs {
    /// A directory of DICOM files (searched recursively).
    pub input: PathBuf,
    /// Which series to use when the directory holds several: SeriesNumber or SeriesInstanceUID.
    #[arg(long)]
    pub series: Option<String>,
}

#[derive(Args, Debug, Clone)]
pub struct SegmentationArgs {
    /// Inside = HU at or above this value (default 300: bone).
    #[arg(long, conflicts_with = "range", allow_hyphen_values = true)]
    pub threshold: Option<f64>,
    /// Inside = HU within LO:HI (inclusive), e.g. --range -100:200.
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
    pub range: Option<(f64, f64)>,
    /// Drop islands and holes smaller than this area (mm²).
    #[arg(long, default_value_t = 4.0)]
    pub min_area: f64,
    /// Fill holes (drop hole contours and anything inside them).
    #[arg(long)]
    pub fill_holes: bool,
    /// Polygon compression tolerance (mm); 0 keeps every marching-squares point.
    #[arg(long, default_value_t = 0.05)]
    pub compress_tol: f64,
}

#[derive(Args, Debug, Clone)]
pub struct PipelineArgs {
    /// Capacity of the channels between stages (items).
    #[arg(long, default_value_t = 4)]
    pub channel_depth: usize,
}

#[derive(Args, Debug)]
pub struct ContoursArgs {
    #[command(flatten)]
    pub series: SeriesArgs,
    #[command(flatten)]
    pub segmentation: SegmentationArgs,
    #[command(flatten)]
    pub pipeline: PipelineArgs,
    /// Output file, or - for stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    pub series: SeriesArgs,
    #[command(flatten)]
    pub segmentation: SegmentationArgs,
    #[command(flatten)]
    pub pipeline: PipelineArgs,
    /// Output directory (created): report.json, mesh.stl, surfaces.step, surfaces.igs (and
    /// mesh.obj, mesh.ply, mesh.3mf when asked for).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Files to write besides report.json, comma-separated: stl, obj, ply, 3mf, step, igs.
    #[arg(long, default_value = "stl,step,igs")]
    pub formats: String,
    /// Write every geometric output in RAS (x right, y anterior) instead of DICOM patient LPS
    /// (x left, y posterior): x → −x, y → −y.
    #[arg(long)]
    pub ras: bool,
    /// Also write samples.json: points of each surface by bskin's own evaluation, for checking
    /// the CAD files with another kernel (scripts/check_cad.py).
    #[arg(long, hide = true)]
    pub write_samples: bool,
    /// Fitting tolerance (mm): every input contour point lies within it of its surface.
    #[arg(long, default_value_t = 0.5)]
    pub tolerance: f64,
    /// Distance-map raster cell for branching and capping (mm; default tolerance / 4, at most 0.1).
    #[arg(long)]
    pub cell: Option<f64>,
    /// Chordal tolerance of mesh.stl as a fraction of the fitting tolerance: the triangles stay
    /// within FRACTION × tolerance of the surfaces.
    #[arg(long, value_name = "FRACTION", default_value_t = bskin::config::DEFAULT_CHORDAL)]
    pub chordal: f64,
    /// Skip searching the written mesh for faces crossing one another (report.json's
    /// mesh.crossing_faces is then null). The search reads the mesh back slab by slab: a few
    /// seconds on a CT head.
    #[arg(long)]
    pub no_crossing_check: bool,
    /// Most curves (slices) of one surface; a longer object is split into surfaces that share
    /// the contour where they meet (bounded memory on long series)
    #[arg(long, value_name = "N", default_value_t = bskin::config::DEFAULT_MAX_CURVES)]
    pub max_curves: usize,
}

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// A directory of DICOM files (searched recursively).
    pub input: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct PhantomArgs {
    /// Shape: tube-split, tubes-crossing, torus-standing, torus-flat, blobs, tube-three.
    pub shape: String,
    /// Output directory (created).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Image rows and columns.
    #[arg(long, default_value_t = 128)]
    pub size: usize,
    /// Pixel spacing (mm).
    #[arg(long, default_value_t = 0.8)]
    pub pixel: f64,
    /// Number of slices.
    #[arg(long, default_value_t = 61)]
    pub slices: usize,
    /// Distance between slices (mm; the median when --uneven).
    #[arg(long, default_value_t = 1.5)]
    pub slice_spacing: f64,
    /// Gantry tilt (degrees).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub tilt: f64,
    /// Variable slice spacing.
    #[arg(long)]
    pub uneven: bool,
    /// Noise standard deviation (HU); 0 for none.
    #[arg(long, default_value_t = 20.0)]
    pub noise: f64,
    /// Random seed (noise and UIDs).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Also write the shape's ground truth (its volume in mm³) as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
}

fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let (lo, hi) = s
        .split_once(':')
        .ok_or_else(|| format!("expected LO:HI, got {s:?}"))?;
    let lo: f64 = lo
        .trim()
        .parse()
        .map_err(|_| format!("LO is not a number in {s:?}"))?;
    let hi: f64 = hi
        .trim()
        .parse()
        .map_err(|_| format!("HI is not a number in {s:?}"))?;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(format!("need finite LO < HI, got {s:?}"));
    }
    Ok((lo, hi))
}
