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
//! **Failures.** A drive that fails (bad file, a stage error, even a panic) is recorded with the
//! stage and the error, leaves no output, and the other drives go on. A stage that cannot serve a
//! drive (see `spec`: `missing = "skip"`) is skipped with its reason; the drive succeeds.
//!
//! **Idempotence.** See [`super::dataset`]: a drive whose done-marker matches its input's
//! content hash and its configuration hash is reused, not recomputed (unless `force`).
//!
//! **Sharding.** `--shard i/N` keeps the inputs whose path hashes to `i` modulo `N` (SHA-256 of
//! the path as listed): stable when other files come or go, the same in every process.

use super::dataset::{escape, file_sha256, sweep_temps, utc_date, Dataset};
pub use super::record::{
    DriveMetrics, DriveOutcome, DriveRecord, DriveStatus, RunError, RunReport, Shard, StageNote,
};
use super::spec::{DatasetTable, LongitudinalSpec, MissingPolicy, PipelineStage, Plan, SlopeInput};
use super::vehicles::LoadedVehicle;
use super::{axle_stage, resample_stage, slope_stage};
use crate::io::{
    config_hash, write_column_refs_with_constants, AtomicFile, ColumnRef, DataRef, OutColumn,
    OutData, TableMeta,
};
use crate::model::axle::Axle;
use crate::report::axle_sim::{axle_sim_columns, AxleSimExtra, TimeAxis};
use crate::report::axle_validation::{axle_meta, axle_validation_columns};
use crate::road::slope_filter::{filter_slope, SlopeFiltered};
use crate::road::study::{slope_spectrum, RoadSpectrum, StudyError};
use crate::schema::{drive_log, Dtype, Stage};
use crate::signal::distance::{resample_to_distance, DistanceLog};
use crate::sim::axle_validate::{require_pressures, AxleValidation, Segment};
use crate::sim::validate::{validate_shuffle, ShuffleValidation};
use crate::table::{DriveLog, Signal};
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

/// A stage error with the stage it belongs to.
struct Fail(PipelineStage, String);

fn fail(stage: PipelineStage, e: impl std::fmt::Display) -> Fail {
    Fail(stage, e.to_string())
}

/// Vehicle-id partition value of a drive without one.
pub const UNKNOWN_VEHICLE: &str = "__HIVE_DEFAULT_PARTITION__";

/// Configuration hash of a drive: the plan, its vehicle file, the manifest's vehicle id, the
/// fleetdyn version.
fn drive_config_hash(
    plan: &Plan,
    vehicle: Option<&LoadedVehicle>,
    manifest_vehicle: Option<&str>,
) -> String {
    config_hash(&[
        plan.fingerprint.as_bytes(),
        vehicle
            .map_or("no vehicle file", |v| v.sha256.as_str())
            .as_bytes(),
        manifest_vehicle.unwrap_or("").as_bytes(),
        env!("CARGO_PKG_VERSION").as_bytes(),
    ])
}

