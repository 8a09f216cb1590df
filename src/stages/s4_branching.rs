//! Stage 4: branching by distance maps (METHOD.md §3) and region assembly. For each
//! transition it computes the intermediate contours of every m-to-n problem and the caps of
//! every contour without a counterpart, then threads the curves into single-branching regions:
//! a 1-to-1 link extends a region, a branching ends the regions below at their intermediate
//! contours and starts new ones above, a cap ends or starts one. A keyhole (a contour joined
//! with holes by slits, see [`crate::geometry::keyhole`]) ends the regions of its contour and
//! holes and starts one on its loop, or the other way up; where a branching's intermediate
//! section has holes, they start hole walls of their own or are slit into their loop. A
//! region leaves as soon as it is closed, so memory holds only the regions still open at the
//! current slice.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use crossbeam_channel::{Receiver, Sender};
use rayon::prelude::*;

use super::s3_correspondence::{Joined, Problem, Side, Transition};
use super::{Control, StageStats};
use crate::geometry::branching::{intermediate_contours, Intermediate};
use crate::geometry::capping::{cap, cap_height, material_width, open_fraction, LEAST_CAP_HEIGHT};
use crate::geometry::conform::{conform, remove_spikes, weld};
use crate::geometry::keyhole::{join_rings, open_slits, search_step, slits};
use crate::geometry::overlap::{overlap_area, Region as Material};
use crate::geometry::polygon::Point;
use crate::geometry::polygon::{bbox, contains, signed_area};
use crate::mesh::{seal_problem, shared_edges};
use crate::region::{CurveOrigin, Region, RegionCurve};
use crate::section::{dot, Section, SliceFrame};
use crate::{Error, Result};

pub const STAGE: &str = "branching";

/// The curves a problem contributes, in the lower section's frame (2-D), before lifting.
pub enum Solved {
    Link,
    /// Intermediate contours: one per lower contour, one per upper contour, on the plane at
    /// the fraction `t` of the way from the lower section to the upper one.
    Branch {
        lower: Vec<Intermediate>,
        upper: Vec<Intermediate>,
        t: f64,
        /// The problem's `lower_joined` keyholes, in order.
        lower_keyholes: Vec<Keyhole>,
        /// The `upper_joined` keyholes, in order, each with the holes it really joins:
        /// those the intermediate section has already stand apart (`hole_loops`).
        upper_keyholes: Vec<(Joined, Keyhole)>,
        /// Per upper contour that is a keyhole: the holes of the intermediate section that
        /// lie over its holes, as (hole contour, loop): they start hole walls of their own.
        hole_loops: Vec<Option<Vec<(usize, Intermediate)>>>,
    },
    /// Caps: for the outer contour (if any) and each hole, in the capped section's frame.
    Cap {
        outer: Option<Intermediate>,
        holes: Vec<Intermediate>,
    },
    /// A link whose lower and/or upper side is a keyhole.
    Keyhole {
        lower: Option<Keyhole>,
        upper: Option<Keyhole>,
    },
}

/// One side of a keyhole problem, in patient mm: the contour and its joined holes with the
/// slits' feet inserted, and the loop that joins them.
pub struct Keyhole {
    pub rings: Vec<Vec<[f64; 3]>>,
    pub joined: Vec<[f64; 3]>,
}

/// Builds the keyhole `joined` of `section` from the contours' own patient points (so the
/// loop shares them bit for bit), the slits sampled every `step` mm.
fn keyhole_of(section: &Section, joined: &Joined, step: f64) -> Keyhole {
    let curves: Vec<Vec<[f64; 3]>> = std::iter::once(joined.contour)
        .chain(joined.holes.iter().copied())
        .map(|c| contour_curve(section, c).points)
        .collect();
    let refs: Vec<&[[f64; 3]]> = curves.iter().map(|c| c.as_slice()).collect();
    let (rings, joined) = join_rings(&refs, &joined.slits, &joined.also, step);
    Keyhole { rings, joined }
}

/// The keyhole `joined` of `section` as a counter-clockwise polygon in `frame`, for the
/// distance maps (the slits have no width, so the polygon bounds the material).
fn keyhole_in(frame: &SliceFrame, section: &Section, joined: &Joined, step: f64) -> Vec<Point> {
    let polys: Vec<Vec<Point>> = std::iter::once(joined.contour)
        .chain(joined.holes.iter().copied())
        .map(|c| in_frame(frame, section, c))
        .collect();
    let refs: Vec<&[Point]> = polys.iter().map(|p| p.as_slice()).collect();
    join_rings(&refs, &joined.slits, &joined.also, step).1
}

/// Contour `k` of `section` in `frame`, as stored (holes clockwise).
fn in_frame(frame: &SliceFrame, section: &Section, k: usize) -> Vec<Point> {
    section.contours[k]
        .points
        .iter()
        .map(|&p| frame.to_plane(section.frame.to_patient(p)))
        .collect()
}

fn lift(frame: &SliceFrame, p: Point, dz: f64) -> [f64; 3] {
    let q = frame.to_patient(p);
    let n = frame.normal();
    [q[0] + dz * n[0], q[1] + dz * n[1], q[2] + dz * n[2]]
}

fn lift_curve(frame: &SliceFrame, c: &Intermediate, dz: f64, reverse: bool) -> Vec<[f64; 3]> {
    match c {
        Intermediate::Point(p) => vec![lift(frame, *p, dz)],
        Intermediate::Loop(pts) => {
            let mut out: Vec<[f64; 3]> = pts.iter().map(|&p| lift(frame, p, dz)).collect();
            if reverse {
                out.reverse();
            }
            out
        }
    }
}

