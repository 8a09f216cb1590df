//! Intermediate contours of an m-to-n branching problem (METHOD.md §3, paper §2.2).
//!
//! In: the m lower contours (section A1, height z1) and the n upper contours (section A2,
//! z2), filled, counter-clockwise, pairwise disjoint within a section, all in one plane frame
//! (mm); and the raster cell (mm, e.g. a fifth of the fitting tolerance). Out: one
//! intermediate contour per input contour on an intermediate plane, lower contours first,
//! each a counter-clockwise loop, simple but for the slits of bridges (see below), or, when
//! degenerate, a point; the plane's position
//! `t` (fraction of the way from z1 to z2); plus warnings.
//!
//! The construction, in the paper's terms, with distance maps computed exactly:
//! - the A1/A2 bisecting edges are the zero set of `φ_t = (1 − t)·d_A1 + t·d_A2` (signed
//!   distances, negative inside): the intermediate section `M_t = {φ_t ≤ 0}` is the
//!   shape-based interpolation of the two sections at `z1 + t·(z2 − z1)`. The paper uses the
//!   mid-plane, `t = ½`;
//! - the zone of lower contour `i` is `{ψ_i ≤ 0}` with `ψ_i = d_i − min_{j≠i} d_j` over the
//!   lower contours (its boundary is the bisecting edges between colours of A1); likewise
//!   for the upper contours among themselves;
//! - the intermediate contour of lower contour `i` is the boundary of `M_t ∩ zone_i`,
//!   extracted by marching squares on `min(−φ_t, −ψ_i) ≥ 0`. So the lower intermediate
//!   contours tile `M_t`, the upper ones tile the same `M_t`, and neighbours share their
//!   bisecting edges (paper Fig. 4: c21's contour is `{e1, e2, e7, e6}`).
//!
//! Choosing the plane (beyond the paper): when a lower contour splits between the sections
//! below the mid-plane (a long band under two blobs far apart; the bottom of a standing
//! torus), its zone meets `M_½` in several pieces and one intermediate contour cannot bound
//! them. `M_t` moves towards A1 as `t → 0`, and there a single lower contour's zone meets it
//! in one piece. So: try `t = ½`; if some lower zone meets `M_t` in several pieces, try the
//! `t` of [`T_TOWARDS_LOWER`] in turn (0.35, 0.25, 0.15, 0.08); if some upper zone does, the
//! same towards 1 (`1 − t`); stop at the first `t` where no zone of either side is split. If
//! both sides split at `t = ½`, or no `t` tried mends it, the `t` with the least discarded
//! area is kept (a `t` at which a zone misses `M_t` altogether is never preferred) and a
//! warning says so; a note instead where the bridges then join every piece. But a plane
//! moved nearer a section than [`NEAR_SECTION_T`] (0.15, 0.08) leaves a band a sixth of a
//! slice high or less between the intermediate contour and the contour beside it, which
//! folds more often than a wall rising from a slit: where bridges (see [`super::bridges`])
//! join every piece of the split zones at `t = ½`, dropping nothing, `t = ½` is kept after
//! all (skull at `--chordal 0.4`: 3 580 crossing faces against 4 101; doing so for every
//! moved plane, 3 781, and a phantom's window got a wall hanging 2.5 mm into it).
//! The caller lifts the intermediate contours to `z1 + t·(z2 − z1)`.
//! The distance fields do not depend on `t`: only `φ_t` and the zone loops are recomputed.
//!
//! Cost: the distance fields are made exact (foot-point walk and sweeps) only where the output
//! reads their values, where `∂M_t` can pass for some `t` (not deep inside both sections nor
//! far outside both) and around the zone boundaries; elsewhere the seed distances give the
//! signs (see `exact_band`). Each zone is extracted in the window of the samples where it can
//! be inside, and a plane position whose mended side alone already discards as much as the
//! best so far is not extracted further.
//!
//! Making the shared edges identical, not just close:
//! - a sample on the `i`/`j` bisector has `ψ_i = −ψ_j` bit for bit (both come from the same
//!   nearest-two distances), and an exact tie is given to one side only;
//! - every crossing is recomputed from the field that really crosses its grid edge (marching
//!   squares on a minimum would interpolate between the two fields near a junction), so both
//!   sections' loops put the same point on `∂M` and both neighbours the same point on their
//!   bisecting edge;
//! - the corner where a bisecting edge meets `∂M` is put back (marching squares on the
//!   minimum cuts it, across several cells where the two meet at a shallow angle): both zero
//!   curves are followed cell by cell to the cell where they meet, the corner is solved there,
//!   and both neighbours and the other section insert the same points;
//! - loops are compressed (Douglas–Peucker within [`SIMPLIFY_TOL_CELLS`] = ¼ cell) run by run,
//!   where a run is a chain of points owned by the same set of loops, so a shared chain is
//!   compressed to the same points in every loop that owns it.
//!
//! In the tests every `∂M` vertex of one section's loops is a vertex of the other section's
//! (1-to-2, 2-to-2, 1-to-3, 3-to-1), and over random star problems 190 of 191 are exact, the
//! other within 0.06 cell (a corner whose tracing gave up: a saddle or more than 6 cells).
//!
//! Degenerate cases (paper §2.2 "degeneracy"), each reported in `warnings` (a split zone in
//! `notes` where bridges join every piece, so nothing is lost):
//! - `M_t ∩ zone_i` in several pieces at the `t` kept (see above): beyond the paper, the
//!   pieces are joined into one loop by zero-width bridges through contour `i`'s footprint
//!   outside `M_t` ([`super::bridges`]), so each piece stays covered from both sections.
//!   Pieces below `MIN_PIECE_CELLS` or that no bridge reaches are dropped (no intermediate
//!   contour of that section covers them; the mesh seals them flat);
//! - a piece with holes (possible when `M_t` itself is annular): the holes are returned
//!   beside the loop (`lower_holes`, `upper_holes`); those below `MIN_PIECE_CELLS` are
//!   dropped;
//! - `M_t ∩ zone_i` empty (the contour overlaps nothing, or only below the raster
//!   resolution): a point intermediate contour at the sample of `M` nearest to contour `i`;
//! - `M_t` empty (no contour overlaps any other): every contour gets the point of largest
//!   distance inside it (its cap, as the paper does for degeneracy);
//! - a raster over [`MAX_RASTER_CELLS`] samples: the cell is coarsened to fit;
//! - contours of one section that overlap each other (the construction assumes disjoint
//!   contours, as a compiled slice's outer boundaries are): a warning, and the result treats
//!   the section as the nearest contour's signed distance, which is not the union's there.
//!
//! Invariants: deterministic (no hash-map order reaches the output; rayon only maps
//! independent items in order), no panics on bad input (errors instead).

