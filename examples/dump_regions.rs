//! Diagnostics: stages 3–7 on contour NDJSON from stdin, and the listed surfaces written as
//! JSON on stdout, to look at the surfaces that `scripts/mesh_crossings.py` finds folding.
//!
//! Usage: `bskin contours DIR -o contours.ndjson; cargo run --release --example dump_regions
//! -- IDS [TOLERANCE] < contours.ndjson > regions.json`, IDS a comma-separated list of surface
//! ids (as in the `surfaces` of the report of `bskin run -` on the same NDJSON: stage 6
//! numbers them, after cutting regions into segments, so every region is fitted) or `all`;
//! TOLERANCE in mm (default 0.5, the run's). Per surface: its curves (origins and points,
//! after alignment), the fitting points and parameters, the u knots, v̄, and `rows`: each
//! fitted curve evaluated at `ROW_SAMPLES` (environment, default 2000) equally spaced u.
//! With `MESH_DIR` set, each surface's mesh
//! (chordal 0.2 mm) is also written there as binary STL `s<id>.stl`.

use std::io::BufReader;

use bskin::bspline::fit::FitOptions;
use bskin::config::RunConfig;
use bskin::io::ndjson::NdjsonReader;
use bskin::io::stl::StlWriter;
use bskin::stages::{
    s3_correspondence, s4_branching, s5_alignment, s6_fitting, s7_skinning, Control,
};
use crossbeam_channel::bounded;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: dump_regions IDS|all [TOLERANCE] < contours.ndjson";
    let Some(list) = args.first() else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let ids: Option<Vec<usize>> = (list != "all").then(|| {
        list.split(',')
            .map(|s| {
                s.parse()
                    .unwrap_or_else(|_| fail(&format!("bad id {s:?}; {usage}")))
            })
            .collect()
    });
    let tol: f64 = args.get(1).map_or(0.5, |s| {
        s.parse()
            .unwrap_or_else(|_| fail(&format!("bad tolerance {s:?}")))
    });
    let samples: usize = std::env::var("ROW_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    let mesh_dir = std::env::var("MESH_DIR").ok();
    let config = RunConfig::with_tolerance(tol);
    let ctl = Control::new();
    let reader = NdjsonReader::new(BufReader::new(std::io::stdin()))
        .unwrap_or_else(|e| fail(&e.to_string()));
    let (transitions_tx, transitions_rx) = bounded(4);
    let (regions_tx, regions_rx) = bounded(4);
    let mut out = Vec::new();
    std::thread::scope(|s| {
        let front = s.spawn(|| s3_correspondence::run(reader, 1.0, transitions_tx, &ctl));
        let branching = s.spawn(|| {
            s4_branching::run(
                transitions_rx,
                config.cell_mm,
                config.tolerance_mm,
                128,
                regions_tx,
                &ctl,
            )
        });
        // Every region is fitted: one cut into segments moves the ids after it on, as in
        // stage 6.
        let mut next_id = 0;
        let opts = FitOptions::new(tol);
        for mut region in regions_rx.iter() {
            s5_alignment::align(&mut region, &opts);
            let segments =
                s6_fitting::fit_segments(region, &opts).unwrap_or_else(|e| fail(&e.to_string()));
            for mut fitted in segments {
                fitted.region.id = next_id;
                next_id += 1;
                if ids
                    .as_ref()
                    .is_some_and(|ids| !ids.contains(&fitted.region.id))
                {
                    continue;
                }
                let region = fitted.region.clone();
                let (params, points) = (fitted.fit.params.clone(), fitted.fit.points.clone());
                let surf =
                    s7_skinning::skin_region(fitted, tol).unwrap_or_else(|e| fail(&e.to_string()));
                let sf = &surf.surface;
                let period = sf.u_knots().period();
                let rows: Vec<Vec<[f64; 3]>> = sf
                    .v_bar()
                    .iter()
                    .map(|&v| {
                        (0..samples)
                            .map(|k| sf.eval(period * k as f64 / samples as f64, v))
                            .collect()
                    })
                    .collect();
                if let Some(dir) = &mesh_dir {
                    let c = &region.curves;
                    let tris =
                        bskin::mesh::tessellate(sf, &c[0].points, &c[c.len() - 1].points, 0.2);
                    let path = std::path::Path::new(dir).join(format!("s{}.stl", region.id));
                    let file =
                        std::fs::File::create(&path).unwrap_or_else(|e| fail(&e.to_string()));
                    let written =
                        StlWriter::new(std::io::BufWriter::new(file), "bskin dump_regions")
                            .and_then(|mut w| w.write_triangles(&tris).and_then(|()| w.finish()));
                    if let Err(e) = written {
                        fail(&format!("{}: {e}", path.display()));
                    }
                }
                let origins: Vec<String> = region
                    .curves
                    .iter()
                    .map(|c| format!("{:?}", c.origin))
                    .collect();
                out.push(serde_json::json!({
                    "id": region.id, "hole": region.hole, "origins": origins,
                    "control_points": [sf.n_u(), sf.n_v()], "max_error_mm": surf.error.max_mm,
                    "tolerance_met": surf.tolerance_met,
                    "curves": region.curves.iter().map(|c| c.points.clone()).collect::<Vec<_>>(),
                    "fit_points": points, "fit_params": params, "period": period,
                    "u_knots": sf.u_knots().domain(), "v_bar": sf.v_bar(), "rows": rows,
                    "seal": region.seal,
                }));
            }
        }
        for r in [front.join(), branching.join()] {
            match r {
                Ok(Ok(_)) => {}
                Ok(Err(e)) => fail(&e.to_string()),
                Err(_) => fail("a stage panicked"),
            }
        }
    });
    println!("{}", serde_json::Value::Array(out));
}

fn fail(msg: &str) -> ! {
    eprintln!("dump_regions: {msg}");
    std::process::exit(1)
}
