//! The records of a pipeline run: what happened to each stage of each drive, the drive's
//! metrics, the per-drive outcome and the run report (`run_report.json`, the `drive_summary`
//! table), the shard a run covers, and why a run could not complete. Plain data, written by
//! [`super::run`] and rendered by [`super::run_report`].

use crate::io::{config_hash, OutputError};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn is_zero(n: &u64) -> bool {
    *n == 0
}
fn one() -> usize {
    1
}
fn is_one(n: &usize) -> bool {
    *n == 1
}
use crate::ingest::SkippedSegment;
use crate::table::Segment;
use thiserror::Error;

/// One shard of a split run: inputs whose path hash is `index` modulo `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Shard {
    /// 0-based index.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Parses `I/N` with `0 <= I < N`.
    ///
    /// # Errors
    /// A message naming the rule broken.
    pub fn parse(s: &str) -> Result<Self, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("--shard {s}: expected I/N, e.g. 0/4"))?;
        let index: usize = i
            .trim()
            .parse()
            .map_err(|_| format!("--shard {s}: `{i}` is not a shard index"))?;
        let count: usize = n
            .trim()
            .parse()
            .map_err(|_| format!("--shard {s}: `{n}` is not a shard count"))?;
        if count == 0 || index >= count {
            return Err(format!(
                "--shard {s}: the index must lie in 0 … {}",
                count.saturating_sub(1)
            ));
        }
        Ok(Self { index, count })
    }

    /// Whether the input at `path` belongs to this shard.
    pub fn owns(&self, path: &Path) -> bool {
        let h = config_hash(&[path.to_string_lossy().as_bytes()]);
        let v = u64::from_str_radix(&h[..16], 16).expect("hex");
        (v % self.count as u64) as usize == self.index
    }
}

/// What happened to one stage of one drive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageNote {
    /// Stage name.
    pub stage: String,
    /// `ran` or `skipped`.
    pub status: String,
    /// Why it was skipped.
    pub reason: Option<String>,
}

/// A drive's validation summary (the `validate` stage), SI units, `None` where a stage did not
/// run or a metric is undefined.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DriveMetrics {
    /// Rows of the canonical drive log.
    pub rows: u64,
    /// Per column, samples ingest masked to missing (not finite, outside the physical range, a
    /// speed spike).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub masked_samples: BTreeMap<String, u64>,
    /// Samples ingest replaced by a later one at the same time with another value.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub conflicts_resolved: u64,
    /// Time of the first sample, ns since the Unix epoch.
    pub start_ns: i64,
    /// Duration, s.
    pub duration_s: f64,
    /// Distance travelled, m.
    pub distance_m: Option<f64>,
    /// Slope sensor quantisation step found.
    pub slope_quantization_step: Option<f64>,
    /// Driveline model: vehicle speed RMSE (all gears), m/s.
    pub vehicle_speed_rmse_mps: Option<f64>,
    /// Vehicle speed fit, %.
    pub vehicle_speed_fit_percent: Option<f64>,
    /// Engine speed RMSE, rad/s.
    pub engine_speed_rmse_rad_per_s: Option<f64>,
    /// Engine speed fit, %.
    pub engine_speed_fit_percent: Option<f64>,
    /// Mean square shuffle indicator with the configured slope input, m²/s².
    pub shuffle_ms_m2_per_s2: Option<f64>,
    /// Mean square shuffle indicator with the raw sensor slope, m²/s².
    pub shuffle_ms_raw_slope_m2_per_s2: Option<f64>,
    /// Per gear, the shuffle the slope filter removes and the total with the raw slope
    /// ([`crate::sim::slope_shuffle`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub slope_shuffle_by_gear: Vec<crate::sim::slope_shuffle::GearShuffle>,
    /// Axle model: bellow pressure MAE, front / rear / tag, Pa.
    pub bellow_pressure_mae_pa: [Option<f64>; 3],
    /// Bellow pressure fit, front / rear / tag, %.
    pub bellow_pressure_fit_percent: [Option<f64>; 3],
    /// Frequency below which 90 % of the slope power lies, 1/m.
    pub slope_knee_90_per_m: Option<f64>,
    /// Frequency below which 99 % of the slope power lies, 1/m.
    pub slope_knee_99_per_m: Option<f64>,
    /// Slope PSD bin frequencies (for the fleet study), 1/m.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub spectrum_freq_per_m: Vec<f64>,
    /// Slope PSD, 1/(1/m).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub spectrum_psd: Vec<f64>,
}

