//! Planar closed polygons: points `[x, y]` in mm, not repeated at the end.
//!
//! Conventions (shared with the whole crate): a positive signed area means counter-clockwise
//! in (x, y), which is counter-clockwise seen from the slice normal. Outer boundaries are
//! counter-clockwise, holes clockwise.

pub type Point = [f64; 2];

/// Signed area by the shoelace formula (positive = counter-clockwise).
pub fn signed_area(pts: &[Point]) -> f64 {
    let n = pts.len();
    if n < 3 {
        return 0.0;
    }
    // Shifting by the first point keeps the sum well conditioned far from the origin.
    let o = pts[0];
    let mut twice = 0.0;
    for i in 1..n - 1 {
        let a = [pts[i][0] - o[0], pts[i][1] - o[1]];
        let b = [pts[i + 1][0] - o[0], pts[i + 1][1] - o[1]];
        twice += a[0] * b[1] - a[1] * b[0];
    }
    0.5 * twice
}

/// The centroid of the area the polygon encloses; the mean of its points where it encloses
/// none (fewer than three points, or a polygon folded flat).
pub fn centroid(pts: &[Point]) -> Point {
    let n = pts.len();
    if n == 0 {
        return [0.0, 0.0];
    }
    let o = pts[0];
    let (mut twice, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 1..n.saturating_sub(1) {
        let a = [pts[i][0] - o[0], pts[i][1] - o[1]];
        let b = [pts[i + 1][0] - o[0], pts[i + 1][1] - o[1]];
        let cross = a[0] * b[1] - a[1] * b[0];
        twice += cross;
        cx += (a[0] + b[0]) * cross;
        cy += (a[1] + b[1]) * cross;
    }
    let scale = pts.iter().map(|p| dist(*p, o)).fold(0.0, f64::max);
    if twice.abs() <= 1e-12 * scale * scale {
        let k = 1.0 / n as f64;
        let sum = pts
            .iter()
            .fold([0.0, 0.0], |s, p| [s[0] + p[0], s[1] + p[1]]);
        return [sum[0] * k, sum[1] * k];
    }
    [o[0] + cx / (3.0 * twice), o[1] + cy / (3.0 * twice)]
}

/// Length of the closed polygon, closing edge included.
pub fn perimeter(pts: &[Point]) -> f64 {
    let n = pts.len();
    (0..n).map(|i| dist(pts[i], pts[(i + 1) % n])).sum()
}

/// Euclidean distance. Not `f64::hypot`: contour coordinates are millimetres, nowhere near
/// overflow, and glibc's careful `hypot` was an eighth of a skull run's CPU time.
pub fn dist(a: Point, b: Point) -> f64 {
    let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
    (dx * dx + dy * dy).sqrt()
}

/// Axis-aligned bounding box `[min_x, min_y, max_x, max_y]`.
pub fn bbox(pts: &[Point]) -> [f64; 4] {
    pts.iter().fold(
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ],
        |b, p| {
            [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ]
        },
    )
}

