//! Fanning joins (`geometry::alignment::fan_match`, `fan_tables`): two notched loops where
//! one has a long thin hooked finger the other lacks. Chord length spreads the finger's walls
//! along the whole other loop, its notches drift apart, and the surface between them crosses
//! itself; the fan joins the finger to the
//! points at its root, and the fitted, skinned and meshed surface (`fit_common_densest`, the
//! mesher's arc-length projection of the end loops) does not cross itself. Stacked under
//! more loops, the fan would stand them all still: the region is cut into segments instead
//! (`stages::s6_fitting::fit_segments`).

use bskin::bspline::common_knots::fit_common_densest;
use bskin::bspline::fit::FitOptions;
use bskin::bspline::skinning::{skin_ends, SkinEnd};
use bskin::geometry::alignment::{align_starts, chord_join_folds, fan_match, fan_tables};
use bskin::mesh::crossings::crossing_faces;
use bskin::mesh::{tessellate_each, RowLoops};
use bskin::region::{CurveOrigin, Region, RegionCurve};
use bskin::stages::s6_fitting;
use bskin::stages::s7_skinning::{crossings_of, crossings_of_all};

type P2 = [f64; 2];
type P3 = [f64; 3];

/// A circle of radius 20 mm, counter-clockwise from +x, with a notch 8 mm deep and 6° wide
/// at each angle of `notches` (degrees): radial walls, points every 0.5°.
fn notched(notches: &[f64]) -> Vec<P2> {
    let at = |r: f64, deg: f64| -> P2 {
        let t = deg.to_radians();
        [r * t.cos(), r * t.sin()]
    };
    let mut out = Vec::new();
    for k in 0..720 {
        let deg = k as f64 * 0.5;
        let inside = |d: f64| notches.iter().any(|&n| (d - n).abs() < 3.0);
        if inside(deg) && !inside(deg - 0.5) {
            out.push(at(20.0, deg));
        }
        out.push(at(if inside(deg) { 12.0 } else { 20.0 }, deg));
        if inside(deg) && !inside(deg + 0.5) {
            out.push(at(20.0, deg));
        }
    }
    out
}

fn circle() -> Vec<P2> {
    notched(&NOTCHES)
}

const NOTCHES: [f64; 5] = [20.0, 80.0, 180.0, 240.0, 300.0];

/// The circle with a finger `width` mm wide leaving it at angle 120°: `out` mm straight out,
/// then `hook` mm turned a right angle counter-clockwise, its walls sampled every millimetre.
fn fingered(width: f64, out: f64, hook: f64) -> Vec<P2> {
    let dir = [(120f64).to_radians().cos(), (120f64).to_radians().sin()];
    let side = [-dir[1], dir[0]];
    let on_finger = |p: &P2| (p[0] * side[0] + p[1] * side[1]).abs() < width / 2.0;
    let ahead = |p: &P2| p[0] * dir[0] + p[1] * dir[1] > 0.0;
    let c = circle();
    let gap = c.iter().position(|p| ahead(p) && on_finger(p)).unwrap();
    let after = gap + c[gap..].iter().take_while(|p| on_finger(p)).count();
    // The centre line: from the root out along `dir`, then along `side`; each point with
    // the unit normal its walls are offset along (mitred at the corner).
    let root = (20.0f64.powi(2) - (width / 2.0).powi(2)).sqrt();
    let mut centre: Vec<(P2, P2)> = Vec::new();
    let (n_out, n_hook) = (out.round() as usize, hook.round() as usize);
    // Straight samples stop, and the hook's start, a wall's width from the corner, so that
    // the inner wall does not run back past its mitre.
    for s in 0..n_out {
        let a = root + (out - root) * s as f64 / n_out as f64;
        if a < out - width {
            centre.push(([a * dir[0], a * dir[1]], side));
        }
    }
    let corner = [out * dir[0], out * dir[1]];
    let mitre = [side[0] - dir[0], side[1] - dir[1]];
    centre.push((corner, mitre));
    for s in 1..=n_hook {
        let a = hook * s as f64 / n_hook as f64;
        if a < width {
            continue;
        }
        centre.push((
            [corner[0] + a * side[0], corner[1] + a * side[1]],
            [-dir[0], -dir[1]],
        ));
    }
    let wall = |(c, n): &(P2, P2), sign: f64| -> P2 {
        [
            c[0] + sign * width / 2.0 * n[0],
            c[1] + sign * width / 2.0 * n[1],
        ]
    };
    let mut loop_ = c[..gap].to_vec();
    // Counter-clockwise: out along the wall on the −side, back along the +side.
    loop_.extend(centre.iter().map(|c| wall(c, -1.0)));
    loop_.extend(centre.iter().rev().map(|c| wall(c, 1.0)));
    loop_.extend_from_slice(&c[after..]);
    loop_
}

