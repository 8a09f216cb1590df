//! Analytic shapes with a known surface, as signed distance functions in patient mm.
//!
//! In: a patient point `[x, y, z]` (mm, LPS; slices are stacked along +z). Out: a signed
//! distance, negative inside. Every shape is a *plain* union (`min`) of primitives (capsules,
//! tori, ellipsoids), never a smooth union, so the surface is exactly the zero set of the union
//! of the primitives, with creases where primitives meet.
//!
//! Exactness (documented because tests measure surface errors against it):
//! - capsule and torus distances are exact; the ellipsoid "distance" is the 1-Lipschitz bound
//!   `(|p / r| − 1) · min(r)`: zero exactly on the surface, `|value| ≤` true distance elsewhere;
//! - outside a union, `min` of exact distances is the exact distance to the union;
//! - inside a union, `min` is a lower bound of the depth (the true depth can be larger where
//!   primitives overlap), with the correct sign.
//!
//! Hence `signed_distance(p) == 0` exactly on the surface, the sign is always right, and
//! `|signed_distance(p)|` never exceeds the true distance: the sampler relies on this to skip
//! supersampling far from the surface.
//!
//! All shapes fit in the box |x|, |y| ≤ 45 mm, |z| ≤ 42 mm ([`Shape::bounds`]), which the
//! default [`super::PhantomSpec`] covers, so every surface is closed inside the volume.

use crate::bspline::vecops::{dot, sub};

/// The phantom shapes, by CLI name (see [`Shape::NAMES`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Shape {
    /// A Y: one tube (capsule) splitting in two. Slices: 1 contour, then 2 (3 surfaces).
    TubeSplit,
    /// An X: two tubes that merge then split. Slices: 2, 1, 2 contours.
    TubesCrossing,
    /// A torus with a horizontal axis (y): slices cut it in 1 then 2 then 1 contours.
    TorusStanding,
    /// A torus with its axis along z: slices have a contour with a hole.
    TorusFlat,
    /// Three separate ellipsoids: several unrelated closed surfaces.
    Blobs,
    /// One tube splitting into three.
    TubeThree,
}

impl Shape {
    /// The CLI names, in the order of [`Shape::ALL`].
    pub const NAMES: [&'static str; 6] = [
        "tube-split",
        "tubes-crossing",
        "torus-standing",
        "torus-flat",
        "blobs",
        "tube-three",
    ];

    pub const ALL: [Shape; 6] = [
        Shape::TubeSplit,
        Shape::TubesCrossing,
        Shape::TorusStanding,
        Shape::TorusFlat,
        Shape::Blobs,
        Shape::TubeThree,
    ];

    pub fn name(&self) -> &'static str {
        match self {
            Shape::TubeSplit => "tube-split",
            Shape::TubesCrossing => "tubes-crossing",
            Shape::TorusStanding => "torus-standing",
            Shape::TorusFlat => "torus-flat",
            Shape::Blobs => "blobs",
            Shape::TubeThree => "tube-three",
        }
    }

    /// The shape with CLI name `name`, or `None` (callers list [`Shape::NAMES`] in the error).
    pub fn from_name(name: &str) -> Option<Shape> {
        Shape::ALL.iter().copied().find(|s| s.name() == name)
    }

    /// Axis-aligned bounding box `[min, max]` of the shape (mm), a little generous.
    pub fn bounds(&self) -> [[f64; 3]; 2] {
        [[-45.0, -45.0, -42.0], [45.0, 45.0, 42.0]]
    }

    /// Signed distance (mm, negative inside) of patient point `p`; see the module doc for how
    /// exact it is.
    pub fn signed_distance(&self, p: [f64; 3]) -> f64 {
        match self {
            Shape::TubeSplit => {
                let fork = [0.0, 0.0, 0.0];
                let trunk = capsule(p, [0.0, 0.0, -32.0], fork, 8.0);
                let left = capsule(p, fork, [-20.0, 0.0, 32.0], 6.0);
                let right = capsule(p, fork, [20.0, 0.0, 32.0], 6.0);
                trunk.min(left).min(right)
            }
            Shape::TubesCrossing => {
                let a = capsule(p, [-20.0, 0.0, -32.0], [20.0, 0.0, 32.0], 7.0);
                let b = capsule(p, [20.0, 0.0, -32.0], [-20.0, 0.0, 32.0], 7.0);
                a.min(b)
            }
            Shape::TorusStanding => {
                // Axis along y: the ring lies in the x–z plane.
                torus([p[0], p[2], p[1]], 26.0, 8.0)
            }
            Shape::TorusFlat => torus(p, 26.0, 9.0),
            Shape::Blobs => {
                let a = ellipsoid(p, [-22.0, -14.0, -14.0], [12.0, 9.0, 14.0]);
                let b = ellipsoid(p, [20.0, 12.0, 2.0], [13.0, 10.0, 10.0]);
                let c = ellipsoid(p, [0.0, 22.0, 24.0], [9.0, 8.0, 10.0]);
                a.min(b).min(c)
            }
            Shape::TubeThree => {
                let fork = [0.0, 0.0, 0.0];
                let mut d = capsule(p, [0.0, 0.0, -32.0], fork, 9.0);
                for k in 0..3 {
                    let a = (90.0 + 120.0 * k as f64).to_radians();
                    let end = [22.0 * a.cos(), 22.0 * a.sin(), 32.0];
                    d = d.min(capsule(p, fork, end, 5.5));
                }
                d
            }
        }
    }
}

