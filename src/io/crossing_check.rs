//! The run's mesh checked for faces crossing one another, as `mesh.stl` holds it (single
//! precision, which is what slicers and MeshLab read), in bounded memory: the report's
//! `mesh.crossing_faces` and `mesh.crossings`.
//!
//! In: per surface its id and triangles, in the mesh files' order. They are streamed into an
//! anonymous temporary file (36 bytes a face; it vanishes when closed, even if the process is
//! killed), with a count of faces per half-millimetre of lowest z. Out: after the last
//! surface, the faces crossing another ([`crate::mesh::crossings`]), found slab by slab along
//! z ([`crate::mesh::crossings::slabs`]): each slab's faces are read back from the file and
//! searched alone, a few slabs at once on rayon's threads, so memory holds a few slabs,
//! whatever the mesh's size. Per pair of surfaces
//! (a surface with itself included), how many of their faces cross and where. Deterministic:
//! the same triangles in the same order give the same summary.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;

use crate::io::stl::single;
use crate::mesh::crossings::{crossing_pairs_in_slab, reaches_slab, slabs, z_extent};
use crate::mesh::Triangle;

/// Faces whose lowest z starts in one slab, at most (unless one bin alone holds more). The
/// search holds about 150 bytes a face: some 80 MB a slab at this size.
pub const SLAB_FACES: u64 = 1 << 19;

/// Most slabs searched at once (one per rayon thread), each held in memory meanwhile.
const BATCH: usize = 4;

/// Bin of lowest z the slabs are cut at (mm).
const BIN_MM: f64 = 0.5;

/// Bytes of one face in the scratch file: nine little-endian f32.
const RECORD: usize = 36;

/// Faces of two surfaces (`surfaces[0] == surfaces[1]`: one surface through itself) crossing
/// a face of the other.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct SurfaceCrossing {
    /// Surface ids as in the report's `surfaces`, the smaller first.
    pub surfaces: [usize; 2],
    /// Faces of either in a crossing between them.
    pub faces: u64,
    /// The mean of those faces' centroids (mm, in the output's coordinates): where to look.
    pub at: [f64; 3],
}

/// What the check found.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossingSummary {
    /// Faces checked (the mesh files' triangles).
    pub faces: u64,
    /// Faces crossing another face that shares no vertex with them.
    pub crossing_faces: u64,
    /// Per pair of surfaces, most crossing faces first (then by ids).
    pub pairs: Vec<SurfaceCrossing>,
    /// Slabs searched.
    pub slabs: usize,
}

/// The faces of a run's mesh as they are written; see the module doc.
pub struct CrossingCheck {
    body: BufWriter<File>,
    /// `(surface id, first face)`, in order.
    surfaces: Vec<(usize, u64)>,
    faces: u64,
    /// Faces per bin of lowest z.
    starts: BTreeMap<i64, u64>,
}

impl CrossingCheck {
    /// An empty check whose scratch file is in `scratch_dir` (normally the output directory).
    pub fn in_dir(scratch_dir: &Path) -> io::Result<Self> {
        Ok(CrossingCheck {
            body: BufWriter::with_capacity(1 << 16, tempfile::tempfile_in(scratch_dir)?),
            surfaces: Vec::new(),
            faces: 0,
            starts: BTreeMap::new(),
        })
    }

