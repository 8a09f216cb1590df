//! Symmetric positive definite systems with cyclic band structure: the normal equations
//! NᵀN B = NᵀP of closed cubic least squares (paper Appendix, METHOD §6).
//!
//! In: an N×N matrix with `A[i][k] = 0` unless the cyclic distance of i and k is ≤ 3 (built with
//! [`CyclicBandedMatrix::add`]), and right-hand sides `[f64; D]` per row. Out: the solution,
//! in O(N) time and memory, or [`BsplineError::Singular`] when a pivot vanishes (e.g. a knot
//! span holds no parameter).
//!
//! Method: order the unknowns as (x₁, x₂) with x₂ the last three. A₁₁ (the first N−3 rows
//! and columns) is then *plainly* banded (half-bandwidth 3: a cyclic offset ≤ 3 between two of
//! its indices is also a linear one), and A₁₂ is non-zero only in its first and last three
//! rows. Banded Cholesky of A₁₁, the 3×3 Schur complement S = A₂₂ − A₁₂ᵀA₁₁⁻¹A₁₂, then
//! x₂ = S⁻¹(b₂ − A₁₂ᵀA₁₁⁻¹b₁), x₁ = A₁₁⁻¹(b₁ − A₁₂x₂). This is the block form of a
//! Sherman–Morrison–Woodbury correction, exact, with no dense inverse. Below N = 8 the cyclic
//! offsets overlap and the matrix is stored and factored densely (tiny anyway).

use super::BsplineError;

/// Half-bandwidth of cubic normal equations.
const W: usize = 3;
/// Below this size the matrix is dense.
const DENSE_BELOW: usize = 8;
/// Relative pivot threshold for "singular".
const PIVOT_EPS: f64 = 1e-13;

#[derive(Debug, Clone)]
enum Storage {
    /// `band[i][d] = A[i][(i+d) mod N]`, `d = 0..=3`.
    Band(Vec<[f64; W + 1]>),
    /// Row-major N×N.
    Dense(Vec<f64>),
}

/// A symmetric cyclic banded matrix (half-bandwidth 3).
#[derive(Debug, Clone)]
pub struct CyclicBandedMatrix {
    n: usize,
    storage: Storage,
}

impl CyclicBandedMatrix {
    /// The N×N zero matrix (N ≥ 1).
    pub fn zeros(n: usize) -> Self {
        let storage = if n < DENSE_BELOW {
            Storage::Dense(vec![0.0; n * n])
        } else {
            Storage::Band(vec![[0.0; W + 1]; n])
        };
        Self { n, storage }
    }

    pub fn size(&self) -> usize {
        self.n
    }

    /// Adds `v` to `A[i][k]` and, when i ≠ k, to `A[k][i]` (the matrix stays symmetric).
    /// Returns an error if the cyclic distance of i and k exceeds 3 or an index is out of range.
    pub fn add(&mut self, i: usize, k: usize, v: f64) -> Result<(), BsplineError> {
        let n = self.n;
        if i >= n || k >= n {
            return Err(BsplineError::InvalidArgument(format!(
                "entry ({i}, {k}) outside a {n}×{n} matrix"
            )));
        }
        match &mut self.storage {
            Storage::Dense(a) => {
                a[i * n + k] += v;
                if i != k {
                    a[k * n + i] += v;
                }
            }
            Storage::Band(b) => {
                let d = (k + n - i) % n;
                if d <= W {
                    b[i][d] += v;
                } else if n - d <= W {
                    b[k][n - d] += v;
                } else {
                    return Err(BsplineError::InvalidArgument(format!(
                        "entry ({i}, {k}) outside the cyclic band of half-width {W} (N = {n})"
                    )));
                }
            }
        }
        Ok(())
    }

    /// Adds the outer product of the four cubic basis values of span `s` (control indices
    /// s..s+3 mod N) times `w`: the contribution of one data point to NᵀN.
    #[inline]
    pub(crate) fn add_span_outer(&mut self, s: usize, b: &[f64; 4]) {
        let n = self.n;
        match &mut self.storage {
            Storage::Band(band) => {
                for a in 0..4 {
                    let row = &mut band[(s + a) % n];
                    for c in a..4 {
                        row[c - a] += b[a] * b[c];
                    }
                }
            }
            Storage::Dense(m) => {
                for a in 0..4 {
                    for c in 0..4 {
                        m[((s + a) % n) * n + (s + c) % n] += b[a] * b[c];
                    }
                }
            }
        }
    }

    /// `A[i][k]`.
    pub fn get(&self, i: usize, k: usize) -> f64 {
        let n = self.n;
        match &self.storage {
            Storage::Dense(a) => a[i * n + k],
            Storage::Band(b) => {
                let d = (k + n - i) % n;
                if d <= W {
                    b[i][d]
                } else if n - d <= W {
                    b[k][n - d]
                } else {
                    0.0
                }
            }
        }
    }

    /// Row-major dense copy (for tests and diagnostics).
    pub fn to_dense(&self) -> Vec<f64> {
        let n = self.n;
        let mut out = vec![0.0; n * n];
        for i in 0..n {
            for k in 0..n {
                out[i * n + k] = self.get(i, k);
            }
        }
        out
    }

