//! Pipeline files (`pipelines/*.toml`): parsed into a [`PipelineSpec`], then validated into a
//! [`Plan`] before any drive is read. Every problem found is reported together in one
//! [`PlanError`]: unknown keys, unknown or misordered stages, sections of stages that are not
//! run, vehicle or mapping files that do not load, vehicle ids of a manifest without a vehicle
//! file, stages that no vehicle file or mapping can serve, tables that no stage produces, inputs
//! that match nothing, settings out of range.
//!
//! ```toml
//! name = "nightly"
//! model_version = "2026.1"          # partition key of every output (side-by-side versions)
//! stages = ["ingest", "resample", "slope", "shuffle", "axle", "validate", "write"]
//! inputs = ["fixtures/drives"]      # files, folders (recursive), `*` globs, manifest files
//! output_dir = "out/fleet"
//! max_drives_in_flight = 4          # memory bound (default: --jobs)
//! vehicle = "fixtures/vehicles/truck-40t.toml"      # for vehicle ids not listed below
//! vehicle_dir = "fixtures/vehicles"                  # files found by their vehicle_id key
//! [vehicles]                                         # vehicle_id -> file, first choice
//! "TRK-0001" = "fixtures/vehicles/truck-40t.toml"
//! [ingest]   # IngestConfig        [resample] # ResampleConfig   [slope] # SlopeFilterConfig
//! [shuffle]  # ShuffleSpec         [axle]     # AxleSpec         [spectrum] # SpectrumSpec
//! [write]    # WriteSpec           [report]   # ReportSpec
//! ```
//!
//! Relative paths are resolved against the current directory (run from the repository top);
//! paths inside a manifest against the manifest's folder.
//!
//! **Stages and their order**: `ingest`, `resample`, `slope`, `shuffle`, `axle`, `spectrum`,
//! `validate`, `write`; `ingest` first, `write` last, no repeats. `slope` and `spectrum` need
//! `resample`; a simulation with `slope = "filtered"` needs `slope`.
//!
//! **Drives a stage cannot serve** (no `[driveline]` in the drive's vehicle file, no bellow
//! pressures in the recording, ...): with `missing = "skip"` (default) the stage is skipped for
//! that drive, the reason recorded in the run report and in the drive's summary row, and the
//! drive still succeeds; with `missing = "fail"` the drive fails at that stage. What can be known
//! before reading drives is checked in the plan: a stage that *no* configured vehicle file or
//! explicit mapping could serve is a plan error, not a run of skips.

use super::ingest_stage::IngestConfig;
use super::inputs::{list_inputs, InputItem};
use super::vehicles::VehicleBook;
use crate::ingest::{IngestOptions, Mapping};
use crate::road::slope_filter::SlopeFilterConfig;
use crate::road::study::SpectrumSettings;
use crate::schema::Stage;
use crate::signal::distance::ResampleConfig;
use crate::sim::axle_recorded::{AccelSource, AxleRecordConfig};
use crate::sim::axle_validate::AxleValidationConfig;
use crate::sim::validate::ValidationConfig;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

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
    /// Outputs to the partitioned dataset.
    Write,
}

impl PipelineStage {
    /// Every stage, in order.
    pub const ALL: [PipelineStage; 8] = [
        PipelineStage::Ingest,
        PipelineStage::Resample,
        PipelineStage::Slope,
        PipelineStage::Shuffle,
        PipelineStage::Axle,
        PipelineStage::Spectrum,
        PipelineStage::Validate,
        PipelineStage::Write,
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
            PipelineStage::Write => "write",
        }
    }

    /// Parses a stage name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|x| x.name() == s)
    }
}

/// What a simulation stage does with a drive it cannot serve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MissingPolicy {
    /// Skip the stage for that drive, with the reason recorded (the drive succeeds).
    #[default]
    Skip,
    /// Fail the drive at that stage.
    Fail,
}

/// Which slope a simulation takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SlopeInput {
    /// The zero-phase filtered slope of the `slope` stage, mapped to time.
    #[default]
    Filtered,
    /// The sensor as recorded.
    Raw,
}

/// `[shuffle]`: the driveline simulation of the recorded drive (`simulate shuffle --drive`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LongitudinalSpec {
    /// The recording's torques and acceleration.
    #[default]
    Recorded,
    /// The driveline simulation of the recording (needs `[driveline]` too).
    Driveline,
}