fn contour_curve(section: &Section, k: usize) -> RegionCurve {
    RegionCurve {
        points: section.contours[k]
            .points
            .iter()
            .map(|&p| section.frame.to_patient(p))
            .collect(),
        origin: CurveOrigin::Contour {
            slice: section.index,
            contour: k,
        },
    }
}

/// Polygons of `section`'s contours `ids`, in `frame`, counter-clockwise (holes reversed, so
/// the distance-map kernel always sees the region it should fill).
fn ccw_in(frame: &SliceFrame, section: &Section, ids: &[usize]) -> Vec<Vec<Point>> {
    ids.iter()
        .map(|&k| {
            let mut pts = in_frame(frame, section, k);
            if section.contours[k].hole {
                pts.reverse();
            }
            pts
        })
        .collect()
}

/// Distance within which two vertices of a problem's loops are one, and a vertex of one loop
/// counts as lying on another loop's edge, in distance-map cells. Small: on the skull, 0.02
/// cell made more tiny shared edges than it removed; gaps wider than this are sealed.
const CONFORM_EPS_CELLS: f64 = 1e-3;

/// Widest seal triangle, in distance-map cells, whose thin corner the mesh puts on the
/// opposite edge: the chains between pieces of an intermediate contour end up to a fifth of a
/// cell off the loop they tile (the GE head's 128 such slivers: at most 0.019 mm, cells of
/// 0.1 mm). Half a cell is the default chordal tolerance. Only the mesh moves; the loops
/// are fitted as they are.
const SLIVER_CELLS: f64 = 0.5;

/// Make the loops of one problem share their vertices wherever they share boundary (see
/// [`conform`]), so the surfaces meeting there are stitched without T-junctions.
fn conform_loops<'a>(curves: impl Iterator<Item = &'a mut Intermediate>, cell_mm: f64) {
    let mut loops: Vec<&mut Vec<Point>> = curves
        .filter_map(|c| match c {
            Intermediate::Loop(l) => Some(l),
            Intermediate::Point(_) => None,
        })
        .collect();
    let welded = weld(&mut loops, CONFORM_EPS_CELLS * cell_mm);
    if welded > 0 {
        tracing::debug!("{welded} near-duplicate vertices welded");
    }
    let n = conform(&mut loops, CONFORM_EPS_CELLS * cell_mm);
    let spikes: usize = loops.iter_mut().map(|l| remove_spikes(l)).sum();
    if spikes > 0 {
        tracing::debug!("{spikes} spike points removed");
    }
    if n > 0 {
        tracing::debug!("{n} T-junction vertices inserted");
    }
}

/// A hole contour of a section and the hole of the intermediate section over it.
type HolePair = (usize, Vec<Point>);

/// Pairs the holes of an intermediate section (`holes`, clockwise, lower frame) with the
/// holes of the keyhole `joined` they lie over (most of their area over exactly one, and
/// one each); returns the pairs (hole contour, loop) and the holes left unpaired.
fn pair_holes(
    holes: &[Vec<Point>],
    section: &Section,
    joined: &Joined,
    frame: &SliceFrame,
) -> (Vec<HolePair>, Vec<Vec<Point>>) {
    let targets: Vec<Vec<Point>> = ccw_in(frame, section, &joined.holes);
    let (mut pairs, mut unpaired): (Vec<HolePair>, Vec<Vec<Point>>) = Default::default();
    for h in holes {
        let area = signed_area(h).abs();
        let cell = (area.sqrt() / 64.0).max(1e-3);
        let over: Vec<usize> = (0..targets.len())
            .filter(|&k| {
                let shared =
                    overlap_area(&Material::filled(h), &Material::filled(&targets[k]), cell);
                shared > 0.5 * area
            })
            .collect();
        match over.as_slice() {
            [k] if pairs.iter().all(|p| p.0 != joined.holes[*k]) => {
                pairs.push((joined.holes[*k], h.clone()))
            }
            _ => unpaired.push(h.clone()),
        }
    }
    (pairs, unpaired)
}

/// Contour `k` of `section` joined with only `holes` (slits found again in `frame`, their
/// midpoints outside `outside_of`, clear of the contour's other holes), or `None` if they no
/// longer fit.
fn rejoin(
    section: &Section,
    k: usize,
    holes: &[usize],
    outside_of: &[&[Point]],
    frame: &SliceFrame,
) -> Option<Joined> {
    let plain = Joined {
        contour: k,
        holes: Vec::new(),
        slits: Vec::new(),
        also: Vec::new(),
        as_built: false,
    };
    if holes.is_empty() {
        return Some(plain);
    }
    let outer = in_frame(frame, section, k);
    let own: Vec<Vec<Point>> = holes.iter().map(|&h| in_frame(frame, section, h)).collect();
    let others: Vec<Vec<Point>> = (0..section.contours.len())
        .filter(|&h| section.contours[h].hole && !holes.contains(&h))
        .map(|h| in_frame(frame, section, h))
        .filter(|h| h.first().is_some_and(|&p| contains(&outer, p)))
        .collect();
    let own_refs: Vec<&[Point]> = own.iter().map(|h| h.as_slice()).collect();
    let other_refs: Vec<&[Point]> = others.iter().map(|h| h.as_slice()).collect();
    let cuts = slits(
        &outer,
        &own_refs,
        &other_refs,
        outside_of,
        min_search_step(&own_refs),
        true,
    )?;
    Some(Joined {
        holes: holes.to_vec(),
        slits: cuts,
        ..plain
    })
}

