//! Knot vectors of cubic (order 4) B-splines.
//!
//! - [`PeriodicKnotVector`] (u, closed curves; paper §2.1, METHOD §5): in go the n+2 domain
//!   knots ξ_0 = 0 < ξ_1 < … < ξ_{n+1} = n+1 of a curve with n+1 distinct control points; out
//!   comes the full vector ξ_{-3}..ξ_{n+4} (n+8 entries), extended periodically:
//!   ξ_{-i} = ξ_{n+1-i} − (n+1), ξ_{n+1+i} = ξ_i + (n+1), i = 1..3.
//! - [`ClampedKnotVector`] (v, open curves): r+7 knots for r+3 control points, the first four
//!   equal, the last four equal, non-decreasing, interior multiplicities ≤ 3.
//!
//! Invariants (checked at construction): finite, strictly increasing domain (periodic),
//! non-decreasing with non-empty domain (clamped), at least 4 control points.

use super::BsplineError;

/// Cubic degree.
pub const DEGREE: usize = 3;

/// Knot vector of a closed (periodic) cubic B-spline with n+1 control points.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicKnotVector {
    /// ξ_{-3}..ξ_{n+4}; `ext[k + 3] = ξ_k`.
    ext: Vec<f64>,
}

impl PeriodicKnotVector {
    /// From the domain knots ξ_0..ξ_{n+1}. ξ_0 must be 0 and ξ_{n+1} = n+1 (within 1e-9
    /// relative; snapped exactly), strictly increasing, n+1 ≥ 4.
    pub fn try_new(domain: &[f64]) -> Result<Self, BsplineError> {
        if domain.len() < 5 {
            return Err(BsplineError::InvalidKnots(format!(
                "got {} domain knots, expected at least 5 (4 control points)",
                domain.len()
            )));
        }
        if let Some(i) = domain.iter().position(|x| !x.is_finite()) {
            return Err(BsplineError::InvalidKnots(format!(
                "domain knot {i} is {}",
                domain[i]
            )));
        }
        let period = (domain.len() - 1) as f64;
        let tol = 1e-9 * period;
        if domain[0].abs() > tol || (domain[domain.len() - 1] - period).abs() > tol {
            return Err(BsplineError::InvalidKnots(format!(
                "domain is [{}, {}], expected [0, {}] for {} control points",
                domain[0],
                domain[domain.len() - 1],
                period,
                domain.len() - 1
            )));
        }
        let mut d = domain.to_vec();
        d[0] = 0.0;
        let last = d.len() - 1;
        d[last] = period;
        // A span narrower than this makes the normal equations numerically singular.
        let min_span = 1e-12 * period;
        for k in 0..last {
            if d[k + 1] - d[k] <= min_span {
                return Err(BsplineError::InvalidKnots(format!(
                    "domain knots not strictly increasing: ξ_{} = {} ≥ ξ_{} = {}",
                    k,
                    d[k],
                    k + 1,
                    d[k + 1]
                )));
            }
        }
        let n1 = last; // n+1
        let mut ext = Vec::with_capacity(n1 + 7);
        for i in (1..=3).rev() {
            ext.push(d[n1 - i] - period);
        }
        ext.extend_from_slice(&d);
        for i in 1..=3 {
            ext.push(d[i] + period);
        }
        Ok(Self { ext })
    }

    /// Uniform knots ξ_k = k for `n_control` control points.
    pub fn uniform(n_control: usize) -> Result<Self, BsplineError> {
        let d: Vec<f64> = (0..=n_control).map(|k| k as f64).collect();
        Self::try_new(&d)
    }

    /// Number of distinct control points, n+1.
    pub fn n_control(&self) -> usize {
        self.ext.len() - 7
    }

    /// Length of the parameter domain, n+1.
    pub fn period(&self) -> f64 {
        self.n_control() as f64
    }

    /// Domain knots ξ_0..ξ_{n+1}.
    pub fn domain(&self) -> &[f64] {
        &self.ext[3..self.ext.len() - 3]
    }

    /// All n+8 knots ξ_{-3}..ξ_{n+4} (index k+3 holds ξ_k).
    pub fn extended(&self) -> &[f64] {
        &self.ext
    }

