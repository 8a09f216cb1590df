//! Input compilation for one slice (METHOD.md §1): threshold segmentation, sub-pixel contour
//! extraction, island and hole filtering, polygon compression.
//!
//! In: a row-major HU field, its pixel spacing and the options. Out: contours in slice-plane
//! mm (x along the row direction = column index × column spacing, y along the column
//! direction), outer boundaries counter-clockwise, holes clockwise, listed in nesting order
//! (each outer boundary followed by its holes, then by the islands inside those holes, and so
//! on). Every contour is simple and no two contours cross.

use crate::section::Contour;

use super::marching_squares::iso_loops;
use super::polygon::{bbox, contains, signed_area, Point};
use super::simplify::simplify_closed;

/// Which HU values are "inside".
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Threshold {
    /// `value >= hu`
    Above(f64),
    /// `lo <= value <= hi`
    Range(f64, f64),
}

impl Threshold {
    /// The field whose zero level is the boundary, and that level. A range becomes
    /// `min(v − lo, hi − v)`, continuous, so both ends are found at sub-pixel precision.
    fn field(&self, hu: &[f32]) -> (Option<Vec<f32>>, f64) {
        match *self {
            Threshold::Above(t) => (None, t),
            Threshold::Range(lo, hi) => (
                Some(
                    hu.iter()
                        .map(|&v| ((v as f64 - lo).min(hi - v as f64)) as f32)
                        .collect(),
                ),
                0.0,
            ),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct ContourOptions {
    pub threshold: Threshold,
    /// Contours (islands and holes) enclosing less than this are dropped, mm².
    pub min_area_mm2: f64,
    /// Drop holes (and whatever lies inside them).
    pub fill_holes: bool,
    /// Polygon compression tolerance, mm (0 = none).
    pub compress_tol_mm: f64,
}

impl Default for ContourOptions {
    fn default() -> Self {
        ContourOptions {
            threshold: Threshold::Above(300.0),
            min_area_mm2: 4.0,
            fill_holes: false,
            compress_tol_mm: 0.05,
        }
    }
}

/// What one slice's compilation produced, with the counts the run reports.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SliceContours {
    pub contours: Vec<Contour>,
    /// Points before compression (of the contours kept).
    pub points_raw: usize,
    /// Contours dropped for being smaller than the minimum area.
    pub dropped_small: usize,
}

/// Compile one slice. `spacing` is PixelSpacing: `[between rows, between columns]` in mm.
pub fn extract_contours(
    hu: &[f32],
    cols: usize,
    rows: usize,
    spacing: [f64; 2],
    opts: &ContourOptions,
) -> SliceContours {
    let (transformed, level) = opts.threshold.field(hu);
    let field = transformed.as_deref().unwrap_or(hu);
    let loops: Vec<Vec<Point>> = iso_loops(field, cols, rows, level)
        .into_iter()
        .map(|lp| {
            lp.into_iter()
                .map(|p| [p[0] * spacing[1], p[1] * spacing[0]])
                .collect()
        })
        .collect();

    // Small loops go first: a loop nested in a smaller-than-minimum loop is smaller still, so
    // filtering by area needs no nesting information.
    let total = loops.len();
    let kept: Vec<(Vec<Point>, f64)> = loops
        .into_iter()
        .map(|lp| {
            let a = signed_area(&lp);
            (lp, a)
        })
        .filter(|(_, a)| a.abs() >= opts.min_area_mm2 && *a != 0.0)
        .collect();
    let dropped_small = total - kept.len();

    let refs: Vec<&[Point]> = kept.iter().map(|(lp, _)| lp.as_slice()).collect();
    let parents = nesting(&refs);
    // Depth parity says hole or not; with fill_holes a hole and its subtree go.
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); kept.len()];
    let mut roots = Vec::new();
    for (i, p) in parents.iter().enumerate() {
        match p {
            Some(p) => children[*p].push(i),
            None => roots.push(i),
        }
    }
    let mut out = SliceContours {
        dropped_small,
        ..Default::default()
    };
    let mut stack: Vec<usize> = roots.into_iter().rev().collect();
    while let Some(i) = stack.pop() {
        let (lp, area) = &kept[i];
        let hole = *area < 0.0;
        if hole && opts.fill_holes {
            continue;
        }
        out.points_raw += lp.len();
        out.contours.push(Contour {
            points: simplify_closed(lp, opts.compress_tol_mm),
            hole,
        });
        stack.extend(children[i].iter().rev());
    }
    out
}

