//! `bskin info`: the series found under a directory, as text or JSON.

use serde_json::{json, Value};

use crate::dicom::{Scan, Series};

fn series_json(s: &Series) -> Value {
    json!({
        "uid": s.uid,
        "key": s.key,
        "number": s.number,
        "description": s.description,
        "modality": s.modality,
        "slices": s.slices.len(),
        "rows": s.rows,
        "cols": s.cols,
        "pixel_spacing": s.spacing,
        "slice_spacing": s.slice_spacing.map(|sp| json!({"min": sp.min, "median": sp.median, "max": sp.max})),
        "orientation": s.orientation,
        "tilt_deg": s.tilt_deg,
        "transfer_syntaxes": s.transfer_syntaxes,
        "localizer": s.localizer,
        "volumetric": s.is_volumetric(),
        "problems": s.problems,
        "errors": s.errors.iter().map(|(p, m)| json!({"file": p.display().to_string(), "message": m})).collect::<Vec<_>>(),
    })
}

pub fn scan_json(scan: &Scan) -> Value {
    json!({
        "files": scan.files,
        "not_dicom": scan.not_dicom,
        "unreadable": scan.unreadable.iter().map(|(p, m)| json!({"file": p.display().to_string(), "message": m})).collect::<Vec<_>>(),
        "notes": scan.notes,
        "series": scan.series.iter().map(series_json).collect::<Vec<_>>(),
    })
}

pub fn scan_text(scan: &Scan) -> String {
    let mut out = format!(
        "{} file(s): {} series, {} not DICOM, {} unreadable\n",
        scan.files,
        scan.series.len(),
        scan.not_dicom,
        scan.unreadable.len()
    );
    for s in &scan.series {
        out.push_str(&format!("\nseries {}\n", s.label()));
        out.push_str(&format!(
            "  description   {:?}\n  modality      {}\n",
            s.description, s.modality
        ));
        out.push_str(&format!(
            "  slices        {}{}\n",
            s.slices.len(),
            if s.is_volumetric() {
                ""
            } else {
                " (not volumetric: skipped by run/contours)"
            }
        ));
        out.push_str(&format!(
            "  size          {} × {} (columns × rows)\n",
            s.cols, s.rows
        ));
        out.push_str(&format!(
            "  pixel spacing {} × {} mm (rows, columns)\n",
            s.spacing[0], s.spacing[1]
        ));
        if let Some(sp) = s.slice_spacing {
            out.push_str(&format!(
                "  slice spacing {:.3} mm median ({:.3}–{:.3})\n",
                sp.median, sp.min, sp.max
            ));
        }
        let o = s.orientation;
        out.push_str(&format!(
            "  orientation   row [{:.4}, {:.4}, {:.4}] col [{:.4}, {:.4}, {:.4}]\n",
            o[0], o[1], o[2], o[3], o[4], o[5]
        ));
        if s.tilt_deg > 0.0 {
            out.push_str(&format!("  gantry tilt   {:.2}°\n", s.tilt_deg));
        }
        let ts: Vec<&str> = s.transfer_syntaxes.iter().map(String::as_str).collect();
        out.push_str(&format!("  transfer      {}\n", ts.join(", ")));
        for p in &s.problems {
            out.push_str(&format!("  problem       {p}\n"));
        }
        for (p, m) in &s.errors {
            out.push_str(&format!("  error         {}: {m}\n", p.display()));
        }
    }
    for (p, m) in &scan.unreadable {
        out.push_str(&format!("\nunreadable {}: {m}\n", p.display()));
    }
    for n in &scan.notes {
        out.push_str(&format!("note: {n}\n"));
    }
    out
}
