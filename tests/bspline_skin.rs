//! Skinning: the surface reproduces each curve at its v̄_k, meets the end-tangent conditions,
//! closes smoothly onto caps; partials and the closest point against references.

#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

#[path = "bspline_helpers.rs"]
mod helpers;

use bskin::bspline::{
    fit_common, skin, skin_ends, ClosedCurve, FitOptions, SkinEnd, SkinnedSurface,
};
use helpers::{dist, ellipse, lift, star};
use proptest::prelude::*;

fn region(sizes: &[usize], seed: u64, caps: (bool, bool)) -> (Vec<ClosedCurve<3>>, f64) {
    let mut contours: Vec<Vec<[f64; 3]>> = sizes
        .iter()
        .enumerate()
        .map(|(k, &m)| {
            lift(
                &star(m, 20.0 + 2.0 * (k as f64).sin(), 0.02, seed + k as u64),
                3.0 * (k + 1) as f64,
            )
        })
        .collect();
    if caps.0 {
        contours.insert(0, vec![[0.3, -0.2, 1.5]]);
    }
    if caps.1 {
        let z = 3.0 * (sizes.len() + 1) as f64 - 1.5;
        contours.push(vec![[-0.1, 0.4, z]]);
    }
    let f = fit_common(&contours, &FitOptions::new(0.05)).unwrap();
    (f.curves, 0.05)
}

