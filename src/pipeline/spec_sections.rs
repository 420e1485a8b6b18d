//! The stages of a pipeline file and the settings of its sections (docs/pipelines.md): the
//! stages in their only order ([`PipelineStage`]), `[shuffle]`, `[axle]`, `[spectrum]`,
//! `[write]` and `[report]` with their defaults (TOML keys carry their units), and the per-drive
//! tables of the dataset ([`DatasetTable`]). Checking them is [`super::spec_check`].
//!
//! **Drives a stage cannot serve** (no `[driveline]` in the drive's vehicle file, no bellow
//! pressures in the recording, ...): with `missing = "skip"` (default) the stage is skipped for
//! that drive, the reason recorded in the run report and in the drive's summary row, and the
//! drive still succeeds; with `missing = "fail"` the drive fails at that stage
//! ([`MissingPolicy`]).

use crate::road::study::SpectrumSettings;
use crate::sim::axle_recorded::{AccelSource, AxleRecordConfig};
use crate::sim::axle_validate::AxleValidationConfig;
use crate::sim::validate::ValidationConfig;
use serde::Deserialize;

/// A stage of a pipeline file, in the only order stages may run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PipelineStage {
    /// Source file to the canonical drive log.
    Ingest,
    /// Uniform distance grid.
    Resample,
    /// Zero-phase spatial slope filter (docs/models/road.md).
    Slope,
    /// Driveline shuffle simulation and its validation (docs/models/driveline.md).
    Shuffle,
    /// Axle-load simulation and its validation (docs/models/axle.md).
    Axle,
    /// Slope spectrum of the drive's road (the `road study` analysis on recorded roads).
    Spectrum,
    /// Per-drive summary row and fleet-level validation tables.
    Validate,
    /// The diagnosis of the drive against its vehicle file (docs/diagnosis/guide.md).
    Diagnose,
    /// Outputs to the partitioned dataset.
    Write,
    /// Per-vehicle evidence over every diagnosed drive of the dataset (docs/fleet.md); after
    /// `write`, in an unsharded run.
    Fleet,
}

impl PipelineStage {
    /// Every stage, in order.
    pub const ALL: [PipelineStage; 10] = [
        PipelineStage::Ingest,
        PipelineStage::Resample,
        PipelineStage::Slope,
        PipelineStage::Shuffle,
        PipelineStage::Axle,
        PipelineStage::Spectrum,
        PipelineStage::Validate,
        PipelineStage::Diagnose,
        PipelineStage::Write,
        PipelineStage::Fleet,
    ];

    /// The name used in pipeline files and reports.
    pub fn name(self) -> &'static str {
        match self {
            PipelineStage::Ingest => "ingest",
            PipelineStage::Resample => "resample",
            PipelineStage::Slope => "slope",
            PipelineStage::Shuffle => "shuffle",
            PipelineStage::Axle => "axle",
            PipelineStage::Spectrum => "spectrum",
            PipelineStage::Validate => "validate",
            PipelineStage::Diagnose => "diagnose",
            PipelineStage::Write => "write",
            PipelineStage::Fleet => "fleet",
        }
    }

    /// Parses a stage name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|x| x.name() == s)
    }
}

/// What a simulation stage does with a drive it cannot serve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MissingPolicy {
    /// Skip the stage for that drive, with the reason recorded (the drive succeeds).
    #[default]
    Skip,
    /// Fail the drive at that stage.
    Fail,
}

/// Which slope a simulation takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SlopeInput {
    /// The zero-phase filtered slope of the `slope` stage, mapped to time.
    #[default]
    Filtered,
    /// The sensor as recorded.
    Raw,
}

/// `[shuffle]`: the driveline simulation of the recorded drive (`simulate shuffle --drive`).
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ShuffleSpec {
    /// Re-initialisation window, s.
    pub window_s: f64,
    /// Fast-path step, s.
    pub dt_s: f64,
    /// Samples below this measured speed are left out of the metrics, m/s.
    pub min_speed_mps: f64,
    /// Slope input.
    pub slope: SlopeInput,
    /// Also simulate with the raw sensor slope, to report the shuffle the quantised slope
    /// excites (mean square shuffle indicator with raw vs filtered slope).
    pub compare_raw_slope: bool,
    /// Drives without `[driveline]` or the driveline columns.
    pub missing: MissingPolicy,
}

