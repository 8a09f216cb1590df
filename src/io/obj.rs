//! Wavefront OBJ mesh writer (`mesh.obj`), streamed surface by surface.
//!
//! In: per surface, its id and triangles (wound outwards, see [`crate::mesh`]). Out: an ASCII
//! OBJ: a comment header (producer, units, coordinate system), then per surface with at least
//! one triangle an object and a group named `surface_<id>`, the vertices it adds (`v x y z`:
//! bit-identical vertices merged within the surface, and with earlier surfaces where their
//! boundaries meet, see [`super::indexed`]) and its faces (`f i j k`, 1-based indices into
//! the whole file's vertex list, in the triangles' vertex order, so the winding,
//! counter-clockwise seen from outside, is kept). Coordinates are
//! written as the shortest decimal that reads back to the same f64: exact, and the same bytes
//! for the same triangles. Nothing is held beyond one surface but the boundary vertices.

use std::io::{self, Write};

use super::indexed::{Indexed, Seams};
use crate::mesh::Triangle;

pub struct ObjWriter<W: Write> {
    out: W,
    vertices: u64,
    faces: u64,
    seams: Seams,
}

impl<W: Write> ObjWriter<W> {
    /// Writes the header: `# ` before every line of `comment` (e.g. units and coordinates).
    pub fn new(mut out: W, comment: &str) -> io::Result<Self> {
        for line in comment.lines() {
            writeln!(out, "# {line}")?;
        }
        Ok(ObjWriter {
            out,
            vertices: 0,
            faces: 0,
            seams: Seams::default(),
        })
    }

    /// One surface: its object/group, vertices and faces. A surface without triangles writes
    /// nothing.
    pub fn write_surface(&mut self, id: usize, tris: &[Triangle]) -> io::Result<()> {
        if tris.is_empty() {
            return Ok(());
        }
        let m = Indexed::of(tris, &mut self.seams, self.vertices);
        let mut buf = Vec::with_capacity(40 * m.vertices.len() + 24 * m.faces.len() + 64);
        writeln!(buf, "o surface_{id}")?;
        writeln!(buf, "g surface_{id}")?;
        for v in &m.vertices {
            writeln!(buf, "v {} {} {}", v[0], v[1], v[2])?;
        }
        for f in &m.faces {
            writeln!(buf, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1)?;
        }
        self.out.write_all(&buf)?;
        self.vertices += m.vertices.len() as u64;
        self.faces += m.faces.len() as u64;
        Ok(())
    }

    /// Flush and hand back the output.
    pub fn finish(mut self) -> io::Result<W> {
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
    fn groups_shared_vertices_and_global_indices() {
        let (a, b, c, d) = (
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, -0.5],
        );
        let mut w = ObjWriter::new(Vec::new(), "bskin test\nunits: mm").unwrap();
        w.write_surface(3, &[[a, b, c], [a, c, d]]).unwrap();
        w.write_surface(4, &[]).unwrap();
        w.write_surface(7, &[[b, c, d]]).unwrap();
        // Surface 7 lies on surface 3's boundary vertices: it adds none of its own.
        assert_eq!(w.counts(), (4, 3));
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        assert_eq!(
            text,
            "# bskin test\n# units: mm\n\
             o surface_3\ng surface_3\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 -0.5\nf 1 2 3\nf 1 3 4\n\
             o surface_7\ng surface_7\nf 2 3 4\n"
        );
    }

    #[test]
    fn coordinates_read_back_exactly() {
        let p = [0.1 + 0.2, -123.456789012345, 1e-9];
        let mut w = ObjWriter::new(Vec::new(), "").unwrap();
        w.write_surface(0, &[[p, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
            .unwrap();
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        let v: Vec<f64> = text
            .lines()
            .find(|l| l.starts_with("v "))
            .unwrap()
            .split_whitespace()
            .skip(1)
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!(v, p.to_vec());
    }
}
