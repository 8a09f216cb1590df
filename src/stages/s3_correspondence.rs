//! Stage 3: correspondence by overlap (METHOD.md §2). Sections arrive in ascending height;
//! for each adjacent pair this stage links contours whose regions overlap (projected along
//! the normal), and splits the overlap graph into branching problems: 1-to-1 links, m-to-n
//! branchings, and caps (a contour with no counterpart). Outer contours link by their
//! material (outer minus its holes); holes link to holes by the voids they bound. A hole
//! with no hole to link to whose void opens onto the other section's outside (a bay closing
//! into a hole, or a hole opening into a bay) joins its outer contour in a keyhole instead
//! of being capped alone (see [`crate::geometry::keyhole`]).
//!
//! Only two sections are alive here at a time; each leaves inside the transitions that need
//! it and is dropped after the next one arrives.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Instant;

use crossbeam_channel::Sender;

use super::{Control, StageStats};
use crate::geometry::contours::nesting;
use crate::geometry::keyhole::{lie_clear, search_step, slits, Slit};
use crate::geometry::overlap::{overlap_area, regions_overlap, Region as Material};
use crate::geometry::polygon::{bbox, signed_area, Point};
use crate::section::{Contour, Section};
use crate::{Error, Result};

pub const STAGE: &str = "correspondence";

/// Which side of a section a cap closes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Below,
    Above,
}

/// A hole joins a keyhole when at least this fraction of its void lies outside the other
/// section's contour: less, and it is a cavity starting inside the material, capped alone.
pub const MIN_OPEN_FRACTION: f64 = 0.02;

/// A contour and the holes it joins by slits into one keyhole loop (see
/// [`crate::geometry::keyhole`]; in `slits` ring 0 is the contour and ring `k + 1` is
/// `holes[k]`, in the lower section's plane). Without holes: the contour on its own.
#[derive(Clone, Debug, PartialEq)]
pub struct Joined {
    pub contour: usize,
    pub holes: Vec<usize>,
    pub slits: Vec<Slit>,
    /// The slits of the same rings' other keyhole on this slice, where the region below ends
    /// on one keyhole loop and the region above starts on another (see [`rekeyholed`]): both
    /// loops carry both slits' feet, so they share every ring vertex. Empty otherwise.
    pub also: Vec<Slit>,
    /// Stage 4 builds the loop from exactly these slits: a keyhole problem's. A branching
    /// may join its keyholes' rings again (`s4_branching::rejoin`), so the loop another
    /// keyhole's feet must match is only known there, and such keyholes are not joined
    /// again ([`rekeyholed`]).
    pub as_built: bool,
}

impl Joined {
    pub fn is_keyhole(&self) -> bool {
        !self.holes.is_empty()
    }
}

impl Problem {
    /// The keyholes of this problem on the lower section (`lower`) or the upper one.
    fn keyholes(&self, lower: bool) -> Vec<&Joined> {
        match (self, lower) {
            (Problem::Keyhole { lower: j, .. }, true)
            | (Problem::Keyhole { upper: j, .. }, false)
                if j.is_keyhole() =>
            {
                vec![j]
            }
            (Problem::Branch { lower_joined, .. }, true) => lower_joined.iter().collect(),
            (Problem::Branch { upper_joined, .. }, false) => upper_joined.iter().collect(),
            _ => Vec::new(),
        }
    }

    /// Whether lower contour `k` ends here in a keyhole (its regions close on it).
    pub fn ends_in_keyhole(&self, k: usize) -> bool {
        self.keyholes(true).iter().any(|j| j.contour == k)
    }

    /// Whether lower contour `k`'s region runs on here through the keyhole loop it started
    /// from (see [`Problem::Link`]).
    pub fn runs_through(&self, k: usize) -> bool {
        matches!(self, Problem::Link { lower, through, .. } if *lower == k && !through.is_empty())
    }
}

