//! What the CAD writers ([`super::step`], [`super::iges`]) share: the periodic-to-open
//! unwrapping of a [`SkinnedSurface`], knot lists as (distinct value, multiplicity), the number
//! format, and the file metadata.
//!
//! In: a skinned surface (periodic cubic in u with n+1 distinct control rows and the extended
//! knots ξ_{-3}..ξ_{n+4}; clamped cubic in v). Out: the same surface as an ordinary
//! (non-periodic) bicubic B-spline: n+4 control rows V_{i mod (n+1)} (the first three rows
//! repeated at the end), the n+8 extended knots as u knots (each of multiplicity 1: the domain
//! knots are strictly increasing), the clamped v knots unchanged. Invariant: the parameters are
//! the identity, S_open(u, v) = S(u, v) for u ∈ [ξ_0, ξ_{n+1}] = [0, n+1] and v in the v domain,
//! because the open B-spline's basis function k on the extended knots is exactly the periodic
//! basis function that carries control row k mod (n+1) (see `SkinnedSurface::eval`).

use crate::bspline::SkinnedSurface;

type P3 = [f64; 3];

/// Fixed timestamp written into STEP and IGES headers: the files carry no clock time, so the
/// same input gives the same bytes.
pub const FIXED_TIMESTAMP: &str = "2000-01-01T00:00:00";

/// Header data of a CAD file.
#[derive(Debug, Clone, PartialEq)]
pub struct CadMeta {
    /// File name recorded inside the file (STEP FILE_NAME, IGES global parameter 4).
    pub file_name: String,
    /// Free text describing the content, e.g. the DICOM series.
    pub description: String,
    /// Patient coordinate system of the geometry, "LPS" (DICOM) or "RAS"; only recorded
    /// (the surfaces are given in it).
    pub coordinates: &'static str,
    /// Producing system, e.g. "bskin 0.1.0".
    pub system: String,
    /// ISO 8601 date and time; [`FIXED_TIMESTAMP`] by default so output is reproducible.
    pub timestamp: String,
}

impl Default for CadMeta {
    fn default() -> Self {
        CadMeta {
            file_name: String::new(),
            description: "bskin B-spline surfaces".into(),
            coordinates: "LPS",
            system: format!("bskin {}", env!("CARGO_PKG_VERSION")),
            timestamp: FIXED_TIMESTAMP.into(),
        }
    }
}

/// A skinned surface as an open (non-periodic) bicubic B-spline; see the module doc.
#[derive(Debug, Clone, PartialEq)]
pub struct Unwrapped {
    /// Full u knot vector: the n+8 extended periodic knots.
    pub u_knots: Vec<f64>,
    /// Full v knot vector (clamped: end multiplicities 4).
    pub v_knots: Vec<f64>,
    /// `rows[i][j]`, i along u (n+4 rows), j along v (n_v).
    pub rows: Vec<Vec<P3>>,
    /// Parameter domain in u: [ξ_0, ξ_{n+1}].
    pub u_domain: (f64, f64),
    /// Parameter domain in v.
    pub v_domain: (f64, f64),
}

impl Unwrapped {
    pub fn of(s: &SkinnedSurface) -> Self {
        let (nu, nv) = (s.n_u(), s.n_v());
        let rows = (0..nu + 3)
            .map(|i| (0..nv).map(|j| s.control_point(i % nu, j)).collect())
            .collect();
        let d = s.u_knots().domain();
        Unwrapped {
            u_knots: s.u_knots().extended().to_vec(),
            v_knots: s.v_knots().knots().to_vec(),
            rows,
            u_domain: (d[0], d[d.len() - 1]),
            v_domain: s.v_knots().domain(),
        }
    }

    /// Control points of the iso-curve at u = `u` (a v-direction curve on the v knots): the u
    /// basis at `u` applied to each column. Used for the seam at u = ξ_0.
    pub fn u_iso_control(&self, u: f64) -> Vec<P3> {
        let w = basis_at(&self.u_knots, 3, u);
        let nv = self.rows.first().map_or(0, |r| r.len());
        (0..nv)
            .map(|j| {
                let mut p = [0.0; 3];
                for (i, wi) in w.iter().enumerate() {
                    if *wi != 0.0 {
                        for (x, px) in p.iter_mut().enumerate() {
                            *px += wi * self.rows[i][j][x];
                        }
                    }
                }
                p
            })
            .collect()
    }

