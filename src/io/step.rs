//! STEP (ISO 10303-21) writer: the skinned surfaces as one AP214 (AUTOMOTIVE_DESIGN) surface
//! model, units mm.
//!
//! In: surfaces in region order and a [`CadMeta`]. Out: one exchange file with a product
//! (`PRODUCT` … `SHAPE_DEFINITION_REPRESENTATION`) whose shape is a
//! `MANIFOLD_SURFACE_SHAPE_REPRESENTATION` holding one `SHELL_BASED_SURFACE_MODEL`, with one
//! `OPEN_SHELL` per surface, each of one `ADVANCED_FACE` on a `B_SPLINE_SURFACE_WITH_KNOTS`
//! (degree 3×3, `u_closed = .T.`, form `.UNSPECIFIED.`). The face is bounded by its natural
//! boundary: the iso-curves v = v_min and v = v_max (closed `B_SPLINE_CURVE_WITH_KNOTS` on the
//! u knots, left out where the surface closes onto a cap point there) and the seam u = 0 (an
//! open curve on the v knots), used twice with opposite orientations.
//!
//! Periodic u is unwrapped as CAD kernels expect (see [`super::cad`]): n+4 control rows (the
//! first three repeated), the n+8 extended knots with multiplicity 1 each; parameters are
//! bskin's own (identity mapping). v keeps its clamped knots (end multiplicity 4).
//!
//! Invariants: entity ids are consecutive from #1 in a fixed order, reals are written in
//! shortest round-trip form, the FILE_NAME timestamp is `meta.timestamp` (fixed by default):
//! the same surfaces give the same bytes.

use std::io::{self, Write};

use super::cad::{knots_with_mults, real, CadMeta, Unwrapped};
use crate::bspline::SkinnedSurface;

type P3 = [f64; 3];

/// Writes `surfaces` as an AP214 STEP file; see the module doc.
pub fn write_step<W: Write>(
    out: W,
    surfaces: &[&SkinnedSurface],
    meta: &CadMeta,
) -> io::Result<()> {
    let mut w = StepOut {
        out: io::BufWriter::new(out),
        next: 1,
    };
    w.header(meta)?;
    w.line("DATA;")?;
    let app = w.ent("APPLICATION_CONTEXT('automotive design')")?;
    w.ent(&format!(
        "APPLICATION_PROTOCOL_DEFINITION('international standard','automotive_design',2000,{app})"
    ))?;
    let pctx = w.ent(&format!("PRODUCT_CONTEXT('',{app},'mechanical')"))?;
    let name = string(&meta.system);
    let product = w.ent(&format!(
        "PRODUCT('bskin','{}','',({pctx}))",
        string(&meta.description)
    ))?;
    w.ent(&format!(
        "PRODUCT_RELATED_PRODUCT_CATEGORY('part',$,({product}))"
    ))?;
    let pdf = w.ent(&format!(
        "PRODUCT_DEFINITION_FORMATION('','{name}',{product})"
    ))?;
    let pdctx = w.ent(&format!(
        "PRODUCT_DEFINITION_CONTEXT('part definition',{app},'design')"
    ))?;
    let pd = w.ent(&format!("PRODUCT_DEFINITION('design','',{pdf},{pdctx})"))?;
    let pds = w.ent(&format!("PRODUCT_DEFINITION_SHAPE('','',{pd})"))?;
    let mm = w.ent("(LENGTH_UNIT()NAMED_UNIT(*)SI_UNIT(.MILLI.,.METRE.))")?;
    let rad = w.ent("(NAMED_UNIT(*)PLANE_ANGLE_UNIT()SI_UNIT($,.RADIAN.))")?;
    let sr = w.ent("(NAMED_UNIT(*)SI_UNIT($,.STERADIAN.)SOLID_ANGLE_UNIT())")?;
    let unc = w.ent(&format!(
        "UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE({}),{mm},'distance_accuracy_value','confusion accuracy')",
        real(1e-7)
    ))?;
    let ctx = w.ent(&format!(
        "(GEOMETRIC_REPRESENTATION_CONTEXT(3)GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT(({unc}))\
         GLOBAL_UNIT_ASSIGNED_CONTEXT(({mm},{rad},{sr}))REPRESENTATION_CONTEXT('',''))"
    ))?;
    let origin = w.point(&[0.0; 3])?;
    let placement = w.ent(&format!("AXIS2_PLACEMENT_3D('',{origin},$,$)"))?;

    let mut shells = Vec::with_capacity(surfaces.len());
    for (k, s) in surfaces.iter().enumerate() {
        let face = w.face(k, s)?;
        shells.push(w.ent(&format!("OPEN_SHELL('surface {k}',({face}))"))?);
    }
    // The model's shell set may not be empty (SET [1:?]): with no surface the representation
    // holds only its placement.
    let mut items = vec![placement];
    if !shells.is_empty() {
        items.push(w.ent(&format!(
            "SHELL_BASED_SURFACE_MODEL('',({}))",
            shells.join(",")
        ))?);
    }
    let rep = w.ent(&format!(
        "MANIFOLD_SURFACE_SHAPE_REPRESENTATION('bskin surfaces',({}),{ctx})",
        items.join(",")
    ))?;
    w.ent(&format!("SHAPE_DEFINITION_REPRESENTATION({pds},{rep})"))?;
    w.line("ENDSEC;")?;
    w.line("END-ISO-10303-21;")?;
    w.out.flush()
}