use rayon::prelude::*;

use super::bridges::join_pieces;
use super::distance_map::{
    bbox_of, mark_label_band, nearest_contours_within, signed_distance, validate_polygons, Grid,
    NearestContours, SeedField,
};
use super::marching_squares::iso_loops;
use super::overlap::{overlap_area, Region};
use super::polygon::{contains, signed_area, Point};
use super::simplify::simplify_closed;
use super::zones::{
    insert_junctions, largest_loop, neg_psi, refine_innermost, simplify_shared, zone_loops, Window,
};
use super::GeometryError;

/// Largest raster used (samples). Peak memory is about 100 bytes per sample (two sections'
/// distance transforms at once plus their nearest-contour fields), so 8 M samples ≈ 800 MB.
pub const MAX_RASTER_CELLS: usize = 8 << 20;

/// Samples of empty border around the contours' bounding box.
const MARGIN_CELLS: usize = 3;

/// Pieces of a split zone smaller than this (cells², 2.56 mm² at the skull's 0.1 mm cells) are
/// dropped (their lids sealed flat) rather than bridged: the fitted curve would pass a smaller
/// excursion by within the tolerance, and a mesh zipped along a slit it does not follow folds.
const MIN_PIECE_CELLS: f64 = 256.0;

/// Compression tolerance of the output loops, in cells.
pub const SIMPLIFY_TOL_CELLS: f64 = 0.25;

/// A contour on the intermediate plane: a loop, or a single point when degenerate (a closed
/// B-spline with all control points equal).
#[derive(Clone, Debug, PartialEq)]
pub enum Intermediate {
    Loop(Vec<Point>),
    Point(Point),
}

/// One intermediate contour per input contour, in input order.
#[derive(Clone, Debug, PartialEq)]
pub struct IntermediateContours {
    /// Where the intermediate plane lies: the fraction of the way from the lower section to
    /// the upper one (0.5, the paper's mid-plane, unless a zone splits there).
    pub t: f64,
    pub lower: Vec<Intermediate>,
    pub upper: Vec<Intermediate>,
    /// The holes of each lower (upper) contour's loop: where `M_t` itself has holes (a bay
    /// closing, a window between branches), clockwise loops inside it, compressed with the
    /// other loops so both sides' holes share their points; the caller joins or skins them.
    pub lower_holes: Vec<Vec<Vec<Point>>>,
    pub upper_holes: Vec<Vec<Vec<Point>>>,
    pub warnings: Vec<String>,
    /// What the construction did that a user may want to know but need not act on: a split
    /// zone whose pieces bridges joined whole, dropping nothing.
    pub notes: Vec<String>,
}

/// A raster covering the polygons, coarsened (with a warning) if the requested cell would
/// exceed the cap.
pub(crate) fn raster_for(
    polys: &[&[Point]],
    cell_mm: f64,
    warnings: &mut Vec<String>,
) -> Result<Grid, GeometryError> {
    let bb = bbox_of(polys);
    let mut cell = cell_mm;
    for _ in 0..8 {
        match Grid::covering(bb, cell, MARGIN_CELLS, MAX_RASTER_CELLS) {
            Ok(g) => {
                if cell != cell_mm {
                    warnings.push(format!(
                        "raster cell coarsened from {cell_mm} mm to {cell:.6} mm to stay within \
                         {MAX_RASTER_CELLS} samples"
                    ));
                }
                return Ok(g);
            }
            Err(GeometryError::RasterTooLarge(_)) => {
                let m = 2.0 * MARGIN_CELLS as f64 + 1.0;
                let cells = ((bb[2] - bb[0]) / cell + m) * ((bb[3] - bb[1]) / cell + m);
                cell *= (cells / MAX_RASTER_CELLS as f64).sqrt().max(1.01) * 1.01;
            }
            Err(e) => return Err(e),
        }
    }
    Err(GeometryError::RasterTooLarge(format!(
        "could not fit the bounding box {bb:?} in {MAX_RASTER_CELLS} samples"
    )))
}

