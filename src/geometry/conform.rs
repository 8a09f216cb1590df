//! Conforming vertex sets for loops that share boundary (a branching problem's intermediate
//! contours below and above, a cap's outer and hole loops).
//!
//! The loops of one problem tile the same area and share almost all their vertices bit for
//! bit, but now and then a vertex of one loop lies on an edge of another loop without being
//! one of its vertices (a T-junction). A mesh joined along those loops then has an edge used
//! once on one side and two shorter edges on the other: not watertight. [`conform`] inserts
//! every such vertex into the edge it lies on, with its identical coordinates, so every loop
//! edge on a shared stretch of boundary exists in exactly the loops that share it.

use std::collections::HashMap;

use super::polygon::{dist, Point};

/// Insert into every loop each vertex of another loop that lies within `eps` of one of its
/// edges (strictly between the edge's ends) and is not already one of its vertices. Returns the
/// number of insertions. One pass suffices: inserted points are existing vertices, and each
/// edge collects all its candidates at once.
pub fn conform(loops: &mut [&mut Vec<Point>], eps: f64) -> usize {
    let total: usize = loops.iter().map(|l| l.len()).sum();
    if loops.len() < 2 || total == 0 {
        return 0;
    }
    // Bucket every vertex (with its loop) on a grid about one mean edge long.
    let (mut len_sum, mut edges) = (0.0, 0usize);
    for l in loops.iter() {
        for i in 0..l.len() {
            let (a, b) = (l[i], l[(i + 1) % l.len()]);
            len_sum += dist(a, b);
            edges += 1;
        }
    }
    let h = (len_sum / edges.max(1) as f64).max(eps * 16.0).max(1e-12);
    let key = |p: Point| ((p[0] / h).floor() as i64, (p[1] / h).floor() as i64);
    let mut buckets: HashMap<(i64, i64), Vec<(usize, Point)>> = HashMap::new();
    for (li, l) in loops.iter().enumerate() {
        for &p in l.iter() {
            buckets.entry(key(p)).or_default().push((li, p));
        }
    }
    let mut inserted = 0;
    let mut out: Vec<Vec<Point>> = Vec::with_capacity(loops.len());
    for (li, l) in loops.iter().enumerate() {
        let n = l.len();
        let mut new = Vec::with_capacity(n);
        for i in 0..n {
            let (a, b) = (l[i], l[(i + 1) % n]);
            new.push(a);
            if n < 2 || a == b {
                continue;
            }
            let d = [b[0] - a[0], b[1] - a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let (lo, hi) = (
                key([a[0].min(b[0]) - eps, a[1].min(b[1]) - eps]),
                key([a[0].max(b[0]) + eps, a[1].max(b[1]) + eps]),
            );
            let mut on: Vec<(f64, Point)> = Vec::new();
            for kx in lo.0..=hi.0 {
                for ky in lo.1..=hi.1 {
                    let Some(cands) = buckets.get(&(kx, ky)) else {
                        continue;
                    };
                    for &(lj, p) in cands {
                        if lj == li || p == a || p == b {
                            continue;
                        }
                        let w = [p[0] - a[0], p[1] - a[1]];
                        let s = (w[0] * d[0] + w[1] * d[1]) / len2;
                        if s <= 0.0 || s >= 1.0 {
                            continue;
                        }
                        let cross = (w[0] * d[1] - w[1] * d[0]).abs() / len2.sqrt();
                        if cross <= eps {
                            on.push((s, p));
                        }
                    }
                }
            }
            if on.is_empty() {
                continue;
            }
            on.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1[0].total_cmp(&y.1[0])));
            on.dedup_by(|x, y| x.1 == y.1);
            for (_, p) in on {
                if !l.contains(&p) {
                    new.push(p);
                    inserted += 1;
                }
            }
        }
        out.push(new);
    }
    for (l, new) in loops.iter_mut().zip(out) {
        **l = new;
    }
    inserted
}