/// For each loop, the smallest loop that contains it (its parent in the nesting tree). Loops
/// must not cross one another (marching squares guarantees it), so one vertex decides
/// containment.
pub fn nesting(loops: &[&[Point]]) -> Vec<Option<usize>> {
    let boxes: Vec<[f64; 4]> = loops.iter().map(|lp| bbox(lp)).collect();
    let areas: Vec<f64> = loops.iter().map(|lp| signed_area(lp).abs()).collect();
    let mut by_size: Vec<usize> = (0..loops.len()).collect();
    by_size.sort_by(|&a, &b| areas[a].total_cmp(&areas[b]).then(a.cmp(&b)));
    let mut parent = vec![None; loops.len()];
    for (rank, &i) in by_size.iter().enumerate() {
        let Some(&p) = loops[i].first() else { continue };
        parent[i] = by_size[rank + 1..].iter().copied().find(|&j| {
            let b = boxes[j];
            p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3] && contains(loops[j], p)
        });
    }
    parent
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::is_simple;

    /// Rings: value 1000 inside radii bands, 0 elsewhere, with partial volume by supersampling.
    fn rings(w: usize, h: usize, bands: &[(f64, f64)]) -> Vec<f32> {
        let mut f = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut acc = 0.0;
                for sy in 0..4 {
                    for sx in 0..4 {
                        let px = x as f64 + (sx as f64 + 0.5) / 4.0 - 0.5 - w as f64 / 2.0;
                        let py = y as f64 + (sy as f64 + 0.5) / 4.0 - 0.5 - h as f64 / 2.0;
                        let r = px.hypot(py);
                        if bands.iter().any(|&(a, b)| r >= a && r < b) {
                            acc += 1000.0 / 16.0;
                        }
                    }
                }
                f[y * w + x] = acc as f32;
            }
        }
        f
    }

    #[test]
    fn nested_rings_alternate_and_come_in_nesting_order() {
        let f = rings(80, 80, &[(0.0, 8.0), (14.0, 20.0), (26.0, 34.0)]);
        let out = extract_contours(&f, 80, 80, [0.5, 0.5], &ContourOptions::default());
        let holes: Vec<bool> = out.contours.iter().map(|c| c.hole).collect();
        assert_eq!(holes, vec![false, true, false, true, false]);
        for c in &out.contours {
            assert!(is_simple(&c.points));
            assert_eq!(signed_area(&c.points) < 0.0, c.hole);
        }
        assert!(out.points_raw > out.contours.iter().map(|c| c.points.len()).sum::<usize>());
    }

    #[test]
    fn fill_holes_drops_holes_and_what_is_inside_them() {
        let f = rings(80, 80, &[(0.0, 8.0), (14.0, 20.0), (26.0, 34.0)]);
        let opts = ContourOptions {
            fill_holes: true,
            ..Default::default()
        };
        let out = extract_contours(&f, 80, 80, [0.5, 0.5], &opts);
        assert_eq!(out.contours.len(), 1);
        assert!(!out.contours[0].hole);
    }

    #[test]
    fn range_threshold_and_min_area() {
        // A 1000 HU core (r < 10) in a 500 HU disc (r < 20): 250..750 selects the annulus, with
        // both boundaries at 50 % partial volume.
        let inner = rings(60, 60, &[(0.0, 10.0)]);
        let outer = rings(60, 60, &[(0.0, 20.0)]);
        let f: Vec<f32> = inner
            .iter()
            .zip(&outer)
            .map(|(a, b)| 0.5 * a + 0.5 * b)
            .collect();
        let opts = ContourOptions {
            threshold: Threshold::Range(250.0, 750.0),
            ..Default::default()
        };
        let out = extract_contours(&f, 60, 60, [1.0, 1.0], &opts);
        let holes: Vec<bool> = out.contours.iter().map(|c| c.hole).collect();
        assert_eq!(holes, vec![false, true]);
        let pi = std::f64::consts::PI;
        assert!((signed_area(&out.contours[0].points) - pi * 400.0).abs() < 2.0);
        assert!((signed_area(&out.contours[1].points) + pi * 100.0).abs() < 2.0);

        let opts = ContourOptions {
            min_area_mm2: 2000.0,
            ..Default::default()
        };
        let out = extract_contours(&outer, 60, 60, [1.0, 1.0], &opts);
        assert!(out.contours.is_empty());
        assert_eq!(out.dropped_small, 1);
    }

    #[test]
    fn empty_slice_gives_no_contours() {
        let f = vec![-1000.0f32; 16 * 16];
        let out = extract_contours(&f, 16, 16, [1.0, 1.0], &ContourOptions::default());
        assert!(out.contours.is_empty());
    }
}
