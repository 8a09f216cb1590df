//! Capping (METHOD.md §3 "degeneracy and capping"): how a material region with no
//! counterpart on the next slice closes.
//!
//! In: a region of one slice, its outer contour (counter-clockwise) and its holes
//! (clockwise), closed polygons in mm; the raster cell (mm). Out: the cap of the outer
//! contour and of each hole, as degenerate intermediate contours (points) or loops, plus
//! warnings. The caller places them half a slice beyond the region.
//!
//! - Without holes the cap is the innermost point of the region's distance map (largest
//!   distance to the boundary), found on the raster and then refined on the exact distance
//!   to sub-cell precision (a compass search: the map peaks in a cone or ridge, where a
//!   parabola fit would be biased).
//! - With holes (beyond the paper: an annulus is the top of a flat torus) the largest-distance
//!   set is a ridge, not a point. The material is split into zones, one per boundary contour
//!   (the points of the material nearer to it than to the others); the outer contour closes
//!   onto the inner boundary of its zone and each hole onto the outer boundary of its zone.
//!   These loops are ridge (medial-axis) loops: with one hole both are the same loop, so the
//!   outer and hole surfaces meet along it and the solid closes like a torus, with no
//!   membrane over the hole. If a zone boundary has several candidate loops the largest is
//!   used (with a warning); if it has none the cap degenerates to the innermost point (with
//!   a warning).
//!
//! Invariants: every loop is counter-clockwise and simple; shared ridge chains are
//! compressed identically (within a quarter cell); deterministic; errors, not panics, on bad
//! input.

use super::branching::{raster_for, Intermediate, EXACT_MARGIN_CELLS, SIMPLIFY_TOL_CELLS};
use super::distance_map::{
    inside_mask, mark_label_band, nearest_contours_within, validate_polygons, Grid, SeedField,
};
use super::polygon::{signed_area, Point};
use super::zones::{largest_loop, neg_psi, refine_innermost, simplify_shared, zone_loops};
use super::GeometryError;

/// The caps of one region: the outer contour's and each hole's, in input order.
#[derive(Clone, Debug, PartialEq)]
pub struct Caps {
    pub outer: Intermediate,
    pub holes: Vec<Intermediate>,
    pub warnings: Vec<String>,
}

/// Innermost point of the material (largest depth), refined on the exact distance.
fn innermost(grid: &Grid, polys: &[&[Point]], neg_sdm: &[f32]) -> Point {
    let best = (0..neg_sdm.len()).fold(0, |b, k| if neg_sdm[k] > neg_sdm[b] { k } else { b });
    let start = grid.point(best / grid.width, best % grid.width);
    refine_innermost(polys, start, grid.cell_mm)
}

/// The samples where the distance must be exact: near the material's deepest samples (the
/// seed distances exceed the true ones by less than 2.5 cells, so no sample farther below
/// the deepest seed distance than the margin can be the deepest), near the boundary (the
/// zero set of the depth), and around the zones' boundaries (the ridge).
fn exact_band(grid: &Grid, seed: &SeedField, material: &[bool]) -> Vec<bool> {
    let m = EXACT_MARGIN_CELLS * grid.cell_mm;
    let top = (0..grid.len())
        .filter(|&k| material[k])
        .map(|k| seed.dist[k])
        .fold(f64::NEG_INFINITY, f64::max);
    let mut mask: Vec<bool> = (0..grid.len())
        .map(|k| seed.dist[k] < m || (material[k] && seed.dist[k] >= top - m))
        .collect();
    mark_label_band(grid, &[seed], EXACT_MARGIN_CELLS as usize, &mut mask);
    mask
}

