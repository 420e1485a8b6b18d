//! The analysis stages of one drive, in memory, before anything is written: resample to
//! distance, slope filter, the shuffle and axle simulations side by side (`rayon::join`), the
//! road slope spectrum, the diagnosis. A stage that cannot serve a drive (see [`super::spec`]:
//! `missing = "skip"`) is skipped with its reason and the drive succeeds; with
//! `missing = "fail"`, or on a stage error, the drive fails with that stage (`Fail`).

use super::axle_stage;
use super::record::StageNote;
use super::spec::Plan;
use super::spec_sections::{LongitudinalSpec, MissingPolicy, PipelineStage, SlopeInput};
use super::vehicles::LoadedVehicle;
use crate::diagnose::extended::ExtendedError;
use crate::diagnose::long_drive::release_between_steps;
use crate::diagnose::run::{diagnose, DiagnoseConfig, DiagnoseError, Diagnosed};
use crate::road::slope_filter::{filter_slope, SlopeFiltered};
use crate::road::study::{slope_spectrum, RoadSpectrum, StudyError};
use crate::schema::{drive_log, Stage};
use crate::signal::distance::{resample_to_distance, DistanceLog};
use crate::sim::axle_validate::{require_pressures, AxleValidation};
use crate::sim::slope_shuffle::{self, GearShuffle};
use crate::sim::validate::{validate_shuffle, ShuffleValidation};
use crate::table::{DriveLog, Signal};

/// A stage error with the stage it belongs to.
pub(super) struct Fail(pub(super) PipelineStage, pub(super) String);

pub(super) fn fail(stage: PipelineStage, e: impl std::fmt::Display) -> Fail {
    Fail(stage, e.to_string())
}

fn missing_columns(log: &DriveLog, stage: Stage) -> Vec<String> {
    drive_log()
        .required_for(&[stage])
        .into_iter()
        .filter(|c| log.signal(&c.name).is_none())
        .map(|c| c.name.clone())
        .collect()
}

/// Skip or fail, as the stage's policy says.
fn cannot_serve(
    policy: MissingPolicy,
    stage: PipelineStage,
    reason: String,
    notes: &mut Vec<StageNote>,
) -> Result<(), Fail> {
    match policy {
        MissingPolicy::Skip => {
            notes.push(StageNote {
                stage: stage.name().into(),
                status: "skipped".into(),
                reason: Some(reason),
            });
            Ok(())
        }
        MissingPolicy::Fail => Err(Fail(stage, reason)),
    }
}

fn ran(stage: PipelineStage) -> StageNote {
    StageNote {
        stage: stage.name().into(),
        status: "ran".into(),
        reason: None,
    }
}

pub(super) fn mean_square(v: &[f64]) -> Option<f64> {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v.iter().filter(|x| x.is_finite()) {
        s += x * x;
        n += 1;
    }
    (n > 0).then(|| s / n as f64)
}

pub(super) struct ShuffleOut {
    pub(super) val: ShuffleValidation,
    pub(super) ms_raw: Option<f64>,
    /// Per gear, the shuffle the slope filter removes (empty without a raw-slope run).
    pub(super) slope_by_gear: Vec<GearShuffle>,
}

fn run_shuffle(
    plan: &Plan,
    log: &DriveLog,
    vehicle: &LoadedVehicle,
    slope_col: Option<&str>,
    notes: &mut Vec<StageNote>,
) -> Result<Option<ShuffleOut>, Fail> {
    let Some(spec) = &plan.shuffle else {
        return Ok(None);
    };
    let st = PipelineStage::Shuffle;
    let Some(p) = &vehicle.file.driveline else {
        let why = format!("vehicle file {} has no [driveline] section", vehicle.path);
        cannot_serve(spec.missing, st, why, notes)?;
        return Ok(None);
    };
    let missing = missing_columns(log, Stage::Driveline);
    if !missing.is_empty() {
        let why = format!("the recording has no {}", missing.join(", "));
        cannot_serve(spec.missing, st, why, notes)?;
        return Ok(None);
    }
    let cfg = spec.validation();
    let ratios = &vehicle.file.gearbox.ratios;
    // The raw-slope run first: only its shuffle indicator is kept, so its other trajectories
    // are freed before the run whose outputs are written (a 10-hour drive: ~140 MB less at peak).
    let raw_indicator = if spec.compare_raw_slope && slope_col.is_some() {
        let raw = validate_shuffle(log, p, ratios, None, &cfg).map_err(|e| fail(st, e))?;
        Some(raw.shuffle_indicator)
    } else {
        None
    };
    let val = validate_shuffle(log, p, ratios, slope_col, &cfg).map_err(|e| fail(st, e))?;
    let (ms_raw, slope_by_gear) = match (&raw_indicator, log.signal("gear")) {
        (Some(raw), Some(gear)) => (
            mean_square(raw),
            slope_shuffle::by_gear(raw, &val.shuffle_indicator, gear),
        ),
        (Some(raw), None) => (mean_square(raw), Vec::new()),
        (None, _) if slope_col.is_none() => (mean_square(&val.shuffle_indicator), Vec::new()),
        (None, _) => (None, Vec::new()),
    };
    notes.push(ran(st));
    Ok(Some(ShuffleOut {
        val,
        ms_raw,
        slope_by_gear,
    }))
}

