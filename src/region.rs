//! Single-branching regions (METHOD.md §3, end): after correspondence and branching, every
//! surface is a chain of closed curves linked 1-to-1, from bottom to top. Each curve is an
//! original contour, an intermediate contour on a mid-plane, a cap (a single point, or a
//! ridge loop when an annulus closes), or a keyhole (a contour and holes joined by slits
//! where a bay closes into a hole). Points are 3-D patient mm.
//!
//! Invariants: a region has at least two curves; all its loops have the same orientation seen
//! from the slice normal (counter-clockwise for outer walls, clockwise for hole walls); a
//! single-point curve can only be first or last.

use crate::mesh::Triangle;
use crate::section::{dot, SliceFrame};

/// Where one curve of a region comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CurveOrigin {
    /// An input contour: its points count towards the tolerance certificate.
    Contour { slice: usize, contour: usize },
    /// An intermediate contour of a branching problem, between two slices.
    Intermediate { below: usize, above: usize },
    /// Where a region closes off beyond its last contour (see `capping::cap_height`).
    Cap { slice: usize },
    /// A contour joined with some of its holes by slits (see `geometry::keyhole`): the
    /// contours' points count in the regions that start or end on them.
    Keyhole { slice: usize },
}

#[derive(Clone, Debug, PartialEq)]
pub struct RegionCurve {
    /// Closed loop (not repeated at the end), or a single point (degenerate curve).
    pub points: Vec<[f64; 3]>,
    pub origin: CurveOrigin,
}

impl CurveOrigin {
    /// The first and last slice the curve comes from.
    pub fn slices(&self) -> (usize, usize) {
        match *self {
            CurveOrigin::Contour { slice, .. }
            | CurveOrigin::Cap { slice }
            | CurveOrigin::Keyhole { slice } => (slice, slice),
            CurveOrigin::Intermediate { below, above } => (below, above),
        }
    }
}

impl RegionCurve {
    pub fn is_point(&self) -> bool {
        self.points.len() == 1
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    /// Emission order: deterministic for a given input.
    pub id: usize,
    /// The wall of a hole (a void inside the material) rather than an outer wall.
    pub hole: bool,
    pub curves: Vec<RegionCurve>,
    /// Flat triangles closing slivers that the loops of a branching or cap problem this
    /// region ends at leave uncovered (see [`crate::mesh::seal`]); written with its mesh.
    pub seal: Vec<[[f64; 3]; 3]>,
    /// Points the seal put on its end loops' edges, as `[a, b, x]`: `x` between `a` and `b`
    /// where two loops' edges cross (see [`crate::mesh::seal_problem`]). The mesh's end rows
    /// take them; the fitted curves do not.
    pub seal_points: Vec<[[f64; 3]; 3]>,
    /// Edges of its end loops that a neighbouring region's loop on the same side of the plane
    /// runs the other way (see [`crate::mesh::shared_edges`]), either way round: stage 6
    /// fences them when it judges the surface, so rulings that leave them to the neighbour's
    /// side count as crossings.
    pub shared_edges: Vec<[[f64; 3]; 2]>,
    /// The first curve is the contour where the previous segment of the same chain ended
    /// (a long chain is split, see `RunConfig::max_curves`): its points count there.
    pub joint_below: bool,
    /// Points inserted into its first and its last contour curve (where keyhole slits meet
    /// them, see `geometry::keyhole::with_feet`, and spurs, see `geometry::spur`): on the
    /// contours, but not input points.
    pub inserted: [usize; 2],
}

impl Region {
    /// The region cut at the curves `joints` (indices, ascending, strictly between its
    /// first and last) into segments that each run from one joint to the next, the joint
    /// curve in both, as a long chain's segments are (`RunConfig::max_curves`): each
    /// segment after the first has `joint_below`. All keep the region's id; the first keeps
    /// the insertions into its first curve and the seal triangles in that curve's plane,
    /// the last the others.
    pub fn split_at(&self, joints: &[usize]) -> Vec<Region> {
        let n = self.curves.len();
        let mut cuts: Vec<usize> = joints
            .iter()
            .copied()
            .filter(|&k| k > 0 && k + 1 < n)
            .collect();
        cuts.sort_unstable();
        cuts.dedup();
        if cuts.is_empty() {
            return vec![self.clone()];
        }
        let bounds: Vec<usize> = std::iter::once(0)
            .chain(cuts)
            .chain(std::iter::once(n.saturating_sub(1)))
            .collect();
        let last = bounds.len() - 2;
        let (seal_bottom, seal_top) = self.seal_by_end();
        bounds
            .windows(2)
            .enumerate()
            .map(|(i, w)| Region {
                id: self.id,
                hole: self.hole,
                curves: self.curves[w[0]..=w[1]].to_vec(),
                seal: [
                    if i == 0 { seal_bottom.as_slice() } else { &[] },
                    if i == last { seal_top.as_slice() } else { &[] },
                ]
                .concat(),
                seal_points: self.seal_points.clone(),
                shared_edges: self.shared_edges.clone(),
                joint_below: if i == 0 { self.joint_below } else { true },
                inserted: [
                    if i == 0 { self.inserted[0] } else { 0 },
                    if i == last { self.inserted[1] } else { 0 },
                ],
            })
            .collect()
    }

    /// The plane frame of the region's first loop (all its curves lie in parallel planes);
    /// `None` if no curve is a loop of some area.
    pub fn plane_frame(&self) -> Option<SliceFrame> {
        self.curves
            .iter()
            .find(|c| c.points.len() >= 3)
            .and_then(|c| SliceFrame::of_loop(&c.points))
    }

    /// The seal triangles nearer the plane of the first curve, and the others (all in the
    /// first if the region has no loop to take a plane from): a seal lies in the plane of
    /// the end loops whose slivers it closes.
    fn seal_by_end(&self) -> (Vec<Triangle>, Vec<Triangle>) {
        let frame = self.plane_frame();
        let (Some(frame), Some(first), Some(end)) = (
            frame,
            self.curves.first().and_then(|c| c.points.first()),
            self.curves.last().and_then(|c| c.points.first()),
        ) else {
            return (self.seal.clone(), Vec::new());
        };
        let normal = frame.normal();
        let height = |p: &[f64; 3]| dot(*p, normal);
        let (h0, h1) = (height(first), height(end));
        self.seal.iter().copied().partition(|t| {
            let c: [f64; 3] = std::array::from_fn(|d| (t[0][d] + t[1][d] + t[2][d]) / 3.0);
            (height(&c) - h0).abs() <= (height(&c) - h1).abs()
        })
    }

    /// Number of input contour points (the paper's "data" side of the reduction ratio).
    pub fn input_points(&self) -> usize {
        self.curves
            .iter()
            .skip(self.joint_below as usize)
            .filter(|c| matches!(c.origin, CurveOrigin::Contour { .. }))
            .map(|c| c.points.len())
            .sum::<usize>()
            .saturating_sub(self.inserted[0] + self.inserted[1])
    }
}
