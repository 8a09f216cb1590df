//! Algorithm 2 (paper §2.5, METHOD §7): all contours of one single-branching region on one
//! common knot vector, with as few control points as the binary search finds.
//!
//! In: the region's contours in order (bottom to top), each a list of points; the first and/or
//! last may be a single point (a cap; a contour whose points all coincide counts as one).
//! Out: a [`CommonFit`]: the common [`PeriodicKnotVector`], one curve per input contour on it
//! (a cap's curve has every control point equal to the cap point), each curve's max true
//! distance to its contour, and `met`.
//!
//! Steps: CLIST starts with the contours sorted by point count, largest first (the paper
//! leaves the initial order open; more points is our guess at "more complex"). N_min =
//! Algorithm 1 on CLIST's first, N_max = most points of any contour; binary search on N with
//! the invariant "N_upp feasible, its curves stored" (see [`super::fit`] for why not the
//! paper's T_pre). For a trial N, each contour gets its own domain knots (Eq. 4 / Eq. 5, or
//! resampling on its interpolant D(t) up to 2N points when it has fewer than 2N — those
//! resampled points then also serve as fitting data, since N control points cannot be fitted
//! to fewer points, and are held to the tolerance too; the paper resamples to exactly N, an
//! interpolation on knots that are not the contour's own, which can swing far off between
//! its sites); the common domain knots are their average (caps excluded;
//! [`fit_common_densest`], which the pipeline uses, spreads them as the densest contour's
//! instead). Gap filling (Fig. 5): a span of
//! the common knots holding no parameter of a contour gets two extra points of that contour's
//! polygon at 1/3 and 2/3 of the span (not at the midpoint: one point per span exactly at the
//! midpoints makes the periodic cubic collocation matrix singular for an even count). Extra
//! points are fitting data; the reported errors are measured on the contour's own points, but
//! success also needs every extra point within the tolerance. Beyond the paper, where the
//! contour creeps through such a span ([`CREEP`]) its control points there are also held
//! straight ([`super::fit::solve_lsq`]'s `straight`): where a warp stands the contour nearly
//! still over several spans, the extra points move slowly along one polygon edge between
//! points that move fast, and plain least squares rings there, the curve running back and
//! forth along the edge (abdomen surface 197: hooks 0.1–0.4 mm long in two of its curves,
//! and a pleat 2 mm wide between them in the surface).
//! The first failing contour moves to the front of CLIST.
//!
//! When N_max fails (the averaged knots suit one contour badly, or its resampled points need
//! more freedom than its own point count), the search doubles N up to 4 N_max. When even that
//! fails, the N_max fit of every contour is returned with `met = false` and the per-curve
//! errors, rather than an error: the caller decides.

use super::closed_curve::ClosedCurve;
use super::fit::{
    chord_params, clean_contour, fewest_prepared, finalize, fit_on_knots, interpolate,
    knots_approximation, knots_interpolation, polygon_at, prepare_contour, resample,
    split_combined, ContourFit, FitOptions,
};
use super::knot_vector::PeriodicKnotVector;
use super::vecops::dist;
use super::BsplineError;

/// Curves of one region on a common knot vector.
#[derive(Debug, Clone, PartialEq)]
pub struct CommonFit<const D: usize> {
    pub knots: PeriodicKnotVector,
    /// One per input contour, in input order.
    pub curves: Vec<ClosedCurve<D>>,
    /// Per input contour: max true distance of its (cleaned) points to its curve; 0 for caps.
    pub max_errors: Vec<f64>,
    /// Every contour within tolerance.
    pub met: bool,
    /// Per input contour: the cleaned points ([`super::clean_contour`]; a cap has its one
    /// point).
    pub points: Vec<Vec<[f64; D]>>,
    /// Per point: parameter of its closest point found on its curve (cap: 0). With
    /// [`SkinnedSurface::v_bar`](super::SkinnedSurface::v_bar) it seeds
    /// [`SkinnedSurface::closest_point_hint`](super::SkinnedSurface::closest_point_hint).
    pub params: Vec<Vec<f64>>,
    /// Per point: distance to that closest point, as in [`ContourFit::errors`] (true for the
    /// points deciding the maximum, an upper bound for the others; cap: 0).
    pub errors: Vec<Vec<f64>>,
    /// CLIST at the end (most recently failing contours first).
    pub clist: Vec<usize>,
}