/// Joins `holes` into the intermediate loop `c` by slits whose midpoints lie outside
/// `outside_of` (the side's own contours: the slit's notch opens towards that side's void);
/// if no slits fit, the holes are filled, with a warning.
fn join_holes(
    c: &mut Intermediate,
    holes: &[Vec<Point>],
    outside_of: &[&[Point]],
    cell_mm: f64,
    warn: &mut impl FnMut(String),
) {
    let Intermediate::Loop(outer) = c else { return };
    let refs: Vec<&[Point]> = holes.iter().map(|h| h.as_slice()).collect();
    // The bays of a section's own contours say nothing of where an intermediate loop's
    // hole opens (measured: the GE head 40,246 crossing faces with the bay-depth rule off
    // here, 42,875 with it on).
    match slits(outer, &refs, &[], outside_of, min_search_step(&refs), false) {
        Some(cuts) => {
            let rings: Vec<&[Point]> = std::iter::once(outer.as_slice()).chain(refs).collect();
            *outer = join_rings(&rings, &cuts, &[], slit_step(cell_mm)).1;
        }
        None => warn(format!(
            "{} hole(s) of an intermediate contour could not be joined to it by a slit; filled",
            holes.len()
        )),
    }
}

/// The finest of the holes' slit search steps (see [`search_step`]).
fn min_search_step(holes: &[&[Point]]) -> f64 {
    holes
        .iter()
        .map(|h| search_step(h))
        .fold(f64::INFINITY, f64::min)
}

/// Whether upper contour `k`'s region runs on through its keyhole loop in the next
/// transition (the first of `ahead`).
fn runs_through(ahead: &[Transition], k: usize) -> bool {
    ahead
        .first()
        .is_some_and(|n| n.problems.iter().any(|p| p.runs_through(k)))
}

/// The keyhole of `joined`'s rings that the next transition (the first of `ahead`) starts a
/// region on, where correspondence joined them again across another mouth
/// (`Joined::also`, which then holds `joined`'s slits).
fn rekeyholed_next<'a>(ahead: &'a [Transition], joined: &Joined) -> Option<&'a Joined> {
    ahead.first()?.problems.iter().find_map(|p| match p {
        Problem::Keyhole { lower, .. }
            if lower.contour == joined.contour
                && lower.holes == joined.holes
                && lower.also == joined.slits =>
        {
            Some(lower)
        }
        _ => None,
    })
}

/// Slits are sampled at twice the distance-map cell, like the ridge loops' paths.
fn slit_step(cell_mm: f64) -> f64 {
    2.0 * cell_mm
}

