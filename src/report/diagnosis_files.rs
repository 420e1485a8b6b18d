//! The per-drive output folder of a diagnosis (docs/diagnosis/contract.md): `diagnosis.json`,
//! `mismatch.parquet`, `findings.parquet`, `parameter_estimates.parquet`, `report.md` with one residual SVG per compared
//! signal (before: nominal; after: with the accepted findings), and `detail.json` with
//! everything the diagnosis computed (window tests, band powers, coherence, lags, condition
//! cells, statements, every greedy round's screen and fits) for an engineer who wants to check
//! a verdict.
//!
//! # Output atomicity
//! Files are written into a hidden staging folder inside the output folder and renamed into
//! place only when all of them are written, `diagnosis.json` last: a reader never sees a
//! partial diagnosis, and a failed one leaves the folder as it was (no partial outputs).
//! A process killed while writing leaves its staging folder behind; the next write into the
//! same folder removes every staging folder it finds there (the writer owns its output folder:
//! the pipeline gives each drive's folder to one shard, the `diagnose` command to its one run).

use super::axle_plot::PlotError;
use super::contract::assemble;
use super::diagnosis::{plot_residuals, write_report, ReportParts, ResidualSeries};
use super::sentences::statement_text;
use crate::diagnose::altitude_offset::AltitudeOutcome;
use crate::diagnose::explain::{Explanation, SignalMetrics};
use crate::diagnose::idle_torque::IdleTorqueOutcome;
use crate::diagnose::locate::Location;
use crate::diagnose::modal::ModalComparison;
use crate::diagnose::noise::NoiseFloors;
use crate::diagnose::resistance_stretch::ResistanceStretch;
use crate::diagnose::run::{Diagnosed, ModelsUsed};
use crate::diagnose::speed_consistency::SpeedConsistency;
use crate::io::OutputError;
use crate::table::DriveLog;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a diagnosis could not be written.
#[derive(Debug, Error)]
pub enum WriteError {
    /// An output could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A plot could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// Another I/O failure on the output folder.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
}

/// `detail.json`: everything behind the verdict.
#[derive(Serialize)]
struct Detail<'a> {
    drive_id: &'a str,
    source_file: &'a str,
    models: &'a ModelsUsed,
    noise_floors: &'a NoiseFloors,
    location: &'a Location,
    modal: &'a Option<ModalComparison>,
    speed_consistency: &'a Option<SpeedConsistency>,
    resistance_stretch: &'a Option<ResistanceStretch>,
    altitude_offset: &'a AltitudeOutcome,
    idle_torque: &'a IdleTorqueOutcome,
    explanation: &'a Explanation,
}

/// Where the outputs of [`write_outputs`] went.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// `diagnosis.json`.
    pub json: PathBuf,
    /// `mismatch.parquet`.
    pub mismatch: PathBuf,
    /// `findings.parquet`.
    pub findings: PathBuf,
    /// `parameter_estimates.parquet`.
    pub parameter_estimates: PathBuf,
    /// `report.md`.
    pub report: PathBuf,
    /// Residual plots.
    pub plots: Vec<PathBuf>,
    /// `detail.json`.
    pub detail: PathBuf,
}

/// Per-finding MAE and fit % for the report.
fn metrics_of(d: &Diagnosed) -> Vec<BTreeMap<String, SignalMetrics>> {
    d.explanation
        .findings
        .iter()
        .map(|f| f.metrics.clone())
        .collect()
}

/// Writes the diagnosis `d` of `log` into `dir` (module documentation: staged, then renamed).
/// `fingerprint` identifies the configuration in the Parquet metadata.
///
/// # Errors
/// [`WriteError::Output`], [`WriteError::Plot`] or [`WriteError::Io`]; the folder is
/// left without any new file then.
pub fn write_outputs(
    dir: &Path,
    d: &Diagnosed,
    log: &DriveLog,
    fingerprint: &str,
) -> Result<Written, WriteError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| WriteError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    remove_stale_stages(dir).map_err(io(dir))?;
    let stage = dir.join(format!("{STAGE_PREFIX}{}", std::process::id()));
    std::fs::create_dir_all(&stage).map_err(io(&stage))?;
    let result = write_staged(&stage, d, log, fingerprint);
    let names = match result {
        Ok(n) => n,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&stage);
            return Err(e);
        }
    };
    // diagnosis.json last: its presence means the folder is complete
    let mut order: Vec<&String> = names.iter().filter(|n| *n != "diagnosis.json").collect();
    let json_name = "diagnosis.json".to_string();
    order.push(&json_name);
    for n in &order {
        let (from, to) = (stage.join(n), dir.join(n));
        std::fs::rename(&from, &to).map_err(io(&to))?;
    }
    std::fs::remove_dir_all(&stage).map_err(io(&stage))?;
    let p = |n: &str| dir.join(n);
    Ok(Written {
        json: p("diagnosis.json"),
        mismatch: p("mismatch.parquet"),
        findings: p("findings.parquet"),
        parameter_estimates: p("parameter_estimates.parquet"),
        report: p("report.md"),
        plots: names
            .iter()
            .filter(|n| n.ends_with(".svg"))
            .map(|n| p(n))
            .collect(),
        detail: p("detail.json"),
    })
}