impl Default for ShuffleSpec {
    fn default() -> Self {
        let v = ValidationConfig::default();
        Self {
            window_s: v.window_s,
            dt_s: v.dt_s,
            min_speed_mps: v.min_speed_mps,
            slope: SlopeInput::Filtered,
            compare_raw_slope: true,
            missing: MissingPolicy::Skip,
        }
    }
}

impl ShuffleSpec {
    /// The validation settings.
    pub fn validation(&self) -> ValidationConfig {
        ValidationConfig {
            window_s: self.window_s,
            dt_s: self.dt_s,
            min_speed_mps: self.min_speed_mps,
        }
    }
}

/// Acceleration input of the axle model (TOML spelling of [`AccelSource`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AccelSpec {
    /// The IMU column when present, else d(speed)/dt.
    #[default]
    Auto,
    /// The IMU column.
    Imu,
    /// d(speed)/dt.
    Speed,
}

/// Longitudinal inputs of the axle model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LongitudinalSpec {
    /// The recording's torques and acceleration.
    #[default]
    Recorded,
    /// The driveline simulation of the recording (needs `[driveline]` too).
    Driveline,
}

/// `[axle]`: the axle-load simulation of the recorded drive (`simulate axle --drive`).
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct AxleSpec {
    /// Acceleration input.
    pub accel: AccelSpec,
    /// Longitudinal inputs.
    pub longitudinal: LongitudinalSpec,
    /// Acceleration separating the acceleration / steady / braking segments, m/s².
    pub accel_threshold_mps2: f64,
    /// Slope input.
    pub slope: SlopeInput,
    /// Drives without `[axles]`, bellow pressures or the axle columns.
    pub missing: MissingPolicy,
}

impl Default for AxleSpec {
    fn default() -> Self {
        Self {
            accel: AccelSpec::Auto,
            longitudinal: LongitudinalSpec::Recorded,
            accel_threshold_mps2: AxleValidationConfig::default().accel_threshold_mps2,
            slope: SlopeInput::Filtered,
            missing: MissingPolicy::Skip,
        }
    }
}

impl AxleSpec {
    /// The validation settings.
    pub fn validation(&self) -> AxleValidationConfig {
        AxleValidationConfig {
            record: AxleRecordConfig {
                accel: match self.accel {
                    AccelSpec::Auto => AccelSource::Auto,
                    AccelSpec::Imu => AccelSource::Imu,
                    AccelSpec::Speed => AccelSource::Speed,
                },
                ..Default::default()
            },
            accel_threshold_mps2: self.accel_threshold_mps2,
        }
    }
}

/// `[spectrum]`: Welch PSD of the drive's raw road slope on the distance grid
/// (docs/models/road.md).
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpectrumSpec {
    /// Welch segment length, m (frequency resolution = 1 / segment).
    pub segment_length_m: f64,
    /// Confidence level of the PSD band.
    pub confidence: f64,
    /// Drives shorter than one segment.
    pub missing: MissingPolicy,
}

impl Default for SpectrumSpec {
    fn default() -> Self {
        Self {
            segment_length_m: 2048.0,
            confidence: 0.95,
            missing: MissingPolicy::Skip,
        }
    }
}

impl SpectrumSpec {
    /// The study settings.
    pub fn settings(&self) -> SpectrumSettings {
        SpectrumSettings {
            segment_length_m: self.segment_length_m,
            confidence: self.confidence,
        }
    }
}

/// `[diagnose]`: the diagnosis of each drive against its vehicle file (`fleetdyn diagnose`,
/// its default settings).
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiagnoseSpec {
    /// Write each drive's diagnosis folder (`diagnosis.json`, `report.md`, residual plots,
    /// `detail.json`) under `_reports/diagnose/`.
    pub reports: bool,
    /// Drives that no model can be compared on (no `[driveline]` and no `[axles]` the
    /// recording can drive).
    pub missing: MissingPolicy,
}