/// One problem between two adjacent sections. Indices are contour indices in their section.
#[derive(Clone, Debug, PartialEq)]
pub enum Problem {
    /// One contour below continues as one contour above. `through` lists the holes of the
    /// lower contour's keyhole loop where its region starts from one and every such hole
    /// ends here, opening onto the upper contour's outside (a mouth closed on this slice
    /// only): the region runs on through that loop, a curve of it rather than its end, and
    /// the holes it really joined are carried with it (branching drops their caps,
    /// `s4_branching::Assembler::drop_carried_caps`). Empty otherwise.
    Link {
        hole: bool,
        lower: usize,
        upper: usize,
        through: Vec<usize>,
    },
    /// m contours below and n above form one connected component with m + n ≥ 3. Outer
    /// contours with lone holes that open onto the other side's outside enter it as keyholes
    /// (`lower_joined`, `upper_joined`; see [`Problem::Keyhole`]).
    Branch {
        hole: bool,
        lower: Vec<usize>,
        upper: Vec<usize>,
        lower_joined: Vec<Joined>,
        upper_joined: Vec<Joined>,
    },
    /// One outer contour continuing as one, where holes of either (or both) have no hole to
    /// link to and open onto the other contour's outside (a bay closing into a hole, or a
    /// hole opening into a bay). That side's contour and holes are joined into one loop,
    /// where its regions end or start.
    Keyhole { lower: Joined, upper: Joined },
    /// Contours of one section with no counterpart on `side`: an outer contour with those of
    /// its holes that end with it (closed together, like the top of a flat torus), or a lone
    /// hole whose void closes while its outer contour goes on.
    Cap {
        side: Side,
        outer: Option<usize>,
        holes: Vec<usize>,
    },
}

/// The problems between two adjacent sections; `lower` is `None` below the first section and
/// `upper` is `None` above the last.
#[derive(Clone, Debug)]
pub struct Transition {
    pub lower: Option<Arc<Section>>,
    pub upper: Option<Arc<Section>>,
    /// Distance between the two planes along the normal (at the ends of the series: the
    /// spacing to the nearest section: caps sit within it).
    pub spacing: f64,
    pub problems: Vec<Problem>,
}

/// The contours of a section arranged for overlap tests, in the section's own frame.
struct Arranged {
    /// Parent (enclosing contour) of each contour.
    parent: Vec<Option<usize>>,
    boxes: Vec<[f64; 4]>,
}

fn arrange(points: &[&[Point]]) -> Arranged {
    Arranged {
        parent: nesting(points),
        boxes: points.iter().map(|p| bbox(p)).collect(),
    }
}

fn boxes_meet(a: [f64; 4], b: [f64; 4]) -> bool {
    a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3]
}