    /// Appends triangles of surface `id`; a surface may come in any number of calls.
    pub fn add(&mut self, id: usize, tris: &[Triangle]) -> io::Result<()> {
        if tris.is_empty() {
            return Ok(());
        }
        if self.surfaces.last().map(|&(last, _)| last) != Some(id) {
            self.surfaces.push((id, self.faces));
        }
        let mut bytes = Vec::with_capacity(tris.len() * RECORD);
        for t in tris {
            let s = single(t);
            for x in s.iter().flatten() {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
            let low = f64::from(s[0][2].min(s[1][2]).min(s[2][2]));
            if low.is_finite() {
                *self
                    .starts
                    .entry((low / BIN_MM).floor() as i64)
                    .or_default() += 1;
            }
        }
        self.faces += tris.len() as u64;
        self.body.write_all(&bytes)
    }

    /// Ends the writing; the search then runs a few slabs per [`CrossingSearch::next_slabs`].
    pub fn search(self, cap: u64) -> io::Result<CrossingSearch> {
        let file = self.body.into_inner().map_err(|e| e.into_error())?;
        Ok(CrossingSearch {
            slabs: slabs(&self.starts, BIN_MM, cap),
            done: 0,
            file,
            surfaces: self.surfaces,
            crossing: vec![false; self.faces as usize],
            by_pair: BTreeMap::new(),
        })
    }
}

/// A [`CrossingCheck`] being searched, a few slabs at a time, so that the caller can stop
/// between.
pub struct CrossingSearch {
    slabs: Vec<(f64, f64)>,
    done: usize,
    file: File,
    surfaces: Vec<(usize, u64)>,
    /// Per face of the mesh, whether it crosses another.
    crossing: Vec<bool>,
    /// Per pair of surfaces: their crossing faces and those faces' centroids (summed in face
    /// order at the end, so the mean does not depend on which slab found which).
    by_pair: BTreeMap<(usize, usize), BTreeMap<u64, [f64; 3]>>,
}

impl CrossingSearch {
    /// Searches the next slabs, as many as rayon has threads (at most [`BATCH`]), reading the
    /// faces once for all of them; false when every slab has been. The slabs' pairs are taken
    /// in slab order, so the summary does not depend on the thread count.
    pub fn next_slabs(&mut self) -> io::Result<bool> {
        let width = rayon::current_num_threads().clamp(1, BATCH);
        let batch: Vec<(f64, f64)> = self
            .slabs
            .iter()
            .skip(self.done)
            .take(width)
            .copied()
            .collect();
        if batch.is_empty() {
            return Ok(false);
        }
        self.done += batch.len();
        self.file.seek(SeekFrom::Start(0))?;
        let mut reader = BufReader::with_capacity(1 << 20, &self.file);
        let mut held: Vec<(Vec<Triangle>, Vec<u64>)> = vec![Default::default(); batch.len()];
        let mut record = [0u8; RECORD];
        for k in 0..self.crossing.len() as u64 {
            reader.read_exact(&mut record)?;
            let x = |i: usize| {
                let b = [0, 1, 2, 3].map(|j| record[4 * i + j]);
                f64::from(f32::from_le_bytes(b))
            };
            let t: Triangle = std::array::from_fn(|v| std::array::from_fn(|d| x(3 * v + d)));
            let z = z_extent(&t);
            for (slab, (faces, index)) in batch.iter().zip(&mut held) {
                if reaches_slab(z, *slab) {
                    faces.push(t);
                    index.push(k);
                }
            }
        }
        let found: Vec<Vec<(usize, usize)>> = batch
            .par_iter()
            .zip(&held)
            .map(|(slab, (faces, _))| crossing_pairs_in_slab(faces, *slab))
            .collect();
        for ((faces, index), pairs) in held.iter().zip(found) {
            for (i, j) in pairs {
                let (a, b) = (self.surface_of(index[i]), self.surface_of(index[j]));
                let pair = self.by_pair.entry((a.min(b), a.max(b))).or_default();
                for local in [i, j] {
                    let g = index[local];
                    self.crossing[g as usize] = true;
                    let t = &faces[local];
                    pair.entry(g).or_insert_with(|| {
                        std::array::from_fn(|d| (t[0][d] + t[1][d] + t[2][d]) / 3.0)
                    });
                }
            }
        }
        Ok(true)
    }

    fn surface_of(&self, face: u64) -> usize {
        let k = self.surfaces.partition_point(|&(_, first)| first <= face);
        self.surfaces[k.saturating_sub(1)].0
    }