enum Item<const D: usize> {
    Cap([f64; D]),
    Contour {
        pts: Vec<[f64; D]>,
        interp: Option<(ClosedCurve<D>, Vec<f64>)>,
        /// Chord-length fraction at common parameters (see [`fit_common_warped`]).
        warp: Option<Vec<f64>>,
    },
}

/// A contour's fitting data for one trial: points (with resampled ones), which are original,
/// chord-length parameters.
type TrialData<const D: usize> = (Vec<[f64; D]>, Vec<bool>, Vec<f64>);

enum Trial<const D: usize> {
    Ok(PeriodicKnotVector, Vec<Option<ContourFit<D>>>),
    Failed(usize),
}

/// Algorithm 2; see the module doc.
pub fn fit_common<const D: usize>(
    contours: &[Vec<[f64; D]>],
    opts: &FitOptions,
) -> Result<CommonFit<D>, BsplineError> {
    fit_common_warped(contours, &[], opts)
}

/// [`fit_common`] with the parameters of some contours warped off chord length: `warps[i]`,
/// when given, is contour i's chord-length fraction at the common parameters j / (len − 1)
/// (increasing from 0 to 1; see `geometry::alignment::chord_warps`), and each of its
/// points gets the parameter at which the table reaches the point's own fraction. Contours
/// past the end of `warps`, or with `None`, keep chord length.
pub fn fit_common_warped<const D: usize>(
    contours: &[Vec<[f64; D]>],
    warps: &[Option<Vec<f64>>],
    opts: &FitOptions,
) -> Result<CommonFit<D>, BsplineError> {
    fit_common_with(contours, warps, KnotRule::Average, opts)
}

/// [`fit_common_warped`] with the common domain knots spread as the densest of the
/// contours' own knots ([`densest_knots`]), not as their average; stage 6 fits every region
/// so. Where a warp stands a contour still over a stretch of the common parameter (a fan:
/// `geometry::alignment::fan_tables`), its own knots all fall outside that stretch, the
/// average leaves the stretch a few wide spans, and the contour moving through it cannot be
/// fitted (GE head surface 135 fanned: 14 mm off at every control-point count tried).
/// Without fans it is also more compact: each contour gets knots where it bends, rather than
/// a share of every other contour's (skull, GE head, abdomen: 3.1, 5.3 and 4.2 % fewer
/// control points than the average, crossing faces 535 → 519, 10 234 → 10 054, 2 883 →
/// 2 924).
pub fn fit_common_densest<const D: usize>(
    contours: &[Vec<[f64; D]>],
    warps: &[Option<Vec<f64>>],
    opts: &FitOptions,
) -> Result<CommonFit<D>, BsplineError> {
    fit_common_with(contours, warps, KnotRule::Densest, opts)
}

/// How a trial's common domain knots come from the contours' parameters.
#[derive(Clone, Copy, PartialEq, Eq)]
enum KnotRule {
    /// The average of each contour's own (paper §2.5).
    Average,
    /// Where the contour that moves most densely wants them ([`densest_knots`]).
    Densest,
}