/// The problems between `lower` and `upper` (both present). `started` says, per lower
/// contour, whether it starts here from a keyhole (the previous transition's upper side),
/// with that keyhole for its outer contour (for its holes, the hole on its own): such
/// regions have one curve yet, so they cannot end in another keyhole at once; where the
/// keyhole's holes open onto the upper contour's outside, the region runs on through the
/// loop (`through` of [`Problem::Link`]).
pub fn correspond(lower: &Section, upper: &Section, started: &[Option<Joined>]) -> Vec<Problem> {
    let lo: Vec<&[Point]> = lower.contours.iter().map(|c| c.points.as_slice()).collect();
    // The upper contours projected along the normal into the lower section's plane.
    let up_owned: Vec<Vec<Point>> = upper
        .contours
        .iter()
        .map(|c| {
            c.points
                .iter()
                .map(|&p| lower.frame.to_plane(upper.frame.to_patient(p)))
                .collect()
        })
        .collect();
    let up: Vec<&[Point]> = up_owned.iter().map(|p| p.as_slice()).collect();
    let (la, ua) = (arrange(&lo), arrange(&up));
    let m = lo.len();
    let mut overlapping: Vec<(usize, usize)> = Vec::new();
    for i in 0..m {
        let hole_i = lower.contours[i].hole;
        for j in 0..up.len() {
            if upper.contours[j].hole != hole_i || !boxes_meet(la.boxes[i], ua.boxes[j]) {
                continue;
            }
            let overlap = if hole_i {
                // Voids: the hole polygons themselves (clockwise; overlap is orientation-free).
                regions_overlap(
                    &Material {
                        outer: lo[i],
                        holes: Vec::new(),
                    },
                    &Material {
                        outer: up[j],
                        holes: Vec::new(),
                    },
                    0.0,
                )
            } else {
                regions_overlap(
                    &Material {
                        outer: lo[i],
                        holes: holes_of(&lo, &la, i),
                    },
                    &Material {
                        outer: up[j],
                        holes: holes_of(&up, &ua, j),
                    },
                    0.0,
                )
            };
            if overlap {
                overlapping.push((i, j));
            }
        }
    }
    // An island in a hole overlaps the material its enclosing contour links to wherever it
    // touches the wall on the other section. Linked, the two nested contours would make one
    // branching of overlapping pieces, whose intermediate contours fill the hole between
    // them; so while that hole goes on across (it is not joined into its contour by a
    // keyhole, which would take the island outside it), the island is not linked there and
    // caps, as a cavity inside the material does.
    let pairs: HashSet<(usize, usize)> = overlapping.iter().copied().collect();
    let (mut goes_on_lower, mut goes_on_upper) = (vec![false; m], vec![false; up.len()]);
    for &(i, j) in &overlapping {
        (goes_on_lower[i], goes_on_upper[j]) = (true, true);
    }
    let shadowed = |&(i, j): &(usize, usize)| {
        enclosing(&la.parent, &lower.contours, i)
            .any(|(h, a)| goes_on_lower[h] && pairs.contains(&(a, j)))
            || enclosing(&ua.parent, &upper.contours, j)
                .any(|(h, b)| goes_on_upper[h] && pairs.contains(&(i, b)))
    };
    let kept: Vec<(usize, usize)> = overlapping
        .iter()
        .copied()
        .filter(|p| !shadowed(p))
        .collect();
    // Union–find over lower contours 0..m and upper contours m..m+n.
    let mut uf = UnionFind::new(m + up.len());
    let mut linked = vec![false; m + up.len()];
    for (i, j) in kept {
        uf.union(i, m + j);
        linked[i] = true;
        linked[m + j] = true;
    }
    let mut problems = Vec::new();
    // Components in order of their smallest member: deterministic.
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); m + up.len()];
    for k in 0..m + up.len() {
        if linked[k] {
            members[uf.find(k)].push(k);
        }
    }
    let mut comps: Vec<Vec<usize>> = members.into_iter().filter(|c| !c.is_empty()).collect();
    comps.sort_by_key(|c| c[0]);
    for comp in comps {
        let lower_ids: Vec<usize> = comp.iter().copied().filter(|&k| k < m).collect();
        let upper_ids: Vec<usize> = comp
            .iter()
            .copied()
            .filter(|&k| k >= m)
            .map(|k| k - m)
            .collect();
        let hole = lower.contours[lower_ids[0]].hole;
        problems.push(if lower_ids.len() == 1 && upper_ids.len() == 1 {
            Problem::Link {
                hole,
                lower: lower_ids[0],
                upper: upper_ids[0],
                through: Vec::new(),
            }
        } else {
            Problem::Branch {
                hole,
                lower: lower_ids,
                upper: upper_ids,
                lower_joined: Vec::new(),
                upper_joined: Vec::new(),
            }
        });
    }
    let ending: Vec<bool> = (0..m).map(|i| !linked[i]).collect();
    problems.extend(caps(lower, &la, &ending, Side::Above));
    let starting: Vec<bool> = (0..up.len()).map(|j| !linked[m + j]).collect();
    problems.extend(caps(upper, &ua, &starting, Side::Below));
    let holes = |s: &Section| s.contours.iter().map(|c| c.hole).collect::<Vec<bool>>();
    let lower_side = View {
        pts: &lo,
        arr: &la,
        hole: holes(lower),
    };
    let upper_side = View {
        pts: &up,
        arr: &ua,
        hole: holes(upper),
    };
    join_keyholes(problems, &lower_side, &upper_side, started)
}

/// One section's contours as [`join_keyholes`] sees them (in the lower section's plane).
struct View<'a> {
    pts: &'a [&'a [Point]],
    arr: &'a Arranged,
    hole: Vec<bool>,
}

/// The fraction of hole `h`'s void outside the polygons `others` (disjoint: one section's
/// outer contours).
fn open_fraction(h: &[Point], others: &[&[Point]]) -> f64 {
    let area = signed_area(h).abs();
    if area.is_nan() || area <= 0.0 {
        return 0.0;
    }
    let cell = (area.sqrt() / 64.0).max(1e-3);
    let shared: f64 = others
        .iter()
        .map(|o| overlap_area(&Material::filled(h), &Material::filled(o), cell))
        .sum();
    (1.0 - shared / area).clamp(0.0, 1.0)
}

/// Contour `k` of `own` with those of its holes among `lone` that open onto the outside of
/// `others` (the contours it links to), each kept only if it can join by a slit (with those
/// kept before it).
fn joinable(own: &View, k: usize, lone: &[usize], others: &[&[Point]]) -> Joined {
    let candidates: Vec<usize> = lone
        .iter()
        .copied()
        .filter(|&h| {
            own.arr.parent[h] == Some(k) && open_fraction(own.pts[h], others) >= MIN_OPEN_FRACTION
        })
        .collect();
    let mut best = Joined {
        contour: k,
        holes: Vec::new(),
        slits: Vec::new(),
        also: Vec::new(),
        as_built: false,
    };
    for &c in &candidates {
        let mut trial = best.holes.clone();
        trial.push(c);
        let joined: Vec<&[Point]> = trial.iter().map(|&h| own.pts[h]).collect();
        let rest: Vec<&[Point]> = (0..own.pts.len())
            .filter(|&h| own.hole[h] && own.arr.parent[h] == Some(k) && !trial.contains(&h))
            .map(|h| own.pts[h])
            .collect();
        let step = search_step(own.pts[c]);
        if let Some(s) = slits(own.pts[k], &joined, &rest, others, step, true) {
            best.holes = trial;
            best.slits = s;
        }
    }
    best
}