fn lift(l: &[P2], z: f64) -> Vec<P3> {
    l.iter().map(|p| [p[0], p[1], z]).collect()
}

/// The notched circle and the one with a hooked finger, started as stage 5 starts them
/// (`align_starts`).
fn loops() -> (Vec<P2>, Vec<P2>) {
    let (mut a, mut b) = (circle(), fingered(3.0, 40.0, 60.0));
    let starts = align_starts(&[&lift(&a, 0.0), &lift(&b, 2.0)], 0.125);
    a.rotate_left(starts[0]);
    b.rotate_left(starts[1]);
    (a, b)
}

#[test]
fn a_fan_joins_a_finger_the_other_loop_lacks_without_crossing() {
    let (a, b) = loops();
    assert!(
        chord_join_folds(&a, &b),
        "chord length should fold this join"
    );
    let m = fan_match(&a, &b, f64::INFINITY).unwrap();
    assert_eq!(m.blends, 0);
    assert_eq!(m.path.first(), Some(&(0.0, 0.0)));
    assert_eq!(m.path.last(), Some(&(1.0, 1.0)));
    for w in m.path.windows(2) {
        let (da, db) = (w[1].0 - w[0].0, w[1].1 - w[0].1);
        assert!(da >= 0.0 && db >= 0.0 && da + db > 0.0, "{w:?}");
    }
    // The finger's 120 mm of wall is joined to a stretch of the circle a few millimetres
    // long: somewhere the circle stands still while the finger's loop moves on.
    let still = m.path.windows(2).filter(|w| w[1].0 == w[0].0).count();
    assert!(still > 100, "{still} steps with the circle standing still");
}

#[test]
fn a_fan_keeps_its_rulings_within_the_slack_of_the_shortest() {
    let (a, b) = loops();
    let shortest = fan_match(&a, &b, 1.0).unwrap();
    let any = fan_match(&a, &b, f64::INFINITY).unwrap();
    assert!(any.blends <= shortest.blends);
    assert!(shortest.length <= any.length);
    for slack in [1.0, 1.1, 1.5, 2.0, 4.0] {
        let m = fan_match(&a, &b, slack).unwrap();
        assert!(
            m.length <= slack * shortest.length + 1e-9,
            "slack {slack}: rulings {} mm, shortest {} mm",
            m.length,
            shortest.length
        );
        assert!(m.blends <= shortest.blends, "slack {slack}");
    }
}

