//! Stage 7: skinning (paper §2.6) and the tolerance certificate. A region's curves become one
//! bicubic surface, closed in u and open in v; then every input contour point's TRUE distance
//! to that surface is measured (closest point, seeded at the point's curve parameter), which
//! is what the report calls the surface error.

use std::collections::HashSet;
use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};
use rayon::prelude::*;

use super::s6_fitting::{describe, FittedRegion};
use super::{Control, StageStats};
use crate::bspline::skinning::{skin_ends, SkinEnd};
use crate::bspline::surface::SkinnedSurface;
use crate::geometry::polygon::signed_area;
use crate::mesh::crossings::crossing_pairs;
use crate::mesh::{tessellate_each, undirected_key, EdgeKey, RowLoops, Triangle};
use crate::region::{CurveOrigin, Region, RegionCurve};
use crate::section::{dot, SliceFrame};
use crate::{Error, Result};

pub const STAGE: &str = "skinning";

/// Error statistics of a surface against its input contour points (mm).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    pub points: usize,
    pub max_mm: f64,
    pub mean_mm: f64,
    pub rms_mm: f64,
}

/// One output surface.
#[derive(Clone, Debug)]
pub struct Surface {
    pub region: Region,
    pub surface: SkinnedSurface,
    /// Distances of the input contour points to the surface.
    pub error: ErrorStats,
    /// Largest curve-fitting error over all curves of the region (intermediate ones too).
    pub curve_fit_max_mm: f64,
    pub tolerance_met: bool,
}

/// The surface through a region's fitted curves, with the end conditions its end curves ask
/// for (a cap, a branching seam, or free).
pub fn skin(fitted: &FittedRegion) -> Result<SkinnedSurface> {
    let FittedRegion { region, fit } = fitted;
    let end = |c: Option<&RegionCurve>| match c.map(|c| c.origin) {
        Some(CurveOrigin::Cap { .. }) => SkinEnd::Cap,
        Some(CurveOrigin::Intermediate { .. }) => SkinEnd::Seam,
        _ => SkinEnd::Free,
    };
    let ends = [end(region.curves.first()), end(region.curves.last())];
    skin_ends(&fit.curves, ends).map_err(|e| Error::Kernel {
        stage: STAGE,
        context: describe(region),
        source: e,
    })
}

/// Chordal tolerance, in fitting tolerances, of the mesh a choice between surfaces is judged
/// on (a lobe's walk in stage 5, a fanning join in stage 6): the one the README's crossing
/// counts are measured at, fixed so that the surfaces do not depend on the output's
/// `--chordal`.
const JUDGE_CHORDAL: f64 = 0.4;

/// What a choice between surfaces is judged by, in the mesh of the surface(s) at
/// [`JUDGE_CHORDAL`] fitting tolerances: `own`, the faces crossing another face of it
/// ([`crossing_pairs`]); `fence`, the faces crossing the fence on a cap's ridge loop
/// ([`cap_fence`]) or on a chain shared with a sibling ([`chain_fence`]), where the surface
/// beyond the loop would be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crossings {
    pub own: usize,
    pub fence: usize,
}

impl Crossings {
    /// A surface that cannot be skinned: worse than any.
    pub const UNFIT: Crossings = Crossings {
        own: usize::MAX,
        fence: usize::MAX,
    };

    pub fn total(&self) -> usize {
        self.own.saturating_add(self.fence)
    }

    /// Whether this is better than `other`: fewer faces crossing their own surface, or as
    /// many and fewer crossing a fence. A fence only says where another surface may be, so
    /// it never buys a fold of the surface itself (judged on the sum, the abdomen's crossing
    /// faces rose 703 → 768: segments cut for a fence folded).
    pub fn fewer_than(&self, other: &Crossings) -> bool {
        (self.own, self.fence) < (other.own, other.fence)
    }
}

/// [`Crossings`] of the surface through `fitted`'s curves; [`Crossings::UNFIT`] if it cannot
/// be skinned.
pub fn crossings_of(fitted: &FittedRegion, tolerance: f64) -> Crossings {
    crossings_of_all(std::slice::from_ref(fitted), tolerance)
}

