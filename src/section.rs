//! Cross-sections in patient space: the frame of a slice, its image in HU, and its contours.
//!
//! Everything is in patient millimetres (DICOM LPS). A slice plane has an origin (the centre of
//! its first pixel, ImagePositionPatient) and two unit directions (ImageOrientationPatient):
//! `row` runs along a row (increasing column index), `col` along a column (increasing row
//! index). A 2-D point `[x, y]` on the slice is the 3-D point `origin + x·row + y·col`, so a
//! counter-clockwise polygon in (x, y) is counter-clockwise seen from `normal = row × col`.

use std::path::PathBuf;

use crate::bspline::vecops::{add, scale, sub};

/// Position and orientation of one slice plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliceFrame {
    pub origin: [f64; 3],
    pub row: [f64; 3],
    pub col: [f64; 3],
}

impl SliceFrame {
    /// A frame in the plane of the planar loop `points` (its first point the origin), with
    /// the normal of its area vector (Newell's): `None` for a loop of no area.
    pub fn of_loop(points: &[[f64; 3]]) -> Option<SliceFrame> {
        let o = *points.first()?;
        let n = points.len();
        let area = (0..n).fold([0.0; 3], |area, i| {
            let (a, b) = (sub(&points[i], &o), sub(&points[(i + 1) % n], &o));
            add(&area, &cross(a, b))
        });
        let unit = |v: [f64; 3]| {
            let len = dot(v, v).sqrt();
            (len > 0.0 && len.is_finite()).then(|| v.map(|x| x / len))
        };
        let normal = unit(area)?;
        // The row along the loop's farthest point from the origin, off the normal.
        let far = points
            .iter()
            .map(|q| sub(q, &o))
            .max_by(|a, b| dot(*a, *a).total_cmp(&dot(*b, *b)))?;
        let row = unit(sub(&far, &scale(&normal, dot(far, normal))))?;
        Some(SliceFrame {
            origin: o,
            row,
            col: cross(normal, row),
        })
    }

    /// Unit normal `row × col`; slices are ordered by `origin · normal`.
    pub fn normal(&self) -> [f64; 3] {
        let n = cross(self.row, self.col);
        let len = dot(n, n).sqrt();
        [n[0] / len, n[1] / len, n[2] / len]
    }

    /// Height of the plane along its normal.
    pub fn height(&self) -> f64 {
        dot(self.origin, self.normal())
    }

    /// The 3-D patient point of the in-plane point `[x, y]`.
    pub fn to_patient(&self, p: [f64; 2]) -> [f64; 3] {
        std::array::from_fn(|i| self.origin[i] + p[0] * self.row[i] + p[1] * self.col[i])
    }

    /// The in-plane coordinates of the patient point `q` projected along the normal.
    pub fn to_plane(&self, q: [f64; 3]) -> [f64; 2] {
        let d = [
            q[0] - self.origin[0],
            q[1] - self.origin[1],
            q[2] - self.origin[2],
        ];
        [dot(d, self.row), dot(d, self.col)]
    }
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// One decoded slice in Hounsfield units, as it enters segmentation. Dropped as soon as its
/// contours exist.
#[derive(Clone, Debug)]
pub struct SliceImage {
    /// Position in the sorted series (0 = lowest).
    pub index: usize,
    pub frame: SliceFrame,
    /// The file it came from (and frame number for multi-frame files), for error messages.
    pub source: SliceSource,
    pub rows: usize,
    pub cols: usize,
    /// PixelSpacing: `[between rows (along col), between columns (along row)]` in mm.
    pub spacing: [f64; 2],
    /// Row-major HU values, `rows × cols`. Padding pixels hold `f32::MIN` so that no threshold
    /// selects them.
    pub hu: Vec<f32>,
}

/// Where a slice came from: a file and, for multi-frame files, the frame.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct SliceSource {
    pub path: PathBuf,
    pub frame: Option<u32>,
}

impl std::fmt::Display for SliceSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.frame {
            Some(k) => write!(f, "{} (frame {})", self.path.display(), k + 1),
            None => write!(f, "{}", self.path.display()),
        }
    }
}

/// A closed contour on a slice: distinct points in slice-plane mm, not repeated at the end.
/// Outer boundaries are counter-clockwise, holes clockwise.
#[derive(Clone, Debug, PartialEq)]
pub struct Contour {
    pub points: Vec<[f64; 2]>,
    pub hole: bool,
}

/// A cross-section: one slice's frame and all its contours (possibly none).
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    pub index: usize,
    pub frame: SliceFrame,
    pub source: SliceSource,
    pub contours: Vec<Contour>,
}

/// What a run says about its input series (NDJSON header, report).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeriesSummary {
    /// SeriesInstanceUID, or the fallback grouping key when the UID is empty.
    pub uid: String,
    pub number: Option<i64>,
    pub description: String,
    pub modality: String,
    pub slices: usize,
    pub rows: usize,
    pub cols: usize,
    /// `[between rows, between columns]`, mm.
    pub pixel_spacing: [f64; 2],
    /// Where it was read from (a directory, a file, or "-").
    pub source: String,
}