fn needs_vehicle(plan: &Plan) -> bool {
    plan.has(PipelineStage::Shuffle) || plan.has(PipelineStage::Axle)
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

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

fn mean_square(v: &[f64]) -> Option<f64> {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v.iter().filter(|x| x.is_finite()) {
        s += x * x;
        n += 1;
    }
    (n > 0).then(|| s / n as f64)
}

struct ShuffleOut {
    val: ShuffleValidation,
    ms_raw: Option<f64>,
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
    // The raw-slope run first: only its mean-square shuffle is kept, so its trajectories are
    // freed before the run whose outputs are written (a 10-hour drive: ~170 MB less at peak).
    let raw_ms = if spec.compare_raw_slope && slope_col.is_some() {
        let raw = validate_shuffle(log, p, ratios, None, &cfg).map_err(|e| fail(st, e))?;
        Some(mean_square(&raw.shuffle_indicator))
    } else {
        None
    };
    let val = validate_shuffle(log, p, ratios, slope_col, &cfg).map_err(|e| fail(st, e))?;
    let ms_raw = match raw_ms {
        Some(ms) => ms,
        None if slope_col.is_none() => mean_square(&val.shuffle_indicator),
        None => None,
    };
    notes.push(ran(st));
    Ok(Some(ShuffleOut { val, ms_raw }))
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

/// The canonical columns in schema order, each present (null where the drive has none): one
/// schema for every file of a dataset table. Pass-through columns stay in the source. The
/// columns are borrowed from `signals`, not copied (copied and NaN-filled, a 10-hour drive's
/// `drive_log` table took ~290 MB).
fn conformed(signals: &[Signal], n: usize) -> Vec<ColumnRef<'_>> {
    drive_log()
        .columns
        .iter()
        .skip(1)
        .map(|c| {
            let values = signals.iter().find(|s| s.name == c.name);
            ColumnRef {
                name: &c.name,
                unit: &c.unit,
                data: match (c.dtype, values) {
                    (Dtype::I16, Some(s)) => DataRef::I16(&s.values),
                    (Dtype::I16, None) => DataRef::NullI16(n),
                    (_, Some(s)) => DataRef::F64(&s.values),
                    (_, None) => DataRef::NullF64(n),
                },
            }
        })
        .collect()
}

/// The columns of one table of a drive: borrowed from the drive's results where they are
/// long, built where they are small.
enum TableColumns<'a> {
    Borrowed(Vec<ColumnRef<'a>>),
    Built(Vec<OutColumn>),
}

fn base_meta(table: &str, log: &DriveLog, hash: &str, vehicle_id: &str) -> TableMeta {
    TableMeta {
        table: table.into(),
        drive_id: log.meta.drive_id.clone(),
        vehicle_id: Some(vehicle_id.to_string()),
        source_file: log.meta.source_file.clone(),
        config_hash: hash.into(),
        extra: Vec::new(),
    }
}

fn str_col(name: &str, v: impl Into<String>) -> OutColumn {
    OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::Str(vec![v.into()]),
    }
}

fn opt_col(name: &str, unit: &str, v: Option<f64>) -> OutColumn {
    OutColumn::f64(name, unit, vec![v.unwrap_or(f64::NAN)])
}

fn stage_status(notes: &[StageNote], stage: PipelineStage) -> String {
    notes.iter().find(|n| n.stage == stage.name()).map_or_else(
        || "not configured".to_string(),
        |n| match &n.reason {
            Some(r) => format!("skipped: {r}"),
            None => n.status.clone(),
        },
    )
}

/// The `drive_summary` row of a record (schema `schemas/outputs/drive-summary.toml`).
pub fn summary_columns(r: &DriveRecord) -> Vec<OutColumn> {
    let m = &r.metrics;
    let mut cols = vec![
        OutColumn::timestamp(vec![m.start_ns]),
        OutColumn::f64("duration", "s", vec![m.duration_s]),
        OutColumn {
            name: "rows".into(),
            unit: "1".into(),
            data: OutData::U64(vec![m.rows]),
        },
        opt_col("distance", "m", m.distance_m),
        opt_col("slope_quantization_step", "1", m.slope_quantization_step),
        opt_col("vehicle_speed_rmse", "m/s", m.vehicle_speed_rmse_mps),
        opt_col("vehicle_speed_fit", "%", m.vehicle_speed_fit_percent),
        opt_col("engine_speed_rmse", "rad/s", m.engine_speed_rmse_rad_per_s),
        opt_col("engine_speed_fit", "%", m.engine_speed_fit_percent),
        opt_col("shuffle_ms", "m^2/s^2", m.shuffle_ms_m2_per_s2),
        opt_col(
            "shuffle_ms_raw_slope",
            "m^2/s^2",
            m.shuffle_ms_raw_slope_m2_per_s2,
        ),
    ];
    for (i, a) in ["front", "rear", "tag"].iter().enumerate() {
        cols.push(opt_col(
            &format!("bellow_pressure_mae_{a}"),
            "Pa",
            m.bellow_pressure_mae_pa[i],
        ));
    }
    for (i, a) in ["front", "rear", "tag"].iter().enumerate() {
        cols.push(opt_col(
            &format!("bellow_pressure_fit_{a}"),
            "%",
            m.bellow_pressure_fit_percent[i],
        ));
    }
    cols.push(opt_col("slope_knee_90", "1/m", m.slope_knee_90_per_m));
    cols.push(opt_col("slope_knee_99", "1/m", m.slope_knee_99_per_m));
    for st in [
        PipelineStage::Shuffle,
        PipelineStage::Axle,
        PipelineStage::Spectrum,
    ] {
        cols.push(str_col(
            &format!("{}_status", st.name()),
            stage_status(&r.stages, st),
        ));
    }
    cols.push(str_col(
        "vehicle_file",
        r.vehicle_file.clone().unwrap_or_default(),
    ));
    cols.push(str_col("source_file", r.input.clone()));
    cols.push(str_col("input_sha256", r.input_sha256.clone()));
    cols
}

