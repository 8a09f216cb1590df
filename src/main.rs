//! The `bskin` command: parses arguments, runs the library, reports. Exit codes are in
//! `bskin::exit_codes` and the README.

mod cli;

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};

use bskin::config::{ContoursConfig, CoordinateSystem, OutputOptions, PipelineOptions, RunConfig};
use bskin::dicom::{self, Series};
use bskin::exit_codes::ExitCode;
use bskin::geometry::contours::{ContourOptions, Threshold};
use bskin::io::atomic::Output;
use bskin::io::ndjson::{NdjsonReader, NdjsonWriter, SeriesRecord};
use bskin::io::report::{InputReport, Report, SliceSpacing, Timings};
use bskin::phantom::{self, PhantomSpec, Shape};
use bskin::pipeline::RunInput;
use bskin::stages::s8_write;
use bskin::stages::Control;
use bskin::{pipeline, Error, Result, SeriesSummary};
use cli::{Cli, Command, ContoursArgs, InfoArgs, PhantomArgs, RunArgs, SegmentationArgs};

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose, cli.quiet);
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
        {
            eprintln!("bskin: cannot set {n} threads: {e}");
            return ExitCode::Usage.into();
        }
    }
    let interrupted = Arc::new(AtomicBool::new(false));
    {
        let flag = interrupted.clone();
        // Ctrl-C sets the pipeline's cancel flag: stages stop, outputs are not committed.
        let _ = ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::SeqCst));
    }
    let ctl = Control::with_flag(interrupted);
    let result = match cli.command {
        Command::Run(args) => {
            // A failed run leaves no output directory it made itself (remove_dir takes only
            // an empty one: nothing the user had is touched).
            let out = args.output.clone();
            let made = !out.exists();
            let r = run(args, cli.quiet, &ctl);
            if r.is_err() && made {
                let _ = std::fs::remove_dir(&out);
            }
            r
        }
        Command::Contours(args) => contours(args, cli.quiet, &ctl),
        Command::Info(args) => info(args),
        Command::Phantom(args) => make_phantom(args, cli.quiet),
    };
    match result {
        Ok(()) => ExitCode::Success.into(),
        Err(e) => {
            let code = ExitCode::of(&e);
            if code != ExitCode::Success {
                eprintln!("bskin: error: {}", chain(&e));
            }
            code.into()
        }
    }
}

/// The error and its causes, one line.
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut src = e.source();
    while let Some(c) = src {
        let t = c.to_string();
        if !s.contains(&t) {
            s.push_str(": ");
            s.push_str(&t);
        }
        src = c.source();
    }
    s
}

fn init_logging(verbose: u8, quiet: bool) {
    let level = match (quiet, verbose) {
        (true, _) => "error",
        (false, 0) => "warn",
        (false, 1) => "info",
        _ => "debug",
    };
    // The stages' warnings stream only from `-v` on: by default the summary lists each kind
    // once, so a run fits one screen whatever the series.
    let warnings = if verbose == 0 { "off" } else { level };
    let directives = format!(
        "bskin={level},{}={warnings}",
        bskin::stages::WARNINGS_TARGET
    );
    let filter = tracing_subscriber::EnvFilter::try_from_env("BSKIN_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(directives));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}

fn contour_options(a: &SegmentationArgs) -> Result<ContourOptions> {
    let threshold = match (a.threshold, a.range) {
        (_, Some((lo, hi))) => Threshold::Range(lo, hi),
        (Some(t), None) => Threshold::Above(t),
        (None, None) => Threshold::Above(300.0),
    };
    if let Threshold::Above(t) = threshold {
        if !t.is_finite() {
            return Err(Error::usage(
                "--threshold",
                format!("{t} is not a finite HU value"),
            ));
        }
    }
    for (name, v) in [
        ("--min-area", a.min_area),
        ("--compress-tol", a.compress_tol),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::usage(
                name,
                format!("must be a finite number ≥ 0, got {v}"),
            ));
        }
    }
    Ok(ContourOptions {
        threshold,
        min_area_mm2: a.min_area,
        fill_holes: a.fill_holes,
        compress_tol_mm: a.compress_tol,
    })
}