fn fit_common_with<const D: usize>(
    contours: &[Vec<[f64; D]>],
    warps: &[Option<Vec<f64>>],
    rule: KnotRule,
    opts: &FitOptions,
) -> Result<CommonFit<D>, BsplineError> {
    opts.validate()?;
    let count = contours.len();
    if count == 0 {
        return Err(BsplineError::Degenerate("region has 0 contours".into()));
    }
    let ctx = |i: usize, e: BsplineError| -> BsplineError {
        let msg = format!("contour {i} of {count}: {e}");
        match e {
            BsplineError::NonFinite(_) => BsplineError::NonFinite(msg),
            _ => BsplineError::Degenerate(msg),
        }
    };
    let mut items = Vec::with_capacity(count);
    for (i, c) in contours.iter().enumerate() {
        let cleaned = clean_contour(c).map_err(|e| ctx(i, e))?;
        if cleaned.len() == 1 {
            if i != 0 && i + 1 != count {
                return Err(BsplineError::Degenerate(format!(
                    "contour {i} of {count} is a single point; caps are only allowed at either end"
                )));
            }
            items.push(Item::Cap(cleaned[0]));
        } else {
            let pts = prepare_contour(&cleaned).map_err(|e| ctx(i, e))?;
            let warp = warps.get(i).cloned().flatten().filter(|t| t.len() >= 2);
            items.push(Item::Contour {
                pts,
                interp: None,
                warp,
            });
        }
    }
    let sizes: Vec<(usize, usize)> = items
        .iter()
        .enumerate()
        .filter_map(|(i, it)| match it {
            Item::Contour { pts, .. } => Some((i, pts.len())),
            Item::Cap(_) => None,
        })
        .collect();
    if sizes.is_empty() {
        return Err(BsplineError::Degenerate(format!(
            "all {count} contours are single points"
        )));
    }
    let mut clist: Vec<usize> = sizes.iter().map(|s| s.0).collect();
    // Stable sort: ties keep input order.
    clist.sort_by_key(|&i| std::cmp::Reverse(sizes.iter().find(|s| s.0 == i).map_or(0, |s| s.1)));
    let n_max = sizes.iter().map(|s| s.1).max().unwrap_or(4);
    let n_min = match &items[clist[0]] {
        Item::Contour { pts, .. } => fewest_prepared(pts, opts)?.n_control(),
        Item::Cap(_) => 4,
    };
    let mut low = n_min - 1;
    let mut upp = n_max;
    let mut now = n_min;
    let mut best: Option<(PeriodicKnotVector, Vec<Option<ContourFit<D>>>)> = None;
    let cap = 4 * n_max;
    loop {
        match trial(&mut items, now, &clist, rule, opts, true)? {
            Trial::Ok(k, fits) => {
                upp = now;
                best = Some((k, fits));
            }
            Trial::Failed(c) => {
                if let Some(pos) = clist.iter().position(|&x| x == c) {
                    let v = clist.remove(pos);
                    clist.insert(0, v);
                }
                low = now;
            }
        }
        if upp <= low + 1 {
            if best.is_some() || low >= cap {
                break;
            }
            // N_max was presumed feasible and is not (resampled points held to the
            // tolerance can need more): test it, then double up to the cap.
            if low < upp {
                now = upp;
            } else {
                upp = (2 * upp).min(cap);
                now = upp;
            }
            continue;
        }
        now = (low + upp) / 2;
    }
    let (knots, fits) = match best {
        Some(b) => b,
        None => match trial(&mut items, n_max, &clist, rule, opts, false)? {
            Trial::Ok(k, f) => (k, f),
            Trial::Failed(c) => {
                return Err(BsplineError::Singular(format!(
                    "contour {c} of {count} cannot be fitted with {n_max} control points"
                )))
            }
        },
    };
    let mut out = CommonFit {
        knots: knots.clone(),
        curves: Vec::with_capacity(count),
        max_errors: Vec::with_capacity(count),
        met: true,
        points: Vec::with_capacity(count),
        params: Vec::with_capacity(count),
        errors: Vec::with_capacity(count),
        clist,
    };
    for (item, fit) in items.iter().zip(fits) {
        match (item, fit) {
            (Item::Cap(p), _) => {
                out.curves.push(ClosedCurve::point(knots.clone(), *p)?);
                out.max_errors.push(0.0);
                out.points.push(vec![*p]);
                out.params.push(vec![0.0]);
                out.errors.push(vec![0.0]);
            }
            (Item::Contour { .. }, Some(f)) => {
                let f = finalize(f, opts.tolerance);
                out.met &= f.met;
                out.max_errors.push(f.max_error);
                out.curves.push(f.curve);
                out.points.push(f.points);
                out.params.push(f.params);
                out.errors.push(f.errors);
            }
            (Item::Contour { .. }, None) => {
                return Err(BsplineError::Singular("a contour was not fitted".into()))
            }
        }
    }
    Ok(out)
}