/// [`crossings_of`] for the meshes of several surfaces together (the segments of one
/// region, which share the curves where they meet): faces crossing a face of any of them.
pub fn crossings_of_all(fitted: &[FittedRegion], tolerance: f64) -> Crossings {
    let mut mesh = JudgedMesh::default();
    for f in fitted {
        if !mesh.add(f, tolerance) {
            return Crossings::UNFIT;
        }
    }
    mesh.crossing().1
}

/// The meshes a choice between surfaces is judged on, at [`JUDGE_CHORDAL`] fitting
/// tolerances, and the fences on their caps' ridge loops.
#[derive(Default)]
struct JudgedMesh {
    faces: Vec<Triangle>,
    fences: Vec<Triangle>,
}

impl JudgedMesh {
    /// Adds `fitted`'s mesh and fences; false if the surface cannot be skinned.
    fn add(&mut self, fitted: &FittedRegion, tolerance: f64) -> bool {
        let Ok(surface) = skin(fitted) else {
            return false;
        };
        let c = &fitted.region.curves;
        let (bottom, top) = (&c[0].points, &c[c.len() - 1].points);
        let chordal = JUDGE_CHORDAL * tolerance;
        tessellate_each(&surface, bottom, top, chordal, RowLoops::Keep, |t| {
            self.faces.push(t)
        });
        for (end, next) in [(0, 1), (c.len() - 1, c.len().saturating_sub(2))] {
            if end == next {
                continue;
            }
            match c[end].origin {
                CurveOrigin::Cap { .. } => {
                    self.fences
                        .extend(cap_fence(&c[end].points, &c[next].points));
                }
                CurveOrigin::Intermediate { .. } => self.fences.extend(chain_fence(
                    &c[end].points,
                    &fitted.region.shared_edges,
                    &c[next].points,
                )),
                _ => {}
            }
        }
        true
    }

    /// Per face of the surfaces, whether it crosses another face of them, or else (if none
    /// does) whether it crosses a fence; and the counts. The fences join the faces for the
    /// search and leave again, so the mesh is not copied.
    fn crossing(&mut self) -> (Vec<bool>, Crossings) {
        let n = self.faces.len();
        self.faces.extend_from_slice(&self.fences);
        let pairs = crossing_pairs(&self.faces);
        self.faces.truncate(n);
        let (mut own, mut fence) = (vec![false; n], vec![false; n]);
        for (i, j) in pairs {
            match (i < n, j < n) {
                (true, true) => (own[i], own[j]) = (true, true),
                (true, false) => fence[i] = true,
                (false, true) => fence[j] = true,
                (false, false) => {}
            }
        }
        let count = |v: &[bool]| v.iter().filter(|&&c| c).count();
        let crossings = Crossings {
            own: count(&own),
            fence: count(&fence),
        };
        (if crossings.own > 0 { own } else { fence }, crossings)
    }
}

/// How far up towards the next curve a cap loop's fence stands, in that curve's distance.
/// The skull's caps crossed within a tenth of it; at half (before the area test below),
/// the skull had 436 surfaces against 432 at a quarter, for the same 212 crossing faces.
const FENCE_HEIGHT: f64 = 0.25;

/// A cap loop enclosing less than this (mm²) is a ridge round a tree, not round holes.
/// Fenced too, such loops took the abdomen's wall time 9.9 → 12.6 s (fitting busy 9.0 →
/// 11.6 s, 289 → 296 surfaces), for the same 703 crossing faces.
const FENCE_MIN_AREA_MM2: f64 = 0.01;

/// A wall standing on a cap's ridge loop, towards the next curve, for [`JudgedMesh`]: on the
/// far side of a ridge loop lies the surface that closes onto it from there (a hole's, for
/// an outer contour's cap; the outer's, for a hole's), rising from the loop as this one
/// does, so a surface whose rulings leave the loop to the far side crosses it. Joined at
/// chord length, a ridge loop with long slits and the contour drift apart: the skull's
/// surface 1 ran across a corner of its ridge loop, through the cap of its hole (68 faces),
/// though it crossed nothing of its own. The wall shares the loop's vertices, so faces that
/// leave the loop to its own side do not count as crossing it. Nothing for a cap point, a
/// loop with no plane, or a ridge round a tree (no area: the surface is on both sides).
/// Not on intermediate contours, where siblings meet: there it cut the skull into 841
/// surfaces from 436, for 208 crossing faces from 212, at 2.6 times the time.
fn cap_fence(lp: &[[f64; 3]], next: &[[f64; 3]]) -> Vec<Triangle> {
    let (Some(frame), Some(q)) = (SliceFrame::of_loop(lp), next.first()) else {
        return Vec::new();
    };
    // A zero-width ridge loop (round a tree, no holes inside: a contour not star-shaped)
    // is this surface's on both sides; its folds count as its own.
    let flat: Vec<[f64; 2]> = lp.iter().map(|&p| frame.to_plane(p)).collect();
    if lp.len() < 3 || signed_area(&flat).abs() < FENCE_MIN_AREA_MM2 {
        return Vec::new();
    }
    wall(
        lp,
        &frame,
        FENCE_HEIGHT * (dot(*q, frame.normal()) - frame.height()),
        |_| true,
    )
}