/// Scan `dir`, report what was skipped, and pick the series to process.
fn open_series(dir: &Path, selector: Option<&str>, quiet: bool) -> Result<Series> {
    let scan = dicom::scan(dir)?;
    if !quiet {
        if scan.not_dicom > 0 {
            eprintln!(
                "bskin: note: skipped {} file(s) that are not DICOM",
                scan.not_dicom
            );
        }
        for (p, why) in &scan.unreadable {
            eprintln!("bskin: note: skipped {}: {why}", p.display());
        }
        for n in &scan.notes {
            eprintln!("bskin: note: {n}");
        }
    }
    let series = dicom::select_series(&scan, selector, dir)?.clone();
    if !quiet {
        for p in &series.problems {
            eprintln!("bskin: warning: series {}: {p}", series.label());
        }
    }
    Ok(series)
}

fn summary_of(series: &Series, dir: &Path) -> SeriesSummary {
    SeriesSummary {
        uid: series.uid.clone().unwrap_or_else(|| series.key.clone()),
        number: series.number,
        description: series.description.clone(),
        modality: series.modality.clone(),
        slices: series.slices.len(),
        rows: series.rows,
        cols: series.cols,
        pixel_spacing: series.spacing,
        source: dir.display().to_string(),
    }
}

fn progress(total: usize, quiet: bool, what: &str) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(total as u64);
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} slices, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

fn contours(args: ContoursArgs, quiet: bool, ctl: &Control) -> Result<()> {
    let started = Instant::now();
    let opts = contour_options(&args.segmentation)?;
    let dir = &args.series.input;
    let series = open_series(dir, args.series.series.as_deref(), quiet)?;
    let config = ContoursConfig {
        contour: opts.clone(),
        pipeline: PipelineOptions {
            channel_depth: args.pipeline.channel_depth.max(1),
            ..Default::default()
        },
    };
    let header = SeriesRecord::new(&summary_of(&series, dir), &opts);
    let output = Output::open(&args.output)?;
    let to_stdout = matches!(output, Output::Stdout(_));
    let write_err = |e: std::io::Error| {
        if to_stdout {
            Error::io("stdout", e)
        } else {
            Error::Output {
                path: args.output.clone(),
                source: e,
            }
        }
    };
    let mut writer = NdjsonWriter::new(output, &header).map_err(write_err)?;
    let pb = progress(series.slices.len(), quiet, "contours");
    let summary = pipeline::run_contours(&series, &config, ctl, &mut |compiled| {
        pb.inc(1);
        writer.write_section(&compiled.section).map_err(write_err)
    });
    pb.finish_and_clear();
    let summary = summary?;
    let output = writer.finish().map_err(write_err)?;
    // Only a complete stream reaches its final name.
    output.commit()?;
    if !quiet {
        eprintln!(
            "bskin: {} slices ({} empty), {} contours ({} holes), {} points ({} before compression), {} small contours dropped, {:.2} s",
            summary.sections,
            summary.empty_sections,
            summary.contours,
            summary.holes,
            summary.points_compressed,
            summary.points_raw,
            summary.dropped_small,
            started.elapsed().as_secs_f64()
        );
        if summary.contours == 0 {
            eprintln!(
                "bskin: note: the segmentation is empty: no region {} in any slice",
                inside(&opts.threshold)
            );
        }
    }
    Ok(())
}

/// What the threshold takes as inside, for messages: "at or above 300".
fn inside(threshold: &Threshold) -> String {
    match *threshold {
        Threshold::Above(t) => format!("at or above {t}"),
        Threshold::Range(lo, hi) => format!("from {lo} to {hi}"),
    }
}