/// The point of largest distance inside a filled contour (its cap point).
pub(crate) fn innermost_point(grid: &Grid, contour: &[Point]) -> Point {
    let sd = signed_distance(grid, &[contour]);
    let best = (0..sd.len()).fold(0, |b, k| if sd[k] < sd[b] { k } else { b });
    let start = grid.point(best / grid.width, best % grid.width);
    refine_innermost(&[contour], start, grid.cell_mm)
}

/// Pieces of `M_½` besides the largest, in all, that [`halfway_loop`] drops: a fraction of the
/// largest piece's area.
const HALFWAY_DROPPED_FRACTION: f64 = 0.1;

/// The intermediate contour of a 1-to-1 link at its mid-plane: the outer boundary of the
/// largest piece of `M_½ = {d_a + d_b ≤ 0}` (the paper's construction with one contour a
/// side, so no zones), counter-clockwise, compressed within [`SIMPLIFY_TOL_CELLS`]. Holes of
/// `M_½` are filled: a fjord of one loop that closes into a hole there shuts at the
/// mid-plane, and the fjord of the other loop opens above it, rather than one fjord's walls
/// sweeping round to the other's. `None` if the other pieces of `M_½` together exceed
/// [`HALFWAY_DROPPED_FRACTION`] of the largest (the loops then need a branching, not a curve
/// between them), if `M_½` is empty, if the loops are not finite polygons or if the raster
/// would exceed [`MAX_RASTER_CELLS`]. Both loops are filled whatever their orientation.
pub fn halfway_loop(a: &[Point], b: &[Point], cell_mm: f64) -> Option<Vec<Point>> {
    validate_polygons(&[a, b], "halfway loop").ok()?;
    let grid = Grid::covering(bbox_of(&[a, b]), cell_mm, MARGIN_CELLS, MAX_RASTER_CELLS).ok()?;
    let (da, db) = (signed_distance(&grid, &[a]), signed_distance(&grid, &[b]));
    // Inside is `≥ 0` for marching squares: the negated sum.
    let field: Vec<f32> = da.iter().zip(&db).map(|(x, y)| -(x + y)).collect();
    let loops = iso_loops(&field, grid.width, grid.height, 0.0);
    let areas: Vec<f64> = loops.iter().map(|l| signed_area(l)).collect();
    // The first of the largest (`min_by` keeps the first of equals): loops come in scan
    // order, so ties are deterministic.
    let largest = (0..loops.len())
        .filter(|&k| areas[k] > 0.0)
        .min_by(|&i, &j| areas[j].total_cmp(&areas[i]))?;
    let others: f64 = (0..loops.len())
        .filter(|&k| k != largest && areas[k] > 0.0)
        .map(|k| areas[k])
        .sum();
    if others > HALFWAY_DROPPED_FRACTION * areas[largest] {
        return None;
    }
    let world: Vec<Point> = loops[largest].iter().map(|&p| grid.to_world(p)).collect();
    let out = simplify_closed(&world, SIMPLIFY_TOL_CELLS * grid.cell_mm);
    (out.len() >= 3 && signed_area(&out) > 0.0).then_some(out)
}

/// Positions of the intermediate plane tried when a lower zone meets `M_t` in several pieces
/// (fractions of the way from the lower section to the upper one; an upper zone uses
/// `1 − t`), in order after the paper's `t = 0.5`.
pub const T_TOWARDS_LOWER: [f64; 4] = [0.35, 0.25, 0.15, 0.08];

/// A plane this near a section (a fraction of the slice distance: the last two of
/// [`T_TOWARDS_LOWER`]) gives way to `t = ½` where bridges join the split zones whole there.
pub const NEAR_SECTION_T: f64 = 0.2;

/// Intermediate contours of the m-to-n problem between `lower` (A1) and `upper` (A2), on a
/// raster of `cell_mm` (coarsened with a warning past [`MAX_RASTER_CELLS`]), on the plane
/// chosen by the rule of the module docs (`t = 0.5` unless a zone splits there that bridges do
/// not join whole). Holes are not part of a section here: a caller branching holes among
/// themselves passes them reversed (as filled counter-clockwise contours).
///
/// Errors: an empty section ([`GeometryError::Empty`]), a contour with fewer than 3 points
/// ([`GeometryError::Degenerate`]), a non-finite coordinate ([`GeometryError::NonFinite`]), a
/// cell that is not a positive number ([`GeometryError::InvalidParameter`]).
pub fn intermediate_contours(
    lower: &[&[Point]],
    upper: &[&[Point]],
    cell_mm: f64,
) -> Result<IntermediateContours, GeometryError> {
    intermediate_contours_with(lower, upper, cell_mm, None)
}

