//! Formats read and written: contour NDJSON, STL, OBJ, PLY, STEP, IGES, report and sample JSON, and
//! atomic (write-then-rename) output files; the written mesh's crossing check.

pub mod atomic;
pub mod cad;
pub mod crossing_check;
pub mod iges;
pub mod indexed;
pub mod listing;
pub mod meshes;
pub mod ndjson;
pub mod obj;
pub mod ply;
pub mod report;
pub mod samples;
pub mod step;
pub mod stl;
pub mod threemf;
