//! Header scan: every file under a directory, headers only, into series.
//!
//! In: a directory. Out: a [`Scan`]: the series found (grouped, sorted and checked by
//! [`super::series`]), the count of files that are not DICOM, the files that look like DICOM but
//! cannot be read (with the reason), and notes (DICOMDIRs, non-image objects skipped).
//!
//! Invariants: files are read in parallel but the output depends only on the directory content
//! (paths are sorted, results collected in path order). Pixel data is never read here, except for
//! the rare bare data sets without file meta (see [`super::open`]). Nothing in a file can make
//! this panic or fail as a whole: a bad file becomes an entry in `unreadable`, a bad attribute a
//! problem or error of its series.

use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use rayon::prelude::*;

use super::attr::{self, FrameGroups};
use super::open::{open, Opened};
use super::series::{group, Series};
use crate::error::{Error, Result};

/// The result of scanning a directory.
#[derive(Clone, Debug, Default)]
pub struct Scan {
    /// Series, in order of their first file's path.
    pub series: Vec<Series>,
    /// Number of regular files seen.
    pub files: usize,
    /// Files that are not DICOM (skipped, not an error).
    pub not_dicom: usize,
    /// Files that look like DICOM but could not be read: path and reason.
    pub unreadable: Vec<(PathBuf, String)>,
    /// DICOM files that hold no image (RT plans, SR, …): path and what they are.
    pub non_image: Vec<(PathBuf, String)>,
    /// Other things skipped (DICOMDIR, non-image objects), one line each.
    pub notes: Vec<String>,
}

/// What one frame of one file says about its geometry and values; `None` = attribute absent.
#[derive(Clone, Debug, Default)]
pub(crate) struct RawFrame {
    pub frame: Option<u32>,
    pub position: Option<Vec<f64>>,
    pub orientation: Option<Vec<f64>>,
    pub spacing: Option<Vec<f64>>,
    pub thickness: Option<f64>,
    pub slope: Option<f64>,
    pub intercept: Option<f64>,
    pub instance_number: Option<i64>,
    /// Attributes present but unparsable.
    pub errors: Vec<String>,
}

/// The header of one image file.
#[derive(Clone, Debug, Default)]
pub(crate) struct RawFile {
    pub path: PathBuf,
    pub ts_uid: String,
    pub study_uid: Option<String>,
    pub series_uid: Option<String>,
    pub series_number: Option<i64>,
    pub description: Option<String>,
    pub modality: Option<String>,
    pub image_type: Vec<String>,
    pub photometric: Option<String>,
    pub samples_per_pixel: Option<i64>,
    pub rows: Option<i64>,
    pub cols: Option<i64>,
    pub frames: Vec<RawFrame>,
    /// File-level reasons the file cannot be processed.
    pub errors: Vec<String>,
}

impl Scan {
    /// A few lines for a person: counts, then one line per series with its problems.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} file(s): {} series, {} not DICOM, {} non-image DICOM, {} unreadable",
            self.files,
            self.series.len(),
            self.not_dicom,
            self.non_image.len(),
            self.unreadable.len()
        );
        for se in &self.series {
            s.push_str(&format!("\n  {}", se.summary()));
            for p in &se.problems {
                s.push_str(&format!("\n    warning: {p}"));
            }
            for (path, e) in &se.errors {
                s.push_str(&format!("\n    error: {}: {e}", path.display()));
            }
        }
        for (p, why) in &self.unreadable {
            s.push_str(&format!("\n  unreadable {}: {why}", p.display()));
        }
        for n in &self.notes {
            s.push_str(&format!("\n  note: {n}"));
        }
        s
    }
}

enum Outcome {
    Image(Box<RawFile>),
    NotDicom,
    DicomDir,
    NonImage(String),
    Unreadable(String),
}

/// Scans `dir` recursively. Fails only when `dir` itself cannot be read.
pub fn scan(dir: &Path) -> Result<Scan> {
    let meta = std::fs::metadata(dir).map_err(|e| Error::io(dir, e))?;
    if !meta.is_dir() {
        return Err(Error::bad_input(dir, "not a directory"));
    }
    let mut paths = Vec::new();
    let mut unreadable = Vec::new();
    for entry in walkdir::WalkDir::new(dir).follow_links(true) {
        match entry {
            Ok(e) if e.file_type().is_file() => paths.push(e.into_path()),
            Ok(_) => {}
            Err(e) => {
                let p = e
                    .path()
                    .map(Path::to_path_buf)
                    .unwrap_or_else(|| dir.to_path_buf());
                unreadable.push((p, format!("cannot list: {e}")));
            }
        }
    }
    paths.sort();
    let outcomes: Vec<Outcome> = paths.par_iter().map(|p| read_header(p)).collect();

    let mut scan = Scan {
        files: paths.len(),
        unreadable,
        ..Scan::default()
    };
    let mut images = Vec::new();
    let mut dicomdirs = 0;
    let mut non_image = Vec::new();
    for (path, o) in paths.into_iter().zip(outcomes) {
        match o {
            Outcome::Image(f) => images.push(*f),
            Outcome::NotDicom => scan.not_dicom += 1,
            Outcome::DicomDir => dicomdirs += 1,
            Outcome::NonImage(why) => non_image.push((path, why)),
            Outcome::Unreadable(why) => scan.unreadable.push((path, why)),
        }
    }
    if dicomdirs > 0 {
        scan.notes.push(format!(
            "{dicomdirs} DICOMDIR file(s) skipped (an index, not images)"
        ));
    }
    if let Some((p, why)) = non_image.first() {
        scan.notes.push(format!(
            "{} DICOM file(s) without an image skipped (e.g. {}: {why})",
            non_image.len(),
            p.display()
        ));
    }
    scan.non_image = non_image;
    scan.unreadable.sort();
    scan.series = group(images);
    Ok(scan)
}

