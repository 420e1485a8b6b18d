//! Running a validated [`Plan`]: every drive through its stages, failures isolated per drive.
//!
//! Per drive, all stages run in memory first; only then are its files written (each atomically),
//! and if any write fails the drive's files already written are removed — a drive has all of its
//! outputs or none. A failed drive is recorded with the stage that failed and its error; the
//! other drives go on. Outputs go to `<output_dir>/<drive_id>/`, and `run_report.json` lists
//! every drive.

use super::spec::Plan;
use super::{ingest_stage, resample_stage, slope_stage};
use crate::io::{AtomicFile, OutputError};
use crate::road::slope_filter::filter_slope;
use crate::schema::Stage;
use crate::signal::distance::resample_to_distance;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What happened to one drive.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct DriveOutcome {
    /// Input file.
    pub input: String,
    /// Drive id (the file stem when ingest failed before reading metadata).
    pub drive_id: String,
    /// `ok` or `failed`.
    pub status: &'static str,
    /// Stage that failed.
    pub failed_stage: Option<&'static str>,
    /// Error message.
    pub error: Option<String>,
    /// Files written, relative to the run's output folder.
    pub outputs: Vec<String>,
    /// Distance travelled, m (when resampled).
    pub distance_m: Option<f64>,
    /// Slope quantisation step found (when filtered).
    pub slope_quantization_step: Option<f64>,
}

/// The whole run.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// Pipeline name.
    pub pipeline: String,
    /// fleetdyn version.
    pub fleetdyn_version: &'static str,
    /// Drives that completed.
    pub ok: usize,
    /// Drives that failed.
    pub failed: usize,
    /// Per drive, in input order.
    pub drives: Vec<DriveOutcome>,
}

fn fail(mut o: DriveOutcome, stage: Stage, e: impl std::fmt::Display) -> DriveOutcome {
    o.status = "failed";
    o.failed_stage = Some(stage.name());
    o.error = Some(e.to_string());
    o
}

/// Runs one drive through the plan's stages.
pub fn run_drive(plan: &Plan, input: &Path, out_root: &Path) -> DriveOutcome {
    let mut o = DriveOutcome {
        input: input.display().to_string(),
        drive_id: input
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        status: "ok",
        failed_stage: None,
        error: None,
        outputs: Vec::new(),
        distance_m: None,
        slope_quantization_step: None,
    };
    let ing = match ingest_stage::run(input, &plan.ingest) {
        Ok(i) => i,
        Err(e) => return fail(o, Stage::Ingest, e),
    };
    o.drive_id = ing.log.meta.drive_id.clone();
    let log = ing.log;
    let dist = if plan.stages.contains(&Stage::Resample) {
        match resample_to_distance(&log, &plan.spec.resample) {
            Ok(d) => {
                o.distance_m = Some(d.map.total_m());
                Some(d)
            }
            Err(e) => return fail(o, Stage::Resample, e),
        }
    } else {
        None
    };
    let slope = match (&dist, plan.stages.contains(&Stage::Slope)) {
        (Some(d), true) => match filter_slope(d, &plan.spec.slope) {
            Ok(f) => {
                o.slope_quantization_step = f.quantization.map(|q| q.step);
                Some(f)
            }
            Err(e) => return fail(o, Stage::Slope, e),
        },
        _ => None,
    };

    let dir = out_root.join(&o.drive_id);
    let fp = &plan.fingerprint;
    let mut written: Vec<PathBuf> = Vec::new();
    let result = (|| -> Result<(), OutputError> {
        let p = dir.join("drive_log.parquet");
        ingest_stage::write(&p, &log, fp)?;
        written.push(p);
        if let Some(d) = &dist {
            let p = dir.join("distance_log.parquet");
            resample_stage::write(&p, d, fp)?;
            written.push(p);
            if let Some(f) = &slope {
                let (a, b) = (
                    dir.join("slope_distance.parquet"),
                    dir.join("slope_time.parquet"),
                );
                slope_stage::write(&a, &b, &log, d, f, &plan.spec.slope, fp)?;
                written.extend([a, b]);
            }
        }
        Ok(())
    })();
    match result {
        Ok(()) => {
            o.outputs = written
                .iter()
                .map(|p| p.strip_prefix(out_root).unwrap_or(p).display().to_string())
                .collect();
            o
        }
        Err(e) => {
            for p in &written {
                let _ = std::fs::remove_file(p);
            }
            let stage = *plan.stages.last().expect("non-empty");
            fail(o, stage, e)
        }
    }
}

/// Runs every input of the plan and writes `run_report.json`; `on_drive` sees each outcome as it
/// completes (for progress output).
///
/// # Errors
/// Only when the run report itself cannot be written; drive failures are in the report.
pub fn run_plan(
    plan: &Plan,
    out_root: &Path,
    mut on_drive: impl FnMut(&DriveOutcome),
) -> std::io::Result<RunReport> {
    let mut drives: Vec<DriveOutcome> = Vec::with_capacity(plan.inputs.len());
    for input in &plan.inputs {
        let mut o = run_drive(plan, input, out_root);
        if o.status == "ok"
            && drives
                .iter()
                .any(|d| d.status == "ok" && d.drive_id == o.drive_id)
        {
            for p in &o.outputs {
                let _ = std::fs::remove_file(out_root.join(p));
            }
            let id = o.drive_id.clone();
            o = fail(
                o,
                Stage::Ingest,
                format!("drive id {id} is not unique in this run"),
            );
            o.outputs.clear();
        }
        on_drive(&o);
        drives.push(o);
    }
    let failed = drives.iter().filter(|d| d.status != "ok").count();
    let report = RunReport {
        pipeline: plan.spec.name.clone(),
        fleetdyn_version: env!("CARGO_PKG_VERSION"),
        ok: drives.len() - failed,
        failed,
        drives,
    };
    let mut f = AtomicFile::create(&out_root.join("run_report.json"))?;
    let json = serde_json::to_string_pretty(&report).map_err(std::io::Error::other)?;
    f.file().write_all(json.as_bytes())?;
    f.file().write_all(b"\n")?;
    f.commit()?;
    Ok(report)
}
