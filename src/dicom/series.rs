//! Series: grouping files, sorting slices in space, and checking the geometry.
//!
//! In: the headers of image files (from [`super::scan`](mod@super::scan)). Out: [`Series`], each with its slices
//! sorted by height along the normal, `problems` (warnings: tilt, uneven spacing, gaps,
//! duplicates, missing UIDs) and `errors` (reasons the series cannot be processed, each naming a
//! file). [`select_series`] picks the one series to process and refuses a series with errors.
//!
//! Grouping key: SeriesInstanceUID. When it is empty or missing (some anonymisers blank it), the
//! fallback key is (directory, StudyInstanceUID, SeriesNumber, Modality, Rows×Columns,
//! ImageOrientationPatient rounded to 1e-3). The directory is part of it because, without UIDs,
//! the folder is the best remaining evidence of what belongs together; size and orientation are,
//! so that a localizer or a reformat with the same SeriesNumber does not join the stack.
//!
//! Sorting: by `origin · (row × col)` of the series orientation, never by file name or
//! InstanceNumber; ties keep path order. Slices whose height is within 0.01 mm of the previous
//! kept slice are duplicates: the first (in path order) is kept, the others reported.
//!
//! Tolerances: orientation vectors must be unit within 1e-3 and orthogonal within 1e-3;
//! orientation agrees across a series within 1e-3 per component, PixelSpacing within 1e-4
//! relative. Tilt is reported above 0.1°, uneven spacing when the gaps differ by more than 1 %
//! of the median (and 0.01 mm), and gaps larger than 1.5 × the median are listed.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use super::open::ts_name;
use super::scan::{RawFile, RawFrame, Scan};
use crate::error::{Error, Result};
use crate::section::{cross, dot, SliceFrame, SliceSource};

/// One slice of a series: where it is, where it comes from, how to turn its values into HU.
#[derive(Clone, Debug, PartialEq)]
pub struct SliceHeader {
    /// The file, and the frame for multi-frame files.
    pub source: SliceSource,
    pub frame: SliceFrame,
    /// `origin · normal` (mm): the sort key.
    pub height: f64,
    pub rows: usize,
    pub cols: usize,
    /// PixelSpacing `[between rows, between columns]` (mm).
    pub spacing: [f64; 2],
    /// SliceThickness (mm), when given.
    pub thickness: Option<f64>,
    /// Modality LUT: HU = stored × slope + intercept (1 and 0 when absent).
    pub slope: f64,
    pub intercept: f64,
    /// InstanceNumber (classic) or InStackPositionNumber (enhanced); informative only.
    pub instance_number: Option<i64>,
    /// Transfer syntax UID of the file.
    pub transfer_syntax: String,
}

/// Slice-spacing statistics along the normal (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpacingStats {
    pub min: f64,
    pub median: f64,
    pub max: f64,
}

/// A group of slices forming one series.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// The grouping key (see the module doc); unique within a scan.
    pub key: String,
    /// SeriesInstanceUID, when present.
    pub uid: Option<String>,
    pub number: Option<i64>,
    pub description: String,
    pub modality: String,
    pub rows: usize,
    pub cols: usize,
    /// PixelSpacing `[between rows, between columns]` (mm).
    pub spacing: [f64; 2],
    /// ImageOrientationPatient: row direction then column direction (unit vectors).
    pub orientation: [f64; 6],
    /// Names of the transfer syntaxes of its files.
    pub transfer_syntaxes: BTreeSet<String>,
    /// ImageType contains LOCALIZER.
    pub localizer: bool,
    /// Sorted lowest first (by height along the normal); duplicates removed.
    pub slices: Vec<SliceHeader>,
    /// Median angle between the stacking direction and the normal (degrees); 0 when untilted.
    pub tilt_deg: f64,
    /// Gaps between consecutive slices, when there are ≥ 2.
    pub slice_spacing: Option<SpacingStats>,
    /// Warnings, each saying what and where; processing continues.
    pub problems: Vec<String>,
    /// Reasons the series cannot be processed: file and message.
    pub errors: Vec<(PathBuf, String)>,
}

