//! Running a validated [`Plan`] over its drives: in parallel, memory bounded, failures isolated,
//! outputs atomic and idempotent.
//!
//! **Parallelism.** A rayon pool of `jobs` threads; at most `max_drives_in_flight` drives
//! (default `jobs`) are held in memory at once — each in-flight slot takes the next input when
//! its drive is done. Within a drive the shuffle and axle simulations run side by side
//! (`rayon::join`). Results do not depend on the number of threads or the order drives finish:
//! every output is a function of its input and the configuration alone, and reports list drives
//! in input order.
//!
//! **Drives.** Each input gives one drive, or one per segment when its recording is split at
//! logger pauses ([`crate::ingest::segment`]); each drive runs on its own
//! ([`super::drive_job`]): failures isolated, outputs reused when up to date. Reports list drives
//! in input order, an input's segments in time order.
//!
//! **Sharding.** `--shard i/N` keeps the inputs whose path hashes to `i` modulo `N` (SHA-256 of
//! the path as listed): stable when other files come or go, the same in every process.

use super::dataset::{escape, Dataset};
pub use super::drive_job::UNKNOWN_VEHICLE;
use super::drive_job::{process, Ctx, InputOutcome};
pub use super::drive_tables::summary_columns;
pub use super::record::{
    DriveMetrics, DriveOutcome, DriveRecord, DriveStatus, RunError, RunReport, Shard, SkippedInput,
    StageNote,
};
use super::spec::Plan;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// How to run a plan.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Output root.
    pub out_root: PathBuf,
    /// Worker threads.
    pub jobs: usize,
    /// Only this shard's inputs.
    pub shard: Option<Shard>,
    /// Recompute drives whose outputs are up to date.
    pub force: bool,
}

/// Runs the plan's inputs (this shard's) and writes the run report; `on_drive` sees each
/// outcome as it completes, from any worker thread (progress output).
///
/// # Errors
/// [`RunError`] only for an unwritable output root, the pool and the report itself; drive
/// failures are in the report.
pub fn run_plan(
    plan: &Plan,
    opts: &RunOptions,
    on_drive: &(dyn Fn(&DriveOutcome) + Sync),
) -> Result<RunReport, RunError> {
    let t0 = Instant::now();
    let items: Vec<&super::inputs::InputItem> = plan
        .inputs
        .iter()
        .filter(|it| opts.shard.is_none_or(|s| s.owns(&it.path)))
        .collect();
    let jobs = opts.jobs.max(1);
    let in_flight = plan
        .spec
        .max_drives_in_flight
        .unwrap_or(jobs)
        .min(jobs)
        .clamp(1, items.len().max(1));
    let ctx = Ctx {
        plan,
        ds: Dataset {
            root: opts.out_root.clone(),
            model_version: plan.spec.model_version.clone(),
        },
        force: opts.force,
        claims: Mutex::new(HashMap::new()),
    };
    ctx.ds
        .check_writable()
        .map_err(|source| RunError::OutputFolder {
            path: opts.out_root.clone(),
            source,
        })?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| RunError::Pool(e.to_string()))?;
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<InputOutcome>>> =
        Mutex::new((0..items.len()).map(|_| None).collect());
    pool.scope(|s| {
        for _ in 0..in_flight {
            s.spawn(|_| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(item) = items.get(i) else {
                    break;
                };
                let o = process(&ctx, i, item);
                for d in &o.drives {
                    on_drive(d);
                }
                results.lock().unwrap_or_else(|p| p.into_inner())[i] = Some(o);
            });
        }
    });
    let mut drives: Vec<DriveOutcome> = Vec::new();
    let mut skipped_segments = Vec::new();
    for (o, item) in results
        .into_inner()
        .unwrap_or_else(|p| p.into_inner())
        .into_iter()
        .zip(&items)
    {
        let o = o.expect("every input processed");
        drives.extend(o.drives);
        skipped_segments.extend(o.skipped.into_iter().map(|segment| SkippedInput {
            input: item.path.display().to_string(),
            segment,
        }));
    }
    let count = |s: DriveStatus| drives.iter().filter(|d| d.status == s).count();
    let shard = opts.shard.map(|s| (s.index, s.count));
    let report_dir = ctx.ds.report_dir(&plan.spec.name, shard);
    let fleet = match (plan.has(super::spec::PipelineStage::Fleet), shard) {
        (true, None) => Some(super::fleet_stage::run_fleet(&ctx.ds, plan, &report_dir)?),
        _ => None,
    };
    let report = RunReport {
        pipeline: plan.spec.name.clone(),
        pipeline_file: plan.file.clone(),
        model_version: plan.spec.model_version.clone(),
        fleetdyn_version: env!("CARGO_PKG_VERSION"),
        shard: opts.shard,
        jobs,
        max_drives_in_flight: in_flight,
        inputs_total: plan.inputs.len(),
        ok: count(DriveStatus::Ok),
        reused: count(DriveStatus::Reused),
        failed: count(DriveStatus::Failed),
        skipped_segments,
        elapsed_s: t0.elapsed().as_secs_f64(),
        output_dir: opts.out_root.display().to_string(),
        report_dir: report_dir.display().to_string(),
        drives,
        fleet,
    };
    super::run_report::write_run_report(&report_dir, plan, &report)?;
    Ok(report)
}

/// Escaped file name of a drive's outputs (`<drive_id>.parquet`).
pub fn output_file_name(drive_id: &str) -> String {
    format!("{}.parquet", escape(drive_id))
}
