//! Binary PLY mesh writer (`mesh.ply`), streamed surface by surface with bounded memory.
//!
//! In: per surface, its id and triangles (wound outwards, see [`crate::mesh`]). Out: a PLY 1.0
//! file, `binary_little_endian`: a header (producer, units and coordinate system as comments,
//! one `comment surface <id> faces <first> <count>` per surface, then `element vertex V` with
//! `double x, y, z` and `element face F` with `list uchar int vertex_indices`), the V vertices
//! (24 bytes each) and the F faces (13 bytes each: the count 3, then three int32 indices, in
//! the triangles' vertex order, so the winding is kept). Vertices are shared within a surface
//! and with earlier surfaces where their boundaries meet (bit-identical ones merged, see
//! [`super::indexed`]); coordinates are the exact f64 values.
//!
//! The header needs V and F before the bodies: they are streamed into temporary files
//! ([`Bodies`], in a directory of the caller's choice) and copied behind the header by
//! [`PlyWriter::finish`]. Memory holds one surface at a time, and the boundary vertices. Deterministic: the same triangles give the same bytes.

use std::io::{self, Write};
use std::path::Path;

use super::indexed::{Bodies, Indexed, Seams};
use crate::mesh::Triangle;

pub struct PlyWriter<W: Write> {
    out: W,
    comments: Vec<String>,
    bodies: Bodies,
    vertices: u64,
    faces: u64,
    seams: Seams,
}

impl<W: Write> PlyWriter<W> {
    /// `comment`: header comment lines (e.g. units and coordinates); `scratch_dir`: where the
    /// two temporary body files live until [`PlyWriter::finish`].
    pub fn new(out: W, comment: &str, scratch_dir: &Path) -> io::Result<Self> {
        Ok(PlyWriter {
            out,
            comments: comment.lines().map(str::to_string).collect(),
            bodies: Bodies::in_dir(scratch_dir)?,
            vertices: 0,
            faces: 0,
            seams: Seams::default(),
        })
    }

    /// One surface's vertices and faces. A surface without triangles writes nothing.
    pub fn write_surface(&mut self, id: usize, tris: &[Triangle]) -> io::Result<()> {
        if tris.is_empty() {
            return Ok(());
        }
        let m = Indexed::of(tris, &mut self.seams, self.vertices);
        let total = self.vertices + m.vertices.len() as u64;
        if total > i32::MAX as u64 {
            return Err(io::Error::other(
                "more than 2^31 − 1 vertices: PLY int32 indices cannot address them",
            ));
        }
        let mut vertices = Vec::with_capacity(24 * m.vertices.len());
        for v in &m.vertices {
            for c in v {
                vertices.extend_from_slice(&c.to_le_bytes());
            }
        }
        let mut faces = Vec::with_capacity(13 * m.faces.len());
        for f in &m.faces {
            faces.push(3u8);
            for &i in f {
                // Below 2^31 − 1: checked above against the vertex count.
                faces.extend_from_slice(&(i as i32).to_le_bytes());
            }
        }
        self.bodies.append(&vertices, &faces)?;
        self.comments.push(format!(
            "surface {id} faces {} {}",
            self.faces,
            m.faces.len()
        ));
        self.vertices = total;
        self.faces += m.faces.len() as u64;
        Ok(())
    }

    /// Header, then the vertex and face bodies; hands back the output (flushed).
    pub fn finish(mut self) -> io::Result<W> {
        let mut h = String::from("ply\nformat binary_little_endian 1.0\n");
        for c in &self.comments {
            h.push_str("comment ");
            h.push_str(c);
            h.push('\n');
        }
        h.push_str(&format!(
            "element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
             element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            self.vertices, self.faces
        ));
        self.out.write_all(h.as_bytes())?;
        let expected = [24 * self.vertices, 13 * self.faces];
        for ((mut f, _), bytes) in self.bodies.rewound()?.into_iter().zip(expected) {
            let copied = io::copy(&mut f, &mut self.out)?;
            if copied != bytes {
                return Err(io::Error::other(format!(
                    "PLY body: {copied} bytes read back from the temporary file, {bytes} written"
                )));
            }
        }
        self.out.flush()?;
        Ok(self.out)
    }

    /// Vertices and faces written so far.
    pub fn counts(&self) -> (u64, u64) {
        (self.vertices, self.faces)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_counts_and_little_endian_bodies() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c, d) = (
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, -0.5],
        );
        let mut w = PlyWriter::new(Vec::new(), "bskin test", dir.path()).unwrap();
        w.write_surface(2, &[[a, b, c], [a, c, d]]).unwrap();
        w.write_surface(5, &[[b, c, d]]).unwrap();
        // Surface 5 lies on surface 2's boundary vertices: it adds none of its own.
        assert_eq!(w.counts(), (4, 3));
        let bytes = w.finish().unwrap();
        let end = b"end_header\n";
        let at = bytes.windows(end.len()).position(|x| x == end).unwrap() + end.len();
        let header = std::str::from_utf8(&bytes[..at]).unwrap();
        assert!(header.starts_with("ply\nformat binary_little_endian 1.0\ncomment bskin test\n"));
        assert!(header.contains("comment surface 2 faces 0 2\ncomment surface 5 faces 2 1\n"));
        assert!(header.contains("element vertex 4\n") && header.contains("element face 3\n"));
        let body = &bytes[at..];
        assert_eq!(body.len(), 4 * 24 + 3 * 13);
        let f64_at = |k: usize| f64::from_le_bytes(body[8 * k..8 * k + 8].try_into().unwrap());
        assert_eq!([f64_at(9), f64_at(10), f64_at(11)], d);
        let faces = &body[4 * 24..];
        let i32_at = |o: usize| i32::from_le_bytes(faces[o..o + 4].try_into().unwrap());
        assert_eq!(faces[0], 3);
        assert_eq!([i32_at(1), i32_at(5), i32_at(9)], [0, 1, 2]);
        assert_eq!(faces[26], 3);
        assert_eq!([i32_at(27), i32_at(31), i32_at(35)], [1, 2, 3]);
        // Nothing left in the scratch directory.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