/// Contour `k` of `own` joined again with the holes of the keyhole it `started` from, by
/// slits over the mouth of `others` (the contour it links to), where the started slits lie
/// over that contour's material and the new ones clear of it; `None` where the started
/// loop serves (the region runs on through it) or no such slits are found.
///
/// A bay that closes into a hole on one slice only can open on either side through a
/// different mouth: a ring on one slice, the bay's mouth on one side of it below and on the
/// other above (abdomen surface 190: a wall 1–2 mm thick round a slot). Running on through
/// the loop whose slits cross the mouth below takes the slits, 1 mm long, across the wall
/// above while that wall's mouth opens 15 mm round the ring: the walls of the bay's two
/// sides then swap places between the slices and cross (147 faces). Ending the region there on
/// that loop and starting the next on the ring joined across the mouth above, each side's
/// walls rise to their own mouth (the two loops share the ring; each side's slits fold
/// within its own surface).
fn rekeyholed(own: &View, k: usize, started: &Joined, others: &[&[Point]]) -> Option<Joined> {
    if !started.as_built {
        return None;
    }
    let rings: Vec<&[Point]> = std::iter::once(own.pts[k])
        .chain(started.holes.iter().map(|&h| own.pts[h]))
        .collect();
    if lie_clear(&rings, &started.slits, others) {
        return None;
    }
    let again = joinable(own, k, &started.holes, others);
    // The same rings in the same order, so that either loop's feet index both; lying
    // clear, the slits differ from the started ones.
    (again.holes == started.holes && lie_clear(&rings, &again.slits, others)).then(|| Joined {
        also: started.slits.clone(),
        ..again
    })
}

/// The keyhole problem of `lower` and `upper`, their loops built as joined here.
fn keyhole_problem(lower: Joined, upper: Joined) -> Problem {
    Problem::Keyhole {
        lower: Joined {
            as_built: true,
            ..lower
        },
        upper: Joined {
            as_built: true,
            ..upper
        },
    }
}