impl Series {
    /// A stack worth turning into surfaces: ≥ 2 slices and not a localizer.
    pub fn is_volumetric(&self) -> bool {
        self.slices.len() >= 2 && !self.localizer
    }

    /// Unit normal `row × col`.
    pub fn normal(&self) -> [f64; 3] {
        let o = &self.orientation;
        normalise(cross([o[0], o[1], o[2]], [o[3], o[4], o[5]]))
    }

    /// Refuses a series that cannot be processed, naming the first offending file.
    pub fn validate(&self) -> Result<()> {
        if let Some((path, msg)) = self.errors.first() {
            let more = if self.errors.len() > 1 {
                format!(
                    " (and {} more problem(s) in this series)",
                    self.errors.len() - 1
                )
            } else {
                String::new()
            };
            return Err(Error::bad_input(
                path,
                format!("series {}: {msg}{more}", self.label()),
            ));
        }
        if self.slices.len() < 2 {
            let p = self
                .slices
                .first()
                .map(|s| s.source.path.clone())
                .unwrap_or_default();
            return Err(Error::bad_input(
                p,
                format!(
                    "series {} has {} slice(s): need at least 2",
                    self.label(),
                    self.slices.len()
                ),
            ));
        }
        Ok(())
    }

    /// Short name: number and UID (or key).
    pub fn label(&self) -> String {
        let num = self.number.map(|n| format!("#{n} ")).unwrap_or_default();
        match &self.uid {
            Some(u) => format!("{num}{u}"),
            None => format!("{num}(no SeriesInstanceUID; key {})", self.key),
        }
    }

    /// One line for listings: number, UID, description, modality, slices, flags.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} \"{}\" {} {}×{}, {} slice(s)",
            self.label(),
            self.description,
            self.modality,
            self.cols,
            self.rows,
            self.slices.len()
        );
        if self.localizer {
            s.push_str(", localizer");
        }
        if !self.errors.is_empty() {
            s.push_str(&format!(", {} error(s)", self.errors.len()));
        }
        s
    }
}

/// Picks the series to process: `selector` matches a SeriesNumber, a SeriesInstanceUID or a
/// key; without it, the only volumetric series. Refuses series with errors ([`Series::validate`]).
pub fn select_series<'a>(scan: &'a Scan, selector: Option<&str>, dir: &Path) -> Result<&'a Series> {
    let listing = |v: &mut dyn Iterator<Item = &Series>| -> String {
        v.map(|s| format!("\n  {}", s.summary()))
            .collect::<String>()
    };
    let chosen = match selector {
        Some(sel) => {
            let sel = sel.trim();
            let hits: Vec<&Series> = scan
                .series
                .iter()
                .filter(|s| {
                    s.uid.as_deref() == Some(sel)
                        || s.key == sel
                        || s.number.map(|n| n.to_string()).as_deref() == Some(sel)
                })
                .collect();
            match hits.len() {
                1 => hits[0],
                0 => {
                    return Err(Error::NoSeries {
                        path: dir.to_path_buf(),
                        message: format!(
                            "no series matches --series {sel}; found:{}",
                            if scan.series.is_empty() {
                                " none".to_string()
                            } else {
                                listing(&mut scan.series.iter())
                            }
                        ),
                    })
                }
                _ => {
                    return Err(Error::AmbiguousSeries {
                        path: dir.to_path_buf(),
                        message: format!(
                            "--series {sel} matches {} series; pass a SeriesInstanceUID:{}",
                            hits.len(),
                            listing(&mut hits.iter().copied())
                        ),
                    })
                }
            }
        }
        None => {
            let vol: Vec<&Series> = scan.series.iter().filter(|s| s.is_volumetric()).collect();
            match vol.len() {
                1 => vol[0],
                0 => {
                    let loc = scan.series.iter().filter(|s| s.localizer).count();
                    let short = scan.series.len() - loc;
                    return Err(Error::NoSeries {
                        path: dir.to_path_buf(),
                        message: format!(
                            "no volumetric image series: {} file(s), {} not DICOM, {} unreadable, \
                             {} series ({} localizer(s) skipped, {} with fewer than 2 slices){}{}",
                            scan.files,
                            scan.not_dicom,
                            scan.unreadable.len(),
                            scan.series.len(),
                            loc,
                            short,
                            listing(&mut scan.series.iter()),
                            scan.notes
                                .iter()
                                .map(|n| format!("\n  note: {n}"))
                                .collect::<String>()
                        ),
                    });
                }
                n => {
                    return Err(Error::AmbiguousSeries {
                        path: dir.to_path_buf(),
                        message: format!(
                            "{n} volumetric series; pass --series <SeriesNumber or \
                             SeriesInstanceUID> to choose one:{}",
                            listing(&mut vol.iter().copied())
                        ),
                    })
                }
            }
        }
    };
    chosen.validate()?;
    Ok(chosen)
}