#[test]
fn fanned_surface_fits_and_meshes_without_crossing_itself() {
    let (a, b) = loops();
    let fans = fan_tables(&[Some(a.clone()), Some(b.clone())], f64::INFINITY, &[]).unwrap();
    assert_eq!(fans.starts[0], 0);
    // One join: its match's blend crossings are the region's.
    let m = fan_match(&a, &b, f64::INFINITY).unwrap();
    assert_eq!(fans.blends, m.blends);
    for t in fans.tables.iter().flatten() {
        assert_eq!((t[0], t[t.len() - 1]), (0.0, 1.0));
        assert!(t.windows(2).all(|w| w[1] >= w[0]));
    }
    let mut b = b;
    b.rotate_left(fans.starts[1]);
    let (lo, hi) = (lift(&a, 0.0), lift(&b, 2.0));
    let opts = FitOptions::new(0.5);
    let fanned = fit_common_densest(&[lo.clone(), hi.clone()], &fans.tables, &opts).unwrap();
    assert!(fanned.met, "errors {:?}", fanned.max_errors);
    let chord = fit_common_densest(&[lo.clone(), hi.clone()], &[], &opts).unwrap();
    let faces = |curves| {
        let s = skin_ends(curves, [SkinEnd::Free, SkinEnd::Free]).unwrap();
        let mut out = Vec::new();
        tessellate_each(&s, &lo, &hi, 0.2, RowLoops::Keep, |t| out.push(t));
        crossing_faces(&out)
    };
    let (f, c) = (faces(&fanned.curves), faces(&chord.curves));
    assert!(c > 0, "chord length should cross itself here");
    assert_eq!(
        f, 0,
        "fanned surface crosses itself ({c} faces at chord length)"
    );
}

#[test]
fn three_loops_fan_where_their_joins_fold_and_keep_chord_length_elsewhere() {
    let (a, b) = loops();
    // a → b folds; b → b (the same loop again) does not.
    let fans = fan_tables(
        &[Some(a), Some(b.clone()), Some(b), None],
        f64::INFINITY,
        &[],
    )
    .unwrap();
    assert_eq!(fans.starts.len(), 4);
    assert!(fans.tables[3].is_none());
    let (t1, t2) = (
        fans.tables[1].as_ref().unwrap(),
        fans.tables[2].as_ref().unwrap(),
    );
    // Loop 2 is joined to loop 1 at chord length: the same fractions, from the same point
    // (wherever the fan started loop 1, loop 2 follows it).
    assert_eq!(fans.starts[2], fans.starts[1]);
    assert!(t1.iter().zip(t2).all(|(x, y)| (x - y).abs() < 1e-12));
    assert!(fans.tables[0]
        .as_ref()
        .unwrap()
        .windows(2)
        .any(|w| w[1] == w[0]));
}

#[test]
fn a_join_chord_length_does_not_fold_is_fanned_when_asked() {
    let (_, b) = loops();
    let pair = [Some(b.clone()), Some(b)];
    // Stage 6 asks where the fitted surface's band crosses though chord length does not fold.
    assert!(fan_tables(&pair, f64::INFINITY, &[]).is_none());
    assert!(fan_tables(&pair, f64::INFINITY, &[false]).is_none());
    let fans = fan_tables(&pair, f64::INFINITY, &[true]).expect("asked join fanned");
    for t in fans.tables.iter() {
        let t = t.as_ref().unwrap();
        assert_eq!((t[0], t[t.len() - 1]), (0.0, 1.0));
        assert!(t.windows(2).all(|w| w[1] >= w[0]));
    }
}

/// A region of five loops 2 mm apart: the fingered circle, then the notched circle four
/// times, each a little smaller and turned a little further than the one below, started as
/// stage 5 starts them.
fn fingered_stack() -> Region {
    let (a, b) = (fingered(3.0, 40.0, 60.0), circle());
    let mut loops: Vec<Vec<P3>> = (0..5)
        .map(|k| {
            if k == 0 {
                return lift(&a, 0.0);
            }
            let (scale, turn) = (1.0 - 0.04 * k as f64, (4.0 * k as f64).to_radians());
            let (c, s) = (turn.cos(), turn.sin());
            let l: Vec<P2> = b
                .iter()
                .map(|p| [scale * (c * p[0] - s * p[1]), scale * (s * p[0] + c * p[1])])
                .collect();
            lift(&l, 2.0 * k as f64)
        })
        .collect();
    let starts = align_starts(&loops.iter().map(Vec::as_slice).collect::<Vec<_>>(), 0.125);
    for (l, s) in loops.iter_mut().zip(starts) {
        l.rotate_left(s);
    }
    let curves = loops
        .into_iter()
        .enumerate()
        .map(|(k, points)| RegionCurve {
            points,
            origin: CurveOrigin::Contour {
                slice: k,
                contour: 0,
            },
        })
        .collect();
    Region {
        id: 7,
        hole: false,
        curves,
        seal: Vec::new(),
        seal_points: Vec::new(),
        shared_edges: Vec::new(),
        joint_below: false,
        inserted: [3, 2],
    }
}

