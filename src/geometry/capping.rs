//! Capping (METHOD.md §3 "degeneracy and capping"): how a material region with no
//! counterpart on the next slice closes.
//!
//! In: a region of one slice, its outer contour (counter-clockwise) and its holes
//! (clockwise), closed polygons in mm; the raster cell (mm). Out: the cap of the outer
//! contour and of each hole, as degenerate intermediate contours (points) or loops, plus
//! warnings. The caller places them at the height [`cap_height`] estimates beyond the region.
//!
//! - Without holes the cap is the innermost point of the region's distance map (largest
//!   distance to the boundary), found on the raster and then refined on the exact distance
//!   to sub-cell precision (a compass search: the map peaks in a cone or ridge, where a
//!   parabola fit would be biased). Beyond the paper, a contour not star-shaped around that
//!   point caps onto a zero-width ridge loop instead (see [`super::ridge`]), or keeps the
//!   point with a warning where no ridge path passes its checks.
//! - With holes (beyond the paper: an annulus is the top of a flat torus) the largest-distance
//!   set is a ridge, not a point. The material is split into zones, one per boundary contour
//!   (the points of the material nearer to it than to the others); the outer contour closes
//!   onto the inner boundary of its zone and each hole onto the outer boundary of its zone.
//!   These loops are ridge (medial-axis) loops: with one hole both are the same loop, so the
//!   outer and hole surfaces meet along it and the solid closes like a torus, with no
//!   membrane over the hole. Where the outer contour's zone rings several groups of holes
//!   (the material between them is its), its inner boundaries are joined by zero-width
//!   slits through the zone ([`super::bridges`]), so the outer wall closes onto every group's
//!   ridge. If a hole's zone boundary has several candidate loops the largest is used (with
//!   a warning); if a zone has none the cap degenerates to the innermost point (with a
//!   warning).
//!
//! Invariants: every loop is counter-clockwise and simple, except a ridge loop (zero width,
//! weakly simple); shared ridge chains are compressed identically (within a quarter cell);
//! deterministic; errors, not panics, on bad input.

use super::branching::{raster_for, Intermediate, EXACT_MARGIN_CELLS, SIMPLIFY_TOL_CELLS};
use super::bridges::join_pieces;
use super::distance_map::{
    inside_mask, mark_label_band, nearest_contours_within, validate_polygons, Grid, SeedField,
};
use super::overlap::{overlap_area, Region as Material};
use super::polygon::{perimeter, signed_area, Point};
use super::ridge::{is_star_around, ridge_loop};
use super::zones::{largest_loop, neg_psi, refine_innermost, simplify_shared, zone_loops};
use super::GeometryError;

/// The caps of one region: the outer contour's and each hole's, in input order.
#[derive(Clone, Debug, PartialEq)]
pub struct Caps {
    pub outer: Intermediate,
    pub holes: Vec<Intermediate>,
    pub warnings: Vec<String>,
    /// Informational: ridge loops that bridges joined whole, dropping nothing.
    pub notes: Vec<String>,
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

/// Caps of the region bounded by `outer` minus `holes`. `ridge_tip_mm`: how far a ridge
/// path's ends stay back from the contour's tips ([`ridge_loop`]); the fitting tolerance.
pub fn cap(
    outer: &[Point],
    holes: &[&[Point]],
    cell_mm: f64,
    ridge_tip_mm: f64,
) -> Result<Caps, GeometryError> {
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
        let p = innermost(&grid, &all, &neg_sdm);
        let slack = SIMPLIFY_TOL_CELLS * cell_mm;
        let outer = if is_star_around(outer, p, slack) {
            Intermediate::Point(p)
        } else {
            match ridge_loop(outer, 0.5 * cell_mm, slack, ridge_tip_mm) {
                Some(lp) => Intermediate::Loop(lp),
                None => {
                    warnings.push(format!(
                        "contour not star-shaped around its innermost point {p:?} and no \
                         ridge path inside it; capped at the point (the cap may fold)"
                    ));
                    Intermediate::Point(p)
                }
            }
        };
        return Ok(Caps {
            outer,
            holes: Vec::new(),
            warnings,
            notes: Vec::new(),
        });
    }