/// Two triangles standing on each edge of the loop `lp` that `keep` takes, from the loop
/// (its own vertices) to `rise` along `frame`'s normal: a fence for [`JudgedMesh`].
fn wall(
    lp: &[[f64; 3]],
    frame: &SliceFrame,
    rise: f64,
    keep: impl Fn(&([f64; 3], [f64; 3])) -> bool,
) -> Vec<Triangle> {
    let n = frame.normal();
    let up = |p: &[f64; 3]| -> [f64; 3] { std::array::from_fn(|d| p[d] + rise * n[d]) };
    let m = lp.len();
    (0..m)
        .map(|i| (lp[i], lp[(i + 1) % m]))
        .filter(keep)
        .flat_map(|(a, b)| [[a, b, up(&b)], [a, up(&b), up(&a)]])
        .collect()
}

/// How far towards the next curve a fence on a shared chain stands, in that curve's
/// distance. Skull 49 and 52 crossed within the tenth of the band nearest the plane, 206 and
/// 208 (two slivers at slices 45–46) 29 % of the way up: at 0.1 the skull kept those 4
/// faces, at 0.35 none (at `--chordal 0.4`, our count), for 5 fewer control points there,
/// GE head 59 448 → 59 584 and abdomen 43 597 → 43 653 at the same crossing counts (1 185,
/// 217). At a quarter the skull kept them too (GE head 59 644, abdomen 43 997 then).
const CHAIN_FENCE_HEIGHT: f64 = 0.35;

/// A wall standing on the chains where an intermediate contour's loop meets a sibling's on
/// the same side of the plane (`shared`, see [`Region::shared_edges`]), towards the next
/// curve, as [`cap_fence`] stands on a ridge loop: beyond such a chain lies the sibling's
/// surface, closing onto it from its side as this one does from this, so a surface whose
/// rows cut across the chain below the plane crosses it. Skull surfaces 49 and 52 at slice
/// 12 (a band and a capped sliver, each fitted alone, neither crossing itself) crossed each
/// other in 15 faces: where the chain has a knee, the band's rulings, joining its contour's
/// corner to a corner of the loop 2 mm along, cut inside the knee just below the plane.
/// Only the shared chains: elsewhere the loop goes on into the surface beyond the plane (a
/// fence on the whole loop cut the skull into 841 surfaces from 436, see [`cap_fence`]).
fn chain_fence(lp: &[[f64; 3]], shared: &[[[f64; 3]; 2]], next: &[[f64; 3]]) -> Vec<Triangle> {
    // Most regions share no chain: no plane to fit for them, on every judgement.
    if shared.is_empty() || lp.len() < 3 {
        return Vec::new();
    }
    let (Some(frame), Some(q)) = (SliceFrame::of_loop(lp), next.first()) else {
        return Vec::new();
    };
    let chains: HashSet<EdgeKey> = shared.iter().map(|[a, b]| undirected_key(a, b)).collect();
    let rise = CHAIN_FENCE_HEIGHT * (dot(*q, frame.normal()) - frame.height());
    wall(lp, &frame, rise, |(a, b)| {
        chains.contains(&undirected_key(a, b))
    })
}