fn run_axle(
    plan: &Plan,
    log: &DriveLog,
    vehicle: &LoadedVehicle,
    slope_col: Option<&str>,
    notes: &mut Vec<StageNote>,
) -> Result<Option<AxleValidation>, Fail> {
    let Some(spec) = &plan.axle else {
        return Ok(None);
    };
    let st = PipelineStage::Axle;
    if vehicle.file.axles.is_none() {
        let why = format!("vehicle file {} has no [axles] section", vehicle.path);
        cannot_serve(spec.missing, st, why, notes)?;
        return Ok(None);
    }
    let driveline = spec.longitudinal == LongitudinalSpec::Driveline;
    if driveline && vehicle.file.driveline.is_none() {
        let why = format!(
            "longitudinal = \"driveline\" and vehicle file {} has no [driveline] section",
            vehicle.path
        );
        cannot_serve(spec.missing, st, why, notes)?;
        return Ok(None);
    }
    if let Err(e) = require_pressures(log) {
        cannot_serve(spec.missing, st, e.to_string(), notes)?;
        return Ok(None);
    }
    let mut missing = missing_columns(log, Stage::Axle);
    if driveline {
        missing.extend(missing_columns(log, Stage::Driveline));
        missing.sort();
        missing.dedup();
    }
    if !missing.is_empty() {
        let why = format!("the recording has no {}", missing.join(", "));
        cannot_serve(spec.missing, st, why, notes)?;
        return Ok(None);
    }
    let cfg = axle_stage::AxleStageConfig {
        validation: spec.validation(),
        longitudinal: if driveline {
            axle_stage::LongitudinalSource::Driveline
        } else {
            axle_stage::LongitudinalSource::Recorded
        },
        slope_column: slope_col.map(str::to_string),
    };
    let v = axle_stage::run(log, &vehicle.file, &vehicle.path, &cfg).map_err(|e| fail(st, e))?;
    notes.push(ran(st));
    Ok(Some(v))
}

fn run_spectrum(
    plan: &Plan,
    d: &DistanceLog,
    f: Option<&SlopeFiltered>,
    notes: &mut Vec<StageNote>,
) -> Result<Option<RoadSpectrum>, Fail> {
    let Some(spec) = &plan.spectrum else {
        return Ok(None);
    };
    let st = PipelineStage::Spectrum;
    let slope: Vec<f64> = match f {
        Some(f) => f.raw.clone(),
        None => match d.signals.iter().find(|s| s.name == "road_slope") {
            Some(s) => s.values.clone(),
            None => {
                cannot_serve(
                    spec.missing,
                    st,
                    "the recording has no road_slope".into(),
                    notes,
                )?;
                return Ok(None);
            }
        },
    };
    match slope_spectrum(&slope, d.step_m, &spec.settings()) {
        Ok(sp) => {
            notes.push(ran(st));
            Ok(Some(sp))
        }
        Err(e @ StudyError::SegmentTooLong { .. }) => {
            cannot_serve(spec.missing, st, e.to_string(), notes)?;
            Ok(None)
        }
        Err(e) => Err(fail(st, e)),
    }
}

fn run_diagnose(
    plan: &Plan,
    log: &DriveLog,
    vehicle: &LoadedVehicle,
    notes: &mut Vec<StageNote>,
) -> Result<Option<Diagnosed>, Fail> {
    let Some(spec) = &plan.diagnose else {
        return Ok(None);
    };
    let st = PipelineStage::Diagnose;
    match diagnose(log, &vehicle.file, &DiagnoseConfig::default()) {
        Ok(d) => {
            notes.push(ran(st));
            Ok(Some(d))
        }
        Err(e @ DiagnoseError::Setup(ExtendedError::NoModel { .. })) => {
            cannot_serve(spec.missing, st, e.to_string(), notes)?;
            Ok(None)
        }
        Err(e) => Err(fail(st, e)),
    }
}