/// Grid step (mm) of [`Shape::volume`]'s rays.
pub const VOLUME_STEP_MM: f64 = 0.05;

impl Shape {
    /// Closed-form volume (mm³) where there is one: the tori (Pappus, 2π²Rr²) and the blobs
    /// (three disjoint ellipsoids, 4/3·π·abc each).
    pub fn exact_volume(&self) -> Option<f64> {
        use std::f64::consts::PI;
        match self {
            Shape::TorusStanding => Some(2.0 * PI * PI * 26.0 * 8.0 * 8.0),
            Shape::TorusFlat => Some(2.0 * PI * PI * 26.0 * 9.0 * 9.0),
            Shape::Blobs => {
                Some(4.0 / 3.0 * PI * (12.0 * 9.0 * 14.0 + 13.0 * 10.0 * 10.0 + 9.0 * 8.0 * 10.0))
            }
            _ => None,
        }
    }

    /// Volume (mm³) by integration of the signed distance function: rays along z through
    /// the centres of a square grid of `step` mm over the bounds (midpoint rule in x and y),
    /// each ray's inside intervals found by sphere tracing (`|signed_distance|` never
    /// exceeds the true distance) and bisection to 1e-12 mm. Agrees with
    /// [`Shape::exact_volume`] to about 1e-5 relative at [`VOLUME_STEP_MM`] (tested).
    pub fn volume(&self, step: f64) -> f64 {
        use rayon::prelude::*;
        let [lo, hi] = self.bounds();
        let nx = ((hi[0] - lo[0]) / step).ceil() as usize;
        let ny = ((hi[1] - lo[1]) / step).ceil() as usize;
        let rows: Vec<f64> = (0..ny)
            .into_par_iter()
            .map(|j| {
                let y = lo[1] + (j as f64 + 0.5) * step;
                (0..nx)
                    .map(|i| {
                        let x = lo[0] + (i as f64 + 0.5) * step;
                        self.inside_length(x, y, lo[2], hi[2])
                    })
                    .sum::<f64>()
            })
            .collect();
        rows.iter().sum::<f64>() * step * step
    }

    /// Length of the ray (x, y, z ∈ [z0, z1]) inside the shape.
    fn inside_length(&self, x: f64, y: f64, z0: f64, z1: f64) -> f64 {
        const MIN_STEP: f64 = 1e-3;
        let f = |z: f64| self.signed_distance([x, y, z]);
        let root = |mut a: f64, mut b: f64, fa: f64| {
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                if (f(m) < 0.0) == (fa < 0.0) {
                    a = m;
                } else {
                    b = m;
                }
                if b - a < 1e-12 {
                    break;
                }
            }
            0.5 * (a + b)
        };
        let (mut z, mut d) = (z0, f(z0));
        let mut entered: Option<f64> = (d < 0.0).then_some(z0);
        let mut len = 0.0;
        while z < z1 {
            let zn = (z + d.abs().max(MIN_STEP)).min(z1);
            let dn = f(zn);
            if (dn < 0.0) != (d < 0.0) {
                let r = root(z, zn, d);
                match entered.take() {
                    Some(e) => len += r - e,
                    None => entered = Some(r),
                }
            }
            z = zn;
            d = dn;
        }
        if let Some(e) = entered {
            len += z1 - e;
        }
        len
    }
}