fn spectrum_columns(sp: &RoadSpectrum) -> Vec<OutColumn> {
    vec![
        OutColumn::f64("frequency", "1/m", sp.psd.freq_hz.clone()),
        OutColumn::f64("psd", "(1)^2/(1/m)", sp.psd.psd.clone()),
        OutColumn::f64("psd_lower", "(1)^2/(1/m)", sp.psd.lower.clone()),
        OutColumn::f64("psd_upper", "(1)^2/(1/m)", sp.psd.upper.clone()),
        OutColumn::f64("cumulative_power", "1", sp.cumulative.clone()),
        OutColumn::f64(
            "filter_zero_phase_gain",
            "dB",
            sp.filter.zero_phase_db.clone(),
        ),
        OutColumn::f64("filter_causal_gain", "dB", sp.filter.causal_db.clone()),
    ]
}

/// Everything a drive produced, in memory, before anything is written.
struct Computed {
    log: DriveLog,
    dist: Option<DistanceLog>,
    slope: Option<SlopeFiltered>,
    shuffle: Option<ShuffleOut>,
    axle: Option<AxleValidation>,
    spectrum: Option<RoadSpectrum>,
    gravity: f64,
}

fn check_gears(log: &DriveLog, v: &LoadedVehicle) -> Result<(), String> {
    let Some(g) = log.signal("gear") else {
        return Ok(());
    };
    let (lo, hi) = v.file.gear_range();
    for (i, &x) in g.iter().enumerate() {
        if x.is_finite() && (x < f64::from(lo) || x > f64::from(hi)) {
            return Err(format!(
                "{}: column gear row {i}: value {x} outside the gearbox of {} ({lo} … {hi})",
                log.meta.source_file, v.path
            ));
        }
    }
    Ok(())
}

/// Shared state of a run.
struct Ctx<'a> {
    plan: &'a Plan,
    ds: Dataset,
    force: bool,
    claims: Mutex<HashMap<String, usize>>,
}

fn process(ctx: &Ctx<'_>, index: usize, item: &super::inputs::InputItem) -> DriveOutcome {
    let t0 = Instant::now();
    let input = item.path.display().to_string();
    let stem = item
        .path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        process_inner(ctx, index, item, &input)
    }));
    let result = match caught {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err((
                None,
                Fail(
                    PipelineStage::Ingest,
                    format!("internal error (panic): {msg}"),
                ),
            ))
        }
    };
    let elapsed_s = t0.elapsed().as_secs_f64();
    match result {
        Ok((status, record)) => DriveOutcome {
            input,
            drive_id: record.drive_id.clone(),
            status,
            failed_stage: None,
            error: None,
            elapsed_s,
            record: Some(record),
        },
        Err((id, Fail(stage, e))) => DriveOutcome {
            input,
            drive_id: id.unwrap_or(stem),
            status: DriveStatus::Failed,
            failed_stage: Some(stage.name()),
            error: Some(e),
            elapsed_s,
            record: None,
        },
    }
}

type Processed = Result<(DriveStatus, DriveRecord), (Option<String>, Fail)>;