#[test]
fn a_region_is_cut_where_its_join_folds_and_its_segments_cross_less() {
    let region = fingered_stack();
    let opts = FitOptions::new(0.5);
    let whole = s6_fitting::fit(region.clone(), &opts).unwrap();
    let before = crossings_of(&whole, opts.tolerance).own;
    assert!(before > 0, "the whole surface should cross itself here");
    let segments = s6_fitting::fit_segments(region.clone(), &opts).unwrap();
    // The folding join (finger → circle) is a segment of its own; the bands above, which
    // its fan stood still and tangled, are cut too.
    assert!(segments.len() >= 2, "{} segments", segments.len());
    assert_eq!(segments[0].region.curves.len(), 2);
    let after = crossings_of_all(&segments, opts.tolerance).own;
    assert!(
        after < before,
        "segments {after} crossing faces, whole {before}"
    );
    assert!(segments.iter().all(|s| s.fit.met));
    // Consecutive segments meet on the joint loop's own points (each may start it
    // elsewhere), and every input point still counts once.
    let sorted = |c: &RegionCurve| {
        let mut p: Vec<String> = c.points.iter().map(|p| format!("{p:?}")).collect();
        p.sort();
        p
    };
    for w in segments.windows(2) {
        let (lower, upper) = (&w[0].region, &w[1].region);
        assert_eq!(
            sorted(&lower.curves[lower.curves.len() - 1]),
            sorted(&upper.curves[0])
        );
        assert!(upper.joint_below);
    }
    assert!(!segments[0].region.joint_below);
    let curves: usize = segments.iter().map(|s| s.region.curves.len() - 1).sum();
    assert_eq!(curves + 1, region.curves.len());
    let points: usize = segments.iter().map(|s| s.region.input_points()).sum();
    assert_eq!(points, region.input_points());
}

#[test]
fn a_region_split_shares_its_joints_and_keeps_its_end_insertions() {
    let mut region = fingered_stack();
    // A seal triangle in each end loop's plane (z = 0 and z = 8).
    let flat = |z: f64| [[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]];
    region.seal = vec![flat(8.0), flat(0.0)];
    let parts = region.split_at(&[3, 1, 0, 4, 1]);
    let spans: Vec<(usize, usize)> = parts
        .iter()
        .map(
            |p| match (p.curves[0].origin, p.curves[p.curves.len() - 1].origin) {
                (CurveOrigin::Contour { slice: a, .. }, CurveOrigin::Contour { slice: b, .. }) => {
                    (a, b)
                }
                _ => unreachable!(),
            },
        )
        .collect();
    assert_eq!(spans, [(0, 1), (1, 3), (3, 4)]);
    assert_eq!(
        parts.iter().map(|p| p.inserted).collect::<Vec<_>>(),
        [[3, 0], [0, 0], [0, 2]]
    );
    assert_eq!(
        parts.iter().map(|p| p.joint_below).collect::<Vec<_>>(),
        [false, true, true]
    );
    assert_eq!(parts[0].seal, vec![flat(0.0)]);
    assert!(parts[1].seal.is_empty());
    assert_eq!(parts[2].seal, vec![flat(8.0)]);
    let total: usize = parts.iter().map(Region::input_points).sum();
    assert_eq!(total, region.input_points());
    assert_eq!(region.split_at(&[]), vec![region.clone()]);
}