/// Whether `p` lies inside the closed polygon (even–odd rule; boundary points are undefined).
pub fn contains(pts: &[Point], p: Point) -> bool {
    let n = pts.len();
    let mut inside = false;
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let (a, b) = (pts[i], pts[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    if len2 == 0.0 {
        return dist(p, a);
    }
    let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0);
    dist(p, [a[0] + t * d[0], a[1] + t * d[1]])
}

/// Distance from `p` to the closed polygon's boundary.
pub fn boundary_distance(pts: &[Point], p: Point) -> f64 {
    let n = pts.len();
    (0..n)
        .map(|i| point_segment_distance(p, pts[i], pts[(i + 1) % n]))
        .fold(f64::INFINITY, f64::min)
}

/// [`boundary_distance`], negative when `p` lies inside the polygon.
pub fn signed_boundary_distance(pts: &[Point], p: Point) -> f64 {
    let d = boundary_distance(pts, p);
    if contains(pts, p) {
        -d
    } else {
        d
    }
}

/// Items `0..items` sorted into `buckets` by a counting sort: `put` is called by `each(i,
/// put)` with every bucket item `i` belongs to, twice (to count, then to fill). Returns the
/// start of each bucket (and one past the last) and the items, bucket after bucket.
fn bucket(
    buckets: usize,
    items: usize,
    each: impl Fn(usize, &mut dyn FnMut(usize)),
) -> (Vec<usize>, Vec<u32>) {
    let mut start = vec![0usize; buckets + 1];
    for i in 0..items {
        each(i, &mut |k| start[k + 1] += 1);
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    let mut fill = start.clone();
    let mut out = vec![0u32; start[buckets]];
    for i in 0..items {
        each(i, &mut |k| {
            out[fill[k]] = i as u32;
            fill[k] += 1;
        });
    }
    (start, out)
}

/// [`boundary_distance`] to one closed polygon, for many queries: its edges binned on a
/// uniform grid, searched in square rings round the query's cell until no unsearched edge
/// can be nearer. The minimum is taken over the same [`point_segment_distance`] values as
/// [`boundary_distance`], so the result is the same to the bit.
pub struct BoundaryIndex<'a> {
    pts: &'a [Point],
    origin: Point,
    cell: f64,
    width: usize,
    height: usize,
    /// Edges (by first vertex) of each cell, row-major: `edges[start[k]..start[k + 1]]`.
    start: Vec<usize>,
    edges: Vec<u32>,
    /// Edges of each row of cells, each once: `row_edges[row_start[r]..row_start[r + 1]]`.
    /// A horizontal line through a row crosses only these.
    row_start: Vec<usize>,
    row_edges: Vec<u32>,
    /// The polygon's bounding box, `[min_x, min_y, max_x, max_y]`.
    bbox: [f64; 4],
}

impl<'a> BoundaryIndex<'a> {
    /// Cells about two mean edge lengths wide, at most [`Self::MAX_CELLS`] along a side.
    const MAX_CELLS: f64 = 512.0;

    pub fn new(pts: &'a [Point]) -> Self {
        let n = pts.len();
        let b = bbox(pts);
        let extent = (b[2] - b[0]).max(b[3] - b[1]);
        let mean_edge = if n > 0 {
            perimeter(pts) / n as f64
        } else {
            0.0
        };
        let cell = (2.0 * mean_edge).max(extent / Self::MAX_CELLS);
        let cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            1.0
        };
        let cells = |len: f64| (len / cell).floor() as usize + 1;
        let finite = n > 0 && b.iter().all(|v| v.is_finite());
        let (width, height) = if finite {
            (cells(b[2] - b[0]), cells(b[3] - b[1]))
        } else {
            (0, 0)
        };
        let origin = if finite { [b[0], b[1]] } else { [0.0, 0.0] };
        let mut index = BoundaryIndex {
            pts,
            origin,
            cell,
            width,
            height,
            start: Vec::new(),
            edges: Vec::new(),
            row_start: Vec::new(),
            row_edges: Vec::new(),
            bbox: b,
        };
        // Each edge in every cell its bounding box meets, and in every row of cells it meets.
        let span = |i: usize| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            let (c0, r0) = index.clamped(index.cell_of([a[0].min(b[0]), a[1].min(b[1])]));
            let (c1, r1) = index.clamped(index.cell_of([a[0].max(b[0]), a[1].max(b[1])]));
            (c0, r0, c1, r1)
        };
        let edges = if finite { n } else { 0 };
        let (start, cell_edges) = bucket(width * height, edges, |i, put| {
            let (c0, r0, c1, r1) = span(i);
            for r in r0..=r1 {
                for c in c0..=c1 {
                    put(r * width + c);
                }
            }
        });
        let (row_start, row_edges) = bucket(height, edges, |i, put| {
            let (_, r0, _, r1) = span(i);
            (r0..=r1).for_each(put);
        });
        index.start = start;
        index.edges = cell_edges;
        index.row_start = row_start;
        index.row_edges = row_edges;
        index
    }

    /// The polygon indexed.
    pub fn points(&self) -> &'a [Point] {
        self.pts
    }

    /// The polygon's bounding box: [`bbox`] of [`Self::points`].
    pub fn bbox(&self) -> [f64; 4] {
        self.bbox
    }

    /// [`contains`], asking only the edges of the row of cells `p` lies in: an edge that a
    /// horizontal line through `p` crosses has `p`'s ordinate within its own, so its box
    /// meets that row (`floor` is monotonic). The same crossing rule on the same edges, so
    /// the same answer.
    pub fn contains(&self, p: Point) -> bool {
        let n = self.pts.len();
        if self.height == 0 || !p[1].is_finite() {
            return contains(self.pts, p);
        }
        let r = self.cell_of(p).1;
        if r < 0 || r >= self.height as i64 {
            // Beyond the box's ordinates no edge straddles `p`'s.
            return false;
        }
        let r = r as usize;
        let mut inside = false;
        for &e in &self.row_edges[self.row_start[r]..self.row_start[r + 1]] {
            // As `contains` pairs them: vertex i with the one before it.
            let (a, b) = (self.pts[(e as usize + 1) % n], self.pts[e as usize]);
            if (a[1] > p[1]) != (b[1] > p[1]) {
                let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                if p[0] < x {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// Whether [`Self::distance`] exceeds `margin` (≥ 0), searching only the rings of cells
    /// within it: the same edges' distances decide as in the full search, which can only
    /// find farther ones beyond (a slack of 1e-9 mm covers the rounding of a foot point).
    pub fn farther_than(&self, p: Point, margin: f64) -> bool {
        if self.width == 0 || !(p[0].is_finite() && p[1].is_finite() && margin >= 0.0) {
            return self.distance(p) > margin;
        }
        if self.distance_floor(p) > margin {
            return true;
        }
        let centre = self.cell_of(p);
        for ring in 0..=self.last_ring(centre) {
            if (ring - 1) as f64 * self.cell > margin + 1e-9 {
                break;
            }
            let near = self.ring_any(centre, ring, |k| {
                self.cell_edges(k)
                    .any(|(a, b)| point_segment_distance(p, a, b) <= margin)
            });
            if near {
                return false;
            }
        }
        true
    }

    /// The edges binned in cell `k`, as their end points.
    fn cell_edges(&self, k: usize) -> impl Iterator<Item = (Point, Point)> + '_ {
        let n = self.pts.len();
        self.edges[self.start[k]..self.start[k + 1]]
            .iter()
            .map(move |&e| (self.pts[e as usize], self.pts[(e as usize + 1) % n]))
    }

    /// The last ring round cell `(c, r)` that still meets the grid.
    fn last_ring(&self, (c, r): (i64, i64)) -> i64 {
        let (w, h) = (self.width as i64, self.height as i64);
        (c.abs().max((w - 1 - c).abs())).max(r.abs().max((h - 1 - r).abs()))
    }

    /// Whether `f` holds for some grid cell (by flat index) of the square ring `ring` round
    /// `(c, r)` (ring 0: the cell itself); stops at the first that does.
    fn ring_any(&self, (pc, pr): (i64, i64), ring: i64, mut f: impl FnMut(usize) -> bool) -> bool {
        let (w, h) = (self.width as i64, self.height as i64);
        let mut at = |c: i64, r: i64| {
            c >= 0 && r >= 0 && c < w && r < h && f(r as usize * self.width + c as usize)
        };
        if ring == 0 {
            return at(pc, pr);
        }
        let (c0, c1, r0, r1) = (pc - ring, pc + ring, pr - ring, pr + ring);
        (c0..=c1).any(|c| at(c, r0) || at(c, r1)) || (r0 + 1..r1).any(|r| at(c0, r) || at(c1, r))
    }

    /// A lower bound of [`Self::distance`]: the distance to the polygon's box, less a
    /// margin far above the rounding of a foot point.
    fn distance_floor(&self, p: Point) -> f64 {
        let b = self.bbox;
        let dx = (b[0] - p[0]).max(p[0] - b[2]).max(0.0);
        let dy = (b[1] - p[1]).max(p[1] - b[3]).max(0.0);
        (dx * dx + dy * dy).sqrt() * (1.0 - 1e-9) - 1e-9
    }

    /// The cell holding `p`, unclamped (it may lie off the grid).
    fn cell_of(&self, p: Point) -> (i64, i64) {
        let f = |v: f64, o: f64| ((v - o) / self.cell).floor().clamp(-1e15, 1e15) as i64;
        (f(p[0], self.origin[0]), f(p[1], self.origin[1]))
    }

    fn clamped(&self, (c, r): (i64, i64)) -> (usize, usize) {
        (
            c.clamp(0, self.width as i64 - 1) as usize,
            r.clamp(0, self.height as i64 - 1) as usize,
        )
    }

    /// Distance from `p` to the polygon's boundary: [`boundary_distance`].
    pub fn distance(&self, p: Point) -> f64 {
        let centre = self.cell_of(p);
        let last = self.last_ring(centre);
        // Far off the grid (or no grid: an empty or non-finite polygon) the rings would be
        // mostly empty: every edge, as [`boundary_distance`] does.
        let side = self.width.max(self.height) as i64;
        if self.width == 0 || last > 2 * side || !(p[0].is_finite() && p[1].is_finite()) {
            return boundary_distance(self.pts, p);
        }
        let mut best = f64::INFINITY;
        for ring in 0..=last {
            // An edge not yet visited meets no cell within `ring - 1` of `p`'s cell, so it
            // lies at least `ring - 1` cells from `p`.
            if ring > 0 && best <= (ring - 1) as f64 * self.cell {
                break;
            }
            self.ring_any(centre, ring, |k| {
                for (a, b) in self.cell_edges(k) {
                    best = best.min(point_segment_distance(p, a, b));
                }
                false
            });
        }
        best
    }

    /// [`signed_boundary_distance`]: negative when `p` lies inside.
    pub fn signed_distance(&self, p: Point) -> f64 {
        let d = self.distance(p);
        if self.contains(p) {
            -d
        } else {
            d
        }
    }
}

/// Whether `p` lies outside every polygon of the set and farther than `margin` (≥ 0) from
/// each: [`least_signed_distance`]` > margin`, without measuring how far.
pub fn clear_of(set: &[BoundaryIndex], p: Point, margin: f64) -> bool {
    if !(p[0].is_finite() && p[1].is_finite() && margin >= 0.0) || set.iter().any(|o| o.height == 0)
    {
        return least_signed_distance(set, p) > margin;
    }
    set.iter()
        .all(|o| !o.contains(p) && o.farther_than(p, margin))
}

/// The least [`BoundaryIndex::signed_distance`] over a set of polygons, bit for bit what
/// folding `f64::min` over all of them gives, without measuring those that cannot be the
/// least: when `p` lies inside some, only those (the others are non-negative); else, nearest
/// box first, until the next box lies farther than the nearest boundary so far.
pub fn least_signed_distance(set: &[BoundaryIndex], p: Point) -> f64 {
    let full = || {
        set.iter()
            .map(|o| o.signed_distance(p))
            .fold(f64::INFINITY, f64::min)
    };
    if !(p[0].is_finite() && p[1].is_finite()) || set.iter().any(|o| o.height == 0) {
        return full();
    }
    let inside = set
        .iter()
        .filter(|o| o.contains(p))
        .map(|o| -o.distance(p))
        .fold(f64::INFINITY, f64::min);
    if inside < 0.0 {
        return inside;
    }
    if inside == 0.0 {
        // On a boundary it contains: the signs of zeros decide, as the full fold has them.
        return full();
    }
    let mut order: Vec<(f64, usize)> = set
        .iter()
        .enumerate()
        .map(|(k, o)| (o.distance_floor(p), k))
        .collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut best = f64::INFINITY;
    for (floor, k) in order {
        if floor > best {
            break;
        }
        best = best.min(set[k].distance(p));
    }
    best
}

/// Whether the closed polygon is simple: no two non-adjacent edges touch or cross, and no
/// edge has zero length.
pub fn is_simple(pts: &[Point]) -> bool {
    let n = pts.len();
    if n < 3 || (0..n).any(|i| pts[i] == pts[(i + 1) % n]) {
        return false;
    }
    no_edges_meeting(pts, |i, j, (a, b), (c, d)| {
        if (i + 1) % n == j || (j + 1) % n == i {
            // Adjacent edges share one vertex; they must not fold back onto each other.
            n > 3 && collinear_overlap(a, b, c, d)
        } else {
            segments_intersect(a, b, c, d)
        }
    })
}

/// Whether the closed polygon is simple but for slits: like [`is_simple`], except that an
/// edge may be run both ways (a slit out and back, as bridges between the pieces of a split
/// zone make) and non-adjacent edges may meet at a vertex they share, as long as they do not
/// run along each other from it. (A loop crossing itself exactly at a shared vertex passes.)
pub fn is_weakly_simple(pts: &[Point]) -> bool {
    let n = pts.len();
    if n < 3 || (0..n).any(|i| pts[i] == pts[(i + 1) % n]) {
        return false;
    }
    no_edges_meeting(pts, |_, _, (a, b), (c, d)| {
        if a == d && b == c {
            return false;
        }
        let shared = [(a, b, c, d), (a, b, d, c), (b, a, c, d), (b, a, d, c)]
            .into_iter()
            .find(|(p, _, q, _)| p == q);
        match shared {
            // Meeting at a vertex: only running along each other from it is wrong.
            Some((p, x, _, y)) => n > 3 && collinear_overlap(x, p, p, y),
            None => segments_intersect(a, b, c, d),
        }
    })
}

/// Whether two non-adjacent edges of the closed polygon cross properly: each one's ends
/// strictly on either side of the other's line. Touching does not count (a slit's two sides,
/// a vertex on an edge), so a keyhole loop does not cross itself; a figure eight does.
pub fn crosses_itself(pts: &[Point]) -> bool {
    proper_crossings(pts, 1) > 0
}

/// Pairs of non-adjacent edges of the closed polygon that cross properly (as in
/// [`crosses_itself`]), counted up to `limit`.
pub fn proper_crossings(pts: &[Point], limit: usize) -> usize {
    let n = pts.len();
    if n < 4 {
        return 0;
    }
    edges_meeting(pts, limit, |i, j, (a, b), (c, d)| {
        let adjacent = (i + 1) % n == j || (j + 1) % n == i;
        !adjacent && proper_crossing(a, b, c, d).is_some()
    })
}

/// Where segment ab crosses segment cd properly (each passes strictly through the other:
/// touching, shared ends and collinear overlaps are not crossings), as the fraction of the way
/// from a to b; `None` if it does not.
pub fn proper_crossing(a: Point, b: Point, c: Point, d: Point) -> Option<f64> {
    if boxes_disjoint(a, b, c, d) {
        return None;
    }
    let (oa, ob) = (orient(c, d, a), orient(c, d, b));
    (orient(a, b, c) * orient(a, b, d) < 0.0 && oa * ob < 0.0).then(|| oa / (oa - ob))
}

/// Whether `meet(i, j, edge i, edge j)` is false for every pair of edges whose x-ranges
/// overlap (see [`edges_meeting`]).
fn no_edges_meeting(
    pts: &[Point],
    meet: impl Fn(usize, usize, (Point, Point), (Point, Point)) -> bool,
) -> bool {
    edges_meeting(pts, 1, meet) == 0
}

/// How many pairs of edges whose x-ranges overlap `meet(i, j, edge i, edge j)` holds for,
/// counted up to `limit` (see [`edges_meeting_among`]).
fn edges_meeting(
    pts: &[Point],
    limit: usize,
    meet: impl Fn(usize, usize, (Point, Point), (Point, Point)) -> bool,
) -> usize {
    edges_meeting_among(&[pts], limit, |(_, i), (_, j), e, f| meet(i, j, e, f))
}

/// How many pairs of edges of the closed polygons whose x-ranges overlap
/// `meet((polygon, i), (polygon, j), edge, edge)` holds for, counted up to `limit`: a sweep
/// over edges sorted by their smallest x (ties in polygon and edge order), so typical contours
/// cost O(n log n) rather than O(n²). The first edge handed to `meet` is the one the sweep
/// reached last.
pub(crate) fn edges_meeting_among(
    polys: &[&[Point]],
    limit: usize,
    mut meet: impl FnMut((usize, usize), (usize, usize), (Point, Point), (Point, Point)) -> bool,
) -> usize {
    let edge = |(k, i): (usize, usize)| {
        let pts = polys[k];
        (pts[i], pts[(i + 1) % pts.len()])
    };
    let mut order: Vec<(usize, usize)> = polys
        .iter()
        .enumerate()
        .flat_map(|(k, pts)| (0..pts.len()).map(move |i| (k, i)))
        .collect();
    let min_x = |e: (usize, usize)| {
        let (a, b) = edge(e);
        a[0].min(b[0])
    };
    order.sort_by(|&a, &b| min_x(a).total_cmp(&min_x(b)));
    let mut active: Vec<(usize, usize)> = Vec::new();
    let mut count = 0;
    for &e in &order {
        let (a, b) = edge(e);
        let lo = a[0].min(b[0]);
        active.retain(|&f| {
            let (c, d) = edge(f);
            c[0].max(d[0]) >= lo
        });
        for &f in &active {
            if meet(e, f, (a, b), edge(f)) {
                count += 1;
                if count >= limit {
                    return count;
                }
            }
        }
        active.push(e);
    }
    count
}

/// Twice the signed area of the triangle abc: positive when c lies left of a→b.
pub fn orient(a: Point, b: Point, c: Point) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn on_segment(a: Point, b: Point, p: Point) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Closed-segment intersection test (touching counts).
pub fn segments_intersect(a: Point, b: Point, c: Point, d: Point) -> bool {
    let (o1, o2, o3, o4) = (
        orient(a, b, c),
        orient(a, b, d),
        orient(c, d, a),
        orient(c, d, b),
    );
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0))
        && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0))
    {
        return true;
    }
    (o1 == 0.0 && on_segment(a, b, c))
        || (o2 == 0.0 && on_segment(a, b, d))
        || (o3 == 0.0 && on_segment(c, d, a))
        || (o4 == 0.0 && on_segment(c, d, b))
}

