//! Knot vectors, basis functions, closed-curve evaluation and point distance, checked against
//! independent references (Cox–de Boor sums, finite differences, brute-force sampling).

#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

#[path = "bspline_helpers.rs"]
mod helpers;

use bskin::bspline::basis::{cox_de_boor, ders, values, values_d1};
use bskin::bspline::{BsplineError, ClampedKnotVector, ClosedCurve, PeriodicKnotVector};
use helpers::dist;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_curve(n1: usize, seed: u64) -> ClosedCurve<2> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut d = vec![0.0];
    let mut acc = 0.0;
    let steps: Vec<f64> = (0..n1).map(|_| rng.random_range(0.2..1.8)).collect();
    let total: f64 = steps.iter().sum();
    for s in &steps[..n1 - 1] {
        acc += s / total * n1 as f64;
        d.push(acc);
    }
    d.push(n1 as f64);
    let k = PeriodicKnotVector::try_new(&d).unwrap();
    let ctrl = (0..n1)
        .map(|_| [rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0)])
        .collect();
    ClosedCurve::try_new(k, ctrl).unwrap()
}

#[test]
fn periodic_knots_validate_and_extend() {
    let k = PeriodicKnotVector::try_new(&[0.0, 0.5, 2.0, 2.5, 3.5, 5.0]).unwrap();
    assert_eq!(k.n_control(), 5);
    let e = k.extended();
    assert_eq!(e.len(), 5 + 7);
    // ξ_{-i} = ξ_{n+1-i} − (n+1), ξ_{n+1+i} = ξ_i + (n+1).
    assert_eq!(&e[..3], &[2.0 - 5.0, 2.5 - 5.0, 3.5 - 5.0]);
    assert_eq!(&e[9..], &[5.5, 7.0, 7.5]);
    let msg = |r: Result<PeriodicKnotVector, BsplineError>| r.unwrap_err().to_string();
    assert!(msg(PeriodicKnotVector::try_new(&[0.0, 1.0, 2.0, 3.0]))
        .contains("got 4 domain knots, expected at least 5"));
    assert!(msg(PeriodicKnotVector::try_new(&[0.0, 2.0, 1.0, 3.0, 4.0])).contains("ξ_1 = 2"));
    assert!(msg(PeriodicKnotVector::try_new(&[0.0, 1.0, f64::NAN, 3.0, 4.0])).contains("NaN"));
    assert!(
        msg(PeriodicKnotVector::try_new(&[0.0, 1.0, 2.0, 3.0, 7.0])).contains("expected [0, 4]")
    );
}

#[test]
fn clamped_knots_validate() {
    assert!(ClampedKnotVector::try_new(&[0., 0., 0., 0., 1., 2., 2., 2., 2.]).is_ok());
    let e = ClampedKnotVector::try_new(&[0., 0., 0., 0., 1., 1., 1.])
        .unwrap_err()
        .to_string();
    assert!(e.contains("got 7 knots, expected at least 8"), "{e}");
    assert!(ClampedKnotVector::try_new(&[0., 0., 0., 0.5, 1., 2., 2., 2., 2.]).is_err());
    assert!(ClampedKnotVector::try_new(&[0., 0., 0., 0., 1.5, 1., 2., 2., 2., 2.]).is_err());
    assert!(ClampedKnotVector::try_new(&[0., 0., 0., 0., 1., 1., 1., 1., 2., 2., 2., 2.]).is_err());
}

