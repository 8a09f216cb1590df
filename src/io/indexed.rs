//! Indexed meshes for the OBJ and PLY writers: the triangles of one surface as a vertex list
//! and faces of indices into it.
//!
//! In: triangles (vertex triples). Out: the distinct vertices in order of first appearance and
//! one index triple per triangle, in the triangles' order and with their vertex order (so the
//! winding is kept). Vertices are merged only when bit-identical (all three coordinates have
//! the same f64 bits): no tolerance, so no two distinct points are ever moved onto each other.
//! Deterministic: the same triangles give the same lists.

use std::collections::HashMap;

use crate::mesh::Triangle;

/// A surface's triangles with shared vertices; see the module doc.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Indexed {
    pub vertices: Vec<[f64; 3]>,
    pub faces: Vec<[u32; 3]>,
}

impl Indexed {
    /// Fails (rather than wrapping the index) when one surface has 2^32 vertices or more.
    pub fn of(tris: &[Triangle]) -> std::io::Result<Indexed> {
        let mut index: HashMap<[u64; 3], u32> = HashMap::with_capacity(tris.len());
        let mut out = Indexed {
            vertices: Vec::with_capacity(tris.len() / 2 + 3),
            faces: Vec::with_capacity(tris.len()),
        };
        for t in tris {
            let face = t.map(|p| -> std::io::Result<u32> {
                let key = p.map(f64::to_bits);
                if let Some(&k) = index.get(&key) {
                    return Ok(k);
                }
                let k = u32::try_from(out.vertices.len()).map_err(|_| {
                    std::io::Error::other(format!(
                        "a surface with more than {} vertices: 32-bit mesh indices cannot \
                         address them",
                        u32::MAX
                    ))
                })?;
                out.vertices.push(p);
                index.insert(key, k);
                Ok(k)
            });
            let [a, b, c] = face;
            out.faces.push([a?, b?, c?]);
        }
        Ok(out)
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
        let m = Indexed::of(&[[a, b, c], [a, c, d]]).unwrap();
        assert_eq!(m.vertices, vec![a, b, c, d]);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn nearly_equal_vertices_stay_apart() {
        let a = [0.1 + 0.2, 0.0, 0.0];
        let a2 = [0.3, 0.0, 0.0];
        let m = Indexed::of(&[
            [a, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            [a2, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        ])
        .unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.faces[1], [3, 1, 2]);
    }
}
