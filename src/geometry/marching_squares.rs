//! Iso-contours of a sampled scalar field at sub-pixel precision (marching squares).
//!
//! In: a row-major field of `height × width` samples (sample `(r, c)` sits at pixel
//! coordinates `x = c`, `y = r`) and a level; "inside" is `value >= level`. Out: closed loops in
//! pixel coordinates, each crossing placed by linear interpolation along its grid edge.
//!
//! Invariants: every loop is closed (not repeated at the end) and simple, loops never cross
//! one another, the inside is on the left of every loop (outer boundaries counter-clockwise,
//! holes clockwise), and the output depends only on the input (loops in scan order). The
//! field is treated as surrounded by outside samples, so regions touching the image edge
//! close half a pixel beyond the last sample. Saddle cells are resolved by the cell-centre
//! average, the usual choice that keeps the topology consistent between adjacent cells.

use super::polygon::Point;

/// Keep crossings a hair away from grid points: a sample exactly at the level would otherwise
/// put two crossings of one cell on the same point and give zero-length edges.
const T_MARGIN: f64 = 1e-4;

/// Closed iso-loops of `field` at `level`. Non-finite samples count as outside.
///
/// Dense arrays rather than hash maps: a crossing is found from its grid edge through one
/// index table, and most cells (all inside or all outside) cost four byte reads.
pub fn iso_loops(field: &[f32], width: usize, height: usize, level: f64) -> Vec<Vec<Point>> {
    assert_eq!(
        field.len(),
        width * height,
        "field size must be width × height"
    );
    // Padded grid: one ring of outside samples around the image; NaN marks "outside, no value".
    // Only two rows of it exist at a time, and the crossings are indexed by the edges of the
    // current row of cells only: memory O(width), not O(width × height) (this runs on the
    // distance-map rasters of branching problems, millions of samples each).
    let pw = width + 2;
    let ph = height + 2;
    let fill_row = |row: &mut [f64], i: usize| {
        row.fill(f64::NAN);
        if i >= 1 && i <= height {
            for (c, &v) in field[(i - 1) * width..i * width].iter().enumerate() {
                let v = v as f64;
                if v.is_finite() {
                    row[c + 1] = v;
                }
            }
        }
    };
    // Crossing on the grid edge from sample a to sample b (one inside, one outside).
    let crossing_t = |va: f64, vb: f64| -> f64 {
        if va.is_nan() || vb.is_nan() {
            0.5
        } else {
            ((level - va) / (vb - va)).clamp(T_MARGIN, 1.0 - T_MARGIN)
        }
    };

    let mut points: Vec<Point> = Vec::new();
    // next[crossing] = the crossing its segment leads to (inside on the left).
    let mut next: Vec<u32> = Vec::new();
    // Segment starts in scan order, so loops come out in a fixed order.
    let mut starts: Vec<u32> = Vec::new();
    // Samples of the cell row's top (i) and bottom (i + 1) grid rows; crossings on its top and
    // bottom horizontal edges (by column) and on its vertical edges (by column).
    let (mut top, mut bottom) = (vec![f64::NAN; pw], vec![f64::NAN; pw]);
    let none = u32::MAX;
    let (mut h_top, mut h_bottom, mut vert) = (vec![none; pw], vec![none; pw], vec![none; pw]);
    fill_row(&mut bottom, 0);

    for i in 0..ph - 1 {
        std::mem::swap(&mut top, &mut bottom);
        fill_row(&mut bottom, i + 1);
        std::mem::swap(&mut h_top, &mut h_bottom);
        h_bottom.fill(none);
        vert.fill(none);
        for j in 0..pw - 1 {
            // Corners counter-clockwise in (x, y): TL, TR, BR, BL.
            let v = [top[j], top[j + 1], bottom[j + 1], bottom[j]];
            let ins = v.map(|x| x >= level);
            if ins[0] == ins[1] && ins[1] == ins[2] && ins[2] == ins[3] {
                continue;
            }
            let pos = [
                (j as f64, i as f64),
                ((j + 1) as f64, i as f64),
                ((j + 1) as f64, (i + 1) as f64),
                (j as f64, (i + 1) as f64),
            ];
            // (exit?, crossing) for each edge whose ends differ, in counter-clockwise order;
            // e_k joins corner k to corner k+1: top, right, bottom, left.
            let mut crossings = [(false, 0u32); 4];
            let mut count = 0;
            for k in 0..4 {
                let (a, b) = (k, (k + 1) % 4);
                if ins[a] == ins[b] {
                    continue;
                }
                let slot = match k {
                    0 => &mut h_top[j],
                    1 => &mut vert[j + 1],
                    2 => &mut h_bottom[j],
                    _ => &mut vert[j],
                };
                if *slot == none {
                    let t = crossing_t(v[a], v[b]);
                    let (pa, pb) = (pos[a], pos[b]);
                    *slot = points.len() as u32;
                    points.push([
                        pa.0 + t * (pb.0 - pa.0) - 1.0,
                        pa.1 + t * (pb.1 - pa.1) - 1.0,
                    ]);
                    next.push(none);
                }
                crossings[count] = (ins[a], *slot);
                count += 1;
            }
            // Walking the cell boundary counter-clockwise, the inside region's boundary leaves
            // the cell edge at an exit and the iso-segment runs back from it to an entry.
            // One inside run: exit → its entry. Saddle: each exit pairs with the entry before
            // it (inside corners separate) or after it (inside corners joined through the
            // centre).
            let mut link = |from: u32, to: u32| {
                next[from as usize] = to;
                starts.push(from);
            };
            if count == 2 {
                if crossings[0].0 {
                    link(crossings[0].1, crossings[1].1);
                } else {
                    link(crossings[1].1, crossings[0].1);
                }
            } else {
                let centre = if v.iter().any(|x| x.is_nan()) {
                    f64::NEG_INFINITY
                } else {
                    v.iter().sum::<f64>() / 4.0
                };
                let joined = centre >= level;
                for k in 0..4 {
                    if crossings[k].0 {
                        let entry = if joined { (k + 1) % 4 } else { (k + 3) % 4 };
                        link(crossings[k].1, crossings[entry].1);
                    }
                }
            }
        }
    }

    // Every crossing has exactly one outgoing and one incoming segment: chain them.
    let mut used = vec![false; points.len()];
    let mut loops = Vec::new();
    for &start in &starts {
        if used[start as usize] {
            continue;
        }
        let mut lp = Vec::new();
        let mut e = start;
        loop {
            used[e as usize] = true;
            lp.push(points[e as usize]);
            e = next[e as usize];
            if e == start || e == u32::MAX {
                break;
            }
        }
        dedup_closed(&mut lp);
        if lp.len() >= 3 {
            loops.push(lp);
        }
    }
    loops
}