/// [`intermediate_contours`] on the plane at the fraction `t` (in `(0, 1)`) of the way from
/// the lower section to the upper one, whatever the pieces: the construction with
/// `φ_t = (1 − t)·d_A1 + t·d_A2` in place of `φ_M`. A `t` outside `(0, 1)` is an
/// [`GeometryError::InvalidParameter`].
pub fn intermediate_contours_at(
    lower: &[&[Point]],
    upper: &[&[Point]],
    cell_mm: f64,
    t: f64,
) -> Result<IntermediateContours, GeometryError> {
    if !(t > 0.0 && t < 1.0) {
        return Err(GeometryError::InvalidParameter(format!(
            "the intermediate plane must lie strictly between the sections, got t = {t}"
        )));
    }
    intermediate_contours_with(lower, upper, cell_mm, Some(t))
}

/// Margin (cells) around the zero sets within which the distance fields are made exact:
/// the seed distances elsewhere exceed the true ones by less than 2.5 cells, so beyond this
/// margin their sign, and that of any `φ_t`, is certain one cell further on as well.
pub(crate) const EXACT_MARGIN_CELLS: f64 = 5.0;

/// The samples where the fields must be exact: where `∂M_t` can pass for some `t` in (0, 1)
/// (not deeper than the margin inside both sections nor farther outside both: there every
/// `φ_t` keeps the sign of both), and around the zones' boundaries of either section. Away
/// from these, marching squares only needs signs, which the seed distances give (the inside
/// mask is exact and their error is below the margin). This is most of the raster on
/// consecutive CT slices, which overlap almost everywhere.
fn exact_band(grid: &Grid, lower: &SeedField, upper: &SeedField) -> Vec<bool> {
    let m = EXACT_MARGIN_CELLS * grid.cell_mm;
    let mut mask: Vec<bool> = (0..grid.len())
        .into_par_iter()
        .map(|k| {
            let (a, b) = (lower.signed(k), upper.signed(k));
            !((a > m && b > m) || (a < -m && b < -m))
        })
        .collect();
    mark_label_band(
        grid,
        &[lower, upper],
        EXACT_MARGIN_CELLS as usize,
        &mut mask,
    );
    mask
}

/// Which contour a zone belongs to: lower (`true`) or upper, and its index in its section.
type Job = (bool, usize);

/// All loops of `M_t ∩ zone`, the largest counter-clockwise one, how many counter-clockwise
/// loops there are and their total area (mm²).
type ZoneLoops = (Vec<Vec<Point>>, Option<usize>, usize, f64);

/// The zone loops of every contour for one position `t` of the intermediate plane.
struct Attempt {
    t: f64,
    /// `−φ_t` on the raster, non-negative on `M_t`.
    neg_phi: Vec<f32>,
    m_empty: bool,
    /// Per job: all loops of `M_t ∩ zone`, and the largest counter-clockwise one with the
    /// count of counter-clockwise loops and their total area.
    zones: Vec<ZoneLoops>,
    /// Whether some lower zone, some upper zone, meets `M_t` in several pieces.
    split: [bool; 2],
    /// Area of the pieces that would be dropped (all but the largest of each zone), mm².
    discarded: f64,
    /// Zones that miss `M_t` altogether.
    empty: usize,
}

/// The zone loops at `t`. With `prune = Some((side, bound))`, `None` when the zones of
/// `side` (lower when true) alone are split and discard at least `bound` mm².
fn attempt(
    grid: &Grid,
    near_lower: &NearestContours,
    near_upper: &NearestContours,
    jobs: &[Job],
    t: f64,
    prune: Option<(bool, f64)>,
) -> Option<Attempt> {
    let (wl, wu) = (1.0 - t, t);
    let neg_phi: Vec<f32> = near_lower
        .min1
        .par_iter()
        .zip(&near_upper.min1)
        .map(|(&a, &b)| (-(wl * a as f64 + wu * b as f64)) as f32)
        .collect();
    let m_empty = !neg_phi.iter().any(|&v| v >= 0.0);
    // Zone i is inside only where M_t is and i is the nearest contour of its section: each
    // zone's loops are extracted within the window of those samples, not the whole raster.
    let in_m = |k: usize| neg_phi[k] >= 0.0;
    let (win_lower, win_upper) = rayon::join(
        || {
            let count = jobs.iter().filter(|j| j.0).count();
            Window::per_label(grid, count, &in_m, &|k| near_lower.label1[k])
        },
        || {
            let count = jobs.iter().filter(|j| !j.0).count();
            Window::per_label(grid, count, &in_m, &|k| near_upper.label1[k])
        },
    );
    let extract = |ids: &[usize]| -> Vec<ZoneLoops> {
        ids.par_iter()
            .map(|&j| {
                let (is_lower, i) = jobs[j];
                let window = if is_lower { win_lower[i] } else { win_upper[i] };
                let Some(window) = window.filter(|_| !m_empty) else {
                    return (Vec::new(), None, 0, 0.0);
                };
                let near = if is_lower { near_lower } else { near_upper };
                // Rounded as the f32 field is, so every step sees what marching squares saw.
                let g = |k: usize| neg_phi[k] as f64;
                let n = |k: usize| neg_psi(near, i as u32, k) as f32 as f64;
                let loops = zone_loops(grid, &g, &n, Some(window));
                let (best, count, total) = largest_loop(&loops, true);
                (loops, best, count, total)
            })
            .collect()
    };
    // The side being mended first: when it alone already discards as much as the best plane
    // so far, this plane cannot be chosen and the other side is not worth extracting.
    let (first, rest): (Vec<usize>, Vec<usize>) =
        (0..jobs.len()).partition(|&j| prune.is_none_or(|(side, _)| jobs[j].0 == side));
    let mut zones: Vec<Option<ZoneLoops>> = (0..jobs.len()).map(|_| None).collect();
    for (&j, z) in first.iter().zip(extract(&first)) {
        zones[j] = Some(z);
    }
    if let Some((_, bound)) = prune {
        let (mut split, mut discarded) = (false, 0.0);
        for (loops, best, count, total) in zones.iter().flatten() {
            if let (Some(b), true) = (best, *count > 1) {
                split = true;
                discarded += total - signed_area(&loops[*b]);
            }
        }
        if split && discarded >= bound {
            return None;
        }
    }
    for (&j, z) in rest.iter().zip(extract(&rest)) {
        zones[j] = Some(z);
    }
    let zones: Vec<ZoneLoops> = zones.into_iter().flatten().collect();
    let mut split = [false; 2];
    let (mut discarded, mut empty) = (0.0, 0);
    for (&(is_lower, _), (loops, best, count, total)) in jobs.iter().zip(&zones) {
        match best {
            Some(b) if *count > 1 => {
                split[usize::from(!is_lower)] = true;
                discarded += total - signed_area(&loops[*b]);
            }
            Some(_) => {}
            None => empty += 1,
        }
    }
    Some(Attempt {
        t,
        neg_phi,
        m_empty,
        zones,
        split,
        discarded,
        empty,
    })
}