fn run(args: RunArgs, quiet: bool, ctl: &Control) -> Result<()> {
    let started = Instant::now();
    let opts = contour_options(&args.segmentation)?;
    if !(args.tolerance.is_finite() && args.tolerance > 0.0) {
        return Err(Error::usage(
            "--tolerance",
            format!("must be a positive number of mm, got {}", args.tolerance),
        ));
    }
    let mut config = RunConfig::with_tolerance(args.tolerance);
    config.contour = opts.clone();
    config.outputs =
        OutputOptions::from_formats(&args.formats).map_err(|e| Error::usage("--formats", e))?;
    config.outputs.samples = args.write_samples;
    config.outputs.check_crossings = !args.no_crossing_check;
    if args.ras {
        config.outputs.coordinates = CoordinateSystem::Ras;
    }
    config.pipeline.channel_depth = args.pipeline.channel_depth.max(1);
    if let Some(c) = args.cell {
        if !(c.is_finite() && c > 0.0) {
            return Err(Error::usage(
                "--cell",
                format!("must be a positive number of mm, got {c}"),
            ));
        }
        config.cell_mm = c;
    }
    if !(args.chordal.is_finite() && args.chordal > 0.0) {
        return Err(Error::usage(
            "--chordal",
            format!(
                "must be a positive fraction of the tolerance, got {}",
                args.chordal
            ),
        ));
    }
    config.mesh_chordal = args.chordal;
    if args.max_curves < 2 {
        return Err(Error::usage(
            "--max-curves",
            format!("must be at least 2, got {}", args.max_curves),
        ));
    }
    config.max_curves = args.max_curves;
    let out = &args.output;
    std::fs::create_dir_all(out).map_err(|e| Error::Output {
        path: out.clone(),
        source: e,
    })?;

    let input_path = &args.series.input;
    let from_stdin = input_path.as_os_str() == "-";
    let series;
    let mut threshold = Some(opts.threshold.into());
    let (input, summary) = if from_stdin {
        let reader = NdjsonReader::new(std::io::BufReader::new(std::io::stdin()))?;
        threshold = reader.header.as_ref().and_then(|h| h.threshold.clone());
        let summary = reader
            .header
            .as_ref()
            .map(|h| h.series.clone())
            .unwrap_or_else(|| SeriesSummary {
                source: "-".into(),
                ..Default::default()
            });
        (RunInput::Sections(Box::new(reader)), summary)
    } else {
        series = open_series(input_path, args.series.series.as_deref(), quiet)?;
        if let Some(t) = series.slices.first().and_then(|s| s.thickness) {
            config.fallback_spacing_mm = t;
        }
        (RunInput::Images(&series), summary_of(&series, input_path))
    };
    let pb = progress(summary.slices, quiet, "run");
    let result = pipeline::run_surfaces(input, &config, out, ctl, &|_| pb.inc(1));
    pb.finish_and_clear();
    let result = result.map_err(|e| match e {
        Error::EmptySegmentation { sections, dropped } => Error::BadInput {
            path: input_path.clone(),
            message: if from_stdin {
                format!(
                    "the contour stream is empty: no contour in any of its {sections} \
                     slices; nothing was written"
                )
            } else {
                format!(
                    "the segmentation is empty: no region {} in any of its {sections} slices \
                     ({dropped} smaller than the minimum area dropped); nothing was written \
                     (--threshold, --min-area)",
                    inside(&opts.threshold)
                )
            },
        },
        e => e,
    })?;

    let surfaces = result.written.surfaces;
    // A crossing or folding mesh first: the summary shows the first few warnings only.
    let crossings = result.written.crossings;
    let warnings: Vec<String> = crossings
        .as_ref()
        .and_then(bskin::io::report::crossing_warning)
        .into_iter()
        .chain(bskin::io::report::fold_warning(&surfaces))
        .chain(ctl.warnings())
        .collect();
    let input_points_total: usize = surfaces.iter().map(|s| s.input_points).sum();
    let control_points_total: usize = surfaces
        .iter()
        .map(|s| s.control_points[0] * s.control_points[1])
        .sum();
    let max_error_mm = surfaces.iter().map(|s| s.max_error_mm).fold(0.0, f64::max);
    let report = Report {
        format: bskin::io::report::FORMAT,
        version: bskin::io::report::VERSION,
        input: InputReport {
            slices: result.input.sections,
            empty_slices: result.input.empty_sections,
            contours: result.input.contours,
            holes: result.input.holes,
            points_raw: result.input.points_raw,
            points_compressed: result.input.points_compressed,
            slice_spacing_mm: result
                .input
                .slice_spacing()
                .map(|(min, mean, max)| SliceSpacing { min, mean, max }),
            threshold,
            min_area_mm2: opts.min_area_mm2,
            fill_holes: opts.fill_holes,
            compress_tol_mm: opts.compress_tol_mm,
        },
        series: summary,
        tolerance_mm: config.tolerance_mm,
        units: "mm",
        coordinates: config.outputs.coordinates.name(),
        surfaces_total: surfaces.len(),
        input_points_total,
        control_points_total,
        reduction_ratio: if control_points_total > 0 {
            input_points_total as f64 / control_points_total as f64
        } else {
            0.0
        },
        reduction_ratio_raw: if control_points_total > 0 {
            result.input.points_raw as f64 / control_points_total as f64
        } else {
            0.0
        },
        max_error_mm,
        tolerance_met: surfaces.iter().all(|s| s.tolerance_met),
        mesh: (config.outputs.stl
            || config.outputs.obj
            || config.outputs.ply
            || config.outputs.three_mf)
            .then(|| bskin::io::report::MeshReport {
                chordal_fraction: config.mesh_chordal,
                chordal_mm: config.mesh_chordal * config.tolerance_mm,
                triangles: surfaces.iter().map(|s| s.triangles).sum(),
                seal_triangles: surfaces.iter().map(|s| s.seal_triangles).sum(),
                folded_surfaces: surfaces.iter().filter(|s| s.folded_rows > 0).count(),
                folded_rows: surfaces.iter().map(|s| s.folded_rows).sum(),
                row_loops_cut: surfaces.iter().map(|s| s.row_loops_cut).sum(),
                row_cusps_cut: surfaces.iter().map(|s| s.row_cusps_cut).sum(),
                crossing_faces: crossings.as_ref().map(|c| c.crossing_faces),
                crossings: crossings.map_or_else(Vec::new, |c| c.pairs),
            }),
        surfaces,
        files: result.written.files,
        timings: Timings {
            wall_s: started.elapsed().as_secs_f64(),
            stages: result.stages,
        },
        peak_rss_mb: bskin::io::report::peak_rss_mb(),
        warnings,
        notes: ctl.notes(),
    };
    let report_path = s8_write::write_report(out, &report)?;
    if !quiet {
        let dir = report_path.parent().unwrap_or(out).display().to_string();
        eprint!("{}", report.summary(&dir));
    }
    Ok(())
}

