//! Validation of a pipeline file into a [`Plan`] ([`PipelineSpec::plan`], docs/pipelines.md):
//! every problem found is collected into one [`PlanError`] before any drive is read.
//!
//! **Stages and their order**: `ingest`, `resample`, `slope`, `shuffle`, `axle`, `spectrum`,
//! `validate`, `diagnose`, `write`, `fleet`; `ingest` first, `write` last but for `fleet` (which
//! needs `diagnose`), no repeats. `slope` and `spectrum` need
//! `resample`; a simulation with `slope = "filtered"` needs `slope`.
//!
//! What can be known before reading drives is checked here: a stage that *no* configured
//! vehicle file or explicit mapping could serve is a plan error, not a run of skips. Numbers are
//! checked against their ranges (the slope filter's band against the grid's Nyquist frequency,
//! the spectrum segment against the grid step), tables against the stages that produce them,
//! manifest vehicle ids against the vehicle files.

use super::inputs::list_inputs;
use super::spec::{PipelineSpec, Plan, PlanError};
use super::spec_sections::{AxleSpec, DatasetTable, LongitudinalSpec, PipelineStage, SlopeInput};
use super::vehicles::VehicleBook;
use crate::ingest::Mapping;
use crate::road::slope_filter::SlopeFilterConfig;
use crate::schema::Stage;
use std::collections::BTreeMap;
use std::path::PathBuf;

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
                "name = `{}` must be a non-empty name without slashes",
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
                "model_version = `{}` must be non-empty letters, digits, '.', '_' or '-'",
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
            ("diagnose", self.diagnose.is_some(), PipelineStage::Diagnose),
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
        let diagnose =
            has(PipelineStage::Diagnose).then(|| self.diagnose.clone().unwrap_or_default());

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
        let vehicle_stages = shuffle.is_some() || axle.is_some() || diagnose.is_some();
        if vehicle_stages && vehicles.is_empty() {
            problems.push(
                "stages shuffle, axle and diagnose need vehicle files: set vehicle, vehicle_dir or [vehicles]"
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
        if vehicle_stages {
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
                    "manifest vehicle_id {id} ({n} drive(s)) has no vehicle file ([vehicles], vehicle_dir or vehicle)"
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
        let mut fingerprint = format!(
            "{}\n{}\n{}\n{}\n{}",
            crate::io::canonical(
                "pipeline:v3",
                &serde_json::json!({
                    "stages": stages,
                    "model_version": self.model_version,
                    "shuffle": shuffle,
                    "axle": axle,
                    "spectrum": spectrum,
                    "tables": tables,
                }),
            ),
            self.ingest.fingerprint(&ingest),
            super::resample_stage::fingerprint(&self.resample),
            super::slope_stage::fingerprint(&self.slope),
            crate::io::canonical("diagnose:v2", &diagnose),
        );
        if diagnose.is_some() {
            // the diagnosis's own settings, which the pipeline file does not set
            fingerprint.push(' ');
            fingerprint.push_str(&crate::io::canonical(
                "diagnose-settings:v1",
                &crate::diagnose::run::DiagnoseConfig::default(),
            ));
        }
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
            diagnose,
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
                    "unknown stage `{s}` (stages: {})",
                    PipelineStage::ALL.map(PipelineStage::name).join(", ")
                )),
            }
        }
        if stages.first() != Some(&PipelineStage::Ingest) {
            problems.push("the first stage must be ingest".into());
        }
        let per_drive = stages.iter().rfind(|s| **s != PipelineStage::Fleet);
        if per_drive != Some(&PipelineStage::Write) {
            problems.push("the last stage must be write (only fleet may follow it)".into());
        }
        if stages.contains(&PipelineStage::Fleet) && !stages.contains(&PipelineStage::Diagnose) {
            problems.push(
                "stage fleet needs diagnose: it pools the drives' parameter estimates".into(),
            );
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
