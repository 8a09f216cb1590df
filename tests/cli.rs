//! The `bskin` binary end to end: exit codes, error messages that name the file, outputs that
//! never exist half-written, and bytes that do not depend on the thread count.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn bskin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bskin"))
        .args(args)
        .output()
        .expect("run bskin")
}

/// `bskin ARGS` with `input` on its standard input.
fn bskin_with_stdin(args: &[&str], input: &[u8]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_bskin"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run bskin");
    {
        use std::io::Write;
        child.stdin.take().unwrap().write_all(input).unwrap();
    }
    child.wait_with_output().unwrap()
}

fn testdata() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/tube-split")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn missing_directory_is_an_input_error_naming_it() {
    let o = bskin(&["run", "/nonexistent/series", "-o", "/tmp/bskin-never"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("/nonexistent/series"), "{}", stderr(&o));
}

#[test]
fn a_threshold_above_everything_is_an_input_error_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let dir = testdata();
    let o = bskin(&[
        "run",
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--threshold",
        "100000",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains(dir.to_str().unwrap())
            && e.contains("segmentation is empty")
            && e.contains("at or above 100000"),
        "{e}"
    );
    // Not even the output directory it made.
    assert!(!out.exists());
    // An output directory the user made stays, empty.
    std::fs::create_dir(&out).unwrap();
    let o = bskin(&[
        "run",
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--threshold",
        "100000",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0);
}

#[test]
fn directory_without_dicom_says_what_it_found() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("notes.txt"), "not an image").unwrap();
    std::fs::write(tmp.path().join("data.bin"), [0u8; 300]).unwrap();
    let o = bskin(&["contours", tmp.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("2 file(s) that are not DICOM") && e.contains(tmp.path().to_str().unwrap()),
        "{e}"
    );
}