/// Turns outer links and branchings whose contours have lone holes opening onto the other
/// side's outside into keyholes, and drops those holes' caps. Lower contours that `started`
/// from a keyhole (see [`correspond`]) are not joined; a link of one runs on through its
/// loop where all the loop's holes are lone here and open onto the upper contour's outside.
fn join_keyholes(
    problems: Vec<Problem>,
    lower: &View,
    upper: &View,
    started: &[Option<Joined>],
) -> Vec<Problem> {
    let lone = |side: Side| -> Vec<usize> {
        problems
            .iter()
            .filter_map(|p| match p {
                Problem::Cap {
                    side: s,
                    outer: None,
                    holes,
                } if *s == side => holes.first().copied(),
                _ => None,
            })
            .collect()
    };
    // Lone holes of the lower section cap above it; those of the upper one below it.
    let (lone_lower, lone_upper) = (lone(Side::Above), lone(Side::Below));
    if lone_lower.is_empty() && lone_upper.is_empty() {
        return problems;
    }
    fn pts<'a>(v: &View<'a>, ids: &[usize]) -> Vec<&'a [Point]> {
        ids.iter().map(|&k| v.pts[k]).collect()
    }
    let started_with = |i: usize| started.get(i).and_then(|s| s.as_ref());
    // The keyhole lower contour `i` starts from, if its holes all cap here and open onto the
    // outside of `others`: its region runs on through that loop.
    let through = |i: usize, others: &[&[Point]]| {
        started_with(i).filter(|j| {
            j.is_keyhole()
                && j.holes.iter().all(|h| {
                    lone_lower.contains(h)
                        && open_fraction(lower.pts[*h], others) >= MIN_OPEN_FRACTION
                })
        })
    };
    let join_lower = |i: usize, others: &[&[Point]]| {
        if started_with(i).is_some() {
            joinable(lower, i, &[], others)
        } else {
            joinable(lower, i, &lone_lower, others)
        }
    };
    let mut out: Vec<Problem> = problems
        .iter()
        .map(|p| match p {
            Problem::Link {
                hole: false,
                lower: i,
                upper: j,
                ..
            } => {
                let others = pts(upper, &[*j]);
                let up = joinable(upper, *j, &lone_upper, &pts(lower, &[*i]));
                // (Not where the upper contour starts from a keyhole itself: the region
                // would end where it starts.)
                if let (Some(k), false) = (through(*i, &others), up.is_keyhole()) {
                    return match rekeyholed(lower, *i, k, &others) {
                        Some(rekeyed) => keyhole_problem(rekeyed, up),
                        None => Problem::Link {
                            hole: false,
                            lower: *i,
                            upper: *j,
                            through: k.holes.clone(),
                        },
                    };
                }
                let lo = join_lower(*i, &others);
                if lo.is_keyhole() || up.is_keyhole() {
                    keyhole_problem(lo, up)
                } else {
                    p.clone()
                }
            }
            Problem::Branch {
                hole: false,
                lower: l,
                upper: u,
                ..
            } => {
                let (lo_pts, up_pts) = (pts(lower, l), pts(upper, u));
                let keyholes = |joined: Vec<Joined>| -> Vec<Joined> {
                    joined.into_iter().filter(Joined::is_keyhole).collect()
                };
                Problem::Branch {
                    hole: false,
                    lower: l.clone(),
                    upper: u.clone(),
                    lower_joined: keyholes(l.iter().map(|&i| join_lower(i, &up_pts)).collect()),
                    upper_joined: keyholes(
                        u.iter()
                            .map(|&j| joinable(upper, j, &lone_upper, &lo_pts))
                            .collect(),
                    ),
                }
            }
            _ => p.clone(),
        })
        .collect();
    let joined = |lower: bool| -> Vec<usize> {
        out.iter()
            .flat_map(|p| p.keyholes(lower))
            .flat_map(|j| j.holes.iter().copied())
            .collect()
    };
    let (joined_lower, joined_upper) = (joined(true), joined(false));
    out.retain(|p| match p {
        Problem::Cap {
            side,
            outer: None,
            holes,
        } => !holes.iter().any(|h| match side {
            Side::Above => joined_lower.contains(h),
            Side::Below => joined_upper.contains(h),
        }),
        _ => true,
    });
    out
}

/// Per contour of `upper`, whether it starts from a keyhole in `problems`: that keyhole
/// for its outer contour, each hole on its own.
pub fn keyholed_upper(problems: &[Problem], n: usize) -> Vec<Option<Joined>> {
    let mut started = vec![None; n];
    for j in problems.iter().flat_map(|p| p.keyholes(false)) {
        for &h in &j.holes {
            started[h] = Some(Joined {
                contour: h,
                holes: Vec::new(),
                slits: Vec::new(),
                also: Vec::new(),
                as_built: false,
            });
        }
        started[j.contour] = Some(j.clone());
    }
    started
}

/// Cap problems for the contours of `section` flagged in `free` (no counterpart on `side`).
fn caps(section: &Section, arr: &Arranged, free: &[bool], side: Side) -> Vec<Problem> {
    let mut out = Vec::new();
    for (i, c) in section.contours.iter().enumerate() {
        if !free[i] {
            continue;
        }
        if !c.hole {
            let holes = (0..free.len())
                .filter(|&h| free[h] && section.contours[h].hole && arr.parent[h] == Some(i))
                .collect();
            out.push(Problem::Cap {
                side,
                outer: Some(i),
                holes,
            });
        } else {
            let outer_free = arr.parent[i].is_some_and(|p| free[p] && !section.contours[p].hole);
            if !outer_free {
                out.push(Problem::Cap {
                    side,
                    outer: None,
                    holes: vec![i],
                });
            }
        }
    }
    out
}

/// Every contour of an end section is capped on its open side.
fn end_caps(section: &Section, side: Side) -> Vec<Problem> {
    let pts: Vec<&[Point]> = section
        .contours
        .iter()
        .map(|c| c.points.as_slice())
        .collect();
    let arr = arrange(&pts);
    caps(section, &arr, &vec![true; pts.len()], side)
}

/// The contours enclosing contour `k` of the same kind as `k`, each with the contour of the
/// other kind just inside it on the way to `k`: for an island in a hole, the outer contour
/// round that hole and the hole.
fn enclosing<'a>(
    parent: &'a [Option<usize>],
    contours: &'a [Contour],
    k: usize,
) -> impl Iterator<Item = (usize, usize)> + 'a {
    let ancestors = std::iter::successors(parent[k], move |&a| parent[a]);
    let kind = |c: usize| contours[c].hole;
    ancestors
        .clone()
        .zip(ancestors.skip(1))
        .filter(move |&(h, a)| kind(a) == kind(k) && kind(h) != kind(k))
}