fn info(args: InfoArgs) -> Result<()> {
    let scan = dicom::scan(&args.input)?;
    let mut out = std::io::stdout().lock();
    let text = if args.json {
        format!("{:#}\n", bskin::io::listing::scan_json(&scan))
    } else {
        bskin::io::listing::scan_text(&scan)
    };
    out.write_all(text.as_bytes())
        .map_err(|e| Error::io("stdout", e))?;
    Ok(())
}

fn make_phantom(args: PhantomArgs, quiet: bool) -> Result<()> {
    let shape = Shape::from_name(&args.shape).ok_or_else(|| {
        Error::usage(
            "<shape>",
            format!(
                "unknown shape {:?}; choose one of: {}",
                args.shape,
                Shape::NAMES.join(", ")
            ),
        )
    })?;
    let spec = PhantomSpec {
        shape,
        rows: args.size,
        cols: args.size,
        pixel_spacing: [args.pixel, args.pixel],
        slices: args.slices,
        slice_spacing: args.slice_spacing,
        tilt_deg: args.tilt,
        uneven: args.uneven,
        noise_sd_hu: args.noise,
        seed: args.seed,
        ..Default::default()
    };
    let volume = phantom::generate(&spec)?;
    let options = dicom::WriteOptions::for_phantom(&spec);
    let paths = dicom::write_ct_series(&args.output, &volume.slices, &options)?;
    if let Some(path) = &args.truth {
        let step = phantom::shapes::VOLUME_STEP_MM;
        let (volume_mm3, method) = match shape.exact_volume() {
            Some(v) => (v, "closed form".to_string()),
            None => (
                shape.volume(step),
                format!("rays along z on a {step} mm grid, sphere tracing + bisection"),
            ),
        };
        let json = serde_json::json!({
            "shape": shape.name(),
            "volume_mm3": volume_mm3,
            "volume_method": method,
        });
        let mut f = bskin::io::atomic::AtomicFile::create(path)?;
        f.write_all(format!("{json:#}\n").as_bytes())
            .map_err(|e| Error::io(path, e))?;
        f.commit()?;
    }
    if !quiet {
        eprintln!(
            "bskin: wrote {} slices of {} to {}",
            paths.len(),
            shape.name(),
            args.output.display()
        );
    }
    Ok(())
}