/// A processed drive: its done-marker, and what the reports say about it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriveRecord {
    /// Input file as listed.
    pub input: String,
    /// SHA-256 of the input's bytes.
    pub input_sha256: String,
    /// Configuration hash of the drive (pipeline, vehicle file, fleetdyn version).
    pub config_hash: String,
    /// Drive id.
    pub drive_id: String,
    /// Vehicle id (partition value; `__HIVE_DEFAULT_PARTITION__` when unknown).
    pub vehicle_id: String,
    /// UTC date of the first sample.
    pub date: String,
    /// Vehicle file used.
    pub vehicle_file: Option<String>,
    /// Per stage: ran or skipped, and why.
    pub stages: Vec<StageNote>,
    /// Files written, relative to the output root, in writing order.
    pub outputs: Vec<String>,
    /// Validation summary.
    pub metrics: DriveMetrics,
    /// Where the drive sits in its recording, when that was split at pauses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segment: Option<Segment>,
    /// Drives the input file gave (more than one when it was split at pauses).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub input_drives: usize,
    /// Segments of the input not kept as drives (on the input's first drive only).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub skipped_segments: Vec<SkippedSegment>,
}

/// `ok` (processed now), `reused` (up to date from an earlier run) or `failed`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DriveStatus {
    /// Processed in this run.
    Ok,
    /// Outputs of an earlier run with the same input and configuration.
    Reused,
    /// Failed; no outputs.
    Failed,
}

impl DriveStatus {
    /// The status as the run report writes it: `ok`, `reused`, `failed`.
    pub fn name(self) -> &'static str {
        match self {
            DriveStatus::Ok => "ok",
            DriveStatus::Reused => "reused",
            DriveStatus::Failed => "failed",
        }
    }
}

/// What happened to one input in this run.
#[derive(Debug, Clone, Serialize)]
pub struct DriveOutcome {
    /// Input file.
    pub input: String,
    /// Drive id (the file stem when ingest failed before reading metadata).
    pub drive_id: String,
    /// Status.
    pub status: DriveStatus,
    /// Stage that failed.
    pub failed_stage: Option<&'static str>,
    /// Error message.
    pub error: Option<String>,
    /// Wall time spent on the drive in this run, s.
    pub elapsed_s: f64,
    /// The drive's record (ok and reused drives).
    pub record: Option<DriveRecord>,
}

/// A segment of an input not kept as a drive.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SkippedInput {
    /// Input file.
    pub input: String,
    /// The segment and why it was skipped.
    #[serde(flatten)]
    pub segment: SkippedSegment,
}

/// What the fleet stage ([`super::fleet_stage`]) wrote.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FleetSummary {
    /// Folder of its outputs.
    pub dir: String,
    /// Vehicles with diagnosed drives.
    pub vehicles: usize,
    /// Drives read.
    pub drives: usize,
    /// Drives left out because their table could not be read.
    pub unreadable: usize,
    /// Vehicles with a parameter outside its tolerance.
    pub flagged: usize,
    /// Changes over time found.
    pub changes: usize,
}

/// The whole run.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// Pipeline name.
    pub pipeline: String,
    /// Pipeline file.
    pub pipeline_file: String,
    /// Model version.
    pub model_version: String,
    /// fleetdyn version.
    pub fleetdyn_version: &'static str,
    /// Shard of this run.
    pub shard: Option<Shard>,
    /// Worker threads.
    pub jobs: usize,
    /// Drives in memory at once, at most.
    pub max_drives_in_flight: usize,
    /// Inputs of the plan (all shards).
    pub inputs_total: usize,
    /// Drives processed now.
    pub ok: usize,
    /// Drives reused from earlier runs.
    pub reused: usize,
    /// Drives that failed.
    pub failed: usize,
    /// Segments of split recordings not kept as drives, with the input and the reason.
    pub skipped_segments: Vec<SkippedInput>,
    /// Wall time of the run, s.
    pub elapsed_s: f64,
    /// Output root of the dataset.
    pub output_dir: String,
    /// Folder of the report.
    pub report_dir: String,
    /// Per drive, in input order.
    pub drives: Vec<DriveOutcome>,
    /// The fleet stage's outputs, when it ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fleet: Option<FleetSummary>,
}

/// Why a run could not complete (drive failures are not errors: they are in the report).
#[derive(Debug, Error)]
pub enum RunError {
    /// Thread pool.
    #[error("thread pool: {0}")]
    Pool(String),
    /// A report file.
    #[error("writing the run report {path}: {source}")]
    Report {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// A report table.
    #[error(transparent)]
    Table(#[from] OutputError),
    /// The fleet stage could not write its outputs.
    #[error(transparent)]
    Fleet(#[from] crate::fleet::FleetError),
    /// The output root cannot be written (read-only, no permission): checked before any drive.
    #[error("output folder {path} is not writable: {source}")]
    OutputFolder {
        /// Output root.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}