/// The construction, at `t` when given, else at the `t` the rule of the module docs picks.
fn intermediate_contours_with(
    lower: &[&[Point]],
    upper: &[&[Point]],
    cell_mm: f64,
    fixed_t: Option<f64>,
) -> Result<IntermediateContours, GeometryError> {
    if lower.is_empty() || upper.is_empty() {
        return Err(GeometryError::Empty(format!(
            "a branching problem needs contours on both sections, got {} lower and {} upper",
            lower.len(),
            upper.len()
        )));
    }
    validate_polygons(lower, "lower contour")?;
    validate_polygons(upper, "upper contour")?;
    let mut warnings = Vec::new();
    for (name, set) in [("lower", lower), ("upper", upper)] {
        for (i, c) in set.iter().enumerate() {
            if signed_area(c) <= 0.0 {
                warnings.push(format!(
                    "{name} contour {i} is not counter-clockwise (area {:.4} mm²); treated as \
                     filled anyway",
                    signed_area(c)
                ));
            }
        }
    }
    // The construction takes a section as the union of its contours and needs them disjoint
    // (the signed distance to the union is then the smallest of theirs).
    for (name, set) in [("lower", lower), ("upper", upper)] {
        for i in 0..set.len() {
            for j in i + 1..set.len() {
                let shared =
                    overlap_area(&Region::filled(set[i]), &Region::filled(set[j]), cell_mm);
                if shared > 0.0 {
                    warnings.push(format!(
                        "{name} contours {i} and {j} overlap ({shared:.4} mm²); the section is \
                         expected to consist of disjoint contours"
                    ));
                }
            }
        }
    }
    let all: Vec<&[Point]> = lower.iter().chain(upper.iter()).copied().collect();
    let grid = raster_for(&all, cell_mm, &mut warnings)?;

    // The distance fields do not depend on t: every attempt below reuses them. They are
    // exact only where the output can depend on their values (see `exact_band`).
    let (seed_lower, seed_upper) = rayon::join(
        || SeedField::new(&grid, lower, true),
        || SeedField::new(&grid, upper, true),
    );
    let exact = exact_band(&grid, &seed_lower, &seed_upper);
    let (near_lower, near_upper) = rayon::join(
        || nearest_contours_within(&grid, seed_lower, Some(&exact)),
        || nearest_contours_within(&grid, seed_upper, Some(&exact)),
    );
    let jobs: Vec<Job> = (0..lower.len())
        .map(|i| (true, i))
        .chain((0..upper.len()).map(|i| (false, i)))
        .collect();

    // Choose the plane. A lower zone that meets M_t in several pieces means that contour
    // splits between the sections below the plane: moving the plane towards A1 (t → 0)
    // brings M_t towards A1, where the zone meets it in one piece. Likewise upwards.
    // Without pruning an attempt always comes back.
    let Some(half) = attempt(
        &grid,
        &near_lower,
        &near_upper,
        &jobs,
        fixed_t.unwrap_or(0.5),
        None,
    ) else {
        return Err(GeometryError::Degenerate(
            "internal: the plane at t = 0.5 was pruned".to_string(),
        ));
    };
    let mut moved: Option<Attempt> = None;
    let mut move_warning = None;
    if fixed_t.is_none() && half.split[0] != half.split[1] {
        let towards_lower = half.split[0];
        let mut tried = vec![0.5];
        for &s in &T_TOWARDS_LOWER {
            let best = moved.as_ref().unwrap_or(&half);
            let t = if towards_lower { s } else { 1.0 - s };
            tried.push(t);
            let prune = Some((towards_lower, best.discarded));
            let Some(a) = attempt(&grid, &near_lower, &near_upper, &jobs, t, prune) else {
                continue;
            };
            // A plane that loses a zone altogether is no improvement.
            if a.empty > half.empty {
                continue;
            }
            let fixed = a.split == [false, false];
            if fixed || a.discarded < best.discarded {
                moved = Some(a);
            }
            if fixed {
                break;
            }
        }
        let best = moved.as_ref().unwrap_or(&half);
        if best.split != [false, false] {
            move_warning = Some(format!(
                "{} zone meets the intermediate plane in several pieces at every t tried \
                 ({tried:?}); kept t = {} (pieces besides each zone's largest: {:.4} mm², \
                 {:.4} mm² at t = 0.5; split lower/upper at t = 0.5: {:?})",
                if towards_lower { "a lower" } else { "an upper" },
                best.t,
                best.discarded,
                half.discarded,
                half.split
            ));
        }
    } else if fixed_t.is_none() && half.split == [true, true] {
        move_warning = Some(
            "zones of both sections meet the mid-plane in several pieces: no plane between \
             the sections mends both; kept t = 0.5"
                .to_string(),
        );
    }
    let build = |at: &Attempt, warnings: Vec<String>| {
        build_at(
            at,
            &grid,
            &near_lower,
            &near_upper,
            &jobs,
            lower,
            upper,
            warnings,
        )
    };
    // The split the plane could not mend is a warning only if the bridges leave some of it
    // dropped; where they join every piece, nothing is lost and it is a note.
    let with_plane_message = move |(mut out, dropped): (IntermediateContours, f64)| {
        if let Some(m) = move_warning {
            if dropped == 0.0 {
                out.notes.push(m);
            } else {
                out.warnings.push(m);
            }
        }
        out
    };
    // A plane moved near a section mends the split, but bridges may mend it at t = ½
    // already: then the paper's plane is kept (see the module docs).
    if let Some(moved) = moved {
        if moved.t.min(1.0 - moved.t) < NEAR_SECTION_T {
            let (at_half, dropped) = build(&half, warnings.clone());
            if dropped == 0.0 {
                return Ok(at_half);
            }
        }
        return Ok(with_plane_message(build(&moved, warnings)));
    }
    Ok(with_plane_message(build(&half, warnings)))
}

