//! Cubic B-spline basis functions (standard indexing: N_i has support [u_i, u_{i+4})).
//!
//! In: a full knot vector `u`, a span index `k` with u_k ≤ t < u_{k+1} and u_k < u_{k+1}
//! (3 ≤ k, k+4 ≤ u.len()). Out: the four non-zero functions N_{k-3..=k}(t) and their first
//! and second derivatives ([`ders`], The NURBS Book A2.3), or a point by de Boor's algorithm
//! ([`de_boor`]). [`cox_de_boor`] is the plain recursive definition, kept as an independent
//! reference for tests. The four values sum to 1 and are non-negative inside the span.

/// Values and first two derivatives of the non-zero cubic basis functions at `t`:
/// `out[d][a]` = d-th derivative of N_{k-3+a}(t).
pub fn ders(u: &[f64], k: usize, t: f64) -> [[f64; 4]; 3] {
    const P: usize = 3;
    let mut ndu = [[0.0f64; 4]; 4];
    let mut left = [0.0f64; 4];
    let mut right = [0.0f64; 4];
    ndu[0][0] = 1.0;
    for j in 1..=P {
        left[j] = t - u[k + 1 - j];
        right[j] = u[k + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    let mut out = [[0.0f64; 4]; 3];
    for j in 0..=P {
        out[0][j] = ndu[j][P];
    }
    let mut a = [[0.0f64; 4]; 2];
    for r in 0..=P {
        let (mut s1, mut s2) = (0usize, 1usize);
        a[0][0] = 1.0;
        for kk in 1..=2usize {
            let mut d = 0.0;
            let rk = r as isize - kk as isize;
            let pk = P - kk;
            if r >= kk {
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if r as isize - 1 <= pk as isize {
                kk - 1
            } else {
                P - r
            };
            for j in j1..=j2 {
                let idx = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                d += a[s2][j] * ndu[idx][pk];
            }
            if r <= pk {
                a[s2][kk] = -a[s1][kk - 1] / ndu[pk + 1][r];
                d += a[s2][kk] * ndu[r][pk];
            }
            out[kk][r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    out[1].iter_mut().for_each(|x| *x *= 3.0);
    out[2].iter_mut().for_each(|x| *x *= 6.0);
    out
}

/// Values only of the four non-zero cubic basis functions at `t` in span `k`.
pub fn values(u: &[f64], k: usize, t: f64) -> [f64; 4] {
    cubic_and_quadratic(u, k, t).0
}

/// The triangular Cox–de Boor recurrence up to the cubics, keeping the three quadratics on
/// the way (the first derivative is a difference of them).
fn cubic_and_quadratic(u: &[f64], k: usize, t: f64) -> ([f64; 4], [f64; 3]) {
    let mut n = [0.0f64; 4];
    let mut left = [0.0f64; 4];
    let mut right = [0.0f64; 4];
    n[0] = 1.0;
    let mut quad = [0.0f64; 3];
    for j in 1..=3 {
        if j == 3 {
            quad.copy_from_slice(&n[..3]);
        }
        left[j] = t - u[k + 1 - j];
        right[j] = u[k + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = n[r] / (right[r + 1] + left[j - r]);
            n[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        n[j] = saved;
    }
    (n, quad)
}

/// Values and first derivatives of the four non-zero cubic basis functions at `t` in span
/// `k` (cheaper than [`ders`]): N′_{i,4} = 3 (N_{i,3}/(u_{i+3} − u_i) − N_{i+1,3}/(u_{i+4} − u_{i+1})).
pub fn values_d1(u: &[f64], k: usize, t: f64) -> ([f64; 4], [f64; 4]) {
    let (n, quad) = cubic_and_quadratic(u, k, t);
    // quad[b] = N_{k-2+b, 3}(t); q(a) = N_{k-3+a, 3}, zero outside.
    let q = |a: usize| if a == 0 || a == 4 { 0.0 } else { quad[a - 1] };
    let mut d = [0.0f64; 4];
    for (a, da) in d.iter_mut().enumerate() {
        let i = k + a - 3;
        let t1 = if a > 0 { q(a) / (u[i + 3] - u[i]) } else { 0.0 };
        let t2 = if a < 3 {
            q(a + 1) / (u[i + 4] - u[i + 1])
        } else {
            0.0
        };
        *da = 3.0 * (t1 - t2);
    }
    (n, d)
}

/// de Boor's algorithm: the point `Σ_a ctrl[a]·N_{k-3+a}(t)` for t in span `k`, where `ctrl`
/// are the four control points of that span.
pub fn de_boor<const D: usize>(u: &[f64], k: usize, t: f64, ctrl: [[f64; D]; 4]) -> [f64; D] {
    let mut d = ctrl;
    for r in 1..=3 {
        for j in (r..=3).rev() {
            let i = k + j - 3;
            let alpha = (t - u[i]) / (u[i + 4 - r] - u[i]);
            for c in 0..D {
                d[j][c] = (1.0 - alpha) * d[j - 1][c] + alpha * d[j][c];
            }
        }
    }
    d[3]
}

/// N_{i,p+1}(t) by the Cox–de Boor recursion (half-open supports, 0/0 := 0). Slow; for tests.
pub fn cox_de_boor(u: &[f64], i: usize, p: usize, t: f64) -> f64 {
    if p == 0 {
        return if u[i] <= t && t < u[i + 1] { 1.0 } else { 0.0 };
    }
    let mut s = 0.0;
    let d1 = u[i + p] - u[i];
    if d1 > 0.0 {
        s += (t - u[i]) / d1 * cox_de_boor(u, i, p - 1, t);
    }
    let d2 = u[i + p + 1] - u[i + 1];
    if d2 > 0.0 {
        s += (u[i + p + 1] - t) / d2 * cox_de_boor(u, i + 1, p - 1, t);
    }
    s
}
