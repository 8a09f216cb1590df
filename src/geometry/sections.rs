//! Sections as the construction needs them: disjoint simple contours, each hole inside an outer
//! contour and each outer contour inside none or inside a hole (METHOD.md §2: a section is
//! the region its contours bound). Contours this project extracts from images are so by
//! construction; contours a segmentation tool hands over (NDJSON) need not be: a contour
//! crossing itself, two contours overlapping, an outer contour inside another outer contour
//! or a hole outside every contour. Such a section, left as it is, gives distance maps of
//! the wrong region and surfaces through one another.
//!
//! In: a section's contours (outer counter-clockwise, holes clockwise, as the reader
//! normalises them). Out: [`defect`], the first thing that is wrong (`None` for a valid
//! section, which is then used exactly as given), and [`resolved`], the region the contours
//! mean as disjoint simple contours: each contour fills what it winds round (non-zero
//! rule, so both lobes of a figure eight), an outer contour adds its fill and a hole takes
//! its fill away, counted by winding, so the region is where more outer contours than holes
//! wind. This does not depend on the order the contours come in: an island in a hole counts
//! +1 − 1 + 1 and stays; two overlapping outer contours are their union; a hole beyond its
//! contour removes only what it covers. The polygon boolean operations are iOverlay's
//! (`i_overlay`, the engine of the `geo` crate), whose float interface snaps points to an
//! integer grid over the section's extent (about 10⁻⁶ mm for a 500 mm slice), so a resolved
//! section's points may move by that much.
//!
//! Invariants: pure and deterministic (no hash-map order, iOverlay single-threaded); no panic
//! on any finite input.

use std::fmt;

use i_overlay::core::fill_rule::FillRule;
use i_overlay::float::simplify::SimplifyShape;

use super::polygon::{bbox, contains, edges_meeting_among, proper_crossing, signed_area, Point};
use crate::section::Contour;

/// The first thing found wrong with a section's contours (indices as given).
#[derive(Clone, Debug, PartialEq)]
pub enum Defect {
    /// The contour has no area (its points lie on one line).
    NoArea { contour: usize },
    /// Two edges of one contour cross, at `at`.
    CrossesItself { contour: usize, at: Point },
    /// An edge of one contour crosses an edge of another, at `at`.
    Crossing { contours: [usize; 2], at: Point },
    /// The contours touch or nest so that their areas, outer contours' added and holes'
    /// taken away, do not add up to the region they bound (overlapping along shared edges, for
    /// instance, where no two edges cross).
    Overlap { listed_mm2: f64, region_mm2: f64 },
    /// The contour lies inside `depth` others, which makes it a hole if odd, an outer
    /// contour if even, and it is flagged the other way.
    Misnested {
        contour: usize,
        hole: bool,
        depth: usize,
    },
}

impl fmt::Display for Defect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Defect::NoArea { contour } => write!(f, "contour {contour} has no area"),
            Defect::CrossesItself { contour, at } => write!(
                f,
                "contour {contour} crosses itself at ({:.3}, {:.3})",
                at[0], at[1]
            ),
            Defect::Crossing { contours, at } => write!(
                f,
                "contours {} and {} cross at ({:.3}, {:.3})",
                contours[0], contours[1], at[0], at[1]
            ),
            Defect::Overlap {
                listed_mm2,
                region_mm2,
            } => write!(
                f,
                "contours overlap: their areas add up to {listed_mm2:.3} mm² (outer contours \
                 less holes) but they bound {region_mm2:.3} mm²"
            ),
            Defect::Misnested {
                contour,
                hole,
                depth,
            } => write!(
                f,
                "{} {contour} lies inside {depth} other contour(s), so it is {}",
                if *hole { "hole" } else { "outer contour" },
                if *hole {
                    "no hole of an outer contour"
                } else {
                    "inside an outer contour without a hole between them"
                }
            ),
        }
    }
}