struct StepOut<W: Write> {
    out: io::BufWriter<W>,
    next: usize,
}

impl<W: Write> StepOut<W> {
    fn line(&mut self, s: &str) -> io::Result<()> {
        self.out.write_all(s.as_bytes())?;
        self.out.write_all(b"\n")
    }

    /// Writes `#id=body;` and returns "#id".
    fn ent(&mut self, body: &str) -> io::Result<String> {
        let id = self.next;
        self.next += 1;
        writeln!(self.out, "#{id}={body};")?;
        Ok(format!("#{id}"))
    }

    fn point(&mut self, p: &P3) -> io::Result<String> {
        self.ent(&format!(
            "CARTESIAN_POINT('',({},{},{}))",
            real(p[0]),
            real(p[1]),
            real(p[2])
        ))
    }

    fn header(&mut self, meta: &CadMeta) -> io::Result<()> {
        self.line("ISO-10303-21;")?;
        self.line("HEADER;")?;
        self.line(&format!(
            "FILE_DESCRIPTION(('{}','units mm, patient {} coordinates'),'2;1');",
            string(&meta.description),
            string(meta.coordinates)
        ))?;
        self.line(&format!(
            "FILE_NAME('{}','{}',(''),(''),'{}','{}','');",
            string(&meta.file_name),
            string(&meta.timestamp),
            string(&meta.system),
            string(&meta.system)
        ))?;
        self.line("FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));")?;
        self.line("ENDSEC;")
    }

    /// A B-spline curve on the given full knot vector.
    fn curve(&mut self, pts: &[P3], knots: &[f64], closed: bool) -> io::Result<String> {
        let ids = pts
            .iter()
            .map(|p| self.point(p))
            .collect::<io::Result<Vec<_>>>()?;
        let (vals, mults) = knots_with_mults(knots);
        self.ent(&format!(
            "B_SPLINE_CURVE_WITH_KNOTS('',3,({}),.UNSPECIFIED.,{},.F.,({}),({}),.UNSPECIFIED.)",
            ids.join(","),
            logical(closed),
            ints(&mults),
            reals(&vals)
        ))
    }