fn sv_start_expected(curves: &[ClosedCurve<3>], vb: &[f64], i: usize, end: bool) -> [f64; 3] {
    let r = curves.len() - 1;
    let b = |k: usize| curves[k].control()[i];
    let sub = |a: [f64; 3], c: [f64; 3], h: f64| -> [f64; 3] {
        std::array::from_fn(|x| (a[x] - c[x]) / h)
    };
    if r == 1 {
        return sub(b(1), b(0), vb[1] - vb[0]);
    }
    if !end {
        let (h1, h2) = (vb[1] - vb[0], vb[2] - vb[1]);
        let (d1, d2) = (sub(b(1), b(0), h1), sub(b(2), b(1), h2));
        std::array::from_fn(|x| ((2.0 * h1 + h2) * d1[x] - h1 * d2[x]) / (h1 + h2))
    } else {
        let (h1, h2) = (vb[r - 1] - vb[r - 2], vb[r] - vb[r - 1]);
        let (d1, d2) = (sub(b(r - 1), b(r - 2), h1), sub(b(r), b(r - 1), h2));
        std::array::from_fn(|x| ((2.0 * h2 + h1) * d2[x] - h2 * d1[x]) / (h1 + h2))
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn surface_interpolates_curves_and_end_tangents(
        sizes in prop::collection::vec(8usize..200, 2..7),
        seed in 0u64..1_000_000,
    ) {
        let (curves, _) = region(&sizes, seed, (false, false));
        let s = skin(&curves).unwrap();
        let r = curves.len() - 1;
        prop_assert_eq!(s.n_u(), curves[0].control().len());
        prop_assert_eq!(s.n_v(), r + 3);
        let vb = s.v_bar().to_vec();
        prop_assert_eq!(vb.len(), r + 1);
        prop_assert!(vb[0] == 0.0 && vb[r] == r as f64);
        let n1 = s.n_u();
        for (k, c) in curves.iter().enumerate() {
            for q in 0..50 {
                let u = n1 as f64 * q as f64 / 50.0;
                let e = dist(&s.eval(u, vb[k]), &c.eval(u));
                prop_assert!(e < 1e-9, "curve {k} at u = {u}: {e}");
            }
        }
        // End conditions on the control net: V_{i,1} − V_{i,0} = (v_1/3) T_{i,0}, etc.
        let vk = s.v_knots().knots();
        let (v1, vr1) = (vk[4], vk[vk.len() - 5]);
        for i in 0..n1 {
            let t0 = sv_start_expected(&curves, &vb, i, false);
            let tr = sv_start_expected(&curves, &vb, i, true);
            let d0: [f64; 3] = std::array::from_fn(|x| (s.control_point(i, 1)[x] - s.control_point(i, 0)[x]) * 3.0 / v1);
            let dr: [f64; 3] = std::array::from_fn(|x| (s.control_point(i, r + 2)[x] - s.control_point(i, r + 1)[x]) * 3.0 / (r as f64 - vr1));
            prop_assert!(dist(&d0, &t0) < 1e-8 * (1.0 + dist(&t0, &[0.0; 3])));
            prop_assert!(dist(&dr, &tr) < 1e-8 * (1.0 + dist(&tr, &[0.0; 3])));
        }
        // S_v along the boundary is the B-spline of the end tangents.
        let t0c: Vec<[f64; 3]> = (0..n1).map(|i| sv_start_expected(&curves, &vb, i, false)).collect();
        let tcurve = ClosedCurve::try_new(s.u_knots().clone(), t0c).unwrap();
        for q in 0..20 {
            let u = n1 as f64 * q as f64 / 20.0;
            let (_, _, sv) = s.partials(u, 0.0);
            let e = tcurve.eval(u);
            prop_assert!(dist(&sv, &e) < 1e-7 * (1.0 + dist(&e, &[0.0; 3])));
        }
    }

    /// Partial derivatives against central differences.
    #[test]
    fn partials_match_finite_differences(seed in 0u64..1_000_000, uf in 0.0f64..1.0, vf in 0.02f64..0.98) {
        let (curves, _) = region(&[40, 60, 50, 30], seed, (false, false));
        let s = skin(&curves).unwrap();
        let (u, v) = (uf * s.n_u() as f64, vf * 3.0);
        let h = 1e-5;
        let (_, su, sv) = s.partials(u, v);
        let fu: [f64; 3] = std::array::from_fn(|x| (s.eval(u + h, v)[x] - s.eval(u - h, v)[x]) / (2.0 * h));
        let fv: [f64; 3] = std::array::from_fn(|x| (s.eval(u, v + h)[x] - s.eval(u, v - h)[x]) / (2.0 * h));
        prop_assert!(dist(&su, &fu) < 1e-5 * (1.0 + dist(&su, &[0.0; 3])));
        prop_assert!(dist(&sv, &fv) < 1e-5 * (1.0 + dist(&sv, &[0.0; 3])));
        let d = s.derivs2(u, v);
        let (_, su2, sv2) = s.partials(u + h, v);
        let (_, su1, sv1) = s.partials(u - h, v);
        let fuu: [f64; 3] = std::array::from_fn(|x| (su2[x] - su1[x]) / (2.0 * h));
        let fuv: [f64; 3] = std::array::from_fn(|x| (sv2[x] - sv1[x]) / (2.0 * h));
        prop_assert!(dist(&d[3], &fuu) < 1e-3 * (1.0 + dist(&d[3], &[0.0; 3])));
        prop_assert!(dist(&d[4], &fuv) < 1e-3 * (1.0 + dist(&d[4], &[0.0; 3])));
    }

    /// Closest point: never worse than a dense sample grid, and exact for points offset along
    /// the normal from a surface point.
    #[test]
    fn closest_point_is_global(seed in 0u64..1_000_000, px in -30.0f64..30.0, py in -30.0f64..30.0, pz in 0.0f64..15.0) {
        let (curves, _) = region(&[30, 40, 30], seed, (true, false));
        let s = skin(&curves).unwrap();
        let p = [px, py, pz];
        let (d, u, v) = s.closest_point(&p);
        prop_assert!((dist(&s.eval(u, v), &p) - d).abs() < 1e-12);
        let (nu, nv) = (400, 120);
        let rr = (s.v_bar().len() - 1) as f64;
        let mut brute = f64::INFINITY;
        for a in 0..nu {
            for b in 0..=nv {
                brute = brute.min(dist(&s.eval(s.n_u() as f64 * a as f64 / nu as f64, rr * b as f64 / nv as f64), &p));
            }
        }
        prop_assert!(d <= brute + 1e-9, "closest {d} > grid {brute}");
        // Offset along the normal from an interior point.
        let (u0, v0) = (0.37 * s.n_u() as f64, 0.55 * rr);
        let (q, su, sv) = s.partials(u0, v0);
        let n = [su[1] * sv[2] - su[2] * sv[1], su[2] * sv[0] - su[0] * sv[2], su[0] * sv[1] - su[1] * sv[0]];
        let nl = dist(&n, &[0.0; 3]);
        let off = 0.01;
        let p2: [f64; 3] = std::array::from_fn(|x| q[x] + off * n[x] / nl);
        let (d2, _, _) = s.closest_point(&p2);
        prop_assert!((d2 - off).abs() < 1e-8, "{d2} vs {off}");
    }
}

/// The largest amount by which the surface's height goes back along v (0 if it never does),
/// sampled on a 24 × 600 grid, and how far it strays below the first curve's plane or above
/// the last's.
fn height_reversal(s: &SkinnedSurface, lo: f64, hi: f64) -> (f64, f64) {
    let (n1, r) = (s.n_u() as f64, (s.v_bar().len() - 1) as f64);
    let (mut back, mut out) = (0.0f64, 0.0f64);
    for a in 0..24 {
        let u = n1 * a as f64 / 24.0;
        let mut prev = f64::NEG_INFINITY;
        for b in 0..=600 {
            let z = s.eval(u, r * b as f64 / 600.0)[2];
            back = back.max(prev - z);
            out = out.max(lo - z).max(z - hi);
            prev = z;
        }
    }
    (back, out)
}

/// Curves in planes `heights`, each an ellipse `(a, b)` centred at `(cx, cy)`.
fn stack(heights: &[f64], shapes: &[(f64, f64, f64, f64)]) -> Vec<ClosedCurve<3>> {
    let contours: Vec<Vec<[f64; 3]>> = heights
        .iter()
        .zip(shapes)
        .map(|(&z, &(a, b, cx, cy))| {
            let e = ellipse(120, a, b);
            lift(
                &e.iter().map(|p| [p[0] + cx, p[1] + cy]).collect::<Vec<_>>(),
                z,
            )
        })
        .collect();
    fit_common(&contours, &FitOptions::new(0.05))
        .unwrap()
        .curves
}

/// An intermediate contour 0.08 mm below the next contour (a plane moved to t = 0.92) and
/// 2 mm inside it (its zone cut it): with centripetal v̄ its step is as long as a slice's, and
/// the height spline dipped 0.20 mm below the intermediate plane, folding the surface through
/// the one below. The height must rise all the way.
#[test]
fn heights_stay_monotone_next_to_a_near_plane() {
    let inner = (8.0, 6.0, 0.0, 0.0);
    let (plain, outside) = ((10.0, 8.0, 0.0, 0.0), (12.0, 10.0, 1.0, 0.0));
    // At the bottom with the near curve inside its neighbour; at the top, outside it.
    let cases = [
        (
            [0.0, 0.08, 1.08, 2.08, 3.08],
            [inner, plain, plain, plain, plain],
        ),
        (
            [0.0, 1.0, 2.0, 2.92, 3.0],
            [plain, plain, plain, plain, outside],
        ),
    ];
    for (heights, shapes) in cases {
        let s = skin(&stack(&heights, &shapes)).unwrap();
        let (back, out) = height_reversal(&s, 0.0, heights[4]);
        assert!(
            back < 1e-9 && out < 1e-9,
            "{heights:?}: height goes back {back} mm, strays {out} mm"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Random gaps between the planes (0.05–1.5 mm) and random outlines: the surface still
    /// interpolates every curve, and its height never goes back.
    #[test]
    fn heights_are_monotone_over_uneven_planes(
        gaps in prop::collection::vec(0.05f64..1.5, 2..7),
        shapes in prop::collection::vec((5.0f64..12.0, 4.0f64..12.0, -2.0f64..2.0, -2.0f64..2.0), 8),
    ) {
        let mut heights = vec![0.0];
        for g in &gaps {
            heights.push(heights[heights.len() - 1] + g);
        }
        let curves = stack(&heights, &shapes[..heights.len()]);
        let s = skin(&curves).unwrap();
        let top = heights[heights.len() - 1];
        let (back, out) = height_reversal(&s, 0.0, top);
        prop_assert!(back < 1e-9 && out < 1e-9, "height goes back {} mm, strays {} mm", back, out);
        let vb = s.v_bar();
        for (k, c) in curves.iter().enumerate() {
            for q in 0..20 {
                let u = s.n_u() as f64 * q as f64 / 20.0;
                let e = dist(&s.eval(u, vb[k]), &c.eval(u));
                prop_assert!(e < 1e-9, "curve {} at u = {}: {}", k, u, e);
            }
        }
    }
}

/// Caps at both ends: the surface collapses to the cap point at v = 0 and v = r, and S_v there
/// lies in the slice plane for every u (a tangent plane exists: a smooth dome, not a cone).
#[test]
fn caps_close_smoothly() {
    let (curves, _) = region(&[60, 80, 70], 11, (true, true));
    let s: SkinnedSurface = skin(&curves).unwrap();
    let r = (curves.len() - 1) as f64;
    let n1 = s.n_u();
    for q in 0..40 {
        let u = n1 as f64 * q as f64 / 40.0;
        assert!(dist(&s.eval(u, 0.0), &[0.3, -0.2, 1.5]) < 1e-12);
        assert!(dist(&s.eval(u, r), &[-0.1, 0.4, 10.5]) < 1e-12);
        let (_, _, sv0) = s.partials(u, 0.0);
        let (_, _, svr) = s.partials(u, r);
        assert!(
            sv0[2].abs() < 1e-9 * (1.0 + dist(&sv0, &[0.0; 3])),
            "{sv0:?}"
        );
        assert!(
            svr[2].abs() < 1e-9 * (1.0 + dist(&svr, &[0.0; 3])),
            "{svr:?}"
        );
        // The tangents point away from the cap, towards the neighbouring contour.
        let p1 = s.eval(u, 0.05);
        let dir: [f64; 3] = std::array::from_fn(|x| p1[x] - s.eval(u, 0.0)[x]);
        assert!(dir[0] * sv0[0] + dir[1] * sv0[1] > 0.0);
    }
    // One factor for every column: S_v(u, 0) is the same multiple of the projected chord
    // to the neighbouring curve for every u, so the rows near the cap are shrunken copies
    // of it (per-column tangents bent each column its own way, and the rows crossed).
    let vb = s.v_bar().to_vec();
    let ratio = |v: f64, k: usize, q: usize| -> f64 {
        let u = n1 as f64 * q as f64 / 40.0;
        let (_, _, sv) = s.partials(u, v);
        let chord: [f64; 3] = std::array::from_fn(|x| curves[k].eval(u)[x] - s.eval(u, v)[x]);
        // Parallel in the slice plane: the 2-D cross product vanishes.
        let cross = sv[0] * chord[1] - sv[1] * chord[0];
        let dot = sv[0] * chord[0] + sv[1] * chord[1];
        assert!(
            cross.abs() < 1e-9 * (1.0 + dot.abs()),
            "{sv:?} vs {chord:?}"
        );
        dot / (chord[0] * chord[0] + chord[1] * chord[1])
    };
    for (v, k) in [(0.0, 1), (r, curves.len() - 2)] {
        let first = ratio(v, k, 0);
        assert!(first.abs() > 1e-3 / (vb[1] - vb[0]), "{first}");
        for q in 1..40 {
            let rq = ratio(v, k, q);
            assert!((rq - first).abs() < 1e-9 * first.abs(), "{rq} vs {first}");
        }
    }
    // Still interpolates the curves.
    for (k, c) in curves.iter().enumerate() {
        assert!(dist(&s.eval(1.3, s.v_bar()[k]), &c.eval(1.3)) < 1e-9);
    }
}

/// A seam end (an intermediate contour where surfaces branch) leaves along the chord to the
/// next curve; a capped loop (a ridge where an annulus closes) is reached parallel to the slices;
/// both still interpolate every curve.
#[test]
fn seam_and_ridge_ends_take_their_tangents() {
    let (curves, _) = region(&[60, 80, 70, 50], 13, (false, false));
    let s = skin_ends(&curves, [SkinEnd::Seam, SkinEnd::Cap]).unwrap();
    let (vb, r) = (s.v_bar().to_vec(), curves.len() - 1);
    let n1 = s.n_u();
    for q in 0..40 {
        let u = n1 as f64 * q as f64 / 40.0;
        let (_, _, sv0) = s.partials(u, 0.0);
        let chord: [f64; 3] = std::array::from_fn(|x| {
            (curves[1].eval(u)[x] - curves[0].eval(u)[x]) / (vb[1] - vb[0])
        });
        assert!(
            dist(&sv0, &chord) < 1e-9 * (1.0 + dist(&chord, &[0.0; 3])),
            "{sv0:?} vs {chord:?}"
        );
        let (_, _, svr) = s.partials(u, r as f64);
        assert!(
            svr[2].abs() < 1e-9 * (1.0 + dist(&svr, &[0.0; 3])),
            "{svr:?}"
        );
    }
    for (k, c) in curves.iter().enumerate() {
        assert!(dist(&s.eval(2.7, vb[k]), &c.eval(2.7)) < 1e-9);
    }
    // Free ends are Bessel's, as `skin` gives them.
    let free = skin_ends(&curves, [SkinEnd::Free, SkinEnd::Free]).unwrap();
    assert_eq!(free.control(), skin(&curves).unwrap().control());
}

#[test]
fn skinning_rejects_bad_input() {
    let (curves, _) = region(&[30, 40], 5, (false, false));
    assert!(skin(&curves[..1]).is_err());
    let dup = vec![curves[0].clone(), curves[0].clone(), curves[1].clone()];
    let e = skin(&dup).unwrap_err();
    assert!(e.to_string().contains("curves 0 and 1 coincide"), "{e}");
    let other = ClosedCurve::try_new(
        bskin::bspline::PeriodicKnotVector::uniform(curves[0].control().len() + 1).unwrap(),
        vec![[0.0, 0.0, 9.0]; curves[0].control().len() + 1],
    )
    .unwrap();
    assert!(skin(&[curves[0].clone(), other]).is_err());
}

/// Two curves (r = 1): a Hermite patch between them with chord tangents.
#[test]
fn two_curves_skin() {
    let (curves, _) = region(&[30, 40], 9, (false, false));
    let s = skin(&curves).unwrap();
    assert_eq!(s.n_v(), 4);
    assert!(dist(&s.eval(2.0, 1.0), &curves[1].eval(2.0)) < 1e-9);
    // The iso-curve at v̄_k has curve k's control points.
    for (k, c) in curves.iter().enumerate() {
        let iso = s.iso_curve(s.v_bar()[k]).unwrap();
        for (a, b) in iso.control().iter().zip(c.control()) {
            assert!(dist(a, b) < 1e-9);
        }
    }
}

/// Regression: next to a flat cap the surface bends sharply at the first contours, and a
/// contour point there can have two local minima of distance (e.g. 0.003 mm at its own foot,
/// 0.7 mm on the bulge below), even inside one patch. Three bugs were pinned on this region:
/// the search once kept a patch's best *sample* as "best" and skipped Newton from it as
/// "same basin" (0.49 mm); an unconstrained Newton run slid from the foot's patch into the
/// bulge's basin (0.56 mm); a seed on a patch boundary stalled because the Newton step pointed
/// out of the box while the gradient pointed in (0.19 mm). Every contour point must be at most
/// its curve error from the surface (the surface contains the curve), seeded or not.
#[test]
fn closest_point_near_cap_finds_the_foot_not_the_bulge() {
    use rand::{Rng, SeedableRng};
    let mut contours: Vec<Vec<[f64; 3]>> = (0..10)
        .map(|k| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(k as u64);
            let m = 150 + rng.random_range(0..300);
            let r0 = 30.0 + (k as f64 * 0.7).sin() * 5.0;
            lift(&star(m, r0, 0.02, 100 + k as u64), 2.0 * k as f64 + 2.0)
        })
        .collect();
    contours.insert(0, vec![[0.0, 0.0, 1.0]]);
    let f = fit_common(&contours, &FitOptions::new(0.1)).unwrap();
    let s = skin(&f.curves).unwrap();
    for (k, pts) in f.points.iter().enumerate() {
        for (j, p) in pts.iter().enumerate() {
            let g = s.closest_point(p);
            let h = s.closest_point_hint(p, f.params[k][j], s.v_bar()[k]);
            assert!(
                g.0 <= f.errors[k][j] + 1e-9,
                "contour {k} point {j}: surface {g:?} > curve {}",
                f.errors[k][j]
            );
            assert!(
                (g.0 - h.0).abs() < 1e-9,
                "contour {k} point {j}: global {g:?} vs hinted {h:?}"
            );
        }
    }
}

/// Queries with NaN or infinite arguments do not panic; they give NaN (documented).
#[test]
fn non_finite_queries_do_not_panic() {
    let (curves, _) = region(&[30, 40, 30], 2, (false, false));
    let s = skin(&curves).unwrap();
    for (u, v) in [
        (f64::NAN, 1.0),
        (1.0, f64::NAN),
        (f64::INFINITY, f64::NEG_INFINITY),
    ] {
        let _ = s.eval(u, v);
        let _ = s.derivs2(u, v);
        let _ = s.closest_point_from(&[1.0, 2.0, 3.0], u, v);
    }
    assert!(
        s.closest_point(&[f64::NAN, 0.0, 1.0]).0.is_nan()
            || s.closest_point(&[f64::NAN, 0.0, 1.0]).0.is_infinite()
    );
    let c = &curves[1];
    let _ = c.eval(f64::NAN);
    let _ = c.derivs(f64::INFINITY);
    assert!(!c.distance_to(&[f64::NAN, 0.0, 0.0]).0.is_finite());
}