/// The first defect of the section's contours, or `None` when they are disjoint, simple
/// (edges may touch, not cross) and nested as their hole flags say. Checks, in order:
/// crossing edges (a sweep over all edges of the section, O(n log n) on typical contours),
/// nesting (three points of each contour against the other contours), areas, and last that
/// the region they bound has the area they list (contours can overlap along shared edges
/// with no edge crossing another and no vertex inside another contour).
pub fn defect(contours: &[Contour]) -> Option<Defect> {
    if let Some(k) = contours.iter().position(|c| c.points.len() < 3) {
        return Some(Defect::NoArea { contour: k });
    }
    if let Some(d) = first_crossing(contours) {
        return Some(d);
    }
    if let Some(d) = misnested(contours) {
        return Some(d);
    }
    if let Some(k) = contours.iter().position(|c| signed_area(&c.points) == 0.0) {
        return Some(Defect::NoArea { contour: k });
    }
    // What edges and vertices cannot tell: contours overlapping along shared edges. Disjoint
    // contours bound exactly their areas; the region's own area differs from it by the
    // snapping of its points only.
    let listed: f64 = contours.iter().map(|c| signed_area(&c.points)).sum();
    let region: f64 = resolved(contours)
        .iter()
        .map(|c| signed_area(&c.points))
        .sum();
    let scale: f64 = contours.iter().map(|c| signed_area(&c.points).abs()).sum();
    if (listed - region).abs() > AREA_SLACK * scale + 1e-9 {
        return Some(Defect::Overlap {
            listed_mm2: listed,
            region_mm2: region,
        });
    }
    None
}

/// Relative difference between the listed area and the region's within which they are
/// taken as equal: the region's points are snapped to a grid some 10⁻⁶ mm fine.
const AREA_SLACK: f64 = 1e-6;

/// The first contour nested against its hole flag.
fn misnested(contours: &[Contour]) -> Option<Defect> {
    let boxes: Vec<[f64; 4]> = contours.iter().map(|c| bbox(&c.points)).collect();
    let depth = |k: usize, p: Point| {
        (0..contours.len())
            .filter(|&j| {
                let b = boxes[j];
                j != k
                    && p[0] >= b[0]
                    && p[0] <= b[2]
                    && p[1] >= b[1]
                    && p[1] <= b[3]
                    && contains(&contours[j].points, p)
            })
            .count()
    };
    for (k, c) in contours.iter().enumerate() {
        // With no crossings every point of a contour lies equally deep, but a vertex on
        // another contour (two contours touching at a saddle of the image) is neither inside
        // nor out: a contour is misnested only if three of its vertices all say so.
        let n = c.points.len();
        let mut depths = [0, n / 3, 2 * n / 3].map(|i| depth(k, c.points[i]));
        depths.sort_unstable();
        if depths.iter().all(|&d| (d % 2 == 1) != c.hole) {
            return Some(Defect::Misnested {
                contour: k,
                hole: c.hole,
                depth: depths[1],
            });
        }
    }
    None
}

/// The first proper crossing between two edges of the section (not adjacent edges of one
/// contour), in sweep order along x.
fn first_crossing(contours: &[Contour]) -> Option<Defect> {
    let polys: Vec<&[Point]> = contours.iter().map(|c| c.points.as_slice()).collect();
    let mut found = None;
    edges_meeting_among(&polys, 1, |(k, i), (l, j), (a, b), (c, d)| {
        let n = polys[k].len();
        if k == l && ((i + 1) % n == j || (j + 1) % n == i) {
            return false;
        }
        let Some(s) = proper_crossing(a, b, c, d) else {
            return false;
        };
        let at = [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])];
        found = Some(if k == l {
            Defect::CrossesItself { contour: k, at }
        } else {
            Defect::Crossing {
                contours: [k.min(l), k.max(l)],
                at,
            }
        });
        true
    });
    found
}