/// Caps of the region bounded by `outer` minus `holes`.
pub fn cap(outer: &[Point], holes: &[&[Point]], cell_mm: f64) -> Result<Caps, GeometryError> {
    validate_polygons(&[outer], "outer contour")?;
    validate_polygons(holes, "hole")?;
    let mut warnings = Vec::new();
    let all: Vec<&[Point]> = std::iter::once(outer)
        .chain(holes.iter().copied())
        .collect();
    let grid = raster_for(&all, cell_mm, &mut warnings)?;

    // Zones among the boundary contours, by unsigned distance within the material. The
    // distances are exact only where they matter (see `exact_band`).
    let material = inside_mask(&grid, &all);
    let seed = SeedField::new(&grid, &all, false);
    let exact = exact_band(&grid, &seed, &material);
    let near = nearest_contours_within(&grid, seed, Some(&exact));
    // Depth in the material: positive inside, negative outside (−signed distance).
    let neg_sdm: Vec<f32> = near
        .min1
        .iter()
        .zip(&material)
        .map(|(&d, &m)| if m { d } else { -d })
        .collect();
    if !material.iter().any(|&m| m) {
        return Err(GeometryError::Degenerate(format!(
            "the region has no material on a {} mm raster (outer area {:.6} mm²)",
            grid.cell_mm,
            signed_area(outer)
        )));
    }
    if holes.is_empty() {
        return Ok(Caps {
            outer: Intermediate::Point(innermost(&grid, &all, &neg_sdm)),
            holes: Vec::new(),
            warnings,
        });
    }

    // Zone loops: label 0 is the outer contour, label h + 1 hole h.
    let zone_loops_of = |label: u32| {
        let g = |k: usize| neg_sdm[k] as f64;
        let n = |k: usize| neg_psi(&near, label, k) as f32 as f64;
        zone_loops(&grid, &g, &n, None)
    };
    let mut chosen: Vec<Option<Vec<Point>>> = Vec::with_capacity(all.len());
    for label in 0..all.len() {
        let loops = zone_loops_of(label as u32);
        // The outer contour's zone is bounded inside by the ridge (a clockwise hole loop of
        // its zone region); a hole's zone outside by the ridge (counter-clockwise).
        let want_ccw = label > 0;
        let (best, count, _) = largest_loop(&loops, want_ccw);
        let name = if label == 0 {
            "outer contour".to_string()
        } else {
            format!("hole {}", label - 1)
        };
        if count > 1 {
            warnings.push(format!(
                "{name}: its zone has {count} ridge loops; capped onto the largest"
            ));
        }
        chosen.push(best.map(|b| {
            let mut lp = loops[b].clone();
            if !want_ccw {
                lp.reverse();
            }
            lp
        }));
    }
    let found: Vec<Vec<Point>> = chosen.iter().flatten().cloned().collect();
    let mut compressed = simplify_shared(&found, SIMPLIFY_TOL_CELLS * grid.cell_mm).into_iter();
    let mut caps: Vec<Intermediate> = Vec::with_capacity(all.len());
    for (label, c) in chosen.iter().enumerate() {
        let lp = if c.is_some() { compressed.next() } else { None };
        match lp {
            Some(lp) => caps.push(Intermediate::Loop(lp)),
            _ => {
                let p = innermost(&grid, &all, &neg_sdm);
                warnings.push(format!(
                    "{}: no ridge loop found; capped at the innermost point {p:?}",
                    if label == 0 {
                        "outer contour".to_string()
                    } else {
                        format!("hole {}", label - 1)
                    }
                ));
                caps.push(Intermediate::Point(p));
            }
        }
    }
    let mut caps = caps.into_iter();
    let outer_cap = caps
        .next()
        .unwrap_or_else(|| Intermediate::Point(innermost(&grid, &all, &neg_sdm)));
    Ok(Caps {
        outer: outer_cap,
        holes: caps.collect(),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::circle;
    use crate::geometry::polygon::is_simple;

    #[test]
    fn disc_caps_at_its_centre() {
        let d = circle(3.3, -1.7, 8.0, 500, true);
        let c = cap(&d, &[], 0.2).unwrap();
        let Intermediate::Point(p) = c.outer else {
            panic!("expected a point")
        };
        assert!((p[0] - 3.3).hypot(p[1] + 1.7) < 0.1, "{p:?}");
        assert!(c.holes.is_empty() && c.warnings.is_empty());
    }

    #[test]
    fn annulus_caps_on_its_mid_radius_for_outer_and_hole() {
        let outer = circle(0.0, 0.0, 20.0, 800, true);
        let hole = circle(0.0, 0.0, 10.0, 500, false);
        let cell = 0.2;
        let c = cap(&outer, &[&hole], cell).unwrap();
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        let (Intermediate::Loop(o), Intermediate::Loop(h)) = (&c.outer, &c.holes[0]) else {
            panic!("expected loops: {c:?}")
        };
        for lp in [o, h] {
            assert!(signed_area(lp) > 0.0 && is_simple(lp));
            for p in lp {
                let r = p[0].hypot(p[1]);
                assert!((r - 15.0).abs() < cell / 2.0, "radius {r}");
            }
        }
        assert_eq!(o, h, "outer and hole close onto the same ridge loop");
    }
}