    /// What the slabs searched so far found (all of them, once [`Self::next_slabs`] is false).
    pub fn summary(&self) -> CrossingSummary {
        let mut pairs: Vec<SurfaceCrossing> = self
            .by_pair
            .iter()
            .map(|(&(a, b), faces)| {
                let n = faces.len() as u64;
                let mut sum = [0.0; 3];
                for c in faces.values() {
                    (0..3).for_each(|d| sum[d] += c[d]);
                }
                SurfaceCrossing {
                    surfaces: [a, b],
                    faces: n,
                    at: sum.map(|s| s / n as f64),
                }
            })
            .collect();
        pairs.sort_by(|x, y| y.faces.cmp(&x.faces).then(x.surfaces.cmp(&y.surfaces)));
        CrossingSummary {
            faces: self.crossing.len() as u64,
            crossing_faces: self.crossing.iter().filter(|&&c| c).count() as u64,
            pairs,
            slabs: self.done,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of two faces centred on `c` in the plane z = `c[2]`, turned by `turn` about z.
    fn lying(c: [f64; 3], size: f64, turn: f64) -> Vec<Triangle> {
        let (co, si) = (turn.cos(), turn.sin());
        let p = |x: f64, y: f64| [c[0] + co * x - si * y, c[1] + si * x + co * y, c[2]];
        let h = size / 2.0;
        let (a, b, cc, d) = (p(-h, -h), p(h, -h), p(h, h), p(-h, h));
        vec![[a, b, cc], [a, cc, d]]
    }

    /// A square of two faces centred on `c` in the plane x = `c[0]`.
    fn standing(c: [f64; 3], size: f64) -> Vec<Triangle> {
        let p = |y: f64, z: f64| [c[0], c[1] + y, c[2] + z];
        let h = size / 2.0;
        let (a, b, cc, d) = (p(-h, -h), p(h, -h), p(h, h), p(-h, h));
        vec![[a, b, cc], [a, cc, d]]
    }

    fn run(check: CrossingCheck, cap: u64) -> CrossingSummary {
        let mut search = check.search(cap).unwrap();
        while search.next_slabs().unwrap() {}
        search.summary()
    }

    #[test]
    fn finds_which_surfaces_cross_and_where_in_any_number_of_slabs() {
        let dir = tempfile::tempdir().unwrap();
        // Surface 3: a standing square through a lying one at (0, 0, 0); surface 7: one
        // standing through a lying square of surface 3's at (20, 0, 5); surface 9: apart.
        let mut summaries = Vec::new();
        for cap in [1, 2, SLAB_FACES] {
            let mut check = CrossingCheck::in_dir(dir.path()).unwrap();
            check.add(3, &lying([0.0; 3], 2.0, 0.3)).unwrap();
            check.add(3, &standing([0.0; 3], 2.0)).unwrap();
            check.add(3, &lying([20.0, 0.0, 5.0], 2.0, 0.3)).unwrap();
            check.add(7, &standing([20.0, 0.0, 5.0], 2.0)).unwrap();
            check.add(9, &lying([40.0, 0.0, 5.0], 2.0, 0.3)).unwrap();
            let s = run(check, cap);
            assert_eq!(s.faces, 10);
            assert_eq!(s.crossing_faces, 8, "cap {cap}");
            assert_eq!(s.pairs.len(), 2);
            assert_eq!(s.pairs[0].surfaces, [3, 3]);
            assert_eq!(s.pairs[0].faces, 4);
            assert_eq!(s.pairs[1].surfaces, [3, 7]);
            assert_eq!(s.pairs[1].faces, 4);
            assert!(s.pairs[1]
                .at
                .iter()
                .zip([20.0, 0.0, 5.0])
                .all(|(x, y)| (x - y).abs() < 1e-5));
            assert_eq!(s.slabs > 1, cap < 10);
            summaries.push(s);
        }
        // The slabs change the work, never the answer.
        for s in &mut summaries {
            s.slabs = 0;
        }
        assert_eq!(summaries[0], summaries[2]);
        assert_eq!(summaries[1], summaries[2]);
        // The scratch file is anonymous: nothing is left in the directory.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn checks_the_single_precision_mesh_stl_holds() {
        // A face whose apex rises 1e-9 mm through a sheet crosses it in double precision; in
        // mesh.stl's single precision the apex lies on the sheet, which is no crossing. One
        // rising 0.01 mm through crosses in both.
        let dir = tempfile::tempdir().unwrap();
        let sheet = lying([2.0, 2.0, 1.0], 4.0, 0.0);
        for (rise, crossing) in [(1e-9, 0), (0.01, 2)] {
            let spike = [[1.0, 2.5, 0.0], [2.0, 2.5, 0.0], [1.5, 2.5, 1.0 + rise]];
            let both: Vec<Triangle> = sheet.iter().copied().chain([spike]).collect();
            assert_eq!(crate::mesh::crossings::crossing_faces(&both), 2);
            let mut check = CrossingCheck::in_dir(dir.path()).unwrap();
            check.add(1, &sheet).unwrap();
            check.add(2, &[spike]).unwrap();
            let s = run(check, SLAB_FACES);
            assert_eq!(s.crossing_faces, crossing, "rise {rise}");
            assert_eq!(s.pairs.len(), crossing as usize / 2);
        }
    }

    #[test]
    fn an_empty_mesh_has_no_crossings() {
        let dir = tempfile::tempdir().unwrap();
        let s = run(CrossingCheck::in_dir(dir.path()).unwrap(), SLAB_FACES);
        assert_eq!((s.faces, s.crossing_faces, s.pairs.len()), (0, 0, 0));
    }
}
