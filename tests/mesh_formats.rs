//! Mesh formats and the coordinate system, end to end on the phantom series in
//! `testdata/tube-split`: `mesh.obj`, `mesh.ply` and `mesh.3mf` read back (by small parsers
//! written here, independent of the writers) hold exactly the triangles of `mesh.stl`
//! (`scripts/check_meshes.py` reads them with trimesh and lib3mf in CI); `--ras` turns every
//! geometric output (meshes, STEP, samples) into the LPS one with x and y negated, keeps the
//! winding outward, and the report and headers say which system.

mod common;

use std::path::{Path, PathBuf};

use bskin::config::{CoordinateSystem, OutputOptions, RunConfig};
use bskin::pipeline::RunSummary;
use common::*;

type Tri = [[f64; 3]; 3];

fn testdata() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/tube-split")
}

fn run(out: &Path, coordinates: CoordinateSystem) -> RunSummary {
    let mut config = RunConfig::with_tolerance(0.5);
    config.outputs = OutputOptions {
        stl: true,
        obj: true,
        ply: true,
        three_mf: true,
        step: true,
        iges: true,
        samples: true,
        coordinates,
        check_crossings: true,
    };
    run_dir(&testdata(), out, &config).expect("run")
}

/// An OBJ: (object names, triangles by vertex index, 1-based, into one global vertex list).
fn read_obj(path: &Path) -> (Vec<String>, Vec<Tri>, String) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut faces = Vec::new();
    let mut objects = Vec::new();
    let mut comments = String::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("#") => {
                comments.push_str(line);
                comments.push('\n');
            }
            Some("o") => objects.push(it.next().unwrap().to_string()),
            Some("v") => {
                let c: Vec<f64> = it.map(|x| x.parse().unwrap()).collect();
                assert_eq!(c.len(), 3, "{line}");
                vertices.push([c[0], c[1], c[2]]);
            }
            Some("f") => {
                let i: Vec<usize> = it.map(|x| x.parse().unwrap()).collect();
                assert_eq!(i.len(), 3, "{line}");
                assert!(i.iter().all(|&k| k >= 1 && k <= vertices.len()), "{line}");
                faces.push([vertices[i[0] - 1], vertices[i[1] - 1], vertices[i[2] - 1]]);
            }
            Some("g") | None => {}
            Some(other) => panic!("unexpected OBJ statement {other:?}"),
        }
    }
    (objects, faces, comments)
}

/// A binary little-endian PLY with double x, y, z vertices and uchar/int face lists:
/// (header, vertex count, triangles).
fn read_ply(path: &Path) -> (String, usize, Vec<Tri>) {
    let b = std::fs::read(path).unwrap();
    let end = b"end_header\n";
    let at = b.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let header = String::from_utf8(b[..at].to_vec()).unwrap();
    let lines: Vec<&str> = header.lines().collect();
    assert_eq!(&lines[..2], &["ply", "format binary_little_endian 1.0"]);
    let count = |el: &str| -> usize {
        let l = lines
            .iter()
            .find(|l| l.starts_with(&format!("element {el} ")))
            .unwrap();
        l.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let (nv, nf) = (count("vertex"), count("face"));
    for p in [
        "property double x",
        "property double y",
        "property double z",
        "property list uchar int vertex_indices",
    ] {
        assert!(lines.contains(&p), "{header}");
    }
    let body = &b[at..];
    assert_eq!(body.len(), 24 * nv + 13 * nf, "PLY body size");
    let f = |o: usize| f64::from_le_bytes(body[o..o + 8].try_into().unwrap());
    let vertices: Vec<[f64; 3]> = (0..nv)
        .map(|k| [f(24 * k), f(24 * k + 8), f(24 * k + 16)])
        .collect();
    let faces = &body[24 * nv..];
    let tris = (0..nf)
        .map(|k| {
            let r = &faces[13 * k..13 * k + 13];
            assert_eq!(r[0], 3);
            let i = |o: usize| i32::from_le_bytes(r[o..o + 4].try_into().unwrap()) as usize;
            [vertices[i(1)], vertices[i(5)], vertices[i(9)]]
        })
        .collect();
    (header, nv, tris)
}

/// The value of attribute `name` in one XML element's text.
fn attr<'a>(element: &'a str, name: &str) -> &'a str {
    let key = format!(" {name}=\"");
    let at = element
        .find(&key)
        .unwrap_or_else(|| panic!("{name} in {element}"))
        + key.len();
    &element[at..at + element[at..].find('"').unwrap()]
}