/// One problem of transition `t`, on distance maps of `cell_mm`; caps' ridge paths stay
/// `ridge_tip_mm` (the fitting tolerance) back from their contours' tips.
pub fn solve(
    t: &Transition,
    p: &Problem,
    cell_mm: f64,
    ridge_tip_mm: f64,
    ctl: &Control,
) -> Result<Solved> {
    let geometry = |e, what: String| Error::Geometry {
        stage: STAGE,
        context: what,
        source: e,
    };
    match p {
        Problem::Link { .. } => Ok(Solved::Link),
        Problem::Keyhole { lower, upper } => {
            let (lo, up) = both(t)?;
            let step = slit_step(cell_mm);
            Ok(Solved::Keyhole {
                lower: lower.is_keyhole().then(|| keyhole_of(lo, lower, step)),
                upper: upper.is_keyhole().then(|| keyhole_of(up, upper, step)),
            })
        }
        Problem::Branch {
            lower,
            upper,
            lower_joined,
            upper_joined,
            ..
        } => {
            let (Some(lo), Some(up)) = (&t.lower, &t.upper) else {
                return Err(Error::Internal(
                    "branching problem at the end of the series".into(),
                ));
            };
            let step = slit_step(cell_mm);
            // Keyholes enter the distance maps as the material they bound.
            let with_keyholes = |s: &Section, ids: &[usize], joined: &[Joined]| {
                let mut polys = ccw_in(&lo.frame, s, ids);
                for j in joined {
                    if let Some(n) = ids.iter().position(|&k| k == j.contour) {
                        polys[n] = keyhole_in(&lo.frame, s, j, step);
                    }
                }
                polys
            };
            let a = with_keyholes(lo, lower, lower_joined);
            let b = with_keyholes(up, upper, upper_joined);
            let a_refs: Vec<&[Point]> = a.iter().map(|v| v.as_slice()).collect();
            let b_refs: Vec<&[Point]> = b.iter().map(|v| v.as_slice()).collect();
            let r = intermediate_contours(&a_refs, &b_refs, cell_mm).map_err(|e| {
                geometry(
                    e,
                    format!(
                        "slices {}–{}, {}-to-{} branching of contours {lower:?} / {upper:?}",
                        lo.index,
                        up.index,
                        lower.len(),
                        upper.len()
                    ),
                )
            })?;
            for w in &r.warnings {
                ctl.warn(format!("slices {}–{}: {w}", lo.index, up.index));
            }
            for n in &r.notes {
                ctl.note(format!("slices {}–{}: {n}", lo.index, up.index));
            }
            let (mut il, mut iu) = (r.lower, r.upper);
            let mut warn = |w: String| ctl.warn(format!("slices {}–{}: {w}", lo.index, up.index));
            // Where M_t has holes: an upper keyhole whose holes they match starts them as
            // hole walls of their own; every other loop takes its holes in by slits.
            // The holes each upper keyhole really joins; its loop is built once they are known.
            let mut upper_final: Vec<Joined> = upper_joined.clone();
            let mut hole_loops: Vec<Option<Vec<(usize, Intermediate)>>> = vec![None; upper.len()];
            for (n, holes) in r.upper_holes.into_iter().enumerate() {
                if holes.is_empty() {
                    continue;
                }
                let mut rest = holes;
                if let Some(ji) = upper_joined.iter().position(|j| j.contour == upper[n]) {
                    let j = &upper_joined[ji];
                    let (pairs, unmatched) = pair_holes(&rest, up, j, &lo.frame);
                    let left: Vec<usize> = j
                        .holes
                        .iter()
                        .copied()
                        .filter(|h| pairs.iter().all(|p| p.0 != *h))
                        .collect();
                    // The keyhole is rebuilt from the holes the section does not have.
                    let rebuilt = if pairs.is_empty() {
                        None
                    } else {
                        rejoin(up, j.contour, &left, &a_refs, &lo.frame)
                    };
                    if let Some(rebuilt) = rebuilt {
                        upper_final[ji] = rebuilt;
                        hole_loops[n] = Some(
                            pairs
                                .into_iter()
                                .map(|(h, l)| (h, Intermediate::Loop(l)))
                                .collect(),
                        );
                        rest = unmatched;
                    }
                }
                if !rest.is_empty() {
                    join_holes(&mut iu[n], &rest, &b_refs, cell_mm, &mut warn);
                }
            }
            for (n, holes) in r.lower_holes.into_iter().enumerate() {
                if !holes.is_empty() {
                    join_holes(&mut il[n], &holes, &a_refs, cell_mm, &mut warn);
                }
            }
            // Slits (a keyhole's, carried into its zone, or the holes' joined above) open into
            // channels, as in a loop a region runs through: the fitted curve would take each
            // pass of a zero-width slit its own way, and they cross.
            for c in il.iter_mut().chain(iu.iter_mut()) {
                if let Intermediate::Loop(l) = c {
                    if let Some(opened) = open_slits(l, 4.0 * cell_mm) {
                        *l = opened;
                    }
                }
            }
            let separate = hole_loops.iter_mut().flatten().flatten().map(|(_, l)| l);
            conform_loops(il.iter_mut().chain(iu.iter_mut()).chain(separate), cell_mm);
            Ok(Solved::Branch {
                lower: il,
                upper: iu,
                hole_loops,
                t: r.t,
                lower_keyholes: lower_joined
                    .iter()
                    .map(|j| keyhole_of(lo, j, step))
                    .collect(),
                upper_keyholes: upper_final
                    .into_iter()
                    .map(|j| {
                        let key = keyhole_of(up, &j, step);
                        (j, key)
                    })
                    .collect(),
            })
        }
        Problem::Cap { side, outer, holes } => {
            let section = match side {
                Side::Above => t.lower.as_ref(),
                Side::Below => t.upper.as_ref(),
            }
            .ok_or_else(|| Error::Internal("cap without its section".into()))?;
            let frame = &section.frame;
            let hole_pts: Vec<Vec<Point>> = holes
                .iter()
                .map(|&h| section.contours[h].points.clone())
                .collect();
            let what = || {
                format!(
                    "slice {}, cap of contours {outer:?} + holes {holes:?}",
                    section.index
                )
            };
            match outer {
                Some(o) => {
                    let hole_refs: Vec<&[Point]> = hole_pts.iter().map(|v| v.as_slice()).collect();
                    let caps = cap(
                        &section.contours[*o].points,
                        &hole_refs,
                        cell_mm,
                        ridge_tip_mm,
                    )
                    .map_err(|e| geometry(e, what()))?;
                    for w in &caps.warnings {
                        ctl.warn(format!("slice {}: {w}", section.index));
                    }
                    for n in &caps.notes {
                        ctl.note(format!("slice {}: {n}", section.index));
                    }
                    let (mut outer, mut holes) = (caps.outer, caps.holes);
                    conform_loops(std::iter::once(&mut outer).chain(holes.iter_mut()), cell_mm);
                    Ok(Solved::Cap {
                        outer: Some(outer),
                        holes,
                    })
                }
                None => {
                    // A lone void closing: cap it as the solid region it bounds.
                    let void = ccw_in(frame, section, holes);
                    let caps = cap(&void[0], &[], cell_mm, ridge_tip_mm)
                        .map_err(|e| geometry(e, what()))?;
                    for w in &caps.warnings {
                        ctl.warn(format!("slice {}: hole closing alone: {w}", section.index));
                    }
                    for n in &caps.notes {
                        ctl.note(format!("slice {}: hole closing alone: {n}", section.index));
                    }
                    Ok(Solved::Cap {
                        outer: None,
                        holes: vec![caps.outer],
                    })
                }
            }
        }
    }
}

/// Threads transitions into regions. Holds the regions open at the current section.
#[derive(Default)]
pub struct Assembler {
    /// Open region per contour of the current top section.
    open: Vec<Option<Region>>,
    next_id: usize,
    /// Most curves of a region (0: no limit); see `RunConfig::max_curves`.
    max_curves: usize,
    /// Holes of the current top section that a region carries through its keyhole loop:
    /// the next transition's caps of them are dropped (see [`Assembler::drop_carried_caps`]).
    carried: Vec<usize>,
    /// Width of the channels the slits of such a loop open into (mm; see
    /// [`crate::geometry::keyhole::open_slits`]).
    channel_mm: f64,
    /// Sampling of the slits of keyhole loops built here ([`slit_step`]).
    slit_mm: f64,
    /// Widest seal triangle whose thin corner the mesh puts on the opposite edge instead
    /// ([`crate::mesh::seal_problem`]).
    sliver_mm: f64,
}

impl Assembler {
    /// `cell_mm`: the distance maps' cell; the slits of loops that regions run through open
    /// into channels four cells wide (0.4 mm at the default tolerance, within which the
    /// fitted curve holds each pass apart from the other).
    pub fn new(max_curves: usize, cell_mm: f64) -> Self {
        Assembler {
            max_curves,
            channel_mm: 4.0 * cell_mm,
            slit_mm: slit_step(cell_mm),
            sliver_mm: SLIVER_CELLS * cell_mm,
            ..Default::default()
        }
    }

