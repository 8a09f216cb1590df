//! 3MF mesh writer (`mesh.3mf`), streamed surface by surface with bounded memory: the format
//! 3D-printing slicers (PrusaSlicer, Cura, Bambu Studio) read natively, in millimetres, with
//! the orientation and closedness STL leaves to guesswork.
//!
//! In: per surface, its id and triangles (wound outwards, see [`crate::mesh`]). Out: a 3MF
//! package (3MF Core Specification 1.3): a ZIP holding `[Content_Types].xml`, `_rels/.rels`
//! and `3D/3dmodel.model`, whose one object (`type="model"`, `unit="millimeter"`) is the whole
//! closed mesh: `<vertices>`, `<triangles>` in the triangles' vertex order (counter-clockwise
//! seen from outside, as 3MF requires), and one triangle set per surface (the triangle-sets
//! extension of 3MF Core 1.3, `surface_<id>` as in report.json, one `<t:ref>` per triangle;
//! readers that do not know it ignore it). Vertices are shared within a surface and with
//! earlier surfaces where their boundaries meet, as in mesh.ply ([`super::indexed`]);
//! coordinates are the shortest decimal that reads back as the exact f64. A triangle repeating a vertex (no area; 3MF forbids it)
//! is left out; the pipeline's meshes have none.
//!
//! As in mesh.ply, the model part needs every vertex before the first triangle: the vertex and
//! triangle elements are streamed into temporary files ([`Bodies`]) and copied into the
//! package by [`ThreeMfWriter::finish`]. Deterministic: entries are stamped 1980-01-01 with
//! fixed permissions, so the same triangles give the same bytes.

use std::fmt::Write as _;
use std::io::{self, Seek, Write};
use std::path::Path;

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use super::indexed::{Bodies, Indexed, Seams};
use crate::mesh::Triangle;

const CONTENT_TYPES: &str = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
<Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">\n\
<Default Extension=\"rels\" ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>\n\
<Default Extension=\"model\" ContentType=\"application/vnd.ms-package.3dmanufacturing-3dmodel+xml\"/>\n\
</Types>\n";

const RELS: &str = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\n\
<Relationship Target=\"/3D/3dmodel.model\" Id=\"rel0\" \
Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel\"/>\n\
</Relationships>\n";

pub struct ThreeMfWriter<W: Write + Seek> {
    out: W,
    description: String,
    bodies: Bodies,
    /// Per surface: id, first triangle, triangle count.
    sets: Vec<(usize, u64, u64)>,
    vertices: u64,
    triangles: u64,
    seams: Seams,
}

/// `s` with the five XML special characters escaped, for attribute values and text.
fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

/// One `<t:triangleset>` per surface with triangles, listing them one `<t:ref>` each: the
/// spec's `<t:refrange>` would be shorter, but lib3mf 2.5, the consortium's own reader, rejects
/// it in strict mode ("Invalid Element in namespace").
fn write_triangle_sets(out: &mut impl Write, sets: &[(usize, u64, u64)]) -> io::Result<()> {
    if sets.iter().all(|s| s.2 == 0) {
        return Ok(());
    }
    out.write_all(b"<t:trianglesets>\n")?;
    let mut buf = String::new();
    for &(id, first, count) in sets.iter().filter(|s| s.2 > 0) {
        buf.clear();
        let _ = writeln!(
            buf,
            "<t:triangleset name=\"surface_{id}\" identifier=\"surface_{id}\">"
        );
        for i in first..first + count {
            let _ = writeln!(buf, "<t:ref index=\"{i}\"/>");
        }
        buf.push_str("</t:triangleset>\n");
        out.write_all(buf.as_bytes())?;
    }
    out.write_all(b"</t:trianglesets>\n")
}

impl<W: Write + Seek> ThreeMfWriter<W> {
    /// `description`: the model's Description metadata (units, coordinates); `scratch_dir`:
    /// where the two temporary body files live until [`ThreeMfWriter::finish`].
    pub fn new(out: W, description: &str, scratch_dir: &Path) -> io::Result<Self> {
        Ok(ThreeMfWriter {
            out,
            description: description.to_string(),
            bodies: Bodies::in_dir(scratch_dir)?,
            sets: Vec::new(),
            vertices: 0,
            triangles: 0,
            seams: Seams::default(),
        })
    }

    /// One surface's vertices and triangles. A surface without triangles writes nothing.
    pub fn write_surface(&mut self, id: usize, tris: &[Triangle]) -> io::Result<()> {
        if tris.is_empty() {
            return Ok(());
        }
        let m = Indexed::of(tris, &mut self.seams, self.vertices);
        let mut vertices = String::with_capacity(80 * m.vertices.len());
        for v in &m.vertices {
            // Writing into a String cannot fail.
            let _ = writeln!(
                vertices,
                "<vertex x=\"{}\" y=\"{}\" z=\"{}\"/>",
                v[0], v[1], v[2]
            );
        }
        let mut triangles = String::with_capacity(48 * m.faces.len());
        let mut count = 0;
        for f in m
            .faces
            .iter()
            .filter(|f| f[0] != f[1] && f[1] != f[2] && f[0] != f[2])
        {
            let _ = writeln!(
                triangles,
                "<triangle v1=\"{}\" v2=\"{}\" v3=\"{}\"/>",
                f[0], f[1], f[2]
            );
            count += 1;
        }
        self.bodies
            .append(vertices.as_bytes(), triangles.as_bytes())?;
        self.sets.push((id, self.triangles, count));
        self.vertices += m.vertices.len() as u64;
        self.triangles += count;
        Ok(())
    }

