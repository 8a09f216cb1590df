//! Binary STL: an 80-byte header, a triangle count, then 50 bytes per triangle (normal,
//! three vertices as little-endian f32, a zero attribute). The count is patched in at the end,
//! so triangles can be streamed as surfaces arrive.

use std::io::{Seek, SeekFrom, Write};

use crate::mesh::{normal, Triangle};

pub struct StlWriter<W: Write + Seek> {
    out: W,
    count: u32,
}

impl<W: Write + Seek> StlWriter<W> {
    pub fn new(mut out: W, header: &str) -> std::io::Result<Self> {
        let mut h = [b' '; 80];
        let bytes = header.as_bytes();
        // "solid" at the start makes some readers take a binary file for ASCII.
        let n = bytes.len().min(80);
        h[..n].copy_from_slice(&bytes[..n]);
        out.write_all(&h)?;
        out.write_all(&0u32.to_le_bytes())?;
        Ok(StlWriter { out, count: 0 })
    }

    pub fn write_triangles(&mut self, tris: &[Triangle]) -> std::io::Result<()> {
        // In chunks: one buffer for a whole long surface was the largest allocation of a run.
        const CHUNK: usize = 1024;
        let mut buf = Vec::with_capacity(50 * CHUNK.min(tris.len()));
        for chunk in tris.chunks(CHUNK) {
            buf.clear();
            encode(chunk, &mut buf);
            self.out.write_all(&buf)?;
        }
        self.count = self
            .count
            .checked_add(tris.len() as u32)
            .ok_or_else(|| std::io::Error::other("more than 2^32 triangles"))?;
        Ok(())
    }

    /// Patch the triangle count and hand back the writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.seek(SeekFrom::Start(80))?;
        self.out.write_all(&self.count.to_le_bytes())?;
        self.out.seek(SeekFrom::End(0))?;
        Ok(self.out)
    }

    pub fn count(&self) -> u32 {
        self.count
    }
}

/// 50 bytes per triangle: unit normal, three vertices (f32), a zero attribute.
fn encode(tris: &[Triangle], buf: &mut Vec<u8>) {
    for t in tris {
        let n = normal(t);
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let n = if len > 0.0 {
            [n[0] / len, n[1] / len, n[2] / len]
        } else {
            [0.0; 3]
        };
        for c in n
            .iter()
            .map(|&c| c as f32)
            .chain(single(t).into_iter().flatten())
        {
            buf.extend_from_slice(&c.to_le_bytes());
        }
        buf.extend_from_slice(&[0, 0]);
    }
}

/// A triangle's vertices rounded as mesh.stl stores them.
pub fn single(t: &Triangle) -> [[f32; 3]; 3] {
    t.map(|p| p.map(|x| x as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_count_and_size() {
        let mut w = StlWriter::new(std::io::Cursor::new(Vec::new()), "bskin test").unwrap();
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        w.write_triangles(&[t, t]).unwrap();
        let bytes = w.finish().unwrap().into_inner();
        assert_eq!(bytes.len(), 84 + 2 * 50);
        assert_eq!(u32::from_le_bytes(bytes[80..84].try_into().unwrap()), 2);
        // The normal of the first triangle is +z.
        let nz = f32::from_le_bytes(bytes[92..96].try_into().unwrap());
        assert_eq!(nz, 1.0);
    }
}