/// `[axle]`: the axle-load simulation of the recorded drive (`simulate axle --drive`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
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
#[derive(Debug, Clone, PartialEq, Deserialize)]
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
    /// One row per drive: the validation summary (the `validate` stage).
    DriveSummary,
}

impl DatasetTable {
    /// Every table, in writing order (`drive_summary` last: the drive's commit row).
    pub const ALL: [DatasetTable; 10] = [
        DatasetTable::DriveLog,
        DatasetTable::DistanceLog,
        DatasetTable::SlopeDistance,
        DatasetTable::SlopeTime,
        DatasetTable::ShuffleSim,
        DatasetTable::ShuffleValidation,
        DatasetTable::AxleSim,
        DatasetTable::AxleValidation,
        DatasetTable::RoadSpectrum,
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

fn default_model_version() -> String {
    "1".into()
}

/// A pipeline file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    /// Pipeline name (names the run report).
    pub name: String,
    /// One line for humans.
    #[serde(default)]
    pub description: String,
    /// Model version: a partition key of every output, so results of two versions sit side by
    /// side in one dataset (`model_version=…`).
    #[serde(default = "default_model_version")]
    pub model_version: String,
    /// Stages in order.
    pub stages: Vec<String>,
    /// Input files, folders (searched recursively for .mcap / .parquet), `*` globs in the file
    /// name, or manifest files (any other extension: one drive per line, `path,vehicle_id`).
    pub inputs: Vec<PathBuf>,
    /// Output root of the dataset.
    pub output_dir: PathBuf,
    /// Upper bound of drives held in memory at once (default: the number of jobs).
    pub max_drives_in_flight: Option<usize>,
    /// Vehicle file for vehicle ids not in `vehicles` nor `vehicle_dir`.
    pub vehicle: Option<PathBuf>,
    /// Folder of vehicle files, each used for the `vehicle_id` it declares.
    pub vehicle_dir: Option<PathBuf>,
    /// `vehicle_id` → vehicle file (first choice).
    #[serde(default)]
    pub vehicles: BTreeMap<String, PathBuf>,
    /// Ingest settings.
    #[serde(default)]
    pub ingest: IngestConfig,
    /// Resampling settings.
    #[serde(default)]
    pub resample: ResampleConfig,
    /// Slope filter settings.
    #[serde(default)]
    pub slope: SlopeFilterConfig,
    /// Driveline simulation settings (only with the `shuffle` stage).
    pub shuffle: Option<ShuffleSpec>,
    /// Axle-load simulation settings (only with the `axle` stage).
    pub axle: Option<AxleSpec>,
    /// Spectrum settings (only with the `spectrum` stage).
    pub spectrum: Option<SpectrumSpec>,
    /// Output selection.
    #[serde(default)]
    pub write: WriteSpec,
    /// Report settings.
    #[serde(default)]
    pub report: ReportSpec,
}

/// Everything wrong with a pipeline file, found before any drive is read.
#[derive(Debug, Error)]
#[error("pipeline {file}: {} problem(s):\n  - {}", problems.len(), problems.join("\n  - "))]
pub struct PlanError {
    /// Pipeline file.
    pub file: String,
    /// Every problem found.
    pub problems: Vec<String>,
}

/// A validated pipeline: stages resolved, vehicle and mapping files loaded, inputs listed.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The spec it came from.
    pub spec: PipelineSpec,
    /// Pipeline file as given.
    pub file: String,
    /// Stages in order.
    pub stages: Vec<PipelineStage>,
    /// Inputs, sorted by path.
    pub inputs: Vec<InputItem>,
    /// Ingest options shared by every drive (mapping loaded once; the gear range and vehicle
    /// id are set per drive).
    pub ingest: IngestOptions,
    /// Vehicle files by vehicle id.
    pub vehicles: VehicleBook,
    /// Driveline settings, when the stage runs.
    pub shuffle: Option<ShuffleSpec>,
    /// Axle settings, when the stage runs.
    pub axle: Option<AxleSpec>,
    /// Spectrum settings, when the stage runs.
    pub spectrum: Option<SpectrumSpec>,
    /// Tables written, in writing order.
    pub tables: Vec<DatasetTable>,
    /// Canonical text of the whole configuration except vehicle files (each drive's config
    /// hash adds its vehicle file's content hash).
    pub fingerprint: String,
}