/// A 3MF package's model: (triangles, vertex count, triangle sets as (identifier, count),
/// the model element's text before `<resources>`).
fn read_3mf(path: &Path) -> (Vec<Tri>, usize, Vec<(String, usize)>, String) {
    use std::io::Read;
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    let mut names: Vec<String> = zip.file_names().map(|n| n.unwrap().into_owned()).collect();
    names.sort();
    assert_eq!(
        names,
        ["3D/3dmodel.model", "[Content_Types].xml", "_rels/.rels"]
    );
    let mut model = String::new();
    zip.by_name("3D/3dmodel.model")
        .unwrap()
        .read_to_string(&mut model)
        .unwrap();
    let head = model[..model.find("<resources>").unwrap()].to_string();
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut tris = Vec::new();
    let mut sets: Vec<(String, usize)> = Vec::new();
    for element in model.split('<').map(|e| e.trim_end()) {
        if element.starts_with("vertex ") {
            let c = |n: &str| attr(element, n).parse::<f64>().unwrap();
            vertices.push([c("x"), c("y"), c("z")]);
        } else if element.starts_with("triangle ") {
            let v = |n: &str| vertices[attr(element, n).parse::<usize>().unwrap()];
            tris.push([v("v1"), v("v2"), v("v3")]);
        } else if element.starts_with("t:triangleset ") {
            sets.push((attr(element, "identifier").to_string(), 0));
        } else if element.starts_with("t:ref ") {
            let k: usize = attr(element, "index").parse().unwrap();
            let before: usize = sets.iter().map(|s| s.1).sum();
            assert_eq!(k, before, "triangle sets list the triangles in order");
            sets.last_mut().unwrap().1 += 1;
        }
    }
    (tris, vertices.len(), sets, head)
}

/// Largest coordinate difference between two triangle lists of the same length.
fn max_diff(a: &[Tri], b: &[Tri]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(s, t)| (0..3).flat_map(move |v| (0..3).map(move |c| (s[v][c] - t[v][c]).abs())))
        .fold(0.0, f64::max)
}

/// Σ (a · (b × c)) / 6: the signed volume enclosed (positive for outward winding).
fn signed_volume(tris: &[Tri]) -> f64 {
    tris.iter()
        .map(|[a, b, c]| {
            let bc = [
                b[1] * c[2] - b[2] * c[1],
                b[2] * c[0] - b[0] * c[2],
                b[0] * c[1] - b[1] * c[0],
            ];
            (a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2]) / 6.0
        })
        .sum()
}

fn ras(p: [f64; 3]) -> [f64; 3] {
    [-p[0], -p[1], p[2]]
}