/// The intermediate contours at the plane of `chosen`, and the area of split zones' pieces
/// that neither a bridge joins nor is large enough to keep (mm²).
#[allow(clippy::too_many_arguments)]
fn build_at(
    chosen: &Attempt,
    grid: &Grid,
    near_lower: &NearestContours,
    near_upper: &NearestContours,
    jobs: &[Job],
    lower: &[&[Point]],
    upper: &[&[Point]],
    mut warnings: Vec<String>,
) -> (IntermediateContours, f64) {
    let cell = grid.cell_mm;
    let t = chosen.t;
    let neg_phi = &chosen.neg_phi;
    let m_empty = chosen.m_empty;
    if m_empty {
        warnings.push(
            "the two sections do not overlap on the raster: the intermediate section is empty \
             and every contour closes at its innermost point"
                .to_string(),
        );
    }

    // Each contour's zone within M_t: its pieces, largest first (several when the zone is
    // split; they are joined by bridges once compressed, see `bridges`).
    type Pieces = Option<(Vec<Vec<Point>>, Vec<Vec<Point>>)>;
    let extracted: Vec<(Pieces, Vec<String>, f64)> = jobs
        .par_iter()
        .zip(&chosen.zones)
        .map(|(&(is_lower, i), (loops, best, _, _))| {
            let mut filled = Vec::new();
            let Some(b) = *best else {
                return (None, filled, 0.0);
            };
            let near = if is_lower { &near_lower } else { &near_upper };
            let name = if is_lower { "lower" } else { "upper" };
            let g = |k: usize| neg_phi[k] as f64;
            let n = |k: usize| neg_psi(near, i as u32, k) as f32 as f64;
            let mut pieces = vec![insert_junctions(&loops[b], grid, &g, &n)];
            let mut tiny = 0.0;
            for (_, lp) in loops.iter().enumerate().filter(|&(k, _)| k != b) {
                let a = signed_area(lp);
                if a > MIN_PIECE_CELLS * cell * cell {
                    pieces.push(insert_junctions(lp, grid, &g, &n));
                } else if a > 0.0 {
                    tiny += a;
                }
            }
            let inside = |lp: &Vec<Point>| pieces.iter().any(|pc| contains(pc, lp[0]));
            let small = loops
                .iter()
                .filter(|lp| {
                    let a = signed_area(lp);
                    a < 0.0 && a >= -MIN_PIECE_CELLS * cell * cell && inside(lp)
                })
                .count();
            if small > 0 {
                filled.push(format!(
                    "{name} contour {i}: its intermediate region has {small} hole(s) too small \
                     to keep; filled"
                ));
            }
            let holes: Vec<Vec<Point>> = loops
                .iter()
                .filter(|lp| signed_area(lp) < -MIN_PIECE_CELLS * cell * cell && inside(lp))
                .map(|lp| insert_junctions(lp, grid, &g, &n))
                .collect();
            (Some((pieces, holes)), filled, tiny)
        })
        .collect();

    // Compress all loops together so shared bisecting edges stay shared.
    let flat: Vec<Vec<Point>> = extracted
        .iter()
        .filter_map(|(lp, _, _)| lp.as_ref())
        .flat_map(|(pieces, holes)| pieces.iter().chain(holes))
        .cloned()
        .collect();
    let compressed_flat = simplify_shared(&flat, SIMPLIFY_TOL_CELLS * cell);
    let all_loops: Vec<&[Point]> = compressed_flat.iter().map(|l| l.as_slice()).collect();
    let mut next_loop = 0;
    let mut compressed = Vec::new();
    let mut compressed_holes = Vec::new();
    let mut dropped = 0.0;
    let mut notes = Vec::new();
    for ((&(is_lower, i), (lp, _, tiny)), (_, _, count, total)) in
        jobs.iter().zip(&extracted).zip(&chosen.zones)
    {
        let Some((pieces, holes)) = lp else { continue };
        let own = &compressed_flat[next_loop..next_loop + pieces.len()];
        next_loop += pieces.len();
        compressed_holes.push(compressed_flat[next_loop..next_loop + holes.len()].to_vec());
        next_loop += holes.len();
        let (name, contour) = if is_lower {
            ("lower", lower[i])
        } else {
            ("upper", upper[i])
        };
        let joined = join_pieces(own, contour, &all_loops, cell);
        if *count > 1 {
            let lost = joined.dropped_area + tiny;
            dropped += lost;
            let message = format!(
                "{name} contour {i}: its zone meets the intermediate section (t = {t}) in \
                 {count} pieces; joined {} by bridges, dropped {:.4} of {:.4} mm²",
                joined.pieces, lost, total
            );
            // Nothing lost: the surface follows the whole zone, so it is not a warning.
            if lost == 0.0 {
                &mut notes
            } else {
                &mut warnings
            }
            .push(message);
        }
        compressed.push(joined.points);
    }
    let mut compressed = compressed.into_iter();
    let mut compressed_holes = compressed_holes.into_iter();

    let mut out = IntermediateContours {
        t,
        lower: Vec::new(),
        upper: Vec::new(),
        lower_holes: Vec::new(),
        upper_holes: Vec::new(),
        warnings: Vec::new(),
        notes,
    };
    for (&(is_lower, i), (lp, filled, _)) in jobs.iter().zip(extracted) {
        warnings.extend(filled);
        let (name, contour) = if is_lower {
            ("lower", lower[i])
        } else {
            ("upper", upper[i])
        };
        let holes = match lp {
            Some(_) => compressed_holes.next().unwrap_or_default(),
            None => Vec::new(),
        };
        let result = match lp {
            Some(_) => match compressed.next() {
                Some(c) => Intermediate::Loop(c),
                None => Intermediate::Point(innermost_point(grid, contour)),
            },
            None if m_empty => Intermediate::Point(innermost_point(grid, contour)),
            None => {
                // The sample of M_t nearest to the contour.
                let sd = signed_distance(grid, &[contour]);
                let best = (0..grid.len()).filter(|&k| neg_phi[k] >= 0.0).fold(
                    None,
                    |b: Option<usize>, k| match b {
                        Some(bk) if sd[bk] <= sd[k] => Some(bk),
                        _ => Some(k),
                    },
                );
                let p = match best {
                    Some(k) => grid.point(k / grid.width, k % grid.width),
                    None => innermost_point(grid, contour),
                };
                warnings.push(format!(
                    "{name} contour {i}: its zone misses the intermediate section; degenerate \
                     intermediate contour at the nearest point of that section {p:?}"
                ));
                Intermediate::Point(p)
            }
        };
        if is_lower {
            out.lower.push(result);
            out.lower_holes.push(holes);
        } else {
            out.upper.push(result);
            out.upper_holes.push(holes);
        }
    }
    out.warnings = warnings;
    (out, dropped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::{circle, dist, is_simple};

    #[test]
    fn the_halfway_loop_of_two_equal_discs_is_the_ellipse_with_their_centres_as_foci() {
        // d_a + d_b ≤ 0 ⇔ |p − c_a| + |p − c_b| ≤ 2R.
        let (ca, cb, rad) = ([1.0, -2.0], [4.0, 2.0], 5.0);
        let a = circle(ca[0], ca[1], rad, 512, true);
        let b = circle(cb[0], cb[1], rad, 512, false);
        let cell = 0.1;
        let m = halfway_loop(&a, &b, cell).expect("one piece");
        assert!(signed_area(&m) > 0.0 && is_simple(&m));
        for p in &m {
            let sum = dist(*p, ca) + dist(*p, cb);
            assert!((sum - 2.0 * rad).abs() < cell / 2.0, "{p:?}: {sum}");
        }
        // Symmetric in its two loops, whatever their orientation.
        assert_eq!(halfway_loop(&b, &a, cell), Some(m));
    }

    /// The ring of radii 4 and 10 round the origin, keyholed by a slit along the x axis from
    /// its rim to its hole, on the right (`side` 1) or on the left (−1).
    fn keyholed_ring(side: f64) -> Vec<Point> {
        let turn = |p: Point| [side * p[0], side * p[1]];
        let mut ring: Vec<Point> = circle(0.0, 0.0, 10.0, 256, true)
            .into_iter()
            .map(turn)
            .collect();
        ring.push(turn([4.0, 0.0]));
        ring.extend(circle(0.0, 0.0, 4.0, 256, false).into_iter().map(turn));
        ring.push(turn([4.0, 0.0]));
        ring
    }

    #[test]
    fn a_halfway_loop_fills_its_holes_and_is_none_when_the_loops_meet_nowhere() {
        // Keyholed on opposite sides, M_½ is the ring itself: the slits close (each lies in
        // the other loop's material) but for a notch a cell deep where they meet the rim; the
        // hole is filled.
        let m = halfway_loop(&keyholed_ring(1.0), &keyholed_ring(-1.0), 0.1).expect("one piece");
        assert!(
            m.iter().all(|p| (p[0].hypot(p[1]) - 10.0).abs() < 0.15),
            "{m:?}"
        );
        let disc = circle(0.0, 0.0, 10.0, 256, true);
        let far = circle(40.0, 0.0, 10.0, 256, true);
        assert_eq!(halfway_loop(&disc, &far, 0.1), None);
    }

    #[test]
    fn concentric_circles_interpolate_to_the_mean_radius() {
        let a = circle(1.0, -2.0, 10.0, 400, true);
        let b = circle(1.0, -2.0, 6.0, 400, true);
        let cell = 0.1;
        let r = intermediate_contours(&[&a], &[&b], cell).unwrap();
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        for side in [&r.lower[0], &r.upper[0]] {
            let Intermediate::Loop(lp) = side else {
                panic!("expected a loop")
            };
            assert!(signed_area(lp) > 0.0 && is_simple(lp));
            for p in lp {
                let rad = (p[0] - 1.0).hypot(p[1] + 2.0);
                assert!((rad - 8.0).abs() < cell / 2.0, "radius {rad}");
            }
        }
        assert_eq!(
            r.lower[0], r.upper[0],
            "1-to-1: both sides give the same loop"
        );
    }

    #[test]
    fn bad_inputs_are_errors() {
        let a = circle(0.0, 0.0, 1.0, 20, true);
        assert!(matches!(
            intermediate_contours(&[], &[&a], 0.1),
            Err(GeometryError::Empty(_))
        ));
        let mut bad = a.clone();
        bad[3][1] = f64::NAN;
        assert!(matches!(
            intermediate_contours(&[&a], &[&bad], 0.1),
            Err(GeometryError::NonFinite(_))
        ));
        assert!(intermediate_contours(&[&a], &[&a], -1.0).is_err());
        assert!(intermediate_contours(&[&a[..2]], &[&a], 0.1).is_err());
    }

    #[test]
    fn huge_raster_is_coarsened_with_a_warning() {
        let a = circle(0.0, 0.0, 100.0, 100, true);
        let mut warnings = Vec::new();
        let g = raster_for(&[&a], 0.01, &mut warnings).unwrap();
        assert!(g.len() <= MAX_RASTER_CELLS && g.cell_mm > 0.01);
        assert!(warnings.iter().any(|w| w.contains("coarsened")));
    }

    #[test]
    fn an_annular_intermediate_section_returns_its_hole() {
        // Below, two U-shaped halves of a 30 × 30 frame (bars 6 mm wide) with 2 mm gaps
        // between them; above, the whole frame, as a keyhole (a slit through its left bar).
        let left = vec![
            [0.0, 0.0],
            [14.0, 0.0],
            [14.0, 6.0],
            [6.0, 6.0],
            [6.0, 24.0],
            [14.0, 24.0],
            [14.0, 30.0],
            [0.0, 30.0],
        ];
        let right: Vec<Point> = left.iter().rev().map(|p| [30.0 - p[0], p[1]]).collect();
        let frame = vec![
            [0.0, 15.0],
            [0.0, 0.0],
            [30.0, 0.0],
            [30.0, 30.0],
            [0.0, 30.0],
            [0.0, 15.0],
            [6.0, 15.0],
            [6.0, 24.0],
            [24.0, 24.0],
            [24.0, 6.0],
            [6.0, 6.0],
            [6.0, 15.0],
        ];
        let r = intermediate_contours(&[&left, &right], &[&frame], 0.1).unwrap();
        assert!(r.lower_holes.iter().all(|h| h.is_empty()));
        let [hole] = r.upper_holes[0].as_slice() else {
            panic!("{:?}", r.upper_holes)
        };
        // The window, 18 × 18 mm at both sections, and clockwise.
        let area = signed_area(hole);
        assert!((area + 324.0).abs() < 5.0, "area {area}");
        // Its points are on the lower loops too: both sides share the window's edges.
        let lower_points: Vec<Point> = r
            .lower
            .iter()
            .filter_map(|c| match c {
                Intermediate::Loop(l) => Some(l.clone()),
                Intermediate::Point(_) => None,
            })
            .flatten()
            .collect();
        let shared = hole.iter().filter(|p| lower_points.contains(p)).count();
        assert_eq!(shared, hole.len());
    }
}