impl Plan {
    /// Whether the plan runs `stage`.
    pub fn has(&self, stage: PipelineStage) -> bool {
        self.stages.contains(&stage)
    }
}

/// Canonical-schema stages ingest checks columns for (the simulation stages check their own
/// columns per drive, so a drive without them can be skipped instead of failing ingest).
fn ingest_stages(stages: &[PipelineStage]) -> Vec<Stage> {
    let mut v = Vec::new();
    if stages.contains(&PipelineStage::Resample) {
        v.push(Stage::Resample);
    }
    if stages.contains(&PipelineStage::Slope) {
        v.push(Stage::Slope);
    }
    v
}

impl PipelineSpec {
    /// Reads a pipeline file.
    ///
    /// # Errors
    /// [`PlanError`] for unreadable or malformed files (unknown keys included).
    pub fn load(path: &Path) -> Result<Self, PlanError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| PlanError {
            file: file.clone(),
            problems: vec![e.to_string()],
        })?;
        Self::parse(&text, &file)
    }

    /// Parses pipeline-file text; `file` names it in errors.
    ///
    /// # Errors
    /// [`PlanError`] for malformed text (unknown keys included).
    pub fn parse(text: &str, file: &str) -> Result<Self, PlanError> {
        toml::from_str(text).map_err(|e| PlanError {
            file: file.into(),
            problems: vec![e.to_string()],
        })
    }

    /// Validates the spec into a plan, collecting every problem.
    ///
    /// `inputs` overrides the spec's inputs (the `--input` flag).
    ///
    /// # Errors
    /// [`PlanError`] listing all problems found.
    pub fn plan(self, file: &str, inputs: Option<&[PathBuf]>) -> Result<Plan, PlanError> {
        let mut problems = Vec::new();
        let stages = self.check_stages(&mut problems);
        let has = |s: PipelineStage| stages.contains(&s);

        if self.name.trim().is_empty() || self.name.contains(['/', '\\']) {
            problems.push(format!(
                "name = {:?} must be a non-empty name without slashes",
                self.name
            ));
        }
        if self.model_version.is_empty()
            || !self
                .model_version
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
        {
            problems.push(format!(
                "model_version = {:?} must be non-empty letters, digits, '.', '_' or '-'",
                self.model_version
            ));
        }
        if self.max_drives_in_flight == Some(0) {
            problems.push("max_drives_in_flight must be at least 1".into());
        }
        for (section, present, stage) in [
            ("shuffle", self.shuffle.is_some(), PipelineStage::Shuffle),
            ("axle", self.axle.is_some(), PipelineStage::Axle),
            ("spectrum", self.spectrum.is_some(), PipelineStage::Spectrum),
        ] {
            if present && !has(stage) {
                problems.push(format!(
                    "section [{section}] configures stage {section}, which is not in stages"
                ));
            }
        }
        let shuffle = has(PipelineStage::Shuffle).then(|| self.shuffle.clone().unwrap_or_default());
        let axle = has(PipelineStage::Axle).then(|| self.axle.clone().unwrap_or_default());
        let spectrum =
            has(PipelineStage::Spectrum).then(|| self.spectrum.clone().unwrap_or_default());

        // vehicles
        let vehicles = VehicleBook::load(
            &self.vehicles,
            self.vehicle_dir.as_deref(),
            self.vehicle.as_deref(),
            &mut problems,
        );
        let needs_driveline = shuffle.is_some()
            || axle
                .as_ref()
                .is_some_and(|a| a.longitudinal == LongitudinalSpec::Driveline);
        if (shuffle.is_some() || axle.is_some()) && vehicles.is_empty() {
            problems.push(
                "stages shuffle and axle need vehicle files: set vehicle, vehicle_dir or [vehicles]"
                    .into(),
            );
        } else {
            if needs_driveline && !vehicles.any(|v| v.file.driveline.is_some()) {
                problems.push(
                    "no vehicle file has a [driveline] section, which stage shuffle (or axle with longitudinal = \"driveline\") needs: every drive would skip it".into(),
                );
            }
            if axle.is_some() && !vehicles.any(|v| v.file.axles.is_some()) {
                problems.push(
                    "no vehicle file has an [axles] section, which stage axle needs: every drive would skip it".into(),
                );
            }
        }
        for (name, slope) in [
            ("shuffle", shuffle.as_ref().map(|s| s.slope)),
            ("axle", axle.as_ref().map(|s| s.slope)),
        ] {
            if slope == Some(SlopeInput::Filtered) && !has(PipelineStage::Slope) {
                problems.push(format!(
                    "[{name}] slope = \"filtered\" needs stage slope (or set slope = \"raw\")"
                ));
            }
        }

        // ingest and mapping
        let istages = ingest_stages(&stages);
        let ingest = match self.ingest.options(&istages, None) {
            Ok(o) => Some(o),
            Err(e) => {
                problems.push(format!("ingest: {e}"));
                None
            }
        };
        if let Some(m) = ingest.as_ref().and_then(|o| o.mapping.as_ref()) {
            check_mapping_covers(m, &stages, axle.as_ref(), &mut problems);
        }

        // numbers
        let r = &self.resample;
        if !(r.step_m > 0.0 && r.step_m.is_finite()) {
            problems.push(format!("resample.step_m = {} must be positive", r.step_m));
        } else {
            if has(PipelineStage::Slope) {
                check_slope(&self.slope, r.step_m, &mut problems);
            }
            if let Some(s) = &spectrum {
                if !(s.segment_length_m.is_finite() && s.segment_length_m >= 8.0 * r.step_m) {
                    problems.push(format!(
                        "spectrum.segment_length_m = {} must be at least 8 grid steps ({} m)",
                        s.segment_length_m,
                        8.0 * r.step_m
                    ));
                }
                if !(s.confidence > 0.0 && s.confidence < 1.0) {
                    problems.push(format!(
                        "spectrum.confidence = {} must lie strictly between 0 and 1",
                        s.confidence
                    ));
                }
            }
        }
        if let Some(s) = &shuffle {
            if !(s.window_s.is_finite() && s.dt_s > 0.0 && s.dt_s < s.window_s) {
                problems.push(format!(
                    "shuffle.window_s = {} and shuffle.dt_s = {} must be positive with dt_s < window_s",
                    s.window_s, s.dt_s
                ));
            }
            if !(s.min_speed_mps.is_finite() && s.min_speed_mps >= 0.0) {
                problems.push(format!(
                    "shuffle.min_speed_mps = {} must be >= 0",
                    s.min_speed_mps
                ));
            }
        }
        if let Some(a) = &axle {
            if !(a.accel_threshold_mps2.is_finite() && a.accel_threshold_mps2 > 0.0) {
                problems.push(format!(
                    "axle.accel_threshold_mps2 = {} must be positive",
                    a.accel_threshold_mps2
                ));
            }
        }
        if self.report.slowest_drives == 0 {
            problems.push("report.slowest_drives must be at least 1".into());
        }

        // tables
        let produced: Vec<DatasetTable> = DatasetTable::ALL
            .into_iter()
            .filter(|t| has(t.stage()))
            .collect();
        let tables = match &self.write.tables {
            None => produced.clone(),
            Some(list) => {
                for t in list {
                    if !produced.contains(t) {
                        problems.push(format!(
                            "write.tables: {} needs stage {}, which is not in stages",
                            t.name(),
                            t.stage().name()
                        ));
                    }
                }
                DatasetTable::ALL
                    .into_iter()
                    .filter(|t| list.contains(t))
                    .collect()
            }
        };

        // inputs
        let listed = match list_inputs(inputs.unwrap_or(&self.inputs)) {
            Ok(v) => {
                if v.items.is_empty() && v.problems.is_empty() {
                    problems.push("no input files".into());
                }
                problems.extend(v.problems);
                v.items
            }
            Err(e) => {
                problems.push(e);
                Vec::new()
            }
        };
        if shuffle.is_some() || axle.is_some() {
            let mut unknown: BTreeMap<&str, usize> = BTreeMap::new();
            for it in &listed {
                if let Some(id) = &it.vehicle_id {
                    if vehicles.resolve(Some(id)).is_none() {
                        *unknown.entry(id).or_default() += 1;
                    }
                }
            }
            for (id, n) in unknown {
                problems.push(format!(
                    "manifest vehicle_id {id:?} ({n} drive(s)) has no vehicle file ([vehicles], vehicle_dir or vehicle)"
                ));
            }
        }

        if !problems.is_empty() {
            return Err(PlanError {
                file: file.into(),
                problems,
            });
        }
        let ingest = ingest.expect("no problems");
        let fingerprint = format!(
            "pipeline:v2 stages={:?} model_version={}\n{}\n{}\n{}\nshuffle:{:?}\naxle:{:?}\nspectrum:{:?}\ntables:{:?}",
            stages,
            self.model_version,
            self.ingest.fingerprint(&ingest),
            super::resample_stage::fingerprint(&self.resample),
            super::slope_stage::fingerprint(&self.slope),
            shuffle,
            axle,
            spectrum,
            tables,
        );
        Ok(Plan {
            spec: self,
            file: file.into(),
            stages,
            inputs: listed,
            ingest,
            vehicles,
            shuffle,
            axle,
            spectrum,
            tables,
            fingerprint,
        })
    }

    fn check_stages(&self, problems: &mut Vec<String>) -> Vec<PipelineStage> {
        let mut stages = Vec::new();
        for s in &self.stages {
            match PipelineStage::parse(s) {
                Some(st) => stages.push(st),
                None => problems.push(format!(
                    "unknown stage {s:?} (stages: {})",
                    PipelineStage::ALL.map(PipelineStage::name).join(", ")
                )),
            }
        }
        if stages.first() != Some(&PipelineStage::Ingest) {
            problems.push("the first stage must be ingest".into());
        }
        if stages.last() != Some(&PipelineStage::Write) {
            problems.push("the last stage must be write".into());
        }
        for (s, need) in [
            (PipelineStage::Slope, PipelineStage::Resample),
            (PipelineStage::Spectrum, PipelineStage::Resample),
        ] {
            if stages.contains(&s) && !stages.contains(&need) {
                problems.push(format!(
                    "stage {} needs {} before it",
                    s.name(),
                    need.name()
                ));
            }
        }
        if !stages.windows(2).all(|w| w[0] < w[1]) {
            problems.push(format!(
                "stages must be in the order {}, without repeats",
                PipelineStage::ALL.map(PipelineStage::name).join(", ")
            ));
        }
        stages
    }
}

