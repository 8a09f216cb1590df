//! Indexed meshes for the OBJ and PLY writers: the triangles of one surface as the vertices it
//! adds to the file and faces of indices into the whole file's vertex list.
//!
//! In: triangles (vertex triples), the file's [`Seams`] so far and its vertex count. Out: the
//! new distinct vertices in order of first appearance and one index triple per triangle, in
//! the triangles' order and with their vertex order (so the winding is kept). Vertices are
//! merged only when bit-identical (all three coordinates have the same f64 bits): no
//! tolerance, so no two distinct points are ever moved onto each other.
//!
//! Surfaces meet along their end loops, whose points they share bit for bit (see
//! [`crate::mesh`]). A vertex on a surface's open boundary (an edge of one triangle of it) is
//! kept in the seams, and a later surface with the same vertex on its boundary uses that one:
//! the file's mesh is then closed where mesh.stl is, for readers that do not weld vertices.
//! Only boundary vertices are held across surfaces. Deterministic: the same triangles in the
//! same order give the same lists.
//!
//! [`Bodies`]: the PLY and 3MF files need every vertex before the first face, and their
//! counts first of all, but meshes of real CT hold millions of triangles: both bodies are
//! streamed into anonymous temporary files (they vanish when closed, even if the process is
//! killed) and copied into the file at the end.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

use crate::mesh::Triangle;

/// A surface's triangles with shared vertices; see the module doc.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Indexed {
    /// The vertices the surface adds to the file, in order.
    pub vertices: Vec<[f64; 3]>,
    /// 0-based indices into the whole file's vertex list.
    pub faces: Vec<[u64; 3]>,
}

/// The boundary vertices of the surfaces written so far, with their index in the file.
#[derive(Debug, Default)]
pub struct Seams {
    index: HashMap<[u64; 3], u64>,
}

impl Indexed {
    /// `written`: the vertices already in the file (the first new vertex gets that index).
    pub fn of(tris: &[Triangle], seams: &mut Seams, written: u64) -> Indexed {
        // Local vertex ids, then how many triangles use each undirected edge.
        let mut local: HashMap<[u64; 3], usize> = HashMap::with_capacity(tris.len());
        let mut points: Vec<[f64; 3]> = Vec::with_capacity(tris.len() / 2 + 3);
        let ids: Vec<[usize; 3]> = tris
            .iter()
            .map(|t| {
                t.map(|p| {
                    *local.entry(p.map(f64::to_bits)).or_insert_with(|| {
                        points.push(p);
                        points.len() - 1
                    })
                })
            })
            .collect();
        let mut uses: HashMap<(usize, usize), u32> = HashMap::with_capacity(3 * tris.len() / 2);
        for f in &ids {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let mut boundary = vec![false; points.len()];
        for (&(a, b), &n) in &uses {
            if n == 1 {
                boundary[a] = true;
                boundary[b] = true;
            }
        }
        let mut out = Indexed::default();
        let global: Vec<u64> = points
            .iter()
            .zip(&boundary)
            .map(|(p, &on_boundary)| {
                let key = p.map(f64::to_bits);
                if on_boundary {
                    if let Some(&g) = seams.index.get(&key) {
                        return g;
                    }
                }
                let g = written + out.vertices.len() as u64;
                out.vertices.push(*p);
                if on_boundary {
                    seams.index.insert(key, g);
                }
                g
            })
            .collect();
        out.faces = ids.iter().map(|f| f.map(|i| global[i])).collect();
        out
    }
}

/// The vertex and face bodies of an indexed mesh file, held in two temporary files until the
/// file is finished; see the module doc.
pub struct Bodies {
    vertices: BufWriter<File>,
    faces: BufWriter<File>,
}

impl Bodies {
    /// Two empty bodies in `scratch_dir` (normally the output directory).
    pub fn in_dir(scratch_dir: &Path) -> io::Result<Self> {
        Ok(Bodies {
            vertices: BufWriter::with_capacity(1 << 16, tempfile::tempfile_in(scratch_dir)?),
            faces: BufWriter::with_capacity(1 << 16, tempfile::tempfile_in(scratch_dir)?),
        })
    }

    /// Appends one surface's encoded vertices and faces.
    pub fn append(&mut self, vertices: &[u8], faces: &[u8]) -> io::Result<()> {
        self.vertices.write_all(vertices)?;
        self.faces.write_all(faces)
    }

    /// The vertex and face files, each rewound to its start, with the bytes it holds.
    pub fn rewound(self) -> io::Result<[(File, u64); 2]> {
        let rewind = |body: BufWriter<File>| -> io::Result<(File, u64)> {
            let mut f = body.into_inner().map_err(|e| e.into_error())?;
            let bytes = f.stream_position()?;
            f.seek(SeekFrom::Start(0))?;
            Ok((f, bytes))
        };
        Ok([rewind(self.vertices)?, rewind(self.faces)?])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_identical_vertices_and_keeps_the_winding() {
        let (a, b, c, d) = (
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        );
        let m = Indexed::of(&[[a, b, c], [a, c, d]], &mut Seams::default(), 0);
        assert_eq!(m.vertices, vec![a, b, c, d]);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn nearly_equal_vertices_stay_apart() {
        let a = [0.1 + 0.2, 0.0, 0.0];
        let a2 = [0.3, 0.0, 0.0];
        let m = Indexed::of(
            &[
                [a, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                [a2, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            ],
            &mut Seams::default(),
            0,
        );
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.faces[1], [3, 1, 2]);
    }

    #[test]
    fn a_later_surface_reuses_the_vertices_of_a_shared_boundary() {
        // Two squares sharing the edge b–c: the second adds only its two own vertices.
        let (a, b, c, d) = (
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        );
        let (e, f) = ([2.0, 0.0, 0.0], [2.0, 1.0, 0.0]);
        let mut seams = Seams::default();
        let first = Indexed::of(&[[a, b, c], [a, c, d]], &mut seams, 0);
        let second = Indexed::of(&[[b, e, f], [b, f, c]], &mut seams, 4);
        assert_eq!(first.vertices.len(), 4);
        assert_eq!(second.vertices, vec![e, f]);
        assert_eq!(second.faces, vec![[1, 4, 5], [1, 5, 2]]);
    }
}