    /// One surface as an ADVANCED_FACE bounded by its natural boundary; returns the face id.
    fn face(&mut self, k: usize, s: &SkinnedSurface) -> io::Result<String> {
        let un = Unwrapped::of(s);
        let mut rows = Vec::with_capacity(un.rows.len());
        for row in &un.rows {
            let ids = row
                .iter()
                .map(|p| self.point(p))
                .collect::<io::Result<Vec<_>>>()?;
            rows.push(format!("({})", ids.join(",")));
        }
        let (uk, um) = knots_with_mults(&un.u_knots);
        let (vk, vm) = knots_with_mults(&un.v_knots);
        let surf = self.ent(&format!(
            "B_SPLINE_SURFACE_WITH_KNOTS('surface {k}',3,3,({}),.UNSPECIFIED.,.T.,.F.,.F.,({}),({}),({}),({}),.UNSPECIFIED.)",
            rows.join(","),
            ints(&um),
            ints(&vm),
            reals(&uk),
            reals(&vk)
        ))?;

        // Natural boundary. The bottom/top iso-curves are the first/last control columns (v is
        // clamped); the seam's control points are the u basis at u = ξ_0 applied to the rows.
        let nv = un.rows.first().map_or(0, |r| r.len());
        let column = |j: usize| -> Vec<P3> { un.rows.iter().map(|r| r[j]).collect() };
        let (bottom, top) = (column(0), column(nv - 1));
        let seam_pts = un.u_iso_control(un.u_domain.0);
        let p0 = seam_pts[0];
        let p1 = seam_pts[nv - 1];
        let v0 = self.point(&p0)?;
        let v0 = self.ent(&format!("VERTEX_POINT('',{v0})"))?;
        let v1 = self.point(&p1)?;
        let v1 = self.ent(&format!("VERTEX_POINT('',{v1})"))?;
        let seam_c = self.curve(&seam_pts, &un.v_knots, false)?;
        let seam = self.ent(&format!("EDGE_CURVE('',{v0},{v1},{seam_c},.T.)"))?;
        // Counter-clockwise in (u, v): bottom (u ↑), seam at u = max (v ↑), top (u ↓), seam
        // at u = min (v ↓). An end that closes onto a cap point has no edge: the loop just
        // passes through the pole vertex.
        let mut oriented = Vec::new();
        if !is_point(&bottom) {
            let c = self.curve(&bottom, &un.u_knots, true)?;
            let e = self.ent(&format!("EDGE_CURVE('',{v0},{v0},{c},.T.)"))?;
            oriented.push(self.ent(&format!("ORIENTED_EDGE('',*,*,{e},.T.)"))?);
        }
        oriented.push(self.ent(&format!("ORIENTED_EDGE('',*,*,{seam},.T.)"))?);
        if !is_point(&top) {
            let c = self.curve(&top, &un.u_knots, true)?;
            let e = self.ent(&format!("EDGE_CURVE('',{v1},{v1},{c},.T.)"))?;
            oriented.push(self.ent(&format!("ORIENTED_EDGE('',*,*,{e},.F.)"))?);
        }
        oriented.push(self.ent(&format!("ORIENTED_EDGE('',*,*,{seam},.F.)"))?);
        let lp = self.ent(&format!("EDGE_LOOP('',({}))", oriented.join(",")))?;
        let bound = self.ent(&format!("FACE_OUTER_BOUND('',{lp},.T.)"))?;
        self.ent(&format!(
            "ADVANCED_FACE('surface {k}',({bound}),{surf},.T.)"
        ))
    }
}

/// All points equal: the iso-curve is a cap point.
fn is_point(pts: &[P3]) -> bool {
    let scale = pts
        .iter()
        .flat_map(|p| p.iter())
        .fold(1.0, |m: f64, c| m.max(c.abs()));
    pts.iter().all(|p| {
        p.iter()
            .zip(pts[0].iter())
            .all(|(a, b)| (a - b).abs() <= 1e-12 * scale)
    })
}

fn logical(b: bool) -> &'static str {
    if b {
        ".T."
    } else {
        ".F."
    }
}

fn ints(v: &[usize]) -> String {
    v.iter()
        .map(|m| m.to_string())
        .collect::<Vec<_>>()
        .join(",")
}

fn reals(v: &[f64]) -> String {
    v.iter().map(|x| real(*x)).collect::<Vec<_>>().join(",")
}

/// A STEP string body: apostrophes doubled, restricted to printable ASCII (Part 21 needs
/// \X\ escapes for anything else; a '?' keeps the file valid and readable).
fn string(s: &str) -> String {
    s.chars()
        .map(|c| if (' '..='~').contains(&c) { c } else { '?' })
        .collect::<String>()
        .replace('\\', "\\\\")
        .replace('\'', "''")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strings_are_escaped() {
        assert_eq!(string("it's a\\b é"), "it''s a\\\\b ?");
    }

    #[test]
    fn cap_detection() {
        assert!(is_point(&[[1.0, 2.0, 3.0]; 5]));
        assert!(!is_point(&[[1.0, 2.0, 3.0], [1.0, 2.0, 3.1]]));
    }
}