impl Default for DiagnoseSpec {
    fn default() -> Self {
        Self {
            reports: true,
            missing: MissingPolicy::Skip,
        }
    }
}

/// Per-drive tables of the dataset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DatasetTable {
    /// Canonical drive log (all canonical columns, null where the source has none).
    DriveLog,
    /// Distance-grid log.
    DistanceLog,
    /// Slope on the distance grid.
    SlopeDistance,
    /// Slope on the time axis.
    SlopeTime,
    /// Driveline simulation.
    ShuffleSim,
    /// Driveline validation per gear (schema `validation`).
    ShuffleValidation,
    /// Axle-load simulation.
    AxleSim,
    /// Axle-load validation per axle and segment.
    AxleValidation,
    /// Road slope spectrum.
    RoadSpectrum,
    /// Located mismatches of the diagnosis (schema `mismatch`).
    Mismatch,
    /// Accepted findings of the diagnosis (schema `findings`).
    Findings,
    /// Every catalogue parameter the drive informs (schema `parameter_estimates`).
    ParameterEstimates,
    /// One row per drive: the validation summary (the `validate` stage).
    DriveSummary,
}

impl DatasetTable {
    /// Every table, in writing order (`drive_summary` last: the drive's commit row).
    pub const ALL: [DatasetTable; 13] = [
        DatasetTable::DriveLog,
        DatasetTable::DistanceLog,
        DatasetTable::SlopeDistance,
        DatasetTable::SlopeTime,
        DatasetTable::ShuffleSim,
        DatasetTable::ShuffleValidation,
        DatasetTable::AxleSim,
        DatasetTable::AxleValidation,
        DatasetTable::RoadSpectrum,
        DatasetTable::Mismatch,
        DatasetTable::Findings,
        DatasetTable::ParameterEstimates,
        DatasetTable::DriveSummary,
    ];

    /// Folder name of the table under the output root.
    pub fn name(self) -> &'static str {
        match self {
            DatasetTable::DriveLog => "drive_log",
            DatasetTable::DistanceLog => "distance_log",
            DatasetTable::SlopeDistance => "slope_distance",
            DatasetTable::SlopeTime => "slope_time",
            DatasetTable::ShuffleSim => "shuffle_sim",
            DatasetTable::ShuffleValidation => "shuffle_validation",
            DatasetTable::AxleSim => "axle_sim",
            DatasetTable::AxleValidation => "axle_validation",
            DatasetTable::RoadSpectrum => "road_spectrum",
            DatasetTable::Mismatch => "mismatch",
            DatasetTable::Findings => "findings",
            DatasetTable::ParameterEstimates => "parameter_estimates",
            DatasetTable::DriveSummary => "drive_summary",
        }
    }

    /// The stage producing the table.
    pub fn stage(self) -> PipelineStage {
        match self {
            DatasetTable::DriveLog => PipelineStage::Ingest,
            DatasetTable::DistanceLog => PipelineStage::Resample,
            DatasetTable::SlopeDistance | DatasetTable::SlopeTime => PipelineStage::Slope,
            DatasetTable::ShuffleSim | DatasetTable::ShuffleValidation => PipelineStage::Shuffle,
            DatasetTable::AxleSim | DatasetTable::AxleValidation => PipelineStage::Axle,
            DatasetTable::RoadSpectrum => PipelineStage::Spectrum,
            DatasetTable::Mismatch | DatasetTable::Findings | DatasetTable::ParameterEstimates => {
                PipelineStage::Diagnose
            }
            DatasetTable::DriveSummary => PipelineStage::Validate,
        }
    }
}

/// `[write]`: which tables go to the dataset.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct WriteSpec {
    /// Tables to write; default: every table the stages produce.
    pub tables: Option<Vec<DatasetTable>>,
}

/// `[report]`: the run report.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReportSpec {
    /// Rows of the slowest-drives table.
    pub slowest_drives: usize,
}

impl Default for ReportSpec {
    fn default() -> Self {
        Self { slowest_drives: 10 }
    }
}
