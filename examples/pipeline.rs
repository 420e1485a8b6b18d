//! Run a pipeline from code: load a pipeline file, plan it, run it with a progress callback and
//! read the run report. The library calls behind `fleetdyn run`.
//!
//! ```text
//! cargo run --release --example pipeline                    # pipelines/nightly.toml
//! cargo run --release --example pipeline -- PIPELINE.toml
//! ```
//!
//! A pipeline file's relative paths (inputs, vehicle files, output folder) resolve against the
//! file's own folder. The dataset goes to `out/examples/pipeline/` (relative to the current
//! directory) instead of the file's `output_dir`. Run it twice: the second run
//! reuses every drive whose input and configuration are unchanged.

use fleetdyn::pipeline::run::{run_plan, DriveOutcome, DriveStatus, RunOptions};
use fleetdyn::pipeline::spec::PipelineSpec;
use std::error::Error;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

fn main() -> Result<(), Box<dyn Error>> {
    let file = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("pipelines/nightly.toml"), PathBuf::from);

    // 1. Load the file. `PipelineSpec` is the file as written; it can also be parsed from text
    //    with `PipelineSpec::parse` and changed in code before planning, as here.
    let mut spec = PipelineSpec::load(&file)?;
    spec.max_drives_in_flight = Some(2); // at most two drives held in memory at once

    // 2. Plan: every problem of the configuration (unknown stages, missing vehicle files,
    //    inputs that match nothing, out-of-range settings) is found here, before any drive is
    //    read, and reported together in one error.
    let plan = spec.plan(&file.display().to_string(), None)?;
    let stages: Vec<&str> = plan.stages.iter().map(|s| s.name()).collect();
    let tables: Vec<&str> = plan.tables.iter().map(|t| t.name()).collect();
    println!(
        "pipeline {} (model version {}): {} drives",
        plan.spec.name,
        plan.spec.model_version,
        plan.inputs.len()
    );
    println!("  stages {}", stages.join(" > "));
    println!("  tables {}", tables.join(", "));

    // 3. Run. Drives run in parallel on `jobs` threads; the callback sees each drive's outcome
    //    as it completes, from any worker thread, so it only uses thread-safe state.
    let opts = RunOptions {
        out_root: Path::new("out/examples/pipeline").to_path_buf(),
        jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
        shard: None,
        force: false,
    };
    let done = AtomicUsize::new(0);
    let total = plan.inputs.len();
    let progress = |o: &DriveOutcome| {
        let n = done.fetch_add(1, Ordering::Relaxed) + 1;
        let status = match o.status {
            DriveStatus::Ok => "ok",
            DriveStatus::Reused => "reused",
            DriveStatus::Failed => "FAILED",
        };
        eprintln!(
            "  [{n}/{total}] {status:<6} {} ({:.2} s)",
            o.drive_id, o.elapsed_s
        );
    };
    let report = run_plan(&plan, &opts, &progress)?;

    // 4. The run report: counts, and per drive (in input order) its stages and metrics. A drive
    //    that fails is not an error of the run: it is in the report, with its stage and message.
    println!(
        "{} processed, {} reused, {} failed in {:.2} s with {} jobs",
        report.ok, report.reused, report.failed, report.elapsed_s, report.jobs
    );
    for d in &report.drives {
        let Some(r) = &d.record else {
            let stage = d.failed_stage.unwrap_or("?");
            println!(
                "  {:<16} failed at {stage}: {}",
                d.drive_id,
                d.error.as_deref().unwrap_or("")
            );
            continue;
        };
        let m = &r.metrics;
        let skipped: Vec<&str> = r
            .stages
            .iter()
            .filter(|s| s.status == "skipped")
            .map(|s| s.stage.as_str())
            .collect();
        let fmt = |v: Option<f64>, unit: &str| v.map_or("-".into(), |v| format!("{v:.1}{unit}"));
        println!(
            "  {:<16} {:<12} {:>7} km, speed fit {:>6}, rear bellow fit {:>6}, skipped [{}]",
            r.drive_id,
            r.vehicle_id,
            fmt(m.distance_m.map(|x| x / 1000.0), ""),
            fmt(m.vehicle_speed_fit_percent, " %"),
            fmt(m.bellow_pressure_fit_percent[1], " %"),
            skipped.join(", ")
        );
    }
    let summary = Path::new(&report.report_dir).join("summary.md");
    println!(
        "dataset in {}, report {}",
        report.output_dir,
        summary.display()
    );
    Ok(())
}