fn check_slope(c: &SlopeFilterConfig, step_m: f64, problems: &mut Vec<String>) {
    let nyquist = 0.5 / step_m;
    if !(c.cutoff_per_m > 0.0 && c.cutoff_per_m < nyquist) {
        problems.push(format!(
            "slope.cutoff_per_m = {} must lie in (0, {nyquist}) for a {step_m} m grid",
            c.cutoff_per_m
        ));
    }
    if !(c.stop_per_m > c.cutoff_per_m && c.stop_per_m < nyquist) {
        problems.push(format!(
            "slope.stop_per_m = {} must lie between the cut-off and {nyquist}",
            c.stop_per_m
        ));
    }
    if c.order == 0 || c.order > 12 {
        problems.push(format!("slope.order = {} must be 1 … 12", c.order));
    }
}

/// An explicit mapping must provide what ingest requires, and at least what the simulation
/// stages need (else every drive would skip them).
fn check_mapping_covers(
    m: &Mapping,
    stages: &[PipelineStage],
    axle: Option<&AxleSpec>,
    problems: &mut Vec<String>,
) {
    let dl = crate::schema::drive_log();
    let mut need: Vec<(Stage, &str)> = ingest_stages(stages)
        .into_iter()
        .map(|s| (s, s.name()))
        .collect();
    if stages.contains(&PipelineStage::Shuffle) {
        need.push((Stage::Driveline, "shuffle"));
    }
    if let Some(a) = axle {
        need.push((Stage::Axle, "axle"));
        if a.longitudinal == LongitudinalSpec::Driveline {
            need.push((Stage::Driveline, "axle"));
        }
    }
    let mut seen = std::collections::BTreeSet::new();
    for (s, stage_name) in need {
        for c in dl.required_for(&[s]) {
            if !m.signals.contains_key(&c.name) && seen.insert((c.name.clone(), stage_name)) {
                problems.push(format!(
                    "mapping {} does not provide {}, which stage {stage_name} needs",
                    m.name, c.name
                ));
            }
        }
    }
}