/// The holes of contour `k` (its children in the nesting tree).
fn holes_of<'a>(pts: &[&'a [Point]], arr: &Arranged, k: usize) -> Vec<&'a [Point]> {
    (0..pts.len())
        .filter(|&h| arr.parent[h] == Some(k))
        .map(|h| pts[h])
        .collect()
}

struct UnionFind(Vec<usize>);

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind((0..n).collect())
    }
    fn find(&mut self, mut k: usize) -> usize {
        while self.0[k] != k {
            self.0[k] = self.0[self.0[k]];
            k = self.0[k];
        }
        k
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        // The smaller index becomes the root, so components are named by their first member.
        if ra < rb {
            self.0[rb] = ra;
        } else {
            self.0[ra] = rb;
        }
    }
}

/// `fallback_spacing` places the caps of a series that has a single section.
pub fn run(
    input: impl Iterator<Item = Result<Section>>,
    fallback_spacing: f64,
    out: Sender<Transition>,
    ctl: &Control,
) -> Result<StageStats> {
    let mut stats = StageStats {
        stage: STAGE,
        ..Default::default()
    };
    let mut prev: Option<Arc<Section>> = None;
    let mut started: Vec<Option<Joined>> = Vec::new();
    let mut spacing = fallback_spacing;
    let send = |t: Transition| out.send(t).is_ok();
    for section in input {
        ctl.check()?;
        let section = Arc::new(section?);
        if let Some(lower) = prev.take() {
            let t = Instant::now();
            spacing = section.frame.height() - lower.frame.height();
            if spacing.is_nan() || spacing <= 0.0 {
                return Err(Error::Slice {
                    stage: STAGE,
                    index: section.index,
                    source_file: section.source.clone(),
                    message: format!(
                        "sections must come in ascending height: this one is {spacing:.4} mm from the previous (slice {})",
                        lower.index
                    ),
                });
            }
            let problems = correspond(&lower, &section, &started);
            started = keyholed_upper(&problems, section.contours.len());
            stats.busy += t.elapsed();
            // The bottom caps of the first section wait for the first spacing.
            if stats.items == 1 && !send(end_transition(&lower, Side::Below, spacing)) {
                return Ok(stats);
            }
            let t = Transition {
                lower: Some(lower),
                upper: Some(section.clone()),
                spacing,
                problems,
            };
            if !send(t) {
                return Ok(stats);
            }
        }
        stats.items += 1;
        prev = Some(section);
    }
    if let Some(last) = prev {
        if stats.items == 1 && !send(end_transition(&last, Side::Below, spacing)) {
            return Ok(stats);
        }
        send(end_transition(&last, Side::Above, spacing));
    }
    Ok(stats)
}