/// Groups files into series (in order of first path), then builds and checks each.
pub(crate) fn group(files: Vec<RawFile>) -> Vec<Series> {
    let mut order: Vec<String> = Vec::new();
    let mut groups: BTreeMap<String, Vec<RawFile>> = BTreeMap::new();
    for f in files {
        let key = key_of(&f);
        if !groups.contains_key(&key) {
            order.push(key.clone());
        }
        groups.entry(key).or_default().push(f);
    }
    order
        .into_iter()
        .filter_map(|k| {
            let files = groups.remove(&k)?;
            Some(build(k, files))
        })
        .collect()
}

fn key_of(f: &RawFile) -> String {
    if let Some(uid) = &f.series_uid {
        return uid.clone();
    }
    let dir = f
        .path
        .parent()
        .unwrap_or(Path::new(""))
        .display()
        .to_string();
    let iop = f
        .frames
        .first()
        .and_then(|fr| fr.orientation.as_ref())
        .map(|v| {
            v.iter()
                .map(|x| format!("{:.3}", x + 0.0))
                .collect::<Vec<_>>()
                .join(",")
        })
        .unwrap_or_default();
    format!(
        "dir={dir}|study={}|number={}|modality={}|{}x{}|iop={iop}",
        f.study_uid.as_deref().unwrap_or(""),
        f.series_number.map(|n| n.to_string()).unwrap_or_default(),
        f.modality.as_deref().unwrap_or(""),
        f.cols.unwrap_or(0),
        f.rows.unwrap_or(0)
    )
}