/// The region the contours mean (see the module docs), as disjoint simple contours: per
/// piece its outer contour (counter-clockwise), then its holes (clockwise). Empty when
/// nothing is inside (every contour a hole, say).
pub fn resolved(contours: &[Contour]) -> Vec<Contour> {
    // Each contour's own fill as simple paths winding once round it: a piece's boundary
    // counter-clockwise, its holes clockwise; all reversed for a hole contour, whose fill
    // counts against.
    let mut paths: Vec<Vec<Point>> = Vec::new();
    for c in contours {
        for shape in c.points.simplify_shape(FillRule::NonZero) {
            for (j, path) in shape.into_iter().enumerate() {
                let ccw = signed_area(&path) > 0.0;
                let want_ccw = (j == 0) != c.hole;
                paths.push(if ccw == want_ccw {
                    path
                } else {
                    path.into_iter().rev().collect()
                });
            }
        }
    }
    let mut out = Vec::new();
    for shape in paths.simplify_shape(FillRule::Positive) {
        for (j, path) in shape.into_iter().enumerate() {
            let hole = j > 0;
            let ccw = signed_area(&path) > 0.0;
            let points = if ccw == hole {
                path.into_iter().rev().collect()
            } else {
                path
            };
            out.push(Contour { points, hole });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(cx: f64, cy: f64, r: f64, hole: bool) -> Contour {
        let mut points = vec![
            [cx - r, cy - r],
            [cx + r, cy - r],
            [cx + r, cy + r],
            [cx - r, cy + r],
        ];
        if hole {
            points.reverse();
        }
        Contour { points, hole }
    }

    /// Area of the region: outer contours add, holes (clockwise) subtract.
    fn area(contours: &[Contour]) -> f64 {
        contours.iter().map(|c| signed_area(&c.points)).sum()
    }

    fn assert_valid(contours: &[Contour]) {
        assert_eq!(defect(contours), None, "{contours:?}");
        for c in contours {
            assert_eq!(signed_area(&c.points) < 0.0, c.hole, "{c:?}");
        }
    }

    #[test]
    fn nested_contours_in_any_order_are_valid_and_kept() {
        // An outer contour, its hole, an island in the hole, and another outer contour.
        let mut section = vec![
            square(0.0, 0.0, 10.0, false),
            square(0.0, 0.0, 6.0, true),
            square(0.0, 0.0, 2.0, false),
            square(30.0, 0.0, 5.0, false),
        ];
        assert_valid(&section);
        section.reverse();
        assert_valid(&section);
        // Touching is not crossing: two squares sharing an edge, a triangle whose first
        // vertex lies on a square's edge (outside by the even-odd test, or inside: either
        // way the other vertices say where it lies).
        assert_valid(&[square(0.0, 0.0, 1.0, false), square(2.0, 0.0, 1.0, false)]);
        for x in [1.0, -1.0] {
            let touching = Contour {
                points: vec![[x, 0.0], [3.0 * x, -x], [3.0 * x, x]],
                hole: false,
            };
            assert_valid(&[square(0.0, 0.0, 1.0, false), touching]);
        }
    }

    #[test]
    fn a_figure_eight_is_both_its_lobes() {
        let bow = Contour {
            points: vec![[-10.0, -10.0], [10.0, 10.0], [10.0, -10.0], [-10.0, 10.0]],
            hole: false,
        };
        match defect(std::slice::from_ref(&bow)) {
            Some(Defect::CrossesItself { contour: 0, at }) => {
                assert!(at[0].abs() < 1e-12 && at[1].abs() < 1e-12, "{at:?}");
            }
            d => panic!("{d:?}"),
        }
        let r = resolved(&[bow]);
        assert_eq!(r.len(), 2, "{r:?}");
        assert_valid(&r);
        assert!((area(&r) - 200.0).abs() < 1e-6, "{}", area(&r));
    }

    #[test]
    fn overlapping_outer_contours_are_their_union() {
        let section = [square(-6.0, 0.0, 8.0, false), square(6.0, 0.0, 8.0, false)];
        // Their horizontal edges overlap along y = ±8 and each vertical edge ends on the
        // other square's: nothing crosses properly, no vertex lies inside; the areas tell.
        assert_eq!(
            defect(&section),
            Some(Defect::Overlap {
                listed_mm2: 512.0,
                region_mm2: 448.0
            })
        );
        let crossing = [square(-6.0, 0.0, 8.0, false), square(6.0, 1.0, 8.0, false)];
        assert!(matches!(
            defect(&crossing),
            Some(Defect::Crossing {
                contours: [0, 1],
                ..
            })
        ));
        let r = resolved(&section);
        assert_eq!(r.len(), 1, "{r:?}");
        assert_valid(&r);
        assert!((area(&r) - (2.0 * 256.0 - 64.0)).abs() < 1e-6);
        assert_eq!(bbox(&r[0].points), [-14.0, -8.0, 14.0, 8.0]);
    }

    #[test]
    fn misnested_contours_are_resolved_by_winding() {
        // An outer contour inside another, with no hole between: the larger alone.
        let inside = [square(0.0, 0.0, 10.0, false), square(1.0, 0.0, 3.0, false)];
        assert_eq!(
            defect(&inside),
            Some(Defect::Misnested {
                contour: 1,
                hole: false,
                depth: 1
            })
        );
        let r = resolved(&inside);
        assert_valid(&r);
        assert_eq!(r.len(), 1);
        assert!((area(&r) - 400.0).abs() < 1e-6);

        // A hole outside every outer contour removes nothing; one half outside removes
        // what it covers.
        let beyond = [square(0.0, 0.0, 10.0, false), square(30.0, 0.0, 3.0, true)];
        assert!(matches!(
            defect(&beyond),
            Some(Defect::Misnested { contour: 1, .. })
        ));
        let r = resolved(&beyond);
        assert_valid(&r);
        assert!((area(&r) - 400.0).abs() < 1e-6);
        let half = [square(0.0, 0.0, 10.0, false), square(10.0, 0.0, 2.0, true)];
        assert!(matches!(defect(&half), Some(Defect::Crossing { .. })));
        let r = resolved(&half);
        assert_valid(&r);
        assert!((area(&r) - (400.0 - 8.0)).abs() < 1e-6, "{}", area(&r));

        // A hole alone is nothing.
        assert_eq!(resolved(&[square(0.0, 0.0, 3.0, true)]), Vec::new());
    }

    #[test]
    fn a_valid_section_resolves_to_the_same_region() {
        let section = vec![
            square(0.0, 0.0, 10.0, false),
            square(0.0, 0.0, 6.0, true),
            square(0.0, 0.0, 2.0, false),
        ];
        let r = resolved(&section);
        assert_valid(&r);
        assert_eq!(r.len(), 3);
        assert!((area(&r) - area(&section)).abs() < 1e-6);
        assert_eq!(r.iter().filter(|c| c.hole).count(), 1);
    }

    #[test]
    fn a_keyhole_ring_keeps_its_hole_when_resolved() {
        // One contour round a ring: out along the outer square, in by a slit, back round the
        // inner square the other way. Its non-zero fill is the ring, a piece with a hole.
        let ring = Contour {
            points: vec![
                [10.0, 0.0],
                [10.0, 10.0],
                [-10.0, 10.0],
                [-10.0, -10.0],
                [10.0, -10.0],
                [10.0, 0.0],
                [5.0, 0.0],
                [5.0, -5.0],
                [-5.0, -5.0],
                [-5.0, 5.0],
                [5.0, 5.0],
                [5.0, 0.0],
            ],
            hole: false,
        };
        let other = square(30.0, 0.0, 2.0, false);
        let r = resolved(&[ring.clone(), other.clone()]);
        assert_valid(&r);
        assert!((area(&r) - (400.0 - 100.0 + 16.0)).abs() < 1e-6, "{r:?}");
        assert_eq!(r.iter().filter(|c| c.hole).count(), 1, "{r:?}");
        // As a hole of a larger contour it takes the ring away, leaving the middle.
        let mut hole = ring;
        hole.points.reverse();
        hole.hole = true;
        let r = resolved(&[square(0.0, 0.0, 20.0, false), hole]);
        assert_valid(&r);
        assert!((area(&r) - (1600.0 - 300.0)).abs() < 1e-6, "{r:?}");
    }

    #[test]
    fn collinear_points_have_no_area() {
        let flat = Contour {
            points: vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]],
            hole: false,
        };
        let section = [square(10.0, 0.0, 1.0, false), flat];
        assert_eq!(defect(&section), Some(Defect::NoArea { contour: 1 }));
        let r = resolved(&section);
        assert_valid(&r);
        assert_eq!(r.len(), 1);
    }
}