/// Parameters in [0, n_control) of the closed polygon's points where the warp `table` (chord
/// fraction at common parameters j / (len − 1), increasing) reaches each point's chord
/// fraction: linear between the table's entries.
fn warped_params<const D: usize>(points: &[[f64; D]], n_control: usize, table: &[f64]) -> Vec<f64> {
    let last = table.len() - 1;
    chord_params(points, 1)
        .into_iter()
        .map(|f| {
            let j = table.partition_point(|&x| x <= f).clamp(1, last);
            let (a, b) = (table[j - 1], table[j]);
            let t = if b > a {
                ((f - a) / (b - a)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            n_control as f64 * ((j - 1) as f64 + t) / last as f64
        })
        .collect()
}

/// Cells per span of the grid on which [`densest_knots`] takes the densest contour's knots.
const DENSITY_CELLS: usize = 8;

/// Half-width, in cells, of the box filter over [`densest_knots`]' weights: one span each
/// side. The bare maximum jumps wherever the densest contour changes, and knots bunched
/// against a jump let the curves ripple there (no smoothing: crossing faces 568, 9 984 and
/// 3 107 on the skull, GE head and abdomen; ±½ span 537, 9 971, 3 143; ±1 span 519, 10 054,
/// 2 924 for 3–5 % fewer control points than the average; ±2 spans 511, 10 058, 2 904 but no
/// fewer control points on the skull).
const DENSITY_SMOOTHING: usize = DENSITY_CELLS;

/// `n1` domain knots spread as the densest of the contours' own knots at each parameter: on
/// a grid of [`DENSITY_CELLS`] cells per span, each cell weighs the most knots per unit
/// parameter any contour's own knots have there, the weights are smoothed periodically over
/// [`DENSITY_SMOOTHING`] cells each side, and the knots divide them evenly.
/// Every contour then gets knots where it moves, in proportion to its own need, however
/// many other contours stand still there (summing the contours' parameters instead let the
/// many loops moving together above a fanning pair outweigh it: GE head surface 233, 17
/// loops, 5 mm off at every count).
fn densest_knots(
    owns: &[PeriodicKnotVector],
    n1: usize,
) -> Result<PeriodicKnotVector, BsplineError> {
    let cells = DENSITY_CELLS * n1;
    let width = n1 as f64 / cells as f64;
    let mut weight = vec![0.0f64; cells];
    for own in owns {
        let d = own.domain();
        let mut span = 0;
        for (c, w) in weight.iter_mut().enumerate() {
            let mid = (c as f64 + 0.5) * width;
            while span + 2 < d.len() && d[span + 1] <= mid {
                span += 1;
            }
            let density = 1.0 / (d[span + 1] - d[span]).max(1e-12);
            *w = w.max(density);
        }
    }
    let weight = box_filter(&weight, DENSITY_SMOOTHING);
    let total: f64 = weight.iter().sum();
    let mut domain = Vec::with_capacity(n1 + 1);
    domain.push(0.0);
    let (mut acc, mut c) = (0.0, 0);
    for j in 1..n1 {
        let target = total * j as f64 / n1 as f64;
        while c < cells && acc + weight[c] < target {
            acc += weight[c];
            c += 1;
        }
        let f = if c < cells {
            (target - acc) / weight[c]
        } else {
            1.0
        };
        let at = ((c as f64 + f.clamp(0.0, 1.0)) * width).max(domain[j - 1] + 1e-9 * width);
        domain.push(at);
    }
    domain.push(n1 as f64);
    PeriodicKnotVector::try_new(&domain)
}

/// The periodic running mean of `w` over `half` entries each side.
fn box_filter(w: &[f64], half: usize) -> Vec<f64> {
    let n = w.len();
    let width = (2 * half + 1) as f64;
    (0..n)
        .map(|c| {
            (0..=2 * half)
                .map(|k| w[(c + k + n * (half / n + 1) - half) % n])
                .sum::<f64>()
                / width
        })
        .collect()
}

/// An empty span whose stretch of the polygon is shorter than this fraction of the mean
/// span's (perimeter / N) is one where a warp makes the contour creep, and its control
/// points are held straight. At chord length every span has the mean pace, and so do most
/// spans emptied only by knots the other contours need: there the extra points alone keep
/// the curve on its edge. Holding every empty span straight gave the same abdomen and GE
/// head but took the skull at `--chordal 0.4` from 0 to 2 crossing faces.
const CREEP: f64 = 0.5;

/// Fitting data per control point a contour of a region gets at least (see [`trial`]).
const OVERSAMPLE: usize = 2;

/// One trial of Algorithm 2 with `n1` control points: common knots, gap filling, fits in
/// CLIST order. With `early_exit`, stops at the first contour missing the tolerance (or whose
/// system is singular); without it, fits all and fails only on a singular system.
fn trial<const D: usize>(
    items: &mut [Item<D>],
    n1: usize,
    clist: &[usize],
    rule: KnotRule,
    opts: &FitOptions,
    early_exit: bool,
) -> Result<Trial<D>, BsplineError> {
    // Per contour: fitting data (combined), which entries are original, params, own knots.
    let mut data: Vec<Option<TrialData<D>>> = Vec::with_capacity(items.len());
    let mut owns: Vec<PeriodicKnotVector> = Vec::new();
    for item in items.iter_mut() {
        match item {
            Item::Cap(_) => data.push(None),
            Item::Contour { pts, interp, warp } => {
                // Fewer than 2N points: resample D(t) up to 2N, so the fit on the averaged
                // (not the contour's own) knots is least squares with data in every span;
                // resampling to exactly N made it an interpolation whose sites could sit
                // badly against those knots and swing far off between them.
                let (combined, orig) = if pts.len() >= OVERSAMPLE * n1 {
                    (pts.clone(), vec![true; pts.len()])
                } else {
                    if interp.is_none() {
                        *interp = Some(interpolate(pts)?);
                    }
                    match interp {
                        Some(i) => resample(pts, i, OVERSAMPLE * n1),
                        None => return Err(BsplineError::Singular("no interpolant".into())),
                    }
                };
                let u = match warp {
                    Some(table) => warped_params(&combined, n1, table),
                    None => chord_params(&combined, n1),
                };
                let own = if combined.len() == n1 {
                    knots_interpolation(&u, n1)?
                } else {
                    knots_approximation(&u, n1)?
                };
                owns.push(own);
                data.push(Some((combined, orig, u)));
            }
        }
    }
    let knots = match rule {
        KnotRule::Average => {
            let mut sum = vec![0.0f64; n1 + 1];
            for own in &owns {
                for (s, k) in sum.iter_mut().zip(own.domain()) {
                    *s += k;
                }
            }
            let domain: Vec<f64> = sum.iter().map(|s| s / owns.len() as f64).collect();
            PeriodicKnotVector::try_new(&domain)?
        }
        KnotRule::Densest => densest_knots(&owns, n1)?,
    };
    let dom = knots.domain();
    let mut fits: Vec<Option<ContourFit<D>>> = (0..items.len()).map(|_| None).collect();
    for &i in clist {
        let (pts, (combined, orig, u)) = match (&items[i], &data[i]) {
            (Item::Contour { pts, .. }, Some(d)) => (pts, d),
            _ => continue,
        };
        let (po, mut ex) = split_combined(combined, orig, u);
        // Gap filling (Fig. 5); where the contour creeps through an empty span, the control
        // points of its two second differences there are held straight (by first index).
        let mut straight = vec![false; n1];
        let perimeter: f64 = (0..combined.len())
            .map(|k| dist(&combined[k], &combined[(k + 1) % combined.len()]))
            .sum();
        let creeping = CREEP * perimeter / n1 as f64;
        let at = |t: f64| polygon_at(combined, u, n1 as f64, t);
        let mut j = 0usize;
        for s in 0..n1 {
            let (a, b) = (dom[s], dom[s + 1]);
            while j < u.len() && u[j] < a {
                j += 1;
            }
            if !(j < u.len() && u[j] < b) {
                if dist(&at(a), &at(b)) / (b - a) < creeping {
                    straight[s] = true;
                    straight[(s + 1) % n1] = true;
                }
                for f in [1.0 / 3.0, 2.0 / 3.0] {
                    let t = a + (b - a) * f;
                    ex.push((at(t), t));
                }
            }
        }
        let straight: Vec<usize> = (0..n1).filter(|&k| straight[k]).collect();
        match fit_on_knots(pts, &po, &ex, &straight, &knots, opts) {
            Ok(f) => {
                if early_exit && !f.met {
                    return Ok(Trial::Failed(i));
                }
                fits[i] = Some(f);
            }
            Err(BsplineError::Singular(_)) if early_exit => return Ok(Trial::Failed(i)),
            Err(e) => return Err(e),
        }
    }
    Ok(Trial::Ok(knots, fits))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_filter_keeps_the_total_and_wraps_round() {
        let w = [4.0, 0.0, 0.0, 0.0, 0.0, 2.0];
        let s = box_filter(&w, 1);
        assert!((s.iter().sum::<f64>() - 6.0).abs() < 1e-12);
        // Entry 0 spreads to 5, 0 and 1; entry 5 to 4, 5 and 0.
        let want = [2.0, 4.0 / 3.0, 0.0, 0.0, 2.0 / 3.0, 2.0];
        assert!(
            s.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12),
            "{s:?}"
        );
        // Wider than the ring: the window wraps round it (entry 0 sees 2, 1, 2, 1, 2, 1, 2),
        // and the total is still kept.
        let wide = box_filter(&[1.0, 2.0], 3);
        assert!((wide[0] - 11.0 / 7.0).abs() < 1e-12, "{wide:?}");
        assert!((wide[1] - 10.0 / 7.0).abs() < 1e-12, "{wide:?}");
    }

    #[test]
    fn densest_knots_follow_the_contour_that_needs_them() {
        // One contour wants its knots in the first half, the other in the second: the
        // common knots are dense in both halves, strictly increasing, and end at n1.
        let n1 = 16;
        let lo: Vec<f64> = (0..=n1)
            .map(|j| {
                let t = j as f64 / n1 as f64;
                n1 as f64
                    * if t < 0.75 {
                        t * 2.0 / 3.0
                    } else {
                        0.5 + (t - 0.75) * 2.0
                    }
            })
            .collect();
        let hi: Vec<f64> = lo.iter().rev().map(|k| n1 as f64 - k).collect();
        let owns = [lo, hi].map(|d| PeriodicKnotVector::try_new(&d).unwrap());
        let k = densest_knots(&owns, n1).unwrap();
        let d = k.domain();
        assert_eq!(d.len(), n1 + 1);
        assert_eq!((d[0], d[n1]), (0.0, n1 as f64));
        assert!(d.windows(2).all(|w| w[1] > w[0]));
        // Each own vector puts 12 of its 16 spans in its dense half: the common vector, as
        // dense as either wherever either is dense, splits its spans evenly between halves.
        let first = d
            .iter()
            .filter(|&&x| x > 0.0 && x < n1 as f64 / 2.0)
            .count();
        assert!((7..=9).contains(&first), "{d:?}");
    }
}