    /// Drops from `t` (the next transition) the caps of the holes carried through keyhole
    /// loops: correspondence runs a region on through its loop where all the loop's holes
    /// close and open onto the outside above, but cannot know which of them a branching's
    /// keyhole really joined (those the intermediate section already has start walls of
    /// their own, and keep their caps).
    pub fn drop_carried_caps(&self, t: &mut Transition) {
        t.problems.retain(|p| match p {
            Problem::Cap {
                side: Side::Above,
                outer: None,
                holes,
            } => !holes.iter().all(|h| self.carried.contains(h)),
            _ => true,
        });
    }

    fn close(&mut self, mut r: Region, out: &mut Vec<Region>) {
        r.id = self.next_id;
        self.next_id += 1;
        out.push(r);
    }

    fn take(&mut self, k: usize, section: &Section) -> Result<Region> {
        self.open.get_mut(k).and_then(Option::take).ok_or_else(|| {
            Error::Internal(format!(
                "slice {}: contour {k} has no open region",
                section.index
            ))
        })
    }

    /// The sections a cap closes, going away from the cap, as `(distance, width)` for
    /// [`cap_height`]: the capped section's contours `ids` (outer first, or a lone void),
    /// then, while every one of them continues 1-to-1 from an input contour, those it
    /// continues from. Above the series these are the open regions' earlier curves; below it
    /// the links of the transitions `ahead`.
    fn cap_widths(
        &self,
        section: &Section,
        side: Side,
        ids: &[usize],
        ahead: &[Transition],
    ) -> Vec<(f64, f64)> {
        let frame = &section.frame;
        let width = |loops: &[&[Point]]| material_width(loops[0], &loops[1..]);
        let own: Vec<&[Point]> = ids
            .iter()
            .map(|&k| section.contours[k].points.as_slice())
            .collect();
        let mut widths = vec![(0.0, width(&own))];
        let mut current: Vec<usize> = ids.to_vec();
        for depth in 1..=2 {
            // The sections `depth` away, in patient mm.
            let curves: Option<Vec<Vec<[f64; 3]>>> = match side {
                Side::Above => ids
                    .iter()
                    .map(|&k| {
                        let r = self.open.get(k)?.as_ref()?;
                        let c = &r.curves[r.curves.len().checked_sub(1 + depth)?];
                        matches!(c.origin, CurveOrigin::Contour { .. }).then(|| c.points.clone())
                    })
                    .collect(),
                Side::Below => ahead.get(depth - 1).and_then(|next| {
                    let up = next.upper.as_ref()?;
                    current = current
                        .iter()
                        .map(|&k| {
                            next.problems.iter().find_map(|p| match p {
                                Problem::Link { lower, upper, .. } if *lower == k => Some(*upper),
                                _ => None,
                            })
                        })
                        .collect::<Option<Vec<usize>>>()?;
                    Some(
                        current
                            .iter()
                            .map(|&k| contour_curve(up, k).points)
                            .collect(),
                    )
                }),
            };
            let Some(curves) = curves else { break };
            let distance = (frame.height() - dot(curves[0][0], frame.normal())).abs();
            let loops: Vec<Vec<Point>> = curves
                .iter()
                .map(|c| c.iter().map(|&p| frame.to_plane(p)).collect())
                .collect();
            let refs: Vec<&[Point]> = loops.iter().map(|l| l.as_slice()).collect();
            widths.push((distance, width(&refs)));
        }
        widths
    }

    /// Closes the regions of `joined`'s contour and holes in `section` on their rings (the
    /// slits' feet inserted) and returns the region that starts on the keyhole loop.
    fn end_on_keyhole(
        &mut self,
        section: &Section,
        joined: &Joined,
        k: Keyhole,
        closed: &mut Vec<Region>,
    ) -> Result<Region> {
        let ids = std::iter::once(&joined.contour).chain(&joined.holes);
        for (&c, ring) in ids.zip(k.rings) {
            let mut r = self.take(c, section)?;
            // The rings the region below ended on, on the other keyhole of this slice
            // (`Joined::also`): nothing lies between the two loops, which must share them.
            if r.curves.len() == 1 && !joined.also.is_empty() {
                if r.curves[0].points != ring {
                    return Err(Error::Internal(format!(
                        "slice {}: contour {c}'s two keyhole loops do not share its ring",
                        section.index
                    )));
                }
                continue;
            }
            // Otherwise correspondence never joins a contour that started from a keyhole
            // (it has one curve yet), and chains are not split just before one.
            if r.curves.len() < 2 {
                return Err(Error::Internal(format!(
                    "slice {}: contour {c} ends in a keyhole where it starts",
                    section.index
                )));
            }
            if let Some(last) = r.curves.last_mut() {
                r.inserted[1] += ring.len().saturating_sub(last.points.len());
                last.points = ring;
            }
            self.close(r, closed);
        }
        Ok(Region {
            id: 0,
            hole: false,
            curves: vec![RegionCurve {
                points: k.joined,
                origin: CurveOrigin::Keyhole {
                    slice: section.index,
                },
            }],
            seal: Vec::new(),
            seal_points: Vec::new(),
            shared_edges: Vec::new(),
            joint_below: false,
            inserted: [0, 0],
        })
    }