    /// Solves A x = b in place (`rhs` becomes x).
    pub fn solve<const D: usize>(&self, rhs: &mut [[f64; D]]) -> Result<(), BsplineError> {
        if rhs.len() != self.n {
            return Err(BsplineError::InvalidArgument(format!(
                "right-hand side has {} rows, matrix is {}×{}",
                rhs.len(),
                self.n,
                self.n
            )));
        }
        if let Some(i) = rhs.iter().position(|r| r.iter().any(|x| !x.is_finite())) {
            return Err(BsplineError::NonFinite(format!("right-hand side row {i}")));
        }
        let scale = (0..self.n)
            .map(|i| self.get(i, i).abs())
            .fold(0.0, f64::max);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(BsplineError::Singular(format!(
                "matrix diagonal maximum is {scale}"
            )));
        }
        match &self.storage {
            Storage::Dense(a) => dense_cholesky_solve(a.clone(), self.n, rhs, scale),
            Storage::Band(_) => self.band_solve(rhs, scale),
        }
    }

    fn band_solve<const D: usize>(
        &self,
        rhs: &mut [[f64; D]],
        scale: f64,
    ) -> Result<(), BsplineError> {
        let n = self.n;
        let m = n - W;
        // Banded Cholesky of A11: l[i][d] = L[i][i-d].
        let mut l = vec![[0.0f64; W + 1]; m];
        for i in 0..m {
            for d in (1..=W.min(i)).rev() {
                let j = i - d;
                let mut s = self.get(i, j);
                // Σ_k L[i][k] L[j][k] over k < j within both bands.
                for e in 1..=(W - d).min(j) {
                    let k = j - e;
                    s -= l[i][i - k] * l[j][e];
                }
                l[i][d] = s / l[j][0];
            }
            let mut s = self.get(i, i);
            for d in 1..=W.min(i) {
                s -= l[i][d] * l[i][d];
            }
            if !(s > PIVOT_EPS * scale) {
                return Err(BsplineError::Singular(format!(
                    "pivot {i} of {n} is {s:.3e} (diagonal scale {scale:.3e})"
                )));
            }
            l[i][0] = s.sqrt();
        }
        let solve11 = |b: &mut [f64]| {
            for i in 0..m {
                let mut s = b[i];
                for d in 1..=W.min(i) {
                    s -= l[i][d] * b[i - d];
                }
                b[i] = s / l[i][0];
            }
            for i in (0..m).rev() {
                let mut s = b[i];
                for d in 1..=W.min(m - 1 - i) {
                    s -= l[i + d][d] * b[i + d];
                }
                b[i] = s / l[i][0];
            }
        };
        // Y = A11⁻¹ A12 (three columns).
        let mut y = [vec![0.0f64; m], vec![0.0f64; m], vec![0.0f64; m]];
        for (c, col) in y.iter_mut().enumerate() {
            for (i, v) in col.iter_mut().enumerate() {
                *v = self.get(i, m + c);
            }
            solve11(col);
        }
        // S = A22 − A12ᵀ Y.
        let mut s = [[0.0f64; W]; W];
        for a in 0..W {
            for c in 0..W {
                let mut v = self.get(m + a, m + c);
                for i in 0..m {
                    let a12 = self.get(i, m + a);
                    if a12 != 0.0 {
                        v -= a12 * y[c][i];
                    }
                }
                s[a][c] = v;
            }
        }
        let mut flat: Vec<f64> = s.iter().flatten().copied().collect();
        // Per coordinate: z = A11⁻¹ b1, x2 = S⁻¹ (b2 − A12ᵀ z), x1 = z − Y x2.
        let mut z = vec![0.0f64; m];
        let mut x2s = [[0.0f64; D]; W];
        let mut zs: Vec<Vec<f64>> = Vec::with_capacity(D);
        for x in 0..D {
            for i in 0..m {
                z[i] = rhs[i][x];
            }
            solve11(&mut z);
            for a in 0..W {
                let mut v = rhs[m + a][x];
                for (i, zi) in z.iter().enumerate() {
                    let a12 = self.get(i, m + a);
                    if a12 != 0.0 {
                        v -= a12 * zi;
                    }
                }
                x2s[a][x] = v;
            }
            zs.push(z.clone());
        }
        dense_cholesky_solve_in_place(&mut flat, W, &mut x2s, scale)?;
        for (x, zx) in zs.iter().enumerate() {
            for i in 0..m {
                let mut v = zx[i];
                for (c, yc) in y.iter().enumerate() {
                    v -= yc[i] * x2s[c][x];
                }
                rhs[i][x] = v;
            }
            for a in 0..W {
                rhs[m + a][x] = x2s[a][x];
            }
        }
        Ok(())
    }
}

fn dense_cholesky_solve<const D: usize>(
    mut a: Vec<f64>,
    n: usize,
    rhs: &mut [[f64; D]],
    scale: f64,
) -> Result<(), BsplineError> {
    dense_cholesky_solve_in_place(&mut a, n, rhs, scale)
}

/// Dense Cholesky (lower triangle overwritten) and solve; for N < 8 and the 3×3 Schur block.
fn dense_cholesky_solve_in_place<const D: usize>(
    a: &mut [f64],
    n: usize,
    rhs: &mut [[f64; D]],
    scale: f64,
) -> Result<(), BsplineError> {
    for j in 0..n {
        let mut s = a[j * n + j];
        for k in 0..j {
            s -= a[j * n + k] * a[j * n + k];
        }
        if !(s > PIVOT_EPS * scale) {
            return Err(BsplineError::Singular(format!(
                "pivot {j} of {n} is {s:.3e} (diagonal scale {scale:.3e})"
            )));
        }
        let d = s.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    for x in 0..D {
        for i in 0..n {
            let mut s = rhs[i][x];
            for k in 0..i {
                s -= a[i * n + k] * rhs[k][x];
            }
            rhs[i][x] = s / a[i * n + i];
        }
        for i in (0..n).rev() {
            let mut s = rhs[i][x];
            for k in i + 1..n {
                s -= a[k * n + i] * rhs[k][x];
            }
            rhs[i][x] = s / a[i * n + i];
        }
    }
    Ok(())
}