/// Faces of the surface through `fitted`'s curves crossing another, or if none does, a
/// fence ([`JudgedMesh::crossing`]: a fold comes first, as in [`Crossings::fewer_than`]; the
/// abdomen's crossing faces rose 703 → 715 with joins cut and fanned for either), per band
/// between consecutive curves (`curves − 1` of them), each counted in the band its
/// centroid's height lies in (all curves lie in parallel planes; faces beyond an end curve
/// count in the end band); and the [`Crossings`] in all.
/// `None` if the surface cannot be skinned or its curves have no plane.
pub fn crossing_bands(fitted: &FittedRegion, tolerance: f64) -> Option<(Vec<usize>, Crossings)> {
    let curves = &fitted.region.curves;
    let frame = fitted.region.plane_frame()?;
    let normal = frame.normal();
    let height = |p: &[f64; 3]| dot(*p, normal);
    let heights: Vec<f64> = curves
        .iter()
        .map(|c| c.points.first().map_or(f64::NAN, height))
        .collect();
    let mut mesh = JudgedMesh::default();
    if !mesh.add(fitted, tolerance) {
        return None;
    }
    let (crossing, crossings) = mesh.crossing();
    let bands = heights.len().saturating_sub(1).max(1);
    let rising = heights[heights.len() - 1] >= heights[0];
    let mut counts = vec![0usize; bands];
    for (t, _) in mesh.faces.iter().zip(&crossing).filter(|(_, &c)| c) {
        let centroid: [f64; 3] = std::array::from_fn(|d| (t[0][d] + t[1][d] + t[2][d]) / 3.0);
        let h = height(&centroid);
        // The first band whose upper curve lies beyond the face.
        let k = (1..heights.len())
            .position(|k| {
                if rising {
                    h <= heights[k]
                } else {
                    h >= heights[k]
                }
            })
            .unwrap_or(bands - 1);
        counts[k.min(bands - 1)] += 1;
    }
    Some((counts, crossings))
}

pub fn skin_region(fitted: FittedRegion, tolerance: f64) -> Result<Surface> {
    let surface = skin(&fitted)?;
    let FittedRegion { region, fit } = fitted;
    let v_bar = surface.v_bar();
    let mut dists: Vec<f64> = Vec::new();
    for (k, c) in region.curves.iter().enumerate() {
        if !matches!(c.origin, CurveOrigin::Contour { .. }) {
            continue;
        }
        let d: Vec<f64> = fit.points[k]
            .par_iter()
            .zip(&fit.params[k])
            .map(|(p, &u)| surface.closest_point_hint(p, u, v_bar[k]).0)
            .collect();
        dists.extend(d);
    }
    let n = dists.len().max(1) as f64;
    let error = ErrorStats {
        points: dists.len(),
        max_mm: dists.iter().copied().fold(0.0, f64::max),
        mean_mm: dists.iter().sum::<f64>() / n,
        rms_mm: (dists.iter().map(|d| d * d).sum::<f64>() / n).sqrt(),
    };
    let curve_fit_max_mm = fit.max_errors.iter().copied().fold(0.0, f64::max);
    tracing::debug!(
        "{}: {}×{} control points, {} input points, max error {:.4} mm",
        describe(&region),
        surface.n_u(),
        surface.n_v(),
        error.points,
        error.max_mm
    );
    Ok(Surface {
        tolerance_met: error.max_mm <= tolerance && fit.met,
        region,
        surface,
        error,
        curve_fit_max_mm,
    })
}