    /// Ends `r` on the keyhole loop of `joined` in `section` and opens the regions of its
    /// contour and holes on their rings (the slits' feet inserted), or, where the next
    /// transition (the first of `ahead`) carries the loop's holes on (the mouth is closed on
    /// this slice only), lets `r` run on with the loop as one of its curves, in the
    /// contour's place. Where the next transition starts a region on another keyhole of the
    /// same rings instead (`Joined::also`), this loop takes that one's feet too.
    #[allow(clippy::too_many_arguments)] // the region, its loop and where it goes next
    fn start_from_keyhole(
        &mut self,
        section: &Section,
        joined: &Joined,
        k: Keyhole,
        mut r: Region,
        ahead: &[Transition],
        next: &mut [Option<Region>],
        closed: &mut Vec<Region>,
    ) {
        let through = runs_through(ahead, joined.contour);
        // The loop solved with this transition could not know the next one's slits: it is
        // built again with their feet.
        let k = match rekeyholed_next(ahead, joined) {
            Some(other) => {
                let both = Joined {
                    also: other.slits.clone(),
                    ..joined.clone()
                };
                keyhole_of(section, &both, self.slit_mm)
            }
            None => k,
        };
        let mut points = k.joined;
        if through {
            // Inside the region the slits open into channels (only the slits' points move;
            // no other region holds this loop).
            let plane: Vec<Point> = points.iter().map(|&p| section.frame.to_plane(p)).collect();
            if let Some(opened) = open_slits(&plane, self.channel_mm) {
                for (q, (o, p)) in points.iter_mut().zip(opened.iter().zip(&plane)) {
                    if o != p {
                        *q = section.frame.to_patient(*o);
                    }
                }
            }
        }
        r.curves.push(RegionCurve {
            points,
            origin: CurveOrigin::Keyhole {
                slice: section.index,
            },
        });
        if through {
            next[joined.contour] = Some(r);
            self.carried.extend(joined.holes.iter().copied());
            return;
        }
        self.close(r, closed);
        let ids = std::iter::once(&joined.contour).chain(&joined.holes);
        for (n, (&c, points)) in ids.zip(k.rings).enumerate() {
            let inserted = points
                .len()
                .saturating_sub(section.contours[c].points.len());
            next[c] = Some(Region {
                id: 0,
                hole: n > 0,
                curves: vec![RegionCurve {
                    points,
                    origin: CurveOrigin::Contour {
                        slice: section.index,
                        contour: c,
                    },
                }],
                seal: Vec::new(),
                seal_points: Vec::new(),
                shared_edges: Vec::new(),
                joint_below: false,
                inserted: [inserted, 0],
            });
        }
    }