#[test]
fn obj_ply_and_3mf_hold_the_stl_triangles_with_shared_vertices() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("lps");
    let summary = run(&out, CoordinateSystem::Lps);
    let surfaces = &summary.written.surfaces;
    let total: usize = surfaces.iter().map(|s| s.triangles).sum();
    assert!(total > 1000, "{total} triangles");

    let stl = read_stl(&out.join("mesh.stl"));
    let (objects, obj, comments) = read_obj(&out.join("mesh.obj"));
    let (header, ply_vertices, ply) = read_ply(&out.join("mesh.ply"));
    assert_eq!((stl.len(), obj.len(), ply.len()), (total, total, total));
    // OBJ and PLY are exact (f64); the STL is f32: the same triangles, same vertex order.
    assert_eq!(obj, ply, "OBJ and PLY carry the same f64 triangles");
    let scale = stl
        .iter()
        .flatten()
        .flatten()
        .fold(1.0f64, |m, c| m.max(c.abs()));
    let d = max_diff(&obj, &stl);
    assert!(d <= scale * f32::EPSILON as f64, "OBJ vs STL: {d} mm");
    // Winding kept: the enclosed volume agrees (and is positive: outward normals).
    let (v_obj, v_stl) = (signed_volume(&obj), signed_volume(&stl));
    assert!(
        v_obj > 0.0 && (v_obj - v_stl).abs() < 1e-4 * v_obj,
        "{v_obj} vs {v_stl}"
    );

    // One object per surface, named as in the report, in region order.
    let want: Vec<String> = surfaces
        .iter()
        .filter(|s| s.triangles > 0)
        .map(|s| format!("surface_{}", s.id))
        .collect();
    assert_eq!(objects, want);
    // Vertices are shared: a closed-in-u grid has about half as many vertices as triangles.
    assert!(
        ply_vertices < total * 6 / 10,
        "{ply_vertices} vertices for {total} triangles"
    );
    let obj_vertices = std::fs::read_to_string(out.join("mesh.obj"))
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("v "))
        .count();
    assert_eq!(obj_vertices, ply_vertices);
    for text in [&comments, &header] {
        assert!(
            text.contains("units: mm") && text.contains("coordinates: patient LPS"),
            "{text}"
        );
    }
    for s in surfaces.iter().filter(|s| s.triangles > 0) {
        assert!(header.contains(&format!("comment surface {} faces ", s.id)));
    }
    let names: Vec<&str> = summary
        .written
        .files
        .iter()
        .map(|f| f.name.as_str())
        .collect();
    for n in ["mesh.stl", "mesh.obj", "mesh.ply", "mesh.3mf"] {
        assert!(names.contains(&n), "{names:?}");
    }
    // 3MF: the PLY's triangles bit for bit (shortest round-trip decimals), its shared
    // vertices, one triangle set per surface, millimetres and the coordinate system.
    let (three_mf, three_mf_vertices, sets, model_head) = read_3mf(&out.join("mesh.3mf"));
    assert!(three_mf == ply, "3MF and PLY carry the same f64 triangles");
    assert_eq!(three_mf_vertices, ply_vertices);
    let counted: Vec<(String, usize)> = surfaces
        .iter()
        .filter(|s| s.triangles > 0)
        .map(|s| (format!("surface_{}", s.id), s.triangles))
        .collect();
    assert_eq!(sets, counted);
    assert!(
        model_head.contains("unit=\"millimeter\"")
            && model_head.contains("coordinates: patient LPS"),
        "{model_head}"
    );
    // No scratch file of the PLY and 3MF writers is left behind.
    let mut left: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(
        left,
        [
            "mesh.3mf",
            "mesh.obj",
            "mesh.ply",
            "mesh.stl",
            "samples.json",
            "surfaces.igs",
            "surfaces.step"
        ]
    );
}

/// `CARTESIAN_POINT` coordinates of a STEP file, in entity order.
fn step_points(path: &Path) -> Vec<[f64; 3]> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let i = l.find("CARTESIAN_POINT('',(")? + "CARTESIAN_POINT('',(".len();
            let j = i + l[i..].find(')')?;
            let c: Vec<f64> = l[i..j].split(',').map(|x| x.parse().unwrap()).collect();
            Some([c[0], c[1], c[2]])
        })
        .collect()
}