/// Snap vertices closer than `eps` to one another (within a loop or across the loops) onto
/// the first of them in loop order, then drop consecutive repeats; a loop that would keep
/// fewer than three points keeps its own. Near-duplicates (a few 1e-5 mm apart, from the
/// distance-map contouring) otherwise make a tiny edge that two tilings share three times.
/// Returns the number of points moved.
pub fn weld(loops: &mut [&mut Vec<Point>], eps: f64) -> usize {
    let h = eps.max(1e-300);
    let key = |p: Point| ((p[0] / h).floor() as i64, (p[1] / h).floor() as i64);
    let mut reps: HashMap<(i64, i64), Vec<Point>> = HashMap::new();
    let mut moved = 0;
    for l in loops.iter_mut() {
        let mut out: Vec<Point> = Vec::with_capacity(l.len());
        let mut moved_here = 0;
        for &p in l.iter() {
            let (kx, ky) = key(p);
            let mut found = None;
            'search: for dx in -1..=1 {
                for dy in -1..=1 {
                    if let Some(v) = reps.get(&(kx + dx, ky + dy)) {
                        if let Some(&q) = v.iter().find(|q| (q[0] - p[0]).hypot(q[1] - p[1]) <= eps)
                        {
                            found = Some(q);
                            break 'search;
                        }
                    }
                }
            }
            let q = match found {
                Some(q) => {
                    moved_here += (q != p) as usize;
                    q
                }
                None => {
                    reps.entry((kx, ky)).or_default().push(p);
                    p
                }
            };
            if out.last() != Some(&q) {
                out.push(q);
            }
        }
        while out.len() > 1 && out.first() == out.last() {
            out.pop();
        }
        if out.len() >= 3 {
            **l = out;
            moved += moved_here;
        }
    }
    moved
}

/// The loop without zero-area spikes (a vertex whose two neighbours are the same point: the
/// loop runs out along a chain and back, e.g. a dangling branch of a cap's ridge) and without
/// consecutive repeated points. The enclosed area is unchanged; loops of one problem that
/// share such a chain drop it together (it is removed wherever it occurs). A loop that would
/// keep fewer than three points is left as it is. Returns the number of points removed.
pub fn remove_spikes(l: &mut Vec<Point>) -> usize {
    let before = l.len();
    let mut out: Vec<Point> = Vec::with_capacity(l.len());
    for &p in l.iter() {
        if out.last() == Some(&p) {
            continue;
        }
        if out.len() >= 2 && out[out.len() - 2] == p {
            out.pop();
            continue;
        }
        out.push(p);
    }
    // Across the wrap-around.
    loop {
        let n = out.len();
        if n < 3 {
            return 0;
        }
        if out[0] == out[n - 1] {
            out.pop();
        } else if out[n - 2] == out[0] {
            out.truncate(n - 1);
            out.pop();
        } else if out[n - 1] == out[1] {
            out.pop();
            out.remove(0);
        } else {
            break;
        }
    }
    if out.len() < 3 {
        return 0;
    }
    let removed = before - out.len();
    *l = out;
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_duplicates_weld_onto_the_first() {
        let mut a = vec![[0.0, 0.0], [1.0, 0.0], [1.0 + 1e-7, 0.0], [1.0, 1.0]];
        let mut b = vec![[1.0 - 1e-7, 1e-8], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0]];
        assert_eq!(weld(&mut [&mut a, &mut b], 1e-6), 2);
        assert_eq!(a, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
        assert_eq!(b[0], [1.0, 0.0]);
    }

    #[test]
    fn spikes_go_area_stays() {
        let mut l = vec![
            [0.0, 0.0],
            [2.0, 0.0],
            [3.0, 0.5],
            [2.0, 0.0],
            [2.0, 2.0],
            [0.0, 2.0],
            [-1.0, 2.5],
            [-2.0, 3.0],
            [-1.0, 2.5],
            [0.0, 2.0],
        ];
        assert_eq!(remove_spikes(&mut l), 6);
        assert_eq!(l, vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]);
    }

    #[test]
    fn t_junction_is_filled_and_shared_vertices_untouched() {
        // A square split into two rectangles; the big square lacks the split's end points.
        let mut big = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
        let mut left = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let mut right = vec![[1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0]];
        let n = conform(&mut [&mut big, &mut left, &mut right], 1e-9);
        assert_eq!(n, 2);
        assert_eq!(
            big,
            vec![
                [0.0, 0.0],
                [1.0, 0.0],
                [2.0, 0.0],
                [2.0, 1.0],
                [1.0, 1.0],
                [0.0, 1.0]
            ]
        );
        assert_eq!(left.len(), 4);
        assert_eq!(right.len(), 4);
    }

    #[test]
    fn near_but_off_the_edge_is_left_alone() {
        let mut a = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]];
        let mut b = vec![[1.0, 1e-3], [1.5, 5.0], [0.5, 5.0]];
        assert_eq!(conform(&mut [&mut a, &mut b], 1e-6), 0);
        assert_eq!(conform(&mut [&mut a, &mut b], 1e-2), 1);
        assert_eq!(a[1], [1.0, 1e-3]);
    }
}