impl std::fmt::Display for Shape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Exact distance to a capsule (segment `a`–`b` swept by a ball of radius `r`).
fn capsule(p: [f64; 3], a: [f64; 3], b: [f64; 3], r: f64) -> f64 {
    let pa = sub(&p, &a);
    let ba = sub(&b, &a);
    let t = (dot(&pa, &ba) / dot(&ba, &ba)).clamp(0.0, 1.0);
    let q = [pa[0] - t * ba[0], pa[1] - t * ba[1], pa[2] - t * ba[2]];
    dot(&q, &q).sqrt() - r
}

/// Exact distance to a torus around the z axis (major radius `big`, tube radius `small`).
fn torus(p: [f64; 3], big: f64, small: f64) -> f64 {
    let ring = (p[0] * p[0] + p[1] * p[1]).sqrt() - big;
    (ring * ring + p[2] * p[2]).sqrt() - small
}

/// 1-Lipschitz signed bound for an axis-aligned ellipsoid (centre `c`, radii `r`): exact zero set.
fn ellipsoid(p: [f64; 3], c: [f64; 3], r: [f64; 3]) -> f64 {
    let q = [
        (p[0] - c[0]) / r[0],
        (p[1] - c[1]) / r[1],
        (p[2] - c[2]) / r[2],
    ];
    let rmin = r[0].min(r[1]).min(r[2]);
    (dot(&q, &q).sqrt() - 1.0) * rmin
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for (s, n) in Shape::ALL.iter().zip(Shape::NAMES) {
            assert_eq!(s.name(), n);
            assert_eq!(Shape::from_name(n), Some(*s));
        }
        assert_eq!(Shape::from_name("cube"), None);
    }

    #[test]
    fn known_distances() {
        // Torus flat: centre of the tube is inside at depth = tube radius.
        assert!((Shape::TorusFlat.signed_distance([26.0, 0.0, 0.0]) + 9.0).abs() < 1e-12);
        // The hole's centre is outside by big − small.
        assert!((Shape::TorusFlat.signed_distance([0.0, 0.0, 0.0]) - 17.0).abs() < 1e-12);
        // Trunk of the Y at z = −20: radius 8.
        assert!((Shape::TubeSplit.signed_distance([8.0, 0.0, -20.0])).abs() < 1e-12);
        // Standing torus: tube centre at x = 26 on the z = 0 slice.
        assert!((Shape::TorusStanding.signed_distance([26.0, 0.0, 0.0]) + 8.0).abs() < 1e-12);
    }

    #[test]
    fn numeric_volume_matches_closed_forms() {
        for s in [Shape::TorusFlat, Shape::Blobs] {
            let exact = s.exact_volume().unwrap();
            let got = s.volume(0.25);
            eprintln!(
                "{s}: {got} by rays vs {exact}: {:+.2e}",
                (got - exact) / exact
            );
            assert!(
                ((got - exact) / exact).abs() < 2e-4,
                "{s}: {got} vs {exact}"
            );
        }
    }

    #[test]
    fn everything_inside_bounds() {
        // Sample the bounding box faces: all outside.
        for s in Shape::ALL {
            let [lo, hi] = s.bounds();
            for i in 0..=20 {
                for j in 0..=20 {
                    let u = i as f64 / 20.0;
                    let v = j as f64 / 20.0;
                    let x = lo[0] + u * (hi[0] - lo[0]);
                    let y = lo[1] + v * (hi[1] - lo[1]);
                    let z = lo[2] + v * (hi[2] - lo[2]);
                    for p in [[x, y, lo[2]], [x, y, hi[2]], [lo[0], y, z], [hi[0], y, z]] {
                        assert!(s.signed_distance(p) > 0.0, "{s} inside at {p:?}");
                    }
                }
            }
        }
    }
}