#[test]
fn bad_arguments_are_usage_errors() {
    assert_eq!(bskin(&["run"]).status.code(), Some(2));
    assert_eq!(
        bskin(&["contours", "x", "--range", "5:1"]).status.code(),
        Some(2)
    );
    let o = bskin(&[
        "run",
        testdata().to_str().unwrap(),
        "-o",
        "/tmp/x",
        "--tolerance",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--tolerance"));
}

#[test]
fn unwritable_output_is_exit_3_and_leaves_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let blocker = tmp.path().join("file");
    std::fs::write(&blocker, "").unwrap();
    // A directory cannot be created under a regular file.
    let out = blocker.join("out");
    let o = bskin(&[
        "run",
        testdata().to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let o = bskin(&[
        "contours",
        testdata().to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 1);
}

#[test]
fn closed_stdout_is_not_an_error() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_bskin"))
        .args(["contours", testdata().to_str().unwrap(), "-q"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away at once, like `| head -0`
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0));
}

#[test]
fn contours_and_surfaces_are_identical_whatever_the_thread_count() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = testdata();
    let mut ndjson = Vec::new();
    let mut meshes = Vec::new();
    let mut reports = Vec::new();
    for threads in ["1", "2", "3"] {
        let c = bskin(&[
            "--threads",
            threads,
            "contours",
            dir.to_str().unwrap(),
            "-q",
        ]);
        assert!(c.status.success(), "{}", stderr(&c));
        ndjson.push(c.stdout);
        let out = tmp.path().join(threads);
        let r = bskin(&[
            "--threads",
            threads,
            "run",
            dir.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--formats",
            "stl,obj,ply,step,igs",
            "-q",
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        meshes.push(
            [
                "mesh.stl",
                "mesh.obj",
                "mesh.ply",
                "surfaces.step",
                "surfaces.igs",
            ]
            .map(|f| std::fs::read(out.join(f)).unwrap()),
        );
        let mut report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
        // Timing and memory are measurements of the run, not results (and so is the size of
        // report.json, which holds them).
        report.as_object_mut().unwrap().remove("timings");
        report.as_object_mut().unwrap().remove("peak_rss_mb");
        let files = report["files"].as_array_mut().unwrap();
        assert_eq!(files.pop().unwrap()["name"], "report.json");
        reports.push(report);
    }
    assert!(ndjson[0].len() > 10_000);
    assert!(ndjson.iter().all(|b| b == &ndjson[0]));
    assert!(meshes.iter().all(|b| b == &meshes[0]));
    assert!(reports.iter().all(|r| r == &reports[0]));
    assert_eq!(reports[0]["surfaces_total"], 3);
    assert_eq!(reports[0]["tolerance_met"], true);
}

#[test]
fn info_lists_the_series() {
    let o = bskin(&["info", testdata().to_str().unwrap()]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("bskin phantom tube-split") && text.contains("61"),
        "{text}"
    );
    let o = bskin(&["info", "--json", testdata().to_str().unwrap()]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["series"][0]["slices"], 61);
}

#[test]
fn contours_piped_into_run_give_the_same_surfaces() {
    // `bskin contours DIR | bskin run - -o OUT`: the contour NDJSON is a pipeline input.
    let tmp = tempfile::tempdir().unwrap();
    let c = bskin(&["contours", testdata().to_str().unwrap(), "-q"]);
    assert!(c.status.success());
    let out = tmp.path().join("piped");
    let o = bskin_with_stdin(&["run", "-", "-o", out.to_str().unwrap(), "-q"], &c.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    let piped: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let direct_dir = tmp.path().join("direct");
    let d = bskin(&[
        "run",
        testdata().to_str().unwrap(),
        "-o",
        direct_dir.to_str().unwrap(),
        "-q",
    ]);
    assert!(d.status.success());
    let direct: serde_json::Value =
        serde_json::from_slice(&std::fs::read(direct_dir.join("report.json")).unwrap()).unwrap();
    assert_eq!(piped["surfaces_total"], direct["surfaces_total"]);
    assert_eq!(piped["input"]["contours"], direct["input"]["contours"]);
    assert_eq!(piped["tolerance_met"], true);
    assert_eq!(piped["series"]["uid"], direct["series"]["uid"]);
    // Not just the same counts: the NDJSON loses nothing, so the outputs are the same bytes.
    for file in ["mesh.stl", "surfaces.step", "surfaces.igs"] {
        let (a, b) = (out.join(file), direct_dir.join(file));
        assert!(
            std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
            "{file}: piped and direct runs differ"
        );
    }
}

#[test]
fn truncated_contour_stream_is_an_error_naming_the_line() {
    let c = bskin(&["contours", testdata().to_str().unwrap(), "-q"]);
    let text = String::from_utf8(c.stdout).unwrap();
    let cut = &text[..text.len() / 2];
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = bskin_with_stdin(
        &["run", "-", "-o", out.to_str().unwrap(), "-q"],
        cut.as_bytes(),
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("NDJSON line"), "{}", stderr(&o));
    assert!(!out.join("report.json").exists() && !out.join("mesh.stl").exists());
}

#[test]
fn quiet_prints_nothing_and_the_summary_fits_one_screen() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = testdata();
    let quiet = tmp.path().join("quiet");
    let q = bskin(&[
        "run",
        dir.to_str().unwrap(),
        "-o",
        quiet.to_str().unwrap(),
        "-q",
    ]);
    assert!(q.status.success(), "{}", stderr(&q));
    assert!(q.stderr.is_empty(), "-q printed: {}", stderr(&q));
    assert!(q.stdout.is_empty());
    assert!(quiet.join("report.json").exists());

    let loud = tmp.path().join("loud");
    let o = bskin(&[
        "run",
        dir.to_str().unwrap(),
        "-o",
        loud.to_str().unwrap(),
        "--formats",
        "stl,ply",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
    let e = stderr(&o);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(loud.join("report.json")).unwrap()).unwrap();
    assert!(e.lines().count() <= 12, "{e}");
    for want in [
        format!("{} surfaces", report["surfaces_total"]),
        format!("{} control points", report["control_points_total"]),
        format!(
            "max error {:.4} mm",
            report["max_error_mm"].as_f64().unwrap()
        ),
        "tolerance 0.5 mm met".to_string(),
        "coordinates LPS mm".to_string(),
        "mesh.stl (".to_string(),
        "mesh.ply (".to_string(),
        "report.json".to_string(),
        loud.display().to_string(),
    ] {
        assert!(e.contains(&want), "summary lacks {want:?}:\n{e}");
    }
    assert!(!e.contains("surfaces.step"), "{e}");
    // The sample's split zone is bridged whole at t = ½: a note in the report, not a warning
    // on the screen.
    assert_eq!(report["warnings"], serde_json::json!([]), "{e}");
    let notes = report["notes"].as_array().unwrap();
    assert!(
        notes.len() == 1 && notes[0].as_str().unwrap().contains("dropped 0.0000"),
        "{notes:?}"
    );
    assert!(!e.contains("warning") && e.contains("1 note(s)"), "{e}");
}

#[test]
fn ras_is_recorded_and_unknown_formats_are_usage_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ras");
    let o = bskin(&[
        "run",
        testdata().to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--ras",
        "--formats",
        "obj",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("coordinates RAS mm"), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["coordinates"], "RAS");
    assert_eq!(report["version"], 8);
    assert!(report["notes"].is_array());
    let files: Vec<&str> = report["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["name"].as_str().unwrap())
        .collect();
    assert_eq!(files, ["mesh.obj", "report.json"]);
    // Every file's size is stated, report.json's own included.
    for f in report["files"].as_array().unwrap() {
        let on_disk = std::fs::metadata(out.join(f["name"].as_str().unwrap()))
            .unwrap()
            .len();
        assert_eq!(f["bytes"].as_u64(), Some(on_disk), "{f}");
    }
    // The mesh section: the chordal tolerance it was made with, triangle totals.
    let mesh = &report["mesh"];
    assert_eq!(mesh["chordal_fraction"].as_f64(), Some(0.1));
    let sum = |k: &str| -> u64 {
        report["surfaces"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s[k].as_u64().unwrap())
            .sum()
    };
    assert_eq!(mesh["triangles"].as_u64(), Some(sum("triangles")));
    assert_eq!(mesh["seal_triangles"].as_u64(), Some(sum("seal_triangles")));
    assert_eq!(mesh["folded_rows"].as_u64(), Some(sum("folded_rows")));
    assert_eq!(mesh["row_loops_cut"].as_u64(), Some(sum("row_loops_cut")));
    assert_eq!(mesh["row_cusps_cut"].as_u64(), Some(sum("row_cusps_cut")));
    assert_eq!(mesh["folded_surfaces"], 0);
    // The mesh was searched for faces crossing one another (tests/mesh_watertight.rs compares
    // the count with the whole mesh's): none on this phantom.
    assert_eq!(mesh["crossing_faces"], 0);
    assert_eq!(mesh["crossings"], serde_json::json!([]));
    assert!(!stderr(&o).contains("cross another face"), "{}", stderr(&o));
    assert!(sum("mesh_rows") > 0);
    assert!(sum("triangles") > sum("seal_triangles"));
    assert!(!out.join("mesh.stl").exists());
    let spacing = &report["input"]["slice_spacing_mm"];
    assert!(
        (spacing["mean"].as_f64().unwrap() - 1.5).abs() < 1e-9,
        "{spacing}"
    );

    let o = bskin(&[
        "run",
        testdata().to_str().unwrap(),
        "-o",
        tmp.path().join("x").to_str().unwrap(),
        "--formats",
        "stl,vrml",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("vrml") && stderr(&o).contains("obj, ply"));
}

#[test]
fn piped_contours_report_the_threshold_they_were_made_with_and_a_check_skipped() {
    let c = bskin(&[
        "contours",
        testdata().to_str().unwrap(),
        "-q",
        "--threshold",
        "250",
    ]);
    assert!(c.status.success(), "{}", stderr(&c));
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("piped");
    let args = [
        "run",
        "-",
        "-o",
        out.to_str().unwrap(),
        "-q",
        "--no-crossing-check",
    ];
    let o = bskin_with_stdin(&args, &c.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        report["input"]["threshold"],
        serde_json::json!({"above": 250.0})
    );
    // Not searched: null, not a count of 0.
    assert!(report["mesh"]["crossing_faces"].is_null());
    assert_eq!(report["mesh"]["crossings"], serde_json::json!([]));
}

/// A contour stream of `slices` (each a list of contours, as JSON `{"points", "hole"}`),
/// 2 mm apart, under the header `bskin contours` writes for the test series.
fn contour_stream(slices: &[Vec<serde_json::Value>]) -> Vec<u8> {
    let c = bskin(&["contours", testdata().to_str().unwrap(), "-q"]);
    assert!(c.status.success(), "{}", stderr(&c));
    let first = c.stdout.split(|&b| b == b'\n').next().unwrap();
    let mut header: serde_json::Value = serde_json::from_slice(first).unwrap();
    header["slices"] = serde_json::json!(slices.len());
    header["series"]["slices"] = serde_json::json!(slices.len());
    let mut lines = vec![header.to_string()];
    for (i, contours) in slices.iter().enumerate() {
        let slice = serde_json::json!({"type": "slice", "index": i,
            "origin": [0.0, 0.0, 2.0 * i as f64], "row": [1.0, 0.0, 0.0], "col": [0.0, 1.0, 0.0],
            "contours": contours});
        lines.push(slice.to_string());
    }
    let points: usize = slices
        .iter()
        .flatten()
        .map(|c| c["points"].as_array().unwrap().len())
        .sum();
    let end = serde_json::json!({"type": "end", "slices": slices.len(),
        "contours": slices.iter().map(Vec::len).sum::<usize>(), "points": points});
    lines.push(end.to_string());
    (lines.join("\n") + "\n").into_bytes()
}

/// A counter-clockwise square of half-side `r` centred at (`cx`, 0).
fn square(cx: f64, r: f64) -> serde_json::Value {
    serde_json::json!({"points": [[cx - r, -r], [cx + r, -r], [cx + r, r], [cx - r, r]], "hole": false})
}

/// A square between `middle` slices of two overlapping squares and another square: each
/// middle slice warns that its contours cross.
fn overlapping_squares_stream(middle: usize) -> Vec<u8> {
    let mut slices = vec![vec![square(0.0, 10.0)]];
    slices.extend((0..middle).map(|_| vec![square(-6.0, 8.0), square(6.0, 8.0)]));
    slices.push(vec![square(0.0, 10.0)]);
    contour_stream(&slices)
}

fn report_of(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn warnings_stay_in_the_summary_one_line_per_kind_unless_verbose() {
    let stream = overlapping_squares_stream(5);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("default");
    let o = bskin_with_stdin(&["run", "-", "-o", out.to_str().unwrap()], &stream);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = report_of(&out);
    let warnings: Vec<&str> = report["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    let crossing = |w: &str| w.contains(": contours overlap: their areas add up to 512.000 mm²");
    assert_eq!(
        warnings.iter().filter(|w| crossing(w)).count(),
        5,
        "{warnings:?}"
    );
    let e = stderr(&o);
    // No log lines streamed before the summary: every line is the summary's.
    assert!(e.lines().all(|l| l.starts_with("bskin: ")), "{e}");
    assert!(e.lines().count() <= 14, "{e}");
    let lines: Vec<&str> = e.lines().filter(|l| crossing(l)).collect();
    assert_eq!(lines.len(), 1, "{e}");
    assert!(lines[0].ends_with("(and 4 more like it)"), "{e}");
    // Each kind once, with how many more are like it; the kinds left out are counted.
    let count_after = |line: &str, before: &str| -> usize {
        line.split(before)
            .nth(1)
            .map_or(0, |rest| rest.split(' ').next().unwrap().parse().unwrap())
    };
    let mut accounted = 0;
    for line in e.lines() {
        if line.starts_with("bskin: warning: ") {
            accounted += 1 + count_after(line, "(and ");
        } else if line.starts_with("bskin: … and ") {
            accounted += count_after(line, "… and ");
        }
    }
    assert_eq!(accounted, warnings.len(), "{e}");

    // `-v` streams each warning as it happens.
    let loud = tmp.path().join("verbose");
    let v = bskin_with_stdin(&["run", "-", "-o", loud.to_str().unwrap(), "-v"], &stream);
    assert!(v.status.success(), "{}", stderr(&v));
    let streamed = stderr(&v)
        .lines()
        .filter(|l| l.contains("WARN") && crossing(l))
        .count();
    assert_eq!(streamed, 5, "{}", stderr(&v));
}

#[test]
fn contours_that_cross_are_resolved_into_the_region_they_bound() {
    // Two overlapping squares, and a figure eight: left as given, their surfaces crossed one
    // another (821 and 391 crossing faces); resolved, the mesh is a valid solid.
    let bow =
        serde_json::json!({"points": [[-10.0, -10.0], [10.0, 10.0], [10.0, -10.0], [-10.0, 10.0]]});
    let cases = [
        ("overlap", overlapping_squares_stream(2)),
        (
            "bow",
            contour_stream(&[vec![square(0.0, 10.0)], vec![bow], vec![square(0.0, 10.0)]]),
        ),
    ];
    let tmp = tempfile::tempdir().unwrap();
    for (name, stream) in cases {
        let out = tmp.path().join(name);
        let o = bskin_with_stdin(&["run", "-", "-o", out.to_str().unwrap(), "-q"], &stream);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let report = report_of(&out);
        let warnings = report["warnings"].to_string();
        let said = if name == "bow" {
            "slice 1: contour 0 crosses itself at (0.000, 0.000); its 1 contour(s) replaced by the 2"
        } else {
            "slice 1: contours overlap: their areas add up to 512.000 mm² (outer contours less \
             holes) but they bound 448.000 mm²; its 2 contour(s) replaced by the 1 bounding"
        };
        assert!(warnings.contains(said), "{name}: {warnings}");
        assert_eq!(report["mesh"]["crossing_faces"], 0, "{name}: {warnings}");
        assert_eq!(report["tolerance_met"], true, "{name}");
    }
}