    /// Apply one transition; returns the regions it closes, in problem order. `ahead` are
    /// the next transitions (up to two), whose links place the caps that start regions.
    pub fn apply(
        &mut self,
        t: &Transition,
        solved: Vec<Solved>,
        ahead: &[Transition],
    ) -> Result<Vec<Region>> {
        let mut closed = Vec::new();
        self.carried.clear();
        let mut next: Vec<Option<Region>> =
            vec![None; t.upper.as_ref().map_or(0, |u| u.contours.len())];
        for (p, s) in t.problems.iter().zip(solved) {
            match (p, s) {
                (Problem::Link { lower, upper, .. }, Solved::Link) => {
                    let (lo, up) = both(t)?;
                    let mut r = self.take(*lower, lo)?;
                    r.curves.push(contour_curve(up, *upper));
                    // Not where the next transition ends the chain in a keyhole: that
                    // inserts the slits' feet into this contour, and a segment ending here
                    // would already be gone.
                    let keyhole_next = ahead
                        .first()
                        .is_some_and(|n| n.problems.iter().any(|p| p.ends_in_keyhole(*upper)));
                    if self.max_curves >= 2 && r.curves.len() >= self.max_curves && !keyhole_next {
                        // A long chain: this segment ends here, the next starts on the same
                        // contour (its mesh rows are that contour's points on both sides).
                        let joint = r.curves.last().cloned();
                        let hole = r.hole;
                        self.close(r, &mut closed);
                        r = Region {
                            id: 0,
                            hole,
                            curves: joint.into_iter().collect(),
                            seal: Vec::new(),
                            seal_points: Vec::new(),
                            shared_edges: Vec::new(),
                            joint_below: true,
                            inserted: [0, 0],
                        };
                    }
                    next[*upper] = Some(r);
                }
                (
                    Problem::Branch {
                        hole,
                        lower,
                        upper,
                        lower_joined,
                        upper_joined,
                    },
                    Solved::Branch {
                        lower: il,
                        upper: iu,
                        t: at,
                        lower_keyholes,
                        upper_keyholes,
                        hole_loops,
                    },
                ) => {
                    // The kernel may move the plane off the middle (a contour splitting
                    // near one section): both sides' regions end on it.
                    let dz = at * t.spacing;
                    let (lo, up) = both(t)?;
                    let origin = CurveOrigin::Intermediate {
                        below: lo.index,
                        above: up.index,
                    };
                    let below: Vec<Vec<[f64; 3]>> = il
                        .iter()
                        .map(|c| lift_curve(&lo.frame, c, dz, *hole))
                        .collect();
                    let above: Vec<Vec<[f64; 3]>> = iu
                        .iter()
                        .map(|c| lift_curve(&lo.frame, c, dz, *hole))
                        .collect();
                    // Holes of the intermediate section that start hole walls of their own.
                    let hole_above: Vec<Vec<(usize, Vec<[f64; 3]>)>> = hole_loops
                        .iter()
                        .map(|h| {
                            h.iter()
                                .flatten()
                                .map(|(c, l)| (*c, lift_curve(&lo.frame, l, dz, *hole)))
                                .collect()
                        })
                        .collect();
                    let ends: Vec<(&[[f64; 3]], bool)> = below
                        .iter()
                        .map(|c| (c.as_slice(), true))
                        .chain(above.iter().map(|c| (c.as_slice(), false)))
                        .chain(
                            hole_above
                                .iter()
                                .flatten()
                                .map(|(_, c)| (c.as_slice(), false)),
                        )
                        .collect();
                    let (seal, seal_points) = seal_problem(&ends, self.sliver_mm);
                    let shared = shared_edges(&ends);
                    let mut seal = Some(seal);
                    let mut lower_keyholes: Vec<Option<Keyhole>> =
                        lower_keyholes.into_iter().map(Some).collect();
                    let mut upper_keyholes: Vec<Option<(Joined, Keyhole)>> =
                        upper_keyholes.into_iter().map(Some).collect();
                    let keyhole = |joined: &[Joined], keys: &mut [Option<Keyhole>], k: usize| {
                        let n = joined.iter().position(|j| j.contour == k)?;
                        Some((joined[n].clone(), keys[n].take()?))
                    };
                    for (&k, points) in lower.iter().zip(below) {
                        let mut r = match keyhole(lower_joined, &mut lower_keyholes, k) {
                            None => self.take(k, lo)?,
                            Some((j, key)) => self.end_on_keyhole(lo, &j, key, &mut closed)?,
                        };
                        r.curves.push(RegionCurve { points, origin });
                        r.seal.extend(seal.take().unwrap_or_default());
                        r.seal_points.extend_from_slice(&seal_points);
                        r.shared_edges.extend_from_slice(&shared);
                        self.close(r, &mut closed);
                    }
                    for ((&k, points), holes_above) in upper.iter().zip(above).zip(hole_above) {
                        let mut r = Region {
                            id: 0,
                            hole: *hole,
                            curves: vec![RegionCurve { points, origin }],
                            seal: seal.take().unwrap_or_default(),
                            seal_points: seal_points.clone(),
                            shared_edges: shared.clone(),
                            joint_below: false,
                            inserted: [0, 0],
                        };
                        // Holes of the intermediate section over the keyhole's holes start
                        // their walls there; the keyhole joins only the others, if any.
                        for (h, points) in holes_above {
                            next[h] = Some(Region {
                                id: 0,
                                hole: true,
                                curves: vec![RegionCurve { points, origin }, contour_curve(up, h)],
                                seal: Vec::new(),
                                seal_points: seal_points.clone(),
                                shared_edges: shared.clone(),
                                joint_below: false,
                                inserted: [0, 0],
                            });
                        }
                        let key = upper_joined
                            .iter()
                            .position(|j| j.contour == k)
                            .and_then(|n| upper_keyholes[n].take());
                        match key {
                            Some((j, key)) if j.is_keyhole() => self.start_from_keyhole(
                                up,
                                &j,
                                key,
                                r,
                                ahead,
                                &mut next,
                                &mut closed,
                            ),
                            _ => {
                                r.curves.push(contour_curve(up, k));
                                next[k] = Some(r);
                            }
                        }
                    }
                }
                (
                    Problem::Cap { side, outer, holes },
                    Solved::Cap {
                        outer: co,
                        holes: ch,
                    },
                ) => {
                    let mut ends: Vec<(usize, bool, Intermediate)> = Vec::new();
                    if let (Some(o), Some(c)) = (outer, co) {
                        ends.push((*o, false, c));
                    }
                    ends.extend(holes.iter().zip(ch).map(|(&h, c)| (h, true, c)));
                    let section = match side {
                        Side::Above => t.lower.as_ref(),
                        Side::Below => t.upper.as_ref(),
                    }
                    .ok_or_else(|| Error::Internal("cap without its section".into()))?;
                    // Every loop of one cap at one height: they share ridge loops and seals.
                    let across = match side {
                        Side::Above => t.upper.as_ref(),
                        Side::Below => t.lower.as_ref(),
                    };
                    let opening =
                        outer.is_none() && across.is_some_and(|a| opens(section, holes, a));
                    // Islands that neighbours' walls may sweep over cap low too (see
                    // `in_a_hole` and `in_a_bay`); one in a bay only where no three sections
                    // estimate the height, which would be half a slice.
                    let least = LEAST_CAP_HEIGHT * t.spacing;
                    let height = if opening || outer.is_some_and(|o| in_a_hole(section, o)) {
                        least
                    } else {
                        let ids: Vec<usize> = outer.iter().chain(holes).copied().collect();
                        let widths = self.cap_widths(section, *side, &ids, ahead);
                        let in_bay = widths.len() < 3
                            && outer.is_some_and(|o| {
                                across.is_some_and(|a| opens(section, &[o], a))
                                    && in_a_bay(section, o)
                            });
                        if in_bay {
                            least
                        } else {
                            cap_height(&widths, t.spacing)
                        }
                    };
                    let dz = match side {
                        Side::Above => height,
                        Side::Below => -height,
                    };
                    let origin = CurveOrigin::Cap {
                        slice: section.index,
                    };
                    let top = matches!(side, Side::Above);
                    let lifted: Vec<(usize, bool, Vec<[f64; 3]>)> = ends
                        .into_iter()
                        .map(|(k, hole, c)| (k, hole, lift_curve(&section.frame, &c, dz, hole)))
                        .collect();
                    let loops: Vec<(&[[f64; 3]], bool)> =
                        lifted.iter().map(|(_, _, c)| (c.as_slice(), top)).collect();
                    let (seal, seal_points) = seal_problem(&loops, self.sliver_mm);
                    let mut seal = Some(seal);
                    for (k, hole, points) in lifted {
                        let end = RegionCurve { points, origin };
                        if top {
                            let mut r = self.take(k, section)?;
                            r.curves.push(end);
                            r.seal.extend(seal.take().unwrap_or_default());
                            r.seal_points.extend_from_slice(&seal_points);
                            self.close(r, &mut closed);
                        } else {
                            next[k] = Some(Region {
                                id: 0,
                                hole,
                                curves: vec![end, contour_curve(section, k)],
                                seal: seal.take().unwrap_or_default(),
                                seal_points: seal_points.clone(),
                                shared_edges: Vec::new(),
                                joint_below: false,
                                inserted: [0, 0],
                            });
                        }
                    }
                }
                (
                    Problem::Keyhole { lower, upper },
                    Solved::Keyhole {
                        lower: kl,
                        upper: ku,
                    },
                ) => {
                    let (lo, up) = both(t)?;
                    let mut r = match kl {
                        None => self.take(lower.contour, lo)?,
                        Some(k) => self.end_on_keyhole(lo, lower, k, &mut closed)?,
                    };
                    match ku {
                        None => {
                            r.curves.push(contour_curve(up, upper.contour));
                            next[upper.contour] = Some(r);
                        }
                        Some(k) => {
                            self.start_from_keyhole(up, upper, k, r, ahead, &mut next, &mut closed)
                        }
                    }
                }
                _ => return Err(Error::Internal("problem and solution do not match".into())),
            }
        }
        if let Some(k) = self.open.iter().position(Option::is_some) {
            return Err(Error::Internal(format!(
                "contour {k} was left without a problem"
            )));
        }
        self.open = next;
        Ok(closed)
    }
}

