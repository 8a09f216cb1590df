//! Faces of a triangle mesh that cross another of its faces: the count a mesh checker
//! reports as self-intersecting faces (MeshLab's "select self intersecting faces", which
//! `scripts/mesh_crossings.py` runs), made here so that a choice between two surfaces can be
//! judged by the mesh it gives.
//!
//! Two faces cross when an edge of one passes properly through the other (for faces not in
//! one plane, every crossing has such an edge: each end of the segment they share lies on an
//! edge of one of them). Faces that share a vertex are neighbours, not crossings, and faces
//! only touching do not count: the signs of orientation tests must be strict.
//!
//! Cost: a uniform grid of cells about the size of a face, each face tested against the faces
//! in the cells its box covers. A mesh too large to hold is checked slab by slab along z
//! ([`slabs`], [`crossing_pairs_in_slab`]), each slab's faces read in turn.

use std::collections::{BTreeMap, HashMap};

use super::Triangle;
use crate::bspline::vecops::{dist, sub};

type P3 = [f64; 3];

/// How many of `faces` properly cross another face that shares no vertex with them.
pub fn crossing_faces(faces: &[Triangle]) -> usize {
    let mut crossing = vec![false; faces.len()];
    for (i, j) in crossing_pairs(faces) {
        crossing[i] = true;
        crossing[j] = true;
    }
    crossing.iter().filter(|&&c| c).count()
}

/// Every pair `(i, j)`, `i < j`, of `faces` that properly cross and share no vertex, in
/// ascending `i` (to tell which surfaces of a mesh cross which).
pub fn crossing_pairs(faces: &[Triangle]) -> Vec<(usize, usize)> {
    if faces.len() < 2 {
        return Vec::new();
    }
    let boxes: Vec<(P3, P3)> = faces.iter().map(bounds).collect();
    let cell = cell_size(faces);
    if !(cell.is_finite() && cell > 0.0) {
        return Vec::new();
    }
    let cells = |(lo, hi): &(P3, P3)| {
        let key = |p: &P3| -> [i64; 3] { std::array::from_fn(|d| (p[d] / cell).floor() as i64) };
        let (a, b) = (key(lo), key(hi));
        (a[0]..=b[0]).flat_map(move |x| {
            (a[1]..=b[1]).flat_map(move |y| (a[2]..=b[2]).map(move |z| [x, y, z]))
        })
    };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (i, b) in boxes.iter().enumerate() {
        for c in cells(b) {
            grid.entry(c).or_default().push(i as u32);
        }
    }
    let mut pairs = Vec::new();
    let mut seen = vec![u32::MAX; faces.len()];
    for (i, b) in boxes.iter().enumerate() {
        for c in cells(b) {
            for &j in &grid[&c] {
                let j = j as usize;
                if j <= i || seen[j] == i as u32 {
                    continue;
                }
                seen[j] = i as u32;
                if boxes_overlap(b, &boxes[j])
                    && !share_vertex(&faces[i], &faces[j])
                    && faces_cross(&faces[i], &faces[j])
                {
                    pairs.push((i, j));
                }
            }
        }
    }
    pairs
}

/// A face's lowest and highest z.
pub fn z_extent(t: &Triangle) -> (f64, f64) {
    (
        t[0][2].min(t[1][2]).min(t[2][2]),
        t[0][2].max(t[1][2]).max(t[2][2]),
    )
}

/// Whether a face with z extent `(low, high)` reaches into the slab `lo ≤ z < hi`, so that
/// [`crossing_pairs_in_slab`] must be given it.
pub fn reaches_slab((low, high): (f64, f64), (lo, hi): (f64, f64)) -> bool {
    high >= lo && low < hi
}

/// [`crossing_pairs`] of `faces`, every face of a mesh that reaches into the slab `lo ≤ z <
/// hi` ([`reaches_slab`]), keeping the pairs whose overlap along z starts in the slab: the
/// higher of the two faces' lowest z lies in `[lo, hi)`. Two faces that cross overlap along z
/// and both reach into the slab where their overlap starts, so over slabs that partition z
/// every crossing pair of the mesh is found once.
pub fn crossing_pairs_in_slab(faces: &[Triangle], (lo, hi): (f64, f64)) -> Vec<(usize, usize)> {
    let mut pairs = crossing_pairs(faces);
    pairs.retain(|&(i, j)| {
        let start = z_extent(&faces[i]).0.max(z_extent(&faces[j]).0);
        lo <= start && start < hi
    });
    pairs
}