    /// All control points, for bounding the coordinates.
    pub fn max_abs_coordinate(&self) -> f64 {
        self.rows
            .iter()
            .flatten()
            .flat_map(|p| p.iter())
            .fold(0.0, |m: f64, c| m.max(c.abs()))
    }
}

/// Every basis function N_{k,degree}(t) on the full knot vector (Cox–de Boor, right end
/// belonging to the last non-empty span).
pub fn basis_at(knots: &[f64], degree: usize, t: f64) -> Vec<f64> {
    let m = knots.len();
    if m < degree + 2 {
        return Vec::new();
    }
    let n = m - degree - 1;
    let (a, b) = (knots[degree], knots[n]);
    let t = t.clamp(a, b);
    // Span: ξ_s ≤ t < ξ_{s+1}, s in degree..n-1; t = b goes to the last non-empty span.
    let mut s = degree;
    for k in degree..n {
        if knots[k] <= t && (t < knots[k + 1] || (t >= b && knots[k] < knots[k + 1])) {
            s = k;
            if t < knots[k + 1] {
                break;
            }
        }
    }
    let mut local = vec![0.0; degree + 1];
    local[0] = 1.0;
    for d in 1..=degree {
        let mut saved = 0.0;
        for r in 0..d {
            let left = knots[s + 1 + r - d];
            let right = knots[s + 1 + r];
            let denom = right - left;
            let tmp = if denom > 0.0 { local[r] / denom } else { 0.0 };
            local[r] = saved + (right - t) * tmp;
            saved = (t - left) * tmp;
        }
        local[d] = saved;
    }
    let mut out = vec![0.0; n];
    for (r, v) in local.into_iter().enumerate() {
        out[s - degree + r] = v;
    }
    out
}

/// (distinct values, multiplicities) of a non-decreasing knot vector.
pub fn knots_with_mults(knots: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut values: Vec<f64> = Vec::new();
    let mut mults: Vec<usize> = Vec::new();
    for &k in knots {
        match values.last() {
            Some(&last) if last == k => {
                if let Some(m) = mults.last_mut() {
                    *m += 1;
                }
            }
            _ => {
                values.push(k);
                mults.push(1);
            }
        }
    }
    (values, mults)
}

/// A real in the shortest form that reads back to the same f64, with the decimal point and
/// exponent letter both STEP (ISO 10303-21 REAL) and IGES accept: `1.5E-7`, `1.E0`, `-0.25E2`.
pub fn real(x: f64) -> String {
    // Non-finite values cannot occur (SkinnedSurface validates), but never write "NaN".
    let x = if x.is_finite() { x } else { 0.0 };
    let s = format!("{x:e}");
    let (mant, exp) = s.split_once('e').unwrap_or((&s, "0"));
    if mant.contains('.') {
        format!("{mant}E{exp}")
    } else {
        format!("{mant}.E{exp}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_round_trip_and_have_a_point() {
        for x in [
            0.0,
            -0.0,
            1.0,
            -2.5,
            1e-7,
            123456.789,
            0.1 + 0.2,
            f64::MAX,
            5e-324,
        ] {
            let s = real(x);
            assert!(s.contains('.') && s.contains('E'), "{s}");
            assert_eq!(s.parse::<f64>().unwrap(), x, "{s}");
        }
        assert_eq!(real(1.0), "1.E0");
        assert_eq!(real(-0.25), "-2.5E-1");
    }

    #[test]
    fn mults() {
        let (v, m) = knots_with_mults(&[0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 2.0, 3.0, 3.0, 3.0, 3.0]);
        assert_eq!(v, vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(m, vec![4, 1, 2, 4]);
    }

    #[test]
    fn basis_partition_of_unity() {
        let k = [-3.0, -2.0, -1.0, 0.0, 1.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0];
        for t in [0.0, 0.3, 2.5, 3.9, 4.0] {
            let b = basis_at(&k, 3, t);
            assert_eq!(b.len(), 7);
            assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        }
    }
}