fn process_inner(
    ctx: &Ctx<'_>,
    index: usize,
    item: &super::inputs::InputItem,
    input: &str,
) -> Processed {
    let plan = ctx.plan;
    let ing_st = PipelineStage::Ingest;
    let sha = file_sha256(&item.path)
        .map_err(|e| (None, fail(ing_st, format!("{input}: reading: {e}"))))?;
    // one marker per input file: its content and its path as listed (two files with the same
    // bytes are two drives when their ids come from their names)
    let key = config_hash(&[sha.as_bytes(), input.as_bytes()]);
    let prev = ctx.ds.read_marker(&key);
    if let (false, Some(rec)) = (ctx.force, &prev) {
        let vid = (rec.vehicle_id != UNKNOWN_VEHICLE).then_some(rec.vehicle_id.as_str());
        let v = plan.vehicles.resolve(item.vehicle_id.as_deref().or(vid));
        let expected = drive_config_hash(plan, v.map(|v| &**v), item.vehicle_id.as_deref());
        let complete = rec.outputs.iter().all(|o| ctx.ds.root.join(o).is_file());
        if rec.config_hash == expected && complete {
            let mut rec = rec.clone();
            rec.input = input.to_string();
            return Ok((DriveStatus::Reused, rec));
        }
    }

    // ingest
    let manifest_vehicle = item
        .vehicle_id
        .as_deref()
        .and_then(|id| plan.vehicles.resolve(Some(id)));
    let mut opts = plan.ingest.clone();
    opts.vehicle_id = item.vehicle_id.clone();
    opts.gear_range = manifest_vehicle.map(|v| v.file.gear_range());
    let ing = super::ingest_stage::run(&item.path, &opts).map_err(|e| (None, fail(ing_st, e)))?;
    let log = ing.log;
    let id = Some(log.meta.drive_id.clone());
    let vehicle = plan
        .vehicles
        .resolve(log.meta.vehicle_id.as_deref())
        .cloned();
    if needs_vehicle(plan) && vehicle.is_none() {
        return Err((
            id,
            fail(
                ing_st,
                format!(
                    "{input}: no vehicle file for vehicle_id {:?} (pipeline [vehicles], vehicle_dir, vehicle)",
                    log.meta.vehicle_id
                ),
            ),
        ));
    }
    if let (Some(v), None) = (&vehicle, manifest_vehicle) {
        check_gears(&log, v).map_err(|e| (id.clone(), fail(ing_st, e)))?;
    }
    {
        let mut claims = ctx.claims.lock().unwrap_or_else(|p| p.into_inner());
        match claims.get(&log.meta.drive_id) {
            Some(&other) if other != index => {
                return Err((
                    id,
                    fail(
                        ing_st,
                        format!(
                            "drive id {} is not unique in this run (also input #{other})",
                            log.meta.drive_id
                        ),
                    ),
                ))
            }
            _ => {
                claims.insert(log.meta.drive_id.clone(), index);
            }
        }
    }
    let hash = drive_config_hash(plan, vehicle.as_deref(), item.vehicle_id.as_deref());
    let c = compute(plan, log, vehicle.as_deref()).map_err(|f| (id.clone(), f))?;
    let rec = write_drive(
        ctx,
        &c,
        (&sha, &key),
        &hash,
        input,
        vehicle.as_deref(),
        prev.as_ref(),
    )
    .map_err(|f| (id, f))?;
    Ok((DriveStatus::Ok, rec))
}

fn compute(
    plan: &Plan,
    mut log: DriveLog,
    vehicle: Option<&LoadedVehicle>,
) -> Result<(Computed, Vec<StageNote>), Fail> {
    let mut notes = vec![ran(PipelineStage::Ingest)];
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
    notes.extend(sh_notes);
    notes.extend(ax_notes);
    let spectrum = match &dist {
        Some(d) => run_spectrum(plan, d, slope.as_ref(), &mut notes)?,
        None => None,
    };
    if plan.has(PipelineStage::Validate) {
        notes.push(ran(PipelineStage::Validate));
    }
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
            gravity,
        },
        notes,
    ))
}

fn metrics_of(c: &Computed) -> DriveMetrics {
    let log = &c.log;
    let mut m = DriveMetrics {
        rows: log.len() as u64,
        start_ns: log.timestamp_ns[0],
        duration_s: log.duration_s(),
        distance_m: c.dist.as_ref().map(|d| d.map.total_m()),
        slope_quantization_step: c
            .slope
            .as_ref()
            .and_then(|f| f.quantization.map(|q| q.step)),
        ..Default::default()
    };
    if let Some(s) = &c.shuffle {
        let all = |sig: &str| {
            s.val
                .metrics
                .iter()
                .find(|x| x.signal == sig && x.gear.is_none())
        };
        if let Some(x) = all("vehicle_speed") {
            m.vehicle_speed_rmse_mps = finite(x.rmse);
            m.vehicle_speed_fit_percent = finite(x.fit_percent);
        }
        if let Some(x) = all("engine_speed") {
            m.engine_speed_rmse_rad_per_s = finite(x.rmse);
            m.engine_speed_fit_percent = finite(x.fit_percent);
        }
        m.shuffle_ms_m2_per_s2 = mean_square(&s.val.shuffle_indicator);
        m.shuffle_ms_raw_slope_m2_per_s2 = s.ms_raw;
    }
    if let Some(a) = &c.axle {
        for (i, axle) in Axle::ALL.into_iter().enumerate() {
            if let Some(x) = a.metrics.iter().find(|x| {
                x.axle == axle
                    && x.segment == Segment::All
                    && x.signal.starts_with("bellow_pressure")
            }) {
                m.bellow_pressure_mae_pa[i] = finite(x.mae);
                m.bellow_pressure_fit_percent[i] = finite(x.fit_percent);
            }
        }
    }
    if let Some(sp) = &c.spectrum {
        m.slope_knee_90_per_m = finite(sp.knee_90);
        m.slope_knee_99_per_m = finite(sp.knee_99);
        m.spectrum_freq_per_m = sp.psd.freq_hz.clone();
        m.spectrum_psd = sp.psd.psd.clone();
    }
    m
}