/// Slabs `[lo, hi)` partitioning z (the first from −∞, the last to +∞) from the faces' count
/// per bin of lowest z (`starts`: bin `k` is `k·bin ≤ z < (k+1)·bin`), cut at bin edges so
/// that at most `cap` faces start in each slab, unless one bin alone holds more. A slab also
/// holds the faces reaching up into it from below: at most a band between two curves high,
/// they add a fraction.
pub fn slabs(starts: &BTreeMap<i64, u64>, bin: f64, cap: u64) -> Vec<(f64, f64)> {
    let mut cuts = Vec::new();
    let mut held = 0u64;
    for (&k, &n) in starts {
        if held > 0 && held + n > cap {
            cuts.push(k as f64 * bin);
            held = 0;
        }
        held += n;
    }
    let edges: Vec<f64> = std::iter::once(f64::NEG_INFINITY)
        .chain(cuts)
        .chain(std::iter::once(f64::INFINITY))
        .collect();
    edges.windows(2).map(|w| (w[0], w[1])).collect()
}

fn cell_size(faces: &[Triangle]) -> f64 {
    let mut longest: Vec<f64> = faces
        .iter()
        .map(|t| {
            (0..3)
                .map(|k| dist(&t[k], &t[(k + 1) % 3]))
                .fold(0.0, f64::max)
        })
        .filter(|l| l.is_finite())
        .collect();
    if longest.is_empty() {
        return f64::NAN;
    }
    let mid = longest.len() / 2;
    let (_, m, _) = longest.select_nth_unstable_by(mid, f64::total_cmp);
    2.0 * *m
}

fn bounds(t: &Triangle) -> (P3, P3) {
    let lo = std::array::from_fn(|d| t[0][d].min(t[1][d]).min(t[2][d]));
    let hi = std::array::from_fn(|d| t[0][d].max(t[1][d]).max(t[2][d]));
    (lo, hi)
}

fn boxes_overlap(a: &(P3, P3), b: &(P3, P3)) -> bool {
    (0..3).all(|d| a.0[d] <= b.1[d] && b.0[d] <= a.1[d])
}

fn share_vertex(a: &Triangle, b: &Triangle) -> bool {
    a.iter().any(|p| b.contains(p))
}

/// Whether an edge of either face passes properly through the other.
fn faces_cross(a: &Triangle, b: &Triangle) -> bool {
    let pierces =
        |s: &Triangle, t: &Triangle| (0..3).any(|k| segment_pierces(&s[k], &s[(k + 1) % 3], t));
    pierces(a, b) || pierces(b, a)
}

/// Whether segment pq crosses the interior of triangle t: p and q strictly either side of its
/// plane, and pq passing strictly inside each of its edges.
fn segment_pierces(p: &P3, q: &P3, t: &Triangle) -> bool {
    let (sp, sq) = (
        orient(&t[0], &t[1], &t[2], p),
        orient(&t[0], &t[1], &t[2], q),
    );
    // NaN compares false: a face with a non-finite vertex crosses nothing.
    if sp * sq >= 0.0 || (sp * sq).is_nan() {
        return false;
    }
    let e: [f64; 3] = std::array::from_fn(|k| orient(p, q, &t[k], &t[(k + 1) % 3]));
    (e[0] > 0.0 && e[1] > 0.0 && e[2] > 0.0) || (e[0] < 0.0 && e[1] < 0.0 && e[2] < 0.0)
}