/// Remove consecutive repeated points, including a last point equal to the first.
pub fn dedup_closed(pts: &mut Vec<Point>) {
    pts.dedup();
    while pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::{is_simple, signed_area};

    fn disc_field(w: usize, h: usize, cx: f64, cy: f64, r: f64) -> Vec<f32> {
        let mut f = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                f[y * w + x] = (r - ((x as f64 - cx).hypot(y as f64 - cy))) as f32;
            }
        }
        f
    }

    #[test]
    fn disc_gives_one_ccw_loop_on_the_circle() {
        let f = disc_field(40, 30, 20.3, 14.7, 9.0);
        let loops = iso_loops(&f, 40, 30, 0.0);
        assert_eq!(loops.len(), 1);
        assert!(signed_area(&loops[0]) > 0.0);
        assert!(is_simple(&loops[0]));
        for p in &loops[0] {
            let r = (p[0] - 20.3).hypot(p[1] - 14.7);
            assert!((r - 9.0).abs() < 0.05, "point {p:?} at radius {r}");
        }
    }

    #[test]
    fn annulus_gives_ccw_outer_and_cw_hole() {
        let (w, h) = (50, 50);
        let mut f = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let r = (x as f64 - 25.0).hypot(y as f64 - 25.0);
                f[y * w + x] = (6.0 - (r - 15.0).abs()) as f32;
            }
        }
        let mut loops = iso_loops(&f, w, h, 0.0);
        loops.sort_by(|a, b| signed_area(b).total_cmp(&signed_area(a)));
        assert_eq!(loops.len(), 2);
        let (outer, hole) = (signed_area(&loops[0]), signed_area(&loops[1]));
        assert!(outer > 0.0 && hole < 0.0);
        let pi = std::f64::consts::PI;
        assert!((outer - pi * 21.0 * 21.0).abs() / outer < 0.01);
        assert!((-hole - pi * 9.0 * 9.0).abs() / -hole < 0.01);
    }

    #[test]
    fn region_touching_the_edge_closes_half_a_pixel_out() {
        let f = vec![1.0f32; 4 * 3];
        let loops = iso_loops(&f, 4, 3, 0.5);
        assert_eq!(loops.len(), 1);
        assert!(
            (signed_area(&loops[0]) - 11.5).abs() < 1e-9,
            "corners are cut diagonally"
        );
        for p in &loops[0] {
            assert!(p[0] >= -0.5 && p[0] <= 3.5 && p[1] >= -0.5 && p[1] <= 2.5);
        }
    }

    #[test]
    fn saddles_and_nan_stay_consistent() {
        // A checkerboard exercises every saddle; loops must still be simple and closed.
        let (w, h) = (6, 5);
        let mut f: Vec<f32> = (0..w * h)
            .map(|k| if (k % w + k / w) % 2 == 0 { 1.0 } else { 0.0 })
            .collect();
        f[7] = f32::NAN;
        for level in [0.5, 0.3, 0.7] {
            for lp in iso_loops(&f, w, h, level) {
                assert!(is_simple(&lp), "level {level}: {lp:?}");
            }
        }
    }

    #[test]
    fn sample_exactly_at_level_gives_no_repeated_points() {
        let f = vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        let loops = iso_loops(&f, 3, 3, 1.0);
        assert_eq!(loops.len(), 1);
        assert!(is_simple(&loops[0]));
    }
}