fn build(key: String, files: Vec<RawFile>) -> Series {
    let first = &files[0];
    let mut s = Series {
        key,
        uid: first.series_uid.clone(),
        number: first.series_number,
        description: first.description.clone().unwrap_or_default(),
        modality: first.modality.clone().unwrap_or_default(),
        rows: 0,
        cols: 0,
        spacing: [0.0; 2],
        orientation: [0.0; 6],
        transfer_syntaxes: BTreeSet::new(),
        localizer: false,
        slices: Vec::new(),
        tilt_deg: 0.0,
        slice_spacing: None,
        problems: Vec::new(),
        errors: Vec::new(),
    };
    if s.uid.is_none() {
        s.problems.push(format!(
            "SeriesInstanceUID is empty in {} file(s) (e.g. {}): grouped by directory, \
             StudyInstanceUID, SeriesNumber, Modality, size and orientation",
            files.len(),
            first.path.display()
        ));
    }
    let modality_is_volume = matches!(s.modality.as_str(), "CT" | "MR" | "PT" | "");

    // Per-frame candidates, validated one by one; the series geometry is then the most common
    // one (ties: the first met), so the error names the odd file out, not the first file.
    let mut valid: Vec<(PathBuf, String, SliceHeader)> = Vec::new();
    // A localizer filed under the same UID as an axial stack (some scanners do) would make the
    // stack look inconsistent: drop it with a note. A series of localizers only stays one.
    let is_loc = |f: &RawFile| f.image_type.iter().any(|t| t == "LOCALIZER");
    let n_loc = files.iter().filter(|f| is_loc(f)).count();
    if n_loc == files.len() {
        s.localizer = true;
    } else if n_loc > 0 {
        let first = files
            .iter()
            .find(|f| is_loc(f))
            .map(|f| f.path.display().to_string());
        s.problems.push(format!(
            "{n_loc} localizer image(s) in this series ignored (e.g. {})",
            first.unwrap_or_default()
        ));
    }
    for f in &files {
        if !s.localizer && is_loc(f) {
            continue;
        }
        s.transfer_syntaxes.insert(ts_name(&f.ts_uid));
        for e in &f.errors {
            s.errors.push((f.path.clone(), e.clone()));
        }
        if let Some(pi) = &f.photometric {
            if !pi.starts_with("MONOCHROME") {
                s.errors.push((
                    f.path.clone(),
                    format!(
                        "PhotometricInterpretation {pi}: only greyscale (MONOCHROME1/2) images \
                         have HU"
                    ),
                ));
                continue;
            }
        }
        if f.samples_per_pixel.unwrap_or(1) != 1 {
            s.errors.push((
                f.path.clone(),
                format!(
                    "SamplesPerPixel {}: only greyscale images have HU",
                    f.samples_per_pixel.unwrap_or(1)
                ),
            ));
            continue;
        }
        for fr in &f.frames {
            match slice_of(f, fr, modality_is_volume) {
                Ok(h) => valid.push((f.path.clone(), frame_prefix(fr), h)),
                Err(m) => s
                    .errors
                    .push((f.path.clone(), format!("{}{m}", frame_prefix(fr)))),
            }
        }
    }
    let mut votes: Vec<(usize, usize)> = Vec::new(); // (count, index of its first slice)
    for (i, (_, _, h)) in valid.iter().enumerate() {
        match votes
            .iter_mut()
            .find(|v| consistent(h, &valid[v.1].2).is_ok())
        {
            Some(v) => v.0 += 1,
            None => votes.push((1, i)),
        }
    }
    let Some(&(_, ref_idx)) = votes
        .iter()
        .max_by(|a, b| a.0.cmp(&b.0).then(b.1.cmp(&a.1)))
    else {
        return s;
    };
    let reference = valid[ref_idx].2.clone();
    s.rows = reference.rows;
    s.cols = reference.cols;
    s.spacing = reference.spacing;
    s.orientation = orientation_of(&reference.frame);
    let mut candidates = Vec::with_capacity(valid.len());
    for (path, prefix, h) in valid {
        match consistent(&h, &reference) {
            Ok(()) => candidates.push(h),
            Err(m) => s.errors.push((path, format!("{prefix}{m}"))),
        }
    }
    if candidates.is_empty() {
        return s;
    }
    sort_and_check(&mut s, candidates);
    s
}

fn frame_prefix(fr: &RawFrame) -> String {
    match fr.frame {
        Some(k) => format!("frame {}: ", k + 1),
        None => String::new(),
    }
}

fn orientation_of(f: &SliceFrame) -> [f64; 6] {
    [f.row[0], f.row[1], f.row[2], f.col[0], f.col[1], f.col[2]]
}