#[test]
fn ras_negates_x_and_y_in_every_output_and_keeps_the_winding() {
    let tmp = tempfile::tempdir().unwrap();
    let (lps_dir, ras_dir) = (tmp.path().join("lps"), tmp.path().join("ras"));
    let lps = run(&lps_dir, CoordinateSystem::Lps);
    let ras_run = run(&ras_dir, CoordinateSystem::Ras);
    // Fit results do not depend on the output system.
    for (a, b) in lps.written.surfaces.iter().zip(&ras_run.written.surfaces) {
        assert_eq!(
            (a.max_error_mm, a.control_points, a.triangles),
            (b.max_error_mm, b.control_points, b.triangles)
        );
    }

    // Meshes: the same triangles, x and y negated exactly, vertex order (winding) unchanged.
    let stl_l = read_stl(&lps_dir.join("mesh.stl"));
    let stl_r = read_stl(&ras_dir.join("mesh.stl"));
    let (_, obj_l, _) = read_obj(&lps_dir.join("mesh.obj"));
    let (_, obj_r, comments) = read_obj(&ras_dir.join("mesh.obj"));
    let (_, _, ply_l) = read_ply(&lps_dir.join("mesh.ply"));
    let (header, _, ply_r) = read_ply(&ras_dir.join("mesh.ply"));
    for (l, r) in [(&stl_l, &stl_r), (&obj_l, &obj_r), (&ply_l, &ply_r)] {
        assert_eq!(l.len(), r.len());
        let flipped: Vec<Tri> = l.iter().map(|t| t.map(ras)).collect();
        assert_eq!(&flipped, r);
    }
    // A rotation (180° about z) keeps the signed volume; a reflection would negate it.
    let (v_l, v_r) = (signed_volume(&ply_l), signed_volume(&ply_r));
    assert!(
        v_l > 0.0 && (v_l - v_r).abs() <= 1e-9 * v_l,
        "{v_l} vs {v_r}"
    );
    // The STL's stored normals turn with the triangles: (nx, ny, nz) → (−nx, −ny, nz).
    let raw_l = std::fs::read(lps_dir.join("mesh.stl")).unwrap();
    let raw_r = std::fs::read(ras_dir.join("mesh.stl")).unwrap();
    let normal = |b: &[u8], t: usize| -> [f32; 3] {
        let o = 84 + 50 * t;
        std::array::from_fn(|k| f32::from_le_bytes(b[o + 4 * k..o + 4 * k + 4].try_into().unwrap()))
    };
    for t in (0..stl_l.len()).step_by(97) {
        let (nl, nr) = (normal(&raw_l, t), normal(&raw_r, t));
        assert_eq!([-nl[0], -nl[1], nl[2]], nr, "triangle {t}");
    }
    assert!(String::from_utf8_lossy(&raw_r[..80]).starts_with("bskin mesh, patient RAS mm"));
    assert!(String::from_utf8_lossy(&raw_l[..80]).starts_with("bskin mesh, patient LPS mm"));
    assert!(comments.contains("coordinates: patient RAS") && header.contains("patient RAS"));

    // STEP: every point (control points, curve points, the placement origin) negated in x, y.
    let (pl, pr) = (
        step_points(&lps_dir.join("surfaces.step")),
        step_points(&ras_dir.join("surfaces.step")),
    );
    assert!(pl.len() > 100);
    assert_eq!(pl.iter().map(|&p| ras(p)).collect::<Vec<_>>(), pr);
    let step_r = std::fs::read_to_string(ras_dir.join("surfaces.step")).unwrap();
    assert!(step_r.contains("patient RAS coordinates"));
    let iges_r = std::fs::read_to_string(ras_dir.join("surfaces.igs")).unwrap();
    assert!(iges_r.lines().next().unwrap().contains("patient RAS"));

    // samples.json: same (u, v), the point negated in x and y.
    let samples = |d: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(d.join("samples.json")).unwrap()).unwrap()
    };
    let (sl, sr) = (samples(&lps_dir), samples(&ras_dir));
    assert_eq!(
        (sl["coordinates"].as_str(), sr["coordinates"].as_str()),
        (Some("LPS"), Some("RAS"))
    );
    let n = sl["surfaces"].as_array().unwrap().len();
    assert_eq!(n, 3);
    for k in 0..n {
        let a = sl["surfaces"][k]["points"].as_array().unwrap();
        let b = sr["surfaces"][k]["points"].as_array().unwrap();
        assert_eq!(a.len(), b.len());
        for (p, q) in a.iter().zip(b) {
            let p: Vec<f64> = p
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            let q: Vec<f64> = q
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            assert_eq!(vec![p[0], p[1], -p[2], -p[3], p[4]], q);
        }
    }
}