    // Zone loops: label 0 is the outer contour, label h + 1 hole h.
    let zone_loops_of = |label: u32| {
        let g = |k: usize| neg_sdm[k] as f64;
        let n = |k: usize| neg_psi(&near, label, k) as f32 as f64;
        zone_loops(&grid, &g, &n, None)
    };
    // Per label, its cap loops: one, or for the outer contour every inner boundary of its
    // zone, largest first (each bounds the zones of some holes).
    let mut chosen: Vec<Vec<Vec<Point>>> = Vec::with_capacity(all.len());
    for label in 0..all.len() {
        let mut loops = zone_loops_of(label as u32);
        // The outer contour's zone is bounded inside by the ridge (clockwise hole loops of
        // its zone region); a hole's zone outside by the ridge (counter-clockwise).
        let want_ccw = label > 0;
        let (best, count, _) = largest_loop(&loops, want_ccw);
        let mut kept: Vec<Vec<Point>> = Vec::new();
        if let Some(b) = best {
            kept.push(loops.swap_remove(b));
            if label == 0 {
                let mut rest: Vec<Vec<Point>> = loops
                    .into_iter()
                    .filter(|lp| signed_area(lp) < 0.0)
                    .collect();
                rest.sort_by(|a, b| signed_area(a).total_cmp(&signed_area(b)));
                kept.extend(rest);
            } else if count > 1 {
                warnings.push(format!(
                    "hole {}: its zone has {count} ridge loops; capped onto the largest",
                    label - 1
                ));
            }
        }
        if !want_ccw {
            kept.iter_mut().for_each(|lp| lp.reverse());
        }
        chosen.push(kept);
    }
    let found: Vec<Vec<Point>> = chosen.iter().flatten().cloned().collect();
    let compressed = simplify_shared(&found, SIMPLIFY_TOL_CELLS * grid.cell_mm);
    let all_loops: Vec<&[Point]> = compressed.iter().map(|l| l.as_slice()).collect();
    let mut next = 0;
    let mut caps: Vec<Intermediate> = Vec::with_capacity(all.len());
    let mut notes = Vec::new();
    for (label, c) in chosen.iter().enumerate() {
        let own = &compressed[next..next + c.len()];
        next += c.len();
        if own.len() > 1 {
            // The outer contour's zone rings several groups of holes: its loops are joined
            // by slits through the zone (as a split zone's pieces are, `super::bridges`),
            // so the outer wall closes onto the ridge round every group.
            let joined = join_pieces(own, outer, &all_loops, grid.cell_mm);
            let message = format!(
                "outer contour: its zone has {} ridge loops; joined {} by bridges, dropped \
                 {:.4} mm²",
                own.len(),
                joined.pieces,
                joined.dropped_area
            );
            if joined.dropped_area == 0.0 {
                &mut notes
            } else {
                &mut warnings
            }
            .push(message);
            caps.push(Intermediate::Loop(joined.points));
        } else if let Some(lp) = own.first() {
            caps.push(Intermediate::Loop(lp.clone()));
        } else {
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
    let mut caps = caps.into_iter();
    let outer_cap = caps
        .next()
        .unwrap_or_else(|| Intermediate::Point(innermost(&grid, &all, &neg_sdm)));
    Ok(Caps {
        outer: outer_cap,
        holes: caps.collect(),
        warnings,
        notes,
    })
}

/// Width of a section of material: area over boundary length (outer contour and holes).
/// A linear size that is half the radius for a disc, the half-width for an annulus, and
/// scales with the section, so its square is quadratic in height on spheres, ellipsoids,
/// tori and cones alike.
pub fn material_width(outer: &[Point], holes: &[&[Point]]) -> f64 {
    let area = signed_area(outer).abs() - holes.iter().map(|h| signed_area(h).abs()).sum::<f64>();
    let length = perimeter(outer) + holes.iter().map(|h| perimeter(h)).sum::<f64>();
    if length > 0.0 && area > 0.0 {
        area / length
    } else {
        0.0
    }
}

/// Where between the capped section and the empty one next to it the surface closes, as a
/// distance from the capped section (mm). Beyond the paper, which always closes half a slice
/// out (METHOD.md §3): that misses the volume of round ends (a flat torus loses 3 %).
///
/// `widths` are `(distance, width)` of the capped section (distance 0) and of the sections
/// leading up to it on the same chain of contours (distances > 0, nearest first), widths by
/// [`material_width`]; `spacing` is the distance to the empty section. With three sections
/// the squared width is fitted by a quadratic in height, exact for spheres, ellipsoids, tori
/// and cones, and the cap goes where it reaches zero. Beyond the empty section it cannot be
/// (the section would have material), so an estimate `e` past `spacing` means the sections
/// are not closing (a cylinder cut flat): the surface ends somewhere within the slice, and
/// the height falls back smoothly to half a slice, as `max(spacing / 2, spacing² / e)`.
/// Without three sections, or when the sections do not shrink towards the cap, half a slice.
/// The height is at least a tenth of the spacing, so the cap stays clear of its section.
pub fn cap_height(widths: &[(f64, f64)], spacing: f64) -> f64 {
    let half = 0.5 * spacing;
    let [(z0, w0), (d1, w1), (d2, w2)] = match widths {
        [a, b, c, ..] => [*a, *b, *c],
        _ => return half,
    };
    let ok = |v: f64| v.is_finite();
    if !(ok(spacing) && spacing > 0.0 && z0 == 0.0 && ok(w0) && ok(w1) && ok(w2))
        || !(0.0 < d1 && d1 < d2 && d2.is_finite())
        || !(0.0 < w0 && w0 < w1 && w1 <= w2)
    {
        return half;
    }
    // Squared width y(z) at heights z = 0, −d1, −d2 (z grows towards the cap), Newton form.
    let (y0, y1, y2) = (w0 * w0, w1 * w1, w2 * w2);
    let s01 = (y0 - y1) / d1; // slope between z = −d1 and 0
    let s12 = (y1 - y2) / (d2 - d1); // slope between z = −d2 and −d1
    let gamma = (s01 - s12) / d2;
    // y(z) = y0 + beta z + gamma z², with y'(−d1/2) = s01.
    let beta = s01 + gamma * d1;
    let end = smallest_positive_root(gamma, beta, y0);
    let h = match end {
        Some(e) if e <= spacing => e,
        Some(e) => half.max(spacing * spacing / e),
        None => half,
    };
    h.max(LEAST_CAP_HEIGHT * spacing)
}

/// The least cap height, in slice spacings: the cap stays clear of its section.
pub const LEAST_CAP_HEIGHT: f64 = 0.1;

/// The fraction of a void's footprint (the closed polygon `void`) that the section across
/// its cap leaves void too: `across` holds that section's contours in the void's plane
/// coordinates, each with whether it is a hole. Nested contours alternate outer and hole,
/// so the material over the footprint is the outers' overlap with it less the holes'
/// ([`overlap_area`], by scanlines a 64th of the void's size apart). 0 for a void of no
/// (finite) area.
pub fn open_fraction(void: &[Point], across: &[(&[Point], bool)]) -> f64 {
    let area = signed_area(void).abs();
    if !area.is_finite() || area <= 0.0 {
        return 0.0;
    }
    let cell = (area.sqrt() / 64.0).max(1e-3);
    let footprint = Material::filled(void);
    let covered: f64 = across
        .iter()
        .map(|&(c, hole)| {
            let shared = overlap_area(&footprint, &Material::filled(c), cell);
            if hole {
                -shared
            } else {
                shared
            }
        })
        .sum();
    (1.0 - covered / area).clamp(0.0, 1.0)
}

/// Smallest root z > 0 of `c2 z² + c1 z + c0` (c0 > 0), if any.
fn smallest_positive_root(c2: f64, c1: f64, c0: f64) -> Option<f64> {
    let scale = c1.abs().max(c0.abs()).max(c2.abs());
    if c2.abs() <= 1e-12 * scale {
        return (c1 < 0.0).then(|| -c0 / c1);
    }
    let mut disc = c1 * c1 - 4.0 * c2 * c0;
    if disc < 0.0 && disc > -1e-9 * c1 * c1 {
        disc = 0.0; // a double root (a cone's apex) under rounding
    }
    if disc < 0.0 {
        return None;
    }
    // Roots without cancellation: q = −(c1 + sign(c1) √disc) / 2, roots q / c2 and c0 / q.
    let q = -0.5 * (c1 + c1.signum() * disc.sqrt());
    let roots = [q / c2, if q != 0.0 { c0 / q } else { f64::NAN }];
    roots
        .into_iter()
        .filter(|r| r.is_finite() && *r > 0.0)
        .min_by(f64::total_cmp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::circle;
    use crate::geometry::polygon::is_simple;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<Point> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    #[test]
    fn a_void_under_material_is_closed_and_one_under_a_bay_or_a_hole_is_open() {
        let void = rect(0.0, 0.0, 4.0, 4.0);
        // Under material: nothing open.
        assert_eq!(
            open_fraction(&void, &[(&rect(-5.0, -5.0, 9.0, 9.0), false)]),
            0.0
        );
        // Nothing across (beyond the material's edge): all open.
        assert_eq!(open_fraction(&void, &[]), 1.0);
        // Half under the material's edge.
        let half = open_fraction(&void, &[(&rect(2.0, -5.0, 9.0, 9.0), false)]);
        assert!((half - 0.5).abs() < 1e-12, "{half}");
        // Under a hole of the material across (inside two contours: not material).
        let outer = rect(-5.0, -5.0, 9.0, 9.0);
        let hole = rect(-1.0, -1.0, 5.0, 5.0);
        assert_eq!(open_fraction(&void, &[(&outer, false), (&hole, true)]), 1.0);
        // A degenerate void has no footprint.
        assert_eq!(open_fraction(&[[0.0, 0.0], [1.0, 1.0]], &[]), 0.0);
    }

    #[test]
    fn disc_caps_at_its_centre() {
        let d = circle(3.3, -1.7, 8.0, 500, true);
        let c = cap(&d, &[], 0.2, 0.0).unwrap();
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
        let c = cap(&outer, &[&hole], cell, 0.0).unwrap();
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

    /// Two discs (radius 12 at x = ±20) joined by a neck 4 mm wide, each with a hole (radius 4):
    /// the material in the neck is nearer the outer contour than either hole, so the outer
    /// contour's zone rings each hole's zone separately. Its cap joins both ridge loops by a
    /// slit (before, it kept the larger and the other disc's outer wall swept onto it).
    #[test]
    fn a_dumbbell_with_a_hole_in_each_end_caps_its_outer_wall_onto_both_ridges() {
        let (c, r, neck) = (20.0f64, 12.0f64, 2.0f64);
        let a = (neck / r).asin();
        let arc = |cx: f64, from: f64, to: f64| -> Vec<Point> {
            (0..=200)
                .map(|k| {
                    let t = from + (to - from) * k as f64 / 200.0;
                    [cx + r * t.cos(), r * t.sin()]
                })
                .collect()
        };
        let pi = std::f64::consts::PI;
        // Counter-clockwise: round the right disc from its neck corner, along the neck's top,
        // round the left disc, back along the neck's bottom.
        let mut outer = arc(c, -pi + a, pi - a);
        outer.extend(arc(-c, a, 2.0 * pi - a));
        let holes = [
            circle(-c, 0.0, 4.0, 300, false),
            circle(c, 0.0, 4.0, 300, false),
        ];
        let refs: Vec<&[Point]> = holes.iter().map(|h| h.as_slice()).collect();
        let caps = cap(&outer, &refs, 0.2, 0.0).unwrap();
        assert!(
            caps.warnings.iter().all(|w| !w.contains("largest")),
            "{:?}",
            caps.warnings
        );
        let Intermediate::Loop(o) = &caps.outer else {
            panic!("expected a loop: {caps:?}")
        };
        let mut area = 0.0;
        for h in &caps.holes {
            let Intermediate::Loop(h) = h else {
                panic!("expected hole loops: {caps:?}")
            };
            // Every vertex of each hole's ridge loop is on the outer cap, bit for bit.
            assert!(h.iter().all(|p| o.contains(p)));
            area += signed_area(h);
        }
        // The slit adds no area: the outer cap bounds both ridges and nothing else.
        assert!(crate::geometry::polygon::is_weakly_simple(o));
        assert!(
            (signed_area(o) - area).abs() < 1e-6 * area,
            "{} vs {area}",
            signed_area(o)
        );
    }

    /// Widths of horizontal sections of a solid of revolution at the given heights below the
    /// last one, the last at `z_last`; `radius(z)` is the section radius, `hole(z)` the radius
    /// of its hole (0: none).
    fn widths(
        z_last: f64,
        step: f64,
        radius: impl Fn(f64) -> f64,
        hole: impl Fn(f64) -> f64,
    ) -> Vec<(f64, f64)> {
        (0..3)
            .map(|k| {
                let z = z_last - k as f64 * step;
                let outer = circle(0.0, 0.0, radius(z), 256, true);
                let h = hole(z);
                let w = if h > 0.0 {
                    let inner = circle(0.0, 0.0, h, 256, false);
                    material_width(&outer, &[&inner])
                } else {
                    material_width(&outer, &[])
                };
                (k as f64 * step, w)
            })
            .collect()
    }

    #[test]
    fn cap_height_finds_the_pole_of_a_sphere() {
        // Sphere of radius 10 about z = 0; last section at 9.1, next (empty) at 10.6.
        let r = |z: f64| (100.0 - z * z).sqrt();
        let h = cap_height(&widths(9.1, 1.5, r, |_| 0.0), 1.5);
        assert!((h - 0.9).abs() < 1e-9, "{h}");
    }

    #[test]
    fn cap_height_finds_the_top_of_a_flat_torus_and_a_cone() {
        // Torus R = 26, r = 9 about z = 0: the annulus at z has half-width √(81 − z²).
        let w = |z: f64| (81.0 - z * z).sqrt();
        let h = cap_height(&widths(7.8, 1.5, |z| 26.0 + w(z), |z| 26.0 - w(z)), 1.5);
        assert!((h - 1.2).abs() < 1e-9, "{h}");
        // Cone with its apex at z = 4: radius 4 − z.
        let h = cap_height(&widths(3.5, 1.0, |z| 4.0 - z, |_| 0.0), 2.0);
        assert!((h - 0.5).abs() < 1e-9, "{h}");
    }

    #[test]
    fn cap_height_falls_back_to_half_a_slice_without_a_closing_trend() {
        let half = 0.75;
        // A cylinder cut flat, a section that grows towards the cap, too little history.
        assert_eq!(cap_height(&widths(5.0, 1.5, |_| 8.0, |_| 0.0), 1.5), half);
        assert_eq!(
            cap_height(&widths(5.0, 1.5, |z| 8.0 + z, |_| 0.0), 1.5),
            half
        );
        assert_eq!(cap_height(&[(0.0, 2.0), (1.5, 3.0)], 1.5), half);
        assert_eq!(cap_height(&[], 1.5), half);
        assert_eq!(
            cap_height(&[(0.0, f64::NAN), (1.5, 3.0), (3.0, 4.0)], 1.5),
            half
        );
        // Slowly closing: an end estimated beyond the empty section blends towards half.
        // A sphere of radius 5 about z = −3 ends 2 mm out: 1.5² / 2.
        let r = |z: f64| (25.0 - (z + 3.0).powi(2)).sqrt();
        let h = cap_height(&widths(0.0, 1.5, r, |_| 0.0), 1.5);
        assert!((h - 1.125).abs() < 1e-9, "{h}");
    }

    #[test]
    fn cap_height_stays_within_the_slice() {
        // Random shrinking histories: the cap is never past the empty section, nor on its own.
        let mut state = 12345_u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..10_000 {
            let spacing = 0.2 + 5.0 * next();
            let w0 = 0.01 + 10.0 * next();
            let w1 = w0 + 10.0 * next();
            let w2 = w1 + 10.0 * next();
            let d1 = spacing * (0.2 + next());
            let d2 = d1 + spacing * (0.2 + next());
            let h = cap_height(&[(0.0, w0), (d1, w1), (d2, w2)], spacing);
            assert!(
                h >= 0.1 * spacing && h <= spacing,
                "{h} for spacing {spacing}"
            );
        }
    }
}