fn both(t: &Transition) -> Result<(&Arc<Section>, &Arc<Section>)> {
    match (&t.lower, &t.upper) {
        (Some(a), Some(b)) => Ok((a, b)),
        _ => Err(Error::Internal("link at the end of the series".into())),
    }
}

/// Stage 4: each transition's problems solved (in parallel) into regions, assembled and sent
/// on in order. `ridge_tip_mm`: see [`solve`].
pub fn run(
    input: Receiver<Transition>,
    cell_mm: f64,
    ridge_tip_mm: f64,
    max_curves: usize,
    out: Sender<Region>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    let mut assembler = Assembler::new(max_curves, cell_mm);
    // Two transitions are held back: caps that start regions are placed from the links above.
    let mut held: VecDeque<Transition> = VecDeque::with_capacity(3);
    for arrived in input.iter().map(Some).chain(std::iter::once(None)) {
        ctl.check()?;
        let end = arrived.is_none();
        held.extend(arrived);
        while held.len() > 2 || (end && !held.is_empty()) {
            let Some(mut t) = held.pop_front() else { break };
            assembler.drop_carried_caps(&mut t);
            let start = Instant::now();
            // The problems of one transition are independent: solve them in parallel, in order.
            let solved: Result<Vec<Solved>> = t
                .problems
                .par_iter()
                .map(|p| solve(&t, p, cell_mm, ridge_tip_mm, ctl))
                .collect();
            let closed = assembler.apply(&t, solved?, held.make_contiguous())?;
            stats.busy += start.elapsed();
            for r in closed {
                stats.items += 1;
                if out.send(r).is_err() {
                    return Ok(stats);
                }
            }
        }
    }
    Ok(stats)
}

/// Whether contour `k` of `section` lies inside one of its holes: an island in a cavity.
/// Capped alone, such an island caps at the least height. The cavity goes on across while
/// the island does not, so the cavity's wall between the slices may sweep over the island's
/// footprint, and a dome half a slice deep crossed it (the GE head's bone islands in the
/// cranial cavity: 340 faces); near its own slice the wall is near its own contour, which
/// the island's does not meet.
fn in_a_hole(section: &Section, k: usize) -> bool {
    let Some(&p) = section.contours[k].points.first() else {
        return false;
    };
    section
        .contours
        .iter()
        .any(|c| c.hole && contains(&c.points, p))
}

/// Whether contour `k` of `section` lies within the bounding box of a larger outer contour:
/// an island in one of its bays, or beside it, among its walls. Capped alone over void, with
/// no sections to estimate its end from, such an island caps at the least height rather than
/// half a slice: the larger contour's walls between the slices may sweep over its footprint
/// (the GE head's crescent island 214 at slice 9, in a bay that band 198 sweeps over: 189
/// faces).
fn in_a_bay(section: &Section, k: usize) -> bool {
    let own = bbox(&section.contours[k].points);
    let area = signed_area(&section.contours[k].points).abs();
    section.contours.iter().enumerate().any(|(j, c)| {
        let b = bbox(&c.points);
        j != k
            && !c.hole
            && signed_area(&c.points).abs() > area
            && b[0] <= own[0]
            && b[1] <= own[1]
            && b[2] >= own[2]
            && b[3] >= own[3]
    })
}

/// Fraction of a capped void's footprint that must be void across its cap too for the void
/// to count as opening there ([`opens`]).
const OPEN_VOID: f64 = 0.5;

/// Whether any of the voids `holes` of `section`, capped alone, opens onto void in the
/// section `across` its cap rather than closing under material: a hole whose footprint lies
/// mostly outside the next slice's material (a bay, or the outside) runs on sideways, and no
/// roof is there. Such a void caps at the least height: at half a slice, the skull's hole 52
/// domed up through the walls its outer region's bay swept over it (195 crossing faces).
fn opens(section: &Section, holes: &[usize], across: &Section) -> bool {
    let mapped: Vec<(Vec<Point>, bool)> = (0..across.contours.len())
        .map(|c| (in_frame(&section.frame, across, c), across.contours[c].hole))
        .collect();
    let loops: Vec<(&[Point], bool)> = mapped.iter().map(|(c, h)| (c.as_slice(), *h)).collect();
    holes
        .iter()
        .any(|&k| open_fraction(&section.contours[k].points, &loops) >= OPEN_VOID)
}
