//! Pipeline files (`pipelines/*.toml`): parsed into a [`PipelineSpec`], then validated into a
//! [`Plan`] before any drive is read — unknown keys, unknown or misordered stages, missing
//! vehicle or mapping files, inputs that match nothing, and filter settings the grid cannot carry
//! are all reported up front, together.
//!
//! ```toml
//! name = "nightly"
//! stages = ["ingest", "resample", "slope"]
//! inputs = ["fixtures/drives/*.mcap", "fixtures/drives/*.parquet"]   # files, folders, globs
//! output_dir = "out/nightly"
//! vehicle = "fixtures/vehicles/truck-40t.toml"                        # optional
//! [ingest]    # see IngestConfig
//! [resample]  # see ResampleConfig
//! [slope]     # see SlopeFilterConfig
//! ```
//! Relative paths are resolved against the current directory (run from the repository top).

use super::ingest_stage::IngestConfig;
use crate::ingest::{IngestOptions, Mapping};
use crate::model::vehicle::VehicleFile;
use crate::road::slope_filter::SlopeFilterConfig;
use crate::schema::Stage;
use crate::signal::distance::ResampleConfig;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A pipeline file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    /// Pipeline name (names the run report).
    pub name: String,
    /// One line for humans.
    #[serde(default)]
    pub description: String,
    /// Stages in order.
    pub stages: Vec<String>,
    /// Input files, folders (searched recursively for .mcap / .parquet) or `*` globs in the file
    /// name.
    pub inputs: Vec<PathBuf>,
    /// Output folder.
    pub output_dir: PathBuf,
    /// Vehicle file.
    pub vehicle: Option<PathBuf>,
    /// Ingest settings.
    #[serde(default)]
    pub ingest: IngestConfig,
    /// Resampling settings.
    #[serde(default)]
    pub resample: ResampleConfig,
    /// Slope filter settings.
    #[serde(default)]
    pub slope: SlopeFilterConfig,
}

/// Everything wrong with a pipeline file, found before any drive is read.
#[derive(Debug, Error)]
#[error("pipeline {file}:\n  - {}", problems.join("\n  - "))]
pub struct PlanError {
    /// Pipeline file.
    pub file: String,
    /// Every problem found.
    pub problems: Vec<String>,
}

/// A validated pipeline: stages resolved, files loaded, inputs listed.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The spec it came from.
    pub spec: PipelineSpec,
    /// Stages in order.
    pub stages: Vec<Stage>,
    /// Input files, sorted.
    pub inputs: Vec<PathBuf>,
    /// Ingest options (mapping loaded once).
    pub ingest: IngestOptions,
    /// Canonical text of the whole configuration (hashed into every output).
    pub fingerprint: String,
}

const IMPLEMENTED: &[Stage] = &[Stage::Ingest, Stage::Resample, Stage::Slope];