/// Whether the bounding boxes of segments ab and cd are apart: then the segments cannot meet,
/// a cheap test before [`segments_intersect`] where most pairs are far apart.
pub fn boxes_disjoint(a: Point, b: Point, c: Point, d: Point) -> bool {
    a[0].max(b[0]) < c[0].min(d[0])
        || a[0].min(b[0]) > c[0].max(d[0])
        || a[1].max(b[1]) < c[1].min(d[1])
        || a[1].min(b[1]) > c[1].max(d[1])
}

/// Two edges sharing a vertex overlap when they are collinear and point the same way from it.
fn collinear_overlap(a: Point, b: Point, c: Point, d: Point) -> bool {
    let (shared, p, q) = if b == c {
        (b, a, d)
    } else if d == a {
        (a, b, c)
    } else {
        return false;
    };
    let u = [p[0] - shared[0], p[1] - shared[1]];
    let v = [q[0] - shared[0], q[1] - shared[1]];
    u[0] * v[1] - u[1] * v[0] == 0.0 && u[0] * v[0] + u[1] * v[1] > 0.0
}

/// A regular polygon of `n` points on a circle, counter-clockwise (clockwise when `!ccw`):
/// the shape most geometry tests start from.
#[cfg(test)]
pub(crate) fn circle(cx: f64, cy: f64, r: f64, n: usize, ccw: bool) -> Vec<Point> {
    let mut v: Vec<Point> = (0..n)
        .map(|k| {
            let t = k as f64 * std::f64::consts::TAU / n as f64;
            [cx + r * t.cos(), cy + r * t.sin()]
        })
        .collect();
    if !ccw {
        v.reverse();
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centroid_of_an_l_is_its_area_weighted_mean_either_way_round() {
        // Unit squares at (0.5, 0.5), (1.5, 0.5) and (0.5, 1.5), 100 mm from the origin.
        let l: Vec<Point> = [[0., 0.], [2., 0.], [2., 1.], [1., 1.], [1., 2.], [0., 2.]]
            .iter()
            .map(|p| [p[0] + 100.0, p[1] - 100.0])
            .collect();
        let want = [100.0 + 2.5 / 3.0, -100.0 + 2.5 / 3.0];
        let mut rev = l.clone();
        rev.reverse();
        rev.rotate_left(2);
        for c in [centroid(&l), centroid(&rev)] {
            assert!(
                (c[0] - want[0]).abs() < 1e-12 && (c[1] - want[1]).abs() < 1e-12,
                "{c:?}"
            );
        }
        // Folded flat: no area, the points' mean.
        assert_eq!(
            centroid(&[[0., 0.], [2., 0.], [4., 0.], [2., 0.]]),
            [2.0, 0.0]
        );
        assert_eq!(centroid(&[]), [0.0, 0.0]);
    }

    #[test]
    fn crossing_itself_is_a_proper_crossing_not_a_touch() {
        let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert!(!crosses_itself(&square));
        let eight = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]];
        assert!(crosses_itself(&eight));
        // A slit out and back: its two sides touch along their length but do not cross.
        let keyhole = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 4.0],
            [2.0, 4.0],
            [2.0, 2.0],
            [2.0, 4.0],
            [0.0, 4.0],
        ];
        assert!(!crosses_itself(&keyhole));
        // A vertex (2, 0) lying inside a non-adjacent edge touches it.
        let touching = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [2.0, 0.0], [0.0, 4.0]];
        assert!(!crosses_itself(&touching));
    }

    #[test]
    fn a_slit_is_weakly_simple_a_crossing_is_not() {
        // Two squares joined by a slit from (1, 0) to (2, 0) and back.
        let slit = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [3.0, 0.0],
            [3.0, 1.0],
            [2.0, 1.0],
            [2.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
        ];
        assert!(is_weakly_simple(&slit) && !is_simple(&slit));
        let bow = vec![[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(!is_weakly_simple(&bow) && !is_simple(&bow));
        let square = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert!(is_weakly_simple(&square) && is_simple(&square));
        // A slit that runs along its own edge (folds back part-way) is not a slit.
        let fold = vec![[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert!(!is_weakly_simple(&fold));
    }

    const SQUARE: [Point; 4] = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];

    #[test]
    fn square_area_perimeter_and_containment() {
        assert_eq!(signed_area(&SQUARE), 4.0);
        let mut cw = SQUARE.to_vec();
        cw.reverse();
        assert_eq!(signed_area(&cw), -4.0);
        assert_eq!(perimeter(&SQUARE), 8.0);
        assert!(contains(&SQUARE, [1.0, 1.0]));
        assert!(!contains(&SQUARE, [3.0, 1.0]));
        assert_eq!(boundary_distance(&SQUARE, [1.0, 1.5]), 0.5);
        assert_eq!(bbox(&SQUARE), [0.0, 0.0, 2.0, 2.0]);
    }

    #[test]
    fn simplicity_detects_bow_tie_and_spikes() {
        assert!(is_simple(&SQUARE));
        let bow_tie = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]];
        assert!(!is_simple(&bow_tie));
        let spike = [[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        assert!(!is_simple(&spike));
        let repeated = [[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        assert!(!is_simple(&repeated));
    }

    /// A star-shaped polygon of `radii` round `centre`, wiggly and with long and short edges.
    fn star(centre: Point, radii: &[f64]) -> Vec<Point> {
        let n = radii.len();
        (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                [
                    centre[0] + radii[i] * a.cos(),
                    centre[1] + radii[i] * a.sin(),
                ]
            })
            .collect()
    }

    proptest::proptest! {
        /// The index gives exactly the linear scan's distance, to the bit, near and far.
        #[test]
        fn boundary_index_matches_the_linear_scan(
            radii in proptest::collection::vec(0.5f64..40.0, 3..300),
            centre in (-100.0f64..100.0, -100.0f64..100.0),
            queries in proptest::collection::vec((-300.0f64..300.0, -300.0f64..300.0), 1..60),
        ) {
            let poly = star([centre.0, centre.1], &radii);
            let index = BoundaryIndex::new(&poly);
            for (x, y) in queries {
                // Queries all round, and some right on a vertex.
                for p in [[x, y], [centre.0 + x / 10.0, centre.1 + y / 10.0], poly[(x.abs() as usize) % poly.len()]] {
                    proptest::prop_assert_eq!(
                        index.distance(p).to_bits(),
                        boundary_distance(&poly, p).to_bits(),
                        "{:?}", p
                    );
                    proptest::prop_assert_eq!(
                        index.signed_distance(p).to_bits(),
                        signed_boundary_distance(&poly, p).to_bits()
                    );
                    proptest::prop_assert_eq!(index.contains(p), contains(&poly, p), "{:?}", p);
                    let d = boundary_distance(&poly, p);
                    // Margins either side of the distance itself, and the distance exactly.
                    for margin in [0.0, 0.5 * d, d, 1.5 * d, 7.0] {
                        proptest::prop_assert_eq!(index.farther_than(p, margin), d > margin);
                    }
                }
            }
        }

        /// Over a set of polygons (near, far, overlapping), the least signed distance is the
        /// full fold's, to the bit, inside one, two or none of them and on their vertices.
        #[test]
        fn least_signed_distance_matches_the_full_fold(
            stars in proptest::collection::vec(
                (proptest::collection::vec(0.5f64..20.0, 3..80), -60.0f64..60.0, -60.0f64..60.0),
                1..8,
            ),
            queries in proptest::collection::vec((-120.0f64..120.0, -120.0f64..120.0), 1..40),
        ) {
            let polys: Vec<Vec<Point>> =
                stars.iter().map(|(r, x, y)| star([*x, *y], r)).collect();
            let set: Vec<BoundaryIndex> = polys.iter().map(|p| BoundaryIndex::new(p)).collect();
            for (k, (x, y)) in queries.into_iter().enumerate() {
                let on = &polys[k % polys.len()];
                for p in [[x, y], on[(x.abs() as usize) % on.len()]] {
                    let fold = polys
                        .iter()
                        .map(|o| signed_boundary_distance(o, p))
                        .fold(f64::INFINITY, f64::min);
                    proptest::prop_assert_eq!(
                        least_signed_distance(&set, p).to_bits(),
                        fold.to_bits(),
                        "{:?}", p
                    );
                    for margin in [0.0, 0.3, 2.5, 40.0] {
                        proptest::prop_assert_eq!(clear_of(&set, p, margin), fold > margin);
                    }
                }
            }
        }
    }

    #[test]
    fn boundary_index_of_an_empty_or_degenerate_polygon_agrees_with_the_scan() {
        for poly in [
            vec![],
            vec![[1.0, 2.0]],
            vec![[0.0, 0.0], [0.0, 0.0]],
            vec![[f64::NAN, 0.0], [1.0, 1.0], [2.0, 0.0]],
        ] {
            let index = BoundaryIndex::new(&poly);
            for p in [[0.0, 0.0], [5.0, -3.0], [1e12, 1e12]] {
                let (a, b) = (index.distance(p), boundary_distance(&poly, p));
                assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{poly:?} {p:?}: {a} {b}"
                );
            }
        }
    }
}