fn read_header(path: &Path) -> Outcome {
    let obj = match open(path, true) {
        Ok(Opened::Dicom(o)) => o,
        Ok(Opened::NotDicom) => return Outcome::NotDicom,
        Ok(Opened::DicomDir) => return Outcome::DicomDir,
        Err(why) => return Outcome::Unreadable(why),
    };
    let ts_uid = obj
        .meta()
        .transfer_syntax()
        .trim_end_matches('\0')
        .to_string();
    let o: &dicom_object::InMemDicomObject = &obj;
    let rows = attr::int(o, tags::ROWS);
    let cols = attr::int(o, tags::COLUMNS);
    if rows.is_none() && cols.is_none() {
        let class = obj.meta().media_storage_sop_class_uid().to_string();
        return Outcome::NonImage(format!("SOP class {class}, no Rows/Columns"));
    }
    let mut f = RawFile {
        path: path.to_path_buf(),
        ts_uid,
        study_uid: attr::string(o, tags::STUDY_INSTANCE_UID),
        series_uid: attr::string(o, tags::SERIES_INSTANCE_UID),
        series_number: attr::int(o, tags::SERIES_NUMBER),
        description: attr::string(o, tags::SERIES_DESCRIPTION),
        modality: attr::string(o, tags::MODALITY),
        image_type: attr::strings(o, tags::IMAGE_TYPE),
        photometric: attr::string(o, tags::PHOTOMETRIC_INTERPRETATION),
        samples_per_pixel: attr::int(o, tags::SAMPLES_PER_PIXEL),
        rows,
        cols,
        ..RawFile::default()
    };
    let n_frames = attr::int(o, tags::NUMBER_OF_FRAMES).unwrap_or(1);
    let per_frame = o
        .get(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)
        .and_then(|e| e.items())
        .map(|items| items.len());
    match per_frame {
        Some(n_items) => {
            if n_frames < 1 || n_items as i64 != n_frames {
                f.errors.push(format!(
                    "NumberOfFrames is {n_frames} but the Per-Frame Functional Groups have \
                     {n_items} items"
                ));
            }
            for k in 0..n_items.min(n_frames.max(0) as usize) {
                f.frames
                    .push(read_frame(&FrameGroups::new(o, Some(k)), Some(k as u32)));
            }
        }
        None if n_frames > 1 => f.errors.push(format!(
            "{n_frames} frames but no Per-Frame Functional Groups: per-frame positions unknown \
             (only single-frame and enhanced multi-frame images are supported)"
        )),
        None => f.frames.push(read_frame(&FrameGroups::new(o, None), None)),
    }
    Outcome::Image(Box::new(f))
}

fn read_frame(g: &FrameGroups<'_>, frame: Option<u32>) -> RawFrame {
    let mut r = RawFrame {
        frame,
        ..RawFrame::default()
    };
    let mut take = |v: std::result::Result<Option<Vec<f64>>, String>| match v {
        Ok(v) => v,
        Err(e) => {
            r.errors.push(e);
            None
        }
    };
    let position = take(g.floats(
        tags::PLANE_POSITION_SEQUENCE,
        tags::IMAGE_POSITION_PATIENT,
        "ImagePositionPatient",
    ));
    let orientation = take(g.floats(
        tags::PLANE_ORIENTATION_SEQUENCE,
        tags::IMAGE_ORIENTATION_PATIENT,
        "ImageOrientationPatient",
    ));
    let spacing = take(g.floats(
        tags::PIXEL_MEASURES_SEQUENCE,
        tags::PIXEL_SPACING,
        "PixelSpacing",
    ));
    let thickness = take(g.floats(
        tags::PIXEL_MEASURES_SEQUENCE,
        tags::SLICE_THICKNESS,
        "SliceThickness",
    ));
    let slope = take(g.floats(
        tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
        tags::RESCALE_SLOPE,
        "RescaleSlope",
    ));
    let intercept = take(g.floats(
        tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
        tags::RESCALE_INTERCEPT,
        "RescaleIntercept",
    ));
    r.position = position;
    r.orientation = orientation;
    r.spacing = spacing;
    r.thickness = thickness.and_then(|v| v.first().copied());
    r.slope = slope.and_then(|v| v.first().copied());
    r.intercept = intercept.and_then(|v| v.first().copied());
    r.instance_number = match frame {
        Some(_) => g.int(tags::FRAME_CONTENT_SEQUENCE, tags::IN_STACK_POSITION_NUMBER),
        None => attr::int(g.top, tags::INSTANCE_NUMBER),
    };
    r
}