/// Turns one frame's attributes into a slice header, or says what is missing or absurd.
fn slice_of(f: &RawFile, fr: &RawFrame, strict: bool) -> std::result::Result<SliceHeader, String> {
    if let Some(e) = fr.errors.first() {
        return Err(e.clone());
    }
    let mut missing = Vec::new();
    if f.rows.is_none() {
        missing.push("Rows");
    }
    if f.cols.is_none() {
        missing.push("Columns");
    }
    if fr.spacing.is_none() {
        missing.push("PixelSpacing");
    }
    if fr.position.is_none() {
        missing.push("ImagePositionPatient");
    }
    if fr.orientation.is_none() {
        missing.push("ImageOrientationPatient");
    }
    if !missing.is_empty() {
        let why = if strict {
            "required to place the slice in patient space"
        } else {
            "required to place the slice (modality not CT/MR)"
        };
        return Err(format!("missing {} ({why})", missing.join(", ")));
    }
    let (rows, cols) = (f.rows.unwrap_or(0), f.cols.unwrap_or(0));
    if rows < 1 || cols < 1 || rows > 65535 || cols > 65535 {
        return Err(format!("image size {cols}×{rows} is not usable"));
    }
    let sp = fr.spacing.as_deref().unwrap_or(&[]);
    if sp.len() != 2
        || sp
            .iter()
            .any(|v| !v.is_finite() || *v <= 0.0 || *v > 1000.0)
    {
        return Err(format!(
            "PixelSpacing {sp:?} must be two finite values in (0, 1000] mm"
        ));
    }
    let pos = fr.position.as_deref().unwrap_or(&[]);
    if pos.len() != 3 || pos.iter().any(|v| !v.is_finite() || v.abs() > 1e6) {
        return Err(format!(
            "ImagePositionPatient {pos:?} must be three finite values"
        ));
    }
    let iop = fr.orientation.as_deref().unwrap_or(&[]);
    if iop.len() != 6 || iop.iter().any(|v| !v.is_finite()) {
        return Err(format!(
            "ImageOrientationPatient {iop:?} must be six finite values"
        ));
    }
    let row = [iop[0], iop[1], iop[2]];
    let col = [iop[3], iop[4], iop[5]];
    let (lr, lc) = (dot(row, row).sqrt(), dot(col, col).sqrt());
    if (lr - 1.0).abs() > 1e-3 || (lc - 1.0).abs() > 1e-3 {
        return Err(format!(
            "ImageOrientationPatient {iop:?}: direction lengths {lr:.4} and {lc:.4}, not unit"
        ));
    }
    let d = dot(row, col) / (lr * lc);
    if d.abs() > 1e-3 {
        return Err(format!(
            "ImageOrientationPatient {iop:?}: row and column directions not orthogonal (cos = {d:.4})"
        ));
    }
    let slope = fr.slope.unwrap_or(1.0);
    let intercept = fr.intercept.unwrap_or(0.0);
    if !slope.is_finite() || slope == 0.0 || !intercept.is_finite() {
        return Err(format!(
            "RescaleSlope {slope} / RescaleIntercept {intercept} not usable"
        ));
    }
    let frame = SliceFrame {
        origin: [pos[0], pos[1], pos[2]],
        row: normalise(row),
        col: normalise(col),
    };
    Ok(SliceHeader {
        source: SliceSource {
            path: f.path.clone(),
            frame: fr.frame,
        },
        height: frame.height(),
        frame,
        rows: rows as usize,
        cols: cols as usize,
        spacing: [sp[0], sp[1]],
        thickness: fr.thickness,
        slope,
        intercept,
        instance_number: fr.instance_number,
        transfer_syntax: f.ts_uid.clone(),
    })
}

fn consistent(h: &SliceHeader, r: &SliceHeader) -> std::result::Result<(), String> {
    if h.rows != r.rows || h.cols != r.cols {
        return Err(format!(
            "size {}×{} differs from the series' {}×{}",
            h.cols, h.rows, r.cols, r.rows
        ));
    }
    if (0..2).any(|i| (h.spacing[i] - r.spacing[i]).abs() > 1e-4 * r.spacing[i]) {
        return Err(format!(
            "PixelSpacing {:?} differs from the series' {:?}",
            h.spacing, r.spacing
        ));
    }
    let (ho, ro) = (orientation_of(&h.frame), orientation_of(&r.frame));
    if (0..6).any(|i| (ho[i] - ro[i]).abs() > 1e-3) {
        return Err(format!(
            "ImageOrientationPatient {ho:?} differs from the series' {ro:?}"
        ));
    }
    Ok(())
}

