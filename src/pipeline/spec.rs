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
//! [diagnose] # DiagnoseSpec        [write]    # WriteSpec        [report]   # ReportSpec
//! ```
//!
//! Relative paths are resolved against the current directory (run from the repository top);
//! paths inside a manifest against the manifest's folder.
//!
//! The stages and sections are [`super::spec_sections`] (re-exported here), the validation
//! [`super::spec_check`]; the keys are documented in docs/pipelines.md.

use super::ingest_stage::IngestConfig;
use super::inputs::InputItem;
pub use super::spec_sections::{
    AccelSpec, AxleSpec, DatasetTable, DiagnoseSpec, LongitudinalSpec, MissingPolicy,
    PipelineStage, ReportSpec, ShuffleSpec, SlopeInput, SpectrumSpec, WriteSpec,
};
use super::vehicles::VehicleBook;
use crate::ingest::IngestOptions;
use crate::road::slope_filter::SlopeFilterConfig;
use crate::signal::distance::ResampleConfig;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

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
    /// Diagnosis settings (only with the `diagnose` stage).
    pub diagnose: Option<DiagnoseSpec>,
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
    /// Diagnosis settings, when the stage runs.
    pub diagnose: Option<DiagnoseSpec>,
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

impl PipelineSpec {
    /// Reads a pipeline file; its relative paths (`inputs`, `output_dir`, `vehicle`,
    /// `vehicle_dir`, `[vehicles]`, `[ingest] mapping`) resolve against the file's folder
    /// ([`PipelineSpec::resolve_paths`]).
    ///
    /// # Errors
    /// [`PlanError`] for unreadable or malformed files (unknown keys included).
    pub fn load(path: &Path) -> Result<Self, PlanError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| PlanError {
            file: file.clone(),
            problems: vec![e.to_string()],
        })?;
        let mut spec = Self::parse(&text, &file)?;
        spec.resolve_paths(path.parent().unwrap_or(Path::new("")));
        Ok(spec)
    }

    /// Resolves the file's relative paths against the folder `base` (the pipeline file's own,
    /// [`super::paths::resolve`]); absolute paths stay as they are.
    pub fn resolve_paths(&mut self, base: &Path) {
        let r = |p: &mut PathBuf| *p = super::paths::resolve(base, p);
        self.inputs.iter_mut().for_each(r);
        r(&mut self.output_dir);
        self.vehicle.iter_mut().for_each(r);
        self.vehicle_dir.iter_mut().for_each(r);
        self.vehicles.values_mut().for_each(r);
        self.ingest.mapping.iter_mut().for_each(r);
    }

    /// Parses pipeline-file text; `file` names it in errors. Relative paths stay as written
    /// (relative to the current directory) until [`PipelineSpec::resolve_paths`] is called.
    ///
    /// # Errors
    /// [`PlanError`] for malformed text (unknown keys included).
    pub fn parse(text: &str, file: &str) -> Result<Self, PlanError> {
        toml::from_str(text).map_err(|e| PlanError {
            file: file.into(),
            problems: vec![e.to_string()],
        })
    }
}