    /// The package: content types, relationships, then the model with the vertex and triangle
    /// bodies copied in; hands back the output (flushed).
    pub fn finish(self) -> io::Result<W> {
        let head = format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
             <model unit=\"millimeter\" xml:lang=\"en-US\" \
             xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\" \
             xmlns:t=\"http://schemas.microsoft.com/3dmanufacturing/trianglesets/2021/07\">\n\
             <metadata name=\"Application\">bskin {}</metadata>\n\
             <metadata name=\"Description\">{}</metadata>\n\
             <resources>\n<object id=\"1\" type=\"model\" name=\"bskin mesh\">\n<mesh>\n<vertices>\n",
            env!("CARGO_PKG_VERSION"),
            xml_escape(&self.description)
        );
        let tail = "</mesh>\n</object>\n</resources>\n<build>\n<item objectid=\"1\"/>\n</build>\n</model>\n";
        let [(mut vertex_body, vertex_bytes), (mut triangle_body, triangle_bytes)] =
            self.bodies.rewound()?;
        let body_bytes = vertex_bytes + triangle_bytes;
        let between = "</vertices>\n<triangles>\n";
        // An upper bound of the model's size, to choose ZIP64 only when it is needed: a set's
        // element with two 20-digit ids is under 160 bytes, a `<t:ref>` under 40.
        let sets_bytes = 64 + 160 * self.sets.len() as u64 + 40 * self.triangles;
        let model_bytes =
            (head.len() + between.len() + tail.len()) as u64 + body_bytes + sets_bytes;
        let options = SimpleFileOptions::default()
            .compression_method(CompressionMethod::Deflated)
            .last_modified_time(DateTime::default())
            .system(zip::System::Unix)
            .unix_permissions(0o644);
        let mut zip = ZipWriter::new(self.out);
        zip.start_file("[Content_Types].xml", options)?;
        zip.write_all(CONTENT_TYPES.as_bytes())?;
        zip.start_file("_rels/.rels", options)?;
        zip.write_all(RELS.as_bytes())?;
        zip.start_file(
            "3D/3dmodel.model",
            options.large_file(model_bytes >= u32::MAX as u64),
        )?;
        zip.write_all(head.as_bytes())?;
        io::copy(&mut vertex_body, &mut zip)?;
        zip.write_all(between.as_bytes())?;
        io::copy(&mut triangle_body, &mut zip)?;
        zip.write_all(b"</triangles>\n")?;
        write_triangle_sets(&mut zip, &self.sets)?;
        zip.write_all(tail.as_bytes())?;
        let mut out = zip.finish()?;
        out.flush()?;
        Ok(out)
    }

    /// Vertices and triangles written so far.
    pub fn counts(&self) -> (u64, u64) {
        (self.vertices, self.triangles)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Cursor, Read};

    fn model_of(bytes: Vec<u8>) -> (Vec<String>, String) {
        let mut zip = zip::ZipArchive::new(Cursor::new(bytes)).unwrap();
        let names: Vec<String> = zip.file_names().map(|n| n.unwrap().into_owned()).collect();
        let mut model = String::new();
        zip.by_name("3D/3dmodel.model")
            .unwrap()
            .read_to_string(&mut model)
            .unwrap();
        (names, model)
    }

    #[test]
    fn one_object_with_shared_vertices_and_a_triangle_set_per_surface() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c, d) = (
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, -0.5],
        );
        let mut w =
            ThreeMfWriter::new(Cursor::new(Vec::new()), "units: mm & <LPS>", dir.path()).unwrap();
        w.write_surface(2, &[[a, b, c], [a, c, d]]).unwrap();
        // A triangle repeating a vertex is left out.
        w.write_surface(5, &[[b, c, d], [b, b, c]]).unwrap();
        assert_eq!(w.counts(), (4, 3));
        let (mut names, model) = model_of(w.finish().unwrap().into_inner());
        names.sort();
        assert_eq!(
            names,
            ["3D/3dmodel.model", "[Content_Types].xml", "_rels/.rels"]
        );
        assert!(model.contains("unit=\"millimeter\""));
        assert!(
            model.contains("<metadata name=\"Description\">units: mm &amp; &lt;LPS&gt;</metadata>")
        );
        assert!(model.contains("<vertex x=\"0\" y=\"1\" z=\"-0.5\"/>\n</vertices>"));
        assert_eq!(model.matches("<vertex ").count(), 4);
        assert!(model.contains(
            "<triangle v1=\"0\" v2=\"1\" v3=\"2\"/>\n<triangle v1=\"0\" v2=\"2\" v3=\"3\"/>\n\
             <triangle v1=\"1\" v2=\"2\" v3=\"3\"/>\n</triangles>"
        ));
        assert!(model.contains(
            "<t:triangleset name=\"surface_5\" identifier=\"surface_5\">\n<t:ref index=\"2\"/>\n</t:triangleset>"
        ));
        // Nothing left in the scratch directory.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn same_triangles_same_bytes_and_exact_coordinates() {
        let dir = tempfile::tempdir().unwrap();
        let p = [0.1 + 0.2, -1.0 / 3.0, 1e-7];
        let tri = [p, [2.5, 0.0, 0.0], [0.0, 1e300, 0.0]];
        let write = || {
            let mut w = ThreeMfWriter::new(Cursor::new(Vec::new()), "x", dir.path()).unwrap();
            w.write_surface(0, &[tri]).unwrap();
            w.finish().unwrap().into_inner()
        };
        let (first, second) = (write(), write());
        assert_eq!(first, second);
        let (_, model) = model_of(first);
        let xs: Vec<f64> = model
            .split("<vertex x=\"")
            .skip(1)
            .map(|s| s.split('"').next().unwrap().parse().unwrap())
            .collect();
        assert_eq!(xs, vec![p[0], 2.5, 0.0]);
        let y: f64 = model
            .split("y=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(y.to_bits(), p[1].to_bits());
    }
}