fn end_transition(section: &Arc<Section>, side: Side, spacing: f64) -> Transition {
    let problems = end_caps(section, side);
    match side {
        Side::Below => Transition {
            lower: None,
            upper: Some(section.clone()),
            spacing,
            problems,
        },
        Side::Above => Transition {
            lower: Some(section.clone()),
            upper: None,
            spacing,
            problems,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::keyhole::Foot;
    use crate::section::{SliceFrame, SliceSource};

    fn section(index: usize, contours: Vec<(Vec<Point>, bool)>) -> Section {
        Section {
            index,
            frame: SliceFrame {
                origin: [0.0, 0.0, index as f64],
                row: [1.0, 0.0, 0.0],
                col: [0.0, 1.0, 0.0],
            },
            source: SliceSource {
                path: format!("test/{index}").into(),
                frame: None,
            },
            contours: contours
                .into_iter()
                .map(|(mut points, hole)| {
                    if (signed_area(&points) < 0.0) != hole {
                        points.reverse();
                    }
                    Contour { points, hole }
                })
                .collect(),
        }
    }

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<Point> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    /// A block with a cavity that opens through its top edge by a mouth (x 18–22).
    fn bay() -> Vec<Point> {
        vec![
            [0.0, 0.0],
            [40.0, 0.0],
            [40.0, 20.0],
            [22.0, 20.0],
            [22.0, 18.0],
            [30.0, 18.0],
            [30.0, 8.0],
            [10.0, 8.0],
            [10.0, 18.0],
            [18.0, 18.0],
            [18.0, 20.0],
            [0.0, 20.0],
        ]
    }

    fn block_with_hole() -> Section {
        section(
            1,
            vec![
                (rect(0.0, 0.0, 40.0, 20.0), false),
                (rect(10.0, 8.0, 30.0, 17.0), true),
            ],
        )
    }

    #[test]
    fn a_bay_closing_into_a_hole_is_a_keyhole_not_a_cap() {
        let (lower, upper) = (section(0, vec![(bay(), false)]), block_with_hole());
        let problems = correspond(&lower, &upper, &[]);
        let [Problem::Keyhole { lower, upper }] = problems.as_slice() else {
            panic!("{problems:?}");
        };
        assert_eq!((lower.contour, upper.contour), (0, 0));
        assert!(!lower.is_keyhole());
        assert_eq!(upper.holes, vec![1]);
        // Across the closed mouth, from the block's top edge to the hole's.
        assert_eq!((upper.slits[0].from.ring, upper.slits[0].to.ring), (0, 1));
        let started = keyholed_upper(&problems, 2);
        assert_eq!(started[0].as_ref(), Some(upper));
        // The other way up: the hole opens into the bay, the lower side is the keyhole.
        let (lower, upper) = (block_with_hole(), section(2, vec![(bay(), false)]));
        let problems = correspond(&lower, &upper, &[]);
        assert!(
            matches!(problems.as_slice(), [Problem::Keyhole { lower, upper }]
                if lower.holes == vec![1] && !upper.is_keyhole()),
            "{problems:?}"
        );
        // Unless the lower contour starts from a keyhole itself: joining other holes, the
        // hole caps alone;
        let other = Joined {
            contour: 0,
            holes: vec![2],
            slits: Vec::new(),
            also: Vec::new(),
            as_built: false,
        };
        let problems = correspond(&lower, &upper, &[Some(other), started[1].clone()]);
        assert!(
            matches!(
                problems.as_slice(),
                [Problem::Link { through, .. }, Problem::Cap { outer: None, .. }]
                    if through.is_empty()
            ),
            "{problems:?}"
        );
        // joining this one (the mouth is closed on this slice only), the region runs on
        // through that keyhole loop (branching drops the hole's cap).
        let problems = correspond(&lower, &upper, &started);
        assert!(
            matches!(
                problems.as_slice(),
                [Problem::Link { through, .. }, Problem::Cap { outer: None, holes, .. }]
                    if through == &vec![1] && holes == &vec![1]
            ),
            "{problems:?}"
        );
        assert!(problems[0].runs_through(0) && !problems[0].runs_through(1));
    }

    /// [`bay`] upside down: the mouth in the bottom edge (x 18–22, y 0–8).
    fn bay_below() -> Vec<Point> {
        vec![
            [0.0, 0.0],
            [18.0, 0.0],
            [18.0, 8.0],
            [10.0, 8.0],
            [10.0, 18.0],
            [30.0, 18.0],
            [30.0, 8.0],
            [22.0, 8.0],
            [22.0, 0.0],
            [40.0, 0.0],
            [40.0, 20.0],
            [0.0, 20.0],
        ]
    }

    #[test]
    fn a_hole_closing_mouths_on_opposite_sides_is_joined_again_across_the_one_above() {
        // The bay opens through the top edge below, through the bottom edge above.
        let (lower, middle) = (section(0, vec![(bay(), false)]), block_with_hole());
        let upper = section(2, vec![(bay_below(), false)]);
        let first = correspond(&lower, &middle, &[]);
        let started = keyholed_upper(&first, 2);
        let below = started[0].clone().expect("a keyhole");
        let problems = correspond(&middle, &upper, &started);
        let [Problem::Keyhole { lower, upper }] = problems.as_slice() else {
            panic!("{problems:?}");
        };
        assert!(!upper.is_keyhole());
        assert_eq!((lower.contour, &lower.holes), (0, &vec![1]));
        // The loop below keeps its slit; the one above is joined across the lower wall
        // (y 0–8) and carries the other's feet.
        assert_eq!(lower.also, below.slits);
        let rings = [
            middle.contours[0].points.as_slice(),
            &middle.contours[1].points,
        ];
        let foot = |f: Foot| {
            let r = rings[f.ring];
            let (a, b) = (r[f.edge], r[(f.edge + 1) % r.len()]);
            [a[0] + f.t * (b[0] - a[0]), a[1] + f.t * (b[1] - a[1])]
        };
        let (old, new) = (below.slits[0], lower.slits[0]);
        assert!(
            foot(old.from)[1] > 17.0 && foot(new.from)[1] < 8.0,
            "{old:?} {new:?}"
        );
        // With the mouth on the same side above, the region runs on through the loop.
        let problems = correspond(&middle, &section(2, vec![(bay(), false)]), &started);
        assert!(problems[0].runs_through(0), "{problems:?}");
    }

    #[test]
    fn an_island_touching_the_wall_beyond_caps_rather_than_branch_with_its_contour() {
        // A block with a cavity and an island (x 10–14) in the cavity; the next section's
        // cavity has shrunk (from x 15), so the island lies over the wall there.
        let with_island = |index| {
            section(
                index,
                vec![
                    (rect(0.0, 0.0, 40.0, 20.0), false),
                    (rect(5.0, 3.0, 35.0, 17.0), true),
                    (rect(10.0, 8.0, 14.0, 12.0), false),
                ],
            )
        };
        let walled = |index| {
            section(
                index,
                vec![
                    (rect(0.0, 0.0, 40.0, 20.0), false),
                    (rect(15.0, 3.0, 35.0, 17.0), true),
                ],
            )
        };
        let lower = with_island(0);
        let problems = correspond(&lower, &walled(1), &[]);
        assert_eq!(
            problems,
            vec![
                Problem::Link {
                    hole: false,
                    lower: 0,
                    upper: 0,
                    through: vec![]
                },
                Problem::Link {
                    hole: true,
                    lower: 1,
                    upper: 1,
                    through: vec![]
                },
                Problem::Cap {
                    side: Side::Above,
                    outer: Some(2),
                    holes: vec![]
                },
            ]
        );
        let holds = |problems: Vec<Problem>, p: Problem| {
            assert!(problems.contains(&p), "{p:?} not in {problems:?}")
        };
        let link = |lower, upper| Problem::Link {
            hole: false,
            lower,
            upper,
            through: vec![],
        };
        // The other way up, the island caps below.
        let cap = Problem::Cap {
            side: Side::Below,
            outer: Some(2),
            holes: vec![],
        };
        holds(correspond(&walled(0), &with_island(1), &[]), cap);
        // An island over an island still links to it.
        holds(correspond(&lower, &with_island(1), &[]), link(2, 2));
        // Where the hole closes into a bay on the other section, it joins its contour in a
        // keyhole, which leaves the island outside: the island branches with the contour.
        let closing = section(
            1,
            vec![
                (rect(0.0, 0.0, 40.0, 20.0), false),
                (rect(6.0, 4.0, 34.0, 17.0), true),
                (rect(7.0, 5.0, 9.0, 7.0), false),
            ],
        );
        let problems = correspond(&section(0, vec![(bay(), false)]), &closing, &[]);
        assert!(
            matches!(problems.as_slice(), [Problem::Branch { lower, upper, upper_joined, .. }]
                if lower == &vec![0] && upper == &vec![0, 2] && upper_joined[0].holes == vec![1]),
            "{problems:?}"
        );
        // And where the enclosing contour does not reach the piece over the island (the
        // block ends there but for that piece), the island goes on as that piece.
        let piece = section(1, vec![(rect(9.0, 7.0, 15.0, 13.0), false)]);
        holds(correspond(&lower, &piece, &[]), link(2, 0));
    }

    #[test]
    fn a_hole_over_the_gap_between_branches_joins_in_the_branching() {
        // Two blocks below, one above with a hole over the gap between them.
        let lower = section(
            0,
            vec![
                (rect(0.0, 0.0, 18.0, 20.0), false),
                (rect(22.0, 0.0, 40.0, 20.0), false),
            ],
        );
        let problems = correspond(&lower, &block_with_hole(), &[]);
        let [Problem::Branch {
            lower,
            upper,
            lower_joined,
            upper_joined,
            ..
        }] = problems.as_slice()
        else {
            panic!("{problems:?}");
        };
        assert_eq!(
            (lower.as_slice(), upper.as_slice()),
            (&[0, 1][..], &[0][..])
        );
        assert!(lower_joined.is_empty());
        assert_eq!(upper_joined.len(), 1);
        assert_eq!(
            (upper_joined[0].contour, &upper_joined[0].holes),
            (0, &vec![1])
        );
    }

    #[test]
    fn a_cavity_starting_inside_the_material_caps_alone() {
        let lower = section(0, vec![(rect(0.0, 0.0, 40.0, 20.0), false)]);
        let problems = correspond(&lower, &block_with_hole(), &[]);
        assert!(
            matches!(
                problems.as_slice(),
                [
                    Problem::Link { hole: false, .. },
                    Problem::Cap {
                        side: Side::Below,
                        outer: None,
                        ..
                    }
                ]
            ),
            "{problems:?}"
        );
    }
}
