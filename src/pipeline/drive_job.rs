//! One drive of a run, from its input file to its done-marker: reuse of up-to-date outputs,
//! ingest, the analysis stages ([`super::drive_stages`]), the tables written
//! ([`super::drive_tables`]) and the marker that commits them.
//!
//! **Failures.** A drive that fails (bad file, a stage error, even a panic) is recorded with the
//! stage and the error, leaves no output, and the other drives go on. A stage that cannot serve a
//! drive (see [`super::spec`]: `missing = "skip"`) is skipped with its reason; the drive succeeds.
//!
//! **Idempotence.** See [`super::dataset`]: a drive whose done-marker matches its input's
//! content hash and its configuration hash is reused, not recomputed (unless `force`).

use super::dataset::{file_sha256, sweep_temps, utc_date, Dataset};
use super::drive_stages::{compute, fail, Computed, Fail};
use super::drive_tables::{
    base_meta, conformed, metrics_of, spectrum_columns, summary_columns, TableColumns,
};
use super::record::{DriveOutcome, DriveRecord, DriveStatus, StageNote};
use super::spec::Plan;
use super::spec_sections::{DatasetTable, PipelineStage};
use super::vehicles::LoadedVehicle;
use super::{resample_stage, slope_stage};
use crate::diagnose::parameter_table::parameter_columns;
use crate::ingest::BadSamples;
use crate::io::{
    config_hash, write_column_refs_with_constants, AtomicFile, ColumnRef, OutColumn, TableMeta,
};
use crate::report::axle_sim::{axle_sim_columns, AxleSimExtra, TimeAxis};
use crate::report::axle_validation::{axle_meta, axle_validation_columns};
use crate::report::diagnosis_files::write_outputs;
use crate::table::DriveLog;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

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
    plan.has(PipelineStage::Shuffle)
        || plan.has(PipelineStage::Axle)
        || plan.has(PipelineStage::Diagnose)
}

/// Checks the gear column against the vehicle's gearbox (known only once the drive names its
/// vehicle): a gear outside it is masked to missing and counted in `masked` with
/// [`BadSamples::Mask`] (the run of missing values then bounded by `max_nan_run_s`), an error with
/// [`BadSamples::Error`].
fn check_gears(
    log: &mut DriveLog,
    v: &LoadedVehicle,
    opts: &crate::ingest::IngestOptions,
    masked: &mut std::collections::BTreeMap<String, u64>,
) -> Result<(), String> {
    let source = log.meta.source_file.clone();
    let Some(g) = log.signal_mut("gear") else {
        return Ok(());
    };
    let (lo, hi) = v.file.gear_range();
    let mut n = 0;
    for (i, x) in g.iter_mut().enumerate() {
        if x.is_finite() && (*x < f64::from(lo) || *x > f64::from(hi)) {
            if opts.bad_samples == BadSamples::Error {
                return Err(format!(
                    "{source}: column gear row {i}: value {x} outside the gearbox of {} ({lo} … {hi})",
                    v.path
                ));
            }
            *x = f64::NAN;
            n += 1;
        }
    }
    if n > 0 {
        *masked.entry("gear".into()).or_default() += n;
        crate::ingest::check_nan_runs(
            std::path::Path::new(&source),
            &log.timestamp_ns,
            &log.signals,
            &[("gear", "ingest")],
            opts.max_nan_run_s,
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Shared state of a run.
pub(super) struct Ctx<'a> {
    pub(super) plan: &'a Plan,
    pub(super) ds: Dataset,
    pub(super) force: bool,
    pub(super) claims: Mutex<HashMap<String, usize>>,
}

pub(super) fn process(
    ctx: &Ctx<'_>,
    index: usize,
    item: &super::inputs::InputItem,
) -> DriveOutcome {
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
    let (mut log, mut ing_report) = (ing.log, ing.report);
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
                match &log.meta.vehicle_id {
                    Some(id) => format!(
                        "{input}: no vehicle file for vehicle_id {id} (pipeline [vehicles], vehicle_dir, vehicle)"
                    ),
                    None => format!(
                        "{input}: the drive names no vehicle_id and the pipeline has no default vehicle file (pipeline vehicle, or a manifest's vehicle_id)"
                    ),
                },
            ),
        ));
    }
    if let (Some(v), None) = (&vehicle, manifest_vehicle) {
        check_gears(&mut log, v, &opts, &mut ing_report.masked)
            .map_err(|e| (id.clone(), fail(ing_st, e)))?;
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
    let mut c = compute(plan, log, vehicle.as_deref()).map_err(|f| (id.clone(), f))?;
    c.0.masked = ing_report.masked;
    c.0.conflicts_resolved = ing_report.conflicts_resolved;
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
            DatasetTable::Mismatch | DatasetTable::Findings | DatasetTable::ParameterEstimates => {
                if let Some(d) = &c.diagnosis {
                    let diag = &crate::report::contract::assemble(d);
                    let mut m = meta(t.name());
                    m.extra = vec![("verdict".into(), diag.verdict.as_str().into())];
                    let cols = match t {
                        DatasetTable::Mismatch => diag.mismatch_columns(),
                        DatasetTable::Findings => diag.findings_columns(),
                        _ => parameter_columns(&d.parameters),
                    };
                    return Some((m, Built(cols)));
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
    // the drive's diagnosis report, before the tables (drive_summary stays the last file)
    if let (Some(d), Some(spec)) = (&c.diagnosis, &plan.diagnose) {
        if spec.reports {
            let rel = ctx.ds.diagnosis_rel(&vehicle_id, &rec.drive_id);
            match write_outputs(&root.join(&rel), d, log, hash) {
                Ok(w) => {
                    let mut files = vec![w.mismatch, w.findings, w.parameter_estimates, w.report];
                    files.extend(w.plots);
                    files.extend([w.detail, w.json]);
                    for f in files {
                        if let Ok(p) = f.strip_prefix(root) {
                            written.push(p.to_path_buf());
                        }
                    }
                }
                Err(e) => return Err(fail(wst, e)),
            }
        }
    }
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