/// Lists input files: files as given, folders recursively (`.mcap`, `.parquet`), and `*`
/// patterns in the last path component. Sorted, without duplicates.
pub fn list_inputs(patterns: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
        for e in std::fs::read_dir(dir)? {
            let p = e?.path();
            if p.is_dir() {
                walk(&p, out)?;
            } else if matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("mcap" | "parquet")
            ) {
                out.push(p);
            }
        }
        Ok(())
    }
    fn glob_match(pat: &str, name: &str) -> bool {
        let parts: Vec<&str> = pat.split('*').collect();
        if parts.len() == 1 {
            return pat == name;
        }
        let (first, last) = (parts[0], parts[parts.len() - 1]);
        if !name.starts_with(first) || !name[first.len()..].ends_with(last) {
            return false;
        }
        let mut rest = &name[first.len()..name.len() - last.len()];
        for mid in &parts[1..parts.len() - 1] {
            match rest.find(mid) {
                Some(i) => rest = &rest[i + mid.len()..],
                None => return false,
            }
        }
        true
    }
    let mut out = Vec::new();
    for p in patterns {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.contains('*') {
            let dir = p
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            let entries =
                std::fs::read_dir(dir).map_err(|e| format!("input {}: {e}", p.display()))?;
            let before = out.len();
            for e in entries.flatten() {
                let path = e.path();
                let n = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
                if path.is_file() && glob_match(name, n) {
                    out.push(path);
                }
            }
            if out.len() == before {
                return Err(format!("input {} matches no file", p.display()));
            }
        } else if p.is_dir() {
            walk(p, &mut out).map_err(|e| format!("input {}: {e}", p.display()))?;
        } else if p.is_file() {
            out.push(p.clone());
        } else {
            return Err(format!("input {} does not exist", p.display()));
        }
    }
    out.sort();
    out.dedup();
    Ok(out)
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
        toml::from_str(&text).map_err(|e| PlanError {
            file,
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
        let mut stages = Vec::new();
        for s in &self.stages {
            match Stage::parse(s) {
                Some(st) if IMPLEMENTED.contains(&st) => stages.push(st),
                Some(st) => problems.push(format!(
                    "stage {} is not available yet (available: ingest, resample, slope)",
                    st.name()
                )),
                None => problems.push(format!("unknown stage {s:?}")),
            }
        }
        if stages.first() != Some(&Stage::Ingest) {
            problems.push("the first stage must be ingest".into());
        }
        if stages.contains(&Stage::Slope) && !stages.contains(&Stage::Resample) {
            problems.push("stage slope needs resample before it".into());
        }
        if !stages.windows(2).all(|w| w[0] < w[1]) {
            problems.push(
                "stages must be in the order ingest, resample, slope, without repeats".into(),
            );
        }
        let vehicle = match &self.vehicle {
            Some(p) => match VehicleFile::load(p) {
                Ok(v) => Some(v),
                Err(e) => {
                    problems.push(format!("vehicle: {e}"));
                    None
                }
            },
            None => None,
        };
        let ingest = match self.ingest.options(&stages, vehicle.as_ref()) {
            Ok(o) => Some(o),
            Err(e) => {
                problems.push(format!("ingest: {e}"));
                None
            }
        };
        if let Some(m) = ingest.as_ref().and_then(|o| o.mapping.as_ref()) {
            check_mapping_covers(m, &stages, &mut problems);
        }
        let r = &self.resample;
        if !(r.step_m > 0.0 && r.step_m.is_finite()) {
            problems.push(format!("resample.step_m = {} must be positive", r.step_m));
        } else if stages.contains(&Stage::Slope) {
            let nyquist = 0.5 / r.step_m;
            let c = &self.slope;
            if !(c.cutoff_per_m > 0.0 && c.cutoff_per_m < nyquist) {
                problems.push(format!(
                    "slope.cutoff_per_m = {} must lie in (0, {nyquist}) for a {} m grid",
                    c.cutoff_per_m, r.step_m
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
        let listed = match list_inputs(inputs.unwrap_or(&self.inputs)) {
            Ok(v) if v.is_empty() => {
                problems.push("no input files".into());
                v
            }
            Ok(v) => v,
            Err(e) => {
                problems.push(e);
                Vec::new()
            }
        };
        if !problems.is_empty() {
            return Err(PlanError {
                file: file.into(),
                problems,
            });
        }
        let ingest = ingest.expect("no problems");
        let fingerprint = format!(
            "pipeline:v1 stages={:?}\n{}\n{}\n{}",
            stages,
            self.ingest.fingerprint(&ingest),
            super::resample_stage::fingerprint(&self.resample),
            super::slope_stage::fingerprint(&self.slope)
        );
        Ok(Plan {
            spec: self,
            stages,
            inputs: listed,
            ingest,
            fingerprint,
        })
    }
}

fn check_mapping_covers(m: &Mapping, stages: &[Stage], problems: &mut Vec<String>) {
    for c in crate::schema::drive_log().required_for(stages) {
        if !m.signals.contains_key(&c.name) {
            problems.push(format!(
                "mapping {} does not provide {}, which the stages need",
                m.name, c.name
            ));
        }
    }
}