/// Sorts by height along the series normal, removes duplicates, measures tilt and spacing.
fn sort_and_check(s: &mut Series, mut cand: Vec<SliceHeader>) {
    let n = s.normal();
    for c in &mut cand {
        // One normal for the whole series, so heights are comparable across slices.
        c.height = dot(c.frame.origin, n);
    }
    // Stable: equal heights keep path (and frame) order, so "first" is well defined.
    cand.sort_by(|a, b| a.height.total_cmp(&b.height));
    let mut kept: Vec<SliceHeader> = Vec::with_capacity(cand.len());
    let mut dups = Vec::new();
    for c in cand {
        match kept.last() {
            Some(k) if (c.height - k.height).abs() < 0.01 => {
                dups.push(format!(
                    "{} (duplicates {} at height {:.3} mm)",
                    c.source, k.source, k.height
                ));
            }
            _ => kept.push(c),
        }
    }
    if !dups.is_empty() {
        s.problems.push(format!(
            "{} duplicate slice position(s), first kept, others ignored: {}",
            dups.len(),
            list(&dups, 5)
        ));
    }
    if kept.len() >= 2 {
        let gaps: Vec<f64> = kept.windows(2).map(|w| w[1].height - w[0].height).collect();
        // Angle between each step and the normal: in-plane shift over height step.
        let mut angles: Vec<f64> = kept
            .windows(2)
            .map(|w| {
                let d: [f64; 3] =
                    std::array::from_fn(|i| w[1].frame.origin[i] - w[0].frame.origin[i]);
                let along = dot(d, n);
                let shift: [f64; 3] = std::array::from_fn(|i| d[i] - along * n[i]);
                dot(shift, shift).sqrt().atan2(along).to_degrees()
            })
            .collect();
        angles.sort_by(f64::total_cmp);
        let tilt = median(&angles);
        let (amin, amax) = (angles[0], angles[angles.len() - 1]);
        if tilt > 0.1 {
            s.tilt_deg = tilt;
            s.problems.push(format!(
                "gantry tilt {tilt:.2}°: slice positions are not stacked along the row × column \
                 normal; each slice keeps its own origin (all in patient mm)"
            ));
        }
        if amax - amin > 1.0 {
            s.problems.push(format!(
                "slice positions are not on one line: the step direction varies {amin:.2}°–{amax:.2}° from the normal"
            ));
        }
        let heights: Vec<f64> = kept.iter().map(|k| k.height).collect();
        let mut sorted = gaps.clone();
        sorted.sort_by(f64::total_cmp);
        let med = median(&sorted);
        let (gmin, gmax) = (sorted[0], sorted[sorted.len() - 1]);
        s.slice_spacing = Some(SpacingStats {
            min: gmin,
            median: med,
            max: gmax,
        });
        if gmax - gmin > (0.01 * med).max(0.01) {
            let big: Vec<String> = gaps
                .iter()
                .enumerate()
                .filter(|(_, g)| **g > 1.5 * med)
                .map(|(i, g)| format!("{:.2}→{:.2} ({g:.2} mm)", heights[i], heights[i + 1]))
                .collect();
            let mut m = format!("uneven slice spacing {gmin:.2}–{gmax:.2} mm (median {med:.2})");
            if !big.is_empty() {
                m.push_str(&format!(
                    "; {} gap(s) > 1.5× median at height {}",
                    big.len(),
                    list(&big, 8)
                ));
            }
            s.problems.push(m);
        }
    }
    s.slices = kept;
}

fn median(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

fn list(v: &[String], max: usize) -> String {
    let mut s = v.iter().take(max).cloned().collect::<Vec<_>>().join(", ");
    if v.len() > max {
        s.push_str(&format!(", … ({} more)", v.len() - max));
    }
    s
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let l = dot(v, v).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        v
    }
}