/// Everything a drive produced, in memory, before anything is written.
pub(super) struct Computed {
    pub(super) log: DriveLog,
    pub(super) dist: Option<DistanceLog>,
    pub(super) slope: Option<SlopeFiltered>,
    pub(super) shuffle: Option<ShuffleOut>,
    pub(super) axle: Option<AxleValidation>,
    pub(super) spectrum: Option<RoadSpectrum>,
    pub(super) diagnosis: Option<Diagnosed>,
    pub(super) gravity: f64,
    /// Per column, samples ingest masked to missing.
    pub(super) masked: std::collections::BTreeMap<String, u64>,
    /// Samples ingest replaced by a later one at the same time.
    pub(super) conflicts_resolved: u64,
}

pub(super) fn compute(
    plan: &Plan,
    mut log: DriveLog,
    vehicle: Option<&LoadedVehicle>,
) -> Result<(Computed, Vec<StageNote>), Fail> {
    let mut notes = vec![ran(PipelineStage::Ingest)];
    // The diagnosis reads the log alone: it runs first, while no other stage's output is held (a
    // long drive's distance tables and simulations would otherwise sit beside its own peak), and
    // takes its place after validate in the notes and, should it fail, in the failures (a stage
    // before it that fails is the one reported).
    let diagnosed = vehicle.map(|v| {
        let mut n = Vec::new();
        (run_diagnose(plan, &log, v, &mut n), n)
    });
    // between the stages of a long drive, the pages its last stage freed go back to the
    // operating system before the next allocates its own
    let rows = log.len();
    let release = || release_between_steps(rows);
    release();
    let dist = if plan.has(PipelineStage::Resample) {
        let d = resample_to_distance(&log, &plan.spec.resample)
            .map_err(|e| fail(PipelineStage::Resample, e))?;
        notes.push(ran(PipelineStage::Resample));
        Some(d)
    } else {
        None
    };
    let mut slope = match (&dist, plan.has(PipelineStage::Slope)) {
        (Some(d), true) => {
            let f = filter_slope(d, &plan.spec.slope).map_err(|e| fail(PipelineStage::Slope, e))?;
            notes.push(ran(PipelineStage::Slope));
            Some(f)
        }
        _ => None,
    };
    release();
    // the simulations' log: the filtered slope added as a column when a simulation takes it
    let wants_filtered = [
        plan.shuffle.as_ref().map(|s| s.slope),
        plan.axle.as_ref().map(|s| s.slope),
    ]
    .contains(&Some(SlopeInput::Filtered));
    // The column is lent to the log for the simulations and handed back after them: the log is
    // not copied (a 10-hour drive's log is ~170 MB) and the filtered slope not duplicated.
    let mut lent = false;
    if let (true, Some(f)) = (wants_filtered, &mut slope) {
        if log.signal("road_slope").is_some() {
            log.signals.push(Signal {
                name: "road_slope_filtered".into(),
                unit: "1".into(),
                values: std::mem::take(&mut f.zero_phase_time),
            });
            lent = true;
        }
    }
    let col = |s: Option<SlopeInput>| {
        (s == Some(SlopeInput::Filtered) && lent).then_some("road_slope_filtered")
    };
    let (sh_col, ax_col) = (
        col(plan.shuffle.as_ref().map(|s| s.slope)),
        col(plan.axle.as_ref().map(|s| s.slope)),
    );
    let (mut sh_notes, mut ax_notes) = (Vec::new(), Vec::new());
    let (shuffle, axle) = match vehicle {
        Some(v) => rayon::join(
            || run_shuffle(plan, &log, v, sh_col, &mut sh_notes),
            || run_axle(plan, &log, v, ax_col, &mut ax_notes),
        ),
        None => (Ok(None), Ok(None)),
    };
    if let (true, Some(f)) = (lent, &mut slope) {
        let s = log.signals.pop().expect("the lent column is the last");
        f.zero_phase_time = s.values;
    }
    let (shuffle, axle) = (shuffle?, axle?);
    release();
    notes.extend(sh_notes);
    notes.extend(ax_notes);
    let spectrum = match &dist {
        Some(d) => run_spectrum(plan, d, slope.as_ref(), &mut notes)?,
        None => None,
    };
    if plan.has(PipelineStage::Validate) {
        notes.push(ran(PipelineStage::Validate));
    }
    let diagnosis = match diagnosed {
        Some((d, n)) => {
            let d = d?;
            notes.extend(n);
            d
        }
        None => None,
    };
    let gravity = vehicle
        .and_then(|v| v.file.axles.as_ref())
        .map_or(9.81, |a| a.gravity_m_per_s2);
    Ok((
        Computed {
            log,
            dist,
            slope,
            shuffle,
            axle,
            spectrum,
            diagnosis,
            gravity,
            masked: Default::default(),
            conflicts_resolved: 0,
        },
        notes,
    ))
}
