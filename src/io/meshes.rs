//! The mesh files of a run together: `mesh.stl`, `mesh.obj`, `mesh.ply` and `mesh.3mf`,
//! whichever were asked for, fed the same triangles surface by surface.
//!
//! In: the output directory, which formats, the coordinate system the triangles are in (for
//! the headers), then per surface its id and triangles. Out: the files, each written under a
//! temporary name and renamed by [`MeshWriters::commit`] only when complete (a failed run
//! leaves none of them half-written). The triangles must already be in the named coordinate
//! system; nothing here transforms them.

use std::path::{Path, PathBuf};

use super::atomic::AtomicFile;
use super::obj::ObjWriter;
use super::ply::PlyWriter;
use super::stl::StlWriter;
use super::threemf::ThreeMfWriter;
use crate::config::{CoordinateSystem, OutputOptions};
use crate::mesh::Triangle;
use crate::{Error, Result};

pub const STL_FILE: &str = "mesh.stl";
pub const OBJ_FILE: &str = "mesh.obj";
pub const PLY_FILE: &str = "mesh.ply";
pub const THREE_MF_FILE: &str = "mesh.3mf";

pub struct MeshWriters {
    stl: Option<(PathBuf, StlWriter<AtomicFile>)>,
    obj: Option<(PathBuf, ObjWriter<AtomicFile>)>,
    ply: Option<(PathBuf, PlyWriter<AtomicFile>)>,
    three_mf: Option<(PathBuf, ThreeMfWriter<AtomicFile>)>,
}

fn output_error(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::Output {
        path: path.to_path_buf(),
        source: e,
    }
}

/// Header text of the OBJ, PLY and 3MF files: producer, units, coordinate system, winding.
pub fn mesh_comment(system: CoordinateSystem) -> String {
    format!(
        "bskin {} mesh of B-spline surfaces\nunits: mm\ncoordinates: patient {}{}\n\
         faces wound counter-clockwise seen from outside (normals point out of the material)",
        env!("CARGO_PKG_VERSION"),
        system.name(),
        match system {
            CoordinateSystem::Lps => " (DICOM: x left, y posterior, z superior)",
            CoordinateSystem::Ras => " (x right, y anterior, z superior)",
        }
    )
}

impl MeshWriters {
    /// Opens (under temporary names) the mesh files `outputs` asks for in `out_dir`.
    pub fn create(out_dir: &Path, outputs: &OutputOptions) -> Result<Self> {
        let system = outputs.coordinates;
        let comment = mesh_comment(system);
        let stl = if outputs.stl {
            let path = out_dir.join(STL_FILE);
            let header = format!("bskin mesh, patient {} mm", system.name());
            let w =
                StlWriter::new(AtomicFile::create(&path)?, &header).map_err(output_error(&path))?;
            Some((path, w))
        } else {
            None
        };
        let obj = if outputs.obj {
            let path = out_dir.join(OBJ_FILE);
            let c = format!(
                "{comment}\none object and group per surface: surface_<id> as in report.json"
            );
            let w = ObjWriter::new(AtomicFile::create(&path)?, &c).map_err(output_error(&path))?;
            Some((path, w))
        } else {
            None
        };
        let ply = if outputs.ply {
            let path = out_dir.join(PLY_FILE);
            let w = PlyWriter::new(AtomicFile::create(&path)?, &comment, out_dir)
                .map_err(output_error(&path))?;
            Some((path, w))
        } else {
            None
        };
        let three_mf = if outputs.three_mf {
            let path = out_dir.join(THREE_MF_FILE);
            let d =
                format!("{comment}\none triangle set per surface: surface_<id> as in report.json");
            let w = ThreeMfWriter::new(AtomicFile::create(&path)?, &d, out_dir)
                .map_err(output_error(&path))?;
            Some((path, w))
        } else {
            None
        };
        Ok(MeshWriters {
            stl,
            obj,
            ply,
            three_mf,
        })
    }

    /// Whether any mesh file is being written (else the caller need not tessellate).
    pub fn any(&self) -> bool {
        self.stl.is_some() || self.wants_whole_surfaces()
    }

    /// Surface `id`'s triangles into every open mesh file.
    pub fn write_surface(&mut self, id: usize, tris: &[Triangle]) -> Result<()> {
        self.write_stl(tris)?;
        self.write_indexed(id, tris)
    }

    /// Triangles into `mesh.stl`, which needs no more than that: a surface may come in any
    /// number of calls, so it streams.
    pub fn write_stl(&mut self, tris: &[Triangle]) -> Result<()> {
        if let Some((path, w)) = self.stl.as_mut() {
            w.write_triangles(tris).map_err(output_error(path))?;
        }
        Ok(())
    }

    /// Whether `mesh.obj`, `mesh.ply` or `mesh.3mf` is open: they index a surface's shared
    /// vertices, so they need its triangles at once ([`Self::write_indexed`]).
    pub fn wants_whole_surfaces(&self) -> bool {
        self.obj.is_some() || self.ply.is_some() || self.three_mf.is_some()
    }

    /// Surface `id`'s triangles, all of them, into `mesh.obj`, `mesh.ply` and `mesh.3mf`.
    pub fn write_indexed(&mut self, id: usize, tris: &[Triangle]) -> Result<()> {
        if let Some((path, w)) = self.obj.as_mut() {
            w.write_surface(id, tris).map_err(output_error(path))?;
        }
        if let Some((path, w)) = self.ply.as_mut() {
            w.write_surface(id, tris).map_err(output_error(path))?;
        }
        if let Some((path, w)) = self.three_mf.as_mut() {
            w.write_surface(id, tris).map_err(output_error(path))?;
        }
        Ok(())
    }

    /// Completes every file and renames it onto its final name; returns their paths in the
    /// order STL, OBJ, PLY, 3MF.
    pub fn commit(self) -> Result<Vec<PathBuf>> {
        let mut done = Vec::new();
        if let Some((path, w)) = self.stl {
            w.finish().map_err(output_error(&path))?.commit()?;
            done.push(path);
        }
        if let Some((path, w)) = self.obj {
            w.finish().map_err(output_error(&path))?.commit()?;
            done.push(path);
        }
        if let Some((path, w)) = self.ply {
            w.finish().map_err(output_error(&path))?.commit()?;
            done.push(path);
        }
        if let Some((path, w)) = self.three_mf {
            w.finish().map_err(output_error(&path))?.commit()?;
            done.push(path);
        }
        Ok(done)
    }
}