pub fn run(
    input: Receiver<FittedRegion>,
    tolerance: f64,
    out: Sender<Surface>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    for fitted in input.iter() {
        ctl.check()?;
        let t = Instant::now();
        let s = skin_region(fitted, tolerance)?;
        stats.busy += t.elapsed();
        stats.items += 1;
        if out.send(s).is_err() {
            break;
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 mm square loop at height `z`, counter-clockwise.
    fn square(z: f64) -> Vec<[f64; 3]> {
        vec![
            [0.0, 0.0, z],
            [10.0, 0.0, z],
            [10.0, 10.0, z],
            [0.0, 10.0, z],
        ]
    }

    #[test]
    fn a_face_leaving_a_cap_loop_to_its_far_side_crosses_the_fence() {
        for (z, next) in [(0.0, 1.0), (5.0, 4.0)] {
            let lp = square(z);
            let fence = cap_fence(&lp, &square(next));
            assert_eq!(fence.len(), 8);
            // The wall stands on the loop, part of the way to the next curve.
            let top = fence.iter().flatten().map(|p| p[2]).fold(z, |a, h| {
                if (h - z).abs() > (a - z).abs() {
                    h
                } else {
                    a
                }
            });
            assert!(
                (top - (z + FENCE_HEIGHT * (next - z))).abs() < 1e-12,
                "{top}"
            );
            let rise = 0.1 * (next - z);
            // From the loop's edge outwards, rising: a neighbour of the wall, not a crossing.
            let out = [lp[0], lp[1], [5.0, -3.0, z + rise]];
            // From outside the loop in across its edge, a tenth of the way up.
            let across = [
                [4.0, -3.0, z + rise],
                [6.0, -3.0, z + rise],
                [5.0, 3.0, z + rise],
            ];
            // Inside the loop, clear of the wall.
            let inside = [
                [4.0, 3.0, z + rise],
                [6.0, 3.0, z + rise],
                [5.0, 6.0, z + rise],
            ];
            let mut mesh = JudgedMesh {
                faces: vec![out, across, inside],
                fences: fence,
            };
            let (crossing, counts) = mesh.crossing();
            assert_eq!(crossing, [false, true, false]);
            assert_eq!(counts, Crossings { own: 0, fence: 1 });
        }
    }

    #[test]
    fn a_fence_stands_on_the_shared_chain_only() {
        // Two lower pieces of one intermediate contour at z = 1 meet along x = 10: the left
        // square's right side, which the right piece runs the other way.
        let lp = square(1.0);
        let shared = [[lp[2], lp[1]]];
        let fence = chain_fence(&lp, &shared, &square(0.0));
        assert_eq!(fence.len(), 2);
        for t in &fence {
            for p in t {
                assert_eq!(p[0], 10.0);
                assert!((0.0..=10.0).contains(&p[1]));
                assert!(p[2] == 1.0 || (p[2] - (1.0 - CHAIN_FENCE_HEIGHT)).abs() < 1e-12);
            }
        }
        let rise = -0.05;
        // Just below the plane: a face cutting across the chain into the sibling's piece; one
        // that stays inside this piece; one from the chain outwards, a neighbour of the wall.
        let h = 1.0 + rise;
        let across = [[9.5, 4.0, h], [10.5, 5.0, h], [9.5, 6.0, h]];
        let inside = [[9.5, 4.0, h], [9.8, 5.0, h], [9.5, 6.0, h]];
        let out = [lp[1], lp[2], [10.5, 5.0, h]];
        // Under an edge that is not shared: the loop goes on into the surface above.
        let under_free = [[4.0, -0.5, h], [6.0, -0.5, h], [5.0, 0.5, h]];
        let mut mesh = JudgedMesh {
            faces: vec![across, inside, out, under_free],
            fences: fence,
        };
        let (crossing, counts) = mesh.crossing();
        assert_eq!(crossing, [true, false, false, false]);
        assert_eq!(counts, Crossings { own: 0, fence: 1 });
        assert!(chain_fence(&lp, &[], &square(0.0)).is_empty());
    }

    #[test]
    fn a_ridge_round_a_tree_has_no_fence() {
        // Out along two branches and back: zero width, zero area.
        let ridge = vec![
            [0.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [5.0, 4.0, 0.0],
            [5.0, 0.0, 0.0],
            [9.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
        ];
        assert!(cap_fence(&ridge, &square(1.0)).is_empty());
        assert!(cap_fence(&ridge[..1], &square(1.0)).is_empty());
    }

    #[test]
    fn a_fold_outweighs_any_number_of_fence_crossings() {
        let c = |own, fence| Crossings { own, fence };
        assert!(c(0, 90).fewer_than(&c(1, 0)));
        assert!(c(2, 3).fewer_than(&c(2, 4)));
        assert!(!c(2, 4).fewer_than(&c(2, 4)));
        assert!(!c(3, 0).fewer_than(&c(2, 9)));
        assert!(c(5, 5).fewer_than(&Crossings::UNFIT));
        // Two faces of the surface through each other: both count as its own.
        let fold = [
            [[0.0, 0.0, -1.0], [2.0, 0.0, 1.0], [0.0, 2.0, 1.0]],
            [[-1.0, 0.5, 0.0], [3.0, 0.5, 0.0], [0.5, 3.0, 0.0]],
        ];
        let mut mesh = JudgedMesh {
            faces: fold.to_vec(),
            fences: Vec::new(),
        };
        assert_eq!(mesh.crossing(), (vec![true, true], c(2, 0)));
    }
}