    /// `t` wrapped into [0, n+1).
    pub fn wrap(&self, t: f64) -> f64 {
        let p = self.period();
        if (0.0..p).contains(&t) {
            return t;
        }
        let w = t.rem_euclid(p);
        // rem_euclid may return p itself for tiny negative t.
        if w >= p {
            0.0
        } else {
            w
        }
    }

    /// Span s ∈ 0..=n with ξ_s ≤ t < ξ_{s+1}, for t already wrapped into [0, n+1).
    pub fn span(&self, t: f64) -> usize {
        let d = self.domain();
        let n = d.len() - 2;
        // Domain knots average one unit apart: guess ⌊t⌋ and walk a few steps; fall back to
        // binary search for very uneven knots.
        if t.is_finite() && t >= 0.0 {
            let mut s = (t as usize).min(n);
            for _ in 0..8 {
                if d[s] > t {
                    s -= 1;
                } else if s < n && d[s + 1] <= t {
                    s += 1;
                } else {
                    return s;
                }
            }
        }
        let s = d.partition_point(|&x| x <= t);
        s.saturating_sub(1).min(n)
    }
}

/// Clamped knot vector of an open cubic B-spline.
#[derive(Debug, Clone, PartialEq)]
pub struct ClampedKnotVector {
    knots: Vec<f64>,
}

impl ClampedKnotVector {
    /// From the full knot vector (r+7 entries for r+3 control points).
    pub fn try_new(knots: &[f64]) -> Result<Self, BsplineError> {
        let len = knots.len();
        if len < 8 {
            return Err(BsplineError::InvalidKnots(format!(
                "got {len} knots, expected at least 8 (4 control points)"
            )));
        }
        if let Some(i) = knots.iter().position(|x| !x.is_finite()) {
            return Err(BsplineError::InvalidKnots(format!(
                "knot {i} is {}",
                knots[i]
            )));
        }
        for i in 0..len - 1 {
            if knots[i + 1] < knots[i] {
                return Err(BsplineError::InvalidKnots(format!(
                    "knots decrease: v[{}] = {} > v[{}] = {}",
                    i,
                    knots[i],
                    i + 1,
                    knots[i + 1]
                )));
            }
        }
        if knots[0] != knots[3] || knots[len - 4] != knots[len - 1] {
            return Err(BsplineError::InvalidKnots(format!(
                "not clamped: first four {:?}, last four {:?}",
                &knots[..4],
                &knots[len - 4..]
            )));
        }
        if knots[3] >= knots[len - 4] {
            return Err(BsplineError::InvalidKnots(format!(
                "empty domain [{}, {}]",
                knots[3],
                knots[len - 4]
            )));
        }
        // Interior multiplicity ≤ 3 keeps the curve continuous.
        let mut run = 1;
        for i in 4..len - 4 {
            run = if knots[i] == knots[i - 1] { run + 1 } else { 1 };
            if knots[i] == knots[3] || run > DEGREE {
                return Err(BsplineError::InvalidKnots(format!(
                    "interior knot v[{i}] = {} has multiplicity above {DEGREE} or sits on an end",
                    knots[i]
                )));
            }
        }
        if len > 8 && knots[len - 5] == knots[len - 4] {
            return Err(BsplineError::InvalidKnots(format!(
                "interior knot v[{}] = {} sits on the end knot",
                len - 5,
                knots[len - 5]
            )));
        }
        Ok(Self {
            knots: knots.to_vec(),
        })
    }

    /// From the domain ends and the interior knots.
    pub fn try_from_interior(a: f64, b: f64, interior: &[f64]) -> Result<Self, BsplineError> {
        let mut k = vec![a; 4];
        k.extend_from_slice(interior);
        k.extend([b; 4]);
        Self::try_new(&k)
    }

    /// The full knot vector.
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// Number of control points (knots − 4).
    pub fn n_control(&self) -> usize {
        self.knots.len() - 4
    }

    /// Domain [v_0, v_end].
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[3], self.knots[self.knots.len() - 4])
    }

    /// Index k (into [`Self::knots`]) of the non-empty span holding `t` (clamped to the
    /// domain; the right end belongs to the last span).
    pub fn span(&self, t: f64) -> usize {
        let (a, b) = self.domain();
        let t = t.clamp(a, b);
        let last = self.knots.len() - 5;
        if t >= b {
            return last;
        }
        // saturating: a NaN t finds no knot ≤ t.
        let k = self.knots.partition_point(|&x| x <= t).saturating_sub(1);
        k.clamp(3, last)
    }
}
