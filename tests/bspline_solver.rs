//! The O(n) cyclic banded solver against a dense nalgebra solve on random systems.

#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

use bskin::bspline::basis::values;
use bskin::bspline::{BsplineError, CyclicBandedMatrix, PeriodicKnotVector};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random SPD cyclic banded matrix: Σ of random 4×4 SPD blocks placed at random positions
/// (cyclically), plus a positive diagonal.
fn random_spd(n: usize, seed: u64) -> CyclicBandedMatrix {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut a = CyclicBandedMatrix::zeros(n);
    for _ in 0..3 * n {
        let s = rng.random_range(0..n);
        let b: [f64; 4] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        for x in 0..4 {
            for y in x..4 {
                // `add` puts an off-diagonal value at both (i, k) and (k, i); where N < 4
                // wraps x ≠ y onto one index, both halves of b·bᵀ land on the diagonal, so
                // it takes the value twice (once, n = 2, seed 78 287 was not positive).
                let (i, k) = ((s + x) % n, (s + y) % n);
                let twice = if x != y && i == k { 2.0 } else { 1.0 };
                a.add(i, k, twice * b[x] * b[y]).unwrap();
            }
        }
    }
    for i in 0..n {
        a.add(i, i, rng.random_range(0.01..0.5)).unwrap();
    }
    a
}

fn dense(a: &CyclicBandedMatrix) -> DMatrix<f64> {
    let n = a.size();
    DMatrix::from_row_slice(n, n, &a.to_dense())
}

#[test]
fn small_wrapped_matrices_are_positive_definite() {
    // N < 4 wraps a block onto itself; the generator once made (2, 78 287) indefinite.
    for n in 1..4 {
        for seed in [78_287, 0, 1, 2, 3] {
            let mut x = vec![[1.0, 2.0, 3.0]; n];
            random_spd(n, seed).solve(&mut x).unwrap();
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn matches_dense_solve(n in 1usize..80, seed in 0u64..100_000) {
        let a = random_spd(n, seed);
        let m = dense(&a);
        // The band storage keeps the matrix symmetric.
        prop_assert!((m.clone() - m.transpose()).amax() < 1e-14);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xabc);
        let b: Vec<[f64; 3]> = (0..n).map(|_| std::array::from_fn(|_| rng.random_range(-5.0..5.0))).collect();
        let mut x = b.clone();
        a.solve(&mut x).unwrap();
        let lu = m.clone().lu();
        for c in 0..3 {
            let rhs = DVector::from_iterator(n, b.iter().map(|r| r[c]));
            let xd = lu.solve(&rhs).unwrap();
            let err = (0..n).map(|i| (x[i][c] - xd[i]).abs()).fold(0.0, f64::max);
            let scale = xd.amax().max(1.0);
            prop_assert!(err < 1e-8 * scale, "n = {n}: max |x − x_dense| = {err:e}");
        }
    }

    /// Normal equations of a real closed cubic least-squares problem.
    #[test]
    fn matches_dense_on_normal_equations(n1 in 4usize..60, extra in 1usize..200, seed in 0u64..100_000) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let k = PeriodicKnotVector::uniform(n1).unwrap();
        let mut a = CyclicBandedMatrix::zeros(n1);
        let m1 = n1 + extra;
        let mut rhs = vec![[0.0; 2]; n1];
        for j in 0..m1 {
            let t = (j as f64 + rng.random_range(0.0..0.9)) * n1 as f64 / m1 as f64;
            let s = k.span(t);
            let b = values(k.extended(), s + 3, t);
            let p = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
            for x in 0..4 {
                for y in x..4 {
                    a.add((s + x) % n1, (s + y) % n1, b[x] * b[y]).unwrap();
                }
                for c in 0..2 { rhs[(s + x) % n1][c] += b[x] * p[c]; }
            }
        }
        let m = dense(&a);
        let mut x = rhs.clone();
        a.solve(&mut x).unwrap();
        let lu = m.lu();
        for c in 0..2 {
            let xd = lu.solve(&DVector::from_iterator(n1, rhs.iter().map(|r| r[c]))).unwrap();
            let err = (0..n1).map(|i| (x[i][c] - xd[i]).abs()).fold(0.0, f64::max);
            prop_assert!(err < 1e-8 * xd.amax().max(1.0), "err {err:e}");
        }
    }
}

#[test]
fn singular_and_out_of_band_are_errors() {
    let a = CyclicBandedMatrix::zeros(20);
    let mut x = vec![[1.0]; 20];
    assert!(matches!(a.solve(&mut x), Err(BsplineError::Singular(_))));
    let mut a = CyclicBandedMatrix::zeros(20);
    assert!(a.add(0, 10, 1.0).is_err());
    assert!(a.add(0, 17, 1.0).is_ok()); // cyclic offset 3
    let mut b = CyclicBandedMatrix::zeros(10);
    for i in 0..10 {
        b.add(i, i, 1.0).unwrap();
    }
    let mut y = vec![[1.0]; 9];
    assert!(b
        .solve(&mut y)
        .unwrap_err()
        .to_string()
        .contains("9 rows, matrix is 10×10"));
}