fn write_drive(
    ctx: &Ctx<'_>,
    computed: &(Computed, Vec<StageNote>),
    (sha, key): (&str, &str),
    hash: &str,
    input: &str,
    vehicle: Option<&LoadedVehicle>,
    prev: Option<&DriveRecord>,
) -> Result<DriveRecord, Fail> {
    let (c, notes) = computed;
    let plan = ctx.plan;
    let log = &c.log;
    let vehicle_id = log
        .meta
        .vehicle_id
        .clone()
        .unwrap_or_else(|| UNKNOWN_VEHICLE.to_string());
    let mut rec = DriveRecord {
        input: input.to_string(),
        input_sha256: sha.to_string(),
        config_hash: hash.to_string(),
        drive_id: log.meta.drive_id.clone(),
        vehicle_id: vehicle_id.clone(),
        date: utc_date(log.timestamp_ns[0]),
        vehicle_file: vehicle.map(|v| v.path.clone()),
        stages: notes.clone(),
        outputs: Vec::new(),
        metrics: metrics_of(c),
    };
    let meta = |t: &str| base_meta(t, log, hash, &vehicle_id);
    // Each table is built just before it is written and dropped after: one table's columns
    // in memory at a time, not every table of the drive; the long tables borrow their columns
    // from the drive's results instead of copying them (docs/validation/benchmarks.md).
    let build = |t: DatasetTable| -> Option<(TableMeta, TableColumns<'_>)> {
        use TableColumns::{Borrowed, Built};
        match t {
            DatasetTable::DriveLog => {
                let mut cols = vec![ColumnRef::timestamp(&log.timestamp_ns)];
                cols.extend(conformed(&log.signals, log.len()));
                return Some((meta("drive_log"), Borrowed(cols)));
            }
            DatasetTable::DistanceLog => {
                if let Some(d) = &c.dist {
                    let (mut m, _) = resample_stage::table(d, "");
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    let mut cols = vec![
                        ColumnRef::f64("distance", "m", &d.distance_m),
                        ColumnRef::timestamp(&d.timestamp_ns),
                    ];
                    cols.extend(conformed(&d.signals, d.distance_m.len()));
                    return Some((m, Borrowed(cols)));
                }
            }
            DatasetTable::SlopeDistance | DatasetTable::SlopeTime => {
                if let (Some(d), Some(f)) = (&c.dist, &c.slope) {
                    let (dist, time) = slope_stage::tables(log, d, f);
                    let (name, cols) = if t == DatasetTable::SlopeDistance {
                        ("slope_distance", dist)
                    } else {
                        ("slope_time", time)
                    };
                    let mut m = slope_stage::meta(name, d, f, &plan.spec.slope, "");
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    return Some((m, Borrowed(cols)));
                }
            }
            DatasetTable::ShuffleSim | DatasetTable::ShuffleValidation => {
                if let Some(s) = &c.shuffle {
                    let ((ma, a), (mb, b)) = crate::report::validation::tables(log, &s.val, "");
                    let (mut m, cols) = if t == DatasetTable::ShuffleSim {
                        (ma, Borrowed(a))
                    } else {
                        (mb, Built(b))
                    };
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    return Some((m, cols));
                }
            }
            DatasetTable::AxleSim | DatasetTable::AxleValidation => {
                if let Some(a) = &c.axle {
                    let name = t.name();
                    let mut m = axle_meta(name, log, "", a);
                    m.config_hash = hash.into();
                    m.vehicle_id = Some(vehicle_id.clone());
                    let cols = if t == DatasetTable::AxleSim {
                        axle_sim_columns(
                            &a.trajectory,
                            &AxleSimExtra {
                                time: TimeAxis::Recorded {
                                    timestamp_ns: &log.timestamp_ns,
                                },
                                inputs: &a.recorded.inputs,
                                vehicle_speed_mps: log.signal("vehicle_speed"),
                                gravity_m_per_s2: c.gravity,
                            },
                        )
                    } else {
                        axle_validation_columns(a)
                    };
                    return Some((m, Built(cols)));
                }
            }
            DatasetTable::RoadSpectrum => {
                if let Some(sp) = &c.spectrum {
                    let mut m = meta("road_spectrum");
                    m.extra = vec![
                        ("knee_50_per_m".into(), format!("{:e}", sp.knee_50)),
                        ("knee_90_per_m".into(), format!("{:e}", sp.knee_90)),
                        ("knee_99_per_m".into(), format!("{:e}", sp.knee_99)),
                        ("nperseg".into(), sp.psd.nperseg.to_string()),
                        ("step_m".into(), sp.step_m.to_string()),
                    ];
                    return Some((m, Built(spectrum_columns(sp))));
                }
            }
            DatasetTable::DriveSummary => {
                return Some((meta("drive_summary"), Built(summary_columns(&rec))));
            }
        }
        None
    };
    let wst = PipelineStage::Write;
    let root = &ctx.ds.root;
    let mut written: Vec<PathBuf> = Vec::new();
    let undo = |written: &[PathBuf]| {
        for p in written {
            let _ = std::fs::remove_file(root.join(p));
        }
    };
    for &t in &plan.tables {
        let Some((m, cols)) = build(t) else {
            continue;
        };
        let rel = ctx
            .ds
            .table_rel(t.name(), &vehicle_id, &rec.date, &rec.drive_id);
        let path = root.join(&rel);
        sweep_temps(&path);
        let constants = [("drive_id", rec.drive_id.as_str())];
        let written_or = match &cols {
            TableColumns::Borrowed(c) => write_column_refs_with_constants(&path, &m, c, &constants),
            TableColumns::Built(c) => {
                let refs: Vec<ColumnRef<'_>> = c.iter().map(OutColumn::as_column_ref).collect();
                write_column_refs_with_constants(&path, &m, &refs, &constants)
            }
        };
        if let Err(e) = written_or {
            undo(&written);
            return Err(fail(wst, e));
        }
        written.push(rel);
    }
    rec.outputs = written
        .iter()
        .map(|p| p.to_string_lossy().replace('\\', "/"))
        .collect();
    // outputs of an earlier configuration that this one does not write
    if let Some(prev) = prev {
        for o in &prev.outputs {
            if !rec.outputs.contains(o) {
                let _ = std::fs::remove_file(root.join(o));
            }
        }
    }
    let marker = root.join(ctx.ds.marker_rel(key));
    sweep_temps(&marker);
    let json = serde_json::to_vec_pretty(&rec).map_err(|e| fail(wst, e))?;
    if let Err(e) = AtomicFile::write_all(&marker, &json) {
        undo(&written);
        return Err(fail(wst, format!("{}: {e}", marker.display())));
    }
    Ok(rec)
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
    let results: Mutex<Vec<Option<DriveOutcome>>> = Mutex::new(vec![None; items.len()]);
    pool.scope(|s| {
        for _ in 0..in_flight {
            s.spawn(|_| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(item) = items.get(i) else {
                    break;
                };
                let o = process(&ctx, i, item);
                on_drive(&o);
                results.lock().unwrap_or_else(|p| p.into_inner())[i] = Some(o);
            });
        }
    });
    let drives: Vec<DriveOutcome> = results
        .into_inner()
        .unwrap_or_else(|p| p.into_inner())
        .into_iter()
        .map(|o| o.expect("every input processed"))
        .collect();
    let count = |s: DriveStatus| drives.iter().filter(|d| d.status == s).count();
    let shard = opts.shard.map(|s| (s.index, s.count));
    let report_dir = ctx.ds.report_dir(&plan.spec.name, shard);
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
        elapsed_s: t0.elapsed().as_secs_f64(),
        output_dir: opts.out_root.display().to_string(),
        report_dir: report_dir.display().to_string(),
        drives,
    };
    super::run_report::write_run_report(&report_dir, plan, &report)?;
    Ok(report)
}

/// Escaped file name of a drive's outputs (`<drive_id>.parquet`).
pub fn output_file_name(drive_id: &str) -> String {
    format!("{}.parquet", escape(drive_id))
}
