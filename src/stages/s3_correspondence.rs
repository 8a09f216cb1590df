//! Stage 3: correspondence by overlap (METHOD.md §2). Sections arrive in ascending height;
//! for each adjacent pair this stage links contours whose regions overlap (projected along
//! the normal), and splits the overlap graph into branching problems: 1-to-1 links, m-to-n
//! branchings, and caps (a contour with no counterpart). Outer contours link by their
//! material (outer minus its holes); holes link to holes by the voids they bound.
//!
//! Only two sections are alive here at a time; each leaves inside the transitions that need
//! it and is dropped after the next one arrives.

use std::sync::Arc;
use std::time::Instant;

use crossbeam_channel::Sender;

use super::{Control, StageStats};
use crate::geometry::contours::nesting;
use crate::geometry::overlap::{regions_overlap, Region as Material};
use crate::geometry::polygon::{bbox, Point};
use crate::section::Section;
use crate::{Error, Result};

pub const STAGE: &str = "correspondence";

/// Which side of a section a cap closes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Below,
    Above,
}

/// One problem between two adjacent sections. Indices are contour indices in their section.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Problem {
    /// One contour below continues as one contour above.
    Link {
        hole: bool,
        lower: usize,
        upper: usize,
    },
    /// m contours below and n above form one connected component with m + n ≥ 3.
    Branch {
        hole: bool,
        lower: Vec<usize>,
        upper: Vec<usize>,
    },
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

/// The problems between `lower` and `upper` (both present).
pub fn correspond(lower: &Section, upper: &Section) -> Vec<Problem> {
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
    // Union–find over lower contours 0..m and upper contours m..m+n.
    let mut uf = UnionFind::new(m + up.len());
    let mut linked = vec![false; m + up.len()];
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
                uf.union(i, m + j);
                linked[i] = true;
                linked[m + j] = true;
            }
        }
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
            }
        } else {
            Problem::Branch {
                hole,
                lower: lower_ids,
                upper: upper_ids,
            }
        });
    }
    let ending: Vec<bool> = (0..m).map(|i| !linked[i]).collect();
    problems.extend(caps(lower, &la, &ending, Side::Above));
    let starting: Vec<bool> = (0..up.len()).map(|j| !linked[m + j]).collect();
    problems.extend(caps(upper, &ua, &starting, Side::Below));
    problems
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
            let problems = correspond(&lower, &section);
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