#[test]
fn closed_curve_rejects_wrong_counts_and_nan() {
    let k = PeriodicKnotVector::uniform(5).unwrap();
    let e = ClosedCurve::try_new(k.clone(), vec![[0.0, 0.0]; 4])
        .unwrap_err()
        .to_string();
    assert!(e.contains("got 4 control points, expected 5"), "{e}");
    let mut c = vec![[1.0, 0.0]; 5];
    c[2][1] = f64::NAN;
    assert!(matches!(
        ClosedCurve::try_new(k, c),
        Err(BsplineError::NonFinite(_))
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// de Boor equals the explicit sum Σ_{i=0}^{n+3} B_{i mod (n+1)} N_{i,4}(t) (Cox–de Boor).
    #[test]
    fn de_boor_matches_cox_de_boor_sum(n1 in 4usize..12, seed in 0u64..10_000, t in 0.0f64..1.0) {
        let c = random_curve(n1, seed);
        let t = t * n1 as f64;
        let e = c.knots().extended();
        let mut s = [0.0; 2];
        for i in 0..n1 + 3 {
            let w = cox_de_boor(e, i, 3, t);
            for x in 0..2 { s[x] += w * c.control()[i % n1][x]; }
        }
        let p = c.eval(t);
        prop_assert!(dist(&p, &s) < 1e-10, "{p:?} vs {s:?}");
    }

    /// The specialised value/first-derivative routines agree with the general A2.3 one.
    #[test]
    fn specialised_basis_matches_general(n1 in 4usize..12, seed in 0u64..10_000, t in 0.0f64..1.0) {
        let c = random_curve(n1, seed);
        let t = t * n1 as f64;
        let k = c.knots().span(t) + 3;
        let e = c.knots().extended();
        let g = ders(e, k, t);
        let v = values(e, k, t);
        let (v1, d1) = values_d1(e, k, t);
        for a in 0..4 {
            prop_assert!((g[0][a] - v[a]).abs() < 1e-14 && (g[0][a] - v1[a]).abs() < 1e-14);
            prop_assert!((g[1][a] - d1[a]).abs() < 1e-12);
        }
        prop_assert!((v.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        let (p, d) = c.eval_d1(t);
        let (p2, dd, _) = c.derivs(t);
        prop_assert!(dist(&p, &p2) < 1e-12 && dist(&d, &dd) < 1e-10);
    }

    /// First and second derivatives against central differences.
    #[test]
    fn derivatives_match_finite_differences(n1 in 4usize..12, seed in 0u64..10_000, t in 0.0f64..1.0) {
        let c = random_curve(n1, seed);
        let t = t * n1 as f64;
        let h = 1e-5;
        let (_, d1, d2) = c.derivs(t);
        let (p0, p1) = (c.eval(t - h), c.eval(t + h));
        let (q0, _, _) = c.derivs(t);
        let (a1, _, _) = c.derivs(t - h);
        let (b1, _, _) = c.derivs(t + h);
        let fd1: [f64; 2] = std::array::from_fn(|x| (p1[x] - p0[x]) / (2.0 * h));
        let fd2: [f64; 2] = std::array::from_fn(|x| (b1[x] - 2.0 * q0[x] + a1[x]) / (h * h));
        // Second differences straddling a knot see the C² jump in C''' only: O(h) error.
        prop_assert!(dist(&d1, &fd1) < 1e-5 * (1.0 + dist(&d1, &[0.0, 0.0])));
        prop_assert!(dist(&d2, &fd2) < 1e-2 * (1.0 + dist(&d2, &[0.0, 0.0])));
        let (_, e1, e2) = c.derivs(t + h);
        let (_, f1, _) = c.derivs(t - h);
        let fd2b: [f64; 2] = std::array::from_fn(|x| (e1[x] - f1[x]) / (2.0 * h));
        prop_assert!(dist(&d2, &fd2b) < 1e-4 * (1.0 + dist(&e2, &[0.0, 0.0])));
    }

    /// C² across the seam: the last span's polynomial evaluated at its right end ξ_{n+1}
    /// matches value, C′ and C″ of the first span at ξ_0 = 0.
    #[test]
    fn closed_curve_is_c2_across_seam(n1 in 4usize..12, seed in 0u64..10_000) {
        let c = random_curve(n1, seed);
        let e = c.knots().extended();
        let b = ders(e, n1 - 1 + 3, n1 as f64);
        let mut left = [[0.0; 2]; 3];
        for d in 0..3 {
            for a in 0..4 {
                for x in 0..2 { left[d][x] += b[d][a] * c.control()[(n1 - 1 + a) % n1][x]; }
            }
        }
        let (p, d1, d2) = c.derivs(0.0);
        prop_assert!(dist(&p, &left[0]) < 1e-10);
        prop_assert!(dist(&d1, &left[1]) < 1e-9);
        prop_assert!(dist(&d2, &left[2]) < 1e-8);
    }

    /// The true distance is the minimum over a dense sampling (never larger, and within the
    /// sampling's own error of it), and the returned parameter attains it.
    #[test]
    fn distance_is_global_minimum(n1 in 4usize..10, seed in 0u64..10_000, px in -15.0f64..15.0, py in -15.0f64..15.0) {
        let c = random_curve(n1, seed);
        let p = [px, py];
        let (d, t) = c.distance_to(&p);
        prop_assert!((dist(&c.eval(t), &p) - d).abs() < 1e-12);
        let samples = 20_000;
        let brute = (0..samples)
            .map(|q| dist(&c.eval(n1 as f64 * q as f64 / samples as f64), &p))
            .fold(f64::INFINITY, f64::min);
        prop_assert!(d <= brute + 1e-9, "projection {d} worse than sampling {brute}");
        prop_assert!(brute - d < 1e-2, "sampling {brute} far below projection {d}?");
    }
}