/// Name of a staging folder, before the writing process's id.
const STAGE_PREFIX: &str = ".diagnose-partial-";

/// Removes the staging folders of earlier writes into `dir` that did not finish (their process
/// was killed), whatever process made them.
fn remove_stale_stages(dir: &Path) -> std::io::Result<()> {
    for e in std::fs::read_dir(dir)? {
        let e = e?;
        if e.file_name().to_string_lossy().starts_with(STAGE_PREFIX) && e.file_type()?.is_dir() {
            std::fs::remove_dir_all(e.path())?;
        }
    }
    Ok(())
}

/// File name of a signal's residual plot.
pub fn plot_name(signal: &str) -> String {
    format!("residual_{signal}.svg")
}

fn write_staged(
    stage: &Path,
    d: &Diagnosed,
    log: &DriveLog,
    fingerprint: &str,
) -> Result<Vec<String>, WriteError> {
    let vehicle_id = log.meta.vehicle_id.as_deref();
    let source = log.meta.source_file.as_str();
    let diag = &assemble(d);
    diag.write_mismatch(
        &stage.join("mismatch.parquet"),
        vehicle_id,
        source,
        fingerprint,
    )?;
    diag.write_findings(
        &stage.join("findings.parquet"),
        vehicle_id,
        source,
        fingerprint,
    )?;
    diag.write_parameter_estimates(
        &stage.join("parameter_estimates.parquet"),
        &d.parameters,
        vehicle_id,
        source,
        fingerprint,
    )?;
    let mut names = vec![
        "mismatch.parquet".to_string(),
        "findings.parquet".to_string(),
        "parameter_estimates.parquet".to_string(),
    ];
    let mut plots = Vec::new();
    for r in &d.residuals {
        if !r.before.iter().any(|x| x.is_finite()) {
            continue;
        }
        let name = plot_name(&r.signal);
        let stretches: Vec<(f64, f64)> = diag
            .mismatch
            .iter()
            .filter(|m| m.signal == r.signal)
            .map(|m| (m.start_s, m.end_s))
            .collect();
        plot_residuals(
            &stage.join(&name),
            &format!("{}: {} residual", diag.drive_id, r.signal),
            &ResidualSeries {
                signal: &r.signal,
                t_s: &d.t_s,
                before: &r.before,
                after: &r.after,
            },
            &stretches,
        )?;
        plots.push((r.signal.clone(), name.clone()));
        names.push(name);
    }
    let report = stage.join("report.md");
    let shapes: Vec<(String, Vec<String>)> = d
        .location
        .signals
        .iter()
        .filter(|s| !s.statements.is_empty())
        .map(|s| {
            let words = s.statements.iter().map(statement_text).collect();
            (s.signal.clone(), words)
        })
        .collect();
    let parts = ReportParts {
        metrics: &metrics_of(d),
        shapes: &shapes,
        plots: &plots,
    };
    write_report(&report, diag, &parts).map_err(|source| WriteError::Io {
        path: report.clone(),
        source,
    })?;
    names.push("report.md".into());
    let detail = Detail {
        drive_id: &diag.drive_id,
        source_file: source,
        models: &d.models,
        noise_floors: &d.floors,
        location: &d.location,
        modal: &d.modal,
        speed_consistency: &d.speed_consistency,
        resistance_stretch: &d.resistance_stretch,
        altitude_offset: &d.altitude_offset,
        idle_torque: &d.idle_torque,
        explanation: &d.explanation,
    };
    let mut text = serde_json::to_string_pretty(&detail).map_err(|e| WriteError::Io {
        path: stage.join("detail.json"),
        source: std::io::Error::other(e),
    })?;
    text.push('\n');
    let path = stage.join("detail.json");
    crate::io::AtomicFile::write_all(&path, text.as_bytes())
        .map_err(|source| WriteError::Io { path, source })?;
    names.push("detail.json".into());
    diag.write_json(&stage.join("diagnosis.json"))?;
    names.push("diagnosis.json".into());
    Ok(names)
}