/// Six times the signed volume of the tetrahedron abcd.
fn orient(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
    let (u, v, w) = (sub(b, a), sub(c, a), sub(d, a));
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of two faces in the plane z = `z`, turned by `turn` about the z axis.
    fn square(z: f64, size: f64, turn: f64) -> Vec<Triangle> {
        let (c, s) = (turn.cos(), turn.sin());
        let p = |x: f64, y: f64| [c * x - s * y, s * x + c * y, z];
        let h = size / 2.0;
        let (a, b, cc, d) = (p(-h, -h), p(h, -h), p(h, h), p(-h, h));
        vec![[a, b, cc], [a, cc, d]]
    }

    #[test]
    fn two_squares_through_each_other_cross_and_apart_do_not() {
        // A square standing in the plane x = 0 through one lying in z = 0.
        let lying = square(0.0, 2.0, 0.3);
        let standing: Vec<Triangle> = square(0.0, 2.0, 0.0)
            .into_iter()
            .map(|t| t.map(|p| [0.0, p[0], p[1]]))
            .collect();
        let both: Vec<Triangle> = lying.iter().chain(&standing).copied().collect();
        assert_eq!(crossing_faces(&both), 4);
        // Lifted clear of it: nothing crosses.
        let lifted: Vec<Triangle> = standing
            .iter()
            .map(|t| t.map(|p| [p[0], p[1], p[2] + 1.5]))
            .collect();
        let apart: Vec<Triangle> = lying.iter().chain(&lifted).copied().collect();
        assert_eq!(crossing_faces(&apart), 0);
    }

    #[test]
    fn neighbours_and_parallel_faces_do_not_cross() {
        // Two stacked squares: a closed fan would share vertices; parallel planes never meet.
        let stacked: Vec<Triangle> = square(0.0, 2.0, 0.0)
            .into_iter()
            .chain(square(0.5, 2.0, 0.7))
            .collect();
        assert_eq!(crossing_faces(&stacked), 0);
        // A fan round one vertex, folded steeply: faces share the apex and never cross.
        let apex = [0.0, 0.0, 0.0];
        let fan: Vec<Triangle> = (0..8)
            .map(|k| {
                let (a, b) = (k as f64 * 0.8, (k + 1) as f64 * 0.8);
                let z = |t: f64| if (t / 0.8) as i64 % 2 == 0 { 1.0 } else { -1.0 };
                [apex, [a.cos(), a.sin(), z(a)], [b.cos(), b.sin(), z(b)]]
            })
            .collect();
        assert_eq!(crossing_faces(&fan), 0);
    }

    /// Faces of a random soup, from a little linear congruential generator (fixed seeds:
    /// the same soup every run).
    fn soup(seed: u64, n: usize, size: f64) -> Vec<Triangle> {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let c: [f64; 3] = std::array::from_fn(|_| next() * 10.0);
                std::array::from_fn(|_| std::array::from_fn(|d| c[d] + (next() - 0.5) * size))
            })
            .collect()
    }

    #[test]
    fn slabs_find_every_crossing_pair_once() {
        for (seed, cap) in [(1, 7), (2, 40), (3, 1), (4, 1_000)] {
            let faces = soup(seed, 400, 2.0);
            let mut whole = crossing_pairs(&faces);
            whole.sort_unstable();
            assert!(whole.len() > 50, "seed {seed}: a soup that crosses");
            let bin = 0.5;
            let mut starts = BTreeMap::new();
            for t in &faces {
                *starts
                    .entry((z_extent(t).0 / bin).floor() as i64)
                    .or_insert(0u64) += 1;
            }
            let slabs = slabs(&starts, bin, cap);
            assert_eq!(slabs.len() > 1, cap < 400, "seed {seed}, cap {cap}");
            let mut found = Vec::new();
            for slab in slabs {
                let (held, index): (Vec<Triangle>, Vec<usize>) = faces
                    .iter()
                    .enumerate()
                    .filter(|(_, t)| reaches_slab(z_extent(t), slab))
                    .map(|(k, t)| (*t, k))
                    .unzip();
                found.extend(
                    crossing_pairs_in_slab(&held, slab)
                        .into_iter()
                        .map(|(i, j)| (index[i], index[j])),
                );
            }
            found.sort_unstable();
            assert_eq!(found, whole, "seed {seed}, cap {cap}");
        }
    }

    #[test]
    fn slabs_cut_at_bin_edges_and_cover_all_z() {
        let starts = BTreeMap::from([(-2, 3u64), (0, 3), (1, 3), (5, 10), (6, 1)]);
        let s = slabs(&starts, 0.5, 6);
        assert_eq!(
            s,
            vec![
                (f64::NEG_INFINITY, 0.5),
                (0.5, 2.5),
                (2.5, 3.0),
                (3.0, f64::INFINITY)
            ]
        );
        assert_eq!(
            slabs(&BTreeMap::new(), 0.5, 6),
            vec![(f64::NEG_INFINITY, f64::INFINITY)]
        );
    }

    #[test]
    fn a_face_through_a_tessellated_sheet_crosses_only_the_faces_it_passes() {
        // A 10 × 10 grid of squares (200 faces) in z = 0, and one small upright face through
        // the middle of grid square (4, 4) only.
        let mut faces = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                let (x, y) = (i as f64, j as f64);
                let (a, b, c, d) = (
                    [x, y, 0.0],
                    [x + 1.0, y, 0.0],
                    [x + 1.0, y + 1.0, 0.0],
                    [x, y + 1.0, 0.0],
                );
                faces.push([a, b, c]);
                faces.push([a, c, d]);
            }
        }
        // Across the diagonal of square (4, 4): it passes through both of its faces.
        faces.push([[4.2, 4.5, -0.5], [4.8, 4.5, -0.5], [4.5, 4.5, 0.5]]);
        assert_eq!(crossing_faces(&faces), 3);
    }
}
